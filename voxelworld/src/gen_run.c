/* gen_run.c — the generator driver: every chunk column of the world, on a team of workers
 * (parallel.h), each chunk stored straight into the world.
 *
 * Columns are independent (a voxel depends only on the seed, the size and its position), so
 * workers take columns in any order; each writes only its own column buffer and scratch,
 * then the chunks of that column, which no other worker touches. What the chunks share is
 * the world's accounting (counts, bytes, the budget check before a dense array is taken):
 * that part, and only that, runs under a mutex. The world is therefore bit-identical for
 * any thread count, and the budget holds exactly as in a serial run: chunks only ever get
 * added, so a run fails exactly when the finished world would not fit, whatever the order. */
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

#include "generators.h"
#include "parallel.h"

typedef struct run {
    vw_world *w;
    const vwg_generator *g;
    uint8_t *scratch;        /* per worker: column buffer, then the generator's scratch      */
    size_t column_bytes, worker_bytes, stride;
    pthread_mutex_t lock;    /* the world's accounting                                        */
    atomic_int failed;       /* first failure's status (VW_OK while none); stops the team     */
    atomic_uint done;        /* columns finished, for progress                                */
    vwg_progress *progress;  /* worker 0 (the calling thread) only                            */
} run;

/* Stores chunk row cy of a filled column: a uniform chunk as a tag, others as a copy. */
static vw_status store_chunk(run *r, const vwg_column *col, int32_t cx, int32_t cy, int32_t cz)
{
    vw_world *w = r->w;
    const int32_t c = col->c;
    const size_t slice = (size_t)c * (size_t)c;
    const uint8_t v0 = *vwg_at(col, 0, cy * c, 0);
    /* Branch-free, so that the compiler vectorises the scan. */
    uint8_t differ = 0;
    uint32_t solid = 0;
    for (int32_t z = 0; z < c; z++) {
        const uint8_t *p = vwg_at(col, 0, cy * c, z);
        for (size_t i = 0; i < slice; i++) {
            differ |= (uint8_t)(p[i] ^ v0);
            solid += p[i] != 0;
        }
    }
    const int uniform = differ == 0;
    const uint32_t index = vwi_index(w, cx, cy, cz);
    pthread_mutex_lock(&r->lock);
    if (uniform) {
        vwi_chunk_set_uniform(w, index, v0);
        pthread_mutex_unlock(&r->lock);
        return VW_OK;
    }
    uint8_t *dst = vwi_chunk_dense(w, index);
    const vw_status st = dst ? VW_OK : vwi_dense_failure(w);
    pthread_mutex_unlock(&r->lock);
    if (!dst)
        return st;
    for (int32_t z = 0; z < c; z++)
        memcpy(dst + slice * (size_t)z, vwg_at(col, 0, cy * c, z), slice);
    pthread_mutex_lock(&r->lock);
    vwi_chunk_set_solid(w, index, solid);
    pthread_mutex_unlock(&r->lock);
    return VW_OK;
}

static void fail(run *r, vw_status st)
{
    int expected = VW_OK;
    atomic_compare_exchange_strong(&r->failed, &expected, (int)st);
}

static void column_item(void *ctx, uint32_t worker, uint32_t item)
{
    run *r = ctx;
    vw_world *w = r->w;
    const int32_t c = w->chunk_size, nx = w->chunks[0];
    const int32_t cx = (int32_t)(item % (uint32_t)nx), cz = (int32_t)(item / (uint32_t)nx);
    uint8_t *mine = r->scratch + r->stride * worker;
    vwg_column col = {cx * c, cz * c, c, w->size[1], mine};
    memset(col.v, 0, r->column_bytes);
    r->g->fill(r->g->state, r->worker_bytes ? mine + r->column_bytes : NULL, &col);
    for (int32_t cy = 0; cy < w->chunks[1]; cy++) {
        const vw_status st = store_chunk(r, &col, cx, cy, cz);
        if (st != VW_OK) {
            fail(r, st);
            return;
        }
    }
    const uint32_t done = atomic_fetch_add_explicit(&r->done, 1u, memory_order_relaxed) + 1u;
    /* Progress in whole percent, each at most once, from the calling thread only. */
    if (worker == 0 && r->progress->fn) {
        const uint64_t total = (uint64_t)nx * (uint64_t)w->chunks[2];
        const int pct = (int)((uint64_t)done * 100u / total);
        if (pct > r->progress->reported) {
            r->progress->fn("generating", pct / 100.0, r->progress->user);
            r->progress->reported = pct;
        }
    }
}

vw_status vwg_run(vw_world *w, const vwg_generator *g, uint32_t threads, vwg_progress *progress, vw_error *err)
{
    const uint64_t columns = (uint64_t)w->chunks[0] * (uint64_t)w->chunks[2];
    run r;
    memset(&r, 0, sizeof r);
    r.w = w;
    r.g = g;
    r.column_bytes = (size_t)vwg_column_bytes(w->chunk_size, w->size[1]);
    r.worker_bytes = (size_t)g->worker_bytes;
    threads = vwi_threads_for(threads, columns);
    r.stride = (size_t)vwg_run_stride(r.column_bytes, r.worker_bytes, threads);
    r.scratch = malloc(r.stride * threads);
    if (!r.scratch)
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "out of memory for %u generator columns of %zu bytes",
                        (unsigned)threads, r.stride);
    if (pthread_mutex_init(&r.lock, NULL) != 0) {
        free(r.scratch);
        return vwi_fail(err, VW_ERROR_OUT_OF_MEMORY, "cannot create the generator's lock");
    }
    atomic_init(&r.failed, VW_OK);
    atomic_init(&r.done, 0u);
    r.progress = progress;
    if (progress->fn && progress->reported < 0) {
        progress->fn("generating", 0.0, progress->user);
        progress->reported = 0;
    }
    /* Dense chunks from pool blocks (chunk_pool.c) when the world may need two blocks or
     * more; small worlds keep exact per-chunk arrays. Off again afterwards, so that edits
     * never take a new block (their budget checks count single arrays). */
    w->pool_on = (uint64_t)w->chunk_count * vwi_chunk_volume(w) >= 2 * (uint64_t)VWI_POOL_BLOCK;
    vwi_parallel_run(threads, (uint32_t)columns, column_item, &r, &r.failed);
    w->pool_on = 0;
    const vw_status st = (vw_status)atomic_load(&r.failed);
    /* The last columns may have finished on other threads. */
    if (st == VW_OK && progress->fn && progress->reported < 100) {
        progress->fn("generating", 1.0, progress->user);
        progress->reported = 100;
    }
    pthread_mutex_destroy(&r.lock);
    free(r.scratch);
    return st;
}
