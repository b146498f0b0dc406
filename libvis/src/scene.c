/* scene.c — objects and in-place leaf updates.
 *
 * The tree never changes after vis_scene_create (kdtree.c). An edit replaces one object's
 * primitives and rewrites only the leaves that reference it: each leaf owns a slot in the
 * primitive pools with spare capacity (desc.leaf_slack, rounded up to a size class); a leaf
 * that outgrows its slot moves to a free slot of the new size, or to the end of the pool
 * (vis_scene_stats.relocations), and its old slot is free for the next leaf of that size
 * (slot_free.h) — the tree is untouched.
 * Within a slot, quads on integer planes are packed into one word each and sorted into
 * (axis, plane) buckets so the traversal can visit planes in ray order (trace_core.h,
 * vis_flat_leaf); an object inside one leaf keeps no other copy of its quads. An edit's growth in bytes is
 * computed before anything changes (set_object_growth) and held to desc.max_bytes, so a
 * refused edit leaves the scene as it was.
 */
#include "scene.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "kdtree.h"

/* ---- small dynamic arrays ----------------------------------------------------------- */

/* The capacity grow() gives an array of capacity cap that must hold need: cap when it
 * suffices, else the first of cap, cap * 3/2 + 16, ... (from 16 when cap is 0) that does,
 * growing by 1/8 instead once past 2^14 entries (the primitive pools of large scenes: spare
 * capacity is memory the scene holds, and one more copy of a large array every 1/8 is still
 * linear time in all); 0 when need is beyond 32-bit counts. Growing one array several times
 * ends where growing it once to the largest need ends: every growth steps along the same
 * sequence. */
static uint64_t grown_cap(uint32_t cap, uint64_t need)
{
    if (need <= cap)
        return cap;
    uint64_t n = cap ? cap : 16;
    while (n < need)
        n = n < ((uint64_t)1 << 14) ? n * 3 / 2 + 16 : n + n / 8;
    if (n > 0xFFFFFFF0u)
        n = 0xFFFFFFF0u;
    return n < need ? 0 : n;
}

/* Bytes that growing an array of `elem`-byte elements from cap to hold need adds;
 * UINT64_MAX when it cannot grow that far. */
static uint64_t growth(uint32_t cap, uint64_t need, uint64_t elem)
{
    if (need <= cap)
        return 0;
    uint64_t n = grown_cap(cap, need);
    return n == 0 ? UINT64_MAX : (n - cap) * elem;
}

static int grow(vis_context *ctx, void **ptr, uint32_t *cap, uint32_t need, size_t elem)
{
    if (need <= *cap)
        return 1;
    uint64_t n = grown_cap(*cap, need);
    if (n == 0)
        return 0;
    void *p = vis_realloc(ctx, *ptr, (size_t)*cap * elem, (size_t)n * elem);
    if (!p)
        return 0;
    *ptr = p;
    *cap = (uint32_t)n;
    return 1;
}

/* ---- ID map: open addressing, ID -> slot + 1 ------------------------------------------ */

uint32_t vis_scene_find(const vis_scene *s, uint32_t id)
{
    if (!s->id_map_cap || id == 0)
        return VIS_NO_OBJECT;
    uint32_t mask = s->id_map_cap - 1;
    for (uint32_t i = vis_hash_u32(id) & mask;; i = (i + 1) & mask) {
        uint32_t v = s->id_map[i];
        if (v == 0)
            return VIS_NO_OBJECT;
        if (s->objects[v - 1].id == id)
            return v - 1;
    }
}

static int map_insert_raw(uint32_t *map, uint32_t cap, const vis_flat_object *objects, uint32_t slot)
{
    uint32_t mask = cap - 1;
    for (uint32_t i = vis_hash_u32(objects[slot].id) & mask;; i = (i + 1) & mask) {
        if (map[i] == 0) {
            map[i] = slot + 1;
            return 1;
        }
    }
}

static int map_insert(vis_scene *s, uint32_t slot)
{
    if ((uint64_t)(s->object_live + 1) * 2 > s->id_map_cap) {
        uint32_t cap = s->id_map_cap ? s->id_map_cap * 2 : 1024;
        uint32_t *m = vis_calloc(s->ctx, cap, sizeof *m);
        if (!m)
            return 0;
        for (uint32_t i = 0; i < s->id_map_cap; ++i)
            if (s->id_map[i])
                map_insert_raw(m, cap, s->objects, s->id_map[i] - 1);
        vis_free(s->ctx, s->id_map);
        s->id_map = m;
        s->id_map_cap = cap;
    }
    return map_insert_raw(s->id_map, s->id_map_cap, s->objects, slot);
}

/* Backward-shift deletion keeps probe chains intact without tombstones. */
static void map_remove(vis_scene *s, uint32_t id)
{
    uint32_t mask = s->id_map_cap - 1;
    uint32_t i = vis_hash_u32(id) & mask;
    while (s->id_map[i] && s->objects[s->id_map[i] - 1].id != id)
        i = (i + 1) & mask;
    if (!s->id_map[i])
        return;
    s->id_map[i] = 0;
    for (uint32_t j = (i + 1) & mask; s->id_map[j]; j = (j + 1) & mask) {
        uint32_t home = vis_hash_u32(s->objects[s->id_map[j] - 1].id) & mask;
        /* Move j back to i if its home is not cyclically within (i, j]. */
        int in_range = i <= j ? (home > i && home <= j) : (home > i || home <= j);
        if (!in_range) {
            s->id_map[i] = s->id_map[j];
            s->id_map[j] = 0;
            i = j;
        }
    }
}

/* ---- dirty tracking ------------------------------------------------------------------ */

void vis_scene_mark_leaf(vis_scene *s, uint32_t leaf)
{
    if (s->leaf_host[leaf].dirty)
        return;
    s->leaf_host[leaf].dirty = 1;
    s->dirty_leaves[s->dirty_leaf_count++] = leaf; /* sized leaf_count at creation */
}

static int mark_object(vis_scene *s, uint32_t slot)
{
    if (s->object_dirty_flag[slot])
        return 1;
    if (!grow(s->ctx, (void **)&s->dirty_objects, &s->dirty_object_cap, s->dirty_object_count + 1, sizeof(uint32_t)))
        return 0;
    s->object_dirty_flag[slot] = 1;
    s->dirty_objects[s->dirty_object_count++] = slot;
    return 1;
}

static void mark_object_leaves(vis_scene *s, uint32_t lo, uint32_t hi)
{
    if (lo >= hi)
        return;
    if (s->dirty_ol_lo >= s->dirty_ol_hi) {
        s->dirty_ol_lo = lo;
        s->dirty_ol_hi = hi;
    } else {
        if (lo < s->dirty_ol_lo)
            s->dirty_ol_lo = lo;
        if (hi > s->dirty_ol_hi)
            s->dirty_ol_hi = hi;
    }
}

/* ---- create / destroy ---------------------------------------------------------------- */

void vis_scene_desc_defaults(vis_scene_desc *desc)
{
    memset(desc, 0, sizeof *desc);
    desc->cell_size = 16.0f;
    desc->leaf_slack = 0.25f;
    desc->max_bytes = VIS_DEFAULT_SCENE_MAX_BYTES;
}

/* Per node: the node and its rope index. Per leaf: the flat leaf, its host bookkeeping and
 * its entry in the dirty list. Per rope entry: the rope node. For the default 16-voxel cells
 * the leaf headers (64 + 40 + 4 bytes) and the ropes (56 bytes per node, about two nodes per
 * leaf) make up nine tenths of an empty scene. Per cell_map entry (one per leaf at full
 * depth): its leaf index. */
uint64_t vis_scene_tree_bytes(uint64_t nodes, uint64_t leaves, uint64_t ropes, uint64_t cell_map)
{
    uint64_t b = sizeof(vis_scene);
    b = vis_sat_add(b, vis_sat_mul(nodes, sizeof(vis_kd_node) + sizeof(uint32_t)));
    b = vis_sat_add(b, vis_sat_mul(leaves, sizeof(vis_flat_leaf) + sizeof(vis_leaf_host) + sizeof(uint32_t)));
    b = vis_sat_add(b, vis_sat_mul(cell_map, sizeof(uint32_t)));
    return vis_sat_add(b, vis_sat_mul(ropes, sizeof(vis_rope_node)));
}

uint64_t vis_scene_bytes(const vis_scene *s)
{
    return vis_scene_tree_bytes(s->node_count, s->leaf_count, s->rope_count, s->cell_map ? s->leaf_count : 0) +
           (uint64_t)s->bucket_cap * sizeof(uint32_t) + (uint64_t)s->quad_cap * sizeof *s->quads +
           (uint64_t)s->tri_cap * sizeof *s->tris +
           (uint64_t)s->object_cap * (sizeof *s->objects + sizeof *s->object_host + 1) +
           (uint64_t)s->object_leaf_cap * sizeof(uint32_t) + (uint64_t)s->id_map_cap * sizeof(uint32_t) +
           (uint64_t)s->free_cap * sizeof(uint32_t) + (uint64_t)s->dirty_object_cap * sizeof(uint32_t) +
           s->leaf_list_bytes + s->object_prim_bytes;
}

