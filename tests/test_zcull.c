/*
 * test_zcull.c — the software z-buffer occlusion culler (libvis/src/zcull*.c).
 *
 * Oracles:
 *  - an exact integer top-left-rule rasteriser written here independently (coverage rules:
 *    shared edges and fans cover each pixel centre exactly once);
 *  - a double-precision reference: pixel-centre rays cast against the exact occluders and
 *    boxes (clipping, guard band, conservativeness of depth and of every box test);
 *  - the scalar path, against which the SSE2 and AVX2 paths must match bit for bit.
 */
#define _POSIX_C_SOURCE 200112L /* posix_memalign */

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "test_support.h"
#include "vis/vis.h"
#include "zcull.h"

/* ---- helpers ------------------------------------------------------------------------- */

#define ZT_PI 3.14159265358979323846

typedef struct zt_target {
    vis_zc_target t;
    float *depth, *tile_min;
    uint32_t *count;
} zt_target;

static void zt_make(zt_target *z, uint32_t w, uint32_t h, int count_mode, vis_zc_simd simd)
{
    size_t nd, nt;
    vis_zc_target_sizes(w, h, &nd, &nt);
    z->depth = malloc(nd * sizeof(float));
    z->tile_min = malloc(nt * sizeof(float));
    z->count = count_mode ? malloc(nd * sizeof(uint32_t)) : NULL;
    assert_non_null(z->depth);
    assert_non_null(z->tile_min);
    vis_zc_target_init(&z->t, w, h, z->depth, z->tile_min, z->count, simd);
    vis_zc_target_clear(&z->t);
}

static void zt_free(zt_target *z)
{
    free(z->depth);
    free(z->tile_min);
    free(z->count);
}

static uint32_t zt_count(const zt_target *z, uint32_t x, uint32_t y)
{
    return z->count[vis_zc_pixel_index(&z->t, x, y)];
}

static double urand(uint64_t *s, double lo, double hi)
{
    return lo + (hi - lo) * vt_rand_unit(s);
}

static int64_t irand(uint64_t *s, int64_t lo, int64_t hi) /* inclusive */
{
    return lo + (int64_t)(vt_rand(s) % (uint64_t)(hi - lo + 1));
}

/* ---- an independent exact top-left rasteriser ---------------------------------------- */

/* Pixel centre (X, Y) in sub-pixel units, exact. Covered by triangle (x[], y[]) (either
 * winding) under the top-left rule: inside, or on a top edge (horizontal, third vertex
 * below) or a left edge (third vertex to its right). */
static int ref_covered(const int64_t *x, const int64_t *y, int f, int64_t X, int64_t Y)
{
    __int128 px = ((__int128)X << f) + ((__int128)1 << (f - 1));
    __int128 py = ((__int128)Y << f) + ((__int128)1 << (f - 1));
    __int128 area = (__int128)(x[1] - x[0]) * (y[2] - y[0]) - (__int128)(x[2] - x[0]) * (y[1] - y[0]);
    if (area == 0)
        return 0;
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        /* side of p and of the third vertex relative to edge (i, j) */
        __int128 ep = (__int128)(x[j] - x[i]) * (py - y[i]) - (__int128)(y[j] - y[i]) * (px - x[i]);
        __int128 ek = (__int128)(x[j] - x[i]) * (y[k] - y[i]) - (__int128)(y[j] - y[i]) * (x[k] - x[i]);
        if (ep == 0) {
            int top_or_left;
            if (y[j] == y[i])
                top_or_left = y[k] > y[i];
            else {
                /* third vertex right of the edge at its height: sign of x_k - x_line(y_k) */
                __int128 num = (__int128)(x[k] - x[i]) * (y[j] - y[i]) - (__int128)(y[k] - y[i]) * (x[j] - x[i]);
                top_or_left = (num > 0) == (y[j] - y[i] > 0);
            }
            if (!top_or_left)
                return 0;
        } else if ((ep > 0) != (ek > 0)) {
            return 0;
        }
    }
    return 1;
}

static void draw_fixed_tri(zt_target *z, const int64_t *x, const int64_t *y, double za, double zb, double zc)
{
    vis_zc_fixed_poly p;
    memset(&p, 0, sizeof p);
    p.n = 3;
    for (int i = 0; i < 3; i++) {
        p.x[i] = x[i];
        p.y[i] = y[i];
    }
    p.za = za;
    p.zb = zb;
    p.zc = zc;
    vis_zc_draw_fixed(&z->t, &p);
}

/* A random sub-pixel coordinate: half of them on the half-pixel grid, so that edges run
 * exactly through pixel centres and vertices sit exactly on them. */
static int64_t rand_coord(uint64_t *s, int f, int64_t lo_px, int64_t hi_px)
{
    int64_t v = irand(s, lo_px * ((int64_t)1 << f), hi_px * ((int64_t)1 << f));
    switch (vt_rand(s) % 4) {
    case 0: return v & ~(((int64_t)1 << (f - 1)) - 1); /* half-pixel grid   */
    case 1: return v & ~(((int64_t)1 << f) - 1);       /* pixel corners     */
    default: return v;
    }
}

/* Checks the count buffer against the reference triangles, pixel by pixel: every pixel
 * covered exactly as often as the reference says, and at most once. */
static void check_counts(const zt_target *z, int ntri, const int64_t (*tx)[3], const int64_t (*ty)[3], int max_once)
{
    for (uint32_t Y = 0; Y < z->t.height; Y++) {
        for (uint32_t X = 0; X < z->t.width; X++) {
            uint32_t want = 0;
            for (int i = 0; i < ntri; i++)
                want += (uint32_t)ref_covered(tx[i], ty[i], z->t.sub_bits, X, Y);
            uint32_t got = zt_count(z, X, Y);
            if (got != want || (max_once && got > 1)) {
                print_error("pixel (%u,%u): covered %u times, reference %u\n", X, Y, got, want);
                fail();
            }
        }
    }
}

/* ---- coverage rules ------------------------------------------------------------------ */

static void test_shared_edge_exactly_once(void **state)
{
    (void)state;
    uint64_t rng = 11;
    const int iters = vt_small() ? 300 : 3000;
    for (int it = 0; it < iters; it++) {
        uint32_t w = (uint32_t)irand(&rng, 1, 40), h = (uint32_t)irand(&rng, 1, 40);
        vis_zc_simd simd = (vis_zc_simd)(1 + it % 3);
        zt_target z;
        zt_make(&z, w, h, 1, simd);
        const int f = z.t.sub_bits;
        int64_t span = it % 7 == 0 ? (int64_t)1 << (z.t.guard_bits - 1) : 48;
        if (span > (int64_t)1 << (z.t.guard_bits - 1))
            span = (int64_t)1 << (z.t.guard_bits - 1);
        /* Two triangles (a, b, c) and (b, a, d): the shared edge a-b, walked both ways. */
        int64_t ax = rand_coord(&rng, f, -span / 4, span), ay = rand_coord(&rng, f, -span / 4, span);
        int64_t bx = rand_coord(&rng, f, -span / 4, span), by = rand_coord(&rng, f, -span / 4, span);
        if (it % 5 == 0)
            by = ay; /* horizontal shared edge */
        if (it % 5 == 1)
            bx = ax; /* vertical shared edge   */
        int64_t cx = rand_coord(&rng, f, -span / 4, span), cy = rand_coord(&rng, f, -span / 4, span);
        /* d on the other side of a-b */
        int64_t dx = rand_coord(&rng, f, -span / 4, span), dy = rand_coord(&rng, f, -span / 4, span);
        __int128 sc = (__int128)(bx - ax) * (cy - ay) - (__int128)(by - ay) * (cx - ax);
        __int128 sd = (__int128)(bx - ax) * (dy - ay) - (__int128)(by - ay) * (dx - ax);
        if (sc == 0 || sd == 0 || (sc > 0) == (sd > 0)) {
            dx = ax + bx - cx; /* reflect c through the edge's midpoint */
            dy = ay + by - cy;
        }
        int64_t lim = (int64_t)1 << (z.t.guard_bits + f);
        if (llabs(dx) > lim || llabs(dy) > lim) {
            zt_free(&z);
            continue; /* outside the fixed-point range the rasteriser accepts */
        }
        int64_t tx[2][3] = {{ax, bx, cx}, {bx, ax, dx}}, ty[2][3] = {{ay, by, cy}, {by, ay, dy}};
        draw_fixed_tri(&z, tx[0], ty[0], 0, 0, 1);
        draw_fixed_tri(&z, tx[1], ty[1], 0, 0, 1);
        check_counts(&z, 2, (const int64_t(*)[3])tx, (const int64_t(*)[3])ty, 1);
        zt_free(&z);
    }
}

