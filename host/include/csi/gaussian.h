/* The Gaussian filter Phi of Alg. 1 (Sen & Darabi 2010, Sec. 5.1): its width and its frequency
 * response. No OpenCL: the operators that apply it are in csi/spectral.h. */
#ifndef CSI_GAUSSIAN_H
#define CSI_GAUSSIAN_H

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The paper's Alg. 1 step 2 for one axis: sigma_phi = 1.1 * (1/4) * (grid / out) (grid cells)
 * and sigma_g_for_n = grid / (2 pi sigma_phi) (DFT-index units for an axis of `grid` samples).
 * grid = 0 or out = 0 gives 0 for both (no filtering). Either output pointer may be NULL. */
void csi_gauss_sigmas(size_t grid, size_t out, double *sigma_phi, double *sigma_g_for_n);

/* Frequency response of one axis: exp(-u^2 / (2 sigma_G^2)) with sigma_G = n / (2 pi sigma_phi)
 * and u the signed frequency index of DFT bin `k` (k < n/2 ... -> k, else k - n). sigma_phi = 0
 * gives 1 (no filtering along the axis). Exposed for tests and for callers that want G. */
double csi_gauss_gain_1d(size_t n, size_t k, double sigma_phi);

#ifdef __cplusplus
}
#endif
#endif
