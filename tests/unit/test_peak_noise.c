/* Isolated peaks judged against their own noise (csi/peak_noise.h), on hand-made samples whose
 * outcome the rule states exactly. A peak its noise explains becomes r + w (x - r), r the value
 * without it, x the reconstruction's, w = max(0, 1 - v / d^2) for its excess d and variance v;
 * the expected values are computed here in double from that formula (want_shrunk).
 *
 *   1. One sample per pixel, 16 x 16 pixels on a 4x grid, every sample 1 except a few peaks; the
 *      "reconstruction" x is 0.5 everywhere, so every pixel the rule sets shows. Channel 1 is
 *      channel 0 times 2 with 4x the variance: the test and the weight w are scale-free, so the
 *      same pixels are set, with the same w (r doubles, x does not).
 *      - (5, 5) = 20, variance 1: a peak (20 > 4 x 1) with an excess of 19 >= 3 sd = 3, the
 *        image's: untouched, 0.5.
 *      - (10, 10) = 40, variance 1600 (sd 40: one path of 64 carrying the whole value has
 *        v = y^2), its 8 neighbours 1..8: a peak (40 > 4 x 8) that its noise explains (32 < 120)
 *        with v > d^2 = 1024, so w = 0: the median of the neighbours, 4.5 exactly.
 *      - (2, 13) = 10, variance 9: excess 9 = 3 sd exactly, the image's (the bound is
 *        inclusive): untouched, 0.5.
 *      - (13, 2) = 10, variance 9.0001: just below, noise, but most of it signal by its noise
 *        (w = 1 - 9.0001 / 81, just under 8/9): 1 + w (0.5 - 1), shrunk towards the neighbours'
 *        median 1, not dropped.
 *      - (5, 10) = 3.5, variance 0: not a peak (3.5 < 4 x 1 with the floor e = 1% of the mean
 *        absolute sample), untouched: 0.5. Every other pixel untouched too (next to a peak no
 *        sample is one).
 *   2. Three samples per pixel, every sample 1 (variance 0.01) except in three pixels, the
 *      brightest sample judged against the pixel's others (channel 1 again twice channel 0):
 *      - (3, 3) holds 1, 2, 20 of variance 400: 20 > 4 x 2 and 18 < 3 sd = 60, noise with
 *        v > 18^2 (w = 0): the mean of the other two, 1.5 exactly;
 *      - (12, 12) holds 1, 1, 9 of variance 32: 8 < 3 sd = 17, noise, with w = 1 - 32 / 64 = 1/2:
 *        halfway between the others' mean 1 and x, 0.75 (1.25 in channel 1) exactly;
 *      - (8, 8) holds 1, 1, 20 of variance 1: 19 >= 3, the image's: untouched, 0.5;
 *      - (12, 4) holds 2, 3, 7 of variance 0: 7 < 4 x 3, no peak: untouched.
 *   3. One cell per pixel: every sample is its pixel's exact value, nothing is set. And on the 4x
 *      grid, a pixel holding all 16 of its cells (15 at 1 and a one-path peak of 20, variance
 *      400, which in a pixel of three samples is dropped: 2) is its cells' exact mean: untouched,
 *      while the same three samples elsewhere are still shrunk.
 *   4. Three samples per pixel, every sample 1 (variance 0.01), two pixels holding 1, 1, 20 of
 *      variance 400 (a one-path peak: w = 0) amid neighbours bright in the same way:
 *      - (4, 4)'s 8 neighbours hold 20, 20, 1 (the 20s of variance 400, no peaks: each has a
 *        twin): 16 of their 24 samples reach the peak level, and the pixel's 2 others both below
 *        it has probability (1/3)^2 = 0.11 >= 5% at that rate: the pixel may share the level,
 *        and the neighbours' median mean 41/3, above the others' 1, is the value, exactly;
 *      - (11, 11)'s 8 neighbours hold 20, 20, 20: every sample reaches the level, two below it
 *        have probability 0 < 5%: the pixel is not the neighbourhood's, the others' mean 1. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/peak_noise.h"
#include "testlib.h"

enum { OW = 16, F = 4, NP = OW * OW };

typedef struct {
    int x, y;
    float v, var;
} peak;

static const peak peaks[] = {{5, 5, 20, 1}, {10, 10, 40, 1600}, {2, 13, 10, 9}, {13, 2, 10, 9.0001f}, {5, 10, 3.5f, 0}};

/* The samples of property 1: one per pixel, at cell (1, 1) of its block, 2 channels; the
 * neighbours of (10, 10) are 1..8 in raster order. */
