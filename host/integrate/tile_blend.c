/* The blend of tiles into one result (csi/tiles.h: csi_tiles_begin, csi_tiles_add, csi_tiles_end):
 * each tile's image and frames weighted into the whole's in index order, and what a time window
 * or a still image that settles leaves for the end (residual sums, the frames' mean, pixel sums). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/settle.h"
#include "csi/step_coverage.h"
#include "csi/tiles.h"
#include "internal.h"

void csi_tiles_resid_clear(double *r, size_t pixels)
{
    for (size_t q = 0; q < pixels; q++) {
        double *a = r + q * CSI_RESID_SUMS;
        a[0] = a[1] = a[2] = a[5] = a[6] = a[7] = a[8] = a[9] = 0;
        a[3] = INFINITY;
        a[4] = -INFINITY;
    }
}

csi_status csi_tiles_begin(const csi_tiling *tl, uint32_t channels, bool frames, csi_blend *b,
                           csi_recon_result *out)
{
    memset(b, 0, sizeof *b);
    memset(out, 0, sizeof *out);
    b->tl = *tl;
    b->out = out;
    const csi_grid *g = &tl->grid;
    const size_t np = (size_t)g->out_w * g->out_h;
    out->out_w = g->out_w;
    out->out_h = g->out_h;
    out->channels = channels;
    out->k = (size_t)g->w * g->h * g->t;
    out->tiles = tl->count;
    out->image = calloc(np * channels, sizeof(float));
    if (frames && g->t > 1) {
        out->nframes = g->t;
        out->frames = calloc(np * channels * g->t, sizeof(float));
    }
    if (!out->image || (out->nframes && !out->frames)) {
        csi_recon_result_free(out);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the %ux%u output", g->out_w, g->out_h);
    }
    for (uint32_t c = 0; c < channels; c++)
        out->report[c].converged = true;
    if (tl->n[2] > 1) {
        b->resid_all = true;
        b->resid = malloc(np * channels * CSI_RESID_SUMS * sizeof *b->resid);
        if (!b->resid) {
            csi_recon_result_free(out);
            return csi_fail(CSI_ERR_NOMEM, "out of host memory for the residual sums of the %ux%u output",
                            g->out_w, g->out_h);
        }
        csi_tiles_resid_clear(b->resid, np * channels);
    }
    return CSI_OK;
}

void csi_tiles_release(csi_blend *b)
{
    free(b->resid);
    free(b->px_cnt);
    free(b->px_sum);
    free(b->step_changes);
    free(b->frames_mean);
    b->resid = NULL;
    b->px_cnt = NULL;
    b->px_sum = NULL;
    b->step_changes = NULL;
    b->step_count = b->step_cap = 0;
    b->frames_mean = NULL;
}

/* A tile's residual sums into the whole image's: weights add, the means combine weighted, and
 * the sums of squares about them as in Chan et al.'s pairwise update (in tile order, so the
 * same bits for any completion order). */
static void resid_add(csi_blend *b, const csi_tile_result *t)
{
    const csi_recon_result *r = &t->r;
    const size_t W = b->tl.grid.out_w, np = W * b->tl.grid.out_h, tnp = (size_t)r->out_w * r->out_h;
    for (uint32_t c = 0; c < r->channels; c++)
        for (uint32_t y = 0; y < r->out_h; y++)
            for (uint32_t x = 0; x < r->out_w; x++) {
                const double *a = t->resid + ((size_t)c * tnp + (size_t)y * r->out_w + x) * CSI_RESID_SUMS;
                double *s = b->resid + ((size_t)c * np + (size_t)(t->y0 + y) * W + t->x0 + x) * CSI_RESID_SUMS;
                if (a[7] > 0) { /* the frames' sums */
                    const double wf = s[7] + a[7], df = a[8] - s[8];
                    s[9] += a[9] + df * df * (s[7] * a[7] / wf);
                    s[8] += df * (a[7] / wf);
                    s[7] = wf;
                }
                if (!(a[0] > 0))
                    continue;
                const double w = s[0] + a[0], delta = a[1] - s[1], dv = a[5] - s[5];
                s[2] += a[2] + delta * delta * (s[0] * a[0] / w);
                s[1] += delta * (a[0] / w);
                s[6] += a[6] + dv * dv * (s[0] * a[0] / w);
                s[5] += dv * (a[0] / w);
                s[0] = w;
                s[3] = fmin(s[3], a[3]);
                s[4] = fmax(s[4], a[4]);
            }
}

