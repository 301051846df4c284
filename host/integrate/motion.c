/* Alg. 2 (motion blur and animation): A = S F3^H on the half (or full) spectrum, solve, residual
 * correction, mean over t and every frame; the volume kept within the samples' range. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/gaussian.h"
#include "csi/integrate_ops.h"
#include "csi/motion_filter.h"
#include "csi/sampled_half_fourier.h"
#include "csi/sampling.h"
#include "csi/solve.h"
#include "csi/spectral.h"
#include "internal.h"

/* Alg. 2 and Sec. 6.1.
 *
 * The paper solves for the complex 3-D Fourier coefficients x of f with A = S F3^H. For real
 * samples that problem has a Hermitian minimiser (if x minimises, so does its conjugate mirror,
 * and by convexity their mean, which is Hermitian and no worse), so csi solves the same problem
 * on the half spectrum z (csi_fourier_half: z = x on the planes u0 = 0 and u0 = n0/2, 2 x
 * between, so H z = F3^H x and ||z||_1 = ||x||_1): half the unknowns and about half the FFT
 * work, the same tau and the same minimiser (docs/bench/motion.md has the measurements). The
 * full complex formulation stays available (csi_recon_options.motion_full_spectrum) and is
 * used when the size does not allow the half spectrum (an odd first axis).
 *
 * csi's motion basis (csi_recon_options.motion_time, motion_velocity; docs/bench/animation.md):
 * the half-spectrum basis sheared by the velocity at which most of the scene moves, estimated
 * from the samples (csi_motion_velocity_estimate), with the DCT along t; the residual correction
 * then runs along that motion too. The full spectrum keeps the paper's basis. */

/* The values the velocity is judged on: the mean over channels, compressed as m / (1 + m) so
 * that a few very bright samples (HDR) do not decide the motion alone. */
static void motion_values(const float *values, uint32_t channels, size_t n, float *y)
{
    for (size_t i = 0; i < n; i++) {
        double m = 0;
        for (uint32_t c = 0; c < channels; c++)
            m += values[i * channels + c];
        m = m / channels;
        m = m > 0 ? m : 0;
        y[i] = (float)(m / (1.0 + m));
    }
}

/* The transform along t: the option's, or with auto the DCT for a sheared basis (whose aligned
 * volume is not periodic in t: the DFT's wrap spreads its ends over the temporal spectrum) and
 * for a still one whose shutter's ends differ by more than the image holds (ends: the ratio of
 * csi_recon_motion_ends, motion_ends.c); else the DFT, measured better on still cameras with
 * movers (docs/bench/animation.md, sessions 5 and 34). */
static csi_motion_time time_for(csi_motion_time t, const double v[2], double ends)
{
    if (t != CSI_MOTION_TIME_AUTO)
        return t;
    return v[0] != 0 || v[1] != 0 || ends > CSI_MOTION_ENDS_DCT ? CSI_MOTION_TIME_DCT : CSI_MOTION_TIME_DFT;
}

static csi_time_transform transform_of(csi_motion_time t)
{
    return t == CSI_MOTION_TIME_DFT ? CSI_TIME_DFT : CSI_TIME_DCT;
}

/* Gives the operator's basis its time stage and velocity (the options' or the estimated one),
 * both reported in res->options. The search borrows G, the coefficients, the operator's scratch volume and sampler, the real
 * volume and the measurements' buffer: none of them holds anything yet. */
