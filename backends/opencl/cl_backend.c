/* cl_backend.c — the OpenCL backend's vtable: create, sync, trace one view or a batch.
 *
 * One context and one in-order queue with profiling on the chosen device (cl_device.c); the
 * program is built at creation (cl_program.c), so a device that cannot build the kernels
 * fails here and AUTO falls back to the CPU. Each pass is one kernel launch over the pixels
 * in 8x8 work-groups, then a readback of the IDs (and depths when asked for). The kernel's
 * own time comes from its event (CL_PROFILING_COMMAND_START/END). */
#include <stdint.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opencl/cl_internal.h"

/* Output buffers hold at most this many pixels per launch (256 MiB of IDs); larger batches
 * run as several launches. */
#define MAX_PIXELS_PER_LAUNCH ((size_t)1 << 26)
#define TILE 8u

const char *vis_cl_error_name(cl_int e)
{
    switch (e) {
    case CL_SUCCESS: return "CL_SUCCESS";
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_DEVICE_NOT_AVAILABLE: return "CL_DEVICE_NOT_AVAILABLE";
    case CL_COMPILER_NOT_AVAILABLE: return "CL_COMPILER_NOT_AVAILABLE";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_PROFILING_INFO_NOT_AVAILABLE: return "CL_PROFILING_INFO_NOT_AVAILABLE";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_DEVICE: return "CL_INVALID_DEVICE";
    case CL_INVALID_CONTEXT: return "CL_INVALID_CONTEXT";
    case CL_INVALID_COMMAND_QUEUE: return "CL_INVALID_COMMAND_QUEUE";
    case CL_INVALID_MEM_OBJECT: return "CL_INVALID_MEM_OBJECT";
    case CL_INVALID_BUILD_OPTIONS: return "CL_INVALID_BUILD_OPTIONS";
    case CL_INVALID_PROGRAM_EXECUTABLE: return "CL_INVALID_PROGRAM_EXECUTABLE";
    case CL_INVALID_KERNEL_NAME: return "CL_INVALID_KERNEL_NAME";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_ARG_INDEX: return "CL_INVALID_ARG_INDEX";
    case CL_INVALID_ARG_VALUE: return "CL_INVALID_ARG_VALUE";
    case CL_INVALID_ARG_SIZE: return "CL_INVALID_ARG_SIZE";
    case CL_INVALID_WORK_DIMENSION: return "CL_INVALID_WORK_DIMENSION";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_INVALID_WORK_ITEM_SIZE: return "CL_INVALID_WORK_ITEM_SIZE";
    case CL_INVALID_GLOBAL_WORK_SIZE: return "CL_INVALID_GLOBAL_WORK_SIZE";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_EVENT: return "CL_INVALID_EVENT";
    case CL_INVALID_OPERATION: return "CL_INVALID_OPERATION";
    case CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST: return "CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST";
    case CL_PLATFORM_NOT_FOUND_KHR: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "OpenCL error";
    }
}

int vis_cl_status(cl_int e)
{
    if (e == CL_MEM_OBJECT_ALLOCATION_FAILURE || e == CL_OUT_OF_RESOURCES || e == CL_OUT_OF_HOST_MEMORY ||
        e == CL_INVALID_BUFFER_SIZE)
        return VIS_ERROR_OUT_OF_MEMORY;
    return VIS_ERROR_BACKEND;
}

int vis_cl_fail(cl_int e, const char *what, char *err, size_t err_size)
{
    int st = vis_cl_status(e);
    snprintf(err, err_size, "%s: %s (%d)%s", what, vis_cl_error_name(e), (int)e,
             st == VIS_ERROR_OUT_OF_MEMORY ? ": out of device memory" : "");
    return st;
}

void vis_cl_log(const vis_cl_backend *b, int level, const char *fmt, ...)
{
    if (!b->log)
        return;
    char buf[2048];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    b->log(level, buf, b->log_user);
}

/* ---- vtable --------------------------------------------------------------------------- */

static void cl_destroy(void *impl)
{
    vis_cl_backend *b = impl;
    if (!b)
        return;
    if (b->queue)
        clFinish(b->queue);
    vis_cl_staging_release(b);
    vis_cl_programs_release(b);
    vis_cl_drawlist_release(b);
    if (b->ids)
        clReleaseMemObject(b->ids);
    if (b->depth)
        clReleaseMemObject(b->depth);
    if (b->setups)
        clReleaseMemObject(b->setups);
    if (b->dummy)
        clReleaseMemObject(b->dummy);
    if (b->pt_counter)
        clReleaseMemObject(b->pt_counter);
    cl_mem fx[3] = {b->fx_layers, b->fx_reflection, b->fx_shadow};
    for (int i = 0; i < 3; ++i)
        if (fx[i])
            clReleaseMemObject(fx[i]);
    if (b->queue)
        clReleaseCommandQueue(b->queue);
    if (b->context)
        clReleaseContext(b->context);
    vis_allocator a = b->alloc;
    vis_host_free(&a, b);
}

