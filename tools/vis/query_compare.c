/* query_compare.c — the baselines of `vis query --compare`, traced with libvis's own segment
 * test (vis_occ_segment_clear: the same kd-tree and quad test as the ray pass), so that
 * rays and milliseconds compare like with like.
 *
 * Sources for the methods (as described in issue 11 and their projects' documentation):
 *  - SMAC anti-wallhack (SourceMod Anti-Cheat): up to 10 traces per pair, positions
 *    extrapolated by velocity x (latency + interpolation), 0.75 s reveal hold, at most
 *    1,280 traces per tick.
 *  - Luanti (formerly Minetest): isBlockOccluded, 9 rays per 16^3 map block (centre and
 *    corners) to decide what to send; no occlusion for active objects, so its entity variant
 *    here is the same 9-point test applied to the entity box. */
#include "query_compare.h"

#include <string.h>

#include "occlusion.h"
#include "scene.h"

static void local(const vis_scene *s, const double w[3], double out[3])
{
    for (int i = 0; i < 3; ++i)
        out[i] = w[i] - s->desc.origin[i];
}

/* Segment from a to b, stopping `short_by` voxels before b. */
static int clear(const vis_scene_view *v, const double a[3], const double b[3], double short_by)
{
    double d[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    double len = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    double end[3] = {b[0], b[1], b[2]};
    if (short_by > 0.0 && len > 0.0) {
        double l = __builtin_sqrt(len), k = l > short_by ? (l - short_by) / l : 0.0;
        for (int i = 0; i < 3; ++i)
            end[i] = a[i] + d[i] * k;
    }
    return vis_occ_segment_clear(v, a, end, NULL);
}

uint64_t qc_smac(const vis_scene *scene, const vis_query_viewer *vw, uint32_t nv, const vis_query_entity *en,
                 uint32_t ne, double tick_ms, uint32_t hold_ticks, uint32_t max_traces, uint32_t *hold,
                 uint8_t *visible)
{
    vis_scene_begin_read(scene);
    vis_scene_view view = vis_scene_get_view(scene);
    uint64_t traces = 0;
    for (uint32_t i = 0; i < nv; ++i) {
        double L = (vw[i].latency_ms + tick_ms) * 1e-3, eye[3], ew[3];
        for (int k = 0; k < 3; ++k)
            ew[k] = vw[i].eye[k] + vw[i].velocity[k] * L;
        local(scene, ew, eye);
        for (uint32_t j = 0; j < ne; ++j) {
            size_t p = (size_t)i * ne + j;
            visible[p] = 0;
            if (en[j].id == vw[i].id)
                continue;
            int seen = 0;
            if (traces >= max_traces) {
                seen = 1; /* over the tick's trace budget: not checked, sent */
            } else {
                double c[3], h[3];
                for (int k = 0; k < 3; ++k) {
                    double lo = en[j].box_min[k] + en[j].velocity[k] * L, hi = en[j].box_max[k] + en[j].velocity[k] * L;
                    c[k] = 0.5 * (lo + hi);
                    h[k] = 0.5 * (hi - lo);
                }
                double pts[10][3];
                memcpy(pts[0], c, sizeof c);
                memcpy(pts[1], c, sizeof c);
                pts[1][1] = c[1] + 0.8 * h[1]; /* head: stands in for the weapon tip */
                for (int q = 0; q < 8; ++q) {
                    pts[2 + q][0] = c[0] + ((q & 1) ? 1.3 : -1.3) * h[0];
                    pts[2 + q][1] = c[1] + ((q & 2) ? 0.65 : -0.65) * h[1];
                    pts[2 + q][2] = c[2] + ((q & 4) ? 1.3 : -1.3) * h[2];
                }
                for (int q = 0; q < 10 && !seen && traces < max_traces; ++q) {
                    double pl[3];
                    local(scene, pts[q], pl);
                    ++traces;
                    seen = clear(&view, eye, pl, 0.0);
                }
            }
            if (seen)
                hold[p] = hold_ticks + 1;
            else if (hold[p])
                --hold[p];
            visible[p] = seen || hold[p] > 0;
        }
    }
    vis_scene_end_read(scene);
    return traces;
}

uint64_t qc_luanti_entities(const vis_scene *scene, const vis_query_viewer *vw, uint32_t nv,
                            const vis_query_entity *en, uint32_t ne, uint8_t *visible)
{
    vis_scene_begin_read(scene);
    vis_scene_view view = vis_scene_get_view(scene);
    uint64_t traces = 0;
    for (uint32_t i = 0; i < nv; ++i) {
        double eye[3];
        local(scene, vw[i].eye, eye);
        for (uint32_t j = 0; j < ne; ++j) {
            size_t p = (size_t)i * ne + j;
            visible[p] = 0;
            if (en[j].id == vw[i].id)
                continue;
            for (int q = 0; q < 9 && !visible[p]; ++q) {
                double pw[3], pl[3];
                for (int k = 0; k < 3; ++k)
                    pw[k] = q == 0 ? 0.5 * (en[j].box_min[k] + en[j].box_max[k])
                                   : (((q - 1) >> k) & 1) ? en[j].box_max[k] : en[j].box_min[k];
                local(scene, pw, pl);
                ++traces;
                visible[p] = (uint8_t)clear(&view, eye, pl, 0.0);
            }
        }
    }
    vis_scene_end_read(scene);
    return traces;
}

uint64_t qc_luanti_chunks(const vis_scene *scene, const double eye_w[3], const qc_chunk *chunks, uint32_t n,
                          double range, uint8_t *sent)
{
    vis_scene_begin_read(scene);
    vis_scene_view view = vis_scene_get_view(scene);
    double eye[3];
    local(scene, eye_w, eye);
    uint64_t traces = 0;
    for (uint32_t c = 0; c < n; ++c) {
        sent[c] = 0;
        if (!chunks[c].id)
            continue;
        double d2 = 0.0;
        int inside = 1;
        for (int k = 0; k < 3; ++k) {
            double x = eye_w[k] < chunks[c].lo[k] ? chunks[c].lo[k] - eye_w[k]
                       : eye_w[k] > chunks[c].hi[k] ? eye_w[k] - chunks[c].hi[k] : 0.0;
            if (x > 0.0)
                inside = 0;
            d2 += x * x;
        }
        if (d2 > range * range)
            continue;
        if (inside) {
            sent[c] = 1;
            continue;
        }
        for (int q = 0; q < 9 && !sent[c]; ++q) {
            double pw[3], pl[3];
            for (int k = 0; k < 3; ++k)
                pw[k] = q == 0 ? 0.5 * (chunks[c].lo[k] + chunks[c].hi[k])
                               : (((q - 1) >> k) & 1) ? chunks[c].hi[k] : chunks[c].lo[k];
            local(scene, pw, pl);
            ++traces;
            sent[c] = (uint8_t)clear(&view, eye, pl, 1.0);
        }
    }
    vis_scene_end_read(scene);
    return traces;
}
