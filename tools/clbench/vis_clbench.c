/* vis_clbench.c — OpenCL conformance and timing on a real world, for machines where the
 * cmocka tests cannot run (a GPU box without cmocka) and for the figures in docs/opencl.md.
 *
 *   vis_clbench [--scene SPEC] [--device SEL] [--cameras N] [--reps N] [--batch N,N,...]
 *
 * 1. Conformance: the camera path of the world plus N random cameras, 512x512 and 61x47,
 *    object and leaf IDs, every traversal method, CPU backend vs OpenCL: ID and depth buffers
 *    must be equal byte for byte; then the same after random voxel edits. Exit code 1 on any
 *    difference.
 * 2. One 512x512 pass: kernel time (event profiling) and end-to-end time (vis_trace: sync,
 *    kernel, readback of IDs and depths), median and minimum over --reps passes per view.
 * 3. Batches: vis_trace_batch of N views at 512x512 (IDs only, and IDs + depths): kernel and
 *    end-to-end rays per second.
 * 4. Bytes uploaded per single-voxel edit (median, max over 200 edits).
 * 5. --methods 1: Chang & Ihm's Table 3 and 5 for this scene: kernel time of each traversal
 *    method (short and cached stacks of 1-3 and 7) on every camera-path view, 512x512, and
 *    the median over the views in Mrays/s. --only "stack (,dda" runs only the rows whose names
 *    start with one of the comma-separated prefixes (a register sweep needs two rows).
 * 6. --drawlist 1: vis_trace_drawlist (the list built on the device, only the list read back)
 *    per path view, kernel and end-to-end, against vis_trace + vis_drawlist_build; batches of
 *    views with draw lists as the output (vis_trace_batch_drawlist); single-voxel edits
 *    followed by the next draw-list pass, timed with their upload.
 * 7. --walks "W;W@8x4;...": the kernels' walks ($VIS_OPENCL_WALK: plain, default, persistent,
 *    postpone, ...) side by side, each in its own context, checked against the CPU, then timed
 *    in --rounds alternating rounds (stack method per path view, a batch of the last --batch
 *    count with draw lists).
 * --conformance 0 skips 1 (for large scenes), --passes 0 skips 2-4; --traversal N (the
 * vis_traversal value) is the method of 6. --copies N adds to 6 a batch of N copies of each
 * view (kernel ms per view): what the view costs where the device is full, against its time
 * alone.
 * With --nv-verbose 1 it only prints NVIDIA's kernel build log with -cl-nv-verbose
 * (registers, spills, stack per kernel), for the program of every method, and with
 * $VIS_CLBENCH_PTX=DIR writes each program's binary (PTX on NVIDIA) into DIR;
 * $VIS_CLBENCH_NV_ONLY=N builds only method N's plain program (fewer builds per device call).
 *
 * Built as the CMake target vis_clbench whenever the OpenCL backend is (docs/opencl.md). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include "camera_path.h"
#include "timer.h"
#include "vis/vis.h"
#include "voxelworld/vw.h"
#include "world_scene.h"

static uint64_t rng_next(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double rng_unit(uint64_t *s) { return (double)(rng_next(s) >> 11) * (1.0 / 9007199254740992.0); }

static void die(const char *what, vis_context *ctx)
{
    fprintf(stderr, "vis_clbench: %s: %s\n", what, ctx ? vis_context_last_error(ctx) : "");
    exit(2);
}

/* A failed vis_context_create has no context to ask: its reason comes through the log. */
static void log_errors(vis_log_level level, const char *message, void *user)
{
    (void)user;
    if (level >= VIS_LOG_ERROR)
        fprintf(stderr, "vis_clbench: %s\n", message);
}

static vis_context *open_ctx(vis_backend_kind kind, const char *device)
{
    vis_context_desc d;
    vis_context_desc_defaults(&d);
    d.backend = kind;
    d.opencl_device = device;
    d.log = log_errors;
    vis_context *ctx = NULL;
    vis_status st = vis_context_create(&d, &ctx);
    if (st != VIS_OK) {
        fprintf(stderr, "vis_clbench: no %s context (%s)\n", kind == VIS_BACKEND_CPU ? "CPU" : "OpenCL",
                vis_status_string(st));
        exit(2);
    }
    return ctx;
}

/* A camera somewhere above the terrain, looking at a random point of the world. */
static void random_camera(const vw_world *w, uint64_t *rng, vis_camera *cam)
{
    double lo[3], hi[3];
    world_scene_bounds(w, lo, hi);
    memset(cam, 0, sizeof *cam);
    int64_t x = (int64_t)(lo[0] + rng_unit(rng) * (hi[0] - lo[0]));
    int64_t z = (int64_t)(lo[2] + rng_unit(rng) * (hi[2] - lo[2]));
    double ground = (double)vc_surface_height(w, x, z);
    cam->eye[0] = (double)x + rng_unit(rng);
    cam->eye[2] = (double)z + rng_unit(rng);
    cam->eye[1] = ground + 1.5 + rng_unit(rng) * (rng_unit(rng) < 0.5 ? 8.0 : 120.0);
    if (rng_unit(rng) < 0.15) /* on integer planes (chunk corners, split planes) */
        for (int a = 0; a < 3; ++a)
            cam->eye[a] = floor(cam->eye[a] / 16.0) * 16.0 + (a == 1 ? 16.0 : 0.0);
    for (int a = 0; a < 3; ++a)
        cam->target[a] = lo[a] + rng_unit(rng) * (hi[a] - lo[a]);
    cam->target[1] = ground + (rng_unit(rng) - 0.5) * 40.0;
    if (rng_unit(rng) < 0.1) { /* along an axis */
        cam->target[0] = cam->eye[0];
        cam->target[2] = cam->eye[2] + (rng_unit(rng) < 0.5 ? 50.0 : -50.0);
        cam->target[1] = cam->eye[1];
    }
    cam->fovy_deg = 40.0 + rng_unit(rng) * 60.0;
}

typedef struct bufs {
    uint32_t *ia, *ib;
    float *da, *db;
    size_t n; /* elements of each */
} bufs;

/* Traversal methods vis.h names, AUTO (0) to DDA: the conformance log counts them all. */
enum { TRAVERSALS = VIS_TRAVERSAL_DDA + 1 };
static uint32_t g_size = 512; /* --size: the square pass of sections 5 and 6 */
static uint64_t g_compared, g_failures;