static void test_fan_around_pixel_centre(void **state)
{
    (void)state;
    uint64_t rng = 12;
    const int iters = vt_small() ? 200 : 2000;
    for (int it = 0; it < iters; it++) {
        uint32_t w = (uint32_t)irand(&rng, 4, 48), h = (uint32_t)irand(&rng, 4, 48);
        zt_target z;
        zt_make(&z, w, h, 1, (vis_zc_simd)(1 + it % 3));
        const int f = z.t.sub_bits;
        int64_t CX = irand(&rng, 0, w - 1), CY = irand(&rng, 0, h - 1);
        int64_t cx = (CX << f) + ((int64_t)1 << (f - 1)), cy = (CY << f) + ((int64_t)1 << (f - 1));
        /* n spokes around the vertex at a pixel centre, sorted by angle: a fan. Some run
         * exactly along pixel rows, columns and diagonals (through pixel centres). */
        int n = (int)irand(&rng, 3, 12);
        int64_t px[12], py[12];
        double ang[12];
        for (int i = 0; i < n; i++) {
            double a = urand(&rng, 0, 2 * ZT_PI);
            if (vt_rand(&rng) % 3 == 0) {
                double q = ZT_PI / 4 * floor(a / (ZT_PI / 4) + 0.5);
                int64_t step = irand(&rng, 1, 6) * ((int64_t)1 << f);
                px[i] = cx + (int64_t)llround(cos(q)) * step;
                py[i] = cy + (int64_t)llround(sin(q)) * step;
            } else {
                double r = urand(&rng, 0.3, 12.0) * (double)((int64_t)1 << f);
                px[i] = cx + (int64_t)llround(r * cos(a));
                py[i] = cy + (int64_t)llround(r * sin(a));
            }
            ang[i] = atan2((double)(py[i] - cy), (double)(px[i] - cx));
        }
        for (int i = 1; i < n; i++) /* insertion sort by angle */
            for (int j = i; j > 0 && ang[j] < ang[j - 1]; j--) {
                double ta = ang[j]; ang[j] = ang[j - 1]; ang[j - 1] = ta;
                int64_t t0 = px[j]; px[j] = px[j - 1]; px[j - 1] = t0;
                t0 = py[j]; py[j] = py[j - 1]; py[j - 1] = t0;
            }
        int64_t lim = (int64_t)1 << (z.t.guard_bits + f), far_out = 0;
        for (int i = 0; i < n; i++)
            far_out |= llabs(px[i]) > lim || llabs(py[i]) > lim;
        if (far_out) {
            zt_free(&z);
            continue; /* outside the fixed-point range the rasteriser accepts */
        }
        int64_t tx[12][3], ty[12][3];
        int nt = 0;
        for (int i = 0; i < n; i++) {
            int j = (i + 1) % n;
            tx[nt][0] = cx; ty[nt][0] = cy;
            tx[nt][1] = px[i]; ty[nt][1] = py[i];
            tx[nt][2] = px[j]; ty[nt][2] = py[j];
            /* skip spokes that would make a reflex or degenerate wedge (not a fan then) */
            __int128 cr = (__int128)(px[i] - cx) * (py[j] - cy) - (__int128)(py[i] - cy) * (px[j] - cx);
            if (cr <= 0)
                continue;
            draw_fixed_tri(&z, tx[nt], ty[nt], 0, 0, 1);
            nt++;
        }
        check_counts(&z, nt, (const int64_t(*)[3])tx, (const int64_t(*)[3])ty, 1);
        /* The pixel holding the shared vertex: exactly once when the wedges close around it. */
        if (nt == n)
            assert_int_equal(zt_count(&z, (uint32_t)CX, (uint32_t)CY), 1);
        zt_free(&z);
    }
}

/* Single triangles across the whole fixed-point range (guard band included): the
 * traversal and the int32 inner loop must agree with the exact reference everywhere. */
static void test_fill_rule_single_triangles(void **state)
{
    (void)state;
    uint64_t rng = 13;
    const int iters = vt_small() ? 300 : 3000;
    for (int it = 0; it < iters; it++) {
        uint32_t w = (uint32_t)irand(&rng, 1, 64), h = (uint32_t)irand(&rng, 1, 64);
        zt_target z;
        zt_make(&z, w, h, 1, (vis_zc_simd)(1 + it % 3));
        const int f = z.t.sub_bits;
        int64_t g = (int64_t)1 << z.t.guard_bits;
        int64_t tx[1][3], ty[1][3];
        for (int i = 0; i < 3; i++) {
            int big = it % 4 == 0;
            tx[0][i] = big ? irand(&rng, -(g << f), g << f) : rand_coord(&rng, f, -8, (int64_t)w + 8);
            ty[0][i] = big ? irand(&rng, -(g << f), g << f) : rand_coord(&rng, f, -8, (int64_t)h + 8);
        }
        draw_fixed_tri(&z, tx[0], ty[0], 0, 0, 1);
        check_counts(&z, 1, (const int64_t(*)[3])tx, (const int64_t(*)[3])ty, 1);
        zt_free(&z);
    }
}

/* ---- the double-precision reference -------------------------------------------------- */

typedef struct ref_cam {
    double eye[3], f[3], r[3], u[3];
    double tan_half, near_dist, far_dist;
    uint32_t w, h;
} ref_cam;

static void v3_sub(double *o, const double *a, const double *b)
{
    for (int i = 0; i < 3; i++)
        o[i] = a[i] - b[i];
}
static double v3_dot(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void v3_cross(double *o, const double *a, const double *b)
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}
static void v3_norm(double *a)
{
    double l = sqrt(v3_dot(a, a));
    for (int i = 0; i < 3; i++)
        a[i] /= l;
}

/* The camera basis exactly as DESIGN.md defines it. */
static void ref_cam_make(ref_cam *c, const double eye[3], const double target[3], double fovy_deg, double near_dist,
                         double far_dist, uint32_t w, uint32_t h)
{
    memcpy(c->eye, eye, sizeof c->eye);
    v3_sub(c->f, target, eye);
    v3_norm(c->f);
    double up[3] = {0, 1, 0};
    v3_cross(c->r, c->f, up);
    if (c->r[0] == 0 && c->r[1] == 0 && c->r[2] == 0) {
        double alt[3] = {0, 0, -1};
        v3_cross(c->r, c->f, alt);
    }
    v3_norm(c->r);
    v3_cross(c->u, c->r, c->f);
    c->tan_half = tan(fovy_deg * 0.5 * (ZT_PI / 180.0));
    c->near_dist = near_dist;
    c->far_dist = far_dist;
    c->w = w;
    c->h = h;
}

static void ref_view(const ref_cam *c, const vis_zc_target *t, vis_zc_view *v)
{
    vis_zc_view_make(v, t, c->eye, c->f, c->r, c->u, c->tan_half, c->near_dist, c->far_dist);
}

/* Direction (not normalised; d.f = 1) of the ray through pixel (X + ox, Y + oy). */
static void ref_dir(const ref_cam *c, double px, double py, double d[3])
{
    double aspect = (double)c->w / (double)c->h;
    double nx = px / c->w * 2.0 - 1.0, ny = 1.0 - py / c->h * 2.0;
    for (int i = 0; i < 3; i++)
        d[i] = c->f[i] + nx * c->tan_half * aspect * c->r[i] + ny * c->tan_half * c->u[i];
}

