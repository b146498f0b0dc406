/* test_alloc.c — every host allocation goes through the context's allocator, and a warm
 * frame allocates nothing, by anyone.
 *
 * The allocator hook alone cannot see a backend that calls malloc itself, so this binary
 * also interposes malloc, calloc, realloc and the aligned allocators (forwarding to glibc's
 * __libc_* entry points) and counts the calls made while a flag is up, from any thread. The
 * context's own allocator forwards to __libc_memalign directly, so it is not counted as a
 * direct call. Under AddressSanitizer, which owns malloc, nothing is interposed: there the
 * tests check the context's allocator (counts, failures, leaks) and the release build checks
 * the direct calls. */
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "host_memory.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

/* ---- malloc interposition ----------------------------------------------------------- */

static atomic_int g_watch;        /* count direct calls while set                            */
static atomic_size_t g_direct;    /* malloc-family calls seen while g_watch was set          */
static void *_Atomic g_first_caller; /* return address of the first one (for the message) */

#ifdef VT_ASAN
static void *raw_alloc(size_t align, size_t size) { return aligned_alloc(align, (size + align - 1) / align * align); }
static void raw_free(void *p) { free(p); }
#else
extern void *__libc_malloc(size_t size);
extern void *__libc_calloc(size_t count, size_t size);
extern void *__libc_realloc(void *ptr, size_t size);
extern void *__libc_memalign(size_t align, size_t size);
extern void __libc_free(void *ptr);
static void *raw_alloc(size_t align, size_t size) { return __libc_memalign(align, size); }
static void raw_free(void *p) { __libc_free(p); }

static void note_direct(void *caller)
{
    if (!atomic_load_explicit(&g_watch, memory_order_relaxed))
        return;
    if (atomic_fetch_add(&g_direct, 1) == 0)
        atomic_store(&g_first_caller, caller);
}

void *malloc(size_t size)
{
    note_direct(__builtin_return_address(0));
    return __libc_malloc(size);
}

void *calloc(size_t count, size_t size)
{
    note_direct(__builtin_return_address(0));
    return __libc_calloc(count, size);
}

void *realloc(void *ptr, size_t size)
{
    note_direct(__builtin_return_address(0));
    return __libc_realloc(ptr, size);
}

void *aligned_alloc(size_t align, size_t size)
{
    note_direct(__builtin_return_address(0));
    return __libc_memalign(align, size);
}

void *memalign(size_t align, size_t size)
{
    note_direct(__builtin_return_address(0));
    return __libc_memalign(align, size);
}

int posix_memalign(void **out, size_t align, size_t size)
{
    note_direct(__builtin_return_address(0));
    void *p = __libc_memalign(align, size);
    if (!p)
        return 12; /* ENOMEM */
    *out = p;
    return 0;
}

void free(void *ptr) { __libc_free(ptr); }
#endif

static void watch_begin(void)
{
    atomic_store(&g_direct, 0);
    atomic_store(&g_first_caller, NULL);
    atomic_store(&g_watch, 1);
}

static size_t watch_end(void)
{
    atomic_store(&g_watch, 0);
    return atomic_load(&g_direct);
}

/* ---- the context's allocator ---------------------------------------------------------- */

typedef struct counting {
    atomic_size_t allocs, frees;
    atomic_int watch;        /* count allocs into `watched` while set */
    atomic_size_t watched;
} counting;

static void *count_alloc(size_t size, size_t align, void *user)
{
    counting *c = user;
    atomic_fetch_add(&c->allocs, 1);
    if (atomic_load(&c->watch))
        atomic_fetch_add(&c->watched, 1);
    return raw_alloc(align, size ? size : 1);
}

static void count_free(void *p, void *user)
{
    atomic_fetch_add(&((counting *)user)->frees, 1);
    raw_free(p);
}

static vis_context *make_context(counting *c, uint32_t threads)
{
    vis_allocator a = {count_alloc, count_free, c};
    vis_context *ctx = NULL;
    vis_status st = cpu_ctx_create(threads, &a, &ctx);
    if (st != VIS_OK)
        fail_msg("vis_context_create: %s", vis_status_string(st));
    return ctx;
}

