/* A volume's frames when its samples are noisy (csi/frames_denoise.h has the why and the rule). */
#include "csi/frames_denoise.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"

/* Step 2's widths, (sigma_xy, sigma_t), tried in this order (a tie keeps the earlier: the
 * smaller). Each is an index into SXY and ST below. */
static const uint8_t WIDTH_AT[CSI_FRAMES_DENOISE_WIDTHS][2] = {
    {0, 0}, {1, 0}, {1, 1}, {1, 2}, {1, 3}, {2, 0}, {2, 1}, {2, 2}, {2, 3},
    {3, 0}, {3, 1}, {3, 2}, {3, 3}, {4, 0}, {4, 1}, {4, 2}, {4, 3}};
#define NXY 5
#define NT 4
static const double SXY[NXY] = {0, 0.5, 0.75, 1.0, 1.5};
static const double ST[NT] = {0, 0.5, 1.0, 1.5};
#define RMAX 5 /* ceil(3 sigma) of the widest */
/* Twice the samples a fold's errors are judged on at most (one width for a whole volume: this
 * many squared errors pin it down, and each costs a few thousand bilinear reads) */
#define CV_SAMPLES ((size_t)1 << 15)

/* Gaussian taps exp(-d^2 / (2 sigma^2)) for d = 0..RMAX, 0 beyond ceil(3 sigma) (sigma 0: the
 * centre alone). */
static void taps(double sigma, double g[RMAX + 1])
{
    const int r = sigma > 0 ? (int)ceil(3 * sigma) : 0;
    for (int d = 0; d <= RMAX; d++)
        g[d] = d > r ? 0 : (sigma > 0 ? exp(-(double)(d * d) / (2 * sigma * sigma)) : 1);
}

void csi_frames_fold_options(const csi_recon_options *opt, const csi_recon_result *whole, csi_recon_options *out)
{
    int most = 0;
    for (uint32_t c = 0; c < whole->channels && c < 4; c++)
        if (whole->report[c].iterations > most)
            most = whole->report[c].iterations;
    int cap = 2 * most > CSI_FRAMES_FOLD_MIN_ITER ? 2 * most : CSI_FRAMES_FOLD_MIN_ITER;
    if (whole->options.max_iter > 0 && cap > whole->options.max_iter)
        cap = whole->options.max_iter;
    *out = *opt;
    out->frames = true;
    out->frames_denoise = CSI_SWITCH_OFF;
    out->image_frames = CSI_SWITCH_OFF;
    out->motion_image_cv = CSI_SWITCH_OFF; /* the image is not asked for */
    out->max_iter = cap;
    if (opt->motion_time == CSI_MOTION_TIME_AUTO)
        out->motion_time = whole->options.motion_time;
}

void csi_frames_fold_samples(const float *values, const float *variance, uint32_t channels, const size_t *index,
                             size_t count, float *v, float *var)
{
    for (size_t j = 0; j < count; j++) {
        const size_t i = index ? index[j] : j;
        if (channels == 1) {
            v[j] = values[i];
            if (variance)
                var[j] = variance[i];
            continue;
        }
        double m = 0, sd = 0;
        for (uint32_t c = 0; c < channels; c++) {
            m += values[i * channels + c];
            if (variance)
                sd += sqrt((double)variance[i * channels + c]);
        }
        v[j] = (float)(m / channels);
        if (variance) {
            const double s = sd / channels;
            var[j] = (float)(s * s);
        }
    }
}

double csi_frames_fold_noise(const float *values, size_t n, uint32_t channels, const double noise[4])
{
    if (channels == 1 || n == 0)
        return noise[0];
    double mean_abs = 0, level[4] = {0, 0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        double m = 0;
        for (uint32_t c = 0; c < channels; c++) {
            m += values[i * channels + c];
            if (c < 4)
                level[c] += fabs((double)values[i * channels + c]);
        }
        mean_abs += fabs(m / channels);
    }
    double sd = 0;
    for (uint32_t c = 0; c < channels && c < 4; c++)
        sd += noise[c] * level[c] / (double)n;
    return mean_abs > 0 ? sd / channels / (mean_abs / (double)n) : 0;
}

int csi_frames_denoise_noisy(const double noise[4], uint32_t channels)
{
    for (uint32_t c = 0; c < channels && c < 4; c++)
        if (noise[c] >= CSI_FRAMES_DENOISE_NOISE_MIN)
            return 1;
    return 0;
}

