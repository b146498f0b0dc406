/* test_effects.c — vis_trace_effects and vis_drawlist_build_effects (docs/effects.md).
 *
 *  - Every effect alone and all together, on generated worlds with water (gen:terrain),
 *    leaves (gen:terrain with trees) and glass (gen:city), for every method: bit for bit the brute force's buffers, and the
 *    effects actually occur there (see-through layers, reflections, off-screen casters).
 *  - The same through the packet instance (packet and auto, backends/cpu/packet_fx_*.c) on
 *    views narrow enough for 16x16, 8x8 and 4x4 packets, checked to be taken, and on a view
 *    where far packets give up and their rays go one by one.
 *  - Hand-made hard cases with the answer worked out by hand: a ray grazing a glass edge, a
 *    mirror facing a mirror (one bounce), a caster exactly on the light ray, the fog distance
 *    exactly at a face; each also inside a packet.
 *  - Bad inputs refused with a message and nothing written; the draw list's reasons. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "packet_check.h"
#include "scene_builder.h"
#include "test_support.h"
#include "trace.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

/* The buffers of one pass, allocated for W x H and the most layers. */
typedef struct fx_bufs {
    uint32_t w, h, layers;
    uint32_t *ids, *st, *refl, *shadow;
    float *depth;
    vis_effect_buffers b;
} fx_bufs;

static void bufs_init(fx_bufs *f, uint32_t w, uint32_t h, uint32_t layers)
{
    size_t n = (size_t)w * h;
    memset(f, 0, sizeof *f);
    f->w = w, f->h = h, f->layers = layers;
    f->ids = calloc(n, 4), f->st = calloc(n * VIS_MAX_SEE_THROUGH_LAYERS, 4), f->refl = calloc(n, 4);
    f->shadow = calloc(n, 4), f->depth = calloc(n, 4);
    assert_true(f->ids && f->st && f->refl && f->shadow && f->depth);
    vis_effect_buffers b = {f->ids, n, f->depth, n, f->st, n * layers, f->refl, n, f->shadow, n};
    f->b = b;
}

static void bufs_free(fx_bufs *f)
{
    free(f->ids), free(f->st), free(f->refl), free(f->shadow), free(f->depth);
}

static int bufs_equal(const fx_bufs *a, const fx_bufs *b, uint32_t effects, char *why, size_t why_size)
{
    size_t n = (size_t)a->w * a->h;
    for (size_t i = 0; i < n; ++i) {
        if (a->ids[i] != b->ids[i] || memcmp(&a->depth[i], &b->depth[i], 4) != 0) {
            snprintf(why, why_size, "pixel %zu: id %u depth %.9g, reference %u %.9g", i, a->ids[i], a->depth[i],
                     b->ids[i], b->depth[i]);
            return 0;
        }
        if ((effects & VIS_EFFECT_REFLECT) && a->refl[i] != b->refl[i]) {
            snprintf(why, why_size, "pixel %zu: reflection %u, reference %u", i, a->refl[i], b->refl[i]);
            return 0;
        }
        if ((effects & VIS_EFFECT_SHADOWS) && a->shadow[i] != b->shadow[i]) {
            snprintf(why, why_size, "pixel %zu: shadow caster %u, reference %u", i, a->shadow[i], b->shadow[i]);
            return 0;
        }
        if (effects & VIS_EFFECT_SEE_THROUGH)
            for (uint32_t k = 0; k < a->layers; ++k)
                if (a->st[i * a->layers + k] != b->st[i * a->layers + k]) {
                    snprintf(why, why_size, "pixel %zu: see-through layer %u %u, reference %u", i, k,
                             a->st[i * a->layers + k], b->st[i * a->layers + k]);
                    return 0;
                }
    }
    return 1;
}

static void trace_fx(vis_context *ctx, vis_scene *scene, const vis_camera *cam, vis_traversal method, uint32_t effects,
                     const double light[3], double fog, fx_bufs *f)
{
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = f->w, d.height = f->h;
    d.traversal = method;
    d.effects = effects;
    d.see_through_layers = f->layers;
    if (light)
        memcpy(d.light_dir, light, sizeof d.light_dir);
    d.fog_dist = fog;
    if (vis_trace_effects(ctx, scene, cam, &d, &f->b) != VIS_OK)
        fail_msg("vis_trace_effects (method %d, effects 0x%x): %s", (int)method, effects, vis_context_last_error(ctx));
}

/* A box's diagonal: no leaf is entered farther than this from an eye inside it. */
static float diagonal(const float *size)
{
    return sqrtf(size[0] * size[0] + size[1] * size[1] + size[2] * size[2]);
}

/* The distance from an eye outside the box [0, size] to its nearest point and to its
 * farthest corner. */
static double nearest_point(const double *eye, const float *size)
{
    double d = 0;
    for (int a = 0; a < 3; ++a) {
        double n = eye[a] < 0 ? 0 : eye[a] > size[a] ? size[a] : eye[a];
        d += (n - eye[a]) * (n - eye[a]);
    }
    return sqrt(d);
}

static double farthest_corner(const double *eye, const float *size)
{
    double d = 0;
    for (int a = 0; a < 3; ++a) {
        double f = eye[a] < size[a] * 0.5 ? size[a] : 0;
        d += (f - eye[a]) * (f - eye[a]);
    }
    return sqrt(d);
}

/* ---- generated worlds against the brute force ------------------------------------------ */

typedef struct fx_counts {
    uint64_t see_through, reflected, casters, off_screen;
} fx_counts;

