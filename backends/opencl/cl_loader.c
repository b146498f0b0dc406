/* cl_loader.c — the OpenCL ICD loader, opened at run time, and which implementations it
 * would load.
 *
 * libvis does not link libOpenCL: a program that only uses the CPU backend needs neither the
 * loader nor a driver to link or to start. The first OpenCL context opens the loader with
 * dlopen ($VIS_OPENCL_LIBRARY if set, else libOpenCL.so.1, the soname every loader has, then
 * libOpenCL.so) and reads the entry points the backend calls into one table; cl_internal.h
 * maps each cl* name onto it. The handle is never closed: ICDs start threads and register exit
 * handlers (PoCL does both) that must not outlive their code. The table is the one piece of
 * process-wide state in libvis, as the loader's own dispatch is: written once under a mutex,
 * read-only afterwards. A failed load is not remembered, so a later call tries again.
 *
 * VIS_BACKEND_AUTO without a named device only wants a GPU. Asking the loader for its
 * platforms makes it dlopen every ICD listed in /etc/OpenCL/vendors, and PoCL's library alone
 * maps ~64 MB (LLVM); its first device query then starts its worker threads. So AUTO first
 * reads what the loader would read (vis_cl_icds_cpu_only) and does not open the loader at all
 * when every listed ICD is a CPU-only implementation; the CPU backend is faster there
 * (docs/performance.md). Where a GPU driver is listed too, the loader is opened and
 * cl_device.c skips device queries on CPU-only platforms (vis_cl_pocl_cpu_only). */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <dlfcn.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* This file resolves the cl* names itself, so it sees the header's declarations, not the
 * table that cl_internal.h maps them onto elsewhere. */
#define VIS_CL_LOADER_NO_NAMES
#include "opencl/cl_internal.h"

/* Each table entry has exactly the type of its prototype in CL/cl.h: the assignments are
 * type-checked but, inside sizeof, never evaluated, so they reference no cl* symbol. */
#if defined(__GNUC__)
#  pragma GCC diagnostic push
#  pragma GCC diagnostic error "-Wincompatible-pointer-types"
#endif
static inline void check_prototypes(vis_cl_api *t)
{
#define VIS_CL_CHECK(ret, fn, params) (void)sizeof(t->fn = cl##fn);
    VIS_CL_FUNCTIONS(VIS_CL_CHECK)
#undef VIS_CL_CHECK
}
#if defined(__GNUC__)
#  pragma GCC diagnostic pop
#endif

static pthread_mutex_t load_lock = PTHREAD_MUTEX_INITIALIZER;
static void *loader;       /* the open loader; NULL until a load succeeded */
static vis_cl_api table;   /* filled before `loader` is set, never written afterwards */

const vis_cl_api *vis_cl_api_table(void) { return &table; }

