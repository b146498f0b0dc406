/* kdtree.c — the fixed-depth kd-tree, built once over the scene bounds.
 *
 * The voxel-object visibility talk (seeds/002) prebuilds the tree to its maximum depth and
 * afterwards only updates leaf contents: the split planes never depend on the geometry, so
 * no edit can ever require a rebuild. Splits halve the axis with the most cells, always on a
 * cell (chunk) boundary, so that a chunk lies in exactly one leaf. Nodes are flat arrays with
 * index links and both children adjacent (copyable to a device in one transfer).
 */
#include "kdtree.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

static uint32_t ceil_log2(uint32_t n)
{
    uint32_t d = 0;
    while ((1u << d) < n)
        ++d;
    return d;
}

uint32_t vis_kdtree_full_depth(const uint32_t cells[3])
{
    return ceil_log2(cells[0]) + ceil_log2(cells[1]) + ceil_log2(cells[2]);
}

/* The split rule: the axis with the most cells (the lowest such axis on ties). A node whose
 * largest extent is one cell, or that lies at the fixed depth, is a leaf. The build and the
 * plan both use it, so the plan's counts are the build's. */
static uint32_t split_axis(const uint32_t ext[3])
{
    uint32_t axis = 0;
    if (ext[1] > ext[axis])
        axis = 1;
    if (ext[2] > ext[axis])
        axis = 2;
    return axis;
}

typedef struct build_state {
    vis_scene *s;
    uint32_t next_node, node_cap;
    uint32_t next_leaf, leaf_cap;
    int overflow; /* the tree outgrew the plan's counts (never, by construction) */
} build_state;

static void build_node(build_state *b, uint32_t node, const uint32_t c0[3], const uint32_t c1[3], uint32_t depth)
{
    vis_scene *s = b->s;
    uint32_t ext[3] = {c1[0] - c0[0], c1[1] - c0[1], c1[2] - c0[2]};
    uint32_t axis = split_axis(ext);
    if (depth >= s->kd_depth || ext[axis] <= 1) {
        if (b->next_leaf >= b->leaf_cap) {
            b->overflow = 1;
            return;
        }
        uint32_t li = b->next_leaf++;
        s->nodes[node].split = 0.0f;
        s->nodes[node].info = VIS_NODE_LEAF | (li << 2);
        vis_flat_leaf *lf = &s->leaves[li];
        memset(lf, 0, sizeof *lf);
        uint32_t E[3];
        for (int a = 0; a < 3; ++a) {
            lf->lo[a] = (float)c0[a] * s->desc.cell_size;
            float hi = (float)c1[a] * s->desc.cell_size;
            lf->hi[a] = hi < s->desc.size[a] ? hi : s->desc.size[a];
            float e = floorf(lf->hi[a] - lf->lo[a]);
            E[a] = e > 0.0f ? (uint32_t)e : 0u;
        }
        /* Bucketing needs integer plane offsets that fit the packed dims; leaves larger than
         * that keep every quad "loose" (correct, only slower). */
        if (E[0] <= VIS_KD_MAX_BUCKET_EXTENT && E[1] <= VIS_KD_MAX_BUCKET_EXTENT && E[2] <= VIS_KD_MAX_BUCKET_EXTENT) {
            lf->dims_xy = E[0] | (E[1] << 16);
            lf->dims_z = E[2];
        } else {
            lf->dims_xy = 0xFFFFFFFFu; /* marks "no buckets" */
            lf->dims_z = 0xFFFFFFFFu;
        }
        lf->bucket_offset = VIS_KD_NO_BUCKETS;
        return;
    }
    uint32_t mid = c0[axis] + ext[axis] / 2;
    if ((uint64_t)b->next_node + 2 > b->node_cap) {
        b->overflow = 1;
        return;
    }
    uint32_t first = b->next_node;
    b->next_node += 2;
    s->nodes[node].split = (float)mid * s->desc.cell_size;
    s->nodes[node].info = axis | (first << 2);
    uint32_t lc1[3] = {c1[0], c1[1], c1[2]};
    uint32_t rc0[3] = {c0[0], c0[1], c0[2]};
    lc1[axis] = mid;
    rc0[axis] = mid;
    build_node(b, first, c0, lc1, depth + 1);
    build_node(b, first + 1, rc0, c1, depth + 1);
}

