/* Gaussian filter Phi and its Wiener inverse (host/ops/spectral.c, kernels/spectral.cl) under
 * PoCL, against numpy references (tests/data/spectral/gen_refs.py, full complex FFT in float64) and
 * closed forms.
 *
 * Tolerances. A radix-2/3/5/7 FFT in float32 has a relative L2 error bounded by about
 * c * eps * log2(N) with eps = 6e-8 and a small constant c (Higham, Accuracy and Stability of
 * Numerical Algorithms, 2nd ed., Sec. 24.1); forward + inverse at N = 8192 gives ~2 * 13 * 6e-8
 * = 1.6e-6 before c. The gain multiply adds one rounding (and the Wiener formula three). We allow
 * 2e-5 relative L2 (c ~ 12) for the Gaussian and 4e-5 for the Wiener inverse, whose gains up to
 * (1 + lambda) / (2 sqrt(lambda)) ~ 2.4 at lambda = 0.05 amplify the transform's roundoff where
 * the signal is weak. Measured errors are ~10x below these (printed by the test). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../../host/ops/fft_filter.h"
#include "csi/spectral.h"
#include "testlib.h"

#define PI 3.14159265358979323846

/* y = op(x) for a host vector; also checks that x on the device was left unchanged. */
static bool run_op(const csi_linop *op, const float *x, float *y, bool adjoint)
{
    size_t n = op->cols * csi_linop_elem(op) / sizeof(float);
    cl_mem dx = test_upload(x, n * sizeof(float));
    cl_mem dy = test_alloc(n * sizeof(float));
    csi_status st = adjoint ? csi_linop_adjoint(op, dx, dy) : csi_linop_apply(op, dx, dy);
    CHECK(st == CSI_OK, "%s: %s", op->name, csi_last_error());
    test_download(dy, y, n * sizeof(float));
    float *back = malloc(n * sizeof *back);
    test_download(dx, back, n * sizeof(float));
    CHECK(memcmp(back, x, n * sizeof(float)) == 0, "%s left its input unchanged", op->name);
    free(back);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
    return st == CSI_OK;
}

static double dot(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * b[i];
    return s;
}

static double norm2(const float *a, size_t n) { return sqrt(dot(a, a, n)); }

struct fcase {
    const char *name;
    size_t dims[3];
    double sigma[3];
    float lambda;
};

static const struct fcase cases[] = {
    {"f64x64", {64, 64, 1}, {1.1, 2.2, 0.0}, 0.3f},
    {"f96x64", {96, 64, 1}, {1.65, 0.55, 0.0}, 0.3f},
    {"f45x30", {45, 30, 1}, {1.0, 1.5, 0.0}, 0.1f},
    {"f24x16x8", {24, 16, 8}, {1.1, 0.8, 0.5}, 0.3f},
    {"f32x32x8", {32, 32, 8}, {1.1, 1.1, 2.0}, 0.05f},
    {"f60", {60, 1, 1}, {2.0, 0.0, 0.0}, 0.3f},
    {"f28x14x6", {28, 14, 6}, {0.9, 1.3, 0.7}, 0.2f},
    {"f320x24", {320, 24, 1}, {1.2, 0.9, 0.0}, 0.3f},
    {"f162x18", {162, 18, 1}, {1.3, 1.1, 0.0}, 0.3f},
    {"f288x18", {288, 18, 1}, {0.9, 1.4, 0.0}, 0.3f},
};

