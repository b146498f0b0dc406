/* cl_scene.c — the device copy of a scene, and the partial uploads that keep it current.
 *
 * The scene is the flat arrays of trace_core.h, copied once (the first sync writes every
 * array whole). After that, libvis reports what edits touched (backend.h, vis_scene_changes)
 * and only those bytes travel:
 *  - a changed leaf: its 64-byte header, its bucket table (vis_bucket_words), its bucketed
 *    and loose quads, and its triangles — only the used part of each slot;
 *  - a changed object: its 16-byte slot;
 *  - the object_leaves range [lo, hi) that edits rewrote;
 *  - the cell map entries whose clearance an edit lowered (trace_core.h, VIS_CELL_CLEAR).
 * The tree (nodes, the cell map's leaves) never changes after creation and is sent once;
 * so are the ropes, once the first pass that walks them has built them.
 *
 * Those ranges are staged: copied into pinned host memory, sent with one write and put in
 * place by one kernel (kernels/upload.cl), instead of one clEnqueueWriteBuffer per range —
 * a single-voxel edit is 5 to 15 ranges of a few hundred bytes, and each write costs the
 * driver microseconds whatever its size. The staging area is bounded (STAGE_WORDS); a larger
 * sync (a compaction re-sends every leaf) flushes it as often as it fills.
 *
 * Pools grow on the host (a leaf that outgrows its slot moves to the end of the quad pool;
 * new objects take new slots). When an array's used count passes its device buffer's
 * capacity, a larger buffer (1.5x + 4096 elements of headroom) replaces it: the part already
 * on the device is copied across on the device (clEnqueueCopyBuffer, no host transfer), then
 * the changed ranges are written as usual. Still no tree rebuild, and no full re-upload.
 *
 * Ordering: the queue is in order, so a pass enqueued after a sync sees its data. Writes
 * straight from the host arrays (the first sync, growth, ropes) are non-blocking and the sync
 * ends with clFinish when it made any, since the host arrays may change once it returns. A
 * staged sync does not wait: its data was copied into the staging area, which is refilled
 * only after the last scatter that read it has completed (its event). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opencl/cl_internal.h"

#define HEADROOM_MIN 4096u

/* The staging area (kernels/upload.cl): STAGE_RANGES headers of 4 ulongs, then STAGE_WORDS
 * words. A single-voxel edit takes under 20 ranges and a few thousand bytes. */
#define STAGE_RANGES 256u
#define STAGE_WORDS (64u * 1024u)
#define STAGE_HEADER_WORDS (STAGE_RANGES * 8u)
#define STAGE_BYTES ((size_t)(STAGE_HEADER_WORDS + STAGE_WORDS) * sizeof(cl_uint))

/* Must match kernels/upload.cl. */
enum stage_array {
    STAGE_LEAVES,
    STAGE_BUCKETS,
    STAGE_QUADS,
    STAGE_TRIS,
    STAGE_OBJECTS,
    STAGE_OBJECT_LEAVES,
    STAGE_ROPE_INDEX
};

_Static_assert(sizeof(vis_flat_leaf) % 4 == 0 && sizeof(vis_flat_tri) % 4 == 0 && sizeof(vis_flat_object) % 4 == 0,
               "staged uploads copy whole 32-bit words");

typedef struct upload_state {
    vis_cl_backend *b;
    vis_cl_scene *sc;
    uint64_t bytes;
    int direct;          /* a write straight from the host arrays was enqueued: finish */
    uint32_t ranges;     /* staged ranges not yet flushed */
    uint32_t words;      /* their words */
    uint32_t flushes;    /* staging areas sent by this sync */
    char *err;
    size_t err_size;
} upload_state;

static void array_release(vis_cl_array *a)
{
    if (a->mem)
        clReleaseMemObject(a->mem);
    memset(a, 0, sizeof *a);
}

/* A buffer of `cap` elements. Zero-length arrays get one element: kernels need a valid
 * buffer for every parameter even where the scene has none (no ropes yet, no triangles). */