static vis_status cl_scene_sync(void *impl, void **scene_data, const vis_scene_view *view, const vis_scene_changes *changes,
                         char *err, size_t err_size)
{
    const vis_cl_backend *b = impl;
    /* The watertight triangle test needs double precision to equal the CPU (trace_core.h):
     * without it a triangle scene is refused rather than traced differently. Quads never
     * use it, so quad scenes trace bit for bit on any device. */
    if (!b->caps.fp64 && view->tri_count > 0u) {
        snprintf(err, err_size,
                 "device '%s' has no double precision (cl_khr_fp64), which the triangle test needs to equal the "
                 "CPU; this scene holds triangles: trace it on the CPU backend",
                 b->caps.name);
        return VIS_ERROR_UNSUPPORTED;
    }
    return vis_cl_scene_sync(impl, (vis_cl_scene **)scene_data, view, changes, err, err_size);
}

static void cl_scene_release(void *impl, void *scene_data)
{
    vis_cl_backend *b = impl;
    if (b->queue)
        clFinish(b->queue);
    vis_cl_scene_release(b, scene_data);
}

static uint64_t cl_last_upload_bytes(void *impl, void *scene_data)
{
    (void)impl;
    const vis_cl_scene *sc = scene_data;
    return sc ? sc->last_upload_bytes : 0;
}

static double cl_last_kernel_ms(void *impl) { return ((const vis_cl_backend *)impl)->last_kernel_ms; }

int vis_cl_ensure_buffer(vis_cl_backend *b, cl_mem *mem, size_t *cap, size_t need, size_t elem, cl_mem_flags flags,
                         const char *what, char *err, size_t err_size)
{
    if (*mem && *cap >= need)
        return VIS_OK;
    if ((cl_ulong)need * elem > b->caps.max_alloc) {
        snprintf(err, err_size, "%s of %zu bytes exceed the device's largest allocation (%llu bytes)", what,
                 need * elem, (unsigned long long)b->caps.max_alloc);
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    if (*mem)
        clReleaseMemObject(*mem);
    *mem = NULL;
    *cap = 0;
    cl_int e = CL_SUCCESS;
    cl_mem m = clCreateBuffer(b->context, flags, need * elem, NULL, &e);
    if (e != CL_SUCCESS) {
        char w[96];
        snprintf(w, sizeof w, "clCreateBuffer (%s, %zu bytes)", what, need * elem);
        return vis_cl_fail(e, w, err, err_size);
    }
    *mem = m;
    *cap = need;
    return VIS_OK;
}

int vis_cl_set_scene_args(cl_kernel k, const vis_cl_scene *sc, cl_uint first)
{
    const cl_mem *m[] = {&sc->nodes.mem,   &sc->leaves.mem,        &sc->buckets.mem,
                         &sc->quads.mem,   &sc->tris.mem,          &sc->objects.mem,
                         &sc->object_leaves.mem, &sc->ropes.mem,   &sc->rope_index.mem};
    for (cl_uint i = 0; i < sizeof m / sizeof m[0]; ++i) {
        cl_int e = clSetKernelArg(k, first + i, sizeof(cl_mem), m[i]);
        if (e != CL_SUCCESS)
            return (int)e;
    }
    return CL_SUCCESS;
}

cl_int vis_cl_enqueue_pass(vis_cl_backend *b, const vis_cl_program *p, cl_kernel k, cl_uint pt_arg, uint32_t width,
                           uint32_t height, uint32_t views, int batch, cl_event *ev)
{
    size_t global[3], local[3];
    vis_cl_grid(b, width, height, views, batch, global, local);
    if (!p->persistent)
        return clEnqueueNDRangeKernel(b->queue, k, 3, NULL, global, local, 0, NULL, ev);
    /* Persistent threads: as many groups as the device could hold at once if registers
     * allowed (2,048 work-items per compute unit, the most an NVIDIA SM runs since Maxwell),
     * never more than there are tiles. Groups beyond what fits wait and start as others end,
     * taking whatever tiles are left, so too many costs nothing and too few would idle SMs. */
    size_t items = local[0] * local[1];
    size_t tiles = global[0] / local[0] * (global[1] / local[1]) * views;
    size_t groups = (size_t)(b->caps.compute_units ? b->caps.compute_units : 1u) * (2048u / items ? 2048u / items : 1u);
    if (groups > tiles)
        groups = tiles;
    size_t pg[3] = {groups * local[0], local[1], 1};
    cl_uint nv = views, zero[2] = {0, 0};
    /* The last group zeroes the counter for the next launch; a launch that died part-way
     * would leave it counting, and every later launch would find no tile and write nothing.
     * So the host zeroes it too (8 bytes, in queue order; added after the H200 figures). */
    cl_int e = clEnqueueFillBuffer(b->queue, b->pt_counter, zero, sizeof zero[0], 0, sizeof zero, 0, NULL, NULL);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, pt_arg, sizeof(cl_mem), &b->pt_counter);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, pt_arg + 1u, sizeof nv, &nv);
    if (e == CL_SUCCESS)
        e = clEnqueueNDRangeKernel(b->queue, k, 3, NULL, pg, local, 0, NULL, ev);
    return e;
}

