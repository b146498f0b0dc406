/* bench.h — what the parts of `vis bench` share: the results of each part, in one struct. */
#ifndef VIS_CLI_BENCH_H
#define VIS_CLI_BENCH_H

#include <stddef.h>
#include <stdint.h>

#include "camera_path.h"
#include "cli.h"
#include "embree_compare.h"
#include "pass.h"

#define CMD "bench"

typedef struct view_result {
    const char *view;
    size_t view_index;
    size_t config;          /* index into bench.configs */
    cli_pass_times t;
    size_t visible;
} view_result;

typedef struct config_result {
    char backend[64];
    char device[128];
    uint32_t threads;
    double build_ms;
} config_result;

typedef struct embree_view {
    double single_ms, single_min, single_max;
    double stream_ms, stream_min, stream_max;
    double ours_ms;
    uint64_t diff_single, diff_stream;
} embree_view;

typedef struct edit_result {
    uint32_t count;
    double median_ms, p99_ms, max_ms, per_s;
    double update_median_ms, remesh_median_ms; /* leaf update alone, remesh alone */
    double sync_median_ms, sync_max_ms; /* vis_scene_prepare after each edit (the next pass's share) */
    double chunks_per_edit;
    int embree;                                /* the Embree columns below are filled */
    double embree_median_ms, embree_p99_ms;
    int upload;                                /* an OpenCL copy mirrored the edits      */
    char upload_device[128];
    double upload_median_bytes, upload_max_bytes, scene_bytes;
    uint64_t edited_bytes, fresh_bytes;        /* the edited scene, and one built afresh from
                                                  the edited world (0: not measured)       */
} edit_result;

typedef struct bench {
    const cli_args *a;
    cli_world world;
    vc_view views[VC_MAX_VIEWS];
    size_t nviews;
    config_result configs[2 * CLI_MAX_LIST * CLI_MAX_LIST];
    size_t nconfigs;
    view_result *results;
    size_t nresults;
    cli_scene keep;          /* the CPU scene with the most threads: edits and Embree run on it */
    size_t keep_config;
    int have_keep;
    vis_scene_info info;
    uint32_t *ids, *ids2;
    size_t ids_cap;          /* elements of ids and of ids2                                    */
    /* Embree */
    embree_compare *ec;
    embree_view ev[VC_MAX_VIEWS];
    edit_result edits;
} bench;

/* K random single-voxel edits on b->keep (and on Embree's dynamic scene when b->ec is set),
 * each timed on its own, into b->edits. Prints its summary unless --json. */
int bench_run_edits(bench *b);

#endif