typedef struct {
    size_t w, h, t, np;
} vol;

/* ---- samples by cell -------------------------------------------------------------------- */

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

/* Samples of a volume's frames (those of one fold, or all), sorted by cell then index: the same
 * order on every run. */
typedef struct {
    cell_sample *order;
    size_t used;
    sampled_cell *sc;
    size_t nc;
    uint8_t *bits; /* the sampled cells */
} cell_set;

static void cell_set_free(cell_set *s)
{
    free(s->order), free(s->sc), free(s->bits);
    memset(s, 0, sizeof *s);
}

/* The fold of a cell: a hash of its index (splitmix64's finaliser), so that a cell's samples
 * are in one fold and the folds interleave everywhere. */
static int fold_of(size_t cell)
{
    return (int)(csi_mix64((uint64_t)cell + 0x9e3779b97f4a7c15ull) & 1);
}

/* The samples at frames < v->t (and of fold `fold`, or all with -1). */
static csi_status cell_set_make(const vol *v, const csi_sample_pos *pos, size_t n, int fold, cell_set *s)
{
    memset(s, 0, sizeof *s);
    const size_t cells = v->np * v->t;
    s->order = malloc((n ? n : 1) * sizeof *s->order);
    s->sc = malloc((n ? n : 1) * sizeof *s->sc);
    s->bits = calloc(cells / 8 + 1, 1);
    if (!s->order || !s->sc || !s->bits) {
        cell_set_free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory denoising %zu cells of frames", cells);
    }
    for (size_t i = 0; i < n; i++) {
        if (pos[i].t >= v->t || pos[i].x >= v->w || pos[i].y >= v->h)
            continue;
        const size_t cell = (size_t)pos[i].t * v->np + (size_t)pos[i].y * v->w + pos[i].x;
        if (fold < 0 || fold_of(cell) == fold)
            s->order[s->used++] = (cell_sample){cell, i};
    }
    qsort(s->order, s->used, sizeof *s->order, by_cell);
    for (size_t j = 0; j < s->used; j++) {
        if (s->nc && s->sc[s->nc - 1].cell == s->order[j].cell) {
            s->sc[s->nc - 1].m++;
            continue;
        }
        s->sc[s->nc++] = (sampled_cell){s->order[j].cell, j, 1};
        s->bits[s->order[j].cell >> 3] |= (uint8_t)(1u << (s->order[j].cell & 7));
    }
    return CSI_OK;
}

/* ---- step 1 ------------------------------------------------------------------------------ */

/* The mean of the unsampled 8 neighbours of `cell` in its frame, or its own value. */
static double neighbours(const vol *v, const uint8_t *bits, const float *f, size_t stride_t, size_t cell)
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
            const size_t qq = (size_t)((ptrdiff_t)q + dy * (ptrdiff_t)v->w + dx), nb = t * v->np + qq;
            if ((bits[nb >> 3] >> (nb & 7)) & 1)
                continue;
            sum += frame[qq];
            cnt++;
        }
    return cnt ? sum / cnt : frame[q];
}

/* Step 1 on the frames of every channel, with the samples of s. */
static csi_status cells_step(const vol *v, uint32_t channels, const float *values, const cell_set *s,
                             const double noise[4], float *frames)
{
    const size_t stride_t = (size_t)channels * v->np;
    double *d = malloc((s->nc ? s->nc : 1) * sizeof *d), *ybar = malloc((s->nc ? s->nc : 1) * sizeof *ybar);
    if (!d || !ybar) {
        free(d), free(ybar);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory denoising the frames' %zu sampled cells", s->nc);
    }
    for (uint32_t c = 0; c < channels && s->used; c++) {
        float *f = frames + (size_t)c * v->np; /* frame t of channel c at f + t * stride_t */
        double level = 0;
        for (size_t j = 0; j < s->used; j++)
            level += fabs((double)values[s->order[j].index * channels + c]);
        level /= (double)s->used;
        const double s2 = noise[c] * level * noise[c] * level;
        double e2 = 0;
        for (size_t j = 0; j < s->nc; j++) {
            d[j] = neighbours(v, s->bits, f, stride_t, s->sc[j].cell);
            double sum = 0;
            for (uint32_t k = 0; k < s->sc[j].m; k++)
                sum += values[s->order[s->sc[j].first + k].index * channels + c];
            ybar[j] = sum / s->sc[j].m;
            e2 += (ybar[j] - d[j]) * (ybar[j] - d[j]) - s2 / s->sc[j].m;
        }
        const double vd = e2 > 0 ? e2 / (double)s->nc : 0;
        for (size_t j = 0; j < s->nc; j++) {
            const double var = s2 / s->sc[j].m, k = vd + var > 0 ? vd / (vd + var) : 1;
            f[(s->sc[j].cell / v->np) * stride_t + s->sc[j].cell % v->np] = (float)(d[j] + k * (ybar[j] - d[j]));
        }
    }
    free(d), free(ybar);
    return CSI_OK;
}

