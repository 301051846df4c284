/* The corrected image of a volume moved towards each pixel's own sample mean, where noisy samples
 * say the mean is the better of the two (csi_recon_motion_toward_mean, internal.h; measured in
 * docs/bench/animation.md, session 41).
 *
 * After the correction (motion_correct.c) a pixel has two estimates of its mean over its cells:
 * c, the fit's box integral corrected by its residuals, and m, the mean of its own samples,
 * unbiased over where its samples fell. With noisy samples (each a Monte Carlo estimate) c
 * carries the fit's own error where the picture is still: a sparse fit of a few noisy samples
 * per pixel puts part of their noise into changes over t that are not there, and its box
 * integral and its values at the samples then disagree by that part (a path-traced still room
 * behind a sliding crate: csi 1.2x stratified's image MSE at 4 spp, 2x the mean of its own
 * samples on the still pixels). m's error there is only the samples' noise over n_p. Where
 * something moves through the pixel m sees it at the few times it was sampled. The two are
 * combined as the blend combines an image's fit with its means (blend.c), Stein's
 * positive-part shrinkage of m towards c:
 *
 *     out = c + beta (m - c),   beta = B^2 / (B^2 + V),
 *
 *   V   the variance of m: s^2 / n_p (1 - n_p / cells), s^2 the largest of the pixel's own
 *       sample variance, the one pooled over its 3 x 3 pixels (their sums of squared deviations
 *       over their n - 1; two samples give one degree of freedom) and the fit's: what the fit
 *       says the pixel's samples spread by, CSI_TOWARD_MEAN_FIT_VAR times the variance over t
 *       of the fitted volume's box mean over the pixel, but no more than the largest own sample
 *       variance among the 3 x 3 pixels. The fit's term is what keeps a pixel a mover crossed
 *       on c: where the samples happened to miss the mover, or hit it more often than it was
 *       there, their own spread says nothing of it (a disc over 2 of 16 frames, a pixel sampled
 *       at 8: their hits are 0 to 2, m off by up to half the disc's contrast), and the
 *       neighbours' samples that did hit it bound how much the mover can be. The factor is
 *       above 1 because such hit counts have heavier tails than a variance says, and the fit's
 *       change over t is a smoothed one. The bound is what leaves a still pixel to its mean
 *       where the fit is poor: a texture it cannot represent makes the fit change over t
 *       where nothing does (and c off by that), while the samples around spread by their
 *       noise alone.
 *   B^2 c's squared error: the median over the 3 x 3 pixels of two samples or more of
 *       (m - c)^2 - V, clipped at 0. One pixel's (m - c)^2 is as noisy as V, and a mean over
 *       the window let one unlucky pixel's m (a mover hit at three of four samples) move its
 *       neighbours towards theirs.
 *
 * Only pixels of two samples or more move (one sample has no variance of its own), and only
 * where their 3 x 3 pixels' samples give CSI_TOWARD_MEAN_MIN_DOF degrees of freedom (a variance
 * from 8 is below a third of the true one one time in twenty, chi-square; from the one of two
 * samples, one time in four below a tenth, and such a pixel went to its mean: Mitsuba's
 * camera pan at one path a sample, 3-10% of the cells, lost 6-7% of its image MSE without the
 * bound). One whose every cell is sampled has V = 0 and takes m. m and c both lie in the pixel's range
 * (motion_correct.c's bound holds the pixel's own samples), so out does too, and non-negative
 * samples keep a non-negative image. Exact samples (CSI_SAMPLES_EXACT) skip this step: their
 * correction is already whole (k = 1), and their spread over t is all motion. All in double, in
 * pixel order (deterministic). */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The fitted volume's variance over t counts this many times in m's (see above). */
#define CSI_TOWARD_MEAN_FIT_VAR 4.0
/* The fewest degrees of freedom (sum of n - 1) over a pixel's 3 x 3 pixels for it to move. */
#define CSI_TOWARD_MEAN_MIN_DOF 8.0

/* The median of m values (1 <= m <= 9): the middle one of a sort, or the mean of the two there. */
static double median_of(double *w, int m)
{
    for (int a = 1; a < m; a++)
        for (int b = a; b > 0 && w[b - 1] > w[b]; b--) {
            const double t = w[b];
            w[b] = w[b - 1];
            w[b - 1] = t;
        }
    return m % 2 ? w[m / 2] : 0.5 * (w[m / 2 - 1] + w[m / 2]);
}

csi_status csi_recon_motion_toward_mean(const csi_grid *g, const csi_px_values *px, const float *fit_var,
                                        float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const double cells = (double)(g->w / g->out_w) * (g->h / g->out_h) * g->t;
    double *own = malloc((np ? np : 1) * sizeof *own), *var = malloc((np ? np : 1) * sizeof *var),
           *err = malloc((np ? np : 1) * sizeof *err);
    if (!own || !var || !err) {
        free(own);
        free(var);
        free(err);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the pixels' means (%zu pixels)", np);
    }
    for (size_t p = 0; p < np; p++)
        own[p] = px[p].n >= 2 ? px[p].ss / (px[p].n - 1.0) : -INFINITY;
    /* V and (m - c)^2 - V of every pixel that may move; NaN for the others */
    for (size_t p = 0; p < np; p++) {
        var[p] = err[p] = NAN;
        if (px[p].n < 2)
            continue;
        const size_t x = p % ow, y = p / ow;
        double ss = 0, dof = 0, most = -INFINITY;
        for (size_t j = y ? y - 1 : 0; j <= y + 1 && j < oh; j++)
            for (size_t i = x ? x - 1 : 0; i <= x + 1 && i < ow; i++) {
                const csi_px_values *q = &px[j * ow + i];
                ss += q->ss;
                dof += q->n ? q->n - 1.0 : 0.0;
                most = fmax(most, own[j * ow + i]);
            }
        if (dof < CSI_TOWARD_MEAN_MIN_DOF)
            continue;
        const double s2 = fmax(fmax(own[p], ss / dof), fmin(CSI_TOWARD_MEAN_FIT_VAR * fit_var[p], most));
        var[p] = s2 / px[p].n * fmax(1.0 - px[p].n / cells, 0.0);
        const double dm = px[p].mean - (double)plane[p];
        err[p] = dm * dm - var[p];
    }
    /* every err first; each pixel's out then replaces its var, which no other pixel reads */
    for (size_t p = 0; p < np; p++) {
        if (isnan(var[p]))
            continue;
        const size_t x = p % ow, y = p / ow;
        double w[9];
        int m = 0;
        for (size_t j = y ? y - 1 : 0; j <= y + 1 && j < oh; j++)
            for (size_t i = x ? x - 1 : 0; i <= x + 1 && i < ow; i++)
                if (!isnan(err[j * ow + i]))
                    w[m++] = err[j * ow + i];
        const double b2 = fmax(median_of(w, m), 0.0), v = var[p];
        const double beta = b2 + v > 0 ? b2 / (b2 + v) : 0.0;
        var[p] = (double)plane[p] + beta * (px[p].mean - (double)plane[p]);
    }
    for (size_t p = 0; p < np; p++)
        if (!isnan(var[p]))
            plane[p] = (float)var[p];
    free(own);
    free(var);
    free(err);
    return CSI_OK;
}
