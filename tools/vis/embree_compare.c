/* embree_compare.c — the Embree 3 reference behind `vis bench --compare embree`. */
#define _POSIX_C_SOURCE 200809L

#include "embree_compare.h"

#include <stdio.h>

#ifndef VIS_HAVE_EMBREE

int embree_compare_available(void) { return 0; }

int embree_compare_create(world_scene *ws, uint32_t threads, embree_compare **out, char *err, size_t err_size)
{
    (void)ws;
    (void)threads;
    *out = NULL;
    snprintf(err, err_size, "--compare embree is not available in this build (Embree 3 was not found)");
    return -1;
}
void embree_compare_destroy(embree_compare *ec) { (void)ec; }
double embree_compare_static_build_ms(const embree_compare *ec) { (void)ec; return 0.0; }
double embree_compare_dynamic_build_ms(const embree_compare *ec) { (void)ec; return 0.0; }
uint64_t embree_compare_triangles(const embree_compare *ec) { (void)ec; return 0; }
uint64_t embree_compare_static_bytes(const embree_compare *ec) { (void)ec; return 0; }
uint64_t embree_compare_dynamic_bytes(const embree_compare *ec) { (void)ec; return 0; }
int embree_compare_trace(embree_compare *ec, const vis_camera *camera, uint32_t width, uint32_t height,
                         int stream, uint32_t *ids, double *ms, char *err, size_t err_size)
{
    (void)ec;
    (void)camera;
    (void)width;
    (void)height;
    (void)stream;
    (void)ids;
    (void)ms;
    snprintf(err, err_size, "Embree is not available in this build");
    return -1;
}
double embree_compare_replace(embree_compare *ec, uint32_t id, const vis_quad *quads, size_t count)
{
    (void)ec;
    (void)id;
    (void)quads;
    (void)count;
    return 0.0;
}
double embree_compare_commit(embree_compare *ec) { (void)ec; return 0.0; }

#else /* VIS_HAVE_EMBREE */

#include <embree3/rtcore.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h" /* libvis internal: the exact float ray setup libvis traces */
#include "common/trace_core.h"
#include "timer.h"

#define TILE 8

typedef struct embree_compare embree_compare;

/* One pass, shared by the workers. */
typedef struct pass_job {
    vis_ray_setup setup;
    uint32_t tiles_x, tiles;
    int stream;
    uint32_t *ids;
    atomic_uint next_tile;
} pass_job;

typedef struct worker {
    embree_compare *ec;
    pthread_t thread;
    uint32_t index;
} worker;

struct embree_compare {
    vis_context *ctx;
    double origin[3];
    RTCDevice device;
    RTCScene scene;          /* static: robust, high quality                               */
    RTCScene dynamic;        /* dynamic: replaced geometry per edit                         */
    uint32_t *geom_to_id;    /* static scene: geomID -> object ID                           */
    uint8_t *dyn_present;    /* dynamic scene: object ID -> has a geometry (geomID = ID)    */
    uint32_t dyn_cap;        /* entries of dyn_present: the largest possible ID + 1         */
    uint32_t geom_count, geom_cap;
    uint64_t triangles;
    double static_ms, dynamic_ms;
    char error[256];
    /* What the device holds for each scene (its geometry buffers and its BVH), summed by the
     * memory monitor (on_memory) into the scene that `mem_scene` names while it builds. */
    atomic_int mem_scene;      /* SCENE_STATIC or SCENE_DYNAMIC                            */
    atomic_llong mem_bytes[2];

    /* The tile workers: the caller traces too; `started` others wait for a new generation. */
    uint32_t threads;
    worker *workers;
    uint32_t started;
    pthread_mutex_t lock;
    pthread_cond_t wake, finished;
    int sync_ready;
    unsigned generation, active;
    int quit;
    pass_job job;
};

enum { SCENE_STATIC, SCENE_DYNAMIC };

