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
 *       the brightest of the pixel's own samples, and in a pixel of one sample up to 16 times
 *       that sample (Poisson-disk positions at 2 spp leave many: there a fit spreading a lamp,
 *       a highlight or the sky into one took its own magnitude as the noise level, up to 2.2x
 *       the mean's relMSE at 2 spp, docs/bench/mitsuba.md; the price is the fit's light in
 *       such a pixel on the dark side of an emitter's rim, which no arrangement of the
 *       neighbours told from a thin dark blade's). Up to there b may be light the samples
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
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

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
/* The same for a pixel of one sample among pixels of more: one sample is a poorer bound on its
 * pixel's level than the brightest of several, so the fit may stand further above it; 16 is
 * where the empty pixels' cap (csi/empty_pixels.h) takes a ratio for an HDR step. */
#define CSI_BLEND_LEAK_ONE 16.0
/* A pixel's samples spread beyond their noise when their variance about m is above this many
 * times the mean of their given variances (the header): for four samples of Gaussian noise,
 * chi^2 with 3 degrees of freedom above 12, p ~ 0.007. */
#define CSI_BLEND_SPREAD 4.0

/* Four selections, each exactly its ternary for every input (NaN, -0 and ties included):
 *
 *   lt_min(a, b) = a < b ? a : b,         gt_max(a, b) = a > b ? a : b,
 *   run_min(acc, v) = v <= acc ? v : acc, run_max(acc, v) = v >= acc ? v : acc.
 *
 * The first two are x86's minsd and maxsd. The last two are csi_fmin(acc, v) and csi_fmax(acc, v)
 * for a running bound acc that is never NaN (one started at +-INFINITY): v where it is not NaN and
 * at or beyond acc (of two equal values the second, as csi_fmin's), else acc. Written in SSE2's
 * instructions where the target has them: from the ternaries the compiler branches (wherever one
 * comparison chooses two values, as lt_min(a, b) beside gt_max(b, a), or a bound in memory is
 * rewritten), and on noisy values such a branch mispredicts about half the time (the blend took
 * 1.7x the CPU with them: csi-bench-blend, docs/bench/cost.md, session 29). */
#ifdef __SSE2__
static inline double lt_min(double a, double b)
{
    return _mm_cvtsd_f64(_mm_min_sd(_mm_set_sd(a), _mm_set_sd(b)));
}
static inline double gt_max(double a, double b)
{
    return _mm_cvtsd_f64(_mm_max_sd(_mm_set_sd(a), _mm_set_sd(b)));
}
/* v where the comparison's mask is set, else acc */
static inline double masked(__m128d take, double v, double acc)
{
    return _mm_cvtsd_f64(_mm_or_pd(_mm_and_pd(take, _mm_set_sd(v)), _mm_andnot_pd(take, _mm_set_sd(acc))));
}
static inline double run_min(double acc, double v)
{
    return masked(_mm_cmple_sd(_mm_set_sd(v), _mm_set_sd(acc)), v, acc);
}
static inline double run_max(double acc, double v)
{
    return masked(_mm_cmpge_sd(_mm_set_sd(v), _mm_set_sd(acc)), v, acc);
}
#else
#define lt_min(a, b) ((a) < (b) ? (a) : (b))
#define gt_max(a, b) ((a) > (b) ? (a) : (b))
#define run_min(acc, v) ((v) <= (acc) ? (v) : (acc))
#define run_max(acc, v) ((v) >= (acc) ? (v) : (acc))
#endif

/* csi_fminf(csi_fmaxf(v, lo), hi) for lo and hi that are not NaN (v may be): maxss, then minss. */
static inline float clampf(float v, float lo, float hi)
{
    const float t = v > lo ? v : lo;
    return t < hi ? t : hi;
}

/* Whether the pixel at column x, row y of an ow x oh image is inside its border: its 3 x 3 window
 * is whole, the j-th of its pixels (j < 9) window3_inside(p, ow, j), in csi_recon_window3_at's
 * order (rows from the top, each from the left). The passes loop over these nine apart from the
 * border's list: one loop over a neighbour list filled either way took the blend 1.25x the CPU
 * (csi-bench-blend; the compiler unrolls only a loop of known count). */
static inline bool inside(size_t x, size_t y, size_t ow, size_t oh)
{
    return x > 0 && y > 0 && x + 1 < ow && y + 1 < oh;
}
static inline size_t window3_inside(size_t p, size_t ow, int j)
{
    return p + (size_t)(j / 3 - 1) * ow + (size_t)(j % 3) - 1; /* wraps below p, then adds back */
}

/* The median of three values that are not NaN: the third clamped to the range of the first two
 * (c < lo ? lo : c > hi ? hi : c, in minsd and maxsd). */
static inline double median3(double a, double b, double c)
{
    const double lo = lt_min(a, b), hi = gt_max(b, a);
    return lt_min(hi, gt_max(lo, c));
}

/* The median of 9 values that are not NaN, without sorting them: of the rows of a 3 x 3 array,
 * the median lies between the largest of the rows' least values and the least of their largest,
 * and is the median of those two and the median of the rows' medians. Every value it returns is
 * one of the inputs, the one a sort puts in the middle (the values the blend takes medians of are
 * never -0, the only value equal to another with other bits). */
static double median9(const double *w)
{
    double lo[3], mid[3], hi[3];
#pragma GCC unroll 3
    for (int r = 0; r < 3; r++) {
        const double a = w[3 * r], b = w[3 * r + 1], c = w[3 * r + 2];
        const double l = lt_min(a, b), h = gt_max(b, a);
        lo[r] = lt_min(c, l);
        hi[r] = gt_max(c, h);
        mid[r] = lt_min(h, gt_max(l, c));
    }
    const double lmax = gt_max(gt_max(lo[0], lo[1]), lo[2]);
    const double hmin = lt_min(lt_min(hi[0], hi[1]), hi[2]);
    return median3(lmax, median3(mid[0], mid[1], mid[2]), hmin);
}

/* The k-th smallest (from 1) of m <= 9 values that are not NaN: median9 of them with 5 - k
 * values of -INFINITY and 4 - m + k of +INFINITY beside them, which puts the k-th in the middle
 * (an infinite value among the m is the same bits as the padding, so ties do not matter). */
static double kth_of9(const double *w, int m, int k)
{
    double a[9];
    int j = 0;
    for (int i = 0; i < 5 - k; i++)
        a[j++] = -INFINITY;
    for (int i = 0; i < m; i++)
        a[j++] = w[i];
    while (j < 9)
        a[j++] = INFINITY;
    return median9(a);
}

/* The median of m values (1 <= m <= 9, none NaN): the middle one, or the mean of the two in the
 * middle (what a sort's w[m / 2] or 0.5 (w[m / 2 - 1] + w[m / 2]) gives). */
static double median_upto9(const double *w, int m)
{
    if (m == 9)
        return median9(w);
    if (m % 2)
        return kth_of9(w, m, m / 2 + 1);
    return 0.5 * (kth_of9(w, m, m / 2) + kth_of9(w, m, m / 2 + 1));
}

/* The median of the non-NaN values among a[nb[0..k)]; INFINITY if there is none. */
static double window_median(const double *a, const size_t *nb, int k)
{
    double w[9];
    int m = 0;
    for (int i = 0; i < k; i++)
        if (!isnan(a[nb[i]]))
            w[m++] = a[nb[i]];
    return m ? median_upto9(w, m) : INFINITY;
}

/* The same over the window of a pixel p inside the image (inside()), unrolled: each value is
 * written at w[m], and kept (m advanced) unless it is NaN. */
static double window_median_inside(const double *a, size_t p, size_t ow)
{
    double w[9];
    int m = 0;
#pragma GCC unroll 9
    for (int j = 0; j < 9; j++) {
        const double v = a[window3_inside(p, ow, j)];
        w[m] = v;
        m += !isnan(v);
    }
    return m ? median_upto9(w, m) : INFINITY;
}

/* One blend's inputs, its per-pixel arrays and the whole image's figures, for its passes over
 * bands of rows (csi/row_pool.h). Each pass writes only its band's pixels and reads its
 * neighbours' values from passes before it, so bands give the same bits in any split. */
typedef struct blend_state {
    const csi_recon_options *opt;
    const float *values, *fine_at;
    const csi_sample_pos *pos;
    const size_t *start; /* each row's samples (csi_recon_sample_rows) */
    uint32_t channels, c;
    csi_pixel_map map;
    size_t n, ow, oh;
    double cells, eps;
    bool by_pixel, spread, clamp;
    float *plane;
    size_t *cnt;
    uint32_t *pix; /* each sample's pixel, divided out once */
    double *m, *ss, *gbar, *sc, *rel, *top, *V, *q, *d, *vsum;
    float *lo, *hi;
    atomic_bool unordered; /* a band's samples were not in row order */
} blend_state;

/* Each pixel's samples i0 .. i1 - 1: their pixels, least and largest values (in V and q), counts
 * and sums. A band of rows [r0, r1) (check) stops, false, at a sample outside its rows' order
 * before writing anything of it (csi_recon_band_pixel). */
static bool blend_samples_first(blend_state *b, size_t i0, size_t i1, size_t r0, size_t r1, bool check)
{
    const float *values = b->values;
    const csi_sample_pos *pos = b->pos;
    const uint32_t channels = b->channels, c = b->c;
    const csi_pixel_map map = b->map;
    uint32_t *pix = b->pix;
    size_t *cnt = b->cnt;
    double *V = b->V, *q = b->q, *m = b->m;
    size_t last = r0;
    for (size_t i = i0; i < i1; i++) {
        const size_t p = check ? csi_recon_band_pixel(&map, pos[i], r1, &last)
                               : csi_recon_pixel_at(&map, pos[i]);
        if (p == SIZE_MAX)
            return false;
        const double v = values[i * channels + c];
        pix[i] = (uint32_t)p;
        V[p] = run_min(V[p], v);
        q[p] = run_max(q[p], v);
        cnt[p]++;
        m[p] += v;
    }
    return true;
}

static void blend_pixels_clear(blend_state *b, size_t p0, size_t p1)
{
    for (size_t p = p0; p < p1; p++)
        b->V[p] = INFINITY, b->q[p] = -INFINITY, b->cnt[p] = 0, b->m[p] = 0;
}

/* Sums over pixels p0 .. p1 - 1's samples made means (pixels without a sample keep 0). */
static void sums_to_means(double *sum, const size_t *cnt, size_t p0, size_t p1)
{
    for (size_t p = p0; p < p1; p++)
        if (cnt[p])
            sum[p] /= (double)cnt[p];
}

/* Pass 1 over a band: the pixels' sample statistics and means. */
static void blend_pass1(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    blend_pixels_clear(b, r0 * b->ow, r1 * b->ow);
    if (!blend_samples_first(b, b->start[r0], b->start[r1], r0, r1, true)) {
        atomic_store(&b->unordered, true);
        return;
    }
    sums_to_means(b->m, b->cnt, r0 * b->ow, r1 * b->ow);
}

/* b onto the range of the samples in the pixel and its 8 neighbours. */
static void blend_range(blend_state *b, size_t r0, size_t r1)
{
    const size_t ow = b->ow, oh = b->oh;
    const double *V = b->V, *q = b->q;
    float *lo = b->lo, *hi = b->hi, *plane = b->plane;
    size_t nb[9];
    for (size_t y = r0; y < r1; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x;
            double l = INFINITY, h = -INFINITY;
            if (inside(x, y, ow, oh)) {
#pragma GCC unroll 9
                for (int j = 0; j < 9; j++) {
                    const size_t i = window3_inside(p, ow, j);
                    l = run_min(l, V[i]);
                    h = run_max(h, q[i]);
                }
            } else {
                const int k = csi_recon_window3_at(x, y, ow, oh, nb);
                for (int j = 0; j < k; j++) {
                    l = run_min(l, V[nb[j]]);
                    h = run_max(h, q[nb[j]]);
                }
            }
            lo[p] = l <= h ? (float)l : -INFINITY; /* no sample around: nothing to project onto */
            hi[p] = l <= h ? (float)h : INFINITY;
            plane[p] = clampf(plane[p], lo[p], hi[p]);
        }
}

/* The mean of the fine estimate at each pixel's samples (onto the range above) and the sums of
 * the samples' squared distances from their mean (and of their given variances). */
static void blend_samples_second(blend_state *b, size_t i0, size_t i1)
{
    const float *values = b->values, *fine_at = b->fine_at, *lo = b->lo, *hi = b->hi;
    const uint32_t channels = b->channels, c = b->c, *pix = b->pix;
    const float *var = b->spread ? b->opt->sample_variance : NULL;
    const double *m = b->m;
    double *gbar = b->gbar, *ss = b->ss, *vsum = b->vsum;
    for (size_t i = i0; i < i1; i++) {
        const size_t p = pix[i];
        gbar[p] += clampf(fine_at[i], lo[p], hi[p]);
        const double e = values[i * channels + c] - m[p];
        ss[p] += e * e;
        if (var)
            vsum[p] += var[i * channels + c];
    }
}

static void blend_pixels_second_clear(blend_state *b, size_t p0, size_t p1)
{
    for (size_t p = p0; p < p1; p++)
        b->gbar[p] = 0, b->ss[p] = 0, b->vsum[p] = 0;
}

/* Pass 2 over a band whose samples are in row order: the range, then the samples' second pass. */
static void blend_pass2(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    blend_range(b, r0, r1);
    blend_pixels_second_clear(b, r0 * b->ow, r1 * b->ow);
    blend_samples_second(b, b->start[r0], b->start[r1]);
    sums_to_means(b->gbar, b->cnt, r0 * b->ow, r1 * b->ow);
}

/* Pass 2 where the samples are not in row order: the range alone (the samples after it, on the
 * calling thread). */
static void blend_pass2_range(void *arg, size_t r0, size_t r1)
{
    blend_range(arg, r0, r1);
}

/* Pass 3: each pixel's magnitude, its relative per-sample variance and its brightest sample. */
static void blend_pass3(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    const size_t ow = b->ow, oh = b->oh, *cnt = b->cnt;
    const bool by_pixel = b->by_pixel;
    const double eps = b->eps, *m = b->m, *ss = b->ss, *V = b->V, *q = b->q;
    const float *plane = b->plane;
    double *sc = b->sc, *rel = b->rel, *top = b->top;
    size_t nb[9];
    for (size_t y = r0; y < r1; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x;
            const double bb = plane[p], mm = cnt[p] ? m[p] : bb;
            sc[p] = 0.5 * (mm * mm + bb * bb) + eps;
            double s2 = NAN;
            if (by_pixel) {
                if (cnt[p] >= 2)
                    s2 = ss[p] / (double)(cnt[p] - 1);
            } else if (cnt[p]) {
                double d1 = INFINITY, d2 = INFINITY; /* the two smallest neighbour differences */
                const int k = csi_recon_window3_at(x, y, ow, oh, nb);
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
            top[p] = csi_fmax(fabs(V[p]), fabs(q[p]));
        }
}

/* Pass 4: V, relative to the pixel's magnitude: the window's median per-sample variance over n_p
 * (0 where no pixel around has a variance: m is then taken as it is), plus the error that the
 * positions explain; then the relative bias of b seen at the pixel: d signed, q squared less
 * noise, clipped at 0. */
static void blend_pass4(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    const size_t ow = b->ow, oh = b->oh, *cnt = b->cnt;
    const bool by_pixel = b->by_pixel, spread = b->spread;
    const double eps = b->eps, cells = b->cells, *m = b->m, *ss = b->ss, *rel = b->rel, *top = b->top;
    const double *sc = b->sc, *gbar = b->gbar, *vsum = b->vsum;
    const float *plane = b->plane;
    double *V = b->V, *q = b->q, *d = b->d;
    size_t nb[9];
    for (size_t y = r0; y < r1; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x, cp = cnt[p];
            if (!cp) {
                V[p] = INFINITY;
            } else {
                double fpc = 1.0 - (double)cp / cells;
                double med = inside(x, y, ow, oh) ? window_median_inside(rel, p, ow)
                                                  : window_median(rel, nb, csi_recon_window3_at(x, y, ow, oh, nb));
                if (!by_pixel && !isnan(rel[p]))
                    med = csi_fmin(med, rel[p]); /* one sample per pixel: the pixel's own where lower */
                double noise = fpc > 0 && isfinite(med) ? med / (double)cp * fpc : 0.0;
                if (by_pixel) {
                    /* b only up to a few times the pixel's brightest sample (the header) */
                    const double leak = cp >= 2 ? CSI_BLEND_LEAK : CSI_BLEND_LEAK_ONE;
                    double bc = csi_fmin(fabs(plane[p]), leak * top[p]);
                    noise *= (0.5 * (m[p] * m[p] + bc * bc) + eps) / sc[p];
                }
                if (by_pixel && cp >= 2) {
                    const double s2 = ss[p] / (double)(cp - 1);
                    if (spread && s2 > CSI_BLEND_SPREAD * vsum[p] / (double)cp) {
                        /* a spread beyond the records' noise: at least the mean's own error (the
                         * header) */
                        const double strat = csi_fmin(1.0, 2.0 / sqrt((double)cp));
                        noise = csi_fmax(noise, s2 / sc[p] / (double)cp * fpc * strat);
                    }
                }
                double pe = gbar[p] - plane[p], mf = gbar[p] - m[p];
                V[p] = noise + csi_fmin(csi_fmax(pe * pe - mf * mf, 0.0), 0.25 * m[p] * m[p]) / sc[p];
            }
            double diff = cp ? m[p] - plane[p] : 0.0;
            d[p] = diff / sqrt(sc[p]);
            double e = cp && isfinite(V[p]) ? d[p] * d[p] - V[p] : 0.0;
            q[p] = e > 0 ? e : 0.0;
        }
}

/* Pass 5: beta per pixel with samples (kept in rel, no longer needed). */
static void blend_pass5(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    const size_t ow = b->ow, oh = b->oh, *cnt = b->cnt;
    const double *V = b->V, *q = b->q, *d = b->d;
    double *rel = b->rel;
    size_t nb[9];
    for (size_t y = r0; y < r1; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x;
            rel[p] = NAN;
            if (!cnt[p])
                continue;
            int k, kf = 0;
            double qs = 0, ds = 0, vs = 0;
            if (inside(x, y, ow, oh)) {
                k = 9;
#pragma GCC unroll 9
                for (int j = 0; j < 9; j++) {
                    const size_t i = window3_inside(p, ow, j);
                    qs += q[i];
                    if (cnt[i]) {
                        ds += d[i];
                        vs += isfinite(V[i]) ? V[i] : 0.0;
                        kf++;
                    }
                }
            } else {
                k = csi_recon_window3_at(x, y, ow, oh, nb);
                for (int j = 0; j < k; j++) {
                    qs += q[nb[j]];
                    if (cnt[nb[j]]) {
                        ds += d[nb[j]];
                        vs += isfinite(V[nb[j]]) ? V[nb[j]] : 0.0;
                        kf++;
                    }
                }
            }
            double dbar = ds / kf;
            /* csi_fmax's (q is never NaN, the running bound neither) */
            double B2 = run_max(gt_max(qs / k, q[p]), dbar * dbar - vs / kf / kf);
            rel[p] = B2 + V[p] > 0 ? B2 / (B2 + V[p]) : 1.0;
        }
}

/* Pass 6: b onto the range of the 3 x 3 pixels' means (after the weights, which see b's distance
 * from m before it), then the blend. */
static void blend_pass6(void *arg, size_t r0, size_t r1)
{
    blend_state *b = arg;
    const size_t ow = b->ow, oh = b->oh, *cnt = b->cnt;
    const double cells = b->cells, *m = b->m, *rel = b->rel;
    const bool clamp = b->clamp;
    float *plane = b->plane;
    size_t nb[9];
    for (size_t y = r0; y < r1; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x;
            double ml = INFINITY, mh = -INFINITY;
            if (inside(x, y, ow, oh)) {
#pragma GCC unroll 9
                for (int j = 0; j < 9; j++) {
                    const size_t i = window3_inside(p, ow, j);
                    const double v = cnt[i] ? m[i] : NAN; /* NaN: skipped */
                    ml = run_min(ml, v);
                    mh = run_max(mh, v);
                }
            } else {
                const int k = csi_recon_window3_at(x, y, ow, oh, nb);
                for (int j = 0; j < k; j++) {
                    const double v = cnt[nb[j]] ? m[nb[j]] : NAN;
                    ml = run_min(ml, v);
                    mh = run_max(mh, v);
                }
            }
            if (ml <= mh) /* csi_fmin(csi_fmax(plane, ml), mh) for ml and mh that are not NaN */
                plane[p] = (float)lt_min(gt_max(plane[p], ml), mh);
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
                int kf = 0;
                const int k = csi_recon_window3_at(x, y, ow, oh, nb);
                for (int j = 0; j < k; j++)
                    if (cnt[nb[j]]) {
                        w[kf++] = m[nb[j]];
                        bs += rel[nb[j]];
                    }
                if (kf)
                    out = plane[p] + bs / kf * (median_upto9(w, kf) - plane[p]);
            }
            if (clamp && out < 0)
                out = 0;
            plane[p] = (float)out;
        }
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
                           const float *fine_at, size_t n, bool clamp, csi_row_pool *pool, float *plane,
                           size_t *multi_out)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    blend_state b = {
        .opt = opt, .values = values, .fine_at = fine_at, .pos = pos, .channels = channels, .c = c,
        .map = csi_recon_pixel_map(g), .n = n, .ow = ow, .oh = oh,
        .cells = (double)(g->w / g->out_w) * (g->h / g->out_h) * g->t, .clamp = clamp, .plane = plane,
        .spread = opt->blend_spread == CSI_SWITCH_ON && opt->sample_variance,
    };
    atomic_init(&b.unordered, false);
    size_t *start = malloc((oh + 1) * sizeof *start);
    b.start = start;
    b.cnt = malloc(np * sizeof *b.cnt);
    b.m = malloc(np * sizeof *b.m), b.ss = malloc(np * sizeof *b.ss), b.gbar = malloc(np * sizeof *b.gbar);
    b.sc = malloc(np * sizeof *b.sc), b.rel = malloc(np * sizeof *b.rel), b.top = malloc(np * sizeof *b.top);
    b.V = malloc(np * sizeof *b.V), b.q = malloc(np * sizeof *b.q), b.d = malloc(np * sizeof *b.d);
    b.lo = malloc(np * sizeof *b.lo), b.hi = malloc(np * sizeof *b.hi);
    b.pix = malloc((n ? n : 1) * sizeof *b.pix);
    /* the sum of each pixel's given sample variances (0, unused, when none is given) */
    b.vsum = malloc(np * sizeof *b.vsum);
    csi_status s = CSI_OK;
    int passes = 0;
    if (!start || !b.cnt || !b.m || !b.ss || !b.gbar || !b.sc || !b.rel || !b.top || !b.V || !b.q || !b.d ||
        !b.lo || !b.hi || !b.pix || !b.vsum) {
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel blend");
        goto done;
    }
    /* The pixels' sample ranges, means and counts: in bands of rows where the samples are in row
     * order (each pixel's sums in sample order either way: deterministic), else in one pass. */
    csi_recon_sample_rows(g, pos, n, start);
    csi_row_pool_run(pool, oh, ow, blend_pass1, &b);
    const bool ordered = !atomic_load(&b.unordered);
    if (!ordered) {
        blend_pixels_clear(&b, 0, np);
        blend_samples_first(&b, 0, n, 0, oh, false);
        sums_to_means(b.m, b.cnt, 0, np);
    }
    size_t multi = 0, filled = 0;
    double mabs = 0;
    for (size_t p = 0; p < np; p++) { /* in pixel order, on this thread: the same sum */
        if (b.cnt[p]) {
            mabs += fabs(b.m[p]);
            filled++;
        }
        multi += b.cnt[p] >= 2;
    }
    BLEND_PASS_DONE();
    if (ordered) {
        csi_row_pool_run(pool, oh, ow, blend_pass2, &b);
    } else {
        csi_row_pool_run(pool, oh, ow, blend_pass2_range, &b);
        blend_pixels_second_clear(&b, 0, np);
        blend_samples_second(&b, 0, n);
        sums_to_means(b.gbar, b.cnt, 0, np);
    }
    BLEND_PASS_DONE();
    BLEND_PASS_DONE();
    b.by_pixel = 2 * multi >= np;
    if (multi_out)
        *multi_out = multi;
    b.eps = csi_fmax(pow(CSI_BLEND_EPS_REL * (filled ? mabs / (double)filled : 0.0), 2), 1e-300);
    csi_row_pool_run(pool, oh, ow, blend_pass3, &b);
    BLEND_PASS_DONE();
    csi_row_pool_run(pool, oh, ow, blend_pass4, &b);
    BLEND_PASS_DONE();
    csi_row_pool_run(pool, oh, ow, blend_pass5, &b);
    BLEND_PASS_DONE();
    csi_row_pool_run(pool, oh, ow, blend_pass6, &b);
    BLEND_PASS_DONE();
done:
    free(start), free(b.cnt), free(b.m), free(b.ss), free(b.gbar), free(b.sc), free(b.rel), free(b.V);
    free(b.q), free(b.d), free(b.top), free(b.lo), free(b.hi), free(b.pix), free(b.vsum);
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
