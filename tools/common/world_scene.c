/* world_scene.c — chunk meshes of a voxelworld world as objects of a libvis scene. */
#include "world_scene.h"

#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "timer.h"

struct world_scene {
    vis_context *ctx;
    vis_scene *scene;
    vw_world *world;
    int64_t origin[3];          /* the world's, which is the scene's                         */
    uint32_t chunk_count;
    uint8_t *present;           /* per chunk: 1 if its object is in the scene               */
    uint32_t object_count;
    uint32_t *dirty;            /* chunk_count entries: vw_world_take_dirty never needs more */
    vw_mesh mesh;               /* reused by every remesh                                    */
    vis_quad *quads;            /* conversion buffer, grown to the largest mesh              */
    size_t quad_cap;
    world_scene_chunk_fn hook;
    void *hook_user;
};

static void set_error(vw_error *err, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void set_error(vw_error *err, const char *fmt, ...)
{
    if (!err)
        return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err->message, sizeof err->message, fmt, ap);
    va_end(ap);
}

void world_scene_convert_quads(const vw_quad *in, size_t count, vis_quad *out)
{
    for (size_t i = 0; i < count; ++i) {
        const vw_quad *q = &in[i];
        uint32_t flags = 0;
        if (q->flags & VW_MAT_SEE_THROUGH)
            flags |= VIS_PRIM_SEE_THROUGH;
        if (q->flags & VW_MAT_REFLECTIVE)
            flags |= VIS_PRIM_REFLECTIVE;
        out[i].axis = q->axis;
        out[i].flags = flags;
        out[i].plane = (float)q->plane;
        out[i].u0 = (float)q->u0;
        out[i].v0 = (float)q->v0;
        out[i].u1 = (float)q->u1;
        out[i].v1 = (float)q->v1;
    }
}

void world_scene_bounds(const vw_world *world, double out_min[3], double out_max[3])
{
    vw_world_info info;
    vw_world_get_info(world, &info);
    for (int a = 0; a < 3; ++a) {
        out_min[a] = (double)info.origin[a];
        out_max[a] = (double)info.origin[a] + (double)info.size[a];
    }
}

/* Grows a conversion buffer to hold `count` quads (the only allocation on the edit path,
 * and only until the buffer fits the largest chunk mesh; a meshing batch's until it fits the
 * largest batch). */
static int reserve_quads(vis_quad **quads, size_t *quad_cap, size_t count)
{
    if (count <= *quad_cap)
        return 0;
    size_t cap = *quad_cap ? *quad_cap : 256;
    while (cap < count)
        cap *= 2;
    vis_quad *q = realloc(*quads, cap * sizeof *q);
    if (!q)
        return -1;
    *quads = q;
    *quad_cap = cap;
    return 0;
}

/* Meshes one chunk into ws->mesh (empty chunks give an empty mesh without meshing). */
static int mesh_chunk(world_scene *ws, uint32_t chunk, vw_error *err)
{
    ws->mesh.count = 0;
    if (vw_world_chunk_empty(ws->world, chunk))
        return 0;
    vw_status st = vw_mesh_chunk(ws->world, chunk, &ws->mesh);
    if (st != VW_OK) {
        set_error(err, "meshing chunk %u: %s", chunk, vw_status_string(st));
        return -1;
    }
    return 0;
}

/* Hands a chunk's current mesh to libvis: replace, add, or remove. */
/* `converted`, when not NULL, holds cm's quads already converted (a meshing batch does it on
 * its own thread); otherwise they are converted here. */
static int upload_chunk(world_scene *ws, uint32_t chunk, const vw_mesh *cm, const vis_quad *converted,
                        world_scene_stats *st, vw_error *err)
{
    uint32_t id = vw_chunk_object_id(chunk);
    size_t n = cm->count;
    double t0 = vc_now_ms();
    if (n == 0) {
        if (ws->present[chunk]) {
            vis_status s = vis_scene_remove_object(ws->scene, id);
            if (s != VIS_OK) {
                set_error(err, "removing object %u: %s", id, vis_context_last_error(ws->ctx));
                return -1;
            }
            ws->present[chunk] = 0;
            --ws->object_count;
            ++st->objects_removed;
        }
    } else {
        if (!converted) {
            if (reserve_quads(&ws->quads, &ws->quad_cap, n) != 0) {
                set_error(err, "out of memory converting %zu quads", n);
                return -1;
            }
            world_scene_convert_quads(cm->quads, n, ws->quads);
            converted = ws->quads;
        }
        vis_mesh mesh = {converted, (uint32_t)n, NULL, 0};
        t0 = vc_now_ms();
        vis_status s = vis_scene_set_object(ws->scene, id, &mesh);
        if (s != VIS_OK) {
            set_error(err, "setting object %u: %s", id, vis_context_last_error(ws->ctx));
            return -1;
        }
        if (!ws->present[chunk]) {
            ws->present[chunk] = 1;
            ++ws->object_count;
        }
        ++st->objects_set;
        st->quads += n;
    }
    st->scene_ms += vc_now_ms() - t0;
    if (ws->hook)
        ws->hook(chunk, id, cm, ws->hook_user);
    return 0;
}

