/* csi-bench-model-filter: CPU and wall time of the model grid's filter (csi_model_filter_create:
 * the Wiener filter with its complex factor, on csi's own FFT kernels), one apply and one
 * adjoint per run, on a W x H model grid (issue 13; docs/bench/cost.md). The 1920x1080, 4 spp
 * case's tiles have 2880 x 4320 model grids, the demo's 1024 x 1024. With the kernel-profile
 * preload it gives each FFT pass's cost:
 *
 *   csi-bench-model-filter [W H [RUNS]]          (default 1024 1024 10)
 *   CSI_KERNEL_PROFILE=prof.tsv LD_PRELOAD=build/libcsi-preload-kernel-profile.so \
 *       build/csi-bench-model-filter 2880 4320 6
 *
 * Prints the fastest and the median run (CPU: the process's, all threads), after one warm-up
 * run that builds the programs. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "csi/linop.h"
#include "csi/model_grid.h"
#include "csi/runtime.h"

static double clock_s(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static int fail(const char *what)
{
    fprintf(stderr, "csi-bench-model-filter: %s: %s\n", what, csi_last_error());
    return 1;
}

int main(int argc, char **argv)
{
    const long w = argc > 1 ? atol(argv[1]) : 1024, h = argc > 2 ? atol(argv[2]) : 1024;
    const int runs = argc > 3 ? atoi(argv[3]) : 10;
    if (argc > 4 || w < 4 || w % 2 || h < 2 || runs < 1 || runs > 1000) {
        fprintf(stderr, "usage: csi-bench-model-filter [W H [RUNS]]  (W even >= 4, H >= 2, 1-1000 runs)\n");
        return 2;
    }
    csi_ctx *ctx;
    if (csi_ctx_create(&ctx, NULL) != CSI_OK)
        return fail("OpenCL device");
    /* sigma of csi-render's default 8x grid at 4 spp, on the fine grid (D = 2) */
    const double sigma[2] = {3.2, 3.2};
    csi_linop *op;
    if (csi_model_filter_create(ctx, (size_t)w, (size_t)h, 2, sigma, 0.3f, CSI_WAVELET_DB4, 1, 1, &op) != CSI_OK)
        return fail("model filter");
    const size_t n = (size_t)w * (size_t)h;
    float *x = malloc(n * sizeof *x);
    double *cpu = malloc((size_t)runs * sizeof *cpu), *wall = malloc((size_t)runs * sizeof *wall);
    if (!x || !cpu || !wall) {
        fprintf(stderr, "csi-bench-model-filter: out of host memory\n");
        return 1;
    }
    for (size_t i = 0; i < n; i++)
        x[i] = (float)((i * 2654435761u) % 1000) / 1000.0f - 0.5f;
    cl_mem a, b;
    if (csi_buffer(ctx, n * sizeof *x, CL_MEM_READ_WRITE, "input", &a) != CSI_OK ||
        csi_buffer(ctx, n * sizeof *x, CL_MEM_READ_WRITE, "output", &b) != CSI_OK ||
        csi_write(ctx, a, 0, n * sizeof *x, x) != CSI_OK)
        return fail("buffers");
    for (int r = -1; r < runs; r++) {
        const double c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID), t0 = clock_s(CLOCK_MONOTONIC);
        if (csi_linop_apply(op, a, b) != CSI_OK || csi_linop_adjoint(op, b, a) != CSI_OK ||
            csi_finish(ctx) != CSI_OK)
            return fail("filter run");
        if (r >= 0) {
            cpu[r] = clock_s(CLOCK_PROCESS_CPUTIME_ID) - c0;
            wall[r] = clock_s(CLOCK_MONOTONIC) - t0;
        }
    }
    qsort(cpu, (size_t)runs, sizeof *cpu, cmp_d);
    qsort(wall, (size_t)runs, sizeof *wall, cmp_d);
    printf("model filter %ld x %ld, apply + adjoint, %d runs: CPU min %.2f ms median %.2f ms; "
           "wall min %.2f ms median %.2f ms\n",
           w, h, runs, 1e3 * cpu[0], 1e3 * cpu[runs / 2], 1e3 * wall[0], 1e3 * wall[runs / 2]);
    free(x);
    free(cpu);
    free(wall);
    csi_buffer_release(&a);
    csi_buffer_release(&b);
    csi_linop_free(op);
    csi_ctx_release(ctx);
    return 0;
}
