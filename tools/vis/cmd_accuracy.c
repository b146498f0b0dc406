/*
 * cmd_accuracy.c — `vis accuracy`: what does accuracy cost in time?
 *
 * For each view of the camera path, the ground truth is the object-ID ray pass at display
 * resolution (optionally 2x2 supersampled). Against it, every method at every resolution —
 * the ray pass with object IDs, the ray pass with leaf IDs, the z-buffer culler — is timed
 * (median of --repeat passes) and its draw list compared (tools/common/accuracy.c): missed
 * objects and their screen area, overdraw and its triangles, hidden objects culled.
 * Buffers keep the display's aspect ratio (vc_accuracy_buffer_size): "512²" is 683x384 for
 * a 16:9 display, the same rays over the same view.
 *
 * With --effects (docs/effects.md) the truth and the object-ID passes are vis_trace_effects
 * with the same effects, and their draw lists hold every object seen directly, through
 * see-through layers, in reflections or as a shadow caster; each truth object's misses are
 * also counted per reason (vc_accuracy_reasons). Leaf IDs have no effects pass, so their
 * rows are left out; the z-buffer culler knows no effects, and its rows show what a culler
 * without them misses.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "accuracy.h"
#include "accuracy_report.h"
#include "camera_path.h"
#include "cli.h"
#include "commands.h"
#include "json.h"
#include "names.h"
#include "pass.h"
#include "timer.h"

#define CMD "accuracy"
#define ACC_DEFAULT_REPEAT 3
#define ACC_MIN_RES 64      /* the ray ladder: 64², 128², ... up to --max-res               */
#define ACC_LEAF_LEVELS 3   /* leaf IDs: 3 levels above the object scene's leaves (8 chunks) */
#define ACC_MAX_ROWS 32

enum { M_OBJECT = 0, M_LEAF, M_ZBUF };
static const char *const method_names[] = {"ray-object", "ray-leaf", "zbuf"};

/* The culler's resolutions (budgets; each traced at the display's aspect). */
static const uint32_t zbuf_budgets[][2] = {{256, 128}, {512, 512}, {1024, 1024}};

typedef struct plan_row {
    int method;
    uint32_t bw, bh;      /* budget                                                        */
    uint32_t w, h;        /* buffer traced                                                 */
    double *ms, *a_ms, *b_ms; /* per frame: median total, median parts                    */
    vc_accuracy *acc;     /* per frame                                                     */
} plan_row;

typedef struct study {
    const cli_args *a;
    uint32_t repeat;
    cli_world world;
    cli_scene obj;        /* truth, object IDs, the culler                                 */
    cli_scene leaf;       /* leaf IDs (its own kd depth)                                   */
    int own_leaf;         /* leaf is a second scene (else obj is used)                     */
    uint32_t kd_depth, leaf_depth;
    vis_scene_info info;
    vc_view views[VC_MAX_VIEWS];
    size_t nviews, frame[VC_MAX_VIEWS], nframes;
    plan_row rows[ACC_MAX_ROWS];
    size_t nrows;
    /* per object ID */
    uint32_t id_count;
    uint32_t *triangles;
    double *box;          /* 6 per ID: lo xyz, hi xyz                                       */
    uint8_t *has_box, *in_view;
    /* buffers */
    uint32_t *ids;
    size_t ids_cap;       /* elements of ids                                                */
    vis_draw_entry *truth, *list;
    size_t cap, truth_count;
    double *reps, *reps_a, *reps_b;
    vis_zcull *zc;
    double truth_ms[VC_MAX_VIEWS];
    uint32_t truth_visible[VC_MAX_VIEWS];
    /* --effects: the buffers of every effects pass (the largest size), and the draw lists
     * with reasons of the truth and of the last pass */
    cli_effect_buffers fx;
    vis_effect_entry *fx_truth, *fx_list;
    size_t fx_truth_count;
} study;

/* ---- setup ------------------------------------------------------------------------------ */

