/* packet.c — which packet size traces a tile (packet_impl.h has the tracing).
 *
 * A packet's bounds are only as tight as its rays are close: a 16x16 tile at 512x512 and a
 * 60 degree field of view spans about 2 degrees, and its culls remove almost everything; the
 * same tile of a 32x32 image spans 30 degrees and culls almost nothing, so every leaf in view
 * is opened for it. Where the tile would spread wider than PACKET_MAX_SPREAD, each of its rays
 * is traced alone, as a packet of one (as fast as the per-ray stack method there, and exact
 * in the same way).
 *
 * Far away the same happens at normal fields of view: a tile whose hits lie where a pixel
 * covers more than PACKET_MAX_FOOTPRINT voxels spans several leaves, its bounds stop culling,
 * and every quad in its rectangle is tested against its rays (docs/performance.md, "Where the
 * time goes": past 2-4 voxels per pixel single rays are cheaper). The packet walk goes near
 * side first, so the first leaf it enters tells: entered beyond that distance, the packet gives
 * up and its rays go one by one. Both give the same pixels: the brute force's. */
#include <math.h>

#include "cpu/packet.h"

int vis_packet_trace_16x16(const vis_ray_setup *setup, const vis_scene_view *view, const uint8_t *occupied,
                           float give_up_t, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth);
int vis_packet_trace_1x1(const vis_ray_setup *setup, const vis_scene_view *view, const uint8_t *occupied,
                         float give_up_t, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth);

/* Scene units a pixel may cover where a tile enters its first leaf for the tile to stay a
 * packet. */
#ifndef PACKET_MAX_FOOTPRINT
#  define PACKET_MAX_FOOTPRINT 3.0f
#endif

/* Widest tile, as its extent on the image plane at distance 1 (tangent units): at 60 degrees,
 * 512x512 tiles span 0.036 and 256x256 ones 0.072 (16x16 packets 2.5-3.5x faster than single
 * rays there), 128x128 ones 0.144 (a tie); docs/traversal.md. */
#ifndef PACKET_MAX_SPREAD
#  define PACKET_MAX_SPREAD 0.1f
#endif

static float vec_len(const float *v) { return sqrtf(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

int vis_packet_wide(const vis_ray_setup *setup)
{
    /* Pixels step 2/W along `right` and 2/H along `up` on the image plane at distance 1. */
    float sx = VIS_PACKET_SIDE * 2.0f * vec_len(setup->right) / (float)setup->width;
    float sy = VIS_PACKET_SIDE * 2.0f * vec_len(setup->up) / (float)setup->height;
    return sx > PACKET_MAX_SPREAD || sy > PACKET_MAX_SPREAD;
}

void vis_packet_trace_tile(const vis_ray_setup *setup, const vis_scene_view *view, const uint8_t *occupied,
                           int wide, uint32_t x0, uint32_t y0, uint32_t *ids, float *depth)
{
    if (!wide) {
        float pixel = fmaxf(2.0f * vec_len(setup->right) / (float)setup->width,
                            2.0f * vec_len(setup->up) / (float)setup->height);
        if (vis_packet_trace_16x16(setup, view, occupied, PACKET_MAX_FOOTPRINT / pixel, x0, y0, ids, depth))
            return;
    }
    for (uint32_t y = y0; y < y0 + VIS_PACKET_SIDE && y < setup->height; y += 1u)
        for (uint32_t x = x0; x < x0 + VIS_PACKET_SIDE && x < setup->width; x += 1u)
            vis_packet_trace_1x1(setup, view, occupied, INFINITY, x, y, ids, depth);
}
