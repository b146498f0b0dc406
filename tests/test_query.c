/* test_query.c — the server queries (vis_query_*): entities never hidden while a dense pass
 * from the true eye sees them, conservative under latency and peeks, the budget's
 * degradation, determinism across thread counts, edits seen by the next tick, the hold, the
 * cache, and bad input rejected with the query unchanged.
 *
 * The oracle is independent of occlusion.c: the entities are added as box objects to a
 * second scene holding the same walls, and vis_trace (the ray pass, itself held to a
 * double-precision reference by test_trace.c) renders dense views from the true eye; every
 * entity with a pixel must be in the query's list. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "run_tool.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

#define ENT_BASE 1000u /* entity object IDs in the truth scene */

/* A 64 x 32 x 64 world: a floor and random 1- or 2-voxel-thick walls on integer planes. */
static void walls_world(tworld *w, uint64_t *rng, int walls)
{
    memset(w, 0, sizeof *w);
    w->size[0] = 64.0f;
    w->size[1] = 32.0f;
    w->size[2] = 64.0f;
    float flo[3] = {0, 0, 0}, fhi[3] = {64, 1, 64};
    obj_box(add_obj(w, 1), flo, fhi);
    for (int i = 0; i < walls; ++i) {
        float lo[3], hi[3];
        int ax = (int)(vt_rand(rng) % 2) * 2; /* walls along x or z */
        int len = 6 + (int)(vt_rand(rng) % 20), th = 1 + (int)(vt_rand(rng) % 2);
        int x = 2 + (int)(vt_rand(rng) % 56), z = 2 + (int)(vt_rand(rng) % 56);
        lo[0] = (float)x;
        lo[2] = (float)z;
        lo[1] = 1.0f;
        hi[1] = (float)(3 + vt_rand(rng) % 6);
        hi[0] = lo[0] + (float)(ax == 0 ? len : th);
        hi[2] = lo[2] + (float)(ax == 0 ? th : len);
        if (hi[0] > 64.0f)
            hi[0] = 64.0f;
        if (hi[2] > 64.0f)
            hi[2] = 64.0f;
        obj_box(add_obj(w, 2u + (uint32_t)i), lo, hi);
    }
}

static void random_entity(uint64_t *rng, uint32_t id, vis_query_entity *e)
{
    memset(e, 0, sizeof *e);
    e->id = id;
    double x = 1.0 + 61.0 * vt_rand_unit(rng), z = 1.0 + 61.0 * vt_rand_unit(rng);
    double sx = 0.3 + 0.6 * vt_rand_unit(rng), sy = 0.5 + 1.5 * vt_rand_unit(rng);
    e->box_min[0] = x;
    e->box_min[1] = 1.0 + (vt_rand(rng) % 4 == 0 ? 4.0 * vt_rand_unit(rng) : 0.0);
    e->box_min[2] = z;
    e->box_max[0] = x + sx;
    e->box_max[1] = e->box_min[1] + sy;
    e->box_max[2] = z + sx;
}

static void random_viewer(uint64_t *rng, uint32_t id, vis_query_viewer *v)
{
    memset(v, 0, sizeof *v);
    v->id = id;
    v->eye[0] = 1.0 + 62.0 * vt_rand_unit(rng);
    v->eye[1] = 1.6 + 3.0 * vt_rand_unit(rng);
    v->eye[2] = 1.0 + 62.0 * vt_rand_unit(rng);
    double a = 6.283185307179586 * vt_rand_unit(rng);
    v->dir[0] = cos(a);
    v->dir[2] = sin(a);
    v->fov_deg = 90.0;
}

/* The truth: which entities have a pixel in a 6-face cube of side x side from the eye
 * (all around: the query does not cull by view direction). Marks seen[j]. */
static void truth_pass(vis_context *ctx, vis_scene *truth, const double eye[3], uint32_t side, uint32_t ne,
                       int *seen)
{
    uint32_t *ids = malloc((size_t)side * side * sizeof *ids);
    assert_non_null(ids);
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = side;
    for (int f = 0; f < 6; ++f) {
        vis_camera c;
        memset(&c, 0, sizeof c);
        memcpy(c.eye, eye, sizeof c.eye);
        memcpy(c.target, eye, sizeof c.target);
        c.target[f >> 1] += (f & 1) ? -1.0 : 1.0;
        c.fovy_deg = 90.0;
        assert_int_equal(vis_trace(ctx, truth, &c, &d, ids, (size_t)side * side, NULL, 0), VIS_OK);
        for (size_t p = 0; p < (size_t)side * side; ++p)
            if (ids[p] >= ENT_BASE && ids[p] < ENT_BASE + ne)
                seen[ids[p] - ENT_BASE] = 1;
    }
    free(ids);
}

/* Entity j as box object ENT_BASE + j of the truth scene s (its box at time 0). */
static void add_entity_boxes(vis_scene *s, const vis_query_entity *en, uint32_t ne)
{
    for (uint32_t j = 0; j < ne; ++j) {
        tobj o;
        memset(&o, 0, sizeof o);
        o.id = ENT_BASE + j;
        float lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = (float)en[j].box_min[k];
            hi[k] = (float)en[j].box_max[k];
        }
        obj_box(&o, lo, hi);
        set_obj(s, &o);
        obj_clear(&o);
    }
}

/* The truth scene: the walls plus the entities (add_entity_boxes). */
static vis_scene *truth_scene(vis_context *ctx, const tworld *w, const vis_query_entity *en, uint32_t ne)
{
    vis_scene *s = make_scene(ctx, w, NULL, 0);
    add_entity_boxes(s, en, ne);
    return s;
}

static int listed(vis_query *q, uint32_t viewer, uint32_t id, uint32_t *reason)
{
    vis_query_hit hits[512];
    size_t n = 0;
    assert_int_equal(vis_query_entities(q, viewer, hits, 512, &n), VIS_OK);
    for (size_t i = 0; i < n; ++i)
        if (hits[i].id == id) {
            if (reason)
                *reason = hits[i].reason;
            return 1;
        }
    return 0;
}

/* ---- solid ground (vis_query_desc.solid) ---------------------------------------------- */

/* An empty 64 x 48 x 64 voxel world. */
static vw_world *empty_64x48x64(void)
{
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.size[0] = 64;
    d.size[1] = 48;
    d.size[2] = 64;
    vw_world *w = NULL;
    vw_error err;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_OK);
    return w;
}

/* A 64 x 48 x 64 voxel world of rolling hills (a sum of cosines, 1 to 40 voxels high), meshed
 * by voxelworld as the tools do: no quads inside the hills. heights[x + 64 z] is the first
 * air voxel of column (x, z). */
static vw_world *hill_world(uint64_t *rng, int32_t heights[64 * 64])
{
    vw_world *w = empty_64x48x64();
    double f[3][2], ph[3][2];
    for (int i = 0; i < 3; ++i)
        for (int k = 0; k < 2; ++k) {
            f[i][k] = (1.0 + (double)i) * 6.283185307179586 / 64.0 * (0.5 + vt_rand_unit(rng));
            ph[i][k] = 6.283185307179586 * vt_rand_unit(rng);
        }
    for (int64_t z = 0; z < 64; ++z)
        for (int64_t x = 0; x < 64; ++x) {
            double h = 14.0;
            for (int i = 0; i < 3; ++i)
                h += (12.0 / (1.0 + i)) * cos(f[i][0] * (double)x + ph[i][0]) * cos(f[i][1] * (double)z + ph[i][1]);
            int32_t top = (int32_t)(h < 1.0 ? 1.0 : h > 40.0 ? 40.0 : h);
            heights[x + 64 * z] = top;
            int64_t lo[3] = {x, 0, z}, hi[3] = {x + 1, top, z + 1};
            assert_int_equal(vw_world_fill(w, lo, hi, 1), VW_OK);
        }
    return w;
}

static void hill_chunk_to_truth(uint32_t chunk, uint32_t id, const vw_mesh *mesh, void *user)
{
    (void)chunk;
    vis_quad *q = malloc((mesh->count ? mesh->count : 1) * sizeof *q);
    assert_non_null(q);
    world_scene_convert_quads(mesh->quads, mesh->count, q);
    vis_mesh m = {q, (uint32_t)mesh->count, NULL, 0};
    assert_int_equal(vis_scene_set_object(user, id, &m), VIS_OK);
    free(q);
}

/* The truth for a voxel world: its chunk meshes plus the entities (add_entity_boxes). */
static vis_scene *hill_truth(vis_context *ctx, world_scene *ws, const vis_query_entity *en, uint32_t ne)
{
    vis_scene_desc sd;
    memset(&sd, 0, sizeof sd);
    sd.size[0] = 64.0f;
    sd.size[1] = 48.0f;
    sd.size[2] = 64.0f;
    sd.cell_size = 16.0f;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &s), VIS_OK);
    vw_error err;
    assert_int_equal(world_scene_for_each_object(ws, hill_chunk_to_truth, s, &err), 0);
    add_entity_boxes(s, en, ne);
    return s;
}

/* Someone standing on the hills at a random column. */
static void hill_spot(uint64_t *rng, const int32_t heights[64 * 64], double out[3])
{
    int x = 1 + (int)(vt_rand(rng) % 62), z = 1 + (int)(vt_rand(rng) % 62);
    out[0] = x + 0.2 + 0.6 * vt_rand_unit(rng);
    out[1] = (double)heights[x + 64 * z];
    out[2] = z + 0.2 + 0.6 * vt_rand_unit(rng);
}

/* Hills: with the world's solid voxels (world_scene_solid) the proof settles pairs whose
 * segments run through a hill, which the quads alone leave unchecked (a voxel mesh has no
 * quads inside a hill): more pairs hidden, fewer unchecked, fewer rays. With or without it,
 * no entity with a pixel in the dense truth from the true eye is hidden. */
static void test_solid_ground(void **state)
{
    (void)state;
    uint64_t rng = 0x5011d001;
    vis_context *ctx = make_cpu_ctx(2);
    uint32_t hidden[2] = {0, 0}, unchecked[2] = {0, 0}, visible = 0;
    uint64_t rays[2] = {0, 0}, tests[2] = {0, 0};
    int rounds = vt_small() ? 2 : 4;
    for (int round = 0; round < rounds; ++round) {
        int32_t *heights = malloc(64 * 64 * sizeof *heights);
        assert_non_null(heights);
        vw_world *w = hill_world(&rng, heights);
        world_scene *ws = NULL;
        vw_error err;
        assert_int_equal(world_scene_create(ctx, w, NULL, &ws, NULL, &err), 0);
        enum { NV = 6, NE = 24 };
        vis_query_viewer vw[NV];
        vis_query_entity en[NE];
        for (uint32_t i = 0; i < NV; ++i) {
            memset(&vw[i], 0, sizeof vw[i]);
            vw[i].id = 1 + i;
            hill_spot(&rng, heights, vw[i].eye);
            vw[i].eye[1] += 1.6;
            vw[i].velocity[0] = 4.0 * vt_rand_unit(&rng) - 2.0;
            vw[i].velocity[2] = 4.0 * vt_rand_unit(&rng) - 2.0;
            vw[i].latency_ms = 50.0;
        }
        for (uint32_t j = 0; j < NE; ++j) {
            memset(&en[j], 0, sizeof en[j]);
            en[j].id = 100 + j;
            double at[3];
            hill_spot(&rng, heights, at);
            for (int k = 0; k < 3; ++k) {
                en[j].box_min[k] = at[k] - (k == 1 ? 0.0 : 0.3);
                en[j].box_max[k] = at[k] + (k == 1 ? 1.8 : 0.3);
            }
        }
        vis_scene *truth = hill_truth(ctx, ws, en, NE);
        int seen[NV][NE];
        memset(seen, 0, sizeof seen);
        for (uint32_t i = 0; i < NV; ++i)
            truth_pass(ctx, truth, vw[i].eye, vt_small() ? 256 : 384, NE, seen[i]);
        for (int with = 0; with < 2; ++with) {
            vis_query_desc d;
            vis_query_desc_defaults(&d);
            if (with) {
                d.solid = world_scene_solid;
                d.solid_user = ws;
            }
            vis_query *q = NULL;
            assert_int_equal(vis_query_create(ctx, world_scene_scene(ws), &d, &q), VIS_OK);
            vis_query_stats st;
            assert_int_equal(vis_query_run(q, vw, NV, en, NE, &st), VIS_OK);
            for (uint32_t i = 0; i < NV; ++i)
                for (uint32_t j = 0; j < NE; ++j) {
                    if (seen[i][j] && !listed(q, i, en[j].id, NULL))
                        fail_msg("round %d, solid %d, viewer %u: entity %u has pixels in the truth but was hidden",
                                 round, with, i, en[j].id);
                    visible += (uint32_t)(with && seen[i][j]);
                }
            hidden[with] += st.pairs_hidden;
            unchecked[with] += st.pairs_unchecked;
            rays[with] += st.entity_rays;
            tests[with] += st.solid_tests;
            vis_query_destroy(q);
        }
        vis_scene_destroy(truth);
        world_scene_destroy(ws);
        vw_world_destroy(w);
        free(heights);
    }
    print_message("truly visible %u; hidden %u -> %u, unchecked %u -> %u, rays %llu -> %llu, solid tests %llu\n",
                  visible, hidden[0], hidden[1], unchecked[0], unchecked[1], (unsigned long long)rays[0],
                  (unsigned long long)rays[1], (unsigned long long)tests[1]);
    assert_true(visible > 0);
    assert_int_equal(tests[0], 0);
    assert_true(tests[1] > 0);
    assert_true(hidden[1] > hidden[0]);
    assert_true(unchecked[1] < unchecked[0]);
    assert_true(rays[1] < rays[0]);
    vis_context_destroy(ctx);
}