/* Launches `k` of `p` over width x height x views (vis_cl_enqueue_pass; pt_arg: where a
 * persistent kernel takes its counter; batch: in a batch's tiles) and reads the outputs back
 * into ids/depth (views * width * height each). Adds the kernel's device time to
 * last_kernel_ms. */
static int launch(vis_cl_backend *b, const vis_cl_program *p, cl_kernel k, cl_uint pt_arg, uint32_t width,
                  uint32_t height, uint32_t views, int batch, uint32_t *ids, float *depth, char *err, size_t err_size)
{
    cl_event ev = NULL;
    cl_int e = vis_cl_enqueue_pass(b, p, k, pt_arg, width, height, views, batch, &ev);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clEnqueueNDRangeKernel", err, err_size);
    size_t n = (size_t)width * height * views;
    e = clEnqueueReadBuffer(b->queue, b->ids, CL_FALSE, 0, n * sizeof(uint32_t), ids, 0, NULL, NULL);
    if (e == CL_SUCCESS && depth)
        e = clEnqueueReadBuffer(b->queue, b->depth, CL_FALSE, 0, n * sizeof(float), depth, 0, NULL, NULL);
    cl_int f = clFinish(b->queue);
    if (e == CL_SUCCESS)
        e = f;
    if (e != CL_SUCCESS) {
        clReleaseEvent(ev);
        return vis_cl_fail(e, "ray pass", err, err_size);
    }
    vis_cl_add_event_time(b, ev);
    clReleaseEvent(ev);
    return VIS_OK;
}

void vis_cl_add_event_time(vis_cl_backend *b, cl_event ev)
{
    cl_ulong t0 = 0, t1 = 0;
    if (clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL) == CL_SUCCESS &&
        clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL) == CL_SUCCESS && t1 >= t0)
        b->last_kernel_ms += (double)(t1 - t0) * 1e-6;
}

/* Whole tiles where the device runs them; otherwise one work-item per group (the draw-list
 * kernel sizes its local memory from the group, so the runtime may not pick the size). */
void vis_cl_grid(const vis_cl_backend *b, uint32_t width, uint32_t height, uint32_t views, int batch,
                 size_t global[3], size_t local[3])
{
    const size_t *shape = batch ? b->batch_tile : b->tile;
    size_t tx = shape[0], ty = shape[1];
    if (!(b->caps.max_wg >= tx * ty && b->caps.max_item[0] >= tx && b->caps.max_item[1] >= ty))
        tx = ty = 1;
    local[0] = tx;
    local[1] = ty;
    local[2] = 1;
    global[0] = (width + tx - 1) / tx * tx;
    global[1] = (height + ty - 1) / ty * ty;
    global[2] = views;
}

size_t vis_cl_ring_bytes(const vis_ray_setup *setup, const size_t local[3])
{
    if (setup->traversal == VIS_TRAVERSAL_ID_PACKET)
        return VIS_CL_TILE_LOCAL_BYTES; /* the group's flags and stack, once (kernels/tile.cl) */
    size_t items = local[0] * local[1];
    uint32_t n = setup->traversal == VIS_TRAVERSAL_ID_CACHED_STACK ? setup->short_stack : 1u;
    if (n < 1u)
        n = 1u;
    return items * n * sizeof(vis_stack_entry);
}

static int prepare_outputs(vis_cl_backend *b, size_t pixels, int want_depth, char *err, size_t err_size)
{
    int st = vis_cl_ensure_buffer(b, &b->ids, &b->out_cap, pixels, sizeof(uint32_t), CL_MEM_WRITE_ONLY, "ID buffer", err,
                           err_size);
    if (st == VIS_OK && want_depth)
        st = vis_cl_ensure_buffer(b, &b->depth, &b->depth_cap, pixels, sizeof(float), CL_MEM_WRITE_ONLY, "depth buffer",
                           err, err_size);
    return st;
}

/* The program for one traversal method: built with -DVIS_TRAVERSAL_ONLY=<id>u, so the kernel
 * holds that method alone (trace_core.h, vis_trace_pixel_slot) and none of the others'
 * private stacks. Nine methods, packets being the work-group's walk of kernels/tile.cl, and at
 * most VIS_CL_MAX_PROGRAMS option sets; ids above the table get the generic program that
 * switches on setup->traversal (which has no tile walk: a batch mixing methods traces its
 * packet views with kd-restart, exact like every method). */
