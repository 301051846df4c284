/* The sampling operator S: N point samples of a k-element signal on the fine grid.
 *
 * apply (k -> N):   y_i = f[idx_i]                 (gather)
 * adjoint (N -> k): f = S^T y, f[idx_i] = y_i, zero elsewhere (scatter)
 * so S S^T = I_N and S^T S is the diagonal projector onto the sampled positions. */
#ifndef CSI_SAMPLING_H
#define CSI_SAMPLING_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/linop.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Makes S for a signal of k elements sampled at indices[0..n-1] (copied to the device; the
 * caller keeps its array). complex_valued: both sides hold interleaved complex pairs.
 * Errors (CSI_ERR_ARG): k = 0, k or n beyond 2^32 - 1, an index >= k, or an index that
 * repeats an earlier one; the message names the first offending record (its position in
 * `indices` and its value). Callers average duplicate samples before making S. */
csi_status csi_sampling_create(csi_ctx *ctx, size_t k, const uint32_t *indices, size_t n,
                               bool complex_valued, csi_linop **out);

/* The device buffers csi_sampling_create allocates for n samples (csi/runtime.h's tally). */
void csi_sampling_buffers(size_t n, csi_mem_tally *t);

#ifdef __cplusplus
}
#endif
#endif
