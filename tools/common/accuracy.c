/* accuracy.c — a draw list against the ground truth: missed objects and area, overdraw,
 * culled hidden objects; averages over a path; display-shaped buffers; the frustum test. */
#include "accuracy.h"

#include <math.h>
#include <string.h>

static int sorted_unique(const vis_draw_entry *e, size_t n)
{
    for (size_t i = 1; i < n; ++i)
        if (e[i].id <= e[i - 1].id)
            return 0;
    return 1;
}

static uint32_t triangles_of(const vc_accuracy_objects *o, uint32_t id)
{
    return o && o->triangles && id < o->id_count ? o->triangles[id] : 0;
}

static int in_view(const vc_accuracy_objects *o, uint32_t id)
{
    return o && o->in_view && id < o->id_count && o->in_view[id];
}

int vc_accuracy_compare(const vis_draw_entry *truth, size_t truth_count, uint64_t truth_samples,
                        const vis_draw_entry *drawn, size_t drawn_count, const vc_accuracy_objects *objects,
                        vc_accuracy *out)
{
    if (!sorted_unique(truth, truth_count) || !sorted_unique(drawn, drawn_count))
        return -1;
    vc_accuracy r;
    memset(&r, 0, sizeof r);
    r.drawn = (uint32_t)drawn_count;
    uint64_t missed_samples = 0;
    size_t i = 0, k = 0;
    /* One merge of the two sorted lists; IDs in neither list are handled below. */
    while (i < truth_count || k < drawn_count) {
        uint32_t t_id = i < truth_count ? truth[i].id : UINT32_MAX;
        uint32_t d_id = k < drawn_count ? drawn[k].id : UINT32_MAX;
        int in_truth = 0, in_drawn = 0;
        uint32_t id, pixels = 0;
        if (i < truth_count && (k >= drawn_count || t_id <= d_id)) {
            id = t_id;
            pixels = truth[i].pixels;
            in_truth = 1;
            ++i;
            if (k < drawn_count && d_id == id) {
                in_drawn = 1;
                ++k;
            }
        } else {
            id = d_id;
            in_drawn = 1;
            ++k;
        }
        int visible = in_truth && pixels > 0;
        if (visible) {
            ++r.truth_visible;
            if (!in_drawn) {
                ++r.missed;
                missed_samples += pixels;
            }
        } else if (in_drawn) {
            ++r.overdraw;
            r.overdraw_triangles += triangles_of(objects, id);
        }
        if (!visible && in_view(objects, id)) {
            ++r.hidden;
            r.hidden_culled += !in_drawn;
        }
    }
    if (missed_samples && !truth_samples)
        return -1;
    r.missed_area = missed_samples ? (double)missed_samples / (double)truth_samples : 0.0;
    /* Objects in view that are in neither list: hidden, and culled. */
    if (objects && objects->in_view) {
        size_t a = 0, b = 0;
        for (uint32_t id = 0; id < objects->id_count; ++id) {
            while (a < truth_count && truth[a].id < id)
                ++a;
            while (b < drawn_count && drawn[b].id < id)
                ++b;
            int listed = (a < truth_count && truth[a].id == id) || (b < drawn_count && drawn[b].id == id);
            if (!listed && objects->in_view[id]) {
                ++r.hidden;
                ++r.hidden_culled;
            }
        }
    }
    *out = r;
    return 0;
}

int vc_accuracy_reasons(const vis_effect_entry *truth, size_t truth_count, const vis_draw_entry *drawn,
                        size_t drawn_count, uint32_t truth_objects[VIS_REASON_COUNT],
                        uint32_t missed[VIS_REASON_COUNT])
{
    for (size_t i = 1; i < truth_count; ++i)
        if (truth[i].id <= truth[i - 1].id)
            return -1;
    if (!sorted_unique(drawn, drawn_count))
        return -1;
    uint32_t t[VIS_REASON_COUNT] = {0}, m[VIS_REASON_COUNT] = {0};
    size_t k = 0;
    for (size_t i = 0; i < truth_count; ++i) {
        while (k < drawn_count && drawn[k].id < truth[i].id)
            ++k;
        int in_drawn = k < drawn_count && drawn[k].id == truth[i].id;
        for (int r = 0; r < VIS_REASON_COUNT; ++r) {
            if (!((truth[i].reasons >> r) & 1u))
                continue;
            ++t[r];
            m[r] += !in_drawn;
        }
    }
    memcpy(truth_objects, t, sizeof t);
    memcpy(missed, m, sizeof m);
    return 0;
}

