/* Gaussian averages of the samples as candidates of the cross-validated choice (csi/cv_smooth.h).
 *
 * A 48 x 48 image on a 4x grid, 4 samples a pixel, one per 2 x 2 stratum (the folds' checkerboard
 * split: two samples of each fold in every pixel). The incumbent is the per-pixel mean: the image
 * is each pixel's mean and the folds' predictions are each fold's means, as where the choice took
 * the mean.
 *   1. Flat and noisy: every sample 1 + Gaussian noise of sigma 0.5. Per pixel and direction the
 *      gain D = (m_A - m_B)^2 - (G_A - m_B)^2 has mean about 0.125 - 0.01 and standard deviation
 *      about 0.4, so a region's 64 pixels give S / sqrt(sum D^2) near 2.2 against the threshold
 *      1.5: each direction passes with probability about 0.76, a region about 0.6-0.75 of the
 *      time. So at least half the pixels must be smoothed. On those, the MSE against the truth (1)
 *      must be under 0.3x the mean's, which takes the choice of the width with the largest gain to
 *      pick wide ones on a flat field: simulated in numpy (2 million pixels, the estimate clipped
 *      to the pixel's m +- 2 se, se from its 4 samples with 3 degrees of freedom), a Gaussian of
 *      width 1 pixel or more (about 12 pixels' samples or more) gives at most 0.137x (0.066x for
 *      an exact one), the narrowest, 0.5 pixel (its own pixel 62% of the weight), 0.42x: above
 *      0.3x only if it were taken in most pixels.
 *   2. The bound, and no value made negative: a dark noisy field (0.05 + noise 0.05, clipped at
 *      0) with 4 HDR squares of 500 (3 x 3 pixels). Every pixel the step changes holds, in every
 *      channel, a value within 2 standard errors of its own samples' mean (computed here, in
 *      double, from the samples: se^2 = unbiased variance / n) or at 0 where that interval goes
 *      below it, up to float rounding; no value is negative; the squares' pixels, whose samples
 *      all agree (se = 0), keep their mean exactly.
 *   3. Deterministic: on the calling thread alone and on a pool of 3 threads, the same bits and
 *      count.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/cv_select.h"
#include "csi/cv_smooth.h"
#include "testlib.h"

#define OW 48
#define F 4
#define SPP 4

static double gauss(test_rng *r)
{
    double u = test_rng_uniform(r), v = test_rng_uniform(r);
    return sqrt(-2.0 * log(1.0 - u)) * cos(6.283185307179586 * v);
}

typedef struct {
    csi_grid g;
    size_t n;
    csi_sample_pos *pos;
    float *val;    /* one channel */
    uint8_t *fold;
    float *mean, *ma, *mb; /* the pixel's mean and each fold's */
} field;

/* Samples of truth(px, py) + noise * N(0, 1), clipped at 0 when clip, one per 2 x 2 stratum. */
static void make(field *f, double (*truth)(uint32_t, uint32_t), double noise, int clip, uint64_t seed)
{
    f->g = (csi_grid){OW * F, OW * F, 1, OW, OW};
    const size_t np = (size_t)OW * OW;
    f->n = np * SPP;
    f->pos = malloc(f->n * sizeof *f->pos);
    f->val = malloc(f->n * sizeof *f->val);
    f->fold = malloc(f->n);
    f->mean = malloc(np * sizeof *f->mean);
    f->ma = malloc(np * sizeof *f->ma);
    f->mb = malloc(np * sizeof *f->mb);
    test_rng r;
    test_rng_seed(&r, seed);
    for (size_t p = 0; p < np; p++) {
        const uint32_t px = (uint32_t)(p % OW), py = (uint32_t)(p / OW);
        for (uint32_t j = 0; j < SPP; j++) {
            const size_t i = p * SPP + j;
            f->pos[i].x = px * F + (j & 1) * 2 + (uint32_t)(test_rng_uniform(&r) * 2);
            f->pos[i].y = py * F + (j >> 1) * 2 + (uint32_t)(test_rng_uniform(&r) * 2);
            f->pos[i].t = 0;
            double v = truth(px, py) + noise * gauss(&r);
            f->val[i] = (float)(clip && v < 0 ? 0 : v);
        }
    }
    CHECK_OK(csi_cv_folds(&f->g, f->pos, f->n, f->fold, NULL));
    for (size_t p = 0; p < np; p++) {
        double s = 0, s2[2] = {0, 0};
        int c2[2] = {0, 0};
        for (uint32_t j = 0; j < SPP; j++) {
            const size_t i = p * SPP + j;
            s += f->val[i];
            s2[f->fold[i]] += f->val[i];
            c2[f->fold[i]]++;
        }
        f->mean[p] = (float)(s / SPP);
        f->ma[p] = (float)(s2[0] / c2[0]);
        f->mb[p] = (float)(s2[1] / c2[1]);
    }
}