static void compare(vis_context *cpu, vis_scene *sa, vis_context *cl, vis_scene *sb, const vis_camera *cam, uint32_t W,
                    uint32_t H, bufs *b, const char *what)
{
    size_t n = (size_t)W * H;
    for (uint32_t mode = 0; mode < 2; ++mode)
        for (uint32_t t = VIS_TRAVERSAL_STACK; t <= VIS_TRAVERSAL_DDA; ++t) {
            if (t == (uint32_t)VIS_TRAVERSAL_BRUTEFORCE && W * H > 16 * 12)
                continue; /* brute force: every quad per ray, tiny buffers only (packets: the CPU's
                           * tiles against the device's work-group walk, both exact) */
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = W;
            td.height = H;
            td.ids = (vis_id_mode)mode;
            td.traversal = (vis_traversal)t;
            td.short_stack = 1u + (uint32_t)(g_compared % 8u);
            memset(b->ib, 0xAB, n * 4);
            if (vis_trace(cpu, sa, cam, &td, b->ia, b->n, b->da, b->n) != VIS_OK)
                die("cpu trace", cpu);
            if (vis_trace(cl, sb, cam, &td, b->ib, b->n, b->db, b->n) != VIS_OK)
                die("opencl trace", cl);
            ++g_compared;
            size_t bad = 0, first = 0;
            for (size_t i = 0; i < n; ++i)
                if (b->ia[i] != b->ib[i] || memcmp(&b->da[i], &b->db[i], 4) != 0) {
                    if (!bad)
                        first = i;
                    ++bad;
                }
            if (bad) {
                ++g_failures;
                printf("MISMATCH %s %ux%u ids=%u traversal=%u: %zu pixels; first (%zu,%zu): cpu %u %.9g, opencl %u %.9g\n",
                       what, W, H, mode, t, bad, first % W, first / W, b->ia[first], (double)b->da[first],
                       b->ib[first], (double)b->db[first]);
            }
        }
}

/* Builds the embedded kernels on the first NVIDIA device with -cl-nv-verbose and prints
 * the build log: ptxas's registers, spills and stack frame per kernel (why a kernel is as
 * fast as it is). Same source and options as the library, plus the verbose flag. */
extern const char vis_kernels_source[];
extern const size_t vis_kernels_source_size;

/* The program's binary (NVIDIA's is PTX text) as DIR/program_M.ptx. */
static void write_binary(cl_program prog, const char *dir, size_t m)
{
    size_t size = 0;
    if (clGetProgramInfo(prog, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, NULL) != CL_SUCCESS || size == 0)
        return;
    unsigned char *bin = malloc(size);
    char path[1024];
    snprintf(path, sizeof path, "%s/program_%zu.ptx", dir, m);
    FILE *f = bin && clGetProgramInfo(prog, CL_PROGRAM_BINARIES, sizeof bin, &bin, NULL) == CL_SUCCESS
                  ? fopen(path, "wb") : NULL;
    if (f) {
        fwrite(bin, 1, size, f);
        fclose(f);
    }
    free(bin);
}

/* With $VIS_CLBENCH_PTX set to a folder, each program's binary is also written there. */
static void nv_verbose(void)
{
    const char *ptx_dir = getenv("VIS_CLBENCH_PTX");
    cl_platform_id plats[8];
    cl_uint np = 0;
    if (clGetPlatformIDs(8, plats, &np) != CL_SUCCESS)
        return;
    for (cl_uint p = 0; p < np && p < 8; ++p) {
        char name[256] = "";
        clGetPlatformInfo(plats[p], CL_PLATFORM_NAME, sizeof name, name, NULL);
        if (!strstr(name, "NVIDIA"))
            continue;
        cl_device_id dev;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_GPU, 1, &dev, NULL) != CL_SUCCESS)
            return;
        cl_int e;
        cl_context ctx = clCreateContext(NULL, 1, &dev, NULL, NULL, &e);
        const char *pre = "#if defined(cl_khr_fp64)\n#pragma OPENCL EXTENSION cl_khr_fp64 : enable\n#endif\n";
        const char *srcs[2] = {pre, vis_kernels_source};
        size_t lens[2] = {strlen(pre), vis_kernels_source_size};
        const char *extra = getenv("VIS_OPENCL_BUILD_OPTIONS");
        /* The library's per-method programs (cl_backend.c, vis_cl_traversal_options), then the
         * stack method's with the walks of $VIS_OPENCL_WALK (cl_backend.c, walk_options). */
        static const int only[] = {0, 2, 3, 4, 5, 6, 8, 9, 0, 0, 0, 0, 0};
        static const char *const walk[] = {"", "", "", "", "", "", "", "", "-DVIS_CL_PERSISTENT",
                                           "-DVIS_CL_POSTPONE=1", "-DVIS_CL_POSTPONE=2",
                                           "-DVIS_CL_POSTPONE=2 -DVIS_CL_VOTE",
                                           "-DVIS_CL_POSTPONE=2 -DVIS_CL_PERSISTENT"};
        const char *one_env = getenv("VIS_CLBENCH_NV_ONLY");
        const int one = one_env ? atoi(one_env) : 0; /* read once; unset: every program */
        for (size_t m = 0; m < sizeof only / sizeof only[0]; ++m) {
            if (one_env && (walk[m][0] != '\0' || only[m] != one))
                continue;
            char opts[512];
            snprintf(opts, sizeof opts,
                     "-cl-fp32-correctly-rounded-divide-sqrt -cl-nv-verbose -DVIS_TRAVERSAL_ONLY=%du %s %s", only[m],
                     walk[m], extra ? extra : "");
            cl_program prog = clCreateProgramWithSource(ctx, 2, srcs, lens, &e);
            e = clBuildProgram(prog, 1, &dev, opts, NULL, NULL);
            size_t n = 0;
            clGetProgramBuildInfo(prog, dev, CL_PROGRAM_BUILD_LOG, 0, NULL, &n);
            char *log = calloc(n + 1, 1);
            clGetProgramBuildInfo(prog, dev, CL_PROGRAM_BUILD_LOG, n, log, NULL);
            printf("nvidia build (%d), VIS_TRAVERSAL_ONLY=%d, options \"%s\", -cl-nv-verbose log:\n%s\n", (int)e,
                   only[m], opts, log);
            free(log);
            if (ptx_dir && e == CL_SUCCESS)
                write_binary(prog, ptx_dir, m);
            clReleaseProgram(prog);
        }
        clReleaseContext(ctx);
        return;
    }
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of n timings (sorts them). */
static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return v[n / 2];
}

/* 5. Chang & Ihm 2010, Tables 3 and 5, for this scene: per method, the kernel time on each
 * view (median of reps after 3 warm-ups) and the median over the views in Mrays/s. */
static const char *g_only; /* --only: the rows of the methods table to run (prefixes of their names, comma-separated) */

