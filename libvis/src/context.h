/* context.h — internal: the context (allocator, logger, last error, backend, scratch). */
#ifndef VIS_CONTEXT_H
#define VIS_CONTEXT_H

#include <stdarg.h>
#include <stdatomic.h>

#include "backend.h"
#include "vis/vis.h"

struct vis_context {
    vis_context_desc desc;
    vis_allocator alloc;
    vis_backend backend;
    vis_backend_info info;
    char last_error[2048];
    void *scratch;        /* per-call scratch (draw list counts, ...), grown only when needed */
    size_t scratch_size;
    vis_timing timing;    /* of the last successful vis_trace / vis_trace_batch              */
    int have_timing;
    atomic_int busy;      /* 1 while a thread is inside a call that uses the fields above    */
    atomic_uint foreign_copies; /* backend copies this context holds of other contexts' scenes */
    struct vis_scene *scenes;   /* created here, newest first (vis_context_destroy frees them) */
    struct vis_zcull *zculls;
};

/* Records the message as the context's last error, logs it, and returns `status`. */
vis_status vis_fail(vis_context *ctx, vis_status status, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
void vis_log(vis_context *ctx, vis_log_level level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
void vis_clear_error(vis_context *ctx);

/* Takes the context for one call: VIS_ERROR_BUSY (and no message: the last error belongs
 * to the thread inside) when another thread is in a call on it. vis_leave gives it back. */
vis_status vis_enter(vis_context *ctx);
void vis_leave(vis_context *ctx);

/* Host memory through the context's allocator; 64-byte aligned. vis_realloc keeps the
 * first min(old_size, new_size) bytes. All return NULL on failure (no message). */
void *vis_alloc(vis_context *ctx, size_t size);
void *vis_calloc(vis_context *ctx, size_t count, size_t size);
void *vis_realloc(vis_context *ctx, void *ptr, size_t old_size, size_t new_size);
void vis_free(vis_context *ctx, void *ptr);

/* Scratch of at least `size` bytes, valid until the next call that takes scratch. */
void *vis_scratch(vis_context *ctx, size_t size);

/* A 32-bit integer hash for the open-addressing ID maps (the scene's, the queries'): Chris
 * Wellons' lowbias32 (hash-prospector), every bit of the key spread over every bit. */
static inline uint32_t vis_hash_u32(uint32_t x)
{
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

#endif
