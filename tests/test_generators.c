/* test_generators.c — specs and generators: determinism (same spec, same voxels; another
 * seed, other voxels), origin independence, the facts each world promises (terrain caves
 * that open to the sky, city windows and furniture, maze walls 1 thick and corridors at most
 * 3 wide, all connected), spec errors, progress; the worlds recorded before generation was
 * optimised, and the same world for every thread count. Prints (never asserts) timings. */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <pthread.h>

#include <cmocka.h>

#include "test_support.h"
#include "voxelworld/vw.h"

static vw_world *gen(const char *spec)
{
    vw_world *w = NULL;
    vw_error err;
    err.message[0] = '\0';
    vw_status st = vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err);
    if (st != VW_OK)
        fail_msg("%s: %s: %s", spec, vw_status_string(st), err.message);
    return w;
}

/* The world's voxels as one dense array (origin-relative), for scans and flood fills. */
typedef struct grid {
    int32_t n[3];
    uint8_t *v;
} grid;

static grid to_grid(const vw_world *w)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    grid g = {{info.size[0], info.size[1], info.size[2]}, NULL};
    g.v = malloc((size_t)g.n[0] * g.n[1] * g.n[2]);
    assert_non_null(g.v);
    size_t i = 0;
    for (int32_t z = 0; z < g.n[2]; z++)
        for (int32_t y = 0; y < g.n[1]; y++)
            for (int32_t x = 0; x < g.n[0]; x++)
                g.v[i++] = vw_world_get(w, info.origin[0] + x, info.origin[1] + y, info.origin[2] + z);
    return g;
}

static uint8_t at(const grid *g, int32_t x, int32_t y, int32_t z)
{
    if (x < 0 || y < 0 || z < 0 || x >= g->n[0] || y >= g->n[1] || z >= g->n[2])
        return 0;
    return g->v[x + (size_t)g->n[0] * (y + (size_t)g->n[1] * z)];
}

static uint64_t hash_world(const vw_world *w)
{
    grid g = to_grid(w);
    uint64_t h = 1469598103934665603ull; /* FNV-1a */
    for (size_t i = 0; i < (size_t)g.n[0] * g.n[1] * g.n[2]; i++)
        h = (h ^ g.v[i]) * 1099511628211ull;
    free(g.v);
    return h;
}

static void test_determinism(void **state)
{
    (void)state;
    const char *names[] = {"terrain", "city", "maze"};
    for (int i = 0; i < 3; i++) {
        char a[128], b[128];
        snprintf(a, sizeof a, "gen:%s:size=96x64x80:seed=42", names[i]);
        snprintf(b, sizeof b, "gen:%s:size=96x64x80:seed=43", names[i]);
        vw_world *w1 = gen(a), *w2 = gen(a), *w3 = gen(b);
        uint64_t h1 = hash_world(w1), h2 = hash_world(w2), h3 = hash_world(w3);
        assert_true(h1 == h2);
        if (h1 == h3)
            fail_msg("%s: seeds 42 and 43 gave the same world", names[i]);
        vw_world_info i1, i2;
        vw_world_get_info(w1, &i1);
        vw_world_get_info(w2, &i2);
        assert_int_equal(i1.solid_voxels, i2.solid_voxels);
        assert_true(i1.solid_voxels > 0);
        /* A fresh world has nothing dirty: its user meshes everything once. */
        assert_int_equal(vw_world_take_dirty(w1, NULL, 0), 0);
        vw_world_destroy(w1);
        vw_world_destroy(w2);
        vw_world_destroy(w3);
    }
    /* gen:default is the default spec. */
    vw_world *d1 = gen("gen:default"), *d2 = gen(vw_default_spec());
    vw_world_info info;
    vw_world_get_info(d1, &info);
    assert_int_equal(info.size[0], 512);
    assert_int_equal(info.size[1], 128);
    assert_int_equal(info.size[2], 512);
    assert_int_equal(info.chunk_size, 16);
    assert_true(hash_world(d1) == hash_world(d2));
    /* The default world has lakes: see-through, reflective water at some column's sea level. */
    size_t water = 0;
    for (int32_t z = 0; z < 512; z++)
        for (int32_t x = 0; x < 512; x++) {
            const vw_material *m = vw_world_material(d1, vw_world_get(d1, x, 40, z));
            water += (m->flags & (VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE)) == (VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE);
        }
    printf("default world: %zu of 512x512 columns hold water at y = 40\n", water);
    assert_true(water > 1000);
    vw_world_destroy(d1);
    vw_world_destroy(d2);
}

/* The same spec at origin 0 and far away: the same voxels relative to the origin, hence the
 * same meshes; origins round down to a chunk multiple. */
