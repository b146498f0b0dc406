/* A program outside the project, built against an installed libvis and voxelworld (through
 * find_package or a plain `pkg-config --libs`), doing what a game does with them:
 *
 *   a MagicaVoxel .vox (written here, byte by byte, in memory: two 32x32 walls one behind the
 *   other) -> vw_vox_load_memory -> vw_mesh_chunk per chunk -> a vis scene -> vis_trace;
 *   then one voxel of the front wall is removed, the dirty chunks are re-meshed, and the
 *   scene is traced again.
 *
 * The oracle is independent of both libraries' algorithms: every pixel's ray is built in
 * double from the camera model vis.h documents and walked voxel by voxel through the world
 * (Amanatides & Woo 1987, "A Fast Voxel Traversal Algorithm for Ray Tracing"); its first
 * solid voxel gives the expected chunk object ID and distance. Pixels whose ray meets its
 * voxel within 1e-4 of an edge are ambiguous by design (the tie rule) and are only counted.
 * It also checks that the OpenCL loader was not mapped into this CPU-only process. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <vis/vis.h>
#include <voxelworld/vw.h>

#define WALL 32  /* voxels per side                              */
#define GAP 6    /* .vox y of the back wall (the front one is 0) */
#define RES 25   /* odd: the centre pixel's ray is the view axis */

/* ---- a .vox file in memory (format: ephtracy/voxel-model, version 150) ----------------- */

static unsigned char *put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
    return p + 4;
}

static unsigned char *put_id(unsigned char *p, const char id[4])
{
    memcpy(p, id, 4);
    return p + 4;
}

/* Two walls in .vox coordinates (z up): x, z in [0, WALL), at y = 0 and y = GAP. */
static size_t write_vox(unsigned char *buf)
{
    const uint32_t n = 2u * WALL * WALL;
    unsigned char *p = buf;
    p = put_id(p, "VOX ");
    p = put32(p, 150);
    p = put_id(p, "MAIN");
    p = put32(p, 0);
    p = put32(p, (12 + 12) + (12 + 4 + 4 * n));
    p = put_id(p, "SIZE");
    p = put32(p, 12);
    p = put32(p, 0);
    p = put32(p, WALL);
    p = put32(p, GAP + 1);
    p = put32(p, WALL);
    p = put_id(p, "XYZI");
    p = put32(p, 4 + 4 * n);
    p = put32(p, 0);
    p = put32(p, n);
    for (int wall = 0; wall < 2; ++wall)
        for (int z = 0; z < WALL; ++z)
            for (int x = 0; x < WALL; ++x) {
                *p++ = (unsigned char)x;
                *p++ = (unsigned char)(wall ? GAP : 0);
                *p++ = (unsigned char)z;
                *p++ = (unsigned char)(wall ? 80 : 200); /* palette entries: two materials */
            }
    return (size_t)(p - buf);
}

/* ---- world -> scene ------------------------------------------------------------------------ */

static vis_quad *quads_buf;
static size_t quads_cap;

/* Meshes one chunk and puts it in the scene as object vw_chunk_object_id(chunk) (an empty
 * mesh removes it). Quads are relative to the world origin, which is the scene origin. */
static int put_chunk(const vw_world *world, vis_scene *scene, uint32_t chunk, vw_mesh *mesh)
{
    if (vw_mesh_chunk(world, chunk, mesh) != VW_OK)
        return 1;
    if (mesh->count > quads_cap) {
        free(quads_buf);
        quads_cap = mesh->count;
        quads_buf = malloc(quads_cap * sizeof *quads_buf);
        if (!quads_buf)
            return 1;
    }
    for (size_t i = 0; i < mesh->count; ++i) {
        const vw_quad *q = &mesh->quads[i];
        vis_quad o = {q->axis, 0u, (float)q->plane, (float)q->u0, (float)q->v0, (float)q->u1, (float)q->v1};
        quads_buf[i] = o;
    }
    vis_mesh m = {quads_buf, (uint32_t)mesh->count, NULL, 0};
    return vis_scene_set_object(scene, vw_chunk_object_id(chunk), &m) != VIS_OK;
}

/* ---- the oracle ------------------------------------------------------------------------------ */

typedef struct expect {
    uint32_t id;    /* 0: nothing within reach */
    double t;       /* distance along the normalised ray */
    int ambiguous;  /* the ray meets its voxel within 1e-4 of an edge */
} expect;

