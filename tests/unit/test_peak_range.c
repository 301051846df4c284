/* Isolated peaks by the log fit (csi/peak_range.h).
 *
 *   1. Which pixels are peak pixels, on hand-made samples whose outcome the rule states exactly
 *      (16 x 16 pixels on a 4x grid, four samples per pixel, every sample 1 but in these):
 *      - (5, 5) holds 1, 1, 1, 20: 20 >= 4 x (1 + e), every neighbour's sample 1: a peak pixel;
 *      - (10, 10) holds 1, 1, 1, 20 next to (11, 10), which holds 1, 1, 1, 45: (11, 10) is one
 *        (45 >= 2 x (20 + e)), (10, 10) is not (a brighter sample beside it: what an HDR edge
 *        looks like);
 *      - (7, 2) holds 1, 1, 1, 20 next to (8, 2), which holds 1, 1, 1, 10.5: neither (20 < 2 x
 *        (10.5 + e): a neighbour at half the peak holds part of the same feature; 10.5 is below
 *        its own neighbour's 20);
 *      - (2, 13) holds 1, 1, 20, 20: two equal brightest, no peak;
 *      - (13, 2) holds 1, 1, 1, 3.9: below the ratio, no peak.
 *      The same samples one per pixel (only each pixel's brightest kept) have no peak pixel (a
 *      lone sample is left alone), and on a grid of one cell per pixel nothing is one.
 *   2. The map against its formula in double: u = log(1 + max(y, 0) / s), s = 8 x the mean of
 *      max(y, 0), a channel of zeros mapped to 0.
 *   3. A pixel's value from a fine image of u: s (e^clip(u, 0, umax) - 1) averaged over its
 *      cells, clipped at both ends.
 *   4. A reconstruction: a floor of 0.1 with two dots of 1000, each one fine cell (1/64 of its
 *      pixel) where one of its pixel's four stratified samples lies, so that the pixel's mean
 *      reads 250 where its integral is 15.7. With the option: exactly those two pixels change
 *      (every other pixel the same bits as without it), each comes out between the mean of its
 *      other samples (the peak dropped, 0.1) and its mean, nearer its integral than the mean,
 *      and the result counts 2 peak pixels. (Not nearer than dropping the peak here: the fit
 *      spreads a one-cell dot over about a stratum, 66 for 15.7; on the glints scene dropping
 *      was the better of the two as well, docs/bench/mitsuba.md, session 10.) */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/peak_range.h"
#include "csi/reconstruct.h"
#include "testlib.h"

enum { OW = 16, F = 4, NP = OW * OW };

/* The pixels that differ from 1: their last sample (s = 3), and their third (s = 2). */
static const struct {
    int x, y;
    float last, third;
} special[] = {{5, 5, 20, 1}, {10, 10, 20, 1}, {11, 10, 45, 1}, {2, 13, 20, 20}, {13, 2, 3.9f, 1}, {7, 2, 20, 1}, {8, 2, 10.5f, 1}};

static float sample_value(int p, int s)
{
    for (size_t i = 0; i < sizeof special / sizeof *special; i++)
        if (special[i].x == p % OW && special[i].y == p / OW)
            return s == 3 ? special[i].last : s == 2 ? special[i].third : 1.0f;
    return 1.0f;
}

static void pixels(void)
{
    csi_sample_pos pos[4 * NP];
    float val[4 * NP * 2];
    size_t n = 0;
    for (int p = 0; p < NP; p++)
        for (int s = 0; s < 4; s++) {
            pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + (s % 2) * 2), (uint32_t)(p / OW * F + (s / 2) * 2), 0};
            val[n * 2] = sample_value(p, s), val[n * 2 + 1] = 3 * sample_value(p, s);
            n++;
        }
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    uint8_t peak[NP];
    size_t k = 99;
    CHECK_OK(csi_peak_range_pixels(&g, 2, pos, val, n, peak, &k));
    size_t other = 0;
    for (int p = 0; p < NP; p++)
        if (p != 5 * OW + 5 && p != 10 * OW + 11)
            other += peak[p];
    CHECK(peak[5 * OW + 5] && peak[10 * OW + 11], "the isolated peaks: (5, 5) %d, (11, 10) %d", peak[5 * OW + 5],
          peak[10 * OW + 11]);
    CHECK(other == 0 && k == 2, "%zu other peak pixels, %zu counted (want 2)", other, k);

    /* one sample per pixel: each pixel's brightest alone */
    size_t m = 0;
    for (int p = 0; p < NP; p++) {
        pos[m] = pos[p * 4 + 3];
        val[m * 2] = val[(p * 4 + 3) * 2], val[m * 2 + 1] = val[(p * 4 + 3) * 2 + 1];
        m++;
    }
    CHECK_OK(csi_peak_range_pixels(&g, 2, pos, val, m, peak, &k));
    CHECK(k == 0, "one sample per pixel: %zu peak pixels", k);

    /* one cell per pixel */
    const csi_grid g1 = {OW, OW, 1, OW, OW};
    for (size_t i = 0; i < m; i++)
        pos[i].x /= F, pos[i].y /= F;
    CHECK_OK(csi_peak_range_pixels(&g1, 2, pos, val, m, peak, &k));
    CHECK(k == 0, "one cell per pixel: %zu peak pixels", k);
}

