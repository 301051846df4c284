/* The interpolation operator of csi/interp.h (host/ops/interp.c, kernels/interp.cl) under PoCL,
 * against float64 references made by numpy (tests/data/interp/gen_refs.py: every tap summed
 * directly with explicit wrap; the kernel's transform by scipy's adaptive quadrature).
 *
 * Tolerances. Gather and spread sum 36 float32 products of O(1) values with float32 weights:
 * rounding of order 36 * 6e-8 |terms| ~ 2e-6 of the largest value; we allow 1e-5 of max |ref|.
 * The kernel in double against numpy: 1e-13 (both evaluate the same closed form); its transform:
 * csi's 48-point Gauss-Legendre rule against quad's adaptive rule, 1e-9 relative to phi^(0)
 * (the integrand's derivative is singular at the support's edge, where phi ~ exp(-beta) = 3e-6,
 * which bounds what a fixed rule loses there well below that). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/interp.h"
#include "testlib.h"

static void test_kernel(void)
{
    test_npy az, ap, ax, af;
    bool ok = test_npy_load("interp/kernel_z.npy", &az) && test_npy_load("interp/kernel_phi.npy", &ap) &&
              test_npy_load("interp/kernel_xi.npy", &ax) && test_npy_load("interp/kernel_ft.npy", &af);
    CHECK(ok, "kernel reference files");
    if (!ok)
        return;
    double *z = test_npy_f64(&az), *p = test_npy_f64(&ap), *xi = test_npy_f64(&ax), *ft = test_npy_f64(&af);
    double worst = 0, worst_ft = 0;
    for (size_t i = 0; i < az.count; i++)
        worst = fmax(worst, fabs(csi_interp_kernel(z[i]) - p[i]));
    for (size_t i = 0; i < ax.count; i++)
        worst_ft = fmax(worst_ft, fabs(csi_interp_kernel_ft(xi[i]) - ft[i]) / ft[0]);
    CHECK(worst < 1e-13, "kernel values within 1e-13 (max diff %.2e)", worst);
    CHECK(worst_ft < 1e-9, "kernel transform within 1e-9 of phi^(0) (max %.2e)", worst_ft);
    printf("kernel: max |phi - ref| %.2e, max |phi^ - ref| / phi^(0) %.2e\n", worst, worst_ft);
    free(z);
    free(p);
    free(xi);
    free(ft);
    test_npy_free(&az);
    test_npy_free(&ap);
    test_npy_free(&ax);
    test_npy_free(&af);
}

struct icase {
    const char *name;
    size_t mw, mh;
    unsigned D;
};

static const struct icase cases[] = {
    {"i20x12_D2", 20, 12, 2},
    {"i4x4_D4", 4, 4, 4},
    {"i200x40_D2", 200, 40, 2},
};

static double ddot(const float *a, const float *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += (double)a[i] * b[i];
    return s;
}

static void test_case(csi_ctx *ctx, const struct icase *ic)
{
    char path[128];
    test_npy ai, ac, ar, ay, as;
    bool ok = true;
    const char *parts[] = {"idx", "c", "r", "y", "s"};
    test_npy *arrs[] = {&ai, &ac, &ar, &ay, &as};
    for (int i = 0; i < 5; i++) {
        snprintf(path, sizeof path, "interp/%s_%s.npy", ic->name, parts[i]);
        ok = ok && test_npy_load(path, arrs[i]);
    }
    CHECK(ok, "reference files for %s", ic->name);
    if (!ok)
        return;
    const size_t n = ai.count, k = ic->mw * ic->mh;
    uint32_t *idx = malloc(n * sizeof *idx);
    double *id = test_npy_f64(&ai);
    for (size_t i = 0; i < n; i++)
        idx[i] = (uint32_t)id[i];
    float *c = test_npy_f32(&ac), *r = test_npy_f32(&ar), *yref = test_npy_f32(&ay), *sref = test_npy_f32(&as);
    csi_linop *op = NULL;
    CHECK_OK(csi_interp_create(ctx, ic->mw, ic->mh, ic->D, idx, n, &op));
    if (op) {
        cl_mem dc = test_upload(c, k * 4), dr = test_upload(r, n * 4);
        /* the second spreading onto a buffer of 1e30: every cell must first be set to 0 */
        float *big = malloc(k * 4);
        for (size_t j = 0; j < k; j++)
            big[j] = 1e30f;
        cl_mem dy = test_alloc(n * 4), ds = test_alloc(k * 4), ds2 = test_upload(big, k * 4);
        free(big);
        CHECK_OK(csi_linop_apply(op, dc, dy));
        CHECK_OK(csi_linop_adjoint(op, dr, ds));
        CHECK_OK(csi_linop_adjoint(op, dr, ds2));
        float *y = malloc(n * 4), *s = malloc(k * 4), *s2 = malloc(k * 4);
        test_download(dy, y, n * 4);
        test_download(ds, s, k * 4);
        test_download(ds2, s2, k * 4);
        double ey = test_max_abs_diff(y, yref, n) / test_max_abs(yref, n);
        double es = test_max_abs_diff(s, sref, k) / test_max_abs(sref, k);
        CHECK(ey < 1e-5, "%s gather within 1e-5 of max |ref| (%.2e)", ic->name, ey);
        CHECK(es < 1e-5, "%s spread within 1e-5 of max |ref| (%.2e)", ic->name, es);
        CHECK(memcmp(s, s2, k * 4) == 0, "%s spread gives the same bits twice", ic->name);
        /* <I c, r> = <c, I^T r> in double: both sides from float32 results, so within the same
         * 1e-5 of the sums of |terms|. */
        double lhs = ddot(y, r, n), rhs = ddot(c, s, k);
        double scale = sqrt(ddot(y, y, n) * ddot(r, r, n)) + sqrt(ddot(c, c, k) * ddot(s, s, k));
        CHECK(fabs(lhs - rhs) <= 1e-5 * scale, "%s adjoint identity: %.9g vs %.9g", ic->name, lhs, rhs);
        printf("%s: %zu samples, gather err %.2e, spread err %.2e, adjoint gap %.2e\n", ic->name, n, ey,
               es, fabs(lhs - rhs) / scale);
        free(y);
        free(s);
        free(s2);
        csi_buffer_release(&dc);
        csi_buffer_release(&dr);
        csi_buffer_release(&dy);
        csi_buffer_release(&ds);
        csi_buffer_release(&ds2);
        csi_linop_free(op);
    }
    free(idx);
    free(id);
    free(c);
    free(r);
    free(yref);
    free(sref);
    for (int i = 0; i < 5; i++)
        test_npy_free(arrs[i]);
}