static int array_alloc(upload_state *u, vis_cl_array *a, size_t cap, const char *what)
{
    if (cap == 0)
        cap = 1;
    size_t bytes = cap * a->elem;
    if ((cl_ulong)bytes > u->b->caps.max_alloc) {
        snprintf(u->err, u->err_size,
                 "device '%s' cannot hold the scene's %s: %zu bytes exceed its largest allocation (%llu bytes)",
                 u->b->caps.name, what, bytes, (unsigned long long)u->b->caps.max_alloc);
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    cl_int e = CL_SUCCESS;
    cl_mem m = clCreateBuffer(u->b->context, CL_MEM_READ_ONLY, bytes, NULL, &e);
    if (e != CL_SUCCESS) {
        char w[96];
        snprintf(w, sizeof w, "clCreateBuffer (%s, %zu bytes)", what, bytes);
        return vis_cl_fail(e, w, u->err, u->err_size);
    }
    a->mem = m;
    a->cap = cap;
    return VIS_OK;
}

/* Whether [first, first + count) lies in the device buffer; the message when not. */
static int range_fits(upload_state *u, const vis_cl_array *a, size_t first, size_t count, const char *what)
{
    if (first + count <= a->cap)
        return 1;
    snprintf(u->err, u->err_size, "internal: %s range [%zu, %zu) beyond the device buffer (%zu)", what, first,
             first + count, a->cap);
    return 0;
}

static int write_range(upload_state *u, vis_cl_array *a, const void *host, size_t first, size_t count,
                       const char *what)
{
    if (count == 0)
        return VIS_OK;
    if (!range_fits(u, a, first, count, what))
        return VIS_ERROR_BACKEND;
    size_t off = first * a->elem, bytes = count * a->elem;
    cl_int e = clEnqueueWriteBuffer(u->b->queue, a->mem, CL_FALSE, off, bytes, (const char *)host + off, 0, NULL,
                                    NULL);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clEnqueueWriteBuffer", u->err, u->err_size);
    u->bytes += bytes;
    u->direct = 1;
    return VIS_OK;
}

/* ---- staged uploads ------------------------------------------------------------------- */

/* The pinned staging memory (mapped for the backend's life) and its device copy, made on
 * the first staged sync. */
static int stage_ready(upload_state *u)
{
    vis_cl_backend *b = u->b;
    if (b->stage_host)
        return VIS_OK;
    cl_int e = CL_SUCCESS;
    if (!b->stage_pinned)
        b->stage_pinned = clCreateBuffer(b->context, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, STAGE_BYTES, NULL, &e);
    if (e == CL_SUCCESS && !b->stage_dev)
        b->stage_dev = clCreateBuffer(b->context, CL_MEM_READ_ONLY, STAGE_BYTES, NULL, &e);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clCreateBuffer (upload staging)", u->err, u->err_size);
    void *host = clEnqueueMapBuffer(b->queue, b->stage_pinned, CL_TRUE, CL_MAP_WRITE, 0, STAGE_BYTES, 0, NULL, NULL, &e);
    if (e != CL_SUCCESS || !host)
        return vis_cl_fail(e != CL_SUCCESS ? e : CL_OUT_OF_HOST_MEMORY, "clEnqueueMapBuffer (upload staging)", u->err,
                           u->err_size);
    b->stage_host = host;
    return VIS_OK;
}

/* Waits until the staging memory may be written again: the last scatter that read it has
 * run. A scatter that failed (reported only here, as the sync that enqueued it did not wait)
 * left its scene's copy half-written: when that is this sync's scene, this sync fails, which
 * drops the copy; another scene's copy is marked stale, and its next sync sends it whole. */
static int stage_wait(upload_state *u)
{
    vis_cl_backend *b = u->b;
    if (!b->stage_done)
        return VIS_OK;
    cl_int e = clWaitForEvents(1, &b->stage_done);
    clReleaseEvent(b->stage_done);
    b->stage_done = NULL;
    vis_cl_scene *failed = e == CL_SUCCESS ? NULL : b->stage_scene;
    b->stage_scene = NULL;
    if (!failed)
        return VIS_OK;
    if (failed != u->sc) {
        failed->stale = 1;
        return VIS_OK;
    }
    return vis_cl_fail(e, "the previous scene upload", u->err, u->err_size);
}

/* Sends what is staged: one write of the headers and words, one scatter kernel. */
static int stage_flush(upload_state *u)
{
    if (u->ranges == 0)
        return VIS_OK;
    vis_cl_backend *b = u->b;
    vis_cl_scene *sc = u->sc;
    size_t bytes = (size_t)(STAGE_HEADER_WORDS + u->words) * sizeof(cl_uint);
    cl_int e = clEnqueueWriteBuffer(b->queue, b->stage_dev, CL_FALSE, 0, bytes, b->stage_host, 0, NULL, NULL);
    cl_kernel k = b->stage_scatter;
    const cl_mem *args[] = {&b->stage_dev,  &b->stage_dev,    &sc->leaves.mem,        &sc->buckets.mem,
                            &sc->quads.mem, &sc->tris.mem,    &sc->objects.mem,       &sc->object_leaves.mem,
                            &sc->rope_index.mem};
    for (cl_uint i = 0; e == CL_SUCCESS && i < sizeof args / sizeof args[0]; ++i)
        e = clSetKernelArg(k, i, sizeof(cl_mem), args[i]);
    size_t local = 64, global = (size_t)u->ranges * local;
    if (e == CL_SUCCESS)
        e = clEnqueueNDRangeKernel(b->queue, k, 1, NULL, &global, &local, 0, NULL, &b->stage_done);
    if (e == CL_SUCCESS)
        b->stage_scene = sc;
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "scene upload (staged)", u->err, u->err_size);
    u->ranges = 0;
    u->words = 0;
    ++u->flushes;
    return VIS_OK;
}

