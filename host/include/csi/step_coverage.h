/* An HDR step's pixels given the coverage their neighbourhood's samples allow: a step of a
 * still image's reconstruction when the samples come with their variances (csi_samples.variance),
 * after the deciding pixels have settled on their means (csi/settle.h).
 *
 * Why. Where a pixel holds part of a bright region (an emitter's rim, a lamp's disc, a sun patch)
 * and part of a dark one, its value is about c B + (1 - c) D: the two levels and the bright side's
 * coverage c. With samples of many paths the levels are known well; the pixel's error is its
 * coverage's. The per-pixel mean estimates c by the share of its own samples that landed on the
 * bright side (k of n: at 4 spp a quarter of a pixel at a time), and at an HDR step that share is
 * the whole of its error: at 4 spp x 64 paths 92-99.9% of the mean's MSE sits in such pixels
 * (docs/bench/mitsuba.md, session 26). csi's fit cannot do better there (it rings at a 100:1
 * step), so the blend and the settling leave these pixels at their means. Yet the samples of the
 * pixel's neighbours say where the boundary runs: a region's rim crosses a 5 x 5 window of pixels
 * holding 100 samples at 4 spp, and the shape of a boundary that separates the window's bright
 * samples from its dark ones says which of the pixel's cells lie beyond its own samples of each
 * side, which its own four cannot.
 *
 * The rule, per pixel, in two windows: the wide one (the pixel and the pixels within 2 of it),
 * bounded by a line; where its samples are not a step as below or no line divides them (a lamp's
 * disc, a corner, a second light), the near one (the pixel and its 8 neighbours), bounded by a
 * line or a conic, with checks (below); where that does not move the pixel either, the wide
 * window once more with one side of the step taken as convex (last item). In a window whose
 * samples span an HDR step, on the
 * samples' channel mean L (a sample's noise: the square root of its channels' mean variance):
 *   - a step: the window's brightest sample at least CSI_STEP_RATIO times its darkest and
 *     CSI_STEP_IMAGE_RATIO times the image's mean sample; its samples classed bright above the
 *     geometric mean of the window's 10th and 90th percentiles; two levels, not a ramp: the
 *     darkest bright sample at least CSI_STEP_GAP times the brightest dark one, the brightest
 *     bright at most CSI_STEP_SPREAD times the darkest bright; every bright sample's noise at most
 *     CSI_STEP_NOISE of its value (a firefly or a glossy path says nothing of where a rim runs);
 *   - the boundary: a logistic regression of the classes on the samples' positions (a line; in the
 *     near window a conic where no line separates them: a disc's rim), which must separate the
 *     window's samples without error;
 *   - the band: the boundary's function f is positive at the bright samples and negative at the
 *     dark ones; of the pixel's cells, those where f is at least its value at the pixel's own least
 *     bright-looking bright sample are bright by every boundary of that shape through the gap,
 *     those where f is at most its value at the pixel's own most bright-looking dark sample are
 *     dark: coverages c_lo and c_hi. Only the pixel's own samples bound it (but for stratified
 *     samples in the wide window, next): a level line through a
 *     neighbour's sample, carried across the pixel by a boundary that does not curve as the rim
 *     does (a lamp's disc a few pixels wide), was measured to cut the pixel wrongly;
 *   - the coverage: the share of the pixel's cells on the bright side of the boundary (f > 0).
 *     In the wide window, taken as it is, except where the pixel's own samples lie one per box of
 *     a split of its cells (stratified positions: their own share of a straight rim is already
 *     close, where the boundary, somewhere in the gap between the classes, guesses a row of
 *     cells): there the pixel's own share k / n, moved only as far as the window's band allows
 *     (the band above, from all the window's samples). In the near window only when the pixel
 *     holds at least CSI_STEP_FIT_MIN samples of its own, not one per box, and a boundary of the
 *     same shape fitted to the neighbours' samples alone classes every one of the pixel's own
 *     right (the shape carries across the pixel: not a rectangle's corner); else the pixel's own
 *     share. A line through 100 samples places a rim well enough at any spp; a conic through them
 *     was measured to cut small flames wrongly, a boundary through 36 to lose to the pixel's own
 *     share below 8 samples (docs/bench/mitsuba.md, sessions 39 and 50);
 *   - that coverage clamped to [c_lo, c_hi]: where the result is the mean's share, the pixel keeps
 *     its value (a straight rim split exactly by stratified samples keeps the mean); where it is
 *     not, the pixel's value moves by the change from its share times the difference of its own
 *     bright and dark samples' means;
 *   - a pixel whose own samples are all of one class has no band of its own, and a level of the
 *     other class only from its neighbours. In the near window it is left alone (moved by conics
 *     as well, such pixels beside a corner brightened at a cost to their relMSE of up to 1573x
 *     the mean's: measured, session 50). In the wide window, where a line divides the samples of
 *     5 x 5 pixels, its share (0 or 1) is clamped to the window's band: a pixel of at least two
 *     dark samples only whose cells the window's bright samples reach along the line's normal
 *     brightens to c_win, the share of its cells where f is at least its value at the window's
 *     least bright-looking bright sample (a pixel of one dark sample keeps it: at 1 spp, where
 *     25 samples place the line loosely, brightening them cost dark pixels their relMSE, up to
 *     2.3x on a held-out scene: measured, session 51); one of bright samples only dims to c_win,
 *     the share of its cells where f exceeds its value at the window's most bright-looking dark
 *     one (a rim across a pixel's corner between its samples); by c_win - share times the
 *     difference of the bright and dark levels, the other class's level the mean of the window's
 *     samples of that class (docs/bench/mitsuba.md, session 51);
 *   - the convex side: where no line divides the wide window's samples, one side may still be a
 *     convex region on the other (an emitter's corner, a strip light a few pixels tall, a lamp's
 *     disc; or the dark side, beside a bright region's inner corner): its samples' convex hull
 *     holds none of the other side's. Then, whichever side that is alone, the cells every convex
 *     region through the samples puts on each side bound the coverage (csi/convex_band.h), and
 *     the pixel's share is clamped to them, as above (a pixel of one dark sample excepted), the
 *     levels its own or, for a class it lacks, the window's. Where both sides are convex a line
 *     divides them (the first rule's case); where neither, nothing is certain. Measured, session
 *     51: the benchmark's Cornell box at 4 spp x 64 paths, whose emitter is under 4 pixels tall.
 * Clamping moves an estimate towards an interval; when the interval holds the truth, the estimate
 * gets no farther from it. The gates keep the rule to windows where the boundary is well
 * determined: measured on Mitsuba's samples (docs/bench/mitsuba.md, sessions 38, 39 and 50).
 *
 * Nothing here makes a value negative: a moved value is clamped at 0. */
