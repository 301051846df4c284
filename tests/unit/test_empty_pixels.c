/* Pixels without a sample next to an HDR step (csi/empty_pixels.h), on hand-made samples whose
 * outcome the rule states exactly: 5 x 5 pixels on a 4x grid, one sample per pixel but in the
 * centre pixel (2, 2), which holds none; row 1 is a line of brightness B, every other sample 1
 * (channel 0; channel 1 is twice channel 0, so the dark side differs per channel). The image
 * handed in is 1 (2 in channel 1) everywhere but in the centre, where it stands a fraction f of
 * the way from the darkest neighbour to the brightest. e, the rule's floor, is 1% of the samples'
 * mean absolute value.
 *   1. B = 1000, f = 0.02 (below the full-weight twentieth; the ratio of the step far above 16):
 *      the centre becomes exactly its lowest neighbours' means, 1 and 2.
 *   2. B = 1000, f = 0.5 (the fit seeing the pixel half on the bright side): the same bits.
 *   3. B = 3 (a ratio below 4: ordinary shading), f = 0.02: the same bits.
 *   4. B = 1000, f = 0.075 (halfway up the fraction's ramp, a twentieth to a tenth): the centre
 *      moves half of the way to its dark side, to 1 + (x - 1) / 2 (1% relative: the ramp in
 *      the ratio is 1 here).
 *   5. In every case every pixel holding a sample keeps its bits, and nothing is raised. */
#include <math.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/empty_pixels.h"
#include "testlib.h"

enum { OW = 5, F = 4, NP = OW * OW, C = 2 };

static void run(double bright, double f, const char *what, int expect)
{
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    csi_sample_pos pos[NP];
    float val[NP * C];
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        if (p == 2 * OW + 2)
            continue;
        pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + 1), (uint32_t)(p / OW * F + 2), 0};
        val[n * C] = p / OW == 1 ? (float)bright : 1.0f;
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
    run(1000, 0.02, "a leak beside a line of 1000", 1);
    run(1000, 0.5, "half the line's light", 0);
    run(3, 0.02, "a step of 3", 0);
    run(1000, 0.075, "halfway up the ramp", 2);
    return test_done();
}
