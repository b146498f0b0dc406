/* query.c — headless server queries: per tick and per viewer, the visible chunk objects
 * (query_chunks.c) and the visible entities, conservative under latency (occlusion.c).
 *
 * What servers do today, and what this file does instead (docs/server.md):
 *  - SMAC (Source): up to 10 traces per pair (centre, weapon tip, corners at 1.3x and
 *    0.65x), positions extrapolated by velocity x latency, 0.75 s reveal hold, 1,280 traces a
 *    tick. CS2's S2FOW: 39 points per target, 96 rays per player, caches of 2-28 ticks.
 *    CornerCulling: 4 peek points x 8 box corners. All sample points, so a sliver seen
 *    between samples is hidden; here a pair is hidden only when occlusion.c proves every
 *    segment from the eye region (every eye the viewer can reach within its latency: a
 *    peek) to the swept box (every place the entity can be within it) blocked.
 *  - A ray budget shared over the viewers that have pairs to prove (water-filling, made
 *    serially, so deterministic), spent by priority within each (in view, then near); pairs
 *    it cannot prove are reported (VIS_QUERY_UNCHECKED), never hidden.
 *  - A reveal hold in ticks, and per-pair caching: a pair's last proof is kept with the
 *    regions it covers and reused while the scene is unchanged and this tick's eye region
 *    and swept box lie inside them; a new or hidden pair is proven for regions grown about
 *    proof_slack voxels ahead along the velocities (1/2 to 3/2 of it, drawn per pair and
 *    tick, so that proofs made together end apart), so that one proof lasts while players
 *    walk on.
 *  - Every buffer is sized at creation: a tick allocates nothing. Viewers are independent
 *    jobs (each writes only its own row of results), so any thread count gives the same
 *    output. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "camera.h"
#include "query.h"
#include "query_sort.h"

#define QUERY_DEFAULT_VIEWERS 64u
#define QUERY_DEFAULT_ENTITIES 256u
#define QUERY_DEFAULT_CHUNK_RES 32u
#define QUERY_DEFAULT_PAIR_RAYS 16u
#define QUERY_MAX_PAIR_RAYS 4096u
#define QUERY_MAX_UNSETTLED_TICKS 1024u
#define QUERY_MAX_COORD 1e9      /* world coordinates beyond this are rejected             */
#define QUERY_MAX_BOX 1e5        /* an entity box larger than this (voxels) is rejected     */
#define QUERY_MAX_BYTES ((uint64_t)1 << 31)
#define QUERY_DEFAULT_SLACK 0.5  /* voxels: about 15 ticks of a walk at 128 ticks/s          */
/* Slack, in voxels and relative, added to changed boxes against rounding (edit_touches_pair). */
#define PAIR_EDIT_SLACK_ABS 1e-3
#define PAIR_EDIT_SLACK_REL 1e-5

#define PAIR_NONE 0u      /* nothing cached: prove it, the grown regions first                  */
#define PAIR_SEEN 1u
#define PAIR_HIDDEN 2u
#define PAIR_UNSETTLED 3u /* the proof ran out of its pair limit: reported until pair_retry  */
#define PAIR_FAILED 4u    /* the proof ran out of its pair limit: reported, proven next tick  */

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* ---- ID maps ------------------------------------------------------------------------------ */

uint32_t vis_idmap_find(const vis_idmap *m, uint32_t key)
{
    for (uint32_t i = vis_hash_u32(key) & m->mask;; i = (i + 1) & m->mask) {
        if (m->keys[i] == key)
            return m->vals[i];
        if (m->keys[i] == 0)
            return UINT32_MAX;
    }
}

int vis_idmap_insert(vis_idmap *m, uint32_t key, uint32_t val)
{
    for (uint32_t i = vis_hash_u32(key) & m->mask;; i = (i + 1) & m->mask) {
        if (m->keys[i] == key)
            return 0;
        if (m->keys[i] == 0) {
            m->keys[i] = key;
            m->vals[i] = val;
            return 1;
        }
    }
}

void vis_idmap_clear(vis_idmap *m)
{
    memset(m->keys, 0, ((size_t)m->mask + 1) * sizeof *m->keys);
}

static uint32_t map_size(uint64_t entries)
{
    uint32_t n = 16;
    while (n < 2 * entries)
        n <<= 1;
    return n;
}

/* ---- create / destroy ----------------------------------------------------------------------- */

void vis_query_desc_defaults(vis_query_desc *d)
{
    if (!d)
        return;
    memset(d, 0, sizeof *d);
    d->max_viewers = QUERY_DEFAULT_VIEWERS;
    d->max_entities = QUERY_DEFAULT_ENTITIES;
    d->chunk_res = QUERY_DEFAULT_CHUNK_RES;
    d->chunk_every = 1;
    d->pair_ray_limit = QUERY_DEFAULT_PAIR_RAYS;
    d->proof_slack = QUERY_DEFAULT_SLACK;
    d->unsettled_ticks = 1;
}

static vis_status resolve_desc(vis_context *ctx, const vis_query_desc *in, vis_query_desc *d)
{
    vis_query_desc_defaults(d);
    if (!in)
        return VIS_OK;
    *d = *in;
    if (!d->max_viewers)
        d->max_viewers = QUERY_DEFAULT_VIEWERS;
    if (!d->max_entities)
        d->max_entities = QUERY_DEFAULT_ENTITIES;
    if (!d->chunk_res)
        d->chunk_res = QUERY_DEFAULT_CHUNK_RES;
    if (!d->chunk_every)
        d->chunk_every = 1;
    if (!d->pair_ray_limit)
        d->pair_ray_limit = QUERY_DEFAULT_PAIR_RAYS;
    if (!d->unsettled_ticks)
        d->unsettled_ticks = 1;
    if (d->proof_slack == 0.0)
        d->proof_slack = QUERY_DEFAULT_SLACK;
    else if (d->proof_slack < 0.0)
        d->proof_slack = 0.0; /* none (NaN and +inf are refused below)                       */
    if (d->max_viewers > VIS_QUERY_MAX_VIEWERS || d->max_entities > VIS_QUERY_MAX_ENTITIES ||
        d->chunk_res > VIS_QUERY_MAX_CHUNK_RES || d->pair_ray_limit > QUERY_MAX_PAIR_RAYS ||
        d->unsettled_ticks > QUERY_MAX_UNSETTLED_TICKS)
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "vis_query_create: max_viewers %u (at most %u), max_entities %u (at most %u), chunk_res %u "
                        "(at most %u), pair_ray_limit %u (at most %u), unsettled_ticks %u (at most %u)",
                        d->max_viewers, VIS_QUERY_MAX_VIEWERS, d->max_entities, VIS_QUERY_MAX_ENTITIES, d->chunk_res,
                        VIS_QUERY_MAX_CHUNK_RES, d->pair_ray_limit, QUERY_MAX_PAIR_RAYS, d->unsettled_ticks,
                        QUERY_MAX_UNSETTLED_TICKS);
    if (!isfinite(d->margin) || d->margin < 0.0 || d->margin > QUERY_MAX_BOX || !isfinite(d->peek_speed) ||
        d->peek_speed < 0.0 || d->peek_speed > VIS_QUERY_MAX_SPEED || !isfinite(d->proof_slack) ||
        d->proof_slack > QUERY_MAX_BOX || !isfinite(d->chunk_move) || d->chunk_move < 0.0 ||
        d->chunk_move > QUERY_MAX_BOX || !isfinite(d->chunk_range) ||
        !(d->chunk_range == 0.0 || (d->chunk_range >= 1.0 && d->chunk_range <= QUERY_MAX_COORD)))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT,
                        "vis_query_create: margin %g must be in [0, %g], peek_speed %g in [0, %g], proof_slack %g "
                        "at most %g, chunk_move %g in [0, %g], chunk_range %g 0 or in [1, %g]",
                        d->margin, QUERY_MAX_BOX, d->peek_speed, VIS_QUERY_MAX_SPEED, d->proof_slack, QUERY_MAX_BOX,
                        d->chunk_move, QUERY_MAX_BOX, d->chunk_range, QUERY_MAX_COORD);
    if (!vis_traversal_known(d->chunk_traversal))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_query_create: chunk_traversal %d is not a vis_traversal",
                        (int)d->chunk_traversal);
    return VIS_OK;
}

