/* camera.c — camera validation and the float ray setup of a pass.
 *
 * The basis is computed in double (DESIGN.md, "The `vis` command line"): f = normalize(T-E),
 * r = normalize(f x (0,1,0)), u = r x f, with (0,0,-1) standing in for (0,1,0) only when the
 * cross product is exactly zero. The eye is made scene-local in double before the one
 * rounding to float, which keeps rays exact-looking far from the world origin. */
#include "camera.h"

#include <math.h>
#include <string.h>

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double norm(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

static vis_status check_camera(vis_context *ctx, const vis_camera *c, double *fovy, double *near_d, double *far_d)
{
    if (!c)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera is NULL");
    if (!finite3(c->eye))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera eye is not finite (%g, %g, %g)", c->eye[0], c->eye[1], c->eye[2]);
    if (!finite3(c->target))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera target is not finite (%g, %g, %g)", c->target[0],
                        c->target[1], c->target[2]);
    double d[3] = {c->target[0] - c->eye[0], c->target[1] - c->eye[1], c->target[2] - c->eye[2]};
    if (!(norm(d) > 0.0) || !isfinite(norm(d)))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera target equals eye (no view direction)");
    *fovy = c->fovy_deg == 0.0 ? 60.0 : c->fovy_deg;
    if (!(*fovy > 0.0 && *fovy < 180.0))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera fovy %g is outside (0, 180) degrees", c->fovy_deg);
    *near_d = c->near_dist == 0.0 ? 0.05 : c->near_dist;
    if (!(*near_d > 0.0) || !isfinite(*near_d))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera near %g must be > 0 and finite", c->near_dist);
    *far_d = c->far_dist == 0.0 ? INFINITY : c->far_dist;
    if (!(*far_d > *near_d))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "camera far %g must be greater than near %g", c->far_dist, *near_d);
    return VIS_OK;
}

vis_status vis_camera_validate(vis_context *ctx, const vis_camera *camera)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    double fovy = 0.0, n = 0.0, f = 0.0;
    vis_status st = check_camera(ctx, camera, &fovy, &n, &f);
    vis_leave(ctx);
    return st;
}

vis_status vis_camera_frame_make(vis_context *ctx, const vis_camera *c, const double origin[3], uint32_t width,
                                 uint32_t height, vis_camera_frame *out)
{
    double fovy = 0.0, n = 0.0, f = 0.0;
    vis_status st = check_camera(ctx, c, &fovy, &n, &f);
    if (st != VIS_OK)
        return st;
    if (width == 0 || height == 0 || width > VIS_MAX_RESOLUTION || height > VIS_MAX_RESOLUTION)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "resolution %ux%u is outside 1..%u per axis", width, height,
                        VIS_MAX_RESOLUTION);
    vis_camera_frame fr;
    memset(&fr, 0, sizeof fr);
    double fwd[3];
    for (int a = 0; a < 3; ++a) {
        fr.eye[a] = c->eye[a] - origin[a];
        fwd[a] = c->target[a] - c->eye[a];
    }
    double len = norm(fwd);
    for (int a = 0; a < 3; ++a)
        fr.f[a] = fwd[a] / len;
    const double up_y[3] = {0.0, 1.0, 0.0}, up_z[3] = {0.0, 0.0, -1.0};
    double r[3];
    cross(fr.f, up_y, r);
    if (r[0] == 0.0 && r[1] == 0.0 && r[2] == 0.0)
        cross(fr.f, up_z, r);
    double rl = norm(r);
    for (int a = 0; a < 3; ++a)
        fr.r[a] = r[a] / rl;
    cross(fr.r, fr.f, fr.u);
    fr.tan_half_fovy = tan(fovy * 0.5 * (3.14159265358979323846 / 180.0));
    fr.aspect = (double)width / (double)height;
    fr.near_dist = n;
    fr.far_dist = f;
    fr.width = width;
    fr.height = height;
    *out = fr;
    return VIS_OK;
}

void vis_camera_frame_ray_setup(const vis_camera_frame *fr, vis_ray_setup *s)
{
    memset(s, 0, sizeof *s);
    for (int a = 0; a < 3; ++a) {
        s->origin[a] = (float)fr->eye[a];
        s->forward[a] = (float)fr->f[a];
        s->right[a] = (float)(fr->r[a] * fr->tan_half_fovy * fr->aspect);
        s->up[a] = (float)(fr->u[a] * fr->tan_half_fovy);
    }
    s->t_near = (float)fr->near_dist;
    s->t_far = (float)fr->far_dist;
    s->width = fr->width;
    s->height = fr->height;
}

void vis_trace_desc_defaults(vis_trace_desc *desc)
{
    memset(desc, 0, sizeof *desc);
    desc->width = 512;
    desc->height = 512;
    desc->ids = VIS_IDS_OBJECT;
    desc->traversal = VIS_TRAVERSAL_AUTO;
    desc->short_stack = 4;
}

vis_status vis_trace_desc_resolve(vis_context *ctx, const vis_trace_desc *desc, vis_trace_desc *out)
{
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    if (desc) {
        if (desc->width || desc->height) {
            d.width = desc->width;
            d.height = desc->height;
        }
        d.ids = desc->ids;
        d.traversal = desc->traversal;
        if (desc->short_stack)
            d.short_stack = desc->short_stack;
    }
    if (d.width == 0 || d.height == 0 || d.width > VIS_MAX_RESOLUTION || d.height > VIS_MAX_RESOLUTION)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "resolution %ux%u is outside 1..%u per axis", d.width, d.height,
                        VIS_MAX_RESOLUTION);
    if (d.ids != VIS_IDS_OBJECT && d.ids != VIS_IDS_LEAF)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown ID mode %d", (int)d.ids);
    if ((unsigned)d.traversal > (unsigned)VIS_TRAVERSAL_PACKET)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown traversal %d", (int)d.traversal);
    if (d.short_stack > VIS_MAX_SHORT_STACK)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "short_stack %u exceeds %u", d.short_stack,
                        VIS_MAX_SHORT_STACK);
    *out = d;
    return VIS_OK;
}