static void test_references(csi_ctx *ctx)
{
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const struct fcase *fc = &cases[c];
        char path[128];
        test_npy ax, ag, aw;
        snprintf(path, sizeof path, "spectral/%s_x.npy", fc->name);
        bool ok = test_npy_load(path, &ax);
        snprintf(path, sizeof path, "spectral/%s_gauss.npy", fc->name);
        ok = ok && test_npy_load(path, &ag);
        snprintf(path, sizeof path, "spectral/%s_wiener.npy", fc->name);
        ok = ok && test_npy_load(path, &aw);
        CHECK(ok, "reference files for %s", fc->name);
        if (!ok)
            continue;
        size_t n = fc->dims[0] * fc->dims[1] * fc->dims[2];
        CHECK(ax.count == n, "%s: reference size", fc->name);
        float *x = test_npy_f32(&ax), *wg = test_npy_f32(&ag), *ww = test_npy_f32(&aw);
        float *y = malloc(n * sizeof *y), *y2 = malloc(n * sizeof *y2);

        /* Both implementations: clFFT and csi's own kernels (AUTO falls back to clFFT for the
         * odd 45 x 30, which NATIVE refuses). Each against numpy, and against each other. */
        float *yc = malloc(n * sizeof *yc), *wc = malloc(n * sizeof *wc);
        for (int be = 0; be < 2; be++) {
        const csi_fft_backend backend = be == 0 ? CSI_FFT_CLFFT : CSI_FFT_AUTO;
        const char *bname = be == 0 ? "clFFT" : "auto";
        csi_linop *g = NULL, *w = NULL;
        CHECK_OK(csi_filter_create_backend(ctx, fc->dims, fc->sigma, CSI_FILTER_GAUSS, 0.0f, backend, &g));
        CHECK_OK(csi_filter_create_backend(ctx, fc->dims, fc->sigma, CSI_FILTER_WIENER, fc->lambda, backend, &w));
        if (g && w) {
            CHECK(g->rows == n && g->cols == n && !g->complex_valued, "%s: shape", fc->name);
            run_op(g, x, y, false);
            double eg = test_rel_l2(y, wg, n), egc = 0, ewc = 0;
            CHECK(eg < 2e-5, "%s %s gauss vs numpy: rel L2 %.3g", fc->name, bname, eg);
            if (be == 0)
                memcpy(yc, y, n * sizeof *y);
            else
                egc = test_rel_l2(y, yc, n);
            /* Determinism: same input, same bits. */
            run_op(g, x, y2, false);
            CHECK(memcmp(y, y2, n * sizeof *y) == 0, "%s %s: gauss repeatable", fc->name, bname);
            run_op(w, x, y, false);
            double ew = test_rel_l2(y, ww, n);
            CHECK(ew < 4e-5, "%s %s wiener vs numpy: rel L2 %.3g", fc->name, bname, ew);
            if (be == 0)
                memcpy(wc, y, n * sizeof *y);
            else
                ewc = test_rel_l2(y, wc, n);
            /* Two float32 FFT implementations each within ~2e-7 of float64: 2x the bounds. */
            CHECK(egc < 4e-5 && ewc < 8e-5, "%s: csi FFT vs clFFT: %.3g %.3g", fc->name, egc, ewc);
            printf("%-9s %-5s gauss rel L2 %.2e  wiener rel L2 %.2e  (vs clFFT %.2e %.2e)\n",
                   fc->name, bname, eg, ew, egc, ewc);

            /* Self-adjoint: <Phi a, b> = <a, Phi b> for random a, b; both sides are sums of n
             * products of O(1) terms with FFT roundoff ~1e-6 relative, so 1e-5 of |a||b|. */
            test_rng r;
            test_rng_seed(&r, 7 + c);
            float *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b);
            for (size_t i = 0; i < n; i++) {
                a[i] = (float)test_rng_normal(&r);
                b[i] = (float)test_rng_normal(&r);
            }
            const csi_linop *ops[2] = {g, w};
            for (int o = 0; o < 2; o++) {
                run_op(ops[o], a, y, false);
                run_op(ops[o], b, y2, true);
                double lhs = dot(y, b, n), rhs = dot(a, y2, n);
                double scale = norm2(a, n) * norm2(b, n);
                CHECK(fabs(lhs - rhs) <= 1e-5 * scale, "%s %s adjoint: %.9g vs %.9g", fc->name,
                      ops[o]->name, lhs, rhs);
            }
            free(a);
            free(b);
        }
        csi_linop_free(g);
        csi_linop_free(w);
        }
        free(yc);
        free(wc);
        free(x);
        free(wg);
        free(ww);
        free(y);
        free(y2);
        test_npy_free(&ax);
        test_npy_free(&ag);
        test_npy_free(&aw);
    }
}

