/* An HDR step's pixels given the coverage their window's samples allow (csi/step_coverage.h), on
 * samples of shapes whose pixel values are known: a bright region of (100, 50, 25) on a dark one
 * of (1, 1, 1), 32 x 32 pixels on an 8x grid, 4 or 16 samples per pixel (one random cell in each
 * of the pixel's 2 x 2 or 4 x 4 strata, or as many distinct random cells), every sample the value at its cell's centre with
 * variance 0 (an emitter seen directly: each of a sample's paths reads the same). The reference is
 * each pixel's box coverage c by 256 x 256 points per pixel (an error below 1/256 of the pixel's
 * rim length, 2e-3 here), its value c B + (1 - c) D; the input image is the per-pixel mean, which
 * the settling leaves at such pixels.
 *
 *   1. A straight rim at 23 degrees, a small disc (radius 1.6 pixels: a lamp, the rim curving
 *      across the windows: the near window's conic), a larger one (radius 6) and an axis-aligned
 *      rectangle (a light panel: at its corners no line divides the wide window), each at 3
 *      seeds, both position sets and 4 and 16 spp: the summed squared error of the output against
 *      the reference is at most the mean's (the rule's promise where its gates hold), and below it
 *      for the straight rim with each position set (some pixels move, or the test says nothing;
 *      one per stratum too: the wide window's line needs no more of the pixel's own samples); a
 *      pixel whose own samples are all dark may only brighten (x >= its mean per channel), one
 *      whose own samples are all bright only dim, and over the pixels of one class so moved the
 *      error falls, for each shape where any move (some do on the straight rim, and on the
 *      rectangle at 4 spp: a rim's pixels whose samples all fell on one side of it); a moved
 *      pixel's value lies between the levels, D <= x <= B per channel (it is c B + (1 - c) D for
 *      a coverage c in [0, 1], to float rounding).
 *   2. The same straight rim whose bright samples have a standard deviation of 0.3 times their
 *      value (paths that only sometimes reach the emitter): nothing moves (bit for bit).
 *   3. Not two levels: the bright side 0.2 and 2 times B in alternate columns of pixels (10:1 among
 *      the bright samples of any window, beyond the rule's 8:1): nothing moves.
 *   4. One cell per pixel (every sample its pixel's exact value): nothing moves.
 *   5. The rows in bands on a pool of 2 threads: the same bits as on the calling thread.
 *   6. A strip light under 3 pixels tall, slightly slanted (every 5 x 5 window on its rim holds both
 *      edges, so no line divides it; the convex region's band takes it, csi/convex_band.h), both
 *      position sets, 3 seeds: at 4 and 16 spp the error at most half the mean's (issue 9's target
 *      at 4 spp, here on noise-free samples of the shape the band is for; without the band 0.64x at
 *      4 spp). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/row_pool.h"
#include "csi/step_coverage.h"
#include "testlib.h"

enum { OW = 32, F = 8, SPP_MAX = 16, NP = OW * OW, N_MAX = NP * SPP_MAX, SUPER = 256 };

/* Samples per pixel of the case at hand (a square: 4 or 16) and their count. */
static int spp = 4;
static size_t n_samples(void)
{
    return (size_t)NP * spp;
}

static const double BRIGHT[3] = {100, 50, 25}, DARK[3] = {1, 1, 1};

typedef enum { RIM, SMALL_DISC, LARGE_DISC, RECT, STRIP } shape;

/* Is the image point (x, y), in pixels, on the bright side? */
static int bright_at(shape s, double x, double y)
{
    switch (s) {
    case RIM: {
        const double a = 23.0 * 3.14159265358979 / 180.0;
        return x * sin(a) - y * cos(a) - 4.0 > 0; /* a corner: a tenth of the image */
    }
    case SMALL_DISC:
        return (x - 16.3) * (x - 16.3) + (y - 15.7) * (y - 15.7) < 1.6 * 1.6;
    case RECT:
        return x > 9.3 && x < 22.6 && y > 10.4 && y < 19.7;
    case STRIP: /* a strip light under 3 pixels tall: every 5 x 5 window on its rim holds both edges */
        return x > 6.3 && x < 25.4 && y > 14.2 + 0.05 * x && y < 16.9 + 0.05 * x;
    default:
        return (x - 15.6) * (x - 15.6) + (y - 16.2) * (y - 16.2) < 6.0 * 6.0;
    }
}

/* Each pixel's box coverage by SUPER x SUPER points. */
static void coverage(shape s, double *cov)
{
    for (int p = 0; p < NP; p++) {
        long k = 0;
        for (int j = 0; j < SUPER; j++)
            for (int i = 0; i < SUPER; i++)
                k += bright_at(s, p % OW + (i + 0.5) / SUPER, p / OW + (j + 0.5) / SUPER);
        cov[p] = (double)k / (SUPER * SUPER);
    }
}