static void test_far_origin(void **state)
{
    (void)state;
    const char *names[] = {"terrain", "city", "maze"};
    for (int i = 0; i < 3; i++) {
        char a[160], b[160];
        snprintf(a, sizeof a, "gen:%s:size=64x64x64:seed=3", names[i]);
        snprintf(b, sizeof b, "gen:%s:size=64x64x64:seed=3:origin=1048576,0,-1048576", names[i]);
        vw_world *w1 = gen(a), *w2 = gen(b);
        vw_world_info i2;
        vw_world_get_info(w2, &i2);
        assert_true(i2.origin[0] == 1048576 && i2.origin[1] == 0 && i2.origin[2] == -1048576);
        assert_true(hash_world(w1) == hash_world(w2));
        vw_mesh m1 = {NULL, 0, 0}, m2 = {NULL, 0, 0};
        for (uint32_t c = 0; c < i2.chunk_count; c++) {
            assert_int_equal(vw_mesh_chunk(w1, c, &m1), VW_OK);
            assert_int_equal(vw_mesh_chunk(w2, c, &m2), VW_OK);
            assert_int_equal(m1.count, m2.count);
            if (m1.count)
                assert_memory_equal(m1.quads, m2.quads, m1.count * sizeof(vw_quad));
        }
        vw_mesh_free(&m1);
        vw_mesh_free(&m2);
        vw_world_destroy(w1);
        vw_world_destroy(w2);
    }
    vw_world *w = gen("gen:maze:size=32x16x32:origin=17,-1,-33:chunk=32");
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_true(info.origin[0] == 0 && info.origin[1] == -32 && info.origin[2] == -64);
    assert_int_equal(info.chunk_size, 32);
    vw_world_destroy(w);
}

/* Flood fill of air from the top layer of the world; counts the reached air voxels that lie
 * below their column's highest solid voxel, i.e. inside caves entered from the sky. */