static vis_status scene_create(vis_context *ctx, const vis_scene_desc *desc, vis_scene **out_scene)
{
    if (!desc || !out_scene)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_scene_create: desc and out_scene must not be NULL");
    vis_scene_desc d = *desc;
    if (d.cell_size == 0.0f)
        d.cell_size = 16.0f;
    if (d.leaf_slack == 0.0f)
        d.leaf_slack = 0.25f;
    if (d.max_bytes == 0)
        d.max_bytes = VIS_DEFAULT_SCENE_MAX_BYTES;
    for (int a = 0; a < 3; ++a) {
        if (!isfinite(d.origin[a]))
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "scene origin[%d] is not finite", a);
        if (!(d.size[a] > 0.0f) || !(d.size[a] <= 16777216.0f))
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "scene size[%d] = %g must be in (0, 2^24]", a, (double)d.size[a]);
    }
    if (!(d.cell_size > 0.0f) || !isfinite(d.cell_size))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "scene cell_size %g must be > 0", (double)d.cell_size);
    if (!(d.leaf_slack >= 0.0f && d.leaf_slack <= 16.0f))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "scene leaf_slack %g must be in [0, 16]", (double)d.leaf_slack);
    if (d.kd_depth > 48)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "kd_depth %u exceeds 48", d.kd_depth);
    if (d.commit != VIS_COMMIT_AUTO && d.commit != VIS_COMMIT_EXPLICIT)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "scene commit mode %d is not a vis_commit_mode", (int)d.commit);

    /* The tree's size from arithmetic on the desc, checked before anything is allocated. */
    vis_kdtree_plan plan;
    vis_status st = vis_kdtree_plan_make(ctx, &d, &plan);
    if (st != VIS_OK)
        return st;
    if (plan.nodes > VIS_MAX_KD_NODES)
        return vis_fail(ctx, VIS_ERROR_BUDGET,
                        "kd-tree would have %llu nodes (%ux%ux%u cells, depth %u), over the limit of %u nodes; use a "
                        "larger cell_size or a smaller kd_depth",
                        (unsigned long long)plan.nodes, plan.cells[0], plan.cells[1], plan.cells[2], plan.kd_depth,
                        VIS_MAX_KD_NODES);
    if (plan.bytes > d.max_bytes)
        return vis_fail(ctx, VIS_ERROR_BUDGET,
                        "the empty scene would hold %llu bytes (%llu nodes, %llu leaves, depth %u), over max_bytes "
                        "%llu; use a larger cell_size, a smaller kd_depth or a larger max_bytes",
                        (unsigned long long)plan.bytes, (unsigned long long)plan.nodes,
                        (unsigned long long)plan.leaves, plan.kd_depth, (unsigned long long)d.max_bytes);

    vis_scene *s = vis_calloc(ctx, 1, sizeof *s);
    if (!s)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for a scene");
    s->ctx = ctx;
    s->desc = d;
    s->ctx_next = ctx->scenes; /* linked first: vis_scene_destroy unlinks on every path */
    if (ctx->scenes)
        ctx->scenes->ctx_prev = s;
    ctx->scenes = s;
    st = vis_scene_lock_init(s);
    if (st != VIS_OK)
        st = vis_fail(ctx, st, "could not create the scene's lock");
    if (st == VIS_OK)
        st = vis_kdtree_build(s, &plan);
    if (st == VIS_OK) {
        s->dirty_leaves = vis_calloc(ctx, s->leaf_count, sizeof *s->dirty_leaves);
        if (!s->dirty_leaves)
            st = vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for a scene");
    }
    if (st != VIS_OK) {
        vis_scene_destroy(s);
        return st;
    }
    s->dirty_full = 1;
    s->generation = 1;
    *out_scene = s;
    return VIS_OK;
}

vis_status vis_scene_create(vis_context *ctx, const vis_scene_desc *desc, vis_scene **out_scene)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st = scene_create(ctx, desc, out_scene);
    vis_leave(ctx);
    return st;
}

void vis_scene_destroy(vis_scene *s)
{
    if (!s)
        return;
    vis_context *ctx = s->ctx;
    vis_scene_lock_free(s);
    vis_scene_share_free(s);
    if (s->ctx_prev)
        s->ctx_prev->ctx_next = s->ctx_next;
    else if (ctx->scenes == s)
        ctx->scenes = s->ctx_next;
    if (s->ctx_next)
        s->ctx_next->ctx_prev = s->ctx_prev;
    if (s->backend_data && ctx->backend.ops && ctx->backend.ops->scene_release)
        ctx->backend.ops->scene_release(ctx->backend.impl, s->backend_data);
    if (s->leaf_host)
        for (uint32_t i = 0; i < s->leaf_count; ++i)
            vis_free(ctx, s->leaf_host[i].objects);
    if (s->object_host)
        for (uint32_t i = 0; i < s->object_slots; ++i) {
            vis_free(ctx, s->object_host[i].quads);
            vis_free(ctx, s->object_host[i].tris);
        }
    void *arrays[] = {s->nodes,        s->leaves,      s->leaf_host,    s->buckets,      s->quads,
                      s->tris,         s->objects,     s->object_host,  s->free_slots,   s->object_leaves,
                      s->id_map,       s->dirty_leaves, s->dirty_objects, s->object_dirty_flag, s->ropes, s->rope_index};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i)
        vis_free(ctx, arrays[i]);
    vis_free(ctx, s);
}

/* ---- leaf rebuild -------------------------------------------------------------------- */

static int leaf_has_buckets(const vis_flat_leaf *lf) { return lf->dims_z != 0xFFFFFFFFu; }

static void leaf_dims(const vis_flat_leaf *lf, uint32_t E[3])
{
    E[0] = lf->dims_xy & 0xFFFFu;
    E[1] = lf->dims_xy >> 16;
    E[2] = lf->dims_z;
}

/* Entries of the leaf's bucket table: offsets, then cover masks (trace_core.h). */
static uint32_t bucket_table_size(const vis_flat_leaf *lf)
{
    uint32_t E[3];
    leaf_dims(lf, E);
    return vis_bucket_words(E[0], E[1], E[2]);
}

/* Each bucket's cover masks from its packed quads (trace_core.h, vis_cover_bits), into the
 * pairs of words after the nb offsets of bk. */
static void bucket_cover(uint32_t *bk, uint32_t nb, const uint32_t *packed)
{
    uint32_t *cover = bk + nb;
    for (uint32_t b = 0; b + 1 < nb; ++b) {
        uint32_t m[2] = {0, 0};
        for (uint32_t i = bk[b]; i < bk[b + 1]; ++i)
            for (uint32_t c = 0; c < 2u; ++c) { /* fields c (low) and c + 2 (high): u, then v */
                int lo = (int)VIS_PQ_FIELD(packed[i], c), hi = (int)VIS_PQ_FIELD(packed[i], c + 2u) - 1;
                m[c] |= vis_cover_bits(lo, hi > lo ? hi : lo);
            }
        cover[2 * b] = m[0];
        cover[2 * b + 1] = m[1];
    }
}

/* Bucket index of a quad in the leaf, or UINT32_MAX if it is "loose" (its plane is not an
 * integer offset from the leaf's lower corner). */
static uint32_t quad_bucket(const vis_flat_leaf *lf, const vis_flat_quad *q)
{
    if (!leaf_has_buckets(lf))
        return UINT32_MAX;
    uint32_t a = VIS_META_AXIS(q->meta);
    uint32_t E[3];
    leaf_dims(lf, E);
    float k = q->plane - lf->lo[a];
    /* whole: k is in [0, E] (E < 2^16) before the conversion, so truncation is floor */
    if (!(k >= 0.0f) || k > (float)E[a] || (float)(uint32_t)k != k || lf->lo[a] + k != q->plane)
        return UINT32_MAX;
    uint32_t base = a == 0 ? 0u : a == 1 ? E[0] + 1u : E[0] + E[1] + 2u;
    return base + (uint32_t)k;
}

static int quad_in_leaf(const vis_flat_leaf *lf, uint32_t a, float plane, float u0, float v0, float u1, float v1)
{
    uint32_t u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
    return plane >= lf->lo[a] && plane <= lf->hi[a] && u1 >= lf->lo[u] && u0 <= lf->hi[u] && v1 >= lf->lo[v] &&
           v0 <= lf->hi[v];
}

static int quad_overlaps_leaf(const vis_flat_leaf *lf, const vis_flat_quad *q)
{
    return quad_in_leaf(lf, VIS_META_AXIS(q->meta), q->plane, q->u0, q->v0, q->u1, q->v1);
}

static int tri_in_leaf(const vis_flat_leaf *lf, const float *v0, const float *v1, const float *v2)
{
    for (int a = 0; a < 3; ++a) {
        float lo = fminf(v0[a], fminf(v1[a], v2[a]));
        float hi = fmaxf(v0[a], fmaxf(v1[a], v2[a]));
        if (hi < lf->lo[a] || lo > lf->hi[a])
            return 0;
    }
    return 1;
}

static int tri_overlaps_leaf(const vis_flat_leaf *lf, const vis_flat_tri *t)
{
    return tri_in_leaf(lf, t->v0, t->v1, t->v2);
}

/* The class of the slot a leaf that must hold `need` entries gets: need plus the slack, and
 * 4 more, rounded up to a size class. */
static uint32_t slot_class_for(const vis_scene *s, uint64_t need)
{
    return vis_slot_class(need + (uint64_t)((double)need * s->desc.leaf_slack) + 4u);
}

/* Reserves `need` entries for a leaf slot in a pool: in place when it fits, else a free slot
 * of its class or of one of the next VIS_SLOT_REUSE_CLASSES - 1 (up to twice its size: freed
 * slots are taken rather than left to pile up in classes no leaf asks for), else a new one at
 * the end of the pool; the old slot goes to its class's free list. Returns 0 on allocation
 * failure (nothing changed). */
