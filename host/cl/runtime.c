/* OpenCL runtime: device choice, program registry over the embedded kernels, checked calls.
 * Modelled on darktable's src/common/opencl.c (a registry of kernel files, error codes turned
 * into names) and GEGL's embedding of .cl sources at build time. */
#include "csi/runtime.h"

#include <clFFT.h>
#include <ctype.h>
#include <errno.h>
#include <stdatomic.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/stat.h>

#include "csi/buffer_keep.h"
#include "csi/program_cache.h"

struct csi_embedded_kernel {
    const char *name;
    const char *source;
};
extern const struct csi_embedded_kernel csi_embedded_kernels[];

#define CSI_MAX_PROGRAMS 32
#define CSI_MAX_KERNELS 256

struct csi_kernel_slot {
    char program[48];
    char name[64];
    cl_kernel kernel;
};

struct csi_ctx {
    cl_platform_id platform;
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    char name[512];
    size_t max_alloc;
    uint64_t global_mem;
    struct {
        const char *name;
        cl_program program;
    } programs[CSI_MAX_PROGRAMS];
    int nprograms;
    int nprograms_cached; /* of which loaded from csi's program cache */
    struct csi_kernel_slot kernels[CSI_MAX_KERNELS];
    int nkernels;
    bool clfft;
    double t_build; /* seconds spent building programs and creating kernels */
    _Atomic(csi_row_pool *) row_pool; /* the host passes' workers, started on first use */
};

/* Device bytes held through csi_buffer by this process (every context): live now, and the
 * largest live total since the last reset. The resource plan (csi/plan.h) is tested against the
 * peak, and csi_buffer refuses an allocation that would take the live total over the device's
 * global memory (PoCL otherwise fails later, or aborts when the host runs out). */
static _Atomic uint64_t csi_dev_live, csi_dev_peak;

static void dev_bytes_add(uint64_t bytes)
{
    uint64_t now = atomic_fetch_add(&csi_dev_live, bytes) + bytes;
    uint64_t peak = atomic_load(&csi_dev_peak);
    while (now > peak && !atomic_compare_exchange_weak(&csi_dev_peak, &peak, now))
        ;
}

uint64_t csi_device_bytes_live(void) { return atomic_load(&csi_dev_live); }
uint64_t csi_device_bytes_peak(void) { return atomic_load(&csi_dev_peak); }
void csi_device_bytes_reset_peak(void) { atomic_store(&csi_dev_peak, atomic_load(&csi_dev_live)); }

void csi_mem_tally_add(csi_mem_tally *t, uint64_t bytes, const char *what)
{
    if (bytes == 0)
        bytes = CSI_BUFFER_MIN_BYTES; /* as csi_buffer allocates */
    t->total += bytes;
    if (bytes > t->largest) {
        t->largest = bytes;
        t->largest_what = what;
    }
}

/* clFFT keeps one library state per process; count the contexts that use it. */
static int csi_clfft_users;
/* clFFT's repository is a C++ static destroyed by exit handlers registered when clfftSetup runs;
 * a context released by an earlier-registered atexit handler (as the tests do) would then call
 * clfftTeardown on a destroyed repository and crash. So the first setup registers its own exit
 * handler (run before clFFT's destructor, exit handlers being LIFO) that tears down once. */
static bool csi_clfft_down;
static void csi_clfft_atexit(void)
{
    if (csi_clfft_users > 0 && !csi_clfft_down) {
        clfftTeardown();
        csi_clfft_down = true;
    }
}

