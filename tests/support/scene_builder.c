#include "scene_builder.h"

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "test_support.h"

vis_status cpu_ctx_create(uint32_t threads, const vis_allocator *a, vis_context **out)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = threads;
    if (a)
        cd.allocator = *a;
    *out = NULL;
    return vis_context_create(&cd, out);
}

vis_context *make_cpu_ctx(uint32_t threads)
{
    vis_context *ctx = NULL;
    assert_int_equal(cpu_ctx_create(threads, NULL, &ctx), VIS_OK);
    return ctx;
}

vis_scene *make_cube_scene(vis_context *ctx, float side)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    d.size[0] = d.size[1] = d.size[2] = side;
    vis_scene *s = NULL;
    assert_int_equal(vis_scene_create(ctx, &d, &s), VIS_OK);
    return s;
}

tobj *add_obj(tworld *w, uint32_t id)
{
    if (w->n == w->cap) {
        w->cap = w->cap ? w->cap * 2 : 64;
        w->objs = realloc(w->objs, w->cap * sizeof *w->objs);
        assert_non_null(w->objs);
    }
    tobj *o = &w->objs[w->n++];
    memset(o, 0, sizeof *o);
    o->id = id;
    return o;
}

tobj *add_obj_quads(tworld *w, uint32_t id, uint32_t nq)
{
    tobj *o = add_obj(w, id);
    o->quads = malloc((nq ? nq : 1) * sizeof *o->quads);
    assert_non_null(o->quads);
    o->nq = nq;
    return o;
}

void obj_quad(tobj *o, uint32_t axis, float plane, float u0, float v0, float u1, float v1)
{
    o->quads = realloc(o->quads, (o->nq + 1) * sizeof *o->quads);
    assert_non_null(o->quads);
    vis_quad q = {axis, 0, plane, u0, v0, u1, v1};
    o->quads[o->nq++] = q;
}

void obj_tri(tobj *o, const float a[3], const float b[3], const float c[3])
{
    o->tris = realloc(o->tris, (o->nt + 1) * sizeof *o->tris);
    assert_non_null(o->tris);
    vis_triangle t;
    memset(&t, 0, sizeof t);
    memcpy(t.v[0], a, 12);
    memcpy(t.v[1], b, 12);
    memcpy(t.v[2], c, 12);
    o->tris[o->nt++] = t;
}

void obj_box(tobj *o, const float lo[3], const float hi[3])
{
    for (uint32_t a = 0; a < 3; ++a) {
        uint32_t u = (a + 1) % 3, v = (a + 2) % 3;
        obj_quad(o, a, lo[a], lo[u], lo[v], hi[u], hi[v]);
        obj_quad(o, a, hi[a], lo[u], lo[v], hi[u], hi[v]);
    }
}

void obj_clear(tobj *o)
{
    free(o->quads);
    free(o->tris);
    o->quads = NULL;
    o->tris = NULL;
    o->nq = o->nt = 0;
}

void free_world(tworld *w)
{
    for (uint32_t i = 0; i < w->n; ++i)
        obj_clear(&w->objs[i]);
    free(w->objs);
    memset(w, 0, sizeof *w);
}

void set_obj(vis_scene *s, const tobj *o)
{
    vis_mesh m = {o->quads, o->nq, o->tris, o->nt};
    if (vis_scene_set_object(s, o->id, &m) != VIS_OK)
        fail_msg("vis_scene_set_object(%u) failed", o->id);
}

vis_scene *make_scene(vis_context *ctx, const tworld *w, const double origin[3], uint32_t kd_depth)
{
    vis_scene_desc d;
    vis_scene_desc_defaults(&d);
    memcpy(d.size, w->size, sizeof d.size);
    if (origin)
        memcpy(d.origin, origin, sizeof d.origin);
    d.kd_depth = kd_depth;
    return make_scene_desc(ctx, w, &d);
}

vis_scene *make_scene_desc(vis_context *ctx, const tworld *w, const vis_scene_desc *d)
{
    vis_scene *s = NULL;
    if (vis_scene_create(ctx, d, &s) != VIS_OK)
        fail_msg("vis_scene_create: %s", vis_context_last_error(ctx));
    for (uint32_t i = 0; i < w->n; ++i)
        set_obj(s, &w->objs[i]);
    return s;
}