static csi_status motion_basis(csi_ctx *ctx, const csi_grid *g, const csi_sample_pos *pos, const float *values,
                               uint32_t channels, size_t n, const csi_recon_options *opt,
                               csi_recon_state *st, csi_linop *G, cl_mem ydev, csi_recon_result *res)
{
    const size_t dims[3] = {g->w, g->h, g->t};
    csi_fourier_half *H = csi_half_fourier_basis(st->A);
    double v[2] = {0, 0};
    if (opt->motion_velocity == CSI_VELOCITY_GIVEN) {
        v[0] = opt->motion_vx;
        v[1] = opt->motion_vy;
    } else if (opt->motion_velocity == CSI_VELOCITY_ESTIMATE) {
        csi_motion_velocity mv;
        motion_values(values, channels, n, st->plane);
        CSI_TRY(csi_motion_velocity_estimate(ctx, g, H, G, st->x, csi_half_fourier_scratch(st->A),
                                             st->tmp, csi_half_fourier_sampler(st->A), ydev, st->y,
                                             st->plane, st->idx, n, opt, &mv));
        v[0] = mv.v[0];
        v[1] = mv.v[1];
        res->t_velocity = mv.seconds;
        res->velocity_evals = (uint32_t)mv.evaluations;
    }
    res->options.motion_vx = v[0];
    res->options.motion_vy = v[1];
    double ends = 0;
    if (opt->motion_time == CSI_MOTION_TIME_AUTO && v[0] == 0 && v[1] == 0)
        CSI_TRY(csi_recon_motion_ends(g, channels, pos, values, n, &ends));
    res->options.motion_time = time_for(opt->motion_time, v, ends);
    return csi_fourier_half_set_motion(H, dims, transform_of(res->options.motion_time), v[0], v[1]);
}

/* csi_recon_motion_filter_width (internal.h): auto is, with a still basis and fewer than 2
 * samples per pixel over the shutter, Alg. 1's rule (at least the paper's width, and
 * sigma_spacing times the samples' spacing) with the spacing of all the volume's samples seen on
 * one frame, sqrt(w h / N), since a still background is seen by every frame's samples. Where a
 * pixel sees about one sample or fewer the filter measured better, where it sees several worse;
 * with a sheared basis it lost on a path-traced camera slide at every width tried, so auto leaves
 * it out there (motion.c; docs/bench/animation.md, round 5). */
double csi_recon_motion_filter_width(const csi_grid *g, size_t n, const csi_recon_options *opt,
                                     const csi_tile_scope *scope)
{
    if (opt->motion_filter != 0 || opt->motion_full_spectrum)
        return opt->motion_filter > 0 && !opt->motion_full_spectrum ? opt->motion_filter : -1;
    /* the whole problem's cells and samples for a tile; its own frames (a time window's) */
    const double k = scope ? (double)scope->k : (double)g->w * g->h * g->t;
    const double spacing2 = k / (scope ? (double)scope->n : (double)n) / (double)g->t; /* pixels per sample */
    if (spacing2 <= 0.5)
        return -1;
    double paper;
    csi_gauss_sigmas(g->w, g->out_w, &paper, NULL);
    return fmax(paper * opt->sigma_scale, opt->sigma_spacing * sqrt(spacing2));
}

/* Noisy samples: the corrected image moved towards its pixels' own sample means
 * (motion_toward_mean.c), from what each pixel's samples say (px) and the volume's variance over
 * t of each pixel's box mean (into scratch). */
static csi_status toward_mean(csi_ctx *ctx, const csi_grid *g, cl_mem vol, cl_mem scratch, const csi_px_values *px,
                              float *plane)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    float *fit_var = malloc((np ? np : 1) * sizeof *fit_var);
    csi_status s = fit_var ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the pixels' means (%zu pixels)", np);
    if (s == CSI_OK)
        s = csi_box_time_var(ctx, vol, g->w, g->h, g->t, g->out_w, g->out_h, scratch);
    if (s == CSI_OK)
        s = csi_read(ctx, scratch, 0, np * sizeof *fit_var, fit_var);
    if (s == CSI_OK)
        s = csi_recon_motion_toward_mean(g, px, fit_var, plane);
    free(fit_var);
    return s;
}

