/* Reconstruction by tiles (csi/tiles.h): the whole problem's scope, one tile's problem (its
 * samples, its grid, its result), and the whole tiled run in this process (tile_blend.c blends). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/buffer_keep.h"
#include "csi/empty_pixels.h"
#include "csi/frames_denoise.h"
#include "csi/peak_noise.h"
#include "csi/settle.h"
#include "csi/step_coverage.h"
#include "csi/tiles.h"
#include "internal.h"

void csi_tile_result_free(csi_tile_result *t)
{
    if (t) {
        csi_recon_result_free(&t->r);
        free(t->resid);
        free(t->px_cnt);
        free(t->px_sum);
        free(t->step_delta);
        free(t->frames_mean);
        t->resid = NULL;
        t->px_cnt = NULL;
        t->px_sum = NULL;
        t->step_delta = NULL;
        t->frames_mean = NULL;
    }
}

/* The tile's own problem: its grid and the samples inside its window, shifted to its origin
 * (and their variances, when the caller has them). */
typedef struct {
    csi_grid g;
    csi_tile tile;
    uint32_t lo[3], hi[3]; /* the window in the whole grid's cells: [lo, hi) in x, y, t */
    csi_sample_pos *pos;
    float *values;
    float *variance;
    size_t n;
} tile_problem;

static bool in_window(const tile_problem *p, csi_sample_pos q)
{
    return q.x >= p->lo[0] && q.x < p->hi[0] && q.y >= p->lo[1] && q.y < p->hi[1] && q.t >= p->lo[2] &&
           q.t < p->hi[2];
}

static void tile_problem_free(tile_problem *p)
{
    free(p->pos);
    free(p->values);
    free(p->variance);
    p->pos = NULL;
    p->values = NULL;
    p->variance = NULL;
}

/* The window's variances (one per value, in the order of p's samples) into p: apart from its
 * samples so that a caller holds them only while it needs them. */
static csi_status tile_problem_add_variance(tile_problem *p, uint32_t index, uint32_t channels,
                                            const csi_sample_pos *pos, const float *variance, size_t n)
{
    if (!(p->variance = malloc((p->n ? p->n : 1) * channels * sizeof *p->variance)))
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the variances of the %zu samples of tile %u", p->n,
                        index);
    for (size_t i = 0, j = 0; i < n; i++)
        if (in_window(p, pos[i]))
            memcpy(p->variance + j++ * channels, variance + i * channels, channels * sizeof(float));
    return CSI_OK;
}

/* Without the variances (tile_problem_add_variance adds them). */
static csi_status tile_problem_make(const csi_tiling *tl, uint32_t index, uint32_t channels,
                                    const csi_sample_pos *pos, const float *values, size_t n, tile_problem *p)
{
    memset(p, 0, sizeof *p);
    if (index >= tl->count)
        return csi_fail(CSI_ERR_ARG, "tile %u of a layout of %u tiles", index, tl->count);
    csi_tiling_tile(tl, index, &p->tile);
    const csi_grid *G = &tl->grid;
    const uint32_t cells_per[3] = {G->w / G->out_w, G->h / G->out_h, 1}; /* a window unit in cells */
    for (int a = 0; a < 3; a++) {
        p->lo[a] = p->tile.win0[a] * cells_per[a];
        p->hi[a] = p->lo[a] + tl->window[a] * cells_per[a];
    }
    p->g = (csi_grid){.w = p->hi[0] - p->lo[0], .h = p->hi[1] - p->lo[1], .t = p->hi[2] - p->lo[2],
                      .out_w = tl->window[0], .out_h = tl->window[1]};
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += in_window(p, pos[i]);
    p->pos = malloc((m ? m : 1) * sizeof *p->pos);
    p->values = malloc((m ? m : 1) * channels * sizeof *p->values);
    if (!p->pos || !p->values) {
        tile_problem_free(p);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the %zu samples of tile %u", m, index);
    }
    for (size_t i = 0; i < n; i++) {
        const csi_sample_pos q = pos[i];
        if (in_window(p, q)) {
            p->pos[p->n] = (csi_sample_pos){q.x - p->lo[0], q.y - p->lo[1], q.t - p->lo[2]};
            memcpy(p->values + p->n * channels, values + i * channels, channels * sizeof(float));
            p->n++;
        }
    }
    return CSI_OK;
}

void csi_tile_scope_init(const csi_grid *g, uint32_t channels, size_t n, csi_tile_scope *out)
{
    memset(out, 0, sizeof *out);
    out->k = (uint64_t)g->w * g->h * g->t;
    out->n = n;
    out->out_w = g->out_w;
    out->out_h = g->out_h;
    out->channels = channels;
}

