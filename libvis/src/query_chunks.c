/* query_chunks.c — which chunk objects each viewer sees, for streaming: a low-resolution ID
 * pass (the viewer's view, or the six faces of a cube all around) traced for every due
 * viewer in one vis_trace_batch, and the unique IDs of each viewer's pixels.
 *
 * Luanti decides what to send with 9 rays per 16^3 block (its occlusion culler); the ID pass
 * instead traces a fixed number of rays per viewer whatever the world's size, and names only
 * what a pixel centre hits first. It is sampled, not conservative (docs/server.md measures
 * its misses against a dense pass). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "query.h"
#include "query_sort.h"
#include "trace.h"

static int all_around(const vis_query_viewer *in)
{
    return in->dir[0] == 0.0 && in->dir[1] == 0.0 && in->dir[2] == 0.0;
}

/* Would the viewer's pass now look from another camera than its last one? Beyond `move`
 * voxels on any axis, or with another direction or (in view) field of view. */
static int camera_moved(const vis_qviewer *v, const vis_query_viewer *in, double move)
{
    for (int k = 0; k < 3; ++k)
        if (fabs(in->eye[k] - v->chunk_eye[k]) > move || in->dir[k] != v->chunk_dir[k])
            return 1;
    return !all_around(in) && in->fov_deg != v->chunk_fov;
}

/* ---- which passes an edit can change ---------------------------------------------------- */

/* A pass's pixel names the nearest primitive its ray hits within [t_near, t_far] (ties to the
 * lower ID; every traversal gives brute force's answer, docs/traversal.md "Exactness"). An
 * edit changes primitives only inside the hull of the object's box before and after it
 * (scene_edit_log.c), so a ray whose segment [t_near, its hit distance] (or to t_far when it
 * hit nothing) stays out of that box keeps its hit: a primitive added elsewhere lies beyond
 * the hit or off the ray, one removed elsewhere was not the hit. The pass's IDs can change only
 * if one of its rays reaches a changed box before its hit. The test below follows exactly the
 * rays the trace made (vis_ray_for_pixel on the pass's own setup) with their recorded hit
 * distances; the box is grown and the segment lengthened by far more than float rounding, so
 * it errs only toward tracing again. */

/* Slack, in voxels and relative, added to boxes and hit distances against rounding. */
#define EDIT_SLACK_ABS 1e-3
#define EDIT_SLACK_REL 1e-5

