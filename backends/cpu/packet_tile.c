/* packet_tile.c — packets of 16x16 rays (packet_impl.h): the CPU pass at normal fields of view. */
#define PK_TILE_W 16
#define PK_TILE_H 16
#define PK_ENTRY vis_packet_trace_16x16
#include "cpu/packet_impl.h"
