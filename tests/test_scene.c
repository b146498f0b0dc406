/* test_scene.c — the fixed-depth kd-tree and in-place leaf updates.
 *
 * The central promise: the tree is built once and never rebuilt, yet after any sequence of
 * edits the scene traces exactly like a scene built fresh from the edited world. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "kdtree.h"
#include "scene.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

/* Leaves tile the bounds exactly, and every cell-aligned box lands in exactly one leaf. */
static void test_tree_shape(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
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
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene *s = make_cube_scene(ctx, 256);
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
        if (vis_trace(ctx, s, &v->cams[i], &td, ids + (size_t)i * 96 * 64, 96 * 64, depth + (size_t)i * 96 * 64,
                      96 * 64) != VIS_OK)
            fail_msg("trace: %s", vis_context_last_error(ctx));
}

static void test_edits_equal_fresh_build(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
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
    vis_scene_stats stats;
    assert_int_equal(vis_scene_get_stats(world_scene_scene(ws), &stats), VIS_OK);
    assert_true(stats.relocations > 0); /* the leaf-outgrew-its-slot path ran */

    world_scene *fresh = NULL;
    if (world_scene_create(ctx, w, &opt, &fresh, NULL, &err) != 0)
        fail_msg("fresh scene: %s", err.message);
    vis_scene_info finfo;
    vis_scene_get_info(world_scene_scene(fresh), &finfo);
    assert_int_equal(info.objects, finfo.objects);
    assert_int_equal(info.quads, finfo.quads);
    assert_int_equal(info.leaves, finfo.leaves);
    /* Memory stays bounded: slots left by relocated leaves are reused (slot_free.h), so the
     * edited scene holds no more than a tenth over a fresh build of the same world. */
    if ((double)info.bytes > 1.10 * (double)finfo.bytes)
        fail_msg("after %d edits the scene holds %llu bytes, a fresh build %llu", edits,
                 (unsigned long long)info.bytes, (unsigned long long)finfo.bytes);
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

/* vis_scene_get_stats: the pools' slots against what the leaves hold, counted here from
 * the leaves' object lists (an object counts once in every leaf it overlaps). */
static void test_scene_stats(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene *s = make_cube_scene(ctx, 64);
    vis_scene_stats st;
    assert_int_equal(vis_scene_get_stats(NULL, &st), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_scene_get_stats(s, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_scene_get_stats(s, &st), VIS_OK);
    assert_int_equal(st.quads_in_leaves, 0);
    assert_int_equal(st.tris_in_leaves, 0);
    assert_int_equal(st.relocations, 0);
    assert_true(st.rope_bytes > 0);
    vis_quad floor_q = {1, 0, 8, 0, 0, 64, 64};           /* object 1: one quad over every column */
    vis_quad two[2] = {{0, 0, 3, 1, 1, 2, 2}, {2, 0, 5, 1, 1, 2, 2}}; /* object 2: one cell */
    vis_triangle tri = {{{1, 1, 1}, {40, 2, 1}, {1, 40, 2}}, 0};     /* object 3 */
    vis_mesh m1 = {&floor_q, 1, NULL, 0}, m2 = {two, 2, NULL, 0}, m3 = {NULL, 0, &tri, 1};
    assert_int_equal(vis_scene_set_object(s, 1, &m1), VIS_OK);
    assert_int_equal(vis_scene_set_object(s, 2, &m2), VIS_OK);
    assert_int_equal(vis_scene_set_object(s, 3, &m3), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    uint64_t refs[4] = {0, 0, 0, 0};
    for (uint32_t leaf = 1; leaf <= info.leaves; ++leaf) {
        uint32_t ids[4], n = 0;
        assert_int_equal(vis_scene_leaf_objects(s, leaf, ids, 4, &n), VIS_OK);
        for (uint32_t i = 0; i < n; ++i)
            ++refs[ids[i]];
    }
    assert_true(refs[1] > 1 && refs[2] == 1 && refs[3] > 1);
    assert_int_equal(vis_scene_get_stats(s, &st), VIS_OK);
    assert_int_equal(st.quads_in_leaves, refs[1] + 2 * refs[2]);
    assert_int_equal(st.tris_in_leaves, refs[3]);
    assert_true(st.quad_slots >= st.quads_in_leaves);
    assert_true(st.tri_slots >= st.tris_in_leaves);
    for (uint32_t n = 0; n <= VIS_MAX_SHORT_STACK; ++n)
        assert_int_equal(st.rope_bytes_used[n], 0); /* no pass has walked ropes */
    assert_int_equal(vis_kdtree_build_ropes(s, ctx), VIS_OK);
    assert_int_equal(vis_scene_get_stats(s, &st), VIS_OK);
    assert_true(st.rope_bytes_used[0] > 0 && st.rope_bytes_used[0] <= st.rope_bytes);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

static void test_no_allocation_per_frame(void **state)
{
    (void)state;
    counting c = {0, 0};
    vis_allocator a = {count_alloc, count_free, &c};
    vis_context *ctx = NULL;
    assert_int_equal(cpu_ctx_create(2, &a, &ctx), VIS_OK);
    vis_scene *s = make_cube_scene(ctx, 64);
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
    assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, 64 * 64, depth, 64 * 64), VIS_OK); /* warm-up */
    assert_int_equal(vis_drawlist_build(ctx, s, ids, 64, 64, VIS_IDS_OBJECT, list, 4, &count), VIS_OK);
    size_t before = c.allocs;
    for (int i = 0; i < 10; ++i) {
        cam.eye[0] += 0.5;
        assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, 64 * 64, depth, 64 * 64), VIS_OK);
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

/* ---- size limits ------------------------------------------------------------------------ */

static vis_scene_desc sized(float x, float y, float z)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = x, d.size[1] = y, d.size[2] = z;
    return d;
}

/* Refused with VIS_ERROR_BUDGET, nothing created, the message naming the number and the
 * limit. */
static void expect_budget(vis_context *ctx, const vis_scene_desc *d, const char *number, const char *limit)
{
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, d, &s), VIS_ERROR_BUDGET);
    assert_null(s);
    const char *msg = vis_context_last_error(ctx);
    if (!strstr(msg, number) || !strstr(msg, limit))
        fail_msg("message '%s' does not name %s and the limit %s", msg, number, limit);
}

