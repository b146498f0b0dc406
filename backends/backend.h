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
#include <string.h>

#include "common/trace_core.h"
/* The device's short-stack limit, taken before vis.h defines the same macro token for token:
 * a different value draws a "redefined" warning and, with trace_core.h included first as
 * here, fails the assertion below. */
enum { VIS_DEVICE_MAX_SHORT_STACK_ = VIS_MAX_SHORT_STACK };
#include "vis/vis.h"

/* One set of numbers on both sides of the boundary: the limits and enums of vis.h are the
 * ones trace_core.h (and so the OpenCL kernels) use. */
_Static_assert(VIS_DEVICE_MAX_SHORT_STACK_ == VIS_MAX_SHORT_STACK, "trace_core.h and vis.h disagree on the short stack");
/* vis_ray_setup.traversal is vis_traversal - 1 (AUTO resolved by libvis/src/trace.c). */
#define VIS_CHECK_TRAVERSAL_(name)                                                                                     \
    _Static_assert(VIS_TRAVERSAL_ID_##name + 1u == (unsigned)VIS_TRAVERSAL_##name, "VIS_TRAVERSAL_ID_" #name)
VIS_CHECK_TRAVERSAL_(STACK);
VIS_CHECK_TRAVERSAL_(BRUTEFORCE);
VIS_CHECK_TRAVERSAL_(RESTART);
VIS_CHECK_TRAVERSAL_(PUSHDOWN);
VIS_CHECK_TRAVERSAL_(SHORTSTACK);
VIS_CHECK_TRAVERSAL_(ROPES);
VIS_CHECK_TRAVERSAL_(ROPES_SHORTSTACK);
VIS_CHECK_TRAVERSAL_(PACKET);
VIS_CHECK_TRAVERSAL_(CACHED_STACK);
VIS_CHECK_TRAVERSAL_(DDA);
#undef VIS_CHECK_TRAVERSAL_
_Static_assert(VIS_IDS_OBJECT == 0 && VIS_IDS_LEAF == 1, "vis_ray_setup.id_mode is vis_id_mode");
_Static_assert(VIS_FLAG_SEE_THROUGH == VIS_PRIM_SEE_THROUGH && VIS_FLAG_REFLECTIVE == VIS_PRIM_REFLECTIVE,
               "trace_core.h and vis.h disagree on the material flags");
_Static_assert(VIS_FX_SEE_THROUGH == VIS_EFFECT_SEE_THROUGH && VIS_FX_REFLECT == VIS_EFFECT_REFLECT &&
                   VIS_FX_SHADOWS == VIS_EFFECT_SHADOWS && VIS_FX_FOG == VIS_EFFECT_FOG,
               "trace_core.h and vis.h disagree on the effect bits");
_Static_assert(VIS_MAX_LAYERS == VIS_MAX_SEE_THROUGH_LAYERS, "trace_core.h and vis.h disagree on the layers");

/* The flat layout is copied to devices byte for byte: 4-byte fields only, no padding, the
 * sizes trace_core.h states. The kernels check the same sizes against the host's on their
 * side (cl_program.c passes them to the build, opencl/kernels/trace.cl compares). */
#define VIS_CHECK_LAYOUT_(type, bytes)                                                                                 \
    _Static_assert(sizeof(type) == (bytes) && _Alignof(type) == 4, #type " is laid out as the device expects")
VIS_CHECK_LAYOUT_(vis_kd_node, 8);
VIS_CHECK_LAYOUT_(vis_flat_leaf, 64);
VIS_CHECK_LAYOUT_(vis_flat_quad, 24);
VIS_CHECK_LAYOUT_(vis_flat_tri, 40);
VIS_CHECK_LAYOUT_(vis_flat_object, 16);
VIS_CHECK_LAYOUT_(vis_rope_node, 56);
VIS_CHECK_LAYOUT_(vis_ray_setup, 116);
VIS_CHECK_LAYOUT_(vis_effect_setup, 32);
#undef VIS_CHECK_LAYOUT_

/* Host memory of a backend comes from the context's allocator (vis_context_desc.allocator, or
 * libvis's default, libvis/src/host_memory.c); both functions are always set. Nothing in a backend calls
 * malloc/free directly. */
static inline void *vis_host_alloc(const vis_allocator *a, size_t size)
{
    return a->alloc(size ? size : 1u, 64u, a->user);
}

static inline void *vis_host_calloc(const vis_allocator *a, size_t count, size_t size)
{
    if (size && count > SIZE_MAX / size)
        return NULL;
    void *p = vis_host_alloc(a, count * size);
    if (p)
        memset(p, 0, count * size);
    return p;
}

static inline void vis_host_free(const vis_allocator *a, void *ptr)
{
    if (ptr)
        a->free(ptr, a->user);
}

/* The scene as flat arrays. Counts are the used extents of each array. */
typedef struct vis_scene_view {
    const vis_kd_node *nodes;
    uint32_t node_count;
    const vis_flat_leaf *leaves;
    uint32_t leaf_count;
    const uint32_t *buckets;
    uint32_t bucket_count;
    const uint32_t *quads;        /* the quad pool, in words (trace_core.h, vis_flat_leaf) */
    uint32_t quad_count;
    const vis_flat_tri *tris;
    uint32_t tri_count;
    const vis_flat_object *objects;
    uint32_t object_count;
    const uint32_t *object_leaves;
    uint32_t object_leaf_count;
    const vis_rope_node *ropes;   /* NULL (rope_count 0) until the first pass that walks them
                                     builds them; never change afterwards                   */
    uint32_t rope_count;
    const uint32_t *rope_index;   /* rope_index_count entries: node_count, then the cell map  */
    uint32_t rope_index_count;
    uint32_t cells[3];            /* the cell grid; cell_map: where its map starts (0: none)  */
    uint32_t cell_map;
    float cell_size;
    float size[3];
    uint32_t kd_depth;
    const uint32_t *labels;       /* the CPU backend's voxel labels (trace_core.h, the label
                                     walk), set by it for its passes; NULL from libvis       */
} vis_scene_view;

/* VIS_SCENE_ARGS (common/trace_core.h) taken from a vis_scene_view: the traversal functions'
 * scene parameters, in their order. */
#define VIS_SCENE_VIEW_ARGS(v)                                                               \
    (v)->nodes, (v)->leaves, (v)->buckets, (v)->quads, (v)->tris, (v)->objects, (v)->object_leaves, \
        (v)->ropes, (v)->rope_index, (v)->labels

/* What changed since the backend's last sync of this scene. `full` is set for the backend's
 * first sync of the scene (and for every sync of a copy held by a context other than the
 * scene's own, libvis/src/scene_share.c): everything must be sent. Pools that grew on the
 * host do not set it: the view's counts say how large each array is now, and the backend
 * grows its copy itself (the OpenCL backend counts those reallocations). Otherwise only:
 *  - leaves[i]: the leaf header and its quad and triangle slots (bucketed, loose, tris);
 *  - objects[i]: those object slots;
 *  - object_leaves[object_leaf_lo, object_leaf_hi). */
typedef struct vis_scene_changes {
    uint64_t generation;
    int full;
    int copy; /* a context's copy of another context's scene: every sync of it is full, as
                 that context never sees the owner's change lists (scene_share.c)          */
    const uint32_t *leaves;
    uint32_t leaf_count;
    const uint32_t *objects;
    uint32_t object_count;
    uint32_t object_leaf_lo, object_leaf_hi;
    /* Cells whose map entry (the clearance, trace_core.h VIS_CELL_CLEAR) changed lie in the box
     * [map_lo, map_hi] (inclusive, cell coordinates); none when map_changed is 0. */
    int map_changed;
    uint32_t map_lo[3], map_hi[3];
    /* Host memory the backend may keep for the scene beside the scene's arrays: its max_bytes
     * less its bytes. What the CPU backend's optional labels are held to. */
    uint64_t room;
} vis_scene_changes;

/* The buffers of an effects pass (vis_trace_effects): ids always; the others NULL when
 * not asked for (depth) or their effect is off. see_through holds setup->layers IDs per
 * pixel, pixel-major. Sizes were checked by libvis. */
typedef struct vis_effect_outputs {
    uint32_t *ids;
    float *depth;
    uint32_t *see_through;
    uint32_t *reflection;
    uint32_t *shadow;
    uint64_t *secondary_rays; /* set to the reflected and shadow rays cast (the CPU counts) */
} vis_effect_outputs;

typedef struct vis_backend_ops {
    const char *name;
    void (*destroy)(void *impl);
    /* Brings the backend's copy of a scene up to date. *scene_data is NULL on the first call
     * for a scene and is kept by libvis between calls. */
    vis_status (*scene_sync)(void *impl, void **scene_data, const vis_scene_view *view,
                      const vis_scene_changes *changes, char *err, size_t err_size);
    void (*scene_release)(void *impl, void *scene_data);
    /* One pass: width*height IDs into ids; depth may be NULL. */
    vis_status (*trace)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                 uint32_t *ids, float *depth, char *err, size_t err_size);
    /* Optional (NULL: VIS_ERROR_UNSUPPORTED): `trace` for the packet method (setup->traversal
     * VIS_TRAVERSAL_ID_PACKET) that also writes each pixel's traversal cost (vis_trace_cost). */
    vis_status (*trace_cost)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                             uint32_t *ids, uint32_t *cost, char *err, size_t err_size);
    /* Bytes sent to the device by the last scene_sync (0 for host backends). */
    uint64_t (*last_upload_bytes)(void *impl, void *scene_data);
    /* Optional (NULL: libvis calls trace once per view). `count` views of one size, view i
     * with setups[i], its IDs at ids + i*width*height (depths likewise; depth may be NULL). */
    vis_status (*trace_batch)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setups,
                       uint32_t count, uint32_t *ids, float *depth, char *err, size_t err_size);
    /* Optional (NULL: libvis times the trace call itself): device time of the ray pass(es)
     * of the last trace or trace_batch, in milliseconds. */
    double (*last_kernel_ms)(void *impl);
    /* Optional (NULL: libvis traces into its scratch and builds each list on the host, as
     * vis_drawlist_build does). `count` views of one size, as trace_batch; per view the draw
     * list of the IDs the pass gives (vis_drawlist_build's entries, sorted by ID as it sorts
     * them), the lists one after the other in entries, per_view[i] entries for view i, their
     * sum in *total. ids and depth may be NULL (then nothing is read back but the lists).
     * VIS_ERROR_CAPACITY when the lists need more than `capacity` entries: *total says how
     * many; entries are then untouched for a batch of one launch, unspecified beyond. */
    vis_status (*trace_drawlist)(void *impl, void *scene_data, const vis_scene_view *view,
                                 const vis_ray_setup *setups, uint32_t count, uint32_t *ids, float *depth,
                                 vis_draw_entry *entries, size_t capacity, size_t *per_view, size_t *total, char *err,
                                 size_t err_size);
    /* Optional (NULL: VIS_ERROR_UNSUPPORTED): one pass with effects (trace_core.h,
     * vis_trace_pixel_effects), every method equal to the brute force. */
    vis_status (*trace_effects)(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setup,
                                const vis_effect_setup *effects, const vis_effect_outputs *out, char *err,
                                size_t err_size);
    /* Optional (NULL: none): host memory the backend holds for its copy of a scene, beside
     * the scene's own arrays (vis_scene_info.backend_bytes). */
    uint64_t (*scene_bytes)(void *impl, void *scene_data);
} vis_backend_ops;