static int reserve_slot(vis_scene *s, void **pool, uint32_t *used, uint32_t *cap, size_t elem, vis_slot_free *fl,
                        uint32_t *slot_offset, uint32_t *slot_cap, uint32_t need, int *moved)
{
    *moved = 0;
    if (need <= *slot_cap)
        return 1;
    uint32_t c0 = slot_class_for(s, need), c = vis_slot_free_class(fl, NULL, c0), off;
    uint64_t want;
    if (c != UINT32_MAX) {
        off = vis_slot_take(fl, *pool, elem, c);
        want = vis_slot_class_size(c);
    } else {
        want = vis_slot_class_size(c0);
        if (*used + want > 0xFFFFFF00u || !grow(s->ctx, pool, cap, (uint32_t)(*used + want), elem))
            return 0;
        off = *used;
        *used += (uint32_t)want;
    }
    if (*slot_cap) {
        vis_slot_give(fl, *pool, elem, *slot_offset, vis_slot_class(*slot_cap));
        *moved = 1;
    }
    *slot_offset = off;
    *slot_cap = (uint32_t)want;
    return 1;
}

/* The packed word of a quad in the leaf (trace_core.h, vis_packed_quad) and its bucket, when
 * it can be packed: its plane on a bucket, its rectangle on whole offsets in [0, 31] from the
 * leaf's corner that give its coordinates back exactly, small flags, and a table index that
 * fits. Returns 0 for a quad that stays loose. */
_Static_assert(offsetof(vis_flat_quad, v0) == offsetof(vis_flat_quad, u0) + sizeof(float) &&
                   offsetof(vis_flat_quad, u1) == offsetof(vis_flat_quad, u0) + 2 * sizeof(float) &&
                   offsetof(vis_flat_quad, v1) == offsetof(vis_flat_quad, u0) + 3 * sizeof(float),
               "pack_quad loads u0, v0, u1, v1 as four floats in that order");
static int pack_quad(const vis_flat_leaf *lf, const vis_flat_quad *q, uint32_t local, uint32_t *bucket, uint32_t *word)
{
    uint32_t b = quad_bucket(lf, q);
    if (b == UINT32_MAX || local > VIS_PQ_TABLE_MAX || VIS_META_FLAGS(q->meta) > VIS_PQ_FLAGS_MAX)
        return 0;
    uint32_t a = VIS_META_AXIS(q->meta), u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
    uint32_t w = VIS_META_FLAGS(q->meta) << 20 | local << 22;
    /* Each of u0, v0, u1, v1 less the corner: in [0, 31], whole, and giving the coordinate
     * back exactly. The same float operations four lanes at a time where SSE2 is there. */
#if defined(__SSE2__)
    const __m128 c = _mm_loadu_ps(&q->u0), base = _mm_setr_ps(lf->lo[u], lf->lo[v], lf->lo[u], lf->lo[v]);
    const __m128 k = _mm_sub_ps(c, base);
    /* Clamped first so that no lane's conversion is out of range (no FE_INVALID raised where
     * the scalar test would have stopped); lanes outside [0, 31] or NaN fail `ok` anyway. */
    const __m128 kc = _mm_min_ps(_mm_max_ps(k, _mm_setzero_ps()), _mm_set1_ps((float)VIS_PQ_COORD_MAX));
    const __m128i ki = _mm_cvttps_epi32(kc); /* exact where k is whole and in range */
    const __m128 kf = _mm_cvtepi32_ps(ki);
    __m128 ok = _mm_and_ps(_mm_cmpge_ps(k, _mm_setzero_ps()), _mm_cmple_ps(k, _mm_set1_ps((float)VIS_PQ_COORD_MAX)));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmpeq_ps(kf, k), _mm_cmpeq_ps(_mm_add_ps(base, kf), c)));
    if (_mm_movemask_ps(ok) != 0xF)
        return 0;
    _Alignas(16) uint32_t kw[4];
    _mm_store_si128((__m128i *)kw, ki);
    w |= kw[0] | kw[1] << 5 | kw[2] << 10 | kw[3] << 15;
#else
    const float c[4] = {q->u0, q->v0, q->u1, q->v1}, base[4] = {lf->lo[u], lf->lo[v], lf->lo[u], lf->lo[v]};
    for (uint32_t i = 0; i < 4; ++i) {
        float k = c[i] - base[i];
        if (!(k >= 0.0f && k <= (float)VIS_PQ_COORD_MAX))
            return 0;
        uint32_t ki = (uint32_t)k;
        if ((float)ki != k || base[i] + (float)ki != c[i])
            return 0;
        w |= ki << (5u * i);
    }
#endif
    *bucket = b;
    *word = w;
    return 1;
}

/* Words of a leaf slot holding `packed` packed and `loose` loose quads of `objects` objects:
 * the object table (when a quad is packed), one word per packed quad, VIS_LOOSE_WORDS per loose
 * one (trace_core.h, vis_flat_leaf). rebuild_leaf fills it; leaf_words_after predicts it. */
static uint32_t table_words(uint32_t objects, uint64_t packed)
{
    return packed ? (objects < VIS_PQ_TABLE_MAX + 1u ? objects : VIS_PQ_TABLE_MAX + 1u) : 0u;
}

static uint64_t slot_words(uint32_t objects, uint64_t packed, uint64_t loose)
{
    return table_words(objects, packed) + packed + loose * VIS_LOOSE_WORDS;
}

/* Insertion sort (stable) by u0: buckets hold a handful of quads, and a leaf rebuild must not
 * allocate. */
static void sort_by_u0(uint32_t *w, uint32_t n)
{
    for (uint32_t i = 1; i < n; ++i) {
        uint32_t x = w[i], j = i;
        while (j > 0 && VIS_PQ_FIELD(w[j - 1], 0u) > VIS_PQ_FIELD(x, 0u)) {
            w[j] = w[j - 1];
            --j;
        }
        w[j] = x;
    }
}