/* A 1-D filter laid out along y (dims 1 x 60 x 1) equals the 1-D reference along x. */
static void test_squeezed_axis(csi_ctx *ctx)
{
    test_npy ax, ag;
    if (!test_npy_load("spectral/f60_x.npy", &ax) || !test_npy_load("spectral/f60_gauss.npy", &ag)) {
        CHECK(0, "f60 references");
        return;
    }
    float *x = test_npy_f32(&ax), *want = test_npy_f32(&ag), y[60];
    size_t dims[3] = {1, 60, 1};
    double sig[3] = {0.0, 2.0, 0.0};
    csi_linop *g = NULL;
    CHECK_OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, &g));
    if (g) {
        run_op(g, x, y, false);
        double e = test_rel_l2(y, want, 60);
        CHECK(e < 2e-5, "1 x 60 x 1 filter vs 1-D reference: rel L2 %.3g", e);
    }
    csi_linop_free(g);
    free(x);
    free(want);
    test_npy_free(&ax);
    test_npy_free(&ag);
}

/* A plane wave cos(2 pi (a i / n0 + b j / n1) + phi) is one pair of DFT bins, so the Gaussian
 * multiplies it by exp(-2 pi^2 sigma^2 f^2) per axis (f in cycles per cell), and a factor
 * exp(-2 pi i (kx s / n0 + ky t / n1)) shifts it by (s, t) cells (apply; the adjoint by (-s, -t));
 * a row stage that writes a row to the wrong place, leaves one out or gets a pass wrong breaks
 * all three. A constant d and q (-1)^i add the two bins along x that the real-to-complex
 * unpacking writes apart (0 and M: the Gaussian keeps d and multiplies q by its gain at 1/2 cycle
 * per cell, the shift multiplies q by (-1)^s). Tolerance as for the references above: 2e-5 relative L2 (log2 n = 23 at most here,
 * ~2.8e-6 before the constant). `what` names the row stages under test. */
static void plane_wave_filters(csi_ctx *ctx, size_t n0, size_t n1, const char *what)
{
    const size_t n = n0 * n1, dims[3] = {n0, n1, 1};
    const double sig[3] = {0.7, 0.9, 0.0}, a = 5, b = 37, phi = 0.3, d = 0.25, q = 0.5;
    const long s = 3, t = -2;
    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y), *want = malloc(n * sizeof *want);
    double *fx = calloc(2 * (n0 / 2 + 1), sizeof *fx), *fy = calloc(2 * n1, sizeof *fy);
    for (size_t k = 0; k <= n0 / 2; k++) {
        fx[2 * k] = cos(-2 * PI * (double)k * (double)s / (double)n0);
        fx[2 * k + 1] = sin(-2 * PI * (double)k * (double)s / (double)n0);
    }
    for (size_t k = 0; k < n1; k++) {
        const double ky = k <= n1 / 2 ? (double)k : (double)k - (double)n1;
        fy[2 * k] = cos(-2 * PI * ky * (double)t / (double)n1);
        fy[2 * k + 1] = k == n1 / 2 ? 0.0 : sin(-2 * PI * ky * (double)t / (double)n1);
    }
    const double g = exp(-2 * PI * PI * (sig[0] * sig[0] * (a / n0) * (a / n0) + sig[1] * sig[1] * (b / n1) * (b / n1)));
    const double gq = exp(-2 * PI * PI * sig[0] * sig[0] * 0.25);
    for (size_t j = 0; j < n1; j++)
        for (size_t i = 0; i < n0; i++)
            x[i + n0 * j] = (float)(cos(2 * PI * (a * (double)i / n0 + b * (double)j / n1) + phi) + d + (i % 2 ? -q : q));
    csi_linop *G = NULL, *F = NULL;
    const uint64_t live0 = csi_device_bytes_live();
    CHECK_OK(csi_filter_create_backend(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, CSI_FFT_NATIVE, &G));
    CHECK_OK(csi_filter_create_factor(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, fx, fy, &F));
    /* shift 0: the plain filter; then the factor's shift by (s, t), and the adjoint's by (-s, -t) */
    for (int c = 0; c < 3 && G && F; c++) {
        const long ds = c == 0 ? 0 : c == 1 ? s : -s, dt = c == 0 ? 0 : c == 1 ? t : -t;
        for (size_t j = 0; j < n1; j++)
            for (size_t i = 0; i < n0; i++)
                want[i + n0 * j] = (float)(g * cos(2 * PI * (a * ((double)i - ds) / n0 + b * ((double)j - dt) / n1) + phi) +
                                           d + ((i + (size_t)labs(ds)) % 2 ? -q : q) * gq);
        run_op(c == 0 ? G : F, x, y, c == 2);
        double e = test_rel_l2(y, want, n);
        CHECK(e < 2e-5, "%zu x %zu in %s, %s: rel L2 %.3g against the plane wave", n0, n1, what,
              c == 0 ? "Gaussian" : c == 1 ? "factor (apply)" : "factor (adjoint)", e);
        printf("%zu x %zu %s %s: rel L2 %.2e\n", n0, n1, what,
               c == 0 ? "gauss" : c == 1 ? "factor apply" : "factor adjoint", e);
    }
    csi_linop_free(G);
    csi_linop_free(F);
    /* the blocks' sub-buffers hold no device bytes: freed, the filters leave the live count where
     * it was (a sub-buffer counted out as a buffer once made the next tile's plan refuse) */
    CHECK(csi_device_bytes_live() == live0, "device bytes live after the filters in %s: %llu, before %llu",
          what, (unsigned long long)csi_device_bytes_live(), (unsigned long long)live0);
    free(x);
    free(y);
    free(want);
    free(fx);
    free(fy);
}

/* The filter's row stages run block by block once its two volumes outgrow the device's cache
 * (host/ops/fft_filter.c, row_block: 1024 rows at M = 64 complex values per row, so 128 x 44100,
 * two volumes of 28 MB, makes 43 whole blocks and a partial one where the cache is at most 56 MB,
 * as PoCL's 32 MiB here; M = 64 has two row passes, so no fused stage). */
static void test_row_blocks(csi_ctx *ctx) { plane_wave_filters(ctx, 128, 44100, "row blocks"); }

/* The Wiener filter on a random n0 x n1 image with its row stages fused (they must be, or the
 * comparison proves nothing) and launched pass by pass: the fused stages do each element's
 * arithmetic as the passes do, so the two outputs must have the same bits. */
static void fused_rows_same_bits(csi_ctx *ctx, size_t n0, size_t n1)
{
    const size_t n = n0 * n1, c[3] = {n0, n1, 1};
    const double sig[3] = {3.2, 3.2, 0.0};
    CHECK(csi_fft_filter_rows_fused(n0, csi_ctx_local_mem(ctx)), "%zu-wide rows run fused", n0);
    float *x = malloc(n * sizeof *x), *y[2] = {malloc(n * sizeof(float)), malloc(n * sizeof(float))};
    test_rng rng;
    test_rng_seed(&rng, 19);
    for (size_t i = 0; i < n; i++)
        x[i] = (float)test_rng_normal(&rng);
    cl_mem dx = test_upload(x, n * sizeof *x), dy = test_alloc(n * sizeof(float));
    for (int fuse = 0; fuse < 2; fuse++) {
        csi_fft_filter *f = NULL;
        CHECK_OK(csi_fft_filter_create_rows(ctx, c, 2, sig, true, 0.3f, fuse == 1, &f));
        if (f) {
            CHECK_OK(csi_fft_filter_run(f, dx, dy));
            test_download(dy, y[fuse], n * sizeof(float));
        }
        csi_fft_filter_free(f);
    }
    size_t differ = 0;
    for (size_t i = 0; i < n; i++)
        differ += memcmp(&y[0][i], &y[1][i], sizeof(float)) != 0;
    CHECK(differ == 0, "%zu x %zu: fused rows and passes one by one differ at %zu of %zu values", n0, n1, differ, n);
    clReleaseMemObject(dx);
    clReleaseMemObject(dy);
    free(x);
    free(y[0]);
    free(y[1]);
}

/* The fused row stages (one launch per stage, a work-item per row: rows_fused_fit) take M a
 * multiple of 128 whose plan is radices 8, then 4 and 8, then 9, 3 and 5: M = 128 (passes 8, 4,
 * 4), M = 2048 (8, 8, 8, 4: the 1920x1080 default's tiles), M = 3840 (8, 8, 4, 3, 5: a model grid
 * 7680 wide, the whole 1920x1080 image), M = 5760 (8, 4, 4, 9, 5). */
static void test_rows_fused(csi_ctx *ctx)
{
    plane_wave_filters(ctx, 256, 300, "fused rows");
    plane_wave_filters(ctx, 4096, 96, "fused rows");
    plane_wave_filters(ctx, 7680, 80, "fused rows");
    plane_wave_filters(ctx, 11520, 80, "fused rows");
    fused_rows_same_bits(ctx, 4096, 48);
    fused_rows_same_bits(ctx, 7680, 40);
    fused_rows_same_bits(ctx, 11520, 36);
}

/* A 2-D filter's column stage runs as one launch, a strip of 8 columns per work-item in local
 * memory, where its plan allows (host/ops/fft_filter.c, cols_fused_fit): along y 300 is passes
 * 4, 3, 5, 5, 96 is 8, 4, 3 (above), 90 is 2, 9, 5 (here); 44100 (above) runs pass by pass (two
 * strip volumes of 5.6 MB, more than the 2 MiB of local memory PoCL's CPU device reports here).
 * Where three strip volumes fit, a work-item takes two adjacent strips (cols_pair_fit: 300, 96
 * and 90 rows); at 12000 rows (8, 4, 3, 5, 5, 5) three volumes (2.30 MB) exceed those 2 MiB and
 * two (1.54 MB) do not, so that filter runs the one-strip kernel. */
static void test_cols_fused(csi_ctx *ctx)
{
    plane_wave_filters(ctx, 256, 90, "fused columns");
    plane_wave_filters(ctx, 32, 12000, "fused columns, one strip a work-item");
}

static void test_sigmas(void)
{
    /* The paper's example (Sec. 4): k = 1024^2 reduced to p = 256^2 gives 2 sigma_Phi = 2.2. */
    double sp, sg;
    csi_gauss_sigmas(1024, 256, &sp, &sg);
    CHECK(fabs(sp - 1.1) < 1e-12, "sigma_phi %.17g", sp);
    CHECK(fabs(sg - 1024.0 / (2 * PI * 1.1)) < 1e-9, "sigma_G %.17g", sg);
    double sp0 = 1, sg0 = 1;
    csi_gauss_sigmas(0, 256, &sp0, &sg0);
    CHECK(sp0 == 0.0 && sg0 == 0.0, "degenerate grid gives no filtering");
    /* Gain at u = sigma_G is exp(-1/2); at u = 0 it is 1; symmetric in u. */
    double g1 = csi_gauss_gain_1d(1024, 0, 1.1);
    CHECK(g1 == 1.0, "DC gain %g", g1);
    /* bins k and n - k are +u and -u. */
    CHECK(csi_gauss_gain_1d(1024, 10, 1.1) == csi_gauss_gain_1d(1024, 1014, 1.1), "even in u");
    /* Same quantity by the paper's route (sigma_G) and ours (2 pi^2 sigma_phi^2 f^2): equal up
     * to a few double roundings. */
    double want = exp(-100.0 / (2 * sg * sg));
    CHECK(fabs(csi_gauss_gain_1d(1024, 10, 1.1) - want) < 1e-13 * want,
          "gain matches exp(-u^2 / 2 sigma_G^2)");
    CHECK(csi_gauss_gain_1d(16, 8, 0.0) == 1.0, "sigma 0 = no filtering");
}

/* Constant images: the Gaussian and the Wiener inverse have DC gain exactly 1, so a constant
 * passes through unchanged, up to FFT roundoff (~1e-6 relative; 1e-5 allowed), for lambda from
 * 1e-6 to 10. */
static void test_dc(csi_ctx *ctx)
{
    size_t dims[3] = {96, 64, 1};
    double sig[3] = {2.2, 2.2, 0};
    size_t n = 96 * 64;
    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    for (size_t i = 0; i < n; i++)
        x[i] = 0.7f;
    const float lambdas[] = {0.3f, 1e-6f, 10.0f};
    for (int l = 0; l < 4; l++) {
        csi_linop *op = NULL;
        csi_filter_kind kind = l == 3 ? CSI_FILTER_GAUSS : CSI_FILTER_WIENER;
        CHECK_OK(csi_filter_create(ctx, dims, sig, kind, l == 3 ? 0.0f : lambdas[l], &op));
        if (!op)
            continue;
        run_op(op, x, y, false);
        double worst = 0;
        for (size_t i = 0; i < n; i++)
            worst = fmax(worst, fabs(y[i] - 0.7));
        CHECK(worst < 1e-5 * 0.7, "%s lambda %g: constant 0.7 moved by %.3g", op->name,
              l == 3 ? 0.0 : lambdas[l], worst);
        csi_linop_free(op);
    }
    free(x);
    free(y);
}

