/* Alg. 1's model grid (csi/model_grid.h, host/ops/model_grid.c) and the filter with a complex
 * factor it rests on (csi_filter_create_factor), under PoCL, against the exact fine-grid model
 * made by numpy and PyWavelets in float64 (tests/data/interp/gen_refs.py): the Wiener inverse
 * of the Gaussian on the fine grid applied to d levels of wavelet synthesis of the model image,
 * read at random fine cells or box-averaged over output pixels.
 *
 * Tolerances. The model grid approximates that operator: gen_refs.py --measure gives relative L2
 * errors of 0.6-1e-5 on the image cases and 2.2e-5 on white noise (the worst case: a flat
 * spectrum up to the model grid's Nyquist frequency) with csi's kernel; float32 adds ~1e-6. We
 * allow 5e-5, about twice the worst measured. The unit factor must reproduce the plain filter
 * bit for bit (the complex gain path then multiplies by exactly 1 and adds exactly 0). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/interp.h"
#include "csi/model_grid.h"
#include "csi/spectral.h"
#include "testlib.h"

struct mcase {
    const char *name;
    size_t fw, fh;
    unsigned D;
    double sigma[2];
    float lambda;
    csi_wavelet_family family;
};

static const struct mcase cases[] = {
    {"m64x48_D2", 64, 48, 2, {3.2, 3.2}, 0.3f, CSI_WAVELET_DB4},
    {"m64x48_D2n", 64, 48, 2, {3.2, 3.2}, 0.3f, CSI_WAVELET_DB4},
    {"m128x64_D4", 128, 64, 4, {6.4, 6.4}, 0.3f, CSI_WAVELET_DB4},
    {"m64x64_D2db8", 64, 64, 2, {3.0, 4.0}, 0.3f, CSI_WAVELET_DB8},
};

static double ddot(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * b[i];
    return s;
}

static uint32_t *load_idx(const char *name, size_t *n)
{
    char path[128];
    test_npy a;
    snprintf(path, sizeof path, "interp/%s_idx.npy", name);
    if (!test_npy_load(path, &a))
        return NULL;
    double *d = test_npy_f64(&a);
    uint32_t *idx = malloc(a.count * sizeof *idx);
    for (size_t i = 0; i < a.count; i++)
        idx[i] = (uint32_t)d[i];
    *n = a.count;
    free(d);
    test_npy_free(&a);
    return idx;
}

static float *load_f32(const char *name, const char *part, size_t *n)
{
    char path[128];
    test_npy a;
    snprintf(path, sizeof path, "interp/%s_%s.npy", name, part);
    if (!test_npy_load(path, &a))
        return NULL;
    float *f = test_npy_f32(&a);
    if (n)
        *n = a.count;
    test_npy_free(&a);
    return f;
}

/* y = I(W(g)) for the model grid filter with the given box and reading positions idx. */
static float *model_read(csi_ctx *ctx, const struct mcase *mc, const float *g, unsigned bx, unsigned by,
                         const uint32_t *idx, size_t n)
{
    const size_t mw = mc->fw / mc->D, mh = mc->fh / mc->D, k = mw * mh;
    csi_linop *W = NULL, *I = NULL;
    CHECK_OK(csi_model_filter_create(ctx, mw, mh, mc->D, mc->sigma, mc->lambda, mc->family, bx, by, &W));
    CHECK_OK(csi_interp_create(ctx, mw, mh, mc->D, idx, n, &I));
    float *y = NULL;
    if (W && I) {
        cl_mem dg = test_upload(g, k * 4), dc = test_alloc(k * 4), dy = test_alloc(n * 4);
        CHECK_OK(csi_linop_apply(W, dg, dc));
        CHECK_OK(csi_linop_apply(I, dc, dy));
        y = malloc(n * 4);
        test_download(dy, y, n * 4);
        /* The filter's adjoint (conjugated factor) against its apply, in double. */
        float *r = malloc(k * 4), *fg = malloc(k * 4), *ar = malloc(k * 4);
        test_rng rng;
        test_rng_seed(&rng, 7);
        for (size_t i = 0; i < k; i++)
            r[i] = (float)test_rng_normal(&rng);
        cl_mem dr = test_upload(r, k * 4), dar = test_alloc(k * 4);
        CHECK_OK(csi_linop_adjoint(W, dr, dar));
        test_download(dc, fg, k * 4);
        test_download(dar, ar, k * 4);
        double lhs = ddot(fg, r, k), rhs = ddot(g, ar, k);
        double scale = sqrt(ddot(fg, fg, k) * ddot(r, r, k));
        CHECK(fabs(lhs - rhs) <= 1e-5 * scale, "%s box %ux%u: filter adjoint identity %.9g vs %.9g",
              mc->name, bx, by, lhs, rhs);
        free(r);
        free(fg);
        free(ar);
        csi_buffer_release(&dr);
        csi_buffer_release(&dar);
        csi_buffer_release(&dg);
        csi_buffer_release(&dc);
        csi_buffer_release(&dy);
    }
    csi_linop_free(W);
    csi_linop_free(I);
    return y;
}

