/* fuzz_vox.c — libFuzzer harness for the .vox importer (and, on what it accepts, the
 * exporter).
 *
 * Every input goes through vw_vox_load_memory_ex with limits smaller than the library's
 * defaults, so that one execution stays in milliseconds while every cap is still reached by
 * small inputs (the caps themselves are what is being tested, not their values). The
 * sanitizers (address, undefined) catch bad reads, overflows and leaks. When a world comes
 * out and is small, it must survive a round trip: saved with vw_vox_save_memory and loaded
 * again, it must hold the same voxels (up to one translation: far worlds are written
 * relative to their origin) with the same colours and flags; anything else aborts, which
 * libFuzzer records as a crash.
 *
 * Built with -DVOX_FUZZ_SEEDS instead, this file is fuzz_vox_seeds, which writes thinned
 * copies of the shared .vox files into the corpus: every chunk kept as it is (scene graph,
 * layers, materials, IMAP, render chunks), but each XYZI cut to its first 64 voxels. The
 * originals are 37 KB to 3 MB; the thinned copies keep their structure at a few KB, so the
 * fuzzer spends its time on structure instead of on copying voxels.
 *
 * Build and run: `make fuzz` (FUZZ_SECONDS=60 by default); docs/vox.md has the record. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef VOX_FUZZ_SEEDS

#include "vox_format.h"

static const vw_vox_limits fuzz_limits = {
    1u << 14,  /* chunks: the shared seeds need up to ~4,500                              */
    1u << 12,  /* instances                                                               */
    1u << 21,  /* instanced voxels: the largest seed has 768,000                          */
    1u << 16,  /* node visits                                                             */
};

static void die(const char *what)
{
    fprintf(stderr, "fuzz_vox: %s\n", what);
    abort();
}

/* Solid voxel count and the min corner of their box, over non-empty chunks. */
static uint64_t solid_min(const vw_world *w, int64_t lo[3])
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    int32_t C = info.chunk_size;
    uint64_t n = 0;
    for (uint32_t i = 0; i < info.chunk_count; i++) {
        if (vw_world_chunk_empty(w, i))
            continue;
        int32_t cc[3];
        vw_world_chunk_coords(w, i, cc);
        for (int32_t z = 0; z < C; z++)
            for (int32_t y = 0; y < C; y++)
                for (int32_t x = 0; x < C; x++) {
                    int64_t p[3] = {info.origin[0] + (int64_t)cc[0] * C + x, info.origin[1] + (int64_t)cc[1] * C + y,
                                    info.origin[2] + (int64_t)cc[2] * C + z};
                    if (!vw_world_get(w, p[0], p[1], p[2]))
                        continue;
                    for (int a = 0; a < 3; a++)
                        if (n == 0 || p[a] < lo[a])
                            lo[a] = p[a];
                    n++;
                }
    }
    return n;
}

static void check_round_trip(const vw_world *a)
{
    void *data = NULL;
    size_t size = 0;
    vw_error err;
    if (vw_vox_save_memory(a, &data, &size, &err) != VW_OK)
        die("export of an imported world failed");
    vw_world *b = NULL;
    vw_vox_stats st;
    vw_status s = vw_vox_load_memory_ex(data, size, 16, NULL, &b, &st, &err);
    free(data);
    if (s != VW_OK) {
        fprintf(stderr, "fuzz_vox: %s\n", err.message);
        die("re-import of our own export failed");
    }
    int64_t la[3] = {0, 0, 0}, lb[3] = {0, 0, 0};
    uint64_t na = solid_min(a, la), nb = solid_min(b, lb);
    if (na != nb)
        die("round trip changed the number of voxels");
    vw_world_info ia;
    vw_world_get_info(a, &ia);
    int32_t C = ia.chunk_size;
    uint8_t used[256] = {0};
    for (uint32_t i = 0; i < ia.chunk_count; i++) {
        if (vw_world_chunk_empty(a, i))
            continue;
        int32_t cc[3];
        vw_world_chunk_coords(a, i, cc);
        for (int32_t z = 0; z < C; z++)
            for (int32_t y = 0; y < C; y++)
                for (int32_t x = 0; x < C; x++) {
                    int64_t p[3] = {ia.origin[0] + (int64_t)cc[0] * C + x, ia.origin[1] + (int64_t)cc[1] * C + y,
                                    ia.origin[2] + (int64_t)cc[2] * C + z};
                    vw_voxel v = vw_world_get(a, p[0], p[1], p[2]);
                    if (v != vw_world_get(b, p[0] - la[0] + lb[0], p[1] - la[1] + lb[1], p[2] - la[2] + lb[2]))
                        die("round trip moved or changed a voxel");
                    used[v] = 1;
                }
    }
    for (uint32_t m = 1; m < 256; m++)
        if (used[m] && (vw_world_material(a, m)->rgba != vw_world_material(b, m)->rgba ||
                        vw_world_material(a, m)->flags != vw_world_material(b, m)->flags))
            die("round trip changed a material");
    vw_world_destroy(b);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error err;
    vw_status s = vw_vox_load_memory_ex(data, size, 16, &fuzz_limits, &w, &st, &err);
    if (s != VW_OK) {
        if (w)
            die("a failed load returned a world");
        if (!err.message[0])
            die("a failed load left no message");
        return 0;
    }
    vw_world_info info;
    vw_world_get_info(w, &info);
    if (info.solid_voxels > st.instanced_voxels)
        die("more voxels than the instances hold");
    if (st.instances > fuzz_limits.max_instances || info.chunk_count > fuzz_limits.max_chunks)
        die("a limit was exceeded");
    if (info.nonempty_chunks <= 256)
        check_round_trip(w);
    vw_world_destroy(w);
    return 0;
}

