/* trace_effects.c — vis_trace_effects: check the effect parameters and every buffer, build
 * the ray and effect setups, run the backend's effects pass (trace_core.h,
 * vis_trace_pixel_effects; docs/effects.md). */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "camera.h"
#include "scene.h"
#include "trace.h"

/* One buffer against its need: NULL where its effect is on is a bad argument, a short
 * capacity is VIS_ERROR_CAPACITY. */
static vis_status check_buffer(vis_context *ctx, const void *buf, size_t capacity, uint64_t need, const char *name,
                               const char *effect)
{
    if (!buf)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_effects: %s is NULL but %s is on", name, effect);
    if ((uint64_t)capacity < need)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_trace_effects: %s needs %llu elements, its capacity is %zu", name,
                        (unsigned long long)need, capacity);
    return VIS_OK;
}

static vis_status check_buffers(vis_context *ctx, const vis_trace_desc *d, const vis_effect_buffers *b)
{
    uint64_t n = (uint64_t)d->width * d->height;
    vis_status st = check_buffer(ctx, b->ids, b->ids_capacity, n, "ids", "the pass");
    if (st != VIS_OK)
        return st;
    if (!b->depth && b->depth_capacity)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_effects: depth is NULL but depth_capacity is %zu",
                        b->depth_capacity);
    if (b->depth && (st = check_buffer(ctx, b->depth, b->depth_capacity, n, "depth", "")) != VIS_OK)
        return st;
    if ((d->effects & VIS_EFFECT_SEE_THROUGH) &&
        (st = check_buffer(ctx, b->see_through, b->see_through_capacity, n * d->see_through_layers, "see_through",
                           "VIS_EFFECT_SEE_THROUGH")) != VIS_OK)
        return st;
    if ((d->effects & VIS_EFFECT_REFLECT) &&
        (st = check_buffer(ctx, b->reflection, b->reflection_capacity, n, "reflection", "VIS_EFFECT_REFLECT")) != VIS_OK)
        return st;
    if ((d->effects & VIS_EFFECT_SHADOWS) &&
        (st = check_buffer(ctx, b->shadow, b->shadow_capacity, n, "shadow", "VIS_EFFECT_SHADOWS")) != VIS_OK)
        return st;
    return VIS_OK;
}

/* The device's effect parameters: the light normalised in double (scaled first, so no square
 * overflows), then rounded to float. */
static void make_effect_setup(const vis_trace_desc *d, vis_effect_setup *e)
{
    memset(e, 0, sizeof *e);
    e->effects = d->effects & ~(uint32_t)VIS_EFFECT_FOG; /* fog is in the ray setup's t_far */
    e->layers = (d->effects & VIS_EFFECT_SEE_THROUGH) ? d->see_through_layers : 0u;
    if (d->effects & VIS_EFFECT_SHADOWS) {
        double m = fmax(fabs(d->light_dir[0]), fmax(fabs(d->light_dir[1]), fabs(d->light_dir[2])));
        double l[3] = {d->light_dir[0] / m, d->light_dir[1] / m, d->light_dir[2] / m};
        double len = sqrt(l[0] * l[0] + l[1] * l[1] + l[2] * l[2]);
        for (int a = 0; a < 3; ++a)
            e->light[a] = (float)(l[a] / len);
    }
}

static vis_status trace_effects(vis_context *ctx, vis_scene *scene, const vis_camera *camera,
                                const vis_trace_desc *desc, const vis_effect_buffers *b)
{
    double t0 = vis_trace_now_ms();
    vis_clear_error(ctx);
    if (!scene || !b)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_effects: scene and buffers must not be NULL");
    vis_trace_desc d;
    vis_status st = vis_trace_desc_resolve(ctx, desc, &d);
    if (st != VIS_OK)
        return st;
    if (d.ids != VIS_IDS_OBJECT)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_effects: object IDs only (desc.ids is leaf IDs)");
    if ((st = check_buffers(ctx, &d, b)) != VIS_OK)
        return st;
    vis_ray_setup setup;
    d.traversal = vis_trace_auto_stack(ctx, d.traversal); /* on a device: see trace.h */
    if ((st = vis_trace_make_setup(ctx, scene, camera, &d, &setup)) != VIS_OK)
        return st;
    const vis_backend_ops *ops = ctx->backend.ops;
    if (!ops->trace_effects)
        return vis_fail(ctx, VIS_ERROR_UNSUPPORTED, "vis_trace_effects: the %s backend has no effects pass", ops->name);
    vis_effect_setup fx;
    make_effect_setup(&d, &fx);
    uint64_t secondary = 0;
    vis_effect_outputs out = {b->ids, b->depth, fx.effects & VIS_EFFECT_SEE_THROUGH ? b->see_through : NULL,
                              fx.effects & VIS_EFFECT_REFLECT ? b->reflection : NULL,
                              fx.effects & VIS_EFFECT_SHADOWS ? b->shadow : NULL, &secondary};

    uint64_t upload = 0;
    void *data = NULL;
    if ((st = vis_scene_begin_trace(ctx, scene, vis_trace_walks_ropes(&setup), &data, &upload)) != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    double p0 = vis_trace_now_ms();
    int rc = ops->trace_effects(ctx->backend.impl, data, &view, &setup, &fx, &out, err, sizeof err);
    double pass_ms = vis_trace_now_ms() - p0;
    vis_scene_end_read(scene);
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ops->name, err);
    vis_trace_record_timing(ctx, t0, pass_ms, upload, (uint64_t)d.width * d.height, 1);
    ctx->timing.secondary_rays = secondary;
    return VIS_OK;
}

vis_status vis_trace_effects(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                             const vis_effect_buffers *buffers)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = trace_effects(ctx, scene, camera, desc, buffers);
    vis_leave(ctx);
    return st;
}
