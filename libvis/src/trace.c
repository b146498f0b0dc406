/* trace.c — vis_trace and vis_trace_batch: validate everything, sync the backend's copy of
 * the scene, run; and the timing of the last call. */
#define _POSIX_C_SOURCE 199309L
#include <stdint.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "scene.h"

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* The method as backends number it (trace_core.h, VIS_TRAVERSAL_ID_*). AUTO and PACKET are
 * resolved here, once: the CPU traces packets, a device runs the stack method per ray. */
static uint32_t kernel_traversal(const vis_context *ctx, vis_traversal t)
{
    if (t == VIS_TRAVERSAL_AUTO || t == VIS_TRAVERSAL_PACKET)
        return ctx->info.kind == VIS_BACKEND_CPU ? VIS_TRAVERSAL_ID_PACKET : VIS_TRAVERSAL_ID_STACK;
    return (uint32_t)t - 1u; /* STACK .. ROPES_SHORTSTACK are ids 0 .. 6 */
}

/* The float ray setup of one view: validated camera, resolved desc. */
static vis_status make_setup(vis_context *ctx, const vis_scene *scene, const vis_camera *camera,
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
    return VIS_OK;
}

static vis_status check_args(vis_context *ctx, const vis_scene *scene, const void *out_ids, const char *fn)
{
    if (!scene || !out_ids)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: scene and out_ids must not be NULL", fn);
    if (scene->ctx != ctx)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: the scene belongs to another context", fn);
    return VIS_OK;
}

/* Syncs the scene; *bytes = what this sync sent (0 when nothing had changed). */
static vis_status sync_scene(vis_context *ctx, vis_scene *scene, uint64_t *bytes)
{
    int had_changes = !(scene->synced_generation == scene->generation && scene->backend_data);
    vis_status st = vis_scene_sync_backend(scene);
    if (st != VIS_OK)
        return st;
    *bytes = 0;
    if (had_changes && ctx->backend.ops->last_upload_bytes)
        *bytes = ctx->backend.ops->last_upload_bytes(ctx->backend.impl, scene->backend_data);
    return VIS_OK;
}

static void record_timing(vis_context *ctx, double t0, double pass_ms, uint64_t upload, uint64_t rays, uint32_t views)
{
    vis_timing *t = &ctx->timing;
    t->total_ms = now_ms() - t0;
    t->kernel_ms = ctx->backend.ops->last_kernel_ms ? ctx->backend.ops->last_kernel_ms(ctx->backend.impl) : pass_ms;
    t->upload_bytes = upload;
    t->rays = rays;
    t->views = views;
    ctx->have_timing = 1;
}

vis_status vis_trace(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                     uint32_t *out_ids, float *out_depth)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    double t0 = now_ms();
    vis_clear_error(ctx);
    vis_status st = check_args(ctx, scene, out_ids, "vis_trace");
    if (st != VIS_OK)
        return st;
    vis_trace_desc d;
    if ((st = vis_trace_desc_resolve(ctx, desc, &d)) != VIS_OK)
        return st;
    vis_ray_setup setup;
    if ((st = make_setup(ctx, scene, camera, &d, &setup)) != VIS_OK)
        return st;

    uint64_t upload = 0;
    if ((st = sync_scene(ctx, scene, &upload)) != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    double p0 = now_ms();
    int rc = ctx->backend.ops->trace(ctx->backend.impl, scene->backend_data, &view, &setup, out_ids, out_depth, err,
                                     sizeof err);
    double pass_ms = now_ms() - p0;
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ctx->backend.ops->name, err);
    record_timing(ctx, t0, pass_ms, upload, (uint64_t)d.width * d.height, 1);
    return VIS_OK;
}

vis_status vis_trace_batch(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                           const vis_trace_desc *desc, uint32_t *out_ids, float *out_depth)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    double t0 = now_ms();
    vis_clear_error(ctx);
    if (count == 0)
        return VIS_OK;
    vis_status st = check_args(ctx, scene, out_ids, "vis_trace_batch");
    if (st != VIS_OK)
        return st;
    if (!cameras)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_batch: cameras must not be NULL");
    vis_trace_desc d;
    if ((st = vis_trace_desc_resolve(ctx, desc, &d)) != VIS_OK)
        return st;
    size_t pixels = (size_t)d.width * d.height;
    if ((uint64_t)count * pixels > SIZE_MAX / sizeof(uint32_t))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_batch: %u views of %ux%u overflow the address space",
                        count, d.width, d.height);
    /* Every camera is checked before any work, so a bad one leaves the outputs untouched.
     * The setups live in the context's scratch: no allocation once it has grown. */
    vis_ray_setup *setups = vis_scratch(ctx, (size_t)count * sizeof *setups);
    if (!setups)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_trace_batch: out of memory for %u views", count);
    for (uint32_t i = 0; i < count && st == VIS_OK; ++i) {
        st = make_setup(ctx, scene, &cameras[i], &d, &setups[i]);
        if (st != VIS_OK) {
            char msg[sizeof ctx->last_error];
            memcpy(msg, ctx->last_error, sizeof msg);
            st = vis_fail(ctx, st, "vis_trace_batch: camera %u: %s", i, msg);
        }
    }
    uint64_t upload = 0;
    if (st == VIS_OK)
        st = sync_scene(ctx, scene, &upload);
    if (st != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    const vis_backend_ops *ops = ctx->backend.ops;
    double p0 = now_ms();
    int rc = VIS_OK;
    if (ops->trace_batch) {
        rc = ops->trace_batch(ctx->backend.impl, scene->backend_data, &view, setups, count, out_ids, out_depth, err,
                              sizeof err);
    } else {
        for (uint32_t i = 0; i < count && rc == VIS_OK; ++i)
            rc = ops->trace(ctx->backend.impl, scene->backend_data, &view, &setups[i], out_ids + i * pixels,
                            out_depth ? out_depth + i * pixels : NULL, err, sizeof err);
    }
    double pass_ms = now_ms() - p0;
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ops->name, err);
    record_timing(ctx, t0, pass_ms, upload, (uint64_t)count * pixels, count);
    return VIS_OK;
}

vis_status vis_context_last_timing(const vis_context *ctx, vis_timing *out)
{
    if (!ctx || !out)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (!ctx->have_timing)
        return VIS_ERROR_NOT_FOUND;
    *out = ctx->timing;
    return VIS_OK;
}

vis_status vis_scene_last_upload_bytes(const vis_scene *scene, uint64_t *out_bytes)
{
    if (!scene || !out_bytes)
        return VIS_ERROR_INVALID_ARGUMENT;
    const vis_backend *b = &scene->ctx->backend;
    *out_bytes = scene->backend_data && b->ops->last_upload_bytes
                     ? b->ops->last_upload_bytes(b->impl, scene->backend_data)
                     : 0;
    return VIS_OK;
}
