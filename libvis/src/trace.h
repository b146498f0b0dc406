/* trace.h — internal: vis_trace_batch for callers that already hold the context (vis_enter),
 * such as the server queries (query.c), which trace their chunk passes inside their own call. */
#ifndef VIS_TRACE_H
#define VIS_TRACE_H

#include "vis/vis.h"

vis_status vis_trace_batch_held(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                                const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity, float *out_depth,
                                size_t depth_capacity);

#endif
