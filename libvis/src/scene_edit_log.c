/* scene_edit_log.c — the scene's log of the boxes its last edits changed (scene.h,
 * vis_scene_edit_log).
 *
 * A reader that knows only the generation it last saw can tell that the scene changed, not
 * where; the log tells where, for the last VIS_SCENE_EDIT_LOG boxes. An edit of an object
 * changes nothing outside the hull of its box before and after (its quads and triangles lie
 * in those boxes; the kd-tree never changes, kdtree.c), so a ray that does not reach that hull
 * within its hit distance hits what it hit before. Consecutive edits of one box (a chunk
 * meshed again voxel by voxel) share an entry. */
#include <string.h>

#include "scene.h"

void vis_scene_log_edit(vis_scene *s, int have_old, const float old_lo[3], const float old_hi[3], int have_new,
                          const float new_lo[3], const float new_hi[3])
{
    vis_scene_edit_log *c = &s->edit_log;
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = have_old ? old_lo[a] : new_lo[a];
        hi[a] = have_old ? old_hi[a] : new_hi[a];
        if (have_old && have_new) {
            lo[a] = new_lo[a] < lo[a] ? new_lo[a] : lo[a];
            hi[a] = new_hi[a] > hi[a] ? new_hi[a] : hi[a];
        }
    }
    if (c->floor == 0)
        c->floor = s->generation; /* the first edit: everything since creation is held */
    ++s->generation;
    if (c->count) {
        vis_scene_edit_box *last = &c->ring[(c->head + VIS_SCENE_EDIT_LOG - 1) % VIS_SCENE_EDIT_LOG];
        if (last->last + 1 == s->generation && memcmp(last->lo, lo, sizeof lo) == 0 &&
            memcmp(last->hi, hi, sizeof hi) == 0) {
            last->last = s->generation;
            return;
        }
    }
    vis_scene_edit_box *e = &c->ring[c->head];
    if (c->count == VIS_SCENE_EDIT_LOG)
        c->floor = e->last; /* the oldest entry goes: readers from before its last edit lose */
    else
        ++c->count;
    e->first = e->last = s->generation;
    memcpy(e->lo, lo, sizeof lo);
    memcpy(e->hi, hi, sizeof hi);
    c->head = (c->head + 1) % VIS_SCENE_EDIT_LOG;
}

uint32_t vis_scene_edits_since(const vis_scene *s, uint64_t since, vis_scene_edit_box *out, uint32_t capacity)
{
    const vis_scene_edit_log *c = &s->edit_log;
    if (since >= s->generation)
        return 0;
    if (c->floor == 0 || since < c->floor)
        return UINT32_MAX;
    uint32_t n = 0;
    /* Newest first: entries are in generation order, so stop at the first one already seen. */
    for (uint32_t k = 0; k < c->count; ++k) {
        const vis_scene_edit_box *e = &c->ring[(c->head + VIS_SCENE_EDIT_LOG - 1 - k) % VIS_SCENE_EDIT_LOG];
        if (e->last <= since)
            break;
        if (n == capacity)
            return UINT32_MAX;
        out[n++] = *e;
    }
    return n;
}
