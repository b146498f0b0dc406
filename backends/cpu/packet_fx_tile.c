/* packet_fx_tile.c — packets of 16x16 primary rays in an effects pass (packet_impl.h's effects
 * instance): the effects pass at normal fields of view. */
#define VIS_TRACE_EFFECTS 1
#define PK_EFFECTS 1
#define PK_TILE_W 16
#define PK_TILE_H 16
#define PK_ENTRY vis_packet_effects_16x16
#include "cpu/packet_impl.h"
