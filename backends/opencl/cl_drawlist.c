/* cl_drawlist.c — the draw list built on the device: trace, count pixels per object (or leaf),
 * compact the counts into per-view lists, read back only the lists.
 *
 * Reading a 512x512 ID buffer back (1 MiB) costs more than tracing it on a fast GPU; the
 * list of a view is a few kilobytes. Per launch:
 *   1. one fill zeroes the views' pixel counts (one buffer, the list heads in front), unless
 *      they are zero already: the compaction of object IDs leaves every count it reads at
 *      zero, so a launch whose counts lie within the words the last finished launch left zero
 *      has none to clear, and its trace is the first command after the camera's write;
 *   2. vis_trace_drawlist_kernel traces and adds each pixel to its key's count (kernels/trace.cl);
 *   3. vis_drawlist_block_count and vis_drawlist_compact turn the counts into (ID, pixels)
 *      entries, per view, in slot order (groups over blocks of slots scan which slots have
 *      pixels; no atomics);
 *   4. one view: the compaction writes its head in front of its list, and one read brings
 *      head and list into pinned host memory (CL_MEM_ALLOC_HOST_PTR, mapped once), with the
 *      IDs and depths only when the caller asked for them; one finish. The read stops after
 *      the entries the last one-view list needed, with a margin (gen:large's camera path sees
 *      1-32,705 of 120,693 objects, and reading every slot was 966 KB); a longer list
 *      reads its rest after (a second finish). Several views: vis_drawlist_pack puts
 *      the lists one after the other, the heads are read (one finish), then the packed lists
 *      with one read (a second finish): two round trips, where a read per view and a sort per
 *      list made most of a 3.5 ms gap between kernel and end to end for 256 views on the H200
 *      (docs/opencl.md);
 *   5. each list is sorted by ID from there into the caller's entries (a radix sort with as
 *      few passes as the largest ID needs; a list already in order is copied).
 * Nothing is allocated per frame once the buffers are large enough. */
#include <stdio.h>
#include <string.h>

#include "opencl/cl_internal.h"

_Static_assert(sizeof(vis_draw_entry) == 2 * sizeof(cl_uint), "a draw entry is the kernel's uint2 (ID, pixels)");

/* Per launch, the counts and lists take at most this many bytes (larger batches run as
 * several launches); the pixel limit of trace batches applies to IDs and depths. */
#define DL_MAX_BYTES ((size_t)64 << 20)
#define DL_MAX_PIXELS ((size_t)1 << 26)
/* A one-view launch reads at least this many entries in its first read (8 KiB). */
#define DL_FIRST_READ_MIN ((size_t)1024)

/* Whether words [lo, hi) of the counts are known to be zero; forgetting is setting [0, 0). */
static int counts_known_zero(const vis_cl_backend *b, size_t lo, size_t hi)
{
    return b->dl_zero_lo <= lo && hi <= b->dl_zero_hi;
}

static void counts_set_zero(vis_cl_backend *b, size_t lo, size_t hi)
{
    b->dl_zero_lo = lo;
    b->dl_zero_hi = hi;
}

void vis_cl_drawlist_release(vis_cl_backend *b)
{
    if (b->dl_pinned && b->dl_host && b->queue) {
        clEnqueueUnmapMemObject(b->queue, b->dl_pinned, b->dl_host, 0, NULL, NULL);
        clFinish(b->queue);
    }
    cl_mem *m[] = {&b->dl_counts, &b->dl_list, &b->dl_packed, &b->dl_blocks, &b->dl_pinned};
    for (size_t i = 0; i < sizeof m / sizeof m[0]; ++i)
        if (*m[i]) {
            clReleaseMemObject(*m[i]);
            *m[i] = NULL;
        }
    b->dl_host = NULL;
    b->dl_counts_cap = b->dl_list_cap = b->dl_packed_cap = b->dl_blocks_cap = b->dl_pinned_cap = 0;
    counts_set_zero(b, 0, 0);
}

