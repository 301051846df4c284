/* The cross-validated choice between a reconstruction and the per-pixel mean (csi/cv_select.h).
 *
 *   1. Folds on csi_positions' stratified positions: at 4 spp (2 x 2 strata per pixel) and 16 spp
 *      (4 x 4) every sample's fold is the parity of its stratum (x + y), the stratum computed
 *      here from the pixel's block and the strata count; each pixel holds spp / 2 samples of
 *      each fold, so every pixel is a held-out pair. At 1 spp no pixel is.
 *   2. The choice on samples with a known truth: each pixel's integral I, 4 samples I + Gaussian
 *      noise (sigma 1), and "reconstructions" I + delta with delta 0 in two of the four 16 x 16
 *      blocks and 3 in the other two. Each fold's mean has variance 1/2, so a pixel's two
 *      directions have expectation 2 delta^2 - 1 (csi/cv_select.h): -1 and 17, with standard
 *      deviations 2.24 and 6.40 (a 10^6-draw simulation of the two terms in numpy). A delta-0
 *      region's sum is negative in expectation (-64 over 8 x 8 pixels, standard deviation 18)
 *      and is kept; a delta-3 one's 64 pixels give S / sqrt(sum D_p^2) near
 *      8 * 17 / sqrt(17^2 + 6.4^2) = 7.5, far above the threshold 1.5, and switch. A switched
 *      pixel holds exactly the double mean of its samples rounded to float (computed here); a
 *      kept one is untouched.
 *   2b. One pixel alone cannot switch a region: a reconstruction off by 100 in one pixel of an
 *      otherwise exact region is kept (S / sqrt(sum D_p^2) <= 1 for one pixel).
 *   3. One sample per pixel: no held-out pair, nothing switched even where the reconstruction is
 *      far off (the choice does not guess).
 *   4. The choice made on other values than the image's (csi_cv_choose_on, as for the folds on
 *      the mean of RGB channels): property 2's samples as the decision's values, an RGB image
 *      whose channels are other functions of the pixel, sampled with their own noise. The
 *      regions that switch are those of property 2 (the decision sees only its values), and a
 *      switched pixel holds in each channel exactly the double mean of that channel's samples.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/cv_select.h"
#include "testlib.h"

static double gauss(test_rng *r)
{
    double u = test_rng_uniform(r), v = test_rng_uniform(r);
    return sqrt(-2.0 * log(1.0 - u)) * cos(6.283185307179586 * v);
}

static void stratified_folds(uint32_t ow, uint32_t spp)
{
    const uint32_t F = csi_default_grid_factor(ow, ow, 1, spp);
    const csi_grid g = {ow * F, ow * F, 1, ow, ow};
    const csi_pos_opts po = {CSI_POS_STRATIFIED, spp, 0, 11};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    csi_pos_info info;
    CHECK_OK(csi_positions(&g, &po, &pos, &n, &info));
    if (!pos)
        return;
    uint8_t *fold = malloc(n);
    size_t pairs = 99;
    CHECK_OK(csi_cv_folds(&g, pos, n, fold, &pairs));
    const uint32_t s = (uint32_t)lround(sqrt((double)spp)); /* strata per side */
    const size_t np = (size_t)ow * ow;
    uint32_t *per = calloc(np * 2, sizeof *per);
    size_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        const uint32_t sx = pos[i].x % F / (F / s), sy = pos[i].y % F / (F / s);
        if (fold[i] != (sx + sy) % 2)
            bad++;
        per[((size_t)(pos[i].y / F) * ow + pos[i].x / F) * 2 + fold[i]]++;
    }
    size_t unbalanced = 0;
    for (size_t p = 0; p < np; p++)
        unbalanced += spp >= 2 ? per[p * 2] != spp / 2 || per[p * 2 + 1] != spp / 2 : 0;
    CHECK(bad == 0, "%u spp: %zu of %zu samples not in their stratum's fold", spp, bad, n);
    CHECK(unbalanced == 0, "%u spp: %zu pixels without spp / 2 samples in each fold", spp, unbalanced);
    CHECK(pairs == (spp >= 2 ? np : 0), "%u spp: %zu held-out pairs of %zu pixels", spp, pairs, np);
    free(per);
    free(fold);
    csi_free(pos);
}

