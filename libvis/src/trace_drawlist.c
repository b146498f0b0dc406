/* trace_drawlist.c — vis_trace_drawlist and vis_trace_batch_drawlist: the ray pass and its
 * draw list in one call. A backend that builds lists itself (OpenCL: on the device,
 * backends/opencl/cl_drawlist.c) hands back the lists, sorted; for the others the
 * pass goes into the context's scratch and the list is built from it as vis_drawlist_build
 * builds it, so both give the same entries. */
#include <stdint.h>
#include <string.h>

#include "camera.h"
#include "drawlist.h"
#include "scene.h"
#include "trace.h"

/* What one call asks for. */
typedef struct dl_call {
    const vis_camera *cameras;
    uint32_t count;
    vis_draw_entry *entries;
    size_t capacity;
    size_t *counts;        /* count elements                                                   */
    size_t *total;
    uint32_t *ids;         /* single view only; may be NULL                                    */
    float *depth;
    const char *fn;
} dl_call;

static size_t round64(size_t n) { return (n + 63u) & ~(size_t)63u; }

/* The CPU path: each view traced into `ids_scratch` (or the caller's IDs), then its list. */
static vis_status host_lists(vis_context *ctx, vis_scene *scene, void *data, const vis_scene_view *view,
                             const vis_ray_setup *setups, const dl_call *c, uint32_t *ids_scratch, uint32_t *count_scratch,
                             vis_id_mode mode)
{
    const vis_backend_ops *ops = ctx->backend.ops;
    uint64_t pixels = (uint64_t)setups[0].width * setups[0].height;
    size_t done = 0;
    for (uint32_t i = 0; i < c->count; ++i) {
        uint32_t *ids = c->ids ? c->ids : ids_scratch;
        char err[1024] = "";
        int rc = ops->trace(ctx->backend.impl, data, view, &setups[i], ids, c->depth, err, sizeof err);
        if (rc != VIS_OK)
            return vis_fail(ctx, (vis_status)rc, "%s backend: %s", ops->name, err);
        size_t m = 0;
        vis_status st = vis_drawlist_from_ids(ctx, scene, ids, pixels, mode, count_scratch, c->entries + done,
                                              c->capacity - done, &m);
        if (st == VIS_ERROR_CAPACITY) {
            *c->total = done + m;
            return vis_fail(ctx, st, "%s: the draw list%s need%s %zu entries or more, capacity is %zu", c->fn,
                            c->count > 1 ? "s" : "", c->count > 1 ? "" : "s", done + m, c->capacity);
        }
        if (st != VIS_OK)
            return st;
        c->counts[i] = m;
        done += m;
    }
    *c->total = done;
    return VIS_OK;
}

