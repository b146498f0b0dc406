/* scene_compact.c — compacting a primitive pool whose freed leaf slots have piled up
 * (slot_free.h, vis_slot_should_compact): every leaf's slot is copied, in leaf order, to a new
 * array holding the live entries and 1/16 more, the free lists are emptied, and every moved
 * leaf is marked for the backends. It runs after an edit, and set_object_growth counts what
 * it gives back, so an edit's change in bytes stays exactly what was predicted. */
#include <string.h>

#include "scene.h"

/* One pool's slots as leaves hold them. */
typedef struct pool_ref {
    void **data;
    uint32_t *used, *cap;
    size_t elem;
    vis_slot_free *free;
    int tris; /* 0: the quad pool, 1: the triangle pool */
} pool_ref;

static uint32_t slot_cap(const vis_scene *s, uint32_t li, int tris)
{
    return tris ? s->leaf_host[li].tri_cap : s->leaf_host[li].quad_cap;
}

/* Moves leaf li's slot to `to`. */
static void move_slot(vis_scene *s, uint32_t li, int tris, uint32_t to)
{
    vis_flat_leaf *lf = &s->leaves[li];
    vis_leaf_host *lh = &s->leaf_host[li];
    if (tris) {
        lf->tri_offset = to;
        return;
    }
    /* The table, packed and loose quads keep their places within the slot. */
    uint32_t from = lh->quad_slot;
    lf->table_offset = lf->table_offset - from + to;
    lf->quad_offset = lf->quad_offset - from + to;
    lh->quad_slot = to;
}

static uint32_t slot_offset(const vis_scene *s, uint32_t li, int tris)
{
    return tris ? s->leaves[li].tri_offset : s->leaf_host[li].quad_slot;
}

static void compact(vis_scene *s, const pool_ref *p)
{
    uint64_t used = *p->used, live = used - p->free->entries;
    uint64_t cap = vis_slot_compact_cap(live, *p->cap);
    char *fresh = vis_alloc(s->ctx, (size_t)cap * p->elem);
    if (!fresh)
        return; /* the pool stays as it is: nothing is lost, it is only larger */
    const char *old = *p->data;
    uint32_t at = 0;
    for (uint32_t li = 0; li < s->leaf_count; ++li) {
        uint32_t n = slot_cap(s, li, p->tris);
        if (!n)
            continue;
        memcpy(fresh + (size_t)at * p->elem, old + (size_t)slot_offset(s, li, p->tris) * p->elem, (size_t)n * p->elem);
        move_slot(s, li, p->tris, at);
        vis_scene_mark_leaf(s, li);
        at += n;
    }
    vis_free(s->ctx, *p->data);
    *p->data = fresh;
    *p->cap = (uint32_t)cap;
    *p->used = at;
    memset(p->free, 0, sizeof *p->free);
}

void vis_scene_compact_pools(vis_scene *s)
{
    pool_ref quads = {(void **)&s->quads, &s->quad_used, &s->quad_cap, sizeof *s->quads, &s->quad_free, 0};
    pool_ref tris = {(void **)&s->tris, &s->tri_used, &s->tri_cap, sizeof *s->tris, &s->tri_free, 1};
    if (vis_slot_should_compact(s->quad_used, s->quad_free.entries))
        compact(s, &quads);
    if (vis_slot_should_compact(s->tri_used, s->tri_free.entries))
        compact(s, &tris);
}
