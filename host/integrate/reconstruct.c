/* Alg. 1 and Alg. 2 of Sen & Darabi 2010 on the device: build the operator once, solve each
 * channel, integrate. See csi/reconstruct.h. */
#include "csi/reconstruct.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <time.h>

#include "csi/integrate_ops.h"
#include "csi/linop.h"
#include "csi/sampling.h"
#include "csi/spectral.h"
#include "csi/vec.h"

const char *csi_solver_kind_name(csi_solver_kind k)
{
    switch (k) {
    case CSI_SOLVER_ROMP: return "romp";
    case CSI_SOLVER_SPARSA: return "sparsa";
    default: return "default";
    }
}

csi_status csi_solver_kind_parse(const char *s, csi_solver_kind *out)
{
    if (s && !strcasecmp(s, "romp"))
        *out = CSI_SOLVER_ROMP;
    else if (s && !strcasecmp(s, "sparsa"))
        *out = CSI_SOLVER_SPARSA;
    else
        return csi_fail(CSI_ERR_ARG, "unknown solver '%s' (expected romp or sparsa)", s ? s : "");
    return CSI_OK;
}

const char *csi_aa_output_name(csi_aa_output o)
{
    return o == CSI_AA_SHARP ? "sharp" : "filtered";
}

csi_status csi_aa_output_parse(const char *s, csi_aa_output *out)
{
    if (s && !strcasecmp(s, "filtered"))
        *out = CSI_AA_FILTERED;
    else if (s && !strcasecmp(s, "sharp"))
        *out = CSI_AA_SHARP;
    else
        return csi_fail(CSI_ERR_ARG, "unknown integration target '%s' (expected filtered or sharp)",
                        s ? s : "");
    return CSI_OK;
}

const char *csi_aa_correct_name(csi_aa_correct c)
{
    return c == CSI_CORRECT_CV ? "cv" : c == CSI_CORRECT_NONE ? "none" : "auto";
}

csi_status csi_aa_correct_parse(const char *s, csi_aa_correct *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_CORRECT_AUTO;
    else if (s && !strcasecmp(s, "none"))
        *out = CSI_CORRECT_NONE;
    else if (s && !strcasecmp(s, "cv"))
        *out = CSI_CORRECT_CV;
    else
        return csi_fail(CSI_ERR_ARG, "unknown correction '%s' (expected none, cv or auto)", s ? s : "");
    return CSI_OK;
}

const char *csi_switch_name(csi_switch s)
{
    return s == CSI_SWITCH_ON ? "on" : s == CSI_SWITCH_OFF ? "off" : "auto";
}

csi_status csi_switch_parse(const char *s, csi_switch *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_SWITCH_AUTO;
    else if (s && !strcasecmp(s, "on"))
        *out = CSI_SWITCH_ON;
    else if (s && !strcasecmp(s, "off"))
        *out = CSI_SWITCH_OFF;
    else
        return csi_fail(CSI_ERR_ARG, "'%s' is not on, off or auto", s ? s : "");
    return CSI_OK;
}

const char *csi_recon_stop_name(csi_recon_stop s)
{
    return s == CSI_STOP_GAP ? "gap" : s == CSI_STOP_OBJECTIVE ? "objective" : "auto";
}

csi_status csi_recon_stop_parse(const char *s, csi_recon_stop *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_STOP_AUTO;
    else if (s && !strcasecmp(s, "gap"))
        *out = CSI_STOP_GAP;
    else if (s && !strcasecmp(s, "objective"))
        *out = CSI_STOP_OBJECTIVE;
    else
        return csi_fail(CSI_ERR_ARG, "unknown stopping rule '%s' (expected gap, objective or auto)",
                        s ? s : "");
    return CSI_OK;
}

const char *csi_estimator_name(csi_estimator e)
{
    switch (e) {
    case CSI_EST_MEAN: return "mean";
    case CSI_EST_GAUSS: return "gauss";
    default: return "cs";
    }
}

csi_status csi_estimator_parse(const char *s, csi_estimator *out)
{
    if (s && !strcasecmp(s, "cs"))
        *out = CSI_EST_CS;
    else if (s && !strcasecmp(s, "mean"))
        *out = CSI_EST_MEAN;
    else if (s && !strcasecmp(s, "gauss"))
        *out = CSI_EST_GAUSS;
    else
        return csi_fail(CSI_ERR_ARG, "unknown estimator '%s' (expected cs, mean or gauss)", s ? s : "");
    return CSI_OK;
}

double csi_gauss_nc_default_sigma(size_t k, size_t n, int dims)
{
    if (n == 0 || k == 0 || dims < 1)
        return 1.0;
    return 0.5 * pow((double)k / (double)n, 1.0 / dims);
}

double csi_motion_tau_rel(size_t n)
{
    if (n == 0)
        return CSI_MOTION_TAU_MAX;
    double t = CSI_MOTION_TAU_C / sqrt((double)n);
    return t < CSI_MOTION_TAU_MIN ? CSI_MOTION_TAU_MIN : t > CSI_MOTION_TAU_MAX ? CSI_MOTION_TAU_MAX : t;
}

void csi_recon_defaults(csi_recon_options *o)
{
    memset(o, 0, sizeof *o);
    o->solver = CSI_SOLVER_DEFAULT;
    o->wavelet = CSI_WAVELET_DB4;
    o->lambda = 0.3f;
    o->seed = 1;
    o->sigma_scale = 1.0;
    o->output = CSI_AA_SHARP;
    o->correct = CSI_CORRECT_AUTO;
    o->cv_n0 = -1.0;
    o->sigma_spacing = -1.0;
    o->motion_resid_sigma = 0.0; /* on, width from the sampling density */
}

