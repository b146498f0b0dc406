/* pass.c — timed ray passes and draw lists. */
#include "pass.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "names.h"
#include "timer.h"

vis_trace_desc cli_trace_desc(const cli_args *a)
{
    vis_trace_desc d;
    memset(&d, 0, sizeof d);
    d.width = a->width;
    d.height = a->height;
    d.ids = a->ids;
    d.traversal = vc_traversal_method((int)a->traversal); /* names.h: N rides along */
    d.short_stack = vc_traversal_short_stack((int)a->traversal);
    d.effects = a->effects;
    d.see_through_layers = VC_SEE_THROUGH_LAYERS;
    memcpy(d.light_dir, a->light, sizeof d.light_dir);
    d.fog_dist = a->fog;
    return d;
}

/* One untimed warm-up call, then `passes` (0 counts as 1) timed calls of pass(arg); stops at
 * the first failure and returns its status. */
static vis_status timed_passes(vis_status (*pass)(const void *arg), const void *arg, uint32_t passes, double rays,
                               cli_pass_times *out)
{
    double t0 = vc_now_ms();
    vis_status s = pass(arg);
    if (s != VIS_OK)
        return s;
    out->first_ms = vc_now_ms() - t0;
    if (passes == 0)
        passes = 1;
    double *t = malloc(passes * sizeof *t);
    if (!t)
        return VIS_ERROR_OUT_OF_MEMORY;
    for (uint32_t i = 0; i < passes && s == VIS_OK; ++i) {
        t0 = vc_now_ms();
        s = pass(arg);
        t[i] = vc_now_ms() - t0;
    }
    if (s == VIS_OK) {
        out->passes = passes;
        out->min_ms = vc_min(t, passes);
        out->max_ms = vc_max(t, passes);
        out->median_ms = vc_median(t, passes);
        out->mrays_per_s = vc_mrays_per_s(rays, out->median_ms);
    }
    free(t);
    return s;
}

typedef struct trace_call {
    vis_context *ctx;
    vis_scene *scene;
    const vis_camera *camera;
    const vis_trace_desc *desc;
    uint32_t *ids;
    size_t ids_capacity;
    float *depth;
    size_t depth_capacity;
    const vis_effect_buffers *buffers; /* vis_trace_effects when set, else vis_trace */
} trace_call;

static vis_status trace_once(const void *arg)
{
    const trace_call *c = arg;
    if (c->buffers)
        return vis_trace_effects(c->ctx, c->scene, c->camera, c->desc, c->buffers);
    return vis_trace(c->ctx, c->scene, c->camera, c->desc, c->ids, c->ids_capacity, c->depth, c->depth_capacity);
}

vis_status cli_pass_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                        uint32_t passes, uint32_t *ids, size_t ids_capacity, float *depth, size_t depth_capacity,
                        cli_pass_times *out)
{
    trace_call c = {ctx, scene, camera, desc, ids, ids_capacity, depth, depth_capacity, NULL};
    return timed_passes(trace_once, &c, passes, (double)desc->width * desc->height, out);
}

/* The buffers of an effects pass for W x H. */
int cli_effect_buffers_alloc(cli_effect_buffers *e, uint32_t width, uint32_t height)
{
    size_t n = (size_t)width * height;
    memset(e, 0, sizeof *e);
    e->b.ids = malloc(n * sizeof(uint32_t));
    e->b.see_through = malloc(n * VC_SEE_THROUGH_LAYERS * sizeof(uint32_t));
    e->b.reflection = malloc(n * sizeof(uint32_t));
    e->b.shadow = malloc(n * sizeof(uint32_t));
    e->b.ids_capacity = e->b.reflection_capacity = e->b.shadow_capacity = n;
    e->b.see_through_capacity = n * VC_SEE_THROUGH_LAYERS;
    return e->b.ids && e->b.see_through && e->b.reflection && e->b.shadow ? 0 : -1;
}

void cli_effect_buffers_free(cli_effect_buffers *e)
{
    free(e->b.ids);
    free(e->b.see_through);
    free(e->b.reflection);
    free(e->b.shadow);
    memset(e, 0, sizeof *e);
}

vis_status cli_effects_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                           uint32_t passes, const vis_effect_buffers *b, cli_pass_times *out)
{
    trace_call c = {ctx, scene, camera, desc, NULL, 0, NULL, 0, b};
    return timed_passes(trace_once, &c, passes, (double)desc->width * desc->height, out);
}

typedef struct drawlist_call {
    vis_context *ctx;
    const vis_scene *scene;
    const uint32_t *ids;
    uint32_t width, height;
    vis_id_mode mode;
    vis_draw_entry *entries;
    size_t cap, *count;
} drawlist_call;

static vis_status drawlist_once(const void *arg)
{
    const drawlist_call *c = arg;
    return vis_drawlist_build(c->ctx, c->scene, c->ids, c->width, c->height, c->mode, c->entries, c->cap, c->count);
}

vis_status cli_drawlist(vis_context *ctx, const vis_scene *scene, const uint32_t *ids, uint32_t width,
                        uint32_t height, vis_id_mode mode, uint32_t repeat, vis_draw_entry **out_entries,
                        size_t *out_count, double *out_ms)
{
    size_t cap = vis_drawlist_bound(scene);
    vis_draw_entry *e = malloc((cap ? cap : 1) * sizeof *e);
    if (!e)
        return VIS_ERROR_OUT_OF_MEMORY;
    drawlist_call c = {ctx, scene, ids, width, height, mode, e, cap, out_count};
    vis_status s;
    if (out_ms) { /* the first call is cold (its scratch is allocated then): the median of the next */
        cli_pass_times t;
        memset(&t, 0, sizeof t);
        s = timed_passes(drawlist_once, &c, repeat, 0.0, &t);
        *out_ms = t.median_ms;
    } else {
        s = drawlist_once(&c);
    }
    if (s != VIS_OK) {
        free(e);
        return s;
    }
    *out_entries = e;
    return VIS_OK;
}
