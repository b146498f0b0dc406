/*
 * embree_compare.h — `vis bench --compare embree`: the same quads as Embree 3 triangles
 * (two per quad, one geometry per object), traced with the very rays libvis traces
 * (vis_ray_for_pixel on the camera frame), to put our numbers next to a reference.
 *
 *  - static scene: RTC_SCENE_FLAG_ROBUST, RTC_BUILD_QUALITY_HIGH; traced per ray
 *    (rtcIntersect1, "single") and per coherent 8x8 tile (rtcIntersect1M, "stream"), the
 *    tiles split over T threads (a small pthread pool that lives as long as the comparison);
 *  - dynamic scene: RTC_SCENE_FLAG_DYNAMIC (Embree's two-level build), where an edited
 *    chunk's geometry is replaced and the scene recommitted — the counterpart of our
 *    in-place leaf update.
 *
 * Built only with VIS_HAVE_EMBREE; otherwise embree_compare_available() is 0 and create
 * fails with a message.
 */
#ifndef VIS_CLI_EMBREE_COMPARE_H
#define VIS_CLI_EMBREE_COMPARE_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis.h"
#include "world_scene.h"

typedef struct embree_compare embree_compare;

int embree_compare_available(void);

/* Builds both Embree scenes from the objects of `ws` (remeshed from its world). `threads`
 * (>= 1) trace the tiles. Returns 0, or -1 with a message in err. */
int embree_compare_create(world_scene *ws, uint32_t threads, embree_compare **out, char *err, size_t err_size);
void embree_compare_destroy(embree_compare *ec);

/* Build times (ms) of the static and the dynamic scene, and the triangle count. */
double embree_compare_static_build_ms(const embree_compare *ec);
double embree_compare_dynamic_build_ms(const embree_compare *ec);
uint64_t embree_compare_triangles(const embree_compare *ec);

/* The bytes the Embree device holds for the static and the dynamic scene: geometry buffers
 * and BVH, as its memory monitor reports them, after the build and the edits replaced so far. */
uint64_t embree_compare_static_bytes(const embree_compare *ec);
uint64_t embree_compare_dynamic_bytes(const embree_compare *ec);

/* One pass over the camera's W x H pixels on the static scene: object IDs (0 where nothing
 * is hit) into ids, the pass time into *ms. stream: 0 = rtcIntersect1 per ray, 1 =
 * rtcIntersect1M per 8x8 tile. Returns 0, or -1 with a message in err (a bad camera). */
int embree_compare_trace(embree_compare *ec, const vis_camera *camera, uint32_t width, uint32_t height,
                         int stream, uint32_t *ids, double *ms, char *err, size_t err_size);

/* Replaces object `id`'s geometry in the dynamic scene (count 0 removes it), without
 * committing the scene. Returns the time in ms (the quads are turned into triangles inside
 * the timed part, as a game would have to). */
double embree_compare_replace(embree_compare *ec, uint32_t id, const vis_quad *quads, size_t count);

/* rtcCommitScene on the dynamic scene after the replacements of one edit; the time in ms. */
double embree_compare_commit(embree_compare *ec);

#endif
