/* cmd_cull.c — `vis cull`: one view of a scene, by the ray pass or the z-buffer culler. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_path.h"
#include "cli.h"
#include "commands.h"
#include "dump.h"
#include "id_png.h"
#include "json.h"
#include "names.h"
#include "pass.h"
#include "timer.h"
#include "zcull_pass.h"

#define CMD "cull"

typedef struct cull_result {
    const char *scene;
    vis_camera camera;
    vis_scene_info info;
    vis_draw_entry *entries;
    size_t count;
    uint64_t hit_pixels;   /* pixels with an ID (ray pass) */
    cli_pass_times times;
    double drawlist_ms;
    vis_zcull_stats zstats; /* z-buffer culler */
    vis_effect_entry *fx_entries; /* --effects: the draw list with reasons */
    uint32_t reason_objects[VIS_REASON_COUNT]; /* objects with each reason */
    uint32_t shadow_only;   /* objects in the list only as shadow casters */
    uint64_t secondary_rays;
} cull_result;

/* Options that need an ID buffer, which only the ray pass has. */
static int check_method_options(const cli_args *a)
{
    if (a->effects && a->ids == VIS_IDS_LEAF)
        return cli_usage_error(CMD, "--effects needs --ids object (effects buffers hold object IDs)");
    if (a->effects && a->dump_depth)
        return cli_usage_error(CMD, "--dump-depth is not available with --effects");
    if (a->method != CLI_METHOD_ZBUF)
        return CLI_EXIT_OK;
    if (a->effects)
        return cli_usage_error(CMD, "--effects needs --method ray");
    static const struct { unsigned bit; const char *name; } ray_only[] = {
        {OPT_DUMP_IDS, "--dump-ids"}, {OPT_PNG, "--png"}, {OPT_IDS, "--ids"}, {OPT_TRAVERSAL, "--traversal"},
    };
    for (size_t i = 0; i < sizeof ray_only / sizeof ray_only[0]; ++i)
        if (a->given & ray_only[i].bit)
            return cli_usage_error(CMD, "%s needs --method ray (the z-buffer culler makes no ID buffer)",
                                   ray_only[i].name);
    return CLI_EXIT_OK;
}

static void print_json(const cli_args *a, const cli_scene *s, const cull_result *r)
{
    json_writer w;
    json_init(&w, stdout);
    json_object_begin(&w, NULL);
    json_string(&w, "command", "cull");
    json_string(&w, "scene", r->scene);
    json_string(&w, "method", a->method == CLI_METHOD_ZBUF ? "zbuf" : "ray");
    json_string(&w, "backend", s->backend.name);
    json_string(&w, "device", s->backend.device);
    json_uint(&w, "threads", s->backend.threads);
    if (a->method == CLI_METHOD_RAY)
        json_string(&w, "traversal", vc_traversal_run_name((int)a->traversal, s->backend.kind));
    json_uint(&w, "width", a->width);
    json_uint(&w, "height", a->height);
    json_string(&w, "ids", vc_name_of(&vc_id_modes, (int)a->ids));
    json_uint(&w, "objects", r->info.objects);
    json_uint(&w, "visible", r->count);
    json_number(&w, "time_ms", r->times.median_ms);
    json_number(&w, "min_ms", r->times.min_ms);
    json_number(&w, "max_ms", r->times.max_ms);
    json_number(&w, "first_ms", r->times.first_ms);
    json_uint(&w, "repeat", r->times.passes);
    json_number(&w, "mrays_per_s", r->times.mrays_per_s);
    json_number(&w, "drawlist_ms", r->drawlist_ms);
    if (a->effects) {
        char names[128];
        vc_effects_format(a->effects, names, sizeof names);
        json_string(&w, "effects", names);
        json_object_begin(&w, "reasons");
        static const char *const keys[VIS_REASON_COUNT] = {"direct", "see_through", "reflection", "shadow"};
        for (int i = 0; i < VIS_REASON_COUNT; ++i)
            json_uint(&w, keys[i], r->reason_objects[i]);
        json_uint(&w, "shadow_only", r->shadow_only);
        json_object_end(&w);
        json_uint(&w, "secondary_rays", r->secondary_rays);
    }
    if (a->method == CLI_METHOD_RAY) {
        json_uint(&w, "hit_pixels", r->hit_pixels);
    } else {
        json_object_begin(&w, "zcull");
        json_string(&w, "simd", r->zstats.simd);
        json_uint(&w, "in_view", r->zstats.in_view);
        json_uint(&w, "occluder_objects", r->zstats.occluder_objects);
        json_uint(&w, "occluder_triangles", r->zstats.triangles);
        json_number(&w, "raster_ms", r->zstats.ms_raster);
        json_number(&w, "test_ms", r->zstats.ms_test);
        json_object_end(&w);
    }
    json_object_begin(&w, "camera");
    json_vec3(&w, "eye", r->camera.eye);
    json_vec3(&w, "target", r->camera.target);
    json_number(&w, "fovy", r->camera.fovy_deg > 0.0 ? r->camera.fovy_deg : 60.0);
    json_object_end(&w);
    json_number(&w, "build_ms", s->build.total_ms);
    json_object_end(&w);
}

