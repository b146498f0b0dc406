/* args.c — option table, value parsers and usage text shared by every `vis` command. */
#include "args.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "effects_spec.h"
#include "names.h"
#include "bench_traversal.h" /* CLI_TRAVERSAL_ALL */

typedef int (*opt_parse_fn)(const char *cmd, const char *opt, const char *value, int list, cli_args *a);

typedef struct opt_spec {
    const char *name;       /* "--res"                                                   */
    unsigned bit;
    const char *metavar;    /* NULL for flags without a value                            */
    const char *help;
    opt_parse_fn parse;
} opt_spec;

int cli_usage_error(const char *command, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fprintf(stderr, "vis %s: ", command);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    return CLI_EXIT_USAGE;
}

/* ---- value parsers ------------------------------------------------------------------- */

/* A decimal unsigned integer in [lo, hi], nothing else. */
static int parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    if (!s[0] || s[0] == '-' || s[0] == '+' || s[0] == ' ')
        return -1;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return -1;
    *out = v;
    return 0;
}

static int parse_u32_opt(const char *cmd, const char *opt, const char *value, uint32_t lo, uint32_t hi,
                         uint32_t *out)
{
    uint64_t v;
    if (parse_u64(value, lo, hi, &v) != 0)
        return cli_usage_error(cmd, "%s '%s': expected a whole number from %u to %u", opt, value, lo, hi);
    *out = (uint32_t)v;
    return CLI_EXIT_OK;
}

static int p_scene(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (!value[0])
        return cli_usage_error(cmd, "%s: empty scene spec", opt);
    a->scene = value;
    return CLI_EXIT_OK;
}

static int p_camera(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    double v[7];
    int n = 0;
    const char *p = value;
    char buf[64];
    for (;;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        if (n == 7 || len == 0 || len >= sizeof buf)
            return cli_usage_error(cmd, "%s '%s': expected EX,EY,EZ,TX,TY,TZ[,FOVY] (6 or 7 numbers)", opt, value);
        memcpy(buf, p, len);
        buf[len] = '\0';
        if (vc_parse_double(buf, &v[n]) != 0)
            return cli_usage_error(cmd, "%s: '%s' is not a finite number", opt, buf);
        ++n;
        if (!comma)
            break;
        p = comma + 1;
    }
    if (n < 6)
        return cli_usage_error(cmd, "%s '%s': expected EX,EY,EZ,TX,TY,TZ[,FOVY] (6 or 7 numbers), got %d", opt,
                               value, n);
    memset(&a->camera, 0, sizeof a->camera);
    for (int i = 0; i < 3; ++i) {
        a->camera.eye[i] = v[i];
        a->camera.target[i] = v[3 + i];
    }
    a->camera.fovy_deg = n == 7 ? v[6] : 60.0;
    if (!(a->camera.fovy_deg > 0.0 && a->camera.fovy_deg < 180.0))
        return cli_usage_error(cmd, "%s: field of view %g is outside (0, 180) degrees", opt, a->camera.fovy_deg);
    if (v[0] == v[3] && v[1] == v[4] && v[2] == v[5])
        return cli_usage_error(cmd, "%s: eye and target are the same point", opt);
    return CLI_EXIT_OK;
}

static int parse_wxh(const char *cmd, const char *opt, const char *value, uint32_t *out_w, uint32_t *out_h)
{
    const char *x = strchr(value, 'x');
    char w[32];
    uint64_t wv, hv;
    size_t len = x ? (size_t)(x - value) : 0;
    if (!x || len == 0 || len >= sizeof w)
        return cli_usage_error(cmd, "%s '%s': expected WxH, e.g. 512x512", opt, value);
    memcpy(w, value, len);
    w[len] = '\0';
    if (parse_u64(w, 1, VIS_MAX_RESOLUTION, &wv) != 0 || parse_u64(x + 1, 1, VIS_MAX_RESOLUTION, &hv) != 0)
        return cli_usage_error(cmd, "%s '%s': width and height must be whole numbers from 1 to %u", opt, value,
                               VIS_MAX_RESOLUTION);
    *out_w = (uint32_t)wv;
    *out_h = (uint32_t)hv;
    return CLI_EXIT_OK;
}

