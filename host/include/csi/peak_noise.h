/* Isolated peaks judged against their own Monte Carlo noise: the last step of a still image's
 * reconstruction when the samples come with their variances (csi_samples.variance; a renderer
 * that averages several paths per sample knows each value's noise, csi-mitsuba writes it).
 *
 * Why. Neither the blend (host/integrate/blend.c) nor the fit (fit_trust.c) can tell a sample
 * far brighter than every sample around it (an isolated peak) that is noise, one rare bright
 * path, from one that is the image: the blend's noise estimate comes from the neighbours' means
 * (one sample per pixel) or from the pixel's spread, which such a sample inflates as much as an
 * edge does. So csi keeps most of every such peak, and the per-pixel mean keeps all of it: on
 * the Mitsuba benchmark a single path of a sun reached through a diffuse bounce, 45 where the
 * pixel's truth is 0.7, stays at 44, and at 4 spp x 64 paths a dozen such samples carry 90-98% of
 * an image's relMSE (docs/bench/mitsuba.md). The sample's variance tells the two apart: a peak
 * that its own noise explains is noise.
 *
 * The rule, per channel, in pixels of more than one cell, not all of them sampled (a pixel whose
 * every cell holds a sample is its cells' exact mean, whatever their noise: csi's output there is
 * the box integral of the samples, as the blend's finite-population factor leaves it, and a
 * renderer's own firefly clamp is the place for more). A sample y of variance v is a peak when
 * (y + e) >= CSI_PEAK_RATIO (h + e), where h is the largest of the other samples of its pixel,
 * or, for a pixel's only sample, of its 8 neighbours' samples (h 0 if negative), and e 1% of the
 * samples' mean absolute value (blend.c's floor); a pixel's brightest sample is the only one that
 * can be a peak. A peak is explained by its noise when y - h < CSI_PEAK_Z sqrt(v): a value whose
 * expectation is at most h exceeds it by z standard deviations with probability at most 1 / z^2
 * (Chebyshev's inequality, whatever the paths' distribution; one path in 64 carrying all of a
 * sample's value gives v = y^2, z <= 1). Such a peak is shrunk by how much of it its noise
 * explains: with r the value without it (the mean of its pixel's other samples, or, for a
 * pixel's only sample, the median of its neighbours' means, a pixel without a sample; for a
 * pixel of several samples the neighbours' median too where it is higher and the pixel's other
 * samples may share the neighbourhood's rate of such peaks: a caustic, peak_noise.c), x the
 * reconstruction's value and d = y - h, the pixel becomes r + w (x - r), w = max(0, 1 - v / d^2):
 * the positive-part James-Stein (Wiener) weight, max(0, d^2 - v) estimating the excess's signal
 * power and d^2 its total. One path carrying a whole sample (v ~ y^2) gives w ~ 0, the peak
 * dropped; k of 64 paths carrying it give w ~ 1 - 1/k, most of it kept. Dropping all of every
 * such peak (w = 0) took a caustic's energy, made of exactly such rare bright paths, and was
 * measured against this (docs/bench/mitsuba.md). What is shrunk away is a bias towards dark, in
 * exchange for variance (the firefly trade every renderer's clamp makes); with the variances a
 * caller opts into it. A peak its noise does not explain keeps the reconstruction's
 * value: it is the image, but its sample is no better an estimate of the pixel (a peak is
 * selected for being bright and over-reads more often than not: keeping single samples' values
 * was measured and not kept, docs/bench/mitsuba.md).
 *
 * Nothing here makes a value negative that was not: r is a mean of samples, w in [0, 1). */
#ifndef CSI_PEAK_NOISE_H
#define CSI_PEAK_NOISE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/row_pool.h"
#include "csi/samples.h"
#include "csi/status.h"

/* A sample at least this many times brighter than every neighbour's is a peak: fit_trust.c's
 * ratio from which an isolated bright sample starts to lose the fit's trust (4:1 is ordinary
 * shading, beyond it the HDR steps the fit spreads). */
#define CSI_PEAK_RATIO 4.0
/* Standard deviations of the sample's own noise its excess over the neighbours must reach to be
 * the image's (Chebyshev: noise passes it with probability at most 1/9). */
#define CSI_PEAK_Z 3.0
/* The probability below which a pixel's other samples, all below a peak's level, say that the
 * pixel does not share its neighbours' rate of such samples (the usual 5% level). */
#define CSI_PEAK_SHARED_P 0.05

/* The rule above on a planar image (channel c's pixel p at c * out_w * out_h + p), in place.
 * values and variance: sample-major, `channels` per sample; variance >= 0. grid.t must be 1.
 * The passes over the pixels run in bands of rows on pool (NULL: on the calling thread), the
 * same bits either way. *changed (may be NULL): the pixel-channels set. */
csi_status csi_peak_noise(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, const float *variance, size_t n, csi_row_pool *pool,
                          float *image, size_t *changed);

#endif
