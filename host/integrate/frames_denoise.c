/* A volume's frames when its samples are noisy (csi/frames_denoise.h has the why and the rule). */
#include "csi/frames_denoise.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* Step 2's widths, (sigma_xy, sigma_t), tried in this order (a tie keeps the earlier: the
 * smaller). Each is an index into SXY and ST below. */
static const uint8_t WIDTH_AT[CSI_FRAMES_DENOISE_WIDTHS][2] = {
    {0, 0}, {1, 0}, {1, 1}, {1, 2}, {2, 0}, {2, 1}, {2, 2}, {3, 0}, {3, 1}, {3, 2}};
static const double SXY[4] = {0, 0.5, 0.75, 1.0};
static const double ST[3] = {0, 0.5, 1.0};
#define RMAX 3 /* ceil(3 sigma) of the widest */
/* Samples step 2's choice is judged on at most (one width for a whole volume: this many squared
 * errors pin it down, and each costs about 1400 bilinear reads) */
#define CV_SAMPLES ((size_t)1 << 17)

/* Gaussian taps exp(-d^2 / (2 sigma^2)) for d = 0..RMAX, 0 beyond ceil(3 sigma) (sigma 0: the
 * centre alone). */
static void taps(double sigma, double g[RMAX + 1])
{
    const int r = sigma > 0 ? (int)ceil(3 * sigma) : 0;
    for (int d = 0; d <= RMAX; d++)
        g[d] = d > r ? 0 : (sigma > 0 ? exp(-(double)(d * d) / (2 * sigma * sigma)) : 1);
}

int csi_frames_denoise_noisy(const double noise[4], uint32_t channels)
{
    for (uint32_t c = 0; c < channels && c < 4; c++)
        if (noise[c] > 0)
            return 1;
    return 0;
}

typedef struct {
    size_t cell; /* t * np + y * w + x */
    size_t index;
} cell_sample;

static int by_cell(const void *a, const void *b)
{
    const cell_sample *p = a, *q = b;
    if (p->cell != q->cell)
        return p->cell < q->cell ? -1 : 1;
    return p->index < q->index ? -1 : p->index > q->index;
}

/* A sampled cell: its samples are order[first .. first + m). */
typedef struct {
    size_t cell, first;
    uint32_t m;
} sampled_cell;

typedef struct {
    size_t w, h, t, np;
    const uint8_t *bits; /* sampled cells */
} vol;

static inline int sampled(const vol *v, size_t cell)
{
    return (v->bits[cell >> 3] >> (cell & 7)) & 1;
}

/* The mean of the unsampled 8 neighbours of `cell` in its frame, or its own value. */
static double neighbours(const vol *v, const float *f, size_t stride_t, size_t cell)
{
    const size_t t = cell / v->np, q = cell % v->np, x = q % v->w, y = q / v->w;
    const float *frame = f + t * stride_t;
    double sum = 0;
    int cnt = 0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            if ((!dy && !dx) || (!y && dy < 0) || (!x && dx < 0) || (y + 1 == v->h && dy > 0) ||
                (x + 1 == v->w && dx > 0))
                continue;
            const size_t qq = (size_t)((ptrdiff_t)q + dy * (ptrdiff_t)v->w + dx);
            if (sampled(v, t * v->np + qq))
                continue;
            sum += frame[qq];
            cnt++;
        }
    return cnt ? sum / cnt : frame[q];
}

/* Bilinear value of frame f (w x h) at (yf, xf) and the weight of its taps inside the frame
 * (the taps of weight 0 skipped: an integer position reads its cell alone). */
static double bilinear(const vol *v, const float *f, double yf, double xf, double *cover)
{
    const double y0 = floor(yf), x0 = floor(xf), fy = yf - y0, fx = xf - x0;
    const double wy[2] = {1 - fy, fy}, wx[2] = {1 - fx, fx};
    double val = 0, cov = 0;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            const double w = wy[i] * wx[j], yy = y0 + i, xx = x0 + j;
            if (w <= 0 || yy < 0 || xx < 0 || yy >= (double)v->h || xx >= (double)v->w)
                continue;
            val += w * f[(size_t)yy * v->w + (size_t)xx];
            cov += w;
        }
    *cover = cov;
    return val;
}

/* Adds to err[] each width's squared error at the sample of value y in `cell`: the frames f
 * (frame stride stride_t) smoothed by the width, along t at velocity (vx, vy) first (each
 * point's taps renormalised by their weight inside the frames), then along x and y (renormalised
 * by the weight of the points inside the image): what step 2's smoothing gives there. */
