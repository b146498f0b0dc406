/*
 * zcull.c — the software z-buffer occlusion culler: occluder selection, box tests, the
 * public vis_zcull_* entry points. The rasteriser itself is zcull_raster.c.
 *
 * Sources:
 *  - The comparison the voxel-object visibility talk makes (seeds/002): software occlusion
 *    culling of chunk meshes against the ray-cast ID buffer.
 *  - Occluders nearest first, and occluders found already hidden skipped (their triangles
 *    cannot change the buffer): Hasselgren, Andersson & Akenine-Moeller, "Masked Software
 *    Occlusion Culling", HPG 2016, and Intel's MaskedOcclusionCulling sample, where the
 *    application submits occluders front to back and tests occluder bounds first.
 *  - Box tests against a per-tile farthest depth before pixels: Greene, Kass & Miller,
 *    "Hierarchical Z-Buffer Visibility", SIGGRAPH 1993.
 *  - Front-to-back order of equal-sized blocks by distance: Lee & Han 2005 (seeds/001).
 */
#define _POSIX_C_SOURCE 199309L

#include <math.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "context.h"
#include "scene.h"
#include "zcull.h"

/* Box classes kept per object slot during a run. */
enum { ZC_FREE = 0, ZC_CULLED, ZC_NEAR, ZC_ON_SCREEN };

struct vis_zcull {
    vis_context *ctx;
    vis_zcull *prev, *next; /* ctx->zculls (vis_context_destroy frees those left) */
    float *depth;           /* tile-major depth target                                     */
    size_t depth_cap;       /* floats                                                      */
    float *tile_min;
    size_t tile_cap;
    vis_zc_rect *rects;     /* per object slot                                             */
    uint8_t *cls;           /* per object slot                                             */
    uint64_t *keys, *keys_tmp; /* occluder candidates: distance bits << 32 | slot           */
    size_t obj_cap;
    uint64_t *bits;         /* visible IDs                                                 */
    size_t bits_cap;        /* words                                                       */
    int have_run;
    vis_zc_target target;
    double tan_half, aspect;
};

static int zc_ctz64(uint64_t b)
{
#if defined(__GNUC__)
    return __builtin_ctzll(b);
#else
    int n = 0;
    while (!(b & 1u)) {
        b >>= 1;
        n++;
    }
    return n;
#endif
}

static double zc_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

void vis_zcull_desc_defaults(vis_zcull_desc *desc)
{
    if (!desc)
        return;
    memset(desc, 0, sizeof *desc);
    desc->width = 512;
    desc->height = 512;
    desc->occluder_triangles = VIS_ZCULL_DEFAULT_OCCLUDER_TRIANGLES;
    desc->occluder_min_pixels = 0;
    desc->simd = VIS_ZCULL_SIMD_AUTO;
}

static vis_status zcull_create(vis_context *ctx, vis_zcull **out)
{
    if (!out)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_create: out_zcull is NULL");
    vis_zcull *zc = vis_calloc(ctx, 1, sizeof *zc);
    if (!zc)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_zcull_create: out of memory");
    zc->ctx = ctx;
    zc->next = ctx->zculls;
    if (ctx->zculls)
        ctx->zculls->prev = zc;
    ctx->zculls = zc;
    *out = zc;
    return VIS_OK;
}

vis_status vis_zcull_create(vis_context *ctx, vis_zcull **out)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st = zcull_create(ctx, out);
    vis_leave(ctx);
    return st;
}

void vis_zcull_destroy(vis_zcull *zc)
{
    if (!zc)
        return;
    vis_context *ctx = zc->ctx;
    if (zc->prev)
        zc->prev->next = zc->next;
    else if (ctx->zculls == zc)
        ctx->zculls = zc->next;
    if (zc->next)
        zc->next->prev = zc->prev;
    vis_free(ctx, zc->depth);
    vis_free(ctx, zc->tile_min);
    vis_free(ctx, zc->rects);
    vis_free(ctx, zc->cls);
    vis_free(ctx, zc->keys);
    vis_free(ctx, zc->keys_tmp);
    vis_free(ctx, zc->bits);
    vis_free(ctx, zc);
}

/* Grows *p to hold n elements of `size` bytes (contents not kept). */
static int zc_grow(vis_context *ctx, void **p, size_t *cap, size_t n, size_t size)
{
    if (n <= *cap && *p)
        return 1;
    size_t c = *cap ? *cap : 64;
    while (c < n)
        c *= 2;
    void *q = vis_alloc(ctx, c * size);
    if (!q)
        return 0;
    vis_free(ctx, *p);
    *p = q;
    *cap = c;
    return 1;
}

