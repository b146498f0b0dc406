/* trace.cl — the ray pass on an OpenCL device: one work-item per pixel, in 8x8 work-groups
 * (square tiles, Chang & Ihm 2010), each calling vis_trace_pixel() from trace_core.h, which
 * is compiled in front of this file, so the device runs the CPU's code operation for
 * operation. The host launches a grid rounded up to whole tiles; items past the edge return.
 *
 * The host passes the sizes of the shared structs (-DVIS_CL_*_SIZE); a mismatch with this
 * compiler's layout stops the build here rather than tracing misread scene data. */
#include "../../common/trace_core.h"

#if defined(VIS_CL_SETUP_SIZE)
typedef char vis_cl_check_setup[sizeof(vis_ray_setup) == VIS_CL_SETUP_SIZE ? 1 : -1];
typedef char vis_cl_check_node[sizeof(vis_kd_node) == VIS_CL_NODE_SIZE ? 1 : -1];
typedef char vis_cl_check_leaf[sizeof(vis_flat_leaf) == VIS_CL_LEAF_SIZE ? 1 : -1];
typedef char vis_cl_check_quad[sizeof(vis_flat_quad) == VIS_CL_QUAD_SIZE ? 1 : -1];
typedef char vis_cl_check_tri[sizeof(vis_flat_tri) == VIS_CL_TRI_SIZE ? 1 : -1];
typedef char vis_cl_check_object[sizeof(vis_flat_object) == VIS_CL_OBJECT_SIZE ? 1 : -1];
typedef char vis_cl_check_rope[sizeof(vis_rope_node) == VIS_CL_ROPE_SIZE ? 1 : -1];
typedef char vis_cl_check_effects[sizeof(vis_effect_setup) == VIS_CL_EFFECTS_SIZE ? 1 : -1];
#endif

/* The scene arrays as kernel parameters: VIS_SCENE_PARAMS with `restrict`, which tells the
 * compiler that nothing writes them during the pass (NVIDIA then loads them through the
 * read-only data cache). Must name the same arrays, in the same order, as VIS_SCENE_ARGS;
 * a mismatch fails the build. */
#define VIS_CL_SCENE_PARAMS                                                                  \
    const __global vis_kd_node *restrict nodes, const __global vis_flat_leaf *restrict leaves, \
        const __global uint *restrict buckets, const __global uint *restrict quads,            \
        const __global vis_flat_tri *restrict tris, const __global vis_flat_object *restrict objects, \
        const __global uint *restrict object_leaves, const __global vis_rope_node *restrict ropes, \
        const __global uint *restrict rope_index

/* The cached stack's ring (VIS_TRAVERSAL_ID_CACHED_STACK): the host gives every kernel a
 * local buffer of short_stack entries per work-item (one entry for the other methods);
 * work-item i of the group uses ring[i], ring[i + items], ..., interleaved so that a warp's
 * accesses to one slot fall in different banks. */
#define VIS_CL_RING(ring) (ring + (get_local_id(1) * get_local_size(0) + get_local_id(0)))
#define VIS_CL_RING_STRIDE ((uint)(get_local_size(0) * get_local_size(1)))

/* One work-item's pixel by the program's method; 0 for an item outside the image. Every item
 * of the group calls it: the tile walk (VIS_TRAVERSAL_ID_PACKET, tile.cl) synchronises the
 * group, its flags and stack taking the local buffer that the other methods use as the cached
 * stack's ring (vis_cl_ring_bytes sizes it for either). */
VIS_INLINE int vis_cl_pixel(const vis_ray_setup *s, uint x, uint y, VIS_SCENE_PARAMS, __local vis_stack_entry *ring,
                            uint *id, float *t, uint *slot)
{
#if defined(VIS_TRAVERSAL_ONLY) && VIS_TRAVERSAL_ONLY == 7u
    __local uint *flags = (__local uint *)ring;
    __local vis_tile_entry *stack = (__local vis_tile_entry *)(ring + 2); /* past 16 bytes of flags */
    return vis_trace_tile_slot(s, x, y, VIS_SCENE_ARGS, flags, stack, id, t, slot);
#elif defined(VIS_CL_POSTPONE)
    (void)ring;
    if (x >= s->width || y >= s->height)
        return 0;
    vis_cl_pixel_postpone(s, x, y, VIS_SCENE_ARGS, id, t, slot); /* postpone.cl */
    return 1;
#else
    if (x >= s->width || y >= s->height)
        return 0;
    vis_trace_pixel_slot(s, x, y, VIS_SCENE_ARGS, VIS_CL_RING(ring), VIS_CL_RING_STRIDE, id, t, slot);
    return 1;
#endif
}

