/* cli.h — what the `vis` commands share: opening a context, loading a world with a progress
 * bar, building its scene, and reporting errors with the right exit code. */
#ifndef VIS_CLI_CLI_H
#define VIS_CLI_CLI_H

#include <stddef.h>
#include <stdint.h>

#include "args.h"
#include "progress.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

/* A loaded world and its scene on one context. */
typedef struct cli_world {
    vw_world *world;
    double load_ms;            /* vw_world_from_spec                                        */
} cli_world;

typedef struct cli_scene {
    vis_context *ctx;
    vis_backend_info backend;
    world_scene *ws;
    world_scene_stats build;   /* meshing + upload of every chunk                           */
} cli_scene;

/* Creates a context for (backend, threads). Prints "vis CMD: ..." and returns
 * CLI_EXIT_FAILURE when the library refuses. */
int cli_context_open(const char *cmd, vis_backend_kind backend, uint32_t threads, vis_context **out,
                     vis_backend_info *out_info);

/* Loads a world from SPEC, drawing progress on `p` (may be NULL). Returns CLI_EXIT_USAGE
 * for a malformed spec, CLI_EXIT_FAILURE for I/O and format errors, after printing why. */
int cli_world_load(const char *cmd, const char *spec, cli_progress *p, cli_world *out);
/* The budget cli_world_load passes to the library (0 = its default); main sets it from
 * --max-bytes and --max-voxels. A load over it fails with CLI_EXIT_FAILURE and the numbers. */
void cli_world_set_budget(uint64_t max_bytes, uint64_t max_voxels);
/* The threads cli_world_load generates on and cli_scene_open meshes on: the largest of the
 * command's --threads values (0 = every core); main sets it after parsing. */
void cli_world_set_threads(const uint32_t *threads, size_t count);
void cli_world_free(cli_world *w);

/* Opens a context and builds the world's scene on it (progress "meshing" on p). */
int cli_scene_open(const char *cmd, const cli_world *w, vis_backend_kind backend, uint32_t threads,
                   uint32_t kd_depth, cli_progress *p, cli_scene *out);
void cli_scene_close(cli_scene *s);

/* Prints "vis CMD: WHAT: <the context's last error>" on stderr and returns CLI_EXIT_FAILURE. */
int cli_fail_vis(const char *cmd, const vis_context *ctx, const char *what);

/* Prints "vis CMD: MESSAGE" on stderr and returns CLI_EXIT_FAILURE. */
int cli_fail(const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Checks the camera against the library's rules; a camera it rejects is a usage error
 * (CLI_EXIT_USAGE, the library's message on stderr). */
int cli_camera_check(const char *cmd, vis_context *ctx, const vis_camera *camera);

/* "EX,EY,EZ,TX,TY,TZ,FOVY" of a camera, for output. */
void cli_camera_format(const vis_camera *camera, char *buf, size_t size);

/* Writes `size` bytes to a file (out_file.h: a failure never destroys what was there); prints
 * the error and returns CLI_EXIT_FAILURE on failure. */
int cli_write_file(const char *cmd, const char *path, const void *data, size_t size);


/* 1 when `s` ends with `suffix`, ignoring ASCII case (".VOX" matches ".vox"). */
int cli_ends_with(const char *s, const char *suffix);

/* 1 when `s` ends with `suffix`, ignoring ASCII case (".VOX" matches ".vox"). */
int cli_ends_with(const char *s, const char *suffix);

#endif
