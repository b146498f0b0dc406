/* cl_internal.h — internal to the OpenCL backend: its state and the helpers its files share.
 *
 * Files: cl_device.c picks the platform and device; cl_program.c builds (and caches) the
 * program; cl_scene.c keeps a device copy of each scene and uploads only what changed;
 * cl_backend.c is the vtable (trace, batch, timing). Kernels: kernels/trace.cl, compiled
 * after backends/common/trace_core.h (both embedded into vis_kernels_source). */
#ifndef VIS_CL_INTERNAL_H
#define VIS_CL_INTERNAL_H

#ifndef CL_TARGET_OPENCL_VERSION
#  define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#ifndef CL_PLATFORM_NOT_FOUND_KHR
#  define CL_PLATFORM_NOT_FOUND_KHR -1001 /* cl_khr_icd: the loader found no platform */
#endif

/* ---- cl_loader.c: the ICD loader, opened at run time ---------------------------------------
 *
 * libvis does not link libOpenCL (a CPU-only program needs neither the loader nor a driver);
 * every OpenCL entry point the backend calls is listed here once, read from the loader with
 * dlsym into vis_cl_api, and the cl* names below are mapped onto that table, so the backend's
 * code reads as plain OpenCL. cl_loader.c checks each entry against the prototype in CL/cl.h
 * at compile time. Nothing may call a cl* function before vis_cl_load() succeeded. */
#define VIS_CL_FUNCTIONS(X)                                                                                      \
    X(cl_int, BuildProgram,                                                                                     \
      (cl_program, cl_uint, const cl_device_id *, const char *, void(CL_CALLBACK *)(cl_program, void *), void *)) \
    X(cl_mem, CreateBuffer, (cl_context, cl_mem_flags, size_t, void *, cl_int *))                               \
    X(cl_command_queue, CreateCommandQueue, (cl_context, cl_device_id, cl_command_queue_properties, cl_int *))  \
    X(cl_context, CreateContext,                                                                                \
      (const cl_context_properties *, cl_uint, const cl_device_id *,                                            \
       void(CL_CALLBACK *)(const char *, const void *, size_t, void *), void *, cl_int *))                      \
    X(cl_kernel, CreateKernel, (cl_program, const char *, cl_int *))                                            \
    X(cl_program, CreateProgramWithSource, (cl_context, cl_uint, const char **, const size_t *, cl_int *))      \
    X(cl_int, EnqueueCopyBuffer,                                                                                \
      (cl_command_queue, cl_mem, cl_mem, size_t, size_t, size_t, cl_uint, const cl_event *, cl_event *))       \
    X(cl_int, EnqueueFillBuffer,                                                                                \
      (cl_command_queue, cl_mem, const void *, size_t, size_t, size_t, cl_uint, const cl_event *, cl_event *)) \
    X(void *, EnqueueMapBuffer,                                                                                 \
      (cl_command_queue, cl_mem, cl_bool, cl_map_flags, size_t, size_t, cl_uint, const cl_event *, cl_event *,  \
       cl_int *))                                                                                               \
    X(cl_int, EnqueueUnmapMemObject, (cl_command_queue, cl_mem, void *, cl_uint, const cl_event *, cl_event *)) \
    X(cl_int, EnqueueNDRangeKernel,                                                                             \
      (cl_command_queue, cl_kernel, cl_uint, const size_t *, const size_t *, const size_t *, cl_uint,           \
       const cl_event *, cl_event *))                                                                           \
    X(cl_int, EnqueueReadBuffer,                                                                                \
      (cl_command_queue, cl_mem, cl_bool, size_t, size_t, void *, cl_uint, const cl_event *, cl_event *))      \
    X(cl_int, EnqueueWriteBuffer,                                                                               \
      (cl_command_queue, cl_mem, cl_bool, size_t, size_t, const void *, cl_uint, const cl_event *, cl_event *))\
    X(cl_int, Finish, (cl_command_queue))                                                                       \
    X(cl_int, GetDeviceIDs, (cl_platform_id, cl_device_type, cl_uint, cl_device_id *, cl_uint *))               \
    X(cl_int, GetDeviceInfo, (cl_device_id, cl_device_info, size_t, void *, size_t *))                          \
    X(cl_int, GetEventProfilingInfo, (cl_event, cl_profiling_info, size_t, void *, size_t *))                   \
    X(cl_int, GetPlatformIDs, (cl_uint, cl_platform_id *, cl_uint *))                                           \
    X(cl_int, GetPlatformInfo, (cl_platform_id, cl_platform_info, size_t, void *, size_t *))                    \
    X(cl_int, GetProgramBuildInfo, (cl_program, cl_device_id, cl_program_build_info, size_t, void *, size_t *)) \
    X(cl_int, ReleaseCommandQueue, (cl_command_queue))                                                          \
    X(cl_int, ReleaseContext, (cl_context))                                                                     \
    X(cl_int, ReleaseEvent, (cl_event))                                                                         \
    X(cl_int, ReleaseKernel, (cl_kernel))                                                                       \
    X(cl_int, ReleaseMemObject, (cl_mem))                                                                       \
    X(cl_int, ReleaseProgram, (cl_program))                                                                     \
    X(cl_int, SetKernelArg, (cl_kernel, cl_uint, size_t, const void *))                                        \
    X(cl_int, WaitForEvents, (cl_uint, const cl_event *))