/* The whole shutter's correction of channel c from the blended sums (csi_tile_result): projected
 * onto the range an untiled run's has (sample_range.c), from the sums of the samples' values. */
static csi_status resid_correct(csi_blend *b, uint32_t c)
{
    const csi_grid *g = &b->tl.grid;
    const size_t np = (size_t)g->out_w * g->out_h;
    csi_px_resid *st = calloc(np, sizeof *st);
    csi_px_values *px = malloc(np * sizeof *px);
    float *lohi = malloc(2 * np * sizeof *lohi), all[2] = {INFINITY, -INFINITY};
    float *fit_var = malloc(np * sizeof *fit_var);
    csi_status s = CSI_OK;
    if (!st || !px || !lohi || !fit_var)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel correction (%zu pixels)", np);
    for (size_t q = 0; s == CSI_OK && q < np; q++) {
        const double *a = b->resid + ((size_t)c * np + q) * CSI_RESID_SUMS;
        st[q].n = (uint32_t)llround(a[0]); /* the weights of a sample's tiles sum to 1 */
        st[q].d = a[1];
        st[q].ss = a[2];
        px[q] = (csi_px_values){.mean = a[5], .ss = a[6], .n = st[q].n, .lo = (float)a[3], .hi = (float)a[4]};
        fit_var[q] = a[7] > 0 ? (float)(a[9] / a[7]) : 0.0f;
        all[0] = fminf(all[0], px[q].lo);
        all[1] = fmaxf(all[1], px[q].hi);
    }
    if (s == CSI_OK)
        s = csi_recon_value_ranges(g->out_w, g->out_h, px, all, lohi);
    /* as untiled: exact samples take the whole correction, the others move towards their means */
    if (s == CSI_OK)
        csi_recon_motion_correct_pixels(g, st, lohi, b->exact, b->out->image + (size_t)c * np);
    if (s == CSI_OK && !b->exact)
        s = csi_recon_motion_toward_mean(g, px, fit_var, b->out->image + (size_t)c * np);
    free(st);
    free(px);
    free(lohi);
    free(fit_var);
    return s;
}

/* The still pixels' rule (csi_recon_still_pixels) on the blended image of a volume in time
 * windows, from the whole shutter's sums, so that it is the untiled image's: a pixel's samples
 * agree where their range is one value in every channel, the share is of the pixels of two
 * samples or more, and a pixel whose 3 x 3 pixels' samples all agree takes their value. (Each
 * window sees a part of a pixel's samples; the sums see them all, in one process or merged from
 * partials.) */
static csi_status still_from_sums(csi_blend *b)
{
    csi_recon_result *out = b->out;
    const uint32_t C = out->channels, ow = b->tl.grid.out_w, oh = b->tl.grid.out_h;
    const size_t np = (size_t)ow * oh;
    unsigned char *state = malloc(np ? np : 1);
    if (!state)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the still pixels (%zu pixels)", np);
    for (size_t q = 0; q < np; q++) {
        const long long cnt = llround(b->resid[q * CSI_RESID_SUMS]);
        state[q] = cnt == 0 ? CSI_STILL_NONE : cnt == 1 ? CSI_STILL_ONE : CSI_STILL_AGREE;
        for (uint32_t c = 0; c < C && state[q] == CSI_STILL_AGREE; c++) {
            const double *a = b->resid + ((size_t)c * np + q) * CSI_RESID_SUMS;
            if (a[3] != a[4])
                state[q] = CSI_STILL_DIFFER;
        }
    }
    const bool still_picture = csi_recon_still_share(state, np) > CSI_STILL_PICTURE_SHARE;
    for (size_t q = 0; still_picture && q < np; q++) {
        if (!csi_recon_still_calm(state, q, ow, oh))
            continue;
        for (uint32_t c = 0; c < C; c++)
            out->image[(size_t)c * np + q] = (float)b->resid[((size_t)c * np + q) * CSI_RESID_SUMS + 3];
    }
    free(state);
    return CSI_OK;
}

