/* Large device buffers kept for reuse while a context runs a sequence of problems of the same
 * sizes (a reconstruction's tiles: each tile's scale pass, then its solve, makes and frees the
 * same model-grid volumes again).
 *
 * On a device in host memory (PoCL's CPU device) a buffer of tens of megabytes is a fresh
 * mapping each time it is made: every page is faulted in and zeroed by the kernel on first touch
 * and unmapped when the buffer is freed. Between csi_buffer_keep_begin(ctx) and
 * csi_buffer_keep_end(ctx), a buffer of CSI_BUFFER_KEEP_MIN bytes or more that csi_buffer_release
 * frees on ctx's OpenCL context is kept instead, and the next csi_buffer on that context of the
 * same size and flags takes it back: the same memory, its pages already in place. A buffer taken
 * back holds what its last user left in it, as OpenCL allows of any new buffer (csi writes every
 * buffer before it reads it). Bounded by the peak already reached: a csi_buffer that finds no
 * buffer of its size releases kept ones (the oldest first) until the bytes live, the bytes kept
 * and its own fit under the peak of live bytes so far (csi_device_bytes_peak), so the process
 * never holds more device memory than it would without keeping, and the counted peak is the
 * peak of what the process holds. csi_buffer_keep_end releases what is left; begin / end nest.
 * Thread-safe; the bytes kept are not live (csi_device_bytes_live). */
#ifndef CSI_BUFFER_KEEP_H
#define CSI_BUFFER_KEEP_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/runtime.h"

#ifdef __cplusplus
extern "C" {
#endif

/* glibc's largest mmap threshold: smaller blocks come from its heap, which the programs keep
 * (host/cli/common_heap.c); larger ones are fresh mappings each time. */
#define CSI_BUFFER_KEEP_MIN ((size_t)32 << 20)

void csi_buffer_keep_begin(csi_ctx *ctx);
void csi_buffer_keep_end(csi_ctx *ctx);

/* For csi_buffer and csi_buffer_release (runtime.c). csi_buffer_keep_take: a kept buffer of
 * `bytes` and `flags` on `context` into *out (true), or false after releasing kept ones down to
 * the bound above for a new buffer of `bytes`. csi_buffer_keep_put: true when m (its size
 * `bytes`) is now kept rather than to be released. */
bool csi_buffer_keep_take(cl_context context, size_t bytes, cl_mem_flags flags, cl_mem *out);
bool csi_buffer_keep_put(cl_mem m, size_t bytes);

#ifdef __cplusplus
}
#endif
#endif
