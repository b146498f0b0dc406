/*
 * test_threads.c — libvis from several threads: misuse of one context is detected
 * (VIS_ERROR_BUSY), a context's destroy takes its live scenes and culls with it, one scene
 * is traced through several contexts while another thread edits and commits it (traces see
 * only committed states), and the CPU backend runs on a caller's job system.
 *
 * Oracles: buffers traced single-threaded, on the default pool, from scenes built directly
 * in each known state (no commit, no sharing); every threaded result must equal one of them
 * bit for bit. Run under ThreadSanitizer by `make test-tsan`.
 */
#define _POSIX_C_SOURCE 200112L

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"

#define W 96u
#define H 64u
#define PIX (W * H)

/* ---- the scene in two known states --------------------------------------------------- */

static void box_quads(vis_quad q[6], const float lo[3], const float hi[3])
{
    for (uint32_t a = 0; a < 3; ++a) {
        uint32_t u = (a + 1) % 3, v = (a + 2) % 3;
        for (int side = 0; side < 2; ++side) {
            vis_quad *f = &q[a * 2 + (uint32_t)side];
            memset(f, 0, sizeof *f);
            f->axis = a;
            f->plane = side ? hi[a] : lo[a];
            f->u0 = lo[u];
            f->u1 = hi[u];
            f->v0 = lo[v];
            f->v1 = hi[v];
        }
    }
}

static vis_status set_box(vis_scene *s, uint32_t id, float x0, float y0, float z0, float x1, float y1, float z1)
{
    vis_quad q[6];
    const float lo[3] = {x0, y0, z0}, hi[3] = {x1, y1, z1};
    box_quads(q, lo, hi);
    vis_mesh m = {q, 6, NULL, 0};
    return vis_scene_set_object(s, id, &m);
}

/* State 0: a floor (1), a tall box (2), a small box (3). State 1: the tall box moved and
 * widened, the small box removed, a new box (4) in front. Several edits per commit, so a
 * half-applied commit shows as neither state. */
static void apply_state(vis_scene *s, int state)
{
    assert_int_equal(set_box(s, 1, 0, 0, 0, 64, 2, 64), VIS_OK);
    if (state == 0) {
        (void)vis_scene_remove_object(s, 4); /* NOT_FOUND the first time */
        assert_int_equal(set_box(s, 2, 20, 2, 20, 28, 30, 28), VIS_OK);
        assert_int_equal(set_box(s, 3, 40, 2, 30, 46, 10, 36), VIS_OK);
    } else {
        assert_int_equal(set_box(s, 2, 30, 2, 16, 44, 24, 24), VIS_OK);
        vis_status r = vis_scene_remove_object(s, 3); /* absent when built directly */
        assert_true(r == VIS_OK || r == VIS_ERROR_NOT_FOUND);
        assert_int_equal(set_box(s, 4, 8, 2, 40, 16, 12, 48), VIS_OK);
    }
}

static vis_scene_desc scene_desc(vis_commit_mode mode)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = 64.0f;
    d.cell_size = 8.0f;
    d.commit = mode;
    return d;
}

static vis_camera camera(void)
{
    vis_camera c;
    memset(&c, 0, sizeof c);
    c.eye[0] = 32.0;
    c.eye[1] = 40.0;
    c.eye[2] = 90.0;
    c.target[0] = 32.0;
    c.target[1] = 8.0;
    c.target[2] = 30.0;
    c.fovy_deg = 60.0;
    c.near_dist = 0.05;
    return c;
}

static vis_trace_desc trace_desc(vis_traversal t)
{
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = W;
    d.height = H;
    d.traversal = t;
    return d;
}

/* The oracle: state `state` built directly into a fresh scene, traced once on one thread. */
static void reference(int state, vis_traversal t, uint32_t *ids, float *depth)
{
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene_desc sd = scene_desc(VIS_COMMIT_AUTO);
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &s), VIS_OK);
    apply_state(s, state);
    vis_camera c = camera();
    vis_trace_desc td = trace_desc(t);
    assert_int_equal(vis_trace(ctx, s, &c, &td, ids, PIX, depth, depth ? PIX : 0), VIS_OK);
    vis_scene_destroy(s);
    assert_int_equal(vis_context_destroy(ctx), VIS_OK);
}