/* Position of `slot` in the leaf's ascending object list (where it is or would go). */
static uint32_t list_position(const vis_leaf_host *lh, uint32_t slot)
{
    uint32_t lo = 0, hi = lh->object_count;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (lh->objects[mid] < slot)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* An object in a single leaf keeps no copy of its quads: its leaf holds them all (packed or
 * loose) and gives them back (gather_leaf, vis_scene_object_quads). Objects over several
 * leaves keep theirs, since each leaf holds only the quads that overlap it. */
static int object_resident(const vis_scene *s, uint32_t slot) { return s->objects[slot].leaf_count == 1; }

typedef void (*quad_visitor)(void *user, const vis_flat_quad *q);

/* Visits every quad the leaf stores (packed ones unpacked; meta with the object slot). */
static void visit_stored(const vis_scene *s, uint32_t li, quad_visitor visit, void *user)
{
    const vis_flat_leaf *lf = &s->leaves[li];
    if (lf->quad_count) {
        const uint32_t *bk = &s->buckets[lf->bucket_offset];
        uint32_t E[3], b = 0;
        leaf_dims(lf, E);
        for (uint32_t a = 0; a < 3; ++a)
            for (uint32_t k = 0; k <= E[a]; ++k, ++b)
                for (uint32_t i = bk[b]; i < bk[b + 1]; ++i) {
                    vis_flat_quad q = vis_unpack_quad(s->quads[lf->quad_offset + i], a, (int)k, lf, s->quads);
                    visit(user, &q);
                }
    }
    if (lf->loose_count) {
        const vis_flat_quad *loose = vis_loose_quads(s->quads, lf);
        for (uint32_t i = 0; i < lf->loose_count; ++i)
            visit(user, &loose[i]);
    }
}

static int in_list(const vis_leaf_host *lh, uint32_t slot)
{
    uint32_t p = list_position(lh, slot);
    return p < lh->object_count && lh->objects[p] == slot;
}

/* gather_leaf's filter of a leaf's stored quads: those of its resident objects other than the
 * one being set. */
typedef struct kept_quads {
    const vis_scene *s;
    const vis_leaf_host *lh;
    uint32_t slot;
    quad_visitor visit;
    void *user;
    uint32_t count;
} kept_quads;

static void visit_kept(void *user, const vis_flat_quad *q)
{
    kept_quads *k = user;
    uint32_t o = VIS_META_OBJECT(q->meta);
    if (o == k->slot || !object_resident(k->s, o) || !in_list(k->lh, o))
        return;
    k->visit(k->user, q);
    ++k->count;
}

/* Visits the quads a rebuild of leaf li puts in it, as flat quads (meta with the object slot):
 * the quads of its resident objects from its slot as it is now, the others' from their
 * copies, and `mesh` for the object in `slot` (VIS_NO_OBJECT: none) when `mesh_in` (over n
 * leaves; its old quads are left out). Objects no longer in the leaf's list are left out.
 * Returns the count. */
static uint32_t gather_leaf(const vis_scene *s, uint32_t li, uint32_t slot, const vis_mesh *mesh, uint32_t n,
                            int mesh_in, quad_visitor visit, void *user)
{
    const vis_flat_leaf *lf = &s->leaves[li];
    const vis_leaf_host *lh = &s->leaf_host[li];
    kept_quads k = {s, lh, slot, visit, user, 0};
    int others_resident = 0; /* the common edit: the object alone in its leaf reads nothing back */
    for (uint32_t i = 0; i < lh->object_count && !others_resident; ++i)
        others_resident = lh->objects[i] != slot && object_resident(s, lh->objects[i]);
    if (others_resident)
        visit_stored(s, li, visit_kept, &k);
    uint32_t count = k.count;
    for (uint32_t i = 0; i < lh->object_count; ++i) {
        uint32_t o = lh->objects[i];
        if (o == slot || object_resident(s, o))
            continue;
        const vis_object_host *oh = &s->object_host[o];
        for (uint32_t q = 0; q < oh->quad_count; ++q)
            if (quad_overlaps_leaf(lf, &oh->quads[q])) {
                visit(user, &oh->quads[q]);
                ++count;
            }
    }
    if (mesh_in)
        for (uint32_t q = 0; q < mesh->quad_count; ++q) {
            const vis_quad *mq = &mesh->quads[q];
            if (!(n == 1 || quad_in_leaf(lf, mq->axis, mq->plane, mq->u0, mq->v0, mq->u1, mq->v1)))
                continue;
            vis_flat_quad fq = {mq->plane, mq->u0, mq->v0, mq->u1, mq->v1, slot << 8 | mq->flags << 2 | mq->axis};
            visit(user, &fq);
            ++count;
        }
    return count;
}

/* vis_scene_visit_object_quads's filter: one object's quads. */
typedef struct object_quads {
    uint32_t slot;
    quad_visitor visit;
    void *user;
} object_quads;

static void visit_object(void *user, const vis_flat_quad *q)
{
    object_quads *o = user;
    if (VIS_META_OBJECT(q->meta) == o->slot)
        o->visit(o->user, q);
}

void vis_scene_visit_object_quads(const vis_scene *s, uint32_t slot, quad_visitor visit, void *user)
{
    const vis_object_host *oh = &s->object_host[slot];
    if (!object_resident(s, slot)) {
        for (uint32_t q = 0; q < oh->quad_count; ++q)
            visit(user, &oh->quads[q]);
        return;
    }
    object_quads o = {slot, visit, user};
    visit_stored(s, s->object_leaves[s->objects[slot].leaf_offset], visit_object, &o);
}

typedef struct gather_array {
    vis_flat_quad *q;
    uint32_t n;
} gather_array;

static void visit_append(void *user, const vis_flat_quad *q)
{
    gather_array *g = user;
    g->q[g->n++] = *q;
}

/* gather_leaf into a fresh array (freed by the caller with vis_free; NULL when empty) of
 * *cap entries, sized from what the leaf and the copies hold without a counting pass, with
 * room after it for rebuild_leaf's packed words and buckets (two per entry). */
static vis_status gather_leaf_alloc(const vis_scene *s, uint32_t li, uint32_t slot, const vis_mesh *mesh, uint32_t n,
                                    int mesh_in, vis_flat_quad **out, uint32_t *count, uint32_t *cap)
{
    const vis_flat_leaf *lf = &s->leaves[li];
    const vis_leaf_host *lh = &s->leaf_host[li];
    uint64_t bound = (uint64_t)lf->quad_count + lf->loose_count + (mesh_in ? mesh->quad_count : 0u);
    for (uint32_t i = 0; i < lh->object_count; ++i)
        if (lh->objects[i] != slot && !object_resident(s, lh->objects[i]))
            bound += s->object_host[lh->objects[i]].quad_count;
    *out = NULL;
    *count = *cap = 0;
    if (bound == 0)
        return VIS_OK;
    if (bound > 0xFFFFFF00u)
        return vis_fail(s->ctx, VIS_ERROR_CAPACITY, "leaf %u would hold %llu quads, more than the pool can address", li,
                        (unsigned long long)bound);
    gather_array g = {vis_alloc(s->ctx, (size_t)bound * (sizeof *g.q + 2 * sizeof(uint32_t))), 0};
    if (!g.q)
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory gathering a leaf's quads");
    gather_leaf(s, li, slot, mesh, n, mesh_in, visit_append, &g);
    *out = g.q;
    *count = g.n;
    *cap = (uint32_t)bound;
    return VIS_OK;
}

/* The leaf's content box (trace_core.h, vis_flat_leaf): the closed box, in offsets from its
 * corner, of the quads that rebuild_leaf packs (bucket[i] != UINT32_MAX), each quad's plane
 * and rectangle exactly as packed, the offsets capped at 31 (a plane of a leaf wider than 31
 * may lie farther: a high field of 31 reads as the leaf's last plane); 0 when none is. */
static uint32_t content_box(const vis_flat_leaf *lf, const vis_flat_quad *q, const uint32_t *bucket, uint32_t n)
{
    uint32_t blo[3] = {VIS_PQ_COORD_MAX, VIS_PQ_COORD_MAX, VIS_PQ_COORD_MAX}, bhi[3] = {0, 0, 0};
    int any = 0;
    for (uint32_t i = 0; i < n; ++i) {
        if (bucket[i] == UINT32_MAX)
            continue;
        uint32_t a = VIS_META_AXIS(q[i].meta), u = a == 2u ? 0u : a + 1u, v = a == 0u ? 2u : a - 1u;
        /* pack_quad took the quad only where these differences are whole and exact */
        uint32_t c[3][2];
        c[a][0] = c[a][1] = (uint32_t)(q[i].plane - lf->lo[a]);
        c[u][0] = (uint32_t)(q[i].u0 - lf->lo[u]);
        c[u][1] = (uint32_t)(q[i].u1 - lf->lo[u]);
        c[v][0] = (uint32_t)(q[i].v0 - lf->lo[v]);
        c[v][1] = (uint32_t)(q[i].v1 - lf->lo[v]);
        for (uint32_t k = 0; k < 3u; ++k) {
            blo[k] = c[k][0] < blo[k] ? c[k][0] : blo[k];
            bhi[k] = c[k][1] > bhi[k] ? c[k][1] : bhi[k];
        }
        any = 1;
    }
    if (!any)
        return 0;
    for (uint32_t k = 0; k < 3u; ++k) { /* planes may lie past 31: capped, read back as "to the end" */
        blo[k] = blo[k] < VIS_PQ_COORD_MAX ? blo[k] : VIS_PQ_COORD_MAX;
        bhi[k] = bhi[k] < VIS_PQ_COORD_MAX ? bhi[k] : VIS_PQ_COORD_MAX;
    }
    return blo[0] | blo[1] << 5 | blo[2] << 10 | bhi[0] << 15 | bhi[1] << 20 | bhi[2] << 25;
}

/* The edit in progress (set by set_object_located around its rebuilds): the object whose
 * quads come from `mesh` rather than from its old copy or leaf. */
typedef struct pending_edit {
    uint32_t slot;
    const vis_mesh *mesh;
} pending_edit;

/* Refills the leaf's slot: [object table | packed quads by bucket, each bucket by u0 | loose
 * quads] (trace_core.h, vis_flat_leaf), and its triangles. */
static vis_status rebuild_leaf(vis_scene *s, uint32_t li, const pending_edit *pe)
{
    vis_flat_leaf *lf = &s->leaves[li];
    vis_leaf_host *lh = &s->leaf_host[li];
    uint32_t slot = pe ? pe->slot : VIS_NO_OBJECT;
    int mesh_in = pe && in_list(lh, slot);
    int was_empty = !vis_leaf_has_primitives(lf);
    vis_flat_quad *g = NULL;
    uint32_t ng = 0, gcap = 0;
    vis_status st = gather_leaf_alloc(s, li, slot, pe ? pe->mesh : NULL, pe ? s->objects[slot].leaf_count : 0, mesh_in,
                                      &g, &ng, &gcap);
    if (st != VIS_OK)
        return st;
    int can_pack = leaf_has_buckets(lf);
    uint32_t packed = 0, nt = 0;
    uint32_t *gw = (uint32_t *)(g + gcap), *gb = gw + gcap; /* each quad's word and bucket, or loose */
    for (uint32_t i = 0; i < ng; ++i) {
        gb[i] = UINT32_MAX;
        packed += can_pack && pack_quad(lf, &g[i], list_position(lh, VIS_META_OBJECT(g[i].meta)), &gb[i], &gw[i]);
    }
    for (uint32_t i = 0; i < lh->object_count; ++i) {
        const vis_object_host *oh = &s->object_host[lh->objects[i]];
        int single = s->objects[lh->objects[i]].leaf_count == 1;
        for (uint32_t t = 0; t < oh->tri_count; ++t)
            nt += single || tri_overlaps_leaf(lf, &oh->tris[t]);
    }
    uint32_t table = table_words(lh->object_count, packed);
    uint64_t words = slot_words(lh->object_count, packed, ng - packed);
    uint32_t qoff = lh->quad_slot;
    int moved_q = 0, moved_t = 0;
    if (words > 0xFFFFFF00u)
        st = vis_fail(s->ctx, VIS_ERROR_CAPACITY, "leaf %u would hold %llu quad words, more than the pool can address",
                      li, (unsigned long long)words);
    else if (!reserve_slot(s, (void **)&s->quads, &s->quad_used, &s->quad_cap, sizeof *s->quads, &s->quad_free,
                           &qoff, &lh->quad_cap, (uint32_t)words, &moved_q) ||
             !reserve_slot(s, (void **)&s->tris, &s->tri_used, &s->tri_cap, sizeof *s->tris, &s->tri_free,
                           &lf->tri_offset, &lh->tri_cap, nt, &moved_t))
        st = vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory growing the primitive pools");
    /* Bucket table: allocated the first time the leaf holds packed quads; its size is fixed
     * by the leaf's extent, so it never moves afterwards. */
    uint32_t nb = can_pack ? bucket_table_size(lf) : 0;
    if (st == VIS_OK && nb && lf->bucket_offset == VIS_KD_NO_BUCKETS && packed) {
        if (!grow(s->ctx, (void **)&s->buckets, &s->bucket_cap, s->bucket_count + nb, sizeof *s->buckets))
            st = vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for bucket tables");
        else {
            lf->bucket_offset = s->bucket_count;
            memset(&s->buckets[lf->bucket_offset], 0, nb * sizeof *s->buckets);
            s->bucket_count += nb;
        }
    }
    if (st != VIS_OK) {
        vis_free(s->ctx, g);
        return st;
    }
    lh->quad_slot = qoff;
    s->relocations += (uint64_t)moved_q + (uint64_t)moved_t;

    /* Counting sort by bucket: counts into the table, then prefix offsets; the scatter
     * advances the entries, which are shifted back afterwards. */
    uint32_t *bk = packed ? &s->buckets[lf->bucket_offset] : NULL;
    uint32_t *tab = &s->quads[qoff], *dst = tab + table;
    vis_flat_quad *dst_loose = (vis_flat_quad *)(dst + packed);
    for (uint32_t i = 0; i < table; ++i)
        tab[i] = lh->objects[i];
    if (nb && lf->bucket_offset != VIS_KD_NO_BUCKETS)
        memset(&s->buckets[lf->bucket_offset], 0, nb * sizeof *s->buckets);
    uint32_t nl = 0;
    for (uint32_t i = 0; i < ng; ++i)
        if (gb[i] != UINT32_MAX)
            ++bk[gb[i] + 1];
        else
            dst_loose[nl++] = g[i];
    if (bk) {
        uint32_t E[3];
        leaf_dims(lf, E);
        uint32_t no = vis_bucket_offsets(E[0], E[1], E[2]);
        for (uint32_t k = 1; k < no; ++k)
            bk[k] += bk[k - 1];
        for (uint32_t i = 0; i < ng; ++i)
            if (gb[i] != UINT32_MAX)
                dst[bk[gb[i]]++] = gw[i];
        for (uint32_t k = no - 1; k > 0; --k)
            bk[k] = bk[k - 1];
        bk[0] = 0;
        /* Within a bucket, ascending u0 lets the traversal stop at the first quad that starts
         * beyond the crossing point (trace_core.h). Stable, so equal u0 keep their order. */
        for (uint32_t k = 0; k + 1 < no; ++k)
            sort_by_u0(dst + bk[k], bk[k + 1] - bk[k]);
        bucket_cover(bk, no, dst);
    }
    lf->content_box = content_box(lf, g, gb, ng);
    vis_free(s->ctx, g);
    lf->table_offset = qoff;
    lf->quad_offset = qoff + table;
    lf->quad_count = packed;
    lf->loose_count = nl;

    uint32_t t_out = 0;
    for (uint32_t i = 0; i < lh->object_count; ++i) {
        const vis_object_host *oh = &s->object_host[lh->objects[i]];
        int single = s->objects[lh->objects[i]].leaf_count == 1;
        for (uint32_t t = 0; t < oh->tri_count; ++t)
            if (single || tri_overlaps_leaf(lf, &oh->tris[t]))
                s->tris[lf->tri_offset + t_out++] = oh->tris[t];
    }
    lf->tri_count = t_out;
    if (was_empty && vis_leaf_has_primitives(lf))
        vis_kdtree_leaf_filled(s, li);
    else if (!was_empty && !vis_leaf_has_primitives(lf))
        vis_kdtree_leaf_emptied(s, li);
    vis_scene_mark_leaf(s, li);
    return VIS_OK;
}

/* ---- leaf object lists --------------------------------------------------------------- */

static int leaf_add_object(vis_scene *s, uint32_t li, uint32_t slot)
{
    vis_leaf_host *lh = &s->leaf_host[li];
    uint32_t cap = lh->object_cap;
    if (!grow(s->ctx, (void **)&lh->objects, &lh->object_cap, lh->object_count + 1, sizeof(uint32_t)))
        return 0;
    s->leaf_list_bytes += (uint64_t)(lh->object_cap - cap) * sizeof(uint32_t);
    uint32_t i = lh->object_count;
    while (i > 0 && lh->objects[i - 1] > slot) {
        lh->objects[i] = lh->objects[i - 1];
        --i;
    }
    lh->objects[i] = slot;
    ++lh->object_count;
    return 1;
}

static void leaf_remove_object(vis_scene *s, uint32_t li, uint32_t slot)
{
    vis_leaf_host *lh = &s->leaf_host[li];
    for (uint32_t i = 0; i < lh->object_count; ++i)
        if (lh->objects[i] == slot) {
            memmove(&lh->objects[i], &lh->objects[i + 1], (lh->object_count - i - 1) * sizeof(uint32_t));
            --lh->object_count;
            return;
        }
}

static int contains(const uint32_t *a, uint32_t n, uint32_t x)
{
    for (uint32_t i = 0; i < n; ++i)
        if (a[i] == x)
            return 1;
    return 0;
}

/* ---- objects ------------------------------------------------------------------------- */

static vis_status validate_mesh(vis_scene *s, const vis_mesh *m)
{
    if (m->quad_count && !m->quads)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "mesh has %u quads but quads is NULL", m->quad_count);
    if (m->triangle_count && !m->triangles)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "mesh has %u triangles but triangles is NULL",
                        m->triangle_count);
    const float *size = s->desc.size;
    for (uint32_t i = 0; i < m->quad_count; ++i) {
        const vis_quad *q = &m->quads[i];
        if (q->axis > 2 || q->flags > 63)
            return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "quad %u: axis %u or flags %u out of range", i, q->axis,
                            q->flags);
        uint32_t u = (q->axis + 1) % 3, v = (q->axis + 2) % 3;
        if (!(q->plane >= 0.0f && q->plane <= size[q->axis]) || !(q->u0 >= 0.0f && q->u0 <= q->u1 && q->u1 <= size[u]) ||
            !(q->v0 >= 0.0f && q->v0 <= q->v1 && q->v1 <= size[v]))
            return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT,
                            "quad %u (axis %u, plane %g, [%g,%g]x[%g,%g]) is empty, not finite or outside the scene", i,
                            q->axis, (double)q->plane, (double)q->u0, (double)q->u1, (double)q->v0, (double)q->v1);
    }
    for (uint32_t i = 0; i < m->triangle_count; ++i) {
        const vis_triangle *t = &m->triangles[i];
        if (t->flags > 63)
            return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "triangle %u: flags %u out of range", i, t->flags);
        for (int k = 0; k < 3; ++k)
            for (int a = 0; a < 3; ++a)
                if (!(t->v[k][a] >= 0.0f && t->v[k][a] <= size[a]))
                    return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT,
                                    "triangle %u vertex %d is not finite or outside the scene", i, k);
    }
    return VIS_OK;
}

