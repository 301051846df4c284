/* Where to sample next (csi_refine_positions in csi/csi.h): every cell not yet sampled of the
 * pixels on which the image and the mean of the pixel's own samples disagree so much that the
 * pixel alone holds a given share of their disagreement over the whole image, or whose mean's own
 * sampling variance holds that share of its sum (below).
 *
 * Why those pixels. On a renderer's HDR samples (a sun, a lamp, an emitter's edge) at a few
 * samples per pixel, one to three pixels carry most of an image's error, whichever estimator
 * is used: a sub-pixel light that one of the pixel's four samples hit is a coin flip on how much
 * of the pixel it covers, and neither the fit nor the mean can tell from those samples
 * (docs/bench/mitsuba.md, sessions 15 and 20). Where the two estimates disagree by a large share
 * of the image's total disagreement is where one of them is that wrong; sampling the pixel's
 * every cell settles it for both: the mean becomes the mean of the pixel's every cell centre (its
 * box mean up to the paths' noise, but for a light smaller than a few cells, which the lattice of
 * centres aliases) and the blend takes it (csi_aa_correct: a fully sampled pixel's mean has no
 * sampling error). A few pixels' cells are a small part of the samples; the image's error drops
 * by far more than that part would buy spread evenly. csi_refine_apply then gives the refined pixels that
 * mean without a second reconstruction (csi-mitsuba's second pass, csi-reconstruct --refine-with).
 *
 * The disagreement is blind where the image already is the pixel's mean: where the fit gives a
 * light's pixel its samples' mean, or the blend takes it, the two agree however wrong both are (a
 * glint one of four samples hit, a lamp's rim). There the mean's own error speaks: its sampling
 * variance from the spread of the pixel's samples, (1 - n / N) s^2 / n over the channels (s^2 the
 * unbiased variance of n samples, N cells: the finite-population factor, 0 for a full pixel; the
 * textbook estimate under simple random sampling, e.g. Cochran, Sampling Techniques, 1977,
 * ch. 2); a pixel of one sample has no spread of its own and takes its 3 x 3 pixels' (a lone bright
 * sample at 1 spp is seen from beside it). A pixel whose estimate holds the same share of that sum
 * over the image is picked too.
 *
 * Everything in double, in sample order: the same inputs give the same cells. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/settle.h"
#include "csi/step_coverage.h"
#include "csi/status.h"

/* The share's default (csi-reconstruct --refine-share, csi-mitsuba --refine-share): a pixel
 * that holds 0.5% of the disagreement or of the means' sampling variance. At most 1 / share
 * pixels can hold it of each, and the neighbours of at most 50 pixels holding 2% (csi/settle.h),
 * so the request is bounded by 200 + 200 + 400 pixels' cells whatever the image's size. */
#define CSI_REFINE_SHARE_DEFAULT 0.005

double csi_refine_share_default(void)
{
    return CSI_REFINE_SHARE_DEFAULT;
}

/* An image's grid (not a volume, whole pixels) and the image of it both functions take. */
static csi_status check_image(const csi_grid *g, uint32_t channels, const csi_image *image)
{
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "refinement: the samples are a volume (%u frames); it picks pixels of an image",
                        g->t);
    if (!g->out_w || !g->out_h || g->w % g->out_w || g->h % g->out_h)
        return csi_fail(CSI_ERR_ARG, "refinement: a grid of %ux%u cells for a %ux%u image", g->w, g->h, g->out_w,
                        g->out_h);
    if (image->w != g->out_w || image->h != g->out_h || image->channels != channels || !image->data)
        return csi_fail(CSI_ERR_ARG, "refinement: a %ux%u image of %u channels for %ux%u samples of %u", image->w,
                        image->h, image->channels, g->out_w, g->out_h, channels);
    return CSI_OK;
}