/* A floor, a wall and a triangle in a 64^3 scene. */
static vis_scene *make_small_scene(vis_context *ctx)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = 64;
    vis_scene *s = NULL;
    if (vis_scene_create(ctx, &d, &s) != VIS_OK)
        return NULL;
    vis_quad floor_q = {1, 0, 8, 0, 0, 64, 64};
    vis_quad wall = {0, 0, 40, 8, 0, 30, 64};
    vis_triangle tri = {{{10, 8, 10}, {20, 20, 12}, {30, 8, 14}}, 0};
    vis_quad glass = {2, VIS_PRIM_SEE_THROUGH | VIS_PRIM_REFLECTIVE, 20, 0, 8, 64, 30}; /* for the effects */
    vis_mesh m1 = {&floor_q, 1, NULL, 0}, m2 = {&wall, 1, NULL, 0}, m3 = {NULL, 0, &tri, 1}, m4 = {&glass, 1, NULL, 0};
    if (vis_scene_set_object(s, 1, &m1) != VIS_OK || vis_scene_set_object(s, 2, &m2) != VIS_OK ||
        vis_scene_set_object(s, 7, &m3) != VIS_OK || vis_scene_set_object(s, 9, &m4) != VIS_OK) {
        vis_scene_destroy(s);
        return NULL;
    }
    return s;
}

enum { W = 64, H = 48 };
static uint32_t g_ids[2 * W * H];
static float g_depth[2 * W * H];
static uint32_t g_layers[2 * W * H], g_reflection[W * H], g_shadow[W * H];

/* One frame of every per-frame call; returns the first status that is not VIS_OK. */
static vis_status frame(vis_context *ctx, vis_scene *s, vis_zcull *z, const vis_camera *cam)
{
    vis_draw_entry list[8];
    size_t count = 0;
    vis_status st;
    for (int t = 0; t <= (int)VIS_TRAVERSAL_PACKET; ++t)
        for (int mode = 0; mode < 2; ++mode) {
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = W;
            td.height = H;
            td.ids = (vis_id_mode)mode;
            td.traversal = (vis_traversal)t;
            if ((st = vis_trace(ctx, s, cam, &td, g_ids, W * H, g_depth, W * H)) != VIS_OK)
                return st;
            if ((st = vis_drawlist_build(ctx, s, g_ids, W, H, (vis_id_mode)mode, list, 8, &count)) != VIS_OK)
                return st;
        }
    /* Every effect, every method; the packet instance too (AUTO, PACKET): 4x4 packets on this
     * view, 16x16 on the last pass, narrowed to 12 degrees. */
    for (int t = 0; t <= (int)VIS_TRAVERSAL_PACKET + 1; ++t) {
        vis_camera view = *cam;
        if (t > (int)VIS_TRAVERSAL_PACKET)
            view.fovy_deg = 12;
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = W;
        td.height = H;
        td.traversal = t > (int)VIS_TRAVERSAL_PACKET ? VIS_TRAVERSAL_PACKET : (vis_traversal)t;
        td.effects = VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG;
        td.light_dir[0] = 0.3, td.light_dir[1] = 1.0, td.light_dir[2] = 0.2;
        td.fog_dist = 80.0;
        vis_effect_buffers b = {g_ids, W * H, g_depth, W * H, g_layers, 2 * W * H, g_reflection, W * H, g_shadow, W * H};
        vis_effect_entry fx[8];
        if ((st = vis_trace_effects(ctx, s, &view, &td, &b)) != VIS_OK ||
            (st = vis_drawlist_build_effects(ctx, s, &b, W, H, 2, fx, 8, &count)) != VIS_OK)
            return st;
    }
    vis_camera two[2] = {*cam, *cam};
    two[1].eye[1] += 3;
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = W;
    td.height = H;
    if ((st = vis_trace_batch(ctx, s, two, 2, &td, g_ids, 2 * W * H, g_depth, 2 * W * H)) != VIS_OK)
        return st;
    vis_zcull_desc zd;
    vis_zcull_desc_defaults(&zd);
    zd.width = W;
    zd.height = H;
    if ((st = vis_zcull_run(z, s, cam, &zd, list, 8, &count, NULL)) != VIS_OK)
        return st;
    vis_timing timing;
    return vis_context_last_timing(ctx, &timing);
}