static int refresh_chunk(world_scene *ws, uint32_t chunk, world_scene_stats *st, vw_error *err)
{
    double t0 = vc_now_ms();
    if (mesh_chunk(ws, chunk, err) != 0)
        return -1;
    st->mesh_ms += vc_now_ms() - t0;
    ++st->chunks;
    return upload_chunk(ws, chunk, &ws->mesh, NULL, st, err);
}

/* Chunks meshed per vw_mesh_chunks call: enough that the threads stay busy and the
 * team's start-up is noise, few enough that the meshes waiting for upload stay small (a few
 * MB, and as much again for their quads converted for libvis). The meshes and the converted
 * quads are reused from batch to batch, so they stop allocating once grown. */
#define MESH_BATCH 1024u

/* One batch of chunks and their meshes, meshed on a thread of its own while the batch before
 * it is uploaded. */
typedef struct mesh_batch {
    vw_world *world;
    uint32_t threads;
    uint32_t chunks[MESH_BATCH];
    vw_mesh meshes[MESH_BATCH];
    size_t first[MESH_BATCH + 1]; /* mesh i's quads in `quads`: [first[i], first[i + 1])   */
    vis_quad *quads;               /* every mesh's quads converted for libvis (off the main thread) */
    size_t quad_cap;
    uint32_t n;
    vw_status status;
    double ms;
} mesh_batch;

static void *mesh_batch_run(void *arg)
{
    mesh_batch *b = arg;
    double t0 = vc_now_ms();
    b->status = vw_mesh_chunks(b->world, b->chunks, b->n, b->meshes, b->threads);
    b->first[0] = 0;
    for (uint32_t i = 0; i < b->n; ++i)
        b->first[i + 1] = b->first[i] + (b->status == VW_OK ? b->meshes[i].count : 0);
    if (b->status == VW_OK && reserve_quads(&b->quads, &b->quad_cap, b->first[b->n]) != 0)
        b->status = VW_ERROR_OUT_OF_MEMORY;
    if (b->status == VW_OK)
        for (uint32_t i = 0; i < b->n; ++i)
            if (b->meshes[i].count)
                world_scene_convert_quads(b->meshes[i].quads, b->meshes[i].count, b->quads + b->first[i]);
    b->ms = vc_now_ms() - t0;
    return NULL;
}

/* Fills the batch with the next non-empty chunks from *next on. */
static void mesh_batch_collect(const world_scene *ws, mesh_batch *b, uint32_t *next)
{
    b->n = 0;
    for (; *next < ws->chunk_count && b->n < MESH_BATCH; ++*next)
        if (!vw_world_chunk_empty(ws->world, *next))
            b->chunks[b->n++] = *next;
}

/* Meshes every non-empty chunk, a batch at a time on opt->mesh_threads threads, and uploads
 * the batches in ascending chunk order: the same calls, in the same order, as a serial loop,
 * so the scene is the same. The next batch is meshed while one is uploaded (libvis's scene
 * build is serial): on two threads the upload no longer leaves a core idle. */
static int mesh_all(world_scene *ws, const world_scene_options *opt, world_scene_stats *st, vw_error *err)
{
    int rc = 0;
    mesh_batch *b[2] = {calloc(1, sizeof(mesh_batch)), calloc(1, sizeof(mesh_batch))};
    if (!b[0] || !b[1]) {
        set_error(err, "out of memory for a meshing batch");
        free(b[0]);
        free(b[1]);
        return -1;
    }
    for (int i = 0; i < 2; ++i) {
        b[i]->world = ws->world;
        b[i]->threads = opt->mesh_threads;
    }
    uint32_t next = 0, step = ws->chunk_count / 200 + 1, reported = 0;
    mesh_batch_collect(ws, b[0], &next);
    mesh_batch_run(b[0]);
    for (int cur = 0; b[cur]->n > 0 || next < ws->chunk_count; cur ^= 1) {
        mesh_batch *now = b[cur], *ahead = b[cur ^ 1];
        st->mesh_ms += now->ms;
        if (now->status != VW_OK) {
            set_error(err, "meshing %u chunks before chunk %u: %s", now->n, now->n ? now->chunks[now->n - 1] + 1 : next,
                      vw_status_string(now->status));
            rc = -1;
            break;
        }
        uint32_t done = next; /* chunks looked at once this batch is uploaded */
        mesh_batch_collect(ws, ahead, &next);
        pthread_t helper;
        int threaded = ahead->n > 0 && pthread_create(&helper, NULL, mesh_batch_run, ahead) == 0;
        for (uint32_t i = 0; i < now->n && rc == 0; ++i) {
            ++st->chunks;
            rc = upload_chunk(ws, now->chunks[i], &now->meshes[i], now->quads ? now->quads + now->first[i] : NULL, st,
                              err);
        }
        if (threaded)
            pthread_join(helper, NULL);
        else
            mesh_batch_run(ahead); /* no thread to spare (or nothing left): mesh it here */
        if (opt->progress && done / step > reported) {
            reported = done / step;
            opt->progress("meshing", (double)done / (double)ws->chunk_count, opt->progress_user);
        }
        if (rc != 0)
            break;
    }
    for (int k = 0; k < 2; ++k) {
        for (uint32_t i = 0; i < MESH_BATCH; ++i)
            vw_mesh_free(&b[k]->meshes[i]);
        free(b[k]->quads);
        free(b[k]);
    }
    return rc;
}

