/* out_file.h — writing a file the user named without ever destroying it (docs/cli.md,
 * "Output files").
 *
 * A regular file, or a name that does not exist yet, is written to a temporary file in the
 * same directory that is renamed over it only once every byte is written: a failed write
 * leaves the old file exactly as it was and no partial file. Anything else (a device such as
 * /dev/null or /dev/full, a FIFO, a terminal) is written in place and never removed or
 * replaced. Symbolic links are followed: the file they point to is the one replaced.
 *
 *     vc_out_file o;
 *     if (vc_out_open(&o, path, err, sizeof err) != 0) ...;
 *     vc_out_write(&o, data, size);  vc_out_printf(&o, "%u\n", x);  ...
 *     if (vc_out_close(&o, 1, err, sizeof err) != 0) ...;   // the reason is in err
 */
#ifndef VIS_TOOLS_OUT_FILE_H
#define VIS_TOOLS_OUT_FILE_H

#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>

#include "vwi_file.h"

/* f: where the bytes go; a caller whose data another program writes (gnuplot) may fclose it
 * and set it to NULL, and hand that program vc_out_name(). */
typedef vwi_file vc_out_file;

/* Opens PATH for binary writing. Returns 0, or -1 with the reason in err (nothing created). */
int vc_out_open(vc_out_file *o, const char *path, char *err, size_t err_size);

/* The name the bytes are written to: the temporary, or the target when writing in place. */
static inline const char *vc_out_name(const vc_out_file *o)
{
    return vwi_file_name(o);
}

/* Writes, noting the first failure in o->error. Return 0, or -1 once anything has failed. */
static inline int vc_out_write(vc_out_file *o, const void *data, size_t size)
{
    return vwi_file_write(o, data, size);
}

#if defined(__GNUC__)
__attribute__((format(printf, 2, 3)))
#endif
static inline int vc_out_printf(vc_out_file *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = vwi_file_vprintf(o, fmt, ap);
    va_end(ap);
    return rc;
}

/* Finishes. With ok != 0: flushes and closes, and when every write succeeded renames the
 * temporary over the target and returns 0. Otherwise (ok == 0: the caller failed, or a
 * write, the flush, the close or the rename failed) removes only the temporary and returns
 * -1; err then says why when the failure was here (ok == 0 alone leaves err alone). */
int vc_out_close(vc_out_file *o, int ok, char *err, size_t err_size);

/* SIZE bytes of DATA as the whole of PATH, through the above. Returns 0, or -1 with err. */
int vc_write_file(const char *path, const void *data, size_t size, char *err, size_t err_size);

#endif
