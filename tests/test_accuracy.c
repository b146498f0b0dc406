/*
 * test_accuracy.c — `vis accuracy` and the arithmetic behind it (tools/common/accuracy.c):
 * missed / overdraw / area on hand-made draw lists and against a per-ID brute force on random
 * ones; averages over a path; display-shaped buffers; the frustum test. Then the properties
 * the study relies on, on a small generated city: the truth compared with itself is perfect,
 * leaf IDs never miss more than object IDs at the same resolution, and the z-buffer culler
 * never misses an object the ray pass at its resolution sees. Last, one small `vis accuracy`
 * run of the built binary: the CSV's columns and rows, the JSON, and a missing gnuplot; and
 * `vis bench --method zbuf`, the culler's timing along the camera path. And the report's
 * safety: scene and directory names built to run gnuplot commands run none, and a failed
 * gnuplot or CSV write leaves the files (or devices) that were there.
 */
#define _POSIX_C_SOURCE 200809L
#define _XOPEN_SOURCE 700 /* mknod and S_IFCHR, for the device-node outputs */

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmocka.h>

#include "accuracy.h"
#include "camera_path.h"
#include "run_tool.h"
#include "test_support.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

#define VIS_EXE VIS_BINARY_DIR "/tools/vis"
#define CITY "gen:city:size=96x48x96:seed=2"

static char tmp_dir[256];

/* ---- the arithmetic on hand-made lists ---------------------------------------------------- */

static void test_compare_by_hand(void **state)
{
    (void)state;
    /* Truth: 1 (10 samples), 3 (5), 5 (1), 7 (listed with 0 samples: not visible). */
    vis_draw_entry truth[] = {{1, 10}, {3, 5}, {5, 1}, {7, 0}};
    /* Drawn: 1 and 5 (hits), 2, 7 and 9 (not visible: overdraw); 3 is missed. */
    vis_draw_entry drawn[] = {{1, 0}, {2, 0}, {5, 3}, {7, 0}, {9, 0}};
    uint32_t tris[12] = {0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22};
    /* In view: 1..9 except 4; 10 and 11 are in view and in neither list (hidden, culled). */
    uint8_t in_view[12] = {0, 1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1};
    vc_accuracy_objects objects = {tris, in_view, 12};
    vc_accuracy r;
    assert_int_equal(vc_accuracy_compare(truth, 4, 100, drawn, 5, &objects, &r), 0);
    assert_int_equal(r.truth_visible, 3);
    assert_int_equal(r.drawn, 5);
    assert_int_equal(r.missed, 1);
    assert_true(fabs(r.missed_area - 0.05) < 1e-15);
    assert_int_equal(r.overdraw, 3);
    assert_int_equal(r.overdraw_triangles, 4 + 14 + 18);
    /* Hidden (in view, not visible): 2, 6, 7, 8, 9, 10, 11; culled: 6, 8, 10, 11. */
    assert_int_equal(r.hidden, 7);
    assert_int_equal(r.hidden_culled, 4);

    /* Without the tables: no triangles, nothing hidden. */
    assert_int_equal(vc_accuracy_compare(truth, 4, 100, drawn, 5, NULL, &r), 0);
    assert_int_equal(r.missed, 1);
    assert_int_equal(r.overdraw, 3);
    assert_int_equal(r.overdraw_triangles, 0);
    assert_int_equal(r.hidden, 0);

    /* Nothing drawn: everything visible is missed, the whole truth area. */
    assert_int_equal(vc_accuracy_compare(truth, 4, 16, NULL, 0, NULL, &r), 0);
    assert_int_equal(r.missed, 3);
    assert_true(fabs(r.missed_area - 1.0) < 1e-15);
    assert_int_equal(r.overdraw, 0);

    /* Nothing visible: everything drawn is overdraw. */
    assert_int_equal(vc_accuracy_compare(NULL, 0, 100, drawn, 5, &objects, &r), 0);
    assert_int_equal(r.truth_visible, 0);
    assert_int_equal(r.missed, 0);
    assert_true(r.missed_area == 0.0);
    assert_int_equal(r.overdraw, 5);
    assert_int_equal(r.overdraw_triangles, 2 + 4 + 10 + 14 + 18);

    /* IDs beyond the tables count no triangles and are never in view. */
    vis_draw_entry far_ids[] = {{40, 0}};
    assert_int_equal(vc_accuracy_compare(NULL, 0, 100, far_ids, 1, &objects, &r), 0);
    assert_int_equal(r.overdraw, 1);
    assert_int_equal(r.overdraw_triangles, 0);

    /* Unsorted or repeated IDs, or samples = 0 with a missed object: refused, out untouched. */
    vis_draw_entry unsorted[] = {{3, 1}, {2, 1}};
    vis_draw_entry repeated[] = {{2, 1}, {2, 1}};
    memset(&r, 0xAB, sizeof r);
    vc_accuracy before = r;
    assert_int_equal(vc_accuracy_compare(unsorted, 2, 10, drawn, 5, NULL, &r), -1);
    assert_int_equal(vc_accuracy_compare(truth, 4, 10, repeated, 2, NULL, &r), -1);
    assert_int_equal(vc_accuracy_compare(truth, 4, 0, drawn, 5, NULL, &r), -1);
    assert_memory_equal(&r, &before, sizeof r);
}

/* Misses per reason: an object counts under each reason the truth gives it, and only when
 * the drawn list lacks it altogether. */
