/* Pixels without a sample next to an HDR step (csi/empty_pixels.h), on hand-made samples whose
 * outcome the rule states exactly: 5 x 5 pixels on a 4x grid, one sample per pixel but in the
 * centre pixel (2, 2), which holds none; the pixels a case names bright hold B, every other
 * sample 1 (channel 0; channel 1 is twice channel 0, so the dark side differs per channel). The
 * image handed in is 1 (2 in channel 1) everywhere but in the centre, where it stands a fraction
 * f of the way from the darkest neighbour to the brightest. e, the rule's floor, is 1% of the
 * samples' mean absolute value. The fraction below which the centre is taken for the dark side
 * (fully below half of it) follows the bright side's shape. In cases 1-3 the centre's left and
 * right neighbours, (1, 2) and (3, 2), hold no sample either, so that no line through the centre
 * decides (case 5) and the fraction alone does:
 *   1. One bright pixel, (2, 1), above the centre (a sub-pixel source: its light goes on past
 *      no pixel of the centre's window, the bright side stands alone, F_ALONE = 1): at B = 1000,
 *      f = 0.02 and f = 0.45 the centre becomes exactly its lowest neighbours' means, 1 and 2;
 *      at f = 0.75 (halfway up the ramp from a half to all of the step) it moves half of the way
 *      there, to 1 + (x - 1) / 2 (1% relative: the ramp in the ratio is 1 here); at B = 3 (a
 *      ratio below 4: ordinary shading), f = 0.02, the same bits.
 *   2. A line one pixel wide along row 1 (nothing beyond it straight away from the centre: it
 *      stands alone, F_ALONE = 1): f = 0.02, 0.075 and 0.45 the dark side; rows 0 and 1 bright
 *      (an extended region's edge beside the centre, F = 0.1): f = 0.02 the dark side, f = 0.075
 *      halfway, f = 0.45 the same bits.
 *   3. The bright pixel of case 1 and the pixel below the centre, (2, 3), a quarter of the way up
 *      (bright: above the step's geometric midpoint; the centre lies between bright pixels, on
 *      the feature, F = 0.1): f = 0.02 the dark side, f = 0.075 halfway, f = 0.45 the same bits.
 *   4. A segment of row 2, pixels 1 to 3, through the centre (bright on both sides of it, dark
 *      beyond): f = 0.45 the same bits.
 *   5. The line the centre lies on (csi/empty_pixels.h), every neighbour sampled, B = 1000:
 *      a. a dark slat: rows 1 and 3 bright, row 2 dark (the centre's left neighbour 1.5, so that
 *         the target, the mean of its row's two neighbours, 1.25, is not just the darkest
 *         neighbour), at f = 0.45 and f = 0.9 (far up the step, where the fraction keeps it):
 *         exactly 1.25 and 2.5;
 *      b. the source of case 1 with the centre's row sampled: its row is dark on both sides, so
 *         at f = 0.75 (where the fraction's ramp moves it halfway) it goes all the way;
 *      c. an extended region, rows 0 and 1, the centre's row dark on both sides and the rows
 *         beside it uniform: at f = 0.45 (an edge the fraction keeps) it goes to its dark side;
 *      d. a bright column through the centre crossing the dark rows (the columns beside it
 *         uniformly dark, the rows not): f = 0.45, the same bits; so does case 4's segment;
 *      e. two dark corners alone, (1, 1) and (3, 3), the centre's upper and left neighbours
 *         unsampled, (3, 2), (2, 3), (1, 3) bright, (3, 1) dark: no line parallel to that
 *         diagonal holds two samples, so it does not decide (a diagonal needs a supporting
 *         line), and the fraction's rule (bright neighbours on opposite sides: F = 0.1) keeps
 *         f = 0.45.
 *   6. The cap, last (csi/empty_pixels.h): unless the centre's row or column has both
 *      neighbours bright and neither has both dark or unknown (a neighbour without a sample
 *      stood in for by the pixel beyond it), a centre still above the step's geometric midpoint
 *      sqrt((D + e) (H + e)) - e of its darkest and brightest neighbours D and H (channels'
 *      means) is scaled, both channels together, to stand exactly there (the step's ratio is
 *      1000, its weight 1). So the cases above that kept the centre far up the step are now
 *      capped: case 1 at f = 0.75 (its row, beyond the unsampled neighbours, is dark), the
 *      extended edge of case 2 and case 3 at f = 0.45 (the same), the segment of case 4 and the
 *      column of 5d (a bright line one way, a dark one the other: which the pixel lies on, the
 *      samples cannot tell) and the corners of 5e (no line bright on both sides);
 *      f. a dark slat whose row neighbour on the left holds no sample (no line decides, the
 *         fraction keeps f = 0.9; beyond the hole, the row is dark): capped;
 *      g. an extended region's edge row, rows 0 to 2 bright but the centre, rows 3 and 4 dark
 *         (its row bright on both sides, its column bright above): kept at f = 0.45;
 *      h. the inner corner of an L-shaped bright region, columns 0-1 and rows 3-4 (its row and
 *         its column each cross the step, 5 of its 8 neighbours bright): capped at f = 0.45, as
 *         the corners of 5e are (a corner of the step is capped whatever the neighbours' majority);
 *      i. a dark line running into the bright side from below, pixels (2, 3) and (2, 4), all else
 *         bright: its row is inside the bright side, its column crosses the step at (2, 3), whose
 *         own neighbours along the row are bright (a line, not g's region): capped at f = 0.45;
 *      j. the same with the centre holding one sample of the dark side's value (1, 2): capped at
 *         the step from its sample to the brightest neighbour (here the same midpoint); at B = 3
 *         (a ratio below the cap's 16) the same bits;
 *      k. one such sample on g's edge row, and one inside a bright side (every neighbour bright:
 *         a path that missed the light, which the fit's value rightly fills): the same bits;
 *      l. i's line one pixel long, (2, 3) alone dark (a path of a noisy side that found no light,
 *         or a point: nothing beyond it is dark): the same bits;
 *      m. a dark line slanting through the centre, (1, 2) and (3, 3) dark, all else bright (its
 *         row crosses the step at a lone dark pixel, its column is inside the bright side, but
 *         two dark neighbours lie on opposite sides of it): capped.
 *   7. In every case every pixel holding a sample keeps its bits but a centre of one sample, and
 *      nothing is raised. */