/* Occluders of the reference: triangles and axis-aligned quads, scene-local. */
typedef struct ref_occ {
    int is_quad;
    vis_flat_quad q;
    vis_flat_tri t;
} ref_occ;

/* Ray (origin eye, direction d) against a triangle, closed, in double; parameter s along d
 * (which is the camera-space depth w since d.f = 1), or INFINITY. */
static double ref_hit_tri(const double eye[3], const double d[3], const float *a, const float *b, const float *cc)
{
    double A[3], B[3], C[3];
    for (int i = 0; i < 3; i++) {
        A[i] = (double)a[i] - eye[i];
        B[i] = (double)b[i] - eye[i];
        C[i] = (double)cc[i] - eye[i];
    }
    double e1[3], e2[3], pv[3], qv[3];
    v3_sub(e1, B, A);
    v3_sub(e2, C, A);
    v3_cross(pv, d, e2);
    double det = v3_dot(e1, pv);
    if (det == 0.0)
        return INFINITY;
    double inv = 1.0 / det;
    double tv[3] = {-A[0], -A[1], -A[2]};
    double u = v3_dot(tv, pv) * inv;
    v3_cross(qv, tv, e1);
    double v = v3_dot(d, qv) * inv;
    if (u < 0 || v < 0 || u + v > 1)
        return INFINITY;
    double s = v3_dot(e2, qv) * inv;
    return s;
}

static double ref_hit_quad(const double eye[3], const double d[3], const vis_flat_quad *q)
{
    int a = (int)(q->meta & 3), ua = (a + 1) % 3, va = (a + 2) % 3;
    if (d[a] == 0.0)
        return INFINITY;
    double s = ((double)q->plane - eye[a]) / d[a];
    double pu = eye[ua] + s * d[ua], pv = eye[va] + s * d[va];
    if (pu < q->u0 || pu > q->u1 || pv < q->v0 || pv > q->v1)
        return INFINITY;
    return s;
}

/* Nearest occluder hit along the pixel ray whose distance is >= near (as the ray pass
 * counts hits), or INFINITY. */
static double ref_occluder_s(const ref_cam *c, const double d[3], const ref_occ *occ, int nocc)
{
    double len = sqrt(v3_dot(d, d)), best = INFINITY;
    for (int i = 0; i < nocc; i++) {
        double s = occ[i].is_quad ? ref_hit_quad(c->eye, d, &occ[i].q)
                                  : ref_hit_tri(c->eye, d, occ[i].t.v0, occ[i].t.v1, occ[i].t.v2);
        if (s * len >= c->near_dist && s < best)
            best = s;
    }
    return best;
}

/* Closed slab test; the box's first point along the ray at distance >= near. */
static double ref_box_s(const ref_cam *c, const double d[3], const float lo[3], const float hi[3])
{
    double len = sqrt(v3_dot(d, d));
    double s0 = c->near_dist / len, s1 = INFINITY;
    for (int a = 0; a < 3; a++) {
        double l = (double)lo[a] - c->eye[a], h = (double)hi[a] - c->eye[a];
        if (d[a] == 0.0) {
            if (l > 0 || h < 0)
                return INFINITY;
            continue;
        }
        double ta = l / d[a], tb = h / d[a];
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        s0 = ta > s0 ? ta : s0;
        s1 = tb < s1 ? tb : s1;
    }
    if (s0 > s1 || s0 * len > c->far_dist)
        return INFINITY;
    return s0;
}

/* The reference: visible when some pixel centre sees a point of the box no farther than
 * every occluder at that pixel. */
static int ref_box_visible(const ref_cam *c, const ref_occ *occ, int nocc, const float lo[3], const float hi[3])
{
    for (uint32_t Y = 0; Y < c->h; Y++) {
        for (uint32_t X = 0; X < c->w; X++) {
            double d[3];
            ref_dir(c, X + 0.5, Y + 0.5, d);
            double sb = ref_box_s(c, d, lo, hi);
            if (sb == INFINITY)
                continue;
            if (sb <= ref_occluder_s(c, d, occ, nocc))
                return 1;
        }
    }
    return 0;
}

static void draw_occ(vis_zc_target *t, const vis_zc_view *v, const ref_occ *o)
{
    if (o->is_quad)
        vis_zc_draw_quad(t, v, &o->q);
    else
        vis_zc_draw_tri(t, v, &o->t);
}

/* What the culler decides for one box against the current buffer. */
static int zc_box_visible(const vis_zc_target *t, const vis_zc_view *v, const float lo[3], const float hi[3])
{
    vis_zc_rect r;
    switch (vis_zc_box_classify(t, v, lo, hi, &r, NULL)) {
    case VIS_ZC_BOX_CULLED: return 0;
    case VIS_ZC_BOX_NEAR: return 1;
    default: return vis_zc_rect_visible(t, &r);
    }
}

/* ---- random scenes ------------------------------------------------------------------- */

static float rand_grid(uint64_t *s, double lo, double hi, int integer)
{
    double v = urand(s, lo, hi);
    return (float)(integer ? floor(v) : v);
}

static void rand_quad(uint64_t *s, vis_flat_quad *q, double lo, double hi, int integer)
{
    uint32_t a = (uint32_t)(vt_rand(s) % 3);
    float u0 = rand_grid(s, lo, hi, integer), u1 = rand_grid(s, lo, hi, integer);
    float v0 = rand_grid(s, lo, hi, integer), v1 = rand_grid(s, lo, hi, integer);
    q->plane = rand_grid(s, lo, hi, integer);
    q->u0 = fminf(u0, u1);
    q->u1 = fmaxf(u0, u1);
    q->v0 = fminf(v0, v1);
    q->v1 = fmaxf(v0, v1);
    q->meta = a;
}

static void rand_tri(uint64_t *s, vis_flat_tri *t, double lo, double hi, int integer)
{
    for (int i = 0; i < 3; i++) {
        t->v0[i] = rand_grid(s, lo, hi, integer);
        t->v1[i] = rand_grid(s, lo, hi, integer);
        t->v2[i] = rand_grid(s, lo, hi, integer);
    }
    t->meta = 0;
}

typedef struct rand_config {
    ref_cam cam;
    ref_occ occ[8];
    int nocc;
    float lo[6][3], hi[6][3];
    int nbox;
} rand_config;

static void rand_camera(uint64_t *s, ref_cam *c, uint32_t w, uint32_t h, double far_dist)
{
    double eye[3], target[3];
    int kind = (int)(vt_rand(s) % 6);
    for (int i = 0; i < 3; i++) {
        eye[i] = urand(s, -6, 22);
        target[i] = urand(s, 2, 14);
    }
    if (kind == 0) {
        /* integer eye, looking straight along an axis: edges through pixel centres */
        for (int i = 0; i < 3; i++)
            eye[i] = floor(eye[i]);
        int a = (int)(vt_rand(s) % 3);
        for (int i = 0; i < 3; i++)
            target[i] = eye[i];
        target[a] += vt_rand(s) % 2 ? 5 : -5;
    } else if (kind == 1) {
        /* close to the geometry: near-plane crossings and huge projections */
        for (int i = 0; i < 3; i++)
            eye[i] = urand(s, 2, 14);
    }
    if (eye[0] == target[0] && eye[1] == target[1] && eye[2] == target[2])
        target[2] += 1;
    double fov = vt_rand(s) % 4 == 0 ? urand(s, 1, 179) : urand(s, 20, 110);
    double near_dist = vt_rand(s) % 3 == 0 ? urand(s, 0.5, 4) : urand(s, 0.001, 0.2);
    ref_cam_make(c, eye, target, fov, near_dist, far_dist, w, h);
}