#ifndef CSI_STEP_COVERAGE_H
#define CSI_STEP_COVERAGE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/row_pool.h"
#include "csi/samples.h"
#include "csi/status.h"

/* The window's brightest sample over its darkest for an HDR step: empty_pixels.c's 8:1. */
#define CSI_STEP_RATIO 8.0
/* ... and over the image's mean sample (a step in a dim corner is not one that decides pixels). */
#define CSI_STEP_IMAGE_RATIO 4.0
/* The darkest bright sample over the brightest dark one: two levels, with a gap between. */
#define CSI_STEP_GAP 2.0
/* The brightest bright sample over the darkest bright one: one bright level, not a ramp. */
#define CSI_STEP_SPREAD 8.0
/* A bright sample's standard deviation over its value, at most. */
#define CSI_STEP_NOISE 0.25
/* The pixel's own samples from which the window's boundary may place its rim (below 8, a wrong
 * boundary rarely misclasses one of them, so the check that it holds across the pixel says
 * little: measured, docs/bench/mitsuba.md, session 39). */
#define CSI_STEP_FIT_MIN 8

/* The rule above on a planar image (channel c's pixel p at c * out_w * out_h + p), in place:
 * csi_step_coverage_delta with the samples' own mean, then csi_step_coverage_apply. values and
 * variance: sample-major, `channels` per sample; variance >= 0. grid.t must be 1. Bands of rows
 * run on pool (NULL: the calling thread), the same bits either way. *changed (may be NULL): the
 * pixels moved. */
csi_status csi_step_coverage(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                             const float *values, const float *variance, size_t n, csi_row_pool *pool,
                             float *image, size_t *changed);

/* What the rule adds to each pixel (planar, as the image; 0 where it does not move), from the
 * samples alone, with image_mean the whole image's mean sample (csi_step_coverage_mean over all of
 * them: a tile's window, csi/tiles.h, gives the whole image's so that its pixels move as the whole
 * image's do). *moved (may be NULL): the pixels it moves. */
csi_status csi_step_coverage_delta(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                   const float *values, const float *variance, size_t n, double image_mean,
                                   csi_row_pool *pool, float *delta, size_t *moved);
/* The mean over the samples of their channel mean, in sample order. */
double csi_step_coverage_mean(const float *values, size_t n, uint32_t channels);
/* image[i] = max(0, image[i] + delta[i]) where delta[i] is not 0, in double, rounded once. */
void csi_step_coverage_apply(float *image, const float *delta, size_t count);

#endif