/* Gaussian then Wiener inverse on single DFT-bin cosines: the closed form gain per frequency is
 * G^2 (1 + lambda) / (G^2 + lambda) (Phi^-1 Phi is diagonal in F), close to 1 at low u. The
 * sigma comes from csi_gauss_sigmas (64 -> 16 cells: sigma_Phi = 1.1), G is recomputed here in
 * double from sigma_G. Error bound: two filter passes on an amplitude-1 cosine, 4e-6 absolute. */
static void test_gauss_then_wiener(csi_ctx *ctx)
{
    const size_t n0 = 64, n1 = 48, n = 64 * 48;
    double sp0, sg0, sp1, sg1;
    csi_gauss_sigmas(n0, 16, &sp0, &sg0);
    csi_gauss_sigmas(n1, 12, &sp1, &sg1);
    size_t dims[3] = {n0, n1, 1};
    double sig[3] = {sp0, sp1, 0};
    const float lambda = 0.3f;
    csi_linop *g = NULL, *w = NULL;
    CHECK_OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, &g));
    CHECK_OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_WIENER, lambda, &w));
    if (!g || !w) {
        csi_linop_free(g);
        csi_linop_free(w);
        return;
    }
    float *x = malloc(n * sizeof *x), *m = malloc(n * sizeof *m), *y = malloc(n * sizeof *y);
    const int freqs[][2] = {{0, 1}, {1, 0}, {1, 2}, {3, 0}, {5, 4}, {10, 7}, {-6, 3}, {32, 0}, {20, 24}};
    for (size_t f = 0; f < sizeof freqs / sizeof freqs[0]; f++) {
        int u0 = freqs[f][0], u1 = freqs[f][1];
        for (size_t j = 0; j < n1; j++)
            for (size_t i = 0; i < n0; i++)
                x[i + n0 * j] = (float)cos(2 * PI * ((double)u0 * i / n0 + (double)u1 * j / n1));
        cl_mem dx = test_upload(x, n * sizeof *x), dm = test_alloc(n * sizeof *x),
               dy = test_alloc(n * sizeof *x);
        CHECK_OK(csi_linop_apply(g, dx, dm));
        CHECK_OK(csi_linop_apply(w, dm, dy));
        test_download(dy, y, n * sizeof *y);
        /* Nyquist (u0 = 32 of 64) is its own mirror: u = -32 in [-n/2, n/2). */
        double G = exp(-(double)u0 * u0 / (2 * sg0 * sg0)) * exp(-(double)u1 * u1 / (2 * sg1 * sg1));
        double want = G * G * (1 + lambda) / (G * G + lambda);
        double worst = 0;
        for (size_t i = 0; i < n; i++)
            worst = fmax(worst, fabs(y[i] - want * x[i]));
        CHECK(worst < 4e-6, "u = (%d, %d): gain %.6f, max deviation %.3g", u0, u1, want, worst);
        if (abs(u0) <= 1 && abs(u1) <= 1)
            CHECK(want > 0.99, "low frequency (%d, %d) nearly identity: %.6f", u0, u1, want);
        csi_buffer_release(&dx);
        csi_buffer_release(&dm);
        csi_buffer_release(&dy);
    }
    free(x);
    free(m);
    free(y);
    csi_linop_free(g);
    csi_linop_free(w);
}

/* lambda = 1e-6: the largest gain is (1 + lambda) / (2 sqrt(lambda)) ~ 500. Random noise and a
 * single bright dot give finite output with ||y|| <= max gain * ||x|| (Parseval). */
