/* test_vox.c — MagicaVoxel .vox import and export.
 *
 * - Synthetic files built here byte by byte: the coordinate mapping, every one of the 48
 *   rotation bytes and nested rotations against a double-precision evaluation of
 *   floor(R (p + 0.5 - floor(size/2)) + t) (the placement vengi documents for MagicaVoxel),
 *   DAG instancing, hidden nodes and layers, palettes, materials, IMAP, animation frame 0,
 *   unknown chunks.
 * - Bad files: each malformation of the issue, built in the test, must give
 *   VW_ERROR_FORMAT with the byte offset and chunk in the message, no world, no leak (the
 *   sanitizer build runs these too); every prefix and many byte flips of a valid file.
 * - The shared files (../shared/data/vox): the facts in ATTRIBUTION.md, plus the distinct
 *   voxel counts and voxel boxes of an independent float evaluation of the same placement.
 * - Export: random worlds, one larger than 256 per axis, one far from the origin, the
 *   empty world and a real scene go through vw_vox_save_file and back, voxel for voxel; a
 *   failed save (or vw_export_obj) leaves the old file and no temporary, and a device target
 *   is never removed.
 * - Crashes the fuzzer found, as inlined bytes (fuzz/fuzz_vox.c, docs/vox.md).
 * - The budget: hostile files refused by arithmetic before allocating; files that are not
 *   regular files, and large ones, refused from their type, size and header. */
#define _POSIX_C_SOURCE 200809L
#define _XOPEN_SOURCE 700 /* mknod and S_IFCHR, for the device-node outputs */
#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "../voxelworld/src/vox_format.h"
#include "run_tool.h"
#include "test_support.h"
#include "voxelworld/vw.h"

/* ---- a .vox builder ------------------------------------------------------------------ */

typedef struct vb {
    uint8_t *p;
    size_t n, cap;
} vb;

static void vb_raw(vb *b, const void *d, size_t n)
{
    if (b->n + n > b->cap) {
        size_t cap = b->cap ? b->cap : 256;
        while (cap < b->n + n)
            cap *= 2;
        b->p = realloc(b->p, cap);
        assert_non_null(b->p);
        b->cap = cap;
    }
    memcpy(b->p + b->n, d, n);
    b->n += n;
}

static void vb_u32(vb *b, uint32_t v)
{
    uint8_t x[4] = {(uint8_t)v, (uint8_t)(v >> 8), (uint8_t)(v >> 16), (uint8_t)(v >> 24)};
    vb_raw(b, x, 4);
}

static void vb_put32(vb *b, size_t at, uint32_t v)
{
    b->p[at] = (uint8_t)v, b->p[at + 1] = (uint8_t)(v >> 8), b->p[at + 2] = (uint8_t)(v >> 16),
    b->p[at + 3] = (uint8_t)(v >> 24);
}

static void vb_str(vb *b, const char *s)
{
    vb_u32(b, (uint32_t)strlen(s));
    vb_raw(b, s, strlen(s));
}

/* kv: pairs of key, value; NULL-terminated. */
static void vb_dict(vb *b, const char *const *kv)
{
    uint32_t n = 0;
    while (kv && kv[2 * n])
        n++;
    vb_u32(b, n);
    for (uint32_t i = 0; i < 2 * n; i++)
        vb_str(b, kv[i]);
}

static size_t vb_open(vb *b, const char *id)
{
    size_t at = b->n;
    vb_raw(b, id, 4);
    vb_u32(b, 0);
    vb_u32(b, 0);
    return at;
}

static void vb_close(vb *b, size_t at) { vb_put32(b, at + 4, (uint32_t)(b->n - at - 12)); }

static void vb_begin(vb *b, uint32_t version)
{
    memset(b, 0, sizeof *b);
    vb_raw(b, "VOX ", 4);
    vb_u32(b, version);
    vb_open(b, "MAIN");
}

static void vb_end(vb *b) { vb_put32(b, 16, (uint32_t)(b->n - 20)); }

/* A whole file of VERSION holding one chunk ID whose content is the N words W. */
static void vb_one_chunk(vb *b, uint32_t version, const char *id, const uint32_t *w, size_t n)
{
    vb_begin(b, version);
    size_t at = vb_open(b, id);
    for (size_t i = 0; i < n; i++)
        vb_u32(b, w[i]);
    vb_close(b, at);
    vb_end(b);
}

static void vb_free(vb *b)
{
    free(b->p);
    memset(b, 0, sizeof *b);
}

static void vb_model(vb *b, int sx, int sy, int sz, const uint8_t *xyzi, uint32_t count)
{
    size_t at = vb_open(b, "SIZE");
    vb_u32(b, (uint32_t)sx), vb_u32(b, (uint32_t)sy), vb_u32(b, (uint32_t)sz);
    vb_close(b, at);
    at = vb_open(b, "XYZI");
    vb_u32(b, count);
    vb_raw(b, xyzi, 4 * (size_t)count);
    vb_close(b, at);
}

/* nTRN with one frame; r, t, attr may be NULL. */
static void vb_trn(vb *b, int id, int child, int layer, const char *r, const char *t, const char *const *attr)
{
    size_t at = vb_open(b, "nTRN");
    vb_u32(b, (uint32_t)id);
    vb_dict(b, attr);
    vb_u32(b, (uint32_t)child), vb_u32(b, 0xFFFFFFFFu), vb_u32(b, (uint32_t)layer), vb_u32(b, 1);
    const char *kv[5] = {NULL};
    int k = 0;
    if (r)
        kv[k++] = "_r", kv[k++] = r;
    if (t)
        kv[k++] = "_t", kv[k++] = t;
    vb_dict(b, kv);
    vb_close(b, at);
}

static void vb_grp(vb *b, int id, int n, const int *children, const char *const *attr)
{
    size_t at = vb_open(b, "nGRP");
    vb_u32(b, (uint32_t)id);
    vb_dict(b, attr);
    vb_u32(b, (uint32_t)n);
    for (int i = 0; i < n; i++)
        vb_u32(b, (uint32_t)children[i]);
    vb_close(b, at);
}

static void vb_shp(vb *b, int id, int model)
{
    size_t at = vb_open(b, "nSHP");
    vb_u32(b, (uint32_t)id);
    vb_dict(b, NULL);
    vb_u32(b, 1);
    vb_u32(b, (uint32_t)model);
    vb_dict(b, NULL);
    vb_close(b, at);
}

static void vb_layr(vb *b, int id, int hidden)
{
    size_t at = vb_open(b, "LAYR");
    vb_u32(b, (uint32_t)id);
    const char *kv[] = {"_hidden", hidden ? "1" : "0", NULL};
    vb_dict(b, kv);
    vb_u32(b, 0xFFFFFFFFu);
    vb_close(b, at);
}

static void vb_matl(vb *b, int id, const char *const *kv)
{
    size_t at = vb_open(b, "MATL");
    vb_u32(b, (uint32_t)id);
    vb_dict(b, kv);
    vb_close(b, at);
}

/* The test palette: colour index i is 0xFF000000 | i * 0x010305 (distinct, not default). */
static uint32_t test_colour(uint32_t i) { return 0xFF000000u | (i * 0x010305u & 0xFFFFFFu); }

static void vb_rgba(vb *b)
{
    size_t at = vb_open(b, "RGBA");
    for (uint32_t i = 0; i < 256; i++)
        vb_u32(b, i < 255 ? test_colour(i + 1) : 0);
    vb_close(b, at);
}

static vw_status load_vb(const vb *b, vw_world **w, vw_vox_stats *st, vw_error *e)
{
    return vw_vox_load_memory_ex(b->p, b->n, 16, NULL, w, st, e);
}

/* The test model: 3x4x5 (odd and even edges), voxels at the corners and inside. */
static const uint8_t model_xyzi[] = {0, 0, 0, 1, 2, 3, 4, 7, 1, 0, 2, 255, 2, 0, 0, 9, 0, 3, 1, 10, 1, 2, 3, 11};
#define MODEL_N 6

/* A version-200 file that starts with the 3x4x5 model above (model 0). */
static void vb_begin_model(vb *b)
{
    vb_begin(b, 200);
    vb_model(b, 3, 4, 5, model_xyzi, MODEL_N);
}

/* ---- a double-precision reference placement ----------------------------------------- */

typedef struct ref_tf {
    double m[3][4];
} ref_tf;

/* Spec (c): row 0's non-zero entry in column bits 0-1, row 1's in bits 2-3, row 2's in the
 * remaining column; bits 4, 5, 6 negate rows 0, 1, 2. */
static ref_tf ref_make(int bits, double tx, double ty, double tz)
{
    ref_tf f;
    memset(&f, 0, sizeof f);
    int c0 = bits & 3, c1 = (bits >> 2) & 3;
    int c2 = 3 - c0 - c1;
    f.m[0][c0] = (bits & 16) ? -1.0 : 1.0;
    f.m[1][c1] = (bits & 32) ? -1.0 : 1.0;
    f.m[2][c2] = (bits & 64) ? -1.0 : 1.0;
    f.m[0][3] = tx, f.m[1][3] = ty, f.m[2][3] = tz;
    return f;
}

static ref_tf ref_mul(const ref_tf *a, const ref_tf *b)
{
    ref_tf r;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            double s = j == 3 ? a->m[i][3] : 0.0;
            for (int k = 0; k < 3; k++)
                s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    }
    return r;
}

/* World cell of model voxel p (model size s) under f. */
static void ref_place(const ref_tf *f, const int s[3], const uint8_t p[3], int64_t w[3])
{
    double c[3], q[3];
    for (int a = 0; a < 3; a++)
        c[a] = p[a] + 0.5 - (double)(s[a] / 2);
    for (int i = 0; i < 3; i++)
        q[i] = floor(f->m[i][0] * c[0] + f->m[i][1] * c[1] + f->m[i][2] * c[2] + f->m[i][3]);
    w[0] = (int64_t)q[0], w[1] = (int64_t)q[2], w[2] = -(int64_t)q[1] - 1;
}