int world_scene_create(vis_context *ctx, vw_world *world, const world_scene_options *options,
                       world_scene **out, world_scene_stats *stats, vw_error *err)
{
    world_scene_options opt = {0};
    if (options)
        opt = *options;
    world_scene_stats st = {0};
    double t_start = vc_now_ms();

    vw_world_info info;
    vw_world_get_info(world, &info);
    world_scene *ws = calloc(1, sizeof *ws);
    if (!ws) {
        set_error(err, "out of memory");
        return -1;
    }
    ws->ctx = ctx;
    ws->world = world;
    ws->chunk_count = info.chunk_count;
    for (int a = 0; a < 3; ++a)
        ws->origin[a] = info.origin[a];
    ws->present = calloc(info.chunk_count ? info.chunk_count : 1, 1);
    ws->dirty = malloc((info.chunk_count ? info.chunk_count : 1) * sizeof *ws->dirty);
    if (!ws->present || !ws->dirty) {
        set_error(err, "out of memory for %u chunks", info.chunk_count);
        world_scene_destroy(ws);
        return -1;
    }

    vis_scene_desc desc;
    memset(&desc, 0, sizeof desc);
    for (int a = 0; a < 3; ++a) {
        desc.origin[a] = (double)info.origin[a];
        desc.size[a] = (float)info.size[a];
    }
    desc.cell_size = (float)info.chunk_size;
    desc.kd_depth = opt.kd_depth;
    vis_status s = vis_scene_create(ctx, &desc, &ws->scene);
    if (s != VIS_OK) {
        set_error(err, "creating the scene: %s", vis_context_last_error(ctx));
        world_scene_destroy(ws);
        return -1;
    }

    /* Creation does not call the hook: it is for edits (set it after creating). */
    if (opt.progress)
        opt.progress("meshing", 0.0, opt.progress_user);
    if (mesh_all(ws, &opt, &st, err) != 0) {
        world_scene_destroy(ws);
        return -1;
    }
    if (opt.progress)
        opt.progress("meshing", 1.0, opt.progress_user);
    vw_world_clear_dirty(world);
    st.total_ms = vc_now_ms() - t_start;
    if (stats)
        *stats = st;
    *out = ws;
    return 0;
}

void world_scene_destroy(world_scene *ws)
{
    if (!ws)
        return;
    vis_scene_destroy(ws->scene);
    vw_mesh_free(&ws->mesh);
    free(ws->quads);
    free(ws->dirty);
    free(ws->present);
    free(ws);
}

int world_scene_solid(void *user, const int32_t lo[3], const int32_t hi[3])
{
    const world_scene *ws = user;
    int64_t min[3], max[3];
    for (int a = 0; a < 3; ++a) {
        min[a] = ws->origin[a] + lo[a];
        max[a] = ws->origin[a] + hi[a];
    }
    return vw_world_box_opaque(ws->world, min, max);
}

vis_scene *world_scene_scene(const world_scene *ws) { return ws->scene; }
vw_world *world_scene_world(const world_scene *ws) { return ws->world; }
vis_context *world_scene_context(const world_scene *ws) { return ws->ctx; }
uint32_t world_scene_object_count(const world_scene *ws) { return ws->object_count; }

void world_scene_set_chunk_hook(world_scene *ws, world_scene_chunk_fn fn, void *user)
{
    ws->hook = fn;
    ws->hook_user = user;
}

int world_scene_update(world_scene *ws, world_scene_stats *stats, vw_error *err)
{
    world_scene_stats st = {0};
    double t_start = vc_now_ms();
    size_t n = vw_world_take_dirty(ws->world, ws->dirty, ws->chunk_count);
    for (size_t i = 0; i < n; ++i) {
        if (refresh_chunk(ws, ws->dirty[i], &st, err) != 0)
            return -1;
    }
    st.total_ms = vc_now_ms() - t_start;
    if (stats)
        *stats = st;
    return 0;
}

int world_scene_for_each_object(world_scene *ws, world_scene_chunk_fn fn, void *user, vw_error *err)
{
    for (uint32_t c = 0; c < ws->chunk_count; ++c) {
        if (!ws->present[c])
            continue;
        if (mesh_chunk(ws, c, err) != 0)
            return -1;
        fn(c, vw_chunk_object_id(c), &ws->mesh, user);
    }
    return 0;
}
