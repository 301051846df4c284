/* The blurred image of a volume, per region either csi's (the mean over t of the volume solve)
 * or that of a solve of the shutter binned in t to 4 frames, whichever two-fold cross-validation of the
 * pixel integrals says is closer (csi_recon_options.motion_image_cv; the measurements are in
 * docs/bench/animation.md, session 10; tools/bench/anim_image.py is the numpy form).
 *
 * Why a second estimator. The image is the mean over t of the frames, a smoother signal than the
 * frames, and a sample at a uniformly random cell (x, y, t) is an unbiased point sample of it at
 * pixel (x, y), the randomness of t acting as noise. Binned to K frames (samples sharing an
 * (x, y, bin) cell averaged, as the binned shutter of a time-windowed volume does: binned.c), a
 * solve has fewer unknowns and more samples per cell: where the scene holds still (a still
 * photograph, a billiard table under shading noise) its image is better than the volume's;
 * where things move it is worse (what moves within a bin is blurred, and at K = 1 a pan is
 * noise). Neither wins everywhere, so each region takes the one its held-out samples favour.
 *
 * The choice is csi/cv_select.h's, with the default image in the place of the per-pixel mean:
 * each pixel's samples go alternately (in t order, the first by the pixel's parity) to two
 * folds; both estimators are reconstructed from each fold A and scored against the other fold's
 * pixel means m_B, D = (binned_A - m_B)^2 - (csi_A - m_B)^2 summed over the channels, whose
 * expectation is the difference of the two estimators' errors in the pixel integral (m_B's noise
 * cancels: it is independent of everything made from A). A region of CSI_CV_REGION pixels (where
 * none wins there, of twice that side) takes a binned image only when each direction's sum of D
 * is below -CSI_CV_Z times the root of the sum of its pixels' squared D (a few pixels never
 * decide), and of several that do, the one with the smallest sum. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/cv_select.h"
#include "internal.h"

/* The shutter's bin counts tried (each below T): four. One bin (Alg. 1 on the per-pixel means,
 * the samples projected to x, y) was measured as a second candidate and left out: its folds, each
 * from half the samples, chose it where on all the samples it loses (a train at 16 spp: 1.83x the
 * default's image MSE; docs/bench/animation.md, session 10). The loop takes more than one. */
static const uint32_t BINS[] = {4};
#define NBINS (sizeof BINS / sizeof BINS[0])
_Static_assert(NBINS >= 1, "at least one binned estimator");

/* fold[i] in {0, 1}: a pixel's samples alternately, in t order (then sample order), the first
 * to the fold of the pixel's parity. The samples are visited in that order by a stable counting
 * sort on t, each pixel counting the samples it has seen. */
static csi_status make_folds(const csi_grid *g, const csi_sample_pos *pos, size_t n, uint8_t *fold)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h;
    size_t *next = calloc((size_t)g->t + 1, sizeof *next), *order = malloc((n ? n : 1) * sizeof *order);
    uint32_t *seen = calloc(np, sizeof *seen);
    csi_status s = CSI_OK;
    if (!next || !order || !seen)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the folds of %zu samples", n);
    for (size_t i = 0; s == CSI_OK && i < n; i++)
        next[pos[i].t + 1]++;
    for (size_t t = 0; s == CSI_OK && t < g->t; t++)
        next[t + 1] += next[t];
    for (size_t i = 0; s == CSI_OK && i < n; i++)
        order[next[pos[i].t]++] = i;
    for (size_t j = 0; s == CSI_OK && j < n; j++) {
        const size_t i = order[j], p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
        fold[i] = (uint8_t)((seen[p]++ + p % g->out_w + p / g->out_w) & 1);
    }
    free(next);
    free(order);
    free(seen);
    return s;
}

/* The samples whose fold is `f` (f = 2: all), binned to `bins` frames (bins = 0: as they are),
 * into pos_out / val_out (room for n); *m their count. Binned cells are in linear order of the
 * binned grid, each the mean of its samples. */