typedef struct vis_cl_api {
#define VIS_CL_MEMBER(ret, fn, params) ret(CL_API_CALL *fn) params;
    VIS_CL_FUNCTIONS(VIS_CL_MEMBER)
#undef VIS_CL_MEMBER
} vis_cl_api;

/* Opens the loader ($VIS_OPENCL_LIBRARY, else libOpenCL.so.1, else libOpenCL.so) once per
 * process and fills the table. Thread-safe; a failure (UNSUPPORTED, the reason in err) is not
 * remembered. Returns a vis_status value. */
int vis_cl_load(char *err, size_t err_size);
/* The table; valid after a successful vis_cl_load(). */
const vis_cl_api *vis_cl_api_table(void);

/* 1 when every OpenCL implementation the ICD loader would open (the .icd files it reads, by
 * its environment variables) is a CPU-only one, with a sentence saying so in `why`; 0 when
 * any may offer a GPU, nothing is listed, or the list cannot be read. Opens nothing. */
int vis_cl_icds_cpu_only(char *why, size_t why_size);
/* 1 when PoCL (its library `library`, a path or a bare name; may be NULL) offers CPU devices
 * only: $POCL_DEVICES names CPU drivers only, or else no GPU driver module is installed. */
int vis_cl_pocl_cpu_only(const char *library);

#ifndef VIS_CL_LOADER_NO_NAMES
#  define clBuildProgram (vis_cl_api_table()->BuildProgram)
#  define clCreateBuffer (vis_cl_api_table()->CreateBuffer)
#  define clCreateCommandQueue (vis_cl_api_table()->CreateCommandQueue)
#  define clCreateContext (vis_cl_api_table()->CreateContext)
#  define clCreateKernel (vis_cl_api_table()->CreateKernel)
#  define clCreateProgramWithSource (vis_cl_api_table()->CreateProgramWithSource)
#  define clEnqueueCopyBuffer (vis_cl_api_table()->EnqueueCopyBuffer)
#  define clEnqueueFillBuffer (vis_cl_api_table()->EnqueueFillBuffer)
#  define clEnqueueMapBuffer (vis_cl_api_table()->EnqueueMapBuffer)
#  define clEnqueueUnmapMemObject (vis_cl_api_table()->EnqueueUnmapMemObject)
#  define clEnqueueNDRangeKernel (vis_cl_api_table()->EnqueueNDRangeKernel)
#  define clEnqueueReadBuffer (vis_cl_api_table()->EnqueueReadBuffer)
#  define clEnqueueWriteBuffer (vis_cl_api_table()->EnqueueWriteBuffer)
#  define clFinish (vis_cl_api_table()->Finish)
#  define clGetDeviceIDs (vis_cl_api_table()->GetDeviceIDs)
#  define clGetDeviceInfo (vis_cl_api_table()->GetDeviceInfo)
#  define clGetEventProfilingInfo (vis_cl_api_table()->GetEventProfilingInfo)
#  define clGetPlatformIDs (vis_cl_api_table()->GetPlatformIDs)
#  define clGetPlatformInfo (vis_cl_api_table()->GetPlatformInfo)
#  define clGetProgramBuildInfo (vis_cl_api_table()->GetProgramBuildInfo)
#  define clReleaseCommandQueue (vis_cl_api_table()->ReleaseCommandQueue)
#  define clReleaseContext (vis_cl_api_table()->ReleaseContext)
#  define clReleaseEvent (vis_cl_api_table()->ReleaseEvent)
#  define clReleaseKernel (vis_cl_api_table()->ReleaseKernel)
#  define clReleaseMemObject (vis_cl_api_table()->ReleaseMemObject)
#  define clReleaseProgram (vis_cl_api_table()->ReleaseProgram)
#  define clSetKernelArg (vis_cl_api_table()->SetKernelArg)
#  define clWaitForEvents (vis_cl_api_table()->WaitForEvents)
#endif