/* ---- 1. two threads on one context --------------------------------------------------- */

typedef struct busy_arg {
    vis_context *ctx;
    vis_scene *scene;
    const uint32_t *ref;
    atomic_int *start;
    int busy, ok, wrong;
    vis_status last_wrong;
} busy_arg;

static void *busy_thread(void *p)
{
    busy_arg *a = p;
    uint32_t *ids = malloc(PIX * sizeof *ids);
    vis_camera c = camera();
    vis_trace_desc td = trace_desc(VIS_TRAVERSAL_AUTO);
    while (!atomic_load(a->start)) {
    }
    for (int i = 0; i < (vt_small() ? 60 : 300); ++i) {
        memset(ids, 0xAB, PIX * sizeof *ids);
        vis_status st = vis_trace(a->ctx, a->scene, &c, &td, ids, PIX, NULL, 0);
        if (st == VIS_ERROR_BUSY)
            ++a->busy;
        else if (st == VIS_OK && memcmp(ids, a->ref, PIX * sizeof *ids) == 0)
            ++a->ok;
        else {
            ++a->wrong;
            a->last_wrong = st;
        }
    }
    free(ids);
    return NULL;
}

/* Before the busy flag this deadlocked in the pool or returned the other thread's buffer. */
static void test_two_threads_one_context(void **state)
{
    (void)state;
    uint32_t *ref = malloc(PIX * sizeof *ref);
    reference(0, VIS_TRAVERSAL_AUTO, ref, NULL);
    vis_context *ctx = make_cpu_ctx(4);
    vis_scene_desc sd = scene_desc(VIS_COMMIT_AUTO);
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &sd, &s), VIS_OK);
    apply_state(s, 0);
    atomic_int start;
    atomic_init(&start, 0);
    busy_arg a[2];
    pthread_t t[2];
    for (int i = 0; i < 2; ++i) {
        a[i] = (busy_arg){ctx, s, ref, &start, 0, 0, 0, VIS_OK};
        assert_int_equal(pthread_create(&t[i], NULL, busy_thread, &a[i]), 0);
    }
    atomic_store(&start, 1);
    for (int i = 0; i < 2; ++i)
        pthread_join(t[i], NULL);
    for (int i = 0; i < 2; ++i) {
        print_message("thread %d: %d ok, %d busy, %d wrong (last %d)\n", i, a[i].ok, a[i].busy, a[i].wrong,
                      (int)a[i].last_wrong);
        assert_int_equal(a[i].wrong, 0);
        assert_true(a[i].ok > 0 || a[i].busy > 0);
    }
    vis_scene_destroy(s);
    assert_int_equal(vis_context_destroy(ctx), VIS_OK);
    free(ref);
}

/* Deterministic: the log callback runs inside a failing call, with the context taken. */
typedef struct reenter {
    vis_context *ctx;
    vis_scene *scene;
    vis_status inner;
    int calls, armed;
} reenter;

static void reenter_log(vis_log_level level, const char *message, void *user)
{
    (void)level, (void)message;
    reenter *r = user;
    if (!r->armed || r->calls++)
        return;
    uint32_t ids[4];
    vis_camera c = camera();
    vis_trace_desc td = trace_desc(VIS_TRAVERSAL_AUTO);
    td.width = td.height = 2;
    r->inner = vis_trace(r->ctx, r->scene, &c, &td, ids, 4, NULL, 0);
}

