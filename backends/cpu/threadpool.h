/* threadpool.h — a fixed set of worker threads that run one parallel-for at a time.
 * With 1 thread everything runs on the caller (no thread is created). */
#ifndef VIS_THREADPOOL_H
#define VIS_THREADPOOL_H

#include <stdint.h>

#include "backend.h"

typedef struct vis_pool vis_pool;

/* Runs item(user, i) for i in [0, count), items claimed in order by whichever thread is free
 * (the caller takes part). */
typedef void (*vis_pool_item_fn)(void *user, uint32_t index);

/* threads: total threads including the caller (>= 1); the pool's memory comes from `alloc`,
 * which must outlive it. VIS_ERROR_OUT_OF_MEMORY, or VIS_ERROR_BACKEND when a thread could
 * not be started; *out is set only on VIS_OK. */
vis_status vis_pool_create(uint32_t threads, const vis_allocator *alloc, vis_pool **out);
void vis_pool_destroy(vis_pool *pool);
uint32_t vis_pool_threads(const vis_pool *pool);
/* Not re-entrant: one run at a time per pool. */
void vis_pool_run(vis_pool *pool, uint32_t count, vis_pool_item_fn fn, void *user);

#endif
