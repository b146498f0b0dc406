/* test_opencl.c — the OpenCL backend against the CPU backend, bit for bit.
 *
 * The CPU backend is the reference (test_trace.c checks it against an independent
 * double-precision reference); here every ID and depth buffer the OpenCL backend writes must
 * equal the CPU's byte for byte (every 8th bulk camera also the CPU brute force's): random
 * worlds x random cameras (object and leaf IDs, every traversal the enum has), the same after
 * bursts of random edits (which exercises the partial uploads and the growth of device
 * buffers), the hard cases of DESIGN.md, batches, a generated terrain with
 * voxel edits, cameras aimed exactly at voxel edges and corners (also held to the
 * double-precision reference), device selection errors and the AUTO reason.
 *
 * Without an OpenCL device (or in a build without the backend) every test prints a SKIP
 * line saying why and is skipped. $VIS_OPENCL_DEVICE picks the device, as for the library. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "camera_path.h"
#include "drawlist_check.h"
#include "ref_trace.h"
#include "scene_builder.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

/* ---- contexts ------------------------------------------------------------------------- */

static char g_log[2048];

static int g_grew; /* "buffer grew" messages: the reallocation path ran */
static int g_flushes; /* "staged in N flushes": an upload larger than the staging area */

static void capture_log(vis_log_level level, const char *message, void *user)
{
    (void)user;
    if (strstr(message, "buffer grew"))
        ++g_grew;
    if (strstr(message, "flushes"))
        ++g_flushes;
    if (level >= VIS_LOG_WARNING)
        snprintf(g_log, sizeof g_log, "%s", message);
}

static vis_context *make_ctx(vis_backend_kind kind, const char *device, vis_status *out_status)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = kind;
    cd.threads = 2;
    cd.opencl_device = device;
    cd.log = capture_log;
    g_log[0] = '\0';
    vis_context *ctx = NULL;
    vis_status st = vis_context_create(&cd, &ctx);
    if (out_status)
        *out_status = st;
    return st == VIS_OK ? ctx : NULL;
}

/* The OpenCL context every test uses, or NULL (after one SKIP line) when there is none; a
 * device whose compiler refuses the kernels fails the test. */
static vis_context *cl_ctx_or_skip(void)
{
    static int tried = 0;
    static char why[2048];
    vis_status st;
    vis_context *ctx = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
    /* A device that refuses our kernels is our bug, not a missing device: NVIDIA's compiler
     * (OpenCL C 3.0, generic address space) refused a pointer PoCL took, and a skip hid it. */
    if (!ctx && strstr(g_log, "kernel build failed"))
        fail_msg("the OpenCL device did not build the kernels: %s", g_log);
    if (!ctx && !tried) {
        snprintf(why, sizeof why, "%s (%.1900s)", vis_status_string(st), g_log);
        printf("SKIP: no usable OpenCL device: %s\n", why);
    }
    tried = 1;
    if (ctx && !getenv("VIS_TEST_QUIET_DEVICE")) {
        static int said = 0;
        vis_backend_info bi;
        vis_context_backend(ctx, &bi);
        if (!said++)
            printf("OpenCL device: %s (%s)\n", bi.device, bi.is_gpu ? "GPU" : "not a GPU");
    }
    return ctx;
}

#define REQUIRE_OPENCL(var)                                                                  \
    vis_context *var = cl_ctx_or_skip();                                                     \
    if (!var) {                                                                              \
        skip();                                                                              \
        return;                                                                              \
    }

static vis_trace_desc desc_make(uint32_t w, uint32_t h, vis_id_mode ids, vis_traversal traversal)
{
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = w;
    td.height = h;
    td.ids = ids;
    td.traversal = traversal;
    return td;
}

/* Number of traversal methods the enum has now: the CPU accepts 0..n-1. */
static uint32_t traversal_count(vis_context *cpu, vis_scene *scene)
{
    vis_camera cam = {{1, 1, 1}, {2, 2, 2}, 60, 0, 0};
    uint32_t id;
    uint32_t n = 0;
    for (uint32_t t = 0; t < 64; ++t) {
        vis_trace_desc td = desc_make(1, 1, VIS_IDS_OBJECT, (vis_traversal)t);
        if (vis_trace(cpu, scene, &cam, &td, &id, 1, NULL, 0) != VIS_OK)
            break;
        n = t + 1;
    }
    return n;
}

/* ---- test worlds (as test_trace.c builds them) ---------------------------------------- */


/* ---- comparison ----------------------------------------------------------------------- */

typedef struct pair {
    vis_context *cpu, *cl;
    vis_scene *cpu_scene, *cl_scene;
    uint32_t short_stack; /* for the short-stack traversals; 0 = the default */
} pair;

static void compare_buffers(const uint32_t *ia, const float *da, const uint32_t *ib, const float *db, size_t n,
                            uint32_t W, const char *what, uint32_t mode, uint32_t trav)
{
    for (size_t i = 0; i < n; ++i)
        if (ia[i] != ib[i] || memcmp(&da[i], &db[i], 4) != 0)
            fail_msg("%s (ids %u, traversal %u): pixel (%zu,%zu): cpu id %u t %.9g (%08x), opencl id %u t %.9g (%08x)",
                     what, mode, trav, i % W, i / W, ia[i], (double)da[i], *(const uint32_t *)&da[i], ib[i],
                     (double)db[i], *(const uint32_t *)&db[i]);
}

/* Which traversals compare_view runs. The brute force (no tree) costs ~20x a tree
 * traversal, so the bulk test runs it on every 8th camera only. */
enum { ALL_TRAVERSALS = 0, TREE_TRAVERSALS = 1 };

/* One view on both backends, every ID mode and traversal; returns the hit pixels. */
static uint32_t compare_view_sel(const pair *p, const vis_camera *cam, uint32_t W, uint32_t H, uint32_t traversals,
                                 int which, const char *what)
{
    size_t n = (size_t)W * H;
    uint32_t *ia = malloc(n * 4), *ib = malloc(n * 4);
    float *da = malloc(n * 4), *db = malloc(n * 4);
    uint32_t hits = 0;
    /* The first `traversals` methods from STACK, identical on both backends. AUTO and PACKET
     * trace packets on the CPU: they are held to the brute force below; OpenCL's PACKET (the
     * work-group's tile walk) is held here to the CPU's stack method, itself held to the
     * brute force below. */
    for (uint32_t mode = 0; mode < 2; ++mode)
        for (uint32_t t = VIS_TRAVERSAL_STACK; t < VIS_TRAVERSAL_STACK + traversals && t <= VIS_TRAVERSAL_DDA;
             ++t) {
            if (which == TREE_TRAVERSALS && t == (uint32_t)VIS_TRAVERSAL_BRUTEFORCE)
                continue;
            vis_trace_desc td = desc_make(W, H, (vis_id_mode)mode, (vis_traversal)t);
            if (p->short_stack)
                td.short_stack = p->short_stack;
            memset(ib, 0xAB, n * 4);
            memset(db, 0xAB, n * 4);
            td.traversal = t == VIS_TRAVERSAL_PACKET ? VIS_TRAVERSAL_STACK : (vis_traversal)t;
            int rc = vis_trace(p->cpu, p->cpu_scene, cam, &td, ia, n, da, n);
            td.traversal = (vis_traversal)t;
            if (rc != VIS_OK)
                fail_msg("%s: cpu: %s", what, vis_context_last_error(p->cpu));
            if (vis_trace(p->cl, p->cl_scene, cam, &td, ib, n, db, n) != VIS_OK)
                fail_msg("%s: opencl: %s", what, vis_context_last_error(p->cl));
            compare_buffers(ia, da, ib, db, n, W, what, mode, t);
            if (mode == 0 && t == VIS_TRAVERSAL_STACK)
                for (size_t i = 0; i < n; ++i)
                    hits += ia[i] != 0;
        }
    if (which == ALL_TRAVERSALS && traversals > 1)
        for (uint32_t mode = 0; mode < 2; ++mode) {
            vis_trace_desc td = desc_make(W, H, (vis_id_mode)mode, VIS_TRAVERSAL_BRUTEFORCE);
            if (vis_trace(p->cpu, p->cpu_scene, cam, &td, ia, n, da, n) != VIS_OK)
                fail_msg("%s: cpu bruteforce: %s", what, vis_context_last_error(p->cpu));
            td.traversal = VIS_TRAVERSAL_PACKET;
            if (vis_trace(p->cpu, p->cpu_scene, cam, &td, ib, n, db, n) != VIS_OK)
                fail_msg("%s: cpu packet: %s", what, vis_context_last_error(p->cpu));
            for (size_t i = 0; i < n; ++i)
                if (ia[i] != ib[i] || memcmp(&da[i], &db[i], 4) != 0)
                    fail_msg("%s (ids %u): pixel (%zu,%zu): cpu packet id %u t %.9g, bruteforce id %u t %.9g", what,
                             mode, i % W, i / W, ib[i], (double)db[i], ia[i], (double)da[i]);
            /* The per-ray methods (equal on both backends, above) equal the brute force too:
             * the stack method (whose decisions the kd methods share) and the cell-grid walk. */
            static const vis_traversal per_ray[2] = {VIS_TRAVERSAL_STACK, VIS_TRAVERSAL_DDA};
            for (uint32_t k = 0; k < 2; ++k) {
                td.traversal = per_ray[k];
                if (vis_trace(p->cpu, p->cpu_scene, cam, &td, ib, n, db, n) != VIS_OK)
                    fail_msg("%s: cpu per-ray method %d: %s", what, (int)per_ray[k], vis_context_last_error(p->cpu));
                for (size_t i = 0; i < n; ++i)
                    if (ia[i] != ib[i] || memcmp(&da[i], &db[i], 4) != 0)
                        fail_msg("%s (ids %u): pixel (%zu,%zu): method %d id %u t %.9g, bruteforce id %u t %.9g",
                                 what, mode, i % W, i / W, (int)per_ray[k], ib[i], (double)db[i], ia[i],
                                 (double)da[i]);
            }
        }
    free(ia), free(ib), free(da), free(db);
    return hits;
}

