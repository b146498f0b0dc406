/* overlays.h — what the viewer draws besides the world: the ray pass's ID buffer (a colour
 * per ID) or the z-buffer culler's depth buffer as a picture beside the frame, and lines in
 * the world (the frozen camera's frustum, the boxes of the objects it culled). */
#ifndef VIS_VIEWER_OVERLAYS_H
#define VIS_VIEWER_OVERLAYS_H

#include <stddef.h>
#include <stdint.h>

#include "viewer.h"

typedef struct vv_overlays vv_overlays;

vv_overlays *vv_overlays_create(void);
void vv_overlays_destroy(vv_overlays *o);

/* The colour of an ID (0xAABBGGRR, opaque; black for 0): a hash, so neighbours differ. */
uint32_t vv_id_colour(uint32_t id);

/* Pictures: the IDs or depths of a W x H pass (top row first), drawn into the screen
 * rectangle (x, y, w, h) in pixels from the top left of an fb_w x fb_h framebuffer. Depth is
 * shown as grey from the nearest depth in the buffer (bright) to the farthest, at most
 * `far_depth` (dark); +inf black. */
void vv_overlay_ids(vv_overlays *o, const uint32_t *ids, uint32_t w, uint32_t h, int x, int y, int sw, int sh,
                    int fb_w, int fb_h);
void vv_overlay_depth(vv_overlays *o, const float *depth, uint32_t w, uint32_t h, float far_depth, int x, int y,
                      int sw, int sh, int fb_w, int fb_h);
/* A heat map of per-pixel traversal costs (vis_trace_cost): log scale from the cheapest pixel
 * (dark blue) through green and yellow to the dearest (red). */
void vv_overlay_cost(vv_overlays *o, const uint32_t *cost, uint32_t w, uint32_t h, int x, int y, int sw, int sh,
                     int fb_w, int fb_h);

/* Lines in scene-local coordinates, drawn with mvp at vv_lines_end. */
void vv_lines_begin(vv_overlays *o);
void vv_lines_add(vv_overlays *o, const float a[3], const float b[3], uint32_t rgba);
void vv_lines_box(vv_overlays *o, const float lo[3], const float hi[3], uint32_t rgba);
void vv_lines_end(vv_overlays *o, const float mvp[16]);

#endif
