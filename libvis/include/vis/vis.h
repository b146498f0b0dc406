/*
 * libvis — which parts of a voxel world can this camera see?
 *
 * One ray per pixel of a small buffer (512x512 by default) is traced through a prebuilt,
 * fixed-depth kd-tree of objects; the nearest object ID (or kd-leaf ID) per pixel is written
 * to an ID buffer, and the unique IDs of that buffer are the draw list.
 *
 * Conventions, for every function below:
 *  - Every call that can fail returns vis_status. On failure, output buffers are left
 *    untouched and vis_context_last_error() says what went wrong.
 *  - Desc structs are zero-initialised by the caller; a zero field means the documented
 *    default (vis_*_desc_defaults() shows the values filled in).
 *  - Pointers are non-NULL unless the parameter says "may be NULL".
 *  - Caller-owned output buffers come with their capacity in elements (not bytes); a short
 *    one gives VIS_ERROR_CAPACITY with the count needed, and nothing is written.
 *  - Units: world units are voxels. Angles are degrees. Times are milliseconds.
 *  - The library never prints, never exits and never aborts on bad input.
 *
 * Thread safety:
 *  - Contexts are independent of each other and may be used from different threads at the
 *    same time. One context serves one thread at a time: a call that uses a context's
 *    mutable state (vis_trace, vis_trace_batch, vis_trace_drawlist, vis_trace_batch_drawlist,
 *    vis_drawlist_build, vis_camera_validate,
 *    vis_zcull_create/run/depth, vis_scene_create, vis_context_last_timing, and the scene
 *    edits and vis_scene_leaf_objects, which count as calls on the scene's own context)
 *    returns VIS_ERROR_BUSY at once, doing nothing, when another thread is inside such a
 *    call on that context. Destroy functions are not
 *    checked: nothing else may run on the context or object being destroyed.
 *  - A scene may be traced (vis_trace, vis_trace_batch, vis_trace_drawlist,
 *    vis_trace_batch_drawlist, vis_drawlist_build) from several
 *    threads through several contexts at once, its own and others (each context keeps its
 *    own backend copy of the scene, brought up to date at its first trace after a commit);
 *    vis_zcull_run takes scenes of its own context only. Traces hold the scene's
 *    reader-writer lock shared for their duration; vis_scene_commit (and every edit of a
 *    VIS_COMMIT_AUTO scene) holds it exclusive, so a trace sees the committed state as it
 *    was when the trace began, never a half-applied edit. vis_scene_get_info,
 *    vis_scene_leaf_objects and vis_drawlist_bound read under the shared lock too.
 *  - Edits (vis_scene_set_object, vis_scene_remove_object, vis_scene_commit) are calls on
 *    the scene's own context: one thread edits, while any number trace through other
 *    contexts. With vis_scene_desc.commit = VIS_COMMIT_EXPLICIT they are staged and become
 *    visible to traces only at vis_scene_commit (Embree's model).
 *  - vis_scene_destroy gives back every context's copy of the scene, through that context's
 *    backend and allocator, on the destroying thread: a context that traces scenes of
 *    other contexts needs an allocator that may be called from their threads (malloc may).
 *    Likewise the first pass that walks ropes (VIS_TRAVERSAL_ROPES, _ROPES_SHORTSTACK)
 *    builds the scene's ropes through the scene's own context's allocator, on the tracing
 *    thread, under the exclusive lock; it fails with VIS_ERROR_BUDGET where they would take
 *    the scene past max_bytes.
 *  - The CPU backend runs its pool's worker threads (or desc.parallel_for) inside the trace
 *    calls; the pool's workers live as long as the context. After a pass each worker spins
 *    for up to 0.1 ms, so that a pass following soon finds it awake, then sleeps until the
 *    next pass. A query (vis_query) whose thread count is the context's runs its viewers on
 *    these same workers.
 *
 * Environment: the library reads these variables, and no others (docs/opencl.md has the
 * details); none is read by a CPU-only context:
 *  - VIS_OPENCL_DEVICE: the OpenCL device when vis_context_desc.opencl_device is NULL or ""
 *    (same syntax); it also makes VIS_BACKEND_AUTO take that device whatever its kind.
 *  - VIS_OPENCL_LIBRARY: the OpenCL ICD loader to open (a path or soname) instead of
 *    libOpenCL.so.1 / libOpenCL.so.
 *  - VIS_OPENCL_TILE=WxH: the OpenCL work-group shape (default 8x8 for one view, 8x4 for a
 *    batch; this sets both; each 1..1024), a tuning knob that never changes results;
 *    malformed values are ignored.
 *  - VIS_OPENCL_WALK: how the OpenCL per-ray kernels are scheduled (words joined by '+' or
 *    ',': persistent, postpone, postpone1..postpone4, vote, plain), a tuning knob that never
 *    changes results; an unknown word makes the OpenCL backend's creation fail with
 *    VIS_ERROR_INVALID_ARGUMENT, vote without postpone or off NVIDIA with
 *    VIS_ERROR_UNSUPPORTED.
 *  - VIS_OPENCL_ASSUME_NO_FP64=1: the OpenCL device is treated as one without double
 *    precision (scenes holding triangles are then refused on it), for tests.
 *  - VIS_OPENCL_BUILD_OPTIONS: options appended to every OpenCL program build (a tuning knob,
 *    e.g. a register limit); one that changes results (-cl-fast-relaxed-math, -cl-mad-enable,
 *    -cl-unsafe-math-optimizations, -cl-denorms-are-zero, -cl-finite-math-only), a macro
 *    definition (-D, -U) or a value of 256 characters or more makes the OpenCL backend's
 *    creation fail with VIS_ERROR_INVALID_ARGUMENT.
 *  - OCL_ICD_FILENAMES, OCL_ICD_VENDORS, OPENCL_VENDOR_PATH, POCL_DEVICES: read, as the ICD
 *    loader and PoCL would read them, only to tell which OpenCL implementations are
 *    CPU-only, so that VIS_BACKEND_AUTO neither opens the loader nor starts PoCL's CPU
 *    devices when no GPU can be there.
 *
 * What "visible" promises: an object is in the draw list of a ray pass when at least one
 * pixel-centre ray of the buffer hits it before anything else (ties in distance go to the
 * lowest ID). Objects seen only between pixel centres can be missed; leaf-ID mode trades
 * overdraw for fewer such misses. The z-buffer culler is conservative at its own resolution.
 */
#ifndef VIS_VIS_H
#define VIS_VIS_H

#include <stddef.h>
#include <stdint.h>

#include "vis/vis_config.h"

#if defined(_WIN32) && defined(VIS_SHARED)
#  define VIS_API __declspec(dllexport)
#elif defined(__GNUC__)
#  define VIS_API __attribute__((visibility("default")))
#else
#  define VIS_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------ */
/* Status                                                                               */
/* ------------------------------------------------------------------------------------ */

typedef enum vis_status {
    VIS_OK = 0,
    VIS_ERROR_INVALID_ARGUMENT, /* a parameter is out of range; the message names it     */
    VIS_ERROR_OUT_OF_MEMORY,    /* host or device allocation failed                      */
    VIS_ERROR_UNSUPPORTED,      /* the backend or build lacks the feature                */
    VIS_ERROR_BACKEND,          /* the backend failed (OpenCL error, kernel build, ...)  */
    VIS_ERROR_NOT_FOUND,        /* no such object, device or platform                    */
    VIS_ERROR_CAPACITY,         /* a caller-owned output is too small                    */
    VIS_ERROR_BUDGET,           /* the call would exceed a size limit (a scene's max_bytes,
                                   VIS_MAX_KD_NODES, cells per axis); the message names the
                                   number and the limit                                  */
    VIS_ERROR_BUSY              /* another thread is inside a call on the same context (the
                                   call did nothing and left the last error alone), or
                                   vis_context_destroy found the context still in use    */
} vis_status;

/* A static English string for a status ("ok", "invalid argument", ...). Never NULL. */
VIS_API const char *vis_status_string(vis_status status);

/* The library version, "MAJOR.MINOR.PATCH". */
VIS_API const char *vis_version(void);

/* ------------------------------------------------------------------------------------ */
/* Context                                                                              */
/* ------------------------------------------------------------------------------------ */

typedef struct vis_context vis_context;
typedef struct vis_scene vis_scene;

typedef enum vis_backend_kind {
    VIS_BACKEND_AUTO = 0, /* a GPU through OpenCL if present (or the OpenCL device named
                             by opencl_device / $VIS_OPENCL_DEVICE), else the CPU         */
    VIS_BACKEND_CPU,      /* threads on this machine                                     */
    VIS_BACKEND_OPENCL    /* OpenCL; fails if no usable device                            */
} vis_backend_kind;

