/* drawlist.c — from an ID buffer to the draw list: unique object IDs, sorted, with pixel
 * counts; leaf IDs expand to every object of the leaf (the talk's conservative mode). */
#include <string.h>

#include "drawlist.h"
#include "scene.h"

/* Entry i's ID: the first field of every entry type sorted here. */
static uint32_t id_at(const unsigned char *e, size_t i, size_t size)
{
    uint32_t id;
    memcpy(&id, e + i * size, sizeof id);
    return id;
}

static void swap_entries(unsigned char *e, size_t i, size_t j, size_t size)
{
    unsigned char t[VIS_SORT_MAX_ENTRY];
    memcpy(t, e + i * size, size);
    memcpy(e + i * size, e + j * size, size);
    memcpy(e + j * size, t, size);
}

static void sift_down(unsigned char *e, size_t root, size_t n, size_t size)
{
    for (;;) {
        size_t c = 2 * root + 1;
        if (c >= n)
            return;
        if (c + 1 < n && id_at(e, c + 1, size) > id_at(e, c, size))
            ++c;
        if (id_at(e, root, size) >= id_at(e, c, size))
            return;
        swap_entries(e, root, c, size);
        root = c;
    }
}

void vis_sort_by_id(void *entries, size_t n, size_t size)
{
    unsigned char *e = entries;
    for (size_t i = n / 2; i-- > 0;)
        sift_down(e, i, n, size);
    for (size_t end = n; end-- > 1;) {
        swap_entries(e, 0, end, size);
        sift_down(e, 0, end, size);
    }
}

size_t vis_drawlist_bound(const vis_scene *scene)
{
    if (!scene)
        return 0;
    vis_scene_begin_read(scene);
    size_t n = scene->object_live;
    vis_scene_end_read(scene);
    return n;
}

size_t vis_drawlist_scratch_bytes(const vis_scene *s, vis_id_mode mode)
{
    size_t words = (size_t)s->object_slots + (mode == VIS_IDS_LEAF ? (size_t)s->leaf_count + 1 : 0);
    return (words ? words : 1u) * sizeof(uint32_t);
}

static vis_status build(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint32_t width, uint32_t height,
                        vis_id_mode mode, vis_draw_entry *out, size_t capacity, size_t *out_count)
{
    if (!s || !ids || !out_count || (capacity && !out))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_drawlist_build: NULL argument");
    if (mode != VIS_IDS_OBJECT && mode != VIS_IDS_LEAF)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown ID mode %d", (int)mode);
    uint32_t *count = vis_scratch(ctx, vis_drawlist_scratch_bytes(s, mode));
    if (!count)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for draw-list scratch");
    return vis_drawlist_from_ids(ctx, s, ids, (uint64_t)width * height, mode, count, out, capacity, out_count);
}

vis_status vis_drawlist_from_ids(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint64_t n,
                                 vis_id_mode mode, uint32_t *count, vis_draw_entry *out, size_t capacity,
                                 size_t *out_count)
{
    /* Pixel counts indexed by object slot (dense, bounded by the scene), so the scratch does
     * not depend on how large the caller's IDs are. */
    uint32_t slots = s->object_slots;
    uint32_t leaves = s->leaf_count;
    memset(count, 0, vis_drawlist_scratch_bytes(s, mode));
    if (mode == VIS_IDS_OBJECT) {
        uint32_t last_id = 0, last_slot = VIS_NO_OBJECT;
        for (uint64_t i = 0; i < n; ++i) {
            uint32_t id = ids[i];
            if (id == 0)
                continue;
            if (id != last_id) { /* runs of one ID are the common case */
                last_id = id;
                last_slot = vis_scene_find(s, id);
                if (last_slot == VIS_NO_OBJECT)
                    return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "ID buffer holds %u, which is no object of the scene", id);
            }
            ++count[last_slot];
        }
    } else {
        uint32_t *leaf_px = count + slots;
        for (uint64_t i = 0; i < n; ++i) {
            uint32_t l = ids[i];
            if (l > leaves)
                return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "ID buffer holds leaf %u; the scene has %u leaves", l, leaves);
            ++leaf_px[l];
        }
        for (uint32_t l = 1; l <= leaves; ++l) {
            if (!leaf_px[l])
                continue;
            const vis_leaf_host *lh = &s->leaf_host[l - 1];
            for (uint32_t k = 0; k < lh->object_count; ++k)
                count[lh->objects[k]] += leaf_px[l];
        }
    }
    size_t m = 0;
    for (uint32_t i = 0; i < slots; ++i)
        m += count[i] != 0;
    if (m > capacity) {
        *out_count = m;
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "draw list has %zu entries, capacity is %zu", m, capacity);
    }
    size_t k = 0;
    for (uint32_t i = 0; i < slots; ++i)
        if (count[i]) {
            out[k].id = s->objects[i].id;
            out[k].pixels = count[i];
            ++k;
        }
    /* Slots are not in ID order: sort by ID in place (heap sort: no allocation, n log n). */
    vis_sort_by_id(out, k, sizeof *out);
    *out_count = k;
    return VIS_OK;
}

vis_status vis_drawlist_build(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint32_t width,
                              uint32_t height, vis_id_mode mode, vis_draw_entry *out, size_t capacity,
                              size_t *out_count)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    if (s)
        vis_scene_begin_read(s);
    vis_status st = build(ctx, s, ids, width, height, mode, out, capacity, out_count);
    if (s)
        vis_scene_end_read(s);
    vis_leave(ctx);
    return st;
}