/* ---- the plan: the tree's counts without building it ------------------------------------
 *
 * A node's subtree depends only on its extent in cells and its depth (the split rule reads
 * nothing else), so the tree is counted a level at a time over the distinct extents of the
 * level, each with the number of nodes that have it. Halving an axis of n cells k times
 * leaves floor(n / 2^k) or ceil(n / 2^k) cells, and it is always the largest axis that is
 * halved, so a level holds few distinct extents (never more than 16 in a sweep of random
 * sizes up to 2^30 cells per axis; nothing here depends on that bound) where it may hold
 * billions of nodes: the work grows with the depth, not with the node count, and a scene too
 * big to build is refused without being walked.
 */

typedef struct plan_entry {
    uint32_t ext[3];
    uint32_t child[2]; /* entry indices; UINT32_MAX for a leaf */
    uint32_t height;   /* levels down to the deepest leaf below */
    uint64_t count;    /* nodes of this level with this extent  */
} plan_entry;

vis_status vis_kdtree_plan_make(vis_context *ctx, const vis_scene_desc *desc, vis_kdtree_plan *out)
{
    memset(out, 0, sizeof *out);
    for (int a = 0; a < 3; ++a) {
        double n = ceil((double)desc->size[a] / (double)desc->cell_size);
        if (!(n <= (double)VIS_KD_MAX_CELLS))
            return vis_fail(ctx, VIS_ERROR_BUDGET,
                            "scene size[%d] / cell_size = %.0f cells, over the limit of %u cells per axis; use a "
                            "larger cell_size",
                            a, n, VIS_KD_MAX_CELLS);
        out->cells[a] = n < 1.0 ? 1u : (uint32_t)n;
    }
    uint32_t full = vis_kdtree_full_depth(out->cells);
    out->kd_depth = desc->kd_depth == 0 || desc->kd_depth > full ? full : desc->kd_depth;

    uint32_t cap = 64, n = 1;
    plan_entry *e = vis_alloc(ctx, cap * sizeof *e);
    if (!e)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory planning a kd-tree");
    memset(&e[0], 0, sizeof e[0]);
    memcpy(e[0].ext, out->cells, sizeof e[0].ext);
    e[0].count = 1;
    for (uint32_t lo = 0, hi = 1, depth = 0; lo < hi; lo = hi, hi = n, ++depth) {
        for (uint32_t i = lo; i < hi; ++i) {
            uint32_t axis = split_axis(e[i].ext);
            out->nodes = vis_sat_add(out->nodes, e[i].count);
            e[i].child[0] = e[i].child[1] = UINT32_MAX;
            if (depth >= out->kd_depth || e[i].ext[axis] <= 1) {
                out->leaves = vis_sat_add(out->leaves, e[i].count);
                continue;
            }
            for (uint32_t c = 0; c < 2; ++c) {
                uint32_t ext[3] = {e[i].ext[0], e[i].ext[1], e[i].ext[2]};
                ext[axis] = c == 0 ? ext[axis] / 2 : ext[axis] - ext[axis] / 2;
                uint32_t j = hi;
                while (j < n && memcmp(e[j].ext, ext, sizeof ext) != 0)
                    ++j;
                if (j == n) {
                    if (n == cap) {
                        plan_entry *g = vis_realloc(ctx, e, cap * sizeof *e, 2 * cap * sizeof *e);
                        if (!g) {
                            vis_free(ctx, e);
                            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory planning a kd-tree");
                        }
                        e = g;
                        cap *= 2;
                    }
                    memset(&e[n], 0, sizeof e[n]);
                    memcpy(e[n].ext, ext, sizeof ext);
                    ++n;
                }
                e[j].count = vis_sat_add(e[j].count, e[i].count);
                e[i].child[c] = j;
            }
        }
    }
    /* Children come after their parents: heights from the last entry up. */
    for (uint32_t i = n; i-- > 0;) {
        if (e[i].child[0] != UINT32_MAX) {
            uint32_t hl = e[e[i].child[0]].height, hr = e[e[i].child[1]].height;
            e[i].height = 1 + (hl > hr ? hl : hr);
        }
        if (e[i].height <= VIS_MAX_SHORT_STACK)
            out->ropes = vis_sat_add(out->ropes, e[i].count);
    }
    vis_free(ctx, e);
    /* Every leaf one cell (full depth): the DDA method's cell map, one entry a leaf. */
    uint64_t ncells = (uint64_t)out->cells[0] * out->cells[1] * out->cells[2];
    out->bytes = vis_scene_tree_bytes(out->nodes, out->leaves, 0, out->leaves == ncells ? out->leaves : 0);
    return VIS_OK;
}