/* Embree's memory monitor: every allocation and free of the device (negative bytes), each
 * reported once, before (post = 0, when it may be refused) or after it; from any of the
 * device's threads. Only one scene is built at a time, so what it allocates goes to that one. */
static bool on_memory(void *user, ssize_t bytes, bool post)
{
    (void)post;
    embree_compare *ec = user;
    atomic_fetch_add(&ec->mem_bytes[atomic_load(&ec->mem_scene)], (long long)bytes);
    return true;
}

static void on_error(void *user, enum RTCError code, const char *msg)
{
    embree_compare *ec = user;
    snprintf(ec->error, sizeof ec->error, "Embree error %d: %s", (int)code, msg ? msg : "");
}

/* Two triangles per quad, corners in the quad's plane (scene-local, as libvis stores them). */
static RTCGeometry make_geometry(embree_compare *ec, const vis_quad *quads, size_t count, enum RTCBuildQuality q)
{
    RTCGeometry g = rtcNewGeometry(ec->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *v = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 4 * count);
    unsigned *ix = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned),
                                           2 * count);
    if (!v || !ix) {
        rtcReleaseGeometry(g);
        return NULL;
    }
    for (size_t i = 0; i < count; ++i) {
        const vis_quad *qd = &quads[i];
        uint32_t a = qd->axis, u = (a + 1) % 3, w = (a + 2) % 3;
        float cu[4] = {qd->u0, qd->u1, qd->u1, qd->u0}, cv[4] = {qd->v0, qd->v0, qd->v1, qd->v1};
        for (int k = 0; k < 4; ++k) {
            float *p = v + 3 * (4 * i + k);
            p[a] = qd->plane;
            p[u] = cu[k];
            p[w] = cv[k];
        }
        unsigned b = (unsigned)(4 * i);
        unsigned *t = ix + 6 * i;
        t[0] = b;
        t[1] = b + 1;
        t[2] = b + 2;
        t[3] = b;
        t[4] = b + 2;
        t[5] = b + 3;
    }
    rtcSetGeometryBuildQuality(g, q);
    rtcCommitGeometry(g);
    return g;
}

typedef struct build_state {
    embree_compare *ec;
    vis_quad *quads;
    size_t cap;
    int failed;
    double static_ms, dynamic_ms; /* geometry creation counts towards the build */
} build_state;

static void add_object(uint32_t chunk, uint32_t id, const vw_mesh *mesh, void *user)
{
    (void)chunk;
    build_state *b = user;
    embree_compare *ec = b->ec;
    if (b->failed || mesh->count == 0)
        return;
    if (mesh->count > b->cap) {
        size_t cap = mesh->count * 2;
        vis_quad *q = realloc(b->quads, cap * sizeof *q);
        if (!q) {
            b->failed = 1;
            return;
        }
        b->quads = q;
        b->cap = cap;
    }
    world_scene_convert_quads(mesh->quads, mesh->count, b->quads);
    if (ec->geom_count == ec->geom_cap) {
        uint32_t cap = ec->geom_cap ? ec->geom_cap * 2 : 1024;
        uint32_t *m = realloc(ec->geom_to_id, cap * sizeof *m);
        if (!m) {
            b->failed = 1;
            return;
        }
        ec->geom_to_id = m;
        ec->geom_cap = cap;
    }
    double t0 = vc_now_ms();
    atomic_store(&ec->mem_scene, SCENE_STATIC);
    RTCGeometry g = make_geometry(ec, b->quads, mesh->count, RTC_BUILD_QUALITY_HIGH);
    if (!g) {
        b->failed = 1;
        return;
    }
    unsigned gid = rtcAttachGeometry(ec->scene, g);
    rtcReleaseGeometry(g);
    double t1 = vc_now_ms();
    atomic_store(&ec->mem_scene, SCENE_DYNAMIC);
    RTCGeometry d = make_geometry(ec, b->quads, mesh->count, RTC_BUILD_QUALITY_MEDIUM);
    if (!d) {
        b->failed = 1;
        return;
    }
    rtcAttachGeometryByID(ec->dynamic, d, id);
    rtcReleaseGeometry(d);
    ec->dyn_present[id] = 1;
    double t2 = vc_now_ms();
    b->static_ms += t1 - t0;
    b->dynamic_ms += t2 - t1;
    /* geomIDs are handed out densely from 0 in attach order. */
    while (ec->geom_count <= gid)
        ec->geom_to_id[ec->geom_count++] = 0;
    ec->geom_to_id[gid] = id;
    ec->triangles += 2 * mesh->count;
}