void vc_accuracy_summarize(const vc_accuracy *f, size_t n, vc_accuracy_summary *out)
{
    memset(out, 0, sizeof *out);
    out->frames = (uint32_t)n;
    double hidden = 0.0, culled = 0.0;
    for (size_t i = 0; i < n; ++i) {
        out->truth_visible += f[i].truth_visible;
        out->drawn += f[i].drawn;
        out->missed += f[i].missed;
        out->missed_area += f[i].missed_area;
        if (f[i].missed_area > out->missed_area_max)
            out->missed_area_max = f[i].missed_area;
        out->overdraw += f[i].overdraw;
        out->overdraw_triangles += (double)f[i].overdraw_triangles;
        out->hidden += f[i].hidden;
        hidden += f[i].hidden;
        culled += f[i].hidden_culled;
        for (int r = 0; r < VIS_REASON_COUNT; ++r) {
            out->reason_truth[r] += f[i].reason_truth[r];
            out->reason_missed[r] += f[i].reason_missed[r];
        }
    }
    if (n) {
        double inv = 1.0 / (double)n;
        out->truth_visible *= inv;
        out->drawn *= inv;
        out->missed *= inv;
        out->missed_area *= inv;
        out->overdraw *= inv;
        out->overdraw_triangles *= inv;
        out->hidden *= inv;
        for (int r = 0; r < VIS_REASON_COUNT; ++r) {
            out->reason_truth[r] *= inv;
            out->reason_missed[r] *= inv;
        }
    }
    out->occluded_culled = hidden > 0.0 ? culled / hidden : 1.0;
}

static uint32_t clamp_side(double v)
{
    if (!(v >= 1.0))
        return 1;
    if (v > (double)VIS_MAX_RESOLUTION)
        return VIS_MAX_RESOLUTION;
    return (uint32_t)v;
}

void vc_accuracy_buffer_size(uint32_t pixels_w, uint32_t pixels_h, uint32_t display_w, uint32_t display_h,
                             uint32_t *out_w, uint32_t *out_h)
{
    double aspect = display_h ? (double)display_w / (double)display_h : 1.0;
    if (!(aspect > 0.0))
        aspect = 1.0;
    double pixels = (double)pixels_w * (double)pixels_h;
    uint32_t h = clamp_side(floor(sqrt(pixels / aspect) + 0.5));
    uint32_t w = clamp_side(floor((double)h * aspect + 0.5));
    *out_w = w;
    *out_h = h;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static int normalize(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(len > 0.0))
        return -1;
    for (int a = 0; a < 3; ++a)
        v[a] /= len;
    return 0;
}

int vc_box_in_view(const vis_camera *c, uint32_t width, uint32_t height, const double lo[3], const double hi[3])
{
    /* The camera frame of DESIGN.md: f = normalize(T - E), r = normalize(f x Y), u = r x f,
     * with (0,0,-1) standing in for Y when f is parallel to it. */
    double f[3] = {c->target[0] - c->eye[0], c->target[1] - c->eye[1], c->target[2] - c->eye[2]};
    if (normalize(f) != 0)
        return 1;
    double up[3] = {0.0, 1.0, 0.0}, r[3], u[3];
    cross(f, up, r);
    if (r[0] == 0.0 && r[1] == 0.0 && r[2] == 0.0) {
        double alt[3] = {0.0, 0.0, -1.0};
        cross(f, alt, r);
    }
    if (normalize(r) != 0)
        return 1;
    cross(r, f, u);
    double fovy = c->fovy_deg > 0.0 ? c->fovy_deg : 60.0;
    double ty = tan(0.5 * fovy * 3.14159265358979323846 / 180.0);
    double tx = ty * (height ? (double)width / (double)height : 1.0);
    double near = c->near_dist > 0.0 ? c->near_dist : 0.05;
    double far = c->far_dist > 0.0 ? c->far_dist : INFINITY;
    /* Bit k of `outside` stays set while every corner so far lies beyond plane k. */
    unsigned outside = 0x3F;
    for (int i = 0; i < 8; ++i) {
        double p[3] = {(i & 1 ? hi[0] : lo[0]) - c->eye[0], (i & 2 ? hi[1] : lo[1]) - c->eye[1],
                       (i & 4 ? hi[2] : lo[2]) - c->eye[2]};
        double z = p[0] * f[0] + p[1] * f[1] + p[2] * f[2];
        double x = p[0] * r[0] + p[1] * r[1] + p[2] * r[2];
        double y = p[0] * u[0] + p[1] * u[1] + p[2] * u[2];
        unsigned o = 0;
        o |= (x > z * tx) << 0;
        o |= (x < -z * tx) << 1;
        o |= (y > z * ty) << 2;
        o |= (y < -z * ty) << 3;
        o |= (z < near) << 4;
        o |= (z > far) << 5;
        outside &= o;
    }
    return outside == 0;
}