static void normalize(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int a = 0; a < 3; ++a)
        v[a] /= l;
}

static void cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* The ray of pixel (x, y), as vis.h defines it. */
static void pixel_ray(const vis_camera *cam, uint32_t w, uint32_t h, uint32_t x, uint32_t y, double d[3])
{
    double f[3] = {cam->target[0] - cam->eye[0], cam->target[1] - cam->eye[1], cam->target[2] - cam->eye[2]};
    normalize(f);
    const double up[3] = {0.0, 1.0, 0.0};
    double r[3], u[3];
    cross(f, up, r);
    normalize(r);
    cross(r, f, u);
    double th = tan(cam->fovy_deg * 3.14159265358979323846 / 360.0);
    double nx = ((x + 0.5) / w * 2.0 - 1.0) * th * ((double)w / h);
    double ny = (1.0 - (y + 0.5) / h * 2.0) * th;
    for (int a = 0; a < 3; ++a)
        d[a] = f[a] + nx * r[a] + ny * u[a];
    normalize(d);
}

static expect walk(const vw_world *world, const vw_world_info *info, const double e[3], const double d[3])
{
    expect ex = {0u, INFINITY, 0};
    int64_t v[3];
    int step[3];
    double tmax[3], tdelta[3];
    for (int a = 0; a < 3; ++a) {
        v[a] = (int64_t)floor(e[a]);
        step[a] = d[a] > 0 ? 1 : (d[a] < 0 ? -1 : 0);
        tdelta[a] = step[a] ? fabs(1.0 / d[a]) : INFINITY;
        double next = step[a] > 0 ? (double)(v[a] + 1) : (double)v[a];
        tmax[a] = step[a] ? (next - e[a]) / d[a] : INFINITY;
    }
    double t = 0.0;
    int entered = -1;
    for (int i = 0; i < 4096 && t < 1000.0; ++i) {
        if (entered >= 0 && vw_world_get(world, v[0], v[1], v[2]) != 0) {
            int64_t c[3];
            for (int a = 0; a < 3; ++a)
                c[a] = (v[a] - info->origin[a]) / info->chunk_size;
            ex.id = vw_chunk_object_id(vw_world_chunk_index(world, (int32_t)c[0], (int32_t)c[1], (int32_t)c[2]));
            ex.t = t;
            for (int a = 0; a < 3; ++a) {
                if (a == entered)
                    continue;
                double p = e[a] + t * d[a];
                double frac = p - floor(p);
                if (frac < 1e-4 || frac > 1.0 - 1e-4)
                    ex.ambiguous = 1;
            }
            return ex;
        }
        int a = tmax[0] < tmax[1] ? (tmax[0] < tmax[2] ? 0 : 2) : (tmax[1] < tmax[2] ? 1 : 2);
        t = tmax[a];
        v[a] += step[a];
        tmax[a] += tdelta[a];
        entered = a;
    }
    return ex;
}

/* Compares a traced pass with the oracle; returns the number of wrong pixels. */
static int check_pass(const char *what, const vw_world *world, const vw_world_info *info, const vis_camera *cam,
                      const uint32_t *ids, const float *depth)
{
    int wrong = 0, ambiguous = 0;
    for (uint32_t y = 0; y < RES; ++y)
        for (uint32_t x = 0; x < RES; ++x) {
            double d[3];
            pixel_ray(cam, RES, RES, x, y, d);
            expect ex = walk(world, info, cam->eye, d);
            size_t i = (size_t)y * RES + x;
            if (ex.ambiguous) {
                ++ambiguous;
                continue;
            }
            double tol = 1e-4 * (ex.t > 1.0 ? ex.t : 1.0);
            if (ids[i] != ex.id || !(fabs((double)depth[i] - ex.t) <= tol)) {
                if (wrong < 5)
                    fprintf(stderr, "%s: pixel (%u,%u): id %u depth %.6f, expected id %u depth %.6f\n", what, x, y,
                            ids[i], (double)depth[i], ex.id, ex.t);
                ++wrong;
            }
        }
    printf("%s: %d of %d pixels as the oracle says, %d on an edge (not compared), %d wrong\n", what,
           RES * RES - ambiguous - wrong, RES * RES, ambiguous, wrong);
    if (ambiguous > RES * RES / 10) {
        fprintf(stderr, "%s: %d ambiguous pixels: the view is badly placed\n", what, ambiguous);
        ++wrong;
    }
    return wrong;
}

