/* out_file.c — the exporters' output file as vw_status (out_file.h). */
#include "out_file.h"

#include <string.h>

#include "vw_internal.h"

vw_status vwi_out_open(vwi_file *o, const char *path, vw_error *err)
{
    int e = vwi_file_open(o, path);
    return e ? vwi_fail(err, VW_ERROR_IO, "cannot open %s for writing: %s", path, strerror(e)) : VW_OK;
}

vw_status vwi_out_close(vwi_file *o, vw_status status, vw_error *err)
{
    const char *path = o->path;
    int rc = vwi_file_finish(o, status == VW_OK);
    if (rc > 0)
        return vwi_fail(err, VW_ERROR_IO, "writing %s: %s", path, strerror(rc));
    return status;
}
