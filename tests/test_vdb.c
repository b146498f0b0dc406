/* test_vdb.c — the OpenVDB importer (voxelworld/src/vdb/vdb_shim.cpp).
 *
 * Expected counts do not come from the import path:
 *  - structure: the ls_cube level set is the solid cube -110..110 (221^3); the ls_sphere
 *    count is within 3% of 4/3*pi*r^3 with r from its narrow band; the fog files' counts
 *    equal their active voxel counts listed in ../shared/data/ATTRIBUTION.md (every active
 *    value is > 0 in those files, checked through the threshold below their minimum);
 *  - a second reading: vwi_vdb_test_compare probes every index voxel of the grid through an
 *    OpenVDB ValueAccessor, restates the rules, and compares voxel by voxel with the world;
 *  - fixtures written by vwi_vdb_test_write_fixture, whose counts follow from how they are
 *    built (tiles, inactive interiors, transforms, instances, non-float grids).
 * The exact counts were pinned once both agreed (docs/vdb.md says how). */
#define _POSIX_C_SOURCE 200809L /* mkdtemp, strdup */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "test_support.h"
#include "voxelworld/vw.h"

#ifdef VW_WITH_OPENVDB

/* Test hooks of vdb_shim.cpp (not part of vw.h). */
int vwi_vdb_test_write_fixture(const char *path, const char *kind);
int vwi_vdb_test_compare(const char *path, const char *grid_name, float fog_threshold, const vw_world *world,
                         uint64_t *out_solid, uint64_t *out_mismatches);

static char g_tmp[256];

static int setup_tmp(void **state)
{
    (void)state;
    snprintf(g_tmp, sizeof g_tmp, "/tmp/vis_test_vdb_XXXXXX");
    return mkdtemp(g_tmp) ? 0 : -1;
}

static const char *const k_tmp_files[] = {"multi.vdb", "vector.vdb", "tiles.vdb", "fogtile.vdb", "xform.vdb",
                                          "rotated.vdb", "instance.vdb", "stream.vdb", "empty.vdb", "cut.vdb", "text.vdb",
                                          "zero.vdb"};

static int teardown_tmp(void **state)
{
    (void)state;
    char p[512];
    for (size_t i = 0; i < sizeof k_tmp_files / sizeof k_tmp_files[0]; i++) {
        snprintf(p, sizeof p, "%s/%s", g_tmp, k_tmp_files[i]);
        unlink(p);
    }
    rmdir(g_tmp);
    return 0;
}

static const char *tmp_path(const char *name)
{
    static char p[512];
    snprintf(p, sizeof p, "%s/%s", g_tmp, name);
    return p;
}

/* Writes a fixture and returns its path (a static buffer). */
static const char *fixture(const char *kind)
{
    char name[64];
    snprintf(name, sizeof name, "%s.vdb", kind);
    const char *p = tmp_path(name);
    assert_int_equal(vwi_vdb_test_write_fixture(p, kind), 0);
    return p;
}

/* Copies a shared file's path (vt_shared_file returns a static buffer), NULL when absent. */
static char *shared(const char *name)
{
    char rel[128];
    snprintf(rel, sizeof rel, "vdb/%s", name);
    const char *p = vt_shared_file(rel);
    return p ? strdup(p) : NULL;
}

static vw_world *load_ok(const char *path, const char *grid, float threshold, int use_transform, int32_t chunk)
{
    vw_vdb_options o;
    memset(&o, 0, sizeof o);
    o.grid = grid;
    o.fog_threshold = threshold;
    o.use_transform = use_transform;
    o.chunk_size = chunk;
    vw_world *w = NULL;
    vw_error err = {{0}};
    vw_status st = vw_vdb_load_file(path, &o, &w, &err);
    if (st != VW_OK)
        fail_msg("%s: %s: %s", path, vw_status_string(st), err.message);
    assert_non_null(w);
    return w;
}

static uint64_t solid_of(const vw_world *w)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    return info.solid_voxels;
}

