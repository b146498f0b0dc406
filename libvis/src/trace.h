/* trace.h — internal: vis_trace_batch for callers that already hold the context (vis_enter),
 * such as the server queries (query.c), which trace their chunk passes inside their own call. */
#ifndef VIS_TRACE_H
#define VIS_TRACE_H

#include "backend.h"

vis_status vis_trace_batch_held(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                                const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity, float *out_depth,
                                size_t depth_capacity);

/* Shared with trace_drawlist.c and trace_effects.c: the float ray setup of a view (camera
 * checked, fog applied), the clock, and the timing record of a call that began at t0. */
/* AUTO as the stack method on a device (OpenCL), `t` unchanged otherwise: the effects pass,
 * whose dda programs were not timed on a GPU (docs/opencl.md). */
vis_traversal vis_trace_auto_stack(const vis_context *ctx, vis_traversal t);

vis_status vis_trace_make_setup(vis_context *ctx, const vis_scene *scene, const vis_camera *camera,
                                const vis_trace_desc *d, vis_ray_setup *setup);
/* Whether a pass of this setup walks the scene's ropes (vis_scene_begin_trace builds them). */
static inline int vis_trace_walks_ropes(const vis_ray_setup *setup)
{
    return setup->traversal == VIS_TRAVERSAL_ID_ROPES || setup->traversal == VIS_TRAVERSAL_ID_ROPES_SHORTSTACK;
}
double vis_trace_now_ms(void);
/* VIS_ERROR_INVALID_ARGUMENT, naming fn, for any effect but fog (d resolved). */
vis_status vis_trace_check_plain_effects(vis_context *ctx, const vis_trace_desc *d, const char *fn);
void vis_trace_record_timing(vis_context *ctx, double t0, double pass_ms, uint64_t upload, uint64_t rays,
                             uint32_t views);

#endif