const char *csi_cl_error_name(cl_int err)
{
    switch (err) {
#define N(c) case c: return #c
    N(CL_SUCCESS); N(CL_DEVICE_NOT_FOUND); N(CL_DEVICE_NOT_AVAILABLE); N(CL_COMPILER_NOT_AVAILABLE);
    N(CL_MEM_OBJECT_ALLOCATION_FAILURE); N(CL_OUT_OF_RESOURCES); N(CL_OUT_OF_HOST_MEMORY);
    N(CL_PROFILING_INFO_NOT_AVAILABLE); N(CL_MEM_COPY_OVERLAP); N(CL_IMAGE_FORMAT_MISMATCH);
    N(CL_IMAGE_FORMAT_NOT_SUPPORTED); N(CL_BUILD_PROGRAM_FAILURE); N(CL_MAP_FAILURE);
    N(CL_MISALIGNED_SUB_BUFFER_OFFSET); N(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST);
    N(CL_COMPILE_PROGRAM_FAILURE); N(CL_LINKER_NOT_AVAILABLE); N(CL_LINK_PROGRAM_FAILURE);
    N(CL_DEVICE_PARTITION_FAILED); N(CL_KERNEL_ARG_INFO_NOT_AVAILABLE);
    N(CL_INVALID_VALUE); N(CL_INVALID_DEVICE_TYPE); N(CL_INVALID_PLATFORM); N(CL_INVALID_DEVICE);
    N(CL_INVALID_CONTEXT); N(CL_INVALID_QUEUE_PROPERTIES); N(CL_INVALID_COMMAND_QUEUE);
    N(CL_INVALID_HOST_PTR); N(CL_INVALID_MEM_OBJECT); N(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR);
    N(CL_INVALID_IMAGE_SIZE); N(CL_INVALID_SAMPLER); N(CL_INVALID_BINARY); N(CL_INVALID_BUILD_OPTIONS);
    N(CL_INVALID_PROGRAM); N(CL_INVALID_PROGRAM_EXECUTABLE); N(CL_INVALID_KERNEL_NAME);
    N(CL_INVALID_KERNEL_DEFINITION); N(CL_INVALID_KERNEL); N(CL_INVALID_ARG_INDEX);
    N(CL_INVALID_ARG_VALUE); N(CL_INVALID_ARG_SIZE); N(CL_INVALID_KERNEL_ARGS);
    N(CL_INVALID_WORK_DIMENSION); N(CL_INVALID_WORK_GROUP_SIZE); N(CL_INVALID_WORK_ITEM_SIZE);
    N(CL_INVALID_GLOBAL_OFFSET); N(CL_INVALID_EVENT_WAIT_LIST); N(CL_INVALID_EVENT);
    N(CL_INVALID_OPERATION); N(CL_INVALID_GL_OBJECT); N(CL_INVALID_BUFFER_SIZE);
    N(CL_INVALID_MIP_LEVEL); N(CL_INVALID_GLOBAL_WORK_SIZE); N(CL_INVALID_PROPERTY);
    N(CL_INVALID_IMAGE_DESCRIPTOR); N(CL_INVALID_COMPILER_OPTIONS); N(CL_INVALID_LINKER_OPTIONS);
    N(CL_INVALID_DEVICE_PARTITION_COUNT);
    N(-1001); /* CL_PLATFORM_NOT_FOUND_KHR: the ICD loader found no platform */
#undef N
    }
    static _Thread_local char buf[32];
    snprintf(buf, sizeof buf, "CL_ERROR(%d)", (int)err);
    return buf;
}

const char *csi_clfft_error_name(int err)
{
    switch (err) {
    case CLFFT_BUGCHECK: return "CLFFT_BUGCHECK";
    case CLFFT_NOTIMPLEMENTED: return "CLFFT_NOTIMPLEMENTED";
    case CLFFT_TRANSPOSED_NOTIMPLEMENTED: return "CLFFT_TRANSPOSED_NOTIMPLEMENTED";
    case CLFFT_FILE_NOT_FOUND: return "CLFFT_FILE_NOT_FOUND";
    case CLFFT_FILE_CREATE_FAILURE: return "CLFFT_FILE_CREATE_FAILURE";
    case CLFFT_VERSION_MISMATCH: return "CLFFT_VERSION_MISMATCH";
    case CLFFT_INVALID_PLAN: return "CLFFT_INVALID_PLAN";
    case CLFFT_DEVICE_NO_DOUBLE: return "CLFFT_DEVICE_NO_DOUBLE";
    case CLFFT_DEVICE_MISMATCH: return "CLFFT_DEVICE_MISMATCH";
    default: return csi_cl_error_name((cl_int)err);
    }
}

csi_status csi_cl_check(cl_int err, const char *call, const char *file, int line)
{
    if (err == CL_SUCCESS)
        return CSI_OK;
    /* Keep only the function name of the call for a readable one-line message. */
    char fn[64];
    size_t i = 0;
    while (call[i] && call[i] != '(' && i + 1 < sizeof fn) {
        fn[i] = call[i];
        i++;
    }
    fn[i] = '\0';
    const char *base = strrchr(file, '/');
    return csi_fail(CSI_ERR_CL, "OpenCL call %s failed with %s (%s:%d)", fn, csi_cl_error_name(err),
                    base ? base + 1 : file, line);
}

