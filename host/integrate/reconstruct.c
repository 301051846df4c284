/* Alg. 1 and Alg. 2 of Sen & Darabi 2010 on the device: check the inputs, dispatch to the method,
 * release everything. See csi/reconstruct.h. */
#include "csi/reconstruct.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/empty_pixels.h"
#include "csi/frames_denoise.h"
#include "csi/peak_noise.h"
#include "csi/settle.h"
#include "csi/step_coverage.h"
#include "internal.h"

void csi_recon_state_free(csi_recon_state *st)
{
    csi_solver_free(st->solver);
    csi_linop_free(st->A); /* owns S and inner, which own the rest (see below) */
    if (!st->A) {
        csi_linop_free(st->S);
        csi_linop_free(st->inner);
    }
    csi_linop_free(st->Wbox);
    csi_linop_free(st->Ipix);
    csi_recon_coarse_free(st->coarse);
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

csi_status csi_recon_check_sizes(const csi_grid *g, uint32_t channels, size_t n)
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
    return CSI_OK;
}

static csi_status check_inputs(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                               const float *values, size_t n)
{
    CSI_TRY(csi_recon_check_sizes(g, channels, n));
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

static csi_status check_options(const csi_recon_options *opt)
{
    if (!(opt->lambda > 0) || !isfinite(opt->lambda))
        return csi_fail(CSI_ERR_ARG, "lambda must be a finite number > 0 (got %g)", (double)opt->lambda);
    if (!(opt->sigma_scale > 0) || !isfinite(opt->sigma_scale))
        return csi_fail(CSI_ERR_ARG, "sigma scale must be a finite number > 0 (got %g)", opt->sigma_scale);
    if (opt->image_frames == CSI_SWITCH_ON && opt->frames_denoise == CSI_SWITCH_OFF)
        return csi_fail(CSI_ERR_ARG, "image-frames on averages the image with the frames frames-denoise gives: "
                        "not with frames-denoise off");
    return CSI_OK;
}

csi_status csi_recon_check_variance(const float *variance, size_t n, uint32_t channels)
{
    for (size_t i = 0; variance && i < n * channels; i++)
        if (!(variance[i] >= 0) || !isfinite(variance[i]))
            return csi_fail(CSI_ERR_ARG, "sample %zu channel %zu: variance %g is not a finite number >= 0",
                            i / channels, i % channels, (double)variance[i]);
    return CSI_OK;
}

/* A step on a whole reconstruction's result (internal.h: csi_recon_cv_select and its kind). */
typedef csi_status (*whole_step)(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                 const float *values, size_t n, const csi_recon_options *opt,
                                 csi_recon_result *out);

/* A fold of the frames' step (csi/frames_denoise.h): its samples' channels' mean solved as the
 * whole was (the options csi_frames_fold_options makes, the mean's variances), for its frames
 * alone. */
typedef struct {
    csi_ctx *ctx;
    const csi_grid *grid;
    uint32_t channels;
    const csi_sample_pos *pos;
    const float *values;
    csi_recon_options opt;
    unsigned solved; /* folds solved so far: the progress's "frames fold 1" and "2" */
} frames_fold;

/* A fold's phases for the caller's progress callback: "frames fold 1 solve 2/3" and so on. */
static bool on_fold_progress(void *user, const char *phase, int iter, double res)
{
    const frames_fold *f = user;
    char name[64];
    snprintf(name, sizeof name, "frames fold %u %s", f->solved + 1, phase);
    return f->opt.progress(f->opt.user, name, iter, res);
}

static csi_status frames_fold_solve(void *user, const size_t *index, size_t count, double noise, float **frames,
                                    double vel[2])
{
    (void)noise; /* csi_recon takes it from the fold's variances, as the whole's from its own */
    frames_fold *f = user;
    const float *var = f->opt.sample_variance;
    csi_sample_pos *p = malloc(count * sizeof *p);
    float *v = malloc(count * sizeof *v), *vv = var ? malloc(count * sizeof *vv) : NULL;
    if (!p || !v || (var && !vv)) {
        free(p), free(v), free(vv);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a fold of %zu samples", count);
    }
    for (size_t j = 0; j < count; j++)
        p[j] = f->pos[index[j]];
    csi_frames_fold_samples(f->values, var, f->channels, index, count, v, vv);
    csi_recon_options o = f->opt;
    o.sample_variance = vv;
    if (f->opt.progress) {
        o.progress = on_fold_progress;
        o.user = f;
    }
    csi_recon_result r;
    csi_status s = csi_recon(f->ctx, f->grid, 1, p, v, count, &o, &r);
    free(p), free(v), free(vv);
    f->solved++;
    CSI_TRY(s);
    *frames = r.frames;
    r.frames = NULL;
    vel[0] = r.options.motion_vx;
    vel[1] = r.options.motion_vy;
    csi_recon_result_free(&r);
    return CSI_OK;
}

/* The frames of noisy samples on an untiled result (its frames_sigma -1 where it does not run). */
static csi_status frames_step(csi_ctx *ctx, const csi_grid *grid, uint32_t channels, const csi_sample_pos *pos,
                              const float *values, size_t n, const csi_recon_options *opt,
                              csi_recon_result *out)
{
    out->frames_sigma[0] = out->frames_sigma[1] = -1;
    if (grid->t == 1 || !out->nframes || !out->frames || out->options.tiles > 1 ||
        out->options.estimator != CSI_EST_CS || out->options.frames_denoise != CSI_SWITCH_ON)
        return CSI_OK;
    const double t0 = csi_recon_now();
    const double v[2] = {out->options.motion_vx, out->options.motion_vy}; /* the basis's, resolved */
    frames_fold fold = {ctx, grid, channels, pos, values, {0}, 0};
    csi_frames_fold_options(opt, out, &fold.opt);
    csi_status s = csi_frames_denoise(grid, out->nframes, channels, pos, values, n, opt->sample_noise, v,
                                      frames_fold_solve, &fold, out->frames, out->frames_sigma);
    if (s == CSI_OK && out->options.image_frames == CSI_SWITCH_ON)
        csi_frames_denoise_image(out->frames, out->nframes, channels, (size_t)out->out_w * out->out_h, out->image);
    out->t_frames = csi_recon_now() - t0;
    return s;
}

static csi_status recon(csi_ctx *ctx, const csi_grid *grid, uint32_t channels, const csi_sample_pos *pos,
                        const float *values, size_t n, csi_recon_options opt, csi_recon_result *out)
{
    CSI_TRY(check_options(&opt));
    CSI_TRY(check_inputs(grid, channels, pos, values, n));
    CSI_TRY(csi_recon_check_variance(opt.sample_variance, n, channels));
    if (grid->t > 1 && opt.frames && opt.estimator == CSI_EST_MEAN)
        return csi_fail(CSI_ERR_ARG, "the per-pixel mean (estimator mean) makes an image, not frames: frames need "
                        "the cs or gauss estimator");
    if (grid->t > 1) /* the whole's noise, before any scaling or tiling (motion.c's tau) */
        csi_recon_sample_noise(values, opt.sample_variance, n, channels, opt.sample_noise);
    /* The layout (csi_tiling_layout: what a tile run alone, --tile, lays out too). Sides the
     * transforms cannot take (internal.h): the padded grid, on which the samples' positions are
     * the same cells (it grows right and down), unless tiles of the image's own grid are laid out
     * and the padded whole would not fit either. */
    csi_tiling tl;
    CSI_TRY(csi_tiling_layout(ctx, grid, channels, n, &opt, &tl));
    CSI_TRY(csi_tiling_check_samples(&tl, pos, n));
    /* The image averaged with the denoised frames (image_frames) needs the frames, asked for or
     * not: made below, dropped by csi_recon when not asked for; time windows' tiles make their
     * own and give the blend their frames' mean (csi_recon_tile). */
    if (grid->t > 1 && !opt.frames && tl.n[2] == 1) {
        csi_recon_options r;
        CSI_TRY(csi_recon_resolve(&opt, grid, n, &r));
        opt.frames = r.image_frames == CSI_SWITCH_ON;
    }
    if (memcmp(&tl.grid, grid, sizeof *grid)) {
        const csi_grid padded = tl.grid;
        csi_recon_options po = opt;
        po.shutter_frames = grid->t; /* the later frames are padding: the image is the mean of these */
        if (padded.t != grid->t)
            po.tiles_t = 1; /* as csi_tiling_layout laid it out: no time windows over padding */
        /* the cross-validated image bins the whole solved shutter */
        csi_status ps = padded.t != grid->t && opt.motion_image_cv == CSI_SWITCH_ON
                            ? csi_fail(CSI_ERR_ARG, "--motion-image-cv bins the frames it solves, and %u frames are "
                                       "solved as %u", grid->t, padded.t)
                            : csi_recon(ctx, &padded, channels, pos, values, n, &po, out);
        if (ps == CSI_OK)
            ps = csi_recon_crop(out, grid->out_w, grid->out_h, grid->t);
        if (ps == CSI_OK)
            ps = frames_step(ctx, grid, channels, pos, values, n, &opt, out);
        if (ps == CSI_OK) {
            out->options.shutter_frames = 0; /* internal: not the result's */
            out->options.tiles_t = opt.tiles_t;
        }
        if (ps != CSI_OK) {
            csi_recon_result_free(out);
            return csi_recon_padded_fail(ps, grid, &padded);
        }
        return ps;
    }
    /* Any finite float32 reconstructs: a channel whose largest magnitude is far from 1 is solved
     * scaled by a power of two (exact), its result scaled back. */
    int e[4];
    float *scaled = NULL;
    CSI_TRY(csi_recon_scale_values(values, n, channels, csi_recon_scale_common(channels, &opt), e, &scaled));
    const float *v = scaled ? scaled : values;
    csi_status s;
    /* Each tile resolves its own autos (csi_recon_resolve_scoped); the whole's are reported. */
    if (tl.count > 1)
        s = csi_recon_tiled(ctx, grid, channels, pos, v, n, &opt, &tl, out);
    else
        s = csi_recon_scoped(ctx, grid, channels, pos, v, n, &opt, NULL, NULL, out);
    if (s == CSI_OK && (s = csi_recon_reported(&opt, &tl, n, &out->options, &out->options)) != CSI_OK)
        csi_recon_result_free(out);
    free(scaled);
    CSI_TRY(s);
    csi_recon_unscale_result(out, e);
    /* The steps on the whole result that need the whole image's (or volume's) samples: the
     * cross-validated choice (csi/cv_select.h), a volume's image chosen against binned solves'
     * (motion_image.c), then isolated peaks by the log fit (csi/peak_range.h), which comes after the
     * choice since the choice compares the blend with the mean and knows nothing of it. A tile (a
     * job of its own, csi/tiles.h) sees its window only: a tiled run's tiles made the choice in
     * their windows (tiled.c), and it goes without the other two (its options say off:
     * csi_recon_reported). */
    int cs = out->options.estimator == CSI_EST_CS && tl.count == 1;
    const struct {
        whole_step fn;
        csi_switch *on;
        int applies;
    } steps[] = {
        {csi_recon_cv_select, &out->options.cv_select, cs && grid->t == 1},
        {csi_recon_motion_image, &out->options.motion_image_cv, cs && grid->t > 1},
        {csi_recon_peak_range, &out->options.peak_range, cs && grid->t == 1},
    };
    for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++) {
        if (!steps[k].applies || *steps[k].on != CSI_SWITCH_ON)
            continue;
        s = steps[k].fn(ctx, grid, channels, pos, values, n, &opt, out);
        if (s != CSI_OK) {
            csi_recon_result_free(out);
            return s;
        }
    }
    /* Pixels without a sample next to an HDR step (csi/empty_pixels.h): on the blend's whole image, all
     * channels at once (the step is judged on their mean). A tiled run's tiles did it in their
     * windows (tiled.c), before the blend, as a tile run alone does. */
    if (grid->t == 1 && tl.count == 1 && out->options.estimator == CSI_EST_CS &&
        out->options.correct == CSI_CORRECT_BLEND) {
        s = csi_empty_pixels(grid, channels, pos, values, n, csi_ctx_row_pool(ctx), out->image);
        if (s != CSI_OK) {
            csi_recon_result_free(out);
            return s;
        }
    }
    /* Isolated peaks against their own noise (csi/peak_noise.h): last, so that a region the choice
     * gave its means loses its noisy peaks too. A tiled run's tiles did it in their windows
     * (tiled.c), before the blend, as a tile run alone does. */
    if (opt.sample_variance && grid->t == 1 && tl.count == 1 && out->options.estimator == CSI_EST_CS &&
        out->options.correct == CSI_CORRECT_BLEND) {
        s = csi_peak_noise(grid, channels, pos, values, opt.sample_variance, n, csi_ctx_row_pool(ctx), out->image,
                           NULL);
        if (s != CSI_OK) {
            csi_recon_result_free(out);
            return s;
        }
    }
    /* The pixels that decide the image settled on their samples' mean (csi/settle.h): last, on
     * the image every step before has made. A tiled run settles once, on the blended image, from
     * its tiles' pixel sums (tile_blend.c), as a merge of tiles run alone does. */
    if (grid->t == 1 && tl.count == 1 && out->options.estimator == CSI_EST_CS &&
        out->options.settle == CSI_SWITCH_ON) {
        s = csi_settle(grid, channels, pos, values, n, out->image, NULL, &out->settled);
        if (s != CSI_OK) {
            csi_recon_result_free(out);
            return s;
        }
    }
    /* An HDR step's pixels given the coverage their window's samples allow (csi/step_coverage.h):
     * after the settling, which puts them at their means, the step's own starting point. A tiled
     * run's tiles computed its changes in their windows (tiled.c), added after the blend's
     * settling (tile_blend.c), as a merge of tiles run alone does. */
    if (opt.sample_variance && grid->t == 1 && tl.count == 1 && out->options.step_coverage == CSI_SWITCH_ON) {
        s = csi_step_coverage(grid, channels, pos, values, opt.sample_variance, n, csi_ctx_row_pool(ctx),
                              out->image, &out->step_moved);
        if (s != CSI_OK) {
            csi_recon_result_free(out);
            return s;
        }
    }
    /* The frames of noisy samples (csi/frames_denoise.h), after every step of the image: the
     * whole volume's here; a padded run's after its crop (above); a tiled run's tiles did it in
     * their windows (tiled.c). */
    if (!opt.shutter_frames && (s = frames_step(ctx, grid, channels, pos, values, n, &opt, out)) != CSI_OK) {
        csi_recon_result_free(out);
        return s;
    }
    return CSI_OK;
}