static int p_res(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_wxh(cmd, opt, value, &a->width, &a->height);
}

static int p_truth_res(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_wxh(cmd, opt, value, &a->truth_width, &a->truth_height);
}

static int p_supersample(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 1, 4, &a->supersample);
}

static int p_leaf_depth(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 1, 64, &a->leaf_depth);
}

static int p_max_res(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 64, VIS_MAX_RESOLUTION, &a->max_res);
}

static int p_method(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (strcmp(value, "ray") == 0)
        a->method = CLI_METHOD_RAY;
    else if (strcmp(value, "zbuf") == 0)
        a->method = CLI_METHOD_ZBUF;
    else
        return cli_usage_error(cmd, "%s '%s': expected ray or zbuf", opt, value);
    return CLI_EXIT_OK;
}

static int p_named(const char *cmd, const char *opt, const char *value, const vc_name_table *t, int *out)
{
    if (vc_name_lookup(t, value, out) == 0)
        return CLI_EXIT_OK;
    char names[256];
    vc_name_list(t, ", ", names, sizeof names);
    return cli_usage_error(cmd, "%s: unknown %s '%s' (known: %s)", opt, t->what, value, names);
}

static int p_ids(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    int v;
    int rc = p_named(cmd, opt, value, &vc_id_modes, &v);
    a->ids = (vis_id_mode)v;
    return rc;
}

static int p_traversal(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    int v;
    if (strcmp(value, "all") == 0 && strcmp(cmd, "bench") == 0) { /* bench_traversal.c: Tables 3, 4 */
        a->traversal = CLI_TRAVERSAL_ALL;
        return CLI_EXIT_OK;
    }
    int rc = p_named(cmd, opt, value, &vc_traversals, &v);
    a->traversal = (vis_traversal)v;
    return rc;
}

/* Splits a comma-separated list and calls `one` on each item. */
static int each_item(const char *cmd, const char *opt, const char *value, int list,
                     int (*one)(const char *cmd, const char *opt, const char *item, size_t index, cli_args *a),
                     cli_args *a, size_t *count)
{
    char item[64];
    size_t n = 0;
    const char *p = value;
    for (;;) {
        const char *comma = strchr(p, ',');
        size_t len = comma ? (size_t)(comma - p) : strlen(p);
        if (len == 0 || len >= sizeof item)
            return cli_usage_error(cmd, "%s '%s': empty or overlong item", opt, value);
        if (n == CLI_MAX_LIST)
            return cli_usage_error(cmd, "%s '%s': at most %d items", opt, value, CLI_MAX_LIST);
        if (n == 1 && !list)
            return cli_usage_error(cmd, "%s '%s': this command takes one value, not a list", opt, value);
        memcpy(item, p, len);
        item[len] = '\0';
        int rc = one(cmd, opt, item, n, a);
        if (rc != CLI_EXIT_OK)
            return rc;
        ++n;
        if (!comma)
            break;
        p = comma + 1;
    }
    *count = n;
    return CLI_EXIT_OK;
}

static int one_backend(const char *cmd, const char *opt, const char *item, size_t i, cli_args *a)
{
    int v;
    int rc = p_named(cmd, opt, item, &vc_backends, &v);
    a->backends[i] = (vis_backend_kind)v;
    return rc;
}

static int p_backend(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return each_item(cmd, opt, value, list, one_backend, a, &a->backend_count);
}

static int one_threads(const char *cmd, const char *opt, const char *item, size_t i, cli_args *a)
{
    if (strcmp(item, "all") == 0) {
        a->threads[i] = 0;
        return CLI_EXIT_OK;
    }
    return parse_u32_opt(cmd, opt, item, 1, 1024, &a->threads[i]);
}

static int p_threads(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return each_item(cmd, opt, value, list, one_threads, a, &a->thread_count);
}

static int p_repeat(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 1, 100000, &a->repeat);
}

static int p_frames(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 1, 100000, &a->frames);
}

static int p_edits(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 0, 10000000, &a->edits);
}

