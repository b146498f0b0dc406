/* occupancy.c — see occupancy.h. */
#include <math.h>

#include "cpu/occupancy.h"

#define PATH_MAX_NODES 128 /* deeper than any tree (kd_depth is at most 48; full depth at most 90) */

void vis_occupancy_free(vis_occupancy *occ)
{
    vis_host_free(occ->alloc, occ->parent);
    vis_host_free(occ->alloc, occ->leaf_node);
    vis_host_free(occ->alloc, occ->fill);
    occ->parent = occ->leaf_node = NULL;
    occ->fill = NULL;
    occ->node_count = occ->leaf_count = 0;
}

/* The fill of a node spanning [y0, y1] on y whose primitives' parts inside it lie in [c0,
 * c1]: the tightest bytes whose bounds (vis_node_fill_lo, _hi) still hold [c0, c1]. */
static vis_node_fill fill_of(float c0, float c1, float y0, float y1)
{
    if (!(c0 >= y0))
        c0 = y0;
    if (!(c1 <= y1))
        c1 = y1;
    if (!(c0 <= c1)) { /* cannot happen for parts inside the box: the whole height */
        c0 = y0;
        c1 = y1;
    }
    if (!(y1 > y0))
        return (vis_node_fill){0u, 255u}; /* a box of no height (the tree makes none): all of it */
    float scale = 255.0f / (y1 - y0);
    int lo = (int)((c0 - y0) * scale), hi = (int)ceilf((c1 - y0) * scale);
    lo = lo < 0 ? 0 : lo > 255 ? 255 : lo;
    hi = hi < 0 ? 0 : hi > 255 ? 255 : hi;
    vis_node_fill f = {(uint8_t)lo, (uint8_t)hi};
    while (f.lo > 0u && vis_node_fill_lo(f, y0, y1) > c0)
        --f.lo;
    while (f.lo < 255u && vis_node_fill_lo((vis_node_fill){(uint8_t)(f.lo + 1u), 0u}, y0, y1) <= c0)
        ++f.lo;
    while (f.hi < 255u && vis_node_fill_hi(f, y0, y1) < c1)
        ++f.hi;
    while (f.hi > f.lo && vis_node_fill_hi((vis_node_fill){0u, (uint8_t)(f.hi - 1u)}, y0, y1) >= c1)
        --f.hi;
    if (f.hi < f.lo)
        f.hi = f.lo; /* a node too thin for 255ths to part them: both bounds hold [c0, c1] */
    return f;
}

/* A leaf's fill: its packed quads' content box cut to the leaf (as the packets cut it; a quad
 * reaching past its leaf lies in the neighbour that holds it too), or the whole leaf where it
 * has loose quads or triangles, which lie anywhere in it. */
static vis_node_fill leaf_fill(const vis_flat_leaf *leaf, float y0, float y1)
{
    if (!vis_leaf_has_primitives(leaf))
        return VIS_NODE_EMPTY;
    if ((leaf->loose_count | leaf->tri_count) || leaf->quad_count == 0u)
        return fill_of(y0, y1, y0, y1);
    uint32_t e = leaf->dims_xy >> 16;
    uint32_t bl = VIS_BOX_FIELD(leaf->content_box, 1u), bh = VIS_BOX_FIELD(leaf->content_box, 4u);
    if (bh == VIS_PQ_COORD_MAX && e > bh)
        bh = e; /* saturated */
    float c0 = leaf->lo[1] + (float)bl, c1 = leaf->lo[1] + (float)bh;
    return fill_of(c0, c1 < leaf->hi[1] ? c1 : leaf->hi[1], y0, y1);
}

/* The y extents of node's children, for node spanning [y0, y1]: the split cuts it only where
 * the node splits y. */
static void child_spans(const vis_kd_node *n, float y0, float y1, float span[2][2])
{
    int on_y = (n->info & 3u) == 1u;
    span[0][0] = y0;
    span[0][1] = on_y ? n->split : y1;
    span[1][0] = on_y ? n->split : y0;
    span[1][1] = y1;
}

/* An inner node's fill from its children's. */
static vis_node_fill inner_fill(const vis_occupancy *occ, const vis_scene_view *view, uint32_t node, float y0,
                                float y1)
{
    const vis_kd_node *n = &view->nodes[node];
    float span[2][2], c0 = INFINITY, c1 = -INFINITY;
    child_spans(n, y0, y1, span);
    for (uint32_t j = 0; j < 2u; ++j) {
        vis_node_fill f = occ->fill[(n->info >> 2) + j];
        if (!vis_node_filled(f))
            continue;
        float lo = vis_node_fill_lo(f, span[j][0], span[j][1]), hi = vis_node_fill_hi(f, span[j][0], span[j][1]);
        c0 = lo < c0 ? lo : c0;
        c1 = hi > c1 ? hi : c1;
    }
    return c0 <= c1 ? fill_of(c0, c1, y0, y1) : VIS_NODE_EMPTY;
}

static vis_node_fill node_fill(const vis_occupancy *occ, const vis_scene_view *view, uint32_t node, float y0,
                               float y1)
{
    uint32_t info = view->nodes[node].info;
    if ((info & 3u) == VIS_NODE_LEAF)
        return leaf_fill(&view->leaves[info >> 2], y0, y1);
    return inner_fill(occ, view, node, y0, y1);
}