static void test_tiny_lambda(csi_ctx *ctx)
{
    size_t dims[3] = {32, 32, 8}, n = 32 * 32 * 8;
    double sig[3] = {1.1, 1.1, 1.1};
    const float lambda = 1e-6f;
    csi_linop *w = NULL;
    CHECK_OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_WIENER, lambda, &w));
    if (!w)
        return;
    float *x = malloc(n * sizeof *x), *y = malloc(n * sizeof *y);
    double gmax = (1.0 + lambda) / (2.0 * sqrt((double)lambda));
    for (int c = 0; c < 2; c++) {
        test_rng r;
        test_rng_seed(&r, 99);
        for (size_t i = 0; i < n; i++)
            x[i] = c == 0 ? (float)test_rng_normal(&r) : 0.0f;
        if (c == 1)
            x[5 + 32 * (7 + 32 * 3)] = 1e4f; /* an HDR dot */
        run_op(w, x, y, false);
        size_t bad = 0;
        for (size_t i = 0; i < n; i++)
            bad += !isfinite(y[i]);
        CHECK(bad == 0, "lambda 1e-6 case %d: %zu non-finite outputs", c, bad);
        double ny = norm2(y, n), nx = norm2(x, n);
        CHECK(ny <= gmax * nx * 1.001, "lambda 1e-6 case %d: |y| %.4g > %.4g |x|", c, ny, gmax);
    }
    free(x);
    free(y);
    csi_linop_free(w);
}

static void test_bad_input(csi_ctx *ctx)
{
    csi_linop *op = (csi_linop *)1;
    double sig[3] = {1, 1, 0};
    size_t d11[3] = {22, 16, 1};
    csi_status st = csi_filter_create(ctx, d11, sig, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG && op == NULL && strstr(csi_last_error(), "22"), "%s", csi_last_error());
    size_t d13[3] = {64, 64, 13};
    st = csi_filter_create(ctx, d13, sig, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "13"), "%s", csi_last_error());
    size_t d0[3] = {64, 0, 1};
    st = csi_filter_create(ctx, d0, sig, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG, "zero axis: %s", csi_last_error());
    size_t d1[3] = {1, 1, 1};
    st = csi_filter_create(ctx, d1, sig, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG, "one sample: %s", csi_last_error());
    size_t ok[3] = {16, 16, 1};
    st = csi_filter_create(ctx, ok, sig, CSI_FILTER_WIENER, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "lambda"), "%s", csi_last_error());
    st = csi_filter_create(ctx, ok, sig, CSI_FILTER_WIENER, NAN, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "lambda"), "%s", csi_last_error());
    double neg[3] = {1, -1, 0}, nan_[3] = {NAN, 1, 0};
    st = csi_filter_create(ctx, ok, neg, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "sigma"), "%s", csi_last_error());
    st = csi_filter_create(ctx, ok, nan_, CSI_FILTER_GAUSS, 0.0f, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "sigma"), "%s", csi_last_error());
    st = csi_filter_create(ctx, ok, sig, (csi_filter_kind)7, 0.3f, &op);
    CHECK(st == CSI_ERR_ARG, "kind: %s", csi_last_error());
    /* csi's own FFT needs an even first axis: NATIVE refuses 45 x 30, naming the size. */
    size_t odd[3] = {45, 30, 1};
    st = csi_filter_create_backend(ctx, odd, sig, CSI_FILTER_GAUSS, 0.0f, CSI_FFT_NATIVE, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "45"), "%s", csi_last_error());
    /* Aliasing input and output is refused, not computed wrongly. */
    CHECK_OK(csi_filter_create(ctx, ok, sig, CSI_FILTER_GAUSS, 0.0f, &op));
    if (op) {
        cl_mem b = test_alloc(256 * sizeof(float));
        st = csi_linop_apply(op, b, b);
        CHECK(st == CSI_ERR_ARG, "aliased buffers: %s", csi_last_error());
        csi_buffer_release(&b);
        csi_linop_free(op);
    }
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    test_sigmas();
    test_references(ctx);
    test_squeezed_axis(ctx);
    test_row_blocks(ctx);
    test_rows_fused(ctx);
    test_cols_fused(ctx);
    test_dc(ctx);
    test_gauss_then_wiener(ctx);
    test_tiny_lambda(ctx);
    test_bad_input(ctx);
    return test_done();
}
