/* context.c — contexts: allocator, logger, last error, backend choice, scratch. */
#include "context.h"
#include "host_memory.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *vis_status_string(vis_status status)
{
    switch (status) {
    case VIS_OK: return "ok";
    case VIS_ERROR_INVALID_ARGUMENT: return "invalid argument";
    case VIS_ERROR_OUT_OF_MEMORY: return "out of memory";
    case VIS_ERROR_UNSUPPORTED: return "unsupported";
    case VIS_ERROR_BACKEND: return "backend error";
    case VIS_ERROR_NOT_FOUND: return "not found";
    case VIS_ERROR_CAPACITY: return "output too small";
    case VIS_ERROR_BUDGET: return "over budget";
    case VIS_ERROR_BUSY: return "context busy on another thread";
    }
    return "unknown status";
}

const char *vis_version(void) { return VIS_VERSION_STRING; }

void *vis_alloc(vis_context *ctx, size_t size) { return ctx->alloc.alloc(size, 64, ctx->alloc.user); }

void *vis_calloc(vis_context *ctx, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    void *p = vis_alloc(ctx, count * size);
    if (p)
        memset(p, 0, count * size);
    return p;
}

void *vis_realloc(vis_context *ctx, void *ptr, size_t old_size, size_t new_size)
{
    if (ctx->alloc.alloc == vis_default_alloc)
        return vis_default_realloc(ptr, old_size, new_size);
    void *p = vis_alloc(ctx, new_size);
    if (!p)
        return NULL;
    if (ptr) {
        memcpy(p, ptr, old_size < new_size ? old_size : new_size);
        vis_free(ctx, ptr);
    }
    return p;
}

void vis_free(vis_context *ctx, void *ptr)
{
    if (ptr)
        ctx->alloc.free(ptr, ctx->alloc.user);
}

void *vis_scratch(vis_context *ctx, size_t size)
{
    if (size <= ctx->scratch_size)
        return ctx->scratch;
    size_t cap = ctx->scratch_size ? ctx->scratch_size : 4096;
    while (cap < size)
        cap *= 2;
    void *p = vis_alloc(ctx, cap);
    if (!p)
        return NULL;
    vis_free(ctx, ctx->scratch);
    ctx->scratch = p;
    ctx->scratch_size = cap;
    return p;
}

static void vlog(vis_context *ctx, vis_log_level level, const char *fmt, va_list ap, char *copy_to, size_t copy_size)
{
    char buf[2048];
    vsnprintf(buf, sizeof buf, fmt, ap);
    if (copy_to)
        snprintf(copy_to, copy_size, "%s", buf);
    if (ctx->desc.log)
        ctx->desc.log(level, buf, ctx->desc.log_user);
}

vis_status vis_fail(vis_context *ctx, vis_status status, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(ctx, VIS_LOG_ERROR, fmt, ap, ctx->last_error, sizeof ctx->last_error);
    va_end(ap);
    return status;
}

void vis_log(vis_context *ctx, vis_log_level level, const char *fmt, ...)
{
    if (!ctx->desc.log)
        return;
    va_list ap;
    va_start(ap, fmt);
    vlog(ctx, level, fmt, ap, NULL, 0);
    va_end(ap);
}

void vis_clear_error(vis_context *ctx) { ctx->last_error[0] = '\0'; }

vis_status vis_enter(vis_context *ctx)
{
    int expected = 0;
    return atomic_compare_exchange_strong_explicit(&ctx->busy, &expected, 1, memory_order_acquire,
                                                   memory_order_relaxed)
               ? VIS_OK
               : VIS_ERROR_BUSY;
}

void vis_leave(vis_context *ctx) { atomic_store_explicit(&ctx->busy, 0, memory_order_release); }

void vis_context_desc_defaults(vis_context_desc *desc)
{
    memset(desc, 0, sizeof *desc);
    desc->backend = VIS_BACKEND_AUTO;
}