void csi_recon_result_free(csi_recon_result *r)
{
    if (!r)
        return;
    free(r->image);
    free(r->frames);
    r->image = r->frames = NULL;
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Everything one reconstruction allocates, released in one place. */
typedef struct {
    csi_linop *S, *inner, *A, *Psi, *W;
    csi_solver *solver;
    cl_mem y, x, f, tmp, out;
    uint32_t *idx;
    float *plane;
    cl_mem romp_norms;   /* ROMP column norms, made once for all channels (or NULL) */
    uint32_t *romp_seed; /* ROMP seed support (or NULL) */
    size_t romp_seed_n;
} recon_state;

static void state_free(recon_state *st)
{
    csi_solver_free(st->solver);
    csi_linop_free(st->A); /* owns S and inner, which own the rest (see below) */
    if (!st->A) {
        csi_linop_free(st->S);
        csi_linop_free(st->inner);
    }
    csi_buffer_release(&st->y);
    csi_buffer_release(&st->x);
    csi_buffer_release(&st->f);
    csi_buffer_release(&st->tmp);
    csi_buffer_release(&st->out);
    free(st->idx);
    free(st->plane);
    csi_buffer_release(&st->romp_norms);
    free(st->romp_seed);
}

static csi_status check_inputs(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                               const float *values, size_t n)
{
    if (channels < 1 || channels > 4)
        return csi_fail(CSI_ERR_ARG, "%u channels (expected 1 to 4)", channels);
    if (!g->w || !g->h || !g->t || !g->out_w || !g->out_h)
        return csi_fail(CSI_ERR_ARG, "grid %ux%ux%u -> %ux%u has a zero size", g->w, g->h, g->t,
                        g->out_w, g->out_h);
    if (g->w % g->out_w || g->h % g->out_h)
        return csi_fail(CSI_ERR_ARG, "grid %ux%u is not a multiple of the output %ux%u", g->w, g->h,
                        g->out_w, g->out_h);
    if (n == 0)
        return csi_fail(CSI_ERR_ARG, "no samples to reconstruct from");
    uint64_t k = (uint64_t)g->w * g->h * g->t;
    if (k > UINT32_MAX)
        return csi_fail(CSI_ERR_ARG, "grid %ux%ux%u has %llu cells, over 2^32", g->w, g->h, g->t,
                        (unsigned long long)k);
    if (n > k)
        return csi_fail(CSI_ERR_ARG, "%zu samples for %llu grid cells", n, (unsigned long long)k);
    for (size_t i = 0; i < n; i++) {
        if (pos[i].x >= g->w || pos[i].y >= g->h || pos[i].t >= g->t)
            return csi_fail(CSI_ERR_ARG, "sample %zu at (%u, %u, %u) is outside the %ux%ux%u grid", i,
                            pos[i].x, pos[i].y, pos[i].t, g->w, g->h, g->t);
        for (uint32_t c = 0; c < channels; c++)
            if (!isfinite(values[i * channels + c]))
                return csi_fail(CSI_ERR_ARG, "sample %zu channel %u is %s", i, c,
                                isnan(values[i * channels + c]) ? "NaN" : "infinite");
    }
    return CSI_OK;
}

/* SpaRSA settings for Alg. 1 (the image problem) where the caller left them to the method.
 * Measured in docs/bench/quality.md. */
static void image_sparsa_defaults(csi_sparsa_options *o, double spp)
{
    /* The image stops changing long before the duality gap closes (with continuation the
     * default gap rule ran 2000 steps in an intermediate stage): stop on the relative change of
     * the objective instead. 3e-3 stops after 15-55 steps with the MSE within a few % of 300. */
    o->stop = CSI_SPARSA_STOP_OBJECTIVE;
    o->tol = 3e-3;
    o->max_iter = 300;
    /* The final least squares on the support refits the samples exactly and cost up to 2x in
     * MSE (e.g. 9.6e-4 against 4.6e-4, triangle 4 spp); without it never worse. */
    o->debias = false;
    /* The best tau falls with the samples per pixel, about 3e-3 / spp of ||A^H y||_inf
     * (measured 1 to 16 spp, 4x4 and 8x8 cells per pixel): few samples want a smoother fit. */
    o->tau_rel = fmin(3e-3, fmax(1e-5, 3e-3 / spp));
}

/* ROMP settings for Alg. 1 where the caller left them to the method (docs/bench/romp.md). */
typedef struct {
    size_t s;           /* candidates per step, 0: csi_romp_default_s */
    double max_support; /* >= 1 a count, (0, 1) a fraction of N, 0: 2s */
    bool normalize;     /* column-normalised selection */
    int seed_levels;    /* see csi_recon_options.romp_seed_levels; <= 0: none */
    int lsq_iter;       /* 0: the solver's default */
} image_romp;

/* Probes of csi_column_norms for ROMP's column normalisation: relative deviation sqrt(2/64) =
 * 18% per column, enough to rank correlations (csi/solve.h). */
#define CSI_ROMP_NORM_PROBES 64

static void image_romp_defaults(image_romp *o, size_t N, bool published)
{
    /* The published ROMP (Needell & Vershynin): s from N, stop at 2s, raw correlations. */
    o->s = 0;
    o->max_support = 0;
    o->normalize = false;
    o->seed_levels = 0;
    o->lsq_iter = 0;
    if (published)
        return;
    /* csi's image settings (docs/bench/romp.md): fewer candidates per step, a support limit
     * as a fraction of N (early stopping is ROMP's only regulariser: the least squares
     * interpolate the samples), the coarse block and the coarsest detail level seeded, short
     * least squares. */
    o->s = N / 64 > 16 ? N / 64 : 16;
    o->max_support = 0.15;
    o->seed_levels = 2;
    /* One warm-started CG step per support growth instead of ROMP's least squares (60 steps):
     * the exact fits interpolate the samples on the support, which is what makes ROMP's images
     * spiky; fewer steps measured monotonically better (60 -> 10 -> 3 -> 1: triangle 4 spp
     * 4.5e-4, 4.2e-4, 3.7e-4, 3.4e-4) and 3-10x faster. With one step the update is a steepest-
     * descent step on the support (closer to gradient pursuit than to Needell & Vershynin's
     * projection); --romp-lsq-iter restores the exact least squares. */
    o->lsq_iter = 1;
}

/* image_spp > 0: Alg. 1 with that many samples per output pixel (SpaRSA gets the image
 * defaults where the caller left a setting open); 0: Alg. 2. */
static csi_status run_solver(recon_state *st, csi_solver_kind kind, const csi_recon_options *opt,
                             double image_spp, size_t motion_n, csi_solve_report *rep)
{
    if (kind == CSI_SOLVER_ROMP) {
        csi_romp_options o;
        csi_romp_defaults(&o);
        image_romp o_img;
        image_romp_defaults(&o_img, st->A->rows, opt->romp_published);
        if (opt->romp_s > 0)
            o_img.s = opt->romp_s;
        if (opt->romp_max_support > 0)
            o_img.max_support = opt->romp_max_support;
        if (opt->romp_normalize != CSI_SWITCH_AUTO)
            o_img.normalize = opt->romp_normalize == CSI_SWITCH_ON;
        if (opt->romp_seed_levels != 0)
            o_img.seed_levels = opt->romp_seed_levels;
        if (opt->romp_lsq_iter > 0)
            o_img.lsq_iter = opt->romp_lsq_iter;
        const size_t N = st->A->rows, k = st->A->cols;
        o.s = o_img.s;
        if (o_img.max_support >= 1)
            o.max_support = (size_t)o_img.max_support;
        else if (o_img.max_support > 0)
            o.max_support = (size_t)fmax(1.0, floor(o_img.max_support * (double)N));
        if (o_img.lsq_iter > 0)
            o.lsq_iter = o_img.lsq_iter;
        if (opt->tol > 0)
            o.tol = opt->tol;
        if (opt->max_iter > 0)
            o.max_iter = opt->max_iter;
        if (o_img.normalize && !st->romp_norms) {
            CSI_TRY(csi_buffer(st->A->ctx, k * sizeof(float), CL_MEM_READ_WRITE,
                               "the ROMP column norms", &st->romp_norms));
            CSI_TRY(csi_column_norms(st->A, CSI_ROMP_NORM_PROBES, opt->seed, st->romp_norms));
        }
        o.col_norms = o_img.normalize ? st->romp_norms : NULL;
        if (o_img.seed_levels > 0 && !st->romp_seed) {
            /* The top-left block of the coefficient array (csi/wavelet.h's layout): the coarse
             * scaling block, widened by one detail level per extra seed level. */
            const int levels = csi_wavelet_levels(st->Psi);
            size_t cw, ch;
            csi_wavelet_coarse_block(st->Psi, &cw, &ch);
            const int extra = o_img.seed_levels - 1 < levels ? o_img.seed_levels - 1 : levels;
            cw <<= extra;
            ch <<= extra;
            const size_t w = cw << (levels - extra);
            st->romp_seed = malloc(cw * ch * sizeof *st->romp_seed);
            if (!st->romp_seed)
                return csi_fail(CSI_ERR_NOMEM, "out of host memory for the ROMP seed support");
            for (size_t yy = 0; yy < ch; yy++)
                for (size_t xx = 0; xx < cw; xx++)
                    st->romp_seed[st->romp_seed_n++] = (uint32_t)(yy * w + xx);
        }
        if (o_img.seed_levels > 0) {
            o.seed_support = st->romp_seed;
            o.seed_count = st->romp_seed_n;
        }
        o.progress = opt->progress;
        o.user = opt->user;
        CSI_TRY(csi_romp_run(st->solver, st->y, st->x, &o, rep));
        if (o.max_support > 0 && rep->reason == CSI_SOLVE_SUPPORT_LIMIT) {
            /* A support limit set for images (csi's, or the caller's) is the stopping rule, as
             * SpaRSA's objective change is: the samples are not meant to be fit exactly. */
            rep->reason = CSI_SOLVE_CONVERGED;
            rep->converged = true;
            snprintf(rep->message, sizeof rep->message, "ROMP reached its support limit %zu "
                     "(the early stop for images): %zu selected + %zu seeded after %d "
                     "iterations, residual %.3g", o.max_support, rep->support - o.seed_count, o.seed_count,
                     rep->iterations, rep->rel_residual);
        }
        return CSI_OK;
    }
    const bool motion = image_spp <= 0;
    csi_sparsa_options o;
    csi_sparsa_defaults(&o);
    if (image_spp > 0)
        image_sparsa_defaults(&o, image_spp);
    if (opt->stop != CSI_STOP_AUTO)
        o.stop = opt->stop == CSI_STOP_GAP ? CSI_SPARSA_STOP_GAP : CSI_SPARSA_STOP_OBJECTIVE;
    if (opt->continuation != CSI_SWITCH_AUTO)
        o.continuation = opt->continuation == CSI_SWITCH_ON;
    if (opt->debias != CSI_SWITCH_AUTO)
        o.debias = opt->debias == CSI_SWITCH_ON;
    if (opt->tol > 0)
        o.tol = opt->tol;
    if (opt->max_iter > 0)
        o.max_iter = opt->max_iter;
    if (opt->tau_rel > 0)
        o.tau_rel = opt->tau_rel;
    else if (motion)
        o.tau_rel = csi_motion_tau_rel(motion_n);
    if (motion) {
        /* Alg. 2: SpaRSA's debiasing (least squares on the support) only when asked for: the
         * video's spectrum is compressible, not sparse, and refitting its support to the samples
         * overfits them (docs/bench/motion.md). Also keeps the half- and full-spectrum solves
         * alike: the solver's support count differs between them (conjugate pairs count once
         * on the half spectrum), and with it whether it debiases. */
        o.debias = opt->motion_debias;
    }
    o.progress = opt->progress;
    o.user = opt->user;
    return csi_sparsa_run(st->solver, st->y, st->x, &o, rep);
}

static void report_progress(const csi_recon_options *opt, const char *phase)
{
    if (opt->progress)
        opt->progress(opt->user, phase, 0, -1.0);
}

static csi_status finish_nan_check(const float *a, size_t n, const char *what)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(a[i]))
            return csi_fail(CSI_ERR_NUMERIC, "the reconstructed %s has a non-finite value at %zu", what, i);
    return CSI_OK;
}

