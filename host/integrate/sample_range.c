/* The range of the samples that bounds Alg. 2's volume and image where the basis is still
 * (motion_range.c, motion_correct.c; issue 12, docs/bench/animation.md session 30).
 *
 * Each output pixel's cells over all t are bounded by [min, max] of the samples in the pixel
 * and its 8 neighbours. Where the picture is still that window's few samples are the pixel's
 * own values (exact samples of a still photograph: its own sample is the pixel's value at
 * every t), and the tight bound is what makes a still basis good at one sample per pixel.
 * Where something moves through the pixel, a sample is the pixel's value at one time only: a
 * window holding one or two samples of a passing ball pins the pixel to the ball's value at
 * every t (the blocks of docs/bench/animation.md's figure, session 30).
 *
 * Which of the two a region is, the samples say: in a still region the samples of one pixel
 * at different times agree (up to their noise), so their spread within the pixel is a small
 * part of the window's. The ratio
 *
 *     rho = (pooled variance of the samples about their own pixel's mean)
 *         / (pooled variance of the samples about their 3 x 3 window's mean),
 *
 * both pooled over the (2 POOL + 1)^2 pixels around (the pairs of samples sharing a pixel are
 * few at these rates), is near 0 where a pixel holds still and near 1 where its values over t
 * span what its window saw. Where rho > 1/2 (most of the window's spread is the pixels' own
 * change over t) the window grows until it holds MIN_SAMPLES samples, so that the bound is the
 * range of what passes rather than of one moment; elsewhere it stays 3 x 3. A window with no
 * sample, or one that would have to grow beyond MAX_RADIUS pixels, takes the range of all the
 * samples. All in double, pixels in order: the same bits for the same samples.
 *
 * On a grid of several cells a pixel (a still camera's volume from 4 spp) the 3 x 3 pixels span
 * 6 x 6 to 12 x 12 cells, each seen about once over the shutter: a still light's samples in one
 * pixel then bound cells a pixel or more away from it, and the fit keeps the light there at the
 * frames no sample saw. Where the samples say little moves (motion.c: exact ones by the rule of
 * the still layer's tenth, noisy ones by a stricter share of motion), each cell takes the range
 * of the samples in the 3 x 3 cells around it instead (csi_recon_cell_ranges), about as many
 * samples as 3 x 3 pixels held on the pixel grid. */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* How far around a pixel the two variances are pooled (pixels): 17 x 17 pixels hold a few tens
 * of pairs of samples sharing a pixel at half a sample per pixel. */
#define POOL 8
/* The samples a grown window holds at least (4 to 16 measured, docs/bench/animation.md session
 * 30: 6 and more about alike, 4 kept part of the loss). */
#define MIN_SAMPLES 8
/* The widest grown window's half side (pixels); beyond, the range of all the samples. */
#define MAX_RADIUS 8

/* Sliding sums of a[0 .. len) over [i - r, i + r] (clipped), stride `step`, into out. */
static void box1(const double *a, double *out, size_t len, size_t step, size_t r)
{
    double s = 0;
    for (size_t i = 0; i < len && i < r; i++)
        s += a[i * step];
    for (size_t i = 0; i < len; i++) {
        if (i + r < len)
            s += a[(i + r) * step];
        out[i * step] = s;
        if (i >= r)
            s -= a[(i - r) * step];
    }
}

/* a (w x h) replaced by its (2r + 1)^2 box sums; tmp holds w x h. */
static void box2(double *a, double *tmp, size_t w, size_t h, size_t r)
{
    for (size_t y = 0; y < h; y++)
        box1(a + y * w, tmp + y * w, w, 1, r);
    for (size_t x = 0; x < w; x++)
        box1(tmp + x, a + x, h, w, r);
}

/* The samples in pixels [x0, x1] x [y0, y1] (clipped to the frame), from the counts' prefix sums
 * cum ((w + 1) x (h + 1)). */
static uint64_t count_in(const uint64_t *cum, size_t w, long x0, long y0, long x1, long y1, size_t h)
{
    const size_t a = (size_t)(x0 < 0 ? 0 : x0), b = (size_t)(y0 < 0 ? 0 : y0);
    const size_t c = (size_t)(x1 >= (long)w ? (long)w - 1 : x1) + 1, d = (size_t)(y1 >= (long)h ? (long)h - 1 : y1) + 1;
    const size_t W1 = w + 1;
    return cum[d * W1 + c] - cum[b * W1 + c] - cum[d * W1 + a] + cum[b * W1 + a];
}

