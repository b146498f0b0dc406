/* cpu_backend.c — the ray pass on CPU threads. Rays go in square tiles (Chang & Ihm 2010
 * use square thread tiles for coherence: neighbouring rays touch the same nodes and leaves),
 * 8x8 for the per-ray methods and VIS_PACKET_SIDE for packets (8x8 for packets of 8 or fewer
 * rays a side), handed out dynamically by the pool. A batch of views is one pool run over the
 * tiles of all of them, so that the threads share out a batch of small passes (a server's
 * 32x32 faces: 16 tiles each) as they do one large pass, woken once. The scene arrays are the host's own; a sync
 * refreshes only what this backend keeps beside them: the subtree fills the packet
 * method skips empty space with, and the voxel labels of the per-ray leaf walk (labels.h).
 * The packet method traces a tile at once (packet.c); every other method runs trace_core.h
 * pixel by pixel, the same code the OpenCL kernel runs. A pass with effects runs the effects
 * instance of that code (effects.c): per ray in 8x8 tiles, or for the packet method in
 * packets of primary rays (packet_fx_*.c) in VIS_PACKET_SIDE tiles. */
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "backend.h"
#include "cpu/effects.h"
#include "cpu/labels.h"
#include "cpu/occupancy.h"
#include "cpu/packet.h"
#include "cpu/threadpool.h"

#define TILE 8u

typedef struct cpu_backend {
    vis_allocator alloc; /* the context's: every host allocation of this backend */
    vis_pool *pool;
    vis_parallel_for_fn parallel_for; /* the caller's job system, or NULL: the pool */
    void *parallel_for_user;
} cpu_backend;

/* The backend's own data for a scene, beside the host arrays it traces: the
 * subtree fills of the packets and the voxel labels of the per-ray leaf walk. */
typedef struct cpu_scene {
    vis_occupancy occ;
    vis_labels labels;
} cpu_scene;

typedef struct cpu_job {
    vis_scene_view view;        /* the scene's arrays and this backend's labels */
    const vis_node_fill *fill;
    const vis_ray_setup *setup; /* `views` setups of one size and method (a batch), or one */
    uint32_t views;
    uint32_t *ids;              /* view i's pixels at + i * width * height, depth likewise */
    float *depth;
    uint32_t side, tiles_x, tiles; /* tile edge in pixels, tiles per row, tiles per view */
    uint32_t *cost;         /* packets: per-pixel traversal cost, or NULL */
    const vis_effect_setup *effects; /* an effects pass, or NULL */
    const vis_effect_outputs *effect_out;
    atomic_ullong secondary; /* secondary rays cast by the effects pass */
} cpu_job;

static void trace_tile(void *user, uint32_t item)
{
    const cpu_job *job = user;
    const vis_scene_view v = job->view; /* a local copy: its arrays stay in registers */
    const uint32_t view = item / job->tiles, tile = item % job->tiles;
    const vis_ray_setup *s = &job->setup[view];
    const size_t first = (size_t)view * s->width * s->height; /* the view's first pixel */
    uint32_t *ids = job->ids + first;
    float *depth = job->depth ? job->depth + first : NULL;
    uint32_t x0 = (tile % job->tiles_x) * job->side, y0 = (tile / job->tiles_x) * job->side;
    if (job->effects) {
        uint32_t x1 = x0 + job->side < s->width ? x0 + job->side : s->width;
        uint32_t y1 = y0 + job->side < s->height ? y0 + job->side : s->height;
        uint64_t n = s->traversal == VIS_TRAVERSAL_ID_PACKET
                         ? vis_cpu_effects_packet_tile(&v, job->fill, s, job->effects, job->effect_out,
                                                       vis_packet_side(s), x0, y0)
                         : vis_cpu_effects_tile(&v, s, job->effects, job->effect_out, x0, y0, x1, y1);
        atomic_fetch_add_explicit((atomic_ullong *)&job->secondary, (unsigned long long)n, memory_order_relaxed);
        return;
    }
    if (s->traversal == VIS_TRAVERSAL_ID_PACKET) {
        /* Per tile: the views of a batch may differ in field of view, so in packet size. */
        vis_packet_trace_tile(s, &v, job->fill, vis_packet_side(s), job->side, x0, y0, ids, depth, job->cost);
        return;
    }
    uint32_t x1 = x0 + job->side < s->width ? x0 + job->side : s->width;
    uint32_t y1 = y0 + job->side < s->height ? y0 + job->side : s->height;
    for (uint32_t y = y0; y < y1; ++y)
        for (uint32_t x = x0; x < x1; ++x) {
            uint32_t id;
            float t;
            vis_trace_pixel(s, x, y, VIS_SCENE_VIEW_ARGS(&v), &id, &t);
            size_t i = (size_t)y * s->width + x;
            ids[i] = id;
            if (depth)
                depth[i] = t;
        }
}

