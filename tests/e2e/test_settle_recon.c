/* Settling the pixels that decide an image (csi/settle.h) as the last step of a reconstruction,
 * untiled and in tiles, against the rule applied by hand to the same reconstruction without it.
 *
 * A noisy HDR image: the analytic texture (tests/support/analytic.h) on a 512 x 512 grid -> 64 x 64
 * pixels (8 x 8 cells per pixel, csi's grid at 4 spp), with a few small bright spots (5 x 5 cells,
 * 2000:1 over the texture) that a pixel's few samples hit or miss, 4 spp stratified, each value
 * times 1 + uniform noise of half-width 0.3 (noisy samples: the blend, and settling on by
 * default). Claims:
 *   1. untiled, csi_recon's image is bit for bit csi_settle applied to the image csi_recon makes
 *      with --settle off, and its count of settled pixels is csi_settle's; some pixels settle;
 *   2. every pixel it changes moves towards the mean of its own samples, and no further;
 *   3. in 4 tiles, no tile settles its window: each gives the count and sum of its core pixels'
 *      samples (checked by hand), and the tiled run's image is bit for bit csi_settle applied to
 *      the tiled image made with --settle off, over all the samples (shares of the whole image's
 *      disagreement, as untiled), with csi_settle's count;
 * Whether settling lowers the error depends on who was right at the spots, the fit or the few
 * samples' mean (docs/bench/mitsuba.md, sessions 20 and 25): the test prints both MSEs and the
 * mean's, and asserts none of them.
 * The second run of each claim is in a second context, so the bits do not depend on one. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "csi/settle.h"
#include "csi/tiles.h"
#include "analytic.h"
#include "testlib.h"

#define OW 64
#define F 8
#define GW (OW * F)

/* The texture with spots of 5 x 5 cells at 2000 times it, on a lattice of 9 x 7 pixels (off the
 * pixel grid by 3 cells). */
static double scene(uint32_t x, uint32_t y)
{
    const double t = analytic_texture((x + 0.5) / GW, (y + 0.5) / GW);
    const uint32_t lx = x % (9 * F), ly = y % (7 * F);
    return lx >= 3 && lx < 8 && ly >= 3 && ly < 8 ? 2000.0 * (t + 0.1) : t;
}

/* The mean of each pixel's samples (NaN where it has none). */
static void pixel_means(const csi_sample_pos *pos, const float *val, size_t n, double *mean)
{
    double sum[OW * OW] = {0};
    int cnt[OW * OW] = {0};
    for (size_t i = 0; i < n; i++) {
        const size_t p = (size_t)(pos[i].y / F) * OW + pos[i].x / F;
        sum[p] += val[i];
        cnt[p]++;
    }
    for (size_t p = 0; p < OW * OW; p++)
        mean[p] = cnt[p] ? sum[p] / cnt[p] : NAN;
}