static void count_effects(const fx_bufs *f, fx_counts *c)
{
    size_t n = (size_t)f->w * f->h;
    for (size_t i = 0; i < n; ++i) {
        c->see_through += f->st[i * f->layers] != 0;
        c->reflected += f->refl[i] != 0;
        c->casters += f->shadow[i] != 0;
        if (f->shadow[i]) { /* a caster that no pixel shows directly */
            int seen = 0;
            for (size_t j = 0; j < n && !seen; ++j)
                seen = f->ids[j] == f->shadow[i];
            c->off_screen += !seen;
        }
    }
}

static void world_against_bruteforce(vis_context *ctx, const char *spec, fx_counts *counts)
{
    vw_world *world = NULL;
    world_scene *ws = NULL;
    vw_error err;
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &world, &err) != VW_OK ||
        world_scene_create(ctx, world, NULL, &ws, NULL, &err) != 0)
        fail_msg("%s: %s", spec, err.message);
    vis_scene *scene = world_scene_scene(ws);
    vis_scene_info info;
    vis_scene_get_info(scene, &info);
    const float *sz = info.size;
    /* Looking down across the world from two corners, and low over it toward the far side. */
    vis_camera cams[3] = {
        {{sz[0] * 0.1, sz[1] * 0.9, sz[2] * 0.1}, {sz[0] * 0.6, sz[1] * 0.2, sz[2] * 0.7}, 60, 0.05, 0},
        {{sz[0] * 0.9, sz[1] * 0.8, sz[2] * 0.5}, {sz[0] * 0.3, sz[1] * 0.25, sz[2] * 0.45}, 70, 0.05, 0},
        {{sz[0] * 0.5, sz[1] * 0.45, sz[2] * 0.05}, {sz[0] * 0.5, sz[1] * 0.3, sz[2] * 0.95}, 50, 0.05, 0},
    };
    static const uint32_t sets[] = {
        VIS_EFFECT_SEE_THROUGH,
        VIS_EFFECT_REFLECT,
        VIS_EFFECT_SHADOWS,
        VIS_EFFECT_FOG,
        VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG,
    };
    const double light[3] = {1.0, 0.7, 0.4};
    uint32_t side = vt_small() ? 24u : 40u;
    fx_bufs ref, got;
    bufs_init(&ref, side, side, 3);
    bufs_init(&got, side, side, 3);
    for (size_t c = 0; c < sizeof cams / sizeof cams[0]; ++c)
        for (size_t e = 0; e < sizeof sets / sizeof sets[0]; ++e) {
            double fog = 0.4 * sz[0];
            trace_fx(ctx, scene, &cams[c], VIS_TRAVERSAL_BRUTEFORCE, sets[e], light, fog, &ref);
            if (sets[e] == sets[4])
                count_effects(&ref, counts);
            for (int m = VIS_TRAVERSAL_AUTO; m <= VIS_TRAVERSAL_DDA; ++m) {
                if (m == VIS_TRAVERSAL_BRUTEFORCE)
                    continue;
                trace_fx(ctx, scene, &cams[c], (vis_traversal)m, sets[e], light, fog, &got);
                char why[256];
                if (!bufs_equal(&got, &ref, sets[e], why, sizeof why))
                    fail_msg("%s, camera %zu, effects 0x%x, method %d: %s", spec, c, sets[e], m, why);
            }
        }
    bufs_free(&ref);
    bufs_free(&got);
    world_scene_destroy(ws);
    vw_world_destroy(world);
}

/* The packet instance on views of the world: 44x36 narrowed to 12, 20 and 40 degrees (16x16,
 * 8x8 and 4x4 packets; the eye inside the world, so no packet gives up), 46 degrees from
 * outside and above a corner, where the 4x4 packets whose first leaf lies past the give-up
 * distance go ray by ray and the nearer ones stay packets (about 5 % of them on the terrain,
 * 40 % on the city), and 12 degrees from far outside, where 16x16 packets give up the same way
 * (their own, larger distance: PACKET_FAR_FOOTPRINT), and the third view widened to 90 degrees
 * (4x4 packets whose tiles spread 0.22, near the limit). `packet` and `auto` against the
 * brute force, every effect set, the fog at the target's distance. */
