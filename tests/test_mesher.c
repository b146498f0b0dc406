/* test_mesher.c — the greedy mesher against a brute-force oracle, the meshes recorded before
 * meshing went parallel, vw_mesh_chunks against vw_mesh_chunk on 1-7 threads, and the OBJ
 * export.
 *
 * Oracle: every (voxel, direction) pair whose face must be drawn, by the rule in vw.h (a
 * solid voxel a, neighbour b: a face unless b is opaque or b == a; outside the world is
 * empty). The quads of a chunk must cover exactly those unit faces of the chunk's voxels,
 * each once (no overlap, nothing extra, nothing missing), with the voxel's material and flags. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"
#include "voxelworld/vw.h"

static vw_world *make_world(int32_t chunk, const int64_t o[3], int32_t sx, int32_t sy, int32_t sz)
{
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.chunk_size = chunk;
    memcpy(d.origin, o, sizeof d.origin);
    d.size[0] = sx;
    d.size[1] = sy;
    d.size[2] = sz;
    vw_world *w = NULL;
    assert_int_equal(vw_world_create(&d, &w, NULL), VW_OK);
    return w;
}

static int hides(const vw_world *w, uint8_t a, uint8_t b)
{
    return b != 0 && (b == a || !(vw_world_material(w, b)->flags & VW_MAT_SEE_THROUGH));
}

/* Checks one chunk's mesh against the oracle; returns its quad count. */
static size_t check_chunk(const vw_world *w, uint32_t index, vw_mesh *mesh)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    const int32_t c = info.chunk_size;
    int32_t cc[3];
    vw_world_chunk_coords(w, index, cc);
    assert_int_equal(vw_mesh_chunk(w, index, mesh), VW_OK);
    /* covered[d][x + c*(y + c*z)]: how many quads cover that voxel face */
    uint8_t *covered = calloc((size_t)6 * c * c * c, 1);
    assert_non_null(covered);
    for (size_t k = 0; k < mesh->count; k++) {
        const vw_quad *q = &mesh->quads[k];
        assert_true(q->axis < 3);
        assert_true(q->side == 1 || q->side == -1);
        assert_true(q->u0 < q->u1 && q->v0 < q->v1);
        assert_int_equal(q->flags, vw_world_material(w, q->material)->flags);
        const int a = q->axis, ua = (a + 1) % 3, va = (a + 2) % 3;
        const int d = 2 * a + (q->side > 0);
        for (int32_t v = q->v0; v < q->v1; v++)
            for (int32_t u = q->u0; u < q->u1; u++) {
                int32_t p[3];
                p[a] = q->side > 0 ? q->plane - 1 : q->plane; /* the solid voxel */
                p[ua] = u;
                p[va] = v;
                int32_t l[3];
                for (int i = 0; i < 3; i++) {
                    l[i] = p[i] - cc[i] * c;
                    if (l[i] < 0 || l[i] >= c)
                        fail_msg("chunk %u: quad %zu covers voxel (%d,%d,%d) outside the chunk", index, k, p[0], p[1], p[2]);
                }
                uint8_t mat = vw_world_get(w, info.origin[0] + p[0], info.origin[1] + p[1], info.origin[2] + p[2]);
                if (mat != q->material)
                    fail_msg("chunk %u: quad of material %d over voxel (%d,%d,%d) of material %d", index, q->material, p[0],
                             p[1], p[2], mat);
                uint8_t *cov = &covered[(size_t)d * c * c * c + l[0] + c * (l[1] + c * l[2])];
                if (++*cov > 1)
                    fail_msg("chunk %u: quads overlap at voxel (%d,%d,%d) direction %d", index, p[0], p[1], p[2], d);
            }
    }
    for (int32_t z = 0; z < c; z++)
        for (int32_t y = 0; y < c; y++)
            for (int32_t x = 0; x < c; x++) {
                const int64_t p[3] = {info.origin[0] + cc[0] * c + x, info.origin[1] + cc[1] * c + y, info.origin[2] + cc[2] * c + z};
                const uint8_t a = vw_world_get(w, p[0], p[1], p[2]);
                for (int d = 0; d < 6; d++) {
                    int64_t n[3] = {p[0], p[1], p[2]};
                    n[d / 2] += (d & 1) ? 1 : -1;
                    const int want = a != 0 && !hides(w, a, vw_world_get(w, n[0], n[1], n[2]));
                    const int got = covered[(size_t)d * c * c * c + x + c * (y + c * z)];
                    if (want != got)
                        fail_msg("chunk %u: voxel (%lld,%lld,%lld) material %d direction %d: face %s", index,
                                 (long long)p[0], (long long)p[1], (long long)p[2], a, d, want ? "missing" : "extra");
                }
            }
    free(covered);
    return mesh->count;
}