/* A ridge along z (30 voxels high at x = 32, a step down every voxel on each side) between a
 * viewer and an entity standing at its feet: the quads alone leave the pair unchecked, the
 * solid voxels prove it hidden, the next tick answers from the cache, and a tunnel dug
 * through the ridge on the line of sight (voxels set to air, the scene updated) is seen by
 * the tick after the edit. */
static void test_solid_edit_tunnel(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vw_world *w = empty_64x48x64();
    vw_error err;
    for (int64_t x = 0; x < 64; ++x) {
        int64_t top = 30 - 2 * (x < 32 ? 32 - x : x - 32);
        int64_t lo[3] = {x, 0, 0}, hi[3] = {x + 1, top > 1 ? top : 1, 64};
        assert_int_equal(vw_world_fill(w, lo, hi, 1), VW_OK);
    }
    world_scene *ws = NULL;
    assert_int_equal(world_scene_create(ctx, w, NULL, &ws, NULL, &err), 0);
    vis_query_viewer v;
    memset(&v, 0, sizeof v);
    v.id = 1;
    v.eye[0] = 6.5;
    v.eye[1] = 2.6;
    v.eye[2] = 32.5;
    vis_query_entity e;
    memset(&e, 0, sizeof e);
    e.id = 2;
    double elo[3] = {56.2, 1.0, 32.2}, ehi[3] = {56.8, 2.8, 32.8};
    memcpy(e.box_min, elo, sizeof elo);
    memcpy(e.box_max, ehi, sizeof ehi);
    uint32_t reason = 0;
    vis_query_stats st;
    /* The quads alone, within a few rays: no face of the ridge covers the crossings of its
     * first hits, and its inside has none. */
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.pair_ray_limit = 4;
    d.margin = 1.0; /* regions taller than a step of the ridge */
    vis_query *plain = NULL;
    assert_int_equal(vis_query_create(ctx, world_scene_scene(ws), &d, &plain), VIS_OK);
    assert_int_equal(vis_query_run(plain, &v, 1, &e, 1, &st), VIS_OK);
    assert_true(listed(plain, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_UNCHECKED);
    vis_query_destroy(plain);
    d.solid = world_scene_solid;
    d.solid_user = ws;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, world_scene_scene(ws), &d, &q), VIS_OK);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    assert_int_equal(st.pairs_hidden, 1);
    assert_true(st.solid_tests > 0);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 1);
    assert_false(listed(q, 0, 2, NULL));
    /* The tunnel: x through the ridge, y in [1, 4), z in [31, 35). */
    int64_t tlo[3] = {10, 1, 31}, thi[3] = {54, 4, 35};
    assert_int_equal(vw_world_fill(w, tlo, thi, 0), VW_OK);
    assert_int_equal(world_scene_update(ws, NULL, &err), 0);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 0);
    assert_true(listed(q, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_SEEN);
    vis_query_destroy(q);
    world_scene_destroy(ws);
    vw_world_destroy(w);
    vis_context_destroy(ctx);
}

/* Random worlds, viewers and entities: no entity with a pixel in the dense truth is hidden,
 * and the query does hide some (it is not reporting everything). */
static void test_never_hides_visible(void **state)
{
    (void)state;
    uint64_t rng = 0x5eed0001;
    vis_context *ctx = make_cpu_ctx(1);
    uint32_t hidden_total = 0, visible_total = 0, pairs_total = 0;
    int rounds = vt_small() ? 3 : 8;
    for (int round = 0; round < rounds; ++round) {
        tworld w;
        walls_world(&w, &rng, 24);
        vis_scene *scene = make_scene(ctx, &w, NULL, 0);
        enum { NV = 4, NE = 24 };
        vis_query_viewer vw[NV];
        vis_query_entity en[NE];
        for (uint32_t i = 0; i < NV; ++i)
            random_viewer(&rng, 1 + i, &vw[i]);
        for (uint32_t j = 0; j < NE; ++j)
            random_entity(&rng, 100 + j, &en[j]);
        vis_query_desc d;
        vis_query_desc_defaults(&d);
        d.pair_ray_limit = 256;
        vis_query *q = NULL;
        assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
        vis_query_stats st;
        assert_int_equal(vis_query_run(q, vw, NV, en, NE, &st), VIS_OK);
        vis_scene *truth = truth_scene(ctx, &w, en, NE);
        for (uint32_t i = 0; i < NV; ++i) {
            int seen[NE] = {0};
            truth_pass(ctx, truth, vw[i].eye, vt_small() ? 256 : 512, NE, seen);
            for (uint32_t j = 0; j < NE; ++j) {
                int in = listed(q, i, en[j].id, NULL);
                if (seen[j] && !in)
                    fail_msg("round %d viewer %u: entity %u has pixels in the truth but was hidden", round, i,
                             en[j].id);
                visible_total += (uint32_t)seen[j];
            }
        }
        hidden_total += st.pairs_hidden;
        pairs_total += st.pairs;
        vis_query_destroy(q);
        vis_scene_destroy(truth);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    print_message("pairs %u, truly visible %u, hidden by the query %u\n", pairs_total, visible_total, hidden_total);
    assert_true(visible_total > 0);
    assert_true(hidden_total > pairs_total / 10); /* it proves a fair share hidden */
    vis_context_destroy(ctx);
}

/* A wall x in [20, 21], y up to 10, z in [0, 40): an opening at z >= 40. */
static void corner_world(tworld *w)
{
    memset(w, 0, sizeof *w);
    w->size[0] = w->size[1] = w->size[2] = 64.0f;
    float flo[3] = {0, 0, 0}, fhi[3] = {64, 1, 64};
    obj_box(add_obj(w, 1), flo, fhi);
    float lo[3] = {20, 1, 0}, hi[3] = {21, 10, 40};
    obj_box(add_obj(w, 2), lo, hi);
}

static void corner_setup(vis_query_viewer *v, vis_query_entity *e)
{
    memset(v, 0, sizeof *v);
    memset(e, 0, sizeof *e);
    v->id = 1;
    v->eye[0] = 10.0;
    v->eye[1] = 2.6;
    v->eye[2] = 38.0;
    v->dir[0] = 1.0;
    v->fov_deg = 90.0;
    e->id = 2;
    /* Behind the wall, 1.5 voxels short of the opening, running towards it at 10 voxels/s. */
    double lo[3] = {22.0, 1.0, 37.5}, hi[3] = {23.0, 2.8, 38.5};
    memcpy(e->box_min, lo, sizeof lo);
    memcpy(e->box_max, hi, sizeof hi);
    e->velocity[2] = 10.0;
}

/* An entity about to step out from behind a corner is reported before the truth sees it,
 * when the latency lets it get there; without latency it stays hidden. The same for a
 * viewer peeking out. */
static void test_latency_peek(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup(&v, &e);
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q), VIS_OK);
    /* The truth from the true eye: hidden now. */
    vis_scene *truth = truth_scene(ctx, &w, &e, 1);
    int seen[1] = {0};
    truth_pass(ctx, truth, v.eye, 256, 1, seen);
    assert_false(seen[0]);
    v.latency_ms = 0.0;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    /* 200 ms at 10 voxels/s: 2 voxels, past z = 40 into the opening. */
    v.latency_ms = 200.0;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_true(listed(q, 0, 2, NULL));
    /* And the truth, once it gets there, does see it. */
    vis_query_entity later = e;
    later.box_min[2] += 2.0;
    later.box_max[2] += 2.0;
    vis_scene *truth2 = truth_scene(ctx, &w, &later, 1);
    seen[0] = 0;
    truth_pass(ctx, truth2, v.eye, 256, 1, seen);
    assert_true(seen[0]);
    /* A still entity further back, and a viewer that may peek: hidden without the peek,
     * reported with it (the eye can reach past the wall's end in 300 ms at 10 voxels/s). */
    e.velocity[2] = 0.0;
    e.box_min[2] = 30.0;
    e.box_max[2] = 31.0;
    v.latency_ms = 300.0;
    v.eye[2] = 38.5;
    v.eye[0] = 18.0;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    vis_query_destroy(q);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.peek_speed = 10.0;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_true(listed(q, 0, 2, NULL));
    vis_query_destroy(q);
    vis_scene_destroy(truth);
    vis_scene_destroy(truth2);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* An edit that opens the wall is seen by the next tick (the cache is dropped). */
/* corner_setup with the entity standing still behind the wall, at z 19.5..20.5. */
static void corner_setup_still(vis_query_viewer *v, vis_query_entity *e)
{
    corner_setup(v, e);
    e->velocity[2] = 0.0;
    e->box_min[2] = 19.5;
    e->box_max[2] = 20.5;
}

/* Object 2 becomes the wall x 20..21, y 1..10, z 0..40 with a window y 2..4, z z0..z1 cut
 * into it; then the pair (viewer 0, entity 2) of q, behind it, is seen on the next tick and
 * answered from no cached proof. */
static void cut_window_and_see(vis_scene *scene, vis_query *q, const vis_query_viewer *v, const vis_query_entity *e,
                               float z0, float z1)
{
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = 2;
    float parts[4][6] = {{20, 1, 0, 21, 10, z0}, {20, 1, z1, 21, 10, 40}, {20, 1, z0, 21, 2, z1}, {20, 4, z0, 21, 10, z1}};
    for (int i = 0; i < 4; ++i)
        obj_box(&o, parts[i], parts[i] + 3);
    set_obj(scene, &o);
    obj_clear(&o);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, v, 1, e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 0);
    uint32_t reason = 0;
    assert_true(listed(q, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_SEEN);
}

