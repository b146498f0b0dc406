/* bench_traversal.c — `vis bench --traversal all`: Chang & Ihm 2010, Tables 3 and 4, for
 * our scene. Table 3: each method's Mrays/s over the camera path (the median over the
 * views) per backend; Table 4: the rope bytes that ropes and ropes-shortstack:N read. */
#include "bench_traversal.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json.h"
#include "names.h"
#include "timer.h"

/* The rows of the paper's Tables 3 and 5 that we have: kd-restart with a short stack of 1-3
 * and 7, the local ("stack") and cached stack of 1-3 and 7, ropes with a short stack of 1-3;
 * and the cell-grid walk (dda), which the paper does not have. */
const char *const bench_traversal_methods[] = {
    "stack",          "restart",        "pushdown",       "shortstack:1",       "shortstack:2",
    "shortstack:3",   "shortstack:4",   "shortstack:7",   "cached-stack:1",     "cached-stack:2",
    "cached-stack:3", "cached-stack:7", "ropes",          "ropes-shortstack:1", "ropes-shortstack:2",
    "ropes-shortstack:3", "ropes-shortstack:4", "dda",
};
const size_t bench_traversal_method_count = sizeof bench_traversal_methods / sizeof bench_traversal_methods[0];

#define NMETHODS (sizeof bench_traversal_methods / sizeof bench_traversal_methods[0])

/* Table 4 rows: 0 = ropes, N = ropes-shortstack:N. */
static const uint32_t rope_rows[] = {0, 1, 2, 3, 4, 8};
#define NROPE (sizeof rope_rows / sizeof rope_rows[0])

typedef struct trav_cell {
    double view_ms[VC_MAX_VIEWS];
    double view_mrays[VC_MAX_VIEWS];
    double median_ms, median_mrays;
} trav_cell;

typedef struct trav_config {
    char backend[64];
    char device[128];
    uint32_t threads;
    double build_ms;
    trav_cell cell[NMETHODS];
} trav_config;

static int run_config(bench *b, cli_scene *s, trav_config *tc)
{
    const cli_args *a = b->a;
    vis_scene *scene = world_scene_scene(s->ws);
    if (!a->json) {
        printf("  %s (%s): ", s->backend.name, s->backend.device);
        fflush(stdout);
    }
    for (size_t m = 0; m < NMETHODS; ++m) {
        int value;
        if (vc_name_lookup(&vc_traversals, bench_traversal_methods[m], &value) != 0)
            return cli_fail(CMD, "internal: unknown traversal '%s'", bench_traversal_methods[m]);
        cli_args am = *a;
        am.traversal = (vis_traversal)value;
        vis_trace_desc desc = cli_trace_desc(&am);
        trav_cell *c = &tc->cell[m];
        double ms[VC_MAX_VIEWS], mr[VC_MAX_VIEWS];
        for (size_t v = 0; v < b->nviews; ++v) {
            cli_pass_times t;
            memset(&t, 0, sizeof t);
            if (cli_pass_run(s->ctx, scene, &b->views[v].camera, &desc, a->frames, b->ids, b->ids_cap, NULL, 0, &t) !=
                VIS_OK)
                return cli_fail_vis(CMD, s->ctx, bench_traversal_methods[m]);
            c->view_ms[v] = ms[v] = t.median_ms;
            c->view_mrays[v] = mr[v] = t.mrays_per_s;
        }
        c->median_ms = b->nviews ? vc_median(ms, b->nviews) : 0.0;
        c->median_mrays = b->nviews ? vc_median(mr, b->nviews) : 0.0;
        if (!a->json) {
            printf("%s%s", m ? " " : "", bench_traversal_methods[m]);
            fflush(stdout);
        }
    }
    if (!a->json) {
        printf("\n");
        fflush(stdout);
    }
    return CLI_EXIT_OK;
}

static double mb(uint64_t bytes) { return (double)bytes / (1024.0 * 1024.0); }

static uint64_t rope_used(const vis_scene_stats *stats, uint32_t n)
{
    return n <= VIS_MAX_SHORT_STACK ? stats->rope_bytes_used[n] : 0;
}

