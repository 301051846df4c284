/* ROMP on the paper's image problem (Alg. 1; docs/bench/romp.md): what its measured settings
 * do, asserted on dumps made here from the analytic images of test_quality_aa.c (same
 * functions, same 256 x 256 -> 64 x 64 grid, same supersampled box-average truth; see that
 * file for why 8 x 8 points per cell cannot decide a comparison).
 *
 * Configurations (all Poisson-disk positions, except stratified Monte Carlo):
 *   published  ROMP as Needell & Vershynin publish it (s from N, stop at 2s, raw correlations)
 *              with csi's integration (sharp target, CV correction): --romp-preset published
 *   paper      the same ROMP with the paper's integration (f_b, no correction, the paper's
 *              Gaussian width): the paper's Alg. 1 as written
 *   csi        csi's ROMP settings for images (csi_recon's ROMP defaults: s = N/64,
 *              support limit 0.15 N, coarse block + coarsest detail level seeded, one CG
 *              step per least squares)
 *   sparsa     csi_recon's defaults (SpaRSA), the default solver of Alg. 1, with the CV
 *              correction (--correct cv) like the ROMP configurations
 *   mean       stratified Monte Carlo (the per-pixel mean of stratified samples)
 * Claims, MSE averaged over position seeds 1..3 at 4 spp, on both images:
 *   1. csi's ROMP settings have a lower MSE than the published ROMP, with either integration;
 *   2. SpaRSA's defaults have a lower MSE than ROMP with csi's settings (why SpaRSA stays the
 *      default solver of Alg. 1);
 *   3. against stratified Monte Carlo, as measured (docs/bench/romp.md): csi's ROMP is below
 *      stratified on both images (2 seeds: triangle 3.38e-4 vs 4.69e-4, texture 3.41e-4 vs
 *      5.55e-4), and the published ROMP is above it on the triangle (5.79e-4: the spiky result
 *      of issue 3 item 5).
 * With 3 seeds this test measured, published / paper / csi / SpaRSA / stratified:
 *   triangle 5.68e-4 / 7.09e-4 / 3.18e-4 / 3.09e-4 / 4.82e-4;
 *   texture  4.08e-4 / 1.98e-3 / 3.51e-4 / 3.16e-4 / 5.68e-4.
 * The tightest margin is claim 2 on the triangle (3%): positions and solves are deterministic,
 * so the figures are fixed, and a change that flips it means the default solver of Alg. 1
 * should be measured again (docs/bench/romp.md), which is what the failure message says.
 * The test prints every figure it compares. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "analytic.h"
#include "testlib.h"

#define MAX_SEEDS 3

typedef enum { CFG_PUBLISHED, CFG_PAPER, CFG_CSI, CFG_SPARSA, CFG_MEAN, CFG_N } config;
static const char *cfg_name[CFG_N] = {"published", "paper", "csi", "sparsa", "mean"};

/* Reconstructs from positions made with (config, spp, seed); writes the NP-pixel image. */
static bool run(csi_ctx *ctx, const analytic_scene *s, config cfg, uint32_t spp, uint64_t seed, float *img)
{
    const csi_grid g = {GRID, GRID, 1, OUT, OUT};
    const csi_pos_opts po = {.method = cfg == CFG_MEAN ? CSI_POS_STRATIFIED : CSI_POS_POISSON,
                             .spp = spp, .seed = seed};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(&g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(false, "positions: %s", csi_last_error());
        return false;
    }
    float *val = malloc(n * sizeof *val);
    for (size_t i = 0; i < n; i++)
        val[i] = s->fine[pos[i].y * GRID + pos[i].x];
    csi_recon_options o;
    csi_recon_defaults(&o);
    /* The solvers are compared through the control-variate correction these claims were
     * measured with (docs/bench/romp.md): the default blend (issue 9) leans each pixel towards
     * its own samples by weights estimated from them, which narrows the differences between
     * fine estimates that this test is about. */
    o.correct = CSI_CORRECT_CV;
    switch (cfg) {
    case CFG_PAPER:
        o.output = CSI_AA_FILTERED;
        o.correct = CSI_CORRECT_NONE;
        o.sigma_spacing = 0;
        /* fall through */
    case CFG_PUBLISHED: o.solver = CSI_SOLVER_ROMP; o.romp_preset = CSI_ROMP_PRESET_PUBLISHED; break;
    case CFG_CSI: o.solver = CSI_SOLVER_ROMP; break;
    case CFG_SPARSA: break;
    case CFG_MEAN: o.estimator = CSI_EST_MEAN; break;
    default: break;
    }
    csi_recon_result r;
    csi_status st = csi_recon(ctx, &g, 1, pos, val, n, &o, &r);
    CHECK(st == CSI_OK, "reconstruct (%s, spp %u, seed %llu): %s", cfg_name[cfg], spp,
          (unsigned long long)seed, st == CSI_OK ? "" : csi_last_error());
    if (st == CSI_OK) {
        CHECK(cfg != CFG_SPARSA || r.options.solver == CSI_SOLVER_SPARSA, "the default solver is %s",
              csi_recon_choice_name("solver", r.options.solver));
        /* csi's support limit is the stopping rule for images: reported as such */
        CHECK(cfg != CFG_CSI || (r.report[0].converged && r.options.solver == CSI_SOLVER_ROMP),
              "csi's ROMP: %s", r.report[0].message);
        memcpy(img, r.image, NP * sizeof(float));
        csi_recon_result_free(&r);
    }
    free(pos);
    free(val);
    return st == CSI_OK;
}

