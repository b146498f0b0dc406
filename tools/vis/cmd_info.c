/* cmd_info.c — `vis info`: what a scene spec gives (world, meshes, kd-tree, memory). */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "json.h"
#include "timer.h"

#define CMD "info"

/* The grid lines of a .vdb file ("name type class bbox active_voxels"), or "" if none. */
static void describe_vdb(const char *path, char *out, size_t size)
{
    vw_error err;
    out[0] = '\0';
    if (vw_vdb_describe_file(path, out, size, &err) != VW_OK)
        snprintf(out, size, "(could not describe the grids: %s)", err.message);
}

int cmd_info(const cli_args *a)
{
    cli_progress progress;
    cli_progress_init(&progress, CLI_PROGRESS_AUTO);
    cli_world world;
    int rc = cli_world_load(CMD, a->scene, &progress, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    /* No rays are traced, but the CPU backend prepares its copy of the scene (what the first
     * trace would do), on every core, so that the memory counts what tracing holds. */
    cli_scene s;
    rc = cli_scene_open(CMD, &world, VIS_BACKEND_CPU, 0, a->kd_depth, &progress, &s);
    if (rc != CLI_EXIT_OK) {
        cli_world_free(&world);
        return rc;
    }
    vw_world_info wi;
    vw_world_get_info(world.world, &wi);
    vis_scene_info si;
    double p0 = vc_now_ms();
    if (vis_scene_prepare(s.ctx, world_scene_scene(s.ws)) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_scene_prepare");
        goto done;
    }
    double prepare_ms = vc_now_ms() - p0;
    if (vis_scene_get_info(world_scene_scene(s.ws), &si) != VIS_OK) {
        rc = cli_fail_vis(CMD, s.ctx, "vis_scene_get_info");
        goto done;
    }
    double lo[3], hi[3];
    world_scene_bounds(world.world, lo, hi);
    static char grids[16384];
    int is_vdb = cli_ends_with(a->scene, ".vdb");
    if (is_vdb)
        describe_vdb(a->scene, grids, sizeof grids);

    if (a->json) {
        json_writer w;
        json_init(&w, stdout);
        json_object_begin(&w, NULL);
        json_string(&w, "command", "info");
        json_string(&w, "scene", a->scene);
        json_object_begin(&w, "bounds");
        json_vec3(&w, "min", lo);
        json_vec3(&w, "max", hi);
        json_object_end(&w);
        json_uint(&w, "chunk_size", (uint64_t)wi.chunk_size);
        json_uint(&w, "chunks", wi.chunk_count);
        json_uint(&w, "nonempty_chunks", wi.nonempty_chunks);
        json_array_begin(&w, "chunk_grid");
        for (int i = 0; i < 3; ++i)
            json_int(&w, NULL, wi.chunks[i]);
        json_array_end(&w);
        json_uint(&w, "objects", si.objects);
        json_uint(&w, "voxels", wi.solid_voxels);
        json_uint(&w, "quads", si.quads);
        json_uint(&w, "triangles", si.triangles);
        json_uint(&w, "kd_depth", si.kd_depth);
        json_uint(&w, "nodes", si.nodes);
        json_uint(&w, "leaves", si.leaves);
        json_uint(&w, "bytes", si.bytes + si.backend_bytes + wi.bytes);
        json_uint(&w, "scene_bytes", si.bytes);
        json_uint(&w, "backend_bytes", si.backend_bytes);
        json_uint(&w, "world_bytes", wi.bytes);
        /* Everything tracing the scene holds (tree, leaves, quads, tables, slack, and the CPU
         * backend's flags and labels), per quad. */
        json_number(&w, "bytes_per_quad", si.quads ? (double)(si.bytes + si.backend_bytes) / (double)si.quads : 0.0);
        json_number(&w, "load_ms", world.load_ms);
        json_number(&w, "build_ms", s.build.total_ms);
        json_number(&w, "prepare_ms", prepare_ms);
        if (is_vdb) {
            json_array_begin(&w, "grids");
            for (char *line = grids; *line;) {
                char *nl = strchr(line, '\n');
                if (nl)
                    *nl = '\0';
                if (*line)
                    json_string(&w, NULL, line);
                if (!nl)
                    break;
                line = nl + 1;
            }
            json_array_end(&w);
        }
        json_object_end(&w);
    } else {
        printf("scene       %s\n", a->scene);
        printf("bounds      min (%.0f, %.0f, %.0f)  max (%.0f, %.0f, %.0f)\n", lo[0], lo[1], lo[2], hi[0], hi[1],
               hi[2]);
        printf("chunks      %u (%d x %d x %d of %d^3 voxels), %u non-empty\n", wi.chunk_count, wi.chunks[0],
               wi.chunks[1], wi.chunks[2], wi.chunk_size, wi.nonempty_chunks);
        printf("voxels      %llu solid\n", (unsigned long long)wi.solid_voxels);
        printf("objects     %u\n", si.objects);
        printf("quads       %llu   triangles %llu\n", (unsigned long long)si.quads,
               (unsigned long long)si.triangles);
        printf("kd-tree     depth %u, %u nodes, %u leaves\n", si.kd_depth, si.nodes, si.leaves);
        printf("memory      %.1f MiB (scene %.1f MiB, CPU backend %.1f MiB, world %.1f MiB)\n",
               (double)(si.bytes + si.backend_bytes + wi.bytes) / 1048576.0, (double)si.bytes / 1048576.0,
               (double)si.backend_bytes / 1048576.0, (double)wi.bytes / 1048576.0);
        if (si.quads)
            printf("            scene and CPU backend %.2f bytes per quad\n",
                   (double)(si.bytes + si.backend_bytes) / (double)si.quads);
        printf("time        loaded in %.0f ms, scene built in %.0f ms, prepared for tracing in %.0f ms\n",
               world.load_ms, s.build.total_ms, prepare_ms);
        if (is_vdb)
            printf("grids\n%s%s", grids, grids[0] && grids[strlen(grids) - 1] != '\n' ? "\n" : "");
    }
done:
    cli_scene_close(&s);
    cli_world_free(&world);
    return rc;
}
