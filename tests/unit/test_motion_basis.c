/* Alg. 2's motion basis (csi_fourier_half_set_motion: the half-spectrum Fourier basis with a
 * shear and a DFT / DCT-II / no transform along t) under PoCL, against numpy / scipy references
 * (tests/data/motion/gen_refs.py: rfftn, the shear phase, np.fft.fft or scipy.fft.dct along t,
 * computed without csi's R2C packing, Stockham passes or Makhoul reordering): forward of a random
 * real volume, synthesis (the real adjoint) of random coefficients, on sizes with even and odd T
 * (radices 2, 3, 5, 7 along t), a squeezed y (x and t only) and a squeezed x (y is the half
 * axis); then the adjoint identity, the round trip with the inner planes doubled, the plain DFT
 * at v = 0 bit for bit the basis without a time stage, changing the velocity, and bad input.
 *
 * Tolerances as in test_fourier.c: a float32 FFT of N points has relative L2 error ~ c eps log2 N
 * (Higham, Sec. 24.1); the time stage adds at most two element-wise complex products and one
 * two-term sum per coefficient (a few eps), so 2e-5 for one transform against the float64
 * reference rounded to float32 (as for the half basis without a time stage), and 1e-5 relative
 * for identities between double sums of float products. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/spectral.h"
#include "testlib.h"

struct mcase {
    const char *name;
    size_t dims[3];
    csi_time_transform t;
    double vx, vy;
};

static const struct mcase cases[] = {
    {"m16x12x8_dct", {16, 12, 8}, CSI_TIME_DCT, 0.7, -0.3},
    {"m16x12x8_dft", {16, 12, 8}, CSI_TIME_DFT, 0.7, -0.3},
    {"m16x12x8_none", {16, 12, 8}, CSI_TIME_NONE, -1.3, 0.45},
    {"m24x16x6_dct", {24, 16, 6}, CSI_TIME_DCT, 2.5, 1.25},
    {"m20x10x5_dct", {20, 10, 5}, CSI_TIME_DCT, -0.35, 0.8},
    {"m28x14x7_dct", {28, 14, 7}, CSI_TIME_DCT, 0.0, 0.0},
    {"m32x1x8_dct", {32, 1, 8}, CSI_TIME_DCT, 1.1, 0.0},
    {"m1x16x8_dft", {1, 16, 8}, CSI_TIME_DFT, 0.0, -0.9},
};

static void write_buf(cl_mem m, const void *p, size_t bytes) { CHECK_OK(csi_write(test_ctx(), m, 0, bytes, p)); }

/* Relative L2 distance between the padded layout z (rows of hs) and a dense reference (rows of
 * M + 1), and whether the padding is exactly zero. */
static double half_rel(const float *z, const float *ref, size_t rows, size_t hs, size_t m1, bool *pad0)
{
    double e2 = 0, n2 = 0;
    *pad0 = true;
    for (size_t r = 0; r < rows; r++)
        for (size_t u = 0; u < hs; u++) {
            const float *a = z + 2 * (r * hs + u);
            if (u >= m1) {
                *pad0 = *pad0 && a[0] == 0.0f && a[1] == 0.0f;
                continue;
            }
            const float *b = ref + 2 * (r * m1 + u);
            e2 += (double)(a[0] - b[0]) * (a[0] - b[0]) + (double)(a[1] - b[1]) * (a[1] - b[1]);
            n2 += (double)b[0] * b[0] + (double)b[1] * b[1];
        }
    return sqrt(e2 / n2);
}

