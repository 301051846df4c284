/* An HDR step's pixels given the coverage their neighbourhood's samples allow
 * (csi/step_coverage.h). On the host, in double, each pixel from its window's samples in a fixed
 * order (deterministic); a pixel writes only its own value. */
#include "csi/step_coverage.h"

#include <math.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "csi/convex_band.h"
#include "internal.h"

/* The logistic regression: a small ridge (the classes are separable, so without one the weights
 * grow without bound), a fixed number of Newton steps from zero (the same steps on every machine:
 * the boundary need not be the optimum's, only a separating one). */
#define STEP_RIDGE 1e-3
#define STEP_NEWTON 30
/* Features of the boundary: 1, x, y (a line), then x^2, x y, y^2 (a conic). */
#define STEP_LINE 3
#define STEP_CONIC 6
/* csi_recon takes 1 to 4 channels */
#define STEP_MAX_CHANNELS 4

static void features(double x, double y, double *phi)
{
    phi[0] = 1.0, phi[1] = x, phi[2] = y, phi[3] = x * x, phi[4] = x * y, phi[5] = y * y;
}

/* Solves H w = g for a symmetric positive definite k x k H (Cholesky, in place); 0 if H is not. */
static int solve_spd(double *h, double *g, int k)
{
    for (int j = 0; j < k; j++) {
        double d = h[j * k + j];
        for (int m = 0; m < j; m++)
            d -= h[j * k + m] * h[j * k + m];
        if (!(d > 0))
            return 0;
        d = sqrt(d);
        h[j * k + j] = d;
        for (int i = j + 1; i < k; i++) {
            double s = h[i * k + j];
            for (int m = 0; m < j; m++)
                s -= h[i * k + m] * h[j * k + m];
            h[i * k + j] = s / d;
        }
    }
    for (int i = 0; i < k; i++) {
        double s = g[i];
        for (int m = 0; m < i; m++)
            s -= h[i * k + m] * g[m];
        g[i] = s / h[i * k + i];
    }
    for (int i = k - 1; i >= 0; i--) {
        double s = g[i];
        for (int m = i + 1; m < k; m++)
            s -= h[m * k + i] * g[m];
        g[i] = s / h[i * k + i];
    }
    return 1;
}

/* The boundary's weights w (k features) by ridge-regularised logistic regression of the classes
 * cls (1 bright, 0 dark) on the m samples' positions (x, y); 0 if a Newton system fails. */
static int fit_boundary(const double *x, const double *y, const unsigned char *cls, size_t m, int k, double *w)
{
    double h[STEP_CONIC * STEP_CONIC], g[STEP_CONIC], phi[STEP_CONIC];
    for (int j = 0; j < k; j++)
        w[j] = 0.0;
    for (int it = 0; it < STEP_NEWTON; it++) {
        memset(h, 0, sizeof h), memset(g, 0, sizeof g);
        for (size_t i = 0; i < m; i++) {
            features(x[i], y[i], phi);
            double z = 0;
            for (int j = 0; j < k; j++)
                z += phi[j] * w[j];
            const double p = 1.0 / (1.0 + exp(-csi_fmin(csi_fmax(z, -30.0), 30.0)));
            const double r = p - cls[i], q = p * (1.0 - p) + 1e-6;
            for (int a = 0; a < k; a++) {
                g[a] += phi[a] * r;
                for (int b = 0; b < k; b++)
                    h[a * k + b] += phi[a] * q * phi[b];
            }
        }
        for (int a = 0; a < k; a++)
            g[a] += STEP_RIDGE * w[a], h[a * k + a] += STEP_RIDGE;
        if (!solve_spd(h, g, k))
            return 0;
        for (int a = 0; a < k; a++)
            w[a] -= g[a];
    }
    return 1;
}

static double boundary_at(const double *w, int k, double x, double y)
{
    double phi[STEP_CONIC], z = 0;
    features(x, y, phi);
    for (int j = 0; j < k; j++)
        z += phi[j] * w[j];
    return z;
}

