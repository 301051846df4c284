/* The Gaussian of Alg. 1: its width from the grid and output sizes, and its DFT gain (csi/gaussian.h).
 * Its own module so that the FFT filter (fft_filter.c) and the operators built on it (spectral.c)
 * both use it and depend on each other one way only. */
#include "csi/gaussian.h"

#include <math.h>

/* M_PI is XSI, not C11. */
#define CSI_PI 3.14159265358979323846

void csi_gauss_sigmas(size_t grid, size_t out, double *sigma_phi, double *sigma_g_for_n)
{
    double sp = 0.0, sg = 0.0;
    if (grid > 0 && out > 0) {
        /* Alg. 1 step 2: 2 sigma_Phi spans half the block averaged into one output cell, plus
         * 10%: sigma_Phi = 1.1 * (1/4) * (grid/out); sigma_G = n / (2 pi sigma_Phi). */
        sp = 1.1 * 0.25 * ((double)grid / (double)out);
        sg = (double)grid / (2.0 * CSI_PI * sp);
    }
    if (sigma_phi)
        *sigma_phi = sp;
    if (sigma_g_for_n)
        *sigma_g_for_n = sg;
}

double csi_gauss_gain_1d(size_t n, size_t k, double sigma_phi)
{
    if (sigma_phi <= 0.0 || n == 0)
        return 1.0;
    /* Signed index in [-n/2, n/2): numpy's fftfreq order. */
    double u = (k < (n + 1) / 2) ? (double)k : (double)k - (double)n;
    /* exp(-u^2 / (2 sigma_G^2)) with sigma_G = n / (2 pi sigma_phi)
     * = exp(-2 pi^2 sigma_phi^2 u^2 / n^2). */
    double f = u / (double)n;
    return exp(-2.0 * CSI_PI * CSI_PI * sigma_phi * sigma_phi * f * f);
}
