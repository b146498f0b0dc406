/* parallel.c — a thread team per call (see parallel.h). Starting one or two threads costs
 * tens of microseconds, against the milliseconds to seconds of the generation and meshing
 * runs that use it, so a persistent pool (and its lifetime in the API) would buy nothing. */
#include "parallel.h"

#include <pthread.h>

typedef struct team {
    vwi_item_fn fn;
    void *ctx;
    uint32_t count;
    atomic_uint next;
    atomic_int *stop;
} team;

typedef struct member {
    team *t;
    uint32_t worker;
} member;

static void drain(team *t, uint32_t worker)
{
    for (;;) {
        if (t->stop && atomic_load_explicit(t->stop, memory_order_relaxed))
            return;
        const uint32_t i = atomic_fetch_add_explicit(&t->next, 1u, memory_order_relaxed);
        if (i >= t->count)
            return;
        t->fn(t->ctx, worker, i);
    }
}

static void *member_main(void *arg)
{
    member *m = arg;
    drain(m->t, m->worker);
    return NULL;
}

uint32_t vwi_threads_for(uint32_t requested, uint64_t items)
{
    uint32_t n = requested ? requested : 1u;
    if (n > VWI_MAX_THREADS)
        n = VWI_MAX_THREADS;
    if (items < n)
        n = items ? (uint32_t)items : 1u;
    return n;
}

void vwi_parallel_run(uint32_t threads, uint32_t count, vwi_item_fn fn, void *ctx, atomic_int *stop)
{
    team t;
    t.fn = fn;
    t.ctx = ctx;
    t.count = count;
    t.stop = stop;
    atomic_init(&t.next, 0u);
    threads = vwi_threads_for(threads, count);
    pthread_t id[VWI_MAX_THREADS];
    member m[VWI_MAX_THREADS];
    uint32_t started = 0;
    /* An explicit stack size: the mesher's scratch (135 KiB for 32-voxel chunks) lives on the
     * worker's stack, more than some C libraries' default thread stack (musl: 128 KiB). */
    pthread_attr_t attr;
    const int have_attr = pthread_attr_init(&attr) == 0;
    if (have_attr)
        pthread_attr_setstacksize(&attr, (size_t)1 << 20);
    /* Worker numbers stay dense (1..started): a thread that fails to start leaves no hole
     * in the per-worker scratch the callers index. */
    for (uint32_t k = 1; k < threads; k++) {
        m[started].t = &t;
        m[started].worker = started + 1;
        if (pthread_create(&id[started], have_attr ? &attr : NULL, member_main, &m[started]) != 0)
            break;
        started++;
    }
    if (have_attr)
        pthread_attr_destroy(&attr);
    drain(&t, 0);
    for (uint32_t k = 0; k < started; k++)
        pthread_join(id[k], NULL);
}
