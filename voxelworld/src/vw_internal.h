/*
 * vw_internal.h — the world's storage, shared by the files of voxelworld (never installed).
 *
 * A world is a box of chunks_x * chunks_y * chunks_z chunks of edge C (16 or 32). Chunk
 * (cx, cy, cz), relative to the origin, is chunk[cx + nx*(cy + ny*cz)]. A chunk is either
 *   - uniform: voxels == NULL, every voxel is `uniform` (0 = all air) — no memory beyond the
 *     table entry, which is what lets a large world hold its >100,000 surface chunks plus
 *     millions of air and solid-rock chunks; or
 *   - dense: voxels points at C*C*C bytes, voxel (x, y, z) at x + C*(y + C*z) (rows along X
 *     are contiguous, which is what the mesher's 16-byte row compares want).
 *
 * Importers and generators that fill a world fast write dense arrays directly:
 *     uint8_t *v = vwi_chunk_dense(world, index);   // converts a uniform chunk lazily
 *     ... write v[x + C*(y + C*z)] ...
 *     vwi_chunk_settle(world, index);               // recounts; compacts if now uniform
 * or, for a chunk that is one value throughout, vwi_chunk_set_uniform(). These never mark
 * chunks dirty: a world handed out by a loader starts with no dirty chunks (its user meshes
 * everything once); only the public edit calls (vw_world_set, vw_world_fill) mark chunks.
 */
#ifndef VOXELWORLD_VW_INTERNAL_H
#define VOXELWORLD_VW_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "voxelworld/vw.h"

