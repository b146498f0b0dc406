/* effects.h — the CPU's effects pass for one tile: per ray (effects.c, trace_core.h built with
 * VIS_TRACE_EFFECTS) or by packets (packet_fx_*.c, packet_impl.h's effects instance). */
#ifndef VIS_CPU_EFFECTS_H
#define VIS_CPU_EFFECTS_H

#include <stddef.h>
#include <stdint.h>

#include "backend.h"
#include "cpu/occupancy.h"

/* Traces pixels [x0, x1) x [y0, y1) with the effects and writes every buffer `out` has;
 * returns the secondary rays cast. */
uint64_t vis_cpu_effects_tile(const vis_scene_view *view, const vis_ray_setup *setup, const vis_effect_setup *effects,
                          const vis_effect_outputs *out, uint32_t x0, uint32_t y0, uint32_t x1, uint32_t y1);

/* The same for the pixels [x0, x0 + VIS_PACKET_SIDE) x [y0, y0 + VIS_PACKET_SIDE) (clipped to
 * the image) of a packet pass (setup->traversal VIS_TRAVERSAL_ID_PACKET): the primary rays in
 * packets of `side` (vis_packet_side) where they share a walk, else one by one, as the plain
 * packet pass decides (packet.c); `fill` as for vis_packet_trace_tile. Bit for bit the
 * per-ray buffers. */
uint64_t vis_cpu_effects_packet_tile(const vis_scene_view *view, const vis_node_fill *fill, const vis_ray_setup *setup,
                                     const vis_effect_setup *effects, const vis_effect_outputs *out, uint32_t side,
                                     uint32_t x0, uint32_t y0);

#ifdef VIS_TRACE_EFFECTS
/* Writes pixel i's results to every buffer `out` has (`layers` see-through IDs per pixel). */
static inline void vis_effect_pixel_store(const vis_effect_outputs *out, uint32_t layers, size_t i,
                                          const vis_effect_pixel *px)
{
    out->ids[i] = px->id;
    if (out->depth)
        out->depth[i] = px->depth;
    if (out->see_through)
        for (uint32_t k = 0; k < layers; ++k)
            out->see_through[i * layers + k] = px->see_through[k];
    if (out->reflection)
        out->reflection[i] = px->reflection;
    if (out->shadow)
        out->shadow[i] = px->shadow;
}
#endif

#endif /* VIS_CPU_EFFECTS_H */
