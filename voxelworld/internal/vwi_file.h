/* vwi_file.h — writing a file the user named without ever destroying it: the one
 * implementation, used by voxelworld's exporters (src/out_file.h) and by the tools' output
 * files (tools/common/out_file.h). Internal: not installed, not exported from the shared
 * library; the tools reach it through the CMake target voxelworld_internal.
 *
 * A regular file, or a name that does not exist yet, is written to a temporary file in the
 * same directory that is renamed over it only once every byte is written: a failed write
 * leaves the old file exactly as it was and no partial file. Anything else (a device such as
 * /dev/null or /dev/full, a FIFO, a terminal) is written in place and never removed or
 * replaced. Symbolic links are followed: the file they point to is the one replaced. */
#ifndef VOXELWORLD_VWI_FILE_H
#define VOXELWORLD_VWI_FILE_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

typedef struct vwi_file {
    FILE *f;          /* where the bytes go; a caller whose data another program writes
                         (gnuplot) may fclose it and set it to NULL, and hand that program
                         vwi_file_name()                                                   */
    int error;        /* the errno of the first failed write, 0 while all went well         */
    const char *path; /* as the user named it, for messages                                 */
    char *target;     /* the file that ends up written (links resolved)                     */
    char *tmp;        /* the temporary beside it; NULL when writing in place                */
} vwi_file;

/* Opens PATH for binary writing. Returns 0, or the errno saying why (nothing created). */
int vwi_file_open(vwi_file *o, const char *path);

/* The name the bytes are written to: the temporary, or the target when writing in place. */
const char *vwi_file_name(const vwi_file *o);

/* Notes that an operation on o->f failed, while errno still says why (the first one counts). */
void vwi_file_failed(vwi_file *o);

/* Writes, noting the first failure in o->error. Return 0, or -1 once anything has failed. */
int vwi_file_write(vwi_file *o, const void *data, size_t size);
int vwi_file_vprintf(vwi_file *o, const char *fmt, va_list ap);
int vwi_file_printf(vwi_file *o, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Finishes. Flushes and closes; with ok != 0 and every write successful, renames the
 * temporary over the target and returns 0. Otherwise removes only the temporary and returns
 * the errno of what failed here (a write, the flush, the close or the rename), or -1 when
 * nothing failed here (ok == 0: the caller failed). */
int vwi_file_finish(vwi_file *o, int ok);

#endif