typedef enum vis_log_level { VIS_LOG_DEBUG = 0, VIS_LOG_INFO, VIS_LOG_WARNING, VIS_LOG_ERROR } vis_log_level;

/* Optional allocator for all host memory libvis and its backends take (the context, scenes,
 * scratch, the CPU backend's pool and subtree fills, the OpenCL backend's bookkeeping);
 * nothing in the library calls malloc itself (tests/test_alloc.c interposes malloc to check).
 * What the C library, the OpenCL loader and driver allocate on their own (thread stacks,
 * dlopen, the OpenCL runtime's own memory) does not go through it. Both functions or neither.
 * alloc returns memory aligned to at least `align` (a power of two, <= 64), or NULL. */
typedef struct vis_allocator {
    void *(*alloc)(size_t size, size_t align, void *user);
    void (*free)(void *ptr, void *user);
    void *user;
} vis_allocator;

/* Optional log callback: called from the thread that made the library call. */
typedef void (*vis_log_fn)(vis_log_level level, const char *message, void *user);

/* Optional job system for the CPU backend: runs job(i, arg) once for every i in [0, count),
 * on any threads, in any order, and returns when all have finished. Called from inside
 * vis_trace()/vis_trace_batch() on the calling thread: once for the pass, and in the first
 * pass over a scene (or the first after the context's copy was rebuilt whole) once more for
 * every 1024 kd leaves, to build the voxel labels of the per-ray leaf walk. Several contexts
 * sharing one job system may call it at the same time. A job keeps a whole ray packet on its stack: give its
 * threads (or fibers) at least 64 KiB of stack (a 16x16 packet of an effects pass is 39 KB,
 * of a plain pass 15 KB). */
typedef void (*vis_parallel_for_fn)(uint32_t count, void (*job)(uint32_t index, void *arg), void *arg,
                                    void *user);

typedef struct vis_context_desc {
    vis_backend_kind backend;    /* default VIS_BACKEND_AUTO                                  */
    uint32_t threads;            /* CPU backend worker threads; 0 = number of cores, 1 = serial */
    const char *opencl_device;   /* may be NULL: device selector, an index ("1") or a name
                                    substring ("NVIDIA"); NULL reads $VIS_OPENCL_DEVICE, and if
                                    that is unset takes the first GPU, else the first device */
    vis_allocator allocator;     /* zero = the library's own: aligned_alloc, and on Linux
                                    blocks of 1 MiB and more as anonymous mappings that grow
                                    in place (mremap) instead of being copied                */
    vis_log_fn log;              /* may be NULL                                               */
    void *log_user;
    vis_parallel_for_fn parallel_for; /* may be NULL: the CPU backend's own pool of `threads`
                                    workers. When set, the CPU backend starts no thread of its
                                    own and runs each pass's tiles through it (`threads` is then
                                    ignored and vis_backend_info.threads is 0); buffers are
                                    bit-identical either way                                  */
    void *parallel_for_user;
} vis_context_desc;

VIS_API void vis_context_desc_defaults(vis_context_desc *desc);

/* Creates a context. With VIS_BACKEND_AUTO it never fails for lack of OpenCL: it falls
 * back to the CPU and says why in vis_context_backend(). */
VIS_API vis_status vis_context_create(const vis_context_desc *desc, vis_context **out_context);

/* May be NULL (VIS_OK). Destroys the zculls, then the scenes still alive that were created
 * from the context (newest first, as vis_zcull_destroy / vis_scene_destroy would; do not
 * destroy them again), then the context. Fails with VIS_ERROR_BUSY, destroying nothing, when
 * another thread is inside a call on the context, or when the context still holds its copy
 * of a scene created from another context (a scene it traced): destroy those scenes first. */
VIS_API vis_status vis_context_destroy(vis_context *context);

/* The message of the last failed call on this context ("" if none). Valid until the next
 * call on the context. */
VIS_API const char *vis_context_last_error(const vis_context *context);

typedef struct vis_backend_info {
    vis_backend_kind kind;   /* the backend actually used: CPU or OPENCL                     */
    uint32_t threads;        /* CPU worker threads (CPU backend); 0 with desc.parallel_for    */
    char name[64];           /* "cpu" or "opencl"                                             */
    char device[128];        /* "4 threads" / the OpenCL device name                          */
    char reason[256];        /* why AUTO picked it, or "" when chosen explicitly              */
    int is_gpu;              /* OpenCL: 1 when the device is a GPU (CL_DEVICE_TYPE_GPU)      */
} vis_backend_info;

VIS_API vis_status vis_context_backend(const vis_context *context, vis_backend_info *out_info);

/* ------------------------------------------------------------------------------------ */
/* Scene: objects in a fixed-depth kd-tree                                             */
/* ------------------------------------------------------------------------------------ */

/* Object IDs: 1..VIS_MAX_OBJECT_ID (0 means "nothing"); they need not be dense (the draw
 * list's scratch follows the object count, not the largest ID). At most VIS_MAX_OBJECTS
 * objects. */
#define VIS_MAX_OBJECT_ID 0x0FFFFFFFu
#define VIS_MAX_OBJECTS   0x00FFFFFFu

/* Primitive flags (materials). Reserved for the effects; 0 = opaque. */
#define VIS_PRIM_SEE_THROUGH 0x1u
#define VIS_PRIM_REFLECTIVE  0x2u

/* An axis-aligned rectangle in the plane x[axis] = plane, covering
 * [u0,u1] x [v0,v1] in the two other axes, u = (axis+1)%3 and v = (axis+2)%3.
 * Closed on all edges, hit from both sides; a ray that touches an edge or corner counts as a
 * hit (the test is the quad box's slab test with a 2^-20 relative slack, docs/traversal.md,
 * "Exactness"), so rounding never lets a ray slip between faces. Coordinates are scene-local
 * (relative to vis_scene_desc.origin). Requires u0 <= u1 and v0 <= v1. */
typedef struct vis_quad {
    uint32_t axis;   /* 0 = x, 1 = y, 2 = z */
    uint32_t flags;  /* VIS_PRIM_*          */
    float plane;
    float u0, v0, u1, v1;
} vis_quad;

/* A triangle, scene-local, intersected with the watertight test of Woop et al. 2013,
 * from both sides. */
typedef struct vis_triangle {
    float v[3][3];
    uint32_t flags;
} vis_triangle;

/* The geometry of one object. Arrays may be NULL when their count is 0. Copied by the
 * library; the caller's arrays are not kept. */
typedef struct vis_mesh {
    const vis_quad *quads;
    uint32_t quad_count;
    const vis_triangle *triangles;
    uint32_t triangle_count;
} vis_mesh;

/* When edits become visible to traces. */
typedef enum vis_commit_mode {
    VIS_COMMIT_AUTO = 0,  /* each edit is committed as it returns (it waits for traces in
                             flight on other threads to finish): the next trace sees it   */
    VIS_COMMIT_EXPLICIT   /* edits are staged (copied, validated) and published together by
                             vis_scene_commit(); traces and queries see only what was
                             committed                                                   */
} vis_commit_mode;

typedef struct vis_scene_desc {
    double origin[3];     /* world position of scene-local (0,0,0); keep it near the geometry
                             so that float coordinates stay exact far from the world origin */
    float size[3];        /* scene-local bounds are [0,size]; every object must lie inside   */
    float cell_size;      /* split planes lie on multiples of this (the chunk edge); default 16 */
    uint32_t kd_depth;    /* fixed depth of the tree; 0 = deep enough that a leaf is one cell  */
    float leaf_slack;     /* spare capacity of each leaf's primitive slot, as a fraction of its
                             size when filled; default 0.25                                   */
    uint64_t max_bytes;   /* host memory the scene may hold between calls (vis_scene_info.bytes;
                             a call's short-lived scratch is not counted); 0 =
                             VIS_DEFAULT_SCENE_MAX_BYTES. The CPU backend keeps its voxel
                             labels only where, at a trace or vis_scene_prepare, bytes and
                             backend_bytes fit within it (vis_scene_info); without them its
                             passes are the same, slower                                      */
    vis_commit_mode commit; /* default VIS_COMMIT_AUTO                                      */
} vis_scene_desc;

#define VIS_DEFAULT_SCENE_MAX_BYTES ((uint64_t)2 << 30) /* 2 GiB                              */
#define VIS_MAX_KD_NODES (1u << 26) /* inner nodes + leaves of a scene's tree, at most        */