/* Trees too big to build are refused from their size alone. Walking these trees node by node
 * takes minutes (1e6 x 256 x 1e6 voxels in chunks of 16 has 1.25e11 nodes), so a check that
 * walks shows up here as a time-out. */
static void test_huge_scenes_refused(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene_desc d = sized(1e6f, 256, 1e6f);             /* 62500 x 16 x 62500 cells */
    expect_budget(ctx, &d, "124999999999 nodes", "67108864");
    d = sized(65536, 256, 65536);                         /* 4096 x 16 x 4096 cells   */
    expect_budget(ctx, &d, "536870911 nodes", "67108864");
    /* Cells that would not fit the tree's 32-bit cell arithmetic. */
    d = sized(16777216, 16, 16);
    d.cell_size = 1e-6f;
    d.kd_depth = 4;
    expect_budget(ctx, &d, "cells", "1073741824");
    /* Fewer nodes than the limit, but the empty tree alone holds about 4 GB, over the
     * default max_bytes. */
    d = sized(16384, 256, 16384);
    expect_budget(ctx, &d, "bytes", "2147483648");
    /* The depth is a parameter with a range of its own. */
    d = sized(64, 64, 64);
    d.kd_depth = 49;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(ctx), "49"));
    /* The same huge bounds with a shallow fixed depth are cheap, and accepted. */
    d = sized(1e6f, 256, 1e6f);
    d.kd_depth = 12;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_int_equal(info.nodes, 8191);
    assert_int_equal(info.leaves, 4096);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* max_bytes: the default (2 GiB) takes gen:large's bounds; a smaller limit refuses them. */
static void test_scene_max_bytes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene_desc d = sized(2560, 160, 2560); /* gen:large: 160 x 10 x 160 chunks of 16 */
    assert_true(d.max_bytes == VIS_DEFAULT_SCENE_MAX_BYTES);
    assert_true(VIS_DEFAULT_SCENE_MAX_BYTES == (uint64_t)2 << 30);
    d.max_bytes = 0; /* zero means the default */
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_true(info.max_bytes == VIS_DEFAULT_SCENE_MAX_BYTES);
    assert_int_equal(info.leaves, 160 * 10 * 160);
    vis_scene_destroy(s);
    char limit[32];
    d.max_bytes = info.bytes - 1;
    snprintf(limit, sizeof limit, "%llu", (unsigned long long)d.max_bytes);
    expect_budget(ctx, &d, "bytes", limit);
    d.max_bytes = info.bytes + info.bytes / 100;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* The plan (arithmetic on the desc) gives the built tree's nodes, leaves and ropes, and the
 * bytes vis_scene_get_info reports for the empty scene, for sizes that are not powers of two,
 * cells of other sizes and fixed depths that stop above single cells. */
static void test_plan_matches_build(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    static const float sizes[][3] = {{16, 16, 16},   {17, 16, 16},    {80, 48, 128},  {16, 200, 16},
                                     {1000, 30, 7},  {2560, 160, 2560}, {333, 1, 999}, {64, 64, 64}};
    static const float cells[] = {16.0f, 1.0f, 3.5f};
    static const uint32_t depths[] = {0, 1, 3, 7, 20};
    int built = 0;
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; ++i)
        for (size_t c = 0; c < sizeof cells / sizeof cells[0]; ++c)
            for (size_t k = 0; k < sizeof depths / sizeof depths[0]; ++k) {
                vis_scene_desc d = sized(sizes[i][0], sizes[i][1], sizes[i][2]);
                d.cell_size = cells[c];
                d.kd_depth = depths[k];
                vis_kdtree_plan plan;
                assert_int_equal(vis_kdtree_plan_make(ctx, &d, &plan), VIS_OK);
                if (plan.nodes > 600000)
                    continue; /* keep the test quick */
                vis_scene *s = NULL;
                assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
                vis_scene_info info;
                assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
                assert_true(plan.bytes >= info.bytes); /* the estimate never falls short ... */
                assert_true(plan.bytes == info.bytes); /* ... and is the figure itself (no ropes yet) */
                assert_int_equal(s->rope_count, 0);
                assert_int_equal(vis_kdtree_build_ropes(s, ctx), VIS_OK);
                assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
                assert_true(info.bytes == plan.bytes + plan.ropes * sizeof(vis_rope_node));
                if (plan.nodes != s->node_count || plan.leaves != s->leaf_count || plan.ropes != s->rope_count ||
                    plan.kd_depth != s->kd_depth)
                    fail_msg("%gx%gx%g cell %g depth %u: plan %llu nodes %llu leaves %llu ropes depth %u, built %u %u "
                             "%u depth %u",
                             (double)sizes[i][0], (double)sizes[i][1], (double)sizes[i][2], (double)cells[c], depths[k],
                             (unsigned long long)plan.nodes, (unsigned long long)plan.leaves,
                             (unsigned long long)plan.ropes, plan.kd_depth, s->node_count, s->leaf_count,
                             s->rope_count, s->kd_depth);
                vis_scene_destroy(s);
                ++built;
            }
    assert_true(built > 50);
    /* Counts past 64 bits saturate instead of wrapping. */
    vis_scene_desc d = sized(16777216, 16777216, 16777216);
    d.cell_size = 1.0f / 32.0f; /* 2^29 cells per axis: 2^88 leaves */
    vis_kdtree_plan plan;
    assert_int_equal(vis_kdtree_plan_make(ctx, &d, &plan), VIS_OK);
    assert_true(plan.leaves == UINT64_MAX && plan.nodes == UINT64_MAX && plan.bytes == UINT64_MAX);
    vis_context_destroy(ctx);
}

