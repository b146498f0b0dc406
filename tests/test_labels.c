/* test_labels.c — the CPU backend's voxel labels (backends/cpu/labels.c) and the label walk
 * that reads them (trace_core.h, vis_label_walk).
 *
 * - Every block against the definition, voxel by voxel: its loud bits are exactly the voxels
 *   that some quad of the leaf touches (square, edge or corner; quads without area too), and
 *   two loud face-neighbours have different labels exactly where a quad covers the square
 *   between them. A leaf without a block must be one that the rules exclude or whose quads
 *   admit no two-labelling (checked by a breadth-first colouring).
 * - The label walk against the plane walk, ray by ray, on random worlds and rays aimed at
 *   voxel edges and corners, from eyes on split and voxel planes: the same hit, bit for bit.
 * - Edits: the blocks after partial syncs equal a fresh build's, and the array stays within
 *   a bound of what the leaves need.
 * - Without memory: no labels, no retry until the next full sync. */
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
#include "cpu/labels.h"
#include "scene.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

static vis_labels labels_of(const vis_scene_view *v)
{
    vis_labels lab;
    assert_int_equal(vt_labels_build(&lab, v), VIS_OK);
    return lab;
}

/* ---- blocks against the definition ------------------------------------------------------- */

#define VOX(x, y, z) ((x) + 16 * ((y) + 16 * (z)))

typedef struct leaf_ref {
    uint8_t loud[4096];
    uint8_t cover[3][17][16][16]; /* [axis][plane][u][v]: a quad covers that square */
} leaf_ref;

/* The definition, quad by quad, from the leaf's packed words. */
static void reference(const vis_scene_view *v, const vis_flat_leaf *lf, leaf_ref *ref)
{
    memset(ref, 0, sizeof *ref);
    const uint32_t *bk = v->buckets + lf->bucket_offset, *packed = v->quads + lf->quad_offset;
    for (int a = 0; a < 3; ++a)
        for (int k = 0; k <= 16; ++k)
            for (uint32_t q = bk[17 * a + k]; q < bk[17 * a + k + 1]; ++q) {
                uint32_t w = packed[q];
                int u0 = (int)VIS_PQ_FIELD(w, 0u), v0 = (int)VIS_PQ_FIELD(w, 1u);
                int u1 = (int)VIS_PQ_FIELD(w, 2u), v1 = (int)VIS_PQ_FIELD(w, 3u);
                for (int u = u0; u < u1 && u < 16; ++u)
                    for (int vv = v0; vv < v1 && vv < 16; ++vv)
                        ref->cover[a][k][u][vv] = 1;
                /* Touching: the closed rectangle meets the closed face of a voxel beside the plane. */
                for (int side = k - 1; side <= k; ++side)
                    for (int u = u0 - 1; u <= u1; ++u)
                        for (int vv = v0 - 1; vv <= v1; ++vv) {
                            if (side < 0 || side > 15 || u < 0 || u > 15 || vv < 0 || vv > 15)
                                continue;
                            int x = a == 0 ? side : a == 1 ? vv : u;
                            int y = a == 0 ? u : a == 1 ? side : vv;
                            int z = a == 0 ? vv : a == 1 ? u : side;
                            ref->loud[VOX(x, y, z)] = 1;
                        }
            }
}