const char *vis_cl_traversal_options(uint32_t traversal)
{
    static const char *const opts[] = {"-DVIS_TRAVERSAL_ONLY=0u", "-DVIS_TRAVERSAL_ONLY=1u", "-DVIS_TRAVERSAL_ONLY=2u",
                                        "-DVIS_TRAVERSAL_ONLY=3u", "-DVIS_TRAVERSAL_ONLY=4u", "-DVIS_TRAVERSAL_ONLY=5u",
                                        "-DVIS_TRAVERSAL_ONLY=6u", "-DVIS_TRAVERSAL_ONLY=7u",
                                        "-DVIS_TRAVERSAL_ONLY=8u", "-DVIS_TRAVERSAL_ONLY=9u"};
    return traversal < sizeof opts / sizeof opts[0] ? opts[traversal] : "";
}

const char *vis_cl_method_options(const vis_cl_backend *b, uint32_t traversal, int batch)
{
    if (traversal > VIS_TRAVERSAL_ID_DDA)
        return "";
    return batch ? b->batch_options[traversal] : b->method_options[traversal];
}

/* The register cap of a method's batch program (launches of several views): on a platform
 * whose name contains "NVIDIA" (its compiler takes -cl-nv-* options) " -cl-nv-maxrregcount=N" for the stack method (N = 56) and the
 * cell-grid walk (N = 72), "" otherwise, and "" when $VIS_OPENCL_BUILD_OPTIONS (extra) sets a
 * cap of its own. A batch keeps every SM full, so it runs as fast as the warps an SM holds
 * allow, and those are set by the registers of its largest kernel: the draw-list kernels
 * take 72 (stack) and 121 (dda) registers uncapped, 28 and 16 warps of 64 per SM (ptxas,
 * sm_90a). Capped, 256 views with draw lists went from 3.26 to 3.62 G rays/s with `stack`
 * and from 2.60 to 3.35 with `dda` on the H200; one view, whose time is its slowest tiles',
 * ran slower capped (docs/opencl.md, "Register caps for batches"), so single views are built
 * without. The cap is meant to change where values live, not an operation; results were
 * measured bit for bit the same on the H200 (test_opencl, vis_clbench conformance). */
const char *vis_cl_batch_register_cap(const char *platform, uint32_t traversal, const char *extra)
{
    if (!strstr(platform, "NVIDIA") || strstr(extra, "maxrregcount"))
        return "";
    if (traversal == VIS_TRAVERSAL_ID_STACK)
        return " -cl-nv-maxrregcount=56";
    return traversal == VIS_TRAVERSAL_ID_DDA ? " -cl-nv-maxrregcount=72" : "";
}

/* $VIS_OPENCL_WALK: how the per-ray kernels walk (docs/opencl.md "Persistent threads and leaf
 * postponing"; Aila & Laine 2009). Words joined by '+' or ',':
 *   persistent   every method's kernels as persistent threads (trace.cl);
 *   postpone     the stack method's walk parks 2 non-empty leaves before testing them
 *                (postpone.cl); postpone1 .. postpone4 park that many;
 *   vote         with postpone, the node loop ends once every lane of the warp holds a
 *                leaf (a warp vote in inline PTX: NVIDIA only);
 *   plain        none of these.
 * A value applies to single views and batches alike. Unset (the default): on a GPU, launches
 * of several views (batches, batch draw lists) run as persistent threads and single views
 * plain, which measured fastest on the H200 for each; on other devices everything is plain.
 * Fills b->method_options and b->batch_options; returns a vis_status value with the reason.
 * Results never depend on it (every walk gives the stack method's buffers). */
