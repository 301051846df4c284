/* Pixels without a sample next to an HDR step (csi/empty_pixels.h). The blend gives
 * such a pixel the fit's box integral moved towards its neighbours' means (blend.c); where a thin
 * bright feature runs beside it, the fit's blur carries a fraction of the feature's light into
 * it, many times the dark wall's own value where the feature is an emitter. Let D be the
 * lowest of the 8 neighbours' means and H the highest (by the channels' mean), and f the
 * fraction of the way from D to H at which the pixel stands. Two things can be true of it: the
 * pixel is as dark as the dark side (the fit leaked), or it holds a fraction f of the bright
 * side (a sliver of the feature). Writing the dark side's value costs, if the sliver is real,
 * f^2 (H - D)^2 of squared error and at most 1 of relative error (what the per-pixel mean's 0
 * costs there); keeping the fit's value costs, if the pixel is dark, the same squared error and
 * f^2 (H - D)^2 / (D^2 + eps) of relative error, thousands where H / D is in the thousands. So
 * where the neighbourhood spans an HDR step and f is small, the pixel takes the dark side's
 * value (each channel: the lowest of its neighbours' means): the squared error at stake is
 * small against the step's own, and the relative error is bounded by the mean's. A larger f is
 * the fit seeing the pixel mostly on the bright side (an emitter's edge, which it extrapolates
 * well), and is kept. Ramps, not thresholds: the step counts from a ratio H / D of R0 (fully
 * from R1), a fraction below F (fully below F / 2) is lowered. Only ever lowered, never below
 * D, so the result stays in the range of the neighbours' means. */
#include "csi/empty_pixels.h"

#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The ratios of fit_trust.c: 4x is ordinary shading, 16x the start of an HDR step. */
#define EMPTY_R0 4.0
#define EMPTY_R1 16.0
/* The fraction of the step below which the pixel is taken for the dark side (fully below half of
 * it): the largest of those measured that cost no Mitsuba cell more than the 2% of MSE a default
 * may move (docs/bench/mitsuba.md, session 11); larger ones also lowered the corners of the
 * Cornell box's emitter, which the fit under-reads. */
#define EMPTY_F 0.1
/* The floor that keeps the ratio finite at 0: blend.c's 1% of the mean absolute value. */
#define EMPTY_EPS_REL 1e-2

static double ramp(double x, double lo, double hi)
{
    return fmin(fmax((x - lo) / (hi - lo), 0.0), 1.0);
}

csi_status csi_empty_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                            const float *values, size_t n, float *image)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *m = calloc(np * channels, sizeof *m);
    if (!cnt || !m) {
        free(cnt), free(m);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    double sabs = 0;
    for (size_t i = 0; i < n; i++) { /* in sample order: deterministic */
        size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
        cnt[p]++;
        for (uint32_t c = 0; c < channels; c++) {
            m[(size_t)c * np + p] += values[i * channels + c];
            sabs += fabs((double)values[i * channels + c]);
        }
    }
    for (size_t p = 0; p < np; p++)
        for (uint32_t c = 0; c < channels && cnt[p]; c++)
            m[(size_t)c * np + p] /= cnt[p];
    const double e = EMPTY_EPS_REL * (n ? sabs / (double)n / channels : 0.0);
    for (size_t p = 0; p < np; p++) {
        if (cnt[p])
            continue;
        size_t nb[9];
        const int k = csi_recon_window3(p, ow, oh, nb);
        double lo = INFINITY, hi = -INFINITY, here = 0;
        for (int j = 0; j < k; j++) {
            const size_t q = nb[j];
            if (!cnt[q])
                continue;
            double b = 0;
            for (uint32_t c = 0; c < channels; c++)
                b += m[(size_t)c * np + q];
            b = fmax(b / channels, 0.0);
            lo = fmin(lo, b), hi = fmax(hi, b);
        }
        if (!(hi > lo))
            continue;
        for (uint32_t c = 0; c < channels; c++)
            here += image[(size_t)c * np + p];
        here /= channels;
        const double f = (here - lo) / (hi - lo);
        const double w = ramp(log((hi + e) / (lo + e)), log(EMPTY_R0), log(EMPTY_R1)) *
                         (1.0 - ramp(f, 0.5 * EMPTY_F, EMPTY_F));
        if (w <= 0)
            continue;
        for (uint32_t c = 0; c < channels; c++) {
            double d = INFINITY;
            for (int j = 0; j < k; j++)
                if (cnt[nb[j]])
                    d = fmin(d, m[(size_t)c * np + nb[j]]);
            float *x = image + (size_t)c * np + p;
            if (*x > d)
                *x = (float)(*x - w * (*x - d));
        }
    }
    free(cnt), free(m);
    return CSI_OK;
}