/* Stages elements [first, first + count) of a host array for the device array `a`, split
 * over as many flushes as the staging area needs. */
static int stage_range(upload_state *u, vis_cl_array *a, enum stage_array which, const void *host, size_t first,
                       size_t count, const char *what)
{
    if (!u->b->stage_host) /* no staging memory (see sync_partial): a write per range */
        return write_range(u, a, host, first, count, what);
    if (count == 0)
        return VIS_OK;
    if (!range_fits(u, a, first, count, what))
        return VIS_ERROR_BACKEND;
    const size_t per = a->elem / sizeof(cl_uint);
    const cl_uint *src = (const cl_uint *)host + first * per;
    size_t word = first * per, left = count * per;
    while (left) {
        if (u->ranges == STAGE_RANGES || u->words == STAGE_WORDS) {
            int st = stage_flush(u);
            if (st != VIS_OK)
                return st;
        }
        if (u->ranges == 0 && u->words == 0) {
            int st = stage_wait(u);
            if (st != VIS_OK)
                return st;
        }
        size_t n = STAGE_WORDS - u->words < left ? STAGE_WORDS - u->words : left;
        cl_uint *stage = u->b->stage_host;
        cl_ulong *hdr = (cl_ulong *)stage + 4u * u->ranges;
        hdr[0] = (cl_ulong)which;
        hdr[1] = (cl_ulong)word;
        hdr[2] = (cl_ulong)n;
        hdr[3] = (cl_ulong)(STAGE_HEADER_WORDS + u->words);
        memcpy(stage + STAGE_HEADER_WORDS + u->words, src, n * sizeof(cl_uint));
        ++u->ranges;
        u->words += (uint32_t)n;
        u->bytes += n * sizeof(cl_uint);
        src += n;
        word += n;
        left -= n;
    }
    return VIS_OK;
}

/* Whole array: (re)allocated with headroom when too small, then written [0, count). */
static int upload_all(upload_state *u, vis_cl_array *a, const void *host, size_t count, size_t headroom,
                      const char *what)
{
    if (!a->mem || a->cap < count) {
        vis_cl_array fresh = {NULL, 0, 0, a->elem};
        int st = array_alloc(u, &fresh, count + headroom, what);
        if (st != VIS_OK)
            return st;
        array_release(a);
        *a = fresh;
    }
    int st = host ? write_range(u, a, host, 0, count, what) : VIS_OK;
    if (st == VIS_OK)
        a->valid = host ? count : 0;
    return st;
}

/* Makes room for `count` elements, keeping the `valid` prefix already on the device. */
static int ensure(upload_state *u, vis_cl_array *a, size_t count, vis_cl_scene *sc, const char *what)
{
    if (count <= a->cap)
        return VIS_OK;
    size_t cap = count + count / 2 + HEADROOM_MIN;
    vis_cl_array fresh = {NULL, 0, 0, a->elem};
    int st = array_alloc(u, &fresh, cap, what);
    if (st != VIS_OK) {
        /* Headroom is a convenience: retry with the exact size before giving up. */
        st = array_alloc(u, &fresh, count, what);
        if (st != VIS_OK)
            return st;
    }
    if (a->valid) {
        cl_int e = clEnqueueCopyBuffer(u->b->queue, a->mem, fresh.mem, 0, 0, a->valid * a->elem, 0, NULL, NULL);
        if (e != CL_SUCCESS) {
            array_release(&fresh);
            return vis_cl_fail(e, "clEnqueueCopyBuffer", u->err, u->err_size);
        }
    }
    fresh.valid = a->valid;
    vis_cl_log(u->b, 0, "opencl: scene %s buffer grew from %zu to %zu elements", what, a->cap, fresh.cap);
    /* The old buffer is released after the copy: OpenCL keeps it alive until queued
     * commands that use it are done. */
    array_release(a);
    *a = fresh;
    ++sc->reallocations;
    return VIS_OK;
}