/* ---- ropes ----------------------------------------------------------------------------
 *
 * Popov et al. 2007 (Stackless kd-tree traversal for high performance GPU ray tracing): each
 * leaf knows its box and, for each of its six faces, the smallest node on the other side that
 * covers the whole face; a ray leaving the leaf follows that link and descends to the leaf
 * holding its exit point, with no stack. Chang & Ihm 2010 (seeds/000, "rope with short
 * stack") keep ropes only on the nodes N levels above the leaves and walk the N levels below
 * them with a short stack, which cuts the rope memory (their Table 4).
 *
 * The tree never changes after creation, so neither do the ropes. They are built once, by the
 * first pass that walks them (vis_kdtree_build_ropes): no other method reads them, and at
 * 56 bytes a node they would be a tenth of a large world's scene.
 * N is chosen per pass (vis_trace_desc.short_stack), so every node up to
 * VIS_MAX_SHORT_STACK levels above the leaves gets an entry: a pass with N uses the highest
 * nodes of height <= N on each path (exactly the nodes N levels up when all leaves are at one
 * depth) and never reads the others. Entry i < leaf_count is leaf i, so plain ropes index
 * `ropes` by leaf without rope_index.
 *
 * A link never points deeper than the node it starts from. That keeps the node reached from
 * a link at or above the level a pass works on (the smallest covering node may otherwise be a
 * child of that level's node split across the face's normal), and changes nothing for leaves
 * of one depth, whose neighbours cover their faces exactly.
 */

typedef struct rope_target {
    uint32_t node;
    uint32_t depth;
    uint32_t c0[3], c1[3]; /* its cells */
} rope_target;

typedef struct rope_state {
    vis_scene *s;
    uint32_t *height; /* per node, until rope_fill overwrites it (build_ropes) */
    uint32_t next_inner; /* next free entry for inner nodes */
} rope_state;

/* The split cell of an inner node, by the build's rule (build_node). */
static uint32_t node_mid(uint32_t axis, const uint32_t c0[3], const uint32_t c1[3])
{
    return c0[axis] + (c1[axis] - c0[axis]) / 2;
}

static uint32_t compute_heights(const vis_scene *s, uint32_t node, uint32_t *height)
{
    uint32_t info = s->nodes[node].info;
    uint32_t h = 0;
    if ((info & 3u) != VIS_NODE_LEAF) {
        uint32_t first = info >> 2;
        uint32_t hl = compute_heights(s, first, height), hr = compute_heights(s, first + 1, height);
        h = 1 + (hl > hr ? hl : hr);
    }
    height[node] = h;
    return h;
}

/* Descends from t (which covers the face) while one child still covers the cell layer just
 * across the face, no deeper than max_depth. */
static void rope_descend(const vis_scene *s, rope_target *t, const uint32_t lo[3], const uint32_t hi[3],
                         uint32_t max_depth)
{
    while (t->depth < max_depth) {
        uint32_t info = s->nodes[t->node].info;
        if ((info & 3u) == VIS_NODE_LEAF)
            return;
        uint32_t a = info & 3u, mid = node_mid(a, t->c0, t->c1), first = info >> 2;
        if (hi[a] <= mid) {
            t->node = first;
            t->c1[a] = mid;
        } else if (lo[a] >= mid) {
            t->node = first + 1;
            t->c0[a] = mid;
        } else {
            return;
        }
        ++t->depth;
    }
}

