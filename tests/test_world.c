/* test_world.c — chunked storage: create limits, get/set against a reference array (also at
 * far negative origins), fill, uniform-chunk compaction, materials, dirty-chunk tracking. */
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

static vw_world *make_world(int32_t chunk, int64_t ox, int64_t oy, int64_t oz, int32_t sx, int32_t sy, int32_t sz)
{
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.chunk_size = chunk;
    d.origin[0] = ox;
    d.origin[1] = oy;
    d.origin[2] = oz;
    d.size[0] = sx;
    d.size[1] = sy;
    d.size[2] = sz;
    vw_world *w = NULL;
    vw_error err;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_OK);
    assert_non_null(w);
    return w;
}

static void test_create_limits(void **state)
{
    (void)state;
    vw_world_desc d;
    vw_world *w = (vw_world *)1;
    vw_error err;
    memset(&d, 0, sizeof d);
    d.size[0] = d.size[1] = d.size[2] = 16;
    d.chunk_size = 8;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    assert_null(w);
    assert_true(strlen(err.message) > 0);
    d.chunk_size = 0;
    d.size[1] = 0;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    d.size[1] = (1 << 20) + 1;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    d.size[0] = d.size[1] = d.size[2] = 1 << 20; /* 2^48 chunks: IDs would not fit */
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    d.size[0] = d.size[1] = d.size[2] = 16;
    d.origin[1] = 8; /* not a chunk multiple */
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_create(NULL, &w, &err), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_create(&d, NULL, NULL), VW_ERROR_INVALID_ARGUMENT);

    /* Sizes round up to chunk multiples; defaults fill in. */
    w = make_world(0, -32, 0, 64, 20, 1, 33);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.chunk_size, 16);
    assert_int_equal(info.size[0], 32);
    assert_int_equal(info.size[1], 16);
    assert_int_equal(info.size[2], 48);
    assert_int_equal(info.chunks[0], 2);
    assert_int_equal(info.chunks[2], 3);
    assert_int_equal(info.chunk_count, 6);
    assert_int_equal(info.nonempty_chunks, 0);
    assert_int_equal(info.solid_voxels, 0);
    assert_true(info.bytes > 0);
    vw_world_destroy(w);
    vw_world_destroy(NULL);

    for (int s = VW_OK; s <= VW_ERROR_RANGE; s++)
        assert_non_null(vw_status_string((vw_status)s));
    assert_string_not_equal(vw_status_string(VW_OK), vw_status_string(VW_ERROR_RANGE));
}

/* A reference copy of a world as a flat array, compared voxel by voxel. */
typedef struct ref {
    int64_t o[3];
    int32_t n[3];
    uint8_t *v;
} ref;

static uint8_t *ref_at(ref *r, int64_t x, int64_t y, int64_t z)
{
    return &r->v[(x - r->o[0]) + r->n[0] * ((y - r->o[1]) + (int64_t)r->n[1] * (z - r->o[2]))];
}

static void check_against_ref(const vw_world *w, ref *r)
{
    uint64_t solid = 0;
    for (int64_t z = r->o[2]; z < r->o[2] + r->n[2]; z++)
        for (int64_t y = r->o[1]; y < r->o[1] + r->n[1]; y++)
            for (int64_t x = r->o[0]; x < r->o[0] + r->n[0]; x++) {
                uint8_t want = *ref_at(r, x, y, z);
                if (vw_world_get(w, x, y, z) != want)
                    fail_msg("voxel (%lld,%lld,%lld): got %d, want %d", (long long)x, (long long)y, (long long)z,
                             vw_world_get(w, x, y, z), want);
                solid += want != 0;
            }
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, solid);
    /* Non-empty chunks agree with a recount. */
    uint32_t nonempty = 0;
    for (uint32_t i = 0; i < info.chunk_count; i++) {
        int32_t c[3];
        vw_world_chunk_coords(w, i, c);
        int any = 0;
        for (int z = 0; z < info.chunk_size && !any; z++)
            for (int y = 0; y < info.chunk_size && !any; y++)
                for (int x = 0; x < info.chunk_size && !any; x++)
                    any = vw_world_get(w, info.origin[0] + c[0] * info.chunk_size + x, info.origin[1] + c[1] * info.chunk_size + y,
                                       info.origin[2] + c[2] * info.chunk_size + z) != 0;
        assert_int_equal(vw_world_chunk_empty(w, i), !any);
        nonempty += (uint32_t)any;
    }
    assert_int_equal(info.nonempty_chunks, nonempty);
}