static uint32_t bucket_entries(const vis_flat_leaf *lf)
{
    if (lf->dims_z == 0xFFFFFFFFu)
        return 0; /* leaf too large for buckets: every quad is loose */
    return vis_bucket_words(lf->dims_xy & 0xFFFFu, lf->dims_xy >> 16, lf->dims_z);
}

static int upload_leaf(upload_state *u, vis_cl_scene *sc, const vis_scene_view *v, uint32_t li)
{
    if (li >= v->leaf_count) {
        snprintf(u->err, u->err_size, "internal: changed leaf %u of %u", li, v->leaf_count);
        return VIS_ERROR_BACKEND;
    }
    const vis_flat_leaf *lf = &v->leaves[li];
    int st = stage_range(u, &sc->leaves, STAGE_LEAVES, v->leaves, li, 1, "leaf");
    uint32_t nb = bucket_entries(lf);
    if (st == VIS_OK && nb && lf->bucket_offset < v->bucket_count && lf->bucket_offset + nb <= v->bucket_count)
        st = stage_range(u, &sc->buckets, STAGE_BUCKETS, v->buckets, lf->bucket_offset, nb, "bucket table");
    if (st != VIS_OK)
        return st;
    /* The slot's object table, packed quads and loose quads lie one after the other. */
    size_t q0 = lf->table_offset;
    size_t q1 = (size_t)lf->quad_offset + lf->quad_count + (size_t)lf->loose_count * VIS_LOOSE_WORDS;
    if (q1 > q0)
        st = stage_range(u, &sc->quads, STAGE_QUADS, v->quads, q0, q1 - q0, "quads");
    if (st == VIS_OK && lf->tri_count)
        st = stage_range(u, &sc->tris, STAGE_TRIS, v->tris, lf->tri_offset, lf->tri_count, "triangles");
    return st;
}

/* The cell map entries of the box of cells an edit changed, one range per row of the box. */
static int upload_map_box(upload_state *u, vis_cl_scene *sc, const vis_scene_view *v, const vis_scene_changes *ch)
{
    const uint32_t *n = v->cells;
    if (!v->cell_map || ch->map_hi[0] >= n[0] || ch->map_hi[1] >= n[1] || ch->map_hi[2] >= n[2] ||
        ch->map_lo[0] > ch->map_hi[0] || ch->map_lo[1] > ch->map_hi[1] || ch->map_lo[2] > ch->map_hi[2]) {
        snprintf(u->err, u->err_size, "internal: changed cell box (%u,%u,%u)-(%u,%u,%u) of a %ux%ux%u map",
                 ch->map_lo[0], ch->map_lo[1], ch->map_lo[2], ch->map_hi[0], ch->map_hi[1], ch->map_hi[2], n[0], n[1],
                 n[2]);
        return VIS_ERROR_BACKEND;
    }
    int st = VIS_OK;
    for (uint32_t z = ch->map_lo[2]; z <= ch->map_hi[2] && st == VIS_OK; ++z)
        for (uint32_t y = ch->map_lo[1]; y <= ch->map_hi[1] && st == VIS_OK; ++y) {
            size_t first = v->cell_map + ch->map_lo[0] + (size_t)n[0] * (y + (size_t)n[1] * z);
            st = stage_range(u, &sc->rope_index, STAGE_ROPE_INDEX, v->rope_index, first,
                             ch->map_hi[0] - ch->map_lo[0] + 1u, "cell map");
        }
    return st;
}