static void rope_fill(rope_state *rs, uint32_t node, const uint32_t c0[3], const uint32_t c1[3], uint32_t depth,
                      rope_target link[6])
{
    vis_scene *s = rs->s;
    /* Narrow each inherited link to this node's faces. */
    for (uint32_t f = 0; f < 6; ++f) {
        if (link[f].node == VIS_NO_ROPE)
            continue;
        uint32_t a = f >> 1, lo[3], hi[3];
        memcpy(lo, c0, sizeof lo);
        memcpy(hi, c1, sizeof hi);
        if (f & 1u) {
            lo[a] = c1[a];
            hi[a] = c1[a] + 1;
        } else {
            lo[a] = c0[a] - 1;
            hi[a] = c0[a];
        }
        rope_descend(s, &link[f], lo, hi, depth);
    }
    uint32_t info = s->nodes[node].info;
    uint32_t height = rs->height[node]; /* read before the entry below overwrites it */
    uint32_t e = VIS_NO_ROPE;
    if (height <= VIS_MAX_SHORT_STACK)
        e = (info & 3u) == VIS_NODE_LEAF ? info >> 2 : rs->next_inner++;
    s->rope_index[node] = e;
    if (e != VIS_NO_ROPE) {
        vis_rope_node *rn = &s->ropes[e];
        memset(rn, 0, sizeof *rn);
        for (int a = 0; a < 3; ++a) {
            /* The very expressions of build_node, so box faces equal split planes bit for bit. */
            rn->lo[a] = (float)c0[a] * s->desc.cell_size;
            float hi = (float)c1[a] * s->desc.cell_size;
            rn->hi[a] = hi < s->desc.size[a] ? hi : s->desc.size[a];
        }
        for (uint32_t f = 0; f < 6; ++f)
            rn->link[f] = link[f].node;
        rn->node = node;
        rn->height = height;
    }
    if ((info & 3u) == VIS_NODE_LEAF)
        return;
    uint32_t a = info & 3u, first = info >> 2, mid = node_mid(a, c0, c1);
    uint32_t lc1[3] = {c1[0], c1[1], c1[2]}, rc0[3] = {c0[0], c0[1], c0[2]};
    lc1[a] = mid;
    rc0[a] = mid;
    rope_target child[6];
    /* Left child: its high face on the split axis looks at the right child. */
    memcpy(child, link, sizeof child);
    child[2 * a + 1].node = first + 1;
    child[2 * a + 1].depth = depth + 1;
    memcpy(child[2 * a + 1].c0, rc0, sizeof rc0);
    memcpy(child[2 * a + 1].c1, c1, sizeof rc0);
    rope_fill(rs, first, c0, lc1, depth + 1, child);
    memcpy(child, link, sizeof child);
    child[2 * a].node = first;
    child[2 * a].depth = depth + 1;
    memcpy(child[2 * a].c0, c0, sizeof rc0);
    memcpy(child[2 * a].c1, lc1, sizeof rc0);
    rope_fill(rs, first + 1, rc0, c1, depth + 1, child);
}

/* The DDA method's map (trace_core.h, vis_traverse_dda): the entry of every cell, x fastest,
 * at rope_index[cell_map + cell]: its leaf, and the largest clearance, since every leaf is
 * empty. The walk repeats build_node's splits. */
_Static_assert(VIS_MAX_KD_NODES <= 1u << VIS_CELL_LEAF_BITS, "a map entry's leaf fits below its clearance");
static void fill_cell_map(vis_scene *s, uint32_t node, const uint32_t c0[3], const uint32_t c1[3])
{
    uint32_t info = s->nodes[node].info;
    if ((info & 3u) == VIS_NODE_LEAF) {
        /* Full depth: every leaf is one cell. */
        s->rope_index[s->cell_map + c0[0] + s->cells[0] * (c0[1] + s->cells[1] * c0[2])] =
            info >> 2 | VIS_CELL_CLEAR_MAX << VIS_CELL_LEAF_BITS;
        return;
    }
    uint32_t axis = info & 3u, first = info >> 2;
    uint32_t mid = c0[axis] + (c1[axis] - c0[axis]) / 2;
    uint32_t lc1[3] = {c1[0], c1[1], c1[2]};
    uint32_t rc0[3] = {c0[0], c0[1], c0[2]};
    lc1[axis] = mid;
    rc0[axis] = mid;
    fill_cell_map(s, first, c0, lc1);
    fill_cell_map(s, first + 1, rc0, c1);
}

/* The index (node_count entries, VIS_NO_ROPE until vis_kdtree_build_ropes fills them) and,
 * at full depth (as many leaves as cells), the cell map after it. */
static vis_status build_index(vis_scene *s, const uint32_t cells[3])
{
    uint64_t ncells = (uint64_t)cells[0] * cells[1] * cells[2];
    s->cell_map = ncells == s->leaf_count ? s->node_count : 0u;
    memcpy(s->cells, cells, sizeof s->cells);
    s->rope_index = vis_alloc(s->ctx, ((size_t)s->node_count + (s->cell_map ? s->leaf_count : 0u)) *
                                          sizeof *s->rope_index);
    if (!s->rope_index)
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for the index of %u nodes", s->node_count);
    for (uint32_t i = 0; i < s->node_count; ++i)
        s->rope_index[i] = VIS_NO_ROPE;
    uint32_t zero[3] = {0, 0, 0};
    if (s->cell_map)
        fill_cell_map(s, 0, zero, cells);
    return VIS_OK;
}

