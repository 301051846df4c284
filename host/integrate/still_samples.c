/* Whether a volume's samples are a noise-free still picture (the still layer's weight,
 * motion.c; issue 12, docs/bench/animation.md session 30).
 *
 * Where the picture holds still and the samples carry no noise, every sample of a pixel has the
 * same value, whatever its time: exact point samples of a still photograph. A path tracer's
 * samples differ at every time (each is one Monte Carlo estimate), and so do the samples of a
 * pixel something moves through. So the share of the pixels holding two samples or more whose
 * samples are all equal, bit for bit in every channel, tells the two kinds of volume apart: on
 * the benchmark's still photographs with movers it is 0.89-1.0, on every path-traced animation
 * 0. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

csi_status csi_recon_still_exact_share(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                       uint32_t channels, size_t n, double *share)
{
    const size_t ow = g->out_w, np = ow * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    /* each pixel's first sample, and whether every later one equals it */
    size_t *first = malloc(np * sizeof *first);
    uint32_t *count = calloc(np, sizeof *count);
    unsigned char *differ = calloc(np, 1);
    if (!first || !count || !differ) {
        free(first), free(count), free(differ);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the samples' agreement over t (%zu pixels)", np);
    }
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_of(pos[i], bw, bh, ow);
        if (count[p]++ == 0)
            first[p] = i;
        else if (!differ[p])
            differ[p] = memcmp(values + i * channels, values + first[p] * channels, channels * sizeof *values) != 0;
    }
    size_t multi = 0, equal = 0;
    for (size_t p = 0; p < np; p++)
        if (count[p] >= 2) {
            multi++;
            equal += !differ[p];
        }
    *share = multi ? (double)equal / (double)multi : 0;
    free(first), free(count), free(differ);
    return CSI_OK;
}