/* The samples the boundary misclassifies (f > 0 is bright). */
static size_t misclassified(const double *w, int k, const double *x, const double *y, const unsigned char *cls,
                            size_t m)
{
    size_t bad = 0;
    for (size_t i = 0; i < m; i++)
        bad += (boundary_at(w, k, x[i], y[i]) > 0) != (cls[i] != 0);
    return bad;
}

/* numpy's default percentile (linear between order statistics) of m sorted values. */
static double percentile(const double *sorted, size_t m, double q)
{
    const double at = q / 100.0 * (double)(m - 1);
    const size_t lo = (size_t)floor(at);
    if (lo + 1 >= m)
        return sorted[m - 1];
    return sorted[lo] + (at - (double)lo) * (sorted[lo + 1] - sorted[lo]);
}

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

typedef struct step_state {
    const csi_sample_pos *pos;
    const float *values;
    const double *lum, *sd; /* each sample's channel mean and noise */
    const size_t *start, *idx; /* each pixel's samples, in sample order: idx[start[p] ..] */
    csi_pixel_map map;
    const csi_point2 *cells; /* a pixel's cells' centres, in pixels from its centre (map.bw x map.bh) */
    uint32_t channels;
    size_t ow, oh, np, window_max;
    double image_mean;
    float *delta;
    atomic_size_t moved;
    atomic_int nomem;
} step_state;

/* Scratch for one band of rows: a window's samples. */
typedef struct step_scratch {
    size_t *ids;
    double *l, *sorted, *x, *y, *span;
    unsigned char *cls, *box;
    csi_point2 *bright, *dark, *hull;
} step_scratch;

/* The mean of the class's samples among the window's first n (n = own: the pixel's own). */
static void class_level(const step_state *t, const step_scratch *s, size_t n, unsigned char cls, double *level)
{
    const uint32_t channels = t->channels;
    size_t k = 0;
    for (uint32_t c = 0; c < channels; c++)
        level[c] = 0.0;
    for (size_t i = 0; i < n; i++)
        if (s->cls[i] == cls) {
            for (uint32_t c = 0; c < channels; c++)
                level[c] += t->values[s->ids[i] * channels + c];
            k++;
        }
    for (uint32_t c = 0; c < channels; c++)
        level[c] /= (double)(k ? k : 1);
}

/* Whether the pixel's own samples (its first `own` window samples) lie one per box of a split of its
 * cells into a x b equal boxes (a b = own): stratified positions, or any that happen to fall so. */
static bool own_one_per_box(const step_state *t, step_scratch *s, size_t own)
{
    const uint32_t bw = t->map.bw, bh = t->map.bh;
    for (size_t a = 1; a <= own; a++) {
        const size_t b = own / a;
        if (own % a || bw % a || bh % b)
            continue;
        const size_t sx = bw / a, sy = bh / b;
        memset(s->box, 0, own);
        bool one = true;
        for (size_t i = 0; i < own && one; i++) {
            const csi_sample_pos q = t->pos[s->ids[i]];
            one = !s->box[(q.y % bh) / sy * a + (q.x % bw) / sx]++;
        }
        if (one)
            return true;
    }
    return false;
}

/* Whether a boundary of the window's shape (k features) fitted to the neighbours' samples alone
 * classes the pixel's own samples right: if not, the shape does not carry across the pixel (a
 * rectangle's corner, a rim that turns inside it). */
static bool boundary_holds(const step_scratch *s, size_t own, size_t m, int k)
{
    double wn[STEP_CONIC];
    return fit_boundary(s->x + own, s->y + own, s->cls + own, m - own, k, wn) &&
           !misclassified(wn, k, s->x, s->y, s->cls, own);
}

/* How a window judges a pixel: its reach in pixels, whether a conic may bound it, whether the
 * boundary's own coverage needs the pixel's own samples to check it, whether a pixel whose own
 * samples are all of one class moves to the window's band (csi/step_coverage.h). */
typedef struct step_window {
    size_t radius;
    bool conic, checked, one_class_to_band;
} step_window;

/* The outer window, then the inner one where the outer's samples are no clean step a line divides. */
static const step_window WIDE = {2, false, false, true}, NEAR = {1, true, true, false};

enum { STEP_NONE = -1, STEP_KEPT = 0, STEP_MOVED = 1 };