static uint32_t compare_view(const pair *p, const vis_camera *cam, uint32_t W, uint32_t H, uint32_t traversals,
                             const char *what)
{
    return compare_view_sel(p, cam, W, H, traversals, ALL_TRAVERSALS, what);
}

static void pair_make(pair *p, vis_context *cl, const tworld *w, const double origin[3], uint32_t depth)
{
    memset(p, 0, sizeof *p);
    p->cl = cl;
    p->cpu = make_ctx(VIS_BACKEND_CPU, NULL, NULL);
    assert_non_null(p->cpu);
    p->cpu_scene = make_scene(p->cpu, w, origin, depth);
    p->cl_scene = make_scene(p->cl, w, origin, depth);
}

static void pair_free(pair *p)
{
    vis_scene_destroy(p->cpu_scene);
    vis_scene_destroy(p->cl_scene);
    vis_context_destroy(p->cpu);
    p->cpu = NULL;
}

/* Applies one random edit to the test world and to both scenes: replace a chunk object,
 * remove an object, move an entity, or add a new one. */
static void random_edit(pair *p, tworld *w, uint64_t *rng, int nx, int ny)
{
    uint32_t k = (uint32_t)(vt_rand(rng) % w->n);
    tobj *o = &w->objs[k];
    double r = vt_rand_unit(rng);
    if (r < 0.3 && o->nq + o->nt > 0) { /* remove */
        assert_int_equal(vis_scene_remove_object(p->cpu_scene, o->id), VIS_OK);
        assert_int_equal(vis_scene_remove_object(p->cl_scene, o->id), VIS_OK);
        obj_clear(o);
        return;
    }
    if (r < 0.8 && o->id < 100000) { /* remesh (or re-add) a chunk object */
        uint32_t ci = o->id - 1;
        int c[3] = {(int)(ci % (uint32_t)nx), (int)(ci / (uint32_t)nx % (uint32_t)ny), (int)(ci / (uint32_t)(nx * ny))};
        obj_clear(o);
        obj_chunk_boxes(o, rng, c, &chunk_world_default);
    } else if (r < 0.9) { /* a new entity */
        o = add_obj(w, 300000 + (uint32_t)(vt_rand(rng) % 100000));
        for (uint32_t i = 0; i + 1 < w->n; ++i)
            if (w->objs[i].id == o->id) { /* ID taken: edit that one instead */
                --w->n;
                o = &w->objs[i];
                break;
            }
        obj_clear(o);
        obj_entity(o, rng, w->size, &chunk_world_default);
    } else { /* move whatever it is as an entity */
        obj_clear(o);
        obj_entity(o, rng, w->size, &chunk_world_default);
    }
    set_obj(p->cpu_scene, o);
    set_obj(p->cl_scene, o);
}

/* ---- tests ---------------------------------------------------------------------------- */

static void test_bad_selector_not_found(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    vis_context_destroy(cl);
    vis_status st;
    assert_null(make_ctx(VIS_BACKEND_OPENCL, "no-such-device-xyzzy", &st));
    assert_int_equal(st, VIS_ERROR_NOT_FOUND);
    if (!strstr(g_log, "no-such-device-xyzzy"))
        fail_msg("message does not name the selector: %s", g_log);
    assert_null(make_ctx(VIS_BACKEND_OPENCL, "999", &st));
    assert_int_equal(st, VIS_ERROR_NOT_FOUND);
    /* Index 0 always exists when a device does; "gpu" finds a GPU when the default is one. */
    vis_context *c0 = make_ctx(VIS_BACKEND_OPENCL, "0", &st);
    assert_int_equal(st, VIS_OK);
    vis_context_destroy(c0);
    vis_context *d = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
    vis_backend_info di;
    assert_int_equal(vis_context_backend(d, &di), VIS_OK);
    vis_context_destroy(d);
    if (di.is_gpu) {
        vis_context *g = make_ctx(VIS_BACKEND_OPENCL, "GPU", &st);
        assert_int_equal(st, VIS_OK);
        vis_context_destroy(g);
    }
    /* AUTO with a bad $VIS_OPENCL_DEVICE falls back to the CPU and says why. */
    const char *old = getenv("VIS_OPENCL_DEVICE");
    char saved[256] = "";
    if (old)
        snprintf(saved, sizeof saved, "%s", old);
    setenv("VIS_OPENCL_DEVICE", "no-such-device-xyzzy", 1);
    vis_context *a = make_ctx(VIS_BACKEND_AUTO, NULL, &st);
    if (old)
        setenv("VIS_OPENCL_DEVICE", saved, 1);
    else
        unsetenv("VIS_OPENCL_DEVICE");
    assert_non_null(a);
    vis_backend_info bi;
    assert_int_equal(vis_context_backend(a, &bi), VIS_OK);
    assert_int_equal(bi.kind, VIS_BACKEND_CPU);
    if (!strstr(bi.reason, "auto") || !strstr(bi.reason, "no-such-device-xyzzy"))
        fail_msg("AUTO fallback reason: '%s'", bi.reason);
    vis_context_destroy(a);
}

static void test_auto_reports_reason(void **state)
{
    (void)state;
    vis_context *ctx = make_ctx(VIS_BACKEND_AUTO, NULL, NULL);
    assert_non_null(ctx);
    vis_backend_info bi;
    assert_int_equal(vis_context_backend(ctx, &bi), VIS_OK);
    printf("AUTO: %s (%s): %s\n", bi.name, bi.device, bi.reason);
    assert_true(strncmp(bi.reason, "auto:", 5) == 0);
    if (bi.kind == VIS_BACKEND_OPENCL) {
        assert_non_null(strstr(bi.reason, bi.device));
        assert_non_null(strstr(bi.reason, bi.is_gpu ? "GPU" : "device"));
    } else {
        assert_int_equal(bi.kind, VIS_BACKEND_CPU);
    }
    vis_context_destroy(ctx);
}