static void test_samples(csi_ctx *ctx, const struct mcase *mc)
{
    size_t n = 0, ng = 0, ny = 0;
    uint32_t *idx = load_idx(mc->name, &n);
    float *g = load_f32(mc->name, "g", &ng), *yref = load_f32(mc->name, "y", &ny);
    CHECK(idx && g && yref && ny == n, "reference files for %s", mc->name);
    if (idx && g && yref) {
        float *y = model_read(ctx, mc, g, 1, 1, idx, n);
        if (y) {
            double e = test_rel_l2(y, yref, n);
            CHECK(e < 5e-5, "%s: model grid within 5e-5 of the fine-grid model (rel L2 %.2e)", mc->name, e);
            printf("%s: %zu samples, rel L2 error against the fine-grid model %.2e\n", mc->name, n, e);
            free(y);
        }
    }
    free(idx);
    free(g);
    free(yref);
}

static void test_box(csi_ctx *ctx, const char *bname, const struct mcase *mc, unsigned bx, unsigned by)
{
    float *g = load_f32(mc->name, "g", NULL), *oref = NULL;
    size_t np = 0;
    oref = load_f32(bname, "out", &np);
    CHECK(g && oref, "reference files for %s", bname);
    const size_t ow = mc->fw / bx, oh = mc->fh / by;
    if (g && oref && np == ow * oh) {
        uint32_t *idx = malloc(np * sizeof *idx);
        for (size_t Y = 0; Y < oh; Y++)
            for (size_t X = 0; X < ow; X++)
                idx[Y * ow + X] = (uint32_t)(Y * by * mc->fw + X * bx);
        float *o = model_read(ctx, mc, g, bx, by, idx, np);
        if (o) {
            double e = test_rel_l2(o, oref, np);
            CHECK(e < 5e-5, "%s: box means within 5e-5 of the fine-grid model's (rel L2 %.2e)", bname, e);
            printf("%s: %zux%zu pixels, rel L2 error %.2e\n", bname, ow, oh, e);
            free(o);
        }
        free(idx);
    }
    free(g);
    free(oref);
}

