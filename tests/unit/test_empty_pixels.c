/* Pixels without a sample next to an HDR step (csi/empty_pixels.h), on hand-made samples whose
 * outcome the rule states exactly: 5 x 5 pixels on a 4x grid, one sample per pixel but in the
 * centre pixel (2, 2), which holds none; the pixels a case names bright hold B, every other
 * sample 1 (channel 0; channel 1 is twice channel 0, so the dark side differs per channel). The
 * image handed in is 1 (2 in channel 1) everywhere but in the centre, where it stands a fraction
 * f of the way from the darkest neighbour to the brightest. e, the rule's floor, is 1% of the
 * samples' mean absolute value. The fraction below which the centre is taken for the dark side
 * (fully below half of it) follows the bright side's shape:
 *   1. One bright pixel, (2, 1), above the centre (a sub-pixel source: its light goes on past
 *      no pixel of the centre's window, the bright side stands alone, F_ALONE = 1): at B = 1000,
 *      f = 0.02 and f = 0.45 the centre becomes exactly its lowest neighbours' means, 1 and 2;
 *      at f = 0.75 (halfway up the ramp from a half to all of the step) it moves half of the way
 *      there, to 1 + (x - 1) / 2 (1% relative: the ramp in the ratio is 1 here); at B = 3 (a
 *      ratio below 4: ordinary shading), f = 0.02, the same bits.
 *   2. A line one pixel wide along row 1 (it goes on past the window along itself, F = 0.1):
 *      f = 0.02 the dark side, f = 0.075 halfway, f = 0.45 the same bits; rows 0 and 1 bright
 *      (an extended region's edge beside the centre): the same.
 *   3. The bright pixel of case 1 and the pixel below the centre, (2, 3), a quarter of the way up
 *      (bright: above the step's geometric midpoint; the centre lies between bright pixels, on
 *      the feature, F = 0.1): f = 0.02 the dark side, f = 0.075 halfway, f = 0.45 the same bits.
 *   4. A segment of row 2, pixels 1 to 3, through the centre (bright on both sides of it, dark
 *      beyond): f = 0.45 the same bits.
 *   5. In every case every pixel holding a sample keeps its bits, and nothing is raised. */
#include <math.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/empty_pixels.h"
#include "testlib.h"

enum { OW = 5, F = 4, NP = OW * OW, C = 2 };

enum { POINT, LINE1, EXTENDED, POINT_BELOW, THROUGH };

static int bright_pixel(int shape, int p)
{
    const int x = p % OW, y = p / OW;
    switch (shape) {
    case POINT:
    case POINT_BELOW:
        return x == 2 && y == 1;
    case LINE1:
        return y == 1;
    case EXTENDED:
        return y <= 1;
    default:
        return y == 2 && x >= 1 && x <= 3;
    }
}

/* expect: 0 the same bits, 1 the dark side, 2 halfway to it */
static void run(int shape, double bright, double f, const char *what, int expect)
{
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    csi_sample_pos pos[NP];
    float val[NP * C];
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        if (p == 2 * OW + 2)
            continue;
        pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + 1), (uint32_t)(p / OW * F + 2), 0};
        val[n * C] = bright_pixel(shape, p) ? (float)bright : 1.0f;
        if (shape == POINT_BELOW && p == 3 * OW + 2)
            val[n * C] = (float)(1.0 + 0.25 * (bright - 1.0));
        val[n * C + 1] = 2 * val[n * C];
        n++;
    }
    float img[NP * C], before[NP * C];
    for (int c = 0; c < C; c++)
        for (int p = 0; p < NP; p++) {
            /* the centre's channel mean stands at f of the way from 1.5 to 1.5 B */
            double x = 1.0 + f * (bright - 1.0);
            img[c * NP + p] = (float)((p == 2 * OW + 2 ? x : 1.0) * (c + 1));
        }
    memcpy(before, img, sizeof img);
    CHECK_OK(csi_empty_pixels(&g, C, pos, val, n, img));
    int changed = 0, raised = 0;
    for (int i = 0; i < NP * C; i++) {
        changed += (i % NP != 2 * OW + 2) && memcmp(&img[i], &before[i], sizeof(float));
        raised += img[i] > before[i];
    }
    CHECK(changed == 0, "%s: %d pixels holding a sample changed", what, changed);
    CHECK(raised == 0, "%s: %d values raised", what, raised);
    for (int c = 0; c < C; c++) {
        const float got = img[c * NP + 2 * OW + 2], was = before[c * NP + 2 * OW + 2];
        if (expect == 0)
            CHECK(memcmp(&got, &was, sizeof got) == 0, "%s: channel %d moved %g -> %g", what, c, was, got);
        else if (expect == 1)
            CHECK(got == (float)(c + 1), "%s: channel %d is %g, not its dark side %d", what, c, got, c + 1);
        else {
            const double want = (c + 1) + 0.5 * (was - (c + 1));
            CHECK(fabs(got - want) <= 1e-2 * want, "%s: channel %d is %g, not %g", what, c, got, want);
        }
    }
}

int main(void)
{
    run(POINT, 1000, 0.02, "a leak beside a source of 1000", 1);
    run(POINT, 1000, 0.45, "a large leak beside a source of 1000", 1);
    run(POINT, 1000, 0.75, "beside a source, halfway up the ramp", 2);
    run(POINT, 3, 0.02, "a step of 3", 0);
    run(LINE1, 1000, 0.02, "a leak beside a line", 1);
    run(LINE1, 1000, 0.075, "beside a line, halfway up the ramp", 2);
    run(LINE1, 1000, 0.45, "beside a line", 0);
    run(EXTENDED, 1000, 0.02, "a leak beside an extended region", 1);
    run(EXTENDED, 1000, 0.075, "beside an extended region, halfway up the ramp", 2);
    run(EXTENDED, 1000, 0.45, "an extended region's edge", 0);
    run(POINT_BELOW, 1000, 0.02, "a leak between two bright pixels", 1);
    run(POINT_BELOW, 1000, 0.075, "between two bright pixels, halfway up the ramp", 2);
    run(POINT_BELOW, 1000, 0.45, "between two bright pixels", 0);
    run(THROUGH, 1000, 0.45, "a segment through the pixel", 0);
    return test_done();
}
