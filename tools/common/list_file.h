/* list_file.h — the draw-list text files of `vis cull --dump-list` and `vis-viewer
 * --drawlist`, written by one function each so that the two programs' files can be compared
 * byte for byte (tests/test_viewer.c does). Ascending IDs, as the lists come.
 *   plain list:   "ID PIXELS" per line
 *   with effects: "ID DIRECT SEE_THROUGH REFLECTION SHADOW" per line (pixels per reason,
 *                 VIS_REASON_* order), whose first two columns read as the plain list's.
 * Written through out_file.h (a failed write leaves the old file as it was). */
#ifndef VIS_TOOLS_LIST_FILE_H
#define VIS_TOOLS_LIST_FILE_H

#include <stddef.h>

#include "vis/vis.h"

/* Each returns 0, or -1 with the reason in err. */
int vc_list_write(const char *path, const vis_draw_entry *entries, size_t count, char *err, size_t err_size);
int vc_effect_list_write(const char *path, const vis_effect_entry *entries, size_t count, char *err,
                         size_t err_size);

#endif