static int p_kd_depth(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return parse_u32_opt(cmd, opt, value, 0, 64, &a->kd_depth);
}

static int p_seed(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (parse_u64(value, 0, UINT64_MAX, &a->seed) != 0)
        return cli_usage_error(cmd, "%s '%s': expected a whole number", opt, value);
    return CLI_EXIT_OK;
}

static int p_path(const char *cmd, const char *opt, const char *value, const char **out)
{
    if (!value[0])
        return cli_usage_error(cmd, "%s: empty file name", opt);
    *out = value;
    return CLI_EXIT_OK;
}

static int p_dump_ids(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return p_path(cmd, opt, value, &a->dump_ids);
}
static int p_dump_depth(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return p_path(cmd, opt, value, &a->dump_depth);
}
static int p_dump_list(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return p_path(cmd, opt, value, &a->dump_list);
}
static int p_png(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return p_path(cmd, opt, value, &a->png);
}
static int p_out(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    return p_path(cmd, opt, value, &a->out);
}

static int p_compare(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (strcmp(value, "embree") != 0)
        return cli_usage_error(cmd, "%s '%s': the only comparison is 'embree'", opt, value);
    a->compare_embree = 1;
    return CLI_EXIT_OK;
}

/* A count or a size: N, N with a binary suffix K, M, G or T (optionally followed by "iB" or
 * "B": 4G = 4GiB = 2^32), or 2^N; at most 2^64 - 1. */
static int parse_amount(const char *s, uint64_t *out)
{
    uint64_t v;
    const char *caret = strchr(s, '^');
    if (caret) {
        if (caret - s != 1 || s[0] != '2' || parse_u64(caret + 1, 0, 63, &v) != 0)
            return -1;
        *out = (uint64_t)1 << v;
        return 0;
    }
    size_t n = strlen(s), k = 0;
    char digits[32];
    while (k < n && s[k] >= '0' && s[k] <= '9')
        k++;
    if (k == 0 || k >= sizeof digits)
        return -1;
    memcpy(digits, s, k);
    digits[k] = '\0';
    if (parse_u64(digits, 0, UINT64_MAX, &v) != 0)
        return -1;
    const char *suffix = s + k;
    int shift = 0;
    if (*suffix) {
        static const char units[] = "KMGT";
        const char *u = strchr(units, suffix[0] >= 'a' ? suffix[0] - 'a' + 'A' : suffix[0]);
        if (!u || !*u)
            return -1;
        shift = 10 * (int)(u - units + 1);
        suffix++;
        if (strcmp(suffix, "") != 0 && strcmp(suffix, "B") != 0 && strcmp(suffix, "iB") != 0)
            return -1;
    }
    if (shift && v > (UINT64_MAX >> shift))
        return -1;
    *out = v << shift;
    return 0;
}

static int p_max_bytes(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (parse_amount(value, &a->max_bytes) != 0)
        return cli_usage_error(cmd, "%s '%s': expected bytes, e.g. 512M, 4G, 2^31 (0: the default 2G)", opt, value);
    return CLI_EXIT_OK;
}

static int p_max_voxels(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    if (parse_amount(value, &a->max_voxels) != 0)
        return cli_usage_error(cmd, "%s '%s': expected a voxel count, e.g. 1000000, 256M, 2^30 (0: the default 2^30)",
                               opt, value);
    return CLI_EXIT_OK;
}

static int p_json(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    a->json = 1;
    return CLI_EXIT_OK;
}

/* --effects: the list parser shared with vis-viewer (effects_spec.h). */
static int p_effects(const char *cmd, const char *opt, const char *value, int list, cli_args *a)
{
    (void)list;
    vc_effects e;
    memset(&e, 0, sizeof e);
    char err[256];
    if (vc_effects_parse(value, &e, err, sizeof err) != 0)
        return cli_usage_error(cmd, "%s: %s", opt, err);
    a->effects = e.bits;
    memcpy(a->light, e.light, sizeof a->light);
    a->fog = e.fog;
    return CLI_EXIT_OK;
}

