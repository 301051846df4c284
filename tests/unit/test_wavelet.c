/* 2-D periodized Daubechies wavelet operator (host/ops/wavelet.c, kernels/wavelet.cl).
 *
 * References: PyWavelets 1.8 (wavedec2 / waverec2, mode='periodization', coeffs_to_array layout)
 * vectors in tests/data/wavelet made by tests/data/wavelet/gen_refs.py (seed 20261122), and, for sizes
 * too large to commit, a plain double-precision C transform written here from PyWavelets'
 * periodization formula with PyWavelets' filters (tests/data/wavelet/filters_*.npy).
 *
 * Tolerances. float32 has eps = 2^-24 ~ 6e-8 (unit roundoff). One 1-D pass computes each output
 * as an F-term fma chain of values of similar size with |filter taps| < 1; its relative rounding
 * error is below ~F * eps in the worst case and ~sqrt(F) * eps (~2.5e-7 for F = 16) typically,
 * plus the taps themselves rounded to float (relative 6e-8 each, an operator perturbation of
 * ~sqrt(F) * 6e-8 in norm). An L-level 2-D transform is 2L such passes whose errors add, so
 * the relative L2 error is bounded by about 2L * 3e-7 = 6e-7 * L (in practice less: coarser
 * levels touch ever fewer coefficients). We allow 1e-6 * L. Measured (printed when the test
 * runs): 0.9e-7 .. 2.2e-7 for L = 1 .. 7, at least 4x under the bound. A systematic bug (wrong
 * tap, wrong wrap, wrong layout) gives errors of order 1e-2 .. 1, far above. Max-abs errors are
 * checked at 5e-6 * L * max|ref| (single entries can exceed the L2 average, but the worst case
 * is still ~F * eps per pass; measured <= 1.5e-6 absolute on values up to ~4.8). References
 * are stored as float32, adding 6e-8 relative, within the same margin. The adjoint identity
 * and Parseval checks use the same relative bound times ||c|| ||x|| (Cauchy-Schwarz). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/wavelet.h"
#include "testlib.h"

typedef struct {
    const char *fam;
    size_t w, h;
    int levels;
} wcase;

/* Must match CASES in tests/data/wavelet/gen_refs.py. */
static const wcase cases[] = {
    {"db4", 64, 64, 1},  {"db4", 64, 64, 3},   {"db8", 64, 64, 2}, {"db8", 64, 64, 4},
    {"db4", 96, 64, 3},  {"db8", 128, 48, 4},  {"db4", 48, 48, 4}, {"db8", 48, 96, 4},
    {"db8", 160, 96, 5}, {"db4", 2, 2, 1},     {"db8", 4, 2, 1},   {"db4", 12, 6, 1},
    {"db8", 8, 8, 3},    {"db4", 24, 48, 3},
};

static double dot(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * (double)b[i];
    return s;
}

static double norm(const float *a, size_t n) { return sqrt(dot(a, a, n)); }

static float *load(const char *tag, const char *what, size_t w, size_t h)
{
    char path[256];
    snprintf(path, sizeof path, "wavelet/%s_%s.npy", tag, what);
    test_npy a;
    if (!test_npy_load(path, &a))
        return NULL;
    float *f = NULL;
    if (a.ndim == 2 && a.shape[0] == h && a.shape[1] == w)
        f = test_npy_f32(&a);
    else
        fprintf(stderr, "%s: unexpected shape\n", path);
    test_npy_free(&a);
    return f;
}

/* Compares got against want (n floats) with the tolerances explained at the top. */
static void check_close(const char *what, const char *tag, int levels, const float *got,
                        const float *want, size_t n)
{
    double rel = test_rel_l2(got, want, n);
    double mx = test_max_abs_diff(got, want, n), ref = test_max_abs(want, n);
    printf("  %-22s %-10s rel L2 %.2e  max abs %.2e (max |ref| %.2f)\n", tag, what, rel, mx, ref);
    CHECK(rel <= 1e-6 * levels, "%s %s: relative L2 error %.3e over %.1e", tag, what, rel,
          1e-6 * levels);
    CHECK(mx <= 5e-6 * levels * ref, "%s %s: max abs error %.3e over %.3e", tag, what, mx,
          5e-6 * levels * ref);
}

