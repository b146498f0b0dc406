/* A program outside the project, built against an installed libvis (find_package or
 * pkg-config): one quad in a scene, an 8x8 ray pass, every pixel must see the quad. */
#include <stdio.h>
#include <string.h>

#include <vis/vis.h>

#define QUAD_ID 7u

int main(void)
{
    printf("libvis %s (header %s)\n", vis_version(), VIS_VERSION_STRING);
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = 1;
    vis_context *ctx = NULL;
    if (vis_context_create(&cd, &ctx) != VIS_OK) {
        fprintf(stderr, "vis_context_create failed\n");
        return 1;
    }
    vis_scene_desc sd;
    vis_scene_desc_defaults(&sd);
    sd.size[0] = sd.size[1] = sd.size[2] = 16.0f;
    sd.cell_size = 16.0f;
    vis_scene *scene = NULL;
    int rc = 1;
    if (vis_scene_create(ctx, &sd, &scene) != VIS_OK)
        goto done;
    /* A wall across the whole scene at z = 8, seen head-on from z = 20 with a narrow view. */
    vis_quad wall = {2, 0, 8.0f, 0.0f, 0.0f, 16.0f, 16.0f};
    vis_mesh mesh = {&wall, 1, NULL, 0};
    if (vis_scene_set_object(scene, QUAD_ID, &mesh) != VIS_OK)
        goto done;
    vis_camera cam = {{8.0, 8.0, 20.0}, {8.0, 8.0, 0.0}, 30.0, 0.0, 0.0};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = 8;
    td.height = 8;
    uint32_t ids[64];
    float depth[64];
    memset(ids, 0xFF, sizeof ids);
    if (vis_trace(ctx, scene, &cam, &td, ids, depth) != VIS_OK)
        goto done;
    for (int i = 0; i < 64; ++i) {
        if (ids[i] != QUAD_ID || !(depth[i] >= 12.0f && depth[i] < 13.0f)) {
            fprintf(stderr, "pixel %d: id %u depth %g, expected id %u at distance 12..13\n", i, ids[i],
                    (double)depth[i], QUAD_ID);
            goto done;
        }
    }
    vis_draw_entry list[4];
    size_t n = 0;
    if (vis_drawlist_build(ctx, scene, ids, 8, 8, VIS_IDS_OBJECT, list, 4, &n) != VIS_OK || n != 1 ||
        list[0].id != QUAD_ID || list[0].pixels != 64) {
        fprintf(stderr, "unexpected draw list (%zu entries)\n", n);
        goto done;
    }
    printf("ok: 64 of 64 pixels see object %u\n", QUAD_ID);
    rc = 0;
done:
    if (rc != 0)
        fprintf(stderr, "failed: %s\n", vis_context_last_error(ctx));
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
    return rc;
}