VIS_API void vis_scene_desc_defaults(vis_scene_desc *desc);

/* Builds the empty tree over the bounds; it is never rebuilt afterwards. The tree's node
 * count and bytes are computed from size, cell_size and kd_depth before anything is
 * allocated: VIS_ERROR_BUDGET when an axis would have more than 2^30 cells, the tree more
 * than VIS_MAX_KD_NODES nodes or the empty scene more than max_bytes bytes, with a message
 * naming the number and the limit. */
VIS_API vis_status vis_scene_create(vis_context *context, const vis_scene_desc *desc, vis_scene **out_scene);

/* May be NULL. Waits for traces in flight on other threads to finish; none may start after
 * it (the caller's duty). Releases every context's backend copy of the scene. */
VIS_API void vis_scene_destroy(vis_scene *scene);

/* Adds the object, or replaces its mesh if the ID exists: the leaves it lies in are updated
 * in place (nothing is rebuilt). An empty mesh removes the object. An object must lie
 * inside the scene bounds; one that crosses split planes is referenced from every leaf it
 * overlaps. VIS_ERROR_BUDGET, with the scene unchanged, when the edit would make the scene
 * hold more than its max_bytes (the growth is computed before anything is changed). */
VIS_API vis_status vis_scene_set_object(vis_scene *scene, uint32_t id, const vis_mesh *mesh);

/* VIS_ERROR_NOT_FOUND if there is no such object. Like vis_scene_set_object, it may return
 * VIS_ERROR_BUDGET (scene unchanged) when the scene would grow past max_bytes: its
 * bookkeeping, or a leaf of more than 1,024 objects whose later objects' quads become
 * packable once one leaves, which brings the leaf an object table. */
VIS_API vis_status vis_scene_remove_object(vis_scene *scene, uint32_t id);

/* With VIS_COMMIT_EXPLICIT, vis_scene_set_object and vis_scene_remove_object check their
 * arguments (IDs, meshes, bounds; NOT_FOUND against the staged state) and stage the edit;
 * the budget is checked when the edit is applied. vis_scene_commit applies the staged
 * edits in order, under the scene's exclusive lock, and publishes them: every trace that
 * starts afterwards, on any thread and context, sees them all (each context brings its
 * backend copy up to date at its next trace). If an edit fails (VIS_ERROR_BUDGET,
 * VIS_ERROR_OUT_OF_MEMORY) the ones before it stay applied and published, it and the
 * ones after it are dropped, and its status is returned. VIS_OK with nothing staged, and
 * always for VIS_COMMIT_AUTO scenes (their edits are committed as they return). */
VIS_API vis_status vis_scene_commit(vis_scene *scene);

/* Deepest short stack a pass may ask for (vis_trace_desc.short_stack), and the highest level
 * above the leaves that carries ropes. */
#define VIS_MAX_SHORT_STACK 16u

typedef struct vis_scene_info {
    double origin[3];
    float size[3];
    float cell_size;
    uint32_t kd_depth;      /* the tree's fixed depth                                       */
    uint32_t nodes;         /* inner nodes + leaves                                         */
    uint32_t leaves;
    uint32_t objects;
    uint32_t max_id;        /* largest object ID present (0 if none)                        */
    uint64_t quads;
    uint64_t triangles;
    uint64_t bytes;         /* host memory held by the scene (its arrays at their capacity) */
    uint64_t max_bytes;     /* the limit on `bytes` (vis_scene_desc.max_bytes)              */
    uint64_t edits;         /* set/remove calls so far                                      */
    uint64_t backend_bytes; /* host memory the scene's own context's backend holds for it
                               beside `bytes` (the CPU backend: what each kd subtree holds
                               and the voxel labels of its per-ray leaf walk), as of its last
                               trace or vis_scene_prepare; 0 before the first. `bytes` +
                               backend_bytes is what tracing the scene holds all told. The
                               labels are built only within max_bytes, the subtrees' record
                               always (a few bytes per kd node, which the packets need).
                               Labels that did not fit (or could not have their memory)
                               come back only once the room beside `bytes` has grown by an
                               eighth, or at a sync of the whole scene                     */
} vis_scene_info;

VIS_API vis_status vis_scene_get_info(const vis_scene *scene, vis_scene_info *out_info);

/* Brings `context`'s copy of the scene up to date now, as its next trace would first do: the
 * CPU backend builds its record of what each kd subtree holds and its voxel labels (whole at
 * the first call, then the changed leaves; a copy of another context's scene, made whole
 * after every edit, keeps no labels and walks planes, with the same buffers), a device
 * backend uploads. For an engine that would rather pay that when it
 * loads a world than in its first frame. A call on `context` as a trace is (threads: as
 * vis_trace); VIS_ERROR_OUT_OF_MEMORY, or the upload's error, leaves the copy to the next
 * trace. */
VIS_API vis_status vis_scene_prepare(vis_context *context, vis_scene *scene);

/* How the scene's memory is used inside: for benchmarks and debugging, not for deciding
 * anything (the fields follow the implementation and may change between versions). */
typedef struct vis_scene_stats {
    uint64_t relocations;     /* leaf updates that outgrew their slot and moved to a freed slot
                                 or the end of the pool (the tree is never rebuilt)          */
    uint64_t quad_slots;      /* 4-byte words of the quad pool handed out to leaf slots: the
                                 leaves' object tables and quads (a packed quad takes one
                                 word, a loose one six), their spare capacity
                                 (vis_scene_desc.leaf_slack, rounded up to a size class) and
                                 freed slots waiting for reuse or compaction                 */
    uint64_t quads_in_leaves; /* quads the leaves hold (an object's quad counts once in every
                                 leaf it overlaps)                                           */
    uint64_t tri_slots;       /* the same for the triangle pool, in triangles                 */
    uint64_t tris_in_leaves;
    uint64_t rope_bytes;      /* rope data held (part of vis_scene_info.bytes): the 4-byte
                                 node-to-rope index, and once a pass has walked ropes
                                 (VIS_TRAVERSAL_ROPES, _ROPES_SHORTSTACK; built by the first
                                 such pass, never changed afterwards) box + six neighbour
                                 links of every node up to VIS_MAX_SHORT_STACK levels above
                                 the leaves                                                  */
    uint64_t rope_bytes_used[VIS_MAX_SHORT_STACK + 1]; /* of those, the rope nodes a method
                                 walks: [0] ropes (one per leaf), [N] ropes-shortstack with N
                                 (one per node N levels above the leaves; Chang & Ihm 2010,
                                 Table 4)                                                    */
} vis_scene_stats;

/* Fills *out_stats; walks the tree and the leaves (not for every frame). Reads under the
 * scene's shared lock, like vis_scene_get_info. */
VIS_API vis_status vis_scene_get_stats(const vis_scene *scene, vis_scene_stats *out_stats);

/* Writes the IDs of the objects referenced by leaf `leaf_id` (1..leaves), sorted.
 * Pass out_ids = NULL to learn the count. VIS_ERROR_CAPACITY if capacity is too small. */
VIS_API vis_status vis_scene_leaf_objects(const vis_scene *scene, uint32_t leaf_id, uint32_t *out_ids,
                                          uint32_t capacity, uint32_t *out_count);

/* ------------------------------------------------------------------------------------ */
/* Camera and the ray pass                                                              */
/* ------------------------------------------------------------------------------------ */

/* Eye E looks at target T, up +Y. Pixel (x, y) of a W x H buffer shoots one ray through its
 * centre: ndc = ((x+0.5)/W*2-1, 1-(y+0.5)/H*2), direction = normalize(f + ndc.x*tan(fovy/2)*
 * (W/H)*r + ndc.y*tan(fovy/2)*u), with f = normalize(T-E), r = normalize(f x (0,1,0)),
 * u = r x f computed in double ((0,0,-1) stands in for (0,1,0) when f is parallel to Y).
 * Hits count between near and far (distances along the normalised ray). */
typedef struct vis_camera {
    double eye[3];
    double target[3];
    double fovy_deg;   /* vertical field of view, (0, 180); default 60                    */
    double near_dist;  /* > 0; default 0.05                                                */
    double far_dist;   /* > near; default +infinity (0 means default)                      */
} vis_camera;

typedef enum vis_id_mode {
    VIS_IDS_OBJECT = 0, /* the nearest object's ID per pixel                                */
    VIS_IDS_LEAF        /* the ID (1..leaves) of the kd-leaf holding the nearest hit: draw
                           every object of that leaf (conservative: fewer misses, more overdraw) */
} vis_id_mode;

