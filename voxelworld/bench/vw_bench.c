/* vw_bench.c — how long a world takes to generate and to mesh, and a hash of its meshes.
 *
 *   vw_bench SPEC [THREADS]      e.g. vw_bench gen:large 2
 *
 * Prints one line: the spec, the threads, the milliseconds spent in vw_world_load and in
 * meshing every non-empty chunk (vw_mesh_chunks, batches of 4,096 chunks, as the vis tool
 * meshes), the quad count and an FNV-1a hash of every mesh in chunk order, so that two
 * builds can be compared for speed and for identical output in one go.
 *
 * Built with -DVW_BENCH_SERIAL_API it uses only vw_world_from_spec and vw_mesh_chunk (one
 * chunk at a time, THREADS ignored), which is how the same program measures a voxelworld
 * from before those calls had threads (docs/performance.md). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "voxelworld/vw.h"

enum { BATCH = 4096 };

static double now_ms(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec * 1e3 + (double)t.tv_nsec * 1e-6;
}

static uint64_t hash_mesh(uint64_t h, const vw_mesh *m, uint32_t chunk)
{
    const unsigned char *b = (const unsigned char *)m->quads;
    for (size_t i = 0; i < m->count * sizeof(vw_quad); i++)
        h = (h ^ b[i]) * 1099511628211ull;
    return (h ^ (unsigned char)chunk) * 1099511628211ull;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: vw_bench SPEC [THREADS]\n");
        return 2;
    }
    const char *spec = argv[1];
    const unsigned threads = argc > 2 ? (unsigned)strtoul(argv[2], NULL, 10) : 1u;
    vw_world *w = NULL;
    vw_error err;
    err.message[0] = '\0';
    const double t0 = now_ms();
#ifdef VW_BENCH_SERIAL_API
    vw_status st = vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err);
#else
    vw_load_options opt;
    memset(&opt, 0, sizeof opt);
    opt.threads = threads;
    vw_status st = vw_world_load(spec, &opt, &w, &err);
#endif
    const double t1 = now_ms();
    if (st != VW_OK) {
        fprintf(stderr, "vw_bench: %s: %s: %s\n", spec, vw_status_string(st), err.message);
        return 1;
    }
    vw_world_info info;
    vw_world_get_info(w, &info);
    uint64_t h = 1469598103934665603ull, quads = 0;
    static vw_mesh meshes[BATCH];
    static uint32_t chunks[BATCH];
    uint32_t next = 0;
    while (next < info.chunk_count && st == VW_OK) {
        size_t n = 0;
        for (; next < info.chunk_count && n < BATCH; next++)
            if (!vw_world_chunk_empty(w, next))
                chunks[n++] = next;
#ifdef VW_BENCH_SERIAL_API
        for (size_t i = 0; i < n && st == VW_OK; i++)
            st = vw_mesh_chunk(w, chunks[i], &meshes[i]);
#else
        st = vw_mesh_chunks(w, chunks, n, meshes, threads);
#endif
        for (size_t i = 0; i < n && st == VW_OK; i++) {
            quads += meshes[i].count;
            h = hash_mesh(h, &meshes[i], chunks[i]);
        }
    }
    const double t2 = now_ms();
    if (st != VW_OK) {
        fprintf(stderr, "vw_bench: %s: meshing: %s\n", spec, vw_status_string(st));
        return 1;
    }
#ifdef VW_BENCH_SERIAL_API
    const char *api = "serial API";
#else
    const char *api = "threads";
#endif
    printf("%s %s %u: generate %.1f ms, mesh %.1f ms, total %.1f ms; %llu quads, meshes %016llx\n", spec, api,
           threads, t1 - t0, t2 - t1, t2 - t0, (unsigned long long)quads, (unsigned long long)h);
    for (int i = 0; i < BATCH; i++)
        vw_mesh_free(&meshes[i]);
    vw_world_destroy(w);
    return 0;
}