static void test_reasons_by_hand(void **state)
{
    (void)state;
    vis_effect_entry truth[] = {
        {1, VIS_REASON_DIRECT, {5, 0, 0, 0}},
        {2, VIS_REASON_DIRECT | VIS_REASON_SHADOW, {3, 0, 0, 2}},
        {4, VIS_REASON_SEE_THROUGH, {0, 4, 0, 0}},
        {6, VIS_REASON_REFLECTION | VIS_REASON_SEE_THROUGH, {0, 1, 2, 0}},
        {8, VIS_REASON_SHADOW, {0, 0, 0, 7}},
    };
    /* Drawn: 1, 4 and 9; 2, 6 and 8 are missed. */
    vis_draw_entry drawn[] = {{1, 1}, {4, 1}, {9, 1}};
    uint32_t t[VIS_REASON_COUNT], m[VIS_REASON_COUNT];
    assert_int_equal(vc_accuracy_reasons(truth, 5, drawn, 3, t, m), 0);
    assert_int_equal(t[0], 2); /* direct: 1, 2          */
    assert_int_equal(m[0], 1); /*   missed: 2           */
    assert_int_equal(t[1], 2); /* see-through: 4, 6     */
    assert_int_equal(m[1], 1); /*   missed: 6           */
    assert_int_equal(t[2], 1); /* reflection: 6         */
    assert_int_equal(m[2], 1);
    assert_int_equal(t[3], 2); /* shadow: 2, 8          */
    assert_int_equal(m[3], 2);
    /* Nothing drawn: every reason's objects are missed. */
    assert_int_equal(vc_accuracy_reasons(truth, 5, NULL, 0, t, m), 0);
    for (int k = 0; k < VIS_REASON_COUNT; ++k)
        assert_int_equal(m[k], t[k]);
    /* Unsorted lists are refused and the outputs left alone. */
    vis_effect_entry unsorted[] = {{3, VIS_REASON_DIRECT, {1, 0, 0, 0}}, {2, VIS_REASON_DIRECT, {1, 0, 0, 0}}};
    vis_draw_entry repeated[] = {{2, 1}, {2, 1}};
    memset(t, 0xAB, sizeof t);
    assert_int_equal(vc_accuracy_reasons(unsorted, 2, drawn, 3, t, m), -1);
    assert_int_equal(vc_accuracy_reasons(truth, 5, repeated, 2, t, m), -1);
    assert_int_equal(t[0], 0xABABABABu);
    /* The summary averages them. */
    vc_accuracy f[2];
    memset(f, 0, sizeof f);
    f[0].reason_missed[3] = 2;
    f[1].reason_missed[3] = 4;
    f[1].reason_truth[2] = 3;
    vc_accuracy_summary s;
    vc_accuracy_summarize(f, 2, &s);
    assert_true(s.reason_missed[3] == 3.0);
    assert_true(s.reason_truth[2] == 1.5);
}

/* Random lists against the obvious per-ID count. */
static void test_compare_random(void **state)
{
    (void)state;
    enum { IDS = 200 };
    uint64_t rng = 11;
    int rounds = vt_small() ? 200 : 2000;
    for (int round = 0; round < rounds; ++round) {
        vis_draw_entry truth[IDS], drawn[IDS];
        uint32_t pixels[IDS], tris[IDS];
        uint8_t in_t[IDS], in_d[IDS], view[IDS];
        size_t tn = 0, dn = 0;
        uint64_t samples = 0;
        uint32_t pt = (uint32_t)(vt_rand(&rng) % 100), pd = (uint32_t)(vt_rand(&rng) % 100);
        for (uint32_t id = 0; id < IDS; ++id) {
            in_t[id] = id > 0 && vt_rand(&rng) % 100 < pt;
            in_d[id] = id > 0 && vt_rand(&rng) % 100 < pd;
            pixels[id] = in_t[id] ? (uint32_t)(vt_rand(&rng) % 50) : 0; /* some listed with 0 */
            tris[id] = (uint32_t)(vt_rand(&rng) % 1000);
            view[id] = vt_rand(&rng) % 4 != 0;
            if (in_t[id])
                truth[tn++] = (vis_draw_entry){id, pixels[id]};
            if (in_d[id])
                drawn[dn++] = (vis_draw_entry){id, 0};
            samples += pixels[id];
        }
        samples += vt_rand(&rng) % 1000 + 1; /* background */
        vc_accuracy_objects obj = {tris, view, IDS};
        vc_accuracy r;
        assert_int_equal(vc_accuracy_compare(truth, tn, samples, drawn, dn, &obj, &r), 0);
        uint32_t vis = 0, missed = 0, over = 0, hidden = 0, culled = 0;
        uint64_t missed_px = 0, over_tris = 0;
        for (uint32_t id = 0; id < IDS; ++id) {
            int visible = in_t[id] && pixels[id] > 0;
            vis += visible;
            if (visible && !in_d[id]) {
                ++missed;
                missed_px += pixels[id];
            }
            if (!visible && in_d[id]) {
                ++over;
                over_tris += tris[id];
            }
            if (!visible && view[id]) {
                ++hidden;
                culled += !in_d[id];
            }
        }
        assert_int_equal(r.truth_visible, vis);
        assert_int_equal(r.drawn, dn);
        assert_int_equal(r.missed, missed);
        assert_true(fabs(r.missed_area - (double)missed_px / (double)samples) < 1e-12);
        assert_int_equal(r.overdraw, over);
        assert_int_equal(r.overdraw_triangles, over_tris);
        assert_int_equal(r.hidden, hidden);
        assert_int_equal(r.hidden_culled, culled);
    }
}

