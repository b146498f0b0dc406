/* cmd_bench.c — `vis bench`: the camera path timed per view (N frames each, per backend and
 * thread count), random single-voxel edits timed one by one, and optionally the same rays
 * and edits through Embree. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "bench_effects.h"
#include "bench_traversal.h"
#include "bench_zbuf.h"
#include "cli.h"
#include "commands.h"
#include "json.h"
#include "names.h"
#include "pass.h"
#include "timer.h"

/* ---- the camera path per configuration ------------------------------------------------- */

static int run_views(bench *b, cli_scene *s, size_t config)
{
    const cli_args *a = b->a;
    vis_trace_desc desc = cli_trace_desc(a);
    vis_scene *scene = world_scene_scene(s->ws);
    if (!a->json) {
        printf("\n%s (%s), traversal %s, scene built in %.0f ms\n", s->backend.name, s->backend.device,
               vc_traversal_run_name((int)a->traversal, s->backend.kind), s->build.total_ms);
        printf("  %-10s %10s %10s %10s %10s %10s\n", "view", "median ms", "min ms", "max ms", "Mrays/s", "visible");
    }
    for (size_t v = 0; v < b->nviews; ++v) {
        view_result *r = &b->results[b->nresults];
        memset(r, 0, sizeof *r);
        r->view = b->views[v].name;
        r->view_index = v;
        r->config = config;
        if (cli_pass_run(s->ctx, scene, &b->views[v].camera, &desc, a->frames, b->ids, b->ids_cap, NULL, 0, &r->t) !=
            VIS_OK)
            return cli_fail_vis(CMD, s->ctx, b->views[v].name);
        vis_draw_entry *e = NULL;
        if (cli_drawlist(s->ctx, scene, b->ids, a->width, a->height, a->ids, 0, &e, &r->visible, NULL) != VIS_OK)
            return cli_fail_vis(CMD, s->ctx, "vis_drawlist_build");
        free(e);
        ++b->nresults;
        if (!a->json) {
            printf("  %-10s %10.3f %10.3f %10.3f %10.1f %10zu\n", r->view, r->t.median_ms, r->t.min_ms, r->t.max_ms,
                   r->t.mrays_per_s, r->visible);
            fflush(stdout);
        }
    }
    return CLI_EXIT_OK;
}

static int same_config(const bench *b, const cli_scene *s)
{
    for (size_t i = 0; i < b->nconfigs; ++i)
        if (strcmp(b->configs[i].backend, s->backend.name) == 0 && b->configs[i].threads == s->backend.threads &&
            strcmp(b->configs[i].device, s->backend.device) == 0)
            return 1;
    return 0;
}

static int run_configs(bench *b, cli_progress *progress)
{
    const cli_args *a = b->a;
    for (size_t bi = 0; bi < a->backend_count; ++bi) {
        for (size_t ti = 0; ti < a->thread_count; ++ti) {
            cli_scene s;
            int rc = cli_scene_open(CMD, &b->world, a->backends[bi], a->threads[ti], a->kd_depth, progress, &s);
            if (rc != CLI_EXIT_OK)
                return rc;
            int cpu = s.backend.kind == VIS_BACKEND_CPU;
            if (same_config(b, &s)) { /* "1,all" on one core; a thread list on OpenCL */
                cli_scene_close(&s);
                if (!cpu)
                    break;
                continue;
            }
            size_t c = b->nconfigs++;
            config_result *cr = &b->configs[c];
            snprintf(cr->backend, sizeof cr->backend, "%s", s.backend.name);
            snprintf(cr->device, sizeof cr->device, "%s", s.backend.device);
            cr->threads = s.backend.threads;
            cr->build_ms = s.build.total_ms;
            rc = run_views(b, &s, c);
            if (rc != CLI_EXIT_OK) {
                cli_scene_close(&s);
                return rc;
            }
            if (cpu && (!b->have_keep || s.backend.threads > b->keep.backend.threads)) {
                if (b->have_keep)
                    cli_scene_close(&b->keep);
                b->keep = s;
                b->keep_config = c;
                b->have_keep = 1;
            } else {
                cli_scene_close(&s);
            }
            if (!cpu)
                break; /* thread counts mean nothing to OpenCL */
        }
    }
    if (!b->have_keep) { /* no CPU configuration asked for: edits still need a scene */
        int rc = cli_scene_open(CMD, &b->world, VIS_BACKEND_CPU, 0, a->kd_depth, progress, &b->keep);
        if (rc != CLI_EXIT_OK)
            return rc;
        b->have_keep = 1;
        b->keep_config = (size_t)-1;
    }
    return CLI_EXIT_OK;
}

