/* Solver benchmark (not a test): recovery rate against the number of measurements, time per
 * phase, operator share of the time, and multi-channel strategies. Prints Markdown tables for
 * docs/bench/solve.md.
 *
 *   csi-bench-solve            everything (a few minutes on 2 cores)
 *   csi-bench-solve quick      fewer seeds
 *   csi-bench-solve wavelet    only the wavelet-problem tables
 *   csi-bench-solve large      SpaRSA, partial Fourier k = 65536, 20 seeds */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/dense.h"
#include "csi/sampling.h"
#include "csi/solve.h"
#include "csi/spectral.h"
#include "csi/vec.h"
#include "csi/wavelet.h"

static csi_ctx *ctx;

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static void die(const char *what)
{
    fprintf(stderr, "%s: %s\n", what, csi_last_error());
    exit(1);
}
#define TRY(x) do { if ((x) != CSI_OK) die(#x); } while (0)

/* splitmix64 */
static uint64_t rs;
static uint64_t rnd(void)
{
    uint64_t z = (rs += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static double unif(void) { return (double)(rnd() >> 11) * 0x1.0p-53; }
static double gauss(void)
{
    double u = unif(), v = unif();
    if (u < 1e-300)
        u = 1e-300;
    return sqrt(-2 * log(u)) * cos(6.283185307179586 * v);
}
static uint32_t *subset(size_t k, size_t n)
{
    uint32_t *p = malloc(k * sizeof *p);
    for (size_t i = 0; i < k; i++)
        p[i] = (uint32_t)i;
    for (size_t i = 0; i < n; i++) {
        size_t j = i + rnd() % (k - i);
        uint32_t t = p[i];
        p[i] = p[j];
        p[j] = t;
    }
    return p;
}

/* A timing wrapper: forwards to an inner operator, finishing the queue around each call so the
 * time spent inside the operator is attributed to it. */
typedef struct {
    csi_linop *inner;
    double t;
    long calls;
} timed_state;
static csi_status timed_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    timed_state *s = op->state;
    TRY(csi_finish(op->ctx));
    double t0 = now();
    csi_status st = csi_linop_apply(s->inner, x, y);
    csi_finish(op->ctx);
    s->t += now() - t0;
    s->calls++;
    return st;
}
static csi_status timed_adjoint(const csi_linop *op, cl_mem y, cl_mem x)
{
    timed_state *s = op->state;
    TRY(csi_finish(op->ctx));
    double t0 = now();
    csi_status st = csi_linop_adjoint(s->inner, y, x);
    csi_finish(op->ctx);
    s->t += now() - t0;
    s->calls++;
    return st;
}
static csi_linop timed(csi_linop *inner, timed_state *s)
{
    s->inner = inner;
    s->t = 0;
    s->calls = 0;
    csi_linop op = *inner;
    op.apply = timed_apply;
    op.adjoint = timed_adjoint;
    op.destroy = NULL;
    op.state = s;
    return op;
}

static csi_linop *partial_fourier(const size_t dims[3], size_t N)
{
    size_t k = dims[0] * dims[1] * dims[2];
    csi_linop *F, *S, *A;
    uint32_t *rows = subset(k, N);
    TRY(csi_fourier_create(ctx, dims, &F));
    TRY(csi_sampling_create(ctx, k, rows, N, true, &S));
    TRY(csi_linop_compose("S*F^H", S, F, true, &A));
    free(rows);
    return A;
}

static csi_linop *gaussian(size_t N, size_t k)
{
    float *A = malloc(N * k * 4);
    for (size_t i = 0; i < N * k; i++)
        A[i] = (float)(gauss() / sqrt((double)N));
    csi_linop *op;
    TRY(csi_dense_create(ctx, N, k, A, false, &op));
    free(A);
    return op;
}

static double rel_err(const float *a, const float *b, size_t n)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < n; i++) {
        num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        den += (double)b[i] * b[i];
    }
    return sqrt(num / den);
}

typedef struct {
    int ok, conv, wrong;
    double it, t, t_sel, t_lsq, t_step, t_deb, t_op;
} agg;