/* The samples: spp per pixel, stratified (one random cell in each of the pixel's sqrt(spp) x
 * sqrt(spp) boxes) or spp distinct random cells; value B or D at the cell's centre (B times 0.2 or 2 in alternate columns when
 * uneven), variance var_rel^2 times the bright value squared on the bright side, 0 elsewhere. */
static void make(shape s, int stratified, uint64_t seed, int uneven, double var_rel, csi_sample_pos *pos,
                 float *val, float *var)
{
    test_rng r;
    test_rng_seed(&r, seed);
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        int used[F * F] = {0};
        const int side = spp == 16 ? 4 : 2, box = F / side;
        for (int k = 0; k < spp; k++) {
            int cx, cy;
            do {
                if (stratified) {
                    cx = (k % side) * box + (int)(test_rng_uniform(&r) * box);
                    cy = (k / side) * box + (int)(test_rng_uniform(&r) * box);
                } else {
                    cx = (int)(test_rng_uniform(&r) * F), cy = (int)(test_rng_uniform(&r) * F);
                }
            } while (used[cy * F + cx]);
            used[cy * F + cx] = 1;
            const uint32_t gx = (uint32_t)(p % OW * F + cx), gy = (uint32_t)(p / OW * F + cy);
            pos[n] = (csi_sample_pos){gx, gy, 0};
            const double x = (gx + 0.5) / F, y = (gy + 0.5) / F;
            const int b = bright_at(s, x, y);
            const double scale = uneven && b ? (p % OW % 2 ? 2.0 : 0.2) : 1.0;
            for (int c = 0; c < 3; c++) {
                const double v = b ? BRIGHT[c] * scale : DARK[c];
                val[n * 3 + c] = (float)v;
                var[n * 3 + c] = b ? (float)(var_rel * var_rel * v * v) : 0.0f;
            }
            n++;
        }
    }
}

/* The per-pixel mean (planar), and whether each pixel's own samples are all of one class: 1 all
 * dark, 2 all bright, else 0. */
static void pixel_means(const csi_sample_pos *pos, const float *val, float *img, int *one_class)
{
    double sum[3 * NP] = {0};
    int nb[NP] = {0}, cnt[NP] = {0};
    for (size_t i = 0; i < n_samples(); i++) {
        const int p = (int)(pos[i].y / F * OW + pos[i].x / F);
        for (int c = 0; c < 3; c++)
            sum[c * NP + p] += val[i * 3 + c];
        nb[p] += val[i * 3] > 10.0f, cnt[p]++;
    }
    for (int p = 0; p < NP; p++) {
        for (int c = 0; c < 3; c++)
            img[c * NP + p] = (float)(sum[c * NP + p] / cnt[p]);
        one_class[p] = nb[p] == 0 ? 1 : nb[p] == cnt[p] ? 2 : 0;
    }
}

/* Summed over the pixels, or only those where only[p] (only: NULL for all). */
static double squared_error(const float *img, const double *cov, const int *only)
{
    double e = 0;
    for (int p = 0; p < NP; p++)
        for (int c = 0; only && !only[p] ? 0 : c < 3; c++) {
            const double d = img[c * NP + p] - (cov[p] * BRIGHT[c] + (1 - cov[p]) * DARK[c]);
            e += d * d;
        }
    return e;
}