/* The bulk: random worlds x random cameras, then a burst of edits and the same again. */
static void test_random_worlds_bit_identical(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 20240611;
    /* 1,000 cameras in the normal build: 8 worlds x (63 before + 62 after the edits). */
    int worlds = vt_small() ? 3 : 8;
    int cams = vt_small() ? 12 : 63;
    uint64_t cameras = 0, pixels_hit = 0;
    for (int wi = 0; wi < worlds; ++wi) {
        int nx = 3 + wi % 2, ny = 2, nz = 3;
        tworld w;
        random_chunk_world(&w, &rng, nx, ny, nz);
        uint32_t depth = wi % 4 == 3 ? 2 : 0; /* also shallow trees: multi-chunk leaves */
        const double zero[3] = {0, 0, 0}, far_o[3] = {1048576.0, -512.0, -1048576.0};
        const double *origin = wi % 4 == 2 ? far_o : zero;
        pair p;
        pair_make(&p, cl, &w, origin, depth);
        uint32_t trav = traversal_count(p.cpu, p.cpu_scene);
        assert_true(trav >= 2);
        if (wi == 0)
            printf("%u traversal methods, object and leaf IDs\n", trav);
        char what[96];
        for (int ci = 0; ci < cams; ++ci) {
            vis_camera cam;
            random_view(&cam, &rng, w.size, origin);
            snprintf(what, sizeof what, "world %d camera %d", wi, ci);
            p.short_stack = 1u + (uint32_t)ci % 8u;
            pixels_hit += compare_view_sel(&p, &cam, 32, 24, trav, ci % 8 ? TREE_TRAVERSALS : ALL_TRAVERSALS, what);
            ++cameras;
        }
        /* The first trace sent the whole scene; a burst of edits sends only what changed. */
        vis_timing tm;
        vis_camera cam0;
        random_view(&cam0, &rng, w.size, origin);
        uint64_t full = 0;
        {
            vis_scene *fresh = make_scene(cl, &w, origin, depth);
            uint32_t id;
            vis_trace_desc td = desc_make(1, 1, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
            assert_int_equal(vis_trace(cl, fresh, &cam0, &td, &id, 1, NULL, 0), VIS_OK);
            assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
            full = tm.upload_bytes;
            assert_true(full > 0);
            vis_scene_destroy(fresh);
        }
        int edits = vt_small() ? 10 : 40;
        for (int e = 0; e < edits; ++e)
            random_edit(&p, &w, &rng, nx, ny);
        for (int ci = 0; ci < cams - (vt_small() ? 0 : 1); ++ci) {
            vis_camera cam;
            random_view(&cam, &rng, w.size, origin);
            snprintf(what, sizeof what, "world %d camera %d after %d edits", wi, ci, edits);
            p.short_stack = 1u + (uint32_t)ci % 8u;
            compare_view_sel(&p, &cam, 32, 24, trav, ci % 8 ? TREE_TRAVERSALS : ALL_TRAVERSALS, what);
            ++cameras;
        }
        /* One more edit: a single chunk object. Its upload is a small part of the scene. */
        random_edit(&p, &w, &rng, nx, ny);
        uint32_t id;
        vis_trace_desc td = desc_make(1, 1, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
        assert_int_equal(vis_trace(cl, p.cl_scene, &cam0, &td, &id, 1, NULL, 0), VIS_OK);
        assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
        if (!(tm.upload_bytes > 0 && tm.upload_bytes * 4 < full))
            fail_msg("world %d: one edit uploaded %llu bytes, the whole scene is %llu", wi,
                     (unsigned long long)tm.upload_bytes, (unsigned long long)full);
        /* Tracing again without edits uploads nothing. */
        assert_int_equal(vis_trace(cl, p.cl_scene, &cam0, &td, &id, 1, NULL, 0), VIS_OK);
        assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
        assert_int_equal(tm.upload_bytes, 0);
        pair_free(&p);
        free_world(&w);
    }
    printf("%llu cameras compared bit for bit (%llu hit pixels in object/stack mode)\n",
           (unsigned long long)cameras, (unsigned long long)pixels_hit);
    vis_context_destroy(cl);
}

/* The exact bytes of one chunk edit: the leaf header (64), its bucket table (16+16+16+4
 * offsets and 51 pairs of cover masks, 4 bytes each), its object table (one 4-byte word) and
 * its quads (packed: one word each, their coordinates are whole offsets in the leaf), the
 * object slot (16) and its one leaf index (4) — nothing else. */
static void test_edit_uploads_only_changed_bytes(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 555;
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = 64, w.size[1] = 32, w.size[2] = 64;
    for (int cz = 0; cz < 4; ++cz)
        for (int cx = 0; cx < 4; ++cx) { /* chunk objects only: each alone in its leaf */
            int c[3] = {cx, 0, cz};
            obj_chunk_boxes(add_obj(&w, 1u + (uint32_t)(cx + 4 * 2 * cz)), &rng, c, &chunk_world_default);
        }
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    vis_camera cam = {{-10, 40, -10}, {32, 8, 32}, 70, 0, 0};
    compare_view(&p, &cam, 48, 40, 1, "before the edit");
    /* Replace chunk (1, 0, 1) with a known mesh: it lies alone in its leaf. */
    tobj *o = NULL;
    uint32_t cid = 1u + (1 + 4 * (0 + 2 * 1));
    for (uint32_t i = 0; i < w.n; ++i)
        if (w.objs[i].id == cid)
            o = &w.objs[i];
    if (!o)
        o = add_obj(&w, cid);
    obj_clear(o);
    float lo[3] = {17, 1, 18}, hi[3] = {25, 9, 30};
    obj_box(o, lo, hi);
    float lo2[3] = {20, 9, 20}, hi2[3] = {22, 12, 22};
    obj_box(o, lo2, hi2);
    set_obj(p.cpu_scene, o);
    set_obj(p.cl_scene, o);
    uint32_t ids[48 * 40];
    vis_trace_desc td = desc_make(48, 40, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    assert_int_equal(vis_trace(cl, p.cl_scene, &cam, &td, ids, 48 * 40, NULL, 0), VIS_OK);
    vis_timing tm;
    assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
    uint64_t expect = 64 + (52 + 2 * 51) * 4 + (1 + (uint64_t)o->nq) * 4 + 16 + 4;
    if (tm.upload_bytes != expect)
        fail_msg("one chunk edit (%u quads) uploaded %llu bytes, expected %llu", o->nq,
                 (unsigned long long)tm.upload_bytes, (unsigned long long)expect);
    printf("one chunk edit: %llu bytes uploaded (%u quads)\n", (unsigned long long)tm.upload_bytes, o->nq);
    compare_view(&p, &cam, 48, 40, 1, "after the edit");
    /* The CPU backend uploads nothing (compare_view traced the edited scene on it too). */
    assert_int_equal(vis_context_last_timing(p.cpu, &tm), VIS_OK);
    assert_int_equal(tm.upload_bytes, 0);
    pair_free(&p);
    free_world(&w);
    vis_context_destroy(cl);
}

/* An edit that puts the first primitives into empty cells lowers the cell map's clearances
 * around them (trace_core.h, VIS_CELL_CLEAR), which the cell-grid walk reads to step over
 * empty cells unread: the device must get them with the edit, or its walk would step over
 * the new objects. A long, mostly empty world (clearances up to the maximum along the view),
 * then boxes dropped into cells the view's rays cross, each edit traced at once, then three
 * far apart traced together. */
static void test_edit_fills_empty_cells(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = 384, w.size[1] = 64, w.size[2] = 96; /* 24 x 4 x 6 cells */
    const float lo0[3] = {2, 1, 2}, hi0[3] = {14, 12, 94};
    obj_box(add_obj(&w, 1), lo0, hi0); /* a wall at the near end */
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    vis_camera cam = {{20, 30, 48}, {380, 20, 48}, 70, 0, 0};
    compare_view(&p, &cam, 40, 32, VIS_TRAVERSAL_DDA + 1u, "before the edits");
    uint64_t rng = 8080;
    for (uint32_t k = 0; k < 6; ++k) {
        float c = 96.0f + 48.0f * (float)k + (float)(vt_rand(&rng) % 8u);
        float lo[3] = {c, (float)(vt_rand(&rng) % 40u), 20.0f + (float)(vt_rand(&rng) % 40u)};
        float hi[3] = {c + 3.0f, lo[1] + 6.0f, lo[2] + 9.0f};
        tobj *o = add_obj(&w, 10u + k);
        obj_box(o, lo, hi);
        set_obj(p.cpu_scene, o);
        set_obj(p.cl_scene, o);
        char what[64];
        snprintf(what, sizeof what, "after box %u", k);
        if (compare_view(&p, &cam, 40, 32, VIS_TRAVERSAL_DDA + 1u, what) == 0)
            fail_msg("%s: the view hits nothing", what);
    }
    /* Several fills far apart before one trace: one upload of the box around all of them. */
    static const float at[3][3] = {{40, 44, 4}, {200, 2, 80}, {360, 30, 40}};
    for (uint32_t k = 0; k < 3; ++k) {
        float hi[3] = {at[k][0] + 5.0f, at[k][1] + 5.0f, at[k][2] + 5.0f};
        tobj *o = add_obj(&w, 20u + k);
        obj_box(o, at[k], hi);
        set_obj(p.cpu_scene, o);
        set_obj(p.cl_scene, o);
    }
    compare_view(&p, &cam, 40, 32, VIS_TRAVERSAL_DDA + 1u, "after three boxes at once");
    /* Cells emptied again: the six boxes removed (the clearances around them rise), then a
     * box dropped where one was, before one trace: the upload carries the raised clearances
     * and the ones lowered after them. */
    for (uint32_t k = 0; k < 6; ++k) {
        assert_int_equal(vis_scene_remove_object(p.cpu_scene, 10u + k), VIS_OK);
        assert_int_equal(vis_scene_remove_object(p.cl_scene, 10u + k), VIS_OK);
    }
    compare_view(&p, &cam, 40, 32, VIS_TRAVERSAL_DDA + 1u, "after the six boxes were removed");
    const float lo1[3] = {243, 18, 41}, hi1[3] = {247, 26, 50};
    tobj *o = add_obj(&w, 30u);
    obj_box(o, lo1, hi1);
    set_obj(p.cpu_scene, o);
    set_obj(p.cl_scene, o);
    if (compare_view(&p, &cam, 40, 32, VIS_TRAVERSAL_DDA + 1u, "after a box where the clearances rose") == 0)
        fail_msg("the view hits nothing");
    pair_free(&p);
    free_world(&w);
    vis_context_destroy(cl);
}

/* Pools that grow past the device buffers (big new objects, leaves that outgrow their
 * slots) take the reallocation path; the result must still match. */
static void test_pool_growth_reallocates(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 9090;
    tworld w;
    random_chunk_world(&w, &rng, 3, 2, 3);
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    uint32_t trav = traversal_count(p.cpu, p.cpu_scene);
    vis_camera cam = {{-8, 30, -8}, {24, 8, 24}, 80, 0, 0};
    compare_view(&p, &cam, 40, 32, trav, "before growth");
    /* A many-triangle object all over the scene, and a many-quad one. */
    tobj *t = add_obj(&w, 400000), *q = add_obj(&w, 400001);
    int n = vt_small() ? 3000 : 12000;
    for (int i = 0; i < n; ++i) {
        float a[3], b[3], c[3];
        for (int k = 0; k < 3; ++k) {
            a[k] = (float)(vt_rand_unit(&rng) * (w.size[k] - 2.0) + 1.0);
            b[k] = a[k] + (float)(vt_rand_unit(&rng) - 0.5);
            c[k] = a[k] + (float)(vt_rand_unit(&rng) - 0.5);
        }
        obj_tri(t, a, b, c);
        uint32_t ax = (uint32_t)(vt_rand(&rng) % 3), u = (ax + 1) % 3, v = (ax + 2) % 3;
        float pl = (float)(vt_rand(&rng) % (uint64_t)w.size[ax]);
        float u0 = (float)(vt_rand(&rng) % (uint64_t)(w.size[u] - 1)), v0 = (float)(vt_rand(&rng) % (uint64_t)(w.size[v] - 1));
        obj_quad(q, ax, pl, u0, v0, u0 + 1, v0 + 1);
    }
    set_obj(p.cpu_scene, t);
    set_obj(p.cl_scene, t);
    set_obj(p.cpu_scene, q);
    set_obj(p.cl_scene, q);
    int grew = g_grew, flushes = g_flushes;
    /* The sync alone first, to read what it sent. */
    uint32_t ids[8 * 8];
    vis_trace_desc td = desc_make(8, 8, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    assert_int_equal(vis_trace(cl, p.cl_scene, &cam, &td, ids, 64, NULL, 0), VIS_OK);
    vis_timing tm;
    assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
    compare_view(&p, &cam, 12, 10, trav, "after growth"); /* brute force included, small */
    if (g_grew == grew)
        fail_msg("no device buffer grew: the reallocation path was not exercised");
    /* Past 256 KiB of words (cl_scene.c, STAGE_WORDS) an upload takes several flushes of the
     * staging area. The full-size run sends more than that; the reduced one (vt_small) may
     * not, and then checks only that one flush did. */
    const uint64_t stage_bytes = 64u * 1024u * 4u;
    if (!vt_small() && tm.upload_bytes <= stage_bytes)
        fail_msg("the upload (%llu bytes) fitted one staging area: the multi-flush path was not exercised",
                 (unsigned long long)tm.upload_bytes);
    if (tm.upload_bytes > stage_bytes && g_flushes == flushes)
        fail_msg("an upload of %llu bytes was not split over several flushes", (unsigned long long)tm.upload_bytes);
    print_message("growth upload: %llu bytes, %d multi-flush syncs\n", (unsigned long long)tm.upload_bytes,
                  g_flushes - flushes);
    for (int i = 0; i < 6; ++i) {
        vis_camera c;
        const double zero[3] = {0, 0, 0};
        random_view(&c, &rng, w.size, zero);
        compare_view_sel(&p, &c, 40, 32, trav, TREE_TRAVERSALS, "after growth");
    }
    /* And shrink again: remove them. */
    assert_int_equal(vis_scene_remove_object(p.cpu_scene, 400000), VIS_OK);
    assert_int_equal(vis_scene_remove_object(p.cl_scene, 400000), VIS_OK);
    compare_view(&p, &cam, 40, 32, trav, "after removal");
    pair_free(&p);
    free_world(&w);
    vis_context_destroy(cl);
}

/* The hard cases of test_trace.c (DESIGN.md "Numerics") on OpenCL. */
static void test_hard_cases(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 32.0f;
    float flo[3] = {0, 0, 0}, fhi[3] = {32, 1, 32};
    obj_box(add_obj(&w, 1), flo, fhi);
    float lo[3] = {16, 1, 4}, hi[3] = {17, 12, 28}; /* wall on the split plane x = 16 */
    obj_box(add_obj(&w, 2), lo, hi);
    float lo2[3] = {4, 1, 16}, hi2[3] = {16, 12, 17};
    obj_box(add_obj(&w, 3), lo2, hi2);
    /* ties: the same quad in two objects */
    obj_quad(add_obj(&w, 9), 2, 24.0f, 20, 2, 30, 10);
    obj_quad(add_obj(&w, 7), 2, 24.0f, 20, 2, 30, 10);
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    uint32_t trav = traversal_count(p.cpu, p.cpu_scene);
    const double eyes[][6] = {
        {16, 6, 0, 16, 6, 32},     {16, 16, 16, 16, 0, 16}, {16, 16, 16, 16, 32, 16}, {0, 6, 16, 32, 6, 16},
        {31, 6, 16, 0, 6, 16},     {0, 1, 0, 32, 1, 32},    {16, 12, 0, 16, 12, 32},  {17, 12, 17, 0, 0, 0},
        {8, 30, 8, 16.5, 1, 16.5}, {25, 6, 0.5, 25, 6, 30}, {16.5, 16.5, 16.5, 30, 20, 10},
    };
    for (size_t i = 0; i < sizeof eyes / sizeof eyes[0]; ++i) {
        vis_camera cam;
        memset(&cam, 0, sizeof cam);
        memcpy(cam.eye, eyes[i], 24);
        memcpy(cam.target, eyes[i] + 3, 24);
        compare_view(&p, &cam, 33, 33, trav, "hard case (33x33)");
        compare_view(&p, &cam, 32, 32, trav, "hard case (32x32)");
        compare_view(&p, &cam, 7, 5, trav, "hard case (7x5)");
    }
    /* Inside a closed room of 1-voxel walls, aiming at corners. */
    tworld room;
    memset(&room, 0, sizeof room);
    room.size[0] = room.size[1] = room.size[2] = 48.0f;
    float L = 10, Hh = 30;
    float walls[6][6] = {{L, L, L, Hh, L + 1, Hh},     {L, Hh - 1, L, Hh, Hh, Hh}, {L, L, L, L + 1, Hh, Hh},
                         {Hh - 1, L, L, Hh, Hh, Hh},   {L, L, L, Hh, Hh, L + 1},   {L, L, Hh - 1, Hh, Hh, Hh}};
    for (int i = 0; i < 6; ++i)
        obj_box(add_obj(&room, 1 + i), walls[i], walls[i] + 3);
    pair r;
    pair_make(&r, cl, &room, NULL, 0);
    uint64_t rng = 99;
    for (int i = 0; i < 12; ++i) {
        vis_camera cam;
        memset(&cam, 0, sizeof cam);
        for (int a = 0; a < 3; ++a) {
            cam.eye[a] = L + 1 + vt_rand_unit(&rng) * (Hh - L - 2);
            if (i % 4 == 0)
                cam.eye[a] = floor(cam.eye[a]);
            cam.target[a] = L + vt_rand_unit(&rng) * (Hh - L);
        }
        if (i % 3 == 0)
            cam.target[0] = L + 1, cam.target[1] = Hh - 1, cam.target[2] = L + 1;
        cam.fovy_deg = 90;
        compare_view(&r, &cam, 41, 37, trav, "inside the room");
    }
    pair_free(&r);
    pair_free(&p);
    free_world(&room);
    free_world(&w);
    vis_context_destroy(cl);
}

/* vis_trace_batch: each view equals vis_trace of its camera, with and without depth; a bad
 * camera anywhere rejects the batch before any work. */
static void test_batch(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 31337;
    tworld w;
    random_chunk_world(&w, &rng, 3, 2, 3);
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    enum { N = 37, W = 24, H = 22 }; /* no multiple of 8 nor of 4: part-filled groups in both shapes */
    vis_camera cams[N];
    const double zero[3] = {0, 0, 0};
    for (int i = 0; i < N; ++i)
        random_view(&cams[i], &rng, w.size, zero);
    size_t px = (size_t)W * H;
    uint32_t *ref_ids = malloc(N * px * 4), *ids = malloc(N * px * 4), *cpu_ids = malloc(N * px * 4);
    float *ref_depth = malloc(N * px * 4), *depth = malloc(N * px * 4), *cpu_depth = malloc(N * px * 4);
    for (uint32_t mode = 0; mode < 2; ++mode) {
        vis_trace_desc td = desc_make(W, H, (vis_id_mode)mode, VIS_TRAVERSAL_STACK);
        for (int i = 0; i < N; ++i)
            assert_int_equal(vis_trace(p.cpu, p.cpu_scene, &cams[i], &td, ref_ids + i * px, px, ref_depth + i * px, px),
                             VIS_OK);
        if (vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, depth, N * px) != VIS_OK)
            fail_msg("batch: %s", vis_context_last_error(p.cl));
        compare_buffers(ref_ids, ref_depth, ids, depth, N * px, W, "opencl batch", mode, 0);
        /* The work-group tile walk (kernels/tile.cl) in the batch kernel: 24x22 views leave
         * part-filled groups at the edges, whose outside items still join every barrier. */
        td.traversal = VIS_TRAVERSAL_PACKET;
        if (vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, depth, N * px) != VIS_OK)
            fail_msg("batch: %s", vis_context_last_error(p.cl));
        compare_buffers(ref_ids, ref_depth, ids, depth, N * px, W, "opencl batch, packets", mode, 0);
        td.traversal = VIS_TRAVERSAL_DDA; /* the cell-grid walk, the GPU default, in the batch kernel */
        if (vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, depth, N * px) != VIS_OK)
            fail_msg("batch: %s", vis_context_last_error(p.cl));
        compare_buffers(ref_ids, ref_depth, ids, depth, N * px, W, "opencl batch, dda", mode, 0);
        /* The cached stack's local ring, sized from the batch's work-group shape (8x4), not
         * one view's (8x8). */
        td.traversal = VIS_TRAVERSAL_CACHED_STACK;
        if (vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, depth, N * px) != VIS_OK)
            fail_msg("batch: %s", vis_context_last_error(p.cl));
        compare_buffers(ref_ids, ref_depth, ids, depth, N * px, W, "opencl batch, cached stack", mode, 0);
        td.traversal = VIS_TRAVERSAL_STACK;
        vis_timing tm;
        assert_int_equal(vis_context_last_timing(p.cl, &tm), VIS_OK);
        assert_int_equal(tm.views, N);
        assert_int_equal(tm.rays, N * px);
        assert_true(tm.kernel_ms > 0.0 && tm.total_ms > 0.0);
        memset(ids, 0, N * px * 4);
        assert_int_equal(vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, NULL, 0), VIS_OK);
        assert_memory_equal(ids, ref_ids, N * px * 4);
        assert_int_equal(vis_trace_batch(p.cpu, p.cpu_scene, cams, N, &td, cpu_ids, N * px, cpu_depth, N * px), VIS_OK);
        compare_buffers(ref_ids, ref_depth, cpu_ids, cpu_depth, N * px, W, "cpu batch", mode, 0);
        assert_int_equal(vis_context_last_timing(p.cpu, &tm), VIS_OK);
        assert_int_equal(tm.views, N);
        assert_int_equal(tm.upload_bytes, 0);
    }
    /* A bad camera (index 20): rejected, nothing written, the message names it. */
    vis_camera bad[N];
    memcpy(bad, cams, sizeof bad);
    bad[20].fovy_deg = 200;
    memset(ids, 0x5A, N * px * 4);
    vis_trace_desc td = desc_make(W, H, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    assert_int_equal(vis_trace_batch(p.cl, p.cl_scene, bad, N, &td, ids, N * px, depth, N * px),
                     VIS_ERROR_INVALID_ARGUMENT);
    assert_non_null(strstr(vis_context_last_error(p.cl), "camera 20"));
    for (size_t i = 0; i < N * px; ++i)
        assert_int_equal(ids[i], 0x5A5A5A5Au);
    /* A batch capacity one view short: refused before any work on OpenCL too. */
    assert_int_equal(vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, (N - 1) * px, NULL, 0), VIS_ERROR_CAPACITY);
    for (size_t i = 0; i < N * px; ++i)
        assert_int_equal(ids[i], 0x5A5A5A5Au);
    assert_int_equal(vis_trace_batch(p.cl, p.cl_scene, cams, 0, &td, ids, N * px, depth, N * px), VIS_OK);
    free(ref_ids), free(ids), free(cpu_ids), free(ref_depth), free(depth), free(cpu_depth);
    pair_free(&p);
    free_world(&w);
    vis_context_destroy(cl);
}

