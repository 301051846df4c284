/* csi-bench-motion: what Alg. 2 (compressive motion blur, 3-D Fourier basis + SpaRSA) costs and
 * what it gains, on procedural moving scenes rendered analytically here (the ground truth is
 * the exact volume, so no renderer is involved).
 *
 *   csi-bench-motion fft     [--size WxHxT] [--runs N]
 *       one 3-D complex transform of the orthonormal Fourier basis (apply = F^H and adjoint = F),
 *       csi's native kernels vs clFFT, median of N runs after a warm-up.
 *   csi-bench-motion solve   [--size WxHxT] [--fraction F | --spp S] [--scene NAME] [--seed S]
 *                            [--tau-rel X] [--max-iter N] [--tol X] [--no-cont] [--gauss SIGMA]
 *       one csi_recon of the scene with every frame (Alg. 2 and Sec. 6.1): setup, solve
 *       and integration times, SpaRSA iterations and seconds per iteration, the image PSNR and
 *       the mean per-frame PSNR against the exact volume, peak resident memory of the process
 *       (PoCL's CPU buffers are host memory, so this bounds the device memory used). With
 *       --gauss SIGMA (0: the default rule) the Gaussian NC baseline is measured as well.
 *   csi-bench-motion quality [--size WxHxT] [--scenes a,b] [--rates 0.1,spp1] [--sweep]
 *       compressive (the csi_recon defaults, or a sweep of SpaRSA settings with --sweep) against
 *       the oracle-tuned 3-D Gaussian normalized convolution (the sigma with the lowest error for
 *       each case and each figure, searched over a grid of widths), as Markdown table rows.
 *
 * PSNR: 10 log10(1 / MSE) (the scenes' values lie in [0, 1]); image = the mean of the volume
 * over t (out = grid size); frames = the mean over t of each frame's PSNR. */
#define _GNU_SOURCE
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "csi/sampling.h"
#include "csi/spectral.h"
#include "csi/vec.h"

#define PI_ 3.14159265358979323846

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

#define DIE(...)                                                                             \
    do {                                                                                     \
        fprintf(stderr, "csi-bench-motion: " __VA_ARGS__);                                   \
        fputc('\n', stderr);                                                                 \
        exit(1);                                                                             \
    } while (0)
#define OK(expr)                                                                             \
    do {                                                                                     \
        csi_status st_ = (expr);                                                             \
        if (st_ != CSI_OK)                                                                   \
            DIE("%s: %s", #expr, csi_last_error());                                          \
    } while (0)

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

/* Peak resident set of this process (VmHWM), MiB. */
static double peak_rss_mib(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    if (!f)
        return -1;
    char line[256];
    double kb = -1;
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6))
            kb = atof(line + 6);
    fclose(f);
    return kb / 1024.0;
}

/* ---- scenes ------------------------------------------------------------------------------ */

/* Smooth step of width e around 0 (the edges are point-sampled, as a renderer's would be, but
 * not wider than a cell: e is a fraction of a cell). */
static double inside(double d) { return d < 0 ? 1.0 : 0.0; }

