/* cl_device.c — which OpenCL device the backend runs on, and whether it can give the CPU's
 * answers bit for bit.
 *
 * Devices are numbered over all platforms in the order the ICD loader lists them (the order
 * `clinfo -l` prints). A selector is an index into that list or a case-insensitive substring
 * of the device name, vendor or platform name. Without one, $VIS_OPENCL_DEVICE is read, and
 * without that the first usable GPU is taken, else the first usable device (PoCL on a CPU).
 * "Usable" means it has a compiler and correctly rounded single-precision division and
 * square root: the ray setup divides and takes a square root, and the CPU does both in IEEE
 * arithmetic, so a device without them would produce different rays. The selectors "gpu",
 * "cpu" and "accelerator" take the first device of that type; a substring also matches the
 * platform vendor ("pocl" finds PoCL, whose device names changed between versions).
 *
 * `gpu_only` (AUTO with nothing named) asks for GPUs alone, and platforms that only ever offer
 * CPU devices (PoCL with its CPU drivers, vis_cl_pocl_cpu_only) are not asked for devices at
 * all: PoCL's first device query starts its worker threads, for a device AUTO would refuse. */
#define _POSIX_C_SOURCE 200809L
#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "opencl/cl_internal.h"

#define MAX_PLATFORMS 16
#define MAX_DEVICES 64

typedef struct dev_entry {
    cl_platform_id platform;
    cl_device_id device;
} dev_entry;

static void info_string(cl_device_id d, cl_device_info what, char *out, size_t size)
{
    out[0] = '\0';
    if (clGetDeviceInfo(d, what, size, out, NULL) != CL_SUCCESS)
        out[0] = '\0';
    out[size - 1] = '\0';
}