static csi_status integrate_volume(csi_ctx *ctx, const csi_grid *g, cl_mem vol, uint32_t c,
                                   const csi_recon_options *opt, csi_recon_result *res,
                                   cl_mem scratch_wh, cl_mem out);

/* sigma_spacing when the caller leaves it (< 0). Measured: docs/bench/quality.md. */
#define CSI_SIGMA_SPACING_DEFAULT 0.8

/* The CV shrinkage when the caller leaves it (cv_n0 < 0). Measured: docs/bench/quality.md. */
#define CSI_CV_N0_DEFAULT 8.0

/* The control-variate correction of one channel (see csi_aa_correct in the header): gathers
 * the fine estimate `fine` at the samples through S (into `gathered`, n floats on the device),
 * then adds beta_p * (mean residual of pixel p) to plane[p] on the host, in double, in sample
 * order (deterministic). values: sample-major, `channels` per sample; this is channel c. */
static csi_status cv_correct(csi_ctx *ctx, const csi_grid *g, const csi_recon_options *opt,
                             const csi_linop *S, cl_mem fine, cl_mem gathered, const float *values,
                             uint32_t channels, uint32_t c, const csi_sample_pos *pos, size_t n,
                             float *plane)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const double n0 = opt->cv_n0 >= 0 ? opt->cv_n0 : CSI_CV_N0_DEFAULT;
    float *gs = malloc(n * sizeof *gs);
    double *sum = calloc(np, sizeof *sum);
    uint32_t *cnt = calloc(np, sizeof *cnt);
    csi_status s = CSI_OK;
    if (!gs || !sum || !cnt)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel correction");
    if (s == CSI_OK)
        s = csi_linop_apply(S, fine, gathered);
    if (s == CSI_OK)
        s = csi_read(ctx, gathered, 0, n * sizeof(float), gs);
    if (s == CSI_OK) {
        for (size_t i = 0; i < n; i++) {
            size_t p = (size_t)(pos[i].y / bh) * g->out_w + pos[i].x / bw;
            sum[p] += (double)values[i * channels + c] - (double)gs[i];
            cnt[p]++;
        }
        for (size_t p = 0; p < np; p++)
            if (cnt[p])
                plane[p] = (float)((double)plane[p] + sum[p] / ((double)cnt[p] + n0));
    }
    free(gs);
    free(sum);
    free(cnt);
    return s;
}