static void test_reentry_is_busy(void **state)
{
    (void)state;
    reenter r = {NULL, NULL, VIS_OK, 0, 0};
    vis_context_desc d;
    vis_context_desc_defaults(&d);
    d.backend = VIS_BACKEND_CPU;
    d.threads = 2;
    d.log = reenter_log;
    d.log_user = &r;
    assert_int_equal(vis_context_create(&d, &r.ctx), VIS_OK);
    vis_scene_desc sd = scene_desc(VIS_COMMIT_AUTO);
    assert_int_equal(vis_scene_create(r.ctx, &sd, &r.scene), VIS_OK);
    apply_state(r.scene, 0);
    r.armed = 1;
    vis_camera bad = camera();
    bad.fovy_deg = 200.0; /* fails validation: the log callback runs inside vis_trace */
    uint32_t ids[PIX];
    vis_trace_desc td = trace_desc(VIS_TRAVERSAL_AUTO);
    assert_int_equal(vis_trace(r.ctx, r.scene, &bad, &td, ids, PIX, NULL, 0), VIS_ERROR_INVALID_ARGUMENT);
    assert_true(r.calls >= 1);
    assert_int_equal(r.inner, VIS_ERROR_BUSY);
    r.armed = 0;
    assert_string_equal(vis_status_string(VIS_ERROR_BUSY), "context busy on another thread");
    /* After the call the context is free again. */
    vis_camera c = camera();
    assert_int_equal(vis_trace(r.ctx, r.scene, &c, &td, ids, PIX, NULL, 0), VIS_OK);
    assert_int_equal(vis_context_destroy(r.ctx), VIS_OK); /* takes the scene with it */
}

/* ---- 2. destroying a context with live scenes ---------------------------------------- */

typedef struct counting {
    atomic_long live;
} counting;

static void *count_alloc(size_t size, size_t align, void *user)
{
    void *p = NULL;
    if (posix_memalign(&p, align < sizeof(void *) ? sizeof(void *) : align, size ? size : 1) != 0)
        return NULL;
    atomic_fetch_add(&((counting *)user)->live, 1);
    return p;
}

static void count_free(void *ptr, void *user)
{
    atomic_fetch_sub(&((counting *)user)->live, 1);
    free(ptr);
}

static void test_destroy_with_live_objects(void **state)
{
    (void)state;
    counting cnt;
    atomic_init(&cnt.live, 0);
    vis_context_desc d;
    vis_context_desc_defaults(&d);
    d.backend = VIS_BACKEND_CPU;
    d.threads = 2;
    d.allocator = (vis_allocator){count_alloc, count_free, &cnt};
    vis_context *owner = NULL, *other = NULL;
    assert_int_equal(vis_context_create(&d, &owner), VIS_OK);
    assert_int_equal(vis_context_create(&d, &other), VIS_OK);
    vis_scene_desc sd = scene_desc(VIS_COMMIT_AUTO);
    vis_scene *s1 = NULL, *s2 = NULL;
    assert_int_equal(vis_scene_create(owner, &sd, &s1), VIS_OK);
    assert_int_equal(vis_scene_create(owner, &sd, &s2), VIS_OK);
    apply_state(s1, 0);
    apply_state(s2, 1);
    vis_zcull *zc = NULL;
    assert_int_equal(vis_zcull_create(owner, &zc), VIS_OK);
    vis_camera c = camera();
    vis_draw_entry e[8];
    size_t n = 0;
    assert_int_equal(vis_zcull_run(zc, s1, &c, NULL, e, 8, &n, NULL), VIS_OK);

    /* `other` traces s1: it now holds a copy of a scene it does not own. */
    uint32_t *ids = malloc(PIX * sizeof *ids), *ref = malloc(PIX * sizeof *ref);
    vis_trace_desc td = trace_desc(VIS_TRAVERSAL_AUTO);
    assert_int_equal(vis_trace(owner, s1, &c, &td, ref, PIX, NULL, 0), VIS_OK);
    assert_int_equal(vis_trace(other, s1, &c, &td, ids, PIX, NULL, 0), VIS_OK);
    assert_memory_equal(ids, ref, PIX * sizeof *ids);
    assert_int_equal(vis_context_destroy(other), VIS_ERROR_BUSY);
    assert_non_null(strstr(vis_context_last_error(other), "destroy those scenes first"));

    /* The owner goes first, with both scenes and the cull; its scenes release other's copy. */
    assert_int_equal(vis_context_destroy(owner), VIS_OK);
    assert_int_equal(vis_context_destroy(other), VIS_OK);
    assert_int_equal(atomic_load(&cnt.live), 0); /* every allocation given back */
    free(ids);
    free(ref);
}