/* Whether the interior planes admit two labels (breadth-first from voxel 0). */
static int colourable(const leaf_ref *ref)
{
    int8_t col[4096];
    int queue[4096], head = 0, tail = 0;
    memset(col, -1, sizeof col);
    col[0] = 0;
    queue[tail++] = 0;
    while (head < tail) {
        int c = queue[head++], x = c % 16, y = c / 16 % 16, z = c / 256;
        for (int a = 0; a < 3; ++a) {
            int p[3] = {x, y, z};
            if (++p[a] > 15)
                continue;
            int n = VOX(p[0], p[1], p[2]);
            int u = a == 0 ? y : a == 1 ? z : x, vv = a == 0 ? z : a == 1 ? x : y;
            int want = col[c] ^ ref->cover[a][p[a]][u][vv];
            if (col[n] < 0) {
                col[n] = (int8_t)want;
                queue[tail++] = n;
            } else if (col[n] != want) {
                return 0;
            }
        }
        for (int a = 0; a < 3; ++a) { /* the neighbour below, for voxels reached from above */
            int p[3] = {x, y, z};
            if (--p[a] < 0)
                continue;
            int n = VOX(p[0], p[1], p[2]);
            int u = a == 0 ? y : a == 1 ? z : x, vv = a == 0 ? z : a == 1 ? x : y;
            int want = col[c] ^ ref->cover[a][p[a] + 1][u][vv];
            if (col[n] < 0) {
                col[n] = (int8_t)want;
                queue[tail++] = n;
            } else if (col[n] != want) {
                return 0;
            }
        }
    }
    return 1;
}

/* Voxel c's loud bit and label from a block. */
static void block_voxel(const uint32_t *b, int c, int *loud, int *label)
{
    uint32_t bit = (uint32_t)c, j = VIS_LW_BRICK(bit), in = VIS_LW_BIT(bit);
    uint64_t L = vis_lw_u64(b), X = vis_lw_u64(b + 2), U = vis_lw_u64(b + 4), below = (1ull << j) - 1u;
    *loud = 0;
    *label = -1;
    if (!(L >> j & 1u))
        return;
    const uint32_t *lw = b + VIS_LW_HEADER + 2u * vis_popcount64(L & below);
    *loud = (int)(vis_lw_u64(lw) >> in & 1u);
    if (X >> j & 1u)
        *label = (int)(vis_lw_u64(b + VIS_LW_HEADER + 2u * vis_popcount64(L) + 2u * vis_popcount64(X & below)) >> in & 1u);
    else
        *label = (int)(U >> j & 1u);
}

static int qualifies(const vis_scene_view *v, const vis_flat_leaf *lf)
{
    if (lf->quad_count == 0u || lf->dims_xy != (16u | 16u << 16) || lf->dims_z != 16u || lf->loose_count ||
        lf->tri_count || lf->quad_offset - lf->table_offset != 1u)
        return 0;
    for (uint32_t q = 0; q < lf->quad_count; ++q)
        if (VIS_PQ_FLAGS(v->quads[lf->quad_offset + q]) || VIS_PQ_TABLE(v->quads[lf->quad_offset + q]))
            return 0;
    return 1;
}

/* Checks every leaf of the scene's view; returns the leaves with a block. */
static uint32_t check_blocks(vis_scene *s, const char *what)
{
    vis_scene_view v = vis_scene_get_view(s);
    vis_labels lab = labels_of(&v);
    static leaf_ref ref;
    uint32_t labelled = 0;
    for (uint32_t li = 0; li < v.leaf_count; ++li) {
        const vis_flat_leaf *lf = &v.leaves[li];
        const uint32_t *b = vis_leaf_labels(lab.words, li);
        if (!qualifies(&v, lf)) {
            if (b)
                fail_msg("%s: leaf %u has a block but the rules exclude it", what, li);
            continue;
        }
        reference(&v, lf, &ref);
        if (!b) {
            if (colourable(&ref))
                fail_msg("%s: leaf %u admits two labels but has no block", what, li);
            continue;
        }
        ++labelled;
        uint32_t words = vis_labels_block_words(b);
        uint32_t again[VIS_LABELS_MAX_BLOCK];
        assert_int_equal(vis_labels_build_leaf(lf, v.buckets, v.quads, again), words);
        assert_memory_equal(again, b, words * sizeof *b);
        for (int c = 0; c < 4096; ++c) {
            int loud, label;
            block_voxel(b, c, &loud, &label);
            if (loud != ref.loud[c])
                fail_msg("%s: leaf %u voxel (%d,%d,%d): loud %d, the definition %d", what, li, c % 16, c / 16 % 16,
                         c / 256, loud, ref.loud[c]);
        }
        for (int c = 0; c < 4096; ++c) {
            int x = c % 16, y = c / 16 % 16, z = c / 256, loud, label;
            block_voxel(b, c, &loud, &label);
            for (int a = 0; a < 3 && loud; ++a) {
                int p[3] = {x, y, z};
                if (++p[a] > 15)
                    continue;
                int nloud, nlabel;
                block_voxel(b, VOX(p[0], p[1], p[2]), &nloud, &nlabel);
                int u = a == 0 ? y : a == 1 ? z : x, vv = a == 0 ? z : a == 1 ? x : y;
                if (nloud && (label != nlabel) != ref.cover[a][p[a]][u][vv])
                    fail_msg("%s: leaf %u voxels (%d,%d,%d) +axis %d: labels %d %d, square covered %d", what, li, x, y,
                             z, a, label, nlabel, ref.cover[a][p[a]][u][vv]);
            }
        }
    }
    assert_int_equal(labelled, lab.labelled);
    vis_labels_free(&lab);
    return labelled;
}