static void test_edit_opens_wall(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup_still(&v, &e);
    v.eye[2] = 20.0;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 1); /* nothing moved: answered from the cache */
    assert_false(listed(q, 0, 2, NULL));
    /* An edit away from every segment between the eye region and the entity's box (a new
     * block behind the viewer's back, past the world's far corner of the pair) keeps the
     * proof: answered from the cache. */
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = 9;
    float far_lo[3] = {40, 1, 50}, far_hi[3] = {41, 3, 51};
    obj_box(&o, far_lo, far_hi);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 1);
    assert_false(listed(q, 0, 2, NULL));
    /* Cut a window z in [18, 22), y in [2, 4) into the wall: the wall becomes 4 boxes. */
    memset(&o, 0, sizeof o);
    o.id = 2;
    float parts[4][6] = {{20, 1, 0, 21, 10, 18}, {20, 1, 22, 21, 10, 40}, {20, 1, 18, 21, 2, 22}, {20, 4, 18, 21, 10, 22}};
    for (int i = 0; i < 4; ++i)
        obj_box(&o, parts[i], parts[i] + 3);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 0);
    uint32_t reason = 0;
    assert_true(listed(q, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_SEEN);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Proof slack: a proof over regions grown ahead along the velocities answers the next ticks
 * while viewer and entity stay inside them. An entity walking along behind the wall and out
 * past its end: the slack query spends fewer rays, answers ticks from the cache, lists the
 * entity whenever the exact query (slack 0) sees it, and whenever the truth does; a window
 * cut into the wall is seen by the next tick although the cached proof still covered it. */
static void test_slack_cache(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup(&v, &e);
    v.velocity[2] = 1.0; /* both move: the viewer slowly, the entity at 10 voxels/s */
    v.latency_ms = 50.0;
    e.box_min[2] = 30.0;
    e.box_max[2] = 31.0;
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.proof_slack = -1.0; /* none */
    vis_query *q0 = NULL, *q1 = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q0), VIS_OK);
    d.proof_slack = 2.0;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q1), VIS_OK);
    uint64_t rays0 = 0, rays1 = 0, cached = 0;
    int hidden_ticks = 0, truth_seen = 0;
    for (int t = 0; t < 160; ++t) {
        vis_query_stats s0, s1;
        assert_int_equal(vis_query_run(q0, &v, 1, &e, 1, &s0), VIS_OK);
        assert_int_equal(vis_query_run(q1, &v, 1, &e, 1, &s1), VIS_OK);
        rays0 += s0.entity_rays;
        rays1 += s1.entity_rays;
        cached += s1.pairs_cached;
        uint32_t r0 = 0;
        int l0 = listed(q0, 0, 2, &r0), l1 = listed(q1, 0, 2, NULL);
        if (l0 && r0 == VIS_QUERY_SEEN)
            assert_true(l1);
        hidden_ticks += !l1;
        if (t % 16 == 0) {
            vis_scene *truth = truth_scene(ctx, &w, &e, 1);
            int seen[1] = {0};
            truth_pass(ctx, truth, v.eye, 128, 1, seen);
            if (seen[0]) {
                assert_true(l1);
                ++truth_seen;
            }
            vis_scene_destroy(truth);
        }
        for (int k = 0; k < 3; ++k) {
            v.eye[k] += v.velocity[k] / 128.0;
            e.box_min[k] += e.velocity[k] / 128.0;
            e.box_max[k] += e.velocity[k] / 128.0;
        }
    }
    assert_true(hidden_ticks > 40); /* it was behind the wall for the first ~100 ticks */
    assert_true(truth_seen > 0);    /* and came out */
    assert_true(cached > 80);
    /* A third fewer at least: one pair's proofs reach 1/2 to 3/2 of the slack, drawn per tick
     * (proof_reach), and a far reach near the wall's end costs a failed proof. */
    assert_true(rays1 * 3 < rays0 * 2);
    /* Behind the wall again, moving: a cached proof; then a window in front of it. */
    e.box_min[2] = 20.0;
    e.box_max[2] = 21.0;
    v.eye[2] = 20.5;
    vis_query_stats st;
    for (int t = 0; t < 3; ++t)
        assert_int_equal(vis_query_run(q1, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 1);
    assert_false(listed(q1, 0, 2, NULL));
    cut_window_and_see(scene, q1, &v, &e, 18, 23);
    vis_query_destroy(q0);
    vis_query_destroy(q1);
    /* Bad slack or range: refused at creation. */
    vis_query *bad = NULL;
    d.proof_slack = NAN;
    assert_int_equal(vis_query_create(ctx, scene, &d, &bad), VIS_ERROR_INVALID_ARGUMENT);
    d.proof_slack = 0.0;
    d.chunk_range = 0.5; /* inside the pass's near plane */
    assert_int_equal(vis_query_create(ctx, scene, &d, &bad), VIS_ERROR_INVALID_ARGUMENT);
    assert_null(bad);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Proofs made together do not expire together. Sixteen entities walk along behind a wall
 * beside a viewer walking with them, all at one speed: the first tick proves every pair over
 * regions grown ahead (so the second tick does not prove them again), and each proof reaches
 * its own distance ahead, so no later tick proves more than half of what the first did. */
static void test_proofs_spread(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    enum { NE = 16 };
    vis_query_viewer v;
    vis_query_entity en[NE];
    memset(&v, 0, sizeof v);
    v.id = 1;
    v.eye[0] = 10.0;
    v.eye[1] = 2.6;
    v.eye[2] = 4.0;
    v.dir[2] = 1.0;
    v.fov_deg = 90.0;
    v.velocity[2] = 4.3;
    v.latency_ms = 50.0;
    for (uint32_t j = 0; j < NE; ++j) {
        memset(&en[j], 0, sizeof en[j]);
        en[j].id = 100 + j;
        double x = 22.0 + 2.0 * (j % 8), z = 4.0 + 3.0 * (j / 8);
        double lo[3] = {x, 1.0, z}, hi[3] = {x + 0.6, 2.8, z + 0.6};
        memcpy(en[j].box_min, lo, sizeof lo);
        memcpy(en[j].box_max, hi, sizeof hi);
        en[j].velocity[2] = 4.3;
    }
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q), VIS_OK);
    uint64_t first = 0, most = 0, total = 0;
    for (int t = 0; t < 96; ++t) {
        vis_query_stats st;
        assert_int_equal(vis_query_run(q, &v, 1, en, NE, &st), VIS_OK);
        assert_int_equal(st.pairs_hidden, NE); /* the wall hides them all the way */
        if (t == 0)
            first = st.entity_rays;
        else if (st.entity_rays > most)
            most = st.entity_rays;
        total += st.entity_rays;
        v.eye[2] += v.velocity[2] / 128.0;
        for (uint32_t j = 0; j < NE; ++j) {
            en[j].box_min[2] += en[j].velocity[2] / 128.0;
            en[j].box_max[2] += en[j].velocity[2] / 128.0;
        }
    }
    print_message("rays: first tick %llu, most on a later tick %llu, all %llu\n", (unsigned long long)first,
                  (unsigned long long)most, (unsigned long long)total);
    assert_true(first >= NE);
    assert_true(most * 2 <= first);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* An edit off every segment a proof took keeps it, although it lies inside the bounding box
 * of the pair's two regions: the viewer and the entity are far apart along a diagonal, with
 * the wall between them; a block dropped into the empty corner of their box leaves the proof
 * answered from the cache, and a block on the line between them proves it again. */
static void test_edit_off_the_segment(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup_still(&v, &e);
    v.eye[2] = 10.0;
    double lo[3] = {30.0, 1.0, 30.0}, hi[3] = {30.6, 2.8, 30.6};
    memcpy(e.box_min, lo, sizeof lo);
    memcpy(e.box_max, hi, sizeof hi);
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = 9;
    float corner_lo[3] = {27, 1, 12}, corner_hi[3] = {28, 3, 13}; /* about 11 voxels off the line */
    obj_box(&o, corner_lo, corner_hi);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 1);
    assert_int_equal(st.entity_rays, 0);
    assert_false(listed(q, 0, 2, NULL));
    memset(&o, 0, sizeof o);
    o.id = 10;
    float line_lo[3] = {15, 1, 15}, line_hi[3] = {16, 4, 16}; /* across the line from eye to box */
    obj_box(&o, line_lo, line_hi);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.pairs_cached, 0);
    assert_false(listed(q, 0, 2, NULL));
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Unsettled pairs wait: a pair whose proof used its whole pair limit is reported
 * (UNCHECKED) and, with unsettled_ticks N, not proven again for N ticks while it stays in
 * its regions; leaving them, an edit reaching them, or a proof the ray budget cut short ends
 * the wait. With the default (1) it is proven every tick. A pair limit of 1 ray cannot
 * settle any hidden pair (the segment and the plane test are two). */
static void test_unsettled_wait(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup_still(&v, &e);
    v.eye[1] = 3.0; /* the centre segment clears the window's sill, once it is cut */
    v.eye[2] = 20.0;
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    assert_int_equal(d.unsettled_ticks, 1);
    d.pair_ray_limit = 1;
    vis_query *q1 = NULL, *q4 = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q1), VIS_OK);
    d.unsettled_ticks = 4;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q4), VIS_OK);
    vis_query_stats s1, s4;
    /* Ticks 1..8: q4 proves on ticks 1 and 5 and answers the others from the wait; q1 proves
     * every tick. Both report the pair every tick. */
    for (int t = 1; t <= 8; ++t) {
        assert_int_equal(vis_query_run(q1, &v, 1, &e, 1, &s1), VIS_OK);
        assert_int_equal(vis_query_run(q4, &v, 1, &e, 1, &s4), VIS_OK);
        assert_int_equal(s1.entity_rays, 1);
        assert_int_equal(s1.pairs_cached, 0);
        int proves = t == 1 || t == 5;
        assert_int_equal(s4.entity_rays, proves ? 1 : 0);
        assert_int_equal(s4.pairs_cached, proves ? 0 : 1);
        assert_int_equal(s4.pairs_unchecked, 1);
        uint32_t r1 = 0, r4 = 0;
        assert_true(listed(q1, 0, 2, &r1));
        assert_true(listed(q4, 0, 2, &r4));
        assert_int_equal(r1, VIS_QUERY_UNCHECKED);
        assert_int_equal(r4, VIS_QUERY_UNCHECKED);
    }
    /* Tick 9 proved again (the wait of tick 5's proof ends at tick 9); on tick 10 the viewer
     * (still: its regions are not grown) steps 0.25 voxels: proven again at once. */
    assert_int_equal(vis_query_run(q4, &v, 1, &e, 1, &s4), VIS_OK);
    assert_int_equal(s4.entity_rays, 1);
    v.eye[2] += 0.25;
    assert_int_equal(vis_query_run(q4, &v, 1, &e, 1, &s4), VIS_OK);
    assert_int_equal(s4.entity_rays, 1);
    assert_true(listed(q4, 0, 2, NULL));
    /* A window cut into the wall between them during the wait: SEEN on the next tick. */
    cut_window_and_see(scene, q4, &v, &e, 18, 22);
    vis_query_destroy(q1);
    vis_query_destroy(q4);
    /* A proof the ray budget cut short is not kept: proven again on the next tick. */
    vis_scene *scene2 = make_scene(ctx, &w, NULL, 0); /* the wall without its window */
    d.pair_ray_limit = 16;
    d.unsettled_ticks = 8;
    d.ray_budget = 1;
    assert_int_equal(vis_query_create(ctx, scene2, &d, &q4), VIS_OK);
    for (int t = 0; t < 3; ++t) {
        assert_int_equal(vis_query_run(q4, &v, 1, &e, 1, &s4), VIS_OK);
        assert_int_equal(s4.entity_rays, 1);
        assert_int_equal(s4.pairs_cached, 0);
        assert_true(listed(q4, 0, 2, NULL));
    }
    vis_query_destroy(q4);
    /* Out of range: refused at creation. */
    vis_query *bad = NULL;
    d.unsettled_ticks = 1025;
    assert_int_equal(vis_query_create(ctx, scene2, &d, &bad), VIS_ERROR_INVALID_ARGUMENT);
    assert_null(bad);
    vis_scene_destroy(scene2);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Hold: seen at tick 1, hidden from tick 2: reported (HELD) for hold_ticks more ticks. */
static void test_hold(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup(&v, &e);
    e.velocity[2] = 0.0;
    e.box_min[2] = 60.0; /* in the open */
    e.box_max[2] = 61.0;
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.hold_ticks = 3;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    uint32_t reason = 0;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_true(listed(q, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_SEEN);
    e.box_min[2] = 20.0; /* behind the wall */
    e.box_max[2] = 21.0;
    for (int t = 0; t < 3; ++t) {
        assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
        assert_true(listed(q, 0, 2, &reason));
        assert_int_equal(reason, VIS_QUERY_HELD);
    }
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, NULL), VIS_OK);
    assert_false(listed(q, 0, 2, NULL));
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Runs a few ticks of a random world on ctx (destroyed here) and returns every list, for
 * comparisons. */