static vis_status run(vis_context *ctx, vis_scene *scene, const vis_trace_desc *desc, const dl_call *c)
{
    double t0 = vis_trace_now_ms();
    vis_clear_error(ctx);
    if (!scene || !c->total || (c->capacity && !c->entries) || (c->count && !c->cameras))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: NULL argument", c->fn);
    *c->total = 0;
    if (c->count == 0)
        return VIS_OK;
    vis_trace_desc d;
    vis_status st = vis_trace_desc_resolve(ctx, desc, &d);
    if (st == VIS_OK)
        st = vis_trace_check_plain_effects(ctx, &d, c->fn);
    if (st != VIS_OK)
        return st;
    uint64_t pixels = (uint64_t)d.width * d.height;
    /* Scratch, one block: the setups; for the CPU path the IDs of one view and the counts. */
    const vis_backend_ops *ops = ctx->backend.ops;
    size_t setup_bytes = round64((size_t)c->count * sizeof(vis_ray_setup));
    size_t ids_bytes = ops->trace_drawlist || c->ids ? 0 : round64((size_t)pixels * sizeof(uint32_t));
    vis_scene_begin_read(scene);
    size_t count_bytes = ops->trace_drawlist ? 0 : vis_drawlist_scratch_bytes(scene, d.ids);
    vis_scene_end_read(scene);
    unsigned char *scratch = vis_scratch(ctx, setup_bytes + ids_bytes + count_bytes);
    if (!scratch)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "%s: out of memory for %u views", c->fn, c->count);
    vis_ray_setup *setups = (vis_ray_setup *)scratch;
    for (uint32_t i = 0; i < c->count && st == VIS_OK; ++i) {
        st = vis_trace_make_setup(ctx, scene, &c->cameras[i], &d, &setups[i]);
        if (st != VIS_OK && c->count > 1) {
            char msg[sizeof ctx->last_error];
            memcpy(msg, ctx->last_error, sizeof msg);
            st = vis_fail(ctx, st, "%s: camera %u: %s", c->fn, i, msg);
        }
    }
    if (st != VIS_OK)
        return st;
    uint64_t upload = 0;
    void *data = NULL;
    if ((st = vis_scene_begin_trace(ctx, scene, vis_trace_walks_ropes(&setups[0]), &data, &upload)) != VIS_OK)
        return st;
    vis_scene_view view = vis_scene_get_view(scene);
    double p0 = vis_trace_now_ms();
    if (ops->trace_drawlist) {
        char err[1024] = "";
        int rc = ops->trace_drawlist(ctx->backend.impl, data, &view, setups, c->count, c->ids, c->depth, c->entries,
                                     c->capacity, c->counts, c->total, err, sizeof err);
        if (rc != VIS_OK)
            st = vis_fail(ctx, (vis_status)rc, "%s: %s backend: %s", c->fn, ops->name, err);
    } else {
        /* Objects added since the scratch was sized (another thread's edit): a larger one, and
         * the setups again, as a new scratch keeps nothing. */
        size_t need = setup_bytes + ids_bytes + vis_drawlist_scratch_bytes(scene, d.ids);
        if (need > setup_bytes + ids_bytes + count_bytes) {
            scratch = vis_scratch(ctx, need);
            setups = (vis_ray_setup *)scratch;
            for (uint32_t i = 0; scratch && i < c->count && st == VIS_OK; ++i)
                st = vis_trace_make_setup(ctx, scene, &c->cameras[i], &d, &setups[i]);
        }
        if (!scratch)
            st = vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "%s: out of memory for draw-list scratch", c->fn);
        if (st == VIS_OK)
            st = host_lists(ctx, scene, data, &view, setups, c, ids_bytes ? (uint32_t *)(scratch + setup_bytes) : NULL,
                            (uint32_t *)(scratch + setup_bytes + ids_bytes), d.ids);
    }
    double pass_ms = vis_trace_now_ms() - p0;
    vis_scene_end_read(scene);
    if (st == VIS_OK)
        vis_trace_record_timing(ctx, t0, pass_ms, upload, (uint64_t)c->count * pixels, c->count);
    return st;
}

vis_status vis_trace_drawlist(vis_context *ctx, vis_scene *scene, const vis_camera *camera, const vis_trace_desc *desc,
                              vis_draw_entry *out_entries, size_t capacity, size_t *out_count, uint32_t *out_ids,
                              size_t ids_capacity, float *out_depth, size_t depth_capacity)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st = VIS_OK;
    vis_trace_desc d;
    if (!camera || !out_count)
        st = vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_drawlist: camera and out_count must not be NULL");
    else if ((!out_ids && ids_capacity) || (!out_depth && depth_capacity))
        st = vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_drawlist: a NULL buffer with a capacity");
    else if ((st = vis_trace_desc_resolve(ctx, desc, &d)) == VIS_OK &&
             (st = vis_trace_check_plain_effects(ctx, &d, "vis_trace_drawlist")) == VIS_OK) {
        uint64_t pixels = (uint64_t)d.width * d.height;
        if ((out_ids && (uint64_t)ids_capacity < pixels) || (out_depth && (uint64_t)depth_capacity < pixels))
            st = vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_trace_drawlist: a %ux%u view needs %llu elements, %s is %zu",
                          d.width, d.height, (unsigned long long)pixels,
                          out_ids && (uint64_t)ids_capacity < pixels ? "ids_capacity" : "depth_capacity",
                          out_ids && (uint64_t)ids_capacity < pixels ? ids_capacity : depth_capacity);
    }
    if (st == VIS_OK) {
        size_t n = 0;
        dl_call c = {camera, 1, out_entries, capacity, &n, out_count, out_ids, out_depth, "vis_trace_drawlist"};
        st = run(ctx, scene, desc, &c);
    }
    vis_leave(ctx);
    return st;
}

vis_status vis_trace_batch_drawlist(vis_context *ctx, vis_scene *scene, const vis_camera *cameras, uint32_t count,
                                    const vis_trace_desc *desc, vis_draw_entry *out_entries, size_t capacity,
                                    size_t *out_counts, size_t counts_capacity, size_t *out_total)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st = VIS_OK;
    if (count && !out_counts)
        st = vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_trace_batch_drawlist: out_counts must not be NULL");
    else if (counts_capacity < count)
        st = vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_trace_batch_drawlist: %u views need %u counts, counts_capacity is %zu",
                      count, count, counts_capacity);
    if (st == VIS_OK) {
        dl_call c = {cameras, count, out_entries, capacity, out_counts, out_total, NULL, NULL, "vis_trace_batch_drawlist"};
        st = run(ctx, scene, desc, &c);
    }
    vis_leave(ctx);
    return st;
}