static csi_status gather(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                         const float *values, size_t n, const uint8_t *fold, int f, uint32_t bins,
                         csi_sample_pos *pos_out, float *val_out, size_t *m)
{
    if (!bins) {
        size_t u = 0;
        for (size_t i = 0; i < n; i++)
            if (f == 2 || fold[i] == f) {
                pos_out[u] = pos[i];
                memcpy(val_out + u * channels, values + i * channels, channels * sizeof *val_out);
                u++;
            }
        *m = u;
        return CSI_OK;
    }
    const csi_grid bg = {.w = g->w, .h = g->h, .t = bins, .out_w = g->out_w, .out_h = g->out_h};
    const size_t cells = (size_t)bg.w * bg.h * bg.t;
    uint32_t *cnt = calloc(cells, sizeof *cnt);
    if (!cnt)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a shutter binned to %u frames (%zu cells)",
                        bins, cells);
    for (size_t i = 0; i < n; i++)
        if (f == 2 || fold[i] == f) {
            const csi_sample_pos at = {pos[i].x, pos[i].y, (uint32_t)((uint64_t)pos[i].t * bins / g->t)};
            cnt[csi_grid_index(&bg, at)]++;
        }
    /* cnt becomes each occupied cell's record + 1, in linear order */
    size_t u = 0;
    for (size_t c = 0; c < cells; c++)
        if (cnt[c]) {
            const size_t t = c / ((size_t)bg.w * bg.h), r = c % ((size_t)bg.w * bg.h);
            pos_out[u] = (csi_sample_pos){(uint32_t)(r % bg.w), (uint32_t)(r / bg.w), (uint32_t)t};
            cnt[c] = (uint32_t)++u;
        }
    double *sum = calloc((u ? u : 1) * channels, sizeof *sum);
    uint32_t *num = calloc(u ? u : 1, sizeof *num);
    if (!sum || !num) {
        free(cnt);
        free(sum);
        free(num);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu binned samples", u);
    }
    for (size_t i = 0; i < n; i++)
        if (f == 2 || fold[i] == f) {
            const csi_sample_pos at = {pos[i].x, pos[i].y, (uint32_t)((uint64_t)pos[i].t * bins / g->t)};
            const size_t j = cnt[csi_grid_index(&bg, at)] - 1;
            for (uint32_t ch = 0; ch < channels; ch++)
                sum[j * channels + ch] += values[i * channels + ch];
            num[j]++;
        }
    for (size_t j = 0; j < u; j++)
        for (uint32_t ch = 0; ch < channels; ch++)
            val_out[j * channels + ch] = (float)(sum[j * channels + ch] / num[j]);
    free(cnt);
    free(sum);
    free(num);
    *m = u;
    return CSI_OK;
}

/* The image (planar, out_w * out_h * channels) of csi's solve of these samples: on the volume's
 * grid (bins = 0) or binned to `bins` frames; its times and CPU added to main's. */
static csi_status solve_image(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                              const float *values, size_t n, const uint8_t *fold, int f, uint32_t bins,
                              const csi_recon_options *opt, csi_sample_pos *pbuf, float *vbuf, float *image,
                              csi_recon_result *main)
{
    size_t m = 0;
    CSI_TRY(gather(g, channels, pos, values, n, fold, f, bins, pbuf, vbuf, &m));
    const csi_grid sg = {.w = g->w, .h = g->h, .t = bins ? bins : g->t, .out_w = g->out_w, .out_h = g->out_h};
    csi_recon_options o = *opt;
    o.motion_image_cv = CSI_SWITCH_OFF;
    o.frames = false;
    o.progress = NULL;
    o.sample_variance = NULL;
    if (bins) /* a bin's mean over its samples' times is no point value */
        o.sample_flags &= ~(uint32_t)CSI_SAMPLES_EXACT;
    csi_recon_result r;
    CSI_TRY(csi_recon(ctx, &sg, channels, pbuf, vbuf, m, &o, &r));
    memcpy(image, r.image, (size_t)g->out_w * g->out_h * channels * sizeof *image);
    main->t_setup += r.t_setup;
    main->t_solve += r.t_solve;
    main->t_integrate += r.t_integrate;
    main->cpu_work += r.cpu_setup + r.cpu_work;
    csi_recon_result_free(&r);
    return CSI_OK;
}

/* Per region of side `side`: sums of d (fold 0, fold 1) and of the pixels' squared d0 + d1. */
static void region_sums(const csi_grid *g, const double *d0, const double *d1, uint32_t side, double *acc)
{
    const size_t rw = (g->out_w + side - 1) / side, rh = (g->out_h + side - 1) / side;
    memset(acc, 0, rw * rh * 3 * sizeof *acc);
    for (size_t y = 0; y < g->out_h; y++)
        for (size_t x = 0; x < g->out_w; x++) {
            const size_t p = y * g->out_w + x, r = (y / side) * rw + x / side;
            acc[3 * r] += d0[p];
            acc[3 * r + 1] += d1[p];
            acc[3 * r + 2] += (d0[p] + d1[p]) * (d0[p] + d1[p]);
        }
}