static vis_status alloc_slot(vis_scene *s, uint32_t *out)
{
    if (s->free_count) {
        *out = s->free_slots[--s->free_count];
        return VIS_OK;
    }
    if (s->object_slots >= VIS_MAX_OBJECTS)
        return vis_fail(s->ctx, VIS_ERROR_CAPACITY, "scene holds the maximum of %u objects", VIS_MAX_OBJECTS);
    uint32_t cap = s->object_cap;
    if (s->object_slots + 1 > cap) {
        uint32_t c1 = cap, c2 = cap, c3 = cap;
        if (!grow(s->ctx, (void **)&s->objects, &c1, s->object_slots + 1, sizeof *s->objects) ||
            !grow(s->ctx, (void **)&s->object_host, &c2, c1, sizeof *s->object_host) ||
            !grow(s->ctx, (void **)&s->object_dirty_flag, &c3, c1, 1))
            return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for objects");
        s->object_cap = c1 < c2 ? (c1 < c3 ? c1 : c3) : (c2 < c3 ? c2 : c3);
    }
    uint32_t slot = s->object_slots++;
    memset(&s->objects[slot], 0, sizeof s->objects[slot]);
    memset(&s->object_host[slot], 0, sizeof s->object_host[slot]);
    s->object_dirty_flag[slot] = 0;
    *out = slot;
    return VIS_OK;
}

/* ---- budget ------------------------------------------------------------------------- */

/* Refuses an edit that would take the scene past max_bytes, before anything changes. */
static vis_status check_growth(vis_scene *s, uint64_t add, uint64_t shrink, const char *what, uint32_t id)
{
    uint64_t now = vis_scene_bytes(s), after = vis_sat_add(now, add);
    after = add == UINT64_MAX ? after : after - (shrink < after ? shrink : after);
    if (after <= s->desc.max_bytes)
        return VIS_OK;
    if (add == UINT64_MAX)
        return vis_fail(s->ctx, VIS_ERROR_BUDGET, "%s of object %u would grow the scene's arrays past their 32-bit "
                        "counts (max_bytes %llu)", what, id, (unsigned long long)s->desc.max_bytes);
    return vis_fail(s->ctx, VIS_ERROR_BUDGET, "%s of object %u would grow the scene from %llu to %llu bytes, over "
                    "max_bytes %llu", what, id, (unsigned long long)now, (unsigned long long)after,
                    (unsigned long long)s->desc.max_bytes);
}

/* What leaf_words_after counts: packed and loose quads as rebuild_leaf will classify them. */
typedef struct word_count {
    const vis_scene *s;
    const vis_flat_leaf *lf;
    const vis_leaf_host *lh;
    uint32_t slot;  /* the object being set or leaving                                     */
    int shift;      /* what its joining (+1), staying (0) or leaving (-1) does to the table
                     * index of every object after it in the list                           */
    int can_pack;
    uint64_t packed, loose;
} word_count;

