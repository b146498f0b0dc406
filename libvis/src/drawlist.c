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

/* The scratch: a count per object slot, then (at an 8-byte boundary, in 32-bit words from
 * its start) the bitset of slots seen, of seen_words 64-bit words, then the leaves' counts. */
static size_t seen_at(const vis_scene *s) { return (size_t)s->object_slots + (s->object_slots & 1u); }
static size_t seen_words(const vis_scene *s) { return ((size_t)s->object_slots + 63u) / 64u; }

size_t vis_drawlist_scratch_bytes(const vis_scene *s, vis_id_mode mode)
{
    size_t words = seen_at(s) + 2u * seen_words(s) + (mode == VIS_IDS_LEAF ? (size_t)s->leaf_count + 1 : 0);
    return (words ? words : 1u) * sizeof(uint32_t);
}

/* Adds px pixels to slot's count, marking the slot seen (and counting it in *m) at its
 * first. */
static void add_pixels(uint32_t *count, uint64_t *seen, size_t *m, uint32_t slot, uint32_t px)
{
    if (count[slot] == 0) {
        seen[slot / 64u] |= 1ull << (slot % 64u);
        ++*m;
    }
    count[slot] += px;
}

/* Object IDs. Runs of one ID (sky included) are the common case: each run costs one lookup
 * (none when it repeats the last ID) and one add. */
static vis_status count_objects(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint64_t n, uint32_t *count,
                                uint64_t *seen, size_t *m)
{
    uint32_t last_id = 0, slot = VIS_NO_OBJECT;
    for (uint64_t i = 0; i < n;) {
        uint32_t id = ids[i];
        uint64_t j = i + 1;
        while (j < n && ids[j] == id)
            ++j;
        if (id != 0) {
            if (id != last_id) {
                last_id = id;
                slot = vis_scene_find(s, id);
                if (slot == VIS_NO_OBJECT)
                    return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "ID buffer holds %u, which is no object of the scene", id);
            }
            add_pixels(count, seen, m, slot, (uint32_t)(j - i));
        }
        i = j;
    }
    return VIS_OK;
}

/* Leaf IDs: each leaf's pixels added to every object of the leaf. */
static vis_status count_leaves(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint64_t n, uint32_t *count,
                               uint64_t *seen, size_t *m, uint32_t *leaf_px)
{
    uint32_t leaves = s->leaf_count;
    memset(leaf_px, 0, ((size_t)leaves + 1) * sizeof *leaf_px);
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
            add_pixels(count, seen, m, lh->objects[k], leaf_px[l]);
    }
    return VIS_OK;
}

vis_status vis_drawlist_from_ids(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint64_t n,
                                 vis_id_mode mode, uint32_t *count, vis_draw_entry *out, size_t capacity,
                                 size_t *out_count)
{
    /* Pixel counts indexed by object slot (dense, bounded by the scene), so the scratch does
     * not depend on how large the caller's IDs are; the bitset of the slots seen keeps the
     * output from reading every count. */
    const size_t nw = seen_words(s);
    uint64_t *seen = (uint64_t *)(count + seen_at(s)); /* 8-byte aligned: count is */
    memset(count, 0, (size_t)s->object_slots * sizeof *count);
    memset(seen, 0, nw * sizeof *seen);
    size_t m = 0;
    vis_status st = mode == VIS_IDS_OBJECT ? count_objects(ctx, s, ids, n, count, seen, &m)
                                           : count_leaves(ctx, s, ids, n, count, seen, &m, (uint32_t *)(seen + nw));
    if (st != VIS_OK)
        return st;
    if (m > capacity) {
        *out_count = m;
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "draw list has %zu entries, capacity is %zu", m, capacity);
    }
    /* In slot order, which is ID order where the objects were added in ID order (every
     * world the tools load): then the list is sorted already and the sort is skipped. */
    size_t k = 0;
    int sorted = 1;
    for (size_t w = 0; w < nw; ++w)
        for (uint64_t bits = seen[w]; bits; bits &= bits - 1u) {
            uint32_t slot = (uint32_t)(w * 64u + (size_t)__builtin_ctzll(bits));
            out[k].id = s->objects[slot].id;
            out[k].pixels = count[slot];
            sorted &= k == 0 || out[k - 1].id < out[k].id;
            ++k;
        }
    if (!sorted)
        vis_sort_by_id(out, k, sizeof *out); /* heap sort: no allocation, n log n */
    *out_count = k;
    return VIS_OK;
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