int vis_cl_load(char *err, size_t err_size)
{
    pthread_mutex_lock(&load_lock);
    if (loader) {
        pthread_mutex_unlock(&load_lock);
        return VIS_OK;
    }
    const char *named = getenv("VIS_OPENCL_LIBRARY");
    const char *names[2] = {"libOpenCL.so.1", "libOpenCL.so"};
    size_t count = 2;
    if (named && *named) {
        names[0] = named; /* an explicit choice is kept or refused, never replaced */
        count = 1;
    }
    void *h = NULL;
    char why[512] = "";
    const char *name = names[0];
    for (size_t i = 0; i < count && !h; ++i) {
        name = names[i];
        h = dlopen(name, RTLD_NOW | RTLD_LOCAL);
        if (!h && !why[0]) {
            const char *e = dlerror();
            snprintf(why, sizeof why, "%s", e ? e : "dlopen failed");
        }
    }
    if (!h) {
        pthread_mutex_unlock(&load_lock);
        snprintf(err, err_size,
                 "the OpenCL ICD loader %s could not be loaded (%s); install one (Debian: ocl-icd-libopencl1) "
                 "or name it with $VIS_OPENCL_LIBRARY",
                 names[0], why);
        return VIS_ERROR_UNSUPPORTED;
    }
    vis_cl_api t;
    memset(&t, 0, sizeof t);
    const char *missing = NULL;
    /* POSIX guarantees that a data pointer from dlsym converts to a function pointer; the
     * memcpy says so without a cast that -Wpedantic rejects. */
#define VIS_CL_RESOLVE(ret, fn, params)                                                                           \
    if (!missing) {                                                                                               \
        void *sym = dlsym(h, "cl" #fn);                                                                           \
        if (sym)                                                                                                  \
            memcpy(&t.fn, &sym, sizeof sym);                                                                      \
        else                                                                                                      \
            missing = "cl" #fn;                                                                                   \
    }
    VIS_CL_FUNCTIONS(VIS_CL_RESOLVE)
#undef VIS_CL_RESOLVE
    if (missing) {
        dlclose(h);
        pthread_mutex_unlock(&load_lock);
        snprintf(err, err_size, "the OpenCL ICD loader %s has no %s (OpenCL 1.2 is required)", name, missing);
        return VIS_ERROR_UNSUPPORTED;
    }
    table = t;
    loader = h;
    pthread_mutex_unlock(&load_lock);
    return VIS_OK;
}

/* ---- what the ICD loader would load --------------------------------------------------------- */

#define MAX_ICDS 32

typedef struct icd_list {
    char lib[MAX_ICDS][256]; /* library names, as the .icd files (or the environment) give them */
    char from[MAX_ICDS][256];
    unsigned count;
    int overflow;
} icd_list;

static void add_lib(icd_list *l, const char *lib, size_t len, const char *from)
{
    while (len && (lib[len - 1] == '\n' || lib[len - 1] == '\r' || lib[len - 1] == ' ' || lib[len - 1] == '\t'))
        --len;
    while (len && (*lib == ' ' || *lib == '\t')) {
        ++lib;
        --len;
    }
    if (!len)
        return;
    if (l->count == MAX_ICDS || len >= sizeof l->lib[0]) {
        l->overflow = 1; /* something we cannot judge: let the loader decide */
        return;
    }
    memcpy(l->lib[l->count], lib, len);
    l->lib[l->count][len] = '\0';
    snprintf(l->from[l->count], sizeof l->from[0], "%s", from);
    ++l->count;
}

/* The first line of an .icd file is the library to dlopen. */
static void add_icd_file(icd_list *l, const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        l->overflow = 1;
        return;
    }
    char line[512];
    if (fgets(line, sizeof line, f))
        add_lib(l, line, strlen(line), path);
    else
        l->overflow = 1;
    fclose(f);
}

static int is_dir(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISDIR(st.st_mode);
}

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && strcmp(s + n - m, suffix) == 0;
}

static void add_icd_dir(icd_list *l, const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return; /* no vendors directory: nothing listed */
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        if (!ends_with(e->d_name, ".icd"))
            continue;
        char path[1024];
        if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path) {
            l->overflow = 1;
            continue;
        }
        add_icd_file(l, path);
    }
    closedir(d);
}

/* The ICDs the loader would open, by the rules of ocl-icd (libOpenCL(7)) and the Khronos
 * loader: $OCL_ICD_FILENAMES (Khronos: a colon-separated list of libraries); $OCL_ICD_VENDORS
 * as a directory of .icd files, one .icd file, or one library; else $OPENCL_VENDOR_PATH or
 * /etc/OpenCL/vendors. */
static void list_icds(icd_list *l)
{
    memset(l, 0, sizeof *l);
    const char *files = getenv("OCL_ICD_FILENAMES");
    if (files && *files) {
        for (const char *p = files; *p;) {
            const char *q = strchr(p, ':');
            size_t len = q ? (size_t)(q - p) : strlen(p);
            add_lib(l, p, len, "$OCL_ICD_FILENAMES");
            p += len + (q ? 1 : 0);
        }
    }
    const char *vendor_path = getenv("OPENCL_VENDOR_PATH");
    const char *dir = vendor_path && *vendor_path ? vendor_path : "/etc/OpenCL/vendors";
    const char *vendors = getenv("OCL_ICD_VENDORS");
    if (vendors && *vendors) {
        if (is_dir(vendors)) {
            add_icd_dir(l, vendors);
        } else if (ends_with(vendors, ".icd")) {
            char path[1024];
            struct stat st;
            if (!strchr(vendors, '/') && snprintf(path, sizeof path, "%s/%s", dir, vendors) < (int)sizeof path &&
                stat(path, &st) == 0)
                add_icd_file(l, path);
            else
                add_icd_file(l, vendors);
        } else {
            add_lib(l, vendors, strlen(vendors), "$OCL_ICD_VENDORS");
        }
        return;
    }
    add_icd_dir(l, dir);
}