static csi_status scope_make(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                             const float *values, size_t n, const csi_recon_options *opt, const csi_tiling *tl,
                             csi_tile_scope *out);

/* Samples far from magnitude 1 are scaled as csi_recon scales them (result.c), so that a tile
 * run alone (--tile I/N) solves what the same tile of csi_recon solves, and the scope's tau
 * scales are in the units the tiles see. */
csi_status csi_tile_scope_make(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                               const csi_sample_pos *pos, const float *values, size_t n,
                               const csi_recon_options *opt, const csi_tiling *tl,
                               csi_tile_scope *out)
{
    int e[4];
    float *scaled = NULL;
    CSI_TRY(csi_recon_scale_values(values, n, channels, csi_recon_scale_common(channels, opt), e, &scaled));
    csi_status s = scope_make(ctx, g, channels, pos, scaled ? scaled : values, n, opt, tl, out);
    free(scaled);
    return s;
}

static csi_status scope_make(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                             const float *values, size_t n, const csi_recon_options *opt, const csi_tiling *tl,
                             csi_tile_scope *out)
{
    csi_tile_scope_init(g, channels, n, out);
    if (opt->estimator != CSI_EST_CS || channels > 4)
        return CSI_OK;
    if (g->t > 1) {
        for (uint32_t c = 0; c < channels; c++) {
            double sum = 0;
            for (size_t i = 0; i < n; i++)
                sum += values[i * channels + c];
            out->scale[c] = n ? sum / (double)n : 0;
        }
        out->has_scale = true;
        return CSI_OK;
    }
    if (opt->solver == CSI_SOLVER_ROMP)
        return CSI_OK; /* ROMP has no tau */
    csi_recon_options o = *opt;
    o.levels = tl->levels;
    for (uint32_t i = 0; i < tl->count; i++) {
        /* one adjoint per tile: with many tiles a long pass, heard from (and cancelled) per tile */
        CSI_TRY(csi_recon_progress_step(opt, "tile scale", (int)i));
        tile_problem p;
        CSI_TRY(tile_problem_make(tl, i, channels, pos, values, n, &p));
        double sc[4] = {0, 0, 0, 0};
        csi_status s = CSI_OK;
        if (p.n > 0) {
            csi_recon_state st;
            memset(&st, 0, sizeof st);
            csi_tile_scope whole = *out; /* the filter follows the whole's cells per sample */
            st.scope = &whole;
            csi_recon_options ro;
            s = csi_recon_resolve_scoped(&o, &p.g, p.n, &whole, &ro);
            st.idx = malloc(p.n * sizeof *st.idx);
            st.plane = malloc(p.n * sizeof *st.plane);
            if (!st.idx || !st.plane)
                s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the %zu samples of tile %u", p.n, i);
            for (size_t j = 0; j < p.n && s == CSI_OK; j++)
                st.idx[j] = (uint32_t)csi_grid_index(&p.g, p.pos[j]);
            if (s == CSI_OK)
                s = csi_recon_antialias_scale(ctx, &p.g, channels, p.values, p.n, &ro, &st, sc);
            csi_recon_state_free(&st);
        }
        tile_problem_free(&p);
        CSI_TRY(s);
        for (uint32_t c = 0; c < channels; c++)
            if (sc[c] > out->scale[c])
                out->scale[c] = sc[c];
    }
    out->has_scale = true;
    return CSI_OK;
}

static csi_status reconstruct_tile(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                   const csi_sample_pos *pos, const float *values, size_t n,
                                   const csi_recon_options *opt, const csi_tiling *tl,
                                   const csi_tile_scope *scope, uint32_t index, csi_tile_result *out);