static void visit_count(void *user, const vis_flat_quad *q)
{
    word_count *c = user;
    uint32_t o = VIS_META_OBJECT(q->meta), b, w;
    /* The table index once the list has `slot` added, kept or taken out. */
    uint32_t local = list_position(c->lh, o) + (uint32_t)(c->slot < o ? c->shift : 0);
    if (c->can_pack && pack_quad(c->lf, q, local, &b, &w))
        ++c->packed;
    else
        ++c->loose;
}

/* The quad words rebuild_leaf will give leaf li once the object in `slot` holds `mesh` (and
 * lies in n leaves), or, `leaving`, once it is out of the leaf's list (mesh unread), counted
 * as rebuild_leaf counts them; *packed gets the packed quads. A leaf an object leaves can
 * grow: the objects after it in the list move down, and a quad of the one that enters the
 * object table's range (VIS_PQ_TABLE_MAX) packs, which brings the table with it. */
static uint64_t leaf_words_after(const vis_scene *s, uint32_t li, uint32_t slot, const vis_mesh *mesh, uint32_t n,
                                 int leaving, uint32_t *packed)
{
    const vis_leaf_host *lh = &s->leaf_host[li];
    int shift = leaving ? -1 : !contains(lh->objects, lh->object_count, slot);
    word_count c = {s, &s->leaves[li], lh, slot, shift, leaf_has_buckets(&s->leaves[li]), 0, 0};
    gather_leaf(s, li, slot, mesh, n, !leaving, visit_count, &c);
    *packed = (uint32_t)c.packed;
    return slot_words((uint32_t)((int64_t)lh->object_count + shift), c.packed, c.loose);
}

/* At least leaf_words_after's count, without packing a quad: every quad the leaf may hold
 * after the edit (its stored ones, the old copy of `slot`'s among them, the others' copies and
 * the mesh's, if any) counted loose, plus a full object table. */
static uint64_t leaf_words_bound(const vis_scene *s, uint32_t li, const vis_mesh *mesh)
{
    const vis_flat_leaf *lf = &s->leaves[li];
    const vis_leaf_host *lh = &s->leaf_host[li];
    uint64_t quads = (uint64_t)lf->quad_count + lf->loose_count + (mesh ? mesh->quad_count : 0u);
    for (uint32_t i = 0; i < lh->object_count; ++i)
        if (!object_resident(s, lh->objects[i]))
            quads += s->object_host[lh->objects[i]].quad_count;
    return table_words(lh->object_count + 1u, 1u) + quads * VIS_LOOSE_WORDS;
}

/* reserve_slot's choice for a slot of slot_cap that must hold need, without making it, with
 * the slots earlier moves of the same edit took and freed (per class): returns the entries
 * it appends to the pool (0 when a free slot serves). */
typedef struct pool_sim {
    const vis_slot_free *fl;
    int32_t delta[VIS_SLOT_CLASSES]; /* slots earlier moves of the edit freed, less those taken */
    uint64_t used, free_entries;
    int bound; /* an upper bound only: every slot appended, nothing compacted */
} pool_sim;

static void pool_sim_init(pool_sim *p, const vis_slot_free *fl, uint32_t used, int bound)
{
    memset(p, 0, sizeof *p);
    p->fl = fl;
    p->used = used;
    p->free_entries = fl->entries;
    p->bound = bound;
}

/* reserve_slot's choice for a slot of slot_cap that must hold need, without making it. */
static void simulate_reserve(const vis_scene *s, pool_sim *p, uint64_t need, uint32_t slot_cap)
{
    uint32_t c0 = slot_class_for(s, need), c = p->bound ? UINT32_MAX : vis_slot_free_class(p->fl, p->delta, c0);
    if (c != UINT32_MAX) {
        --p->delta[c];
        p->free_entries -= vis_slot_class_size(c);
    } else {
        p->used += vis_slot_class_size(c0);
    }
    if (slot_cap) {
        ++p->delta[vis_slot_class(slot_cap)];
        p->free_entries += slot_cap;
    }
}

/* The pool's capacity after the edit: grown to its use, then, where the edit `compacts`,
 * compacted if it will be (scene_compact.c). */
static uint64_t pool_sim_cap(const pool_sim *p, uint32_t cap, int compacts)
{
    uint64_t c = p->used <= cap ? cap : grown_cap(cap, p->used); /* 0: past 32-bit counts */
    if (c && compacts && !p->bound && vis_slot_should_compact(p->used, p->free_entries))
        c = vis_slot_compact_cap(p->used - p->free_entries, c);
    return c;
}

/* The primitive pools and bucket entries of one walk of set_object_growth (its pools' `bound`
 * says which walk it is). */
typedef struct growth_walk {
    pool_sim quads, tris;
    uint64_t buckets; /* bucket entries after the edit */
} growth_walk;

/* One leaf's rebuild in the walks below, in relink's order: its quad words (exact, or the
 * bound), its triangles, and the slots and first bucket table that rebuild_leaf will take.
 * `mesh` joins or stays in the leaf (NULL: the object in `slot` leaves it); `old` is that
 * object's host record when the leaf holds its triangles now (NULL otherwise). Returns 0
 * when the leaf would pass the pool's 32-bit counts. */
static int walk_leaf(const vis_scene *s, growth_walk *g, uint32_t li, uint32_t slot, const vis_mesh *mesh, uint32_t n,
                     const vis_object_host *old, uint32_t old_count)
{
    const vis_flat_leaf *lf = &s->leaves[li];
    const vis_leaf_host *lh = &s->leaf_host[li];
    uint32_t packed = 1; /* the bound: a first bucket table wherever one may be needed */
    uint64_t nq = g->quads.bound ? leaf_words_bound(s, li, mesh)
                                 : leaf_words_after(s, li, slot, mesh, n, !mesh, &packed);
    if (nq > 0xFFFFFF00u)
        return 0;
    uint64_t nt = lf->tri_count;
    if (old)
        for (uint32_t t = 0; t < old->tri_count; ++t)
            nt -= old_count == 1 || tri_overlaps_leaf(lf, &old->tris[t]);
    for (uint32_t t = 0; mesh && t < mesh->triangle_count; ++t) {
        const vis_triangle *mt = &mesh->triangles[t];
        nt += n == 1 || tri_in_leaf(lf, mt->v[0], mt->v[1], mt->v[2]);
    }
    /* reserve_slot's rule, in the order rebuild_leaf follows: a free slot of the class if one
     * is left, else the end of the pool; then the old slot is free. */
    if (nq > lh->quad_cap)
        simulate_reserve(s, &g->quads, nq, lh->quad_cap);
    if (nt > lh->tri_cap)
        simulate_reserve(s, &g->tris, nt, lh->tri_cap);
    if (leaf_has_buckets(lf) && lf->bucket_offset == VIS_KD_NO_BUCKETS && packed)
        g->buckets += bucket_table_size(lf);
    return 1;
}

/* The bytes vis_scene_set_object(id, mesh) will add, walking its allocations step by step
 * without making them: the slot and ID map of a new object, the object's copy of the mesh,
 * the object lists of the leaves it joins, its leaf list, the leaves' new slots in the
 * primitive pools (rebuild_leaf's reserve_slot, from the primitive counts each leaf will
 * hold, taking freed slots as reserve_slot does), first-time bucket tables and the dirty
 * list. Pools that move several slots grow as if once to their final need (grown_cap). What
 * the compaction after the edit gives back (scene_compact.c) goes to *shrink. `leaves` are the
 * n leaves of the new mesh; a NULL mesh (n 0) walks vis_scene_remove_object instead: its slot
 * freed and its relink, which compacts nothing. With `bound`, an upper bound instead, with *shrink 0: every leaf's
 * quads loose (leaf_words_bound), every moved slot appended (each at least as large as the
 * exact walk's, as slot classes and grown_cap only rise with the need), nothing compacted. */
