/* packet.h — the CPU ray pass for one 8x8 tile traced as a packet. */
#ifndef VIS_CPU_PACKET_H
#define VIS_CPU_PACKET_H

#include <stdint.h>

#include "backend.h"

#ifndef VIS_PACKET_SIDE
#  define VIS_PACKET_SIDE 16u
#endif

/* Traces pixels [x0, x0+8) x [y0, y0+8) (clipped to the image) of the view in `setup` and
 * writes their IDs and depths (depth may be NULL) exactly as vis_trace_pixel would: the same
 * rays, the same primitive tests, the same nearest hit and tie rule. `occupied` flags the
 * kd nodes whose subtree holds a primitive (occupancy.h). */
void vis_packet_trace_tile(const vis_ray_setup *setup, const vis_scene_view *view, const uint8_t *occupied,
                           uint32_t x0, uint32_t y0, uint32_t *ids, float *depth);

#endif /* VIS_CPU_PACKET_H */
