/* csi-bench-interp: CPU time of the interpolation operator (csi/interp.h) alone, its gather
 * (apply) and its spreading (adjoint), on a model grid of MW x MH cells at D = 2 with 4 samples in
 * each pixel of 8 x 8 fine cells (csi's default grid at 4 spp; each at a random cell of its pixel),
 * in raster order of the fine grid as csi's dumps hold them, or shuffled.
 *
 *   csi-bench-interp MW MH RUNS [shuffle]
 *
 * Prints the smallest process CPU time (all threads: PoCL's workers) of one spreading and of one
 * gather over RUNS runs, and hashes of the spreading's output and of the gather of that output,
 * so that two builds can be checked for the same bits on the same samples (the samples come from
 * a fixed seed). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "csi/interp.h"
#include "csi/linop.h"
#include "csi/runtime.h"
#include "fnv1a.h"

static double cpu_now(void) { return (double)clock() / CLOCKS_PER_SEC; }

static uint64_t state = 88172645463325252ull;
static uint32_t next_random(void)
{
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return (uint32_t)state;
}

static int by_index(const void *a, const void *b)
{
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static float *random_values(size_t n)
{
    float *v = malloc(n * sizeof *v);
    for (size_t i = 0; v && i < n; i++)
        v[i] = (float)(next_random() % 1000) / 500.0f - 1.0f;
    return v;
}

static int fail(const char *what)
{
    fprintf(stderr, "csi-bench-interp: %s: %s\n", what, csi_last_error());
    return 1;
}

int main(int argc, char **argv)
{
    if (argc < 4) {
        fprintf(stderr, "usage: %s MW MH RUNS [shuffle]\n", argv[0]);
        return 2;
    }
    const size_t mw = strtoul(argv[1], NULL, 10), mh = strtoul(argv[2], NULL, 10);
    const int runs = atoi(argv[3]), shuffle = argc > 4 && atoi(argv[4]);
    const unsigned D = 2;
    const size_t fw = mw * D, pw = fw / 8, ph = mh * D / 8, n = pw * ph * 4;
    uint32_t *idx = malloc(n * sizeof *idx);
    if (!idx || n == 0 || runs < 1) {
        fprintf(stderr, "csi-bench-interp: need a grid of at least 4 x 4 cells and RUNS >= 1\n");
        return 2;
    }
    size_t k = 0;
    for (size_t y = 0; y < ph; y++)
        for (size_t x = 0; x < pw; x++)
            for (int s = 0; s < 4; s++)
                idx[k++] = (uint32_t)((y * 8 + next_random() % 8) * fw + x * 8 + next_random() % 8);
    if (!shuffle)
        qsort(idx, n, sizeof *idx, by_index);
    for (size_t i = n - 1; shuffle && i > 0; i--) {
        size_t j = next_random() % (i + 1);
        uint32_t t = idx[i];
        idx[i] = idx[j];
        idx[j] = t;
    }
    csi_ctx *ctx;
    csi_linop *op;
    cl_mem c, r;
    if (csi_ctx_create(&ctx, NULL) != CSI_OK)
        return fail("device");
    if (csi_interp_create(ctx, mw, mh, D, idx, n, &op) != CSI_OK)
        return fail("interpolation");
    float *rv = random_values(n), *cv = random_values(mw * mh);
    if (!rv || !cv || csi_buffer(ctx, mw * mh * 4, CL_MEM_READ_WRITE, "grid", &c) != CSI_OK ||
        csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "samples", &r) != CSI_OK || csi_write(ctx, r, 0, n * 4, rv) != CSI_OK)
        return fail("buffers");
    double best_spread = 1e30, best_gather = 1e30;
    for (int i = 0; i <= runs; i++) { /* run 0 warms up (programs, first touch) */
        double t0 = cpu_now();
        if (csi_linop_adjoint(op, r, c) != CSI_OK || csi_finish(ctx) != CSI_OK)
            return fail("spreading");
        double t1 = cpu_now();
        if (csi_linop_apply(op, c, r) != CSI_OK || csi_finish(ctx) != CSI_OK)
            return fail("gather");
        double t2 = cpu_now();
        if (i > 0 && t1 - t0 < best_spread)
            best_spread = t1 - t0;
        if (i > 0 && t2 - t1 < best_gather)
            best_gather = t2 - t1;
        if (csi_write(ctx, r, 0, n * 4, rv) != CSI_OK)
            return fail("samples");
    }
    if (csi_linop_adjoint(op, r, c) != CSI_OK || csi_read(ctx, c, 0, mw * mh * 4, cv) != CSI_OK)
        return fail("spreading");
    /* the gather of that spread grid back at the samples */
    if (csi_linop_apply(op, c, r) != CSI_OK || csi_read(ctx, r, 0, n * 4, rv) != CSI_OK)
        return fail("gather");
    const uint64_t h = fnv1a(cv, mw * mh * 4), hg = fnv1a(rv, n * 4);
    printf("interpolation %zu x %zu, D = %u, %zu samples (%s): spreading min %.2f ms CPU, gather min "
           "%.2f ms CPU; spread hash %016llx, gather hash %016llx\n",
           mw, mh, D, n, shuffle ? "shuffled" : "raster order", 1e3 * best_spread, 1e3 * best_gather,
           (unsigned long long)h, (unsigned long long)hg);
    csi_linop_free(op);
    csi_buffer_release(&c);
    csi_buffer_release(&r);
    free(idx);
    free(rv);
    free(cv);
    csi_ctx_release(ctx);
    return 0;
}
