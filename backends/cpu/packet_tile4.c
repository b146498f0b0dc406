/* packet_tile4.c — packets of 4x4 rays (packet_impl.h): tiles of the smallest images. */
#define PK_TILE_W 4
#define PK_TILE_H 4
#define PK_ENTRY vis_packet_trace_4x4
#include "cpu/packet_impl.h"