/* ---- Embree: the same rays ------------------------------------------------------------- */

static uint64_t count_diff(const uint32_t *x, const uint32_t *y, size_t n)
{
    uint64_t d = 0;
    for (size_t i = 0; i < n; ++i)
        d += x[i] != y[i];
    return d;
}

static const view_result *ours_for(const bench *b, size_t v)
{
    for (size_t i = 0; i < b->nresults; ++i)
        if (b->results[i].config == b->keep_config && b->results[i].view == b->views[v].name)
            return &b->results[i];
    return NULL;
}

static int embree_pass(bench *b, size_t v, int stream, double *med, double *mn, double *mx)
{
    const cli_args *a = b->a;
    char err[512];
    double *t = malloc(a->frames * sizeof *t);
    if (!t)
        return cli_fail(CMD, "out of memory");
    double warm;
    int rc = embree_compare_trace(b->ec, &b->views[v].camera, a->width, a->height, stream, b->ids2, &warm, err,
                                  sizeof err);
    for (uint32_t i = 0; rc == 0 && i < a->frames; ++i)
        rc = embree_compare_trace(b->ec, &b->views[v].camera, a->width, a->height, stream, b->ids2, &t[i], err,
                                  sizeof err);
    if (rc != 0) {
        free(t);
        return cli_fail(CMD, "Embree: %s", err);
    }
    *mn = vc_min(t, a->frames);
    *mx = vc_max(t, a->frames);
    *med = vc_median(t, a->frames);
    free(t);
    return CLI_EXIT_OK;
}

/* Embree's memory for the same quads next to ours: every array the traced scene holds, at its
 * capacity, and what its context's backend keeps beside them (vis_scene_info.bytes and
 * backend_bytes). */
static void print_memory(const bench *b)
{
    double quads = b->info.quads ? (double)b->info.quads : 1.0, mb = 1024.0 * 1024.0;
    uint64_t st = embree_compare_static_bytes(b->ec), dy = embree_compare_dynamic_bytes(b->ec);
    uint64_t ours = b->info.bytes + b->info.backend_bytes;
    printf("  memory: static scene %.1f MiB (%.1f bytes per quad), dynamic %.1f MiB (%.1f); ours %.1f MiB (%.1f)\n",
           (double)st / mb, (double)st / quads, (double)dy / mb, (double)dy / quads, (double)ours / mb,
           (double)ours / quads);
}