/* vis_trace_drawlist and its batch form on the device: the lists built there (pixel counts
 * by atomics, compacted, read back alone) equal the CPU's vis_trace + vis_drawlist_build, in
 * object and leaf IDs, with a deep tree and a shallow one (leaves of several objects), image
 * sizes that are and are not whole tiles, the stack and the cached stack; then again after
 * random edits (freed and reused object slots, grown device buffers). */
static void test_drawlist_on_device(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 9001;
    const double zero[3] = {0, 0, 0};
    size_t longest = 0;
    for (uint32_t depth = 0; depth <= 3; depth += 3) {
        tworld w;
        /* the larger: lists past 64 entries, and more than 256 object slots (several blocks
         * of the device's compaction, cl_drawlist.c) */
        random_chunk_world(&w, &rng, depth ? 3 : 16, 2, depth ? 3 : 16);
        pair p;
        pair_make(&p, cl, &w, NULL, depth);
        vis_scene_info si;
        assert_int_equal(vis_scene_get_info(p.cl_scene, &si), VIS_OK);
        if (!depth)
            assert_true(si.objects > 256u);
        enum { N = 5 };
        vis_camera cams[N];
        for (int i = 0; i < N; ++i)
            random_view(&cams[i], &rng, w.size, zero);
        vis_camera over = {{-10, w.size[1] * 2.5, -10}, {w.size[0] * 0.5, 0, w.size[2] * 0.5}, 70, 0, 0};
        cams[0] = over; /* the whole world in view */
        for (int round = 0; round < 2; ++round) {
            for (uint32_t mode = 0; mode < 2; ++mode)
                for (uint32_t k = 0; k < 4; ++k) {
                    /* dda: the GPU default (on the shallow tree, without a cell map, the
                     * stack method runs in its place) */
                    static const vis_traversal methods[4] = {VIS_TRAVERSAL_STACK, VIS_TRAVERSAL_CACHED_STACK,
                                                             VIS_TRAVERSAL_PACKET, VIS_TRAVERSAL_DDA};
                    vis_trace_desc td = desc_make(k ? 24 : 37, k ? 16 : 29, (vis_id_mode)mode, methods[k]);
                    td.short_stack = 3;
                    size_t l = check_trace_drawlist(p.cpu, p.cpu_scene, p.cl, p.cl_scene, cams, N, &td,
                                                    round ? "opencl draw list, after edits" : "opencl draw list");
                    longest = l > longest ? l : longest;
                }
            for (int e = 0; e < 30; ++e)
                random_edit(&p, &w, &rng, depth ? 3 : 16, 2);
        }
        pair_free(&p);
        free_world(&w);
    }
    /* An empty scene (no object slot at all), both ID modes: empty lists. */
    tworld empty;
    memset(&empty, 0, sizeof empty);
    empty.size[0] = empty.size[1] = empty.size[2] = 32.0f;
    pair pe;
    pair_make(&pe, cl, &empty, NULL, 0);
    vis_camera look = {{-5, 20, -5}, {16, 0, 16}, 60, 0, 0};
    for (uint32_t mode = 0; mode < 2; ++mode) {
        vis_trace_desc td = desc_make(24, 16, (vis_id_mode)mode, VIS_TRAVERSAL_STACK);
        check_trace_drawlist(pe.cpu, pe.cpu_scene, pe.cl, pe.cl_scene, &look, 1, &td, "opencl draw list, empty scene");
    }
    pair_free(&pe);
    printf("device draw lists: longest %zu entries\n", longest);
    assert_true(longest >= 64); /* the radix sort's passes ran, not only its insertion sort */
    vis_context_destroy(cl);
}