static void rand_config_make(uint64_t *s, rand_config *cf, int max_res)
{
    uint32_t w = (uint32_t)irand(s, 1, max_res), h = (uint32_t)irand(s, 1, max_res);
    double far_dist = vt_rand(s) % 8 == 0 ? urand(s, 2, 30) : INFINITY;
    rand_camera(s, &cf->cam, w, h, far_dist);
    int integer = vt_rand(s) % 2;
    cf->nocc = (int)irand(s, 0, 6);
    for (int i = 0; i < cf->nocc; i++) {
        cf->occ[i].is_quad = vt_rand(s) % 3 != 0;
        if (cf->occ[i].is_quad)
            rand_quad(s, &cf->occ[i].q, 0, 16, integer);
        else
            rand_tri(s, &cf->occ[i].t, 0, 16, integer);
    }
    cf->nbox = (int)irand(s, 1, 5);
    for (int b = 0; b < cf->nbox; b++) {
        for (int a = 0; a < 3; a++) {
            double c0 = urand(s, 0, 16), e = vt_rand(s) % 4 == 0 ? urand(s, 0, 0.3) : urand(s, 0, 5);
            cf->lo[b][a] = (float)(integer ? floor(c0) : c0);
            cf->hi[b][a] = (float)(integer ? floor(c0) + floor(e) : c0 + e);
            if (vt_rand(s) % 10 == 0)
                cf->hi[b][a] = cf->lo[b][a]; /* flat */
        }
        /* sometimes a box face lies exactly in an occluder quad's plane (a tie) */
        if (cf->nocc && cf->occ[0].is_quad && vt_rand(s) % 4 == 0) {
            int a = (int)(cf->occ[0].q.meta & 3);
            if (vt_rand(s) % 2)
                cf->lo[b][a] = cf->occ[0].q.plane;
            else
                cf->hi[b][a] = cf->occ[0].q.plane;
            if (cf->lo[b][a] > cf->hi[b][a]) {
                float tmp = cf->lo[b][a];
                cf->lo[b][a] = cf->hi[b][a];
                cf->hi[b][a] = tmp;
            }
        }
    }
}

/* ---- SIMD paths against the scalar reference ----------------------------------------- */


static void test_simd_bit_exact(void **state)
{
    (void)state;
    vis_zc_simd best = vis_zc_simd_resolve(VIS_ZC_SIMD_AUTO);
    print_message("zcull: best ISA here: %s\n", vis_zc_simd_name(best));
    uint64_t rng = 14;
    const int iters = vt_small() ? 40 : 300;
    for (int it = 0; it < iters; it++) {
        uint32_t w = (uint32_t)irand(&rng, 1, 300), h = (uint32_t)irand(&rng, 1, 200);
        int count_mode = it % 5 == 0;
        zt_target z[3];
        for (int p = 0; p < 3; p++)
            zt_make(&z[p], w, h, count_mode, (vis_zc_simd)(VIS_ZC_SIMD_SCALAR + p));
        int npoly = (int)irand(&rng, 1, 60);
        for (int k = 0; k < npoly; k++) {
            vis_zc_fixed_poly p;
            memset(&p, 0, sizeof p);
            p.n = (int)irand(&rng, 3, 8);
            const int f = z[0].t.sub_bits;
            double cx = urand(&rng, -20, w + 20), cy = urand(&rng, -20, h + 20), r = urand(&rng, 0.2, 150);
            double a0 = urand(&rng, 0, 2 * ZT_PI);
            for (int i = 0; i < p.n; i++) {
                double a = a0 + 2 * ZT_PI * i / p.n;
                p.x[i] = llround((cx + r * cos(a)) * ldexp(1, f));
                p.y[i] = llround((cy + r * sin(a)) * ldexp(1, f));
                p.margin[i] = it % 2 ? irand(&rng, 0, (int64_t)1 << (f + 4)) : 0;
            }
            p.za = urand(&rng, -0.01, 0.01);
            p.zb = urand(&rng, -0.01, 0.01);
            p.zc = urand(&rng, 0.0, 2.0);
            for (int q = 0; q < 3; q++)
                vis_zc_draw_fixed(&z[q].t, &p);
        }
        /* and projected occluders: quads (whose front end has its own AVX2 code) and
         * triangles, through the clipper too */
        if (it % 2) {
            ref_cam c;
            rand_camera(&rng, &c, w, h, INFINITY);
            vis_zc_view v;
            ref_view(&c, &z[0].t, &v);
            int nq = (int)irand(&rng, 1, 40);
            for (int k = 0; k < nq; k++) {
                ref_occ o;
                memset(&o, 0, sizeof o);
                o.is_quad = k % 4 != 0;
                double lo = k % 5 == 0 ? -500 : 0, hi = k % 5 == 0 ? 500 : 16;
                if (o.is_quad)
                    rand_quad(&rng, &o.q, lo, hi, k % 3 == 0);
                else
                    rand_tri(&rng, &o.t, lo, hi, k % 3 == 0);
                for (int q = 0; q < 3; q++)
                    draw_occ(&z[q].t, &v, &o);
            }
        }
        size_t nd, nt;
        vis_zc_target_sizes(w, h, &nd, &nt);
        for (int q = 1; q < 3; q++) {
            if (z[q].t.simd != (vis_zc_simd)(VIS_ZC_SIMD_SCALAR + q))
                continue; /* not runnable on this CPU: resolved to another path */
            assert_memory_equal(z[0].depth, z[q].depth, nd * sizeof(float));
            assert_memory_equal(z[0].tile_min, z[q].tile_min, nt * sizeof(float));
            if (count_mode)
                assert_memory_equal(z[0].count, z[q].count, nd * sizeof(uint32_t));
        }
        for (int q = 0; q < 3; q++)
            zt_free(&z[q]);
    }
}

/* ---- clipping and the guard band against the reference -------------------------------- */

/* Does the pixel-centre ray at (px, py) hit the occluder with camera depth w >= near
 * (the culler clips at the near plane)? Returns the hit depth w or INFINITY. */
static double ref_clip_hit(const ref_cam *c, const ref_occ *o, double px, double py)
{
    double d[3];
    ref_dir(c, px, py, d);
    double s = o->is_quad ? ref_hit_quad(c->eye, d, &o->q) : ref_hit_tri(c->eye, d, o->t.v0, o->t.v1, o->t.v2);
    return s >= c->near_dist ? s : INFINITY;
}