/* Alg. 1. */
static csi_status antialias(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt, csi_recon_result *res, recon_state *st)
{
    const size_t w = g->w, h = g->h, k = w * h;
    const size_t dims[3] = {w, h, 1};
    double sphi[3] = {0, 0, 0};
    csi_gauss_sigmas(w, g->out_w, &sphi[0], NULL);
    csi_gauss_sigmas(h, g->out_h, &sphi[1], NULL);
    sphi[0] *= opt->sigma_scale;
    sphi[1] *= opt->sigma_scale;
    /* The filter follows the sampling rate: below a few samples per pixel the paper's width
     * (set by the output size alone) is narrower than the gaps between samples, and the
     * reconstruction rings between them (docs/bench/quality.md). */
    const double spacing = (opt->sigma_spacing >= 0 ? opt->sigma_spacing : CSI_SIGMA_SPACING_DEFAULT) *
                           sqrt((double)k / (double)n);
    sphi[0] = fmax(sphi[0], spacing);
    sphi[1] = fmax(sphi[1], spacing);
    /* Default: as many levels as the grid allows, at most 5. The tau rule (image_sparsa_defaults)
     * is relative to ||A^H y||_inf, which the coarse band dominates and which doubles with each
     * extra level; with 7 levels at 1024^2 the rule's tau was 2x off (MSE 8.5e-4 against 4.6e-4
     * with 5 levels, texture 1 spp), while 5 against 6 levels at 512^2 differ by < 5%. */
    int levels = opt->levels;
    if (levels <= 0) {
        levels = csi_wavelet_default_levels(opt->wavelet, w, h);
        if (levels > 5)
            levels = 5;
    }
    if (levels < 1)
        return csi_fail(CSI_ERR_ARG, "grid %zux%zu is too small or odd for a %s wavelet level", w, h,
                        csi_wavelet_name(opt->wavelet));

    /* A = S . (Phi^-1 . Psi); the compositions own their parts. */
    csi_linop *Psi = NULL, *W = NULL, *WPsi = NULL;
    CSI_TRY(csi_wavelet_create(ctx, opt->wavelet, w, h, levels, &Psi));
    csi_status s = csi_filter_create(ctx, dims, sphi, CSI_FILTER_WIENER, opt->lambda, &W);
    if (s == CSI_OK)
        s = csi_linop_compose("Phi^-1 Psi", W, Psi, true, &WPsi);
    if (s != CSI_OK) {
        csi_linop_free(W);
        csi_linop_free(Psi);
        return s;
    }
    st->inner = WPsi;
    st->Psi = Psi; /* borrowed from WPsi */
    st->W = W;     /* borrowed from WPsi */
    CSI_TRY(csi_sampling_create(ctx, k, st->idx, n, false, &st->S));
    CSI_TRY(csi_linop_compose("S Phi^-1 Psi", st->S, st->inner, true, &st->A));
    CSI_TRY(csi_solver_create(st->A, &st->solver));

    CSI_TRY(csi_buffer(ctx, n * sizeof(float), CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, k * sizeof(float), CL_MEM_READ_WRITE, "the wavelet coefficients", &st->x));
    CSI_TRY(csi_buffer(ctx, k * sizeof(float), CL_MEM_READ_WRITE, "the fine image", &st->f));
    CSI_TRY(csi_buffer(ctx, k * sizeof(float), CL_MEM_READ_WRITE, "the sharpened image", &st->tmp));
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, np * sizeof(float), CL_MEM_READ_WRITE, "the output image", &st->out));
    res->t_setup = now_s();

    double t_solve = 0, t_int = 0;
    for (uint32_t c = 0; c < channels; c++) {
        for (size_t i = 0; i < n; i++)
            st->plane[i] = values[i * channels + c];
        CSI_TRY(csi_write(ctx, st->y, 0, n * sizeof(float), st->plane));
        CSI_TRY(csi_fill_zero(ctx, st->x, k * sizeof(float)));
        double t0 = now_s();
        CSI_TRY(run_solver(st, res->solver, opt, (double)n / (double)np, 0, &res->report[c]));
        CSI_TRY(csi_finish(ctx));
        double t1 = now_s();
        t_solve += t1 - t0;
        report_progress(opt, "integrate");
        CSI_TRY(csi_linop_apply(st->Psi, st->x, st->f)); /* f_b = Psi x */
        cl_mem src = st->f;
        if (opt->output == CSI_AA_SHARP) {
            CSI_TRY(csi_linop_apply(st->W, st->f, st->tmp)); /* Phi^-1 f_b */
            src = st->tmp;
        }
        CSI_TRY(csi_box_integrate(ctx, src, g->w, g->h, 1, g->out_w, g->out_h, st->out));
        CSI_TRY(csi_read(ctx, st->out, 0, np * sizeof(float), res->image + (size_t)c * np));
        if (opt->correct != CSI_CORRECT_NONE)
            CSI_TRY(cv_correct(ctx, g, opt, st->S, src, st->y, values, channels, c, pos, n,
                               res->image + (size_t)c * np));
        t_int += now_s() - t1;
    }
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    return finish_nan_check(res->image, np * channels, "image");
}

