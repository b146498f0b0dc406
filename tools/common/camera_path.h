/*
 * camera_path.h — the views `vis run` and `vis bench` fly through, defined once from the
 * world's bounds (and a few probes of its voxels):
 *
 *   ground      eye at standing height on the surface near the west edge, looking level
 *               across the world (the upper half of the picture is sky);
 *   overview    45 degrees down from above the (min x, min z) corner at the centre;
 *   topdown     straight down on the centre from high enough to see the whole width;
 *   walk-0..N   a walk along the diagonal at the lowest walkable level of each column
 *               (cave floors where the terrain has caves, streets in a city), looking
 *               ahead along the walk.
 */
#ifndef VIS_TOOLS_CAMERA_PATH_H
#define VIS_TOOLS_CAMERA_PATH_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"
#include "voxelworld/vw.h"

#define VC_VIEW_NAME_MAX 32
#define VC_WALK_STEPS 6
#define VC_MAX_VIEWS (3 + VC_WALK_STEPS)

typedef struct vc_view {
    char name[VC_VIEW_NAME_MAX];
    vis_camera camera;         /* absolute world coordinates; fovy 60, default near/far */
} vc_view;

/* Fills up to `capacity` views (VC_MAX_VIEWS is all of them) and returns how many. */
size_t vc_camera_path(const vw_world *world, vc_view *out, size_t capacity);

/* The top of the highest solid voxel in column (x, z) (absolute voxels), or the world's
 * minimum y when the column is empty. */
int64_t vc_surface_height(const vw_world *world, int64_t x, int64_t z);

/* The default camera of `vis cull`: the overview (45 degrees down from above a corner). */
void vc_camera_default(const vw_world *world, vis_camera *out);

#endif