/* The bounding box of the solid voxels, found by scanning (not from the importer). */
static void solid_bbox(const vw_world *w, int64_t mn[3], int64_t mx[3])
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    for (int a = 0; a < 3; a++) {
        mn[a] = INT64_MAX;
        mx[a] = INT64_MIN;
    }
    for (int64_t z = info.origin[2]; z < info.origin[2] + info.size[2]; z++)
        for (int64_t y = info.origin[1]; y < info.origin[1] + info.size[1]; y++)
            for (int64_t x = info.origin[0]; x < info.origin[0] + info.size[0]; x++)
                if (vw_world_get(w, x, y, z)) {
                    const int64_t p[3] = {x, y, z};
                    for (int a = 0; a < 3; a++) {
                        mn[a] = p[a] < mn[a] ? p[a] : mn[a];
                        mx[a] = p[a] > mx[a] ? p[a] : mx[a];
                    }
                }
}

static void expect_status(const char *path, const vw_vdb_options *o, vw_status want, const char *needle)
{
    vw_world *w = (vw_world *)(uintptr_t)0x1; /* must stay untouched on failure */
    vw_error err = {{0}};
    vw_status st = vw_vdb_load_file(path, o, &w, &err);
    if (st != want)
        fail_msg("%s: got %s (%s), want %s", path ? path : "(null)", vw_status_string(st), err.message,
                 vw_status_string(want));
    assert_true(w == (vw_world *)(uintptr_t)0x1);
    assert_true(strlen(err.message) > 0);
    if (needle && !strstr(err.message, needle))
        fail_msg("message '%s' lacks '%s'", err.message, needle);
}

/* Loads a shared file, checks the world against the second reading, returns its count. */
static uint64_t load_and_compare(const char *path, const char *grid, float threshold, int32_t chunk)
{
    vw_world *w = load_ok(path, grid, threshold, 0, chunk);
    uint64_t probe = 0, mismatches = 0;
    assert_int_equal(vwi_vdb_test_compare(path, grid, threshold, w, &probe, &mismatches), 0);
    const uint64_t n = solid_of(w);
    if (mismatches != 0 || probe != n)
        fail_msg("%s: import has %llu solid voxels, the probe %llu, %llu differ", path, (unsigned long long)n,
                 (unsigned long long)probe, (unsigned long long)mismatches);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0); /* a loader hands out a clean world */
    for (int a = 0; a < 3; a++)
        assert_int_equal(info.origin[a] % info.chunk_size, 0);
    vw_world_destroy(w);
    return n;
}

static void expect_describe(const char *path, const char *want)
{
    char text[1024];
    vw_error err = {{0}};
    vw_status st = vw_vdb_describe_file(path, text, sizeof text, &err);
    if (st != VW_OK)
        fail_msg("%s: %s", path, err.message);
    assert_string_equal(text, want);
}

/* ---- the shared files ---------------------------------------------------------------- */

static void test_cube_level_set(void **state)
{
    (void)state;
    char *p = shared("mjurczyk_cube.vdb");
    if (!p)
        return;
    expect_describe(p, "ls_cube float level_set (-112,-112,-112)->(112,112,112) 1452218\n");
    /* The band reaches +-112 and is 3 voxels wide (background 0.15 / voxel 0.05), so the
     * faces lie between 109 and 112: the inside is the cube -110..110, 221 per side. */
    assert_int_equal(load_and_compare(p, "ls_cube", 0.0f, 0), 221ull * 221 * 221);
    vw_world *w = load_ok(p, NULL, 0.0f, 0, 0);
    vw_world_info info;
    vw_world_get_info(w, &info);
    for (int a = 0; a < 3; a++) {
        assert_int_equal(info.origin[a], -112); /* -110 rounded down to a multiple of 16 */
        assert_int_equal(info.size[a], 224);
    }
    int64_t mn[3], mx[3];
    solid_bbox(w, mn, mx);
    for (int a = 0; a < 3; a++) {
        assert_int_equal(mn[a], -110);
        assert_int_equal(mx[a], 110);
    }
    assert_int_equal(vw_world_get(w, 0, 0, 0), 1); /* the deep inside: inactive tiles */
    assert_int_equal(vw_world_get(w, 100, -100, 37), 1);
    assert_int_equal(vw_world_get(w, 111, 0, 0), 0);
    vw_world_destroy(w);
    /* use_transform: voxel size 0.05, world voxel n samples index 20n: |20n| <= 110 keeps
     * n in -5..5, an 11^3 cube. */
    w = load_ok(p, NULL, 0.0f, 1, 0);
    assert_int_equal(solid_of(w), 11 * 11 * 11);
    solid_bbox(w, mn, mx);
    for (int a = 0; a < 3; a++) {
        assert_int_equal(mn[a], -5);
        assert_int_equal(mx[a], 5);
    }
    vw_world_destroy(w);
    free(p);
}

