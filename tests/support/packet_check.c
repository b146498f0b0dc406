/* packet_check.c — see packet_check.h. */
#include "packet_check.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

#include "cpu/packet.h"
#include "trace.h"

float expect_packets(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t w, uint32_t h,
                     uint32_t want, vis_ray_setup *setup)
{
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = w, d.height = h;
    d.traversal = VIS_TRAVERSAL_PACKET;
    vis_ray_setup s;
    assert_int_equal(vis_trace_make_setup(ctx, scene, cam, &d, &s), VIS_OK);
    uint32_t side = vis_packet_side(&s);
    if (side != want)
        fail_msg("%ux%u at %g degrees: packets of %u, want %u", w, h, cam->fovy_deg, side, want);
    if (setup)
        *setup = s;
    return vis_packet_give_up_t(&s, side);
}
