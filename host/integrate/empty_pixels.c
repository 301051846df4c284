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
 * Beside a source that lives inside one pixel (a sub-pixel lamp) or a line one pixel wide (a
 * thin tube, a gap between the slats of a blind), the light does not reach past that pixel, and
 * the fit's blur alone puts a good fraction of it into the pixel next to it. The samples tell
 * the two apart. A neighbour q is bright above the step's geometric midpoint, sqrt((D + eps)
 * (H + eps)) - eps (on an HDR step a noisy bright side's samples spread over a ratio, not a
 * fraction), and the edge of something extended when the light goes on past it straight away
 * from the pixel: when the pixel beyond q, on the line from the pixel through q, holds samples
 * at least a quarter as far up the step as q's (ramped from an eighth to a half). The pixel is
 * on the feature, not beside it, when two bright neighbours lie on opposite sides of it. Where
 * neither is, the bright side stands alone: the fit's value then says nothing of the pixel, and
 * F_ALONE takes anything up to the step's top for the leak. A line beside the pixel counts as
 * alone although it goes on along itself: at one sample per pixel some of a thin tube's own
 * pixels read dark and the pixels without a sample it runs through lose its light (a few % of
 * the image's MSE, docs/bench/mitsuba.md session 12), but beside a row of such lines (a blind's
 * slats against the sky) the fit stands halfway up the step in dark pixels and the relative
 * error is 50 times the mean's.
 *
 * Where the step runs in lines one pixel wide (the slats of a blind against a bright sky, a lamp
 * two pixels across), the bright side goes on past the pixel and the fit, which blurs the lines
 * together, stands anywhere up the step: the fraction says nothing either way. The neighbours'
 * arrangement does. Each of the four lines through the pixel (its row, its column, the two
 * diagonals) whose two neighbours hold samples on one side of the step (the same side of its
 * geometric midpoint) is a candidate for the pixel's own side: the pixel lies on a line of that
 * side. A candidate is supported by each line parallel to it in the 3 x 3 pixels (two of them)
 * whose samples are all on one side, and contradicted by each whose samples are not: a dark
 * slat between bright gaps has uniform rows above and below it, a bright line crossing a dark
 * wall uniform columns beside it. The row and the column come first (their neighbours are
 * nearer); the diagonals count only where neither is a candidate, and then only with a
 * supporting line (two dark corners alone are also what a bright feature's corner looks like).
 * The best supported candidate wins; a tie goes to the dark side, as the relative error at
 * stake is the larger by the step's ratio squared. A dark winner moves the pixel (by the step's
 * ramp) to the mean of its two neighbours, channel by channel; a bright one leaves it.
 *
 * Neither rule is sure where the samples themselves mislead: a thin bright line crossing a dark
 * pixel's corner puts one point sample far up the step (a blind's slanted gaps, a neon tube on
 * the diagonal), one path in a hundred finds a lamp, and a neighbour without a sample hides a
 * line. A pixel left high on the step there can cost the relative error of thousands of the
 * mean's pixels (a slat between gaps, 1 spp on Poisson-disk positions: 1.2-1.9x the mean's
 * relMSE on 8 seeds of a blind, docs/bench/mitsuba.md session 14), while the mean's 0 costs at
 * most 1. So, last, unless the pixel's row or column shows it inside the bright side (both
 * neighbours on that line bright, a neighbour without a sample stood in for by the pixel beyond
 * it) and neither shows a dark line through it (both dark, or unknown), the pixel is capped
 * (from a ratio of 16, fully from 64) at the step's geometric midpoint, the value whose ratio to
 * either end is the same: if it is dark, its relative error is the step's ratio, not that ratio
 * squared; if it is bright, at most the mean's. Where one of the two lines is inside the bright
 * side and the other crosses the step, the dark neighbour on the crossing line is the edge of a
 * dark region (an emitter's border above a pixel of the ceiling: that neighbour's own neighbours
 * along the other line are dark too), one path of a noisy dark side that found no light, or the
 * end of a dark line running into the bright side (a blade of grass, a wire, a window's bar
 * against the sky: its neighbours along the other line are bright, and beyond it the line goes
 * on), which may well go on through the pixel; only the line does not keep the pixel (a lone dark
 * sample counted as a line darkened the bright side of a noisy garden's shadow edges at one sample
 * per pixel). Two dark neighbours on opposite sides of the pixel (the dark side's counterpart of
 * the bright ones above) put a dark feature through it at whatever angle (twigs crossing a bright
 * sky), and the pixel is capped whatever its row and column show. Where both lines cross the step
 * (a corner of it), 8 neighbours cannot tell a bright region's inner corner from a thin dark
 * line's bend or slant, and the pixel is capped: a majority of bright neighbours kept such pixels,
 * and on thin dark blades against a bright sky it filled blade pixels with sky, each costing the
 * relative error of thousands of the mean's pixels (docs/bench/mitsuba.md, session 36). A pixel of
 * one sample is capped the same way, its step from its own sample up to the brightest of its
 * neighbours' means: its mean is one point, and where that point reads far below the bright side
 * around it the blend keeps the fit (its noise level sees the step as aliasing: blend.c;
 * fit_trust.c's w_dark then leaves it), whose value there, on a thin dark line, is the same leak.
 * Channels are scaled together, keeping the pixel's colour. */
#include "csi/empty_pixels.h"

#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>
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
/* The lines' sides are split at the step's geometric midpoint with its dark end floored at this
 * fraction of its bright end: over a dark side of exact zeros (one-path samples that found no
 * light) the midpoint would otherwise fall among the dark side's own noise. */
#define EMPTY_SIDE_FLOOR 1e-3
/* The same split for the row and the column of the cap (the header's last paragraph), its dark
 * end floored higher: the cap errs towards the dark side, and at a floor of a thousandth a slat's
 * faint light (a few % of the gaps' beside it) already counted as bright. */
#define EMPTY_AXIS_FLOOR 1e-2
/* The ratios over which the cap comes in: from where the step is fully an HDR one (EMPTY_R1) to
 * four times that. Below, a leak costs at most the ratio squared in relative error, hundreds
 * rather than the thousands the cap is for, and an LDR texture's pixels lost to the cap cost
 * more than that (tests/e2e/test_fit_trust.c). */
#define EMPTY_CAP_R0 16.0
#define EMPTY_CAP_R1 64.0

static double ramp(double x, double lo, double hi)
{
    return csi_fmin(csi_fmax((x - lo) / (hi - lo), 0.0), 1.0);
}

/* Pixel p's sampled neighbours (not p) on one side of bt (at or above it when above, else below):
 * their indices in nb and offsets from p in (dx, dy); returns how many. */
static int side_neighbours(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double bt,
                           bool above, size_t nb[9], long dx[9], long dy[9])
{
    const long px = (long)(p % ow), py = (long)(p / ow);
    size_t w[9];
    int m = 0;
    const int k = csi_recon_window3(p, ow, oh, w);
    for (int j = 0; j < k; j++)
        if (w[j] != p && cnt[w[j]] && (b[w[j]] >= bt) == above) {
            nb[m] = w[j];
            dx[m] = (long)(w[j] % ow) - px, dy[m] = (long)(w[j] / ow) - py;
            m++;
        }
    return m;
}

/* Whether two of the m offsets (dx, dy) from a pixel lie on opposite sides of it (at more than a
 * right angle). */
static bool opposite(const long *dx, const long *dy, int m)
{
    for (int i = 0; i < m; i++)
        for (int j = 0; j < i; j++)
            if (dx[i] * dx[j] + dy[i] * dy[j] < 0)
                return true;
    return false;
}

/* How far the bright side beside pixel p goes on past it: over p's sampled neighbours q at or
 * above bt, the largest (b[r] - lo) / (b[q] - lo) of r = q + (q - p), the pixel beyond q
 * straight away from p, where r holds samples (0 where none does); 1 where two such q lie on
 * opposite sides of p (p between them: the feature runs through p). b is each pixel's mean over
 * the channels, cnt its count of samples. */
static double beyond(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double lo,
                     double bt)
{
    const long px = (long)(p % ow), py = (long)(p / ow);
    size_t nb[9];
    long dx[9], dy[9];
    const int m = side_neighbours(p, ow, oh, cnt, b, bt, true, nb, dx, dy);
    if (opposite(dx, dy, m))
        return 1.0;
    double most = 0;
    for (int i = 0; i < m; i++) {
        const long rx = px + 2 * dx[i], ry = py + 2 * dy[i];
        if (rx < 0 || ry < 0 || rx >= (long)ow || ry >= (long)oh)
            continue;
        const size_t r = (size_t)ry * ow + (size_t)rx;
        if (cnt[r])
            most = csi_fmax(most, (b[r] - lo) / (b[nb[i]] - lo));
    }
    return most;
}

/* The four lines through a pixel, as offsets (dx, dy): the two neighbours on it, then the lines
 * parallel to it in the 3 x 3 pixels (three pixels each for the row and the column, two for a
 * diagonal). */
typedef struct {
    int pair[2][2];
    int lines[2][3][2];
    int len;
} line_dir;

static const line_dir DIRS[4] = {
    {{{-1, 0}, {1, 0}}, {{{-1, -1}, {0, -1}, {1, -1}}, {{-1, 1}, {0, 1}, {1, 1}}}, 3},  /* row */
    {{{0, -1}, {0, 1}}, {{{-1, -1}, {-1, 0}, {-1, 1}}, {{1, -1}, {1, 0}, {1, 1}}}, 3},  /* column */
    {{{-1, -1}, {1, 1}}, {{{0, -1}, {1, 0}}, {{-1, 0}, {0, 1}}}, 2},                     /* NW-SE */
    {{{1, -1}, {-1, 1}}, {{{0, -1}, {-1, 0}}, {{1, 0}, {0, 1}}}, 2},                     /* NE-SW */
};

/* The sampled pixel at offset (dx, dy) from p, or SIZE_MAX (outside the image, or no sample). */
static size_t sampled_at(size_t p, int dx, int dy, size_t ow, size_t oh, const uint32_t *cnt)
{
    const long x = (long)(p % ow) + dx, y = (long)(p / ow) + dy;
    if (x < 0 || y < 0 || x >= (long)ow || y >= (long)oh)
        return SIZE_MAX;
    const size_t q = (size_t)y * ow + (size_t)x;
    return cnt[q] ? q : SIZE_MAX;
}

/* The line through empty pixel p that the arrangement of its neighbours puts it on, when that
 * line is on the dark side (the header's last paragraph): its index in DIRS, or -1 (none, or a
 * bright one). b: each pixel's mean over the channels; split: the side's threshold; here: p's
 * value (channels' mean), to which a line's side is compared. */
static int dark_line(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double split,
                     double here)
{
    int best_dark = -1, score_dark = INT_MIN, score_bright = INT_MIN;
    double level_dark = INFINITY;
    for (int pass = 0; pass < 2 && best_dark < 0 && score_bright == INT_MIN; pass++) {
        for (int d = 2 * pass; d < 2 * pass + 2; d++) {
            const line_dir *L = &DIRS[d];
            const size_t a = sampled_at(p, L->pair[0][0], L->pair[0][1], ow, oh, cnt);
            const size_t z = sampled_at(p, L->pair[1][0], L->pair[1][1], ow, oh, cnt);
            if (a == SIZE_MAX || z == SIZE_MAX || (b[a] > split) != (b[z] > split))
                continue;
            int score = 0;
            for (int l = 0; l < 2; l++) {
                int seen = 0, above = 0;
                for (int i = 0; i < L->len; i++) {
                    const size_t q = sampled_at(p, L->lines[l][i][0], L->lines[l][i][1], ow, oh, cnt);
                    if (q != SIZE_MAX)
                        seen++, above += b[q] > split;
                }
                if (seen >= 2)
                    score += (above == 0 || above == seen) ? 1 : -1;
            }
            const double level = 0.5 * (b[a] + b[z]);
            if (level >= here)
                score_bright = score > score_bright ? score : score_bright;
            else if (score > score_dark || (score == score_dark && level < level_dark))
                best_dark = d, score_dark = score, level_dark = level;
        }
        if (pass == 1 && score_dark < 1)
            best_dark = -1; /* a diagonal only with a supporting line */
    }
    return best_dark >= 0 && score_dark >= score_bright ? best_dark : -1;
}

/* Whether the dark neighbour dk of pixel p, on the line through p that crosses the step (DIRS[d],
 * dk on its side k), ends a dark line running into the bright side rather than edging a dark
 * region or being a lone dark sample (the header's last paragraph): its own neighbours along the
 * other line through p hold a sample, every one of them on the bright side itself (within
 * ordinary shading of its brightest hi: a ratio of EMPTY_R0; a darker one is the dark region
 * going on beside dk), and the line goes on: one of the three pixels beyond dk, away from p,
 * holds a sample below bt (without one, dk may be one path of a noisy dark side that found no
 * light, or a point). */
static bool dark_line_end(size_t dk, int d, int k, size_t ow, size_t oh, const uint32_t *cnt, const double *b,
                          double bt, double hi)
{
    const int along = 1 - d; /* the other of the row and the column */
    int seen = 0;
    for (int j = 0; j < 2; j++) {
        const size_t r = sampled_at(dk, DIRS[along].pair[j][0], DIRS[along].pair[j][1], ow, oh, cnt);
        if (r == SIZE_MAX)
            continue;
        if (b[r] < hi / EMPTY_R0)
            return false;
        seen++;
    }
    if (!seen)
        return false;
    const int fx = DIRS[d].pair[k][0], fy = DIRS[d].pair[k][1]; /* from p towards dk */
    const int ax = DIRS[along].pair[1][0], ay = DIRS[along].pair[1][1];
    for (int j = -1; j <= 1; j++) {
        const size_t r = sampled_at(dk, fx + j * ax, fy + j * ay, ow, oh, cnt);
        if (r != SIZE_MAX && b[r] < bt)
            return true;
    }
    return false;
}

/* Whether two of pixel p's sampled neighbours below bt lie on opposite sides of it (their
 * offsets from p at more than a right angle): a dark feature passes through p, at whatever angle
 * (the dark side's counterpart of beyond()'s bright neighbours on opposite sides). */
static bool dark_through(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double bt)
{
    size_t nb[9];
    long dx[9], dy[9];
    return opposite(dx, dy, side_neighbours(p, ow, oh, cnt, b, bt, false, nb, dx, dy));
}

/* Whether the row and the column through pixel p place it inside the bright side (the header's
 * last paragraph): no dark feature passes through p (dark_through), neither line has both
 * neighbours below bt, and both have both at or above it, or one has and the other's neighbour
 * below bt edges a dark region, not a dark line running into the bright side (dark_line_end). A
 * line crossing the step both ways (a corner of it) does not. A neighbour without a sample is
 * stood in for by the pixel beyond it on that line; with neither, the line is unknown, which
 * counts as possibly dark. */
static bool inside_bright(size_t p, size_t ow, size_t oh, const uint32_t *cnt, const double *b, double bt,
                          double hi)
{
    if (dark_through(p, ow, oh, cnt, b, bt))
        return false;
    int inside = 0, crossing = -1, side = 0;
    size_t dark_end = SIZE_MAX;
    for (int d = 0; d < 2; d++) { /* DIRS' row, then its column */
        size_t q[2];
        for (int k = 0; k < 2; k++) {
            const int dx = DIRS[d].pair[k][0], dy = DIRS[d].pair[k][1];
            q[k] = sampled_at(p, dx, dy, ow, oh, cnt);
            if (q[k] == SIZE_MAX)
                q[k] = sampled_at(p, 2 * dx, 2 * dy, ow, oh, cnt);
        }
        if (q[0] == SIZE_MAX || q[1] == SIZE_MAX || (b[q[0]] < bt && b[q[1]] < bt))
            return false;
        if (b[q[0]] >= bt && b[q[1]] >= bt)
            inside++;
        else
            crossing = d, side = b[q[0]] < bt ? 0 : 1, dark_end = q[side];
    }
    return inside == 2 || (inside == 1 && !dark_line_end(dark_end, crossing, side, ow, oh, cnt, b, bt, hi));
}

/* Pixel p's value in the image, by the channels' mean (planar, np pixels a channel). */
static double channel_mean(const float *image, size_t np, uint32_t channels, size_t p)
{
    double v = 0;
    for (uint32_t c = 0; c < channels; c++)
        v += image[(size_t)c * np + p];
    return v / channels;
}

/* One call's inputs and per-pixel arrays, for its passes over bands of rows (csi/row_pool.h). */
typedef struct empty_state {
    const float *values;
    const csi_sample_pos *pos;
    const size_t *start; /* each row's samples (csi_recon_sample_rows) */
    uint32_t channels;
    csi_pixel_map map;
    size_t ow, oh, np;
    double e;
    uint32_t *cnt;
    double *m, *b;
    float *image;
    atomic_bool unordered; /* a band's samples were not in row order */
} empty_state;

/* The cap (the header's last paragraph) at pixel p of the step from lo, the darker side (by the
 * channels' mean), to hi: unless the row and the column place p inside the bright side, a value
 * above the step's geometric midpoint is scaled there, all channels together, by the step's
 * ratio's weight. */
static void cap_at_midpoint(empty_state *t, size_t p, double lo, double hi)
{
    const size_t np = t->np;
    const double e = t->e;
    const double capw = ramp(log((hi + e) / (lo + e)), log(EMPTY_CAP_R0), log(EMPTY_CAP_R1));
    const double bt = sqrt((lo + e) * (hi + e)) - e;
    const double here = channel_mean(t->image, np, t->channels, p);
    if (capw <= 0 || here <= bt ||
        inside_bright(p, t->ow, t->oh, t->cnt, t->b, sqrt(csi_fmax(lo, EMPTY_AXIS_FLOOR * hi) * hi), hi))
        return;
    const double scale = 1.0 - capw * (1.0 - bt / here);
    for (uint32_t c = 0; c < t->channels; c++)
        t->image[(size_t)c * np + p] *= (float)scale;
}

/* A pixel of one sample (the header's last paragraph): the step from its sample up to the
 * brightest of its 8 neighbours' means, capped as a pixel without a sample is. */
static void one_sample_pixel(empty_state *t, size_t p)
{
    size_t nb[9];
    const int k = csi_recon_window3_at(p % t->ow, p / t->ow, t->ow, t->oh, nb);
    double hi = -INFINITY;
    for (int j = 0; j < k; j++)
        if (nb[j] != p && t->cnt[nb[j]])
            hi = csi_fmax(hi, t->b[nb[j]]);
    if (hi > t->b[p])
        cap_at_midpoint(t, p, t->b[p], hi);
}

/* Each pixel's count and sums of samples i0 .. i1 - 1, per channel; a band of rows [r0, r1)
 * (check) stops, false, at a sample outside its rows' order before writing anything of it
 * (csi_recon_band_pixel). */
static bool empty_samples(empty_state *t, size_t i0, size_t i1, size_t r0, size_t r1, bool check)
{
    const float *values = t->values;
    const uint32_t channels = t->channels;
    const size_t np = t->np;
    const csi_pixel_map map = t->map;
    uint32_t *cnt = t->cnt;
    double *m = t->m;
    size_t last = r0;
    for (size_t i = i0; i < i1; i++) { /* in sample order: deterministic */
        const size_t p = check ? csi_recon_band_pixel(&map, t->pos[i], r1, &last)
                               : csi_recon_pixel_at(&map, t->pos[i]);
        if (p == SIZE_MAX)
            return false;
        cnt[p]++;
        for (uint32_t c = 0; c < channels; c++)
            m[(size_t)c * np + p] += values[i * channels + c];
    }
    return true;
}

static void empty_clear(empty_state *t, size_t p0, size_t p1)
{
    for (size_t p = p0; p < p1; p++) {
        t->cnt[p] = 0, t->b[p] = 0;
        for (uint32_t c = 0; c < t->channels; c++)
            t->m[(size_t)c * t->np + p] = 0;
    }
}

static void empty_pass_samples(void *arg, size_t r0, size_t r1)
{
    empty_state *t = arg;
    empty_clear(t, r0 * t->ow, r1 * t->ow);
    if (!empty_samples(t, t->start[r0], t->start[r1], r0, r1, true))
        atomic_store(&t->unordered, true);
}

/* The pixels' means, and their mean over the channels. */
static void empty_pass_means(void *arg, size_t r0, size_t r1)
{
    empty_state *t = arg;
    const uint32_t channels = t->channels;
    const size_t np = t->np;
    for (size_t p = r0 * t->ow; p < r1 * t->ow; p++) {
        if (!t->cnt[p])
            continue;
        for (uint32_t c = 0; c < channels; c++) {
            t->m[(size_t)c * np + p] /= t->cnt[p];
            t->b[p] += t->m[(size_t)c * np + p];
        }
        t->b[p] = csi_fmax(t->b[p] / channels, 0.0);
    }
}

/* The rule at each pixel of the band without a sample: it reads its neighbours' means and writes
 * its own pixel only. */
static void empty_pass_pixels(void *arg, size_t r0, size_t r1)
{
    empty_state *t = arg;
    const uint32_t channels = t->channels, *cnt = t->cnt;
    const size_t ow = t->ow, oh = t->oh, np = t->np;
    const double e = t->e, *m = t->m, *b = t->b;
    float *image = t->image;
    for (size_t py = r0; py < r1; py++)
        for (size_t px = 0; px < ow; px++) {
            const size_t p = py * ow + px;
            if (cnt[p]) {
                if (cnt[p] == 1)
                    one_sample_pixel(t, p);
                continue;
            }
            size_t nb[9];
            const int k = csi_recon_window3_at(px, py, ow, oh, nb);
            double lo = INFINITY, hi = -INFINITY;
            for (int j = 0; j < k; j++)
                if (cnt[nb[j]])
                    lo = csi_fmin(lo, b[nb[j]]), hi = csi_fmax(hi, b[nb[j]]);
            if (!(hi > lo))
                continue;
            const double f = (channel_mean(image, np, channels, p) - lo) / (hi - lo);
            const double ratio = log((hi + e) / (lo + e));
            const double step = ramp(ratio, log(EMPTY_R0), log(EMPTY_R1));
            if (step <= 0)
                continue;
            const double bt = sqrt((lo + e) * (hi + e)) - e; /* bright: above the step's geometric midpoint */
            const double alone = 1.0 - ramp(beyond(p, ow, oh, cnt, b, lo, bt), EMPTY_BEYOND0, EMPTY_BEYOND1);
            const double F = EMPTY_F + (EMPTY_F_ALONE - EMPTY_F) * alone;
            const double w = step * (1.0 - ramp(f, 0.5 * F, F));
            for (uint32_t c = 0; c < channels && w > 0; c++) {
                double d = INFINITY;
                for (int j = 0; j < k; j++)
                    if (cnt[nb[j]])
                        d = csi_fmin(d, m[(size_t)c * np + nb[j]]);
                float *x = image + (size_t)c * np + p;
                if (*x > d)
                    *x = (float)(*x - w * (*x - d));
            }
            /* then the line the pixel lies on, from the value the fraction's rule left */
            const double split = sqrt(csi_fmax(lo, EMPTY_SIDE_FLOOR * hi) * hi);
            const int d = dark_line(p, ow, oh, cnt, b, split, channel_mean(image, np, channels, p));
            if (d >= 0) {
                const size_t a = sampled_at(p, DIRS[d].pair[0][0], DIRS[d].pair[0][1], ow, oh, cnt);
                const size_t z = sampled_at(p, DIRS[d].pair[1][0], DIRS[d].pair[1][1], ow, oh, cnt);
                for (uint32_t c = 0; c < channels; c++) {
                    const double mid = 0.5 * (m[(size_t)c * np + a] + m[(size_t)c * np + z]);
                    float *x = image + (size_t)c * np + p;
                    if (*x > mid)
                        *x = (float)(*x - step * (*x - mid));
                }
            }
            /* last, the cap at the step's geometric midpoint */
            cap_at_midpoint(t, p, lo, hi);
        }
}

csi_status csi_empty_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                            const float *values, size_t n, csi_row_pool *pool, float *image)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    empty_state t = {
        .values = values, .pos = pos, .channels = channels, .map = csi_recon_pixel_map(g), .ow = ow,
        .oh = oh, .np = np, .image = image,
    };
    atomic_init(&t.unordered, false);
    size_t *start = malloc((oh + 1) * sizeof *start);
    t.start = start;
    t.cnt = malloc(np * sizeof *t.cnt);
    t.m = malloc(np * channels * sizeof *t.m), t.b = malloc(np * sizeof *t.b);
    if (!start || !t.cnt || !t.m || !t.b) {
        free(start), free(t.cnt), free(t.m), free(t.b);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    csi_recon_sample_rows(g, pos, n, start);
    csi_row_pool_run(pool, oh, ow, empty_pass_samples, &t);
    if (atomic_load(&t.unordered)) {
        empty_clear(&t, 0, np);
        empty_samples(&t, 0, n, 0, oh, false);
    }
    double sabs = 0;
    for (size_t i = 0; i < n * channels; i++) /* in sample order: the same sum */
        sabs += fabs((double)values[i]);
    csi_row_pool_run(pool, oh, ow, empty_pass_means, &t);
    t.e = EMPTY_EPS_REL * (n ? sabs / (double)n / channels : 0.0);
    csi_row_pool_run(pool, oh, ow, empty_pass_pixels, &t);
    free(start), free(t.cnt), free(t.m), free(t.b);
    return CSI_OK;
}