static size_t sky_reachable_cave_air(const grid *g, size_t *cave_air)
{
    const size_t n = (size_t)g->n[0] * g->n[1] * g->n[2];
    uint8_t *seen = calloc(n, 1);
    size_t *stack = malloc(n * sizeof *stack);
    int32_t *top = malloc(sizeof(int32_t) * (size_t)g->n[0] * g->n[2]);
    assert_true(seen && stack && top);
    *cave_air = 0;
    for (int32_t z = 0; z < g->n[2]; z++)
        for (int32_t x = 0; x < g->n[0]; x++) {
            int32_t y = g->n[1] - 1;
            while (y > 0 && !at(g, x, y, z))
                y--;
            top[x + g->n[0] * z] = y;
            for (int32_t k = 1; k < y; k++)
                *cave_air += !at(g, x, k, z);
        }
    size_t sp = 0, reached = 0;
    for (int32_t z = 0; z < g->n[2]; z++)
        for (int32_t x = 0; x < g->n[0]; x++) {
            size_t i = x + (size_t)g->n[0] * ((g->n[1] - 1) + (size_t)g->n[1] * z);
            if (!g->v[i]) {
                seen[i] = 1;
                stack[sp++] = i;
            }
        }
    while (sp) {
        size_t i = stack[--sp];
        int32_t x = (int32_t)(i % g->n[0]), y = (int32_t)(i / g->n[0] % g->n[1]), z = (int32_t)(i / g->n[0] / g->n[1]);
        reached += y < top[x + g->n[0] * z];
        const int32_t d[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
        for (int k = 0; k < 6; k++) {
            int32_t a = x + d[k][0], b = y + d[k][1], c = z + d[k][2];
            if (a < 0 || b < 0 || c < 0 || a >= g->n[0] || b >= g->n[1] || c >= g->n[2])
                continue;
            size_t j = a + (size_t)g->n[0] * (b + (size_t)g->n[1] * c);
            if (!seen[j] && !g->v[j]) {
                seen[j] = 1;
                stack[sp++] = j;
            }
        }
    }
    free(seen);
    free(stack);
    free(top);
    return reached;
}

static void test_terrain_facts(void **state)
{
    (void)state;
    vw_world *w = gen("gen:terrain:size=256x128x256:seed=1");
    grid g = to_grid(w);
    size_t counts[256] = {0};
    for (size_t i = 0; i < (size_t)g.n[0] * g.n[1] * g.n[2]; i++)
        counts[g.v[i]]++;
    /* grass, dirt, stone, water: indices from the generator palette, checked by flags too */
    int materials = 0, water = 0;
    for (int m = 1; m < 256; m++) {
        if (!counts[m])
            continue;
        materials++;
        uint32_t flags = vw_world_material(w, (uint32_t)m)->flags;
        if (flags & VW_MAT_SEE_THROUGH) {
            assert_true(flags & VW_MAT_REFLECTIVE);
            water++;
        }
    }
    assert_true(materials >= 3); /* this corner of the world has no lake; see test_determinism */
    assert_true(water <= 1);
    /* Caves: plenty of air under the surface, and some of it reachable from the sky. */
    size_t cave_air = 0;
    size_t reached = sky_reachable_cave_air(&g, &cave_air);
    printf("terrain 256x128x256: %zu air voxels under the surface, %zu of them reachable from the sky\n", cave_air, reached);
    assert_true(cave_air > (size_t)g.n[0] * g.n[2]);        /* on average more than 1 per column */
    assert_true(reached > 1000);
    /* Varied relief: the surface spans a good part of the height. */
    int32_t lo = g.n[1], hi = 0;
    for (int32_t z = 0; z < g.n[2]; z++)
        for (int32_t x = 0; x < g.n[0]; x++) {
            int32_t y = g.n[1] - 1;
            while (y > 0 && !at(&g, x, y, z))
                y--;
            lo = y < lo ? y : lo;
            hi = y > hi ? y : hi;
        }
    assert_true(hi - lo > g.n[1] / 5);
    free(g.v);
    vw_world_destroy(w);
}

/* A window: an air voxel in a thin wall, air on both sides across the wall, wall beside it
 * (within 2 voxels) along the wall, and wall above and below (within 2 voxels). */
static int is_window(const grid *g, int32_t x, int32_t y, int32_t z, int along_x)
{
    if (at(g, x, y, z))
        return 0;
    const int32_t ax = along_x, az = !along_x; /* step along the wall */
    const int32_t cx = !along_x, cz = along_x; /* step across it      */
    if (at(g, x + cx, y, z + cz) || at(g, x - cx, y, z - cz))
        return 0;
    int side_a = 0, side_b = 0, above = 0, below = 0;
    for (int k = 1; k <= 2; k++) {
        side_a |= at(g, x + k * ax, y, z + k * az) != 0 && !at(g, x + k * ax + cx, y, z + k * az + cz);
        side_b |= at(g, x - k * ax, y, z - k * az) != 0 && !at(g, x - k * ax + cx, y, z - k * az + cz);
        above |= at(g, x, y + k, z) != 0;
        below |= at(g, x, y - k, z) != 0;
    }
    return side_a && side_b && above && below;
}

static void test_city_facts(void **state)
{
    (void)state;
    vw_world *w = gen("gen:city:size=192x96x192:seed=5");
    grid g = to_grid(w);
    size_t windows = 0, furniture = 0, glass = 0, hollow = 0;
    for (int32_t z = 1; z < g.n[2] - 1; z++)
        for (int32_t y = 2; y < g.n[1] - 2; y++)
            for (int32_t x = 1; x < g.n[0] - 1; x++) {
                windows += is_window(&g, x, y, z, 1) || is_window(&g, x, y, z, 0);
                uint8_t v = at(&g, x, y, z);
                if (v && (vw_world_material(w, v)->flags & VW_MAT_SEE_THROUGH))
                    glass++;
                /* Hollow rooms: air with a floor below and a ceiling above, inside walls. */
                if (!v && at(&g, x, y - 1, z) && !at(&g, x, y + 1, z) && at(&g, x, y + 4, z) && y > 2)
                    hollow++;
            }
    /* Furniture: small solid things standing on a floor, one voxel inside an outer wall. */
    for (int32_t z = 1; z < g.n[2] - 1; z++)
        for (int32_t y = 2; y < g.n[1] - 2; y++)
            for (int32_t x = 1; x < g.n[0] - 1; x++)
                if (at(&g, x, y, z) && !at(&g, x, y + 2, z) && at(&g, x, y + 4, z) && at(&g, x, y - 1, z) &&
                    (!at(&g, x + 1, y, z) || !at(&g, x - 1, y, z)))
                    furniture++;
    printf("city 192x96x192: %zu window voxels, %zu glass voxels, %zu room floor cells, %zu furniture candidates\n", windows,
           glass, hollow, furniture);
    assert_true(windows > 100);
    assert_true(hollow > 1000);
    assert_true(furniture > 10);
    free(g.v);
    vw_world_destroy(w);
}

static void test_maze_facts(void **state)
{
    (void)state;
    vw_world *w = gen("gen:maze:size=128x16x96:seed=9");
    grid g = to_grid(w);
    /* A floor everywhere. */
    for (int32_t z = 0; z < g.n[2]; z++)
        for (int32_t x = 0; x < g.n[0]; x++)
            assert_true(at(&g, x, 0, z) != 0);
    /* Walls 1 thick: no 2x2 block of wall in the plan. Corridors at most 3 wide: no 4x4 block
     * of corridor. */
    const int32_t y = 1;
    size_t wall = 0;
    for (int32_t z = 0; z + 1 < g.n[2]; z++)
        for (int32_t x = 0; x + 1 < g.n[0]; x++) {
            int block = at(&g, x, y, z) && at(&g, x + 1, y, z) && at(&g, x, y, z + 1) && at(&g, x + 1, y, z + 1);
            if (block)
                fail_msg("a 2x2 block of wall at (%d, %d)", x, z);
            wall += at(&g, x, y, z) != 0;
        }
    for (int32_t z = 0; z + 4 <= g.n[2]; z++)
        for (int32_t x = 0; x + 4 <= g.n[0]; x++) {
            int any = 0;
            for (int k = 0; k < 16; k++)
                any |= at(&g, x + k % 4, y, z + k / 4) != 0;
            if (!any)
                fail_msg("a 4x4 block of corridor at (%d, %d)", x, z);
        }
    assert_true(wall > (size_t)g.n[0] * g.n[2] / 5);
    /* Walls are the same in every layer up to their top; above them, air. */
    for (int32_t z = 0; z < g.n[2]; z++)
        for (int32_t x = 0; x < g.n[0]; x++)
            for (int32_t k = 2; k < g.n[1]; k++)
                assert_int_equal(at(&g, x, k, z) != 0, k <= 5 && at(&g, x, 1, z) != 0);
    /* Connected: every corridor voxel is reachable from any other. */
    size_t n = (size_t)g.n[0] * g.n[2], open = 0, reached = 0, sp = 0;
    uint8_t *seen = calloc(n, 1);
    size_t *stack = malloc(n * sizeof *stack);
    assert_true(seen && stack);
    for (size_t i = 0; i < n; i++)
        if (!at(&g, (int32_t)(i % g.n[0]), y, (int32_t)(i / g.n[0]))) {
            open++;
            if (!sp) {
                seen[i] = 1;
                stack[sp++] = i;
            }
        }
    while (sp) {
        size_t i = stack[--sp];
        reached++;
        int32_t x = (int32_t)(i % g.n[0]), z = (int32_t)(i / g.n[0]);
        const int32_t d[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (int k = 0; k < 4; k++) {
            int32_t a = x + d[k][0], b = z + d[k][1];
            if (a < 0 || b < 0 || a >= g.n[0] || b >= g.n[2])
                continue;
            size_t j = a + (size_t)g.n[0] * b;
            if (!seen[j] && !at(&g, a, y, b)) {
                seen[j] = 1;
                stack[sp++] = j;
            }
        }
    }
    assert_int_equal(reached, open);
    free(seen);
    free(stack);
    free(g.v);
    vw_world_destroy(w);
}

static void expect_error(const char *spec, vw_status want)
{
    vw_world *w = (vw_world *)&w;
    vw_error err;
    err.message[0] = '\0';
    vw_status st = vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err);
    if (st != want)
        fail_msg("%s: got %s (%s), want %s", spec ? spec : "(null)", vw_status_string(st), err.message, vw_status_string(want));
    assert_null(w);
    assert_true(strlen(err.message) > 0);
}

static void test_spec_errors(void **state)
{
    (void)state;
    const char *bad[] = {
        "gen:",
        "gen:forest",
        "gen:terrain:size=64x64",
        "gen:terrain:size=0x16x16",
        "gen:terrain:size=16x-16x16",
        "gen:terrain:size=2000000x16x16",
        "gen:terrain:size=axbxc",
        "gen:terrain:size=16x16x16x16",
        "gen:terrain:size=1048576x1048576x1048576", /* too many chunks for IDs */
        "gen:maze:size=1048576x16x65536",           /* too many chunks to generate */
        "gen:terrain:seed=-1",
        "gen:terrain:seed=12abc",
        "gen:terrain:chunk=8",
        "gen:terrain:chunk=",
        "gen:terrain:origin=1,2",
        "gen:terrain:color=red",
        "gen:terrain:size",
        "gen:city:preset=large",
        "gen:terrain:preset=huge",
        "gen:terrain:trees=101",
        "gen:terrain:trees=-1",
        "gen:terrain:trees=many",
        "gen:city:trees=10",
        "world.txt",
        "",
        "terrain",
        "model.vdb?frobnicate=1",
        "model.vdb?threshold=abc",
        "model.vox?chunk=8",
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        expect_error(bad[i], VW_ERROR_INVALID_ARGUMENT);
    vw_world *w = NULL;
    assert_int_equal(vw_world_from_spec(NULL, NULL, NULL, NULL, &w, NULL), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_from_spec("gen:maze", NULL, NULL, NULL, NULL, NULL), VW_ERROR_INVALID_ARGUMENT);
    /* A file spec is handed to its importer, which reports a missing file its own way. */
    vw_error err;
    assert_true(vw_world_from_spec("/nonexistent/none.vox", NULL, NULL, NULL, &w, &err) != VW_OK);
    assert_null(w);
    assert_true(vw_world_from_spec("/nonexistent/none.vdb?grid=density&threshold=0.5&transform=1", NULL, NULL, NULL, &w, &err) != VW_OK);
    assert_null(w);
}

typedef struct progress_log {
    int calls;
    double last;
    int monotone;
    int stage_ok;
} progress_log;

static void on_progress(const char *stage, double fraction, void *user)
{
    progress_log *p = user;
    p->calls++;
    p->monotone &= fraction >= p->last && fraction >= 0.0 && fraction <= 1.0;
    p->stage_ok &= stage != NULL && strcmp(stage, "generating") == 0;
    p->last = fraction;
}

static void test_progress(void **state)
{
    (void)state;
    const char *specs[] = {"gen:maze:size=512x16x512", "gen:city:size=64x32x64", "gen:terrain:size=16x16x16"};
    for (int i = 0; i < 3; i++) {
        progress_log p = {0, 0.0, 1, 1};
        vw_world *w = NULL;
        assert_int_equal(vw_world_from_spec(specs[i], NULL, on_progress, &p, &w, NULL), VW_OK);
        assert_true(p.calls >= 2 && p.calls <= 101);
        assert_true(p.monotone && p.stage_ok);
        assert_true(p.last == 1.0);
        vw_world_destroy(w);
    }
}

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + (double)t.tv_nsec * 1e-9;
}

/* Figures for the record (printed, never asserted: machines differ). */
static void test_timings(void **state)
{
    (void)state;
    const char *spec = vt_small() ? "gen:terrain:size=128x128x128:seed=1" : vw_default_spec();
    double t0 = now();
    vw_world *w = gen(spec);
    double t1 = now();
    vw_world_info info;
    vw_world_get_info(w, &info);
    vw_mesh mesh = {NULL, 0, 0};
    size_t quads = 0, objects = 0;
    uint32_t *meshed = malloc(sizeof(uint32_t) * info.chunk_count);
    assert_non_null(meshed);
    for (uint32_t i = 0; i < info.chunk_count; i++) {
        assert_int_equal(vw_mesh_chunk(w, i, &mesh), VW_OK);
        quads += mesh.count;
        if (mesh.count)
            meshed[objects++] = i;
    }
    double t2 = now();
    const int reps = 3;
    for (int r = 0; r < reps; r++)
        for (size_t k = 0; k < objects; k++)
            vw_mesh_chunk(w, meshed[k], &mesh);
    double t3 = now();
    printf("%s: generated in %.3f s, meshed in %.3f s; %u chunks, %zu with a mesh, %zu quads, %.1f MiB; "
           "remesh of a chunk with a mesh: %.2f us on average\n",
           spec, t1 - t0, t2 - t1, info.chunk_count, objects, quads, info.bytes / 1048576.0,
           objects ? (t3 - t2) * 1e6 / (double)(reps * objects) : 0.0);
    assert_true(objects > 0);
    free(meshed);
    vw_mesh_free(&mesh);
    vw_world_destroy(w);
}

/* ---- recorded worlds and threads ---------------------------------------------------- */

/* Voxel hashes (hash_world) recorded with the serial generator of commit 6eded59, before the
 * terrain learnt to skip cave tests and generation went parallel: both must leave every
 * voxel as it was. The oracle is that older code's output, not the code under test. */
static const struct {
    const char *spec;
    uint64_t voxels;
    uint64_t solid;
} recorded[] = {
    {"gen:terrain:size=200x40x200:seed=11:origin=-1000,16,77", 0x539fcdbac665295cull, 751108},
    {"gen:terrain:size=320x96x320:seed=3:chunk=32", 0x6aebfa9c3e1bf617ull, 3941038},
    {"gen:terrain:size=64x1024x64:seed=5", 0x195045e4bebdb9b1ull, 1326864},
    {"gen:terrain:size=96x160x96:seed=1", 0xb3f922d3d9b37ef3ull, 679969},
    {"gen:city:size=128x64x128:seed=9", 0xb3030e444d92b9b9ull, 108191},
    {"gen:maze:size=128x16x96:seed=4", 0x568367d3e3291181ull, 33868},
};

static vw_world *load_threads(const char *spec, uint32_t threads)
{
    vw_load_options o;
    memset(&o, 0, sizeof o);
    o.threads = threads;
    vw_world *w = NULL;
    vw_error err;
    err.message[0] = '\0';
    vw_status st = vw_world_load(spec, &o, &w, &err);
    if (st != VW_OK)
        fail_msg("%s on %u threads: %s: %s", spec, (unsigned)threads, vw_status_string(st), err.message);
    return w;
}

static void assert_same_info(const vw_world *a, const vw_world *b)
{
    vw_world_info x, y;
    vw_world_get_info(a, &x);
    vw_world_get_info(b, &y);
    assert_int_equal(x.solid_voxels, y.solid_voxels);
    assert_int_equal(x.nonempty_chunks, y.nonempty_chunks);
    assert_int_equal(x.bytes, y.bytes); /* the same chunks stored dense */
    assert_int_equal(x.chunk_count, y.chunk_count);
}

static void test_recorded_worlds(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof recorded / sizeof recorded[0]; i++) {
        vw_world *w = gen(recorded[i].spec);
        vw_world_info info;
        vw_world_get_info(w, &info);
        const uint64_t h = hash_world(w);
        if (h != recorded[i].voxels || info.solid_voxels != recorded[i].solid)
            fail_msg("%s: voxels hash %016llx (%llu solid), recorded %016llx (%llu)", recorded[i].spec,
                     (unsigned long long)h, (unsigned long long)info.solid_voxels,
                     (unsigned long long)recorded[i].voxels, (unsigned long long)recorded[i].solid);
        vw_world_destroy(w);
    }
}

