/* The pixels that decide a still image settled on their own samples' mean (csi/settle.h says
 * why and the rule). All in double, in sample order and pixel order: the same inputs give the
 * same bits. */
#include "csi/settle.h"

#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "internal.h"

void csi_pixel_disagreement_free(csi_pixel_disagreement *d)
{
    free(d->cnt);
    free(d->sum);
    free(d->d2);
    d->cnt = NULL;
    d->sum = d->d2 = NULL;
}

void csi_pixel_sums_add(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos, const float *values,
                        size_t n, const uint32_t box[4], uint32_t *cnt, double *sum)
{
    const uint32_t C = channels, bw = g->w / g->out_w, bh = g->h / g->out_h;
    for (size_t i = 0; i < n; i++) {
        const uint32_t px = pos[i].x / bw, py = pos[i].y / bh;
        if (box && !(px >= box[0] && py >= box[1] && px < box[2] && py < box[3]))
            continue;
        const size_t p = (size_t)py * g->out_w + px;
        cnt[p]++;
        for (uint32_t c = 0; c < C; c++)
            sum[p * C + c] += values[i * C + c];
    }
}

/* Each pixel's disagreement d2[p] between image and the mean of its samples (cnt, sum), and
 * their total. */
static double disagreement_of(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                              const float *image, double *d2)
{
    const uint32_t C = channels;
    const size_t np = (size_t)g->out_w * g->out_h;
    /* pixels without a sample have no mean to disagree with */
    double t = 0;
    for (size_t p = 0; p < np; p++) {
        d2[p] = 0;
        if (!cnt[p])
            continue;
        double e2 = 0;
        for (uint32_t c = 0; c < C; c++) {
            const double x = image[(size_t)c * np + p], m = sum[p * C + c] / cnt[p], e = x - m;
            /* an image that is the mean in float32 (the mean estimator, a pixel the blend gave its
             * mean) differs from the mean in double by its rounding: no disagreement */
            if (fabs(e) > CSI_SETTLE_ROUNDING * (fabs(x) + fabs(m)))
                e2 += e * e;
        }
        d2[p] = e2;
        t += e2;
    }
    return t;
}

csi_status csi_pixel_disagreement_make(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                       const float *values, size_t n, const float *image,
                                       csi_pixel_disagreement *out)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    out->cnt = calloc(np ? np : 1, sizeof *out->cnt);
    out->sum = calloc(np ? np * channels : 1, sizeof *out->sum);
    out->d2 = calloc(np ? np : 1, sizeof *out->d2);
    out->total = 0;
    if (!out->cnt || !out->sum || !out->d2) {
        csi_pixel_disagreement_free(out);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    csi_pixel_sums_add(g, channels, pos, values, n, NULL, out->cnt, out->sum);
    out->total = disagreement_of(g, channels, out->cnt, out->sum, image, out->d2);
    return CSI_OK;
}

/* The image's level: the mean over the pixels with a sample of their means' channel sums. */
static double level_of(size_t np, uint32_t C, const uint32_t *cnt, const double *sum)
{
    double level = 0;
    size_t sampled = 0;
    for (size_t p = 0; p < np; p++) {
        if (!cnt[p])
            continue;
        for (uint32_t c = 0; c < C; c++)
            level += sum[p * C + c] / cnt[p];
        sampled++;
    }
    return sampled ? level / (double)sampled : 0;
}

/* Whether the rule may move pixel p (it has a sample): neither a firefly nor within ordinary
 * shading (csi/settle.h). */
static bool movable(size_t np, uint32_t C, const uint32_t *cnt, const double *sum, const float *image,
                    double level, size_t p)
{
    double xm = 0, mm = 0;
    for (uint32_t c = 0; c < C; c++) {
        xm += image[(size_t)c * np + p];
        mm += sum[p * C + c] / cnt[p];
    }
    if (fmin(xm, mm) < CSI_SETTLE_BRIGHT * fmax(xm, mm))
        return false; /* a firefly (or a pixel one of the two sees dark) */
    return fmax(xm, mm) >= CSI_SETTLE_HDR * level; /* beyond ordinary shading: an HDR light */
}

