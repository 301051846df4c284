/* Sampling operator S (gather / scatter) and the dense operator against plain C.
 *
 * Gather and scatter move floats without arithmetic: exact equality. The adjoint identity
 * <S f, y> = <f, S^T y> holds exactly in exact arithmetic; both sides are float reductions of
 * the same N products, so they agree within the reduction bound 3u sum|f_i y_i| each (vec.h),
 * tested as 1e-6 relative. The dense operator's rows are Kahan sums: within a few u of
 * sum |A_ij x_j|, tested at 1e-6 of that sum against double. */
#include <stdlib.h>
#include <string.h>

#include "csi/dense.h"
#include "csi/sampling.h"
#include "csi/vec.h"
#include "testlib.h"

static void check_sampling(csi_ctx *ctx, csi_vec_ws *ws, test_rng *r, size_t k, size_t n, bool cplx)
{
    /* n distinct indices by a partial Fisher-Yates shuffle. */
    uint32_t *perm = malloc(k * sizeof *perm);
    for (size_t i = 0; i < k; i++)
        perm[i] = (uint32_t)i;
    for (size_t i = 0; i < n; i++) {
        size_t j = i + test_rng_u64(r) % (k - i);
        uint32_t t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    csi_linop *S;
    CHECK_OK(csi_sampling_create(ctx, k, perm, n, cplx, &S));
    if (!S) {
        free(perm);
        return;
    }
    CHECK(S->rows == n && S->cols == k && S->complex_valued == cplx, "shape");
    size_t w = cplx ? 2 : 1;
    float *f = malloc(k * w * 4), *y = malloc(n * w * 4 + 4), *hy = malloc(n * w * 4 + 4),
          *hf = malloc(k * w * 4);
    for (size_t i = 0; i < k * w; i++)
        f[i] = (float)test_rng_normal(r);
    for (size_t i = 0; i < n * w; i++)
        y[i] = (float)test_rng_normal(r);
    cl_mem df = test_upload(f, k * w * 4), dy = test_upload(y, n * w * 4 + 4);
    cl_mem dSf = test_alloc(n * w * 4 + 4), dSty = test_alloc(k * w * 4);
    CHECK_OK(csi_linop_apply(S, df, dSf));
    CHECK_OK(csi_linop_adjoint(S, dy, dSty));
    test_download(dSf, hy, n * w * 4);
    test_download(dSty, hf, k * w * 4);
    int bad = 0;
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < w; c++)
            bad += hy[i * w + c] != f[perm[i] * w + c];
    CHECK(bad == 0, "gather k=%zu n=%zu: %d wrong", k, n, bad);
    float *want = calloc(k * w, 4);
    for (size_t i = 0; i < n; i++)
        for (size_t c = 0; c < w; c++)
            want[perm[i] * w + c] = y[i * w + c];
    CHECK(memcmp(want, hf, k * w * 4) == 0, "scatter k=%zu n=%zu matches S^T y with zeros elsewhere", k, n);
    /* Scatter twice into a dirty buffer: still zeros elsewhere. */
    CHECK_OK(csi_vec_fill(ctx, dSty, k * w, 9.0f));
    CHECK_OK(csi_linop_adjoint(S, dy, dSty));
    test_download(dSty, hf, k * w * 4);
    CHECK(memcmp(want, hf, k * w * 4) == 0, "scatter clears stale values");
    double lhs, rhs, sabs = 0;
    for (size_t i = 0; i < n * w; i++)
        sabs += fabs((double)hy[i] * y[i]);
    CHECK_OK(csi_vec_dot(ws, n * w, dSf, dy, &lhs));
    CHECK_OK(csi_vec_dot(ws, k * w, df, dSty, &rhs));
    CHECK(fabs(lhs - rhs) <= 1e-6 * sabs + 1e-30, "adjoint identity k=%zu n=%zu: %.9g vs %.9g", k, n, lhs, rhs);
    free(want);
    free(f);
    free(y);
    free(hy);
    free(hf);
    free(perm);
    csi_buffer_release(&df);
    csi_buffer_release(&dy);
    csi_buffer_release(&dSf);
    csi_buffer_release(&dSty);
    csi_linop_free(S);
}