static void object_facts(uint32_t chunk, uint32_t id, const vw_mesh *mesh, void *user)
{
    study *st = user;
    if (id >= st->id_count || !mesh->count)
        return;
    vw_world_info wi;
    vw_world_get_info(st->world.world, &wi);
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (size_t i = 0; i < mesh->count; ++i) {
        const vw_quad *q = &mesh->quads[i];
        int ax = q->axis, u = (ax + 1) % 3, v = (ax + 2) % 3;
        double qlo[3], qhi[3];
        qlo[ax] = qhi[ax] = q->plane;
        qlo[u] = q->u0;
        qhi[u] = q->u1;
        qlo[v] = q->v0;
        qhi[v] = q->v1;
        for (int k = 0; k < 3; ++k) {
            if (qlo[k] < lo[k])
                lo[k] = qlo[k];
            if (qhi[k] > hi[k])
                hi[k] = qhi[k];
        }
    }
    for (int k = 0; k < 3; ++k) {
        st->box[6 * id + k] = (double)wi.origin[k] + lo[k];
        st->box[6 * id + 3 + k] = (double)wi.origin[k] + hi[k];
    }
    st->has_box[id] = 1;
    st->triangles[id] = (uint32_t)(2 * mesh->count);
}

static int add_row(study *st, int method, uint32_t bw, uint32_t bh)
{
    if (st->nrows == ACC_MAX_ROWS)
        return cli_fail(CMD, "too many rows");
    plan_row *r = &st->rows[st->nrows++];
    memset(r, 0, sizeof *r);
    r->method = method;
    r->bw = bw;
    r->bh = bh;
    vc_accuracy_buffer_size(bw, bh, st->a->truth_width, st->a->truth_height, &r->w, &r->h);
    r->ms = calloc(st->nframes, sizeof *r->ms);
    r->a_ms = calloc(st->nframes, sizeof *r->a_ms);
    r->b_ms = calloc(st->nframes, sizeof *r->b_ms);
    r->acc = calloc(st->nframes, sizeof *r->acc);
    if (!r->ms || !r->a_ms || !r->b_ms || !r->acc)
        return cli_fail(CMD, "out of memory");
    return CLI_EXIT_OK;
}

static int plan(study *st)
{
    const cli_args *a = st->a;
    int last_ray = a->effects ? M_OBJECT : M_LEAF; /* leaf IDs have no effects pass */
    for (int m = M_OBJECT; m <= last_ray; ++m)
        for (uint32_t e = ACC_MIN_RES; e <= a->max_res; e *= 2)
            if (add_row(st, m, e, e) != CLI_EXIT_OK)
                return CLI_EXIT_FAILURE;
    for (size_t i = 0; i < sizeof zbuf_budgets / sizeof zbuf_budgets[0]; ++i) {
        uint32_t bw = zbuf_budgets[i][0], bh = zbuf_budgets[i][1];
        if (i > 0 && bw > a->max_res) /* 256x128 always; the square ones within --max-res */
            continue;
        if (add_row(st, M_ZBUF, bw, bh) != CLI_EXIT_OK)
            return CLI_EXIT_FAILURE;
    }
    return CLI_EXIT_OK;
}

/* N views spread over the path: the middle of each of N equal stretches. */
static void pick_frames(study *st, uint32_t n)
{
    if (n > st->nviews)
        n = (uint32_t)st->nviews;
    st->nframes = n;
    for (uint32_t i = 0; i < n; ++i)
        st->frame[i] = (size_t)(((double)i + 0.5) * (double)st->nviews / (double)n);
}