/* Pinned host memory of at least `bytes`, mapped for the backend's life. */
static int ensure_pinned(vis_cl_backend *b, size_t bytes, char *err, size_t err_size)
{
    if (b->dl_pinned && b->dl_pinned_cap >= bytes)
        return VIS_OK;
    if (b->dl_pinned) {
        clEnqueueUnmapMemObject(b->queue, b->dl_pinned, b->dl_host, 0, NULL, NULL);
        clFinish(b->queue);
        clReleaseMemObject(b->dl_pinned);
        b->dl_pinned = NULL;
        b->dl_host = NULL;
        b->dl_pinned_cap = 0;
    }
    cl_int e = CL_SUCCESS;
    cl_mem m = clCreateBuffer(b->context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes, NULL, &e);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clCreateBuffer (pinned draw-list memory)", err, err_size);
    void *host = clEnqueueMapBuffer(b->queue, m, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes, 0, NULL, NULL, &e);
    if (e != CL_SUCCESS || !host) {
        clReleaseMemObject(m);
        return vis_cl_fail(e != CL_SUCCESS ? e : CL_OUT_OF_HOST_MEMORY, "clEnqueueMapBuffer (draw list)", err,
                           err_size);
    }
    b->dl_pinned = m;
    b->dl_host = host;
    b->dl_pinned_cap = bytes;
    return VIS_OK;
}

/* Sorts src[0..n) by ID into dst (src is scratch: it is overwritten). LSD radix sort: linear in
 * n (a heap sort of a large scene's 30,000 entries took milliseconds, more than the trace), no
 * allocation, alternating src -> dst -> src. Only the passes the largest ID needs run, with
 * 8-bit digits for short lists (a pass clears and scans its counts, 2,048 of them at 11 bits:
 * more work than a list of a few hundred entries; a batch sorts one list per view), and a
 * list already in order is copied. IDs are unique, so stability does not show, but the sort
 * is stable anyway. */
static void radix_sort_into(vis_draw_entry *src, vis_draw_entry *dst, size_t n)
{
    if (n < 64) { /* insertion sort, straight into dst */
        for (size_t i = 0; i < n; ++i) {
            vis_draw_entry x = src[i];
            size_t j = i;
            for (; j > 0 && dst[j - 1].id > x.id; --j)
                dst[j] = dst[j - 1];
            dst[j] = x;
        }
        return;
    }
    uint32_t bits_of_ids = src[0].id;
    int in_order = 1;
    for (size_t i = 1; i < n; ++i) {
        bits_of_ids |= src[i].id;
        in_order &= src[i - 1].id < src[i].id;
    }
    if (in_order) {
        memcpy(dst, src, n * sizeof *dst);
        return;
    }
    unsigned digit = n < 1024 ? 8u : 11u, width = 0;
    while (width < 32u && (bits_of_ids >> width) != 0u)
        ++width;
    vis_draw_entry *from = src, *to = dst;
    size_t count[2048];
    for (unsigned shift = 0; shift < width; shift += digit) {
        uint32_t mask = (1u << digit) - 1u;
        memset(count, 0, ((size_t)mask + 1u) * sizeof count[0]);
        for (size_t i = 0; i < n; ++i)
            ++count[(from[i].id >> shift) & mask];
        size_t sum = 0;
        for (uint32_t b = 0; b <= mask; ++b) {
            size_t c = count[b];
            count[b] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; ++i)
            to[count[(from[i].id >> shift) & mask]++] = from[i];
        vis_draw_entry *t = from;
        from = to;
        to = t;
    }
    if (from != dst) /* an even number of passes: the result is in src */
        memcpy(dst, from, n * sizeof *dst);
}

/* Views per launch: within the pixel limit for IDs/depths read back and DL_MAX_BYTES for
 * the counts and lists; at least one. */
static uint32_t views_per_launch(uint32_t count, size_t pixels, int want_pixels, size_t stride, size_t slots)
{
    size_t per_view = (1u + stride) * sizeof(cl_uint) + slots * sizeof(vis_draw_entry);
    size_t per = (DL_MAX_BYTES - sizeof(vis_draw_entry)) / per_view; /* the one-view head's entry too */
    if (want_pixels && DL_MAX_PIXELS / pixels < per)
        per = DL_MAX_PIXELS / pixels;
    if (per == 0)
        per = 1;
    return per < count ? (uint32_t)per : count;
}