#include "backend.h"

/* Kernels built per option set and kept for the backend's life (DESIGN.md: a scene without
 * an effect pays nothing for it, so each effect set gets its own program). */
#define VIS_CL_MAX_PROGRAMS 32
/* Of those, the effects programs built for one method and effect set (cl_backend.c): the rest
 * stays for the plain option sets (methods x ID modes) and the one generic effects program. */
#define VIS_CL_MAX_EFFECT_PROGRAMS 15

/* Local memory of a work-group walking the tree as one packet (kernels/tile.cl): 16 bytes of
 * flags, then VIS_STACK_SIZE entries of node, box lo and box hi (28 bytes; tile.cl checks). */
#define VIS_CL_TILE_ENTRY_BYTES 28u
#define VIS_CL_TILE_LOCAL_BYTES (16u + VIS_STACK_SIZE * VIS_CL_TILE_ENTRY_BYTES)

typedef struct vis_cl_program {
    char options[512];
    cl_program program;
    cl_kernel trace;       /* vis_trace_kernel: one view, setup by value        */
    cl_kernel batch;       /* vis_trace_batch_kernel: many views, setups in a buffer */
    cl_kernel drawlist;    /* vis_trace_drawlist_kernel: the batch kernel counting pixels per key */
    cl_kernel compact;     /* vis_drawlist_compact: counts to per-view lists            */
    cl_kernel block_count; /* vis_drawlist_block_count: slots with pixels per block, before compact */
    cl_kernel pack;        /* vis_drawlist_pack: a batch's lists one after the other    */
    cl_kernel effects;     /* vis_trace_effects_kernel (-DVIS_TRACE_EFFECTS programs only) */
    int persistent;        /* built with -DVIS_CL_PERSISTENT: trace, batch and drawlist take the tile
                              counter and the view count as their two last arguments */
} vis_cl_program;

typedef struct vis_cl_device_caps {
    char name[128];
    char platform[128];
    char vendor[128];
    char driver[64];
    char version[128];
    int is_gpu;
    int fp64;                 /* CL_DEVICE_DOUBLE_FP_CONFIG != 0 (cl_khr_fp64) */
    int denorms;              /* CL_FP_DENORM in the single-precision config */
    size_t max_wg;            /* CL_DEVICE_MAX_WORK_GROUP_SIZE */
    cl_uint compute_units;    /* CL_DEVICE_MAX_COMPUTE_UNITS (SMs on NVIDIA) */
    size_t max_item[3];       /* CL_DEVICE_MAX_WORK_ITEM_SIZES */
    cl_ulong max_alloc;       /* CL_DEVICE_MAX_MEM_ALLOC_SIZE */
    cl_ulong global_mem;
} vis_cl_device_caps;