/* Value of scene `s` at the centre of cell (x, y, t) of a w x h x T grid; in [0, 1]. */
static double scene_value(const char *s, size_t x, size_t y, size_t t, size_t w, size_t h, size_t T)
{
    double u = (x + 0.5) / (double)w, v = (y + 0.5) / (double)h, tt = (t + 0.5) / (double)T;
    if (!strcmp(s, "disc")) {
        /* A bright disc sliding over a smooth background (the shutter interval moves it by
         * half the frame width). */
        double bg = 0.35 + 0.12 * sin(2 * PI_ * (2 * u + v)) + 0.08 * cos(2 * PI_ * 3 * v);
        double cx = 0.25 + 0.5 * tt, cy = 0.5 - 0.1 * tt, r = 0.15;
        double d = hypot(u - cx, v - cy) - r;
        return d < 0 ? 0.9 : bg;
    }
    if (!strcmp(s, "pan")) {
        /* Camera pan over a textured plane (the TRAIN scene's situation): stripes, a checker of
         * large squares and a soft blob, all translating by 0.2 of the width. */
        double uu = u + 0.2 * tt, vv = v + 0.03 * tt;
        double stripes = 0.5 + 0.25 * sin(2 * PI_ * 6 * uu);
        int check = ((int)floor(uu * 4) + (int)floor(vv * 4)) & 1;
        double blob = exp(-((uu - 0.6) * (uu - 0.6) + (vv - 0.4) * (vv - 0.4)) / 0.02);
        double val = 0.3 * stripes + 0.35 * check + 0.3 * blob + 0.05;
        return val > 1 ? 1 : val;
    }
    if (!strcmp(s, "balls")) {
        /* Two balls moving in different directions over a static striped table with a square
         * pocket (BILLIARDS-like): static background, fast small movers. */
        double bg = 0.2 + 0.1 * (((int)floor(u * 8)) & 1) + 0.05 * sin(2 * PI_ * 2 * v);
        if (fabs(u - 0.85) < 0.08 && fabs(v - 0.15) < 0.08)
            bg = 0.02;
        double val = bg;
        double c1x = 0.2 + 0.45 * tt, c1y = 0.3 + 0.3 * tt;
        if (inside(hypot(u - c1x, v - c1y) - 0.09) > 0)
            val = 0.95 - 0.3 * ((((int)floor((u - c1x) * 40 + 0.5 * tt * 10)) & 1));
        double c2x = 0.75 - 0.3 * tt, c2y = 0.7;
        if (inside(hypot(u - c2x, v - c2y) - 0.07) > 0)
            val = 0.8;
        return val;
    }
    DIE("unknown scene '%s' (disc, pan, balls)", s);
}

static float *scene_volume(const char *s, size_t w, size_t h, size_t T)
{
    float *v = malloc(w * h * T * sizeof *v);
    if (!v)
        DIE("out of memory for the scene");
    for (size_t t = 0; t < T; t++)
        for (size_t y = 0; y < h; y++)
            for (size_t x = 0; x < w; x++)
                v[(t * h + y) * w + x] = (float)scene_value(s, x, y, t, w, h, T);
    return v;
}

/* ---- figures ----------------------------------------------------------------------------- */

typedef struct {
    double img_psnr, frame_psnr, img_mse;
} figures;

static double psnr(double mse) { return mse > 0 ? 10 * log10(1.0 / mse) : 200.0; }

static figures measure(const float *truth, size_t w, size_t h, size_t T, const float *image,
                       const float *frames)
{
    figures f = {0, 0, 0};
    size_t wh = w * h;
    double se = 0;
    for (size_t i = 0; i < wh; i++) {
        double m = 0;
        for (size_t t = 0; t < T; t++)
            m += truth[t * wh + i];
        m /= (double)T;
        double d = image[i] - m;
        se += d * d;
    }
    f.img_mse = se / (double)wh;
    f.img_psnr = psnr(f.img_mse);
    if (frames) {
        double sum = 0;
        for (size_t t = 0; t < T; t++) {
            double e = 0;
            for (size_t i = 0; i < wh; i++) {
                double d = frames[t * wh + i] - truth[t * wh + i];
                e += d * d;
            }
            sum += psnr(e / (double)wh);
        }
        f.frame_psnr = sum / (double)T;
    }
    return f;
}

/* ---- options ----------------------------------------------------------------------------- */

typedef struct {
    size_t w, h, T;
    double fraction;
    unsigned spp;
    const char *scene;
    unsigned long long seed;
    int runs;
    double tau_rel, tol;
    int max_iter;
    int full;
    double resid; /* -2: library default */
    int cont; /* -1 default, 0 off, 1 on */
    double gauss;
    const char *scenes, *rates;
    int sweep;
    int rgb; /* solve: three channels (value^(1 + 0.3 c)), one operator, the timing of an RGB image */
} bench_opts;

static void parse_size(const char *s, bench_opts *o)
{
    unsigned a, b, c;
    if (sscanf(s, "%ux%ux%u", &a, &b, &c) != 3 || !a || !b || !c)
        DIE("--size wants WxHxT, got '%s'", s);
    o->w = a;
    o->h = b;
    o->T = c;
}

