/* kdtree.h — internal: building the fixed-depth tree and locating boxes in it. */
#ifndef VIS_KDTREE_H
#define VIS_KDTREE_H

#include "scene.h"

#define VIS_KD_MAX_BUCKET_EXTENT 4096u
#define VIS_KD_NO_BUCKETS 0xFFFFFFFFu
#define VIS_ROPE_MAX_HEIGHT VIS_SHORT_STACK_MAX /* nodes up to this height get ropes */

/* Depth at which every leaf is a single cell. */
uint32_t vis_kdtree_full_depth(const uint32_t cells[3]);

/* Builds nodes and (empty) leaves over s->desc, and the ropes (never changed afterwards);
 * sets s->kd_depth, node, leaf and rope counts. */
vis_status vis_kdtree_build(vis_scene *s);

/* Leaf indices overlapped by the box (see kdtree.c for the boundary rule). Writes at most
 * `cap` and returns the total count. */
uint32_t vis_kdtree_leaves_of_box(const vis_scene *s, const float lo[3], const float hi[3], uint32_t *out, uint32_t cap);

#endif
