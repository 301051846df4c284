/* Vector operations (host/ops/vec.c, kernels/vec.cl) against plain C in double.
 *
 * Element-wise real updates are single IEEE operations (a*x + b*y rounded twice, no FMA on
 * either side: kernels disable contraction, the host is built as ISO C11 where GCC does not
 * contract), so they must match the float reference exactly. Complex soft-thresholding uses
 * a scaled magnitude (8 ulp, vec.cl) and a division: 1e-6 relative. Reductions must stay within the
 * bound documented in vec.h, |err| <= 3u sum|v_i| (u = 2^-24), checked with a margin of 2 on
 * sizes where naive float summation exceeds it (n = 1e6 with cancellation). */
#include <float.h>
#include <stdlib.h>
#include <string.h>

#include "csi/vec.h"
#include "testlib.h"

#define BOUND(sumabs) (2.0 * 3.0 * 0x1.0p-24 * (sumabs) + 1e-300)

static float *rand_vec(test_rng *r, size_t n, double scale)
{
    float *v = malloc(n * sizeof *v + 4);
    for (size_t i = 0; i < n; i++)
        v[i] = (float)(scale * test_rng_normal(r));
    return v;
}

static void test_elementwise(csi_ctx *ctx, csi_vec_ws *ws, test_rng *r, size_t n)
{
    float *x = rand_vec(r, n, 1.0), *y = rand_vec(r, n, 3.0), *h = malloc(n * sizeof *h + 4);
    cl_mem dx = test_upload(x, n * 4), dy = test_upload(y, n * 4), dw = test_alloc(n * 4);
    const float a = 0.37f, b = -1.25f;
    int bad;

    CHECK_OK(csi_vec_waxpby(ctx, n, a, dx, b, dy, dw));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != a * x[i] + b * y[i];
    CHECK(bad == 0, "waxpby n=%zu: %d mismatches", n, bad);

    CHECK_OK(csi_vec_copy(ctx, dw, dy, n));
    CHECK_OK(csi_vec_axpy(ctx, n, a, dx, dw));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != y[i] + a * x[i];
    CHECK(bad == 0, "axpy n=%zu: %d mismatches", n, bad);

    CHECK_OK(csi_vec_copy(ctx, dw, dy, n));
    CHECK_OK(csi_vec_xpay(ctx, n, dx, b, dw));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != 1.0f * x[i] + b * y[i];
    CHECK(bad == 0, "xpay n=%zu: %d mismatches", n, bad);

    CHECK_OK(csi_vec_copy(ctx, dw, dy, n));
    CHECK_OK(csi_vec_axpby(ctx, n, a, dx, b, dw));
    CHECK_OK(csi_vec_scale(ctx, dw, n, 2.5f));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != 2.5f * (a * x[i] + b * y[i]);
    CHECK(bad == 0, "axpby+scale n=%zu: %d mismatches", n, bad);

    CHECK_OK(csi_vec_fill(ctx, dw, n, -7.5f));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != -7.5f;
    CHECK(bad == 0, "fill n=%zu: %d mismatches", n, bad);

    /* Real soft threshold, its fused proximal form, masks. */
    const float t = 0.8f, alpha = 4.0f;
    CHECK_OK(csi_vec_soft(ctx, n, false, dx, t, dw));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++) {
        float m = fabsf(x[i]) - t;
        float want = m > 0 ? copysignf(m, x[i]) : 0.0f;
        bad += h[i] != want;
    }
    CHECK(bad == 0, "soft real n=%zu: %d mismatches", n, bad);
    {
        double l1, dx2;
        CHECK_OK(csi_vec_prox_sums(ws, n, false, dx, dy, -1.0f / alpha, t, dw, &l1, &dx2));
        test_download(dw, h, n * 4);
        bad = 0;
        double rl1 = 0, rdx2 = 0;
        for (size_t i = 0; i < n; i++) {
            float v = x[i] + (-1.0f / alpha) * y[i];
            float m = fabsf(v) - t;
            float want = m > 0 ? copysignf(m, v) : 0.0f;
            bad += h[i] != want;
            rl1 += fabs((double)want);
            rdx2 += ((double)want - x[i]) * ((double)want - x[i]);
        }
        CHECK(bad == 0, "prox step real n=%zu: %d mismatches", n, bad);
        CHECK(fabs(l1 - rl1) <= BOUND(rl1) && fabs(dx2 - rdx2) <= BOUND(rdx2) + 3 * 0x1.0p-24 * rdx2,
              "prox sums n=%zu: %.9g %.9g vs %.9g %.9g", n, l1, dx2, rl1, rdx2);
        /* fused residual pass: r = y - z, sums r^2, (z - x)^2, r y  (here y := dy, z := dx, x := dw) */
        double rr, dd, ry;
        cl_mem dr = test_alloc(n * 4);
        CHECK_OK(csi_vec_resid_sums(ws, n, dy, dx, dw, dr, &rr, &dd, &ry));
        float *hr = malloc(n * 4);
        test_download(dr, hr, n * 4);
        double wrr = 0, wdd = 0, wry = 0, ary = 0;
        bad = 0;
        for (size_t i = 0; i < n; i++) {
            float ri = y[i] - x[i];
            bad += hr[i] != ri;
            float di = x[i] - h[i];
            wrr += (double)ri * ri;
            wdd += (double)di * di;
            wry += (double)ri * y[i];
            ary += fabs((double)ri * y[i]);
        }
        CHECK(bad == 0, "resid sums n=%zu: %d residual mismatches", n, bad);
        CHECK(fabs(rr - wrr) <= BOUND(wrr) && fabs(dd - wdd) <= BOUND(wdd) && fabs(ry - wry) <= BOUND(ary),
              "resid sums n=%zu: %.9g %.9g %.9g vs %.9g %.9g %.9g", n, rr, dd, ry, wrr, wdd, wry);
        free(hr);
        csi_buffer_release(&dr);
    }
    unsigned char *mask = malloc(n + 1);
    for (size_t i = 0; i < n; i++)
        mask[i] = (unsigned char)(test_rng_u64(r) & 1);
    cl_mem dm = test_upload(mask, n + 1);
    CHECK_OK(csi_vec_copy(ctx, dw, dx, n));
    CHECK_OK(csi_vec_mask(ctx, n, false, dm, dw));
    test_download(dw, h, n * 4);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += h[i] != (mask[i] ? x[i] : 0.0f);
    CHECK(bad == 0, "mask n=%zu: %d mismatches", n, bad);
    unsigned char *m2 = malloc(n + 1);
    CHECK_OK(csi_vec_nonzero_mask(ctx, n, false, dw, dm));
    test_download(dm, m2, n);
    bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += m2[i] != (mask[i] && x[i] != 0.0f);
    CHECK(bad == 0, "nonzero mask n=%zu: %d mismatches", n, bad);

    free(mask);
    free(m2);
    free(x);
    free(y);
    free(h);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
    csi_buffer_release(&dw);
    csi_buffer_release(&dm);
}