static size_t check_world(const vw_world *w)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    vw_mesh mesh = {NULL, 0, 0};
    size_t quads = 0;
    for (uint32_t i = 0; i < info.chunk_count; i++)
        quads += check_chunk(w, i, &mesh);
    vw_mesh_free(&mesh);
    assert_null(mesh.quads);
    return quads;
}

/* Random boxes (so that merging has something to merge) and random single voxels of a few
 * materials, one of them see-through glass and one see-through water. */
static void randomise(vw_world *w, uint64_t *s, int boxes, int voxels)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    vw_material glass = {0x80FFFFFFu, VW_MAT_SEE_THROUGH};
    vw_material water = {0x80FF0000u, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE};
    vw_world_set_material(w, 3, &glass);
    vw_world_set_material(w, 4, &water);
    for (int i = 0; i < boxes; i++) {
        int64_t mn[3], mx[3];
        for (int a = 0; a < 3; a++) {
            mn[a] = info.origin[a] + (int64_t)(vt_rand(s) % (uint64_t)info.size[a]);
            mx[a] = mn[a] + 1 + (int64_t)(vt_rand(s) % 24);
        }
        vw_world_fill(w, mn, mx, (uint8_t)(vt_rand(s) % 6));
    }
    for (int i = 0; i < voxels; i++) {
        int64_t p[3];
        for (int a = 0; a < 3; a++)
            p[a] = info.origin[a] + (int64_t)(vt_rand(s) % (uint64_t)info.size[a]);
        vw_world_set(w, p[0], p[1], p[2], (uint8_t)(vt_rand(s) % 6));
    }
}

static void test_brute_force_random(void **state)
{
    (void)state;
    const int rounds = vt_small() ? 6 : 40;
    uint64_t s = 12345;
    for (int r = 0; r < rounds; r++) {
        const int32_t chunk = r % 4 == 3 ? 32 : 16;
        /* Far, negative and odd origins: meshes are relative to the origin anyway. */
        const int64_t o[3] = {(int64_t)(vt_rand(&s) % 5 - 2) * 1048576, -chunk * (int64_t)(vt_rand(&s) % 3),
                              chunk * (int64_t)(vt_rand(&s) % 1000) - 500 * chunk};
        vw_world *w = make_world(chunk, o, chunk * 2, chunk + 3, chunk * 3 - 5);
        if (r % 5 == 4) {
            /* Many see-through materials (the mesher then switches to a per-byte table);
             * only 5 is used, but all of them count. */
            for (uint32_t m = 5; m < 20; m++) {
                vw_material tinted = {0x80000000u | m, VW_MAT_SEE_THROUGH};
                vw_world_set_material(w, m, &tinted);
            }
        }
        randomise(w, &s, 4 + (int)(vt_rand(&s) % 30), (int)(vt_rand(&s) % 3000));
        check_world(w);
        vw_world_destroy(w);
    }
}

/* A checkerboard: no two faces merge, the worst case for the quad count. */
static void test_checkerboard(void **state)
{
    (void)state;
    const int64_t o[3] = {0, 0, 0};
    for (int32_t chunk = 16; chunk <= 32; chunk += 16) {
        vw_world *w = make_world(chunk, o, chunk, chunk, chunk);
        for (int z = 0; z < chunk; z++)
            for (int y = 0; y < chunk; y++)
                for (int x = 0; x < chunk; x++)
                    if ((x + y + z) % 2 == 0)
                        vw_world_set(w, x, y, z, (uint8_t)(1 + (x % 3)));
        size_t quads = check_world(w);
        assert_int_equal(quads, (size_t)6 * chunk * chunk * chunk / 2);
        vw_world_destroy(w);
    }
}