/* ---- persistent threads (-DVIS_CL_PERSISTENT) ------------------------------------------
 *
 * Aila & Laine 2009, section 3: instead of one work-group per tile, launched in waves by the
 * hardware, the host launches about as many groups as the device holds at once, and each
 * group takes the next tile from a global counter until none is left, so that no SM idles
 * while the last, slowest tiles of a pass run elsewhere. A tile is a group's shape of pixels
 * (8x8 by default); tiles are numbered row by row, view after view, as the plain grid's. The
 * counter (two words: tiles handed out, groups finished) is zero before a launch; the last
 * group to finish zeroes it again, so the host never has to (docs/opencl.md). The kernels
 * take the counter and the number of views as their two last arguments. */
#if defined(VIS_CL_PERSISTENT)
#  define VIS_CL_PT_PARAMS , __global volatile uint *pt_counter, const uint pt_views

/* The group's next tile: its pixel (x, y) and view v for this work-item; 0 when every tile
 * is taken (every item of the group gets the same answer). next: a __local word. */
VIS_INLINE int vis_cl_next_tile(__global volatile uint *counter, __local volatile uint *next, uint width, uint height,
                                uint views, uint *x, uint *y, uint *v)
{
    uint lw = (uint)get_local_size(0), lh = (uint)get_local_size(1);
    uint tiles_x = (width + lw - 1u) / lw, tiles_y = (height + lh - 1u) / lh;
    uint first = get_local_id(0) == 0 && get_local_id(1) == 0;
    if (first)
        *next = atomic_inc(&counter[0]);
    barrier(CLK_LOCAL_MEM_FENCE);
    uint tile = *next;
    barrier(CLK_LOCAL_MEM_FENCE); /* every item has read it before item 0 writes the next */
    if (tile < tiles_x * tiles_y * views) {
        *v = tile / (tiles_x * tiles_y);
        tile -= *v * tiles_x * tiles_y;
        *x = tile % tiles_x * lw + (uint)get_local_id(0);
        *y = tile / tiles_x * lh + (uint)get_local_id(1);
        return 1;
    }
    /* The last group out zeroes the counter for the next launch (the queue is in order, and
     * a kernel sees the writes of the one before it). */
    uint groups = (uint)(get_num_groups(0) * get_num_groups(1) * get_num_groups(2));
    if (first && atomic_inc(&counter[1]) == groups - 1u) {
        counter[0] = 0u;
        counter[1] = 0u;
    }
    return 0;
}
#else
#  define VIS_CL_PT_PARAMS
#endif

/* One pixel's outputs: IDs (and depths when write_depth) at pixel i of the buffers. */
VIS_INLINE void vis_cl_trace_item(const vis_ray_setup *s, uint x, uint y, size_t view_base, VIS_SCENE_PARAMS,
                                  __global uint *restrict ids, __global float *restrict depth, uint write_depth,
                                  __local vis_stack_entry *ring)
{
    uint id, slot;
    float t;
    if (!vis_cl_pixel(s, x, y, VIS_SCENE_ARGS, ring, &id, &t, &slot))
        return;
    size_t i = view_base + (size_t)y * s->width + x;
    ids[i] = id;
    if (write_depth)
        depth[i] = t;
}

/* One view. The setup comes by value (the host's struct, byte for byte). write_depth = 0
 * when the caller asked for no depth buffer. */
__kernel void vis_trace_kernel(const vis_ray_setup setup, VIS_CL_SCENE_PARAMS, __global uint *restrict ids,
                               __global float *restrict depth, const uint write_depth,
                               __local vis_stack_entry *ring VIS_CL_PT_PARAMS)
{
    vis_ray_setup s = setup;
#if defined(VIS_CL_PERSISTENT)
    __local volatile uint next;
    uint x, y, v;
    while (vis_cl_next_tile(pt_counter, &next, s.width, s.height, 1u, &x, &y, &v))
        vis_cl_trace_item(&s, x, y, 0, VIS_SCENE_ARGS, ids, depth, write_depth, ring);
#else
    vis_cl_trace_item(&s, (uint)get_global_id(0), (uint)get_global_id(1), 0, VIS_SCENE_ARGS, ids, depth, write_depth,
                      ring);
#endif
}

/* Many views of one size: the third grid dimension is the view; view v writes at
 * v * width * height. setups[v] is view v's setup. */
