/* out_file.c — the tools' output files (out_file.h): voxelworld's vwi_file, failures as
 * messages. */
#include "out_file.h"

#include <string.h>

int vc_out_open(vc_out_file *o, const char *path, char *err, size_t err_size)
{
    int e = vwi_file_open(o, path);
    if (e)
        snprintf(err, err_size, "cannot open %s: %s", path, strerror(e));
    return e ? -1 : 0;
}

int vc_out_close(vc_out_file *o, int ok, char *err, size_t err_size)
{
    const char *path = o->path;
    int rc = vwi_file_finish(o, ok);
    if (rc > 0)
        snprintf(err, err_size, "writing %s: %s", path, strerror(rc));
    return rc ? -1 : 0;
}

int vc_write_file(const char *path, const void *data, size_t size, char *err, size_t err_size)
{
    vc_out_file o;
    if (vc_out_open(&o, path, err, err_size) != 0)
        return -1;
    vc_out_write(&o, data, size);
    return vc_out_close(&o, 1, err, err_size);
}
