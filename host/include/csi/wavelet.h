/* The 2-D orthonormal Daubechies wavelet transform as an operator (Psi in A = S Phi^-1 Psi).
 *
 * Periodized, multi-level, separable, computed with the filters (not lifting) in
 * kernels/wavelet.cl. The coefficient vector uses the layout of PyWavelets'
 *     pywt.coeffs_to_array(pywt.wavedec2(img, "db4", mode="periodization", level=levels))
 * flattened row-major: the approximation (coarsest scaling) block of (w >> levels) x
 * (h >> levels) at the top left, then at each level l (coarsest first) the detail blocks of size
 * (w >> l) x (h >> l): horizontal-detail ('da', low-pass along x, high-pass along y) below the
 * approximation, vertical-detail ('ad') to its right, diagonal ('dd') diagonally. Images are
 * row-major too (index y * w + x). */
#ifndef CSI_WAVELET_H
#define CSI_WAVELET_H

#include <stddef.h>

#include "csi/linop.h"
#include "csi/runtime.h"
#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* PyWavelets names: 'db4' has 8 taps (4 vanishing moments), 'db8' has 16 taps. */
typedef enum { CSI_WAVELET_DB4 = 4, CSI_WAVELET_DB8 = 8 } csi_wavelet_family;

/* "db4" / "db8"; "?" for a value outside the enum. */
const char *csi_wavelet_name(csi_wavelet_family f);

/* Parses "db4" or "db8" (exactly, lower case as PyWavelets writes them). Anything else (NULL,
 * "db6", "DB4") is CSI_ERR_ARG with a message naming the string and the accepted names. */
csi_status csi_wavelet_parse(const char *s, csi_wavelet_family *out);

/* Filter length of a family (8 or 16), 0 for a value outside the enum. */
int csi_wavelet_taps(csi_wavelet_family f);

/* The family's decomposition low-pass filter (PyWavelets' dec_lo, csi_wavelet_taps(f) values),
 * as kernels/wavelet.cl uses it; NULL for a value outside the enum. */
const double *csi_wavelet_lowpass(csi_wavelet_family f);

/* The default number of levels for a w x h image, by this rule:
 *   L = min(floor(log2(min(w, h) / (taps - 1))), t)
 * where the first term is PyWavelets' dwt_max_level (the deepest level at which the coarsest band
 * is still at least as long as the filter less one, so no band is all boundary) and t is the
 * number of factors of two common to w and h (every level halves both sides exactly). If that is
 * below 1 but w and h are both even, 1 (one level is always possible on even sides, the taps just
 * wrap around). Returns 0 when no level is possible (w or h odd or zero): csi_wavelet_create
 * would refuse the size. */
int csi_wavelet_default_levels(csi_wavelet_family f, size_t w, size_t h);

/* A real operator with rows = cols = w * h.
 *   apply   (x = coefficients -> y = image): synthesis Psi, the inverse DWT.
 *   adjoint (y = image -> x = coefficients): analysis Psi^T, the forward DWT.
 * Orthonormal, so Psi^T Psi = Psi Psi^T = I up to float rounding. Input buffers are not modified,
 * except that both may also run in place (x == y), which gives the same bits as out of place;
 * one scratch image buffer is allocated here and reused. Work is enqueued on ctx's queue; the
 * calls return without waiting for it. Float32 rounding: relative L2 error ~1e-7 against
 * PyWavelets in double (tests/unit/test_wavelet.c). Errors: CSI_ERR_ARG (message naming the
 * size and level count) when levels < 1, w or h is zero, or w or h is not divisible by 2^levels,
 * or w * h exceeds 32-bit indexing; CSI_ERR_DEVICE when the buffers exceed the device's limits;
 * CSI_ERR_BUILD / CSI_ERR_CL from the OpenCL runtime. */
csi_status csi_wavelet_create(csi_ctx *ctx, csi_wavelet_family f, size_t w, size_t h, int levels,
                              csi_linop **out);

/* Size of the approximation (coarsest scaling) block: the top-left cw x ch of the coefficient
 * array, cw = w >> levels, ch = h >> levels. op must come from csi_wavelet_create. */
/* The device buffers csi_wavelet_create allocates for a w x h image (csi/runtime.h's tally). */
void csi_wavelet_buffers(size_t w, size_t h, csi_mem_tally *t);

void csi_wavelet_coarse_block(const csi_linop *op, size_t *cw, size_t *ch);

/* The family and level count op was made with. op must come from csi_wavelet_create. */
csi_wavelet_family csi_wavelet_family_of(const csi_linop *op);
int csi_wavelet_levels(const csi_linop *op);

#ifdef __cplusplus
}
#endif
#endif
