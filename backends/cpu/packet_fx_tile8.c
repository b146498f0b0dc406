/* packet_fx_tile8.c — packets of 8x8 primary rays in an effects pass (packet_impl.h's effects
 * instance): tiles of images too small for 16x16. */
#define VIS_TRACE_EFFECTS 1
#define PK_EFFECTS 1
#define PK_TILE_W 8
#define PK_TILE_H 8
#define PK_ENTRY vis_packet_effects_8x8
#include "cpu/packet_impl.h"
