/* ref_trace.c — the double-precision reference (see ref_trace.h). */
#include "ref_trace.h"

#include "test_support.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define REF_U 5.9604644775390625e-08 /* 2^-24: the unit roundoff of float */

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static double len3(const double a[3]) { return sqrt(dot3(a, a)); }

static double max_abs3(const double a[3])
{
    double m = fabs(a[0]);
    if (fabs(a[1]) > m)
        m = fabs(a[1]);
    if (fabs(a[2]) > m)
        m = fabs(a[2]);
    return m;
}

int ref_camera_make(const vis_camera *cam, const double scene_origin[3], uint32_t width, uint32_t height,
                    ref_camera *out)
{
    memset(out, 0, sizeof *out);
    double fovy = cam->fovy_deg == 0.0 ? 60.0 : cam->fovy_deg;
    if (!(fovy > 0.0 && fovy < 180.0) || width == 0 || height == 0)
        return 0;
    double fwd[3];
    for (int a = 0; a < 3; ++a) {
        out->eye[a] = cam->eye[a] - (scene_origin ? scene_origin[a] : 0.0);
        fwd[a] = cam->target[a] - cam->eye[a];
    }
    double l = len3(fwd);
    if (!(l > 0.0))
        return 0;
    for (int a = 0; a < 3; ++a)
        out->f[a] = fwd[a] / l;
    /* r = normalize(f x (0,1,0)), (0,0,-1) standing in when that is exactly zero; u = r x f */
    const double up_y[3] = {0.0, 1.0, 0.0}, up_z[3] = {0.0, 0.0, -1.0};
    double r[3];
    cross3(out->f, up_y, r);
    if (r[0] == 0.0 && r[1] == 0.0 && r[2] == 0.0)
        cross3(out->f, up_z, r);
    double rl = len3(r);
    for (int a = 0; a < 3; ++a)
        out->r[a] = r[a] / rl;
    cross3(out->r, out->f, out->u);
    out->tan_half = tan(fovy * 0.5 * (3.14159265358979323846 / 180.0));
    out->aspect = (double)width / (double)height;
    out->near_d = cam->near_dist == 0.0 ? 0.05 : cam->near_dist;
    out->far_d = cam->far_dist == 0.0 ? INFINITY : cam->far_dist;
    out->width = width;
    out->height = height;
    return 1;
}

void ref_camera_ray(const ref_camera *c, uint32_t x, uint32_t y, ref_ray *r)
{
    double nx = ((double)x + 0.5) / (double)c->width * 2.0 - 1.0;
    double ny = 1.0 - ((double)y + 0.5) / (double)c->height * 2.0;
    double d[3];
    for (int a = 0; a < 3; ++a)
        d[a] = c->f[a] + nx * c->tan_half * c->aspect * c->r[a] + ny * c->tan_half * c->u[a];
    double l = len3(d);
    for (int a = 0; a < 3; ++a) {
        r->o[a] = c->eye[a];
        r->d[a] = d[a] / l;
    }
    r->t_near = c->near_d;
    r->t_far = c->far_d;
    /* The library rounds the scene-local eye to float once. Its direction is f + nx R + ny U
     * in float, from f, R = r tan aspect, U = u tan rounded to float and nx, ny rounded (<= 3
     * units of u = 2^-24, absolute): each term and each sum adds at most a few u times |f| +
     * |R| + |U| <= 1 + tan (aspect + 1), and the unnormalised vector is at least 1 long (f is
     * orthogonal to R and U); normalising adds about 2u. So about 8u times that sum; taken
     * twice over. The centre pixel of an odd-sized image has nx = ny = 0 exactly: d = fl(F /
     * |F|) with F = fl(f), within 2u of f per component; 4u. */
    double err_o = 0.0;
    for (int a = 0; a < 3; ++a) {
        double e = fabs((double)(float)c->eye[a] - c->eye[a]);
        err_o = e > err_o ? e : err_o;
    }
    r->err_o = err_o;
    int centre = nx == 0.0 && ny == 0.0;
    r->err_d = centre ? 4.0 * REF_U : 16.0 * REF_U * (1.0 + c->tan_half * (c->aspect + 1.0));
    r->strict = centre && err_o == 0.0;
}