static void print_human(const cli_args *a, const cli_scene *s, const cull_result *r, double load_ms)
{
    char cam[256];
    cli_camera_format(&r->camera, cam, sizeof cam);
    printf("scene     %s: %u objects, %llu quads (loaded in %.0f ms, scene built in %.0f ms)\n", r->scene,
           r->info.objects, (unsigned long long)r->info.quads, load_ms, s->build.total_ms);
    printf("backend   %s (%s)%s%s\n", s->backend.name, s->backend.device, s->backend.reason[0] ? ": " : "",
           s->backend.reason);
    printf("camera    %s\n", cam);
    if (a->method == CLI_METHOD_ZBUF) {
        printf("method    z-buffer culler (%s), %ux%u depth buffer, %u occluder objects (%llu triangles)\n",
               r->zstats.simd, a->width, a->height, r->zstats.occluder_objects,
               (unsigned long long)r->zstats.triangles);
    } else {
        printf("method    ray pass, %ux%u %s IDs, traversal %s\n", a->width, a->height,
               vc_name_of(&vc_id_modes, (int)a->ids), vc_name_of(&vc_traversals, (int)a->traversal));
    }
    if (a->effects) {
        char names[128];
        vc_effects_format(a->effects, names, sizeof names);
        printf("effects   %s: %u direct, %u seen through, %u in reflections, %u shadow casters (%u only as casters); "
               "%llu secondary rays\n",
               names, r->reason_objects[0], r->reason_objects[1], r->reason_objects[2], r->reason_objects[3],
               r->shadow_only, (unsigned long long)r->secondary_rays);
    }
    printf("visible   %zu of %u objects", r->count, r->info.objects);
    if (a->method == CLI_METHOD_RAY)
        printf(" (%llu of %u pixels hit)", (unsigned long long)r->hit_pixels, a->width * a->height);
    printf("\ntime      %.3f ms per pass (median of %u; min %.3f, max %.3f), %.1f Mrays/s; draw list %.3f ms\n",
           r->times.median_ms, r->times.passes, r->times.min_ms, r->times.max_ms, r->times.mrays_per_s,
           r->drawlist_ms);
}

/* The ray pass and everything that needs its buffers. */
static int ray_pass(const cli_args *a, cli_scene *s, cull_result *r)
{
    vis_scene *scene = world_scene_scene(s->ws);
    size_t n = (size_t)a->width * a->height;
    uint32_t *ids = malloc(n * sizeof *ids);
    float *depth = a->dump_depth ? malloc(n * sizeof *depth) : NULL;
    int rc = CLI_EXIT_OK;
    if (!ids || (a->dump_depth && !depth)) {
        rc = cli_fail(CMD, "out of memory for a %ux%u buffer", a->width, a->height);
        goto done;
    }
    vis_trace_desc desc = cli_trace_desc(a);
    if (cli_pass_run(s->ctx, scene, &r->camera, &desc, a->repeat, ids, n, depth, depth ? n : 0, &r->times) != VIS_OK) {
        rc = cli_fail_vis(CMD, s->ctx, "vis_trace");
        goto done;
    }
    if (cli_drawlist(s->ctx, scene, ids, a->width, a->height, a->ids, a->repeat, &r->entries, &r->count, &r->drawlist_ms) !=
        VIS_OK) {
        rc = cli_fail_vis(CMD, s->ctx, "vis_drawlist_build");
        goto done;
    }
    for (size_t i = 0; i < n; ++i)
        r->hit_pixels += ids[i] != 0;
    if (a->dump_ids && (rc = cli_dump_ids(CMD, a->dump_ids, ids, n)) != CLI_EXIT_OK)
        goto done;
    if (a->dump_depth && (rc = cli_dump_depth(CMD, a->dump_depth, depth, n)) != CLI_EXIT_OK)
        goto done;
    if (a->png) {
        char err[512];
        if (cli_png_write_ids(a->png, ids, a->width, a->height, err, sizeof err) != 0)
            rc = cli_fail(CMD, "%s", err);
    }
done:
    free(ids);
    free(depth);
    return rc;
}

/* The ray pass with effects: the draw list with reasons (entries and r->count), and the IDs
 * for --dump-ids / --png. */