static size_t make(csi_sample_pos *pos, float *val, float *var)
{
    float img[NP], iv[NP];
    for (int p = 0; p < NP; p++)
        img[p] = 1, iv[p] = 0.01f;
    int k = 1;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++)
            if (dx || dy)
                img[(10 + dy) * OW + 10 + dx] = (float)k++;
    for (size_t i = 0; i < sizeof peaks / sizeof *peaks; i++)
        img[peaks[i].y * OW + peaks[i].x] = peaks[i].v, iv[peaks[i].y * OW + peaks[i].x] = peaks[i].var;
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + 1), (uint32_t)(p / OW * F + 1), 0};
        val[n * 2] = img[p], val[n * 2 + 1] = 2 * img[p];
        var[n * 2] = iv[p], var[n * 2 + 1] = 4 * iv[p];
        n++;
    }
    return n;
}

/* Property 2's samples: three per pixel, at cells (1, 1), (2, 2), (3, 3) of its block. */
static size_t make3(csi_sample_pos *pos, float *val, float *var)
{
    size_t n = 0;
    for (int p = 0; p < NP; p++)
        for (int s = 0; s < 3; s++) {
            float v = 1, vv = 0.01f;
            if (p == 3 * OW + 3)
                v = s == 0 ? 1 : s == 1 ? 2 : 20, vv = s == 2 ? 400 : 0.01f;
            if (p == 8 * OW + 8)
                v = s == 2 ? 20 : 1, vv = s == 2 ? 1 : 0.01f;
            if (p == 4 * OW + 12)
                v = s == 0 ? 2 : s == 1 ? 3 : 7, vv = 0;
            if (p == 12 * OW + 12)
                v = s == 2 ? 9 : 1, vv = s == 2 ? 32 : 0.01f;
            pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + 1 + s), (uint32_t)(p / OW * F + 1 + s), 0};
            val[n * 2] = v, val[n * 2 + 1] = 2 * v;
            var[n * 2] = vv, var[n * 2 + 1] = 4 * vv;
            n++;
        }
    return n;
}

/* Property 3's second part: three samples per pixel as make3's, all 1 (variance 0.01), but pixel
 * (3, 3) holds every one of its 16 cells and (3, 3), (12, 12) a one-path peak of 20 (variance
 * 400) as their last sample. */
static size_t make_full(csi_sample_pos *pos, float *val, float *var)
{
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        const int full = p == 3 * OW + 3, ns = full ? F * F : 3;
        for (int s = 0; s < ns; s++) {
            const int peak = (full || p == 12 * OW + 12) && s == ns - 1;
            const float v = peak ? 20 : 1, vv = peak ? 400 : 0.01f;
            pos[n] = full ? (csi_sample_pos){(uint32_t)(p % OW * F + s % F), (uint32_t)(p / OW * F + s / F), 0}
                          : (csi_sample_pos){(uint32_t)(p % OW * F + 1 + s), (uint32_t)(p / OW * F + 1 + s), 0};
            val[n * 2] = v, val[n * 2 + 1] = 2 * v;
            var[n * 2] = vv, var[n * 2 + 1] = 4 * vv;
            n++;
        }
    }
    return n;
}

/* Property 4's samples: three per pixel as make3's; bright is 20 of variance 400. */
static size_t make4(csi_sample_pos *pos, float *val, float *var)
{
    size_t n = 0;
    for (int p = 0; p < NP; p++)
        for (int s = 0; s < 3; s++) {
            const int x = p % OW, y = p / OW;
            const int near_a = abs(x - 4) <= 1 && abs(y - 4) <= 1, near_b = abs(x - 11) <= 1 && abs(y - 11) <= 1;
            const int centre = (x == 4 && y == 4) || (x == 11 && y == 11);
            const int bright = centre ? s == 2 : near_a ? s < 2 : near_b;
            const float v = bright ? 20 : 1, vv = bright ? 400 : 0.01f;
            pos[n] = (csi_sample_pos){(uint32_t)(x * F + 1 + s), (uint32_t)(y * F + 1 + s), 0};
            val[n * 2] = v, val[n * 2 + 1] = 2 * v;
            var[n * 2] = vv, var[n * 2 + 1] = 4 * vv;
            n++;
        }
    return n;
}

/* The rule's value for a peak its noise explains, in double: the reference the library's float
 * output is checked against. */
static double want_shrunk(double r, double x, double d, double v)
{
    const double w = fmax(0.0, 1.0 - v / (d * d));
    return r + w * (x - r);
}

/* The library rounds its double result to float once: half an ulp, with room for a different
 * order of the same double operations. */
static int near(float got, double want)
{
    return fabs((double)got - want) <= 0x1p-23 * fabs(want);
}

static float *half_image(void)
{
    float *im = malloc(2 * NP * sizeof *im);
    for (int i = 0; i < 2 * NP; i++)
        im[i] = 0.5f;
    return im;
}

