/* zcull_pass.h — `vis cull --method zbuf`: the software z-buffer culler (vis_zcull_*), timed
 * like the ray pass. */
#ifndef VIS_CLI_ZCULL_PASS_H
#define VIS_CLI_ZCULL_PASS_H

#include <stddef.h>
#include <stdint.h>

#include "pass.h"
#include "vis/vis.h"

/* Culls the scene's objects against a width x height depth buffer: a warm-up, then `passes`
 * timed passes. The draw list (pixels 0: the culler counts none) is malloc'ed for the
 * caller; depth (may be NULL) receives width*height distances of the last pass (+inf where
 * no occluder covers the pixel); stats (may be NULL) the last pass's statistics. */
vis_status cli_zcull_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, uint32_t width,
                         uint32_t height, uint32_t passes, vis_draw_entry **out_entries, size_t *out_count,
                         float *depth, vis_zcull_stats *stats, cli_pass_times *out_times);

#endif
