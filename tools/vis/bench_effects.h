/* bench_effects.h — `vis bench --effects LIST`: each effect's cost along the camera path. */
#ifndef VIS_CLI_BENCH_EFFECTS_H
#define VIS_CLI_BENCH_EFFECTS_H

#include "args.h"

/* The whole command with --effects: per view of the camera path, the pass without effects
 * (the --traversal method; AUTO: packets on the CPU), the plain stack method (the primary
 * pass an effects pass runs per ray), each listed effect alone and all listed together
 * (vis_trace_effects), --frames timed passes each after a warm-up; medians with min/max, and
 * the secondary rays cast. First --backend, last --threads entry. */
int bench_effects(const cli_args *args);

#endif
