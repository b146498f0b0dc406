/* cmd_query.c — `vis query`: replays JSON Lines ticks through vis_query_run (per viewer: the
 * visible chunks and entities), or simulates bots to make a replay; with --compare, measures
 * in the same run a SMAC-style and a Luanti-style check against a dense truth pass
 * (docs/server.md). Needs Jansson at configure time; without it the command says so. */
#define _POSIX_C_SOURCE 199309L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cli.h"
#include "commands.h"
#include "json.h"
#include "names.h"
#include "query_compare.h"
#include "query_replay.h"
#include "query_sim.h"

#define CMD "query"

static void usage(FILE *f)
{
    fprintf(f,
            "usage: vis query --scene SPEC --replay FILE [--out FILE] [--json] [options]\n"
            "       vis query --simulate PLAYERS --ticks N --scene SPEC --out FILE [--seed N] [--edit-every N]\n\n"
            "Replays a JSON Lines file of ticks (docs/server.md) through libvis's server queries: per tick\n"
            "and viewer, the visible chunk objects and entities. Writes one JSON line per tick to --out and\n"
            "a summary on stdout (one JSON object with --json).\n\n"
            "options:\n"
            "  --threads N          viewers in parallel (default 2)\n"
            "  --backend B          auto|cpu|opencl: where the chunk passes are traced (default auto:\n"
            "                       a GPU if OpenCL has one, else the CPU); entities always on the CPU\n"
            "  --max-viewers N      capacity, 1..4096 (default 256); --max-entities N, 1..65536 (default 1024)\n"
            "  --budget N           entity rays per tick, all viewers (default 0: no limit)\n"
            "  --viewer-budget N    entity rays per viewer per tick (default 0: no limit)\n"
            "  --pair-limit N       rays to prove one pair hidden (default 16)\n"
            "  --unsettled-ticks N  a pair the pair limit could not settle is reported and proven again\n"
            "                       N ticks later, or once it leaves its grown regions (default 1)\n"
            "  --margin X           voxels around eye regions and swept boxes (default 0)\n"
            "  --peek X             voxels per second a viewer may move beyond its velocity (default 0)\n"
            "  --hold N             ticks an entity stays sent after it was seen (default 0)\n"
            "  --slack X            voxels a proof reaches ahead along each velocity, kept while\n"
            "                       both stay inside (default 0.5; 0: re-prove on any move)\n"
            "  --solid on|off       let the proof use where the world's voxels are opaque, so that\n"
            "                       pairs on either side of a hill settle (default on)\n"
            "  --chunk-res N        chunk pass resolution per face (default 32)\n"
            "  --chunk-every N      re-trace a viewer's chunks every N ticks (default 32)\n"
            "  --chunk-range X      the chunk pass's far plane in voxels (default 0: unlimited)\n"
            "  --chunk-move X       re-trace a viewer's chunks when its eye moved X voxels (on any\n"
            "                       axis) since its last pass, instead of every --chunk-every ticks\n"
            "                       (default 0: the cadence, skipping passes whose camera is unchanged)\n"
            "  --chunk-traversal M  the chunk passes' traversal (default auto: the backend's, packets\n"
            "                       on the CPU; names as vis run's)\n"
            "  --chunk-face-budget N\n"
            "                       faces of chunk passes traced per tick (an all-around pass has\n"
            "                       6, one in view 1); the others wait, most urgent first, each\n"
            "                       traced from its viewer's eye when its turn comes (default 0:\n"
            "                       no limit)\n"
            "  --chunks view|around the chunk pass: the viewer's view, or all around (default around)\n"
            "  --compare            also run the SMAC-style and Luanti-style checks and a dense truth\n"
            "  --truth-res N        truth: N x N per cube face (default 256)\n"
            "  --truth-every N      truth (and Luanti chunks) every N ticks (default 16)\n"
            "  --luanti-range X     Luanti chunk range in voxels (default 192)\n"
            "  --tick-ms X          tick length when the replay's header has none (default 7.8125)\n");
}

#ifndef VIS_HAVE_JANSSON
int cmd_query(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    (void)usage;
    fprintf(stderr, "vis query: this build has no Jansson (the JSON reader replays need); install "
                    "libjansson-dev and configure again\n");
    return CLI_EXIT_USAGE;
}
#else

typedef struct qopts {
    const char *scene, *replay, *out;
    int json, compare, around, no_solid;
    uint32_t simulate, ticks, threads, max_viewers, max_entities, pair_limit, unsettled, hold, chunk_res, chunk_every;
    uint32_t truth_res, truth_every, edit_every, viewer_budget, chunk_face_budget;
    uint64_t budget, seed;
    double margin, peek, slack, chunk_range, chunk_move, luanti_range, tick_ms;
    int chunk_traversal;
    int backend; /* vis_backend_kind */
    int have_simulate;
} qopts;

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

static int parse_u64(const char *opt, const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end = NULL;
    errno = 0;
    if (!s || !*s || *s == '-') {
        fprintf(stderr, "vis query: %s needs a whole number from %llu to %llu\n", opt, (unsigned long long)lo,
                (unsigned long long)hi);
        return -1;
    }
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || v < lo || v > hi) {
        fprintf(stderr, "vis query: %s '%s': a whole number from %llu to %llu\n", opt, s, (unsigned long long)lo,
                (unsigned long long)hi);
        return -1;
    }
    *out = v;
    return 0;
}