static int setup(study *st, cli_progress *progress)
{
    const cli_args *a = st->a;
    int rc = cli_world_load(CMD, a->scene, progress, &st->world);
    if (rc != CLI_EXIT_OK)
        return rc;
    rc = cli_scene_open(CMD, &st->world, a->backends[0], a->threads[0], a->kd_depth, progress, &st->obj);
    if (rc != CLI_EXIT_OK)
        return rc;
    vis_scene *scene = world_scene_scene(st->obj.ws);
    if (vis_scene_get_info(scene, &st->info) != VIS_OK)
        return cli_fail_vis(CMD, st->obj.ctx, "vis_scene_get_info");
    st->kd_depth = st->info.kd_depth;
    st->leaf_depth = a->leaf_depth ? a->leaf_depth
                                   : (st->kd_depth > ACC_LEAF_LEVELS ? st->kd_depth - ACC_LEAF_LEVELS : 1);
    if (st->leaf_depth == st->kd_depth || a->effects) {
        st->leaf = st->obj;
    } else {
        rc = cli_scene_open(CMD, &st->world, a->backends[0], a->threads[0], st->leaf_depth, progress, &st->leaf);
        if (rc != CLI_EXIT_OK)
            return rc;
        st->own_leaf = 1;
    }
    st->id_count = st->info.max_id + 1;
    st->triangles = calloc(st->id_count, sizeof *st->triangles);
    st->box = calloc((size_t)st->id_count * 6, sizeof *st->box);
    st->has_box = calloc(st->id_count, 1);
    st->in_view = calloc(st->id_count, 1);
    if (!st->triangles || !st->box || !st->has_box || !st->in_view)
        return cli_fail(CMD, "out of memory");
    vw_error err;
    err.message[0] = '\0';
    if (world_scene_for_each_object(st->obj.ws, object_facts, st, &err) != 0)
        return cli_fail(CMD, "meshing: %s", err.message);

    st->nviews = vc_camera_path(st->world.world, st->views, VC_MAX_VIEWS);
    pick_frames(st, (a->given & OPT_FRAMES) ? a->frames : (uint32_t)st->nviews);
    if ((rc = plan(st)) != CLI_EXIT_OK)
        return rc;

    size_t n = (size_t)a->truth_width * a->supersample * a->truth_height * a->supersample;
    for (size_t i = 0; i < st->nrows; ++i)
        if ((size_t)st->rows[i].w * st->rows[i].h > n)
            n = (size_t)st->rows[i].w * st->rows[i].h;
    st->cap = vis_drawlist_bound(scene);
    if (st->cap == 0)
        st->cap = 1;
    st->ids = malloc(n * sizeof *st->ids);
    st->ids_cap = n;
    st->truth = malloc(st->cap * sizeof *st->truth);
    st->list = malloc(st->cap * sizeof *st->list);
    st->reps = malloc(st->repeat * sizeof *st->reps);
    st->reps_a = malloc(st->repeat * sizeof *st->reps_a);
    st->reps_b = malloc(st->repeat * sizeof *st->reps_b);
    if (!st->ids || !st->truth || !st->list || !st->reps || !st->reps_a || !st->reps_b)
        return cli_fail(CMD, "out of memory for a %zu-pixel buffer", n);
    if (a->effects) {
        st->fx_truth = malloc(st->cap * sizeof *st->fx_truth);
        st->fx_list = malloc(st->cap * sizeof *st->fx_list);
        if (n > UINT32_MAX || cli_effect_buffers_alloc(&st->fx, (uint32_t)n, 1) != 0 || !st->fx_truth ||
            !st->fx_list)
            return cli_fail(CMD, "out of memory for a %zu-pixel pass with effects", n);
    }
    if (vis_zcull_create(st->obj.ctx, &st->zc) != VIS_OK)
        return cli_fail_vis(CMD, st->obj.ctx, "vis_zcull_create");
    return CLI_EXIT_OK;
}

static void teardown(study *st)
{
    vis_zcull_destroy(st->zc);
    for (size_t i = 0; i < st->nrows; ++i) {
        free(st->rows[i].ms);
        free(st->rows[i].a_ms);
        free(st->rows[i].b_ms);
        free(st->rows[i].acc);
    }
    free(st->triangles);
    free(st->box);
    free(st->has_box);
    free(st->in_view);
    free(st->ids);
    free(st->truth);
    free(st->list);
    free(st->reps);
    free(st->reps_a);
    free(st->reps_b);
    cli_effect_buffers_free(&st->fx);
    free(st->fx_truth);
    free(st->fx_list);
    if (st->own_leaf)
        cli_scene_close(&st->leaf);
    if (st->obj.ctx)
        cli_scene_close(&st->obj);
    if (st->world.world)
        cli_world_free(&st->world);
}

