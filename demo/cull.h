/* cull.h — the libvis side of a frame: the camera handed over as view and projection
 * matrices, then the current method's draw list (ray pass with object or leaf IDs, the
 * z-buffer culler, or no culling), on the CPU or the OpenCL backend. Every buffer is
 * allocated once, for the largest pass resolution, so a frame allocates nothing. */
#ifndef VIS_VIEWER_CULL_H
#define VIS_VIEWER_CULL_H

#include "viewer.h"

#define VV_MAX_PASS 1024u

typedef struct vv_cull {
    vis_context *ctx[2];          /* [0] CPU, [1] OpenCL (opened on first use)            */
    vis_backend_info info[2];
    int owner;                    /* the context the scene was built on                   */
    int active;                   /* the context that traces                              */
    int opencl_failed;            /* an OpenCL context could not be opened: say so once   */
    char opencl_error[256];
    world_scene *ws;
    vis_zcull *zcull;             /* on the owner context                                 */
    vv_method method;
    uint32_t width, height;       /* the pass                                             */
    uint32_t *ids;                /* VV_MAX_PASS^2 each                                   */
    float *depth;                 /* the ray pass's depth (picking)                       */
    float *zdepth;                /* the z-buffer culler's depth (overlay)                */
    uint32_t *cost;               /* the ray pass's traversal cost per pixel (overlay)    */
    uint32_t *cost_ids;           /* the IDs vis_trace_cost writes beside it              */
    int want_cost;                /* trace the cost too (the cost overlay is shown)       */
    int ids_valid, zdepth_valid, cost_valid; /* what the last frame filled               */
    vis_draw_entry *entries;      /* the draw list                                        */
    size_t capacity, count;
    vis_camera camera;            /* the camera of the last cull                          */
    vv_mat4 view, proj;           /* and its matrices                                     */
    double cull_ms, pass_ms;      /* last frame: the whole libvis call(s); the pass alone */
} vv_cull;

/* Opens a context for `backend`, builds the world's scene on it. Prints and returns
 * VV_EXIT_FAILURE on failure. */
int vv_cull_open(vv_cull *c, vw_world *world, vis_backend_kind backend, uint32_t width, uint32_t height);
void vv_cull_close(vv_cull *c);

/* Switches the tracing backend (the scene stays on its owner; a second context traces it).
 * Returns 0, or -1 with the reason in c->opencl_error (the active backend is unchanged). */
int vv_cull_toggle_backend(vv_cull *c);

/* Sets the pass resolution (each 1..VV_MAX_PASS). */
int vv_cull_set_resolution(vv_cull *c, uint32_t width, uint32_t height);

/* One frame's culling for the view (absolute world coordinates): matrices -> vis_camera
 * through vis_camera_from_matrices -> the method's draw list. Prints the library's message
 * and returns VV_EXIT_FAILURE on failure. */
int vv_cull_run(vv_cull *c, const vv_view *view);

/* After an edit: the draw list may need more room (objects were added). */
int vv_cull_grow(vv_cull *c);

/* The backend info of the active context. */
const vis_backend_info *vv_cull_backend(const vv_cull *c);

#endif