/* A solid world: faces only on the world's outside, one quad per chunk side there. */
static void test_world_edges(void **state)
{
    (void)state;
    const int64_t o[3] = {-32, -16, 1048576};
    vw_world *w = make_world(16, o, 32, 32, 48);
    const int64_t mx[3] = {0, 16, 1048576 + 48};
    assert_int_equal(vw_world_fill(w, o, mx, 7), VW_OK);
    size_t quads = check_world(w);
    /* 2x2x3 chunks: chunk sides on the boundary = 2*(2*2 + 2*3 + 2*3) = 32. */
    assert_int_equal(quads, 32);
    vw_mesh mesh = {NULL, 0, 0};
    assert_int_equal(vw_mesh_chunk(w, 0, &mesh), VW_OK);
    assert_int_equal(mesh.count, 3); /* a corner chunk shows three sides */
    for (size_t k = 0; k < mesh.count; k++) {
        const vw_quad *q = &mesh.quads[k];
        assert_int_equal(q->side, -1);
        assert_int_equal(q->plane, 0);
        assert_int_equal(q->u1 - q->u0, 16);
        assert_int_equal(q->v1 - q->v0, 16);
        assert_int_equal(q->material, 7);
        assert_int_equal(q->flags, VW_MAT_OPAQUE);
    }
    assert_int_equal(vw_mesh_chunk(w, 12, &mesh), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_mesh_chunk(NULL, 0, &mesh), VW_ERROR_INVALID_ARGUMENT);
    vw_mesh_free(&mesh);
    vw_world_destroy(w);
}

/* See-through materials across a chunk border: water meets water (no face), glass meets
 * water (faces on both sides), stone under water (the stone's top face only). */
static void test_see_through(void **state)
{
    (void)state;
    const int64_t o[3] = {0, 0, 0};
    vw_world *w = make_world(16, o, 32, 16, 16);
    vw_material glass = {0x80FFFFFFu, VW_MAT_SEE_THROUGH};
    vw_material water = {0x80FF0000u, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE};
    vw_world_set_material(w, 3, &glass);
    vw_world_set_material(w, 4, &water);
    /* Water x in [8, 24) crosses the chunk border at x = 16; stone below it; glass after. */
    const int64_t w0[3] = {8, 5, 5}, w1[3] = {24, 6, 6};
    vw_world_fill(w, w0, w1, 4);
    vw_world_set(w, 12, 4, 5, 1);
    vw_world_set(w, 24, 5, 5, 3);
    check_world(w);
    vw_mesh mesh = {NULL, 0, 0};
    int water_x_faces = 0, glass_minus_x = 0, stone_top = 0, water_bottom_over_stone = 0;
    for (uint32_t i = 0; i < 2; i++) {
        vw_mesh_chunk(w, i, &mesh);
        for (size_t k = 0; k < mesh.count; k++) {
            const vw_quad *q = &mesh.quads[k];
            if (q->material == 4 && q->axis == 0)
                water_x_faces++;
            if (q->material == 4)
                assert_int_equal(q->flags, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE);
            if (q->material == 3 && q->axis == 0 && q->side == -1 && q->plane == 24)
                glass_minus_x++;
            if (q->material == 1 && q->axis == 1 && q->side == 1)
                stone_top++;
            if (q->material == 4 && q->axis == 1 && q->side == -1 && q->plane == 5 && q->v0 <= 12 && 12 < q->v1 && q->u0 <= 5 &&
                5 < q->u1)
                water_bottom_over_stone++;
        }
    }
    assert_int_equal(water_x_faces, 2); /* the two ends only: x = 8 and the glass at x = 24 */
    assert_int_equal(glass_minus_x, 1);
    assert_int_equal(stone_top, 1);
    assert_int_equal(water_bottom_over_stone, 0);
    vw_mesh_free(&mesh);
    vw_world_destroy(w);
}

/* Uniform chunks (stored without voxels) next to every kind of neighbour: the mesher's
 * shortcut for buried chunks must agree with the oracle. */
