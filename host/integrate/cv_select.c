/* The per-region choice between the reconstruction and the per-pixel mean by two-fold
 * cross-validation (csi/cv_select.h), and its place in a reconstruction: the two folds'
 * reconstructions, then the choice. All on the host, in double, in sample order (deterministic). */
#include "csi/cv_select.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/cv_smooth.h"
#include "internal.h"

csi_status csi_cv_folds(const csi_grid *g, const csi_sample_pos *pos, size_t n, uint8_t *fold,
                        size_t *pairs)
{
    if (g->t != 1)
        return csi_fail(CSI_ERR_ARG, "cross-validated choice: a volume (%u frames) is not an image", g->t);
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h;
    uint32_t *cnt = calloc(np, sizeof *cnt);
    uint8_t *has = calloc(np, 1); /* bit f: the pixel holds a sample of fold f */
    if (!cnt || !has) {
        free(cnt);
        free(has);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    }
    for (size_t i = 0; i < n; i++)
        cnt[csi_recon_pixel_of(pos[i], bw, bh, g->out_w)]++;
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
        /* k = ceil(sqrt(cnt)), exactly in integers */
        uint64_t k = (uint64_t)ceil(sqrt((double)cnt[p]));
        while (k > 1 && (k - 1) * (k - 1) >= cnt[p])
            k--;
        while (k * k < cnt[p])
            k++;
        const uint64_t sx = (uint64_t)(pos[i].x % bw) * k / bw, sy = (uint64_t)(pos[i].y % bh) * k / bh;
        fold[i] = (uint8_t)((sx + sy) & 1);
        has[p] |= (uint8_t)(1u << fold[i]);
    }
    if (pairs) {
        size_t c = 0;
        for (size_t p = 0; p < np; p++)
            c += has[p] == 3;
        *pairs = c;
    }
    free(cnt);
    free(has);
    return CSI_OK;
}

/* Marks (in `lose`) the pixels of the regions of side r whose sums of d[.][0] and of d[.][1] are
 * both above CSI_CV_Z times the root of their sums of squares. The regions are those of an image
 * whose pixel (0, 0) is this one's (ox, oy): a tile's window cut from a larger image makes the
 * larger image's regions, cut at the window's sides. */
static csi_status mark_regions(const csi_grid *g, uint32_t ox, uint32_t oy, const double *d, uint32_t r,
                               uint8_t *lose)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    const uint32_t sx = ox % r, sy = oy % r;
    const size_t rw = (g->out_w + sx + r - 1) / r, rh = (g->out_h + sy + r - 1) / r;
    double *acc = calloc(rw * rh * 4, sizeof *acc); /* per region: sum and sum of squares, x2 */
    if (!acc)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu regions", rw * rh);
#define REGION_OF(p) ((((p) / g->out_w + sy) / r) * rw + ((p) % g->out_w + sx) / r)
    for (size_t p = 0; p < np; p++) {
        double *a = acc + REGION_OF(p) * 4;
        for (int k = 0; k < 2; k++) {
            a[k * 2] += d[p * 2 + k];
            a[k * 2 + 1] += d[p * 2 + k] * d[p * 2 + k];
        }
    }
    for (size_t p = 0; p < np; p++) {
        const double *a = acc + REGION_OF(p) * 4;
        if (a[0] > CSI_CV_Z * sqrt(a[1]) && a[2] > CSI_CV_Z * sqrt(a[3]))
            lose[p] = 1;
    }
#undef REGION_OF
    free(acc);
    return CSI_OK;
}

csi_status csi_cv_choose(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                         const float *values, size_t n, const uint8_t *fold, const float *cA,
                         const float *cB, uint32_t region, float *image, size_t *switched)
{
    return csi_cv_choose_on(g, pos, n, fold, channels, values, cA, cB, region, channels, values, image,
                            switched);
}

static csi_status choose_at(const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box,
                            const csi_sample_pos *pos, size_t n, const uint8_t *fold, uint32_t fold_channels,
                            const float *fold_values, const float *cA, const float *cB, uint32_t region,
                            uint32_t channels, const float *values, float *image, size_t *switched, float *incA,
                            float *incB);

csi_status csi_cv_choose_on(const csi_grid *g, const csi_sample_pos *pos, size_t n, const uint8_t *fold,
                            uint32_t fold_channels, const float *fold_values, const float *cA,
                            const float *cB, uint32_t region, uint32_t channels, const float *values,
                            float *image, size_t *switched)
{
    return choose_at(g, 0, 0, NULL, pos, n, fold, fold_channels, fold_values, cA, cB, region, channels, values,
                     image, switched, NULL, NULL);
}