static bool contains_ci(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    for (const char *p = hay; *p; p++) {
        size_t i = 0;
        while (i < n && p[i] && tolower((unsigned char)p[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == n)
            return true;
    }
    return n == 0;
}

/* Sets up kernel caches before the platform is first touched (PoCL reads its env at init). A
 * CSI_CACHE_DIR where PoCL cannot write its cache is refused here: PoCL would otherwise fail to
 * start and the process would only learn that no OpenCL device was found. */
static csi_status setup_caches(void)
{
    const char *dir = getenv("CSI_CACHE_DIR");
    char path[1024];
    if (dir && *dir) {
        const char *sub[2] = {"pocl", "clfft"}, *var[2] = {"POCL_CACHE_DIR", "CLFFT_CACHE_PATH"};
        for (int i = 0; i < 2; i++) {
            if (getenv(var[i]))
                continue; /* the caller's own choice stands */
            snprintf(path, sizeof path, "%s/%s", dir, sub[i]);
            csi_cache_mkdirs(path);
            if (access(path, W_OK | X_OK) != 0)
                return csi_fail(CSI_ERR_IO, "CSI_CACHE_DIR=%s: cannot keep kernel caches in %s (%s); set it to a "
                                            "writable directory, or unset it", dir, path, strerror(errno));
            setenv(var[i], path, 1);
        }
        return CSI_OK;
    }
    if (getenv("CLFFT_CACHE_PATH"))
        return CSI_OK;
    const char *xdg = getenv("XDG_CACHE_HOME");
    const char *home = getenv("HOME");
    if (xdg && *xdg)
        snprintf(path, sizeof path, "%s/csi/clfft", xdg);
    else if (home && *home)
        snprintf(path, sizeof path, "%s/.cache/csi/clfft", home);
    else
        return CSI_OK;
    csi_cache_mkdirs(path);
    setenv("CLFFT_CACHE_PATH", path, 0);
    return CSI_OK;
}

/* The settings the library reads from the environment beside CSI_CACHE_DIR and CSI_DEVICE,
 * checked when a device is made: a value they cannot mean is refused then, in one line naming
 * it, rather than read as something else (CSI_HOST_THREADS=four as one thread). */
static bool whole_number(const char *text, unsigned long long lo)
{
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    return isdigit((unsigned char)text[0]) && *end == '\0' && !errno && v >= lo;
}

static csi_status check_settings(void)
{
    const char *v = getenv("CSI_HOST_THREADS");
    if (v && *v && !whole_number(v, 1))
        return csi_fail(CSI_ERR_ARG, "CSI_HOST_THREADS=%.40s is not a number of threads (1 or more); unset it for "
                                     "the host's cores", v);
    v = getenv("CSI_PROGRAM_CACHE");
    if (v && *v && strcmp(v, "0") && strcmp(v, "1"))
        return csi_fail(CSI_ERR_ARG, "CSI_PROGRAM_CACHE=%.40s is neither 0 (off) nor 1 (on, the default)", v);
    v = getenv("CSI_HOST_MEMORY_LIMIT");
    if (v && *v && !whole_number(v, 1))
        return csi_fail(CSI_ERR_ARG, "CSI_HOST_MEMORY_LIMIT=%.40s is not a number of bytes (1 or more)", v);
    return CSI_OK;
}

typedef struct {
    cl_platform_id platform;
    cl_device_id device;
    char label[512];
    cl_device_type type;
} dev_entry;

static csi_status enumerate(dev_entry *out, int cap, int *count)
{
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(0, NULL, &np);
    *count = 0;
    if (err == -1001 || np == 0)
        return CSI_OK; /* no platform installed: reported by the caller as "no device" */
    CSI_CL_TRY(err);
    cl_platform_id plats[16];
    if (np > 16)
        np = 16;
    CSI_CL_TRY(clGetPlatformIDs(np, plats, NULL));
    for (cl_uint p = 0; p < np; p++) {
        char pname[256] = "";
        clGetPlatformInfo(plats[p], CL_PLATFORM_NAME, sizeof pname, pname, NULL);
        cl_uint nd = 0;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, 0, NULL, &nd) != CL_SUCCESS || nd == 0)
            continue;
        cl_device_id devs[16];
        if (nd > 16)
            nd = 16;
        if (clGetDeviceIDs(plats[p], CL_DEVICE_TYPE_ALL, nd, devs, NULL) != CL_SUCCESS)
            continue;
        for (cl_uint d = 0; d < nd && *count < cap; d++) {
            dev_entry *e = &out[(*count)++];
            char dname[256] = "";
            clGetDeviceInfo(devs[d], CL_DEVICE_NAME, sizeof dname, dname, NULL);
            clGetDeviceInfo(devs[d], CL_DEVICE_TYPE, sizeof e->type, &e->type, NULL);
            e->platform = plats[p];
            e->device = devs[d];
            snprintf(e->label, sizeof e->label, "%s / %s", pname, dname);
        }
    }
    return CSI_OK;
}

