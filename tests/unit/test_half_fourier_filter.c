/* Alg. 1's filter in Alg. 2's operator (csi_half_fourier_set_filter: A = S H D) under PoCL.
 *
 * The reference is the closed form of D, computed here in double from its definition and not
 * from the library's gain function: the Wiener inverse (1 + lambda) G / (G^2 + lambda) of the
 * Gaussian G = exp(-2 pi^2 sigma^2 (fx^2 + fy^2)), fx = u / w (u = 0 .. w/2 along the half axis)
 * and fy the signed frequency of row v (numpy's fftfreq), the same for every temporal
 * coefficient. The unfiltered basis H is checked against numpy / scipy by test_motion_basis.c,
 * so H D z against H (D z) checks the filtered synthesis against that chain: the gain, its
 * layout (per column u, row v, repeated over t), with a sheared DCT time stage and with the plain
 * DFT. Then the sampled operator (apply is S H D z, the adjoint identity with A^T = D H^T S^T)
 * and bad input.
 *
 * Tolerances: one float32 synthesis has relative L2 error ~ 2e-5 against double (test_fourier.c's
 * bound); D z is one float product per coefficient (eps), and both sides round the gain to float:
 * 2e-5 relative. The adjoint identity compares double sums of float products: 1e-5. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "csi/sampled_half_fourier.h"
#include "csi/spectral.h"
#include "testlib.h"

#define PI_ 3.14159265358979323846

/* D at column u, row v of a w x h frame, from its definition. */
static double gain_ref(size_t w, size_t h, size_t u, size_t v, double sigma, double lambda)
{
    const double fx = (double)u / (double)w;
    const double fy = (v < (h + 1) / 2 ? (double)v : (double)v - (double)h) / (double)h;
    const double g = exp(-2.0 * PI_ * PI_ * sigma * sigma * (fx * fx + fy * fy));
    return (1.0 + lambda) * g / (g * g + lambda);
}

/* Relative L2 distance between op(A, a) and op(A0, b), outputs of `floats` floats. */
static double both(csi_status (*op)(const csi_linop *, cl_mem, cl_mem), const csi_linop *A,
                   const csi_linop *A0, cl_mem a, cl_mem b, size_t floats)
{
    cl_mem o = test_alloc(floats * 4), o0 = test_alloc(floats * 4);
    float *h = malloc(floats * 4), *h0 = malloc(floats * 4);
    CHECK(op(A, a, o) == CSI_OK && op(A0, b, o0) == CSI_OK, "both operators run");
    test_download(o, h, floats * 4);
    test_download(o0, h0, floats * 4);
    const double e = test_rel_l2(h, h0, floats);
    csi_buffer_release(&o);
    csi_buffer_release(&o0);
    free(h);
    free(h0);
    return e;
}

