/* Smoothings of the samples as further candidates of the cross-validated choice (csi/cv_smooth.h
 * says why and the rule). All on the host, in double, in sample and pixel order: the same inputs
 * give the same bits. */
#include "csi/cv_smooth.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "csi/cv_select.h"
#include "internal.h"

static const double sigmas[CSI_CV_SMOOTH_WIDTHS] = CSI_CV_SMOOTH_SIGMAS;

/* The region of side r (rw per row, the image's shifted by sx, sy) holding pixel p of a row of w. */
static size_t region_of(size_t p, uint32_t w, uint32_t r, uint32_t sx, uint32_t sy, size_t rw)
{
    return (p / w + sy) / r * rw + (p % w + sx) / r;
}

/* One pass of a separable Gaussian over rows [y0, y1) (csi/row_pool.h: each output row depends
 * on the input alone, so any split of the rows gives the same bits). */
typedef struct {
    const double *in, *k; /* k[i + r] for i in [-r, r] */
    double *out;
    uint32_t w, h;
    int r;
} blur_pass;

static void blur_x(void *arg, size_t y0, size_t y1)
{
    const blur_pass *b = arg;
    const long w = b->w, r = b->r;
    for (size_t y = y0; y < y1; y++) {
        const double *in = b->in + y * b->w;
        double *out = b->out + y * b->w;
        for (long x = 0; x < w; x++) {
            const long i0 = x - r < 0 ? -x : -r, i1 = x + r >= w ? w - 1 - x : r;
            double t = 0;
            for (long i = i0; i <= i1; i++)
                t += b->k[i + r] * in[x + i];
            out[x] = t;
        }
    }
}

static void blur_y(void *arg, size_t y0, size_t y1)
{
    const blur_pass *b = arg;
    const long h = b->h, r = b->r;
    const size_t w = b->w;
    for (size_t y = y0; y < y1; y++) {
        double *out = b->out + y * w;
        const long yy = (long)y, i0 = yy - r < 0 ? -yy : -r, i1 = yy + r >= h ? h - 1 - yy : r;
        for (size_t x = 0; x < w; x++)
            out[x] = 0;
        for (long i = i0; i <= i1; i++) {
            const double k = b->k[i + r], *in = b->in + (size_t)(yy + i) * w;
            for (size_t x = 0; x < w; x++)
                out[x] += k * in[x];
        }
    }
}

/* out = the plane `in` (w x h) convolved with a Gaussian of standard deviation sigma truncated at
 * 3 sigma, zero outside; tmp holds w * h. Separable: along x into tmp, along y into out. */
static void gauss_plane(csi_row_pool *pool, const double *in, double *out, double *tmp, uint32_t w, uint32_t h,
                        double sigma)
{
    const int r = (int)ceil(3 * sigma);
    double k[64];
    for (int i = -r; i <= r; i++)
        k[i + r] = exp(-0.5 * i * i / (sigma * sigma));
    blur_pass b = {in, k, tmp, w, h, r};
    csi_row_pool_run(pool, h, w, blur_x, &b);
    b.in = tmp;
    b.out = out;
    csi_row_pool_run(pool, h, w, blur_y, &b);
}

/* The normalized convolution of `planes` sum planes by the count plane cnt: out[c * np + p] =
 * (K * sum_c) / (K * cnt), NaN where no sample lies within 3 sigma. */