static void test_sphere_level_set(void **state)
{
    (void)state;
    char *p = shared("gaffer_sphere.vdb");
    if (!p)
        return;
    expect_describe(p, "ls_sphere float level_set (-62,-62,-62)->(62,62,62) 270638\n");
    const uint64_t n = load_and_compare(p, NULL, 0.0f, 0);
    /* Band to +-62, 3 voxels wide: the surface is near 62 - 3 + 0.5. */
    const double pi = 3.14159265358979323846, r = 59.5, ideal = 4.0 / 3.0 * pi * r * r * r;
    if (fabs((double)n - ideal) > 0.03 * ideal)
        fail_msg("sphere: %llu solid voxels, 4/3 pi r^3 = %.0f", (unsigned long long)n, ideal);
    assert_int_equal(n, 903939);
    /* Chunk size 32 and the grid by name give the same voxels. */
    assert_int_equal(load_and_compare(p, "ls_sphere", 0.0f, 32), 903939);
    vw_world *w = load_ok(p, NULL, 0.0f, 0, 0);
    assert_int_equal(vw_world_get(w, 0, 0, 0), 1);
    assert_int_equal(vw_world_get(w, 59, 0, 0), 1);
    assert_int_equal(vw_world_get(w, 0, -59, 0), 1);
    assert_int_equal(vw_world_get(w, 60, 0, 0), 0);
    assert_int_equal(vw_world_get(w, 42, 42, 42), 0); /* |p| = 72.7 */
    vw_world_destroy(w);

    /* use_transform: voxel size 0.05, so world voxel n samples index 20n, inside where
     * 20|n| < r: the lattice points with |n|^2 <= 8, of which there are 93. */
    w = load_ok(p, NULL, 0.0f, 1, 0);
    assert_int_equal(solid_of(w), 93);
    int64_t mn[3], mx[3];
    solid_bbox(w, mn, mx);
    for (int a = 0; a < 3; a++) {
        assert_int_equal(mn[a], -2);
        assert_int_equal(mx[a], 2);
    }
    assert_int_equal(vw_world_get(w, 2, 2, 0), 1);  /* |n|^2 = 8 */
    assert_int_equal(vw_world_get(w, 2, 2, 1), 0);  /* |n|^2 = 9: on the surface, not inside */
    vw_world_destroy(w);
    free(p);
}

static void test_fog_files(void **state)
{
    (void)state;
    char *p = shared("oiio_sphere.vdb");
    if (p) {
        expect_describe(p, "density float fog_volume (-12,-12,-12)->(12,12,12) 9047\n");
        /* 9047 active voxels (ATTRIBUTION: 9.05KVox), of which 4049 hold more than 0. */
        assert_int_equal(load_and_compare(p, NULL, 0.0f, 0), 4049);
        assert_int_equal(load_and_compare(p, "density", -1.0f, 0), 9047);
        const uint64_t half = load_and_compare(p, "density", 0.5f, 0);
        assert_true(half > 0 && half < 4049);
        free(p);
    }
    p = shared("arnoldusd_torus01.vdb");
    if (p) {
        expect_describe(p, "voxel_fog_density float fog_volume (-25,-4,1)->(-4,4,22) 2450\n");
        /* Every active value is > 0.026, so threshold 0 keeps all 2450 (ATTRIBUTION: 2.45KVox). */
        assert_int_equal(load_and_compare(p, NULL, 0.0f, 0), 2450);
        assert_int_equal(load_and_compare(p, NULL, -1.0f, 0), 2450);
        free(p);
    }
    p = shared("gaffer_smoke.vdb");
    if (p) {
        expect_describe(p, "density float fog_volume (1,2,1)->(111,223,112) 1049275\n");
        assert_int_equal(load_and_compare(p, NULL, 0.0f, 0), 1049275); /* ATTRIBUTION: 1.05MVox */
        /* use_transform: voxel size 0.476, translation (-34, -13.1, -26.4). The world box
         * must lie inside the image of the index bbox [1,111]x[2,223]x[1,112]. */
        vw_world *w = load_ok(p, NULL, 0.0f, 1, 0);
        int64_t mn[3], mx[3];
        solid_bbox(w, mn, mx);
        const double t[3] = {-34.0, -13.1, -26.4}, lo[3] = {1, 2, 1}, hi[3] = {111, 223, 112};
        for (int a = 0; a < 3; a++) {
            assert_true((double)mn[a] > t[a] + 0.476 * (lo[a] - 0.5) - 1e-6);
            assert_true((double)mx[a] <= t[a] + 0.476 * (hi[a] + 0.5) + 1e-6);
        }
        /* Point sampling keeps about 0.476^3 of the voxels. */
        const double ideal = 1049275.0 * 0.476 * 0.476 * 0.476;
        if (fabs((double)solid_of(w) - ideal) > 0.1 * ideal)
            fail_msg("smoke with its transform: %llu voxels, about %.0f expected", (unsigned long long)solid_of(w),
                     ideal);
        vw_world_destroy(w);
        free(p);
    }
}

