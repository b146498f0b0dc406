/* drawlist_check.h — vis_trace_drawlist and vis_trace_batch_drawlist held to vis_trace +
 * vis_drawlist_build, for test_trace.c (CPU) and test_opencl.c (the device). */
#ifndef DRAWLIST_CHECK_H
#define DRAWLIST_CHECK_H

#include "vis/vis.h"

/* For each camera: the list of vis_trace_drawlist on (ctx, scene), with and without the IDs
 * and depths asked for, must equal vis_drawlist_build on (ref_ctx, ref_scene)'s vis_trace
 * IDs (entries, pixel counts, order), and its IDs/depths vis_trace's byte for byte; the batch
 * form must give the same lists one after the other; a capacity one entry short must fail
 * with the count needed and leave the entries untouched. Fails the test otherwise. Returns
 * the longest list. */
size_t check_trace_drawlist(vis_context *ref_ctx, vis_scene *ref_scene, vis_context *ctx, vis_scene *scene,
                          const vis_camera *cams, uint32_t count, const vis_trace_desc *td, const char *what);

#endif