typedef struct vis_cl_backend {
    cl_platform_id platform;
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    vis_cl_device_caps caps;
    vis_backend_log_fn log;
    void *log_user;
    vis_allocator alloc;      /* the context's: every host allocation of the backend */

    vis_cl_program programs[VIS_CL_MAX_PROGRAMS];
    uint32_t program_count;
    uint32_t effect_programs; /* built for one method and effect set (at most VIS_CL_MAX_EFFECT_PROGRAMS) */

    /* Output buffers (grown on demand, never per frame once large enough). */
    cl_mem ids, depth, setups;
    cl_mem dummy;             /* 16 bytes: the depth argument when no depth is asked for */
    size_t tile[2];           /* work-group shape of one view's pass (8x8 unless $VIS_OPENCL_TILE) */
    size_t batch_tile[2];     /* and of a batch's (8x4 unless $VIS_OPENCL_TILE; docs/opencl.md,
                                 "Work-group shape and register cap for batches") */
    char extra_options[256];  /* $VIS_OPENCL_BUILD_OPTIONS: appended to every build (tuning,
                                 e.g. -cl-nv-maxrregcount=64; never options that change results) */
    size_t out_cap;           /* pixels of `ids` */
    size_t depth_cap;         /* pixels of `depth` */
    size_t setup_cap;         /* setups */
    cl_mem fx_layers, fx_reflection, fx_shadow; /* effects outputs (vis_trace_effects)    */
    size_t fx_layers_cap, fx_reflection_cap, fx_shadow_cap;

    /* The draw list on the device (cl_drawlist.c): per-key pixel counts with the views' list
     * heads in front, the lists, and pinned host memory (CL_MEM_ALLOC_HOST_PTR, mapped once
     * for the backend's life) that heads and lists are read into. */
    cl_mem dl_counts, dl_list, dl_packed, dl_blocks, dl_pinned;
    size_t dl_counts_cap;     /* uints of dl_counts                                      */
    size_t dl_list_cap;       /* entries (uint2) of dl_list                               */
    size_t dl_packed_cap;     /* entries (uint2) of dl_packed: the lists, one after another */
    size_t dl_blocks_cap;     /* uints of dl_blocks: per view, the entries of each block of slots */
    size_t dl_pinned_cap;     /* bytes of dl_pinned                                       */
    void *dl_host;            /* dl_pinned, mapped                                        */
    /* Words [dl_zero_lo, dl_zero_hi) of dl_counts are zero: the compaction of object IDs
     * leaves every count it read at zero, so a launch whose counts lie there needs no fill. */
    size_t dl_zero_lo, dl_zero_hi;
    /* Entries a one-view launch reads first (with its head in front): the last one-view list's
     * length and a margin (0 before the first; DL_FIRST_READ_MIN is applied where it is read);
     * a longer list takes a second read. */
    size_t dl_first_read;

    /* Staged scene uploads (cl_scene.c): pinned host memory mapped for the backend's life,
     * its device copy, and the event of the last scatter that read it. The scatter kernel
     * (vis_scatter_words) comes from the program built when the backend is created. */
    cl_kernel stage_scatter;
    cl_mem stage_pinned, stage_dev;
    void *stage_host;
    cl_event stage_done;
    struct vis_cl_scene *stage_scene; /* the copy that scatter writes                       */
    int stage_unavailable;    /* staging memory could not be made: writes per range instead */

    double last_kernel_ms;    /* from event profiling, summed over a batch's launches */

    /* How the per-ray kernels walk ($VIS_OPENCL_WALK, docs/opencl.md "Persistent threads and
     * leaf postponing"): the options of each method's program for one view and for batches
     * (vis_cl_method_options), and the persistent kernels' tile counter (two words, zero
     * between launches). */
    char method_options[VIS_TRAVERSAL_ID_DDA + 1u][128];
    char batch_options[VIS_TRAVERSAL_ID_DDA + 1u][128];
    cl_mem pt_counter;
} vis_cl_backend;

/* A device array of one scene: capacity in elements, `valid` = elements in sync. */
typedef struct vis_cl_array {
    cl_mem mem;
    size_t cap;
    size_t valid;
    size_t elem;
} vis_cl_array;

typedef struct vis_cl_scene {
    vis_cl_array nodes, leaves, buckets, quads, tris, objects, object_leaves, ropes, rope_index;
    uint64_t last_upload_bytes;
    uint64_t total_upload_bytes;
    uint32_t reallocations;   /* device buffers grown past their capacity (counted, logged) */
    int stale;                /* a staged upload into this copy failed: the next sync sends all */
} vis_cl_scene;

/* ---- cl_device.c ---------------------------------------------------------------------- */

/* Picks a device by selector (NULL/"" = $VIS_OPENCL_DEVICE, else the first usable GPU, else
 * the first usable device; "N" = the N-th device over all platforms; otherwise a
 * case-insensitive substring of the device, vendor or platform name). gpu_only: no selector,
 * the first usable GPU or none, and CPU-only platforms are not asked for devices. Fills the
 * caps. Returns a vis_status value with the reason in err. */
int vis_cl_device_pick(const char *selector, int gpu_only, cl_platform_id *out_platform, cl_device_id *out_device,
                       vis_cl_device_caps *caps, char *err, size_t err_size);

/* Reads a device's capabilities and checks what bit-identical rays need (correctly rounded
 * division and square root). Returns a vis_status value (UNSUPPORTED with the reason). */
int vis_cl_device_check(cl_platform_id platform, cl_device_id device, vis_cl_device_caps *caps, char *err,
                        size_t err_size);

/* ---- cl_program.c --------------------------------------------------------------------- */

/* The program for an option set ("" = no effects), built on first use and cached. */
int vis_cl_program_get(vis_cl_backend *b, const char *options, vis_cl_program **out, char *err, size_t err_size);
void vis_cl_programs_release(vis_cl_backend *b);

/* ---- cl_scene.c ----------------------------------------------------------------------- */

