/* csi-bench-spectral: time of one Gaussian filter pass (forward real transform, gain multiply,
 * inverse real transform) on the OpenCL device, against FFTW 3 float doing the same pass
 * (FFTW_MEASURE r2c / c2r, 1 and 2 threads) and against a device copy of the same bytes.
 *
 *   csi-bench-spectral [--runs N] [--only 2d|3d] [--md FILE]
 *
 * Sizes: 1024 x 1024 (2-D) and 512 x 512 x 128 (3-D, the paper's motion-blur volume); also
 * 96 x 64 and 64 x 64 (small, launch-overhead bound). Each figure is the median of N timed runs
 * after one warm-up run. Ratios are device time / FFTW time (lower is better). With --md the
 * table is also written as Markdown (with the command line and the machine) to FILE. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include "csi/spectral.h"

#ifdef CSI_HAVE_FFTW
#include <fftw3.h>
#endif

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_d);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#define DIE(...)                                                                             \
    do {                                                                                     \
        fprintf(stderr, "csi-bench-spectral: " __VA_ARGS__);                                 \
        fputc('\n', stderr);                                                                 \
        exit(1);                                                                             \
    } while (0)
#define OK(expr)                                                                             \
    do {                                                                                     \
        csi_status st_ = (expr);                                                             \
        if (st_ != CSI_OK)                                                                   \
            DIE("%s: %s", #expr, csi_last_error());                                          \
    } while (0)

typedef struct {
    const char *label;
    size_t dims[3];
    double dev_ms, copy_ms, fftw1_ms, fftw2_ms;
} row;

static double time_device_filter(csi_ctx *ctx, const size_t dims[3], int runs, double *copy_ms)
{
    size_t n = dims[0] * dims[1] * dims[2];
    double sig[3] = {1.1, 1.1, dims[2] > 1 ? 1.1 : 0.0};
    csi_linop *op;
    OK(csi_filter_create(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, &op));
    cl_mem x, y;
    OK(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "bench input", &x));
    OK(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "bench output", &y));
    float *h = malloc(n * 4);
    for (size_t i = 0; i < n; i++)
        h[i] = (float)((i * 2654435761u) % 1000) * 1e-3f;
    OK(csi_write(ctx, x, 0, n * 4, h));
    free(h);
    double *t = malloc((size_t)runs * sizeof *t);
    OK(csi_linop_apply(op, x, y)); /* warm-up: first launches, page faults */
    OK(csi_finish(ctx));
    for (int r = 0; r < runs; r++) {
        double t0 = now();
        OK(csi_linop_apply(op, x, y));
        OK(csi_finish(ctx));
        t[r] = now() - t0;
    }
    double dev = median(t, runs);
    OK(csi_copy(ctx, y, 0, x, 0, n * 4));
    OK(csi_finish(ctx));
    for (int r = 0; r < runs; r++) {
        double t0 = now();
        OK(csi_copy(ctx, y, 0, x, 0, n * 4));
        OK(csi_finish(ctx));
        t[r] = now() - t0;
    }
    *copy_ms = 1e3 * median(t, runs);
    free(t);
    csi_buffer_release(&x);
    csi_buffer_release(&y);
    csi_linop_free(op);
    return 1e3 * dev;
}

#ifdef CSI_HAVE_FFTW
/* FFTW's threads library is not in the build's link line (pkg-config fftw3f gives only
 * -lfftw3f), so it is loaded at run time. */
typedef int (*init_threads_fn)(void);
typedef void (*plan_threads_fn)(int);
static plan_threads_fn fftw_plan_threads;

static void fftw_threads_load(void)
{
    void *lib = dlopen("libfftw3f_threads.so.3", RTLD_NOW | RTLD_GLOBAL);
    if (!lib)
        return;
    init_threads_fn init = (init_threads_fn)dlsym(lib, "fftwf_init_threads");
    plan_threads_fn plan = (plan_threads_fn)dlsym(lib, "fftwf_plan_with_nthreads");
    if (init && plan && init())
        fftw_plan_threads = plan;
}

