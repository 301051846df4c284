/* The defaults that depend on the problem: every "auto" option resolved to the value the method
 * uses, so that a caller (and the statistics) can see what ran. See csi/reconstruct.h. */
#include <math.h>

#include "csi/frames_denoise.h"
#include "csi/model_grid.h"
#include "csi/solve.h"
#include "csi/tiles.h"
#include "csi/wavelet.h"
#include "internal.h"

/* SpaRSA for Alg. 1 (the image problem), where the caller left a setting open. Measured in
 * docs/bench/quality.md. */
static void image_sparsa(csi_recon_options *o, double spp)
{
    /* The image stops changing long before the duality gap closes (with continuation the
     * default gap rule ran 2000 steps in an intermediate stage): stop on the relative change of
     * the objective instead. 3e-3 stops after 15-55 steps with the MSE within a few % of 300. */
    if (o->stop == CSI_STOP_AUTO)
        o->stop = CSI_STOP_OBJECTIVE;
    if (o->tol == 0)
        o->tol = 3e-3;
    if (o->max_iter == 0)
        o->max_iter = 300;
    /* The final least squares on the support refits the samples exactly and cost up to 2x in
     * MSE (e.g. 9.6e-4 against 4.6e-4, triangle 4 spp); without it never worse. */
    if (o->debias == CSI_SWITCH_AUTO)
        o->debias = CSI_SWITCH_OFF;
    /* The best tau falls with the samples per pixel, about 3e-3 / spp of ||A^H y||_inf
     * (measured 1 to 16 spp, 4x4 and 8x8 cells per pixel): few samples want a smoother fit. */
    if (o->tau_rel == 0)
        o->tau_rel = fmin(3e-3, fmax(1e-5, 3e-3 / spp));
    csi_sparsa_options d;
    csi_sparsa_defaults(&d);
    if (o->continuation == CSI_SWITCH_AUTO)
        o->continuation = d.continuation ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    /* The objective stop ends each stage long before ||A^H r||_inf comes down to tau_k (2-5x it
     * on the Mitsuba scenes), so the adaptive rule lowers tau by 0.4-0.9x a stage and a solve
     * runs 8-11 stages; a fixed 0.1 a stage takes 4-5 and about three quarters of the operator
     * runs, with the MSE within about 1% (docs/bench/cost.md). */
    if (o->cont_step == 0)
        o->cont_step = 0.1;
    /* A stage before the last only has to bring the start of the next one near its path: at 3e-2
     * (instead of the last stage's 3e-3) a solve takes 0.70-0.85x the operator runs of 3e-3's,
     * the MSE within 1.5% on the same dumps; at 1e-1 a solve can end after 10 steps (+4.7%). */
    if (o->cont_tol == 0)
        o->cont_tol = 3e-2;
}

/* SpaRSA for Alg. 2: the solver's own defaults but tau, which follows the number of samples
 * (csi_motion_tau_rel). The debiasing (least squares on the support) only when asked for with
 * motion_debias: the video's spectrum is compressible, not sparse, and refitting its support to
 * the samples overfits them (docs/bench/motion.md). That also keeps the half- and full-spectrum
 * solves alike: the solver's support count differs between them (conjugate pairs count once on
 * the half spectrum), and with it whether it debiases. */
static void motion_sparsa(csi_recon_options *o, size_t n)
{
    csi_sparsa_options d;
    csi_sparsa_defaults(&d);
    /* where Alg. 1's filter may be used, auto waits for it (motion.c) */
    if (o->stop == CSI_STOP_AUTO && o->motion_filter < 0)
        o->stop = d.stop == CSI_SPARSA_STOP_GAP ? CSI_STOP_GAP : CSI_STOP_OBJECTIVE;
    if (o->tol == 0)
        o->tol = d.tol;
    if (o->max_iter == 0)
        o->max_iter = d.max_iter;
    if (o->tau_rel == 0)
        o->tau_rel = csi_motion_tau_rel(n);
    o->debias = o->motion_debias ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    if (o->continuation == CSI_SWITCH_AUTO)
        o->continuation = d.continuation ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    if (o->cont_step == 0)
        o->cont_step = -1;
    if (o->cont_tol == 0)
        o->cont_tol = d.cont_tol;
}