/* The OpenVDB shim (C++) fills worlds through this header too. */
#ifdef __cplusplus
extern "C" {
#endif

/* Limits checked by vw_world_create: a voxel axis up to 1<<20, and a chunk count whose
 * object IDs (index + 1) fit in uint32 with room to spare. */
#define VWI_MAX_AXIS        (1 << 20)
#define VWI_MAX_CHUNKS      0x7FFFFFFFu
/* Origins stay this far inside int64 so that origin + size never overflows. */
#define VWI_MAX_ORIGIN      ((int64_t)1 << 60)

typedef struct vwi_chunk {
    uint8_t *voxels;  /* NULL: uniform; else C^3 bytes (see above)                       */
    uint32_t solid;   /* voxels != 0 in this chunk (kept by set/fill/settle)             */
    uint8_t uniform;  /* the value of every voxel while voxels == NULL                   */
    uint8_t pooled;   /* voxels lies in a pool block (chunk_pool.c), not its own malloc   */
} vwi_chunk;

/* The pool's block: 2 MiB, the size of an x86-64 huge page. */
#define VWI_POOL_BLOCK ((size_t)2 << 20)

struct vw_world {
    int32_t chunk_size;   /* C                                                            */
    int32_t chunk_shift;  /* log2(C)                                                      */
    int64_t origin[3];
    int32_t size[3];      /* voxels, multiples of C                                       */
    int32_t chunks[3];
    uint32_t chunk_count;
    vwi_chunk *chunk;     /* chunk_count entries                                          */

    uint64_t *dirty;      /* one bit per chunk                                            */
    uint64_t *dirty_any;  /* one bit per word of `dirty` that is not 0: take_dirty reads only
                           * those words, not a bitmap of a quarter million chunks per edit */
    size_t dirty_count;

    /* Running totals, kept by vwi_chunk_account() so that vw_world_get_info is O(1).   */
    uint32_t nonempty_chunks;
    uint32_t dense_chunks;
    uint32_t heap_chunks;  /* dense chunks with an array of their own (not pooled)          */
    uint64_t solid_voxels;

    /* The chunk pool (chunk_pool.c): blocks linked through their first slot, the block
     * being carved, and pooled arrays given back. pool_on lets vwi_chunk_dense take new
     * blocks (set by the generator driver for large worlds); the free list is used always. */
    int pool_on;
    uint8_t *pool_blocks, *pool_next, *pool_free;
    uint32_t pool_left, pool_block_count;

    /* The limit on vwi_world_bytes(): vwi_chunk_dense refuses a chunk that would pass it.
     * A generator lowers it by its own scratch memory while it runs (spec.c).          */
    uint64_t max_bytes;

    vw_material material[256];
};

/* The chunk's dense array, converting a uniform chunk first. NULL when the conversion would
 * take the world past max_bytes or malloc fails; vwi_dense_failure says which. */
uint8_t *vwi_chunk_dense(vw_world *world, uint32_t index);
/* Why vwi_chunk_dense just returned NULL: VW_ERROR_BUDGET when one more dense chunk does not
 * fit under max_bytes, else VW_ERROR_OUT_OF_MEMORY. */
vw_status vwi_dense_failure(const vw_world *world);
/* Recounts a chunk after direct writes to its dense array and compacts it to uniform when
 * every voxel holds one value. */
void vwi_chunk_settle(vw_world *world, uint32_t index);
/* Records the solid count of a dense chunk whose array was written directly and is known
 * to mix values (so settling would not compact it): vwi_chunk_settle without the recount. */
void vwi_chunk_set_solid(vw_world *world, uint32_t index, uint32_t solid);
/* Makes the chunk uniform (freeing a dense array). */
void vwi_chunk_set_uniform(vw_world *world, uint32_t index, uint8_t value);

/* Marks one chunk dirty (no range check). */
void vwi_mark_dirty(vw_world *world, uint32_t index);

static inline uint32_t vwi_chunk_volume(const vw_world *w)
{
    return (uint32_t)w->chunk_size * (uint32_t)w->chunk_size * (uint32_t)w->chunk_size;
}

/* What a world of `chunk_count` chunks holds before any chunk is dense: the struct, the
 * chunk table and the dirty bits. vw_world_create, the loaders and the generators check
 * budgets with this one formula. */
static inline uint64_t vwi_table_bytes(uint64_t chunk_count)
{
    const uint64_t dirty_words = (chunk_count + 63) / 64;
    return (uint64_t)sizeof(vw_world) + chunk_count * (uint64_t)sizeof(vwi_chunk) +
           (dirty_words + (dirty_words + 63) / 64) * (uint64_t)sizeof(uint64_t);
}

/* Everything the world holds now (vw_world_info.bytes): pool blocks count whole, used or
 * not. */
static inline uint64_t vwi_world_bytes(const vw_world *w)
{
    return vwi_table_bytes(w->chunk_count) + (uint64_t)w->heap_chunks * vwi_chunk_volume(w) +
           (uint64_t)w->pool_block_count * VWI_POOL_BLOCK;
}

/* A pooled chunk array: from the free list, else the current block, else (when pool_on and
 * a whole block fits under max_bytes) a new block; NULL otherwise (the caller then mallocs
 * one array, or fails). Its contents are undefined. chunk_pool.c. */
uint8_t *vwi_pool_take(vw_world *world);
/* Puts a pooled array on the free list. */
void vwi_pool_give(vw_world *world, uint8_t *voxels);
/* Frees every block (vw_world_destroy). */
void vwi_pool_destroy(vw_world *world);

/* The budget with its defaults filled in (budget may be NULL). */
static inline vw_budget vwi_budget(const vw_budget *budget)
{
    vw_budget b = {VW_DEFAULT_MAX_BYTES, VW_DEFAULT_MAX_VOXELS};
    if (budget && budget->max_bytes)
        b.max_bytes = budget->max_bytes;
    if (budget && budget->max_voxels)
        b.max_voxels = budget->max_voxels;
    return b;
}

/* For messages: "16.0 GiB" (bytes below 1 KiB as "512 bytes"), and "4,194,304". Both
 * return `buf`, which should hold 32 chars. */
const char *vwi_format_bytes(uint64_t bytes, char *buf, size_t size);
const char *vwi_format_count(uint64_t count, char *buf, size_t size);

static inline uint32_t vwi_index(const vw_world *w, int32_t cx, int32_t cy, int32_t cz)
{
    return (uint32_t)cx + (uint32_t)w->chunks[0] * ((uint32_t)cy + (uint32_t)w->chunks[1] * (uint32_t)cz);
}

/* Index of the lowest set bit (x != 0). */
static inline int vwi_ctz64(uint64_t x)
{
#if defined(__GNUC__)
    return __builtin_ctzll(x);
#else
    int n = 0;
    while (!(x & 1)) {
        x >>= 1;
        n++;
    }
    return n;
#endif
}

/* Writes "fmt" into err (if any) and returns status: the one way errors leave this module. */
vw_status vwi_fail(vw_error *err, vw_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#ifdef __cplusplus
}
#endif

#endif /* VOXELWORLD_VW_INTERNAL_H */
