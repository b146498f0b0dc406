/* camera_path.c — the camera path shared by `vis run` and `vis bench`. */
#include "camera_path.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#define EYE_HEIGHT 1.7 /* voxels above the floor a walker's eye is */

typedef struct bounds {
    int64_t lo[3], hi[3]; /* voxels, hi exclusive */
    double ground;        /* mean surface height over a coarse grid */
} bounds;

static int solid(const vw_world *w, int64_t x, int64_t y, int64_t z)
{
    return vw_world_get(w, x, y, z) != 0;
}

/* The top of the highest solid voxel of the column (lo[1] if the column is empty). */
static int64_t surface(const vw_world *w, const bounds *b, int64_t x, int64_t z)
{
    for (int64_t y = b->hi[1] - 1; y >= b->lo[1]; --y)
        if (solid(w, x, y, z))
            return y + 1;
    return b->lo[1];
}

/* The lowest floor of the column with three empty voxels above it (room to stand), or -1
 * when there is none below the surface. */
static int64_t lowest_floor(const vw_world *w, const bounds *b, int64_t x, int64_t z, int64_t *out_y)
{
    for (int64_t y = b->lo[1] + 1; y + 2 < b->hi[1]; ++y) {
        if (solid(w, x, y - 1, z) && !solid(w, x, y, z) && !solid(w, x, y + 1, z) && !solid(w, x, y + 2, z)) {
            *out_y = y;
            return 0;
        }
    }
    return -1;
}

static void get_bounds(const vw_world *w, bounds *b)
{
    vw_world_info info;
    vw_world_get_info(w, &info);
    for (int a = 0; a < 3; ++a) {
        b->lo[a] = info.origin[a];
        b->hi[a] = info.origin[a] + info.size[a];
    }
    /* Mean surface height over an 8x8 grid: where the overview and top-down views aim. */
    double sum = 0.0;
    for (int i = 0; i < 8; ++i) {
        for (int k = 0; k < 8; ++k) {
            int64_t x = b->lo[0] + (int64_t)((i + 0.5) / 8.0 * (double)info.size[0]);
            int64_t z = b->lo[2] + (int64_t)((k + 0.5) / 8.0 * (double)info.size[2]);
            sum += (double)surface(w, b, x, z);
        }
    }
    b->ground = sum / 64.0;
}

static void set_view(vc_view *v, const char *name, const double eye[3], const double target[3])
{
    memset(v, 0, sizeof *v);
    snprintf(v->name, sizeof v->name, "%s", name);
    for (int a = 0; a < 3; ++a) {
        v->camera.eye[a] = eye[a];
        v->camera.target[a] = target[a];
    }
    v->camera.fovy_deg = 60.0;
}

static void overview(const bounds *b, vc_view *v)
{
    double cx = 0.5 * (double)(b->lo[0] + b->hi[0]), cz = 0.5 * (double)(b->lo[2] + b->hi[2]);
    double dx = cx - (double)b->lo[0], dz = cz - (double)b->lo[2];
    double horizontal = sqrt(dx * dx + dz * dz);
    double target[3] = {cx, b->ground, cz};
    double eye[3] = {(double)b->lo[0], b->ground + horizontal, (double)b->lo[2]}; /* 45 degrees */
    set_view(v, "overview", eye, target);
}

size_t vc_camera_path(const vw_world *world, vc_view *out, size_t capacity)
{
    bounds b;
    get_bounds(world, &b);
    vc_view views[VC_MAX_VIEWS];
    size_t n = 0;
    double ext[3];
    for (int a = 0; a < 3; ++a)
        ext[a] = (double)(b.hi[a] - b.lo[a]);
    double cx = (double)b.lo[0] + 0.5 * ext[0], cz = (double)b.lo[2] + 0.5 * ext[2];

    /* Ground: standing on the surface 15% in from the west edge, looking east, level. */
    {
        int64_t x = b.lo[0] + (int64_t)(0.15 * ext[0]), z = (int64_t)floor(cz);
        double eye[3] = {(double)x + 0.5, (double)surface(world, &b, x, z) + EYE_HEIGHT, (double)z + 0.5};
        double target[3] = {(double)b.hi[0], eye[1], eye[2]};
        set_view(&views[n++], "ground", eye, target);
    }
    overview(&b, &views[n++]);
    /* Top-down: the forward vector is exactly -Y (the camera's special case); high enough
     * that the 60-degree view spans the larger horizontal extent. */
    {
        double span = ext[0] > ext[2] ? ext[0] : ext[2];
        double target[3] = {cx, b.ground, cz};
        double eye[3] = {cx, (double)b.hi[1] + 0.5 * span / tan(30.0 * 3.14159265358979323846 / 180.0), cz};
        set_view(&views[n++], "topdown", eye, target);
    }
    /* The walk: along the diagonal from 20% to 80%, at the lowest floor of each column. */
    for (int i = 0; i < VC_WALK_STEPS; ++i) {
        double s = 0.2 + 0.6 * (double)i / (double)(VC_WALK_STEPS - 1);
        int64_t x = b.lo[0] + (int64_t)(s * ext[0]), z = b.lo[2] + (int64_t)(s * ext[2]);
        int64_t floor_y;
        if (lowest_floor(world, &b, x, z, &floor_y) != 0)
            floor_y = surface(world, &b, x, z);
        double eye[3] = {(double)x + 0.5, (double)floor_y + EYE_HEIGHT, (double)z + 0.5};
        /* Level, towards the far corner of the diagonal. */
        double target[3] = {eye[0] + ext[0], eye[1], eye[2] + ext[2]};
        char name[VC_VIEW_NAME_MAX];
        snprintf(name, sizeof name, "walk-%d", i);
        set_view(&views[n++], name, eye, target);
    }
    if (n > capacity)
        n = capacity;
    memcpy(out, views, n * sizeof *out);
    return n;
}

int64_t vc_surface_height(const vw_world *world, int64_t x, int64_t z)
{
    vw_world_info info;
    vw_world_get_info(world, &info);
    bounds b;
    for (int a = 0; a < 3; ++a) {
        b.lo[a] = info.origin[a];
        b.hi[a] = info.origin[a] + info.size[a];
    }
    return surface(world, &b, x, z);
}

void vc_camera_default(const vw_world *world, vis_camera *out)
{
    bounds b;
    get_bounds(world, &b);
    vc_view v;
    overview(&b, &v);
    *out = v.camera;
}