/* The same pass with FFTW: r2c, multiply by the separable Gaussian, c2r (scaled by 1/N). */
static double time_fftw_filter(const size_t dims[3], int runs, int threads)
{
    if (threads > 1 && !fftw_plan_threads)
        return NAN;
    if (fftw_plan_threads)
        fftw_plan_threads(threads);
    int nd = dims[2] > 1 ? 3 : 2;
    int nn[3];
    if (nd == 3) {
        nn[0] = (int)dims[2];
        nn[1] = (int)dims[1];
        nn[2] = (int)dims[0];
    } else {
        nn[0] = (int)dims[1];
        nn[1] = (int)dims[0];
    }
    size_t n = dims[0] * dims[1] * dims[2], h0 = dims[0] / 2 + 1, nh = h0 * dims[1] * dims[2];
    float *x = fftwf_alloc_real(n), *y = fftwf_alloc_real(n);
    fftwf_complex *s = fftwf_alloc_complex(nh);
    fftwf_plan pf = fftwf_plan_dft_r2c(nd, nn, x, s, FFTW_MEASURE);
    fftwf_plan pb = fftwf_plan_dft_c2r(nd, nn, s, y, FFTW_MEASURE | FFTW_DESTROY_INPUT);
    if (!pf || !pb)
        DIE("FFTW planning failed");
    for (size_t i = 0; i < n; i++)
        x[i] = (float)((i * 2654435761u) % 1000) * 1e-3f;
    float *g0 = malloc(h0 * 4), *g1 = malloc(dims[1] * 4), *g2 = malloc(dims[2] * 4);
    for (size_t k = 0; k < h0; k++)
        g0[k] = (float)(csi_gauss_gain_1d(dims[0], k, 1.1) / (double)n);
    for (size_t k = 0; k < dims[1]; k++)
        g1[k] = (float)csi_gauss_gain_1d(dims[1], k, 1.1);
    for (size_t k = 0; k < dims[2]; k++)
        g2[k] = (float)csi_gauss_gain_1d(dims[2], k, dims[2] > 1 ? 1.1 : 0.0);
    double *t = malloc((size_t)(runs + 1) * sizeof *t);
    for (int r = -1; r < runs; r++) {
        double t0 = now();
        fftwf_execute(pf);
        for (size_t k = 0; k < dims[2]; k++)
            for (size_t j = 0; j < dims[1]; j++) {
                float gjk = g1[j] * g2[k];
                fftwf_complex *line = s + h0 * (j + dims[1] * k);
                for (size_t i = 0; i < h0; i++) {
                    float gi = g0[i] * gjk;
                    line[i][0] *= gi;
                    line[i][1] *= gi;
                }
            }
        fftwf_execute(pb);
        if (r >= 0)
            t[r] = now() - t0;
    }
    double med = median(t, runs);
    free(t);
    free(g0);
    free(g1);
    free(g2);
    fftwf_destroy_plan(pf);
    fftwf_destroy_plan(pb);
    fftwf_free(x);
    fftwf_free(y);
    fftwf_free(s);
    return 1e3 * med;
}
#endif

int main(int argc, char **argv)
{
    int runs = 7;
    const char *only = NULL, *md = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--runs") && i + 1 < argc)
            runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--only") && i + 1 < argc)
            only = argv[++i];
        else if (!strcmp(argv[i], "--md") && i + 1 < argc)
            md = argv[++i];
        else {
            fprintf(stderr, "usage: csi-bench-spectral [--runs N] [--only 2d|3d|small] [--md FILE]\n");
            return 2;
        }
    }
    if (runs < 1)
        runs = 1;
    csi_ctx *ctx;
    OK(csi_ctx_create(&ctx, NULL));
#ifdef CSI_HAVE_FFTW
    fftw_threads_load();