static void test_uniform_chunks(void **state)
{
    (void)state;
    const int64_t o[3] = {-48, 16, 4096};
    const uint8_t kinds[] = {0, 1, 3, 4}; /* air, stone, glass, water */
    for (size_t centre = 1; centre < sizeof kinds; centre++)
        for (size_t around = 0; around < sizeof kinds; around++)
            for (int odd = 0; odd < 2; odd++) {
                vw_world *w = make_world(16, o, 48, 48, 48);
                vw_material glass = {0x80FFFFFFu, VW_MAT_SEE_THROUGH};
                vw_material water = {0x80FF0000u, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE};
                vw_world_set_material(w, 3, &glass);
                vw_world_set_material(w, 4, &water);
                const int64_t all_max[3] = {o[0] + 48, o[1] + 48, o[2] + 48};
                vw_world_fill(w, o, all_max, kinds[around]);
                const int64_t c0[3] = {o[0] + 16, o[1] + 16, o[2] + 16}, c1[3] = {o[0] + 32, o[1] + 32, o[2] + 32};
                vw_world_fill(w, c0, c1, kinds[centre]);
                if (odd) /* one neighbour differs: the +y chunk gets a voxel of air */
                    vw_world_set(w, o[0] + 20, o[1] + 40, o[2] + 20, 0);
                check_world(w);
                vw_mesh mesh = {NULL, 0, 0};
                vw_mesh_chunk(w, 13, &mesh);
                const int hidden = kinds[around] == 1 || kinds[around] == kinds[centre];
                if (hidden)
                    assert_int_equal(mesh.count, 0);
                else
                    assert_int_equal(mesh.count, 6);
                vw_mesh_free(&mesh);
                vw_world_destroy(w);
            }
}

/* The same voxels at origin 0 and far away give identical quads (they are origin-relative). */
static void test_far_origin(void **state)
{
    (void)state;
    const int64_t near[3] = {0, 0, 0}, far[3] = {1048576, 0, -1048576}, farther[3] = {-((int64_t)1 << 50), 4096, (int64_t)1 << 45};
    vw_world *a = make_world(16, near, 48, 32, 48);
    vw_world *b = make_world(16, far, 48, 32, 48);
    vw_world *c = make_world(16, farther, 48, 32, 48);
    uint64_t s = 777;
    for (int i = 0; i < 4000; i++) {
        int64_t p[3] = {(int64_t)(vt_rand(&s) % 48), (int64_t)(vt_rand(&s) % 32), (int64_t)(vt_rand(&s) % 48)};
        uint8_t v = (uint8_t)(vt_rand(&s) % 4);
        vw_world_set(a, p[0], p[1], p[2], v);
        vw_world_set(b, far[0] + p[0], far[1] + p[1], far[2] + p[2], v);
        vw_world_set(c, farther[0] + p[0], farther[1] + p[1], farther[2] + p[2], v);
    }
    vw_mesh ma = {NULL, 0, 0}, mb = {NULL, 0, 0}, mc = {NULL, 0, 0};
    for (uint32_t i = 0; i < 3 * 2 * 3; i++) {
        assert_int_equal(vw_mesh_chunk(a, i, &ma), VW_OK);
        assert_int_equal(vw_mesh_chunk(b, i, &mb), VW_OK);
        assert_int_equal(vw_mesh_chunk(c, i, &mc), VW_OK);
        assert_int_equal(ma.count, mb.count);
        assert_int_equal(ma.count, mc.count);
        assert_true(ma.count > 0);
        assert_memory_equal(ma.quads, mb.quads, ma.count * sizeof(vw_quad));
        assert_memory_equal(ma.quads, mc.quads, ma.count * sizeof(vw_quad));
    }
    vw_mesh_free(&ma);
    vw_mesh_free(&mb);
    vw_mesh_free(&mc);
    vw_world_destroy(a);
    vw_world_destroy(b);
    vw_world_destroy(c);
}

/* A mesh with room is reused as is; one without grows. */
static void test_mesh_capacity(void **state)
{
    (void)state;
    const int64_t o[3] = {0, 0, 0};
    vw_world *w = make_world(16, o, 16, 16, 16);
    uint64_t s = 5;
    randomise(w, &s, 10, 500);
    vw_mesh mesh = {NULL, 0, 0};
    assert_int_equal(vw_mesh_chunk(w, 0, &mesh), VW_OK);
    assert_true(mesh.count > 0 && mesh.capacity >= mesh.count);
    const size_t count = mesh.count;
    vw_quad *before = mesh.quads;
    const size_t cap = mesh.capacity;
    mesh.count = 12345; /* replaced, not appended to */
    assert_int_equal(vw_mesh_chunk(w, 0, &mesh), VW_OK);
    assert_ptr_equal(mesh.quads, before);
    assert_int_equal(mesh.capacity, cap);
    assert_int_equal(mesh.count, count);
    vw_mesh_free(&mesh);
    vw_mesh_free(&mesh);
    vw_world_destroy(w);
}

/* ---- recorded meshes and threads ----------------------------------------------------- */

