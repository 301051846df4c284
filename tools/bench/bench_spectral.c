/* csi-bench-spectral: time of one Gaussian filter pass (forward real transform, gain multiply,
 * inverse real transform) on the OpenCL device, against FFTW 3 float doing the same pass
 * (FFTW_MEASURE r2c / c2r, 1 and 2 threads) and against a device copy of the same bytes.
 *
 *   csi-bench-spectral [--runs N] [--only 2d|3d] [--md FILE]
 *
 * Sizes: 1024 x 1024 and 768 x 1024 (2-D, 768 = 3 * 2^8) and 512 x 512 x 128 (3-D, the paper's
 * motion-blur volume); also 96 x 64 and 64 x 64 (small, launch-overhead bound). Both device
 * paths are timed: csi's own FFT kernels (what csi_filter_create uses) and clFFT. Each figure is the median of N timed runs
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
    double dev_ms, clfft_ms, copy_ms, fftw1_ms, fftw2_ms;
} row;

/* One device filter (csi's FFT kernels or clFFT) with its buffers. */
typedef struct {
    csi_ctx *ctx;
    csi_linop *op;
    cl_mem x, y;
    size_t n;
} dev_case;

static void dev_setup(dev_case *d, csi_ctx *ctx, const size_t dims[3], csi_fft_backend be)
{
    d->ctx = ctx;
    d->n = dims[0] * dims[1] * dims[2];
    double sig[3] = {1.1, 1.1, dims[2] > 1 ? 1.1 : 0.0};
    OK(csi_filter_create_backend(ctx, dims, sig, CSI_FILTER_GAUSS, 0.0f, be, &d->op));
    OK(csi_buffer(ctx, d->n * 4, CL_MEM_READ_WRITE, "bench input", &d->x));
    OK(csi_buffer(ctx, d->n * 4, CL_MEM_READ_WRITE, "bench output", &d->y));
    float *h = malloc(d->n * 4);
    for (size_t i = 0; i < d->n; i++)
        h[i] = (float)((i * 2654435761u) % 1000) * 1e-3f;
    OK(csi_write(ctx, d->x, 0, d->n * 4, h));
    free(h);
    OK(csi_linop_apply(d->op, d->x, d->y)); /* warm-up: first launches, page faults */
    OK(csi_finish(ctx));
}

static double dev_pass(dev_case *d)
{
    double t0 = now();
    OK(csi_linop_apply(d->op, d->x, d->y));
    OK(csi_finish(d->ctx));
    return now() - t0;
}

static double dev_copy(dev_case *d)
{
    double t0 = now();
    OK(csi_copy(d->ctx, d->y, 0, d->x, 0, d->n * 4));
    OK(csi_finish(d->ctx));
    return now() - t0;
}

