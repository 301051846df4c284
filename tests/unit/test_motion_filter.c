/* The Gaussian along the motion (csi_motion_filter_create) under PoCL: against numpy references
 * (tests/data/motion/gen_refs.py: the full complex spectrum of each aligned frame, the Gaussian
 * gain, scipy's DCT or numpy's FFT along t), symmetry <G a, b> = <a, G b>, the self weight
 * (csi_motion_filter_self_weight, closed form) against the filtered unit impulse in every frame,
 * the DFT at v = 0 against csi_filter_create's GAUSS (an independent implementation of the same
 * periodic filter), the filter from the frames' spatial spectra (csi_motion_filter_apply_spatial,
 * the velocity search's path) against the same references and the whole apply's bits, and bad
 * widths.
 *
 * Tolerances: a filter pass is two transforms (2e-5 each in test_motion_basis.c) and one product
 * per coefficient: 4e-5 relative L2 against float64 references rounded to float32; identities
 * between double sums of float products 1e-5; the self weight is one entry of a float32 volume
 * of magnitude ~1: 1e-5 of the kernel's peak. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/motion_filter.h"
#include "testlib.h"

struct fcase {
    const char *name;
    size_t dims[3];
    csi_time_transform t;
    double vx, vy, sxy, st;
};

static const struct fcase cases[] = {
    {"g16x12x8_dct", {16, 12, 8}, CSI_TIME_DCT, 0.7, -0.3, 1.1, 2.0},
    {"g24x16x6_dft", {24, 16, 6}, CSI_TIME_DFT, 1.5, 0.5, 0.8, 1.5},
    {"g32x1x8_dct", {32, 1, 8}, CSI_TIME_DCT, -1.2, 0.0, 1.3, 3.0},
};

typedef struct {
    csi_fourier_half *h;
    cl_mem z;
    csi_linop *G;
} filt;

static bool make(csi_ctx *ctx, const size_t dims[3], csi_time_transform t, double vx, double vy,
                 double sxy, double st, filt *f)
{
    memset(f, 0, sizeof *f);
    CHECK_OK(csi_fourier_half_create(ctx, dims, &f->h));
    if (!f->h)
        return false;
    CHECK_OK(csi_fourier_half_set_motion(f->h, dims, t, vx, vy));
    f->z = test_alloc(csi_fourier_half_count(f->h) * 8);
    CHECK_OK(csi_motion_filter_create(ctx, f->h, dims, t, sxy, st, f->z, &f->G));
    return f->G != NULL;
}

static void unmake(filt *f)
{
    csi_linop_free(f->G);
    csi_buffer_release(&f->z);
    csi_fourier_half_free(f->h);
}

static void run(const csi_linop *G, const float *x, float *y)
{
    const size_t n = G->cols;
    cl_mem dx = test_upload(x, n * 4), dy = test_alloc(n * 4);
    CHECK_OK(csi_linop_apply(G, dx, dy));
    test_download(dy, y, n * 4);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
}

static void check_case(csi_ctx *ctx, const struct fcase *c)
{
    char path[128];
    test_npy ax, ay;
    snprintf(path, sizeof path, "motion/%s_x.npy", c->name);
    bool ok = test_npy_load(path, &ax);
    snprintf(path, sizeof path, "motion/%s_y.npy", c->name);
    ok = test_npy_load(path, &ay) && ok;
    CHECK(ok, "%s: reference vectors load", c->name);
    filt f;
    if (!ok || !make(ctx, c->dims, c->t, c->vx, c->vy, c->sxy, c->st, &f)) {
        if (ok) {
            test_npy_free(&ax);
            test_npy_free(&ay);
            unmake(&f);
        }
        return;
    }
    const size_t n = c->dims[0] * c->dims[1] * c->dims[2], T = c->dims[2];
    float *x = test_npy_f32(&ax), *want = test_npy_f32(&ay), *y = malloc(n * 4), *b = malloc(n * 4),
          *gb = malloc(n * 4);
    run(f.G, x, y);
    double e = test_rel_l2(y, want, n);
    CHECK(e < 4e-5, "%s vs reference: rel L2 %.3g", c->name, e);

    /* from the frames' spatial spectra, made while the basis was in another state (the still
     * DFT, then another velocity): the spatial stage does not depend on it, so the reference
     * again, and the same kernels in the same order as the whole apply, so its very bits */
    {
        cl_mem dx = test_upload(x, n * 4), dy = test_alloc(n * 4);
        cl_mem zs = test_alloc(csi_fourier_half_count(f.h) * 8);
        CHECK_OK(csi_fourier_half_set_motion(f.h, c->dims, CSI_TIME_DFT, 0, 0));
        CHECK_OK(csi_fourier_half_forward_space(f.h, dx, zs));
        CHECK_OK(csi_fourier_half_set_motion(f.h, c->dims, CSI_TIME_DCT, c->vx + 0.5, c->vy));
        CHECK_OK(csi_motion_filter_apply_spatial(f.G, zs, dy)); /* another state: not checked */
        CHECK_OK(csi_fourier_half_set_motion(f.h, c->dims, c->t, c->vx, c->vy));
        CHECK_OK(csi_motion_filter_apply_spatial(f.G, zs, dy));
        float *ys = malloc(n * 4);
        test_download(dy, ys, n * 4);
        double es = test_rel_l2(ys, want, n);
        CHECK(es < 4e-5, "%s from spatial spectra vs reference: rel L2 %.3g", c->name, es);
        CHECK(memcmp(ys, y, n * 4) == 0, "%s from spatial spectra: the whole apply's bits", c->name);
        /* the filter's own scratch cannot hold them: the time stage writes it */
        CHECK(csi_motion_filter_apply_spatial(f.G, f.z, dy) == CSI_ERR_ARG, "%s: scratch as spectra refused", c->name);
        free(ys);
        csi_buffer_release(&zs);
        csi_buffer_release(&dx);
        csi_buffer_release(&dy);
    }

    /* symmetry */
    test_rng r;
    test_rng_seed(&r, 5);
    for (size_t i = 0; i < n; i++)
        b[i] = (float)test_rng_normal(&r);
    run(f.G, b, gb);
    double l = 0, rr = 0, na = 0, nb = 0;
    for (size_t i = 0; i < n; i++) {
        l += (double)y[i] * b[i];
        rr += (double)x[i] * gb[i];
        na += (double)x[i] * x[i];
        nb += (double)b[i] * b[i];
    }
    CHECK(fabs(l - rr) <= 1e-5 * sqrt(na * nb), "%s symmetric: %.9g vs %.9g", c->name, l, rr);

    /* self weight: the impulse at (x0, y0, t) filtered, read back at itself, for every t */
    double *w0 = malloc(T * sizeof *w0), worst = 0, peak = 0;
    csi_motion_filter_self_weight(c->dims, c->t, c->sxy, c->st, w0);
    const size_t wh = c->dims[0] * c->dims[1], at = c->dims[0] / 3 + c->dims[0] * (c->dims[1] / 2);
    for (size_t t = 0; t < T; t++) {
        memset(b, 0, n * 4);
        b[t * wh + at] = 1.0f;
        run(f.G, b, gb);
        worst = fmax(worst, fabs(gb[t * wh + at] - w0[t]));
        peak = fmax(peak, w0[t]);
    }
    CHECK(worst <= 1e-5 * peak, "%s self weight: off by %.3g (peak %.3g)", c->name, worst, peak);
    printf("%s: rel L2 %.2e symmetry gap %.2e self weight %.2e\n", c->name, e,
           fabs(l - rr) / sqrt(na * nb), worst / peak);
    free(w0);
    free(x);
    free(want);
    free(y);
    free(b);
    free(gb);
    test_npy_free(&ax);
    test_npy_free(&ay);
    unmake(&f);
}