void ref_ray_from_float(const float o[3], const float d[3], float t_near, float t_far, ref_ray *r)
{
    for (int a = 0; a < 3; ++a) {
        r->o[a] = o[a];
        r->d[a] = d[a];
    }
    r->t_near = t_near;
    r->t_far = t_far;
    r->err_o = 0.0;
    r->err_d = 0.0;
    r->strict = 1;
}

/* 2^-45 of the magnitudes: double rounding, far below float rounding (2^-24). */
#define REF_TOUCH 2.8421709430404007e-14

int ref_quad(const ref_ray *r, const vis_quad *q, double widen, double *t_out)
{
    uint32_t a = q->axis, u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    if (r->d[a] == 0.0)
        return 0;
    double t = ((double)q->plane - r->o[a]) / r->d[a];
    double su = t * r->d[u], sv = t * r->d[v];
    double pu = r->o[u] + su, pv = r->o[v] + sv;
    double mu = widen + REF_TOUCH * (fabs(r->o[u]) + fabs(su)), mv = widen + REF_TOUCH * (fabs(r->o[v]) + fabs(sv));
    *t_out = t;
    return pu >= (double)q->u0 - mu && pu <= (double)q->u1 + mu && pv >= (double)q->v0 - mv &&
           pv <= (double)q->v1 + mv;
}

int ref_triangle(const ref_ray *r, const vis_triangle *tr, double widen, double *t_out)
{
    double v[3][3];
    for (int i = 0; i < 3; ++i)
        for (int a = 0; a < 3; ++a)
            v[i][a] = tr->v[i][a];
    double e1[3], e2[3], n[3];
    for (int a = 0; a < 3; ++a) {
        e1[a] = v[1][a] - v[0][a];
        e2[a] = v[2][a] - v[0][a];
    }
    cross3(e1, e2, n);
    double nn = len3(n);
    double den = dot3(n, r->d);
    if (!(nn > 0.0) || den == 0.0)
        return 0; /* degenerate, or parallel to its plane */
    double w[3];
    for (int a = 0; a < 3; ++a)
        w[a] = v[0][a] - r->o[a];
    double t = dot3(n, w) / den;
    double p[3];
    for (int a = 0; a < 3; ++a)
        p[a] = r->o[a] + t * r->d[a];
    double mag = max_abs3(r->o) + fabs(t) * max_abs3(r->d) + max_abs3(v[0]);
    *t_out = t;
    /* Signed distance of p from each edge's line, in the plane, positive inside. */
    for (int i = 0; i < 3; ++i) {
        const double *a0 = v[i], *a1 = v[(i + 1) % 3];
        double e[3], ap[3], c[3];
        for (int k = 0; k < 3; ++k) {
            e[k] = a1[k] - a0[k];
            ap[k] = p[k] - a0[k];
        }
        cross3(e, ap, c);
        double el = len3(e);
        double s = el > 0.0 ? dot3(c, n) / (nn * el) : 0.0;
        if (s < -(widen + REF_TOUCH * mag))
            return 0;
    }
    return 1;
}

ref_bound ref_face_bound(const ref_ray *r, double t, double cos_n)
{
    double at = fabs(t);
    double mag = max_abs3(r->o) + at * max_abs3(r->d);
    /* The two rays lie at most this far apart at distance t; a crossing point on a plane moves
     * by that over the cosine (twice: the offset along the plane and the tilt both count). */
    double apart = r->err_o + at * r->err_d;
    double c = cos_n > 1e-300 ? cos_n : 1e-300;
    /* The library: its distances round by a few units of 2^-24, its quad test takes what it
     * misses by up to 2^-20 of |t d| and that rounding (trace_core.h), its unit direction is
     * 1 long within a few units of 2^-24. 2^-18 of the magnitudes covers all. */
    double lib = 3.814697265625e-06 * mag; /* 2^-18 */
    ref_bound b;
    b.ray = 2.0 * apart / c;
    b.in_plane = b.ray + lib;
    b.t = b.ray + lib;
    return b;
}

