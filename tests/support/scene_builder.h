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
/* add_obj with room for nq quads (o->nq = nq), for the caller to fill. */
tobj *add_obj_quads(tworld *w, uint32_t id, uint32_t nq);
void obj_quad(tobj *o, uint32_t axis, float plane, float u0, float v0, float u1, float v1);
void obj_tri(tobj *o, const float a[3], const float b[3], const float c[3]);
/* The six faces of the box [lo, hi]. */
void obj_box(tobj *o, const float lo[3], const float hi[3]);
/* Frees the object's primitives and leaves it empty (its ID stays). */
void obj_clear(tobj *o);
void free_world(tworld *w);
/* An empty world of nx*ny*nz 16^3 chunks. */
void chunk_world_init(tworld *w, int nx, int ny, int nz);
/* A 32^3 world: a floor (object 1), a 1-voxel wall on the split plane x = 16 (object 2) and
 * a wall meeting it at a corner (object 3). */
void wall_world(tworld *w);
/* A 48^3 world holding a closed room: six 1-voxel walls, objects 1..6, that meet exactly at
 * edges and corners and enclose [lo, hi]^3, and a floor slab outside it, object 50. */
void room_world(tworld *w, float lo, float hi);
/* A CPU context running THREADS threads; fails the test on error. */
vis_context *make_cpu_ctx(uint32_t threads);
/* The same on the allocator a (NULL: the default), returning vis_context_create's status. */
vis_status cpu_ctx_create(uint32_t threads, const vis_allocator *a, vis_context **out);
/* An empty scene over [0, side]^3, otherwise the default desc; fails the test on error. */
vis_scene *make_cube_scene(vis_context *ctx, float side);
/* vis_scene_set_object with the object's mesh; fails the test on error. */
void set_obj(vis_scene *s, const tobj *o);
/* A scene over [0, w->size] (origin may be NULL) holding every object; fails the test on error. */
vis_scene *make_scene(vis_context *ctx, const tworld *w, const double origin[3], uint32_t kd_depth);
/* A scene of desc d holding every object of w; fails the test on error. */
vis_scene *make_scene_desc(vis_context *ctx, const tworld *w, const vis_scene_desc *d);

/* Random worlds (vt_rand streams, so a seed gives the same world everywhere). */
/* What a random chunk world holds (see random_chunk_world for the default). */
typedef struct chunk_world_opts {
    double empty;     /* the chance that a chunk stays empty                                  */
    int max_boxes;    /* 1 to max_boxes voxel boxes per chunk object                          */
    double touch;     /* the chance that a box's extent on an axis is pushed to the chunk's
                       * boundary (0: never, and no draw for it)                               */
    int any_face;     /* the chunk-boundary face (30 %) on a random axis and side, else x low  */
    int ties;         /* pairs of identical boxes under two IDs (100000 + 2i and + 2i + 1)     */
    int entity_boxes; /* each entity also gets an off-grid box across a chunk corner          */
} chunk_world_opts;
/* {0.3, 6, 0, 0, 4, 0}: random_chunk_world's worlds. */
extern const chunk_world_opts chunk_world_default;
/* 1 to opt->max_boxes random voxel boxes inside 16^3 chunk c, sometimes a face exactly on
 * its boundary. */
void obj_chunk_boxes(tobj *o, uint64_t *rng, const int c[3], const chunk_world_opts *opt);
/* An entity: two triangles sharing an edge and an off-grid quad, across chunk borders. */
void obj_entity(tobj *o, uint64_t *rng, const float size[3], const chunk_world_opts *opt);
/* nx*ny*nz chunks, 1 - opt->empty of them an object of obj_chunk_boxes (ID 1 + chunk
 * index), opt->ties pairs of identical boxes under two IDs (100000 + 2i and + 2i + 1: the
 * lowest ID must win) and four entities (200000 + i). */
void random_chunk_world_opts(tworld *w, uint64_t *rng, int nx, int ny, int nz, const chunk_world_opts *opt);
/* random_chunk_world_opts with chunk_world_default. */
void random_chunk_world(tworld *w, uint64_t *rng, int nx, int ny, int nz);
/* What a random view does; each "chance" is of one vt_rand_unit draw. */
typedef struct view_opts {
    double split;       /* per axis: u < split puts the eye on a multiple of 16 (a split plane or
                         * chunk corner), else u < voxel on an integer (a voxel plane)          */
    double voxel;
    double target_snap; /* per axis: the chance the target is put on an integer (0: no draw)  */
    double axis;        /* u < axis: looking along an axis; else u < diagonal: along an exact
                         * diagonal (rays through cell corners)                                 */
    double diagonal;
    double far;         /* the chance of a far plane at 8, 16, 24 or 32 (0: no draw)          */
} view_opts;
/* {0.3, 0.3, 0, 0.2, 0.2, 0}: random_view's cameras. */
extern const view_opts view_default;
/* A camera looking into the box [origin, origin + size] from in or around it, fov 20 to 120
 * degrees, as opt says. */
void random_view_opts(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3],
                      const view_opts *opt);
/* random_view_opts with view_default: eyes sometimes on split planes and chunk corners,
 * sometimes looking along an axis. */
void random_view(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3]);

#endif