/* ---- fixtures ------------------------------------------------------------------------- */

static void test_fixture_tiles(void **state)
{
    (void)state;
    const char *p = fixture("tiles");
    vw_world *w = load_ok(p, NULL, 0.0f, 0, 0);
    /* 80^3 of inactive -3 tiles, one voxel punched out, one active -1 voxel outside. */
    assert_int_equal(solid_of(w), 80ull * 80 * 80);
    assert_int_equal(vw_world_get(w, 5, 5, 5), 0);
    assert_int_equal(vw_world_get(w, 0, 0, 41), 1);
    assert_int_equal(vw_world_get(w, -40, -40, -40), 1);
    assert_int_equal(vw_world_get(w, 39, 39, 39), 1);
    assert_int_equal(vw_world_get(w, -41, 0, 0), 0);
    assert_int_equal(vw_world_get(w, 0, 0, 40), 0);
    vw_world_destroy(w);
}

static void test_fixture_fog(void **state)
{
    (void)state;
    const char *p = fixture("fogtile");
    /* An active 16^3 tile region of 0.5; an inactive region of 1.0; active 0.25, 0, -1. */
    vw_world *w = load_ok(p, NULL, 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 4096 + 1);
    assert_int_equal(vw_world_get(w, 15, 15, 15), 1);
    assert_int_equal(vw_world_get(w, 32, 32, 32), 0);
    assert_int_equal(vw_world_get(w, 100, 0, 0), 1);
    assert_int_equal(vw_world_get(w, 101, 0, 0), 0);
    vw_world_destroy(w);
    w = load_ok(p, NULL, 0.3f, 0, 0);
    assert_int_equal(solid_of(w), 4096);
    vw_world_destroy(w);
    w = load_ok(p, NULL, -2.0f, 0, 0);
    assert_int_equal(solid_of(w), 4096 + 3);
    vw_world_destroy(w);
    w = load_ok(p, NULL, 0.5f, 0, 0); /* strictly above */
    assert_int_equal(solid_of(w), 0);
    vw_world_destroy(w);

    w = load_ok(fixture("empty"), NULL, 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 0);
    vw_world_destroy(w);
    expect_describe(tmp_path("empty.vdb"), "nothing float fog_volume empty 0\n");
}

static void test_fixture_grid_choice(void **state)
{
    (void)state;
    const char *p = fixture("multi");
    expect_describe(p, "velocity vec3s unknown (0,0,0)->(0,0,0) 1\n"
                       "flags int32 unknown (1,1,1)->(1,1,1) 1\n"
                       "dist double level_set (0,0,0)->(9,4,2) 150\n"
                       "density float unknown (1,2,3)->(4,5,6) 2\n");
    /* Default: the first float grid. Unknown class follows the fog rule, so its inactive
     * -1 at (7,8,9) is not solid. */
    vw_world *w = load_ok(p, NULL, 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 2);
    assert_int_equal(vw_world_get(w, 1, 2, 3), 1);
    assert_int_equal(vw_world_get(w, 4, 5, 6), 1);
    assert_int_equal(vw_world_get(w, 7, 8, 9), 0);
    vw_world_destroy(w);
    w = load_ok(p, "dist", 0.0f, 0, 0); /* a double level set */
    assert_int_equal(solid_of(w), 150);
    assert_int_equal(vw_world_get(w, 9, 4, 2), 1);
    vw_world_destroy(w);

    vw_vdb_options o;
    memset(&o, 0, sizeof o);
    o.grid = "velocity";
    expect_status(p, &o, VW_ERROR_UNSUPPORTED, "vec3s");
    o.grid = "flags";
    expect_status(p, &o, VW_ERROR_UNSUPPORTED, "int32");
    o.grid = "no_such_grid";
    expect_status(p, &o, VW_ERROR_INVALID_ARGUMENT, "'no_such_grid'");
    expect_status(p, &o, VW_ERROR_INVALID_ARGUMENT, "'density'"); /* lists what there is */
    expect_status(fixture("vector"), NULL, VW_ERROR_UNSUPPORTED, "no float or double grid");
}