/* A mesh of n quads on y planes inside the chunk (cx, 0, cz), or across the whole 64^3 scene
 * when cx < 0. */
static vis_quad *quads_in(uint32_t n, int cx, int cz, uint64_t *rng)
{
    vis_quad *q = malloc((n ? n : 1) * sizeof *q);
    assert_non_null(q);
    for (uint32_t i = 0; i < n; ++i) {
        float x0 = cx < 0 ? 0.0f : (float)cx * 16.0f, z0 = cx < 0 ? 0.0f : (float)cz * 16.0f;
        float ext = cx < 0 ? 64.0f : 16.0f;
        float a = (float)(vt_rand_unit(rng) * ext * 0.5), b = (float)(vt_rand_unit(rng) * ext * 0.5);
        q[i].axis = 1;
        q[i].flags = 0;
        q[i].plane = (float)(int)(vt_rand_unit(rng) * 15.0) + (i % 3 ? 0.5f : 0.0f); /* bucketed and loose */
        q[i].u0 = z0 + b, q[i].u1 = z0 + b + ext * 0.5f; /* u = z */
        q[i].v0 = x0 + a, q[i].v1 = x0 + a + ext * 0.5f; /* v = x */
    }
    return q;
}

/* What a refused edit must leave as it was. */
/* The ropes are built by the first pass that walks them, not with the tree: they count in
 * the scene's bytes from then on, within max_bytes, and a pass over a scene without room for
 * them fails with VIS_ERROR_BUDGET while the other methods go on (docs/traversal.md). */
static void trace_64(vis_context *ctx, vis_scene *s, vis_traversal t, vis_status want, uint32_t *ids)
{
    vis_camera cam = {{70, 40, 70}, {0, 0, 0}, 70, 0, 0};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 64;
    td.traversal = t;
    assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, 64 * 64, NULL, 0), want);
}

static void test_ropes_built_by_first_rope_pass(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2), *other = make_cpu_ctx(1);
    static uint32_t stack_ids[64 * 64], ids[64 * 64];
    for (int foreign = 0; foreign < 2; ++foreign) {
        vis_scene *s = make_cube_scene(ctx, 64);
        vis_quad q[2] = {{1, 0, 8, 0, 0, 64, 64}, {2, 0, 30, 10, 10, 40, 60}};
        vis_mesh m = {q, 2, NULL, 0};
        assert_int_equal(vis_scene_set_object(s, 1, &m), VIS_OK);
        vis_context *tc = foreign ? other : ctx;
        vis_scene_info before, after;
        trace_64(tc, s, VIS_TRAVERSAL_STACK, VIS_OK, stack_ids);
        trace_64(tc, s, VIS_TRAVERSAL_DDA, VIS_OK, ids);
        assert_int_equal(vis_scene_get_info(s, &before), VIS_OK);
        assert_null(s->ropes);
        for (int i = 0; i < 2; ++i) {
            memset(ids, 0xAB, sizeof ids);
            trace_64(tc, s, i ? VIS_TRAVERSAL_ROPES_SHORTSTACK : VIS_TRAVERSAL_ROPES, VIS_OK, ids);
            assert_memory_equal(ids, stack_ids, sizeof ids);
        }
        assert_non_null(s->ropes);
        assert_int_equal(vis_scene_get_info(s, &after), VIS_OK);
        assert_true(after.bytes == before.bytes + (uint64_t)s->rope_count * sizeof(vis_rope_node));
        vis_scene_destroy(s);
    }

    /* No room for the ropes: the rope pass fails and changes nothing; the others trace. */
    vis_scene *s = make_cube_scene(ctx, 64);
    vis_quad q = {1, 0, 8, 0, 0, 64, 64};
    vis_mesh m = {&q, 1, NULL, 0};
    assert_int_equal(vis_scene_set_object(s, 1, &m), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    s->desc.max_bytes = info.bytes + 8; /* what vis_scene_desc.max_bytes would have set */
    trace_64(ctx, s, VIS_TRAVERSAL_STACK, VIS_OK, stack_ids);
    trace_64(ctx, s, VIS_TRAVERSAL_ROPES, VIS_ERROR_BUDGET, ids);
    assert_non_null(strstr(vis_context_last_error(ctx), "ropes"));
    assert_null(s->ropes);
    vis_scene_info again;
    assert_int_equal(vis_scene_get_info(s, &again), VIS_OK);
    assert_true(again.bytes == info.bytes);
    trace_64(ctx, s, VIS_TRAVERSAL_DDA, VIS_OK, ids);
    assert_memory_equal(ids, stack_ids, sizeof ids);
    vis_scene_destroy(s);
    vis_context_destroy(other);
    vis_context_destroy(ctx);
}