/* Warm frames on the CPU backend with its worker threads: no allocation through the hook,
 * and no malloc by anyone (libvis, the backend, the pool's workers). */
static void test_warm_frames_allocate_nothing(void **state)
{
    (void)state;
    counting c = {0};
    vis_context *ctx = make_context(&c, 3);
    vis_scene *s = make_small_scene(ctx);
    assert_non_null(s);
    vis_zcull *z = NULL;
    assert_int_equal(vis_zcull_create(ctx, &z), VIS_OK);
    vis_camera cam = {{32, 40, 2}, {30, 0, 40}, 60, 0, 0};
    assert_int_equal(frame(ctx, s, z, &cam), VIS_OK); /* warm-up: scratch grows, scene syncs */
    vis_status st[10];
    atomic_store(&c.watch, 1);
    watch_begin();
    for (int i = 0; i < 10; ++i) {
        cam.eye[0] += 0.5;
        cam.target[2] -= 0.25;
        st[i] = frame(ctx, s, z, &cam);
    }
    size_t direct = watch_end();
    atomic_store(&c.watch, 0);
    for (int i = 0; i < 10; ++i)
        assert_int_equal(st[i], VIS_OK);
    if (direct)
        fail_msg("%zu malloc-family calls during warm frames (first from %p)", direct, atomic_load(&g_first_caller));
    if (atomic_load(&c.watched))
        fail_msg("%zu allocations through the context's allocator during warm frames", atomic_load(&c.watched));
    vis_zcull_destroy(z);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
    assert_int_equal(atomic_load(&c.allocs), atomic_load(&c.frees));
}

/* The whole life of a serial context (no thread is started, so the C library has no reason
 * to allocate on libvis's behalf): every byte comes from the context's allocator, nothing
 * from malloc, and everything taken is given back. */
static void test_all_host_memory_through_the_allocator(void **state)
{
    (void)state;
    counting c = {0};
    watch_begin();
    vis_context *ctx = make_context(&c, 1);
    vis_scene *s = make_small_scene(ctx);
    vis_zcull *z = NULL;
    vis_status zst = vis_zcull_create(ctx, &z);
    vis_camera cam = {{32, 40, 2}, {30, 0, 40}, 60, 0, 0};
    vis_status f1 = s && zst == VIS_OK ? frame(ctx, s, z, &cam) : VIS_ERROR_INVALID_ARGUMENT;
    /* An edit and a removal: the backend's copy of the scene follows. */
    vis_quad q = {2, 0, 50, 0, 0, 64, 64};
    vis_mesh m = {&q, 1, NULL, 0};
    vis_status e1 = s ? vis_scene_set_object(s, 9, &m) : VIS_ERROR_INVALID_ARGUMENT;
    vis_status e2 = s ? vis_scene_remove_object(s, 2) : VIS_ERROR_INVALID_ARGUMENT;
    vis_status f2 = s && zst == VIS_OK ? frame(ctx, s, z, &cam) : VIS_ERROR_INVALID_ARGUMENT;
    vis_zcull_destroy(z);
    vis_scene_destroy(s);
    vis_context_destroy(ctx);
    size_t direct = watch_end();
    assert_non_null(s);
    assert_int_equal(zst, VIS_OK);
    assert_int_equal(f1, VIS_OK);
    assert_int_equal(e1, VIS_OK);
    assert_int_equal(e2, VIS_OK);
    assert_int_equal(f2, VIS_OK);
    if (direct)
        fail_msg("%zu malloc-family calls bypassed the context's allocator (first from %p)", direct,
                 atomic_load(&g_first_caller));
    assert_true(atomic_load(&c.allocs) > 3); /* context, backend, scene, ... */
    assert_int_equal(atomic_load(&c.allocs), atomic_load(&c.frees));
}

/* An allocator that fails at its n-th call: every call either succeeds or returns
 * VIS_ERROR_OUT_OF_MEMORY, and nothing leaks, whichever allocation fails. */
typedef struct failing {
    counting c;
    size_t fail_at; /* 1-based; 0 = never */
} failing;