static void test_clipping_and_guard_band(void **state)
{
    (void)state;
    uint64_t rng = 15;
    const int iters = vt_small() ? 300 : 4000;
    long checked = 0, ambiguous = 0, covered = 0, missed = 0;
    double worst_rel = 0.0;
    for (int it = 0; it < iters; it++) {
        uint32_t w = (uint32_t)irand(&rng, 1, 48), h = (uint32_t)irand(&rng, 1, 48);
        ref_cam c;
        rand_camera(&rng, &c, w, h, INFINITY);
        zt_target zc, zd;
        zt_make(&zc, w, h, 1, (vis_zc_simd)(1 + it % 3));
        zt_make(&zd, w, h, 0, (vis_zc_simd)(1 + it % 3));
        vis_zc_view v;
        ref_view(&c, &zc.t, &v);
        ref_occ o;
        memset(&o, 0, sizeof o);
        o.is_quad = it % 2;
        /* large ones cross the near plane and leave the guard band */
        double lo = it % 3 == 0 ? -2000 : 0, hi = it % 3 == 0 ? 2000 : 16;
        if (o.is_quad)
            rand_quad(&rng, &o.q, lo, hi, it % 4 == 1);
        else
            rand_tri(&rng, &o.t, lo, hi, it % 4 == 1);
        draw_occ(&zc.t, &v, &o);
        draw_occ(&zd.t, &v, &o);
        const double tol = 1e-3; /* pixels: the snapped, shrunk edges move less than this */
        for (uint32_t Y = 0; Y < h; Y++) {
            for (uint32_t X = 0; X < w; X++) {
                static const double off[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
                double px = X + 0.5, py = Y + 0.5;
                double wc = ref_clip_hit(&c, &o, px, py);
                int inside = wc < INFINITY;
                int amb = 0;
                for (int k = 0; k < 4 && !amb; k++)
                    amb = (ref_clip_hit(&c, &o, px + off[k][0] * tol, py + off[k][1] * tol) < INFINITY) != inside;
                /* near the near-plane edge of the clipped polygon */
                if (!amb && !inside) {
                    double d[3];
                    ref_dir(&c, px, py, d);
                    double s = o.is_quad ? ref_hit_quad(c.eye, d, &o.q) : ref_hit_tri(c.eye, d, o.t.v0, o.t.v1, o.t.v2);
                    amb = s < INFINITY && fabs(s - c.near_dist) <= 1e-6 * (1 + c.near_dist);
                }
                uint32_t got = zt_count(&zc, X, Y);
                checked++;
                assert_true(got <= 1);
                if (got && !inside) {
                    /* never cover a centre outside the exact clipped polygon */
                    int loose = 0;
                    for (int k = 0; k < 4 && !loose; k++)
                        loose = ref_clip_hit(&c, &o, px + off[k][0] * 1e-7, py + off[k][1] * 1e-7) < INFINITY;
                    if (!loose) {
                        print_error("iteration %d pixel (%u,%u) of %ux%u: covered outside the polygon\n", it, X, Y, w, h);
                        fail();
                    }
                }
                if (amb) {
                    ambiguous++;
                    continue;
                }
                if (inside && !got)
                    missed++; /* shrunk away: slivers, whose short edges' directions are uncertain */
                if (inside && got) {
                    /* stored depth: never nearer than the surface, and close to it */
                    float dz = zd.depth[vis_zc_pixel_index(&zd.t, X, Y)];
                    double iw = 1.0 / wc;
                    assert_true((double)dz <= iw);
                    double rel = (iw - dz) / iw;
                    worst_rel = rel > worst_rel ? rel : worst_rel;
                    covered++;
                }
            }
        }
        zt_free(&zc);
        zt_free(&zd);
    }
    print_message("zcull clip: %ld pixels checked, %ld covered, %ld within 1e-3 px of an edge, %ld inside "
                  "but shrunk away; largest relative depth under-estimate %.3g\n",
                  checked, covered, ambiguous, missed, worst_rel);
    assert_true(covered > checked / 20);
    assert_true(missed <= covered / 10000);
    assert_true(worst_rel < 1e-2); /* the plane is conservative, not useless */
}

/* ---- box tests ------------------------------------------------------------------------ */

static void test_box_classify_edges(void **state)
{
    (void)state;
    ref_cam c;
    double eye[3] = {0, 0, 0}, target[3] = {0, 0, -1};
    ref_cam_make(&c, eye, target, 90.0, 0.1, INFINITY, 8, 8);
    zt_target z;
    zt_make(&z, 8, 8, 0, VIS_ZC_SIMD_AUTO);
    vis_zc_view v;
    ref_view(&c, &z.t, &v);
    vis_zc_rect r;
    /* f = -z, r = +x, u = +y; at depth 4 the screen spans x in [-4, 4]: 1 unit per pixel. */
    float lo[3] = {-1, -1, -5}, hi[3] = {1, 1, -4};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, lo, hi, &r, NULL), VIS_ZC_BOX_ON_SCREEN);
    /* behind the eye */
    float blo[3] = {-1, -1, 2}, bhi[3] = {1, 1, 3};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, blo, bhi, &r, NULL), VIS_ZC_BOX_CULLED);
    /* crossing the near plane, and around the eye */
    float nlo[3] = {-1, -1, -0.5f}, nhi[3] = {1, 1, 0.05f};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, nlo, nhi, &r, NULL), VIS_ZC_BOX_NEAR);
    float elo[3] = {-1, -1, -1}, ehi[3] = {1, 1, 1};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, elo, ehi, &r, NULL), VIS_ZC_BOX_NEAR);
    /* A sliver at depth 4 reaching exactly the leftmost pixel centres' ray (x = -3.5):
     * visible (closed); just short of it: culled. */
    float slo[3] = {-9, -1, -4}, shi[3] = {-3.5f, 1, -4};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, slo, shi, &r, NULL), VIS_ZC_BOX_ON_SCREEN);
    assert_int_equal(r.x0, 0);
    assert_int_equal(r.x1, 0);
    shi[0] = -3.51f;
    assert_int_equal(vis_zc_box_classify(&z.t, &v, slo, shi, &r, NULL), VIS_ZC_BOX_CULLED);
    /* Between two pixel centres: no ray reaches it. */
    float glo[3] = {0.05f, 0.05f, -4}, ghi[3] = {0.45f, 0.45f, -4};
    assert_int_equal(vis_zc_box_classify(&z.t, &v, glo, ghi, &r, NULL), VIS_ZC_BOX_CULLED);
    /* beyond far */
    ref_cam_make(&c, eye, target, 90.0, 0.1, 3.0, 8, 8);
    ref_view(&c, &z.t, &v);
    assert_int_equal(vis_zc_box_classify(&z.t, &v, lo, hi, &r, NULL), VIS_ZC_BOX_CULLED);
    zt_free(&z);
}

/* An occluder in front hides a box behind; a box touching it (tie) stays visible. */
static void test_box_behind_quad(void **state)
{
    (void)state;
    ref_cam c;
    double eye[3] = {0.5, 0.5, 10}, target[3] = {0.5, 0.5, 0};
    ref_cam_make(&c, eye, target, 60.0, 0.05, INFINITY, 64, 48);
    for (int p = 1; p <= 3; p++) {
        zt_target z;
        zt_make(&z, 64, 48, 0, (vis_zc_simd)p);
        vis_zc_view v;
        ref_view(&c, &z.t, &v);
        vis_flat_quad q = {4.0f, -20, -20, 20, 20, 2u}; /* z = 4, large */
        vis_zc_draw_quad(&z.t, &v, &q);
        float lo[3] = {-1, -1, -3}, hi[3] = {1, 1, -1};
        assert_false(zc_box_visible(&z.t, &v, lo, hi));
        float tlo[3] = {-1, -1, 2}, thi[3] = {1, 1, 4}; /* its near face in the quad's plane */
        assert_true(zc_box_visible(&z.t, &v, tlo, thi));
        float flo[3] = {-1, -1, 4.5f}, fhi[3] = {1, 1, 5}; /* in front */
        assert_true(zc_box_visible(&z.t, &v, flo, fhi));
        zt_free(&z);
    }
}

/* Snapping never moves an edge over a pixel centre: edges pass within a few 2^-16 pixel
 * of pixel centres, on either side; a centre outside the exact triangle is never covered,
 * one well inside always is. The camera maps world (x, y) at depth 8 to pixels 1:1. */
static void test_snapping_is_conservative(void **state)
{
    (void)state;
    uint64_t rng = 17;
    ref_cam c;
    double eye[3] = {0, 0, 0}, target[3] = {0, 0, -1};
    ref_cam_make(&c, eye, target, 90.0, 0.05, INFINITY, 16, 16);
    const int iters = vt_small() ? 2000 : 20000;
    long outside = 0, inside = 0;
    for (int it = 0; it < iters; it++) {
        zt_target z;
        zt_make(&z, 16, 16, 1, (vis_zc_simd)(1 + it % 3));
        vis_zc_view v;
        ref_view(&c, &z.t, &v);
        /* pixel centre (X+0.5, Y+0.5) is world (X+0.5-8, 8-(Y+0.5)) at z = -8 */
        int X = (int)irand(&rng, 2, 13), Y = (int)irand(&rng, 2, 13);
        double cxw = X + 0.5 - 8.0, cyw = 8.0 - (Y + 0.5);
        double ang = urand(&rng, 0, 2 * ZT_PI), nx = cos(ang), ny = sin(ang);
        double off = ldexp(urand(&rng, 0.05, 8.0), -16) * (vt_rand(&rng) % 2 ? 1 : -1);
        if (vt_rand(&rng) % 4 == 0)
            off = -ldexp(urand(&rng, 1.0, 4.0), -10); /* well inside */
        /* edge line: points q with (q - c).n = off, i.e. the centre is at signed distance
         * -off from it; the triangle lies on the side (q - c).n >= off */
        double px0 = cxw + nx * off - ny * 5.3, py0 = cyw + ny * off + nx * 5.3;
        double px1 = cxw + nx * off + ny * 4.7, py1 = cyw + ny * off - nx * 4.7;
        double px2 = cxw + nx * (off + 6.1) + ny * 0.4, py2 = cyw + ny * (off + 6.1) - nx * 0.4;
        double p[3][3] = {{px0, py0, -8}, {px1, py1, -8}, {px2, py2, -8}};
        vis_zc_draw_polygon(&z.t, &v, (const double(*)[3])p, 3);
        uint32_t got = zt_count(&z, (uint32_t)X, (uint32_t)Y);
        /* the exact signed distance of the centre from the edge, inside positive */
        if (off > 0) {
            outside++;
            if (got) {
                print_error("iteration %d: centre %g px outside an edge covered\n", it, off);
                fail();
            }
        } else if (off < -ldexp(1.0, -11)) {
            inside++;
            assert_int_equal(got, 1);
        }
        zt_free(&z);
    }
    print_message("zcull snap: %ld centres just outside an edge, %ld inside\n", outside, inside);
}