/* Samples of the volume at random positions (uniform random cells, the paper's Alg. 2 step 2). */
static void sample(const float *vol, const csi_grid *g, double fraction, unsigned spp,
                   unsigned long long seed, csi_sample_pos **pos, float **val, size_t *n)
{
    csi_pos_opts po = {CSI_POS_RANDOM, spp, fraction, seed};
    OK(csi_positions(g, &po, pos, n, NULL));
    *val = malloc(*n * sizeof **val);
    for (size_t i = 0; i < *n; i++)
        (*val)[i] = vol[csi_grid_index(g, (*pos)[i])];
}

/* ---- fft --------------------------------------------------------------------------------- */

static void bench_fft(csi_ctx *ctx, const bench_opts *o)
{
    size_t dims[3] = {o->w, o->h, o->T}, n = o->w * o->h * o->T;
    cl_mem x, y;
    OK(csi_buffer(ctx, n * 8, CL_MEM_READ_WRITE, "bench input", &x));
    OK(csi_buffer(ctx, n * 8, CL_MEM_READ_WRITE, "bench output", &y));
    float *hbuf = malloc(n * 8);
    for (size_t i = 0; i < 2 * n; i++)
        hbuf[i] = (float)((i * 2654435761u) % 1000) * 1e-3f;
    OK(csi_write(ctx, x, 0, n * 8, hbuf));
    free(hbuf);
    printf("| transform %zu x %zu x %zu complex | native ms | clFFT ms | clFFT / native |\n|---|---|---|---|\n",
           o->w, o->h, o->T);
    double med[2][2];
    for (int be = 0; be < 2; be++) {
        csi_linop *F;
        double t0 = now();
        OK(csi_fourier_create_backend(ctx, dims, be == 0 ? CSI_FFT_NATIVE : CSI_FFT_CLFFT, &F));
        OK(csi_linop_apply(F, x, y)); /* warm-up */
        OK(csi_linop_adjoint(F, x, y));
        OK(csi_finish(ctx));
        fprintf(stderr, "%s: setup + warm-up %.2f s\n", be ? "clFFT" : "native", now() - t0);
        for (int dir = 0; dir < 2; dir++) {
            double *t = malloc((size_t)o->runs * sizeof *t);
            for (int r = 0; r < o->runs; r++) {
                double a = now();
                OK(dir ? csi_linop_adjoint(F, x, y) : csi_linop_apply(F, x, y));
                OK(csi_finish(ctx));
                t[r] = now() - a;
            }
            med[be][dir] = median(t, o->runs) * 1e3;
            free(t);
        }
        csi_linop_free(F);
    }
    for (int dir = 0; dir < 2; dir++)
        printf("| %s | %.1f | %.1f | %.2f |\n", dir ? "forward F (adjoint)" : "inverse F^H (apply)",
               med[0][dir], med[1][dir], med[1][dir] / med[0][dir]);
    /* the half-spectrum basis of a real volume (what Alg. 2 uses) */
    csi_fourier_half *hf;
    OK(csi_fourier_half_create(ctx, dims, &hf));
    cl_mem z;
    OK(csi_buffer(ctx, csi_fourier_half_count(hf) * 8, CL_MEM_READ_WRITE, "bench spectrum", &z));
    OK(csi_fourier_half_forward(hf, x, z)); /* x read as n real values */
    OK(csi_fourier_half_inverse(hf, z, y));
    OK(csi_finish(ctx));
    double hm[2];
    for (int dir = 0; dir < 2; dir++) {
        double *t = malloc((size_t)o->runs * sizeof *t);
        for (int r = 0; r < o->runs; r++) {
            double a = now();
            OK(dir ? csi_fourier_half_forward(hf, x, z) : csi_fourier_half_inverse(hf, z, y));
            OK(csi_finish(ctx));
            t[r] = now() - a;
        }
        hm[dir] = median(t, o->runs) * 1e3;
        free(t);
    }
    printf("\n| real volume, half spectrum | native ms | vs complex native |\n|---|---|---|\n");
    printf("| inverse (synthesis, apply) | %.1f | %.2f |\n", hm[0], hm[0] / med[0][0]);
    printf("| forward (R2C, adjoint) | %.1f | %.2f |\n", hm[1], hm[1] / med[0][1]);
    csi_buffer_release(&z);
    csi_fourier_half_free(hf);
    csi_buffer_release(&x);
    csi_buffer_release(&y);
}