static int effects_pass(const cli_args *a, cli_scene *s, cull_result *r)
{
    vis_scene *scene = world_scene_scene(s->ws);
    size_t n = (size_t)a->width * a->height;
    cli_effect_buffers fb;
    int rc = CLI_EXIT_OK;
    size_t cap = vis_drawlist_bound(scene);
    r->fx_entries = malloc((cap ? cap : 1) * sizeof *r->fx_entries);
    r->entries = malloc((cap ? cap : 1) * sizeof *r->entries);
    if (cli_effect_buffers_alloc(&fb, a->width, a->height) != 0 || !r->fx_entries || !r->entries) {
        rc = cli_fail(CMD, "out of memory for a %ux%u pass with effects", a->width, a->height);
        goto done;
    }
    vis_trace_desc desc = cli_trace_desc(a);
    if (cli_effects_run(s->ctx, scene, &r->camera, &desc, a->repeat, &fb.b, &r->times) != VIS_OK) {
        rc = cli_fail_vis(CMD, s->ctx, "vis_trace_effects");
        goto done;
    }
    vis_timing tm;
    if (vis_context_last_timing(s->ctx, &tm) == VIS_OK)
        r->secondary_rays = tm.secondary_rays;
    vis_effect_buffers lb = fb.b; /* the draw list reads the buffers of the effects that ran */
    if (!(desc.effects & VIS_EFFECT_SEE_THROUGH))
        lb.see_through = NULL;
    if (!(desc.effects & VIS_EFFECT_REFLECT))
        lb.reflection = NULL;
    if (!(desc.effects & VIS_EFFECT_SHADOWS))
        lb.shadow = NULL;
    double t0 = vc_now_ms();
    if (vis_drawlist_build_effects(s->ctx, scene, &lb, a->width, a->height, VC_SEE_THROUGH_LAYERS, r->fx_entries, cap,
                                   &r->count) != VIS_OK) {
        rc = cli_fail_vis(CMD, s->ctx, "vis_drawlist_build_effects");
        goto done;
    }
    r->drawlist_ms = vc_now_ms() - t0;
    for (size_t i = 0; i < r->count; ++i) {
        const vis_effect_entry *e = &r->fx_entries[i];
        r->entries[i].id = e->id;
        r->entries[i].pixels = e->pixels[0];
        for (int k = 0; k < VIS_REASON_COUNT; ++k)
            r->reason_objects[k] += (e->reasons >> k) & 1u;
        r->shadow_only += e->reasons == VIS_REASON_SHADOW;
    }
    for (size_t i = 0; i < n; ++i)
        r->hit_pixels += fb.b.ids[i] != 0;
    if (a->dump_ids && (rc = cli_dump_ids(CMD, a->dump_ids, fb.b.ids, n)) != CLI_EXIT_OK)
        goto done;
    if (a->png) {
        char err[512];
        if (cli_png_write_ids(a->png, fb.b.ids, a->width, a->height, err, sizeof err) != 0)
            rc = cli_fail(CMD, "%s", err);
    }
done:
    cli_effect_buffers_free(&fb);
    return rc;
}

/* The z-buffer culler: a draw list without pixel counts, and its depth buffer. */
static int zbuf_pass(const cli_args *a, cli_scene *s, cull_result *r)
{
    size_t n = (size_t)a->width * a->height;
    float *depth = a->dump_depth ? malloc(n * sizeof *depth) : NULL;
    if (a->dump_depth && !depth)
        return cli_fail(CMD, "out of memory for a %ux%u buffer", a->width, a->height);
    int rc = CLI_EXIT_OK;
    if (cli_zcull_run(s->ctx, world_scene_scene(s->ws), &r->camera, a->width, a->height, a->repeat, &r->entries,
                      &r->count, depth, &r->zstats, &r->times) != VIS_OK)
        rc = cli_fail_vis(CMD, s->ctx, "z-buffer culler");
    else if (depth)
        rc = cli_dump_depth(CMD, a->dump_depth, depth, n);
    free(depth);
    return rc;
}

int cmd_cull(const cli_args *a)
{
    int rc = check_method_options(a);
    if (rc != CLI_EXIT_OK)
        return rc;
    if (a->png && !cli_png_available())
        return cli_usage_error(CMD, "--png is not available in this build (libpng was not found)");

    cli_progress progress;
    cli_progress_init(&progress, CLI_PROGRESS_AUTO);
    cli_world world;
    if ((rc = cli_world_load(CMD, a->scene, &progress, &world)) != CLI_EXIT_OK)
        return rc;
    cli_scene s;
    if ((rc = cli_scene_open(CMD, &world, a->backends[0], a->threads[0], a->kd_depth, &progress, &s)) !=
        CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }

    cull_result r;
    memset(&r, 0, sizeof r);
    r.scene = a->scene;
    if (a->given & OPT_CAMERA)
        r.camera = a->camera;
    else
        vc_camera_default(world.world, &r.camera);
    rc = cli_camera_check(CMD, s.ctx, &r.camera);
    if (rc == CLI_EXIT_OK && vis_scene_get_info(world_scene_scene(s.ws), &r.info) != VIS_OK)
        rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_info");
    if (rc == CLI_EXIT_OK) {
        if (a->method == CLI_METHOD_ZBUF) {
            rc = zbuf_pass(a, &s, &r);
        } else if (a->effects) {
            rc = effects_pass(a, &s, &r);
        } else {
            rc = ray_pass(a, &s, &r);
        }
    }
    if (rc == CLI_EXIT_OK && a->dump_list)
        rc = a->effects ? cli_dump_effect_list(CMD, a->dump_list, r.fx_entries, r.count)
                        : cli_dump_list(CMD, a->dump_list, r.entries, r.count);
    if (rc == CLI_EXIT_OK) {
        if (a->json)
            print_json(a, &s, &r);
        else
            print_human(a, &s, &r, world.load_ms);
    }
    free(r.entries);
    free(r.fx_entries);
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}