static uint64_t set_object_growth(const vis_scene *s, uint32_t slot, const vis_mesh *mesh, const uint32_t *leaves,
                                  uint32_t n, int bound, uint64_t *shrink)
{
    uint64_t add = 0;
    *shrink = 0;
    uint32_t quad_cap = 0, tri_cap = 0;
    int dirty = 0;
    const vis_object_host *oh = NULL;
    uint32_t old_count = 0, slot_after = slot;
    const uint32_t *old = NULL;
    if (slot == VIS_NO_OBJECT) {
        slot_after = s->free_count ? s->free_slots[s->free_count - 1] : s->object_slots;
        add = vis_sat_add(add, growth(s->free_cap, (uint64_t)s->free_count + 1, sizeof(uint32_t)));
        if (s->free_count) { /* alloc_slot reuses the last free slot, capacities and all */
            uint32_t reuse = s->free_slots[s->free_count - 1];
            quad_cap = s->object_host[reuse].quad_cap;
            tri_cap = s->object_host[reuse].tri_cap;
            dirty = s->object_dirty_flag[reuse];
        } else {
            add = vis_sat_add(add, growth(s->object_cap, (uint64_t)s->object_slots + 1,
                                          sizeof *s->objects + sizeof *s->object_host + 1));
        }
        if ((uint64_t)(s->object_live + 1) * 2 > s->id_map_cap)
            add = vis_sat_add(add, ((uint64_t)(s->id_map_cap ? s->id_map_cap * 2ull : 1024u) - s->id_map_cap) *
                                       sizeof(uint32_t));
    } else {
        oh = &s->object_host[slot];
        quad_cap = oh->quad_cap;
        tri_cap = oh->tri_cap;
        dirty = s->object_dirty_flag[slot];
        old_count = s->objects[slot].leaf_count;
        old = old_count ? &s->object_leaves[s->objects[slot].leaf_offset] : NULL;
    }
    if (!mesh) /* a removal: the object's slot goes to the free list */
        add = vis_sat_add(add, growth(s->free_cap, (uint64_t)s->free_count + 1, sizeof(uint32_t)));
    if (mesh) {
        if (n != 1) /* a resident object keeps no copy of its quads (object_resident) */
            add = vis_sat_add(add, growth(quad_cap, mesh->quad_count, sizeof(vis_flat_quad)));
        add = vis_sat_add(add, growth(tri_cap, mesh->triangle_count, sizeof(vis_flat_tri)));
    }
    uint32_t leaf_range = slot_after < s->object_slots ? s->object_host[slot_after].leaf_range : 0;
    if (n > leaf_range)
        add = vis_sat_add(add, growth(s->object_leaf_cap, (uint64_t)s->object_leaf_used + n, sizeof(uint32_t)));
    growth_walk g = {{0}, {0}, s->bucket_count};
    pool_sim_init(&g.quads, &s->quad_free, s->quad_used, bound);
    pool_sim_init(&g.tris, &s->tri_free, s->tri_used, bound);
    /* As relink rebuilds them: the leaves the object leaves, then every leaf of the new set. */
    for (uint32_t i = 0; i < old_count; ++i)
        if (!contains(leaves, n, old[i]) && !walk_leaf(s, &g, old[i], slot, NULL, 0, oh, old_count))
            return UINT64_MAX;
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t li = leaves[i];
        int was_in = old && contains(old, old_count, li);
        if (!was_in)
            add = vis_sat_add(add, growth(s->leaf_host[li].object_cap, (uint64_t)s->leaf_host[li].object_count + 1,
                                          sizeof(uint32_t)));
        if (!walk_leaf(s, &g, li, slot_after, mesh, n, was_in ? oh : NULL, old_count))
            return UINT64_MAX;
    }
    const pool_sim *qs = &g.quads, *ts = &g.tris;
    if (qs->used > 0xFFFFFF00u || ts->used > 0xFFFFFF00u)
        return UINT64_MAX;
    uint64_t qcap = pool_sim_cap(qs, s->quad_cap, mesh != NULL), tcap = pool_sim_cap(ts, s->tri_cap, mesh != NULL);
    if ((qcap == 0 && qs->used) || (tcap == 0 && ts->used))
        return UINT64_MAX;
    /* Pools only grow within the edit; a compaction after it gives bytes back. */
    if (qcap >= s->quad_cap)
        add = vis_sat_add(add, (qcap - s->quad_cap) * sizeof *s->quads);
    else
        *shrink += (s->quad_cap - qcap) * sizeof *s->quads;
    if (tcap >= s->tri_cap)
        add = vis_sat_add(add, (tcap - s->tri_cap) * sizeof *s->tris);
    else
        *shrink += (s->tri_cap - tcap) * sizeof *s->tris;
    add = vis_sat_add(add, growth(s->bucket_cap, g.buckets, sizeof(uint32_t)));
    if (!dirty)
        add = vis_sat_add(add, growth(s->dirty_object_cap, (uint64_t)s->dirty_object_count + 1, sizeof(uint32_t)));
    return add;
}

/* The growth the budget check charges an edit (set_object_growth's arguments). The bound
 * settles nearly every edit (a scene far below max_bytes) without packing the leaves' quads
 * once to count them and again to store them; near the limit the exact walk decides. Either
 * way the decision is the exact one. */
static uint64_t edit_growth(const vis_scene *s, uint32_t slot, const vis_mesh *mesh, const uint32_t *leaves,
                            uint32_t n, uint64_t *shrink)
{
    uint64_t add = set_object_growth(s, slot, mesh, leaves, n, 1, shrink);
    if (add == UINT64_MAX || vis_sat_add(vis_scene_bytes(s), add) > s->desc.max_bytes)
        add = set_object_growth(s, slot, mesh, leaves, n, 0, shrink);
    return add;
}

/* Moves an object to a new leaf set and rebuilds every leaf it leaves, joins or stays in; `pe`
 * (NULL for a removal) gives its new quads to those rebuilds. */
static vis_status relink(vis_scene *s, uint32_t slot, const uint32_t *new_leaves, uint32_t new_count,
                         const pending_edit *pe)
{
    vis_flat_object *ob = &s->objects[slot];
    uint32_t old_count = ob->leaf_count;
    uint32_t old_buf[64];
    uint32_t *old = old_buf;
    if (old_count > 64 && !(old = vis_alloc(s->ctx, old_count * sizeof *old)))
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory relinking an object");
    if (old_count)
        memcpy(old, &s->object_leaves[ob->leaf_offset], old_count * sizeof *old);
    vis_status st = VIS_OK;
    for (uint32_t i = 0; i < old_count; ++i)
        if (!contains(new_leaves, new_count, old[i]))
            leaf_remove_object(s, old[i], slot);
    for (uint32_t i = 0; i < new_count && st == VIS_OK; ++i)
        if (!contains(old, old_count, new_leaves[i]) && !leaf_add_object(s, new_leaves[i], slot))
            st = vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for leaf object lists");
    /* The object's own leaf list: rewritten in place when it fits the range the slot holds
     * (kept through removals, for the next object in the slot), else appended. */
    vis_object_host *oh = &s->object_host[slot];
    if (st == VIS_OK && new_count > oh->leaf_range) {
        if (!grow(s->ctx, (void **)&s->object_leaves, &s->object_leaf_cap, s->object_leaf_used + new_count,
                  sizeof(uint32_t)))
            st = vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for object leaf lists");
        else {
            ob->leaf_offset = s->object_leaf_used;
            oh->leaf_range = new_count;
            s->object_leaf_used += new_count;
        }
    }
    if (st == VIS_OK) {
        if (new_count)
            memcpy(&s->object_leaves[ob->leaf_offset], new_leaves, new_count * sizeof(uint32_t));
        ob->leaf_count = new_count;
        mark_object_leaves(s, ob->leaf_offset, ob->leaf_offset + new_count);
        for (uint32_t i = 0; i < old_count && st == VIS_OK; ++i)
            if (!contains(new_leaves, new_count, old[i]))
                st = rebuild_leaf(s, old[i], pe);
        for (uint32_t i = 0; i < new_count && st == VIS_OK; ++i)
            st = rebuild_leaf(s, new_leaves[i], pe);
    }
    if (old != old_buf)
        vis_free(s->ctx, old);
    return st;
}

/* vis_scene_set_object once the mesh is validated, located (its box and leaves) and known
 * to fit the budget. */
static vis_status set_object_located(vis_scene *s, uint32_t id, uint32_t slot, const vis_mesh *mesh,
                                     const float lo[3], const float hi[3], const uint32_t *leaves, uint32_t n)
{
    vis_status st;
    const int had = slot != VIS_NO_OBJECT;
    float old_lo[3] = {0.0f, 0.0f, 0.0f}, old_hi[3] = {0.0f, 0.0f, 0.0f};
    if (had) {
        memcpy(old_lo, s->object_host[slot].box_lo, sizeof old_lo);
        memcpy(old_hi, s->object_host[slot].box_hi, sizeof old_hi);
    }
    if (slot == VIS_NO_OBJECT) {
        if (!grow(s->ctx, (void **)&s->free_slots, &s->free_cap, s->free_count + 1, sizeof(uint32_t)))
            return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for objects");
        if ((st = alloc_slot(s, &slot)) != VIS_OK)
            return st;
        s->objects[slot].id = id;
        if (!map_insert(s, slot)) {
            s->objects[slot].id = 0;
            s->free_slots[s->free_count++] = slot; /* capacity reserved above */
            return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for the ID map");
        }
        ++s->object_live;
        if (id > s->max_id)
            s->max_id = id;
    }
    vis_object_host *oh = &s->object_host[slot];
    uint64_t prim_bytes = (uint64_t)oh->quad_cap * sizeof *oh->quads + (uint64_t)oh->tri_cap * sizeof *oh->tris;
    /* The quads are copied only for an object over several leaves (object_resident); the
     * rebuilds take them from the mesh (pending_edit). */
    int copied = (n == 1 || grow(s->ctx, (void **)&oh->quads, &oh->quad_cap, mesh->quad_count, sizeof *oh->quads)) &&
                 grow(s->ctx, (void **)&oh->tris, &oh->tri_cap, mesh->triangle_count, sizeof *oh->tris);
    s->object_prim_bytes += (uint64_t)oh->quad_cap * sizeof *oh->quads + (uint64_t)oh->tri_cap * sizeof *oh->tris -
                            prim_bytes;
    if (!copied)
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory copying a mesh");
    s->quad_total -= oh->quad_count;
    s->tri_total -= oh->tri_count;
    for (uint32_t i = 0; n != 1 && i < mesh->quad_count; ++i) {
        const vis_quad *q = &mesh->quads[i];
        vis_flat_quad *fq = &oh->quads[i];
        fq->plane = q->plane;
        fq->u0 = q->u0;
        fq->v0 = q->v0;
        fq->u1 = q->u1;
        fq->v1 = q->v1;
        fq->meta = (slot << 8) | (q->flags << 2) | q->axis;
    }
    for (uint32_t i = 0; i < mesh->triangle_count; ++i) {
        const vis_triangle *t = &mesh->triangles[i];
        vis_flat_tri *ft = &oh->tris[i];
        for (int a = 0; a < 3; ++a) {
            ft->v0[a] = t->v[0][a];
            ft->v1[a] = t->v[1][a];
            ft->v2[a] = t->v[2][a];
        }
        ft->meta = (slot << 8) | (t->flags << 2);
    }
    oh->quad_count = mesh->quad_count;
    oh->tri_count = mesh->triangle_count;
    oh->id = id;
    memcpy(oh->box_lo, lo, sizeof oh->box_lo);
    memcpy(oh->box_hi, hi, sizeof oh->box_hi);
    s->quad_total += oh->quad_count;
    s->tri_total += oh->tri_count;
    pending_edit pe = {slot, mesh};
    st = relink(s, slot, leaves, n, &pe);
    if (st != VIS_OK)
        return st;
    if (!mark_object(s, slot))
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory tracking changes");
    vis_scene_compact_pools(s);
    ++s->edits;
    vis_scene_log_edit(s, had, old_lo, old_hi, 1, lo, hi);
    return VIS_OK;
}

