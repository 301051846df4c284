/* A per-region choice between a reconstruction and the per-pixel mean of the same samples, made by
 * two-fold cross-validation against held-out pixel means (issue 9: never worse than the mean,
 * decided from the samples alone).
 *
 * The estimate. Split each pixel's samples into two folds A and B. The mean of B's samples in a
 * pixel, m_B, is an unbiased estimate of the pixel's integral I whose error is independent of
 * everything computed from A alone (independent positions and noise). So for any estimate e_A made
 * from A, E[(e_A - m_B)^2] = E[(e_A - I)^2] + Var(m_B), and the difference
 *
 *     D = (c_A - m_B)^2 - (m_A - m_B)^2
 *
 * (c_A the reconstruction from fold A, m_A the pixel's mean of A) has expectation
 * E[(c_A - I)^2] - E[(m_A - I)^2]: the error of the reconstruction in the pixel's integral minus
 * the mean's, with nothing to estimate about the noise (it cancels). This is cross-validation of
 * the pixel integral, not of point predictions (Stone 1974; Hastie, Tibshirani & Friedman, The
 * Elements of Statistical Learning, 2nd ed. 2009, Sec. 7.10). D summed over both directions
 * (A -> B and B -> A), the channels and the pixels of a region is unbiased for how much the
 * reconstruction on half the samples loses (> 0) or gains (< 0) against the mean of half the
 * samples there. The sum is made twice: of D (the squared error) and of D / (m^2 + 0.01), m the
 * pixel's mean of all its samples (the relative error of issue 9's relMSE, where a dark pixel's
 * error weighs as much as a bright one's).
 *
 * The decision. Unbiased is not enough: next to an HDR highlight one held-out mean far from its
 * pixel's integral (a rare bright path) moves D by more than the whole region's real difference.
 * A region is taken to lose only when each of the two sums S is above z = CSI_CV_Z times the root
 * of the sum of its pixels' squared D (each pixel's D over its channels and both directions):
 * S / sqrt(sum D_p^2) is at most sqrt(k) when k pixels carry the sum, so with z = 1.5 one or two
 * pixels never decide a region, however large their D; and for pixels whose D are independent
 * and symmetric about 0 (the reconstruction no worse than the mean) it exceeds z with
 * probability at most exp(-z^2 / 2) (Hoeffding's inequality given |D_p|: Efron, Student's t-test
 * under symmetry conditions, JASA 1969). A pixel takes its full mean when its region of
 * CSI_CV_REGION x CSI_CV_REGION pixels, or of twice that side, loses (a loss along an edge shows
 * at one scale or the other); the others keep the full reconstruction.
 *
 * The folds. A pixel with n >= 2 samples is cut into k x k equal squares, k = ceil(sqrt(n)), and a
 * sample goes to the fold of its square's parity (x + y). On stratified positions of 2 x 2 or
 * 4 x 4 strata this is the checkerboard split of the strata: each fold's mean is then unbiased
 * for any image that is a sum of a function of x and one of y over the pixel (an edge along an
 * axis), which a split into rows or columns of strata is not. A pixel with one sample has no
 * held-out pair and adds nothing: where no pixel of a region has two, the region keeps the
 * reconstruction (every pixel at 1 spp on stratified positions). A reconstruction from fewer
 * than 2 samples per pixel on average is left as it is (csi_recon_cv_select): each fold would
 * hold under one sample per pixel. A tiled reconstruction makes the choice in each tile's window
 * (host/integrate/tiled.c), with the whole image's regions.
 *
 * The channels. For samples of several channels the folds reconstruct, by default, the mean of
 * the channels (--cv-channels mean): one solve per fold instead of one per channel and fold, and
 * D is that mean's. A region that loses takes the mean of its samples in every channel. A loss
 * only in the difference of channels (a colour error the grey mean does not see) is missed; on
 * Mitsuba's dumps the MSE stayed within 0.2% of the folds per channel's in 227 cells of 228, and
 * the other lost 5.7% by one region near the threshold (docs/bench/mitsuba.md, session 19). */
#ifndef CSI_CV_SELECT_H
#define CSI_CV_SELECT_H

#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h"

/* The side, in output pixels, of the smaller square regions the choice is made for
 * (docs/bench/mitsuba.md measures sides 1 to 128 and thresholds 0 to 2). */
#define CSI_CV_REGION 8
/* The folds' model grid. The folds are the choice's instrument, not its output: each fold's
 * reconstruction only has to lose where the whole's would. So each is made with the model grid's
 * smallest Gaussian width at most this (in model cells; csi/model_grid.h): at 4-16 spp on csi's
 * grids the band-limited model one level coarser than the image's exact one, about a third of its
 * cost. On Mitsuba's dumps it makes the same choices as folds on the image's own grid, and a grid
 * coarser again does not (docs/bench/mitsuba.md, session 16). */
#define CSI_CV_FOLD_SIGMA_MIN 0.75
/* The folds' stop: SpaRSA's objective stop (the image's --tol, 3e-3 by default) at least this
 * loose. For the same reason as their grid: where the image's solve ends decides its last
 * percent, but what decides the choice is a region's loss against held-out pixel means far
 * noisier than that. On Mitsuba's dumps the choices are nearly those of folds at the image's
 * stop (MSE within 1.2% on 228 cells, the same cells above the mean but one that came under),
 * for about half the folds' steps (docs/bench/mitsuba.md, session 18). */
#define CSI_CV_FOLD_TOL 2e-2
/* The threshold of the self-normalised sums (above). */
#define CSI_CV_Z 1.5
/* The floor of the relative error's denominator, m^2 + CSI_CV_REL_FLOOR: issue 9's relMSE. */
#define CSI_CV_REL_FLOOR 0.01

/* The fold (0 or 1) of every sample (rule above) into fold[n]; *pairs (may be NULL): the pixels
 * holding samples of both folds. grid.t must be 1. */
csi_status csi_cv_folds(const csi_grid *g, const csi_sample_pos *pos, size_t n, uint8_t *fold,
                        size_t *pairs);

/* The choice. values: sample-major, `channels` per sample; cA, cB: the reconstructions from fold
 * 0's and fold 1's samples alone, planar (channel c's pixel p at c * out_w * out_h + p); image:
 * the reconstruction from all samples, planar, overwritten with each pixel's mean of its samples
 * (computed in double) where a region of `region` x `region` pixels or of twice that side loses
 * (above); a pixel without a sample keeps the reconstruction. *switched (may be NULL): the pixels
 * that took their mean. */
csi_status csi_cv_choose(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                         const float *values, size_t n, const uint8_t *fold, const float *cA,
                         const float *cB, uint32_t region, float *image, size_t *switched);

/* The same choice made on other values than the image's: the folds' reconstructions cA, cB hold
 * fold_channels channels of fold_values (sample-major, as values), e.g. the mean of the image's
 * channels; a pixel that loses takes the mean of its samples of `values` in all `channels` of the
 * image. csi_cv_choose is this with the folds' values the image's own. */
csi_status csi_cv_choose_on(const csi_grid *g, const csi_sample_pos *pos, size_t n, const uint8_t *fold,
                            uint32_t fold_channels, const float *fold_values, const float *cA,
                            const float *cB, uint32_t region, uint32_t channels, const float *values,
                            float *image, size_t *switched);

#endif
