/* drawlist.h — internal: the draw list from an ID buffer, for vis_drawlist_build and for the
 * CPU path of vis_trace_drawlist (trace_drawlist.c), which brings its own scratch. */
#ifndef VIS_DRAWLIST_H
#define VIS_DRAWLIST_H

#include <stddef.h>

#include "vis/vis.h"

struct vis_scene;

/* Bytes of scratch vis_drawlist_from_ids needs for the scene and mode. */
size_t vis_drawlist_scratch_bytes(const struct vis_scene *s, vis_id_mode mode);

/* vis_drawlist_build's work on n IDs with the caller's scratch `count`
 * (vis_drawlist_scratch_bytes); the scene's read lock held, arguments checked. */
vis_status vis_drawlist_from_ids(vis_context *ctx, const struct vis_scene *s, const uint32_t *ids, uint64_t n,
                                 vis_id_mode mode, uint32_t *count, vis_draw_entry *out, size_t capacity,
                                 size_t *out_count);

/* Heap sort by ID, in place, no allocation: n entries of `size` bytes (at most
 * VIS_SORT_MAX_ENTRY) whose first field is their uint32_t ID (vis_draw_entry,
 * vis_effect_entry). */
#define VIS_SORT_MAX_ENTRY 32u
_Static_assert(offsetof(vis_draw_entry, id) == 0 && offsetof(vis_effect_entry, id) == 0 &&
                   sizeof(vis_draw_entry) <= VIS_SORT_MAX_ENTRY && sizeof(vis_effect_entry) <= VIS_SORT_MAX_ENTRY,
               "vis_sort_by_id reads the ID first, in entries of at most VIS_SORT_MAX_ENTRY bytes");
void vis_sort_by_id(void *entries, size_t n, size_t size);

#endif
