/* Isolated peaks judged against their own Monte Carlo noise (csi/peak_noise.h). On the host, in
 * double, in sample order (deterministic). */
#include "csi/peak_noise.h"

#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "internal.h"

/* The floor that keeps the peak ratio finite at 0, as a fraction of the samples' mean absolute
 * value: blend.c's and fit_trust.c's 1%. */
#define PEAK_EPS_REL 1e-2

/* A peak its noise explains, shrunk towards r, the value without it: r + w (x - r), x the
 * reconstruction's value, w = max(0, 1 - v / d^2) for the peak's excess d over the others and its
 * variance v (the positive-part James-Stein / Wiener weight: d^2 - v estimates the excess's signal
 * power, d^2 its total). One path carrying the whole sample has v ~ y^2 >= d^2, w 0: dropped. */
static float peak_shrink(double r, double x, double d, double v)
{
    const double w = d > 0 ? csi_fmax(0.0, 1.0 - v / (d * d)) : 0.0;
    return (float)(r + w * (x - r));
}

/* The median of k <= 8 values, sorted in place (insertion sort). */
static double median_of(double *w, int k)
{
    for (int i = 1; i < k; i++) {
        const double v = w[i];
        int j = i;
        for (; j > 0 && w[j - 1] > v; j--)
            w[j] = w[j - 1];
        w[j] = v;
    }
    return k % 2 ? w[k / 2] : 0.5 * (w[k / 2 - 1] + w[k / 2]);
}

/* One call's inputs and per-pixel arrays, for its passes over bands of rows (csi/row_pool.h). */
typedef struct peak_state {
    const float *values, *variance;
    const uint32_t *cnt;
    const size_t *start, *idx; /* each pixel's samples, in sample order: idx[start[p] ..] */
    uint32_t channels, c;
    size_t ow, oh, np;
    uint64_t cells; /* a pixel's cells */
    double e;
    double *m, *hi;
    float *plane;
    atomic_size_t set;
} peak_state;

/* Each pixel's mean and brightest sample in channel c, its samples summed in sample order. */
static void peak_pass_means(void *arg, size_t r0, size_t r1)
{
    peak_state *t = arg;
    const float *values = t->values;
    const uint32_t channels = t->channels, c = t->c, *cnt = t->cnt;
    const size_t *start = t->start, *idx = t->idx;
    for (size_t p = r0 * t->ow; p < r1 * t->ow; p++) {
        double m = 0, hi = -INFINITY;
        for (size_t k = start[p]; k < start[p + 1]; k++) {
            const double v = values[idx[k] * channels + c];
            m += v;
            hi = csi_fmax(hi, v);
        }
        t->m[p] = cnt[p] ? m / cnt[p] : m;
        t->hi[p] = hi;
    }
}

/* The level a peak of pixel (px, py) recurs at around it: the median of its 8 neighbours' means,
 * or -inf where its pixel's `others` samples, all below the peak level CSI_PEAK_RATIO (hp + e),
 * contradict it. A caustic or a highlight reached only through rare paths gives most samples
 * around it one such path: each sample is then a peak its noise explains, and dropping every one
 * of them to its pixel's darker others takes the light away (a caustic under glass at 4 spp x 64
 * paths, 1.06x the mean's MSE; docs/bench/mitsuba.md, session 28). Where a fraction rho of the
 * neighbours' samples reach the peak level, the pixel's others all staying below it has the
 * probability (1 - rho)^others if the pixel shares that rate; below CSI_PEAK_SHARED_P the pixel
 * is not the neighbourhood's (beside a bokeh disc or an emitter, many dark samples of its own). */
static double shared_level(const peak_state *t, size_t px, size_t py, double hp, uint32_t others)
{
    const float *values = t->values;
    const uint32_t channels = t->channels, c = t->c, *cnt = t->cnt;
    const size_t *start = t->start, *idx = t->idx, p = py * t->ow + px;
    size_t nb[9];
    double w[8], reach = 0, total = 0;
    int k = 0;
    const int kn = csi_recon_window3_at(px, py, t->ow, t->oh, nb);
    for (int j = 0; j < kn; j++) {
        const size_t q = nb[j];
        if (q == p || !cnt[q])
            continue;
        w[k++] = t->m[q];
        for (size_t i = start[q]; i < start[q + 1]; i++) {
            total++;
            reach += values[idx[i] * channels + c] + t->e >= CSI_PEAK_RATIO * (hp + t->e);
        }
    }
    if (!k || pow(1.0 - reach / total, (double)others) < CSI_PEAK_SHARED_P)
        return -INFINITY;
    return median_of(w, k);
}