static void check_case(csi_ctx *ctx, const struct mcase *c)
{
    char path[128];
    test_npy af, az, ac, ai;
    snprintf(path, sizeof path, "motion/%s_f.npy", c->name);
    bool ok = test_npy_load(path, &af);
    snprintf(path, sizeof path, "motion/%s_fwd.npy", c->name);
    ok = test_npy_load(path, &az) && ok;
    snprintf(path, sizeof path, "motion/%s_c.npy", c->name);
    ok = test_npy_load(path, &ac) && ok;
    snprintf(path, sizeof path, "motion/%s_inv.npy", c->name);
    ok = test_npy_load(path, &ai) && ok;
    CHECK(ok, "%s: reference vectors load", c->name);
    if (!ok)
        return;
    const size_t n = c->dims[0] * c->dims[1] * c->dims[2];
    csi_fourier_half *h = NULL;
    CHECK_OK(csi_fourier_half_create(ctx, c->dims, &h));
    if (!h)
        return;
    CHECK_OK(csi_fourier_half_set_motion(h, c->dims, c->t, c->vx, c->vy));
    const size_t hs = csi_fourier_half_stride(h), nz = csi_fourier_half_count(h), rows = nz / hs;
    const size_t m1 = az.shape[az.ndim - 1];
    CHECK(az.count == rows * m1 && af.count == n, "%s: reference shapes match the layout", c->name);
    float *f = test_npy_f32(&af), *zref = test_npy_f32(&az), *cc = test_npy_f32(&ac),
          *gref = test_npy_f32(&ai);
    float *z = malloc(nz * 8), *zp = calloc(2 * nz, sizeof *zp), *g = malloc(n * 4);
    cl_mem df = test_upload(f, n * 4), dz = test_alloc(nz * 8), dg = test_alloc(n * 4);

    /* forward against numpy / scipy */
    CHECK_OK(csi_fourier_half_forward(h, df, dz));
    test_download(dz, z, nz * 8);
    bool pad0;
    double ef = half_rel(z, zref, rows, hs, m1, &pad0);
    CHECK(ef < 2e-5, "%s forward vs reference: rel L2 %.3g", c->name, ef);
    CHECK(pad0, "%s forward: padding entries are zero", c->name);

    /* synthesis of random coefficients (garbage in the padding is ignored) */
    for (size_t r = 0; r < rows; r++)
        for (size_t u = 0; u < hs; u++) {
            float *a = zp + 2 * (r * hs + u);
            a[0] = u < m1 ? cc[2 * (r * m1 + u)] : 1e3f;
            a[1] = u < m1 ? cc[2 * (r * m1 + u) + 1] : -1e3f;
        }
    write_buf(dz, zp, nz * 8);
    CHECK_OK(csi_fourier_half_inverse(h, dz, dg));
    test_download(dg, g, n * 4);
    double ei = test_rel_l2(g, gref, n);
    CHECK(ei < 2e-5, "%s inverse vs reference: rel L2 %.3g", c->name, ei);

    /* adjoint identity <inverse(a), f> = Re <a, forward(f)> (a without padding garbage) */
    for (size_t r = 0; r < rows; r++)
        for (size_t u = m1; u < hs; u++)
            zp[2 * (r * hs + u)] = zp[2 * (r * hs + u) + 1] = 0.0f;
    double lhs = 0, rhs = 0, na = 0, nb = 0;
    write_buf(dz, zp, nz * 8);
    CHECK_OK(csi_fourier_half_inverse(h, dz, dg));
    test_download(dg, g, n * 4);
    for (size_t i = 0; i < n; i++) {
        lhs += (double)g[i] * f[i];
        nb += (double)f[i] * f[i];
    }
    for (size_t i = 0; i < 2 * nz; i++) {
        rhs += (double)zp[i] * z[i];
        na += (double)zp[i] * zp[i];
    }
    CHECK(fabs(lhs - rhs) <= 1e-5 * sqrt(na * nb), "%s adjoint identity: %.9g vs %.9g", c->name, lhs, rhs);

    /* round trip: the inner planes doubled (u0 = 1 .. M-1 along the half axis) give f back */
    const size_t M = m1 - 1;
    for (size_t r = 0; r < rows; r++)
        for (size_t u = 0; u < hs; u++) {
            float m = u == 0 || u == M ? 1.0f : u < M ? 2.0f : 0.0f;
            zp[2 * (r * hs + u)] = m * z[2 * (r * hs + u)];
            zp[2 * (r * hs + u) + 1] = m * z[2 * (r * hs + u) + 1];
        }
    write_buf(dz, zp, nz * 8);
    CHECK_OK(csi_fourier_half_inverse(h, dz, dg));
    test_download(dg, g, n * 4);
    double er = test_rel_l2(g, f, n);
    CHECK(er < 2e-5, "%s round trip: rel L2 %.3g", c->name, er);
    printf("%s: forward %.2e inverse %.2e round trip %.2e adjoint gap %.2e\n", c->name, ef, ei, er,
           fabs(lhs - rhs) / sqrt(na * nb));

    csi_buffer_release(&df);
    csi_buffer_release(&dz);
    csi_buffer_release(&dg);
    free(f);
    free(zref);
    free(cc);
    free(gref);
    free(z);
    free(zp);
    free(g);
    csi_fourier_half_free(h);
    test_npy_free(&af);
    test_npy_free(&az);
    test_npy_free(&ac);
    test_npy_free(&ai);
}

