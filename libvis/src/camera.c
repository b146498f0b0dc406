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
    desc->see_through_layers = 2;
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
        d.effects = desc->effects;
        if (desc->see_through_layers)
            d.see_through_layers = desc->see_through_layers;
        memcpy(d.light_dir, desc->light_dir, sizeof d.light_dir);
        d.fog_dist = desc->fog_dist;
    }
    if (d.width == 0 || d.height == 0 || d.width > VIS_MAX_RESOLUTION || d.height > VIS_MAX_RESOLUTION)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "resolution %ux%u is outside 1..%u per axis", d.width, d.height,
                        VIS_MAX_RESOLUTION);
    if (d.ids != VIS_IDS_OBJECT && d.ids != VIS_IDS_LEAF)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown ID mode %d", (int)d.ids);
    if (!vis_traversal_known(d.traversal))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown traversal %d", (int)d.traversal);
    if (d.short_stack > VIS_MAX_SHORT_STACK)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "short_stack %u exceeds %u", d.short_stack,
                        VIS_MAX_SHORT_STACK);
    const uint32_t known = VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG;
    if (d.effects & ~known)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "unknown effect bits 0x%x", d.effects & ~known);
    if ((d.effects & VIS_EFFECT_SEE_THROUGH) && d.see_through_layers > VIS_MAX_SEE_THROUGH_LAYERS)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "see_through_layers %u is outside 1..%u", d.see_through_layers,
                        VIS_MAX_SEE_THROUGH_LAYERS);
    if (d.effects & VIS_EFFECT_SHADOWS) {
        const double *l = d.light_dir;
        if (!isfinite(l[0]) || !isfinite(l[1]) || !isfinite(l[2]) || (l[0] == 0.0 && l[1] == 0.0 && l[2] == 0.0))
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "light_dir (%g, %g, %g) must be finite and not zero", l[0],
                            l[1], l[2]);
    }
    if ((d.effects & VIS_EFFECT_FOG) && !(isfinite(d.fog_dist) && d.fog_dist > 0.0))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "fog_dist %g must be finite and > 0", d.fog_dist);
    *out = d;
    return VIS_OK;
}

/* ---- The engine's camera form (vis_camera_from_matrices) --------------------------------
 *
 * The talk builds its rays from projection[0][0], projection[1][1] and the inverse view
 * matrix. Rather than a second ray setup, the matrices are turned into the eye/target camera
 * that has the same basis, so both forms share one validation and one ray setup
 * (vis_camera_frame_make) and cannot drift apart. What the eye/target form cannot express
 * (roll, off-centre and orthographic projections) is refused rather than approximated. */