static int opencl_loader_mapped(void)
{
    FILE *f = fopen("/proc/self/maps", "r");
    if (!f)
        return 0;
    char line[1024];
    int found = 0;
    while (fgets(line, sizeof line, f))
        if (strstr(line, "libOpenCL"))
            found = 1;
    fclose(f);
    return found;
}

int main(void)
{
    printf("libvis %s (header %s)\n", vis_version(), VIS_VERSION_STRING);
    if (strcmp(vis_version(), VIS_VERSION_STRING) != 0) {
        fprintf(stderr, "the library (%s) is not the header's version (%s)\n", vis_version(), VIS_VERSION_STRING);
        return 1;
    }
    int rc = 1;
    vis_context *ctx = NULL;
    vis_scene *scene = NULL;
    vw_world *world = NULL;
    vw_mesh mesh = {NULL, 0, 0};
    uint32_t *dirty = NULL;
    static unsigned char vox[64 + 4 * 2 * WALL * WALL];
    static uint32_t ids[RES * RES], ids_before[RES * RES];
    static float depth[RES * RES], depth_before[RES * RES];

    /* 1. The .vox, loaded from memory. */
    size_t vox_size = write_vox(vox);
    vw_error err;
    if (vw_vox_load_memory(vox, vox_size, 16, NULL, &world, &err) != VW_OK) {
        fprintf(stderr, "vw_vox_load_memory: %s\n", err.message);
        goto done;
    }
    vw_world_info info;
    vw_world_get_info(world, &info);
    /* Where the walls landed: .vox (x, y, z) is world (x, z, -y-1) up to a translation, so the
     * front wall (.vox y = 0) is the one with the larger world z. */
    int64_t lo[3] = {INT64_MAX, INT64_MAX, INT64_MAX}, hi[3] = {INT64_MIN, INT64_MIN, INT64_MIN};
    uint64_t solid = 0;
    for (int64_t z = info.origin[2]; z < info.origin[2] + info.size[2]; ++z)
        for (int64_t y = info.origin[1]; y < info.origin[1] + info.size[1]; ++y)
            for (int64_t x = info.origin[0]; x < info.origin[0] + info.size[0]; ++x)
                if (vw_world_get(world, x, y, z)) {
                    int64_t p[3] = {x, y, z};
                    for (int a = 0; a < 3; ++a) {
                        lo[a] = p[a] < lo[a] ? p[a] : lo[a];
                        hi[a] = p[a] > hi[a] ? p[a] : hi[a];
                    }
                    ++solid;
                }
    if (solid != 2u * WALL * WALL || solid != info.solid_voxels || hi[0] - lo[0] != WALL - 1 ||
        hi[1] - lo[1] != WALL - 1 || hi[2] - lo[2] != GAP ||
        !vw_world_get(world, lo[0], lo[1], hi[2]) || !vw_world_get(world, lo[0], lo[1], lo[2]) ||
        vw_world_get(world, lo[0], lo[1], lo[2] + 1)) {
        fprintf(stderr, "the loaded world is not the two walls: %llu solid voxels in [%lld,%lld]x[%lld,%lld]x[%lld,%lld]\n",
                (unsigned long long)solid, (long long)lo[0], (long long)hi[0], (long long)lo[1], (long long)hi[1],
                (long long)lo[2], (long long)hi[2]);
        goto done;
    }
    printf("vox: %llu voxels, world %dx%dx%d at (%lld,%lld,%lld), %u chunks\n", (unsigned long long)solid,
           info.size[0], info.size[1], info.size[2], (long long)info.origin[0], (long long)info.origin[1],
           (long long)info.origin[2], info.chunk_count);

    /* 2. The scene: one object per non-empty chunk. */
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = VIS_BACKEND_CPU;
    cd.threads = 1;
    if (vis_context_create(&cd, &ctx) != VIS_OK) {
        fprintf(stderr, "vis_context_create failed\n");
        goto done;
    }
    vis_scene_desc sd;
    vis_scene_desc_defaults(&sd);
    for (int a = 0; a < 3; ++a) {
        sd.origin[a] = (double)info.origin[a];
        sd.size[a] = (float)info.size[a];
    }
    sd.cell_size = (float)info.chunk_size;
    if (vis_scene_create(ctx, &sd, &scene) != VIS_OK)
        goto done;
    uint32_t objects = 0;
    for (uint32_t c = 0; c < info.chunk_count; ++c) {
        if (vw_world_chunk_empty(world, c))
            continue;
        if (put_chunk(world, scene, c, &mesh) != 0)
            goto done;
        ++objects;
    }
    /* 3. Trace: the eye straight in front of voxel column (12, 12) of the front wall. The scene
     * coordinates are world coordinates here: the camera is in world units. */
    double cx = (double)lo[0] + 12.5, cy = (double)lo[1] + 12.5, front = (double)hi[2] + 1.0;
    vis_camera cam = {{cx, cy, front + 20.0}, {cx, cy, front}, 40.0, 0.05, 0.0};
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = RES;
    td.height = RES;
    if (vis_trace(ctx, scene, &cam, &td, ids, RES * RES, depth, RES * RES) != VIS_OK)
        goto done;
    int wrong = check_pass("before the edit", world, &info, &cam, ids, depth);
    size_t centre = (size_t)(RES / 2) * RES + RES / 2;
    if (!(fabs((double)depth[centre] - 20.0) <= 1e-4)) {
        fprintf(stderr, "centre pixel depth %g, expected 20 (the front wall)\n", (double)depth[centre]);
        ++wrong;
    }
    /* The draw list accounts for every pixel: the walls fill the view. */
    vis_draw_entry list[64];
    size_t n = 0;
    uint64_t listed = 0;
    if (vis_drawlist_build(ctx, scene, ids, RES, RES, VIS_IDS_OBJECT, list, 64, &n) != VIS_OK || n == 0) {
        fprintf(stderr, "draw list failed (%zu entries)\n", n);
        ++wrong;
    }
    for (size_t i = 0; i < n; ++i)
        listed += list[i].pixels;
    if (listed != RES * RES) {
        fprintf(stderr, "the draw list covers %llu of %d pixels\n", (unsigned long long)listed, RES * RES);
        ++wrong;
    }
    memcpy(ids_before, ids, sizeof ids);
    memcpy(depth_before, depth, sizeof depth);

    /* 4. The edit: knock out the front-wall voxel on the view axis, re-mesh what changed. */
    if (vw_world_set(world, lo[0] + 12, lo[1] + 12, hi[2], 0) != VW_OK)
        goto done;
    dirty = malloc(info.chunk_count * sizeof *dirty);
    if (!dirty)
        goto done;
    size_t nd = vw_world_take_dirty(world, dirty, info.chunk_count);
    if (nd == 0) {
        fprintf(stderr, "the edit left no dirty chunk\n");
        goto done;
    }
    for (size_t i = 0; i < nd; ++i)
        if (put_chunk(world, scene, dirty[i], &mesh) != 0)
            goto done;
    if (vis_trace(ctx, scene, &cam, &td, ids, RES * RES, depth, RES * RES) != VIS_OK)
        goto done;
    wrong += check_pass("after the edit", world, &info, &cam, ids, depth);
    int changed = 0;
    for (size_t i = 0; i < RES * RES; ++i)
        changed += ids[i] != ids_before[i] || depth[i] != depth_before[i];
    double back_t = front + 20.0 - ((double)lo[2] + 1.0);
    if (!(fabs((double)depth[centre] - back_t) <= 1e-4)) {
        fprintf(stderr, "after the edit the centre pixel is at %g, expected the back wall at %g\n",
                (double)depth[centre], back_t);
        ++wrong;
    }
    if (changed == 0) {
        fprintf(stderr, "the edit changed no pixel\n");
        ++wrong;
    }
    if (wrong)
        goto done;
    printf("ok: %u chunk objects, %zu in view; removing one voxel re-meshed %zu chunk%s and changed %d pixels; "
           "the view axis sees the back wall at %.1f\n",
           objects, n, nd, nd == 1 ? "" : "s", changed, back_t);

    /* 5. A CPU-only program never maps the OpenCL loader (libvis opens it only for OpenCL). */
    if (opencl_loader_mapped()) {
        fprintf(stderr, "libOpenCL is mapped into a program that only used the CPU backend\n");
        goto done;
    }
    rc = 0;
done:
    if (rc != 0 && ctx)
        fprintf(stderr, "failed: %s\n", vis_context_last_error(ctx));
    free(dirty);
    free(quads_buf);
    vw_mesh_free(&mesh);
    vis_scene_destroy(scene);
    vis_context_destroy(ctx);
    vw_world_destroy(world);
    return rc;
}