/* ---- step 2 ------------------------------------------------------------------------------ */

/* The path of a point along t at the velocity: at d frames from it, the integer offset and the
 * bilinear fraction of (vy d, vx d), the same for every point. */
typedef struct {
    ptrdiff_t oy[2 * RMAX + 1], ox[2 * RMAX + 1];
    double fy[2 * RMAX + 1], fx[2 * RMAX + 1];
} path_steps;

static void path_make(const double vel[2], path_steps *p)
{
    for (int d = -RMAX; d <= RMAX; d++) {
        const double py = vel[1] * d, px = vel[0] * d, iy = floor(py), ix = floor(px);
        p->oy[d + RMAX] = (ptrdiff_t)iy;
        p->ox[d + RMAX] = (ptrdiff_t)ix;
        p->fy[d + RMAX] = py - iy;
        p->fx[d + RMAX] = px - ix;
    }
}

/* The frame f bilinearly at (y0 + fy, x0 + fx): taps of weight 0 skipped (an integer position
 * reads its cell alone) and taps outside the frame left out; *cover the weight of those read. */
static double bilinear(const vol *v, const float *f, ptrdiff_t y0, ptrdiff_t x0, double fy, double fx, double *cover)
{
    const double wy[2] = {1 - fy, fy}, wx[2] = {1 - fx, fx};
    double val = 0, cov = 0;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            const double w = wy[i] * wx[j];
            const ptrdiff_t yy = y0 + i, xx = x0 + j;
            if (w <= 0 || yy < 0 || xx < 0 || yy >= (ptrdiff_t)v->h || xx >= (ptrdiff_t)v->w)
                continue;
            val += w * f[(size_t)yy * v->w + (size_t)xx];
            cov += w;
        }
    *cover = cov;
    return val;
}

/* Adds to err[] each width's squared error at the sample of value y in `cell`: the frames f
 * (frame stride stride_t) smoothed by the width, along t on the velocity's path ps first (each point's
 * taps renormalised by their weight inside the frames), then along x and y (renormalised by the
 * weight of the points inside the image): what step 2's smoothing gives there. */
