/* bench_zbuf.c — `vis bench --method zbuf`: vis_zcull_run along the camera path, per view the
 * median of --frames runs with its parts (occluder rasterisation, box tests), the occluder
 * triangles drawn and the objects kept. Single-threaded, like the culler. */
#include "bench_zbuf.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_path.h"
#include "cli.h"
#include "json.h"
#include "timer.h"

#define CMD "bench"
#define ZB_MAX_RES 2

typedef struct zb_view {
    const char *name;
    vis_camera camera;
    uint32_t width, height;
    double time_ms, min_ms, max_ms, raster_ms, test_ms;
    vis_zcull_stats last; /* triangles, occluders, in view, kept: the same in every run */
} zb_view;

static int run_view(vis_zcull *zc, const cli_scene *s, const vis_camera *cam, uint32_t w, uint32_t h,
                    uint32_t frames, vis_draw_entry *list, size_t cap, double *t, double *tr, double *tt, zb_view *out)
{
    vis_zcull_desc d;
    vis_zcull_desc_defaults(&d);
    d.width = w;
    d.height = h;
    vis_scene *scene = world_scene_scene(s->ws);
    size_t count = 0;
    if (vis_zcull_run(zc, scene, cam, &d, list, cap, &count, NULL) != VIS_OK) /* warm-up: grows buffers */
        return cli_fail_vis(CMD, s->ctx, "vis_zcull_run");
    for (uint32_t i = 0; i < frames; ++i) {
        double t0 = vc_now_ms();
        if (vis_zcull_run(zc, scene, cam, &d, list, cap, &count, &out->last) != VIS_OK)
            return cli_fail_vis(CMD, s->ctx, "vis_zcull_run");
        t[i] = vc_now_ms() - t0;
        tr[i] = out->last.ms_raster;
        tt[i] = out->last.ms_test;
    }
    out->width = w;
    out->height = h;
    out->min_ms = vc_min(t, frames);
    out->max_ms = vc_max(t, frames);
    out->time_ms = vc_median(t, frames);
    out->raster_ms = vc_median(tr, frames);
    out->test_ms = vc_median(tt, frames);
    return CLI_EXIT_OK;
}

static void print_json(const cli_args *a, const cli_scene *s, const vis_scene_info *info, double load_ms,
                       const zb_view *v, size_t n)
{
    json_writer w;
    json_init(&w, stdout);
    json_object_begin(&w, NULL);
    json_string(&w, "command", "bench");
    json_string(&w, "method", "zbuf");
    json_string(&w, "scene", a->scene);
    json_uint(&w, "frames", a->frames);
    json_uint(&w, "objects", info->objects);
    json_uint(&w, "quads", info->quads);
    json_number(&w, "load_ms", load_ms);
    json_number(&w, "build_ms", s->build.total_ms);
    json_string(&w, "simd", n ? v[0].last.simd : "");
    json_array_begin(&w, "views");
    for (size_t i = 0; i < n; ++i) {
        json_object_begin(&w, NULL);
        json_string(&w, "name", v[i].name);
        char cam[256];
        cli_camera_format(&v[i].camera, cam, sizeof cam);
        json_string(&w, "camera", cam); /* as --camera takes it */
        json_uint(&w, "width", v[i].width);
        json_uint(&w, "height", v[i].height);
        json_number(&w, "time_ms", v[i].time_ms);
        json_number(&w, "min_ms", v[i].min_ms);
        json_number(&w, "max_ms", v[i].max_ms);
        json_number(&w, "mrays_per_s", vc_mrays_per_s((double)v[i].width * v[i].height, v[i].time_ms));
        json_number(&w, "raster_ms", v[i].raster_ms);
        json_number(&w, "test_ms", v[i].test_ms);
        json_uint(&w, "triangles", v[i].last.triangles);
        json_uint(&w, "occluder_objects", v[i].last.occluder_objects);
        json_uint(&w, "in_view", v[i].last.in_view);
        json_uint(&w, "visible", v[i].last.visible);
        json_object_end(&w);
    }
    json_array_end(&w);
    json_null(&w, "edit_ms"); /* the culler has no scene to update */
    json_object_end(&w);
}

