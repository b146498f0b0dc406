/* trace.c — vis_trace and vis_trace_batch: validate everything, sync the backend's copy of
 * the scene, run; and the timing of the last call. */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "scene.h"
#include "trace.h"

double vis_trace_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

vis_traversal vis_trace_auto_stack(const vis_context *ctx, vis_traversal t)
{
    return t == VIS_TRAVERSAL_AUTO && ctx->info.kind != VIS_BACKEND_CPU ? VIS_TRAVERSAL_STACK : t;
}

/* The method as backends number it (trace_core.h, VIS_TRAVERSAL_ID_*). AUTO is resolved here,
 * once: the CPU traces packets; a GPU walks the cell grid per ray (dda), which measured faster
 * there than the stack method for one view and for batches (docs/opencl.md, "dda as the GPU
 * default for one view" and "Batches walk the cell grid"); other devices (PoCL) run the stack
 * method. A scene without a cell map gets the stack method in vis_trace_make_setup. PACKET is
 * the CPU's tile packets or a device's work-group tile walk (backends/opencl/kernels/tile.cl). */
static uint32_t kernel_traversal(const vis_context *ctx, vis_traversal t)
{
    if (t == VIS_TRAVERSAL_PACKET)
        return VIS_TRAVERSAL_ID_PACKET;
    if (t == VIS_TRAVERSAL_AUTO) {
        if (ctx->info.kind == VIS_BACKEND_CPU)
            return VIS_TRAVERSAL_ID_PACKET;
        return ctx->info.is_gpu ? VIS_TRAVERSAL_ID_DDA : VIS_TRAVERSAL_ID_STACK;
    }
    return (uint32_t)t - 1u; /* STACK .. ROPES_SHORTSTACK are ids 0 .. 6, CACHED_STACK 8, DDA 9 */
}

/* The float ray setup of one view: validated camera, resolved desc (fog shortens t_far). */
vis_status vis_trace_make_setup(vis_context *ctx, const vis_scene *scene, const vis_camera *camera,
                                const vis_trace_desc *d, vis_ray_setup *setup)
{
    vis_camera_frame frame;
    vis_status st = vis_camera_frame_make(ctx, camera, scene->desc.origin, d->width, d->height, &frame);
    if (st != VIS_OK)
        return st;
    vis_camera_frame_ray_setup(&frame, setup);
    memcpy(setup->size, scene->desc.size, sizeof setup->size);
    setup->id_mode = d->ids == VIS_IDS_LEAF ? 1u : 0u;
    setup->traversal = kernel_traversal(ctx, d->traversal);
    setup->short_stack = d->short_stack;
    setup->root = 0;
    setup->leaf_count = scene->leaf_count;
    memcpy(setup->cells, scene->cells, sizeof setup->cells);
    setup->cell_map = scene->cell_map;
    setup->cell_size = scene->desc.cell_size;
    /* The cell-grid walk needs every leaf to be one cell; on a shallower tree the stack
     * method (the same buffers) runs instead. */
    if (setup->traversal == VIS_TRAVERSAL_ID_DDA && scene->cell_map == 0u)
        setup->traversal = VIS_TRAVERSAL_ID_STACK;
    if (d->effects & VIS_EFFECT_FOG) {
        float fog = (float)d->fog_dist;
        if (fog < setup->t_far)
            setup->t_far = fog;
    }
    return VIS_OK;
}

/* vis_trace, vis_trace_batch and the draw-list calls have buffers for the ID pass only: fog is
 * all they take. */
vis_status vis_trace_check_plain_effects(vis_context *ctx, const vis_trace_desc *d, const char *fn)
{
    if (d->effects & ~VIS_EFFECT_FOG)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "%s: effects 0x%x need vis_trace_effects (only VIS_EFFECT_FOG is taken here)", fn, d->effects);
    return VIS_OK;
}

static vis_status check_args(vis_context *ctx, const vis_scene *scene, const void *out_ids, const char *fn)
{
    if (!scene || !out_ids)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: scene and out_ids must not be NULL", fn);
    return VIS_OK; /* a scene of any context: each context keeps its own backend copy */
}

/* Output capacities, in elements, against `needed` (count * W * H, at most 2^60: no
 * overflow in 64 bits). */