/* ROMP for Alg. 1 (docs/bench/romp.md): csi's settings, or the published ROMP's (Needell &
 * Vershynin: s from N, stop at 2s, raw correlations, its least squares). */
static void image_romp(csi_recon_options *o, size_t N, size_t k)
{
    csi_romp_options d;
    csi_romp_defaults(&d);
    const bool published = o->romp_preset == CSI_ROMP_PRESET_PUBLISHED;
    if (o->romp_s == 0)
        o->romp_s = published ? csi_romp_default_s(N, k) : (N / 64 > 16 ? N / 64 : 16);
    /* csi: a support limit as a fraction of N (early stopping is ROMP's only regulariser: the
     * least squares interpolate the samples). */
    if (o->romp_max_support == 0)
        o->romp_max_support = published ? (double)(2 * o->romp_s) : 0.15;
    if (o->romp_normalize == CSI_SWITCH_AUTO)
        o->romp_normalize = CSI_SWITCH_OFF;
    /* csi: the coarse block and the coarsest detail level seeded (raw correlations never pick
     * the scaling block on point samples). */
    if (o->romp_seed_levels == 0)
        o->romp_seed_levels = published ? -1 : 2;
    /* csi: one warm-started CG step per support growth instead of ROMP's least squares (60
     * steps): the exact fits interpolate the samples on the support, which is what makes ROMP's
     * images spiky; fewer steps measured monotonically better and 3-10x faster
     * (docs/bench/romp.md). With one step the update is a steepest-descent step on the support
     * (closer to gradient pursuit than to Needell & Vershynin's projection); --romp-lsq-iter
     * restores the exact least squares. */
    if (o->romp_lsq_iter == 0)
        o->romp_lsq_iter = published ? d.lsq_iter : 1;
    if (o->tol == 0)
        o->tol = d.tol;
    if (o->max_iter == 0) /* each iteration adds at least one index */
        o->max_iter = (int)(csi_recon_romp_support_limit(o, N) + 10);
}

size_t csi_recon_romp_support_limit(const csi_recon_options *o, size_t N)
{
    if (o->romp_max_support >= 1)
        return (size_t)o->romp_max_support;
    return (size_t)fmax(1.0, floor(o->romp_max_support * (double)N));
}

csi_status csi_recon_resolve(const csi_recon_options *in, const csi_grid *g, size_t n,
                             csi_recon_options *out)
{
    return csi_recon_resolve_scoped(in, g, n, NULL, out);
}