/* Every thread count gives the serial world: voxels, chunk storage and counts. 7 threads on
 * a world of fewer columns checks the clamp too. */
static void test_threads_same_world(void **state)
{
    (void)state;
    const uint32_t counts[] = {1, 2, 3, 7};
    for (size_t i = 0; i < sizeof recorded / sizeof recorded[0]; i++) {
        vw_world *serial = gen(recorded[i].spec);
        const uint64_t h = hash_world(serial);
        for (size_t k = 0; k < sizeof counts / sizeof counts[0]; k++) {
            vw_world *w = load_threads(recorded[i].spec, counts[k]);
            assert_same_info(serial, w);
            if (hash_world(w) != h)
                fail_msg("%s: %u threads gave another world", recorded[i].spec, (unsigned)counts[k]);
            assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);
            vw_world_destroy(w);
        }
        vw_world_destroy(serial);
    }
    /* A world of one column: more threads than columns. */
    vw_world *one = load_threads("gen:terrain:size=16x64x16:seed=2", 7), *ref = gen("gen:terrain:size=16x64x16:seed=2");
    assert_true(hash_world(one) == hash_world(ref));
    vw_world_destroy(one);
    vw_world_destroy(ref);
}

/* Trees (gen:terrain's trees=PERCENT): they only fill air, with wood trunks standing on
 * grass and see-through leaves, the rest of the world as without them; the same for every
 * thread count, also away from the origin; none with trees=0. */