/* acc += w v in double, rounded once to float: the same bits for the same order of tiles. */
static inline void blend1(float *acc, double w, float v)
{
    *acc = (float)((double)*acc + w * (double)v);
}

csi_status csi_tiles_add(csi_blend *b, const csi_tile_result *t)
{
    const csi_tiling *tl = &b->tl;
    csi_recon_result *out = b->out;
    const csi_recon_result *r = &t->r;
    if (t->index != b->next)
        return csi_fail(CSI_ERR_ARG, "tile %u came where tile %u was due (tiles are blended in index "
                        "order, so that the image is the same bits however they were computed)", t->index, b->next);
    csi_tile tile;
    csi_tiling_tile(tl, t->index, &tile);
    if (r->out_w != tl->window[0] || r->out_h != tl->window[1] || r->channels != out->channels ||
        t->x0 != tile.win0[0] || t->y0 != tile.win0[1] || t->t0 != tile.win0[2])
        return csi_fail(CSI_ERR_ARG, "tile %u is a %ux%u window at (%u, %u, %u) with %u channels; the "
                        "layout's is %ux%u at (%u, %u, %u) with %u", t->index, r->out_w, r->out_h, t->x0,
                        t->y0, t->t0, r->channels, tl->window[0], tl->window[1], tile.win0[0], tile.win0[1],
                        tile.win0[2], out->channels);
    if (t->index == 0)
        b->exact = t->exact;
    else if (t->exact != b->exact)
        return csi_fail(CSI_ERR_ARG, "tile %u's samples are%s flagged exact, tile 0's are%s", t->index,
                        t->exact ? "" : " not", b->exact ? "" : " not");
    if (out->nframes && r->nframes != tl->window[2])
        return csi_fail(CSI_ERR_ARG, "tile %u has %u frames, the layout's windows %u", t->index, r->nframes,
                        tl->window[2]);
    const uint32_t W = tl->grid.out_w, H = tl->grid.out_h, C = out->channels;
    const size_t np = (size_t)W * H, tnp = (size_t)r->out_w * r->out_h;
    if (t->index == 0 && t->px_cnt) {
        b->px_cnt = calloc(np, sizeof *b->px_cnt);
        b->px_sum = calloc(np * C, sizeof *b->px_sum);
        if (!b->px_cnt || !b->px_sum)
            return csi_fail(CSI_ERR_NOMEM, "out of host memory for the pixel sums of the %ux%u output", W, H);
    }
    if (!b->px_cnt != !t->px_cnt)
        return csi_fail(CSI_ERR_ARG, "tile %u %s pixel sums where tile 0 %s (tiles of another run?)", t->index,
                        t->px_cnt ? "has" : "has no", t->px_cnt ? "has none" : "has them");
    if (t->index == 0)
        b->step_given = t->step_delta != NULL;
    if (b->step_given != (t->step_delta != NULL))
        return csi_fail(CSI_ERR_ARG, "tile %u %s the HDR step's changes where tile 0 %s (tiles of another run?)",
                        t->index, t->step_delta ? "has" : "has no", t->step_delta ? "has none" : "has them");
    if (t->index == 0 && t->frames_mean && !(b->frames_mean = calloc(np * C, sizeof *b->frames_mean)))
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the frames' mean of the %ux%u output", W, H);
    if (!b->frames_mean != !t->frames_mean)
        return csi_fail(CSI_ERR_ARG, "tile %u %s the frames' mean where tile 0 %s (tiles of another run?)", t->index,
                        t->frames_mean ? "has" : "has no", t->frames_mean ? "has none" : "has it");
    double *wx = malloc(r->out_w * sizeof *wx), *wy = malloc(r->out_h * sizeof *wy);
    if (!wx || !wy) {
        free(wx);
        free(wy);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory blending tile %u", t->index);
    }
    for (uint32_t x = 0; x < r->out_w; x++)
        wx[x] = csi_tile_weight(tl, &tile, 0, t->x0 + x);
    for (uint32_t y = 0; y < r->out_h; y++)
        wy[y] = csi_tile_weight(tl, &tile, 1, t->y0 + y);
    for (uint32_t c = 0; c < C; c++)
        for (uint32_t y = 0; y < r->out_h; y++)
            for (uint32_t x = 0; x < r->out_w; x++) {
                const double w = wx[x] * wy[y];
                const size_t at = (size_t)c * np + (size_t)(t->y0 + y) * W + t->x0 + x;
                const size_t from = (size_t)c * tnp + (size_t)y * r->out_w + x;
                if (w > 0)
                    blend1(&out->image[at], w, r->image[from]);
                if (b->step_given && t->step_delta[from] != 0.0f) { /* each pixel in one tile's core */
                    if (b->step_count == b->step_cap) {
                        const size_t cap = b->step_cap ? 2 * b->step_cap : 256;
                        struct csi_step_change *m = realloc(b->step_changes, cap * sizeof *m);
                        if (!m) {
                            free(wx), free(wy);
                            return csi_fail(CSI_ERR_NOMEM, "out of host memory for the HDR step's changes");
                        }
                        b->step_changes = m, b->step_cap = cap;
                    }
                    b->step_changes[b->step_count++] = (struct csi_step_change){at, t->step_delta[from]};
                }
                if (w > 0 && b->frames_mean)
                    blend1(&b->frames_mean[at], w, t->frames_mean[from]);
            }
    for (uint32_t f = 0; out->nframes && f < r->nframes; f++) {
        const double wt = csi_tile_weight(tl, &tile, 2, t->t0 + f);
        if (wt <= 0)
            continue;
        for (uint32_t c = 0; c < C; c++)
            for (uint32_t y = 0; y < r->out_h; y++)
                for (uint32_t x = 0; x < r->out_w; x++) {
                    const double w = wx[x] * wy[y] * wt;
                    if (w > 0)
                        blend1(&out->frames[((size_t)(t->t0 + f) * C + c) * np + (size_t)(t->y0 + y) * W + t->x0 + x],
                               w, r->frames[((size_t)f * C + c) * tnp + (size_t)y * r->out_w + x]);
                }
    }
    free(wx);
    free(wy);
    /* a tile's sums are its core's pixels' and zero elsewhere: added, the whole image's exactly */
    for (uint32_t y = 0; b->px_cnt && y < r->out_h; y++)
        for (uint32_t x = 0; x < r->out_w; x++) {
            const size_t q = (size_t)y * r->out_w + x, p = (size_t)(t->y0 + y) * W + t->x0 + x;
            b->px_cnt[p] += t->px_cnt[q];
            for (uint32_t c = 0; c < C; c++)
                b->px_sum[p * C + c] += t->px_sum[q * C + c];
        }
    if (b->resid && !t->resid)
        b->resid_all = false;
    else if (b->resid)
        resid_add(b, t);
    /* The run's figures: operator calls, iterations and times add up; the residual is the worst
     * tile's; converged when every tile did. */
    if (t->index == 0) {
        out->options = r->options;
        out->model_factor = r->model_factor;
        out->chroma_model_factor = r->chroma_model_factor;
    }
    out->unknowns += r->unknowns;
    for (uint32_t c = 0; c < C; c++) {
        csi_solve_report *a = &out->report[c];
        const csi_solve_report *p = &r->report[c];
        a->iterations += p->iterations;
        a->inner_iterations += p->inner_iterations;
        a->stages += p->stages;
        a->applies += p->applies;
        a->adjoints += p->adjoints;
        a->support += p->support;
        a->objective += p->objective;
        a->t_total += p->t_total;
        a->t_select += p->t_select;
        a->t_lsq += p->t_lsq;
        a->t_step += p->t_step;
        a->t_debias += p->t_debias;
        if (p->rel_residual > a->rel_residual)
            a->rel_residual = p->rel_residual;
        if (p->rel_gap > a->rel_gap)
            a->rel_gap = p->rel_gap;
        if (p->tau > a->tau)
            a->tau = p->tau;
        if (!p->converged && a->converged) {
            a->converged = false;
            a->reason = p->reason;
            snprintf(a->message, sizeof a->message, "tile %u: %s", t->index, p->message);
        }
    }
    out->t_setup += r->t_setup;
    out->t_solve += r->t_solve;
    out->t_integrate += r->t_integrate;
    out->t_programs += r->t_programs;
    out->t_cv += r->t_cv;
    out->cv_switched += r->cv_switched;
    out->cv_smoothed += r->cv_smoothed;
    out->cpu_setup += r->cpu_setup;
    out->cpu_work += r->cpu_work;
    for (uint32_t c = 0; c < C && c < 4; c++)
        out->t_channel_integrate[c] += r->t_channel_integrate[c];
    b->next++;
    return CSI_OK;
}