void room_world(tworld *w, float lo, float hi)
{
    memset(w, 0, sizeof *w);
    w->size[0] = w->size[1] = w->size[2] = 48.0f;
    float L = lo, H = hi;
    float walls[6][6] = {{L, L, L, H, L + 1, H}, {L, H - 1, L, H, H, H}, {L, L, L, L + 1, H, H},
                         {H - 1, L, L, H, H, H}, {L, L, L, H, H, L + 1}, {L, L, H - 1, H, H, H}};
    for (int i = 0; i < 6; ++i)
        obj_box(add_obj(w, 1u + (uint32_t)i), walls[i], walls[i] + 3);
    float out_lo[3] = {0, 0, 0}, out_hi[3] = {48, 2, 48};
    obj_box(add_obj(w, 50), out_lo, out_hi);
}

void wall_world(tworld *w)
{
    memset(w, 0, sizeof *w);
    w->size[0] = w->size[1] = w->size[2] = 32.0f;
    float flo[3] = {0, 0, 0}, fhi[3] = {32, 1, 32};
    obj_box(add_obj(w, 1), flo, fhi);
    float lo[3] = {16, 1, 4}, hi[3] = {17, 12, 28}; /* wall x in [16,17]: on the split plane */
    obj_box(add_obj(w, 2), lo, hi);
    float lo2[3] = {4, 1, 16}, hi2[3] = {16, 12, 17}; /* meets the wall at a corner */
    obj_box(add_obj(w, 3), lo2, hi2);
}

/* ---- random worlds and cameras ---------------------------------------------------------- */

const chunk_world_opts chunk_world_default = {0.3, 6, 0.0, 0, 4, 0};

/* Random boxes inside chunk c (a chunk object). */
void obj_chunk_boxes(tobj *o, uint64_t *rng, const int c[3], const chunk_world_opts *opt)
{
    int boxes = 1 + (int)(vt_rand(rng) % (uint64_t)opt->max_boxes);
    for (int b = 0; b < boxes; ++b) {
        float lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            int l = (int)(vt_rand(rng) % 16), e = 1 + (int)(vt_rand(rng) % 8);
            if (opt->touch > 0.0 && vt_rand_unit(rng) < opt->touch) /* touch the chunk boundary */
                l = vt_rand(rng) & 1 ? 0 : 16 - e;
            if (l + e > 16)
                e = 16 - l;
            lo[a] = (float)(c[a] * 16 + l);
            hi[a] = lo[a] + (float)e;
        }
        obj_box(o, lo, hi);
    }
    if (vt_rand_unit(rng) < 0.3) { /* a face exactly on the chunk boundary */
        uint32_t a = 0;
        int side = 0;
        if (opt->any_face) {
            a = (uint32_t)(vt_rand(rng) % 3);
            side = vt_rand(rng) & 1 ? 16 : 0;
        }
        uint32_t u = (a + 1) % 3, v = (a + 2) % 3;
        obj_quad(o, a, (float)(c[a] * 16 + side), (float)(c[u] * 16), (float)(c[v] * 16), (float)(c[u] * 16 + 16),
                 (float)(c[v] * 16 + 16));
    }
}

/* An entity: two triangles sharing an edge and an off-grid quad, across chunk borders, and
 * with opt->entity_boxes an off-grid box across a chunk corner. */
void obj_entity(tobj *o, uint64_t *rng, const float size[3], const chunk_world_opts *opt)
{
    float p[3];
    for (int a = 0; a < 3; ++a)
        p[a] = (float)(vt_rand_unit(rng) * (size[a] - 6.0) + 0.5);
    float a0[3] = {p[0], p[1], p[2]}, a1[3] = {p[0] + 5.3f, p[1] + 0.7f, p[2]};
    float a2[3] = {p[0], p[1] + 4.1f, p[2] + 5.2f}, a3[3] = {p[0] + 5.3f, p[1] + 4.1f, p[2] + 5.2f};
    obj_tri(o, a0, a1, a2);
    obj_tri(o, a1, a3, a2);
    obj_quad(o, 1, p[1] + 0.375f, p[2], p[0], p[2] + 5.5f, p[0] + 5.25f);
    if (!opt->entity_boxes)
        return;
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
        float c = 16.0f * (float)(1 + (int)(vt_rand(rng) % (uint64_t)(size[a] / 16.0f > 1 ? size[a] / 16.0f - 1 : 1)));
        if (c >= size[a])
            c = size[a] / 2;
        lo[a] = c - 1.5f;
        hi[a] = c + 2.25f;
    }
    obj_box(o, lo, hi);
}