/* Whether the methods table runs row `name` (every row without --only). */
static int method_wanted(const char *name)
{
    if (!g_only)
        return 1;
    for (const char *p = g_only; *p;) {
        size_t n = strcspn(p, ",");
        if (n && !strncmp(name, p, n))
            return 1;
        p += n + (p[n] == ',');
    }
    return 0;
}

static void methods_table(vis_context *cl, vis_scene *B, const vis_camera *def, const vc_view *views, size_t nv,
                          int reps, bufs *b)
{
    static const struct { vis_traversal t; uint32_t n; const char *name; } m[] = {
        {VIS_TRAVERSAL_STACK, 0, "stack (local)"},     {VIS_TRAVERSAL_PACKET, 0, "tile walk (group)"},
        {VIS_TRAVERSAL_RESTART, 0, "restart"},
        {VIS_TRAVERSAL_PUSHDOWN, 0, "pushdown"},       {VIS_TRAVERSAL_SHORTSTACK, 1, "restart stack 1"},
        {VIS_TRAVERSAL_SHORTSTACK, 2, "restart stack 2"}, {VIS_TRAVERSAL_SHORTSTACK, 3, "restart stack 3"},
        {VIS_TRAVERSAL_SHORTSTACK, 7, "restart stack 7"}, {VIS_TRAVERSAL_CACHED_STACK, 1, "cached stack 1"},
        {VIS_TRAVERSAL_CACHED_STACK, 2, "cached stack 2"}, {VIS_TRAVERSAL_CACHED_STACK, 3, "cached stack 3"},
        {VIS_TRAVERSAL_CACHED_STACK, 7, "cached stack 7"}, {VIS_TRAVERSAL_ROPES, 0, "rope"},
        {VIS_TRAVERSAL_ROPES_SHORTSTACK, 1, "rope stack 1"}, {VIS_TRAVERSAL_ROPES_SHORTSTACK, 2, "rope stack 2"},
        {VIS_TRAVERSAL_ROPES_SHORTSTACK, 3, "rope stack 3"}, {VIS_TRAVERSAL_DDA, 0, "dda (cell grid)"},
    };
    double *km = malloc((size_t)reps * sizeof *km);
    printf("\nmethods (Chang & Ihm Tables 3 and 5), %ux%u, kernel ms per view (median of %d), Mrays/s:\n", g_size,
           g_size, reps);
    printf("%-18s", "method");
    for (size_t v = 0; v <= nv; ++v)
        printf(" %8.8s", v == 0 ? "default" : views[v - 1].name);
    printf(" %10s %10s %10s\n", "max ms", "med Mrays", "min Mrays");
    for (size_t i = 0; i < sizeof m / sizeof m[0]; ++i) {
        double per[VC_MAX_VIEWS + 1], mr[VC_MAX_VIEWS + 1], worst = 0.0;
        if (!method_wanted(m[i].name))
            continue;
        printf("%-18s", m[i].name);
        for (size_t v = 0; v <= nv; ++v) {
            const vis_camera *cam = v == 0 ? def : &views[v - 1].camera;
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = td.height = g_size;
            td.traversal = m[i].t;
            if (m[i].n)
                td.short_stack = m[i].n;
            vis_timing tg;
            for (int r = 0; r < 3; ++r)
                vis_trace(cl, B, cam, &td, b->ib, b->n, NULL, 0);
            for (int r = 0; r < reps; ++r) {
                if (vis_trace(cl, B, cam, &td, b->ib, b->n, NULL, 0) != VIS_OK)
                    die("trace", cl);
                vis_context_last_timing(cl, &tg);
                km[r] = tg.kernel_ms;
            }
            per[v] = median(km, reps);
            mr[v] = (double)g_size * g_size / (per[v] * 1e3);
            worst = per[v] > worst ? per[v] : worst;
            printf(" %8.4f", per[v]);
        }
        double mm = median(mr, (int)nv + 1);
        printf(" %10.4f %10.1f %10.1f\n", worst, mm, mr[0]);
    }
    free(km);
}

/* --batch N,N,...: each 1..MAX_BATCH views. */
#define MAX_BATCH 4096u

static int batches_valid(const char *p)
{
    while (*p) {
        char *end;
        unsigned long n = strtoul(p, &end, 10);
        if (end == p || n < 1 || n > MAX_BATCH || (*end && *end != ','))
            return 0;
        p = *end ? end + 1 : end;
    }
    return 1;
}

/* The next count of a --batch list checked by batches_valid; 0 at its end. */
static uint32_t next_batch(const char **p)
{
    char *end;
    uint32_t n = (uint32_t)strtoul(*p, &end, 10);
    *p = *end == ',' ? end + 1 : end;
    return n;
}

/* One warm-up and 5 timed calls of vis_trace_batch_drawlist over cams[0..n), the lists left
 * in be/counts/total; the median kernel and total ms into *k and *t. */
static void time_batch_drawlist(vis_context *cl, vis_scene *B, const vis_camera *cams, uint32_t n,
                                const vis_trace_desc *td, vis_draw_entry *be, size_t bcap, size_t *counts,
                                size_t *total, double *k, double *t)
{
    double bk[5], bt[5];
    vis_timing tg;
    for (int r = 0; r < 6; ++r) {
        if (vis_trace_batch_drawlist(cl, B, cams, n, td, be, bcap, counts, n, total) != VIS_OK)
            die("batch drawlist", cl);
        vis_context_last_timing(cl, &tg);
        if (r) {
            bk[r - 1] = tg.kernel_ms;
            bt[r - 1] = tg.total_ms;
        }
    }
    *k = median(bk, 5);
    *t = median(bt, 5);
}

/* The median kernel ms per view of batches of `copies` copies of one camera, draw lists as
 * the output; -1 where the host memory is missing. */
static double copies_kernel_ms(vis_context *cl, vis_scene *B, const vis_camera *cam, const vis_trace_desc *td,
                               uint32_t copies, size_t cap)
{
    vis_camera *cams = malloc(copies * sizeof *cams);
    vis_draw_entry *be = malloc(cap * copies * sizeof *be);
    size_t *counts = malloc(copies * sizeof *counts), total = 0;
    double k = -1.0, t;
    if (cams && be && counts) {
        for (uint32_t i = 0; i < copies; ++i)
            cams[i] = *cam;
        time_batch_drawlist(cl, B, cams, copies, td, be, cap * copies, counts, &total, &k, &t);
        k /= copies;
    }
    free(cams), free(be), free(counts);
    return k;
}