static size_t run_ticks_on(vis_context *ctx, uint32_t threads, const vis_query_desc *base, uint32_t *out, size_t cap,
                           vis_query_stats *st_out)
{
    uint64_t rng = 0x5eed0002;
    tworld w;
    walls_world(&w, &rng, 24);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    enum { NV = 12, NE = 40 };
    vis_query_viewer vw[NV];
    vis_query_entity en[NE];
    for (uint32_t i = 0; i < NV; ++i)
        random_viewer(&rng, 1 + i, &vw[i]);
    for (uint32_t j = 0; j < NE; ++j)
        random_entity(&rng, 100 + j, &en[j]);
    vis_query_desc d = *base;
    d.threads = threads;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    size_t n = 0;
    memset(st_out, 0, sizeof *st_out);
    for (int t = 0; t < 4; ++t) {
        for (uint32_t j = 0; j < NE; ++j) {
            en[j].box_min[0] += 0.25 * (double)(j % 3);
            en[j].box_max[0] += 0.25 * (double)(j % 3);
            en[j].velocity[2] = (double)(j % 5);
        }
        vw[t % NV].latency_ms = 50.0 * t;
        if (t >= 2) { /* edits: the passes they reach are traced again, the others kept */
            float lo[3] = {20.0f * (float)t - 30.0f, 1.0f, 30.0f}, hi[3] = {20.0f * (float)t - 28.0f, 4.0f, 33.0f};
            tobj o;
            memset(&o, 0, sizeof o);
            o.id = 500u + (uint32_t)t;
            obj_box(&o, lo, hi);
            set_obj(scene, &o);
            obj_clear(&o);
        }
        vis_query_stats st;
        assert_int_equal(vis_query_run(q, vw, NV, en, NE, &st), VIS_OK);
        st_out->pairs_unchecked += st.pairs_unchecked;
        st_out->pairs_hidden += st.pairs_hidden;
        st_out->entity_rays += st.entity_rays;
        st_out->pairs += st.pairs;
        st_out->chunk_rays += st.chunk_rays;
        st_out->chunk_edit_passes += st.chunk_edit_passes;
        for (uint32_t i = 0; i < NV; ++i) {
            vis_query_hit hits[NE];
            size_t k = 0;
            assert_int_equal(vis_query_entities(q, i, hits, NE, &k), VIS_OK);
            for (size_t h = 0; h < k && n + 2 <= cap; ++h) {
                out[n++] = hits[h].id;
                out[n++] = hits[h].reason;
            }
            uint32_t chunks[6 * 32 * 32];
            assert_int_equal(vis_query_chunks(q, i, chunks, 6 * 32 * 32, &k), VIS_OK);
            for (size_t h = 0; h < k && n < cap; ++h)
                out[n++] = chunks[h];
        }
    }
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
    return n;
}

static size_t run_ticks(uint32_t threads, const vis_query_desc *base, uint32_t *out, size_t cap, vis_query_stats *st_out)
{
    return run_ticks_on(make_cpu_ctx(threads), threads, base, out, cap, st_out);
}

/* The same lists from an OpenCL context (its chunk passes run on the device); skipped where
 * no OpenCL device can be opened. */
static void test_backends_deterministic(void **state)
{
    (void)state;
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_OPENCL;
    vis_context *cl = NULL;
    if (vis_context_create(&cd, &cl) != VIS_OK) {
        print_message("no OpenCL device: skipped\n");
        skip();
    }
    enum { CAP = 1 << 16 };
    uint32_t *a = malloc(CAP * 4), *b = malloc(CAP * 4);
    assert_non_null(a);
    assert_non_null(b);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.ray_budget = 300;
    vis_query_stats s1, s2;
    size_t n1 = run_ticks(2, &d, a, CAP, &s1);
    size_t n2 = run_ticks_on(cl, 2, &d, b, CAP, &s2);
    assert_int_equal(n1, n2);
    assert_memory_equal(a, b, n1 * 4);
    free(a);
    free(b);
}

static void test_threads_deterministic(void **state)
{
    (void)state;
    enum { CAP = 1 << 16 };
    uint32_t *a = malloc(CAP * 4), *b = malloc(CAP * 4);
    assert_non_null(a);
    assert_non_null(b);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.ray_budget = 300; /* the budget runs out mid-tick: its split must not depend on threads */
    vis_query_stats s1, s2;
    size_t n1 = run_ticks(1, &d, a, CAP, &s1);
    assert_true(s1.pairs_unchecked > 0);
    uint32_t threads[] = {2, 4};
    for (int t = 0; t < 2; ++t) {
        size_t n2 = run_ticks(threads[t], &d, b, CAP, &s2);
        assert_int_equal(n1, n2);
        assert_memory_equal(a, b, n1 * 4);
        assert_int_equal(s1.entity_rays, s2.entity_rays);
        assert_int_equal(s1.chunk_rays, s2.chunk_rays);
        assert_int_equal(s1.chunk_edit_passes, s2.chunk_edit_passes);
    }
    /* The viewers on a pool of the query's own (3 threads beside the context's 2) rather than
     * on the context's CPU threads: the same lists. */
    size_t n3 = run_ticks_on(make_cpu_ctx(2), 3, &d, b, CAP, &s2);
    assert_int_equal(n1, n3);
    assert_memory_equal(a, b, n1 * 4);
    assert_int_equal(s1.entity_rays, s2.entity_rays);
    assert_true(s1.chunk_edit_passes > 0 && s1.chunk_edit_passes < 2 * 12); /* edits retraced some viewers */
    /* Unsettled pairs waiting (a pair limit too small to settle many): the same lists. */
    d.pair_ray_limit = 3;
    d.unsettled_ticks = 2;
    n1 = run_ticks(1, &d, a, CAP, &s1);
    assert_true(s1.pairs_unchecked > 0);
    for (int t = 0; t < 2; ++t) {
        size_t n2 = run_ticks(threads[t], &d, b, CAP, &s2);
        assert_int_equal(n1, n2);
        assert_memory_equal(a, b, n1 * 4);
        assert_int_equal(s1.entity_rays, s2.entity_rays);
    }
    d.pair_ray_limit = 0;
    d.unsettled_ticks = 0;
    /* Passes driven by the eyes' motion, with another traversal, then with a budget of 2 faces
     * (passes spread over ticks, faces waiting): still the same lists. */
    d.chunk_move = 0.5;
    d.chunk_traversal = VIS_TRAVERSAL_SHORTSTACK;
    uint64_t unbudgeted = 0;
    for (int budget = 0; budget < 2; ++budget) {
        d.chunk_face_budget = budget ? 2u : 0u;
        n1 = run_ticks(1, &d, a, CAP, &s1);
        for (int t = 0; t < 2; ++t) {
            size_t n2 = run_ticks(threads[t], &d, b, CAP, &s2);
            assert_int_equal(n1, n2);
            assert_memory_equal(a, b, n1 * 4);
            assert_int_equal(s1.chunk_rays, s2.chunk_rays);
        }
        if (budget) /* four ticks of at most 2 faces, fewer than without the budget */
            assert_true(s1.chunk_rays <= 4u * 2u * 32u * 32u && s1.chunk_rays < unbudgeted);
        unbudgeted = s1.chunk_rays;
    }
    free(a);
    free(b);
}

/* The budget: what it cannot check is reported (UNCHECKED), never hidden; rays stay within
 * it; the nearest in-view pairs are checked first. */
static void test_budget(void **state)
{
    (void)state;
    enum { CAP = 1 << 16 };
    uint32_t *a = malloc(CAP * 4);
    assert_non_null(a);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    vis_query_stats full, tight, none;
    run_ticks(1, &d, a, CAP, &full);
    print_message("no budget: %u pairs, %u hidden, %u unchecked (pair limit), %llu rays\n", full.pairs,
                  full.pairs_hidden, full.pairs_unchecked, (unsigned long long)full.entity_rays);
    d.ray_budget = 120;
    run_ticks(1, &d, a, CAP, &tight);
    assert_true(tight.entity_rays <= 4 * 120);
    assert_true(tight.pairs_unchecked > 0);
    assert_true(tight.pairs_hidden < full.pairs_hidden);
    d.ray_budget = 0;
    d.viewer_ray_budget = 1; /* one ray per viewer: only a clear first segment settles a pair */
    run_ticks(1, &d, a, CAP, &none);
    assert_int_equal(none.pairs_hidden, 0);
    assert_true(none.entity_rays <= 4 * 12);
    free(a);

    /* Priority: with room for one pair, a viewer checks the nearest in-view entity. */
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e[2];
    corner_setup(&v, &e[0]);
    e[0].velocity[2] = 0.0;
    e[1] = e[0];
    e[1].id = 3;
    double far_lo[3] = {40.0, 1.0, 30.0}, near_lo[3] = {25.0, 1.0, 33.0}; /* both in view, behind the wall */
    for (int k = 0; k < 3; ++k) {
        e[0].box_min[k] = far_lo[k];
        e[0].box_max[k] = far_lo[k] + (k == 1 ? 1.8 : 1.0);
        e[1].box_min[k] = near_lo[k];
        e[1].box_max[k] = near_lo[k] + (k == 1 ? 1.8 : 1.0);
    }
    vis_query_desc_defaults(&d);
    d.viewer_ray_budget = 2; /* a segment and a plane test: one simple proof */
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    uint32_t reason = 0;
    assert_int_equal(vis_query_run(q, &v, 1, e, 2, NULL), VIS_OK);
    assert_false(listed(q, 0, 3, NULL));
    assert_true(listed(q, 0, 2, &reason));
    assert_int_equal(reason, VIS_QUERY_UNCHECKED);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The call budget goes where proofs are needed: fifteen viewers whose pairs the cache answers
 * leave their part of it to the one whose pair needs a proof (an even split would give that
 * one a sixteenth: too little for its proof). */
static void test_budget_shared(void **state)
{
    (void)state;
    enum { NV = 16, H = NV - 1 }; /* H, last in input order, gets no remainder of an even split */
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v[NV];
    vis_query_entity e;
    corner_setup_still(&v[H], &e); /* viewer H: the entity behind the wall */
    for (uint32_t i = 0; i < H; ++i) { /* the others: in the open beside it */
        v[i] = v[H];
        v[i].id = 10 + i;
        v[i].eye[0] = 30.0;
        v[i].eye[2] = 5.0 + 2.0 * i;
        v[i].dir[0] = -1.0;
    }
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.threads = 2;
    vis_query *free_q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &free_q), VIS_OK);
    vis_query_stats first, second;
    assert_int_equal(vis_query_run(free_q, v, NV, &e, 1, &first), VIS_OK);
    v[H].eye[2] -= 0.3; /* viewer H steps out of its proven region, still behind the wall */
    assert_int_equal(vis_query_run(free_q, v, NV, &e, 1, &second), VIS_OK);
    /* Without a budget: every other pair seen and then cached; viewer H's proven again. */
    assert_false(listed(free_q, H, e.id, NULL));
    for (uint32_t i = 0; i < H; ++i)
        assert_true(listed(free_q, i, e.id, NULL));
    assert_int_equal(second.pairs_cached, NV - 1);
    const uint64_t budget = first.entity_rays;
    print_message("budget %llu rays; viewer H's proof on the second tick: %llu\n", (unsigned long long)budget,
                  (unsigned long long)second.entity_rays);
    assert_true(second.entity_rays > budget / NV && second.entity_rays <= budget);

    d.ray_budget = budget;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    v[H].eye[2] += 0.3;
    vis_query_stats st;
    for (int t = 0; t < 2; ++t) { /* what the first tick's shares did not reach, the second's do */
        assert_int_equal(vis_query_run(q, v, NV, &e, 1, &st), VIS_OK);
        assert_true(st.entity_rays <= budget);
    }
    assert_int_equal(st.pairs_unchecked, 0);
    v[H].eye[2] -= 0.3;
    assert_int_equal(vis_query_run(q, v, NV, &e, 1, &st), VIS_OK);
    assert_true(st.entity_rays <= budget);
    assert_int_equal(st.pairs_cached, NV - 1);
    assert_false(listed(q, H, e.id, NULL)); /* proven hidden: the budget reached it */
    for (uint32_t i = 0; i < H; ++i)
        assert_true(listed(q, i, e.id, NULL));
    vis_query_destroy(q);
    vis_query_destroy(free_q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* One tick of viewers v[0..nv) and entities e[0..ne) on a new query with desc d. */
static vis_query_stats one_tick(vis_context *ctx, vis_scene *scene, const vis_query_desc *d,
                                const vis_query_viewer *v, uint32_t nv, const vis_query_entity *e, uint32_t ne)
{
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, d, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, v, nv, e, ne, &st), VIS_OK);
    vis_query_destroy(q);
    return st;
}