static void dev_free(dev_case *d)
{
    csi_buffer_release(&d->x);
    csi_buffer_release(&d->y);
    csi_linop_free(d->op);
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

/* The same pass with FFTW: r2c, multiply by the separable Gaussian (and 1/N), c2r. */
typedef struct {
    size_t dims[3], n, h0;
    float *x, *y, *g0, *g1, *g2;
    fftwf_complex *s;
    fftwf_plan pf, pb;
} fftw_case;

static bool fftwcase_setup(fftw_case *f, const size_t dims[3], int threads)
{
    memset(f, 0, sizeof *f);
    if (threads > 1 && !fftw_plan_threads)
        return false;
    if (fftw_plan_threads)
        fftw_plan_threads(threads);
    memcpy(f->dims, dims, sizeof f->dims);
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
    f->n = dims[0] * dims[1] * dims[2];
    f->h0 = dims[0] / 2 + 1;
    size_t nh = f->h0 * dims[1] * dims[2];
    f->x = fftwf_alloc_real(f->n);
    f->y = fftwf_alloc_real(f->n);
    f->s = fftwf_alloc_complex(nh);
    f->pf = fftwf_plan_dft_r2c(nd, nn, f->x, f->s, FFTW_MEASURE);
    f->pb = fftwf_plan_dft_c2r(nd, nn, f->s, f->y, FFTW_MEASURE | FFTW_DESTROY_INPUT);
    if (!f->pf || !f->pb)
        DIE("FFTW planning failed");
    for (size_t i = 0; i < f->n; i++)
        f->x[i] = (float)((i * 2654435761u) % 1000) * 1e-3f;
    f->g0 = malloc(f->h0 * 4);
    f->g1 = malloc(dims[1] * 4);
    f->g2 = malloc(dims[2] * 4);
    for (size_t k = 0; k < f->h0; k++)
        f->g0[k] = (float)(csi_gauss_gain_1d(dims[0], k, 1.1) / (double)f->n);
    for (size_t k = 0; k < dims[1]; k++)
        f->g1[k] = (float)csi_gauss_gain_1d(dims[1], k, 1.1);
    for (size_t k = 0; k < dims[2]; k++)
        f->g2[k] = (float)csi_gauss_gain_1d(dims[2], k, dims[2] > 1 ? 1.1 : 0.0);
    return true;
}

static double fftwcase_pass(fftw_case *f)
{
    double t0 = now();
    fftwf_execute(f->pf);
    for (size_t k = 0; k < f->dims[2]; k++)
        for (size_t j = 0; j < f->dims[1]; j++) {
            float gjk = f->g1[j] * f->g2[k];
            fftwf_complex *line = f->s + f->h0 * (j + f->dims[1] * k);
            for (size_t i = 0; i < f->h0; i++) {
                float gi = f->g0[i] * gjk;
                line[i][0] *= gi;
                line[i][1] *= gi;
            }
        }
    fftwf_execute(f->pb);
    return now() - t0;
}

static void fftwcase_free(fftw_case *f)
{
    if (!f->pf)
        return;
    fftwf_destroy_plan(f->pf);
    fftwf_destroy_plan(f->pb);
    fftwf_free(f->x);
    fftwf_free(f->y);
    fftwf_free(f->s);
    free(f->g0);
    free(f->g1);
    free(f->g2);
}
#endif

/* All contenders timed in turn within each round, so that load from other processes on a shared
 * machine hits them alike; medians over the rounds. */
static void measure(csi_ctx *ctx, row *r, int runs)
{
    dev_case dn, dc;
    dev_setup(&dn, ctx, r->dims, CSI_FFT_AUTO);
    dev_setup(&dc, ctx, r->dims, CSI_FFT_CLFFT);
    double *t[5];
    for (int i = 0; i < 5; i++)
        t[i] = calloc((size_t)runs, sizeof(double));
#ifdef CSI_HAVE_FFTW
    fftw_case f1, f2;
    bool have1 = fftwcase_setup(&f1, r->dims, 1);
    bool have2 = fftwcase_setup(&f2, r->dims, 2);
    if (have1)
        fftwcase_pass(&f1);
    if (have2)
        fftwcase_pass(&f2);
#endif
    for (int k = 0; k < runs; k++) {
        t[0][k] = dev_pass(&dn);
        t[1][k] = dev_pass(&dc);
        t[2][k] = dev_copy(&dn);
#ifdef CSI_HAVE_FFTW
        if (have1)
            t[3][k] = fftwcase_pass(&f1);
        if (have2) {
            fftw_plan_threads(2);
            t[4][k] = fftwcase_pass(&f2);
        }
#endif
    }
    r->dev_ms = 1e3 * median(t[0], runs);
    r->clfft_ms = 1e3 * median(t[1], runs);
    r->copy_ms = 1e3 * median(t[2], runs);
    r->fftw1_ms = r->fftw2_ms = NAN;
#ifdef CSI_HAVE_FFTW
    if (have1)
        r->fftw1_ms = 1e3 * median(t[3], runs);
    if (have2)
        r->fftw2_ms = 1e3 * median(t[4], runs);
    fftwcase_free(&f1);
    fftwcase_free(&f2);
#endif
    for (int i = 0; i < 5; i++)
        free(t[i]);
    dev_free(&dn);
    dev_free(&dc);
}

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
        {"64 x 64", {64, 64, 1}, 0, 0, 0, 0, 0},
        {"96 x 64", {96, 64, 1}, 0, 0, 0, 0, 0},
        {"1024 x 1024", {1024, 1024, 1}, 0, 0, 0, 0, 0},
        {"768 x 1024", {768, 1024, 1}, 0, 0, 0, 0, 0},
        {"512 x 512 x 128", {512, 512, 128}, 0, 0, 0, 0, 0},
    };
    int nrows = (int)(sizeof rows / sizeof rows[0]);
    printf("device: %s\n", csi_ctx_device_name(ctx));
    printf("%-16s %9s %9s %9s %9s %9s %9s %9s %9s %9s\n", "size", "csi ms", "clFFT ms", "copy ms",
           "fftw1 ms", "fftw2 ms", "csi/fftw1", "csi/fftw2", "csi/copy", "clfft/fw1");
    for (int i = 0; i < nrows; i++) {
        row *r = &rows[i];
        bool is3 = r->dims[2] > 1, small = r->dims[0] * r->dims[1] < 100000;
        if (only && ((!strcmp(only, "2d") && (is3 || small)) || (!strcmp(only, "3d") && !is3) ||
                     (!strcmp(only, "small") && !small)))
            continue;
        measure(ctx, r, runs);
        printf("%-16s %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.2f %9.1f %9.2f\n", r->label, r->dev_ms,
               r->clfft_ms, r->copy_ms, r->fftw1_ms, r->fftw2_ms, r->dev_ms / r->fftw1_ms,
               r->dev_ms / r->fftw2_ms, r->dev_ms / r->copy_ms, r->clfft_ms / r->fftw1_ms);
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
        fprintf(f, "| size | csi FFT ms | clFFT ms | device copy ms | FFTW 1 thread ms | "
                   "FFTW 2 threads ms | csi / FFTW 1 | csi / FFTW 2 | csi / copy | clFFT / FFTW 1 |\n");
        fprintf(f, "|---|---|---|---|---|---|---|---|---|---|\n");
        for (int i = 0; i < nrows; i++) {
            row *r = &rows[i];
            if (r->dev_ms == 0)
                continue;
            fprintf(f, "| %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.1f | %.2f |\n",
                    r->label, r->dev_ms, r->clfft_ms, r->copy_ms, r->fftw1_ms, r->fftw2_ms,
                    r->dev_ms / r->fftw1_ms, r->dev_ms / r->fftw2_ms, r->dev_ms / r->copy_ms,
                    r->clfft_ms / r->fftw1_ms);
        }
        fprintf(f, "\nCommand: `");
        for (int i = 0; i < argc; i++)
            fprintf(f, "%s%s", i ? " " : "", argv[i]);
        double load[3] = {0, 0, 0};
        FILE *la = fopen("/proc/loadavg", "r");
        if (la) {
            if (fscanf(la, "%lf %lf %lf", &load[0], &load[1], &load[2]) != 3)
                load[0] = load[1] = load[2] = 0;
            fclose(la);
        }
        fprintf(f, "`, median of %d rounds after one warm-up; in each round every contender runs "
                   "once, in turn.  \n", runs);
        fprintf(f, "Load average when written: %.2f %.2f %.2f.  \n", load[0], load[1], load[2]);
        fprintf(f, "Machine: %s, %ld cores online, %s %s; device: %s.\n", cpu,
                sysconf(_SC_NPROCESSORS_ONLN), u.sysname, u.release, csi_ctx_device_name(ctx));
        fclose(f);
    }
    csi_ctx_release(ctx);
    return 0;
}