/* Chunk objects of up to five voxel boxes (faces pushed to the chunk's boundary now and
 * then), ties and entities as random_chunk_world_opts adds them: leaves of one object, of
 * several, with loose quads and triangles. */
static const chunk_world_opts busy_world = {0.2, 5, 0.3, 1, 2, 0};

/* A random world of nx x ny x nz chunks as busy_world makes them, and its scene. */
static vis_scene *busy_scene(vis_context *ctx, uint64_t *rng, int nx, int ny, int nz, tworld *w)
{
    random_chunk_world_opts(w, rng, nx, ny, nz, &busy_world);
    return make_scene(ctx, w, NULL, 0);
}

/* Chunk object c of a random world (ID 1 + chunk index), or NULL if that chunk is empty. */
static tobj *chunk_obj(tworld *w, int nx, int ny, const int c[3])
{
    uint32_t id = 1u + (uint32_t)(c[0] + nx * (c[1] + ny * c[2]));
    for (uint32_t i = 0; i < w->n; ++i)
        if (w->objs[i].id == id)
            return &w->objs[i];
    return NULL;
}

static void test_blocks_match_definition(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 4242;
    uint32_t labelled = 0;
    for (int round = 0; round < 4; ++round) {
        tworld w;
        random_chunk_world_opts(&w, &rng, 6, 2, 5, &busy_world);
        /* In some chunk objects: quads without area, one reaching past the chunk, and one on
         * each of two boundary planes. */
        for (int c0 = 0; c0 < 6; c0 += 2) {
            int c[3] = {c0, round % 2, (c0 + round) % 5};
            tobj *o = chunk_obj(&w, 6, 2, c);
            if (!o)
                continue;
            float x = 16.0f * (float)c[0], y = 16.0f * (float)c[1], z = 16.0f * (float)c[2];
            obj_quad(o, 0, x + 5.0f, y + 3.0f, z + 4.0f, y + 3.0f, z + 9.0f);  /* no width */
            obj_quad(o, 1, y + 7.0f, z + 2.0f, x + 2.0f, z + 2.0f, x + 2.0f);  /* a point */
            obj_quad(o, 2, z + 16.0f, x + 1.0f, y + 1.0f, x + 15.0f, y + 9.0f); /* the far z boundary */
            obj_quad(o, 0, x, y + 2.0f, z + 2.0f, y + 14.0f, z + 5.0f);         /* the near x boundary */
            /* An open quad inside leaves no two-labelling (a loop around its edge crosses it
             * once): every other round only, so that the boundary quads above are checked in
             * labelled leaves too. */
            if (round % 2)
                obj_quad(o, 1, y + 11.0f, z + 3.0f, x + 3.0f, z + 6.0f, x + 6.0f);
        }
        vis_scene *s = make_scene(ctx, &w, NULL, 0);
        char what[64];
        snprintf(what, sizeof what, "random world %d", round);
        labelled += check_blocks(s, what);
        vis_scene_destroy(s);
        free_world(&w);
    }
    assert_true(labelled > 100); /* not vacuous: most chunk leaves take the walk */
    vis_context_destroy(ctx);
}

