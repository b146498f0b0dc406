/* meshes.h — the chunk meshes on the GPU: one vertex buffer (and VAO) per object, made from
 * voxelworld's greedy quads with the materials' own colours (a .vox palette included), drawn
 * with a fixed directional shade per face direction. Only the objects of a draw list are
 * drawn; an effects list tints the objects it holds for an effect alone, and with the
 * see-through effect on, see-through quads are drawn as a screen door (every other pixel
 * left out, in a checkerboard) so that what lies behind them shows without sorting. */
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

/* The tints (RGB bytes) of the objects an effects list holds for an effect alone, with no
 * direct pixel: drawn in this colour times the face shade instead of their materials'. An
 * object with several such reasons takes the first of see-through, reflection, shadow. The
 * same numbers are in docs/viewer.md and tests/test_viewer.c. */
#define VV_TINT_SEE_THROUGH_R 0
#define VV_TINT_SEE_THROUGH_G 255
#define VV_TINT_SEE_THROUGH_B 255 /* cyan: only its see-through quads are seen            */
#define VV_TINT_REFLECTION_R 255
#define VV_TINT_REFLECTION_G 0
#define VV_TINT_REFLECTION_B 255  /* magenta: seen only in a reflection                   */
#define VV_TINT_SHADOW_R 255
#define VV_TINT_SHADOW_G 128
#define VV_TINT_SHADOW_B 0        /* orange: only casts a shadow onto something seen      */

/* The tint of an effects entry's reasons: 0 none (it has a direct pixel), else 1 see-through,
 * 2 reflection, 3 shadow; rgb gets the colour in 0..1. */
int vv_tint_of(uint32_t reasons, float rgb[3]);

typedef struct vv_meshes vv_meshes;

/* What to draw: the entries of a draw list (or every object), with their reasons when the
 * list came from an effects pass. */
typedef struct vv_draw_desc {
    const vis_draw_entry *entries;
    size_t count;
    int all;                           /* every object, entries ignored ("no culling")    */
    const vis_effect_entry *reasons;   /* parallel to entries, or NULL: no tints          */
    int screen_door;                   /* see-through quads as a checkerboard             */
} vv_draw_desc;

/* Uploads every object of the scene (meshed again from the world). NULL after printing why. */
vv_meshes *vv_meshes_create(world_scene *ws);
void vv_meshes_destroy(vv_meshes *m);

/* (Re)uploads one object's mesh (count 0: the object is gone). world_scene's chunk hook. */
void vv_meshes_chunk_hook(uint32_t chunk_index, uint32_t object_id, const vw_mesh *mesh, void *user);

/* Draws what d says with mvp (scene-local coordinates). Returns the triangles drawn. */
uint64_t vv_meshes_draw(vv_meshes *m, const vv_draw_desc *d, const float mvp[16]);

/* Triangles of all objects, and objects holding a mesh. */
uint64_t vv_meshes_total_triangles(const vv_meshes *m);
uint32_t vv_meshes_objects(const vv_meshes *m);

/* The box of an object's mesh (scene-local); 0 when it has none. */
int vv_meshes_box(const vv_meshes *m, uint32_t id, float lo[3], float hi[3]);
uint32_t vv_meshes_max_id(const vv_meshes *m);

#endif