/* 6. The draw list built on the device, per view, in batches, and after single-voxel edits. */
static void drawlist_section(vis_context *cl, vis_scene *B, const vis_camera *def, const vc_view *views, size_t nv,
                             int reps, bufs *b, const char *batches, vis_traversal trav, vw_world *wb, world_scene *sb,
                             uint64_t *rng, uint32_t copies)
{
    size_t cap = vis_drawlist_bound(B) + 16;
    vis_draw_entry *e1 = malloc(cap * sizeof *e1), *e2 = malloc(cap * sizeof *e2);
    double *km = malloc((size_t)reps * sizeof *km), *tm = malloc((size_t)reps * sizeof *tm),
           *om = malloc((size_t)reps * sizeof *om);
    printf("\ndraw list on the device (vis_trace_drawlist, traversal %d), %ux%u, median of %d (ms):\n", (int)trav,
           g_size, g_size, reps);
    printf("%-12s %8s %12s %12s %12s %22s", "view", "entries", "kernel", "end-to-end", "min e2e",
           "vis_trace+build e2e");
    if (copies)
        printf(" %10s%-4u", "kernel/view x", copies);
    printf("\n");
    vis_trace_desc td;
    vis_trace_desc_defaults(&td);
    td.width = td.height = g_size;
    td.traversal = trav;
    for (size_t v = 0; v <= nv; ++v) {
        const vis_camera *cam = v == 0 ? def : &views[v - 1].camera;
        const char *name = v == 0 ? "default" : views[v - 1].name;
        size_t n1 = 0, n2 = 0;
        vis_timing tg;
        for (int r = 0; r < 5; ++r)
            vis_trace_drawlist(cl, B, cam, &td, e1, cap, &n1, NULL, 0, NULL, 0);
        for (int r = 0; r < reps; ++r) {
            if (vis_trace_drawlist(cl, B, cam, &td, e1, cap, &n1, NULL, 0, NULL, 0) != VIS_OK)
                die("trace_drawlist", cl);
            vis_context_last_timing(cl, &tg);
            km[r] = tg.kernel_ms;
            tm[r] = tg.total_ms;
            double t0 = vc_now_ms();
            if (vis_trace(cl, B, cam, &td, b->ib, b->n, NULL, 0) != VIS_OK ||
                vis_drawlist_build(cl, B, b->ib, g_size, g_size, VIS_IDS_OBJECT, e2, cap, &n2) != VIS_OK)
                die("trace + build", cl);
            om[r] = vc_now_ms() - t0;
        }
        if (n1 != n2 || memcmp(e1, e2, n1 * sizeof *e1) != 0) {
            printf("MISMATCH draw list %s: %zu entries on the device, %zu from the IDs\n", name, n1, n2);
            ++g_failures;
        }
        double kmed = median(km, reps), tmed = median(tm, reps), tmin = tm[0], omed = median(om, reps);
        printf("%-12s %8zu %12.4f %12.4f %12.4f %22.4f", name, n1, kmed, tmed, tmin, omed);
        if (copies)
            printf(" %14.4f", copies_kernel_ms(cl, B, cam, &td, copies, cap));
        printf("\n");
    }
    /* Batches: lists as the only output. */
    printf("\nbatches of %ux%u views, draw lists as the output (vis_trace_batch_drawlist, median of 5):\n", g_size,
           g_size);
    printf("%6s %12s %12s %14s %14s %12s\n", "views", "kernel ms", "total ms", "kernel Grays/s", "e2e Grays/s",
           "entries");
    for (const char *p = batches; *p;) {
        uint32_t n = next_batch(&p);
        if (n == 0)
            break;
        vis_camera *cams = malloc(n * sizeof *cams);
        size_t bcap = cap * n, total = 0;
        vis_draw_entry *be = malloc(bcap * sizeof *be);
        size_t *counts = malloc(n * sizeof *counts);
        if (!cams || !be || !counts) {
            printf("%6u: out of host memory\n", n);
            free(cams), free(be), free(counts);
            break;
        }
        for (uint32_t i = 0; i < n; ++i)
            cams[i] = views[i % nv].camera;
        double k, t;
        time_batch_drawlist(cl, B, cams, n, &td, be, bcap, counts, &total, &k, &t);
        double rays = (double)n * g_size * g_size;
        printf("%6u %12.3f %12.3f %14.2f %14.2f %12zu\n", n, k, t, rays / (k * 1e6), rays / (t * 1e6), total);
        /* every view's list equals a single call's (a large scene's batch runs as several
         * launches, cl_drawlist.c, each with its own counts) */
        size_t at = 0;
        for (uint32_t v = 0; v < n; ++v) {
            size_t n1 = 0;
            vis_trace_drawlist(cl, B, &cams[v], &td, e1, cap, &n1, NULL, 0, NULL, 0);
            if (n1 != counts[v] || memcmp(e1, be + at, n1 * sizeof *e1) != 0) {
                printf("MISMATCH batch draw list, view %u\n", v);
                ++g_failures;
                break;
            }
            at += counts[v];
        }
        free(cams), free(be), free(counts);
    }
    /* Single-voxel edits: the edit (remesh + scene update on the host), then the next
     * draw-list pass, which uploads the changed leaves first. */
    vw_world_info wi;
    vw_world_get_info(wb, &wi);
    int ne = 100;
    double *ed = malloc((size_t)ne * sizeof *ed), *pass = malloc((size_t)ne * sizeof *pass),
           *plain = malloc((size_t)ne * sizeof *plain), *bytes = malloc((size_t)ne * sizeof *bytes),
           *seen = malloc((size_t)ne * sizeof *seen);
    if (!ed || !pass || !plain || !bytes || !seen)
        die("out of memory for the edit timings", NULL);
    vw_error werr;
    for (int i = 0; i < ne; ++i) {
        int64_t x = wi.origin[0] + (int64_t)(rng_next(rng) % (uint64_t)wi.size[0]);
        int64_t z = wi.origin[2] + (int64_t)(rng_next(rng) % (uint64_t)wi.size[2]);
        int64_t y = vc_surface_height(wb, x, z) - (int64_t)(rng_next(rng) % 2);
        size_t n1 = 0;
        vis_timing tg;
        vis_trace_drawlist(cl, B, def, &td, e1, cap, &n1, NULL, 0, NULL, 0);
        vis_context_last_timing(cl, &tg);
        plain[i] = tg.total_ms;
        double t0 = vc_now_ms();
        vw_world_set(wb, x, y, z, vw_world_get(wb, x, y, z) ? 0 : 1);
        if (world_scene_update(sb, NULL, &werr))
            die("update", NULL);
        ed[i] = vc_now_ms() - t0;
        if (vis_trace_drawlist(cl, B, def, &td, e1, cap, &n1, NULL, 0, NULL, 0) != VIS_OK)
            die("trace_drawlist after edit", cl);
        vis_context_last_timing(cl, &tg);
        pass[i] = tg.total_ms;
        bytes[i] = (double)tg.upload_bytes;
        /* What the edit costs until the GPU can see it: the host's part plus what the pass
         * after it took beyond the pass just before it. */
        seen[i] = ed[i] + pass[i] - plain[i];
    }
    double med_ed = median(ed, ne), med_pass = median(pass, ne), med_plain = median(plain, ne),
           med_bytes = median(bytes, ne), med_seen = median(seen, ne); /* sorted now: [ne - 1] is the maximum */
    printf("\nsingle-voxel edits then the next draw-list pass (default view), %d edits, median / max:\n"
           "  edit on the host (world + scene update) %.4f / %.4f ms; next pass with upload %.4f / %.4f ms; "
           "pass without edit %.4f ms; uploaded %.0f / %.0f bytes\n",
           ne, med_ed, ed[ne - 1], med_pass, pass[ne - 1], med_plain, med_bytes, bytes[ne - 1]);
    printf("  edit seen by the GPU (host edit + next pass - pass before it, per edit): median %.4f ms, max %.4f\n",
           med_seen, seen[ne - 1]);
    free(ed), free(pass), free(plain), free(bytes), free(seen);
    free(e1), free(e2), free(km), free(tm), free(om);
}

