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
 * and bad input. The still plane's gain (check_still) the same way, against D W z from the closed
 * form.
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

/* Two operators on the same samples (every third cell) with the same basis (time stage t,
 * velocity vx, vy): A to be given a gain, A0 the plain one. */
typedef struct {
    uint32_t *idx;
    size_t n;
    csi_linop *A, *A0;
} op_pair;

/* False (nothing left) on a failure. */
static bool make_pair(csi_ctx *ctx, const size_t dims[3], csi_time_transform t, double vx, double vy, op_pair *p)
{
    const size_t k = dims[0] * dims[1] * dims[2];
    p->n = 0;
    p->A = p->A0 = NULL;
    p->idx = malloc(k * sizeof *p->idx);
    for (size_t i = 0; i < k; i += 3)
        p->idx[p->n++] = (uint32_t)i;
    CHECK_OK(csi_half_fourier_sampling_create(ctx, dims, p->idx, p->n, &p->A));
    CHECK_OK(csi_half_fourier_sampling_create(ctx, dims, p->idx, p->n, &p->A0));
    if (!p->A || !p->A0) {
        csi_linop_free(p->A);
        csi_linop_free(p->A0);
        free(p->idx);
        return false;
    }
    CHECK_OK(csi_fourier_half_set_motion(csi_half_fourier_basis(p->A), dims, t, vx, vy));
    CHECK_OK(csi_fourier_half_set_motion(csi_half_fourier_basis(p->A0), dims, t, vx, vy));
    return true;
}

