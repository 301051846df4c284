/* The blurred image of a volume split in time windows from one solve of the whole shutter,
 * binned in t (csi_recon_options.tile_image_binned; csi/tiles.h).
 *
 * A time window's model sees only its own stretch of the shutter: its still content rests on
 * its own samples, and the blend of the windows' frames was measured up to 14% above the whole
 * volume's image MSE (docs/bench/scale.md). The image needs only the mean over t, and that does
 * not need every frame: the tile's x/y window over the whole shutter, its T frames merged b at
 * a time into T' = ceil(T / b) bins (csi_tiling_bin_t: no more than a window's frames), is one
 * problem no larger than a time window's, with every sample the window's x/y column holds.
 * Samples that fall into one cell of the binned grid are averaged (the sampling operator takes
 * one value per cell). Equal bins keep a constant velocity constant (b times the cells per
 * frame), so the sheared basis and its search work on the bins as on the frames; what moves
 * within a bin is seen at the times its samples fell, and the mean over the bins averages it
 * as the shutter does (a last bin of fewer frames counts as a whole one: a bias of its share). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

csi_status csi_recon_binned_image(csi_ctx *ctx, const csi_tiling *tl, const csi_tile *tile, uint32_t channels,
                                  const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, const csi_tile_scope *scope,
                                  csi_recon_result *out)
{
    memset(out, 0, sizeof *out);
    const csi_grid *G = &tl->grid;
    const uint32_t bw = G->w / G->out_w, bh = G->h / G->out_h, T = G->t, b = csi_tiling_bin_t(tl);
    const uint32_t Tb = (T + b - 1) / b;
    const uint32_t x0 = tile->win0[0] * bw, x1 = x0 + tl->window[0] * bw;
    const uint32_t y0 = tile->win0[1] * bh, y1 = y0 + tl->window[1] * bh;
    const csi_grid bg = {.w = x1 - x0, .h = y1 - y0, .t = Tb, .out_w = tl->window[0], .out_h = tl->window[1]};
    const size_t cells = (size_t)bg.w * bg.h * bg.t;
    /* each binned cell's first sample in sample order names its record: deterministic */
    uint32_t *slot = malloc(cells * sizeof *slot);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += pos[i].x >= x0 && pos[i].x < x1 && pos[i].y >= y0 && pos[i].y < y1;
    csi_sample_pos *bp = malloc((m ? m : 1) * sizeof *bp);
    double *sum = calloc((m ? m : 1) * channels, sizeof *sum);
    uint32_t *cnt = calloc(m ? m : 1, sizeof *cnt);
    float *bv = NULL;
    csi_status s = CSI_OK;
    if (!slot || !bp || !sum || !cnt)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the binned shutter of tile %u (%zu cells)",
                     tile->index, cells);
    size_t u = 0;
    for (size_t c = 0; s == CSI_OK && c < cells; c++)
        slot[c] = UINT32_MAX;
    for (size_t i = 0; s == CSI_OK && i < n; i++) {
        const csi_sample_pos q = pos[i];
        if (!(q.x >= x0 && q.x < x1 && q.y >= y0 && q.y < y1))
            continue;
        const csi_sample_pos at = {q.x - x0, q.y - y0, q.t / b};
        const size_t c = csi_grid_index(&bg, at);
        if (slot[c] == UINT32_MAX) {
            slot[c] = (uint32_t)u;
            bp[u++] = at;
        }
        for (uint32_t ch = 0; ch < channels; ch++)
            sum[(size_t)slot[c] * channels + ch] += values[i * channels + ch];
        cnt[slot[c]]++;
    }
    if (s == CSI_OK && !(bv = malloc((u ? u : 1) * channels * sizeof *bv)))
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the binned shutter of tile %u", tile->index);
    for (size_t j = 0; s == CSI_OK && j < u; j++)
        for (uint32_t ch = 0; ch < channels; ch++)
            bv[j * channels + ch] = (float)(sum[j * channels + ch] / cnt[j]);
    free(slot);
    free(sum);
    free(cnt);
    /* The binned problem's whole: the volume's cells on T' frames, and its samples as many as
     * this column's share of cells merged leaves (the filter width and the tau rule follow
     * them); the tau scale (the mean sample) is the volume's, which averaging keeps. */
    csi_tile_scope bs = *scope;
    bs.k = scope->k / T * Tb;
    bs.n = m ? (uint64_t)llround((double)scope->n * (double)u / (double)m) : scope->n;
    csi_recon_options o = *opt;
    o.frames = false;
    o.tiles = 0;
    /* what is given per frame is per bin on the binned grid */
    o.motion_vx = opt->motion_vx * b;
    o.motion_vy = opt->motion_vy * b;
    if (opt->motion_resid_sigma_t > 0)
        o.motion_resid_sigma_t = opt->motion_resid_sigma_t / b;
    if (s == CSI_OK && u == 0) {
        const size_t np = (size_t)bg.out_w * bg.out_h;
        out->out_w = bg.out_w;
        out->out_h = bg.out_h;
        out->channels = channels;
        out->image = calloc(np * channels, sizeof(float));
        if (!out->image)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for tile %u", tile->index);
    } else if (s == CSI_OK) {
        s = csi_recon_scoped(ctx, &bg, channels, bp, bv, u, &o, &bs, NULL, out);
    }
    free(bp);
    free(bv);
    if (s != CSI_OK) {
        csi_recon_result_free(out);
        return csi_fail_context(s, "the binned shutter of tile %u: ", tile->index);
    }
    return CSI_OK;
}
