/* bench_zbuf.h — `vis bench --method zbuf`: the software z-buffer culler timed along the
 * camera path. */
#ifndef VIS_CLI_BENCH_ZBUF_H
#define VIS_CLI_BENCH_ZBUF_H

#include "args.h"

/* The whole command for --method zbuf: each view of the camera path culled --frames times
 * (after a warm-up) at --res, or at 512x512 and 256x128 when --res is not given. */
int bench_zbuf(const cli_args *args);

#endif
