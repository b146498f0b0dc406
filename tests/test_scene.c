/* test_scene.c — the fixed-depth kd-tree and in-place leaf updates.
 *
 * The central promise: the tree is built once and never rebuilt, yet after any sequence of
 * edits the scene traces exactly like a scene built fresh from the edited world. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "kdtree.h"
#include "scene.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

static vis_context *make_ctx(void)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = 2;
    vis_context *ctx = NULL;
    assert_int_equal(vis_context_create(&cd, &ctx), VIS_OK);
    return ctx;
}

/* Leaves tile the bounds exactly, and every cell-aligned box lands in exactly one leaf. */
static void test_tree_shape(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx();
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = 80, d.size[1] = 48, d.size[2] = 128; /* 5 x 3 x 8 cells: not powers of two */
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_int_equal(info.leaves, 5 * 3 * 8);
    assert_int_equal(info.kd_depth, 3 + 2 + 3);
    double volume = 0;
    for (uint32_t i = 0; i < s->leaf_count; ++i) {
        const vis_flat_leaf *lf = &s->leaves[i];
        volume += (double)(lf->hi[0] - lf->lo[0]) * (lf->hi[1] - lf->lo[1]) * (lf->hi[2] - lf->lo[2]);
    }
    assert_true(volume == 80.0 * 48.0 * 128.0);
    for (int cz = 0; cz < 8; ++cz)
        for (int cy = 0; cy < 3; ++cy)
            for (int cx = 0; cx < 5; ++cx) {
                float lo[3] = {cx * 16.0f, cy * 16.0f, cz * 16.0f}, hi[3] = {lo[0] + 16, lo[1] + 16, lo[2] + 16};
                uint32_t out[8];
                assert_int_equal(vis_kdtree_leaves_of_box(s, lo, hi, out, 8), 1);
                const vis_flat_leaf *lf = &s->leaves[out[0]];
                for (int a = 0; a < 3; ++a) {
                    assert_true(lf->lo[a] == lo[a]);
                    assert_true(lf->hi[a] == hi[a]);
                }
            }
    vis_scene_destroy(s);
    /* A shallower fixed depth gives bigger leaves, never more than 2^depth. */
    d.kd_depth = 4;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_get_info(s, &info);
    assert_int_equal(info.kd_depth, 4);
    assert_true(info.leaves <= 16);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* Many objects: add, replace, remove, re-add; the ID map, slots, counts and max_id follow. */
static void test_object_lifecycle(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx();
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = 256;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    uint64_t rng = 5;
    enum { N = 3000 };
    static uint8_t present[N + 1];
    memset(present, 0, sizeof present);
    uint32_t live = 0;
    for (int step = 0; step < 20000; ++step) {
        uint32_t id = 1 + (uint32_t)(vt_rand(&rng) % N);
        if (vt_rand_unit(&rng) < 0.3) {
            vis_status st = vis_scene_remove_object(s, id);
            assert_int_equal(st, present[id] ? VIS_OK : VIS_ERROR_NOT_FOUND);
            live -= present[id];
            present[id] = 0;
        } else {
            /* Three quads near one point: an object of one or a few leaves. */
            vis_quad q[3];
            float p[3] = {(float)(vt_rand(&rng) % 240), (float)(vt_rand(&rng) % 240), (float)(vt_rand(&rng) % 240)};
            for (uint32_t a = 0; a < 3; ++a) {
                uint32_t u = (a + 1) % 3, v = (a + 2) % 3;
                vis_quad one = {a, 0, p[a] + (float)a, p[u], p[v], p[u] + 1 + (float)(vt_rand(&rng) % 5), p[v] + 1};
                q[a] = one;
            }
            vis_mesh m = {q, 3, NULL, 0};
            assert_int_equal(vis_scene_set_object(s, id, &m), VIS_OK);
            live += !present[id];
            present[id] = 1;
        }
    }
    vis_scene_info info;
    vis_scene_get_info(s, &info);
    assert_int_equal(info.objects, live);
    uint32_t max_id = 0;
    for (uint32_t id = 1; id <= N; ++id) {
        assert_true((vis_scene_find(s, id) != VIS_NO_OBJECT) == present[id]);
        if (present[id])
            max_id = id;
    }
    assert_int_equal(info.max_id, max_id);
    assert_int_equal(info.quads, 3ull * live);
    assert_true(s->object_slots <= N); /* freed slots are reused */
    /* Leaf object lists hold exactly the live objects. */
    uint64_t refs = 0;
    for (uint32_t l = 0; l < s->leaf_count; ++l)
        for (uint32_t k = 0; k < s->leaf_host[l].object_count; ++k)
            assert_true(s->objects[s->leaf_host[l].objects[k]].id != 0), ++refs;
    assert_true(refs >= live);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* ---- edits equal a fresh build --------------------------------------------------------- */

typedef struct views {
    vis_camera cams[6];
    int n;
} views;

static void make_views(views *v, const vw_world *w)
{
    vw_world_info wi;
    vw_world_get_info(w, &wi);
    double lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = (double)wi.origin[a];
        hi[a] = lo[a] + wi.size[a];
    }
    double c[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
    const double eyes[6][6] = {
        {lo[0] - 10, hi[1] + 20, lo[2] - 10, c[0], lo[1], c[2]},
        {c[0], hi[1] + 30, c[2] + 0.5, c[0], lo[1], c[2]},
        {hi[0] + 5, c[1] + 5, c[2], lo[0], c[1], c[2] + 3},
        {c[0] + 0.25, c[1], c[2] + 0.75, c[0] + 40, c[1] - 10, c[2] - 30}, /* inside, caves */
        {lo[0] + 16, c[1], lo[2] + 16, hi[0], lo[1], hi[2]},              /* on chunk corners */
        {c[0], c[1] + 20, lo[2] - 30, c[0], c[1], hi[2]},
    };
    v->n = 6;
    for (int i = 0; i < 6; ++i) {
        memset(&v->cams[i], 0, sizeof v->cams[i]);
        memcpy(v->cams[i].eye, eyes[i], 24);
        memcpy(v->cams[i].target, eyes[i] + 3, 24);
        v->cams[i].fovy_deg = 70;
    }
}

static void trace_all(vis_context *ctx, vis_scene *s, const views *v, vis_id_mode mode, uint32_t *ids, float *depth)
{
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = 96;
    td.height = 64;
    td.ids = mode;
    for (int i = 0; i < v->n; ++i)
        if (vis_trace(ctx, s, &v->cams[i], &td, ids + (size_t)i * 96 * 64, depth + (size_t)i * 96 * 64) != VIS_OK)
            fail_msg("trace: %s", vis_context_last_error(ctx));
}

static void test_edits_equal_fresh_build(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx();
    vw_world *w = NULL;
    vw_error err;
    if (vw_world_from_spec("gen:terrain:size=128x64x128:seed=3", NULL, NULL, NULL, &w, &err) != VW_OK)
        fail_msg("world: %s", err.message);
    world_scene *ws = NULL;
    world_scene_options opt;
    memset(&opt, 0, sizeof opt);
    if (world_scene_create(ctx, w, &opt, &ws, NULL, &err) != 0)
        fail_msg("scene: %s", err.message);
    views v;
    make_views(&v, w);
    size_t n = (size_t)v.n * 96 * 64;
    uint32_t *ids_a = malloc(n * 4), *ids_b = malloc(n * 4);
    float *d_a = malloc(n * 4), *d_b = malloc(n * 4);

    vw_world_info wi;
    vw_world_get_info(w, &wi);
    uint64_t rng = 2024;
    int edits = vt_small() ? 2000 : 10000;
    for (int e = 0; e < edits; ++e) {
        int64_t p[3];
        for (int a = 0; a < 3; ++a)
            p[a] = wi.origin[a] + (int64_t)(vt_rand(&rng) % (uint64_t)wi.size[a]);
        if (e % 7 == 0) { /* on either side of a chunk border */
            int a = (int)(vt_rand(&rng) % 3);
            p[a] = wi.origin[a] + (int64_t)(vt_rand(&rng) % (uint64_t)(wi.size[a] / 16)) * 16 - (e % 2);
        }
        double r = vt_rand_unit(&rng);
        vw_voxel val = r < 0.45 ? 0 : (vw_voxel)(1 + vt_rand(&rng) % 4);
        if (e % 500 == 250) { /* now and then empty or fill a whole chunk */
            int64_t lo[3] = {p[0] & ~15ll, p[1] & ~15ll, p[2] & ~15ll}, hi[3] = {lo[0] + 16, lo[1] + 16, lo[2] + 16};
            vw_world_fill(w, lo, hi, val);
        } else if (vw_world_set(w, p[0], p[1], p[2], val) != VW_OK && vw_world_get(w, p[0], p[1], p[2]) != 0) {
            fail_msg("edit %d failed inside the world", e);
        }
        /* Apply after every edit sometimes, in batches otherwise. */
        if (e % 97 == 0 || e % 13 == 0 || e == edits - 1)
            if (world_scene_update(ws, NULL, &err) != 0)
                fail_msg("update: %s", err.message);
        if (e == edits / 2) { /* a trace in the middle: the backend copy is synced mid-way */
            trace_all(ctx, world_scene_scene(ws), &v, VIS_IDS_OBJECT, ids_a, d_a);
        }
    }
    vis_scene_info info;
    vis_scene_get_info(world_scene_scene(ws), &info);
    assert_true(info.relocations > 0); /* the leaf-outgrew-its-slot path ran */

    world_scene *fresh = NULL;
    if (world_scene_create(ctx, w, &opt, &fresh, NULL, &err) != 0)
        fail_msg("fresh scene: %s", err.message);
    vis_scene_info finfo;
    vis_scene_get_info(world_scene_scene(fresh), &finfo);
    assert_int_equal(info.objects, finfo.objects);
    assert_int_equal(info.quads, finfo.quads);
    assert_int_equal(info.leaves, finfo.leaves);
    for (int mode = 0; mode < 2; ++mode) {
        trace_all(ctx, world_scene_scene(ws), &v, (vis_id_mode)mode, ids_a, d_a);
        trace_all(ctx, world_scene_scene(fresh), &v, (vis_id_mode)mode, ids_b, d_b);
        size_t hits = 0;
        for (size_t i = 0; i < n; ++i) {
            hits += ids_a[i] != 0;
            if (ids_a[i] != ids_b[i] || memcmp(&d_a[i], &d_b[i], 4) != 0)
                fail_msg("mode %d, view %zu pixel %zu: edited scene id %u t %g, fresh id %u t %g", mode, i / (96 * 64),
                         i % (96 * 64), ids_a[i], (double)d_a[i], ids_b[i], (double)d_b[i]);
        }
        assert_true(hits > n / 4); /* the views do look at something */
    }
    world_scene_destroy(fresh);
    world_scene_destroy(ws);
    vw_world_destroy(w);
    free(ids_a), free(ids_b), free(d_a), free(d_b);
    vis_context_destroy(ctx);
}

/* An allocator that counts, to check that a warm trace allocates nothing. */
typedef struct counting {
    size_t allocs, frees;
} counting;

static void *count_alloc(size_t size, size_t align, void *user)
{
    ((counting *)user)->allocs++;
    size_t rounded = (size + align - 1) / align * align;
    return aligned_alloc(align, rounded ? rounded : align);
}

static void count_free(void *p, void *user)
{
    ((counting *)user)->frees++;
    free(p);
}

static void test_no_allocation_per_frame(void **state)
{
    (void)state;
    counting c = {0, 0};
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = 2;
    cd.allocator.alloc = count_alloc;
    cd.allocator.free = count_free;
    cd.allocator.user = &c;
    vis_context *ctx = NULL;
    assert_int_equal(vis_context_create(&cd, &ctx), VIS_OK);
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = 64;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_quad q = {1, 0, 8, 0, 0, 64, 64};
    vis_mesh m = {&q, 1, NULL, 0};
    assert_int_equal(vis_scene_set_object(s, 1, &m), VIS_OK);
    vis_camera cam = {{32, 40, 32}, {30, 0, 30}, 60, 0, 0};
    static uint32_t ids[64 * 64];
    static float depth[64 * 64];
    vis_draw_entry list[4];
    size_t count = 0;
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 64;
    assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, depth), VIS_OK); /* warm-up */
    assert_int_equal(vis_drawlist_build(ctx, s, ids, 64, 64, VIS_IDS_OBJECT, list, 4, &count), VIS_OK);
    size_t before = c.allocs;
    for (int i = 0; i < 10; ++i) {
        cam.eye[0] += 0.5;
        assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, depth), VIS_OK);
        assert_int_equal(vis_drawlist_build(ctx, s, ids, 64, 64, VIS_IDS_OBJECT, list, 4, &count), VIS_OK);
    }
    assert_int_equal(c.allocs, before);
    assert_int_equal(count, 1);
    assert_int_equal(list[0].id, 1);
    assert_int_equal(list[0].pixels, 64 * 64);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
    assert_int_equal(c.allocs, c.frees);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tree_shape),
        cmocka_unit_test(test_object_lifecycle),
        cmocka_unit_test(test_edits_equal_fresh_build),
        cmocka_unit_test(test_no_allocation_per_frame),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
