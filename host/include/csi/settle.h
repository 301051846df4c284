/* The pixels that decide a still image, settled on their own samples' mean: the last step of a
 * reconstruction with the blend (csi_recon_options.settle), and the disagreement that step and
 * the second pass's pick (csi_refine_positions in csi/csi.h) both measure.
 *
 * Why. On a renderer's HDR samples at a few samples per pixel, one to three pixels can hold most
 * of an image's error (a sun, a lamp, an emitter's edge that one of a pixel's few samples hit):
 * there the fit and the pixel's own mean are a coin flip, and when the fit loses such a pixel the
 * whole image is worse than the mean of the same samples (issue 9's bound). Where the two
 * disagree by a large share of their disagreement over the whole image, one of them is that
 * wrong, and the samples cannot say which (docs/bench/mitsuba.md, sessions 15 and 20). The mean
 * is the unbiased one, so such a pixel takes it: no single pixel can then put the image above
 * the mean. A renderer that can sample again settles those pixels better, by sampling every cell
 * of them (the second pass: csi-mitsuba's default, csi-reconstruct --refine-request), and then
 * this step is not wanted on the first pass (its image is what the second completes). After the
 * passes, with several paths per sample, it runs once more on all the samples
 * (csi_refine_settle): with the lights' pixels exact, the pixels left deciding the image are the
 * fit's rings around them and dim lights among bright ones (docs/bench/mitsuba.md, session 48).
 *
 * The rule. d_p = sum over channels of (x_p - m_p)^2 (x the image, m the mean of the pixel's
 * samples, in double, a difference within float rounding counted as none), share_p = d_p / sum of
 * d over the pixels with a sample. Pixel p moves towards m_p by
 *
 *     w = clamp((share_p - FROM) / (FULL - FROM), 0, 1),
 *
 * FROM the pick's share (0.5%), FULL four times it, unless one of the two sees the pixel dark
 * (the lower of the channels' means of x_p and m_p under BRIGHT times the higher): that is a
 * firefly, a rare bright path in the mean that the fit rightly leaves out, not a light whose
 * extent the samples cannot tell; or unless neither sees it HDR (the higher under HDR times the
 * image's mean pixel): in an image of ordinary range no pixel's error can dominate, and where
 * few pixels hold the disagreement (a small image's edges) they are edges the fit has seen
 * between the samples, which the mean of a few point samples has not. Measured on 300 Mitsuba
 * cells and the analytic images (docs/bench/mitsuba.md, session 25).
 *
 * A light's neighbours. A pixel beside one that takes its mean whole (share >= FULL, and moved by
 * the tests above) counts as holding FULL itself, when it disagrees with its mean at all: it lies
 * on the same light, whose extent within it the samples cannot tell either. At higher resolution
 * one light spans more pixels, each with a smaller share of an image whose disagreement grew with
 * its pixel count: by its own share alone the ring around a sun's glint stays unsettled, and at
 * 512 x 512 its few pixels put the whole image above the mean (docs/bench/mitsuba.md, session
 * 29). The pick counts the same neighbours, so every pixel this step moves is still one the
 * second pass samples. */
#ifndef CSI_SETTLE_H
#define CSI_SETTLE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h"

/* The share from which a pixel moves (csi_refine_share_default's 0.5%, so that every pixel this
 * step touches is one the second pass would sample), and the share from which it takes its mean
 * whole. */
#define CSI_SETTLE_FROM 0.005
#define CSI_SETTLE_FULL 0.02
/* A pixel both see bright: the lower channels' mean at least this fraction of the higher. */
#define CSI_SETTLE_BRIGHT 0.3
/* An HDR pixel: the higher of the two at least this many times the image's level (the mean of
 * its pixels' means). Ordinary shading stays within about 4x of it (a diffuse wall in and out
 * of shadow: fit_trust.c's TRUST_R0); the lights that decide an image are far beyond. */
#define CSI_SETTLE_HDR 4.0
/* A relative difference this small between the image and the mean is float32's rounding of the
 * same value (2^-24 per operation, a few operations), not a disagreement. */
#define CSI_SETTLE_ROUNDING 1e-5

/* Adds to cnt[p] and sum[p * channels + c] each pixel's sample count and channel sums (in double,
 * in sample order) over the n samples inside box (x0, y0, x1, y1 in g's pixels; NULL: all). */
void csi_pixel_sums_add(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos, const float *values,
                        size_t n, const uint32_t box[4], uint32_t *cnt, double *sum);

/* Per pixel of an image and its samples: the sample count cnt[p], the channel sums
 * sum[p * channels + c] (in double, in sample order) and the disagreement d2[p] with the image;
 * total, the sum of d2 over the pixels. */
typedef struct csi_pixel_disagreement {
    uint32_t *cnt;
    double *sum, *d2, total;
} csi_pixel_disagreement;

/* *out for image (planar, g->out_w * g->out_h * channels) and the n samples (inside g; g->t must
 * be 1); freed with csi_pixel_disagreement_free (also after a failure). */
csi_status csi_pixel_disagreement_make(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                       const float *values, size_t n, const float *image,
                                       csi_pixel_disagreement *out);
void csi_pixel_disagreement_free(csi_pixel_disagreement *d);

/* share[p] for every pixel of image (planar) given its samples (cnt, sum) and its disagreement
 * (d2, total: csi_pixel_disagreement's): d2[p] / total, raised to CSI_SETTLE_FULL beside a pixel
 * that takes its mean whole (the header); 0 without a sample. */
csi_status csi_settle_shares(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                             const float *image, const double *d2, double total, double *share);

/* The step on a still image (planar, in and out) of the n samples: each pixel moved by the rule
 * above. *settled (may be NULL) gets the pixels moved inside box (x0, y0, x1, y1; NULL: all).
 * Deterministic. */
csi_status csi_settle(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos, const float *values, size_t n,
                      float *image, const uint32_t box[4], size_t *settled);

/* The same step given each pixel's sample count and channel sums (csi_pixel_sums_add's) instead
 * of the samples: the same bits as csi_settle on samples that give those sums. A tiled run
 * settles this way once, on the blended image, from its tiles' sums (csi/tiles.h): a pixel's
 * share is then of the whole image's disagreement, as untiled. */
csi_status csi_settle_sums(const csi_grid *g, uint32_t channels, const uint32_t *cnt, const double *sum,
                           float *image, const uint32_t box[4], size_t *settled);

#endif