/* What the first round's shares leave goes to the viewers that still have pairs: viewer A
 * sees NE entities in the open (a ray each), viewer B proves them hidden behind a wall (more
 * rays each). A budget of both viewers' needs plus two pair limits (for a proof cut short at
 * the end of a share) proves every pair, though the first round gives B half of it, less
 * than B needs. And viewer_ray_budget still caps every viewer's share. */
static void test_budget_rounds_and_caps(void **state)
{
    (void)state;
    enum { NE = 48 };
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    corner_world(&w); /* the wall x 20..21, y 1..10, z 0..40 */
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v[2];
    vis_query_entity e[NE];
    memset(v, 0, sizeof v);
    v[0].id = 1000; /* A: on the entities' side */
    v[0].eye[0] = 62.0;
    v[0].eye[1] = 2.6;
    v[0].eye[2] = 20.0;
    v[0].dir[0] = -1.0;
    v[0].fov_deg = 90.0;
    v[1] = v[0]; /* B: behind the wall */
    v[1].id = 1001;
    v[1].eye[0] = 10.0;
    v[1].dir[0] = 1.0;
    memset(e, 0, sizeof e);
    for (uint32_t j = 0; j < NE; ++j) {
        e[j].id = 1 + j;
        double lo[3] = {24.0 + 4.0 * (j % 8), 1.0, 14.0 + 2.0 * (j / 8)};
        for (int k = 0; k < 3; ++k) {
            e[j].box_min[k] = lo[k];
            e[j].box_max[k] = lo[k] + (k == 1 ? 1.8 : 0.6);
        }
    }
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.threads = 2;
    d.max_entities = NE;
    vis_query_stats a = one_tick(ctx, scene, &d, &v[0], 1, e, NE), b = one_tick(ctx, scene, &d, &v[1], 1, e, NE);
    assert_int_equal(a.pairs_seen, NE);
    assert_int_equal(b.pairs_hidden, NE);
    const uint64_t slack = 2u * d.pair_ray_limit, budget = a.entity_rays + b.entity_rays + slack;
    print_message("A needs %llu rays, B %llu; budget %llu\n", (unsigned long long)a.entity_rays,
                  (unsigned long long)b.entity_rays, (unsigned long long)budget);
    assert_true(budget / 2 < b.entity_rays); /* the first round alone cannot fund B */

    d.ray_budget = budget;
    vis_query_stats st = one_tick(ctx, scene, &d, v, 2, e, NE);
    assert_int_equal(st.pairs_unchecked, 0);
    assert_int_equal(st.pairs_hidden, NE);
    assert_true(st.entity_rays <= budget);

    d.viewer_ray_budget = (uint32_t)(a.entity_rays / 2); /* less than either viewer needs */
    st = one_tick(ctx, scene, &d, v, 2, e, NE);
    assert_true(st.entity_rays <= 2u * d.viewer_ray_budget);
    assert_true(st.pairs_unchecked > 0);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Bad input: rejected with a message naming the item, nothing changed (the last tick's
 * results stay, the tick is not counted). */
static void test_bad_input(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    corner_world(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup(&v, &e);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.max_viewers = 2;
    d.max_entities = 2;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.tick, 1);
    size_t before = 0;
    assert_int_equal(vis_query_entities(q, 0, NULL, 0, &before), VIS_OK);

    struct {
        const char *what;
        vis_status want;
        int field;
    } cases[] = {{"eye", VIS_ERROR_INVALID_ARGUMENT, 0},      {"latency", VIS_ERROR_INVALID_ARGUMENT, 1},
                 {"box is empty", VIS_ERROR_INVALID_ARGUMENT, 2}, {"id is not", VIS_ERROR_INVALID_ARGUMENT, 3},
                 {"appears twice", VIS_ERROR_INVALID_ARGUMENT, 4}, {"velocity", VIS_ERROR_INVALID_ARGUMENT, 5},
                 {"fov_deg", VIS_ERROR_INVALID_ARGUMENT, 6},      {"the query holds", VIS_ERROR_CAPACITY, 7},
                 {"box is not finite", VIS_ERROR_INVALID_ARGUMENT, 8},
                 {"dir is too short", VIS_ERROR_INVALID_ARGUMENT, 9},
                 {"fov_deg", VIS_ERROR_INVALID_ARGUMENT, 10}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        vis_query_viewer bv = v;
        vis_query_entity be[3] = {e, e, e};
        be[1].id = 7;
        be[2].id = 8;
        uint32_t ne = 1;
        switch (cases[c].field) {
        case 0: bv.eye[1] = NAN; break;
        case 1: bv.latency_ms = -5.0; break;
        case 2: be[0].box_max[0] = be[0].box_min[0]; break;
        case 3: be[0].id = 0; break;
        case 4: be[1].id = be[0].id; ne = 2; break;
        case 5: be[0].velocity[0] = INFINITY; break;
        case 6: bv.fov_deg = 0.0; break;
        case 7: ne = 3; break;
        case 8: be[0].box_min[2] = -1e300; break;
        case 9: bv.dir[0] = 1e-20; bv.dir[1] = bv.dir[2] = 0.0; break; /* eye + dir == eye */
        case 10: bv.fov_deg = 5e-44; break;                              /* a face's axes round to 0 */
        }
        vis_status s = vis_query_run(q, &bv, 1, be, ne, &st);
        assert_int_equal(s, cases[c].want);
        const char *msg = vis_context_last_error(ctx);
        if (!strstr(msg, cases[c].what))
            fail_msg("case %zu: message '%s' lacks '%s'", c, msg, cases[c].what);
        size_t after = 0;
        assert_int_equal(vis_query_entities(q, 0, NULL, 0, &after), VIS_OK);
        assert_int_equal(before, after);
    }
    assert_int_equal(vis_query_run(q, &v, 1, &e, 1, &st), VIS_OK);
    assert_int_equal(st.tick, 2);
    /* Output capacities and indices. */
    vis_query_hit one[1];
    size_t n = 0;
    assert_int_equal(vis_query_entities(q, 1, one, 1, &n), VIS_ERROR_NOT_FOUND);
    uint32_t small[1];
    size_t nc = 0;
    assert_int_equal(vis_query_chunks(q, 0, NULL, 0, &nc), VIS_OK);
    assert_true(nc >= 2);
    assert_int_equal(vis_query_chunks(q, 0, small, 1, &n), VIS_ERROR_CAPACITY);
    /* Capacities at creation. */
    vis_query *q2 = NULL;
    d.max_entities = VIS_QUERY_MAX_ENTITIES + 1;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q2), VIS_ERROR_INVALID_ARGUMENT);
    d.max_entities = 4;
    d.margin = NAN;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q2), VIS_ERROR_INVALID_ARGUMENT);
    assert_null(q2);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The chunk pass names what a vis_trace of the same camera and size names. */
static void test_chunks_match_trace(void **state)
{
    (void)state;
    uint64_t rng = 0x5eed0003;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    walls_world(&w, &rng, 24);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    random_viewer(&rng, 1, &v);
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q), VIS_OK);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, NULL), VIS_OK);
    uint32_t got[1024];
    size_t n = 0;
    assert_int_equal(vis_query_chunks(q, 0, got, 1024, &n), VIS_OK);
    vis_camera c;
    memset(&c, 0, sizeof c);
    memcpy(c.eye, v.eye, sizeof c.eye);
    for (int k = 0; k < 3; ++k)
        c.target[k] = v.eye[k] + v.dir[k];
    c.fovy_deg = v.fov_deg;
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = 32;
    uint32_t ids[32 * 32];
    assert_int_equal(vis_trace(ctx, scene, &c, &td, ids, 32 * 32, NULL, 0), VIS_OK);
    vis_draw_entry list[256];
    size_t m = 0;
    assert_int_equal(vis_drawlist_build(ctx, scene, ids, 32, 32, VIS_IDS_OBJECT, list, 256, &m), VIS_OK);
    assert_int_equal(n, m);
    for (size_t i = 0; i < n; ++i)
        assert_int_equal(got[i], list[i].id);
    vis_query_destroy(q);
    /* Every traversal method names the same chunks (docs/traversal.md, "Exactness"). */
    for (int t = VIS_TRAVERSAL_STACK; t <= VIS_TRAVERSAL_DDA; ++t) {
        vis_query_desc d;
        vis_query_desc_defaults(&d);
        d.chunk_traversal = (vis_traversal)t;
        assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
        assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, NULL), VIS_OK);
        uint32_t other[1024];
        size_t k = 0;
        assert_int_equal(vis_query_chunks(q, 0, other, 1024, &k), VIS_OK);
        assert_int_equal(k, n);
        assert_memory_equal(other, got, n * 4);
        vis_query_destroy(q);
    }
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The chunks a viewer's last pass named, and whether object `id` is among them. */
static int chunk_listed(vis_query *q, uint32_t viewer, uint32_t id, size_t *count)
{
    uint32_t got[6 * 32 * 32];
    size_t n = 0;
    assert_int_equal(vis_query_chunks(q, viewer, got, 6 * 32 * 32, &n), VIS_OK);
    if (count)
        *count = n;
    for (size_t i = 0; i < n; ++i)
        if (got[i] == id)
            return 1;
    return 0;
}

/* Chunk passes that run only when needed. With chunk_move, a viewer's pass runs when its eye
 * has left the cube of half-side chunk_move around its last pass's eye, or it turned, or the
 * scene was edited -- an edit opening a window shows on the next tick although the viewer
 * stood still. With the cadence (chunk_move 0), a due pass whose camera is unchanged is
 * skipped and its list kept, which is the list the pass would give. */
