/* query_chunks.c — which chunk objects each viewer sees, for streaming: a low-resolution ID
 * pass (the viewer's view, or the six faces of a cube all around) traced for the due faces
 * of every viewer in one vis_trace_batch, and the unique IDs of each viewer's pixels.
 *
 * Luanti decides what to send with 9 rays per 16^3 block (its occlusion culler); the ID pass
 * instead traces a fixed number of rays per viewer whatever the world's size, and names only
 * what a pixel centre hits first. It is sampled, not conservative (docs/server.md measures
 * its misses against a dense pass).
 *
 * Each face (camera) of a viewer's pass is kept and traced on its own: its ray setup, hit
 * distances and unique IDs live in the viewer's slot, and the viewer's list is the union of
 * its faces' IDs. So an edit retraces only the faces it reaches, and chunk_face_budget can
 * spread one viewer's pass over several calls. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "query.h"
#include "query_sort.h"
#include "trace.h"

int vis_query_all_around(const vis_query_viewer *in)
{
    return in->dir[0] == 0.0 && in->dir[1] == 0.0 && in->dir[2] == 0.0;
}

/* The faces of the viewer's pass: 6 all around, 1 in view. */
static uint32_t faces_of(const vis_query_viewer *in) { return vis_query_all_around(in) ? 6u : 1u; }

/* Would the viewer's pass now look from another camera than the one its faces were last due
 * for? Beyond `move` voxels on any axis, or with another direction or (in view) field of view. */
static int camera_moved(const vis_qviewer *v, const vis_query_viewer *in, double move)
{
    for (int k = 0; k < 3; ++k)
        if (fabs(in->eye[k] - v->chunk_eye[k]) > move || in->dir[k] != v->chunk_dir[k])
            return 1;
    return !vis_query_all_around(in) && in->fov_deg != v->chunk_fov;
}

/* ---- which faces are due ---------------------------------------------------------------- */

/* Why a face is due, most urgent first: its viewer has no list yet (or changed between in
 * view and all around), an edit reached the face's last trace, or the viewer's cadence or
 * motion came (vis_qviewer.face_owed stores one of these plus one). */
enum { DUE_NEW, DUE_EDIT, DUE_ROUTINE };

/* The faces of the viewer in slot s that are due this tick, by why (q->face_due, by input
 * index i: 0, or 1 + the reason). A viewer without faces of its kind yet: all of them, as new.
 * Otherwise the faces still owed from an earlier call; after an edit, every face with a ray
 * that reaches a changed box before its hit (the others keep their IDs: a trace would give
 * the same); and all faces when the viewer is due by its schedule: with chunk_move 0, each
 * slot on its own phase of chunk_every ticks (so that the passes spread evenly over the ticks
 * instead of all landing on the same one), unless its camera is the one of its last round to
 * the bit, which would trace the same pixels of the same scene; with chunk_move above 0, when
 * the eye has left the cube of half-side chunk_move around its last round's eye (or turned):
 * a viewer that stands still costs no rays, one that walks pays in proportion to its speed,
 * and no cadence synchronises the passes. Returns whether the schedule started a round. */
static int due_faces(vis_query *q, uint32_t i, uint32_t s)
{
    const vis_query_viewer *in = &q->in_viewers[i];
    const vis_qviewer *v = &q->viewers[s];
    uint8_t *due = q->face_due + (size_t)i * 6;
    uint32_t n = faces_of(in);
    memset(due, 0, 6);
    if (v->chunk_faces != n) {
        memset(due, 1 + DUE_NEW, n);
        return 1;
    }
    memcpy(due, v->face_owed, 6);
    if (q->regenerated) {
        uint32_t reached = vis_query_edit_faces(q, s);
        for (uint32_t f = 0; f < n; ++f)
            if (reached >> f & 1u && (!due[f] || due[f] > 1 + DUE_EDIT))
                due[f] = 1 + DUE_EDIT;
    }
    int round = q->desc.chunk_move > 0.0 ? camera_moved(v, in, q->desc.chunk_move)
                                         : (q->tick + s) % q->desc.chunk_every == 0 && camera_moved(v, in, 0.0);
    if (round)
        for (uint32_t f = 0; f < n; ++f)
            if (!due[f])
                due[f] = 1 + DUE_ROUTINE;
    return round;
}

static void face_camera(const vis_query_viewer *in, double range, int face, vis_camera *c)
{
    memset(c, 0, sizeof *c);
    memcpy(c->eye, in->eye, sizeof c->eye);
    c->near_dist = 0.05;
    c->far_dist = range; /* 0: unlimited */
    if (!vis_query_all_around(in)) {
        for (int k = 0; k < 3; ++k)
            c->target[k] = in->eye[k] + in->dir[k];
        c->fovy_deg = in->fov_deg;
        return;
    }
    memcpy(c->target, in->eye, sizeof c->target);
    c->target[face >> 1] += (face & 1) ? -1.0 : 1.0;
    c->fovy_deg = 90.0;
}