static const opt_spec options[] = {
    {"--scene", OPT_SCENE, "SPEC", "world: a .vox/.vdb file or a generator (default gen:default)", p_scene},
    {"--camera", OPT_CAMERA, "EX,EY,EZ,TX,TY,TZ[,FOVY]", "eye, look-at target, vertical fov in degrees (60)", p_camera},
    {"--res", OPT_RES, "WxH", "ID buffer size (default 512x512)", p_res},
    {"--method", OPT_METHOD, "ray|zbuf", "ray pass (default) or the software z-buffer culler", p_method},
    {"--ids", OPT_IDS, "object|leaf", "object IDs (default) or kd-leaf IDs", p_ids},
    {"--traversal", OPT_TRAVERSAL, "NAME", "kd-tree traversal: auto (default: packet on the CPU; on an OpenCL GPU dda for one view and for batches, stack for effects; stack on other OpenCL devices), packet, stack, bruteforce, restart, pushdown, shortstack[:N], ropes, ropes-shortstack[:N], cached-stack[:N], dda; bench: all", p_traversal},
    {"--backend", OPT_BACKEND, "auto|cpu|opencl", "backend (default auto)", p_backend},
    {"--threads", OPT_THREADS, "N|all", "CPU backend threads (default all cores)", p_threads},
    {"--repeat", OPT_REPEAT, "N", "passes to time; the median is reported", p_repeat},
    {"--frames", OPT_FRAMES, "N", "bench: passes per view (20); accuracy: views of the path (all)", p_frames},
    {"--edits", OPT_EDITS, "K", "random single-voxel edits to time (default 1000)", p_edits},
    {"--seed", OPT_SEED, "N", "seed of the random edits (default 1)", p_seed},
    {"--kd-depth", OPT_KD_DEPTH, "N", "fixed kd-tree depth (default: a leaf per chunk)", p_kd_depth},
    {"--dump-ids", OPT_DUMP_IDS, "FILE", "write W*H little-endian uint32 IDs", p_dump_ids},
    {"--dump-depth", OPT_DUMP_DEPTH, "FILE", "write W*H little-endian float32 depths (+inf: no hit)", p_dump_depth},
    {"--dump-list", OPT_DUMP_LIST, "FILE", "write the draw list, 'ID PIXELS' per line", p_dump_list},
    {"--png", OPT_PNG, "FILE", "write the ID buffer as a picture", p_png},
    {"--out", OPT_OUT, "PATH", "output: export's .obj or .vox file, accuracy's directory", p_out},
    {"--compare", OPT_COMPARE, "embree", "also trace the same rays with Embree", p_compare},
    {"--truth-res", OPT_TRUTH_RES, "WxH", "display the truth is traced at (default 1920x1080)", p_truth_res},
    {"--supersample", OPT_SUPERSAMPLE, "S", "truth samples per pixel side: 2 = 2x2 (default 1)", p_supersample},
    {"--max-res", OPT_MAX_RES, "N", "largest ray-pass rung: N*N rays (default 2048)", p_max_res},
    {"--leaf-depth", OPT_LEAF_DEPTH, "N", "kd depth for leaf IDs (default: 8 chunks per leaf)", p_leaf_depth},
    {"--effects", OPT_EFFECTS, "LIST", "see-through,reflect,shadows:DX,DY,DZ,fog:DIST (docs/effects.md)", p_effects},
    {"--json", OPT_JSON, NULL, "one JSON object on stdout", p_json},
    {"--max-bytes", OPT_MAX_BYTES, "N", "memory the world may take (default 2G; K/M/G/T suffixes, 2^N)", p_max_bytes},
    {"--max-voxels", OPT_MAX_VOXELS, "N", "voxels a load may write (default 2^30)", p_max_voxels},
};

/* The options a command takes: its own, and the budget wherever a scene is loaded. */
static unsigned accepted(const cli_command *cmd)
{
    return cmd->options | (cmd->options & OPT_SCENE ? OPT_MAX_BYTES | OPT_MAX_VOXELS : 0u);
}

#define OPTION_COUNT (sizeof options / sizeof options[0])

