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
    if (q->regenerated && vis_query_edit_reaches(q, s)) {
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

/* ---- the pass budget ------------------------------------------------------------------ */

/* Why a viewer is due, most urgent first: it has no list yet, an edit reached its last pass,
 * or its cadence or motion came (vis_qviewer.chunk_owed stores one of these plus one). */
enum { DUE_NEW, DUE_EDIT, DUE_ROUTINE };

/* Orders this tick's due viewers (input indices in q->due_viewers, their reasons in
 * q->due_by_input) and keeps the first
 * chunk_pass_budget: by reason, then the oldest list first, then input order -- nothing that
 * depends on threads or timing. Returns how many stay. */
_Static_assert(VIS_QUERY_MAX_VIEWERS <= 0x2000u, "an input index takes the key's low 13 bits");

static uint32_t apply_pass_budget(vis_query *q, uint32_t n)
{
    uint32_t budget = q->desc.chunk_pass_budget;
    if (budget == 0 || n <= budget)
        return n;
    uint64_t *key = q->keys; /* free until the entity jobs run */
    for (uint32_t k = 0; k < n; ++k) {
        uint32_t i = q->due_viewers[k];
        uint64_t age = q->viewers[q->vslot[i]].chunk_tick;
        age = age > 0xFFFFFFFFFFull ? 0xFFFFFFFFFFull : age; /* 40 bits of ticks */
        key[k] = (uint64_t)q->due_by_input[i] << 62 | age << 13 | i;
    }
    vis_sort_u64(key, n);
    for (uint32_t k = 0; k < n; ++k)
        q->due_viewers[k] = (uint32_t)(key[k] & 0x1FFFu);
    return budget;
}

/* The due viewers the budget left (sorted positions ntrace..ndue) stay due, with their most
 * urgent reason, until a later tick traces them. Only called once the tick's passes are
 * traced: a failed tick changes nothing. */
static void owe_deferred(vis_query *q, uint32_t ntrace, uint32_t ndue)
{
    for (uint32_t k = ntrace; k < ndue; ++k) {
        uint32_t i = q->due_viewers[k];
        q->viewers[q->vslot[i]].chunk_owed = (uint8_t)(q->due_by_input[i] + 1u);
    }
    q->chunk_deferred = ndue - ntrace;
}

vis_status vis_query_chunks_run(vis_query *q)
{
    uint32_t ndue = 0, ncam = 0, edited_passes = 0;
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        const vis_query_viewer *in = &q->in_viewers[i];
        uint32_t s = q->vslot[i];
        const vis_qviewer *v = &q->viewers[s];
        int edited = 0;
        int now = due(q, s, in, &edited);
        if (!now && !v->chunk_owed)
            continue;
        uint8_t r = v->chunk_tick == 0 ? DUE_NEW : edited ? DUE_EDIT : DUE_ROUTINE;
        if (v->chunk_owed && v->chunk_owed - 1u < r)
            r = (uint8_t)(v->chunk_owed - 1u);
        q->due_by_input[i] = r; /* by input index: the reason follows the viewer through the sort */
        q->due_viewers[ndue++] = i;
    }
    uint32_t ntrace = apply_pass_budget(q, ndue);
    for (uint32_t k = 0; k < ntrace; ++k) {
        uint32_t i = q->due_viewers[k];
        const vis_query_viewer *in = &q->in_viewers[i];
        uint32_t s = q->vslot[i];
        edited_passes += q->due_by_input[i] == DUE_EDIT;
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
    q->chunk_deferred = 0;
    if (ncam == 0) {
        owe_deferred(q, ntrace, ndue);
        return VIS_OK;
    }
    vis_trace_desc d;
    vis_trace_desc_defaults(&d);
    d.width = d.height = q->desc.chunk_res;
    /* The query's default is the backend's: on the CPU, 4x4 packets at 32^2 per 90-degree face
     * (a tile spreads 0.25 tangent units, within cpu/packet.c's limit for 4x4), which executed
     * 24-70 % fewer instructions than the stack walk on the chunk passes of gen:city,
     * gen:default and gen:maze; finer faces take larger packets, coarser ones lone rays.
     * OpenCL batches run the stack method. Every method names the same IDs (docs/server.md,
     * "Chunk passes in 4x4 packets"). */
    d.traversal = q->desc.chunk_traversal;
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
        v->chunk_owed = 0;
    }
    owe_deferred(q, ntrace, ndue);
    return VIS_OK;
}
