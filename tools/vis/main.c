/* main.c — `vis COMMAND [options]`: dispatch to the commands (one file each). */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "vis/vis.h"

#define RAY_PASS_OPTS (OPT_SCENE | OPT_RES | OPT_TRAVERSAL | OPT_BACKEND | OPT_THREADS | OPT_KD_DEPTH)

const cli_command cli_commands[] = {
    {"cull", "Which objects does one camera see? One ray pass (or the z-buffer culler) and its draw list.",
     RAY_PASS_OPTS | OPT_CAMERA | OPT_METHOD | OPT_IDS | OPT_REPEAT | OPT_DUMP_IDS | OPT_DUMP_DEPTH | OPT_DUMP_LIST |
         OPT_PNG | OPT_JSON | OPT_EFFECTS,
     0, 0, cmd_cull},
    {"run", "Generate the world (progress on stderr) and cull it along the camera path, view by view.",
     RAY_PASS_OPTS | OPT_IDS | OPT_REPEAT | OPT_EFFECTS, 0, 0, cmd_run},
    {"bench", "Time the camera path (N frames per view), single-voxel edits, and optionally Embree.",
     RAY_PASS_OPTS | OPT_METHOD | OPT_FRAMES | OPT_EDITS | OPT_SEED | OPT_COMPARE | OPT_JSON | OPT_EFFECTS,
     OPT_THREADS | OPT_BACKEND, 0, cmd_bench},
    {"accuracy", "What does accuracy cost in time? Every method and resolution against the display's truth.",
     OPT_SCENE | OPT_TRAVERSAL | OPT_BACKEND | OPT_THREADS | OPT_KD_DEPTH | OPT_OUT | OPT_FRAMES | OPT_REPEAT |
         OPT_TRUTH_RES | OPT_SUPERSAMPLE | OPT_MAX_RES | OPT_LEAF_DEPTH | OPT_JSON | OPT_EFFECTS,
     0, 0, cmd_accuracy},
    {"info", "Describe a scene: bounds, chunks, voxels, quads, kd-tree, memory (and .vdb grids).",
     OPT_SCENE | OPT_KD_DEPTH | OPT_JSON, 0, 0, cmd_info},
    {"export", "Write the world as .obj (the meshes exactly as traced) or .vox.", OPT_SCENE | OPT_OUT, 0, OPT_OUT,
     cmd_export},
};
const size_t cli_command_count = sizeof cli_commands / sizeof cli_commands[0];

static void usage(FILE *f)
{
    fprintf(f, "usage: vis COMMAND [options]   (vis COMMAND --help for its options)\n\ncommands:\n");
    for (size_t i = 0; i < cli_command_count; ++i)
        fprintf(f, "  %-8s %s\n", cli_commands[i].name, cli_commands[i].summary);
    fprintf(f, "  %-8s %s\n", "query",
            "Server queries: replay (or simulate) players and report what each one sees, tick by tick.");
    fprintf(f, "\nSPEC: a .vox or .vdb file, or a generator such as gen:terrain:size=512x128x512:seed=1\n"
               "      (gen:terrain, gen:city, gen:maze; gen:default is the default world).\n"
               "      --max-bytes N and --max-voxels N bound what loading it may take (defaults 2G and\n"
               "      2^30); a SPEC that needs more fails with 'over budget' and the numbers.\n"
               "exit codes: 0 ok, 1 library or I/O error, 2 bad arguments.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return CLI_EXIT_USAGE;
    }
    const char *name = argv[1];
    if (strcmp(name, "-h") == 0 || strcmp(name, "--help") == 0 || strcmp(name, "help") == 0) {
        usage(stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(name, "--version") == 0 || strcmp(name, "version") == 0) {
        printf("vis %s\n", vis_version());
        return CLI_EXIT_OK;
    }
    if (strcmp(name, "query") == 0)
        return cmd_query(argc - 1, argv + 1); /* its own options (tools/vis/cmd_query.c) */
    for (size_t i = 0; i < cli_command_count; ++i) {
        if (strcmp(cli_commands[i].name, name) != 0)
            continue;
        cli_args args;
        int rc = cli_args_parse(&cli_commands[i], argc - 1, argv + 1, &args);
        if (rc < 0)
            return CLI_EXIT_OK; /* --help */
        if (rc != CLI_EXIT_OK)
            return rc;
        cli_world_set_budget(args.max_bytes, args.max_voxels);
        cli_world_set_threads(args.threads, args.thread_count);
        return cli_commands[i].run(&args);
    }
    fprintf(stderr, "vis: unknown command '%s'\n\n", name);
    usage(stderr);
    return CLI_EXIT_USAGE;
}