/* Each pixel's estimate of its mean's sampling variance (1 - n / N) s^2 / n summed over the
 * channels, n of its N cells sampled (cnt; sum: the channel sums), in risk[p]; the sum over the
 * image returned (CSI_ERR_NOMEM in *st, and 0, when the window sums do not fit). s^2 is the
 * unbiased variance of the pixel's own samples from n >= 2; a pixel of one sample has none, and
 * takes that of its 3 x 3 pixels' samples (from two of them; the window clipped at the border),
 * so that at 1 spp a lone bright sample's neighbours are seen too. Deviations from the means, in
 * a pass over the samples after the sums, so that equal values give exactly 0 (a flat region
 * holds no share of it). */
static double mean_sampling_variance(const csi_grid *g, uint32_t C, const csi_sample_pos *pos, const float *values,
                                     size_t count, const uint32_t *cnt, const double *sum, double *risk,
                                     csi_status *st)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h, W = g->out_w, H = g->out_h;
    const size_t np = (size_t)W * H, cells = (size_t)bw * bh;
    memset(risk, 0, np * sizeof *risk);
    size_t single = 0;
    for (size_t p = 0; p < np; p++)
        single += cnt[p] == 1;
    /* the 3 x 3 windows' counts and channel sums, for the pixels of one sample */
    size_t *wn = single ? calloc(np, sizeof *wn) : NULL;
    double *ws = single ? calloc(np * C, sizeof *ws) : NULL;
    if (single && (!wn || !ws)) {
        free(wn);
        free(ws);
        *st = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels' windows", np);
        return 0;
    }
    for (size_t p = 0; p < np && single; p++) {
        if (cnt[p] != 1)
            continue;
        const uint32_t x = (uint32_t)(p % W), y = (uint32_t)(p / W);
        for (uint32_t qy = y ? y - 1 : 0; qy <= y + 1 && qy < H; qy++)
            for (uint32_t qx = x ? x - 1 : 0; qx <= x + 1 && qx < W; qx++) {
                const size_t q = (size_t)qy * W + qx;
                wn[p] += cnt[q];
                for (uint32_t c = 0; c < C; c++)
                    ws[p * C + c] += sum[q * C + c];
            }
    }
    for (size_t i = 0; i < count; i++) {
        const uint32_t x = pos[i].x / bw, y = pos[i].y / bh;
        const size_t p = (size_t)y * W + x;
        for (uint32_t c = 0; c < C; c++) {
            const double e = values[i * C + c] - sum[p * C + c] / cnt[p];
            risk[p] += e * e;
        }
        if (!single)
            continue;
        /* the sample's share of each window of a one-sample pixel that holds it */
        for (uint32_t qy = y ? y - 1 : 0; qy <= y + 1 && qy < H; qy++)
            for (uint32_t qx = x ? x - 1 : 0; qx <= x + 1 && qx < W; qx++) {
                const size_t q = (size_t)qy * W + qx;
                if (cnt[q] != 1 || wn[q] < 2)
                    continue;
                for (uint32_t c = 0; c < C; c++) {
                    const double e = values[i * C + c] - ws[q * C + c] / (double)wn[q];
                    risk[q] += e * e;
                }
            }
    }
    double total = 0;
    for (size_t p = 0; p < np; p++) {
        const double n = cnt[p], f = 1 - n / (double)cells;
        risk[p] = cnt[p] >= 2                ? f * risk[p] / (n - 1) / n
                  : cnt[p] == 1 && wn[p] >= 2 ? f * risk[p] / (double)(wn[p] - 1)
                                              : 0;
        total += risk[p];
    }
    free(wn);
    free(ws);
    return total;
}

