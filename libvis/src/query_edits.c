/* query_edits.c — which faces of the viewers' chunk passes an edit can change (query_chunks.c
 * traces only those again after an edit, instead of every viewer's whole pass).
 *
 * A pass's pixel names the nearest primitive its ray hits within [t_near, t_far] (ties to the
 * lower ID; every traversal gives brute force's answer, docs/traversal.md "Exactness"). An
 * edit changes primitives only inside the hull of the object's box before and after it
 * (scene_edit_log.c), so a ray whose segment [t_near, its hit distance] (or to t_far when it
 * hit nothing) stays out of that box keeps its hit: a primitive added elsewhere lies beyond
 * the hit or off the ray, one removed elsewhere was not the hit. The pass's IDs can change only
 * if one of its rays reaches a changed box before its hit. The test here follows exactly the
 * rays the trace made (vis_ray_for_pixel on the pass's own setup) with their recorded hit
 * distances; the box is grown and the segment lengthened by far more than float rounding, so
 * it errs only toward tracing again.
 *
 * Slab test (vis_segment_meets_box): Kay and Kajiya, "Ray tracing complex scenes", SIGGRAPH
 * 1986. */
#include <math.h>

#include "query.h"

/* Slack, in voxels and relative, added to boxes and hit distances against rounding. */
#define EDIT_SLACK_ABS 1e-3
#define EDIT_SLACK_REL 1e-5

int vis_segment_meets_box(const double o3[3], const double d3[3], const double lo[3], const double hi[3], double t0,
                          double t1)
{
    for (int a = 0; a < 3; ++a) {
        double o = o3[a], d = d3[a];
        if (d == 0.0) {
            if (o < lo[a] || o > hi[a])
                return 0;
            continue;
        }
        double ta = (lo[a] - o) / d, tb = (hi[a] - o) / d;
        if (ta > tb) {
            double t = ta;
            ta = tb;
            tb = t;
        }
        t0 = ta > t0 ? ta : t0;
        t1 = tb < t1 ? tb : t1;
        if (t0 > t1)
            return 0;
    }
    return 1;
}

static double dot3(const double a[3], const float b[3])
{
    return a[0] * (double)b[0] + a[1] * (double)b[1] + a[2] * (double)b[2];
}

/* The pixels of one face whose rays can pass through the box [lo, hi] (relative to the eye):
 * the rectangle of its corners' projections, one pixel wider on each side (the projection uses
 * the setup's float axes in double; their error is far below a pixel). A box wholly behind the
 * eye's plane meets no ray (every ray of a face goes forward: its direction's forward part is
 * at least 1/sqrt(3) of it on a 90-degree face, about 0.06 at an in-view pass's widest field
 * of 170 degrees, far above rounding); one reaching across the plane projects without
 * bound: the whole face. Returns 0 when no pixel can. */
static int box_pixels(const vis_ray_setup *st, const double lo[3], const double hi[3], int32_t px[2], int32_t py[2])
{
    const int32_t w = (int32_t)st->width, h = (int32_t)st->height;
    double rr = dot3((const double[3]){st->right[0], st->right[1], st->right[2]}, st->right);
    double uu = dot3((const double[3]){st->up[0], st->up[1], st->up[2]}, st->up);
    double nx_lo = INFINITY, nx_hi = -INFINITY, ny_lo = INFINITY, ny_hi = -INFINITY;
    int behind = 0, unbounded = 0;
    for (int c = 0; c < 8; ++c) {
        double p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]};
        double z = dot3(p, st->forward);
        double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        behind += z < 0.0;
        double nx = dot3(p, st->right) / (rr * z), ny = dot3(p, st->up) / (uu * z);
        /* Across the eye's plane, or a projection that is not a number (a face whose axes
         * round to 0, for a field of view of 1e-43 degrees): no bound, not "no pixel". */
        if (!(z > 1e-6 * len) || !isfinite(nx) || !isfinite(ny)) {
            unbounded = 1;
            continue;
        }
        nx_lo = fmin(nx_lo, nx);
        nx_hi = fmax(nx_hi, nx);
        ny_lo = fmin(ny_lo, ny);
        ny_hi = fmax(ny_hi, ny);
    }
    if (behind == 8)
        return 0;
    if (unbounded) {
        px[0] = py[0] = 0;
        px[1] = w - 1;
        py[1] = h - 1;
        return 1;
    }
    /* Pixel centre x has nx = (2x+1)/W - 1; y has ny = 1 - (2y+1)/H. */
    double x0 = floor(((nx_lo + 1.0) * w - 1.0) * 0.5) - 1.0, x1 = ceil(((nx_hi + 1.0) * w - 1.0) * 0.5) + 1.0;
    double y0 = floor(((1.0 - ny_hi) * h - 1.0) * 0.5) - 1.0, y1 = ceil(((1.0 - ny_lo) * h - 1.0) * 0.5) + 1.0;
    if (x1 < 0.0 || y1 < 0.0 || x0 > w - 1 || y0 > h - 1)
        return 0;
    px[0] = x0 < 0.0 ? 0 : (int32_t)x0;
    px[1] = x1 > w - 1 ? w - 1 : (int32_t)x1;
    py[0] = y0 < 0.0 ? 0 : (int32_t)y0;
    py[1] = y1 > h - 1 ? h - 1 : (int32_t)y1;
    return 1;
}