static int sync_full(upload_state *u, vis_cl_scene *sc, const vis_scene_view *v)
{
    /* Pools get headroom so that the first edits that grow them need no reallocation. */
    size_t hq = v->quad_count / 4 + HEADROOM_MIN, ht = v->tri_count / 4 + HEADROOM_MIN;
    size_t ho = v->object_count / 4 + HEADROOM_MIN, hb = v->bucket_count / 4 + HEADROOM_MIN;
    int st = upload_all(u, &sc->nodes, v->nodes, v->node_count, 0, "nodes");
    if (st == VIS_OK)
        st = upload_all(u, &sc->leaves, v->leaves, v->leaf_count, 0, "leaves");
    if (st == VIS_OK)
        st = upload_all(u, &sc->buckets, v->buckets, v->bucket_count, hb, "bucket tables");
    if (st == VIS_OK)
        st = upload_all(u, &sc->quads, v->quads, v->quad_count, hq, "quads");
    if (st == VIS_OK)
        st = upload_all(u, &sc->tris, v->tris, v->tri_count, ht, "triangles");
    if (st == VIS_OK)
        st = upload_all(u, &sc->objects, v->objects, v->object_count, ho, "objects");
    if (st == VIS_OK)
        st = upload_all(u, &sc->object_leaves, v->object_leaves, v->object_leaf_count, ho, "object leaf lists");
    if (st == VIS_OK)
        st = upload_all(u, &sc->ropes, v->ropes, v->ropes ? v->rope_count : 0, 0, "ropes");
    if (st == VIS_OK)
        st = upload_all(u, &sc->rope_index, v->rope_index, v->rope_index ? v->rope_index_count : 0, 0, "rope index");
    return st;
}

static int sync_partial(upload_state *u, vis_cl_scene *sc, const vis_scene_view *v, const vis_scene_changes *ch)
{
    /* The tree is fixed: a different node or leaf count, or ropes built since the last sync,
     * mean the backend's copy is of another tree; send everything again. */
    if (v->node_count != sc->nodes.valid || v->leaf_count != sc->leaves.valid)
        return sync_full(u, sc, v);
    /* Ropes are built by the first pass that walks them and never change; if they appeared
     * since the last sync, they are sent once, whole, with the index that now points at
     * them. */
    int st = VIS_OK;
    size_t ropes = v->ropes ? v->rope_count : 0, rope_index = v->rope_index ? v->rope_index_count : 0;
    if (ropes != sc->ropes.valid || rope_index != sc->rope_index.valid) {
        st = upload_all(u, &sc->ropes, v->ropes, ropes, 0, "ropes");
        if (st == VIS_OK)
            st = upload_all(u, &sc->rope_index, v->rope_index, rope_index, 0, "rope index");
    }
    if (st == VIS_OK)
        st = ensure(u, &sc->buckets, v->bucket_count, sc, "bucket tables");
    if (st == VIS_OK)
        st = ensure(u, &sc->quads, v->quad_count, sc, "quads");
    if (st == VIS_OK)
        st = ensure(u, &sc->tris, v->tri_count, sc, "triangles");
    if (st == VIS_OK)
        st = ensure(u, &sc->objects, v->object_count, sc, "objects");
    if (st == VIS_OK)
        st = ensure(u, &sc->object_leaves, v->object_leaf_count, sc, "object leaf lists");
    if (st == VIS_OK && (ch->leaf_count || ch->object_count || ch->object_leaf_hi > ch->object_leaf_lo) &&
        !u->b->stage_unavailable && stage_ready(u) != VIS_OK) {
        /* Pinned memory is a convenience: without it, each range is its own write (said once). */
        vis_cl_log(u->b, 1, "opencl: no staging memory for scene uploads (%s): a write per range", u->err);
        u->err[0] = '\0';
        u->b->stage_unavailable = 1;
    }
    for (uint32_t i = 0; i < ch->leaf_count && st == VIS_OK; ++i)
        st = upload_leaf(u, sc, v, ch->leaves[i]);
    for (uint32_t i = 0; i < ch->object_count && st == VIS_OK; ++i) {
        if (ch->objects[i] >= v->object_count) {
            snprintf(u->err, u->err_size, "internal: changed object slot %u of %u", ch->objects[i], v->object_count);
            return VIS_ERROR_BACKEND;
        }
        st = stage_range(u, &sc->objects, STAGE_OBJECTS, v->objects, ch->objects[i], 1, "objects");
    }
    if (st == VIS_OK && ch->map_changed)
        st = upload_map_box(u, sc, v, ch);
    if (st == VIS_OK && ch->object_leaf_hi > ch->object_leaf_lo) {
        uint32_t hi = ch->object_leaf_hi < v->object_leaf_count ? ch->object_leaf_hi : v->object_leaf_count;
        if (hi > ch->object_leaf_lo)
            st = stage_range(u, &sc->object_leaves, STAGE_OBJECT_LEAVES, v->object_leaves, ch->object_leaf_lo,
                             hi - ch->object_leaf_lo, "object leaf lists");
    }
    if (st == VIS_OK)
        st = stage_flush(u);
    if (st == VIS_OK && u->flushes > 1)
        vis_cl_log(u->b, 0, "opencl: scene upload staged in %u flushes (%llu bytes)", u->flushes,
                   (unsigned long long)u->bytes);
    if (st == VIS_OK) {
        /* Everything below the used counts now mirrors the host. */
        sc->buckets.valid = v->bucket_count;
        sc->quads.valid = v->quad_count;
        sc->tris.valid = v->tri_count;
        sc->objects.valid = v->object_count;
        sc->object_leaves.valid = v->object_leaf_count;
    }
    return st;
}