/* One solve of an s-sparse signal; w = 2 complex. */
static void one(bool romp, csi_linop *A, size_t s, agg *g)
{
    size_t k = A->cols, N = A->rows, w = A->complex_valued ? 2 : 1;
    float *x = calloc(k * w, 4), *xo = malloc(k * w * 4);
    uint32_t *supp = subset(k, s);
    for (size_t i = 0; i < s; i++)
        for (size_t c = 0; c < w; c++)
            x[supp[i] * w + c] = (float)gauss();
    cl_mem dx, dxt, dy;
    TRY(csi_buffer(ctx, k * w * 4, CL_MEM_READ_WRITE, "x", &dx));
    TRY(csi_buffer(ctx, k * w * 4, CL_MEM_READ_WRITE, "xt", &dxt));
    TRY(csi_buffer(ctx, N * w * 4, CL_MEM_READ_WRITE, "y", &dy));
    TRY(csi_write(ctx, dxt, 0, k * w * 4, x));
    TRY(csi_linop_apply(A, dxt, dy));
    TRY(csi_finish(ctx));
    timed_state ts;
    csi_linop T = timed(A, &ts);
    csi_solve_report rep;
    if (romp) {
        csi_romp_options o;
        csi_romp_defaults(&o);
        o.s = s;
        TRY(csi_romp(&T, dy, dx, &o, &rep));
    } else {
        TRY(csi_sparsa(&T, dy, dx, NULL, &rep));
    }
    TRY(csi_read(ctx, dx, 0, k * w * 4, xo));
    double e = rel_err(xo, x, k * w);
    g->ok += e < 1e-4;
    g->conv += rep.converged;
    g->wrong += rep.converged && !(e < 1e-3);
    g->it += rep.iterations;
    g->t += rep.t_total;
    g->t_sel += rep.t_select;
    g->t_lsq += rep.t_lsq;
    g->t_step += rep.t_step;
    g->t_deb += rep.t_debias;
    g->t_op += ts.t;
    free(x);
    free(xo);
    free(supp);
    csi_buffer_release(&dx);
    csi_buffer_release(&dxt);
    csi_buffer_release(&dy);
}

static void recovery_table(bool romp, size_t k, size_t s, const double *factors, int nf, int seeds)
{
    printf("\n%s, %s, k = %zu, s = %zu, %d seeds per row\n\n", romp ? "ROMP" : "SpaRSA (defaults)",
           romp ? "dense Gaussian N x k" : "random partial Fourier S F^H (complex)", k, s, seeds);
    printf("| N / (s ln(k/s)) | N | recovered (err < 1e-4) | converged | wrong claims | iterations | "
           "time / solve (ms) | %s | operator share |\n",
           romp ? "select / least squares (ms)" : "steps / debias (ms)");
    printf("|---|---|---|---|---|---|---|---|---|\n");
    for (int f = 0; f < nf; f++) {
        size_t N = (size_t)ceil(factors[f] * s * log((double)k / s));
        agg g = {0};
        for (int seed = 0; seed < seeds; seed++) {
            rs = 77 + 1000 * (uint64_t)f + (uint64_t)seed;
            csi_linop *A;
            if (romp) {
                A = gaussian(N, k);
            } else {
                size_t dims[3] = {k, 1, 1};
                A = partial_fourier(dims, N);
            }
            one(romp, A, s, &g);
            csi_linop_free(A);
        }
        double n = seeds;
        printf("| %.1f | %zu | %d/%d | %d | %d | %.1f | %.1f | %.1f / %.1f | %.0f%% |\n", factors[f], N, g.ok,
               seeds, g.conv, g.wrong, g.it / n, 1e3 * g.t / n, 1e3 * (romp ? g.t_sel : g.t_step) / n,
               1e3 * (romp ? g.t_lsq : g.t_deb) / n, 100 * g.t_op / g.t);
        fflush(stdout);
    }
}