/* The steps an untiled run of noisy samples takes after its blend (reconstruct.c), in a tile's
 * window, in the same order, on the window's samples as given (unscaled, like the tile's result
 * by now), made once for all three:
 * - the cross-validated choice (csi/cv_select.h): its folds are the window's samples, split as the
 *   whole image's are (a sample's fold depends on its own pixel only), each reconstructed as the
 *   window's one problem; its regions are the whole image's, cut at the window's sides. A region
 *   wholly inside the window is decided on the same samples as in the untiled run, though by folds
 *   of the window rather than of the whole;
 * - pixels without a sample next to an HDR step (csi/empty_pixels.h): the rule looks two pixels
 *   around a pixel (its neighbours and theirs), and a pixel a tile contributes with a weight above
 *   0 lies at least half the margin (2 pixels with the automatic margins) inside its window, so it
 *   is judged on the same neighbours' samples as the whole image's would be (only the rule's
 *   floor, 1% of the samples' mean absolute value, is the window's, as the blend's is in a tile);
 * - isolated peaks against their own noise (csi/peak_noise.h), given the samples' variances: the
 *   rule looks one pixel around a pixel, and a tile's core lies margin pixels inside its window, so
 *   every pixel a tile's core contributes is judged as the whole image's would be;
 * - the pixels that decide the image settled on their means (csi/settle.h): not here but on the
 *   blended image (csi_tiles_end), from the sums of its core's pixels the tile gives
 *   (csi_tile_result).
 * - an HDR step's pixels given the coverage their window's samples allow (csi/step_coverage.h),
 *   given the samples' variances: its changes of the core's pixels, from their 3 x 3 pixels'
 *   samples (inside the window) and the whole image's mean sample, added after the settling on
 *   the blended image (csi_tiles_end), as untiled.
 * Tiles run alone (--tile I/N) and merged give the same bits as csi_recon's own tiles. */
static csi_status tile_noisy_steps(csi_ctx *ctx, const csi_tiling *tl, uint32_t index, uint32_t channels,
                                   const csi_sample_pos *pos, const float *values, size_t n,
                                   const csi_recon_options *opt, csi_tile_result *out)
{
    csi_recon_result *r = &out->r;
    const bool choice = r->options.cv_select == CSI_SWITCH_ON; /* asked for with any correction, as untiled */
    const bool blend = r->options.correct == CSI_CORRECT_BLEND;
    if (tl->grid.t != 1 || r->options.estimator != CSI_EST_CS || !(choice || blend))
        return CSI_OK;
    /* the variances only after the choice: its folds' solves are the tile's peak of memory */
    tile_problem p;
    CSI_TRY(tile_problem_make(tl, index, channels, pos, values, n, &p));
    csi_status s = CSI_OK;
    /* the tile's core in its window's pixels: what its counts of pixels changed cover */
    const uint32_t core[4] = {p.tile.core0[0] - p.tile.win0[0], p.tile.core0[1] - p.tile.win0[1],
                              p.tile.core1[0] - p.tile.win0[0], p.tile.core1[1] - p.tile.win0[1]};
    if (choice) {
        csi_recon_options o = *opt;
        o.tiles = 1; /* a fold is the window's problem, whatever the layout asked of the whole */
        s = csi_recon_cv_select_at(ctx, &p.g, p.tile.win0[0], p.tile.win0[1], core, channels, p.pos, p.values, p.n,
                                   &o, r);
    }
    if (s == CSI_OK && blend && opt->sample_variance)
        s = tile_problem_add_variance(&p, index, channels, pos, opt->sample_variance, n);
    if (s == CSI_OK && blend)
        s = csi_empty_pixels(&p.g, channels, p.pos, p.values, p.n, csi_ctx_row_pool(ctx), r->image);
    if (s == CSI_OK && p.variance)
        s = csi_peak_noise(&p.g, channels, p.pos, p.values, p.variance, p.n, csi_ctx_row_pool(ctx), r->image, NULL);
    if (s == CSI_OK && r->options.settle == CSI_SWITCH_ON) {
        const size_t np = (size_t)p.g.out_w * p.g.out_h;
        out->px_cnt = calloc(np ? np : 1, sizeof *out->px_cnt);
        out->px_sum = calloc(np ? np * channels : 1, sizeof *out->px_sum);
        if (!out->px_cnt || !out->px_sum)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the pixel sums of tile %u", index);
        else
            csi_pixel_sums_add(&p.g, channels, p.pos, p.values, p.n, core, out->px_cnt, out->px_sum);
    }
    if (s == CSI_OK && p.variance && r->options.step_coverage == CSI_SWITCH_ON) {
        const size_t w = p.g.out_w, np = w * p.g.out_h;
        if (!(out->step_delta = malloc((np ? np * channels : 1) * sizeof *out->step_delta)))
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the HDR step's changes of tile %u", index);
        else
            s = csi_step_coverage_delta(&p.g, channels, p.pos, p.values, p.variance, p.n,
                                        csi_step_coverage_mean(values, n, channels), csi_ctx_row_pool(ctx),
                                        out->step_delta, NULL);
        for (size_t c = 0; s == CSI_OK && c < channels; c++) /* the core's pixels only: each lies in one core */
            for (size_t q = 0; q < np; q++)
                if (q % w < core[0] || q / w < core[1] || q % w >= core[2] || q / w >= core[3])
                    out->step_delta[c * np + q] = 0.0f;
    }
    tile_problem_free(&p);
    return s;
}