/* ---- vec: the solver's per-iteration vector work at the volume's size ------------------- */

static void bench_vec(csi_ctx *ctx, const bench_opts *o)
{
    size_t k = o->w * o->h * o->T, nf = 2 * k;
    cl_mem a, b, c;
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "a", &a));
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "b", &b));
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "c", &c));
    OK(csi_vec_fill(ctx, a, nf, 0.5f));
    OK(csi_vec_fill(ctx, b, nf, 0.25f));
    OK(csi_vec_fill(ctx, c, nf, 0.0f));
    csi_vec_ws *ws;
    OK(csi_vec_ws_create(ctx, &ws));
    double r;
    const char *names[] = {"copy (csi_copy)", "fill_zero", "prox_sums", "asum (cplx)", "dist2", "amax (cplx)", "dot", "nrm2"};
    for (int op = 0; op < 8; op++) {
        double t[7];
        for (int rep = 0; rep < 4; rep++) {
            double t0 = now();
            switch (op) {
            case 0: OK(csi_copy(ctx, c, 0, a, 0, nf * 4)); break;
            case 1: OK(csi_fill_zero(ctx, c, nf * 4)); break;
            case 2: { double l1, dx2; OK(csi_vec_prox_sums(ws, k, true, a, b, -0.5f, 0.01f, c, &l1, &dx2)); } break;
            case 3: OK(csi_vec_asum(ws, k, true, a, &r)); break;
            case 4: OK(csi_vec_dist2(ws, nf, a, b, &r)); break;
            case 5: OK(csi_vec_amax(ws, k, true, a, &r, NULL)); break;
            case 6: OK(csi_vec_dot(ws, nf, a, b, &r)); break;
            case 7: OK(csi_vec_nrm2(ws, nf, a, &r)); break;
            }
            OK(csi_finish(ctx));
            t[rep] = now() - t0;
        }
        printf("| %s | %.1f ms |\n", names[op], 1e3 * median(t + 1, 3));
    }
    csi_vec_ws_free(ws);
    csi_buffer_release(&a);
    csi_buffer_release(&b);
    csi_buffer_release(&c);
}

/* ---- vecproto: the prototype that led kernels/vec.cl's reductions to contiguous chunks ---- *
 * Built from source here (not part of the library). It showed that reductions whose work-items
 * stride by the global size are slow on PoCL (a group's work-items run one after another, so a
 * cache line is fetched once per work-item touching it) and that contiguous chunks per work-item
 * run at copy speed; kernels/vec.cl now works that way (docs/bench/solve.md, "Contiguous chunks
 * per work-item"). Kept as the baseline the library's kernels are timed against. */
static const char *proto_src =
    "#pragma OPENCL FP_CONTRACT OFF\n"
    "__kernel void prox(__global const float *restrict x, __global const float *restrict g, const float c,\n"
    "                   const float t, __global float *restrict out) {\n"
    "  const size_t i = get_global_id(0);\n"
    "  const float re = x[2*i] + c * g[2*i], im = x[2*i+1] + c * g[2*i+1];\n"
    "  const float mag = sqrt(re * re + im * im), m = mag - t;\n"
    "  const float f = m > 0.0f ? m / mag : 0.0f;\n"
    "  out[2*i] = re * f; out[2*i+1] = im * f; }\n"
    "__kernel void asum(__global const float *restrict x, const ulong chunk, __global float *restrict part) {\n"
    "  const size_t j = get_global_id(0); const size_t b = j * chunk;\n"
    "  float s = 0.0f, c = 0.0f;\n"
    "  for (size_t i = b; i < b + chunk; i++) { const float re = x[2*i], im = x[2*i+1];\n"
    "    const float v = sqrt(re * re + im * im) - c; const float t = s + v; c = (t - s) - v; s = t; }\n"
    "  part[2*j] = s; part[2*j+1] = -c; }\n";