static void test_summarize(void **state)
{
    (void)state;
    vc_accuracy f[3];
    memset(f, 0, sizeof f);
    f[0] = (vc_accuracy){10, 12, 1, 0.01, 3, 30, 4, 1, {0}, {0}};
    f[1] = (vc_accuracy){20, 18, 3, 0.04, 1, 10, 6, 6, {0}, {0}};
    f[2] = (vc_accuracy){30, 30, 2, 0.01, 2, 20, 0, 0, {0}, {0}};
    vc_accuracy_summary s;
    vc_accuracy_summarize(f, 3, &s);
    assert_int_equal(s.frames, 3);
    assert_true(fabs(s.truth_visible - 20.0) < 1e-12);
    assert_true(fabs(s.drawn - 20.0) < 1e-12);
    assert_true(fabs(s.missed - 2.0) < 1e-12);
    assert_true(fabs(s.missed_area - 0.02) < 1e-12);
    assert_true(s.missed_area_max == 0.04);
    assert_true(fabs(s.overdraw - 2.0) < 1e-12);
    assert_true(fabs(s.overdraw_triangles - 20.0) < 1e-12);
    assert_true(fabs(s.hidden - 10.0 / 3.0) < 1e-12);
    /* Pooled: (1 + 6 + 0) / (4 + 6 + 0), not the mean of 1/4, 6/6 and (undefined). */
    assert_true(fabs(s.occluded_culled - 0.7) < 1e-12);

    vc_accuracy_summarize(NULL, 0, &s);
    assert_int_equal(s.frames, 0);
    assert_true(s.missed == 0.0 && s.missed_area == 0.0 && s.occluded_culled == 1.0);
}

static void test_buffer_size(void **state)
{
    (void)state;
    uint32_t w, h;
    vc_accuracy_buffer_size(512, 512, 1920, 1080, &w, &h);
    assert_int_equal(w, 683);
    assert_int_equal(h, 384);
    vc_accuracy_buffer_size(64, 64, 1920, 1080, &w, &h);
    assert_int_equal(w, 85);
    assert_int_equal(h, 48);
    vc_accuracy_buffer_size(2048, 2048, 1920, 1080, &w, &h);
    assert_int_equal(w, 2731);
    assert_int_equal(h, 1536);
    vc_accuracy_buffer_size(256, 128, 1920, 1080, &w, &h); /* 32768 pixels */
    assert_int_equal(h, 136);
    assert_int_equal(w, 242);
    vc_accuracy_buffer_size(512, 512, 800, 800, &w, &h); /* a square display: as asked */
    assert_int_equal(w, 512);
    assert_int_equal(h, 512);
    vc_accuracy_buffer_size(1, 1, 16384, 1, &w, &h); /* never below 1 per side */
    assert_int_equal(h, 1);
    assert_int_equal(w, 16384);
    vc_accuracy_buffer_size(16384, 16384, 16384, 1, &w, &h); /* never above the maximum */
    assert_int_equal(w, VIS_MAX_RESOLUTION);
    assert_true(h >= 1 && h <= VIS_MAX_RESOLUTION);
}

static void test_box_in_view(void **state)
{
    (void)state;
    vis_camera c = {{0, 0, 0}, {0, 0, -10}, 60, 0, 0}; /* looking down -z */
    double lo[3], hi[3];
#define BOX(x0, y0, z0, x1, y1, z1) (lo[0] = x0, lo[1] = y0, lo[2] = z0, hi[0] = x1, hi[1] = y1, hi[2] = z1)
    BOX(-1, -1, -11, 1, 1, -9);
    assert_true(vc_box_in_view(&c, 100, 100, lo, hi));
    BOX(-1, -1, 9, 1, 1, 11); /* behind */
    assert_false(vc_box_in_view(&c, 100, 100, lo, hi));
    BOX(-1, 20, -11, 1, 22, -9); /* above: 63 degrees up */
    assert_false(vc_box_in_view(&c, 100, 100, lo, hi));
    /* 40 degrees to the right: outside a square view (half-angle 30), inside a 16:9 one
     * (half-angle atan(tan 30 * 16/9) = 45.8). */
    double x = 10.0 * tan(40.0 * 3.14159265358979 / 180.0);
    BOX(x - 0.1, -0.1, -10.1, x + 0.1, 0.1, -9.9);
    assert_false(vc_box_in_view(&c, 100, 100, lo, hi));
    assert_true(vc_box_in_view(&c, 1920, 1080, lo, hi));
    /* A box around the eye, one crossing the near plane, one beyond far. */
    BOX(-1, -1, -1, 1, 1, 1);
    assert_true(vc_box_in_view(&c, 100, 100, lo, hi));
    c.far_dist = 5.0;
    BOX(-1, -1, -11, 1, 1, -9);
    assert_false(vc_box_in_view(&c, 100, 100, lo, hi));
    /* Straight down (forward parallel to Y: (0,0,-1) stands in for up). */
    vis_camera down = {{5, 100, 5}, {5, 0, 5}, 60, 0, 0};
    BOX(0, 0, 0, 10, 1, 10);
    assert_true(vc_box_in_view(&down, 64, 64, lo, hi));
    BOX(200, 0, 0, 210, 1, 10);
    assert_false(vc_box_in_view(&down, 64, 64, lo, hi));
#undef BOX
}

