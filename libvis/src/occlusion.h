/* occlusion.h — internal: proving that every segment between two boxes is blocked by the
 * scene's opaque quads (the server queries' entity test, query.c). */
#ifndef VIS_OCCLUSION_H
#define VIS_OCCLUSION_H

#include "backend.h"

/* A box in scene-local coordinates, in double. */
typedef struct vis_occ_box {
    double lo[3], hi[3];
} vis_occ_box;

typedef enum vis_occ_result {
    VIS_OCC_SEEN = 0,   /* a segment from a point of E to a point of B is unblocked          */
    VIS_OCC_HIDDEN,     /* every segment from E to B crosses an opaque quad (proven)          */
    VIS_OCC_UNKNOWN     /* the ray limit (or the work stack) ran out first                    */
} vis_occ_result;

/* Where the caller says the world is solid (vis_query_desc.solid); fn NULL: never asked. */
typedef struct vis_occ_solid {
    vis_query_solid_fn fn;
    void *user;
} vis_occ_solid;

/* Decides E against B spending at most `limit` rays (a segment cast and a plane coverage test
 * count one each); adds the rays spent to *rays and the boxes asked of solid (may be NULL, and
 * solid_tests with it) to *solid_tests. On VIS_OCC_SEEN, witness (may be NULL) gets the
 * unblocked segment: its end in E (witness[0..2]) and its end in B (witness[3..5]). Reads the
 * scene's host arrays: the caller holds the scene's lock shared. Allocates nothing; safe to
 * call from several threads (solid->fn then is too). */
vis_occ_result vis_occ_test(const vis_scene_view *view, const vis_occ_box *eye, const vis_occ_box *target,
                            uint32_t limit, const vis_occ_solid *solid, uint32_t *rays, uint64_t *solid_tests,
                            double witness[6]);

/* One segment from a to b (scene-local): 1 when it crosses no opaque primitive, 0 otherwise;
 * hit_point (may be NULL) gets the blocking hit. See-through quads (VIS_PRIM_SEE_THROUGH)
 * are passed through, up to 8 layers. The baselines of `vis query` use it too. */
int vis_occ_segment_clear(const vis_scene_view *view, const double a[3], const double b[3], double hit_point[3]);

#endif
