/* camera.h — internal: validating a camera and turning it into the per-pass ray setup. */
#ifndef VIS_CAMERA_H
#define VIS_CAMERA_H

#include "backend.h"
#include "context.h"

/* The camera in double precision, relative to a scene origin. */
typedef struct vis_camera_frame {
    double eye[3];          /* scene-local                                                 */
    double f[3], r[3], u[3];/* forward, right, up: orthonormal                             */
    double tan_half_fovy;
    double aspect;          /* width / height                                              */
    double near_dist, far_dist; /* far may be +inf                                        */
    uint32_t width, height;
} vis_camera_frame;

/* Validates (see vis_camera_validate) and fills the frame. Defaults: fovy 60, near 0.05,
 * far +inf. */
vis_status vis_camera_frame_make(vis_context *ctx, const vis_camera *camera, const double origin[3],
                                 uint32_t width, uint32_t height, vis_camera_frame *out);

/* The float ray setup the traversal uses (see trace_core.h). */
void vis_camera_frame_ray_setup(const vis_camera_frame *frame, vis_ray_setup *out);

/* 1 when t names a traversal method of vis.h (the one place that knows the last one). */
static inline int vis_traversal_known(vis_traversal t) { return (unsigned)t <= (unsigned)VIS_TRAVERSAL_DDA; }

/* Fills a defaulted copy of a trace desc and checks it. */
vis_status vis_trace_desc_resolve(vis_context *ctx, const vis_trace_desc *desc, vis_trace_desc *out);

#endif
