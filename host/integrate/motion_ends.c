/* How much a volume's shutter ends differ, from its samples (csi_recon_motion_ends, internal.h):
 * what decides the still basis's transform along t (motion.c).
 *
 * The DFT along t treats the shutter as periodic: its fit joins the last frame to the first, and
 * where they differ (a lamp that leaves the view, a light that dims, a camera that moves in) the
 * difference spreads over the whole temporal spectrum, costing the l1 fit its sparsity and
 * pulling each end towards the other (Shi et al., TOG 2014). The DCT-II mirrors the ends instead.
 * Where the ends are alike, the DFT measured better on still cameras with movers (billiards,
 * Mitsuba's anim_ball: 0.1-0.5 dB per frame), so the choice follows the samples:
 *
 *     ratio = sum_b |a_b - z_b|^2 / sum_b |m_b|^2,
 *
 * a_b and z_b the mean of block b's samples in the shutter's first and last quarter of frames,
 * m_b the mean of all its samples, each squared term less its own sampling variance (s^2 / n from
 * the spread of the block's samples in that set: noise and texture, which would otherwise count
 * as difference), summed over channels and over the blocks holding two samples or more in each
 * quarter. Blocks are squares of output pixels just large enough that each quarter expects 8
 * samples. A ratio of 1 means the ends differ by as much energy as the image holds.
 * Measured (docs/bench/animation.md, session 34): 0.61 at most on 110 Mitsuba volumes without
 * such a change, billiards and the train, and 55 procedural ones; 3.1-11.7 where a lamp leaves
 * the view. Two passes in sample order per set (no cancellation), deterministic. */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* Per block and channel: count, then sum, then (second pass) squared deviations. */
typedef struct {
    double *sum, *ss;
    uint32_t *cnt;
} block_sums;

static void block_pass(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos, const float *values,
                       size_t n, uint32_t B, size_t nbx, size_t nb, uint32_t t0, uint32_t t1, int pass, block_sums *s)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    for (size_t i = 0; i < n; i++) {
        if (pos[i].t < t0 || pos[i].t >= t1)
            continue;
        const size_t b = (size_t)(pos[i].y / bh / B) * nbx + pos[i].x / bw / B;
        if (pass == 0)
            s->cnt[b]++;
        for (uint32_t c = 0; c < channels; c++) {
            const double v = values[i * channels + c];
            if (pass == 0) {
                s->sum[b * channels + c] += v;
            } else {
                const double d = v - s->sum[b * channels + c];
                s->ss[b * channels + c] += d * d;
            }
        }
    }
    if (pass == 0) /* sums become means */
        for (size_t b = 0; b < nb; b++)
            for (uint32_t c = 0; c < channels && s->cnt[b]; c++)
                s->sum[b * channels + c] /= s->cnt[b];
}

csi_status csi_recon_motion_ends(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                 const float *values, size_t n, double *ratio)
{
    *ratio = 0;
    const uint32_t T = g->t, q = T / 4 ? T / 4 : 1;
    if (T < 2 || n == 0)
        return CSI_OK;
    /* blocks whose quarters expect 8 samples each */
    const double per_pixel = (double)n / ((double)g->out_w * g->out_h) * q / T;
    double side = ceil(sqrt(8.0 / per_pixel));
    const uint32_t most = g->out_w < g->out_h ? g->out_w : g->out_h;
    const uint32_t B = side < 1 ? 1 : side > most ? most : (uint32_t)side;
    const size_t nbx = (g->out_w + B - 1) / B, nb = nbx * ((g->out_h + B - 1) / B), nv = nb * channels;
    block_sums set[3];
    double *mem = calloc(3 * 2 * nv, sizeof *mem);
    uint32_t *cnt = calloc(3 * nb, sizeof *cnt);
    if (!mem || !cnt) {
        free(mem), free(cnt);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the shutter ends' sums (%zu blocks)", nb);
    }
    const uint32_t from[3] = {0, T - q, 0}, to[3] = {q, T, T}; /* first quarter, last, all */
    for (int k = 0; k < 3; k++) {
        set[k] = (block_sums){mem + (size_t)k * 2 * nv, mem + (size_t)k * 2 * nv + nv, cnt + (size_t)k * nb};
        block_pass(g, channels, pos, values, n, B, nbx, nb, from[k], to[k], 0, &set[k]);
        block_pass(g, channels, pos, values, n, B, nbx, nb, from[k], to[k], 1, &set[k]);
    }
    double diff = 0, energy = 0;
    for (size_t b = 0; b < nb; b++) {
        const uint32_t na = set[0].cnt[b], nz = set[1].cnt[b], nm = set[2].cnt[b];
        if (na < 2 || nz < 2)
            continue;
        for (uint32_t c = 0; c < channels; c++) {
            const size_t j = b * channels + c;
            const double a = set[0].sum[j], z = set[1].sum[j], m = set[2].sum[j];
            const double va = set[0].ss[j] / (na - 1.0) / na, vz = set[1].ss[j] / (nz - 1.0) / nz;
            const double vm = set[2].ss[j] / (nm - 1.0) / nm;
            diff += (a - z) * (a - z) - va - vz;
            energy += m * m - vm;
        }
    }
    free(mem), free(cnt);
    *ratio = energy > 0 ? diff / energy : 0;
    return CSI_OK;
}