__kernel void vis_trace_batch_kernel(__global const vis_ray_setup *restrict setups, VIS_CL_SCENE_PARAMS,
                                     __global uint *restrict ids, __global float *restrict depth,
                                     const uint write_depth, __local vis_stack_entry *ring VIS_CL_PT_PARAMS)
{
#if defined(VIS_CL_PERSISTENT)
    __local volatile uint next;
    uint x, y, v;
    while (vis_cl_next_tile(pt_counter, &next, setups[0].width, setups[0].height, pt_views, &x, &y, &v)) {
        vis_ray_setup s = setups[v];
        vis_cl_trace_item(&s, x, y, (size_t)v * s.height * s.width, VIS_SCENE_ARGS, ids, depth, write_depth, ring);
    }
#else
    uint v = (uint)get_global_id(2);
    vis_ray_setup s = setups[v];
    vis_cl_trace_item(&s, (uint)get_global_id(0), (uint)get_global_id(1), (size_t)v * s.height * s.width,
                      VIS_SCENE_ARGS, ids, depth, write_depth, ring);
#endif
}

/* ---- the draw list on the device ------------------------------------------------------
 *
 * vis_trace_drawlist_kernel: the batch kernel that also counts, per view, the pixels of each
 * object slot (object IDs) or leaf (leaf IDs) in counts[counts_offset + v * stride + key]. IDs and depths are
 * written only when asked for (write_ids, write_depth). A pixel's count goes through the
 * work-group's local memory first: each run of equal keys along a row of the tile adds its
 * length with one atomic, so an object filling a tile costs one atomic per row, not per pixel.
 *
 * vis_drawlist_block_count + vis_drawlist_compact (below): the views' list heads in the first
 * words of `counts` (before counts_offset). Object IDs: the slot's count; leaf IDs: the sum of the
 * counts of the slot's leaves (object_leaves, the same relation vis_drawlist_build expands
 * through). Each non-zero count becomes (ID, count) in the view's list at list[v * slots] (one
 * view: at list[1], its head in front), in slot order; the host sorts each list by ID (a list
 * already in order is copied). counts are zeroed by the host before. */
#define VIS_CL_NO_KEY 0xFFFFFFFFu

/* One pixel of the draw-list kernel; every item of the group calls it (it has a barrier). */
VIS_INLINE void vis_cl_drawlist_item(const vis_ray_setup *s, uint x, uint y, uint v, VIS_SCENE_PARAMS,
                                     __global uint *restrict ids, __global float *restrict depth, uint write_ids,
                                     uint write_depth, __global uint *counts, uint counts_offset, uint stride,
                                     __local vis_stack_entry *ring, __local uint *keys)
{
    uint key = VIS_CL_NO_KEY;
    uint id, slot;
    float t;
    if (vis_cl_pixel(s, x, y, VIS_SCENE_ARGS, ring, &id, &t, &slot)) { /* no early return: every item reaches the barrier */
        size_t i = ((size_t)v * s->height + y) * s->width + x;
        if (write_ids)
            ids[i] = id;
        if (write_depth)
            depth[i] = t;
        key = s->id_mode == 1u ? (id ? id - 1u : VIS_CL_NO_KEY) : slot;
    }
    uint lx = (uint)get_local_id(0), lw = (uint)get_local_size(0);
    uint li = (uint)get_local_id(1) * lw + lx;
    keys[li] = key;
    barrier(CLK_LOCAL_MEM_FENCE);
    if (key != VIS_CL_NO_KEY && !(lx > 0u && keys[li - 1u] == key)) { /* the first of its run */
        uint n = 1u;
        while (lx + n < lw && keys[li + n] == key)
            ++n;
        atomic_add(&counts[counts_offset + (size_t)v * stride + key], n);
    }
#if defined(VIS_CL_PERSISTENT)
    barrier(CLK_LOCAL_MEM_FENCE); /* keys are rewritten by the group's next tile */
#endif
}

__kernel void vis_trace_drawlist_kernel(__global const vis_ray_setup *restrict setups, VIS_CL_SCENE_PARAMS,
                                        __global uint *restrict ids, __global float *restrict depth,
                                        const uint write_ids, const uint write_depth, __global uint *counts,
                                        const uint counts_offset, const uint stride, __local vis_stack_entry *ring,
                                        __local uint *keys VIS_CL_PT_PARAMS)
{
#if defined(VIS_CL_PERSISTENT)
    __local volatile uint next;
    uint x, y, v;
    while (vis_cl_next_tile(pt_counter, &next, setups[0].width, setups[0].height, pt_views, &x, &y, &v)) {
        vis_ray_setup s = setups[v];
        vis_cl_drawlist_item(&s, x, y, v, VIS_SCENE_ARGS, ids, depth, write_ids, write_depth, counts, counts_offset,
                             stride, ring, keys);
    }
#else
    uint v = (uint)get_global_id(2);
    vis_ray_setup s = setups[v];
    vis_cl_drawlist_item(&s, (uint)get_global_id(0), (uint)get_global_id(1), v, VIS_SCENE_ARGS, ids, depth, write_ids,
                         write_depth, counts, counts_offset, stride, ring, keys);
#endif
}