/* FNV-1a over every non-empty chunk's quads (their bytes: vw_quad has no padding), then the
 * chunk index's low byte, in chunk order — as recorded. */
static uint64_t hash_meshes(const vw_world *w)
{
    _Static_assert(sizeof(vw_quad) == 24, "vw_quad is hashed as its 24 bytes");
    vw_world_info info;
    vw_world_get_info(w, &info);
    uint64_t h = 1469598103934665603ull;
    vw_mesh m = {NULL, 0, 0};
    for (uint32_t c = 0; c < info.chunk_count; c++) {
        if (vw_world_chunk_empty(w, c))
            continue;
        assert_int_equal(vw_mesh_chunk(w, c, &m), VW_OK);
        const unsigned char *b = (const unsigned char *)m.quads;
        for (size_t i = 0; i < m.count * sizeof(vw_quad); i++)
            h = (h ^ b[i]) * 1099511628211ull;
        h = (h ^ (unsigned char)c) * 1099511628211ull;
    }
    vw_mesh_free(&m);
    return h;
}

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

/* The meshes of generated worlds as the mesher of commit 6eded59 made them (quads and their
 * order): any change to the mesher must keep them, or prove (with the oracle above) that
 * new meshes cover the same faces and change this table knowingly. */
static void test_recorded_meshes(void **state)
{
    (void)state;
    static const struct {
        const char *spec;
        uint64_t hash, quads;
        int big;
    } rec[] = {
        {"gen:terrain:size=200x40x200:seed=11:origin=-1000,16,77", 0xd5085f48f9b7304aull, 32757, 0},
        {"gen:terrain:size=320x96x320:seed=3:chunk=32", 0xe086655e56b9a650ull, 170713, 0},
        {"gen:terrain:size=96x160x96:seed=1", 0x20f7c81453ff7f4dull, 30378, 0},
        {"gen:city:size=128x64x128:seed=9", 0x0f643e308808ad25ull, 40665, 0},
        {"gen:maze:size=128x16x96:seed=4", 0xb0c83256efeae479ull, 4686, 0},
        {"gen:default", 0xd9efac7e1c49b1c9ull, 623211, 1},
    };
    for (size_t i = 0; i < sizeof rec / sizeof rec[0]; i++) {
        if (rec[i].big && vt_small())
            continue;
        vw_world *w = gen(rec[i].spec);
        const uint64_t h = hash_meshes(w);
        if (h != rec[i].hash)
            fail_msg("%s: meshes hash %016llx, recorded %016llx", rec[i].spec, (unsigned long long)h,
                     (unsigned long long)rec[i].hash);
        vw_world_destroy(w);
    }
}

/* Asserts meshes[i] equals vw_mesh_chunk's mesh of chunks[i], quad for quad. */
static void assert_meshes_serial(const vw_world *w, const uint32_t *chunks, size_t n, const vw_mesh *meshes)
{
    vw_mesh ref = {NULL, 0, 0};
    for (size_t i = 0; i < n; i++) {
        assert_int_equal(vw_mesh_chunk(w, chunks[i], &ref), VW_OK);
        assert_int_equal(meshes[i].count, ref.count);
        if (ref.count && memcmp(meshes[i].quads, ref.quads, ref.count * sizeof *ref.quads) != 0)
            fail_msg("chunk %u: the batch's quads differ from vw_mesh_chunk's", (unsigned)chunks[i]);
    }
    vw_mesh_free(&ref);
}

/* vw_mesh_chunks gives each chunk exactly the serial mesh, for 1, 2, 3 and 7 threads, with
 * meshes reused across calls (grown, and holding other chunks' quads before), in any order
 * of chunks, empty and buried ones included; and refuses bad arguments. */