/* ---- properties on a small city ----------------------------------------------------------- */

typedef struct city {
    vw_world *world;
    vis_context *ctx;
    world_scene *ws;       /* a leaf per chunk                                               */
    world_scene *coarse;   /* three levels shallower: a leaf holds 8 chunks                  */
    vc_view views[VC_MAX_VIEWS + 6];
    size_t nviews;
    size_t cap;
    uint32_t *ids;
    vis_draw_entry *a, *b;
} city;

static void city_open(city *c)
{
    memset(c, 0, sizeof *c);
    vw_error err;
    assert_int_equal(vw_world_from_spec(CITY, NULL, NULL, NULL, &c->world, &err), VW_OK);
    vis_context_desc d;
    memset(&d, 0, sizeof d);
    d.backend = VIS_BACKEND_CPU;
    d.threads = 2;
    assert_int_equal(vis_context_create(&d, &c->ctx), VIS_OK);
    assert_int_equal(world_scene_create(c->ctx, c->world, NULL, &c->ws, NULL, &err), 0);
    vis_scene_info info;
    assert_int_equal(vis_scene_get_info(world_scene_scene(c->ws), &info), VIS_OK);
    assert_true(info.kd_depth > 3);
    world_scene_options o;
    memset(&o, 0, sizeof o);
    o.kd_depth = info.kd_depth - 3;
    assert_int_equal(world_scene_create(c->ctx, c->world, &o, &c->coarse, NULL, &err), 0);
    /* The camera path, and street-level cameras looking along and across the streets. */
    c->nviews = vc_camera_path(c->world, c->views, VC_MAX_VIEWS);
    uint64_t rng = 5;
    for (int i = 0; i < 6; ++i) {
        vc_view *v = &c->views[c->nviews++];
        memset(v, 0, sizeof *v);
        double x = 4 + vt_rand_unit(&rng) * 88, z = 4 + vt_rand_unit(&rng) * 88;
        double a = vt_rand_unit(&rng) * 6.283185307179586;
        v->camera.eye[0] = x;
        v->camera.eye[1] = 2.5 + 10 * vt_rand_unit(&rng);
        v->camera.eye[2] = z;
        v->camera.target[0] = x + 50 * cos(a);
        v->camera.target[1] = v->camera.eye[1] - 1;
        v->camera.target[2] = z + 50 * sin(a);
        v->camera.fovy_deg = 60;
        snprintf(v->name, sizeof v->name, "street-%d", i);
    }
    c->cap = vis_drawlist_bound(world_scene_scene(c->ws));
    c->ids = malloc((size_t)512 * 512 * sizeof *c->ids);
    c->a = malloc(c->cap * sizeof *c->a);
    c->b = malloc(c->cap * sizeof *c->b);
    assert_non_null(c->ids);
    assert_non_null(c->a);
    assert_non_null(c->b);
}

static void city_close(city *c)
{
    free(c->ids);
    free(c->a);
    free(c->b);
    world_scene_destroy(c->coarse);
    world_scene_destroy(c->ws);
    vis_context_destroy(c->ctx);
    vw_world_destroy(c->world);
}

/* The ray pass's draw list on `ws` into `out`. */
static size_t ray_list(city *c, world_scene *ws, const vis_camera *cam, uint32_t w, uint32_t h, vis_id_mode mode,
                       vis_draw_entry *out)
{
    vis_trace_desc d;
    memset(&d, 0, sizeof d);
    d.width = w;
    d.height = h;
    d.ids = mode;
    assert_int_equal(vis_trace(c->ctx, world_scene_scene(ws), cam, &d, c->ids, (size_t)512 * 512, NULL, 0), VIS_OK);
    size_t n = 0;
    assert_int_equal(vis_drawlist_build(c->ctx, world_scene_scene(ws), c->ids, w, h, mode, out, c->cap, &n), VIS_OK);
    return n;
}

static void test_truth_against_itself(void **state)
{
    (void)state;
    city c;
    city_open(&c);
    static const uint32_t res[][2] = {{64, 36}, {160, 90}, {320, 180}};
    size_t seen = 0;
    for (size_t v = 0; v < c.nviews; ++v) {
        for (size_t k = 0; k < 3; ++k) {
            uint32_t w = res[k][0], h = res[k][1];
            size_t n = ray_list(&c, c.ws, &c.views[v].camera, w, h, VIS_IDS_OBJECT, c.a);
            vc_accuracy r;
            assert_int_equal(vc_accuracy_compare(c.a, n, (uint64_t)w * h, c.a, n, NULL, &r), 0);
            assert_int_equal(r.truth_visible, n);
            assert_int_equal(r.drawn, n);
            assert_int_equal(r.missed, 0);
            assert_true(r.missed_area == 0.0);
            assert_int_equal(r.overdraw, 0);
            seen += n;
        }
    }
    assert_true(seen > 0);
    city_close(&c);
}

/* Leaf IDs expand the hit leaf to all its objects, so they draw a superset of what object
 * IDs draw at the same resolution: never more missed, never more missed area. */
