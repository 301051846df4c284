/* Interpolation of a band-limited image held on a model grid at point samples on a D-times finer
 * grid: the gridding step of a non-uniform FFT (Dutt & Rokhlin 1993; the "exponential of
 * semicircle" kernel of Barnett, Magland & af Klinteberg, SIAM J. Sci. Comput. 41(5), 2019).
 *
 * With f(t) = sum_j c[j] phi(t - j) (per axis, t in model cells, the model grid periodic), a
 * sample at fine cell p = (px, py) reads f at t = p / D. phi has support |z| < CSI_INTERP_TAPS / 2,
 * so each sample reads CSI_INTERP_TAPS^2 model cells. If c = IDFT(F / (phi^ x phi^)) for a
 * spectrum F on the model grid's frequencies, f(t) equals the band-limited function with spectrum
 * F up to the kernel's aliasing error (for the images of Alg. 1 about 1e-5 relative when F falls
 * to 1e-4 of its peak at 0.7 of the model grid's Nyquist frequency: host/ops/model_grid.c).
 *
 * apply (mw mh -> n): y_i = f(p_i / D) (gather)
 * adjoint (n -> mw mh): c = sum_i r_i phi(p_i / D - j) (spread; deterministic: the same bits on
 * every run, summed in a fixed order without atomics). */
#ifndef CSI_INTERP_H
#define CSI_INTERP_H

#include <stddef.h>
#include <stdint.h>

#include "csi/linop.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Kernel width in model cells (taps per axis); must match kernels/interp.cl. */
#define CSI_INTERP_TAPS 6

/* phi(z) = exp(beta (sqrt(1 - (2z / w)^2) - 1)) for |z| < w / 2, else 0 (w = CSI_INTERP_TAPS). */
double csi_interp_kernel(double z);
/* Its Fourier transform phi^(xi) = integral phi(z) exp(-2 pi i xi z) dz (real: phi is even), xi
 * in cycles per model cell; computed by Gauss-Legendre quadrature to ~1e-12 relative. */
double csi_interp_kernel_ft(double xi);

/* The operator for a model grid of mw x mh cells and n samples at fine-grid indices idx
 * (y * mw D + x on the fine grid of mw D x mh D cells; the caller keeps its array; repeats are
 * allowed). D >= 1 and at most 64; idx < mw mh D^2. Errors: CSI_ERR_ARG naming the first bad
 * index or size. Device memory: 12 bytes per sample plus the tile lists. */
csi_status csi_interp_create(csi_ctx *ctx, size_t mw, size_t mh, unsigned D, const uint32_t *idx,
                             size_t n, csi_linop **out);
/* The device buffers csi_interp_create allocates (csi/runtime.h's tally). */
void csi_interp_buffers(size_t mw, size_t mh, unsigned D, size_t n, csi_mem_tally *t);

#ifdef __cplusplus
}
#endif
#endif