/* Every array of a query, with its size: planned (and bounded) before anything is taken. */
typedef struct query_plan {
    void **ptr;
    uint64_t bytes;
    int unzeroed; /* written before it is read: left as the allocator gives it, so that the
                     pages of capacity a server never uses are never touched */
} query_plan;

static void query_free(vis_query *q)
{
    vis_context *ctx = q->ctx;
    void *arrays[] = {q->viewers, q->entities, q->viewer_map.keys, q->viewer_map.vals, q->entity_map.keys,
                      q->entity_map.vals, q->check_map.keys, q->check_map.vals, q->vslot, q->eslot,
                      q->pair_state, q->pair_eye, q->pair_box, q->pair_seen, q->pair_retry, q->eye_now, q->box_now,
                      q->keys, q->share_order, q->hits, q->results, q->chunks, q->face_ids, q->cameras, q->ids,
                      q->chunk_set.keys, q->chunk_set.vals, q->chunk_setup, q->chunk_depth, q->depth, q->setups,
                      q->face_due, q->face_keys, q->viewer_flags};
    for (size_t i = 0; i < sizeof arrays / sizeof arrays[0]; ++i)
        if (arrays[i])
            vis_free(ctx, arrays[i]);
    if (q->pool)
        vis_pool_destroy(q->pool);
    vis_free(ctx, q);
}

static vis_status query_create(vis_context *ctx, vis_scene *scene, const vis_query_desc *desc, vis_query **out)
{
    vis_query_desc d;
    vis_status st = resolve_desc(ctx, desc, &d);
    if (st != VIS_OK)
        return st;
    vis_query *q = vis_calloc(ctx, 1, sizeof *q);
    if (!q)
        return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_query_create: out of memory");
    q->ctx = ctx;
    q->scene = scene;
    q->desc = d;
    uint64_t V = d.max_viewers, E = d.max_entities, res2 = (uint64_t)d.chunk_res * d.chunk_res;
    q->chunk_cap = (uint32_t)(6 * res2);
    uint32_t vm = map_size(V), em = map_size(E), cm = map_size(V > E ? V : E), sm = map_size(6 * res2);
    q->viewer_map.mask = vm - 1;
    q->entity_map.mask = em - 1;
    q->check_map.mask = cm - 1;
    q->chunk_set.mask = sm - 1;
    query_plan plan[] = {
        {(void **)&q->viewers, V * sizeof(vis_qviewer), 0},
        {(void **)&q->entities, E * sizeof(vis_qentity), 0},
        {(void **)&q->viewer_map.keys, vm * 4ull, 0},
        {(void **)&q->viewer_map.vals, vm * 4ull, 0},
        {(void **)&q->entity_map.keys, em * 4ull, 0},
        {(void **)&q->entity_map.vals, em * 4ull, 0},
        {(void **)&q->check_map.keys, cm * 4ull, 0},
        {(void **)&q->check_map.vals, cm * 4ull, 0},
        {(void **)&q->vslot, V * 4, 0},
        {(void **)&q->eslot, E * 4, 0},
        {(void **)&q->pair_state, V * E, 0},
        {(void **)&q->pair_eye, V * E * sizeof(vis_occ_box), 0},
        {(void **)&q->pair_box, V * E * sizeof(vis_occ_box), 0},
        {(void **)&q->pair_seen, V * E * 4, 0},
        {(void **)&q->pair_retry, V * E * 4, 0},
        {(void **)&q->eye_now, V * sizeof(vis_occ_box), 0},
        {(void **)&q->box_now, V * E * sizeof(vis_occ_box), 0},
        {(void **)&q->keys, V * E * 8, 0},
        {(void **)&q->share_order, V * 8, 0},
        {(void **)&q->hits, V * E * sizeof(vis_query_hit), 0},
        {(void **)&q->results, V * sizeof(vis_qresult), 0},
        {(void **)&q->chunks, V * 6 * res2 * 4, 1},
        {(void **)&q->cameras, V * 6 * sizeof(vis_camera), 0},
        {(void **)&q->face_ids, V * 6 * res2 * 4, 1},
        {(void **)&q->ids, V * 6 * res2 * 4, 1},
        {(void **)&q->chunk_set.keys, sm * 4ull, 0},
        {(void **)&q->chunk_set.vals, sm * 4ull, 0},
        {(void **)&q->chunk_setup, V * 6 * sizeof(vis_ray_setup), 0},
        {(void **)&q->chunk_depth, V * 6 * res2 * 4, 1},
        {(void **)&q->depth, V * 6 * res2 * 4, 1},
        {(void **)&q->setups, V * 6 * sizeof(vis_ray_setup), 0},
        {(void **)&q->face_due, V * 6, 0},
        {(void **)&q->face_keys, V * 6 * 8, 0},
        {(void **)&q->viewer_flags, V, 0},
    };
    uint64_t total = 0;
    for (size_t i = 0; i < sizeof plan / sizeof plan[0]; ++i)
        total += plan[i].bytes;
    if (total > QUERY_MAX_BYTES || total != (size_t)total) {
        query_free(q);
        return vis_fail(ctx, VIS_ERROR_BUDGET, "vis_query_create: %llu bytes for these capacities, at most %llu",
                        (unsigned long long)total, (unsigned long long)QUERY_MAX_BYTES);
    }
    for (size_t i = 0; i < sizeof plan / sizeof plan[0]; ++i) {
        size_t bytes = (size_t)plan[i].bytes;
        *plan[i].ptr = plan[i].unzeroed ? vis_alloc(ctx, bytes) : vis_calloc(ctx, 1, bytes);
        if (!*plan[i].ptr) {
            query_free(q);
            return vis_fail(ctx, VIS_ERROR_OUT_OF_MEMORY, "vis_query_create: out of memory (%llu bytes)",
                            (unsigned long long)total);
        }
    }
    /* Threads: the context's job system, the CPU backend's threads when the count is theirs
     * (one set of workers: a second pool's threads would compete with the first's for the
     * cores: docs/server.md, "One pool run per batch, one set of threads"), or the query's
     * own pool. */
    uint32_t threads = d.threads;
    if (threads == 0 && ctx->desc.parallel_for) {
        q->parallel_for = ctx->desc.parallel_for;
        q->parallel_for_user = ctx->desc.parallel_for_user;
    } else {
        if (threads == 0)
            threads = ctx->info.threads ? ctx->info.threads : 1u;
        if (threads > 1 && ctx->info.kind == VIS_BACKEND_CPU && threads == ctx->info.threads)
            q->cpu_threads = 1;
        else if (threads > 1 && vis_pool_create(threads, &ctx->alloc, &q->pool) != VIS_OK) {
            query_free(q);
            return vis_fail(ctx, VIS_ERROR_BACKEND, "vis_query_create: could not start %u threads", threads);
        }
    }
    if ((st = vis_query_chunks_warm(q)) != VIS_OK) {
        query_free(q);
        return st;
    }
    *out = q;
    return VIS_OK;
}