/* Normalized convolution with a Gaussian of one width on every axis of the grid (t too when the
 * grid has one): NC(y) = G*(S^T y) / G*(S^T 1). The Gaussian baseline is NC of the samples; Alg.
 * 2's residual correction (csi_recon_options.motion_resid_sigma) is f += NC(y - S f). */
typedef struct {
    csi_linop *S, *G;
    cl_mem den, b, fs;
    float eps;
} nc_op;

static void nc_free(nc_op *r)
{
    csi_linop_free(r->S);
    csi_linop_free(r->G);
    csi_buffer_release(&r->den);
    csi_buffer_release(&r->b);
    csi_buffer_release(&r->fs);
}

/* yscratch: n floats and scratch: k floats of device scratch; ones: n floats of host scratch. */
static csi_status nc_init(csi_ctx *ctx, const csi_grid *g, const uint32_t *idx, size_t n,
                          double sigma, cl_mem yscratch, cl_mem scratch, float *ones, nc_op *r)
{
    const size_t k = (size_t)g->w * g->h * g->t;
    const size_t dims[3] = {g->w, g->h, g->t};
    const int nd = g->t > 1 ? 3 : 2;
    const double sphi[3] = {sigma, sigma, g->t > 1 ? sigma : 0};
    CSI_TRY(csi_sampling_create(ctx, k, idx, n, false, &r->S));
    CSI_TRY(csi_filter_create(ctx, dims, sphi, CSI_FILTER_GAUSS, 1.0f, &r->G));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the filtered sample density", &r->den));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the filtered samples", &r->b));
    CSI_TRY(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the estimate at the samples", &r->fs));
    /* Cells whose filtered density is below 1e-6 of a single sample's peak contribution (no
     * sample within reach of the filter) are left 0 instead of 0/0. */
    r->eps = (float)(1e-6 / pow(sqrt(2 * 3.14159265358979323846) * sigma, nd));
    for (size_t i = 0; i < n; i++)
        ones[i] = 1.0f;
    CSI_TRY(csi_write(ctx, yscratch, 0, n * 4, ones));
    CSI_TRY(csi_linop_adjoint(r->S, yscratch, scratch));
    return csi_linop_apply(r->G, scratch, r->den);
}

/* out = NC(yd): yd is n floats on the device; out (k floats) may be `scratch`. */
static csi_status nc_interp(csi_ctx *ctx, nc_op *r, cl_mem yd, size_t k, cl_mem scratch, cl_mem out)
{
    CSI_TRY(csi_linop_adjoint(r->S, yd, scratch));
    CSI_TRY(csi_linop_apply(r->G, scratch, r->b));
    cl_kernel div;
    CSI_TRY(csi_kernel(ctx, "recon", "csi_nc_divide", &div));
    cl_uint nk = (cl_uint)k;
    CSI_TRY(CSI_ARGS(div, CSI_MEM(r->b), CSI_MEM(r->den), CSI_MEM(out), CSI_ARG(nk), CSI_ARG(r->eps)));
    return csi_run1d(ctx, div, k);
}

/* f += NC(y - S f). y: the channel's n samples on the host; yscratch: n floats, scratch: k
 * floats of device scratch; host: n floats of host scratch. */
static csi_status nc_correct(csi_ctx *ctx, nc_op *r, const float *y, size_t n, size_t k, cl_mem f,
                             cl_mem yscratch, cl_mem scratch, float *host)
{
    CSI_TRY(csi_linop_apply(r->S, f, r->fs));
    CSI_TRY(csi_read(ctx, r->fs, 0, n * 4, host));
    for (size_t i = 0; i < n; i++)
        host[i] = y[i] - host[i];
    CSI_TRY(csi_write(ctx, yscratch, 0, n * 4, host));
    CSI_TRY(nc_interp(ctx, r, yscratch, k, scratch, scratch));
    return csi_vec_axpy(ctx, k, 1.0f, scratch, f);
}