static void world_packets_against_bruteforce(vis_context *ctx, const char *spec, fx_counts *counts)
{
    vw_world *world = NULL;
    world_scene *ws = NULL;
    vw_error err;
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &world, &err) != VW_OK ||
        world_scene_create(ctx, world, NULL, &ws, NULL, &err) != 0)
        fail_msg("%s: %s", spec, err.message);
    vis_scene *scene = world_scene_scene(ws);
    vis_scene_info info;
    vis_scene_get_info(scene, &info);
    const float *sz = info.size;
    const uint32_t w = 44, h = 36;
    vis_camera cams[6] = {
        {{sz[0] * 0.1, sz[1] * 0.9, sz[2] * 0.1}, {sz[0] * 0.6, sz[1] * 0.2, sz[2] * 0.7}, 12, 0.05, 0},
        {{sz[0] * 0.9, sz[1] * 0.8, sz[2] * 0.5}, {sz[0] * 0.3, sz[1] * 0.25, sz[2] * 0.45}, 20, 0.05, 0},
        {{sz[0] * 0.5, sz[1] * 0.45, sz[2] * 0.05}, {sz[0] * 0.5, sz[1] * 0.3, sz[2] * 0.95}, 40, 0.05, 0},
        {{-sz[0] * 0.8, sz[1] * 1.2, -sz[2] * 0.8}, {sz[0] * 0.6, sz[1] * 0.1, sz[2] * 0.6}, 46, 0.05, 0},
    };
    const uint32_t sides[4] = {16, 8, 4, 4};
    for (int c = 0; c < 3; ++c) {
        float give_up = expect_packets(ctx, scene, &cams[c], w, h, sides[c], NULL);
        assert_true(give_up >= diagonal(sz));
    }
    /* The far view: the world's nearest point lies within the give-up distance, its farthest
     * corner beyond. */
    float give_up = expect_packets(ctx, scene, &cams[3], w, h, sides[3], NULL);
    assert_true(nearest_point(cams[3].eye, sz) < give_up && farthest_corner(cams[3].eye, sz) > give_up);
    /* The far 16x16 view: its give-up distance depends on its pixel only, so the eye is put
     * that far from the world's centre, above and outside a corner, looking at the centre. */
    const double away[3] = {-0.6, 0.5, -0.6};
    double away_len = sqrt(away[0] * away[0] + away[1] * away[1] + away[2] * away[2]);
    cams[4] = cams[0];
    for (int a = 0; a < 3; ++a)
        cams[4].target[a] = sz[a] * 0.5;
    float give_up16 = expect_packets(ctx, scene, &cams[4], w, h, 16, NULL);
    for (int a = 0; a < 3; ++a)
        cams[4].eye[a] = cams[4].target[a] + give_up16 * away[a] / away_len;
    assert_true(expect_packets(ctx, scene, &cams[4], w, h, 16, NULL) == give_up16);
    assert_true(nearest_point(cams[4].eye, sz) < give_up16 && farthest_corner(cams[4].eye, sz) > give_up16);
    /* A near view at 90 degrees: 4x4 packets as wide as they come (a tile spreads 0.22). */
    cams[5] = cams[2];
    cams[5].fovy_deg = 90;
    expect_packets(ctx, scene, &cams[5], w, h, 4, NULL);
    static const uint32_t sets[] = {
        VIS_EFFECT_SEE_THROUGH,
        VIS_EFFECT_REFLECT,
        VIS_EFFECT_SHADOWS,
        VIS_EFFECT_FOG,
        VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG,
    };
    const double light[3] = {1.0, 0.7, 0.4};
    fx_bufs ref, got;
    bufs_init(&ref, w, h, 3);
    bufs_init(&got, w, h, 3);
    for (size_t c = 0; c < sizeof cams / sizeof cams[0]; ++c)
        for (size_t e = 0; e < sizeof sets / sizeof sets[0]; ++e) {
            double fog = 0; /* at the target: it culls part of every view */
            for (int a = 0; a < 3; ++a)
                fog += (cams[c].target[a] - cams[c].eye[a]) * (cams[c].target[a] - cams[c].eye[a]);
            fog = sqrt(fog);
            trace_fx(ctx, scene, &cams[c], VIS_TRAVERSAL_BRUTEFORCE, sets[e], light, fog, &ref);
            if (sets[e] == sets[4])
                count_effects(&ref, counts);
            const vis_traversal methods[2] = {VIS_TRAVERSAL_PACKET, VIS_TRAVERSAL_AUTO};
            for (int m = 0; m < 2; ++m) {
                trace_fx(ctx, scene, &cams[c], methods[m], sets[e], light, fog, &got);
                char why[256];
                if (!bufs_equal(&got, &ref, sets[e], why, sizeof why))
                    fail_msg("%s, packet camera %zu, effects 0x%x, method %d: %s", spec, c, sets[e], (int)methods[m],
                             why);
            }
        }
    bufs_free(&ref);
    bufs_free(&got);
    world_scene_destroy(ws);
    vw_world_destroy(world);
}

typedef void (*world_check)(vis_context *ctx, const char *spec, fx_counts *counts);

/* One check on the water terrain and on the glass city, both of which must exercise every
 * effect (else the comparison would prove little). */
static void terrain_and_city(vis_context *ctx, world_check check, const char *label, fx_counts *terrain, fx_counts *city)
{
    check(ctx, "gen:terrain:size=64x48x64:seed=3", terrain);
    check(ctx, "gen:city:size=96x48x96:seed=2", city);
    print_message("%s, all effects, brute force: terrain %llu see-through pixels, %llu reflected, %llu shadowed "
                  "(%llu by off-screen casters); city %llu, %llu, %llu (%llu)\n",
                  label, (unsigned long long)terrain->see_through, (unsigned long long)terrain->reflected,
                  (unsigned long long)terrain->casters, (unsigned long long)terrain->off_screen,
                  (unsigned long long)city->see_through, (unsigned long long)city->reflected,
                  (unsigned long long)city->casters, (unsigned long long)city->off_screen);
    assert_true(terrain->see_through > 0 && terrain->reflected > 0 && terrain->casters > 0);
    assert_true(city->see_through > 0 && city->reflected > 0 && city->casters > 0);
}

static void test_worlds_by_packets_match_bruteforce(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    fx_counts terrain = {0}, city = {0};
    terrain_and_city(ctx, world_packets_against_bruteforce, "packet views", &terrain, &city);
    vis_context_destroy(ctx);
}