/* Mean MSE over seeds 1..nseeds. */
static double measure(csi_ctx *ctx, const analytic_scene *s, config cfg, uint32_t spp, int nseeds)
{
    static float img[NP];
    double mse = 0;
    for (int k = 0; k < nseeds; k++) {
        if (!run(ctx, s, cfg, spp, (uint64_t)k + 1, img))
            return INFINITY;
        double e = 0;
        for (int p = 0; p < NP; p++)
            e += (img[p] - s->truth[p]) * (img[p] - s->truth[p]);
        mse += e / NP / nseeds;
    }
    return mse;
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    static analytic_scene sc;
    const analytic_image *images = analytic_images;
    for (int i = 0; i < ANALYTIC_IMAGES; i++) {
        analytic_scene_make(images[i].fn, &sc);
        double m[CFG_N];
        for (int c = 0; c < CFG_N; c++) {
            m[c] = measure(ctx, &sc, (config)c, 4, MAX_SEEDS);
            printf("%-8s 4 spp, %d seeds: MSE %-9s %.3e\n", images[i].name, MAX_SEEDS, cfg_name[c], m[c]);
        }
        const char *im = images[i].name;
        CHECK(m[CFG_CSI] < m[CFG_PUBLISHED], "%s: csi's ROMP %.3e not below the published ROMP's %.3e",
              im, m[CFG_CSI], m[CFG_PUBLISHED]);
        CHECK(m[CFG_CSI] < m[CFG_PAPER], "%s: csi's ROMP %.3e not below the paper's Alg. 1 with "
              "ROMP %.3e", im, m[CFG_CSI], m[CFG_PAPER]);
        CHECK(m[CFG_SPARSA] < m[CFG_CSI], "%s: SpaRSA's defaults %.3e not below csi's ROMP %.3e (measure the default solver "
              "of Alg. 1 again: docs/bench/romp.md)", im,
              m[CFG_SPARSA], m[CFG_CSI]);
        CHECK(m[CFG_CSI] < m[CFG_MEAN], "%s: csi's ROMP %.3e not below stratified's %.3e", im,
              m[CFG_CSI], m[CFG_MEAN]);
        if (i == 0)
            CHECK(m[CFG_PUBLISHED] > m[CFG_MEAN], "%s: the published ROMP %.3e is no longer above "
                  "stratified's %.3e (update docs/bench/romp.md)", im, m[CFG_PUBLISHED], m[CFG_MEAN]);
    }
    return test_done();
}