static void expect_model_at(const vw_world *w, const ref_tf *f)
{
    const int s[3] = {3, 4, 5};
    for (int i = 0; i < MODEL_N; i++) {
        int64_t p[3];
        ref_place(f, s, &model_xyzi[4 * i], p);
        vw_voxel v = vw_world_get(w, p[0], p[1], p[2]);
        if (v != model_xyzi[4 * i + 3])
            fail_msg("voxel %d of the model: expected colour %d at (%lld, %lld, %lld), found %d", i,
                     model_xyzi[4 * i + 3], (long long)p[0], (long long)p[1], (long long)p[2], v);
    }
}

/* ---- synthetic files ---------------------------------------------------------------- */

/* No scene graph and no RGBA: the model sits at the identity with its pivot floor(size/2) at
 * 0, the default palette applies, and the axes map as vw.h says. */
static void test_mapping_and_default_palette(void **state)
{
    (void)state;
    vb b;
    vb_begin(&b, 150);
    vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_end(&b);
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error e;
    assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
    /* By hand: pivot (1, 2, 2); .vox (0,0,0) -> (-1,-2,-2) -> world (-1, -2, 1);
     * (2,3,4) -> (1,1,2) -> (1, 2, -2); (1,0,2) -> (0,-2,0) -> (0, 0, 1). */
    assert_int_equal(vw_world_get(w, -1, -2, 1), 1);
    assert_int_equal(vw_world_get(w, 1, 2, -2), 7);
    assert_int_equal(vw_world_get(w, 0, 0, 1), 255);
    ref_tf id = ref_make(4, 0, 0, 0);
    expect_model_at(w, &id);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, MODEL_N);
    /* The model box: .vox x [-1,2), y [-2,2), z [-2,3) -> world x [-1,2), y [-2,3), z [-2,2). */
    const int64_t lo[3] = {-1, -2, -2}, hi[3] = {2, 3, 2};
    for (int a = 0; a < 3; a++) {
        assert_int_equal(st.bounds_min[a], lo[a]);
        assert_int_equal(st.bounds_max[a], hi[a]);
        assert_int_equal(info.origin[a], -16); /* min rounded down to a chunk */
        assert_true(info.origin[a] + info.size[a] >= hi[a]);
        assert_true(info.size[a] <= 32);
    }
    /* The default palette of the format spec, section 8 (values copied from the spec). */
    assert_int_equal(vw_world_material(w, 1)->rgba, 0xffffffffu);
    assert_int_equal(vw_world_material(w, 2)->rgba, 0xffccffffu);
    assert_int_equal(vw_world_material(w, 7)->rgba, 0xffffccffu);
    assert_int_equal(vw_world_material(w, 216)->rgba, 0xff0000eeu);
    assert_int_equal(vw_world_material(w, 255)->rgba, 0xff111111u);
    for (int i = 1; i < 256; i++)
        assert_int_equal(vw_world_material(w, (uint32_t)i)->rgba, vw_vox_default_palette[i]);
    assert_int_equal(vw_world_material(w, 9)->flags, VW_MAT_OPAQUE);
    assert_int_equal(st.version, 150);
    assert_int_equal(st.models, 1);
    assert_int_equal(st.instances, 1);
    assert_int_equal(st.has_palette, 0);
    /* A loaded world starts with no dirty chunks. */
    assert_int_equal(vw_world_take_dirty(w, NULL, 0), 0);
    vw_world_destroy(w);

    /* Chunk size 32 works; anything else is an argument error. */
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 32, NULL, &w, &e), VW_OK);
    vw_world_get_info(w, &info);
    assert_int_equal(info.chunk_size, 32);
    assert_int_equal(vw_world_get(w, 1, 2, -2), 7);
    vw_world_destroy(w);
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 8, NULL, &w, &e), VW_ERROR_INVALID_ARGUMENT);
    assert_null(w);
    vb_free(&b);
}

static void build_one_transform(vb *b, int version, const char *r, const char *t)
{
    vb_begin(b, (uint32_t)version);
    vb_model(b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2};
    vb_grp(b, 1, 1, kids, NULL);
    vb_trn(b, 2, 3, 0, r, t, NULL);
    vb_shp(b, 3, 0);
    vb_end(b);
}

/* Every valid rotation byte (6 permutations x 8 sign sets), odd and even model edges. */
static void test_all_rotations(void **state)
{
    (void)state;
    int tested = 0;
    for (int bits = 0; bits < 128; bits++) {
        int c0 = bits & 3, c1 = (bits >> 2) & 3;
        if (c0 > 2 || c1 > 2 || c0 == c1)
            continue;
        char r[8];
        snprintf(r, sizeof r, "%d", bits);
        vb b;
        build_one_transform(&b, 200, r, "10 -20 30");
        vw_world *w = NULL;
        vw_vox_stats st;
        vw_error e;
        assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
        ref_tf f = ref_make(bits, 10, -20, 30);
        expect_model_at(w, &f);
        vw_world_info info;
        vw_world_get_info(w, &info);
        assert_int_equal(info.solid_voxels, MODEL_N);
        assert_int_equal(st.rotated_transforms, bits == 4 ? 0 : 1);
        vw_world_destroy(w);
        vb_free(&b);
        tested++;
    }
    assert_int_equal(tested, 48);
}

/* Rotations compose down the graph: parent * child, t = t_parent + R_parent t_child. */
static void test_nested_transforms(void **state)
{
    (void)state;
    static const int rots[] = {4, 105, 20, 36, 49, 81, 72, 41, 52, 98, 24, 17};
    int n = (int)(sizeof rots / sizeof rots[0]);
    for (int i = 0; i < n; i++) {
        int ra = rots[i], rb = rots[(i * 5 + 3) % n];
        char sa[8], sb[8];
        snprintf(sa, sizeof sa, "%d", ra);
        snprintf(sb, sizeof sb, "%d", rb);
        vb b;
        vb_begin(&b, 150);
        vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
        vb_trn(&b, 0, 1, -1, sa, "7 -3 11", NULL);
        const int kids[] = {2};
        vb_grp(&b, 1, 1, kids, NULL);
        vb_trn(&b, 2, 3, 0, sb, "-5 9 2", NULL);
        vb_shp(&b, 3, 0);
        vb_end(&b);
        vw_world *w = NULL;
        vw_error e;
        assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, NULL, &w, &e), VW_OK);
        ref_tf fa = ref_make(ra, 7, -3, 11), fb = ref_make(rb, -5, 9, 2);
        ref_tf f = ref_mul(&fa, &fb);
        expect_model_at(w, &f);
        vw_world_destroy(w);
        vb_free(&b);
    }
}

/* A group shared by two transforms is two instances; each visit of a rotated transform
 * counts. */
static void test_dag_instances(void **state)
{
    (void)state;
    vb b;
    vb_begin(&b, 200);
    vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_trn(&b, 0, 1, -1, NULL, NULL, NULL);
    const int top[] = {2, 3};
    vb_grp(&b, 1, 2, top, NULL);
    vb_trn(&b, 2, 4, 0, NULL, "0 0 0", NULL);
    vb_trn(&b, 3, 4, 0, "105", "100 0 0", NULL);
    const int shared[] = {5};
    vb_grp(&b, 4, 1, shared, NULL);
    vb_trn(&b, 5, 6, -1, "20", "1 2 3", NULL);
    vb_shp(&b, 6, 0);
    vb_end(&b);
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error e;
    assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
    assert_int_equal(st.instances, 2);
    assert_int_equal(st.instanced_voxels, 2 * MODEL_N);
    assert_int_equal(st.rotated_transforms, 3); /* node 3 once, node 5 on both paths */
    assert_int_equal(st.nodes[0], 4);
    assert_int_equal(st.nodes[1], 2);
    assert_int_equal(st.nodes[2], 1);
    ref_tf inner = ref_make(20, 1, 2, 3), a = ref_make(4, 0, 0, 0), c = ref_make(105, 100, 0, 0);
    ref_tf fa = ref_mul(&a, &inner), fc = ref_mul(&c, &inner);
    expect_model_at(w, &fa);
    expect_model_at(w, &fc);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, 2 * MODEL_N);
    vw_world_destroy(w);
    vb_free(&b);
}

/* Hidden transforms, hidden groups and hidden layers are skipped. */
static void test_hidden(void **state)
{
    (void)state;
    static const char *const hidden[] = {"_hidden", "1", NULL};
    static const char *const shown[] = {"_hidden", "0", "_name", "x", NULL};
    vb b;
    vb_begin(&b, 200);
    vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_trn(&b, 0, 1, -1, NULL, NULL, NULL);
    const int top[] = {2, 3, 4, 5};
    vb_grp(&b, 1, 4, top, NULL);
    vb_trn(&b, 2, 10, 0, NULL, "0 0 0", shown);   /* visible                       */
    vb_trn(&b, 3, 10, 0, NULL, "50 0 0", hidden); /* hidden node                   */
    vb_trn(&b, 4, 10, 1, NULL, "100 0 0", NULL);  /* in hidden layer 1             */
    vb_trn(&b, 5, 6, 0, NULL, "150 0 0", NULL);
    const int g[] = {7};
    vb_grp(&b, 6, 1, g, hidden); /* hidden group                  */
    vb_trn(&b, 7, 10, -1, NULL, NULL, NULL);
    vb_shp(&b, 10, 0);
    vb_layr(&b, 0, 0);
    vb_layr(&b, 1, 1);
    vb_end(&b);
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error e;
    assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
    assert_int_equal(st.instances, 1);
    assert_int_equal(st.hidden_instances, 3);
    assert_int_equal(st.layers, 2);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, MODEL_N);
    ref_tf f = ref_make(4, 0, 0, 0);
    expect_model_at(w, &f);
    /* The world covers the visible instance only: x in [-1, 2), not out to 150. */
    assert_int_equal(st.bounds_min[0], -1);
    assert_int_equal(st.bounds_max[0], 2);
    assert_int_equal(info.size[0], 32);
    vw_world_destroy(w);
    vb_free(&b);
}