static void bench_vecproto(csi_ctx *ctx, const bench_opts *o)
{
    size_t k = o->w * o->h * o->T, nf = 2 * k;
    cl_int err;
    cl_context cc = csi_ctx_context(ctx);
    cl_device_id dev = csi_ctx_device(ctx);
    cl_program prog = clCreateProgramWithSource(cc, 1, &proto_src, NULL, &err);
    if (err || clBuildProgram(prog, 1, &dev, "", NULL, NULL))
        DIE("prototype kernels did not build");
    cl_kernel kp = clCreateKernel(prog, "prox", &err), ka = clCreateKernel(prog, "asum", &err);
    cl_mem a, b, c, part;
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "a", &a));
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "b", &b));
    OK(csi_buffer(ctx, nf * 4, CL_MEM_READ_WRITE, "c", &c));
    size_t G = 4096;
    OK(csi_buffer(ctx, 2 * G * 4, CL_MEM_READ_WRITE, "partials", &part));
    OK(csi_vec_fill(ctx, a, nf, 0.5f));
    OK(csi_vec_fill(ctx, b, nf, 0.25f));
    float cf = -0.5f, tf = 0.01f;
    cl_ulong chunk = k / G;
    OK(CSI_ARGS(kp, CSI_MEM(a), CSI_MEM(b), CSI_ARG(cf), CSI_ARG(tf), CSI_MEM(c)));
    OK(CSI_ARGS(ka, CSI_MEM(a), CSI_ARG(chunk), CSI_MEM(part)));
    for (int op = 0; op < 2; op++) {
        double t[4];
        for (int rep = 0; rep < 4; rep++) {
            double t0 = now();
            size_t gl = op == 0 ? k : G, lo = 64;
            OK(csi_run(ctx, op == 0 ? kp : ka, 1, &gl, &lo));
            if (op == 1) {
                float h[2 * 4096];
                OK(csi_read(ctx, part, 0, sizeof h, h));
            }
            OK(csi_finish(ctx));
            t[rep] = now() - t0;
        }
        printf("| prototype %s | %.1f ms |\n", op == 0 ? "prox_step" : "asum (cplx, contiguous chunks)",
               1e3 * median(t + 1, 3));
    }
    clReleaseKernel(kp);
    clReleaseKernel(ka);
    clReleaseProgram(prog);
    csi_buffer_release(&a);
    csi_buffer_release(&b);
    csi_buffer_release(&c);
    csi_buffer_release(&part);
}

static void gauss_oracle(csi_ctx *ctx, const csi_grid *g, const float *vol, const csi_sample_pos *pos,
                         const float *val, size_t n, figures *best, double *sig_img, double *sig_fr);

/* ---- solve ------------------------------------------------------------------------------- */

typedef struct {
    double t_first, t_last;
    int iters;
    int verbose;
} prog_state;

static bool on_progress(void *user, const char *phase, int iter, double res)
{
    prog_state *p = user;
    double t = now();
    if (!strncmp(phase, "solve", 5)) { /* "solve c/C": the solver's steps */
        if (p->iters == 0)
            p->t_first = t;
        p->t_last = t;
        p->iters = iter;
        if (p->verbose && (iter % 10 == 0 || iter < 5))
            fprintf(stderr, "  iter %4d  residual %.4g  %.1f s since the first\n", iter, res, t - p->t_first);
    } else if (p->verbose) {
        fprintf(stderr, "  phase %s\n", phase);
    }
    return true;
}

static void apply_solver_opts(csi_recon_options *ro, const bench_opts *o)
{
    if (o->tau_rel > 0)
        ro->tau_rel = o->tau_rel;
    if (o->tol > 0)
        ro->tol = o->tol;
    if (o->max_iter > 0)
        ro->max_iter = o->max_iter;
    if (o->full & 1)
        ro->motion_full_spectrum = true;
    if (o->full & 2)
        ro->motion_debias = true;
    if (o->resid > -2)
        ro->motion_resid_sigma = o->resid;
}