static int contains_nocase(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    if (n == 0)
        return 0;
    for (; *hay; ++hay) {
        size_t i = 0;
        while (i < n && hay[i] && tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            ++i;
        if (i == n)
            return 1;
    }
    return 0;
}

static int equals_nocase(const char *a, const char *b)
{
    for (; *a && *b; ++a, ++b)
        if (tolower((unsigned char)*a) != tolower((unsigned char)*b))
            return 0;
    return *a == *b;
}

/* Double precision (cl_khr_fp64) is there when its config is not 0 (OpenCL 1.2, 4.2: the
 * minimum double capability of a device without it is 0); read without allocating. */
static int has_fp64(cl_device_id d)
{
    cl_device_fp_config fp = 0;
    return clGetDeviceInfo(d, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp, &fp, NULL) == CL_SUCCESS && fp != 0;
}

int vis_cl_device_check(cl_platform_id platform, cl_device_id d, vis_cl_device_caps *caps, char *err, size_t err_size)
{
    memset(caps, 0, sizeof *caps);
    info_string(d, CL_DEVICE_NAME, caps->name, sizeof caps->name);
    info_string(d, CL_DEVICE_VENDOR, caps->vendor, sizeof caps->vendor);
    info_string(d, CL_DRIVER_VERSION, caps->driver, sizeof caps->driver);
    info_string(d, CL_DEVICE_VERSION, caps->version, sizeof caps->version);
    if (clGetPlatformInfo(platform, CL_PLATFORM_NAME, sizeof caps->platform, caps->platform, NULL) != CL_SUCCESS)
        caps->platform[0] = '\0';
    caps->platform[sizeof caps->platform - 1] = '\0';
    cl_device_type type = 0;
    clGetDeviceInfo(d, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    caps->is_gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
    caps->fp64 = has_fp64(d);
    cl_device_fp_config fp = 0;
    clGetDeviceInfo(d, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp, &fp, NULL);
    caps->denorms = (fp & CL_FP_DENORM) != 0;
    clGetDeviceInfo(d, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof caps->max_wg, &caps->max_wg, NULL);
    clGetDeviceInfo(d, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof caps->compute_units, &caps->compute_units, NULL);
    clGetDeviceInfo(d, CL_DEVICE_MAX_WORK_ITEM_SIZES, sizeof caps->max_item, caps->max_item, NULL);
    clGetDeviceInfo(d, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof caps->max_alloc, &caps->max_alloc, NULL);
    clGetDeviceInfo(d, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof caps->global_mem, &caps->global_mem, NULL);

    cl_bool available = CL_FALSE, compiler = CL_FALSE;
    clGetDeviceInfo(d, CL_DEVICE_AVAILABLE, sizeof available, &available, NULL);
    clGetDeviceInfo(d, CL_DEVICE_COMPILER_AVAILABLE, sizeof compiler, &compiler, NULL);
    if (!available) {
        snprintf(err, err_size, "device '%s' is not available", caps->name);
        return VIS_ERROR_UNSUPPORTED;
    }
    if (!compiler) {
        snprintf(err, err_size, "device '%s' has no OpenCL C compiler", caps->name);
        return VIS_ERROR_UNSUPPORTED;
    }
    if (!caps->denorms) {
        snprintf(err, err_size,
                 "device '%s' flushes single-precision subnormals to zero (no CL_FP_DENORM), which would change "
                 "results where a value falls below 2^-126",
                 caps->name);
        return VIS_ERROR_UNSUPPORTED;
    }
    if (!(fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT)) {
        snprintf(err, err_size,
                 "device '%s' lacks correctly rounded single-precision divide and sqrt "
                 "(CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT), which bit-identical rays need",
                 caps->name);
        return VIS_ERROR_UNSUPPORTED;
    }
    return VIS_OK;
}

/* A platform that offers CPU devices only, known from its name alone: PoCL without a GPU
 * driver. Reading the platform's strings does not start PoCL's devices. */
static int platform_cpu_only(cl_platform_id p)
{
    char name[128] = "", vendor[128] = "";
    clGetPlatformInfo(p, CL_PLATFORM_NAME, sizeof name, name, NULL);
    clGetPlatformInfo(p, CL_PLATFORM_VENDOR, sizeof vendor, vendor, NULL);
    name[sizeof name - 1] = '\0';
    vendor[sizeof vendor - 1] = '\0';
    int pocl = contains_nocase(vendor, "pocl") || contains_nocase(name, "Portable Computing Language");
    return pocl && vis_cl_pocl_cpu_only(NULL);
}

/* All devices of all platforms (GPUs of platforms that may have one, when gpu_only), in
 * loader order. Returns a vis_status value. */
static int list_devices(int gpu_only, dev_entry *out, uint32_t *out_count, char *err, size_t err_size)
{
    cl_platform_id plats[MAX_PLATFORMS];
    cl_uint np = 0;
    cl_int e = clGetPlatformIDs(MAX_PLATFORMS, plats, &np);
    if (e == CL_PLATFORM_NOT_FOUND_KHR || (e == CL_SUCCESS && np == 0)) {
        snprintf(err, err_size, "no OpenCL platform found (is an ICD installed under /etc/OpenCL/vendors?)");
        return VIS_ERROR_NOT_FOUND;
    }
    if (e != CL_SUCCESS)
        return vis_cl_fail(e, "clGetPlatformIDs", err, err_size);
    if (np > MAX_PLATFORMS)
        np = MAX_PLATFORMS;
    uint32_t n = 0;
    for (cl_uint p = 0; p < np && n < MAX_DEVICES; ++p) {
        cl_device_id devs[MAX_DEVICES];
        cl_uint nd = 0;
        if (gpu_only && platform_cpu_only(plats[p]))
            continue;
        if (clGetDeviceIDs(plats[p], gpu_only ? CL_DEVICE_TYPE_GPU : CL_DEVICE_TYPE_ALL, MAX_DEVICES, devs, &nd) !=
            CL_SUCCESS)
            continue; /* CL_DEVICE_NOT_FOUND: a platform without devices (of that type) */
        if (nd > MAX_DEVICES)
            nd = MAX_DEVICES;
        for (cl_uint i = 0; i < nd && n < MAX_DEVICES; ++i) {
            out[n].platform = plats[p];
            out[n].device = devs[i];
            ++n;
        }
    }
    if (n == 0) {
        snprintf(err, err_size, "no OpenCL %s found on %u platform%s", gpu_only ? "GPU" : "device", np,
                 np == 1 ? "" : "s");
        return VIS_ERROR_NOT_FOUND;
    }
    *out_count = n;
    return VIS_OK;
}

/* "0: NAME (PLATFORM), 1: ..." for error messages. */
static void describe(const dev_entry *devs, uint32_t n, char *out, size_t size)
{
    size_t used = 0;
    out[0] = '\0';
    for (uint32_t i = 0; i < n && used + 1 < size; ++i) {
        char name[128], plat[128] = "";
        info_string(devs[i].device, CL_DEVICE_NAME, name, sizeof name);
        clGetPlatformInfo(devs[i].platform, CL_PLATFORM_NAME, sizeof plat, plat, NULL);
        plat[sizeof plat - 1] = '\0';
        int w = snprintf(out + used, size - used, "%s%u: %s (%s)", i ? ", " : "", i, name, plat);
        if (w < 0)
            break;
        used += (size_t)w;
    }
}

int vis_cl_device_pick(const char *selector, int gpu_only, cl_platform_id *out_platform, cl_device_id *out_device,
                       vis_cl_device_caps *caps, char *err, size_t err_size)
{
    dev_entry devs[MAX_DEVICES];
    uint32_t n = 0;
    if (gpu_only)
        selector = NULL;
    int st = list_devices(gpu_only, devs, &n, err, err_size);
    if (st != VIS_OK)
        return st;
    if (!gpu_only && (!selector || !*selector))
        selector = getenv("VIS_OPENCL_DEVICE");
    char list[768];

    if (selector && *selector) {
        const char *p = selector;
        while (*p >= '0' && *p <= '9')
            ++p;
        int index = -1;
        if (*p == '\0' && p - selector <= 6) {
            long v = strtol(selector, NULL, 10);
            if (v >= (long)n) {
                describe(devs, n, list, sizeof list);
                snprintf(err, err_size, "OpenCL device index %ld out of range; devices: %s", v, list);
                return VIS_ERROR_NOT_FOUND;
            }
            index = (int)v;
        } else {
            /* "gpu", "cpu", "accelerator": the first device of that type. */
            cl_device_type want = 0;
            if (equals_nocase(selector, "gpu"))
                want = CL_DEVICE_TYPE_GPU;
            else if (equals_nocase(selector, "cpu"))
                want = CL_DEVICE_TYPE_CPU;
            else if (equals_nocase(selector, "accelerator"))
                want = CL_DEVICE_TYPE_ACCELERATOR;
            for (uint32_t i = 0; i < n && index < 0; ++i) {
                if (want) {
                    cl_device_type type = 0;
                    clGetDeviceInfo(devs[i].device, CL_DEVICE_TYPE, sizeof type, &type, NULL);
                    if (type & want)
                        index = (int)i;
                    continue;
                }
                char name[128], vendor[128], plat[128] = "", pvendor[128] = "";
                info_string(devs[i].device, CL_DEVICE_NAME, name, sizeof name);
                info_string(devs[i].device, CL_DEVICE_VENDOR, vendor, sizeof vendor);
                clGetPlatformInfo(devs[i].platform, CL_PLATFORM_NAME, sizeof plat, plat, NULL);
                clGetPlatformInfo(devs[i].platform, CL_PLATFORM_VENDOR, sizeof pvendor, pvendor, NULL);
                plat[sizeof plat - 1] = '\0';
                pvendor[sizeof pvendor - 1] = '\0';
                if (contains_nocase(name, selector) || contains_nocase(vendor, selector) ||
                    contains_nocase(plat, selector) || contains_nocase(pvendor, selector))
                    index = (int)i;
            }
            if (index < 0) {
                describe(devs, n, list, sizeof list);
                snprintf(err, err_size, "no OpenCL device matches '%s'; devices: %s", selector, list);
                return VIS_ERROR_NOT_FOUND;
            }
        }
        /* An explicit choice is kept or refused, never silently replaced. */
        char why[512] = "";
        st = vis_cl_device_check(devs[index].platform, devs[index].device, caps, why, sizeof why);
        if (st != VIS_OK) {
            snprintf(err, err_size, "%s", why);
            return st;
        }
        *out_platform = devs[index].platform;
        *out_device = devs[index].device;
        return VIS_OK;
    }

    /* No selector: GPUs first, then the rest, each in loader order; the first usable wins. */
    char first_why[512] = "";
    for (int pass = 0; pass < 2; ++pass)
        for (uint32_t i = 0; i < n; ++i) {
            cl_device_type type = 0;
            clGetDeviceInfo(devs[i].device, CL_DEVICE_TYPE, sizeof type, &type, NULL);
            int gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
            if (gpu != (pass == 0))
                continue;
            char why[512] = "";
            if (vis_cl_device_check(devs[i].platform, devs[i].device, caps, why, sizeof why) == VIS_OK) {
                *out_platform = devs[i].platform;
                *out_device = devs[i].device;
                return VIS_OK;
            }
            if (!first_why[0])
                snprintf(first_why, sizeof first_why, "%s", why);
        }
    snprintf(err, err_size, "no usable OpenCL device: %s", first_why);
    return VIS_ERROR_UNSUPPORTED;
}
