/* edit.c — picking through libvis and the brush. */
#include "edit.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "timer.h"

const char *vv_tool_name(vv_tool t)
{
    return t == VV_TOOL_ADD ? "add" : t == VV_TOOL_REMOVE ? "remove" : t == VV_TOOL_PAINT ? "paint" : "?";
}

int vv_tool_parse(const char *s)
{
    for (int t = 0; t < VV_TOOL_COUNT; ++t)
        if (strcmp(s, vv_tool_name((vv_tool)t)) == 0)
            return t;
    return -1;
}

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    v[0] /= l, v[1] /= l, v[2] /= l;
}

static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

/* The direction of pixel (px, py)'s ray as vis.h defines the pass's rays. */
static void pixel_ray(const vis_camera *cam, uint32_t W, uint32_t H, double px, double py, double dir[3])
{
    double f[3] = {cam->target[0] - cam->eye[0], cam->target[1] - cam->eye[1], cam->target[2] - cam->eye[2]}, r[3],
           u[3];
    normalize3(f);
    const double up_y[3] = {0, 1, 0}, up_z[3] = {0, 0, -1};
    cross3(f, up_y, r);
    if (r[0] == 0.0 && r[1] == 0.0 && r[2] == 0.0)
        cross3(f, up_z, r);
    normalize3(r);
    cross3(r, f, u);
    double th = tan((cam->fovy_deg == 0.0 ? 60.0 : cam->fovy_deg) * 0.5 * (3.14159265358979323846 / 180.0));
    double nx = px / W * 2.0 - 1.0, ny = 1.0 - py / H * 2.0, aspect = (double)W / (double)H;
    for (int a = 0; a < 3; ++a)
        dir[a] = f[a] + nx * th * aspect * r[a] + ny * th * u[a];
    normalize3(dir);
}

int vv_edit_at(vv_cull *c, double px, double py, vv_tool tool, int radius, uint8_t material, vv_edit_result *out)
{
    memset(out, 0, sizeof *out);
    double t0 = vc_now_ms();
    vis_context *ctx = c->ctx[c->owner];
    double dir[3];
    pixel_ray(&c->camera, c->width, c->height, px, py, dir);
    /* A 1x1 pass whose one pixel-centre ray is this direction: libvis does the picking. */
    vis_camera pick = c->camera;
    for (int a = 0; a < 3; ++a)
        pick.target[a] = pick.eye[a] + dir[a];
    pick.fovy_deg = 1e-3;
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 1;
    uint32_t id = 0;
    float depth = INFINITY;
    if (vis_trace(ctx, world_scene_scene(c->ws), &pick, &td, &id, 1, &depth, 1) != VIS_OK) {
        fprintf(stderr, "vis-viewer: picking: %s\n", vis_context_last_error(ctx));
        return VV_EXIT_FAILURE;
    }
    out->pick_ms = vc_now_ms() - t0;
    if (id == 0 || !isfinite(depth)) {
        out->total_ms = vc_now_ms() - t0;
        return VV_EXIT_OK;
    }
    out->hit = 1;
    out->object = id;
    /* The hit lies on a face: a little past it is the solid voxel, a little before it the
     * empty one in front. */
    double step = tool == VV_TOOL_ADD ? -0.01 : 0.01;
    for (int a = 0; a < 3; ++a)
        out->voxel[a] = (int64_t)floor(pick.eye[a] + dir[a] * ((double)depth + step));
    vw_world *world = world_scene_world(c->ws);
    for (int64_t z = out->voxel[2] - radius; z <= out->voxel[2] + radius; ++z)
        for (int64_t y = out->voxel[1] - radius; y <= out->voxel[1] + radius; ++y)
            for (int64_t x = out->voxel[0] - radius; x <= out->voxel[0] + radius; ++x) {
                vw_voxel old = vw_world_get(world, x, y, z), nv = old;
                if (tool == VV_TOOL_ADD && old == 0)
                    nv = material;
                else if (tool == VV_TOOL_REMOVE)
                    nv = 0;
                else if (tool == VV_TOOL_PAINT && old != 0)
                    nv = material;
                if (nv != old && vw_world_set(world, x, y, z, nv) == VW_OK)
                    out->changed++;
            }
    world_scene_stats st;
    vw_error err;
    memset(&err, 0, sizeof err);
    if (world_scene_update(c->ws, &st, &err) != 0) {
        fprintf(stderr, "vis-viewer: re-meshing after the edit: %s\n", err.message);
        return VV_EXIT_FAILURE;
    }
    if (vv_cull_grow(c) != 0)
        return VV_EXIT_FAILURE;
    out->chunks = st.chunks;
    out->remesh_ms = st.mesh_ms;
    out->scene_ms = st.scene_ms;
    out->total_ms = vc_now_ms() - t0;
    return VV_EXIT_OK;
}