static void test_reference_case(const wcase *c)
{
    csi_ctx *ctx = test_ctx();
    char tag[64];
    snprintf(tag, sizeof tag, "%s_%zux%zu_L%d", c->fam, c->w, c->h, c->levels);
    const size_t n = c->w * c->h, bytes = n * sizeof(float);
    float *img = load(tag, "img", c->w, c->h), *fwd = load(tag, "fwd", c->w, c->h);
    float *coef = load(tag, "coef", c->w, c->h), *inv = load(tag, "inv", c->w, c->h);
    CHECK(img && fwd && coef && inv, "%s: reference files load", tag);
    if (!img || !fwd || !coef || !inv)
        goto out;
    csi_wavelet_family f;
    CHECK_OK(csi_wavelet_parse(c->fam, &f));
    csi_linop *op = NULL;
    csi_status st = csi_wavelet_create(ctx, f, c->w, c->h, c->levels, &op);
    CHECK(st == CSI_OK, "%s: create: %s", tag, csi_last_error());
    if (st != CSI_OK)
        goto out;
    CHECK(op->rows == n && op->cols == n && !op->complex_valued, "%s: operator shape", tag);
    size_t cw, ch;
    csi_wavelet_coarse_block(op, &cw, &ch);
    CHECK(cw == c->w >> c->levels && ch == c->h >> c->levels, "%s: coarse block %zux%zu", tag, cw, ch);

    cl_mem dimg = test_upload(img, bytes), dcoef = test_upload(coef, bytes);
    cl_mem out = test_alloc(bytes), back = test_alloc(bytes);
    float *got = malloc(bytes), *got2 = malloc(bytes), *again = malloc(bytes);

    /* Forward (analysis, the adjoint) against wavedec2 + coeffs_to_array. */
    CHECK_OK(csi_linop_adjoint(op, dimg, out));
    test_download(out, got, bytes);
    check_close("forward", tag, c->levels, got, fwd, n);
    /* The input is left untouched. */
    test_download(dimg, again, bytes);
    CHECK(memcmp(again, img, bytes) == 0, "%s: forward modified its input", tag);

    /* inverse(forward(x)) = x. */
    CHECK_OK(csi_linop_apply(op, out, back));
    test_download(back, again, bytes);
    check_close("inv(fwd(x))", tag, c->levels, again, img, n);

    /* Inverse (synthesis, apply) against waverec2 of an arbitrary coefficient array. */
    CHECK_OK(csi_linop_apply(op, dcoef, back));
    test_download(back, got2, bytes);
    check_close("inverse", tag, c->levels, got2, inv, n);
    test_download(dcoef, again, bytes);
    CHECK(memcmp(again, coef, bytes) == 0, "%s: inverse modified its input", tag);

    /* Adjoint identity <Psi c, x> = <c, Psi^T x> with c = coef, x = img: got2 = Psi c,
     * got = Psi^T x. Cauchy-Schwarz scale: each side's rounding is bounded by the relative
     * error of the transform (tolerance above) times ||c|| ||x||. */
    double lhs = dot(got2, img, n), rhs = dot(coef, got, n);
    double scale = norm(coef, n) * norm(img, n);
    CHECK(fabs(lhs - rhs) <= 1e-6 * c->levels * scale, "%s: <Psi c, x> = %.9g, <c, Psi^T x> = %.9g",
          tag, lhs, rhs);
    /* Orthonormal: energy preserved (Parseval), same bound. */
    double e0 = norm(img, n), e1 = norm(got, n);
    CHECK(fabs(e1 - e0) <= 1e-6 * c->levels * e0, "%s: ||Psi^T x|| = %.9g vs ||x|| = %.9g", tag, e1, e0);

    /* In place (documented as allowed): same results as out of place, bit for bit. In place runs
     * the pass kernels level by level; out of place, the fused levels (both passes of a level in
     * one launch) wherever a band fits the device's local memory, every case here: this compares
     * the two paths. */
    cl_mem inplace = test_upload(img, bytes);
    CHECK_OK(csi_linop_adjoint(op, inplace, inplace));
    test_download(inplace, again, bytes);
    CHECK(memcmp(again, got, bytes) == 0, "%s: in-place forward differs from out of place", tag);
    csi_buffer_release(&inplace);
    inplace = test_upload(coef, bytes);
    CHECK_OK(csi_linop_apply(op, inplace, inplace));
    test_download(inplace, again, bytes);
    CHECK(memcmp(again, got2, bytes) == 0, "%s: in-place inverse differs from out of place", tag);
    csi_buffer_release(&inplace);

    /* Deterministic: a second run gives the same bits. */
    CHECK_OK(csi_linop_adjoint(op, dimg, out));
    test_download(out, again, bytes);
    CHECK(memcmp(again, got, bytes) == 0, "%s: forward not deterministic", tag);

    free(got);
    free(got2);
    free(again);
    csi_buffer_release(&dimg);
    csi_buffer_release(&dcoef);
    csi_buffer_release(&out);
    csi_buffer_release(&back);
    csi_linop_free(op);
out:
    free(img);
    free(fwd);
    free(coef);
    free(inv);
}