static void test_worlds_match_bruteforce(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    fx_counts terrain = {0}, city = {0};
    terrain_and_city(ctx, world_against_bruteforce, "every method", &terrain, &city);
    assert_true(city.off_screen > 0); /* casters the frustum misses: what the effect is for */
    /* A terrain with trees, and the same without: their leaves are see-through too. */
    fx_counts forest = {0}, bare = {0};
    world_against_bruteforce(ctx, "gen:terrain:size=96x64x96:seed=6:trees=80", &forest);
    world_against_bruteforce(ctx, "gen:terrain:size=96x64x96:seed=6", &bare);
    print_message("trees: %llu see-through pixels, %llu without them\n", (unsigned long long)forest.see_through,
                  (unsigned long long)bare.see_through);
    assert_true(forest.see_through > bare.see_through);
    vis_context_destroy(ctx);
}

/* ---- hand-made hard cases --------------------------------------------------------------- */

static void flag_last(tobj *o, uint32_t flags) { o->quads[o->nq - 1].flags = flags; }

/* The centre ray of a view inside a packet: the view narrowed to 10 degrees at 25x25, traced
 * by 8x8 packets (checked; none gives up in these 16^3 scenes), equals the brute force at
 * every pixel, and its centre pixel, whose ray is the 1x1 view's, equals `one`. */
static void centre_in_packet(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t effects,
                             uint32_t layers, const double light[3], double fog, const fx_bufs *one)
{
    vis_camera narrow = *cam;
    narrow.fovy_deg = 10;
    vis_scene_info info;
    vis_scene_get_info(scene, &info);
    assert_true(expect_packets(ctx, scene, &narrow, 25, 25, 8, NULL) >= diagonal(info.size));
    fx_bufs ref, got;
    bufs_init(&ref, 25, 25, layers);
    bufs_init(&got, 25, 25, layers);
    trace_fx(ctx, scene, &narrow, VIS_TRAVERSAL_BRUTEFORCE, effects, light, fog, &ref);
    const vis_traversal methods[2] = {VIS_TRAVERSAL_PACKET, VIS_TRAVERSAL_AUTO};
    for (int m = 0; m < 2; ++m) {
        trace_fx(ctx, scene, &narrow, methods[m], effects, light, fog, &got);
        char why[256];
        if (!bufs_equal(&got, &ref, effects, why, sizeof why))
            fail_msg("effects 0x%x, 25x25 packets, method %d: %s", effects, (int)methods[m], why);
    }
    size_t c = 12 * 25 + 12;
    assert_int_equal(got.ids[c], one->ids[0]);
    assert_memory_equal(&got.depth[c], &one->depth[0], sizeof(float));
    assert_memory_equal(&got.st[c * layers], one->st, layers * sizeof(uint32_t));
    assert_int_equal(got.refl[c], one->refl[0]);
    assert_int_equal(got.shadow[c], one->shadow[0]);
    bufs_free(&ref);
    bufs_free(&got);
}

/* Every method gives `want` on a 1x1 view (each method, then the brute force's buffers); the
 * same ray inside a packet too (centre_in_packet). */
static void trace_all_1x1(vis_context *ctx, vis_scene *scene, const vis_camera *cam, uint32_t effects, uint32_t layers,
                          const double light[3], double fog, fx_bufs *out)
{
    fx_bufs ref;
    bufs_init(&ref, out->w, out->h, layers);
    trace_fx(ctx, scene, cam, VIS_TRAVERSAL_BRUTEFORCE, effects, light, fog, &ref);
    for (int m = VIS_TRAVERSAL_AUTO; m <= VIS_TRAVERSAL_DDA; ++m) {
        trace_fx(ctx, scene, cam, (vis_traversal)m, effects, light, fog, out);
        char why[256];
        if (!bufs_equal(out, &ref, effects, why, sizeof why))
            fail_msg("effects 0x%x, method %d: %s", effects, m, why);
    }
    bufs_free(&ref);
    centre_in_packet(ctx, scene, cam, effects, layers, light, fog, out);
}

/* Two glass panes (IDs 5 and 7) meeting at x = 4 in the plane z = 4, an opaque wall (6) at
 * z = 1 behind them; the ray runs down -z exactly along x = 4, touching both panes' edges. */
static void test_glass_edge(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    tobj *g5 = add_obj(&w, 5);
    obj_quad(g5, 2, 4.0f, 0.0f, 0.0f, 4.0f, 8.0f);
    flag_last(g5, VIS_PRIM_SEE_THROUGH);
    tobj *g7 = add_obj(&w, 7);
    obj_quad(g7, 2, 4.0f, 4.0f, 0.0f, 8.0f, 8.0f);
    flag_last(g7, VIS_PRIM_SEE_THROUGH | VIS_PRIM_REFLECTIVE);
    tobj *wall = add_obj(&w, 6);
    obj_quad(wall, 2, 1.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{4, 4, 10}, {4, 4, 0}, 30, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 1, 1, 2);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_SEE_THROUGH, 2, NULL, 0, &f);
    assert_int_equal(f.ids[0], 6);
    assert_int_equal(f.st[0], 5); /* equal t: the lower ID first */
    assert_int_equal(f.st[1], 7);
    assert_true(f.depth[0] == 9.0f);
    bufs_free(&f);
    /* One layer: only the first by (t, ID). */
    bufs_init(&f, 1, 1, 1);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_SEE_THROUGH, 1, NULL, 0, &f);
    assert_int_equal(f.ids[0], 6);
    assert_int_equal(f.st[0], 5);
    bufs_free(&f);
    /* See-through off: the glass occludes, lowest ID on the tie. */
    bufs_init(&f, 1, 1, 1);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_REFLECT, 1, NULL, 0, &f);
    assert_int_equal(f.ids[0], 5);
    assert_int_equal(f.refl[0], 0); /* pane 5 is not reflective */
    /* See-through on: pane 7 is the reflective crossing; its reflected ray goes back up +z
     * and leaves the scene. */
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_REFLECT | VIS_EFFECT_SEE_THROUGH, 1, NULL, 0, &f);
    assert_int_equal(f.ids[0], 6);
    assert_int_equal(f.refl[0], 0);
    bufs_free(&f);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Mirror 1 at x = 2 facing mirror 2 at x = 14; the camera between them looks at mirror 1.
 * Every pixel: mirror 1 direct, mirror 2 in the reflection -- and nothing further. */