/* A = S H for Alg. 2 on the half spectrum (csi_fourier_half): z (the half spectrum, complex)
 * -> f = H z (real volume) -> the samples f[idx_i], returned as complex values with zero
 * imaginary parts so that the complex solver sees measurements y + 0i. The adjoint takes the
 * real parts of its input (the imaginary parts of y - A z are zero), scatters them and applies
 * H^T (the real-to-complex transform), which is H's adjoint for the real inner products SpaRSA
 * uses (Re <a, b> everywhere: its steps, objective and tests). Complex-linearity is never used by
 * SpaRSA, so a real-linear operator is enough. */
typedef struct {
    csi_fourier_half *H;
    csi_linop *S;   /* real sampling */
    cl_mem vol, yr; /* k and n floats */
    size_t k, n;
} half_state;

static csi_status half_apply(const csi_linop *op, cl_mem z, cl_mem y)
{
    half_state *s = op->state;
    CSI_TRY(csi_fourier_half_inverse(s->H, z, s->vol));
    CSI_TRY(csi_linop_apply(s->S, s->vol, s->yr));
    cl_kernel r2c;
    CSI_TRY(csi_kernel(op->ctx, "recon", "csi_real_to_complex", &r2c));
    cl_uint nn = (cl_uint)s->n;
    CSI_TRY(CSI_ARGS(r2c, CSI_MEM(s->yr), CSI_MEM(y), CSI_ARG(nn)));
    return csi_run1d(op->ctx, r2c, s->n);
}

static csi_status half_adjoint(const csi_linop *op, cl_mem y, cl_mem z)
{
    half_state *s = op->state;
    cl_kernel c2r;
    CSI_TRY(csi_kernel(op->ctx, "recon", "csi_complex_real", &c2r));
    cl_uint nn = (cl_uint)s->n;
    CSI_TRY(CSI_ARGS(c2r, CSI_MEM(y), CSI_MEM(s->yr), CSI_ARG(nn)));
    CSI_TRY(csi_run1d(op->ctx, c2r, s->n));
    CSI_TRY(csi_linop_adjoint(s->S, s->yr, s->vol));
    return csi_fourier_half_forward(s->H, s->vol, z);
}

static void half_destroy(csi_linop *op)
{
    half_state *s = op->state;
    if (!s)
        return;
    csi_fourier_half_free(s->H);
    csi_linop_free(s->S);
    csi_buffer_release(&s->vol);
    csi_buffer_release(&s->yr);
    free(s);
    op->state = NULL;
}

static csi_status half_create(csi_ctx *ctx, const size_t dims[3], const uint32_t *idx, size_t n,
                              csi_linop **out)
{
    *out = NULL;
    csi_linop *op = calloc(1, sizeof *op);
    half_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion operator");
    }
    op->ctx = ctx;
    op->name = "S H (half-spectrum Fourier)";
    op->complex_valued = true;
    op->apply = half_apply;
    op->adjoint = half_adjoint;
    op->destroy = half_destroy;
    op->state = s;
    s->k = dims[0] * dims[1] * dims[2];
    s->n = n;
    csi_status st = csi_fourier_half_create(ctx, dims, &s->H);
    if (st == CSI_OK)
        st = csi_sampling_create(ctx, s->k, idx, n, false, &s->S);
    if (st == CSI_OK)
        st = csi_buffer(ctx, s->k * 4, CL_MEM_READ_WRITE, "the motion operator's volume", &s->vol);
    if (st == CSI_OK)
        st = csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the motion operator's samples", &s->yr);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    op->rows = n;
    op->cols = csi_fourier_half_count(s->H);
    *out = op;
    return CSI_OK;
}

/* Alg. 2 and Sec. 6.1.
 *
 * The paper solves for the complex 3-D Fourier coefficients x of f with A = S F3^H. For real
 * samples that problem has a Hermitian minimiser (if x minimises, so does its conjugate mirror,
 * and by convexity their mean, which is Hermitian and no worse), so csi solves the same problem
 * on the half spectrum z (csi_fourier_half: z = x on the planes u0 = 0 and u0 = n0/2, 2 x
 * between, so H z = F3^H x and ||z||_1 = ||x||_1): half the unknowns and about half the FFT
 * work, the same tau and the same minimiser (docs/bench/motion.md has the measurements). The
 * full complex formulation stays available (csi_recon_options.motion_full_spectrum) and is
 * used when the size does not allow the half spectrum (an odd first axis). */