int vis_cl_walk_options(vis_cl_backend *b, const char *walk, char *err, size_t err_size)
{
    int persistent = 0, postpone = 0, vote = 0;
    const char *p = walk ? walk : "";
    while (*p) {
        size_t n = strcspn(p, "+,");
        if (n == 10 && strncmp(p, "persistent", n) == 0)
            persistent = 1;
        else if (n == 8 && strncmp(p, "postpone", n) == 0)
            postpone = 2;
        else if (n == 9 && strncmp(p, "postpone", 8) == 0 && p[8] >= '1' && p[8] <= '4')
            postpone = p[8] - '0';
        else if (n == 4 && strncmp(p, "vote", n) == 0)
            vote = 1;
        else if (!(n == 5 && strncmp(p, "plain", n) == 0) && n > 0) {
            snprintf(err, err_size, "$VIS_OPENCL_WALK \"%s\": unknown word (persistent, postpone, postpone1..4, vote, plain)",
                     walk);
            return VIS_ERROR_INVALID_ARGUMENT;
        }
        p += n;
        if (*p)
            ++p;
    }
    if (vote && (!postpone || !strstr(b->caps.platform, "NVIDIA"))) {
        snprintf(err, err_size, "$VIS_OPENCL_WALK \"%s\": vote needs postpone and an NVIDIA device (inline PTX)", walk);
        return VIS_ERROR_UNSUPPORTED;
    }
    int batch_persistent = walk && *walk ? persistent : b->caps.is_gpu;
    for (uint32_t t = 0; t <= VIS_TRAVERSAL_ID_DDA; ++t) {
        char pp[48] = "";
        if (postpone && t == VIS_TRAVERSAL_ID_STACK)
            snprintf(pp, sizeof pp, " -DVIS_CL_POSTPONE=%d%s", postpone, vote ? " -DVIS_CL_VOTE" : "");
        snprintf(b->method_options[t], sizeof b->method_options[t], "%s%s%s", vis_cl_traversal_options(t), pp,
                 persistent ? " -DVIS_CL_PERSISTENT" : "");
        snprintf(b->batch_options[t], sizeof b->batch_options[t], "%s%s%s%s", vis_cl_traversal_options(t), pp,
                 batch_persistent ? " -DVIS_CL_PERSISTENT" : "",
                 vis_cl_batch_register_cap(b->caps.platform, t, b->extra_options));
    }
    if (!persistent && !batch_persistent)
        return VIS_OK;
    cl_int e = CL_SUCCESS;
    b->pt_counter = clCreateBuffer(b->context, CL_MEM_READ_WRITE, 2 * sizeof(cl_uint), NULL, &e);
    cl_uint zero = 0;
    if (e == CL_SUCCESS)
        e = clEnqueueFillBuffer(b->queue, b->pt_counter, &zero, sizeof zero, 0, 2 * sizeof(cl_uint), 0, NULL, NULL);
    if (e == CL_SUCCESS)
        e = clFinish(b->queue);
    return e == CL_SUCCESS ? VIS_OK : vis_cl_fail(e, "the persistent threads' counter", err, err_size);
}

static vis_status cl_trace(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                    uint32_t *ids, float *depth, char *err, size_t err_size)
{
    (void)view;
    vis_cl_backend *b = impl;
    const vis_cl_scene *sc = scene_data;
    b->last_kernel_ms = 0.0;
    vis_cl_program *p = NULL;
    int st = vis_cl_program_get(b, vis_cl_method_options(b, setup->traversal, 0), &p, err, err_size);
    if (st != VIS_OK)
        return st;
    size_t pixels = (size_t)setup->width * setup->height;
    if ((st = prepare_outputs(b, pixels, depth != NULL, err, err_size)) != VIS_OK)
        return st;
    cl_uint write_depth = depth != NULL;
    cl_mem depth_mem = depth ? b->depth : b->dummy; /* never written when write_depth = 0 */
    cl_int e = clSetKernelArg(p->trace, 0, sizeof *setup, setup);
    if (e == CL_SUCCESS)
        e = vis_cl_set_scene_args(p->trace, sc, 1);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->trace, 10, sizeof(cl_mem), &b->ids);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->trace, 11, sizeof(cl_mem), &depth_mem);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->trace, 12, sizeof write_depth, &write_depth);
    size_t global[3], local[3];
    if (e == CL_SUCCESS) {
        vis_cl_grid(b, 1, 1, 1, 0, global, local);
        e = clSetKernelArg(p->trace, 13, vis_cl_ring_bytes(setup, local), NULL);
    }
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clSetKernelArg", err, err_size);
    return launch(b, p, p->trace, 14, setup->width, setup->height, 1, 0, ids, depth, err, err_size);
}

/* The program of a batch: its cameras' method when they share one, else the generic one;
 * with the batch walk (persistent threads by default on a GPU) when it has several views. */
int vis_cl_batch_program(vis_cl_backend *b, const vis_ray_setup *setups, uint32_t count, vis_cl_program **p,
                         char *err, size_t err_size)
{
    uint32_t traversal = setups[0].traversal;
    for (uint32_t i = 1; i < count; ++i)
        if (setups[i].traversal != traversal)
            traversal = UINT32_MAX;
    return vis_cl_program_get(b, vis_cl_method_options(b, traversal, count > 1u), p, err, err_size);
}