csi_status csi_list_devices(char *buf, size_t len)
{
    CSI_TRY(setup_caches());
    dev_entry devs[32];
    int n = 0;
    CSI_TRY(enumerate(devs, 32, &n));
    size_t used = 0;
    if (len)
        buf[0] = '\0';
    for (int i = 0; i < n && used < len; i++) {
        const char *t = (devs[i].type & CL_DEVICE_TYPE_CPU) ? "CPU"
                        : (devs[i].type & CL_DEVICE_TYPE_GPU) ? "GPU" : "other";
        int w = snprintf(buf + used, len - used, "%s (%s)\n", devs[i].label, t);
        if (w < 0)
            break;
        used += (size_t)w;
    }
    return CSI_OK;
}

csi_status csi_ctx_create(csi_ctx **out, const char *spec)
{
    *out = NULL;
    CSI_TRY(check_settings());
    CSI_TRY(setup_caches());
    if (!spec || !*spec)
        spec = getenv("CSI_DEVICE");
    dev_entry devs[32];
    int n = 0;
    CSI_TRY(enumerate(devs, 32, &n));
    if (n == 0)
        return csi_fail(CSI_ERR_DEVICE, "no OpenCL device found: install PoCL (tools/setup installs "
                                        "pocl-opencl-icd) or check /etc/OpenCL/vendors");
    int pick = -1;
    if (spec && *spec) {
        for (int i = 0; i < n && pick < 0; i++)
            if (contains_ci(devs[i].label, spec))
                pick = i;
        if (pick < 0)
            return csi_fail(CSI_ERR_DEVICE, "no OpenCL device matches '%s' (%d device%s found; "
                            "first: %s)", spec, n, n == 1 ? "" : "s", devs[0].label);
    } else {
        for (int i = 0; i < n && pick < 0; i++)
            if (contains_ci(devs[i].label, "Portable Computing Language") &&
                (devs[i].type & CL_DEVICE_TYPE_CPU))
                pick = i;
        if (pick < 0)
            pick = 0;
    }

    csi_ctx *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory creating the OpenCL context");
    ctx->platform = devs[pick].platform;
    ctx->device = devs[pick].device;
    snprintf(ctx->name, sizeof ctx->name, "%s", devs[pick].label);
    cl_ulong maxalloc = 0, gmem = 0;
    clGetDeviceInfo(ctx->device, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof maxalloc, &maxalloc, NULL);
    clGetDeviceInfo(ctx->device, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof gmem, &gmem, NULL);
    ctx->max_alloc = (size_t)maxalloc;
    ctx->global_mem = gmem;

    cl_int err;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM, (cl_context_properties)ctx->platform, 0};
    ctx->context = clCreateContext(props, 1, &ctx->device, NULL, NULL, &err);
    if (err != CL_SUCCESS) {
        csi_status st = CSI_CL(err);
        free(ctx);
        return csi_fail_context(st, "creating a context on %s: ", devs[pick].label);
    }
    ctx->queue = clCreateCommandQueue(ctx->context, ctx->device, 0, &err);
    if (err != CL_SUCCESS) {
        csi_status st = CSI_CL(err);
        clReleaseContext(ctx->context);
        free(ctx);
        return st;
    }
    *out = ctx;
    return CSI_OK;
}

