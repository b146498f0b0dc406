/* bench_traversal.h — `vis bench --traversal all`: every traversal method over the camera
 * path per backend (Chang & Ihm 2010, Table 3) and the rope memory of the scene (Table 4). */
#ifndef VIS_CLI_BENCH_TRAVERSAL_H
#define VIS_CLI_BENCH_TRAVERSAL_H

#include "bench.h"
#include "progress.h"

/* cli_args.traversal when `--traversal all` was given (bench only): no vis_traversal and no
 * VC_TRAVERSAL(method, N) value (those keep the low byte below 0xFF). */
#define CLI_TRAVERSAL_ALL ((vis_traversal)0xFF)

/* The methods `all` runs, in table order, as --traversal names (the one list). */
extern const char *const bench_traversal_methods[];
extern const size_t bench_traversal_method_count;

/* Runs the tables on b->world and b->views (loaded by cmd_bench) for every backend of
 * --backend (an OpenCL backend that cannot start is skipped with a line on stderr), prints
 * them, or one JSON object with `traversal_table` and `rope_memory` under --json. */
int bench_traversal_all(bench *b, cli_progress *progress);

#endif
