/* test_trace.c — the ray pass against an independent brute force, the hard cases of
 * DESIGN.md ("Numerics"), and rejection of bad input.
 *
 * The oracle loops over every primitive of every object exactly as the caller handed them
 * to the scene (no tree, no leaves, no buckets) with the shared intersectors, keeping the
 * nearest hit and the lowest ID on ties. The traced buffers must equal it bit for bit. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "common/trace_core.h"
#include "camera.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

/* ---- a test world: objects kept by the test for the oracle ---------------------------- */


/* ---- the oracle ----------------------------------------------------------------------- */

static void oracle(const tworld *w, const vis_ray_setup *s, uint32_t *ids, float *depth)
{
    for (uint32_t y = 0; y < s->height; ++y)
        for (uint32_t x = 0; x < s->width; ++x) {
            vis_ray r;
            vis_ray_for_pixel(s, x, y, &r);
            float best = INFINITY;
            uint32_t bid = 0;
            for (uint32_t i = 0; i < w->n; ++i) {
                const tobj *o = &w->objs[i];
                for (uint32_t k = 0; k < o->nq + o->nt; ++k) {
                    float t;
                    int hit;
                    if (k < o->nq) {
                        const vis_quad *q = &o->quads[k];
                        hit = vis_quad_intersect(&r, q->axis, q->plane, q->u0, q->v0, q->u1, q->v1, &t);
                    } else {
                        const vis_triangle *tr = &o->tris[k - o->nq];
                        hit = vis_triangle_intersect(&r, tr->v[0], tr->v[1], tr->v[2], &t);
                    }
                    if (!hit || !(t >= r.t_near) || t > r.t_far)
                        continue;
                    if (t < best || (t == best && o->id < bid)) {
                        best = t;
                        bid = o->id;
                    }
                }
            }
            ids[y * s->width + x] = bid;
            depth[y * s->width + x] = best;
        }
}

static vis_context *make_ctx(uint32_t threads)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = threads;
    vis_context *ctx = NULL;
    assert_int_equal(vis_context_create(&cd, &ctx), VIS_OK);
    return ctx;
}

/* Traces with the tree -- per ray (the stack method) and as packets (the default) -- and
 * with the built-in brute force, and compares each with the oracle. Returns the number of hit
 * pixels. */
static uint32_t check_one_view(vis_context *ctx, vis_scene *scene, const tworld *w, const vis_camera *cam, uint32_t W,
                               uint32_t H, const char *what)
{
    size_t n = (size_t)W * H;
    uint32_t *ids = malloc(n * 4), *ref_ids = malloc(n * 4), *bf_ids = malloc(n * 4), *pk_ids = malloc(n * 4);
    float *depth = malloc(n * 4), *ref_depth = malloc(n * 4), *bf_depth = malloc(n * 4), *pk_depth = malloc(n * 4);
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = W;
    td.height = H;
    td.traversal = VIS_TRAVERSAL_STACK;
    if (vis_trace(ctx, scene, cam, &td, ids, depth) != VIS_OK)
        fail_msg("%s: %s", what, vis_context_last_error(ctx));
    td.traversal = VIS_TRAVERSAL_BRUTEFORCE;
    assert_int_equal(vis_trace(ctx, scene, cam, &td, bf_ids, bf_depth), VIS_OK);
    td.traversal = VIS_TRAVERSAL_PACKET;
    assert_int_equal(vis_trace(ctx, scene, cam, &td, pk_ids, pk_depth), VIS_OK);

    vis_scene_info info;
    vis_scene_get_info(scene, &info);
    vis_camera_frame fr;
    assert_int_equal(vis_camera_frame_make(ctx, cam, info.origin, W, H, &fr), VIS_OK);
    vis_ray_setup s;
    vis_camera_frame_ray_setup(&fr, &s);
    oracle(w, &s, ref_ids, ref_depth);
    uint32_t hits = 0;
    for (size_t i = 0; i < n; ++i) {
        hits += ref_ids[i] != 0;
        if (ids[i] != ref_ids[i] || memcmp(&depth[i], &ref_depth[i], 4) != 0)
            fail_msg("%s: pixel (%zu,%zu): traced id %u t %.9g, oracle id %u t %.9g", what, i % W, i / W, ids[i],
                     (double)depth[i], ref_ids[i], (double)ref_depth[i]);
        if (bf_ids[i] != ref_ids[i] || memcmp(&bf_depth[i], &ref_depth[i], 4) != 0)
            fail_msg("%s: pixel (%zu,%zu): bruteforce id %u, oracle id %u", what, i % W, i / W, bf_ids[i], ref_ids[i]);
        if (pk_ids[i] != ref_ids[i] || memcmp(&pk_depth[i], &ref_depth[i], 4) != 0)
            fail_msg("%s: pixel (%zu,%zu): packet id %u t %.9g, oracle id %u t %.9g", what, i % W, i / W, pk_ids[i],
                     (double)pk_depth[i], ref_ids[i], (double)ref_depth[i]);
    }
    free(ids), free(ref_ids), free(bf_ids), free(pk_ids), free(depth), free(ref_depth), free(bf_depth), free(pk_depth);
    return hits;
}