/* The job system's argument order. */
static void trace_tile_job(uint32_t tile, void *arg) { trace_tile(arg, tile); }

static void cpu_destroy(void *impl)
{
    cpu_backend *b = impl;
    if (!b)
        return;
    vis_pool_destroy(b->pool);
    vis_allocator a = b->alloc;
    vis_host_free(&a, b);
}

/* job(i, arg) for i in [0, count) on the caller's job system or the pool: the labels' full
 * build and vis_cpu_backend_parallel_for. */
typedef struct pool_call {
    void (*job)(uint32_t index, void *arg);
    void *arg;
} pool_call;

static void pool_call_item(void *user, uint32_t index)
{
    const pool_call *c = user;
    c->job(index, c->arg);
}

static void run_parallel(void *impl, uint32_t count, void (*job)(uint32_t index, void *arg), void *arg)
{
    cpu_backend *b = impl;
    if (b->parallel_for) {
        b->parallel_for(count, job, arg, b->parallel_for_user);
        return;
    }
    pool_call c = {job, arg};
    vis_pool_run(b->pool, count, pool_call_item, &c);
}

static vis_status cpu_scene_sync(void *impl, void **scene_data, const vis_scene_view *view,
                                 const vis_scene_changes *changes, char *err, size_t err_size)
{
    cpu_backend *b = impl;
    cpu_scene *cs = *scene_data;
    if (!cs) {
        if (!(cs = vis_host_calloc(&b->alloc, 1, sizeof *cs))) {
            snprintf(err, err_size, "out of memory");
            return VIS_ERROR_OUT_OF_MEMORY;
        }
        cs->occ.alloc = cs->labels.alloc = &b->alloc;
    }
    *scene_data = cs; /* the host arrays are the scene: only the fills and labels are ours */
    vis_status st = vis_occupancy_sync(&cs->occ, view, changes);
    if (st != VIS_OK) {
        snprintf(err, err_size, st == VIS_ERROR_OUT_OF_MEMORY ? "out of memory for the occupancy of %u kd nodes"
                                                              : "a kd-tree of %u nodes deeper than the fills' walk",
                 view->node_count);
        return st;
    }
    /* The labels only accelerate the per-ray leaf walk: without them every leaf takes the
     * plane walk, with the same buffers (labels.h). So a copy of another context's scene,
     * made whole at every sync after an edit, keeps none: a whole build of gen:large's takes
     * half a second. Nor does a copy whose labels could not have their memory, or would take
     * the scene past its max_bytes beside the fills. */
    if (changes->copy) {
        vis_labels_free(&cs->labels);
        return VIS_OK;
    }
    uint64_t fills = sizeof *cs + vis_occupancy_bytes(&cs->occ);
    (void)vis_labels_sync(&cs->labels, view, changes, changes->room > fills ? changes->room - fills : 0, run_parallel,
                          b);
    return VIS_OK;
}

static void cpu_scene_release(void *impl, void *scene_data)
{
    cpu_backend *b = impl;
    cpu_scene *cs = scene_data;
    if (!cs)
        return;
    vis_occupancy_free(&cs->occ);
    vis_labels_free(&cs->labels);
    vis_host_free(&b->alloc, cs);
}

/* A job over the `views` passes setup[0..views) (one size and method): its items are the
 * tiles of view 0, then those of view 1, and so on. Packets go in VIS_PACKET_SIDE tiles, or
 * in 8x8 ones where no view takes 16x16 packets: a server's 32x32 face is then 16 items
 * instead of 4, so that its threads share a face whose work lies in one corner (a hill's
 * horizon: docs/server.md, "Chunk faces traced one by one"). An effects pass keeps
 * VIS_PACKET_SIDE tiles. */
static void init_job(cpu_job *job, const cpu_scene *cs, const vis_scene_view *view, const vis_ray_setup *setup,
                     uint32_t views, uint32_t *ids, float *depth, const vis_effect_setup *effects)
{
    uint32_t side = TILE;
    if (setup->traversal == VIS_TRAVERSAL_ID_PACKET) {
        side = effects ? VIS_PACKET_SIDE : TILE;
        for (uint32_t i = 0; i < views && side < VIS_PACKET_SIDE; ++i)
            if (vis_packet_side(&setup[i]) > TILE)
                side = VIS_PACKET_SIDE;
    }
    memset(job, 0, sizeof *job);
    job->view = *view;
    job->view.labels = cs->labels.words;
    job->fill = cs->occ.fill;
    job->setup = setup;
    job->views = views;
    job->ids = ids;
    job->depth = depth;
    job->effects = effects;
    job->side = side;
    job->tiles_x = (setup->width + side - 1) / side;
    job->tiles = job->tiles_x * ((setup->height + side - 1) / side);
    atomic_init(&job->secondary, 0u);
}

/* The job's tiles on the caller's job system or the pool. A batch's tile count is at most
 * 2^32 - 1: cpu_trace_batch refuses more. */