static vis_status cl_trace_batch(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setups,
                          uint32_t count, uint32_t *ids, float *depth, char *err, size_t err_size)
{
    (void)view;
    vis_cl_backend *b = impl;
    const vis_cl_scene *sc = scene_data;
    b->last_kernel_ms = 0.0;
    if (count == 0)
        return VIS_OK;
    vis_cl_program *p = NULL;
    int st = vis_cl_batch_program(b, setups, count, &p, err, err_size);
    if (st != VIS_OK)
        return st;
    uint32_t W = setups[0].width, H = setups[0].height;
    size_t pixels = (size_t)W * H;
    size_t limit = MAX_PIXELS_PER_LAUNCH;
    if (b->caps.max_alloc / sizeof(uint32_t) < limit)
        limit = (size_t)(b->caps.max_alloc / sizeof(uint32_t));
    size_t per = limit / pixels;
    if (per == 0)
        per = 1; /* one view larger than the limit: ensure_buffer says whether it fits */
    if (per > count)
        per = count;
    if ((st = prepare_outputs(b, per * pixels, depth != NULL, err, err_size)) != VIS_OK)
        return st;
    if ((st = vis_cl_ensure_buffer(b, &b->setups, &b->setup_cap, per, sizeof(vis_ray_setup), CL_MEM_READ_ONLY,
                            "camera buffer", err, err_size)) != VIS_OK)
        return st;
    cl_uint write_depth = depth != NULL;
    cl_mem depth_mem = depth ? b->depth : b->dummy;
    cl_int e = clSetKernelArg(p->batch, 0, sizeof(cl_mem), &b->setups);
    if (e == CL_SUCCESS)
        e = vis_cl_set_scene_args(p->batch, sc, 1);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->batch, 10, sizeof(cl_mem), &b->ids);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->batch, 11, sizeof(cl_mem), &depth_mem);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(p->batch, 12, sizeof write_depth, &write_depth);
    size_t global[3], local[3];
    if (e == CL_SUCCESS) {
        vis_cl_grid(b, 1, 1, 1, 1, global, local);
        e = clSetKernelArg(p->batch, 13, vis_cl_ring_bytes(&setups[0], local), NULL);
    }
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clSetKernelArg", err, err_size);
    for (uint32_t first = 0; first < count; first += (uint32_t)per) {
        uint32_t n = count - first < per ? count - first : (uint32_t)per;
        e = clEnqueueWriteBuffer(b->queue, b->setups, CL_FALSE, 0, (size_t)n * sizeof *setups, setups + first, 0,
                                 NULL, NULL);
        if (e != CL_SUCCESS)
            return vis_cl_fail(e, "clEnqueueWriteBuffer (cameras)", err, err_size);
        st = launch(b, p, p->batch, 14, W, H, n, 1, ids + (size_t)first * pixels, depth ? depth + (size_t)first * pixels : NULL,
                    err, err_size);
        if (st != VIS_OK)
            return st;
    }
    return VIS_OK;
}

/* The effects program for one method and effect set (-DVIS_TRACE_EFFECTS -DVIS_TRAVERSAL_ONLY
 * -DVIS_EFFECTS_ONLY: only that code is compiled). Once VIS_CL_MAX_EFFECT_PROGRAMS of those
 * are built, the generic effects program (switching on both at run time) serves every
 * further set, so the plain programs always keep their slots. */
static int effects_program(vis_cl_backend *b, uint32_t traversal, uint32_t effects, vis_cl_program **p, char *err,
                           size_t err_size)
{
    char opts[96];
    snprintf(opts, sizeof opts, "-DVIS_TRACE_EFFECTS -DVIS_TRAVERSAL_ONLY=%uu -DVIS_EFFECTS_ONLY=%uu", traversal,
             effects);
    int cached = 0;
    for (uint32_t i = 0; i < b->program_count && !cached; ++i)
        cached = strcmp(b->programs[i].options, opts) == 0;
    /* Every per-ray method gets its own program (dda being the GPU default); the tile walk's
     * effects are the stack method's (vis_traverse), as in the generic program. */
    if (!cached && (b->effect_programs >= VIS_CL_MAX_EFFECT_PROGRAMS || traversal > VIS_TRAVERSAL_ID_DDA ||
                    traversal == VIS_TRAVERSAL_ID_PACKET))
        snprintf(opts, sizeof opts, "-DVIS_TRACE_EFFECTS");
    else if (!cached)
        ++b->effect_programs; /* counted once tried: a set that fails to build fails again */
    int st = vis_cl_program_get(b, opts, p, err, err_size);
    if (st == VIS_OK && !(*p)->effects) {
        snprintf(err, err_size, "no effects kernel in program \"%s\"", opts);
        return VIS_ERROR_BACKEND;
    }
    return st;
}