int bench_zbuf(const cli_args *a)
{
    if (a->compare_embree)
        return cli_usage_error(CMD, "--compare embree needs --method ray");
    uint32_t res[ZB_MAX_RES][2] = {{512, 512}, {256, 128}};
    size_t nres = ZB_MAX_RES;
    if (a->given & OPT_RES) {
        res[0][0] = a->width;
        res[0][1] = a->height;
        nres = 1;
    }
    cli_progress progress;
    cli_progress_init(&progress, a->json ? CLI_PROGRESS_AUTO : CLI_PROGRESS_ALWAYS);
    cli_world world;
    int rc = cli_world_load(CMD, a->scene, &progress, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    cli_scene s;
    rc = cli_scene_open(CMD, &world, VIS_BACKEND_CPU, 1, a->kd_depth, &progress, &s);
    if (rc != CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }
    vc_view views[VC_MAX_VIEWS];
    size_t nviews = vc_camera_path(world.world, views, VC_MAX_VIEWS);
    vis_scene_info info;
    vis_zcull *zc = NULL;
    zb_view *out = calloc(nviews * nres, sizeof *out);
    size_t cap = vis_drawlist_bound(world_scene_scene(s.ws));
    vis_draw_entry *list = malloc((cap ? cap : 1) * sizeof *list);
    double *t = malloc(3 * (size_t)a->frames * sizeof *t);
    size_t n = 0;
    if (!out || !list || !t) {
        rc = cli_fail(CMD, "out of memory");
        goto done;
    }
    if (vis_scene_get_info(world_scene_scene(s.ws), &info) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_info");
        goto done;
    }
    if (vis_zcull_create(s.ctx, &zc) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_zcull_create");
        goto done;
    }
    if (!a->json) {
        printf("libvis %s bench: %s, z-buffer culler, %u frames per view; %u objects, %llu quads\n", vis_version(),
               a->scene, a->frames, info.objects, (unsigned long long)info.quads);
    }
    for (size_t r = 0; r < nres; ++r) {
        if (!a->json)
            printf("\n%ux%u\n  %-10s %9s %9s %9s %9s %9s %10s %9s %8s %8s\n", res[r][0], res[r][1], "view",
                   "median ms", "min ms", "max ms", "raster ms", "test ms", "triangles", "occluders", "in view",
                   "kept");
        for (size_t v = 0; v < nviews; ++v) {
            zb_view *o = &out[n];
            o->name = views[v].name;
            o->camera = views[v].camera;
            rc = run_view(zc, &s, &views[v].camera, res[r][0], res[r][1], a->frames, list, cap, t, t + a->frames,
                          t + 2 * (size_t)a->frames, o);
            if (rc != CLI_EXIT_OK)
                goto done;
            ++n;
            if (!a->json) {
                printf("  %-10s %9.3f %9.3f %9.3f %9.3f %9.3f %10llu %9u %8u %8u\n", o->name, o->time_ms, o->min_ms,
                       o->max_ms, o->raster_ms, o->test_ms, (unsigned long long)o->last.triangles,
                       o->last.occluder_objects, o->last.in_view, o->last.visible);
                fflush(stdout);
            }
        }
    }
    if (!a->json && n)
        printf("\nsingle-threaded, %s; default occluder budget (%u triangles)\n", out[0].last.simd,
               VIS_ZCULL_DEFAULT_OCCLUDER_TRIANGLES);
    if (a->json)
        print_json(a, &s, &info, world.load_ms, out, n);
done:
    vis_zcull_destroy(zc);
    free(out);
    free(list);
    free(t);
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}