static void test_mesh_chunks_threads(void **state)
{
    (void)state;
    vw_world *worlds[3];
    worlds[0] = gen("gen:terrain:size=128x96x128:seed=21");
    worlds[1] = gen("gen:city:size=96x64x96:seed=2");
    const int64_t o[3] = {-32, 0, 32};
    worlds[2] = make_world(32, o, 96, 64, 64);
    uint64_t seed = 77;
    randomise(worlds[2], &seed, 4, 20000);
    const uint32_t counts[] = {1, 2, 3, 7};
    for (int wi = 0; wi < 3; wi++) {
        vw_world *w = worlds[wi];
        vw_world_info info;
        vw_world_get_info(w, &info);
        const size_t n = info.chunk_count;
        uint32_t *chunks = malloc(n * sizeof *chunks);
        vw_mesh *meshes = calloc(n, sizeof *meshes);
        assert_non_null(chunks);
        assert_non_null(meshes);
        for (size_t k = 0; k < sizeof counts / sizeof counts[0]; k++) {
            /* Ascending on even passes, descending on odd ones, so every mesh is reused for
             * another chunk. */
            for (size_t i = 0; i < n; i++)
                chunks[i] = (uint32_t)(k & 1 ? n - 1 - i : i);
            assert_int_equal(vw_mesh_chunks(w, chunks, n, meshes, counts[k]), VW_OK);
            assert_meshes_serial(w, chunks, n, meshes);
        }
        /* One chunk asked for twice, and a batch smaller than the threads. */
        chunks[0] = chunks[1] = (uint32_t)(n / 2);
        assert_int_equal(vw_mesh_chunks(w, chunks, 2, meshes, 7), VW_OK);
        assert_meshes_serial(w, chunks, 2, meshes);
        /* Bad arguments: an index out of range (anywhere in the batch), NULLs; count 0. */
        chunks[1] = info.chunk_count;
        assert_int_equal(vw_mesh_chunks(w, chunks, 2, meshes, 2), VW_ERROR_INVALID_ARGUMENT);
        assert_int_equal(vw_mesh_chunks(NULL, chunks, 1, meshes, 2), VW_ERROR_INVALID_ARGUMENT);
        assert_int_equal(vw_mesh_chunks(w, NULL, 1, meshes, 2), VW_ERROR_INVALID_ARGUMENT);
        assert_int_equal(vw_mesh_chunks(w, chunks, 1, NULL, 2), VW_ERROR_INVALID_ARGUMENT);
        assert_int_equal(vw_mesh_chunks(w, NULL, 0, NULL, 2), VW_OK);
        for (size_t i = 0; i < n; i++)
            vw_mesh_free(&meshes[i]);
        free(meshes);
        free(chunks);
        vw_world_destroy(w);
    }
}

/* ---- OBJ export ------------------------------------------------------------------------ */

typedef struct obj {
    size_t objects, vertices, faces, bad_normals;
    long long min[3], max[3];
    uint32_t ids[64];
} obj;

static void parse_obj(const char *path, obj *out)
{
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    memset(out, 0, sizeof *out);
    for (int a = 0; a < 3; a++) {
        out->min[a] = INT64_MAX;
        out->max[a] = INT64_MIN;
    }
    long long (*v)[3] = malloc(sizeof *v * 100000);
    assert_non_null(v);
    char line[256];
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'o' && line[1] == ' ') {
            if (out->objects < 64)
                out->ids[out->objects] = (uint32_t)strtoul(line + 2, NULL, 10);
            out->objects++;
        } else if (line[0] == 'v' && line[1] == ' ') {
            long long p[3];
            assert_int_equal(sscanf(line + 2, "%lld %lld %lld", &p[0], &p[1], &p[2]), 3);
            assert_true(out->vertices < 100000);
            for (int a = 0; a < 3; a++) {
                v[out->vertices][a] = p[a];
                out->min[a] = p[a] < out->min[a] ? p[a] : out->min[a];
                out->max[a] = p[a] > out->max[a] ? p[a] : out->max[a];
            }
            out->vertices++;
        } else if (line[0] == 'f' && line[1] == ' ') {
            unsigned long i[4];
            assert_int_equal(sscanf(line + 2, "%lu %lu %lu %lu", &i[0], &i[1], &i[2], &i[3]), 4);
            for (int k = 0; k < 4; k++)
                assert_true(i[k] >= 1 && i[k] <= out->vertices);
            /* The face's normal (v1-v0) x (v2-v0) must point along one axis; its sign is
             * checked against the solid side below, through the voxel layout. */
            long long e1[3], e2[3], n[3];
            for (int a = 0; a < 3; a++) {
                e1[a] = v[i[1] - 1][a] - v[i[0] - 1][a];
                e2[a] = v[i[2] - 1][a] - v[i[0] - 1][a];
            }
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            int nonzero = (n[0] != 0) + (n[1] != 0) + (n[2] != 0);
            if (nonzero != 1)
                out->bad_normals++;
            out->faces++;
        }
    }
    fclose(f);
    free(v);
}

