/* Pixels without a sample beside sub-pixel light sources (csi/empty_pixels.h; issue 9's street
 * lamps), end to end through csi_recon's default (the blend) at 1 spp on Poisson-disk positions,
 * where some pixels get no sample. The scene (tests/support/analytic's 256 x 256 grid, 64 x 64
 * pixels), on a sky of 0.05:
 *   - left half: isolated sources of radiance 300-600, each a square of 3 x 3 cells inside one
 *     pixel's 4 x 4, every 6 pixels (a source's light lives in its pixel alone: every pixel
 *     around it has the sky's truth, 0.05, exactly);
 *   - right half: an extended emitter of 300, a rectangle whose sides cut its edge pixels at a
 *     quarter and three quarters of a pixel (edge pixels really are partly bright).
 * Claims, over 3 position seeds, with noise-free samples, one path per sample and the mean of 64
 * (tests/support's unit-exponential path weights):
 *   1. Every pixel without a sample next to a source pixel comes out within 0.05 of its truth
 *      0.05 with noise-free samples: no worse than the per-pixel mean of the
 *      same samples there (which writes 0), where the fit's blur puts a fraction of the source's
 *      light, many times the sky's value. With noisy samples the sky's own means
 *      spread by their noise, a relative standard deviation of 1 / sqrt(paths): the bound is 0.05
 *      plus 4 such deviations of a sky sample (0.25 with one path, 0.075 with 64).
 *   2. Every pixel without a sample on the emitter's edge whose truth is at least half the
 *      emitter's keeps at least a quarter of its truth (the rule leaves an extended emitter's
 *      edge to the fit; taken for a leak, it would be 0.05), or else stands exactly at the cap,
 *      the geometric midpoint sqrt((D + e) (H + e)) - e of its neighbours' lowest and highest
 *      means (e: 1% of the samples' mean absolute value): where the edge's own pixels' point
 *      samples fall on either side of it, its row and column can both cross the step with no
 *      more of its neighbours bright than dark, as a dark pixel's beside a thin line's bend do,
 *      and the cap takes it (csi/empty_pixels.h).
 *      Either way it is nearer its truth than the mean's 0. Not with one path per sample: there
 *      the blend itself leaves some of them below a tenth of their truth, the rule or not.
 *   3. Reconstructed in 4 tiles (csi/tiles.h), claim 1 holds as well, and every pixel beside a
 *      source where the untiled run took the dark side exactly (the lowest of its neighbours'
 *      means) has that value in the tiled run too, to float rounding of the tiles' blend (1e-6
 *      relative): the rule is local and holds in tiled runs. The largest errors beside a source
 *      are printed. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "analytic.h"
#include "testlib.h"

#define SKY 0.05
#define EMIT 300.0
#define SPACING 6
/* the emitter: [X0, X1) x [Y0, Y1) in pixels */
#define EX0 40.25
#define EX1 56.75
#define EY0 10.75
#define EY1 50.25

static int source_pixel(int px, int py)
{
    return px < 32 && px % SPACING == 3 && py % SPACING == 3;
}

static double scene(double x, double y)
{
    const double u = x * GRID, v = y * GRID; /* cells */
    const int cx = (int)u, cy = (int)v, px = cx / BLK, py = cy / BLK;
    if (source_pixel(px, py) && cx % BLK < 3 && cy % BLK < 3)
        return EMIT + 300.0 * ((px / SPACING * 7 + py / SPACING * 3) % 8) / 7.0;
    const double ox = u / BLK, oy = v / BLK; /* pixels */
    return ox >= EX0 && ox < EX1 && oy >= EY0 && oy < EY1 ? EMIT : SKY;
}

static csi_status run(csi_ctx *ctx, const csi_grid *g, const csi_sample_pos *pos, const float *v, size_t n,
                      uint32_t tiles, csi_recon_result *res)
{
    csi_recon_options o;
    csi_recon_defaults(&o);
    o.tiles = tiles;
    o.tile_margin = tiles > 1 ? 8 : 0;
    return csi_recon(ctx, g, 1, pos, v, n, &o, res);
}

