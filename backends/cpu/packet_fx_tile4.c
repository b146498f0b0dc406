/* packet_fx_tile4.c — packets of 4x4 primary rays in an effects pass (packet_impl.h's effects
 * instance): tiles of the smallest images. */
#define VIS_TRACE_EFFECTS 1
#define PK_EFFECTS 1
#define PK_TILE_W 4
#define PK_TILE_H 4
#define PK_ENTRY vis_packet_effects_4x4
#include "cpu/packet_impl.h"