void chunk_world_init(tworld *w, int nx, int ny, int nz)
{
    memset(w, 0, sizeof *w);
    w->size[0] = 16.0f * nx;
    w->size[1] = 16.0f * ny;
    w->size[2] = 16.0f * nz;
}

void random_chunk_world_opts(tworld *w, uint64_t *rng, int nx, int ny, int nz, const chunk_world_opts *opt)
{
    chunk_world_init(w, nx, ny, nz);
    for (int cz = 0; cz < nz; ++cz)
        for (int cy = 0; cy < ny; ++cy)
            for (int cx = 0; cx < nx; ++cx) {
                if (vt_rand_unit(rng) < opt->empty)
                    continue;
                int c[3] = {cx, cy, cz};
                obj_chunk_boxes(add_obj(w, 1u + (uint32_t)(cx + nx * (cy + ny * cz))), rng, c, opt);
            }
    /* Identical boxes in two objects: the lowest ID must win on both backends. */
    for (int i = 0; i < opt->ties; ++i) {
        float lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = (float)(vt_rand(rng) % (uint64_t)(w->size[a] - 4));
            hi[a] = lo[a] + 3;
        }
        obj_box(add_obj(w, 100001 + 2 * i), lo, hi);
        obj_box(add_obj(w, 100000 + 2 * i), lo, hi);
    }
    for (int i = 0; i < 4; ++i)
        obj_entity(add_obj(w, 200000 + i), rng, w->size, opt);
}

void random_chunk_world(tworld *w, uint64_t *rng, int nx, int ny, int nz)
{
    random_chunk_world_opts(w, rng, nx, ny, nz, &chunk_world_default);
}

const view_opts view_default = {0.3, 0.3, 0.0, 0.2, 0.2, 0.0};

void random_view_opts(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3],
                      const view_opts *opt)
{
    memset(cam, 0, sizeof *cam);
    for (int a = 0; a < 3; ++a) {
        double e = vt_rand_unit(rng) * (size[a] * 1.6) - size[a] * 0.3;
        double u = vt_rand_unit(rng);
        if (u < opt->split)
            e = floor(e / 16.0) * 16.0; /* on a split plane or a chunk corner */
        else if (u < opt->voxel)
            e = floor(e); /* on a voxel plane */
        cam->eye[a] = origin[a] + e;
        cam->target[a] = origin[a] + vt_rand_unit(rng) * size[a];
        if (opt->target_snap > 0.0 && vt_rand_unit(rng) < opt->target_snap)
            cam->target[a] = origin[a] + floor(cam->target[a] - origin[a]);
    }
    double u = vt_rand_unit(rng);
    if (u < opt->axis) { /* along an axis */
        for (int a = 0; a < 3; ++a)
            if (a != 1)
                cam->target[a] = cam->eye[a];
    } else if (u < opt->diagonal) { /* along an exact diagonal: rays through cell corners */
        double k = 8.0 + floor(vt_rand_unit(rng) * 16.0);
        cam->target[0] = cam->eye[0] + (vt_rand(rng) & 1 ? k : -k);
        cam->target[1] = cam->eye[1] + (vt_rand(rng) & 1 ? k : vt_rand(rng) & 1 ? -k : 0.0);
        cam->target[2] = cam->eye[2] + (vt_rand(rng) & 1 ? k : -k);
    }
    cam->fovy_deg = 20.0 + vt_rand_unit(rng) * 100.0;
    if (opt->far > 0.0 && vt_rand_unit(rng) < opt->far) /* a far plane, sometimes exactly on a split distance */
        cam->far_dist = 8.0 + floor(vt_rand_unit(rng) * 4.0) * 8.0;
}

void random_view(vis_camera *cam, uint64_t *rng, const float size[3], const double origin[3])
{
    random_view_opts(cam, rng, size, origin, &view_default);
}