/* Property 2 (spp = 4) and 3 (spp = 1) on a 32 x 32 image, 4x grid, 8 x 8 regions. */
static void choice(uint32_t spp)
{
    const uint32_t ow = 32, F = 4, R = CSI_CV_REGION;
    const csi_grid g = {ow * F, ow * F, 1, ow, ow};
    const size_t np = (size_t)ow * ow, n = np * spp;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *val = malloc(n * sizeof *val);
    float *img = malloc(np * sizeof *img), *a = malloc(np * sizeof *a), *b = malloc(np * sizeof *b);
    float *orig = malloc(np * sizeof *orig);
    double *mean = calloc(np, sizeof *mean);
    test_rng r;
    test_rng_seed(&r, 5);
    for (size_t p = 0; p < np; p++) {
        const uint32_t px = (uint32_t)(p % ow), py = (uint32_t)(p / ow);
        const double I = 2.0 + 8.0 * test_rng_uniform(&r);
        const bool off = ((px / (2 * R)) + (py / (2 * R))) % 2 == 1;
        img[p] = a[p] = b[p] = orig[p] = (float)(I + (off ? 3.0 : 0.0));
        for (uint32_t j = 0; j < spp; j++) {
            /* one sample per 2 x 2 stratum of the pixel's 4 x 4 cells (at 1 spp: anywhere) */
            const uint32_t sx = spp == 4 ? (j & 1) * 2 : 0, sy = spp == 4 ? (j >> 1) * 2 : 0;
            const uint32_t ex = spp == 4 ? 2 : 4;
            const size_t i = p * spp + j;
            pos[i].x = px * F + sx + (uint32_t)(test_rng_uniform(&r) * ex);
            pos[i].y = py * F + sy + (uint32_t)(test_rng_uniform(&r) * ex);
            pos[i].t = 0;
            val[i] = (float)(I + gauss(&r));
            mean[p] += val[i];
        }
        mean[p] /= spp;
    }
    uint8_t *fold = malloc(n);
    size_t pairs = 0, switched = 99;
    CHECK_OK(csi_cv_folds(&g, pos, n, fold, &pairs));
    CHECK_OK(csi_cv_choose(&g, 1, pos, val, n, fold, a, b, R, img, &switched));
    size_t wrong = 0, inexact = 0;
    for (size_t p = 0; p < np; p++) {
        const uint32_t px = (uint32_t)(p % ow), py = (uint32_t)(p / ow);
        const bool off = ((px / (2 * R)) + (py / (2 * R))) % 2 == 1 && spp >= 2;
        if (off ? img[p] != (float)mean[p] : img[p] != orig[p]) {
            if (off && img[p] != orig[p])
                inexact++;
            else
                wrong++;
        }
    }
    CHECK(wrong == 0 && inexact == 0, "%u spp: %zu pixels chose wrongly, %zu means not exact", spp, wrong, inexact);
    CHECK(switched == (spp >= 2 ? np / 2 : 0), "%u spp: %zu pixels switched", spp, switched);
    free(fold);
    free(pos);
    free(val);
    free(img);
    free(a);
    free(b);
    free(orig);
    free(mean);
}