static void test_leaf_never_misses_more(void **state)
{
    (void)state;
    city c;
    city_open(&c);
    static const uint32_t res[][2] = {{16, 9}, {64, 36}, {171, 96}};
    int leaf_helped = 0, leaf_overdrew = 0;
    for (size_t v = 0; v < c.nviews; ++v) {
        const vis_camera *cam = &c.views[v].camera;
        /* The truth at 480x270. */
        size_t tn = ray_list(&c, c.ws, cam, 480, 270, VIS_IDS_OBJECT, c.a);
        vis_draw_entry *truth = malloc((tn ? tn : 1) * sizeof *truth);
        assert_non_null(truth);
        memcpy(truth, c.a, tn * sizeof *truth);
        for (size_t k = 0; k < 3; ++k) {
            uint32_t w = res[k][0], h = res[k][1];
            size_t on = ray_list(&c, c.ws, cam, w, h, VIS_IDS_OBJECT, c.a);
            size_t ln = ray_list(&c, c.coarse, cam, w, h, VIS_IDS_LEAF, c.b);
            vc_accuracy ro, rl, sup;
            assert_int_equal(vc_accuracy_compare(truth, tn, 480 * 270, c.a, on, NULL, &ro), 0);
            assert_int_equal(vc_accuracy_compare(truth, tn, 480 * 270, c.b, ln, NULL, &rl), 0);
            assert_true(rl.missed <= ro.missed);
            assert_true(rl.missed_area <= ro.missed_area);
            /* Superset: with the object list as the truth, the leaf list misses nothing. */
            assert_int_equal(vc_accuracy_compare(c.a, on, (uint64_t)w * h, c.b, ln, NULL, &sup), 0);
            assert_int_equal(sup.missed, 0);
            leaf_helped |= rl.missed < ro.missed;
            leaf_overdrew |= rl.overdraw > ro.overdraw;
        }
        free(truth);
    }
    /* The property is not vacuous on this city: leaves did catch something, and cost something. */
    assert_true(leaf_helped);
    assert_true(leaf_overdrew);
    city_close(&c);
}

/* The culler is conservative at its own resolution: every object the ray pass sees at the
 * culler's buffer size (the same pixel centres) is in the culler's list. */
static void test_zbuf_conservative(void **state)
{
    (void)state;
    city c;
    city_open(&c);
    vis_zcull *zc = NULL;
    assert_int_equal(vis_zcull_create(c.ctx, &zc), VIS_OK);
    static const uint32_t res[][2] = {{242, 136}, {256, 128}, {512, 512}, {85, 48}};
    int culled_something = 0;
    for (size_t v = 0; v < c.nviews; ++v) {
        const vis_camera *cam = &c.views[v].camera;
        for (size_t k = 0; k < 4; ++k) {
            uint32_t w = res[k][0], h = res[k][1];
            size_t rn = ray_list(&c, c.ws, cam, w, h, VIS_IDS_OBJECT, c.a);
            vis_zcull_desc zd;
            vis_zcull_desc_defaults(&zd);
            zd.width = w;
            zd.height = h;
            size_t zn = 0;
            vis_zcull_stats zs;
            assert_int_equal(vis_zcull_run(zc, world_scene_scene(c.ws), cam, &zd, c.b, c.cap, &zn, &zs), VIS_OK);
            vc_accuracy r;
            assert_int_equal(vc_accuracy_compare(c.a, rn, (uint64_t)w * h, c.b, zn, NULL, &r), 0);
            if (r.missed)
                print_message("%s at %ux%u: the culler missed %u of the %zu objects the ray pass sees\n",
                              c.views[v].name, w, h, r.missed, rn);
            assert_int_equal(r.missed, 0);
            culled_something |= zs.in_view > zn;
        }
    }
    assert_true(culled_something); /* it does occlusion culling, not just frustum culling */
    vis_zcull_destroy(zc);
    city_close(&c);
}

/* ---- the binary (support/run_tool.h) ------------------------------------------------------- */

/* `ENV vis ARGS` through the shell; ENV may be NULL. */
#define run_vis(env, ...) vt_run(VIS_EXE, tmp_dir, env, __VA_ARGS__)
/* The binary in CWD with ARGS passed as they are, no shell in between. */
#define run_vis_argv(cwd, args) vt_run_argv(VIS_EXE, tmp_dir, cwd, args)

/* The index of `name` among the comma-separated fields of `header`, or -1. */
static int column(const char *header, const char *name)
{
    int i = 0;
    size_t len = strlen(name);
    for (const char *p = header;; ++i) {
        const char *end = strpbrk(p, ",\n");
        size_t n = end ? (size_t)(end - p) : strlen(p);
        if (n == len && strncmp(p, name, len) == 0)
            return i;
        if (!end || *end == '\n')
            return -1;
        p = end + 1;
    }
}

/* Field `i` of a CSV line (no quoting in this file). */
static void field(const char *line, int i, char *out, size_t size)
{
    const char *p = line;
    for (int k = 0; k < i; ++k) {
        p = strchr(p, ',');
        assert_non_null(p);
        ++p;
    }
    size_t n = strcspn(p, ",\n");
    assert_true(n < size);
    memcpy(out, p, n);
    out[n] = '\0';
}