static void test_mirror_facing_mirror(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    tobj *m1 = add_obj(&w, 1);
    obj_quad(m1, 0, 2.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    flag_last(m1, VIS_PRIM_REFLECTIVE);
    tobj *m2 = add_obj(&w, 2);
    obj_quad(m2, 0, 14.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    flag_last(m2, VIS_PRIM_REFLECTIVE);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{8, 8, 8}, {2, 8, 8}, 10, 0.05, 0};
    assert_true(expect_packets(ctx, scene, &cam, 9, 9, 4, NULL) >= 28.0f); /* 4x4 packets for packet and auto */
    fx_bufs f, ref;
    bufs_init(&f, 9, 9, 1);
    bufs_init(&ref, 9, 9, 1);
    trace_fx(ctx, scene, &cam, VIS_TRAVERSAL_BRUTEFORCE, VIS_EFFECT_REFLECT, NULL, 0, &ref);
    for (int m = VIS_TRAVERSAL_AUTO; m <= VIS_TRAVERSAL_DDA; ++m) {
        trace_fx(ctx, scene, &cam, (vis_traversal)m, VIS_EFFECT_REFLECT, NULL, 0, &f);
        char why[256];
        if (!bufs_equal(&f, &ref, VIS_EFFECT_REFLECT, why, sizeof why))
            fail_msg("method %d: %s", m, why);
        for (int i = 0; i < 81; ++i) {
            assert_int_equal(f.ids[i], 1);
            assert_int_equal(f.refl[i], 2);
        }
    }
    bufs_free(&f);
    bufs_free(&ref);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* A floor (10) seen straight down at (8, 0, 8), lit along (1, 1, 0): the shadow ray meets
 * x = 12 at y = 4 (exactly, before rounding). Caster 11 spans y in [0, 4] there, caster 12
 * y in [4, 8] (another run): each touches the ray with an edge and counts. Neither is in
 * the 1x1 view. A light from below leaves the floor in its own shadow: no ray. */
static void test_caster_on_light_ray(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    for (int which = 0; which < 2; ++which) {
        tworld w;
        memset(&w, 0, sizeof w);
        w.size[0] = w.size[1] = w.size[2] = 16.0f;
        obj_quad(add_obj(&w, 10), 1, 0.0f, 0.0f, 0.0f, 16.0f, 16.0f); /* axis y: u = z, v = x */
        tobj *c = add_obj(&w, 11u + (uint32_t)which);
        float y0 = which == 0 ? 0.0f : 4.0f;
        obj_quad(c, 0, 12.0f, y0, 0.0f, y0 + 4.0f, 16.0f); /* axis x: u = y, v = z */
        vis_scene *scene = make_scene(ctx, &w, NULL, 0);
        vis_camera cam = {{8, 10, 8}, {8, 0, 8}, 10, 0.05, 0};
        fx_bufs f;
        bufs_init(&f, 1, 1, 1);
        const double light[3] = {1, 1, 0};
        trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_SHADOWS, 1, light, 0, &f);
        assert_int_equal(f.ids[0], 10);
        assert_int_equal(f.shadow[0], 11 + which);
        const double below[3] = {1, -1, 0};
        trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_SHADOWS, 1, below, 0, &f);
        assert_int_equal(f.shadow[0], 0);
        /* A see-through caster casts nothing. */
        w.objs[1].quads[0].flags = VIS_PRIM_SEE_THROUGH;
        set_obj(scene, &w.objs[1]);
        trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_SHADOWS, 1, light, 0, &f);
        assert_int_equal(f.shadow[0], 0);
        bufs_free(&f);
        vis_scene_destroy(scene);
        free_world(&w);
    }
    vis_context_destroy(ctx);
}

/* A wall (20) at z = 5, seen from z = 15 straight down -z: distance 10 exactly. Fog at 10
 * keeps it (t > fog culls, as the far plane); fog just short of 10 culls it. vis_trace takes
 * fog too. */
static void test_fog_at_face(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    obj_quad(add_obj(&w, 20), 2, 5.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{8, 8, 15}, {8, 8, 0}, 30, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 1, 1, 1);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_FOG, 1, NULL, 10.0, &f);
    assert_int_equal(f.ids[0], 20);
    assert_true(f.depth[0] == 10.0f);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_FOG, 1, NULL, nextafter(10.0, 0.0) - 1e-6, &f);
    assert_int_equal(f.ids[0], 0);
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = 1;
    d.effects = VIS_EFFECT_FOG;
    d.fog_dist = 9.99;
    uint32_t id = 99;
    assert_int_equal(vis_trace(ctx, scene, &cam, &d, &id, 1, NULL, 0), VIS_OK);
    assert_int_equal(id, 0);
    d.fog_dist = 10.0;
    assert_int_equal(vis_trace(ctx, scene, &cam, &d, &id, 1, NULL, 0), VIS_OK);
    assert_int_equal(id, 20);
    bufs_free(&f);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* One object (40), two faces meeting at a concave edge: a floor (y = 2, x in [0, 8]) and a
 * reflective wall (x = 8, from y = 2 up). The ray from (4, 6, 8) along (1, -1, 0) meets both
 * planes at the same t (4 / d, exactly: the components are equal in magnitude), so (t, ID)
 * ties and the primitive decides: the floor (axis 1) before the wall (axis 0 | reflective
 * << 2), which is not reflective, so no reflected ray -- in every method, in a packet too,
 * whichever face it offers first. */