/* A fold of a window's frames' step (csi/frames_denoise.h): the window's samples of the fold, at
 * their cells in the whole grid, solved as the tile is (csi_recon_tile), for its frames alone. */
typedef struct {
    csi_ctx *ctx;
    const csi_tiling *tl;
    const csi_tile_scope *scope;
    uint32_t index, channels;
    const tile_problem *p;
    csi_recon_options opt; /* csi_frames_fold_options */
} tile_fold;

static csi_status tile_fold_solve(void *user, const size_t *index, size_t count, double noise, float **frames,
                                  double vel[2])
{
    const tile_fold *f = user;
    const uint32_t C = f->channels, bw = f->tl->grid.w / f->tl->grid.out_w, bh = f->tl->grid.h / f->tl->grid.out_h;
    csi_sample_pos *p = malloc(count * sizeof *p);
    float *v = malloc(count * sizeof *v);
    if (!p || !v) {
        free(p), free(v);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a fold of %zu samples", count);
    }
    for (size_t j = 0; j < count; j++) {
        const csi_sample_pos q = f->p->pos[index[j]];
        p[j] = (csi_sample_pos){q.x + f->p->tile.win0[0] * bw, q.y + f->p->tile.win0[1] * bh, q.t + f->p->tile.win0[2]};
    }
    csi_frames_fold_samples(f->p->values, NULL, C, index, count, v, NULL);
    /* One channel, the channels' mean: the whole's figures for it. Alg. 2's scale is a channel's
     * mean sample (csi/tiles.h), so the mean's is the mean of the channels' (0, unknown, if any is);
     * its noise is the fold's (a tile's solve reads the noise from its options). */
    csi_tile_scope scope = *f->scope;
    csi_recon_options o = f->opt;
    if (C > 1) {
        double sum = 0;
        bool known = true;
        for (uint32_t c = 0; c < C && c < 4; c++) {
            sum += f->scope->scale[c];
            known = known && f->scope->scale[c] != 0;
        }
        memset(scope.scale, 0, sizeof scope.scale);
        scope.scale[0] = known ? sum / C : 0;
        memset(o.sample_noise, 0, sizeof o.sample_noise);
        o.sample_noise[0] = noise;
    }
    scope.channels = 1;
    csi_tile_result r;
    csi_status s = csi_recon_tile(f->ctx, &f->tl->grid, 1, p, v, count, &o, f->tl, &scope, f->index, &r);
    free(p), free(v);
    CSI_TRY(s);
    *frames = r.r.frames;
    r.r.frames = NULL;
    vel[0] = r.r.options.motion_vx;
    vel[1] = r.r.options.motion_vy;
    csi_tile_result_free(&r);
    return CSI_OK;
}

/* A time window's share of the mean over t of its frames (t->r.frames): sum_t w_t(t) frame(t) / T,
 * in frame order, into dst (channels planar, as the image). Its image's share (reconstruct_tile)
 * and its denoised frames' (csi_tile_result.frames_mean). */
static void window_share(const csi_tiling *tl, const csi_tile_result *t, float *dst)
{
    const csi_recon_result *r = &t->r;
    const size_t np = (size_t)r->out_w * r->out_h;
    csi_tile tile;
    csi_tiling_tile(tl, t->index, &tile);
    for (uint32_t c = 0; c < r->channels; c++)
        for (size_t q = 0; q < np; q++) {
            double acc = 0;
            for (uint32_t f = 0; f < r->nframes; f++)
                acc += csi_tile_weight(tl, &tile, 2, t->t0 + f) * r->frames[((size_t)f * r->channels + c) * np + q];
            dst[(size_t)c * np + q] = (float)(acc / tl->grid.t);
        }
}

/* The frames of noisy samples (csi/frames_denoise.h) in a tile's window, on the window's samples
 * as given, as an untiled run does on the whole volume's (reconstruct.c): after the window's
 * share of the image was taken from its frames (reconstruct_tile). A window's frames past the
 * shutter's (padding) are left out. The image's average with the frames' mean (image_frames):
 * a window over the whole shutter averages its own image, as an untiled run does; a time
 * window's image is corrected over the whole shutter after the blend (the residual sums), so it
 * gives its share of the frames' mean for the blend to average with after that. */