csi_status csi_ctx_wrap(cl_context context, cl_device_id device, cl_command_queue queue,
                        csi_ctx **out)
{
    *out = NULL;
    if (!context || !device || !queue)
        return csi_fail(CSI_ERR_ARG, "an OpenCL device needs a context, a device and a queue "
                                     "(got %s%s%s NULL)", context ? "" : "context ",
                        device ? "" : "device ", queue ? "" : "queue");
    CSI_TRY(setup_caches());
    cl_context qctx = NULL;
    cl_device_id qdev = NULL;
    cl_command_queue_properties props = 0;
    cl_platform_id platform = NULL;
    CSI_CL_TRY(clGetCommandQueueInfo(queue, CL_QUEUE_CONTEXT, sizeof qctx, &qctx, NULL));
    CSI_CL_TRY(clGetCommandQueueInfo(queue, CL_QUEUE_DEVICE, sizeof qdev, &qdev, NULL));
    CSI_CL_TRY(clGetCommandQueueInfo(queue, CL_QUEUE_PROPERTIES, sizeof props, &props, NULL));
    CSI_CL_TRY(clGetDeviceInfo(device, CL_DEVICE_PLATFORM, sizeof platform, &platform, NULL));
    if (qctx != context || qdev != device)
        return csi_fail(CSI_ERR_ARG, "the OpenCL queue belongs to another %s than the one given",
                        qctx != context ? "context" : "device");
    /* Every module enqueues a step and relies on the previous one being done. */
    if (props & CL_QUEUE_OUT_OF_ORDER_EXEC_MODE_ENABLE)
        return csi_fail(CSI_ERR_ARG, "the OpenCL queue executes out of order; csi needs an in-order "
                                     "queue");
    csi_ctx *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory creating the OpenCL context");
    char pname[256] = "", dname[256] = "";
    clGetPlatformInfo(platform, CL_PLATFORM_NAME, sizeof pname, pname, NULL);
    clGetDeviceInfo(device, CL_DEVICE_NAME, sizeof dname, dname, NULL);
    snprintf(ctx->name, sizeof ctx->name, "%s / %s", pname, dname);
    cl_ulong maxalloc = 0, gmem = 0;
    clGetDeviceInfo(device, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof maxalloc, &maxalloc, NULL);
    clGetDeviceInfo(device, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof gmem, &gmem, NULL);
    ctx->max_alloc = (size_t)maxalloc;
    ctx->global_mem = gmem;
    ctx->platform = platform;
    ctx->device = device;
    /* csi's own references, released in csi_ctx_release; the caller keeps its own. */
    cl_int err = clRetainContext(context);
    if (err == CL_SUCCESS) {
        ctx->context = context;
        err = clRetainCommandQueue(queue);
    }
    if (err == CL_SUCCESS)
        ctx->queue = queue;
    if (err != CL_SUCCESS) {
        csi_status st = CSI_CL(err);
        csi_ctx_release(ctx);
        return st;
    }
    *out = ctx;
    return CSI_OK;
}

void csi_ctx_release(csi_ctx *ctx)
{
    if (!ctx)
        return;
    if (ctx->queue)
        clFinish(ctx->queue);
    csi_row_pool_free(atomic_load(&ctx->row_pool));
    for (int i = 0; i < ctx->nkernels; i++)
        clReleaseKernel(ctx->kernels[i].kernel);
    for (int i = 0; i < ctx->nprograms; i++)
        clReleaseProgram(ctx->programs[i].program);
    if (ctx->clfft && --csi_clfft_users == 0 && !csi_clfft_down)
        clfftTeardown();
    if (ctx->queue)
        clReleaseCommandQueue(ctx->queue);
    if (ctx->context)
        clReleaseContext(ctx->context);
    free(ctx);
}

cl_context csi_ctx_context(const csi_ctx *ctx) { return ctx->context; }
cl_command_queue csi_ctx_queue(const csi_ctx *ctx) { return ctx->queue; }
cl_device_id csi_ctx_device(const csi_ctx *ctx) { return ctx->device; }
const char *csi_ctx_device_name(const csi_ctx *ctx) { return ctx->name; }
size_t csi_ctx_max_alloc(const csi_ctx *ctx) { return ctx->max_alloc; }
uint64_t csi_ctx_global_mem(const csi_ctx *ctx) { return ctx->global_mem; }
uint64_t csi_ctx_local_mem(const csi_ctx *ctx)
{
    cl_ulong local = 0;
    if (clGetDeviceInfo(ctx->device, CL_DEVICE_LOCAL_MEM_SIZE, sizeof local, &local, NULL) != CL_SUCCESS)
        return 0;
    return local;
}

/* No -cl-fast-relaxed-math: the solvers' stopping rules depend on IEEE float behaviour. -w: the
 * compiler's warnings would reach the user's stderr on the first run of every kernel (a
 * program's "-q" promises none); a kernel that does not build still fails with its log. */
static const char BUILD_OPTIONS[] = "-cl-std=CL1.2 -w";