static void bench_solve(csi_ctx *ctx, const bench_opts *o)
{
    csi_grid g = {(uint32_t)o->w, (uint32_t)o->h, (uint32_t)o->T, (uint32_t)o->w, (uint32_t)o->h};
    double t0 = now();
    float *vol = scene_volume(o->scene, o->w, o->h, o->T);
    csi_sample_pos *pos;
    float *val;
    size_t n;
    sample(vol, &g, o->fraction, o->spp, o->seed, &pos, &val, &n);
    size_t k = o->w * o->h * o->T;
    fprintf(stderr, "scene %s %zux%zux%zu, %zu samples (%.3g%%), made in %.1f s\n", o->scene, o->w,
            o->h, o->T, n, 100.0 * n / k, now() - t0);
    csi_recon_options ro;
    csi_recon_defaults(&ro);
    apply_solver_opts(&ro, o);
    ro.frames = true;
    prog_state ps = {0, 0, 0, 1};
    ro.progress = on_progress;
    ro.user = &ps;
    csi_recon_result res;
    double a = now();
    if (o->rgb) {
        /* three different channels: the scene's value to the powers 1, 1.3, 1.6 */
        float *v3 = malloc(3 * n * sizeof *v3);
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                v3[3 * i + c] = powf(val[i], 1.0f + 0.3f * (float)c);
        OK(csi_recon(ctx, &g, 3, pos, v3, n, &ro, &res));
        free(v3);
    } else {
        OK(csi_recon(ctx, &g, 1, pos, val, n, &ro, &res));
    }
    double total = now() - a;
    if (o->rgb)
        printf("RGB: all three channels with every frame in %.1f s (setup %.1f, solve %.1f, integrate %.1f); "
               "peak RSS %.0f MiB\n", total, res.t_setup, res.t_solve, res.t_integrate, peak_rss_mib());
    if (o->rgb) {
        /* channel 0 (the scene itself): frames are frame-major, then planar */
        size_t wh = o->w * o->h;
        for (size_t t = 0; t < o->T; t++)
            memmove(res.frames + t * wh, res.frames + t * 3 * wh, wh * sizeof(float));
    }
    figures f = measure(vol, o->w, o->h, o->T, res.image, res.frames);
    const csi_solve_report *r = &res.report[0];
    double per_it = ps.iters > 1 ? (ps.t_last - ps.t_first) / (ps.iters - 1) : 0;
    printf("| %s | %zux%zux%zu | %.3g%% | %d | %d | %.3f | %.1f | %.1f | %.1f | %.1f | %.2f | %.2f | %.0f |\n",
           o->scene, o->w, o->h, o->T, 100.0 * n / k, r->iterations, r->stages, per_it, res.t_setup,
           res.t_solve, res.t_integrate, total, f.img_psnr, f.frame_psnr, peak_rss_mib());
    printf("solver: %s; applies %d adjoints %d; t_step %.1f s t_debias %.1f s\n", r->message,
           r->applies, r->adjoints, r->t_step, r->t_debias);
    csi_recon_result_free(&res);
    if (o->gauss == -3) {
        figures gb;
        double si = 0, sf = 0;
        a = now();
        gauss_oracle(ctx, &g, vol, pos, val, n, &gb, &si, &sf);
        printf("gauss NC, oracle sigma %.2f (image) / %.2f (frames): image PSNR %.2f, frame PSNR %.2f "
               "(%.1f s for the sweep)\n", si, sf, gb.img_psnr, gb.frame_psnr, now() - a);
    } else if (o->gauss >= 0) {
        csi_recon_options go;
        csi_recon_defaults(&go);
        go.estimator = CSI_EST_GAUSS;
        go.gauss_sigma = o->gauss;
        go.frames = true;
        a = now();
        OK(csi_recon(ctx, &g, 1, pos, val, n, &go, &res));
        f = measure(vol, o->w, o->h, o->T, res.image, res.frames);
        printf("gauss NC sigma %g: %.1f s, image PSNR %.2f, frame PSNR %.2f\n", o->gauss, now() - a,
               f.img_psnr, f.frame_psnr);
        csi_recon_result_free(&res);
    }
    free(vol);
    free(pos);
    free(val);
}

/* ---- quality ----------------------------------------------------------------------------- */

/* Oracle-tuned Gaussian NC: the best image PSNR and the best frame PSNR over a grid of widths
 * (each figure gets its own best width). */