static int parse_u32(const char *opt, const char *s, uint32_t lo, uint32_t hi, uint32_t *out)
{
    uint64_t v;
    if (parse_u64(opt, s, lo, hi, &v))
        return -1;
    *out = (uint32_t)v;
    return 0;
}

static int parse_dbl(const char *opt, const char *s, double lo, double hi, double *out)
{
    char *end = NULL;
    double v = s ? strtod(s, &end) : NAN;
    if (!s || !*s || *end || !isfinite(v) || v < lo || v > hi) {
        fprintf(stderr, "vis query: %s '%s': a number from %g to %g\n", opt, s ? s : "", lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

static int parse_args(int argc, char **argv, qopts *o)
{
    memset(o, 0, sizeof *o);
    o->scene = "gen:default";
    o->threads = 2;
    o->backend = VIS_BACKEND_AUTO;
    o->max_viewers = 256;
    o->max_entities = 1024;
    o->chunk_res = 32;
    o->chunk_every = 32;
    o->slack = 0.5;
    o->around = 1;
    o->truth_res = 256;
    o->truth_every = 16;
    o->luanti_range = 192.0;
    o->tick_ms = 7.8125;
    o->seed = 1;
    o->ticks = 256;
    o->edit_every = 64;
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        int rc = 0, takes = 1;
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return -1;
        } else if (!strcmp(a, "--json") || !strcmp(a, "--compare")) {
            takes = 0;
            if (a[2] == 'j')
                o->json = 1;
            else
                o->compare = 1;
        } else if (!v) {
            fprintf(stderr, "vis query: %s needs a value\n", a);
            return CLI_EXIT_USAGE;
        } else if (!strcmp(a, "--scene")) {
            o->scene = v;
        } else if (!strcmp(a, "--replay")) {
            o->replay = v;
        } else if (!strcmp(a, "--out")) {
            o->out = v;
        } else if (!strcmp(a, "--simulate")) {
            rc = parse_u32(a, v, 1, 4096, &o->simulate);
            o->have_simulate = 1;
        } else if (!strcmp(a, "--ticks")) {
            rc = parse_u32(a, v, 1, 10000000, &o->ticks);
        } else if (!strcmp(a, "--seed")) {
            rc = parse_u64(a, v, 0, UINT64_MAX, &o->seed);
        } else if (!strcmp(a, "--edit-every")) {
            rc = parse_u32(a, v, 0, 1000000, &o->edit_every);
        } else if (!strcmp(a, "--threads")) {
            rc = parse_u32(a, v, 1, 256, &o->threads);
        } else if (!strcmp(a, "--backend")) {
            if (!v || vc_name_lookup(&vc_backends, v, &o->backend))
                rc = (fprintf(stderr, "vis query: --backend '%s': auto, cpu or opencl\n", v ? v : ""), -1);
        } else if (!strcmp(a, "--max-viewers")) {
            rc = parse_u32(a, v, 1, VIS_QUERY_MAX_VIEWERS, &o->max_viewers);
        } else if (!strcmp(a, "--max-entities")) {
            rc = parse_u32(a, v, 1, VIS_QUERY_MAX_ENTITIES, &o->max_entities);
        } else if (!strcmp(a, "--budget")) {
            rc = parse_u64(a, v, 0, UINT64_MAX, &o->budget);
        } else if (!strcmp(a, "--viewer-budget")) {
            rc = parse_u32(a, v, 0, UINT32_MAX, &o->viewer_budget);
        } else if (!strcmp(a, "--pair-limit")) {
            rc = parse_u32(a, v, 1, 4096, &o->pair_limit);
        } else if (!strcmp(a, "--solid")) {
            if (!strcmp(v, "on") || !strcmp(v, "off"))
                o->no_solid = v[1] == 'f';
            else
                rc = (fprintf(stderr, "vis query: --solid '%s': on or off\n", v), -1);
        } else if (!strcmp(a, "--unsettled-ticks")) {
            rc = parse_u32(a, v, 1, 1024, &o->unsettled);
        } else if (!strcmp(a, "--hold")) {
            rc = parse_u32(a, v, 0, 1000000, &o->hold);
        } else if (!strcmp(a, "--chunk-res")) {
            rc = parse_u32(a, v, 1, VIS_QUERY_MAX_CHUNK_RES, &o->chunk_res);
        } else if (!strcmp(a, "--chunk-every")) {
            rc = parse_u32(a, v, 1, 1000000, &o->chunk_every);
        } else if (!strcmp(a, "--truth-res")) {
            rc = parse_u32(a, v, 16, 4096, &o->truth_res);
        } else if (!strcmp(a, "--truth-every")) {
            rc = parse_u32(a, v, 1, 1000000, &o->truth_every);
        } else if (!strcmp(a, "--margin")) {
            rc = parse_dbl(a, v, 0.0, 100.0, &o->margin);
        } else if (!strcmp(a, "--chunk-range")) {
            rc = parse_dbl(a, v, 0.0, 1e9, &o->chunk_range);
            if (!rc && o->chunk_range != 0.0 && o->chunk_range < 1.0) {
                fprintf(stderr, "vis query: --chunk-range '%s': 0 (unlimited) or at least 1 voxel\n", v);
                rc = -1;
            }
        } else if (!strcmp(a, "--chunk-face-budget")) {
            rc = parse_u32(a, v, 0, 6 * VIS_QUERY_MAX_VIEWERS, &o->chunk_face_budget);
        } else if (!strcmp(a, "--chunk-move")) {
            rc = parse_dbl(a, v, 0.0, 1e5, &o->chunk_move);
        } else if (!strcmp(a, "--chunk-traversal")) {
            /* The query has no short-stack depth of its own: "shortstack:N" is refused. */
            if (!v || vc_name_lookup(&vc_traversals, v, &o->chunk_traversal) ||
                vc_traversal_short_stack(o->chunk_traversal) != 0)
                rc = (fprintf(stderr, "vis query: --chunk-traversal '%s': a method name without :N\n", v ? v : ""), -1);
        } else if (!strcmp(a, "--slack")) {
            rc = parse_dbl(a, v, 0.0, 100.0, &o->slack);
        } else if (!strcmp(a, "--peek")) {
            rc = parse_dbl(a, v, 0.0, VIS_QUERY_MAX_SPEED, &o->peek);
        } else if (!strcmp(a, "--luanti-range")) {
            rc = parse_dbl(a, v, 1.0, 1e6, &o->luanti_range);
        } else if (!strcmp(a, "--tick-ms")) {
            rc = parse_dbl(a, v, 0.1, 10000.0, &o->tick_ms);
        } else if (!strcmp(a, "--chunks")) {
            if (v && !strcmp(v, "view"))
                o->around = 0;
            else if (v && !strcmp(v, "around"))
                o->around = 1;
            else
                rc = (fprintf(stderr, "vis query: --chunks '%s': view or around\n", v ? v : ""), -1);
        } else {
            fprintf(stderr, "vis query: unknown option '%s' (vis query --help)\n", a);
            return CLI_EXIT_USAGE;
        }
        if (rc)
            return CLI_EXIT_USAGE;
        i += takes;
    }
    if (o->have_simulate ? !o->out : !o->replay) {
        fprintf(stderr, "vis query: %s\n", o->have_simulate ? "--simulate needs --out FILE"
                                                           : "--replay FILE (or --simulate PLAYERS) is required");
        return CLI_EXIT_USAGE;
    }
    return CLI_EXIT_OK;
}

static int run_simulate(const qopts *o)
{
    cli_world world;
    int rc = cli_world_load(CMD, o->scene, NULL, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    /* Written to a temporary name and renamed at the end: a failure leaves no half replay. */
    char tmp[4096];
    if (snprintf(tmp, sizeof tmp, "%s.tmp", o->out) >= (int)sizeof tmp) {
        cli_world_free(&world);
        return cli_fail(CMD, "--out path too long");
    }
    FILE *f = fopen(tmp, "wb");
    if (!f) {
        cli_world_free(&world);
        return cli_fail(CMD, "cannot write '%s': %s", tmp, strerror(errno));
    }
    qs_options so = {o->simulate, o->ticks, o->seed, o->tick_ms, o->edit_every, o->scene};
    char err[512] = "";
    int r = qs_simulate(world.world, &so, f, err, sizeof err);
    if (fclose(f) != 0 && r == 0)
        r = -1, snprintf(err, sizeof err, "write error");
    cli_world_free(&world);
    if (r != 0 || rename(tmp, o->out) != 0) {
        remove(tmp);
        return cli_fail(CMD, "--simulate: %s", r ? err : strerror(errno));
    }
    if (o->json)
        printf("{\"replay\":\"%s\",\"players\":%u,\"ticks\":%u,\"seed\":%llu}\n", o->out, o->simulate, o->ticks,
               (unsigned long long)o->seed);
    else
        printf("wrote %s: %u players, %u ticks on %s (seed %llu)\n", o->out, o->simulate, o->ticks, o->scene,
               (unsigned long long)o->seed);
    return CLI_EXIT_OK;
}

/* ---- replay ---------------------------------------------------------------------------- */

/* Truth: a second scene with the chunks (kept in step through the chunk hook) plus the
 * entities as boxes. */
typedef struct truth_ctx {
    vis_scene *scene;
    qc_chunk *chunks;     /* by chunk index                                               */
    uint32_t chunk_count;
    const vw_world *world;
    int failed;
} truth_ctx;

static void mirror_chunk(uint32_t chunk_index, uint32_t object_id, const vw_mesh *mesh, void *user)
{
    truth_ctx *t = user;
    if (chunk_index >= t->chunk_count)
        return;
    vis_quad *q = mesh->count ? malloc(mesh->count * sizeof *q) : NULL;
    if (mesh->count && !q) {
        t->failed = 1;
        return;
    }
    uint32_t n = 0;
    if (mesh->count) {
        world_scene_convert_quads(mesh->quads, mesh->count, q);
        /* Players see through glass: the truth leaves see-through quads out. */
        for (size_t i = 0; i < mesh->count; ++i)
            if (!(q[i].flags & VIS_PRIM_SEE_THROUGH))
                q[n++] = q[i];
    }
    vis_mesh m = {q, n, NULL, 0};
    vis_status st = vis_scene_set_object(t->scene, object_id, &m);
    if (st != VIS_OK && !(st == VIS_ERROR_NOT_FOUND && !n))
        t->failed = 1;
    free(q);
    t->chunks[chunk_index].id = mesh->count ? object_id : 0;
}

typedef struct acc {
    double *ms;           /* per tick                                                    */
    uint32_t n, cap;
    uint64_t rays, sent, pairs, chunk_rays, chunks_sent, chunk_views;
    uint64_t fn, leaks, truly_hidden, truly_visible, chunk_fn, truth_chunks;
    double chunk_ms;      /* Luanti: its chunk checks, summed                            */
    uint64_t unchecked, held, cached, viewer_ticks, solid_tests;
} acc;

static int acc_push(acc *a, double ms)
{
    if (a->n == a->cap) {
        uint32_t cap = a->cap ? a->cap * 2 : 256;
        double *p = realloc(a->ms, cap * sizeof *p);
        if (!p)
            return -1;
        a->ms = p;
        a->cap = cap;
    }
    a->ms[a->n++] = ms;
    return 0;
}

static int cmp_dbl(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return a < b ? -1 : a > b;
}

/* Median, min, max, mean and 99th percentile (nearest rank) of the ticks' milliseconds: the
 * median alone hides passes that land on few ticks (--chunk-move), the mean does not. */
static void acc_ms(acc *a, double *med, double *mn, double *mx, double *mean, double *p99)
{
    *med = *mn = *mx = *mean = *p99 = 0.0;
    if (!a->n)
        return;
    qsort(a->ms, a->n, sizeof *a->ms, cmp_dbl);
    *med = a->n % 2 ? a->ms[a->n / 2] : 0.5 * (a->ms[a->n / 2 - 1] + a->ms[a->n / 2]);
    *mn = a->ms[0];
    *mx = a->ms[a->n - 1];
    double sum = 0.0;
    for (size_t i = 0; i < a->n; ++i)
        sum += a->ms[i];
    *mean = sum / (double)a->n;
    size_t rank = (size_t)ceil(0.99 * (double)a->n);
    *p99 = a->ms[rank ? rank - 1 : 0];
}

static int find_u32(const uint32_t *v, size_t n, uint32_t x)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t m = (lo + hi) / 2;
        if (v[m] < x)
            lo = m + 1;
        else
            hi = m;
    }
    return lo < n && v[lo] == x;
}