int main(void)
{
    csi_sample_pos pos[3 * NP + F * F]; /* make_full's pixel holds F * F */
    float val[2 * (3 * NP + F * F)], var[2 * (3 * NP + F * F)];
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};

    /* 1 */
    size_t n = make(pos, val, var), changed = 0;
    float *im = half_image();
    CHECK_OK(csi_peak_noise(&g, 2, pos, val, var, n, NULL, im, &changed));
    size_t other = 0;
    for (int c = 0; c < 2; c++)
        for (int p = 0; p < NP; p++) {
            const double s = c + 1; /* channel 1 is channel 0 scaled by 2, its variance by 4 */
            if (p == 10 * OW + 10) /* w = 0: the neighbours' median exactly */
                CHECK(im[c * NP + p] == (float)(4.5 * s), "channel %d: the one-path peak %.9g, want %.9g", c,
                      im[c * NP + p], 4.5 * s);
            else if (p == 2 * OW + 13) {
                const double want = want_shrunk(s, 0.5, 9 * s, (double)9.0001f * s * s);
                CHECK(near(im[c * NP + p], want) && want > 0.5 && want < s,
                      "channel %d: the peak just inside 3 sd %.9g, want %.9g", c, im[c * NP + p], want);
            } else
                other += im[c * NP + p] != 0.5f;
        }
    CHECK(other == 0, "%zu pixel-channels set that are no peak", other);
    CHECK(changed == 4, "%zu pixel-channels set, want 2 noisy peaks x 2 channels", changed);
    free(im);

    /* 2 */
    n = make3(pos, val, var);
    im = half_image();
    CHECK_OK(csi_peak_noise(&g, 2, pos, val, var, n, NULL, im, &changed));
    other = 0;
    for (int c = 0; c < 2; c++)
        for (int p = 0; p < NP; p++) {
            const double s = c + 1;
            if (p == 3 * OW + 3)
                CHECK(im[c * NP + p] == (float)(1.5 * s), "channel %d: the noisy sample's pixel %.9g, want %.9g", c,
                      im[c * NP + p], 1.5 * s);
            else if (p == 12 * OW + 12) {
                const double want = want_shrunk(s, 0.5, 8 * s, 32 * s * s);
                CHECK(near(im[c * NP + p], want), "channel %d: the half-signal peak %.9g, want %.9g", c,
                      im[c * NP + p], want);
            } else
                other += im[c * NP + p] != 0.5f;
        }
    CHECK(other == 0 && changed == 4, "three samples per pixel: %zu other pixel-channels set (%zu reported, want 4)",
          other, changed);
    free(im);

    /* 3 */
    n = make(pos, val, var);
    for (size_t i = 0; i < n; i++)
        pos[i].x /= F, pos[i].y /= F;
    const csi_grid g1 = {OW, OW, 1, OW, OW};
    im = half_image();
    CHECK_OK(csi_peak_noise(&g1, 2, pos, val, var, n, NULL, im, &changed));
    other = 0;
    for (int i = 0; i < 2 * NP; i++)
        other += im[i] != 0.5f;
    CHECK(other == 0 && changed == 0, "one cell per pixel: %zu pixel-channels set", other);
    free(im);
    n = make_full(pos, val, var);
    im = half_image();
    CHECK_OK(csi_peak_noise(&g, 2, pos, val, var, n, NULL, im, &changed));
    other = 0;
    for (int c = 0; c < 2; c++)
        for (int p = 0; p < NP; p++)
            if (p == 12 * OW + 12)
                CHECK(im[c * NP + p] == (float)(c + 1), "channel %d: the three samples' peak %.9g, want %d", c,
                      im[c * NP + p], c + 1);
            else
                other += im[c * NP + p] != 0.5f;
    CHECK(other == 0 && changed == 2, "a pixel of every cell: %zu other pixel-channels set (%zu reported, want 2)",
          other, changed);
    free(im);

    /* 4 */
    n = make4(pos, val, var);
    im = half_image();
    CHECK_OK(csi_peak_noise(&g, 2, pos, val, var, n, NULL, im, &changed));
    other = 0;
    for (int c = 0; c < 2; c++)
        for (int p = 0; p < NP; p++) {
            const double s = c + 1;
            if (p == 4 * OW + 4)
                CHECK(im[c * NP + p] == (float)(41.0 / 3 * s), "channel %d: the peak amid its like %.9g, want %.9g", c,
                      im[c * NP + p], 41.0 / 3 * s);
            else if (p == 11 * OW + 11)
                CHECK(im[c * NP + p] == (float)s, "channel %d: the peak its others contradict %.9g, want %.9g", c,
                      im[c * NP + p], s);
            else
                other += im[c * NP + p] != 0.5f;
        }
    CHECK(other == 0 && changed == 4, "peaks amid bright neighbours: %zu other pixel-channels set (%zu reported, want 4)",
          other, changed);
    free(im);
    return test_done();
}