void csi_recon_pixel_values(size_t ow, size_t oh, const size_t *pix, const float *values, uint32_t channels,
                            uint32_t c, size_t n, csi_px_values *px, float all[2])
{
    const size_t np = ow * oh;
    for (size_t p = 0; p < np; p++)
        px[p] = (csi_px_values){.lo = INFINITY, .hi = -INFINITY};
    all[0] = INFINITY;
    all[1] = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        const size_t p = pix[i];
        const float v = values[i * channels + c];
        all[0] = fminf(all[0], v);
        all[1] = fmaxf(all[1], v);
        if (p >= np)
            continue;
        px[p].n++;
        px[p].mean += v;
        px[p].lo = fminf(px[p].lo, v);
        px[p].hi = fmaxf(px[p].hi, v);
    }
    for (size_t p = 0; p < np; p++)
        if (px[p].n)
            px[p].mean /= px[p].n;
    for (size_t i = 0; i < n; i++) { /* a second pass: no cancellation */
        const size_t p = pix[i];
        if (p >= np)
            continue;
        const double r = (double)values[i * channels + c] - px[p].mean;
        px[p].ss += r * r;
    }
}

csi_status csi_recon_value_ranges(size_t ow, size_t oh, const csi_px_values *px, const float all[2], float *lohi)
{
    const size_t np = ow * oh;
    double *sw = malloc(np * sizeof *sw), *dw = malloc(np * sizeof *dw), *sb = malloc(np * sizeof *sb);
    double *db = malloc(np * sizeof *db), *tmp = malloc(np * sizeof *tmp);
    uint64_t *cum = calloc((ow + 1) * (oh + 1), sizeof *cum);
    csi_status s = CSI_OK;
    if (!sw || !dw || !sb || !db || !tmp || !cum) {
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the sample range of %zu pixels", np);
        goto done;
    }
    /* no sample at all: nothing to bound by */
    const float all_lo = all[0] <= all[1] ? all[0] : -INFINITY, all_hi = all[0] <= all[1] ? all[1] : INFINITY;
    /* the 3 x 3 window's spread about its own mean: within its pixels plus between their means */
    for (size_t y = 0; y < oh; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t y0 = y ? y - 1 : 0, y1 = y + 1 < oh ? y + 1 : y;
            const size_t x0 = x ? x - 1 : 0, x1 = x + 1 < ow ? x + 1 : x;
            double num = 0, sum = 0, ss = 0;
            for (size_t yy = y0; yy <= y1; yy++)
                for (size_t xx = x0; xx <= x1; xx++) {
                    const csi_px_values *q = &px[yy * ow + xx];
                    num += q->n;
                    sum += q->n * q->mean;
                    ss += q->ss;
                }
            const double m = num > 0 ? sum / num : 0;
            for (size_t yy = y0; yy <= y1; yy++)
                for (size_t xx = x0; xx <= x1; xx++) {
                    const csi_px_values *q = &px[yy * ow + xx];
                    ss += q->n * (q->mean - m) * (q->mean - m);
                }
            const size_t p = y * ow + x;
            sb[p] = ss;
            db[p] = num > 1 ? num - 1 : 0;
            sw[p] = px[p].ss;
            dw[p] = px[p].n > 1 ? px[p].n - 1.0 : 0;
        }
    box2(sw, tmp, ow, oh, POOL);
    box2(dw, tmp, ow, oh, POOL);
    box2(sb, tmp, ow, oh, POOL);
    box2(db, tmp, ow, oh, POOL);
    for (size_t y = 0; y < oh; y++)
        for (size_t x = 0; x < ow; x++)
            cum[(y + 1) * (ow + 1) + x + 1] = cum[y * (ow + 1) + x + 1] + cum[(y + 1) * (ow + 1) + x] -
                                              cum[y * (ow + 1) + x] + px[y * ow + x].n;
    for (size_t y = 0; y < oh; y++)
        for (size_t x = 0; x < ow; x++) {
            const size_t p = y * ow + x;
            const double within = sw[p] / fmax(dw[p], 1), window = sb[p] / fmax(db[p], 1);
            const bool moves = window > 0 && within > 0.5 * window;
            long r = 1;
            while (moves && r <= MAX_RADIUS &&
                   count_in(cum, ow, (long)x - r, (long)y - r, (long)x + r, (long)y + r, oh) < MIN_SAMPLES)
                r++;
            float l = INFINITY, h = -INFINITY;
            if (r <= MAX_RADIUS) {
                const size_t y0 = y > (size_t)r ? y - (size_t)r : 0, y1 = y + (size_t)r < oh ? y + (size_t)r : oh - 1;
                const size_t x0 = x > (size_t)r ? x - (size_t)r : 0, x1 = x + (size_t)r < ow ? x + (size_t)r : ow - 1;
                for (size_t yy = y0; yy <= y1; yy++)
                    for (size_t xx = x0; xx <= x1; xx++) {
                        l = fminf(l, px[yy * ow + xx].lo);
                        h = fmaxf(h, px[yy * ow + xx].hi);
                    }
            }
            lohi[2 * p] = l <= h ? l : all_lo;
            lohi[2 * p + 1] = l <= h ? h : all_hi;
        }
done:
    free(sw), free(dw), free(sb), free(db), free(tmp), free(cum);
    return s;
}