/* ---- one frame --------------------------------------------------------------------------- */

/* One vis_trace_effects pass of desc on st->fx, then its draw list with reasons in fx (cap
 * st->cap) and, for vc_accuracy_compare, the same objects in plain with pixels = the sum of
 * their pixels over the reasons (an object seen only in a reflection is visible too).
 * *trace_ms and *list_ms get the parts' times. */
static int effects_pass(study *st, const cli_scene *s, const vis_camera *cam, const vis_trace_desc *d,
                        vis_effect_entry *fx, vis_draw_entry *plain, size_t *count, double *trace_ms, double *list_ms)
{
    vis_scene *scene = world_scene_scene(s->ws);
    double t0 = vc_now_ms();
    if (vis_trace_effects(s->ctx, scene, cam, d, &st->fx.b) != VIS_OK)
        return cli_fail_vis(CMD, s->ctx, "vis_trace_effects");
    double t1 = vc_now_ms();
    vis_effect_buffers lb = st->fx.b; /* the list reads the buffers of the effects that ran */
    if (!(d->effects & VIS_EFFECT_SEE_THROUGH))
        lb.see_through = NULL;
    if (!(d->effects & VIS_EFFECT_REFLECT))
        lb.reflection = NULL;
    if (!(d->effects & VIS_EFFECT_SHADOWS))
        lb.shadow = NULL;
    if (vis_drawlist_build_effects(s->ctx, scene, &lb, d->width, d->height, VC_SEE_THROUGH_LAYERS, fx, st->cap,
                                   count) != VIS_OK)
        return cli_fail_vis(CMD, s->ctx, "vis_drawlist_build_effects");
    for (size_t i = 0; i < *count; ++i) {
        uint32_t px = 0;
        for (int k = 0; k < VIS_REASON_COUNT; ++k)
            px += fx[i].pixels[k];
        plain[i].id = fx[i].id;
        plain[i].pixels = px ? px : 1; /* never 0: a listed object is visible */
    }
    *trace_ms = t1 - t0;
    *list_ms = vc_now_ms() - t1;
    return CLI_EXIT_OK;
}

static int truth_pass(study *st, size_t f, const vis_camera *cam)
{
    const cli_args *a = st->a;
    vis_trace_desc d = cli_trace_desc(a);
    d.width = a->truth_width * a->supersample;
    d.height = a->truth_height * a->supersample;
    d.ids = VIS_IDS_OBJECT;
    vis_context *ctx = st->obj.ctx;
    vis_scene *scene = world_scene_scene(st->obj.ws);
    if (a->effects) {
        double tt, tl;
        int rc = effects_pass(st, &st->obj, cam, &d, st->fx_truth, st->truth, &st->fx_truth_count, &tt, &tl);
        if (rc != CLI_EXIT_OK)
            return rc;
        st->truth_count = st->fx_truth_count;
        st->truth_ms[f] = tt;
    } else {
        double t0 = vc_now_ms();
        if (vis_trace(ctx, scene, cam, &d, st->ids, st->ids_cap, NULL, 0) != VIS_OK)
            return cli_fail_vis(CMD, ctx, "vis_trace (truth)");
        st->truth_ms[f] = vc_now_ms() - t0;
    }
    if (!a->effects && vis_drawlist_build(ctx, scene, st->ids, d.width, d.height, VIS_IDS_OBJECT, st->truth, st->cap,
                           &st->truth_count) != VIS_OK)
        return cli_fail_vis(CMD, ctx, "vis_drawlist_build (truth)");
    st->truth_visible[f] = (uint32_t)st->truth_count;
    for (uint32_t id = 0; id < st->id_count; ++id)
        st->in_view[id] = st->has_box[id] &&
                          vc_box_in_view(cam, a->truth_width, a->truth_height, &st->box[6 * id], &st->box[6 * id + 3]);
    return CLI_EXIT_OK;
}

