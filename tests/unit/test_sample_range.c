/* The range that bounds a still basis's volume and image (csi_recon_sample_ranges,
 * host/integrate/sample_range.c), on samples whose spreads are known by construction:
 *
 *   40 x 12 pixels; the pixels with (x + 2 y) % 3 == 0 hold two samples each (every 3 x 3 window
 *   inside the frame holds three such pixels: 6 samples), but none in the 4 x 4 block at the
 *   corner (0, 0). Left half (x < 20): a still picture, both samples of a pixel equal to
 *   a(x, y) = 0.01 (x + 40 y) / 4.8, so no pixel's values change over t (rho = 0). Right half:
 *   something moves through every pixel, its samples a(x, y) and a(x, y) + 1: within a pixel
 *   the spread is 1/2 per pair, more than half the 3 x 3 window's (its 6 samples: three such
 *   pairs and means that differ by at most 0.07).
 *
 * Expected, from the rule's definition (the pooling reaches 8 pixels, so pixels more than 8
 * from the middle see one half only):
 *   - still pixels (x <= 10): [min, max] of the samples in the pixel and its 8 neighbours; the
 *     range of all the samples where that window holds none (the empty corner);
 *   - moving pixels (x >= 29): the same over the smallest (2 r + 1)^2 window holding at least 8
 *     samples (counted here by brute force: r = 2 inside the frame);
 *   - samples whose pixel index is outside the frame count for the range of all only;
 *   - no sample at all: (-inf, +inf); the same call twice gives the same bits. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../../host/integrate/internal.h"
#include "testlib.h"

enum { W = 40, H = 12, NP = W * H };

static double a_of(int x, int y) { return 0.01 * (x + 40 * y) / 4.8; }

static bool sampled(int x, int y) { return (x + 2 * y) % 3 == 0 && !(x < 4 && y < 4); }

typedef struct {
    size_t pix[2 * NP + 2];
    float val[(2 * NP + 2) * 2]; /* 2 channels: the second is the first times -3 */
    size_t n;
} samples;

static void make(samples *s)
{
    s->n = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            if (!sampled(x, y))
                continue;
            for (int k = 0; k < 2; k++) {
                const float v = (float)(a_of(x, y) + (x >= 20 && k == 1 ? 1.0 : 0.0));
                s->pix[s->n] = (size_t)y * W + (size_t)x;
                s->val[2 * s->n] = v;
                s->val[2 * s->n + 1] = -3 * v;
                s->n++;
            }
        }
    /* two samples outside the frame: the range of all only */
    s->pix[s->n] = NP;
    s->val[2 * s->n] = -7;
    s->val[2 * s->n + 1] = 50;
    s->n++;
    s->pix[s->n] = (size_t)-1;
    s->val[2 * s->n] = 9;
    s->val[2 * s->n + 1] = -60;
    s->n++;
}

/* [min, max] of channel c's in-frame samples within r of (x, y); count their number */
static void window(const samples *s, int c, int x, int y, int r, float *lo, float *hi, int *count)
{
    *lo = INFINITY;
    *hi = -INFINITY;
    *count = 0;
    for (size_t i = 0; i < s->n; i++) {
        if (s->pix[i] >= NP)
            continue;
        const int px = (int)(s->pix[i] % W), py = (int)(s->pix[i] / W);
        if (abs(px - x) > r || abs(py - y) > r)
            continue;
        *lo = fminf(*lo, s->val[2 * i + c]);
        *hi = fmaxf(*hi, s->val[2 * i + c]);
        (*count)++;
    }
}

int main(void)
{
    static samples s;
    make(&s);
    static float lohi[2][2 * NP], again[2 * NP];
    for (int c = 0; c < 2; c++)
        REQUIRE_OK(csi_recon_sample_ranges(W, H, s.pix, s.val, 2, (uint32_t)c, s.n, lohi[c]));
    const float all_lo[2] = {-7, -60}, all_hi[2] = {9, 50};

    int still = 0, moving = 0, empty = 0;
    for (int c = 0; c < 2; c++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const size_t p = (size_t)y * W + (size_t)x;
                float lo, hi;
                int count;
                if (x <= 10) {
                    window(&s, c, x, y, 1, &lo, &hi, &count);
                    if (!count) {
                        lo = all_lo[c];
                        hi = all_hi[c];
                        empty++;
                    }
                    still++;
                } else if (x >= 29) {
                    int r = 1;
                    for (window(&s, c, x, y, r, &lo, &hi, &count); count < 8; window(&s, c, x, y, ++r, &lo, &hi, &count))
                        ;
                    CHECK(r >= 2, "pixel (%d, %d): a moving pixel's 3 x 3 window holds %d samples", x, y, count);
                    moving++;
                } else {
                    continue;
                }
                CHECK(lohi[c][2 * p] == lo && lohi[c][2 * p + 1] == hi,
                      "channel %d pixel (%d, %d): range [%g, %g], expected [%g, %g]", c, x, y, lohi[c][2 * p],
                      lohi[c][2 * p + 1], lo, hi);
            }
    CHECK(still == 2 * 11 * H && moving == 2 * 11 * H && empty > 0, "pixels checked: %d still (%d empty), %d moving",
          still, empty, moving);

    /* the same call, the same bits */
    REQUIRE_OK(csi_recon_sample_ranges(W, H, s.pix, s.val, 2, 0, s.n, again));
    CHECK(memcmp(again, lohi[0], sizeof again) == 0, "a second call gave other bits");

    /* no sample: nothing to bound by */
    REQUIRE_OK(csi_recon_sample_ranges(W, H, s.pix, s.val, 2, 0, 0, again));
    bool open = true;
    for (size_t p = 0; p < NP; p++)
        open = open && isinf(again[2 * p]) && again[2 * p] < 0 && isinf(again[2 * p + 1]) && again[2 * p + 1] > 0;
    CHECK(open, "without samples a pixel's range is not (-inf, inf)");
    return test_done();
}