vis_status vis_query_create(vis_context *ctx, vis_scene *scene, const vis_query_desc *desc, vis_query **out)
{
    if (!ctx)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(ctx);
    vis_status st;
    if (!scene || !out)
        st = vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_query_create: scene and out_query must not be NULL");
    else
        st = query_create(ctx, scene, desc, out);
    vis_leave(ctx);
    return st;
}

void vis_query_destroy(vis_query *q)
{
    if (q)
        query_free(q);
}

/* ---- validation ------------------------------------------------------------------------------ */

static int finite3(const double v[3], double bound)
{
    for (int i = 0; i < 3; ++i)
        if (!isfinite(v[i]) || fabs(v[i]) > bound)
            return 0;
    return 1;
}

/* Does an in-view viewer's pass have a view direction? Its camera looks from eye to eye + dir
 * (query_chunks.c), which the camera refuses when the two are the same point in double (or
 * so close that the distance's square underflows). All around (dir 0) needs none. */
static int dir_moves_eye(const vis_query_viewer *v)
{
    if (vis_query_all_around(v))
        return 1;
    double n2 = 0.0;
    for (int k = 0; k < 3; ++k) {
        double d = (v->eye[k] + v->dir[k]) - v->eye[k];
        n2 += d * d;
    }
    return n2 > 0.0;
}

static int speed_ok(const double v[3])
{
    return finite3(v, VIS_QUERY_MAX_SPEED) && v[0] * v[0] + v[1] * v[1] + v[2] * v[2] <=
                                                 VIS_QUERY_MAX_SPEED * VIS_QUERY_MAX_SPEED;
}

static vis_status check_inputs(vis_query *q, const vis_query_viewer *vw, uint32_t nv, const vis_query_entity *en,
                               uint32_t ne)
{
    vis_context *ctx = q->ctx;
    if ((nv && !vw) || (ne && !en))
        return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_query_run: viewers or entities is NULL with a count");
    if (nv > q->desc.max_viewers || ne > q->desc.max_entities)
        return vis_fail(ctx, VIS_ERROR_CAPACITY, "vis_query_run: %u viewers and %u entities; the query holds %u and %u",
                        nv, ne, q->desc.max_viewers, q->desc.max_entities);
    vis_idmap_clear(&q->check_map);
    for (uint32_t i = 0; i < nv; ++i) {
        const vis_query_viewer *v = &vw[i];
        const char *bad = NULL;
        if (v->id == 0 || v->id > VIS_MAX_OBJECT_ID)
            bad = "id is not in 1..VIS_MAX_OBJECT_ID";
        else if (!vis_idmap_insert(&q->check_map, v->id, i))
            bad = "id appears twice";
        else if (!finite3(v->eye, QUERY_MAX_COORD))
            bad = "eye is not finite or too far";
        else if (!finite3(v->dir, QUERY_MAX_COORD))
            bad = "dir is not finite";
        else if (!dir_moves_eye(v))
            bad = "dir is too short to give a view direction (eye + dir is eye, or too close to it)";
        else if (!vis_query_all_around(v) && !(v->fov_deg >= VIS_QUERY_MIN_FOV && v->fov_deg <= VIS_QUERY_MAX_FOV))
            bad = "fov_deg is not in [VIS_QUERY_MIN_FOV, VIS_QUERY_MAX_FOV] (0.001 to 170 degrees)";
        else if (!speed_ok(v->velocity))
            bad = "velocity is not finite or faster than VIS_QUERY_MAX_SPEED";
        else if (!(v->latency_ms >= 0.0 && v->latency_ms <= VIS_QUERY_MAX_LATENCY_MS))
            bad = "latency_ms is not in [0, VIS_QUERY_MAX_LATENCY_MS]";
        if (bad)
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_query_run: viewer %u (id %u): %s", i, v->id, bad);
    }
    vis_idmap_clear(&q->check_map);
    for (uint32_t i = 0; i < ne; ++i) {
        const vis_query_entity *e = &en[i];
        const char *bad = NULL;
        if (e->id == 0 || e->id > VIS_MAX_OBJECT_ID)
            bad = "id is not in 1..VIS_MAX_OBJECT_ID";
        else if (!vis_idmap_insert(&q->check_map, e->id, i))
            bad = "id appears twice";
        else if (!finite3(e->box_min, QUERY_MAX_COORD) || !finite3(e->box_max, QUERY_MAX_COORD))
            bad = "box is not finite or too far";
        else if (!(e->box_min[0] < e->box_max[0] && e->box_min[1] < e->box_max[1] && e->box_min[2] < e->box_max[2]))
            bad = "box is empty (box_min must be below box_max on every axis)";
        else if (!(e->box_max[0] - e->box_min[0] <= QUERY_MAX_BOX && e->box_max[1] - e->box_min[1] <= QUERY_MAX_BOX &&
                   e->box_max[2] - e->box_min[2] <= QUERY_MAX_BOX))
            bad = "box is larger than 1e5 voxels";
        else if (!speed_ok(e->velocity))
            bad = "velocity is not finite or faster than VIS_QUERY_MAX_SPEED";
        if (bad)
            return vis_fail(ctx, VIS_ERROR_INVALID_ARGUMENT, "vis_query_run: entity %u (id %u): %s", i, e->id, bad);
    }
    return VIS_OK;
}