vis_status vis_kdtree_build_ropes(vis_scene *s, vis_context *ctx)
{
    if (s->ropes || s->node_count == 0)
        return VIS_OK;
    rope_state rs = {s, NULL, 0};
    /* The heights live in rope_index until rope_fill replaces each with the node's entry: it
     * reads a node's height before it writes the node's entry, and its children's after.
     * That keeps the build within the bytes counted below (no array of its own). */
    rs.height = s->rope_index;
    compute_heights(s, 0, rs.height);
    uint32_t count = 0;
    for (uint32_t i = 0; i < s->node_count; ++i)
        count += rs.height[i] <= VIS_MAX_SHORT_STACK;
    const uint64_t now = vis_scene_bytes(s), add = (uint64_t)count * sizeof *s->ropes;
    vis_status st = VIS_OK;
    if (vis_sat_add(now, add) > s->desc.max_bytes)
        st = vis_fail(ctx, VIS_ERROR_BUDGET, "the ropes of %u nodes would grow the scene from %llu to %llu bytes, over "
                      "max_bytes %llu", count, (unsigned long long)now, (unsigned long long)(now + add),
                      (unsigned long long)s->desc.max_bytes);
    else if (!(s->ropes = vis_calloc(s->ctx, count, sizeof *s->ropes)))
        st = vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for %u rope nodes", count);
    if (st != VIS_OK) {
        for (uint32_t i = 0; i < s->node_count; ++i)
            s->rope_index[i] = VIS_NO_ROPE;
        return st;
    }
    s->rope_count = count;
    rs.next_inner = s->leaf_count;
    rope_target none[6];
    for (int f = 0; f < 6; ++f)
        none[f].node = VIS_NO_ROPE; /* the root's faces are the scene's */
    uint32_t zero[3] = {0, 0, 0};
    rope_fill(&rs, 0, zero, s->cells, 0, none);
    return VIS_OK;
}

/* ---- the cell map's clearances ------------------------------------------------------- */

/* The cell of leaf li at full depth: its corner is (float)c * cell_size (build_node), so
 * the rounded quotient is the cell, checked against the map; a corner that rounding made
 * ambiguous (cells past 2^24 on an axis) is found by a search of the map. Every leaf is the
 * entry of exactly one cell (leaf_count of them). */
static uint32_t leaf_cell_index(const vis_scene *s, uint32_t li)
{
    const uint32_t *map = s->rope_index + s->cell_map;
    uint32_t c[3];
    for (int a = 0; a < 3; ++a) {
        double q = floor((double)s->leaves[li].lo[a] / (double)s->desc.cell_size + 0.5);
        c[a] = q < 0.0 ? 0u : q >= (double)s->cells[a] ? s->cells[a] - 1u : (uint32_t)q;
    }
    uint32_t i = c[0] + s->cells[0] * (c[1] + s->cells[1] * c[2]);
    if (VIS_CELL_LEAF(map[i]) == li)
        return i;
    for (i = 0; i < s->leaf_count && VIS_CELL_LEAF(map[i]) != li; ++i) {
    }
    return i;
}

/* The coordinates of map cell i (x fastest). */
static void cell_coords(const vis_scene *s, uint32_t i, int64_t c[3])
{
    c[0] = i % s->cells[0];
    c[1] = i / s->cells[0] % s->cells[1];
    c[2] = i / s->cells[0] / s->cells[1];
}

/* Widens the box of changed map entries (s->dirty_map_lo/hi) over cells lo..hi. */
static void widen_dirty_map(vis_scene *s, const uint32_t lo[3], const uint32_t hi[3])
{
    for (int a = 0; a < 3; ++a) {
        s->dirty_map_lo[a] = s->dirty_map && s->dirty_map_lo[a] < lo[a] ? s->dirty_map_lo[a] : lo[a];
        s->dirty_map_hi[a] = s->dirty_map && s->dirty_map_hi[a] > hi[a] ? s->dirty_map_hi[a] : hi[a];
    }
    s->dirty_map = 1;
}

/* Lowers map entry *e's clearance to c where it is higher; whether it did. */
static int lower_clearance(uint32_t *e, uint32_t c)
{
    if (VIS_CELL_CLEAR(*e) <= c)
        return 0;
    *e = VIS_CELL_LEAF(*e) | c << VIS_CELL_LEAF_BITS;
    return 1;
}