/* RGBA entry i is colour i + 1; MATL/MATT types map to flags as docs/vox.md says. */
static void test_palette_and_materials(void **state)
{
    (void)state;
    vb b;
    vb_begin(&b, 200);
    uint8_t xyzi[4 * 12];
    for (int i = 0; i < 12; i++)
        xyzi[4 * i] = (uint8_t)i, xyzi[4 * i + 1] = 0, xyzi[4 * i + 2] = 0, xyzi[4 * i + 3] = (uint8_t)(i + 1);
    vb_model(&b, 12, 1, 1, xyzi, 12);
    vb_rgba(&b);
    static const char *const m1[] = {"_type", "_glass", "_trans", "0.3", NULL};
    static const char *const m2[] = {"_type", "_blend", "_rough", "0.1", NULL};
    static const char *const m3[] = {"_type", "_blend", "_trans", "0.5", NULL};
    static const char *const m4[] = {"_type", "_metal", "_rough", "0.1", NULL};
    static const char *const m5[] = {"_type", "_metal", "_rough", "0.5", NULL};
    static const char *const m6[] = {"_type", "_cloud", NULL};
    static const char *const m7[] = {"_type", "_media", NULL};
    static const char *const m8[] = {"_type", "_diffuse", "_weight", "1", NULL};
    static const char *const m9[] = {"_type", "_blend", "_metal", "1", "_rough", "1e-1", NULL};
    static const char *const m11[] = {"_type", "_emit", "_emit", "1", NULL};
    static const char *const m12[] = {"_type", "_diffuse", "_vw_flags", "6", NULL};
    vb_matl(&b, 1, m1), vb_matl(&b, 2, m2), vb_matl(&b, 3, m3), vb_matl(&b, 4, m4), vb_matl(&b, 5, m5);
    vb_matl(&b, 6, m6), vb_matl(&b, 7, m7), vb_matl(&b, 8, m8), vb_matl(&b, 9, m9), vb_matl(&b, 11, m11);
    vb_matl(&b, 12, m12);
    vb_matl(&b, 256, m1); /* 256 is the unused slot 0: ignored */
    /* MATT (format spec section 9): id 10, glass, weight 1, no properties. */
    size_t at = vb_open(&b, "MATT");
    vb_u32(&b, 10), vb_u32(&b, 2), vb_u32(&b, 0x3F800000u), vb_u32(&b, 0);
    vb_close(&b, at);
    vb_end(&b);
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error e;
    assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
    assert_int_equal(st.has_palette, 1);
    for (uint32_t i = 1; i < 256; i++)
        assert_int_equal(vw_world_material(w, i)->rgba, test_colour(i));
    static const uint32_t want[13] = {0,
                                      VW_MAT_SEE_THROUGH,
                                      VW_MAT_OPAQUE,
                                      VW_MAT_SEE_THROUGH,
                                      VW_MAT_OPAQUE | VW_MAT_REFLECTIVE,
                                      VW_MAT_OPAQUE,
                                      VW_MAT_SEE_THROUGH,
                                      VW_MAT_SEE_THROUGH,
                                      VW_MAT_OPAQUE,
                                      VW_MAT_OPAQUE | VW_MAT_REFLECTIVE,
                                      VW_MAT_SEE_THROUGH,
                                      VW_MAT_OPAQUE,
                                      VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE};
    for (uint32_t i = 1; i <= 12; i++)
        if (vw_world_material(w, i)->flags != want[i])
            fail_msg("material %u: flags %u, expected %u", i, vw_world_material(w, i)->flags, want[i]);
    assert_int_equal(vw_world_material(w, 13)->flags, VW_MAT_OPAQUE);
    vw_world_destroy(w);
    vb_free(&b);
}

/* IMAP renumbers colours into display order; every voxel keeps its colour and material. */
static void test_index_map(void **state)
{
    (void)state;
    for (int valid = 0; valid < 2; valid++) {
        vb b;
        vb_begin(&b, 150);
        const uint8_t xyzi[] = {0, 0, 0, 1, 1, 0, 0, 2, 2, 0, 0, 3};
        vb_model(&b, 3, 1, 1, xyzi, 3);
        vb_rgba(&b);
        static const char *const glass[] = {"_type", "_glass", NULL};
        vb_matl(&b, 1, glass);
        uint8_t imap[256];
        for (int k = 0; k < 256; k++)
            imap[k] = (uint8_t)((k + 1) & 255);
        /* Display slot 0 shows colour 3, slot 2 shows colour 1. */
        imap[0] = 3, imap[2] = valid ? 1 : 3;
        size_t at = vb_open(&b, "IMAP");
        vb_raw(&b, imap, 256);
        vb_close(&b, at);
        vb_end(&b);
        vw_world *w = NULL;
        vw_vox_stats st;
        vw_error e;
        assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
        assert_int_equal(st.has_index_map, valid);
        /* World x of .vox x = 0, 1, 2 (pivot 1): -1, 0, 1; y = z = 0 -> world y 0, z -1. */
        const uint8_t want_valid[3] = {3, 2, 1}, want_ignored[3] = {1, 2, 3};
        for (int i = 0; i < 3; i++) {
            vw_voxel v = vw_world_get(w, -1 + i, 0, -1);
            assert_int_equal(v, valid ? want_valid[i] : want_ignored[i]);
            assert_int_equal(vw_world_material(w, v)->rgba, test_colour((uint32_t)i + 1));
            assert_int_equal(vw_world_material(w, v)->flags, i == 0 ? VW_MAT_SEE_THROUGH : VW_MAT_OPAQUE);
        }
        vw_world_destroy(w);
        vb_free(&b);
    }
}

/* Animated transforms and shapes are sampled at frame 0 (the smallest _f). */
static void test_animation_frame_zero(void **state)
{
    (void)state;
    vb b;
    vb_begin(&b, 200);
    vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
    const uint8_t other[] = {0, 0, 0, 5};
    vb_model(&b, 1, 1, 1, other, 1);
    vb_trn(&b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2};
    vb_grp(&b, 1, 1, kids, NULL);
    size_t at = vb_open(&b, "nTRN");
    vb_u32(&b, 2);
    vb_dict(&b, NULL);
    vb_u32(&b, 3), vb_u32(&b, 0xFFFFFFFFu), vb_u32(&b, 0), vb_u32(&b, 3);
    static const char *const f10[] = {"_f", "10", "_t", "100 0 0", "_r", "20", NULL};
    static const char *const f0[] = {"_f", "0", "_t", "4 5 6", "_r", "105", NULL};
    static const char *const f20[] = {"_f", "20", "_t", "-100 0 0", NULL};
    vb_dict(&b, f10), vb_dict(&b, f0), vb_dict(&b, f20);
    vb_close(&b, at);
    at = vb_open(&b, "nSHP");
    vb_u32(&b, 3);
    vb_dict(&b, NULL);
    vb_u32(&b, 2);
    static const char *const s5[] = {"_f", "5", NULL};
    static const char *const s0[] = {"_f", "0", NULL};
    vb_u32(&b, 1), vb_dict(&b, s5);
    vb_u32(&b, 0), vb_dict(&b, s0);
    vb_close(&b, at);
    vb_end(&b);
    vw_world *w = NULL;
    vw_vox_stats st;
    vw_error e;
    assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
    ref_tf f = ref_make(105, 4, 5, 6);
    expect_model_at(w, &f);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, MODEL_N);
    vw_world_destroy(w);
    vb_free(&b);
}

/* Chunks we do not use are skipped by their sizes, children included. */
static void test_unknown_chunks(void **state)
{
    (void)state;
    vb b;
    vb_begin(&b, 150);
    size_t at = vb_open(&b, "PACK");
    vb_u32(&b, 1);
    vb_close(&b, at);
    at = vb_open(&b, "rOBJ");
    static const char *const kv[] = {"_type", "_bloom", "_mix", "0.5", NULL};
    vb_dict(&b, kv);
    vb_close(&b, at);
    vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
    at = vb_open(&b, "NOTE");
    vb_u32(&b, 1);
    vb_str(&b, "name");
    vb_close(&b, at);
    /* An unknown chunk with 3 content bytes and a child chunk. */
    at = vb_open(&b, "ZZZZ");
    vb_raw(&b, "abc", 3);
    vb_close(&b, at);
    size_t child = vb_open(&b, "YYYY");
    vb_u32(&b, 42);
    vb_close(&b, child);
    vb_put32(&b, at + 8, (uint32_t)(b.n - child));
    at = vb_open(&b, "rCAM");
    vb_u32(&b, 0);
    vb_dict(&b, kv);
    vb_close(&b, at);
    vb_end(&b);
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 0, NULL, &w, &e), VW_OK);
    ref_tf f = ref_make(4, 0, 0, 0);
    expect_model_at(w, &f);
    vw_world_destroy(w);
    vb_free(&b);
}

/* ---- bad files ---------------------------------------------------------------------- */

typedef struct bad_case {
    const char *name;
    void (*build)(vb *b);
    vw_status status;
    const char *chunk; /* expected in the message, e.g. "'XYZI'"                             */
} bad_case;