static void test_tie_between_primitives(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    tobj *o = add_obj(&w, 40);
    obj_quad(o, 1, 2.0f, 0.0f, 0.0f, 16.0f, 8.0f); /* axis y: u = z, v = x */
    obj_quad(o, 0, 8.0f, 2.0f, 0.0f, 10.0f, 16.0f); /* axis x: u = y, v = z */
    flag_last(o, VIS_PRIM_REFLECTIVE);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{4, 6, 8}, {8, 2, 8}, 30, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 1, 1, 1);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_REFLECT, 1, NULL, 0, &f);
    assert_int_equal(f.ids[0], 40);
    assert_int_equal(f.refl[0], 0);
    /* Both reflective: the wall (0 | 2 << 2) before the floor (1 | 2 << 2); its reflected ray
     * leaves the edge along (-1, -1, 0), and whatever it meets (the floor, or nothing where
     * the rounded origin lies just below y = 2), every method says the same. */
    o->quads[0].flags = VIS_PRIM_REFLECTIVE;
    set_obj(scene, o);
    trace_all_1x1(ctx, scene, &cam, VIS_EFFECT_REFLECT, 1, NULL, 0, &f);
    assert_int_equal(f.ids[0], 40);
    bufs_free(&f);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* Triangles inside packets (the lanes go through vis_test_tri with their see-through lists):
 * a glass triangle (32) in front of an opaque one (33) in front of a reflective wall (31),
 * seen through 16x16 packets, every effect set against the brute force; the glass triangle
 * is recorded and the opaque one hit. */
