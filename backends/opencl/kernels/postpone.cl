/* postpone.cl — the stack method's walk with leaf postponing, for the OpenCL kernels built
 * with -DVIS_CL_POSTPONE=K (1..4; the host builds it for VIS_TRAVERSAL_STACK only when
 * $VIS_OPENCL_WALK asks, docs/opencl.md "Persistent threads and leaf postponing").
 *
 * Aila & Laine 2009 ("Understanding the efficiency of ray traversal on GPUs", HPG), the
 * "while-while" loop with postponed leaves: the lanes of a warp step through inner nodes
 * together until each has found a leaf, then test leaves together. vis_traverse_stack already
 * has the while-while shape, but every lane leaves the node loop at its first leaf, so the
 * leaf tests run with the lanes that got there and the rest idle, and the walk then waits
 * for the slowest lane's descent again. Here a lane parks a non-empty leaf (its index and
 * interval), pops the next entry at once and keeps walking until it holds K leaves or has
 * nothing left; then its K leaves are tested in order. With -DVIS_CL_VOTE (NVIDIA only: a
 * warp vote in inline PTX, as the paper's __any) the node loop also ends, for every lane
 * holding at least one leaf, as soon as no lane of the warp is still without one.
 * Empty leaves are never parked (nothing to test), which also saves their loads of a whole
 * leaf record in the leaf loop.
 *
 * Exactness (docs/traversal.md "Exactness"): the order of leaves, their intervals and every
 * decision at inner nodes are vis_traverse_stack's; only the termination test after a leaf
 * sees a best hit that may not yet include the parked leaves', so a ray may test leaves the
 * plain walk would have skipped. Every hit offered is a real hit of that ray and the result is
 * the minimum (t, ID) over what was tested (vis_leaf_intersect), while the winning primitive
 * lies in a leaf that both walks test (a skipped leaf starts beyond lim(best), with a best no
 * nearer than the winner); and a leaf's own walk only drops planes beyond the best hit, which
 * is never nearer than the winner. So the buffers are the stack method's, which are the brute
 * force's (test_opencl checks every method against the CPU). After the leaves are tested the
 * termination test is repeated with the new best hit when the walk stopped right after a pop,
 * which is where vis_traverse_stack makes it. */
#include "../../common/trace_core.h"

#if defined(VIS_CL_POSTPONE)

#if VIS_CL_POSTPONE < 1 || VIS_CL_POSTPONE > 4
#  error "VIS_CL_POSTPONE must be 1..4"
#endif

#if defined(VIS_CL_VOTE)
/* 1 when `pred` holds for any converged lane of the warp executing this (PTX vote.sync over
 * activemask: lanes that left the loop are not in the mask, and do not search). */
VIS_INLINE int vis_cl_warp_any(int pred)
{
    uint mask, r;
    __asm__ volatile("activemask.b32 %0;" : "=r"(mask));
    __asm__ volatile("{\n\t.reg .pred p;\n\tsetp.ne.u32 p, %1, 0;\n\tvote.sync.any.pred p, p, %2;\n\t"
                     "selp.u32 %0, 1, 0, p;\n\t}"
                     : "=r"(r)
                     : "r"((uint)pred), "r"(mask));
    return (int)r;
}
#endif

/* vis_traverse_stack's step after a leaf: the next entry off the stack into node / t_min /
 * t_max. Returns 0 when the stack is empty. */
VIS_INLINE int vis_pp_pop(vis_stack_entry *stack, int *sp, uint *node, float *t_min, float *t_max)
{
    if (*sp == 0)
        return 0;
    --*sp;
    *node = stack[*sp].node;
    if (*node & VIS_STACK_SAME_INTERVAL) {
        *node &= ~VIS_STACK_SAME_INTERVAL;
        *t_min = stack[*sp].t_max; /* saved t_min; t_max stays */
    } else {
        *t_min = *t_max;
        *t_max = stack[*sp].t_max;
    }
    return 1;
}

/* The termination test right after a pop (vis_traverse_stack's, line for line): 0 when the
 * ray is done, else the entry to walk (possibly an in-plane far side further down). */