void cli_args_usage(const cli_command *cmd, void *fp)
{
    FILE *f = fp;
    fprintf(f, "usage: vis %s", cmd->name);
    for (size_t i = 0; i < OPTION_COUNT; ++i) {
        const opt_spec *o = &options[i];
        if (!(accepted(cmd) & o->bit))
            continue;
        int req = (cmd->required & o->bit) != 0;
        fprintf(f, " %s%s%s%s%s", req ? "" : "[", o->name, o->metavar ? " " : "", o->metavar ? o->metavar : "",
                req ? "" : "]");
    }
    fprintf(f, "\n%s\n\n", cmd->summary);
    for (size_t i = 0; i < OPTION_COUNT; ++i) {
        const opt_spec *o = &options[i];
        if (!(accepted(cmd) & o->bit))
            continue;
        char left[64];
        const char *metavar = o->metavar ? o->metavar : "";
        int list = (cmd->list_options & o->bit) != 0;
        snprintf(left, sizeof left, "%s %s%s", o->name, metavar, list ? ",..." : "");
        fprintf(f, "  %-34s %s\n", left, o->help);
    }
}

static void set_defaults(const cli_command *cmd, cli_args *a)
{
    memset(a, 0, sizeof *a);
    a->scene = "gen:default";
    a->width = 512;
    a->height = 512;
    a->method = CLI_METHOD_RAY;
    a->ids = VIS_IDS_OBJECT;
    a->traversal = VIS_TRAVERSAL_AUTO;
    a->backends[0] = VIS_BACKEND_AUTO;
    a->backend_count = 1;
    a->threads[0] = 0;
    a->thread_count = 1;
    if (cmd->list_options & OPT_THREADS) { /* lists of thread counts: 1 and all cores */
        a->threads[0] = 1;
        a->threads[1] = 0;
        a->thread_count = 2;
    }
    a->repeat = 1;
    a->frames = 20;
    a->edits = 1000;
    a->seed = 1;
    a->truth_width = 1920;
    a->truth_height = 1080;
    a->supersample = 1;
    a->max_res = 2048;
}

int cli_args_parse(const cli_command *cmd, int argc, char **argv, cli_args *out)
{
    set_defaults(cmd, out);
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            cli_args_usage(cmd, stdout);
            return -1;
        }
        if (strncmp(arg, "--", 2) != 0)
            return cli_usage_error(cmd->name, "unexpected argument '%s' (see vis %s --help)", arg, cmd->name);
        char name[64];
        const char *eq = strchr(arg, '=');
        size_t len = eq ? (size_t)(eq - arg) : strlen(arg);
        if (len >= sizeof name)
            return cli_usage_error(cmd->name, "unknown option '%s'", arg);
        memcpy(name, arg, len);
        name[len] = '\0';
        const opt_spec *o = NULL;
        for (size_t k = 0; k < OPTION_COUNT; ++k)
            if (strcmp(options[k].name, name) == 0)
                o = &options[k];
        if (!o || !(accepted(cmd) & o->bit))
            return cli_usage_error(cmd->name, "unknown option '%s' (see vis %s --help)", name, cmd->name);
        if (out->given & o->bit)
            return cli_usage_error(cmd->name, "%s given twice", name);
        const char *value = NULL;
        if (o->metavar) {
            if (eq)
                value = eq + 1;
            else if (i + 1 < argc)
                value = argv[++i];
            else
                return cli_usage_error(cmd->name, "%s needs a value (%s)", name, o->metavar);
        } else if (eq) {
            return cli_usage_error(cmd->name, "%s takes no value", name);
        }
        int rc = o->parse(cmd->name, name, value ? value : "", (cmd->list_options & o->bit) != 0, out);
        if (rc != CLI_EXIT_OK)
            return rc;
        out->given |= o->bit;
    }
    for (size_t k = 0; k < OPTION_COUNT; ++k) {
        if ((cmd->required & options[k].bit) && !(out->given & options[k].bit))
            return cli_usage_error(cmd->name, "%s %s is required", options[k].name,
                                   options[k].metavar ? options[k].metavar : "");
    }
    return CLI_EXIT_OK;
}
