/* A volume's frames when its samples are noisy: the last step of Alg. 2's frames (not of its
 * blurred image) when the samples come with their variances (csi_samples.variance: a path
 * tracer's samples, csi-mitsuba's; issue 12, docs/bench/animation.md session 32).
 *
 * Why. The solve fits the samples: at each sampled cell its frames keep most of that sample's
 * Monte Carlo noise, and the rest spreads to the cells around (measured on Mitsuba's animations
 * at one path per sample: 55-73% of each sample's noise at its own cell). The blurred image has
 * its own per-pixel correction (motion_correct.c); the frames had nothing, and at one path per
 * sample they were 1.3-3 dB below a 3-D Gaussian's whose width was tuned against the truth.
 *
 * What, per channel, on the frames of a grid of one cell per pixel (csi's default grid for every
 * volume), all in double and in a fixed order (deterministic):
 * 1. each sampled cell takes the estimate a sample of known noise gives beside a prediction of
 *    unknown error (the Wiener / positive-part James-Stein weight, as peak_noise.h and the blend
 *    use): D, the mean of the cell's unsampled 8 neighbours in its frame (the cell's own value
 *    when all of them hold samples), and the mean ybar of the cell's m samples; the cell becomes
 *    D + k (ybar - D), k = v / (v + s^2 / m), where s^2 is the samples' noise variance (from
 *    csi_recon_options.sample_noise: the noise relative to the level, times the mean |sample|)
 *    and v = max(0, mean over the sampled cells of (ybar - D)^2 - s^2 / m) the prediction's own
 *    error. Noisy samples (one path each) give k near 0, the neighbours' value; precise ones k
 *    near 1, their own;
 * 2. then the frames are smoothed by a Gaussian along t (sigma_t) on the path of the basis's
 *    velocity (bilinear between cells: a pan's content is followed, not blurred; a still basis's
 *    path is the pixel), then along x and y (sigma_xy), each cut at the volume's sides (the
 *    weights inside renormalised), one width for every channel, chosen from
 *    CSI_FRAMES_DENOISE_WIDTHS by two folds: the samples split in two by their cell, each half
 *    solved alone (the caller's solve) as one channel, the mean of the samples' channels, its
 *    frames taken through step 1 and smoothed by each width predict the other half's samples'
 *    means; the width of the least squared error over both folds (one, from
 *    CSI_FRAMES_DENOISE_ONE_FOLD samples on) wins (no smoothing among them). A fold's frames
 *    have never seen the samples they predict: the frames of the whole solve, even with a sample's own cell left
 *    out, carry its noise and its value into the cells around it, and chose less smoothing than
 *    the truth where the noise is large and more where it is small (measured). A fold has half
 *    the samples, so its frames want a little more smoothing than the whole's: below
 *    CSI_FRAMES_DENOISE_NOISE_MIN, where the frames hardly need any, that bias lost more than
 *    the step gained, and nothing is done.
 * The blurred image is not touched. Grids of several cells per pixel keep their frames as the
 * fit gave them (a frame pixel there is the mean of its cells, where one sample's noise is
 * already spread over them). */
#ifndef CSI_FRAMES_DENOISE_H
#define CSI_FRAMES_DENOISE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/reconstruct.h"
#include "csi/samples.h"
#include "csi/status.h"

/* The widths step 2 chooses from: none, and sigma_xy 0.5, 0.75, 1, 1.5 cells x sigma_t 0,
 * 0.5, 1, 1.5 frames. A fold's errors are taken at most at about 2^14 of the other fold's
 * samples (every k-th in cell order). */
#define CSI_FRAMES_DENOISE_WIDTHS 17

/* From this many samples on, one fold's errors choose the width (the first fold solved, the
 * second predicted: tens of thousands of squared errors per width), at half the cost. On Mitsuba's
 * 64 x 64 x 16 animations, with one to three thousand samples a fold, one fold chose what both
 * chose in 18 of 24 cases and a neighbouring width in the others. */
#define CSI_FRAMES_DENOISE_ONE_FOLD ((size_t)1 << 16)

/* The samples' noise relative to their level (csi_recon_options.sample_noise, its largest
 * channel) below which the step does nothing: at a tenth of the level the folds' choice lost up
 * to 0.6 dB on the procedural volumes, at a fifth it gained (docs/bench/animation.md, session 32). */
#define CSI_FRAMES_DENOISE_NOISE_MIN 0.2