csi_status csi_tiles_end(csi_blend *b)
{
    csi_recon_result *out = b->out;
    if (b->next != b->tl.count) {
        csi_tiles_release(b);
        return csi_fail(CSI_ERR_ARG, "%u of %u tiles blended: tile %u is missing", b->next, b->tl.count, b->next);
    }
    csi_status s = CSI_OK;
    for (uint32_t c = 0; b->resid && b->resid_all && c < out->channels && s == CSI_OK; c++)
        s = resid_correct(b, c);
    if (s == CSI_OK && b->resid && b->resid_all)
        s = still_from_sums(b);
    if (s == CSI_OK && b->px_cnt)
        s = csi_settle_sums(&b->tl.grid, out->channels, b->px_cnt, b->px_sum, out->image, NULL, &out->settled);
    if (s == CSI_OK && b->step_count) { /* after the settling, as untiled (csi/step_coverage.h) */
        const size_t np = (size_t)out->out_w * out->out_h;
        unsigned char *moved = calloc(np, 1);
        if (!moved)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the HDR step's %zu pixels", np);
        for (size_t i = 0; s == CSI_OK && i < b->step_count; i++) {
            const struct csi_step_change *ch = &b->step_changes[i];
            out->image[ch->at] = (float)csi_fmax(0.0, (double)out->image[ch->at] + (double)ch->v);
            out->step_moved += !moved[ch->at % np];
            moved[ch->at % np] = 1;
        }
        free(moved);
    }
    /* time windows: the corrected image averaged with the frames' mean, as csi_frames_denoise_image
     * averages an untiled one */
    for (size_t i = 0; s == CSI_OK && b->frames_mean && i < (size_t)out->out_w * out->out_h * out->channels; i++)
        out->image[i] = (float)(0.5 * ((double)out->image[i] + (double)b->frames_mean[i]));
    csi_tiles_release(b);
    CSI_TRY(s);
    /* a padded grid's pixels past the image's own (docs/tiles.md, "Limits") */
    if (out->out_w != b->tl.image_w || out->out_h != b->tl.image_h || (out->nframes && out->nframes != b->tl.image_t))
        CSI_TRY(csi_recon_crop(out, b->tl.image_w, b->tl.image_h, b->tl.image_t));
    for (uint32_t c = 0; c < out->channels; c++) {
        csi_solve_report *a = &out->report[c];
        if (a->converged)
            snprintf(a->message, sizeof a->message, "%u tiles converged: %d iterations in all, largest "
                     "relative residual %.3g", b->tl.count, a->iterations, a->rel_residual);
    }
    CSI_TRY(csi_recon_check_finite(out->image, (size_t)out->out_w * out->out_h * out->channels, "image"));
    if (out->nframes)
        CSI_TRY(csi_recon_check_finite(out->frames, (size_t)out->out_w * out->out_h * out->channels *
                                       out->nframes, "frames"));
    return CSI_OK;
}
