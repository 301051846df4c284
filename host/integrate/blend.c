/* The final per-pixel estimate (csi_aa_correct CSI_CORRECT_BLEND in csi/reconstruct.h), and the
 * projection of Alg. 2's volume onto the samples' range. The blend: each
 * pixel is the box integral b of the fine estimate moved towards the mean m of the pixel's own
 * samples by a weight that the samples choose,
 *
 *     out = b + beta (m - b),   beta = B^2 / (B^2 + V),
 *
 * where V estimates the variance of m and B^2 the squared bias of b. This beta minimises
 * (1 - beta)^2 B^2 + beta^2 V, the risk of the blend when b's own noise is small against m's
 * (Stein's positive-part shrinkage of m towards b). Both come from the samples alone:
 *
 *   V = s^2 / n_p (1 - n_p / cells) + min(max((gbar - b)^2 - (gbar - m)^2, 0), (m / 2)^2).
 *       The first term is the sampling noise of m. s^2 is the per-sample variance: where most
 *       pixels hold two samples or more, the variance of the pixel's own samples; else (one
 *       sample per pixel) the second smallest of (m_p - m_q)^2 / 2 over the 8 neighbouring
 *       pixels q, divided by its expectation for independent Gaussian noise (the median of it
 *       over 3 x 3 pixels is 0.083 sigma^2, simulated), so that a thin line or an edge through
 *       the neighbourhood does not count as noise. s^2 is then the median over the 3 x 3
 *       pixels around, each relative to its pixel's magnitude, so that one edge pixel or one
 *       firefly does not set its neighbours' noise level; with one sample per pixel, the
 *       pixel's own estimate where it is lower (next to one very bright sample, a sun's glint,
 *       most of the 3 x 3 differences are large, and a large V handed the pixel to a fit that
 *       spreads the glint: horizon, 1 spp on Poisson-disk positions, 1.08x the mean's relMSE;
 *       docs/bench/mitsuba.md). The median goes back to the pixel's scale by its magnitude
 *       0.5 (m^2 + b^2): b, from the fit of many samples, does not share m's noise, so a pixel
 *       whose few samples all missed its bright part (m low) still gets the noise level of the
 *       light around it. Since |out - m| <= min(|b - m|, V / |b - m|) <= sqrt(V) (beta's form,
 *       with B^2 >= (m - b)^2 - V), that magnitude is also how far the fit may move the pixel
 *       from m. Where most pixels hold two samples or more, b counts in it only up to 4 times
 *       the brightest of the pixel's own samples. Up to there b may be light the samples
 *       missed (a fine texture whose bright parts fall between a pixel's stratified positions
 *       leaves four samples several times below the pixel, and the fit, a few times above
 *       them, is the better guess). Far above every one of them, b is more likely an
 *       emitter's light leaked from a neighbour, and scaled by the leak the noise level would
 *       judge the fit by its own bias (sub-pixel lamps on a dark sky: a pixel whose samples all
 *       saw the sky was handed to the leak). Whether the samples agree does not tell the two
 *       apart: a wet road's reflections beside a lamp spread a pixel's samples as much as its
 *       neighbours'. The two errors are not alike: distrusting b costs at most the mean's own
 *       error (a small lamp inside the pixel that all its single paths missed, where b was
 *       right), trusting a leak costs a dark pixel far more than the mean's relMSE. The
 *       bound, 4 (where the empty pixels' rule, csi/empty_pixels.h, starts to see an HDR
 *       step), lets the fit move such a pixel from m by at most 3 times its
 *       brightest sample times the square root of the window's median relative variance over
 *       n_p. With one sample per pixel, b keeps its whole weight: a single sample below the
 *       fit is most often a path that missed the light, the case b is in the magnitude for
 *       (docs/bench/mitsuba.md, sessions 12 and 13).
 *       With --blend-spread on (an option, off by default: docs/bench/mitsuba.md, session 13),
 *       where each sample's variance is given (several paths per sample: the records' variance,
 *       csi_recon_options.sample_variance) and a pixel's samples spread more than CSI_BLEND_SPREAD
 *       times the mean of their variances, the spread is where the samples fell, not noise: a
 *       step or a highlight inside the pixel that some samples hit and others missed. That is
 *       the mean's own error, s^2 / n_p for positions drawn at random in the pixel, which the
 *       window's median, made from the flat pixels around, does not see; the noise term is then
 *       at least that, scaled for stratification. Of n_p strata a straight step crosses
 *       sqrt(n_p) to 2 sqrt(n_p), each erring by its share 1 / n_p of the pixel, so the
 *       stratified mean's variance there is about 0.7 to 1.3 / sqrt(n_p) of s^2 / n_p; the
 *       scale 2 / sqrt(n_p), at most 1, lies between that and random positions' 1 (unscaled,
 *       it over-trusted the fit at 16 spp). Without the records' variance a large spread may as
 *       well be one path's noise, which s^2 of a few samples estimates too poorly to trust alone
 *       (single-path cells went above the mean), so the window's median stays.
 *       The finite-population factor makes V = 0, so out = m exactly, when every cell of the
 *       pixel is sampled.
 *       The second term is the error of m that its positions explain: gbar, the mean of the
 *       fine estimate g at the pixel's samples, differs from b as much as m differs from the
 *       truth wherever g is right (an edge that all of a pixel's samples missed, which the
 *       sample variance cannot see). It counts only beyond (gbar - m)^2, the fit's own misfit
 *       at those samples: a fit that does not pass near the pixel's samples (ringing between
 *       them: thin_geometry, 16 spp x 64 paths on Poisson-disk positions, 1.13x the mean's
 *       relMSE before this) says nothing about where between them the pixel's light lies.
 *       It is capped at (m/2)^2: a pixel is not taken to hide a region far brighter than
 *       everything its own samples saw, since that is also what a fit blurring a bright
 *       neighbour's light into a dark pixel looks like.
 *   B^2 = E(m - b)^2 - V, estimated three ways and the largest kept: the pixel's own
 *       (m - b)^2 - V, its mean over the 3 x 3 pixels, and the square of the mean of (m - b)
 *       over them less its variance (a bias of one sign over a region, as where an emitter's
 *       light leaks into its dark neighbours, stands out of noise that a pixel alone cannot),
 *       all relative to the pixels' magnitudes and clipped at 0.
 *
 * Before all this, b and the fine estimate at the samples are projected onto the range of the
 * samples in the pixel and its 8 neighbours: overshoot and ringing beyond anything the samples
 * near a pixel saw (a sharpened HDR edge) is not signal. Once the weights are chosen, b is also
 * projected onto the range of those 9 pixels' sample means: a box integral outside every mean
 * around it is the fit spreading one bright sample (a caustic path of radiance 10^4 among
 * values below 1: envmap, 4 spp on Poisson-disk positions, 1.20x the mean's relMSE without it)
 * rather than anything the means all missed. The weights are chosen before, so that B^2 still
 * sees how far b was from m (after, the projection hides part of b's bias and the weights
 * trust it more: the Cornell box at 4 spp, stratified, 1.15x the mean's MSE). Since m lies in
 * both ranges, so does the result: no halo and, for non-negative samples, no negative value.
 *
 * Every approximation errs towards m (smaller V, larger B^2): the mean is unbiased, the fine
 * estimate is not, and where they cannot be told apart the unbiased one is the safe choice.
 * When every sample of the channel is >= 0 the result is clamped at 0, which never increases
 * any pixel's error when the truth is non-negative. A pixel without a sample is moved from b
 * towards the median of its neighbours' means by the mean of their betas (and, beside an HDR
 * step, once all channels are done, possibly to its dark side: csi/empty_pixels.h). */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The magnitude below which pixels are treated alike when statistics are made relative, as a
 * fraction of the image's mean absolute value: 1% (the relMSE convention adds 0.01 to ref^2
 * for values of order 1, the same idea). */