/* The spreading at the grid's last rows and columns, where its aligned blocks meet the row's end:
 * every fine cell of the last 8 model rows and columns a sample (the windows that end the grid,
 * those that wrap, those whose block is the row's last), against the taps summed in double here
 * (csi_interp_kernel, explicit wrap), within the 1e-5 above, on a buffer that held 1e30 in every
 * cell; and nothing written past the grid: the buffer's 16 cells after it hold -0, which an added
 * +0 would turn into +0. */
static void test_grid_end(csi_ctx *ctx)
{
    enum { MW = 64, MH = 16, D = 2, TAIL = 16 };
    const size_t k = MW * MH, fw = MW * D;
    uint32_t idx[8 * D * 8 * D];
    float r[8 * D * 8 * D];
    size_t n = 0;
    for (size_t py = (MH - 8) * D; py < MH * D; py++)
        for (size_t px = (MW - 8) * D; px < MW * D; px++) {
            idx[n] = (uint32_t)(py * fw + px);
            r[n] = 0.25f + (float)((n * 37) % 11) / 8.0f; /* positive: each term's + 0 is + 0 */
            n++;
        }
    double *ref = calloc(k, sizeof *ref);
    for (size_t i = 0; i < n; i++) {
        const size_t px = idx[i] % fw, py = idx[i] / fw;
        for (size_t jy = 0; jy < MH; jy++)
            for (size_t jx = 0; jx < MW; jx++) {
                /* the nearest periodic image of the cell to the sample */
                double dx = (double)px / D - (double)jx, dy = (double)py / D - (double)jy;
                dx -= MW * round(dx / MW);
                dy -= MH * round(dy / MH);
                ref[jy * MW + jx] += r[i] * csi_interp_kernel(dx) * csi_interp_kernel(dy);
            }
    }
    float *s = malloc((k + TAIL) * sizeof *s), *refs = malloc(k * sizeof *refs);
    for (size_t j = 0; j < k + TAIL; j++)
        s[j] = j < k ? 1e30f : -0.0f; /* the grid's cells: what the spreading must first set to 0 */
    for (size_t j = 0; j < k; j++)
        refs[j] = (float)ref[j];
    csi_linop *op = NULL;
    CHECK_OK(csi_interp_create(ctx, MW, MH, D, idx, n, &op));
    if (op) {
        cl_mem dr = test_upload(r, n * 4), ds = test_upload(s, (k + TAIL) * 4);
        CHECK_OK(csi_linop_adjoint(op, dr, ds));
        test_download(ds, s, (k + TAIL) * 4);
        double es = test_max_abs_diff(s, refs, k) / test_max_abs(refs, k);
        CHECK(es < 1e-5, "grid end: spread within 1e-5 of max |ref| (%.2e)", es);
        bool untouched = true;
        for (size_t j = k; j < k + TAIL; j++)
            untouched = untouched && signbit(s[j]) && s[j] == 0.0f;
        CHECK(untouched, "grid end: the cells after the grid are not written");
        printf("grid end: %zu samples, spread err %.2e\n", n, es);
        csi_buffer_release(&dr);
        csi_buffer_release(&ds);
        csi_linop_free(op);
    }
    free(ref);
    free(refs);
    free(s);
}

