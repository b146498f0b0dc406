/* labels.h — the voxel labels of the CPU's label walk (trace_core.h, vis_label_walk), kept
 * by the CPU backend beside its subtree fills (occupancy.h).
 *
 * Built from each leaf's own packed quads at the backend's sync: every leaf at a full sync
 * (on the backend's threads), the changed leaves otherwise. A leaf's block is rewritten in
 * place when it still fits, appended otherwise; the array grows by an eighth at a time and is
 * copied out to what the blocks need and a sixteenth more after a full build and whenever the
 * blocks left behind pass an eighth of it, so its size stays within about 1.3 times what the
 * leaves hold now, and never past the bytes the sync allows it (the scene's max_bytes less
 * what the scene and the subtree fills hold). */
#ifndef VIS_CPU_LABELS_H
#define VIS_CPU_LABELS_H

#include <stddef.h>
#include <stdint.h>

#include "backend.h"

typedef struct vis_labels {
    const vis_allocator *alloc; /* set by the owner before the first sync                   */
    uint32_t leaf_count;
    uint32_t *words;   /* [0, leaf_count): each leaf's block offset (0: none); the blocks    */
    size_t used, cap;  /* words in use (the offsets included) and allocated                  */
    size_t stale;      /* words of blocks no leaf points at any more                         */
    uint32_t labelled; /* leaves with a block                                                */
    vis_status failed; /* VIS_OK, or why the labels could not have their memory: none (the
                          plane walk traces every leaf, the same buffers) until a full sync,
                          another leaf count, or a sync allowing more than failed_room and
                          an eighth                                                          */
    uint64_t failed_room; /* the bytes the failed sync allowed                               */
} vis_labels;

/* The words of one leaf's block at most: the header, and two words of loud bits and two of
 * labels for each of the 64 bricks. */
#define VIS_LABELS_MAX_BLOCK (6u + 4u * 64u)

/* The words of a block (trace_core.h, "the CPU's label walk"), from its header. */
static inline uint32_t vis_labels_block_words(const uint32_t *block)
{
    return VIS_LW_HEADER + 2u * vis_popcount64(vis_lw_u64(block)) + 2u * vis_popcount64(vis_lw_u64(block + 2));
}

/* Writes leaf lf's block (trace_core.h, "the CPU's label walk") to out, which holds
 * VIS_LABELS_MAX_BLOCK words, and returns its word count; 0 when the leaf does not take the
 * label walk (not 16 voxels a side, not one object's packed quads alone, material flags, or
 * no labelling exists). */
uint32_t vis_labels_build_leaf(const vis_flat_leaf *lf, const uint32_t *buckets, const uint32_t *quads,
                               uint32_t *out);

/* Runs job(i, arg) for i in [0, count) on the backend's threads (vis_parallel_for_fn's
 * contract) and returns when all have finished. */
typedef void (*vis_labels_run_fn)(void *user, uint32_t count, void (*job)(uint32_t index, void *arg), void *arg);

/* Brings *lab up to date with the view: every leaf when `changes->full` or the leaf count
 * differs (their blocks built on run's threads; run NULL: on the calling thread), else the
 * changed leaves. The array is held to max_bytes (UINT64_MAX: no limit; a full build's
 * short-lived reservation is not counted; a partial sync copies the live blocks out before it
 * gives up on a block that does not fit). VIS_ERROR_BUDGET when the blocks would take more,
 * VIS_ERROR_OUT_OF_MEMORY when the memory cannot be had: either leaves *lab empty and
 * `failed` (no leaf labelled: the plane walk traces every leaf), which a partial sync retries
 * only once max_bytes has grown past failed_room by an eighth. The labels are only an
 * acceleration, so the caller may trace on. */
vis_status vis_labels_sync(vis_labels *lab, const vis_scene_view *view, const vis_scene_changes *changes,
                           uint64_t max_bytes, vis_labels_run_fn run, void *run_user);

/* Bytes allocated. */
static inline uint64_t vis_labels_bytes(const vis_labels *lab) { return (uint64_t)lab->cap * sizeof(uint32_t); }

void vis_labels_free(vis_labels *lab);

#endif /* VIS_CPU_LABELS_H */
