/* test_camera.c — the engine's camera form (vis_camera_from_matrices): view and projection
 * matrices built the way an engine builds them (lookAt with +Y up, an OpenGL perspective, in
 * double) from an eye/target camera must give the same ID and depth buffers as that camera,
 * bit for bit, on random worlds and views (eyes on split planes, looking straight along an
 * axis, far planes, a scene far from the origin); and matrices the eye/target form cannot
 * express, or that are not a camera at all, must be refused with a vis_status and a message.
 *
 * The matrices are made here with their own code (the textbook lookAt and perspective), not
 * from the library's frame, so the test checks the conversion against the engine's side. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

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

/* glm::lookAt, column-major (m[c*4 + r]); up +Y, or (0,0,-1) looking straight along Y as
 * vis.h defines the eye/target form. */
static void look_at(const double e[3], const double t[3], double m[16])
{
    double f[3] = {t[0] - e[0], t[1] - e[1], t[2] - e[2]}, s[3], u[3];
    normalize3(f);
    const double up_y[3] = {0, 1, 0}, up_z[3] = {0, 0, -1};
    cross3(f, up_y, s);
    if (s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0)
        cross3(f, up_z, s);
    normalize3(s);
    cross3(s, f, u);
    memset(m, 0, 16 * sizeof *m);
    for (int c = 0; c < 3; ++c) {
        m[c * 4 + 0] = s[c];
        m[c * 4 + 1] = u[c];
        m[c * 4 + 2] = -f[c];
    }
    m[12] = -(s[0] * e[0] + s[1] * e[1] + s[2] * e[2]);
    m[13] = -(u[0] * e[0] + u[1] * e[1] + u[2] * e[2]);
    m[14] = f[0] * e[0] + f[1] * e[1] + f[2] * e[2];
    m[15] = 1.0;
}

/* glm::perspective (far = 0: the infinite-far form). */
static void perspective(double fovy_deg, double aspect, double n, double f, double m[16])
{
    double th = tan(fovy_deg * 0.5 * (3.14159265358979323846 / 180.0));
    memset(m, 0, 16 * sizeof *m);
    m[0] = 1.0 / (aspect * th);
    m[5] = 1.0 / th;
    m[11] = -1.0;
    if (f == 0.0) {
        m[10] = -1.0;
        m[14] = -2.0 * n;
    } else {
        m[10] = -(f + n) / (f - n);
        m[14] = -(2.0 * f * n) / (f - n);
    }
}

static void camera_matrices(const vis_camera *c, uint32_t W, uint32_t H, double view[16], double proj[16])
{
    look_at(c->eye, c->target, view);
    perspective(c->fovy_deg == 0.0 ? 60.0 : c->fovy_deg, (double)W / (double)H,
                c->near_dist == 0.0 ? 0.05 : c->near_dist, c->far_dist, proj);
}

/* Traces cam both ways and compares the buffers bit for bit. */
static void check_same_buffers(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t W, uint32_t H,
                               int view_index)
{
    double view[16], proj[16];
    camera_matrices(cam, W, H, view, proj);
    vis_camera mc;
    vis_status st = vis_camera_from_matrices(ctx, view, proj, W, H, &mc);
    if (st != VIS_OK)
        fail_msg("view %d: vis_camera_from_matrices: %s", view_index, vis_context_last_error(ctx));
    size_t n = (size_t)W * H;
    uint32_t *a = malloc(n * 4), *b = malloc(n * 4);
    float *da = malloc(n * 4), *db = malloc(n * 4);
    assert_non_null(a), assert_non_null(b), assert_non_null(da), assert_non_null(db);
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = W;
    td.height = H;
    assert_int_equal(vis_trace(ctx, scene, cam, &td, a, n, da, n), VIS_OK);
    assert_int_equal(vis_trace(ctx, scene, &mc, &td, b, n, db, n), VIS_OK);
    size_t hits = 0;
    for (size_t i = 0; i < n; ++i) {
        if (a[i] != b[i] || memcmp(&da[i], &db[i], 4) != 0)
            fail_msg("view %d, pixel %zu: eye/target gives id %u depth %.9g, matrices id %u depth %.9g", view_index, i,
                     a[i], (double)da[i], b[i], (double)db[i]);
        hits += a[i] != 0;
    }
    /* The conversion keeps the eye exactly where a rigid view puts it (to rounding). */
    for (int k = 0; k < 3; ++k)
        assert_true(fabs(mc.eye[k] - cam->eye[k]) <= 1e-9 * (1.0 + fabs(cam->eye[k])));
    (void)hits;
    free(a), free(b), free(da), free(db);
}

