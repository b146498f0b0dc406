/*
 * zcull.h — internal: the software z-buffer occlusion culler (the comparison to the ray pass).
 *
 * Two layers:
 *  - zcull_raster.c: a depth target (8x8 tiles, each tile's 64 floats contiguous, with the
 *    farthest depth of each tile kept beside it), convex-polygon rasterisation with half-plane
 *    edge functions and tiled traversal, the homogeneous clipper, and the box tests. It needs
 *    nothing from the rest of libvis, so its unit tests link it alone.
 *  - zcull.c: the public vis_zcull_* API: occluder selection front to back, the per-frame
 *    scratch, the draw list.
 *
 * Conventions (see docs/zcull.md for the reasoning):
 *  - Screen space is continuous pixels, x right, y down, the buffer's top-left corner at
 *    (0, 0); pixel (X, Y) is sampled at its centre (X + 0.5, Y + 0.5), exactly the centre the
 *    ray pass shoots its ray through.
 *  - Depth is 1/w with w the camera-space distance along the forward axis ("reverse": larger
 *    is nearer, 0 is nothing). Stored occluder depth is never nearer than the true surface
 *    at that pixel centre; box depths are never farther than the box's nearest point.
 *  - Vertices are snapped to 2^-f of a pixel (f = sub_bits, 11..16, see vis_zc_target_init)
 *    inside a guard band of +-2^k pixels (k = guard_bits).
 */
#ifndef VIS_ZCULL_H
#define VIS_ZCULL_H

#include <stddef.h>
#include <stdint.h>

#include "common/trace_core.h"

#define VIS_ZC_TILE 8u          /* tile edge in pixels                                     */
#define VIS_ZC_TILE_PIXELS 64u
#define VIS_ZC_MAX_VERTS 16     /* a quad clipped by the near plane and 4 guard planes: 9   */

/* The inner-loop implementations. All give bit-identical buffers. */
typedef enum vis_zc_simd {
    VIS_ZC_SIMD_AUTO = 0,  /* the best the CPU supports                                     */
    VIS_ZC_SIMD_SCALAR,    /* plain C: the reference                                        */
    VIS_ZC_SIMD_SSE2,
    VIS_ZC_SIMD_AVX2
} vis_zc_simd;

/* Resolves AUTO (and anything the CPU cannot run) to a supported path. */
vis_zc_simd vis_zc_simd_resolve(vis_zc_simd wanted);
const char *vis_zc_simd_name(vis_zc_simd simd);

/* A depth target. The caller owns the arrays (sizes from vis_zc_target_sizes). */
typedef struct vis_zc_target {
    uint32_t width, height;   /* pixels                                                      */
    uint32_t tiles_x, tiles_y;
    int sub_bits;             /* f: vertices snap to 2^-f pixel                               */
    int guard_bits;           /* k: snapped coordinates stay within +-2^k pixels               */
    vis_zc_simd simd;         /* resolved                                                     */
    float *depth;             /* tiles_x*tiles_y*64, tile-major; pixels beyond the buffer's
                                 right/bottom edge hold FLT_MAX so they never lower a tile's
                                 farthest depth                                                */
    float *tile_min;          /* tiles_x*tiles_y: the farthest (smallest) depth of each tile  */
    uint32_t *count;          /* coverage-count mode when non-NULL (tests): each covered pixel
                                 is incremented and depth is left alone; tile-major like depth */
    /* statistics since the last clear */
    uint64_t polygons;        /* polygons that reached traversal                              */
    uint64_t tiles;           /* tiles written                                                */
} vis_zc_target;

/* Floats needed for the depth and tile arrays of a width x height target. */
void vis_zc_target_sizes(uint32_t width, uint32_t height, size_t *depth_floats, size_t *tile_floats);

/* Sets the sizes and fixed-point format (1 <= width, height <= 16384) and attaches the
 * arrays; call vis_zc_target_clear before drawing. */
void vis_zc_target_init(vis_zc_target *t, uint32_t width, uint32_t height, float *depth, float *tile_min,
                        uint32_t *count, vis_zc_simd simd);
void vis_zc_target_clear(vis_zc_target *t);

/* Index of pixel (x, y) in the tile-major arrays. */
static inline size_t vis_zc_pixel_index(const vis_zc_target *t, uint32_t x, uint32_t y)
{
    return ((size_t)(y >> 3) * t->tiles_x + (x >> 3)) * VIS_ZC_TILE_PIXELS + (y & 7u) * 8u + (x & 7u);
}