static void set_get_round_trip(int32_t chunk, int64_t ox, int64_t oy, int64_t oz, uint64_t seed)
{
    const int32_t n[3] = {2 * chunk + 5, chunk + 3, 3 * chunk - 1};
    vw_world *w = make_world(chunk, ox, oy, oz, n[0], n[1], n[2]);
    vw_world_info info;
    vw_world_get_info(w, &info);
    ref r = {{ox, oy, oz}, {info.size[0], info.size[1], info.size[2]}, NULL};
    r.v = calloc((size_t)r.n[0] * r.n[1] * r.n[2], 1);
    assert_non_null(r.v);
    uint64_t s = seed;
    const int edits = vt_small() ? 3000 : 30000;
    for (int i = 0; i < edits; i++) {
        int64_t x = ox + (int64_t)(vt_rand(&s) % (uint64_t)r.n[0]);
        int64_t y = oy + (int64_t)(vt_rand(&s) % (uint64_t)r.n[1]);
        int64_t z = oz + (int64_t)(vt_rand(&s) % (uint64_t)r.n[2]);
        /* Mostly a few materials, often air, so chunks fill up and empty out again. */
        uint8_t v = (uint8_t)(vt_rand(&s) % 4 == 0 ? 0 : 1 + vt_rand(&s) % 255);
        assert_int_equal(vw_world_set(w, x, y, z, v), VW_OK);
        *ref_at(&r, x, y, z) = v;
    }
    check_against_ref(w, &r);
    /* Outside the world: get is 0, set is a range error, even next to the int64 limits. */
    const int64_t outside[][3] = {{ox - 1, oy, oz}, {ox + r.n[0], oy, oz}, {ox, oy - 1, oz}, {ox, oy + r.n[1], oz},
                                  {ox, oy, oz + r.n[2]}, {INT64_MIN, oy, oz}, {INT64_MAX, INT64_MAX, INT64_MIN}};
    for (size_t i = 0; i < sizeof outside / sizeof outside[0]; i++) {
        assert_int_equal(vw_world_get(w, outside[i][0], outside[i][1], outside[i][2]), 0);
        assert_int_equal(vw_world_set(w, outside[i][0], outside[i][1], outside[i][2], 7), VW_ERROR_RANGE);
    }
    /* Clearing everything compacts every chunk back to nothing. */
    for (int64_t z = oz; z < oz + r.n[2]; z++)
        for (int64_t y = oy; y < oy + r.n[1]; y++)
            for (int64_t x = ox; x < ox + r.n[0]; x++)
                vw_world_set(w, x, y, z, 0);
    vw_world_info after;
    vw_world_get_info(w, &after);
    assert_int_equal(after.solid_voxels, 0);
    assert_int_equal(after.nonempty_chunks, 0);
    vw_world *fresh = make_world(chunk, ox, oy, oz, n[0], n[1], n[2]);
    vw_world_info fi;
    vw_world_get_info(fresh, &fi);
    assert_int_equal(after.bytes, fi.bytes);
    vw_world_destroy(fresh);
    free(r.v);
    vw_world_destroy(w);
}

static void test_set_get(void **state)
{
    (void)state;
    set_get_round_trip(16, 0, 0, 0, 1);
    set_get_round_trip(16, -1048576, -64, -((int64_t)1 << 40), 2);
    set_get_round_trip(32, (int64_t)1 << 50, -32, -1048576, 3);
    set_get_round_trip(32, -((int64_t)1 << 59), 0, 1024, 4);
}