/* The rule at each pixel of the band. */
static void peak_pass_pixels(void *arg, size_t r0, size_t r1)
{
    peak_state *t = arg;
    const float *values = t->values, *variance = t->variance;
    const uint32_t channels = t->channels, c = t->c, *cnt = t->cnt;
    const size_t *start = t->start, *idx = t->idx, ow = t->ow, oh = t->oh;
    const double e = t->e, *m = t->m, *hi = t->hi;
    float *plane = t->plane;
    size_t set = 0, nb[9];
    for (size_t py = r0; py < r1; py++)
        for (size_t px = 0; px < ow; px++) {
            const size_t p = py * ow + px;
            if (cnt[p] >= t->cells)
                continue; /* every cell sampled: the pixel is its cells' exact mean, as the blend leaves it */
            if (cnt[p] >= 2) {
                /* The pixel's brightest sample against the others of the pixel. */
                size_t top = idx[start[p]];
                double h = -INFINITY, sum = 0;
                for (size_t k = start[p]; k < start[p + 1]; k++) {
                    const double v = values[idx[k] * channels + c];
                    sum += v;
                    if (v > values[top * channels + c])
                        top = idx[k];
                }
                for (size_t k = start[p]; k < start[p + 1]; k++)
                    if (idx[k] != top)
                        h = csi_fmax(h, values[idx[k] * channels + c]);
                const double y = values[top * channels + c], hp = csi_fmax(h, 0.0);
                if (y + e < CSI_PEAK_RATIO * (hp + e) ||
                    y - hp >= CSI_PEAK_Z * sqrt((double)variance[top * channels + c]))
                    continue;
                /* Shrunk towards the mean of the others, or the neighbours' median where that is
                 * higher and the others may share the neighbourhood's level. */
                const double r = csi_fmax((sum - y) / (double)(cnt[p] - 1),
                                          shared_level(t, px, py, hp, cnt[p] - 1));
                plane[p] = peak_shrink(r, plane[p], y - hp, variance[top * channels + c]);
                set++;
                continue;
            }
            if (cnt[p] != 1)
                continue;
            double h = -INFINITY, w[8];
            int k = 0;
            const int kn = csi_recon_window3_at(px, py, ow, oh, nb);
            for (int j = 0; j < kn; j++) {
                const size_t q = nb[j];
                if (q == p || !cnt[q])
                    continue;
                h = csi_fmax(h, hi[q]);
                w[k++] = m[q];
            }
            if (!k)
                continue; /* no neighbour sampled: nothing to call the sample a peak against */
            const double y = m[p], hp = csi_fmax(h, 0.0);
            if (y + e < CSI_PEAK_RATIO * (hp + e))
                continue;
            if (y - hp >= CSI_PEAK_Z * sqrt((double)variance[idx[start[p]] * channels + c]))
                continue; /* the image's peak: the reconstruction's value stays */
            plane[p] = peak_shrink(median_of(w, k), plane[p], y - hp,
                                   variance[idx[start[p]] * channels + c]); /* towards the neighbours' median */
            set++;
        }
    atomic_fetch_add(&t->set, set);
}

csi_status csi_peak_noise(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, const float *variance, size_t n, csi_row_pool *pool,
                          float *image, size_t *changed)
{
    if (changed)
        *changed = 0;
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "peaks against their noise: a volume (%u frames) is not an image", g->t);
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const csi_pixel_map map = csi_recon_pixel_map(g);
    if ((uint64_t)map.bw * map.bh <= 1)
        return CSI_OK; /* one cell per pixel: every sample is its pixel's exact value */
    size_t *start, *idx;
    CSI_TRY(csi_recon_pixel_samples(&map, pos, n, np, &start, &idx));
    uint32_t *cnt = malloc(np * sizeof *cnt);
    double *m = malloc(np * sizeof *m), *hi = malloc(np * sizeof *hi);
    double *sabs = calloc(channels, sizeof *sabs);
    if (!cnt || !m || !hi || !sabs) {
        free(cnt), free(start), free(idx), free(m), free(hi), free(sabs);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    /* each pixel's sample count, and each channel's sum of absolute values, in sample order */
    for (size_t p = 0; p < np; p++)
        cnt[p] = (uint32_t)(start[p + 1] - start[p]);
    for (size_t i = 0; i < n; i++)
        for (uint32_t c = 0; c < channels; c++)
            sabs[c] += fabs((double)values[i * channels + c]);
    peak_state t = {
        .values = values, .variance = variance, .cnt = cnt, .start = start, .idx = idx,
        .channels = channels, .ow = ow, .oh = oh, .np = np, .cells = (uint64_t)map.bw * map.bh, .m = m, .hi = hi,
    };
    atomic_init(&t.set, 0);
    for (uint32_t c = 0; c < channels; c++) {
        t.c = c;
        t.e = PEAK_EPS_REL * (n ? sabs[c] / (double)n : 0.0);
        t.plane = image + (size_t)c * np;
        csi_row_pool_run(pool, oh, ow, peak_pass_means, &t);
        csi_row_pool_run(pool, oh, ow, peak_pass_pixels, &t);
    }
    if (changed)
        *changed = atomic_load(&t.set);
    free(cnt), free(start), free(idx), free(m), free(hi), free(sabs);
    return CSI_OK;
}
