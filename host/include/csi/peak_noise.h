/* Isolated peaks judged against their own Monte Carlo noise: the last step of a still image's
 * reconstruction when the samples come with their variances (csi_samples.variance; a renderer
 * that averages several paths per sample knows each value's noise, csi-mitsuba writes it).
 *
 * Why. Where most pixels hold one sample, the blend (host/integrate/blend.c) estimates the noise
 * of a pixel's mean from its neighbours' means, which cannot see one sample's own noise, and the
 * fit (fit_trust.c) cannot tell a sample far brighter than every neighbour's (an isolated peak)
 * that is noise, one rare bright path, from one that is the image. So it keeps most of every
 * such peak: on the Mitsuba benchmark's 1-spp x 64-path images a single path of a sun reached
 * through a diffuse bounce, 45 where the pixel's truth is 0.7, stays at 44 (docs/bench/mitsuba.md).
 * The sample's variance tells the two apart: a peak that its own noise explains is noise.
 *
 * The rule, per channel, at each pixel holding exactly one sample y of variance v (of more than
 * one cell, in an image where at most half the pixels hold two samples or more): the pixel is a
 * peak when (y + e) >= CSI_PEAK_RATIO (h + e), h the largest sample of its 8 neighbours (0 if
 * negative), e 1% of the samples' mean absolute value (blend.c's floor). A peak is explained by
 * its noise when y - h < CSI_PEAK_Z sqrt(v): a value whose expectation is at most h exceeds it by
 * z standard deviations with probability at most 1 / z^2 (Chebyshev's inequality, whatever the
 * paths' distribution; one path in 64 carrying all of a sample's value gives v = y^2, z <= 1).
 * Such a peak is taken as noise and the pixel as one without a sample: the median of its
 * neighbours' means. That drops the energy of rare bright paths, a bias towards dark, in
 * exchange for their variance (the firefly trade every renderer's clamp makes); with the
 * variances a caller opts into it. A peak its noise does not explain keeps the reconstruction's
 * value: it is the image, but its one sample is no better an estimate of the pixel (a peak is
 * selected for being bright, and over-reads more often than not: keeping those samples was
 * measured and not kept, docs/bench/mitsuba.md).
 *
 * Pixels with two samples or more keep their value: their within-pixel variance already holds
 * their paths' noise (the blend sees it). Nothing here can make a value negative: the neighbours'
 * median is a mean of samples. */
#ifndef CSI_PEAK_NOISE_H
#define CSI_PEAK_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h"

/* A sample at least this many times brighter than every neighbour's is a peak: fit_trust.c's
 * ratio from which an isolated bright sample starts to lose the fit's trust (4:1 is ordinary
 * shading, beyond it the HDR steps the fit spreads). */
#define CSI_PEAK_RATIO 4.0
/* Standard deviations of the sample's own noise its excess over the neighbours must reach to be
 * the image's (Chebyshev: noise passes it with probability at most 1/9). */
#define CSI_PEAK_Z 3.0

/* The rule above on a planar image (channel c's pixel p at c * out_w * out_h + p), in place.
 * values and variance: sample-major, `channels` per sample; variance >= 0. grid.t must be 1.
 * *changed (may be NULL): the pixel-channels set. */
csi_status csi_peak_noise(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, const float *variance, size_t n, float *image,
                          size_t *changed);

#endif