/* Chunk rays per viewer and check: libvis's passes run every --chunk-every ticks (counted
 * per viewer-tick), Luanti's checks on the truth ticks (counted per check). */
static double chunk_rays_per_view(const acc *a)
{
    if (a->viewer_ticks)
        return (double)a->chunk_rays / (double)a->viewer_ticks;
    return a->chunk_views ? (double)a->chunk_rays / (double)a->chunk_views : 0.0;
}

static void print_method(FILE *f, const char *name, acc *a, uint64_t ticks, uint64_t truth_ticks, int json, int chunks,
                         int first)
{
    double med, mn, mx, mean, p99;
    acc_ms(a, &med, &mn, &mx, &mean, &p99);
    double t = ticks ? (double)ticks : 1.0;
    double leak = a->truly_hidden ? (double)a->leaks / (double)a->truly_hidden : 0.0;
    if (json) {
        fprintf(f, "%s\"%s\":{\"ms_per_tick\":{\"median\":%.4f,\"min\":%.4f,\"max\":%.4f,\"mean\":%.4f,\"p99\":%.4f},"
                   "\"rays_per_tick\":%.1f,\"entities_sent_per_tick\":%.1f,\"pairs_per_tick\":%.1f",
                first ? "" : ",", name, med, mn, mx, mean, p99, (double)a->rays / t, (double)a->sent / t,
                (double)a->pairs / t);
        if (truth_ticks)
            fprintf(f, ",\"hidden_while_visible\":%llu,\"truly_visible\":%llu,\"leak_share\":%.4f",
                    (unsigned long long)a->fn, (unsigned long long)a->truly_visible, leak);
        if (chunks && a->chunk_views)
            fprintf(f, ",\"chunks_sent_per_viewer\":%.1f,\"chunk_rays_per_viewer\":%.1f,\"chunks_missed\":%llu,"
                       "\"truth_chunks\":%llu,\"chunk_ms_per_viewer\":%.4f",
                    (double)a->chunks_sent / (double)a->chunk_views, chunk_rays_per_view(a),
                    (unsigned long long)a->chunk_fn, (unsigned long long)a->truth_chunks,
                    a->chunk_ms / (double)a->chunk_views);
        if (a->viewer_ticks)
            fprintf(f, ",\"unchecked_per_tick\":%.2f,\"held_per_tick\":%.2f,\"cached_per_tick\":%.2f,"
                       "\"solid_tests_per_tick\":%.1f",
                    (double)a->unchecked / t, (double)a->held / t, (double)a->cached / t, (double)a->solid_tests / t);
        fprintf(f, "}");
        return;
    }
    fprintf(f, "  %-8s %7.3f ms/tick (min %.3f, max %.3f, mean %.3f, p99 %.3f)  %9.0f rays/tick  %8.1f of %.1f entities sent/tick",
            name, med, mn, mx, mean, p99, (double)a->rays / t, (double)a->sent / t, (double)a->pairs / t);
    if (truth_ticks)
        fprintf(f, "  hid %llu of %llu truly visible, leaked %.1f%% of hidden", (unsigned long long)a->fn,
                (unsigned long long)a->truly_visible, 100.0 * leak);
    fprintf(f, "\n");
    if (a->viewer_ticks)
        fprintf(f, "  %-8s pairs per tick: %.1f unchecked (budget or pair limit), %.1f held, %.1f from the cache; "
                   "%.1f solid-ground tests\n",
                "", (double)a->unchecked / t, (double)a->held / t, (double)a->cached / t, (double)a->solid_tests / t);
    if (chunks && a->chunk_views)
        fprintf(f, "  %-8s chunks: %.1f sent per viewer, %.0f rays per viewer, %llu of %llu truly visible missed%s",
                "", (double)a->chunks_sent / (double)a->chunk_views, chunk_rays_per_view(a),
                (unsigned long long)a->chunk_fn, (unsigned long long)a->truth_chunks, a->chunk_ms > 0.0 ? "" : "\n");
    if (chunks && a->chunk_views && a->chunk_ms > 0.0)
        fprintf(f, ", %.3f ms per viewer\n", a->chunk_ms / (double)a->chunk_views);
}

