/* bench_effects.c — `vis bench --effects LIST` (bench_effects.h; docs/effects.md). */
#include "bench_effects.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_path.h"
#include "cli.h"
#include "json.h"
#include "names.h"
#include "pass.h"

#define CMD "bench"

/* Columns: the plain pass, the plain stack method, then effect sets. */
enum { COL_PLAIN = 0, COL_STACK, COL_FIRST_SET, MAX_COLS = COL_FIRST_SET + 5 };

typedef struct fx_cell {
    cli_pass_times t;
    uint64_t secondary;
} fx_cell;

int bench_effects(const cli_args *a)
{
    uint32_t sets[5], nsets = 0;
    static const uint32_t bits[4] = {VIS_EFFECT_SEE_THROUGH, VIS_EFFECT_REFLECT, VIS_EFFECT_SHADOWS, VIS_EFFECT_FOG};
    for (int i = 0; i < 4; ++i)
        if (a->effects & bits[i])
            sets[nsets++] = bits[i];
    if (nsets > 1)
        sets[nsets++] = a->effects;
    cli_progress progress;
    cli_progress_init(&progress, a->json ? CLI_PROGRESS_AUTO : CLI_PROGRESS_ALWAYS);
    cli_world world;
    int rc = cli_world_load(CMD, a->scene, &progress, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    cli_scene s;
    if ((rc = cli_scene_open(CMD, &world, a->backends[0], a->threads[a->thread_count - 1], a->kd_depth, &progress,
                             &s)) != CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }
    vc_view views[VC_MAX_VIEWS];
    size_t nviews = vc_camera_path(world.world, views, VC_MAX_VIEWS);
    fx_cell *cells = calloc(nviews * MAX_COLS, sizeof *cells);
    cli_effect_buffers fb;
    if (cli_effect_buffers_alloc(&fb, a->width, a->height) != 0 || !cells) {
        rc = cli_fail(CMD, "out of memory for a %ux%u pass with effects", a->width, a->height);
        goto out;
    }
    vis_scene *scene = world_scene_scene(s.ws);
    size_t n = (size_t)a->width * a->height;
    char names[128];
    vc_effects_format(a->effects, names, sizeof names);
    if (!a->json) {
        printf("libvis %s bench --effects %s: %s, %ux%u, %u frames per view, %s (%s)\n", vis_version(), names,
               a->scene, a->width, a->height, a->frames, s.backend.name, s.backend.device);
        printf("  %-10s %22s %22s", "view", vc_traversal_run_name((int)a->traversal, s.backend.kind), "stack");
        for (uint32_t k = 0; k < nsets; ++k) {
            char nm[128];
            vc_effects_format(sets[k], nm, sizeof nm);
            printf(" %30s", k + 1 == nsets && nsets > 1 ? "all listed" : nm);
        }
        printf("\n  %-10s %22s %22s", "", "median (min-max) ms", "median (min-max) ms");
        for (uint32_t k = 0; k < nsets; ++k)
            printf(" %30s", "median (min-max) ms, 2nd rays");
        printf("\n");
    }
    for (size_t v = 0; v < nviews && rc == CLI_EXIT_OK; ++v) {
        fx_cell *c = &cells[v * MAX_COLS];
        cli_args plain = *a;
        plain.effects = 0;
        vis_trace_desc d = cli_trace_desc(&plain);
        if (cli_pass_run(s.ctx, scene, &views[v].camera, &d, a->frames, fb.b.ids, n, NULL, 0, &c[COL_PLAIN].t) !=
            VIS_OK) {
            rc = cli_fail_vis(CMD, s.ctx, views[v].name);
            break;
        }
        d.traversal = VIS_TRAVERSAL_STACK;
        if (cli_pass_run(s.ctx, scene, &views[v].camera, &d, a->frames, fb.b.ids, n, NULL, 0, &c[COL_STACK].t) !=
            VIS_OK) {
            rc = cli_fail_vis(CMD, s.ctx, views[v].name);
            break;
        }
        for (uint32_t k = 0; k < nsets; ++k) {
            cli_args one = *a;
            one.effects = sets[k];
            vis_trace_desc e = cli_trace_desc(&one);
            fx_cell *cell = &c[COL_FIRST_SET + k];
            vis_timing tm;
            if (cli_effects_run(s.ctx, scene, &views[v].camera, &e, a->frames, &fb.b, &cell->t) != VIS_OK ||
                vis_context_last_timing(s.ctx, &tm) != VIS_OK) {
                rc = cli_fail_vis(CMD, s.ctx, views[v].name);
                break;
            }
            cell->secondary = tm.secondary_rays;
        }
        if (rc != CLI_EXIT_OK || a->json)
            continue;
        printf("  %-10s", views[v].name);
        for (uint32_t k = 0; k < COL_FIRST_SET + nsets; ++k) {
            char txt[64];
            int len = snprintf(txt, sizeof txt, "%.1f (%.1f-%.1f)", c[k].t.median_ms, c[k].t.min_ms, c[k].t.max_ms);
            if (k >= COL_FIRST_SET && len > 0)
                snprintf(txt + len, sizeof txt - (size_t)len, ", %llu", (unsigned long long)c[k].secondary);
            printf(" %*s", k < COL_FIRST_SET ? 22 : 30, txt);
        }
        printf("\n");
        fflush(stdout);
    }
    if (rc == CLI_EXIT_OK && a->json) {
        json_writer w;
        json_init(&w, stdout);
        json_object_begin(&w, NULL);
        json_string(&w, "command", "bench");
        json_string(&w, "scene", a->scene);
        json_string(&w, "effects", names);
        json_uint(&w, "width", a->width);
        json_uint(&w, "height", a->height);
        json_uint(&w, "frames", a->frames);
        json_string(&w, "backend", s.backend.name);
        json_string(&w, "device", s.backend.device);
        json_string(&w, "traversal", vc_traversal_run_name((int)a->traversal, s.backend.kind));
        json_array_begin(&w, "views");
        for (size_t v = 0; v < nviews; ++v) {
            const fx_cell *c = &cells[v * MAX_COLS];
            json_object_begin(&w, NULL);
            json_string(&w, "name", views[v].name);
            json_number(&w, "plain_ms", c[COL_PLAIN].t.median_ms);
            json_number(&w, "plain_min_ms", c[COL_PLAIN].t.min_ms);
            json_number(&w, "plain_max_ms", c[COL_PLAIN].t.max_ms);
            json_number(&w, "stack_ms", c[COL_STACK].t.median_ms);
            json_array_begin(&w, "sets");
            for (uint32_t k = 0; k < nsets; ++k) {
                char nm[128];
                vc_effects_format(sets[k], nm, sizeof nm);
                const fx_cell *x = &c[COL_FIRST_SET + k];
                json_object_begin(&w, NULL);
                json_string(&w, "effects", nm);
                json_number(&w, "time_ms", x->t.median_ms);
                json_number(&w, "min_ms", x->t.min_ms);
                json_number(&w, "max_ms", x->t.max_ms);
                json_uint(&w, "secondary_rays", x->secondary);
                json_object_end(&w);
            }
            json_array_end(&w);
            json_object_end(&w);
        }
        json_array_end(&w);
        json_object_end(&w);
    }
out:
    cli_effect_buffers_free(&fb);
    free(cells);
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}
