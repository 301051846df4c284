/* OpenCL runtime: device choice, embedded programs built once and cached, checked calls.
 *
 * One csi_ctx holds a context, an in-order queue on one device, the programs built from the
 * embedded kernels/ sources (built lazily, once per process; PoCL caches the binaries across
 * runs), and clFFT's library state. Every OpenCL error becomes a csi_status with the call and
 * the error's name in the message. */
#ifndef CSI_RUNTIME_H
#define CSI_RUNTIME_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <CL/cl.h>

#include "csi/row_pool.h"
#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_ctx csi_ctx;

/* Device selection, in this order: `spec` if non-NULL and non-empty, else the environment
 * variable CSI_DEVICE, else the first CPU device of a platform whose name contains "Portable
 * Computing Language" (PoCL), else the first device of any kind. A spec is a case-insensitive
 * substring matched against "platform name / device name"; "list" is not a device.
 * Also: CSI_CACHE_DIR (if set) becomes POCL_CACHE_DIR and holds clFFT's kernel cache; otherwise
 * clFFT's cache goes to $XDG_CACHE_HOME/csi/clfft or ~/.cache/csi/clfft unless
 * CLFFT_CACHE_PATH is already set. */
csi_status csi_ctx_create(csi_ctx **out, const char *spec);
/* A context on the caller's OpenCL objects (csi/csi_opencl.h): the queue must belong to context
 * and device and execute in order. csi retains the context and the queue and releases its
 * references in csi_ctx_release; the caller keeps its own. */
csi_status csi_ctx_wrap(cl_context context, cl_device_id device, cl_command_queue queue,
                        csi_ctx **out);
void csi_ctx_release(csi_ctx *ctx);

/* Lists every platform/device pair as lines "platform / device (type)" into buf. */
csi_status csi_list_devices(char *buf, size_t len);

cl_context csi_ctx_context(const csi_ctx *ctx);
cl_command_queue csi_ctx_queue(const csi_ctx *ctx);
cl_device_id csi_ctx_device(const csi_ctx *ctx);
const char *csi_ctx_device_name(const csi_ctx *ctx); /* "platform / device" */
size_t csi_ctx_max_alloc(const csi_ctx *ctx);        /* CL_DEVICE_MAX_MEM_ALLOC_SIZE */
uint64_t csi_ctx_global_mem(const csi_ctx *ctx);     /* CL_DEVICE_GLOBAL_MEM_SIZE */
uint64_t csi_ctx_local_mem(const csi_ctx *ctx);      /* CL_DEVICE_LOCAL_MEM_SIZE (0 when unknown) */

/* The name of an OpenCL error code ("CL_OUT_OF_RESOURCES"), or "CL_ERROR(-NN)". */
const char *csi_cl_error_name(cl_int err);
/* The name of a clFFT status (clFFT codes extend OpenCL's). */
const char *csi_clfft_error_name(int err);

/* Records and returns a CSI_ERR_CL failure naming the call and error, when err != CL_SUCCESS. */
csi_status csi_cl_check(cl_int err, const char *call, const char *file, int line);
#define CSI_CL(call) csi_cl_check((call), #call, __FILE__, __LINE__)
#define CSI_CL_TRY(call) CSI_TRY(CSI_CL(call))

/* The kernel `kernel` from program `program` (the stem of kernels/<program>.cl), built on first
 * use. The returned object is owned by ctx; callers set arguments and enqueue it, never release
 * it. Single-threaded use of one ctx is assumed. */
csi_status csi_kernel(csi_ctx *ctx, const char *program, const char *kernel, cl_kernel *out);

/* Seconds this context has spent building its programs and creating kernels (PoCL compiles
 * or loads cached binaries on first use): the part of a run's fixed cost the programs take. */
double csi_ctx_build_seconds(const csi_ctx *ctx);

/* How many of this context's programs came from csi's program cache (csi/program_cache.h)
 * rather than from their source. */
int csi_ctx_programs_from_cache(const csi_ctx *ctx);

/* Puts the program `name` (NULL: every program csi embeds) into the program cache for later
 * processes: built from source and its binary stored unless the cache already holds it. Slow
 * once (PoCL compiles every kernel of a program for its binary), then a load. *stored (may be
 * NULL): the programs stored now. CSI_ERR_IO when the cache is off or its file cannot be
 * written. */
csi_status csi_ctx_cache_programs(csi_ctx *ctx, const char *name, int *stored);

/* The pool of worker threads for the host's passes between the device's work (csi/row_pool.h):
 * one per context, started on the first call, stopped by csi_ctx_release. NULL on a host of one
 * core or when no worker could be started (the passes then run on the calling thread). */
csi_row_pool *csi_ctx_row_pool(csi_ctx *ctx);