csi_status csi_recon_motion_image(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                  const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, csi_recon_result *out)
{
    const size_t np = (size_t)g->out_w * g->out_h, plane = np * channels;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    uint32_t bins[NBINS];
    size_t nb = 0;
    for (size_t j = 0; j < NBINS; j++)
        if (BINS[j] < g->t)
            bins[nb++] = BINS[j];
    out->motion_image_switched = 0;
    if (!nb || n < 2)
        return CSI_OK;
    uint8_t *fold = malloc(n);
    csi_sample_pos *pbuf = malloc(n * sizeof *pbuf);
    float *vbuf = malloc(n * channels * sizeof *vbuf);
    float *def = malloc(plane * sizeof *def), *alt = malloc(plane * sizeof *alt);
    float *full = malloc(nb * plane * sizeof *full);
    double *d = calloc(nb * 2 * np, sizeof *d); /* d[(j * 2 + a) * np + p] */
    double *mean = malloc(plane * sizeof *mean);
    uint32_t *cnt = malloc(np * sizeof *cnt);
    int *pick = malloc(np * sizeof *pick);
    const size_t regions = ((g->out_w + CSI_CV_REGION - 1) / CSI_CV_REGION) *
                           ((g->out_h + CSI_CV_REGION - 1) / CSI_CV_REGION);
    double *acc = malloc(regions * 3 * sizeof *acc);
    csi_status s = CSI_OK;
    if (!fold || !pbuf || !vbuf || !def || !alt || !full || !d || !mean || !cnt || !pick || !acc)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the image's cross-validated choice (%zu samples)", n);
    if (s == CSI_OK)
        s = make_folds(g, pos, n, fold);
    for (int a = 0; s == CSI_OK && a < 2; a++) {
        /* the other fold's pixel means */
        memset(mean, 0, plane * sizeof *mean);
        memset(cnt, 0, np * sizeof *cnt);
        for (size_t i = 0; i < n; i++)
            if (fold[i] != a) {
                const size_t p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
                cnt[p]++;
                for (uint32_t ch = 0; ch < channels; ch++)
                    mean[ch * np + p] += values[i * channels + ch];
            }
        for (size_t p = 0; p < np; p++)
            for (uint32_t ch = 0; cnt[p] && ch < channels; ch++)
                mean[ch * np + p] /= cnt[p];
        s = solve_image(ctx, g, channels, pos, values, n, fold, a, 0, opt, pbuf, vbuf, def, out);
        for (size_t j = 0; s == CSI_OK && j < nb; j++) {
            s = solve_image(ctx, g, channels, pos, values, n, fold, a, bins[j], opt, pbuf, vbuf, alt, out);
            double *dj = d + (j * 2 + (size_t)a) * np;
            for (size_t p = 0; s == CSI_OK && p < np; p++)
                for (uint32_t ch = 0; cnt[p] && ch < channels; ch++) {
                    const double m = mean[ch * np + p], e1 = alt[ch * np + p] - m, e0 = def[ch * np + p] - m;
                    dj[p] += e1 * e1 - e0 * e0;
                }
        }
    }
    /* per pixel: the candidate its region (else its region of twice the side) takes, -1 none */
    for (size_t p = 0; s == CSI_OK && p < np; p++)
        pick[p] = -1;
    for (uint32_t side = CSI_CV_REGION; s == CSI_OK && side <= 2 * CSI_CV_REGION; side *= 2) {
        const size_t rw = (g->out_w + side - 1) / side, nr = rw * ((g->out_h + side - 1) / side);
        int *best = malloc(nr * sizeof *best);
        double *best_s = malloc(nr * sizeof *best_s);
        if (!best || !best_s) {
            free(best);
            free(best_s);
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu regions", nr);
            break;
        }
        for (size_t r = 0; r < nr; r++) {
            best[r] = -1;
            best_s[r] = 0;
        }
        for (size_t j = 0; j < nb; j++) {
            region_sums(g, d + (j * 2) * np, d + (j * 2 + 1) * np, side, acc);
            for (size_t r = 0; r < nr; r++) {
                const double s0 = acc[3 * r], s1 = acc[3 * r + 1], lim = CSI_CV_Z * sqrt(acc[3 * r + 2]);
                if (acc[3 * r + 2] > 0 && s0 < -lim && s1 < -lim && s0 + s1 < best_s[r]) {
                    best[r] = (int)j;
                    best_s[r] = s0 + s1;
                }
            }
        }
        for (size_t y = 0; y < g->out_h; y++)
            for (size_t x = 0; x < g->out_w; x++) {
                const size_t p = y * g->out_w + x;
                if (pick[p] < 0)
                    pick[p] = best[(y / side) * rw + x / side];
            }
        free(best);
        free(best_s);
    }
    /* the chosen candidates' images from all the samples */
    for (size_t j = 0; s == CSI_OK && j < nb; j++) {
        bool used = false;
        for (size_t p = 0; p < np && !used; p++)
            used = pick[p] == (int)j;
        if (used)
            s = solve_image(ctx, g, channels, pos, values, n, fold, 2, bins[j], opt, pbuf, vbuf, full + j * plane, out);
    }
    for (size_t p = 0; s == CSI_OK && p < np; p++)
        if (pick[p] >= 0) {
            out->motion_image_switched++;
            for (uint32_t ch = 0; ch < channels; ch++)
                out->image[ch * np + p] = full[(size_t)pick[p] * plane + ch * np + p];
        }
    free(fold);
    free(pbuf);
    free(vbuf);
    free(def);
    free(alt);
    free(full);
    free(d);
    free(mean);
    free(cnt);
    free(pick);
    free(acc);
    return s;
}