/* One view's list comes back with a first read sized by the list before it (at least 1,024
 * entries) and its rest with a second read when longer (cl_drawlist.c). Lists past 1,024
 * entries on a fresh context, after a short list and after a long one, and a short one after
 * a long one: each equals the CPU's. */
static void test_drawlist_long_lists(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    uint64_t rng = 77;
    tworld w;
    random_chunk_world(&w, &rng, 64, 1, 64);
    pair p;
    pair_make(&p, cl, &w, NULL, 0);
    vis_scene_info si;
    assert_int_equal(vis_scene_get_info(p.cl_scene, &si), VIS_OK);
    assert_true(si.objects > 2048u);
    vis_camera over = {{w.size[0] * 0.5, w.size[0] * 1.5, w.size[2] * 0.5}, {w.size[0] * 0.5, 0, w.size[2] * 0.5 + 1},
                       40, 0, 0};
    vis_camera over2 = over; /* another long list: pinned memory holds no copy of it */
    over2.eye[0] += 3;
    vis_camera close = {{-4, 8, -4}, {0, 8, 0}, 30, 0, 0}; /* the corner chunk */
    vis_camera cams[5] = {over, close, over2, over, close};
    size_t longest = 0;
    for (uint32_t mode = 0; mode < 2; ++mode) {
        vis_trace_desc td = desc_make(256, 256, (vis_id_mode)mode, VIS_TRAVERSAL_STACK);
        size_t l = check_trace_drawlist(p.cpu, p.cpu_scene, p.cl, p.cl_scene, cams, 5, &td, "opencl long draw lists");
        longest = l > longest ? l : longest;
    }
    printf("device draw lists: longest %zu entries of %u objects\n", longest, si.objects);
    assert_true(longest > 1024u + 1024u / 4u + 64u); /* past the first read after a list of 1,024 */
    pair_free(&p);
    free_world(&w);
    vis_context_destroy(cl);
}

