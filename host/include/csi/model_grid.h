/* Alg. 1's image model on a grid D times coarser than the sample grid.
 *
 * The model is f = Phi^-1 Psi x on the fine grid of the samples (csi/spectral.h: the Wiener
 * inverse Phi^-1 of a Gaussian of width sigma fine cells). When sigma is wide, Phi^-1 leaves
 * nothing above a fraction of the fine grid's Nyquist frequency: the finest wavelet levels of
 * Psi then have no effect on f (their columns of A vanish, and SpaRSA never selects them), and f
 * itself is a band-limited function that a grid D times coarser represents exactly. With those
 * levels left out, Psi x = U^d Psi_m x_m (D = 2^d, Psi_m the same wavelet on the model grid with
 * d levels fewer, U one level of synthesis with zero details), and
 *     f(p) = (Phi^-1 U^d g)(p),  g = Psi_m x_m,
 * which csi evaluates without the fine grid: a filter on the model grid with gain
 *     Phi^-1(v) H_D(v_x) H_D(v_y) / (D phi^(v_x / mw) D phi^(v_y / mh))
 * (H_D the frequency response of U^d, phi^ the interpolation kernel's transform), then the
 * interpolation of csi/interp.h at the samples' fine positions (a non-uniform FFT). The box mean
 * of f over each output pixel is the same with the gain also multiplied by the pixel's Dirichlet
 * kernel and read at the pixels' first fine cells.
 *
 * Accuracy: the interpolation's aliasing plus the spectrum left out above the model grid's
 * Nyquist frequency, both set by sigma / D. At sigma / D >= CSI_MODEL_SIGMA_MIN the operator
 * matches the fine-grid one to < 5e-5 relative on white noise and ~5e-6 on images
 * (tests/data/interp/gen_refs.py measures it; tests/unit/test_model_grid.c checks it). */
#ifndef CSI_MODEL_GRID_H
#define CSI_MODEL_GRID_H

#include <stddef.h>

#include "csi/linop.h"
#include "csi/wavelet.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The smallest Gaussian width on the model grid (in model cells) at which the model grid is
 * exact to the accuracy above: at 1.5 cells the Wiener gain at the model grid's Nyquist
 * frequency is 6.5e-5 of its value at 0 (exp(-2 pi^2 1.5^2 / 4) = 1.5e-5 for the Gaussian); at
 * 1.1 cells the error was already 2e-3 on white noise. */
#define CSI_MODEL_SIGMA_MIN 1.5

/* The coarsening D (a power of two, >= 1) for a w x h fine grid with Gaussian widths sigma[0],
 * sigma[1] (fine cells) and a wavelet of `levels` levels: the largest D with sigma / D >=
 * sigma_min on both axes, at most 2^(levels - 1) (the model grid keeps at least one level), D
 * dividing w and h, and w / D even (csi's real FFT). 1 means: use the fine grid. sigma_min =
 * CSI_MODEL_SIGMA_MIN gives the accuracy above (the default); below it the model grid is a
 * band-limited model of the image rather than the fine grid's operator (0.75 at 4 spp on an 8x
 * grid: D = 4 instead of 2, a third of the CPU, the MSE -5.6%..+3.4% of the exact grid's on 54
 * dumps; docs/bench/cost.md). */
unsigned csi_model_grid_factor(size_t w, size_t h, const double sigma[2], int levels, double sigma_min);

/* The model grid's filter above for a model grid of mw x mh cells (fine grid mw D x mh D),
 * Gaussian widths sigma (fine cells), Wiener regularisation lambda, wavelet family f (whose low
 * pass defines U). box_x, box_y >= 1: the box mean over box_x x box_y fine cells starting at the
 * point read (1, 1: f itself). A real operator on mw mh floats; apply and adjoint (the
 * transposed convolution) on csi's FFT kernels. */
csi_status csi_model_filter_create(csi_ctx *ctx, size_t mw, size_t mh, unsigned D,
                                   const double sigma[2], float lambda, csi_wavelet_family f,
                                   unsigned box_x, unsigned box_y, csi_linop **out);
/* The device buffers csi_model_filter_create allocates (csi/runtime.h's tally). */
void csi_model_filter_buffers(size_t mw, size_t mh, csi_mem_tally *t);

#ifdef __cplusplus
}
#endif
#endif