/* PoCL's drivers that run on the host CPU. Any other ($POCL_DEVICES=cuda, a cuda or level0
 * driver module installed) may be a GPU. */
static int pocl_cpu_driver(const char *name, size_t len)
{
    static const char *const cpu[] = {"basic", "pthread", "cpu", "cpu-minimal", "tbb", "cpu-tbb"};
    for (size_t i = 0; i < sizeof cpu / sizeof cpu[0]; ++i)
        if (strlen(cpu[i]) == len && strncmp(cpu[i], name, len) == 0)
            return 1;
    return 0;
}

/* Whether a PoCL driver directory (DIR/pocl/libpocl-devices-NAME.so) holds a non-CPU driver. */
static int pocl_dir_has_gpu_driver(const char *libdir)
{
    char path[1024];
    if (snprintf(path, sizeof path, "%s/pocl", libdir) >= (int)sizeof path)
        return 0;
    DIR *d = opendir(path);
    if (!d)
        return 0;
    int gpu = 0;
    struct dirent *e;
    const char *prefix = "libpocl-devices-";
    size_t pn = strlen(prefix);
    while ((e = readdir(d)) != NULL && !gpu) {
        const char *n = e->d_name;
        if (strncmp(n, prefix, pn) != 0 || !ends_with(n, ".so"))
            continue;
        size_t len = strlen(n) - pn - 3;
        if (!pocl_cpu_driver(n + pn, len))
            gpu = 1;
    }
    closedir(d);
    return gpu;
}

int vis_cl_pocl_cpu_only(const char *library)
{
    /* $POCL_DEVICES picks PoCL's drivers ("pthread", "cuda pthread", ...). */
    const char *devs = getenv("POCL_DEVICES");
    if (devs && *devs) {
        for (const char *p = devs; *p;) {
            size_t len = strcspn(p, " ,");
            if (len && !pocl_cpu_driver(p, len))
                return 0;
            p += len;
            p += strspn(p, " ,");
        }
        return 1;
    }
    /* Otherwise PoCL loads every driver module installed next to its library. */
    if (library && strchr(library, '/')) {
        char dir[1024];
        snprintf(dir, sizeof dir, "%s", library);
        char *slash = strrchr(dir, '/');
        *slash = '\0';
        return !pocl_dir_has_gpu_driver(dir);
    }
    static const char *const dirs[] = {
#ifdef VIS_LIBRARY_ARCHITECTURE
        "/usr/lib/" VIS_LIBRARY_ARCHITECTURE,
        "/usr/local/lib/" VIS_LIBRARY_ARCHITECTURE,
#endif
        "/usr/lib64", "/usr/lib", "/usr/local/lib"};
    for (size_t i = 0; i < sizeof dirs / sizeof dirs[0]; ++i)
        if (pocl_dir_has_gpu_driver(dirs[i]))
            return 0;
    return 1;
}

/* A library the loader would open that only ever offers CPU devices. */
static int cpu_only_library(const char *lib)
{
    const char *base = strrchr(lib, '/');
    base = base ? base + 1 : lib;
    return strncmp(base, "libpocl.", 8) == 0 && vis_cl_pocl_cpu_only(lib);
}

int vis_cl_icds_cpu_only(char *why, size_t why_size)
{
    icd_list l;
    list_icds(&l);
    if (l.overflow || l.count == 0)
        return 0; /* unknown or nothing listed: asking the loader is cheap then */
    for (unsigned i = 0; i < l.count; ++i)
        if (!cpu_only_library(l.lib[i]))
            return 0;
    size_t used = (size_t)snprintf(why, why_size, "only CPU OpenCL implementations are installed (");
    for (unsigned i = 0; i < l.count && used < why_size; ++i) {
        const char *from = strrchr(l.from[i], '/');
        used += (size_t)snprintf(why + used, why_size - used, "%s%s: %s", i ? ", " : "", from ? from + 1 : l.from[i],
                                 l.lib[i]);
    }
    if (used < why_size)
        snprintf(why + used, why_size - used, "); the CPU backend is faster on a CPU (name one in $VIS_OPENCL_DEVICE)");
    return 1;
}