/* Slots each work-item of the compaction walks, one after the other (kernels/trace.cl); a
 * group's block is pack_items() runs. */
#define DL_COMPACT_RUN 4u

/* Work-items of a compaction or pack group: a power of two the device runs in one group, at
 * most 64 (blocks of 256 slots: gen:default's 4,371 slots are 18 blocks per view). */
static size_t pack_items(const vis_cl_backend *b)
{
    size_t n = 64;
    while (n > 1 && n > b->caps.max_wg)
        n >>= 1;
    return n;
}

/* The arguments vis_drawlist_block_count and vis_drawlist_compact share (kernels/trace.cl):
 * 0-4 and 6 (5, the counts offset, is set per launch). */
static cl_int set_count_args(const vis_cl_backend *b, cl_kernel k, const vis_cl_scene *sc, cl_uint slots,
                             cl_uint id_mode, cl_uint stride)
{
    cl_int e = clSetKernelArg(k, 0, sizeof(cl_mem), &sc->objects.mem);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 1, sizeof(cl_mem), &sc->object_leaves.mem);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 2, sizeof slots, &slots);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 3, sizeof id_mode, &id_mode);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 4, sizeof(cl_mem), &b->dl_counts);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 6, sizeof stride, &stride);
    return e;
}

/* The kernels' arguments that stay the same for every launch of a call (kernels/trace.cl);
 * the counts offset (the launch's view count: its heads come first) is set per launch. */
static cl_int set_args(vis_cl_backend *b, vis_cl_program *p, const vis_cl_scene *sc, cl_mem ids, cl_mem depth,
                       cl_uint write_ids, cl_uint write_depth, cl_uint stride, cl_uint slots, cl_uint id_mode,
                       size_t ring_bytes, size_t key_bytes)
{
    cl_kernel k = p->drawlist;
    cl_int e = clSetKernelArg(k, 0, sizeof(cl_mem), &b->setups);
    if (e == CL_SUCCESS)
        e = vis_cl_set_scene_args(k, sc, 1);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 10, sizeof(cl_mem), &ids);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 11, sizeof(cl_mem), &depth);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 12, sizeof write_ids, &write_ids);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 13, sizeof write_depth, &write_depth);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 14, sizeof(cl_mem), &b->dl_counts);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 16, sizeof stride, &stride);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 17, ring_bytes, NULL);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 18, key_bytes, NULL);
    k = p->compact;
    if (e == CL_SUCCESS)
        e = set_count_args(b, k, sc, slots, id_mode, stride);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 7, sizeof(cl_mem), &b->dl_list);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 8, pack_items(b) * sizeof(cl_uint), NULL);
    cl_uint run = DL_COMPACT_RUN;
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 9, sizeof run, &run);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 10, sizeof(cl_mem), &b->dl_blocks);
    k = p->block_count;
    if (e == CL_SUCCESS)
        e = set_count_args(b, k, sc, slots, id_mode, stride);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 7, sizeof run, &run);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 8, sizeof(cl_mem), &b->dl_blocks);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 9, pack_items(b) * sizeof(cl_uint), NULL);
    k = p->pack;
    cl_uint list_slots = slots ? slots : 1u; /* the lists' stride: the buffers hold at least one */
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 0, sizeof(cl_mem), &b->dl_counts);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 1, sizeof list_slots, &list_slots);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 2, sizeof(cl_mem), &b->dl_list);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 3, sizeof(cl_mem), &b->dl_packed);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 4, pack_items(b) * sizeof(cl_uint), NULL);
    return e;
}

/* Where a launch's lists lie in pinned memory: after its n heads; one view's after the entry
 * its head came back in (the head is that entry's ID, so heads[0] all the same). */
static vis_draw_entry *pinned_lists(const vis_cl_backend *b, uint32_t n)
{
    return n == 1u ? (vis_draw_entry *)b->dl_host + 1 : (vis_draw_entry *)((cl_uint *)b->dl_host + n);
}

