/* cli.c — context, world and scene setup shared by the `vis` commands. */
#include "cli.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "out_file.h"
#include "timer.h"

int cli_fail(const char *cmd, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "vis %s: ", cmd);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return CLI_EXIT_FAILURE;
}

int cli_fail_vis(const char *cmd, const vis_context *ctx, const char *what)
{
    return cli_fail(cmd, "%s: %s", what, ctx ? vis_context_last_error(ctx) : "no context");
}

/* The library's log: a context that cannot be created cannot hold its last error, so the
 * reason only reaches the log callback. The context keeps the callback for its lifetime, so
 * the buffer lives as long as the program (the CLI is single-threaded). */
typedef struct create_log {
    char message[512];
} create_log;

static create_log last_log;

static void capture_log(vis_log_level level, const char *message, void *user)
{
    create_log *log = user;
    if (level >= VIS_LOG_WARNING)
        snprintf(log->message, sizeof log->message, "%s", message);
}

int cli_context_open(const char *cmd, vis_backend_kind backend, uint32_t threads, vis_context **out,
                     vis_backend_info *out_info)
{
    create_log *log = &last_log;
    log->message[0] = '\0';
    vis_context_desc desc;
    memset(&desc, 0, sizeof desc);
    desc.backend = backend;
    desc.threads = threads;
    desc.log = capture_log;
    desc.log_user = log;
    vis_context *ctx = NULL;
    vis_status s = vis_context_create(&desc, &ctx);
    if (s != VIS_OK) {
        const char *kind = backend == VIS_BACKEND_OPENCL ? "an OpenCL" : backend == VIS_BACKEND_CPU ? "a CPU" : "a";
        return cli_fail(cmd, "cannot create %s context: %s%s%s", kind, vis_status_string(s),
                        log->message[0] ? ": " : "", log->message);
    }
    if (out_info) {
        memset(out_info, 0, sizeof *out_info);
        if (vis_context_backend(ctx, out_info) != VIS_OK) {
            int rc = cli_fail_vis(cmd, ctx, "vis_context_backend");
            vis_context_destroy(ctx);
            return rc;
        }
    }
    *out = ctx;
    return CLI_EXIT_OK;
}

/* The budget of every load (--max-bytes, --max-voxels) and the threads that generate and
 * mesh worlds, set once by main after parsing; the CLI's own code is single-threaded. Zero
 * fields: the library's defaults. */
static vw_budget load_budget;
static uint32_t load_threads = 1;

void cli_world_set_budget(uint64_t max_bytes, uint64_t max_voxels)
{
    load_budget.max_bytes = max_bytes;
    load_budget.max_voxels = max_voxels;
}

void cli_world_set_threads(const uint32_t *threads, size_t count)
{
    /* The most any pass of the command uses; 0 ("all") is every online core. The world is
     * the same for any count, so this only changes how long loading takes. */
    uint32_t n = 1;
    for (size_t i = 0; i < count; ++i) {
        uint32_t t = threads[i];
        if (t == 0) {
            long cores = sysconf(_SC_NPROCESSORS_ONLN);
            t = cores > 0 ? (uint32_t)cores : 1;
        }
        if (t > n)
            n = t;
    }
    load_threads = n;
}

int cli_world_load(const char *cmd, const char *spec, cli_progress *p, cli_world *out)
{
    memset(out, 0, sizeof *out);
    vw_error err;
    err.message[0] = '\0';
    double t0 = vc_now_ms();
    vw_load_options opt;
    memset(&opt, 0, sizeof opt);
    opt.budget = load_budget;
    opt.threads = load_threads;
    opt.progress = p ? cli_progress_update : NULL;
    opt.progress_user = p;
    vw_status s = vw_world_load(spec, &opt, &out->world, &err);
    if (p)
        cli_progress_finish(p);
    out->load_ms = vc_now_ms() - t0;
    if (s != VW_OK) {
        out->world = NULL;
        fprintf(stderr, "vis %s: --scene %s: %s%s%s\n", cmd, spec, vw_status_string(s), err.message[0] ? ": " : "",
                err.message);
        return s == VW_ERROR_INVALID_ARGUMENT ? CLI_EXIT_USAGE : CLI_EXIT_FAILURE;
    }
    return CLI_EXIT_OK;
}

void cli_world_free(cli_world *w)
{
    vw_world_destroy(w->world);
    w->world = NULL;
}

int cli_scene_open(const char *cmd, const cli_world *w, vis_backend_kind backend, uint32_t threads,
                   uint32_t kd_depth, cli_progress *p, cli_scene *out)
{
    memset(out, 0, sizeof *out);
    int rc = cli_context_open(cmd, backend, threads, &out->ctx, &out->backend);
    if (rc != CLI_EXIT_OK)
        return rc;
    world_scene_options opt;
    memset(&opt, 0, sizeof opt);
    opt.kd_depth = kd_depth;
    opt.mesh_threads = load_threads;
    opt.progress = p ? cli_progress_update : NULL;
    opt.progress_user = p;
    vw_error err;
    err.message[0] = '\0';
    int r = world_scene_create(out->ctx, w->world, &opt, &out->ws, &out->build, &err);
    if (p)
        cli_progress_finish(p);
    if (r != 0) {
        cli_fail(cmd, "building the scene: %s", err.message);
        vis_context_destroy(out->ctx);
        out->ctx = NULL;
        /* A kd depth the library rejects is the user's argument. */
        return kd_depth ? CLI_EXIT_USAGE : CLI_EXIT_FAILURE;
    }
    return CLI_EXIT_OK;
}

void cli_scene_close(cli_scene *s)
{
    world_scene_destroy(s->ws);
    vis_context_destroy(s->ctx);
    s->ws = NULL;
    s->ctx = NULL;
}

int cli_camera_check(const char *cmd, vis_context *ctx, const vis_camera *camera)
{
    if (vis_camera_validate(ctx, camera) != VIS_OK) {
        fprintf(stderr, "vis %s: --camera: %s\n", cmd, vis_context_last_error(ctx));
        return CLI_EXIT_USAGE;
    }
    return CLI_EXIT_OK;
}

void cli_camera_format(const vis_camera *c, char *buf, size_t size)
{
    snprintf(buf, size, "%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g", c->eye[0], c->eye[1], c->eye[2], c->target[0],
             c->target[1], c->target[2], c->fovy_deg > 0.0 ? c->fovy_deg : 60.0);
}

int cli_write_file(const char *cmd, const char *path, const void *data, size_t size)
{
    char err[1024];
    if (vc_write_file(path, data, size, err, sizeof err) != 0)
        return cli_fail(cmd, "%s", err);
    return CLI_EXIT_OK;
}

int cli_ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    if (n < k)
        return 0;
    for (size_t i = 0; i < k; ++i) {
        char a = s[n - k + i], b = suffix[i];
        if (a >= 'A' && a <= 'Z')
            a = (char)(a - 'A' + 'a');
        if (b >= 'A' && b <= 'Z')
            b = (char)(b - 'A' + 'a');
        if (a != b)
            return 0;
    }
    return 1;
}