static csi_status motion(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                         const csi_sample_pos *pos, const float *values, size_t n,
                         const csi_recon_options *opt, csi_recon_result *res, recon_state *st)
{
    const size_t w = g->w, h = g->h, T = g->t, k = w * h * T, wh = w * h;
    const size_t dims[3] = {w, h, T};
    if (res->solver == CSI_SOLVER_ROMP)
        return csi_fail(CSI_ERR_ARG, "ROMP is real-valued and the 3-D Fourier problem is complex: "
                                     "use --solver sparsa for a volume (grid_t = %zu)", T);
    bool half = !opt->motion_full_spectrum;
    if (half) {
        csi_status hs = half_create(ctx, dims, st->idx, n, &st->A);
        if (hs == CSI_ERR_ARG && !st->A)
            half = false; /* e.g. an odd width: the full complex problem instead */
        else
            CSI_TRY(hs);
    }
    if (!half) {
        csi_linop *F = NULL;
        CSI_TRY(csi_fourier_create(ctx, dims, &F));
        st->inner = F;
        st->Psi = F;
        CSI_TRY(csi_sampling_create(ctx, k, st->idx, n, true, &st->S));
        CSI_TRY(csi_linop_compose("S F3^H", st->S, st->inner, true, &st->A));
    }
    const size_t ncoef = st->A->cols;
    CSI_TRY(csi_solver_create(st->A, &st->solver));

    CSI_TRY(csi_buffer(ctx, n * 8, CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, ncoef * 8, CL_MEM_READ_WRITE, "the Fourier coefficients", &st->x));
    if (!half)
        CSI_TRY(csi_buffer(ctx, k * 8, CL_MEM_READ_WRITE, "the reconstructed volume", &st->f));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the real volume", &st->tmp));
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, (np > wh ? np : wh) * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    half_state *hst = half ? st->A->state : NULL;
    /* k floats of scratch once the solve is done: the operator's volume, or the complex one */
    cl_mem scratch = half ? hst->vol : st->f;
    cl_mem mean = NULL, real_y = NULL;
    csi_status s = csi_buffer(ctx, wh * 4, CL_MEM_READ_WRITE, "the time mean", &mean);
    if (s == CSI_OK)
        s = csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the real measurements", &real_y);
    cl_kernel r2c = NULL, c2r = NULL;
    if (s == CSI_OK)
        s = csi_kernel(ctx, "recon", "csi_real_to_complex", &r2c);
    if (s == CSI_OK)
        s = csi_kernel(ctx, "recon", "csi_complex_real", &c2r);

    nc_op rnc;
    memset(&rnc, 0, sizeof rnc);
    float *yhost = NULL;
    const bool correct = opt->motion_resid_sigma >= 0;
    if (s == CSI_OK && correct) {
        yhost = malloc(n * sizeof *yhost);
        if (!yhost)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        const double sig = opt->motion_resid_sigma > 0 ? opt->motion_resid_sigma
                                                        : csi_gauss_nc_default_sigma(k, n, 3);
        if (s == CSI_OK)
            s = nc_init(ctx, g, st->idx, n, sig, real_y, scratch, yhost, &rnc);
    }
    res->t_setup = now_s();

    double t_solve = 0, t_int = 0;
    for (uint32_t c = 0; c < channels && s == CSI_OK; c++) {
        for (size_t i = 0; i < n; i++)
            st->plane[i] = values[i * channels + c];
        cl_uint nn = (cl_uint)n, nk = (cl_uint)k;
        s = csi_write(ctx, real_y, 0, n * 4, st->plane);
        if (s == CSI_OK)
            s = CSI_ARGS(r2c, CSI_MEM(real_y), CSI_MEM(st->y), CSI_ARG(nn));
        if (s == CSI_OK)
            s = csi_run1d(ctx, r2c, n);
        if (s == CSI_OK)
            s = csi_fill_zero(ctx, st->x, ncoef * 8);
        double t0 = now_s();
        if (s == CSI_OK)
            s = run_solver(st, res->solver, opt, 0.0, n, &res->report[c]);
        if (s == CSI_OK)
            s = csi_finish(ctx);
        double t1 = now_s();
        t_solve += t1 - t0;
        report_progress(opt, "integrate");
        if (half) {
            if (s == CSI_OK)
                s = csi_fourier_half_inverse(hst->H, st->x, st->tmp); /* f = H z, real */
        } else {
            if (s == CSI_OK)
                s = csi_linop_apply(st->Psi, st->x, st->f);
            if (s == CSI_OK)
                s = CSI_ARGS(c2r, CSI_MEM(st->f), CSI_MEM(st->tmp), CSI_ARG(nk));
            if (s == CSI_OK)
                s = csi_run1d(ctx, c2r, k); /* f = Re(F3^H x) */
        }
        if (s == CSI_OK && correct)
            s = nc_correct(ctx, &rnc, st->plane, n, k, st->tmp, real_y, scratch, yhost);
        if (s == CSI_OK)
            s = integrate_volume(ctx, g, st->tmp, c, opt, res, mean, st->out);
        t_int += now_s() - t1;
    }
    nc_free(&rnc);
    free(yhost);
    csi_buffer_release(&mean);
    csi_buffer_release(&real_y);
    CSI_TRY(s);
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    CSI_TRY(finish_nan_check(res->image, np * channels, "image"));
    if (opt->frames)
        CSI_TRY(finish_nan_check(res->frames, np * channels * T, "frames"));
    return CSI_OK;
}

/* Integrates one channel's real volume `vol` (w x h x T) into the result: the image plane is the
 * box integral of its mean over t; frames (if asked for) the box integral of each slice.
 * scratch_wh: w*h floats; out: out_w*out_h floats. */
static csi_status integrate_volume(csi_ctx *ctx, const csi_grid *g, cl_mem vol, uint32_t c,
                                   const csi_recon_options *opt, csi_recon_result *res,
                                   cl_mem scratch_wh, cl_mem out)
{
    const size_t wh = (size_t)g->w * g->h, np = (size_t)g->out_w * g->out_h;
    const uint32_t channels = res->channels;
    if (g->t == 1) {
        CSI_TRY(csi_box_integrate(ctx, vol, g->w, g->h, 1, g->out_w, g->out_h, out));
        return csi_read(ctx, out, 0, np * 4, res->image + (size_t)c * np);
    }
    CSI_TRY(csi_time_mean(ctx, vol, g->w, g->h, g->t, 1, scratch_wh));
    CSI_TRY(csi_box_integrate(ctx, scratch_wh, g->w, g->h, 1, g->out_w, g->out_h, out));
    CSI_TRY(csi_read(ctx, out, 0, np * 4, res->image + (size_t)c * np));
    for (size_t t = 0; opt->frames && t < g->t; t++) {
        CSI_TRY(csi_copy(ctx, scratch_wh, 0, vol, t * wh * 4, wh * 4));
        CSI_TRY(csi_box_integrate(ctx, scratch_wh, g->w, g->h, 1, g->out_w, g->out_h, out));
        CSI_TRY(csi_read(ctx, out, 0, np * 4, res->frames + (t * channels + c) * np));
    }
    return CSI_OK;
}

