#include "scene_builder.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

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
    vis_scene *s = NULL;
    if (vis_scene_create(ctx, &d, &s) != VIS_OK)
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