static void test_chunk_reuse(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    corner_world(&w);
    /* Object 3: a box behind the wall (x = 20), hidden from the eye until the window opens. */
    float blo[3] = {30, 2, 19}, bhi[3] = {32, 4, 21};
    obj_box(add_obj(&w, 3), blo, bhi);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_query_viewer v;
    vis_query_entity e;
    corner_setup(&v, &e);
    v.eye[2] = 20.0;
    v.fov_deg = 60.0;
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.chunk_move = 2.0;
    d.chunk_every = 1000; /* ignored with chunk_move */
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_stats st;
    size_t n0 = 0, n = 0;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1); /* a new viewer: at once */
    assert_int_equal(st.chunk_rays, 32 * 32);
    assert_true(chunk_listed(q, 0, 2, &n0));
    assert_false(chunk_listed(q, 0, 3, NULL));
    /* 1.5 voxels on x and z: inside the cube, no pass, the list kept. */
    v.eye[0] += 1.5;
    v.eye[2] -= 1.5;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    assert_int_equal(st.chunk_rays, 0);
    assert_true(chunk_listed(q, 0, 2, &n));
    assert_int_equal(n, n0);
    /* 2.5 voxels from the last pass's eye: a pass. */
    v.eye[0] += 1.0;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    /* A turn, a narrower view, all around: a pass each. */
    v.dir[2] = 0.25;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    v.fov_deg = 50.0;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    v.dir[0] = v.dir[2] = 0.0;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_rays, 6 * 32 * 32);
    v.fov_deg = 40.0; /* ignored all around */
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    assert_false(chunk_listed(q, 0, 3, NULL));
    /* Cut a window z in [18, 22), y in [2, 4) into the wall (as test_edit_opens_wall): the
     * viewer stands still, yet the next tick's list names the box behind it. */
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = 2;
    float parts[4][6] = {{20, 1, 0, 21, 10, 18}, {20, 1, 22, 21, 10, 40}, {20, 1, 18, 21, 2, 22}, {20, 4, 18, 21, 10, 22}};
    for (int i = 0; i < 4; ++i)
        obj_box(&o, parts[i], parts[i] + 3);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_edit_passes, 1);
    assert_true(chunk_listed(q, 0, 3, NULL));
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    assert_true(chunk_listed(q, 0, 3, NULL));
    vis_query_destroy(q);

    /* The cadence (chunk_move 0, every tick): a still viewer's due pass is skipped, a moved
     * one's runs, and the kept list equals what a fresh query traces from the same eye. */
    vis_query_desc_defaults(&d);
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    uint32_t kept[6 * 32 * 32], fresh[6 * 32 * 32];
    size_t nk = 0, nf = 0;
    assert_int_equal(vis_query_chunks(q, 0, kept, 6 * 32 * 32, &nk), VIS_OK);
    double y = v.eye[1];
    v.eye[1] += 1e-9;
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    v.eye[1] = y;
    vis_query *q2 = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q2), VIS_OK);
    assert_int_equal(vis_query_run(q2, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(vis_query_chunks(q2, 0, fresh, 6 * 32 * 32, &nf), VIS_OK);
    assert_int_equal(nk, nf);
    assert_memory_equal(kept, fresh, nk * 4);
    vis_query_destroy(q2);
    /* An edit retraces a still viewer on the cadence too: the box behind the window, removed,
     * leaves the list on the next tick. */
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1); /* back from the 1e-9 step */
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    assert_true(chunk_listed(q, 0, 3, NULL));
    assert_int_equal(vis_scene_remove_object(scene, 3), VIS_OK);
    assert_int_equal(vis_query_run(q, &v, 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_false(chunk_listed(q, 0, 3, NULL));
    vis_query_destroy(q);

    /* Bad values are refused at creation. */
    double bad_move[] = {NAN, -1.0, INFINITY, 1e6};
    for (size_t i = 0; i < sizeof bad_move / sizeof bad_move[0]; ++i) {
        vis_query_desc_defaults(&d);
        d.chunk_move = bad_move[i];
        q = NULL;
        assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_ERROR_INVALID_ARGUMENT);
        assert_non_null(strstr(vis_context_last_error(ctx), "chunk_move"));
        assert_null(q);
    }
    vis_query_desc_defaults(&d);
    d.chunk_traversal = (vis_traversal)99;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(ctx), "chunk_traversal"));
    assert_null(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- edits retrace only the passes they can change ----------------------------------- */

/* Viewer i's list of the last run equals what a fresh query traces for the same viewer now
 * (a still viewer: its last pass's camera). */
enum { LIST_CAP = 6 * 32 * 32 };

/* Viewer i's list in q, and a fresh query's list for camera v (one tick, the defaults). */
static void kept_and_fresh(vis_context *ctx, vis_scene *scene, vis_query *q, uint32_t i, const vis_query_viewer *v,
                           uint32_t *kept, size_t *nk, uint32_t *fresh, size_t *nf)
{
    assert_int_equal(vis_query_chunks(q, i, kept, LIST_CAP, nk), VIS_OK);
    vis_query *q2 = NULL;
    assert_int_equal(vis_query_create(ctx, scene, NULL, &q2), VIS_OK);
    assert_int_equal(vis_query_run(q2, v, 1, NULL, 0, NULL), VIS_OK);
    assert_int_equal(vis_query_chunks(q2, 0, fresh, LIST_CAP, nf), VIS_OK);
    vis_query_destroy(q2);
}

static void assert_list_fresh(vis_context *ctx, vis_scene *scene, vis_query *q, uint32_t i, const vis_query_viewer *v)
{
    static uint32_t kept[LIST_CAP], fresh[LIST_CAP];
    size_t nk = 0, nf = 0;
    kept_and_fresh(ctx, scene, q, i, v, kept, &nk, fresh, &nf);
    assert_int_equal(nk, nf);
    assert_memory_equal(kept, fresh, nk * 4);
}

static void set_box(vis_scene *scene, uint32_t id, const float lo[3], const float hi[3])
{
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = id;
    obj_box(&o, lo, hi);
    set_obj(scene, &o);
    obj_clear(&o);
}

/* An edit behind a wall, or behind an in-view viewer, retraces nobody that cannot see it (no
 * pass, no ray) and the kept lists are a fresh pass's; one in sight retraces that viewer and
 * its list names the new object on the next tick; more changed boxes than the scene's log
 * holds retrace everyone, and the log serves again after. Edits of one box, repeated, take one
 * entry of the log. */
static void test_edit_retraces_few(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    corner_world(&w);
    /* A scene origin away from 0: the edit test works in scene-local coordinates. */
    const double origin[3] = {-37.25, 5.0, 100.5};
    vis_scene *scene = make_scene(ctx, &w, origin, 0);
    vis_query_viewer v[2];
    vis_query_entity e;
    corner_setup(&v[0], &e);        /* in view, looking +x at the wall from z = 38 */
    corner_setup(&v[1], &e);
    v[1].id = 2;
    v[1].eye[2] = 30.0;
    v[1].dir[0] = 0.0;               /* all around */
    for (int i = 0; i < 2; ++i)
        for (int k = 0; k < 3; ++k)
            v[i].eye[k] += origin[k];
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.chunk_every = 100000; /* still viewers: only edits bring passes */
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 2);
    assert_int_equal(st.chunk_edit_passes, 0);

    /* Behind the wall (x = 20..21) for both: nobody traced. */
    float hid_lo[3] = {40, 2, 10}, hid_hi[3] = {42, 4, 12};
    set_box(scene, 10, hid_lo, hid_hi);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    assert_int_equal(st.chunk_rays, 0);
    for (uint32_t i = 0; i < 2; ++i) {
        assert_false(chunk_listed(q, i, 10, NULL));
        assert_list_fresh(ctx, scene, q, i, &v[i]);
    }
    /* Behind the in-view viewer, in the open for the all-around one: only the latter, and
     * only its two faces that look at the box (-x, and +z where the box's far corner passes
     * the 45-degree edge between them: it spans x -8..-6 and z 3..7 from the eye). */
    float back_lo[3] = {2, 1, 33}, back_hi[3] = {4, 4, 37};
    set_box(scene, 11, back_lo, back_hi);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_edit_passes, 1);
    assert_int_equal(st.chunk_rays, 2 * 32 * 32);
    assert_false(chunk_listed(q, 0, 11, NULL));
    assert_true(chunk_listed(q, 1, 11, NULL));
    for (uint32_t i = 0; i < 2; ++i)
        assert_list_fresh(ctx, scene, q, i, &v[i]);
    /* Removed again: the all-around viewer's list loses it on the next tick. */
    assert_int_equal(vis_scene_remove_object(scene, 11), VIS_OK);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_edit_passes, 1);
    assert_false(chunk_listed(q, 1, 11, NULL));
    /* The same hidden box set 200 times: one entry of the log, nobody traced. */
    for (int k = 0; k < 200; ++k)
        set_box(scene, 10, hid_lo, hid_hi);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    /* 70 hidden boxes, more than the log holds: everyone is traced (the log cannot tell), and
     * the lists are still a fresh pass's. */
    for (uint32_t k = 0; k < 70; ++k) {
        float lo[3] = {30.0f + (float)(k % 10) * 3.0f, 1.0f, 2.0f + (float)(k / 10) * 3.0f};
        float hi[3] = {lo[0] + 1.0f, 2.0f, lo[2] + 1.0f};
        set_box(scene, 100 + k, lo, hi);
    }
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 2);
    assert_int_equal(st.chunk_edit_passes, 2);
    for (uint32_t i = 0; i < 2; ++i)
        assert_list_fresh(ctx, scene, q, i, &v[i]);
    /* After it, one more hidden edit: the log serves again. */
    assert_int_equal(vis_scene_remove_object(scene, 100), VIS_OK);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 0);
    /* A hole through the wall in front of both: both traced, the box behind shows. */
    tobj o;
    memset(&o, 0, sizeof o);
    o.id = 2;
    float parts[4][6] = {{20, 1, 0, 21, 10, 21}, {20, 1, 27, 21, 10, 40}, {20, 1, 21, 21, 2, 27}, {20, 5, 21, 21, 10, 27}};
    for (int i = 0; i < 4; ++i)
        obj_box(&o, parts[i], parts[i] + 3);
    set_obj(scene, &o);
    obj_clear(&o);
    assert_int_equal(vis_query_run(q, v, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_edit_passes, 2);
    assert_true(chunk_listed(q, 1, 10, NULL));
    for (uint32_t i = 0; i < 2; ++i)
        assert_list_fresh(ctx, scene, q, i, &v[i]);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Whether every ID of viewer i's list is in a fresh pass's list from camera v: a list whose
 * faces are not all traced yet holds only IDs a full pass names. Returns the list's size. */
static size_t assert_list_within_fresh(vis_context *ctx, vis_scene *scene, vis_query *q, uint32_t i,
                                       const vis_query_viewer *v)
{
    static uint32_t kept[LIST_CAP], fresh[LIST_CAP];
    size_t nk = 0, nf = 0, j = 0;
    kept_and_fresh(ctx, scene, q, i, v, kept, &nk, fresh, &nf);
    for (size_t k = 0; k < nk; ++k) { /* both sorted */
        while (j < nf && fresh[j] < kept[k])
            ++j;
        assert_true(j < nf && fresh[j] == kept[k]);
    }
    return nk;
}

/* A box of half-side 0.25 `dist` voxels from the eye along one axis (sign: +1 or -1), centred
 * on the eye on the others: only the face looking that way sees it. */
static void box_beside(vis_scene *scene, uint32_t id, const double eye[3], int axis, float sign, float dist)
{
    float lo[3], hi[3];
    for (int k = 0; k < 3; ++k) {
        float c = (float)eye[k] + (k == axis ? sign * dist : 0.0f);
        lo[k] = c - 0.25f;
        hi[k] = c + 0.25f;
    }
    set_box(scene, id, lo, hi);
}

/* The chunk face budget: at most chunk_face_budget faces traced per tick; those left wait,
 * faces of viewers with no list first, then faces an edit reached, then the rest, the oldest
 * trace first, then input order, then face order; a face an edit reached stays due until
 * traced even when no edit comes on the later tick; a list holds only what a full pass names
 * while faces wait, and once every face is traced it is a fresh pass's. An edit retraces only
 * the faces it reaches. */
static void test_chunk_face_budget(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    uint64_t rng = 0x5eed0b0d;
    tworld w;
    walls_world(&w, &rng, 24);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    enum { NV = 5, RAYS = 32 * 32 };
    vis_query_viewer v[NV + 1];
    for (uint32_t i = 0; i < NV + 1; ++i) {
        random_viewer(&rng, i + 1, &v[i]);
        if (i % 2)
            memset(v[i].dir, 0, sizeof v[i].dir); /* all around: viewers 1, 3 and 5 */
    }
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.chunk_every = 100000; /* still viewers: passes only when new, edited or owed */
    d.chunk_face_budget = 4;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_stats st;
    size_t n = 0;
    /* 15 faces of five new viewers, four per tick in input and face order. Tick 1: viewer 0's
     * face and viewer 1's faces 0..2; viewer 1's list is partial, the others have none. */
    assert_int_equal(vis_query_run(q, v, NV, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 2);
    assert_int_equal(st.chunk_rays, 4 * RAYS);
    assert_int_equal(st.chunk_faces_deferred, 11);
    assert_list_fresh(ctx, scene, q, 0, &v[0]);
    assert_true(assert_list_within_fresh(ctx, scene, q, 1, &v[1]) > 0);
    for (uint32_t i = 2; i < NV; ++i) {
        assert_int_equal(vis_query_chunks(q, i, NULL, 0, &n), VIS_OK);
        assert_int_equal(n, 0);
    }
    /* Tick 2: viewer 1's last three faces and viewer 2's. */
    assert_int_equal(vis_query_run(q, v, NV, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 2);
    assert_int_equal(st.chunk_faces_deferred, 7);
    for (uint32_t i = 0; i < 3; ++i)
        assert_list_fresh(ctx, scene, q, i, &v[i]);
    /* Tick 3: a sixth viewer (all around) joins, listed first in the input. Every face left
     * is a new viewer's and none was traced, so the input order decides: the newcomer's faces
     * 0..3 go before those of viewers 3 and 4, which waited. */
    vis_query_viewer w6[NV + 1];
    w6[0] = v[NV];
    memcpy(w6 + 1, v, sizeof v[0] * NV);
    assert_int_equal(vis_query_run(q, w6, NV + 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_faces_deferred, 9);
    assert_true(assert_list_within_fresh(ctx, scene, q, 0, &w6[0]) > 0);
    for (int t = 0; t < 3; ++t)
        assert_int_equal(vis_query_run(q, w6, NV + 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_faces_deferred, 0);
    for (uint32_t i = 0; i < NV + 1; ++i)
        assert_list_fresh(ctx, scene, q, i, &w6[i]);
    /* A box beside each eye (seen by the all-around viewers at least): the reached faces are
     * traced at most four per tick, every viewer with a face traced counted as an edit's,
     * until each list is a fresh pass's again. */
    for (uint32_t i = 0; i < NV + 1; ++i)
        box_beside(scene, 500 + i, w6[i].eye, (int)(i % 3), w6[i].eye[i % 3] > 32.0 ? -1.0f : 1.0f, 1.5f);
    uint64_t rays = 0;
    for (int t = 0; t < 6; ++t) {
        assert_int_equal(vis_query_run(q, w6, NV + 1, NULL, 0, &st), VIS_OK);
        assert_true(st.chunk_rays <= 4 * RAYS);
        assert_int_equal(st.chunk_passes, st.chunk_edit_passes);
        rays += st.chunk_rays;
    }
    assert_int_equal(st.chunk_faces_deferred, 0);
    assert_true(rays >= 3 * RAYS); /* a face of each all-around viewer at least */
    for (uint32_t i = 0; i < NV + 1; ++i)
        assert_list_fresh(ctx, scene, q, i, &w6[i]);
    /* One more box, beside viewer 1 (all around) on its +x or -x side only: one face is
     * traced, not six. */
    box_beside(scene, 600, w6[2].eye, 0, w6[2].eye[0] > 32.0 ? -1.0f : 1.0f, 1.5f);
    assert_int_equal(vis_query_run(q, w6, NV + 1, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_rays, RAYS);
    assert_int_equal(st.chunk_edit_passes, 1);
    assert_true(chunk_listed(q, 2, 600, NULL));
    assert_list_fresh(ctx, scene, q, 2, &w6[2]);
    vis_query_destroy(q);

    /* Order among waiting faces, a budget of one all-around pass, passes when the eye moved
     * (chunk_move 1). Age: X and Y new (X traced on tick 1, Y on tick 2); both teleport on
     * tick 3, Y listed first: X, whose faces are older, is traced, Y waits. */
    d.chunk_every = 1;
    d.chunk_move = 1.0;
    d.chunk_face_budget = 6;
    vis_query_viewer x0 = v[1], y0 = v[3]; /* all around */
    vis_query_viewer x1 = x0, y1 = y0;
    x1.eye[0] = x0.eye[0] > 32.0 ? x0.eye[0] - 30.0 : x0.eye[0] + 30.0;
    y1.eye[2] = y0.eye[2] > 32.0 ? y0.eye[2] - 30.0 : y0.eye[2] + 30.0;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_viewer in2[2] = {x0, y0};
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK); /* X (input order) */
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK); /* Y, owed */
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_faces_deferred, 0);
    in2[0] = y1;
    in2[1] = x1;
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    assert_int_equal(st.chunk_faces_deferred, 6);
    assert_list_fresh(ctx, scene, q, 1, &x1); /* X traced from its new eye */
    assert_list_fresh(ctx, scene, q, 0, &y0); /* Y keeps the list from its old eye */
    vis_query_destroy(q);

    /* Reason: X traced on tick 1, Y on tick 2 (so X's faces are the older); on tick 3 X moves
     * (due by motion) and is listed first, and a box appears beside Y on one axis (an edit
     * that reaches one face of Y's pass): Y's face goes first and names the box, five of X's
     * faces follow, the sixth waits for tick 4. */
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    in2[0] = x0;
    in2[1] = y0;
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 1);
    box_beside(scene, 900, y0.eye, 1, y0.eye[1] > 6.0 ? -1.0f : 1.0f, 1.0f);
    in2[0] = x1;
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_passes, 2);
    assert_int_equal(st.chunk_edit_passes, 1);
    assert_int_equal(st.chunk_faces_deferred, 1);
    assert_true(chunk_listed(q, 1, 900, NULL));
    assert_list_fresh(ctx, scene, q, 1, &y0);
    assert_int_equal(vis_query_run(q, in2, 2, NULL, 0, &st), VIS_OK);
    assert_int_equal(st.chunk_rays, RAYS);
    assert_int_equal(st.chunk_faces_deferred, 0);
    assert_list_fresh(ctx, scene, q, 0, &x1);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Random walls, still viewers (in view and all around) and random edits (boxes added, moved,
 * removed; walls cut lower): after every tick each viewer's list is a fresh pass's, some
 * viewers are spared and some traced. */
static void test_edit_retrace_random(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    uint64_t rng = 0x5eed0011;
    tworld w;
    walls_world(&w, &rng, 24);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    enum { NV = 8, ROUNDS = 16 };
    vis_query_viewer v[NV];
    for (uint32_t i = 0; i < NV; ++i) {
        random_viewer(&rng, 1 + i, &v[i]);
        if (i % 2)
            v[i].dir[0] = v[i].dir[2] = 0.0;
    }
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.chunk_every = 100000;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    vis_query_stats st;
    assert_int_equal(vis_query_run(q, v, NV, NULL, 0, &st), VIS_OK);
    uint32_t traced = 0;
    for (int r = 0; r < ROUNDS; ++r) {
        uint32_t kind = (uint32_t)(vt_rand(&rng) % 3);
        if (kind == 0 || r < 4) { /* a small box, new or moved */
            float lo[3] = {1.0f + (float)(vt_rand(&rng) % 60), 1.0f + (float)(vt_rand(&rng) % 4),
                           1.0f + (float)(vt_rand(&rng) % 60)};
            float hi[3] = {lo[0] + 1.0f + (float)(vt_rand(&rng) % 2), lo[1] + 1.0f, lo[2] + 1.0f};
            set_box(scene, 200u + (uint32_t)(vt_rand(&rng) % 4), lo, hi);
        } else if (kind == 1) { /* a box removed, when there is one */
            uint32_t id = 200u + (uint32_t)(vt_rand(&rng) % 4);
            vis_status rs = vis_scene_remove_object(scene, id);
            assert_true(rs == VIS_OK || rs == VIS_ERROR_NOT_FOUND);
        } else { /* a wall cut down to 2 voxels */
            uint32_t k = (uint32_t)(vt_rand(&rng) % 24);
            const tobj *o = &w.objs[1 + k];
            float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
            for (uint32_t n = 0; n < o->nq; ++n) { /* the wall's box, from its quads */
                const vis_quad *qd = &o->quads[n];
                uint32_t a = qd->axis, u = (a + 1) % 3, vv = (a + 2) % 3;
                lo[a] = fminf(lo[a], qd->plane);
                hi[a] = fmaxf(hi[a], qd->plane);
                lo[u] = fminf(lo[u], qd->u0);
                hi[u] = fmaxf(hi[u], qd->u1);
                lo[vv] = fminf(lo[vv], qd->v0);
                hi[vv] = fmaxf(hi[vv], qd->v1);
            }
            hi[1] = 2.0f;
            set_box(scene, o->id, lo, hi);
        }
        assert_int_equal(vis_query_run(q, v, NV, NULL, 0, &st), VIS_OK);
        assert_int_equal(st.chunk_passes, st.chunk_edit_passes);
        traced += st.chunk_edit_passes;
        for (uint32_t i = 0; i < NV; ++i)
            assert_list_fresh(ctx, scene, q, i, &v[i]);
    }
    print_message("edits traced %u of %u viewer passes\n", traced, ROUNDS * NV);
    assert_true(traced > 0);
    assert_true(traced < ROUNDS * NV / 2);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* A counting allocator: after the first tick (the backend's copy of the scene, the pools'
 * growth), a tick allocates nothing. */
static size_t alloc_calls;
static void *count_alloc(size_t size, size_t align, void *user)
{
    (void)user;
    ++alloc_calls;
    size_t al = align < sizeof(void *) ? sizeof(void *) : align;
    return aligned_alloc(al, (size + al - 1) / al * al);
}
static void count_free(void *p, void *user)
{
    (void)user;
    free(p);
}

static void test_no_allocation_per_tick(void **state)
{
    (void)state;
    vis_allocator a = {count_alloc, count_free, NULL};
    vis_context *ctx = NULL;
    assert_int_equal(cpu_ctx_create(2, &a, &ctx), VIS_OK);
    uint64_t rng = 0x5eed0004;
    tworld w;
    walls_world(&w, &rng, 24);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    enum { NV = 6, NE = 12 };
    vis_query_viewer vw[NV];
    vis_query_entity en[NE];
    for (uint32_t i = 0; i < NV; ++i)
        random_viewer(&rng, 1 + i, &vw[i]);
    for (uint32_t j = 0; j < NE; ++j)
        random_entity(&rng, 100 + j, &en[j]);
    vis_query_desc d;
    vis_query_desc_defaults(&d);
    d.threads = 2;
    vis_query *q = NULL;
    assert_int_equal(vis_query_create(ctx, scene, &d, &q), VIS_OK);
    assert_int_equal(vis_query_run(q, vw, NV, en, NE, NULL), VIS_OK);
    size_t before = alloc_calls;
    for (int t = 0; t < 5; ++t) {
        for (uint32_t j = 0; j < NE; ++j) {
            en[j].box_min[2] += 0.1;
            en[j].box_max[2] += 0.1;
        }
        vw[t % NV].eye[0] += 0.5;
        assert_int_equal(vis_query_run(q, vw, NV, en, NE, NULL), VIS_OK);
    }
    assert_int_equal(alloc_calls, before);
    vis_query_destroy(q);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- `vis query`: simulate, replay, and hostile replays ----------------------------------- */

#define VIS_EXE VIS_BINARY_DIR "/tools/vis"
#define MAZE "gen:maze:size=64x32x64:seed=3"

static char qdir[256];

static const char *qpath(const char *name)
{
    static char paths[4][512];
    static int next;
    char *p = paths[next++ % 4];
    snprintf(p, 512, "%s/%s", qdir, name);
    return p;
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

/* 1 when this build's `vis query` works (it needs Jansson); else the test is skipped after
 * checking that the command says why. */
static int have_query(void)
{
    vt_run_result r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s", MAZE, qpath("none.jsonl"));
    int have = !strstr(r.err, "no Jansson");
    if (!have)
        vt_assert_exit(r, 2);
    vt_run_free(&r);
    return have;
}

static void test_cli_simulate_replay(void **state)
{
    (void)state;
    if (!have_query())
        skip();
    vt_run_result r = vt_run(VIS_EXE, qdir, NULL, "query --simulate 6 --ticks 48 --edit-every 16 --scene %s --out %s",
                             MAZE, qpath("maze.jsonl"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    char *text = vt_slurp(qpath("maze.jsonl"));
    size_t lines = 0;
    for (const char *c = text; *c; ++c)
        lines += *c == '\n';
    assert_int_equal(lines, 49); /* header + 48 ticks */
    assert_non_null(strstr(text, "\"edits\":[["));
    free(text);
    /* --unsettled-ticks reaches the library: with a pair limit of 2 some proofs run out, and
     * waiting 4 ticks before proving them again spends fewer entity rays than every tick. */
    double rays[2];
    for (int i = 0; i < 2; ++i) {
        r = vt_run(VIS_EXE, qdir, NULL,
                   "query --scene %s --replay %s --chunk-move 1 --chunk-traversal ropes --pair-limit 2 "
                   "--unsettled-ticks %d --json",
                   MAZE, qpath("maze.jsonl"), i ? 4 : 1);
        vt_assert_exit(r, 0);
        assert_non_null(strstr(r.out, "\"mean\":"));
        const char *k = strstr(r.out, "\"rays_per_tick\":");
        assert_non_null(k);
        rays[i] = strtod(k + strlen("\"rays_per_tick\":"), NULL);
        vt_run_free(&r);
    }
    assert_true(rays[1] < rays[0]);
    /* --solid reaches the library: the maze's solid walls are asked about by default, and
     * never with --solid off. */
    for (int off = 0; off < 2; ++off) {
        r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --json%s", MAZE, qpath("maze.jsonl"),
                   off ? " --solid off" : "");
        vt_assert_exit(r, 0);
        const char *k = strstr(r.out, "\"solid_tests_per_tick\":");
        assert_non_null(k);
        double tests = strtod(k + strlen("\"solid_tests_per_tick\":"), NULL);
        if (off ? tests != 0.0 : !(tests > 0.0))
            fail_msg("--solid %s: %g solid tests per tick", off ? "off" : "on", tests);
        vt_run_free(&r);
    }
    /* --chunk-face-budget reaches the library: one face per tick at most, the rest waiting. */
    r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --json --chunk-face-budget 1", MAZE,
               qpath("maze.jsonl"));
    vt_assert_exit(r, 0);
    const char *cr = strstr(r.out, "\"chunk_rays_per_tick\":"), *fd = strstr(r.out, "\"chunk_faces_deferred\":");
    assert_non_null(cr);
    assert_non_null(fd);
    double crays = strtod(cr + strlen("\"chunk_rays_per_tick\":"), NULL);
    double waited = strtod(fd + strlen("\"chunk_faces_deferred\":"), NULL);
    if (!(crays > 0.0 && crays <= 32.0 * 32.0 && waited > 0.0))
        fail_msg("--chunk-face-budget 1: %g chunk rays per tick, %g face-ticks waiting", crays, waited);
    vt_run_free(&r);
    r = vt_run(VIS_EXE, qdir, NULL,
               "query --scene %s --replay %s --compare --truth-every 8 --truth-res 128 --json --out %s", MAZE,
               qpath("maze.jsonl"), qpath("out.jsonl"));
    vt_assert_exit(r, 0);
    const char *lib = strstr(r.out, "\"libvis\":");
    assert_non_null(lib);
    assert_non_null(strstr(lib, "\"hidden_while_visible\":0,"));
    assert_non_null(strstr(r.out, "\"smac\":"));
    assert_non_null(strstr(r.out, "\"luanti\":"));
    vt_run_free(&r);
    text = vt_slurp(qpath("out.jsonl"));
    lines = 0;
    for (const char *c = text; *c; ++c)
        lines += *c == '\n';
    assert_int_equal(lines, 48);
    free(text);
}

/* The text of a --out file with every tick's "ms" field removed (the only field a backend
 * may change). */
static char *without_times(const char *path)
{
    char *text = vt_slurp(path);
    char *w = text;
    for (const char *r = text; *r;) {
        if (!strncmp(r, "\"ms\":", 5)) {
            r += 5;
            while (*r && *r != ',')
                ++r;
            r += *r == ',';
            continue;
        }
        *w++ = *r++;
    }
    *w = '\0';
    return text;
}

/* `vis query --backend opencl` traces the chunk passes on the OpenCL device: the same lines as
 * on the CPU, times aside; skipped where no OpenCL device opens (the command then says so). */
static void test_cli_backends(void **state)
{
    (void)state;
    if (!have_query())
        skip();
    vt_run_result r = vt_run(VIS_EXE, qdir, NULL, "query --simulate 5 --ticks 24 --edit-every 8 --scene %s --out %s",
                             MAZE, qpath("maze_b.jsonl"));
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --backend cpu --json --out %s", MAZE,
               qpath("maze_b.jsonl"), qpath("cpu.jsonl"));
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "\"backend\":\"cpu\""));
    vt_run_free(&r);
    r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --backend opencl --json --out %s", MAZE,
               qpath("maze_b.jsonl"), qpath("cl.jsonl"));
    if (r.code != 0 && strstr(r.err, "cannot create an OpenCL context")) { /* any other failure fails */
        print_message("no OpenCL device (%s): skipped\n", r.err);
        vt_run_free(&r);
        skip();
    }
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "\"backend\":\"opencl\""));
    vt_run_free(&r);
    char *a = without_times(qpath("cpu.jsonl")), *b = without_times(qpath("cl.jsonl"));
    assert_non_null(strstr(a, "\"chunks\":[")); /* lists were written */
    assert_string_equal(a, b);
    free(a);
    free(b);
    r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --backend gpu", MAZE, qpath("maze_b.jsonl"));
    vt_assert_exit(r, 2);
    vt_run_free(&r);
}