static void bad_magic(vb *b)
{
    build_one_transform(b, 150, NULL, NULL);
    memcpy(b->p, "VOX!", 4);
}
static void bad_version(vb *b) { build_one_transform(b, 151, NULL, NULL); }
static void bad_short_header(vb *b)
{
    memset(b, 0, sizeof *b);
    vb_raw(b, "VOX ", 4);
}
static void bad_not_main(vb *b)
{
    build_one_transform(b, 150, NULL, NULL);
    memcpy(b->p + 8, "MAIX", 4);
}
static void bad_main_overflow(vb *b)
{
    build_one_transform(b, 150, NULL, NULL);
    vb_put32(b, 16, 0x7FFFFFF0u);
}
static void bad_chunk_overflow(vb *b)
{
    vb_begin(b, 150);
    size_t at = vb_open(b, "SIZE");
    vb_u32(b, 1), vb_u32(b, 1), vb_u32(b, 1);
    vb_put32(b, at + 4, 0x7FFFFFF0u);
    vb_end(b);
}
static void bad_negative_chunk_size(vb *b)
{
    vb_begin(b, 150);
    size_t at = vb_open(b, "RGBA");
    vb_put32(b, at + 4, 0xFFFFFFFFu);
    vb_end(b);
}
static void bad_negative_children(vb *b)
{
    vb_begin(b, 150);
    size_t at = vb_open(b, "NOTE");
    vb_put32(b, at + 8, 0x80000000u);
    vb_end(b);
}
static void bad_truncated_chunk_header(vb *b)
{
    build_one_transform(b, 150, NULL, NULL);
    vb_raw(b, "nTR", 3);
    vb_end(b);
}
static void bad_size_zero(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 0, 4, 5, model_xyzi, 0);
    vb_end(b);
}
static void bad_size_negative(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 3, -4, 5, model_xyzi, 0);
    vb_end(b);
}
static void bad_size_absurd(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 100000, 100000, 100000, model_xyzi, 0);
    vb_end(b);
}
static void bad_size_short(vb *b)
{
    vb_begin(b, 150);
    size_t at = vb_open(b, "SIZE");
    vb_u32(b, 3), vb_u32(b, 4);
    vb_close(b, at);
    vb_end(b);
}
static void bad_xyzi_count_beyond_chunk(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_put32(b, b->n - 4 * MODEL_N - 4, 1000);
    vb_end(b);
}
static void bad_xyzi_count_overflow(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_put32(b, b->n - 4 * MODEL_N - 4, 0x40000001u); /* 4 * count wraps in 32 bits */
    vb_end(b);
}
static void bad_xyzi_negative_count(vb *b)
{
    vb_begin(b, 150);
    vb_model(b, 3, 4, 5, model_xyzi, MODEL_N);
    vb_put32(b, b->n - 4 * MODEL_N - 4, 0xFFFFFFFEu);
    vb_end(b);
}
static void bad_xyzi_outside_model(vb *b)
{
    vb_begin(b, 150);
    const uint8_t v[] = {0, 0, 0, 1, 3, 0, 0, 1};
    vb_model(b, 3, 4, 5, v, 2);
    vb_end(b);
}
static void bad_xyzi_without_size(vb *b)
{
    static const uint32_t w[] = {0};
    vb_one_chunk(b, 150, "XYZI", w, sizeof w / sizeof w[0]);
}
static void bad_size_without_xyzi(vb *b)
{
    static const uint32_t w[] = {1, 1, 1};
    vb_one_chunk(b, 150, "SIZE", w, sizeof w / sizeof w[0]);
}
static void bad_rgba_short(vb *b)
{
    static const uint32_t w[] = {0xFFFFFFFFu};
    vb_one_chunk(b, 150, "RGBA", w, sizeof w / sizeof w[0]);
}
static void bad_loop(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2, 3};
    vb_grp(b, 1, 2, kids, NULL);
    vb_shp(b, 2, 0);
    vb_trn(b, 3, 1, 0, NULL, NULL, NULL); /* back to the group */
    vb_end(b);
}
static void bad_self_loop(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 0, -1, NULL, NULL, NULL);
    vb_end(b);
}
static void bad_missing_child(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 99, -1, NULL, NULL, NULL);
    vb_end(b);
}
static void bad_missing_group_child(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2, 7};
    vb_grp(b, 1, 2, kids, NULL);
    vb_shp(b, 2, 0);
    vb_end(b);
}
static void bad_missing_model(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    vb_shp(b, 1, 5);
    vb_end(b);
}
static void bad_no_root(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 1, 2, -1, NULL, NULL, NULL);
    vb_shp(b, 2, 0);
    vb_end(b);
}
static void bad_duplicate_node(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    vb_shp(b, 1, 0);
    vb_shp(b, 1, 0);
    vb_end(b);
}
static void bad_negative_node_id(vb *b)
{
    vb_begin(b, 200);
    vb_shp(b, -3, 0);
    vb_end(b);
}
static void bad_negative_group_count(vb *b)
{
    vb_begin(b, 200);
    const int none[] = {0};
    vb_grp(b, 1, 0, none, NULL);
    vb_put32(b, b->n - 4, 0xFFFFFFFFu);
    vb_end(b);
}
static void bad_group_count_beyond_chunk(vb *b)
{
    vb_begin(b, 200);
    const int kids[] = {2};
    vb_grp(b, 1, 1, kids, NULL);
    vb_put32(b, b->n - 8, 5000);
    vb_end(b);
}
static void bad_negative_shape_models(vb *b)
{
    static const uint32_t w[] = {1, 0 /* empty dict */, 0x80000000u};
    vb_one_chunk(b, 200, "nSHP", w, sizeof w / sizeof w[0]);
}
static void bad_negative_dict(vb *b)
{
    static const uint32_t w[] = {0, 0xFFFFFFFFu};
    vb_one_chunk(b, 200, "nTRN", w, sizeof w / sizeof w[0]);
}
static void bad_negative_string(vb *b)
{
    static const uint32_t w[] = {0, 1, 0xFFFFFFF0u};
    vb_one_chunk(b, 200, "LAYR", w, sizeof w / sizeof w[0]);
}
static void bad_string_beyond_chunk(vb *b)
{
    vb_begin(b, 200);
    size_t at = vb_open(b, "MATL");
    vb_u32(b, 1);
    vb_u32(b, 1);
    vb_u32(b, 200);
    vb_raw(b, "_type", 5);
    vb_close(b, at);
    vb_end(b);
}
static void bad_dict_count_huge(vb *b)
{
    static const uint32_t w[] = {1, 0x7FFFFFFFu};
    vb_one_chunk(b, 200, "nGRP", w, sizeof w / sizeof w[0]);
}
static void bad_frames_negative(vb *b)
{
    static const uint32_t w[] = {0, 0 /* empty dict */, 1, 0xFFFFFFFFu, 0, 0xFFFFFFFFu};
    vb_one_chunk(b, 200, "nTRN", w, sizeof w / sizeof w[0]);
}
static void bad_rotation_column(vb *b) { build_one_transform(b, 200, "15", "0 0 0"); }
static void bad_rotation_repeat(vb *b) { build_one_transform(b, 200, "5", "0 0 0"); }
static void bad_rotation_text(vb *b) { build_one_transform(b, 200, "4x", "0 0 0"); }
static void bad_translation(vb *b) { build_one_transform(b, 200, NULL, "1 2"); }
static void bad_translation_range(vb *b) { build_one_transform(b, 200, NULL, "0 99999999999 0"); }
static void bad_world_too_wide(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2, 3};
    vb_grp(b, 1, 2, kids, NULL);
    vb_trn(b, 2, 4, 0, NULL, "2000000000 0 0", NULL);
    vb_trn(b, 3, 4, 0, NULL, "-2000000000 0 0", NULL);
    vb_shp(b, 4, 0);
    vb_end(b);
}
static void bad_world_too_many_chunks(vb *b)
{
    /* 12 instances spread 100,000 apart on each axis: each axis is allowed, the volume is not. */
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int kids[] = {2, 3, 4, 5};
    vb_grp(b, 1, 4, kids, NULL);
    vb_trn(b, 2, 9, 0, NULL, "0 0 0", NULL);
    vb_trn(b, 3, 9, 0, NULL, "900000 0 0", NULL);
    vb_trn(b, 4, 9, 0, NULL, "0 900000 0", NULL);
    vb_trn(b, 5, 9, 0, NULL, "0 0 900000", NULL);
    vb_shp(b, 9, 0);
    vb_end(b);
}
/* 2^40 paths through 40 doubly-linked groups. */
static void dag_bomb(vb *b, int with_shape)
{
    vb_begin_model(b);
    int levels = 40;
    for (int l = 0; l < levels; l++) {
        vb_trn(b, 2 * l, 2 * l + 1, -1, NULL, "1 0 0", NULL);
        const int kids[] = {2 * l + 2, 2 * l + 2};
        if (l + 1 < levels || with_shape)
            vb_grp(b, 2 * l + 1, 2, kids, NULL);
        else
            vb_grp(b, 2 * l + 1, 0, kids, NULL);
    }
    if (with_shape)
        vb_shp(b, 2 * levels, 0);
    vb_end(b);
}
static void bad_dag_bomb_instances(vb *b) { dag_bomb(b, 1); }
static void bad_dag_bomb_visits(vb *b) { dag_bomb(b, 0); }

