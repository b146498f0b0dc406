/*
 * backend.h — what libvis hands to a backend, and the small vtable it calls.
 *
 * A backend sees the scene only as flat arrays (backends/common/trace_core.h) plus the list
 * of what changed since it last looked; it never includes libvis internals. The CPU backend
 * traces the host arrays directly; the OpenCL backend keeps a device copy and uploads only
 * the changed leaves and objects.
 */
#ifndef VIS_BACKEND_H
#define VIS_BACKEND_H

#include <stddef.h>
#include <stdint.h>

#include "common/trace_core.h"

/* The scene as flat arrays. Counts are the used extents of each array. */
typedef struct vis_scene_view {
    const vis_kd_node *nodes;
    uint32_t node_count;
    const vis_flat_leaf *leaves;
    uint32_t leaf_count;
    const uint32_t *buckets;
    uint32_t bucket_count;
    const vis_flat_quad *quads;
    uint32_t quad_count;
    const vis_flat_tri *tris;
    uint32_t tri_count;
    const vis_flat_object *objects;
    uint32_t object_count;
    const uint32_t *object_leaves;
    uint32_t object_leaf_count;
    const vis_rope_node *ropes;   /* built once with the tree; never change afterwards       */
    uint32_t rope_count;
    const uint32_t *rope_index;   /* node_count entries                                      */
    float size[3];
    uint32_t kd_depth;
} vis_scene_view;

/* What changed since the backend's last sync of this scene. When `full` is set (first sync,
 * or a pool was reallocated and grew) everything must be re-sent. Otherwise only:
 *  - leaves[i]: the leaf header and its quad and triangle slots (bucketed, loose, tris);
 *  - objects[i]: those object slots;
 *  - object_leaves[object_leaf_lo, object_leaf_hi). */
typedef struct vis_scene_changes {
    uint64_t generation;
    int full;
    const uint32_t *leaves;
    uint32_t leaf_count;
    const uint32_t *objects;
    uint32_t object_count;
    uint32_t object_leaf_lo, object_leaf_hi;
} vis_scene_changes;

typedef struct vis_backend_ops {
    const char *name;
    void (*destroy)(void *impl);
    /* Brings the backend's copy of a scene up to date. *scene_data is NULL on the first call
     * for a scene and is kept by libvis between calls. */
    int (*scene_sync)(void *impl, void **scene_data, const vis_scene_view *view,
                      const vis_scene_changes *changes, char *err, size_t err_size);
    void (*scene_release)(void *impl, void *scene_data);
    /* One pass: width*height IDs into ids; depth may be NULL. Returns a vis_status value. */
    int (*trace)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                 uint32_t *ids, float *depth, char *err, size_t err_size);
    /* Bytes sent to the device by the last scene_sync (0 for host backends). */
    uint64_t (*last_upload_bytes)(void *impl, void *scene_data);
    /* Optional (NULL: libvis calls trace once per view). `count` views of one size, view i
     * with setups[i], its IDs at ids + i*width*height (depths likewise; depth may be NULL). */
    int (*trace_batch)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setups,
                       uint32_t count, uint32_t *ids, float *depth, char *err, size_t err_size);
    /* Optional (NULL: libvis times the trace call itself): device time of the ray pass(es)
     * of the last trace or trace_batch, in milliseconds. */
    double (*last_kernel_ms)(void *impl);
} vis_backend_ops;

typedef struct vis_backend {
    const vis_backend_ops *ops;
    void *impl;
} vis_backend;

typedef void (*vis_backend_log_fn)(int level, const char *message, void *user);

/* CPU backend: `threads` workers (0 = cores, 1 = the calling thread only). Returns a
 * vis_status value. */
int vis_cpu_backend_create(uint32_t threads, vis_backend *out, uint32_t *out_threads, char *err, size_t err_size);

/* OpenCL backend (only when built with VIS_HAVE_OPENCL). selector: NULL, an index or a
 * name substring. Writes the device name. Returns a vis_status value. */
int vis_opencl_backend_create(const char *selector, vis_backend *out, char *device_name, size_t name_size,
                              int *is_gpu, vis_backend_log_fn log, void *log_user, char *err, size_t err_size);

#endif /* VIS_BACKEND_H */