/* The samples of the window of radius r about pixel (px, py) in s (the pixel's own first, then its
 * neighbours' in raster order; their luminance, class and position in pixels from the pixel's
 * centre), if they span an HDR step (csi/step_coverage.h's gates): their count, with *own and *kb
 * the pixel's own samples and its bright ones; else 0. */
static size_t window_step(step_state *t, step_scratch *s, size_t px, size_t py, size_t r, size_t *own, size_t *kb)
{
    const size_t ow = t->ow, oh = t->oh, p = py * ow + px;
    *own = t->start[p + 1] - t->start[p], *kb = 0;
    if (!*own)
        return 0;
    size_t m = 0;
    for (size_t i = t->start[p]; i < t->start[p + 1]; i++)
        s->ids[m++] = t->idx[i];
    for (size_t yy = py > r ? py - r : 0; yy <= py + r && yy < oh; yy++)
        for (size_t xx = px > r ? px - r : 0; xx <= px + r && xx < ow; xx++) {
            const size_t q = yy * ow + xx;
            if (q != p)
                for (size_t i = t->start[q]; i < t->start[q + 1]; i++)
                    s->ids[m++] = t->idx[i];
        }
    double hi = -INFINITY, lo = INFINITY;
    for (size_t i = 0; i < m; i++) {
        s->l[i] = s->sorted[i] = t->lum[s->ids[i]];
        hi = csi_fmax(hi, s->l[i]), lo = csi_fmin(lo, s->l[i]);
    }
    if (hi < CSI_STEP_RATIO * csi_fmax(lo, 1e-6 * hi + 1e-30) || hi < CSI_STEP_IMAGE_RATIO * t->image_mean)
        return 0;
    qsort(s->sorted, m, sizeof *s->sorted, cmp_double);
    const double thr = sqrt(percentile(s->sorted, m, 90.0) * csi_fmax(percentile(s->sorted, m, 10.0), 1e-30));
    size_t nb = 0;
    double bmin = INFINITY, bmax = -INFINITY, dmax = -INFINITY;
    for (size_t i = 0; i < m; i++) {
        s->cls[i] = s->l[i] > thr;
        if (s->cls[i]) {
            nb++, bmin = csi_fmin(bmin, s->l[i]), bmax = csi_fmax(bmax, s->l[i]);
            if (t->sd[s->ids[i]] > CSI_STEP_NOISE * s->l[i])
                return 0; /* a bright sample its noise could make: no rim to place */
        } else {
            dmax = csi_fmax(dmax, s->l[i]);
        }
    }
    if (!nb || nb == m || bmin < CSI_STEP_GAP * dmax || bmax > CSI_STEP_SPREAD * bmin)
        return 0;
    for (size_t i = 0; i < *own; i++)
        *kb += s->cls[i];
    const double bw = t->map.bw, bh = t->map.bh;
    for (size_t i = 0; i < m; i++) {
        const csi_sample_pos q = t->pos[s->ids[i]];
        s->x[i] = ((double)q.x + 0.5) / bw - ((double)px + 0.5);
        s->y[i] = ((double)q.y + 0.5) / bh - ((double)py + 0.5);
    }
    return m;
}

/* The pixel's value moved from its share of bright samples to coverage cov: by the change times the
 * difference of the bright and dark levels, each its own samples' mean, or the window's where it
 * has none of a class. */
static int step_move(step_state *t, step_scratch *s, size_t p, size_t own, size_t kb, size_t m, double cov)
{
    const double share = (double)kb / (double)own;
    if (cov == share)
        return STEP_KEPT;
    double bright[STEP_MAX_CHANNELS], dark[STEP_MAX_CHANNELS];
    class_level(t, s, kb ? own : m, 1, bright);
    class_level(t, s, kb < own ? own : m, 0, dark);
    for (uint32_t c = 0; c < t->channels; c++)
        t->delta[(size_t)c * t->np + p] = (float)((cov - share) * (bright[c] - dark[c]));
    return STEP_MOVED;
}

/* The rule on one pixel in one window: STEP_NONE where the window's samples are no step its
 * boundary divides, else STEP_MOVED or STEP_KEPT. *stepped (may be NULL): whether they span a step. */