/* The clearance of every cell is min(VIS_CELL_CLEAR_MAX, its Chebyshev distance in cells to
 * the nearest cell whose leaf holds primitives). When leaf li gets its first, each cell
 * at distance r < VIS_CELL_CLEAR_MAX takes min(its own, r), shell by shell outwards. The
 * clearances are 1-Lipschitz (a minimum of distances): when no cell of shell r changed, each
 * cell of shell r + 1 has a neighbour in shell r with a clearance <= r, so its own is <= r + 1
 * already, and the walk stops there. Only the steps after an edit that fills an empty cell
 * pay this; a leaf emptied again raises them (vis_kdtree_leaf_emptied). */
void vis_kdtree_leaf_filled(vis_scene *s, uint32_t li)
{
    if (!s->cell_map)
        return;
    const int64_t n[3] = {s->cells[0], s->cells[1], s->cells[2]};
    uint32_t *map = s->rope_index + s->cell_map;
    uint32_t i = leaf_cell_index(s, li);
    if (i >= s->leaf_count) { /* cannot happen (see leaf_cell_index); no clearance is then safe */
        for (i = 0; i < s->leaf_count; ++i)
            lower_clearance(&map[i], 0u);
        const uint32_t first[3] = {0, 0, 0}, last[3] = {s->cells[0] - 1u, s->cells[1] - 1u, s->cells[2] - 1u};
        widen_dirty_map(s, first, last);
        return;
    }
    int64_t c[3];
    cell_coords(s, i, c);
    int64_t lo[3], hi[3];
    int64_t r = 0;
    for (; r < (int64_t)VIS_CELL_CLEAR_MAX; ++r) {
        for (int a = 0; a < 3; ++a) {
            lo[a] = c[a] - r < 0 ? 0 : c[a] - r;
            hi[a] = c[a] + r > n[a] - 1 ? n[a] - 1 : c[a] + r;
        }
        int changed = 0;
        for (int64_t z = lo[2]; z <= hi[2]; ++z)
            for (int64_t y = lo[1]; y <= hi[1]; ++y) {
                uint32_t *row = map + s->cells[0] * ((uint64_t)y + s->cells[1] * (uint64_t)z);
                if (z == c[2] - r || z == c[2] + r || y == c[1] - r || y == c[1] + r) {
                    for (int64_t x = lo[0]; x <= hi[0]; ++x)
                        changed |= lower_clearance(&row[x], (uint32_t)r);
                } else { /* inside the shell on y and z: only its two x faces */
                    if (c[0] - r >= 0)
                        changed |= lower_clearance(&row[c[0] - r], (uint32_t)r);
                    if (r > 0 && c[0] + r < n[0])
                        changed |= lower_clearance(&row[c[0] + r], (uint32_t)r);
                }
            }
        if (!changed)
            break;
    }
    /* Every entry changed lies in the box of the last shell that changed. None did (r = 0)
     * where the cell had held primitives before. */
    if (r == 0)
        return;
    uint32_t l[3], h[3];
    for (int a = 0; a < 3; ++a) {
        l[a] = (uint32_t)(c[a] - (r - 1) < 0 ? 0 : c[a] - (r - 1));
        h[a] = (uint32_t)(c[a] + (r - 1) > n[a] - 1 ? n[a] - 1 : c[a] + (r - 1));
    }
    widen_dirty_map(s, l, h);
}

/* The cells whose clearance a leaf's emptying can raise lie within VIS_CELL_CLEAR_MAX - 1
 * of its cell (farther ones had the cap from it already); their clearances depend on the
 * cells within as much again. CLEAR_REGION is that region's side. */
#define CLEAR_REACH ((int64_t)VIS_CELL_CLEAR_MAX - 1)
#define CLEAR_REGION (4 * CLEAR_REACH + 1)

/* One pass of the distance transform along axis a over a region of m[0] x m[1] x m[2]
 * values (x fastest): dst[cell] = the least max(|k|, src[cell + k along a]) over |k| <=
 * VIS_CELL_CLEAR_MAX, cells outside the region taking the cap, for the cells of the box
 * [blo, bhi] only. After three passes over 0 (a cell with primitives) or the cap (an empty
 * one), a cell holds min(cap, its Chebyshev distance to the nearest cell with primitives):
 * the cube of radius r is the product of three segments, so a cube's minimum is three
 * segments' minima in turn. Each pass computes only what the next one reads. */