static void map(void)
{
    const float y[] = {0.5f, 0, -2, 0, 100, 0, 3.25f, 0};
    float u[8];
    double s[4], umax[4];
    csi_peak_range_map(2, y, 4, u, s, umax);
    const double want_s = 8.0 * (0.5 + 0 + 100 + 3.25) / 4;
    CHECK(fabs(s[0] - want_s) <= 1e-12 * want_s, "s %.17g, want %.17g", s[0], want_s);
    CHECK(s[1] == 0 && umax[1] == 0, "a channel of zeros: s %g, umax %g", s[1], umax[1]);
    CHECK(fabs(umax[0] - log1p(100 / want_s)) <= 1e-12, "umax %.17g, want %.17g", umax[0], log1p(100 / want_s));
    for (int i = 0; i < 4; i++) {
        const double want = log1p(fmax(y[i * 2], 0) / want_s);
        CHECK(fabs(u[i * 2] - want) <= 0x1p-23 * fmax(want, 1e-30) && u[i * 2 + 1] == 0,
              "sample %d: u %.9g, want %.9g (channel 1: %g)", i, u[i * 2], want, u[i * 2 + 1]);
    }
}

static void pixel_value(void)
{
    /* 2 x 2 pixels of 2 x 2 cells; pixel 1 (x = 1, y = 0) holds u = 0.5, 1, -1 (clipped to 0)
     * and 9 (clipped to umax = 2) in channel 1. */
    const csi_grid g = {4, 4, 1, 2, 2};
    float fine[2 * 16] = {0};
    float *c1 = fine + 16;
    c1[0 * 4 + 2] = 0.5f, c1[0 * 4 + 3] = 1, c1[1 * 4 + 2] = -1, c1[1 * 4 + 3] = 9;
    const double s = 3, want = s * (expm1(0.5) + expm1(1) + 0 + expm1(2)) / 4;
    const double got = csi_peak_range_pixel(&g, fine, 1, 1, s, 2);
    CHECK(fabs(got - want) <= 1e-6 * want, "pixel value %.9g, want %.9g", got, want);
    CHECK(csi_peak_range_pixel(&g, fine, 0, 1, s, 2) == 0, "channel 0 is all 0");
}

enum { RW = 32, RF = 8, RNP = RW * RW };

static void reconstruction(void)
{
    csi_ctx *ctx = test_ctx();
    const csi_grid g = {RW * RF, RW * RF, 1, RW, RW};
    csi_sample_pos *pos = malloc(4 * RNP * sizeof *pos);
    float *val = malloc(4 * RNP * sizeof *val);
    const int dots[2] = {10 * RW + 9, 21 * RW + 22};
    size_t n = 0;
    for (int p = 0; p < RNP; p++)
        for (int s = 0; s < 4; s++) {
            /* one sample in each 4 x 4 stratum of the pixel's 8 x 8 cells, at the stratum's cell (1, 2) */
            pos[n] = (csi_sample_pos){(uint32_t)(p % RW * RF + (s % 2) * 4 + 1), (uint32_t)(p / RW * RF + (s / 2) * 4 + 2), 0};
            val[n] = (p == dots[0] || p == dots[1]) && s == 3 ? 1000.0f : 0.1f;
            n++;
        }
    csi_recon_options o;
    csi_recon_defaults(&o);
    csi_recon_result a, b;
    CHECK_OK(csi_recon(ctx, &g, 1, pos, val, n, &o, &a));
    o.peak_range = CSI_SWITCH_ON;
    CHECK_OK(csi_recon(ctx, &g, 1, pos, val, n, &o, &b));
    CHECK(b.peak_range_pixels == 2, "%zu peak pixels, want 2", b.peak_range_pixels);
    size_t other = 0;
    for (int p = 0; p < RNP; p++)
        if (p != dots[0] && p != dots[1])
            other += memcmp(&a.image[p], &b.image[p], sizeof(float)) != 0;
    CHECK(other == 0, "%zu pixels without a peak changed", other);
    const double truth = 0.1 + (1000.0 - 0.1) / (RF * RF), mean = (1000.0 + 3 * 0.1) / 4, drop = 0.1;
    for (int i = 0; i < 2; i++) {
        const double v = b.image[dots[i]];
        CHECK(v > drop && v < mean && fabs(v - truth) < fabs(mean - truth),
              "dot %d: %.6g (without the option %.6g), its integral %.6g, mean %.6g, without the peak %.6g", i, v,
              (double)a.image[dots[i]], truth, mean, drop);
    }
    csi_recon_result_free(&a);
    csi_recon_result_free(&b);
    free(pos);
    free(val);
}

int main(void)
{
    pixels();
    map();
    pixel_value();
    reconstruction();
    return test_done();
}