static int step_in_window(step_state *t, step_scratch *s, size_t px, size_t py, const step_window *win, bool *stepped)
{
    const size_t p = py * t->ow + px;
    size_t own, kb;
    const size_t m = window_step(t, s, px, py, win->radius, &own, &kb);
    if (stepped)
        *stepped = m > 0;
    if (!m)
        return STEP_NONE;
    if ((!kb || kb == own) && !win->one_class_to_band)
        return STEP_KEPT; /* one class of its own: no band of its own (below), and a level of the other
                             class that would be a neighbour's */
    const double bw = t->map.bw, bh = t->map.bh;
    double w[STEP_CONIC];
    int k = STEP_LINE;
    if (!fit_boundary(s->x, s->y, s->cls, m, k, w))
        return STEP_NONE;
    if (misclassified(w, k, s->x, s->y, s->cls, m)) {
        k = STEP_CONIC;
        if (!win->conic || !fit_boundary(s->x, s->y, s->cls, m, k, w) || misclassified(w, k, s->x, s->y, s->cls, m))
            return STEP_NONE;
    }
    /* the band: the boundary's least bright-looking bright sample of the pixel's own and its most
     * bright-looking dark one (the window's samples beyond the pixel bound it too tightly where the
     * rim curves: measured, docs/bench/mitsuba.md) */
    double fb = INFINITY, fd = -INFINITY, fb_win = INFINITY, fd_win = -INFINITY;
    for (size_t i = 0; i < m; i++) {
        const double f = boundary_at(w, k, s->x[i], s->y[i]);
        if (s->cls[i])
            fb_win = csi_fmin(fb_win, f), fb = i < own ? csi_fmin(fb, f) : fb;
        else
            fd_win = csi_fmax(fd_win, f), fd = i < own ? csi_fmax(fd, f) : fd;
    }
    size_t sure_bright = 0, sure_dark = 0, on_bright = 0, win_bright = 0, win_dark = 0;
    for (uint32_t cy = 0; cy < t->map.bh; cy++)
        for (uint32_t cx = 0; cx < t->map.bw; cx++) {
            const double f = boundary_at(w, k, ((double)cx + 0.5) / bw - 0.5, ((double)cy + 0.5) / bh - 0.5);
            sure_bright += f >= fb;
            sure_dark += f <= fd;
            win_bright += f >= fb_win;
            win_dark += f <= fd_win;
            on_bright += f > 0;
        }
    const double cells = bw * bh, c_lo = (double)sure_bright / cells, c_hi = 1.0 - (double)sure_dark / cells;
    if (!kb || kb == own) { /* all its own samples of one class: moved only into the window's band */
        if (k != STEP_LINE || (!kb && own < 2))
            return STEP_KEPT;
        return step_move(t, s, p, own, kb, m, kb ? 1.0 - (double)win_dark / cells : (double)win_bright / cells);
    }
    const double share = (double)kb / (double)own, fitted = (double)on_bright / cells;
    const bool strata = own_one_per_box(t, s, own);
    double est;
    if (win->checked) /* the boundary's where it holds across the pixel from enough samples of its own */
        est = own >= CSI_STEP_FIT_MIN && !strata && boundary_holds(s, own, m, k) ? fitted : share;
    else /* samples one per stratum: their share, moved only into the band the window's samples allow */
        est = strata ? csi_fmin(csi_fmax(share, (double)win_bright / cells), 1.0 - (double)win_dark / cells) : fitted;
    return step_move(t, s, p, own, kb, m, csi_fmin(csi_fmax(est, c_lo), c_hi));
}

/* The wide window's samples where one side of the step is a convex region and the other is not
 * (csi/convex_band.h: no line divides them, else both sides would be): the pixel's share clamped
 * to the coverages every convex region through them allows. STEP_NONE where neither side is. */
