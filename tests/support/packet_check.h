/* packet_check.h — the packets a CPU packet pass takes (backends/cpu/packet.c), for
 * test_trace.c and test_effects.c. */
#ifndef PACKET_CHECK_H
#define PACKET_CHECK_H

#include <stdint.h>

#include "backend.h"
#include "vis/vis.h"

/* Makes the ray setup of a packet pass of `cam` at w x h (copied to *setup when not NULL),
 * checks that its tiles take packets of `want` (vis_packet_side; fails the test otherwise)
 * and returns the distance past which such a packet gives up (vis_packet_give_up_t). */
float expect_packets(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t w, uint32_t h,
                     uint32_t want, vis_ray_setup *setup);

#endif