static void test_fill(void **state)
{
    (void)state;
    const int64_t o[3] = {-1048576, -48, 1048576};
    vw_world *w = make_world(16, o[0], o[1], o[2], 64, 48, 64);
    ref r = {{o[0], o[1], o[2]}, {64, 48, 64}, calloc(64 * 48 * 64, 1)};
    assert_non_null(r.v);
    uint64_t s = 99;
    const int boxes = vt_small() ? 60 : 300;
    for (int i = 0; i < boxes; i++) {
        int64_t mn[3], mx[3];
        for (int a = 0; a < 3; a++) {
            /* Boxes may stick out of the world on any side. */
            int64_t lo = (int64_t)(vt_rand(&s) % (uint64_t)(r.n[a] + 20)) - 10;
            int64_t len = (int64_t)(vt_rand(&s) % 40);
            mn[a] = o[a] + lo;
            mx[a] = o[a] + lo + len;
        }
        uint8_t v = (uint8_t)(vt_rand(&s) % 3 == 0 ? 0 : 1 + vt_rand(&s) % 3);
        assert_int_equal(vw_world_fill(w, mn, mx, v), VW_OK);
        for (int64_t z = mn[2] > o[2] ? mn[2] : o[2]; z < mx[2] && z < o[2] + 64; z++)
            for (int64_t y = mn[1] > o[1] ? mn[1] : o[1]; y < mx[1] && y < o[1] + 48; y++)
                for (int64_t x = mn[0] > o[0] ? mn[0] : o[0]; x < mx[0] && x < o[0] + 64; x++)
                    *ref_at(&r, x, y, z) = v;
    }
    check_against_ref(w, &r);
    /* A box wholly outside, an empty box and an inverted one change nothing. */
    const int64_t far_min[3] = {0, 0, 0}, far_max[3] = {10, 10, 10};
    assert_int_equal(vw_world_fill(w, far_min, far_max, 5), VW_OK);
    const int64_t inv_min[3] = {o[0] + 10, o[1] + 10, o[2] + 10}, inv_max[3] = {o[0] + 5, o[1] + 20, o[2] + 20};
    assert_int_equal(vw_world_fill(w, inv_min, inv_max, 5), VW_OK);
    check_against_ref(w, &r);
    assert_int_equal(vw_world_fill(w, NULL, far_max, 1), VW_ERROR_INVALID_ARGUMENT);
    free(r.v);
    vw_world_destroy(w);
}

static void test_uniform_compaction(void **state)
{
    (void)state;
    vw_world *w = make_world(16, 160, -16, -4096, 48, 16, 16);
    vw_world_info empty, full, edited, restored;
    vw_world_get_info(w, &empty);
    /* Fill the whole world: every chunk becomes uniform, costing no voxel memory. */
    const int64_t mn[3] = {160, -16, -4096}, mx[3] = {160 + 48, 0, -4096 + 16};
    assert_int_equal(vw_world_fill(w, mn, mx, 9), VW_OK);
    vw_world_get_info(w, &full);
    assert_int_equal(full.bytes, empty.bytes);
    assert_int_equal(full.solid_voxels, 48 * 16 * 16);
    assert_int_equal(full.nonempty_chunks, 3);
    /* One edit makes that chunk dense (and only that one)... */
    assert_int_equal(vw_world_set(w, 160 + 20, -10, -4090, 4), VW_OK);
    vw_world_get_info(w, &edited);
    assert_int_equal(edited.bytes, empty.bytes + 16 * 16 * 16);
    assert_int_equal(vw_world_get(w, 160 + 20, -10, -4090), 4);
    assert_int_equal(vw_world_get(w, 160 + 21, -10, -4090), 9);
    assert_int_equal(vw_world_get(w, 160 + 19, -10, -4090), 9);
    assert_int_equal(edited.solid_voxels, 48 * 16 * 16);
    /* ...and undoing it compacts the chunk again. */
    assert_int_equal(vw_world_set(w, 160 + 20, -10, -4090, 9), VW_OK);
    vw_world_get_info(w, &restored);
    assert_int_equal(restored.bytes, empty.bytes);
    /* Digging a voxel out of a uniform chunk and putting back a different one. */
    assert_int_equal(vw_world_set(w, 160, -16, -4096, 0), VW_OK);
    vw_world_get_info(w, &edited);
    assert_int_equal(edited.solid_voxels, 48 * 16 * 16 - 1);
    assert_int_equal(vw_world_get(w, 160, -16, -4096), 0);
    assert_int_equal(vw_world_get(w, 161, -16, -4096), 9);
    /* A partial fill that completes a chunk with one value compacts it too. */
    const int64_t one_min[3] = {160, -16, -4096}, one_max[3] = {161, -15, -4095};
    assert_int_equal(vw_world_fill(w, one_min, one_max, 9), VW_OK);
    vw_world_get_info(w, &restored);
    assert_int_equal(restored.bytes, empty.bytes);
    vw_world_destroy(w);
}

