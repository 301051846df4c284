/* The per-pixel correction of Alg. 1: gathers the fine estimate at the samples, then applies the
 * control variate (below) or the blend (blend.c, then fit_trust.c on a still image). See
 * csi_aa_correct in csi/reconstruct.h. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* pixel += n_p / (n_p + n0) * mean over the pixel's samples of (y_i - g(x_i)), in double, in
 * sample order (deterministic). */
static void cv_correct(const csi_grid *g, double n0, const float *values, uint32_t channels,
                       uint32_t c, const csi_sample_pos *pos, const float *gs, size_t n,
                       double *sum, uint32_t *cnt, float *plane)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    for (size_t i = 0; i < n; i++) {
        size_t p = csi_recon_pixel_of(pos[i], bw, bh, g->out_w);
        sum[p] += (double)values[i * channels + c] - (double)gs[i];
        cnt[p]++;
    }
    for (size_t p = 0; p < np; p++)
        if (cnt[p])
            plane[p] = (float)((double)plane[p] + sum[p] / ((double)cnt[p] + n0));
}

csi_status csi_recon_correct(csi_ctx *ctx, const csi_grid *g, const csi_recon_options *opt,
                             csi_aa_correct how, const csi_linop *S, cl_mem fine, cl_mem gathered,
                             const float *values, uint32_t channels, uint32_t c,
                             const csi_sample_pos *pos, size_t n, bool clamp, float *plane)
{
    /* a host pass over every pixel and sample: seconds on an image of tens of megapixels */
    CSI_TRY(csi_recon_progress_channel(opt, "correct", c, channels));
    const size_t np = (size_t)g->out_w * g->out_h;
    float *gs = malloc(n * sizeof *gs);
    double *sum = calloc(np, sizeof *sum);
    uint32_t *cnt = calloc(np, sizeof *cnt);
    csi_status s = CSI_OK;
    if (!gs || !sum || !cnt)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel correction");
    if (s == CSI_OK && S)
        s = csi_linop_apply(S, fine, gathered);
    if (s == CSI_OK)
        s = csi_read(ctx, S ? gathered : fine, 0, n * sizeof(float), gs);
    if (s == CSI_OK && how == CSI_CORRECT_BLEND) {
        /* b, before the blend, for the fit's trust on a still image (fit_trust.c) */
        float *box = g->t == 1 ? malloc(np * sizeof *box) : NULL;
        if (g->t == 1 && !box)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel correction");
        if (box)
            memcpy(box, plane, np * sizeof *box);
        size_t multi = 0;
        if (s == CSI_OK)
            s = csi_recon_blend(g, opt, values, channels, c, pos, gs, n, clamp, csi_ctx_row_pool(ctx), plane,
                                &multi);
        /* a second host pass over every pixel and sample, where it can move a pixel (its own
         * count of the pixels' samples would find the blend's) */
        const bool trust = box && csi_recon_fit_trust_acts(g, multi);
        if (s == CSI_OK && trust)
            s = csi_recon_progress_channel(opt, "fit trust", c, channels);
        if (s == CSI_OK && trust)
            s = csi_recon_fit_trust(g, values, channels, c, pos, gs, n, opt->cv_n0, box, csi_ctx_row_pool(ctx),
                                    plane);
        free(box);
    } else if (s == CSI_OK)
        cv_correct(g, opt->cv_n0, values, channels, c, pos, gs, n, sum, cnt, plane);
    free(gs);
    free(sum);
    free(cnt);
    return s;
}