static int run_embree(bench *b)
{
    const cli_args *a = b->a;
    char err[512];
    uint32_t threads = b->keep.backend.threads ? b->keep.backend.threads : 1;
    if (!a->json)
        fprintf(stderr, "  building the Embree scenes ...\n");
    if (embree_compare_create(b->keep.ws, threads, &b->ec, err, sizeof err) != 0)
        return cli_fail(CMD, "%s", err);
    /* Our IDs in object mode, to compare pixel by pixel. */
    vis_trace_desc desc = cli_trace_desc(a);
    desc.ids = VIS_IDS_OBJECT;
    size_t n = (size_t)a->width * a->height;
    if (!a->json) {
        printf("\nEmbree %s, %u threads: %llu triangles, static scene (robust, high quality) built in %.0f ms, "
               "dynamic in %.0f ms\n",
               "3", threads, (unsigned long long)embree_compare_triangles(b->ec), embree_compare_static_build_ms(b->ec),
               embree_compare_dynamic_build_ms(b->ec));
        print_memory(b);
        printf("  %-10s %10s %10s %10s %12s %12s %9s %9s\n", "view", "single ms", "stream ms", "ours ms",
               "ours/single", "ours/stream", "diff px", "diff px");
        printf("  %-10s %10s %10s %10s %12s %12s %9s %9s\n", "", "(1M)", "(8x8 1M)", "", "", "", "single", "stream");
    }
    for (size_t v = 0; v < b->nviews; ++v) {
        embree_view *e = &b->ev[v];
        const view_result *ours = ours_for(b, v);
        e->ours_ms = ours ? ours->t.median_ms : 0.0;
        if (vis_trace(b->keep.ctx, world_scene_scene(b->keep.ws), &b->views[v].camera, &desc, b->ids, b->ids_cap, NULL,
                      0) != VIS_OK)
            return cli_fail_vis(CMD, b->keep.ctx, "vis_trace");
        int rc = embree_pass(b, v, 0, &e->single_ms, &e->single_min, &e->single_max);
        if (rc != CLI_EXIT_OK)
            return rc;
        e->diff_single = count_diff(b->ids, b->ids2, n);
        rc = embree_pass(b, v, 1, &e->stream_ms, &e->stream_min, &e->stream_max);
        if (rc != CLI_EXIT_OK)
            return rc;
        e->diff_stream = count_diff(b->ids, b->ids2, n);
        if (!a->json) {
            printf("  %-10s %10.3f %10.3f %10.3f %12.2f %12.2f %9llu %9llu\n", b->views[v].name, e->single_ms,
                   e->stream_ms, e->ours_ms, e->single_ms > 0 ? e->ours_ms / e->single_ms : 0.0,
                   e->stream_ms > 0 ? e->ours_ms / e->stream_ms : 0.0, (unsigned long long)e->diff_single,
                   (unsigned long long)e->diff_stream);
            fflush(stdout);
        }
    }
    return CLI_EXIT_OK;
}

/* ---- output ---------------------------------------------------------------------------- */