static void test_fixture_transform(void **state)
{
    (void)state;
    const char *p = fixture("xform");
    /* Index voxels (0,0,0) and (1,0,0); scale (2,1,3), translation (10, 20.25, -7.5):
     * x: (9,11] and (11,13] hold 10,11 and 12,13; y: (19.75,20.75] holds 20;
     * z: (-9,-6] holds -8,-7,-6. Two voxels of 2x1x3 each. */
    vw_world *w = load_ok(p, NULL, 0.0f, 1, 0);
    assert_int_equal(solid_of(w), 12);
    int64_t mn[3], mx[3];
    solid_bbox(w, mn, mx);
    assert_int_equal(mn[0], 10);
    assert_int_equal(mx[0], 13);
    assert_int_equal(mn[1], 20);
    assert_int_equal(mx[1], 20);
    assert_int_equal(mn[2], -8);
    assert_int_equal(mx[2], -6);
    vw_world_destroy(w);
    w = load_ok(p, NULL, 0.0f, 0, 0); /* index space */
    assert_int_equal(solid_of(w), 2);
    assert_int_equal(vw_world_get(w, 1, 0, 0), 1);
    vw_world_destroy(w);

    p = fixture("rotated");
    vw_vdb_options o;
    memset(&o, 0, sizeof o);
    o.use_transform = 1;
    expect_status(p, &o, VW_ERROR_UNSUPPORTED, "rotates");
    w = load_ok(p, NULL, 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 2);
    vw_world_destroy(w);
}

static void test_fixture_instance(void **state)
{
    (void)state;
    const char *p = fixture("instance");
    /* "b" shares "a"'s tree, so the file stores it as an instance without a tree. */
    expect_describe(p, "a float fog_volume (0,0,0)->(2,2,2) 27\n"
                       "b float fog_volume (0,0,0)->(2,2,2) 27\n");
    vw_world *w = load_ok(p, "b", 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 27);
    vw_world_destroy(w);
    /* The same grids through io::Stream, which stores no grid offsets. */
    p = fixture("stream");
    expect_describe(p, "a float fog_volume (0,0,0)->(2,2,2) 27\n"
                       "b float fog_volume (0,0,0)->(2,2,2) 27\n");
    w = load_ok(p, "b", 0.0f, 0, 0);
    assert_int_equal(solid_of(w), 27);
    vw_world_destroy(w);
}

/* ---- bad input ---------------------------------------------------------------------- */

static void write_bytes(const char *path, const void *data, size_t n)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    if (n)
        assert_int_equal(fwrite(data, 1, n, f), n);
    fclose(f);
}

/* Every prefix in `cuts` of the file must fail to load and to describe, cleanly. */
static void expect_truncations_fail(const char *src)
{
    size_t size = 0;
    unsigned char *data = vt_read_file(src, &size);
    assert_non_null(data);
    const size_t cuts[] = {1, 4, 8, 16, 40, 100, 200, 300, 500, 1000, size / 3, size / 2, size - 100, size - 1};
    const char *cut = tmp_path("cut.vdb");
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        if (cuts[i] >= size)
            continue;
        write_bytes(cut, data, cuts[i]);
        vw_world *w = NULL;
        vw_error err = {{0}};
        vw_status st = vw_vdb_load_file(cut, NULL, &w, &err);
        if (st != VW_ERROR_FORMAT)
            fail_msg("%s cut to %zu bytes: %s (%s)", src, cuts[i], vw_status_string(st), err.message);
        assert_null(w);
        char text[256];
        st = vw_vdb_describe_file(cut, text, sizeof text, &err);
        if (st != VW_ERROR_FORMAT)
            fail_msg("describe of %s cut to %zu bytes: %s (%s)", src, cuts[i], vw_status_string(st), err.message);
    }
    free(data);
}

