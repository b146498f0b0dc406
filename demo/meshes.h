/* meshes.h — the chunk meshes on the GPU: one vertex buffer (and VAO) per object, made from
 * voxelworld's greedy quads with the materials' own colours (a .vox palette included), drawn
 * with a fixed directional shade per face direction. Only the objects of a draw list are
 * drawn. */
#ifndef VIS_VIEWER_MESHES_H
#define VIS_VIEWER_MESHES_H

#include <stddef.h>
#include <stdint.h>

#include "viewer.h"

/* The shade of each face direction (the light comes from above, a little from +X and +Z):
 * a face's colour is its material's RGB times this. docs/viewer.md lists the same numbers,
 * which tests/test_viewer.c checks screenshots against. */
#define VV_SHADE_TOP 1.0f
#define VV_SHADE_BOTTOM 0.5f
#define VV_SHADE_X 0.8f
#define VV_SHADE_Z 0.65f

typedef struct vv_meshes vv_meshes;

/* Uploads every object of the scene (meshed again from the world). NULL after printing why. */
vv_meshes *vv_meshes_create(world_scene *ws);
void vv_meshes_destroy(vv_meshes *m);

/* (Re)uploads one object's mesh (count 0: the object is gone). world_scene's chunk hook. */
void vv_meshes_chunk_hook(uint32_t chunk_index, uint32_t object_id, const vw_mesh *mesh, void *user);

/* Draws the listed objects (ids; all objects when ids == NULL) with mvp (scene-local
 * coordinates). Returns the triangles drawn. */
uint64_t vv_meshes_draw(vv_meshes *m, const vis_draw_entry *entries, size_t count, int all, const float mvp[16]);

/* Triangles of all objects, and objects holding a mesh. */
uint64_t vv_meshes_total_triangles(const vv_meshes *m);
uint32_t vv_meshes_objects(const vv_meshes *m);

/* The box of an object's mesh (scene-local); 0 when it has none. */
int vv_meshes_box(const vv_meshes *m, uint32_t id, float lo[3], float hi[3]);
uint32_t vv_meshes_max_id(const vv_meshes *m);

#endif
