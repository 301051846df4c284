/* The blend's last step on a still image (csi_aa_correct CSI_CORRECT_BLEND in csi/reconstruct.h):
 * a pixel holding one sample moves from the blend's value towards the control variate (CV) by
 * a weight w that says how far the fit can be trusted there, from the samples alone:
 *
 *     out = blend + w (c - blend),   c = b + (y - g(x)) / (1 + n0), projected onto the range of
 *                                         the samples in the pixel and its 8 neighbours,
 *     w = w_fit * w_dark * w_peak,
 *     w_fit  = 1 / (1 + e^2 / TAU^2),        e^2 = (y - g(x))^2 / (y^2 + eps): the fit's relative
 *                                            misfit at the pixel's own sample,
 *     w_dark = clamp(log(R1 / R) / log(R1 / R0), 0, 1),  R = (max of the samples in the 3 x 3
 *                                            pixels + e) / (y + e): how much darker the pixel's
 *                                            sample is than the brightest one around it;
 *     w_peak = the same of (y + e) / (max of the 8 neighbours' samples + e).
 *
 * Why. With one sample a pixel's mean is a point value, and its error is the signal's variation
 * over the pixel (aliasing) as much as any noise; the blend's noise estimate (from neighbouring
 * means) sees little of it and hands such pixels to their one sample, where the fit, which has seen
 * the sub-pixel structure, predicts the box better: CV's image beat the blend's on lightly noisy
 * samples (ambient occlusion) and on most single-path Mitsuba images at 1 spp, yet lost badly in
 * relMSE in pixels that are dark next to a bright neighbour, where the fit leaks or rings, and in
 * MSE around isolated bright samples (a glint), which it spreads (docs/bench/mitsuba.md). w trusts
 * the fit where none of its failures can be present: where it passes through the pixel's own sample
 * (a fit that misses its samples says nothing about the box between them), where the pixel is not
 * much darker than what is around it (a leak of a few percent of a 100:1 step is a 100% error in
 * the dark pixel) and where its sample is not much brighter than every neighbour's (w_peak, the
 * same ratio the other way). Noise alone is not what separates the two estimators: the fit
 * absorbs most of the noise, so the residuals' spread within a pixel hardly sees it, and textures
 * make noise-free samples differ from their neighbours as much as Monte Carlo noise does
 * (docs/bench/mitsuba.md). Pixels with two samples or more keep the blend: its within-pixel
 * variance sees their aliasing, and CV there made the Cornell box at 4 spp worse than the mean.
 * So does every pixel of an image where most pixels hold two samples or more (below).
 *
 * The result stays in the range of the samples around (both terms do), so it is non-negative
 * for non-negative samples; pixels with no sample or more than one are untouched, and so is a
 * pixel of a single cell (its one sample is its exact mean). */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The relative misfit at which the fit is trusted half: 30% of the sample's value. Measured at
 * 0.1, 0.3, 0.5 and 1 on garden and the Cornell box at 1 spp x 64 paths: 0.3 was the
 * largest that left the latter's relMSE below the blend's (0.866x the mean's against 0.908x;
 * 0.5: 0.94x). */
#define TRUST_TAU 0.3
/* The darkness ratio below which the fit is trusted fully, and above which not at all: a pixel
 * 4x darker than its brightest neighbour's sample is within the range of ordinary shading (a
 * diffuse wall in and out of shadow); 16x is the start of the HDR steps the fit rings on (an
 * emitter, a sun's glint: 100:1 to 1000:1). */
#define TRUST_R0 4.0
#define TRUST_R1 16.0
/* The offsets that keep both ratios finite at 0, as a fraction of the mean absolute value (of
 * the samples for R, of the pixel means for e^2): the 1% of blend.c's CSI_BLEND_EPS_REL. */
#define TRUST_EPS_REL 1e-2

/* 1 up to a ratio of R0, 0 from R1, linear in log(ratio) between. */
static double ratio_weight(double ratio)
{
    return fmin(fmax(log(TRUST_R1 / ratio) / log(TRUST_R1 / TRUST_R0), 0.0), 1.0);
}

