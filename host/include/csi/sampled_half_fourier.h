/* A = S H for Alg. 2 on the half spectrum (csi_fourier_half): z (the half spectrum, complex)
 * -> f = H z (real volume) -> the samples f[idx_i], returned as complex values with zero
 * imaginary parts so that the complex solver sees measurements y + 0i. The adjoint takes the
 * real parts of its input (the imaginary parts of y - A z are zero), scatters them and applies
 * H^T (the real-to-complex transform), which is H's adjoint for the real inner products SpaRSA
 * uses (Re <a, b> everywhere: its steps, objective and tests). Complex-linearity is never used by
 * SpaRSA, so a real-linear operator is enough. */
#ifndef CSI_SAMPLED_HALF_FOURIER_H
#define CSI_SAMPLED_HALF_FOURIER_H

#include <stddef.h>
#include <stdint.h>

#include "csi/linop.h"
#include "csi/spectral.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The operator for a dims[0] x dims[1] x dims[2] real volume sampled at idx[0..n-1] (distinct,
 * < the volume's size; copied). rows = n, cols = csi_fourier_half_count. CSI_ERR_ARG with no
 * operator made when the size has no half spectrum (an odd first axis). */
csi_status csi_half_fourier_sampling_create(csi_ctx *ctx, const size_t dims[3], const uint32_t *idx,
                                            size_t n, csi_linop **out);
/* The device buffers csi_half_fourier_sampling_create allocates (csi/runtime.h's tally), for a
 * size csi_fourier_half_supported accepts. */
void csi_half_fourier_sampling_buffers(const size_t dims[3], size_t n, csi_mem_tally *t);
/* Alg. 1's model in Alg. 2 (csi_recon_options.motion_filter): the operator becomes S H D, D the
 * real diagonal gain of the Wiener inverse of a Gaussian of width sigma (cells) along x and y,
 * (1 + lambda) G / (G^2 + lambda) per spatial frequency (u, v), the same for every temporal
 * coefficient and velocity (the shear and the time stage act along t only). z is then the
 * spectrum of the blurred volume Phi f, which is sparser than f's; H D z is the sharp estimate.
 * D's DC gain is 1, so ||A^T y||_inf's DC term and the tau rule are unchanged. Allocates the
 * gains and a coefficient-sized scratch (csi_half_fourier_filter_buffers). */
csi_status csi_half_fourier_set_filter(csi_linop *op, double sigma, double lambda);
/* The weighted l1 of a time-constant layer (csi_recon_options.motion_still_weight, which is
 * 1 / g0): the operator becomes S H D G, G = g0 on the plane u2 = 0 (the coefficients constant
 * along t in the basis's frame: the still content, or with a velocity what moves at it) and 1
 * elsewhere. An l1 penalty on z' with z = G z' is the l1 of z weighted 1 / g0 on that plane (a
 * column scaling), so g0 > 1 thresholds that layer less than the rest. Without a filter, D = 1
 * is set (its buffers are the filter's, csi_half_fourier_filter_reserve). g0 = 1 leaves the
 * operator as it was, to the bit. A filter set later keeps g0. */
csi_status csi_half_fourier_set_still_gain(csi_linop *op, double g0);
/* Allocates what csi_half_fourier_set_filter needs without setting a filter (for a caller that
 * decides later whether to, with its device memory planned either way). */
csi_status csi_half_fourier_filter_reserve(csi_linop *op);
void csi_half_fourier_filter_buffers(const size_t dims[3], csi_mem_tally *t);
/* D's gain at half-spectrum column u (0..w/2) and row v (0..h-1) of a w x h frame, in double. */
double csi_half_fourier_filter_gain(size_t w, size_t h, size_t u, size_t v, double sigma, double lambda);
/* f = H z (H D z with a filter): the real volume (k floats) of half-spectrum coefficients z, without sampling. */
csi_status csi_half_fourier_synthesize(const csi_linop *op, cl_mem z, cl_mem f);
/* The operator's own k-float volume buffer, which the caller may use as scratch between
 * applications (its contents are overwritten by the next apply or adjoint). */
cl_mem csi_half_fourier_scratch(const csi_linop *op);
/* The operator's basis H, e.g. to give it a time stage (csi_fourier_half_set_motion), which the
 * operator then applies too. Owned by the operator. */
csi_fourier_half *csi_half_fourier_basis(const csi_linop *op);
/* Its real sampling operator S (k floats -> the n samples), owned by the operator. */
const csi_linop *csi_half_fourier_sampler(const csi_linop *op);

#ifdef __cplusplus
}
#endif
#endif