/* vis_scene_prepare: the context's copy made without a trace, counted in backend_bytes (the
 * CPU backend's subtree fills and voxel labels), kept up to date after edits. */
static void test_prepare_counts_backend_bytes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2), *other = make_cpu_ctx(1);
    vis_scene *s = make_cube_scene(ctx, 64);
    /* A closed box in one chunk: its leaf gets labels. */
    tworld w;
    memset(&w, 0, sizeof w);
    tobj *o = add_obj(&w, 7);
    float lo[3] = {2, 3, 4}, hi[3] = {9, 12, 10};
    obj_box(o, lo, hi);
    set_obj(s, o);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_int_equal(info.backend_bytes, 0); /* nothing traced or prepared yet */
    assert_int_equal(vis_scene_prepare(NULL, s), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_scene_prepare(ctx, NULL), VIS_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vis_scene_prepare(ctx, s), VIS_OK);
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    uint64_t prepared = info.backend_bytes;
    assert_true(prepared > 0);
    /* Another context's copy is its own: the scene's figure is its own context's. */
    assert_int_equal(vis_scene_prepare(other, s), VIS_OK);
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_int_equal(info.backend_bytes, prepared);
    /* An edit, then prepare again: the trace after it sees the edit. */
    float hi2[3] = {9, 14, 10};
    obj_clear(o);
    obj_box(o, lo, hi2);
    set_obj(s, o);
    assert_int_equal(vis_scene_prepare(ctx, s), VIS_OK);
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_true(info.backend_bytes > 0);
    vis_camera cam = {{5.5, 30, -20}, {5.5, 13, 7}, 60, 0, 0};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 32;
    td.traversal = VIS_TRAVERSAL_DDA;
    static uint32_t ids[32 * 32], ref[32 * 32];
    assert_int_equal(vis_trace(ctx, s, &cam, &td, ids, 32 * 32, NULL, 0), VIS_OK);
    td.traversal = VIS_TRAVERSAL_BRUTEFORCE;
    assert_int_equal(vis_trace(ctx, s, &cam, &td, ref, 32 * 32, NULL, 0), VIS_OK);
    assert_memory_equal(ids, ref, sizeof ids);
    int seen = 0;
    for (size_t i = 0; i < 32 * 32; ++i)
        seen |= ids[i] == 7;
    assert_true(seen);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(other);
    vis_context_destroy(ctx);
}

/* A 64-cube scene of max_bytes (0: the default) holding a closed box in each of its 64
 * chunks (objects 1..64), prepared on ctx. */
static vis_scene *boxes_scene(vis_context *ctx, uint64_t max_bytes, tworld *w, vis_scene_info *info)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = 64;
    d.max_bytes = max_bytes;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    memset(w, 0, sizeof *w);
    for (uint32_t c = 0; c < 64; ++c) {
        tobj *o = add_obj(w, c + 1);
        float base[3] = {(float)(c % 4 * 16), (float)(c / 4 % 4 * 16), (float)(c / 16 * 16)};
        float lo[3] = {base[0] + 2 + (float)(c % 3), base[1] + 1, base[2] + 3};
        float hi[3] = {base[0] + 11, base[1] + 9 + (float)(c % 5), base[2] + 13};
        obj_box(o, lo, hi);
        set_obj(s, o);
    }
    assert_int_equal(vis_scene_prepare(ctx, s), VIS_OK);
    assert_int_equal(vis_scene_get_info(s, info), VIS_OK);
    return s;
}

/* The CPU backend's voxel labels are kept only within max_bytes beside the scene's bytes;
 * without them the passes are the same, and the scene with its backend data stays within
 * the limit. */
static void test_labels_within_max_bytes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w[4];
    vis_scene_info free_info, bare, half, room;
    vis_scene *s_free = boxes_scene(ctx, 0, &w[0], &free_info);
    /* No room beside the scene: the backend keeps its subtree fills alone. */
    vis_scene *s_bare = boxes_scene(ctx, free_info.bytes + 1, &w[1], &bare);
    assert_int_equal(bare.bytes, free_info.bytes);
    uint64_t fills = bare.backend_bytes, labels = free_info.backend_bytes - fills;
    assert_true(fills > 0 && labels > fills); /* 64 labelled leaves */
    /* Room for half the labels: none. */
    vis_scene *s_half = boxes_scene(ctx, free_info.bytes + fills + labels / 2, &w[2], &half);
    assert_int_equal(half.bytes, free_info.bytes);
    assert_int_equal(half.backend_bytes, fills);
    /* Room for all of them: kept, within the limit. */
    vis_scene *s_room = boxes_scene(ctx, free_info.bytes + fills + labels, &w[3], &room);
    assert_true(room.backend_bytes > fills);
    assert_true(room.bytes + room.backend_bytes <= room.max_bytes);
    /* The same buffers with and without them, from above and along the rows of boxes. */
    vis_camera cams[2] = {{{70, 90, -30}, {32, 20, 32}, 60, 0, 0}, {{-10, 5.5, 0.5}, {64, 5.5, 60}, 60, 0, 0}};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 48;
    static uint32_t ids[4][48 * 48];
    static float depth[4][48 * 48];
    vis_scene *scenes[4] = {s_free, s_bare, s_half, s_room};
    for (int c = 0; c < 2; ++c)
        for (int m = 0; m < 2; ++m) {
            td.traversal = m ? VIS_TRAVERSAL_DDA : VIS_TRAVERSAL_STACK;
            for (int i = 0; i < 4; ++i)
                assert_int_equal(vis_trace(ctx, scenes[i], &cams[c], &td, ids[i], 48 * 48, depth[i], 48 * 48), VIS_OK);
            for (int i = 1; i < 4; ++i) {
                assert_memory_equal(ids[i], ids[0], sizeof ids[0]);
                assert_memory_equal(depth[i], depth[0], sizeof depth[0]);
            }
        }
    int seen = 0; /* the last pass, along the rows: a good part of it hits */
    for (size_t i = 0; i < 48 * 48; ++i)
        seen += ids[0][i] != 0;
    assert_true(seen > 48 * 48 / 4);
    for (int i = 0; i < 4; ++i) {
        vis_scene_destroy(scenes[i]);
        free_world(&w[i]);
    }
    vis_context_destroy(ctx);
}