static void test_complex_soft(csi_ctx *ctx, csi_vec_ws *ws, test_rng *r, size_t n)
{
    float *x = rand_vec(r, 2 * n, 1.0), *h = malloc(2 * n * sizeof *h + 4);
    if (n > 3) {
        x[0] = x[1] = 0.0f; /* exact zero: the 0/0 case */
        x[2] = 1e-30f;      /* tiny, below any threshold */
        x[3] = 0.0f;
    }
    cl_mem dx = test_upload(x, 2 * n * 4), dw = test_alloc(2 * n * 4);
    const float ts[3] = {0.0f, 0.5f, 1e-30f};
    for (int ti = 0; ti < 3; ti++) {
        float t = ts[ti];
        CHECK_OK(csi_vec_soft(ctx, n, true, dx, t, dw));
        test_download(dw, h, 2 * n * 4);
        double worst = 0;
        int nonfinite = 0;
        for (size_t i = 0; i < n; i++) {
            double re = x[2 * i], im = x[2 * i + 1], mag = hypot(re, im);
            double f = (t == 0.0f) ? 1.0 : (mag > t ? (mag - t) / mag : 0.0);
            double wr = re * f, wi = im * f;
            nonfinite += !isfinite(h[2 * i]) || !isfinite(h[2 * i + 1]);
            double e = hypot(h[2 * i] - wr, h[2 * i + 1] - wi) / (mag > 0 ? mag : 1.0);
            if (e > worst)
                worst = e;
        }
        CHECK(nonfinite == 0, "complex soft t=%g: %d non-finite", (double)t, nonfinite);
        CHECK(worst <= 1e-6, "complex soft t=%g: relative error %g", (double)t, worst);
    }
    /* The fused complex proximal step equals soft(x + c g, t) (same tolerance). */
    {
        float *g = rand_vec(r, 2 * n, 2.0);
        cl_mem dg = test_upload(g, 2 * n * 4);
        const float c = -0.25f, t = 0.3f;
        double l1, dx2;
        CHECK_OK(csi_vec_prox_sums(ws, n, true, dx, dg, c, t, dw, &l1, &dx2));
        test_download(dw, h, 2 * n * 4);
        double worst = 0;
        for (size_t i = 0; i < n; i++) {
            double re = x[2 * i] + (double)(c * g[2 * i]), im = x[2 * i + 1] + (double)(c * g[2 * i + 1]);
            double mag = hypot(re, im), f = mag > t ? (mag - t) / mag : 0.0;
            double e = hypot(h[2 * i] - re * f, h[2 * i + 1] - im * f) / (mag > 0 ? mag : 1.0);
            worst = e > worst ? e : worst;
        }
        CHECK(worst <= 1e-6, "complex prox step n=%zu: %g", n, worst);
        double rl1 = 0, rdx2 = 0;
        for (size_t i = 0; i < n; i++) {
            rl1 += hypot(h[2 * i], h[2 * i + 1]);
            rdx2 += ((double)h[2 * i] - x[2 * i]) * ((double)h[2 * i] - x[2 * i]) +
                    ((double)h[2 * i + 1] - x[2 * i + 1]) * ((double)h[2 * i + 1] - x[2 * i + 1]);
        }
        /* magnitudes 8 ulp; each squared difference term has ~4 roundings */
        CHECK(fabs(l1 - rl1) <= BOUND(rl1) + 8 * 0x1.0p-24 * rl1 &&
                  fabs(dx2 - rdx2) <= BOUND(rdx2) + 4 * 0x1.0p-24 * rdx2,
              "complex prox sums n=%zu: %.9g %.9g vs %.9g %.9g", n, l1, dx2, rl1, rdx2);
        free(g);
        csi_buffer_release(&dg);
    }
    /* Zero threshold is the identity, bit for bit. */
    CHECK_OK(csi_vec_soft(ctx, n, true, dx, 0.0f, dw));
    test_download(dw, h, 2 * n * 4);
    CHECK(memcmp(h, x, 2 * n * 4) == 0, "t = 0 leaves complex x unchanged");
    /* A negative or NaN threshold is an argument error. */
    CHECK(csi_vec_soft(ctx, n, true, dx, -1.0f, dw) == CSI_ERR_ARG, "negative threshold refused");
    CHECK(csi_vec_soft(ctx, n, true, dx, NAN, dw) == CSI_ERR_ARG, "NaN threshold refused");
    free(x);
    free(h);
    csi_buffer_release(&dx);
    csi_buffer_release(&dw);
}


