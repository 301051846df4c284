/* Alg. 1's image model on a coarser grid: the choice of D and the model grid's filter (see
 * csi/model_grid.h). */
#include "csi/model_grid.h"

#include <complex.h>
#include <math.h>
#include <stdlib.h>

#include "csi/interp.h"
#include "csi/spectral.h"

#define PI_ 3.14159265358979323846

unsigned csi_model_grid_factor(size_t w, size_t h, const double sigma[2], int levels, double sigma_min)
{
    unsigned D = 1;
    for (;;) {
        unsigned next = 2 * D;
        if (levels - 1 < 1 || next > (1u << (levels - 1)))
            break;
        if (!(sigma[0] / next >= sigma_min && sigma[1] / next >= sigma_min))
            break;
        if (w % next || h % next || (w / next) % 2 || w / next < 4 || h / next < 2)
            break;
        D = next;
    }
    return D;
}

/* One axis of the factor: fine length N = D m; for the model frequency v (signed, |v| < m / 2;
 * the Nyquist bin gets 0, see csi_filter_create_factor),
 *   H_D(v) Dir_B(v) / (D phi^(v / m))
 * with H_D(v) = prod over l < d of H(v; N / 2^l), H(v; n) = sum_j lo[j] exp(-2 pi i v (F/2 - j) / n)
 * the response of one synthesis level with zero details onto n samples (the transpose of
 * kernels/wavelet.cl's analysis a[o] = sum_j lo[j] x[2o + F/2 - j]), and Dir_B(v) =
 * (1/B) sum_{q < B} exp(2 pi i v q / N) the mean over B fine cells from the point read. */
static double complex axis_factor(long v, size_t m, unsigned D, const double *lo, int F, unsigned B)
{
    const double N = (double)m * D;
    double complex h = 1.0;
    for (unsigned n = (unsigned)N; n > m; n /= 2) {
        double complex s = 0.0;
        for (int j = 0; j < F; j++)
            s += lo[j] * cexp(-2.0 * PI_ * I * (double)v * (double)(F / 2 - j) / (double)n);
        h *= s;
    }
    double complex dir = 0.0;
    for (unsigned q = 0; q < B; q++)
        dir += cexp(2.0 * PI_ * I * (double)v * (double)q / N);
    dir /= (double)B;
    return h * dir / ((double)D * csi_interp_kernel_ft((double)v / (double)m));
}

void csi_model_filter_buffers(size_t mw, size_t mh, csi_mem_tally *t)
{
    const size_t dims[3] = {mw, mh, 1};
    csi_filter_factor_buffers(dims, t);
}

csi_status csi_model_filter_create(csi_ctx *ctx, size_t mw, size_t mh, unsigned D,
                                   const double sigma[2], float lambda, csi_wavelet_family f,
                                   unsigned box_x, unsigned box_y, csi_linop **out)
{
    *out = NULL;
    const double *lo = csi_wavelet_lowpass(f);
    const int F = csi_wavelet_taps(f);
    if (!lo || D == 0 || (D & (D - 1)) || box_x == 0 || box_y == 0 || mw % 2 || mw < 4 || mh < 2)
        return csi_fail(CSI_ERR_ARG, "model grid filter: model grid %zu x %zu, D = %u, box %u x %u: "
                        "need an even width >= 4, D a power of two and a box of at least one cell",
                        mw, mh, D, box_x, box_y);
    double *fx = malloc(2 * (mw / 2 + 1) * sizeof *fx), *fy = malloc(2 * mh * sizeof *fy);
    if (!fx || !fy) {
        free(fx);
        free(fy);
        return csi_fail(CSI_ERR_NOMEM, "model grid filter: out of host memory");
    }
    for (size_t k = 0; k <= mw / 2; k++) {
        double complex z = k == mw / 2 ? 0.0 : axis_factor((long)k, mw, D, lo, F, box_x);
        fx[2 * k] = creal(z);
        fx[2 * k + 1] = cimag(z);
    }
    for (size_t k = 0; k < mh; k++) {
        long v = k < (mh + 1) / 2 ? (long)k : (long)k - (long)mh;
        double complex z = (mh % 2 == 0 && k == mh / 2) ? 0.0 : axis_factor(v, mh, D, lo, F, box_y);
        fy[2 * k] = creal(z);
        fy[2 * k + 1] = cimag(z);
    }
    const size_t dims[3] = {mw, mh, 1};
    const double sm[3] = {sigma[0] / D, sigma[1] / D, 0.0};
    csi_status st = csi_filter_create_factor(ctx, dims, sm, CSI_FILTER_WIENER, lambda, fx, fy, out);
    free(fx);
    free(fy);
    return st;
}