static void rope_name(uint32_t n, char *buf, size_t size)
{
    if (n == 0)
        snprintf(buf, size, "ropes");
    else
        snprintf(buf, size, "ropes-shortstack:%u", n);
}

static void print_tables(const bench *b, const trav_config *tc, size_t nc, const vis_scene_info *info,
                         const vis_scene_stats *stats)
{
    printf("\nTable 3: Mrays/s, median over the %zu views of the camera path (%ux%u, %u frames each)\n", b->nviews,
           b->a->width, b->a->height, b->a->frames);
    printf("  %-20s", "method");
    for (size_t c = 0; c < nc; ++c) {
        char head[48];
        if (strcmp(tc[c].backend, "cpu") == 0)
            snprintf(head, sizeof head, "cpu %ut", tc[c].threads);
        else
            snprintf(head, sizeof head, "%s", tc[c].backend);
        printf(" %12s %10s", head, "ms");
    }
    printf("\n");
    for (size_t m = 0; m < NMETHODS; ++m) {
        printf("  %-20s", bench_traversal_methods[m]);
        for (size_t c = 0; c < nc; ++c)
            printf(" %12.2f %10.3f", tc[c].cell[m].median_mrays, tc[c].cell[m].median_ms);
        printf("\n");
    }
    for (size_t c = 0; c < nc; ++c)
        printf("  %s: %s\n", tc[c].backend, tc[c].device);

    printf("\nTable 4: rope memory (kd depth %u, %u nodes, %u leaves; scene %.2f MB, ropes held %.2f MB)\n",
           info->kd_depth, info->nodes, info->leaves, mb(info->bytes), mb(stats->rope_bytes));
    printf("  %-20s %14s %10s %12s\n", "method", "bytes", "MB", "% of scene");
    for (size_t r = 0; r < NROPE; ++r) {
        char name[32];
        rope_name(rope_rows[r], name, sizeof name);
        uint64_t used = rope_used(stats, rope_rows[r]);
        printf("  %-20s %14llu %10.3f %11.2f%%\n", name, (unsigned long long)used, mb(used),
               info->bytes ? 100.0 * (double)used / (double)info->bytes : 0.0);
    }
}

static void print_json(const bench *b, const trav_config *tc, size_t nc, const vis_scene_info *info,
                       const vis_scene_stats *stats)
{
    const cli_args *a = b->a;
    json_writer w;
    json_init(&w, stdout);
    json_object_begin(&w, NULL);
    json_string(&w, "command", "bench");
    json_string(&w, "scene", a->scene);
    json_uint(&w, "width", a->width);
    json_uint(&w, "height", a->height);
    json_uint(&w, "frames", a->frames);
    json_string(&w, "traversal", "all");
    json_string(&w, "ids", vc_name_of(&vc_id_modes, (int)a->ids));
    json_uint(&w, "objects", info->objects);
    json_uint(&w, "quads", info->quads);
    json_number(&w, "load_ms", b->world.load_ms);
    json_array_begin(&w, "traversal_table"); /* one row per method */
    for (size_t m = 0; m < NMETHODS; ++m) {
        json_object_begin(&w, NULL);
        json_string(&w, "method", bench_traversal_methods[m]);
        json_array_begin(&w, "results"); /* one per backend */
        for (size_t c = 0; c < nc; ++c) {
            const trav_cell *cell = &tc[c].cell[m];
            json_object_begin(&w, NULL);
            json_string(&w, "backend", tc[c].backend);
            json_string(&w, "device", tc[c].device);
            json_uint(&w, "threads", tc[c].threads);
            json_number(&w, "build_ms", tc[c].build_ms);
            json_number(&w, "median_ms", cell->median_ms);
            json_number(&w, "mrays_per_s", cell->median_mrays);
            json_array_begin(&w, "views");
            for (size_t v = 0; v < b->nviews; ++v) {
                json_object_begin(&w, NULL);
                json_string(&w, "name", b->views[v].name);
                json_number(&w, "time_ms", cell->view_ms[v]);
                json_number(&w, "mrays_per_s", cell->view_mrays[v]);
                json_object_end(&w);
            }
            json_array_end(&w);
            json_object_end(&w);
        }
        json_array_end(&w);
        json_object_end(&w);
    }
    json_array_end(&w);
    json_object_begin(&w, "rope_memory");
    json_uint(&w, "kd_depth", info->kd_depth);
    json_uint(&w, "scene_bytes", info->bytes);
    json_uint(&w, "rope_bytes", stats->rope_bytes);
    json_array_begin(&w, "rows");
    for (size_t r = 0; r < NROPE; ++r) {
        char name[32];
        rope_name(rope_rows[r], name, sizeof name);
        uint64_t used = rope_used(stats, rope_rows[r]);
        json_object_begin(&w, NULL);
        json_string(&w, "method", name);
        json_uint(&w, "short_stack", rope_rows[r]);
        json_uint(&w, "bytes", used);
        json_number(&w, "mb", mb(used));
        json_number(&w, "share", info->bytes ? (double)used / (double)info->bytes : 0.0);
        json_object_end(&w);
    }
    json_array_end(&w);
    json_object_end(&w);
    json_object_end(&w);
}