/* ---- regions --------------------------------------------------------------------------------- */

/* Eye region: eye and eye + velocity * latency, grown by peek_speed * latency + margin, in
 * scene-local coordinates. */
static void eye_region(const vis_query *q, const vis_query_viewer *v, vis_occ_box *b)
{
    double L = v->latency_ms * 1e-3, grow = q->desc.peek_speed * L + q->desc.margin;
    for (int i = 0; i < 3; ++i) {
        double a = v->eye[i] - q->scene->desc.origin[i], c = a + v->velocity[i] * L;
        b->lo[i] = (a < c ? a : c) - grow;
        b->hi[i] = (a < c ? c : a) + grow;
    }
}

/* Swept box: the box and the box moved by velocity * latency (the viewer's latency: what it
 * will see when the data arrives), grown by margin. */
static void swept_box(const vis_query *q, const vis_query_entity *e, double latency_ms, vis_occ_box *b)
{
    double L = latency_ms * 1e-3, m = q->desc.margin;
    for (int i = 0; i < 3; ++i) {
        double o = q->scene->desc.origin[i], dv = e->velocity[i] * L;
        double lo = e->box_min[i] - o, hi = e->box_max[i] - o;
        b->lo[i] = (dv < 0.0 ? lo + dv : lo) - m;
        b->hi[i] = (dv > 0.0 ? hi + dv : hi) + m;
    }
}

/* ---- slots -------------------------------------------------------------------------------- */

/* Matches this tick's IDs to last tick's slots; frees the slots of IDs that are gone and
 * gives new IDs free slots, with their pair state cleared. */
static void assign_slots(vis_query *q)
{
    const vis_query_desc *d = &q->desc;
    /* Viewers. */
    vis_idmap_clear(&q->check_map);
    for (uint32_t i = 0; i < q->viewer_count; ++i)
        vis_idmap_insert(&q->check_map, q->in_viewers[i].id, i);
    for (uint32_t s = 0; s < d->max_viewers; ++s)
        if (q->viewers[s].id && vis_idmap_find(&q->check_map, q->viewers[s].id) == UINT32_MAX)
            q->viewers[s].id = 0;
    uint32_t next = 0;
    for (uint32_t i = 0; i < q->viewer_count; ++i) {
        uint32_t s = vis_idmap_find(&q->viewer_map, q->in_viewers[i].id);
        if (s == UINT32_MAX || q->viewers[s].id != q->in_viewers[i].id) {
            while (q->viewers[next].id)
                ++next;
            s = next;
            memset(&q->viewers[s], 0, sizeof q->viewers[s]);
            q->viewers[s].id = q->in_viewers[i].id;
            memset(q->pair_state + (size_t)s * d->max_entities, 0, d->max_entities);
            memset(q->pair_seen + (size_t)s * d->max_entities, 0, (size_t)d->max_entities * 4);
        }
        q->vslot[i] = s;
    }
    vis_idmap_clear(&q->viewer_map);
    for (uint32_t s = 0; s < d->max_viewers; ++s)
        if (q->viewers[s].id)
            vis_idmap_insert(&q->viewer_map, q->viewers[s].id, s);
    /* Entities. */
    vis_idmap_clear(&q->check_map);
    for (uint32_t i = 0; i < q->entity_count; ++i)
        vis_idmap_insert(&q->check_map, q->in_entities[i].id, i);
    for (uint32_t s = 0; s < d->max_entities; ++s)
        if (q->entities[s].id && vis_idmap_find(&q->check_map, q->entities[s].id) == UINT32_MAX)
            q->entities[s].id = 0;
    next = 0;
    for (uint32_t i = 0; i < q->entity_count; ++i) {
        uint32_t s = vis_idmap_find(&q->entity_map, q->in_entities[i].id);
        if (s == UINT32_MAX || q->entities[s].id != q->in_entities[i].id) {
            while (q->entities[next].id)
                ++next;
            s = next;
            memset(&q->entities[s], 0, sizeof q->entities[s]);
            q->entities[s].id = q->in_entities[i].id;
            for (uint32_t v = 0; v < d->max_viewers; ++v) {
                q->pair_state[(size_t)v * d->max_entities + s] = PAIR_NONE;
                q->pair_seen[(size_t)v * d->max_entities + s] = 0;
            }
        }
        q->eslot[i] = s;
    }
    vis_idmap_clear(&q->entity_map);
    for (uint32_t s = 0; s < d->max_entities; ++s)
        if (q->entities[s].id)
            vis_idmap_insert(&q->entity_map, q->entities[s].id, s);
}

/* ---- one viewer's job ----------------------------------------------------------------------- */

/* Priority key: in view first, then nearer first, then input order (ties stay
 * deterministic). The distance's float bits order like the distance. */
static uint64_t priority_key(const vis_query_viewer *v, const vis_occ_box *eye, const vis_occ_box *box, uint32_t index)
{
    double c[3], dd = 0.0, dot = 0.0, dl = 0.0;
    for (int i = 0; i < 3; ++i) {
        double ec = 0.5 * (eye->lo[i] + eye->hi[i]);
        c[i] = 0.5 * (box->lo[i] + box->hi[i]) - ec;
        dd += c[i] * c[i];
        dot += c[i] * v->dir[i];
        dl += v->dir[i] * v->dir[i];
    }
    double dist = sqrt(dd);
    int in_view = 1;
    if (dl > 0.0 && dist > 0.0) {
        /* The square pass's corners reach sqrt(2) x tan(fov/2) off axis. */
        double half = atan(sqrt(2.0) * tan(v->fov_deg * 0.5 * 3.14159265358979323846 / 180.0));
        in_view = dot / (dist * sqrt(dl)) >= cos(half);
    }
    float df = (float)dist;
    uint32_t bits;
    memcpy(&bits, &df, sizeof bits);
    return ((uint64_t)(in_view ? 0u : 1u) << 63) | ((uint64_t)(bits & 0x7FFFFFFFu) << 32) | index;
}

static int point_in(const double x[3], const vis_occ_box *b)
{
    for (int k = 0; k < 3; ++k)
        if (!(x[k] >= b->lo[k] && x[k] <= b->hi[k]))
            return 0;
    return 1;
}

