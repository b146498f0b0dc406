/* mesh_chunks.c — vw_mesh_chunks: many chunks meshed on a team of threads (parallel.h).
 *
 * Each chunk's mesh goes to its own caller-owned vw_mesh and depends only on the world, so
 * the output is the serial one whatever the thread count or the order the workers take
 * chunks in. The world is only read (the mesher's contract: several readers at once). */
#include "parallel.h"
#include "vw_internal.h"

typedef struct batch {
    const vw_world *w;
    const uint32_t *chunks;
    vw_mesh *meshes;
    atomic_int failed;       /* any failure so far: stops the team early                     */
} batch;

static void mesh_item(void *ctx, uint32_t worker, uint32_t i)
{
    (void)worker;
    batch *b = ctx;
    const vw_status st = vw_mesh_chunk(b->w, b->chunks[i], &b->meshes[i]);
    if (st != VW_OK)
        atomic_store(&b->failed, 1);
}

vw_status vw_mesh_chunks(const vw_world *w, const uint32_t *chunks, size_t count, vw_mesh *meshes, uint32_t threads)
{
    if (!w || (count && (!chunks || !meshes)) || count > UINT32_MAX)
        return VW_ERROR_INVALID_ARGUMENT;
    /* Which failure to report must not depend on the threads: check the indices first (the
     * lowest bad one), and re-run a failed batch serially to find the lowest failing chunk. */
    for (size_t i = 0; i < count; i++)
        if (chunks[i] >= w->chunk_count)
            return VW_ERROR_INVALID_ARGUMENT;
    batch b;
    b.w = w;
    b.chunks = chunks;
    b.meshes = meshes;
    atomic_init(&b.failed, 0);
    vwi_parallel_run(vwi_threads_for(threads, count), (uint32_t)count, mesh_item, &b, &b.failed);
    if (!atomic_load(&b.failed))
        return VW_OK;
    for (size_t i = 0; i < count; i++) {
        const vw_status st = vw_mesh_chunk(w, chunks[i], &meshes[i]);
        if (st != VW_OK)
            return st;
    }
    return VW_OK;
}