/* Every view twice: as asked (on these small images each ray is a packet of its own), and
 * narrowed to 12 degrees at 64x56, where 16x16 packets share one walk of the tree
 * (backends/cpu/packet.c picks by the tiles' spread). */
static uint32_t check_view(vis_context *ctx, vis_scene *scene, const tworld *w, const vis_camera *cam, uint32_t W,
                           uint32_t H, const char *what)
{
    uint32_t hits = check_one_view(ctx, scene, w, cam, W, H, what);
    vis_camera narrow = *cam;
    narrow.fovy_deg = 12.0;
    char label[192];
    snprintf(label, sizeof label, "%s, narrowed to 16x16 packets", what);
    check_one_view(ctx, scene, w, &narrow, 64, 56, label);
    return hits;
}

/* ---- random worlds -------------------------------------------------------------------- */

/* A world of `cells` (16^3 chunks) with voxel boxes per chunk (each chunk one object), a few
 * random rectangles shared between objects on the same planes (ties), and entities made of
 * triangles and off-grid quads that straddle chunk boundaries. */
static void random_world(tworld *w, uint64_t *rng, int nx, int ny, int nz)
{
    memset(w, 0, sizeof *w);
    w->size[0] = 16.0f * nx;
    w->size[1] = 16.0f * ny;
    w->size[2] = 16.0f * nz;
    for (int cz = 0; cz < nz; ++cz)
        for (int cy = 0; cy < ny; ++cy)
            for (int cx = 0; cx < nx; ++cx) {
                if (vt_rand_unit(rng) < 0.3)
                    continue;
                uint32_t id = 1u + (uint32_t)(cx + nx * (cy + ny * cz));
                tobj *o = add_obj(w, id);
                int boxes = 1 + (int)(vt_rand(rng) % 6);
                for (int b = 0; b < boxes; ++b) {
                    float lo[3], hi[3];
                    int c[3] = {cx, cy, cz};
                    for (int a = 0; a < 3; ++a) {
                        int l = (int)(vt_rand(rng) % 16), e = 1 + (int)(vt_rand(rng) % 8);
                        if (l + e > 16)
                            e = 16 - l;
                        lo[a] = (float)(c[a] * 16 + l);
                        hi[a] = lo[a] + (float)e;
                    }
                    obj_box(o, lo, hi);
                }
                /* a face exactly on the chunk boundary */
                if (vt_rand_unit(rng) < 0.3)
                    obj_quad(o, 0, (float)(cx * 16), (float)(cy * 16), (float)(cz * 16), (float)(cy * 16 + 16),
                             (float)(cz * 16 + 16));
            }
    /* Overlapping objects on identical quads: the lowest ID must win. */
    uint32_t base = 100000;
    for (int i = 0; i < 4; ++i) {
        float lo[3] = {(float)(vt_rand(rng) % (uint64_t)(16 * nx - 4)), (float)(vt_rand(rng) % (uint64_t)(16 * ny - 4)),
                       (float)(vt_rand(rng) % (uint64_t)(16 * nz - 4))};
        float hi[3] = {lo[0] + 3, lo[1] + 3, lo[2] + 3};
        obj_box(add_obj(w, base + 2 * i + 1), lo, hi);
        obj_box(add_obj(w, base + 2 * i), lo, hi);
    }
    /* Entities: triangles and off-grid quads across chunk borders. */
    for (int i = 0; i < 4; ++i) {
        tobj *o = add_obj(w, 200000 + i);
        float p[3];
        for (int a = 0; a < 3; ++a)
            p[a] = (float)(vt_rand_unit(rng) * (w->size[a] - 6.0) + 0.5);
        float a0[3] = {p[0], p[1], p[2]}, a1[3] = {p[0] + 5.3f, p[1] + 0.7f, p[2]}, a2[3] = {p[0], p[1] + 4.1f, p[2] + 5.2f};
        obj_tri(o, a0, a1, a2);
        float a3[3] = {p[0] + 5.3f, p[1] + 4.1f, p[2] + 5.2f};
        obj_tri(o, a1, a3, a2); /* shares an edge with the first */
        obj_quad(o, 1, p[1] + 0.375f, p[2], p[0], p[2] + 5.5f, p[0] + 5.25f);
    }
}