static int box_in(const vis_occ_box *a, const vis_occ_box *b)
{
    for (int k = 0; k < 3; ++k)
        if (!(a->lo[k] >= b->lo[k] && a->hi[k] <= b->hi[k]))
            return 0;
    return 1;
}

/* Does pair p's cached result still answer for this tick's eye region and swept box? A
 * proof over larger regions holds for any regions inside them (every segment between the
 * smaller is one between the larger); an unblocked segment stays a witness while its ends
 * stay inside. An unsettled pair is reported whatever the answer would be, so keeping it
 * hides nothing; it waits for its retry tick, and for its regions to leave those it failed
 * on (a turn, a jump: new geometry, worth a new proof). Edits are checked by the caller. */
static int cache_holds(const vis_query *q, size_t p, const vis_occ_box *eye, const vis_occ_box *box)
{
    switch (q->pair_state[p]) {
    case PAIR_SEEN:
        return point_in(q->pair_eye[p].lo, eye) && point_in(q->pair_box[p].lo, box);
    case PAIR_HIDDEN:
        return box_in(eye, &q->pair_eye[p]) && box_in(box, &q->pair_box[p]);
    case PAIR_UNSETTLED:
        return (int32_t)(q->pair_retry[p] - (uint32_t)q->tick) > 0 && box_in(eye, &q->pair_eye[p]) &&
               box_in(box, &q->pair_box[p]);
    default:
        return 0;
    }
}

/* Can this tick's changed boxes (an edit since the last tick) change pair p's cached proof?
 * A HIDDEN proof holds because every segment from a point a of its eye region to a point b
 * of its box region is blocked where it crosses a plane: by a quad holding the crossing
 * point, or (solid ground, occlusion.c) by solid cells within one voxel of it. A SEEN proof
 * keeps one unblocked segment, its two ends. Either rests only on primitives at points of
 * those segments (within a voxel of them for solid ground), though vis_occ_test may read
 * more (a plane's whole crossing rectangle). A point a + t (b - a) is the regions' centres'
 * point at t plus at most (1 - t) h_eye + t h_box <= max(h_eye, h_box) on each axis (h:
 * half-sides), so every segment lies in the centres' segment swept by a box of half-sides
 * max(h_eye, h_box): a thin tube where the regions are small and far apart, where their
 * bounding box would be large. A change that stays outside the tube (grown by the voxel for
 * solid ground) removes no quad or cell a HIDDEN proof rests on and adds none on a SEEN
 * witness: the proof still answers. The changed boxes are grown by far more than double
 * rounding, as in query_edits.c, so the test errs only toward proving again. */
static int edit_touches_pair(const vis_query *q, size_t p)
{
    if (q->change_count == UINT32_MAX)
        return 1; /* the log did not reach back: anything may have changed */
    const vis_occ_box *e = &q->pair_eye[p], *b = &q->pair_box[p];
    const int seen = q->pair_state[p] == PAIR_SEEN; /* a witness: only .lo holds its ends */
    double from[3], dir[3], half[3], m = 0.0;
    for (int k = 0; k < 3; ++k) {
        double he = seen ? 0.0 : 0.5 * (e->hi[k] - e->lo[k]), hb = seen ? 0.0 : 0.5 * (b->hi[k] - b->lo[k]);
        from[k] = e->lo[k] + he;
        dir[k] = b->lo[k] + hb - from[k];
        half[k] = fmax(he, hb);
        m = fmax(m, fmax(fabs(e->lo[k]), fabs(b->lo[k])) + 2.0 * half[k]);
    }
    /* A solid-ground proof (occlusion.c) also rests on the cells within one voxel of its
     * planes' rectangles, which may reach that far past the segments. */
    const double reach = q->desc.solid ? 1.0 : 0.0;
    for (uint32_t c = 0; c < q->change_count; ++c) {
        const vis_scene_edit_box *ch = &q->changes[c];
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            double mk = fmax(m, fmax(fabs((double)ch->lo[k]), fabs((double)ch->hi[k])));
            double grow = half[k] + reach + PAIR_EDIT_SLACK_ABS + PAIR_EDIT_SLACK_REL * mk;
            lo[k] = (double)ch->lo[k] - grow;
            hi[k] = (double)ch->hi[k] + grow;
        }
        if (vis_segment_meets_box(from, dir, lo, hi, 0.0, 1.0))
            return 1;
    }
    return 0;
}

static double length3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

/* The region reached ahead along the velocity: the hull of b and b moved by `reach` voxels
 * in the velocity's direction (b itself when still). While the motion keeps its direction,
 * the next ticks' regions stay inside for reach / speed seconds. */
static void grow_ahead(double reach, const vis_occ_box *b, const double vel[3], vis_occ_box *out)
{
    *out = *b;
    double len = length3(vel);
    if (!(len > 0.0) || reach == 0.0)
        return;
    for (int k = 0; k < 3; ++k) {
        double dv = vel[k] / len * reach;
        if (dv < 0.0)
            out->lo[k] += dv;
        else
            out->hi[k] += dv;
    }
}

/* How far pair p's proof on this tick reaches ahead: proof_slack times 1/2 to 3/2 in 16
 * steps, drawn from the pair and the tick. Players who start, or turn, together would
 * otherwise all leave their proofs on one later tick and prove every pair again on it (the
 * 32-player replays spent 2,600-2,700 rays on the 16th tick against about 400 on the
 * others). A hash, not a generator: the same on any thread count. */
static double proof_reach(const vis_query *q, size_t p)
{
    uint64_t h = (uint64_t)p * 0x9E3779B97F4A7C15ull ^ (uint64_t)q->tick * 0xBF58476D1CE4E5B9ull;
    h ^= h >> 31;
    h *= 0x94D049BB133111EBull;
    h ^= h >> 29;
    return q->desc.proof_slack * (0.5 + (double)(h & 15u) / 15.0);
}

/* Does a pair in this state try the regions grown ahead first? A pair whose last proof was
 * HIDDEN has moved out of it, and a new pair has no proof: both are likely hidden, and a
 * proof of the grown regions lasts many ticks where one of the exact regions lasts until the
 * next tick's move (a first tick of 32 players proved every pair twice, on that tick and
 * the next). A pair seen, or whose last proof failed, tries the exact regions only. A pair
 * the call budget did not reach starts again as new, whatever it was: with a budget of 512
 * rays on the 32-player replays that left 1-4 % fewer pairs unproven than keeping its
 * class (docs/server.md, "Proofs that do not all end together"). */
static int grown_first(uint8_t state) { return state == PAIR_HIDDEN || state == PAIR_NONE; }

/* Can grow_ahead grow a region moving at this velocity? (Its own length test.) */
static int moves(const double vel[3]) { return length3(vel) > 0.0; }

