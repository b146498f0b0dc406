/* test_traversal.c — the traversal methods (restart, pushdown, short stack, ropes, ropes +
 * short stack; Chang & Ihm 2010) against the stack method and an independent brute force.
 *
 * Every method must give the very same ID and depth buffers as `stack` and as the oracle (a
 * loop over every primitive as the caller handed it to the scene, no tree): on random worlds
 * of several shapes and kd depths (also shallow trees and sizes that are not powers of two,
 * whose leaves lie at different depths), on the hard cases of DESIGN.md, after edits, in leaf
 * ID mode, and ray by ray on rays built to be degenerate: starting on split planes and chunk
 * corners, lying in split planes, running along axes and exact diagonals through cell corners,
 * ending exactly on a split plane, and aimed exactly at chunk edges and corners; those rays
 * are also held, ray by ray, to the double-precision reference of tests/support/ref_trace.c
 * under the conservative rule (docs/traversal.md, "Exactness"). The ropes themselves are
 * checked against their definition (Popov et al. 2007): each link points to the smallest
 * node, no deeper than its own, that covers the face; VIS_NO_ROPE exactly on the scene
 * boundary. The scene builds them for the first pass that walks them; the tests that call
 * the rope methods directly build them first (vis_kdtree_build_ropes). */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

/* The cell-grid walk reports the cells it visits (test_dda_visits_every_passing_cell). */
static unsigned char *g_dda_seen;
static uint32_t g_dda_base; /* the scene's cell_map */
#define VIS_DDA_VISIT(entry) (g_dda_seen ? (void)++g_dda_seen[(entry)-g_dda_base] : (void)0)
#include "common/trace_core.h"
#include "camera.h"
#include "cpu/labels.h"
#include "cpu/occupancy.h"
#include "kdtree.h"
#include "scene.h"
#include "ref_trace.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

/* ---- the methods under test ------------------------------------------------------------ */

typedef struct method {
    vis_traversal traversal;
    uint32_t n;
    const char *name;
} method;

static const method methods[] = {
    {VIS_TRAVERSAL_RESTART, 0, "restart"},
    {VIS_TRAVERSAL_PUSHDOWN, 0, "pushdown"},
    {VIS_TRAVERSAL_SHORTSTACK, 1, "shortstack:1"},
    {VIS_TRAVERSAL_SHORTSTACK, 2, "shortstack:2"},
    {VIS_TRAVERSAL_SHORTSTACK, 3, "shortstack:3"},
    {VIS_TRAVERSAL_SHORTSTACK, 4, "shortstack:4"},
    {VIS_TRAVERSAL_SHORTSTACK, 8, "shortstack:8"},
    {VIS_TRAVERSAL_ROPES, 0, "ropes"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 1, "ropes-shortstack:1"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 2, "ropes-shortstack:2"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 3, "ropes-shortstack:3"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 4, "ropes-shortstack:4"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 8, "ropes-shortstack:8"},
    {VIS_TRAVERSAL_ROPES_SHORTSTACK, 16, "ropes-shortstack:16"},
    {VIS_TRAVERSAL_PACKET, 0, "packet"},
    {VIS_TRAVERSAL_CACHED_STACK, 1, "cached-stack:1"},
    {VIS_TRAVERSAL_CACHED_STACK, 2, "cached-stack:2"},
    {VIS_TRAVERSAL_CACHED_STACK, 3, "cached-stack:3"},
    {VIS_TRAVERSAL_CACHED_STACK, 7, "cached-stack:7"},
    {VIS_TRAVERSAL_CACHED_STACK, 16, "cached-stack:16"},
    {VIS_TRAVERSAL_DDA, 0, "dda"},
};
#define METHOD_COUNT (sizeof methods / sizeof methods[0])

/* ---- a test world: objects kept by the test for the oracle ------------------------------ */


/* Chunk objects of voxel boxes (some touching the chunk boundary, some with a face exactly on
 * it, on any axis and side), pairs of identical boxes under two IDs (ties), and entities of
 * triangles, off-grid quads and off-grid boxes that straddle leaves. */
static const chunk_world_opts edgy_world = {0.35, 5, 0.2, 1, 3, 1};

/* Full-chunk cubes in a 3D checkerboard: every chunk edge and corner is shared by filled and
 * empty chunks, so rays through them touch cube faces exactly where they cross several split
 * planes at once (the stack method's empty-interval leaves). */
static void checker_world(tworld *w, int nx, int ny, int nz)
{
    chunk_world_init(w, nx, ny, nz);
    for (int cz = 0; cz < nz; ++cz)
        for (int cy = 0; cy < ny; ++cy)
            for (int cx = 0; cx < nx; ++cx) {
                if ((cx + cy + cz) % 2 == 0)
                    continue;
                float lo[3] = {16.0f * cx, 16.0f * cy, 16.0f * cz};
                float hi[3] = {lo[0] + 16.0f, lo[1] + 16.0f, lo[2] + 16.0f};
                obj_box(add_obj(w, 1u + (uint32_t)(cx + nx * (cy + ny * cz))), lo, hi);
            }
}

/* ---- the oracle ----------------------------------------------------------------------- */

static void oracle_ray(const tworld *w, const vis_ray *r, float *t_out, uint32_t *id_out)
{
    float best = INFINITY;
    uint32_t bid = 0;
    for (uint32_t i = 0; i < w->n; ++i) {
        const tobj *o = &w->objs[i];
        for (uint32_t k = 0; k < o->nq + o->nt; ++k) {
            float t;
            int hit;
            if (k < o->nq) {
                const vis_quad *q = &o->quads[k];
                hit = vis_quad_intersect(r, q->axis, q->plane, q->u0, q->v0, q->u1, q->v1, &t);
            } else {
                const vis_triangle *tr = &o->tris[k - o->nq];
                hit = vis_triangle_intersect(r, tr->v[0], tr->v[1], tr->v[2], &t);
            }
            if (!hit || !(t >= r->t_near) || t > r->t_far)
                continue;
            if (t < best || (t == best && o->id < bid)) {
                best = t;
                bid = o->id;
            }
        }
    }
    *t_out = best;
    *id_out = bid;
}

/* ---- buffers: every method == stack == oracle ------------------------------------------- */

static void trace_or_fail(vis_context *ctx, vis_scene *scene, const vis_camera *cam, const vis_trace_desc *td,
                          uint32_t *ids, float *depth, const char *what, const char *name)
{
    size_t n = (size_t)td->width * td->height;
    if (vis_trace(ctx, scene, cam, td, ids, n, depth, n) != VIS_OK)
        fail_msg("%s, %s: %s", what, name, vis_context_last_error(ctx));
}

static void check_view_ids(vis_context *ctx, vis_scene *scene, const tworld *w, const vis_camera *cam, uint32_t W,
                           uint32_t H, vis_id_mode ids_mode, const char *what)
{
    size_t n = (size_t)W * H;
    uint32_t *ref_ids = malloc(n * 4), *ids = malloc(n * 4), *or_ids = malloc(n * 4);
    float *ref_depth = malloc(n * 4), *depth = malloc(n * 4), *or_depth = malloc(n * 4);
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = W;
    td.height = H;
    td.ids = ids_mode;
    td.traversal = VIS_TRAVERSAL_STACK;
    trace_or_fail(ctx, scene, cam, &td, ref_ids, ref_depth, what, "stack");

    if (ids_mode == VIS_IDS_OBJECT) {
        vis_scene_info info;
        vis_scene_get_info(scene, &info);
        vis_camera_frame fr;
        assert_int_equal(vis_camera_frame_make(ctx, cam, info.origin, W, H, &fr), VIS_OK);
        vis_ray_setup s;
        vis_camera_frame_ray_setup(&fr, &s);
        for (uint32_t y = 0; y < H; ++y)
            for (uint32_t x = 0; x < W; ++x) {
                vis_ray r;
                vis_ray_for_pixel(&s, x, y, &r);
                float t;
                uint32_t id;
                oracle_ray(w, &r, &t, &id);
                size_t i = (size_t)y * W + x;
                or_ids[i] = id;
                or_depth[i] = t;
                if (ref_ids[i] != id || memcmp(&ref_depth[i], &t, 4) != 0)
                    fail_msg("%s: pixel (%u,%u): stack id %u t %.9g, oracle id %u t %.9g", what, x, y, ref_ids[i],
                             (double)ref_depth[i], id, (double)t);
            }
    }
    for (size_t m = 0; m < METHOD_COUNT; ++m) {
        td.traversal = methods[m].traversal;
        td.short_stack = methods[m].n;
        memset(ids, 0xEE, n * 4);
        trace_or_fail(ctx, scene, cam, &td, ids, depth, what, methods[m].name);
        /* Packets are held to the oracle directly (they equal it, as `stack` does). */
        int to_oracle = methods[m].traversal == VIS_TRAVERSAL_PACKET && ids_mode == VIS_IDS_OBJECT;
        const uint32_t *want_ids = to_oracle ? or_ids : ref_ids;
        const float *want_depth = to_oracle ? or_depth : ref_depth;
        for (size_t i = 0; i < n; ++i)
            if (ids[i] != want_ids[i] || memcmp(&depth[i], &want_depth[i], 4) != 0)
                fail_msg("%s, %s: pixel (%zu,%zu): id %u t %.9g, %s id %u t %.9g", what, methods[m].name, i % W,
                         i / W, ids[i], (double)depth[i], to_oracle ? "oracle" : "stack (= oracle)", want_ids[i],
                         (double)want_depth[i]);
    }
    free(ref_ids), free(ids), free(or_ids), free(ref_depth), free(depth), free(or_depth);
}