static void random_camera(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3])
{
    memset(cam, 0, sizeof *cam);
    for (int a = 0; a < 3; ++a) {
        /* Sometimes on an integer (a split plane or a chunk corner), sometimes outside. */
        double e = vt_rand_unit(rng) * (size[a] * 1.6) - size[a] * 0.3;
        if (vt_rand_unit(rng) < 0.3)
            e = floor(e / 16.0) * 16.0;
        cam->eye[a] = origin[a] + e;
        cam->target[a] = origin[a] + vt_rand_unit(rng) * size[a];
    }
    if (vt_rand_unit(rng) < 0.2) /* along an axis */
        for (int a = 0; a < 3; ++a)
            if (a != 1)
                cam->target[a] = cam->eye[a];
    cam->fovy_deg = 20.0 + vt_rand_unit(rng) * 100.0;
}

static void test_random_worlds_match_oracle(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(2);
    uint64_t rng = 12345;
    int worlds = vt_small() ? 3 : 10, cams = vt_small() ? 4 : 12;
    for (int wi = 0; wi < worlds; ++wi) {
        tworld w;
        random_world(&w, &rng, 3, 2, 3);
        uint32_t depth = wi % 3 == 2 ? 2 : 0; /* also shallow trees: big multi-chunk leaves */
        vis_scene *scene = make_scene(ctx, &w, NULL, depth);
        const double zero[3] = {0, 0, 0};
        for (int ci = 0; ci < cams; ++ci) {
            vis_camera cam;
            random_camera(&cam, &rng, w.size, zero);
            check_view(ctx, scene, &w, &cam, 48, 40, "random world");
        }
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* ---- hard cases ----------------------------------------------------------------------- */

/* wall_world (scene_builder.h): a 1-voxel-thick wall with a corner and a floor, for cameras
 * that look along axes, lie in split planes and sit on chunk corners. */

static void test_axis_rays_split_planes_and_corners(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(1);
    tworld w;
    wall_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    const double eyes[][6] = {
        {16, 6, 0, 16, 6, 32},   /* eye and target in the wall's plane x=16 (a split plane) */
        {16, 16, 16, 16, 0, 16}, /* straight down from a chunk corner: f parallel to -Y     */
        {16, 16, 16, 16, 32, 16},/* straight up                                             */
        {0, 6, 16, 32, 6, 16},   /* along +x in the plane z=16 (split plane, wall face)      */
        {31, 6, 16, 0, 6, 16},   /* along -x                                                 */
        {0, 1, 0, 32, 1, 32},    /* diagonal, lying in the floor's top plane y=1             */
        {16, 12, 0, 16, 12, 32}, /* along the wall's top edge                                */
        {17, 12, 17, 0, 0, 0},   /* from the wall's corner                                   */
        {8, 30, 8, 16.5, 1, 16.5},
    };
    for (size_t i = 0; i < sizeof eyes / sizeof eyes[0]; ++i) {
        vis_camera cam;
        memset(&cam, 0, sizeof cam);
        memcpy(cam.eye, eyes[i], 24);
        memcpy(cam.target, eyes[i] + 3, 24);
        check_view(ctx, scene, &w, &cam, 33, 33, "axis/split-plane view");
        check_view(ctx, scene, &w, &cam, 32, 32, "axis/split-plane view (even)");
    }
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Walls hit edge-on and at corners must not leak: behind a closed 1-voxel room, nothing of
 * the outside may be seen from inside. */
static void test_closed_room_does_not_leak(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(2);
    tworld w;
    const float L = 10, H = 30;
    room_world(&w, L, H); /* the floor, object 50, is something outside to leak to */
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    uint64_t rng = 99;
    int n = vt_small() ? 10 : 40;
    for (int i = 0; i < n; ++i) {
        vis_camera cam;
        memset(&cam, 0, sizeof cam);
        for (int a = 0; a < 3; ++a) {
            cam.eye[a] = L + 1 + vt_rand_unit(&rng) * (H - L - 2);
            if (i % 4 == 0)
                cam.eye[a] = floor(cam.eye[a]); /* on integer planes */
            cam.target[a] = L + vt_rand_unit(&rng) * (H - L);
        }
        if (i % 5 == 0) { /* aim exactly at a corner of the room */
            cam.target[0] = L + 1;
            cam.target[1] = H - 1;
            cam.target[2] = L + 1;
        }
        cam.fovy_deg = 90;
        uint32_t W = 41, Hh = 37;
        uint32_t *ids = malloc(W * Hh * 4);
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = W;
        td.height = Hh;
        assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, NULL), VIS_OK);
        for (uint32_t p = 0; p < W * Hh; ++p)
            if (ids[p] < 1 || ids[p] > 6)
                fail_msg("pixel %u sees id %u from inside the closed room (leak)", p, ids[p]);
        free(ids);
        check_view(ctx, scene, &w, &cam, 41, 37, "inside room");
    }
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

static void test_ties_go_to_lowest_id(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(1);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 32.0f;
    /* Same quad in two objects, inserted high ID first, in different cells of the tree. */
    obj_quad(add_obj(&w, 9), 2, 16.0f, 4, 4, 28, 28);
    obj_quad(add_obj(&w, 7), 2, 16.0f, 4, 4, 28, 28);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{16, 16, 0.5}, {16, 16, 30}, 40, 0, 0};
    uint32_t ids[16 * 16];
    vis_trace_desc td = {16, 16, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK, 0};
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, NULL), VIS_OK);
    for (int i = 0; i < 256; ++i)
        assert_int_equal(ids[i], 7);
    check_view(ctx, scene, &w, &cam, 16, 16, "ties");
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