/* The cosine between the ray and a primitive's plane normal. */
static double prim_cos(const ref_ray *r, const tobj *o, uint32_t k)
{
    double dl = len3(r->d);
    if (k < o->nq)
        return fabs(r->d[o->quads[k].axis]) / dl;
    const vis_triangle *tr = &o->tris[k - o->nq];
    double e1[3], e2[3], n[3];
    for (int a = 0; a < 3; ++a) {
        e1[a] = (double)tr->v[1][a] - tr->v[0][a];
        e2[a] = (double)tr->v[2][a] - tr->v[0][a];
    }
    cross3(e1, e2, n);
    double nl = len3(n);
    return nl > 0.0 ? fabs(dot3(n, r->d)) / (nl * dl) : 0.0;
}

static int prim_hit(const ref_ray *r, const tobj *o, uint32_t k, double widen, double *t)
{
    if (k < o->nq)
        return ref_quad(r, &o->quads[k], widen, t);
    return ref_triangle(r, &o->tris[k - o->nq], widen, t);
}

void ref_scene_init(ref_scene *s, const tworld *w)
{
    s->w = w;
    s->box = malloc((w->n ? w->n : 1) * sizeof *s->box);
    s->order = malloc((w->n ? w->n : 1) * sizeof *s->order);
    for (uint32_t i = 0; i < w->n; ++i) {
        const tobj *o = &w->objs[i];
        double *b = s->box[i];
        for (int a = 0; a < 3; ++a) {
            b[a] = INFINITY;
            b[3 + a] = -INFINITY;
        }
        for (uint32_t k = 0; k < o->nq; ++k) {
            const vis_quad *q = &o->quads[k];
            uint32_t a = q->axis, u = (a + 1u) % 3u, v = (a + 2u) % 3u;
            double lo[3], hi[3];
            lo[a] = hi[a] = q->plane;
            lo[u] = q->u0, hi[u] = q->u1, lo[v] = q->v0, hi[v] = q->v1;
            for (int c = 0; c < 3; ++c) {
                b[c] = fmin(b[c], lo[c]);
                b[3 + c] = fmax(b[3 + c], hi[c]);
            }
        }
        for (uint32_t k = 0; k < o->nt; ++k)
            for (int j = 0; j < 3; ++j)
                for (int c = 0; c < 3; ++c) {
                    b[c] = fmin(b[c], o->tris[k].v[j][c]);
                    b[3 + c] = fmax(b[3 + c], o->tris[k].v[j][c]);
                }
    }
}

void ref_scene_free(ref_scene *s)
{
    free(s->box);
    free(s->order);
    s->box = NULL;
    s->order = NULL;
}

/* Can the ray touch the box (widened far past double rounding) within [t_near, t_far]? Where
 * it enters it (*t_enter, no later than any hit inside). */
static int box_touched(const ref_ray *r, const double *b, double *t_enter)
{
    double t0 = r->t_near, t1 = r->t_far;
    double m = 1e-9 * (max_abs3(r->o) + max_abs3(b) + max_abs3(b + 3) + 1.0);
    for (int a = 0; a < 3; ++a) {
        double lo = b[a] - m, hi = b[3 + a] + m;
        if (r->d[a] == 0.0) {
            if (r->o[a] < lo || r->o[a] > hi)
                return 0;
            continue;
        }
        double ta = (lo - r->o[a]) / r->d[a], tb = (hi - r->o[a]) / r->d[a];
        if (ta > tb) {
            double x = ta;
            ta = tb;
            tb = x;
        }
        t0 = fmax(t0, ta - m);
        t1 = fmin(t1, tb + m);
    }
    *t_enter = t0;
    return t0 <= t1;
}