int main(void)
{
    csi_ctx *ctx = NULL;
    REQUIRE_OK(csi_ctx_create(&ctx, NULL));
    static analytic_scene s;
    analytic_scene_make(scene, &s);
    const csi_grid g = {GRID, GRID, 1, OUT, OUT};
    test_rng r;
    test_rng_seed(&r, 7);
    int beside = 0, edge = 0, exact = 0, capped = 0;
    for (int seed = 1; seed <= 3; seed++)
        for (int paths = 0; paths <= 64; paths = paths ? paths * 64 : 1) {
            const csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = 1, .seed = (uint64_t)seed};
            csi_sample_pos *pos = NULL;
            size_t n = 0;
            REQUIRE_OK(csi_positions(&g, &po, &pos, &n, NULL));
            float *v = analytic_sample(&s, pos, n, paths, &r);
            int cnt[NP] = {0};
            double mean[NP] = {0};
            for (size_t i = 0; i < n; i++) {
                const int p = (int)(pos[i].y / BLK) * OUT + (int)(pos[i].x / BLK);
                cnt[p]++;
                mean[p] += v[i];
            }
            for (int p = 0; p < NP; p++)
                mean[p] /= cnt[p] ? cnt[p] : 1;
            double sabs = 0;
            for (size_t i = 0; i < n; i++)
                sabs += fabs(v[i]);
            const double e = 1e-2 * sabs / (double)n;
            csi_recon_result whole, tiled;
            CHECK_OK(run(ctx, &g, pos, v, n, 1, &whole));
            CHECK_OK(run(ctx, &g, pos, v, n, 4, &tiled));
            CHECK(tiled.tiles == 4, "seed %d: %u tiles, not 4", seed, tiled.tiles);
            const double bound = paths ? SKY * (1 + 4.0 / sqrt(paths)) : SKY;
            double worst[2] = {0, 0}; /* beside a source, untiled and tiled */
            for (int p = 0; p < NP && whole.image && tiled.image; p++) {
                if (cnt[p])
                    continue;
                const int px = p % OUT, py = p / OUT;
                int near_source = 0;
                double lowest = INFINITY, highest = -INFINITY;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        const int x = px + dx, y = py + dy;
                        if (x < 0 || y < 0 || x >= OUT || y >= OUT)
                            continue;
                        near_source |= source_pixel(x, y);
                        if (cnt[y * OUT + x])
                            lowest = fmin(lowest, mean[y * OUT + x]), highest = fmax(highest, mean[y * OUT + x]);
                    }
                const float a = whole.image[p], b = tiled.image[p];
                if (near_source) {
                    beside++;
                    worst[0] = fmax(worst[0], fabs(a - SKY));
                    worst[1] = fmax(worst[1], fabs(b - SKY));
                    CHECK(fabs(a - SKY) <= bound, "seed %d, %d paths: pixel (%d, %d) beside a source is %g, "
                          "not within %g of %g", seed, paths, px, py, a, bound, SKY);
                    CHECK(fabs(b - SKY) <= bound, "seed %d, %d paths, 4 tiles: pixel (%d, %d) beside a source "
                          "is %g, not within %g of %g", seed, paths, px, py, b, bound, SKY);
                }
                if (near_source && a == (float)lowest) {
                    exact++;
                    CHECK(fabs(b - a) <= 1e-6 * a, "seed %d, %d paths: pixel (%d, %d) took its dark side %g "
                          "untiled, %g in 4 tiles", seed, paths, px, py, a, b);
                }
                if (paths != 1 && px >= 32 && s.truth[p] >= 0.5 * EMIT && s.truth[p] < EMIT) {
                    const double cap = sqrt((lowest + e) * (highest + e)) - e;
                    edge++;
                    capped += fabs(a - cap) <= 1e-5 * cap;
                    CHECK(a >= 0.25 * s.truth[p] || fabs(a - cap) <= 1e-5 * cap,
                          "seed %d, %d paths: edge pixel (%d, %d) of truth %g is %g, not capped at %g", seed,
                          paths, px, py, s.truth[p], a, cap);
                    CHECK(a > 0 && a < 2 * s.truth[p], "seed %d, %d paths: edge pixel (%d, %d) of truth %g is %g",
                          seed, paths, px, py, s.truth[p], a);
                }
            }
            printf("seed %d, %2d paths: largest error beside a source %.3g, in 4 tiles %.3g\n", seed, paths, worst[0],
                   worst[1]);
            csi_recon_result_free(&whole);
            csi_recon_result_free(&tiled);
            free(pos);
            free(v);
        }
    printf("pixels without a sample: %d beside a source, %d on the emitter's edge (%d of them capped), %d took "
           "their dark side\n", beside, edge, capped, exact);
    CHECK(beside >= 100 && edge >= 20 && exact >= 100, "too few cases: %d, %d, %d", beside, edge, exact);
    csi_ctx_release(ctx);
    return test_done();
}
