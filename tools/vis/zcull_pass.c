/* zcull_pass.c — the z-buffer culler (vis_zcull_*) behind `vis cull --method zbuf`. */
#include "zcull_pass.h"

#include <stdlib.h>
#include <string.h>

#include "timer.h"

vis_status cli_zcull_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, uint32_t width,
                         uint32_t height, uint32_t passes, vis_draw_entry **out_entries, size_t *out_count,
                         float *depth, vis_zcull_stats *stats, cli_pass_times *out)
{
    vis_zcull *zc = NULL;
    vis_status s = vis_zcull_create(ctx, &zc);
    if (s != VIS_OK)
        return s;
    vis_zcull_desc desc;
    vis_zcull_desc_defaults(&desc);
    desc.width = width;
    desc.height = height;
    size_t cap = vis_drawlist_bound(scene);
    vis_draw_entry *e = malloc((cap ? cap : 1) * sizeof *e);
    if (passes == 0)
        passes = 1;
    double *t = malloc(passes * sizeof *t);
    if (!e || !t) {
        s = VIS_ERROR_OUT_OF_MEMORY;
        goto fail;
    }
    /* The warm-up run grows the culler's buffers; the timed ones allocate nothing. */
    double t0 = vc_now_ms();
    s = vis_zcull_run(zc, scene, camera, &desc, e, cap, out_count, NULL);
    out->first_ms = vc_now_ms() - t0;
    for (uint32_t i = 0; s == VIS_OK && i < passes; ++i) {
        t0 = vc_now_ms();
        s = vis_zcull_run(zc, scene, camera, &desc, e, cap, out_count, stats);
        t[i] = vc_now_ms() - t0;
    }
    if (s == VIS_OK && depth)
        s = vis_zcull_depth(zc, depth, (size_t)width * height);
    if (s != VIS_OK)
        goto fail;
    out->passes = passes;
    out->min_ms = vc_min(t, passes);
    out->max_ms = vc_max(t, passes);
    out->median_ms = vc_median(t, passes);
    /* Pixels of the depth buffer per second: the ray pass's unit for the same buffer. */
    out->mrays_per_s = vc_mrays_per_s((double)width * height, out->median_ms);
    free(t);
    vis_zcull_destroy(zc);
    *out_entries = e;
    return VIS_OK;
fail:
    free(t);
    free(e);
    vis_zcull_destroy(zc);
    return s;
}