#define CSI_BLEND_EPS_REL 1e-2
/* E[median over 3 x 3 pixels of the second smallest (y_p - y_q)^2 / 2 over the 8 neighbours q]
 * / sigma^2 for independent Gaussian noise of variance sigma^2 (simulated on 10^6 pixels). */
#define CSI_BLEND_NBR_CAL 0.083
/* How many times a pixel's brightest sample its box integral may count for in the noise
 * magnitude, where most pixels hold two samples or more (the header). */
#define CSI_BLEND_LEAK 4.0
/* A pixel's samples spread beyond their noise when their variance about m is above this many
 * times the mean of their given variances (the header): for four samples of Gaussian noise,
 * chi^2 with 3 degrees of freedom above 12, p ~ 0.007. */
#define CSI_BLEND_SPREAD 4.0

/* fmin and fmax inlined (the library's are calls), with their results for every argument: the
 * argument that is not NaN, and of two equal ones (+0 and -0) the second, as glibc's. */
static inline double lesser(double a, double b)
{
    return a < b ? a : isnan(b) ? a : b;
}
static inline double greater(double a, double b)
{
    return a > b ? a : isnan(b) ? a : b;
}
static inline float lesserf(float a, float b)
{
    return a < b ? a : isnan(b) ? a : b;
}
static inline float greaterf(float a, float b)
{
    return a > b ? a : isnan(b) ? a : b;
}