static void width_errors(const vol *v, const float *f, size_t stride_t, size_t cell, double y, const double vel[2],
                         const double gs[4][RMAX + 1], const double gt[3][RMAX + 1], double *err)
{
    const ptrdiff_t t0 = (ptrdiff_t)(cell / v->np), q = (ptrdiff_t)(cell % v->np);
    const ptrdiff_t x0 = q % (ptrdiff_t)v->w, y0 = q / (ptrdiff_t)v->w;
    double s[4][3] = {{0}}, wsum[4][3] = {{0}};
    for (ptrdiff_t dy = -RMAX; dy <= RMAX; dy++) {
        const ptrdiff_t yy = y0 + dy;
        if (yy < 0 || yy >= (ptrdiff_t)v->h)
            continue;
        const size_t ay = (size_t)(dy < 0 ? -dy : dy);
        for (ptrdiff_t dx = -RMAX; dx <= RMAX; dx++) {
            const ptrdiff_t xx = x0 + dx;
            if (xx < 0 || xx >= (ptrdiff_t)v->w)
                continue;
            const size_t ax = (size_t)(dx < 0 ? -dx : dx);
            /* the point smoothed along t at the velocity, by each temporal width */
            double num[3] = {0}, den[3] = {0};
            for (ptrdiff_t dt = -RMAX; dt <= RMAX; dt++) {
                const ptrdiff_t t = t0 + dt;
                const size_t at = (size_t)(dt < 0 ? -dt : dt);
                if (t < 0 || t >= (ptrdiff_t)v->t || (gt[1][at] == 0 && gt[2][at] == 0 && dt))
                    continue;
                double cov;
                const double val = bilinear(v, f + (size_t)t * stride_t, (double)yy + vel[1] * (double)dt,
                                            (double)xx + vel[0] * (double)dt, &cov);
                for (int b = 0; b < 3; b++) {
                    num[b] += gt[b][at] * val;
                    den[b] += gt[b][at] * cov;
                }
            }
            for (int b = 0; b < 3; b++) {
                const double pt = num[b] / den[b]; /* den > 0: the point itself, dt = 0, is inside */
                for (int a = 0; a < 4; a++) {
                    const double g = gs[a][ay] * gs[a][ax];
                    s[a][b] += g * pt;
                    wsum[a][b] += g;
                }
            }
        }
    }
    for (int k = 0; k < CSI_FRAMES_DENOISE_WIDTHS; k++) {
        const int a = WIDTH_AT[k][0], b = WIDTH_AT[k][1];
        const double e = s[a][b] / wsum[a][b] - y;
        err[k] += e * e;
    }
}

/* Step 2's pass along t at velocity vel of channel plane f (frame stride stride_t), from a copy
 * of it (src, frame stride np): each point the Gaussian g (radius r) of the bilinear values along
 * its path, renormalised by the taps' weight inside the frames. */
static void smooth_t(const vol *v, const float *src, float *f, size_t stride_t, const double vel[2],
                     const double g[RMAX + 1], int r)
{
    for (size_t t = 0; t < v->t; t++)
        for (size_t y = 0; y < v->h; y++)
            for (size_t x = 0; x < v->w; x++) {
                double num = 0, den = 0;
                for (int d = -r; d <= r; d++) {
                    const ptrdiff_t s = (ptrdiff_t)t + d;
                    if (s < 0 || s >= (ptrdiff_t)v->t)
                        continue;
                    double cov;
                    const double val = bilinear(v, src + (size_t)s * v->np, (double)y + vel[1] * d,
                                                (double)x + vel[0] * d, &cov);
                    num += g[d < 0 ? -d : d] * val;
                    den += g[d < 0 ? -d : d] * cov;
                }
                f[t * stride_t + y * v->w + x] = (float)(num / den);
            }
}

/* One pass of the Gaussian g (radius r) along a line of len values at stride, cut at its ends;
 * line: scratch of len doubles. */
static void smooth_line(float *p, size_t len, size_t stride, const double g[RMAX + 1], int r, double *line)
{
    for (size_t i = 0; i < len; i++)
        line[i] = p[i * stride];
    for (size_t i = 0; i < len; i++) {
        double num = 0, den = 0;
        for (int d = -r; d <= r; d++) {
            const ptrdiff_t j = (ptrdiff_t)i + d;
            if (j < 0 || j >= (ptrdiff_t)len)
                continue;
            const double w = g[d < 0 ? -d : d];
            num += w * line[j];
            den += w;
        }
        p[i * stride] = (float)(num / den);
    }
}