/* Multi-channel: three right-hand sides over one operator. */
static void multichannel(bool romp, csi_linop *A, size_t s, int reps)
{
    size_t k = A->cols, N = A->rows, w = A->complex_valued ? 2 : 1;
    cl_mem y[3], x[3];
    for (int c = 0; c < 3; c++) {
        float *xt = calloc(k * w, 4);
        uint32_t *supp = subset(k, s);
        for (size_t i = 0; i < s; i++)
            for (size_t j = 0; j < w; j++)
                xt[supp[i] * w + j] = (float)gauss();
        cl_mem d;
        TRY(csi_buffer(ctx, k * w * 4, CL_MEM_READ_WRITE, "xt", &d));
        TRY(csi_buffer(ctx, N * w * 4, CL_MEM_READ_WRITE, "y", &y[c]));
        TRY(csi_buffer(ctx, k * w * 4, CL_MEM_READ_WRITE, "x", &x[c]));
        TRY(csi_write(ctx, d, 0, k * w * 4, xt));
        TRY(csi_linop_apply(A, d, y[c]));
        csi_buffer_release(&d);
        free(xt);
        free(supp);
    }
    csi_romp_options ro;
    csi_romp_defaults(&ro);
    ro.s = s;
    csi_solve_report rep[3];
    double t_sep = 1e30, t_multi = 1e30, sel = 0, tot = 0;
    for (int r = 0; r < reps; r++) {
        TRY(csi_finish(ctx));
        double t0 = now();
        for (int c = 0; c < 3; c++) {
            if (romp)
                TRY(csi_romp(A, y[c], x[c], &ro, &rep[c]));
            else
                TRY(csi_sparsa(A, y[c], x[c], NULL, &rep[c]));
        }
        TRY(csi_finish(ctx));
        double t1 = now();
        if (romp)
            TRY(csi_romp_multi(A, 3, y, x, &ro, rep));
        else
            TRY(csi_sparsa_multi(A, 3, y, x, NULL, rep));
        TRY(csi_finish(ctx));
        double t2 = now();
        t_sep = fmin(t_sep, t1 - t0);
        t_multi = fmin(t_multi, t2 - t1);
        sel = tot = 0;
        for (int c = 0; c < 3; c++) {
            sel += rep[c].t_select;
            tot += rep[c].t_total;
        }
    }
    printf("| %s | %s k=%zu N=%zu s=%zu | %.1f | %.1f | %.0f%% |\n", romp ? "ROMP" : "SpaRSA",
           A->name, k, N, s, 1e3 * t_sep, 1e3 * t_multi, romp ? 100 * sel / tot : 0.0);
    for (int c = 0; c < 3; c++) {
        csi_buffer_release(&y[c]);
        csi_buffer_release(&x[c]);
    }
}

/* The 2-D wavelet problem A = S Psi (db4, W x W, N = k/4): signals with s non-zeros among the
 * coarse block and the coarsest detail bands. Rows: SpaRSA defaults; ROMP as published
 * (s = true sparsity, stop at 2s); ROMP with fewer candidates per step and the support limit at
 * twice the true sparsity, raw or column-normalised. */
static void wavelet_table(size_t W, size_t strue, int seeds)
{
    const size_t k = W * W, N = k / 4;
    csi_linop *Psi, *S, *A;
    int levels = csi_wavelet_default_levels(CSI_WAVELET_DB4, W, W);
    TRY(csi_wavelet_create(ctx, CSI_WAVELET_DB4, W, W, levels, &Psi));
    rs = 99;
    uint32_t *pos = subset(k, N);
    TRY(csi_sampling_create(ctx, k, pos, N, false, &S));
    free(pos);
    TRY(csi_linop_compose("S*Psi", S, Psi, true, &A));
    size_t cw, ch;
    csi_wavelet_coarse_block(Psi, &cw, &ch);
    cl_mem norms, dx, dxt, dy;
    TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "norms", &norms));
    double tn = now();
    TRY(csi_column_norms(A, 64, 1, norms));
    TRY(csi_finish(ctx));
    tn = now() - tn;
    TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "x", &dx));
    TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "xt", &dxt));
    TRY(csi_buffer(ctx, N * 4, CL_MEM_READ_WRITE, "y", &dy));
    printf("\nWavelet problem S Psi: db4 %zu x %zu (%d levels, coarse block %zu x %zu), N = k/4 = %zu, "
           "s = %zu non-zeros in the top-left %zu x %zu coefficients, %d seeds (column norms: 64 "
           "probes, %.0f ms)\n\n", W, W, levels, cw, ch, N, strue, 2 * cw, 2 * ch, seeds, 1e3 * tn);
    printf("| solver | recovered (err < 1e-4) | converged | wrong claims | median error | time / solve (ms) |\n");
    printf("|---|---|---|---|---|---|\n");
    const char *names[] = {"SpaRSA (defaults)", "ROMP as published (s = true sparsity, stop at 2s)",
                           "ROMP s = 4, max_support = 2 x true", "ROMP s = 8, max_support = 2 x true",
                           "ROMP s = 4, max_support = 2 x true, column-normalised",
                           "ROMP s = 8, max_support = 2 x true, column-normalised"};
    float *x = malloc(k * 4), *xo = malloc(k * 4);
    double *errs = malloc((size_t)seeds * sizeof *errs);
    for (int v = 0; v < 6; v++) {
        int ok = 0, conv = 0, wrong = 0;
        double t = 0;
        for (int seed = 0; seed < seeds; seed++) {
            rs = 5000 + (uint64_t)seed;
            memset(x, 0, k * 4);
            for (size_t i = 0; i < strue; i++) {
                size_t u = rnd() % (2 * cw), w2 = rnd() % (2 * ch);
                x[w2 * W + u] = (float)gauss();
            }
            TRY(csi_write(ctx, dxt, 0, k * 4, x));
            TRY(csi_linop_apply(A, dxt, dy));
            csi_solve_report rep;
            if (v == 0) {
                TRY(csi_sparsa(A, dy, dx, NULL, &rep));
            } else {
                csi_romp_options o;
                csi_romp_defaults(&o);
                o.s = v == 1 ? strue : (v == 2 || v == 4) ? 4 : 8;
                o.max_support = v == 1 ? 0 : 2 * strue;
                o.col_norms = v >= 4 ? norms : NULL;
                TRY(csi_romp(A, dy, dx, &o, &rep));
            }
            t += rep.t_total;
            TRY(csi_read(ctx, dx, 0, k * 4, xo));
            double e = rel_err(xo, x, k);
            errs[seed] = e;
            ok += e < 1e-4;
            conv += rep.converged;
            wrong += rep.converged && !(e < 1e-3);
        }
        for (int i = 1; i < seeds; i++) /* insertion sort for the median */
            for (int j = i; j > 0 && errs[j] < errs[j - 1]; j--) {
                double tmp = errs[j];
                errs[j] = errs[j - 1];
                errs[j - 1] = tmp;
            }
        printf("| %s | %d/%d | %d | %d | %.2g | %.1f |\n", names[v], ok, seeds, conv, wrong, errs[seeds / 2],
               1e3 * t / seeds);
        fflush(stdout);
    }
    free(x);
    free(xo);
    free(errs);
    csi_buffer_release(&norms);
    csi_buffer_release(&dx);
    csi_buffer_release(&dxt);
    csi_buffer_release(&dy);
    csi_linop_free(A);
}