static const bad_case bad_cases[] = {
    {"wrong magic", bad_magic, VW_ERROR_FORMAT, "file header"},
    {"unknown version", bad_version, VW_ERROR_UNSUPPORTED, "file header"},
    {"4-byte file", bad_short_header, VW_ERROR_FORMAT, "file header"},
    {"first chunk not MAIN", bad_not_main, VW_ERROR_FORMAT, "'MAIN'"},
    {"MAIN past the end", bad_main_overflow, VW_ERROR_FORMAT, "'MAIN'"},
    {"chunk size overflow", bad_chunk_overflow, VW_ERROR_FORMAT, "'SIZE'"},
    {"negative chunk size", bad_negative_chunk_size, VW_ERROR_FORMAT, "'RGBA'"},
    {"negative children size", bad_negative_children, VW_ERROR_FORMAT, "'NOTE'"},
    {"truncated chunk header", bad_truncated_chunk_header, VW_ERROR_FORMAT, "byte offset"},
    {"SIZE 0", bad_size_zero, VW_ERROR_FORMAT, "'SIZE'"},
    {"SIZE negative", bad_size_negative, VW_ERROR_FORMAT, "'SIZE'"},
    {"SIZE absurd", bad_size_absurd, VW_ERROR_FORMAT, "'SIZE'"},
    {"SIZE short", bad_size_short, VW_ERROR_FORMAT, "'SIZE'"},
    {"XYZI count beyond chunk", bad_xyzi_count_beyond_chunk, VW_ERROR_FORMAT, "'XYZI'"},
    {"XYZI count overflow", bad_xyzi_count_overflow, VW_ERROR_FORMAT, "'XYZI'"},
    {"XYZI negative count", bad_xyzi_negative_count, VW_ERROR_FORMAT, "'XYZI'"},
    {"XYZI voxel outside", bad_xyzi_outside_model, VW_ERROR_FORMAT, "'XYZI'"},
    {"XYZI without SIZE", bad_xyzi_without_size, VW_ERROR_FORMAT, "'XYZI'"},
    {"SIZE without XYZI", bad_size_without_xyzi, VW_ERROR_FORMAT, "'SIZE'"},
    {"RGBA short", bad_rgba_short, VW_ERROR_FORMAT, "'RGBA'"},
    {"scene graph loop", bad_loop, VW_ERROR_FORMAT, "loop"},
    {"scene graph self loop", bad_self_loop, VW_ERROR_FORMAT, "'nTRN'"},
    {"missing child", bad_missing_child, VW_ERROR_FORMAT, "'nTRN'"},
    {"missing group child", bad_missing_group_child, VW_ERROR_FORMAT, "'nGRP'"},
    {"missing model", bad_missing_model, VW_ERROR_FORMAT, "'nSHP'"},
    {"no root node", bad_no_root, VW_ERROR_FORMAT, "root"},
    {"duplicate node id", bad_duplicate_node, VW_ERROR_FORMAT, "'nSHP'"},
    {"negative node id", bad_negative_node_id, VW_ERROR_FORMAT, "'nSHP'"},
    {"negative group count", bad_negative_group_count, VW_ERROR_FORMAT, "'nGRP'"},
    {"group count beyond chunk", bad_group_count_beyond_chunk, VW_ERROR_FORMAT, "'nGRP'"},
    {"negative shape model count", bad_negative_shape_models, VW_ERROR_FORMAT, "'nSHP'"},
    {"negative DICT size", bad_negative_dict, VW_ERROR_FORMAT, "'nTRN'"},
    {"negative STRING length", bad_negative_string, VW_ERROR_FORMAT, "'LAYR'"},
    {"STRING beyond chunk", bad_string_beyond_chunk, VW_ERROR_FORMAT, "'MATL'"},
    {"DICT count huge", bad_dict_count_huge, VW_ERROR_FORMAT, "'nGRP'"},
    {"negative frame count", bad_frames_negative, VW_ERROR_FORMAT, "'nTRN'"},
    {"rotation column 3", bad_rotation_column, VW_ERROR_FORMAT, "'nTRN'"},
    {"rotation repeats a column", bad_rotation_repeat, VW_ERROR_FORMAT, "'nTRN'"},
    {"rotation not a number", bad_rotation_text, VW_ERROR_FORMAT, "'nTRN'"},
    {"translation of 2 numbers", bad_translation, VW_ERROR_FORMAT, "'nTRN'"},
    {"translation beyond int32", bad_translation_range, VW_ERROR_FORMAT, "'nTRN'"},
    {"world too wide", bad_world_too_wide, VW_ERROR_FORMAT, "axis"},
    {"world too many chunks", bad_world_too_many_chunks, VW_ERROR_FORMAT, "chunks"},
    {"DAG of 2^40 instances", bad_dag_bomb_instances, VW_ERROR_FORMAT, "instances"},
    {"DAG of 2^40 empty paths", bad_dag_bomb_visits, VW_ERROR_FORMAT, "visits"},
};

static void test_bad_files(void **state)
{
    (void)state;
    for (size_t i = 0; i < sizeof bad_cases / sizeof bad_cases[0]; i++) {
        const bad_case *bc = &bad_cases[i];
        vb b;
        bc->build(&b);
        vw_world *w = (vw_world *)&b; /* must be reset to NULL */
        vw_error e;
        memset(&e, 0, sizeof e);
        vw_status s = vw_vox_load_memory(b.p, b.n, 16, NULL, &w, &e);
        if (s != bc->status)
            fail_msg("%s: status %s, expected %s (%s)", bc->name, vw_status_string(s), vw_status_string(bc->status),
                     e.message);
        assert_null(w);
        if (!strstr(e.message, "byte offset") || !strstr(e.message, bc->chunk))
            fail_msg("%s: message \"%s\" lacks the offset or \"%s\"", bc->name, e.message, bc->chunk);
        vb_free(&b);
    }
}

/* A file using most features, for truncation and byte flips. */
static void build_rich(vb *b)
{
    vb_begin_model(b);
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    const int top[] = {2, 3};
    vb_grp(b, 1, 2, top, NULL);
    vb_trn(b, 2, 4, 0, "105", "5 6 7", NULL);
    vb_trn(b, 3, 4, 1, "20", "-5 6 -7", NULL);
    vb_shp(b, 4, 0);
    vb_layr(b, 0, 0);
    vb_layr(b, 1, 0);
    vb_rgba(b);
    static const char *const glass[] = {"_type", "_glass", "_rough", "0.1", NULL};
    vb_matl(b, 7, glass);
    vb_end(b);
}

/* Every prefix of a valid file is an error; no prefix crashes or leaks. */
static void test_truncated(void **state)
{
    (void)state;
    vb b;
    build_rich(&b);
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, NULL, &w, &e), VW_OK);
    vw_world_destroy(w);
    for (size_t n = 0; n < b.n; n++) {
        uint8_t *copy = malloc(n ? n : 1); /* exact size: ASan sees any overread */
        memcpy(copy, b.p, n);
        vw_status s = vw_vox_load_memory(copy, n, 16, NULL, &w, &e);
        if (s != VW_ERROR_FORMAT)
            fail_msg("prefix of %zu bytes: %s", n, vw_status_string(s));
        assert_null(w);
        free(copy);
    }
    vb_free(&b);
}

/* Byte flips anywhere: any status, but no crash, no leak, no overread. */
static void test_byte_flips(void **state)
{
    (void)state;
    vb b;
    build_rich(&b);
    static const uint8_t values[] = {0x00, 0x01, 0x7F, 0x80, 0xFF};
    for (size_t i = 0; i < b.n; i++) {
        for (size_t k = 0; k < sizeof values; k++) {
            uint8_t *copy = malloc(b.n);
            memcpy(copy, b.p, b.n);
            copy[i] = values[k];
            vw_world *w = NULL;
            vw_error e;
            vw_status s = vw_vox_load_memory(copy, b.n, 16, NULL, &w, &e);
            if (s == VW_OK)
                vw_world_destroy(w);
            else
                assert_null(w);
            free(copy);
        }
    }
    vb_free(&b);
}

static void test_limits(void **state)
{
    (void)state;
    vb b;
    dag_bomb(&b, 1);
    vw_vox_limits lim = {0};
    lim.max_instances = 4;
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_vox_load_memory_ex(b.p, b.n, 16, &lim, &w, NULL, &e), VW_ERROR_FORMAT);
    assert_null(w);
    assert_non_null(strstr(e.message, "more than 4 instances"));
    vb_free(&b);

    assert_int_equal(vw_vox_load_file("/nonexistent/dir/x.vox", 16, NULL, &w, &e), VW_ERROR_IO);
    assert_null(w);
    assert_int_equal(vw_vox_load_memory(NULL, 0, 16, NULL, &w, &e), VW_ERROR_FORMAT);
}

/* Many layers times a wide DAG: the hidden-layer lookup must not be per visit and linear
 * (20,000 layers x 2^17 visits would take minutes). */
static void test_many_layers_wide_dag(void **state)
{
    (void)state;
    for (int hide = 0; hide < 2; hide++) {
        vb b;
        vb_begin(&b, 200);
        vb_model(&b, 3, 4, 5, model_xyzi, MODEL_N);
        int levels = 16;
        for (int l = 0; l < levels; l++) {
            vb_trn(&b, 2 * l, 2 * l + 1, l == 0 ? 7 : -1, NULL, l % 2 ? "1 0 0" : "0 0 1", NULL);
            const int kids[] = {2 * l + 2, 2 * l + 2};
            vb_grp(&b, 2 * l + 1, 2, kids, NULL);
        }
        vb_shp(&b, 2 * levels, 0);
        /* Layer 7 (the top transform's) is hidden in the second file: it hides everything. */
        for (int i = 0; i < 20000; i++)
            vb_layr(&b, i, i == 19999 || (hide && i == 7));
        vb_end(&b);
        vw_world *w = NULL;
        vw_vox_stats st;
        vw_error e;
        assert_int_equal(load_vb(&b, &w, &st, &e), VW_OK);
        assert_int_equal(st.instances, hide ? 0 : 1u << levels);
        assert_int_equal(st.hidden_instances, hide ? 1u << levels : 0);
        assert_int_equal(st.layers, 20000);
        vw_world_info info;
        vw_world_get_info(w, &info);
        assert_int_equal(info.solid_voxels == 0, hide);
        vw_world_destroy(w);
        vb_free(&b);
    }
}

/* ---- the shared files (ATTRIBUTION.md) ---------------------------------------------- */

typedef struct vox_fact {
    const char *file;
    /* From ATTRIBUTION.md. */
    uint32_t version, models;
    int32_t largest[3];
    uint64_t xyzi;
    uint32_t inst;
    uint64_t instvox;
    uint32_t rot;
    uint32_t graph[4]; /* nTRN / nGRP / nSHP / LAYR */
    int64_t world[3];  /* .vox x, y, z extents */
    /* From an independent float evaluation of the same placement (vengi's bake formula,
     * floor(M (p + 0.5 - floor(size/2)))) over the same files: distinct solid voxels after
     * overlapping instances merge, and their box in world coordinates. */
    uint64_t distinct;
    int64_t vlo[3], vhi[3];
} vox_fact;

static const vox_fact facts[] = {
    {"mmmm_scene_store8.vox", 150, 1, {124, 124, 68}, 441118, 1, 441118, 0, {0, 0, 0, 0}, {124, 124, 68},
     441118, {-60, -34, -62}, {57, 27, 62}},
    {"mmmm_scene_church1.vox", 150, 1, {124, 124, 68}, 181774, 1, 181774, 0, {0, 0, 0, 0}, {124, 124, 68},
     181774, {-62, -34, -62}, {62, -10, 61}},
    {"mmmm_scene_house6.vox", 150, 1, {126, 126, 64}, 207466, 1, 207466, 0, {0, 0, 0, 0}, {126, 126, 64},
     207466, {-63, -32, -63}, {63, 32, 61}},
    {"mmmm_scene_riot.vox", 150, 1, {126, 126, 32}, 163171, 1, 163171, 0, {0, 0, 0, 0}, {126, 126, 32},
     163171, {-60, -16, -63}, {63, 12, 37}},
    {"vengi_test-transform.vox", 150, 3, {128, 128, 128}, 126806, 20, 621232, 23, {11, 3, 3, 8}, {256, 256, 129},
     621096, {-129, 0, -128}, {127, 50, 128}},
    {"vengi_test_material.vox", 200, 12, {40, 40, 40}, 768000, 12, 768000, 0, {13, 1, 12, 16}, {342, 40, 202},
     768000, {-23, 0, -20}, {319, 202, 20}},
    {"vengi_8ontop.vox", 150, 8, {12, 14, 1}, 1344, 72, 12096, 72, {73, 1, 72, 32}, {452, 491, 80},
     8946, {-213, 7, -244}, {239, 87, 247}},
    {"ogt_test_multiple_model_scene.vox", 150, 41, {8, 8, 8}, 6053, 104, 12926, 87, {105, 1, 43, 8}, {106, 106, 16},
     12926, {23, 6, -92}, {129, 22, 14}},
};