static void test_materials(void **state)
{
    (void)state;
    vw_world *w = make_world(16, 0, 0, 0, 32, 16, 16);
    for (uint32_t i = 1; i < 256; i++) {
        const vw_material *m = vw_world_material(w, i);
        assert_non_null(m);
        assert_true(m->flags & VW_MAT_OPAQUE);
        assert_false(m->flags & VW_MAT_SEE_THROUGH);
        assert_true((m->rgba >> 24) == 0xFF);
    }
    assert_true(vw_world_material(w, 1)->rgba != vw_world_material(w, 2)->rgba);
    assert_null(vw_world_material(w, 256));
    vw_material glass = {0x80FFFFFFu, VW_MAT_SEE_THROUGH | VW_MAT_OPAQUE | VW_MAT_REFLECTIVE};
    assert_int_equal(vw_world_set_material(w, 0, &glass), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_set_material(w, 256, &glass), VW_ERROR_INVALID_ARGUMENT);
    assert_int_equal(vw_world_set_material(w, 5, NULL), VW_ERROR_INVALID_ARGUMENT);
    /* A voxel in chunk 1; a flags change makes its mesh stale. */
    assert_int_equal(vw_world_set(w, 20, 3, 3, 5), VW_OK);
    vw_world_clear_dirty(w);
    assert_int_equal(vw_world_set_material(w, 5, &glass), VW_OK);
    assert_int_equal(vw_world_material(w, 5)->flags, VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE);
    assert_int_equal(vw_world_material(w, 5)->rgba, 0x80FFFFFFu);
    uint32_t dirty[4];
    assert_int_equal(vw_world_take_dirty(w, dirty, 4), 1);
    assert_int_equal(dirty[0], 1);
    /* A colour change alone alters no mesh. */
    glass.rgba = 0x80000000u;
    assert_int_equal(vw_world_set_material(w, 5, &glass), VW_OK);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);
    vw_material plain = {0xFF00FF00u, 0};
    assert_int_equal(vw_world_set_material(w, 6, &plain), VW_OK);
    assert_int_equal(vw_world_material(w, 6)->flags, VW_MAT_OPAQUE);
    vw_world_destroy(w);
}

/* vw_world_box_opaque against a voxel-by-voxel answer: random boxes (empty, reaching outside
 * the world, across chunks) over a world at a negative origin with holes, a see-through
 * material and uniform chunks (opaque, see-through, air). */
static int box_opaque_ref(const vw_world *w, const int64_t lo[3], const int64_t hi[3])
{
    if (!(lo[0] < hi[0] && lo[1] < hi[1] && lo[2] < hi[2]))
        return 0;
    for (int64_t z = lo[2]; z < hi[2]; ++z)
        for (int64_t y = lo[1]; y < hi[1]; ++y)
            for (int64_t x = lo[0]; x < hi[0]; ++x) {
                vw_voxel v = vw_world_get(w, x, y, z);
                if (!v || (vw_world_material(w, v)->flags & VW_MAT_SEE_THROUGH))
                    return 0;
            }
    return 1;
}