int vis_cl_scene_sync(vis_cl_backend *b, vis_cl_scene **scene, const vis_scene_view *view,
                      const vis_scene_changes *changes, char *err, size_t err_size);
void vis_cl_scene_release(vis_cl_backend *b, vis_cl_scene *scene);
/* Releases the upload staging memory (unmapping it; the queue must be finished). */
void vis_cl_staging_release(vis_cl_backend *b);

/* ---- cl_drawlist.c ----------------------------------------------------------------------- */

/* The backend's trace_drawlist (backend.h). */
vis_status vis_cl_trace_drawlist(void *impl, void *scene_data, const vis_scene_view *view, const vis_ray_setup *setups,
                                 uint32_t count, uint32_t *ids, float *depth, vis_draw_entry *entries, size_t capacity,
                                 size_t *per_view, size_t *total, char *err, size_t err_size);
/* Releases the draw list's buffers (unmapping the pinned one). */
void vis_cl_drawlist_release(vis_cl_backend *b);

/* ---- helpers (cl_backend.c) ------------------------------------------------------------ */

/* The program for one traversal method (-DVIS_TRAVERSAL_ONLY), "" when they differ. */
const char *vis_cl_traversal_options(uint32_t traversal);
/* The same with this backend's walk options added where they apply: for one view, or for a
 * launch of several (`batch`; persistent threads by default on a GPU). */
const char *vis_cl_method_options(const vis_cl_backend *b, uint32_t traversal, int batch);
/* " -cl-nv-maxrregcount=N" for a method's batch program on NVIDIA, or "" (cl_backend.c). */
const char *vis_cl_batch_register_cap(const char *platform, uint32_t traversal, const char *extra);
/* Fills method_options and batch_options from $VIS_OPENCL_WALK's words (`walk`, NULL = none)
 * and the device (caps.platform, caps.is_gpu, extra_options); makes the persistent kernels'
 * counter when a walk needs it (the only OpenCL call: none for "plain"). */
int vis_cl_walk_options(vis_cl_backend *b, const char *walk, char *err, size_t err_size);
/* Enqueues kernel k of program p over width x height x views (vis_cl_grid's tiles, a batch's
 * when `batch`; a persistent program gets about as many groups as the device runs at once and
 * its counter and view count as arguments pt_arg and pt_arg + 1). ev: the launch's event. */
cl_int vis_cl_enqueue_pass(vis_cl_backend *b, const vis_cl_program *p, cl_kernel k, cl_uint pt_arg, uint32_t width,
                           uint32_t height, uint32_t views, int batch, cl_event *ev);
/* Grows a device buffer to `need` elements of `elem` bytes (never per frame once large). */
int vis_cl_ensure_buffer(vis_cl_backend *b, cl_mem *mem, size_t *cap, size_t need, size_t elem, cl_mem_flags flags,
                         const char *what, char *err, size_t err_size);
/* Sets the scene arrays as kernel arguments first, first + 1, ... (VIS_SCENE_ARGS order). */
int vis_cl_set_scene_args(cl_kernel k, const vis_cl_scene *sc, cl_uint first);
/* The program for a batch of `count` >= 1 setups (cl_backend.c). */
int vis_cl_batch_program(vis_cl_backend *b, const vis_ray_setup *setups, uint32_t count, vis_cl_program **p,
                         char *err, size_t err_size);
/* Global and local sizes of a pass over width x height x views in the backend's tiles, a
 * batch's when `batch` (every launch of one call takes the same: the kernels' local memory
 * is sized from them), local = 1x1 where the device cannot run a whole tile. */
void vis_cl_grid(const vis_cl_backend *b, uint32_t width, uint32_t height, uint32_t views, int batch,
                 size_t global[3], size_t local[3]);
/* Bytes of the cached stack's local ring for a pass with this setup in groups of `local`
 * (vis_cl_grid's; at least one entry per work-item: every kernel takes the argument). */
size_t vis_cl_ring_bytes(const vis_ray_setup *setup, const size_t local[3]);
/* Adds the device time of a finished event to b->last_kernel_ms. */
void vis_cl_add_event_time(vis_cl_backend *b, cl_event ev);

const char *vis_cl_error_name(cl_int e);
/* vis_status for an OpenCL error: allocation failures are OUT_OF_MEMORY, others BACKEND. */
int vis_cl_status(cl_int e);
/* Writes "what: NAME (code)" into err and returns vis_cl_status(e). */
int vis_cl_fail(cl_int e, const char *what, char *err, size_t err_size);
void vis_cl_log(const vis_cl_backend *b, int level, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif
