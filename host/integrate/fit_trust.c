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
#include <stdatomic.h>
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
    return csi_fmin(csi_fmax(log(TRUST_R1 / ratio) / log(TRUST_R1 / TRUST_R0), 0.0), 1.0);
}

/* One call's inputs and per-pixel arrays, for its passes over bands of rows (csi/row_pool.h). */
typedef struct trust_state {
    const float *values, *fine_at, *box;
    const csi_sample_pos *pos;
    const size_t *start; /* each row's samples (csi_recon_sample_rows) */
    uint32_t channels, c;
    csi_pixel_map map;
    size_t ow, oh;
    double n0, e, eps;
    uint32_t *cnt;
    double *y, *gx;
    float *lo, *hi, *plane;
    atomic_bool unordered; /* a band's samples were not in row order */
} trust_state;

static void trust_clear(trust_state *t, size_t p0, size_t p1)
{
    for (size_t p = p0; p < p1; p++)
        t->cnt[p] = 0, t->y[p] = 0, t->gx[p] = 0, t->lo[p] = INFINITY, t->hi[p] = -INFINITY;
}

/* Each pixel's count, sums of values and of the fit at them, least and largest value, over
 * samples i0 .. i1 - 1; a band of rows [r0, r1) (check) stops, false, at a sample outside its
 * rows' order before writing anything of it (csi_recon_band_pixel). */
static bool trust_samples(trust_state *t, size_t i0, size_t i1, size_t r0, size_t r1, bool check)
{
    size_t last = r0;
    for (size_t i = i0; i < i1; i++) { /* in sample order: deterministic */
        const size_t p = check ? csi_recon_band_pixel(&t->map, t->pos[i], r1, &last)
                               : csi_recon_pixel_at(&t->map, t->pos[i]);
        if (p == SIZE_MAX)
            return false;
        const float v = t->values[i * t->channels + t->c];
        t->cnt[p]++;
        t->y[p] += v;
        t->gx[p] += t->fine_at[i];
        t->lo[p] = csi_fminf(t->lo[p], v);
        t->hi[p] = csi_fmaxf(t->hi[p], v);
    }
    return true;
}

static void trust_pass_samples(void *arg, size_t r0, size_t r1)
{
    trust_state *t = arg;
    trust_clear(t, r0 * t->ow, r1 * t->ow);
    if (!trust_samples(t, t->start[r0], t->start[r1], r0, r1, true))
        atomic_store(&t->unordered, true);
}

/* The fit's trust at each single-sample pixel, and the move towards the control variate. */
static void trust_pass_pixels(void *arg, size_t r0, size_t r1)
{
    trust_state *t = arg;
    const size_t ow = t->ow, oh = t->oh;
    size_t nb[9];
    for (size_t py = r0; py < r1; py++)
        for (size_t px = 0; px < ow; px++) {
            const size_t p = py * ow + px;
            if (t->cnt[p] != 1)
                continue;
            float l = INFINITY, h = -INFINITY, ho = -INFINITY; /* ho: the 8 neighbours' maximum */
            const int k = csi_recon_window3_at(px, py, ow, oh, nb);
            for (int j = 0; j < k; j++) {
                l = csi_fminf(l, t->lo[nb[j]]);
                h = csi_fmaxf(h, t->hi[nb[j]]);
                if (nb[j] != p)
                    ho = csi_fmaxf(ho, t->hi[nb[j]]);
            }
            /* CV with one sample, as cv_correct computes it, then onto the samples' range. */
            float cv = (float)((double)t->box[p] + (t->y[p] - t->gx[p]) / (1.0 + t->n0));
            cv = csi_fminf(csi_fmaxf(cv, l), h);
            const double e = t->e;
            double w_dark = ratio_weight((h + e) / (csi_fmax(t->lo[p], 0.0) + e));
            double w_peak = ratio_weight((csi_fmax(t->lo[p], 0.0) + e) / (csi_fmax(ho, 0.0) + e));
            double r = t->y[p] - t->gx[p], e2 = r * r / (t->y[p] * t->y[p] + t->eps);
            double w = w_dark * w_peak * (1.0 / (1.0 + e2 / (TRUST_TAU * TRUST_TAU)));
            t->plane[p] = (float)((1.0 - w) * t->plane[p] + w * cv);
        }
}

bool csi_recon_fit_trust_acts(const csi_grid *g, size_t multi)
{
    /* Where most pixels hold two samples or more the blend has measured its noise within the
     * pixels (blend.c), and the few single-sample pixels among them are its business: moving
     * them changed the Mitsuba dumps' Poisson-disk 4-spp cells by < 0.1%, in both directions.
     * With one cell per pixel the sample is exact. */
    const csi_pixel_map map = csi_recon_pixel_map(g);
    const bool full = (uint64_t)map.bw * map.bh * g->t <= 1;
    return 2 * multi < (size_t)g->out_w * g->out_h && !full;
}

csi_status csi_recon_fit_trust(const csi_grid *g, const float *values, uint32_t channels,
                               uint32_t c, const csi_sample_pos *pos, const float *fine_at,
                               size_t n, double n0, const float *box, csi_row_pool *pool, float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    trust_state t = {
        .values = values, .fine_at = fine_at, .box = box, .pos = pos, .channels = channels, .c = c,
        .map = csi_recon_pixel_map(g), .ow = ow, .oh = oh, .n0 = n0, .plane = plane,
    };
    atomic_init(&t.unordered, false);
    size_t *start = malloc((oh + 1) * sizeof *start);
    t.start = start;
    t.cnt = malloc(np * sizeof *t.cnt);
    t.y = malloc(np * sizeof *t.y), t.gx = malloc(np * sizeof *t.gx);
    t.lo = malloc(np * sizeof *t.lo), t.hi = malloc(np * sizeof *t.hi);
    if (!start || !t.cnt || !t.y || !t.gx || !t.lo || !t.hi) {
        free(start), free(t.cnt), free(t.y), free(t.gx), free(t.lo), free(t.hi);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the fit's trust");
    }
    csi_recon_sample_rows(g, pos, n, start);
    csi_row_pool_run(pool, oh, ow, trust_pass_samples, &t);
    if (atomic_load(&t.unordered)) {
        trust_clear(&t, 0, np);
        trust_samples(&t, 0, n, 0, oh, false);
    }
    size_t multi = 0;
    for (size_t p = 0; p < np; p++)
        multi += t.cnt[p] >= 2;
    if (csi_recon_fit_trust_acts(g, multi)) {
        double sabs = 0;
        for (size_t i = 0; i < n; i++) /* in sample order: the same sum */
            sabs += fabs((double)values[i * channels + c]);
        double mabs = 0;
        size_t filled = 0;
        for (size_t p = 0; p < np; p++)
            if (t.cnt[p]) {
                t.y[p] /= t.cnt[p];
                t.gx[p] /= t.cnt[p];
                mabs += fabs(t.y[p]);
                filled++;
            }
        /* floored as blend.c's eps: a channel whose samples are all 0 (a black image, the G and
         * B of a red one with --chroma off) would make both ratios 0 / 0 */
        t.e = csi_fmax(TRUST_EPS_REL * (n ? sabs / (double)n : 0.0), 1e-150);
        t.eps = csi_fmax(pow(filled ? TRUST_EPS_REL * mabs / (double)filled : 0.0, 2), 1e-300);
        csi_row_pool_run(pool, oh, ow, trust_pass_pixels, &t);
    }
    free(start), free(t.cnt), free(t.y), free(t.gx), free(t.lo), free(t.hi);
    return CSI_OK;
}