static void test_binary_run(void **state)
{
    (void)state;
    char dir[512];
    snprintf(dir, sizeof dir, "%s/run1", tmp_dir);
    /* Ladder 64², 128² for both ray modes, the culler at 256x128: 5 rows. */
    vt_run_result r = run_vis(NULL,
                           "accuracy --scene %s --truth-res 192x108 --max-res 128 --frames 2 --repeat 1 "
                           "--backend cpu --threads 2 --out '%s'",
                           CITY, dir);
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "ray-object"));
    assert_non_null(strstr(r.out, "zbuf"));
    vt_run_free(&r);

    char path[600];
    snprintf(path, sizeof path, "%s/accuracy.csv", dir);
    char *csv = vt_slurp(path);
    static const char *const required[] = {"method",   "width",    "height",             "time_ms",
                                           "drawn",    "missed",   "missed_area",        "overdraw",
                                           "overdraw_triangles", "occluded_culled", NULL};
    for (const char *const *k = required; *k; ++k) {
        if (column(csv, *k) < 0)
            print_message("accuracy.csv lacks column %s: %s\n", *k, csv);
        assert_true(column(csv, *k) >= 0);
    }
    int lines = 0;
    for (const char *p = csv; *p; ++p)
        lines += *p == '\n';
    assert_int_equal(lines, 1 + 5);
    /* The rows: methods and buffer sizes of the display's aspect. */
    static const char *const expect[][3] = {{"ray-object", "85", "48"},  {"ray-object", "171", "96"},
                                            {"ray-leaf", "85", "48"},    {"ray-leaf", "171", "96"},
                                            {"zbuf", "242", "136"}};
    int cm = column(csv, "method"), cw = column(csv, "width"), ch = column(csv, "height");
    int cmiss = column(csv, "missed"), carea = column(csv, "missed_area"), cocc = column(csv, "occluded_culled");
    const char *line = strchr(csv, '\n') + 1;
    for (int i = 0; i < 5; ++i) {
        char v[64];
        field(line, cm, v, sizeof v);
        assert_string_equal(v, expect[i][0]);
        field(line, cw, v, sizeof v);
        assert_string_equal(v, expect[i][1]);
        field(line, ch, v, sizeof v);
        assert_string_equal(v, expect[i][2]);
        field(line, cmiss, v, sizeof v);
        assert_true(atof(v) >= 0.0);
        field(line, carea, v, sizeof v);
        assert_true(atof(v) >= 0.0 && atof(v) <= 1.0);
        field(line, cocc, v, sizeof v);
        assert_true(atof(v) >= 0.0 && atof(v) <= 1.0);
        line = strchr(line, '\n') + 1;
    }
    free(csv);
    /* The script is always written; the picture when gnuplot is there. */
    struct stat sb;
    snprintf(path, sizeof path, "%s/accuracy.gp", dir);
    assert_int_equal(stat(path, &sb), 0);
    if (system("command -v gnuplot >/dev/null 2>&1") == 0) {
        snprintf(path, sizeof path, "%s/accuracy.png", dir);
        assert_int_equal(stat(path, &sb), 0);
        assert_true(sb.st_size > 1000);
    }

    /* --json, 2x2 supersampling, and no gnuplot: still the CSV, exit 0, one JSON object. */
    snprintf(dir, sizeof dir, "%s/run2", tmp_dir);
    r = run_vis("VIS_GNUPLOT=/nonexistent/gnuplot",
                "accuracy --scene %s --truth-res 96x54 --supersample 2 --max-res 64 --frames 1 --repeat 1 "
                "--backend cpu --out '%s' --json",
                CITY, dir);
    vt_assert_exit(r, 0);
    assert_int_equal(r.out[0], '{');
    assert_non_null(strstr(r.out, "\"command\": \"accuracy\""));
    assert_non_null(strstr(r.out, "\"supersample\": 2"));
    assert_non_null(strstr(r.out, "\"samples\": 20736")); /* 192 x 108 */
    assert_non_null(strstr(r.out, "\"png\": null"));
    assert_non_null(strstr(r.err, "gnuplot"));
    vt_run_free(&r);
    snprintf(path, sizeof path, "%s/accuracy.csv", dir);
    assert_int_equal(stat(path, &sb), 0);
    snprintf(path, sizeof path, "%s/accuracy.png", dir);
    assert_int_not_equal(stat(path, &sb), 0);

    /* Bad arguments: exit 2. */
    r = run_vis(NULL, "accuracy --scene %s --truth-res 9000x100 --supersample 2", CITY);
    vt_assert_exit(r, 2);
    vt_run_free(&r);
    r = run_vis(NULL, "accuracy --scene %s --supersample 5", CITY);
    vt_assert_exit(r, 2);
    vt_run_free(&r);
    r = run_vis(NULL, "accuracy --scene %s --max-res 32", CITY);
    vt_assert_exit(r, 2);
    vt_run_free(&r);
}

/* The JSON number after "key": at or after p (asserted present). */
static double json_after(const char *p, const char *key)
{
    char pat[64];
    snprintf(pat, sizeof pat, "\"%s\": ", key);
    const char *q = strstr(p, pat);
    assert_non_null(q);
    return atof(q + strlen(pat));
}

/* `vis accuracy --effects`: the small city has glass windows (see-through and reflective)
 * and the sun casts shadows, so the truth lists objects for every reason; each row counts
 * its misses per reason, never more than the truth's, and the leaf rows are left out. */