/* csi_cv_choose_on with the regions of an image whose pixel (0, 0) is this one's (ox, oy), and
 * *switched counting only the pixels inside box (x0, y0, x1, y1; NULL: all). incA, incB (may be
 * NULL): the folds' reconstructions (cA, cB's planes, which may be these), made the choice's own
 * predictions from each fold: a pixel that took its mean there has its folds' means
 * (csi/cv_smooth.h's incumbent). */
static csi_status choose_at(const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box,
                            const csi_sample_pos *pos, size_t n, const uint8_t *fold, uint32_t fold_channels,
                            const float *fold_values, const float *cA, const float *cB, uint32_t region,
                            uint32_t channels, const float *values, float *image, size_t *switched, float *incA,
                            float *incB)
{
    if (switched)
        *switched = 0;
    if (region < 1)
        return csi_fail(CSI_ERR_ARG, "cross-validated choice: a region of %u pixels", region);
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h;
    const uint32_t fc = fold_channels;
    /* per pixel and fold: count, and the sums per channel of the folds' values and of the image's */
    double *sum = calloc(np * 2 * fc, sizeof *sum);
    double *isum = calloc(np * 2 * channels, sizeof *isum);
    uint32_t *cnt = calloc(np * 2, sizeof *cnt);
    double *d = calloc(np * 2, sizeof *d); /* per pixel: D in squared and in relative error */
    uint8_t *lose = calloc(np, 1);
    csi_status s = CSI_OK;
    if (!sum || !isum || !cnt || !d || !lose)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    for (size_t i = 0; i < n && s == CSI_OK; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w), f = fold[i] & 1;
        cnt[p * 2 + f]++;
        for (uint32_t c = 0; c < fc; c++)
            sum[(p * 2 + f) * fc + c] += fold_values[i * fc + c];
        for (uint32_t c = 0; c < channels; c++)
            isum[(p * 2 + f) * channels + c] += values[i * channels + c];
    }
    for (size_t p = 0; p < np && s == CSI_OK; p++) {
        const uint32_t na = cnt[p * 2], nb = cnt[p * 2 + 1];
        if (!na || !nb)
            continue;
        for (uint32_t c = 0; c < fc; c++) {
            const double sa = sum[(p * 2) * fc + c], sb = sum[(p * 2 + 1) * fc + c];
            const double ma = sa / na, mb = sb / nb, m = (sa + sb) / (na + nb);
            const double a = cA[(size_t)c * np + p], b = cB[(size_t)c * np + p];
            const double e = (a - mb) * (a - mb) + (b - ma) * (b - ma) - 2 * (ma - mb) * (ma - mb);
            d[p * 2] += e;
            d[p * 2 + 1] += e / (m * m + CSI_CV_REL_FLOOR);
        }
    }
    if (s == CSI_OK)
        s = mark_regions(g, ox, oy, d, region, lose);
    if (s == CSI_OK)
        s = mark_regions(g, ox, oy, d, 2 * region, lose);
    size_t sw = 0;
    for (size_t p = 0; p < np && s == CSI_OK; p++) {
        const uint32_t nt = cnt[p * 2] + cnt[p * 2 + 1];
        if (!lose[p] || !nt)
            continue;
        for (uint32_t c = 0; c < channels; c++)
            image[(size_t)c * np + p] = (float)((isum[(p * 2) * channels + c] + isum[(p * 2 + 1) * channels + c]) / nt);
        if (incA && cnt[p * 2] && cnt[p * 2 + 1])
            for (uint32_t c = 0; c < fc; c++) {
                incA[(size_t)c * np + p] = (float)(sum[(p * 2) * fc + c] / cnt[p * 2]);
                incB[(size_t)c * np + p] = (float)(sum[(p * 2 + 1) * fc + c] / cnt[p * 2 + 1]);
            }
        const uint32_t x = (uint32_t)(p % g->out_w), y = (uint32_t)(p / g->out_w);
        sw += !box || (x >= box[0] && y >= box[1] && x < box[2] && y < box[3]);
    }
    if (switched)
        *switched = sw;
    free(sum);
    free(isum);
    free(cnt);
    free(d);
    free(lose);
    return s;
}

/* The reconstruction from the samples of one fold alone (the same options but the choice off, the
 * folds' model grid, CSI_CV_FOLD_SIGMA_MIN, and their stop, CSI_CV_FOLD_TOL). */
