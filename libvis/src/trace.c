/* trace.c — vis_trace: validate everything, sync the backend's copy of the scene, run. */
#include <string.h>

#include "camera.h"
#include "scene.h"

vis_status vis_trace(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                     uint32_t *out_ids, float *out_depth)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_clear_error(ctx);
    if (!scene || !out_ids)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace: scene and out_ids must not be NULL");
    if (scene->ctx != ctx)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace: the scene belongs to another context");
    vis_trace_desc d;
    vis_status st = vis_trace_desc_resolve(ctx, desc, &d);
    if (st != VIS_OK)
        return st;
    vis_camera_frame frame;
    st = vis_camera_frame_make(ctx, camera, scene->desc.origin, d.width, d.height, &frame);
    if (st != VIS_OK)
        return st;
    vis_ray_setup setup;
    vis_camera_frame_ray_setup(&frame, &setup);
    memcpy(setup.size, scene->desc.size, sizeof setup.size);
    setup.id_mode = d.ids == VIS_IDS_LEAF ? 1u : 0u;
    setup.traversal = (uint32_t)d.traversal;
    setup.root = 0;
    setup.leaf_count = scene->leaf_count;

    if ((st = vis_scene_sync_backend(scene)) != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    char err[1024] = "";
    int rc = ctx->backend.ops->trace(ctx->backend.impl, scene->backend_data, &view, &setup, out_ids, out_depth, err,
                                     sizeof err);
    if (rc != VIS_OK)
        return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ctx->backend.ops->name, err);
    return VIS_OK;
}
