/* dump.h — the binary and text dumps of `vis cull` (formats in DESIGN.md, the CLI contract). */
#ifndef VIS_CLI_DUMP_H
#define VIS_CLI_DUMP_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"

/* W*H little-endian uint32, row-major, top row first. Returns a CLI exit code. */
int cli_dump_ids(const char *cmd, const char *path, const uint32_t *ids, size_t count);
/* W*H little-endian IEEE float32 (+inf where nothing was hit). */
int cli_dump_depth(const char *cmd, const char *path, const float *depth, size_t count);
/* The draw list, one "ID PIXELS" line per entry. */
int cli_dump_list(const char *cmd, const char *path, const vis_draw_entry *entries, size_t count);

/* The draw list with reasons (--effects), one 'ID DIRECT SEE_THROUGH REFLECTION SHADOW' line
 * per object (pixels per reason), ascending IDs: the first two columns read as cli_dump_list's. */
int cli_dump_effect_list(const char *cmd, const char *path, const vis_effect_entry *entries, size_t count);

#endif
