/* scene_builder.h — test worlds of quads and triangles kept by the test itself, so that an
 * oracle can trace exactly what was handed to the scene. Shared by the trace, traversal and
 * OpenCL tests. */
#ifndef VIS_TEST_SCENE_BUILDER_H
#define VIS_TEST_SCENE_BUILDER_H

#include <stdint.h>

#include "vis/vis.h"

typedef struct tobj {
    uint32_t id;
    vis_quad *quads;
    uint32_t nq;
    vis_triangle *tris;
    uint32_t nt;
} tobj;

typedef struct tworld {
    tobj *objs;
    uint32_t n, cap;
    float size[3];
} tworld;

tobj *add_obj(tworld *w, uint32_t id);
void obj_quad(tobj *o, uint32_t axis, float plane, float u0, float v0, float u1, float v1);
void obj_tri(tobj *o, const float a[3], const float b[3], const float c[3]);
/* The six faces of the box [lo, hi]. */
void obj_box(tobj *o, const float lo[3], const float hi[3]);
/* Frees the object's primitives and leaves it empty (its ID stays). */
void obj_clear(tobj *o);
void free_world(tworld *w);
/* A 32^3 world: a floor (object 1), a 1-voxel wall on the split plane x = 16 (object 2) and
 * a wall meeting it at a corner (object 3). */
void wall_world(tworld *w);
/* A 48^3 world holding a closed room: six 1-voxel walls, objects 1..6, that meet exactly at
 * edges and corners and enclose [lo, hi]^3, and a floor slab outside it, object 50. */
void room_world(tworld *w, float lo, float hi);
/* A CPU context running THREADS threads; fails the test on error. */
vis_context *make_cpu_ctx(uint32_t threads);
/* vis_scene_set_object with the object's mesh; fails the test on error. */
void set_obj(vis_scene *s, const tobj *o);
/* A scene over [0, w->size] (origin may be NULL) holding every object; fails the test on error. */
vis_scene *make_scene(vis_context *ctx, const tworld *w, const double origin[3], uint32_t kd_depth);

/* Random worlds (vt_rand streams, so a seed gives the same world everywhere). */
/* 1 to 6 random voxel boxes inside 16^3 chunk c, sometimes a face exactly on its boundary. */
void obj_chunk_boxes(tobj *o, uint64_t *rng, const int c[3]);
/* An entity: two triangles sharing an edge and an off-grid quad, across chunk borders. */
void obj_entity(tobj *o, uint64_t *rng, const float size[3]);
/* nx*ny*nz chunks, 70 % of them an object of obj_chunk_boxes (ID 1 + chunk index), four
 * pairs of identical boxes under two IDs (100000 + 2i and + 2i + 1: the lowest ID must win)
 * and four entities (200000 + i). */
void random_chunk_world(tworld *w, uint64_t *rng, int nx, int ny, int nz);
/* A camera looking into the box [origin, origin + size] from in or around it: eyes sometimes
 * on split planes and chunk corners, sometimes looking along an axis, fov 20 to 120 degrees. */
void random_view(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3]);

#endif