static void check_case(csi_ctx *ctx, const size_t dims[3], csi_time_transform t, double vx, double vy,
                       double sigma, double lambda)
{
    const size_t w = dims[0], h = dims[1], T = dims[2], k = w * h * T, M = w / 2;
    /* samples: every third cell */
    size_t n = 0;
    uint32_t *idx = malloc(k * sizeof *idx);
    for (size_t i = 0; i < k; i += 3)
        idx[n++] = (uint32_t)i;
    csi_linop *A = NULL, *A0 = NULL;
    CHECK_OK(csi_half_fourier_sampling_create(ctx, dims, idx, n, &A));
    CHECK_OK(csi_half_fourier_sampling_create(ctx, dims, idx, n, &A0));
    if (!A || !A0) {
        free(idx);
        return;
    }
    CHECK_OK(csi_fourier_half_set_motion(csi_half_fourier_basis(A), dims, t, vx, vy));
    CHECK_OK(csi_fourier_half_set_motion(csi_half_fourier_basis(A0), dims, t, vx, vy));
    CHECK_OK(csi_half_fourier_set_filter(A, sigma, lambda));
    const size_t hs = csi_fourier_half_stride(csi_half_fourier_basis(A)), nz = A->cols;
    CHECK(nz == hs * h * T && A0->cols == nz, "%zux%zux%zu: %zu coefficients", w, h, T, nz);

    /* random coefficients (zero padding), and D z from the closed form */
    test_rng r;
    test_rng_seed(&r, 12 + w + T);
    float *hy = malloc(n * 8), *hy0 = malloc(n * 8);
    float *z = calloc(2 * nz, sizeof *z), *dz = calloc(2 * nz, sizeof *dz);
    double dmin = 1e300, dmax = 0;
    for (size_t row = 0; row < h * T; row++)
        for (size_t u = 0; u <= M; u++) {
            const size_t i = row * hs + u;
            const double d = gain_ref(w, h, u, row % h, sigma, lambda);
            dmin = fmin(dmin, d);
            dmax = fmax(dmax, d);
            z[2 * i] = (float)test_rng_normal(&r);
            z[2 * i + 1] = (float)test_rng_normal(&r);
            dz[2 * i] = (float)(d * z[2 * i]);
            dz[2 * i + 1] = (float)(d * z[2 * i + 1]);
        }
    cl_mem bz = test_upload(z, nz * 8), bdz = test_upload(dz, nz * 8);

    /* the filtered synthesis H D z against the plain synthesis of the closed-form D z */
    const double es = both(csi_half_fourier_synthesize, A, A0, bz, bdz, k);
    CHECK(es < 2e-5, "%zux%zux%zu t=%d v=(%g,%g) sigma %g: H D z vs H (D z) rel L2 %.3g", w, h, T, (int)t,
          vx, vy, sigma, es);
    /* the filter is not the identity here (else the check above says nothing) */
    CHECK(dmax - dmin > 0.3, "sigma %g: gains from %.3g to %.3g", sigma, dmin, dmax);

    /* apply = S H D z: the plain operator's apply of D z, the same samples */
    const double ea = both(csi_linop_apply, A, A0, bz, bdz, 2 * n);
    CHECK(ea < 2e-5, "%zux%zux%zu: S H D z vs S H (D z) rel L2 %.3g", w, h, T, ea);

    /* adjoint identity: <A z, y> = Re <z, A^T y> for real samples y (zero imaginary parts) */
    for (size_t i = 0; i < n; i++) {
        hy[2 * i] = (float)test_rng_normal(&r);
        hy[2 * i + 1] = 0.0f;
    }
    cl_mem y = test_alloc(n * 8), yr = test_upload(hy, n * 8), zt = test_alloc(nz * 8);
    float *hzt = malloc(nz * 8);
    CHECK_OK(csi_linop_adjoint(A, yr, zt));
    test_download(zt, hzt, nz * 8);
    double lhs = 0, rhs = 0, na = 0, nb = 0;
    CHECK_OK(csi_linop_apply(A, bz, y));
    test_download(y, hy0, n * 8);
    for (size_t i = 0; i < n; i++) {
        lhs += (double)hy0[2 * i] * hy[2 * i];
        nb += (double)hy[2 * i] * hy[2 * i];
    }
    for (size_t i = 0; i < 2 * nz; i++) {
        rhs += (double)z[i] * hzt[i];
        na += (double)z[i] * z[i];
    }
    CHECK(fabs(lhs - rhs) <= 1e-5 * sqrt(na * nb), "%zux%zux%zu adjoint identity: %.9g vs %.9g", w, h, T,
          lhs, rhs);
    printf("%zux%zux%zu t=%d sigma %g: synthesis %.2e apply %.2e adjoint gap %.2e (gains %.3g..%.3g)\n", w, h,
           T, (int)t, sigma, es, ea, fabs(lhs - rhs) / sqrt(na * nb), dmin, dmax);

    /* bad input: no filter of width <= 0 or with lambda <= 0 */
    CHECK(csi_half_fourier_set_filter(A, 0.0, lambda) == CSI_ERR_ARG, "width 0 refused");
    CHECK(csi_half_fourier_set_filter(A, sigma, 0.0) == CSI_ERR_ARG, "lambda 0 refused");
    CHECK(csi_half_fourier_set_filter(A, NAN, lambda) == CSI_ERR_ARG, "width NaN refused");

    csi_buffer_release(&bz);
    csi_buffer_release(&bdz);
    csi_buffer_release(&y);
    csi_buffer_release(&yr);
    csi_buffer_release(&zt);
    free(z);
    free(dz);
    free(hy);
    free(hy0);
    free(hzt);
    free(idx);
    csi_linop_free(A);
    csi_linop_free(A0);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    const size_t a[3] = {16, 12, 8}, b[3] = {24, 10, 6};
    check_case(ctx, a, CSI_TIME_DFT, 0.0, 0.0, 1.1, 0.3);
    check_case(ctx, a, CSI_TIME_DCT, 0.7, -0.3, 0.8, 0.3);
    check_case(ctx, b, CSI_TIME_DCT, -1.2, 0.4, 1.5, 0.05);
    return test_done();
}