/* The box's pixel rectangle holds every pixel whose centre ray meets the box, and its depth
 * is never farther than the box's nearest point. */
static void test_box_rect_conservative(void **state)
{
    (void)state;
    uint64_t rng = 18;
    const int iters = vt_small() ? 2000 : 20000;
    for (int it = 0; it < iters; it++) {
        rand_config cf;
        rand_config_make(&rng, &cf, 24);
        zt_target z;
        zt_make(&z, cf.cam.w, cf.cam.h, 0, VIS_ZC_SIMD_AUTO);
        vis_zc_view v;
        ref_view(&cf.cam, &z.t, &v);
        for (int b = 0; b < cf.nbox; b++) {
            vis_zc_rect r;
            vis_zc_box_class k = vis_zc_box_classify(&z.t, &v, cf.lo[b], cf.hi[b], &r, NULL);
            if (k == VIS_ZC_BOX_NEAR)
                continue;
            long double wmin = INFINITY;
            for (int i = 0; i < 8; i++) {
                long double wc = 0;
                for (int a = 0; a < 3; a++)
                    wc += ((long double)(((i >> a) & 1) ? cf.hi[b][a] : cf.lo[b][a]) - cf.cam.eye[a]) * cf.cam.f[a];
                wmin = wc < wmin ? wc : wmin;
            }
            if (k == VIS_ZC_BOX_ON_SCREEN)
                assert_true((long double)r.iw >= 1.0L / wmin);
            for (uint32_t Y = 0; Y < cf.cam.h; Y++)
                for (uint32_t X = 0; X < cf.cam.w; X++) {
                    double d[3];
                    ref_dir(&cf.cam, X + 0.5, Y + 0.5, d);
                    if (ref_box_s(&cf.cam, d, cf.lo[b], cf.hi[b]) == INFINITY)
                        continue;
                    if (k == VIS_ZC_BOX_CULLED || (int)X < r.x0 || (int)X > r.x1 || (int)Y < r.y0 || (int)Y > r.y1) {
                        print_error("iteration %d box %d: pixel (%u,%u) sees it, outside its rect\n", it, b, X, Y);
                        fail();
                    }
                }
        }
        zt_free(&z);
    }
}

/* No visible object is ever culled at the culler's own resolution. */
static void test_random_configurations(void **state)
{
    (void)state;
    uint64_t rng = 16;
    const long iters = vt_small() ? 5000 : 100000;
    long boxes = 0, ref_visible = 0, culled_hidden = 0;
    for (long it = 0; it < iters; it++) {
        rand_config cf;
        rand_config_make(&rng, &cf, 24);
        zt_target z;
        zt_make(&z, cf.cam.w, cf.cam.h, 0, (vis_zc_simd)(1 + it % 3));
        vis_zc_view v;
        ref_view(&cf.cam, &z.t, &v);
        for (int i = 0; i < cf.nocc; i++)
            draw_occ(&z.t, &v, &cf.occ[i]);
        for (int b = 0; b < cf.nbox; b++) {
            int got = zc_box_visible(&z.t, &v, cf.lo[b], cf.hi[b]);
            int want = ref_box_visible(&cf.cam, cf.occ, cf.nocc, cf.lo[b], cf.hi[b]);
            boxes++;
            ref_visible += want;
            culled_hidden += !got && !want;
            if (want && !got) {
                print_error("configuration %ld box %d: visible in the reference, culled\n", it, b);
                fail();
            }
        }
        zt_free(&z);
    }
    print_message("zcull random: %ld configurations, %ld boxes, %ld visible in the reference, "
                  "%ld of the %ld hidden ones culled\n",
                  iters, boxes, ref_visible, culled_hidden, boxes - ref_visible);
    /* the culler must also cull: most hidden boxes */
    assert_true(culled_hidden * 2 > boxes - ref_visible);
}

/* ---- the public API ------------------------------------------------------------------- */

typedef struct count_alloc {
    long allocs;
} count_alloc;

static void *ca_alloc(size_t size, size_t align, void *user)
{
    ((count_alloc *)user)->allocs++;
    void *p = NULL;
    if (posix_memalign(&p, align < sizeof(void *) ? sizeof(void *) : align, size ? size : 1) != 0)
        return NULL;
    return p;
}

static void ca_free(void *ptr, void *user)
{
    (void)user;
    free(ptr);
}

static vis_context *make_ctx(count_alloc *ca)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = 1;
    if (ca) {
        cd.allocator.alloc = ca_alloc;
        cd.allocator.free = ca_free;
        cd.allocator.user = ca;
    }
    vis_context *ctx = NULL;
    assert_int_equal(vis_context_create(&cd, &ctx), VIS_OK);
    return ctx;
}

static vis_scene *make_scene(vis_context *ctx, const double origin[3], float size)
{
    vis_scene_desc sd;
    vis_scene_desc_defaults(&sd);
    memcpy(sd.origin, origin, sizeof sd.origin);
    sd.size[0] = sd.size[1] = sd.size[2] = size;
    sd.cell_size = 4;
    vis_scene *scene = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &scene), VIS_OK);
    return scene;
}

static vis_quad vq(uint32_t axis, float plane, float u0, float v0, float u1, float v1)
{
    vis_quad q = {axis, 0, plane, u0, v0, u1, v1};
    return q;
}