/* `repeat` timed passes of one row; its draw list (of the last pass) in st->list. */
static int row_pass(study *st, plan_row *r, size_t f, const vis_camera *cam, size_t *count)
{
    uint32_t n = st->repeat;
    if (r->method == M_ZBUF) {
        vis_zcull_desc zd;
        vis_zcull_desc_defaults(&zd);
        zd.width = r->w;
        zd.height = r->h;
        vis_scene *scene = world_scene_scene(st->obj.ws);
        vis_zcull_stats zs;
        /* The first frame's warm-up grows the culler's buffers; timed runs allocate nothing. */
        if (f == 0 && vis_zcull_run(st->zc, scene, cam, &zd, st->list, st->cap, count, NULL) != VIS_OK)
            return cli_fail_vis(CMD, st->obj.ctx, "vis_zcull_run");
        for (uint32_t i = 0; i < n; ++i) {
            double t0 = vc_now_ms();
            if (vis_zcull_run(st->zc, scene, cam, &zd, st->list, st->cap, count, &zs) != VIS_OK)
                return cli_fail_vis(CMD, st->obj.ctx, "vis_zcull_run");
            st->reps[i] = vc_now_ms() - t0;
            st->reps_a[i] = zs.ms_raster;
            st->reps_b[i] = zs.ms_test;
        }
    } else {
        const cli_scene *s = r->method == M_LEAF ? &st->leaf : &st->obj;
        vis_trace_desc d = cli_trace_desc(st->a);
        d.width = r->w;
        d.height = r->h;
        d.ids = r->method == M_LEAF ? VIS_IDS_LEAF : VIS_IDS_OBJECT;
        vis_scene *scene = world_scene_scene(s->ws);
        /* The game's cost of a draw list: the pass and turning its IDs into the list. */
        for (uint32_t i = 0; i < n && st->a->effects; ++i) {
            int rc = effects_pass(st, s, cam, &d, st->fx_list, st->list, count, &st->reps_a[i], &st->reps_b[i]);
            if (rc != CLI_EXIT_OK)
                return rc;
            st->reps[i] = st->reps_a[i] + st->reps_b[i];
        }
        for (uint32_t i = 0; i < n && !st->a->effects; ++i) {
            double t0 = vc_now_ms();
            if (vis_trace(s->ctx, scene, cam, &d, st->ids, st->ids_cap, NULL, 0) != VIS_OK)
                return cli_fail_vis(CMD, s->ctx, "vis_trace");
            double t1 = vc_now_ms();
            if (vis_drawlist_build(s->ctx, scene, st->ids, d.width, d.height, d.ids, st->list, st->cap, count) !=
                VIS_OK)
                return cli_fail_vis(CMD, s->ctx, "vis_drawlist_build");
            double t2 = vc_now_ms();
            st->reps[i] = t2 - t0;
            st->reps_a[i] = t1 - t0;
            st->reps_b[i] = t2 - t1;
        }
    }
    r->ms[f] = vc_median(st->reps, n);
    r->a_ms[f] = vc_median(st->reps_a, n);
    r->b_ms[f] = vc_median(st->reps_b, n);
    return CLI_EXIT_OK;
}

