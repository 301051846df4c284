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
 *   3. in 4 tiles, a tile's image is csi_settle applied to its image without settling, over its
 *      window's samples (shares of the window's disagreement); the tiled run's count is the
 *      cores' pixels that changed;
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

    /* claim 3: 4 tiles, each tile settled in its window */
    csi_recon_options ton = on, toff = off;
    ton.tiles = toff.tiles = 4;
    ton.tile_margin = toff.tile_margin = 4;
    csi_tiling tl;
    CHECK_OK(csi_tiling_layout(ctx, &g, 1, n, &ton, &tl));
    csi_tile_scope scope;
    CHECK_OK(csi_tile_scope_make(ctx, &tl.grid, 1, pos, val, n, &ton, &tl, &scope));
    size_t core_changed = 0, settled_cores = 0;
    for (uint32_t i = 0; i < tl.count; i++) {
        csi_tile_result a, b;
        CHECK_OK(csi_recon_tile(ctx, &tl.grid, 1, pos, val, n, &ton, &tl, &scope, i, &a));
        CHECK_OK(csi_recon_tile(ctx2, &tl.grid, 1, pos, val, n, &toff, &tl, &scope, i, &b));
        csi_tile tt;
        csi_tiling_tile(&tl, i, &tt);
        const csi_tile *t = &tt;
        const uint32_t ww = a.r.out_w, wh = a.r.out_h;
        /* the window's samples, in their order, as the tile sees them */
        csi_sample_pos *wp = malloc(n * sizeof *wp);
        float *wv = malloc(n * sizeof *wv);
        size_t m = 0;
        for (size_t j = 0; j < n; j++) {
            const uint32_t px = pos[j].x / F, py = pos[j].y / F;
            if (px >= t->win0[0] && px < t->win0[0] + ww && py >= t->win0[1] && py < t->win0[1] + wh) {
                wp[m] = (csi_sample_pos){pos[j].x - t->win0[0] * F, pos[j].y - t->win0[1] * F, 0};
                wv[m++] = val[j];
            }
        }
        const csi_grid wg = {ww * F, wh * F, 1, ww, wh};
        float *hand = malloc((size_t)ww * wh * sizeof *hand);
        memcpy(hand, b.r.image, (size_t)ww * wh * sizeof *hand);
        const uint32_t core[4] = {t->core0[0] - t->win0[0], t->core0[1] - t->win0[1], t->core1[0] - t->win0[0],
                                  t->core1[1] - t->win0[1]};
        size_t kt = 0;
        CHECK_OK(csi_settle(&wg, 1, wp, wv, m, hand, core, &kt));
        CHECK(!memcmp(hand, a.r.image, (size_t)ww * wh * sizeof *hand), "tile %u: not csi_settle of its image", i);
        CHECK(a.r.settled == kt, "tile %u: %zu settled, csi_settle says %zu", i, a.r.settled, kt);
        for (uint32_t y = core[1]; y < core[3]; y++)
            for (uint32_t x = core[0]; x < core[2]; x++)
                core_changed += a.r.image[(size_t)y * ww + x] != b.r.image[(size_t)y * ww + x];
        settled_cores += a.r.settled;
        free(wp);
        free(wv);
        free(hand);
        csi_tile_result_free(&a);
        csi_tile_result_free(&b);
    }
    CHECK(settled_cores == core_changed && settled_cores > 0, "the tiles settled %zu core pixels, %zu changed",
          settled_cores, core_changed);
    csi_recon_result t_on;
    CHECK_OK(csi_recon(ctx, &g, 1, pos, val, n, &ton, &t_on));
    CHECK(t_on.tiles == 4 && t_on.settled == settled_cores, "the tiled run: %u tiles, %zu settled, the tiles %zu",
          t_on.tiles, t_on.settled, settled_cores);
    printf("4 tiles: %zu core pixels settled\n", settled_cores);
    csi_recon_result_free(&t_on);
    free(by_hand);
    csi_recon_result_free(&r_on);
    csi_recon_result_free(&r_off);
    free(val);
    free(pos);
    csi_ctx_release(ctx2);
    return test_done();
}