/* ---- tracing -------------------------------------------------------------------------- */

static void trace_tile(embree_compare *ec, const pass_job *job, uint32_t tile)
{
    uint32_t tx = tile % job->tiles_x, ty = tile / job->tiles_x;
    uint32_t x0 = tx * TILE, y0 = ty * TILE;
    uint32_t w = job->setup.width, h = job->setup.height;
    uint32_t x1 = x0 + TILE < w ? x0 + TILE : w, y1 = y0 + TILE < h ? y0 + TILE : h;
    struct RTCRayHit rays[TILE * TILE];
    uint32_t n = 0;
    for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = x0; x < x1; ++x, ++n) {
            vis_ray r;
            vis_ray_for_pixel(&job->setup, x, y, &r);
            struct RTCRayHit *rh = &rays[n];
            rh->ray.org_x = r.o[0];
            rh->ray.org_y = r.o[1];
            rh->ray.org_z = r.o[2];
            rh->ray.dir_x = r.d[0];
            rh->ray.dir_y = r.d[1];
            rh->ray.dir_z = r.d[2];
            rh->ray.tnear = r.t_near;
            rh->ray.tfar = r.t_far;
            rh->ray.time = 0.0f;
            rh->ray.mask = 0xFFFFFFFFu;
            rh->ray.id = n;
            rh->ray.flags = 0;
            rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        }
    }
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    if (job->stream) {
        ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        rtcIntersect1M(ec->scene, &ictx, rays, n, sizeof(struct RTCRayHit));
    } else {
        for (uint32_t i = 0; i < n; ++i)
            rtcIntersect1(ec->scene, &ictx, &rays[i]);
    }
    n = 0;
    for (uint32_t y = y0; y < y1; ++y) {
        for (uint32_t x = x0; x < x1; ++x, ++n) {
            unsigned g = rays[n].hit.geomID;
            job->ids[(size_t)y * w + x] = g == RTC_INVALID_GEOMETRY_ID || g >= ec->geom_count ? 0 : ec->geom_to_id[g];
        }
    }
}

static void run_tiles(embree_compare *ec)
{
    pass_job *job = &ec->job;
    for (;;) {
        uint32_t t = atomic_fetch_add(&job->next_tile, 1u);
        if (t >= job->tiles)
            return;
        trace_tile(ec, job, t);
    }
}

static void *worker_main(void *arg)
{
    worker *w = arg;
    embree_compare *ec = w->ec;
    unsigned seen = 0;
    for (;;) {
        pthread_mutex_lock(&ec->lock);
        while (ec->generation == seen && !ec->quit)
            pthread_cond_wait(&ec->wake, &ec->lock);
        if (ec->quit) {
            pthread_mutex_unlock(&ec->lock);
            return NULL;
        }
        seen = ec->generation;
        pthread_mutex_unlock(&ec->lock);
        run_tiles(ec);
        pthread_mutex_lock(&ec->lock);
        if (--ec->active == 0)
            pthread_cond_signal(&ec->finished);
        pthread_mutex_unlock(&ec->lock);
    }
}