static csi_status normconv(csi_row_pool *pool, const double *sum, const double *cnt, uint32_t planes, uint32_t w,
                           uint32_t h, double sigma, double *out)
{
    const size_t np = (size_t)w * h;
    double *tmp = malloc(np * sizeof *tmp), *kc = malloc(np * sizeof *kc);
    if (!tmp || !kc) {
        free(tmp);
        free(kc);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    gauss_plane(pool, cnt, kc, tmp, w, h, sigma);
    for (uint32_t c = 0; c < planes; c++) {
        gauss_plane(pool, sum + (size_t)c * np, out + (size_t)c * np, tmp, w, h, sigma);
        for (size_t p = 0; p < np; p++)
            out[(size_t)c * np + p] = kc[p] > 1e-12 ? out[(size_t)c * np + p] / kc[p] : NAN;
    }
    free(tmp);
    free(kc);
    return CSI_OK;
}

/* Each pixel's bound per channel (planar): [lo, hi], its own samples' mean m +- K se (se^2 their
 * unbiased variance / n), not below 0 when no sample is (nonneg), within the least and greatest
 * sample of its 3 x 3 pixels; NaN where the pixel keeps its value (fewer than 2 samples, or every
 * cell sampled: its mean is its exact box integral, issue 9, as the blend leaves it). cnt, sum:
 * each pixel's sample count and channel sums (planar). */
static csi_status pixel_bounds(const csi_grid *g, const csi_sample_pos *pos, size_t n, uint32_t C, const float *values,
                               const double *cnt, const double *sum, bool nonneg, double *lo, double *hi)
{
    const uint32_t w = g->out_w, h = g->out_h, bw = g->w / w, bh = g->h / h;
    const size_t np = (size_t)w * h;
    double *dev = calloc(np * C, sizeof *dev);
    float *lo1 = malloc(np * C * sizeof *lo1), *hi1 = malloc(np * C * sizeof *hi1); /* the pixel's own samples' */
    if (!dev || !lo1 || !hi1) {
        free(dev);
        free(lo1);
        free(hi1);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    for (size_t i = 0; i < np * C; i++) {
        lo1[i] = INFINITY;
        hi1[i] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, w);
        for (uint32_t c = 0; c < C; c++) {
            const float v = values[i * C + c];
            const size_t q = (size_t)c * np + p;
            const double e = v - sum[q] / cnt[p];
            dev[q] += e * e;
            lo1[q] = v < lo1[q] ? v : lo1[q];
            hi1[q] = v > hi1[q] ? v : hi1[q];
        }
    }
    for (uint32_t c = 0; c < C; c++)
        for (size_t p = 0; p < np; p++) {
            const size_t q = (size_t)c * np + p;
            const double nn = cnt[p];
            if (nn < 2 || nn >= (double)bw * bh) {
                lo[q] = hi[q] = NAN;
                continue;
            }
            const long px = (long)(p % w), py = (long)(p / w);
            float l = INFINITY, u = -INFINITY;
            for (long y = py - 1; y <= py + 1; y++)
                for (long x = px - 1; x <= px + 1; x++)
                    if (x >= 0 && y >= 0 && x < (long)w && y < (long)h) {
                        const size_t o = (size_t)c * np + (size_t)y * w + (size_t)x;
                        l = lo1[o] < l ? lo1[o] : l;
                        u = hi1[o] > u ? hi1[o] : u;
                    }
            const double m = sum[q] / nn, se = sqrt(dev[q] / (nn - 1) / nn);
            double a = m - CSI_CV_SMOOTH_BOUND * se, b = m + CSI_CV_SMOOTH_BOUND * se;
            if (nonneg && a < 0)
                a = 0;
            /* nor beyond what the samples around it saw (no halo: issue 9) */
            lo[q] = a > l ? a : l;
            hi[q] = b < u ? b : u;
        }
    free(dev);
    free(lo1);
    free(hi1);
    return CSI_OK;
}

/* The width each region takes (pick[q], an index of CSI_CV_SMOOTH_SIGMAS; -1: none): the test of
 * csi/cv_smooth.h on the folds' counts and sums (fcnt, fsum: fold-major, planar) and the
 * incumbent's predictions cA, cB. Regions of side r, rw per row, shifted by (sx, sy). */
static csi_status pick_widths(csi_row_pool *pool, uint32_t w, uint32_t h, uint32_t fc, const double *fcnt,
                              const double *fsum, const float *cA, const float *cB, double floor, uint32_t r,
                              uint32_t sx, uint32_t sy, size_t rw, size_t nr, int8_t *pick)
{
    const size_t np = (size_t)w * h;
    double *gA = malloc(np * fc * sizeof *gA), *gB = malloc(np * fc * sizeof *gB);
    double *acc = malloc(nr * 8 * sizeof *acc); /* per region: the sum and the sum of squares of 4 gains */
    double *best = calloc(nr, sizeof *best);
    csi_status s = CSI_OK;
    if (!gA || !gB || !acc || !best)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    memset(pick, -1, nr);
    for (int k = 0; k < CSI_CV_SMOOTH_WIDTHS && s == CSI_OK; k++) {
        s = normconv(pool, fsum, fcnt, fc, w, h, sigmas[k], gA);
        if (s == CSI_OK)
            s = normconv(pool, fsum + np * fc, fcnt + np, fc, w, h, sigmas[k], gB);
        if (s != CSI_OK)
            break;
        memset(acc, 0, nr * 8 * sizeof *acc);
        for (size_t p = 0; p < np; p++) {
            const double na = fcnt[p], nb = fcnt[np + p];
            if (!na || !nb)
                continue;
            double d[4] = {0, 0, 0, 0};
            bool ok = true;
            for (uint32_t c = 0; c < fc; c++) {
                const double sa = fsum[c * np + p], sb = fsum[(fc + c) * np + p];
                const double ma = sa / na, mb = sb / nb, m = (sa + sb) / (na + nb);
                const double a = cA[(size_t)c * np + p], b = cB[(size_t)c * np + p];
                const double ga = gA[(size_t)c * np + p], gb = gB[(size_t)c * np + p];
                ok &= !isnan(ga) && !isnan(gb);
                const double da = (a - mb) * (a - mb) - (ga - mb) * (ga - mb);
                const double db = (b - ma) * (b - ma) - (gb - ma) * (gb - ma);
                const double rel = floor > 0 ? 1.0 / (m * m + floor) : 0;
                d[0] += da;
                d[1] += db;
                d[2] += da * rel;
                d[3] += db * rel;
            }
            if (!ok)
                continue;
            double *a = acc + region_of(p, w, r, sx, sy, rw) * 8;
            for (int j = 0; j < 4; j++) {
                a[j * 2] += d[j];
                a[j * 2 + 1] += d[j] * d[j];
            }
        }
        for (size_t q = 0; q < nr; q++) {
            const double *a = acc + q * 8;
            bool pass = true;
            for (int j = 0; j < 4; j++)
                pass &= a[j * 2] > CSI_CV_Z * sqrt(a[j * 2 + 1]);
            if (pass && a[0] + a[2] > best[q]) {
                best[q] = a[0] + a[2];
                pick[q] = (int8_t)k;
            }
        }
    }
    free(gA);
    free(gB);
    free(acc);
    free(best);
    return s;
}

csi_status csi_cv_smooth(csi_row_pool *pool, const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box,
                         const csi_sample_pos *pos, size_t n, const uint8_t *fold, uint32_t fold_channels,
                         const float *fold_values, const float *cA, const float *cB, uint32_t channels,
                         const float *values, float *image, size_t *smoothed)
{
    if (smoothed)
        *smoothed = 0;
    const uint32_t w = g->out_w, h = g->out_h, fc = fold_channels, C = channels, r = CSI_CV_REGION;
    const uint32_t bw = g->w / w, bh = g->h / h;
    const size_t np = (size_t)w * h;
    const uint32_t sx = ox % r, sy = oy % r;
    const size_t rw = (w + sx + r - 1) / r, rh = (h + sy + r - 1) / r, nr = rw * rh;
    /* per fold: counts and sums of the folds' values; all samples: counts and channel sums (planar) */
    double *fcnt = calloc(2 * np, sizeof *fcnt), *fsum = calloc(2 * np * fc, sizeof *fsum);
    double *cnt = calloc(np, sizeof *cnt), *sum = calloc(np * C, sizeof *sum);
    double *lo = malloc(np * C * sizeof *lo), *hi = malloc(np * C * sizeof *hi), *full = malloc(np * C * sizeof *full);
    int8_t *pick = malloc(nr);
    csi_status s = CSI_OK;
    if (!fcnt || !fsum || !cnt || !sum || !lo || !hi || !full || !pick)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    bool nonneg = true;
    double level = 0; /* the folds' values' mean magnitude: the relative error's floor is its scale */
    for (size_t i = 0; i < n && s == CSI_OK; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, w), f = fold[i] & 1;
        fcnt[f * np + p]++;
        for (uint32_t c = 0; c < fc; c++) {
            fsum[(f * fc + c) * np + p] += fold_values[i * fc + c];
            level += fabs(fold_values[i * fc + c]);
        }
        cnt[p]++;
        for (uint32_t c = 0; c < C; c++) {
            sum[(size_t)c * np + p] += values[i * C + c];
            nonneg &= values[i * C + c] >= 0;
        }
    }
    level /= (double)(n ? n : 1) * fc;
    if (s == CSI_OK)
        s = pixel_bounds(g, pos, n, C, values, cnt, sum, nonneg, lo, hi);
    if (s == CSI_OK)
        s = pick_widths(pool, w, h, fc, fcnt, fsum, cA, cB, CSI_CV_REL_FLOOR * level * level, r, sx, sy, rw, nr, pick);
    size_t changed = 0;
    for (int k = 0; k < CSI_CV_SMOOTH_WIDTHS && s == CSI_OK; k++) {
        bool used = false;
        for (size_t q = 0; q < nr; q++)
            used |= pick[q] == k;
        if (!used)
            continue;
        if ((s = normconv(pool, sum, cnt, C, w, h, sigmas[k], full)) != CSI_OK)
            break;
        for (size_t p = 0; p < np; p++) {
            if (pick[region_of(p, w, r, sx, sy, rw)] != k)
                continue;
            bool moved = false;
            for (uint32_t c = 0; c < C; c++) {
                const size_t i = (size_t)c * np + p;
                if (isnan(full[i]) || isnan(lo[i]))
                    continue;
                const double v = full[i] < lo[i] ? lo[i] : full[i] > hi[i] ? hi[i] : full[i];
                const float fv = (float)v;
                moved |= fv != image[i];
                image[i] = fv;
            }
            const uint32_t x = (uint32_t)(p % w), y = (uint32_t)(p / w);
            changed += moved && (!box || (x >= box[0] && y >= box[1] && x < box[2] && y < box[3]));
        }
    }
    if (smoothed)
        *smoothed = changed;
    free(fcnt);
    free(fsum);
    free(cnt);
    free(sum);
    free(lo);
    free(hi);
    free(full);
    free(pick);
    return s;
}