static void test_bad_files(void **state)
{
    (void)state;
    expect_status(tmp_path("does_not_exist.vdb"), NULL, VW_ERROR_IO, "does_not_exist.vdb");
    expect_status(g_tmp, NULL, VW_ERROR_IO, "not a regular file");
    write_bytes(tmp_path("zero.vdb"), "", 0);
    expect_status(tmp_path("zero.vdb"), NULL, VW_ERROR_FORMAT, NULL);
    const char text[] = "# Blender v2.8 OBJ File\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    write_bytes(tmp_path("text.vdb"), text, sizeof text - 1);
    expect_status(tmp_path("text.vdb"), NULL, VW_ERROR_FORMAT, "not");
    char out[64];
    vw_error err = {{0}};
    assert_int_equal(vw_vdb_describe_file(tmp_path("text.vdb"), out, sizeof out, &err), VW_ERROR_FORMAT);
    assert_int_equal(vw_vdb_describe_file(tmp_path("does_not_exist.vdb"), out, sizeof out, &err), VW_ERROR_IO);

    /* Truncated: a fixture always, the shared files (old, current and blosc-compressed
     * formats) when present. */
    expect_truncations_fail(fixture("tiles"));
    const char *names[] = {"gaffer_sphere.vdb", "oiio_sphere.vdb", "arnoldusd_torus01.vdb"};
    for (size_t i = 0; i < 3; i++) {
        char *p = shared(names[i]);
        if (p)
            expect_truncations_fail(p);
        free(p);
    }
}

static void test_bad_arguments(void **state)
{
    (void)state;
    const char *p = fixture("fogtile");
    vw_world *w = NULL;
    vw_error err = {{0}};
    assert_int_equal(vw_vdb_load_file(NULL, NULL, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_vdb_load_file(p, NULL, NULL, &err), VW_ERROR_INVALID_ARGUMENT);
    vw_vdb_options o;
    memset(&o, 0, sizeof o);
    o.chunk_size = 8;
    expect_status(p, &o, VW_ERROR_INVALID_ARGUMENT, "chunk size");
    o.chunk_size = 0;
    o.fog_threshold = NAN;
    expect_status(p, &o, VW_ERROR_INVALID_ARGUMENT, "NaN");
    assert_int_equal(vw_vdb_describe_file(p, NULL, 10, &err), VW_ERROR_INVALID_ARGUMENT);
    char small[12];
    assert_int_equal(vw_vdb_describe_file(p, small, 0, &err), VW_ERROR_INVALID_ARGUMENT);
    /* A short buffer: truncated, terminated. */
    memset(small, 'x', sizeof small);
    assert_int_equal(vw_vdb_describe_file(p, small, sizeof small, NULL), VW_OK);
    assert_string_equal(small, "fog float f");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cube_level_set),      cmocka_unit_test(test_sphere_level_set),
        cmocka_unit_test(test_fog_files),           cmocka_unit_test(test_fixture_tiles),
        cmocka_unit_test(test_fixture_fog),         cmocka_unit_test(test_fixture_grid_choice),
        cmocka_unit_test(test_fixture_transform),   cmocka_unit_test(test_fixture_instance),
        cmocka_unit_test(test_bad_files),           cmocka_unit_test(test_bad_arguments),
    };
    return cmocka_run_group_tests(tests, setup_tmp, teardown_tmp);
}

#else /* !VW_WITH_OPENVDB */

/* A build without OpenVDB: the entry points exist and say so. */
static void test_unsupported(void **state)
{
    (void)state;
    vw_world *w = NULL;
    vw_error err = {{0}};
    assert_int_equal(vw_vdb_load_file("x.vdb", NULL, &w, &err), VW_ERROR_UNSUPPORTED);
    assert_null(w);
    assert_non_null(strstr(err.message, "OpenVDB"));
    char text[64];
    assert_int_equal(vw_vdb_describe_file("x.vdb", text, sizeof text, &err), VW_ERROR_UNSUPPORTED);
    printf("SKIP: built without OpenVDB (VIS_WITH_OPENVDB=OFF or Boost missing); only the stubs are tested\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_unsupported)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}

#endif
