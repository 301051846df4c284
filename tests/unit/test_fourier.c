/* Orthonormal Fourier basis (csi_fourier_create) under PoCL, on both FFT implementations (csi's
 * own Stockham kernels and clFFT): against np.fft.fftn / ifftn with norm="ortho"
 * (tests/data/spectral/gen_refs.py), unitarity (apply(adjoint(x)) = x, Parseval), the complex adjoint
 * identity <A x, y> = <x, A^H y>, 1-D / 2-D / 3-D, non-square and 3 * 2^n sizes; then native
 * against clFFT on sizes that exercise every radix (2..8, 3, 5, 7), odd lengths, the k-indexed
 * row passes (p >= 8) and squeezed axes of length 1.
 *
 * Tolerances: a float32 FFT of N points has relative L2 error ~ c * eps * log2(N) (Higham,
 * Accuracy and Stability of Numerical Algorithms, Sec. 24.1), eps = 6e-8, log2(8192) = 13: we
 * allow 1e-5 (c ~ 12) for one transform and 2e-5 for a round trip; the references themselves are
 * float64 results rounded to float32 (3e-8 relative). Parseval and the adjoint identity compare
 * double sums of float products: 1e-5 relative. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/spectral.h"
#include "testlib.h"

struct ccase {
    const char *name;
    size_t dims[3];
};

static const struct ccase cases[] = {
    {"c64x64", {64, 64, 1}},   {"c96x64", {96, 64, 1}},     {"c30x18", {30, 18, 1}},
    {"c24x16x8", {24, 16, 8}}, {"c32x32x8", {32, 32, 8}}, {"c60", {60, 1, 1}},
};

/* out = op(x) or op^H(x) for n complex values; checks the input buffer is unchanged. */
static void run(const csi_linop *op, const float *x, float *out, bool adjoint)
{
    size_t bytes = op->cols * 8;
    cl_mem dx = test_upload(x, bytes), dy = test_alloc(bytes);
    csi_status st = adjoint ? csi_linop_adjoint(op, dx, dy) : csi_linop_apply(op, dx, dy);
    CHECK(st == CSI_OK, "%s: %s", op->name, csi_last_error());
    test_download(dy, out, bytes);
    float *back = malloc(bytes);
    test_download(dx, back, bytes);
    CHECK(memcmp(back, x, bytes) == 0, "%s %s left its input unchanged", op->name,
          adjoint ? "adjoint" : "apply");
    free(back);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
}

/* Complex inner product <a, b> = sum conj(a_i) b_i, in double. */
static void cdot(const float *a, const float *b, size_t n, double *re, double *im)
{
    double r = 0, i = 0;
    for (size_t k = 0; k < n; k++) {
        double ar = a[2 * k], ai = a[2 * k + 1], br = b[2 * k], bi = b[2 * k + 1];
        r += ar * br + ai * bi;
        i += ar * bi - ai * br;
    }
    *re = r;
    *im = i;
}

static double cnorm(const float *a, size_t n)
{
    double r, i;
    cdot(a, a, n, &r, &i);
    return sqrt(r);
}

static const csi_fft_backend backends[2] = {CSI_FFT_NATIVE, CSI_FFT_CLFFT};
static const char *backend_names[2] = {"native", "clFFT"};

/* Native vs clFFT on random complex data, both directions. Both are float32 FFTs with error
 * ~ c eps log2(N) against the exact DFT (see above), so they differ by at most twice the
 * single-transform bound: 2e-5. */
static void cross_check(csi_ctx *ctx, const size_t dims[3], unsigned seed)
{
    size_t n = dims[0] * dims[1] * dims[2];
    csi_linop *Fn = NULL, *Fc = NULL;
    CHECK_OK(csi_fourier_create_backend(ctx, dims, CSI_FFT_NATIVE, &Fn));
    CHECK_OK(csi_fourier_create_backend(ctx, dims, CSI_FFT_CLFFT, &Fc));
    if (Fn && Fc) {
        test_rng r;
        test_rng_seed(&r, seed);
        float *x = malloc(2 * n * sizeof *x), *a = malloc(2 * n * sizeof *a),
              *b = malloc(2 * n * sizeof *b);
        for (size_t k = 0; k < 2 * n; k++)
            x[k] = (float)test_rng_normal(&r);
        for (int adj = 0; adj < 2; adj++) {
            run(Fn, x, a, adj);
            run(Fc, x, b, adj);
            double e = test_rel_l2(a, b, 2 * n);
            CHECK(e < 2e-5, "%zux%zux%zu %s native vs clFFT: rel L2 %.3g", dims[0], dims[1],
                  dims[2], adj ? "adjoint" : "apply", e);
            printf("%zux%zux%zu %-7s native vs clFFT %.2e\n", dims[0], dims[1], dims[2],
                   adj ? "adjoint" : "apply", e);
        }
        free(x);
        free(a);
        free(b);
    }
    csi_linop_free(Fn);
    csi_linop_free(Fc);
}

