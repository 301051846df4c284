/* csi-bench-wavelet: median wall time of the 2-D wavelet forward + inverse (csi_wavelet) against
 * a device buffer copy of the same bytes (clEnqueueCopyBuffer, and a float4 copy kernel), on the
 * csi device (PoCL CPU unless CSI_DEVICE says otherwise).
 *
 *   csi-bench-wavelet [--reps N] [--sizes 1024,2048,4096x4320] [--levels L] [--markdown]
 *
 * Each figure is the median over N timed runs after two warm-up runs, timed on the host around
 * enqueue + clFinish (so launch overheads count, as they do for the solvers). Levels default to
 * csi_wavelet_default_levels. Also checks inverse(forward(x)) = x on the benchmark data, so a
 * fast wrong kernel cannot go unnoticed, and prints a hash of the forward and inverse outputs'
 * bytes, so that two builds meant to give the same bits can be compared. */
#include <math.h>
#include <stdio.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/resource.h>

#include "csi/runtime.h"
#include "csi/wavelet.h"
#include "fnv1a.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* Process CPU time (all threads, so both PoCL workers): robust to other load on the machine,
 * which wall time is not. */
static double cpu_seconds(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec +
           1e-6 * (double)(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

static void die(const char *what)
{
    fprintf(stderr, "csi-bench-wavelet: %s: %s\n", what, csi_last_error());
    exit(1);
}

/* A plain copy kernel, built here (it is a yardstick, not part of the library). */
static const char *copy_src =
    "__kernel void bench_copy4(__global const float4 *src, __global float4 *dst, const uint n4)\n"
    "{ const uint i = get_global_id(0); if (i < n4) dst[i] = src[i]; }\n";

int main(int argc, char **argv)
{
    int reps = 11, fixed_levels = 0;
    bool markdown = false;
    size_t sizes[8] = {1024, 2048}, heights[8] = {1024, 2048};
    int nsizes = 2;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--reps") && i + 1 < argc)
            reps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--levels") && i + 1 < argc)
            fixed_levels = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--markdown"))
            markdown = true;
        else if (!strcmp(argv[i], "--sizes") && i + 1 < argc) {
            nsizes = 0;
            for (char *p = strtok(argv[++i], ","); p && nsizes < 8; p = strtok(NULL, ","))
            {
                char *end;
                sizes[nsizes] = heights[nsizes] = (size_t)strtoul(p, &end, 10);
                if (*end == 'x')
                    heights[nsizes] = (size_t)strtoul(end + 1, NULL, 10);
                nsizes++;
            }
        } else {
            fprintf(stderr, "usage: %s [--reps N] [--sizes 1024,2048,WxH] [--levels L] [--markdown]\n",
                    argv[0]);
            return 2;
        }
    }
    if (reps < 1 || reps > 1000)
        reps = 11;

    csi_ctx *ctx;
    if (csi_ctx_create(&ctx, NULL) != CSI_OK)
        die("device");
    cl_int err;
    cl_context clctx = csi_ctx_context(ctx);
    cl_device_id dev = csi_ctx_device(ctx);
    cl_program prog = clCreateProgramWithSource(clctx, 1, &copy_src, NULL, &err);
    if (err != CL_SUCCESS || clBuildProgram(prog, 1, &dev, "-cl-std=CL1.2", NULL, NULL) != CL_SUCCESS) {
        fprintf(stderr, "csi-bench-wavelet: copy kernel failed to build\n");
        return 1;
    }
    cl_kernel kcopy = clCreateKernel(prog, "bench_copy4", &err);
    if (err != CL_SUCCESS) {
        fprintf(stderr, "csi-bench-wavelet: clCreateKernel failed\n");
        return 1;
    }

    printf("device: %s\n", csi_ctx_device_name(ctx));
    printf("median of %d runs after 2 warm-ups; wall time around enqueue + clFinish\n\n", reps);
    if (markdown) {
        printf("| size | wavelet | levels | forward ms | inverse ms | fwd+inv ms | copyBuffer ms | "
               "copy kernel ms | (fwd+inv) / copyBuffer | (fwd+inv) / copy kernel | fwd+inv CPU ms | max roundtrip err | hash fwd, inv |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    } else {
        printf("%-10s %-4s %3s %8s %8s %8s %10s %9s %8s %8s %8s %8s %s\n", "size", "wav", "L", "fwd ms",
               "inv ms", "f+i ms", "copyBuf ms", "copyK ms", "f+i/cpB", "f+i/cpK", "f+i cpu", "rt err", "hash fwd, inv");
    }

    double *t = malloc((size_t)reps * sizeof *t), *t2 = malloc((size_t)reps * sizeof *t2);
    for (int si = 0; si < nsizes; si++) {
        const size_t w = sizes[si], h = heights[si], n = w * h, bytes = n * sizeof(float);
        float *host = malloc(bytes), *back = malloc(bytes);
        uint64_t s = 12345;
        for (size_t i = 0; i < n; i++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            host[i] = (float)((s >> 40) & 0xffff) / 65536.0f - 0.5f;
        }
        cl_mem a, b, c;
        if (csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "bench image", &a) != CSI_OK ||
            csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "bench coefficients", &b) != CSI_OK ||
            csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "bench output", &c) != CSI_OK)
            die("buffers");
        if (csi_write(ctx, a, 0, bytes, host) != CSI_OK)
            die("upload");

        /* Copy yardsticks on the same bytes. */
        for (int r = -2; r < reps; r++) {
            double t0 = now();
            if (csi_copy(ctx, c, 0, a, 0, bytes) != CSI_OK || csi_finish(ctx) != CSI_OK)
                die("copy");
            if (r >= 0)
                t[r] = now() - t0;
        }
        double copy_buf = median(t, reps);
        const cl_uint n4 = (cl_uint)(n / 4);
        for (int r = -2; r < reps; r++) {
            double t0 = now();
            size_t global = n4, local = 256;
            if (CSI_ARGS(kcopy, CSI_MEM(a), CSI_MEM(c), CSI_ARG(n4)) != CSI_OK ||
                csi_run(ctx, kcopy, 1, &global, &local) != CSI_OK || csi_finish(ctx) != CSI_OK)
                die("copy kernel");
            if (r >= 0)
                t[r] = now() - t0;
        }
        double copy_k = median(t, reps);

        for (int fi = 0; fi < 2; fi++) {
            csi_wavelet_family f = fi == 0 ? CSI_WAVELET_DB4 : CSI_WAVELET_DB8;
            int levels = fixed_levels > 0 ? fixed_levels : csi_wavelet_default_levels(f, w, h);
            csi_linop *op;
            if (csi_wavelet_create(ctx, f, w, h, levels, &op) != CSI_OK)
                die("create");
            double c0 = 0;
            for (int r = -2; r < reps; r++) {
                if (r == 0)
                    c0 = cpu_seconds();
                double t0 = now();
                if (csi_linop_adjoint(op, a, b) != CSI_OK || csi_finish(ctx) != CSI_OK)
                    die("forward");
                double t1 = now();
                if (csi_linop_apply(op, b, c) != CSI_OK || csi_finish(ctx) != CSI_OK)
                    die("inverse");
                if (r >= 0) {
                    t[r] = t1 - t0;
                    t2[r] = now() - t1;
                }
            }
            double cpu = (cpu_seconds() - c0) / reps; /* mean CPU time of one forward + inverse */
            double tf = median(t, reps), ti = median(t2, reps);
            if (csi_read(ctx, b, 0, bytes, back) != CSI_OK)
                die("download");
            const uint64_t hf = fnv1a(back, bytes);
            if (csi_read(ctx, c, 0, bytes, back) != CSI_OK)
                die("download");
            const uint64_t hi = fnv1a(back, bytes);
            double err = 0;
            for (size_t i = 0; i < n; i++)
                err = fmax(err, fabs((double)back[i] - (double)host[i]));
            const double ms = 1e3;
            char label[32];
            snprintf(label, sizeof label, "%zux%zu", w, h);
            if (markdown)
                printf("| %zux%zu | %s | %d | %.2f | %.2f | %.2f | %.3f | %.3f | %.1f | %.1f | %.2f | %.1e | %016llx %016llx |\n", w,
                       h, csi_wavelet_name(f), levels, tf * ms, ti * ms, (tf + ti) * ms, copy_buf * ms,
                       copy_k * ms, (tf + ti) / copy_buf, (tf + ti) / copy_k, cpu * ms, err,
                       (unsigned long long)hf, (unsigned long long)hi);
            else
                printf("%-10s %-4s %3d %8.2f %8.2f %8.2f %10.3f %9.3f %8.1f %8.1f %8.2f %8.1e %016llx %016llx\n", label,
                       csi_wavelet_name(f), levels, tf * ms, ti * ms, (tf + ti) * ms, copy_buf * ms,
                       copy_k * ms, (tf + ti) / copy_buf, (tf + ti) / copy_k, cpu * ms, err,
                       (unsigned long long)hf, (unsigned long long)hi);
            csi_linop_free(op);
        }
        csi_buffer_release(&a);
        csi_buffer_release(&b);
        csi_buffer_release(&c);
        free(host);
        free(back);
    }
    free(t);
    free(t2);
    clReleaseKernel(kcopy);
    clReleaseProgram(prog);
    csi_ctx_release(ctx);
    return 0;
}