static void test_camera_inside_solid(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(1);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 32.0f;
    float lo[3] = {8, 8, 8}, hi[3] = {24, 24, 24};
    obj_box(add_obj(&w, 5), lo, hi);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{16.5, 16.5, 16.5}, {30, 20, 10}, 90, 0, 0};
    uint32_t ids[20 * 20];
    vis_trace_desc td = {20, 20, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK, 0};
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, NULL), VIS_OK);
    for (int i = 0; i < 400; ++i)
        assert_int_equal(ids[i], 5); /* the enclosing solid, seen from inside */
    check_view(ctx, scene, &w, &cam, 20, 20, "inside solid");
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The same world and camera translated by (2^20, 0, -2^20) give the same IDs and depths. */
static void test_far_from_origin(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(2);
    uint64_t rng = 777;
    tworld w;
    random_world(&w, &rng, 2, 2, 2);
    const double zero[3] = {0, 0, 0}, far_o[3] = {1048576.0, 0.0, -1048576.0};
    vis_scene *a = make_scene(ctx, &w, zero, 0), *b = make_scene(ctx, &w, far_o, 0);
    for (int i = 0; i < 6; ++i) {
        vis_camera ca;
        random_camera(&ca, &rng, w.size, zero);
        vis_camera cb = ca;
        for (int k = 0; k < 3; ++k) {
            cb.eye[k] += far_o[k];
            cb.target[k] += far_o[k];
        }
        uint32_t ia[32 * 32], ib[32 * 32];
        float da[32 * 32], db[32 * 32];
        vis_trace_desc td = {32, 32, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK, 0};
        assert_int_equal(vis_trace(ctx, a, &ca, &td, ia, da), VIS_OK);
        assert_int_equal(vis_trace(ctx, b, &cb, &td, ib, db), VIS_OK);
        assert_memory_equal(ia, ib, sizeof ia);
        assert_memory_equal(da, db, sizeof da);
    }
    vis_scene_destroy(a);
    vis_scene_destroy(b);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Leaf mode writes the leaf of the hit object; the draw list expands it to the leaf's
 * objects, a superset of the object-mode list. */
static void test_leaf_ids_and_drawlist(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(2);
    uint64_t rng = 4242;
    tworld w;
    random_world(&w, &rng, 3, 2, 3);
    vis_scene *scene = make_scene(ctx, &w, NULL, 3); /* shallow: several chunks per leaf */
    vis_camera cam;
    const double zero[3] = {0, 0, 0};
    random_camera(&cam, &rng, w.size, zero);
    cam.eye[0] = -20, cam.eye[1] = 40, cam.eye[2] = -20;
    cam.target[0] = 24, cam.target[1] = 8, cam.target[2] = 24;
    enum { W = 64, H = 48 };
    static uint32_t obj_ids[W * H], leaf_ids[W * H];
    vis_trace_desc td = {W, H, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK, 0};
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, obj_ids, NULL), VIS_OK);
    td.ids = VIS_IDS_LEAF;
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, leaf_ids, NULL), VIS_OK);
    vis_scene_info info;
    vis_scene_get_info(scene, &info);
    uint32_t *buf = malloc(info.objects * 4);
    for (int i = 0; i < W * H; ++i) {
        assert_true((obj_ids[i] == 0) == (leaf_ids[i] == 0));
        if (!obj_ids[i])
            continue;
        assert_true(leaf_ids[i] >= 1 && leaf_ids[i] <= info.leaves);
        uint32_t n = 0;
        assert_int_equal(vis_scene_leaf_objects(scene, leaf_ids[i], buf, info.objects, &n), VIS_OK);
        int found = 0;
        for (uint32_t k = 0; k < n; ++k)
            found |= buf[k] == obj_ids[i];
        assert_true(found);
    }
    size_t cap = vis_drawlist_bound(scene), n_obj = 0, n_leaf = 0;
    vis_draw_entry *lo = malloc(cap * sizeof *lo), *ll = malloc(cap * sizeof *ll);
    assert_int_equal(vis_drawlist_build(ctx, scene, obj_ids, W, H, VIS_IDS_OBJECT, lo, cap, &n_obj), VIS_OK);
    assert_int_equal(vis_drawlist_build(ctx, scene, leaf_ids, W, H, VIS_IDS_LEAF, ll, cap, &n_leaf), VIS_OK);
    assert_true(n_obj > 0 && n_leaf >= n_obj);
    uint32_t total = 0;
    for (size_t i = 0; i < n_obj; ++i) {
        total += lo[i].pixels;
        if (i)
            assert_true(lo[i - 1].id < lo[i].id);
        int found = 0;
        for (size_t k = 0; k < n_leaf; ++k)
            found |= ll[k].id == lo[i].id;
        assert_true(found);
    }
    uint32_t hit = 0;
    for (int i = 0; i < W * H; ++i)
        hit += obj_ids[i] != 0;
    assert_int_equal(total, hit);
    /* capacity too small: an error, nothing written */
    if (n_obj > 1) {
        vis_draw_entry sentinel = {0xDEADBEEF, 0xDEADBEEF};
        lo[0] = sentinel;
        assert_int_equal(vis_drawlist_build(ctx, scene, obj_ids, W, H, VIS_IDS_OBJECT, lo, 1, &n_obj), VIS_ERROR_CAPACITY);
        assert_int_equal(lo[0].id, 0xDEADBEEF);
    }
    free(buf), free(lo), free(ll);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- bad input ------------------------------------------------------------------------ */

