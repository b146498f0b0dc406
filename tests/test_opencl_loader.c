/* test_opencl_loader.c — the OpenCL ICD loader opened at run time, and AUTO leaving CPU-only
 * OpenCL implementations alone (backends/opencl/cl_loader.c, docs/opencl.md).
 *
 *  - which ICDs the loader would open, read from the same files and variables it reads
 *    (OCL_ICD_VENDORS as a directory, an .icd file or a library; OPENCL_VENDOR_PATH;
 *    OCL_ICD_FILENAMES; POCL_DEVICES; PoCL's driver modules), on made-up vendor directories;
 *  - VIS_BACKEND_AUTO on a machine whose only ICD is PoCL: the CPU backend, and neither
 *    libpocl nor libOpenCL mapped into the process, no thread started (skipped, with the
 *    reason, where another ICD is installed or the environment picks ICDs);
 *  - a missing loader ($VIS_OPENCL_LIBRARY naming nothing): VIS_ERROR_UNSUPPORTED with a
 *    message naming it, and AUTO falling back to the CPU;
 *  - an ICD that may be a GPU beside PoCL: the loader is opened, PoCL's platform is not asked
 *    for devices (no thread started), and, finding no GPU, AUTO uses the CPU;
 *  - the register cap that batch programs get on NVIDIA (a pure function, no loader).
 *
 * The process's own state is the oracle (/proc/self/maps, /proc/self/status), so the tests
 * run in the order below in one process: nothing may open the loader before the AUTO test,
 * and the last test leaves the loader configured with a made-up vendor directory. This
 * program links no OpenCL library. */
#define _XOPEN_SOURCE 700
#include <ftw.h>
#include <glob.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "vis/vis.h"
#ifdef VIS_HAVE_OPENCL
#  include "opencl/cl_internal.h"
#endif

/* ---- the process ------------------------------------------------------------------------ */

static int maps_contain(const char *needle)
{
    FILE *f = fopen("/proc/self/maps", "r");
    if (!f)
        return -1;
    char line[4096];
    int found = 0;
    while (fgets(line, sizeof line, f))
        if (strstr(line, needle))
            found = 1;
    fclose(f);
    return found;
}

static int thread_count(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    int n = -1;
    while (fgets(line, sizeof line, f))
        if (strncmp(line, "Threads:", 8) == 0)
            n = atoi(line + 8);
    fclose(f);
    return n;
}

static char g_log[2048];

static void capture_log(vis_log_level level, const char *message, void *user)
{
    (void)user;
    if (level >= VIS_LOG_ERROR)
        snprintf(g_log, sizeof g_log, "%s", message);
}

static vis_status make_ctx(vis_backend_kind kind, const char *device, vis_context **out)
{
    vis_context_desc cd;
    vis_context_desc_defaults(&cd);
    cd.backend = kind;
    cd.threads = 1; /* the CPU backend starts no worker: every new thread is someone else's */
    cd.opencl_device = device;
    cd.log = capture_log;
    g_log[0] = '\0';
    *out = NULL;
    return vis_context_create(&cd, out);
}

/* ---- made-up vendor directories ------------------------------------------------------- */

static char g_tmp[512];

static void write_file(const char *dir, const char *name, const char *text)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
}

static const char *make_dir(const char *name)
{
    static char path[32][1024]; /* every directory a test makes stays valid for the run */
    static int next = 0;
    if (next == 32)
        fail_msg("make_dir: more than 32 directories");
    char *p = path[next++];
    snprintf(p, 1024, "%s/%s", g_tmp, name);
    mkdir(p, 0700);
    return p;
}

static const char *const g_icd_vars[] = {"OCL_ICD_VENDORS", "OPENCL_VENDOR_PATH", "OCL_ICD_FILENAMES", "POCL_DEVICES"};

#define ICD_VARS (sizeof g_icd_vars / sizeof g_icd_vars[0])

