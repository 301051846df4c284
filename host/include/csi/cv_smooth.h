/* Smoothings of the samples as further candidates of the cross-validated choice (csi/cv_select.h):
 * where the samples are mostly noise, a region takes a Gaussian average of its samples when both
 * folds say it predicts the held-out pixel means significantly better than what the choice kept.
 *
 * Why. csi's fit is made for antialiasing: it follows the samples, noise included, so on a path
 * tracer's noise-dominated samples (fog lit by a spot, a caustic, any dim diffuse wall at one path
 * per sample) it is about the per-pixel mean, while a plain Gaussian average of the samples a few
 * pixels wide is a tenth of it (docs/bench/mitsuba.md, session 49). A Gaussian is as wrong as
 * possible at an edge, a thin line or a small light, so it must be chosen where it is right, from
 * the samples alone; the choice's folds already hold what that takes.
 *
 * The candidates. For each width s of CSI_CV_SMOOTH_SIGMAS (output pixels), the normalized
 * convolution of the samples on the pixel grid: G_s = (K_s * sum) / (K_s * count), K_s a Gaussian
 * of standard deviation s truncated at 3 s, sum and count each pixel's sample sum and count (zero
 * outside the image). It is made from each fold's samples alone (G_A, G_B) on the folds' values,
 * and from all the samples in every channel for the image.
 *
 * The test, per region of CSI_CV_REGION x CSI_CV_REGION pixels (the choice's, aligned as its): the
 * incumbent is what the choice kept, its folds' predictions c_A, c_B (the folds' reconstructions,
 * or the folds' means m_A, m_B where the region took its mean). Per pixel holding samples of both
 * folds, the gain of G_s in each direction,
 *
 *     D_A = (c_A - m_B)^2 - (G_A - m_B)^2,   D_B = (c_B - m_A)^2 - (G_B - m_A)^2,
 *
 * summed over the folds' channels, is unbiased for how much less G_s on half the samples errs
 * than the incumbent on half the samples in the pixel's integral (the held-out mean's own noise
 * cancels: csi/cv_select.h). Each is summed over the region twice, as is and divided by
 * m^2 + CSI_CV_REL_FLOOR L^2 (m the pixel's mean over both folds, L the samples' mean magnitude:
 * the relative error of issue 9's relMSE for radiance of level 1, and the same decisions for
 * samples of any scale). G_s passes when
 * all four sums S are above CSI_CV_Z times the root of the sums of their squared terms: a
 * significant gain in both directions and in both measures, never one or two pixels' (the
 * self-normalised test of csi/cv_select.h). Of the widths that pass, the region takes the one with
 * the largest sum of its two absolute gains.
 *
 * The bound. A region's gain is a sum, and a Gaussian that is better over a region can still be
 * far wrong in a few of its pixels (light spread from a lamp into the dark pixel beside it, one
 * colour into another). A smoothing may only remove noise, so a pixel's smoothed value in each
 * channel is kept within CSI_CV_SMOOTH_BOUND standard errors of its own samples' mean, m +- K se,
 * se^2 the samples' spread (their unbiased variance) / n, which holds their noise and how much
 * of the pixel they disagree on (the same in a tile's window as untiled); a pixel of fewer than 2
 * samples keeps the incumbent, and so does one whose every cell is sampled (its mean is its exact
 * box integral, issue 9); a value is not made negative when no sample is, nor taken beyond the
 * least and greatest sample of its 3 x 3 pixels (what the samples around it saw: no halo). Measured before it was built, in numpy on 224 Mitsuba cells at
 * 2-16 spp: without the bound one cell's relMSE went from 0.88x the mean's to 1.64x (neon tubes
 * at 2 spp); with it none above csi's own (docs/bench/mitsuba.md, session 49). */
#ifndef CSI_CV_SMOOTH_H
#define CSI_CV_SMOOTH_H

#include <stddef.h>
#include <stdint.h>

#include "csi/row_pool.h"
#include "csi/samples.h"
#include "csi/status.h"

/* The Gaussians' standard deviations, in output pixels. */
#define CSI_CV_SMOOTH_WIDTHS 4
#define CSI_CV_SMOOTH_SIGMAS {0.5, 1.0, 2.0, 4.0}
/* The bound, in standard errors of the pixel's mean. */
#define CSI_CV_SMOOTH_BOUND 2.0

/* The step on an image (planar, channel c's pixel p at c * out_w * out_h + p; in and out) of the
 * n samples (values sample-major, `channels` per sample) split by fold
 * (csi_cv_folds). fold_values (fold_channels per sample) are what the folds were reconstructed
 * on, and cA, cB (planar, fold_channels) the incumbent's predictions from each fold alone (above).
 * The regions are those of an image whose pixel (0, 0) is this one's (ox, oy); *smoothed (may be
 * NULL) counts the pixels changed inside box (x0, y0, x1, y1; NULL: all). Deterministic: in
 * double, in sample and pixel order; the Gaussians' rows on pool's threads (NULL: the calling
 * thread), the same bits either way. */
csi_status csi_cv_smooth(csi_row_pool *pool, const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box, const csi_sample_pos *pos,
                         size_t n, const uint8_t *fold, uint32_t fold_channels, const float *fold_values,
                         const float *cA, const float *cB, uint32_t channels, const float *values, float *image,
                         size_t *smoothed);

#endif