static void clearance_pass(const uint8_t *src, uint8_t *dst, const int64_t m[3], int a, const int64_t blo[3],
                           const int64_t bhi[3])
{
    const int64_t stride = a == 0 ? 1 : a == 1 ? m[0] : m[0] * m[1], cap = VIS_CELL_CLEAR_MAX;
    int64_t p[3];
    for (p[2] = blo[2]; p[2] <= bhi[2]; ++p[2])
        for (p[1] = blo[1]; p[1] <= bhi[1]; ++p[1])
            for (p[0] = blo[0]; p[0] <= bhi[0]; ++p[0]) {
                const int64_t at = p[0] + m[0] * (p[1] + m[1] * p[2]);
                int64_t best = src[at];
                for (int64_t k = 1; k < best && k <= cap; ++k) {
                    int64_t lo = p[a] - k >= 0 ? src[at - k * stride] : cap;
                    int64_t hi = p[a] + k < m[a] ? src[at + k * stride] : cap;
                    int64_t v = lo < hi ? lo : hi;
                    v = v > k ? v : k;
                    best = v < best ? v : best;
                }
                dst[at] = (uint8_t)best;
            }
}

/* When leaf li has lost its last primitive, the clearances within CLEAR_REACH of its cell
 * are computed again from the cells within twice that (a distance transform over at most
 * CLEAR_REGION^3 cells, 2,197 at the cap of 4), so every clearance stays what
 * vis_kdtree_leaf_filled's comment says: the distance to the nearest cell with primitives
 * now. Only the edits that empty a cell pay this. */
void vis_kdtree_leaf_emptied(vis_scene *s, uint32_t li)
{
    if (!s->cell_map)
        return;
    uint32_t *map = s->rope_index + s->cell_map;
    uint32_t ci = leaf_cell_index(s, li);
    if (ci >= s->leaf_count)
        return; /* cannot happen (see leaf_cell_index); the clearances only stay lower */
    int64_t c[3];
    cell_coords(s, ci, c);
    /* The region (lo, m: its corner and size in the map), and in its own coordinates the
     * box of cells whose clearance can change (ilo..ihi) and the whole region (0..m - 1). */
    int64_t lo[3], m[3], ilo[3], ihi[3], all_lo[3] = {0, 0, 0}, all_hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = c[a] - 2 * CLEAR_REACH < 0 ? 0 : c[a] - 2 * CLEAR_REACH;
        int64_t hi = c[a] + 2 * CLEAR_REACH > (int64_t)s->cells[a] - 1 ? (int64_t)s->cells[a] - 1 : c[a] + 2 * CLEAR_REACH;
        m[a] = hi - lo[a] + 1;
        all_hi[a] = m[a] - 1;
        ilo[a] = (c[a] - CLEAR_REACH < lo[a] ? lo[a] : c[a] - CLEAR_REACH) - lo[a];
        ihi[a] = (c[a] + CLEAR_REACH > hi ? hi : c[a] + CLEAR_REACH) - lo[a];
    }
    /* The map says which cells hold primitives: a clearance of 0 is a cell's own (every
     * clearance is exact, this function and vis_kdtree_leaf_filled keep it so; after their
     * fallbacks some are lower, which only keeps more of them low), but for the cell that has
     * just emptied. */
    uint8_t d[2][CLEAR_REGION * CLEAR_REGION * CLEAR_REGION];
    for (int64_t z = 0; z < m[2]; ++z)
        for (int64_t y = 0; y < m[1]; ++y) {
            const uint32_t *row = map + (uint64_t)lo[0] + s->cells[0] * ((uint64_t)(lo[1] + y) + s->cells[1] * (uint64_t)(lo[2] + z));
            for (int64_t x = 0; x < m[0]; ++x)
                d[0][x + m[0] * (y + m[1] * z)] = VIS_CELL_CLEAR(row[x]) ? (uint8_t)VIS_CELL_CLEAR_MAX : 0u;
        }
    d[0][(c[0] - lo[0]) + m[0] * ((c[1] - lo[1]) + m[1] * (c[2] - lo[2]))] = (uint8_t)VIS_CELL_CLEAR_MAX;
    /* x for the changing columns of every row, then y for those of every plane, then z. */
    const int64_t bx_hi[3] = {ihi[0], all_hi[1], all_hi[2]}, by_hi[3] = {ihi[0], ihi[1], all_hi[2]};
    const int64_t bx_lo[3] = {ilo[0], all_lo[1], all_lo[2]}, by_lo[3] = {ilo[0], ilo[1], all_lo[2]};
    clearance_pass(d[0], d[1], m, 0, bx_lo, bx_hi);
    clearance_pass(d[1], d[0], m, 1, by_lo, by_hi);
    clearance_pass(d[0], d[1], m, 2, ilo, ihi);
    /* Every cell within CLEAR_REACH of a changing cell is in the region (or outside the
     * map), so their values are exact. */
    for (int64_t z = ilo[2]; z <= ihi[2]; ++z)
        for (int64_t y = ilo[1]; y <= ihi[1]; ++y)
            for (int64_t x = ilo[0]; x <= ihi[0]; ++x) {
                uint32_t *e = &map[(uint64_t)(lo[0] + x) +
                                   s->cells[0] * ((uint64_t)(lo[1] + y) + s->cells[1] * (uint64_t)(lo[2] + z))];
                uint32_t v = d[1][x + m[0] * (y + m[1] * z)];
                if (VIS_CELL_CLEAR(*e) == v)
                    continue;
                *e = VIS_CELL_LEAF(*e) | v << VIS_CELL_LEAF_BITS;
                const uint32_t p[3] = {(uint32_t)(lo[0] + x), (uint32_t)(lo[1] + y), (uint32_t)(lo[2] + z)};
                widen_dirty_map(s, p, p);
            }
}