/* The spreading and the gather on a grid larger than the cache (above host/ops/interp.c's
 * ZERO_CACHED_BYTES), where both look ahead of the sample they take (kernels/interp.cl): tiles
 * full of samples (every fine cell of the grid's first two rows of tiles and of its last rows and
 * columns: the windows that wrap, those whose block ends the row, those whose look-ahead would
 * reach past the grid), and samples scattered over the rest, against the taps summed in double
 * here with explicit wrap, within the 1e-5 above, on buffers that held 1e30 in every cell. */
/* The taps of the sample at fine cell `fine` of a D-times finer grid over an mw x mh model grid:
 * the model cells it reads (periodic) and their weights, phi(dx) phi(dy), in double. */
static void sample_taps(uint32_t fine, size_t mw, size_t mh, unsigned D, size_t cell[], double weight[])
{
    const size_t fw = mw * D, px = fine % fw, py = fine / fw, mx = px / D, my = py / D;
    const int o = CSI_INTERP_TAPS / 2 - 1;
    for (int a = 0; a < CSI_INTERP_TAPS; a++)
        for (int b = 0; b < CSI_INTERP_TAPS; b++) {
            const size_t jx = (mx + mw + b - o) % mw, jy = (my + mh + a - o) % mh;
            const double dx = (double)(px % D) / D - (b - o), dy = (double)(py % D) / D - (a - o);
            cell[a * CSI_INTERP_TAPS + b] = jy * mw + jx;
            weight[a * CSI_INTERP_TAPS + b] = csi_interp_kernel(dx) * csi_interp_kernel(dy);
        }
}