/* The pixels of object slot o in the view's counts c: the slot's own count (object IDs) or
 * the sum over its leaves (leaf IDs); 0 for a free slot. */
VIS_INLINE uint vis_cl_slot_pixels(const __global vis_flat_object *restrict objects,
                                   const __global uint *restrict object_leaves, uint id_mode, const __global uint *c,
                                   uint o)
{
    if (id_mode != 1u)
        return c[o];
    vis_flat_object ob = objects[o];
    if (ob.id == 0u)
        return 0u; /* a free slot */
    uint n = 0u;
    for (uint k = 0u; k < ob.leaf_count; ++k)
        n += c[object_leaves[ob.leaf_offset + k]];
    return n;
}

/* An inclusive scan of sum[0..ln) across the group (Hillis & Steele; ln a power of two);
 * every item of the group calls it. */
VIS_INLINE void vis_cl_group_scan(__local uint *sum, uint li, uint ln)
{
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint d = 1u; d < ln; d <<= 1) {
        uint add = li >= d ? sum[li - d] : 0u;
        barrier(CLK_LOCAL_MEM_FENCE);
        sum[li] += add;
        barrier(CLK_LOCAL_MEM_FENCE);
    }
}

/* The slots with pixels in this item's run: `run` consecutive slots of the group's block
 * (get_group_id(0); a block is get_local_size(0) runs), of view get_group_id(1). */
VIS_INLINE uint vis_cl_run_hits(const __global vis_flat_object *restrict objects,
                                const __global uint *restrict object_leaves, uint slots, uint id_mode,
                                const __global uint *c, uint run, uint *lo, uint *hi)
{
    uint first = ((uint)get_group_id(0) * (uint)get_local_size(0) + (uint)get_local_id(0)) * run;
    *lo = min(first, slots);
    *hi = min(first + run, slots);
    uint n = 0u;
    for (uint o = *lo; o < *hi; ++o)
        n += vis_cl_slot_pixels(objects, object_leaves, id_mode, c, o) != 0u;
    return n;
}

/* Ordered compaction in two kernels over a grid of (blocks of slots, views), so that a view's
 * slots are walked by many groups (one group per view took ~60 us for 120,000 slots):
 * vis_drawlist_block_count writes how many slots of each block have pixels
 * (block_counts[v * blocks + block]); vis_drawlist_compact then writes a block's entries after
 * those of the blocks before it, each item's after the items' before it (a scan in local
 * memory), so the list comes out in slot order (the order slots are allocated in, often the
 * IDs' order, which the host then only checks), with no atomic. The last block writes the
 * view's head. A launch of one view (one group row: the host's n == 1) writes its list one
 * entry on, with the head in front (list[0], the head as its ID), so that the host reads head
 * and list with one read sized by the last list (cl_drawlist.c), a longer list's rest after.
 * With object IDs each count is set back to zero once read: within this
 * kernel only the item that reads it touches it, and a later launch whose counts lie there
 * needs no fill (cl_drawlist.c). `sum`: one local word per item, a power of two. */
__kernel void vis_drawlist_block_count(const __global vis_flat_object *restrict objects,
                                       const __global uint *restrict object_leaves, const uint slots,
                                       const uint id_mode, const __global uint *counts, const uint counts_offset,
                                       const uint stride, const uint run, __global uint *restrict block_counts,
                                       __local uint *sum)
{
    uint v = (uint)get_group_id(1), li = (uint)get_local_id(0), ln = (uint)get_local_size(0), lo, hi;
    sum[li] = vis_cl_run_hits(objects, object_leaves, slots, id_mode, counts + counts_offset + (size_t)v * stride,
                              run, &lo, &hi);
    vis_cl_group_scan(sum, li, ln);
    if (li == ln - 1u)
        block_counts[(size_t)v * get_num_groups(0) + get_group_id(0)] = sum[li];
}

