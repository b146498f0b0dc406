/* threadpool.c — persistent workers woken per pass; items handed out by an atomic counter
 * so that fast threads take more tiles (dynamic load balance, no per-pass allocation).
 *
 * Waiting spins for a short while before it sleeps, on both sides: a worker that has just
 * finished a run, and the caller waiting for the workers to finish. A sleeping thread is woken
 * through the kernel, and on a virtual machine whose idle virtual CPU has halted that took
 * 80-100 us per run (docs/server.md, "One pool run per batch, one set of threads"), ten times
 * the work of a run of small items. A run that follows within the spin finds its workers
 * awake; one that does not costs each worker SPIN_NS of CPU time after the last run. */
#if !defined(_POSIX_C_SOURCE) || _POSIX_C_SOURCE < 199309L
#undef _POSIX_C_SOURCE
#define _POSIX_C_SOURCE 199309L /* clock_gettime */
#endif
#include "threadpool.h"

#include <pthread.h>
#include <stdatomic.h>
#include <time.h>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define CPU_RELAX() _mm_pause()
#else
#define CPU_RELAX() ((void)0)
#endif

#ifndef SPIN_NS
#define SPIN_NS 100000 /* how long a waiting thread spins before it sleeps */
#endif

struct vis_pool {
    const vis_allocator *alloc;
    uint32_t threads;
    pthread_t *workers;
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    atomic_ullong generation; /* bumped per run (under lock); workers wait for a new one */
    int quit;
    atomic_uint running;      /* workers still inside the current run (changed under lock) */
    /* current job */
    vis_pool_item_fn fn;
    void *user;
    uint32_t count;
    atomic_uint next;
};

static void drain(vis_pool *p)
{
    for (;;) {
        uint32_t i = atomic_fetch_add_explicit(&p->next, 1u, memory_order_relaxed);
        if (i >= p->count)
            return;
        p->fn(p->user, i);
    }
}

static uint64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec;
}

/* One step of a wait that spins: pauses, and says whether SPIN_NS have passed since `start`
 * (read every 64 steps). */
static int spin_over(uint64_t start, uint32_t step)
{
    CPU_RELAX();
    return step % 64u == 0 && now_ns() - start > SPIN_NS;
}

static void *worker_main(void *arg)
{
    vis_pool *p = arg;
    unsigned long long seen = 0;
    for (;;) {
        /* The next run is usually near: spin, then sleep until it comes. */
        uint64_t start = now_ns();
        for (uint32_t i = 1; atomic_load_explicit(&p->generation, memory_order_acquire) == seen; ++i)
            if (spin_over(start, i))
                break;
        pthread_mutex_lock(&p->lock);
        while (!p->quit && atomic_load(&p->generation) == seen)
            pthread_cond_wait(&p->wake, &p->lock);
        if (p->quit)
            break;
        seen = atomic_load(&p->generation);
        pthread_mutex_unlock(&p->lock);
        drain(p);
        pthread_mutex_lock(&p->lock);
        if (atomic_fetch_sub(&p->running, 1u) == 1u)
            pthread_cond_signal(&p->done);
        pthread_mutex_unlock(&p->lock);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

vis_status vis_pool_create(uint32_t threads, const vis_allocator *alloc, vis_pool **out)
{
    if (threads < 1)
        threads = 1;
    vis_pool *p = vis_host_calloc(alloc, 1, sizeof *p);
    if (!p)
        return VIS_ERROR_OUT_OF_MEMORY;
    p->alloc = alloc;
    p->threads = threads;
    atomic_init(&p->next, 0u);
    atomic_init(&p->generation, 0u);
    atomic_init(&p->running, 0u);
    if (pthread_mutex_init(&p->lock, NULL) != 0) {
        vis_host_free(alloc, p);
        return VIS_ERROR_BACKEND;
    }
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    if (threads > 1) {
        p->workers = vis_host_calloc(alloc, threads - 1, sizeof *p->workers);
        if (!p->workers) {
            vis_pool_destroy(p);
            return VIS_ERROR_OUT_OF_MEMORY;
        }
        for (uint32_t i = 0; i + 1 < threads; ++i) {
            if (pthread_create(&p->workers[i], NULL, worker_main, p) != 0) {
                p->threads = i + 1; /* destroy joins only the ones started */
                vis_pool_destroy(p);
                return VIS_ERROR_BACKEND;
            }
        }
    }
    *out = p;
    return VIS_OK;
}

void vis_pool_destroy(vis_pool *p)
{
    if (!p)
        return;
    if (p->workers) {
        pthread_mutex_lock(&p->lock);
        p->quit = 1;
        pthread_cond_broadcast(&p->wake);
        pthread_mutex_unlock(&p->lock);
        for (uint32_t i = 0; i + 1 < p->threads; ++i)
            pthread_join(p->workers[i], NULL);
        vis_host_free(p->alloc, p->workers);
    }
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    pthread_mutex_destroy(&p->lock);
    vis_host_free(p->alloc, p);
}

uint32_t vis_pool_threads(const vis_pool *p) { return p->threads; }

void vis_pool_run(vis_pool *p, uint32_t count, vis_pool_item_fn fn, void *user)
{
    if (p->threads == 1 || count <= 1) {
        for (uint32_t i = 0; i < count; ++i)
            fn(user, i);
        return;
    }
    pthread_mutex_lock(&p->lock);
    p->fn = fn;
    p->user = user;
    p->count = count;
    atomic_store_explicit(&p->next, 0u, memory_order_relaxed);
    atomic_store(&p->running, p->threads - 1);
    atomic_fetch_add(&p->generation, 1u); /* after the job: a spinning worker reads it then */
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    drain(p);
    /* The workers finish their last items about when the caller does: spin, then sleep. */
    uint64_t start = now_ns();
    for (uint32_t i = 1; atomic_load_explicit(&p->running, memory_order_acquire) != 0u; ++i)
        if (spin_over(start, i))
            break;
    pthread_mutex_lock(&p->lock);
    while (atomic_load(&p->running) != 0u)
        pthread_cond_wait(&p->done, &p->lock);
    pthread_mutex_unlock(&p->lock);
}