static csi_status tile_frames_step(csi_ctx *ctx, const csi_tiling *tl, const csi_tile_scope *scope, uint32_t index,
                                   uint32_t channels, const csi_sample_pos *pos, const float *values, size_t n,
                                   const csi_recon_options *opt, bool frames_asked, csi_tile_result *out)
{
    csi_recon_result *r = &out->r;
    if (tl->grid.t == 1 || !opt->frames || !r->nframes || !r->frames || r->options.estimator != CSI_EST_CS ||
        r->options.frames_denoise != CSI_SWITCH_ON || out->t0 >= tl->image_t)
        return CSI_OK;
    const uint32_t valid = tl->image_t - out->t0 < r->nframes ? tl->image_t - out->t0 : r->nframes;
    /* the image's average (image_frames): a window over the whole shutter's, or a time window's
     * share (not with the binned shutter's image, whose windows' frames are not its image's) */
    const bool ifr = r->options.image_frames == CSI_SWITCH_ON;
    const bool split_t = tl->n[2] > 1, share = ifr && split_t && !csi_tiling_image_binned(tl, opt);
    const bool image = ifr && !split_t && out->t0 == 0 && valid == tl->image_t;
    if (!frames_asked && !image && !share)
        return CSI_OK; /* frames made only for an image that does not take them */
    tile_problem p;
    CSI_TRY(tile_problem_make(tl, index, channels, pos, values, n, &p));
    const double v[2] = {r->options.motion_vx, r->options.motion_vy}; /* the window's basis's */
    tile_fold fold = {ctx, tl, scope, index, channels, &p, {0}};
    csi_frames_fold_options(opt, r, &fold.opt);
    csi_status s = csi_frames_denoise(&p.g, valid, channels, p.pos, p.values, p.n, opt->sample_noise, v,
                                      tile_fold_solve, &fold, r->frames, NULL);
    tile_problem_free(&p);
    if (s == CSI_OK && image)
        csi_frames_denoise_image(r->frames, valid, channels, (size_t)r->out_w * r->out_h, r->image);
    if (s == CSI_OK && share &&
        !(out->frames_mean = malloc((size_t)r->out_w * r->out_h * channels * sizeof *out->frames_mean)))
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the frames' mean of tile %u", index);
    if (s == CSI_OK && share)
        window_share(tl, out, out->frames_mean);
    return s;
}

csi_status csi_recon_tile(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                const csi_sample_pos *pos, const float *values, size_t n,
                                const csi_recon_options *opt, const csi_tiling *tl,
                                const csi_tile_scope *scope, uint32_t index, csi_tile_result *out)
{
    int e[4];
    float *scaled = NULL;
    memset(out, 0, sizeof *out);
    /* The image averaged with the denoised frames (image_frames) needs the window's frames, asked
     * for or not (csi_recon's rule: a tile run alone makes the same image as the tile in process);
     * dropped below when not asked for. */
    csi_recon_options local = *opt;
    if (g->t > 1 && !opt->frames) {
        csi_recon_options r;
        CSI_TRY(csi_recon_resolve(opt, g, n, &r));
        local.frames = r.image_frames == CSI_SWITCH_ON;
    }
    const csi_recon_options *asked = opt;
    opt = &local;
    CSI_TRY(csi_recon_scale_values(values, n, channels, csi_recon_scale_common(channels, opt), e, &scaled));
    csi_status s = reconstruct_tile(ctx, g, channels, pos, scaled ? scaled : values, n, opt, tl, scope, index, out);
    free(scaled);
    if (s == CSI_OK)
        csi_recon_unscale_result(&out->r, e);
    if (s == CSI_OK && (s = tile_noisy_steps(ctx, tl, index, channels, pos, values, n, opt, out)) != CSI_OK)
        csi_tile_result_free(out);
    if (s == CSI_OK && (s = tile_frames_step(ctx, tl, scope, index, channels, pos, values, n, opt, asked->frames, out)) !=
                          CSI_OK)
        csi_tile_result_free(out);
    const size_t np = (size_t)out->r.out_w * out->r.out_h;
    for (uint32_t c = 0; s == CSI_OK && out->resid && c < channels; c++)
        for (size_t q = 0; e[c] && q < np; q++) {
            double *a = out->resid + ((size_t)c * np + q) * CSI_RESID_SUMS;
            a[1] = ldexp(a[1], e[c]);
            a[2] = ldexp(a[2], 2 * e[c]);
            a[3] = ldexp(a[3], e[c]);
            a[4] = ldexp(a[4], e[c]);
            a[5] = ldexp(a[5], e[c]);
            a[6] = ldexp(a[6], 2 * e[c]);
            a[8] = ldexp(a[8], e[c]);
            a[9] = ldexp(a[9], 2 * e[c]);
        }
    out->exact = (opt->sample_flags & CSI_SAMPLES_EXACT) != 0;
    if (s == CSI_OK && local.frames && !asked->frames && out->r.frames)
        csi_recon_result_drop_frames(&out->r);
    return s;
}