/* Ascending order of the at most 9 values of a window, in place (an insertion sort: qsort's
 * calls through a comparator were most of the blend's time at 1920x1080). The values are never
 * NaN, so the order, and every median taken from it, is the one any sort gives. */
static void sort_window(double *w, int m)
{
    for (int i = 1; i < m; i++) {
        const double v = w[i];
        int j = i;
        for (; j > 0 && w[j - 1] > v; j--)
            w[j] = w[j - 1];
        w[j] = v;
    }
}

/* The median of three values that are not NaN. */
static inline double median3(double a, double b, double c)
{
    const double lo = a < b ? a : b, hi = a < b ? b : a;
    return c < lo ? lo : c > hi ? hi : c;
}

/* The median of 9 values that are not NaN, without sorting them: of the rows of a 3 x 3 array,
 * the median lies between the largest of the rows' least values and the least of their largest,
 * and is the median of those two and the median of the rows' medians. Every value it returns is
 * one of the inputs, the one a sort puts in the middle (the values the blend takes medians of are
 * never -0, the only value equal to another with other bits). */
static double median9(const double *w)
{
    double lo[3], mid[3], hi[3];
    for (int r = 0; r < 3; r++) {
        const double a = w[3 * r], b = w[3 * r + 1], c = w[3 * r + 2];
        const double l = a < b ? a : b, h = a < b ? b : a;
        lo[r] = c < l ? c : l;
        hi[r] = c > h ? c : h;
        mid[r] = c < l ? l : c > h ? h : c;
    }
    const double lmax = lo[0] > lo[1] ? (lo[0] > lo[2] ? lo[0] : lo[2]) : (lo[1] > lo[2] ? lo[1] : lo[2]);
    const double hmin = hi[0] < hi[1] ? (hi[0] < hi[2] ? hi[0] : hi[2]) : (hi[1] < hi[2] ? hi[1] : hi[2]);
    return median3(lmax, median3(mid[0], mid[1], mid[2]), hmin);
}

/* The median of the non-NaN values among a[nb[0..k)]; INFINITY if there is none. */
static double window_median(const double *a, const size_t *nb, int k)
{
    double w[9];
    int m = 0;
    for (int i = 0; i < k; i++)
        if (!isnan(a[nb[i]]))
            w[m++] = a[nb[i]];
    if (!m)
        return INFINITY;
    if (m == 9)
        return median9(w);
    sort_window(w, m);
    return m % 2 ? w[m / 2] : 0.5 * (w[m / 2 - 1] + w[m / 2]);
}