static void test_terrain_trees(void **state)
{
    (void)state;
    vw_world *bare = gen("gen:terrain:size=160x96x144:seed=6"), *zero = gen("gen:terrain:size=160x96x144:seed=6:trees=0");
    vw_world *trees = gen("gen:terrain:size=160x96x144:seed=6:trees=60");
    assert_true(hash_world(bare) == hash_world(zero));
    grid a = to_grid(bare), b = to_grid(trees);
    size_t wood = 0, leaves = 0, standing = 0;
    for (int32_t z = 0; z < a.n[2]; z++)
        for (int32_t y = 0; y < a.n[1]; y++)
            for (int32_t x = 0; x < a.n[0]; x++) {
                const uint8_t va = at(&a, x, y, z), vb = at(&b, x, y, z);
                if (va == vb)
                    continue;
                if (va != 0)
                    fail_msg("trees changed a solid voxel at (%d,%d,%d): %u -> %u", x, y, z, va, vb);
                const vw_material *m = vw_world_material(trees, vb);
                if (vb == 17) { /* leaves */
                    assert_true((m->flags & VW_MAT_SEE_THROUGH) != 0);
                    ++leaves;
                } else {
                    assert_true((m->flags & VW_MAT_SEE_THROUGH) == 0); /* wood */
                    ++wood;
                    if (at(&b, x, y - 1, z) != vb) { /* a trunk's foot: on grass (index 1) */
                        if (at(&b, x, y - 1, z) != 1)
                            fail_msg("a trunk at (%d,%d,%d) stands on material %u", x, y, z, at(&b, x, y - 1, z));
                        ++standing;
                    }
                }
            }
    printf("trees=60 on 160x96x144 (360 cells): %zu trunks, %zu wood and %zu leaf voxels\n", standing, wood, leaves);
    assert_true(standing >= 20 && leaves > 20 * standing);
    free(a.v), free(b.v);
    const uint64_t h = hash_world(trees);
    vw_world *threaded = load_threads("gen:terrain:size=160x96x144:seed=6:trees=60", 3);
    if (hash_world(threaded) != h)
        fail_msg("trees: 3 threads gave another world");
    vw_world_destroy(threaded);
    const char *neg = "gen:terrain:size=96x96x96:seed=6:trees=60:origin=-64,0,-48";
    vw_world *n1 = gen(neg), *n3 = load_threads(neg, 3), *nb = gen("gen:terrain:size=96x96x96:seed=6:origin=-64,0,-48");
    assert_true(hash_world(n1) == hash_world(n3));
    vw_world_info i1, ib;
    vw_world_get_info(n1, &i1);
    vw_world_get_info(nb, &ib);
    assert_true(i1.solid_voxels > ib.solid_voxels); /* trees there too */
    vw_world_destroy(n1);
    vw_world_destroy(n3);
    vw_world_destroy(nb);
    vw_world_destroy(bare);
    vw_world_destroy(zero);
    vw_world_destroy(trees);
}