/* kd-tree traversal methods (Chang & Ihm 2010; docs/traversal.md). All give the nearest hit
 * with the lowest-ID tie rule; they differ in speed and in the per-ray state they need. The
 * per-ray methods give bit-identical buffers among themselves, on the CPU and on every
 * OpenCL device the backend accepts. An OpenCL device without double precision
 * (cl_khr_fp64), which the watertight triangle test's fallback needs, traces scenes of quads
 * only: tracing a scene that holds triangles there fails with VIS_ERROR_UNSUPPORTED and the
 * reason, rather than giving other pixels than the CPU. Devices that flush single-precision
 * subnormals to zero, or lack correctly rounded division, are not accepted at all
 * (docs/opencl.md). Every method, packets included, equals VIS_TRAVERSAL_BRUTEFORCE bit for
 * bit (docs/traversal.md, "Exactness"). */
typedef enum vis_traversal {
    VIS_TRAVERSAL_AUTO = 0,       /* the backend's fastest (default): PACKET on the CPU;
                                     on an OpenCL GPU DDA for one view and for batches (STACK
                                     on a scene without a cell map) and STACK for effects
                                     passes; STACK on other OpenCL devices                   */
    VIS_TRAVERSAL_STACK = 1,      /* full stack, 8-byte entries, one ray at a time            */
    VIS_TRAVERSAL_BRUTEFORCE = 2, /* no tree: every primitive of every object (the reference) */
    VIS_TRAVERSAL_RESTART = 3,    /* kd-restart (Foley & Sugerman 2005): after each leaf,
                                     restart from the root past it; no stack                 */
    VIS_TRAVERSAL_PUSHDOWN = 4,   /* kd-restart from the deepest node still holding the rest
                                     of the ray (Horn et al. 2007); no stack                 */
    VIS_TRAVERSAL_SHORTSTACK = 5, /* restart with a ring stack of short_stack entries (Horn
                                     et al. 2007); restarts only when it runs empty          */
    VIS_TRAVERSAL_ROPES = 6,      /* neighbour links on every leaf face (Popov et al. 2007);
                                     no stack                                                */
    VIS_TRAVERSAL_ROPES_SHORTSTACK = 7, /* ropes on the nodes short_stack levels above the
                                     leaves, a short stack below them (Chang & Ihm 2010)     */
    VIS_TRAVERSAL_PACKET = 8,     /* CPU: each 16x16 tile walks the tree once as a packet, with
                                     interval culling and exact per-ray tests (Wald et al.
                                     2001; Reshetov et al. 2005; Boulos et al. 2007); OpenCL:
                                     each work-group walks the tree once for its tile, with
                                     exact per-ray tests (docs/opencl.md; slower than STACK
                                     on the GPUs measured)                                   */
    VIS_TRAVERSAL_CACHED_STACK = 9, /* the full stack with its top short_stack entries in a ring
                                     in the GPU's local (shared) memory, the rest in private
                                     memory (Chang & Ihm 2010, section 3.1); on the CPU the
                                     same walk with the ring on the C stack                  */
    VIS_TRAVERSAL_DDA = 10        /* no tree: a 3D-DDA over the cell grid, whose cells are the
                                     leaves at full depth (Amanatides & Woo 1987); no stack.
                                     A scene built shallower runs STACK instead              */
} vis_traversal;

typedef struct vis_trace_desc {
    uint32_t width, height;    /* default 512 x 512; each at most VIS_MAX_RESOLUTION           */
    vis_id_mode ids;           /* default VIS_IDS_OBJECT                                      */
    vis_traversal traversal;   /* default VIS_TRAVERSAL_AUTO                                  */
    uint32_t short_stack;      /* N for VIS_TRAVERSAL_SHORTSTACK, _ROPES_SHORTSTACK and the
                                  ring of _CACHED_STACK:
                                  1..VIS_MAX_SHORT_STACK, default (0) 4; ignored otherwise    */
    /* Effects (docs/effects.md). vis_trace, vis_trace_batch, vis_trace_drawlist and
     * vis_trace_batch_drawlist take VIS_EFFECT_FOG only (anything else is
     * VIS_ERROR_INVALID_ARGUMENT: they have no buffer for it);
     * vis_trace_effects takes every bit. */
    uint32_t effects;          /* VIS_EFFECT_* bits; default 0: none, the pass of before       */
    uint32_t see_through_layers; /* VIS_EFFECT_SEE_THROUGH: see-through objects recorded per
                                  pixel, 1..VIS_MAX_SEE_THROUGH_LAYERS, default (0) 2         */
    double light_dir[3];       /* VIS_EFFECT_SHADOWS: toward the light (a directional light);
                                  finite, not zero; normalised in double, then rounded        */
    double fog_dist;           /* VIS_EFFECT_FOG: finite, > 0; the rays' far distance becomes
                                  min(camera far, fog_dist) in float                          */
} vis_trace_desc;

/* Effects of a pass (vis_trace_desc.effects).
 *  - SEE_THROUGH: quads and triangles flagged VIS_PRIM_SEE_THROUGH never occlude; each ray
 *    records the see_through_layers nearest distinct see-through objects it crosses before
 *    its opaque hit, by (t, ID) (an object crossed twice counts at its nearest crossing;
 *    "before" is vis_trace's tie rule: t < t_hit, or t == t_hit and a lower ID). Without the
 *    effect they occlude as any quad does.
 *  - REFLECT: one reflected ray per pixel from the nearest reflective (VIS_PRIM_REFLECTIVE)
 *    quad the ray meets: a reflective see-through crossing recorded as above (SEE_THROUGH on,
 *    before the opaque hit, whether or not it is among the recorded layers), else the opaque
 *    hit. Mirror-exact: d[axis] negated, origin on the quad's plane, quads of that plane
 *    ignored, over [0, camera far / fog]; with SEE_THROUGH on, see-through quads do not
 *    stop it. One bounce. Triangles do not reflect.
 *  - SHADOWS: from the opaque hit, when it is a quad whose seen side faces the light
 *    (light_dir[axis] on the side the camera sees it from), a ray toward the light to the
 *    scene bounds (quads of the receiver's plane ignored); the first quad or triangle it
 *    meets is the shadow caster, in the frustum or not (Bittner et al. 2011). See-through
 *    quads cast no shadow. A side facing away from the light (or edge-on) is its own shadow:
 *    no ray, 0. Triangle receivers cast no ray.
 *  - FOG: objects beyond fog_dist are culled (a face at exactly fog_dist, as rounded to
 *    float, is kept, as at the camera's far distance). */
#define VIS_EFFECT_SEE_THROUGH 0x1u
#define VIS_EFFECT_REFLECT     0x2u
#define VIS_EFFECT_SHADOWS     0x4u
#define VIS_EFFECT_FOG         0x8u
#define VIS_MAX_SEE_THROUGH_LAYERS 4u

#define VIS_MAX_RESOLUTION 16384u

VIS_API void vis_trace_desc_defaults(vis_trace_desc *desc);

/* Checks a camera for a W x H pass: finite eye/target, eye != target, 0 < fovy < 180,
 * 0 < near < far. Returns VIS_ERROR_INVALID_ARGUMENT with a message naming the problem. */
VIS_API vis_status vis_camera_validate(vis_context *context, const vis_camera *camera);

/* ---- The engine's camera form: view and projection matrices (issue 12) ------------- */

/* Turns an engine's view and projection matrices into the vis_camera that traces the same
 * rays, so every call that takes a vis_camera (vis_trace, vis_trace_batch, vis_zcull_run)
 * takes the engine's camera too. Matrices are 4x4 doubles, column-major as OpenGL and glm
 * store them: element (row r, column c) at [c*4 + r]. `view` maps world coordinates to eye
 * space (looking down -Z, +Y up, +X right); its inverse gives the eye (its translation) and
 * the forward (-Z), right and up axes. `projection` is a symmetric OpenGL perspective
 * (glm::perspective, gluPerspective, or its infinite-far form): fovy = 2 atan(1 /
 * projection[1][1]); near and far come from projection[2][2] and projection[3][2]; the
 * aspect projection[1][1] / projection[0][0] must be the pass's width / height (which
 * vis_trace takes the aspect from) within 1e-4. The result gets eye, a target along the
 * forward axis, fovy_deg, near_dist and far_dist (0, which means +inf, for an infinite far
 * plane), and is then checked as vis_camera_validate checks it. Like vis_camera_validate it
 * is a call on the context (another thread's call meanwhile gets VIS_ERROR_BUSY); it
 * allocates nothing.
 *
 * The eye/target form has no roll (its up follows +Y), so a view whose right axis leaves the
 * horizontal plane (|right.y| > 1e-6), or, looking straight along Y, whose right axis is not
 * the one the eye/target form takes there, is VIS_ERROR_UNSUPPORTED; so are off-centre
 * (projection[2][0], projection[2][1] != 0) and orthographic projections. Matrices with a
 * non-finite element, a view whose rotation is not orthonormal within 1e-4 (scale, shear,
 * mirror), or a projection that is not a perspective are VIS_ERROR_INVALID_ARGUMENT. The
 * message names the problem; *out_camera is written only on VIS_OK. For a view and
 * projection built from an eye/target camera (lookAt with up +Y, perspective with its fovy,
 * near, far and the pass's aspect, in double), the camera returned gives the same ID buffers
 * as the eye/target camera (tests/test_camera.c checks them bit for bit). */