int embree_compare_trace(embree_compare *ec, const vis_camera *camera, uint32_t width, uint32_t height,
                         int stream, uint32_t *ids, double *ms, char *err, size_t err_size)
{
    vis_camera_frame frame;
    if (vis_camera_frame_make(ec->ctx, camera, ec->origin, width, height, &frame) != VIS_OK) {
        snprintf(err, err_size, "camera: %s", vis_context_last_error(ec->ctx));
        return -1;
    }
    pass_job *job = &ec->job;
    vis_camera_frame_ray_setup(&frame, &job->setup);
    job->tiles_x = (width + TILE - 1) / TILE;
    job->tiles = job->tiles_x * ((height + TILE - 1) / TILE);
    job->stream = stream;
    job->ids = ids;
    atomic_store(&job->next_tile, 0u);
    double t0 = vc_now_ms();
    if (ec->started) {
        pthread_mutex_lock(&ec->lock);
        ec->active = ec->started;
        ++ec->generation;
        pthread_cond_broadcast(&ec->wake);
        pthread_mutex_unlock(&ec->lock);
    }
    run_tiles(ec);
    if (ec->started) {
        pthread_mutex_lock(&ec->lock);
        while (ec->active > 0)
            pthread_cond_wait(&ec->finished, &ec->lock);
        pthread_mutex_unlock(&ec->lock);
    }
    *ms = vc_now_ms() - t0;
    return 0;
}

/* ---- create / destroy ----------------------------------------------------------------- */

int embree_compare_available(void) { return 1; }