csi_status csi_recon(csi_ctx *ctx, const csi_grid *grid, uint32_t channels, const csi_sample_pos *pos,
                     const float *values, size_t n, const csi_recon_options *opt_in,
                     csi_recon_result *out)
{
    memset(out, 0, sizeof *out);
    const csi_recon_options opt = csi_recon_options_or_defaults(opt_in);
    CSI_TRY(recon(ctx, grid, channels, pos, values, n, opt, out));
    if (!opt.frames && out->frames)
        csi_recon_result_drop_frames(out);
    return CSI_OK;
}

csi_status csi_recon_reported(const csi_recon_options *given, const csi_tiling *tl, size_t n,
                              const csi_recon_options *solved, csi_recon_options *out)
{
    if (tl->count > 1) {
        CSI_TRY(csi_recon_resolve(given, &tl->grid, n, out));
        /* the steps on the whole result: a tile sees its window only (csi_recon); the
         * cross-validated choice, if on, was made in the tiles' windows */
        csi_switch *steps[] = {&out->motion_image_cv, &out->peak_range};
        if (tl->grid.t > 1)
            out->cv_select = CSI_SWITCH_OFF;
        for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++)
            if (*steps[k] == CSI_SWITCH_ON)
                *steps[k] = CSI_SWITCH_OFF;
        out->tile_margin = tl->margin[0];
        if (tl->grid.t > 1)
            out->tile_margin_t = tl->margin[2];
        /* the binned shutter's image is not averaged with the frames (tiled.c) */
        if (out->image_frames == CSI_SWITCH_ON && csi_tiling_image_binned(tl, out))
            out->image_frames = CSI_SWITCH_OFF;
    } else if (out != solved) {
        *out = *solved;
    }
    out->sample_variance = NULL; /* the caller's array: not the result's */
    out->shutter_frames = 0;     /* internal (padding.c) */
    out->tiles_t = given->tiles_t;
    out->mem_budget = tl->budget;
    out->tiles = tl->count;
    return CSI_OK;
}

