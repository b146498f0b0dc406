/* pass.h — timed ray passes and draw lists, the same way for cull, run and bench: one
 * untimed warm-up pass (it brings the backend's copy of the scene up to date), then N timed
 * passes, of which the median is "the" time. */
#ifndef VIS_CLI_PASS_H
#define VIS_CLI_PASS_H

#include <stddef.h>
#include <stdint.h>

#include "args.h"
#include "effects_spec.h" /* VC_SEE_THROUGH_LAYERS, vc_effects_format */
#include "vis/vis.h"

typedef struct cli_pass_times {
    uint32_t passes;      /* timed passes                                                 */
    double first_ms;      /* the warm-up pass (includes the scene upload)                  */
    double median_ms, min_ms, max_ms;
    double mrays_per_s;   /* W*H rays over the median                                      */
} cli_pass_times;

/* The trace desc the command line asks for: --res, --ids, --traversal. */
vis_trace_desc cli_trace_desc(const cli_args *args);

/* Traces `passes` (>= 1) timed passes after a warm-up. ids: ids_capacity elements, at least
 * W*H; depth (may be NULL, with depth_capacity 0) likewise. Returns the first failing call's
 * status (its message is on the context). */
vis_status cli_pass_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                        uint32_t passes, uint32_t *ids, size_t ids_capacity, float *depth, size_t depth_capacity,
                        cli_pass_times *out);

/* The buffers of an effects pass (no depth), owned. */
typedef struct cli_effect_buffers {
    vis_effect_buffers b;
} cli_effect_buffers;

/* Allocates every buffer for W x H (0), or -1 when out of memory (free it anyway). */
int cli_effect_buffers_alloc(cli_effect_buffers *e, uint32_t width, uint32_t height);
void cli_effect_buffers_free(cli_effect_buffers *e);

/* cli_pass_run for vis_trace_effects. */
vis_status cli_effects_run(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                           uint32_t passes, const vis_effect_buffers *b, cli_pass_times *out);

/* A draw list of the scene's capacity (entries freed by the caller), built from ids. With
 * out_ms, the list is built once untimed and `repeat` times more (0 counts as 1), and *out_ms
 * is the median time of vis_drawlist_build alone. */
vis_status cli_drawlist(vis_context *ctx, const vis_scene *scene, const uint32_t *ids, uint32_t width,
                        uint32_t height, vis_id_mode mode, uint32_t repeat, vis_draw_entry **out_entries,
                        size_t *out_count, double *out_ms);

#endif
