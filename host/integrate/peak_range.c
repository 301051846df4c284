/* Isolated peaks estimated by a fit of the samples' logarithm (csi/peak_range.h), and its place
 * in a reconstruction. On the host, in double, in sample order (deterministic). */
#include "csi/peak_range.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* The floor that keeps the peak ratio finite at 0, as a fraction of the samples' mean absolute
 * value: blend.c's, fit_trust.c's and peak_noise.c's 1%. */
#define PEAK_RANGE_EPS_REL 1e-2

static double brightness(const float *values, uint32_t channels, size_t i)
{
    double v = 0;
    for (uint32_t c = 0; c < channels; c++)
        v += values[i * channels + c];
    return v / channels;
}

csi_status csi_peak_range_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                 const float *values, size_t n, uint8_t *peak, size_t *count)
{
    *count = 0;
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "peaks by the log fit: a volume (%u frames) is not an image", g->t);
    const size_t np = (size_t)g->out_w * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    memset(peak, 0, np);
    if ((uint64_t)bw * bh <= 1)
        return CSI_OK; /* one cell per pixel: every sample is its pixel's exact value */
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *top = malloc(np * sizeof *top), *second = malloc(np * sizeof *second);
    if (!cnt || !top || !second) {
        free(cnt), free(top), free(second);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    double sabs = 0;
    for (size_t p = 0; p < np; p++)
        top[p] = second[p] = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
        const double v = brightness(values, channels, i);
        sabs += fabs(v);
        cnt[p]++;
        if (v > top[p]) {
            second[p] = top[p];
            top[p] = v;
        } else if (v > second[p]) {
            second[p] = v;
        }
    }
    const double e = PEAK_RANGE_EPS_REL * (n ? sabs / (double)n : 0.0);
    const long ow = (long)g->out_w, oh = (long)g->out_h;
    size_t k = 0;
    for (size_t p = 0; p < np; p++) {
        /* second == top when the two brightest are equal: no peak */
        if (cnt[p] < 2 || top[p] <= second[p] ||
            top[p] + e < CSI_PEAK_RANGE_RATIO * (fmax(second[p], 0.0) + e))
            continue;
        /* isolated: above every sample of the 8 neighbouring pixels by CSI_PEAK_RANGE_NEIGHBOURS
         * (an edge has its bright side's samples around) */
        const long px = (long)p % ow, py = (long)p / ow;
        bool isolated = true;
        for (long dy = -1; dy <= 1 && isolated; dy++)
            for (long dx = -1; dx <= 1; dx++) {
                const long x = px + dx, y = py + dy;
                if ((dx || dy) && x >= 0 && y >= 0 && x < ow && y < oh &&
                    top[p] + e < CSI_PEAK_RANGE_NEIGHBOURS * (fmax(top[(size_t)(y * ow + x)], 0.0) + e)) {
                    isolated = false;
                    break;
                }
            }
        if (isolated) {
            peak[p] = 1;
            k++;
        }
    }
    *count = k;
    free(cnt), free(top), free(second);
    return CSI_OK;
}

void csi_peak_range_map(uint32_t channels, const float *values, size_t n, float *u, double s[4],
                        double umax[4])
{
    for (uint32_t c = 0; c < channels; c++) {
        double sum = 0, hi = 0;
        for (size_t i = 0; i < n; i++) {
            const double v = fmax(values[i * channels + c], 0.0);
            sum += v;
            hi = fmax(hi, v);
        }
        s[c] = n ? CSI_PEAK_RANGE_K * sum / (double)n : 0.0;
        umax[c] = s[c] > 0 ? log1p(hi / s[c]) : 0.0;
        for (size_t i = 0; i < n; i++)
            u[i * channels + c] = s[c] > 0 ? (float)log1p(fmax(values[i * channels + c], 0.0) / s[c]) : 0.0f;
    }
}

double csi_peak_range_pixel(const csi_grid *g, const float *fine, uint32_t c, size_t p, double s,
                            double umax)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t px = p % g->out_w, py = p / g->out_w, cells = (size_t)g->w * g->h;
    const float *plane = fine + (size_t)c * cells;
    double sum = 0;
    for (uint32_t y = 0; y < bh; y++)
        for (uint32_t x = 0; x < bw; x++) {
            const double u = plane[(py * bh + y) * (size_t)g->w + px * bw + x];
            sum += s * expm1(fmin(fmax(u, 0.0), umax));
        }
    return sum / ((double)bw * bh);
}

csi_status csi_recon_peak_range(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                const float *values, size_t n, const csi_recon_options *opt,
                                csi_recon_result *out)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    uint8_t *peak = malloc(np ? np : 1);
    float *u = malloc((n ? n : 1) * channels * sizeof *u);
    if (!peak || !u) {
        free(peak), free(u);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
    }
    size_t k = 0;
    csi_status s = csi_peak_range_pixels(g, channels, pos, values, n, peak, &k);
    if (s != CSI_OK || !k) {
        free(peak), free(u);
        return s;
    }
    double scale[4], umax[4];
    csi_peak_range_map(channels, values, n, u, scale, umax);
    /* The fit of u on the fine grid: an image whose pixels are the grid's cells, with the
     * whole's tau (the default follows the samples per output pixel, which this grid changes). */
    csi_grid fine = *g;
    fine.out_w = g->w;
    fine.out_h = g->h;
    csi_recon_options o = *opt;
    o.correct = CSI_CORRECT_NONE;
    o.cv_select = CSI_SWITCH_OFF;
    o.peak_range = CSI_SWITCH_OFF;
    o.sample_variance = NULL;
    o.tau_rel = out->options.tau_rel;
    o.levels = out->options.levels;
    csi_recon_result r;
    s = csi_recon_progress(opt, "peaks: the log fit");
    if (s == CSI_OK)
        s = csi_recon(ctx, &fine, channels, pos, u, n, &o, &r);
    if (s == CSI_OK) {
        /* Only ever lowered: the rule takes back a peak pixel's over-reading; where the log
         * fit's bump is above the reconstruction it has spread beyond the peak's stratum. */
        for (size_t p = 0; p < np; p++)
            if (peak[p])
                for (uint32_t c = 0; c < channels; c++) {
                    float *x = out->image + (size_t)c * np + p;
                    *x = fminf(*x, (float)csi_peak_range_pixel(g, r.image, c, p, scale[c], umax[c]));
                }
        /* the run's cost is the reconstruction's too */
        out->t_solve += r.t_solve;
        out->t_integrate += r.t_integrate;
        out->cpu_work += r.cpu_setup + r.cpu_work;
        out->peak_range_pixels = k;
        csi_recon_result_free(&r);
    }
    free(peak), free(u);
    return s;
}
