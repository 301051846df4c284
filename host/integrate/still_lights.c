/* Whether a volume's bright samples hold still (the still layer's weight, motion.c; issue 12,
 * docs/bench/animation.md session 43).
 *
 * On a fine grid each cell is seen once or twice over the shutter, so a sample alone cannot say
 * whether the light it saw was there at the other times. Its neighbours can: a light that holds
 * still is seen again by the samples of the cells around it at other times, a moving one is
 * gone from them by then. A sample is bright when its channels' mean is above the display's
 * white (1) and above 4 times the median sample's: an HDR light, not a lit surface. A bright
 * sample is held when another bright sample lies within one cell of it in x and y a quarter of
 * the shutter or more away in t. The bright samples hold still when more than half are held:
 * measured on csi-render's exact scenes at 4 and 16 spp, a still lamp, a lantern and a lit sign
 * 0.99-1.0, two lamps moving across a wall 0.06-0.07, movers without lights 0-0.12.
 *
 * Only the bright samples are gathered (few), sorted by cell column; each looks up the nine
 * columns around its own by binary search. The answer does not depend on the samples' order. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

typedef struct {
    uint64_t col; /* y * w + x on the fine grid */
    uint32_t t;
} bright;

static int by_col(const void *a, const void *b)
{
    const bright *p = a, *q = b;
    return p->col < q->col ? -1 : p->col > q->col ? 1 : (p->t > q->t) - (p->t < q->t);
}

static int by_value(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/* The first entry of the sorted list whose column is >= col. */
static size_t lower(const bright *b, size_t nb, uint64_t col)
{
    size_t lo = 0, hi = nb;
    while (lo < hi) {
        const size_t mid = lo + (hi - lo) / 2;
        if (b[mid].col < col)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

csi_status csi_recon_still_lights(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                  uint32_t channels, size_t n, bool *hold)
{
    *hold = false;
    if (n == 0 || g->t < 4)
        return CSI_OK;
    float *luma = malloc(n * sizeof *luma);
    if (!luma)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the bright samples (%zu samples)", n);
    for (size_t i = 0; i < n; i++) {
        double s = 0;
        for (uint32_t c = 0; c < channels; c++)
            s += values[i * channels + c];
        luma[i] = (float)(s / channels);
    }
    /* the median by sorting a copy: once per solve, beside an FFT solve of the same samples */
    float *sorted = malloc(n * sizeof *sorted);
    if (!sorted) {
        free(luma);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the bright samples (%zu samples)", n);
    }
    memcpy(sorted, luma, n * sizeof *sorted);
    qsort(sorted, n, sizeof *sorted, by_value);
    const float median = sorted[n / 2];
    free(sorted);
    const float thr = median * 4 > 1 ? median * 4 : 1;
    size_t nb = 0;
    for (size_t i = 0; i < n; i++)
        nb += luma[i] > thr;
    if (nb == 0) { /* no light: nothing holds still */
        free(luma);
        return CSI_OK;
    }
    bright *b = malloc(nb * sizeof *b);
    if (!b) {
        free(luma);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu bright samples", nb);
    }
    for (size_t i = 0, k = 0; i < n; i++)
        if (luma[i] > thr)
            b[k++] = (bright){(uint64_t)pos[i].y * g->w + pos[i].x, pos[i].t};
    free(luma);
    qsort(b, nb, sizeof *b, by_col);
    const uint32_t gap = (g->t + 3) / 4; /* a quarter of the shutter, in frames */
    size_t held = 0;
    for (size_t i = 0; i < nb; i++) {
        const uint64_t x = b[i].col % g->w, y = b[i].col / g->w;
        bool found = false;
        for (int dy = -1; dy <= 1 && !found; dy++)
            for (int dx = -1; dx <= 1 && !found; dx++) {
                if ((dy < 0 && y == 0) || (dy > 0 && y + 1 >= g->h) || (dx < 0 && x == 0) || (dx > 0 && x + 1 >= g->w))
                    continue;
                const uint64_t col = (y + dy) * g->w + (x + dx);
                for (size_t j = lower(b, nb, col); j < nb && b[j].col == col && !found; j++)
                    found = b[j].t + gap <= b[i].t || b[i].t + gap <= b[j].t;
            }
        held += found;
    }
    free(b);
    *hold = 2 * held > nb;
    return CSI_OK;
}