static vis_status cl_trace_effects(void *impl, void *scene_data, const vis_scene_view *view,
                                   const vis_ray_setup *setup, const vis_effect_setup *effects,
                                   const vis_effect_outputs *out, char *err, size_t err_size)
{
    (void)view;
    vis_cl_backend *b = impl;
    const vis_cl_scene *sc = scene_data;
    b->last_kernel_ms = 0.0;
    vis_cl_program *p = NULL;
    int st = effects_program(b, setup->traversal, effects->effects, &p, err, err_size);
    if (st != VIS_OK)
        return st;
    size_t pixels = (size_t)setup->width * setup->height;
    if ((st = prepare_outputs(b, pixels, out->depth != NULL, err, err_size)) != VIS_OK)
        return st;
    if (out->see_through && (st = vis_cl_ensure_buffer(b, &b->fx_layers, &b->fx_layers_cap, pixels * effects->layers,
                                                sizeof(uint32_t), CL_MEM_WRITE_ONLY, "see-through buffer", err,
                                                err_size)) != VIS_OK)
        return st;
    if (out->reflection && (st = vis_cl_ensure_buffer(b, &b->fx_reflection, &b->fx_reflection_cap, pixels, sizeof(uint32_t),
                                               CL_MEM_WRITE_ONLY, "reflection buffer", err, err_size)) != VIS_OK)
        return st;
    if (out->shadow && (st = vis_cl_ensure_buffer(b, &b->fx_shadow, &b->fx_shadow_cap, pixels, sizeof(uint32_t),
                                           CL_MEM_WRITE_ONLY, "shadow buffer", err, err_size)) != VIS_OK)
        return st;
    cl_uint write_depth = out->depth != NULL;
    cl_mem mems[4] = {out->depth ? b->depth : b->dummy, out->see_through ? b->fx_layers : b->dummy,
                      out->reflection ? b->fx_reflection : b->dummy, out->shadow ? b->fx_shadow : b->dummy};
    cl_kernel k = p->effects;
    cl_int e = clSetKernelArg(k, 0, sizeof *setup, setup);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 1, sizeof *effects, effects);
    if (e == CL_SUCCESS)
        e = vis_cl_set_scene_args(k, sc, 2);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 11, sizeof(cl_mem), &b->ids);
    for (cl_uint i = 0; i < 4 && e == CL_SUCCESS; ++i)
        e = clSetKernelArg(k, 12 + i, sizeof(cl_mem), &mems[i]);
    if (e == CL_SUCCESS)
        e = clSetKernelArg(k, 16, sizeof write_depth, &write_depth);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clSetKernelArg", err, err_size);
    if ((st = launch(b, p, k, 17, setup->width, setup->height, 1, 0, out->ids, out->depth, err, err_size)) != VIS_OK)
        return st;
    /* launch has finished the queue: the effect buffers are complete. */
    if (out->see_through)
        e = clEnqueueReadBuffer(b->queue, b->fx_layers, CL_TRUE, 0, pixels * effects->layers * sizeof(uint32_t),
                                out->see_through, 0, NULL, NULL);
    if (e == CL_SUCCESS && out->reflection)
        e = clEnqueueReadBuffer(b->queue, b->fx_reflection, CL_TRUE, 0, pixels * sizeof(uint32_t), out->reflection, 0,
                                NULL, NULL);
    if (e == CL_SUCCESS && out->shadow)
        e = clEnqueueReadBuffer(b->queue, b->fx_shadow, CL_TRUE, 0, pixels * sizeof(uint32_t), out->shadow, 0, NULL,
                                NULL);
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "reading the effect buffers", err, err_size);
    if (out->secondary_rays)
        *out->secondary_rays = 0; /* not counted on the device */
    return VIS_OK;
}

static const vis_backend_ops cl_ops = {
    .name = "opencl",
    .destroy = cl_destroy,
    .scene_sync = cl_scene_sync,
    .scene_release = cl_scene_release,
    .trace = cl_trace,
    .last_upload_bytes = cl_last_upload_bytes,
    .trace_batch = cl_trace_batch,
    .last_kernel_ms = cl_last_kernel_ms,
    .trace_drawlist = vis_cl_trace_drawlist,
    .trace_effects = cl_trace_effects,
};

