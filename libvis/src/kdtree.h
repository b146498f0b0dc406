/* kdtree.h — internal: building the fixed-depth tree and locating boxes in it. */
#ifndef VIS_KDTREE_H
#define VIS_KDTREE_H

#include "scene.h"

#define VIS_KD_MAX_BUCKET_EXTENT 4096u
#define VIS_KD_NO_BUCKETS 0xFFFFFFFFu

#define VIS_KD_MAX_CELLS (1u << 30) /* cells per axis, at most                              */

/* Depth at which every leaf is a single cell. */
uint32_t vis_kdtree_full_depth(const uint32_t cells[3]);

/* What the tree over a desc (defaults filled in) will be, computed without building it.
 * Counts saturate at UINT64_MAX. */
typedef struct vis_kdtree_plan {
    uint32_t cells[3];
    uint32_t kd_depth;  /* the depth the build will use                                     */
    uint64_t nodes;     /* inner nodes + leaves                                             */
    uint64_t leaves;
    uint64_t ropes;     /* nodes at most VIS_MAX_SHORT_STACK levels above their deepest leaf */
    uint64_t bytes;     /* what vis_scene_info.bytes reports for the empty scene (no ropes)  */
} vis_kdtree_plan;

/* Fills *out from the desc's size, cell_size and kd_depth alone: its work grows with the
 * tree's depth, not its node count. VIS_ERROR_BUDGET when an axis has more than
 * VIS_KD_MAX_CELLS cells; VIS_ERROR_OUT_OF_MEMORY for its small scratch. Checks no limit on
 * nodes or bytes (the caller does). */
vis_status vis_kdtree_plan_make(vis_context *ctx, const vis_scene_desc *desc, vis_kdtree_plan *out);

/* Builds nodes and (empty) leaves of the plan over s->desc, the node-to-rope index (no ropes
 * yet) and the cell map; sets s->kd_depth, node and leaf counts. */
vis_status vis_kdtree_build(vis_scene *s, const vis_kdtree_plan *plan);

/* Builds the ropes (plan.ropes of them; never changed afterwards) unless the scene has them:
 * VIS_ERROR_BUDGET when they would take the scene past max_bytes, VIS_ERROR_OUT_OF_MEMORY,
 * failures reported on ctx, the scene then as before. Allocates through the scene's context.
 * The caller holds the scene's lock exclusive. */
vis_status vis_kdtree_build_ropes(vis_scene *s, vis_context *ctx);

/* Lowers the cell map's clearances (trace_core.h, VIS_CELL_CLEAR) around leaf li, which has
 * just got its first primitives, and widens the box of changed cells (s->dirty_map_lo/hi)
 * over them. Nothing without a cell map. */
void vis_kdtree_leaf_filled(vis_scene *s, uint32_t li);

/* Raises the clearances around leaf li, which has just lost its last primitive, to what the
 * cells around them hold now, and widens the box of changed cells over them. Nothing without
 * a cell map. */
void vis_kdtree_leaf_emptied(vis_scene *s, uint32_t li);

/* Leaf indices overlapped by the box (see kdtree.c for the boundary rule). Writes at most
 * `cap` and returns the total count. */
uint32_t vis_kdtree_leaves_of_box(const vis_scene *s, const float lo[3], const float hi[3], uint32_t *out, uint32_t cap);

#endif
