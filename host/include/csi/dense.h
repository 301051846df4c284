/* A dense matrix as an operator: for small problems (k up to a few thousand) and tests.
 *
 * apply: y = A x (rows outputs), adjoint: x = A^H y (cols outputs). The matrix is copied to
 * the device twice (A and A^H, both row-major) so each direction reads contiguous rows. */
#ifndef CSI_DENSE_H
#define CSI_DENSE_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/linop.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A_rowmajor: rows x cols floats (real) or rows x cols interleaved complex pairs (2 rows cols
 * floats) when complex_valued. Copied; the caller keeps its array. Errors: zero or oversized
 * dimensions (CSI_ERR_ARG), a NaN or Inf entry (CSI_ERR_ARG naming its row and column). */
csi_status csi_dense_create(csi_ctx *ctx, size_t rows, size_t cols, const float *A_rowmajor,
                            bool complex_valued, csi_linop **out);

#ifdef __cplusplus
}
#endif
#endif