typedef struct scene_state {
    vis_scene_info info;
    vis_scene_stats stats;
} scene_state;

static void snapshot(vis_scene *s, scene_state *state, uint32_t *ids)
{
    assert_int_equal(vis_scene_get_info(s, &state->info), VIS_OK);
    assert_int_equal(vis_scene_get_stats(s, &state->stats), VIS_OK);
    vis_camera cam = {{70, 40, 70}, {0, 0, 0}, 70, 0, 0};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 32;
    assert_int_equal(vis_trace(s->ctx, s, &cam, &td, ids, 32 * 32, NULL, 0), VIS_OK);
}

static void assert_same(const scene_state *sa, const uint32_t *ia, const scene_state *sb, const uint32_t *ib)
{
    const vis_scene_info *a = &sa->info, *b = &sb->info;
    assert_int_equal(a->objects, b->objects);
    assert_int_equal(a->max_id, b->max_id);
    assert_int_equal(a->quads, b->quads);
    assert_int_equal(a->triangles, b->triangles);
    assert_int_equal(a->bytes, b->bytes);
    assert_int_equal(a->edits, b->edits);
    assert_memory_equal(&sa->stats, &sb->stats, sizeof sa->stats);
    assert_memory_equal(ia, ib, 32 * 32 * sizeof *ia);
}

/* Edits respect max_bytes: an edit that would grow the scene past it is refused with
 * VIS_ERROR_BUDGET and changes nothing (counts, bytes, the traced image); every accepted
 * edit leaves bytes <= max_bytes. */
static void test_edits_respect_max_bytes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene_desc d = sized(64, 64, 64);
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    vis_scene_info info;
    scene_state before, after;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    vis_scene_destroy(s);
    d.max_bytes = info.bytes + 256 * 1024;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    uint64_t rng = 99;
    static uint32_t ids_before[32 * 32], ids_after[32 * 32];
    uint32_t id = 1;
    vis_status st = VIS_OK;
    for (; id < 10000 && st == VIS_OK; ++id) {
        snapshot(s, &before, ids_before);
        uint32_t n = 20 + (uint32_t)(vt_rand_unit(&rng) * 200);
        vis_quad *q = quads_in(n, id % 7 == 0 ? -1 : (int)(id % 4), (int)(id / 4 % 4), &rng);
        vis_mesh m = {q, n, NULL, 0};
        st = vis_scene_set_object(s, id, &m);
        free(q);
        if (st != VIS_OK) {
            assert_int_equal(st, VIS_ERROR_BUDGET);
            assert_non_null(strstr(vis_context_last_error(ctx), "max_bytes"));
        }
        snapshot(s, &after, ids_after);
        assert_true(after.info.bytes <= d.max_bytes);
        if (st != VIS_OK)
            assert_same(&before, ids_before, &after, ids_after);
    }
    assert_int_equal(st, VIS_ERROR_BUDGET); /* the limit was reached */
    assert_true(id > 3);
    /* Replacing an object with a bigger mesh than fits: refused, the old mesh stays. */
    snapshot(s, &before, ids_before);
    vis_quad *q = quads_in(20000, -1, 0, &rng);
    vis_mesh m = {q, 20000, NULL, 0};
    assert_int_equal(vis_scene_set_object(s, 1, &m), VIS_ERROR_BUDGET);
    free(q);
    snapshot(s, &after, ids_after);
    assert_same(&before, ids_before, &after, ids_after);
    /* Removing and shrinking still work at the limit. */
    assert_int_equal(vis_scene_remove_object(s, 2), VIS_OK);
    q = quads_in(1, 0, 0, &rng);
    m.quads = q, m.quad_count = 1;
    assert_int_equal(vis_scene_set_object(s, 1, &m), VIS_OK);
    free(q);
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_true(info.bytes <= d.max_bytes);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* The growth an edit is charged before it is made is exactly what it then adds: on a twin
 * scene whose max_bytes leaves one byte less than that, the same edit is refused and changes
 * nothing; with exactly that much it goes through. Random meshes in one leaf and across many,
 * triangles, replacements and removals (which reuse slots). */
