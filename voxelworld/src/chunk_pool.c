/* chunk_pool.c — dense chunk arrays carved from 2 MiB blocks, for worlds that a generator
 * fills with a hundred thousand of them (see vw_internal.h).
 *
 * Why: one malloc per 4 KiB chunk means, for gen:large's half a gigabyte of dense chunks,
 * some 120,000 allocations and as many first-touch page faults, which on a virtual machine
 * cost more than the meshing itself; the scattered 4 KiB pages also cost TLB misses in the
 * mesher. Blocks of 2 MiB, aligned and advised as transparent huge pages where the system
 * offers them (Linux, madvise mode), fault in once per block.
 *
 * A block's first slot holds the link to the next block (so every byte the pool holds is in
 * its blocks, which the world charges to its budget whole); the other slots are chunk
 * arrays. A pooled array given back (its chunk became uniform) goes on a free list that
 * vwi_chunk_dense takes from first, in every world. */
#if defined(__linux__)
#define _DEFAULT_SOURCE /* madvise and MADV_HUGEPAGE are not in strict C11's <sys/mman.h> */
#endif
#include <stdlib.h>
#include <string.h>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "vw_internal.h"

static uint32_t slots_per_block(const vw_world *w)
{
    return (uint32_t)(VWI_POOL_BLOCK / vwi_chunk_volume(w));
}

uint8_t *vwi_pool_take(vw_world *w)
{
    if (w->pool_free) {
        uint8_t *v = w->pool_free;
        memcpy(&w->pool_free, v, sizeof w->pool_free);
        return v;
    }
    if (w->pool_left == 0) {
        if (!w->pool_on || vwi_world_bytes(w) + VWI_POOL_BLOCK > w->max_bytes)
            return NULL;
        uint8_t *block = aligned_alloc(VWI_POOL_BLOCK, VWI_POOL_BLOCK);
        if (!block)
            return NULL;
#if defined(__linux__) && defined(MADV_HUGEPAGE)
        madvise(block, VWI_POOL_BLOCK, MADV_HUGEPAGE); /* a hint: failure changes nothing */
#endif
        memcpy(block, &w->pool_blocks, sizeof w->pool_blocks);
        w->pool_blocks = block;
        w->pool_block_count++;
        w->pool_next = block + vwi_chunk_volume(w);
        w->pool_left = slots_per_block(w) - 1;
    }
    uint8_t *v = w->pool_next;
    w->pool_next += vwi_chunk_volume(w);
    w->pool_left--;
    return v;
}

void vwi_pool_give(vw_world *w, uint8_t *voxels)
{
    memcpy(voxels, &w->pool_free, sizeof w->pool_free);
    w->pool_free = voxels;
}

void vwi_pool_destroy(vw_world *w)
{
    uint8_t *block = w->pool_blocks;
    while (block) {
        uint8_t *next;
        memcpy(&next, block, sizeof next);
        free(block);
        block = next;
    }
    w->pool_blocks = NULL;
    w->pool_free = w->pool_next = NULL;
    w->pool_left = 0;
    w->pool_block_count = 0;
}