/* Does the ray reach the box [lo, hi] within [t0, t1]? (Kay and Kajiya's slabs, in double.) */
static int ray_meets_box(const vis_ray *r, const double lo[3], const double hi[3], double t0, double t1)
{
    for (int a = 0; a < 3; ++a) {
        double o = r->o[a], d = r->d[a];
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
 * the setup's float axes in double; their error is far below a pixel). A box reaching the eye's
 * plane projects without bound: the whole face. Returns 0 when no pixel can. */
static int box_pixels(const vis_ray_setup *st, const double lo[3], const double hi[3], int32_t px[2], int32_t py[2])
{
    const int32_t w = (int32_t)st->width, h = (int32_t)st->height;
    double rr = dot3((const double[3]){st->right[0], st->right[1], st->right[2]}, st->right);
    double uu = dot3((const double[3]){st->up[0], st->up[1], st->up[2]}, st->up);
    double nx_lo = INFINITY, nx_hi = -INFINITY, ny_lo = INFINITY, ny_hi = -INFINITY;
    for (int c = 0; c < 8; ++c) {
        double p[3] = {(c & 1) ? hi[0] : lo[0], (c & 2) ? hi[1] : lo[1], (c & 4) ? hi[2] : lo[2]};
        double z = dot3(p, st->forward);
        double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        if (!(z > 1e-6 * len)) {
            px[0] = py[0] = 0;
            px[1] = w - 1;
            py[1] = h - 1;
            return 1;
        }
        double nx = dot3(p, st->right) / (rr * z), ny = dot3(p, st->up) / (uu * z);
        nx_lo = fmin(nx_lo, nx);
        nx_hi = fmax(nx_hi, nx);
        ny_lo = fmin(ny_lo, ny);
        ny_hi = fmax(ny_hi, ny);
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
    for (int32_t y = py[0]; y <= py[1]; ++y)
        for (int32_t x = px[0]; x <= px[1]; ++x) {
            float t = depth[(size_t)y * st->width + (size_t)x];
            double end = t < st->t_far ? (double)t : (double)st->t_far; /* +inf: nothing hit */
            end += slack + EDIT_SLACK_REL * end;
            vis_ray r;
            vis_ray_for_pixel(st, (uint32_t)x, (uint32_t)y, &r);
            if (ray_meets_box(&r, lo, hi, (double)st->t_near - slack, end))
                return 1;
        }
    return 0;
}

/* Can this tick's changes (q->changes) change the last pass of the viewer in slot s? */
static int edit_reaches(const vis_query *q, uint32_t s)
{
    const vis_qviewer *v = &q->viewers[s];
    if (q->change_count == UINT32_MAX)
        return 1; /* the log did not reach back: anything may have changed */
    size_t pixels = (size_t)q->desc.chunk_res * q->desc.chunk_res;
    for (uint32_t k = 0; k < q->change_count; ++k)
        for (uint32_t f = 0; f < v->chunk_faces; ++f)
            if (face_reaches(&q->chunk_setup[(size_t)s * 6 + f], q->chunk_depth + (size_t)s * q->chunk_cap + f * pixels,
                             &q->changes[k]))
                return 1;
    return 0;
}

/* ---- when a pass runs --------------------------------------------------------------------- */

/* Is the viewer in slot s due for a pass this tick? New viewers at once, and after an edit
 * every viewer with a ray of its last pass that reaches a changed box before its hit (the
 * others keep their lists: the pass would give the same IDs). Otherwise, with chunk_move 0,
 * each slot on its own phase of chunk_every ticks,
 * so that the passes spread evenly over the ticks instead of all landing on the same one --
 * unless its camera is the last pass's to the bit, which would trace the same pixels of the
 * same scene. With chunk_move above 0, when the eye has left the cube of half-side chunk_move
 * around its last pass's eye (or turned): a viewer that stands still costs no rays, one that
 * walks pays in proportion to its speed, and no cadence synchronises the passes. Sets
 * *edited when an edit made it due. */
static int due(const vis_query *q, uint32_t s, const vis_query_viewer *in, int *edited)
{
    const vis_qviewer *v = &q->viewers[s];
    *edited = 0;
    if (v->chunk_tick == 0)
        return 1;
    if (q->regenerated && edit_reaches(q, s)) {
        *edited = 1;
        return 1;
    }
    if (q->desc.chunk_move > 0.0)
        return camera_moved(v, in, q->desc.chunk_move);
    return (q->tick + s) % q->desc.chunk_every == 0 && camera_moved(v, in, 0.0);
}

static void face_camera(const vis_query_viewer *in, double range, int face, vis_camera *c)
{
    memset(c, 0, sizeof *c);
    memcpy(c->eye, in->eye, sizeof c->eye);
    c->near_dist = 0.05;
    c->far_dist = range; /* 0: unlimited */
    if (face < 0) {
        for (int k = 0; k < 3; ++k)
            c->target[k] = in->eye[k] + in->dir[k];
        c->fovy_deg = in->fov_deg;
        return;
    }
    memcpy(c->target, in->eye, sizeof c->target);
    c->target[face >> 1] += (face & 1) ? -1.0 : 1.0;
    c->fovy_deg = 90.0;
}

vis_status vis_query_chunks_run(vis_query *q)
{
    uint32_t ncam = 0, edited_passes = 0;
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        const vis_query_viewer *in = &q->in_viewers[i];
        uint32_t s = q->vslot[i];
        int edited = 0;
        if (!due(q, s, in, &edited))
            continue;
        edited_passes += (uint32_t)edited;
        if (all_around(in)) {
            for (int f = 0; f < 6; ++f) {
                face_camera(in, q->desc.chunk_range, f, &q->cameras[ncam]);
                q->camera_viewer[ncam++] = s;
            }
        } else {
            face_camera(in, q->desc.chunk_range, -1, &q->cameras[ncam]);
            q->camera_viewer[ncam++] = s;
        }
    }
    q->chunk_passes = 0;
    q->chunk_rays = 0;
    q->chunk_edit_passes = 0;
    if (ncam == 0)
        return VIS_OK;
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = q->desc.chunk_res;
    /* The query's default is the plain stack walk: at 32^2 per 90-degree face a pixel spans
     * 0.0625 tangent units, too wide for any packet (cpu/packet.c), and the stack method
     * executed 22-28 % fewer instructions than the packet method's one-ray path on the chunk
     * passes of gen:city and gen:maze (docs/server.md). Every method names the same IDs. */
    d.traversal = q->desc.chunk_traversal == VIS_TRAVERSAL_AUTO ? VIS_TRAVERSAL_STACK : q->desc.chunk_traversal;
    size_t pixels = (size_t)q->desc.chunk_res * q->desc.chunk_res;
    /* What the edit test needs of each face: its rays (the trace's own setup, from the same
     * camera and desc) and their hit distances, both into scratch arrays first, so that a
     * failure leaves every slot's as it was. */
    vis_status st = VIS_OK;
    for (uint32_t c = 0; c < ncam && st == VIS_OK; ++c)
        st = vis_trace_make_setup(q->ctx, q->scene, &q->cameras[c], &d, &q->setups[c]);
    if (st != VIS_OK)
        return st;
    st =
        vis_trace_batch_held(q->ctx, q->scene, q->cameras, ncam, &d, q->ids, pixels * ncam, q->depth, pixels * ncam);
    if (st != VIS_OK)
        return st;
    q->chunk_edit_passes = edited_passes;
    q->chunk_rays = (uint64_t)pixels * ncam;
    /* Cameras of one viewer are consecutive. */
    for (uint32_t c = 0; c < ncam;) {
        uint32_t s = q->camera_viewer[c];
        uint32_t *out = q->chunks + (size_t)s * q->chunk_cap;
        uint32_t n = 0, last = 0, faces = 0;
        for (; c < ncam && q->camera_viewer[c] == s; ++c, ++faces) {
            q->chunk_setup[(size_t)s * 6 + faces] = q->setups[c];
            memcpy(q->chunk_depth + (size_t)s * q->chunk_cap + faces * pixels, q->depth + (size_t)c * pixels,
                   pixels * sizeof *q->depth);
            const uint32_t *ids = q->ids + (size_t)c * pixels;
            for (size_t p = 0; p < pixels; ++p) {
                uint32_t id = ids[p];
                if (id == 0 || id == last)
                    continue; /* runs of one ID are the common case */
                last = id;
                if (vis_idmap_insert(&q->chunk_set, id, 0))
                    out[n++] = id;
            }
        }
        vis_idmap_clear(&q->chunk_set);
        vis_sort_u32(out, n);
        q->viewers[s].chunk_count = n;
        q->viewers[s].chunk_faces = faces;
        q->viewers[s].chunk_tick = q->tick;
        ++q->chunk_passes;
    }
    /* The cameras these lists came from, kept only once they are traced. */
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        const vis_query_viewer *in = &q->in_viewers[i];
        vis_qviewer *v = &q->viewers[q->vslot[i]];
        if (v->chunk_tick != q->tick)
            continue;
        memcpy(v->chunk_eye, in->eye, sizeof v->chunk_eye);
        memcpy(v->chunk_dir, in->dir, sizeof v->chunk_dir);
        v->chunk_fov = in->fov_deg;
    }
    return VIS_OK;
}
