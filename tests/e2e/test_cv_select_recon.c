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
 *   4. tiles (4 of them, 4-pixel margins, so that a window starts off the choice's 8-pixel
 *      regions): each tile makes the choice in its window. A tile's image is, pixel by pixel,
 *      either the tile's image with the choice off (bit for bit) or the mean of the pixel's
 *      samples; the pixels given their mean fill the whole image's regions (aligned to the
 *      image's pixel (0, 0), not the window's) wholly or not at all; some are; and the tiled
 *      image with the choice is closer to the truth (each pixel's box mean of the scene over its
 *      cells) in relMSE than the tiled image without it, as the untiled one is than its own (the
 *      plain MSE is the HDR squares', which the choice leaves alike). The run's count of pixels
 *      given their mean is the cores': no fewer than the choice changed there, no more than are at
 *      their mean.
 * The second run of each claim is in a second context, so the bits do not depend on one. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/cv_select.h"
#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "csi/tiles.h"
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
    o.settle = CSI_SWITCH_OFF; /* as the library's folds */
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
    o.settle = CSI_SWITCH_OFF; /* the choice alone: the settling after it (csi/settle.h) has a test of its own */
    o.cv_smooth = CSI_SWITCH_OFF; /* and so has its smoothing candidates (csi/cv_smooth.h) */
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

/* issue 9's relative MSE: (x - ref)^2 / (ref^2 + 0.01), the measure the choice's D also uses
 * (CSI_CV_REL_FLOOR); the plain MSE here is the HDR squares' alone */
static double rel_mse_vs(const float *img, const double *truth, size_t np)
{
    double e = 0;
    for (size_t p = 0; p < np; p++)
        e += (img[p] - truth[p]) * (img[p] - truth[p]) / (truth[p] * truth[p] + CSI_CV_REL_FLOOR);
    return e / (double)np;
}

/* Claim 4: the choice in each tile's window. */
static void tiled(csi_ctx *ctx, csi_ctx *ctx2, const csi_grid *g, const csi_sample_pos *pos, const float *val,
                  size_t n)
{
    const size_t np = (size_t)OW * OW;
    double *truth = calloc(np, sizeof *truth), *sum = calloc(np, sizeof *sum);
    uint32_t *cnt = calloc(np, sizeof *cnt);
    for (uint32_t y = 0; y < GW; y++)
        for (uint32_t x = 0; x < GW; x++)
            truth[(y / F) * OW + x / F] += scene(x, y) / (F * F);
    for (size_t i = 0; i < n; i++) {
        const size_t p = (pos[i].y / F) * OW + pos[i].x / F;
        sum[p] += val[i];
        cnt[p]++;
    }
    csi_recon_options on, off;
    csi_recon_defaults(&on);
    on.settle = CSI_SWITCH_OFF; /* the choice alone, as above */
    on.cv_smooth = CSI_SWITCH_OFF;
    on.tiles = 4;
    on.tile_margin = 4;
    off = on;
    off.cv_select = CSI_SWITCH_OFF;
    csi_tiling tl;
    CHECK_OK(csi_tiling_layout(ctx, g, 1, n, &on, &tl));
    csi_tile_scope scope;
    CHECK_OK(csi_tile_scope_make(ctx, g, 1, pos, val, n, &on, &tl, &scope));
    /* over the tiles' cores (which partition the image): pixels the choice changed, pixels at their mean */
    size_t switched = 0, blocks_mixed = 0, neither = 0, core_changed = 0, core_at_mean = 0;
    for (uint32_t i = 0; i < tl.count; i++) {
        csi_tile_result a, b;
        CHECK_OK(csi_recon_tile(ctx, g, 1, pos, val, n, &on, &tl, &scope, i, &a));
        CHECK_OK(csi_recon_tile(ctx2, g, 1, pos, val, n, &off, &tl, &scope, i, &b));
        CHECK(a.r.options.cv_select == CSI_SWITCH_ON, "tile %u: the choice is not on", i);
        const uint32_t w = a.r.out_w, h = a.r.out_h;
        /* per pixel: bit 0, at its mean; bit 1, changed by the choice */
        uint8_t *px = calloc((size_t)w * h, 1);
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                const size_t q = (size_t)y * w + x, p = (size_t)(a.y0 + y) * OW + a.x0 + x;
                const double m = sum[p] / cnt[p];
                px[q] = fabs(a.r.image[q] - m) <= 1e-6 * fabs(m);
                if (a.r.image[q] != b.r.image[q]) {
                    px[q] |= 2;
                    neither += !(px[q] & 1);
                }
            }
        /* the regions: in every 8 x 8 block of the image's (aligned to its pixel (0, 0)), cut at
         * the window's sides, where the choice changed a pixel every pixel is at its mean (the
         * blend alone puts some there too) */
        for (uint32_t by = a.y0 / CSI_CV_REGION; by * CSI_CV_REGION < a.y0 + h; by++)
            for (uint32_t bx = a.x0 / CSI_CV_REGION; bx * CSI_CV_REGION < a.x0 + w; bx++) {
                size_t at_mean = 0, changed = 0, of = 0;
                for (uint32_t Y = by * CSI_CV_REGION; Y < (by + 1) * CSI_CV_REGION; Y++)
                    for (uint32_t X = bx * CSI_CV_REGION; X < (bx + 1) * CSI_CV_REGION; X++)
                        if (Y >= a.y0 && Y < a.y0 + h && X >= a.x0 && X < a.x0 + w) {
                            const uint8_t v = px[(size_t)(Y - a.y0) * w + X - a.x0];
                            of++;
                            at_mean += v & 1;
                            changed += v >> 1;
                        }
                blocks_mixed += changed && at_mean != of;
            }
        for (size_t q = 0; q < (size_t)w * h; q++)
            switched += px[q] >> 1;
        csi_tile t;
        csi_tiling_tile(&tl, i, &t);
        for (uint32_t Y = t.core0[1]; Y < t.core1[1]; Y++)
            for (uint32_t X = t.core0[0]; X < t.core1[0]; X++) {
                const uint8_t v = px[(size_t)(Y - a.y0) * w + X - a.x0];
                core_changed += v >> 1;
                core_at_mean += v & 1;
            }
        free(px);
        csi_tile_result_free(&a);
        csi_tile_result_free(&b);
    }
    CHECK(neither == 0, "%zu tile pixels are neither the image without the choice nor their mean", neither);
    CHECK(blocks_mixed == 0, "%zu of the image's regions are given their mean in part", blocks_mixed);
    CHECK(switched > 0, "the choice changed no pixel of any tile");
    bool offside = false;
    for (uint32_t i = 0; i < tl.count; i++) {
        csi_tile t;
        csi_tiling_tile(&tl, i, &t);
        offside |= t.win0[0] % CSI_CV_REGION || t.win0[1] % CSI_CV_REGION;
    }
    CHECK(offside, "no window starts off the regions: the claim on regions would not see their origin");
    /* against the truth: tiled, and untiled for comparison */
    csi_recon_result t_on, t_off, w_on, w_off;
    CHECK_OK(csi_recon(ctx, g, 1, pos, val, n, &on, &t_on));
    CHECK_OK(csi_recon(ctx2, g, 1, pos, val, n, &off, &t_off));
    csi_recon_options won, woff;
    csi_recon_defaults(&won);
    won.settle = CSI_SWITCH_OFF;
    won.cv_smooth = CSI_SWITCH_OFF;
    woff = won;
    woff.cv_select = CSI_SWITCH_OFF;
    CHECK_OK(csi_recon(ctx, g, 1, pos, val, n, &won, &w_on));
    CHECK_OK(csi_recon(ctx2, g, 1, pos, val, n, &woff, &w_off));
    CHECK(t_on.tiles == 4 && t_on.options.cv_select == CSI_SWITCH_ON, "the tiled run: %u tiles, the choice %s",
          t_on.tiles, t_on.options.cv_select == CSI_SWITCH_ON ? "on" : "not on");
    /* its count: each pixel once, in its tile's core; at least the pixels the choice changed there,
     * at most those at their mean (the blend alone puts some there) */
    CHECK(core_changed <= t_on.cv_switched && t_on.cv_switched <= core_at_mean,
          "the tiled run says %zu pixels were given their mean; its tiles' cores changed %zu and hold %zu at "
          "their mean", t_on.cv_switched, core_changed, core_at_mean);
    if (t_on.image && t_off.image && w_on.image && w_off.image) {
        const double a = rel_mse_vs(t_on.image, truth, np), b = rel_mse_vs(t_off.image, truth, np);
        const double c = rel_mse_vs(w_on.image, truth, np), d = rel_mse_vs(w_off.image, truth, np);
        CHECK(c < d, "untiled: relMSE with the choice %.4e, without %.4e", c, d);
        CHECK(a < b, "4 tiles: relMSE with the choice %.4e, without %.4e", a, b);
        printf("relMSE against the truth: untiled %.6e with the choice, %.6e without; 4 tiles %.6e with it in "
               "every window (%zu pixels changed by it), %.6e without\n", c, d, a, switched, b);
    }
    csi_recon_result_free(&t_on);
    csi_recon_result_free(&t_off);
    csi_recon_result_free(&w_on);
    csi_recon_result_free(&w_off);
    free(truth);
    free(sum);
    free(cnt);
}

int main(void)
{
    csi_ctx *ctx = test_ctx(), *ctx2 = NULL;
    REQUIRE_OK(csi_ctx_create(&ctx2, NULL));
    const csi_grid g = {GW, GW, 1, OW, OW};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    float *val = analytic_noisy_cells(&g, scene, 4, 3, 11, 0.6, &pos, &n);
    if (!val) {
        CHECK(false, "the samples: %s", csi_last_error());
        return test_done();
    }
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
    tiled(ctx, ctx2, &g, pos, val, n);
    free(val);
    free(pos);
    csi_ctx_release(ctx2);
    return test_done();
}