static void clear_icd_vars(void)
{
    for (size_t i = 0; i < ICD_VARS; ++i)
        unsetenv(g_icd_vars[i]);
}

/* The variables as the test program found them, put back after every test (a failed
 * assertion leaves a test half way). */
static char *g_saved_vars[ICD_VARS];

static void save_icd_vars(void)
{
    for (size_t i = 0; i < ICD_VARS; ++i) {
        const char *v = getenv(g_icd_vars[i]);
        g_saved_vars[i] = v ? strdup(v) : NULL;
    }
}

static int restore_env(void **state)
{
    (void)state;
    for (size_t i = 0; i < ICD_VARS; ++i) {
        if (g_saved_vars[i])
            setenv(g_icd_vars[i], g_saved_vars[i], 1);
        else
            unsetenv(g_icd_vars[i]);
    }
    unsetenv("VIS_OPENCL_LIBRARY");
    return 0;
}

#ifdef VIS_HAVE_OPENCL
static int cpu_only(char *why, size_t size)
{
    why[0] = '\0';
    return vis_cl_icds_cpu_only(why, size);
}

/* Sets VAR to VALUE and checks what vis_cl_icds_cpu_only says (its sentence left in WHY). */
static void expect_cpu_only(const char *var, const char *value, int want, char *why, size_t size)
{
    setenv(var, value, 1);
    assert_int_equal(cpu_only(why, size), want);
}
#endif

static void test_icd_listing(void **state)
{
    (void)state;
#ifndef VIS_HAVE_OPENCL
    printf("SKIP: this build has no OpenCL backend\n");
    skip();
#else
    char why[512];

    /* PoCL alone, its CPU drivers picked by POCL_DEVICES: CPU-only, and the sentence says so. */
    const char *pocl = make_dir("vendors-pocl");
    write_file(pocl, "pocl.icd", "libpocl.so.2\n");
    clear_icd_vars();
    setenv("OCL_ICD_VENDORS", pocl, 1);
    expect_cpu_only("POCL_DEVICES", "pthread", 1, why, sizeof why);
    assert_non_null(strstr(why, "pocl.icd: libpocl.so.2"));
    expect_cpu_only("POCL_DEVICES", "basic,pthread", 1, why, sizeof why);
    /* POCL_DEVICES naming a GPU driver. */
    expect_cpu_only("POCL_DEVICES", "cuda pthread", 0, why, sizeof why);
    expect_cpu_only("POCL_DEVICES", "level0", 0, why, sizeof why);
    unsetenv("POCL_DEVICES");

    /* Without POCL_DEVICES, PoCL's driver modules next to its library decide. */
    const char *lib_cpu = make_dir("lib-cpu");
    const char *mods_cpu = make_dir("lib-cpu/pocl");
    write_file(mods_cpu, "libpocl-devices-pthread.so", "");
    write_file(mods_cpu, "libpocl-devices-basic.so", "");
    const char *lib_gpu = make_dir("lib-gpu");
    const char *mods_gpu = make_dir("lib-gpu/pocl");
    write_file(mods_gpu, "libpocl-devices-pthread.so", "");
    write_file(mods_gpu, "libpocl-devices-cuda.so", "");
    char line[1100];
    const char *abs_cpu = make_dir("vendors-abs-cpu");
    snprintf(line, sizeof line, "%s/libpocl.so.2\n", lib_cpu);
    write_file(abs_cpu, "pocl.icd", line);
    expect_cpu_only("OCL_ICD_VENDORS", abs_cpu, 1, why, sizeof why);
    const char *abs_gpu = make_dir("vendors-abs-gpu");
    snprintf(line, sizeof line, "%s/libpocl.so.2\n", lib_gpu);
    write_file(abs_gpu, "pocl.icd", line);
    expect_cpu_only("OCL_ICD_VENDORS", abs_gpu, 0, why, sizeof why);

    /* Another vendor beside PoCL, or nothing at all: the loader has to be asked. */
    setenv("POCL_DEVICES", "pthread", 1);
    const char *mixed = make_dir("vendors-mixed");
    write_file(mixed, "pocl.icd", "libpocl.so.2\n");
    write_file(mixed, "nvidia.icd", "libnvidia-opencl.so.1\n");
    expect_cpu_only("OCL_ICD_VENDORS", mixed, 0, why, sizeof why);
    expect_cpu_only("OCL_ICD_VENDORS", make_dir("vendors-empty"), 0, why, sizeof why);
    /* Files that are not .icd are not read. */
    const char *other = make_dir("vendors-other");
    write_file(other, "pocl.icd", "libpocl.so.2\n");
    write_file(other, "README", "libnvidia-opencl.so.1\n");
    expect_cpu_only("OCL_ICD_VENDORS", other, 1, why, sizeof why);

    /* OCL_ICD_VENDORS as one .icd file, and as one library. */
    char icd[1100];
    snprintf(icd, sizeof icd, "%s/pocl.icd", pocl);
    expect_cpu_only("OCL_ICD_VENDORS", icd, 1, why, sizeof why);
    snprintf(icd, sizeof icd, "%s/nvidia.icd", mixed);
    expect_cpu_only("OCL_ICD_VENDORS", icd, 0, why, sizeof why);
    expect_cpu_only("OCL_ICD_VENDORS", "libnvidia-opencl.so.1", 0, why, sizeof why);
    expect_cpu_only("OCL_ICD_VENDORS", "libpocl.so.2", 1, why, sizeof why);

    /* OPENCL_VENDOR_PATH replaces /etc/OpenCL/vendors; OCL_ICD_FILENAMES adds libraries. */
    unsetenv("OCL_ICD_VENDORS");
    expect_cpu_only("OPENCL_VENDOR_PATH", pocl, 1, why, sizeof why);
    expect_cpu_only("OPENCL_VENDOR_PATH", mixed, 0, why, sizeof why);
    setenv("OPENCL_VENDOR_PATH", pocl, 1);
    expect_cpu_only("OCL_ICD_FILENAMES", "/opt/vendor/libsomegpu.so:libpocl.so.2", 0, why, sizeof why);
    expect_cpu_only("OCL_ICD_FILENAMES", "libpocl.so.2", 1, why, sizeof why);

    /* Reading the configuration opened nothing. */
    assert_int_equal(maps_contain("libOpenCL"), 0);
    assert_int_equal(maps_contain("pocl"), 0);
#endif
}