/* ---- 3. one scene, four tracing threads, one editor ---------------------------------- */

typedef struct shared_arg {
    vis_scene *scene;
    const uint32_t *ref[2];
    const float *ref_depth[2];
    vis_traversal traversal;
    atomic_int *stop;
    int seen[2], wrong;
    vis_status fail, destroy; /* cmocka asserts only on the main thread */
} shared_arg;

static void *tracer(void *p)
{
    shared_arg *a = p;
    vis_context *ctx = make_cpu_ctx(2);
    uint32_t *ids = malloc(PIX * sizeof *ids);
    float *depth = malloc(PIX * sizeof *depth);
    vis_camera c = camera();
    vis_trace_desc td = trace_desc(a->traversal);
    int rounds = 0;
    while (!atomic_load(a->stop) || rounds < 4) {
        vis_status st = vis_trace(ctx, a->scene, &c, &td, ids, PIX, depth, PIX);
        if (st != VIS_OK) {
            a->fail = st;
            break;
        }
        int k = memcmp(ids, a->ref[0], PIX * sizeof *ids) == 0 && memcmp(depth, a->ref_depth[0], PIX * sizeof *depth) == 0
                    ? 0
                : memcmp(ids, a->ref[1], PIX * sizeof *ids) == 0 && memcmp(depth, a->ref_depth[1], PIX * sizeof *depth) == 0
                    ? 1
                    : -1;
        if (k < 0)
            ++a->wrong;
        else
            ++a->seen[k];
        ++rounds;
    }
    free(ids);
    free(depth);
    /* The scene is still alive: this context holds a copy, so it cannot go yet. */
    a->destroy = vis_context_destroy(ctx);
    return ctx;
}

