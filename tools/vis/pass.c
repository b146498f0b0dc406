/* pass.c — timed ray passes and draw lists. */
#include "pass.h"

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
    return d;
}

vis_status cli_pass_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                        uint32_t passes, uint32_t *ids, size_t ids_capacity, float *depth, size_t depth_capacity,
                        cli_pass_times *out)
{
    double t0 = vc_now_ms();
    vis_status s = vis_trace(ctx, scene, camera, desc, ids, ids_capacity, depth, depth_capacity);
    if (s != VIS_OK)
        return s;
    out->first_ms = vc_now_ms() - t0;
    if (passes == 0)
        passes = 1;
    double *t = malloc(passes * sizeof *t);
    if (!t)
        return VIS_ERROR_OUT_OF_MEMORY;
    for (uint32_t i = 0; i < passes; ++i) {
        t0 = vc_now_ms();
        s = vis_trace(ctx, scene, camera, desc, ids, ids_capacity, depth, depth_capacity);
        t[i] = vc_now_ms() - t0;
        if (s != VIS_OK) {
            free(t);
            return s;
        }
    }
    out->passes = passes;
    out->min_ms = vc_min(t, passes);
    out->max_ms = vc_max(t, passes);
    out->median_ms = vc_median(t, passes);
    out->mrays_per_s = vc_mrays_per_s((double)desc->width * desc->height, out->median_ms);
    free(t);
    return VIS_OK;
}

vis_status cli_drawlist(vis_context *ctx, const vis_scene *scene, const uint32_t *ids, uint32_t width,
                        uint32_t height, vis_id_mode mode, vis_draw_entry **out_entries, size_t *out_count,
                        double *out_ms)
{
    size_t cap = vis_drawlist_bound(scene);
    vis_draw_entry *e = malloc((cap ? cap : 1) * sizeof *e);
    if (!e)
        return VIS_ERROR_OUT_OF_MEMORY;
    double t0 = vc_now_ms();
    vis_status s = vis_drawlist_build(ctx, scene, ids, width, height, mode, e, cap, out_count);
    if (out_ms)
        *out_ms = vc_now_ms() - t0;
    if (s != VIS_OK) {
        free(e);
        return s;
    }
    *out_entries = e;
    return VIS_OK;
}