csi_status csi_refine_positions(const csi_samples *s, const csi_image *image, double share,
                                csi_sample_pos **out, size_t *count, size_t *pixels)
{
    if (!s || !image || !out || !count)
        return csi_fail(CSI_ERR_ARG, "csi_refine_positions: %s is NULL",
                        !s ? "the samples" : !image ? "the image" : !out ? "out" : "count");
    *out = NULL;
    *count = 0;
    if (pixels)
        *pixels = 0;
    const csi_grid *g = &s->grid;
    CSI_TRY(check_image(g, s->channels, image));
    if (!(share > 0 && share <= 1))
        return csi_fail(CSI_ERR_ARG, "refinement: a share of %g (it is a fraction, 0 < share <= 1)", share);
    if (s->count && (!s->pos || !s->values))
        return csi_fail(CSI_ERR_ARG, "refinement: %zu samples without their positions or values", s->count);
    const uint32_t C = s->channels, bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h, cells = (size_t)bw * bh;
    for (size_t i = 0; i < s->count; i++) {
        const csi_sample_pos p = s->pos[i];
        if (p.x >= g->w || p.y >= g->h || p.t)
            return csi_fail(CSI_ERR_ARG, "refinement: sample %zu at (%u, %u, %u) is outside the %ux%u grid", i, p.x,
                            p.y, p.t, g->w, g->h);
        for (uint32_t c = 0; c < C; c++)
            if (!isfinite(s->values[i * C + c]))
                return csi_fail(CSI_ERR_ARG, "refinement: sample %zu's value is not finite", i);
    }
    for (size_t i = 0; i < np * C; i++)
        if (!isfinite(image->data[i]))
            return csi_fail(CSI_ERR_ARG, "refinement: the image's value %zu is not finite", i);

    /* Each pixel's disagreement, summed over the channels (csi/settle.h: the measure the blend's
     * last step settles by); pixels without a sample have no mean to disagree with, and pixels
     * already sampled in every cell nothing left to sample. */
    csi_pixel_disagreement dis;
    CSI_TRY(csi_pixel_disagreement_make(g, C, s->pos, s->values, s->count, image->data, &dis));
    const uint32_t *cnt = dis.cnt;
    const double *d2 = dis.d2, total = dis.total;
    /* and the neighbours of the pixels that settle wholly, which settling counts as holding 2%
     * (csi_settle_shares) */
    double *sh = malloc((np ? np : 1) * sizeof *sh), *risk = malloc((np ? np : 1) * sizeof *risk), risk_total = 0;
    csi_status st = sh && risk ? csi_settle_shares(g, C, cnt, dis.sum, image->data, d2, total, sh)
                               : csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    if (st == CSI_OK)
        risk_total = mean_sampling_variance(g, C, s->pos, s->values, s->count, cnt, dis.sum, risk, &st);
    size_t flagged = 0, n = 0;
#define PICKED(p)                                                                                  \
    (cnt[p] && cnt[p] < cells &&                                                                   \
     ((total > 0 && (d2[p] >= share * total || sh[p] >= share)) ||                                 \
      (risk_total > 0 && risk[p] >= share * risk_total)))
    for (size_t p = 0; p < np && st == CSI_OK; p++)
        if (PICKED(p)) {
            flagged++;
            n += cells - cnt[p];
        }
    /* the flagged pixels' sampled cells, one bit each (a pixel's block in row order) */
    size_t *slot = NULL;
    unsigned char *taken = NULL;
    csi_sample_pos *cellv = NULL;
    if (st == CSI_OK && flagged) {
        slot = malloc(np * sizeof *slot);
        taken = calloc(flagged * cells, 1);
        cellv = malloc(flagged * cells * sizeof *cellv);
        if (!slot || !taken || !cellv)
            st = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu cells to request", n);
    }
    if (st == CSI_OK && flagged) {
        size_t k = 0;
        for (size_t p = 0; p < np; p++)
            slot[p] = PICKED(p) ? k++ : SIZE_MAX;
        for (size_t i = 0; i < s->count; i++) {
            const csi_sample_pos q = s->pos[i];
            const size_t p = (size_t)(q.y / bh) * g->out_w + q.x / bw;
            if (slot[p] != SIZE_MAX)
                taken[slot[p] * cells + (size_t)(q.y % bh) * bw + q.x % bw] = 1;
        }
        size_t j = 0;
        for (size_t p = 0; p < np; p++) {
            if (slot[p] == SIZE_MAX)
                continue;
            const uint32_t x0 = (uint32_t)(p % g->out_w) * bw, y0 = (uint32_t)(p / g->out_w) * bh;
            for (uint32_t y = 0; y < bh; y++)
                for (uint32_t x = 0; x < bw; x++)
                    if (!taken[slot[p] * cells + (size_t)y * bw + x])
                        cellv[j++] = (csi_sample_pos){x0 + x, y0 + y, 0};
        }
        n = j; /* cells - cnt each, unless the samples repeat a cell (csi_samples forbids it) */
    }
#undef PICKED
    csi_pixel_disagreement_free(&dis);
    free(sh);
    free(risk);
    free(slot);
    free(taken);
    if (st != CSI_OK) {
        free(cellv);
        return st;
    }
    *out = cellv;
    *count = n;
    if (pixels)
        *pixels = flagged;
    return CSI_OK;
}

