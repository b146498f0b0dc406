/* cull.h — the libvis side of a frame: the camera handed over as view and projection
 * matrices, then the current method's draw list (ray pass with object or leaf IDs, the
 * z-buffer culler, or no culling), on the CPU or the OpenCL backend. With effects on (keys
 * 1-4, --effects) the ray pass with object IDs is vis_trace_effects and its list
 * vis_drawlist_build_effects's, with reasons; the other methods ignore effects. Every buffer
 * is allocated once, for the largest pass resolution, so a frame allocates nothing. */
#ifndef VIS_VIEWER_CULL_H
#define VIS_VIEWER_CULL_H

#include "effects_spec.h"
#include "viewer.h"

#define VV_MAX_PASS 1024u

/* The effects' parameters until --effects names others (docs/viewer.md): the worlds have no
 * sun of their own, so shadows take this fixed light direction (from above, +X and +Z, the
 * side the viewer's face shades light), and fog this distance in world units. */
#define VV_DEFAULT_LIGHT_X 1.0
#define VV_DEFAULT_LIGHT_Y 0.7
#define VV_DEFAULT_LIGHT_Z 0.4
#define VV_DEFAULT_FOG 200.0

/* Why the last cull had no effects although some are on (vv_cull_effects_ignored). */
typedef enum vv_fx_state {
    VV_FX_OFF = 0,     /* none on                                                          */
    VV_FX_RAN,         /* the ray pass with object IDs traced them: the list has reasons    */
    VV_FX_IGNORED      /* on, but the method does not take them (leaf IDs, z-buffer, none)  */
} vv_fx_state;

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
    vc_effects fx;                /* the effects on (bits) and their light and fog        */
    vv_fx_state fx_state;         /* what the last cull did with them                     */
    uint32_t fx_traced;           /* with VV_FX_RAN: the bits that pass traced (the keys may
                                     have changed fx.bits since, while culling is frozen)  */
    uint32_t *see_through;        /* VV_MAX_PASS^2 * VC_SEE_THROUGH_LAYERS                */
    uint32_t *reflection, *shadow; /* VV_MAX_PASS^2 each                                  */
    vis_effect_entry *fx_entries; /* with VV_FX_RAN: the list with reasons, parallel to
                                     entries (entries[i].pixels = its direct pixels)      */
    uint32_t fx_objects[VIS_REASON_COUNT]; /* with VV_FX_RAN: entries with reason bit i   */
    uint32_t fx_only[VIS_REASON_COUNT];    /* and of those, entries without a direct pixel */
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
 * through vis_camera_from_matrices -> the method's draw list (with c->fx.bits and the ray
 * pass with object IDs: the effects pass and its list with reasons). Prints the library's
 * message and returns VV_EXIT_FAILURE on failure. */
int vv_cull_run(vv_cull *c, const vv_view *view);

/* After an edit: the draw list may need more room (objects were added). */
int vv_cull_grow(vv_cull *c);

/* Why the current method ignores effects ("the z-buffer culler does not trace them", ...),
 * or NULL when it takes them. */
const char *vv_cull_effects_ignored_by(const vv_cull *c);

/* The backend info of the active context. */
const vis_backend_info *vv_cull_backend(const vv_cull *c);

#endif