static void shared_scene_case(vis_traversal traversal)
{
    uint32_t *ref[2];
    float *ref_depth[2];
    for (int k = 0; k < 2; ++k) {
        ref[k] = malloc(PIX * sizeof *ref[k]);
        ref_depth[k] = malloc(PIX * sizeof *ref_depth[k]);
        reference(k, traversal, ref[k], ref_depth[k]);
    }
    assert_memory_not_equal(ref[0], ref[1], PIX * sizeof *ref[0]);

    vis_context *editor = make_cpu_ctx(1);
    vis_scene_desc sd = scene_desc(VIS_COMMIT_EXPLICIT);
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(editor, &sd, &s), VIS_OK);
    apply_state(s, 0);
    assert_int_equal(vis_scene_commit(s), VIS_OK);

    atomic_int stop;
    atomic_init(&stop, 0);
    enum { TRACERS = 4 };
    shared_arg a[TRACERS];
    pthread_t t[TRACERS];
    for (int i = 0; i < TRACERS; ++i) {
        a[i] = (shared_arg){s, {ref[0], ref[1]}, {ref_depth[0], ref_depth[1]}, traversal, &stop, {0, 0}, 0, VIS_OK, VIS_OK};
        assert_int_equal(pthread_create(&t[i], NULL, tracer, &a[i]), 0);
    }
    /* The editor stages a whole state, checks that its own traces still see the committed
     * one, commits, and checks again. */
    uint32_t *ids = malloc(PIX * sizeof *ids);
    vis_camera c = camera();
    vis_trace_desc td = trace_desc(traversal);
    int state = 0;
    for (int round = 0; round < (vt_small() ? 8 : 40); ++round) {
        int next = 1 - state;
        apply_state(s, next);
        assert_int_equal(vis_trace(editor, s, &c, &td, ids, PIX, NULL, 0), VIS_OK);
        assert_memory_equal(ids, ref[state], PIX * sizeof *ids); /* staged, not visible */
        assert_int_equal(vis_scene_commit(s), VIS_OK);
        state = next;
        assert_int_equal(vis_trace(editor, s, &c, &td, ids, PIX, NULL, 0), VIS_OK);
        assert_memory_equal(ids, ref[state], PIX * sizeof *ids);
        sched_yield();
    }
    atomic_store(&stop, 1);
    vis_context *ctxs[TRACERS];
    for (int i = 0; i < TRACERS; ++i)
        pthread_join(t[i], (void **)&ctxs[i]);
    for (int i = 0; i < TRACERS; ++i) {
        assert_int_equal(a[i].fail, VIS_OK);
        assert_int_equal(a[i].destroy, VIS_ERROR_BUSY);
        assert_int_equal(a[i].wrong, 0);
        assert_true(a[i].seen[0] + a[i].seen[1] >= 4);
    }
    /* remove_object of an ID absent from the staged state is NOT_FOUND; staging a removal of
     * an object only staged works. */
    assert_int_equal(vis_scene_remove_object(s, 77), VIS_ERROR_NOT_FOUND);
    assert_int_equal(set_box(s, 77, 1, 3, 1, 2, 4, 2), VIS_OK);
    assert_int_equal(vis_scene_remove_object(s, 77), VIS_OK);
    assert_int_equal(vis_scene_commit(s), VIS_OK);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(s, &info), VIS_OK);
    assert_int_equal(info.objects, 3);

    vis_scene_destroy(s); /* releases the four tracers' copies */
    for (int i = 0; i < TRACERS; ++i)
        assert_int_equal(vis_context_destroy(ctxs[i]), VIS_OK);
    assert_int_equal(vis_context_destroy(editor), VIS_OK);
    free(ids);
    for (int k = 0; k < 2; ++k) {
        free(ref[k]);
        free(ref_depth[k]);
    }
}

static void test_shared_scene_packet(void **state)
{
    (void)state;
    shared_scene_case(VIS_TRAVERSAL_PACKET);
}

static void test_shared_scene_stack(void **state)
{
    (void)state;
    shared_scene_case(VIS_TRAVERSAL_STACK);
}

/* ---- 4. the CPU backend on the caller's job system ----------------------------------- */

typedef struct jobs {
    atomic_uint calls;
    atomic_uint items;
    uint32_t workers; /* 0: run on the caller; N: N threads started per call */
} jobs;

typedef struct jobs_run {
    uint32_t count;
    void (*job)(uint32_t, void *);
    void *arg;
    atomic_uint next;
    atomic_uint *items;
} jobs_run;

static void *jobs_worker(void *p)
{
    jobs_run *r = p;
    for (uint32_t i; (i = atomic_fetch_add(&r->next, 1u)) < r->count;) {
        r->job(i, r->arg);
        atomic_fetch_add(r->items, 1u);
    }
    return NULL;
}

static void my_parallel_for(uint32_t count, void (*job)(uint32_t index, void *arg), void *arg, void *user)
{
    jobs *j = user;
    atomic_fetch_add(&j->calls, 1u);
    jobs_run r = {count, job, arg, 0, &j->items};
    atomic_init(&r.next, 0u);
    pthread_t t[4];
    uint32_t n = j->workers < 4 ? j->workers : 4;
    for (uint32_t i = 0; i < n; ++i)
        assert_int_equal(pthread_create(&t[i], NULL, jobs_worker, &r), 0);
    jobs_worker(&r); /* the caller takes part */
    for (uint32_t i = 0; i < n; ++i)
        pthread_join(t[i], NULL);
}

