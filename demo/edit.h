/* edit.h — voxel edits with the mouse, as in the talk's demo: the ray through a pixel of the
 * pass is traced by libvis (a 1x1 pass along that exact ray), the voxel it hits is edited
 * with a cubic brush, the dirty chunks are re-meshed and their objects replaced in place
 * (world_scene_update -> vis_scene_set_object), and the next frame's culling sees it. */
#ifndef VIS_VIEWER_EDIT_H
#define VIS_VIEWER_EDIT_H

#include <stdint.h>

#include "cull.h"

typedef enum vv_tool { VV_TOOL_ADD = 0, VV_TOOL_REMOVE, VV_TOOL_PAINT, VV_TOOL_COUNT } vv_tool;

const char *vv_tool_name(vv_tool t);
/* "add" / "remove" / "paint" -> the tool; -1 when none. */
int vv_tool_parse(const char *s);

typedef struct vv_edit_result {
    int hit;                 /* 0: the ray hit nothing, nothing was edited                 */
    int64_t voxel[3];        /* the brush's centre (absolute voxels)                       */
    uint32_t object;         /* the object the ray hit                                     */
    uint64_t changed;        /* voxels whose value changed                                 */
    uint32_t chunks;         /* chunks re-meshed                                           */
    double pick_ms, remesh_ms, scene_ms, total_ms;
} vv_edit_result;

/* Edits at pixel (px, py) of the current pass (c->camera, c->width x c->height): the brush
 * is the cube of side 2*radius+1 voxels around the voxel hit (remove, paint) or the empty
 * voxel in front of it (add). add sets the empty voxels of the cube to `material`, remove
 * empties the cube, paint sets its solid voxels to `material`. Returns VV_EXIT_OK (hit or
 * not), or VV_EXIT_FAILURE after printing the library's message. */
int vv_edit_at(vv_cull *c, double px, double py, vv_tool tool, int radius, uint8_t material, vv_edit_result *out);

#endif