/* The frames' sums of a time window's residual sums (csi/tiles.h: a[7..9]) of channel c, from
 * its frames (r: the window's result): per pixel, two passes over the shutter's frames, the
 * second about the weighted mean (no cancellation), deterministic. */
static void frame_sums(const csi_tiling *tl, const csi_tile *tile, const csi_recon_result *r, uint32_t c,
                       double *rc)
{
    const size_t np = (size_t)r->out_w * r->out_h;
    uint32_t nt = 0; /* the window's frames within the shutter (the later ones are padding) */
    while (nt < r->nframes && tile->win0[2] + nt < tl->image_t)
        nt++;
    for (size_t q = 0; q < np; q++) {
        double *a = rc + q * CSI_RESID_SUMS;
        const double wxy = csi_tile_weight(tl, tile, 0, tile->win0[0] + (uint32_t)(q % r->out_w)) *
                           csi_tile_weight(tl, tile, 1, tile->win0[1] + (uint32_t)(q / r->out_w));
        double w = 0, sum = 0, ss = 0;
        for (uint32_t t = 0; t < nt; t++) {
            const double wt = wxy * csi_tile_weight(tl, tile, 2, tile->win0[2] + t);
            w += wt;
            sum += wt * (double)r->frames[((size_t)t * r->channels + c) * np + q];
        }
        if (!(w > 0))
            continue;
        const double mean = sum / w;
        for (uint32_t t = 0; t < nt; t++) {
            const double d = (double)r->frames[((size_t)t * r->channels + c) * np + q] - mean;
            ss += wxy * csi_tile_weight(tl, tile, 2, tile->win0[2] + t) * d * d;
        }
        a[7] = w;
        a[8] = mean;
        a[9] = ss;
    }
}

/* A time window's residual sums (csi_tile_result.resid) from its samples and its volume at them
 * (fit_at, channel-major; NULL when the window has no sample) and its frames (res): two passes in
 * sample order, the second about each pixel's weighted mean (no cancellation), deterministic. */
static csi_status resid_sums(const csi_tiling *tl, const csi_tile *tile, const tile_problem *p,
                             uint32_t channels, const float *fit_at, const csi_recon_result *res, double **out)
{
    const uint32_t ow = p->g.out_w, oh = p->g.out_h, bw = p->g.w / ow, bh = p->g.h / oh;
    const size_t np = (size_t)ow * oh, n = p->n;
    double *r = malloc(np * channels * CSI_RESID_SUMS * sizeof *r), *w = malloc((n ? n : 1) * sizeof *w);
    size_t *px = malloc((n ? n : 1) * sizeof *px);
    if (!r || !w || !px) {
        free(r), free(w), free(px);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the residual sums of tile %u", tile->index);
    }
    csi_tiles_resid_clear(r, np * channels);
    /* each sample's pixel and blend weight, the tiles' weights at its pixel and frame */
    for (size_t i = 0; i < n; i++) {
        const csi_sample_pos q = p->pos[i];
        px[i] = csi_recon_pixel_of(q, bw, bh, ow) * CSI_RESID_SUMS;
        w[i] = csi_tile_weight(tl, tile, 0, tile->win0[0] + q.x / bw) *
               csi_tile_weight(tl, tile, 1, tile->win0[1] + q.y / bh) *
               csi_tile_weight(tl, tile, 2, tile->win0[2] + q.t);
    }
    for (uint32_t c = 0; c < channels && fit_at; c++) {
        double *rc = r + (size_t)c * np * CSI_RESID_SUMS;
        const float *g = fit_at + (size_t)c * n;
        for (size_t i = 0; i < n; i++) {
            const float y = p->values[i * channels + c];
            double *a = rc + px[i];
            if (w[i] > 0) {
                a[0] += w[i];
                a[1] += w[i] * ((double)y - (double)g[i]);
                a[5] += w[i] * (double)y;
                a[3] = fmin(a[3], y);
                a[4] = fmax(a[4], y);
            }
        }
        for (size_t q = 0; q < np; q++)
            if (rc[q * CSI_RESID_SUMS] > 0) {
                rc[q * CSI_RESID_SUMS + 1] /= rc[q * CSI_RESID_SUMS];
                rc[q * CSI_RESID_SUMS + 5] /= rc[q * CSI_RESID_SUMS];
            }
        for (size_t i = 0; i < n; i++) {
            double *a = rc + px[i];
            const double d = (double)p->values[i * channels + c] - (double)g[i] - a[1];
            const double dv = (double)p->values[i * channels + c] - a[5];
            if (w[i] > 0) {
                a[2] += w[i] * d * d;
                a[6] += w[i] * dv * dv;
            }
        }
        if (res->frames && res->out_w == ow && res->out_h == oh)
            frame_sums(tl, tile, res, c, rc);
    }
    free(w), free(px);
    *out = r;
    return CSI_OK;
}