static void check_case(csi_ctx *ctx, const size_t dims[3], csi_time_transform t, double vx, double vy,
                       double sigma, double lambda)
{
    op_pair p;
    if (!make_pair(ctx, dims, t, vx, vy, &p))
        return;
    const size_t w = dims[0], h = dims[1], T = dims[2], k = w * h * T, M = w / 2, n = p.n;
    uint32_t *idx = p.idx;
    csi_linop *A = p.A, *A0 = p.A0;
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

/* The still plane's gain (csi_half_fourier_set_still_gain): S H D W z against S H (D W z) with
 * D W z from the closed form (W = g on the plane u2 = 0, 1 elsewhere), with the filter (sigma > 0)
 * or without it (D = 1); the adjoint against W D H^T S^T y from the plain operator's adjoint,
 * scaled here; g = 1 afterwards gives the operator its bits back; bad gains refused. Same
 * tolerances as above (W is one more float product per coefficient). */
static void check_still(csi_ctx *ctx, const size_t dims[3], csi_time_transform t, double vx, double vy,
                        double sigma, double lambda, double g)
{
    op_pair p;
    if (!make_pair(ctx, dims, t, vx, vy, &p))
        return;
    csi_linop *A = p.A, *A0 = p.A0;
    const size_t n = p.n, w = dims[0], h = dims[1], T = dims[2], k = w * h * T, M = w / 2;
    if (sigma > 0)
        CHECK_OK(csi_half_fourier_set_filter(A, sigma, lambda));
    const size_t hs = csi_fourier_half_stride(csi_half_fourier_basis(A)), nz = A->cols;
    test_rng r;
    test_rng_seed(&r, 77 + w + T);
    float *z = calloc(2 * nz, sizeof *z), *dz = calloc(2 * nz, sizeof *dz);
    for (size_t row = 0; row < h * T; row++)
        for (size_t u = 0; u <= M; u++) {
            const size_t i = row * hs + u;
            const double d = (sigma > 0 ? gain_ref(w, h, u, row % h, sigma, lambda) : 1.0) * (row < h ? g : 1.0);
            z[2 * i] = (float)test_rng_normal(&r);
            z[2 * i + 1] = (float)test_rng_normal(&r);
            dz[2 * i] = (float)(d * z[2 * i]);
            dz[2 * i + 1] = (float)(d * z[2 * i + 1]);
        }
    cl_mem bz = test_upload(z, nz * 8), bdz = test_upload(dz, nz * 8);
    /* the bits with g = 1 before the gain is set, to compare after it is set back */
    float *y1 = malloc(n * 8), *y1b = malloc(n * 8);
    cl_mem y = test_alloc(n * 8);
    CHECK_OK(csi_linop_apply(A, bz, y));
    test_download(y, y1, n * 8);

    CHECK_OK(csi_half_fourier_set_still_gain(A, g));
    const double es = both(csi_half_fourier_synthesize, A, A0, bz, bdz, k);
    const double ea = both(csi_linop_apply, A, A0, bz, bdz, 2 * n);
    CHECK(es < 2e-5 && ea < 2e-5, "%zux%zux%zu t=%d v=(%g,%g) sigma %g g %g: H D W z vs H (D W z) rel L2 %.3g, "
          "S H D W z %.3g", w, h, T, (int)t, vx, vy, sigma, g, es, ea);

    /* adjoint: A^T y = W D H^T S^T y; the plain operator's H^T S^T y scaled here */
    float *hy = malloc(n * 8), *za = malloc(nz * 8), *z0 = malloc(nz * 8);
    for (size_t i = 0; i < n; i++) {
        hy[2 * i] = (float)test_rng_normal(&r);
        hy[2 * i + 1] = 0.0f;
    }
    cl_mem yr = test_upload(hy, n * 8), zt = test_alloc(nz * 8), zt0 = test_alloc(nz * 8);
    CHECK_OK(csi_linop_adjoint(A, yr, zt));
    CHECK_OK(csi_linop_adjoint(A0, yr, zt0));
    test_download(zt, za, nz * 8);
    test_download(zt0, z0, nz * 8);
    for (size_t row = 0; row < h * T; row++)
        for (size_t u = 0; u < hs; u++) {
            const size_t i = row * hs + u;
            const double d = u > M ? 0.0 :
                (sigma > 0 ? gain_ref(w, h, u, row % h, sigma, lambda) : 1.0) * (row < h ? g : 1.0);
            z0[2 * i] = (float)(d * z0[2 * i]);
            z0[2 * i + 1] = (float)(d * z0[2 * i + 1]);
        }
    const double ead = test_rel_l2(za, z0, 2 * nz);
    CHECK(ead < 2e-5, "%zux%zux%zu g %g: A^T y vs W D (H^T S^T y) rel L2 %.3g", w, h, T, g, ead);
    printf("%zux%zux%zu t=%d sigma %g still gain %g: synthesis %.2e apply %.2e adjoint %.2e\n", w, h, T, (int)t,
           sigma, g, es, ea, ead);

    /* g = 1 again: the operator's bits as before */
    CHECK_OK(csi_half_fourier_set_still_gain(A, 1.0));
    CHECK_OK(csi_linop_apply(A, bz, y));
    test_download(y, y1b, n * 8);
    size_t diff = 0;
    for (size_t i = 0; i < 2 * n; i++)
        diff += y1[i] != y1b[i];
    CHECK(diff == 0, "gain 1 again: %zu of %zu sample values differ from before", diff, 2 * n);
    CHECK(csi_half_fourier_set_still_gain(A, 0.0) == CSI_ERR_ARG, "gain 0 refused");
    CHECK(csi_half_fourier_set_still_gain(A, -2.0) == CSI_ERR_ARG, "negative gain refused");
    CHECK(csi_half_fourier_set_still_gain(A, NAN) == CSI_ERR_ARG, "NaN gain refused");

    csi_buffer_release(&bz);
    csi_buffer_release(&bdz);
    csi_buffer_release(&y);
    csi_buffer_release(&yr);
    csi_buffer_release(&zt);
    csi_buffer_release(&zt0);
    free(z);
    free(dz);
    free(y1);
    free(y1b);
    free(hy);
    free(za);
    free(z0);
    free(p.idx);
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
    check_still(ctx, a, CSI_TIME_DFT, 0.0, 0.0, 0.0, 0.3, 2.0);
    check_still(ctx, a, CSI_TIME_DCT, 0.7, -0.3, 0.8, 0.3, 4.0);
    check_still(ctx, b, CSI_TIME_DCT, -1.2, 0.4, 1.5, 0.05, 0.5);
    return test_done();
}
