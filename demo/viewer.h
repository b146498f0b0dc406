/* viewer.h — what the parts of vis-viewer share: the options it was started with, the
 * culling state (method, backend, pass resolution, the draw list) and the fly camera. Each
 * .c file does one job: window.c (GLFW window and input), fly.c (the camera and its
 * matrices), cull.c (libvis calls per frame), meshes.c (chunk meshes on the GPU and the
 * draw), hud.c (bitmap-font text), overlays.c (ID/depth pictures, frustum and boxes),
 * edit.c (voxel edits through libvis picking), screenshot.c (PNG), script.c (the scripted
 * mode), main.c (set-up and the frame loop).
 *
 * The viewer is an application: it prints, to stderr, and exits with 0 (ok), 1 (a library,
 * GL or I/O failure) or 2 (bad arguments). */
#ifndef VIS_VIEWER_H
#define VIS_VIEWER_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

#define VV_EXIT_OK 0
#define VV_EXIT_FAILURE 1
#define VV_EXIT_USAGE 2

/* Culling methods the viewer switches between (key M). */
typedef enum vv_method {
    VV_METHOD_RAY_OBJECT = 0, /* ray pass, object IDs                                     */
    VV_METHOD_RAY_LEAF,       /* ray pass, kd-leaf IDs                                    */
    VV_METHOD_ZBUF,           /* the software z-buffer culler                             */
    VV_METHOD_NONE,           /* no culling: every object                                 */
    VV_METHOD_COUNT
} vv_method;

const char *vv_method_name(vv_method m);

/* The picture beside the frame (key O). */
typedef enum vv_overlay {
    VV_OVERLAY_NONE = 0,
    VV_OVERLAY_IDS,   /* the ray pass's ID buffer, a colour per ID                       */
    VV_OVERLAY_DEPTH, /* the z-buffer culler's depth buffer                               */
    VV_OVERLAY_COST,  /* the ray pass's traversal cost per pixel (vis_trace_cost), a heat map */
    VV_OVERLAY_COUNT
} vv_overlay;

/* A camera: eye and look-at target in absolute world coordinates, fovy in degrees. */
typedef struct vv_view {
    double eye[3];
    double target[3];
    double fovy_deg;
} vv_view;

/* Column-major 4x4 doubles, element (row r, column c) at [c*4 + r] (OpenGL's layout). */
typedef struct vv_mat4 {
    double m[16];
} vv_mat4;

#define VV_NEAR 0.1
#define VV_FAR 0.0 /* 0: the infinite far plane */

/* fly.c: the view matrix of a camera in absolute world coordinates (lookAt, +Y up, or
 * (0,0,-1) looking straight along Y as vis.h's eye/target form), and the OpenGL
 * perspective for an aspect (infinite far plane when far == 0). */
void vv_look_at(const vv_view *v, vv_mat4 *out);
void vv_perspective(double fovy_deg, double aspect, double near_d, double far_d, vv_mat4 *out);
void vv_mat4_mul(const vv_mat4 *a, const vv_mat4 *b, vv_mat4 *out);
/* The same view with its translation made relative to `origin` (for the GPU's floats). */
void vv_view_local(const vv_view *v, const double origin[3], vv_view *out);

/* Fly camera input: move along the view (forward, right, up, in world units), turn by yaw and
 * pitch (radians); orbit: turn the eye around the target. */
void vv_fly_move(vv_view *v, double forward, double right, double up);
void vv_fly_turn(vv_view *v, double yaw, double pitch);
void vv_orbit(vv_view *v, double yaw, double pitch, double zoom);

/* Parses "EX,EY,EZ,TX,TY,TZ[,FOVY]" as `vis --camera` takes it; 0 or -1. */
int vv_view_parse(const char *s, vv_view *out);

#endif