static void expect_rejected(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t W, uint32_t H,
                            const char *needle)
{
    enum { N = 64 };
    uint32_t ids[N];
    float depth[N];
    for (int i = 0; i < N; ++i) {
        ids[i] = 0xABCDABCD;
        depth[i] = -7.0f;
    }
    vis_trace_desc td = {W, H, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK, 0};
    vis_status st = vis_trace(ctx, scene, cam, &td, ids, depth);
    assert_int_equal(st, VIS_ERROR_INVALID_ARGUMENT);
    const char *msg = vis_context_last_error(ctx);
    if (!strstr(msg, needle))
        fail_msg("message '%s' does not name '%s'", msg, needle);
    for (int i = 0; i < N; ++i) {
        assert_int_equal(ids[i], 0xABCDABCD);
        assert_true(depth[i] == -7.0f);
    }
}

static void test_bad_input_rejected(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(1);
    tworld w;
    wall_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera good = {{1, 20, 1}, {16, 0, 16}, 60, 0.1, 100};
    vis_camera c = good;
    c.eye[0] = NAN;
    expect_rejected(ctx, scene, &c, 8, 8, "eye");
    c = good;
    c.target[2] = INFINITY;
    expect_rejected(ctx, scene, &c, 8, 8, "target");
    c = good;
    c.fovy_deg = -1;
    expect_rejected(ctx, scene, &c, 8, 8, "fovy");
    c.fovy_deg = 180;
    expect_rejected(ctx, scene, &c, 8, 8, "fovy");
    c.fovy_deg = NAN;
    expect_rejected(ctx, scene, &c, 8, 8, "fovy");
    c = good;
    c.near_dist = -0.5;
    expect_rejected(ctx, scene, &c, 8, 8, "near");
    c = good;
    c.far_dist = 0.05;
    expect_rejected(ctx, scene, &c, 8, 8, "far");
    c = good;
    c.target[0] = c.eye[0], c.target[1] = c.eye[1], c.target[2] = c.eye[2];
    expect_rejected(ctx, scene, &c, 8, 8, "eye");
    expect_rejected(ctx, scene, &good, 0, 8, "resolution");
    expect_rejected(ctx, scene, &good, 8, 100000, "resolution");
    /* Bad meshes and scenes */
    vis_quad q = {3, 0, 1, 0, 0, 1, 1};
    vis_mesh m = {&q, 1, NULL, 0};
    assert_int_equal(vis_scene_set_object(scene, 1, &m), VIS_ERROR_INVALID_ARGUMENT);
    q.axis = 0;
    q.u0 = 2; /* u0 > u1 */
    assert_int_equal(vis_scene_set_object(scene, 1, &m), VIS_ERROR_INVALID_ARGUMENT);
    q.u0 = 0;
    q.plane = 100; /* outside */
    assert_int_equal(vis_scene_set_object(scene, 1, &m), VIS_ERROR_INVALID_ARGUMENT);
    q.plane = NAN;
    assert_int_equal(vis_scene_set_object(scene, 1, &m), VIS_ERROR_INVALID_ARGUMENT);
    q.plane = 1;
    assert_int_equal(vis_scene_set_object(scene, 0, &m), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_scene_remove_object(scene, 12345), VIS_ERROR_NOT_FOUND);
    vis_scene_desc sd;
    vis_scene_desc_defaults(&sd);
    vis_scene *bad = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &bad), VIS_ERROR_INVALID_ARGUMENT); /* size 0 */
    assert_null(bad);
    sd.size[0] = sd.size[1] = sd.size[2] = 16;
    sd.origin[1] = NAN;
    assert_int_equal(vis_scene_create(ctx, &sd, &bad), VIS_ERROR_INVALID_ARGUMENT);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The exact quad test: closed on its edges, and two quads sharing an edge or a T-junction
 * leave no gap. */