VIS_API vis_status vis_camera_from_matrices(vis_context *context, const double view[16], const double projection[16],
                                            uint32_t width, uint32_t height, vis_camera *out_camera);

/* ---- end of the engine's camera form ----------------------------------------------- */

/* The ray pass. out_ids receives width*height IDs (row-major, top row first, 0 = nothing
 * hit); out_depth (may be NULL, then depth_capacity must be 0, else
 * VIS_ERROR_INVALID_ARGUMENT) the distance along the normalised ray, +inf where nothing was
 * hit. Capacities are in elements (not bytes): VIS_ERROR_CAPACITY, with nothing written,
 * when ids_capacity, or depth_capacity with out_depth set, is below width*height (the
 * message gives the count needed). Allocates nothing once the scene's backend copy is up to
 * date. */
VIS_API vis_status vis_trace(vis_context *context, vis_scene *scene, const vis_camera *camera,
                             const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity,
                             float *out_depth, size_t depth_capacity);

/* vis_trace, also writing each pixel's traversal cost into out_cost (width*height elements,
 * cost_capacity checked as ids_capacity is): the kd-tree nodes that the packet which traced
 * the pixel opened, plus the quads and triangles tested on the pixel's own ray. Where a tile
 * went ray by ray (wide tiles, far hits; docs/traversal.md) its packet is the ray alone. For
 * heat maps and tuning, not for every frame. Only the CPU backend's packet method counts
 * (VIS_TRAVERSAL_AUTO or VIS_TRAVERSAL_PACKET on a CPU context); other backends and methods
 * return VIS_ERROR_UNSUPPORTED. out_ids gets what vis_trace writes. */
VIS_API vis_status vis_trace_cost(vis_context *context, vis_scene *scene, const vis_camera *camera,
                                  const vis_trace_desc *desc, uint32_t *out_ids, size_t ids_capacity,
                                  uint32_t *out_cost, size_t cost_capacity);

/* The buffers of vis_trace_effects, each with its capacity in elements (VIS_ERROR_CAPACITY,
 * nothing written, when one is short). ID 0 means nothing in every buffer. A buffer whose
 * effect is off is neither read nor written (may be NULL); one whose effect is on must not
 * be NULL (VIS_ERROR_INVALID_ARGUMENT). */
typedef struct vis_effect_buffers {
    uint32_t *ids;           size_t ids_capacity;         /* W*H: the opaque hit (as vis_trace) */
    float *depth;            size_t depth_capacity;       /* W*H, may be NULL (then capacity 0) */
    uint32_t *see_through;   size_t see_through_capacity; /* W*H*layers, pixel-major: a pixel's
                                                             layers nearest first, 0 past the
                                                             last (SEE_THROUGH)             */
    uint32_t *reflection;    size_t reflection_capacity;  /* W*H: what the reflected ray hits
                                                             (REFLECT)                      */
    uint32_t *shadow;        size_t shadow_capacity;      /* W*H: the shadow caster (SHADOWS) */
} vis_effect_buffers;

/* The ray pass with desc->effects (docs/effects.md): writes the buffers above. Object IDs
 * only (desc->ids VIS_IDS_LEAF is VIS_ERROR_INVALID_ARGUMENT). Every method gives the brute
 * force's buffers bit for bit; the CPU backend traces every method's pass per ray here
 * (VIS_TRAVERSAL_PACKET and AUTO run the stack method), secondary rays by the stack method
 * (by the brute force when that is the pass's method). Bad effect parameters (a zero or
 * non-finite light, fog <= 0 or non-finite, layers above VIS_MAX_SEE_THROUGH_LAYERS) are
 * VIS_ERROR_INVALID_ARGUMENT with nothing written. desc->effects == 0 gives vis_trace's
 * buffers. Allocates nothing once the scene's backend copy is up to date (the OpenCL backend
 * grows its device buffers on first use); vis_context_last_timing's `rays` counts primary rays,
 * `secondary_rays` the reflected and shadow rays (CPU backend). A backend without effects:
 * VIS_ERROR_UNSUPPORTED. */
VIS_API vis_status vis_trace_effects(vis_context *context, vis_scene *scene, const vis_camera *camera,
                                     const vis_trace_desc *desc, const vis_effect_buffers *buffers);

/* ------------------------------------------------------------------------------------ */
/* Draw list                                                                            */
/* ------------------------------------------------------------------------------------ */

typedef struct vis_draw_entry {
    uint32_t id;      /* object ID                                                         */
    uint32_t pixels;  /* pixels of the ID buffer that show it (for leaf IDs: pixels of the
                         leaves holding it); 0 where the method has none                   */
} vis_draw_entry;

/* An upper bound on the entries of any draw list of the scene (its object count). */
VIS_API size_t vis_drawlist_bound(const vis_scene *scene);

/* Turns an ID buffer into the draw list: unique object IDs, sorted ascending, leaf IDs
 * expanded to the objects of the leaf, each with its pixel count. Scratch comes from the
 * context: a little over 4 bytes per object slot (the most objects the scene has held at
 * once: a count and a bit each), plus 4 per leaf in VIS_IDS_LEAF mode; it grows only when
 * that grows, so a warm call allocates nothing. VIS_ERROR_CAPACITY if capacity is below the
 * entry count (nothing is written then). */
VIS_API vis_status vis_drawlist_build(vis_context *context, const vis_scene *scene, const uint32_t *ids,
                                      uint32_t width, uint32_t height, vis_id_mode mode,
                                      vis_draw_entry *out_entries, size_t capacity, size_t *out_count);

/* The ray pass and its draw list in one call: what an engine needs each frame. The entries
 * equal vis_trace followed by vis_drawlist_build on its IDs (same entries, same pixel counts,
 * sorted by ID, object or leaf IDs as desc->ids says), on every backend and for every
 * traversal. On OpenCL the list is built on the device and only the list is read back (into
 * pinned host memory): the IDs and depths stay on the device unless out_ids / out_depth ask
 * for them (each may be NULL with its capacity 0; otherwise as vis_trace checks them). The
 * CPU backend traces into the context's scratch (or out_ids) and builds the list from it.
 * capacity in entries (vis_drawlist_bound(scene) always suffices): VIS_ERROR_CAPACITY when
 * the list is longer, *out_count then holding the entries it needs, out_entries untouched.
 * Allocates nothing once the scene's backend copy and the scratch are large enough; the
 * timing (vis_context_last_timing) covers the whole call, its kernel_ms the trace and the
 * list's compaction. */
VIS_API vis_status vis_trace_drawlist(vis_context *context, vis_scene *scene, const vis_camera *camera,
                                      const vis_trace_desc *desc, vis_draw_entry *out_entries, size_t capacity,
                                      size_t *out_count, uint32_t *out_ids, size_t ids_capacity, float *out_depth,
                                      size_t depth_capacity);

/* vis_trace_drawlist for `count` views of one size (server-style batches; OpenCL: one launch
 * for all, or a few for large batches), IDs and depths not read back. View i's list follows
 * view i-1's in out_entries; out_counts[i] (counts_capacity >= count) its entry count, the
 * sum in *out_total. VIS_ERROR_CAPACITY when the lists need more than capacity entries:
 * *out_total then holds at least the number needed, and the entries are unspecified (the
 * lists of views traced in an earlier launch may have been written). Each view's list equals
 * vis_trace_drawlist's for its camera. Cameras are validated before any work. */
