/* The cross-validated choice inside a reconstruction (csi/cv_select.h), against the same choice
 * composed by hand from its documented parts.
 *
 * A noisy image: the analytic texture (tests/support/analytic.h) on a 512 x 512 grid -> 64 x 64
 * pixels (8 x 8 cells per pixel, csi's grid at 4 spp), with HDR squares in its left half where
 * the fit leaks and the choice gives regions their means; 4 spp stratified (every pixel has two
 * samples in each fold), each value times 1 + uniform noise of half-width 0.3, so the blend
 * applies and the choice is on by default (noisy samples, 4 samples per pixel). Claims:
 *   1. csi_recon's image is, bit for bit, the whole reconstruction with the choice off, then
 *      csi_cv_choose on the folds of csi_cv_folds, each fold reconstructed from its own samples
 *      with the choice off, the folds' model grid (CSI_CV_FOLD_SIGMA_MIN) and the folds' stop
 *      (CSI_CV_FOLD_TOL); and the count of pixels it gave their mean is csi_cv_choose's;
 *   2. the folds at the image's own stop (3e-3) are other images than at CSI_CV_FOLD_TOL, after
 *      more steps, and give another choice, so claim 1 sees the folds' stop;
 *   3. a caller's stop looser than CSI_CV_FOLD_TOL (0.1, where a fold is another image again) is
 *      the folds' too: they never run tighter than the image.
 * The second run of each claim is in a second context, so the bits do not depend on one. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/cv_select.h"
#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "analytic.h"
#include "testlib.h"

#define OW 64
#define F 8
#define GW (OW * F)
/* a caller's stop looser than the folds' (claim 3) */
#define LOOSE 0.1

/* The texture, with bright squares of 11 x 11 cells (HDR, 1000:1 over the texture, placed off
 * the pixel grid) on a lattice of 4 x 4 pixels in the left half. */
static double scene(uint32_t x, uint32_t y)
{
    const double t = analytic_texture((x + 0.5) / GW, (y + 0.5) / GW);
    const uint32_t lx = x % (4 * F), ly = y % (4 * F);
    return x < GW / 2 && lx >= 13 && lx < 24 && ly >= 13 && ly < 24 ? 1000.0 * (t + 0.1) : t;
}

/* One fold's reconstruction from its own samples, as the choice documents it. */
static float *fold_image(csi_ctx *ctx, const csi_grid *g, const csi_sample_pos *pos, const float *val,
                         size_t n, const uint8_t *fold, uint8_t f, const csi_recon_options *base, double tol,
                         int *steps)
{
    csi_sample_pos *fp = malloc(n * sizeof *fp);
    float *fv = malloc(n * sizeof *fv);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (fold[i] == f) {
            fp[m] = pos[i];
            fv[m++] = val[i];
        }
    csi_recon_options o = *base;
    o.cv_select = CSI_SWITCH_OFF;
    o.model_sigma_min = CSI_CV_FOLD_SIGMA_MIN;
    o.tol = tol;
    csi_recon_result r;
    float *img = NULL;
    if (csi_recon(ctx, g, 1, fp, fv, m, &o, &r) == CSI_OK) {
        img = r.image;
        r.image = NULL;
        *steps = r.report[0].iterations;
        csi_recon_result_free(&r);
    } else {
        CHECK(false, "fold %u: %s", f, csi_last_error());
    }
    free(fp);
    free(fv);
    return img;
}

/* Claim 1 (and 3 with a caller's tol): csi_recon with the choice against the composition. */
static void composed(csi_ctx *ctx, csi_ctx *ctx2, const csi_grid *g, const csi_sample_pos *pos,
                     const float *val, size_t n, double caller_tol, double fold_tol)
{
    const size_t np = (size_t)OW * OW;
    csi_recon_options o;
    csi_recon_defaults(&o);
    o.tol = caller_tol; /* 0: auto */
    csi_recon_result auto_run, whole;
    CHECK_OK(csi_recon(ctx, g, 1, pos, val, n, &o, &auto_run));
    CHECK(auto_run.options.cv_select == CSI_SWITCH_ON, "the choice is not on for noisy samples at 4 spp");
    csi_recon_options off = o;
    off.cv_select = CSI_SWITCH_OFF;
    CHECK_OK(csi_recon(ctx2, g, 1, pos, val, n, &off, &whole));
    uint8_t *fold = malloc(n);
    size_t pairs = 0, switched = 0;
    CHECK_OK(csi_cv_folds(g, pos, n, fold, &pairs));
    CHECK(pairs == np, "%zu of %zu pixels hold both folds", pairs, np);
    int sa = 0, sb = 0;
    float *a = fold_image(ctx2, g, pos, val, n, fold, 0, &o, fold_tol, &sa);
    float *b = fold_image(ctx2, g, pos, val, n, fold, 1, &o, fold_tol, &sb);
    if (a && b && auto_run.image && whole.image) {
        CHECK_OK(csi_cv_choose(g, 1, pos, val, n, fold, a, b, CSI_CV_REGION, whole.image, &switched));
        CHECK(!memcmp(auto_run.image, whole.image, np * sizeof(float)),
              "tol %g: the choice in csi_recon is not the composition with folds at tol %g", caller_tol, fold_tol);
        CHECK(auto_run.cv_switched == switched, "switched %zu, composed %zu", auto_run.cv_switched, switched);
        printf("caller tol %g, folds at %g: %zu pixels given their mean, fold steps %d + %d\n", caller_tol,
               fold_tol, switched, sa, sb);
    }
    free(a);
    free(b);
    free(fold);
    csi_recon_result_free(&auto_run);
    csi_recon_result_free(&whole);
}