csi_status csi_recon_fit_trust(const csi_grid *g, const float *values, uint32_t channels,
                               uint32_t c, const csi_sample_pos *pos, const float *fine_at,
                               size_t n, double n0, const float *box, float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *y = calloc(np, sizeof *y), *gx = calloc(np, sizeof *gx);
    float *lo = malloc(np * sizeof *lo), *hi = malloc(np * sizeof *hi);
    if (!cnt || !y || !gx || !lo || !hi) {
        free(cnt), free(y), free(gx), free(lo), free(hi);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the fit's trust");
    }
    double sabs = 0;
    for (size_t p = 0; p < np; p++)
        lo[p] = INFINITY, hi[p] = -INFINITY;
    for (size_t i = 0; i < n; i++) { /* in sample order: deterministic */
        size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
        float v = values[i * channels + c];
        cnt[p]++;
        y[p] += v;
        gx[p] += fine_at[i];
        lo[p] = fminf(lo[p], v);
        hi[p] = fmaxf(hi[p], v);
        sabs += fabs((double)v);
    }
    /* Where most pixels hold two samples or more the blend has measured its noise within the
     * pixels (blend.c), and the few single-sample pixels among them are its business: moving
     * them changed the Mitsuba dumps' Poisson-disk 4-spp cells by < 0.1%, in both directions. */
    size_t multi = 0;
    for (size_t p = 0; p < np; p++)
        multi += cnt[p] >= 2;
    if (2 * multi >= np) {
        free(cnt), free(y), free(gx), free(lo), free(hi);
        return CSI_OK;
    }
    double mabs = 0;
    size_t filled = 0;
    for (size_t p = 0; p < np; p++)
        if (cnt[p]) {
            y[p] /= cnt[p];
            gx[p] /= cnt[p];
            mabs += fabs(y[p]);
            filled++;
        }
    const double e = TRUST_EPS_REL * (n ? sabs / (double)n : 0.0);
    const double eps = pow(filled ? TRUST_EPS_REL * mabs / (double)filled : 0.0, 2);
    const bool full = (uint64_t)bw * bh * g->t <= 1; /* one cell per pixel: the sample is exact */
    for (size_t p = 0; p < np; p++) {
        if (cnt[p] != 1 || full)
            continue;
        long px = (long)(p % ow), py = (long)(p / ow);
        float l = INFINITY, h = -INFINITY, ho = -INFINITY; /* ho: the 8 neighbours' maximum */
        for (long dy = -1; dy <= 1; dy++)
            for (long dx = -1; dx <= 1; dx++) {
                long x = px + dx, yy = py + dy;
                if (x < 0 || yy < 0 || x >= (long)ow || yy >= (long)oh)
                    continue;
                l = fminf(l, lo[(size_t)yy * ow + (size_t)x]);
                h = fmaxf(h, hi[(size_t)yy * ow + (size_t)x]);
                if (dx || dy)
                    ho = fmaxf(ho, hi[(size_t)yy * ow + (size_t)x]);
            }
        /* CV with one sample, as cv_correct computes it, then onto the samples' range. */
        float cv = (float)((double)box[p] + (y[p] - gx[p]) / (1.0 + n0));
        cv = fminf(fmaxf(cv, l), h);
        double w_dark = ratio_weight((h + e) / (fmax(lo[p], 0.0) + e));
        double w_peak = ratio_weight((fmax(lo[p], 0.0) + e) / (fmax(ho, 0.0) + e));
        double r = y[p] - gx[p], e2 = r * r / (y[p] * y[p] + eps);
        double w = w_dark * w_peak * (1.0 / (1.0 + e2 / (TRUST_TAU * TRUST_TAU)));
        plane[p] = (float)((1.0 - w) * plane[p] + w * cv);
    }
    free(cnt), free(y), free(gx), free(lo), free(hi);
    return CSI_OK;
}
