/* A pixel whose samples hold one isolated peak, estimated by a fit of the samples' logarithm: an
 * option of a still image's reconstruction with the blend (csi_recon_options.peak_range).
 *
 * Why. A pixel of several samples one of which is far brighter than all the others (a sub-pixel
 * highlight, a glint, a sun seen in a bead) is where the per-pixel mean, and the blend that
 * leans on it, make most of their error on a path tracer's HDR images: the peak sample stands
 * for a whole stratum (a quarter of the pixel at 4 spp) although the highlight it hit covers
 * only a part of it. The mean is unbiased over all the positions the samples could have had,
 * but a pixel is singled out here *because* one sample hit the highlight, and given that, the
 * mean over-reads (its error is the hit's luck). csi's own fit cannot help: fitting a 100:1
 * peak in a sparse basis rings and spreads it. A fit of u = log(1 + y / s) does neither (the
 * peak is a bump of a few units among values near 0), and expanded, s (e^u - 1), on the fine
 * grid, then averaged over the pixel's cells, the bump's extent is what the neighbouring
 * samples allow: narrow where they are all dark (a bead on a dark floor), wider where they are
 * bright (a glint on a lit ball). On its own that fit is biased at every HDR edge (in the log
 * domain a smooth fit between two levels expands to about their geometric mean, darker than
 * their mean), which is why it is used only in the pixels that hold such a peak
 * (docs/bench/mitsuba.md, session 10).
 *
 * The rule. A pixel of more than one cell holding n >= 2 samples is a peak pixel when its
 * brightest sample y (by the channels' mean) satisfies (y + e) >= CSI_PEAK_RANGE_RATIO (h + e),
 * h the brightest of its other samples (0 if negative), e 1% of the samples' mean absolute
 * value, and (y + e) >= CSI_PEAK_RANGE_NEIGHBOURS (h' + e) for the brightest sample h' of its 8
 * neighbouring pixels (a pixel on an HDR edge has the bright side's samples around it: the
 * emitter's border, a window behind thin bars, where the log fit's bias darkens the bright
 * side); two equal brightest samples make no peak. Pixels with one sample are left alone: the
 * question there is the peak against its neighbours, where the isolated sample under-reads as
 * often as it over-reads (docs/bench/mitsuba.md, the horizon glint). If any pixel is a peak
 * pixel, each channel's samples are mapped to u = log(1 + max(y, 0) / s), s =
 * CSI_PEAK_RANGE_K times the channel's mean of max(y, 0), reconstructed by csi on the fine grid
 * itself (the same options, the correction none, the tau of the whole), each fine value clipped
 * to [0, log(1 + max y / s)] and expanded, and a peak pixel takes the mean over its cells where that is below the
 * reconstruction's value (the rule takes back over-reading; a bump above it has spread beyond
 * the peak's stratum: a single bright path among dark ones). The result is >= 0 where the
 * reconstruction's was. One more reconstruction, with an output the
 * size of the fine grid (bw x bh floats per pixel and channel). */
#ifndef CSI_PEAK_RANGE_H
#define CSI_PEAK_RANGE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h"

/* fit_trust.c's and peak_noise.h's ratio: 4:1 is ordinary shading, beyond it a peak. */
#define CSI_PEAK_RANGE_RATIO 4.0
/* How much brighter than every sample of the 8 neighbouring pixels a peak is: a neighbour with a
 * sample at half the peak or more is taken to hold part of the same bright feature (with 1, any
 * local maximum, the window behind thin_geometry's bars lost 3-4% of its MSE:
 * docs/bench/mitsuba.md, session 10). */
#define CSI_PEAK_RANGE_NEIGHBOURS 2.0
/* The map's scale in units of the channel's mean sample: values well above the image's mean
 * are compressed, values near it almost not. */
#define CSI_PEAK_RANGE_K 8.0

/* The peak pixels of a still image (grid.t = 1): peak[p] = 1 for each, the count returned in
 * *count. values: sample-major, `channels` per sample. */
csi_status csi_peak_range_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                 const float *values, size_t n, uint8_t *peak, size_t *count);

/* Each channel's samples mapped: u = log(1 + max(y, 0) / s[c]), s[c] = CSI_PEAK_RANGE_K times
 * the channel's mean of max(y, 0) (a channel of zeros keeps s = 0 and u = 0); umax[c] the largest
 * u. u: n * channels, sample-major like values. */
void csi_peak_range_map(uint32_t channels, const float *values, size_t n, float *u, double s[4],
                        double umax[4]);

/* Channel c's estimate of output pixel p from the fit of the mapped samples on the fine grid
 * (`fine`: the planar w x h image of each channel, as csi_recon returns an image whose output is
 * the grid): the mean over p's cells of s (exp(clip(u, 0, umax)) - 1). */
double csi_peak_range_pixel(const csi_grid *g, const float *fine, uint32_t c, size_t p, double s,
                            double umax);

#endif