#else /* VOX_FUZZ_SEEDS: fuzz_vox_seeds OUT_DIR FILE.vox... */

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v, p[1] = (uint8_t)(v >> 8), p[2] = (uint8_t)(v >> 16), p[3] = (uint8_t)(v >> 24);
}

/* Copies MAIN's children, cutting XYZI chunks to `keep` voxels; 0 if the file is not a
 * well-formed .vox at the chunk level (then it is not thinned). */
static size_t thin(const uint8_t *in, size_t n, uint8_t *out, uint32_t keep)
{
    if (n < 20 || memcmp(in, "VOX ", 4) != 0 || memcmp(in + 8, "MAIN", 4) != 0)
        return 0;
    size_t pos = 20 + (size_t)get32(in + 12), end = pos + get32(in + 16);
    if (pos > n || end > n)
        return 0;
    memcpy(out, in, 20);
    size_t o = 20;
    while (pos + 12 <= end) {
        size_t c = get32(in + pos + 4), m = get32(in + pos + 8), total = 12 + c + m;
        if (c > end - pos || total > end - pos)
            return 0;
        if (memcmp(in + pos, "XYZI", 4) == 0 && c >= 4 && get32(in + pos + 12) > keep && m == 0) {
            memcpy(out + o, in + pos, 4);
            put32(out + o + 4, 4 + 4 * keep);
            put32(out + o + 8, 0);
            put32(out + o + 12, keep);
            memcpy(out + o + 16, in + pos + 16, 4 * (size_t)keep);
            o += 16 + 4 * (size_t)keep;
        } else {
            memcpy(out + o, in + pos, total);
            o += total;
        }
        pos += total;
    }
    put32(out + 12, 0);
    put32(out + 16, (uint32_t)(o - 20));
    return o;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: %s OUT_DIR FILE.vox...\n", argv[0]);
        return 2;
    }
    int failed = 0;
    for (int i = 2; i < argc; i++) {
        FILE *f = fopen(argv[i], "rb");
        if (!f) {
            fprintf(stderr, "cannot open %s\n", argv[i]);
            failed = 1;
            continue;
        }
        fseek(f, 0, SEEK_END);
        long len = ftell(f);
        rewind(f);
        uint8_t *in = malloc(len > 0 ? (size_t)len : 1), *out = malloc(len > 0 ? (size_t)len : 1);
        size_t n = len > 0 && in && out ? fread(in, 1, (size_t)len, f) : 0;
        fclose(f);
        size_t m = n ? thin(in, n, out, 64) : 0;
        const char *base = strrchr(argv[i], '/');
        base = base ? base + 1 : argv[i];
        char path[4096];
        snprintf(path, sizeof path, "%s/thin_%s", argv[1], base);
        FILE *g = m ? fopen(path, "wb") : NULL;
        if (!g || fwrite(out, 1, m, g) != m) {
            fprintf(stderr, "could not thin %s into %s\n", argv[i], path);
            failed = 1;
        } else {
            printf("%s: %zu -> %zu bytes\n", path, n, m);
        }
        if (g)
            fclose(g);
        free(in);
        free(out);
    }
    return failed;
}

#endif