static void random_views(const double origin[3], uint64_t seed, uint32_t W, uint32_t H)
{
    uint64_t rng = seed;
    tworld w;
    random_chunk_world(&w, &rng, 4, 2, 4);
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene *scene = make_scene(ctx, &w, origin, 0);
    view_opts vo = view_default;
    vo.far = 0.3; /* some finite far planes, so near and far both come from the projection */
    int views = vt_small() ? 40 : 200;
    for (int v = 0; v < views; ++v) {
        vis_camera cam;
        random_view_opts(&cam, &rng, w.size, origin, &vo);
        check_same_buffers(ctx, scene, &cam, W, H, v);
    }
    vis_context_destroy(ctx);
    free_world(&w);
}

static void test_matrices_equal_eye_target(void **state)
{
    (void)state;
    const double zero[3] = {0, 0, 0};
    random_views(zero, 12, 64, 64);
    random_views(zero, 13, 96, 40); /* not square: the aspect comes from [0][0] / [1][1] */
}

static void test_matrices_far_from_origin(void **state)
{
    (void)state;
    const double far_origin[3] = {1048576.0 * 16.0, -4096.0, -1048576.0 * 8.0};
    random_views(far_origin, 14, 48, 48);
}

/* Straight down: the eye/target form's right axis there is f x (0,0,-1); the same view with
 * another yaw cannot be expressed and is refused, not silently turned. */
static void test_straight_down(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_camera cam = {{10, 50, 10}, {10, 0, 10}, 60, 0, 0};
    double view[16], proj[16];
    camera_matrices(&cam, 32, 32, view, proj);
    vis_camera mc;
    assert_int_equal(vis_camera_from_matrices(ctx, view, proj, 32, 32, &mc), VIS_OK);
    assert_true(mc.target[1] < mc.eye[1]);
    /* Yawed by 90 degrees about Y: right axis (0,0,1) instead of (1,0,0). */
    double yawed[16];
    memcpy(yawed, view, sizeof yawed);
    for (int c = 0; c < 3; ++c) {
        yawed[c * 4 + 0] = c == 2 ? 1.0 : 0.0;
        yawed[c * 4 + 1] = c == 0 ? 1.0 : 0.0;
    }
    yawed[12] = -10.0, yawed[13] = 10.0;
    assert_int_equal(vis_camera_from_matrices(ctx, yawed, proj, 32, 32, &mc), VIS_ERROR_UNSUPPORTED);
    assert_non_null(strstr(vis_context_last_error(ctx), "straight along Y"));
    vis_context_destroy(ctx);
}

/* Every refusal: the status, a message naming the problem, and the output left alone. */
static void expect_refused(vis_context *ctx, const double *view, const double *proj, uint32_t W, uint32_t H,
                           vis_status want, const char *words)
{
    vis_camera out;
    memset(&out, 0x5A, sizeof out);
    vis_camera before = out;
    vis_status st = vis_camera_from_matrices(ctx, view, proj, W, H, &out);
    if (st != want)
        fail_msg("expected %s for \"%s\", got %s: %s", vis_status_string(want), words, vis_status_string(st),
                 vis_context_last_error(ctx));
    if (!strstr(vis_context_last_error(ctx), words))
        fail_msg("message \"%s\" does not say \"%s\"", vis_context_last_error(ctx), words);
    assert_memory_equal(&out, &before, sizeof out);
}