csi_status csi_recon_scoped(csi_ctx *ctx, const csi_grid *grid, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt_in, const csi_tile_scope *scope,
                            csi_recon_fit *fit, csi_recon_result *out)
{
    memset(out, 0, sizeof *out);
    csi_recon_options opt;
    CSI_TRY(csi_recon_resolve_scoped(opt_in, grid, n, scope, &opt));

    const size_t np = (size_t)grid->out_w * grid->out_h;
    out->out_w = grid->out_w;
    out->out_h = grid->out_h;
    out->channels = channels;
    out->k = (size_t)grid->w * grid->h * grid->t;
    out->unknowns = out->k;
    out->model_factor = 1;
    out->n = n;
    out->tiles = 1;
    out->options = opt;
    out->image = calloc(np * channels, sizeof(float));
    if (grid->t > 1 && opt.frames && opt.estimator != CSI_EST_MEAN) {
        out->nframes = grid->t;
        out->frames = calloc(np * channels * grid->t, sizeof(float));
    }
    if (!out->image || (out->nframes && !out->frames)) {
        csi_recon_result_free(out);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the output image");
    }
    csi_recon_state st;
    memset(&st, 0, sizeof st);
    st.scope = scope;
    st.fit = fit;
    double t0 = csi_recon_now();
    const double b0 = csi_ctx_build_seconds(ctx), c0 = csi_recon_cpu_now();
    csi_status s = csi_recon_progress(&opt, "setup");
    if (s == CSI_OK && opt.estimator != CSI_EST_MEAN) {
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
            s = csi_recon_sample_mean(ctx, grid, channels, pos, values, n, &opt, out, &st);
        else if (opt.estimator == CSI_EST_GAUSS)
            s = csi_recon_gauss_nc(ctx, grid, channels, pos, values, n, &opt, out, &st);
        else if (grid->t == 1)
            s = csi_recon_antialias(ctx, grid, channels, pos, values, n, &opt, out, &st);
        else
            s = csi_recon_motion(ctx, grid, channels, pos, values, n, &opt, out, &st);
    }
    out->t_setup = out->t_setup > t0 ? out->t_setup - t0 : 0;
    out->t_programs = csi_ctx_build_seconds(ctx) - b0;
    /* the methods set cpu_setup to the CPU clock when their setup ended */
    const double c1 = csi_recon_cpu_now();
    out->cpu_work = out->cpu_setup > c0 ? c1 - out->cpu_setup : 0;
    out->cpu_setup = out->cpu_setup > c0 ? out->cpu_setup - c0 : c1 - c0;
    csi_recon_state_free(&st);
    if (s != CSI_OK)
        csi_recon_result_free(out);
    return s;
}