static void test_cli_hostile_replay(void **state)
{
    (void)state;
    if (!have_query())
        skip();
    const char *good_v = "{\"id\":1,\"eye\":[10,5,10],\"latency_ms\":50}";
    const char *good_e = "{\"id\":2,\"min\":[20,1,20],\"max\":[21,3,21]}";
    char line[1024];
    struct {
        const char *name, *body, *want;
    } cases[] = {
        {"nan", "{\"tick\":0,\"viewers\":[{\"id\":1,\"eye\":[NaN,5,10]}]}\n", "line 1"},
        {"overflow", "{\"tick\":0,\"viewers\":[{\"id\":1,\"eye\":[1e999,5,10]}]}\n", "line 1"},
        {"far", "{\"tick\":0,\"viewers\":[{\"id\":1,\"eye\":[1e300,5,10]}]}\n", "'eye'[0]"},
        {"id0", "{\"tick\":0,\"viewers\":[{\"id\":0,\"eye\":[1,5,10]}]}\n", "'id'"},
        {"idbig", "{\"tick\":0,\"viewers\":[{\"id\":1099511627776,\"eye\":[1,5,10]}]}\n", "'id'"},
        {"idfloat", "{\"tick\":0,\"viewers\":[{\"id\":1.5,\"eye\":[1,5,10]}]}\n", "'id'"},
        {"latency", "{\"tick\":0,\"viewers\":[{\"id\":1,\"eye\":[1,5,10],\"latency_ms\":-5}]}\n", "'latency_ms'"},
        {"emptybox", "{\"tick\":0,\"viewers\":[],\"entities\":[{\"id\":2,\"min\":[1,1,1],\"max\":[1,2,2]}]}\n", "min < max"},
        {"dupkey", "{\"tick\":0,\"tick\":1,\"viewers\":[]}\n", "line 1"},
        {"dupid", NULL, "appears twice"},
        {"truncated", NULL, "cut short"},
        {"toomany", NULL, "at most 2"},
        {"edit", "{\"tick\":0,\"viewers\":[],\"edits\":[[1,2,99999999,0]]}\n", "outside the world"},
        {"notobject", "[1,2,3]\n", "JSON object"},
        {"vec2", "{\"tick\":0,\"viewers\":[{\"id\":1,\"eye\":[1,5]}]}\n", "array of 3"},
        {"tickms", "{\"replay\":\"libvis-query\",\"version\":1,\"tick_ms\":1e-9}\n", "'tick_ms'"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; ++c) {
        const char *body = cases[c].body;
        if (!strcmp(cases[c].name, "dupid")) {
            snprintf(line, sizeof line, "{\"tick\":0,\"viewers\":[%s],\"entities\":[%s,%s]}\n", good_v, good_e, good_e);
            body = line;
        } else if (!strcmp(cases[c].name, "truncated")) {
            snprintf(line, sizeof line, "{\"tick\":0,\"viewers\":[%s],\"entities\":[%s]}\n{\"tick\":1,\"viewers\":[%s",
                     good_v, good_e, good_v);
            body = line;
        } else if (!strcmp(cases[c].name, "toomany")) {
            snprintf(line, sizeof line, "{\"tick\":0,\"viewers\":[%s,%s,%s]}\n", good_v, good_v, good_v);
            body = line;
        }
        write_text(qpath("bad.jsonl"), body);
        vt_run_result r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --max-viewers 2 --out %s", MAZE,
                                 qpath("bad.jsonl"), qpath("bad_out.jsonl"));
        if (r.code != 1 || !strstr(r.err, cases[c].want))
            fail_msg("case %s: exit %d, stderr '%s' (wanted exit 1 and '%s')", cases[c].name, r.code, r.err,
                     cases[c].want);
        vt_run_free(&r);
        FILE *f = fopen(qpath("bad_out.jsonl"), "rb"); /* a failed run leaves no output */
        assert_null(f);
    }
    /* A replay that cannot be read (a directory) is an error, not an empty replay. */
    vt_run_result rd = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s", MAZE, qdir);
    vt_assert_exit(rd, 1);
    assert_non_null(strstr(rd.err, "read error"));
    vt_run_free(&rd);
    /* Blank lines before the header are allowed; a second header is not. */
    write_text(qpath("blank.jsonl"),
               "\n{\"replay\":\"libvis-query\",\"version\":1}\n{\"tick\":0,\"viewers\":[]}\n");
    rd = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s", MAZE, qpath("blank.jsonl"));
    vt_assert_exit(rd, 0);
    vt_run_free(&rd);
    write_text(qpath("twice.jsonl"),
               "{\"replay\":\"libvis-query\",\"version\":1}\n{\"replay\":\"libvis-query\",\"version\":1}\n");
    rd = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s", MAZE, qpath("twice.jsonl"));
    vt_assert_exit(rd, 1);
    assert_non_null(strstr(rd.err, "first line"));
    vt_run_free(&rd);
    /* The summary stays JSON whatever the replay's name holds. */
    write_text(qpath("q\"uote.jsonl"), "{\"tick\":0,\"viewers\":[]}\n");
    rd = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay '%s' --json", MAZE, qpath("q\"uote.jsonl"));
    vt_assert_exit(rd, 0);
    assert_non_null(strstr(rd.out, "q\\\"uote.jsonl\""));
    vt_run_free(&rd);
    /* A line over the length budget is refused without being parsed. */
    FILE *f = fopen(qpath("long.jsonl"), "wb");
    assert_non_null(f);
    fputs("{\"tick\":0,\"viewers\":[],\"pad\":\"", f);
    for (int i = 0; i < (5 << 20) / 64; ++i)
        fputs("0123456789012345678901234567890123456789012345678901234567890123", f);
    fputs("\"}\n", f);
    fclose(f);
    vt_run_result r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s", MAZE, qpath("long.jsonl"));
    vt_assert_exit(r, 1);
    assert_non_null(strstr(r.err, "longer than"));
    vt_run_free(&r);
    /* Bad options are usage errors. */
    r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s --threads 0", MAZE, qpath("long.jsonl"));
    vt_assert_exit(r, 2);
    vt_run_free(&r);
    const char *bad_opts[] = {"--chunk-move -1", "--chunk-move nan", "--chunk-move 1e6", "--chunk-traversal shortstack:3",
                              "--chunk-traversal warp", "--chunk-traversal", "--chunks", "--unsettled-ticks 0",
                              "--unsettled-ticks 1025", "--unsettled-ticks", "--solid maybe", "--solid",
                              "--chunk-face-budget -1", "--chunk-face-budget 24577", "--chunk-face-budget"};
    for (size_t i = 0; i < sizeof bad_opts / sizeof bad_opts[0]; ++i) {
        r = vt_run(VIS_EXE, qdir, NULL, "query --scene %s --replay %s %s", MAZE, qpath("long.jsonl"), bad_opts[i]);
        vt_assert_exit(r, 2);
        vt_run_free(&r);
    }
}

