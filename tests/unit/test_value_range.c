/* Any finite float32 reconstructs (csi_reconstruct scales a channel whose magnitude is far from 1
 * by a power of two, solves, and scales back): docs/dump-format.md's contract, which the reader
 * and the solver now agree on.
 *
 * Reference: the same samples at ordinary magnitudes (max ~1). Multiplying every sample by 2^s
 * multiplies the samples the solver sees by a power of two only, and every step of the methods is
 * homogeneous in the data (linear operators, thresholds and stopping rules relative to norms of
 * the data, compensated sums, square roots of sums of squares: all exact under a power-of-two
 * scale in float while nothing overflows or underflows), so the result must be the reference
 * times 2^s bit for bit: checked for s = +100 and -100 (samples near 1e30 and 1e-30, which
 * overflowed or vanished in the solver before), for Alg. 1, Alg. 2 and both baselines. Near the
 * top of the range (samples up to 1.5e38) the scaled-back image saturates at FLT_MAX instead of
 * becoming infinite: every pixel is finite and equals min(ref * 2^127, FLT_MAX). */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "testlib.h"

static void one(const char *name, const csi_grid *g, csi_recon_options o)
{
    csi_ctx *ctx = test_ctx();
    const uint32_t ch = 2;
    csi_pos_opts po = {.method = CSI_POS_RANDOM, .fraction = 0.2, .seed = 5};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(0, "%s: positions: %s", name, csi_last_error());
        return;
    }
    float *v = malloc(n * ch * sizeof *v), *vs = malloc(n * ch * sizeof *v);
    test_rng r;
    test_rng_seed(&r, 9);
    for (size_t i = 0; i < n * ch; i++) /* max magnitude just under 1: no scaling at this size */
        v[i] = (float)(0.9 * test_rng_uniform(&r) - (i % 7 == 0 ? 0.3 : 0.0));
    o.max_iter = 20;
    o.frames = g->t > 1 && o.estimator != CSI_EST_MEAN; /* the per-pixel mean makes no frames */
    csi_recon_result ref, got;
    CHECK_OK(csi_recon(ctx, g, ch, pos, v, n, &o, &ref));
    const size_t np = (size_t)g->out_w * g->out_h;
    const int shifts[] = {100, -100, 127};
    for (int k = 0; k < 3 && ref.image; k++) {
        const int s = shifts[k];
        for (size_t i = 0; i < n * ch; i++)
            vs[i] = ldexpf(v[i], s);
        csi_status st = csi_recon(ctx, g, ch, pos, vs, n, &o, &got);
        CHECK(st == CSI_OK, "%s, samples x 2^%d: %s", name, s, csi_last_error());
        if (st != CSI_OK)
            continue;
        size_t bad = 0, first = 0;
        for (size_t p = 0; p < np * ch; p++) {
            double want = ldexp((double)ref.image[p], s);
            want = want > FLT_MAX ? FLT_MAX : want < -FLT_MAX ? -FLT_MAX : want;
            if ((!isfinite(got.image[p]) || got.image[p] != (float)want) && bad++ == 0)
                first = p;
        }
        CHECK(bad == 0, "%s, samples x 2^%d: %zu pixels differ from the reference x 2^%d (first %zu: %g vs %g)",
              name, s, bad, s, first, (double)got.image[first], ldexp((double)ref.image[first], s));
        if (got.frames && ref.frames) {
            size_t fb = 0;
            for (size_t p = 0; p < np * ch * got.nframes; p++) {
                double want = fmin(fmax(ldexp((double)ref.frames[p], s), -FLT_MAX), FLT_MAX);
                fb += got.frames[p] != (float)want;
            }
            CHECK(fb == 0, "%s, samples x 2^%d: %zu frame pixels differ", name, s, fb);
        }
        csi_recon_result_free(&got);
    }
    csi_recon_result_free(&ref);
    free(v);
    free(vs);
    free(pos);
}

int main(void)
{
    csi_recon_options o;
    const csi_grid img = {32, 32, 1, 8, 8}, vol = {16, 16, 8, 8, 8};
    csi_recon_defaults(&o);
    one("Alg. 1", &img, o);
    one("Alg. 2", &vol, o);
    o.estimator = CSI_EST_GAUSS;
    one("Gaussian baseline", &img, o);
    o.estimator = CSI_EST_MEAN;
    one("sample mean", &vol, o);
    return test_done();
}
