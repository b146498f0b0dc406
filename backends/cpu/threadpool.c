/* threadpool.c — persistent workers woken per pass; items handed out by an atomic counter
 * so that fast threads take more tiles (dynamic load balance, no per-pass allocation).
 *
 * Waiting spins for a short while before it sleeps, on both sides: a worker that has just
 * finished a run, and the caller waiting for the workers to finish. A sleeping thread is woken
 * through the kernel, and on a virtual machine whose idle virtual CPU has halted that took
 * 80-100 us per run (docs/server.md, "One pool run per batch, one set of threads"), ten times
 * the work of a run of small items. A run that follows within the spin finds its workers
 * awake; one that does not costs each worker SPIN_NS of CPU time after the last run.
 *
 * The caller takes part, and once it has run out of items it closes the run: a worker that
 * had not joined by then stays out of it, so the caller waits only for the workers that are
 * working, never for one still being woken or not yet scheduled (a small pass on a busy or
 * virtual CPU would otherwise wait for a thread that has nothing left to do). */
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

#define RUN_CLOSED 0x80000000ull
#define RUN_JOINED 0x7FFFFFFFull

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
    /* The current run: the generation's low 32 bits above RUN_CLOSED and the number of
     * workers that joined it; a worker joins only while the run is open. */
    atomic_ullong run;
    atomic_uint finished;     /* workers of the current run that have finished it (changed
                                 under lock, for the caller's sleep) */
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

/* Joins run `gen` if it is still open (the caller has not run out of items). */
static int join_run(vis_pool *p, unsigned long long gen)
{
    unsigned long long r = atomic_load_explicit(&p->run, memory_order_acquire);
    for (;;) {
        if ((r >> 32) != (gen & 0xFFFFFFFFull) || (r & RUN_CLOSED))
            return 0;
        if (atomic_compare_exchange_weak_explicit(&p->run, &r, r + 1u, memory_order_acq_rel, memory_order_acquire))
            return 1;
    }
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
        if (!join_run(p, seen))
            continue; /* the caller finished without this worker */
        drain(p);
        pthread_mutex_lock(&p->lock);
        atomic_fetch_add(&p->finished, 1u);
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
    atomic_init(&p->run, RUN_CLOSED);
    atomic_init(&p->finished, 0u);
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
    atomic_store(&p->finished, 0u);
    atomic_store_explicit(&p->next, 0u, memory_order_relaxed);
    unsigned long long gen = atomic_load(&p->generation) + 1u;
    atomic_store(&p->run, (gen & 0xFFFFFFFFull) << 32); /* open, nobody joined */
    atomic_store(&p->generation, gen); /* after the job: a spinning worker reads it then */
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    drain(p);
    /* Close the run, then wait for the workers that joined it: they finish their last items
     * about when the caller does, so spin, then sleep. */
    uint32_t joined = (uint32_t)(atomic_fetch_or(&p->run, RUN_CLOSED) & RUN_JOINED);
    uint64_t start = now_ns();
    for (uint32_t i = 1; atomic_load_explicit(&p->finished, memory_order_acquire) != joined; ++i)
        if (spin_over(start, i))
            break;
    pthread_mutex_lock(&p->lock);
    while (atomic_load(&p->finished) != joined)
        pthread_cond_wait(&p->done, &p->lock);
    pthread_mutex_unlock(&p->lock);
}