/* The exact box of the solid voxels, scanning non-empty chunks. */
static uint64_t solid_box(const vw_world *w, int64_t lo[3], int64_t hi[3])
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    uint64_t n = 0;
    int32_t C = info.chunk_size;
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
                    for (int a = 0; a < 3; a++) {
                        if (n == 0 || p[a] < lo[a])
                            lo[a] = p[a];
                        if (n == 0 || p[a] + 1 > hi[a])
                            hi[a] = p[a] + 1;
                    }
                    n++;
                }
    }
    return n;
}

static void test_shared_files(void **state)
{
    (void)state;
    int found = 0;
    for (size_t i = 0; i < sizeof facts / sizeof facts[0]; i++) {
        const vox_fact *f = &facts[i];
        char rel[128];
        snprintf(rel, sizeof rel, "vox/%s", f->file);
        const char *path = vt_shared_file(rel);
        if (!path) {
            printf("SKIP: %s absent; its ATTRIBUTION facts are not checked (synthetic cases still ran)\n", f->file);
            continue;
        }
        size_t size = 0;
        void *data = vt_read_file(path, &size);
        assert_non_null(data);
        for (int cs = 16; cs <= 32; cs += 16) {
            vw_world *w = NULL;
            vw_vox_stats st;
            vw_error e;
            vw_status s = vw_vox_load_memory_ex(data, size, cs, NULL, &w, &st, &e);
            if (s != VW_OK)
                fail_msg("%s: %s", f->file, e.message);
            assert_int_equal(st.version, f->version);
            assert_int_equal(st.models, f->models);
            for (int a = 0; a < 3; a++)
                assert_int_equal(st.largest_model[a], f->largest[a]);
            assert_int_equal(st.model_voxels, f->xyzi);
            assert_int_equal(st.instances, f->inst);
            assert_int_equal(st.hidden_instances, 0);
            assert_int_equal(st.instanced_voxels, f->instvox);
            assert_int_equal(st.rotated_transforms, f->rot);
            for (int k = 0; k < 3; k++)
                assert_int_equal(st.nodes[k], f->graph[k]);
            assert_int_equal(st.layers, f->graph[3]);
            assert_int_equal(st.has_palette, 1);
            /* "world" is the .vox box (x, y, z); in world axes that is (x, z, y). */
            const int64_t want[3] = {f->world[0], f->world[2], f->world[1]};
            vw_world_info info;
            vw_world_get_info(w, &info);
            for (int a = 0; a < 3; a++) {
                if (st.bounds_max[a] - st.bounds_min[a] != want[a])
                    fail_msg("%s: world extent %lld on axis %d, ATTRIBUTION says %lld", f->file,
                             (long long)(st.bounds_max[a] - st.bounds_min[a]), a, (long long)want[a]);
                /* Origin: the min corner rounded down to a chunk; size: the least cover. */
                assert_true(info.origin[a] % cs == 0);
                assert_true(info.origin[a] <= st.bounds_min[a] && st.bounds_min[a] < info.origin[a] + cs);
                assert_true(info.origin[a] + info.size[a] >= st.bounds_max[a]);
                assert_true(info.origin[a] + info.size[a] - cs < st.bounds_max[a]);
            }
            assert_int_equal(info.solid_voxels, f->distinct);
            assert_true(info.solid_voxels <= st.instanced_voxels);
            int64_t lo[3], hi[3];
            assert_int_equal(solid_box(w, lo, hi), f->distinct);
            for (int a = 0; a < 3; a++) {
                assert_int_equal(lo[a], f->vlo[a]);
                assert_int_equal(hi[a], f->vhi[a]);
                assert_true(lo[a] >= st.bounds_min[a] && hi[a] <= st.bounds_max[a]);
            }
            vw_world_destroy(w);
        }
        /* The file helper reads the same thing. */
        vw_world *w = NULL;
        vw_error e;
        assert_int_equal(vw_vox_load_file(path, 16, NULL, &w, &e), VW_OK);
        vw_world_info info;
        vw_world_get_info(w, &info);
        assert_int_equal(info.solid_voxels, f->distinct);
        vw_world_destroy(w);
        free(data);
        found++;
    }
    printf("shared .vox files checked against ATTRIBUTION.md: %d of %zu\n", found, sizeof facts / sizeof facts[0]);
    if ((size_t)found != sizeof facts / sizeof facts[0])
        skip(); /* not every file was checked: the SKIP lines above say which */
}

/* The one material file: which of its MATL entries are see-through (docs/vox.md). */
static void test_shared_materials(void **state)
{
    (void)state;
    const char *path = vt_shared_file("vox/vengi_test_material.vox");
    if (!path)
        skip(); /* vt_shared_file printed why */
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_vox_load_file(path, 16, NULL, &w, &e), VW_OK);
    /* _blend with _trans 0.5 or 1 (ids 190, 194, 197, 199) is see-through; the other _blend
     * entries have no transparency and stay opaque; 158 is a smooth full metal. */
    int see = 0, refl = 0;
    for (uint32_t i = 1; i < 256; i++) {
        uint32_t fl = vw_world_material(w, i)->flags;
        see += (fl & VW_MAT_SEE_THROUGH) != 0;
        refl += (fl & VW_MAT_REFLECTIVE) != 0;
    }
    assert_int_equal(see, 4);
    assert_true(vw_world_material(w, 190)->flags & VW_MAT_SEE_THROUGH);
    assert_true(vw_world_material(w, 199)->flags & VW_MAT_SEE_THROUGH);
    assert_int_equal(refl, 1);
    assert_true(vw_world_material(w, 158)->flags & VW_MAT_REFLECTIVE);
    vw_world_destroy(w);
}

/* ---- export round trips ------------------------------------------------------------- */

static const char *tmp_path(void) { return VIS_BINARY_DIR "/test_vox_roundtrip.vox"; }

/* Every voxel of a is in b at p + shift, b holds no others, and the materials match. */
static void expect_same(const vw_world *a, const vw_world *b, const int64_t shift[3])
{
    vw_world_info ia, ib;
    vw_world_get_info(a, &ia);
    vw_world_get_info(b, &ib);
    assert_int_equal(ia.solid_voxels, ib.solid_voxels);
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
                    vw_voxel va = vw_world_get(a, p[0], p[1], p[2]);
                    vw_voxel vb2 = vw_world_get(b, p[0] + shift[0], p[1] + shift[1], p[2] + shift[2]);
                    if (va != vb2)
                        fail_msg("voxel (%lld, %lld, %lld): %d before, %d after", (long long)p[0], (long long)p[1],
                                 (long long)p[2], va, vb2);
                    used[va] = 1;
                }
    }
    for (uint32_t m = 1; m < 256; m++) {
        if (!used[m])
            continue;
        assert_int_equal(vw_world_material(a, m)->rgba, vw_world_material(b, m)->rgba);
        assert_int_equal(vw_world_material(a, m)->flags, vw_world_material(b, m)->flags);
    }
}

static vw_world *random_world(uint64_t seed, const int64_t origin[3], const int32_t size[3], double density)
{
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.chunk_size = 16;
    memcpy(d.origin, origin, sizeof d.origin);
    memcpy(d.size, size, sizeof d.size);
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_world_create(&d, &w, &e), VW_OK);
    uint64_t rs = seed;
    for (uint32_t m = 1; m < 256; m++) {
        vw_material mat;
        mat.rgba = (uint32_t)vt_rand(&rs);
        uint32_t k = (uint32_t)(vt_rand(&rs) % 4);
        mat.flags = k == 0 ? VW_MAT_OPAQUE
                  : k == 1 ? VW_MAT_SEE_THROUGH
                  : k == 2 ? (VW_MAT_OPAQUE | VW_MAT_REFLECTIVE)
                           : (VW_MAT_SEE_THROUGH | VW_MAT_REFLECTIVE);
        assert_int_equal(vw_world_set_material(w, m, &mat), VW_OK);
    }
    for (int64_t z = 0; z < size[2]; z++)
        for (int64_t y = 0; y < size[1]; y++)
            for (int64_t x = 0; x < size[0]; x++)
                if (vt_rand_unit(&rs) < density)
                    vw_world_set(w, origin[0] + x, origin[1] + y, origin[2] + z, (vw_voxel)(1 + vt_rand(&rs) % 255));
    /* The far corners, so that the box is the whole world. */
    vw_world_set(w, origin[0], origin[1], origin[2], 3);
    vw_world_set(w, origin[0] + size[0] - 1, origin[1] + size[1] - 1, origin[2] + size[2] - 1, 200);
    return w;
}

static void round_trip(const vw_world *a, const int64_t shift[3], uint32_t want_models)
{
    vw_error e;
    assert_int_equal(vw_vox_save_file(a, tmp_path(), &e), VW_OK);
    vw_world *b = NULL;
    assert_int_equal(vw_vox_load_file(tmp_path(), 16, NULL, &b, &e), VW_OK);
    expect_same(a, b, shift);
    vw_world_destroy(b);
    /* The memory writer gives the same bytes as the file writer. */
    size_t fsize = 0;
    void *fdata = vt_read_file(tmp_path(), &fsize);
    void *mdata = NULL;
    size_t msize = 0;
    assert_int_equal(vw_vox_save_memory(a, &mdata, &msize, &e), VW_OK);
    assert_int_equal(fsize, msize);
    assert_memory_equal(fdata, mdata, msize);
    vw_vox_stats st;
    assert_int_equal(vw_vox_load_memory_ex(mdata, msize, 16, NULL, NULL, &st, &e), VW_OK);
    assert_int_equal(st.version, 200);
    if (want_models)
        assert_int_equal(st.models, want_models);
    free(fdata);
    free(mdata);
    remove(tmp_path());
}