/* ---- AUTO on a PoCL-only machine -------------------------------------------------------- */

static int pocl_driver_is_cpu(const char *path)
{
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    static const char *const cpu[] = {"libpocl-devices-basic.so", "libpocl-devices-pthread.so",
                                      "libpocl-devices-cpu.so", "libpocl-devices-cpu-minimal.so",
                                      "libpocl-devices-tbb.so", "libpocl-devices-cpu-tbb.so"};
    for (size_t i = 0; i < sizeof cpu / sizeof cpu[0]; ++i)
        if (strcmp(base, cpu[i]) == 0)
            return 1;
    return 0;
}

/* The first line of the file PATH into LINE (empty when it cannot be read). */
static void first_line(const char *path, char *line, size_t size)
{
    FILE *f = fopen(path, "r");
    line[0] = '\0';
    if (f) {
        if (!fgets(line, (int)size, f))
            line[0] = '\0';
        fclose(f);
    }
}

/* Whether this machine's OpenCL is PoCL on the CPU alone, judged from the files, not by the
 * code under test. Writes why not into `why`. */
static int machine_is_pocl_only(char *why, size_t size)
{
    for (size_t i = 0; i < ICD_VARS; ++i)
        if (getenv(g_icd_vars[i])) {
            snprintf(why, size, "$%s is set: the environment picks the ICDs", g_icd_vars[i]);
            return 0;
        }
    glob_t g;
    int pocl = 0;
    if (glob("/etc/OpenCL/vendors/*.icd", 0, NULL, &g) == 0) {
        for (size_t i = 0; i < g.gl_pathc; ++i) {
            char line[512];
            first_line(g.gl_pathv[i], line, sizeof line);
            if (!strstr(line, "libpocl")) {
                snprintf(why, size, "%s names %s, which may be a GPU driver", g.gl_pathv[i], line);
                globfree(&g);
                return 0;
            }
            pocl = 1;
        }
        globfree(&g);
    }
    if (!pocl) {
        snprintf(why, size, "the PoCL ICD is not installed (no /etc/OpenCL/vendors/*.icd names libpocl)");
        return 0;
    }
    const char *patterns[] = {"/usr/lib/*/pocl/libpocl-devices-*.so", "/usr/lib/pocl/libpocl-devices-*.so",
                              "/usr/lib64/pocl/libpocl-devices-*.so", "/usr/local/lib/pocl/libpocl-devices-*.so"};
    for (size_t p = 0; p < sizeof patterns / sizeof patterns[0]; ++p) {
        if (glob(patterns[p], 0, NULL, &g) != 0)
            continue;
        for (size_t i = 0; i < g.gl_pathc; ++i)
            if (!pocl_driver_is_cpu(g.gl_pathv[i])) {
                snprintf(why, size, "PoCL has a GPU driver (%s)", g.gl_pathv[i]);
                globfree(&g);
                return 0;
            }
        globfree(&g);
    }
    return 1;
}