static int zc_reserve(vis_zcull *zc, size_t depth_floats, size_t tiles, size_t objects, size_t words)
{
    vis_context *ctx = zc->ctx;
    if (!zc_grow(ctx, (void **)&zc->depth, &zc->depth_cap, depth_floats, sizeof(float)))
        return 0;
    if (!zc_grow(ctx, (void **)&zc->tile_min, &zc->tile_cap, tiles, sizeof(float)))
        return 0;
    if (objects > zc->obj_cap || !zc->rects) {
        size_t c = zc->obj_cap ? zc->obj_cap : 64;
        while (c < objects)
            c *= 2;
        vis_zc_rect *r = vis_alloc(ctx, c * sizeof *r);
        uint8_t *k = vis_alloc(ctx, c);
        uint64_t *a = vis_alloc(ctx, c * sizeof *a), *b = vis_alloc(ctx, c * sizeof *b);
        if (!r || !k || !a || !b) {
            vis_free(ctx, r);
            vis_free(ctx, k);
            vis_free(ctx, a);
            vis_free(ctx, b);
            return 0;
        }
        vis_free(ctx, zc->rects);
        vis_free(ctx, zc->cls);
        vis_free(ctx, zc->keys);
        vis_free(ctx, zc->keys_tmp);
        zc->rects = r;
        zc->cls = k;
        zc->keys = a;
        zc->keys_tmp = b;
        zc->obj_cap = c;
    }
    return zc_grow(ctx, (void **)&zc->bits, &zc->bits_cap, words, sizeof(uint64_t));
}

/* Stable LSD radix sort of keys by their upper 32 bits (a non-negative float's bits order
 * like the float); equal distances keep slot order, so the order is deterministic. */
static uint64_t *zc_sort_keys(uint64_t *a, uint64_t *tmp, size_t n)
{
    uint32_t hist[3][2048];
    memset(hist, 0, sizeof hist);
    for (size_t i = 0; i < n; i++) {
        uint32_t k = (uint32_t)(a[i] >> 32);
        hist[0][k & 2047u]++;
        hist[1][(k >> 11) & 2047u]++;
        hist[2][k >> 22]++;
    }
    for (int p = 0; p < 3; p++) {
        uint32_t sum = 0;
        for (int b = 0; b < 2048; b++) {
            uint32_t c = hist[p][b];
            hist[p][b] = sum;
            sum += c;
        }
    }
    for (int p = 0; p < 3; p++) {
        int shift = 32 + 11 * p;
        for (size_t i = 0; i < n; i++) {
            uint32_t b = (uint32_t)(a[i] >> shift) & 2047u;
            tmp[hist[p][b]++] = a[i];
        }
        uint64_t *t = a;
        a = tmp;
        tmp = t;
    }
    return a;
}

static vis_status zc_resolve_desc(vis_context *ctx, const vis_zcull_desc *in, vis_zcull_desc *d)
{
    vis_zcull_desc_defaults(d);
    if (!in)
        return VIS_OK;
    if (in->width)
        d->width = in->width;
    if (in->height)
        d->height = in->height;
    if (in->occluder_triangles)
        d->occluder_triangles = in->occluder_triangles;
    d->occluder_min_pixels = in->occluder_min_pixels;
    d->simd = in->simd;
    if (d->width > VIS_MAX_RESOLUTION || d->height > VIS_MAX_RESOLUTION)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_run: resolution %ux%u is outside 1..%u per axis",
                        d->width, d->height, VIS_MAX_RESOLUTION);
    if ((unsigned)d->simd > (unsigned)VIS_ZCULL_SIMD_AVX2)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_run: simd %d is not a vis_zcull_simd value",
                        (int)d->simd);
    return VIS_OK;
}
/* vis_scene_visit_object_quads's callback: one occluder quad into the buffer. */
typedef struct zc_quad_draw {
    vis_zc_target *t;
    const vis_zc_view *v;
} zc_quad_draw;

static void zc_draw_visited_quad(void *user, const vis_flat_quad *q)
{
    const zc_quad_draw *d = user;
    vis_zc_draw_quad(d->t, d->v, q);
}