/* The binned shutter's image of tile t's x/y window becomes the image of t's result r: the
 * column's first window carries it whole (its weights over t sum to 1 there), the others none;
 * the binned solve's work is added to r's figures. */
static csi_status binned_into(csi_ctx *ctx, const csi_tiling *tl, const csi_tile *t, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const csi_recon_options *opt, const csi_tile_scope *scope, csi_recon_result *r)
{
    const size_t np = (size_t)r->out_w * r->out_h;
    r->options.tile_image_binned = CSI_SWITCH_ON;
    if (t->pos[2] != 0) {
        memset(r->image, 0, np * channels * sizeof *r->image);
        return CSI_OK;
    }
    csi_recon_result b;
    CSI_TRY(csi_recon_binned_image(ctx, tl, t, channels, pos, values, n, opt, scope, &b));
    memcpy(r->image, b.image, np * channels * sizeof *r->image);
    for (uint32_t c = 0; c < channels; c++) {
        r->report[c].iterations += b.report[c].iterations;
        r->report[c].applies += b.report[c].applies;
        r->report[c].adjoints += b.report[c].adjoints;
        r->report[c].t_total += b.report[c].t_total;
    }
    r->t_setup += b.t_setup;
    r->t_solve += b.t_solve;
    r->t_integrate += b.t_integrate;
    r->cpu_setup += b.cpu_setup;
    r->cpu_work += b.cpu_work;
    csi_recon_result_free(&b);
    return CSI_OK;
}

static csi_status reconstruct_tile(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                   const csi_sample_pos *pos, const float *values, size_t n,
                                   const csi_recon_options *opt, const csi_tiling *tl,
                                   const csi_tile_scope *scope, uint32_t index, csi_tile_result *out)
{
    memset(out, 0, sizeof *out);
    if (memcmp(g, &tl->grid, sizeof *g))
        return csi_fail(CSI_ERR_ARG, "the tile layout was made for another grid");
    tile_problem p;
    CSI_TRY(tile_problem_make(tl, index, channels, pos, values, n, &p));
    out->index = index;
    out->x0 = p.tile.win0[0];
    out->y0 = p.tile.win0[1];
    out->t0 = p.tile.win0[2];
    /* With the binned shutter's image a window solves only for its frames (none asked: nothing). */
    const bool binned = csi_tiling_image_binned(tl, opt);
    const bool split_t = tl->n[2] > 1 && !binned, solve = !binned || opt->frames;
    csi_recon_options o = *opt;
    o.levels = tl->levels > 0 ? tl->levels : opt->levels;
    o.frames = opt->frames || split_t; /* a time window's share of the mean needs its frames */
    o.tiles = 0;
    if (tl->image_t < tl->grid.t)
        o.shutter_frames = tl->image_t; /* the later frames are padding (csi_tiling_layout) */
    /* The whole image's variances are indexed by its samples, not the tile's: the tile's peaks
     * read them through tile_noisy_steps, which gathers the tile's own; the solve gets none. */
    o.sample_variance = NULL;
    /* A time window keeps its volume at its samples for the whole shutter's correction. */
    csi_recon_fit fit = {NULL, false};
    csi_status s = tl->n[2] > 1 && p.n == 0 ? csi_tiling_empty_tile(tl, index) : CSI_OK;
    if (split_t && p.n > 0 && !(fit.at = malloc(p.n * channels * sizeof *fit.at)))
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the volume at the %zu samples of tile %u", p.n, index);
    if (s == CSI_OK && (p.n == 0 || !solve)) {
        /* No sample reaches this window, or nothing is asked of it: the tile knows nothing
         * of its own, and says so. */
        csi_recon_result *r = &out->r;
        const size_t np = (size_t)p.g.out_w * p.g.out_h;
        r->out_w = p.g.out_w;
        r->out_h = p.g.out_h;
        r->channels = channels;
        r->nframes = o.frames && p.g.t > 1 && o.estimator != CSI_EST_MEAN ? p.g.t : 0;
        r->image = calloc(np * channels, sizeof(float));
        r->frames = r->nframes ? calloc(np * channels * r->nframes, sizeof(float)) : NULL;
        r->k = (size_t)p.g.w * p.g.h * p.g.t;
        r->model_factor = 1;
        r->tiles = 1;
        s = csi_recon_resolve_scoped(&o, &p.g, 0, scope, &r->options);
        for (uint32_t c = 0; c < channels; c++) {
            r->report[c].converged = true;
            r->report[c].reason = CSI_SOLVE_ZERO;
            snprintf(r->report[c].message, sizeof r->report[c].message,
                     solve ? "tile %u has no sample" : "tile %u: no frames asked for (the image is the binned shutter's)",
                     index);
        }
        if (s == CSI_OK && (!r->image || (r->nframes && !r->frames)))
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for tile %u", index);
    } else if (s == CSI_OK) {
        /* One tile is the whole problem, solved as csi_recon solves it: with its own scale (a
         * volume's scope only approximates that, from the mean sample), so that a run of the one
         * tile alone (--tile 0/1) gives the one-process bits. */
        s = csi_recon_scoped(ctx, &p.g, channels, p.pos, p.values, p.n, &o, tl->count > 1 ? scope : NULL,
                             split_t ? &fit : NULL, &out->r);
    }
    if (s == CSI_OK && split_t && (p.n == 0 || fit.kept))
        s = resid_sums(tl, &p.tile, &p, channels, fit.kept ? fit.at : NULL, &out->r, &out->resid);
    if (s == CSI_OK && binned)
        s = binned_into(ctx, tl, &p.tile, channels, pos, values, n, opt, scope, &out->r);
    free(fit.at);
    tile_problem_free(&p);
    if (s != CSI_OK) {
        csi_tile_result_free(out);
        return csi_fail_context(s, "tile %u of %u: ", index, tl->count);
    }
    csi_recon_result *r = &out->r;
    if (split_t && r->nframes)
        window_share(tl, out, r->image); /* the window's share of the mean over t */
    if (split_t && r->nframes && !opt->frames) {
        free(r->frames);
        r->frames = NULL;
        r->nframes = 0;
    }
    return CSI_OK;
}