static void test_triangles_in_packets(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    tobj *wall = add_obj(&w, 31);
    obj_quad(wall, 2, 1.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    flag_last(wall, VIS_PRIM_REFLECTIVE);
    const float g0[3] = {5, 3, 8}, g1[3] = {11, 3, 8}, g2[3] = {8, 7, 8};
    tobj *glass = add_obj(&w, 32);
    obj_tri(glass, g0, g1, g2);
    glass->tris[0].flags = VIS_PRIM_SEE_THROUGH;
    const float o0[3] = {7, 3.5f, 5}, o1[3] = {10, 4, 4.5f}, o2[3] = {8.5f, 6.5f, 4};
    obj_tri(add_obj(&w, 33), o0, o1, o2);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{8, 6, 15}, {8, 4, 1}, 16, 0.05, 0};
    assert_true(expect_packets(ctx, scene, &cam, 48, 48, 16, NULL) >= diagonal(w.size));
    static const uint32_t sets[] = {
        VIS_EFFECT_SEE_THROUGH,
        VIS_EFFECT_REFLECT,
        VIS_EFFECT_SHADOWS,
        VIS_EFFECT_FOG,
        VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG,
    };
    const double light[3] = {0.3, 1.0, 0.5};
    fx_bufs ref, got;
    bufs_init(&ref, 48, 48, 2);
    bufs_init(&got, 48, 48, 2);
    int seen_through = 0, hit = 0;
    for (size_t e = 0; e < sizeof sets / sizeof sets[0]; ++e) {
        trace_fx(ctx, scene, &cam, VIS_TRAVERSAL_BRUTEFORCE, sets[e], light, 14.2, &ref);
        const vis_traversal methods[2] = {VIS_TRAVERSAL_PACKET, VIS_TRAVERSAL_AUTO};
        for (int m = 0; m < 2; ++m) {
            trace_fx(ctx, scene, &cam, methods[m], sets[e], light, 14.2, &got);
            char why[256];
            if (!bufs_equal(&got, &ref, sets[e], why, sizeof why))
                fail_msg("effects 0x%x, method %d: %s", sets[e], (int)methods[m], why);
        }
        if (sets[e] & VIS_EFFECT_SEE_THROUGH)
            for (size_t i = 0; i < 48 * 48; ++i) {
                seen_through += ref.st[i * 2] == 32;
                hit += ref.ids[i] == 33;
            }
    }
    assert_true(seen_through > 0 && hit > 0);
    bufs_free(&ref);
    bufs_free(&got);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* ---- effects off, bad inputs, the draw list --------------------------------------------- */

/* desc.effects == 0: vis_trace's buffers. */
static void test_no_effects_is_plain_trace(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    room_world(&w, 8, 40);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{24, 24, 24}, {10, 12, 30}, 80, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 32, 32, 1);
    uint32_t ids[32 * 32];
    float depth[32 * 32];
    for (int m = VIS_TRAVERSAL_AUTO; m <= VIS_TRAVERSAL_DDA; ++m) {
        trace_fx(ctx, scene, &cam, (vis_traversal)m, 0, NULL, 0, &f);
        vis_trace_desc d;
        vis_trace_desc_defaults(&d);
        d.width = d.height = 32;
        d.traversal = (vis_traversal)m;
        assert_int_equal(vis_trace(ctx, scene, &cam, &d, ids, 1024, depth, 1024), VIS_OK);
        assert_memory_equal(ids, f.ids, sizeof ids);
        assert_memory_equal(depth, f.depth, sizeof depth);
    }
    bufs_free(&f);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

/* The draw-list calls (vis_trace_drawlist, vis_trace_batch_drawlist) take fog, as vis_trace
 * does, and refuse every other effect with a message, writing nothing. */
static void test_drawlist_calls_take_fog_only(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    room_world(&w, 8, 40);
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{24, 24, 24}, {10, 12, 30}, 80, 0.05, 0};
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = 32;
    d.effects = VIS_EFFECT_FOG;
    d.fog_dist = 12.0;
    uint32_t ids[32 * 32];
    assert_int_equal(vis_trace(ctx, scene, &cam, &d, ids, 1024, NULL, 0), VIS_OK);
    size_t bound = vis_drawlist_bound(scene), want_n = 0, got_n = 0, per_view = 0;
    vis_draw_entry *want = calloc(bound, sizeof *want), *got = calloc(bound, sizeof *got);
    assert_non_null(want);
    assert_non_null(got);
    assert_int_equal(vis_drawlist_build(ctx, scene, ids, 32, 32, VIS_IDS_OBJECT, want, bound, &want_n), VIS_OK);
    assert_int_equal(vis_trace_drawlist(ctx, scene, &cam, &d, got, bound, &got_n, NULL, 0, NULL, 0), VIS_OK);
    assert_int_equal(got_n, want_n);
    assert_memory_equal(got, want, want_n * sizeof *want);
    d.fog_dist = 0; /* the fog must have culled something for the check to bite */
    d.effects = 0;
    size_t all_n = 0;
    assert_int_equal(vis_trace_drawlist(ctx, scene, &cam, &d, got, bound, &all_n, NULL, 0, NULL, 0), VIS_OK);
    assert_true(all_n > want_n);
    const uint32_t others[] = {VIS_EFFECT_SEE_THROUGH, VIS_EFFECT_REFLECT, VIS_EFFECT_SHADOWS};
    for (size_t i = 0; i < sizeof others / sizeof others[0]; ++i) {
        d.effects = others[i] | VIS_EFFECT_FOG;
        d.fog_dist = 12.0;
        d.light_dir[1] = 1.0;
        size_t n = 12345;
        memset(got, 0xAB, bound * sizeof *got);
        assert_int_equal(vis_trace_drawlist(ctx, scene, &cam, &d, got, bound, &n, NULL, 0, NULL, 0),
                         VIS_ERROR_INVALID_ARGUMENT);
        assert_true(strstr(vis_context_last_error(ctx), "vis_trace_effects") != NULL);
        assert_int_equal(vis_trace_batch_drawlist(ctx, scene, &cam, 1, &d, got, bound, &per_view, 1, &n),
                         VIS_ERROR_INVALID_ARGUMENT);
        assert_int_equal(((const unsigned char *)got)[0], 0xAB);
    }
    free(want);
    free(got);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

static void expect_refused(vis_context *ctx, vis_scene *scene, const vis_camera *cam, const vis_trace_desc *d,
                           const vis_effect_buffers *b, vis_status want, const char *what)
{
    vis_status st = vis_trace_effects(ctx, scene, cam, d, b);
    if (st != want)
        fail_msg("%s: status %d, want %d (%s)", what, (int)st, (int)want, vis_context_last_error(ctx));
    if (!vis_context_last_error(ctx)[0])
        fail_msg("%s: no message", what);
}

static void test_bad_inputs(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(1);
    vis_scene *scene = make_cube_scene(ctx, 4.0f);
    vis_camera cam = {{10, 10, 10}, {0, 0, 0}, 60, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 4, 4, 2);
    memset(f.ids, 0xAB, 16 * 4), memset(f.st, 0xAB, 32 * 4), memset(f.refl, 0xAB, 16 * 4);
    memset(f.shadow, 0xAB, 16 * 4), memset(f.depth, 0xAB, 16 * 4);
    vis_trace_desc base;
    vis_trace_desc_defaults(&base);
    base.width = base.height = 4;
    base.effects = VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT | VIS_EFFECT_SHADOWS | VIS_EFFECT_FOG;
    base.light_dir[1] = 1.0;
    base.fog_dist = 100.0;
    vis_trace_desc d = base;
    d.light_dir[0] = NAN;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "NaN light");
    d = base;
    d.light_dir[1] = INFINITY;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "infinite light");
    d = base;
    d.light_dir[1] = 0.0;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "zero light");
    d = base;
    d.fog_dist = -1.0;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "negative fog");
    d.fog_dist = 0.0;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "zero fog");
    d.fog_dist = NAN;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "NaN fog");
    d = base;
    d.see_through_layers = VIS_MAX_SEE_THROUGH_LAYERS + 1;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "too many layers");
    d = base;
    d.effects |= 0x100u;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "unknown effect");
    d = base;
    d.ids = VIS_IDS_LEAF;
    expect_refused(ctx, scene, &cam, &d, &f.b, VIS_ERROR_INVALID_ARGUMENT, "leaf IDs");
    vis_effect_buffers b = f.b;
    b.see_through_capacity = 31;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_CAPACITY, "short see-through");
    b = f.b;
    b.ids_capacity = 15;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_CAPACITY, "short ids");
    b = f.b;
    b.reflection_capacity = 15;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_CAPACITY, "short reflection");
    b = f.b;
    b.shadow_capacity = 0;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_CAPACITY, "short shadow");
    b = f.b;
    b.depth_capacity = 3;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_CAPACITY, "short depth");
    b = f.b;
    b.see_through = NULL;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_INVALID_ARGUMENT, "NULL see-through");
    b = f.b;
    b.reflection = NULL;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_INVALID_ARGUMENT, "NULL reflection");
    b = f.b;
    b.shadow = NULL;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_INVALID_ARGUMENT, "NULL shadow");
    b = f.b;
    b.ids = NULL;
    expect_refused(ctx, scene, &cam, &base, &b, VIS_ERROR_INVALID_ARGUMENT, "NULL ids");
    expect_refused(ctx, scene, &cam, &base, NULL, VIS_ERROR_INVALID_ARGUMENT, "NULL buffers");
    /* Nothing was written by any of them. */
    for (int i = 0; i < 16; ++i) {
        assert_int_equal(f.ids[i], 0xABABABABu);
        assert_int_equal(f.refl[i], 0xABABABABu);
        assert_int_equal(f.shadow[i], 0xABABABABu);
    }
    for (int i = 0; i < 32; ++i)
        assert_int_equal(f.st[i], 0xABABABABu);
    /* vis_trace takes fog only. */
    uint32_t ids[16];
    d = base;
    assert_int_equal(vis_trace(ctx, scene, &cam, &d, ids, 16, NULL, 0), VIS_ERROR_INVALID_ARGUMENT);
    /* A buffer whose effect is off may be NULL and is left alone. */
    d = base;
    d.effects = VIS_EFFECT_REFLECT;
    b = f.b;
    b.see_through = NULL, b.shadow = NULL;
    assert_int_equal(vis_trace_effects(ctx, scene, &cam, &d, &b), VIS_OK);
    bufs_free(&f);
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
}

