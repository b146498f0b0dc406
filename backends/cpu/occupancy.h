/* occupancy.h — which kd-tree subtrees hold any primitive, kept by the CPU backend.
 *
 * A packet of rays skips a whole empty subtree (air above the terrain, buried rock) in one
 * test instead of walking down to its empty leaves. The tree's shape never changes, so the
 * parent links are made once; an edit only changes leaves, and only the ancestors of a
 * changed leaf are looked at again. */
#ifndef VIS_CPU_OCCUPANCY_H
#define VIS_CPU_OCCUPANCY_H

#include <stdint.h>

#include "backend.h"

typedef struct vis_occupancy {
    const vis_allocator *alloc; /* set by the owner before the first sync                  */
    uint32_t node_count, leaf_count;
    uint32_t *parent;    /* node -> parent; the root's is UINT32_MAX                      */
    uint32_t *leaf_node; /* leaf -> its node                                                */
    uint8_t *occupied;   /* node -> 1 when a leaf below it holds a primitive                */
} vis_occupancy;

/* Brings *occ up to date with the view: everything when `changes->full` or the tree's size
 * differs, else the changed leaves and their ancestors. VIS_ERROR_OUT_OF_MEMORY leaves *occ
 * emptied. */
vis_status vis_occupancy_sync(vis_occupancy *occ, const vis_scene_view *view, const vis_scene_changes *changes);

void vis_occupancy_free(vis_occupancy *occ);

/* Bytes allocated. */
static inline uint64_t vis_occupancy_bytes(const vis_occupancy *occ)
{
    return (uint64_t)occ->node_count * (sizeof *occ->parent + sizeof *occ->occupied) +
           (uint64_t)occ->leaf_count * sizeof *occ->leaf_node;
}

#endif /* VIS_CPU_OCCUPANCY_H */