static void test_export_random(void **state)
{
    (void)state;
    const int64_t zero[3] = {0, 0, 0};
    int reps = vt_small() ? 2 : 6;
    for (int r = 0; r < reps; r++) {
        const int64_t origin[3] = {-48 + 16 * r, 16, -32 * r};
        const int32_t size[3] = {40 + 7 * r, 33, 50 - 3 * r};
        vw_world *a = random_world(1234 + (uint64_t)r, origin, size, 0.3);
        round_trip(a, zero, 1);
        vw_world_destroy(a);
    }
}

/* Larger than 256 on two axes: several models placed by the scene graph. */
static void test_export_large(void **state)
{
    (void)state;
    const int64_t zero[3] = {0, 0, 0};
    const int64_t origin[3] = {-320, -16, 64};
    const int32_t size[3] = {600, 40, 300};
    vw_world *a = random_world(99, origin, size, vt_small() ? 0.002 : 0.02);
    /* Tiles of 256 from the origin: 3 x 1 x 2, all non-empty at this density. */
    round_trip(a, zero, 6);
    vw_world_destroy(a);
}

/* Beyond int32: written relative to the world's origin. */
static void test_export_far(void **state)
{
    (void)state;
    const int64_t origin[3] = {(int64_t)1 << 40, -((int64_t)1 << 41), 16 * 12345};
    const int32_t size[3] = {64, 48, 32};
    vw_world *a = random_world(7, origin, size, 0.2);
    const int64_t shift[3] = {-origin[0], -origin[1], -origin[2]};
    round_trip(a, shift, 1);
    vw_world_destroy(a);
}

static void test_export_empty(void **state)
{
    (void)state;
    const int64_t origin[3] = {0, 0, 0};
    vw_world_desc d;
    memset(&d, 0, sizeof d);
    d.size[0] = d.size[1] = d.size[2] = 32;
    memcpy(d.origin, origin, sizeof origin);
    vw_world *a = NULL;
    vw_error e;
    assert_int_equal(vw_world_create(&d, &a, &e), VW_OK);
    round_trip(a, origin, 1);
    vw_world_destroy(a);
}

/* A real scene with rotated, shared instances: import, export, import. */
static void test_export_shared_file(void **state)
{
    (void)state;
    static const char *const files[] = {"vox/vengi_test-transform.vox", "vox/ogt_test_multiple_model_scene.vox"};
    int missing = 0;
    for (int i = 0; i < 2; i++) {
        const char *path = vt_shared_file(files[i]);
        if (!path) {
            missing++;
            continue;
        }
        vw_world *a = NULL;
        vw_error e;
        assert_int_equal(vw_vox_load_file(path, 16, NULL, &a, &e), VW_OK);
        const int64_t zero[3] = {0, 0, 0};
        round_trip(a, zero, 0);
        vw_world_destroy(a);
    }
    if (missing)
        skip(); /* vt_shared_file printed why */
}

/* ---- crashes found by the fuzzer (fuzz/fuzz_vox.c) ----------------------------------- */

static void test_fuzz_regressions(void **state)
{
    (void)state;
    /* None yet: each crash the fuzzer finds lands here as inlined bytes. */
}

/* ---- the budget (vw_budget) and hostile files ---------------------------------------- */

/* Group `group` of count transforms first.. (at most 64), transform i moving `child` by
 * 256 i along .vox axis `axis`. */
static void vb_row(vb *b, int group, int first, int count, int child, int axis)
{
    int kids[64];
    char t[64];
    for (int i = 0; i < count; i++)
        kids[i] = first + i;
    vb_grp(b, group, count, kids, NULL);
    for (int i = 0; i < count; i++) {
        int d[3] = {0, 0, 0};
        d[axis] = 256 * i;
        snprintf(t, sizeof t, "%d %d %d", d[0], d[1], d[2]);
        vb_trn(b, first + i, child, -1, NULL, t, NULL);
    }
}

/* A sparse 256^3 model, one voxel every 16 per axis (4,096 voxels, each alone in its chunk),
 * instanced nx * nz times through a two-level DAG (nx transforms sharing one group of nz):
 * the file stays small (about 20 KB for 32 x 32) while every instanced voxel lands in a chunk of
 * its own. 32 x 32 spans 512 x 16 x 512 chunks (the loader's chunk limit) and touches all
 * 4,194,304 of them: 16 GiB of dense chunks. */
static void sparse_dag(vb *b, int nx, int nz)
{
    vb_begin(b, 200);
    uint8_t *xyzi = malloc(4 * 4096);
    assert_non_null(xyzi);
    uint32_t n = 0;
    for (int z = 0; z < 16; z++)
        for (int y = 0; y < 16; y++)
            for (int x = 0; x < 16; x++, n++) {
                xyzi[4 * n] = (uint8_t)(16 * x), xyzi[4 * n + 1] = (uint8_t)(16 * y);
                xyzi[4 * n + 2] = (uint8_t)(16 * z), xyzi[4 * n + 3] = 1;
            }
    vb_model(b, 256, 256, 256, xyzi, n);
    free(xyzi);
    /* 0 -> group 1 -> transforms 2.. (x = 256 i) -> group 1000 -> transforms 1001.. (.vox
     * y = 256 j) -> shape 3000. */
    vb_trn(b, 0, 1, -1, NULL, NULL, NULL);
    vb_row(b, 1, 2, nx, 1000, 0);
    vb_row(b, 1000, 1001, nz, 3000, 1);
    vb_shp(b, 3000, 0);
    vb_end(b);
}

static double seconds_now(void)
{
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The 20 KB file that asked for 16 GiB: refused by arithmetic, before the world exists. */
static void test_budget_instanced_dag(void **state)
{
    (void)state;
    vb b;
    sparse_dag(&b, 32, 32);
    assert_true(b.n < 24000); /* about 20 KB */
    vw_world *w = (vw_world *)1;
    vw_error e;
    e.message[0] = '\0';
    double t0 = seconds_now();
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, NULL, &w, &e), VW_ERROR_BUDGET);
    double dt = seconds_now() - t0;
    assert_null(w);
    print_message("%zu-byte file refused in %.3f s: %s\n", b.n, dt, e.message);
    assert_true(dt < 5.0);
    assert_non_null(strstr(e.message, "16.0 GiB"));
    assert_non_null(strstr(e.message, "4,194,304 dense chunks"));
    assert_non_null(strstr(e.message, "2.0 GiB"));
    /* Statistics (no world) still parse it. */
    vw_vox_stats st;
    assert_int_equal(vw_vox_load_memory_ex(b.p, b.n, 16, NULL, NULL, &st, &e), VW_OK);
    assert_int_equal(st.instances, 1024);
    assert_int_equal(st.instanced_voxels, 1024u * 4096u);
    vb_free(&b);
}

/* The precheck is exact: a budget of exactly what the world holds loads, one byte less does
 * not; max_voxels counts each instance's solid voxels. */
static void test_budget_exact(void **state)
{
    (void)state;
    vb b;
    sparse_dag(&b, 2, 1); /* 8,192 voxels in 8,192 chunks of a 32 x 16 x 16 chunk world */
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, NULL, &w, &e), VW_OK);
    vw_world_info info;
    vw_world_get_info(w, &info);
    assert_int_equal(info.solid_voxels, 8192);
    assert_int_equal(info.chunk_count, 8192);
    assert_int_equal(info.max_bytes, VW_DEFAULT_MAX_BYTES);
    const uint64_t need = info.bytes;
    assert_true(need > 8192u * 4096u);
    vw_world_destroy(w);

    vw_budget budget = {need, 0};
    w = NULL;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, &budget, &w, &e), VW_OK);
    vw_world_get_info(w, &info);
    assert_int_equal(info.bytes, need);
    assert_int_equal(info.max_bytes, need);
    vw_world_destroy(w);
    budget.max_bytes = need - 1;
    w = (vw_world *)1;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, &budget, &w, &e), VW_ERROR_BUDGET);
    assert_null(w);
    assert_non_null(strstr(e.message, "8,192 dense chunks"));

    budget.max_bytes = 0;
    budget.max_voxels = 8191;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, &budget, &w, &e), VW_ERROR_BUDGET);
    assert_null(w);
    assert_non_null(strstr(e.message, "8,191"));
    budget.max_voxels = 8192;
    assert_int_equal(vw_vox_load_memory(b.p, b.n, 16, &budget, &w, &e), VW_OK);
    vw_world_destroy(w);
    vb_free(&b);
}

/* What vw_vox_load_file returned in a child process that had 10 s and (outside sanitizer
 * builds, whose shadow memory needs the address space) 1 GiB of address space. */
typedef struct child_load {
    int finished;       /* 0: killed after 10 s (the loader hung)                           */
    vw_status status;
    double seconds;
    char message[256];
} child_load;

static child_load load_file_in_child(const char *path, const vw_budget *budget)
{
    child_load r;
    memset(&r, 0, sizeof r);
    int fd[2];
    assert_int_equal(pipe(fd), 0);
    pid_t pid = fork();
    assert_true(pid >= 0);
    if (pid == 0) {
        close(fd[0]);
#ifndef VT_ASAN
        struct rlimit rl = {(rlim_t)1 << 30, (rlim_t)1 << 30};
        setrlimit(RLIMIT_AS, &rl);
#endif
        vw_world *w = NULL;
        vw_error e;
        e.message[0] = '\0';
        double t0 = seconds_now();
        r.status = vw_vox_load_file(path, 16, budget, &w, &e);
        r.seconds = seconds_now() - t0;
        r.finished = 1;
        snprintf(r.message, sizeof r.message, "%s", e.message);
        vw_world_destroy(w);
        ssize_t n = write(fd[1], &r, sizeof r);
        _exit(n == (ssize_t)sizeof r ? 0 : 1);
    }
    close(fd[1]);
    int status = 0, done = 0;
    for (int i = 0; i < 200 && !done; i++) {
        done = waitpid(pid, &status, WNOHANG) == pid;
        if (!done) {
            struct timespec ts = {0, 50 * 1000 * 1000};
            nanosleep(&ts, NULL);
        }
    }
    if (!done) {
        kill(pid, SIGKILL);
        waitpid(pid, &status, 0);
    } else if (read(fd[0], &r, sizeof r) != (ssize_t)sizeof r) {
        memset(&r, 0, sizeof r);
        r.finished = 1;
        r.status = VW_OK;
        snprintf(r.message, sizeof r.message, "the child died (status %d)", status);
    }
    close(fd[0]);
    return r;
}