csi_status csi_recon_motion(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt, csi_recon_result *res,
                            csi_recon_state *st)
{
    const size_t w = g->w, h = g->h, T = g->t, k = w * h * T, wh = w * h;
    const size_t dims[3] = {w, h, T};
    if (opt->solver == CSI_SOLVER_ROMP)
        return csi_fail(CSI_ERR_ARG, "ROMP is real-valued and the 3-D Fourier problem is complex: "
                                     "use --solver sparsa for a volume (grid_t = %zu)", T);
    bool half = !opt->motion_full_spectrum;
    if (half) {
        csi_status hs = csi_half_fourier_sampling_create(ctx, dims, st->idx, n, &st->A);
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
    CSI_TRY(csi_buffer(ctx, n * 8, CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, ncoef * 8, CL_MEM_READ_WRITE, "the Fourier coefficients", &st->x));
    if (!half)
        CSI_TRY(csi_buffer(ctx, k * 8, CL_MEM_READ_WRITE, "the reconstructed volume", &st->f));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the real volume", &st->tmp));
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, (np > wh ? np : wh) * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    /* k floats of scratch once the solve is done: the operator's volume, or the complex one */
    cl_mem scratch = half ? csi_half_fourier_scratch(st->A) : st->f;
    cl_mem mean = NULL, real_y = NULL;
    csi_status s = csi_buffer(ctx, wh * 4, CL_MEM_READ_WRITE, "the time mean", &mean);
    if (s == CSI_OK)
        s = csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the real measurements", &real_y);
    cl_kernel r2c = NULL, c2r = NULL;
    if (s == CSI_OK)
        s = csi_kernel(ctx, "sampling", "csi_real_to_complex", &r2c);
    if (s == CSI_OK)
        s = csi_kernel(ctx, "sampling", "csi_complex_real", &c2r);

    /* The motion basis (before the solver, whose buffers do not change with it). Its filter G,
     * on the basis with the coefficients as scratch, serves the velocity search and then the
     * residual correction. A single pixel over time has no space to shear: the paper's basis. */
    const bool moved = half && (g->w > 1 || g->h > 1) &&
                       (opt->motion_time != CSI_MOTION_TIME_DFT || opt->motion_velocity != CSI_VELOCITY_NONE);
    if (!moved && res->options.motion_time == CSI_MOTION_TIME_AUTO)
        res->options.motion_time = CSI_MOTION_TIME_DFT; /* the paper's basis, the only one here */
    const bool correct = opt->motion_resid_sigma > 0;
    csi_linop *G = NULL;
    if (s == CSI_OK && moved && (correct || opt->motion_velocity == CSI_VELOCITY_ESTIMATE))
        s = csi_motion_filter_create(ctx, csi_half_fourier_basis(st->A), dims, CSI_TIME_DCT, 1.0, 1.0,
                                     st->x, &G);
    if (s == CSI_OK && moved)
        s = motion_basis(ctx, g, pos, values, channels, n, opt, st, G, real_y, res);
    /* Alg. 1's filter (csi_half_fourier_set_filter), after the velocity search, which judges
     * velocities on the samples alone; by default only with a still basis. Its buffers are
     * reserved wherever it may be used, so that the plan (plan.c) need not know the velocity.
     * Its width is reported in res->options (-1: none). */
    const bool still = !moved || (res->options.motion_vx == 0 && res->options.motion_vy == 0);
    if (s == CSI_OK) {
        const double width = half ? csi_recon_motion_filter_width(g, n, opt, st->scope) : -1;
        res->options.motion_filter = width > 0 && (still || opt->motion_filter > 0) ? width : -1;
        if (width > 0)
            s = csi_half_fourier_filter_reserve(st->A);
        if (s == CSI_OK && res->options.motion_filter > 0)
            s = csi_half_fourier_set_filter(st->A, res->options.motion_filter, opt->lambda);
    }
    /* The time-constant layer's own l1 weight (csi_half_fourier_set_still_gain): a gain of
     * 1 / weight on its plane (the still content, or with a velocity what moves at it), tau
     * staying the unweighted problem's (the channel loop below). Reported in res->options. Auto
     * (0, also a caller's unset field): half with a still basis whose samples are a noise-free
     * still picture (most pixels holding two samples hold equal ones, still_samples.c), else
     * one. Half gained on every procedural volume, whose samples are exact, and lost on the
     * path-traced animations (docs/bench/animation.md, round 7 and session 30); with a sheared
     * basis it also lost on the train against the shutter's continuous-time reference. Its
     * buffers are reserved with auto, as the filter's are, so that the plan need not know.
     * A tenth where exact samples on a grid of 2 x 2 cells a pixel or more (a still camera's),
     * as many samples as the pixels' cells, show that little of what they see moves
     * (moving_share.c: lights that move hold at most a quarter of the samples' energy, and
     * either the lights hold still or the neighbours' samples differ little more across the
     * shutter than close in time, against their variance): each cell is then seen once or
     * twice, and at an equal weight the solve keeps a still light at the frames it was seen,
     * bright there and dim between, the image a fraction of what the samples say, and carries it
     * into the neighbours, and lets a still texture flicker over t where nothing says it holds
     * still; the still-picture test above does not fire there (a pixel's samples differ across
     * its cells). Where much moves the weight stays: at a tenth each sample of a mover is held
     * where it was seen, a moving light's worst (docs/bench/animation.md, sessions 43-44). */
    double still_weight = 1;
    bool little_moves = false; /* the samples' own word that little moves (moving_share.c) */
    if (s == CSI_OK && half && opt->motion_still_weight > 0) {
        still_weight = opt->motion_still_weight;
    } else if (s == CSI_OK && half) {
        double share = 0;
        s = csi_half_fourier_filter_reserve(st->A);
        if (s == CSI_OK && still)
            s = csi_recon_still_exact_share(g, pos, values, channels, n, &share);
        still_weight = share > CSI_STILL_PICTURE_SHARE ? 0.5 : 1;
        /* as many samples as cells a pixel over the whole shutter: a tile's or time window's
         * whole problem's (a window holds part of the shutter's samples and all its pixels) */
        const double cells_xy = (double)(g->w / g->out_w) * (g->h / g->out_h);
        const double pixels =
            st->scope ? (double)st->scope->out_w * st->scope->out_h : (double)g->out_w * g->out_h;
        if (s == CSI_OK && still && cells_xy >= 4 && csi_recon_scope_n(st, n) >= cells_xy * pixels) {
            csi_moving_share m;
            s = csi_recon_moving_share(g, pos, values, channels, n, &m);
            if (opt->sample_flags & CSI_SAMPLES_EXACT) {
                const bool still_lights = m.held > 0.5, little_motion = m.motion <= CSI_MOVING_VARIANCE_SHARE;
                little_moves = s == CSI_OK && m.lights <= CSI_MOVING_LIGHTS_SHARE && (still_lights || little_motion);
                if (little_moves)
                    still_weight = CSI_STILL_WEIGHT_LITTLE_MOVES;
            } else {
                little_moves = s == CSI_OK && m.lights <= CSI_MOVING_LIGHTS_SHARE &&
                               m.motion <= CSI_MOVING_VARIANCE_SHARE_NOISY;
            }
        }
    }
    res->options.motion_still_weight = still_weight;
    const bool still_weighted = still_weight != 1;
    if (s == CSI_OK && still_weighted)
        s = csi_half_fourier_set_still_gain(st->A, 1.0 / still_weight);
    /* SpaRSA's stop, if left to auto: the solver's default (the duality gap) without the filter;
     * with it the objective change. The filter's gains spread the operator's singular values,
     * and the gap then falls slowly on directions the volume barely depends on: it ran to the
     * step cap with the image already settled, where the objective stop ends with the same image
     * in a few dozen steps (docs/bench/animation.md, round 5). */
    csi_recon_options sopt = *opt;
    if (sopt.stop == CSI_STOP_AUTO) {
        csi_sparsa_options d;
        csi_sparsa_defaults(&d);
        sopt.stop = res->options.motion_filter > 0 || d.stop != CSI_SPARSA_STOP_GAP ? CSI_STOP_OBJECTIVE
                                                                                     : CSI_STOP_GAP;
    }
    res->options.stop = sopt.stop;
    if (s == CSI_OK)
        s = csi_solver_create(st->A, &st->solver);
    /* Reweighted l1 (motion_reweight.c): its own solver on A G, the first solve staying the
     * plain one on A. */
    csi_motion_reweight *rw = NULL;
    if (s == CSI_OK && opt->motion_reweight > 0)
        s = csi_motion_reweight_create(st->A, &rw);

    csi_nc_op rnc;
    memset(&rnc, 0, sizeof rnc);
    float *yhost = NULL;
    if (s == CSI_OK && correct) {
        yhost = malloc(n * sizeof *yhost);
        if (!yhost)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        const double sig = opt->motion_resid_sigma;
        if (s == CSI_OK && moved) {
            /* along the basis's motion, mirrored at the ends of t with the DCT (the time
             * transform motion_basis chose); its scratch
             * spectrum is the coefficients, free whenever the correction runs (before the solve
             * and after the synthesis) */
            const double sig_t = opt->motion_resid_sigma_t > 0 ? opt->motion_resid_sigma_t : sig;
            /* A cell whose filtered density is below 1e-3 of one sample's peak weight (no
             * sample within 3.7 widths) gets no correction: there the density is within a few
             * hundred float32 roundings of the FFT's sum, and a ratio of two such numbers is
             * noise (measured: at widths below a cell, 1e-6 let it blow the image up 6-20x). */
            const float eps = (float)(1e-3 / (pow(2 * 3.14159265358979323846, 1.5) * sig * sig * sig_t));
            s = csi_motion_filter_set(G, transform_of(res->options.motion_time), sig, sig_t);
            if (s == CSI_OK) {
                s = csi_nc_init_filter(ctx, g, st->idx, n, G, eps, real_y, scratch, yhost, &rnc);
                G = NULL; /* rnc's now */
            }
        } else if (s == CSI_OK) {
            s = csi_nc_init(ctx, g, st->idx, n, sig, real_y, scratch, yhost, &rnc);
        }
    }
    /* By default (and with BLEND) the volume is projected onto the range of the samples around
     * each pixel, so that no value, frame or image, leaves what the samples saw (non-negative
     * samples give non-negative frames). With a sheared basis the neighbourhood is taken in
     * the frame that moves with it (motion_range.c: over all t, a pixel's own neighbourhood
     * bounds its cells only where the picture is still). The per-pixel blend of the image with
     * the pixels' own samples is applied only on request (--correct blend): with the few
     * samples a pixel gets over t at these rates the fit's image was better than the blend (the
     * image MSE of tests/e2e/test_quality_motion.c's scene went from below to 2x above a tuned
     * Gaussian's: the blend moves towards the pixel's sample mean, which sees a mover at a few
     * frames only); pixels whose every cell is sampled take their exact mean. Sr gathers the
     * volume at the samples. */
    const bool blend = opt->correct == CSI_CORRECT_AUTO || opt->correct == CSI_CORRECT_BLEND;
    const bool sheared = moved && (res->options.motion_vx != 0 || res->options.motion_vy != 0);
    /* With a still basis (the default's choice over a still background, whatever moves on it)
     * the image is then corrected with each pixel's own samples, the fit as their control
     * variate (motion_correct.c): the fit of small movers and of a still texture at a few
     * percent of the cells is where the samples know better. With a sheared basis the fit
     * follows the motion, and the correction measured worse (a pan at 3%: 1.47x the image MSE
     * without it; docs/bench/animation.md). */
    const bool own = opt->correct == CSI_CORRECT_AUTO && !sheared;
    /* the per-pixel steps' cells per pixel are the shutter's (a padded volume's other frames
     * hold no sample) */
    csi_grid shutter = *g;
    if (opt->shutter_frames && opt->shutter_frames < g->t)
        shutter.t = opt->shutter_frames;
    csi_linop *Sr = NULL;
    float *fine_at = NULL;
    if (s == CSI_OK && opt->correct != CSI_CORRECT_NONE) /* AUTO too: the plan counts it (csi/plan.h) */
        s = csi_sampling_create(ctx, k, st->idx, n, false, &Sr);
    if (s == CSI_OK && own && !(fine_at = malloc(n * sizeof *fine_at)))
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the volume at %zu samples", n);
    /* With a still basis the range that bounds the volume and the corrected image, per channel
     * (sample_range.c), from what each pixel's samples say (px, which the move towards their
     * means reads too), from each sample's pixel */
    size_t *pix = NULL;
    float *range = NULL, *cell_range = NULL;
    csi_px_values *px = NULL;
    /* Where the samples say little moves (the tenth's rule above; noisy samples by a stricter
     * share of motion, internal.h), the volume's cells are bounded by the samples of the 3 x 3
     * cells around each (over all t) rather than of the 3 x 3 pixels: with several cells a
     * pixel, a pixel's window spans 6 x 6 to 12 x 12 cells, and a still light's samples in one
     * pixel let the fit keep it, at the frames no sample saw, in cells a pixel or two away whose
     * own neighbours never saw it (a lantern's glow in the dark pixel beside it). At one sample
     * a cell over the shutter, 3 x 3 cells hold about as many samples as 3 x 3 pixels did on the
     * pixel grid the bound was made for. */
    const bool by_cells = little_moves; /* decided on 2 x 2 cells a pixel or more only */
    if (s == CSI_OK && blend && !sheared) {
        pix = malloc((n ? n : 1) * sizeof *pix);
        range = malloc(2 * np * sizeof *range);
        px = malloc((np ? np : 1) * sizeof *px);
        if (by_cells)
            cell_range = malloc(2 * (size_t)g->w * g->h * sizeof *cell_range);
        if (!pix || !range || !px || (by_cells && !cell_range))
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the sample range of %zu pixels", np);
        const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
        for (size_t i = 0; s == CSI_OK && i < n; i++)
            pix[i] = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
    }
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();

    double t_solve = 0, t_int = 0;
    for (uint32_t c = 0; c < channels && s == CSI_OK; c++) {
        bool copied = false;
        s = csi_recon_channel_begin(st, opt, res, values, n, channels, c, &copied);
        if (s != CSI_OK || copied)
            continue; /* the loop ends on a failure */
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
        double t0 = csi_recon_now();
        /* A tile scales tau by the whole volume's DC coefficient rescaled to its own cells and
         * samples (csi_tile_scope): n mean / sqrt(k), the tile's DC had its mean been the
         * whole's. */
        double tau_scale = st->scope && st->scope->has_scale
                               ? (double)n * fabs(st->scope->scale[c]) / sqrt((double)k) : 0;
        /* The reweighted l1's re-solves keep the first solve's tau (the unweighted operator's). */
        if (s == CSI_OK && rw && !still_weighted && tau_scale == 0)
            s = csi_solver_adjoint_amax(st->solver, st->y, &tau_scale);
        /* With the still layer weighted, tau is relative to ||A^H y||_inf of the unweighted
         * operator, so that the weight moves that layer's threshold and no other. */
        if (s == CSI_OK && still_weighted && tau_scale == 0) {
            s = csi_half_fourier_set_still_gain(st->A, 1.0);
            if (s == CSI_OK)
                s = csi_solver_adjoint_amax(st->solver, st->y, &tau_scale);
            if (s == CSI_OK)
                s = csi_half_fourier_set_still_gain(st->A, 1.0 / still_weight);
        }
        /* Samples with variances: tau_rel at least CSI_MOTION_TAU_NOISE times their noise
         * relative to their level, at most CSI_MOTION_TAU_NOISE_MAX, over sqrt(n)
         * (csi/reconstruct.h); the whole problem's noise in a tile, which scales it by its own
         * level as it scales tau. */
        const double noise_rel =
            fmin(CSI_MOTION_TAU_NOISE * opt->sample_noise[c], CSI_MOTION_TAU_NOISE_MAX) / sqrt((double)n);
        if (s == CSI_OK && noise_rel > opt->tau_rel) {
            if (tau_scale == 0)
                s = csi_solver_adjoint_amax(st->solver, st->y, &tau_scale);
            tau_scale *= noise_rel / opt->tau_rel;
        }
        if (s == CSI_OK)
            s = csi_recon_run_solver(st, &sopt, tau_scale, &res->report[c]);
        if (s == CSI_OK && rw)
            s = csi_motion_reweight_run(rw, st, &sopt, tau_scale, &res->report[c]);
        if (s == CSI_OK)
            s = csi_finish(ctx);
        double t1 = csi_recon_now();
        t_solve += t1 - t0;
        if (s == CSI_OK)
            s = csi_recon_progress_channel(opt, "integrate", c, channels);
        if (half) {
            if (s == CSI_OK)
                s = csi_half_fourier_synthesize(st->A, st->x, st->tmp); /* f = H z, real */
        } else {
            if (s == CSI_OK)
                s = csi_linop_apply(st->Psi, st->x, st->f);
            if (s == CSI_OK)
                s = CSI_ARGS(c2r, CSI_MEM(st->f), CSI_MEM(st->tmp), CSI_ARG(nk));
            if (s == CSI_OK)
                s = csi_run1d(ctx, c2r, k); /* f = Re(F3^H x) */
        }
        if (s == CSI_OK && correct)
            s = csi_nc_correct(ctx, &rnc, st->plane, n, k, st->tmp, real_y, scratch, yhost);
        if (s == CSI_OK && range) {
            float all[2];
            csi_recon_pixel_values(g->out_w, g->out_h, pix, values, channels, c, n, px, all);
            s = csi_recon_value_ranges(g->out_w, g->out_h, px, all, range);
            if (s == CSI_OK && cell_range)
                s = csi_recon_cell_ranges(g, pos, values, channels, c, n, range, cell_range);
        }
        if (s == CSI_OK && blend)
            s = csi_recon_motion_range_clamp(ctx, g, values, channels, c, pos, n, sheared ? res->options.motion_vx : 0,
                                             sheared ? res->options.motion_vy : 0, moved, range, cell_range, st->tmp);
        if (s == CSI_OK)
            s = csi_recon_integrate_volume(ctx, g, st->tmp, c, opt, res, mean, st->out);
        if (s == CSI_OK && own)
            s = csi_linop_apply(Sr, st->tmp, real_y);
        if (s == CSI_OK && own)
            s = csi_read(ctx, real_y, 0, n * sizeof *fine_at, fine_at);
        if (s == CSI_OK && own && st->fit) { /* a time window: the whole shutter's image is corrected */
            memcpy(st->fit->at + (size_t)c * n, fine_at, n * sizeof *fine_at);
            st->fit->kept = true;
        } else if (s == CSI_OK && own) {
            const bool exact = (opt->sample_flags & CSI_SAMPLES_EXACT) != 0;
            s = csi_recon_motion_correct(&shutter, values, channels, c, pos, fine_at, n, range, exact,
                                         res->image + (size_t)c * np);
            if (s == CSI_OK && !exact)
                s = toward_mean(ctx, &shutter, st->tmp, scratch, px, res->image + (size_t)c * np);
        }
        if (s == CSI_OK && blend)
            csi_recon_exact_full(&shutter, values, channels, c, pos, n, res->image + (size_t)c * np);
        if (s == CSI_OK && (opt->correct == CSI_CORRECT_BLEND || opt->correct == CSI_CORRECT_CV))
            s = csi_recon_correct(ctx, &shutter, opt, opt->correct, Sr, st->tmp, real_y, values,
                                  channels, c, pos, n,
                                  opt->correct == CSI_CORRECT_BLEND && csi_recon_nonneg(values, channels, c, n),
                                  res->image + (size_t)c * np);
        res->t_channel_integrate[c] = csi_recon_now() - t1;
        t_int += res->t_channel_integrate[c];
    }
    /* The pixels a still picture's exact samples show still (still_samples.c), last: their
     * samples' value, which is their mean over t. A time window whose image the whole shutter's
     * correction redoes leaves them to the blend (csi_tiles_end). */
    if (s == CSI_OK && blend && !(own && st->fit))
        s = csi_recon_still_pixels(&shutter, values, channels, pos, n, res->image);
    csi_nc_free(&rnc);
    csi_motion_reweight_free(rw);
    csi_linop_free(G);
    csi_linop_free(Sr);
    free(fine_at);
    free(pix);
    free(range);
    free(cell_range);
    free(px);
    free(yhost);
    csi_buffer_release(&mean);
    csi_buffer_release(&real_y);
    CSI_TRY(s);
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    CSI_TRY(csi_recon_check_finite(res->image, np * channels, "image"));
    if (opt->frames)
        CSI_TRY(csi_recon_check_finite(res->frames, np * channels * T, "frames"));
    return CSI_OK;
}