/* Bad input is rejected before any work on OpenCL too, buffers untouched; timing exists. */
static void test_errors_and_timing(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    vis_timing tm;
    assert_int_equal(vis_context_last_timing(cl, &tm), VIS_ERROR_NOT_FOUND);
    uint64_t rng = 1;
    tworld w;
    random_chunk_world(&w, &rng, 2, 2, 2);
    vis_scene *s = make_scene(cl, &w, NULL, 0);
    uint32_t ids[64];
    float depth[64];
    for (int i = 0; i < 64; ++i)
        ids[i] = 0xABCDABCD, depth[i] = -7.0f;
    vis_camera c = {{1, 20, 1}, {16, 0, 16}, 60, 0.1, 100};
    c.eye[0] = NAN;
    vis_trace_desc td = desc_make(8, 8, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    assert_int_equal(vis_trace(cl, s, &c, &td, ids, 64, depth, 64), VIS_ERROR_INVALID_ARGUMENT);
    for (int i = 0; i < 64; ++i)
        assert_true(ids[i] == 0xABCDABCD && depth[i] == -7.0f);
    c.eye[0] = 1;
    assert_int_equal(vis_trace(cl, s, &c, &td, ids, 64, depth, 64), VIS_OK);
    assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
    assert_int_equal(tm.views, 1);
    assert_int_equal(tm.rays, 64);
    assert_true(tm.kernel_ms > 0.0 && tm.total_ms >= tm.kernel_ms * 0.5);
    assert_true(tm.upload_bytes > 0); /* the first trace sent the scene */
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(cl);
}

/* $VIS_OPENCL_BUILD_OPTIONS: a tuning option is taken and changes nothing; options that would
 * change results (relaxed math, macro definitions) fail the context's creation. */
static void test_build_options(void **state)
{
    (void)state;
    REQUIRE_OPENCL(plain);
    uint64_t rng = 7;
    tworld w;
    random_chunk_world(&w, &rng, 2, 2, 2);
    vis_camera c = {{1, 20, 1}, {16, 0, 16}, 60, 0.1, 100};
    vis_trace_desc td = desc_make(16, 16, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    uint32_t want[256], got[256];
    vis_scene *s = make_scene(plain, &w, NULL, 0);
    assert_int_equal(vis_trace(plain, s, &c, &td, want, 256, NULL, 0), VIS_OK);
    vis_scene_destroy(s);
    vis_context_destroy(plain);
    const char *saved = getenv("VIS_OPENCL_BUILD_OPTIONS");
    char keep[512];
    snprintf(keep, sizeof keep, "%s", saved ? saved : "");
    const char *refused[] = {"-cl-fast-relaxed-math", "-cl-mad-enable", "-DVIS_TRAVERSAL_ONLY=1u",
                             "-w -UVIS_CL_LEAF_SIZE"};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; ++i) {
        setenv("VIS_OPENCL_BUILD_OPTIONS", refused[i], 1);
        vis_status st = VIS_OK;
        vis_context *bad = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
        if (bad)
            vis_context_destroy(bad);
        if (st != VIS_ERROR_INVALID_ARGUMENT)
            fail_msg("VIS_OPENCL_BUILD_OPTIONS=%s: status %d, want invalid argument", refused[i], (int)st);
    }
    setenv("VIS_OPENCL_BUILD_OPTIONS", "-w", 1); /* no warnings: changes nothing */
    vis_status st = VIS_OK;
    vis_context *tuned = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
    if (saved)
        setenv("VIS_OPENCL_BUILD_OPTIONS", keep, 1);
    else
        unsetenv("VIS_OPENCL_BUILD_OPTIONS");
    assert_int_equal(st, VIS_OK);
    s = make_scene(tuned, &w, NULL, 0);
    assert_int_equal(vis_trace(tuned, s, &c, &td, got, 256, NULL, 0), VIS_OK);
    assert_memory_equal(got, want, sizeof want);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(tuned);
}

/* test_walks sets $VIS_OPENCL_WALK and $VIS_OPENCL_TILE per context; its setup saves them and
 * its teardown puts them back even when the test fails half-way, so that the tests after it
 * run with the environment they were started with. */
static struct {
    int had_walk, had_tile;
    char walk[128], tile[64];
} g_walk_env;

static int walk_env_save(void **state)
{
    (void)state;
    const char *w = getenv("VIS_OPENCL_WALK"), *t = getenv("VIS_OPENCL_TILE");
    g_walk_env.had_walk = w != NULL;
    g_walk_env.had_tile = t != NULL;
    snprintf(g_walk_env.walk, sizeof g_walk_env.walk, "%s", w ? w : "");
    snprintf(g_walk_env.tile, sizeof g_walk_env.tile, "%s", t ? t : "");
    return 0;
}

static int walk_env_restore(void **state)
{
    (void)state;
    if (g_walk_env.had_walk)
        setenv("VIS_OPENCL_WALK", g_walk_env.walk, 1);
    else
        unsetenv("VIS_OPENCL_WALK");
    if (g_walk_env.had_tile)
        setenv("VIS_OPENCL_TILE", g_walk_env.tile, 1);
    else
        unsetenv("VIS_OPENCL_TILE");
    return 0;
}

/* $VIS_OPENCL_WALK (docs/opencl.md "Persistent threads and leaf postponing"): every walk gives
 * the CPU's buffers, single views (part-filled edge tiles), batches and device draw lists,
 * with the default and a one-warp work-group; unknown words are refused, and the warp vote
 * is refused off NVIDIA (and without postpone anywhere). */
static void test_walks(void **state)
{
    (void)state;
    REQUIRE_OPENCL(plain);
    vis_backend_info bi;
    vis_context_backend(plain, &bi);
    vis_context_destroy(plain);
    static const struct { const char *walk; vis_status want; } refused[] = {
        {"persistent+bogus", VIS_ERROR_INVALID_ARGUMENT}, {"postpone5", VIS_ERROR_INVALID_ARGUMENT},
        {"vote", VIS_ERROR_UNSUPPORTED}};
    for (size_t i = 0; i < sizeof refused / sizeof refused[0]; ++i) {
        setenv("VIS_OPENCL_WALK", refused[i].walk, 1);
        vis_status st = VIS_OK;
        vis_context *bad = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
        if (bad)
            vis_context_destroy(bad);
        if (st != refused[i].want)
            fail_msg("VIS_OPENCL_WALK=%s: status %d, want %d", refused[i].walk, (int)st, (int)refused[i].want);
    }
    static const struct { const char *walk, *tile; } walks[] = {
        {"persistent", NULL}, {"postpone", NULL}, {"postpone4", "8x4"}, {"persistent,postpone1", "8x4"},
        {"persistent+postpone+vote", NULL}};
    uint64_t rng = 4242;
    tworld w;
    random_chunk_world(&w, &rng, 3, 2, 3);
    const double zero[3] = {0, 0, 0};
    enum { N = 6, W = 37, H = 29 };
    vis_camera cams[N];
    for (int i = 0; i < N; ++i)
        random_view(&cams[i], &rng, w.size, zero);
    for (size_t k = 0; k < sizeof walks / sizeof walks[0]; ++k) {
        int nvidia = strstr(bi.device, "NVIDIA") || strstr(bi.device, "H200") || strstr(bi.device, "GeForce");
        if (strstr(walks[k].walk, "vote") && !nvidia)
            continue; /* refused off NVIDIA (above) */
        setenv("VIS_OPENCL_WALK", walks[k].walk, 1);
        if (walks[k].tile)
            setenv("VIS_OPENCL_TILE", walks[k].tile, 1);
        else if (g_walk_env.had_tile)
            setenv("VIS_OPENCL_TILE", g_walk_env.tile, 1);
        else
            unsetenv("VIS_OPENCL_TILE");
        vis_status st = VIS_OK;
        vis_context *cl = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
        if (!cl)
            fail_msg("VIS_OPENCL_WALK=%s: status %d: %s", walks[k].walk, (int)st, g_log);
        pair p;
        pair_make(&p, cl, &w, NULL, 0);
        char what[160];
        snprintf(what, sizeof what, "VIS_OPENCL_WALK=%s", walks[k].walk);
        /* The stack method on every camera; persistent kernels run every method's program: all
         * methods on one camera. */
        for (int i = 0; i < N; ++i)
            compare_view_sel(&p, &cams[i], W, H, i == 0 && strstr(walks[k].walk, "persistent") ? VIS_TRAVERSAL_DDA + 1u : 1u,
                             TREE_TRAVERSALS, what);
        size_t px = (size_t)W * H;
        uint32_t *ref = malloc(N * px * 4), *ids = malloc(N * px * 4);
        float *ref_d = malloc(N * px * 4), *depth = malloc(N * px * 4);
        for (uint32_t mode = 0; mode < 2; ++mode) {
            vis_trace_desc td = desc_make(W, H, (vis_id_mode)mode, VIS_TRAVERSAL_STACK);
            for (int i = 0; i < N; ++i)
                assert_int_equal(vis_trace(p.cpu, p.cpu_scene, &cams[i], &td, ref + i * px, px, ref_d + i * px, px),
                                 VIS_OK);
            if (vis_trace_batch(p.cl, p.cl_scene, cams, N, &td, ids, N * px, depth, N * px) != VIS_OK)
                fail_msg("%s: batch: %s", what, vis_context_last_error(p.cl));
            compare_buffers(ref, ref_d, ids, depth, N * px, W, what, mode, 0);
            check_trace_drawlist(p.cpu, p.cpu_scene, p.cl, p.cl_scene, cams, N, &td, what);
            /* Twice in a row: the persistent kernels' counter is back at zero after a launch. */
            check_trace_drawlist(p.cpu, p.cpu_scene, p.cl, p.cl_scene, cams, N, &td, what);
        }
        free(ref), free(ids), free(ref_d), free(depth);
        pair_free(&p);
        vis_context_destroy(cl);
    }
    free_world(&w);
}

/* A device without double precision (pretended with $VIS_OPENCL_ASSUME_NO_FP64) traces quad
 * scenes as any other, and refuses a scene holding triangles with its reason instead of
 * tracing it differently from the CPU (the triangle test's fallback needs fp64). */
static void test_no_fp64_refuses_triangles(void **state)
{
    (void)state;
    REQUIRE_OPENCL(plain);
    uint64_t rng = 77;
    tworld w;
    random_chunk_world(&w, &rng, 2, 2, 2);
    for (uint32_t i = 0; i < w.n; ++i)
        w.objs[i].nt = 0; /* quads only: the entities' triangles dropped */
    vis_camera c = {{1, 20, 1}, {16, 0, 16}, 60, 0.1, 100};
    vis_trace_desc td = desc_make(16, 16, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
    uint32_t want[256], got[256];
    vis_scene *s = make_scene(plain, &w, NULL, 0);
    assert_int_equal(vis_trace(plain, s, &c, &td, want, 256, NULL, 0), VIS_OK);
    vis_scene_destroy(s);
    vis_context_destroy(plain);

    setenv("VIS_OPENCL_ASSUME_NO_FP64", "1", 1);
    vis_status st = VIS_OK;
    vis_context *cl = make_ctx(VIS_BACKEND_OPENCL, NULL, &st);
    unsetenv("VIS_OPENCL_ASSUME_NO_FP64");
    if (!cl)
        fail_msg("no context without fp64: %s (%s)", vis_status_string(st), g_log);
    assert_non_null(strstr(g_log, "cl_khr_fp64"));
    s = make_scene(cl, &w, NULL, 0);
    assert_int_equal(vis_trace(cl, s, &c, &td, got, 256, NULL, 0), VIS_OK);
    assert_memory_equal(got, want, sizeof want);
    tobj *t = add_obj(&w, 500000);
    const float a[3] = {2, 2, 2}, b[3] = {12, 2, 2}, d[3] = {2, 12, 12};
    obj_tri(t, a, b, d);
    set_obj(s, t);
    assert_int_equal(vis_trace(cl, s, &c, &td, got, 256, NULL, 0), VIS_ERROR_UNSUPPORTED);
    const char *why = vis_context_last_error(cl);
    if (!strstr(why, "cl_khr_fp64") || !strstr(why, "triangles"))
        fail_msg("refusal without its reason: \"%s\"", why);
    vis_scene_destroy(s);
    free_world(&w);
    vis_context_destroy(cl);
}

/* A generated terrain (greedy chunk meshes, the real workload) with voxel edits: two copies
 * of the same world, one scene per backend, the same edits applied to both. */
/* The same world loaded twice, one scene on the CPU and one on OpenCL, edited in lockstep. */
typedef struct world_pair {
    vw_world *wa, *wb;
    world_scene *sa, *sb;
    pair p;
    uint32_t traversals;
    vc_view views[VC_MAX_VIEWS];
    size_t nviews;
} world_pair;

static void world_pair_open(world_pair *wp, vis_context *cpu, vis_context *cl, const char *spec)
{
    memset(wp, 0, sizeof *wp);
    vw_error err;
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &wp->wa, &err) != VW_OK ||
        vw_world_from_spec(spec, NULL, NULL, NULL, &wp->wb, &err) != VW_OK)
        fail_msg("%s: %s", spec, err.message);
    assert_int_equal(world_scene_create(cpu, wp->wa, NULL, &wp->sa, NULL, &err), 0);
    assert_int_equal(world_scene_create(cl, wp->wb, NULL, &wp->sb, NULL, &err), 0);
    pair p = {cpu, cl, world_scene_scene(wp->sa), world_scene_scene(wp->sb), 0};
    wp->p = p;
    wp->traversals = traversal_count(cpu, p.cpu_scene);
    wp->nviews = vc_camera_path(wp->wa, wp->views, VC_MAX_VIEWS);
    assert_true(wp->nviews > 0);
}