/* A unit factor gives the plain filter's bits. */
static void test_unit_factor(csi_ctx *ctx)
{
    const size_t w = 48, h = 32, k = w * h, dims[3] = {w, h, 1};
    const double sig[3] = {1.3, 2.1, 0};
    double *fx = calloc(2 * (w / 2 + 1), sizeof *fx), *fy = calloc(2 * h, sizeof *fy);
    for (size_t i = 0; i <= w / 2; i++)
        fx[2 * i] = 1.0;
    for (size_t i = 0; i < h; i++)
        fy[2 * i] = 1.0;
    csi_linop *A = NULL, *B = NULL;
    CHECK_OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_WIENER, 0.3f, &A));
    CHECK_OK(csi_filter_create_factor(ctx, dims, sig, CSI_FILTER_WIENER, 0.3f, fx, fy, &B));
    if (A && B) {
        float *x = malloc(k * 4), *ya = malloc(k * 4), *yb = malloc(k * 4), *yc = malloc(k * 4);
        test_rng rng;
        test_rng_seed(&rng, 3);
        for (size_t i = 0; i < k; i++)
            x[i] = (float)test_rng_normal(&rng);
        cl_mem dx = test_upload(x, k * 4), da = test_alloc(k * 4), db = test_alloc(k * 4), dc = test_alloc(k * 4);
        CHECK_OK(csi_linop_apply(A, dx, da));
        CHECK_OK(csi_linop_apply(B, dx, db));
        CHECK_OK(csi_linop_adjoint(B, dx, dc));
        test_download(da, ya, k * 4);
        test_download(db, yb, k * 4);
        test_download(dc, yc, k * 4);
        CHECK(memcmp(ya, yb, k * 4) == 0, "unit factor: the plain filter's bits (apply)");
        CHECK(memcmp(ya, yc, k * 4) == 0, "unit factor: the plain filter's bits (adjoint)");
        free(x);
        free(ya);
        free(yb);
        free(yc);
        csi_buffer_release(&dx);
        csi_buffer_release(&da);
        csi_buffer_release(&db);
        csi_buffer_release(&dc);
    }
    csi_linop_free(A);
    csi_linop_free(B);
    const size_t d3[3] = {w, h, 4};
    csi_linop *C = (csi_linop *)1;
    CHECK(csi_filter_create_factor(ctx, d3, sig, CSI_FILTER_WIENER, 0.3f, fx, fy, &C) == CSI_ERR_ARG && !C,
          "a 3-D filter with a factor is refused");
    free(fx);
    free(fy);
}

static void test_factor_rule(void)
{
    const double s32[2] = {3.2, 3.2}, s22[2] = {2.2, 2.2}, s64[2] = {6.4, 6.4}, s13[2] = {3.2, 13.0};
    CHECK(csi_model_grid_factor(2048, 2048, s32, 5, CSI_MODEL_SIGMA_MIN) == 2, "4 spp on 8x: sigma 3.2 -> D = 2");
    CHECK(csi_model_grid_factor(2048, 2048, s22, 5, CSI_MODEL_SIGMA_MIN) == 1, "sigma 2.2 -> the fine grid");
    CHECK(csi_model_grid_factor(2048, 2048, s64, 5, CSI_MODEL_SIGMA_MIN) == 4, "sigma 6.4 -> D = 4");
    CHECK(csi_model_grid_factor(2048, 2048, s64, 2, CSI_MODEL_SIGMA_MIN) == 2, "two levels keep one on the model grid");
    CHECK(csi_model_grid_factor(2048, 2048, s64, 1, CSI_MODEL_SIGMA_MIN) == 1, "one level: the fine grid");
    CHECK(csi_model_grid_factor(2048, 2048, s13, 5, CSI_MODEL_SIGMA_MIN) == 2, "the narrower axis decides");
    CHECK(csi_model_grid_factor(2050, 2048, s64, 5, CSI_MODEL_SIGMA_MIN) == 1, "2050 / 2 is odd: no real FFT on it");
    CHECK(csi_model_grid_factor(15360, 8640, s32, 5, CSI_MODEL_SIGMA_MIN) == 2, "1920x1080 at 8x: D = 2");
    /* --model-sigma-min 0.75 (a band-limited model below CSI_MODEL_SIGMA_MIN): 3.2 / 4 = 0.8 */
    CHECK(csi_model_grid_factor(15360, 8640, s32, 5, 0.75) == 4, "1920x1080 at 8x, sigma_min 0.75: D = 4");
    CHECK(csi_model_grid_factor(2048, 2048, s22, 5, 0.75) == 2, "sigma 2.2, sigma_min 0.75: D = 2 (1.1 cells)");
    CHECK(csi_model_grid_factor(2048, 2048, s64, 5, 0.75) == 8, "sigma 6.4, sigma_min 0.75: D = 8");
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    test_factor_rule();
    test_unit_factor(ctx);
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        test_samples(ctx, &cases[i]);
    test_box(ctx, "b64x48_D2", &cases[0], 8, 8);
    test_box(ctx, "b128x64_D4", &cases[2], 8, 16);
    return test_done();
}
