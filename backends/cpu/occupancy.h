/* occupancy.h — what each kd-tree subtree holds, kept by the CPU backend for the packets.
 *
 * A packet of rays skips a whole empty subtree (air above the terrain, buried rock) in one
 * test instead of walking down to its empty leaves. A subtree that holds something also tells
 * where on the vertical axis (y) its primitives lie inside its box: a kd cell spans its
 * parent's whole height until the tree splits y, so without it a tile of sky walks down to the
 * leaves of every column under its frustum before their content boxes turn it away
 * (docs/performance.md, "Subtrees' heights"). The tree's shape never changes, so the parent
 * links are made once; an edit only changes leaves, and only the ancestors of a changed leaf
 * are looked at again. */
#ifndef VIS_CPU_OCCUPANCY_H
#define VIS_CPU_OCCUPANCY_H

#include <stdint.h>

#include "backend.h"

/* A subtree's fill: nothing (lo > hi), or primitives whose parts inside the node's box lie
 * between vis_node_fill_lo and vis_node_fill_hi on y. lo and hi are 255ths of the node's own
 * extent on y, rounded outward: two bytes a node. */
typedef struct vis_node_fill {
    uint8_t lo, hi;
} vis_node_fill;

#define VIS_NODE_EMPTY ((vis_node_fill){255u, 0u})

static inline int vis_node_filled(vis_node_fill f) { return f.lo <= f.hi; }

/* The fill's bounds as floats, for a node whose box spans [y0, y1] on y. The encoding checks
 * them against these very expressions, so they never cut into the true extent. */
static inline float vis_node_fill_lo(vis_node_fill f, float y0, float y1)
{
    return f.lo == 0u ? y0 : y0 + (y1 - y0) * ((float)f.lo * (1.0f / 255.0f));
}

static inline float vis_node_fill_hi(vis_node_fill f, float y0, float y1)
{
    return f.hi == 255u ? y1 : y0 + (y1 - y0) * ((float)f.hi * (1.0f / 255.0f));
}

typedef struct vis_occupancy {
    const vis_allocator *alloc; /* set by the owner before the first sync                  */
    uint32_t node_count, leaf_count;
    uint32_t *parent;    /* node -> parent; the root's is UINT32_MAX                      */
    uint32_t *leaf_node; /* leaf -> its node                                                */
    vis_node_fill *fill; /* node -> what its subtree holds                                  */
} vis_occupancy;

/* Brings *occ up to date with the view: everything when `changes->full` or the tree's size
 * differs, else the changed leaves and their ancestors. On failure *occ is left emptied:
 * VIS_ERROR_OUT_OF_MEMORY, or VIS_ERROR_BACKEND for a tree too deep for the full build's
 * stack (a path of about 128 nodes; kdtree.c builds at most 90 levels). */
vis_status vis_occupancy_sync(vis_occupancy *occ, const vis_scene_view *view, const vis_scene_changes *changes);

void vis_occupancy_free(vis_occupancy *occ);

/* Bytes allocated. */
static inline uint64_t vis_occupancy_bytes(const vis_occupancy *occ)
{
    return (uint64_t)occ->node_count * (sizeof *occ->parent + sizeof *occ->fill) +
           (uint64_t)occ->leaf_count * sizeof *occ->leaf_node;
}

#endif /* VIS_CPU_OCCUPANCY_H */
