/* Images and volumes whose sizes the transforms cannot take, padded: see csi_recon_pad_grid (internal.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

bool csi_smooth7(uint64_t v)
{
    static const uint64_t p[4] = {2, 3, 5, 7};
    if (v == 0)
        return false;
    for (int i = 0; i < 4; i++)
        while (v % p[i] == 0)
            v /= p[i];
    return v == 1;
}

/* The output length (pixels) one axis is solved at: `out` itself when its `cells` fine cells per
 * pixel make a length the transforms take (7-smooth; even for the first axis, the real FFT's and
 * the half spectrum's, and for both axes of an image, which a wavelet level halves: an odd side,
 * as a 45 x 27 image of one cell per pixel has, leaves it none), else the smallest longer one
 * that also keeps as many factors of two as a grid of its size can use, up to `twos` (2^6 for
 * an image: five wavelet levels on an even model grid, so that the padding does not cost the
 * levels an unpadded grid of that size would have; a volume's Fourier basis needs none). */
static uint32_t padded_length(uint32_t out, uint32_t cells, bool even, uint64_t twos)
{
    const uint64_t f = (uint64_t)out * cells;
    /* cells with a prime factor above 7 make every length unusable: nothing to pad to */
    if ((csi_smooth7(f) && (!even || f % 2 == 0)) || !csi_smooth7(cells))
        return out;
    uint64_t m = even ? 2 : 1;
    while (m < twos && m * 8 <= f)
        m *= 2;
    /* ends: cells being 7-smooth, a power of two pixels at least m is always taken */
    for (uint64_t e = (uint64_t)out + 1; e <= UINT32_MAX; e++)
        if (e * cells % m == 0 && csi_smooth7(e * cells))
            return (uint32_t)e;
    return out;
}

bool csi_recon_pad_grid(const csi_grid *g, csi_grid *padded)
{
    *padded = *g;
    if (!g->t || !g->out_w || !g->out_h || g->w % g->out_w || g->h % g->out_h)
        return false; /* bad sizes are csi_recon's errors to report */
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const uint64_t twos = g->t == 1 ? 64 : 1;
    const uint32_t pw = padded_length(g->out_w, bw, true, twos), ph = padded_length(g->out_h, bh, g->t == 1, twos);
    /* a volume's frames too: the later ones hold no sample, and the image is the mean over the
     * shutter's own (csi_recon_options.shutter_frames) */
    const uint32_t pt = g->t > 1 ? padded_length(g->t, 1, false, 1) : 1;
    if ((pw == g->out_w && ph == g->out_h && pt == g->t) || (uint64_t)pw * bw > UINT32_MAX ||
        (uint64_t)ph * bh > UINT32_MAX)
        return false;
    padded->out_w = pw;
    padded->out_h = ph;
    padded->w = pw * bw;
    padded->h = ph * bh;
    padded->t = pt;
    return true;
}

/* planes planar images of W x H (a result's image: one per channel; its frames: one per frame
 * and channel), each cut to its top-left w x h pixels, into a new array. */
static float *crop_planes(const float *src, size_t planes, uint32_t W, uint32_t H, uint32_t w, uint32_t h)
{
    const size_t count = planes * w * h;
    float *dst = malloc((count ? count : 1) * sizeof *dst);
    for (size_t p = 0; dst && p < planes; p++)
        for (uint32_t y = 0; y < h; y++)
            memcpy(dst + (p * h + y) * w, src + (p * H + y) * W, w * sizeof *dst);
    return dst;
}

csi_status csi_recon_crop(csi_recon_result *r, uint32_t out_w, uint32_t out_h, uint32_t nframes)
{
    if (out_w > r->out_w || out_h > r->out_h || (r->frames && nframes > r->nframes))
        return csi_fail(CSI_ERR_ARG, "cannot crop a %ux%u result to %ux%u", r->out_w, r->out_h, out_w, out_h);
    if (!r->frames)
        nframes = 0;
    /* frames are frame-major: the first nframes are a prefix */
    float *img = crop_planes(r->image, r->channels, r->out_w, r->out_h, out_w, out_h);
    float *frames = r->frames ? crop_planes(r->frames, (size_t)nframes * r->channels, r->out_w, r->out_h, out_w, out_h)
                              : NULL;
    if (!img || (r->frames && !frames)) {
        free(img);
        free(frames);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the output image");
    }
    free(r->image);
    free(r->frames);
    r->image = img;
    r->frames = frames;
    r->out_w = out_w;
    r->out_h = out_h;
    r->nframes = nframes;
    return CSI_OK;
}

csi_status csi_recon_padded_fail(csi_status s, const csi_grid *g, const csi_grid *padded)
{
    char why[512], frames[64] = "";
    snprintf(why, sizeof why, "%s", csi_last_error());
    if (padded->t != g->t)
        snprintf(frames, sizeof frames, ", its %u frames to %u,", g->t, padded->t);
    return csi_fail(s, "%s (the %ux%u image padded to %ux%u%s for the FFT)", why, g->out_w, g->out_h, padded->out_w,
                    padded->out_h, frames);
}

bool csi_recon_solved_grid(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const csi_recon_options *opt, csi_grid *out)
{
    csi_grid padded;
    *out = *g;
    if (!csi_recon_pad_grid(g, &padded))
        return false;
    csi_tiling own, whole;
    const bool tiles = csi_tiling_plan(ctx, g, channels, n, opt, &own) == CSI_OK && own.count > 1;
    const bool fits = csi_tiling_plan(ctx, &padded, channels, n, opt, &whole) == CSI_OK && whole.count == 1;
    if (tiles && !fits)
        return false;
    *out = padded;
    return true;
}
