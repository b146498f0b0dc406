/* ref_trace.h — a double-precision reference for the ray pass, independent of the library.
 *
 * Nothing here uses libvis's ray code: the camera rays are made from the definition in the
 * comment above vis_camera in vis.h (basis, pixel centres, normalisation), in double; quads and
 * triangles are intersected in double, closed on their edges; the first hit is a brute force
 * over every primitive of every object as the test handed them to the scene (tworld), nearest
 * first, lowest ID on ties.
 *
 * The library works in float, so it cannot equal this reference bit for bit. It is held to it
 * under the conservative rule of docs/traversal.md ("Exactness"), with a rounding bound per
 * ray (ref_ray.err_o, err_d: how far the library's float ray may lie from this one) and per
 * face (ref_face_bound):
 *  - no slip: where the reference hits a face (also exactly on an edge or a corner), the
 *    library reports a hit no farther than that face's distance plus the bound. For a ray
 *    that is `strict` (the library's ray is this one, or its rounding is covered by the quad
 *    test's slack) that holds for every touch; otherwise a touch within the ray's own
 *    rounding of the face's boundary (where the library's float ray may pass on either side)
 *    is exempt;
 *  - no phantom: where the library reports object ID at t, the reference ray passes within the
 *    bound of a face of that object, at a distance within the bound of t. */
#ifndef VIS_TEST_REF_TRACE_H
#define VIS_TEST_REF_TRACE_H

#include <stddef.h>
#include <stdint.h>

#include "scene_builder.h"
#include "vis/vis.h"

/* A ray o + t d (d of unit length for camera rays), hits counted for t in [t_near, t_far]. */
typedef struct ref_ray {
    double o[3], d[3];
    double t_near, t_far;
    double err_o; /* |library origin - o| per component, at most                             */
    double err_d; /* |library direction - d| (unit vectors: the angle), at most               */
    int strict;   /* every touch of a face must be a hit (see above)                        */
} ref_ray;

/* A camera as vis.h defines it, in double, relative to a scene origin. */
typedef struct ref_camera {
    double eye[3], f[3], r[3], u[3];
    double tan_half, aspect, near_d, far_d;
    uint32_t width, height;
} ref_camera;

/* Returns 0 for a camera the library would reject (no direction, fovy outside (0, 180)). */
int ref_camera_make(const vis_camera *cam, const double scene_origin[3], uint32_t width, uint32_t height,
                    ref_camera *out);

/* The ray through the centre of pixel (x, y), with the bounds of the library's float setup.
 * The centre pixel of an odd-sized image with the eye exact in float is strict: its ray goes
 * exactly at the target, and the library's rounding of it is within the quad test's slack
 * (trace_core.h, vis_quad_intersect). */
void ref_camera_ray(const ref_camera *c, uint32_t x, uint32_t y, ref_ray *r);

/* A ray given in float, as the library holds it: the same ray exactly, err_o = err_d = 0,
 * strict. */
void ref_ray_from_float(const float o[3], const float d[3], float t_near, float t_far, ref_ray *r);

/* The first hit: t = +inf and id 0 when none. `obj`, `prim`: the object index in the world
 * and the primitive (quads first, then triangles) that gave it. */
typedef struct ref_hit {
    double t;
    uint32_t id;
    uint32_t obj, prim;
} ref_hit;

/* The ray against one primitive, in double. widen > 0 counts crossings up to that distance
 * outside the face (in its plane), widen < 0 only those at least -widen inside it. With
 * widen = 0 the faces are closed: a crossing exactly on an edge or corner is a hit (decided
 * with a margin of 2^-45 of the coordinates, far below any float rounding, so that double
 * rounding cannot turn an exact touch into a miss). Rays parallel to the face's plane never
 * hit it. */
int ref_quad(const ref_ray *r, const vis_quad *q, double widen, double *t_out);
int ref_triangle(const ref_ray *r, const vis_triangle *tr, double widen, double *t_out);

/* The rounding bound at distance t for a face whose plane meets the ray at cosine `cos_n`
 * (|d . n|, d of unit length): `ray`, how far in the plane the library's ray may cross from
 * the reference's; `in_plane`, that plus how far past a face the library's conservative quad
 * test reaches; `t`, how far apart the two hit distances may be. */
typedef struct ref_bound {
    double ray;
    double in_plane;
    double t;
} ref_bound;
ref_bound ref_face_bound(const ref_ray *r, double t, double cos_n);

/* The world as the reference sees it: the test's objects, each with its bounding box (only
 * to skip objects a ray cannot touch, or only beyond a hit already found; every primitive of
 * every other object is tested). Made again after the world changes; one thread at a time. */
typedef struct ref_scene {
    const tworld *w;
    double (*box)[6];   /* per object: lo[3], hi[3]                                          */
    struct ref_entry {
        double t;
        uint32_t obj;
    } *order;           /* scratch: the objects a ray touches, by box entry                   */
} ref_scene;

void ref_scene_init(ref_scene *s, const tworld *w);
void ref_scene_free(ref_scene *s);

/* Brute force over every primitive of every object. */
ref_hit ref_first_hit(const ref_scene *s, const ref_ray *r);

/* Where the library reports (id, t) -- id 0 = nothing, t ignored -- for the ray r: 0 when it
 * keeps the conservative rule, 1 for a slip (nothing, or only something farther than the
 * reference's first hit by more than the bound), 2 for a phantom (no face of `id` within the
 * bound of the ray near t). `why` (may be NULL) gets a message. `ref_out` (may be NULL) gets
 * the reference's first hit. */
int ref_check(const ref_scene *s, const ref_ray *r, uint32_t id, float t, ref_hit *ref_out, char *why, size_t cap);

/* Aiming (vt_rand streams): a corner of a random quad of w (half the time) or a point of one
 * of its edges at a multiple of 1/4 -- convex and concave voxel edges, seams between coplanar
 * quads, T-junctions --, scene-local; and an eye exact in float (a multiple of 1/64) in the
 * box around size[] widened by 16, at least 1 from p, sometimes in one of p's axis planes. */
void ref_edge_point(const tworld *w, uint64_t *rng, double p[3]);
void ref_random_eye(uint64_t *rng, const float size[3], const double p[3], double e[3]);
/* A float ray (o, d) aimed exactly at p. through != 0: o = p - k D with D an integer vector,
 * each component 0 with probability p_zero or else in [-dmax, dmax] (never all 0), and
 * k = (kden + [0, ksteps)) / kden dyadic -- exact in float while p and k D are small. Else an
 * eye of ref_random_eye and d = fl(normalize(p - e)). */
void ref_aimed_ray(uint64_t *rng, const float size[3], const double p[3], int through, double p_zero, int dmax,
                   int kden, int ksteps, float o[3], float d[3]);

#endif