static void expect_refused(const char *what, const child_load *r, vw_status want, const char *text)
{
    if (!r->finished)
        fail_msg("%s: the loader hung (killed after 10 s)", what);
    print_message("%s: %s in %.3f s: %s\n", what, vw_status_string(r->status), r->seconds, r->message);
    assert_int_equal(r->status, want);
    assert_non_null(strstr(r->message, text));
    assert_true(r->seconds < 2.0);
}

/* Not regular files: a FIFO (opening it for reading would block until a writer came), a
 * character device (/dev/zero through a symlink would be read for 2 GiB before the magic
 * check) and a directory are refused from their type, before a byte is read. */
static void test_load_file_special(void **state)
{
    (void)state;
    char dir[] = "/tmp/vis_test_vox_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char fifo[64], zero[64], sub[64];
    snprintf(fifo, sizeof fifo, "%s/x.vox", dir);
    snprintf(zero, sizeof zero, "%s/zero.vox", dir);
    snprintf(sub, sizeof sub, "%s/dir.vox", dir);
    assert_int_equal(mkfifo(fifo, 0600), 0);
    assert_int_equal(symlink("/dev/zero", zero), 0);
    assert_int_equal(mkdir(sub, 0700), 0);
    const child_load r0 = load_file_in_child(fifo, NULL);
    const child_load r1 = load_file_in_child(zero, NULL);
    const child_load r2 = load_file_in_child(sub, NULL);
    unlink(fifo);
    unlink(zero);
    rmdir(sub);
    rmdir(dir);
    expect_refused("FIFO x.vox", &r0, VW_ERROR_IO, "not a regular file");
    expect_refused("x.vox -> /dev/zero", &r1, VW_ERROR_IO, "not a regular file");
    expect_refused("directory dir.vox", &r2, VW_ERROR_IO, "not a regular file");
}

/* A large regular file is judged by its size and its first bytes, not read whole: 1.5 GiB
 * (sparse) without the magic is not a .vox file; one with a valid header is larger than a
 * 1 MiB budget; one whose MAIN chunk claims more than the file holds is truncated. */
static void test_load_file_header_first(void **state)
{
    (void)state;
    char dir[] = "/tmp/vis_test_vox_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[64];
    snprintf(path, sizeof path, "%s/big.vox", dir);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs("NOTAVOX!", f);
    fclose(f);
    assert_int_equal(truncate(path, (off_t)3 << 29), 0);
    const child_load r0 = load_file_in_child(path, NULL);

    vb b;
    sparse_dag(&b, 1, 1);
    f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b.p, 1, b.n, f), b.n);
    fclose(f);
    assert_int_equal(truncate(path, (off_t)64 << 20), 0); /* trailing zeros: ignored */
    vw_budget budget = {1 << 20, 0};
    const child_load r1 = load_file_in_child(path, &budget);
    const child_load r2 = load_file_in_child(path, NULL); /* the trailing bytes are not needed */

    f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(b.p, 1, 40, f), 40); /* MAIN says ~16 KB follow */
    fclose(f);
    const child_load r3 = load_file_in_child(path, NULL);
    vb_free(&b);
    unlink(path);
    rmdir(dir);

    expect_refused("1.5 GiB without magic", &r0, VW_ERROR_FORMAT, "magic");
    expect_refused("64 MiB file, 1 MiB budget", &r1, VW_ERROR_BUDGET, "1.0 MiB");
    assert_true(r2.finished);
    assert_int_equal(r2.status, VW_OK);
    expect_refused("truncated", &r3, VW_ERROR_FORMAT, "MAIN");
}

/* ---- the exporters never destroy the file they were given (docs/cli.md, "Output files") - */

static void put_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_true(fputs(text, f) >= 0);
    assert_int_equal(fclose(f), 0);
}

/* A save that fails half-way leaves the file that was there as it was (vw_vox_save_file used
 * to remove it), a successful one replaces it, and neither leaves a temporary file beside
 * it. The failure is real for root too: a 64-byte file size limit (RLIMIT_FSIZE) makes the
 * writes fail with EFBIG. */
static void test_save_keeps_file(void **state)
{
    (void)state;
    char dir[] = "/tmp/vw_test_save_XXXXXX", vox[64], obj[64];
    assert_non_null(mkdtemp(dir));
    snprintf(vox, sizeof vox, "%s/world.vox", dir);
    snprintf(obj, sizeof obj, "%s/world.obj", dir);
    static const char old[] = "old contents\n";
    put_text(vox, old);
    put_text(obj, old);
    const int64_t origin[3] = {0, 0, 0};
    const int32_t size[3] = {32, 32, 32};
    vw_world *w = random_world(7, origin, size, 0.2);

    struct rlimit saved, small;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &saved), 0);
    small = saved;
    small.rlim_cur = 64;
    void (*saved_handler)(int) = signal(SIGXFSZ, SIG_IGN);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
    vw_error e_vox, e_obj;
    vw_status s_vox = vw_vox_save_file(w, vox, &e_vox), s_obj = vw_export_obj(w, obj, &e_obj);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &saved), 0);
    signal(SIGXFSZ, saved_handler);
    size_t n = 0;
    char *now = vt_read_file(vox, &n);
    assert_true(now && n == sizeof old - 1 && memcmp(now, old, n) == 0);
    free(now);
    now = vt_read_file(obj, &n);
    assert_true(now && n == sizeof old - 1 && memcmp(now, old, n) == 0);
    free(now);
    assert_int_equal(s_vox, VW_ERROR_IO);
    assert_int_equal(s_obj, VW_ERROR_IO);
    assert_non_null(strstr(e_vox.message, vox));
    assert_non_null(strstr(e_obj.message, obj));
    const char *const names[] = {"world.vox", "world.obj", NULL};
    vt_assert_dir_holds(dir, names);

    assert_int_equal(vw_vox_save_file(w, vox, &e_vox), VW_OK);
    assert_int_equal(vw_export_obj(w, obj, &e_obj), VW_OK);
    vw_world *b = NULL;
    assert_int_equal(vw_vox_load_file(vox, 16, NULL, &b, &e_vox), VW_OK);
    const int64_t shift[3] = {0, 0, 0};
    expect_same(w, b, shift);
    vw_world_destroy(b);
    now = vt_read_file(obj, &n);
    assert_true(now && n > 12 && memcmp(now, "# voxelworld", 12) == 0);
    free(now);
    vt_assert_dir_holds(dir, names);
    vw_world_destroy(w);
    unlink(vox);
    unlink(obj);
    rmdir(dir);
}

/* A target that is not a regular file is written in place, never removed: a private copy of
 * /dev/full (character device 1,7; a regression deletes this node, not the system's). */
static void test_save_to_device(void **state)
{
    (void)state;
    char dir[] = "/tmp/vw_test_save_XXXXXX", full[64];
    assert_non_null(mkdtemp(dir));
    snprintf(full, sizeof full, "%s/full", dir);
    if (!vt_make_full_device(full)) {
        rmdir(dir);
        print_message("cannot make a device node (not root?): nothing to test\n");
        skip();
    }
    const int64_t origin[3] = {0, 0, 0};
    const int32_t size[3] = {32, 32, 32};
    vw_world *w = random_world(8, origin, size, 0.2);
    vw_error e;
    for (int obj = 0; obj < 2; ++obj) {
        e.message[0] = '\0';
        vw_status s = obj ? vw_export_obj(w, full, &e) : vw_vox_save_file(w, full, &e);
        assert_true(vt_is_full_device(full));
        assert_int_equal(s, VW_ERROR_IO);
        if (!strstr(e.message, full) || !strstr(e.message, strerror(ENOSPC)))
            print_message("message lacks the path or the reason: %s\n", e.message);
        assert_non_null(strstr(e.message, full));
        assert_non_null(strstr(e.message, strerror(ENOSPC)));
    }
    vw_world_destroy(w);
    const char *const names[] = {"full", NULL};
    vt_assert_dir_holds(dir, names);
    unlink(full);
    rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_mapping_and_default_palette),
        cmocka_unit_test(test_all_rotations),
        cmocka_unit_test(test_nested_transforms),
        cmocka_unit_test(test_dag_instances),
        cmocka_unit_test(test_hidden),
        cmocka_unit_test(test_palette_and_materials),
        cmocka_unit_test(test_index_map),
        cmocka_unit_test(test_animation_frame_zero),
        cmocka_unit_test(test_unknown_chunks),
        cmocka_unit_test(test_bad_files),
        cmocka_unit_test(test_truncated),
        cmocka_unit_test(test_byte_flips),
        cmocka_unit_test(test_limits),
        cmocka_unit_test(test_many_layers_wide_dag),
        cmocka_unit_test(test_shared_files),
        cmocka_unit_test(test_shared_materials),
        cmocka_unit_test(test_export_random),
        cmocka_unit_test(test_export_large),
        cmocka_unit_test(test_export_far),
        cmocka_unit_test(test_export_empty),
        cmocka_unit_test(test_export_shared_file),
        cmocka_unit_test(test_fuzz_regressions),
        cmocka_unit_test(test_budget_instanced_dag),
        cmocka_unit_test(test_budget_exact),
        cmocka_unit_test(test_load_file_special),
        cmocka_unit_test(test_load_file_header_first),
        cmocka_unit_test(test_save_keeps_file),
        cmocka_unit_test(test_save_to_device),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
