/* threadpool.c — persistent workers woken per pass; items handed out by an atomic counter
 * so that fast threads take more tiles (dynamic load balance, no per-pass allocation). */
#include "threadpool.h"

#include <pthread.h>
#include <stdatomic.h>

struct vis_pool {
    const vis_allocator *alloc;
    uint32_t threads;
    pthread_t *workers;
    pthread_mutex_t lock;
    pthread_cond_t wake, done;
    uint64_t generation; /* bumped per run; workers wait for a new one */
    int quit;
    uint32_t running;    /* workers still inside the current run */
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

static void *worker_main(void *arg)
{
    vis_pool *p = arg;
    uint64_t seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (!p->quit && p->generation == seen)
            pthread_cond_wait(&p->wake, &p->lock);
        if (p->quit)
            break;
        seen = p->generation;
        pthread_mutex_unlock(&p->lock);
        drain(p);
        pthread_mutex_lock(&p->lock);
        if (--p->running == 0)
            pthread_cond_signal(&p->done);
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
    p->running = p->threads - 1;
    ++p->generation;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->lock);
    drain(p);
    pthread_mutex_lock(&p->lock);
    while (p->running)
        pthread_cond_wait(&p->done, &p->lock);
    pthread_mutex_unlock(&p->lock);
}
