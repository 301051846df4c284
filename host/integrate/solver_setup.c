/* The solver of a reconstruction with the method's defaults: SpaRSA for Alg. 1 and Alg. 2, ROMP
 * for Alg. 1, each option the caller left open filled with the measured default. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "csi/wavelet.h"
#include "internal.h"

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

/* The solvers report their steps as "sparsa" / "romp" / "debias"; the caller sees them as
 * "solve <c>/<channels>", the channel being solved. */
typedef struct {
    const csi_recon_options *opt;
    char phase[32];
} channel_progress;

static void forward_progress(void *user, const char *phase, int iter, double rel_residual)
{
    const channel_progress *p = user;
    (void)phase;
    p->opt->progress(p->opt->user, p->phase, iter, rel_residual);
}

/* image_spp > 0: Alg. 1 with that many samples per output pixel (SpaRSA gets the image
 * defaults where the caller left a setting open); 0: Alg. 2. */
csi_status csi_recon_run_solver(csi_recon_state *st, csi_solver_kind kind,
                                const csi_recon_options *opt, double image_spp, size_t motion_n,
                                double tau_scale, csi_solve_report *rep)
{
    channel_progress cp = {opt, ""};
    snprintf(cp.phase, sizeof cp.phase, "solve %u/%u", st->channel + 1, st->channels);
    csi_progress_fn progress = opt->progress ? forward_progress : NULL;
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
        o.progress = progress;
        o.user = &cp;
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
    if (tau_scale > 0)
        o.tau = o.tau_rel * tau_scale;
    if (motion) {
        /* Alg. 2: SpaRSA's debiasing (least squares on the support) only when asked for: the
         * video's spectrum is compressible, not sparse, and refitting its support to the samples
         * overfits them (docs/bench/motion.md). Also keeps the half- and full-spectrum solves
         * alike: the solver's support count differs between them (conjugate pairs count once
         * on the half spectrum), and with it whether it debiases. */
        o.debias = opt->motion_debias;
    }
    o.progress = progress;
    o.user = &cp;
    return csi_sparsa_run(st->solver, st->y, st->x, &o, rep);
}
