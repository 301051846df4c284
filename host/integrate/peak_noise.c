/* Isolated peaks judged against their own Monte Carlo noise (csi/peak_noise.h). On the host, in
 * double, in sample order (deterministic). */
#include "csi/peak_noise.h"

#include <math.h>
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
    const double w = d > 0 ? fmax(0.0, 1.0 - v / (d * d)) : 0.0;
    return (float)(r + w * (x - r));
}

csi_status csi_peak_noise(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, const float *variance, size_t n, float *image,
                          size_t *changed)
{
    if (changed)
        *changed = 0;
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "peaks against their noise: a volume (%u frames) is not an image", g->t);
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    if ((uint64_t)bw * bh <= 1)
        return CSI_OK; /* one cell per pixel: every sample is its pixel's exact value */
    uint32_t *cnt = calloc(np, sizeof *cnt);
    size_t *start = malloc((np + 1) * sizeof *start), *idx = malloc((n ? n : 1) * sizeof *idx);
    double *m = malloc(np * sizeof *m), *hi = malloc(np * sizeof *hi);
    if (!cnt || !start || !idx || !m || !hi) {
        free(cnt), free(start), free(idx), free(m), free(hi);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    /* Each pixel's samples, in sample order (a counting sort: deterministic). */
    for (size_t i = 0; i < n; i++)
        cnt[csi_recon_pixel_of(pos[i], bw, bh, ow)]++;
    start[0] = 0;
    for (size_t p = 0; p < np; p++)
        start[p + 1] = start[p] + cnt[p];
    for (size_t p = 0; p < np; p++)
        cnt[p] = 0;
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
        idx[start[p] + cnt[p]++] = i;
    }
    size_t set = 0;
    for (uint32_t c = 0; c < channels; c++) {
        double sabs = 0;
        for (size_t p = 0; p < np; p++)
            m[p] = 0, hi[p] = -INFINITY;
        for (size_t i = 0; i < n; i++) {
            const size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
            const double v = values[i * channels + c];
            m[p] += v;
            hi[p] = fmax(hi[p], v);
            sabs += fabs(v);
        }
        for (size_t p = 0; p < np; p++)
            if (cnt[p])
                m[p] /= cnt[p];
        const double e = PEAK_EPS_REL * (n ? sabs / (double)n : 0.0);
        float *plane = image + (size_t)c * np;
        for (size_t p = 0; p < np; p++) {
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
                        h = fmax(h, values[idx[k] * channels + c]);
                const double y = values[top * channels + c], hp = fmax(h, 0.0);
                if (y + e < CSI_PEAK_RATIO * (hp + e) ||
                    y - hp >= CSI_PEAK_Z * sqrt((double)variance[top * channels + c]))
                    continue;
                /* Shrunk towards the mean of the others. */
                plane[p] = peak_shrink((sum - y) / (double)(cnt[p] - 1), plane[p], y - hp,
                                       variance[top * channels + c]);
                set++;
                continue;
            }
            if (cnt[p] != 1)
                continue;
            const long px = (long)(p % ow), py = (long)(p / ow);
            double h = -INFINITY, w[8];
            int k = 0;
            for (long dy = -1; dy <= 1; dy++)
                for (long dx = -1; dx <= 1; dx++) {
                    const long x = px + dx, y = py + dy;
                    if ((!dx && !dy) || x < 0 || y < 0 || x >= (long)ow || y >= (long)oh)
                        continue;
                    const size_t q = (size_t)y * ow + (size_t)x;
                    if (!cnt[q])
                        continue;
                    h = fmax(h, hi[q]);
                    w[k++] = m[q];
                }
            if (!k)
                continue; /* no neighbour sampled: nothing to call the sample a peak against */
            const double y = m[p], hp = fmax(h, 0.0);
            if (y + e < CSI_PEAK_RATIO * (hp + e))
                continue;
            if (y - hp >= CSI_PEAK_Z * sqrt((double)variance[idx[start[p]] * channels + c]))
                continue; /* the image's peak: the reconstruction's value stays */
            for (int i = 1; i < k; i++) { /* the neighbours' median (insertion sort: k <= 8) */
                const double v = w[i];
                int j = i;
                for (; j > 0 && w[j - 1] > v; j--)
                    w[j] = w[j - 1];
                w[j] = v;
            }
            plane[p] = peak_shrink(k % 2 ? w[k / 2] : 0.5 * (w[k / 2 - 1] + w[k / 2]), plane[p], y - hp,
                                   variance[idx[start[p]] * channels + c]); /* towards the neighbours' median */
            set++;
        }
    }
    if (changed)
        *changed = set;
    free(cnt), free(start), free(idx), free(m), free(hi);
    return CSI_OK;
}