static void test_auto_does_not_start_pocl(void **state)
{
    (void)state;
#ifndef VIS_HAVE_OPENCL
    printf("SKIP: this build has no OpenCL backend\n");
    skip();
#else
    char why[1024];
    if (!machine_is_pocl_only(why, sizeof why)) {
        printf("SKIP: AUTO may rightly open the OpenCL loader here: %s\n", why);
        skip();
    }
    assert_int_equal(maps_contain("pocl"), 0);
    assert_int_equal(maps_contain("libOpenCL"), 0);
    int threads = thread_count();
    assert_true(threads >= 1);

    vis_context *ctx = NULL;
    assert_int_equal(make_ctx(VIS_BACKEND_AUTO, NULL, &ctx), VIS_OK);
    vis_backend_info bi;
    assert_int_equal(vis_context_backend(ctx, &bi), VIS_OK);
    printf("AUTO: %s (%s): %s\n", bi.name, bi.device, bi.reason);
    assert_int_equal(bi.kind, VIS_BACKEND_CPU);
    assert_non_null(strstr(bi.reason, "only CPU OpenCL implementations"));
    assert_non_null(strstr(bi.reason, "libpocl"));
    /* The point: PoCL (~64 MB mapped, worker threads) was never started, nor the loader. */
    if (maps_contain("pocl") != 0)
        fail_msg("libpocl is mapped after vis_context_create(AUTO)");
    if (maps_contain("libOpenCL") != 0)
        fail_msg("the OpenCL loader is mapped after vis_context_create(AUTO)");
    if (thread_count() != threads)
        fail_msg("vis_context_create(AUTO) started %d thread(s)", thread_count() - threads);
    vis_context_destroy(ctx);
#endif
}

/* ---- a missing loader -------------------------------------------------------------------- */