/* Proves pair p within `left` rays and caches the result with the regions it covers;
 * returns the rays spent. Where grown_first says so, the regions grown ahead (grow_ahead)
 * are tried first; when that fails, the exact regions get a pair limit of their own (so such
 * a pair may spend up to twice pair_ray_limit). A proof that uses its whole pair limit
 * without an answer is UNSETTLED: reported, and kept for unsettled_ticks over the grown
 * regions (1: FAILED, proven again next tick). Waiting longer saves the rays of proofs that
 * keep failing, at the price of the few pairs a later tick would have proven hidden
 * (docs/server.md: on gen:default about 1 % of the retries succeed, and each success hides
 * its pair for many ticks). A proof cut short by the ray budget is not kept: the budget, not
 * the proof, ended it. */
static uint32_t prove_pair(vis_query *q, size_t p, const vis_occ_box *eye, const vis_occ_box *box,
                           const double eye_vel[3], const double box_vel[3], uint64_t left, uint64_t *solid_tests)
{
    uint32_t lim = left < q->desc.pair_ray_limit ? (uint32_t)left : q->desc.pair_ray_limit;
    const vis_occ_solid solid = {q->desc.solid, q->desc.solid_user};
    vis_occ_box ge, gb;
    double reach = proof_reach(q, p);
    grow_ahead(reach, eye, eye_vel, &ge);
    grow_ahead(reach, box, box_vel, &gb);
    uint32_t spent = 0;
    double w[6];
    if (grown_first(q->pair_state[p]) && (!box_in(&ge, eye) || !box_in(&gb, box))) {
        vis_occ_result res = vis_occ_test(&q->view, &ge, &gb, lim, &solid, &spent, solid_tests, w);
        if (res == VIS_OCC_HIDDEN) {
            q->pair_state[p] = PAIR_HIDDEN;
            q->pair_eye[p] = ge;
            q->pair_box[p] = gb;
            return spent;
        }
        if (res == VIS_OCC_SEEN && point_in(w, eye) && point_in(w + 3, box)) {
            q->pair_state[p] = PAIR_SEEN;
            memcpy(q->pair_eye[p].lo, w, sizeof q->pair_eye[p].lo);
            memcpy(q->pair_box[p].lo, w + 3, sizeof q->pair_box[p].lo);
            return spent;
        }
    }
    /* The exact regions get a whole pair limit of their own, within what is left. */
    uint32_t lim2 = left - spent < q->desc.pair_ray_limit ? (uint32_t)(left - spent) : q->desc.pair_ray_limit;
    vis_occ_result res =
        lim2 ? vis_occ_test(&q->view, eye, box, lim2, &solid, &spent, solid_tests, w) : VIS_OCC_UNKNOWN;
    if (res == VIS_OCC_SEEN) {
        q->pair_state[p] = PAIR_SEEN;
        memcpy(q->pair_eye[p].lo, w, sizeof q->pair_eye[p].lo);
        memcpy(q->pair_box[p].lo, w + 3, sizeof q->pair_box[p].lo);
    } else if (res == VIS_OCC_HIDDEN) {
        q->pair_state[p] = PAIR_HIDDEN;
        q->pair_eye[p] = *eye;
        q->pair_box[p] = *box;
    } else if (lim2 == q->desc.pair_ray_limit && q->desc.unsettled_ticks > 1) {
        q->pair_state[p] = PAIR_UNSETTLED; /* reported; tried again at pair_retry */
        q->pair_eye[p] = ge;
        q->pair_box[p] = gb;
        q->pair_retry[p] = (uint32_t)q->tick + q->desc.unsettled_ticks;
    } else {
        q->pair_state[p] = PAIR_FAILED; /* reported; tried again next tick */
    }
    return spent;
}

/* What a run of viewer_job does: every step, or one of them for every viewer. */
enum { VIEWER_ALL, VIEWER_ORDER, VIEWER_SPEND, VIEWER_SPEND_ANSWER, VIEWER_ANSWER };

/* A pair's entry in its viewer's row of q->keys: priority_key, and once the row is sorted,
 * two flags in bits that the entity index (below VIS_QUERY_MAX_ENTITIES) never reaches. */
#define KEY_PROVE ((uint64_t)1 << 31) /* not answered by the cache: to be proven this tick  */
#define KEY_TWICE ((uint64_t)1 << 30) /* may spend twice the pair limit (prove_pair)         */
#define KEY_INDEX(k) ((uint32_t)((k) & 0x3FFFFFFFu))

/* Rounds of sharing what the earlier rounds' proofs left of a call budget. */
#define QUERY_SHARE_ROUNDS 4u

/* What share_budget gave: nothing, or shares, or every viewer all its pairs may spend (no
 * later round can have anything to do). */
enum { SHARE_NONE, SHARE_SOME, SHARE_ALL };

/* Pair (viewer i, entity j) of this tick: its index in the pair arrays. */
static size_t pair_of(const vis_query *q, uint32_t i, uint32_t j)
{
    return (size_t)q->vslot[i] * q->desc.max_entities + q->eslot[j];
}

/* The rays viewer_ray_budget lets one viewer spend in a call (UINT64_MAX: no limit). */
static uint64_t viewer_cap(const vis_query *q)
{
    return q->desc.viewer_ray_budget ? q->desc.viewer_ray_budget : UINT64_MAX;
}

/* The most prove_pair may spend on the pair of key k. */
static uint64_t key_rays(const vis_query *q, uint64_t k)
{
    return (uint64_t)q->desc.pair_ray_limit << ((k & KEY_TWICE) ? 1 : 0);
}

/* Viewer i's pairs in priority order, each marked with whether the cache answers it. */
static void viewer_order(vis_query *q, uint32_t i)
{
    const vis_query_desc *d = &q->desc;
    const vis_query_viewer *v = &q->in_viewers[i];
    const vis_occ_box *eye = &q->eye_now[i];
    uint64_t *keys = q->keys + (size_t)i * d->max_entities;
    vis_occ_box *boxes = q->box_now + (size_t)i * d->max_entities; /* this viewer's row */
    vis_qresult *r = &q->results[i];
    memset(r, 0, sizeof *r);
    uint32_t n = 0;
    for (uint32_t j = 0; j < q->entity_count; ++j) {
        swept_box(q, &q->in_entities[j], v->latency_ms, &boxes[j]);
        if (q->in_entities[j].id != v->id)
            keys[n++] = priority_key(v, eye, &boxes[j], j);
    }
    vis_sort_u64(keys, n);
    for (uint32_t k = 0; k < n; ++k) {
        uint32_t j = KEY_INDEX(keys[k]);
        size_t p = pair_of(q, i, j);
        if ((!q->regenerated || !edit_touches_pair(q, p)) && cache_holds(q, p, eye, &boxes[j]))
            continue;
        /* A pair that tries the grown regions, where they differ from the exact ones, may
         * spend a pair limit on each (prove_pair). */
        const int grows = q->desc.proof_slack > 0.0 && (moves(v->velocity) || moves(q->in_entities[j].velocity));
        keys[k] |= KEY_PROVE | (grows && grown_first(q->pair_state[p]) ? KEY_TWICE : 0u);
        r->demand += key_rays(q, keys[k]);
    }
    r->pairs = n;
}