static void print_json(const bench *b)
{
    const cli_args *a = b->a;
    json_writer w;
    json_init(&w, stdout);
    json_object_begin(&w, NULL);
    json_string(&w, "command", "bench");
    json_string(&w, "scene", a->scene);
    json_uint(&w, "width", a->width);
    json_uint(&w, "height", a->height);
    json_uint(&w, "frames", a->frames);
    json_string(&w, "traversal", vc_name_of(&vc_traversals, (int)a->traversal));
    json_string(&w, "ids", vc_name_of(&vc_id_modes, (int)a->ids));
    json_uint(&w, "objects", b->info.objects);
    json_uint(&w, "quads", b->info.quads);
    json_uint(&w, "scene_bytes", b->info.bytes);
    json_uint(&w, "backend_bytes", b->info.backend_bytes);
    json_number(&w, "load_ms", b->world.load_ms);
    json_array_begin(&w, "configs");
    for (size_t i = 0; i < b->nconfigs; ++i) {
        json_object_begin(&w, NULL);
        json_string(&w, "backend", b->configs[i].backend);
        json_string(&w, "device", b->configs[i].device);
        json_uint(&w, "threads", b->configs[i].threads);
        json_number(&w, "build_ms", b->configs[i].build_ms);
        json_object_end(&w);
    }
    json_array_end(&w);
    json_array_begin(&w, "views");
    for (size_t i = 0; i < b->nresults; ++i) {
        const view_result *r = &b->results[i];
        const config_result *c = &b->configs[r->config];
        char cam[256];
        cli_camera_format(&b->views[r->view_index].camera, cam, sizeof cam);
        json_object_begin(&w, NULL);
        json_string(&w, "name", r->view);
        json_string(&w, "camera", cam); /* as --camera takes it */
        json_string(&w, "backend", c->backend);
        json_uint(&w, "threads", c->threads);
        json_number(&w, "time_ms", r->t.median_ms);
        json_number(&w, "min_ms", r->t.min_ms);
        json_number(&w, "max_ms", r->t.max_ms);
        json_number(&w, "mrays_per_s", r->t.mrays_per_s);
        json_uint(&w, "visible", r->visible);
        json_object_end(&w);
    }
    json_array_end(&w);
    const edit_result *er = &b->edits;
    if (er->count) {
        json_number(&w, "edit_ms", er->median_ms);
        json_object_begin(&w, "edits");
        json_uint(&w, "count", er->count);
        json_number(&w, "per_s", er->per_s);
        json_number(&w, "median_ms", er->median_ms);
        json_number(&w, "p99_ms", er->p99_ms);
        json_number(&w, "max_ms", er->max_ms);
        json_number(&w, "remesh_median_ms", er->remesh_median_ms);
        json_number(&w, "update_median_ms", er->update_median_ms);
        json_number(&w, "sync_median_ms", er->sync_median_ms);
        json_number(&w, "sync_max_ms", er->sync_max_ms);
        json_number(&w, "chunks_per_edit", er->chunks_per_edit);
        if (er->fresh_bytes) {
            json_uint(&w, "edited_scene_bytes", er->edited_bytes);
            json_uint(&w, "fresh_scene_bytes", er->fresh_bytes);
        }
        if (er->upload) {
            json_string(&w, "upload_device", er->upload_device);
            json_number(&w, "upload_bytes_median", er->upload_median_bytes);
            json_number(&w, "upload_bytes_max", er->upload_max_bytes);
        }
        json_object_end(&w);
    } else {
        json_null(&w, "edit_ms");
    }
    if (b->ec) {
        json_object_begin(&w, "embree");
        json_uint(&w, "threads", b->keep.backend.threads);
        json_uint(&w, "triangles", embree_compare_triangles(b->ec));
        json_number(&w, "build_ms", embree_compare_static_build_ms(b->ec));
        json_number(&w, "dynamic_build_ms", embree_compare_dynamic_build_ms(b->ec));
        json_uint(&w, "static_bytes", embree_compare_static_bytes(b->ec));
        json_uint(&w, "dynamic_bytes", embree_compare_dynamic_bytes(b->ec));
        double ours = 0.0, single = 0.0, stream = 0.0;
        uint64_t diff_single = 0, diff_stream = 0;
        json_array_begin(&w, "views");
        for (size_t v = 0; v < b->nviews; ++v) {
            const embree_view *e = &b->ev[v];
            json_object_begin(&w, NULL);
            json_string(&w, "name", b->views[v].name);
            json_number(&w, "single_ms", e->single_ms);
            json_number(&w, "single_min_ms", e->single_min);
            json_number(&w, "single_max_ms", e->single_max);
            json_number(&w, "stream_ms", e->stream_ms);
            json_number(&w, "stream_min_ms", e->stream_min);
            json_number(&w, "stream_max_ms", e->stream_max);
            json_number(&w, "ours_ms", e->ours_ms);
            json_number(&w, "ratio_single", e->single_ms > 0 ? e->ours_ms / e->single_ms : 0.0);
            json_number(&w, "ratio_stream", e->stream_ms > 0 ? e->ours_ms / e->stream_ms : 0.0);
            json_uint(&w, "diff_pixels_single", e->diff_single);
            json_uint(&w, "diff_pixels_stream", e->diff_stream);
            json_object_end(&w);
            ours += e->ours_ms;
            single += e->single_ms;
            stream += e->stream_ms;
            diff_single += e->diff_single;
            diff_stream += e->diff_stream;
        }
        json_array_end(&w);
        json_number(&w, "single_ms", single / (double)(b->nviews ? b->nviews : 1));
        json_number(&w, "stream_ms", stream / (double)(b->nviews ? b->nviews : 1));
        json_number(&w, "ours_ms", ours / (double)(b->nviews ? b->nviews : 1));
        json_number(&w, "ratio", single > 0 ? ours / single : 0.0);
        json_number(&w, "ratio_stream", stream > 0 ? ours / stream : 0.0);
        json_uint(&w, "diff_pixels_single", diff_single);
        json_uint(&w, "diff_pixels_stream", diff_stream);
        if (er->embree) {
            json_number(&w, "recommit_ms", er->embree_median_ms);
            json_number(&w, "recommit_p99_ms", er->embree_p99_ms);
            json_number(&w, "ours_update_ms", er->update_median_ms);
        }
        json_object_end(&w);
    }
    json_object_end(&w);
}

