/* query_sim.h — `vis query --simulate`: bots walking a world, written as a replay. */
#ifndef VIS_CLI_QUERY_SIM_H
#define VIS_CLI_QUERY_SIM_H

#include <stdint.h>
#include <stdio.h>

#include "voxelworld/vw.h"

typedef struct qs_options {
    uint32_t players;
    uint32_t ticks;
    uint64_t seed;
    double tick_ms;       /* default 7.8125 (128 ticks a second)                            */
    uint32_t edit_every;  /* ticks between wall-opening edits; 0 = none                     */
    const char *scene;    /* written to the header                                          */
} qs_options;

/* Writes the header and one line per tick to f. The world is edited as the replay's edits
 * say (the caller reloads it to replay). Returns 0, or -1 with a message in err. */
int qs_simulate(vw_world *world, const qs_options *opt, FILE *f, char *err, size_t err_size);

#endif
