/* cmd_export.c — `vis export`: the world as Wavefront OBJ (the meshes exactly as traced, one
 * `o ID` group per object) or as MagicaVoxel .vox. */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "timer.h"

#define CMD "export"

int cmd_export(const cli_args *a)
{
    int obj = cli_ends_with(a->out, ".obj"), vox = cli_ends_with(a->out, ".vox");
    if (!obj && !vox)
        return cli_usage_error(CMD, "--out %s: the file name must end in .obj or .vox", a->out);
    cli_progress progress;
    cli_progress_init(&progress, CLI_PROGRESS_AUTO);
    cli_world world;
    int rc = cli_world_load(CMD, a->scene, &progress, &world);
    if (rc != CLI_EXIT_OK)
        return rc;
    vw_error err;
    err.message[0] = '\0';
    double t0 = vc_now_ms();
    vw_status s = obj ? vw_export_obj(world.world, a->out, &err) : vw_vox_save_file(world.world, a->out, &err);
    double ms = vc_now_ms() - t0;
    if (s != VW_OK)
        rc = cli_fail(CMD, "writing %s: %s%s%s", a->out, vw_status_string(s), err.message[0] ? ": " : "",
                      err.message);
    else
        fprintf(stderr, "vis export: wrote %s (%s) in %.0f ms\n", a->out, obj ? "Wavefront OBJ" : "MagicaVoxel .vox",
                ms);
    cli_world_free(&world);
    return rc;
}