static void test_box_opaque(void **state)
{
    (void)state;
    vw_world *w = make_world(16, -32, -16, -48, 64, 48, 64); /* x [-32, 32), y [-16, 32), z [-48, 16) */
    vw_material glass = {0xFFFFFFFFu, VW_MAT_SEE_THROUGH};
    assert_int_equal(vw_world_set_material(w, 7, &glass), VW_OK);
    int64_t all_lo[3] = {-32, -16, -48}, all_hi[3] = {32, 16, 16};
    assert_int_equal(vw_world_fill(w, all_lo, all_hi, 1), VW_OK); /* the lower two thirds opaque */
    uint64_t rng = 77;
    for (int i = 0; i < 300; ++i) /* holes and glass in the opaque part */
        assert_int_equal(vw_world_set(w, -32 + (int64_t)(vt_rand(&rng) % 64), -16 + (int64_t)(vt_rand(&rng) % 32),
                                      -48 + (int64_t)(vt_rand(&rng) % 64), (vw_voxel)(i % 3 == 0 ? 7 : 0)),
                         VW_OK);
    int64_t g_lo[3] = {0, 0, -16}, g_hi[3] = {16, 16, 0};
    assert_int_equal(vw_world_fill(w, g_lo, g_hi, 7), VW_OK); /* a uniform see-through chunk */
    int64_t lo[3] = {-32, -16, -48}, hi[3] = {-16, 0, -32}; /* a whole chunk, opaque */
    assert_int_equal(vw_world_fill(w, lo, hi, 2), VW_OK);
    assert_int_equal(vw_world_box_opaque(w, lo, hi), 1);
    int64_t out_hi[3] = {-16, 0, -32}, out_lo[3] = {-33, -16, -48}; /* one column outside */
    assert_int_equal(vw_world_box_opaque(w, out_lo, out_hi), 0);
    int64_t empty_hi[3] = {-32, 0, -32};
    assert_int_equal(vw_world_box_opaque(w, lo, empty_hi), 0);
    assert_int_equal(vw_world_box_opaque(w, g_lo, g_hi), 0);
    int opaque = 0;
    for (int i = 0; i < 4000; ++i) {
        int64_t a[3], b[3];
        for (int k = 0; k < 3; ++k) {
            int64_t o = k == 0 ? -34 : k == 1 ? -18 : -50, span = k == 1 ? 52 : 68;
            a[k] = o + (int64_t)(vt_rand(&rng) % (uint64_t)span);
            b[k] = a[k] + (int64_t)(vt_rand(&rng) % 9) - 1; /* empty, inverted, up to 7 wide */
        }
        int want = box_opaque_ref(w, a, b);
        int got = vw_world_box_opaque(w, a, b);
        if (got != want)
            fail_msg("box [%lld,%lld) x [%lld,%lld) x [%lld,%lld): %d, want %d", (long long)a[0], (long long)b[0],
                     (long long)a[1], (long long)b[1], (long long)a[2], (long long)b[2], got, want);
        opaque += want;
    }
    assert_true(opaque > 100); /* the random boxes are not all refused */
    vw_world_destroy(w);
}

static void test_chunk_index(void **state)
{
    (void)state;
    vw_world *w = make_world(16, -16, 32, 48, 48, 32, 80);
    vw_world_info info;
    vw_world_get_info(w, &info);
    for (int32_t cz = 0; cz < info.chunks[2]; cz++)
        for (int32_t cy = 0; cy < info.chunks[1]; cy++)
            for (int32_t cx = 0; cx < info.chunks[0]; cx++) {
                uint32_t i = vw_world_chunk_index(w, cx, cy, cz);
                assert_int_equal(i, (uint32_t)(cx + 3 * (cy + 2 * cz)));
                assert_int_equal(vw_chunk_object_id(i), i + 1);
                int32_t c[3];
                vw_world_chunk_coords(w, i, c);
                assert_int_equal(c[0], cx);
                assert_int_equal(c[1], cy);
                assert_int_equal(c[2], cz);
            }
    assert_int_equal(vw_world_chunk_index(w, 3, 0, 0), UINT32_MAX);
    assert_int_equal(vw_world_chunk_index(w, 0, -1, 0), UINT32_MAX);
    assert_true(vw_world_chunk_empty(w, info.chunk_count));
    vw_world_destroy(w);
}