static void test_parallel_for_hook(void **state)
{
    (void)state;
    const vis_traversal methods[] = {VIS_TRAVERSAL_PACKET, VIS_TRAVERSAL_STACK, VIS_TRAVERSAL_ROPES};
    for (uint32_t workers = 0; workers <= 3; workers += 3) {
        jobs j;
        atomic_init(&j.calls, 0u);
        atomic_init(&j.items, 0u);
        j.workers = workers;
        vis_context_desc d;
        vis_context_desc_defaults(&d);
        d.backend = VIS_BACKEND_CPU;
        d.threads = 8; /* ignored with the hook */
        d.parallel_for = my_parallel_for;
        d.parallel_for_user = &j;
        vis_context *ctx = NULL;
        assert_int_equal(vis_context_create(&d, &ctx), VIS_OK);
        vis_backend_info info;
        assert_int_equal(vis_context_backend(ctx, &info), VIS_OK);
        assert_int_equal(info.threads, 0);
        vis_scene_desc sd = scene_desc(VIS_COMMIT_AUTO);
        vis_scene *s = NULL;
        assert_int_equal(vis_scene_create(ctx, &sd, &s), VIS_OK);
        apply_state(s, 1);
        uint32_t *ids = malloc(PIX * sizeof *ids), *ref = malloc(PIX * sizeof *ref);
        float *depth = malloc(PIX * sizeof *depth), *ref_depth = malloc(PIX * sizeof *ref_depth);
        vis_camera c = camera();
        /* vis_scene_prepare builds the scene's voxel labels through the hook (once per 1024
         * leaves), as the first pass would; every pass after it makes one call. */
        unsigned first = atomic_load(&j.calls);
        assert_int_equal(vis_scene_prepare(ctx, s), VIS_OK);
        assert_true(atomic_load(&j.calls) >= first + 1);
        for (size_t m = 0; m < sizeof methods / sizeof methods[0]; ++m) {
            reference(1, methods[m], ref, ref_depth);
            vis_trace_desc td = trace_desc(methods[m]);
            unsigned before = atomic_load(&j.calls);
            assert_int_equal(vis_trace(ctx, s, &c, &td, ids, PIX, depth, PIX), VIS_OK);
            assert_int_equal(atomic_load(&j.calls), before + 1);
            assert_memory_equal(ids, ref, PIX * sizeof *ids);
            assert_memory_equal(depth, ref_depth, PIX * sizeof *depth);
        }
        assert_true(atomic_load(&j.items) > 3);
        /* A context tracing this scene as another's copy (made whole at every sync after an
         * edit) keeps no voxel labels: its first pass is one call, as every later one. */
        vis_context *owner = NULL;
        vis_context_desc od;
        vis_context_desc_defaults(&od);
        od.backend = VIS_BACKEND_CPU;
        od.threads = 1;
        assert_int_equal(vis_context_create(&od, &owner), VIS_OK);
        vis_scene *os = NULL;
        assert_int_equal(vis_scene_create(owner, &sd, &os), VIS_OK);
        apply_state(os, 1);
        vis_trace_desc pk = trace_desc(VIS_TRAVERSAL_PACKET);
        unsigned before = atomic_load(&j.calls);
        assert_int_equal(vis_trace(ctx, os, &c, &pk, ids, PIX, depth, PIX), VIS_OK);
        assert_int_equal(atomic_load(&j.calls), before + 1);
        reference(1, VIS_TRAVERSAL_PACKET, ref, ref_depth);
        assert_memory_equal(ids, ref, PIX * sizeof *ids);
        vis_scene_destroy(os);
        assert_int_equal(vis_context_destroy(owner), VIS_OK);
        vis_scene_destroy(s);
        assert_int_equal(vis_context_destroy(ctx), VIS_OK);
        free(ids);
        free(ref);
        free(depth);
        free(ref_depth);
    }
}

int main(void)
{
    alarm(300); /* a deadlock fails the test instead of hanging CTest */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_reentry_is_busy),
        cmocka_unit_test(test_two_threads_one_context),
        cmocka_unit_test(test_destroy_with_live_objects),
        cmocka_unit_test(test_shared_scene_packet),
        cmocka_unit_test(test_shared_scene_stack),
        cmocka_unit_test(test_parallel_for_hook),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