static void test_api_arguments(void **state)
{
    (void)state;
    vis_zcull_desc d;
    vis_zcull_desc_defaults(&d);
    assert_int_equal(d.width, 512);
    assert_int_equal(d.height, 512);
    assert_int_equal(d.occluder_triangles, VIS_ZCULL_DEFAULT_OCCLUDER_TRIANGLES);
    assert_int_equal(d.simd, VIS_ZCULL_SIMD_AUTO);

    vis_context *ctx = make_ctx(NULL);
    double origin[3] = {0, 0, 0};
    vis_scene *scene = make_scene(ctx, origin, 16);
    vis_quad wall = vq(2, 8, 0, 0, 16, 16);
    vis_mesh m = {&wall, 1, NULL, 0};
    assert_int_equal(vis_scene_set_object(scene, 1, &m), VIS_OK);
    vis_zcull *zc = NULL;
    assert_int_equal(vis_zcull_create(ctx, &zc), VIS_OK);
    vis_camera cam = {{8, 8, 20}, {8, 8, 0}, 60, 0.05, 0};
    vis_draw_entry out[4] = {{77, 77}, {77, 77}, {77, 77}, {77, 77}};
    size_t n = 99;
    float depth[16];

    assert_int_equal(vis_zcull_depth(zc, depth, 16), VIS_ERROR_NOT_FOUND);
    assert_int_equal(vis_zcull_run(NULL, scene, &cam, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_zcull_run(zc, NULL, &cam, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(ctx), "scene"));
    assert_int_equal(vis_zcull_run(zc, scene, NULL, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_zcull_run(zc, scene, &cam, NULL, out, 4, NULL, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_zcull_run(zc, scene, &cam, NULL, NULL, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    vis_zcull_desc bad = {VIS_MAX_RESOLUTION + 1, 8, 0, 0, VIS_ZCULL_SIMD_AUTO};
    assert_int_equal(vis_zcull_run(zc, scene, &cam, &bad, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(ctx), "resolution"));
    vis_zcull_desc bads = {8, 8, 0, 0, (vis_zcull_simd)42};
    assert_int_equal(vis_zcull_run(zc, scene, &cam, &bads, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    vis_camera nan_cam = cam;
    nan_cam.eye[1] = NAN;
    assert_int_equal(vis_zcull_run(zc, scene, &nan_cam, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    vis_camera fov_cam = cam;
    fov_cam.fovy_deg = 180;
    assert_int_equal(vis_zcull_run(zc, scene, &fov_cam, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    /* outputs untouched by every failure */
    assert_int_equal(n, 99);
    assert_int_equal(out[0].id, 77);
    assert_int_equal(vis_zcull_depth(zc, depth, 16), VIS_ERROR_NOT_FOUND);

    /* capacity */
    assert_int_equal(vis_zcull_run(zc, scene, &cam, NULL, out, 0, &n, NULL), VIS_ERROR_CAPACITY);
    assert_int_equal(n, 99);
    vis_zcull_stats st;
    assert_int_equal(vis_zcull_run(zc, scene, &cam, NULL, out, vis_drawlist_bound(scene), &n, &st), VIS_OK);
    assert_int_equal(n, 1);
    assert_int_equal(out[0].id, 1);
    assert_int_equal(out[0].pixels, 0);
    assert_int_equal(st.width, 512);
    assert_int_equal(st.objects, 1);
    assert_int_equal(st.triangles, 2);
    assert_int_equal(st.visible, 1);
    assert_true(st.ms_total >= 0.0);
    assert_true(strlen(st.simd) > 0);

    /* The depth buffer of that 512 x 512 run: a 16-float buffer is refused and untouched, the
     * message gives the count needed; an exact one is filled and nothing past it written. */
    for (int i = 0; i < 16; i++)
        depth[i] = -7.0f;
    assert_int_equal(vis_zcull_depth(zc, depth, 16), VIS_ERROR_CAPACITY);
    assert_non_null(strstr(vis_context_last_error(ctx), "262144"));
    for (int i = 0; i < 16; i++)
        assert_true(depth[i] == -7.0f);
    float *full = malloc((512 * 512 + 8) * sizeof *full);
    assert_non_null(full);
    for (int i = 0; i < 512 * 512 + 8; i++)
        full[i] = -7.0f;
    assert_int_equal(vis_zcull_depth(zc, full, 512 * 512 - 1), VIS_ERROR_CAPACITY);
    assert_true(full[0] == -7.0f && full[512 * 512 - 2] == -7.0f);
    assert_int_equal(vis_zcull_depth(zc, full, 512 * 512), VIS_OK);
    assert_true(full[256 * 512 + 256] > 0.0f); /* the wall covers the centre */
    for (int i = 512 * 512; i < 512 * 512 + 8; i++)
        assert_true(full[i] == -7.0f);
    free(full);

    /* a scene from another context */
    vis_context *ctx2 = make_ctx(NULL);
    vis_scene *other = make_scene(ctx2, origin, 16);
    assert_int_equal(vis_zcull_run(zc, other, &cam, NULL, out, 4, &n, NULL), VIS_ERROR_INVALID_ARGUMENT);
    vis_scene_destroy(other);
    vis_context_destroy(ctx2);

    vis_zcull_destroy(zc);
    vis_zcull_destroy(NULL);
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
}

/* A wall hides the objects behind it, not those beside or in front; the depth output is the
 * wall's distance along each pixel's ray, never nearer. No allocation after the first run. */
static void test_api_wall(void **state)
{
    (void)state;
    count_alloc ca = {0};
    vis_context *ctx = make_ctx(&ca);
    double origin[3] = {1e7, -3e6, 5e6}; /* far from the world origin */
    vis_scene *scene = make_scene(ctx, origin, 32);
    /* quads of axis z: u = x, v = y */
    vis_quad wall = vq(2, 16, 8, 4, 24, 28); /* z = 16, x in [8,24], y in [4,28] */
    vis_quad behind = vq(2, 8, 12, 12, 20, 20);
    vis_quad beside = vq(2, 8, 0, 15, 2, 17); /* left of the wall's shadow */
    vis_quad front = vq(2, 20, 14, 14, 18, 18);
    vis_quad back_of_eye = vq(2, 31, 14, 14, 18, 18);
    vis_mesh m1 = {&wall, 1, NULL, 0}, m2 = {&behind, 1, NULL, 0}, m3 = {&beside, 1, NULL, 0},
             m4 = {&front, 1, NULL, 0}, m5 = {&back_of_eye, 1, NULL, 0};
    assert_int_equal(vis_scene_set_object(scene, 5, &m1), VIS_OK);
    assert_int_equal(vis_scene_set_object(scene, 2, &m2), VIS_OK);
    assert_int_equal(vis_scene_set_object(scene, 9, &m3), VIS_OK);
    assert_int_equal(vis_scene_set_object(scene, 3, &m4), VIS_OK);
    assert_int_equal(vis_scene_set_object(scene, 4, &m5), VIS_OK);
    vis_camera cam = {{origin[0] + 16, origin[1] + 16, origin[2] + 30}, {origin[0] + 16, origin[1] + 16, origin[2]}, 60,
                      0.05, 0};
    vis_zcull *zc = NULL;
    assert_int_equal(vis_zcull_create(ctx, &zc), VIS_OK);
    for (int simd = VIS_ZCULL_SIMD_SCALAR; simd <= VIS_ZCULL_SIMD_AVX2; simd++) {
        vis_zcull_desc d = {96, 64, 0, 0, (vis_zcull_simd)simd};
        vis_draw_entry out[8];
        size_t n = 0;
        vis_zcull_stats st;
        assert_int_equal(vis_zcull_run(zc, scene, &cam, &d, out, 8, &n, &st), VIS_OK);
        long before = ca.allocs;
        assert_int_equal(vis_zcull_run(zc, scene, &cam, &d, out, 8, &n, &st), VIS_OK);
        assert_int_equal(ca.allocs, before);
        /* 3 (front), 5 (wall), 9 (beside); 2 hidden; 4 behind the eye */
        assert_int_equal(n, 3);
        assert_int_equal(out[0].id, 3);
        assert_int_equal(out[1].id, 5);
        assert_int_equal(out[2].id, 9);
        float depth[96 * 64];
        assert_int_equal(vis_zcull_depth(zc, depth, 96 * 64), VIS_OK);
        int covered = 0;
        for (uint32_t y = 0; y < 64; y++)
            for (uint32_t x = 0; x < 96; x++) {
                ref_cam c;
                double eye[3] = {16, 16, 30}, target[3] = {16, 16, 0};
                ref_cam_make(&c, eye, target, 60, 0.05, INFINITY, 96, 64);
                double dir[3];
                ref_dir(&c, x + 0.5, y + 0.5, dir);
                double len = sqrt(v3_dot(dir, dir));
                double best = INFINITY;
                const vis_quad *qs[3] = {&wall, &front, &beside};
                for (int k = 0; k < 3; k++) {
                    vis_flat_quad fq = {qs[k]->plane, qs[k]->u0, qs[k]->v0, qs[k]->u1, qs[k]->v1, qs[k]->axis};
                    double sh = ref_hit_quad(c.eye, dir, &fq);
                    best = sh < best ? sh : best;
                }
                float got = depth[y * 96 + x];
                if (best == INFINITY)
                    continue; /* near an edge the culler may leave a pixel uncovered */
                double want = best * len;
                if (got != INFINITY) {
                    covered++;
                    assert_true((double)got >= want);
                    assert_true((double)got <= want * (1 + 1e-5));
                }
            }
        assert_true(covered > 96 * 64 / 3);
    }
    vis_zcull_destroy(zc);
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
}

/* Random scenes through the public API against the reference, with every occluder, the
 * default budget and a tiny one; all SIMD paths give the same list; and every object the
 * ray pass sees at the same resolution is in the list. */
static void test_api_random_scenes(void **state)
{
    (void)state;
    uint64_t rng = 19;
    vis_context *ctx = make_ctx(NULL);
    vis_zcull *zc = NULL;
    assert_int_equal(vis_zcull_create(ctx, &zc), VIS_OK);
    const int iters = vt_small() ? 150 : 1500;
    long objects = 0, ref_visible = 0, listed = 0, ray_seen = 0;
    for (int it = 0; it < iters; it++) {
        double origin[3] = {0, 0, 0};
        if (it % 3 == 0)
            for (int a = 0; a < 3; a++)
                origin[a] = floor(urand(&rng, -1e7, 1e7));
        vis_scene *scene = make_scene(ctx, origin, 16);
        int integer = vt_rand(&rng) % 2;
        int nobj = (int)irand(&rng, 1, 7);
        ref_occ occ[64];
        int nocc = 0;
        float lo[8][3], hi[8][3];
        for (int o = 0; o < nobj; o++) {
            vis_quad qs[4];
            vis_triangle ts[4];
            int nq = (int)irand(&rng, 0, 3), ntr = (int)irand(&rng, nq ? 0 : 1, 2);
            for (int a = 0; a < 3; a++) {
                lo[o][a] = INFINITY;
                hi[o][a] = -INFINITY;
            }
            for (int i = 0; i < nq; i++) {
                vis_flat_quad fq;
                rand_quad(&rng, &fq, 0, 16, integer);
                qs[i] = vq(fq.meta, fq.plane, fq.u0, fq.v0, fq.u1, fq.v1);
                occ[nocc].is_quad = 1;
                occ[nocc++].q = fq;
                int a = (int)fq.meta, u = (a + 1) % 3, v = (a + 2) % 3;
                lo[o][a] = fminf(lo[o][a], fq.plane);
                hi[o][a] = fmaxf(hi[o][a], fq.plane);
                lo[o][u] = fminf(lo[o][u], fq.u0);
                hi[o][u] = fmaxf(hi[o][u], fq.u1);
                lo[o][v] = fminf(lo[o][v], fq.v0);
                hi[o][v] = fmaxf(hi[o][v], fq.v1);
            }
            for (int i = 0; i < ntr; i++) {
                vis_flat_tri ft;
                rand_tri(&rng, &ft, 0, 16, integer);
                memcpy(ts[i].v[0], ft.v0, sizeof ft.v0);
                memcpy(ts[i].v[1], ft.v1, sizeof ft.v1);
                memcpy(ts[i].v[2], ft.v2, sizeof ft.v2);
                ts[i].flags = 0;
                occ[nocc].is_quad = 0;
                occ[nocc++].t = ft;
                for (int a = 0; a < 3; a++) {
                    lo[o][a] = fminf(lo[o][a], fminf(ft.v0[a], fminf(ft.v1[a], ft.v2[a])));
                    hi[o][a] = fmaxf(hi[o][a], fmaxf(ft.v0[a], fmaxf(ft.v1[a], ft.v2[a])));
                }
            }
            vis_mesh m = {qs, (uint32_t)nq, ts, (uint32_t)ntr};
            assert_int_equal(vis_scene_set_object(scene, (uint32_t)(o + 1), &m), VIS_OK);
        }
        ref_cam rc;
        rand_camera(&rng, &rc, (uint32_t)irand(&rng, 1, 40), (uint32_t)irand(&rng, 1, 40), INFINITY);
        vis_camera cam;
        double target_local[3];
        for (int a = 0; a < 3; a++) {
            target_local[a] = rc.eye[a] + rc.f[a] * 7.0;
            cam.eye[a] = origin[a] + rc.eye[a];
            cam.target[a] = origin[a] + target_local[a];
        }
        cam.fovy_deg = atan(rc.tan_half) * 360.0 / ZT_PI;
        cam.near_dist = rc.near_dist;
        cam.far_dist = 0;
        /* the reference camera exactly as the library derives it: world differences */
        {
            double e[3], t[3];
            for (int a = 0; a < 3; a++) {
                e[a] = cam.eye[a];
                t[a] = cam.target[a];
            }
            ref_cam_make(&rc, e, t, cam.fovy_deg, cam.near_dist, INFINITY, rc.w, rc.h);
            for (int a = 0; a < 3; a++)
                rc.eye[a] = cam.eye[a] - origin[a];
        }
        vis_draw_entry lists[5][8];
        size_t counts[5];
        float *depths[3];
        const uint32_t budgets[5] = {VIS_ZCULL_ALL_OCCLUDERS, VIS_ZCULL_ALL_OCCLUDERS, VIS_ZCULL_ALL_OCCLUDERS, 0, 2};
        for (int r = 0; r < 5; r++) {
            vis_zcull_desc d = {rc.w, rc.h, budgets[r], 0, (vis_zcull_simd)(r < 3 ? VIS_ZCULL_SIMD_SCALAR + r : 0)};
            assert_int_equal(vis_zcull_run(zc, scene, &cam, &d, lists[r], 8, &counts[r], NULL), VIS_OK);
            for (size_t i = 1; i < counts[r]; i++)
                assert_true(lists[r][i - 1].id < lists[r][i].id);
            if (r < 3) {
                depths[r] = malloc((size_t)rc.w * rc.h * sizeof(float));
                assert_int_equal(vis_zcull_depth(zc, depths[r], (size_t)rc.w * rc.h), VIS_OK);
            }
        }
        for (int r = 1; r < 3; r++) /* bit-identical depth on every path */
            assert_memory_equal(depths[0], depths[r], (size_t)rc.w * rc.h * sizeof(float));
        for (int r = 0; r < 3; r++)
            free(depths[r]);
        for (int r = 1; r < 3; r++) {
            assert_int_equal(counts[r], counts[0]);
            assert_memory_equal(lists[r], lists[0], counts[0] * sizeof(vis_draw_entry));
        }
        for (int o = 0; o < nobj; o++) {
            int want = ref_box_visible(&rc, occ, nocc, lo[o], hi[o]);
            objects++;
            ref_visible += want;
            for (int r = 0; r < 5; r++) {
                int got = 0;
                for (size_t i = 0; i < counts[r]; i++)
                    got |= lists[r][i].id == (uint32_t)(o + 1);
                listed += r == 0 && got;
                if (want && !got) {
                    print_error("scene %d object %d (run %d): visible in the reference, culled\n", it, o + 1, r);
                    fail();
                }
            }
        }
        /* The ray pass at the same resolution (float rays): what it sees is listed. */
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = rc.w;
        td.height = rc.h;
        uint32_t *ids = malloc((size_t)rc.w * rc.h * sizeof *ids);
        assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, (size_t)rc.w * rc.h, NULL, 0), VIS_OK);
        for (size_t p = 0; p < (size_t)rc.w * rc.h; p++) {
            if (!ids[p])
                continue;
            int got = 0;
            for (size_t i = 0; i < counts[0]; i++)
                got |= lists[0][i].id == ids[p];
            ray_seen++;
            if (!got) {
                print_error("scene %d: the ray pass sees object %u at pixel %zu, culled\n", it, ids[p], p);
                fail();
            }
        }
        free(ids);
        vis_scene_destroy(scene);
    }
    print_message("zcull api: %ld objects, %ld visible in the reference, %ld listed with every occluder; "
                  "%ld ray-pass hits all listed\n",
                  objects, ref_visible, listed, ray_seen);
    assert_true(listed < objects); /* it does cull */
    vis_zcull_destroy(zc);
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shared_edge_exactly_once),
        cmocka_unit_test(test_fan_around_pixel_centre),
        cmocka_unit_test(test_fill_rule_single_triangles),
        cmocka_unit_test(test_simd_bit_exact),
        cmocka_unit_test(test_clipping_and_guard_band),
        cmocka_unit_test(test_box_classify_edges),
        cmocka_unit_test(test_box_behind_quad),
        cmocka_unit_test(test_snapping_is_conservative),
        cmocka_unit_test(test_box_rect_conservative),
        cmocka_unit_test(test_random_configurations),
        cmocka_unit_test(test_api_arguments),
        cmocka_unit_test(test_api_wall),
        cmocka_unit_test(test_api_random_scenes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