static int step_convex(step_state *t, step_scratch *s, size_t px, size_t py)
{
    size_t own, kb;
    const size_t m = window_step(t, s, px, py, WIDE.radius, &own, &kb);
    if (!m || (!kb && own < 2)) /* one dark sample: the wide window's line rule's reason */
        return STEP_NONE;
    /* two samples a pixel of the window at least: fewer rarely show a region that is not convex
     * (at one sample a pixel the rule lost up to 4% of a cell's MSE: measured, session 51) */
    const size_t r = WIDE.radius, x0 = px > r ? px - r : 0, y0 = py > r ? py - r : 0;
    const size_t x1 = px + r < t->ow ? px + r : t->ow - 1, y1 = py + r < t->oh ? py + r : t->oh - 1;
    if (m < 2 * (x1 - x0 + 1) * (y1 - y0 + 1))
        return STEP_NONE;
    size_t nb = 0, nd = 0;
    for (size_t i = 0; i < m; i++) {
        const csi_point2 q = {s->x[i], s->y[i]};
        if (s->cls[i])
            s->bright[nb++] = q;
        else
            s->dark[nd++] = q;
    }
    const size_t n_cells = (size_t)t->map.bw * t->map.bh;
    size_t b_in, b_out, d_in, d_out;
    const bool bright_convex =
        csi_convex_band(s->bright, nb, s->dark, nd, t->cells, n_cells, s->hull, s->span, &b_in, &b_out);
    const bool dark_convex =
        csi_convex_band(s->dark, nd, s->bright, nb, t->cells, n_cells, s->hull, s->span, &d_in, &d_out);
    if (bright_convex == dark_convex)
        return STEP_NONE;
    const double lo = (double)(bright_convex ? b_in : d_out) / (double)n_cells;
    const double hi = 1.0 - (double)(bright_convex ? b_out : d_in) / (double)n_cells;
    if (lo > hi)
        return STEP_NONE;
    const double share = (double)kb / (double)own;
    return step_move(t, s, py * t->ow + px, own, kb, m, csi_fmin(csi_fmax(share, lo), hi));
}

/* The rule on one pixel (csi/step_coverage.h); 1 if it moved. */
static int step_pixel(step_state *t, step_scratch *s, size_t px, size_t py)
{
    bool wide_step;
    const int wide = step_in_window(t, s, px, py, &WIDE, &wide_step);
    if (wide != STEP_NONE)
        return wide == STEP_MOVED;
    /* the convex side only where the wide window spans a step (else it would not: the same window) */
    return step_in_window(t, s, px, py, &NEAR, NULL) == STEP_MOVED ||
           (wide_step && step_convex(t, s, px, py) == STEP_MOVED);
}

static void step_pass(void *arg, size_t r0, size_t r1)
{
    step_state *t = arg;
    const size_t wm = t->window_max ? t->window_max : 1;
    step_scratch s = {malloc(wm * sizeof *s.ids), malloc(wm * sizeof *s.l), malloc(wm * sizeof *s.sorted),
                      malloc(wm * sizeof *s.x), malloc(wm * sizeof *s.y), malloc(3 * wm * sizeof *s.span),
                      malloc(wm), malloc(wm), malloc(wm * sizeof *s.bright), malloc(wm * sizeof *s.dark),
                      malloc(2 * wm * sizeof *s.hull)};
    if (!s.ids || !s.l || !s.sorted || !s.x || !s.y || !s.span || !s.cls || !s.box || !s.bright || !s.dark ||
        !s.hull) {
        atomic_store(&t->nomem, 1);
    } else {
        size_t moved = 0;
        for (size_t py = r0; py < r1; py++)
            for (size_t px = 0; px < t->ow; px++)
                moved += (size_t)step_pixel(t, &s, px, py);
        atomic_fetch_add(&t->moved, moved);
    }
    free(s.ids), free(s.l), free(s.sorted), free(s.x), free(s.y), free(s.span), free(s.cls), free(s.box);
    free(s.bright), free(s.dark), free(s.hull);
}

double csi_step_coverage_mean(const float *values, size_t n, uint32_t channels)
{
    double total = 0;
    for (size_t i = 0; i < n; i++) {
        double l = 0;
        for (uint32_t c = 0; c < channels; c++)
            l += values[i * channels + c];
        total += l / channels;
    }
    return n ? total / (double)n : 0.0;
}