/* Property 4 on property 2's layout, 4 spp. */
static void choice_on_other_values(void)
{
    const uint32_t ow = 32, F = 4, R = CSI_CV_REGION, C = 3;
    const csi_grid g = {ow * F, ow * F, 1, ow, ow};
    const size_t np = (size_t)ow * ow, n = np * 4;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *dv = malloc(n * sizeof *dv), *val = malloc(n * C * sizeof *val);
    float *a = malloc(np * sizeof *a), *img = malloc(np * C * sizeof *img), *orig = malloc(np * C * sizeof *orig);
    double *mean = calloc(np * C, sizeof *mean);
    test_rng r;
    test_rng_seed(&r, 9);
    for (size_t p = 0; p < np; p++) {
        const uint32_t px = (uint32_t)(p % ow), py = (uint32_t)(p / ow);
        const double I = 2.0 + 8.0 * test_rng_uniform(&r);
        const bool off = ((px / (2 * R)) + (py / (2 * R))) % 2 == 1;
        a[p] = (float)(I + (off ? 3.0 : 0.0));
        for (uint32_t c = 0; c < C; c++)
            img[c * np + p] = orig[c * np + p] = (float)(0.5 * c + (double)((px + 3 * py + c) % 11));
        for (uint32_t j = 0; j < 4; j++) {
            const size_t i = p * 4 + j;
            pos[i].x = px * F + (j & 1) * 2 + (uint32_t)(test_rng_uniform(&r) * 2);
            pos[i].y = py * F + (j >> 1) * 2 + (uint32_t)(test_rng_uniform(&r) * 2);
            pos[i].t = 0;
            dv[i] = (float)(I + gauss(&r));
            for (uint32_t c = 0; c < C; c++) {
                val[i * C + c] = (float)(orig[c * np + p] + 0.7 * gauss(&r));
                mean[p * C + c] += val[i * C + c];
            }
        }
        for (uint32_t c = 0; c < C; c++)
            mean[p * C + c] /= 4;
    }
    uint8_t *fold = malloc(n);
    size_t switched = 99;
    CHECK_OK(csi_cv_folds(&g, pos, n, fold, NULL));
    CHECK_OK(csi_cv_choose_on(&g, pos, n, fold, 1, dv, a, a, R, C, val, img, &switched));
    size_t wrong = 0;
    for (size_t p = 0; p < np; p++) {
        const uint32_t px = (uint32_t)(p % ow), py = (uint32_t)(p / ow);
        const bool off = ((px / (2 * R)) + (py / (2 * R))) % 2 == 1;
        for (uint32_t c = 0; c < C; c++)
            wrong += img[c * np + p] != (off ? (float)mean[p * C + c] : orig[c * np + p]);
    }
    CHECK(wrong == 0, "on other values: %zu pixel channels not as chosen", wrong);
    CHECK(switched == np / 2, "on other values: %zu pixels switched", switched);
    free(fold);
    free(pos);
    free(dv);
    free(val);
    free(a);
    free(img);
    free(orig);
    free(mean);
}

/* Property 2b: 4 samples per pixel without noise (the mean exact), the reconstruction exact but
 * in one pixel, off by 100 there. */
static void lone_pixel(void)
{
    const uint32_t ow = 16, F = 4;
    const csi_grid g = {ow * F, ow * F, 1, ow, ow};
    const size_t np = (size_t)ow * ow, n = np * 4;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *val = malloc(n * sizeof *val), *img = malloc(np * sizeof *img);
    uint8_t *fold = malloc(n);
    for (size_t p = 0; p < np; p++) {
        img[p] = 1.0f + (float)(p % 7);
        for (uint32_t j = 0; j < 4; j++) {
            const size_t i = p * 4 + j;
            pos[i] = (csi_sample_pos){(uint32_t)(p % ow) * F + (j & 1) * 2, (uint32_t)(p / ow) * F + (j >> 1) * 2, 0};
            val[i] = img[p];
        }
    }
    img[5 * ow + 5] += 100.0f;
    const float bad = img[5 * ow + 5];
    size_t switched = 99;
    CHECK_OK(csi_cv_folds(&g, pos, n, fold, NULL));
    CHECK_OK(csi_cv_choose(&g, 1, pos, val, n, fold, img, img, CSI_CV_REGION, img, &switched));
    CHECK(switched == 0 && img[5 * ow + 5] == bad, "one pixel switched %zu pixels", switched);
    free(pos);
    free(val);
    free(img);
    free(fold);
}

int main(void)
{
    stratified_folds(64, 1);
    stratified_folds(64, 4);
    stratified_folds(64, 16);
    choice(4);
    choice(1);
    choice_on_other_values();
    lone_pixel();
    /* a volume is refused */
    const csi_grid v = {8, 8, 2, 2, 2};
    csi_sample_pos p0 = {0, 0, 0};
    uint8_t f;
    CHECK(csi_cv_folds(&v, &p0, 1, &f, NULL) == CSI_ERR_ARG, "a volume's folds");
    return test_done();
}