/* Takes every dirty chunk into a sorted list. */
static size_t take_all(vw_world *w, uint32_t *out, size_t cap)
{
    size_t n = vw_world_take_dirty(w, out, cap);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);
    return n;
}

static void expect_dirty(vw_world *w, const uint32_t *want, size_t n_want)
{
    uint32_t got[64];
    size_t n = take_all(w, got, 64);
    if (n != n_want) {
        char buf[512] = "";
        for (size_t i = 0; i < n; i++)
            snprintf(buf + strlen(buf), sizeof buf - strlen(buf), " %u", got[i]);
        fail_msg("expected %zu dirty chunks, got %zu:%s", n_want, n, buf);
    }
    for (size_t i = 0; i < n; i++)
        assert_int_equal(got[i], want[i]);
}

/* More chunks than one word of the dirty summary covers (64 words of 64 chunks): dirty chunks
 * in several words of both summary words come back in ascending order, a few per call when
 * the caller's array is small, and each once. */
static void test_dirty_many_chunks(void **state)
{
    (void)state;
    vw_world *w = make_world(16, 0, 0, 0, 16 * 20, 16 * 16, 16 * 20); /* 6,400 chunks */
    const uint32_t want[] = {0, 63, 64, 200, 4095, 4096, 4160, 6399};
    const size_t n_want = sizeof want / sizeof want[0];
    for (size_t i = n_want; i-- > 0;) { /* marked in descending order: the order must not matter */
        int32_t c[3];
        vw_world_chunk_coords(w, want[i], c);
        assert_int_equal(vw_world_set(w, c[0] * 16 + 8, c[1] * 16 + 8, c[2] * 16 + 8, 1), VW_OK);
    }
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), n_want);
    uint32_t got[8];
    size_t taken = 0;
    for (size_t n; (n = vw_world_take_dirty(w, got, 3)) > 0; taken += n) {
        assert_true(n <= 3);
        for (size_t i = 0; i < n; i++)
            assert_int_equal(got[i], want[taken + i]);
        assert_int_equal(vw_world_take_dirty(w, NULL, 0), n_want - taken - n);
    }
    assert_int_equal(taken, n_want);
    /* Cleared, then marked again: the summary follows. */
    vw_world_set(w, 8, 8, 8, 0);
    vw_world_clear_dirty(w);
    assert_int_equal(vw_world_take_dirty(w, got, 8), 0);
    vw_world_set(w, 16 * 19 + 8, 16 * 15 + 8, 16 * 19 + 8, 0);
    assert_int_equal(vw_world_take_dirty(w, got, 8), 1);
    assert_int_equal(got[0], 6399);
    vw_world_destroy(w);
}