/* After each pass over the image or the samples: the caller hears of it, and may stop here (a
 * pass over an image of tens of megapixels takes a second). */
#define BLEND_PASS_DONE()                                                                          \
    do {                                                                                           \
        if ((s = csi_recon_progress_channel_step(opt, "correct", c, channels, ++passes)) != CSI_OK) \
            goto done;                                                                             \
    } while (0)

csi_status csi_recon_blend(const csi_grid *g, const csi_recon_options *opt, const float *values,
                           uint32_t channels, uint32_t c, const csi_sample_pos *pos,
                           const float *fine_at, size_t n, bool clamp, float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const double cells = (double)bw * bh * g->t;
    size_t *cnt = calloc(np, sizeof *cnt);
    double *m = calloc(np, sizeof *m), *ss = calloc(np, sizeof *ss), *gbar = calloc(np, sizeof *gbar);
    double *sc = malloc(np * sizeof *sc), *rel = malloc(np * sizeof *rel);
    double *top = malloc(np * sizeof *top);
    double *V = malloc(np * sizeof *V), *q = malloc(np * sizeof *q), *d = malloc(np * sizeof *d);
    float *lo = malloc(np * sizeof *lo), *hi = malloc(np * sizeof *hi);
    uint32_t *pix = malloc((n ? n : 1) * sizeof *pix); /* each sample's pixel, divided out once */
    /* the sum of each pixel's given sample variances (calloc: 0, unused, when none is given) */
    double *vsum = calloc(np, sizeof *vsum);
    csi_status s = CSI_OK;
    int passes = 0;
    if (!cnt || !m || !ss || !gbar || !sc || !rel || !top || !V || !q || !d || !lo || !hi || !pix ||
        !vsum) {
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel blend");
        goto done;
    }
    for (size_t i = 0; i < n; i++)
        pix[i] = (uint32_t)csi_recon_pixel_of(pos[i], bw, bh, ow);
    /* The range of the samples in each pixel and its 8 neighbours (in V, q as scratch first):
     * b and the fine estimate at the samples are projected onto it. */
    for (size_t p = 0; p < np; p++)
        V[p] = INFINITY, q[p] = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        const size_t p = pix[i];
        V[p] = lesser(V[p], values[i * channels + c]);
        q[p] = greater(q[p], values[i * channels + c]);
    }
    /* The pixels' means and (two passes, in sample order: deterministic) sums of squares. */
    for (size_t i = 0; i < n; i++) {
        const size_t p = pix[i];
        cnt[p]++;
        m[p] += values[i * channels + c];
    }
    size_t multi = 0, filled = 0;
    double mabs = 0;
    for (size_t p = 0; p < np; p++) {
        if (cnt[p]) {
            m[p] /= (double)cnt[p];
            mabs += fabs(m[p]);
            filled++;
        }
        multi += cnt[p] >= 2;
    }
    BLEND_PASS_DONE();
    /* b onto the samples' range. */
    size_t nb[9];
    for (size_t p = 0; p < np; p++) {
        double l = INFINITY, h = -INFINITY;
        int k = csi_recon_window3(p, ow, oh, nb);
        for (int j = 0; j < k; j++) {
            l = lesser(l, V[nb[j]]);
            h = greater(h, q[nb[j]]);
        }
        lo[p] = l <= h ? (float)l : -INFINITY; /* no sample around: nothing to project onto */
        hi[p] = l <= h ? (float)h : INFINITY;
        plane[p] = lesserf(greaterf(plane[p], lo[p]), hi[p]);
    }
    BLEND_PASS_DONE();
    for (size_t i = 0; i < n; i++) {
        const size_t p = pix[i];
        gbar[p] += lesserf(greaterf(fine_at[i], lo[p]), hi[p]);
    }
    for (size_t p = 0; p < np; p++)
        if (cnt[p])
            gbar[p] /= (double)cnt[p];
    for (size_t i = 0; i < n; i++) {
        const size_t p = pix[i];
        double e = values[i * channels + c] - m[p];
        ss[p] += e * e;
        if (opt->blend_spread == CSI_SWITCH_ON && opt->sample_variance)
            vsum[p] += opt->sample_variance[i * channels + c];
    }
    BLEND_PASS_DONE();
    const bool by_pixel = 2 * multi >= np;
    const double eps = greater(pow(CSI_BLEND_EPS_REL * (filled ? mabs / (double)filled : 0.0), 2), 1e-300);
    for (size_t p = 0; p < np; p++) {
        const double b = plane[p], mm = cnt[p] ? m[p] : b;
        sc[p] = 0.5 * (mm * mm + b * b) + eps;
        double s2 = NAN;
        if (by_pixel) {
            if (cnt[p] >= 2)
                s2 = ss[p] / (double)(cnt[p] - 1);
        } else if (cnt[p]) {
            double d1 = INFINITY, d2 = INFINITY; /* the two smallest neighbour differences */
            int k = csi_recon_window3(p, ow, oh, nb);
            for (int j = 0; j < k; j++) {
                if (nb[j] == p || !cnt[nb[j]])
                    continue;
                double e = 0.5 * (m[p] - m[nb[j]]) * (m[p] - m[nb[j]]);
                if (e < d1) {
                    d2 = d1;
                    d1 = e;
                } else if (e < d2) {
                    d2 = e;
                }
            }
            if (isfinite(d2))
                s2 = d2 / CSI_BLEND_NBR_CAL;
        }
        rel[p] = s2 / sc[p];
        /* the pixel's brightest sample (V and q still hold the least and largest of its
         * samples here) */
        top[p] = greater(fabs(V[p]), fabs(q[p]));
    }
    BLEND_PASS_DONE();
    /* V, relative to the pixel's magnitude: the window's median per-sample variance over n_p
     * (0 where no pixel around has a variance: m is then taken as it is), plus the error that
     * the positions explain. */
    for (size_t p = 0; p < np; p++) {
        if (!cnt[p]) {
            V[p] = INFINITY;
            continue;
        }
        double fpc = 1.0 - (double)cnt[p] / cells;
        double med = window_median(rel, nb, csi_recon_window3(p, ow, oh, nb));
        if (!by_pixel && !isnan(rel[p]))
            med = lesser(med, rel[p]); /* one sample per pixel: the pixel's own where lower */
        double noise = fpc > 0 && isfinite(med) ? med / (double)cnt[p] * fpc : 0.0;
        if (by_pixel && cnt[p] >= 2) {
            /* b only up to a few times the pixel's brightest sample (the header) */
            double bc = lesser(fabs(plane[p]), CSI_BLEND_LEAK * top[p]);
            noise *= (0.5 * (m[p] * m[p] + bc * bc) + eps) / sc[p];
            const double s2 = ss[p] / (double)(cnt[p] - 1);
            if (opt->blend_spread == CSI_SWITCH_ON && opt->sample_variance &&
                s2 > CSI_BLEND_SPREAD * vsum[p] / (double)cnt[p]) {
                /* a spread beyond the records' noise: at least the mean's own error (the header) */
                const double strat = lesser(1.0, 2.0 / sqrt((double)cnt[p]));
                noise = greater(noise, s2 / sc[p] / (double)cnt[p] * fpc * strat);
            }
        }
        double pe = gbar[p] - plane[p], mf = gbar[p] - m[p];
        V[p] = noise + lesser(greater(pe * pe - mf * mf, 0.0), 0.25 * m[p] * m[p]) / sc[p];
    }
    BLEND_PASS_DONE();
    /* The relative bias of b seen at each pixel: d signed, q squared less noise, clipped at 0. */
    for (size_t p = 0; p < np; p++) {
        double diff = cnt[p] ? m[p] - plane[p] : 0.0;
        d[p] = diff / sqrt(sc[p]);
        double e = cnt[p] && isfinite(V[p]) ? d[p] * d[p] - V[p] : 0.0;
        q[p] = e > 0 ? e : 0.0;
    }
    /* beta per pixel with samples (kept in rel, no longer needed), then the blend. */
    for (size_t p = 0; p < np; p++) {
        rel[p] = NAN;
        if (!cnt[p])
            continue;
        int k = csi_recon_window3(p, ow, oh, nb), kf = 0;
        double qs = 0, ds = 0, vs = 0;
        for (int j = 0; j < k; j++) {
            qs += q[nb[j]];
            if (cnt[nb[j]]) {
                ds += d[nb[j]];
                vs += isfinite(V[nb[j]]) ? V[nb[j]] : 0.0;
                kf++;
            }
        }
        double dbar = ds / kf;
        double B2 = greater(greater(qs / k, q[p]), dbar * dbar - vs / kf / kf);
        rel[p] = B2 + V[p] > 0 ? B2 / (B2 + V[p]) : 1.0;
    }
    BLEND_PASS_DONE();
    /* b onto the range of the 3 x 3 pixels' means (after the weights, which see b's distance
     * from m before it), then the blend. */
    for (size_t p = 0; p < np; p++) {
        double ml = INFINITY, mh = -INFINITY;
        int k = csi_recon_window3(p, ow, oh, nb);
        for (int j = 0; j < k; j++)
            if (cnt[nb[j]]) {
                ml = lesser(ml, m[nb[j]]);
                mh = greater(mh, m[nb[j]]);
            }
        if (ml <= mh)
            plane[p] = (float)lesser(greater(plane[p], ml), mh);
    }
    BLEND_PASS_DONE();
    for (size_t p = 0; p < np; p++) {
        double out = plane[p];
        if (cnt[p] && (double)cnt[p] >= cells) {
            out = m[p]; /* every cell sampled: the exact cell mean (beta is 1 here anyway) */
        } else if (cnt[p]) {
            out = plane[p] + rel[p] * (m[p] - plane[p]);
        } else {
            /* No sample of its own: the median of the neighbours' means, trusted as much as
             * the neighbours trust their own (b alone leaks a bright neighbour's light into an
             * unsampled dark pixel as readily as into a sampled one). */
            double w[9], bs = 0;
            int k = csi_recon_window3(p, ow, oh, nb), kf = 0;
            for (int j = 0; j < k; j++)
                if (cnt[nb[j]]) {
                    w[kf++] = m[nb[j]];
                    bs += rel[nb[j]];
                }
            if (kf) {
                sort_window(w, kf);
                double med = kf % 2 ? w[kf / 2] : 0.5 * (w[kf / 2 - 1] + w[kf / 2]);
                out = plane[p] + bs / kf * (med - plane[p]);
            }
        }
        if (clamp && out < 0)
            out = 0;
        plane[p] = (float)out;
    }
done:
    free(cnt), free(m), free(ss), free(gbar), free(sc), free(rel), free(V), free(q), free(d);
    free(top), free(lo), free(hi), free(pix), free(vsum);
    return s;
}
#undef BLEND_PASS_DONE

void csi_recon_exact_full(const csi_grid *g, const float *values, uint32_t channels, uint32_t c,
                          const csi_sample_pos *pos, size_t n, float *plane)
{
    const size_t ow = g->out_w, np = ow * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t cells = (size_t)bw * bh * g->t;
    size_t *cnt = calloc(np, sizeof *cnt);
    double *sum = calloc(np, sizeof *sum);
    if (cnt && sum) {
        for (size_t i = 0; i < n; i++) {
            size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
            cnt[p]++;
            sum[p] += values[i * channels + c];
        }
        for (size_t p = 0; p < np; p++)
            if (cnt[p] == cells)
                plane[p] = (float)(sum[p] / (double)cells);
    }
    /* Out of memory: the fit's pixels stay, which is what the caller had. */
    free(cnt);
    free(sum);
}