vis_status vis_scene_check_mesh(vis_scene *s, uint32_t id, const vis_mesh *mesh)
{
    if (id == 0 || id > VIS_MAX_OBJECT_ID)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "object ID %u is outside 1..%u", id, VIS_MAX_OBJECT_ID);
    if (!mesh)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "mesh is NULL (pass an empty mesh to remove)");
    return validate_mesh(s, mesh);
}

/* Widens [lo, hi] on axis a to hold [x0, x1] (finite values). */
static inline void box_add(float *lo, float *hi, uint32_t a, float x0, float x1)
{
    lo[a] = x0 < lo[a] ? x0 : lo[a];
    hi[a] = x1 > hi[a] ? x1 : hi[a];
}

vis_status vis_scene_apply_set(vis_scene *s, uint32_t id, const vis_mesh *mesh)
{
    vis_status st = vis_scene_check_mesh(s, id, mesh);
    if (st != VIS_OK)
        return st;
    uint32_t slot = vis_scene_find(s, id);
    if (mesh->quad_count == 0 && mesh->triangle_count == 0)
        return slot == VIS_NO_OBJECT ? VIS_OK : vis_scene_apply_remove(s, id);

    /* The box and the leaves first: the budget needs them before anything changes. The
     * mesh is checked, so every coordinate is finite: plain compares, not fminf calls. */
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < mesh->quad_count; ++i) {
        const vis_quad *q = &mesh->quads[i];
        uint32_t a = q->axis, u = (a + 1) % 3, v = (a + 2) % 3;
        box_add(lo, hi, a, q->plane, q->plane);
        box_add(lo, hi, u, q->u0, q->u1);
        box_add(lo, hi, v, q->v0, q->v1);
    }
    for (uint32_t i = 0; i < mesh->triangle_count; ++i)
        for (uint32_t a = 0; a < 3; ++a)
            for (int k = 0; k < 3; ++k)
                box_add(lo, hi, a, mesh->triangles[i].v[k][a], mesh->triangles[i].v[k][a]);
    uint32_t leaves_buf[64];
    uint32_t n = vis_kdtree_leaves_of_box(s, lo, hi, leaves_buf, 64);
    uint32_t *leaves = leaves_buf;
    if (n > 64) {
        leaves = vis_alloc(s->ctx, (size_t)n * sizeof *leaves);
        if (!leaves)
            return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory locating an object");
        vis_kdtree_leaves_of_box(s, lo, hi, leaves, n);
    }
    uint64_t shrink = 0, add = edit_growth(s, slot, mesh, leaves, n, &shrink);
    st = check_growth(s, add, shrink, "setting the mesh", id);
    if (st == VIS_OK)
        st = set_object_located(s, id, slot, mesh, lo, hi, leaves, n);
    if (leaves != leaves_buf)
        vis_free(s->ctx, leaves);
    return st;
}

vis_status vis_scene_apply_remove(vis_scene *s, uint32_t id)
{
    uint32_t slot = vis_scene_find(s, id);
    if (slot == VIS_NO_OBJECT)
        return vis_fail(s->ctx, VIS_ERROR_NOT_FOUND, "no object with ID %u", id);
    /* The free list may grow, and the dirty list, and the leaves the object leaves. */
    uint64_t shrink = 0, add = edit_growth(s, slot, NULL, NULL, 0, &shrink);
    vis_status st = check_growth(s, add, shrink, "removing", id);
    if (st != VIS_OK)
        return st;
    if (!grow(s->ctx, (void **)&s->free_slots, &s->free_cap, s->free_count + 1, sizeof(uint32_t)) ||
        !mark_object(s, slot))
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory removing an object");
    vis_object_host *oh = &s->object_host[slot];
    s->quad_total -= oh->quad_count;
    s->tri_total -= oh->tri_count;
    oh->quad_count = 0;
    oh->tri_count = 0;
    st = relink(s, slot, NULL, 0, NULL);
    if (st != VIS_OK)
        return st;
    map_remove(s, id);
    s->objects[slot].id = 0;
    oh->id = 0;
    s->free_slots[s->free_count++] = slot;
    --s->object_live;
    if (id == s->max_id) {
        s->max_id = 0;
        for (uint32_t i = 0; i < s->object_slots; ++i)
            if (s->objects[i].id > s->max_id)
                s->max_id = s->objects[i].id;
    }
    ++s->edits;
    vis_scene_log_edit(s, 1, oh->box_lo, oh->box_hi, 0, NULL, NULL);
    return VIS_OK;
}

/* ---- queries ------------------------------------------------------------------------- */

static vis_status get_info_locked(const vis_scene *s, vis_scene_info *out)
{
    memset(out, 0, sizeof *out);
    memcpy(out->origin, s->desc.origin, sizeof out->origin);
    memcpy(out->size, s->desc.size, sizeof out->size);
    out->cell_size = s->desc.cell_size;
    out->kd_depth = s->kd_depth;
    out->nodes = s->node_count;
    out->leaves = s->leaf_count;
    out->objects = s->object_live;
    out->max_id = s->max_id;
    out->quads = s->quad_total;
    out->triangles = s->tri_total;
    out->edits = s->edits;
    out->bytes = vis_scene_bytes(s); /* ropes included */
    out->max_bytes = s->desc.max_bytes;
    const vis_backend_ops *ops = s->ctx->backend.ops;
    out->backend_bytes = s->backend_data && ops->scene_bytes ? ops->scene_bytes(s->ctx->backend.impl, s->backend_data) : 0;
    return VIS_OK;
}

vis_status vis_scene_get_info(const vis_scene *s, vis_scene_info *out)
{
    if (!s || !out)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_scene_begin_read(s);
    vis_status st = get_info_locked(s, out);
    vis_scene_end_read(s);
    return st;
}

static vis_status leaf_objects_locked(const vis_scene *s, uint32_t leaf_id, uint32_t *out_ids, uint32_t capacity,
                                      uint32_t *out_count)
{
    if (leaf_id == 0 || leaf_id > s->leaf_count)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT, "leaf ID %u is outside 1..%u", leaf_id, s->leaf_count);
    const vis_leaf_host *lh = &s->leaf_host[leaf_id - 1];
    *out_count = lh->object_count;
    if (!out_ids)
        return VIS_OK;
    if (capacity < lh->object_count)
        return vis_fail(s->ctx, VIS_ERROR_CAPACITY, "leaf %u holds %u objects, capacity is %u", leaf_id,
                        lh->object_count, capacity);
    for (uint32_t i = 0; i < lh->object_count; ++i)
        out_ids[i] = s->objects[lh->objects[i]].id;
    /* Slots ascend, IDs need not: sort (leaves hold few objects). */
    for (uint32_t i = 1; i < lh->object_count; ++i) {
        uint32_t x = out_ids[i], j = i;
        while (j > 0 && out_ids[j - 1] > x) {
            out_ids[j] = out_ids[j - 1];
            --j;
        }
        out_ids[j] = x;
    }
    return VIS_OK;
}

vis_status vis_scene_leaf_objects(const vis_scene *s, uint32_t leaf_id, uint32_t *out_ids, uint32_t capacity,
                                  uint32_t *out_count)
{
    if (!s || !out_count)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(s->ctx) != VIS_OK) /* its errors go to the scene's context */
        return VIS_ERROR_BUSY;
    vis_clear_error(s->ctx);
    vis_scene_begin_read(s);
    vis_status st = leaf_objects_locked(s, leaf_id, out_ids, capacity, out_count);
    vis_scene_end_read(s);
    vis_leave(s->ctx);
    return st;
}

vis_scene_view vis_scene_get_view(const vis_scene *s)
{
    vis_scene_view v;
    memset(&v, 0, sizeof v);
    v.nodes = s->nodes;
    v.node_count = s->node_count;
    v.leaves = s->leaves;
    v.leaf_count = s->leaf_count;
    v.buckets = s->buckets;
    v.bucket_count = s->bucket_count;
    v.quads = s->quads;
    v.quad_count = s->quad_used;
    v.tris = s->tris;
    v.tri_count = s->tri_used;
    v.objects = s->objects;
    v.object_count = s->object_slots;
    v.object_leaves = s->object_leaves;
    v.object_leaf_count = s->object_leaf_used;
    v.ropes = s->ropes;
    v.rope_count = s->rope_count;
    v.rope_index = s->rope_index;
    v.rope_index_count = s->node_count + (s->cell_map ? s->leaf_count : 0u);
    memcpy(v.cells, s->cells, sizeof v.cells);
    v.cell_map = s->cell_map;
    v.cell_size = s->desc.cell_size;
    memcpy(v.size, s->desc.size, sizeof v.size);
    v.kd_depth = s->kd_depth;
    return v;
}