static void test_edit_growth_exact(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    vis_scene_desc d = sized(64, 64, 64);
    vis_scene *a = NULL, *b = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &a), VIS_OK);
    assert_int_equal(vis_scene_create(ctx, &d, &b), VIS_OK);
    uint64_t rng = 4711;
    int refused = 0;
    for (int e = 0; e < 300; ++e) {
        uint32_t id = 1 + (uint32_t)(vt_rand_unit(&rng) * 40);
        int remove = vt_rand_unit(&rng) < 0.15 && vis_scene_find(a, id) != VIS_NO_OBJECT;
        uint32_t nq = remove ? 0 : (uint32_t)(vt_rand_unit(&rng) * 300);
        uint32_t nt = remove ? 0 : (uint32_t)(vt_rand_unit(&rng) * 4);
        int cx = vt_rand_unit(&rng) < 0.2 ? -1 : (int)(vt_rand_unit(&rng) * 4);
        vis_quad *q = quads_in(nq, cx, (int)(vt_rand_unit(&rng) * 4), &rng);
        vis_triangle tris[4];
        for (uint32_t t = 0; t < nt; ++t)
            for (int k = 0; k < 3; ++k)
                for (int ax = 0; ax < 3; ++ax)
                    tris[t].v[k][ax] = (float)(vt_rand_unit(&rng) * 64.0);
        for (uint32_t t = 0; t < nt; ++t)
            tris[t].flags = 0;
        vis_mesh m = {q, nq, tris, nt};
        if (!remove && nq + nt == 0)
            m.quad_count = nq = 1, q[0].plane = 1, q[0].u0 = q[0].v0 = 0, q[0].u1 = q[0].v1 = 1;
        vis_scene_info ia, ib;
        assert_int_equal(vis_scene_get_info(a, &ia), VIS_OK);
        assert_int_equal(vis_scene_get_info(b, &ib), VIS_OK);
        assert_int_equal(ia.bytes, ib.bytes);
        vis_status st = remove ? vis_scene_remove_object(a, id) : vis_scene_set_object(a, id, &m);
        assert_int_equal(st, VIS_OK);
        vis_scene_info ia2;
        assert_int_equal(vis_scene_get_info(a, &ia2), VIS_OK);
        uint64_t grew = ia2.bytes - ib.bytes;
        if (grew > 0) {
            b->desc.max_bytes = ib.bytes + grew - 1;
            st = remove ? vis_scene_remove_object(b, id) : vis_scene_set_object(b, id, &m);
            assert_int_equal(st, VIS_ERROR_BUDGET);
            vis_scene_info ib2;
            assert_int_equal(vis_scene_get_info(b, &ib2), VIS_OK);
            assert_int_equal(ib2.bytes, ib.bytes);
            assert_int_equal(ib2.edits, ib.edits);
            assert_int_equal(ib2.objects, ib.objects);
            assert_int_equal(ib2.quads, ib.quads);
            ++refused;
        }
        b->desc.max_bytes = ib.bytes + grew;
        st = remove ? vis_scene_remove_object(b, id) : vis_scene_set_object(b, id, &m);
        assert_int_equal(st, VIS_OK);
        free(q);
    }
    assert_true(refused > 20);
    vis_scene_destroy(a);
    vis_scene_destroy(b);
    vis_context_destroy(ctx);
}

/* An object leaving a leaf can make the leaf larger: only the first VIS_PQ_TABLE_MAX + 1
 * objects of a leaf's list can have packed quads, so removing one moves the next into the
 * packable range, and its quad packed brings the leaf an object table (one word per object,
 * up to 1,024) and its first bucket table. Here 1,025 objects share one leaf, every quad
 * loose (the first 1,024 lie off the integer grid, the last is past the table). Removing the
 * first, or moving it to another leaf, grows the scene; that growth must be charged before
 * the edit like any other (one byte less than it: refused, nothing changed). */
static void test_leaving_leaf_growth_exact(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene_desc d = sized(64, 64, 64);
    const uint32_t n = VIS_PQ_TABLE_MAX + 2u;
    for (int move = 0; move <= 1; ++move) {
        vis_scene *a = NULL, *b = NULL;
        assert_int_equal(vis_scene_create(ctx, &d, &a), VIS_OK);
        assert_int_equal(vis_scene_create(ctx, &d, &b), VIS_OK);
        for (uint32_t i = 0; i < n; ++i) {
            int last = i == n - 1;
            float o = last ? 2.0f : 0.5f; /* packable coordinates only for the last object */
            vis_quad q = {1, 0, (float)(1 + i % 13), o, o, o + 1.0f, o + 1.0f};
            vis_mesh m = {&q, 1, NULL, 0};
            assert_int_equal(vis_scene_set_object(a, i + 1, &m), VIS_OK);
            assert_int_equal(vis_scene_set_object(b, i + 1, &m), VIS_OK);
        }
        vis_quad far = {1, 0, 40.0f, 40.5f, 40.5f, 41.5f, 41.5f}; /* in another leaf */
        vis_mesh fm = {&far, 1, NULL, 0};
        vis_scene_info ia, ib, ib2;
        assert_int_equal(vis_scene_get_info(a, &ia), VIS_OK);
        assert_int_equal(vis_scene_get_info(b, &ib), VIS_OK);
        assert_int_equal(ia.bytes, ib.bytes);
        assert_int_equal(move ? vis_scene_set_object(a, 1, &fm) : vis_scene_remove_object(a, 1), VIS_OK);
        assert_int_equal(vis_scene_get_info(a, &ia), VIS_OK);
        assert_true(ia.bytes > ib.bytes); /* the case this test is for: the leaf grew */
        b->desc.max_bytes = ia.bytes - 1;
        assert_int_equal(move ? vis_scene_set_object(b, 1, &fm) : vis_scene_remove_object(b, 1), VIS_ERROR_BUDGET);
        assert_int_equal(vis_scene_get_info(b, &ib2), VIS_OK);
        assert_int_equal(ib2.bytes, ib.bytes);
        assert_int_equal(ib2.objects, ib.objects);
        assert_int_equal(ib2.edits, ib.edits);
        b->desc.max_bytes = ia.bytes;
        assert_int_equal(move ? vis_scene_set_object(b, 1, &fm) : vis_scene_remove_object(b, 1), VIS_OK);
        assert_int_equal(vis_scene_get_info(b, &ib2), VIS_OK);
        assert_int_equal(ib2.bytes, ia.bytes);
        vis_scene_destroy(a);
        vis_scene_destroy(b);
    }
    vis_context_destroy(ctx);
}

