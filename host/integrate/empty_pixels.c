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
 * D, so the result stays in the range of the neighbours' means.
 *
 * How far up the step a real sliver can stand depends on the bright side's shape. Beside an
 * extended emitter (the Cornell box's) the pixel may be mostly covered while the fit, which
 * under-reads such an edge, sees it low on the step: only a small f says the pixel is dark.
 * Beside a source that lives inside one pixel (a sub-pixel lamp), the light does not reach the
 * pixel, and the fit's blur alone puts a good fraction of it there. The samples tell the two
 * apart. A neighbour is bright above the step's geometric midpoint, sqrt((D + eps) (H + eps)) -
 * eps (on an HDR step a noisy bright side's samples spread over a ratio, not a fraction). The
 * bright side stands alone unless its light goes on past the pixel's 3 x 3 window: a pixel next
 * to a bright neighbour q, outside the window, holds samples at least a quarter as far up the
 * step as q's (ramped from an eighth to a half); nor does it where two bright neighbours lie on
 * opposite sides of the pixel (the feature runs through it). A bright side that stands alone
 * says nothing of the pixel through the fit's value, and F_ALONE takes anything up to the
 * step's top for the leak. A thin tube beside the pixel goes on past the window along itself
 * and keeps F: at one sample per pixel many of a thin line's own pixels read dark, and which of
 * the pixels without a sample it runs through the samples do not say. */
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
/* The fraction beside a bright side that stands alone, not going on past its own pixels (fully
 * below half of it): all of the step, as the fit's value says nothing of such a pixel. Smaller
 * ones were measured (docs/bench/mitsuba.md, session 12) and left more of the leak. */
#define EMPTY_F_ALONE 1.0
/* How far up the step (relative to the bright neighbour's) the light beyond that neighbour must
 * stand for the bright side to count as extended: a ramp from an eighth to a half. */
#define EMPTY_BEYOND0 0.125
#define EMPTY_BEYOND1 0.5
/* The floor that keeps the ratio finite at 0: blend.c's 1% of the mean absolute value. */
#define EMPTY_EPS_REL 1e-2

static double ramp(double x, double lo, double hi)
{
    return fmin(fmax((x - lo) / (hi - lo), 0.0), 1.0);
}

/* How far the bright side beside pixel p goes on past p's 3 x 3 window: over p's sampled
 * neighbours q at or above bt, the largest (b[r] - lo) / (b[q] - lo) of a sampled pixel r next to
 * q outside p's window (0 where none is); 1 where two such q lie on opposite sides of p (p
 * between them: the feature runs through p). b is each pixel's mean over the channels, cnt its
 * count of samples. */
static double beyond(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double lo,
                     double bt)
{
    const long px = (long)(p % ow), py = (long)(p / ow);
    size_t nb[9], nq[9];
    long dx[9], dy[9];
    int m = 0;
    const int k = csi_recon_window3(p, ow, oh, nb);
    for (int j = 0; j < k; j++)
        if (cnt[nb[j]] && b[nb[j]] >= bt) {
            nb[m] = nb[j];
            dx[m] = (long)(nb[j] % ow) - px, dy[m] = (long)(nb[j] / ow) - py;
            m++;
        }
    for (int i = 0; i < m; i++)
        for (int j = 0; j < i; j++)
            if (dx[i] * dx[j] + dy[i] * dy[j] < 0)
                return 1.0;
    double most = 0;
    for (int i = 0; i < m; i++) {
        const int kq = csi_recon_window3(nb[i], ow, oh, nq);
        for (int j = 0; j < kq; j++) {
            const size_t r = nq[j];
            const long rx = (long)(r % ow), ry = (long)(r / ow);
            if (cnt[r] && (labs(rx - px) > 1 || labs(ry - py) > 1))
                most = fmax(most, (b[r] - lo) / (b[nb[i]] - lo));
        }
    }
    return most;
}

csi_status csi_empty_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                            const float *values, size_t n, float *image)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *m = calloc(np * channels, sizeof *m), *b = calloc(np, sizeof *b);
    if (!cnt || !m || !b) {
        free(cnt), free(m), free(b);
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
    for (size_t p = 0; p < np; p++) {
        if (!cnt[p])
            continue;
        for (uint32_t c = 0; c < channels; c++) {
            m[(size_t)c * np + p] /= cnt[p];
            b[p] += m[(size_t)c * np + p];
        }
        b[p] = fmax(b[p] / channels, 0.0);
    }
    const double e = EMPTY_EPS_REL * (n ? sabs / (double)n / channels : 0.0);
    for (size_t p = 0; p < np; p++) {
        if (cnt[p])
            continue;
        size_t nb[9];
        const int k = csi_recon_window3(p, ow, oh, nb);
        double lo = INFINITY, hi = -INFINITY, here = 0;
        for (int j = 0; j < k; j++)
            if (cnt[nb[j]])
                lo = fmin(lo, b[nb[j]]), hi = fmax(hi, b[nb[j]]);
        if (!(hi > lo))
            continue;
        for (uint32_t c = 0; c < channels; c++)
            here += image[(size_t)c * np + p];
        here /= channels;
        const double f = (here - lo) / (hi - lo);
        const double step = ramp(log((hi + e) / (lo + e)), log(EMPTY_R0), log(EMPTY_R1));
        if (step <= 0)
            continue;
        const double bt = sqrt((lo + e) * (hi + e)) - e; /* bright: above the step's geometric midpoint */
        const double alone = 1.0 - ramp(beyond(p, ow, oh, cnt, b, lo, bt), EMPTY_BEYOND0, EMPTY_BEYOND1);
        const double F = EMPTY_F + (EMPTY_F_ALONE - EMPTY_F) * alone;
        const double w = step * (1.0 - ramp(f, 0.5 * F, F));
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
    free(cnt), free(m), free(b);
    return CSI_OK;
}