/* A fold's solve stops at twice the steps the whole's solve took (its largest channel's), at
 * least CSI_FRAMES_FOLD_MIN_ITER, at most the whole's cap: with half the samples a solve can
 * stall where the whole's did not (one path per sample at 30% of the cells: 2000 steps, the cap,
 * where the whole took 160-180), and frames it would reach by then choose no better width. */
#define CSI_FRAMES_FOLD_MIN_ITER 20
/* The options a fold solves with (out): the whole's (opt, as given) for its frames alone (no
 * frames' step and no image step of its own), its steps capped as above, and where opt leaves
 * the transform along t to auto, the one the whole's solve took (whole): the folds' frames
 * choose the smoothing of the whole's frames, so they share its kind of basis; half the samples
 * can fall on the other side of the still basis's rule (motion.c), and on a held-out animation
 * whose ends differ near it the folds' own choice lost 0.7-0.9 dB per frame (docs/bench/
 * animation.md, session 34). The velocity each fold finds for itself (the whole's given cost a
 * camera slide 12% of its image MSE, session 34). */
void csi_frames_fold_options(const csi_recon_options *opt, const csi_recon_result *whole, csi_recon_options *out);

/* The blurred image averaged with the mean over t of the denoised frames (image_frames): two
 * estimates of each pixel's mean over the shutter, one from the fit and the pixel's own samples
 * (the control variate, motion_correct.c), one from the smoothed neighbourhood, whose errors
 * are partly independent. The average's squared error is the mean of theirs less a quarter of
 * their squared difference (an identity): never above the worse one's, and below the better
 * one's wherever their squared difference exceeds twice the gap between their errors
 * (docs/bench/animation.md, session 33).
 * image: channels planes of np pixels; frames: nframes * channels planes (frame-major), summed
 * in t order in double (deterministic). */
void csi_frames_denoise_image(const float *frames, uint32_t nframes, uint32_t channels, size_t np, float *image);

/* Whether the step applies to samples of this per-channel relative noise. */
int csi_frames_denoise_noisy(const double noise[4], uint32_t channels);

/* A fold's solve: the frames of the volume from the caller's samples index[0 .. count) alone
 * (indices into the arrays given to csi_frames_denoise, in the order of their cells), as one
 * channel: the samples' mean over their channels (csi_frames_fold_samples makes them), whose
 * noise relative to its level is `noise` (for a solve that is not given the variances); in
 * *frames (malloc'd, nframes planes of out_w * out_h; csi_frames_denoise frees it), and the
 * velocity its basis used. One channel because the folds choose one width for every channel:
 * the channels' mean chose the width the sum of every channel's errors chose on 100 of 120
 * Mitsuba animations, at about 0.6x the time of a volume's reconstruction (docs/bench/
 * animation.md, session 35). */
typedef csi_status (*csi_frames_fold_solve)(void *user, const size_t *index, size_t count, double noise,
                                            float **frames, double velocity[2]);
/* A fold's samples (csi_frames_fold_solve): for each index[j] (index NULL: j itself, j < count),
 * the mean of its channels in v[j] and, where variance is not NULL, in var[j] the variance of
 * that mean taken as if the channels' noise were fully correlated (one path carries every
 * channel): (mean of the standard deviations)^2. One channel: its own values and variances, bit
 * for bit. */
void csi_frames_fold_samples(const float *values, const float *variance, uint32_t channels, const size_t *index,
                             size_t count, float *v, float *var);
/* The noise relative to its level of the channels' mean of n samples, from each channel's
 * (noise[c], relative to its mean |value|): the mean of the channels' absolute noise over the
 * mean |channels' mean|, as csi_frames_fold_samples' variances (noise[0] for one channel). */
double csi_frames_fold_noise(const float *values, size_t n, uint32_t channels, const double noise[4]);

/* Steps 1 and 2 on frames (nframes * channels * out_w * out_h floats, frame-major then planar,
 * csi_recon_result.frames) of grid g, from the samples they were solved from (samples at frames
 * >= nframes, padding, are not used). noise: per channel, the samples' noise relative to their
 * mean |value|; velocity: the basis's (csi_recon_options.motion_vx, _vy: cells per frame; NULL
 * still); solve, user: a fold's solve. Nothing is done (chosen -1, -1) on a grid of several
 * cells per pixel or below CSI_FRAMES_DENOISE_NOISE_MIN; chosen (may be NULL) gets sigma_xy,
 * sigma_t. */
csi_status csi_frames_denoise(const csi_grid *g, uint32_t nframes, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const double noise[4], const double velocity[2], csi_frames_fold_solve solve,
                              void *user, float *frames, double chosen[2]);

#endif
