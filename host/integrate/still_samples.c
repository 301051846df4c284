/* Whether a volume's samples are a noise-free still picture (the still layer's weight,
 * motion.c; issue 12, docs/bench/animation.md session 30).
 *
 * Where the picture holds still and the samples carry no noise, every sample of a pixel has the
 * same value, whatever its time: exact point samples of a still photograph. A path tracer's
 * samples differ at every time (each is one Monte Carlo estimate), and so do the samples of a
 * pixel something moves through. So the share of the pixels holding two samples or more whose
 * samples are all equal in every channel, tells the two kinds of volume apart: on
 * the benchmark's still photographs with movers it is 0.89-1.0, on every path-traced animation
 * 0. */
#include <stdbool.h>
#include <stdlib.h>

#include "internal.h"

/* Each pixel's first sample and its state (internal.h: CSI_STILL_*), in one pass in sample order. */
typedef struct {
    size_t *first;
    unsigned char *state;
} agreement;

static void agreement_free(agreement *a)
{
    free(a->first), free(a->state);
}

static csi_status agreement_make(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                 uint32_t channels, size_t n, agreement *a)
{
    const size_t ow = g->out_w, np = ow * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    a->first = malloc(np * sizeof *a->first);
    a->state = calloc(np, 1);
    if (!a->first || !a->state) {
        agreement_free(a);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the samples' agreement over t (%zu pixels)", np);
    }
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
        unsigned char *st = &a->state[p];
        if (*st == CSI_STILL_NONE) {
            a->first[p] = i, *st = CSI_STILL_ONE;
            continue;
        }
        if (*st == CSI_STILL_DIFFER)
            continue;
        *st = CSI_STILL_AGREE;
        for (uint32_t c = 0; c < channels && *st == CSI_STILL_AGREE; c++) /* by value: a window's sums see no sign of 0 */
            if (values[i * channels + c] != values[a->first[p] * channels + c])
                *st = CSI_STILL_DIFFER;
    }
    return CSI_OK;
}

double csi_recon_still_share(const unsigned char *state, size_t np)
{
    size_t multi = 0, equal = 0;
    for (size_t p = 0; p < np; p++) {
        multi += state[p] >= CSI_STILL_DIFFER;
        equal += state[p] == CSI_STILL_AGREE;
    }
    return multi ? (double)equal / (double)multi : 0;
}

bool csi_recon_still_calm(const unsigned char *state, size_t p, size_t ow, size_t oh)
{
    size_t nb[9];
    const int k = csi_recon_window3_at(p % ow, p / ow, ow, oh, nb);
    for (int j = 0; j < k; j++)
        if (state[nb[j]] != CSI_STILL_AGREE)
            return false;
    return true;
}

csi_status csi_recon_still_exact_share(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                       uint32_t channels, size_t n, double *share)
{
    agreement a;
    CSI_TRY(agreement_make(g, pos, values, channels, n, &a));
    *share = csi_recon_still_share(a.state, (size_t)g->out_w * g->out_h);
    agreement_free(&a);
    return CSI_OK;
}

csi_status csi_recon_still_pixels(const csi_grid *g, const float *values, uint32_t channels,
                                  const csi_sample_pos *pos, size_t n, float *image)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    agreement a;
    CSI_TRY(agreement_make(g, pos, values, channels, n, &a));
    const bool still_picture = csi_recon_still_share(a.state, np) > CSI_STILL_PICTURE_SHARE;
    for (size_t p = 0; still_picture && p < np; p++) {
        if (!csi_recon_still_calm(a.state, p, ow, oh))
            continue;
        for (uint32_t c = 0; c < channels; c++)
            image[(size_t)c * np + p] = values[a.first[p] * channels + c];
    }
    agreement_free(&a);
    return CSI_OK;
}