int main(void)
{
    csi_ctx *ctx = test_ctx(), *ctx2 = NULL;
    REQUIRE_OK(csi_ctx_create(&ctx2, NULL));
    const csi_grid g = {GW, GW, 1, OW, OW};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    float *val = analytic_noisy_cells(&g, scene, 4, 5, 17, 0.6, &pos, &n);
    if (!val) {
        CHECK(false, "the samples: %s", csi_last_error());
        return test_done();
    }
    static double mean[OW * OW], truth[OW * OW];
    pixel_means(pos, val, n, mean);
    for (uint32_t p = 0; p < OW * OW; p++) { /* each pixel's box mean of the scene over its cells */
        double s = 0;
        for (uint32_t cy = 0; cy < F; cy++)
            for (uint32_t cx = 0; cx < F; cx++)
                s += scene((p % OW) * F + cx, (p / OW) * F + cy);
        truth[p] = s / (F * F);
    }
    const size_t np = OW * OW;

    /* claims 1, 2 and 4: untiled */
    csi_recon_options on, off;
    csi_recon_defaults(&on);
    off = on;
    off.settle = CSI_SWITCH_OFF;
    csi_recon_result r_on, r_off;
    CHECK_OK(csi_recon(ctx, &g, 1, pos, val, n, &on, &r_on));
    CHECK_OK(csi_recon(ctx2, &g, 1, pos, val, n, &off, &r_off));
    CHECK(r_on.options.settle == CSI_SWITCH_ON && r_on.tiles == 1, "settling is not on by default for noisy samples");
    float *by_hand = malloc(np * sizeof *by_hand);
    memcpy(by_hand, r_off.image, np * sizeof *by_hand);
    size_t k = 0;
    CHECK_OK(csi_settle(&g, 1, pos, val, n, by_hand, NULL, &k));
    CHECK(!memcmp(by_hand, r_on.image, np * sizeof *by_hand), "csi_recon's image is not csi_settle of its image without it");
    CHECK(r_on.settled == k && k > 0, "%zu pixels settled, csi_settle says %zu", r_on.settled, k);
    size_t moved = 0, wrong = 0;
    double e_on = 0, e_off = 0;
    for (size_t p = 0; p < np; p++) {
        const double a = r_off.image[p], b = r_on.image[p], m = mean[p];
        e_on += (b - truth[p]) * (b - truth[p]);
        e_off += (a - truth[p]) * (a - truth[p]);
        if (a == b)
            continue;
        moved++;
        /* towards m, not past it (float rounding of the move allowed) */
        wrong += !(fabs(b - m) <= fabs(a - m) && (b - a) * (m - a) > 0 && fabs(b - m) <= fabs(a - m) + 1e-6 * fabs(m));
    }
    CHECK(moved == k && wrong == 0, "%zu pixels moved (%zu settled), %zu not towards their mean", moved, k, wrong);
    double e_mean = 0;
    for (size_t p = 0; p < np; p++)
        e_mean += isnan(mean[p]) ? 0 : (mean[p] - truth[p]) * (mean[p] - truth[p]);
    printf("untiled: %zu pixels settled; MSE %.6e with settling, %.6e without, %.6e the pixels' means\n", k,
           e_on / np, e_off / np, e_mean / np);

    /* claim 3: 4 tiles settle once, on the blended image, as untiled: no tile settles its window;
     * each gives the count and sum of its core pixels' samples; the tiled image is the tiled run
     * without settling, settled by csi_settle on all the samples */
    csi_recon_options ton = on, toff = off;
    ton.tiles = toff.tiles = 4;
    ton.tile_margin = toff.tile_margin = 4;
    csi_tiling tl;
    CHECK_OK(csi_tiling_layout(ctx, &g, 1, n, &ton, &tl));
    csi_tile_scope scope;
    CHECK_OK(csi_tile_scope_make(ctx, &tl.grid, 1, pos, val, n, &ton, &tl, &scope));
    for (uint32_t i = 0; i < tl.count; i++) {
        csi_tile_result a, b;
        CHECK_OK(csi_recon_tile(ctx, &tl.grid, 1, pos, val, n, &ton, &tl, &scope, i, &a));
        CHECK_OK(csi_recon_tile(ctx2, &tl.grid, 1, pos, val, n, &toff, &tl, &scope, i, &b));
        csi_tile tt;
        csi_tiling_tile(&tl, i, &tt);
        const csi_tile *t = &tt;
        const uint32_t ww = a.r.out_w, wh = a.r.out_h;
        CHECK(!memcmp(a.r.image, b.r.image, (size_t)ww * wh * sizeof *a.r.image) && a.r.settled == 0,
              "tile %u: its image settled in its window (%zu pixels)", i, a.r.settled);
        CHECK(a.px_cnt && a.px_sum && !b.px_cnt && !b.px_sum, "tile %u: pixel sums %s with settling, %s without", i,
              a.px_cnt ? "given" : "missing", b.px_cnt ? "given" : "none");
        /* the sums by hand: the samples of the core's pixels, in sample order */
        size_t bad = 0;
        for (uint32_t y = 0; a.px_cnt && y < wh; y++)
            for (uint32_t x = 0; x < ww; x++) {
                const uint32_t gx = t->win0[0] + x, gy = t->win0[1] + y;
                const bool in_core = gx >= t->core0[0] && gx < t->core1[0] && gy >= t->core0[1] && gy < t->core1[1];
                uint32_t c = 0;
                double sum = 0;
                for (size_t j = 0; in_core && j < n; j++)
                    if (pos[j].x / F == gx && pos[j].y / F == gy) {
                        c++;
                        sum += val[j];
                    }
                bad += a.px_cnt[(size_t)y * ww + x] != c || a.px_sum[(size_t)y * ww + x] != sum;
            }
        CHECK(bad == 0, "tile %u: %zu pixels' sums are not their core samples' count and sum", i, bad);
        csi_tile_result_free(&a);
        csi_tile_result_free(&b);
    }
    csi_recon_result t_on, t_off;
    CHECK_OK(csi_recon(ctx, &g, 1, pos, val, n, &ton, &t_on));
    CHECK_OK(csi_recon(ctx2, &g, 1, pos, val, n, &toff, &t_off));
    size_t kt = 0;
    CHECK_OK(csi_settle(&g, 1, pos, val, n, t_off.image, NULL, &kt));
    CHECK(t_on.tiles == 4 && !memcmp(t_on.image, t_off.image, np * sizeof *t_on.image),
          "the tiled run (%u tiles): not the unsettled tiled image settled on all the samples", t_on.tiles);
    CHECK(t_on.settled == kt && kt > 0, "the tiled run: %zu settled, csi_settle on the whole image %zu", t_on.settled,
          kt);
    printf("4 tiles: %zu pixels settled on the blended image\n", kt);
    csi_recon_result_free(&t_off);
    csi_recon_result_free(&t_on);
    free(by_hand);
    csi_recon_result_free(&r_on);
    csi_recon_result_free(&r_off);
    free(val);
    free(pos);
    csi_ctx_release(ctx2);
    return test_done();
}
