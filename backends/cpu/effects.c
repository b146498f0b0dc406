/* effects.c — the effects instance of the per-ray code: trace_core.h compiled with
 * VIS_TRACE_EFFECTS in this translation unit only, so the plain pass (cpu_backend.c,
 * packet_*.c) keeps its own code untouched and pays nothing for the effects. Each pixel's
 * secondary rays follow its primary ray on the same thread, tile by tile. A packet pass
 * traces the primary rays of its tiles by packets (packet_fx_*.c), the rays of a packet that
 * gives up one by one here. */
#define VIS_TRACE_EFFECTS 1
#include "cpu/effects.h"
#include "cpu/packet.h"

int vis_packet_effects_16x16(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                             float give_up_t, uint32_t x0, uint32_t y0, const vis_effect_setup *effects,
                             const vis_effect_outputs *out, uint64_t *secondary);
int vis_packet_effects_8x8(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                           float give_up_t, uint32_t x0, uint32_t y0, const vis_effect_setup *effects,
                           const vis_effect_outputs *out, uint64_t *secondary);
int vis_packet_effects_4x4(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                           float give_up_t, uint32_t x0, uint32_t y0, const vis_effect_setup *effects,
                           const vis_effect_outputs *out, uint64_t *secondary);

uint64_t vis_cpu_effects_tile(const vis_scene_view *view, const vis_ray_setup *setup, const vis_effect_setup *effects,
                          const vis_effect_outputs *out, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1)
{
    const vis_scene_view v = *view; /* a local copy: its arrays stay in registers */
    uint64_t secondary = 0;
    for (uint32_t y = y0; y < y1; ++y)
        for (uint32_t x = x0; x < x1; ++x) {
            vis_effect_pixel px;
            vis_trace_pixel_effects(setup, effects, x, y, VIS_SCENE_VIEW_ARGS(&v), &px);
            vis_effect_pixel_store(out, effects->layers, (size_t)y * setup->width + x, &px);
            secondary += px.secondary;
        }
    return secondary;
}

typedef int (*packet_effects_fn)(const vis_ray_setup *, const vis_scene_view *, const vis_node_fill *, float, uint32_t,
                                 uint32_t, const vis_effect_setup *, const vis_effect_outputs *, uint64_t *);

uint64_t vis_cpu_effects_packet_tile(const vis_scene_view *view, const vis_node_fill *fill, const vis_ray_setup *setup,
                                     const vis_effect_setup *effects, const vis_effect_outputs *out, uint32_t side,
                                     uint32_t x0, uint32_t y0)
{
    /* Where a tile's rays spread too wide for packets (side 1), they go one by one with the
     * stack method, as they would where a packet gives up: a packet of one ray gains little
     * over it (docs/traversal.md) and would be a fourth instance. */
    packet_effects_fn fn = side == 16u ? vis_packet_effects_16x16 : side == 8u ? vis_packet_effects_8x8
                         : side == 4u ? vis_packet_effects_4x4 : NULL;
    float give_up_t = vis_packet_give_up_t(setup, side);
    uint32_t x_end = x0 + VIS_PACKET_SIDE < setup->width ? x0 + VIS_PACKET_SIDE : setup->width;
    uint32_t y_end = y0 + VIS_PACKET_SIDE < setup->height ? y0 + VIS_PACKET_SIDE : setup->height;
    uint32_t step = fn ? side : VIS_PACKET_SIDE;
    uint64_t secondary = 0;
    for (uint32_t ty = y0; ty < y_end; ty += step)
        for (uint32_t tx = x0; tx < x_end; tx += step) {
            if (fn && fn(setup, view, fill, give_up_t, tx, ty, effects, out, &secondary))
                continue;
            uint32_t x1 = tx + step < x_end ? tx + step : x_end, y1 = ty + step < y_end ? ty + step : y_end;
            secondary += vis_cpu_effects_tile(view, setup, effects, out, tx, ty, x1, y1);
        }
    return secondary;
}
