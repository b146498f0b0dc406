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
    VWG_MAZE_FLOOR
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

typedef struct vwg_generator {
    void *state;
    void (*fill)(void *state, vwg_column *column);
    void (*destroy)(void *state);
} vwg_generator;

/* Each prepares a generator for `world` (its size is the generated size) and sets the
 * materials it uses. */
vw_status vwg_terrain_create(vw_world *world, uint64_t seed, vwg_generator *out, vw_error *err);
vw_status vwg_city_create(vw_world *world, uint64_t seed, vwg_generator *out, vw_error *err);
vw_status vwg_maze_create(vw_world *world, uint64_t seed, vwg_generator *out, vw_error *err);

/* The most memory each generator allocates for itself (its state and scratch, at their
 * peak) for a world of `size` voxels (chunk multiples) and chunks of `chunk`: what the
 * driver charges to the budget before the world is made, next to the column buffer. Kept
 * beside each generator's allocations, which they bound. */
uint64_t vwg_terrain_scratch_bytes(const int32_t size[3], int32_t chunk);
uint64_t vwg_city_scratch_bytes(const int32_t size[3], int32_t chunk);
uint64_t vwg_maze_scratch_bytes(const int32_t size[3], int32_t chunk);

#endif