int vis_cl_scene_sync(vis_cl_backend *b, vis_cl_scene **scene, const vis_scene_view *view,
                      const vis_scene_changes *changes, char *err, size_t err_size)
{
    vis_cl_scene *sc = *scene;
    int fresh = 0;
    if (!sc) {
        sc = vis_host_calloc(&b->alloc, 1, sizeof *sc);
        if (!sc) {
            snprintf(err, err_size, "out of host memory for a scene");
            return VIS_ERROR_OUT_OF_MEMORY;
        }
        sc->nodes.elem = sizeof(vis_kd_node);
        sc->leaves.elem = sizeof(vis_flat_leaf);
        sc->buckets.elem = sizeof(uint32_t);
        sc->quads.elem = sizeof(uint32_t);
        sc->tris.elem = sizeof(vis_flat_tri);
        sc->objects.elem = sizeof(vis_flat_object);
        sc->object_leaves.elem = sizeof(uint32_t);
        sc->ropes.elem = sizeof(vis_rope_node);
        sc->rope_index.elem = sizeof(uint32_t);
        fresh = 1;
    }
    upload_state u = {b, sc, 0, 0, 0, 0, 0, err, err_size};
    int st = fresh || changes->full || sc->stale ? sync_full(&u, sc, view) : sync_partial(&u, sc, view, changes);
    if (st == VIS_OK)
        sc->stale = 0;
    if (st != VIS_OK || u.direct) {
        cl_int e = clFinish(b->queue);
        if (st == VIS_OK && e != CL_SUCCESS)
            st = vis_cl_fail(e, "clFinish (scene upload)", err, err_size);
    }
    if (st != VIS_OK) {
        /* A half-updated copy must not be traced: drop it; the next sync starts afresh. */
        vis_cl_scene_release(b, sc);
        *scene = NULL;
        return st;
    }
    sc->last_upload_bytes = u.bytes;
    sc->total_upload_bytes += u.bytes;
    *scene = sc;
    return VIS_OK;
}

void vis_cl_scene_release(vis_cl_backend *b, vis_cl_scene *sc)
{
    if (!sc)
        return;
    if (b->stage_scene == sc) { /* its scatter's outcome no longer matters */
        clWaitForEvents(1, &b->stage_done);
        clReleaseEvent(b->stage_done);
        b->stage_done = NULL;
        b->stage_scene = NULL;
    }
    vis_cl_array *arrays[] = {&sc->nodes,   &sc->leaves,        &sc->buckets, &sc->quads,     &sc->tris,
                              &sc->objects, &sc->object_leaves, &sc->ropes,   &sc->rope_index};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i)
        array_release(arrays[i]);
    vis_host_free(&b->alloc, sc);
}

void vis_cl_staging_release(vis_cl_backend *b)
{
    if (b->stage_done) {
        clWaitForEvents(1, &b->stage_done);
        clReleaseEvent(b->stage_done);
    }
    if (b->stage_pinned && b->stage_host && b->queue) {
        clEnqueueUnmapMemObject(b->queue, b->stage_pinned, b->stage_host, 0, NULL, NULL);
        clFinish(b->queue);
    }
    if (b->stage_pinned)
        clReleaseMemObject(b->stage_pinned);
    if (b->stage_dev)
        clReleaseMemObject(b->stage_dev);
    if (b->stage_scatter)
        clReleaseKernel(b->stage_scatter);
    b->stage_pinned = b->stage_dev = NULL;
    b->stage_scatter = NULL;
    b->stage_host = NULL;
    b->stage_done = NULL;
    b->stage_scene = NULL;
}
