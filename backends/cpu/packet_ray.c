/* packet_ray.c — packets of one ray (packet_impl.h): where a tile's rays spread too wide to
 * share a walk (small images, wide fields of view), each walks alone, with the same culls. */
#define PK_TILE_W 1
#define PK_TILE_H 1
#define PK_ENTRY vis_packet_trace_1x1
#include "cpu/packet_impl.h"