static void width_errors(const vol *v, const float *f, size_t stride_t, size_t cell, double y, const path_steps *ps,
                         const double gs[NXY][RMAX + 1], const double gt[NT][RMAX + 1], double *err)
{
    const ptrdiff_t t0 = (ptrdiff_t)(cell / v->np), q = (ptrdiff_t)(cell % v->np);
    const ptrdiff_t x0 = q % (ptrdiff_t)v->w, y0 = q / (ptrdiff_t)v->w;
    double s[NXY][NT] = {{0}}, wsum[NXY][NT] = {{0}};
    for (ptrdiff_t dy = -RMAX; dy <= RMAX; dy++) {
        const ptrdiff_t yy = y0 + dy;
        if (yy < 0 || yy >= (ptrdiff_t)v->h)
            continue;
        const size_t ay = (size_t)(dy < 0 ? -dy : dy);
        for (ptrdiff_t dx = -RMAX; dx <= RMAX; dx++) {
            const ptrdiff_t xx = x0 + dx;
            const size_t ax = (size_t)(dx < 0 ? -dx : dx);
            if (xx < 0 || xx >= (ptrdiff_t)v->w || gs[NXY - 1][ay] * gs[NXY - 1][ax] == 0)
                continue;
            /* the point smoothed along t at the velocity, by each temporal width */
            double num[NT] = {0}, den[NT] = {0};
            for (ptrdiff_t dt = -RMAX; dt <= RMAX; dt++) {
                const ptrdiff_t t = t0 + dt;
                const size_t at = (size_t)(dt < 0 ? -dt : dt);
                if (t < 0 || t >= (ptrdiff_t)v->t || gt[NT - 1][at] == 0)
                    continue;
                double cov;
                const int k = (int)dt + RMAX;
                const double val =
                    bilinear(v, f + (size_t)t * stride_t, yy + ps->oy[k], xx + ps->ox[k], ps->fy[k], ps->fx[k], &cov);
                for (int b = 0; b < NT; b++) {
                    num[b] += gt[b][at] * val;
                    den[b] += gt[b][at] * cov;
                }
            }
            for (int b = 0; b < NT; b++) {
                const double pt = num[b] / den[b]; /* den > 0: the point itself, dt = 0, is inside */
                for (int a = 0; a < NXY; a++) {
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

/* Step 2's pass along t at velocity vel of channel plane f (frame stride stride_t), from a copy
 * of it (src, frame stride np): each point the Gaussian g (radius r) of the bilinear values along
 * its path, renormalised by the taps' weight inside the frames. */
static void smooth_t(const vol *v, const float *src, float *f, size_t stride_t, const double vel[2],
                     const double g[RMAX + 1], int r)
{
    path_steps ps;
    path_make(vel, &ps);
    for (size_t t = 0; t < v->t; t++)
        for (size_t y = 0; y < v->h; y++)
            for (size_t x = 0; x < v->w; x++) {
                double num = 0, den = 0;
                for (int d = -r; d <= r; d++) {
                    const ptrdiff_t s = (ptrdiff_t)t + d;
                    if (s < 0 || s >= (ptrdiff_t)v->t)
                        continue;
                    double cov;
                    const int k = d + RMAX;
                    const double val = bilinear(v, src + (size_t)s * v->np, (ptrdiff_t)y + ps.oy[k],
                                                (ptrdiff_t)x + ps.ox[k], ps.fy[k], ps.fx[k], &cov);
                    num += g[d < 0 ? -d : d] * val;
                    den += g[d < 0 ? -d : d] * cov;
                }
                f[t * stride_t + y * v->w + x] = (float)(num / den);
            }
}

/* Step 2's smoothing of every channel of frames by width k. */
static csi_status smooth(const vol *v, uint32_t channels, const double vel[2], int k, float *frames)
{
    const double sxy = SXY[WIDTH_AT[k][0]], st = ST[WIDTH_AT[k][1]];
    const int rxy = sxy > 0 ? (int)ceil(3 * sxy) : 0, rt = st > 0 ? (int)ceil(3 * st) : 0;
    if (!rxy && !rt)
        return CSI_OK;
    double gs[RMAX + 1], gt[RMAX + 1];
    taps(sxy, gs);
    taps(st, gt);
    const size_t cells = v->np * v->t, stride_t = (size_t)channels * v->np;
    double *line = malloc((v->w > v->h ? v->w : v->h) * sizeof *line);
    float *copy = rt ? malloc(cells * sizeof *copy) : NULL;
    if (!line || (rt && !copy)) {
        free(line), free(copy);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory smoothing %zu cells of frames", cells);
    }
    for (uint32_t c = 0; c < channels; c++) {
        float *f = frames + (size_t)c * v->np;
        if (rt) { /* along t first, from a copy of the plane */
            for (size_t t = 0; t < v->t; t++)
                memcpy(copy + t * v->np, f + t * stride_t, v->np * sizeof *copy);
            smooth_t(v, copy, f, stride_t, vel, gt, rt);
        }
        for (size_t t = 0; rxy && t < v->t; t++) {
            float *frame = f + t * stride_t;
            for (size_t y = 0; y < v->h; y++)
                smooth_line(frame + y * v->w, v->w, 1, gs, rxy, line);
            for (size_t x = 0; x < v->w; x++)
                smooth_line(frame + x, v->h, v->w, gs, rxy, line);
        }
    }
    free(line), free(copy);
    return CSI_OK;
}

/* ---- the folds ---------------------------------------------------------------------------- */

/* Fold f solved alone, its frames through step 1, and each width's error at the other fold's
 * samples added to err. values: the samples' channels' means (csi_frames_fold_samples), noise
 * theirs. */
static csi_status fold_errors(const vol *v, const csi_sample_pos *pos, const float *values, size_t n, double noise,
                              int f, csi_frames_fold_solve solve, void *user, double *err)
{
    const double noise1[4] = {noise, 0, 0, 0};
    cell_set mine, other;
    CSI_TRY(cell_set_make(v, pos, n, f, &mine));
    csi_status s = cell_set_make(v, pos, n, 1 - f, &other);
    size_t *index = NULL;
    float *frames = NULL;
    double vel[2] = {0, 0};
    if (s == CSI_OK && mine.used && other.used) {
        if (!(index = malloc(mine.used * sizeof *index)))
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for a fold of %zu samples", mine.used);
        for (size_t j = 0; s == CSI_OK && j < mine.used; j++) /* in cell order */
            index[j] = mine.order[j].index;
        if (s == CSI_OK)
            s = solve(user, index, mine.used, noise, &frames, vel);
        if (s == CSI_OK)
            s = cells_step(v, 1, values, &mine, noise1, frames);
        if (s == CSI_OK) {
            double gs[NXY][RMAX + 1], gt[NT][RMAX + 1];
            for (int a = 0; a < NXY; a++)
                taps(SXY[a], gs[a]);
            for (int b = 0; b < NT; b++)
                taps(ST[b], gt[b]);
            const size_t half = CV_SAMPLES / 2;
            const size_t step = other.used > half ? (other.used + half - 1) / half : 1;
            path_steps ps; /* along the fold's own velocity */
            path_make(vel, &ps);
            for (size_t j = 0; j < other.used; j += step)
                width_errors(v, frames, v->np, other.order[j].cell, values[other.order[j].index], &ps, gs, gt,
                             err);
        }
    }
    free(index), free(frames);
    cell_set_free(&mine);
    cell_set_free(&other);
    return s;
}

csi_status csi_frames_denoise(const csi_grid *g, uint32_t nframes, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const double noise[4], const double velocity[2], csi_frames_fold_solve solve,
                              void *user, float *frames, double chosen[2])
{
    if (chosen)
        chosen[0] = chosen[1] = -1;
    if (g->w != g->out_w || g->h != g->out_h || nframes == 0 || nframes > g->t || n == 0 || channels == 0 ||
        !csi_frames_denoise_noisy(noise, channels))
        return CSI_OK;
    const vol v = {g->w, g->h, nframes, (size_t)g->w * g->h};
    const double vel[2] = {velocity ? velocity[0] : 0, velocity ? velocity[1] : 0};
    cell_set all;
    CSI_TRY(cell_set_make(&v, pos, n, -1, &all));
    /* both folds' errors on a small volume; on a large one, where one fold's errors already pin
     * the width down, the first fold's alone (half the cost) */
    const int folds = all.used >= CSI_FRAMES_DENOISE_ONE_FOLD ? 1 : 2;
    double err[CSI_FRAMES_DENOISE_WIDTHS] = {0};
    /* the folds' samples: each sample's channels' mean */
    float *mean = malloc(n * sizeof *mean);
    csi_status s = mean ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the folds' samples");
    if (s == CSI_OK)
        csi_frames_fold_samples(values, NULL, channels, NULL, n, mean, NULL);
    const double fold_noise = csi_frames_fold_noise(values, n, channels, noise);
    for (int f = 0; f < folds && s == CSI_OK; f++)
        s = fold_errors(&v, pos, mean, n, fold_noise, f, solve, user, err);
    free(mean);
    int best = 0;
    for (int k = 1; k < CSI_FRAMES_DENOISE_WIDTHS; k++)
        if (err[k] < err[best])
            best = k;
    if (s == CSI_OK)
        s = cells_step(&v, channels, values, &all, noise, frames);
    cell_set_free(&all);
    if (s == CSI_OK)
        s = smooth(&v, channels, vel, best, frames);
    if (s == CSI_OK && chosen) {
        chosen[0] = SXY[WIDTH_AT[best][0]];
        chosen[1] = ST[WIDTH_AT[best][1]];
    }
    return s;
}

void csi_frames_denoise_image(const float *frames, uint32_t nframes, uint32_t channels, size_t np, float *image)
{
    for (uint32_t c = 0; c < channels; c++)
        for (size_t p = 0; p < np; p++) {
            double m = 0;
            for (uint32_t t = 0; t < nframes; t++)
                m += frames[((size_t)t * channels + c) * np + p];
            image[(size_t)c * np + p] = (float)(0.5 * ((double)image[(size_t)c * np + p] + m / nframes));
        }
}