static void backend_log_thunk(int level, const char *message, void *user)
{
    vis_log((vis_context *)user, (vis_log_level)level, "%s", message);
}

static vis_status create_cpu(vis_context *ctx)
{
    char err[512] = "";
    uint32_t threads = 0;
    /* With the caller's job system the pool has one thread, the caller: it starts none. */
    int st = vis_cpu_backend_create(ctx->desc.parallel_for ? 1u : ctx->desc.threads, &ctx->alloc, &ctx->backend,
                                    &threads, err, sizeof err);
    if (st != VIS_OK)
        return vis_fail(ctx, (vis_status)st, "cpu backend: %s", err);
    if (ctx->desc.parallel_for) {
        vis_cpu_backend_set_parallel_for(&ctx->backend, ctx->desc.parallel_for, ctx->desc.parallel_for_user);
        threads = 0;
    }
    ctx->info.kind = VIS_BACKEND_CPU;
    ctx->info.threads = threads;
    snprintf(ctx->info.name, sizeof ctx->info.name, "cpu");
    if (ctx->desc.parallel_for)
        snprintf(ctx->info.device, sizeof ctx->info.device, "the caller's parallel_for");
    else
        snprintf(ctx->info.device, sizeof ctx->info.device, "%u thread%s", threads, threads == 1 ? "" : "s");
    return VIS_OK;
}

/* Tries OpenCL; returns its status and leaves the reason in `why`. gpu_only (AUTO with no
 * device named): a GPU or nothing, without starting a CPU-only implementation (PoCL). */
static vis_status create_opencl(vis_context *ctx, int gpu_only, char *why, size_t why_size, int *is_gpu)
{
#ifdef VIS_HAVE_OPENCL
    char err[1024] = "";
    const char *sel = ctx->desc.opencl_device;
    if (!sel || !*sel)
        sel = getenv("VIS_OPENCL_DEVICE");
    int st = vis_opencl_backend_create(sel, gpu_only, &ctx->alloc, &ctx->backend, ctx->info.device, sizeof ctx->info.device,
                                       is_gpu, backend_log_thunk, ctx, err, sizeof err);
    if (st != VIS_OK) {
        snprintf(why, why_size, "%s", err);
        return (vis_status)st;
    }
    ctx->info.kind = VIS_BACKEND_OPENCL;
    ctx->info.is_gpu = *is_gpu;
    snprintf(ctx->info.name, sizeof ctx->info.name, "opencl");
    return VIS_OK;
#else
    (void)ctx;
    (void)gpu_only;
    (void)is_gpu;
    (void)backend_log_thunk;
    snprintf(why, why_size, "this build has no OpenCL backend (configure with -DVIS_WITH_OPENCL=ON)");
    return VIS_ERROR_UNSUPPORTED;
#endif
}

/* Whether the caller named an OpenCL device (desc or $VIS_OPENCL_DEVICE): AUTO then uses it
 * whatever its kind. */
static int opencl_device_named(const vis_context *ctx)
{
    const char *sel = ctx->desc.opencl_device;
    if (sel && *sel)
        return 1;
    sel = getenv("VIS_OPENCL_DEVICE");
    return sel && *sel;
}