static vis_status zcull_run(vis_zcull *zc, const vis_scene *scene, const vis_camera *camera,
                            const vis_zcull_desc *desc, vis_draw_entry *out, size_t capacity, size_t *out_count,
                            vis_zcull_stats *out_stats)
{
    vis_context *ctx = zc->ctx;
    if (!scene || !camera || !out_count)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_run: %s is NULL",
                        !scene ? "scene" : !camera ? "camera" : "out_count");
    if (!out && capacity)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_run: out_entries is NULL with capacity %zu",
                        capacity);
    if (scene->ctx != ctx)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_run: the scene belongs to another context");
    vis_zcull_desc d;
    vis_status st = zc_resolve_desc(ctx, desc, &d);
    if (st != VIS_OK)
        return st;
    vis_camera_frame fr;
    st = vis_camera_frame_make(ctx, camera, scene->desc.origin, d.width, d.height, &fr);
    if (st != VIS_OK)
        return st;

    double t0 = zc_now_ms();
    zc->have_run = 0; /* the buffer is about to change */
    size_t nd, nt;
    vis_zc_target_sizes(d.width, d.height, &nd, &nt);
    const uint32_t slots = scene->object_slots;
    const size_t words = (size_t)scene->max_id / 64u + 1u;
    if (!zc_reserve(zc, nd, nt, slots ? slots : 1, words))
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_zcull_run: out of memory for a %ux%u buffer and %u objects",
                        d.width, d.height, slots);
    /* vis_zcull_simd and vis_zc_simd share their values. */
    vis_zc_target *t = &zc->target;
    vis_zc_target_init(t, d.width, d.height, zc->depth, zc->tile_min, NULL, (vis_zc_simd)d.simd);
    vis_zc_target_clear(t);
    vis_zc_view v;
    vis_zc_view_make(&v, t, fr.eye, fr.f, fr.r, fr.u, fr.tan_half_fovy, fr.near_dist, fr.far_dist);

    /* 1. Every object's box against the frustum, far and the pixel centres; occluder
     *    candidates with their distance. */
    vis_zcull_stats s;
    memset(&s, 0, sizeof s);
    size_t ncand = 0;
    for (uint32_t i = 0; i < slots; i++) {
        const vis_object_host *o = &scene->object_host[i];
        if (o->id == 0) {
            zc->cls[i] = ZC_FREE;
            continue;
        }
        s.objects++;
        double dist = 0.0;
        vis_zc_box_class k = vis_zc_box_classify(t, &v, o->box_lo, o->box_hi, &zc->rects[i], &dist);
        zc->cls[i] = k == VIS_ZC_BOX_CULLED ? ZC_CULLED : k == VIS_ZC_BOX_NEAR ? ZC_NEAR : ZC_ON_SCREEN;
        if (k == VIS_ZC_BOX_CULLED)
            continue;
        s.in_view++;
        if (o->quad_count == 0 && o->tri_count == 0)
            continue;
        if (k == VIS_ZC_BOX_ON_SCREEN && d.occluder_min_pixels) {
            const vis_zc_rect *r = &zc->rects[i];
            uint64_t px = (uint64_t)(r->x1 - r->x0 + 1) * (uint64_t)(r->y1 - r->y0 + 1);
            if (px < d.occluder_min_pixels)
                continue;
        }
        float df = (float)dist;
        uint32_t bits;
        memcpy(&bits, &df, sizeof bits);
        zc->keys[ncand++] = (uint64_t)bits << 32 | i;
    }
    const uint64_t *order = zc_sort_keys(zc->keys, zc->keys_tmp, ncand);
    double t1 = zc_now_ms();

    /* 2. Occluders nearest first, within the budget. */
    uint64_t used = 0;
    const uint64_t budget = d.occluder_triangles == VIS_ZCULL_ALL_OCCLUDERS ? UINT64_MAX : d.occluder_triangles;
    for (size_t c = 0; c < ncand; c++) {
        uint32_t i = (uint32_t)order[c];
        const vis_object_host *o = &scene->object_host[i];
        uint64_t tris = 2u * (uint64_t)o->quad_count + o->tri_count;
        if (used + tris > budget)
            continue;
        /* Already hidden: its triangles lie inside its box, so they cannot change the
         * buffer, and the object stays hidden whatever is drawn later. */
        if (zc->cls[i] == ZC_ON_SCREEN && !vis_zc_rect_visible(t, &zc->rects[i])) {
            zc->cls[i] = ZC_CULLED;
            s.occluders_hidden++;
            continue;
        }
        zc_quad_draw qd = {t, &v};
        vis_scene_visit_object_quads(scene, i, zc_draw_visited_quad, &qd);
        for (uint32_t q = 0; q < o->tri_count; q++)
            vis_zc_draw_tri(t, &v, &o->tris[q]);
        used += tris;
        s.occluder_objects++;
    }
    s.triangles = used;
    double t2 = zc_now_ms();

    /* 3. Every remaining box against the final buffer. */
    memset(zc->bits, 0, words * sizeof(uint64_t));
    size_t count = 0;
    for (uint32_t i = 0; i < slots; i++) {
        int vis = zc->cls[i] == ZC_NEAR || (zc->cls[i] == ZC_ON_SCREEN && vis_zc_rect_visible(t, &zc->rects[i]));
        if (!vis)
            continue;
        uint32_t id = scene->object_host[i].id;
        zc->bits[id >> 6] |= (uint64_t)1 << (id & 63u);
        count++;
    }
    if (count > capacity)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_zcull_run: %zu visible objects, capacity %zu", count, capacity);
    size_t n = 0;
    for (size_t w = 0; w < words; w++) {
        uint64_t b = zc->bits[w];
        while (b) {
            int bit = zc_ctz64(b);
            b &= b - 1;
            out[n].id = (uint32_t)(w * 64u + (unsigned)bit);
            out[n].pixels = 0;
            n++;
        }
    }
    *out_count = n;
    double t3 = zc_now_ms();

    zc->have_run = 1;
    zc->tan_half = fr.tan_half_fovy;
    zc->aspect = fr.aspect;
    if (out_stats) {
        s.width = d.width;
        s.height = d.height;
        s.visible = (uint32_t)n;
        s.polygons = t->polygons;
        s.tiles = t->tiles;
        s.ms_setup = t1 - t0;
        s.ms_raster = t2 - t1;
        s.ms_test = t3 - t2;
        s.ms_total = t3 - t0;
        strncpy(s.simd, vis_zc_simd_name(t->simd), sizeof s.simd - 1);
        *out_stats = s;
    }
    return VIS_OK;
}