VIS_INLINE int vis_pp_check(vis_stack_entry *stack, int *sp, uint *node, float *t_min, float *t_max, float best)
{
    if (!(*t_min > vis_t_limit(best)))
        return 1;
    for (;;) {
        int k = *sp - 1;
        while (k >= 0 && !(stack[k].node & VIS_STACK_SAME_INTERVAL))
            --k;
        if (k < 0)
            return 0;
        if (k + 1 < *sp)
            *t_max = stack[k + 1].t_max;
        *sp = k;
        *node = stack[k].node & ~VIS_STACK_SAME_INTERVAL;
        *t_min = stack[k].t_max;
        if (!(*t_min > vis_t_limit(best)))
            return 1;
    }
}

VIS_INLINE void vis_traverse_postpone(const vis_ray *r, const vis_ray_setup *s, VIS_SCENE_PARAMS, vis_hit *h)
{
    float t_min, t_max;
    if (!vis_clip_scene(r, s->size, &t_min, &t_max))
        return;
    vis_stack_entry stack[VIS_STACK_SIZE];
    int sp = 0;
    uint node = s->root;
    /* Parked leaves, oldest first; constant indices only, so they stay in registers. */
    uint pl[VIS_CL_POSTPONE];
    float pa[VIS_CL_POSTPONE], pb[VIS_CL_POSTPONE];
    int n = 0;
    int done = 0;
    int popped = 0; /* node / t_min / t_max are an entry just popped, not yet descended */
    for (;;) {
        while (!done && n < VIS_CL_POSTPONE) {
            uint info = nodes[node].info;
            if ((info & 3u) != VIS_NODE_LEAF) {
                node = vis_descend(r, nodes, node, info, &t_min, &t_max, stack, &sp, VIS_STACK_SIZE);
                popped = 0;
            } else {
                uint leaf = info >> 2;
                if (vis_leaf_has_primitives(&leaves[leaf])) {
#pragma unroll
                    for (int i = 0; i < VIS_CL_POSTPONE; ++i)
                        if (i == n) {
                            pl[i] = leaf;
                            pa[i] = t_min;
                            pb[i] = t_max;
                        }
                    ++n;
                }
                done = !vis_pp_pop(stack, &sp, &node, &t_min, &t_max) ||
                       !vis_pp_check(stack, &sp, &node, &t_min, &t_max, h->t);
                popped = 1;
            }
#if defined(VIS_CL_VOTE)
            if (!vis_cl_warp_any(n == 0 && !done))
                break; /* every lane of the warp holds a leaf (or is done): test them */
#endif
        }
        if (n == 0)
            return; /* done, nothing parked */
        while (n > 0) {
            vis_leaf_intersect(r, &leaves[pl[0]], buckets, quads, tris, objects, pa[0], pb[0], h);
#pragma unroll
            for (int i = 0; i + 1 < VIS_CL_POSTPONE; ++i) {
                pl[i] = pl[i + 1];
                pa[i] = pa[i + 1];
                pb[i] = pb[i + 1];
            }
            --n;
        }
        if (!done && popped)
            done = !vis_pp_check(stack, &sp, &node, &t_min, &t_max, h->t);
    }
}

/* vis_trace_pixel_slot (trace_core.h) with this walk: the ray, the walk, the ID and depth to
 * write and the hit's object slot. */
VIS_INLINE void vis_cl_pixel_postpone(const vis_ray_setup *s, uint x, uint y, VIS_SCENE_PARAMS, uint *out_id,
                                      float *out_depth, uint *out_slot)
{
    vis_ray r;
    vis_ray_for_pixel(s, x, y, &r);
    vis_hit h;
#ifdef VIS_TRACE_EFFECTS
    vis_hit_init(&h, VIS_ST_OCCLUDE, 0u, VIS_NO_AXIS, 0.0f);
#else
    h.t = VIS_INF;
    h.object = VIS_NO_OBJECT;
    h.id = 0u;
#endif
    vis_traverse_postpone(&r, s, VIS_SCENE_ARGS, &h);
    *out_slot = h.object;
    if (h.object == VIS_NO_OBJECT) {
        *out_id = 0u;
        *out_depth = VIS_INF;
        return;
    }
    *out_id = s->id_mode == 1u ? vis_hit_leaf_id(&r, &h, VIS_SCENE_ARGS) : h.id;
    *out_depth = h.t;
}

#endif /* VIS_CL_POSTPONE */