static int run_frames(study *st)
{
    const cli_args *a = st->a;
    uint64_t samples = (uint64_t)a->truth_width * a->supersample * a->truth_height * a->supersample;
    vc_accuracy_objects objects = {st->triangles, st->in_view, st->id_count};
    /* The leaf scene's first pass is not timed (it would include any first-use cost). */
    if (st->own_leaf) {
        vis_trace_desc d = cli_trace_desc(a);
        d.width = d.height = ACC_MIN_RES;
        d.ids = VIS_IDS_LEAF;
        if (vis_trace(st->leaf.ctx, world_scene_scene(st->leaf.ws), &st->views[st->frame[0]].camera, &d, st->ids,
                      st->ids_cap, NULL, 0) != VIS_OK)
            return cli_fail_vis(CMD, st->leaf.ctx, "vis_trace (leaf warm-up)");
    }
    for (size_t f = 0; f < st->nframes; ++f) {
        const vc_view *v = &st->views[st->frame[f]];
        double t0 = vc_now_ms();
        int rc = truth_pass(st, f, &v->camera);
        if (rc != CLI_EXIT_OK)
            return rc;
        for (size_t i = 0; i < st->nrows; ++i) {
            plan_row *r = &st->rows[i];
            size_t count = 0;
            if ((rc = row_pass(st, r, f, &v->camera, &count)) != CLI_EXIT_OK)
                return rc;
            if (vc_accuracy_compare(st->truth, st->truth_count, samples, st->list, count, &objects, &r->acc[f]) != 0)
                return cli_fail(CMD, "%s: a draw list is not sorted by ID", v->name);
            if (a->effects && vc_accuracy_reasons(st->fx_truth, st->fx_truth_count, st->list, count,
                                                  r->acc[f].reason_truth, r->acc[f].reason_missed) != 0)
                return cli_fail(CMD, "%s: a draw list is not sorted by ID", v->name);
        }
        fprintf(stderr, "vis accuracy: view %zu/%zu %-9s truth %u objects (%.0f ms), %zu rows x %u passes in %.1f s\n",
                f + 1, st->nframes, v->name, st->truth_visible[f], st->truth_ms[f], st->nrows, st->repeat,
                (vc_now_ms() - t0) / 1e3);
    }
    return CLI_EXIT_OK;
}

/* ---- results ------------------------------------------------------------------------------ */