vis_status vis_zcull_run(vis_zcull *zc, const vis_scene *scene, const vis_camera *camera, const vis_zcull_desc *desc,
                         vis_draw_entry *out, size_t capacity, size_t *out_count, vis_zcull_stats *out_stats)
{
    if (!zc)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(zc->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    if (scene)
        vis_scene_begin_read(scene);
    vis_status st = zcull_run(zc, scene, camera, desc, out, capacity, out_count, out_stats);
    if (scene)
        vis_scene_end_read(scene);
    vis_leave(zc->ctx);
    return st;
}

static vis_status zcull_depth(vis_zcull *zc, float *out_depth, size_t capacity)
{
    if (!out_depth)
        return vis_fail(zc->ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_zcull_depth: out_depth is NULL");
    if (!zc->have_run)
        return vis_fail(zc->ctx, VIS_ERROR_NOT_FOUND, "vis_zcull_depth: no run yet");
    const vis_zc_target *t = &zc->target;
    uint64_t needed = (uint64_t)t->width * t->height;
    if ((uint64_t)capacity < needed)
        return vis_fail(zc->ctx, VIS_ERROR_CAPACITY,
                        "vis_zcull_depth: the %ux%u buffer needs %llu floats, capacity is %zu", t->width, t->height,
                        (unsigned long long)needed, capacity);
    const double W = t->width, H = t->height;
    for (uint32_t y = 0; y < t->height; y++) {
        double ny = (1.0 - (y + 0.5) / H * 2.0) * zc->tan_half;
        for (uint32_t x = 0; x < t->width; x++) {
            double nx = ((x + 0.5) / W * 2.0 - 1.0) * zc->tan_half * zc->aspect;
            float iw = t->depth[vis_zc_pixel_index(t, x, y)];
            /* distance along the unit ray = w * |f + nx r + ny u| */
            out_depth[(size_t)y * t->width + x] = iw > 0.0f ? (float)(sqrt(1.0 + nx * nx + ny * ny) / (double)iw) : INFINITY;
        }
    }
    return VIS_OK;
}

vis_status vis_zcull_depth(vis_zcull *zc, float *out_depth, size_t capacity)
{
    if (!zc)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(zc->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_status st = zcull_depth(zc, out_depth, capacity);
    vis_leave(zc->ctx);
    return st;
}