static void test_binary_effects(void **state)
{
    (void)state;
    char dir[512];
    snprintf(dir, sizeof dir, "%s/fx", tmp_dir);
    vt_run_result r = run_vis("VIS_GNUPLOT=/nonexistent/gnuplot",
                              "accuracy --scene %s --effects see-through,reflect,shadows:1,0.7,0.4 "
                              "--truth-res 192x108 --max-res 128 --frames 3 --repeat 1 --backend cpu --threads 2 "
                              "--out '%s' --json",
                              CITY, dir);
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "\"effects\": \"see-through,reflect,shadows\""));
    assert_null(strstr(r.out, "ray-leaf"));
    static const char *const reasons[] = {"direct", "see_through", "reflection", "shadow"};
    static const char *const methods[] = {"ray-object", "ray-object", "zbuf"};
    const char *row = strstr(r.out, "\"rows\"");
    assert_non_null(row);
    double truth[VIS_REASON_COUNT] = {0};
    for (int i = 0; i < 3; ++i) {
        char pat[64];
        snprintf(pat, sizeof pat, "\"method\": \"%s\"", methods[i]);
        row = strstr(row, pat);
        assert_non_null(row);
        const char *rs = strstr(row, "\"reasons\"");
        assert_non_null(rs);
        for (int k = 0; k < VIS_REASON_COUNT; ++k) {
            const char *at = strstr(rs, reasons[k]);
            assert_non_null(at);
            double t = json_after(at, "truth"), m = json_after(at, "missed");
            assert_true(m >= 0.0 && m <= t);
            if (i == 0)
                truth[k] = t;
            else
                assert_true(t == truth[k]); /* one truth for every row */
        }
        ++row;
    }
    for (int k = 0; k < VIS_REASON_COUNT; ++k) {
        if (!(truth[k] > 0.0))
            print_message("no truth objects for reason %s: %s\n", reasons[k], r.out);
        assert_true(truth[k] > 0.0);
    }
    vt_run_free(&r);

    char path[600];
    snprintf(path, sizeof path, "%s/accuracy.csv", dir);
    char *csv = vt_slurp(path);
    static const char *const cols[] = {"missed_direct", "missed_see_through", "missed_reflection", "missed_shadow"};
    for (int k = 0; k < 4; ++k)
        assert_true(column(csv, cols[k]) >= 0);
    int lines = 0;
    for (const char *p = csv; *p; ++p)
        lines += *p == '\n';
    assert_int_equal(lines, 1 + 3);
    free(csv);

    /* The text report has the per-reason table. */
    snprintf(dir, sizeof dir, "%s/fx2", tmp_dir);
    r = run_vis("VIS_GNUPLOT=/nonexistent/gnuplot",
                "accuracy --scene %s --effects reflect,fog:60 --truth-res 96x54 --max-res 64 --frames 1 "
                "--repeat 1 --backend cpu --out '%s'",
                CITY, dir);
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "misses per reason (reflect,fog"));
    vt_run_free(&r);

    /* A bad --effects value: exit 2 and a message naming the problem. */
    r = run_vis(NULL, "accuracy --scene %s --effects glitter", CITY);
    vt_assert_exit(r, 2);
    assert_non_null(strstr(r.err, "glitter"));
    vt_run_free(&r);
    r = run_vis(NULL, "accuracy --scene %s --effects shadows:0,0,0", CITY);
    vt_assert_exit(r, 2);
    assert_non_null(strstr(r.err, "zero"));
    vt_run_free(&r);
}

/* `vis bench --method zbuf`: the culler along the camera path, at 512x512 and 256x128. */
static void test_bench_zbuf(void **state)
{
    (void)state;
    vt_run_result r = run_vis(NULL, "bench --method zbuf --scene %s --frames 2 --json", CITY);
    vt_assert_exit(r, 0);
    assert_int_equal(r.out[0], '{');
    assert_non_null(strstr(r.out, "\"method\": \"zbuf\""));
    static const char *const keys[] = {"\"raster_ms\":", "\"test_ms\":", "\"triangles\":", "\"visible\":",
                                       "\"in_view\":", "\"time_ms\":", NULL};
    for (const char *const *k = keys; *k; ++k) {
        int n = 0;
        for (const char *p = strstr(r.out, *k); p; p = strstr(p + 1, *k))
            ++n;
        assert_int_equal(n, 2 * VC_MAX_VIEWS); /* every view at both sizes */
    }
    assert_non_null(strstr(r.out, "\"width\": 256, \"height\": 128"));
    assert_non_null(strstr(r.out, "\"width\": 512, \"height\": 512"));
    vt_run_free(&r);
    r = run_vis(NULL, "bench --method zbuf --scene %s --frames 1 --res 64x32", CITY);
    vt_assert_exit(r, 0);
    assert_non_null(strstr(r.out, "64x32"));
    assert_null(strstr(r.out, "512x512"));
    vt_run_free(&r);
    r = run_vis(NULL, "bench --method zbuf --compare embree --scene %s", CITY);
    vt_assert_exit(r, 2);
    vt_run_free(&r);
}

/* ---- hostile names and outputs the user named (docs/cli.md, "Output files") -------------- */

/* The scene's name goes into the plot's title and the output directory's into gnuplot's
 * command line: names that try every way out of a gnuplot string (newline, CR, quotes,
 * backslash, backquotes, `;`, `!`, macros, control characters) must reach the picture as
 * text. Any command that ran would leave a pwn file in the run's directory or in DIR. */
