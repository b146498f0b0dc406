/*
 * args.h — the one command-line parser of the `vis` tool. Every command declares which of
 * the options below it accepts (and which take a comma-separated list); the parser checks
 * and converts them all the same way, so `--res 640x480` means the same thing everywhere.
 */
#ifndef VIS_CLI_ARGS_H
#define VIS_CLI_ARGS_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"

/* Exit codes of every command. */
#define CLI_EXIT_OK 0
#define CLI_EXIT_FAILURE 1 /* a library or I/O error                         */
#define CLI_EXIT_USAGE 2   /* bad arguments: the message names the problem   */

/* The options, as bits of cli_command.options. */
enum {
    OPT_SCENE = 1u << 0,
    OPT_CAMERA = 1u << 1,
    OPT_RES = 1u << 2,
    OPT_METHOD = 1u << 3,
    OPT_IDS = 1u << 4,
    OPT_TRAVERSAL = 1u << 5,
    OPT_BACKEND = 1u << 6,
    OPT_THREADS = 1u << 7,
    OPT_REPEAT = 1u << 8,
    OPT_DUMP_IDS = 1u << 9,
    OPT_DUMP_DEPTH = 1u << 10,
    OPT_DUMP_LIST = 1u << 11,
    OPT_PNG = 1u << 12,
    OPT_JSON = 1u << 13,
    OPT_OUT = 1u << 14,
    OPT_FRAMES = 1u << 15,
    OPT_EDITS = 1u << 16,
    OPT_SEED = 1u << 17,
    OPT_COMPARE = 1u << 18,
    OPT_KD_DEPTH = 1u << 19,
    OPT_TRUTH_RES = 1u << 20,
    OPT_SUPERSAMPLE = 1u << 21,
    OPT_MAX_RES = 1u << 22,
    OPT_LEAF_DEPTH = 1u << 23,
    /* The load budget (vw_budget): every command that takes --scene takes these too. */
    OPT_MAX_BYTES = 1u << 24,
    OPT_MAX_VOXELS = 1u << 25,
    OPT_EFFECTS = 1u << 26
};

typedef enum cli_method { CLI_METHOD_RAY = 0, CLI_METHOD_ZBUF } cli_method;

#define CLI_MAX_LIST 8

typedef struct cli_args {
    unsigned given;                 /* OPT_* bits given on the command line              */
    const char *scene;              /* default "gen:default"                             */
    vis_camera camera;              /* valid when OPT_CAMERA is given                    */
    uint32_t width, height;         /* default 512 x 512                                 */
    cli_method method;              /* default ray                                       */
    vis_id_mode ids;                /* default object                                    */
    vis_traversal traversal;        /* default stack                                     */
    vis_backend_kind backends[CLI_MAX_LIST]; /* default {auto}                           */
    size_t backend_count;
    uint32_t threads[CLI_MAX_LIST]; /* 0 = every core ("all"); default {0}, bench {1, 0} */
    size_t thread_count;
    uint32_t repeat;                /* default 1 (run: 5)                                */
    uint32_t frames;                /* default 20                                        */
    uint32_t edits;                 /* default 1000                                      */
    uint64_t seed;                  /* default 1                                         */
    uint32_t kd_depth;              /* default 0 (libvis chooses)                        */
    uint32_t truth_width, truth_height; /* accuracy: the display, default 1920 x 1080    */
    uint32_t supersample;           /* accuracy: truth samples per pixel side, default 1 */
    uint32_t max_res;               /* accuracy: largest ray-pass rung, default 2048     */
    uint32_t leaf_depth;            /* accuracy: kd depth of the leaf-ID scene (0: auto) */
    uint64_t max_bytes, max_voxels; /* the world's budget (vw_budget); 0: the defaults   */
    const char *dump_ids, *dump_depth, *dump_list, *png, *out;
    uint32_t effects;               /* --effects: VIS_EFFECT_* bits, default 0           */
    double light[3];                /* shadows:DX,DY,DZ                                  */
    double fog;                     /* fog:DIST                                          */
    int compare_embree;
    int json;
} cli_args;

typedef struct cli_command {
    const char *name;               /* "cull"                                            */
    const char *summary;            /* one line for `vis --help`                         */
    unsigned options;               /* OPT_* accepted                                    */
    unsigned list_options;          /* of those, the ones that take a comma-separated list */
    unsigned required;              /* OPT_* that must be given                          */
    int (*run)(const cli_args *args);
} cli_command;

/* Parses argv[1..argc) (argv[0] is the command name) into `out`, with defaults filled in.
 * Returns CLI_EXIT_OK, CLI_EXIT_USAGE after printing the problem on stderr, or -1 when
 * --help was asked for and printed (the caller exits 0). */
int cli_args_parse(const cli_command *cmd, int argc, char **argv, cli_args *out);

/* Prints the command's usage (its options, one per line) to `f`. */
void cli_args_usage(const cli_command *cmd, void *f);

/* Reports a usage error the way the parser does: "vis CMD: MESSAGE" on stderr, and returns
 * CLI_EXIT_USAGE. */
int cli_usage_error(const char *command, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

#endif