/* Lowers the memory limits this context enforces and reports (csi_ctx_max_alloc,
 * csi_ctx_global_mem) to at most max_alloc bytes per buffer and global bytes in all; 0 keeps the
 * current limit, and a limit is never raised above what the device reports. For a budget below
 * the device's, and for tests of limits, which must not depend on the machine's free memory
 * (PoCL derives its limits from it at start-up). */
csi_status csi_ctx_limit_memory(csi_ctx *ctx, uint64_t max_alloc, uint64_t global);

/* Buffers. Refuses (CSI_ERR_DEVICE, naming the size, the limit and `what`) a buffer over the
 * single-allocation limit, and one that would take the bytes live through csi_buffer over the
 * global limit; zero-size requests allocate CSI_BUFFER_MIN_BYTES so callers need no cases. A
 * large buffer may be one released earlier and kept for reuse (csi/buffer_keep.h). */
#define CSI_BUFFER_MIN_BYTES 16u
csi_status csi_buffer(csi_ctx *ctx, size_t bytes, cl_mem_flags flags, const char *what, cl_mem *out);
void csi_buffer_release(cl_mem *buf); /* releases and sets to NULL; NULL is fine */
/* Device bytes this process holds through csi_buffer (all contexts): live now, and the peak of
 * the live total since the last reset (csi_device_bytes_reset_peak sets it to the live total). */
uint64_t csi_device_bytes_live(void);
/* csi_device_bytes_peak: csi/csi.h */
void csi_device_bytes_reset_peak(void);

/* The device buffers an operation will allocate, added up before it runs (the resource plan,
 * csi/plan.h): their total and the largest one. Each module that allocates device buffers has a
 * `*_buffers` function that adds exactly what its create function allocates. */
typedef struct csi_mem_tally {
    uint64_t total;           /* bytes of all buffers */
    uint64_t largest;         /* bytes of the largest one */
    const char *largest_what; /* what it holds (NULL when empty) */
    uint64_t local_mem;       /* set by the caller: the device's local memory (csi_ctx_local_mem),
                                 which decides whether the fused FFT stages run and so which
                                 buffers are made; 0 (unknown) counts what the unfused ones need */
} csi_mem_tally;
/* Adds one buffer of `bytes` (0 counts as CSI_BUFFER_MIN_BYTES, as csi_buffer allocates). */
void csi_mem_tally_add(csi_mem_tally *t, uint64_t bytes, const char *what);

csi_status csi_write(csi_ctx *ctx, cl_mem dst, size_t offset, size_t bytes, const void *src);
csi_status csi_read(csi_ctx *ctx, cl_mem src, size_t offset, size_t bytes, void *dst);
csi_status csi_fill_zero(csi_ctx *ctx, cl_mem buf, size_t bytes);
csi_status csi_copy(csi_ctx *ctx, cl_mem dst, size_t dst_off, cl_mem src, size_t src_off, size_t bytes);
/* rows rows of row_bytes bytes each, from src (rows src_pitch bytes apart) to dst (dst_pitch). */
csi_status csi_copy_rows(csi_ctx *ctx, cl_mem dst, size_t dst_pitch, cl_mem src, size_t src_pitch,
                         size_t row_bytes, size_t rows);

/* Enqueues a kernel over `global` work-items in 1, 2 or 3 dimensions with an explicit local
 * size (PoCL otherwise may run one huge group on one core). The global size is rounded up to a
 * multiple of the local size, so kernels must check their bounds. local may be NULL for the
 * default (64 in x, 1 elsewhere; 8x8 for 2-D). */
csi_status csi_run(csi_ctx *ctx, cl_kernel k, cl_uint dims, const size_t *global, const size_t *local);
csi_status csi_run1d(csi_ctx *ctx, cl_kernel k, size_t n);
csi_status csi_finish(csi_ctx *ctx);

/* Sets kernel arguments in order. Each argument is given as a (size, pointer) pair; ends with
 * a 0 size. Prefer the CSI_ARGS macro: CSI_ARGS(k, CSI_MEM(buf), CSI_U32(n), CSI_F32(a)). */
csi_status csi_set_args(cl_kernel k, const char *name, ...);
#define CSI_MEM(m) sizeof(cl_mem), (const void *)&(m)
#define CSI_ARG(v) sizeof(v), (const void *)&(v)
#define CSI_LOCAL(bytes) (size_t)(bytes), (const void *)NULL
#define CSI_ARGS(k, ...) csi_set_args((k), #k, __VA_ARGS__, (size_t)0)

/* clFFT's library state for this ctx (clfftSetup once per process; torn down by the last ctx
 * released). Modules that make plans call this first. */
csi_status csi_clfft_ready(csi_ctx *ctx);

#ifdef __cplusplus
}
#endif
#endif