int main(int argc, char **argv)
{
    const bool known = argc < 2 || !strcmp(argv[1], "quick") || !strcmp(argv[1], "large") ||
                       !strcmp(argv[1], "wavelet");
    if (argc > 2 || !known) {
        if (!(argc == 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")))) {
            fprintf(stderr, "csi-bench-solve: unknown argument '%s' (quick, large, wavelet or none; see --help)\n",
                    argv[known ? 2 : 1]);
            return 2;
        }
        printf("usage: csi-bench-solve [quick|large|wavelet]\n"
               "  (none)   ROMP's and SpaRSA's recovery tables, multi-channel timings, wavelet-basis recovery\n"
               "  quick    the same with fewer seeds\n"
               "  large    SpaRSA's recovery with k = 65536 unknowns only\n"
               "  wavelet  recovery in a wavelet basis only\n");
        return 0;
    }
    bool quick = argc > 1 && strcmp(argv[1], "quick") == 0;
    TRY(csi_ctx_create(&ctx, NULL));
    printf("Device: %s\n", csi_ctx_device_name(ctx));
    int seeds = quick ? 5 : 20;
    if (argc > 1 && strcmp(argv[1], "large") == 0) {
        const double f2[] = {2.0};
        recovery_table(false, 65536, 200, f2, 1, 20);
        csi_ctx_release(ctx);
        return 0;
    }
    if (argc > 1 && strcmp(argv[1], "wavelet") == 0) {
        wavelet_table(64, 24, 20);
        wavelet_table(256, 100, 5);
        csi_ctx_release(ctx);
        return 0;
    }
    const double fr[] = {1.5, 2.0, 3.0, 4.0};
    recovery_table(true, 1024, 12, fr, 4, seeds);
    recovery_table(true, 4096, 20, fr + 1, 3, quick ? 3 : 10);
    const double fs[] = {0.5, 1.0, 1.5, 2.0, 3.0};
    recovery_table(false, 4096, 40, fs, 5, seeds);
    recovery_table(false, 65536, 200, fs + 3, 1, quick ? 2 : 5);

    printf("\nMulti-channel (3 right-hand sides, one operator; best of 3 runs)\n\n");
    printf("| solver | problem | separate solves, workspace made per channel (ms) | one workspace, csi_*_multi (ms) | "
           "ROMP selection share |\n|---|---|---|---|---|\n");
    rs = 5;
    {
        size_t dims[3] = {256, 256, 1};
        csi_linop *A = partial_fourier(dims, 2400);
        multichannel(false, A, 200, 3);
        csi_linop_free(A);
    }
    {
        size_t dims[3] = {4096, 1, 1};
        csi_linop *A = partial_fourier(dims, 400);
        multichannel(false, A, 40, 3);
        csi_linop_free(A);
    }
    {
        csi_linop *A = gaussian(426, 4096);
        multichannel(true, A, 20, 3);
        csi_linop_free(A);
    }
    wavelet_table(64, 24, seeds);
    wavelet_table(256, 100, quick ? 2 : 5);
    csi_ctx_release(ctx);
    return 0;
}