/* One view: the head the compaction wrote in front of its list (kernels/trace.cl) and the
 * first entries come back with one read, the rest only when the head says the list is longer
 * (a second round trip). */
static cl_int read_one_view(vis_cl_backend *b, uint32_t object_count)
{
    vis_draw_entry *head_and_list = b->dl_host;
    size_t first = b->dl_first_read > DL_FIRST_READ_MIN ? b->dl_first_read : DL_FIRST_READ_MIN;
    first = first < object_count ? first : object_count;
    cl_int e = clEnqueueReadBuffer(b->queue, b->dl_list, CL_FALSE, 0, (first + 1u) * sizeof *head_and_list,
                                   head_and_list, 0, NULL, NULL);
    cl_int f = clFinish(b->queue);
    if (e != CL_SUCCESS || f != CL_SUCCESS)
        return e != CL_SUCCESS ? e : f;
    cl_uint *heads = b->dl_host;
    heads[0] = heads[0] <= object_count ? heads[0] : object_count; /* never trust a size read */
    size_t head = heads[0];
    b->dl_first_read = head + head / 4u + 64u; /* the next view's first read: this list and a margin */
    if (head <= first)
        return CL_SUCCESS;
    e = clEnqueueReadBuffer(b->queue, b->dl_list, CL_FALSE, (first + 1u) * sizeof *head_and_list,
                            (head - first) * sizeof *head_and_list, head_and_list + first + 1u, 0, NULL, NULL);
    f = clFinish(b->queue);
    return e != CL_SUCCESS ? e : f;
}

/* Reads the launch's heads and lists into pinned memory, the lists one after the other past
 * the heads (view v's after view v-1's), and the IDs and depths when asked; waits. One view:
 * read_one_view. Several: the pack kernel (its event in *ev) lays the lists end to end on the
 * device, the heads come back first, then their sum of entries with one read: two round
 * trips, whatever the number of views. `slots` is the lists' stride (at least 1),
 * `object_count` the kernels' slot count (0 for an empty scene). */
static cl_int read_back(vis_cl_backend *b, const vis_cl_program *p, uint32_t n, size_t slots, uint32_t object_count,
                        size_t pixels, uint32_t *ids, float *depth, cl_event *ev)
{
    cl_uint *heads = b->dl_host;
    cl_int e = CL_SUCCESS;
    if (n > 1u) {
        size_t local = pack_items(b), global = (size_t)n * local;
        e = clEnqueueNDRangeKernel(b->queue, p->pack, 1, NULL, &global, &local, 0, NULL, ev);
        if (e == CL_SUCCESS)
            e = clEnqueueReadBuffer(b->queue, b->dl_counts, CL_FALSE, 0, n * sizeof(cl_uint), heads, 0, NULL, NULL);
    }
    if (e == CL_SUCCESS && ids)
        e = clEnqueueReadBuffer(b->queue, b->ids, CL_FALSE, 0, (size_t)n * pixels * sizeof(uint32_t), ids, 0, NULL,
                                NULL);
    if (e == CL_SUCCESS && depth)
        e = clEnqueueReadBuffer(b->queue, b->depth, CL_FALSE, 0, (size_t)n * pixels * sizeof(float), depth, 0, NULL,
                                NULL);
    if (n == 1u) {
        if (e != CL_SUCCESS) {
            clFinish(b->queue);
            return e;
        }
        return read_one_view(b, object_count);
    }
    cl_int f = clFinish(b->queue);
    if (e != CL_SUCCESS || f != CL_SUCCESS)
        return e != CL_SUCCESS ? e : f;
    size_t sum = 0;
    for (uint32_t v = 0; v < n; ++v)
        sum += heads[v] <= slots ? heads[v] : slots; /* as the pack kernel clamps */
    if (sum == 0)
        return CL_SUCCESS;
    e = clEnqueueReadBuffer(b->queue, b->dl_packed, CL_FALSE, 0, sum * sizeof(vis_draw_entry), pinned_lists(b, n), 0,
                            NULL, NULL);
    f = clFinish(b->queue);
    return e != CL_SUCCESS ? e : f;
}