/* ---- the label walk against the plane walk ------------------------------------------------- */

static void trace_both(const vis_scene_view *plain, const vis_scene_view *lab, const vis_ray_setup *s,
                       const vis_ray *r, uint32_t method, const char *what, int i)
{
    vis_hit a = {INFINITY, VIS_NO_OBJECT, 0u}, b = a;
    if (method == VIS_TRAVERSAL_ID_DDA) {
        vis_traverse_dda(r, s, VIS_SCENE_VIEW_ARGS(plain), &a);
        vis_traverse_dda(r, s, VIS_SCENE_VIEW_ARGS(lab), &b);
    } else {
        vis_traverse_stack(r, s, VIS_SCENE_VIEW_ARGS(plain), &a);
        vis_traverse_stack(r, s, VIS_SCENE_VIEW_ARGS(lab), &b);
    }
    /* Bit for bit, but for the sign of a zero distance (test_traversal.c, same_distance). */
    if (a.id != b.id || a.object != b.object || (memcmp(&a.t, &b.t, sizeof a.t) != 0 && !(a.t == 0.0f && b.t == 0.0f)))
        fail_msg("%s ray %d (method %u) o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g): planes id %u t %.9g, labels id %u t %.9g",
                 what, i, method, (double)r->o[0], (double)r->o[1], (double)r->o[2], (double)r->d[0], (double)r->d[1],
                 (double)r->d[2], a.id, (double)a.t, b.id, (double)b.t);
}

/* A ray from an eye on split planes, voxel planes or anywhere, at a voxel edge or corner of
 * the world or a random point. */
static void walk_ray(uint64_t *rng, const float size[3], vis_ray *r)
{
    float o[3], target[3], d[3];
    for (int a = 0; a < 3; ++a) {
        double u = vt_rand_unit(rng), x = vt_rand_unit(rng) * (size[a] + 24.0) - 12.0;
        o[a] = (float)(u < 0.3 ? 16.0 * floor(x / 16.0 + 0.5) : u < 0.6 ? floor(x) : u < 0.7 ? floor(x) + 0.5 : x);
        double t = vt_rand_unit(rng) * size[a];
        double e = vt_rand_unit(rng);
        target[a] = (float)(e < 0.5 ? floor(t) : e < 0.6 ? floor(t) + 1e-4 * (vt_rand_unit(rng) - 0.5) : t);
        d[a] = target[a] - o[a];
    }
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f)
        d[1] = -1.0f;
    if (vt_rand_unit(rng) < 0.15) /* level with an axis: a walk along one voxel plane or inside */
        d[vt_rand(rng) % 3] = 0.0f;
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f)
        d[0] = 1.0f;
    float len = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int a = 0; a < 3; ++a) {
        r->o[a] = o[a];
        r->d[a] = d[a] / len;
        r->inv[a] = 1.0f / r->d[a];
    }
    r->t_near = vt_rand_unit(rng) < 0.2 ? 0.0f : 0.05f;
    r->t_far = vt_rand_unit(rng) < 0.2 ? 20.0f : INFINITY;
}