static void test_write(cl_mem buf, const void *data, size_t bytes)
{
    CHECK_OK(csi_write(test_ctx(), buf, 0, bytes, data));
}

static void half_check(csi_ctx *ctx, const size_t dims[3], unsigned seed)
{
    const size_t n = dims[0] * dims[1] * dims[2];
    csi_fourier_half *h = NULL;
    csi_linop *F = NULL;
    CHECK_OK(csi_fourier_half_create(ctx, dims, &h));
    CHECK_OK(csi_fourier_create_backend(ctx, dims, CSI_FFT_NATIVE, &F));
    if (!h || !F) {
        csi_fourier_half_free(h);
        csi_linop_free(F);
        return;
    }
    /* the first axis longer than 1 (squeezed) and the rest */
    size_t n0 = dims[0] > 1 ? dims[0] : dims[1] > 1 ? dims[1] : dims[2];
    size_t rows = n / n0, M = n0 / 2, hs = csi_fourier_half_stride(h), nz = csi_fourier_half_count(h);
    CHECK(hs >= M + 1 && hs % 16 == 0 && nz == hs * rows, "%zux%zux%zu half layout: stride %zu count %zu",
          dims[0], dims[1], dims[2], hs, nz);
    test_rng r;
    test_rng_seed(&r, seed);
    float *f = malloc(n * sizeof *f), *fc = calloc(2 * n, sizeof *fc), *X = malloc(2 * n * sizeof *X);
    float *z = malloc(2 * nz * sizeof *z), *zw = malloc(2 * nz * sizeof *zw), *g = malloc(n * sizeof *g);
    for (size_t i = 0; i < n; i++) {
        f[i] = (float)test_rng_normal(&r);
        fc[2 * i] = f[i];
    }
    run(F, fc, X, true); /* X = fftn(f, ortho) */
    cl_mem df = test_upload(f, n * 4), dz = test_alloc(nz * 8), dg = test_alloc(n * 4);
    /* forward = the first M + 1 columns of X, padding exactly 0 */
    CHECK_OK(csi_fourier_half_forward(h, df, dz));
    test_download(dz, z, nz * 8);
    double e2 = 0, n2 = 0;
    bool pad0 = true;
    for (size_t row = 0; row < rows; row++)
        for (size_t u = 0; u < hs; u++) {
            const float *zz = z + 2 * (row * hs + u);
            if (u > M) {
                pad0 = pad0 && zz[0] == 0.0f && zz[1] == 0.0f;
                continue;
            }
            const float *xx = X + 2 * (row * n0 + u);
            e2 += (double)(zz[0] - xx[0]) * (zz[0] - xx[0]) + (double)(zz[1] - xx[1]) * (zz[1] - xx[1]);
            n2 += (double)xx[0] * xx[0] + (double)xx[1] * xx[1];
        }
    double ef = sqrt(e2 / n2);
    CHECK(ef < 2e-5, "%zux%zux%zu half forward vs the complex basis: rel L2 %.3g", dims[0], dims[1],
          dims[2], ef);
    CHECK(pad0, "%zux%zux%zu half forward: padding entries are zero", dims[0], dims[1], dims[2]);
    /* inverse of (X on u0 = 0, M; 2 X between; garbage in the padding) = f */
    for (size_t row = 0; row < rows; row++)
        for (size_t u = 0; u < hs; u++) {
            float *zz = zw + 2 * (row * hs + u);
            if (u > M) {
                zz[0] = 1e3f;
                zz[1] = -1e3f;
                continue;
            }
            float m = (u == 0 || u == M) ? 1.0f : 2.0f;
            zz[0] = m * X[2 * (row * n0 + u)];
            zz[1] = m * X[2 * (row * n0 + u) + 1];
        }
    test_write(dz, zw, nz * 8);
    CHECK_OK(csi_fourier_half_inverse(h, dz, dg));
    test_download(dg, g, n * 4);
    double ei = test_rel_l2(g, f, n);
    CHECK(ei < 2e-5, "%zux%zux%zu half inverse of the weighted spectrum = f: rel L2 %.3g", dims[0],
          dims[1], dims[2], ei);
    float *zback = malloc(2 * nz * sizeof *zback);
    test_download(dz, zback, nz * 8);
    CHECK(memcmp(zback, zw, nz * 8) == 0, "half inverse left its input unchanged");
    free(zback);
    /* adjoint identity <inverse(a), b> = Re <a, forward(b)> for random a (padding included), b */
    for (size_t i = 0; i < 2 * nz; i++)
        zw[i] = (float)test_rng_normal(&r);
    for (size_t i = 0; i < n; i++)
        f[i] = (float)test_rng_normal(&r);
    test_write(dz, zw, nz * 8);
    CHECK_OK(csi_fourier_half_inverse(h, dz, dg));
    test_download(dg, g, n * 4);
    test_write(df, f, n * 4);
    CHECK_OK(csi_fourier_half_forward(h, df, dz));
    test_download(dz, z, nz * 8);
    double lhs = 0, rhs = 0, na = 0, nb = 0;
    for (size_t i = 0; i < n; i++) {
        lhs += (double)g[i] * f[i];
        nb += (double)f[i] * f[i];
    }
    for (size_t i = 0; i < 2 * nz; i++) {
        rhs += (double)zw[i] * z[i];
        na += (double)zw[i] * zw[i];
    }
    CHECK(fabs(lhs - rhs) <= 1e-5 * sqrt(na * nb), "%zux%zux%zu half adjoint identity: %.9g vs %.9g",
          dims[0], dims[1], dims[2], lhs, rhs);
    printf("%zux%zux%zu half: forward %.2e inverse %.2e adjoint gap %.2e\n", dims[0], dims[1], dims[2],
           ef, ei, fabs(lhs - rhs) / sqrt(na * nb));
    csi_buffer_release(&df);
    csi_buffer_release(&dz);
    csi_buffer_release(&dg);
    free(f);
    free(fc);
    free(X);
    free(z);
    free(zw);
    free(g);
    csi_fourier_half_free(h);
    csi_linop_free(F);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    for (size_t c = 0; c < 2 * sizeof cases / sizeof cases[0]; c++) {
        const int be = (int)(c % 2);
        const struct ccase *cc = &cases[c / 2];
        char path[128];
        test_npy ax, af, ai;
        snprintf(path, sizeof path, "spectral/%s_x.npy", cc->name);
        bool ok = test_npy_load(path, &ax);
        snprintf(path, sizeof path, "spectral/%s_fwd.npy", cc->name);
        ok = ok && test_npy_load(path, &af);
        snprintf(path, sizeof path, "spectral/%s_inv.npy", cc->name);
        ok = ok && test_npy_load(path, &ai);
        CHECK(ok, "reference files for %s", cc->name);
        if (!ok)
            continue;
        size_t n = cc->dims[0] * cc->dims[1] * cc->dims[2];
        CHECK(ax.count == n, "%s: reference size", cc->name);
        float *x = test_npy_f32(&ax), *wf = test_npy_f32(&af), *wi = test_npy_f32(&ai);
        float *y = malloc(2 * n * sizeof *y), *z = malloc(2 * n * sizeof *z);
        csi_linop *F = NULL;
        CHECK_OK(csi_fourier_create_backend(ctx, cc->dims, backends[be], &F));
        if (F) {
            CHECK(F->rows == n && F->cols == n && F->complex_valued, "%s: shape", cc->name);
            /* adjoint = forward unitary DFT = fftn(norm="ortho") */
            run(F, x, y, true);
            double ef = test_rel_l2(y, wf, 2 * n);
            CHECK(ef < 1e-5, "%s adjoint vs fftn ortho: rel L2 %.3g", cc->name, ef);
            /* Parseval: the unitary DFT keeps the 2-norm. */
            double nx = cnorm(x, n), ny = cnorm(y, n);
            CHECK(fabs(ny - nx) <= 1e-5 * nx, "%s Parseval: %.9g vs %.9g", cc->name, ny, nx);
            /* apply(adjoint(x)) = x */
            run(F, y, z, false);
            double er = test_rel_l2(z, x, 2 * n);
            CHECK(er < 2e-5, "%s apply(adjoint(x)) = x: rel L2 %.3g", cc->name, er);
            /* apply = inverse unitary DFT = ifftn(norm="ortho") */
            run(F, x, y, false);
            double ei = test_rel_l2(y, wi, 2 * n);
            CHECK(ei < 1e-5, "%s apply vs ifftn ortho: rel L2 %.3g", cc->name, ei);
            printf("%-9s %-6s fwd %.2e  inv %.2e  round trip %.2e\n", cc->name, backend_names[be],
                   ef, ei, er);

            /* <A a, b> = <a, A^H b> for random complex a, b. */
            test_rng r;
            test_rng_seed(&r, 300 + c / 2);
            float *a = malloc(2 * n * sizeof *a), *b = malloc(2 * n * sizeof *b);
            for (size_t k = 0; k < 2 * n; k++) {
                a[k] = (float)test_rng_normal(&r);
                b[k] = (float)test_rng_normal(&r);
            }
            run(F, a, y, false);
            run(F, b, z, true);
            double lr, li, rr, ri;
            cdot(y, b, n, &lr, &li);
            cdot(a, z, n, &rr, &ri);
            double scale = cnorm(a, n) * cnorm(b, n);
            CHECK(hypot(lr - rr, li - ri) <= 1e-5 * scale, "%s adjoint identity: (%.8g, %.8g) vs (%.8g, %.8g)",
                  cc->name, lr, li, rr, ri);
            free(a);
            free(b);
        }
        csi_linop_free(F);
        free(x);
        free(wf);
        free(wi);
        free(y);
        free(z);
        test_npy_free(&ax);
        test_npy_free(&af);
        test_npy_free(&ai);
    }

    {
        static const size_t sizes[][3] = {
            {56, 20, 9},  /* radices 8 x 7, 4 x 5, 9 = 3 x 3 */
            {512, 4, 2},  /* 8 x 8 x 8 along x: the k-indexed row passes (p >= 8) */
            {1, 25, 14},  /* x of length 1 (squeezed), 5 x 5, 2 x 7 */
            {15, 1, 6},   /* odd x (local size 1 launches), middle axis squeezed */
            {2, 3, 5},    /* the smallest lengths of each radix */
            {128, 1, 1},  /* 1-D */
        };
        for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
            cross_check(ctx, sizes[i], 700 + (unsigned)i);
    }

    /* Real Fourier basis on the half spectrum, against the complex basis (checked against
     * numpy above) on the same real signal, for sizes with every radix along x (M = n0/2) and
     * squeezed axes. Tolerances as for the complex transforms: 2e-5 for one transform compared
     * with another float32 transform, 1e-5 relative for the adjoint identity (double sums). */
    {
        static const size_t sizes[][3] = {{24, 16, 8}, {30, 18, 1}, {64, 64, 1}, {28, 14, 6},
                                          {60, 1, 1},  {1, 20, 6},  {96, 8, 10}};
        for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++)
            half_check(ctx, sizes[i], 900 + (unsigned)i);
        /* An odd first axis is refused with the size in the message. */
        size_t odd[3] = {15, 4, 4};
        csi_fourier_half *h = (csi_fourier_half *)1;
        csi_status st = csi_fourier_half_create(ctx, odd, &h);
        CHECK(st == CSI_ERR_ARG && h == NULL && strstr(csi_last_error(), "15"), "%s", csi_last_error());
    }

    /* A unit impulse at the origin has the flat spectrum 1/sqrt(N) (closed form). */
    {
        size_t dims[3] = {24, 16, 8}, n = 24 * 16 * 8;
        csi_linop *F = NULL;
        CHECK_OK(csi_fourier_create(ctx, dims, &F));
        if (F) {
            float *x = calloc(2 * n, sizeof *x), *y = malloc(2 * n * sizeof *y);
            x[0] = 1.0f;
            run(F, x, y, true);
            double worst = 0, want = 1.0 / sqrt((double)n);
            for (size_t k = 0; k < n; k++)
                worst = fmax(worst, hypot(y[2 * k] - want, y[2 * k + 1]));
            CHECK(worst < 1e-6 * want * 13, "impulse spectrum off by %.3g", worst);
            free(x);
            free(y);
            csi_linop_free(F);
        }
    }

    /* Sizes clFFT cannot do: a clear error naming the size. */
    csi_linop *F = (csi_linop *)1;
    size_t d11[3] = {64, 44, 1};
    csi_status st = csi_fourier_create(ctx, d11, &F);
    CHECK(st == CSI_ERR_ARG && F == NULL && strstr(csi_last_error(), "44"), "%s", csi_last_error());
    size_t d17[3] = {17, 1, 1};
    st = csi_fourier_create(ctx, d17, &F);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "17"), "%s", csi_last_error());
    return test_done();
}