static void test_invalid_matrices(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    const vis_camera cam = {{5, 20, -30}, {40, 2, 60}, 70, 0.5, 500};
    double view[16], proj[16], v[16], p[16];
    camera_matrices(&cam, 64, 48, view, proj);
    vis_camera ok;
    assert_int_equal(vis_camera_from_matrices(ctx, view, proj, 64, 48, &ok), VIS_OK);
    assert_true(fabs(ok.fovy_deg - 70.0) < 1e-9);
    assert_true(fabs(ok.near_dist - 0.5) < 1e-9 && fabs(ok.far_dist - 500.0) < 1e-6);

    assert_int_equal(vis_camera_from_matrices(NULL, view, proj, 64, 48, &ok), VIS_ERROR_INVALID_ARGUMENT);
    expect_refused(ctx, NULL, proj, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "NULL");
    expect_refused(ctx, view, NULL, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "NULL");
    assert_int_equal(vis_camera_from_matrices(ctx, view, proj, 64, 48, NULL), VIS_ERROR_INVALID_ARGUMENT);

    memcpy(v, view, sizeof v), v[13] = NAN;
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "not finite");
    memcpy(p, proj, sizeof p), p[5] = INFINITY;
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "not finite");
    /* Scaled rotation (a model matrix folded in). */
    memcpy(v, view, sizeof v);
    for (int i = 0; i < 12; ++i)
        v[i] *= 2.0;
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "orthonormal");
    /* Mirrored: the right axis negated. */
    memcpy(v, view, sizeof v);
    for (int c = 0; c < 4; ++c)
        v[c * 4] = -v[c * 4];
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "mirror");
    /* Not affine. */
    memcpy(v, view, sizeof v), v[3] = 0.25;
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "last row");
    /* Roll: rotate right and up about the forward axis by 10 degrees. */
    memcpy(v, view, sizeof v);
    double ca = cos(0.1745), sa = sin(0.1745);
    for (int c = 0; c < 4; ++c) {
        double r = view[c * 4 + 0], u = view[c * 4 + 1];
        v[c * 4 + 0] = ca * r + sa * u;
        v[c * 4 + 1] = -sa * r + ca * u;
    }
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_UNSUPPORTED, "roll");
    /* Upside down (a 180 degree roll keeps right horizontal but reversed). */
    memcpy(v, view, sizeof v);
    for (int c = 0; c < 4; ++c)
        v[c * 4 + 0] = -view[c * 4 + 0], v[c * 4 + 1] = -view[c * 4 + 1];
    expect_refused(ctx, v, proj, 64, 48, VIS_ERROR_UNSUPPORTED, "roll");
    /* Off-centre, orthographic, not a projection. */
    memcpy(p, proj, sizeof p), p[8] = 0.1;
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_UNSUPPORTED, "off-centre");
    double ortho[16] = {0.1, 0, 0, 0, 0, 0.1, 0, 0, 0, 0, -0.01, 0, 0, 0, -1, 1};
    expect_refused(ctx, view, ortho, 64, 48, VIS_ERROR_UNSUPPORTED, "orthographic");
    memcpy(p, proj, sizeof p), p[11] = 0.0;
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "not a perspective");
    memcpy(p, proj, sizeof p), p[4] = 0.2;
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "off-diagonal");
    memcpy(p, proj, sizeof p), p[0] = -p[0];
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "must be > 0");
    /* The pass's aspect must be the projection's. */
    expect_refused(ctx, view, proj, 64, 64, VIS_ERROR_INVALID_ARGUMENT, "aspect");
    expect_refused(ctx, view, proj, 0, 48, VIS_ERROR_INVALID_ARGUMENT, "resolution");
    /* near <= 0 and far before near, as an engine's bad inputs would produce them. */
    perspective(60, 64.0 / 48.0, -1.0, 100.0, p);
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "near");
    memcpy(p, proj, sizeof p), p[14] = 0.0;
    expect_refused(ctx, view, p, 64, 48, VIS_ERROR_INVALID_ARGUMENT, "near");
    /* fovy out of range comes from [1][1] <= 0, which is refused above; a tiny [1][1] gives a
     * fovy just below 180 that the shared validation still accepts. */
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matrices_equal_eye_target),
        cmocka_unit_test(test_matrices_far_from_origin),
        cmocka_unit_test(test_straight_down),
        cmocka_unit_test(test_invalid_matrices),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