/* The first hit, and the first hit the library cannot miss: a face met certainly between the
 * near and far planes (not within the bound of either). */
static void first_hits(const ref_scene *s, const ref_ray *r, ref_hit *first, ref_hit *certain)
{
    const tworld *w = s->w;
    ref_hit h = {INFINITY, 0, 0, 0}, c = {INFINITY, 0, 0, 0};
    /* The touched objects by box entry (insertion sort: a ray touches few). */
    uint32_t n = 0;
    for (uint32_t i = 0; i < w->n; ++i) {
        double te;
        if (w->objs[i].nq + w->objs[i].nt == 0 || !box_touched(r, s->box[i], &te))
            continue;
        uint32_t j = n++;
        while (j > 0 && s->order[j - 1].t > te) {
            s->order[j] = s->order[j - 1];
            --j;
        }
        s->order[j].t = te;
        s->order[j].obj = i;
    }
    for (uint32_t e = 0; e < n; ++e) {
        /* Past both hits (the certain one is never nearer): nothing further can win or tie. */
        double beyond = certain ? c.t : h.t;
        if (s->order[e].t > beyond)
            break;
        uint32_t i = s->order[e].obj;
        const tobj *o = &w->objs[i];
        for (uint32_t k = 0; k < o->nq + o->nt; ++k) {
            double t;
            if (!prim_hit(r, o, k, 0.0, &t) || !(t >= r->t_near) || !(t <= r->t_far))
                continue;
            if (t < h.t || (t == h.t && o->id < h.id)) {
                h.t = t, h.id = o->id, h.obj = i, h.prim = k;
            }
            if (certain && t < c.t) {
                /* Certain: not within the bound of the near or far plane, and (unless the ray
                 * is strict) not within the ray's own rounding of the face's boundary. */
                ref_bound b = ref_face_bound(r, t, prim_cos(r, o, k));
                double tc = t;
                if (t - b.t >= r->t_near && t + b.t <= r->t_far && (r->strict || prim_hit(r, o, k, -b.ray, &tc)))
                    c.t = t, c.id = o->id, c.obj = i, c.prim = k;
            }
        }
    }
    *first = h;
    if (certain)
        *certain = c;
}

ref_hit ref_first_hit(const ref_scene *s, const ref_ray *r)
{
    ref_hit h;
    first_hits(s, r, &h, NULL);
    return h;
}

/* Does the ray pass within the bound of a face of object `id`, at a distance within the bound
 * of t? */
static int near_object(const tworld *w, const ref_ray *r, uint32_t id, double t)
{
    for (uint32_t i = 0; i < w->n; ++i) {
        const tobj *o = &w->objs[i];
        if (o->id != id)
            continue;
        for (uint32_t k = 0; k < o->nq + o->nt; ++k) {
            double c = prim_cos(r, o, k), tf = INFINITY;
            if (c == 0.0)
                continue;
            prim_hit(r, o, k, 0.0, &tf); /* the plane's distance, hit or not */
            /* The bound at the larger of the two distances. */
            ref_bound b = ref_face_bound(r, fabs(tf) > fabs(t) ? tf : t, c);
            if (prim_hit(r, o, k, b.in_plane, &tf) && fabs(tf - t) <= b.t)
                return 1;
        }
    }
    return 0;
}

