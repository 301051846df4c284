/* The per-pixel correction of Alg. 2's blurred image (csi_aa_correct AUTO for a volume whose
 * basis is still; docs/bench/animation.md has the measurements).
 *
 * Each pixel's samples over t estimate its mean in two unbiased ways (over where in the pixel's
 * cells the samples fell): their mean m, and the control variate b + d, d = mean over the
 * pixel's samples of the residual y - g (g the fitted volume, b its box mean over the pixel).
 * The second varies only as much as the residual does over the pixel's cells: where g follows
 * what moves through the pixel, much less than m, whose samples see the mover at a few of the
 * frames (the tracer's billiards at 16 spp: m is 4.5x stratified's image MSE). Where g is
 * biased (a Fourier fit of a still texture between the movers, ringing from them), d removes
 * the bias. Where g is right, d only adds the noise of a few residuals; so d is shrunk by its
 * estimated risk, as the blend (blend.c) shrinks m - b:
 *
 *     out = b + k d,   k = B^2 / (B^2 + V),
 *
 *   V   the variance of d: s^2 / n_p (1 - n_p / cells), s^2 the variance of the residuals over
 *       the pixel's cells, estimated as the largest of: the pixel's own (when it has 3 samples
 *       or more), the pooled spread within the 3 x 3 pixels around (the sum of their squared
 *       deviations from their own means over the sum of their n_p - 1), and the spread of all
 *       their residuals about one common mean. The last one also counts how the residual
 *       varies from pixel to pixel: an overestimate where the fit's bias does, but the only
 *       one with enough residuals at about one sample per pixel (3% of 32 frames), where the
 *       within-pixel ones rest on a handful of pairs (without it, the image of
 *       tests/e2e/test_quality_motion.c at 1/T of the cells was 6.1e-4 against the tuned
 *       Gaussian's 5.6e-4; 5.3e-4 with it). Every choice errs towards b, the fit,
 *       which is the better image at low rates. The finite-population factor makes V = 0, so
 *       out = m exactly, when every cell is sampled.
 *   B^2 the squared bias of b, E d^2 - V, averaged over the 3 x 3 pixels with samples and
 *       clipped at 0: a fit's bias spans regions (a texture it cannot represent), and one
 *       pixel's d^2 is as noisy as V.
 *
 * Exact samples (noise-free point values, CSI_SAMPLES_EXACT) of a pixel holding two or more take
 * the whole correction, k = 1: b + d, the control variate itself. V above counts the spread
 * between the 3 x 3 pixels' residuals, which the fit's own bias makes (a texture, an HDR light
 * it smears), as if it were noise; a noise-free d carries none, and its spread over the pixel's
 * cells is the residual's over t alone, which two samples or more over the shutter (stratified
 * ones: one in each of its stretches) bound. Measured on csi-render's exact scenes with still
 * cameras and movers and a dolly (docs/bench/animation.md, session 40): lower image MSE at 4-16
 * spp on all three; on a path tracer's samples the shrinkage stays (billiards at 16 spp lost a
 * third without it). A pixel of one sample keeps the shrinkage: one residual can be a fit's miss
 * anywhere over its shutter.
 *
 * The result is then projected onto the range the volume was (sample_range.c: the samples in
 * the pixel and its 8 neighbours, a wider window where the pixel's values change over t): no
 * halo, and non-negative samples give a non-negative image. A pixel without a sample, which has
 * no correction, is last kept within the range of its 8 neighbours. Frames are left as the fit
 * gave them. All in double, in sample order (deterministic). */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The 3 x 3 pixels around p, clipped to the image: rows y0..y1, columns x0..x1. */
typedef struct {
    size_t x0, x1, y0, y1;
} box3;

static box3 around(size_t p, size_t ow, size_t oh)
{
    const size_t x = p % ow, y = p / ow;
    return (box3){x ? x - 1 : 0, x + 1 < ow ? x + 1 : x, y ? y - 1 : 0, y + 1 < oh ? y + 1 : y};
}