#endif
    row rows[] = {
        {"64 x 64", {64, 64, 1}, 0, 0, 0, 0},
        {"96 x 64", {96, 64, 1}, 0, 0, 0, 0},
        {"1024 x 1024", {1024, 1024, 1}, 0, 0, 0, 0},
        {"512 x 512 x 128", {512, 512, 128}, 0, 0, 0, 0},
    };
    int nrows = (int)(sizeof rows / sizeof rows[0]);
    printf("device: %s\n", csi_ctx_device_name(ctx));
    printf("%-16s %10s %10s %10s %10s %9s %9s %9s\n", "size", "device ms", "copy ms", "fftw1 ms",
           "fftw2 ms", "dev/fftw1", "dev/fftw2", "dev/copy");
    for (int i = 0; i < nrows; i++) {
        row *r = &rows[i];
        bool is3 = r->dims[2] > 1, small = r->dims[0] * r->dims[1] < 100000;
        if (only && ((!strcmp(only, "2d") && (is3 || small)) || (!strcmp(only, "3d") && !is3) ||
                     (!strcmp(only, "small") && !small)))
            continue;
        int rr = is3 ? (runs < 5 ? runs : 5) : runs;
        r->dev_ms = time_device_filter(ctx, r->dims, rr, &r->copy_ms);
#ifdef CSI_HAVE_FFTW
        r->fftw1_ms = time_fftw_filter(r->dims, rr, 1);
        r->fftw2_ms = time_fftw_filter(r->dims, rr, 2);
#else
        r->fftw1_ms = r->fftw2_ms = NAN;
#endif
        printf("%-16s %10.3f %10.3f %10.3f %10.3f %9.2f %9.2f %9.1f\n", r->label, r->dev_ms,
               r->copy_ms, r->fftw1_ms, r->fftw2_ms, r->dev_ms / r->fftw1_ms,
               r->dev_ms / r->fftw2_ms, r->dev_ms / r->copy_ms);
        fflush(stdout);
    }
    if (md) {
        FILE *f = fopen(md, "w");
        if (!f)
            DIE("cannot write %s", md);
        struct utsname u;
        uname(&u);
        char cpu[600] = "?";
        FILE *ci = fopen("/proc/cpuinfo", "r");
        if (ci) {
            char line[512];
            while (fgets(line, sizeof line, ci))
                if (!strncmp(line, "model name", 10)) {
                    char *p = strchr(line, ':');
                    snprintf(cpu, sizeof cpu, "%s", p ? p + 2 : line);
                    cpu[strcspn(cpu, "\n")] = 0;
                    break;
                }
            fclose(ci);
        }
        fprintf(f, "| size | device ms | device copy ms | FFTW 1 thread ms | FFTW 2 threads ms | "
                   "device / FFTW 1 | device / FFTW 2 | device / copy |\n");
        fprintf(f, "|---|---|---|---|---|---|---|---|\n");
        for (int i = 0; i < nrows; i++) {
            row *r = &rows[i];
            if (r->dev_ms == 0)
                continue;
            fprintf(f, "| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f |\n", r->label,
                    r->dev_ms, r->copy_ms, r->fftw1_ms, r->fftw2_ms, r->dev_ms / r->fftw1_ms,
                    r->dev_ms / r->fftw2_ms, r->dev_ms / r->copy_ms);
        }
        fprintf(f, "\nCommand: `");
        for (int i = 0; i < argc; i++)
            fprintf(f, "%s%s", i ? " " : "", argv[i]);
        fprintf(f, "`, median of %d runs (3-D: at most 5) after one warm-up.  \n", runs);
        fprintf(f, "Machine: %s, %ld cores online, %s %s; device: %s.\n", cpu,
                sysconf(_SC_NPROCESSORS_ONLN), u.sysname, u.release, csi_ctx_device_name(ctx));
        fclose(f);
    }
    csi_ctx_release(ctx);
    return 0;
}