static void test_large_grid(csi_ctx *ctx)
{
    enum { MW = 2048, MH = 1040, D = 2 };
    const size_t k = (size_t)MW * MH, fw = (size_t)MW * D, fh = (size_t)MH * D;
    /* the three regions below, then scattered samples up to cap */
    const size_t cap = 32 * 256 + 16 * fw + (fh / 8) * 8 + 8192;
    uint32_t *idx = malloc(cap * sizeof *idx);
    float *r = malloc(cap * sizeof *r);
    size_t n = 0;
    for (size_t py = 0; py < 32; py++)
        for (size_t px = 0; px < 256; px++)
            idx[n++] = (uint32_t)(py * fw + px);
    for (size_t py = fh - 16; py < fh; py++)
        for (size_t px = 0; px < fw; px++)
            idx[n++] = (uint32_t)(py * fw + px);
    for (size_t py = 32; py < fh - 16; py += 8)
        for (size_t px = fw - 24; px < fw; px += 3)
            idx[n++] = (uint32_t)(py * fw + px);
    uint64_t st = 0x9e3779b97f4a7c15ull;
    while (n < cap) {
        st = st * 6364136223846793005ull + 1442695040888963407ull;
        idx[n++] = (uint32_t)((st >> 20) % (fw * fh));
    }
    for (size_t i = 0; i < n; i++)
        r[i] = (float)((i * 37) % 23) / 11.0f - 1.0f;
    enum { TAPS = CSI_INTERP_TAPS * CSI_INTERP_TAPS };
    size_t cell[TAPS];
    double weight[TAPS];
    double *ref = calloc(k, sizeof *ref);
    for (size_t i = 0; i < n; i++) {
        sample_taps(idx[i], MW, MH, D, cell, weight);
        for (int t = 0; t < TAPS; t++)
            ref[cell[t]] += r[i] * weight[t];
    }
    float *s = malloc(k * sizeof *s), *refs = malloc(k * sizeof *refs);
    for (size_t j = 0; j < k; j++) {
        s[j] = 1e30f;
        refs[j] = (float)ref[j];
    }
    csi_linop *op = NULL;
    CHECK_OK(csi_interp_create(ctx, MW, MH, D, idx, n, &op));
    if (op) {
        cl_mem dr = test_upload(r, n * 4), ds = test_upload(s, k * 4);
        CHECK_OK(csi_linop_adjoint(op, dr, ds));
        test_download(ds, s, k * 4);
        double es = test_max_abs_diff(s, refs, k) / test_max_abs(refs, k);
        CHECK(es < 1e-5, "large grid: spread within 1e-5 of max |ref| (%.2e)", es);
        /* the gather, which looks ahead too, of a grid of known values at the same samples */
        for (size_t j = 0; j < k; j++)
            s[j] = (float)((j * 53) % 29) / 14.0f - 1.0f;
        double *yd = calloc(n, sizeof *yd);
        for (size_t i = 0; i < n; i++) {
            sample_taps(idx[i], MW, MH, D, cell, weight);
            for (int t = 0; t < TAPS; t++)
                yd[i] += s[cell[t]] * weight[t];
        }
        float *y = malloc(n * sizeof *y), *yref = malloc(n * sizeof *yref);
        for (size_t i = 0; i < n; i++) {
            y[i] = 1e30f;
            yref[i] = (float)yd[i];
        }
        cl_mem dc = test_upload(s, k * 4), dy = test_upload(y, n * 4);
        CHECK_OK(csi_linop_apply(op, dc, dy));
        test_download(dy, y, n * 4);
        double ey = test_max_abs_diff(y, yref, n) / test_max_abs(yref, n);
        CHECK(ey < 1e-5, "large grid: gather within 1e-5 of max |ref| (%.2e)", ey);
        printf("large grid: %zu samples, spread err %.2e, gather err %.2e\n", n, es, ey);
        csi_buffer_release(&dc);
        csi_buffer_release(&dy);
        free(yd);
        free(y);
        free(yref);
        csi_buffer_release(&dr);
        csi_buffer_release(&ds);
        csi_linop_free(op);
    }
    free(ref);
    free(refs);
    free(s);
    free(idx);
    free(r);
}

static void test_errors(csi_ctx *ctx)
{
    uint32_t idx[2] = {0, 400};
    csi_linop *op = (csi_linop *)1;
    CHECK(csi_interp_create(ctx, 10, 10, 2, idx, 2, &op) == CSI_ERR_ARG && op == NULL,
          "an index outside the 20 x 20 fine grid is refused");
    CHECK(strstr(csi_last_error(), "400") != NULL, "the message names the index: %s", csi_last_error());
    CHECK(csi_interp_create(ctx, 10, 10, 0, idx, 1, &op) == CSI_ERR_ARG, "D = 0 is refused");
    CHECK(csi_interp_create(ctx, 10, 10, 2, idx, 0, &op) == CSI_ERR_ARG, "no samples is refused");
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    test_kernel();
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        test_case(ctx, &cases[i]);
    test_grid_end(ctx);
    test_large_grid(ctx);
    test_errors(ctx);
    return test_done();
}