int bench_traversal_all(bench *b, cli_progress *progress)
{
    const cli_args *a = b->a;
    trav_config *tc = calloc(CLI_MAX_LIST, sizeof *tc);
    if (!tc)
        return cli_fail(CMD, "out of memory");
    size_t nc = 0;
    int have_info = 0, rc = CLI_EXIT_OK;
    vis_scene_info info;
    vis_scene_stats stats;
    memset(&info, 0, sizeof info);
    memset(&stats, 0, sizeof stats);
    /* One thread count: the last of --threads (bench's default list ends with all cores). */
    uint32_t threads = a->thread_count ? a->threads[a->thread_count - 1] : 0;
    if (!a->json)
        printf("\ntraversal methods: %zu, backends: %zu\n", NMETHODS, a->backend_count);
    for (size_t bi = 0; bi < a->backend_count && rc == CLI_EXIT_OK; ++bi) {
        cli_scene s;
        int orc = cli_scene_open(CMD, &b->world, a->backends[bi], threads, a->kd_depth, progress, &s);
        if (orc != CLI_EXIT_OK) {
            if (a->backends[bi] == VIS_BACKEND_OPENCL) { /* no OpenCL here: the CPU rows still count */
                fprintf(stderr, "vis %s: skipping backend opencl (it did not start; see above)\n", CMD);
                continue;
            }
            rc = orc;
            break;
        }
        int dup = 0;
        for (size_t c = 0; c < nc; ++c)
            dup |= strcmp(tc[c].backend, s.backend.name) == 0 && strcmp(tc[c].device, s.backend.device) == 0;
        if (!dup) {
            trav_config *t = &tc[nc];
            snprintf(t->backend, sizeof t->backend, "%s", s.backend.name);
            snprintf(t->device, sizeof t->device, "%s", s.backend.device);
            t->threads = s.backend.threads;
            t->build_ms = s.build.total_ms;
            rc = run_config(b, &s, t);
            if (rc == CLI_EXIT_OK)
                ++nc;
            if (rc == CLI_EXIT_OK && !have_info) {
                if (vis_scene_get_info(world_scene_scene(s.ws), &info) != VIS_OK)
                    rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_info");
                else if (vis_scene_get_stats(world_scene_scene(s.ws), &stats) != VIS_OK)
                    rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_stats");
                else
                    have_info = 1;
            }
        }
        cli_scene_close(&s);
    }
    if (rc == CLI_EXIT_OK && nc == 0)
        rc = cli_fail(CMD, "no backend of --backend could start");
    if (rc == CLI_EXIT_OK) {
        if (a->json)
            print_json(b, tc, nc, &info, &stats);
        else
            print_tables(b, tc, nc, &info, &stats);
    }
    free(tc);
    return rc;
}
