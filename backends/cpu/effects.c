/* effects.c — the effects instance of the per-ray code: trace_core.h compiled with
 * VIS_TRACE_EFFECTS in this translation unit only, so the plain pass (cpu_backend.c,
 * packet_*.c) keeps its own code untouched and pays nothing for the effects. Each pixel's
 * secondary rays follow its primary ray on the same thread, tile by tile. */
#define VIS_TRACE_EFFECTS 1
#include "cpu/effects.h"

uint64_t vis_cpu_effects_tile(const vis_scene_view *view, const vis_ray_setup *setup, const vis_effect_setup *effects,
                          const vis_effect_outputs *out, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1)
{
    const vis_scene_view v = *view; /* a local copy: its arrays stay in registers */
    uint32_t layers = effects->layers;
    uint64_t secondary = 0;
    for (uint32_t y = y0; y < y1; ++y)
        for (uint32_t x = x0; x < x1; ++x) {
            vis_effect_pixel px;
            vis_trace_pixel_effects(setup, effects, x, y, VIS_SCENE_VIEW_ARGS(&v), &px);
            size_t i = (size_t)y * setup->width + x;
            out->ids[i] = px.id;
            if (out->depth)
                out->depth[i] = px.depth;
            if (out->see_through)
                for (uint32_t k = 0; k < layers; ++k)
                    out->see_through[i * layers + k] = px.see_through[k];
            if (out->reflection)
                out->reflection[i] = px.reflection;
            if (out->shadow)
                out->shadow[i] = px.shadow;
            secondary += px.secondary;
        }
    return secondary;
}