int cmd_bench(const cli_args *a)
{
    if (a->method == CLI_METHOD_ZBUF)
        return a->effects ? cli_usage_error(CMD, "--effects needs --method ray") : bench_zbuf(a);
    if (a->effects) {
        if (a->compare_embree || a->traversal == CLI_TRAVERSAL_ALL || a->ids == VIS_IDS_LEAF)
            return cli_usage_error(CMD, "--effects takes neither --compare, --traversal all nor --ids leaf");
        return bench_effects(a);
    }
    if (a->compare_embree && !embree_compare_available())
        return cli_usage_error(CMD, "--compare embree is not available in this build (Embree 3 was not found)");
    bench *b = calloc(1, sizeof *b);
    if (!b)
        return cli_fail(CMD, "out of memory");
    b->a = a;
    int rc;
    size_t n = (size_t)a->width * a->height;
    b->ids = malloc(n * sizeof *b->ids);
    b->ids2 = malloc(n * sizeof *b->ids2);
    b->ids_cap = n;
    if (!b->ids || !b->ids2) {
        free(b->ids);
        free(b->ids2);
        free(b);
        return cli_fail(CMD, "out of memory for a %ux%u buffer", a->width, a->height);
    }
    cli_progress progress;
    cli_progress_init(&progress, a->json ? CLI_PROGRESS_AUTO : CLI_PROGRESS_ALWAYS);
    if (!a->json) {
        printf("libvis %s bench: %s, %ux%u, %u frames per view, traversal %s, %s IDs\n", vis_version(), a->scene,
               a->width, a->height, a->frames,
               a->traversal == CLI_TRAVERSAL_ALL ? "all" : vc_name_of(&vc_traversals, (int)a->traversal),
               vc_name_of(&vc_id_modes, (int)a->ids));
        fflush(stdout);
    }
    rc = cli_world_load(CMD, a->scene, &progress, &b->world);
    if (rc != CLI_EXIT_OK)
        goto out;
    b->nviews = vc_camera_path(b->world.world, b->views, VC_MAX_VIEWS);
    if (a->traversal == CLI_TRAVERSAL_ALL) { /* Tables 3 and 4 alone: no edits, no Embree */
        rc = bench_traversal_all(b, &progress);
        goto out;
    }
    b->results = calloc(b->nviews * (sizeof b->configs / sizeof b->configs[0]), sizeof *b->results);
    if (!b->results) {
        rc = cli_fail(CMD, "out of memory");
        goto out;
    }
    rc = run_configs(b, &progress);
    if (rc == CLI_EXIT_OK && vis_scene_get_info(world_scene_scene(b->keep.ws), &b->info) != VIS_OK)
        rc = cli_fail_vis(CMD, b->keep.ctx, "vis_scene_get_info");
    if (rc == CLI_EXIT_OK && !a->json)
        printf("\nscene: %u objects, %llu quads\n", b->info.objects, (unsigned long long)b->info.quads);
    if (rc == CLI_EXIT_OK && a->compare_embree)
        rc = run_embree(b);
    if (rc == CLI_EXIT_OK)
        rc = bench_run_edits(b);
    if (rc == CLI_EXIT_OK && a->json)
        print_json(b);
out:
    embree_compare_destroy(b->ec);
    if (b->have_keep)
        cli_scene_close(&b->keep);
    if (b->world.world)
        cli_world_free(&b->world);
    free(b->results);
    free(b->ids);
    free(b->ids2);
    free(b);
    return rc;
}