static void field_free(field *f)
{
    free(f->pos);
    free(f->val);
    free(f->fold);
    free(f->mean);
    free(f->ma);
    free(f->mb);
}

static double flat(uint32_t px, uint32_t py)
{
    (void)px;
    (void)py;
    return 1.0;
}

static int in_square(uint32_t px, uint32_t py)
{
    return px % 24 >= 10 && px % 24 < 13 && py % 24 >= 10 && py % 24 < 13;
}

static double squares(uint32_t px, uint32_t py)
{
    return in_square(px, py) ? 500.0 : 0.05;
}

static void flat_noise(void)
{
    field f;
    make(&f, flat, 0.5, 0, 3);
    const size_t np = (size_t)OW * OW;
    float *img = malloc(np * sizeof *img), *img2 = malloc(np * sizeof *img2);
    memcpy(img, f.mean, np * sizeof *img);
    memcpy(img2, f.mean, np * sizeof *img2);
    size_t sm = 0, sm2 = 0;
    csi_row_pool *pool = csi_row_pool_new(3);
    CHECK_OK(csi_cv_smooth(NULL, &f.g, 0, 0, NULL, f.pos, f.n, f.fold, 1, f.val, f.ma, f.mb, 1, f.val, img, &sm));
    CHECK_OK(csi_cv_smooth(pool, &f.g, 0, 0, NULL, f.pos, f.n, f.fold, 1, f.val, f.ma, f.mb, 1, f.val, img2, &sm2));
    csi_row_pool_free(pool);
    double e0 = 0, e1 = 0;
    size_t changed = 0;
    for (size_t p = 0; p < np; p++)
        if (img[p] != f.mean[p]) {
            changed++;
            e0 += (f.mean[p] - 1.0) * (f.mean[p] - 1.0);
            e1 += (img[p] - 1.0) * (img[p] - 1.0);
        }
    CHECK(sm == changed && sm > np / 2, "flat noise: %zu of %zu pixels smoothed, %zu changed", sm, np, changed);
    CHECK(e1 < 0.3 * e0, "flat noise: MSE over the smoothed pixels %.3g, the mean's %.3g (ratio %.3f)", e1 / changed,
          e0 / changed, e1 / e0);
    printf("flat noise: %zu of %zu pixels smoothed, their MSE %.3fx the mean's\n", sm, np, e1 / e0);
    CHECK(sm == sm2 && !memcmp(img, img2, np * sizeof *img), "the calling thread alone and a pool of 3 threads differ");
    free(img);
    free(img2);
    field_free(&f);
}

static void bound(void)
{
    field f;
    make(&f, squares, 0.05, 1, 7);
    const size_t np = (size_t)OW * OW;
    float *img = malloc(np * sizeof *img);
    memcpy(img, f.mean, np * sizeof *img);
    size_t sm = 0;
    CHECK_OK(csi_cv_smooth(NULL, &f.g, 0, 0, NULL, f.pos, f.n, f.fold, 1, f.val, f.ma, f.mb, 1, f.val, img, &sm));
    size_t changed = 0, outside = 0, negative = 0, squares_moved = 0;
    for (size_t p = 0; p < np; p++) {
        double m = 0, d = 0;
        for (uint32_t j = 0; j < SPP; j++)
            m += f.val[p * SPP + j];
        m /= SPP;
        for (uint32_t j = 0; j < SPP; j++)
            d += (f.val[p * SPP + j] - m) * (f.val[p * SPP + j] - m);
        const double se = sqrt(d / (SPP - 1) / SPP), lo = fmax(m - 2 * se, 0), hi = m + 2 * se;
        const double tol = 1e-6 * (fabs(m) + 1e-3);
        negative += img[p] < 0;
        if (img[p] == f.mean[p])
            continue;
        changed++;
        outside += img[p] < lo - tol || img[p] > hi + tol;
        squares_moved += in_square((uint32_t)(p % OW), (uint32_t)(p / OW));
    }
    CHECK(sm > 0 && changed == sm, "squares: %zu smoothed, %zu changed", sm, changed);
    CHECK(outside == 0, "squares: %zu of %zu changed pixels outside m +- 2 se", outside, changed);
    CHECK(negative == 0, "squares: %zu negative values", negative);
    CHECK(squares_moved == 0, "squares: %zu pixels of the squares moved (their samples agree)", squares_moved);
    free(img);
    field_free(&f);
}

int main(void)
{
    flat_noise();
    bound();
    return test_done();
}
