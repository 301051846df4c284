/* How much of what a still camera's samples see moves: whether the still layer may take a tenth
 * of its weight (exact samples) and whether each cell's range bound is its own neighbours'
 * (exact and noisy samples, the latter by a stricter share of motion) (motion.c; issue 12,
 * docs/bench/animation.md sessions 43-45).
 *
 * On a fine grid each cell is seen once or twice over the shutter, so a sample alone cannot say
 * whether what it saw was there at the other times. Its neighbours can: the samples of the
 * cells around it (within one cell in x and y) at other times.
 *
 * Lights. A sample is bright when its channels' mean (its luma) is above the display's white
 * (1) and above 4 times the median sample's: an HDR light, not a lit surface. A bright sample is
 * held when another bright sample around it lies a quarter of the shutter or more away in t: a
 * light that holds still is seen again there, a moving one is gone. Reported: the share of the
 * bright samples that are held (a still lamp, a lantern, a lit sign 0.99-1.0; two lamps moving
 * across a wall 0.06-0.07; where the bright samples are a few lit surfaces just above white,
 * anything from 0 to 0.7 with the seed), and the share of all the samples' energy (the sum of
 * their lumas squared) in bright samples that are not held (the moving lamps 0.90-0.92; the other
 * scenes measured 0.11 or less, those above 0.01 lit surfaces of movers just above white and a
 * small moving headlight).
 * A tenth of the still layer's weight holds each sample where it was seen, which costs in
 * proportion to the energy of what moves: most of all a moving light's.
 *
 * Everything else. Two samples around each other differ by the picture's change over the cell
 * between them and, if something moves, by its change over the time between them. With the
 * lumas capped at the bright threshold (the lights are judged above), the mean squared
 * difference of pairs a quarter of the shutter or more apart in t less that of pairs an eighth
 * or less apart is what the motion adds; over twice the capped lumas' variance (what two
 * unrelated samples differ by) it is the share of their variation that is motion. csi-render's
 * still-camera scenes with movers measured -0.04-0.19 at 4, 9 and 16 spp (0.12 with two moving
 * lamps, whose energy share decides them); a dim disc crossing a faint texture 0.42-0.52, HDR
 * discs crossing it 0.35-0.53 (tests/python/test_still_lights.py). The share grows with the
 * grid's fineness (neighbouring cells differ less): the carousel 0.01-0.03 on 2 x 2 cells a
 * pixel, 0.05 on 4 x 4. Infinite when no pair is an eighth of the shutter apart, or none a
 * quarter.
 *
 * The samples are sorted by cell column (a copy: 16 bytes each); each looks up the nine columns
 * around its own by binary search. Sums in double over the sorted order, which depends on the
 * positions alone (ties in a column broken by t, and a cell holds one sample): the same bits
 * for any order of the input. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

typedef struct {
    uint64_t col; /* y * w + x on the fine grid */
    uint32_t t;
    float luma;
} seen;

static int by_col(const void *a, const void *b)
{
    const seen *p = a, *q = b;
    return p->col < q->col ? -1 : p->col > q->col ? 1 : (p->t > q->t) - (p->t < q->t);
}

static int by_value(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/* A luma capped at the bright threshold: the lights are judged by their own test, and the
 * motion share is of what the rest of the picture does. */
static double capped(float luma, float thr)
{
    return luma > thr ? thr : luma;
}

/* The first entry of the sorted list whose column is >= col. */
static size_t lower(const seen *s, size_t n, uint64_t col)
{
    size_t lo = 0, hi = n;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (s[mid].col < col)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

csi_status csi_recon_moving_share(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                  uint32_t channels, size_t n, csi_moving_share *out)
{
    *out = (csi_moving_share){0, 0, INFINITY};
    if (n == 0 || g->t < 4)
        return CSI_OK;
    seen *s = malloc(n * sizeof *s);
    float *sorted = malloc(n * sizeof *sorted);
    if (!s || !sorted) {
        free(s);
        free(sorted);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the samples' neighbours over t (%zu samples)", n);
    }
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (uint32_t c = 0; c < channels; c++)
            sum += values[i * channels + c];
        s[i] = (seen){(uint64_t)pos[i].y * g->w + pos[i].x, pos[i].t, (float)(sum / channels)};
        sorted[i] = s[i].luma;
    }
    /* the median by sorting a copy: once per solve, beside an FFT solve of the same samples */
    qsort(sorted, n, sizeof *sorted, by_value);
    const float median = sorted[n / 2];
    free(sorted);
    const float thr = median * 4 > 1 ? median * 4 : 1;
    qsort(s, n, sizeof *s, by_col);
    double sum = 0, sum2 = 0; /* the capped lumas' variance, in the sorted order */
    for (size_t i = 0; i < n; i++) {
        const double l = capped(s[i].luma, thr);
        sum += l, sum2 += l * l;
    }
    const double mean = sum / (double)n, var = sum2 / (double)n - mean * mean;
    const uint32_t far = (g->t + 3) / 4; /* a quarter of the shutter, in frames */
    double energy = 0, moving = 0, near_sum = 0, far_sum = 0;
    size_t bright = 0, held = 0, near_n = 0, far_n = 0;
    for (size_t i = 0; i < n; i++) {
        const uint64_t x = s[i].col % g->w, y = s[i].col / g->w;
        const bool is_bright = s[i].luma > thr;
        const double li = capped(s[i].luma, thr);
        bool found = false;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                if ((dy < 0 && y == 0) || (dy > 0 && y + 1 >= g->h) || (dx < 0 && x == 0) || (dx > 0 && x + 1 >= g->w))
                    continue;
                const uint64_t col = (y + dy) * g->w + (x + dx);
                for (size_t j = lower(s, n, col); j < n && s[j].col == col; j++) {
                    if (j == i)
                        continue;
                    const uint32_t dt = s[j].t > s[i].t ? s[j].t - s[i].t : s[i].t - s[j].t;
                    const double lj = capped(s[j].luma, thr), d2 = (li - lj) * (li - lj);
                    if (dt >= far) {
                        far_sum += d2, far_n++;
                        found = found || s[j].luma > thr;
                    } else if (8 * (uint64_t)dt <= g->t) {
                        near_sum += d2, near_n++;
                    }
                }
            }
        const double e = (double)s[i].luma * s[i].luma;
        energy += e;
        if (is_bright) {
            bright++;
            held += found;
            if (!found)
                moving += e;
        }
    }
    free(s);
    out->held = bright ? (double)held / (double)bright : 0;
    out->lights = energy > 0 ? moving / energy : 0;
    if (near_n && far_n)
        out->motion = var > 0 ? (far_sum / (double)far_n - near_sum / (double)near_n) / (2 * var) : 0;
    return CSI_OK;
}