typedef struct vis_backend {
    const vis_backend_ops *ops;
    void *impl;
} vis_backend;

typedef void (*vis_backend_log_fn)(int level, const char *message, void *user);

/* CPU backend: `threads` workers (0 = cores, 1 = the calling thread only). Its host memory
 * comes from `alloc`, which must outlive the backend. */
vis_status vis_cpu_backend_create(uint32_t threads, const vis_allocator *alloc, vis_backend *out,
                                  uint32_t *out_threads, char *err, size_t err_size);

/* Runs the CPU backend's passes through the caller's job system instead of its pool (create
 * it with threads = 1 so that the pool starts no thread). */
void vis_cpu_backend_set_parallel_for(vis_backend *backend, vis_parallel_for_fn parallel_for, void *user);

/* Runs job(i, arg) for i in [0, count) on the CPU backend's threads (its pool, or the job
 * system set above), the caller included; returns when all are done. Not during a pass of
 * the same backend: one run at a time. */
void vis_cpu_backend_parallel_for(vis_backend *backend, uint32_t count, void (*job)(uint32_t index, void *arg),
                                  void *arg);

/* OpenCL backend (only when built with VIS_HAVE_OPENCL). selector: NULL, an index or a
 * name substring. gpu_only (AUTO, nothing named): a GPU or nothing, without starting CPU-only
 * implementations such as PoCL (backends/opencl/cl_loader.c). The ICD loader is opened at
 * run time (no link dependency): UNSUPPORTED with the reason when it is missing. Writes the
 * device name. Its host memory comes from `alloc`, which must outlive the backend. */
vis_status vis_opencl_backend_create(const char *selector, int gpu_only, const vis_allocator *alloc,
                                     vis_backend *out, char *device_name, size_t name_size, int *is_gpu,
                                     vis_backend_log_fn log, void *log_user, char *err, size_t err_size);

#endif /* VIS_BACKEND_H */