/* 7. --walks "A;B;...": how the kernels walk ($VIS_OPENCL_WALK, docs/opencl.md "Persistent
 * threads and leaf postponing"), side by side in one process. Each entry is a value of the
 * variable ("plain" for none), optionally with a work-group shape ("persistent@8x4" sets
 * $VIS_OPENCL_TILE too; "default" leaves the variable unset); both are read when a context
 * is created, so each walk gets its own
 * context and its own copy of the scene. First each walk's IDs and depths (object and leaf
 * IDs, the stack method) are compared with the CPU's on every path view and `ncams` random
 * cameras; then, --rounds times, every walk in turn times the stack method's kernel on the
 * default view and the path views (median of reps) and a batch of `batch` path views with
 * draw lists as the output (kernel and end to end, median of 5), its lists compared with the
 * first walk's. Rounds alternate the walks so that drift of the machine hits them alike. */
#define MAX_WALKS 8

static void print_log(vis_log_level level, const char *message, void *user)
{
    (void)user;
    if (level >= VIS_LOG_WARNING || strstr(message, "stack program"))
        printf("  [log] %s\n", message);
}
#define MAX_ROUNDS 8

static void walks_section(vis_context *cpu, vis_scene *A, vw_world *wa, vw_world *wb, const vis_camera *def,
                          const vc_view *views, size_t nv, int reps, int rounds, uint32_t batch, int ncams,
                          const char *device, const char *list, bufs *b)
{
    char names[MAX_WALKS][96];
    size_t nw = 0;
    for (const char *p = list; *p && nw < MAX_WALKS;) {
        size_t n = strcspn(p, ";");
        snprintf(names[nw++], sizeof names[0], "%.*s", (int)(n < 95 ? n : 95), p);
        p += n;
        if (*p)
            ++p;
    }
    if (rounds > MAX_ROUNDS)
        rounds = MAX_ROUNDS;
    vis_context *ctx[MAX_WALKS];
    world_scene *ws[MAX_WALKS];
    const char *old_tile = getenv("VIS_OPENCL_TILE");
    char old_tile_copy[64] = "";
    if (old_tile)
        snprintf(old_tile_copy, sizeof old_tile_copy, "%s", old_tile);
    for (size_t w = 0; w < nw; ++w) {
        char walk[96];
        memcpy(walk, names[w], sizeof walk);
        char *at = strchr(walk, '@');
        if (at)
            *at++ = '\0';
        if (strcmp(walk, "default") == 0) /* the library's default: the variable unset */
            unsetenv("VIS_OPENCL_WALK");
        else
            setenv("VIS_OPENCL_WALK", walk, 1);
        if (at)
            setenv("VIS_OPENCL_TILE", at, 1);
        else if (old_tile)
            setenv("VIS_OPENCL_TILE", old_tile_copy, 1);
        else
            unsetenv("VIS_OPENCL_TILE");
        vis_context_desc d;
        vis_context_desc_defaults(&d);
        d.backend = VIS_BACKEND_OPENCL;
        d.opencl_device = device;
        vw_error werr;
        d.log = print_log;
        if (vis_context_create(&d, &ctx[w]) != VIS_OK) { /* e.g. the vote off NVIDIA: the others still run */
            printf("walk %s: no context (the log line above says why); left out\n", names[w]);
            memmove(names[w], names[w + 1], (nw - w - 1) * sizeof names[0]);
            --nw;
            --w;
            continue;
        }
        if (world_scene_create(ctx[w], wb, NULL, &ws[w], NULL, &werr)) {
            printf("walk %s: world_scene: %s\n", names[w], werr.message);
            exit(2);
        }
    }
    if (nw == 0)
        return;
    unsetenv("VIS_OPENCL_WALK");

    /* Conformance of each walk against the CPU: the stack method, object and leaf IDs. */
    uint64_t rng = 77;
    size_t big = (size_t)512 * 512;
    printf("\nwalks ($VIS_OPENCL_WALK), conformance against the CPU (stack method, %zu path views + %d random "
           "cameras, object and leaf IDs, IDs and depths):\n", nv + 1, ncams);
    for (size_t w = 0; w < nw; ++w) {
        uint64_t bad = 0, pairs = 0;
        rng = 77;
        vis_scene *B = world_scene_scene(ws[w]);
        for (int i = -1 - (int)nv; i < ncams; ++i) {
            vis_camera c;
            if (i < 0) {
                size_t v = (size_t)(-1 - i);
                c = v == 0 ? *def : views[v - 1].camera;
            } else {
                random_camera(wa, &rng, &c);
            }
            for (uint32_t mode = 0; mode < 2; ++mode) {
                vis_trace_desc td;
                vis_trace_desc_defaults(&td);
                td.width = td.height = 512;
                td.ids = (vis_id_mode)mode;
                td.traversal = VIS_TRAVERSAL_STACK;
                if (vis_trace(cpu, A, &c, &td, b->ia, b->n, b->da, b->n) != VIS_OK)
                    die("cpu trace", cpu);
                if (vis_trace(ctx[w], B, &c, &td, b->ib, b->n, b->db, b->n) != VIS_OK)
                    die("opencl trace", ctx[w]);
                ++pairs;
                if (memcmp(b->ia, b->ib, big * 4) != 0 || memcmp(b->da, b->db, big * 4) != 0)
                    ++bad;
            }
        }
        printf("  %-36s %llu buffer pairs, %llu differ\n", names[w], (unsigned long long)pairs,
               (unsigned long long)bad);
        g_failures += bad;
    }

    /* Timing, rounds alternating the walks. */
    double per[MAX_WALKS][MAX_ROUNDS][VC_MAX_VIEWS + 1], bk[MAX_WALKS][MAX_ROUNDS], bt[MAX_WALKS][MAX_ROUNDS];
    double *km = malloc((size_t)reps * sizeof *km);
    vis_camera *cams = malloc(batch * sizeof *cams);
    size_t cap = vis_drawlist_bound(world_scene_scene(ws[0])) + 16;
    vis_draw_entry *lists[MAX_WALKS];
    size_t *counts = malloc(batch * sizeof *counts), totals[MAX_WALKS];
    if (!km || !cams || !counts)
        die("out of memory for the walks", NULL);
    for (size_t w = 0; w < nw; ++w)
        if (!(lists[w] = malloc(cap * batch * sizeof *lists[w])))
            die("out of memory for the walks' lists", NULL);
    for (uint32_t i = 0; i < batch; ++i)
        cams[i] = views[i % nv].camera;
    for (int r = 0; r < rounds; ++r)
        for (size_t w = 0; w < nw; ++w) {
            vis_scene *B = world_scene_scene(ws[w]);
            vis_trace_desc td;
            vis_trace_desc_defaults(&td);
            td.width = td.height = 512;
            td.traversal = VIS_TRAVERSAL_STACK;
            for (size_t v = 0; v <= nv; ++v) {
                const vis_camera *cam = v == 0 ? def : &views[v - 1].camera;
                vis_timing tg;
                for (int k = 0; k < 3; ++k)
                    vis_trace(ctx[w], B, cam, &td, b->ib, b->n, NULL, 0);
                for (int k = 0; k < reps; ++k) {
                    if (vis_trace(ctx[w], B, cam, &td, b->ib, b->n, NULL, 0) != VIS_OK)
                        die("trace", ctx[w]);
                    vis_context_last_timing(ctx[w], &tg);
                    km[k] = tg.kernel_ms;
                }
                per[w][r][v] = median(km, reps);
            }
            double k5[5], t5[5];
            for (int k = 0; k < 6; ++k) {
                vis_timing tg;
                if (vis_trace_batch_drawlist(ctx[w], B, cams, batch, &td, lists[w], cap * batch, counts, batch,
                                             &totals[w]) != VIS_OK)
                    die("batch drawlist", ctx[w]);
                vis_context_last_timing(ctx[w], &tg);
                if (k) {
                    k5[k - 1] = tg.kernel_ms;
                    t5[k - 1] = tg.total_ms;
                }
            }
            bk[w][r] = median(k5, 5);
            bt[w][r] = median(t5, 5);
            if (totals[w] != totals[0] || memcmp(lists[w], lists[0], totals[0] * sizeof *lists[0]) != 0) {
                printf("MISMATCH walk %s: batch draw lists differ from walk %s\n", names[w], names[0]);
                ++g_failures;
            }
        }
    printf("\nwalks, 512x512, stack method: kernel ms per view (median of %d), per round; batch of %u path views "
           "with draw lists (median of 5)\n", reps, batch);
    printf("%-30s %2s", "walk", "r");
    for (size_t v = 0; v <= nv; ++v)
        printf(" %8.8s", v == 0 ? "default" : views[v - 1].name);
    printf(" %8s %9s %9s %9s\n", "max ms", "med Mray", "batch kGr", "batch eGr");
    double rays = (double)batch * 512.0 * 512.0;
    for (size_t w = 0; w < nw; ++w)
        for (int r = 0; r < rounds; ++r) {
            double mr[VC_MAX_VIEWS + 1], worst = 0.0;
            printf("%-30.30s %2d", names[w], r + 1);
            for (size_t v = 0; v <= nv; ++v) {
                printf(" %8.4f", per[w][r][v]);
                worst = per[w][r][v] > worst ? per[w][r][v] : worst;
                mr[v] = 512.0 * 512.0 / (per[w][r][v] * 1e3);
            }
            printf(" %8.4f %9.1f %9.3f %9.3f\n", worst, median(mr, (int)nv + 1), rays / (bk[w][r] * 1e6),
                   rays / (bt[w][r] * 1e6));
        }
    for (size_t w = 0; w < nw; ++w) {
        free(lists[w]);
        world_scene_destroy(ws[w]);
        vis_context_destroy(ctx[w]);
    }
    free(km), free(cams), free(counts);
}