/* As asked (on these small images each ray is a packet of its own), and narrowed to 12
 * degrees at 64x56, where 16x16 packets share one walk (backends/cpu/packet.c). */
static void check_view(vis_context *ctx, vis_scene *scene, const tworld *w, const vis_camera *cam, uint32_t W,
                       uint32_t H, const char *what)
{
    check_view_ids(ctx, scene, w, cam, W, H, VIS_IDS_OBJECT, what);
    vis_camera narrow = *cam;
    narrow.fovy_deg = 12.0;
    char label[192];
    snprintf(label, sizeof label, "%s, narrowed to 16x16 packets", what);
    check_view_ids(ctx, scene, w, &narrow, 64, 56, VIS_IDS_OBJECT, label);
}

/* Eyes on split planes, chunk corners and voxel planes, targets on integers, views along
 * axes and exact diagonals, sometimes a far plane (scene_builder.h). */
static const view_opts edgy_view = {0.25, 0.4, 0.3, 0.15, 0.3, 0.25};

static void test_random_worlds(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    uint64_t rng = 20100601;
    /* Shapes in chunks: powers of two (every leaf at one depth) and not (leaves at several
     * depths, ropes-shortstack regions of mixed height). */
    static const int shapes[][3] = {{4, 2, 4}, {3, 2, 3}, {5, 3, 2}, {2, 2, 2}, {8, 1, 4}, {3, 3, 3}};
    static const uint32_t depths[] = {0, 1, 2, 3, 5};
    int rounds = vt_small() ? 4 : 12, cams = vt_small() ? 3 : 6;
    for (int wi = 0; wi < rounds; ++wi) {
        const int *sh = shapes[wi % 6];
        tworld w;
        random_chunk_world_opts(&w, &rng, sh[0], sh[1], sh[2], &edgy_world);
        uint32_t depth = depths[wi % 5];
        vis_scene *scene = make_scene(ctx, &w, NULL, depth);
        const double zero[3] = {0, 0, 0};
        for (int ci = 0; ci < cams; ++ci) {
            vis_camera cam;
            random_view_opts(&cam, &rng, w.size, zero, &edgy_view);
            char what[96];
            snprintf(what, sizeof what, "world %d (%dx%dx%d chunks, kd_depth %u), camera %d", wi, sh[0], sh[1], sh[2],
                     depth, ci);
            check_view(ctx, scene, &w, &cam, ci & 1 ? 41 : 40, ci & 1 ? 33 : 32, what);
        }
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* A box of 1 to 7 units a side somewhere in the world (an edit's new shape). */
static void small_box(const tworld *w, uint64_t *rng, float lo[3], float hi[3])
{
    for (int a = 0; a < 3; ++a) {
        lo[a] = (float)(vt_rand(rng) % (uint64_t)(w->size[a] - 8));
        hi[a] = lo[a] + 1.0f + (float)(vt_rand(rng) % 7);
    }
}

/* Edits between passes: the tree and its ropes stay, leaf contents change. */
static void test_edits_between_passes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    uint64_t rng = 77;
    tworld w;
    random_chunk_world_opts(&w, &rng, 4, 2, 3, &edgy_world);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    assert_int_equal(vis_kdtree_build_ropes(scene, ctx), VIS_OK); /* as the first ropes pass does */
    vis_scene_stats before;
    assert_int_equal(vis_scene_get_stats(scene, &before), VIS_OK);
    const double zero[3] = {0, 0, 0};
    int rounds = vt_small() ? 3 : 8;
    for (int e = 0; e < rounds; ++e) {
        /* remove a few, change a few, add one straddling leaves */
        for (int k = 0; k < 3 && w.n > 1; ++k) {
            uint32_t i = (uint32_t)(vt_rand(&rng) % w.n);
            assert_int_equal(vis_scene_remove_object(scene, w.objs[i].id), VIS_OK);
            obj_clear(&w.objs[i]);
            w.objs[i] = w.objs[--w.n];
        }
        for (int k = 0; k < 3 && w.n > 0; ++k) {
            tobj *o = &w.objs[vt_rand(&rng) % w.n];
            float lo[3], hi[3];
            small_box(&w, &rng, lo, hi);
            obj_clear(o);
            obj_box(o, lo, hi);
            set_obj(scene, o);
        }
        tobj *o = add_obj(&w, 300000 + (uint32_t)e);
        float lo[3] = {14.0f, 10.0f, 14.0f}, hi[3] = {18.0f + (float)e, 17.0f, 33.0f};
        obj_box(o, lo, hi);
        set_obj(scene, o);
        for (int c = 0; c < 3; ++c) {
            vis_camera cam;
            random_view_opts(&cam, &rng, w.size, zero, &edgy_view);
            check_view(ctx, scene, &w, &cam, 37, 29, "after edits");
        }
    }
    vis_scene_stats after;
    assert_int_equal(vis_scene_get_stats(scene, &after), VIS_OK);
    assert_true(after.rope_bytes == before.rope_bytes); /* built once, never changed */
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The y extent of each node's primitives inside its box, from the leaves themselves: every
 * packed and loose quad's and every triangle's extent on y, cut to the leaf's box. lo > hi
 * where a subtree holds nothing. */
static void take_y(const vis_flat_leaf *leaf, float ylo, float yhi, float *lo, float *hi)
{
    *lo = fminf(*lo, fmaxf(ylo, leaf->lo[1]));
    *hi = fmaxf(*hi, fminf(yhi, leaf->hi[1]));
}

static void true_fills(const vis_scene_view *v, float *lo, float *hi, float *y0, float *y1)
{
    y0[0] = 0.0f;
    y1[0] = v->size[1];
    for (uint32_t i = 0; i < v->node_count; ++i) { /* children come after their parent */
        uint32_t info = v->nodes[i].info;
        if ((info & 3u) == VIS_NODE_LEAF)
            continue;
        uint32_t c = info >> 2;
        y0[c] = y0[c + 1u] = y0[i];
        y1[c] = y1[c + 1u] = y1[i];
        if ((info & 3u) == 1u)
            y1[c] = y0[c + 1u] = v->nodes[i].split;
    }
    for (uint32_t i = v->node_count; i-- > 0;) {
        uint32_t info = v->nodes[i].info;
        lo[i] = INFINITY, hi[i] = -INFINITY;
        if ((info & 3u) != VIS_NODE_LEAF) {
            for (uint32_t c = info >> 2; c < (info >> 2) + 2u; ++c)
                lo[i] = fminf(lo[i], lo[c]), hi[i] = fmaxf(hi[i], hi[c]);
            continue;
        }
        const vis_flat_leaf *leaf = &v->leaves[info >> 2];
        const vis_flat_quad *loose = vis_loose_quads(v->quads, leaf);
        for (uint32_t j = 0; j < leaf->loose_count; ++j) {
            const vis_flat_quad *q = &loose[j];
            uint32_t a = VIS_META_AXIS(q->meta);
            take_y(leaf, a == 1u ? q->plane : a == 0u ? q->u0 : q->v0, a == 1u ? q->plane : a == 0u ? q->u1 : q->v1,
                   &lo[i], &hi[i]);
        }
        for (uint32_t j = 0; j < leaf->tri_count; ++j) {
            const vis_flat_tri *t = &v->tris[leaf->tri_offset + j];
            take_y(leaf, fminf(t->v0[1], fminf(t->v1[1], t->v2[1])), fmaxf(t->v0[1], fmaxf(t->v1[1], t->v2[1])),
                   &lo[i], &hi[i]);
        }
        if (leaf->quad_count == 0u)
            continue;
        const uint32_t *bk = v->buckets + leaf->bucket_offset;
        uint32_t E[3] = {leaf->dims_xy & 0xFFFFu, leaf->dims_xy >> 16, leaf->dims_z}, b = 0;
        for (uint32_t a = 0; a < 3u; ++a)
            for (uint32_t k = 0; k <= E[a]; ++k, ++b)
                for (uint32_t j = bk[b]; j < bk[b + 1u]; ++j) {
                    vis_flat_quad q = vis_unpack_quad(v->quads[leaf->quad_offset + j], a, (int)k, leaf, v->quads);
                    /* y: the plane of y planes, u of x planes, v of z planes */
                    take_y(leaf, a == 1u ? q.plane : a == 0u ? q.u0 : q.v0, a == 1u ? q.plane : a == 0u ? q.u1 : q.v1,
                           &lo[i], &hi[i]);
                }
    }
}

/* Every node's fill holds what its subtree holds on y, and is empty exactly where it holds
 * nothing: after a full build, and after edits brought in leaf by leaf, which must give the
 * very bytes a full build gives. */
static uint32_t check_fills(const vis_scene_view *v, const vis_occupancy *occ, const char *what)
{
    size_t n = v->node_count;
    float *lo = malloc(n * 4), *hi = malloc(n * 4), *y0 = malloc(n * 4), *y1 = malloc(n * 4);
    true_fills(v, lo, hi, y0, y1);
    uint32_t partial = 0;
    for (uint32_t i = 0; i < n; ++i) {
        vis_node_fill f = occ->fill[i];
        int holds = lo[i] <= hi[i];
        if (holds != vis_node_filled(f))
            fail_msg("%s: node %u holds %s but its fill says %s", what, i, holds ? "primitives" : "nothing",
                     holds ? "empty" : "filled");
        if (!holds)
            continue;
        float flo = vis_node_fill_lo(f, y0[i], y1[i]), fhi = vis_node_fill_hi(f, y0[i], y1[i]);
        if (flo > lo[i] || fhi < hi[i])
            fail_msg("%s: node %u over [%g, %g] holds y in [%g, %g], its fill says [%g, %g]", what, i, (double)y0[i],
                     (double)y1[i], (double)lo[i], (double)hi[i], (double)flo, (double)fhi);
        partial += f.lo != 0u || f.hi != 255u;
    }
    free(lo), free(hi), free(y0), free(y1);
    return partial; /* subtrees lower than their boxes: where the fills cut something */
}

static void fills_through_edits(vis_context *ctx, uint32_t kd_depth, uint64_t rng)
{
    tworld w;
    random_chunk_world_opts(&w, &rng, 4, 3, 3, &edgy_world);
    vis_scene *scene = make_scene(ctx, &w, NULL, kd_depth);
    vis_occupancy occ, fresh;
    memset(&occ, 0, sizeof occ);
    memset(&fresh, 0, sizeof fresh);
    occ.alloc = fresh.alloc = vt_heap_allocator();
    vis_scene_changes all;
    memset(&all, 0, sizeof all);
    all.full = 1;
    vis_scene_view v = vis_scene_get_view(scene);
    assert_int_equal(vis_occupancy_sync(&occ, &v, &all), VIS_OK);
    uint32_t partial = check_fills(&v, &occ, "full build"), saturated = 0, loose = 0;
    int rounds = vt_small() ? 4 : 12;
    uint32_t *leaves = malloc((size_t)v.leaf_count * sizeof *leaves);
    for (int e = 0; e < rounds; ++e) {
        for (int k = 0; k < 4 && w.n > 0; ++k) {
            tobj *o = &w.objs[vt_rand(&rng) % w.n];
            float lo[3], hi[3];
            small_box(&w, &rng, lo, hi);
            obj_clear(o);
            if (vt_rand(&rng) % 4)
                obj_box(o, lo, hi);
            else
                obj_quad(o, 1, lo[1], lo[2], lo[0], hi[2], hi[0]); /* a lone floor (u: z, v: x) */
            set_obj(scene, o);
        }
        v = vis_scene_get_view(scene);
        vis_scene_changes some;
        memset(&some, 0, sizeof some);
        for (uint32_t l = 0; l < v.leaf_count; ++l)
            leaves[l] = l;
        some.leaves = leaves;
        some.leaf_count = v.leaf_count;
        assert_int_equal(vis_occupancy_sync(&occ, &v, &some), VIS_OK);
        char what[48];
        snprintf(what, sizeof what, "kd_depth %u, after edit round %d", kd_depth, e);
        partial += check_fills(&v, &occ, what);
        for (uint32_t l = 0; l < v.leaf_count; ++l) {
            const vis_flat_leaf *lf = &v.leaves[l];
            saturated += lf->quad_count && VIS_BOX_FIELD(lf->content_box, 4u) == VIS_PQ_COORD_MAX;
            loose += lf->loose_count != 0u;
        }
        assert_int_equal(vis_occupancy_sync(&fresh, &v, &all), VIS_OK);
        assert_memory_equal(occ.fill, fresh.fill, v.node_count * sizeof *occ.fill);
    }
    /* The cases each tree is here for. */
    if (kd_depth == 0)
        assert_true(partial > 0);
    else
        assert_true(saturated > 0 && loose > 0);
    free(leaves);
    vis_occupancy_free(&occ);
    vis_occupancy_free(&fresh);
    vis_scene_destroy(scene);
    free_world(&w);
}

/* Leaves of one chunk (the full depth), and of several (kd_depth 2: leaves wider than 31
 * voxels, whose content boxes saturate, and quads too long to pack, which go loose). */
static void test_node_fills_hold_their_leaves(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    fills_through_edits(ctx, 0, 4242);
    fills_through_edits(ctx, 2, 4343);
    vis_context_destroy(ctx);
}

/* Packets skip subtrees that hold nothing or whose heights a tile misses (the CPU backend's
 * subtree fills, refreshed at sync): a leaf emptied and refilled, a far leaf filled for the
 * first time, and a box cut down and raised again must show. */
static void test_packet_occupancy_follows_edits(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = 64.0f, w.size[1] = 32.0f, w.size[2] = 64.0f;
    float lo[3] = {20, 4, 40}, hi[3] = {24, 9, 44};
    obj_box(add_obj(&w, 5), lo, hi);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{32, 30, 0}, {32, 8, 48}, 70, 0.05, 0};
    check_view(ctx, scene, &w, &cam, 40, 33, "one box");
    assert_int_equal(vis_scene_remove_object(scene, 5), VIS_OK);
    obj_clear(&w.objs[0]);
    w.n = 0;
    check_view(ctx, scene, &w, &cam, 40, 33, "empty world");
    float lo2[3] = {40, 0, 56}, hi2[3] = {64, 3, 64}; /* a leaf that never held anything */
    tobj *o = add_obj(&w, 9);
    obj_box(o, lo2, hi2);
    set_obj(scene, o);
    check_view(ctx, scene, &w, &cam, 40, 33, "far box added");
    o = add_obj(&w, 5);
    obj_box(o, lo, hi);
    set_obj(scene, o);
    check_view(ctx, scene, &w, &cam, 40, 33, "first box back");
    uint32_t ids[40 * 33];
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = 40, td.height = 33;
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, 40 * 33, NULL, 0), VIS_OK); /* AUTO: packets */
    int seen5 = 0, seen9 = 0;
    for (size_t i = 0; i < sizeof ids / sizeof ids[0]; ++i)
        seen5 |= ids[i] == 5, seen9 |= ids[i] == 9;
    assert_true(seen5 && seen9);
    /* The subtrees' heights (occupancy.h): box 5 cut down to a slab, then raised to a tower
     * past its old top, seen across its top from a low eye, where tiles of sky above the slab
     * skip whatever the fills say lies below them. */
    float heights[] = {5.0f, 28.0f, 9.0f};
    vis_camera low = {{32, 12, 0}, {32, 10, 48}, 70, 0.05, 0};
    for (int k = 0; k < 3; ++k) {
        tobj *box = &w.objs[w.n - 1];
        assert_int_equal(box->id, 5);
        float top[3] = {hi[0], heights[k], hi[2]};
        obj_clear(box);
        obj_box(box, lo, top);
        set_obj(scene, box);
        char what[48];
        snprintf(what, sizeof what, "box 5 up to y = %g", (double)heights[k]);
        check_view(ctx, scene, &w, &low, 40, 33, what);
        check_view(ctx, scene, &w, &cam, 40, 33, what);
    }
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- hard cases ------------------------------------------------------------------------- */

/* wall_world (scene_builder.h) and two more objects: */
static void wall_world_quads(tworld *w)
{
    wall_world(w);
    /* quads lying exactly in split planes, seen from both sides by in-plane rays' neighbours */
    obj_quad(add_obj(w, 4), 0, 16.0f, 20.0f, 0.0f, 24.0f, 4.0f);
    obj_quad(add_obj(w, 5), 2, 16.0f, 20.0f, 20.0f, 24.0f, 24.0f);
}

static void test_hard_cases(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    wall_world_quads(&w);
    static const uint32_t depths[] = {0, 1, 2};
    const double views[][7] = {
        {16, 6, 0, 16, 6, 32, 0},     /* in the split plane x=16                              */
        {16, 16, 16, 16, 0, 16, 0},   /* straight down from a chunk corner                    */
        {16, 16, 16, 16, 32, 16, 0},  /* straight up                                          */
        {0, 6, 16, 32, 6, 16, 0},     /* along +x in the plane z=16                           */
        {31, 6, 16, 0, 6, 16, 0},     /* along -x                                             */
        {0, 1, 0, 32, 1, 32, 0},      /* diagonal in the floor's top plane                    */
        {16, 12, 0, 16, 12, 32, 0},   /* along the wall's top edge                            */
        {17, 12, 17, 0, 0, 0, 0},     /* from the wall's corner                               */
        {8, 30, 8, 16.5, 1, 16.5, 0},
        {0, 16, 0, 32, 16, 32, 0},    /* exact diagonal through the corners of every chunk    */
        {0, 0, 0, 32, 32, 32, 0},     /* the main diagonal: through the corner of 8 chunks    */
        {32, 32, 32, 0, 0, 0, 0},
        {0.5, 6, 16, 32, 6, 16, 15.5},/* far plane exactly on the split plane x=16            */
        {0.5, 16, 16, 32, 16, 16, 15.5},
        {-10, 16, 16, 40, 16, 16, 26},/* from outside, far exactly on x=16                    */
        {-8, -8, -8, 40, 40, 40, 0},  /* enters the scene exactly at its corner               */
        {16, 16, -5, 16, 16, 40, 0},  /* along the line where two split planes meet           */
    };
    for (size_t di = 0; di < sizeof depths / sizeof depths[0]; ++di) {
        vis_scene *scene = make_scene(ctx, &w, NULL, depths[di]);
        for (size_t i = 0; i < sizeof views / sizeof views[0]; ++i) {
            vis_camera cam;
            memset(&cam, 0, sizeof cam);
            memcpy(cam.eye, views[i], 24);
            memcpy(cam.target, views[i] + 3, 24);
            cam.far_dist = views[i][6];
            char what[64];
            snprintf(what, sizeof what, "hard view %zu, kd_depth %u", i, depths[di]);
            check_view(ctx, scene, &w, &cam, 33, 33, what);
            check_view(ctx, scene, &w, &cam, 32, 32, what);
        }
        vis_scene_destroy(scene);
    }
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Views over the checkerboard: rays through chunk edges and corners, where cubes of two IDs
 * meet at the very same depth. The quad test and the tree walk decide from the same distances
 * (docs/traversal.md, "Exactness"), so the tie rule (lowest ID) holds on every method: every
 * pixel equals the oracle. (With a quad test that compared a rounded crossing point, the walk
 * could put a ray on one side of an edge while the chunk on the other side took it at the same
 * depth: 23 pixels of these views kept the higher ID.) */
static void test_checkerboard_views(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    checker_world(&w, 4, 4, 4);
    const uint32_t depths[] = {0, 2, 4};
    const double views[][6] = {
        {0, 0, 0, 64, 64, 64}, {-16, 32, -16, 80, 32, 80}, {32, 32, 32, 0, 0, 64}, {8, 40, 8, 40, 8, 40},
        {32, 70, 32, 32, 0, 32}, {16, 16, -10, 16, 16, 64}, {64, 48, 0, 0, 48, 64}, {24, 24, 24, 64, 24, 24},
    };
    for (size_t di = 0; di < sizeof depths / sizeof depths[0]; ++di) {
        vis_scene *scene = make_scene(ctx, &w, NULL, depths[di]);
        for (size_t i = 0; i < sizeof views / sizeof views[0]; ++i) {
            vis_camera cam;
            memset(&cam, 0, sizeof cam);
            memcpy(cam.eye, views[i], 24);
            memcpy(cam.target, views[i] + 3, 24);
            cam.fovy_deg = 90;
            check_view_ids(ctx, scene, &w, &cam, 33, 33, VIS_IDS_OBJECT, "checkerboard view");
            check_view_ids(ctx, scene, &w, &cam, 32, 31, VIS_IDS_OBJECT, "checkerboard view");
            cam.fovy_deg = 12; /* 16x16 packets */
            check_view_ids(ctx, scene, &w, &cam, 64, 56, VIS_IDS_OBJECT, "checkerboard view, 16x16 packets");
        }
        vis_scene_destroy(scene);
    }
    free_world(&w);
    vis_context_destroy(ctx);
}

static void test_closed_room_ties_inside_solid(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    const float L = 16, H = 32;
    room_world(&w, L, H);
    /* the same quad in two objects in different leaves: lowest ID wins */
    obj_quad(add_obj(&w, 61), 2, 40.0f, 34, 34, 46, 46);
    obj_quad(add_obj(&w, 60), 2, 40.0f, 34, 34, 46, 46);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    uint64_t rng = 99;
    int n = vt_small() ? 6 : 20;
    for (int i = 0; i < n; ++i) {
        vis_camera cam;
        memset(&cam, 0, sizeof cam);
        for (int a = 0; a < 3; ++a) {
            cam.eye[a] = L + 1 + vt_rand_unit(&rng) * (H - L - 2);
            if (i % 3 == 0)
                cam.eye[a] = floor(cam.eye[a]);
            cam.target[a] = L + vt_rand_unit(&rng) * (H - L);
        }
        if (i % 4 == 0) {
            cam.target[0] = L + 1, cam.target[1] = H - 1, cam.target[2] = L + 1;
        }
        if (i % 5 == 1) { /* from the centre (a split-plane corner) to a room corner */
            cam.eye[0] = cam.eye[1] = cam.eye[2] = 24;
            cam.target[0] = cam.target[1] = cam.target[2] = L + 1;
        }
        cam.fovy_deg = 90;
        check_view(ctx, scene, &w, &cam, 41, 37, "inside the closed room");
    }
    vis_camera ties = {{40, 40, 20}, {40, 40, 47}, 40, 0, 0};
    check_view(ctx, scene, &w, &ties, 16, 16, "ties");
    vis_camera solid = {{24.5, 24.5, 16.5}, {30, 20, 40}, 90, 0, 0};
    check_view(ctx, scene, &w, &solid, 20, 20, "camera inside a solid wall");
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

static void test_far_origin_and_leaf_ids(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    uint64_t rng = 4242;
    tworld w;
    random_chunk_world_opts(&w, &rng, 3, 2, 3, &edgy_world);
    const double far_o[3] = {1048576.0, 0.0, -1048576.0};
    vis_scene *scene = make_scene(ctx, &w, far_o, 0);
    vis_scene *shallow = make_scene(ctx, &w, NULL, 3);
    const double zero[3] = {0, 0, 0};
    for (int i = 0; i < 4; ++i) {
        vis_camera cam;
        random_view_opts(&cam, &rng, w.size, far_o, &edgy_view);
        check_view(ctx, scene, &w, &cam, 32, 32, "far from the origin");
        random_view_opts(&cam, &rng, w.size, zero, &edgy_view);
        check_view_ids(ctx, shallow, &w, &cam, 40, 30, VIS_IDS_LEAF, "leaf IDs");
    }
    vis_scene_destroy(scene);
    vis_scene_destroy(shallow);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- ray by ray: degenerate rays through the shared traversal code ----------------------- */

static void trace_ray(const vis_scene_view *v, const vis_ray_setup *s, const vis_ray *r, vis_hit *h)
{
    h->t = INFINITY;
    h->object = VIS_NO_OBJECT;
    h->id = 0;
    switch (s->traversal) {
    case VIS_TRAVERSAL_ID_STACK: vis_traverse_stack(r, s, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_RESTART: vis_traverse_restart(r, s, 0, 0, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_PUSHDOWN: vis_traverse_restart(r, s, 0, 1, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_SHORTSTACK: vis_traverse_restart(r, s, s->short_stack, 0, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_ROPES: vis_traverse_ropes(r, s, 0, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_ROPES_SHORTSTACK: vis_traverse_ropes(r, s, s->short_stack, VIS_SCENE_VIEW_ARGS(v), h); break;
    case VIS_TRAVERSAL_ID_CACHED_STACK: {
        vis_stack_entry ring[VIS_MAX_SHORT_STACK];
        vis_traverse_cached_stack(r, s, ring, 1u, s->short_stack, VIS_SCENE_VIEW_ARGS(v), h);
        break;
    }
    case VIS_TRAVERSAL_ID_DDA: vis_traverse_dda(r, s, VIS_SCENE_VIEW_ARGS(v), h); break;
    default: fail_msg("unknown traversal %u", s->traversal);
    }
}

static void make_ray(vis_ray *r, const float o[3], const int dir[3], float t_near, float t_far)
{
    float d[3] = {(float)dir[0], (float)dir[1], (float)dir[2]};
    float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) {
        r->o[a] = o[a];
        r->d[a] = d[a] / len;
        r->inv[a] = 1.0f / r->d[a];
    }
    r->t_near = t_near;
    r->t_far = t_far;
}

/* Bit for bit, but for the sign of a zero distance: a ray from a surface (t_near 0) can touch
 * two quads of one object through its origin, at -0 on one axis and +0 on another, and the
 * walks offer them in different orders. No buffer holds such a t (a camera's near distance
 * is > 0; secondary rays return IDs only). */
static int same_distance(float a, float b) { return memcmp(&a, &b, 4) == 0 || (a == 0.0f && b == 0.0f); }

/* One ray: `stack` must equal the oracle and keep the conservative rule against the
 * double-precision reference (every face the ray touches, edges and corners of chunks
 * included, counts), and every per-ray method must equal `stack`. `ray` names it. */
static void check_ray(const vis_scene_view *v, vis_ray_setup *s, const tworld *w, const ref_scene *rs, const vis_ray *r,
                      const char *what, const char *ray)
{
    float ot;
    uint32_t oid;
    oracle_ray(w, r, &ot, &oid);
    s->traversal = VIS_TRAVERSAL_ID_STACK;
    vis_hit ref;
    trace_ray(v, s, r, &ref);
    if (ref.id != oid || !same_distance(ref.t, ot))
        fail_msg("%s: %s: stack id %u t %.9g, oracle id %u t %.9g", what, ray, ref.id, (double)ref.t, oid, (double)ot);
    ref_ray rr;
    ref_ray_from_float(r->o, r->d, r->t_near, r->t_far, &rr);
    char why[256];
    if (ref_check(rs, &rr, ref.id, ref.t, NULL, why, sizeof why))
        fail_msg("%s: %s against the double-precision reference: %s", what, ray, why);
    for (size_t m = 0; m < METHOD_COUNT; ++m) {
        if (methods[m].traversal == VIS_TRAVERSAL_PACKET)
            continue; /* a packet is a camera's tile, not one ray: the views check it */
        s->traversal = (uint32_t)methods[m].traversal - 1u; /* enum -> VIS_TRAVERSAL_ID_* */
        s->short_stack = methods[m].n;
        vis_hit h;
        trace_ray(v, s, r, &h);
        if (h.id != ref.id || !same_distance(h.t, ref.t) || h.object != ref.object)
            fail_msg("%s, %s: %s: id %u t %.9g, stack (= oracle) id %u t %.9g", what, methods[m].name, ray, h.id,
                     (double)h.t, ref.id, (double)ref.t);
    }
}

/* Ray i of a stream (its vt_rand draws from rng), named in `ray`. */
typedef void (*ray_gen)(uint64_t *rng, const tworld *w, int i, int lattice, vis_ray *r, char *ray, size_t cap);

/* count rays of gen through the whole scene, each checked by check_ray. */
static void check_ray_stream(vis_scene *scene, const tworld *w, uint64_t *rng, int count, ray_gen gen, int lattice,
                             const char *what)
{
    assert_int_equal(vis_kdtree_build_ropes(scene, scene->ctx), VIS_OK); /* the rope methods are called directly */
    vis_scene_view v = vis_scene_get_view(scene);
    vis_ray_setup s;
    memset(&s, 0, sizeof s);
    memcpy(s.size, w->size, sizeof s.size);
    s.root = 0;
    s.leaf_count = v.leaf_count;
    memcpy(s.cells, v.cells, sizeof s.cells);
    s.cell_map = v.cell_map;
    s.cell_size = v.cell_size;
    ref_scene rs;
    ref_scene_init(&rs, w);
    /* Every ray twice: through the plane walk (the devices' and the effects pass's), and
     * through the CPU's label walk where a leaf has labels (cpu/labels.h). */
    vis_labels lab;
    assert_int_equal(vt_labels_build(&lab, &v), VIS_OK);
    vis_scene_view lv = v;
    lv.labels = lab.words;
    char labelled[224];
    snprintf(labelled, sizeof labelled, "%s, label walk", what);
    for (int i = 0; i < count; ++i) {
        vis_ray r;
        char ray[192];
        gen(rng, w, i, lattice, &r, ray, sizeof ray);
        check_ray(&v, &s, w, &rs, &r, what, ray);
        check_ray(&lv, &s, w, &rs, &r, labelled, ray);
    }
    vis_labels_free(&lab);
    ref_scene_free(&rs);
}

/* lattice: origins on multiples of 8 and directions in {-1,0,1}^3 (exact diagonals through
 * chunk edges and corners); otherwise origins on split planes or integers, directions in
 * {-2..2}^3. */
static void grid_ray(uint64_t *rng, const tworld *w, int i, int lattice, vis_ray *r, char *ray, size_t cap)
{
    (void)i;
    float o[3];
    int dir[3];
    for (int a = 0; a < 3; ++a) {
        double u = vt_rand_unit(rng);
        double x = vt_rand_unit(rng) * (w->size[a] + 16.0) - 8.0;
        if (lattice)
            x = 8.0 * floor(x / 8.0 + 0.5);
        else if (u < 0.45)
            x = 16.0 * floor(x / 16.0 + 0.5); /* on a split plane / the scene boundary */
        else if (u < 0.8)
            x = floor(x);
        o[a] = (float)x;
        dir[a] = lattice ? (int)(vt_rand(rng) % 3) - 1 : (int)(vt_rand(rng) % 5) - 2;
    }
    if (dir[0] == 0 && dir[1] == 0 && dir[2] == 0)
        dir[vt_rand(rng) % 3] = 1;
    float t_far = INFINITY;
    if (vt_rand_unit(rng) < 0.3)
        t_far = (float)(1 + vt_rand(rng) % 40);
    make_ray(r, o, dir, 0.05f, t_far);
    snprintf(ray, cap, "ray o=(%g,%g,%g) d=(%d,%d,%d) far %g", (double)o[0], (double)o[1], (double)o[2], dir[0],
             dir[1], dir[2], (double)t_far);
}

/* Rays as the effects cast them (reflected and shadow rays): from a point on a surface, at
 * t_near = 0, so that a quad through the origin is a hit at t = 0. Origins on split planes and
 * chunk edges (where the walk must also look into the child behind the plane) and on
 * integers, directions as grid_ray's. */
static void surface_ray(uint64_t *rng, const tworld *w, int i, int lattice, vis_ray *r, char *ray, size_t cap)
{
    grid_ray(rng, w, i, lattice, r, ray, cap);
    r->t_near = 0.0f;
    snprintf(ray + strlen(ray), cap - strlen(ray), ", near 0");
}

static void test_degenerate_rays(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 31337;
    static const int shapes[][3] = {{4, 2, 4}, {3, 3, 3}, {5, 2, 3}, {2, 2, 2}};
    static const uint32_t depths[] = {0, 2, 3, 1};
    int rounds = vt_small() ? 4 : 8, rays = vt_small() ? 1500 : 6000;
    for (int wi = 0; wi < rounds; ++wi) {
        tworld w;
        const int *sh = shapes[wi % 4];
        random_chunk_world_opts(&w, &rng, sh[0], sh[1], sh[2], &edgy_world);
        vis_scene *scene = make_scene(ctx, &w, NULL, depths[wi % 4]);
        char what[64];
        snprintf(what, sizeof what, "world %d, kd_depth %u", wi, depths[wi % 4]);
        check_ray_stream(scene, &w, &rng, rays, grid_ray, 0, what);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    tworld w;
    wall_world_quads(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    check_ray_stream(scene, &w, &rng, rays, grid_ray, 0, "wall world");
    check_ray_stream(scene, &w, &rng, rays, grid_ray, 1, "wall world, lattice rays");
    vis_scene_destroy(scene);
    free_world(&w);
    static const int checkers[][4] = {{4, 4, 4, 0}, {5, 3, 4, 0}, {4, 4, 4, 3}, {6, 2, 5, 4}};
    for (int ci = 0; ci < 4; ++ci) {
        checker_world(&w, checkers[ci][0], checkers[ci][1], checkers[ci][2]);
        scene = make_scene(ctx, &w, NULL, (uint32_t)checkers[ci][3]);
        char what[64];
        snprintf(what, sizeof what, "checkerboard %d, kd_depth %d", ci, checkers[ci][3]);
        check_ray_stream(scene, &w, &rng, rays, grid_ray, 1, what);
        check_ray_stream(scene, &w, &rng, rays / 2, grid_ray, 0, what);
        check_ray_stream(scene, &w, &rng, rays / 2, surface_ray, 1, what);
        check_ray_stream(scene, &w, &rng, rays / 4, surface_ray, 0, what);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* A camera whose centre ray has a subnormal direction component (|d.y| about 1e-41) and
 * starts exactly on a cell boundary on that axis: 1/d.y would be infinite and the offset to
 * the boundary zero, a NaN in the walks (the cell-grid walk looped on it). Every ray the
 * library makes takes such a component as 0 (trace_core.h, vis_dir_component), so every
 * method sees the same parallel ray, ends, and equals the brute force. */
static void test_subnormal_directions(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene_desc sd;
    vis_scene_desc_defaults(&sd);
    sd.origin[1] = -16.0;
    sd.size[0] = sd.size[1] = sd.size[2] = 64.0f;
    vis_scene *scene = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &scene), VIS_OK);
    const vis_quad q = {0u, 0u, 40.0f, 0.0f, 0.0f, 16.0f, 16.0f}; /* x = 40, y and z in [0, 16] */
    const vis_mesh m = {&q, 1u, NULL, 0u};
    assert_int_equal(vis_scene_set_object(scene, 7u, &m), VIS_OK);
    const double ys[] = {1e-39, -1e-39, 2e-39, 0.0};
    for (size_t yi = 0; yi < sizeof ys / sizeof ys[0]; ++yi) {
        vis_camera cam = {{8.0, ys[yi], 8.0}, {108.0, 0.0, 8.0}, 60.0, 0.05, 0.0};
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = td.height = 3u;
        td.traversal = VIS_TRAVERSAL_BRUTEFORCE;
        uint32_t want[9], got[9];
        float want_d[9], got_d[9];
        assert_int_equal(vis_trace(ctx, scene, &cam, &td, want, 9, want_d, 9), VIS_OK);
        if (want[4] != 7u)
            fail_msg("eye y %g: the centre ray saw %u, not the wall 7", ys[yi], want[4]);
        for (size_t i = 0; i <= METHOD_COUNT; ++i) {
            td.traversal = i < METHOD_COUNT ? methods[i].traversal : VIS_TRAVERSAL_AUTO;
            td.short_stack = i < METHOD_COUNT ? methods[i].n : 0u;
            assert_int_equal(vis_trace(ctx, scene, &cam, &td, got, 9, got_d, 9), VIS_OK);
            if (memcmp(got, want, sizeof want) != 0 || memcmp(got_d, want_d, sizeof want_d) != 0)
                fail_msg("eye y %g: %s differs from the brute force", ys[yi], i < METHOD_COUNT ? methods[i].name : "auto");
        }
    }
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
}

/* Rays aimed exactly at edges and corners of the worlds' boxes -- in the checkerboard, every
 * cube edge is a chunk edge, where leaves meet -- from random eyes: built in float to pass
 * exactly through the point (o = P - k D, D integer, k dyadic) or aimed from an eye exact in
 * float (d = fl(normalize(P - e))). There the tree walk meets split planes within rounding of
 * each other and of the hit: `stack` must equal the oracle and keep the conservative rule
 * against the double-precision reference, and every method must equal `stack`. */
static void aimed_ray(uint64_t *rng, const tworld *w, int i, int lattice, vis_ray *r, char *ray, size_t cap)
{
    (void)lattice;
    double p[3];
    ref_edge_point(w, rng, p);
    ref_aimed_ray(rng, w->size, p, i & 1, 0.2, 4, 8, 505, r->o, r->d);
    for (int a = 0; a < 3; ++a)
        r->inv[a] = 1.0f / r->d[a];
    r->t_near = 0.05f;
    r->t_far = INFINITY;
    snprintf(ray, cap, "ray o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) at (%g,%g,%g)", (double)r->o[0], (double)r->o[1],
             (double)r->o[2], (double)r->d[0], (double)r->d[1], (double)r->d[2], p[0], p[1], p[2]);
}

static void test_aimed_at_chunk_edges(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 8128;
    int rays = vt_small() ? 2000 : 20000;
    static const int checkers[][4] = {{4, 4, 4, 0}, {5, 3, 4, 2}, {4, 2, 6, 4}};
    for (int ci = 0; ci < 3; ++ci) {
        tworld w;
        checker_world(&w, checkers[ci][0], checkers[ci][1], checkers[ci][2]);
        vis_scene *scene = make_scene(ctx, &w, NULL, (uint32_t)checkers[ci][3]);
        char what[64];
        snprintf(what, sizeof what, "checkerboard %d, kd_depth %d", ci, checkers[ci][3]);
        check_ray_stream(scene, &w, &rng, rays, aimed_ray, 0, what);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    static const int shapes[][3] = {{4, 2, 4}, {3, 3, 3}};
    for (int wi = 0; wi < 2; ++wi) {
        tworld w;
        random_chunk_world_opts(&w, &rng, shapes[wi][0], shapes[wi][1], shapes[wi][2], &edgy_world);
        vis_scene *scene = make_scene(ctx, &w, NULL, (uint32_t)(wi * 2));
        check_ray_stream(scene, &w, &rng, rays, aimed_ray, 0, "random world");
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* One quad of 1-3 voxels a side on a random axis, inside the chunk at `base` at least `margin`
 * voxels from its faces. */
static void small_quad(tobj *o, const float base[3], int margin, uint64_t *rng)
{
    uint32_t a = (uint32_t)(vt_rand(rng) % 3u), u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    float lo[3];
    int ext[3];
    for (int b = 0; b < 3; ++b) {
        ext[b] = 1 + (int)(vt_rand(rng) % 3u);
        lo[b] = base[b] + (float)margin + (float)(vt_rand(rng) % (uint64_t)(17 - 2 * margin - ext[b]));
    }
    obj_quad(o, a, lo[a], lo[u], lo[v], lo[u] + (float)ext[u], lo[v] + (float)ext[v]);
}

/* Lone quads inside chunks, one to three voxels wide, their edges on even and odd offsets from
 * the chunk's corner, on every axis, with nothing next to them: a ray aimed at such an edge
 * takes the quad only through the quad test's slack. With VIS_LEAF_MASK the leaf walk skips
 * a plane where the mask has no marked cell near the crossing (trace_core.h,
 * vis_mask_may_hit): these rays hold it to widening past that slack and the rounding of the
 * crossing -- a crossing just short of an even offset lies in the cell before the quad's. */
static void lone_quad_world(tworld *w, uint64_t *rng)
{
    chunk_world_init(w, 2, 2, 2);
    for (uint32_t c = 0; c < 8u; ++c) {
        float base[3] = {16.0f * (float)(c & 1u), 16.0f * (float)((c >> 1) & 1u), 16.0f * (float)(c >> 2)};
        uint32_t n = 2u + (uint32_t)(vt_rand(rng) % 4u);
        tobj *o = add_obj(w, 1u + c);
        for (uint32_t i = 0; i < n; ++i)
            small_quad(o, base, 0, rng);
    }
}

static void test_aimed_at_lone_quad_edges(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 4099;
    int rays = vt_small() ? 4000 : 20000;
    for (int wi = 0; wi < 3; ++wi) {
        tworld w;
        lone_quad_world(&w, &rng);
        vis_scene *scene = make_scene(ctx, &w, NULL, 0);
        check_ray_stream(scene, &w, &rng, rays, aimed_ray, 0, "lone quads");
        check_ray_stream(scene, &w, &rng, rays / 4, grid_ray, 0, "lone quads, grid rays");
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* The per-ray leaf walk clips the ray to its leaf's content box, the box of the leaf's packed
 * quads (trace_core.h, vis_leaf_intersect; scene.c, content_box), and looks for quads only
 * there. Rays aimed at the points where the quads that bound an object's box touch its faces
 * -- those quads' outer edges and corners, through them or from random eyes, a third of the
 * components 0 so that some rays lie in the box's face -- take those quads only if the box is
 * exact: a box one voxel short on any side drops such rays (before the walk, or from the planes
 * it steps). Leaves of one chunk, of half a chunk's extent (objects over several leaves, quads
 * reaching past their leaf) and of two chunks'. (Planes past offset 31, where the box's high
 * field saturates, are not reached here: the objects' planes lie at offsets 0..16; other
 * test_traversal tests fail when the saturation rule is broken.) */
static void box_edge_ray(uint64_t *rng, const tworld *w, int i, int lattice, vis_ray *r, char *ray, size_t cap)
{
    (void)lattice;
    const tobj *o;
    do
        o = &w->objs[vt_rand(rng) % w->n];
    while (o->nq == 0u);
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t k = 0; k < o->nq; ++k) {
        const vis_quad *q = &o->quads[k];
        uint32_t a = q->axis, u = (a + 1u) % 3u, v = (a + 2u) % 3u;
        lo[a] = fminf(lo[a], q->plane), hi[a] = fmaxf(hi[a], q->plane);
        lo[u] = fminf(lo[u], q->u0), hi[u] = fmaxf(hi[u], q->u1);
        lo[v] = fminf(lo[v], q->v0), hi[v] = fmaxf(hi[v], q->v1);
    }
    /* a face of the box (axis b, side) and a quad that reaches it */
    uint32_t b = (uint32_t)(vt_rand(rng) % 3u), side = (uint32_t)(vt_rand(rng) % 2u);
    float face = side ? hi[b] : lo[b];
    const vis_quad *q = NULL;
    uint32_t start = (uint32_t)(vt_rand(rng) % o->nq);
    for (uint32_t k = 0; k < o->nq && !q; ++k) {
        const vis_quad *c = &o->quads[(start + k) % o->nq];
        uint32_t a = c->axis, u = (a + 1u) % 3u;
        float qlo = b == a ? c->plane : b == u ? c->u0 : c->v0;
        float qhi = b == a ? c->plane : b == u ? c->u1 : c->v1;
        if ((side ? qhi : qlo) == face)
            q = c;
    }
    assert_non_null(q); /* the box's bound is some quad's */
    /* a point of q on that face: a corner or a quarter point of an edge lying in it */
    uint32_t a = q->axis, u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    double p[3];
    p[a] = q->plane;
    double f = (double)(vt_rand(rng) % 5u) / 4.0;
    int on_u = vt_rand(rng) % 2u; /* which coordinate runs along the edge, unless b fixes it */
    if (b == u)
        on_u = 0;
    else if (b == v)
        on_u = 1;
    double ue = (vt_rand(rng) % 2u) ? q->u1 : q->u0, ve = (vt_rand(rng) % 2u) ? q->v1 : q->v0;
    if (b == u)
        ue = face;
    if (b == v)
        ve = face;
    p[u] = on_u ? q->u0 + f * ((double)q->u1 - q->u0) : ue;
    p[v] = on_u ? ve : q->v0 + f * ((double)q->v1 - q->v0);
    ref_aimed_ray(rng, w->size, p, i & 1, 0.3, 4, 8, 505, r->o, r->d);
    for (int c = 0; c < 3; ++c)
        r->inv[c] = 1.0f / r->d[c];
    r->t_near = 0.05f;
    r->t_far = INFINITY;
    snprintf(ray, cap, "ray o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) at (%g,%g,%g), object %u", (double)r->o[0],
             (double)r->o[1], (double)r->o[2], (double)r->d[0], (double)r->d[1], (double)r->d[2], p[0], p[1], p[2],
             o->id);
}

static void test_aimed_at_content_box_edges(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 6007;
    int rays = vt_small() ? 3000 : 15000;
    static const uint32_t depths[] = {0, 1, 5};
    for (int wi = 0; wi < 3; ++wi) {
        tworld w;
        lone_quad_world(&w, &rng);
        vis_scene *scene = make_scene(ctx, &w, NULL, depths[wi]);
        char what[64];
        snprintf(what, sizeof what, "content boxes, kd_depth %u", depths[wi]);
        check_ray_stream(scene, &w, &rng, rays, box_edge_ray, 0, what);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* The leaf walk skips the content box's slab on an axis the box spans (the whole leaf), and
 * returns after any slab the ray misses, the vertical one first (trace_core.h,
 * vis_leaf_intersect). Chunks whose objects hold a wall or floor across the whole chunk (a
 * box that spans the leaf on two or three axes) and a few small quads inside (so that the box
 * spans it on one axis at most when the wall is missing from some): rays aimed at the box's
 * outer edges and at the quads must equal the brute force, with leaves of one chunk, of half
 * a chunk's extent and of two chunks'. */
static void spanning_box_world(tworld *w, uint64_t *rng)
{
    chunk_world_init(w, 2, 2, 2);
    for (uint32_t c = 0; c < 8u; ++c) {
        float base[3] = {16.0f * (float)(c & 1u), 16.0f * (float)((c >> 1) & 1u), 16.0f * (float)(c >> 2)};
        tobj *o = add_obj(w, 1u + c);
        if (vt_rand(rng) % 4u != 0u) { /* a wall on a face of the chunk, or across its middle */
            uint32_t a = (uint32_t)(vt_rand(rng) % 3u), u = (a + 1u) % 3u, v = (a + 2u) % 3u;
            float k = (float)(vt_rand(rng) % 3u) * 8.0f;
            obj_quad(o, a, base[a] + k, base[u], base[v], base[u] + 16.0f, base[v] + 16.0f);
        }
        uint32_t n = 1u + (uint32_t)(vt_rand(rng) % 3u);
        for (uint32_t i = 0; i < n; ++i)
            small_quad(o, base, 2, rng);
    }
}

/* Cells of 32 voxels at full depth, wider than a content box's 5-bit fields: a wall on a
 * cell's far face (plane offset 32) saturates the box's high field, read back as the leaf's
 * last plane (trace_core.h, vis_leaf_intersect). Each of the 4^3 cells holds one object, by
 * turns: small boxes, a far wall and a small box (a saturated slab that narrows the ray),
 * walls on both faces (a saturated slab that spans the leaf and is skipped), or nothing. */
static void wide_cell_world(tworld *w, uint64_t *rng)
{
    memset(w, 0, sizeof *w);
    w->size[0] = w->size[1] = w->size[2] = 128.0f;
    for (uint32_t c = 0; c < 64u; ++c) {
        float base[3] = {32.0f * (float)(c % 4u), 32.0f * (float)(c / 4u % 4u), 32.0f * (float)(c / 16u)};
        uint32_t kind = (c + c / 4u + c / 16u) % 4u, a = (uint32_t)(vt_rand(rng) % 3u);
        uint32_t u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
        if (kind == 3u)
            continue;
        tobj *o = add_obj(w, 1u + c);
        if (kind != 2u)
            small_quad(o, base, 3, rng);
        if (kind >= 1u) /* rectangles within offsets 0..16: packable */
            obj_quad(o, a, base[a] + 32.0f, base[u] + 4.0f, base[v], base[u] + 16.0f, base[v] + 12.0f);
        if (kind == 2u)
            obj_quad(o, a, base[a], base[u], base[v] + 2.0f, base[u] + 9.0f, base[v] + 16.0f);
    }
}

static void test_content_box_spanning_the_leaf(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 7919;
    int rays = vt_small() ? 2000 : 10000;
    static const uint32_t depths[] = {0, 1, 5, 0};
    for (int wi = 0; wi < 4; ++wi) {
        tworld w;
        vis_scene *scene = NULL;
        if (wi < 3) {
            spanning_box_world(&w, &rng);
            scene = make_scene(ctx, &w, NULL, depths[wi]);
        } else {
            wide_cell_world(&w, &rng);
            vis_scene_desc d;
            vis_scene_desc_defaults(&d);
            memcpy(d.size, w.size, sizeof d.size);
            d.cell_size = 32.0f;
            scene = make_scene_desc(ctx, &w, &d);
            /* both saturated kinds occur: a slab that narrows, and one that spans the leaf */
            int narrows = 0, spans = 0;
            for (uint32_t li = 0; li < scene->leaf_count; ++li) {
                const vis_flat_leaf *lf = &scene->leaves[li];
                const uint32_t E[3] = {lf->dims_xy & 0xFFFFu, lf->dims_xy >> 16, lf->dims_z};
                for (uint32_t a = 0; a < 3u && lf->quad_count; ++a)
                    if (VIS_BOX_FIELD(lf->content_box, a + 3u) == VIS_PQ_COORD_MAX && E[a] > VIS_PQ_COORD_MAX) {
                        narrows += VIS_BOX_FIELD(lf->content_box, a) != 0u;
                        spans += VIS_BOX_FIELD(lf->content_box, a) == 0u;
                    }
            }
            assert_true(scene->cell_map != 0u && narrows > 0 && spans > 0);
        }
        char what[64];
        snprintf(what, sizeof what, "walls, kd_depth %u, cells of %g", depths[wi], (double)scene->desc.cell_size);
        check_ray_stream(scene, &w, &rng, rays, box_edge_ray, 0, what);
        check_ray_stream(scene, &w, &rng, rays, aimed_ray, 0, what);
        check_ray_stream(scene, &w, &rng, rays / 4, grid_ray, 0, what);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* ---- the ropes against their definition --------------------------------------------------- */

typedef struct node_box {
    float lo[3], hi[3];
    uint32_t depth;
} node_box;

static void collect_boxes(const vis_scene *s, uint32_t node, const float lo[3], const float hi[3], uint32_t depth,
                          node_box *out, uint32_t *height)
{
    memcpy(out[node].lo, lo, 12);
    memcpy(out[node].hi, hi, 12);
    out[node].depth = depth;
    uint32_t info = s->nodes[node].info;
    if ((info & 3u) == VIS_NODE_LEAF) {
        height[node] = 0;
        return;
    }
    uint32_t a = info & 3u, first = info >> 2;
    float l1[3], h0[3];
    memcpy(l1, hi, 12);
    memcpy(h0, lo, 12);
    l1[a] = h0[a] = s->nodes[node].split;
    collect_boxes(s, first, lo, l1, depth + 1, out, height);
    collect_boxes(s, first + 1, h0, hi, depth + 1, out, height);
    uint32_t hl = height[first], hr = height[first + 1];
    height[node] = 1 + (hl > hr ? hl : hr);
}

/* Does box b cover face f of box n from the other side? */
static int covers_face(const node_box *b, const node_box *n, uint32_t f)
{
    uint32_t a = f >> 1;
    if (f & 1u) {
        if (b->lo[a] != n->hi[a])
            return 0;
    } else if (b->hi[a] != n->lo[a]) {
        return 0;
    }
    for (uint32_t k = 0; k < 3; ++k)
        if (k != a && (b->lo[k] > n->lo[k] || b->hi[k] < n->hi[k]))
            return 0;
    return 1;
}

static void check_ropes(vis_context *ctx, const float size[3], uint32_t kd_depth)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    memcpy(d.size, size, sizeof d.size);
    d.kd_depth = kd_depth;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    assert_int_equal(vis_kdtree_build_ropes(s, ctx), VIS_OK);
    node_box *box = calloc(s->node_count, sizeof *box);
    uint32_t *height = calloc(s->node_count, sizeof *height);
    float zero[3] = {0, 0, 0};
    collect_boxes(s, 0, zero, d.size, 0, box, height);
    uint32_t entries = 0, leaf_depth_min = 99, leaf_depth_max = 0;
    for (uint32_t node = 0; node < s->node_count; ++node) {
        uint32_t info = s->nodes[node].info, e = s->rope_index[node];
        int leaf = (info & 3u) == VIS_NODE_LEAF;
        if (leaf) {
            leaf_depth_min = box[node].depth < leaf_depth_min ? box[node].depth : leaf_depth_min;
            leaf_depth_max = box[node].depth > leaf_depth_max ? box[node].depth : leaf_depth_max;
            assert_int_equal(e, info >> 2); /* leaf i is entry i */
            /* the leaf's box is the traced one, bit for bit */
            assert_memory_equal(s->leaves[info >> 2].lo, box[node].lo, 12);
            assert_memory_equal(s->leaves[info >> 2].hi, box[node].hi, 12);
        }
        if (height[node] > VIS_MAX_SHORT_STACK) {
            assert_int_equal(e, VIS_NO_ROPE);
            continue;
        }
        assert_true(e < s->rope_count);
        ++entries;
        const vis_rope_node *rn = &s->ropes[e];
        assert_int_equal(rn->node, node);
        assert_int_equal(rn->height, height[node]);
        assert_memory_equal(rn->lo, box[node].lo, 12);
        assert_memory_equal(rn->hi, box[node].hi, 12);
        for (uint32_t f = 0; f < 6; ++f) {
            uint32_t a = f >> 1;
            int boundary = (f & 1u) ? box[node].hi[a] == d.size[a] : box[node].lo[a] == 0.0f;
            uint32_t l = rn->link[f];
            if (boundary) {
                if (l != VIS_NO_ROPE)
                    fail_msg("node %u face %u lies on the scene boundary but links to %u", node, f, l);
                continue;
            }
            if (l == VIS_NO_ROPE || l >= s->node_count)
                fail_msg("node %u face %u: no neighbour link (%u)", node, f, l);
            if (!covers_face(&box[l], &box[node], f))
                fail_msg("node %u face %u: link %u does not cover the face", node, f, l);
            assert_true(box[l].depth <= box[node].depth);
            /* the smallest such node: no child of it (within the depth) covers the face */
            uint32_t li = s->nodes[l].info;
            if ((li & 3u) != VIS_NODE_LEAF && box[l].depth < box[node].depth) {
                assert_false(covers_face(&box[li >> 2], &box[node], f));
                assert_false(covers_face(&box[(li >> 2) + 1], &box[node], f));
            }
        }
    }
    assert_int_equal(entries, s->rope_count);
    vis_scene_stats info;
    assert_int_equal(vis_scene_get_stats(s, &info), VIS_OK);
    assert_true(info.rope_bytes == (uint64_t)s->rope_count * sizeof(vis_rope_node) + (uint64_t)s->node_count * 4u);
    assert_true(info.rope_bytes_used[0] == (uint64_t)s->leaf_count * sizeof(vis_rope_node));
    for (uint32_t n = 1; n <= VIS_MAX_SHORT_STACK; ++n) {
        assert_true(info.rope_bytes_used[n] <= info.rope_bytes_used[n - 1]);
        if (leaf_depth_min == leaf_depth_max) { /* one leaf depth: exactly the nodes n levels up */
            uint32_t level = leaf_depth_max > n ? leaf_depth_max - n : 0, at = 0;
            for (uint32_t node = 0; node < s->node_count; ++node)
                at += box[node].depth == level;
            assert_true(info.rope_bytes_used[n] == (uint64_t)at * sizeof(vis_rope_node));
        }
    }
    free(box);
    free(height);
    vis_scene_destroy(s);
}

static void test_ropes_definition(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    const float sizes[][3] = {{64, 32, 64}, {48, 32, 80}, {16, 16, 16}, {512, 128, 512}, {100, 40, 70}, {16, 16, 400}};
    const uint32_t depths[] = {0, 2, 5};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; ++i)
        for (size_t k = 0; k < sizeof depths / sizeof depths[0]; ++k)
            check_ropes(ctx, sizes[i], depths[k]);
    vis_context_destroy(ctx);
}

/* ---- input --------------------------------------------------------------------------------- */

static void test_desc_validation(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    tworld w;
    wall_world_quads(&w);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{1, 20, 1}, {16, 0, 16}, 60, 0.1, 100};
    uint32_t ids[16];
    for (int i = 0; i < 16; ++i)
        ids[i] = 0xABCDABCD;
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    assert_int_equal(td.traversal, VIS_TRAVERSAL_AUTO);
    assert_int_equal(td.short_stack, 4);
    td.width = td.height = 4;
    td.traversal = VIS_TRAVERSAL_SHORTSTACK;
    td.short_stack = VIS_MAX_SHORT_STACK + 1;
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, 16, NULL, 0), VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(ctx), "short_stack"));
    td.traversal = (vis_traversal)(VIS_TRAVERSAL_DDA + 1);
    td.short_stack = 0;
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, 16, NULL, 0), VIS_ERROR_INVALID_ARGUMENT);
    for (int i = 0; i < 16; ++i)
        assert_int_equal(ids[i], 0xABCDABCD); /* untouched */
    td.traversal = VIS_TRAVERSAL_ROPES_SHORTSTACK; /* 0 = the default N */
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, 16, NULL, 0), VIS_OK);
    td.short_stack = VIS_MAX_SHORT_STACK;
    assert_int_equal(vis_trace(ctx, scene, &cam, &td, ids, 16, NULL, 0), VIS_OK);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- the cell-grid walk against its definition -------------------------------------------
 *
 * vis_traverse_dda must visit every cell whose box passes the slab test within the slack
 * (trace_core.h: max(t0, entries) <= lim(min(t1, exits)), the first and last cell of an axis
 * open towards the scene box, which t0 and t1 already clip; a ray parallel to an axis in the
 * closed slab of the cell), since a quad the brute force takes has its box in such a cell. On
 * an empty scene nothing ends a ray early, so every such cell must be seen. Rays: origins on
 * cell boundaries, on integers, anywhere, inside and outside the scene; directions with zero,
 * equal and random components, and aimed exactly at cell edges and corners. Each cell is
 * visited once (no in-plane ray here visits one twice either: its two walks differ on that
 * axis). */
static int dda_cell_passes(const vis_ray *r, const vis_ray_setup *s, const uint32_t c[3], float t0, float t1)
{
    float in = t0, out = t1;
    for (uint32_t a = 0; a < 3; ++a) {
        float lo = (float)c[a] * s->cell_size, hi = (float)(c[a] + 1u) * s->cell_size;
        int first = c[a] == 0u, last = c[a] + 1u == s->cells[a];
        if (r->d[a] == 0.0f) {
            if ((!first && r->o[a] < lo) || (!last && r->o[a] > hi))
                return 0;
            continue;
        }
        float tlo = first ? (r->d[a] > 0.0f ? -INFINITY : INFINITY) : (lo - r->o[a]) * r->inv[a];
        float thi = last ? (r->d[a] > 0.0f ? INFINITY : -INFINITY) : (hi - r->o[a]) * r->inv[a];
        float e = r->d[a] > 0.0f ? tlo : thi, x = r->d[a] > 0.0f ? thi : tlo;
        if (e > in)
            in = e;
        if (x < out)
            out = x;
    }
    return in <= vis_t_limit(out);
}

static void test_dda_visits_every_passing_cell(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    static const float sizes[][3] = {{80, 48, 64}, {70, 33, 50}, {128, 16, 96}};
    uint64_t rng = 4242;
    int rays = vt_small() ? 20000 : 200000;
    uint64_t checked = 0, passing = 0;
    for (size_t si = 0; si < sizeof sizes / sizeof sizes[0]; ++si) {
        tworld w;
        memset(&w, 0, sizeof w);
        memcpy(w.size, sizes[si], sizeof w.size);
        vis_scene *scene = make_scene(ctx, &w, NULL, 0);
        vis_scene_view v = vis_scene_get_view(scene);
        assert_true(v.cell_map != 0u);
        vis_ray_setup s;
        memset(&s, 0, sizeof s);
        memcpy(s.size, w.size, sizeof s.size);
        s.leaf_count = v.leaf_count;
        memcpy(s.cells, v.cells, sizeof s.cells);
        s.cell_map = v.cell_map;
        s.cell_size = v.cell_size;
        uint32_t ncells = v.cells[0] * v.cells[1] * v.cells[2];
        unsigned char *seen = calloc(ncells, 1);
        for (int i = 0; i < rays; ++i) {
            float o[3], d[3];
            int kind = (int)(vt_rand(&rng) % 4);
            for (int a = 0; a < 3; ++a) {
                double u = vt_rand_unit(&rng);
                double x = vt_rand_unit(&rng) * (w.size[a] + 40.0) - 20.0;
                if (u < 0.4)
                    x = 16.0 * floor(x / 16.0 + 0.5);
                else if (u < 0.7)
                    x = floor(x);
                o[a] = (float)x;
            }
            if (kind == 0) { /* small integer directions: diagonals, zeros */
                int dir[3];
                do {
                    for (int a = 0; a < 3; ++a)
                        dir[a] = (int)(vt_rand(&rng) % 7) - 3;
                } while (!dir[0] && !dir[1] && !dir[2]);
                for (int a = 0; a < 3; ++a)
                    d[a] = (float)dir[a];
            } else if (kind == 1) { /* aimed exactly at a cell edge or corner */
                float p[3];
                for (int a = 0; a < 3; ++a) {
                    double x = vt_rand_unit(&rng) * w.size[a];
                    p[a] = vt_rand(&rng) % 3 ? (float)(16.0 * floor(x / 16.0 + 0.5)) : (float)x;
                    d[a] = p[a] - o[a];
                }
                if (!d[0] && !d[1] && !d[2])
                    d[0] = 1.0f;
            } else { /* random, some components zero */
                for (int a = 0; a < 3; ++a)
                    d[a] = vt_rand(&rng) % 5 == 0 ? 0.0f : (float)(vt_rand_unit(&rng) * 2.0 - 1.0);
                if (!d[0] && !d[1] && !d[2])
                    d[1] = -1.0f;
            }
            double len = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
            vis_ray r;
            for (int a = 0; a < 3; ++a) {
                r.o[a] = o[a];
                r.d[a] = (float)(d[a] / len);
                r.inv[a] = 1.0f / r.d[a];
            }
            r.t_near = vt_rand(&rng) % 4 ? 0.0f : (float)(vt_rand_unit(&rng) * 30.0);
            r.t_far = vt_rand(&rng) % 3 ? INFINITY : r.t_near + (float)(vt_rand_unit(&rng) * 60.0);
            memset(seen, 0, ncells);
            g_dda_seen = seen;
            g_dda_base = v.cell_map;
            vis_hit h = {INFINITY, VIS_NO_OBJECT, 0};
            vis_traverse_dda(&r, &s, VIS_SCENE_VIEW_ARGS(&v), &h);
            g_dda_seen = NULL;
            float t0, t1;
            int in_scene = vis_clip_scene(&r, s.size, &t0, &t1);
            for (uint32_t c = 0; c < ncells; ++c) {
                uint32_t cc[3] = {c % v.cells[0], c / v.cells[0] % v.cells[1], c / (v.cells[0] * v.cells[1])};
                ++checked;
                if (seen[c] > 1)
                    fail_msg("size %zu, ray %d o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g): cell (%u,%u,%u) visited %u "
                             "times",
                             si, i, (double)r.o[0], (double)r.o[1], (double)r.o[2], (double)r.d[0], (double)r.d[1],
                             (double)r.d[2], cc[0], cc[1], cc[2], seen[c]);
                if (!in_scene || !dda_cell_passes(&r, &s, cc, t0, t1))
                    continue;
                ++passing;
                if (!seen[c])
                    fail_msg("size %zu, ray %d o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) near %g far %g: cell (%u,%u,%u) "
                             "passes the slab test but was not visited",
                             si, i, (double)r.o[0], (double)r.o[1], (double)r.o[2], (double)r.d[0], (double)r.d[1],
                             (double)r.d[2], (double)r.t_near, (double)r.t_far, cc[0], cc[1], cc[2]);
            }
        }
        free(seen);
        vis_scene_destroy(scene);
    }
    print_message("dda: %llu cell checks, %llu passing cells, all visited once\n", (unsigned long long)checked,
                  (unsigned long long)passing);
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_ropes_definition),
        cmocka_unit_test(test_desc_validation),
        cmocka_unit_test(test_hard_cases),
        cmocka_unit_test(test_degenerate_rays),
        cmocka_unit_test(test_subnormal_directions),
        cmocka_unit_test(test_aimed_at_chunk_edges),
        cmocka_unit_test(test_aimed_at_lone_quad_edges),
        cmocka_unit_test(test_aimed_at_content_box_edges),
        cmocka_unit_test(test_content_box_spanning_the_leaf),
        cmocka_unit_test(test_checkerboard_views),
        cmocka_unit_test(test_closed_room_ties_inside_solid),
        cmocka_unit_test(test_random_worlds),
        cmocka_unit_test(test_edits_between_passes),
        cmocka_unit_test(test_packet_occupancy_follows_edits),
        cmocka_unit_test(test_node_fills_hold_their_leaves),
        cmocka_unit_test(test_far_origin_and_leaf_ids),
        cmocka_unit_test(test_dda_visits_every_passing_cell),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