/* Entity `e` as a box object of the truth scene (clipped to the scene bounds). */
static vis_status truth_set_entity(vis_scene *scene, uint32_t id, const vis_query_entity *e, const int64_t wmin[3],
                                   const int32_t size[3])
{
    float lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        lo[k] = (float)(e->box_min[k] - (double)wmin[k]);
        hi[k] = (float)(e->box_max[k] - (double)wmin[k]);
        lo[k] = lo[k] < 0.0f ? 0.0f : lo[k] > (float)size[k] ? (float)size[k] : lo[k];
        hi[k] = hi[k] < lo[k] ? lo[k] : hi[k] > (float)size[k] ? (float)size[k] : hi[k];
    }
    vis_quad bq[6];
    for (int a = 0; a < 3; ++a)
        for (int side = 0; side < 2; ++side) {
            int u = (a + 1) % 3, v = (a + 2) % 3;
            vis_quad *qq = &bq[a * 2 + side];
            qq->axis = (uint32_t)a;
            qq->flags = 0;
            qq->plane = side ? hi[a] : lo[a];
            qq->u0 = lo[u];
            qq->u1 = hi[u];
            qq->v0 = lo[v];
            qq->v1 = hi[v];
        }
    vis_mesh m = {bq, 6, NULL, 0};
    return vis_scene_set_object(scene, id, &m);
}