int embree_compare_create(world_scene *ws, uint32_t threads, embree_compare **out, char *err, size_t err_size)
{
    *out = NULL;
    embree_compare *ec = calloc(1, sizeof *ec);
    if (!ec) {
        snprintf(err, err_size, "out of memory");
        return -1;
    }
    ec->ctx = world_scene_context(ws);
    atomic_init(&ec->mem_scene, SCENE_STATIC);
    atomic_init(&ec->mem_bytes[SCENE_STATIC], 0);
    atomic_init(&ec->mem_bytes[SCENE_DYNAMIC], 0);
    vw_world_info wi;
    vw_world_get_info(world_scene_world(ws), &wi);
    ec->dyn_cap = wi.chunk_count + 1;
    ec->dyn_present = calloc(ec->dyn_cap, 1);
    if (!ec->dyn_present) {
        snprintf(err, err_size, "out of memory");
        free(ec);
        return -1;
    }
    double hi[3];
    world_scene_bounds(world_scene_world(ws), ec->origin, hi);
    ec->threads = threads ? threads : 1;
    char config[64];
    snprintf(config, sizeof config, "threads=%u", ec->threads);
    ec->device = rtcNewDevice(config);
    if (!ec->device) {
        snprintf(err, err_size, "rtcNewDevice(\"%s\") failed (error %d)", config, (int)rtcGetDeviceError(NULL));
        free(ec);
        return -1;
    }
    rtcSetDeviceErrorFunction(ec->device, on_error, ec);
    rtcSetDeviceMemoryMonitorFunction(ec->device, on_memory, ec);
    ec->scene = rtcNewScene(ec->device);
    rtcSetSceneFlags(ec->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(ec->scene, RTC_BUILD_QUALITY_HIGH);
    ec->dynamic = rtcNewScene(ec->device);
    rtcSetSceneFlags(ec->dynamic, RTC_SCENE_FLAG_DYNAMIC | RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(ec->dynamic, RTC_BUILD_QUALITY_LOW);

    build_state b = {ec, NULL, 0, 0, 0.0, 0.0};
    vw_error werr;
    int rc = world_scene_for_each_object(ws, add_object, &b, &werr);
    free(b.quads);
    if (rc != 0 || b.failed) {
        snprintf(err, err_size, "building the Embree scenes: %s",
                 rc != 0 ? werr.message : ec->error[0] ? ec->error : "out of memory");
        embree_compare_destroy(ec);
        return -1;
    }
    double t0 = vc_now_ms();
    atomic_store(&ec->mem_scene, SCENE_STATIC);
    rtcCommitScene(ec->scene);
    double t1 = vc_now_ms();
    atomic_store(&ec->mem_scene, SCENE_DYNAMIC); /* and the edits' replacements after it */
    rtcCommitScene(ec->dynamic);
    double t2 = vc_now_ms();
    ec->static_ms = b.static_ms + (t1 - t0);
    ec->dynamic_ms = b.dynamic_ms + (t2 - t1);
    if (ec->error[0]) {
        snprintf(err, err_size, "%s", ec->error);
        embree_compare_destroy(ec);
        return -1;
    }

    if (pthread_mutex_init(&ec->lock, NULL) != 0 || pthread_cond_init(&ec->wake, NULL) != 0 ||
        pthread_cond_init(&ec->finished, NULL) != 0) {
        snprintf(err, err_size, "cannot set up the tracing threads");
        embree_compare_destroy(ec);
        return -1;
    }
    ec->sync_ready = 1;
    ec->workers = calloc(ec->threads, sizeof *ec->workers);
    if (!ec->workers) {
        snprintf(err, err_size, "out of memory");
        embree_compare_destroy(ec);
        return -1;
    }
    for (uint32_t i = 1; i < ec->threads; ++i) {
        ec->workers[i].ec = ec;
        ec->workers[i].index = i;
        if (pthread_create(&ec->workers[i].thread, NULL, worker_main, &ec->workers[i]) != 0) {
            snprintf(err, err_size, "pthread_create failed after %u threads", i);
            embree_compare_destroy(ec);
            return -1;
        }
        ec->started = i;
    }
    *out = ec;
    return 0;
}

void embree_compare_destroy(embree_compare *ec)
{
    if (!ec)
        return;
    if (ec->sync_ready) {
        pthread_mutex_lock(&ec->lock);
        ec->quit = 1;
        pthread_cond_broadcast(&ec->wake);
        pthread_mutex_unlock(&ec->lock);
        for (uint32_t i = 1; i <= ec->started; ++i)
            pthread_join(ec->workers[i].thread, NULL);
        pthread_mutex_destroy(&ec->lock);
        pthread_cond_destroy(&ec->wake);
        pthread_cond_destroy(&ec->finished);
    }
    free(ec->workers);
    if (ec->scene)
        rtcReleaseScene(ec->scene);
    if (ec->dynamic)
        rtcReleaseScene(ec->dynamic);
    if (ec->device)
        rtcReleaseDevice(ec->device);
    free(ec->geom_to_id);
    free(ec->dyn_present);
    free(ec);
}

double embree_compare_static_build_ms(const embree_compare *ec) { return ec->static_ms; }
double embree_compare_dynamic_build_ms(const embree_compare *ec) { return ec->dynamic_ms; }
uint64_t embree_compare_triangles(const embree_compare *ec) { return ec->triangles; }

static uint64_t scene_bytes(const embree_compare *ec, int scene)
{
    long long n = atomic_load(&ec->mem_bytes[scene]);
    return n > 0 ? (uint64_t)n : 0u;
}
uint64_t embree_compare_static_bytes(const embree_compare *ec) { return scene_bytes(ec, SCENE_STATIC); }
uint64_t embree_compare_dynamic_bytes(const embree_compare *ec) { return scene_bytes(ec, SCENE_DYNAMIC); }

double embree_compare_replace(embree_compare *ec, uint32_t id, const vis_quad *quads, size_t count)
{
    if (id >= ec->dyn_cap)
        return 0.0;
    double t0 = vc_now_ms();
    if (ec->dyn_present[id]) {
        rtcDetachGeometry(ec->dynamic, id);
        ec->dyn_present[id] = 0;
    }
    if (count > 0) {
        RTCGeometry g = make_geometry(ec, quads, count, RTC_BUILD_QUALITY_MEDIUM);
        if (g) {
            rtcAttachGeometryByID(ec->dynamic, g, id);
            rtcReleaseGeometry(g);
            ec->dyn_present[id] = 1;
        }
    }
    return vc_now_ms() - t0;
}

double embree_compare_commit(embree_compare *ec)
{
    double t0 = vc_now_ms();
    rtcCommitScene(ec->dynamic);
    return vc_now_ms() - t0;
}

#endif /* VIS_HAVE_EMBREE */