/* The cell map's clearances (trace_core.h, VIS_CELL_CLEAR) after random edits: each cell's
 * is min(VIS_CELL_CLEAR_MAX, its Chebyshev distance in cells to the nearest cell whose leaf
 * holds primitives), computed here by brute force over the cells. Objects are single quads
 * in one cell, or boxes across several; edits add, move, replace and remove them, so leaves
 * fill (kdtree.c, vis_kdtree_leaf_filled) and empty again (vis_kdtree_leaf_emptied). At the
 * end every object is removed: the clearances must all rise to the cap again. */
static void expect_clearances(const vis_scene *s, const char *when, int e)
{
    const uint32_t nx = s->cells[0], ny = s->cells[1], nz = s->cells[2], nc = nx * ny * nz;
    const uint32_t *map = s->rope_index + s->cell_map;
    for (uint32_t c = 0; c < nc; ++c) {
        int64_t x = c % nx, y = c / nx % ny, z = c / nx / ny;
        uint32_t want = VIS_CELL_CLEAR_MAX;
        for (uint32_t m = 0; m < nc; ++m)
            if (vis_leaf_has_primitives(&s->leaves[VIS_CELL_LEAF(map[m])])) {
                int64_t dx = llabs((int64_t)(m % nx) - x), dy = llabs((int64_t)(m / nx % ny) - y),
                        dz = llabs((int64_t)(m / nx / ny) - z);
                int64_t dist = dx > dy ? dx : dy;
                dist = dz > dist ? dz : dist;
                if ((uint64_t)dist < want)
                    want = (uint32_t)dist;
            }
        uint32_t got = VIS_CELL_CLEAR(map[c]);
        if (got != want)
            fail_msg("%s %d: cell (%lld,%lld,%lld) has clearance %u, expected %u", when, e, (long long)x,
                     (long long)y, (long long)z, got, want);
    }
}

static void test_cell_clearance(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene_desc d = sized(400, 96, 240); /* 25 x 6 x 15 cells of 16 */
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    assert_true(s->cell_map != 0u);
    uint64_t rng = 31337;
    int edits = vt_small() ? 150 : 600;
    for (int e = 0; e < edits; ++e) {
        uint32_t id = 1u + (uint32_t)(vt_rand(&rng) % 60u);
        if (vt_rand(&rng) % 4 == 0) {
            vis_status st = vis_scene_remove_object(s, id);
            assert_true(st == VIS_OK || st == VIS_ERROR_NOT_FOUND);
        } else {
            /* A box of 1..3 cells per axis (its faces as quads), sometimes a lone quad. */
            float lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                uint32_t n = s->cells[a], c = (uint32_t)(vt_rand(&rng) % n);
                uint32_t w = 1u + (uint32_t)(vt_rand(&rng) % 3u);
                lo[a] = (float)c * 16.0f + (float)(vt_rand(&rng) % 8u);
                hi[a] = (float)(c + w > n ? n : c + w) * 16.0f - (float)(vt_rand(&rng) % 8u);
            }
            vis_quad q[6];
            uint32_t nq = vt_rand(&rng) % 4 == 0 ? 1u : 6u;
            for (uint32_t f = 0; f < nq; ++f) {
                uint32_t a = f / 2u, u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
                q[f].axis = (uint8_t)a;
                q[f].flags = 0;
                q[f].plane = f % 2u ? hi[a] : lo[a];
                q[f].u0 = lo[u], q[f].u1 = hi[u];
                q[f].v0 = lo[v], q[f].v1 = hi[v];
            }
            vis_mesh m = {q, nq, NULL, 0};
            assert_int_equal(vis_scene_set_object(s, id, &m), VIS_OK);
        }
        if (e % 10 == 9 || e + 1 == edits)
            expect_clearances(s, "after edit", e);
    }
    for (uint32_t id = 1; id <= 60; ++id) {
        vis_status st = vis_scene_remove_object(s, id);
        assert_true(st == VIS_OK || st == VIS_ERROR_NOT_FOUND);
        expect_clearances(s, "after removing object", (int)id);
    }
    const uint32_t *map = s->rope_index + s->cell_map;
    for (uint32_t c = 0; c < s->leaf_count; ++c)
        assert_int_equal(VIS_CELL_CLEAR(map[c]), VIS_CELL_CLEAR_MAX);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
}

/* world_scene_create meshes the next batch of chunks while it uploads one, on any number of
 * meshing threads; the scene must be the one a plain loop builds, chunk by chunk in ascending
 * order, serially: the same leaves, pools and object slots, word for word. The world has more
 * non-empty chunks than a meshing batch (1,024), so batches overlap. */