static void test_export_obj(void **state)
{
    (void)state;
    char path[512];
    snprintf(path, sizeof path, "%s/test_mesher_export.obj", VIS_BINARY_DIR);

    /* One voxel far away: a unit cube at exactly its absolute coordinates, faces outwards. */
    const int64_t o[3] = {1048576, -32, -1048576};
    vw_world *w = make_world(16, o, 32, 32, 32);
    const int64_t p[3] = {1048576 + 17, -32 + 3, -1048576 + 30};
    vw_world_set(w, p[0], p[1], p[2], 2);
    vw_error err;
    assert_int_equal(vw_export_obj(w, path, &err), VW_OK);
    obj r;
    parse_obj(path, &r);
    assert_int_equal(r.objects, 1);
    assert_int_equal(r.ids[0], vw_chunk_object_id(vw_world_chunk_index(w, 1, 0, 1)));
    assert_int_equal(r.faces, 6);
    assert_int_equal(r.vertices, 24);
    assert_int_equal(r.bad_normals, 0);
    for (int a = 0; a < 3; a++) {
        assert_int_equal(r.min[a], p[a]);
        assert_int_equal(r.max[a], p[a] + 1);
    }
    /* Winding: every face of a single cube must point away from its centre. */
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    char line[256];
    long long v[24][3];
    int nv = 0, outward = 0;
    while (fgets(line, sizeof line, f)) {
        if (line[0] == 'v')
            sscanf(line + 2, "%lld %lld %lld", &v[nv][0], &v[nv][1], &v[nv][2]), nv++;
        if (line[0] == 'f') {
            int i[4];
            sscanf(line + 2, "%d %d %d %d", &i[0], &i[1], &i[2], &i[3]);
            long long e1[3], e2[3], n[3], centre[3];
            for (int a = 0; a < 3; a++) {
                e1[a] = v[i[1] - 1][a] - v[i[0] - 1][a];
                e2[a] = v[i[2] - 1][a] - v[i[0] - 1][a];
                centre[a] = (v[i[0] - 1][a] + v[i[2] - 1][a]) * 2 - (2 * p[a] + 1) * 2; /* 4 x (face centre - cube centre) */
            }
            n[0] = e1[1] * e2[2] - e1[2] * e2[1];
            n[1] = e1[2] * e2[0] - e1[0] * e2[2];
            n[2] = e1[0] * e2[1] - e1[1] * e2[0];
            outward += n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2] > 0;
        }
    }
    fclose(f);
    assert_int_equal(outward, 6);
    vw_world_destroy(w);

    /* A random world: one object per chunk with a mesh, 4 vertices and one face per quad. */
    const int64_t o2[3] = {-16, 0, 32};
    w = make_world(16, o2, 48, 32, 32);
    uint64_t s = 31;
    randomise(w, &s, 20, 300);
    vw_mesh mesh = {NULL, 0, 0};
    size_t quads = 0, objects = 0;
    for (uint32_t i = 0; i < 12; i++) {
        vw_mesh_chunk(w, i, &mesh);
        quads += mesh.count;
        objects += mesh.count > 0;
    }
    vw_mesh_free(&mesh);
    assert_int_equal(vw_export_obj(w, path, &err), VW_OK);
    parse_obj(path, &r);
    assert_int_equal(r.objects, objects);
    assert_int_equal(r.faces, quads);
    assert_int_equal(r.vertices, 4 * quads);
    assert_int_equal(r.bad_normals, 0);
    for (size_t k = 1; k < r.objects && k < 64; k++)
        assert_true(r.ids[k] > r.ids[k - 1]);
    for (int a = 0; a < 3; a++) {
        assert_true(r.min[a] >= o2[a]);
        assert_true(r.max[a] <= o2[a] + (a == 0 ? 48 : 32));
    }
    remove(path);
    assert_int_equal(vw_export_obj(w, "/nonexistent-dir/x.obj", &err), VW_ERROR_IO);
    assert_true(strlen(err.message) > 0);
    vw_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_brute_force_random),
        cmocka_unit_test(test_checkerboard),
        cmocka_unit_test(test_world_edges),
        cmocka_unit_test(test_see_through),
        cmocka_unit_test(test_uniform_chunks),
        cmocka_unit_test(test_far_origin),
        cmocka_unit_test(test_mesh_capacity),
        cmocka_unit_test(test_recorded_meshes),
        cmocka_unit_test(test_mesh_chunks_threads),
        cmocka_unit_test(test_export_obj),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