/* ---- rasterisation ------------------------------------------------------------------- */

/* A convex polygon already in fixed point: vertex i at (x[i], y[i]) in units of 2^-f pixel
 * (|x|, |y| <= 2^(k+f)), either winding. Edge i runs from vertex i to i+1 and is shrunk by
 * margin[i] >= 0 edge-function units (0: exact top-left rule). Stored depth at the centre of
 * pixel (X, Y) is za*(X+0.5) + zb*(Y+0.5) + zc, evaluated as the traversal does (see
 * zcull_raster.c). Returns 1 when the polygon reached traversal, 0 when it covers no pixel
 * centre by construction (zero area, outside the buffer). */
typedef struct vis_zc_fixed_poly {
    int n;
    int64_t x[VIS_ZC_MAX_VERTS], y[VIS_ZC_MAX_VERTS];
    int64_t margin[VIS_ZC_MAX_VERTS];
    double za, zb, zc;
} vis_zc_fixed_poly;

int vis_zc_draw_fixed(vis_zc_target *t, const vis_zc_fixed_poly *poly);

/* The camera as the culler uses it, all in double: for a camera-relative point P (scene
 * point minus eye, subtracted in double), hx = rx.P, hy = ry.P, w = rw.P, and the screen
 * position is (hx/w, hy/w) in pixels, matching the ray pass's pixel-centre convention. */
typedef struct vis_zc_view {
    double eye[3];            /* scene-local                                                  */
    double rx[3], ry[3], rw[3];
    double near_dist, far_dist;
    double guard;             /* 2^k pixels                                                    */
    double err_scale;         /* |rx|_1 + |ry|_1 + guard * |rw|_1: scales the rounding bound   */
    double width, height;
} vis_zc_view;

/* f, r, u: the camera's orthonormal forward, right and up vectors (double, as
 * vis_camera_frame has them); tan_half_fovy > 0; aspect is the target's width/height. */
void vis_zc_view_make(vis_zc_view *v, const vis_zc_target *t, const double eye[3], const double f[3],
                      const double r[3], const double u[3], double tan_half_fovy, double near_dist,
                      double far_dist);

/* A planar convex polygon (n <= 4 vertices), camera-relative, in double: clipped against the
 * near plane (w >= near) and, only where the fixed-point range would overflow, the guard
 * band; then snapped, shrunk by a bound on the snapping and rounding error so that no pixel
 * centre outside the exact polygon is ever covered, and drawn with a conservative 1/w plane.
 * Returns the number of polygons that reached traversal (0 or 1). */
int vis_zc_draw_polygon(vis_zc_target *t, const vis_zc_view *v, const double (*p)[3], int n);

/* Occluder primitives in scene-local coordinates (the eye is subtracted in double). */
int vis_zc_draw_quad(vis_zc_target *t, const vis_zc_view *v, const vis_flat_quad *q);
int vis_zc_draw_tri(vis_zc_target *t, const vis_zc_view *v, const vis_flat_tri *tri);

/* ---- box tests ----------------------------------------------------------------------- */

typedef enum vis_zc_box_class {
    VIS_ZC_BOX_CULLED = 0,  /* behind the eye, beyond far, or covering no pixel centre      */
    VIS_ZC_BOX_NEAR,        /* reaches in front of the near plane (or holds the eye): visible */
    VIS_ZC_BOX_ON_SCREEN    /* rect and iw are valid: test with vis_zc_rect_visible          */
} vis_zc_box_class;

/* The pixels whose centres the box's projection may cover (inclusive, clamped to the
 * buffer), and the box's nearest depth 1/w_min rounded up. */
typedef struct vis_zc_rect {
    int32_t x0, y0, x1, y1;
    float iw;
} vis_zc_rect;

/* Classifies a scene-local box [lo, hi]; fills *rect when VIS_ZC_BOX_ON_SCREEN. dist (may be
 * NULL) receives the box's Euclidean distance from the eye (0 when the eye is inside). */
vis_zc_box_class vis_zc_box_classify(const vis_zc_target *t, const vis_zc_view *v, const float lo[3],
                                     const float hi[3], vis_zc_rect *rect, double *dist);

/* 1 when some pixel of the rect holds a depth no nearer than rect->iw (ties are visible). */
int vis_zc_rect_visible(const vis_zc_target *t, const vis_zc_rect *rect);

#endif /* VIS_ZCULL_H */