#include <math.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/empty_pixels.h"
#include "testlib.h"

enum { OW = 5, F = 4, NP = OW * OW, C = 2 };

enum {
    POINT, LINE1, EXTENDED, POINT_BELOW, THROUGH, SLAT, POINT_ROW, EXTENDED_ROW, COLUMN, CORNERS, SLAT_HOLE,
    EDGE_ROW, L_CORNER, LINE_INTO, ONE_LINE_INTO, ONE_EDGE_ROW, ONE_INSIDE, LONE_DARK, SLANT
};

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
    case EXTENDED_ROW:
        return y <= 1;
    case POINT_ROW:
        return x == 2 && y == 1;
    case SLAT:
    case SLAT_HOLE:
        return y == 1 || y == 3;
    case EDGE_ROW:
    case ONE_EDGE_ROW:
        return y <= 2;
    case LINE_INTO:
    case ONE_LINE_INTO:
        return !(x == 2 && y >= 3);
    case ONE_INSIDE:
        return 1;
    case LONE_DARK:
        return !(x == 2 && y == 3);
    case SLANT:
        return !((x == 1 && y == 2) || (x == 3 && y == 3));
    case L_CORNER:
        return x <= 1 || y >= 3;
    case COLUMN:
        return x == 2;
    case CORNERS:
        return (x == 3 && y == 2) || (x == 2 && y == 3) || (x == 1 && y == 3);
    default:
        return y == 2 && x >= 1 && x <= 3;
    }
}

/* whether the centre holds a sample (of 1, 2: the dark side's value) */
static int centre_sampled(int shape)
{
    return shape == ONE_LINE_INTO || shape == ONE_EDGE_ROW || shape == ONE_INSIDE;
}

/* the pixels without a sample besides the centre */
static int unsampled(int shape, int p)
{
    const int x = p % OW, y = p / OW;
    if (shape == POINT || shape == LINE1 || shape == EXTENDED || shape == POINT_BELOW)
        return y == 2 && (x == 1 || x == 3);
    if (shape == CORNERS)
        return (x == 2 && y == 1) || (x == 1 && y == 2);
    if (shape == SLAT_HOLE)
        return x == 1 && y == 2;
    return 0;
}

/* expect: 0 the same bits, 1 the dark side, 2 halfway to it, 3 the mean of its row's neighbours
 * (1.25 and 2.5), 4 capped at the step's geometric midpoint */