static void test_dirty(void **state)
{
    (void)state;
    /* 3x3x3 chunks of 16 at a far negative origin. */
    const int64_t o[3] = {-1048576, -4096, -16};
    vw_world *w = make_world(16, o[0], o[1], o[2], 48, 48, 48);
#define IDX(x, y, z) ((uint32_t)((x) + 3 * ((y) + 3 * (z))))
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);
    /* Inside the middle chunk: only it. */
    vw_world_set(w, o[0] + 20, o[1] + 20, o[2] + 20, 1);
    expect_dirty(w, (uint32_t[]){IDX(1, 1, 1)}, 1);
    /* At the middle chunk's minimum corner: it and its -x, -y, -z face neighbours, not the
     * diagonal ones. Ascending order. */
    vw_world_set(w, o[0] + 16, o[1] + 16, o[2] + 16, 2);
    expect_dirty(w, (uint32_t[]){IDX(1, 1, 0), IDX(1, 0, 1), IDX(0, 1, 1), IDX(1, 1, 1)}, 4);
    /* At its maximum corner: +x, +y, +z. */
    vw_world_set(w, o[0] + 31, o[1] + 31, o[2] + 31, 2);
    expect_dirty(w, (uint32_t[]){IDX(1, 1, 1), IDX(2, 1, 1), IDX(1, 2, 1), IDX(1, 1, 2)}, 4);
    /* On an edge of the world: no neighbour outside. */
    vw_world_set(w, o[0], o[1] + 5, o[2] + 47, 3);
    expect_dirty(w, (uint32_t[]){IDX(0, 0, 2)}, 1);
    /* Setting the same value again still marks (conservative). */
    vw_world_set(w, o[0] + 20, o[1] + 20, o[2] + 20, 1);
    expect_dirty(w, (uint32_t[]){IDX(1, 1, 1)}, 1);
    /* A range error marks nothing. */
    assert_int_equal(vw_world_set(w, o[0] - 1, o[1], o[2], 1), VW_ERROR_RANGE);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);

    /* Partial takes: capacity 2 of 4, ascending, then the rest. */
    vw_world_set(w, o[0] + 16, o[1] + 16, o[2] + 16, 0);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 4);
    uint32_t part[2];
    assert_int_equal(vw_world_take_dirty(w, part, 2), 2);
    assert_int_equal(part[0], IDX(1, 1, 0));
    assert_int_equal(part[1], IDX(1, 0, 1));
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 2);
    assert_int_equal(vw_world_take_dirty(w, part, 2), 2);
    assert_int_equal(part[0], IDX(0, 1, 1));
    assert_int_equal(part[1], IDX(1, 1, 1));
    assert_int_equal(vw_world_take_dirty(w, part, 2), 0);

    /* clear_dirty forgets everything. */
    vw_world_set(w, o[0] + 1, o[1] + 1, o[2] + 1, 1);
    vw_world_clear_dirty(w);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);

    /* Fill: chunks the box touches, plus across each box face lying on a chunk border.
     * Box x in [16, 40): its -x face is on a border (chunk 0 across it), its +x face is not;
     * y in [5, 10): inside chunk row 0, no border; z in [20, 32): +z face on a border. */
    const int64_t mn[3] = {o[0] + 16, o[1] + 5, o[2] + 20}, mx[3] = {o[0] + 40, o[1] + 10, o[2] + 32};
    assert_int_equal(vw_world_fill(w, mn, mx, 4), VW_OK);
    expect_dirty(w, (uint32_t[]){IDX(0, 0, 1), IDX(1, 0, 1), IDX(2, 0, 1), IDX(1, 0, 2), IDX(2, 0, 2)}, 5);
#undef IDX
    vw_world_destroy(w);
}

/* ---- the memory budget (vw_world_desc.max_bytes) ------------------------------------- */

/* A chunk table over the limit is refused before anything is allocated: by the default
 * (2 GiB) for a 2^30-chunk world (16 GiB of table), and by an explicit small limit. */
static void test_create_over_budget(void **state)
{
    (void)state;
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.size[0] = 1 << 20;
    d.size[1] = 1024;
    d.size[2] = 4096; /* 65536 x 64 x 256 = 2^30 chunks: below the ID limit, 16 GiB of table */
    vw_world *w = (vw_world *)1;
    vw_error err;
    err.message[0] = '\0';
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_BUDGET);
    assert_null(w);
    print_message("%s\n", err.message);
    assert_non_null(strstr(err.message, "16.1 GiB")); /* 16 bytes and a dirty bit per chunk */
    assert_non_null(strstr(err.message, "1,073,741,824 chunks"));
    assert_non_null(strstr(err.message, "2.0 GiB"));

    d.size[0] = d.size[1] = d.size[2] = 2048; /* 128^3 chunks: 32 MiB of table */
    d.max_bytes = 1 << 20;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_ERROR_BUDGET);
    assert_null(w);
    assert_non_null(strstr(err.message, "1.0 MiB"));
    d.max_bytes = 64ull << 20;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_OK);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.max_bytes, 64ull << 20);
    assert_true(info.bytes > 32ull << 20 && info.bytes <= info.max_bytes);
    vw_world_destroy(w);
}