int ref_check(const ref_scene *s, const ref_ray *r, uint32_t id, float t, ref_hit *ref_out, char *why, size_t cap)
{
    const tworld *w = s->w;
    ref_hit first, must;
    first_hits(s, r, &first, &must);
    if (ref_out)
        *ref_out = first;
    if (must.t < INFINITY) {
        const tobj *o = &w->objs[must.obj];
        ref_bound b = ref_face_bound(r, must.t, prim_cos(r, o, must.prim));
        if (id == 0 || !((double)t <= must.t + b.t)) {
            if (why)
                snprintf(why, cap, "slip: library id %u t %.9g, reference id %u t %.9g (%s %u of id %u, bound %.3g)",
                         id, (double)t, first.id, first.t, must.prim < o->nq ? "quad" : "triangle", must.prim,
                         must.id, b.t);
            return 1;
        }
    }
    if (id != 0 && !near_object(w, r, id, (double)t)) {
        if (why)
            snprintf(why, cap, "phantom: library id %u t %.9g, no face of it near the ray; reference id %u t %.9g", id,
                     (double)t, first.id, first.t);
        return 2;
    }
    return 0;
}

/* ---- rays aimed at edges and corners ---------------------------------------------------- */

/* A corner of a random quad (half the time) or a point of one of its edges at a multiple of
 * 1/4 (voxel corners, T-junctions and points between them), scene-local. The edges of a voxel
 * mesh are convex and concave voxel edges and seams between coplanar quads. */
void ref_edge_point(const tworld *w, uint64_t *rng, double p[3])
{
    const tobj *o;
    do
        o = &w->objs[vt_rand(rng) % w->n];
    while (o->nq == 0);
    const vis_quad *q = &o->quads[vt_rand(rng) % o->nq];
    uint32_t a = q->axis, u = (a + 1u) % 3u, v = (a + 2u) % 3u;
    double cu = vt_rand(rng) & 1 ? q->u1 : q->u0, cv = vt_rand(rng) & 1 ? q->v1 : q->v0;
    uint64_t kind = vt_rand(rng) % 4;
    if (kind == 2)
        cu = q->u0 + floor(vt_rand_unit(rng) * (q->u1 - q->u0) * 4.0 + 0.5) / 4.0;
    else if (kind == 3)
        cv = q->v0 + floor(vt_rand_unit(rng) * (q->v1 - q->v0) * 4.0 + 0.5) / 4.0;
    p[a] = q->plane;
    p[u] = cu;
    p[v] = cv;
}

/* An eye exact in float (a multiple of 1/64) around the world, at least 1 from p; sometimes
 * in one of p's planes, so that the ray lies in the plane of a face. */
void ref_random_eye(uint64_t *rng, const float size[3], const double p[3], double e[3])
{
    double dd;
    do {
        for (int a = 0; a < 3; ++a)
            e[a] = floor((vt_rand_unit(rng) * (size[a] + 32.0) - 16.0) * 64.0) / 64.0;
        if (vt_rand_unit(rng) < 0.15) {
            int a = (int)(vt_rand(rng) % 3);
            e[a] = p[a];
        }
        dd = 0.0;
        for (int a = 0; a < 3; ++a)
            dd += (e[a] - p[a]) * (e[a] - p[a]);
    } while (dd < 1.0);
}

void ref_aimed_ray(uint64_t *rng, const float size[3], const double p[3], int through, double p_zero, int dmax,
                   int kden, int ksteps, float o[3], float d[3])
{
    if (through) {
        int D[3];
        do {
            for (int a = 0; a < 3; ++a)
                D[a] = vt_rand_unit(rng) < p_zero ? 0 : (int)(vt_rand(rng) % (uint64_t)(2 * dmax + 1)) - dmax;
        } while (D[0] == 0 && D[1] == 0 && D[2] == 0);
        double k = (double)((uint64_t)kden + vt_rand(rng) % (uint64_t)ksteps) / (double)kden;
        for (int a = 0; a < 3; ++a) {
            o[a] = (float)(p[a] - k * D[a]);
            d[a] = (float)D[a];
        }
    } else {
        double e[3], v[3], l = 0.0;
        ref_random_eye(rng, size, p, e);
        for (int a = 0; a < 3; ++a) {
            v[a] = p[a] - e[a];
            l += v[a] * v[a];
        }
        for (int a = 0; a < 3; ++a) {
            o[a] = (float)e[a];
            d[a] = (float)(v[a] / sqrt(l));
        }
    }
}