static void expect_same_scene(const vis_scene *a, const vis_scene *b)
{
    assert_int_equal(a->leaf_count, b->leaf_count);
    assert_memory_equal(a->leaves, b->leaves, a->leaf_count * sizeof *a->leaves);
    assert_int_equal(a->quad_used, b->quad_used);
    assert_int_equal(a->quad_cap, b->quad_cap);
    for (uint32_t i = 0; i < a->leaf_count; ++i) { /* the words each leaf uses (slack is not written) */
        const vis_flat_leaf *lf = &a->leaves[i];
        size_t words = (size_t)(lf->quad_offset + lf->quad_count - lf->table_offset) +
                       (size_t)lf->loose_count * VIS_LOOSE_WORDS;
        if (words)
            assert_memory_equal(&a->quads[lf->table_offset], &b->quads[lf->table_offset], words * sizeof *a->quads);
    }
    assert_int_equal(a->bucket_count, b->bucket_count);
    assert_memory_equal(a->buckets, b->buckets, a->bucket_count * sizeof *a->buckets);
    assert_int_equal(a->object_slots, b->object_slots);
    assert_memory_equal(a->objects, b->objects, a->object_slots * sizeof *a->objects);
    for (uint32_t i = 0; i < a->leaf_count; ++i) {
        assert_int_equal(a->leaf_host[i].object_count, b->leaf_host[i].object_count);
        assert_int_equal(a->leaf_host[i].quad_cap, b->leaf_host[i].quad_cap);
    }
    vis_scene_info ia, ib;
    assert_int_equal(vis_scene_get_info(a, &ia), VIS_OK);
    assert_int_equal(vis_scene_get_info(b, &ib), VIS_OK);
    assert_int_equal(ia.objects, ib.objects);
    assert_int_equal(ia.quads, ib.quads);
    assert_int_equal(ia.bytes, ib.bytes);
    assert_int_equal(ia.edits, ib.edits);
}

static void test_world_scene_batches_equal_serial(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vw_world *w = NULL;
    vw_error err;
    if (vw_world_from_spec("gen:terrain:size=320x128x320:seed=4", NULL, NULL, NULL, &w, &err) != VW_OK)
        fail_msg("world: %s", err.message);
    vw_world_info wi;
    vw_world_get_info(w, &wi);

    /* The oracle: one chunk at a time, meshed and set in ascending order. */
    vis_scene_desc desc;
    memset(&desc, 0, sizeof desc);
    for (int a = 0; a < 3; ++a) {
        desc.origin[a] = (double)wi.origin[a];
        desc.size[a] = (float)wi.size[a];
    }
    desc.cell_size = (float)wi.chunk_size;
    vis_scene *serial = NULL;
    assert_int_equal(vis_scene_create(ctx, &desc, &serial), VIS_OK);
    vw_mesh mesh = {0};
    vis_quad *quads = NULL;
    uint32_t nonempty = 0;
    for (uint32_t c = 0; c < wi.chunk_count; ++c) {
        if (vw_world_chunk_empty(w, c))
            continue;
        ++nonempty;
        assert_int_equal(vw_mesh_chunk(w, c, &mesh), VW_OK);
        if (mesh.count == 0)
            continue;
        quads = realloc(quads, mesh.count * sizeof *quads);
        assert_non_null(quads);
        world_scene_convert_quads(mesh.quads, mesh.count, quads);
        vis_mesh vm = {quads, (uint32_t)mesh.count, NULL, 0};
        assert_int_equal(vis_scene_set_object(serial, vw_chunk_object_id(c), &vm), VIS_OK);
    }
    assert_true(nonempty > 1024u); /* more than one meshing batch */

    const uint32_t threads[] = {0, 1, 3};
    for (size_t t = 0; t < sizeof threads / sizeof threads[0]; ++t) {
        world_scene_options opt;
        memset(&opt, 0, sizeof opt);
        opt.mesh_threads = threads[t];
        world_scene *ws = NULL;
        world_scene_stats st;
        if (world_scene_create(ctx, w, &opt, &ws, &st, &err) != 0)
            fail_msg("scene on %u meshing threads: %s", threads[t], err.message);
        assert_int_equal(st.chunks, nonempty);
        expect_same_scene(serial, world_scene_scene(ws));
        world_scene_destroy(ws);
    }
    free(quads);
    vw_mesh_free(&mesh);
    vis_scene_destroy(serial);
    vw_world_destroy(w);
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tree_shape),
        cmocka_unit_test(test_object_lifecycle),
        cmocka_unit_test(test_edits_equal_fresh_build),
        cmocka_unit_test(test_no_allocation_per_frame),
        cmocka_unit_test(test_scene_stats),
        cmocka_unit_test(test_ropes_built_by_first_rope_pass),
        cmocka_unit_test(test_prepare_counts_backend_bytes),
        cmocka_unit_test(test_labels_within_max_bytes),
        cmocka_unit_test(test_huge_scenes_refused),
        cmocka_unit_test(test_scene_max_bytes),
        cmocka_unit_test(test_edits_respect_max_bytes),
        cmocka_unit_test(test_plan_matches_build),
        cmocka_unit_test(test_edit_growth_exact),
        cmocka_unit_test(test_leaving_leaf_growth_exact),
        cmocka_unit_test(test_world_scene_batches_equal_serial),
        cmocka_unit_test(test_cell_clearance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