static void *fail_alloc(size_t size, size_t align, void *user)
{
    failing *f = user;
    size_t n = atomic_load(&f->c.allocs) + 1;
    if (f->fail_at && n == f->fail_at) {
        f->fail_at = 0;
        return NULL;
    }
    return count_alloc(size, align, &f->c);
}

static void fail_free(void *p, void *user) { count_free(p, &((failing *)user)->c); }

static void test_allocation_failures_are_reported(void **state)
{
    (void)state;
    int completed = 0;
    for (size_t n = 1; n < 200 && !completed; ++n) {
        failing f = {{0}, n};
        vis_allocator a = {fail_alloc, fail_free, &f};
        vis_context *ctx = NULL;
        vis_status st = cpu_ctx_create(2, &a, &ctx);
        if (st == VIS_OK) {
            vis_scene *s = make_small_scene(ctx);
            vis_camera cam = {{32, 40, 2}, {30, 0, 40}, 60, 0, 0};
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = W;
            td.height = H;
            vis_status ts = s ? vis_trace(ctx, s, &cam, &td, g_ids, W * H, NULL, 0) : VIS_ERROR_OUT_OF_MEMORY;
            if (ts != VIS_OK && ts != VIS_ERROR_OUT_OF_MEMORY)
                fail_msg("failing allocation %zu: vis_trace gave %s", n, vis_status_string(ts));
            completed = f.fail_at != 0 && ts == VIS_OK; /* the n-th call never came */
            vis_scene_destroy(s);
            vis_context_destroy(ctx);
        } else if (st != VIS_ERROR_OUT_OF_MEMORY) {
            fail_msg("failing allocation %zu: vis_context_create gave %s", n, vis_status_string(st));
        }
        if (atomic_load(&f.c.allocs) != atomic_load(&f.c.frees))
            fail_msg("failing allocation %zu: %zu allocations, %zu frees", n, atomic_load(&f.c.allocs),
                     atomic_load(&f.c.frees));
    }
    assert_true(completed);
}

/* The default allocator: every block 64-byte aligned, contents kept through growth and
 * shrinking across the 1 MiB line where blocks become mappings that grow in place. */
static void fill_pattern(unsigned char *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; ++i)
        p[i] = (unsigned char)(i * 131u + seed);
}

static void check_pattern(const unsigned char *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; ++i)
        if (p[i] != (unsigned char)(i * 131u + seed))
            fail_msg("byte %zu of %zu changed", i, n);
}

static void test_default_allocator_keeps_contents(void **state)
{
    (void)state;
    assert_null(vis_default_alloc(64, 128, NULL)); /* alignment past 64: refused */
    size_t sizes[] = {1, 100, 4096, 1000000, (size_t)1 << 20, 3000000, 5000000, 200000, 64, 9000000};
    size_t n = sizeof sizes / sizeof sizes[0];
    unsigned char *p = vis_default_alloc(sizes[0], 64, NULL);
    assert_non_null(p);
    fill_pattern(p, sizes[0], 7);
    for (size_t i = 1; i < n; ++i) {
        unsigned char *q = vis_default_realloc(p, sizes[i - 1], sizes[i]);
        assert_non_null(q);
        assert_int_equal((uintptr_t)q % 64u, 0);
        size_t kept = sizes[i - 1] < sizes[i] ? sizes[i - 1] : sizes[i];
        check_pattern(q, kept, 7);
        fill_pattern(q, sizes[i], 7); /* the whole new size is writable */
        p = q;
    }
    vis_default_free(p, NULL);
    vis_default_free(NULL, NULL);
    unsigned char *big = vis_default_realloc(NULL, 0, (size_t)6 << 20);
    assert_non_null(big);
    assert_int_equal((uintptr_t)big % 64u, 0);
    fill_pattern(big, (size_t)6 << 20, 3);
    check_pattern(big, (size_t)6 << 20, 3);
    vis_default_free(big, NULL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_warm_frames_allocate_nothing),
        cmocka_unit_test(test_all_host_memory_through_the_allocator),
        cmocka_unit_test(test_allocation_failures_are_reported),
        cmocka_unit_test(test_default_allocator_keeps_contents),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