vis_status vis_opencl_backend_create(const char *selector, int gpu_only, const vis_allocator *alloc,
                                     vis_backend *out, char *device_name, size_t name_size, int *is_gpu,
                                     vis_backend_log_fn log, void *log_user, char *err, size_t err_size)
{
    /* A GPU is all AUTO wants: where only CPU implementations are installed, the loader is not
     * even opened (it would load them all; cl_loader.c). */
    if (gpu_only && vis_cl_icds_cpu_only(err, err_size))
        return VIS_ERROR_UNSUPPORTED;
    int st = vis_cl_load(err, err_size);
    if (st != VIS_OK)
        return st;
    vis_cl_backend *b = vis_host_calloc(alloc, 1, sizeof *b);
    if (!b) {
        snprintf(err, err_size, "out of host memory");
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    b->alloc = *alloc;
    b->log = log;
    b->log_user = log_user;
    st = vis_cl_device_pick(selector, gpu_only, &b->platform, &b->device, &b->caps, err, err_size);
    if (st != VIS_OK) {
        vis_host_free(alloc, b);
        return st;
    }
    /* $VIS_OPENCL_ASSUME_NO_FP64=1 treats the device as one without double precision, so
     * that the refusal of triangle scenes (cl_scene_sync) can be tested on any device. */
    const char *no_fp64 = getenv("VIS_OPENCL_ASSUME_NO_FP64");
    if (no_fp64 && strcmp(no_fp64, "1") == 0)
        b->caps.fp64 = 0;
    cl_int e = CL_SUCCESS;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)b->platform, 0};
    b->context = clCreateContext(props, 1, &b->device, NULL, NULL, &e);
    if (e == CL_SUCCESS)
        b->queue = clCreateCommandQueue(b->context, b->device, CL_QUEUE_PROFILING_ENABLE, &e);
    if (e != CL_SUCCESS) {
        st = vis_cl_fail(e, b->context ? "clCreateCommandQueue" : "clCreateContext", err, err_size);
        cl_destroy(b);
        return st;
    }
    b->dummy = clCreateBuffer(b->context, CL_MEM_READ_WRITE, 16, NULL, &e);
    if (e != CL_SUCCESS) {
        st = vis_cl_fail(e, "clCreateBuffer", err, err_size);
        cl_destroy(b);
        return st;
    }
    /* Work-group shape: square 8x8 tiles for one view, 8x4 for batches (3 % faster on the
     * lent H100 for batches of 256, the same for one view within 1 %: docs/opencl.md, "Work-
     * group shape and register cap for batches"), unless $VIS_OPENCL_TILE=WxH says otherwise
     * for both (a tuning knob). Results never depend on it. */
    b->tile[0] = b->tile[1] = TILE;
    b->batch_tile[0] = TILE;
    b->batch_tile[1] = TILE / 2;
    const char *tile = getenv("VIS_OPENCL_TILE");
    unsigned tw = 0, th = 0;
    if (tile && sscanf(tile, "%ux%u", &tw, &th) == 2 && tw >= 1 && th >= 1 && tw <= 1024 && th <= 1024) {
        b->tile[0] = b->batch_tile[0] = tw;
        b->tile[1] = b->batch_tile[1] = th;
    }
    /* Extra build options (a tuning knob like the tile shape): register limits and the like.
     * Options that change results are refused, as cl_program.c never uses them: relaxed or
     * flushing math, and macro definitions (-D, -U), which could redefine the kernels' own
     * (VIS_TRAVERSAL_ONLY, the layout sizes). */
    const char *extra = getenv("VIS_OPENCL_BUILD_OPTIONS");
    if (extra && *extra) {
        if (strstr(extra, "fast-relaxed") || strstr(extra, "mad-enable") || strstr(extra, "unsafe-math") ||
            strstr(extra, "denorms-are-zero") || strstr(extra, "finite-math") || strstr(extra, "-D") || strstr(extra, "-U") ||
            strlen(extra) >= sizeof b->extra_options) {
            snprintf(err, err_size, "$VIS_OPENCL_BUILD_OPTIONS \"%s\" is refused: too long, or an option that changes "
                     "results", extra);
            cl_destroy(b);
            return VIS_ERROR_INVALID_ARGUMENT;
        }
        snprintf(b->extra_options, sizeof b->extra_options, "%s", extra);
    }
    if ((st = vis_cl_walk_options(b, getenv("VIS_OPENCL_WALK"), err, err_size)) != VIS_OK) {
        cl_destroy(b);
        return st;
    }
    vis_cl_program *p = NULL; /* the default method's program: a device that cannot build fails here */
    st = vis_cl_program_get(b, vis_cl_method_options(b, 0u, 0), &p, err, err_size);
    if (st == VIS_OK) { /* staged scene uploads (cl_scene.c) */
        cl_int e = CL_SUCCESS;
        b->stage_scatter = clCreateKernel(p->program, "vis_scatter_words", &e);
        if (e != CL_SUCCESS)
            st = vis_cl_fail(e, "clCreateKernel (vis_scatter_words)", err, err_size);
    }
    if (st != VIS_OK) {
        cl_destroy(b);
        return st;
    }
    vis_cl_log(b, 1, "opencl: %s '%s' (%s, %s, driver %s); fp64 %s; fp32 denormals %s; work-groups %zux%zu "
               "(batches %zux%zu)%s%s; stack program \"%s\", batches \"%s\"",
               b->caps.is_gpu ? "GPU" : "device", b->caps.name, b->caps.platform, b->caps.version, b->caps.driver,
               b->caps.fp64 ? "yes" : "no", b->caps.denorms ? "yes" : "no", b->tile[0], b->tile[1], b->batch_tile[0],
               b->batch_tile[1],
               b->extra_options[0] ? "; extra build options " : "", b->extra_options, b->method_options[0],
               b->batch_options[0]);
    if (!b->caps.fp64)
        vis_cl_log(b, 2, "opencl: '%s' has no cl_khr_fp64: scenes holding triangles are refused on it", b->caps.name);
    snprintf(device_name, name_size, "%s", b->caps.name);
    *is_gpu = b->caps.is_gpu;
    out->ops = &cl_ops;
    out->impl = b;
    return VIS_OK;
}
