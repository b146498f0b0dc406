/* drawlist_effects.c — the draw list of an effects pass (vis_trace_effects): every object
 * in its buffers, sorted by ID, with the reasons it is there and its pixels per reason.
 * Counts are kept per object slot (dense, bounded by the scene) in the context's scratch. */
#include <string.h>

#include "drawlist.h"
#include "scene.h"

/* Adds one pixel of reason r for every ID in ids[i * stride + k], k < per_pixel. */
static vis_status count_buffer(vis_context *ctx, const vis_scene *s, const uint32_t *ids, uint64_t pixels,
                               uint32_t per_pixel, int reason, uint32_t *count, const char *name)
{
    uint32_t last_id = 0, last_slot = VIS_NO_OBJECT;
    for (uint64_t i = 0; i < pixels * per_pixel; ++i) {
        uint32_t id = ids[i];
        if (id == 0)
            continue;
        if (id != last_id) { /* runs of one ID are the common case */
            last_id = id;
            last_slot = vis_scene_find(s, id);
            if (last_slot == VIS_NO_OBJECT)
                return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s buffer holds %u, which is no object of the scene",
                                name, id);
        }
        ++count[(size_t)last_slot * VIS_REASON_COUNT + (size_t)reason];
    }
    return VIS_OK;
}

static vis_status check(vis_context *ctx, const void *buf, size_t capacity, uint64_t need, const char *name)
{
    if (buf && (uint64_t)capacity < need)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_drawlist_build_effects: %s needs %llu elements, its capacity is %zu",
                        name, (unsigned long long)need, capacity);
    return VIS_OK;
}

static vis_status build(vis_context *ctx, const vis_scene *s, const vis_effect_buffers *b, uint32_t width,
                        uint32_t height, uint32_t layers, vis_effect_entry *out, size_t capacity, size_t *out_count)
{
    if (!s || !b || !b->ids || !out_count || (capacity && !out))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_drawlist_build_effects: NULL argument");
    if (b->see_through && (layers == 0 || layers > VIS_MAX_SEE_THROUGH_LAYERS))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_drawlist_build_effects: see_through_layers %u is outside 1..%u",
                        layers, VIS_MAX_SEE_THROUGH_LAYERS);
    uint64_t n = (uint64_t)width * height;
    vis_status st;
    if ((st = check(ctx, b->ids, b->ids_capacity, n, "ids")) != VIS_OK ||
        (st = check(ctx, b->see_through, b->see_through_capacity, n * layers, "see_through")) != VIS_OK ||
        (st = check(ctx, b->reflection, b->reflection_capacity, n, "reflection")) != VIS_OK ||
        (st = check(ctx, b->shadow, b->shadow_capacity, n, "shadow")) != VIS_OK)
        return st;
    uint32_t slots = s->object_slots;
    size_t need = (size_t)slots * VIS_REASON_COUNT * sizeof(uint32_t);
    uint32_t *count = vis_scratch(ctx, need ? need : sizeof(uint32_t));
    if (!count)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for draw-list scratch");
    memset(count, 0, need);
    if ((st = count_buffer(ctx, s, b->ids, n, 1, 0, count, "ids")) != VIS_OK)
        return st;
    /* An object appears at most once among a pixel's layers (they are distinct objects), so
     * counting every layer counts pixels. */
    if (b->see_through && (st = count_buffer(ctx, s, b->see_through, n, layers, 1, count, "see_through")) != VIS_OK)
        return st;
    if (b->reflection && (st = count_buffer(ctx, s, b->reflection, n, 1, 2, count, "reflection")) != VIS_OK)
        return st;
    if (b->shadow && (st = count_buffer(ctx, s, b->shadow, n, 1, 3, count, "shadow")) != VIS_OK)
        return st;
    size_t m = 0;
    for (uint32_t i = 0; i < slots; ++i) {
        const uint32_t *c = count + (size_t)i * VIS_REASON_COUNT;
        m += (c[0] | c[1] | c[2] | c[3]) != 0;
    }
    if (m > capacity)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "draw list has %zu entries, capacity is %zu", m, capacity);
    size_t k = 0;
    for (uint32_t i = 0; i < slots; ++i) {
        const uint32_t *c = count + (size_t)i * VIS_REASON_COUNT;
        uint32_t reasons = 0;
        for (int r = 0; r < VIS_REASON_COUNT; ++r)
            reasons |= (c[r] != 0u) << r;
        if (!reasons)
            continue;
        out[k].id = s->objects[i].id;
        out[k].reasons = reasons;
        for (int r = 0; r < VIS_REASON_COUNT; ++r)
            out[k].pixels[r] = c[r];
        ++k;
    }
    vis_sort_by_id(out, k, sizeof *out);
    *out_count = k;
    return VIS_OK;
}

vis_status vis_drawlist_build_effects(vis_context *ctx, const vis_scene *s, const vis_effect_buffers *buffers,
                                      uint32_t width, uint32_t height, uint32_t see_through_layers,
                                      vis_effect_entry *out, size_t capacity, size_t *out_count)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    if (s)
        vis_scene_begin_read(s);
    vis_status st = build(ctx, s, buffers, width, height, see_through_layers, out, capacity, out_count);
    if (s)
        vis_scene_end_read(s);
    vis_leave(ctx);
    return st;
}