VIS_API vis_status vis_trace_batch_drawlist(vis_context *context, vis_scene *scene, const vis_camera *cameras,
                                            uint32_t count, const vis_trace_desc *desc, vis_draw_entry *out_entries,
                                            size_t capacity, size_t *out_counts, size_t counts_capacity,
                                            size_t *out_total);

/* Why an object is in an effects draw list (vis_effect_entry.reasons); pixels[i] counts
 * reason 1 << i. */
#define VIS_REASON_DIRECT      0x1u /* it is the opaque hit                                 */
#define VIS_REASON_SEE_THROUGH 0x2u /* seen through: a recorded see-through layer          */
#define VIS_REASON_REFLECTION  0x4u /* hit by a reflected ray                              */
#define VIS_REASON_SHADOW      0x8u /* casts a shadow onto a visible point                 */
#define VIS_REASON_COUNT 4

typedef struct vis_effect_entry {
    uint32_t id;
    uint32_t reasons;                  /* VIS_REASON_* bits, never 0                        */
    uint32_t pixels[VIS_REASON_COUNT]; /* pixels per reason (see-through: pixels whose
                                          layers hold it)                                   */
} vis_effect_entry;

/* The draw list of a vis_trace_effects pass: every object ID in the buffers, sorted
 * ascending, with why and on how many pixels. buffers->ids is required; see_through,
 * reflection and shadow are counted when not NULL (see_through with see_through_layers per
 * pixel, 1..VIS_MAX_SEE_THROUGH_LAYERS); depth is not read. Capacities are checked against
 * width*height (times the layers) as vis_trace_effects checks them. An ID that is no object
 * of the scene is VIS_ERROR_INVALID_ARGUMENT. Scratch from the context (16 bytes per object
 * slot; a warm call allocates nothing); vis_drawlist_bound entries always suffice;
 * VIS_ERROR_CAPACITY (nothing written) when capacity is below the entry count. */
VIS_API vis_status vis_drawlist_build_effects(vis_context *context, const vis_scene *scene,
                                              const vis_effect_buffers *buffers, uint32_t width, uint32_t height,
                                              uint32_t see_through_layers, vis_effect_entry *out_entries,
                                              size_t capacity, size_t *out_count);

/* ------------------------------------------------------------------------------------ */
/* Software z-buffer occlusion culler (the comparison to the ray pass)                 */
/* ------------------------------------------------------------------------------------ */

/* Rasterises occluders (the objects' own meshes, nearest objects first) into a small depth
 * buffer with the ray pass's camera and pixel centres, then tests every object's box
 * against it. Conservative at its own resolution: an object is left out only when no pixel
 * centre of the buffer sees a point of its box at least as near as the occluders there;
 * boxes that reach in front of the near plane, or hold the eye, are always kept; boxes
 * beyond far_dist, behind the eye or between the pixel centres are left out. It makes no ID
 * buffer: its draw list entries have pixels = 0. Runs serially on the calling thread.
 * docs/zcull.md has the method and its limits.
 *
 * Thread safety: a vis_zcull belongs to the context it was created from; its calls count as
 * calls on that context (another thread's call meanwhile gets VIS_ERROR_BUSY). Several handles
 * may exist; each keeps its own buffers. */
typedef struct vis_zcull vis_zcull;

/* The inner loop's instruction set. Every choice gives bit-identical results. */
typedef enum vis_zcull_simd {
    VIS_ZCULL_SIMD_AUTO = 0, /* the widest this CPU runs: AVX2, else SSE2 (x86-64), else scalar */
    VIS_ZCULL_SIMD_SCALAR,   /* plain C: the reference                                        */
    VIS_ZCULL_SIMD_SSE2,     /* where the CPU lacks the one asked for, AUTO's choice is used   */
    VIS_ZCULL_SIMD_AVX2
} vis_zcull_simd;

#define VIS_ZCULL_DEFAULT_OCCLUDER_TRIANGLES 32768u
#define VIS_ZCULL_ALL_OCCLUDERS 0xFFFFFFFFu

typedef struct vis_zcull_desc {
    uint32_t width, height;       /* depth buffer; default 512 x 512; each at most
                                     VIS_MAX_RESOLUTION                                     */
    uint32_t occluder_triangles;  /* occluder budget: objects are drawn nearest first (by the
                                     distance from the eye to their box) while their
                                     triangles fit (a quad counts as 2); an object that does
                                     not fit is skipped and later, smaller ones may still be
                                     drawn. Objects already hidden when their turn comes are
                                     not drawn and cost nothing. Default
                                     VIS_ZCULL_DEFAULT_OCCLUDER_TRIANGLES;
                                     VIS_ZCULL_ALL_OCCLUDERS draws every object              */
    uint32_t occluder_min_pixels; /* objects whose box spans fewer pixels (its screen
                                     rectangle) are never drawn as occluders; default 0: no
                                     minimum                                                */
    vis_zcull_simd simd;          /* default VIS_ZCULL_SIMD_AUTO                             */
} vis_zcull_desc;

VIS_API void vis_zcull_desc_defaults(vis_zcull_desc *desc);

/* What one run did and how long each part took (milliseconds, wall clock). */
typedef struct vis_zcull_stats {
    uint32_t width, height;
    uint32_t objects;             /* live objects in the scene                               */
    uint32_t in_view;             /* objects not culled by the frustum, far or pixel centres */
    uint32_t occluder_objects;    /* objects whose meshes were rasterised                    */
    uint32_t occluders_hidden;    /* occluder candidates already hidden at their turn        */
    uint32_t visible;             /* entries in the draw list                                */
    uint64_t triangles;           /* occluder triangles rasterised (a quad counts as 2)      */
    uint64_t polygons;            /* polygons that reached tile traversal after clipping and
                                     culling (a quad is one polygon)                         */
    uint64_t tiles;               /* 8x8 tiles written                                       */
    double ms_setup;              /* boxes against the frustum, sort by distance             */
    double ms_raster;             /* occluders (including the hidden-occluder tests)         */
    double ms_test;               /* box tests and the draw list                             */
    double ms_total;
    char simd[8];                 /* the path used: "scalar", "sse2" or "avx2"               */
} vis_zcull_stats;

/* Creates a culler on the context. Its buffers are allocated by the first run and grown
 * only when the resolution or the scene grows: runs at a fixed size allocate nothing. */
VIS_API vis_status vis_zcull_create(vis_context *context, vis_zcull **out_zcull);

/* May be NULL. vis_context_destroy destroys the culls still alive on the context. */
VIS_API void vis_zcull_destroy(vis_zcull *zcull);

/* One culling pass. desc may be NULL (defaults). The scene must come from the culler's
 * context. out_entries receives the draw list, sorted by ID, pixels = 0;
 * vis_drawlist_bound(scene) entries always suffice; VIS_ERROR_CAPACITY if capacity is below
 * the entry count (nothing is written then). out_entries may be NULL when capacity is 0.
 * out_stats may be NULL. */
VIS_API vis_status vis_zcull_run(vis_zcull *zcull, const vis_scene *scene, const vis_camera *camera,
                                 const vis_zcull_desc *desc, vis_draw_entry *out_entries, size_t capacity,
                                 size_t *out_count, vis_zcull_stats *out_stats);

/* The depth buffer of the last successful run: width*height floats, row-major, top row
 * first, the distance along the normalised pixel-centre ray to the occluders as rasterised
 * (never nearer than the true surface), +inf where no occluder covers the pixel centre.
 * VIS_ERROR_NOT_FOUND before the first run; VIS_ERROR_CAPACITY, with nothing written, when
 * capacity (in floats) is below the run's width*height (the message gives the count). */
VIS_API vis_status vis_zcull_depth(vis_zcull *zcull, float *out_depth, size_t capacity);

/* ------------------------------------------------------------------------------------ */
/* Batches, timing, uploads                                                             */
/* ------------------------------------------------------------------------------------ */

/* Traces `count` views of one scene in one call (server-style batches). View i uses
 * cameras[i] and the one desc (desc may be NULL: defaults); its W x H IDs go to
 * out_ids + i*W*H and, when out_depth is not NULL, its depths to out_depth + i*W*H.
 * Capacities are in elements for the whole batch: VIS_ERROR_CAPACITY, with nothing written,
 * when ids_capacity, or depth_capacity with out_depth set, is below count*W*H (computed in
 * 64 bits; the message gives the count needed). out_depth may be NULL, then depth_capacity
 * must be 0. Every camera is validated before any work; on failure the outputs are left
 * untouched and the message names the camera. Each view's buffers equal what vis_trace()
 * gives for that camera, bit for bit. The OpenCL backend runs the views in one kernel
 * launch (a few for batches larger than its output buffers); the CPU backend traces them
 * one after the other. count = 0 does nothing and returns VIS_OK. */