static void check_dense(csi_ctx *ctx, csi_vec_ws *ws, test_rng *r, size_t rows, size_t cols, bool cplx)
{
    size_t w = cplx ? 2 : 1;
    float *A = malloc(rows * cols * w * 4), *x = malloc(cols * w * 4), *y = malloc(rows * w * 4);
    float *hy = malloc(rows * w * 4), *hx = malloc(cols * w * 4);
    for (size_t i = 0; i < rows * cols * w; i++)
        A[i] = (float)test_rng_normal(r);
    for (size_t i = 0; i < cols * w; i++)
        x[i] = (float)test_rng_normal(r);
    for (size_t i = 0; i < rows * w; i++)
        y[i] = (float)test_rng_normal(r);
    csi_linop *op;
    CHECK_OK(csi_dense_create(ctx, rows, cols, A, cplx, &op));
    if (!op)
        return;
    cl_mem dx = test_upload(x, cols * w * 4), dy = test_upload(y, rows * w * 4);
    cl_mem dAx = test_alloc(rows * w * 4), dAhy = test_alloc(cols * w * 4);
    CHECK_OK(csi_linop_apply(op, dx, dAx));
    CHECK_OK(csi_linop_adjoint(op, dy, dAhy));
    test_download(dAx, hy, rows * w * 4);
    test_download(dAhy, hx, cols * w * 4);
    double worst = 0;
    for (size_t i = 0; i < rows; i++) {
        double sr = 0, si = 0, sa = 0;
        for (size_t j = 0; j < cols; j++) {
            if (cplx) {
                double ar = A[2 * (i * cols + j)], ai = A[2 * (i * cols + j) + 1];
                sr += ar * x[2 * j] - ai * x[2 * j + 1];
                si += ar * x[2 * j + 1] + ai * x[2 * j];
                sa += hypot(ar, ai) * hypot(x[2 * j], x[2 * j + 1]);
            } else {
                sr += (double)A[i * cols + j] * x[j];
                sa += fabs((double)A[i * cols + j] * x[j]);
            }
        }
        double e = cplx ? hypot(hy[2 * i] - sr, hy[2 * i + 1] - si) : fabs(hy[i] - sr);
        if (e / sa > worst)
            worst = e / sa;
    }
    CHECK(worst <= 1e-6, "dense apply %zux%zu%s: %g", rows, cols, cplx ? " complex" : "", worst);
    worst = 0;
    for (size_t j = 0; j < cols; j++) {
        double sr = 0, si = 0, sa = 0;
        for (size_t i = 0; i < rows; i++) {
            if (cplx) { /* conj(A_ij) y_i */
                double ar = A[2 * (i * cols + j)], ai = -A[2 * (i * cols + j) + 1];
                sr += ar * y[2 * i] - ai * y[2 * i + 1];
                si += ar * y[2 * i + 1] + ai * y[2 * i];
                sa += hypot(ar, ai) * hypot(y[2 * i], y[2 * i + 1]);
            } else {
                sr += (double)A[i * cols + j] * y[i];
                sa += fabs((double)A[i * cols + j] * y[i]);
            }
        }
        double e = cplx ? hypot(hx[2 * j] - sr, hx[2 * j + 1] - si) : fabs(hx[j] - sr);
        if (e / sa > worst)
            worst = e / sa;
    }
    CHECK(worst <= 1e-6, "dense adjoint %zux%zu%s: %g", rows, cols, cplx ? " complex" : "", worst);
    /* Adjoint identity Re<Ax, y> = Re<x, A^H y>. */
    double lhs, rhs;
    CHECK_OK(csi_vec_dot(ws, rows * w, dAx, dy, &lhs));
    CHECK_OK(csi_vec_dot(ws, cols * w, dx, dAhy, &rhs));
    CHECK(fabs(lhs - rhs) <= 1e-5 * sqrt((double)rows * cols), "dense adjoint identity: %g vs %g", lhs, rhs);
    free(A);
    free(x);
    free(y);
    free(hx);
    free(hy);
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
    csi_buffer_release(&dAx);
    csi_buffer_release(&dAhy);
    csi_linop_free(op);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    csi_vec_ws *ws;
    REQUIRE_OK(csi_vec_ws_create(ctx, &ws));
    test_rng r;
    test_rng_seed(&r, 7);
    check_sampling(ctx, ws, &r, 1, 1, false);
    check_sampling(ctx, ws, &r, 1000, 0, false);
    check_sampling(ctx, ws, &r, 1000, 137, false);
    check_sampling(ctx, ws, &r, 65536, 9000, false);
    check_sampling(ctx, ws, &r, 4096, 4096, true);
    check_sampling(ctx, ws, &r, 30000, 777, true);

    /* Bad input: out of range and duplicates name the first offending record. */
    csi_linop *S = NULL;
    uint32_t bad1[] = {3, 9, 10, 2};
    csi_status st = csi_sampling_create(ctx, 10, bad1, 4, false, &S);
    CHECK(st == CSI_ERR_ARG && S == NULL && strstr(csi_last_error(), "record 2") &&
              strstr(csi_last_error(), "index 10"), "%s", csi_last_error());
    uint32_t bad2[] = {3, 9, 4, 9, 3};
    st = csi_sampling_create(ctx, 10, bad2, 5, false, &S);
    CHECK(st == CSI_ERR_ARG && S == NULL && strstr(csi_last_error(), "record 3") &&
              strstr(csi_last_error(), "repeats record 1"), "%s", csi_last_error());
    st = csi_sampling_create(ctx, 0, bad2, 0, false, &S);
    CHECK(st == CSI_ERR_ARG && S == NULL, "k = 0 refused: %s", csi_last_error());

    check_dense(ctx, ws, &r, 1, 1, false);
    check_dense(ctx, ws, &r, 37, 300, false);
    check_dense(ctx, ws, &r, 256, 1024, false);
    check_dense(ctx, ws, &r, 50, 129, true);
    float nanA[6] = {1, 2, 3, 4, NAN, 6};
    csi_linop *D = NULL;
    st = csi_dense_create(ctx, 2, 3, nanA, false, &D);
    CHECK(st == CSI_ERR_ARG && D == NULL && strstr(csi_last_error(), "(1, 1)"), "%s", csi_last_error());
    csi_vec_ws_free(ws);
    return test_done();
}