static int cli_setup(void **state)
{
    return vt_run_setup(state, qdir, sizeof qdir, "vis_query", VIS_EXE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_never_hides_visible), cmocka_unit_test(test_latency_peek),
        cmocka_unit_test(test_solid_ground),         cmocka_unit_test(test_solid_edit_tunnel),
        cmocka_unit_test(test_edit_opens_wall),     cmocka_unit_test(test_hold),
        cmocka_unit_test(test_slack_cache),        cmocka_unit_test(test_proofs_spread),
        cmocka_unit_test(test_edit_off_the_segment), cmocka_unit_test(test_unsettled_wait),
        cmocka_unit_test(test_threads_deterministic), cmocka_unit_test(test_budget),
        cmocka_unit_test(test_budget_shared),
        cmocka_unit_test(test_budget_rounds_and_caps),
        cmocka_unit_test(test_bad_input),           cmocka_unit_test(test_chunks_match_trace),
        cmocka_unit_test(test_chunk_reuse),
        cmocka_unit_test(test_edit_retraces_few),
        cmocka_unit_test(test_chunk_face_budget), cmocka_unit_test(test_edit_retrace_random),
        cmocka_unit_test(test_no_allocation_per_tick), cmocka_unit_test(test_backends_deterministic),
    };
    const struct CMUnitTest cli_tests[] = {
        cmocka_unit_test(test_cli_simulate_replay),
        cmocka_unit_test(test_cli_hostile_replay),
        cmocka_unit_test(test_cli_backends),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    FILE *exe = fopen(VIS_EXE, "rb");
    if (!exe) { /* a build without the tools (the TSan one): the library tests only */
        print_message("%s is not built: the vis query tests are skipped\n", VIS_EXE);
        return failed;
    }
    fclose(exe);
    return failed | cmocka_run_group_tests_name("vis query", cli_tests, cli_setup, vt_tmp_dir_teardown);
}