/* The draw list of the glass scene, by hand: the wall direct on every pixel, the panes seen
 * through on theirs; pane 7 reflects the mirror (9) placed above the camera. */
static void test_drawlist_reasons(void **state)
{
    (void)state;
    vis_context *ctx = make_cpu_ctx(2);
    tworld w;
    memset(&w, 0, sizeof w);
    w.size[0] = w.size[1] = w.size[2] = 16.0f;
    tobj *g5 = add_obj(&w, 5);
    obj_quad(g5, 2, 4.0f, 0.0f, 0.0f, 8.0f, 16.0f);
    flag_last(g5, VIS_PRIM_SEE_THROUGH | VIS_PRIM_REFLECTIVE);
    obj_quad(add_obj(&w, 6), 2, 1.0f, 0.0f, 0.0f, 16.0f, 16.0f);
    obj_quad(add_obj(&w, 9), 2, 15.0f, 0.0f, 0.0f, 16.0f, 16.0f); /* behind the camera */
    vis_scene *scene = make_scene(ctx, &w, NULL, 0);
    vis_camera cam = {{8, 8, 12}, {8, 8, 0}, 20, 0.05, 0};
    fx_bufs f;
    bufs_init(&f, 16, 16, 2);
    trace_fx(ctx, scene, &cam, VIS_TRAVERSAL_AUTO, VIS_EFFECT_SEE_THROUGH | VIS_EFFECT_REFLECT, NULL, 0, &f);
    /* The left half of the image (x < 8) looks through pane 5 and sees the mirror in it. */
    vis_effect_entry e[4];
    size_t n = 0;
    vis_effect_buffers b = f.b;
    b.shadow = NULL;
    assert_int_equal(vis_drawlist_build_effects(ctx, scene, &b, 16, 16, 2, e, 4, &n), VIS_OK);
    assert_int_equal(n, 3);
    assert_int_equal(e[0].id, 5);
    assert_int_equal(e[0].reasons, VIS_REASON_SEE_THROUGH);
    assert_int_equal(e[0].pixels[1], 128);
    assert_int_equal(e[1].id, 6);
    assert_int_equal(e[1].reasons, VIS_REASON_DIRECT);
    assert_int_equal(e[1].pixels[0], 256);
    assert_int_equal(e[2].id, 9);
    assert_int_equal(e[2].reasons, VIS_REASON_REFLECTION);
    assert_int_equal(e[2].pixels[2], 128);
    assert_int_equal(vis_drawlist_build_effects(ctx, scene, &b, 16, 16, 2, e, 2, &n), VIS_ERROR_CAPACITY);
    b.see_through_capacity = 100;
    assert_int_equal(vis_drawlist_build_effects(ctx, scene, &b, 16, 16, 2, e, 4, &n), VIS_ERROR_CAPACITY);
    b = f.b;
    assert_int_equal(vis_drawlist_build_effects(ctx, scene, &b, 16, 16, 9, e, 4, &n), VIS_ERROR_INVALID_ARGUMENT);
    f.refl[3] = 1234; /* no such object */
    assert_int_equal(vis_drawlist_build_effects(ctx, scene, &b, 16, 16, 2, e, 4, &n), VIS_ERROR_INVALID_ARGUMENT);
    bufs_free(&f);
    vis_scene_destroy(scene);
    free_world(&w);
    vis_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_glass_edge),
        cmocka_unit_test(test_mirror_facing_mirror),
        cmocka_unit_test(test_caster_on_light_ray),
        cmocka_unit_test(test_fog_at_face),
        cmocka_unit_test(test_triangles_in_packets),
        cmocka_unit_test(test_tie_between_primitives),
        cmocka_unit_test(test_no_effects_is_plain_trace),
        cmocka_unit_test(test_bad_inputs),
        cmocka_unit_test(test_drawlist_reasons),
        cmocka_unit_test(test_drawlist_calls_take_fog_only),
        cmocka_unit_test(test_worlds_match_bruteforce),
        cmocka_unit_test(test_worlds_by_packets_match_bruteforce),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