static void test_reductions(csi_vec_ws *ws, test_rng *r, size_t n)
{
    /* Mixed scales and cancellation: sum x_i y_i is small compared with sum |x_i y_i|. */
    float *x = rand_vec(r, 2 * n, 1.0), *y = rand_vec(r, 2 * n, 1.0);
    for (size_t i = 0; i < 2 * n; i += 7)
        x[i] *= 1000.0f;
    cl_mem dx = test_upload(x, 2 * n * 4), dy = test_upload(y, 2 * n * 4);
    double got, ref = 0, sabs = 0;

    for (size_t i = 0; i < n; i++) {
        ref += (double)x[i] * y[i];
        sabs += fabs((double)x[i] * y[i]);
    }
    CHECK_OK(csi_vec_dot(ws, n, dx, dy, &got));
    CHECK(fabs(got - ref) <= BOUND(sabs), "dot n=%zu: %.17g vs %.17g (bound %g)", n, got, ref, BOUND(sabs));

    double s2 = 0;
    for (size_t i = 0; i < n; i++)
        s2 += (double)x[i] * x[i];
    CHECK_OK(csi_vec_nrm2(ws, n, dx, &got));
    CHECK(fabs(got * got - s2) <= BOUND(s2), "nrm2 n=%zu: %.17g vs %.17g", n, got * got, s2);

    double d2 = 0, d2abs = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)x[i] - y[i];
        d2 += d * d;
        d2abs += d * d;
    }
    CHECK_OK(csi_vec_dist2(ws, n, dx, dy, &got));
    /* the difference itself is rounded (u relative), squared: 2u more per term */
    CHECK(fabs(got - d2) <= BOUND(d2abs) + 3 * 0x1.0p-24 * d2abs, "dist2 n=%zu: %.17g vs %.17g", n, got, d2);

    double a1 = 0;
    for (size_t i = 0; i < n; i++)
        a1 += fabs((double)x[i]);
    CHECK_OK(csi_vec_asum(ws, n, false, dx, &got));
    CHECK(fabs(got - a1) <= BOUND(a1), "asum n=%zu: %.17g vs %.17g", n, got, a1);

    /* complex: n elements = 2n floats */
    double cr = 0, ci = 0, cabs = 0, ca1 = 0;
    for (size_t i = 0; i < n; i++) {
        double xr = x[2 * i], xi = x[2 * i + 1], yr = y[2 * i], yi = y[2 * i + 1];
        cr += xr * yr + xi * yi; /* x^H y = conj(x) y */
        ci += xr * yi - xi * yr;
        cabs += hypot(xr, xi) * hypot(yr, yi);
        ca1 += hypot(xr, xi);
    }
    double c[2];
    CHECK_OK(csi_vec_cdot(ws, n, dx, dy, c));
    CHECK(fabs(c[0] - cr) <= 2 * BOUND(cabs) && fabs(c[1] - ci) <= 2 * BOUND(cabs),
          "cdot n=%zu: (%.9g, %.9g) vs (%.9g, %.9g)", n, c[0], c[1], cr, ci);
    /* complex magnitudes are 8 ulp (vec.cl): 8u more per term */
    CHECK_OK(csi_vec_asum(ws, n, true, dx, &got));
    CHECK(fabs(got - ca1) <= BOUND(ca1) + 8 * 0x1.0p-24 * ca1, "complex asum n=%zu: %.17g vs %.17g", n, got, ca1);

    /* amax with its first index; plant a tie after the maximum to check the tie-break. */
    size_t want_i = n / 3;
    x[want_i] = 5e4f;
    x[n - 1] = -5e4f;
    CHECK_OK(csi_write(csi_vec_ws_ctx(ws), dx, 0, n * 4, x));
    double mv;
    size_t mi;
    CHECK_OK(csi_vec_amax(ws, n, false, dx, &mv, &mi));
    CHECK(mv == 5e4 && mi == (n - 1 == want_i ? n - 1 : want_i), "amax n=%zu: %g at %zu", n, mv, mi);
    x[2 * (n / 5)] = 6e4f; /* a clear complex maximum, |z| = 1e5 */
    x[2 * (n / 5) + 1] = 8e4f;
    CHECK_OK(csi_write(csi_vec_ws_ctx(ws), dx, 0, 2 * n * 4, x));
    size_t cm = 0;
    double cmv = -1;
    for (size_t i = 0; i < n; i++) {
        double m = hypot(x[2 * i], x[2 * i + 1]);
        if (m > cmv) {
            cmv = m;
            cm = i;
        }
    }
    CHECK_OK(csi_vec_amax(ws, n, true, dx, &mv, &mi));
    CHECK(mi == cm && fabs(mv - cmv) <= 8 * 0x1.0p-24 * cmv, "complex amax n=%zu: %g at %zu vs %g at %zu",
          n, mv, mi, cmv, cm);

    free(x);
    free(y);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    test_rng r;
    test_rng_seed(&r, 20261122);
    csi_vec_ws *ws;
    REQUIRE_OK(csi_vec_ws_create(ctx, &ws));

    const size_t sizes[] = {1, 63, 64, 65, 1000, 4097, 100003, 1000000};
    for (size_t i = 0; i < sizeof sizes / sizeof *sizes; i++) {
        test_elementwise(ctx, ws, &r, sizes[i]);
        test_complex_soft(ctx, ws, &r, sizes[i]);
        test_reductions(ws, &r, sizes[i]);
    }

    /* Naive float accumulation would fail the bound here: 2^24 + many ones. The compensated
     * sum gets the exact 2^24 + 1e6 - 1. */
    {
        size_t n = 1000000;
        float *x = malloc(n * 4);
        for (size_t i = 0; i < n; i++)
            x[i] = 1.0f;
        x[0] = 16777216.0f;
        cl_mem dx = test_upload(x, n * 4);
        double got;
        CHECK_OK(csi_vec_asum(ws, n, false, dx, &got));
        CHECK(got == 16777216.0 + (double)(n - 1), "compensated sum: %.17g", got);
        free(x);
        csi_buffer_release(&dx);
    }

    /* Empty vectors: zero results, no launch. A NaN surfaces in amax and in the norm. */
    {
        cl_mem d = test_alloc(64);
        double v = 1;
        size_t i = 7;
        CHECK_OK(csi_vec_dot(ws, 0, d, d, &v));
        CHECK(v == 0, "empty dot");
        CHECK_OK(csi_vec_amax(ws, 0, false, d, &v, &i));
        CHECK(v == 0 && i == 0, "empty amax");
        float h[5] = {1, 2, NAN, 3, -4};
        CHECK_OK(csi_write(ctx, d, 0, sizeof h, h));
        CHECK_OK(csi_vec_amax(ws, 5, false, d, &v, &i));
        CHECK(isnan(v) && i == 2, "NaN surfaces in amax: %g at %zu", v, i);
        CHECK_OK(csi_vec_nrm2(ws, 5, d, &v));
        CHECK(isnan(v), "NaN surfaces in nrm2: %g", v);
        csi_buffer_release(&d);
    }

    /* Determinism: the same reduction twice gives the same bits. */
    {
        size_t n = 333333;
        float *x = rand_vec(&r, n, 1.0);
        cl_mem dx = test_upload(x, n * 4);
        double a, b;
        CHECK_OK(csi_vec_dot(ws, n, dx, dx, &a));
        CHECK_OK(csi_vec_dot(ws, n, dx, dx, &b));
        CHECK(memcmp(&a, &b, sizeof a) == 0, "deterministic reduction");
        free(x);
        csi_buffer_release(&dx);
    }
    csi_vec_ws_free(ws);
    return test_done();
}