static void test_quad_edges_closed(void **state)
{
    (void)state;
    vis_ray r;
    memset(&r, 0, sizeof r);
    float d[3] = {0.3f, -0.2f, 1.0f};
    float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) {
        r.d[a] = d[a] / len;
        r.inv[a] = 1.0f / r.d[a];
    }
    r.o[0] = 0.1f, r.o[1] = 0.7f, r.o[2] = 0.0f;
    r.t_near = 0, r.t_far = INFINITY;
    float t;
    /* Find where the ray crosses z = 5, then put quad edges exactly there. */
    assert_true(vis_quad_intersect(&r, 2, 5.0f, -100, -100, 100, 100, &t));
    float px = r.o[0] + t * r.d[0], py = r.o[1] + t * r.d[1];
    /* quad axis 2: u = x, v = y */
    assert_true(vis_quad_intersect(&r, 2, 5.0f, px, py, px + 1, py + 1, &t));  /* corner exactly */
    assert_true(vis_quad_intersect(&r, 2, 5.0f, px - 1, py - 1, px, py, &t));  /* opposite corner */
    assert_false(vis_quad_intersect(&r, 2, 5.0f, nextafterf(px, 1e9f), py, px + 1, py + 1, &t));
    /* A ray with +0 and -0 components parallel to a plane never hits it and makes no NaN. */
    vis_ray z;
    memset(&z, 0, sizeof z);
    z.d[0] = 0.0f, z.d[1] = -0.0f, z.d[2] = 1.0f;
    z.inv[0] = INFINITY, z.inv[1] = -INFINITY, z.inv[2] = 1.0f;
    z.o[0] = 1.0f, z.o[1] = 2.0f, z.o[2] = 0.0f;
    z.t_far = INFINITY;
    assert_false(vis_quad_intersect(&z, 0, 1.0f, -10, -10, 10, 10, &t)); /* lying in x = 1 */
    assert_false(vis_quad_intersect(&z, 1, 2.0f, -10, -10, 10, 10, &t));
    assert_true(vis_quad_intersect(&z, 2, 3.0f, 1.0f, 2.0f, 3.0f, 2.0f, &t)); /* degenerate (zero-height) quad, hit on its edge */
    assert_true(t == 3.0f);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_quad_edges_closed),
        cmocka_unit_test(test_random_worlds_match_oracle),
        cmocka_unit_test(test_axis_rays_split_planes_and_corners),
        cmocka_unit_test(test_closed_room_does_not_leak),
        cmocka_unit_test(test_ties_go_to_lowest_id),
        cmocka_unit_test(test_camera_inside_solid),
        cmocka_unit_test(test_far_from_origin),
        cmocka_unit_test(test_leaf_ids_and_drawlist),
        cmocka_unit_test(test_bad_input_rejected),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