csi_status csi_frames_denoise(const csi_grid *g, uint32_t nframes, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const double noise[4], const double velocity[2], float *frames, double chosen[2])
{
    if (chosen)
        chosen[0] = chosen[1] = -1;
    if (g->w != g->out_w || g->h != g->out_h || nframes == 0 || nframes > g->t || n == 0 || channels == 0)
        return CSI_OK;
    vol v = {g->w, g->h, nframes, (size_t)g->w * g->h, NULL};
    const double vel[2] = {velocity ? velocity[0] : 0, velocity ? velocity[1] : 0};
    const size_t cells = v.np * v.t, stride_t = (size_t)channels * v.np;
    uint8_t *bits = calloc(cells / 8 + 1, 1);
    cell_sample *order = malloc(n * sizeof *order);
    sampled_cell *sc = malloc(n * sizeof *sc);
    double *d = malloc(n * sizeof *d), *ybar = malloc(n * sizeof *ybar);
    double *line = malloc((v.w > v.h ? v.w : v.h) * sizeof *line);
    if (!bits || !order || !sc || !d || !ybar || !line) {
        free(bits), free(order), free(sc), free(d), free(ybar), free(line);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory denoising %zu cells of frames", cells);
    }
    v.bits = bits;
    /* the samples of the frames by cell, then index: the same order on every run */
    size_t used = 0;
    for (size_t i = 0; i < n; i++)
        if (pos[i].t < nframes && pos[i].x < v.w && pos[i].y < v.h)
            order[used++] = (cell_sample){(size_t)pos[i].t * v.np + (size_t)pos[i].y * v.w + pos[i].x, i};
    qsort(order, used, sizeof *order, by_cell);
    size_t nc = 0;
    for (size_t j = 0; j < used; j++) {
        if (nc && sc[nc - 1].cell == order[j].cell) {
            sc[nc - 1].m++;
            continue;
        }
        sc[nc++] = (sampled_cell){order[j].cell, j, 1};
        bits[order[j].cell >> 3] |= (uint8_t)(1u << (order[j].cell & 7));
    }
    /* the choice judged on every sample up to CV_SAMPLES, beyond on every cv_step-th (in cell
     * order: spread over the volume) */
    const size_t cv_step = used > CV_SAMPLES ? (used + CV_SAMPLES - 1) / CV_SAMPLES : 1;
    double gs[4][RMAX + 1], gt[3][RMAX + 1], err[CSI_FRAMES_DENOISE_WIDTHS] = {0};
    for (int a = 0; a < 4; a++)
        taps(SXY[a], gs[a]);
    for (int b = 0; b < 3; b++)
        taps(ST[b], gt[b]);
    for (uint32_t c = 0; c < channels && used; c++) {
        float *f = frames + (size_t)c * v.np; /* frame t of channel c at f + t * stride_t */
        double level = 0;
        for (size_t j = 0; j < used; j++)
            level += fabs((double)values[order[j].index * channels + c]);
        level /= (double)used;
        const double s2 = noise[c] * level * noise[c] * level;
        /* step 1: each sampled cell's prediction from its neighbours, and its samples' mean */
        double e2 = 0;
        for (size_t j = 0; j < nc; j++) {
            const size_t cell = sc[j].cell;
            d[j] = neighbours(&v, f, stride_t, cell);
            double sum = 0;
            for (uint32_t k = 0; k < sc[j].m; k++)
                sum += values[order[sc[j].first + k].index * channels + c];
            ybar[j] = sum / sc[j].m;
            e2 += (ybar[j] - d[j]) * (ybar[j] - d[j]) - s2 / sc[j].m;
        }
        const double vd = e2 > 0 ? e2 / (double)nc : 0;
        /* step 2's choice on the frames with each sampled cell at its neighbours' value */
        for (size_t j = 0; j < nc; j++)
            f[(sc[j].cell / v.np) * stride_t + sc[j].cell % v.np] = (float)d[j];
        for (size_t j = 0; j < used; j += cv_step)
            width_errors(&v, f, stride_t, order[j].cell, values[order[j].index * channels + c], vel, gs, gt, err);
        for (size_t j = 0; j < nc; j++) {
            const double var = s2 / sc[j].m, k = vd + var > 0 ? vd / (vd + var) : 1;
            f[(sc[j].cell / v.np) * stride_t + sc[j].cell % v.np] = (float)(d[j] + k * (ybar[j] - d[j]));
        }
    }
    int best = 0;
    for (int k = 1; k < CSI_FRAMES_DENOISE_WIDTHS; k++)
        if (err[k] < err[best])
            best = k;
    const double sxy = SXY[WIDTH_AT[best][0]], st = ST[WIDTH_AT[best][1]];
    const int rxy = sxy > 0 ? (int)ceil(3 * sxy) : 0, rt = st > 0 ? (int)ceil(3 * st) : 0;
    float *copy = rt && used ? malloc(cells * sizeof *copy) : NULL;
    if (rt && used && !copy) {
        free(bits), free(order), free(sc), free(d), free(ybar), free(line);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory smoothing %zu cells of frames", cells);
    }
    for (uint32_t c = 0; c < channels && used; c++) {
        float *f = frames + (size_t)c * v.np;
        if (rt) { /* along t first, from a copy of the plane */
            for (size_t t = 0; t < v.t; t++)
                memcpy(copy + t * v.np, f + t * stride_t, v.np * sizeof *copy);
            smooth_t(&v, copy, f, stride_t, vel, gt[WIDTH_AT[best][1]], rt);
        }
        for (size_t t = 0; rxy && t < v.t; t++) {
            float *frame = f + t * stride_t;
            for (size_t y = 0; y < v.h; y++)
                smooth_line(frame + y * v.w, v.w, 1, gs[WIDTH_AT[best][0]], rxy, line);
            for (size_t x = 0; x < v.w; x++)
                smooth_line(frame + x, v.h, v.w, gs[WIDTH_AT[best][0]], rxy, line);
        }
    }
    if (chosen && used) {
        chosen[0] = sxy;
        chosen[1] = st;
    }
    free(bits), free(order), free(sc), free(d), free(ybar), free(line), free(copy);
    return CSI_OK;
}