static void run_job(cpu_backend *b, cpu_job *job)
{
    uint32_t items = job->views * job->tiles;
    if (b->parallel_for)
        b->parallel_for(items, trace_tile_job, job, b->parallel_for_user);
    else
        vis_pool_run(b->pool, items, trace_tile, job);
}

static vis_status cpu_trace_effects(void *impl, void *scene_data, const vis_scene_view *view,
                                    const vis_ray_setup *setup, const vis_effect_setup *effects,
                                    const vis_effect_outputs *out, char *err, size_t err_size)
{
    (void)err, (void)err_size;
    cpu_job job;
    init_job(&job, scene_data, view, setup, 1, out->ids, out->depth, effects);
    job.effect_out = out;
    run_job(impl, &job);
    if (out->secondary_rays)
        *out->secondary_rays = atomic_load(&job.secondary);
    return VIS_OK;
}

static vis_status cpu_trace(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                            uint32_t *ids, float *depth, char *err, size_t err_size)
{
    (void)err, (void)err_size;
    cpu_job job;
    init_job(&job, scene_data, view, setup, 1, ids, depth, NULL);
    run_job(impl, &job);
    return VIS_OK;
}

static vis_status cpu_trace_batch(void *impl, void *scene_data, const vis_scene_view *view,
                                  const vis_ray_setup *setups, uint32_t count, uint32_t *ids, float *depth, char *err,
                                  size_t err_size)
{
    cpu_job job;
    init_job(&job, scene_data, view, setups, count, ids, depth, NULL);
    if ((uint64_t)job.tiles * count > UINT32_MAX) {
        snprintf(err, err_size, "a batch of %u views of %u tiles is over 2^32 tiles", count, job.tiles);
        return VIS_ERROR_INVALID_ARGUMENT;
    }
    run_job(impl, &job);
    return VIS_OK;
}

static vis_status cpu_trace_cost(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                                 uint32_t *ids, uint32_t *cost, char *err, size_t err_size)
{
    if (setup->traversal != VIS_TRAVERSAL_ID_PACKET) {
        snprintf(err, err_size, "traversal cost is counted by the packet method only");
        return VIS_ERROR_UNSUPPORTED;
    }
    cpu_job job;
    init_job(&job, scene_data, view, setup, 1, ids, NULL, NULL);
    job.cost = cost;
    run_job(impl, &job);
    return VIS_OK;
}

void vis_cpu_backend_set_parallel_for(vis_backend *backend, vis_parallel_for_fn parallel_for, void *user)
{
    cpu_backend *b = backend->impl;
    b->parallel_for = parallel_for;
    b->parallel_for_user = user;
}

void vis_cpu_backend_parallel_for(vis_backend *backend, uint32_t count, void (*job)(uint32_t index, void *arg),
                                  void *arg)
{
    run_parallel(backend->impl, count, job, arg);
}

static uint64_t cpu_last_upload_bytes(void *impl, void *scene_data)
{
    (void)impl, (void)scene_data;
    return 0;
}

/* The subtree fills and the voxel labels, at their capacity. */
static uint64_t cpu_scene_bytes(void *impl, void *scene_data)
{
    (void)impl;
    const cpu_scene *cs = scene_data;
    if (!cs)
        return 0;
    return sizeof *cs + vis_occupancy_bytes(&cs->occ) + vis_labels_bytes(&cs->labels);
}

static const vis_backend_ops cpu_ops = {"cpu", cpu_destroy, cpu_scene_sync, cpu_scene_release, cpu_trace,
                                        cpu_trace_cost, cpu_last_upload_bytes,
                                        cpu_trace_batch,
                                        NULL /* last_kernel_ms: libvis times the pass */,
                                        NULL /* trace_drawlist: libvis builds lists from the IDs */,
                                        cpu_trace_effects, cpu_scene_bytes};

vis_status vis_cpu_backend_create(uint32_t threads, const vis_allocator *alloc, vis_backend *out,
                                  uint32_t *out_threads, char *err, size_t err_size)
{
    if (threads == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (uint32_t)n : 1u;
    }
    cpu_backend *b = vis_host_calloc(alloc, 1, sizeof *b);
    if (!b) {
        snprintf(err, err_size, "out of memory");
        return VIS_ERROR_OUT_OF_MEMORY;
    }
    b->alloc = *alloc;
    vis_status st = vis_pool_create(threads, &b->alloc, &b->pool);
    if (st != VIS_OK) {
        vis_host_free(alloc, b);
        if (st == VIS_ERROR_OUT_OF_MEMORY)
            snprintf(err, err_size, "out of memory for a pool of %u threads", threads);
        else
            snprintf(err, err_size, "could not start %u threads", threads);
        return st;
    }
    out->ops = &cpu_ops;
    out->impl = b;
    *out_threads = threads;
    return VIS_OK;
}