/* Does a ray of this face reach the changed box before its hit? */
static int face_reaches(const vis_ray_setup *st, const float *depth, const vis_scene_edit_box *c)
{
    double m = fabs((double)st->origin[0]) + fabs((double)st->origin[1]) + fabs((double)st->origin[2]);
    for (int a = 0; a < 3; ++a)
        m = fmax(m, fmax(fabs((double)c->lo[a]), fabs((double)c->hi[a])));
    double slack = EDIT_SLACK_ABS + EDIT_SLACK_REL * m;
    double lo[3], hi[3], rel_lo[3], rel_hi[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = (double)c->lo[a] - slack;
        hi[a] = (double)c->hi[a] + slack;
        rel_lo[a] = lo[a] - st->origin[a];
        rel_hi[a] = hi[a] - st->origin[a];
    }
    int32_t px[2], py[2];
    if (!box_pixels(st, rel_lo, rel_hi, px, py))
        return 0;
    /* A ray's point at distance t lies t |d| from the eye, and |d| is 1 within a few float
     * ulps: a ray whose segment ends nearer than the box's nearest point (with a margin far
     * above that) cannot reach it. Most pixels of a box hidden behind terrain end there, and
     * need no ray of their own. */
    double gap2 = 0.0;
    for (int a = 0; a < 3; ++a) {
        double g = fmax(fmax(rel_lo[a], -rel_hi[a]), 0.0);
        gap2 += g * g;
    }
    double nearest = sqrt(gap2) * (1.0 - 1e-5);
    for (int32_t y = py[0]; y <= py[1]; ++y)
        for (int32_t x = px[0]; x <= px[1]; ++x) {
            float t = depth[(size_t)y * st->width + (size_t)x];
            double end = t < st->t_far ? (double)t : (double)st->t_far; /* +inf: nothing hit */
            end += slack + EDIT_SLACK_REL * end;
            if (end < nearest)
                continue;
            vis_ray r;
            vis_ray_for_pixel(st, (uint32_t)x, (uint32_t)y, &r);
            const double o[3] = {r.o[0], r.o[1], r.o[2]}, d[3] = {r.d[0], r.d[1], r.d[2]};
            if (vis_segment_meets_box(o, d, lo, hi, (double)st->t_near - slack, end))
                return 1;
        }
    return 0;
}

uint32_t vis_query_edit_faces(const vis_query *q, uint32_t s)
{
    const vis_qviewer *v = &q->viewers[s];
    size_t pixels = (size_t)q->desc.chunk_res * q->desc.chunk_res;
    uint32_t reached = 0;
    for (uint32_t f = 0; f < v->chunk_faces; ++f) {
        if (v->face_tick[f] == 0)
            continue; /* never traced: nothing kept to change */
        if (q->change_count == UINT32_MAX) {
            reached |= 1u << f; /* the log did not reach back: anything may have changed */
            continue;
        }
        for (uint32_t k = 0; k < q->change_count; ++k)
            if (face_reaches(&q->chunk_setup[(size_t)s * 6 + f], q->chunk_depth + (size_t)s * q->chunk_cap + f * pixels,
                             &q->changes[k])) {
                reached |= 1u << f;
                break;
            }
    }
    return reached;
}