int main(void)
{
    static csi_sample_pos pos[N_MAX];
    static float val[N_MAX * 3], var[N_MAX * 3], mean[3 * NP], out[3 * NP], out2[3 * NP];
    static double cov[NP];
    static int one_class[NP];
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    csi_row_pool *pool = csi_row_pool_new(2);
    CHECK(pool != NULL, "no row pool");

    /* 1. the rim, two discs and a rectangle, both position sets, 3 seeds, 4 and 16 spp */
    static const char *names[] = {"straight rim", "small disc", "large disc", "rectangle", "strip"};
    for (spp = 4; spp <= 16; spp *= 4)
    for (int s = RIM; s <= STRIP; s++) {
        coverage((shape)s, cov);
        double e_mean = 0, e_out = 0, e_mean_set[2] = {0, 0}, e_out_set[2] = {0, 0};
        size_t moved_all = 0, moved_set[2] = {0, 0}, one_moved_all = 0;
        double e_one_mean = 0, e_one_out = 0;
        for (int strat = 0; strat < 2; strat++)
            for (uint64_t seed = 1; seed <= 3; seed++) {
                make((shape)s, strat, seed, 0, 0.0, pos, val, var);
                pixel_means(pos, val, mean, one_class);
                memcpy(out, mean, sizeof out);
                size_t moved = 0;
                CHECK_OK(csi_step_coverage(&g, 3, pos, val, var, n_samples(), NULL, out, &moved));
                moved_all += moved, moved_set[strat] += moved;
                e_mean_set[strat] += squared_error(mean, cov, NULL), e_out_set[strat] += squared_error(out, cov, NULL);
                e_mean += squared_error(mean, cov, NULL), e_out += squared_error(out, cov, NULL);
                int away = 1, between = 1;
                static int one_moved[NP];
                for (int p = 0; p < NP; p++) {
                    one_moved[p] = one_class[p] && out[p] != mean[p];
                    one_moved_all += one_moved[p];
                    for (int c = 0; c < 3; c++) {
                        const float x = out[c * NP + p];
                        if ((one_class[p] == 1 && x < mean[c * NP + p]) || (one_class[p] == 2 && x > mean[c * NP + p]))
                            away = 0;
                        if (x != mean[c * NP + p] &&
                            !(x >= DARK[c] * (1 - 1e-6) && x <= BRIGHT[c] * (1 + 1e-6)))
                            between = 0;
                    }
                }
                e_one_mean += squared_error(mean, cov, one_moved), e_one_out += squared_error(out, cov, one_moved);
                CHECK(away, "%s, %s, seed %d: a pixel of dark samples darkened, or one of bright ones brightened", names[s],
                      strat ? "stratified" : "random", (int)seed);
                CHECK(between, "%s, %s, seed %d: a moved pixel outside its levels", names[s],
                      strat ? "stratified" : "random", (int)seed);
                /* 5. the pool: the same bits */
                memcpy(out2, mean, sizeof out2);
                CHECK_OK(csi_step_coverage(&g, 3, pos, val, var, n_samples(), pool, out2, NULL));
                CHECK(memcmp(out, out2, sizeof out) == 0, "%s, seed %d: the pool's bits differ", names[s], (int)seed);
            }
        printf("%s, %d spp: squared error %.4g (the mean's %.4g), %zu pixels moved; %zu of them of one class of "
               "samples: %.4g (the mean's %.4g)\n", names[s], spp, e_out, e_mean, moved_all, one_moved_all, e_one_out,
               e_one_mean);
        CHECK(e_out <= e_mean, "%s, %d spp: error %.6g above the mean's %.6g", names[s], spp, e_out, e_mean);
        CHECK(s != STRIP || e_out <= 0.5 * e_mean, "strip, %d spp: error %.6g above half the mean's %.6g", spp, e_out,
              e_mean);
        CHECK(one_moved_all ? e_one_out < e_one_mean : s != RIM && (s != RECT || spp != 4),
              "%s, %d spp: %zu pixels of one class of samples moved, error %.6g, the mean's %.6g", names[s], spp,
              one_moved_all, e_one_out, e_one_mean);
        for (int strat = 0; s == RIM && strat < 2; strat++)
            CHECK(moved_set[strat] > 0 && e_out_set[strat] < e_mean_set[strat],
                  "straight rim, %s, %d spp: %zu moved, error %.6g, the mean's %.6g", strat ? "stratified" : "random",
                  spp, moved_set[strat], e_out_set[strat], e_mean_set[strat]);
    }
    spp = 4;

    /* 2. noisy bright samples; 3. uneven bright samples; 4. one cell per pixel: nothing moves */
    for (int k = 0; k < 3; k++) {
        make(RIM, 1, 7, k == 1, k == 0 ? 0.3 : 0.0, pos, val, var);
        pixel_means(pos, val, mean, one_class);
        memcpy(out, mean, sizeof out);
        size_t moved = 1;
        csi_grid gk = g;
        if (k == 2) { /* the same samples on a grid of one cell per pixel: each pixel's first */
            gk = (csi_grid){OW * F, OW * F, 1, OW * F, OW * F};
        }
        if (k < 2) {
            CHECK_OK(csi_step_coverage(&gk, 3, pos, val, var, n_samples(), NULL, out, &moved));
            CHECK(moved == 0 && memcmp(out, mean, sizeof out) == 0, "%s: %zu pixels moved",
                  k == 0 ? "noisy bright samples" : "uneven bright side", moved);
        } else {
            static float big[3 * NP * F * F];
            memset(big, 0, sizeof big);
            CHECK_OK(csi_step_coverage(&gk, 3, pos, val, var, n_samples(), NULL, big, &moved));
            CHECK(moved == 0, "one cell per pixel: %zu pixels moved", moved);
        }
    }
    csi_row_pool_free(pool);
    return test_done();
}