/* Baseline: normalized convolution with a Gaussian of the same width on every axis. */
static csi_status gauss_nc(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                           const csi_sample_pos *pos, const float *values, size_t n,
                           const csi_recon_options *opt, csi_recon_result *res, recon_state *st)
{
    const size_t k = (size_t)g->w * g->h * g->t, wh = (size_t)g->w * g->h;
    const int nd = g->t > 1 ? 3 : 2;
    const double sigma = opt->gauss_sigma > 0 ? opt->gauss_sigma : csi_gauss_nc_default_sigma(k, n, nd);
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the scattered samples", &st->x));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the interpolated samples", &st->tmp));
    CSI_TRY(csi_buffer(ctx, (np > wh ? np : wh) * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    cl_mem scratch = NULL;
    nc_op nc;
    memset(&nc, 0, sizeof nc);
    csi_status s = csi_buffer(ctx, wh * 4, CL_MEM_READ_WRITE, "a frame", &scratch);
    if (s == CSI_OK)
        s = nc_init(ctx, g, st->idx, n, sigma, st->y, st->x, st->plane, &nc);
    res->t_setup = now_s();
    double t0 = now_s();
    for (uint32_t c = 0; c < channels && s == CSI_OK; c++) {
        for (size_t i = 0; i < n; i++)
            st->plane[i] = values[i * channels + c];
        s = csi_write(ctx, st->y, 0, n * 4, st->plane);
        if (s == CSI_OK)
            s = nc_interp(ctx, &nc, st->y, k, st->x, st->tmp);
        if (s == CSI_OK)
            s = integrate_volume(ctx, g, st->tmp, c, opt, res, scratch, st->out);
        if (s == CSI_OK && g->t == 1 && opt->correct == CSI_CORRECT_CV)
            s = cv_correct(ctx, g, opt, nc.S, st->tmp, st->y, values, channels, c, pos, n,
                           res->image + (size_t)c * np);
        if (s == CSI_OK) {
            csi_solve_report *r = &res->report[c];
            r->converged = true;
            snprintf(r->message, sizeof r->message, "Gaussian normalized convolution, sigma %.3g cells", sigma);
        }
    }
    res->t_integrate = now_s() - t0;
    nc_free(&nc);
    csi_buffer_release(&scratch);
    return s;
}

/* Baseline: the per-pixel sample mean (Monte Carlo). */
static csi_status sample_mean(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              csi_recon_result *res, recon_state *st)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, np * channels * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    res->t_setup = now_s();
    double t0 = now_s();
    size_t empty = 0;
    CSI_TRY(csi_splat_mean(ctx, g, channels, pos, values, n, st->out, &empty));
    CSI_TRY(csi_read(ctx, st->out, 0, np * channels * 4, res->image));
    res->t_integrate = now_s() - t0;
    for (uint32_t c = 0; c < channels; c++) {
        res->report[c].converged = true;
        snprintf(res->report[c].message, sizeof res->report[c].message,
                 "per-pixel sample mean; %zu of %zu pixels had no sample (left 0)", empty, np);
    }
    return CSI_OK;
}

csi_status csi_reconstruct(csi_ctx *ctx, const csi_grid *grid, uint32_t channels,
                           const csi_sample_pos *pos, const float *values, size_t n,
                           const csi_recon_options *opt_in, csi_recon_result *out)
{
    memset(out, 0, sizeof *out);
    csi_recon_options opt;
    if (opt_in)
        opt = *opt_in;
    else
        csi_recon_defaults(&opt);
    if (!(opt.lambda > 0) || !isfinite(opt.lambda))
        return csi_fail(CSI_ERR_ARG, "lambda must be a finite number > 0 (got %g)", (double)opt.lambda);
    if (!(opt.sigma_scale > 0) || !isfinite(opt.sigma_scale))
        return csi_fail(CSI_ERR_ARG, "sigma scale must be a finite number > 0 (got %g)", opt.sigma_scale);
    CSI_TRY(check_inputs(grid, channels, pos, values, n));

    const size_t np = (size_t)grid->out_w * grid->out_h;
    out->out_w = grid->out_w;
    out->out_h = grid->out_h;
    out->channels = channels;
    out->k = (size_t)grid->w * grid->h * grid->t;
    out->n = n;
    out->solver = opt.solver != CSI_SOLVER_DEFAULT ? opt.solver : CSI_SOLVER_SPARSA;
    out->image = calloc(np * channels, sizeof(float));
    if (grid->t > 1 && opt.frames && opt.estimator != CSI_EST_MEAN) {
        out->nframes = grid->t;
        out->frames = calloc(np * channels * grid->t, sizeof(float));
    }
    if (!out->image || (out->nframes && !out->frames)) {
        csi_recon_result_free(out);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the output image");
    }
    recon_state st;
    memset(&st, 0, sizeof st);
    double t0 = now_s();
    report_progress(&opt, "setup");
    csi_status s = CSI_OK;
    if (opt.estimator != CSI_EST_MEAN) {
        /* What every operator-based path needs: the samples' linear grid indices, and one
         * channel's values at a time (st.plane). */
        st.idx = malloc(n * sizeof *st.idx);
        st.plane = malloc(n * sizeof *st.plane);
        if (!st.idx || !st.plane)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        for (size_t i = 0; i < n && s == CSI_OK; i++)
            st.idx[i] = (uint32_t)csi_grid_index(grid, pos[i]);
    }
    if (s == CSI_OK) {
        if (opt.estimator == CSI_EST_MEAN)
            s = sample_mean(ctx, grid, channels, pos, values, n, out, &st);
        else if (opt.estimator == CSI_EST_GAUSS)
            s = gauss_nc(ctx, grid, channels, pos, values, n, &opt, out, &st);
        else if (grid->t == 1)
            s = antialias(ctx, grid, channels, pos, values, n, &opt, out, &st);
        else
            s = motion(ctx, grid, channels, pos, values, n, &opt, out, &st);
    }
    out->t_setup = out->t_setup > t0 ? out->t_setup - t0 : 0;
    state_free(&st);
    if (s != CSI_OK)
        csi_recon_result_free(out);
    return s;
}