/* Phase names of a tile for the caller's progress callback: "tile 3/16 solve" and so on. */
typedef struct {
    const csi_recon_options *opt;
    uint32_t index, count;
} tile_progress;

static bool on_tile_progress(void *user, const char *phase, int iter, double res)
{
    const tile_progress *tp = user;
    char name[64];
    snprintf(name, sizeof name, "tile %u/%u %s", tp->index + 1, tp->count, phase);
    return tp->opt->progress(tp->opt->user, name, iter, res);
}

/* csi_recon_tiled's tiles, solved and blended in index order. */
static csi_status tiled_run(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                            const float *values, size_t n, const csi_recon_options *opt, const csi_tiling *tl,
                            csi_recon_result *out)
{
    csi_tile_scope scope;
    CSI_TRY(csi_recon_progress(opt, "tile scale"));
    CSI_TRY(csi_tile_scope_make(ctx, g, channels, pos, values, n, opt, tl, &scope));
    csi_blend b;
    CSI_TRY(csi_tiles_begin(tl, channels, opt->frames, &b, out));
    tile_progress tp = {opt, 0, tl->count};
    csi_recon_options o = *opt;
    if (opt->progress) {
        o.progress = on_tile_progress;
        o.user = &tp;
    }
    csi_status s = CSI_OK;
    for (uint32_t i = 0; i < tl->count && s == CSI_OK; i++) {
        tp.index = i;
        csi_tile_result t;
        s = csi_recon_tile(ctx, g, channels, pos, values, n, &o, tl, &scope, i, &t);
        if (s == CSI_OK)
            s = csi_recon_progress(&o, "blend"); /* "tile i/N blend": a host pass over the tile */
        if (s == CSI_OK)
            s = csi_tiles_add(&b, &t);
        csi_tile_result_free(&t);
    }
    if (s == CSI_OK)
        s = csi_tiles_end(&b);
    csi_tiles_release(&b);
    out->n = n;
    if (s != CSI_OK)
        csi_recon_result_free(out);
    return s;
}

csi_status csi_recon_tiled(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                 const csi_sample_pos *pos, const float *values, size_t n,
                                 const csi_recon_options *opt, const csi_tiling *tl,
                                 csi_recon_result *out)
{
    memset(out, 0, sizeof *out);
    /* Every tile's scale pass and solve make the same volumes again (one window size): keep
     * them from one to the next rather than fault in fresh pages each time. */
    csi_buffer_keep_begin(ctx);
    csi_status s = tiled_run(ctx, g, channels, pos, values, n, opt, tl, out);
    csi_buffer_keep_end(ctx);
    return s;
}