/* ---- the face budget -------------------------------------------------------------------- */

/* This tick's due faces (keys in q->face_keys: reason, the age of the face's last trace,
 * input index, face) in the order chunk_face_budget takes them: by reason, then the oldest
 * trace first, then input order, then face -- nothing that depends on threads or timing.
 * Returns how many are due; the first min(budget, due) are traced. */
_Static_assert(VIS_QUERY_MAX_VIEWERS <= 0x2000u, "an input index takes 13 bits of the key");

static uint32_t order_due_faces(vis_query *q)
{
    uint32_t n = 0;
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        const vis_qviewer *v = &q->viewers[q->vslot[i]];
        const uint8_t *due = q->face_due + (size_t)i * 6;
        for (uint32_t f = 0; f < 6; ++f) {
            if (!due[f])
                continue;
            uint64_t age = v->chunk_faces == faces_of(&q->in_viewers[i]) ? v->face_tick[f] : 0;
            age = age > 0xFFFFFFFFFFull ? 0xFFFFFFFFFFull : age; /* 40 bits of ticks */
            q->face_keys[n++] = (uint64_t)(due[f] - 1u) << 62 | age << 16 | (uint64_t)i << 3 | f;
        }
    }
    uint32_t budget = q->desc.chunk_face_budget;
    if (budget != 0 && n > budget)
        vis_sort_u64(q->face_keys, n);
    return n;
}

/* What happened to an input viewer this tick (q->viewer_flags): its schedule started a round,
 * a face of it was traced, one of them because an edit reached it. */
enum { FLAG_ROUND = 1u, FLAG_TRACED = 2u, FLAG_EDIT = 4u };

#define KEY_INPUT(k) ((uint32_t)((k) >> 3 & 0x1FFFu))
#define KEY_FACE(k) ((uint32_t)((k) & 7u))
#define KEY_REASON(k) ((uint32_t)((k) >> 62))

/* ---- after the trace ------------------------------------------------------------------- */

/* Keeps what the edit test and the list need of the face traced by camera c: its ray setup,
 * hit distances and unique IDs (merge_faces sorts the viewer's union of them). */
static void keep_face(vis_query *q, uint32_t c, uint32_t s, uint32_t f, size_t pixels)
{
    vis_qviewer *v = &q->viewers[s];
    size_t at = (size_t)s * q->chunk_cap + f * pixels;
    q->chunk_setup[(size_t)s * 6 + f] = q->setups[c];
    memcpy(q->chunk_depth + at, q->depth + (size_t)c * pixels, pixels * sizeof *q->depth);
    const uint32_t *ids = q->ids + (size_t)c * pixels;
    uint32_t *out = q->face_ids + at;
    uint32_t n = 0, last = 0;
    for (size_t p = 0; p < pixels; ++p) {
        uint32_t id = ids[p];
        if (id == 0 || id == last)
            continue; /* runs of one ID are the common case */
        last = id;
        if (vis_idmap_insert(&q->chunk_set, id, 0))
            out[n++] = id;
    }
    vis_idmap_clear(&q->chunk_set);
    v->face_count[f] = n;
    v->face_tick[f] = q->tick;
}

/* The viewer's list: the union of its faces' IDs, sorted. */
static void merge_faces(vis_query *q, uint32_t s, size_t pixels)
{
    vis_qviewer *v = &q->viewers[s];
    uint32_t *out = q->chunks + (size_t)s * q->chunk_cap;
    uint32_t n = 0;
    for (uint32_t f = 0; f < v->chunk_faces; ++f) {
        const uint32_t *ids = q->face_ids + (size_t)s * q->chunk_cap + f * pixels;
        for (uint32_t k = 0; k < v->face_count[f]; ++k)
            if (vis_idmap_insert(&q->chunk_set, ids[k], 0))
                out[n++] = ids[k];
    }
    vis_idmap_clear(&q->chunk_set);
    vis_sort_u32(out, n);
    v->chunk_count = n;
}

vis_status vis_query_chunks_warm(vis_query *q)
{
    vis_camera cams[2];
    memset(cams, 0, sizeof cams);
    for (int c = 0; c < 2; ++c) {
        cams[c].target[0] = 1.0;
        cams[c].fovy_deg = 90.0;
    }
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = 1;
    d.traversal = q->desc.chunk_traversal;
    uint32_t ids[2];
    float depth[2];
    return vis_trace_batch_held(q->ctx, q->scene, cams, 2, &d, ids, 2, depth, 2);
}