static void test_missing_loader(void **state)
{
    (void)state;
    vis_context *ctx = NULL;
    char missing[1024];
    snprintf(missing, sizeof missing, "%s/no-such-dir/libOpenCL.so.1", g_tmp);
    setenv("VIS_OPENCL_LIBRARY", missing, 1);
    vis_status st = make_ctx(VIS_BACKEND_OPENCL, NULL, &ctx);
    if (st != VIS_OK && strstr(g_log, "no OpenCL backend")) {
        unsetenv("VIS_OPENCL_LIBRARY");
        printf("SKIP: %s\n", g_log);
        skip();
    }
    printf("OPENCL without a loader: %s: %s\n", vis_status_string(st), g_log);
    assert_int_equal(st, VIS_ERROR_UNSUPPORTED);
    assert_null(ctx);
    assert_non_null(strstr(g_log, missing));
    assert_non_null(strstr(g_log, "could not be loaded"));

    /* AUTO with a device named still falls back to the CPU, saying why. */
    assert_int_equal(make_ctx(VIS_BACKEND_AUTO, "pocl", &ctx), VIS_OK);
    vis_backend_info bi;
    assert_int_equal(vis_context_backend(ctx, &bi), VIS_OK);
    printf("AUTO without a loader: %s\n", bi.reason);
    assert_int_equal(bi.kind, VIS_BACKEND_CPU);
    assert_non_null(strstr(bi.reason, "could not be loaded"));
    vis_context_destroy(ctx);
    unsetenv("VIS_OPENCL_LIBRARY");
    assert_int_equal(maps_contain("libOpenCL"), 0);
}

/* ---- an ICD that may be a GPU ----------------------------------------------------------- */

/* The library the system's PoCL .icd names ("libpocl.so.2"), or "" when there is none. */
static void system_pocl_library(char *out, size_t size)
{
    out[0] = '\0';
    glob_t g;
    if (glob("/etc/OpenCL/vendors/*.icd", 0, NULL, &g) != 0)
        return;
    for (size_t i = 0; i < g.gl_pathc && !out[0]; ++i) {
        char line[512];
        first_line(g.gl_pathv[i], line, sizeof line);
        line[strcspn(line, "\r\n")] = '\0';
        if (strstr(line, "libpocl"))
            snprintf(out, size, "%s", line);
    }
    globfree(&g);
}

static void test_gpu_icd_opens_loader(void **state)
{
    (void)state;
#ifndef VIS_HAVE_OPENCL
    printf("SKIP: this build has no OpenCL backend\n");
    skip();
#else
    if (access("/usr/lib/x86_64-linux-gnu/libOpenCL.so.1", F_OK) != 0 && access("/usr/lib64/libOpenCL.so.1", F_OK) != 0 &&
        access("/usr/lib/libOpenCL.so.1", F_OK) != 0) {
        printf("SKIP: no OpenCL ICD loader (libOpenCL.so.1) in the usual places\n");
        skip();
    }
    /* A vendor directory naming a library that does not exist, and PoCL where it is installed:
     * the unknown one could be a GPU driver, so the loader must be opened (and it loads PoCL
     * too); then PoCL's platform is not asked for devices (its first device query starts its
     * threads), no GPU is found, and AUTO uses the CPU. */
    char pocl[512], line[600];
    system_pocl_library(pocl, sizeof pocl);
    const char *dir = make_dir("vendors-fake-gpu");
    write_file(dir, "fake-gpu.icd", "libvis-test-no-such-gpu-driver.so\n");
    if (pocl[0]) {
        snprintf(line, sizeof line, "%s\n", pocl);
        write_file(dir, "pocl.icd", line);
    }
    clear_icd_vars();
    setenv("OCL_ICD_VENDORS", dir, 1);
    setenv("POCL_DEVICES", "pthread", 1);
    int threads = thread_count();
    vis_context *ctx = NULL;
    assert_int_equal(make_ctx(VIS_BACKEND_AUTO, NULL, &ctx), VIS_OK);
    vis_backend_info bi;
    assert_int_equal(vis_context_backend(ctx, &bi), VIS_OK);
    printf("AUTO with an unknown ICD%s: %s\n", pocl[0] ? " and PoCL" : "", bi.reason);
    assert_int_equal(bi.kind, VIS_BACKEND_CPU);
    assert_int_equal(maps_contain("libOpenCL"), 1);
    if (pocl[0]) {
        assert_non_null(strstr(bi.reason, "no OpenCL GPU found on 1 platform"));
        assert_int_equal(maps_contain("pocl"), 1); /* loaded by the loader, as every ICD is */
    } else {
        assert_non_null(strstr(bi.reason, "no OpenCL platform"));
    }
    if (thread_count() != threads)
        fail_msg("vis_context_create(AUTO) started %d thread(s): a CPU-only platform was asked for devices",
                 thread_count() - threads);
    vis_context_destroy(ctx);
#endif
}