static void test_hostile_names(void **state)
{
    (void)state;
    if (system("command -v gnuplot >/dev/null 2>&1") != 0) {
        print_message("gnuplot is not installed: the script is never run, nothing to test\n");
        skip();
    }
    static const char scene[] = "k\nsystem \"touch pwn1\"\n!touch pwn2\n'`touch pwn3`;system('touch pwn4');"
                                "$(touch pwn5)\\\r\\\n\"; system \"touch pwn6\" #\x01\x1b[31m@x.vox";
    static const char out[] = "o\nsystem \"touch pwn7\"\n'`touch pwn8`;!touch pwn9\\\r\x02\"";
    char cwd[512], path[1024];
    snprintf(cwd, sizeof cwd, "%s/hostile", tmp_dir);
    assert_int_equal(mkdir(cwd, 0777), 0);
    vw_world *w = NULL;
    vw_error e;
    assert_int_equal(vw_world_from_spec(CITY, NULL, NULL, NULL, &w, &e), VW_OK);
    snprintf(path, sizeof path, "%s/%s", cwd, scene);
    assert_int_equal(vw_vox_save_file(w, path, &e), VW_OK);
    vw_world_destroy(w);

    const char *const args[] = {"accuracy", "--scene", scene, "--truth-res", "96x54", "--max-res", "64", "--frames",
                                "1", "--repeat", "1", "--backend", "cpu", "--out", out, NULL};
    vt_run_result r = run_vis_argv(cwd, args);
    const char *const top[] = {scene, out, NULL};
    vt_assert_dir_holds(cwd, top);
    snprintf(path, sizeof path, "%s/%s", cwd, out);
    const char *const written[] = {"accuracy.csv", "accuracy.gp", "accuracy.png", NULL};
    vt_assert_dir_holds(path, written);
    vt_assert_exit(r, 0);
    vt_run_free(&r);
    /* The name's control characters are not in the script (the title is shown as one line). */
    snprintf(path, sizeof path, "%s/%s/accuracy.gp", cwd, out);
    char *script = vt_slurp(path);
    for (const char *p = script; *p; ++p)
        assert_true((unsigned char)*p >= 0x20 || *p == '\n');
    free(script);
    snprintf(path, sizeof path, "%s/%s/accuracy.png", cwd, out);
    struct stat sb;
    assert_int_equal(stat(path, &sb), 0);
    assert_true(sb.st_size > 1000);
}

/* When gnuplot fails, the accuracy.png that was there stays (it used to be removed before
 * gnuplot ran), be it a picture or a device; a CSV that cannot be written is an error that
 * leaves its device alone. */
static void test_report_keeps_outputs(void **state)
{
    (void)state;
    char dir[512], png[600], csv[600];
    snprintf(dir, sizeof dir, "%s/keep", tmp_dir);
    snprintf(png, sizeof png, "%s/accuracy.png", dir);
    snprintf(csv, sizeof csv, "%s/accuracy.csv", dir);
    assert_int_equal(mkdir(dir, 0777), 0);
    FILE *f = fopen(png, "wb");
    assert_non_null(f);
    fputs("old picture", f);
    assert_int_equal(fclose(f), 0);
    const char *opts = "--truth-res 96x54 --max-res 64 --frames 1 --repeat 1 --backend cpu";
    vt_run_result r = run_vis("VIS_GNUPLOT=false", "accuracy --scene %s %s --out '%s'", CITY, opts, dir);
    vt_assert_exit(r, 1);
    vt_run_free(&r);
    char *now = vt_slurp(png);
    assert_string_equal(now, "old picture");
    free(now);
    const char *const written[] = {"accuracy.csv", "accuracy.gp", "accuracy.png", NULL};
    vt_assert_dir_holds(dir, written);

    assert_int_equal(remove(png), 0);
    if (!vt_make_full_device(png)) {
        print_message("cannot make a device node (not root?): the device cases are not run\n");
        skip();
    }
    r = run_vis("VIS_GNUPLOT=false", "accuracy --scene %s %s --out '%s'", CITY, opts, dir);
    vt_assert_exit(r, 1);
    vt_run_free(&r);
    assert_true(vt_is_full_device(png));

    assert_int_equal(remove(png), 0);
    assert_int_equal(remove(csv), 0);
    assert_true(vt_make_full_device(csv));
    r = run_vis(NULL, "accuracy --scene %s %s --out '%s'", CITY, opts, dir);
    vt_assert_exit(r, 1);
    assert_non_null(strstr(r.err, csv));
    assert_non_null(strstr(r.err, strerror(ENOSPC)));
    vt_run_free(&r);
    assert_true(vt_is_full_device(csv));
}

static int setup(void **state)
{
    return vt_run_setup(state, tmp_dir, sizeof tmp_dir, "vis_test_accuracy", VIS_EXE);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_compare_by_hand),
        cmocka_unit_test(test_reasons_by_hand),
        cmocka_unit_test(test_compare_random),
        cmocka_unit_test(test_summarize),
        cmocka_unit_test(test_buffer_size),
        cmocka_unit_test(test_box_in_view),
        cmocka_unit_test(test_truth_against_itself),
        cmocka_unit_test(test_leaf_never_misses_more),
        cmocka_unit_test(test_zbuf_conservative),
        cmocka_unit_test(test_binary_run),
        cmocka_unit_test(test_binary_effects),
        cmocka_unit_test(test_bench_zbuf),
        cmocka_unit_test(test_hostile_names),
        cmocka_unit_test(test_report_keeps_outputs),
    };
    return cmocka_run_group_tests(tests, setup, vt_tmp_dir_teardown);
}