VIS_API vis_status vis_trace_batch(vis_context *context, vis_scene *scene, const vis_camera *cameras,
                                   uint32_t count, const vis_trace_desc *desc, uint32_t *out_ids,
                                   size_t ids_capacity, float *out_depth, size_t depth_capacity);

/* What the last successful vis_trace() or vis_trace_batch() on a context did and how long
 * it took. */
typedef struct vis_timing {
    double total_ms;       /* the whole call, wall clock: validation, upload of scene changes,
                              the ray pass and the readback of the buffers                   */
    double kernel_ms;      /* the ray pass alone: OpenCL kernel time from event profiling
                              (summed over a batch's launches); CPU backend: the pass's wall
                              clock                                                          */
    uint64_t upload_bytes; /* bytes sent to the device by this call's scene sync: the whole
                              scene on the context's first trace of it, afterwards only the
                              leaves (headers, primitive slots, bucket tables) and objects
                              changed by edits since (docs/opencl.md); 0 when nothing
                              changed, and always 0 on the CPU backend, which traces the
                              host arrays directly                                           */
    uint64_t rays;         /* rays traced: width * height * views                           */
    uint32_t views;        /* 1 for vis_trace()                                              */
    uint64_t secondary_rays; /* vis_trace_effects on the CPU backend: reflected and shadow
                              rays cast (0 elsewhere: the OpenCL kernel does not count them) */
} vis_timing;

/* VIS_ERROR_NOT_FOUND before the first successful trace on the context. */
VIS_API vis_status vis_context_last_timing(const vis_context *context, vis_timing *out_timing);

/* ------------------------------------------------------------------------------------ */
/* Server queries: what each player can see, every tick (docs/server.md)                */
/* ------------------------------------------------------------------------------------ */

/* A headless game server asks two questions per tick and per player ("viewer"): which chunk
 * objects to stream (a low-resolution ID pass, in view or all around) and which entities to
 * send (anti-wallhack). Entities are boxes with velocities; they are never occluders, only
 * the scene's quads are (triangles and VIS_PRIM_SEE_THROUGH quads never hide anything).
 *
 * The entity guarantee (docs/server.md, "What is guaranteed"). Let E be the eye region of a
 * viewer: the box spanned by eye and eye + velocity * latency, grown by peek_speed * latency
 * + margin on every side; let B be an entity's swept box: the hull of its box and the box
 * moved by its velocity * latency, grown by margin. The entity is left out of the viewer's
 * list only when every segment from a point of E to a point of B crosses an opaque quad:
 * proven, never sampled, by finding axis-aligned planes that separate pieces of E from
 * pieces of B and whose crossing rectangle (widened against the rounding of float rays) is
 * covered by the union of the plane's opaque quads. So an entity with any point visible from
 * any eye in E -- in particular any pixel of a ray pass from the true eye, which lies in E --
 * is always reported. Pairs the ray budget leaves unproven are reported
 * (VIS_QUERY_UNCHECKED), never hidden.
 *
 * Thread safety: a vis_query belongs to the context and scene it was created with; its
 * calls count as calls on that context (VIS_ERROR_BUSY while another thread is inside one).
 * The scene may be edited between calls (through its own context); each call sees the
 * committed state; an edit since the last call drops the cached entity results whose proof
 * it can reach (its changed boxes meet the proof's eye region and swept box).
 * Chunk lists: a viewer's list is the union of the IDs of its pass's faces (6 all around, 1
 * in view), each face kept from its last trace. An edit retraces, on the next call, the faces
 * with a ray that reaches an edited object's box (its hull before and after the edit) before
 * that ray's hit -- exactly the faces whose IDs the edit can change; the others keep their
 * IDs, which are what a trace would give on the edited scene. When more than 64 boxes changed
 * since the last call (the scene keeps a log of the last 64), every face is retraced. With a
 * chunk_face_budget, "on the next call" becomes "on a later call": the faces past the budget
 * keep their last IDs until their turn. */
typedef struct vis_query vis_query;

/* Sizes a query may be created with. */
#define VIS_QUERY_MAX_VIEWERS  4096u
#define VIS_QUERY_MAX_ENTITIES 65536u
#define VIS_QUERY_MAX_CHUNK_RES 256u
#define VIS_QUERY_MAX_LATENCY_MS 2000.0
#define VIS_QUERY_MAX_SPEED 1000.0   /* voxels per second, any velocity or peek speed     */
#define VIS_QUERY_SOLID_MAX_CELLS 1024u /* the largest box vis_query_solid_fn is asked about  */
#define VIS_QUERY_MIN_FOV 0.001      /* degrees: an in-view pass's field of view, at least...  */
#define VIS_QUERY_MAX_FOV 170.0      /* ...and at most                                         */

/* Where the world is solid, for the entity proof (optional: vis_query_desc.solid). Returns 1
 * only when every unit cell [x, x + 1] x [y, y + 1] x [z, z + 1] with lo <= (x, y, z) < hi
 * (scene-local integer coordinates, as vis_quad's) is filled with opaque matter whose every
 * face toward a cell outside that matter is covered by the scene's opaque quads: what a voxel
 * mesher gives opaque voxels (faces toward air, see-through voxels and the world's outside;
 * voxelworld's vw_world_box_opaque answers it); 0 otherwise, or when unsure. Asked during
 * vis_query_run only, from the query's threads at once (it must be safe for that), about boxes
 * of at most VIS_QUERY_SOLID_MAX_CELLS cells; it must answer for the world whose meshes the
 * scene holds during that call (edit the world and the scene together, between runs). A wrong
 * 1 can hide a visible entity; 0 is always safe. Not counted as rays
 * (vis_query_stats.solid_tests). */
typedef int (*vis_query_solid_fn)(void *user, const int32_t lo[3], const int32_t hi[3]);

typedef struct vis_query_desc {
    uint32_t max_viewers;      /* viewers per tick, 1..VIS_QUERY_MAX_VIEWERS; default 64     */
    uint32_t max_entities;     /* entities per tick, 1..VIS_QUERY_MAX_ENTITIES; default 256  */
    uint32_t chunk_res;        /* the chunk ID pass: chunk_res x chunk_res per face,
                                  1..VIS_QUERY_MAX_CHUNK_RES; default 32                     */
    uint32_t chunk_every;      /* re-trace a viewer's chunks every N ticks, each viewer slot
                                  on its own phase (and at once for a new viewer, or the
                                  faces a scene edit reaches: see above; "at once" within
                                  chunk_face_budget); default 1: every tick                 */
    double chunk_range;        /* the chunk pass's far plane, in voxels from the eye (Luanti
                                  sends blocks within a range, 192 voxels by default); chunks
                                  seen only beyond it are not listed. 0 (default): unlimited;
                                  otherwise at least 1                                        */
    double chunk_move;         /* voxels: 0 (default), passes come on the chunk_every cadence
                                  (a due pass whose camera is the last one's, to the bit, is
                                  skipped: it would trace the same pixels); above 0, the
                                  cadence is off and a viewer's pass is due when its eye has
                                  left the cube of half-side chunk_move around its eye when
                                  its last pass was due, or its dir or fov_deg changed (and at
                                  once for a new viewer, or the faces an edit reaches); at
                                  most 1e5                                                   */
    vis_traversal chunk_traversal; /* the chunk passes' traversal; VIS_TRAVERSAL_AUTO (default):
                                  the backend's (vis_traversal): on the CPU packets, 4x4 at
                                  the default chunk_res (docs/server.md); every method gives
                                  the same IDs                                               */
    uint32_t chunk_face_budget;/* faces (chunk_res^2 rays each) of the chunk passes traced per
                                  call; 0 (default): every face due. Past it, due faces wait
                                  for a later call, keeping their last IDs (a new viewer's
                                  list holds only its faces traced so far: 0 chunks before the
                                  first), and are traced first then: faces of viewers with no
                                  list (or that changed between in view and all around), then
                                  faces an edit reached, then the rest, the oldest trace
                                  first, then input order, then face order (deterministic): a
                                  waiting face competes in its class, so faces due only by
                                  cadence or motion wait while more than the budget are new or
                                  reached by edits on every call. Each face is traced from the
                                  viewer's eye on the call that traces it. Bounds a call's
                                  chunk rays to budget x chunk_res^2 (a first tick of many new
                                  viewers, an edit near many, one viewer's all-around pass)  */
    double margin;             /* voxels added around eye regions and swept boxes; default 0 */
    double peek_speed;         /* voxels per second the viewer may move, in any direction,
                                  on top of its velocity (a peek); default 0                 */
    uint32_t hold_ticks;       /* an entity seen stays reported this many ticks more;
                                  default 0                                                   */
    uint64_t ray_budget;       /* entity rays per call (all viewers), shared over the viewers
                                  with pairs the cache does not answer (water-filling:
                                  viewers with nothing to prove leave theirs to the others;
                                  each share within viewer_ray_budget), each spending its
                                  share by priority; 0 = no limit                           */
    uint32_t viewer_ray_budget;/* entity rays per viewer per call; 0 = no limit              */
    uint32_t pair_ray_limit;   /* rays spent proving one pair hidden before it is reported
                                  unchecked; default 16, at most 4096                        */
    double proof_slack;        /* voxels a proof reaches ahead along each velocity, so that it
                                  stays valid while viewer and entity move on: a pair is not
                                  proven again while its eye region and swept box stay inside
                                  the regions last proven. Each proof reaches 1/2 to 3/2 of
                                  it, drawn from the pair and the tick, so that proofs made
                                  on one tick do not all end on one later tick; a new pair,
                                  like one whose hidden proof ended, tries the regions grown
                                  ahead first. At most 1e5; 0 = default (0.5), negative =
                                  none (exact regions, re-proven on any move)                */
    uint32_t unsettled_ticks;  /* a pair whose proof was given its whole pair_ray_limit and
                                  ended without an answer is reported (VIS_QUERY_UNCHECKED)
                                  and proven again this many ticks later (1: the next tick),
                                  earlier when its eye region or swept box leaves the regions
                                  grown by proof_slack or an edit reaches them; 0 = default
                                  (1), at most 1024. Saves rays where the proof is weak
                                  (hills, docs/server.md); sends a few more pairs            */
    uint32_t threads;          /* viewers run in parallel on this many threads (the caller
                                  included); 0 = the context's CPU thread count (its
                                  parallel_for when it has one), 1 = the calling thread. On a
                                  CPU context, the context's count runs them on its workers;
                                  another count starts the query's own                       */
    vis_query_solid_fn solid;  /* NULL (default): not asked. Otherwise a plane through solid
                                  matter, where a voxel mesh has no quads, also blocks the
                                  segments that cross it there: pairs whose segments run
                                  through hills are proven hidden (docs/server.md, "Proofs
                                  through solid ground"). Eye positions inside solid matter
                                  are not protected (a player's eye is in the open)          */
    void *solid_user;          /* handed to solid                                            */
} vis_query_desc;