__kernel void vis_drawlist_compact(const __global vis_flat_object *restrict objects,
                                   const __global uint *restrict object_leaves, const uint slots, const uint id_mode,
                                   __global uint *counts, const uint counts_offset, const uint stride,
                                   __global uint2 *restrict list, __local uint *sum, const uint run,
                                   const __global uint *restrict block_counts)
{
    uint v = (uint)get_group_id(1), blk = (uint)get_group_id(0), blocks = (uint)get_num_groups(0);
    uint li = (uint)get_local_id(0), ln = (uint)get_local_size(0), lo, hi;
    /* The entries of the blocks before this one. */
    uint before = 0u;
    for (uint k = li; k < blk; k += ln)
        before += block_counts[(size_t)v * blocks + k];
    sum[li] = before;
    vis_cl_group_scan(sum, li, ln);
    before = sum[ln - 1u];
    barrier(CLK_LOCAL_MEM_FENCE); /* every item has read it before sum is reused */
    __global uint *c = counts + counts_offset + (size_t)v * stride;
    uint mine = vis_cl_run_hits(objects, object_leaves, slots, id_mode, c, run, &lo, &hi);
    sum[li] = mine;
    vis_cl_group_scan(sum, li, ln);
    uint at = before + sum[li] - mine;
    const int one_view = get_num_groups(1) == 1u;
    __global uint2 *mine_list = one_view ? list + 1 : list + (size_t)v * slots;
    for (uint o = lo; o < hi; ++o) {
        uint n = vis_cl_slot_pixels(objects, object_leaves, id_mode, c, o);
        if (n != 0u) {
            mine_list[at++] = (uint2)(objects[o].id, n);
            if (id_mode != 1u)
                c[o] = 0u;
        }
    }
    if (blk == blocks - 1u && li == ln - 1u) {
        counts[v] = before + sum[li]; /* the view's head */
        if (one_view)
            list[0] = (uint2)(before + sum[li], 0u);
    }
}

/* vis_drawlist_pack: the views' lists (view v's at list[v * slots], heads[v] long) one after
 * the other in `packed`, view v's at the sum of the heads before it, so that the host reads
 * every list of a batch with one read instead of one read per view (cl_drawlist.c). One
 * work-group per view, `sum` its local scratch of one word per item (a power of two); heads
 * are clamped to slots, as the host clamps them when it finds each list. */
__kernel void vis_drawlist_pack(__global const uint *restrict heads, const uint slots,
                                __global const uint2 *restrict list, __global uint2 *restrict packed,
                                __local uint *sum)
{
    uint v = (uint)get_group_id(0), li = (uint)get_local_id(0), ln = (uint)get_local_size(0);
    uint s = 0u;
    for (uint u = li; u < v; u += ln)
        s += min(heads[u], slots);
    sum[li] = s;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint w = ln >> 1; w > 0u; w >>= 1) {
        if (li < w)
            sum[li] += sum[li + w];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    size_t at = sum[0];
    uint h = min(heads[v], slots);
    for (uint k = li; k < h; k += ln)
        packed[at + k] = list[(size_t)v * slots + k];
}

#ifdef VIS_TRACE_EFFECTS
/* One view with effects (programs built with -DVIS_TRACE_EFFECTS, and for one method and one
 * effect set with -DVIS_TRAVERSAL_ONLY and -DVIS_EFFECTS_ONLY): vis_trace_pixel_effects, the
 * CPU's code. A buffer whose effect is off is the host's dummy and never written. */
__kernel void vis_trace_effects_kernel(const vis_ray_setup setup, const vis_effect_setup effects, VIS_CL_SCENE_PARAMS,
                                       __global uint *restrict ids, __global float *restrict depth,
                                       __global uint *restrict see_through, __global uint *restrict reflection,
                                       __global uint *restrict shadow, const uint write_depth)
{
    uint x = (uint)get_global_id(0), y = (uint)get_global_id(1);
    vis_ray_setup s = setup;
    vis_effect_setup e = effects;
    if (x >= s.width || y >= s.height)
        return;
    vis_effect_pixel px;
    vis_trace_pixel_effects(&s, &e, x, y, VIS_SCENE_ARGS, &px);
    size_t i = (size_t)y * s.width + x;
    ids[i] = px.id;
    if (write_depth)
        depth[i] = px.depth;
    if (e.effects & VIS_FX_SEE_THROUGH)
        for (uint k = 0u; k < e.layers; ++k)
            see_through[i * e.layers + k] = px.see_through[k];
    if (e.effects & VIS_FX_REFLECT)
        reflection[i] = px.reflection;
    if (e.effects & VIS_FX_SHADOWS)
        shadow[i] = px.shadow;
}
#endif