/* Viewer i proves its pairs, from the first it has not reached, while its budget lasts. */
static void viewer_spend(vis_query *q, uint32_t i)
{
    const vis_query_desc *d = &q->desc;
    const vis_query_viewer *v = &q->in_viewers[i];
    const uint64_t *keys = q->keys + (size_t)i * d->max_entities;
    const vis_occ_box *boxes = q->box_now + (size_t)i * d->max_entities;
    vis_qresult *r = &q->results[i];
    for (; r->next < r->pairs && r->budget; ++r->next) {
        if (!(keys[r->next] & KEY_PROVE))
            continue;
        uint32_t j = KEY_INDEX(keys[r->next]);
        size_t p = pair_of(q, i, j);
        uint32_t spent = prove_pair(q, p, &q->eye_now[i], &boxes[j], v->velocity, q->in_entities[j].velocity,
                                    r->budget, &r->solid_tests);
        r->budget -= spent;
        r->rays += spent;
        r->demand -= key_rays(q, keys[r->next]);
    }
}

/* Viewer i's answers: a pair the cache answered, or proven, or (past r->next) left
 * unproven by the budget and so reported. */
static void viewer_answer(vis_query *q, uint32_t i)
{
    const vis_query_desc *d = &q->desc;
    uint64_t *keys = q->keys + (size_t)i * d->max_entities;
    vis_query_hit *hits = q->hits + (size_t)i * d->max_entities;
    vis_qresult *r = &q->results[i];
    uint32_t nh = 0;
    for (uint32_t k = 0; k < r->pairs; ++k) {
        uint32_t j = KEY_INDEX(keys[k]);
        size_t p = pair_of(q, i, j);
        uint32_t reason = 0;
        if (!(keys[k] & KEY_PROVE))
            ++r->cached;
        else if (k >= r->next) /* not reached: reported, and next time proven as a new pair */
            q->pair_state[p] = PAIR_NONE;
        if (q->pair_state[p] == PAIR_SEEN) {
            reason = VIS_QUERY_SEEN;
            q->pair_seen[p] = (uint32_t)q->tick + 1u;
            ++r->seen;
        } else if (q->pair_state[p] != PAIR_HIDDEN) {
            reason = VIS_QUERY_UNCHECKED;
            ++r->unchecked;
        } else {
            ++r->hidden;
            uint32_t seen = q->pair_seen[p];
            if (seen && (uint32_t)q->tick + 1u - seen <= d->hold_ticks) {
                reason = VIS_QUERY_HELD;
                ++r->held;
            }
        }
        if (reason) {
            hits[nh].id = q->in_entities[j].id;
            hits[nh].reason = reason;
            ++nh;
        }
    }
    /* By ID (unique): the pair order's keys are spent, so their array sorts the hits. */
    for (uint32_t k = 0; k < nh; ++k)
        keys[k] = (uint64_t)hits[k].id << 32 | hits[k].reason;
    vis_sort_u64(keys, nh);
    for (uint32_t k = 0; k < nh; ++k) {
        hits[k].id = (uint32_t)(keys[k] >> 32);
        hits[k].reason = (uint32_t)keys[k];
    }
    r->hit_count = nh;
}

/* Shares `left` rays of the call budget over the viewers with pairs not yet reached, by
 * water-filling: a viewer whose pairs may spend at most d rays in all (r->demand, within
 * viewer_ray_budget) is given d where d fits an even part of what the viewers with more
 * leave, and the others an even part each. So viewers with nothing to prove leave their part
 * to the others, and no viewer's proofs starve another's. Made serially from the viewers'
 * marks, so the shares never depend on the threads. */
static int share_budget(vis_query *q, uint32_t nv, uint64_t left)
{
    const uint64_t cap = viewer_cap(q);
    uint64_t *order = q->share_order; /* demand << 32 | viewer (a demand is below 2^29) */
    uint32_t n = 0;
    for (uint32_t i = 0; i < nv; ++i) {
        vis_qresult *r = &q->results[i];
        r->budget = 0;
        uint64_t room = cap - r->rays, demand = r->demand < room ? r->demand : room;
        if (demand)
            order[n++] = demand << 32 | i;
    }
    if (n == 0 || left == 0)
        return SHARE_NONE;
    vis_sort_u64(order, n);
    int full = 1; /* every viewer given all its pairs may spend */
    for (uint32_t k = 0; k < n; ++k) {
        uint64_t demand = order[k] >> 32, even = left / (n - k);
        uint64_t give = demand < even ? demand : even;
        full &= give == demand;
        q->results[(uint32_t)order[k]].budget = give;
        left -= give;
    }
    return full ? SHARE_ALL : SHARE_SOME;
}

static void viewer_job(vis_query *q, uint32_t i)
{
    switch (q->viewer_step) {
    case VIEWER_ORDER:
        viewer_order(q, i);
        break;
    case VIEWER_SPEND:
        viewer_spend(q, i);
        break;
    case VIEWER_SPEND_ANSWER:
        viewer_spend(q, i);
        viewer_answer(q, i);
        break;
    case VIEWER_ANSWER:
        viewer_answer(q, i);
        break;
    default: /* no call budget: each viewer within its own cap */
        viewer_order(q, i);
        q->results[i].budget = viewer_cap(q);
        viewer_spend(q, i);
        viewer_answer(q, i);
        break;
    }
}

static void viewer_item(void *user, uint32_t index)
{
    viewer_job((vis_query *)user, index);
}

static void viewer_item_pf(uint32_t index, void *arg)
{
    viewer_job((vis_query *)arg, index);
}

/* Runs one step of viewer_job for the tick's nv viewers, in parallel where the query can. */
static void run_viewers(vis_query *q, uint32_t nv, int step)
{
    q->viewer_step = step;
    if (q->parallel_for && nv > 1)
        q->parallel_for(nv, viewer_item_pf, q, q->parallel_for_user);
    else if (q->cpu_threads && nv > 1)
        vis_cpu_backend_parallel_for(&q->ctx->backend, nv, viewer_item_pf, q);
    else if (q->pool && nv > 1)
        vis_pool_run(q->pool, nv, viewer_item, q);
    else
        for (uint32_t i = 0; i < nv; ++i)
            viewer_job(q, i);
}