vis_status vis_kdtree_build(vis_scene *s, const vis_kdtree_plan *plan)
{
    s->kd_depth = plan->kd_depth;
    if (plan->nodes > VIS_MAX_KD_NODES || plan->leaves > plan->nodes)
        return vis_fail(s->ctx, VIS_ERROR_BUDGET, "kd-tree would have %llu nodes, over the limit of %u",
                        (unsigned long long)plan->nodes, VIS_MAX_KD_NODES);
    s->nodes = vis_calloc(s->ctx, (size_t)plan->nodes, sizeof *s->nodes);
    s->leaves = vis_calloc(s->ctx, (size_t)plan->leaves, sizeof *s->leaves);
    s->leaf_host = vis_calloc(s->ctx, (size_t)plan->leaves, sizeof *s->leaf_host);
    if (!s->nodes || !s->leaves || !s->leaf_host)
        return vis_fail(s->ctx, VIS_ERROR_OUT_OF_MEMORY, "out of memory for a kd-tree of %llu nodes",
                        (unsigned long long)plan->nodes);
    build_state b = {s, 1, (uint32_t)plan->nodes, 0, (uint32_t)plan->leaves, 0};
    uint32_t zero[3] = {0, 0, 0};
    build_node(&b, 0, zero, plan->cells, 0);
    s->node_count = b.next_node;
    s->leaf_count = b.next_leaf;
    if (b.overflow || b.next_node != plan->nodes || b.next_leaf != plan->leaves)
        return vis_fail(s->ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "internal: the kd-tree build does not match its plan (%llu nodes, %llu leaves)",
                        (unsigned long long)plan->nodes, (unsigned long long)plan->leaves);
    return build_index(s, plan->cells);
}

/* Leaves whose closed box overlaps the object's box. A box touching a split plane only from
 * one side goes to that side alone, so a chunk's box (whose faces lie on chunk boundaries)
 * lands in exactly one leaf; a box that is flat on a split plane goes to the upper side. */
static void collect(const vis_scene *s, uint32_t node, const float lo[3], const float hi[3], uint32_t *out,
                    uint32_t *count, uint32_t cap)
{
    for (;;) {
        uint32_t info = s->nodes[node].info;
        if ((info & 3u) == VIS_NODE_LEAF) {
            if (*count < cap)
                out[*count] = info >> 2;
            ++*count;
            return;
        }
        uint32_t a = info & 3u, first = info >> 2;
        float split = s->nodes[node].split;
        int left = lo[a] < split;
        int right = hi[a] > split || (lo[a] == split && hi[a] == split);
        if (left && right) {
            collect(s, first, lo, hi, out, count, cap);
            node = first + 1;
        } else {
            node = left ? first : first + 1;
        }
    }
}

uint32_t vis_kdtree_leaves_of_box(const vis_scene *s, const float lo[3], const float hi[3], uint32_t *out,
                                  uint32_t cap)
{
    uint32_t count = 0;
    collect(s, 0, lo, hi, out, &count, cap);
    return count;
}