/* kernels/<name>.cl built from its source, or CSI_ERR_BUILD with the start of the build log. */
static csi_status build_from_source(csi_ctx *ctx, const char *name, const char *src, cl_program *out)
{
    cl_int err;
    cl_program prog = clCreateProgramWithSource(ctx->context, 1, &src, NULL, &err);
    CSI_CL_TRY(err);
    err = clBuildProgram(prog, 1, &ctx->device, BUILD_OPTIONS, NULL, NULL);
    if (err != CL_SUCCESS) {
        char log[1500] = "";
        size_t len = 0;
        clGetProgramBuildInfo(prog, ctx->device, CL_PROGRAM_BUILD_LOG, sizeof log - 1, log, &len);
        log[sizeof log - 1] = '\0';
        for (char *p = log; *p; p++)
            if (*p == '\n')
                *p = ' ';
        clReleaseProgram(prog);
        return csi_fail(CSI_ERR_BUILD, "kernels/%s.cl failed to build (%s): %s", name,
                        csi_cl_error_name(err), log);
    }
    *out = prog;
    return CSI_OK;
}

static csi_status build_program(csi_ctx *ctx, const char *name, cl_program *out)
{
    for (int i = 0; i < ctx->nprograms; i++)
        if (strcmp(ctx->programs[i].name, name) == 0) {
            *out = ctx->programs[i].program;
            return CSI_OK;
        }
    const char *src = NULL, *stored_name = NULL;
    for (const struct csi_embedded_kernel *e = csi_embedded_kernels; e->name; e++)
        if (strcmp(e->name, name) == 0) {
            src = e->source;
            stored_name = e->name;
        }
    if (!src)
        return csi_fail(CSI_ERR_BUILD, "no kernel program '%s' is embedded (kernels/%s.cl)", name, name);
    if (ctx->nprograms == CSI_MAX_PROGRAMS)
        return csi_fail(CSI_ERR_BUILD, "too many kernel programs (limit %d)", CSI_MAX_PROGRAMS);
    cl_program prog = csi_program_cache_load(ctx->context, ctx->device, stored_name, src, BUILD_OPTIONS);
    if (prog)
        ctx->nprograms_cached++;
    else
        CSI_TRY(build_from_source(ctx, stored_name, src, &prog));
    ctx->programs[ctx->nprograms].name = stored_name;
    ctx->programs[ctx->nprograms].program = prog;
    ctx->nprograms++;
    *out = prog;
    return CSI_OK;
}

static double seconds_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

double csi_ctx_build_seconds(const csi_ctx *ctx) { return ctx->t_build; }

int csi_ctx_programs_from_cache(const csi_ctx *ctx) { return ctx->nprograms_cached; }

csi_status csi_ctx_cache_programs(csi_ctx *ctx, const char *name, int *stored)
{
    if (stored)
        *stored = 0;
    char dir[1024];
    CSI_TRY(csi_program_cache_require_dir(dir, sizeof dir));
    bool found = false;
    for (const struct csi_embedded_kernel *e = csi_embedded_kernels; e->name; e++) {
        if (name && strcmp(e->name, name) != 0)
            continue;
        found = true;
        cl_program prog = csi_program_cache_load(ctx->context, ctx->device, e->name, e->source, BUILD_OPTIONS);
        if (prog) {
            clReleaseProgram(prog);
            continue;
        }
        CSI_TRY(build_from_source(ctx, e->name, e->source, &prog));
        const bool ok = csi_program_cache_store(prog, ctx->device, e->name, e->source, BUILD_OPTIONS);
        clReleaseProgram(prog);
        if (!ok)
            return csi_fail(CSI_ERR_IO, "%s: cannot store the binary of kernels/%s.cl there", dir, e->name);
        if (stored)
            (*stored)++;
    }
    if (!found)
        return csi_fail(CSI_ERR_ARG, "no kernel program '%s' is embedded", name);
    return CSI_OK;
}

csi_status csi_kernel(csi_ctx *ctx, const char *program, const char *kernel, cl_kernel *out)
{
    for (int i = 0; i < ctx->nkernels; i++)
        if (strcmp(ctx->kernels[i].name, kernel) == 0 && strcmp(ctx->kernels[i].program, program) == 0) {
            *out = ctx->kernels[i].kernel;
            return CSI_OK;
        }
    if (ctx->nkernels == CSI_MAX_KERNELS)
        return csi_fail(CSI_ERR_BUILD, "too many kernels (limit %d)", CSI_MAX_KERNELS);
    const double t0 = seconds_now();
    cl_program prog = NULL;
    csi_status bst = build_program(ctx, program, &prog);
    cl_int err = CL_SUCCESS;
    cl_kernel k = bst == CSI_OK ? clCreateKernel(prog, kernel, &err) : NULL;
    ctx->t_build += seconds_now() - t0;
    CSI_TRY(bst);
    if (err != CL_SUCCESS)
        return csi_fail(CSI_ERR_BUILD, "kernel '%s' not found in kernels/%s.cl (%s)", kernel, program,
                        csi_cl_error_name(err));
    struct csi_kernel_slot *s = &ctx->kernels[ctx->nkernels++];
    snprintf(s->program, sizeof s->program, "%s", program);
    snprintf(s->name, sizeof s->name, "%s", kernel);
    s->kernel = k;
    *out = k;
    return CSI_OK;
}