static void world_pair_close(world_pair *wp)
{
    world_scene_destroy(wp->sa);
    world_scene_destroy(wp->sb);
    vw_world_destroy(wp->wa);
    vw_world_destroy(wp->wb);
}

static void test_terrain_with_voxel_edits(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    const char *spec = vt_small() ? "gen:terrain:size=96x64x96:seed=7" : "gen:terrain:size=192x96x192:seed=7";
    vis_context *cpu = make_ctx(VIS_BACKEND_CPU, NULL, NULL);
    world_pair wp;
    world_pair_open(&wp, cpu, cl, spec);
    vw_world *wa = wp.wa, *wb = wp.wb;
    world_scene *sa = wp.sa, *sb = wp.sb;
    pair p = wp.p;
    uint32_t trav = wp.traversals;
    vc_view *views = wp.views;
    size_t nv = wp.nviews;
    vw_error err;
    /* The brute force tests every quad of the world per ray: one small view only. */
    compare_view(&p, &views[0].camera, 16, 16, trav, views[0].name);
    for (size_t i = 0; i < nv; ++i)
        compare_view_sel(&p, &views[i].camera, 64, 64, trav, TREE_TRAVERSALS, views[i].name);
    vw_world_info info;
    vw_world_get_info(wa, &info);
    uint64_t rng = 4711;
    int rounds = vt_small() ? 2 : 5;
    uint64_t one_edit_bytes = 0;
    for (int r = 0; r < rounds; ++r) {
        int edits = r == 0 ? 1 : 16;
        for (int e = 0; e < edits; ++e) {
            int64_t x = info.origin[0] + (int64_t)(vt_rand(&rng) % (uint64_t)info.size[0]);
            int64_t z = info.origin[2] + (int64_t)(vt_rand(&rng) % (uint64_t)info.size[2]);
            int64_t y = vc_surface_height(wa, x, z) - (int64_t)(vt_rand(&rng) % 2);
            vw_voxel v = (vw_voxel)(vt_rand(&rng) % 2 ? 0 : 3);
            assert_int_equal(vw_world_set(wa, x, y, z, v), VW_OK);
            assert_int_equal(vw_world_set(wb, x, y, z, v), VW_OK);
        }
        assert_int_equal(world_scene_update(sa, NULL, &err), 0);
        assert_int_equal(world_scene_update(sb, NULL, &err), 0);
        if (r == 0 && nv > 0) { /* the first OpenCL trace after the one edit sends what it changed */
            vis_trace_desc td1 = desc_make(1, 1, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
            uint32_t id1;
            vis_timing tm;
            assert_int_equal(vis_trace(cl, p.cl_scene, &views[0].camera, &td1, &id1, 1, NULL, 0), VIS_OK);
            assert_int_equal(vis_context_last_timing(cl, &tm), VIS_OK);
            one_edit_bytes = tm.upload_bytes;
        }
        for (size_t i = 0; i < nv; ++i)
            compare_view_sel(&p, &views[i].camera, 64, 64, trav, TREE_TRAVERSALS, views[i].name);
    }
    vis_scene_info si;
    vis_scene_get_info(p.cl_scene, &si);
    printf("terrain %s: %u objects, one voxel edit uploaded %llu bytes\n", spec, si.objects,
           (unsigned long long)one_edit_bytes);
    assert_true(one_edit_bytes > 0 && one_edit_bytes < 65536);
    world_pair_close(&wp);
    vis_context_destroy(cpu);
    vis_context_destroy(cl);
}

/* The real .vox scenes of ../shared/data (made by others, see ATTRIBUTION.md): CPU and OpenCL
 * agree bit for bit along each scene's camera path, with a burst of voxel edits between. */
static void test_real_vox_scenes(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    static const char *const files[] = {"vox/mmmm_scene_store8.vox", "vox/mmmm_scene_church1.vox",
                                        "vox/vengi_test-transform.vox", "vox/vengi_8ontop.vox",
                                        "vox/ogt_test_multiple_model_scene.vox", "vox/vengi_test_material.vox"};
    vis_context *cpu = make_ctx(VIS_BACKEND_CPU, NULL, NULL);
    int ran = 0;
    for (size_t f = 0; f < sizeof files / sizeof files[0]; ++f) {
        const char *path = vt_shared_file(files[f]);
        if (!path)
            continue; /* vt_shared_file printed why; counted below */
        world_pair wp;
        world_pair_open(&wp, cpu, cl, path);
        vw_world *wa = wp.wa, *wb = wp.wb;
        vw_error err;
        vw_world_info info;
        vw_world_get_info(wa, &info);
        uint64_t rng = 99 + f;
        for (int round = 0; round < 2; ++round) {
            for (size_t i = 0; i < wp.nviews; ++i)
                compare_view_sel(&wp.p, &wp.views[i].camera, 48, 40, wp.traversals, TREE_TRAVERSALS,
                                 wp.views[i].name);
            for (int e = 0; e < 24; ++e) { /* toggle voxels near the surface in both worlds */
                int64_t x = info.origin[0] + (int64_t)(vt_rand(&rng) % (uint64_t)info.size[0]);
                int64_t z = info.origin[2] + (int64_t)(vt_rand(&rng) % (uint64_t)info.size[2]);
                int64_t y = vc_surface_height(wa, x, z) - (int64_t)(vt_rand(&rng) % 2);
                if (y < info.origin[1] || y >= info.origin[1] + info.size[1])
                    continue;
                vw_voxel v = (vw_voxel)(vt_rand(&rng) % 2 ? 0 : 2);
                assert_int_equal(vw_world_set(wa, x, y, z, v), VW_OK);
                assert_int_equal(vw_world_set(wb, x, y, z, v), VW_OK);
            }
            assert_int_equal(world_scene_update(wp.sa, NULL, &err), 0);
            assert_int_equal(world_scene_update(wp.sb, NULL, &err), 0);
        }
        ++ran;
        world_pair_close(&wp);
    }
    printf("real .vox scenes compared: %d\n", ran);
    vis_context_destroy(cpu);
    vis_context_destroy(cl);
    if ((size_t)ran != sizeof files / sizeof files[0])
        skip(); /* not every scene was compared: the SKIP lines above say which */
}

/* Cameras aimed exactly at voxel edges and corners (eye exact in float, target = the point, a
 * 1x1 image whose pixel centre is the target), in batches: the OpenCL stack method equals the
 * CPU's bit for bit, and no ray slips against the double-precision reference
 * (tests/support/ref_trace.c; test_trace.c runs 10^6 such rays on the CPU). */
static void keep_chunk(uint32_t chunk, uint32_t id, const vw_mesh *m, void *user)
{
    (void)chunk;
    tobj *o = add_obj_quads(user, id, (uint32_t)m->count);
    world_scene_convert_quads(m->quads, m->count, o->quads);
}

static void test_aimed_cameras(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    static const char *const specs[] = {"gen:terrain:size=64x48x64:seed=3", "gen:city:size=64x48x64:seed=2"};
    enum { BATCH = 2048 };
    int count = vt_small() ? 2048 : 16384;
    vis_context *cpu = make_ctx(VIS_BACKEND_CPU, NULL, NULL);
    vis_camera *cams = malloc(BATCH * sizeof *cams);
    uint32_t *ia = malloc(BATCH * 4), *ib = malloc(BATCH * 4);
    float *da = malloc(BATCH * 4), *db = malloc(BATCH * 4);
    uint64_t rng = 4242, rays = 0;
    for (size_t wi = 0; wi < sizeof specs / sizeof specs[0]; ++wi) {
        world_pair wp;
        world_pair_open(&wp, cpu, cl, specs[wi]);
        tworld w;
        memset(&w, 0, sizeof w);
        vw_error err;
        assert_int_equal(world_scene_for_each_object(wp.sa, keep_chunk, &w, &err), 0);
        vis_scene_info info;
        vis_scene_get_info(wp.p.cpu_scene, &info);
        for (int a = 0; a < 3; ++a)
            w.size[a] = (float)info.size[a];
        ref_scene rs;
        ref_scene_init(&rs, &w);
        for (int done = 0; done < count; done += BATCH) {
            for (int i = 0; i < BATCH; ++i) {
                double pt[3], e[3];
                ref_edge_point(&w, &rng, pt);
                ref_random_eye(&rng, w.size, pt, e);
                memset(&cams[i], 0, sizeof cams[i]);
                for (int a = 0; a < 3; ++a) {
                    cams[i].eye[a] = info.origin[a] + e[a];
                    cams[i].target[a] = info.origin[a] + pt[a];
                }
            }
            vis_trace_desc td = desc_make(1, 1, VIS_IDS_OBJECT, VIS_TRAVERSAL_STACK);
            if (vis_trace_batch(cpu, wp.p.cpu_scene, cams, BATCH, &td, ia, BATCH, da, BATCH) != VIS_OK)
                fail_msg("cpu: %s", vis_context_last_error(cpu));
            if (vis_trace_batch(cl, wp.p.cl_scene, cams, BATCH, &td, ib, BATCH, db, BATCH) != VIS_OK)
                fail_msg("opencl: %s", vis_context_last_error(cl));
            for (int i = 0; i < BATCH; ++i) {
                const vis_camera *c = &cams[i];
                char why[256];
                if (ia[i] != ib[i] || memcmp(&da[i], &db[i], 4) != 0)
                    fail_msg("%s, camera (%g, %g, %g) -> (%g, %g, %g): cpu id %u t %.9g, opencl id %u t %.9g",
                             specs[wi], c->eye[0], c->eye[1], c->eye[2], c->target[0], c->target[1], c->target[2],
                             ia[i], (double)da[i], ib[i], (double)db[i]);
                ref_camera rc;
                assert_true(ref_camera_make(c, info.origin, 1, 1, &rc));
                ref_ray rr;
                ref_camera_ray(&rc, 0, 0, &rr);
                if (ref_check(&rs, &rr, ib[i], db[i], NULL, why, sizeof why))
                    fail_msg("%s, camera (%g, %g, %g) -> (%g, %g, %g), opencl: %s", specs[wi], c->eye[0], c->eye[1],
                             c->eye[2], c->target[0], c->target[1], c->target[2], why);
                ++rays;
            }
        }
        ref_scene_free(&rs);
        free_world(&w);
        world_pair_close(&wp);
    }
    printf("aimed cameras on OpenCL: %llu rays, none slipped\n", (unsigned long long)rays);
    free(cams), free(ia), free(ib), free(da), free(db);
    vis_context_destroy(cpu);
    vis_context_destroy(cl);
}

/* vis_trace_effects on OpenCL equals the CPU's buffers bit for bit (the CPU's equal the
 * brute force: test_effects.c), on worlds with water and glass, for the stack method and the
 * brute force and the cell-grid walk (the GPU default), every effect together and reflections
 * and shadows without see-through. Small
 * images: every (method, effect set) is a program of its own, which PoCL builds slowly. */
static void test_effects_bit_identical(void **state)
{
    (void)state;
    REQUIRE_OPENCL(cl);
    static const char *const specs[] = {"gen:terrain:size=64x48x64:seed=3", "gen:city:size=64x48x64:seed=2"};
    static const struct { vis_traversal method; uint32_t effects; } runs[] = {
        {VIS_TRAVERSAL_STACK, VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG},
        {VIS_TRAVERSAL_BRUTEFORCE, VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG},
        {VIS_TRAVERSAL_STACK, VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS},
        {VIS_TRAVERSAL_DDA, VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG},
    };
    enum { S = 24, N = S * S, L = 3 };
    vis_context *cpu = make_ctx(VIS_BACKEND_CPU, NULL, NULL);
    uint32_t *buf[2][4];
    float *depth[2];
    for (int k = 0; k < 2; ++k) {
        for (int j = 0; j < 4; ++j)
            assert_non_null(buf[k][j] = calloc((size_t)N * L, 4));
        assert_non_null(depth[k] = calloc(N, 4));
    }
    uint64_t seen = 0;
    for (size_t wi = 0; wi < sizeof specs / sizeof specs[0]; ++wi) {
        world_pair wp;
        world_pair_open(&wp, cpu, cl, specs[wi]);
        vis_scene_info info;
        vis_scene_get_info(wp.p.cpu_scene, &info);
        const float *sz = info.size;
        vis_camera cam = {{sz[0] * 0.1, sz[1] * 0.9, sz[2] * 0.1}, {sz[0] * 0.6, sz[1] * 0.2, sz[2] * 0.7}, 60, 0.05, 0};
        for (size_t r = 0; r < sizeof runs / sizeof runs[0]; ++r) {
            vis_trace_desc td = desc_make(S, S, VIS_IDS_OBJECT, runs[r].method);
            td.effects = runs[r].effects;
            td.see_through_layers = L;
            td.light_dir[0] = 1.0, td.light_dir[1] = 0.7, td.light_dir[2] = 0.4;
            td.fog_dist = 0.5 * sz[0];
            for (int k = 0; k < 2; ++k) {
                vis_effect_buffers b = {buf[k][0], N, depth[k], N, buf[k][1], (size_t)N * L, buf[k][2], N, buf[k][3], N};
                vis_context *c = k ? cl : cpu;
                if (vis_trace_effects(c, k ? wp.p.cl_scene : wp.p.cpu_scene, &cam, &td, &b) != VIS_OK)
                    fail_msg("%s: %s", k ? "opencl" : "cpu", vis_context_last_error(c));
            }
            size_t st_n = (td.effects & VIS_EFFECT_SEE_THROUGH) ? (size_t)N * L : 0;
            assert_memory_equal(buf[0][0], buf[1][0], N * 4);
            assert_memory_equal(depth[0], depth[1], N * 4);
            if (st_n)
                assert_memory_equal(buf[0][1], buf[1][1], st_n * 4);
            assert_memory_equal(buf[0][2], buf[1][2], N * 4);
            assert_memory_equal(buf[0][3], buf[1][3], N * 4);
            for (int i = 0; i < N; ++i)
                seen += (st_n && buf[1][1][(size_t)i * L] != 0) + (buf[1][2][i] != 0) + (buf[1][3][i] != 0);
        }
        world_pair_close(&wp);
    }
    printf("effects on OpenCL: %llu see-through, reflection and shadow results, all equal to the CPU's\n",
           (unsigned long long)seen);
    assert_true(seen > 0);
    for (int k = 0; k < 2; ++k) {
        for (int j = 0; j < 4; ++j)
            free(buf[k][j]);
        free(depth[k]);
    }
    vis_context_destroy(cpu);
    vis_context_destroy(cl);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_auto_reports_reason),
        cmocka_unit_test(test_bad_selector_not_found),
        cmocka_unit_test(test_errors_and_timing),
        cmocka_unit_test(test_build_options),
        cmocka_unit_test_setup_teardown(test_walks, walk_env_save, walk_env_restore),
        cmocka_unit_test(test_no_fp64_refuses_triangles),
        cmocka_unit_test(test_hard_cases),
        cmocka_unit_test(test_batch),
        cmocka_unit_test(test_drawlist_on_device),
        cmocka_unit_test(test_drawlist_long_lists),
        cmocka_unit_test(test_edit_uploads_only_changed_bytes),
        cmocka_unit_test(test_edit_fills_empty_cells),
        cmocka_unit_test(test_pool_growth_reallocates),
        cmocka_unit_test(test_terrain_with_voxel_edits),
        cmocka_unit_test(test_real_vox_scenes),
        cmocka_unit_test(test_random_worlds_bit_identical),
        cmocka_unit_test(test_aimed_cameras),
        cmocka_unit_test(test_effects_bit_identical),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