/* first and more (NULL: none) hold samples of one image's grid, inside it and finite, and image is
 * that image: what csi_refine_apply and csi_refine_settle both take. */
static csi_status check_pair(const csi_samples *first, const csi_samples *more, const csi_image *image)
{
    const csi_grid *g = &first->grid;
    if (more && (memcmp(g, &more->grid, sizeof *g) || first->channels != more->channels))
        return csi_fail(CSI_ERR_ARG, "refinement: the refined samples' grid (%ux%ux%u for %ux%u, %u channels) is "
                        "not the first samples' (%ux%ux%u for %ux%u, %u channels)", more->grid.w, more->grid.h,
                        more->grid.t, more->grid.out_w, more->grid.out_h, more->channels, g->w, g->h, g->t,
                        g->out_w, g->out_h, first->channels);
    CSI_TRY(check_image(g, first->channels, image));
    const uint32_t C = first->channels;
    const csi_samples *set[2] = {first, more};
    for (int k = 0; k < 2 && set[k]; k++) {
        if (set[k]->count && (!set[k]->pos || !set[k]->values))
            return csi_fail(CSI_ERR_ARG, "refinement: %zu %s samples without their positions or values", set[k]->count,
                            k ? "refined" : "first");
        for (size_t i = 0; i < set[k]->count; i++) {
            const csi_sample_pos p = set[k]->pos[i];
            if (p.x >= g->w || p.y >= g->h || p.t)
                return csi_fail(CSI_ERR_ARG, "refinement: %s sample %zu at (%u, %u, %u) is outside the %ux%u grid",
                                k ? "refined" : "first", i, p.x, p.y, p.t, g->w, g->h);
            for (uint32_t c = 0; c < C; c++)
                if (!isfinite(set[k]->values[i * C + c]))
                    return csi_fail(CSI_ERR_ARG, "refinement: %s sample %zu's value is not finite",
                                    k ? "refined" : "first", i);
        }
    }
    return CSI_OK;
}