vis_status vis_context_create(const vis_context_desc *desc, vis_context **out_context)
{
    if (!out_context)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_context_desc d;
    if (desc)
        d = *desc;
    else
        vis_context_desc_defaults(&d);
    vis_allocator alloc = d.allocator;
    if (!alloc.alloc != !alloc.free)
        return VIS_ERROR_INVALID_ARGUMENT; /* both or neither */
    if (!alloc.alloc) {
        alloc.alloc = vis_default_alloc;
        alloc.free = vis_default_free;
        alloc.user = NULL;
    }
    if (d.backend != VIS_BACKEND_AUTO && d.backend != VIS_BACKEND_CPU && d.backend != VIS_BACKEND_OPENCL)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (d.threads > 1024)
        return VIS_ERROR_INVALID_ARGUMENT;
    vis_context *ctx = alloc.alloc(sizeof *ctx, 64, alloc.user);
    if (!ctx)
        return VIS_ERROR_OUT_OF_MEMORY;
    memset(ctx, 0, sizeof *ctx);
    atomic_init(&ctx->busy, 0);
    atomic_init(&ctx->foreign_copies, 0u);
    ctx->desc = d;
    ctx->alloc = alloc;

    vis_status st;
    char why[1024] = "";
    int is_gpu = 0;
    switch (d.backend) {
    case VIS_BACKEND_CPU:
        st = create_cpu(ctx);
        break;
    case VIS_BACKEND_OPENCL:
        st = create_opencl(ctx, 0, why, sizeof why, &is_gpu);
        if (st != VIS_OK)
            vis_fail(ctx, st, "opencl backend: %s", why);
        break;
    default: /* AUTO: an OpenCL GPU (or any device named), else the CPU backend */
        st = create_opencl(ctx, !opencl_device_named(ctx), why, sizeof why, &is_gpu);
        if (st == VIS_OK && !is_gpu && !opencl_device_named(ctx)) {
            /* An OpenCL CPU device (PoCL): the CPU backend traces packets on the same cores,
             * 10-75x faster than the per-ray kernel there (docs/performance.md). */
            snprintf(why, sizeof why, "the OpenCL device (%.200s) is not a GPU, and the CPU backend is faster on a CPU",
                     ctx->info.device);
            ctx->backend.ops->destroy(ctx->backend.impl);
            memset(&ctx->backend, 0, sizeof ctx->backend);
            memset(&ctx->info, 0, sizeof ctx->info);
            st = VIS_ERROR_UNSUPPORTED;
        }
        if (st == VIS_OK) {
            snprintf(ctx->info.reason, sizeof ctx->info.reason, "auto: OpenCL %s found (%s)",
                     is_gpu ? "GPU" : "device", ctx->info.device);
        } else {
            st = create_cpu(ctx);
            if (st == VIS_OK) {
                snprintf(ctx->info.reason, sizeof ctx->info.reason, "auto: no usable OpenCL device (%.200s); using the CPU", why);
                vis_log(ctx, VIS_LOG_INFO, "%s", ctx->info.reason);
            }
        }
        break;
    }
    if (st != VIS_OK) {
        /* The context cannot be returned, so its message goes to the log only. */
        alloc.free(ctx, alloc.user);
        return st;
    }
    *out_context = ctx;
    return VIS_OK;
}

vis_status vis_context_destroy(vis_context *ctx)
{
    if (!ctx)
        return VIS_OK;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    unsigned foreign = atomic_load(&ctx->foreign_copies);
    if (foreign) {
        vis_status st = vis_fail(ctx, VIS_ERROR_BUSY,
                                 "vis_context_destroy: the context still holds copies of %u scene(s) of other "
                                 "contexts; destroy those scenes first",
                                 foreign);
        vis_leave(ctx);
        return st;
    }
    vis_leave(ctx); /* the destroy functions below are calls on the context */
    while (ctx->zculls)
        vis_zcull_destroy(ctx->zculls);
    while (ctx->scenes)
        vis_scene_destroy(ctx->scenes);
    if (ctx->backend.ops)
        ctx->backend.ops->destroy(ctx->backend.impl);
    vis_free(ctx, ctx->scratch);
    vis_allocator a = ctx->alloc;
    a.free(ctx, a.user);
    return VIS_OK;
}

const char *vis_context_last_error(const vis_context *ctx) { return ctx ? ctx->last_error : "no context"; }

vis_status vis_context_backend(const vis_context *ctx, vis_backend_info *out_info)
{
    if (!ctx || !out_info)
        return VIS_ERROR_INVALID_ARGUMENT;
    *out_info = ctx->info;
    return VIS_OK;
}
