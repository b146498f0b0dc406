/* cmd_run.c — `vis run` (what `make run` does): generate the world with a progress bar, then
 * cull it along the camera path, printing what each view sees and how fast. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera_path.h"
#include "cli.h"
#include "commands.h"
#include "names.h"
#include "pass.h"

#define CMD "run"
#define RUN_DEFAULT_REPEAT 5

/* One view with --effects: the pass, its draw list with reasons, one line. */
static int run_effects_view(const cli_args *a, cli_scene *s, const vc_view *view, uint32_t objects, cli_pass_times *t)
{
    vis_scene *scene = world_scene_scene(s->ws);
    cli_effect_buffers fb;
    size_t cap = vis_drawlist_bound(scene);
    vis_effect_entry *e = malloc((cap ? cap : 1) * sizeof *e);
    int rc = CLI_EXIT_OK;
    if (cli_effect_buffers_alloc(&fb, a->width, a->height) != 0 || !e) {
        rc = cli_fail(CMD, "out of memory for a %ux%u pass with effects", a->width, a->height);
        goto done;
    }
    vis_trace_desc desc = cli_trace_desc(a);
    size_t count = 0;
    vis_effect_buffers lb = fb.b;
    if (!(a->effects & VIS_EFFECT_SEE_THROUGH))
        lb.see_through = NULL;
    if (!(a->effects & VIS_EFFECT_REFLECT))
        lb.reflection = NULL;
    if (!(a->effects & VIS_EFFECT_SHADOWS))
        lb.shadow = NULL;
    if (cli_effects_run(s->ctx, scene, &view->camera, &desc, a->repeat, &fb.b, t) != VIS_OK ||
        vis_drawlist_build_effects(s->ctx, scene, &lb, a->width, a->height, VC_SEE_THROUGH_LAYERS, e, cap, &count) !=
            VIS_OK) {
        rc = cli_fail_vis(CMD, s->ctx, view->name);
        goto done;
    }
    uint32_t per[VIS_REASON_COUNT] = {0};
    for (size_t i = 0; i < count; ++i)
        for (int k = 0; k < VIS_REASON_COUNT; ++k)
            per[k] += (e[i].reasons >> k) & 1u;
    char visible[48], reasons[64];
    snprintf(visible, sizeof visible, "%zu / %u", count, objects);
    snprintf(reasons, sizeof reasons, "%u/%u/%u/%u", per[0], per[1], per[2], per[3]);
    printf("  %-10s %18s %10.2f %10.1f %24s\n", view->name, visible, t->median_ms, t->mrays_per_s, reasons);
    fflush(stdout);
done:
    cli_effect_buffers_free(&fb);
    free(e);
    return rc;
}

int cmd_run(const cli_args *a)
{
    if (a->effects && a->ids == VIS_IDS_LEAF)
        return cli_usage_error(CMD, "--effects needs --ids object (effects buffers hold object IDs)");
    uint32_t repeat = (a->given & OPT_REPEAT) ? a->repeat : RUN_DEFAULT_REPEAT;
    printf("libvis %s: culling %s along the camera path\n", vis_version(), a->scene);
    fflush(stdout);
    cli_progress progress;
    cli_progress_init(&progress, CLI_PROGRESS_ALWAYS);
    cli_world world;
    int rc = cli_world_load(CMD, a->scene, &progress, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    cli_scene s;
    rc = cli_scene_open(CMD, &world, a->backends[0], a->threads[0], a->kd_depth, &progress, &s);
    if (rc != CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }
    vis_scene *scene = world_scene_scene(s.ws);
    vis_scene_info si;
    vw_world_info wi;
    vw_world_get_info(world.world, &wi);
    uint32_t *ids = malloc((size_t)a->width * a->height * sizeof *ids);
    if (!ids) {
        rc = cli_fail(CMD, "out of memory for a %ux%u buffer", a->width, a->height);
        goto done;
    }
    if (vis_scene_get_info(scene, &si) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_info");
        goto done;
    }
    printf("world     %d x %d x %d voxels, %u chunks of %d^3 (%u non-empty), %llu solid voxels\n", wi.size[0],
           wi.size[1], wi.size[2], wi.chunk_count, wi.chunk_size, wi.nonempty_chunks,
           (unsigned long long)wi.solid_voxels);
    printf("scene     %u objects, %llu quads, kd-tree depth %u (%u leaves), %.1f MiB; generated in %.0f ms, "
           "meshed and built in %.0f ms\n",
           si.objects, (unsigned long long)si.quads, si.kd_depth, si.leaves, (double)si.bytes / 1048576.0,
           world.load_ms, s.build.total_ms);
    printf("backend   %s (%s)%s%s\n", s.backend.name, s.backend.device, s.backend.reason[0] ? ": " : "",
           s.backend.reason);
    printf("pass      %ux%u %s IDs, traversal %s, median of %u passes per view\n\n", a->width, a->height,
           vc_name_of(&vc_id_modes, (int)a->ids), vc_traversal_run_name((int)a->traversal, s.backend.kind), repeat);
    if (a->effects) {
        char names[128];
        vc_effects_format(a->effects, names, sizeof names);
        printf("effects   %s: objects per reason (direct, see-through, reflection, shadow caster)\n\n", names);
        printf("  %-10s %18s %10s %10s %24s\n", "view", "visible objects", "ms/pass", "Mrays/s", "direct/seen/refl/cast");
    } else {
        printf("  %-10s %18s %10s %10s\n", "view", "visible objects", "ms/pass", "Mrays/s");
    }

    vc_view views[VC_MAX_VIEWS];
    size_t nviews = vc_camera_path(world.world, views, VC_MAX_VIEWS);
    vis_trace_desc desc = cli_trace_desc(a);
    double total_ms = 0.0;
    for (size_t v = 0; v < nviews && a->effects; ++v) {
        cli_pass_times t;
        if (run_effects_view(a, &s, &views[v], si.objects, &t) != CLI_EXIT_OK) {
            rc = CLI_EXIT_FAILURE;
            goto done;
        }
        total_ms += t.median_ms;
    }
    for (size_t v = 0; v < nviews && !a->effects; ++v) {
        cli_pass_times t;
        if (cli_pass_run(s.ctx, scene, &views[v].camera, &desc, repeat, ids, (size_t)a->width * a->height, NULL, 0,
                         &t) != VIS_OK) {
            rc = cli_fail_vis(CMD, s.ctx, views[v].name);
            goto done;
        }
        vis_draw_entry *entries = NULL;
        size_t count = 0;
        if (cli_drawlist(s.ctx, scene, ids, a->width, a->height, a->ids, 0, &entries, &count, NULL) != VIS_OK) {
            rc = cli_fail_vis(CMD, s.ctx, "vis_drawlist_build");
            goto done;
        }
        free(entries);
        char visible[48];
        snprintf(visible, sizeof visible, "%zu / %u", count, si.objects);
        printf("  %-10s %18s %10.2f %10.1f\n", views[v].name, visible, t.median_ms, t.mrays_per_s);
        fflush(stdout);
        total_ms += t.median_ms;
    }
    if (nviews)
        printf("\n  %zu views, mean %.2f ms per pass, %.1f Mrays/s\n", nviews, total_ms / (double)nviews,
               (double)a->width * a->height * (double)nviews / (total_ms * 1e3));
done:
    free(ids);
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}