vis_status vis_query_chunks_run(vis_query *q)
{
    q->chunk_passes = 0;
    q->chunk_rays = 0;
    q->chunk_edit_passes = 0;
    q->chunk_deferred = 0;
    for (uint32_t i = 0; i < q->viewer_count; ++i)
        q->viewer_flags[i] = due_faces(q, i, q->vslot[i]) ? FLAG_ROUND : 0u;
    uint32_t ndue = order_due_faces(q);
    uint32_t budget = q->desc.chunk_face_budget;
    uint32_t ncam = budget != 0 && ndue > budget ? budget : ndue;
    for (uint32_t c = 0; c < ncam; ++c) {
        uint64_t k = q->face_keys[c];
        face_camera(&q->in_viewers[KEY_INPUT(k)], q->desc.chunk_range, (int)KEY_FACE(k), &q->cameras[c]);
    }
    size_t pixels = (size_t)q->desc.chunk_res * q->desc.chunk_res;
    if (ncam > 0) {
        vis_trace_desc d;
        vis_trace_desc_defaults(&d);
        d.width = d.height = q->desc.chunk_res;
        /* The query's default is the backend's: on the CPU, 4x4 packets at 32^2 per 90-degree
         * face (a tile spreads 0.25 tangent units, within cpu/packet.c's limit for 4x4), which
         * executed 24-70 % fewer instructions than the stack walk on the chunk passes of
         * gen:city, gen:default and gen:maze; finer faces take larger packets, coarser ones
         * lone rays. Every method names the same IDs (docs/server.md, "Chunk passes in 4x4
         * packets"). */
        d.traversal = q->desc.chunk_traversal;
        /* What the edit test needs of each face: its rays (the trace's own setup, from the same
         * camera and desc) and their hit distances, both into scratch arrays first, so that a
         * failure leaves every slot's as it was. */
        vis_status st = VIS_OK;
        for (uint32_t c = 0; c < ncam && st == VIS_OK; ++c)
            st = vis_trace_make_setup(q->ctx, q->scene, &q->cameras[c], &d, &q->setups[c]);
        if (st == VIS_OK)
            st = vis_trace_batch_held(q->ctx, q->scene, q->cameras, ncam, &d, q->ids, pixels * ncam, q->depth,
                                      pixels * ncam);
        if (st != VIS_OK)
            return st;
    }
    /* Traced: from here on the slots change. A viewer whose kind of pass changed (or a new
     * one) drops its old faces when the first face of the new kind is traced. */
    for (uint32_t c = 0; c < ncam; ++c) {
        uint64_t k = q->face_keys[c];
        uint32_t i = KEY_INPUT(k), s = q->vslot[i], f = KEY_FACE(k);
        vis_qviewer *v = &q->viewers[s];
        uint32_t n = faces_of(&q->in_viewers[i]);
        if (v->chunk_faces != n) {
            memset(v->face_count, 0, sizeof v->face_count);
            memset(v->face_tick, 0, sizeof v->face_tick);
            v->chunk_faces = n;
        }
        keep_face(q, c, s, f, pixels);
        q->face_due[(size_t)i * 6 + f] = 0; /* traced: no longer owed */
        q->viewer_flags[i] |= FLAG_TRACED | (KEY_REASON(k) == DUE_EDIT ? FLAG_EDIT : 0u);
    }
    q->chunk_rays = (uint64_t)pixels * ncam;
    q->chunk_deferred = ndue - ncam;
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        uint32_t s = q->vslot[i];
        vis_qviewer *v = &q->viewers[s];
        uint8_t flags = q->viewer_flags[i];
        if (flags & FLAG_TRACED) {
            merge_faces(q, s, pixels);
            ++q->chunk_passes;
            q->chunk_edit_passes += (flags & FLAG_EDIT) != 0;
        }
        /* The faces left are owed, with their most urgent reason, until a later call traces
         * them; a round's camera is where chunk_move and the cadence's skip measure from. */
        if (v->chunk_faces == faces_of(&q->in_viewers[i]))
            memcpy(v->face_owed, q->face_due + (size_t)i * 6, 6);
        if (flags & FLAG_ROUND) {
            memcpy(v->chunk_eye, q->in_viewers[i].eye, sizeof v->chunk_eye);
            memcpy(v->chunk_dir, q->in_viewers[i].dir, sizeof v->chunk_dir);
            v->chunk_fov = q->in_viewers[i].fov_deg;
        }
    }
    return VIS_OK;
}