int main(void)
{
    csi_ctx *ctx = test_ctx(), *ctx2 = NULL;
    REQUIRE_OK(csi_ctx_create(&ctx2, NULL));
    const csi_grid g = {GW, GW, 1, OW, OW};
    const csi_pos_opts po = {.method = CSI_POS_STRATIFIED, .spp = 4, .seed = 3};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    REQUIRE_OK(csi_positions(&g, &po, &pos, &n, NULL));
    float *val = malloc(n * sizeof *val);
    csi_rng rng;
    csi_rng_seed(&rng, 11);
    for (size_t i = 0; i < n; i++)
        val[i] = (float)(scene(pos[i].x, pos[i].y) * (1.0 + 0.6 * (csi_rng_uniform(&rng) - 0.5)));
    composed(ctx, ctx2, &g, pos, val, n, 0, CSI_CV_FOLD_TOL);
    /* claims 2 and 3 see the stop: the folds at the image's own stop (3e-3) and at a loose one
     * (LOOSE) are other images than at CSI_CV_FOLD_TOL, and at 3e-3 they make another choice */
    {
        uint8_t *fold = malloc(n);
        CHECK_OK(csi_cv_folds(&g, pos, n, fold, NULL));
        csi_recon_options o;
        csi_recon_defaults(&o);
        int s1 = 0, s2 = 0, s3 = 0, t1 = 0, t2 = 0;
        const size_t np = (size_t)OW * OW, bytes = np * sizeof(float);
        float *a1 = fold_image(ctx, &g, pos, val, n, fold, 0, &o, CSI_CV_FOLD_TOL, &s1);
        float *a2 = fold_image(ctx, &g, pos, val, n, fold, 0, &o, 3e-3, &s2);
        float *a3 = fold_image(ctx, &g, pos, val, n, fold, 0, &o, LOOSE, &s3);
        float *b1 = fold_image(ctx, &g, pos, val, n, fold, 1, &o, CSI_CV_FOLD_TOL, &t1);
        float *b2 = fold_image(ctx, &g, pos, val, n, fold, 1, &o, 3e-3, &t2);
        CHECK(a1 && a2 && memcmp(a1, a2, bytes), "fold 0 at tol %g and 3e-3: the same image", CSI_CV_FOLD_TOL);
        CHECK(s2 > s1 && t2 > t1, "folds: %d + %d steps at 3e-3, %d + %d at %g", s2, t2, s1, t1, CSI_CV_FOLD_TOL);
        CHECK(a1 && a3 && memcmp(a1, a3, bytes), "fold 0 at tol %g and %g: the same image", CSI_CV_FOLD_TOL, LOOSE);
        if (a1 && a2 && b1 && b2) {
            float *c1 = calloc(np, sizeof *c1), *c2 = calloc(np, sizeof *c2);
            size_t w1 = 0, w2 = 0;
            CHECK_OK(csi_cv_choose(&g, 1, pos, val, n, fold, a1, b1, CSI_CV_REGION, c1, &w1));
            CHECK_OK(csi_cv_choose(&g, 1, pos, val, n, fold, a2, b2, CSI_CV_REGION, c2, &w2));
            CHECK(memcmp(c1, c2, bytes), "the folds at 3e-3 and at %g choose the same pixels", CSI_CV_FOLD_TOL);
            printf("folds: %d + %d steps at 3e-3 (%zu pixels given their mean), %d + %d at %g (%zu); fold 0 "
                   "%d at %g\n", s2, t2, w2, s1, t1, CSI_CV_FOLD_TOL, w1, s3, LOOSE);
            free(c1);
            free(c2);
        }
        free(a1);
        free(a2);
        free(a3);
        free(b1);
        free(b2);
        free(fold);
    }
    /* claim 3: a caller's stop looser than the folds' is theirs too */
    composed(ctx, ctx2, &g, pos, val, n, LOOSE, LOOSE);
    free(val);
    free(pos);
    csi_ctx_release(ctx2);
    return test_done();
}