csi_status csi_refine_apply(const csi_samples *first, const csi_samples *more, csi_image *image, size_t *pixels)
{
    if (!first || !more || !image)
        return csi_fail(CSI_ERR_ARG, "csi_refine_apply: %s is NULL", !first ? "first" : !more ? "more" : "image");
    if (pixels)
        *pixels = 0;
    CSI_TRY(check_pair(first, more, image));
    const csi_grid *g = &first->grid;
    const uint32_t C = first->channels, bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h;
    const csi_samples *set[2] = {first, more};
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *sum = calloc(np * C, sizeof *sum);
    unsigned char *hit = calloc(np, 1);
    if (!cnt || !sum || !hit) {
        free(cnt);
        free(sum);
        free(hit);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    for (size_t i = 0; i < more->count; i++)
        hit[(size_t)(more->pos[i].y / bh) * g->out_w + more->pos[i].x / bw] = 1;
    /* every sample of a refined pixel, the first ones in their order, then the refined ones */
    for (int k = 0; k < 2; k++)
        for (size_t i = 0; i < set[k]->count; i++) {
            const size_t p = (size_t)(set[k]->pos[i].y / bh) * g->out_w + set[k]->pos[i].x / bw;
            if (!hit[p])
                continue;
            cnt[p]++;
            for (uint32_t c = 0; c < C; c++)
                sum[p * C + c] += set[k]->values[i * C + c];
        }
    size_t n = 0;
    for (size_t p = 0; p < np; p++) {
        if (!hit[p])
            continue;
        n++;
        for (uint32_t c = 0; c < C; c++)
            image->data[(size_t)c * np + p] = (float)(sum[p * C + c] / cnt[p]);
    }
    free(cnt);
    free(sum);
    free(hit);
    if (pixels)
        *pixels = n;
    return CSI_OK;
}

csi_status csi_refine_settle(const csi_samples *first, const csi_samples *more, csi_image *image, size_t *pixels)
{
    if (!first || !image)
        return csi_fail(CSI_ERR_ARG, "csi_refine_settle: %s is NULL", !first ? "first" : "image");
    if (pixels)
        *pixels = 0;
    CSI_TRY(check_pair(first, more, image));
    if (!first->variance)
        return CSI_OK; /* one path per sample: a pixel's few samples are too noisy a mean (csi/csi.h) */
    const csi_grid *g = &first->grid;
    const size_t np = (size_t)g->out_w * g->out_h;
    uint32_t *cnt = calloc(np, sizeof *cnt);
    double *sum = calloc(np * first->channels, sizeof *sum);
    csi_status s = cnt && sum ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    if (s == CSI_OK) { /* every sample of every pixel, the first ones in their order, then the refined ones */
        csi_pixel_sums_add(g, first->channels, first->pos, first->values, first->count, NULL, cnt, sum);
        if (more)
            csi_pixel_sums_add(g, first->channels, more->pos, more->values, more->count, NULL, cnt, sum);
        s = csi_settle_sums(g, first->channels, cnt, sum, image->data, NULL, pixels);
    }
    free(cnt);
    free(sum);
    return s;
}

/* A sample of first or more by its cell: csi's cell order, then the sample's place (first's, then more's). */
typedef struct cell_key {
    uint64_t cell;
    size_t at;
} cell_key;

static int cmp_cell_key(const void *a, const void *b)
{
    const cell_key *x = a, *y = b;
    return x->cell != y->cell ? (x->cell > y->cell) - (x->cell < y->cell) : (x->at > y->at) - (x->at < y->at);
}

csi_status csi_refine_step_coverage(const csi_samples *first, const csi_samples *more, csi_image *image,
                                    size_t *pixels)
{
    if (!first || !image)
        return csi_fail(CSI_ERR_ARG, "csi_refine_step_coverage: %s is NULL", !first ? "first" : "image");
    if (pixels)
        *pixels = 0;
    CSI_TRY(check_pair(first, more, image));
    const size_t n1 = first->count, n = n1 + (more ? more->count : 0);
    if (!first->variance || (more && more->count && !more->variance) || !n)
        return CSI_OK; /* one path per sample: no noise level to tell a rim from a lucky path */
    const csi_samples *set[2] = {first, more};
    const uint32_t C = first->channels;
    for (int k = 0; k < 2 && set[k]; k++)
        for (size_t i = 0; i < set[k]->count * C; i++)
            if (!(set[k]->variance[i] >= 0 && isfinite(set[k]->variance[i])))
                return csi_fail(CSI_ERR_ARG, "refinement: %s sample %zu's variance is %s", k ? "refined" : "first",
                                i / C, isfinite(set[k]->variance[i]) ? "negative" : "not finite");
    cell_key *key = malloc(n * sizeof *key);
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *val = malloc(n * C * sizeof *val), *var = malloc(n * C * sizeof *var);
    csi_status s = key && pos && val && var ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
    if (s == CSI_OK) {
        for (size_t i = 0; i < n; i++) {
            const csi_samples *from = i < n1 ? first : more;
            key[i] = (cell_key){csi_grid_index(&first->grid, from->pos[i < n1 ? i : i - n1]), i};
        }
        qsort(key, n, sizeof *key, cmp_cell_key);
        for (size_t j = 0; j < n; j++) {
            const size_t i = key[j].at, at = i < n1 ? i : i - n1;
            const csi_samples *from = i < n1 ? first : more;
            pos[j] = from->pos[at];
            memcpy(val + j * C, from->values + at * C, C * sizeof *val);
            memcpy(var + j * C, from->variance + at * C, C * sizeof *var);
        }
        s = csi_step_coverage(&first->grid, C, pos, val, var, n, NULL, image->data, pixels);
    }
    free(key), free(pos), free(val), free(var);
    return s;
}