static void gauss_oracle(csi_ctx *ctx, const csi_grid *g, const float *vol, const csi_sample_pos *pos,
                         const float *val, size_t n, figures *best, double *sig_img, double *sig_fr)
{
    best->img_psnr = best->frame_psnr = -1;
    for (double s = 0.5; s <= 6.01; s *= 1.15) {
        csi_recon_options go;
        csi_recon_defaults(&go);
        go.estimator = CSI_EST_GAUSS;
        go.gauss_sigma = s;
        go.frames = true;
        csi_recon_result res;
        OK(csi_recon(ctx, g, 1, pos, val, n, &go, &res));
        figures f = measure(vol, g->w, g->h, g->t, res.image, res.frames);
        if (f.img_psnr > best->img_psnr) {
            best->img_psnr = f.img_psnr;
            *sig_img = s;
        }
        if (f.frame_psnr > best->frame_psnr) {
            best->frame_psnr = f.frame_psnr;
            *sig_fr = s;
        }
        csi_recon_result_free(&res);
    }
}

typedef struct {
    const char *label;
    double tau_rel, tol;
    int max_iter;
    int full;     /* motion_full_spectrum */
    double resid; /* motion_resid_sigma; -2 = the library's default */
} setting;

static void bench_quality(csi_ctx *ctx, const bench_opts *o)
{
    csi_grid g = {(uint32_t)o->w, (uint32_t)o->h, (uint32_t)o->T, (uint32_t)o->w, (uint32_t)o->h};
    char scenes[256], rates[256];
    snprintf(scenes, sizeof scenes, "%s", o->scenes);
    snprintf(rates, sizeof rates, "%s", o->rates);
    static const setting defaults_only[] = {
        {"defaults", 0, 0, 0, 0, -2},
        {"paper's (full spectrum, tau_rel 1e-4, debiased, no correction)", 1e-4, 0, 0, 3, -1},
    };
    static const setting sweep[] = {
        {"tau 3e-3 full spectrum (the paper's, tuned tau)", 3e-3, 0, 0, 1, -1},
        {"tau 3e-3 + resid NC", 3e-3, 0, 0, 0, 0},
        {"tau 1e-3 + resid NC", 1e-3, 0, 0, 0, 0},
        {"tau 1e-3 + resid NC, <= 50 steps", 1e-3, 0, 50, 0, 0},
        {"tau 3e-4 + resid NC", 3e-4, 0, 0, 0, 0},
        {"tau 1e-4 + resid NC (solver default tau)", 1e-4, 0, 0, 0, 0},
    };
    const setting *set = o->sweep ? sweep : defaults_only;
    size_t nset = o->sweep ? sizeof sweep / sizeof *sweep : sizeof defaults_only / sizeof *defaults_only;
    printf("| scene | rate | N | method | image PSNR | frame PSNR | iters | solve s |\n|---|---|---|---|---|---|---|---|\n");
    for (char *sc = strtok(scenes, ","); sc; sc = strtok(NULL, ",")) {
        float *vol = scene_volume(sc, o->w, o->h, o->T);
        char *save = NULL;
        char rbuf[256];
        snprintf(rbuf, sizeof rbuf, "%s", rates);
        for (char *rt = strtok_r(rbuf, ",", &save); rt; rt = strtok_r(NULL, ",", &save)) {
            double fraction = 0;
            unsigned spp = 0;
            if (!strncmp(rt, "spp", 3))
                spp = (unsigned)atoi(rt + 3);
            else
                fraction = atof(rt);
            csi_sample_pos *pos;
            float *val;
            size_t n;
            sample(vol, &g, fraction, spp, o->seed, &pos, &val, &n);
            figures gb;
            double si = 0, sf = 0;
            gauss_oracle(ctx, &g, vol, pos, val, n, &gb, &si, &sf);
            printf("| %s | %s | %zu | Gaussian NC (oracle sigma %.2f / %.2f) | %.2f | %.2f | | |\n", sc, rt,
                   n, si, sf, gb.img_psnr, gb.frame_psnr);
            fflush(stdout);
            for (size_t s = 0; s < nset; s++) {
                csi_recon_options ro;
                csi_recon_defaults(&ro);
                bench_opts so = *o;
                if (set[s].tau_rel > 0)
                    so.tau_rel = set[s].tau_rel;
                if (set[s].tol > 0)
                    so.tol = set[s].tol;
                if (set[s].max_iter > 0)
                    so.max_iter = set[s].max_iter;
                so.full = set[s].full;
                if (set[s].resid > -2)
                    so.resid = set[s].resid;
                if (set[s].resid < -0.5 && set[s].resid > -2 && set[s].resid != -1) /* -m: m x default */
                    so.resid = -set[s].resid * csi_gauss_nc_default_sigma(g.w * (size_t)g.h * g.t, n, 3);
                apply_solver_opts(&ro, &so);
                ro.frames = true;
                csi_recon_result res;
                OK(csi_recon(ctx, &g, 1, pos, val, n, &ro, &res));
                figures f = measure(vol, o->w, o->h, o->T, res.image, res.frames);
                printf("| %s | %s | %zu | CS %s | %.2f | %.2f | %d | %.2f |\n", sc, rt, n, set[s].label,
                       f.img_psnr, f.frame_psnr, res.report[0].iterations, res.t_solve);
                fflush(stdout);
                csi_recon_result_free(&res);
            }
            free(pos);
            free(val);
        }
        free(vol);
    }
}

