/* parallel.h — the small thread team behind voxelworld's `threads` options (internal).
 *
 * vwi_parallel_run(threads, count, fn, ctx) calls fn(ctx, worker, i) once for every i in
 * [0, count), on `threads` workers: the calling thread (worker 0) and threads - 1 threads
 * started for the call and joined before it returns. Items are handed out one at a time by
 * an atomic counter, so faster workers take more (dynamic balance); an item's result must
 * therefore not depend on which worker ran it or in which order — every caller writes each
 * item's output to its own slot, which is what makes the results bit-identical for any
 * thread count. `worker` (< threads) indexes per-worker scratch.
 *
 * A thread that cannot be started is not an error: its share goes to the others (at worst
 * the caller does everything), so the call always completes. No state outlives the call:
 * no pool, no globals. */
#ifndef VOXELWORLD_PARALLEL_H
#define VOXELWORLD_PARALLEL_H

#include <stdatomic.h>
#include <stdint.h>

/* At most this many workers per call, whatever the caller asks (memory per worker is
 * charged to budgets, so the cap also bounds that). */
#define VWI_MAX_THREADS 64u

typedef void (*vwi_item_fn)(void *ctx, uint32_t worker, uint32_t item);

/* Clamps a requested thread count: 0 and 1 mean serial; never more than the items or
 * VWI_MAX_THREADS. */
uint32_t vwi_threads_for(uint32_t requested, uint64_t items);

/* Runs every item; `stop` (may be NULL) is polled before each item: once it reads non-zero,
 * workers take no new items (for a first failure to end the run early). */
void vwi_parallel_run(uint32_t threads, uint32_t count, vwi_item_fn fn, void *ctx, atomic_int *stop);

#endif