/* The budget counts each worker's scratch; where it has room for one worker only, more
 * threads are not used and the load still succeeds with the same world. Where the world
 * itself does not fit, every thread count fails the same way. */
static void test_threads_budget(void **state)
{
    (void)state;
    const char *spec = "gen:terrain:size=96x64x96:seed=4";
    vw_world *ref = gen(spec);
    const uint64_t h = hash_world(ref);
    /* The smallest budget a serial load passes (bisection on max_bytes). */
    uint64_t lo = 1, hi = (uint64_t)1 << 30;
    while (hi - lo > 1) {
        const uint64_t mid = lo + (hi - lo) / 2;
        vw_load_options o;
        memset(&o, 0, sizeof o);
        o.budget.max_bytes = mid;
        o.threads = 1;
        vw_world *w = NULL;
        if (vw_world_load(spec, &o, &w, NULL) == VW_OK) {
            hi = mid;
            vw_world_destroy(w);
        } else {
            lo = mid;
        }
    }
    const uint32_t counts[] = {1, 2, 3, 7};
    for (size_t k = 0; k < sizeof counts / sizeof counts[0]; k++) {
        vw_load_options o;
        memset(&o, 0, sizeof o);
        o.budget.max_bytes = hi;
        o.threads = counts[k];
        vw_world *w = NULL;
        vw_error err;
        assert_int_equal(vw_world_load(spec, &o, &w, &err), VW_OK);
        assert_true(hash_world(w) == h);
        vw_world_info info;
        vw_world_get_info(w, &info);
        assert_true(info.bytes <= hi);
        assert_int_equal(info.max_bytes, hi);
        vw_world_destroy(w);
        o.budget.max_bytes = hi - 1;
        w = NULL;
        assert_int_equal(vw_world_load(spec, &o, &w, &err), VW_ERROR_BUDGET);
        assert_null(w);
        assert_true(strlen(err.message) > 0);
    }
    vw_world_destroy(ref);
}

