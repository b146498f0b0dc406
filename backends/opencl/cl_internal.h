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

#include "backend.h"

/* vis_status values (backend.h: backends return the ints). */
enum {
    VIS_CL_OK = 0,
    VIS_CL_INVALID_ARGUMENT = 1,
    VIS_CL_OUT_OF_MEMORY = 2,
    VIS_CL_UNSUPPORTED = 3,
    VIS_CL_BACKEND = 4,
    VIS_CL_NOT_FOUND = 5
};

/* Kernels built per option set and kept for the backend's life (DESIGN.md: a scene without
 * an effect pays nothing for it, so each effect set gets its own program). */
#define VIS_CL_MAX_PROGRAMS 8

typedef struct vis_cl_program {
    char options[512];
    cl_program program;
    cl_kernel trace;       /* vis_trace_kernel: one view, setup by value        */
    cl_kernel batch;       /* vis_trace_batch_kernel: many views, setups in a buffer */
} vis_cl_program;

typedef struct vis_cl_device_caps {
    char name[128];
    char platform[128];
    char vendor[128];
    char driver[64];
    char version[128];
    int is_gpu;
    int fp64;                 /* cl_khr_fp64 */
    int denorms;              /* CL_FP_DENORM in the single-precision config */
    size_t max_wg;            /* CL_DEVICE_MAX_WORK_GROUP_SIZE */
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

    vis_cl_program programs[VIS_CL_MAX_PROGRAMS];
    uint32_t program_count;

    /* Output buffers (grown on demand, never per frame once large enough). */
    cl_mem ids, depth, setups;
    cl_mem dummy;             /* 16 bytes: the depth argument when no depth is asked for */
    size_t tile[2];           /* work-group shape (8x8 unless $VIS_OPENCL_TILE) */
    size_t out_cap;           /* pixels of `ids` */
    size_t depth_cap;         /* pixels of `depth` */
    size_t setup_cap;         /* setups */

    double last_kernel_ms;    /* from event profiling, summed over a batch's launches */
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
} vis_cl_scene;

/* ---- cl_device.c ---------------------------------------------------------------------- */

/* Picks a device by selector (NULL/"" = $VIS_OPENCL_DEVICE, else the first usable GPU, else
 * the first usable device; "N" = the N-th device over all platforms; otherwise a
 * case-insensitive substring of the device, vendor or platform name). Fills the caps.
 * Returns a vis_status value with the reason in err. */
int vis_cl_device_pick(const char *selector, cl_platform_id *out_platform, cl_device_id *out_device,
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
void vis_cl_scene_release(vis_cl_scene *scene);

/* ---- helpers (cl_backend.c) ------------------------------------------------------------ */

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
