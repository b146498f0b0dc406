/* tile.cl — VIS_TRAVERSAL_PACKET on a device: a work-group (one tile of pixels) walks the
 * kd-tree once for all its rays, the CPU packets' idea (backends/cpu/packet_impl.h; Wald,
 * Slusallek, Benthin, Wagner 2001) in its simplest form for a GPU.
 *
 * The walk is the group's, not a ray's: the current node, its box and the stack of nodes
 * still to visit are the same in every work-item (each item keeps the node and box in its
 * registers; the stack lives once in local memory, written by item 0). At each node every
 * ray tests the node's box, widened (below), against its own interval [t_near, t_far]
 * clipped to the best hit it has so far; the group enters the node when one ray does (a
 * flag in local memory, one barrier per node). In a leaf, only the rays that entered it test
 * its primitives, with trace_core.h's vis_leaf_intersect over their own part of the widened
 * box -- the per-ray exact tests. Children are visited near side first (the side of the
 * split plane the eye lies on, as every other method), so later nodes are mostly culled by
 * the hits found.
 *
 * Exactness: a ray's result is the minimum (t, ID) over the primitives it tests, each with
 * the exact tests of trace_core.h (as the brute force). A primitive it does not test lies in
 * a leaf whose widened box the ray misses, or enters beyond its best hit by more than
 * vis_t_limit's slack: either way the primitive cannot be hit, or cannot win. The widening
 * (BOX_SLACK of the largest distance from the eye to the scene box) is far more than the
 * slack of vis_quad_intersect (2^-19 of |t d|) and of the tree walks' decisions (2^-20 of t),
 * as in packet_impl.h; a wider interval only tests more planes of a leaf. So every pixel
 * equals the brute force's, which tests/test_opencl.c checks.
 *
 * What the CPU packets also do and this does not (yet): occupancy flags of whole subtrees
 * (only empty leaves are skipped: never entered nor pushed), interval bounds of the tile's
 * directions, per-quad frustum culls. docs/opencl.md has the measurements: on the H200 this
 * is slower than the per-ray stack method, so it is not the default.
 *
 * The loop has its one barrier at the same place in every iteration, with no `continue`
 * around it: a first version that `continue`d past it after a descent gave wrong pixels on
 * PoCL with 8x8 groups (right ones with 1x1); the cause was not found. */
#include "../../common/trace_core.h"

#define VIS_TILE_BOX_SLACK 3.0517578125e-05f /* 2^-15 */

typedef struct vis_tile_entry {
    uint node;
    float lo[3], hi[3];
} vis_tile_entry;
typedef char vis_cl_check_tile_entry[sizeof(vis_tile_entry) == 28 ? 1 : -1]; /* VIS_CL_TILE_ENTRY_BYTES */

/* The ray's part [*ta, *tb] of box [lo - slack, hi + slack] within [t_near, t_far]: 0 when
 * it has none (with vis_t_limit's slack) or when it starts beyond vis_t_limit(best). */
VIS_INLINE int vis_tile_enters(const vis_ray *r, const float *lo, const float *hi, float slack, float best,
                               float *ta, float *tb)
{
    float a = r->t_near, b = r->t_far;
    for (int i = 0; i < 3; ++i) {
        float l = lo[i] - slack, h = hi[i] + slack;
        if (r->d[i] == 0.0f) {
            if (r->o[i] < l || r->o[i] > h)
                return 0;
            continue;
        }
        float t0 = (l - r->o[i]) * r->inv[i];
        float t1 = (h - r->o[i]) * r->inv[i];
        if (t0 > t1) {
            float tmp = t0;
            t0 = t1;
            t1 = tmp;
        }
        a = t0 > a ? t0 : a;
        b = t1 < b ? t1 : b;
    }
    *ta = a;
    *tb = b;
    return a <= vis_t_limit(b) && a <= vis_t_limit(best);
}

/* A leaf without primitives: skipped without a barrier. */
VIS_INLINE int vis_tile_empty_leaf(const __global vis_kd_node *nodes, const __global vis_flat_leaf *leaves, uint node)
{
    uint info = nodes[node].info;
    if ((info & 3u) != VIS_NODE_LEAF)
        return 0;
    return !vis_leaf_has_primitives(&leaves[info >> 2]);
}

/* One work-item's pixel (x, y) of view s, traced by its group's walk. Every item of the
 * group must call it (it synchronises the group), in the image or not; returns 0 for an item
 * outside the image (outputs untouched). flags: 3 words, stack: VIS_STACK_SIZE entries, both
 * in local memory (the kernel's). */
VIS_INLINE int vis_trace_tile_slot(const vis_ray_setup *s, uint x, uint y, VIS_SCENE_PARAMS,
                                   __local uint *flags, __local vis_tile_entry *stack, uint *out_id,
                                   float *out_depth, uint *out_slot)
{
    int inside = x < s->width && y < s->height;
    vis_ray r;
    vis_ray_for_pixel(s, inside ? x : 0u, inside ? y : 0u, &r);
    vis_hit h;
    h.t = VIS_INF;
    h.object = VIS_NO_OBJECT;
    h.id = 0u;

    /* The widening: BOX_SLACK of a bound on |t d| inside the scene box (the sum over axes of
     * the eye's largest distance to the box's faces), the same in every item. */
    float reach = 0.0f;
    for (int a = 0; a < 3; ++a)
        reach += fmax(fabs(s->origin[a]), fabs(s->origin[a] - s->size[a]));
    float slack = VIS_TILE_BOX_SLACK * reach;

    uint lid = (uint)(get_local_id(1) * get_local_size(0) + get_local_id(0));
    if (lid == 0u)
        flags[0] = flags[1] = flags[2] = 0u;
    barrier(CLK_LOCAL_MEM_FENCE);

    uint node = s->root;
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = 0.0f;
        hi[a] = s->size[a];
    }
    int sp = 0;
    uint round = 0u; /* barriers passed: flags[round % 3] is this node's */
    for (;;) {
        /* Does any ray enter? Flags rotate over three words: this round's is set, read after
         * the barrier, and the one of two rounds ahead cleared -- by then every item has read
         * it (one round back) and none has set it yet (one barrier ahead). One barrier per
         * node, at the same place in every iteration. */
        uint info = nodes[node].info;
        float ta = 0.0f, tb = 0.0f;
        int in = inside && vis_tile_enters(&r, lo, hi, slack, h.t, &ta, &tb);
        uint f = round % 3u;
        if (in)
            flags[f] = 1u;
        barrier(CLK_LOCAL_MEM_FENCE);
        int any = flags[f] != 0u;
        if (lid == 0u)
            flags[(round + 2u) % 3u] = 0u;
        ++round;

        int pop = 1;
        if (any && (info & 3u) != VIS_NODE_LEAF) {
            uint a = info & 3u, first = info >> 2;
            float split = nodes[node].split;
            uint near_child = vis_near_child(s->origin[a], s->forward[a], split, first);
            uint far_child = near_child == first ? first + 1u : first;
            int near_full = !vis_tile_empty_leaf(nodes, leaves, near_child);
            int far_full = !vis_tile_empty_leaf(nodes, leaves, far_child);
            /* The far child goes on the stack, written by item 0; the next node's barrier
             * comes before any item pops it. Empty leaves are never entered nor pushed. */
            if (near_full && far_full && sp < VIS_STACK_SIZE) { /* capacity > depth, as vis_descend */
                if (lid == 0u) {
                    __local vis_tile_entry *e = &stack[sp];
                    e->node = far_child;
                    for (int k = 0; k < 3; ++k) {
                        e->lo[k] = lo[k];
                        e->hi[k] = hi[k];
                    }
                    if (far_child == first)
                        e->hi[a] = split;
                    else
                        e->lo[a] = split;
                }
                ++sp;
            }
            if (near_full || far_full) {
                node = near_full ? near_child : far_child;
                if (node == first)
                    hi[a] = split;
                else
                    lo[a] = split;
                pop = 0;
            }
        } else if (in && (info & 3u) == VIS_NODE_LEAF) {
            vis_leaf_intersect(&r, &leaves[info >> 2], buckets, quads, tris, objects, ta, tb, &h);
        }
        if (pop) {
            if (sp == 0)
                break;
            /* Every item reads the entry; item 0 wrote it before an earlier barrier, and
             * overwrites the slot only after the next one. */
            --sp;
            node = stack[sp].node;
            for (int k = 0; k < 3; ++k) {
                lo[k] = stack[sp].lo[k];
                hi[k] = stack[sp].hi[k];
            }
        }
    }
    if (!inside)
        return 0;
    *out_slot = h.object;
    if (h.object == VIS_NO_OBJECT) {
        *out_id = 0u;
        *out_depth = VIS_INF;
        return 1;
    }
    *out_id = s->id_mode == 1u ? vis_hit_leaf_id(&r, &h, VIS_SCENE_ARGS) : h.id;
    *out_depth = h.t;
    return 1;
}