static const char *need_value(const char *a)
{
    DIE("%s needs a value", a);
}

int main(int argc, char **argv)
{
    if (argc < 2 || !strcmp(argv[1], "--help"))
        DIE("usage: csi-bench-motion fft|solve|quality [options] (see tools/bench/bench_motion.c)");
    const char *mode = argv[1];
    bench_opts o = {512, 512, 128, 0.01, 0, "disc", 1, 5, 0, 0, 0, 0, -2, -1, -1, "disc,pan,balls", "0.1,spp1", 0, 0};
    if (!strcmp(mode, "quality"))
        parse_size("64x64x32", &o);
    for (int i = 2; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEXT() (v ? (i++, v) : need_value(a))
        if (!strcmp(a, "--size"))
            parse_size(NEXT(), &o);
        else if (!strcmp(a, "--fraction"))
            o.fraction = atof(NEXT());
        else if (!strcmp(a, "--spp")) {
            o.spp = (unsigned)atoi(NEXT());
            o.fraction = 0;
        } else if (!strcmp(a, "--scene"))
            o.scene = NEXT();
        else if (!strcmp(a, "--scenes"))
            o.scenes = NEXT();
        else if (!strcmp(a, "--rates"))
            o.rates = NEXT();
        else if (!strcmp(a, "--seed"))
            o.seed = strtoull(NEXT(), NULL, 10);
        else if (!strcmp(a, "--runs"))
            o.runs = atoi(NEXT());
        else if (!strcmp(a, "--tau-rel"))
            o.tau_rel = atof(NEXT());
        else if (!strcmp(a, "--tol"))
            o.tol = atof(NEXT());
        else if (!strcmp(a, "--max-iter"))
            o.max_iter = atoi(NEXT());
        else if (!strcmp(a, "--full"))
            o.full = 1;
        else if (!strcmp(a, "--resid"))
            o.resid = atof(NEXT());
        else if (!strcmp(a, "--gauss"))
            o.gauss = atof(NEXT());
        else if (!strcmp(a, "--gauss-oracle"))
            o.gauss = -3;
        else if (!strcmp(a, "--rgb"))
            o.rgb = 1;
        else if (!strcmp(a, "--sweep"))
            o.sweep = 1;
        else
            DIE("unknown option '%s'", a);
#undef NEXT
    }
    csi_ctx *ctx;
    OK(csi_ctx_create(&ctx, NULL));
    fprintf(stderr, "device: %s\n", csi_ctx_device_name(ctx));
    if (!strcmp(mode, "fft"))
        bench_fft(ctx, &o);
    else if (!strcmp(mode, "vec")) {
        printf("| vector op, %zu x %zu x %zu complex | median of 3 |\n|---|---|\n", o.w, o.h, o.T);
        bench_vec(ctx, &o);
        bench_vecproto(ctx, &o);
    }
    else if (!strcmp(mode, "solve")) {
        printf("| scene | size | rate | iterations | stages | s / iteration | setup s | solve s | integrate s | total s | image PSNR | frame PSNR | peak RSS MiB |\n");
        printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        bench_solve(ctx, &o);
    } else if (!strcmp(mode, "quality"))
        bench_quality(ctx, &o);
    else
        DIE("unknown mode '%s' (fft, solve, quality)", mode);
    csi_ctx_release(ctx);
    return 0;
}