/* v = 0, DFT: csi_filter_create's periodic 3-D Gaussian (its sigma_phi is the spatial width) */
static void check_plain(csi_ctx *ctx)
{
    const size_t dims[3] = {24, 16, 8}, n = 24 * 16 * 8;
    filt f;
    csi_linop *G = NULL;
    const double s[3] = {1.3, 1.3, 0.9};
    CHECK_OK(csi_filter_create(ctx, dims, s, CSI_FILTER_GAUSS, 1.0f, &G));
    if (!make(ctx, dims, CSI_TIME_DFT, 0, 0, 1.3, 0.9, &f) || !G) {
        unmake(&f);
        csi_linop_free(G);
        return;
    }
    float *x = malloc(n * 4), *a = malloc(n * 4), *b = malloc(n * 4);
    test_rng r;
    test_rng_seed(&r, 9);
    for (size_t i = 0; i < n; i++)
        x[i] = (float)test_rng_normal(&r);
    run(f.G, x, a);
    run(G, x, b);
    double e = test_rel_l2(a, b, n);
    CHECK(e < 4e-5, "v = 0 DFT vs csi_filter_create: rel L2 %.3g", e);
    free(x);
    free(a);
    free(b);
    /* bad widths */
    csi_linop *bad = NULL;
    CHECK(csi_motion_filter_create(ctx, f.h, dims, CSI_TIME_DFT, 0.0, 1.0, f.z, &bad) == CSI_ERR_ARG &&
              bad == NULL, "zero spatial width refused");
    CHECK(csi_motion_filter_create(ctx, f.h, dims, CSI_TIME_DFT, 1.0, NAN, f.z, &bad) == CSI_ERR_ARG,
          "NaN width refused");
    const size_t other[3] = {24, 16, 4};
    CHECK(csi_motion_filter_create(ctx, f.h, other, CSI_TIME_DFT, 1.0, 1.0, f.z, &bad) == CSI_ERR_ARG,
          "another volume's size refused");
    unmake(&f);
    csi_linop_free(G);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        check_case(ctx, &cases[i]);
    check_plain(ctx);
    return test_done();
}
