/*
 * world_scene.h — the bridge from a voxelworld world to a libvis scene.
 *
 * The scene covers the world's box (scene origin = world origin, size = world size, split
 * planes on chunk boundaries); each non-empty chunk is one object, ID vw_chunk_object_id(),
 * whose mesh is the chunk's greedy quads. Edits go through world_scene_update(): the world's
 * dirty chunks are remeshed and their objects replaced in place (libvis never rebuilds the
 * tree). A world_scene reuses one vw_mesh and one quad buffer, so an update allocates nothing
 * here once they have grown to the largest chunk mesh seen.
 *
 * Not thread safe: one thread at a time per world_scene (and per world while updating).
 * Nothing here prints.
 */
#ifndef VIS_TOOLS_WORLD_SCENE_H
#define VIS_TOOLS_WORLD_SCENE_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"
#include "voxelworld/vw.h"

typedef struct world_scene world_scene;

typedef struct world_scene_options {
    uint32_t kd_depth;          /* 0: the libvis default (a leaf is one chunk)               */
    uint32_t mesh_threads;      /* create meshes chunks on this many threads (vw_mesh_chunks;
                                   0 or 1: one), on a helper thread beside the uploads of the
                                   batch before; the scene is the same for any count          */
    vw_progress_fn progress;    /* may be NULL; called with stage "meshing", 0..1            */
    void *progress_user;
} world_scene_options;

/* Where the time went in a create or an update (accumulated over the chunks it touched). */
typedef struct world_scene_stats {
    uint32_t chunks;            /* chunks looked at (dirty ones, for an update)              */
    uint32_t objects_set;       /* vis_scene_set_object calls                                */
    uint32_t objects_removed;   /* objects removed (chunk became empty)                      */
    uint64_t quads;             /* quads handed to libvis                                    */
    double mesh_ms;             /* in vw_mesh_chunk(s) and converting the quads for libvis (on
                                   create, beside scene_ms: they overlap)                       */
    double scene_ms;            /* in vis_scene_set_object / vis_scene_remove_object         */
    double total_ms;            /* the whole call                                            */
} world_scene_stats;

/* Called for every chunk an update or create hands to libvis (mesh->count == 0: removed).
 * The mesh is only valid during the call. */
typedef void (*world_scene_chunk_fn)(uint32_t chunk_index, uint32_t object_id, const vw_mesh *mesh,
                                     void *user);

/* Creates the scene on `ctx` and meshes every non-empty chunk of `world` into it, then
 * clears the world's dirty set. `options` and `stats` may be NULL. On failure returns -1
 * with a message in err (may be NULL) and creates nothing. The world must outlive the
 * world_scene; it is not owned. */
int world_scene_create(vis_context *ctx, vw_world *world, const world_scene_options *options,
                       world_scene **out, world_scene_stats *stats, vw_error *err);

/* May be NULL. Destroys the scene (not the world). */
void world_scene_destroy(world_scene *ws);

vis_scene *world_scene_scene(const world_scene *ws);
vw_world *world_scene_world(const world_scene *ws);
vis_context *world_scene_context(const world_scene *ws);

/* Objects currently in the scene (non-empty chunk meshes). */
uint32_t world_scene_object_count(const world_scene *ws);

/* Takes the world's dirty chunks, remeshes each and replaces its object (an empty mesh
 * removes it). `stats` may be NULL. Returns 0, or -1 with a message in err. */
int world_scene_update(world_scene *ws, world_scene_stats *stats, vw_error *err);

/* The hook called for each chunk handed to libvis (NULL to clear). */
void world_scene_set_chunk_hook(world_scene *ws, world_scene_chunk_fn fn, void *user);

/* Calls fn for every object in the scene with its current chunk mesh (remeshed now, from
 * the world), in ascending ID order. For tools that need the same geometry elsewhere
 * (Embree, exporters). Returns 0, or -1 with a message in err. */
int world_scene_for_each_object(world_scene *ws, world_scene_chunk_fn fn, void *user, vw_error *err);

/* vw_quad (world-origin-relative voxels) -> vis_quad (scene-local floats, material flags
 * mapped to VIS_PRIM_*). Exact for coordinates below 2^24. */
void world_scene_convert_quads(const vw_quad *in, size_t count, vis_quad *out);

/* A vis_query_solid_fn over the world's voxels, `user` being the world_scene: the box of
 * scene-local cells is solid when vw_world_box_opaque says every voxel in it is opaque (the
 * scene's origin is the world's). Reads the world only: safe on the query's threads while
 * nothing edits it. */
int world_scene_solid(void *user, const int32_t lo[3], const int32_t hi[3]);

/* The scene bounds in world units (double): min = world origin, max = origin + size. */
void world_scene_bounds(const vw_world *world, double out_min[3], double out_max[3]);

#endif