csi_status csi_recon_motion_correct(const csi_grid *g, const float *values, uint32_t channels,
                                    uint32_t c, const csi_sample_pos *pos, const float *fine_at,
                                    size_t n, const float *range, bool exact, float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    csi_px_resid *st = calloc(np, sizeof *st);
    if (!st)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the per-pixel correction (%zu pixels)", np);
    for (size_t i = 0; i < n; i++) {
        csi_px_resid *s = &st[csi_recon_pixel_of(pos[i], bw, bh, ow)];
        const float y = values[i * channels + c];
        s->d += (double)y - (double)fine_at[i];
        s->n++;
    }
    for (size_t p = 0; p < np; p++)
        if (st[p].n)
            st[p].d /= st[p].n;
    /* the spread about each pixel's mean residual: a second pass, no cancellation */
    for (size_t i = 0; i < n; i++) {
        csi_px_resid *s = &st[csi_recon_pixel_of(pos[i], bw, bh, ow)];
        const double r = (double)values[i * channels + c] - (double)fine_at[i] - s->d;
        s->ss += r * r;
    }
    csi_recon_motion_correct_pixels(g, st, range, exact, plane);
    free(st);
    return CSI_OK;
}

void csi_recon_motion_correct_pixels(const csi_grid *g, csi_px_resid *st, const float *range, bool exact,
                                     float *plane)
{
    const size_t ow = g->out_w, oh = g->out_h, np = ow * oh;
    const double cells = (double)(g->w / g->out_w) * (g->h / g->out_h) * g->t;
    for (size_t p = 0; p < np; p++) {
        if (!st[p].n)
            continue;
        double ss = 0, dof = 0, sum = 0, cnt = 0;
        const box3 r = around(p, ow, oh);
        for (size_t y = r.y0; y <= r.y1; y++)
            for (size_t x = r.x0; x <= r.x1; x++) {
                const csi_px_resid *q = &st[y * ow + x];
                ss += q->ss;
                dof += q->n ? q->n - 1.0 : 0.0;
                sum += q->n * q->d;
                cnt += q->n;
            }
        /* the spread of all the residuals of the 3 x 3 pixels about their common mean: within
         * the pixels plus between their means */
        double all = ss;
        for (size_t y = r.y0; y <= r.y1; y++)
            for (size_t x = r.x0; x <= r.x1; x++) {
                const csi_px_resid *q = &st[y * ow + x];
                all += q->n * (q->d - sum / cnt) * (q->d - sum / cnt);
            }
        double s2 = fmax(dof > 0 ? ss / dof : 0, cnt > 1 ? all / (cnt - 1) : 0);
        if (st[p].n >= 3)
            s2 = fmax(s2, st[p].ss / (st[p].n - 1.0));
        st[p].v = s2 / st[p].n * fmax(1.0 - st[p].n / cells, 0.0);
        st[p].e = st[p].d * st[p].d - st[p].v;
    }
    for (size_t p = 0; p < np; p++) {
        if (!st[p].n)
            continue;
        double e = 0, m = 0;
        const box3 r = around(p, ow, oh);
        for (size_t y = r.y0; y <= r.y1; y++)
            for (size_t x = r.x0; x <= r.x1; x++) {
                const csi_px_resid *q = &st[y * ow + x];
                if (q->n) {
                    e += q->e;
                    m += 1;
                }
            }
        const float lo = range[2 * p], hi = range[2 * p + 1];
        const double b2 = fmax(e / m, 0.0), v = st[p].v;
        const double k = (exact && st[p].n >= 2) || !(b2 + v > 0) ? 1.0 : b2 / (b2 + v);
        const double out = (double)plane[p] + k * st[p].d;
        plane[p] = fminf(fmaxf((float)out, lo), hi);
    }
    /* A pixel without a sample has nothing of its own to say: it is not allowed an extremum
     * among its 8 neighbours either, each channel within their range. Where the basis fits a
     * mover poorly the fit gives such a pixel a value off on its own (a speck of another colour
     * beside a path-traced ball, docs/bench/animation.md session 31); on a still photograph's
     * exact samples the fit between the samples rarely leaves that range. The bounds are all
     * taken before any is applied (v and e, scratch of the pixels with samples only, hold them),
     * so the order of the pixels does not matter. */
    for (size_t p = 0; p < np; p++) {
        if (st[p].n)
            continue;
        const box3 r = around(p, ow, oh);
        double lo = INFINITY, hi = -INFINITY;
        for (size_t y = r.y0; y <= r.y1; y++)
            for (size_t x = r.x0; x <= r.x1; x++)
                if (y * ow + x != p) {
                    lo = fmin(lo, (double)plane[y * ow + x]);
                    hi = fmax(hi, (double)plane[y * ow + x]);
                }
        st[p].v = lo;
        st[p].e = hi;
    }
    for (size_t p = 0; p < np; p++)
        if (!st[p].n && st[p].v <= st[p].e)
            plane[p] = (float)fmin(fmax((double)plane[p], st[p].v), st[p].e);
}
