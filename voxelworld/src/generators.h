/* generators.h — the procedural worlds behind "gen:NAME" specs (internal).
 *
 * A generator fills the world one chunk column at a time: the driver (spec.c) hands it a
 * zeroed C x H x C byte column, the generator writes voxels, and the driver stores each chunk
 * of the column straight into the world (uniform chunks cost nothing). So memory follows the
 * finished world, never the raw volume, and every voxel depends only on the seed, the size
 * and its coordinates relative to the world origin: the same spec gives a bit-identical world
 * wherever its origin lies. */
#ifndef VOXELWORLD_GENERATORS_H
#define VOXELWORLD_GENERATORS_H

#include <stdint.h>

#include "vw_internal.h"

/* Materials shared by the generators (colours and flags set by vwg_set_palette). */
enum {
    VWG_GRASS = 1,
    VWG_DIRT,
    VWG_STONE,
    VWG_SAND,
    VWG_WATER,   /* see-through, reflective */
    VWG_BEDROCK,
    VWG_SNOW,
    VWG_ASPHALT,
    VWG_CONCRETE,
    VWG_BRICK,
    VWG_GLASS,   /* see-through */
    VWG_WOOD,
    VWG_ROOF,
    VWG_FURNITURE,
    VWG_MAZE_WALL,
    VWG_MAZE_FLOOR,
    VWG_LEAVES   /* see-through (gen:terrain with trees) */
};

void vwg_set_palette(vw_world *world);

/* One chunk column: voxels (x0..x0+C-1, 0..H-1, z0..z0+C-1) relative to the origin, stored at
 * v[x + C*(y + H*z)] (local x, z) — for a fixed z the C*C bytes of one chunk are contiguous
 * in the world's own chunk layout. */
typedef struct vwg_column {
    int32_t x0, z0;
    int32_t c, h;
    uint8_t *v;
} vwg_column;

static inline uint8_t *vwg_at(const vwg_column *col, int32_t x, int32_t y, int32_t z)
{
    return &col->v[x + col->c * (y + col->h * z)];
}

/* fill may run on several threads at once for different columns (gen_run.c): it reads
 * `state` only, and writes only the column and `scratch`, this worker's own
 * vwg_*_worker_bytes() bytes (NULL when that is 0). A column's voxels depend on nothing but
 * the state and the column's position, never on what the scratch held before. */
typedef struct vwg_generator {
    void *state;
    void (*fill)(const void *state, void *scratch, vwg_column *column);
    void (*destroy)(void *state);
    uint64_t worker_bytes;  /* scratch each worker needs                                     */
} vwg_generator;

/* Each prepares a generator for `world` (its size is the generated size) and sets the
 * materials it uses. */
/* trees: percent of 8x8-voxel cells that try a tree (0..100; 0 = none, the default); a try
 * on beach, snow, an overhang or a cave entrance plants nothing. */
vw_status vwg_terrain_create(vw_world *world, uint64_t seed, int32_t trees, vwg_generator *out, vw_error *err);
vw_status vwg_city_create(vw_world *world, uint64_t seed, vwg_generator *out, vw_error *err);
vw_status vwg_maze_create(vw_world *world, uint64_t seed, vwg_generator *out, vw_error *err);

/* The most memory each generator allocates for itself (its state, at its peak) for a world
 * of `size` voxels (chunk multiples) and chunks of `chunk`, and the scratch each worker
 * needs (vwg_generator.worker_bytes; only the terrain has any): what the driver charges to
 * the budget before the world is made, next to the column buffers. Kept beside each
 * generator's allocations, which they bound. */
uint64_t vwg_terrain_scratch_bytes(const int32_t size[3], int32_t chunk);
uint64_t vwg_terrain_worker_bytes(const int32_t size[3], int32_t chunk);
uint64_t vwg_city_scratch_bytes(const int32_t size[3], int32_t chunk);
uint64_t vwg_maze_scratch_bytes(const int32_t size[3], int32_t chunk);

/* Runs a generator over every chunk column of `world` on up to `threads` workers (each with
 * a column buffer and worker_bytes of scratch, allocated here), storing each chunk straight
 * into the world; the world comes out bit-identical for every thread count. Progress is
 * reported on the calling thread, each whole percent once and only beyond progress->reported
 * (so a second run after a failed one goes on where the first stopped). Fails with the store's status (VW_ERROR_BUDGET
 * when the world's limit is reached) and no message, or VW_ERROR_OUT_OF_MEMORY with one for
 * the scratch. gen_run.c. */
typedef struct vwg_progress {
    vw_progress_fn fn;       /* may be NULL                                                    */
    void *user;
    int reported;            /* the last whole percent reported; -1 before the first call       */
} vwg_progress;
vw_status vwg_run(vw_world *world, const vwg_generator *gen, uint32_t threads, vwg_progress *progress, vw_error *err);

/* The column buffer of one worker: C x H bytes. */
static inline uint64_t vwg_column_bytes(int32_t chunk, int32_t height)
{
    return (uint64_t)chunk * (uint64_t)chunk * (uint64_t)height;
}

/* What vwg_run allocates for `threads` workers: a column buffer and the generator's
 * worker_bytes each, every worker's share on its own cache lines when there are several. */
static inline uint64_t vwg_run_stride(uint64_t column_bytes, uint64_t worker_bytes, uint32_t threads)
{
    const uint64_t share = column_bytes + worker_bytes;
    return threads > 1 ? (share + 63u) & ~(uint64_t)63u : share;
}

#endif