static int remove_entry(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st;
    (void)type;
    (void)ftw;
    return remove(path);
}

/* The register cap of the batch programs (cl_backend.c, vis_cl_batch_register_cap): on
 * NVIDIA for the stack method and the cell-grid walk only, never on other platforms, and
 * never when $VIS_OPENCL_BUILD_OPTIONS brings a cap of its own (two caps in one build). A
 * pure function of its arguments: no loader is opened. */
static void test_batch_register_cap(void **state)
{
    (void)state;
#ifndef VIS_HAVE_OPENCL
    printf("SKIP: this build has no OpenCL backend\n");
    skip();
#else
    const char *nv = "NVIDIA CUDA";
    assert_string_equal(vis_cl_batch_register_cap(nv, 0u, ""), " -cl-nv-maxrregcount=56"); /* stack */
    assert_string_equal(vis_cl_batch_register_cap(nv, 9u, ""), " -cl-nv-maxrregcount=72"); /* dda */
    for (uint32_t t = 1u; t < 9u; ++t)
        assert_string_equal(vis_cl_batch_register_cap(nv, t, ""), "");
    assert_string_equal(vis_cl_batch_register_cap(nv, 10u, ""), ""); /* the generic program */
    assert_string_equal(vis_cl_batch_register_cap("Portable Computing Language", 0u, ""), "");
    assert_string_equal(vis_cl_batch_register_cap(nv, 0u, "-cl-nv-maxrregcount=40"), "");
    assert_string_equal(vis_cl_batch_register_cap(nv, 9u, "-cl-nv-verbose"), " -cl-nv-maxrregcount=72");

    /* And the options the programs are built with: the cap in the batch programs only. */
    vis_cl_backend *b = calloc(1, sizeof *b);
    assert_non_null(b);
    snprintf(b->caps.platform, sizeof b->caps.platform, "%s", nv);
    char err[256];
    assert_int_equal(vis_cl_walk_options(b, "plain", err, sizeof err), VIS_OK); /* no OpenCL call */
    assert_non_null(strstr(vis_cl_method_options(b, 0u, 1), "-cl-nv-maxrregcount=56"));
    assert_non_null(strstr(vis_cl_method_options(b, 9u, 1), "-cl-nv-maxrregcount=72"));
    assert_null(strstr(vis_cl_method_options(b, 0u, 0), "maxrregcount"));
    assert_null(strstr(vis_cl_method_options(b, 9u, 0), "maxrregcount"));
    free(b);
#endif
}

int main(void)
{
    /* The defaults are under test: nothing named. */
    unsetenv("VIS_OPENCL_DEVICE");
    unsetenv("VIS_OPENCL_LIBRARY");
    const char *base = getenv("TMPDIR");
    snprintf(g_tmp, sizeof g_tmp, "%s/vis-opencl-loader-XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(g_tmp)) {
        fprintf(stderr, "mkdtemp failed\n");
        return 1;
    }
    save_icd_vars();
    /* In this order: see the top of the file. */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_teardown(test_icd_listing, restore_env),
        cmocka_unit_test_teardown(test_auto_does_not_start_pocl, restore_env),
        cmocka_unit_test_teardown(test_missing_loader, restore_env),
        cmocka_unit_test_teardown(test_gpu_icd_opens_loader, restore_env),
        cmocka_unit_test(test_batch_register_cap),
    };
    int failed = cmocka_run_group_tests(tests, NULL, NULL);
    if (nftw(g_tmp, remove_entry, 16, FTW_DEPTH | FTW_PHYS) != 0)
        fprintf(stderr, "could not remove %s\n", g_tmp);
    return failed;
}