/* Plain C, double precision: one periodized analysis step of length n along a strided line,
 * PyWavelets' formula a[o] = sum_j lo[j] x[(2o + F/2 - j) mod n]. */
static void ref_fwd_line(double *v, size_t n, size_t step, const double *lo, const double *hi, int F,
                         double *tmp)
{
    for (size_t o = 0; o < n / 2; o++) {
        double a = 0, d = 0;
        for (int j = 0; j < F; j++) {
            long idx = ((long)(2 * o) + F / 2 - j) % (long)n;
            if (idx < 0)
                idx += (long)n;
            a += lo[j] * v[(size_t)idx * step];
            d += hi[j] * v[(size_t)idx * step];
        }
        tmp[o] = a;
        tmp[n / 2 + o] = d;
    }
    for (size_t i = 0; i < n; i++)
        v[i * step] = tmp[i];
}

static void ref_fwd2(double *img, size_t w, size_t h, int levels, const double *lo, const double *hi,
                     int F)
{
    double *tmp = malloc((w > h ? w : h) * sizeof *tmp);
    for (int l = 0; l < levels; l++) {
        size_t n = w >> l, m = h >> l;
        for (size_t y = 0; y < m; y++)
            ref_fwd_line(img + y * w, n, 1, lo, hi, F, tmp);
        for (size_t x = 0; x < n; x++)
            ref_fwd_line(img + x, m, w, lo, hi, F, tmp);
    }
    free(tmp);
}

/* Larger sizes (many work-groups per pass, non-power-of-two sides) against the C reference; the
 * inverse is checked through inv(fwd(x)) = x and the adjoint identity. */
static void test_large(const char *fam, size_t w, size_t h, int levels)
{
    csi_ctx *ctx = test_ctx();
    char tag[64], path[64];
    snprintf(tag, sizeof tag, "%s_%zux%zu_L%d", fam, w, h, levels);
    snprintf(path, sizeof path, "wavelet/filters_%s.npy", fam);
    test_npy fl;
    if (!test_npy_load(path, &fl)) {
        CHECK(0, "%s loads", path);
        return;
    }
    const int F = (int)fl.shape[1];
    double *filt = test_npy_f64(&fl);
    test_npy_free(&fl);
    csi_wavelet_family f;
    CHECK_OK(csi_wavelet_parse(fam, &f));
    CHECK(F == csi_wavelet_taps(f), "%s: %d taps", fam, F);
    const size_t n = w * h, bytes = n * sizeof(float);
    float *img = malloc(bytes), *got = malloc(bytes), *back = malloc(bytes), *want = malloc(bytes);
    double *ref = malloc(n * sizeof *ref);
    test_rng r;
    test_rng_seed(&r, 7);
    for (size_t i = 0; i < n; i++) {
        img[i] = (float)test_rng_normal(&r);
        ref[i] = img[i];
    }
    ref_fwd2(ref, w, h, levels, filt, filt + F, F);
    for (size_t i = 0; i < n; i++)
        want[i] = (float)ref[i];

    csi_linop *op = NULL;
    csi_status st = csi_wavelet_create(ctx, f, w, h, levels, &op);
    CHECK(st == CSI_OK, "%s: create: %s", tag, csi_last_error());
    if (st == CSI_OK) {
        cl_mem d = test_upload(img, bytes), c = test_alloc(bytes), b = test_alloc(bytes);
        CHECK_OK(csi_linop_adjoint(op, d, c));
        test_download(c, got, bytes);
        check_close("forward (C ref)", tag, levels, got, want, n);
        CHECK_OK(csi_linop_apply(op, c, b));
        test_download(b, back, bytes);
        check_close("inv(fwd(x))", tag, levels, back, img, n);
        /* <Psi (Psi^T x), x> = ||x||^2 for an orthonormal Psi. */
        double lhs = dot(back, img, n), rhs = dot(img, img, n);
        CHECK(fabs(lhs - rhs) <= 1e-6 * levels * rhs, "%s: <Psi Psi^T x, x> = %.9g vs %.9g", tag, lhs, rhs);
        csi_buffer_release(&d);
        csi_buffer_release(&c);
        csi_buffer_release(&b);
        csi_linop_free(op);
    }
    free(filt);
    free(img);
    free(got);
    free(back);
    free(want);
    free(ref);
}