vis_status vis_cl_trace_drawlist(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setups,
                                 uint32_t count, uint32_t *ids, float *depth, vis_draw_entry *entries, size_t capacity,
                                 size_t *per_view, size_t *total, char *err, size_t err_size)
{
    vis_cl_backend *b = impl;
    const vis_cl_scene *sc = scene_data;
    b->last_kernel_ms = 0.0;
    *total = 0;
    if (count == 0)
        return VIS_OK;
    vis_cl_program *p = NULL;
    int st = vis_cl_batch_program(b, setups, count, &p, err, err_size);
    if (st != VIS_OK)
        return st;
    uint32_t W = setups[0].width, H = setups[0].height;
    size_t pixels = (size_t)W * H;
    /* Buffers hold at least one of everything; the kernels get the true slot count (an empty
     * scene's one-element object buffer holds no object to read). */
    size_t slots = view->object_count ? view->object_count : 1u;
    size_t stride = setups[0].id_mode == 1u ? (view->leaf_count ? view->leaf_count : 1u) : slots;
    uint32_t per = views_per_launch(count, pixels, ids || depth, stride, slots);
    size_t block = pack_items(b) * DL_COMPACT_RUN, blocks = (view->object_count + block - 1) / block;
    if (blocks == 0)
        blocks = 1; /* the last block writes the head, even of an empty list */

    /* Cameras; counts with the heads in front; lists (one view: its head in front of its list);
     * pinned heads + lists; IDs/depths if asked. A new counts buffer (its capacity changes)
     * holds no known zeros. */
    size_t counts_cap = b->dl_counts_cap;
    st = vis_cl_ensure_buffer(b, &b->dl_counts, &b->dl_counts_cap, (size_t)per * (1u + stride), sizeof(cl_uint),
                              CL_MEM_READ_WRITE, "draw-list counts", err, err_size);
    if (b->dl_counts_cap != counts_cap)
        counts_set_zero(b, 0, 0);
    if (st != VIS_OK ||
        (st = vis_cl_ensure_buffer(b, &b->setups, &b->setup_cap, per, sizeof(vis_ray_setup), CL_MEM_READ_ONLY,
                                   "camera buffer", err, err_size)) != VIS_OK ||
        (st = vis_cl_ensure_buffer(b, &b->dl_list, &b->dl_list_cap, (size_t)per * slots + 1u, sizeof(vis_draw_entry),
                                   CL_MEM_READ_WRITE, "draw-list entries", err, err_size)) != VIS_OK ||
        (st = vis_cl_ensure_buffer(b, &b->dl_packed, &b->dl_packed_cap, (size_t)per * slots, sizeof(vis_draw_entry),
                                   CL_MEM_READ_WRITE, "packed draw lists", err, err_size)) != VIS_OK ||
        (st = vis_cl_ensure_buffer(b, &b->dl_blocks, &b->dl_blocks_cap, (size_t)per * blocks, sizeof(cl_uint),
                                   CL_MEM_READ_WRITE, "draw-list block counts", err, err_size)) != VIS_OK ||
        (st = ensure_pinned(b, per * sizeof(cl_uint) + ((size_t)per * slots + 1u) * sizeof(vis_draw_entry), err,
                            err_size)) != VIS_OK)
        return st;
    if (ids && (st = vis_cl_ensure_buffer(b, &b->ids, &b->out_cap, (size_t)per * pixels, sizeof(uint32_t),
                                          CL_MEM_WRITE_ONLY, "ID buffer", err, err_size)) != VIS_OK)
        return st;
    if (depth && (st = vis_cl_ensure_buffer(b, &b->depth, &b->depth_cap, (size_t)per * pixels, sizeof(float),
                                            CL_MEM_WRITE_ONLY, "depth buffer", err, err_size)) != VIS_OK)
        return st;

    size_t global[3], local[3];
    const int batch = count > 1; /* every launch of the call in the same groups */
    vis_cl_grid(b, W, H, per, batch, global, local);
    cl_int e = set_args(b, p, sc, ids ? b->ids : b->dummy, depth ? b->depth : b->dummy, ids != NULL, depth != NULL,
                        (cl_uint)stride, (cl_uint)view->object_count, setups[0].id_mode,
                        vis_cl_ring_bytes(&setups[0], local),
                        local[0] * local[1] * sizeof(cl_uint));
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clSetKernelArg (draw list)", err, err_size);

    size_t done = 0;
    for (uint32_t first = 0; first < count; first += per) {
        uint32_t n = count - first < per ? count - first : per;
        cl_uint zero = 0, off = n; /* the launch's n heads come first, then its counts */
        size_t counts_end = (size_t)n * (1u + stride); /* the heads need no zeros: the compaction writes each */
        int zeroed = counts_known_zero(b, n, counts_end);
        counts_set_zero(b, 0, 0); /* known again once this launch has finished */
        e = clEnqueueWriteBuffer(b->queue, b->setups, CL_FALSE, 0, (size_t)n * sizeof *setups, setups + first, 0, NULL,
                                 NULL);
        if (e == CL_SUCCESS && !zeroed)
            e = clEnqueueFillBuffer(b->queue, b->dl_counts, &zero, sizeof zero, n * sizeof(cl_uint),
                                    (counts_end - n) * sizeof(cl_uint), 0, NULL, NULL);
        if (e == CL_SUCCESS)
            e = clSetKernelArg(p->drawlist, 15, sizeof off, &off);
        if (e == CL_SUCCESS)
            e = clSetKernelArg(p->compact, 5, sizeof off, &off);
        if (e == CL_SUCCESS)
            e = clSetKernelArg(p->block_count, 5, sizeof off, &off);
        cl_event ev[4] = {NULL, NULL, NULL, NULL};
        if (e == CL_SUCCESS)
            e = vis_cl_enqueue_pass(b, p, p->drawlist, 19, W, H, n, batch, &ev[0]);
        size_t cl_local[2] = {pack_items(b), 1}, cg[2] = {blocks * pack_items(b), n}; /* (blocks, views) */
        if (e == CL_SUCCESS)
            e = clEnqueueNDRangeKernel(b->queue, p->block_count, 2, NULL, cg, cl_local, 0, NULL, &ev[3]);
        if (e == CL_SUCCESS)
            e = clEnqueueNDRangeKernel(b->queue, p->compact, 2, NULL, cg, cl_local, 0, NULL, &ev[1]);
        if (e == CL_SUCCESS)
            e = read_back(b, p, n, slots, view->object_count, pixels, ids ? ids + (size_t)first * pixels : NULL,
                          depth ? depth + (size_t)first * pixels : NULL, &ev[2]);
        else
            clFinish(b->queue);
        for (int i = 0; i < 4; ++i)
            if (ev[i]) {
                if (e == CL_SUCCESS)
                    vis_cl_add_event_time(b, ev[i]);
                clReleaseEvent(ev[i]);
            }
        if (e != CL_SUCCESS)
            return vis_cl_fail(e, "draw-list pass", err, err_size);
        if (setups[0].id_mode != 1u) /* leaf IDs' counts stay as the trace left them */
            counts_set_zero(b, n, counts_end);
        const cl_uint *heads = b->dl_host;
        vis_draw_entry *lists = pinned_lists(b, n);
        size_t need = done;
        for (uint32_t v = 0; v < n; ++v)
            need += heads[v] <= slots ? heads[v] : slots; /* never trust a size read */
        if (need > capacity) {
            *total = need;
            snprintf(err, err_size, "the draw lists need %zu entries%s, capacity is %zu", need,
                     first + n < count ? " or more" : "", capacity);
            return VIS_ERROR_CAPACITY;
        }
        size_t at = 0; /* view v's list in pinned memory: after the lists before it */
        for (uint32_t v = 0; v < n; ++v) {
            size_t h = heads[v] <= slots ? heads[v] : slots;
            radix_sort_into(lists + at, entries + done, h);
            at += h;
            per_view[first + v] = h;
            done += h;
        }
    }
    *total = done;
    return VIS_OK;
}