VIS_API void vis_query_desc_defaults(vis_query_desc *desc);

/* A player. Coordinates are world coordinates (as vis_camera's), speeds in voxels per
 * second, latency in milliseconds. */
typedef struct vis_query_viewer {
    uint32_t id;           /* 1..VIS_MAX_OBJECT_ID, unique in the call; an entity with the
                              same ID is the viewer itself and is never reported to it       */
    double eye[3];
    double dir[3];         /* view direction; (0,0,0) = all around (6 faces of 90 degrees);
                              refused when eye + dir is eye in double, or so close to it
                              that their distance's square underflows                       */
    double fov_deg;        /* the in-view pass's field of view, horizontal and vertical,
                              [VIS_QUERY_MIN_FOV, VIS_QUERY_MAX_FOV]; ignored all around     */
    double velocity[3];
    double latency_ms;     /* [0, VIS_QUERY_MAX_LATENCY_MS]                                  */
} vis_query_viewer;

/* An entity: a box with a velocity (world coordinates, voxels per second). */
typedef struct vis_query_entity {
    uint32_t id;           /* 1..VIS_MAX_OBJECT_ID, unique in the call                       */
    double box_min[3];     /* box_min < box_max on every axis (no empty boxes)               */
    double box_max[3];
    double velocity[3];
} vis_query_entity;

/* Why an entity is in a viewer's list. */
typedef enum vis_query_reason {
    VIS_QUERY_SEEN = 1,    /* a segment from the eye region to the swept box is unblocked    */
    VIS_QUERY_UNCHECKED,   /* not proven hidden: the ray budget or pair_ray_limit ran out
                              (this tick, or a proof still waiting out unsettled_ticks)     */
    VIS_QUERY_HELD         /* proven hidden, but seen less than hold_ticks ticks ago         */
} vis_query_reason;

typedef struct vis_query_hit {
    uint32_t id;           /* entity ID                                                      */
    uint32_t reason;       /* vis_query_reason                                               */
} vis_query_hit;

typedef struct vis_query_stats {
    uint64_t tick;             /* ticks run so far, this one included                         */
    uint64_t entity_rays;      /* segments cast and plane tests (each counts one ray)         */
    uint64_t chunk_rays;       /* pixels of the chunk passes traced this tick                  */
    uint64_t solid_tests;      /* boxes asked of vis_query_desc.solid (not counted as rays)    */
    uint32_t pairs;            /* viewer-entity pairs (the viewer's own entity excluded)      */
    uint32_t pairs_cached;     /* answered from an earlier tick's proof: its eye region and
                                  swept box still lie inside the regions it covered (or an
                                  unsettled pair still waiting out unsettled_ticks)          */
    uint32_t pairs_seen, pairs_hidden, pairs_unchecked, pairs_held;
    uint32_t chunk_passes;     /* viewers with a face of their chunk pass traced this tick    */
    uint32_t chunk_edit_passes;/* of those, the viewers with a face traced because a scene edit
                                  (since the last tick, or an earlier one whose face
                                  chunk_face_budget left waiting) reached a ray of it (or
                                  every traced face when the scene's change log no longer
                                  reached back: more than 64 boxes changed)                   */
    uint32_t chunk_faces_deferred; /* faces due that chunk_face_budget left for a later call  */
    double ms;                 /* the call, wall clock                                         */
} vis_query_stats;

/* Creates a query for `scene` with every buffer it will need (no allocation per tick),
 * through the context's allocator, and its pool of threads. desc may be NULL (defaults).
 * It also readies the backend for the chunk passes by tracing a batch of two 1x1 views (an
 * OpenCL device builds its batch program and takes the scene's first upload here rather than
 * on the first tick; vis_context_last_timing then describes that batch), and fails with
 * that trace's error if the backend cannot run them. Destroy the query before its scene and
 * its context (vis_context_destroy does not). */
VIS_API vis_status vis_query_create(vis_context *context, vis_scene *scene, const vis_query_desc *desc,
                                    vis_query **out_query);

/* May be NULL. Nothing else may run on the query meanwhile. */
VIS_API void vis_query_destroy(vis_query *query);

/* One tick. Every viewer and entity is checked first (finite values, bounds, unique IDs,
 * counts within the capacities): on failure VIS_ERROR_INVALID_ARGUMENT (or CAPACITY for a
 * count) with a message naming the item and field, and the query is unchanged (the tick is
 * not counted). viewers may be NULL when viewer_count is 0, entities likewise. The results
 * stay readable until the next run; a backend failure in the chunk passes leaves none
 * (VIS_ERROR_NOT_FOUND until the next successful run). Viewers and entities are matched to
 * the last tick's by ID (holds and caches follow the IDs, not the array positions).
 * out_stats may be NULL.
 * The same calls give the same results on any thread count. */
VIS_API vis_status vis_query_run(vis_query *query, const vis_query_viewer *viewers, uint32_t viewer_count,
                                 const vis_query_entity *entities, uint32_t entity_count,
                                 vis_query_stats *out_stats);

/* The last run's entities for viewer `viewer_index` (its index in that call), sorted by ID.
 * out may be NULL to learn the count (capacity 0); VIS_ERROR_CAPACITY, nothing written,
 * when capacity is below it. VIS_ERROR_NOT_FOUND for an index past the last run's viewers. */
VIS_API vis_status vis_query_entities(vis_query *query, uint32_t viewer_index, vis_query_hit *out,
                                      size_t capacity, size_t *out_count);

/* The last run's chunk objects for the viewer: the object IDs its ID pass saw, sorted. At
 * most chunk_res^2 (in view) or 6 chunk_res^2 (all around). Not conservative: objects seen
 * only between pixel centres are missed (docs/server.md measures how many). Same buffer
 * rules as vis_query_entities. */
VIS_API vis_status vis_query_chunks(vis_query *query, uint32_t viewer_index, uint32_t *out, size_t capacity,
                                    size_t *out_count);

#ifdef __cplusplus
}
#endif

#endif /* VIS_VIS_H */
