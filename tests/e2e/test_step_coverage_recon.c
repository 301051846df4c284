/* An HDR step's pixels given the coverage their window's samples allow (csi/step_coverage.h), in
 * a whole reconstruction (csi_recon with the samples' variances): lamps of 200 on a floor of 0.05
 * (discs 1.5 to 6 pixels in radius and a bar), 64 x 64 pixels on the analytic scenes' 4x grid
 * (tests/support/analytic.h: the truth is each pixel's box average by 32 x 32 points), 4 and 8
 * samples per pixel (at 8, Poisson-disk pixels of 8 samples or more whose boundary holds take
 * its coverage), noise-free with variance 0 (an emitter seen directly: every path reads the same),
 * stratified and Poisson-disk positions, seeds 1-3; against the same run with
 * --step-coverage off:
 *   1. the result counts as moved exactly the pixels whose values differ, and some move;
 *   2. the squared error against the truth, summed over the runs, is at most the run's without
 *      the step (the step's promise where its gates hold), and below it;
 *   3. without the variances the step does not run: no pixel counted, the same image as off;
 *   4. in 2 tiles (seed 1, both position sets) the step moves the same pixels by the same amounts
 *      as untiled (each tile's changes of its core, added after the blend's settling): the
 *      pixels where the step on and off differ are the untiled run's, and each difference is the
 *      untiled one to float rounding (1e-5 of the lamps' 200). */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>

#include "analytic.h"
#include "csi/reconstruct.h"
#include "testlib.h"

static double lamps(double x, double y)
{
    static const double disc[][3] = {{0.2, 0.25, 1.5}, {0.55, 0.2, 2.5}, {0.8, 0.6, 4.0}, {0.3, 0.7, 6.0}};
    for (size_t i = 0; i < sizeof disc / sizeof *disc; i++) {
        const double dx = (x - disc[i][0]) * OUT, dy = (y - disc[i][1]) * OUT;
        if (dx * dx + dy * dy < disc[i][2] * disc[i][2])
            return 200.0;
    }
    /* a bar at a slant */
    const double u = (x - 0.6) * 0.94 + (y - 0.85) * 0.34, v = -(x - 0.6) * 0.34 + (y - 0.85) * 0.94;
    return fabs(u) < 0.15 && fabs(v) < 0.03 ? 200.0 : 0.05;
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    static analytic_scene s;
    analytic_scene_make(lamps, &s);
    const csi_grid g = {GRID, GRID, 1, OUT, OUT};
    const csi_pos_method methods[2] = {CSI_POS_STRATIFIED, CSI_POS_POISSON};
    for (uint32_t spp = 4; spp <= 8; spp *= 2) {
    double e_on = 0, e_off = 0;
    size_t moved_all = 0;
    for (int mi = 0; mi < 2; mi++)
        for (uint64_t seed = 1; seed <= 3; seed++) {
            csi_sample_pos *pos;
            size_t n;
            float *v = analytic_draw(&s, methods[mi], spp, seed, seed, 0, &pos, &n);
            REQUIRE_OK(v ? CSI_OK : CSI_ERR_NOMEM);
            float *var = calloc(n, sizeof *var);
            csi_recon_result res[3];
            for (int k = 0; k < 3; k++) { /* step on, off, and on without the variances */
                csi_recon_options o;
                csi_recon_defaults(&o);
                o.sample_variance = k == 2 ? NULL : var;
                o.step_coverage = k == 1 ? CSI_SWITCH_OFF : CSI_SWITCH_AUTO;
                REQUIRE_OK(csi_recon(ctx, &g, 1, pos, v, n, &o, &res[k]));
            }
            size_t differ = 0, differ_novar = 0;
            for (int p = 0; p < NP; p++) {
                differ += res[0].image[p] != res[1].image[p];
                e_on += (res[0].image[p] - s.truth[p]) * (res[0].image[p] - s.truth[p]);
                e_off += (res[1].image[p] - s.truth[p]) * (res[1].image[p] - s.truth[p]);
            }
            /* 3. without the variances: the same image as without them and with the step off */
            csi_recon_result plain;
            csi_recon_options o;
            csi_recon_defaults(&o);
            o.step_coverage = CSI_SWITCH_OFF;
            REQUIRE_OK(csi_recon(ctx, &g, 1, pos, v, n, &o, &plain));
            for (int p = 0; p < NP; p++)
                differ_novar += res[2].image[p] != plain.image[p];
            CHECK(res[0].step_moved == differ, "%s, seed %d: %zu pixels counted as moved, %zu differ",
                  csi_pos_method_name(methods[mi]), (int)seed, res[0].step_moved, differ);
            CHECK(res[2].step_moved == 0 && differ_novar == 0,
                  "%s, seed %d: without variances %zu pixels counted, %zu differ from the step off",
                  csi_pos_method_name(methods[mi]), (int)seed, res[2].step_moved, differ_novar);
            moved_all += differ;
            if (seed == 1) { /* 4. in 2 tiles */
                csi_recon_result tiled[2];
                for (int k = 0; k < 2; k++) {
                    csi_recon_options ot;
                    csi_recon_defaults(&ot);
                    ot.sample_variance = var;
                    ot.tiles = 2;
                    ot.tile_margin = 8;
                    ot.step_coverage = k == 1 ? CSI_SWITCH_OFF : CSI_SWITCH_AUTO;
                    REQUIRE_OK(csi_recon(ctx, &g, 1, pos, v, n, &ot, &tiled[k]));
                }
                size_t same_set = 0, close = 0, tdiffer = 0;
                for (int p = 0; p < NP; p++) {
                    const bool ut = res[0].image[p] != res[1].image[p], tt = tiled[0].image[p] != tiled[1].image[p];
                    const double du = (double)res[0].image[p] - res[1].image[p];
                    const double dt = (double)tiled[0].image[p] - tiled[1].image[p];
                    same_set += ut == tt, tdiffer += tt, close += fabs(du - dt) <= 2e-3;
                }
                CHECK(tiled[0].tiles == 2 && same_set == NP && close == NP && tiled[0].step_moved == res[0].step_moved,
                      "%s, 2 tiles: %zu pixels moved (untiled %zu), %zu of %d pixels moved alike, %zu by the same "
                      "amount to 2e-3", csi_pos_method_name(methods[mi]), tdiffer, differ, same_set, NP, close);
                for (int k = 0; k < 2; k++)
                    csi_recon_result_free(&tiled[k]);
            }
            for (int k = 0; k < 3; k++)
                csi_recon_result_free(&res[k]);
            csi_recon_result_free(&plain);
            free(pos), free(v), free(var);
        }
    printf("lamps, %u spp, 6 runs: squared error with the step %.5g, without %.5g; %zu pixels moved\n", spp, e_on,
           e_off, moved_all);
    CHECK(moved_all > 0, "%u spp: no pixel moved", spp);
    CHECK(e_on < e_off, "%u spp: squared error with the step %.6g, without %.6g", spp, e_on, e_off);
    }
    return test_done();
}