/* csi_settle_shares given the image's level (level_of). */
static csi_status shares_at_level(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                                  const float *image, const double *d2, double total, double level, double *share)
{
    const uint32_t C = channels;
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    for (size_t p = 0; p < np; p++)
        share[p] = cnt[p] && total > 0 ? d2[p] / total : 0;
    if (!(total > 0))
        return CSI_OK;
    /* the pixels that take their mean whole, marked, then their neighbours raised to that share */
    unsigned char *whole = calloc(np ? np : 1, 1);
    if (!whole)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    for (size_t p = 0; p < np; p++)
        whole[p] = share[p] >= CSI_SETTLE_FULL && movable(np, C, cnt, sum, image, level, p);
    size_t nb[9];
    for (size_t p = 0; p < np; p++) {
        if (!cnt[p] || !(d2[p] > 0) || share[p] >= CSI_SETTLE_FULL)
            continue;
        const int k = csi_recon_window3_at(p % ow, p / ow, ow, oh, nb);
        for (int j = 0; j < k; j++)
            if (whole[nb[j]]) {
                share[p] = CSI_SETTLE_FULL;
                break;
            }
    }
    free(whole);
    return CSI_OK;
}

csi_status csi_settle_shares(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                             const float *image, const double *d2, double total, double *share)
{
    const double level = level_of((size_t)g->out_w * g->out_h, channels, cnt, sum);
    return shares_at_level(g, channels, cnt, sum, image, d2, total, level, share);
}

/* The rule (csi/settle.h) on image, given its pixels' samples (cnt, sum), shares and the image's
 * level; the pixels moved inside box. */
static size_t settle_by(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                        const double *share, double level, float *image, const uint32_t box[4])
{
    const uint32_t C = channels;
    const size_t np = (size_t)g->out_w * g->out_h;
    size_t k = 0;
    for (size_t p = 0; p < np; p++) {
        if (share[p] <= CSI_SETTLE_FROM || !movable(np, C, cnt, sum, image, level, p))
            continue;
        const double w = fmin((share[p] - CSI_SETTLE_FROM) / (CSI_SETTLE_FULL - CSI_SETTLE_FROM), 1.0);
        for (uint32_t c = 0; c < C; c++) {
            float *x = image + (size_t)c * np + p;
            *x = (float)(*x + w * (sum[p * C + c] / cnt[p] - *x));
        }
        const uint32_t px = (uint32_t)(p % g->out_w), py = (uint32_t)(p / g->out_w);
        if (!box || (px >= box[0] && py >= box[1] && px < box[2] && py < box[3]))
            k++;
    }
    return k;
}

csi_status csi_settle(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos, const float *values, size_t n,
                      float *image, const uint32_t box[4], size_t *settled)
{
    if (settled)
        *settled = 0;
    const size_t np = (size_t)g->out_w * g->out_h;
    uint32_t *cnt = calloc(np ? np : 1, sizeof *cnt);
    double *sum = calloc(np ? np * channels : 1, sizeof *sum);
    csi_status s = CSI_OK;
    if (!cnt || !sum)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    else if (g->t == 1)
        csi_pixel_sums_add(g, channels, pos, values, n, NULL, cnt, sum);
    if (s == CSI_OK)
        s = csi_settle_sums(g, channels, cnt, sum, image, box, settled);
    free(cnt);
    free(sum);
    return s;
}

csi_status csi_settle_sums(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                           float *image, const uint32_t box[4], size_t *settled)
{
    if (settled)
        *settled = 0;
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "settling pixels: the samples are a volume (%u frames), not an image", g->t);
    const size_t np = (size_t)g->out_w * g->out_h;
    const double level = level_of(np, channels, cnt, sum);
    double *d2 = malloc((np ? np : 1) * sizeof *d2), *share = malloc((np ? np : 1) * sizeof *share);
    csi_status s = d2 && share ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    if (s == CSI_OK) {
        const double total = disagreement_of(g, channels, cnt, sum, image, d2);
        s = shares_at_level(g, channels, cnt, sum, image, d2, total, level, share);
    }
    if (s == CSI_OK) {
        const size_t k = settle_by(g, channels, cnt, sum, share, level, image, box);
        if (settled)
            *settled = k;
    }
    free(d2);
    free(share);
    return s;
}