static void human_bytes(char *buf, size_t len, double b)
{
    const char *u[] = {"B", "KiB", "MiB", "GiB", "TiB"};
    int i = 0;
    while (b >= 1024.0 && i < 4) {
        b /= 1024.0;
        i++;
    }
    snprintf(buf, len, "%.1f %s", b, u[i]);
}

csi_row_pool *csi_ctx_row_pool(csi_ctx *ctx)
{
    csi_row_pool *p = atomic_load(&ctx->row_pool);
    if (p)
        return p;
    p = csi_row_pool_new(csi_row_pool_threads_for_host());
    csi_row_pool *none = NULL;
    if (p && !atomic_compare_exchange_strong(&ctx->row_pool, &none, p)) {
        csi_row_pool_free(p); /* another thread's came first */
        p = none;
    }
    return p;
}

csi_status csi_ctx_limit_memory(csi_ctx *ctx, uint64_t max_alloc, uint64_t global)
{
    if (!ctx)
        return csi_fail(CSI_ERR_ARG, "csi_ctx_limit_memory: no context");
    if (max_alloc && max_alloc < ctx->max_alloc)
        ctx->max_alloc = (size_t)max_alloc;
    if (global && global < ctx->global_mem)
        ctx->global_mem = global;
    return CSI_OK;
}

csi_status csi_buffer(csi_ctx *ctx, size_t bytes, cl_mem_flags flags, const char *what, cl_mem *out)
{
    *out = NULL;
    if (bytes == 0)
        bytes = CSI_BUFFER_MIN_BYTES;
    if (bytes > ctx->max_alloc) {
        char a[32], b[32];
        human_bytes(a, sizeof a, (double)bytes);
        human_bytes(b, sizeof b, (double)ctx->max_alloc);
        return csi_fail(CSI_ERR_DEVICE, "%s needs a %s buffer, over the device's single-buffer limit "
                        "of %s (%s)", what ? what : "an operation", a, b, ctx->name);
    }
    const uint64_t live = csi_device_bytes_live();
    if (ctx->global_mem && (uint64_t)bytes > ctx->global_mem - (live < ctx->global_mem ? live : ctx->global_mem)) {
        char a[32], b[32], c[32];
        human_bytes(a, sizeof a, (double)bytes);
        human_bytes(b, sizeof b, (double)live);
        human_bytes(c, sizeof c, (double)ctx->global_mem);
        return csi_fail(CSI_ERR_DEVICE, "%s needs a %s buffer, but %s of the device's %s are in use (%s)",
                        what ? what : "an operation", a, b, c, ctx->name);
    }
    cl_int err = CL_SUCCESS;
    cl_mem m = NULL;
    if (!csi_buffer_keep_take(ctx->context, bytes, flags, &m))
        m = clCreateBuffer(ctx->context, flags, bytes, NULL, &err);
    if (err != CL_SUCCESS) {
        char a[32];
        human_bytes(a, sizeof a, (double)bytes);
        csi_status st = CSI_CL(err);
        return csi_fail_context(st, "allocating %s for %s: ", a, what ? what : "a buffer");
    }
    dev_bytes_add(bytes);
    *out = m;
    return CSI_OK;
}

void csi_buffer_release(cl_mem *buf)
{
    if (buf && *buf) {
        size_t bytes = 0;
        if (clGetMemObjectInfo(*buf, CL_MEM_SIZE, sizeof bytes, &bytes, NULL) == CL_SUCCESS)
            atomic_fetch_sub(&csi_dev_live, (uint64_t)bytes);
        if (!csi_buffer_keep_put(*buf, bytes))
            clReleaseMemObject(*buf);
        *buf = NULL;
    }
}

csi_status csi_write(csi_ctx *ctx, cl_mem dst, size_t offset, size_t bytes, const void *src)
{
    if (bytes == 0)
        return CSI_OK;
    return CSI_CL(clEnqueueWriteBuffer(ctx->queue, dst, CL_TRUE, offset, bytes, src, 0, NULL, NULL));
}