void csi_step_coverage_apply(float *image, const float *delta, size_t count)
{
    for (size_t i = 0; i < count; i++)
        if (delta[i] != 0.0f)
            image[i] = (float)csi_fmax(0.0, (double)image[i] + (double)delta[i]);
}

csi_status csi_step_coverage_delta(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                   const float *values, const float *variance, size_t n, double image_mean,
                                   csi_row_pool *pool, float *delta, size_t *moved)
{
    if (moved)
        *moved = 0;
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "HDR steps' coverage: a volume (%u frames) is not an image", g->t);
    if (channels < 1 || channels > STEP_MAX_CHANNELS)
        return csi_fail(CSI_ERR_ARG, "HDR steps' coverage: %u channels (1 to %d)", channels, STEP_MAX_CHANNELS);
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    memset(delta, 0, np * channels * sizeof *delta);
    const csi_pixel_map map = csi_recon_pixel_map(g);
    if ((uint64_t)map.bw * map.bh <= 1 || !n)
        return CSI_OK; /* one cell per pixel: every sample is its pixel's exact value */
    size_t *start, *idx;
    CSI_TRY(csi_recon_pixel_samples(&map, pos, n, np, &start, &idx));
    double *lum = malloc(n * sizeof *lum), *sd = malloc(n * sizeof *sd);
    csi_point2 *cells = malloc((size_t)map.bw * map.bh * sizeof *cells);
    if (!lum || !sd || !cells) {
        free(start), free(idx), free(lum), free(sd), free(cells);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
    }
    for (uint32_t cy = 0; cy < map.bh; cy++)
        for (uint32_t cx = 0; cx < map.bw; cx++)
            cells[(size_t)cy * map.bw + cx] = (csi_point2){((double)cx + 0.5) / map.bw - 0.5, ((double)cy + 0.5) / map.bh - 0.5};
    for (size_t i = 0; i < n; i++) {
        double l = 0, v = 0;
        for (uint32_t c = 0; c < channels; c++)
            l += values[i * channels + c], v += variance[i * channels + c];
        lum[i] = l / channels, sd[i] = sqrt(v / channels);
    }
    /* the most samples the wider window holds: each band's scratch */
    size_t window_max = 0;
    for (size_t py = 0; py < oh; py++)
        for (size_t px = 0; px < ow; px++) {
            size_t m = 0;
            for (size_t yy = py > WIDE.radius ? py - WIDE.radius : 0; yy <= py + WIDE.radius && yy < oh; yy++)
                for (size_t xx = px > WIDE.radius ? px - WIDE.radius : 0; xx <= px + WIDE.radius && xx < ow; xx++)
                    m += start[yy * ow + xx + 1] - start[yy * ow + xx];
            window_max = m > window_max ? m : window_max;
        }
    step_state t = {
        .pos = pos, .values = values, .lum = lum, .sd = sd, .start = start, .idx = idx, .map = map, .cells = cells,
        .channels = channels, .ow = ow, .oh = oh, .np = np, .window_max = window_max,
        .image_mean = image_mean, .delta = delta,
    };
    atomic_init(&t.moved, 0);
    atomic_init(&t.nomem, 0);
    csi_row_pool_run(pool, oh, ow, step_pass, &t);
    free(start), free(idx), free(lum), free(sd), free(cells);
    if (atomic_load(&t.nomem))
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a window of %zu samples", window_max);
    if (moved)
        *moved = atomic_load(&t.moved);
    return CSI_OK;
}

csi_status csi_step_coverage(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                             const float *values, const float *variance, size_t n, csi_row_pool *pool,
                             float *image, size_t *changed)
{
    if (changed)
        *changed = 0;
    const size_t count = (size_t)g->out_w * g->out_h * channels;
    float *delta = malloc((count ? count : 1) * sizeof *delta);
    if (!delta)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a %ux%u image's changes", g->out_w, g->out_h);
    csi_status s = csi_step_coverage_delta(g, channels, pos, values, variance, n,
                                           csi_step_coverage_mean(values, n, channels), pool, delta, changed);
    if (s == CSI_OK)
        csi_step_coverage_apply(image, delta, count);
    free(delta);
    return s;
}