static int run_replay(const qopts *o)
{
    cli_world world;
    int rc = cli_world_load(CMD, o->scene, NULL, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    cli_scene s;
    rc = cli_scene_open(CMD, &world, (vis_backend_kind)o->backend, o->threads, 0, NULL, &s);
    if (rc != CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }
    vis_scene *scene = world_scene_scene(s.ws);
    vw_world_info wi;
    vw_world_get_info(world.world, &wi);
    int64_t wmin[3], wmax[3];
    for (int k = 0; k < 3; ++k) {
        wmin[k] = wi.origin[k];
        wmax[k] = wi.origin[k] + wi.size[k];
    }
    char err[1024] = "";
    qr_reader *rd = NULL;
    vis_query *q = NULL;
    FILE *out = NULL;
    truth_ctx truth;
    memset(&truth, 0, sizeof truth);
    uint32_t *ids = NULL, *truth_ids = NULL, *chunk_buf = NULL, *truth_chunks = NULL, *smac_hold = NULL;
    vis_query_hit *hits = NULL;
    uint8_t *smac_vis = NULL, *luanti_vis = NULL, *luanti_sent = NULL, *truth_vis = NULL;
    acc ours, smac, luanti;
    memset(&ours, 0, sizeof ours);
    memset(&smac, 0, sizeof smac);
    memset(&luanti, 0, sizeof luanti);
    uint64_t ticks = 0, truth_ticks = 0, edit_passes = 0, deferred = 0;
    char tmp[4096] = "";

    rd = qr_open(o->replay, o->max_viewers, o->max_entities, wmin, wmax, err, sizeof err);
    if (!rd) {
        rc = cli_fail(CMD, "--replay: %s", err);
        goto done;
    }
    vis_query_desc qd;
    vis_query_desc_defaults(&qd);
    qd.max_viewers = o->max_viewers;
    qd.max_entities = o->max_entities;
    qd.chunk_res = o->chunk_res;
    qd.chunk_every = o->chunk_every;
    qd.margin = o->margin;
    qd.peek_speed = o->peek;
    qd.hold_ticks = o->hold;
    qd.ray_budget = o->budget;
    qd.viewer_ray_budget = o->viewer_budget;
    qd.pair_ray_limit = o->pair_limit;
    qd.unsettled_ticks = o->unsettled;
    qd.proof_slack = o->slack > 0.0 ? o->slack : -1.0; /* the library's 0 means its default */
    qd.chunk_range = o->chunk_range;
    qd.chunk_move = o->chunk_move;
    qd.chunk_face_budget = o->chunk_face_budget;
    qd.chunk_traversal = vc_traversal_method(o->chunk_traversal);
    qd.threads = o->threads;
    if (!o->no_solid) {
        qd.solid = world_scene_solid;
        qd.solid_user = s.ws;
    }
    if (vis_query_create(s.ctx, scene, &qd, &q) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_query_create");
        goto done;
    }
    size_t chunk_cap = (size_t)6 * o->chunk_res * o->chunk_res;
    hits = malloc((size_t)o->max_entities * sizeof *hits);
    chunk_buf = malloc(chunk_cap * sizeof *chunk_buf);
    if (!hits || !chunk_buf) {
        rc = cli_fail(CMD, "out of memory");
        goto done;
    }
    if (o->out) {
        if (snprintf(tmp, sizeof tmp, "%s.tmp", o->out) >= (int)sizeof tmp || !(out = fopen(tmp, "wb"))) {
            rc = cli_fail(CMD, "cannot write '%s'", o->out);
            goto done;
        }
    }
    uint32_t ent_base = wi.chunk_count + 1u;
    if (o->compare) {
        if (ent_base > VIS_MAX_OBJECT_ID - o->max_entities) {
            rc = cli_fail(CMD, "--compare: too many chunks to number the entities");
            goto done;
        }
        vis_scene_info si;
        vis_scene_get_info(scene, &si);
        vis_scene_desc sd;
        vis_scene_desc_defaults(&sd);
        memcpy(sd.origin, si.origin, sizeof sd.origin);
        memcpy(sd.size, si.size, sizeof sd.size);
        sd.cell_size = si.cell_size;
        sd.kd_depth = si.kd_depth;
        truth.chunk_count = wi.chunk_count;
        truth.chunks = calloc(wi.chunk_count ? wi.chunk_count : 1, sizeof *truth.chunks);
        size_t views = (size_t)o->max_viewers * o->max_entities;
        smac_hold = calloc(views, sizeof *smac_hold);
        smac_vis = calloc(views, 1);
        luanti_vis = calloc(views, 1);
        truth_vis = calloc(views, 1);
        luanti_sent = calloc(wi.chunk_count ? wi.chunk_count : 1, 1);
        truth_ids = malloc((size_t)o->truth_res * o->truth_res * sizeof *truth_ids);
        truth_chunks = calloc(wi.chunk_count ? wi.chunk_count : 1, sizeof *truth_chunks);
        if (!truth.chunks || !smac_hold || !smac_vis || !luanti_vis || !truth_vis || !luanti_sent || !truth_ids ||
            !truth_chunks) {
            rc = cli_fail(CMD, "out of memory for --compare");
            goto done;
        }
        for (uint32_t c = 0; c < wi.chunk_count; ++c) {
            int32_t cc[3];
            vw_world_chunk_coords(world.world, c, cc);
            for (int k = 0; k < 3; ++k) {
                truth.chunks[c].lo[k] = (double)wi.origin[k] + (double)cc[k] * wi.chunk_size;
                truth.chunks[c].hi[k] = truth.chunks[c].lo[k] + wi.chunk_size;
            }
        }
        if (vis_scene_create(s.ctx, &sd, &truth.scene) != VIS_OK) {
            rc = cli_fail_vis(CMD, s.ctx, "truth scene");
            goto done;
        }
        vw_error verr;
        if (world_scene_for_each_object(s.ws, mirror_chunk, &truth, &verr) != 0 || truth.failed) {
            rc = cli_fail(CMD, "truth scene: %s", truth.failed ? "could not copy a chunk" : verr.message);
            goto done;
        }
        world_scene_set_chunk_hook(s.ws, mirror_chunk, &truth);
    }
    double tick_ms = qr_get_header(rd)->tick_ms > 0.0 ? qr_get_header(rd)->tick_ms : o->tick_ms;
    uint32_t smac_hold_ticks = (uint32_t)ceil(750.0 / tick_ms);
    uint32_t prev_entities = 0;
    qr_tick t;
    int r;
    while ((r = qr_next(rd, &t, err, sizeof err)) == 1) {
        if (qr_get_header(rd)->tick_ms > 0.0)
            tick_ms = qr_get_header(rd)->tick_ms, smac_hold_ticks = (uint32_t)ceil(750.0 / tick_ms);
        if (t.edit_count) {
            for (uint32_t e = 0; e < t.edit_count; ++e)
                if (vw_world_set(world.world, t.edits[e].x, t.edits[e].y, t.edits[e].z, (vw_voxel)t.edits[e].value) !=
                    VW_OK) {
                    rc = cli_fail(CMD, "tick %llu: edit %u could not be applied", (unsigned long long)t.tick, e);
                    goto done;
                }
            vw_error verr;
            if (world_scene_update(s.ws, NULL, &verr) != 0 || truth.failed) {
                rc = cli_fail(CMD, "tick %llu: %s", (unsigned long long)t.tick,
                              truth.failed ? "truth scene edit failed" : verr.message);
                goto done;
            }
        }
        vis_query_viewer *vw = t.viewers;
        if (o->around) /* else the replay's dir and fov as given */
            for (uint32_t i = 0; i < t.viewer_count; ++i)
                vw[i].dir[0] = vw[i].dir[1] = vw[i].dir[2] = 0.0;
        vis_query_stats st;
        double t0 = now_ms();
        if (vis_query_run(q, vw, t.viewer_count, t.entities, t.entity_count, &st) != VIS_OK) {
            rc = cli_fail(CMD, "tick %llu: %s", (unsigned long long)t.tick, vis_context_last_error(s.ctx));
            rc = CLI_EXIT_FAILURE;
            goto done;
        }
        double ours_ms = now_ms() - t0;
        acc_push(&ours, ours_ms);
        ours.rays += st.entity_rays;
        ours.chunk_rays += st.chunk_rays;
        edit_passes += st.chunk_edit_passes;
        deferred += st.chunk_faces_deferred;
        ours.pairs += st.pairs;
        ours.unchecked += st.pairs_unchecked;
        ours.held += st.pairs_held;
        ours.cached += st.pairs_cached;
        ours.solid_tests += st.solid_tests;
        ours.viewer_ticks += t.viewer_count;
        ++ticks;
        int truth_now = o->compare && (ticks - 1) % o->truth_every == 0;
        if (o->compare) {
            double t1 = now_ms();
            smac.rays += qc_smac(scene, vw, t.viewer_count, t.entities, t.entity_count, tick_ms, smac_hold_ticks,
                                 1280, smac_hold, smac_vis);
            acc_push(&smac, now_ms() - t1);
            t1 = now_ms();
            luanti.rays += qc_luanti_entities(scene, vw, t.viewer_count, t.entities, t.entity_count, luanti_vis);
            acc_push(&luanti, now_ms() - t1);
            smac.pairs += st.pairs;
            luanti.pairs += st.pairs;
            for (size_t p = 0; p < (size_t)t.viewer_count * t.entity_count; ++p) {
                smac.sent += smac_vis[p];
                luanti.sent += luanti_vis[p];
            }
        }
        if (truth_now) {
            ++truth_ticks;
            /* Entities into the truth scene as boxes (IDs after the chunks). */
            for (uint32_t j = 0; j < t.entity_count; ++j)
                if (truth_set_entity(truth.scene, ent_base + j, &t.entities[j], wmin, wi.size) != VIS_OK) {
                    rc = cli_fail_vis(CMD, s.ctx, "truth entity");
                    goto done;
                }
            for (uint32_t j = t.entity_count; j < prev_entities; ++j)
                vis_scene_remove_object(truth.scene, ent_base + j);
            prev_entities = t.entity_count;
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = td.height = o->truth_res;
            size_t px = (size_t)o->truth_res * o->truth_res;
            for (uint32_t i = 0; i < t.viewer_count; ++i) {
                /* The viewer's own box would wrap its eye: out for its pass. */
                uint32_t self = UINT32_MAX;
                for (uint32_t j = 0; j < t.entity_count; ++j)
                    if (t.entities[j].id == vw[i].id)
                        self = j;
                if (self != UINT32_MAX)
                    vis_scene_remove_object(truth.scene, ent_base + self);
                uint8_t *tv = truth_vis + (size_t)i * t.entity_count;
                memset(tv, 0, t.entity_count);
                memset(truth_chunks, 0, wi.chunk_count * sizeof *truth_chunks);
                for (int f = 0; f < 6; ++f) {
                    vis_camera c;
                    memset(&c, 0, sizeof c);
                    memcpy(c.eye, vw[i].eye, sizeof c.eye);
                    memcpy(c.target, vw[i].eye, sizeof c.target);
                    c.target[f >> 1] += (f & 1) ? -1.0 : 1.0;
                    c.fovy_deg = 90.0;
                    if (vis_trace(s.ctx, truth.scene, &c, &td, truth_ids, px, NULL, 0) != VIS_OK) {
                        rc = cli_fail_vis(CMD, s.ctx, "truth pass");
                        goto done;
                    }
                    for (size_t p = 0; p < px; ++p) {
                        uint32_t id = truth_ids[p];
                        if (id >= ent_base && id < ent_base + t.entity_count)
                            tv[id - ent_base] = 1;
                        else if (id && id <= wi.chunk_count)
                            truth_chunks[id - 1] = 1;
                    }
                }
                if (self != UINT32_MAX &&
                    truth_set_entity(truth.scene, ent_base + self, &t.entities[self], wmin, wi.size) != VIS_OK) {
                    rc = cli_fail_vis(CMD, s.ctx, "truth entity");
                    goto done;
                }
                size_t nh = 0, nc = 0;
                vis_query_entities(q, i, hits, o->max_entities, &nh);
                vis_query_chunks(q, i, chunk_buf, chunk_cap, &nc);
                double t1 = now_ms();
                luanti.chunk_rays += qc_luanti_chunks(scene, vw[i].eye, truth.chunks, wi.chunk_count,
                                                      o->luanti_range, luanti_sent);
                luanti.chunk_ms += now_ms() - t1;
                ++luanti.chunk_views;
                ++ours.chunk_views;
                for (uint32_t c = 0; c < wi.chunk_count; ++c) {
                    luanti.chunks_sent += luanti_sent[c];
                    if (truth_chunks[c]) {
                        ++ours.truth_chunks;
                        ++luanti.truth_chunks;
                        if (!find_u32(chunk_buf, nc, c + 1))
                            ++ours.chunk_fn;
                        if (!luanti_sent[c])
                            ++luanti.chunk_fn;
                    }
                }
                ours.chunks_sent += nc;
                for (uint32_t j = 0; j < t.entity_count; ++j) {
                    if (j == self)
                        continue;
                    int in_ours = 0;
                    for (size_t h = 0; h < nh && !in_ours; ++h)
                        in_ours = hits[h].id == t.entities[j].id;
                    size_t p = (size_t)i * t.entity_count + j;
                    acc *m[3] = {&ours, &smac, &luanti};
                    int rep[3] = {in_ours, smac_vis[p], luanti_vis[p]};
                    for (int k = 0; k < 3; ++k) {
                        if (tv[j]) {
                            ++m[k]->truly_visible;
                            m[k]->fn += !rep[k];
                        } else {
                            ++m[k]->truly_hidden;
                            m[k]->leaks += rep[k] != 0;
                        }
                    }
                }
            }
        }
        /* Output line. */
        size_t sent = 0;
        if (out)
            fprintf(out,
                    "{\"tick\":%llu,\"ms\":%.4f,\"entity_rays\":%llu,\"chunk_rays\":%llu,\"chunk_passes\":%u,"
                    "\"chunk_edit_passes\":%u,\"chunk_faces_deferred\":%u,\"viewers\":[",
                    (unsigned long long)t.tick, ours_ms, (unsigned long long)st.entity_rays,
                    (unsigned long long)st.chunk_rays, st.chunk_passes, st.chunk_edit_passes,
                    st.chunk_faces_deferred);
        for (uint32_t i = 0; i < t.viewer_count; ++i) {
            size_t nh = 0, nc = 0;
            if (vis_query_entities(q, i, hits, o->max_entities, &nh) != VIS_OK ||
                vis_query_chunks(q, i, chunk_buf, chunk_cap, &nc) != VIS_OK) {
                rc = cli_fail_vis(CMD, s.ctx, "reading the results");
                goto done;
            }
            sent += nh;
            if (!out)
                continue;
            fprintf(out, "%s{\"id\":%u,\"entities\":[", i ? "," : "", vw[i].id);
            for (size_t h = 0; h < nh; ++h)
                fprintf(out, "%s%u", h ? "," : "", hits[h].id);
            fprintf(out, "],\"chunks\":[");
            for (size_t h = 0; h < nc; ++h)
                fprintf(out, "%s%u", h ? "," : "", chunk_buf[h]);
            fprintf(out, "]}");
        }
        ours.sent += sent;
        if (out)
            fprintf(out, "]}\n");
    }
    if (r < 0) {
        rc = cli_fail(CMD, "--replay %s: %s", o->replay, err);
        goto done;
    }
    /* Summary. */
    if (o->json) {
        printf("{\"scene\":");
        json_quoted(stdout, o->scene);
        printf(",\"replay\":");
        json_quoted(stdout, o->replay);
        printf(",\"ticks\":%llu,\"truth_ticks\":%llu,\"threads\":%u,\"chunks\":%u,", (unsigned long long)ticks,
               (unsigned long long)truth_ticks, o->threads, wi.nonempty_chunks);
        printf("\"backend\":\"%s\",\"device\":", s.backend.name);
        json_quoted(stdout, s.backend.device); /* a driver's name */
        printf(",");
        printf("\"chunk_rays_per_tick\":%.1f,", ticks ? (double)ours.chunk_rays / (double)ticks : 0.0);
        printf("\"chunk_edit_passes\":%llu,\"chunk_faces_deferred\":%llu,", (unsigned long long)edit_passes,
               (unsigned long long)deferred);
        print_method(stdout, "libvis", &ours, ticks, truth_ticks, 1, 1, 1);
        if (o->compare) {
            print_method(stdout, "smac", &smac, ticks, truth_ticks, 1, 0, 0);
            print_method(stdout, "luanti", &luanti, ticks, truth_ticks, 1, 1, 0);
        }
        printf("}\n");
    } else {
        printf("vis query: %s on %s, %llu ticks (%llu with truth at %ux%u x 6), %u threads, %u non-empty chunks\n",
               o->replay, o->scene, (unsigned long long)ticks, (unsigned long long)truth_ticks, o->truth_res,
               o->truth_res, o->threads, wi.nonempty_chunks);
        printf("  backend: %s (%s)\n", s.backend.name, s.backend.device);
        printf("  chunk passes: %.0f rays per tick, %llu viewer-ticks with faces traced because an "
               "edit reached them, %llu face-ticks waiting on --chunk-face-budget\n",
               ticks ? (double)ours.chunk_rays / (double)ticks : 0.0, (unsigned long long)edit_passes,
               (unsigned long long)deferred);
        print_method(stdout, "libvis", &ours, ticks, truth_ticks, 0, 1, 1);
        if (o->compare) {
            print_method(stdout, "smac", &smac, ticks, truth_ticks, 0, 0, 0);
            print_method(stdout, "luanti", &luanti, ticks, truth_ticks, 0, 1, 0);
        }
    }
    rc = CLI_EXIT_OK;
done:
    if (out) {
        int bad = fclose(out) != 0;
        if (rc == CLI_EXIT_OK && (bad || rename(tmp, o->out) != 0))
            rc = cli_fail(CMD, "cannot write '%s'", o->out);
        if (rc != CLI_EXIT_OK)
            remove(tmp);
    }
    if (s.ws)
        world_scene_set_chunk_hook(s.ws, NULL, NULL);
    vis_query_destroy(q);
    if (truth.scene)
        vis_scene_destroy(truth.scene);
    qr_close(rd);
    free(truth.chunks);
    free(ids);
    free(truth_ids);
    free(chunk_buf);
    free(truth_chunks);
    free(smac_hold);
    free(hits);
    free(smac_vis);
    free(luanti_vis);
    free(luanti_sent);
    free(truth_vis);
    free(ours.ms);
    free(smac.ms);
    free(luanti.ms);
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}

int cmd_query(int argc, char **argv)
{
    qopts o;
    int rc = parse_args(argc, argv, &o);
    if (rc < 0)
        return CLI_EXIT_OK;
    if (rc != CLI_EXIT_OK)
        return rc;
    return o.have_simulate ? run_simulate(&o) : run_replay(&o);
}
#endif