/* Element (row r, column c) of a column-major 4x4 matrix. */
static double m4(const double *m, int r, int c) { return m[c * 4 + r]; }

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static vis_status matrices_to_camera(vis_context *ctx, const double *view, const double *proj, uint32_t width,
                                     uint32_t height, vis_camera *out)
{
    if (!view || !proj || !out)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "view, projection and out_camera must not be NULL");
    for (int i = 0; i < 16; ++i) {
        if (!isfinite(view[i]))
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "view matrix element [%d] is not finite", i);
        if (!isfinite(proj[i]))
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "projection matrix element [%d] is not finite", i);
    }
    if (width == 0 || height == 0 || width > VIS_MAX_RESOLUTION || height > VIS_MAX_RESOLUTION)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "resolution %ux%u is outside 1..%u per axis", width, height,
                        VIS_MAX_RESOLUTION);
    /* The view: rows 0..2 of its rotation are right, up and -forward; its last row must be
     * (0, 0, 0, 1) for it to be a rigid transform. */
    if (m4(view, 3, 0) != 0.0 || m4(view, 3, 1) != 0.0 || m4(view, 3, 2) != 0.0 || m4(view, 3, 3) != 1.0)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "view matrix: the last row is not (0, 0, 0, 1)");
    double rows[3][3];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
            rows[r][c] = m4(view, r, c);
    for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) {
            double want = a == b ? 1.0 : 0.0;
            if (!(fabs(dot3(rows[a], rows[b]) - want) <= 1e-4))
                return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                                "view matrix: the rotation is not orthonormal (rows %d.%d = %g; scale, shear?)", a, b,
                                dot3(rows[a], rows[b]));
        }
    double rxu[3];
    cross(rows[0], rows[1], rxu);
    if (dot3(rxu, rows[2]) < 0.0)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "view matrix: the rotation is a mirror (determinant < 0)");
    /* The inverse of a rigid view: eye = -R^T t; forward = -row 2. */
    double eye[3], fwd[3];
    for (int c = 0; c < 3; ++c) {
        eye[c] = -(rows[0][c] * m4(view, 0, 3) + rows[1][c] * m4(view, 1, 3) + rows[2][c] * m4(view, 2, 3));
        fwd[c] = -rows[2][c];
    }
    /* No roll: the right axis must be the one camera.c derives from the forward axis. */
    if (fwd[0] == 0.0 && fwd[2] == 0.0) {
        const double up_z[3] = {0.0, 0.0, -1.0};
        double r[3];
        cross(fwd, up_z, r);
        double rl = norm(r);
        if (!(fabs(r[0] / rl - rows[0][0]) <= 1e-6 && fabs(r[1] / rl - rows[0][1]) <= 1e-6 &&
              fabs(r[2] / rl - rows[0][2]) <= 1e-6))
            return vis_fail(ctx, VIS_ERROR_UNSUPPORTED,
                            "view matrix looks straight along Y with right axis (%g, %g, %g); the eye/target form "
                            "takes (%g, %g, %g) there",
                            rows[0][0], rows[0][1], rows[0][2], r[0] / rl, r[1] / rl, r[2] / rl);
    } else if (!(fabs(rows[0][1]) <= 1e-6) || (rows[0][0] * -fwd[2] + rows[0][2] * fwd[0]) <= 0.0) {
        return vis_fail(ctx, VIS_ERROR_UNSUPPORTED,
                        "view matrix has roll (right axis (%g, %g, %g) is not horizontal); the eye/target form "
                        "keeps +Y up",
                        rows[0][0], rows[0][1], rows[0][2]);
    }
    /* The projection: a symmetric OpenGL perspective. */
    double p00 = m4(proj, 0, 0), p11 = m4(proj, 1, 1), p22 = m4(proj, 2, 2), p23 = m4(proj, 2, 3);
    if (m4(proj, 3, 2) != -1.0 || m4(proj, 3, 3) != 0.0) {
        if (m4(proj, 3, 3) == 1.0 && m4(proj, 3, 2) == 0.0)
            return vis_fail(ctx, VIS_ERROR_UNSUPPORTED, "projection is orthographic; rays need a perspective");
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "projection is not a perspective (row 3 must be (0, 0, -1, 0))");
    }
    if (m4(proj, 0, 2) != 0.0 || m4(proj, 1, 2) != 0.0)
        return vis_fail(ctx, VIS_ERROR_UNSUPPORTED, "projection is off-centre ([2][0] = %g, [2][1] = %g)",
                        m4(proj, 0, 2), m4(proj, 1, 2));
    if (m4(proj, 0, 1) != 0.0 || m4(proj, 0, 3) != 0.0 || m4(proj, 1, 0) != 0.0 || m4(proj, 1, 3) != 0.0 ||
        m4(proj, 2, 0) != 0.0 || m4(proj, 2, 1) != 0.0 || m4(proj, 3, 0) != 0.0 || m4(proj, 3, 1) != 0.0)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "projection has non-zero off-diagonal terms");
    if (!(p00 > 0.0) || !(p11 > 0.0))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "projection scale [0][0] = %g, [1][1] = %g must be > 0", p00,
                        p11);
    double aspect = p11 / p00, pass_aspect = (double)width / (double)height;
    if (!(fabs(aspect / pass_aspect - 1.0) <= 1e-4))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "projection aspect %g ([1][1] / [0][0]) is not the pass's %ux%u (%g)", aspect, width, height,
                        pass_aspect);
    /* near = B / (A - 1), far = B / (A + 1) with A = [2][2], B = [3][2]; A = -1: infinite far. */
    double near_d = p23 / (p22 - 1.0);
    double far_d = p22 == -1.0 ? 0.0 : p23 / (p22 + 1.0);
    if (!(near_d > 0.0) || !isfinite(near_d))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "projection near plane %g must be > 0 (from [2][2], [3][2])",
                        near_d);
    if (far_d != 0.0 && !(far_d > near_d))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "projection far plane %g must lie beyond near %g", far_d,
                        near_d);
    vis_camera c;
    memset(&c, 0, sizeof c);
    /* The target one power-of-two step along the forward axis, at least as far as the eye is
     * from the origin, so that target - eye keeps the forward axis to full precision. */
    double scale = 1.0, emax = fmax(fabs(eye[0]), fmax(fabs(eye[1]), fabs(eye[2])));
    while (scale < emax)
        scale *= 2.0;
    for (int a = 0; a < 3; ++a) {
        c.eye[a] = eye[a];
        c.target[a] = eye[a] + scale * fwd[a];
    }
    c.fovy_deg = 2.0 * atan(1.0 / p11) * (180.0 / 3.14159265358979323846);
    c.near_dist = near_d;
    c.far_dist = far_d;
    double fovy = 0.0, n = 0.0, f = 0.0;
    vis_status st = check_camera(ctx, &c, &fovy, &n, &f);
    if (st != VIS_OK)
        return st;
    *out = c;
    return VIS_OK;
}

vis_status vis_camera_from_matrices(vis_context *ctx, const double view[16], const double projection[16],
                                    uint32_t width, uint32_t height, vis_camera *out_camera)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = matrices_to_camera(ctx, view, projection, width, height, out_camera);
    vis_leave(ctx);
    return st;
}