csi_status csi_read(csi_ctx *ctx, cl_mem src, size_t offset, size_t bytes, void *dst)
{
    if (bytes == 0)
        return CSI_OK;
    return CSI_CL(clEnqueueReadBuffer(ctx->queue, src, CL_TRUE, offset, bytes, dst, 0, NULL, NULL));
}

csi_status csi_fill_zero(csi_ctx *ctx, cl_mem buf, size_t bytes)
{
    if (bytes == 0)
        return CSI_OK;
    const cl_uint zero = 0;
    if (bytes % 4 == 0)
        return CSI_CL(clEnqueueFillBuffer(ctx->queue, buf, &zero, 4, 0, bytes, 0, NULL, NULL));
    const cl_uchar z = 0;
    return CSI_CL(clEnqueueFillBuffer(ctx->queue, buf, &z, 1, 0, bytes, 0, NULL, NULL));
}

csi_status csi_copy(csi_ctx *ctx, cl_mem dst, size_t dst_off, cl_mem src, size_t src_off, size_t bytes)
{
    if (bytes == 0)
        return CSI_OK;
    return CSI_CL(clEnqueueCopyBuffer(ctx->queue, src, dst, src_off, dst_off, bytes, 0, NULL, NULL));
}

csi_status csi_copy_rows(csi_ctx *ctx, cl_mem dst, size_t dst_pitch, cl_mem src, size_t src_pitch,
                         size_t row_bytes, size_t rows)
{
    if (row_bytes == 0 || rows == 0)
        return CSI_OK;
    const size_t origin[3] = {0, 0, 0}, region[3] = {row_bytes, rows, 1};
    return CSI_CL(clEnqueueCopyBufferRect(ctx->queue, src, dst, origin, origin, region, src_pitch, 0,
                                          dst_pitch, 0, 0, NULL, NULL));
}

csi_status csi_run(csi_ctx *ctx, cl_kernel k, cl_uint dims, const size_t *global, const size_t *local)
{
    size_t loc[3] = {64, 1, 1}, glob[3];
    if (dims == 2) {
        loc[0] = 8;
        loc[1] = 8;
    }
    if (local)
        for (cl_uint d = 0; d < dims; d++)
            loc[d] = local[d];
    for (cl_uint d = 0; d < dims; d++) {
        if (global[d] == 0)
            return CSI_OK; /* nothing to do */
        glob[d] = (global[d] + loc[d] - 1) / loc[d] * loc[d];
    }
    cl_int err = clEnqueueNDRangeKernel(ctx->queue, k, dims, NULL, glob, loc, 0, NULL, NULL);
    if (err != CL_SUCCESS) {
        char kname[128] = "?";
        clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof kname, kname, NULL);
        csi_status st = CSI_CL(err);
        return csi_fail_context(st, "launching kernel %s: ", kname);
    }
    return CSI_OK;
}

csi_status csi_run1d(csi_ctx *ctx, cl_kernel k, size_t n)
{
    return csi_run(ctx, k, 1, &n, NULL);
}

csi_status csi_finish(csi_ctx *ctx) { return CSI_CL(clFinish(ctx->queue)); }

csi_status csi_set_args(cl_kernel k, const char *name, ...)
{
    va_list ap;
    va_start(ap, name);
    cl_uint i = 0;
    for (;;) {
        size_t sz = va_arg(ap, size_t);
        if (sz == 0)
            break;
        const void *p = va_arg(ap, const void *);
        cl_int err = clSetKernelArg(k, i, sz, p);
        if (err != CL_SUCCESS) {
            va_end(ap);
            char kname[128] = "?";
            clGetKernelInfo(k, CL_KERNEL_FUNCTION_NAME, sizeof kname, kname, NULL);
            return csi_fail(CSI_ERR_CL, "clSetKernelArg(%s, arg %u) failed with %s", kname, i,
                            csi_cl_error_name(err));
        }
        i++;
    }
    va_end(ap);
    return CSI_OK;
}

csi_status csi_clfft_ready(csi_ctx *ctx)
{
    if (ctx->clfft)
        return CSI_OK;
    if (csi_clfft_users == 0) {
        clfftSetupData setup;
        clfftStatus s = clfftInitSetupData(&setup);
        if (s == CLFFT_SUCCESS)
            s = clfftSetup(&setup);
        if (s != CLFFT_SUCCESS)
            return csi_fail(CSI_ERR_CL, "clfftSetup failed with %s", csi_clfft_error_name(s));
        static bool registered;
        if (!registered)
            registered = atexit(csi_clfft_atexit) == 0;
    }
    csi_clfft_users++;
    ctx->clfft = true;
    return CSI_OK;
}