static void test_errors(void)
{
    csi_ctx *ctx = test_ctx();
    csi_linop *op = (csi_linop *)1;
    csi_status st;

    /* Not divisible by 2^levels: 100 = 4 * 25 allows 2 levels, not 3. */
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 100, 64, 3, &op);
    CHECK(st == CSI_ERR_ARG && op == NULL, "100x64 L3 refused");
    CHECK(strstr(csi_last_error(), "100x64") && strstr(csi_last_error(), "3 levels"), "message: %s",
          csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB8, 64, 63, 1, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "64x63"), "odd side: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB8, 8, 8, 4, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "8x8"), "2^4 > 8: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB8, 64, 64, 0, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "64x64") && strstr(csi_last_error(), "0 levels"),
          "zero levels: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB8, 64, 64, -2, &op);
    CHECK(st == CSI_ERR_ARG, "negative levels: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 0, 64, 1, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "0x64"), "zero width: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 64, 0, 1, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "64x0"), "zero height: %s", csi_last_error());
    st = csi_wavelet_create(ctx, (csi_wavelet_family)6, 64, 64, 1, &op);
    CHECK(st == CSI_ERR_ARG, "unknown family: %s", csi_last_error());
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 1u << 20, 1u << 20, 1, &op);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "1048576x1048576"), "huge: %s", csi_last_error());
    /* Too large for one device buffer: 32768 x 16384 floats = 2 GiB over a 1 GiB limit set here
     * (the device's own depends on the memory free when PoCL starts: 1 to 4 GiB seen). */
    CHECK_OK(csi_ctx_limit_memory(ctx, 1ull << 30, 0));
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 32768, 16384, 1, &op);
    CHECK(st == CSI_ERR_DEVICE && op == NULL, "over the buffer limit: %s", csi_last_error());

    /* Names and parsing. */
    csi_wavelet_family f = CSI_WAVELET_DB4;
    CHECK(csi_wavelet_parse("db8", &f) == CSI_OK && f == CSI_WAVELET_DB8, "parse db8");
    CHECK(csi_wavelet_parse("db4", &f) == CSI_OK && f == CSI_WAVELET_DB4, "parse db4");
    st = csi_wavelet_parse("haar", &f);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "haar") && strstr(csi_last_error(), "db8"),
          "parse haar: %s", csi_last_error());
    CHECK(csi_wavelet_parse("DB4", &f) == CSI_ERR_ARG, "names are lower case");
    CHECK(csi_wavelet_parse(NULL, &f) == CSI_ERR_ARG, "NULL name");
    CHECK(strcmp(csi_wavelet_name(CSI_WAVELET_DB4), "db4") == 0, "name db4");
    CHECK(strcmp(csi_wavelet_name(CSI_WAVELET_DB8), "db8") == 0, "name db8");
    CHECK(csi_wavelet_taps(CSI_WAVELET_DB4) == 8 && csi_wavelet_taps(CSI_WAVELET_DB8) == 16, "taps");
}

/* The documented rule: min(pywt.dwt_max_level(min(w, h), taps), common factors of two), at least 1
 * on even sides, 0 when impossible. pywt.dwt_max_level(n, F) = floor(log2(n / (F - 1))). */
static void test_default_levels(void)
{
    struct {
        csi_wavelet_family f;
        size_t w, h;
        int want;
    } t[] = {
        {CSI_WAVELET_DB4, 64, 64, 3},       /* log2(64/7) = 3.19 */
        {CSI_WAVELET_DB8, 64, 64, 2},       /* log2(64/15) = 2.09 */
        {CSI_WAVELET_DB8, 1024, 1024, 6},   /* log2(1024/15) = 6.09 */
        {CSI_WAVELET_DB4, 2048, 2048, 8},   /* log2(2048/7) = 8.19 */
        {CSI_WAVELET_DB4, 96, 64, 3},       /* min side 64 */
        {CSI_WAVELET_DB4, 1536, 1024, 7},   /* log2(1024/7) = 7.19; 1536 = 3 * 2^9 */
        {CSI_WAVELET_DB8, 48, 48, 1},       /* log2(48/15) = 1.68 */
        {CSI_WAVELET_DB4, 12, 6, 1},        /* 6 < 7: band shorter than the filter, still 1 */
        {CSI_WAVELET_DB4, 1000, 1000, 3},   /* 1000 = 8 * 125: divisibility limits to 3 */
        {CSI_WAVELET_DB8, 63, 64, 0},       /* odd side */
        {CSI_WAVELET_DB8, 0, 64, 0},
    };
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++) {
        int got = csi_wavelet_default_levels(t[i].f, t[i].w, t[i].h);
        CHECK(got == t[i].want, "default levels %s %zux%zu: %d, want %d", csi_wavelet_name(t[i].f),
              t[i].w, t[i].h, got, t[i].want);
    }
}

int main(void)
{
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        test_reference_case(&cases[i]);
    test_large("db8", 512, 384, 7);
    test_large("db4", 320, 256, 6);
    test_errors();
    test_default_levels();
    return test_done();
}