static void test_walk_equals_plane_walk(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 777;
    int rays = vt_small() ? 20000 : 100000;
    for (int round = 0; round < 3; ++round) {
        tworld w;
        vis_scene *s = busy_scene(ctx, &rng, 6, 2, 5, &w);
        vis_scene_view plain = vis_scene_get_view(s), lv = plain;
        vis_labels lab = labels_of(&plain);
        assert_true(lab.labelled > 5);
        lv.labels = lab.words;
        vis_ray_setup setup;
        memset(&setup, 0, sizeof setup);
        memcpy(setup.size, w.size, sizeof setup.size);
        setup.leaf_count = plain.leaf_count;
        memcpy(setup.cells, plain.cells, sizeof setup.cells);
        setup.cell_map = plain.cell_map;
        setup.cell_size = plain.cell_size;
        for (int i = 0; i < rays; ++i) {
            vis_ray r;
            walk_ray(&rng, w.size, &r);
            trace_both(&plain, &lv, &setup, &r, i % 2 ? VIS_TRAVERSAL_ID_DDA : VIS_TRAVERSAL_ID_STACK, "random world", i);
        }
        vis_labels_free(&lab);
        vis_scene_destroy(s);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* ---- edits ------------------------------------------------------------------------------- */

/* Every leaf's block as a fresh build of the view makes it, and the count of labelled leaves;
 * returns the words the offsets and the live blocks take. */
static size_t check_blocks_fresh(const vis_labels *lab, const vis_scene_view *v)
{
    uint32_t labelled = 0;
    size_t live = (size_t)v->leaf_count + 1u;
    for (uint32_t li = 0; li < v->leaf_count; ++li) {
        uint32_t fresh[VIS_LABELS_MAX_BLOCK];
        uint32_t n = vis_labels_build_leaf(&v->leaves[li], v->buckets, v->quads, fresh);
        const uint32_t *b = vis_leaf_labels(lab->words, li);
        assert_int_equal(n != 0, b != NULL);
        if (n) {
            assert_memory_equal(fresh, b, n * sizeof *fresh);
            ++labelled;
            live += n;
        }
    }
    assert_int_equal(labelled, lab->labelled);
    return live;
}

/* One draw of an edit of busy_scene(6, 2, 5): a chunk object replaced by other boxes, so its
 * leaf's block changes size (the ties and entities span leaves and are left alone: 0 then).
 * *ch gets the scene's changed leaves. */
static int edit_a_chunk(vis_scene *s, tworld *w, uint64_t *rng, vis_scene_changes *ch)
{
    tobj *o = &w->objs[vt_rand(rng) % w->n];
    if (o->id >= 100000)
        return 0;
    int c[3] = {(int)((o->id - 1) % 6), (int)((o->id - 1) / 6 % 2), (int)((o->id - 1) / 12)};
    obj_clear(o);
    obj_chunk_boxes(o, rng, c, &busy_world);
    set_obj(s, o);
    memset(ch, 0, sizeof *ch);
    ch->leaves = s->dirty_leaves;
    ch->leaf_count = s->dirty_leaf_count;
    return 1;
}

static void test_edits_keep_blocks_current(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 99;
    tworld w;
    vis_scene *s = busy_scene(ctx, &rng, 6, 2, 5, &w);
    vis_scene_view v = vis_scene_get_view(s);
    vis_labels lab = labels_of(&v);
    size_t most = 0;
    int compactions = 0;
    for (int e = 0; e < 400; ++e) {
        vis_scene_changes ch;
        if (!edit_a_chunk(s, &w, &rng, &ch))
            continue;
        v = vis_scene_get_view(s);
        size_t stale = lab.stale;
        assert_int_equal(vis_labels_sync(&lab, &v, &ch, UINT64_MAX, NULL, NULL), VIS_OK);
        compactions += lab.stale < stale;
        most = lab.cap > most ? lab.cap : most;
    }
    size_t live = check_blocks_fresh(&lab, &v);
    assert_true(compactions > 0);
    /* Bounded: stale blocks at most an eighth of the array, and growth by half again. */
    assert_true(lab.used <= live + live / 7u + VIS_LABELS_MAX_BLOCK);
    assert_true(most <= 2u * (live + live / 7u + VIS_LABELS_MAX_BLOCK));
    vis_labels_free(&lab);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Edits under a limit a little above what the blocks need: the blocks left behind are copied
 * out whenever they are what keeps a new block from the limit, so the labels stay (and stay
 * current) through every edit, and the array never passes the limit. */
static void test_edits_within_a_tight_limit(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 7;
    tworld w;
    vis_scene *s = busy_scene(ctx, &rng, 6, 2, 5, &w);
    vis_scene_view v = vis_scene_get_view(s);
    vis_labels lab = labels_of(&v);
    int compactions = 0, edits = 0;
    for (int e = 0; e < 300; ++e) {
        vis_scene_changes ch;
        if (!edit_a_chunk(s, &w, &rng, &ch))
            continue;
        v = vis_scene_get_view(s);
        vis_labels fresh = labels_of(&v);
        uint64_t limit = (uint64_t)(fresh.used + VIS_LABELS_MAX_BLOCK) * sizeof(uint32_t);
        vis_labels_free(&fresh);
        size_t stale = lab.stale;
        assert_int_equal(vis_labels_sync(&lab, &v, &ch, limit, NULL, NULL), VIS_OK);
        assert_true(vis_labels_bytes(&lab) <= limit);
        compactions += lab.stale < stale;
        ++edits;
    }
    assert_true(edits > 100 && compactions > 0);
    check_blocks_fresh(&lab, &v);
    vis_labels_free(&lab);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- without memory ------------------------------------------------------------------------ */

typedef struct gate {
    int open;      /* 0: every allocation fails */
    unsigned calls;
} gate;

static void *gate_alloc(size_t size, size_t align, void *user)
{
    gate *g = user;
    g->calls++;
    if (!g->open)
        return NULL;
    size_t rounded = (size + align - 1) / align * align;
    return aligned_alloc(align, rounded ? rounded : align);
}

static void gate_free(void *p, void *user)
{
    (void)user;
    free(p);
}

/* Labels whose allocations pass through a gate (open or shut), and the two syncs the tests
 * drive them with: a full one, and a partial one of leaf 0. */
typedef struct gated_labels {
    gate g;
    vis_allocator a;
    vis_labels lab;
    vis_scene_changes full, part;
    uint32_t leaf;
} gated_labels;

static void gated_labels_init(gated_labels *f, int open)
{
    memset(f, 0, sizeof *f);
    f->g.open = open;
    f->a = (vis_allocator){gate_alloc, gate_free, &f->g};
    f->lab.alloc = &f->a;
    f->full.full = 1;
    f->part.leaves = &f->leaf;
    f->part.leaf_count = 1;
}

/* A build without memory leaves no labels and says so once: the partial syncs after it do not
 * try again (the plane walk traces meanwhile); a full sync does, and then succeeds. */
static void test_no_memory_no_labels(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 5;
    tworld w;
    vis_scene *s = busy_scene(ctx, &rng, 4, 2, 3, &w);
    vis_scene_view v = vis_scene_get_view(s);
    gated_labels f;
    gated_labels_init(&f, 0);
    gate *g = &f.g;
    vis_labels *lab = &f.lab;
    const vis_scene_changes *full = &f.full, *part = &f.part;
    assert_int_equal(vis_labels_sync(lab, &v, full, UINT64_MAX, NULL, NULL), VIS_ERROR_OUT_OF_MEMORY);
    assert_true(lab->failed && !lab->words && lab->labelled == 0);
    unsigned calls = g->calls;
    assert_int_equal(vis_labels_sync(lab, &v, part, UINT64_MAX, NULL, NULL), VIS_ERROR_OUT_OF_MEMORY);
    assert_int_equal(g->calls, calls); /* no retry on a partial sync */
    g->open = 1;
    assert_int_equal(vis_labels_sync(lab, &v, full, UINT64_MAX, NULL, NULL), VIS_OK);
    assert_true(!lab->failed && lab->words && lab->labelled > 0);
    vis_labels_free(lab);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- held to a limit -------------------------------------------------------------------- */

/* The array never takes more than the sync allows: a build that fits is copied out to at most
 * the limit, one that does not leaves no labels (VIS_ERROR_BUDGET), a partial sync retries
 * only once the limit has grown by an eighth, and a limit that shrinks under the array
 * copies it out to its size or drops it. */
static void test_labels_held_to_max_bytes(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    uint64_t rng = 17;
    tworld w;
    vis_scene *s = busy_scene(ctx, &rng, 4, 2, 3, &w);
    vis_scene_view v = vis_scene_get_view(s);
    vis_labels free_lab = labels_of(&v);
    uint64_t need = (uint64_t)free_lab.used * sizeof(uint32_t); /* the blocks and offsets */
    assert_true(free_lab.labelled > 0 && free_lab.cap > free_lab.used);
    gated_labels f;
    gated_labels_init(&f, 1);
    gate *g = &f.g;
    vis_labels *lab = &f.lab;
    const vis_scene_changes *full = &f.full, *part = &f.part;
    /* Exactly what the blocks need: built, and copied out to no more. */
    assert_int_equal(vis_labels_sync(lab, &v, full, need, NULL, NULL), VIS_OK);
    assert_int_equal(lab->labelled, free_lab.labelled);
    assert_true(vis_labels_bytes(lab) <= need);
    assert_memory_equal(lab->words, free_lab.words, free_lab.used * sizeof *lab->words);
    /* One word less: none, and said so. */
    assert_int_equal(vis_labels_sync(lab, &v, full, need - 4u, NULL, NULL), VIS_ERROR_BUDGET);
    assert_true(lab->failed == VIS_ERROR_BUDGET && !lab->words && lab->labelled == 0 && vis_labels_bytes(lab) == 0);
    /* Partial syncs: no retry until the room has grown by more than an eighth. */
    unsigned calls = g->calls;
    assert_int_equal(vis_labels_sync(lab, &v, part, need - 4u, NULL, NULL), VIS_ERROR_BUDGET);
    assert_int_equal(vis_labels_sync(lab, &v, part, need - 4u + (need - 4u) / 8u, NULL, NULL), VIS_ERROR_BUDGET);
    assert_int_equal(g->calls, calls);
    assert_int_equal(vis_labels_sync(lab, &v, part, 2u * need, NULL, NULL), VIS_OK);
    assert_true(!lab->failed && lab->labelled == free_lab.labelled && vis_labels_bytes(lab) <= 2u * need);
    /* Built without a limit (a sixteenth of room), then the limit shrinks: copied out to the
     * blocks' size, then, one word short of it, dropped. */
    assert_int_equal(vis_labels_sync(lab, &v, full, UINT64_MAX, NULL, NULL), VIS_OK);
    assert_true(vis_labels_bytes(lab) > need);
    assert_int_equal(vis_labels_sync(lab, &v, part, need, NULL, NULL), VIS_OK);
    assert_true(lab->labelled == free_lab.labelled && vis_labels_bytes(lab) == need);
    assert_int_equal(vis_labels_sync(lab, &v, part, need - 4u, NULL, NULL), VIS_ERROR_BUDGET);
    assert_true(lab->failed && !lab->words && lab->labelled == 0);
    /* Without memory the failure is VIS_ERROR_OUT_OF_MEMORY, and the room rule retries it only
     * where the limit grew (here it is unlimited: never, until a full sync). */
    g->open = 0;
    assert_int_equal(vis_labels_sync(lab, &v, full, UINT64_MAX, NULL, NULL), VIS_ERROR_OUT_OF_MEMORY);
    g->open = 1;
    calls = g->calls;
    assert_int_equal(vis_labels_sync(lab, &v, part, UINT64_MAX, NULL, NULL), VIS_ERROR_OUT_OF_MEMORY);
    assert_int_equal(g->calls, calls);
    vis_labels_free(lab);
    vis_labels_free(&free_lab);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_blocks_match_definition),
        cmocka_unit_test(test_walk_equals_plane_walk),
        cmocka_unit_test(test_edits_keep_blocks_current),
        cmocka_unit_test(test_edits_within_a_tight_limit),
        cmocka_unit_test(test_no_memory_no_labels),
        cmocka_unit_test(test_labels_held_to_max_bytes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