static void run(int shape, double bright, double f, const char *what, int expect)
{
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    csi_sample_pos pos[NP];
    float val[NP * C];
    size_t n = 0;
    for (int p = 0; p < NP; p++) {
        if ((p == 2 * OW + 2 && !centre_sampled(shape)) || unsampled(shape, p))
            continue;
        pos[n] = (csi_sample_pos){(uint32_t)(p % OW * F + 1), (uint32_t)(p / OW * F + 2), 0};
        val[n * C] = bright_pixel(shape, p) && p != 2 * OW + 2 ? (float)bright : 1.0f;
        if (shape == POINT_BELOW && p == 3 * OW + 2)
            val[n * C] = (float)(1.0 + 0.25 * (bright - 1.0));
        if (shape == SLAT && p == 2 * OW + 1)
            val[n * C] = 1.5f;
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
    /* the cap (case 6): the step's ends D and H among the centre's sampled neighbours, by the
     * channels' mean, and the floor e */
    double lo = INFINITY, hi = -INFINITY, sabs = 0;
    for (size_t i = 0; i < n; i++) {
        const int dx = (int)(pos[i].x / F) - 2, dy = (int)(pos[i].y / F) - 2;
        const double mean = 0.5 * (val[i * C] + val[i * C + 1]);
        if (dx >= -1 && dx <= 1 && dy >= -1 && dy <= 1)
            lo = fmin(lo, mean), hi = fmax(hi, mean);
        sabs += fabs(val[i * C]) + fabs(val[i * C + 1]);
    }
    const double e = 1e-2 * sabs / (double)n / C;
    const double cap = sqrt((lo + e) * (hi + e)) - e;
    const double centre = 0.5 * (before[2 * OW + 2] + before[NP + 2 * OW + 2]);
    CHECK_OK(csi_empty_pixels(&g, C, pos, val, n, NULL, img));
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
        else if (expect == 4)
            CHECK(fabs(got - was * cap / centre) <= 1e-5 * was * cap / centre,
                  "%s: channel %d is %g, not capped at %g", what, c, got, was * cap / centre);
        else if (expect == 3)
            CHECK(got == 1.25f * (float)(c + 1), "%s: channel %d is %g, not its row's %g", what, c, got,
                  1.25 * (c + 1));
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
    run(POINT, 1000, 0.75, "beside a source, halfway up the ramp: capped", 4);
    run(POINT, 3, 0.02, "a step of 3", 0);
    run(LINE1, 1000, 0.02, "a leak beside a line", 1);
    run(LINE1, 1000, 0.075, "beside a line, low on the step", 1);
    run(LINE1, 1000, 0.45, "beside a line, halfway up the step", 1);
    run(EXTENDED, 1000, 0.02, "a leak beside an extended region", 1);
    run(EXTENDED, 1000, 0.075, "beside an extended region, halfway up the ramp", 2);
    run(EXTENDED, 1000, 0.45, "an extended region's edge, its row dark beyond: capped", 4);
    run(POINT_BELOW, 1000, 0.02, "a leak between two bright pixels", 1);
    run(POINT_BELOW, 1000, 0.075, "between two bright pixels, halfway up the ramp", 2);
    run(POINT_BELOW, 1000, 0.45, "between two bright pixels, the row dark beyond: capped", 4);
    run(THROUGH, 1000, 0.45, "a segment through the pixel: capped", 4);
    run(SLAT, 1000, 0.45, "a dark slat between bright rows", 3);
    run(SLAT, 1000, 0.9, "a dark slat between bright rows, far up the step", 3);
    run(POINT_ROW, 1000, 0.75, "beside a source, its own row dark", 1);
    run(EXTENDED_ROW, 1000, 0.45, "beside an extended region, its own row dark", 1);
    run(COLUMN, 1000, 0.45, "a bright column crossing dark rows: capped", 4);
    run(CORNERS, 1000, 0.45, "two dark corners alone: capped", 4);
    run(SLAT_HOLE, 1000, 0.9, "a dark slat beside a neighbour without a sample: capped", 4);
    run(EDGE_ROW, 1000, 0.45, "an extended region's edge row", 0);
    run(L_CORNER, 1000, 0.45, "an L-shaped region's inner corner: capped", 4);
    run(LINE_INTO, 1000, 0.45, "a dark line running into the bright side: capped", 4);
    run(ONE_LINE_INTO, 1000, 0.45, "one dark sample, a dark line running into the bright side: capped", 4);
    run(ONE_EDGE_ROW, 1000, 0.45, "one dark sample on an extended region's edge row", 0);
    run(ONE_INSIDE, 1000, 0.45, "one dark sample inside the bright side", 0);
    run(ONE_LINE_INTO, 3, 0.45, "one dark sample, a step of 3", 0);
    run(LONE_DARK, 1000, 0.45, "a lone dark neighbour inside the bright side", 0);
    run(SLANT, 1000, 0.45, "a dark line slanting through the pixel: capped", 4);
    return test_done();
}
