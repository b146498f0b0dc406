/* vdb_disabled.c — the .vdb entry points of a build without OpenVDB (VIS_WITH_OPENVDB=OFF):
 * they fail with VW_ERROR_UNSUPPORTED and say how to enable the importer. */
#ifndef VW_HAVE_OPENVDB
#include <stdio.h>

#include "voxelworld/vw.h"

static vw_status unsupported(const char *path, vw_error *err)
{
    if (err)
        snprintf(err->message, sizeof err->message,
                 "%s: this build has no OpenVDB support (install libopenvdb-dev and configure with -DVIS_WITH_OPENVDB=ON)",
                 path ? path : "(null)");
    return VW_ERROR_UNSUPPORTED;
}

vw_status vw_vdb_load_file(const char *path, const vw_vdb_options *options, vw_world **out_world, vw_error *err)
{
    (void)options;
    (void)out_world;
    return unsupported(path, err);
}

vw_status vw_vdb_describe_file(const char *path, char *out, size_t capacity, vw_error *err)
{
    (void)out;
    (void)capacity;
    return unsupported(path, err);
}
#else
typedef int vw_vdb_disabled_unused; /* ISO C forbids an empty translation unit */
#endif