static csi_status fold_image(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                             const float *values, size_t n, const uint8_t *fold, uint8_t f,
                             const csi_recon_options *opt, csi_recon_result *main, float **image)
{
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += fold[i] == f;
    csi_sample_pos *fp = malloc((m ? m : 1) * sizeof *fp);
    float *fv = malloc((m ? m : 1) * channels * sizeof *fv);
    if (!fp || !fv) {
        free(fp);
        free(fv);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", m);
    }
    size_t j = 0;
    for (size_t i = 0; i < n; i++)
        if (fold[i] == f) {
            fp[j] = pos[i];
            memcpy(fv + j * channels, values + i * channels, channels * sizeof *fv);
            j++;
        }
    csi_recon_options o = *opt;
    o.cv_select = CSI_SWITCH_OFF;
    /* the choice weighs the fit against the mean; settling the pixels that decide the image is a
     * step after it, on the whole image (csi/settle.h) */
    o.settle = CSI_SWITCH_OFF;
    if (o.model_sigma_min == 0 /* auto: CSI_MODEL_SIGMA_MIN */ || o.model_sigma_min > CSI_CV_FOLD_SIGMA_MIN)
        o.model_sigma_min = CSI_CV_FOLD_SIGMA_MIN;
    /* The folds measure the blend against the mean; the peaks' test (csi/peak_noise.h) comes
     * after the choice, on the whole image only (and a fold's indexing is not the whole's). */
    o.sample_variance = NULL;
    /* SpaRSA's objective stop (auto resolves to both for an image); an auto tol is 0 here */
    if (o.solver != CSI_SOLVER_ROMP && o.stop != CSI_STOP_GAP && !(o.tol >= CSI_CV_FOLD_TOL))
        o.tol = CSI_CV_FOLD_TOL;
    csi_recon_result r;
    csi_status s = csi_recon_progress(opt, f ? "cross-validation 2/2" : "cross-validation 1/2");
    if (s == CSI_OK)
        s = csi_recon(ctx, g, channels, fp, fv, m, &o, &r);
    free(fp);
    free(fv);
    CSI_TRY(s);
    /* the run's cost is the reconstruction's too */
    main->t_solve += r.t_solve;
    main->t_integrate += r.t_integrate;
    main->cpu_work += r.cpu_setup + r.cpu_work;
    *image = r.image;
    r.image = NULL;
    csi_recon_result_free(&r);
    return CSI_OK;
}

csi_status csi_recon_cv_select(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                               const float *values, size_t n, const csi_recon_options *opt,
                               csi_recon_result *out)
{
    return csi_recon_cv_select_at(ctx, g, 0, 0, NULL, channels, pos, values, n, opt, out);
}

csi_status csi_recon_cv_select_at(csi_ctx *ctx, const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box,
                                  uint32_t channels, const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, csi_recon_result *out)
{
    /* Below 2 samples per pixel on average each fold's reconstruction is made from under one
     * sample per pixel, a regime so unlike the whole's that its loss against the mean says little
     * about the whole's (docs/bench/mitsuba.md: Poisson-disk cells at 1 spp); nothing is done. */
    if (n < 2 * (size_t)g->out_w * g->out_h)
        return CSI_OK;
    const double t0 = csi_recon_now();
    uint8_t *fold = malloc(n ? n : 1);
    if (!fold)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
    size_t pairs = 0;
    csi_status s = csi_cv_folds(g, pos, n, fold, &pairs);
    float *a = NULL, *b = NULL;
    /* no pixel with a held-out pair: nothing to decide on, the reconstruction stays */
    /* the folds' values: the channels' mean (sample by sample, in double) or the samples' own */
    const int on_mean = channels > 1 && opt->cv_channels != CSI_CV_CHANNELS_EACH;
    const uint32_t fc = on_mean ? 1 : channels;
    float *mean = NULL;
    if (s == CSI_OK && pairs && on_mean) {
        if (!(mean = malloc(n * sizeof *mean)))
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        for (size_t i = 0; i < n && s == CSI_OK; i++) {
            double t = 0;
            for (uint32_t c = 0; c < channels; c++)
                t += values[i * channels + c];
            mean[i] = (float)(t / channels);
        }
    }
    const float *fv = on_mean ? mean : values;
    if (s == CSI_OK && pairs) {
        s = fold_image(ctx, g, fc, pos, fv, n, fold, 0, opt, out, &a);
        if (s == CSI_OK)
            s = fold_image(ctx, g, fc, pos, fv, n, fold, 1, opt, out, &b);
        const bool smooth = out->options.cv_smooth == CSI_SWITCH_ON; /* resolved: opt may say auto */
        if (s == CSI_OK)
            s = choose_at(g, ox, oy, box, pos, n, fold, fc, fv, a, b, CSI_CV_REGION, channels, values, out->image,
                          &out->cv_switched, smooth ? a : NULL, smooth ? b : NULL);
        if (s == CSI_OK && smooth)
            s = csi_cv_smooth(csi_ctx_row_pool(ctx), g, ox, oy, box, pos, n, fold, fc, fv, a, b, channels, values,
                              out->image, &out->cv_smoothed);
    }
    free(mean);
    free(a);
    free(b);
    free(fold);
    out->t_cv = csi_recon_now() - t0;
    return s;
}
