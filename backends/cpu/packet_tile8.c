/* packet_tile8.c — packets of 8x8 rays (packet_impl.h): tiles of images too small for 16x16. */
#define PK_TILE_W 8
#define PK_TILE_H 8
#define PK_ENTRY vis_packet_trace_8x8
#include "cpu/packet_impl.h"