csi_status csi_recon_sample_ranges(size_t ow, size_t oh, const size_t *pix, const float *values, uint32_t channels,
                                   uint32_t c, size_t n, float *lohi)
{
    const size_t np = ow * oh;
    csi_px_values *px = malloc((np ? np : 1) * sizeof *px);
    if (!px)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the sample range of %zu pixels", np);
    float all[2];
    csi_recon_pixel_values(ow, oh, pix, values, channels, c, n, px, all);
    const csi_status s = csi_recon_value_ranges(ow, oh, px, all, lohi);
    free(px);
    return s;
}

/* min / max of a (len values, stride step) over [i - 1, i + 1], clipped, into out */
static void minmax3(const float *lo, const float *hi, float *olo, float *ohi, size_t len, size_t step)
{
    for (size_t i = 0; i < len; i++) {
        float l = lo[i * step], h = hi[i * step];
        if (i > 0)
            l = fminf(l, lo[(i - 1) * step]), h = fmaxf(h, hi[(i - 1) * step]);
        if (i + 1 < len)
            l = fminf(l, lo[(i + 1) * step]), h = fmaxf(h, hi[(i + 1) * step]);
        olo[i * step] = l;
        ohi[i * step] = h;
    }
}

csi_status csi_recon_cell_ranges(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                 uint32_t channels, uint32_t c, size_t n, const float *pixel_range, float *lohi)
{
    const size_t w = g->w, h = g->h, wh = w * h, bw = g->w / g->out_w, bh = g->h / g->out_h;
    float *lo = malloc(wh * sizeof *lo), *hi = malloc(wh * sizeof *hi);
    float *tlo = malloc(wh * sizeof *tlo), *thi = malloc(wh * sizeof *thi);
    csi_status s = CSI_OK;
    if (!lo || !hi || !tlo || !thi) {
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the sample range of %zu cells", wh);
        goto done;
    }
    for (size_t i = 0; i < wh; i++) {
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
    }
    for (size_t i = 0; i < n; i++) {
        const size_t q = (size_t)pos[i].y * w + pos[i].x;
        const float v = values[i * channels + c];
        lo[q] = fminf(lo[q], v);
        hi[q] = fmaxf(hi[q], v);
    }
    for (size_t y = 0; y < h; y++)
        minmax3(lo + y * w, hi + y * w, tlo + y * w, thi + y * w, w, 1);
    for (size_t x = 0; x < w; x++)
        minmax3(tlo + x, thi + x, lo + x, hi + x, h, w);
    for (size_t y = 0; y < h; y++)
        for (size_t x = 0; x < w; x++) {
            const size_t q = y * w + x, p = (y / bh) * g->out_w + x / bw;
            const bool any = lo[q] <= hi[q];
            lohi[2 * q] = any ? lo[q] : pixel_range[2 * p];
            lohi[2 * q + 1] = any ? hi[q] : pixel_range[2 * p + 1];
        }
done:
    free(lo), free(hi), free(tlo), free(thi);
    return s;
}