typedef struct thread_progress {
    pthread_t caller;
    int calls, monotone, same_thread;
    double last;
} thread_progress;

static void on_thread_progress(const char *stage, double fraction, void *user)
{
    thread_progress *p = user;
    p->calls++;
    p->monotone &= fraction >= p->last && strcmp(stage, "generating") == 0;
    p->same_thread &= pthread_equal(pthread_self(), p->caller) != 0;
    p->last = fraction;
}

/* Progress on several threads: still from the calling thread only, non-decreasing, at most
 * 101 calls, ending at 1. */
static void test_threads_progress(void **state)
{
    (void)state;
    const char *specs[] = {"gen:terrain:size=256x32x256", "gen:maze:size=512x16x512", "gen:city:size=16x32x16"};
    for (size_t i = 0; i < 3; i++) {
        thread_progress p = {pthread_self(), 0, 1, 1, 0.0};
        vw_load_options o;
        memset(&o, 0, sizeof o);
        o.threads = 3;
        o.progress = on_thread_progress;
        o.progress_user = &p;
        vw_world *w = NULL;
        assert_int_equal(vw_world_load(specs[i], &o, &w, NULL), VW_OK);
        assert_true(p.calls >= 2 && p.calls <= 101);
        assert_true(p.monotone && p.same_thread);
        assert_true(p.last == 1.0);
        vw_world_destroy(w);
    }
    /* NULL options: the serial defaults; bad arguments. */
    vw_world *w = NULL;
    assert_int_equal(vw_world_load("gen:maze:size=32x16x32", NULL, &w, NULL), VW_OK);
    vw_world_destroy(w);
    assert_int_equal(vw_world_load(NULL, NULL, &w, NULL), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_load("gen:maze", NULL, NULL, NULL), VW_ERROR_INVALID_ARGUMENT);
}

/* A large generated world keeps its dense chunks in 2 MiB pool blocks (charged whole): a
 * chunk dug out gives its array back, and the next chunk that needs one takes it, so edits
 * after generation reuse the memory and take no new block. */
static void test_pool_edits(void **state)
{
    (void)state;
    vw_world *w = gen("gen:terrain:size=512x64x128:seed=3"); /* 1,024 chunks: pooled */
    vw_world_info info;
    vw_world_get_info(w, &info);
    const uint64_t bytes = info.bytes;
    assert_true(bytes <= info.max_bytes);
    /* A chunk that mixes materials (stored dense), found by its voxels. */
    int64_t found[3] = {-1, -1, -1};
    for (int64_t cy = 0; cy < 4 && found[0] < 0; cy++)
        for (int64_t cx = 0; cx < 32 && found[0] < 0; cx++) {
            const uint8_t a = vw_world_get(w, cx * 16, cy * 16, 0);
            for (int64_t i = 1; i < 16 && found[0] < 0; i++)
                if (vw_world_get(w, cx * 16 + i, cy * 16 + i, i) != a)
                    found[0] = cx * 16, found[1] = cy * 16, found[2] = 0;
        }
    assert_true(found[0] >= 0);
    const int64_t mx[3] = {found[0] + 16, found[1] + 16, 16};
    assert_int_equal(vw_world_fill(w, found, mx, 0), VW_OK); /* dense -> uniform air */
    vw_world_get_info(w, &info);
    assert_int_equal(info.bytes, bytes);
    /* A voxel in the top chunk layer, which is mostly air: if its chunk is uniform it needs
     * a dense array, which the free list gives without growing; if not, none is needed. */
    assert_int_equal(vw_world_get(w, 100, 63, 100), 0);
    assert_int_equal(vw_world_set(w, 100, 63, 100, 3), VW_OK);
    assert_int_equal(vw_world_get(w, 100, 63, 100), 3);
    assert_int_equal(vw_world_get(w, 101, 63, 100), 0);
    vw_world_get_info(w, &info);
    assert_int_equal(info.bytes, bytes);
    /* Many more than the freed array: the block's spare slots, then single arrays (the world
     * no longer takes blocks), each charged. */
    for (int64_t x = 0; x < 512; x += 16)
        assert_int_equal(vw_world_set(w, x, 62, 120, 3), VW_OK);
    vw_world_get_info(w, &info);
    assert_true(info.bytes >= bytes && info.bytes <= bytes + 32 * 16 * 16 * 16);
    for (int64_t x = 0; x < 512; x += 16)
        assert_int_equal(vw_world_get(w, x, 62, 120), 3);
    vw_world_destroy(w);
}