static vis_status check_capacity(vis_context *ctx, uint64_t needed, size_t ids_capacity, const float *out_depth,
                                 size_t depth_capacity, const char *fn, uint32_t count, const vis_trace_desc *d)
{
    if (!out_depth && depth_capacity)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: out_depth is NULL but depth_capacity is %zu", fn,
                        depth_capacity);
    int ids_short = (uint64_t)ids_capacity < needed;
    if (!ids_short && !(out_depth && (uint64_t)depth_capacity < needed))
        return VIS_OK;
    return vis_fail(ctx, VIS_ERROR_CAPACITY, "%s: %u view(s) of %ux%u need %llu elements, %s is %zu", fn, count,
                    d->width, d->height, (unsigned long long)needed, ids_short ? "ids_capacity" : "depth_capacity",
                    ids_short ? ids_capacity : depth_capacity);
}

void vis_trace_record_timing(vis_context *ctx, double t0, double pass_ms, uint64_t upload, uint64_t rays, uint32_t views)
{
    vis_timing *t = &ctx->timing;
    t->total_ms = vis_trace_now_ms() - t0;
    t->kernel_ms = ctx->backend.ops->last_kernel_ms ? ctx->backend.ops->last_kernel_ms(ctx->backend.impl) : pass_ms;
    t->upload_bytes = upload;
    t->rays = rays;
    t->views = views;
    t->secondary_rays = 0;
    ctx->have_timing = 1;
}

/* vis_trace, or vis_trace_cost when out_cost is set (then out_depth is NULL). */
static vis_status trace_one(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                            uint32_t *out_ids, size_t ids_capacity, float *out_depth, size_t depth_capacity,
                            uint32_t *out_cost, size_t cost_capacity)
{
    double t0 = vis_trace_now_ms();
    vis_clear_error(ctx);
    const char *fn = out_cost ? "vis_trace_cost" : "vis_trace";
    vis_status st = check_args(ctx, scene, out_ids, fn);
    if (st != VIS_OK)
        return st;
    vis_trace_desc d;
    if ((st = vis_trace_desc_resolve(ctx, desc, &d)) != VIS_OK ||
        (st = vis_trace_check_plain_effects(ctx, &d, fn)) != VIS_OK)
        return st;
    if ((st = check_capacity(ctx, (uint64_t)d.width * d.height, ids_capacity, out_depth, depth_capacity, fn, 1, &d)) !=
        VIS_OK)
        return st;
    if (out_cost && (uint64_t)cost_capacity < (uint64_t)d.width * d.height)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_trace_cost: a %ux%u view needs %llu elements, cost_capacity is %zu",
                        d.width, d.height, (unsigned long long)d.width * d.height, cost_capacity);
    vis_ray_setup setup;
    if ((st = vis_trace_make_setup(ctx, scene, camera, &d, &setup)) != VIS_OK)
        return st;
    /* A backend that counts checks the method itself (the CPU: packets only). */
    if (out_cost && !ctx->backend.ops->trace_cost)
        return vis_fail(ctx, VIS_ERROR_UNSUPPORTED, "vis_trace_cost: the %s backend does not count traversal cost "
                        "(the CPU backend's packet method does)", ctx->backend.ops->name);

    uint64_t upload = 0;
    void *data = NULL;
    if ((st = vis_scene_begin_trace(ctx, scene, vis_trace_walks_ropes(&setup), &data, &upload)) != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    double p0 = vis_trace_now_ms();
    int rc = out_cost ? ctx->backend.ops->trace_cost(ctx->backend.impl, data, &view, &setup, out_ids, out_cost, err,
                                                     sizeof err)
                      : ctx->backend.ops->trace(ctx->backend.impl, data, &view, &setup, out_ids, out_depth, err, sizeof err);
    double pass_ms = vis_trace_now_ms() - p0;
    vis_scene_end_read(scene);
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ctx->backend.ops->name, err);
    vis_trace_record_timing(ctx, t0, pass_ms, upload, (uint64_t)d.width * d.height, 1);
    return VIS_OK;
}

vis_status vis_trace(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                     uint32_t *out_ids, size_t ids_capacity, float *out_depth, size_t depth_capacity)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = trace_one(ctx, scene, camera, desc, out_ids, ids_capacity, out_depth, depth_capacity, NULL, 0);
    vis_leave(ctx);
    return st;
}

vis_status vis_scene_prepare(vis_context *ctx, vis_scene *scene)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st = VIS_OK;
    void *data = NULL;
    uint64_t upload = 0;
    if (!scene)
        st = vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_scene_prepare: scene must not be NULL");
    else if ((st = vis_scene_begin_trace(ctx, scene, 0, &data, &upload)) == VIS_OK)
        vis_scene_end_read(scene);
    vis_leave(ctx);
    return st;
}