/* The paper's basis: DFT at v = 0 is csi_fourier_half without a time stage, bit for bit; a
 * velocity set and then reset to 0 gives those bits again. */
static void check_plain(csi_ctx *ctx)
{
    const size_t dims[3] = {24, 16, 8}, n = 24 * 16 * 8;
    csi_fourier_half *a = NULL, *b = NULL;
    CHECK_OK(csi_fourier_half_create(ctx, dims, &a));
    CHECK_OK(csi_fourier_half_create(ctx, dims, &b));
    if (!a || !b) {
        csi_fourier_half_free(a);
        csi_fourier_half_free(b);
        return;
    }
    const size_t nz = csi_fourier_half_count(a);
    test_rng r;
    test_rng_seed(&r, 77);
    float *f = malloc(n * 4), *za = malloc(nz * 8), *zb = malloc(nz * 8);
    for (size_t i = 0; i < n; i++)
        f[i] = (float)test_rng_normal(&r);
    cl_mem df = test_upload(f, n * 4), dz = test_alloc(nz * 8);
    CHECK_OK(csi_fourier_half_forward(a, df, dz));
    test_download(dz, za, nz * 8);
    CHECK_OK(csi_fourier_half_set_motion(b, dims, CSI_TIME_DFT, 1.5, -0.5));
    CHECK_OK(csi_fourier_half_forward(b, df, dz));
    test_download(dz, zb, nz * 8);
    CHECK(memcmp(za, zb, nz * 8) != 0, "a velocity changes the coefficients");
    CHECK_OK(csi_fourier_half_set_motion(b, dims, CSI_TIME_DFT, 0.0, 0.0));
    CHECK_OK(csi_fourier_half_forward(b, df, dz));
    test_download(dz, zb, nz * 8);
    CHECK(memcmp(za, zb, nz * 8) == 0, "DFT at v = 0 is the plain half basis, bit for bit");

    /* bad input: a different size, no time axis, a velocity that is not finite */
    const size_t other[3] = {24, 16, 4}, flat[3] = {24, 16, 1};
    CHECK(csi_fourier_half_set_motion(b, other, CSI_TIME_DCT, 0, 0) == CSI_ERR_ARG, "other size refused");
    csi_fourier_half *c = NULL;
    CHECK_OK(csi_fourier_half_create(ctx, flat, &c));
    if (c) {
        csi_status st = csi_fourier_half_set_motion(c, flat, CSI_TIME_DCT, 0, 0);
        CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "time axis"), "%s", csi_last_error());
    }
    CHECK(csi_fourier_half_set_motion(b, dims, CSI_TIME_DCT, NAN, 0) == CSI_ERR_ARG, "NaN velocity refused");
    csi_time_transform t;
    CHECK(csi_time_transform_parse("dct", &t) == CSI_OK && t == CSI_TIME_DCT, "parse dct");
    CHECK(csi_time_transform_parse("wavelet", &t) == CSI_ERR_ARG, "unknown name refused");
    csi_buffer_release(&df);
    csi_buffer_release(&dz);
    free(f);
    free(za);
    free(zb);
    csi_fourier_half_free(a);
    csi_fourier_half_free(b);
    csi_fourier_half_free(c);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        check_case(ctx, &cases[i]);
    check_plain(ctx);
    return test_done();
}