static void summarize(study *st, acc_row *out)
{
    for (size_t i = 0; i < st->nrows; ++i) {
        plan_row *r = &st->rows[i];
        acc_row *o = &out[i];
        memset(o, 0, sizeof *o);
        o->method = method_names[r->method];
        o->budget_w = r->bw;
        o->budget_h = r->bh;
        o->width = r->w;
        o->height = r->h;
        vc_accuracy_summarize(r->acc, st->nframes, &o->s);
        /* vc_median sorts in place: the per-frame arrays are not needed in order afterwards. */
        o->time_ms = vc_median(r->ms, st->nframes);
        o->part_a_ms = vc_median(r->a_ms, st->nframes);
        o->part_b_ms = vc_median(r->b_ms, st->nframes);
    }
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

static void print_json(const study *st, const acc_row *rows, const char *csv, const char *png, const char *plot_note,
                       double truth_ms, double truth_visible)
{
    const cli_args *a = st->a;
    json_writer w;
    json_init(&w, stdout);
    json_object_begin(&w, NULL);
    json_string(&w, "command", "accuracy");
    json_string(&w, "scene", a->scene);
    json_string(&w, "backend", st->obj.backend.name);
    json_string(&w, "device", st->obj.backend.device);
    json_uint(&w, "threads", st->obj.backend.threads);
    json_uint(&w, "objects", st->info.objects);
    json_uint(&w, "kd_depth", st->kd_depth);
    json_uint(&w, "leaf_kd_depth", st->leaf_depth);
    json_uint(&w, "repeat", st->repeat);
    if (a->effects) {
        char names[128];
        vc_effects_format(a->effects, names, sizeof names);
        json_string(&w, "effects", names);
    } else {
        json_string(&w, "effects", NULL);
    }
    json_object_begin(&w, "truth");
    json_uint(&w, "width", a->truth_width);
    json_uint(&w, "height", a->truth_height);
    json_uint(&w, "supersample", a->supersample);
    json_uint(&w, "samples", (uint64_t)a->truth_width * a->supersample * a->truth_height * a->supersample);
    json_number(&w, "visible", truth_visible);
    json_number(&w, "time_ms", truth_ms);
    json_object_end(&w);
    json_array_begin(&w, "views");
    for (size_t f = 0; f < st->nframes; ++f)
        json_string(&w, NULL, st->views[st->frame[f]].name);
    json_array_end(&w);
    json_array_begin(&w, "rows");
    for (size_t i = 0; i < st->nrows; ++i) {
        const acc_row *r = &rows[i];
        int zbuf = strcmp(r->method, "zbuf") == 0;
        json_object_begin(&w, NULL);
        json_string(&w, "method", r->method);
        json_uint(&w, "width", r->width);
        json_uint(&w, "height", r->height);
        char budget[32];
        snprintf(budget, sizeof budget, "%ux%u", r->budget_w, r->budget_h);
        json_string(&w, "budget", budget);
        json_uint(&w, "rays", (uint64_t)r->width * r->height);
        json_number(&w, "time_ms", r->time_ms);
        json_number(&w, zbuf ? "raster_ms" : "trace_ms", r->part_a_ms);
        json_number(&w, zbuf ? "test_ms" : "list_ms", r->part_b_ms);
        json_number(&w, "truth_visible", r->s.truth_visible);
        json_number(&w, "drawn", r->s.drawn);
        json_number(&w, "missed", r->s.missed);
        json_number(&w, "missed_area", r->s.missed_area);
        json_number(&w, "missed_area_max", r->s.missed_area_max);
        json_number(&w, "overdraw", r->s.overdraw);
        json_number(&w, "overdraw_triangles", r->s.overdraw_triangles);
        json_number(&w, "hidden", r->s.hidden);
        json_number(&w, "occluded_culled", r->s.occluded_culled);
        if (a->effects) {
            static const char *const names[VIS_REASON_COUNT] = {"direct", "see_through", "reflection", "shadow"};
            json_object_begin(&w, "reasons");
            for (int k = 0; k < VIS_REASON_COUNT; ++k) {
                json_object_begin(&w, names[k]);
                json_number(&w, "truth", r->s.reason_truth[k]);
                json_number(&w, "missed", r->s.reason_missed[k]);
                json_object_end(&w);
            }
            json_object_end(&w);
        }
        json_object_end(&w);
    }
    json_array_end(&w);
    json_string(&w, "csv", csv);
    json_string(&w, "png", png);
    json_string(&w, "plot_note", plot_note);
    json_object_end(&w);
}

static int make_dir(const char *dir)
{
    if (mkdir(dir, 0777) == 0 || errno == EEXIST) {
        struct stat sb;
        if (stat(dir, &sb) == 0 && S_ISDIR(sb.st_mode))
            return CLI_EXIT_OK;
        return cli_fail(CMD, "--out %s: not a directory", dir);
    }
    return cli_fail(CMD, "--out %s: cannot create the directory: %s", dir, strerror(errno));
}

static int report(study *st)
{
    const cli_args *a = st->a;
    const char *dir = a->out ? a->out : ".";
    acc_row rows[ACC_MAX_ROWS];
    summarize(st, rows);
    double tms[VC_MAX_VIEWS], vis = 0.0;
    for (size_t f = 0; f < st->nframes; ++f) {
        tms[f] = st->truth_ms[f];
        vis += st->truth_visible[f];
    }
    vis /= (double)(st->nframes ? st->nframes : 1);
    double truth_ms = vc_median(tms, st->nframes);

    char csv[4096], png[4096], err[1024], title[512];
    snprintf(csv, sizeof csv, "%s/accuracy.csv", dir);
    snprintf(png, sizeof png, "%s/accuracy.png", dir);
    if (acc_write_csv(csv, rows, st->nrows, err, sizeof err) != 0)
        return cli_fail(CMD, "%s", err);
    snprintf(title, sizeof title, "%s: truth %ux%u%s, %zu views, %s (%s)", base_name(a->scene), a->truth_width,
             a->truth_height, a->supersample > 1 ? " supersampled" : "", st->nframes, st->obj.backend.name,
             st->obj.backend.device);
    int plot = acc_plot(dir, title, rows, st->nrows, err, sizeof err);
    if (plot < 0)
        return cli_fail(CMD, "%s", err);
    if (plot > 0)
        fprintf(stderr, "vis %s: %s\n", CMD, err);

    if (a->json) {
        print_json(st, rows, csv, plot == 0 ? png : NULL, plot == 0 ? NULL : err, truth_ms, vis);
        return CLI_EXIT_OK;
    }
    printf("truth     %ux%u object IDs, %u sample%s per pixel: %.1f visible objects per view (mean), %.0f ms per "
           "view (median)\n",
           a->truth_width, a->truth_height, a->supersample * a->supersample, a->supersample > 1 ? "s" : "", vis,
           truth_ms);
    printf("views     ");
    for (size_t f = 0; f < st->nframes; ++f)
        printf("%s%s", f ? ", " : "", st->views[st->frame[f]].name);
    printf("\n\n");
    acc_print_table(stdout, rows, st->nrows, a->truth_width, a->truth_height);
    if (a->effects) {
        char names[128];
        vc_effects_format(a->effects, names, sizeof names);
        printf("\nmisses per reason (%s; truth and ray passes traced with them; zbuf knows no effects):\n", names);
        acc_print_reasons(stdout, rows, st->nrows);
    }
    printf("\nms/frame: median over the views of each view's median of %u passes (ray: pass + draw list; zbuf: "
           "vis_zcull_run).\nOther columns: means per view. missed %%/px: the truth's screen area of the missed "
           "objects; worst %%: the worst view;\novd tris: triangles of the overdrawn objects; occl cull: hidden "
           "objects in the view frustum left out (pooled over the views).\n",
           st->repeat);
    printf("\nwrote     %s%s%s\n", csv, plot == 0 ? ", " : "", plot == 0 ? png : "");
    return CLI_EXIT_OK;
}

int cmd_accuracy(const cli_args *a)
{
    if ((uint64_t)a->truth_width * a->supersample > VIS_MAX_RESOLUTION ||
        (uint64_t)a->truth_height * a->supersample > VIS_MAX_RESOLUTION)
        return cli_usage_error(CMD, "--truth-res %ux%u with --supersample %u traces beyond %u pixels per side",
                               a->truth_width, a->truth_height, a->supersample, VIS_MAX_RESOLUTION);
    if (a->given & OPT_OUT) {
        int rc = make_dir(a->out);
        if (rc != CLI_EXIT_OK)
            return rc;
    }
    study *st = calloc(1, sizeof *st);
    if (!st)
        return cli_fail(CMD, "out of memory");
    st->a = a;
    st->repeat = (a->given & OPT_REPEAT) ? a->repeat : ACC_DEFAULT_REPEAT;
    cli_progress progress;
    cli_progress_init(&progress, CLI_PROGRESS_AUTO);
    if (!a->json) {
        printf("libvis %s accuracy: %s\n", vis_version(), a->scene);
        fflush(stdout);
    }
    int rc = setup(st, &progress);
    if (rc == CLI_EXIT_OK && !a->json) {
        printf("scene     %u objects, %llu quads; kd depth %u (leaf IDs: depth %u); backend %s (%s)\n",
               st->info.objects, (unsigned long long)st->info.quads, st->kd_depth, st->leaf_depth,
               st->obj.backend.name, st->obj.backend.device);
        if (a->effects) {
            char names[128];
            vc_effects_format(a->effects, names, sizeof names);
            printf("effects   %s (the truth and the ray-object rows; no ray-leaf rows)\n", names);
        }
        fflush(stdout);
    }
    if (rc == CLI_EXIT_OK)
        rc = run_frames(st);
    if (rc == CLI_EXIT_OK)
        rc = report(st);
    teardown(st);
    free(st);
    return rc;
}