/* The entity pairs of the tick's viewers. With a call budget: every viewer's order first,
 * then rounds of sharing what is left of the budget and spending the shares (what the
 * viewers leave is shared again next round), then the answers, with the last round's
 * proofs where no later round could have anything to do. */
static void run_pairs(vis_query *q, uint32_t nv)
{
    if (q->desc.ray_budget == 0) {
        run_viewers(q, nv, VIEWER_ALL);
        return;
    }
    run_viewers(q, nv, VIEWER_ORDER);
    for (uint32_t round = 0; round < QUERY_SHARE_ROUNDS; ++round) {
        uint64_t spent = 0;
        for (uint32_t i = 0; i < nv; ++i)
            spent += q->results[i].rays;
        int share = spent < q->desc.ray_budget ? share_budget(q, nv, q->desc.ray_budget - spent) : SHARE_NONE;
        if (share == SHARE_NONE)
            break;
        if (share == SHARE_ALL || round + 1u == QUERY_SHARE_ROUNDS) {
            run_viewers(q, nv, VIEWER_SPEND_ANSWER);
            return;
        }
        run_viewers(q, nv, VIEWER_SPEND);
    }
    run_viewers(q, nv, VIEWER_ANSWER);
}

/* ---- one tick ------------------------------------------------------------------------------- */

static vis_status query_run(vis_query *q, const vis_query_viewer *vw, uint32_t nv, const vis_query_entity *en,
                            uint32_t ne, vis_query_stats *out_stats)
{
    double t0 = now_ms();
    vis_status st = check_inputs(q, vw, nv, en, ne);
    if (st != VIS_OK)
        return st;
    q->in_viewers = vw;
    q->in_entities = en;
    q->viewer_count = nv;
    q->entity_count = ne;
    ++q->tick;
    assign_slots(q);

    vis_scene_begin_read(q->scene);
    uint64_t gen = q->scene->generation;
    q->regenerated = q->tick > 1 && gen != q->generation;
    /* Where it changed, read under the same lock as the generation (query_chunks.c). */
    q->change_count = q->regenerated ? vis_scene_edits_since(q->scene, q->generation, q->changes, VIS_SCENE_EDIT_LOG) : 0;
    vis_scene_end_read(q->scene);
    const uint64_t previous_generation = q->generation;
    q->generation = gen;

    /* Eye regions (the swept boxes depend on each viewer's latency: its job makes them). */
    for (uint32_t i = 0; i < nv; ++i)
        eye_region(q, &vw[i], &q->eye_now[i]);

    /* Chunks: one batch for every viewer due. */
    st = vis_query_chunks_run(q);
    if (st != VIS_OK) {
        --q->tick; /* the slots moved, but no result of this tick is readable */
        q->last_viewers = 0;
        q->generation = previous_generation; /* an edit not traced yet still forces the passes */
        return st;
    }

    vis_scene_begin_read(q->scene);
    q->view = vis_scene_get_view(q->scene);
    run_pairs(q, nv);
    vis_scene_end_read(q->scene);

    q->last_viewers = nv;
    if (out_stats) {
        vis_query_stats s;
        memset(&s, 0, sizeof s);
        s.tick = q->tick;
        s.chunk_rays = q->chunk_rays;
        s.chunk_passes = q->chunk_passes;
        s.chunk_edit_passes = q->chunk_edit_passes;
        s.chunk_faces_deferred = q->chunk_deferred;
        for (uint32_t i = 0; i < nv; ++i) {
            const vis_qresult *r = &q->results[i];
            s.entity_rays += r->rays;
            s.solid_tests += r->solid_tests;
            s.pairs += r->pairs;
            s.pairs_cached += r->cached;
            s.pairs_seen += r->seen;
            s.pairs_hidden += r->hidden;
            s.pairs_unchecked += r->unchecked;
            s.pairs_held += r->held;
        }
        s.ms = now_ms() - t0;
        *out_stats = s;
    }
    return VIS_OK;
}

vis_status vis_query_run(vis_query *q, const vis_query_viewer *viewers, uint32_t viewer_count,
                         const vis_query_entity *entities, uint32_t entity_count, vis_query_stats *out_stats)
{
    if (!q)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(q->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(q->ctx);
    vis_status st = query_run(q, viewers, viewer_count, entities, entity_count, out_stats);
    vis_leave(q->ctx);
    return st;
}

/* ---- results ---------------------------------------------------------------------------------- */

static vis_status copy_out(vis_query *q, const char *fn, uint32_t viewer, const void *src, size_t n, size_t elem,
                           void *out, size_t capacity, size_t *out_count)
{
    if (out_count)
        *out_count = n;
    if (!out && capacity)
        return vis_fail(q->ctx, VIS_ERROR_INVALID_ARGUMENT, "%s: out is NULL with capacity %zu", fn, capacity);
    if (!out)
        return VIS_OK;
    if (capacity < n)
        return vis_fail(q->ctx, VIS_ERROR_CAPACITY, "%s: viewer %u has %zu entries, capacity is %zu", fn, viewer, n,
                        capacity);
    memcpy(out, src, n * elem);
    return VIS_OK;
}

vis_status vis_query_entities(vis_query *q, uint32_t viewer_index, vis_query_hit *out, size_t capacity,
                              size_t *out_count)
{
    if (!q)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(q->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(q->ctx);
    vis_status st;
    if (viewer_index >= q->last_viewers)
        st = vis_fail(q->ctx, VIS_ERROR_NOT_FOUND, "vis_query_entities: viewer %u, the last run had %u", viewer_index,
                      q->last_viewers);
    else
        st = copy_out(q, "vis_query_entities", viewer_index, q->hits + (size_t)viewer_index * q->desc.max_entities,
                      q->results[viewer_index].hit_count, sizeof(vis_query_hit), out, capacity, out_count);
    vis_leave(q->ctx);
    return st;
}

vis_status vis_query_chunks(vis_query *q, uint32_t viewer_index, uint32_t *out, size_t capacity, size_t *out_count)
{
    if (!q)
        return VIS_ERROR_INVALID_ARGUMENT;
    if (vis_enter(q->ctx) != VIS_OK)
        return VIS_ERROR_BUSY;
    vis_clear_error(q->ctx);
    vis_status st;
    if (viewer_index >= q->last_viewers) {
        st = vis_fail(q->ctx, VIS_ERROR_NOT_FOUND, "vis_query_chunks: viewer %u, the last run had %u", viewer_index,
                      q->last_viewers);
    } else {
        uint32_t s = q->vslot[viewer_index];
        st = copy_out(q, "vis_query_chunks", viewer_index, q->chunks + (size_t)s * q->chunk_cap,
                      q->viewers[s].chunk_count, sizeof(uint32_t), out, capacity, out_count);
    }
    vis_leave(q->ctx);
    return st;
}