int main(int argc, char **argv)
{
    const char *spec = "gen:default", *device = NULL, *batches = "16,64,256";
    int ncams = 100, reps = 200, conformance = 1, methods = 0, drawlist = 0, passes = 1, rounds = 3;
    uint32_t copies = 0;
    const char *walks = NULL;
    vis_traversal trav = VIS_TRAVERSAL_AUTO;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--scene"))
            spec = argv[i + 1];
        else if (!strcmp(argv[i], "--device"))
            device = argv[i + 1];
        else if (!strcmp(argv[i], "--cameras"))
            ncams = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--reps"))
            reps = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--batch") && batches_valid(argv[i + 1]))
            batches = argv[i + 1];
        else if (!strcmp(argv[i], "--conformance"))
            conformance = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--size") && atoi(argv[i + 1]) >= 1 && atoi(argv[i + 1]) <= 512)
            g_size = (uint32_t)atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--passes"))
            passes = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--methods"))
            methods = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--drawlist"))
            drawlist = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--copies") && atoi(argv[i + 1]) >= 0 && atoi(argv[i + 1]) <= 256)
            copies = (uint32_t)atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--only"))
            g_only = argv[i + 1];
        else if (!strcmp(argv[i], "--walks"))
            walks = argv[i + 1];
        else if (!strcmp(argv[i], "--rounds") && atoi(argv[i + 1]) >= 1)
            rounds = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--traversal"))
            trav = (vis_traversal)atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--nv-verbose") && !strcmp(argv[i + 1], "1")) {
            nv_verbose();
            return 0;
        }
        else {
            fprintf(stderr, "usage: vis_clbench [--scene SPEC] [--device SEL] [--cameras N] [--reps N] [--batch N,..] "
                            "[--size N<=512] [--conformance 0|1] [--passes 0|1] [--methods 0|1] [--only stack,dda] [--drawlist 0|1 [--copies N]] [--traversal ENUM] [--nv-verbose 1] "
                            "[--walks \"W[@WxH];...\" [--rounds N]]\n");
            return 2;
        }
    }
    vw_error werr;
    vw_world *wa = NULL, *wb = NULL;
    double t0 = vc_now_ms();
    if (vw_world_from_spec(spec, NULL, NULL, NULL, &wa, &werr) != VW_OK || vw_world_from_spec(spec, NULL, NULL, NULL, &wb, &werr) != VW_OK) {
        fprintf(stderr, "vis_clbench: %s: %s\n", spec, werr.message);
        return 2;
    }
    vis_context *cpu = open_ctx(VIS_BACKEND_CPU, NULL), *cl = open_ctx(VIS_BACKEND_OPENCL, device);
    vis_backend_info bc, bo;
    vis_context_backend(cpu, &bc);
    vis_context_backend(cl, &bo);
    printf("scene %s; cpu: %s; opencl: %s (%s); libvis %s\n", spec, bc.device, bo.device, bo.is_gpu ? "GPU" : "not GPU",
           vis_version());
    world_scene *sa = NULL, *sb = NULL;
    if (world_scene_create(cpu, wa, NULL, &sa, NULL, &werr) || world_scene_create(cl, wb, NULL, &sb, &(world_scene_stats){0}, &werr)) {
        fprintf(stderr, "vis_clbench: world_scene: %s\n", werr.message);
        return 2;
    }
    vis_scene *A = world_scene_scene(sa), *B = world_scene_scene(sb);
    vis_scene_info si;
    vis_scene_get_info(B, &si);
    printf("world built in %.0f ms: %u objects, %llu quads, %u leaves\n", vc_now_ms() - t0, si.objects,
           (unsigned long long)si.quads, si.leaves);

    /* ---- 1. conformance ---- */
    vc_view views[VC_MAX_VIEWS];
    size_t nv = vc_camera_path(wa, views, VC_MAX_VIEWS);
    size_t big = 512 * 512;
    bufs b = {malloc(big * 4), malloc(big * 4), malloc(big * 4), malloc(big * 4), big};
    uint64_t rng = 2024;
    double c0 = vc_now_ms();
    uint32_t cams = 0;
    uint64_t full_bytes = 0;
    if (nv > 0) { /* the first trace of B syncs the whole scene: its upload is the scene's size */
        vis_trace_desc td;
        vis_trace_desc_defaults(&td);
        td.width = td.height = 1;
        vis_timing timing;
        if (vis_trace(cl, B, &views[0].camera, &td, b.ib, b.n, NULL, 0) != VIS_OK ||
            vis_context_last_timing(cl, &timing) != VIS_OK)
            die("opencl trace", cl);
        full_bytes = timing.upload_bytes;
    }
    vw_world_info wi;
    vw_world_get_info(wa, &wi);
    if (conformance) {
        for (size_t i = 0; i < nv; ++i, ++cams) {
            compare(cpu, A, cl, B, &views[i].camera, 512, 512, &b, views[i].name);
            compare(cpu, A, cl, B, &views[i].camera, 48, 40, &b, views[i].name);
        }
        for (int i = 0; i < ncams; ++i, ++cams) {
            vis_camera c;
            random_camera(wa, &rng, &c);
            char what[32];
            snprintf(what, sizeof what, "random %d", i);
            compare(cpu, A, cl, B, &c, i % 4 == 0 ? 512 : 61, i % 4 == 0 ? 512 : 47, &b, what);
            if (i % 10 == 0)
                compare(cpu, A, cl, B, &c, 16, 12, &b, what); /* with the brute force */
        }
        /* Random voxel edits on both worlds, then everything again. */
        for (int e = 0; e < 300; ++e) {
            int64_t x = wi.origin[0] + (int64_t)(rng_next(&rng) % (uint64_t)wi.size[0]);
            int64_t z = wi.origin[2] + (int64_t)(rng_next(&rng) % (uint64_t)wi.size[2]);
            int64_t y = vc_surface_height(wa, x, z) - (int64_t)(rng_next(&rng) % 3);
            vw_voxel v = (vw_voxel)(rng_next(&rng) % 2 ? 0 : 1 + rng_next(&rng) % 8);
            vw_world_set(wa, x, y, z, v);
            vw_world_set(wb, x, y, z, v);
        }
        if (world_scene_update(sa, NULL, &werr) || world_scene_update(sb, NULL, &werr)) {
            fprintf(stderr, "vis_clbench: update: %s\n", werr.message);
            return 2;
        }
        for (size_t i = 0; i < nv; ++i, ++cams)
            compare(cpu, A, cl, B, &views[i].camera, 512, 512, &b, "after edits");
        for (int i = 0; i < ncams / 2; ++i, ++cams) {
            vis_camera c;
            random_camera(wa, &rng, &c);
            compare(cpu, A, cl, B, &c, i % 4 == 0 ? 512 : 61, i % 4 == 0 ? 512 : 47, &b, "after edits");
        }
        printf("conformance: %u cameras, %llu buffer pairs (%u traversals x object/leaf IDs), %llu mismatches, %.1f s\n",
               cams, (unsigned long long)g_compared, (unsigned)TRAVERSALS, (unsigned long long)g_failures,
               (vc_now_ms() - c0) * 1e-3);
    }

    /* ---- 2. one 512x512 pass ---- */
    /* km also holds the CPU's 5 timings per view below, whatever --reps is. */
    double *km = malloc((size_t)(reps > 5 ? reps : 5) * sizeof *km), *tm = malloc((size_t)reps * sizeof *tm);
    vis_camera def;
    vc_camera_default(wa, &def);
    if (walks) {
        const char *p = batches, *last = batches;
        while (*p) { /* the last --batch count */
            last = p;
            next_batch(&p);
        }
        walks_section(cpu, A, wa, wb, &def, views, nv, reps, rounds, next_batch(&last), ncams, device, walks, &b);
    }
    if (methods)
        methods_table(cl, B, &def, views, nv, reps, &b);
    if (drawlist)
        drawlist_section(cl, B, &def, views, nv, reps, &b, batches, trav, wb, sb, &rng, copies);
    if (passes) {
        printf("\n512x512 pass, %d reps after %d warm-ups (median / min ms):\n", reps, reps < 20 ? reps : 20);
        printf("%-12s %-10s %18s %18s %18s %14s\n", "view", "traversal", "opencl kernel", "opencl end-to-end",
               "e2e ids only", "cpu e2e");
        for (size_t vi = 0; vi <= nv; ++vi) {
            const vis_camera *cam = vi == 0 ? &def : &views[vi - 1].camera;
            const char *name = vi == 0 ? "default" : views[vi - 1].name;
            for (uint32_t t = VIS_TRAVERSAL_STACK; t <= VIS_TRAVERSAL_DDA; ++t) {
                if (t == (uint32_t)VIS_TRAVERSAL_BRUTEFORCE || t == VIS_TRAVERSAL_PACKET || (vi > 0 && t != VIS_TRAVERSAL_STACK && t != VIS_TRAVERSAL_DDA))
                    continue;
                vis_trace_desc td;
                vis_trace_desc_defaults(&td);
                td.traversal = (vis_traversal)t;
                vis_timing tg;
                for (int r = 0; r < (reps < 20 ? reps : 20); ++r) /* warm-up */
                    vis_trace(cl, B, cam, &td, b.ib, b.n, b.db, b.n);
                for (int r = 0; r < reps; ++r) {
                    if (vis_trace(cl, B, cam, &td, b.ib, b.n, b.db, b.n) != VIS_OK)
                        die("trace", cl);
                    vis_context_last_timing(cl, &tg);
                    km[r] = tg.kernel_ms;
                    tm[r] = tg.total_ms;
                }
                qsort(km, (size_t)reps, sizeof *km, cmp_double);
                qsort(tm, (size_t)reps, sizeof *tm, cmp_double);
                double kmed = km[reps / 2], kmin = km[0], tmed = tm[reps / 2], tmin = tm[0];
                for (int r = 0; r < reps; ++r) {
                    vis_trace(cl, B, cam, &td, b.ib, b.n, NULL, 0);
                    vis_context_last_timing(cl, &tg);
                    tm[r] = tg.total_ms;
                }
                qsort(tm, (size_t)reps, sizeof *tm, cmp_double);
                double imed = tm[reps / 2];
                int creps = 5;
                for (int r = 0; r < creps; ++r) {
                    vis_trace(cpu, A, cam, &td, b.ia, b.n, b.da, b.n);
                    vis_context_last_timing(cpu, &tg);
                    km[r] = tg.total_ms;
                }
                qsort(km, (size_t)creps, sizeof *km, cmp_double);
                printf("%-12s %-10u %8.4f / %7.4f %8.4f / %7.4f %18.4f %14.3f\n", name, t, kmed, kmin, tmed, tmin, imed,
                       km[creps / 2]);
            }
        }

        /* ---- 3. batches ---- */
        printf("\nbatches of 512x512 views (vis_trace_batch, AUTO traversal, object IDs):\n");
        printf("%6s %12s %12s %14s %14s %16s\n", "views", "kernel ms", "total ms", "kernel Grays/s", "e2e Grays/s",
               "e2e+depth Grays/s");
        for (const char *p = batches; *p;) {
            uint32_t n = next_batch(&p);
            if (n == 0)
                break;
            vis_camera *cams_b = malloc(n * sizeof *cams_b);
            if (!cams_b)
                break;
            for (uint32_t i = 0; i < n; ++i)
                random_camera(wa, &rng, &cams_b[i]);
            uint32_t *ids = malloc((size_t)n * big * 4);
            float *depth = malloc((size_t)n * big * 4);
            if (!ids || !depth) {
                printf("%6u: out of host memory\n", n);
                break;
            }
            vis_timing tg;
            double bk[5], bt[5], bd[5];
            for (int r = 0; r < 6; ++r) {
                if (vis_trace_batch(cl, B, cams_b, n, NULL, ids, (size_t)n * big, NULL, 0) != VIS_OK)
                    die("batch", cl);
                vis_context_last_timing(cl, &tg);
                if (r) {
                    bk[r - 1] = tg.kernel_ms;
                    bt[r - 1] = tg.total_ms;
                }
            }
            for (int r = 0; r < 5; ++r) {
                if (vis_trace_batch(cl, B, cams_b, n, NULL, ids, (size_t)n * big, depth, (size_t)n * big) != VIS_OK)
                    die("batch", cl);
                vis_context_last_timing(cl, &tg);
                bd[r] = tg.total_ms;
            }
            qsort(bk, 5, sizeof(double), cmp_double);
            qsort(bt, 5, sizeof(double), cmp_double);
            qsort(bd, 5, sizeof(double), cmp_double);
            double rays = (double)n * (double)big;
            printf("%6u %12.3f %12.3f %14.2f %14.2f %16.2f\n", n, bk[2], bt[2], rays / (bk[2] * 1e6), rays / (bt[2] * 1e6),
                   rays / (bd[2] * 1e6));
            /* spot check: the batch's first and last views equal single passes */
            vis_trace(cl, B, &cams_b[n - 1], NULL, b.ib, b.n, NULL, 0);
            if (memcmp(b.ib, ids + (size_t)(n - 1) * big, big * 4) != 0) {
                printf("MISMATCH batch view %u vs single pass\n", n - 1);
                ++g_failures;
            }
            free(cams_b);
            free(ids);
            free(depth);
        }

        /* ---- 4. bytes per single-voxel edit ---- */
        int ne = 200;
        double *eb = malloc((size_t)ne * sizeof *eb);
        for (int e = 0; e < ne; ++e) {
            int64_t x = wi.origin[0] + (int64_t)(rng_next(&rng) % (uint64_t)wi.size[0]);
            int64_t z = wi.origin[2] + (int64_t)(rng_next(&rng) % (uint64_t)wi.size[2]);
            int64_t y = vc_surface_height(wb, x, z) - (int64_t)(rng_next(&rng) % 2);
            vw_world_set(wb, x, y, z, vw_world_get(wb, x, y, z) ? 0 : 1);
            if (world_scene_update(sb, NULL, &werr))
                die("update", NULL);
            vis_timing tg;
            if (vis_trace(cl, B, &def, NULL, b.ib, b.n, NULL, 0) != VIS_OK)
                die("trace", cl);
            vis_context_last_timing(cl, &tg);
            eb[e] = (double)tg.upload_bytes;
        }
        qsort(eb, (size_t)ne, sizeof *eb, cmp_double);
        printf("\nsingle-voxel edits: %d, bytes uploaded per edit: median %.0f, min %.0f, max %.0f (whole scene: %llu)\n",
               ne, eb[ne / 2], eb[0], eb[ne - 1], (unsigned long long)full_bytes);
        free(eb);
    }
    printf("\nRESULT %s\n", g_failures ? "MISMATCHES FOUND" : "bit-identical");
    free(km), free(tm), free(b.ia), free(b.ib), free(b.da), free(b.db);
    world_scene_destroy(sa);
    world_scene_destroy(sb);
    vis_context_destroy(cpu);
    vis_context_destroy(cl);
    vw_world_destroy(wa);
    vw_world_destroy(wb);
    return g_failures ? 1 : 0;
}