/* A frame of the fills' walk: a node, its y extent, and whether its children's fills are in. */
typedef struct fill_frame {
    uint32_t node;
    int children_done;
    float y0, y1;
} fill_frame;

/* Every node's fill from its leaves: a walk down from the root (which spans [0, size[1]], as
 * the packets' walk starts) carries each node's y extent to its children, and a node's fill
 * is made once its children's are. The walk holds two frames per level of the tree at most,
 * so no array of extents is needed beside the fills. */
static vis_status fill_all(vis_occupancy *occ, const vis_scene_view *view)
{
    fill_frame stack[2 * PATH_MAX_NODES + 1];
    int sp = 0;
    if (view->node_count)
        stack[sp++] = (fill_frame){0u, 0, 0.0f, view->size[1]};
    while (sp > 0) {
        fill_frame f = stack[--sp];
        uint32_t info = view->nodes[f.node].info;
        if ((info & 3u) == VIS_NODE_LEAF || f.children_done) {
            occ->fill[f.node] = node_fill(occ, view, f.node, f.y0, f.y1);
            continue;
        }
        if (sp + 3 > (int)(sizeof stack / sizeof stack[0]))
            return VIS_ERROR_BACKEND; /* deeper than any tree kdtree.c builds */
        float cs[2][2];
        child_spans(&view->nodes[f.node], f.y0, f.y1, cs);
        f.children_done = 1;
        stack[sp++] = f;
        for (uint32_t j = 0; j < 2u; ++j)
            stack[sp++] = (fill_frame){(info >> 2) + j, 0, cs[j][0], cs[j][1]};
    }
    return VIS_OK;
}

/* Parent links and leaf nodes (kdtree.c allocates children after their parent), then every
 * node's fill. */
static vis_status rebuild(vis_occupancy *occ, const vis_scene_view *view)
{
    vis_occupancy_free(occ);
    uint32_t n = view->node_count;
    occ->parent = vis_host_alloc(occ->alloc, (size_t)n * sizeof *occ->parent);
    occ->leaf_node = vis_host_alloc(occ->alloc, (size_t)view->leaf_count * sizeof *occ->leaf_node);
    occ->fill = vis_host_alloc(occ->alloc, (size_t)n * sizeof *occ->fill);
    if (!occ->parent || !occ->leaf_node || !occ->fill) {
        vis_occupancy_free(occ);
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    occ->node_count = n;
    occ->leaf_count = view->leaf_count;
    if (n)
        occ->parent[0] = UINT32_MAX;
    for (uint32_t i = 0; i < n; ++i) {
        uint32_t info = view->nodes[i].info;
        if ((info & 3u) == VIS_NODE_LEAF)
            occ->leaf_node[info >> 2] = i;
        else
            occ->parent[info >> 2] = occ->parent[(info >> 2) + 1u] = i;
    }
    vis_status st = fill_all(occ, view);
    if (st != VIS_OK)
        vis_occupancy_free(occ);
    return st;
}

static int same_fill(vis_node_fill a, vis_node_fill b) { return a.lo == b.lo && a.hi == b.hi; }

/* Leaf li's node and its ancestors, bottom-up, from its new content: each node's y extent
 * comes down the path from the root, then the fills go up it while they change. 0 for a path
 * deeper than PATH_MAX_NODES (never: the caller then rebuilds). */
static int refresh_path(vis_occupancy *occ, const vis_scene_view *view, uint32_t li)
{
    uint32_t path[PATH_MAX_NODES];
    float span[PATH_MAX_NODES][2];
    int len = 0;
    for (uint32_t node = occ->leaf_node[li]; node != UINT32_MAX; node = occ->parent[node]) {
        if (len == PATH_MAX_NODES)
            return 0;
        path[len++] = node;
    }
    span[len - 1][0] = 0.0f; /* the root */
    span[len - 1][1] = view->size[1];
    for (int k = len - 1; k > 0; --k) {
        float cs[2][2];
        child_spans(&view->nodes[path[k]], span[k][0], span[k][1], cs);
        uint32_t j = path[k - 1] - (view->nodes[path[k]].info >> 2);
        span[k - 1][0] = cs[j][0];
        span[k - 1][1] = cs[j][1];
    }
    for (int k = 0; k < len; ++k) {
        vis_node_fill f = node_fill(occ, view, path[k], span[k][0], span[k][1]);
        if (k > 0 && same_fill(f, occ->fill[path[k]]))
            break; /* its ancestors' fills are unions of what has not changed */
        occ->fill[path[k]] = f;
    }
    return 1;
}

vis_status vis_occupancy_sync(vis_occupancy *occ, const vis_scene_view *view, const vis_scene_changes *changes)
{
    if (changes->full || !occ->fill || occ->node_count != view->node_count || occ->leaf_count != view->leaf_count)
        return rebuild(occ, view);
    for (uint32_t i = 0; i < changes->leaf_count; ++i)
        if (!refresh_path(occ, view, changes->leaves[i]))
            return rebuild(occ, view);
    return VIS_OK;
}