vis_status vis_trace_cost(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                          uint32_t *out_ids, size_t ids_capacity, uint32_t *out_cost, size_t cost_capacity)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (!out_cost)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_cost: out_cost must not be NULL");
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = trace_one(ctx, scene, camera, desc, out_ids, ids_capacity, NULL, 0, out_cost, cost_capacity);
    vis_leave(ctx);
    return st;
}

vis_status vis_trace_batch_held(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                              const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity, float *out_depth,
                              size_t depth_capacity)
{
    double t0 = vis_trace_now_ms();
    vis_clear_error(ctx);
    if (count == 0)
        return VIS_OK;
    vis_status st = check_args(ctx, scene, out_ids, "vis_trace_batch");
    if (st != VIS_OK)
        return st;
    if (!cameras)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_batch: cameras must not be NULL");
    vis_trace_desc d;
    if ((st = vis_trace_desc_resolve(ctx, desc, &d)) != VIS_OK ||
        (st = vis_trace_check_plain_effects(ctx, &d, "vis_trace_batch")) != VIS_OK)
        return st;
    size_t pixels = (size_t)d.width * d.height;
    /* W, H <= 2^14 and count < 2^32: the product fits 64 bits, and a capacity that holds it
     * (a size_t) makes every offset i * pixels below fit size_t. */
    if ((st = check_capacity(ctx, (uint64_t)count * d.width * d.height, ids_capacity, out_depth, depth_capacity,
                             "vis_trace_batch", count, &d)) != VIS_OK)
        return st;
    /* Every camera is checked before any work, so a bad one leaves the outputs untouched.
     * The setups live in the context's scratch: no allocation once it has grown. */
    uint64_t setup_bytes = (uint64_t)count * sizeof(vis_ray_setup); /* < 2^48: fits size_t where size_t is 64-bit */
    vis_ray_setup *setups = setup_bytes == (size_t)setup_bytes ? vis_scratch(ctx, (size_t)setup_bytes) : NULL;
    if (!setups)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_trace_batch: out of memory for %u views", count);
    for (uint32_t i = 0; i < count && st == VIS_OK; ++i) {
        st = vis_trace_make_setup(ctx, scene, &cameras[i], &d, &setups[i]);
        if (st != VIS_OK) {
            char msg[sizeof ctx->last_error];
            memcpy(msg, ctx->last_error, sizeof msg);
            st = vis_fail(ctx, st, "vis_trace_batch: camera %u: %s", i, msg);
        }
    }
    uint64_t upload = 0;
    void *data = NULL;
    if (st == VIS_OK)
        st = vis_scene_begin_trace(ctx, scene, vis_trace_walks_ropes(&setups[0]), &data, &upload);
    if (st != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    const vis_backend_ops *ops = ctx->backend.ops;
    double p0 = vis_trace_now_ms();
    int rc = VIS_OK;
    if (ops->trace_batch) {
        rc = ops->trace_batch(ctx->backend.impl, data, &view, setups, count, out_ids, out_depth, err,
                              sizeof err);
    } else {
        for (uint32_t i = 0; i < count && rc == VIS_OK; ++i)
            rc = ops->trace(ctx->backend.impl, data, &view, &setups[i], out_ids + i * pixels,
                            out_depth ? out_depth + i * pixels : NULL, err, sizeof err);
    }
    double pass_ms = vis_trace_now_ms() - p0;
    vis_scene_end_read(scene);
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ops->name, err);
    vis_trace_record_timing(ctx, t0, pass_ms, upload, (uint64_t)count * pixels, count);
    return VIS_OK;
}

vis_status vis_trace_batch(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                           const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity, float *out_depth,
                           size_t depth_capacity)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = vis_trace_batch_held(ctx, scene, cameras, count, desc, out_ids, ids_capacity, out_depth, depth_capacity);
    vis_leave(ctx);
    return st;
}

vis_status vis_context_last_timing(const vis_context *ctx, vis_timing *out)
{
    if (!ctx || !out)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_context *c = (vis_context *)ctx; /* the busy flag: a trace on another thread writes the timing */
    if (vis_enter(c) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = ctx->have_timing ? VIS_OK : VIS_ERROR_NOT_FOUND;
    if (st == VIS_OK)
        *out = ctx->timing;
    vis_leave(c);
    return st;
}
