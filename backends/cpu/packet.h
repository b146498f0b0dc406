/* packet.h — the CPU ray pass for one 8x8 tile traced as a packet. */
#ifndef VIS_CPU_PACKET_H
#define VIS_CPU_PACKET_H

#include <stdint.h>

#include "backend.h"
#include "cpu/occupancy.h"

/* The tile the CPU backend hands to a thread for packets, in pixels. */
#define VIS_PACKET_SIDE 16u

/* The packet side a pass's tiles are traced with: 16, 8 or 4, the largest whose tiles do not
 * spread too wide, or 1 (each ray its own packet). */
uint32_t vis_packet_side(const vis_ray_setup *setup);

/* The distance past which a packet of `side` that first enters a leaf gives up, its rays
 * then traced one by one (for 16x16 packets at 512x512 and 60 degrees, 1,330 units). */
float vis_packet_give_up_t(const vis_ray_setup *setup, uint32_t side);

/* Traces the pixels [x0, x0 + edge) x [y0, y0 + edge) of the view in `setup` (clipped to the
 * image; edge a multiple of `side`, at most VIS_PACKET_SIDE) and writes their IDs and depths
 * (depth may be NULL): per pixel, the nearest hit over every primitive under the lowest-ID tie
 * rule, with the rays and primitive tests of trace_core.h -- bit for bit the brute force's
 * buffers. `fill` tells what each kd node's subtree holds (occupancy.h); `side`
 * is vis_packet_side(setup). `cost` (may be NULL) gets each pixel's traversal cost
 * (vis_trace_cost). Returns the number of pixels traced one ray at a time (packets that gave
 * up or were skipped as sure to, or side 1). */
uint32_t vis_packet_trace_tile(const vis_ray_setup *setup, const vis_scene_view *view, const vis_node_fill *fill,
                               uint32_t side, uint32_t edge, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth,
                               uint32_t *cost);

#endif /* VIS_CPU_PACKET_H */