static vw_world *world_with_limit(uint64_t max_bytes)
{
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.size[0] = d.size[1] = d.size[2] = 64; /* 4x4x4 chunks of 16 */
    d.max_bytes = max_bytes;
    vw_world *w = NULL;
    vw_error err;
    assert_int_equal(vw_world_create(&d, &w, &err), VW_OK);
    return w;
}

/* The world takes no more than its limit: the edit that would need one dense chunk too many
 * fails with VW_ERROR_BUDGET and changes nothing (voxels, totals, dirty chunks); uniform
 * chunks cost nothing, and memory freed by compaction can be used again. */
static void test_dense_growth_over_budget(void **state)
{
    (void)state;
    vw_world *w = world_with_limit(0);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.max_bytes, VW_DEFAULT_MAX_BYTES);
    const uint64_t table = info.bytes, chunk = 16 * 16 * 16;
    vw_world_destroy(w);

    w = world_with_limit(table + 3 * chunk);
    for (int i = 0; i < 3; i++)
        assert_int_equal(vw_world_set(w, 16 * i + 1, 2, 3, 5), VW_OK);
    vw_world_get_info(w, &info);
    assert_int_equal(info.bytes, table + 3 * chunk);
    assert_int_equal(info.max_bytes, table + 3 * chunk);
    vw_world_clear_dirty(w);

    /* A fourth chunk would go over. */
    assert_int_equal(vw_world_set(w, 49, 2, 3, 5), VW_ERROR_BUDGET);
    assert_int_equal(vw_world_get(w, 49, 2, 3), 0);
    const int64_t mn[3] = {40, 0, 40}, mx[3] = {56, 8, 56}; /* parts of 4 chunks, none dense */
    assert_int_equal(vw_world_fill(w, mn, mx, 7), VW_ERROR_BUDGET);
    for (int64_t z = 40; z < 56; z += 5)
        for (int64_t x = 40; x < 56; x += 5)
            assert_int_equal(vw_world_get(w, x, 3, z), 0);
    vw_world_info after;
    vw_world_get_info(w, &after);
    assert_int_equal(after.bytes, info.bytes);
    assert_int_equal(after.solid_voxels, 3);
    assert_int_equal(after.nonempty_chunks, 3);
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);

    /* Within the dense chunks, and whole chunks (uniform), edits still work. */
    assert_int_equal(vw_world_set(w, 2, 2, 3, 9), VW_OK);
    const int64_t c0[3] = {0, 48, 0}, c1[3] = {64, 64, 64}; /* 16 whole chunks */
    assert_int_equal(vw_world_fill(w, c0, c1, 3), VW_OK);
    vw_world_get_info(w, &after);
    assert_int_equal(after.bytes, table + 3 * chunk);
    assert_int_equal(after.solid_voxels, 4 + 64 * 16 * 64);

    /* Emptying a dense chunk frees it for another. */
    const int64_t e0[3] = {0, 0, 0}, e1[3] = {16, 16, 16};
    assert_int_equal(vw_world_fill(w, e0, e1, 0), VW_OK);
    assert_int_equal(vw_world_set(w, 49, 2, 3, 5), VW_OK);
    vw_world_get_info(w, &after);
    assert_int_equal(after.bytes, table + 3 * chunk);
    vw_world_destroy(w);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_create_limits),
        cmocka_unit_test(test_set_get),
        cmocka_unit_test(test_fill),
        cmocka_unit_test(test_uniform_compaction),
        cmocka_unit_test(test_materials),
        cmocka_unit_test(test_chunk_index),
        cmocka_unit_test(test_box_opaque),
        cmocka_unit_test(test_dirty),
        cmocka_unit_test(test_dirty_many_chunks),
        cmocka_unit_test(test_create_over_budget),
        cmocka_unit_test(test_dense_growth_over_budget),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