/* ---- the budget (vw_budget) ----------------------------------------------------------- */

static vw_status from_spec_budget(const char *spec, uint64_t max_bytes, uint64_t max_voxels, vw_world **w,
                                  vw_error *err, double *seconds)
{
    vw_budget b = {max_bytes, max_voxels};
    err->message[0] = '\0';
    *w = (vw_world *)w;
    double t0 = now();
    vw_status st = vw_world_from_spec(spec, &b, NULL, NULL, w, err);
    *seconds = now() - t0;
    return st;
}

/* A maze of 16384 x 16 x 16384 voxels (4.3e9, four times the default max_voxels) took 6.9 GB
 * before failing; it is refused from its size, at once. */
static void test_budget_maze(void **state)
{
    (void)state;
    vw_world *w;
    vw_error err;
    double dt;
    const char *spec = "gen:maze:size=16384x16x16384";
    assert_int_equal(from_spec_budget(spec, 0, 0, &w, &err, &dt), VW_ERROR_BUDGET);
    assert_null(w);
    printf("%s refused in %.3f s: %s\n", spec, dt, err.message);
    assert_true(dt < 1.0);
    assert_non_null(strstr(err.message, "4,294,967,296 voxels"));
    assert_non_null(strstr(err.message, "1,073,741,824"));
    /* Through vw_world_from_spec's NULL budget too. */
    err.message[0] = '\0';
    w = (vw_world *)&w;
    assert_int_equal(vw_world_from_spec(spec, NULL, NULL, NULL, &w, &err), VW_ERROR_BUDGET);
    assert_null(w);
    /* Under a raised max_voxels, the memory limit still refuses it before anything is made:
     * its cells' scratch alone (vwg_maze_scratch_bytes) is over 256 MiB. */
    assert_int_equal(from_spec_budget(spec, 256ull << 20, (uint64_t)1 << 33, &w, &err, &dt), VW_ERROR_BUDGET);
    assert_null(w);
    printf("%s with 256 MiB and 2^33 voxels refused in %.3f s: %s\n", spec, dt, err.message);
    assert_non_null(strstr(err.message, "256.0 MiB"));
}

/* gen:default loads under the default budget and reports it; small budgets refuse it, by
 * its voxels before anything is made, or by its memory during generation. */
static void test_budget_default_world(void **state)
{
    (void)state;
    vw_world *w;
    vw_error err;
    double dt;
    assert_int_equal(from_spec_budget("gen:default", 0, 0, &w, &err, &dt), VW_OK);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.max_bytes, VW_DEFAULT_MAX_BYTES);
    assert_true(info.bytes <= info.max_bytes);
    const uint64_t bytes = info.bytes;
    printf("gen:default: %.1f MiB\n", bytes / 1048576.0);
    vw_world_destroy(w);

    assert_int_equal(from_spec_budget("gen:default", 0, 1000000, &w, &err, &dt), VW_ERROR_BUDGET);
    assert_null(w);
    assert_non_null(strstr(err.message, "33,554,432 voxels"));
    assert_non_null(strstr(err.message, "1,000,000"));

    assert_int_equal(from_spec_budget("gen:default", 1 << 20, 0, &w, &err, &dt), VW_ERROR_BUDGET);
    assert_null(w);
    assert_non_null(strstr(err.message, "1.0 MiB"));
    printf("gen:default, 1 MiB: %s\n", err.message);
    /* Half of what the world ends up holding cannot be enough. */
    assert_int_equal(from_spec_budget("gen:default", bytes / 2, 0, &w, &err, &dt), VW_ERROR_BUDGET);
    assert_null(w);
    /* The table alone over the limit: refused before the world is made. */
    assert_int_equal(from_spec_budget("gen:terrain:size=16384x16x16384", 4 << 20, (uint64_t)1 << 33, &w, &err,
                                      &dt), VW_ERROR_BUDGET);
    assert_null(w);
    assert_true(dt < 1.0);
    assert_non_null(strstr(err.message, "1,048,576 chunks"));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_determinism),
        cmocka_unit_test(test_far_origin),
        cmocka_unit_test(test_terrain_facts),
        cmocka_unit_test(test_city_facts),
        cmocka_unit_test(test_maze_facts),
        cmocka_unit_test(test_spec_errors),
        cmocka_unit_test(test_progress),
        cmocka_unit_test(test_timings),
        cmocka_unit_test(test_budget_maze),
        cmocka_unit_test(test_budget_default_world),
        cmocka_unit_test(test_recorded_worlds),
        cmocka_unit_test(test_threads_same_world),
        cmocka_unit_test(test_terrain_trees),
        cmocka_unit_test(test_threads_budget),
        cmocka_unit_test(test_threads_progress),
        cmocka_unit_test(test_pool_edits),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