csi_status csi_recon_resolve_scoped(const csi_recon_options *in, const csi_grid *g, size_t n,
                                    const csi_tile_scope *scope, csi_recon_options *o)
{
    *o = *in;
    /* The figures the density-dependent defaults follow: the whole problem's for a tile. */
    const size_t k = scope ? (size_t)scope->k : (size_t)g->w * g->h * g->t;
    const size_t nd = scope ? (size_t)scope->n : n;
    const size_t np = scope ? (size_t)scope->out_w * scope->out_h : (size_t)g->out_w * g->out_h;
    const bool still = g->t == 1;
    if (o->estimator == CSI_EST_MEAN)
        return CSI_OK;
    if (o->estimator == CSI_EST_GAUSS) {
        if (o->gauss_sigma == 0)
            o->gauss_sigma = csi_gauss_nc_default_sigma(k, nd, still ? 2 : 3);
        if (still && o->correct == CSI_CORRECT_AUTO)
            o->correct = CSI_CORRECT_NONE;
        return CSI_OK;
    }
    if (o->solver == CSI_SOLVER_AUTO)
        o->solver = CSI_SOLVER_SPARSA;
    if (!still) {
        if (o->motion_resid_sigma == 0)
            o->motion_resid_sigma = csi_gauss_nc_default_sigma(k, nd, 3);
        /* the full spectrum has the DFT only; on the half spectrum auto waits for the velocity
         * (motion.c: the DCT for a sheared basis, and for a still one whose shutter's ends differ
         * more than the image holds; else the DFT) */
        if (o->motion_time == CSI_MOTION_TIME_AUTO && o->motion_full_spectrum)
            o->motion_time = CSI_MOTION_TIME_DFT;
        if (o->motion_resid_sigma_t == 0 && o->motion_resid_sigma > 0)
            o->motion_resid_sigma_t = o->motion_resid_sigma;
        /* the image's per-region choice against binned solves (motion_image.c): an option, off
         * unless asked for (docs/bench/animation.md, session 10) */
        if (o->motion_image_cv == CSI_SWITCH_AUTO)
            o->motion_image_cv = CSI_SWITCH_OFF;
        /* the blurred image averaged with the denoised frames' mean (csi/frames_denoise.h),
         * wherever the frames' step would run on noisy samples: it needs the frames, asked for
         * or not (csi_recon makes them) */
        const bool noisy = csi_frames_denoise_noisy(o->sample_noise, 4);
        if (o->image_frames == CSI_SWITCH_AUTO)
            o->image_frames = o->frames_denoise != CSI_SWITCH_OFF && noisy ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
        /* the frames of noisy samples (csi/frames_denoise.h): where the samples' variances
         * say they are noisy and the frames are asked for, or for the image's average */
        if (o->frames_denoise == CSI_SWITCH_AUTO)
            o->frames_denoise = (o->frames && noisy) || o->image_frames == CSI_SWITCH_ON ? CSI_SWITCH_ON
                                                                                          : CSI_SWITCH_OFF;
        /* the paper's form (the full spectrum) has no filter; on the half spectrum auto waits for
         * the velocity too (motion.c) */
        if (o->motion_full_spectrum)
            o->motion_filter = -1;
        /* the still layer's weight is a gain of the half-spectrum operator */
        if (o->motion_full_spectrum)
            o->motion_still_weight = 1;
        /* the reweighted l1's eps: 0, a caller's unset field, is the option's default */
        if (o->motion_reweight_eps <= 0)
            o->motion_reweight_eps = 10;
        if (o->solver == CSI_SOLVER_SPARSA)
            motion_sparsa(o, n);
        return CSI_OK;
    }
    /* Default: as many levels as the grid allows, at most 5. The tau rule (image_sparsa) is
     * relative to ||A^H y||_inf, which the coarse band dominates and which doubles with each
     * extra level; with 7 levels at 1024^2 the rule's tau was 2x off (MSE 8.5e-4 against 4.6e-4
     * with 5 levels, texture 1 spp), while 5 against 6 levels at 512^2 differ by < 5%. A grid
     * that allows no level keeps 0, and Alg. 1 refuses it. */
    if (o->levels == 0) {
        int l = csi_wavelet_default_levels(o->wavelet, g->w, g->h);
        o->levels = l > 5 ? 5 : l;
    }
    /* The blend (issue 9): never worse than the pixels' own means on a path tracer's samples,
     * where the control variate was; on exact (noise-free) samples the control variate is the
     * better estimator and the blend gives part of its gain away (docs/bench/mitsuba.md). */
    if (o->correct == CSI_CORRECT_AUTO)
        o->correct = o->sample_flags & CSI_SAMPLES_EXACT ? CSI_CORRECT_CV : CSI_CORRECT_BLEND;
    /* The cross-validated choice (csi/cv_select.h): with the blend, the correction for noisy
     * samples; on the whole image, or in each tile's window (tiled.c). */
    if (o->cv_select == CSI_SWITCH_AUTO)
        o->cv_select = o->correct == CSI_CORRECT_BLEND ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    /* Its folds on the channels' mean: a third of the folds' solves, and on Mitsuba's dumps the
     * MSE of folds per channel within 0.2% in 227 cells of 228 (docs/bench/mitsuba.md, session 19). */
    if (o->cv_channels == CSI_CV_CHANNELS_AUTO)
        o->cv_channels = CSI_CV_CHANNELS_MEAN;
    /* Its smoothing candidates (csi/cv_smooth.h): wherever the choice is. */
    if (o->cv_smooth == CSI_SWITCH_AUTO || o->cv_select != CSI_SWITCH_ON)
        o->cv_smooth = o->cv_select == CSI_SWITCH_ON && o->cv_smooth != CSI_SWITCH_OFF ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    /* The log fit at isolated peaks (csi/peak_range.h): an option, measured in
     * docs/bench/mitsuba.md (session 10). */
    if (o->peak_range == CSI_SWITCH_AUTO || o->correct != CSI_CORRECT_BLEND || scope)
        o->peak_range = o->peak_range == CSI_SWITCH_ON && o->correct == CSI_CORRECT_BLEND && !scope
                            ? CSI_SWITCH_ON
                            : CSI_SWITCH_OFF;
    /* The blend's own spread given the samples' variances (blend.c): an option, measured in
     * docs/bench/mitsuba.md (session 13). */
    if (o->blend_spread == CSI_SWITCH_AUTO || o->correct != CSI_CORRECT_BLEND)
        o->blend_spread = o->blend_spread == CSI_SWITCH_ON && o->correct == CSI_CORRECT_BLEND
                              ? CSI_SWITCH_ON
                              : CSI_SWITCH_OFF;
    /* The deciding pixels settled on their means (csi/settle.h): with the blend, the correction
     * for noisy samples, so that one pixel cannot put the image above the mean (issue 9). */
    const bool settles = o->correct == CSI_CORRECT_BLEND && o->estimator == CSI_EST_CS;
    if (o->settle == CSI_SWITCH_AUTO || !settles)
        o->settle = o->settle != CSI_SWITCH_OFF && settles ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    /* An HDR step's pixels given the coverage their window allows (csi/step_coverage.h): where
     * the blend is, after the settling (it runs only given the samples' variances). */
    if (o->step_coverage == CSI_SWITCH_AUTO || !settles)
        o->step_coverage = o->step_coverage != CSI_SWITCH_OFF && settles ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    /* The model grid reproduces the sharp estimate's operator for SpaRSA (csi/model_grid.h);
     * ROMP and the filtered estimate keep the samples' grid. "on": where the filter allows. */
    if (o->model_grid == CSI_SWITCH_AUTO)
        o->model_grid = o->output == CSI_AA_SHARP && o->solver == CSI_SOLVER_SPARSA ? CSI_SWITCH_ON
                                                                                    : CSI_SWITCH_OFF;
    if (o->model_sigma_min == 0)
        o->model_sigma_min = CSI_MODEL_SIGMA_MIN;
    /* Warm-started channels (solver_setup.c) save 40-60% of the steps of channels 2 and 3, but
     * they stop at another point than the cold solves' continuation path: the MSE moved by
     * -3%..+4% on the same samples (garden and checkerboard at 1 spp: +2.5..3.8%;
     * docs/bench/cost.md), more than the 2% the defaults may move. Off unless asked for. */
    if (o->warm_channels == CSI_SWITCH_AUTO)
        o->warm_channels = CSI_SWITCH_OFF;
    if (o->coarse_start == CSI_SWITCH_AUTO)
        o->coarse_start = CSI_SWITCH_OFF;
    /* RGB as luma and chroma (chroma.c; where it applies, csi_recon_chroma_on): 0.68x the CPU of
     * three RGB solves on the 1920x1080 garden, and on 70 bundled, analytic and Mitsuba dumps the
     * MSE within 2% of the RGB solves' but one dump, whose +2.3% lies inside the spread the RGB
     * solves' own stop makes (+2.8% at --tol 2e-3); on the 372 Mitsuba cells of issue 9 as often
     * and as little above the mean (docs/bench/cost.md, sessions 20-22 and 27). */
    if (o->chroma == CSI_SWITCH_AUTO)
        o->chroma = CSI_SWITCH_ON;
    if (o->solver == CSI_SOLVER_ROMP) {
        image_romp(o, n, (size_t)g->w * g->h); /* each problem's own operator (tiles too) */
    } else {
        image_sparsa(o, (double)nd / (double)np);
    }
    return CSI_OK;
}
