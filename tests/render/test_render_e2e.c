/* End to end (issue 5): render bundled scenes at low resolution with the Embree tracer, then
 * compare the compressive reconstruction at 4 spp and stratified Monte Carlo at 4 spp against a
 * 256-spp reference taken at continuous stratified points (not on any grid, so it carries no
 * discretisation of its own). Luminance only (one channel) to keep the test fast; the figures
 * are printed for docs/BENCHMARKS.md. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "csi_tracer.h"
#include "testlib.h"

#define OUT 64

static float luminance(const float *rgb) { return 0.2126f * rgb[0] + 0.7152f * rgb[1] + 0.0722f * rgb[2]; }

/* Loads a bundled scene with its image size replaced by OUT x OUT (and T by `frames` if > 0). */
static csi_scene *load_small(const char *name)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/data/scenes/%s.scene", CSI_SOURCE_DIR, name);
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *text = calloc((size_t)len + 64, 1);
    if (fread(text, 1, (size_t)len, f) != (size_t)len) {
        fclose(f);
        free(text);
        return NULL;
    }
    fclose(f);
    char *sz = strstr(text, "size 256 256");
    if (sz)
        memcpy(sz, "size  64  64", 12);
    char dir[1024];
    snprintf(dir, sizeof dir, "%s/data/scenes", CSI_SOURCE_DIR);
    csi_scene *sc = NULL;
    if (csi_scene_parse(text, path, dir, &sc) != CSI_OK)
        fprintf(stderr, "scene %s: %s\n", name, csi_last_error());
    free(text);
    return sc;
}

/* The reference: per pixel, 16 x 16 jittered strata in x, y (and one stratified time each). */
static float *reference(csi_tracer *tr, uint32_t w, uint32_t h, uint64_t seed)
{
    const int s = 16;
    size_t n = (size_t)w * h * s * s;
    float *uvs = malloc(n * 3 * sizeof(float)), *rgb = malloc(n * 3 * sizeof(float));
    test_rng r;
    test_rng_seed(&r, seed);
    size_t i = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (int a = 0; a < s * s; a++) {
                uvs[3 * i] = (float)((x + ((a % s) + test_rng_uniform(&r)) / s) / w);
                uvs[3 * i + 1] = (float)((y + ((a / s) + test_rng_uniform(&r)) / s) / h);
                /* time: a Latin-hypercube permutation over the pixel's strata */
                uvs[3 * i + 2] = (float)(((a * 97 + 13) % (s * s) + test_rng_uniform(&r)) / (s * s));
                i++;
            }
    float *img = calloc((size_t)w * h, sizeof(float));
    if (csi_tracer_eval_points(tr, uvs, n, seed, rgb, NULL, NULL) != CSI_OK) {
        fprintf(stderr, "reference: %s\n", csi_last_error());
        free(img);
        img = NULL;
    } else {
        for (size_t p = 0; p < (size_t)w * h; p++) {
            double acc = 0;
            for (int a = 0; a < s * s; a++)
                acc += luminance(rgb + 3 * (p * s * s + (size_t)a));
            img[p] = (float)(acc / (s * s));
        }
    }
    free(uvs);
    free(rgb);
    return img;
}

/* Renders at 4 spp with the given positions and reconstructs with the given estimator, the
 * samples flagged with `flags` (CSI_SAMPLES_EXACT: what csi-render says of a plan's samples). */
static double run(csi_tracer *tr, const csi_grid *g, csi_pos_method m, csi_estimator est,
                  csi_aa_correct correct, uint32_t flags, const float *ref, uint64_t seed, double *t_recon)
{
    csi_pos_opts po = {.method = m, .spp = 4, .seed = seed};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(g, &po, &pos, &n, NULL) != CSI_OK) {
        fprintf(stderr, "positions: %s\n", csi_last_error());
        return INFINITY;
    }
    float *rgb = malloc(n * 3 * sizeof(float)), *lum = malloc(n * sizeof(float));
    double mse = INFINITY;
    if (csi_tracer_eval(tr, g, pos, n, seed, rgb, NULL, NULL) == CSI_OK) {
        for (size_t i = 0; i < n; i++)
            lum[i] = luminance(rgb + 3 * i);
        csi_recon_options o;
        csi_recon_defaults(&o);
        o.estimator = est;
        o.correct = correct;
        o.sample_flags = flags;
        csi_recon_result res;
        if (csi_recon(test_ctx(), g, 1, pos, lum, n, &o, &res) == CSI_OK) {
            double acc = 0;
            for (size_t p = 0; p < (size_t)OUT * OUT; p++) {
                double d = (double)res.image[p] - ref[p];
                acc += d * d;
            }
            mse = acc / (OUT * OUT);
            *t_recon = res.t_setup + res.t_solve + res.t_integrate;
            csi_recon_result_free(&res);
        } else {
            fprintf(stderr, "reconstruct: %s\n", csi_last_error());
        }
    } else {
        fprintf(stderr, "trace: %s\n", csi_last_error());
    }
    free(rgb);
    free(lum);
    free(pos);
    return mse;
}

int main(void)
{
    const struct {
        const char *name;
        uint32_t frames;
    } cases[] = {{"triangle", 0}, {"billiards", 16}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        csi_scene *sc = load_small(cases[c].name);
        CHECK(sc != NULL, "scene %s loads", cases[c].name);
        if (!sc)
            continue;
        csi_plan plan;
        csi_plan_overrides ov = {.frames = cases[c].frames};
        REQUIRE_OK(csi_plan_make(sc, &ov, &plan));
        csi_tracer *tr = NULL;
        REQUIRE_OK(csi_tracer_create(sc, &plan, 0, &tr));
        float *ref = reference(tr, OUT, OUT, 99);
        CHECK(ref != NULL, "reference rendered");
        /* Static: a 4x finer grid (the paper's k/p = 16); moving: x, y at pixel rate, T frames. */
        const uint32_t f = plan.frames > 1 ? 1 : 4;
        csi_grid g = {.w = OUT * f, .h = OUT * f, .t = plan.frames, .out_w = OUT, .out_h = OUT};
        double t_cs = 0, t_st = 0;
        /* The compressive estimate with the control-variate correction (--correct cv) against
         * stratified Monte Carlo: the paper's claim. The default on the samples as csi-render
         * flags them (exact when the plan draws no random number) is also run: on an exact
         * still scene it is cv itself (the same image, so the same MSE); it is compared with
         * the mean of its own samples everywhere (the blend's guarantee on noisy samples). The
         * blend on unflagged samples is printed: on the triangle, white on black and
         * noise-free, it leans towards the Poisson-disk samples' own means and does not beat
         * stratified positions (docs/bench/mitsuba.md). */
        const uint32_t flags = plan.exact ? CSI_SAMPLES_EXACT : 0;
        double mse_cs = run(tr, &g, CSI_POS_POISSON, CSI_EST_CS, CSI_CORRECT_CV, flags, ref, 1, &t_cs);
        double t_def = 0, t_pm = 0, t_bl = 0;
        double mse_def = run(tr, &g, CSI_POS_POISSON, CSI_EST_CS, CSI_CORRECT_AUTO, flags, ref, 1, &t_def);
        double mse_bl = run(tr, &g, CSI_POS_POISSON, CSI_EST_CS, CSI_CORRECT_AUTO, 0, ref, 1, &t_bl);
        double mse_pm = run(tr, &g, CSI_POS_POISSON, CSI_EST_MEAN, CSI_CORRECT_AUTO, flags, ref, 1, &t_pm);
        double mse_st = run(tr, &g, CSI_POS_STRATIFIED, CSI_EST_MEAN, CSI_CORRECT_AUTO, flags, ref, 1, &t_st);
        printf("%s (%ux%u, T=%u, grid %ux%u, %s): 4 spp MSE vs 256-spp reference: compressive (cv) %.4g "
               "(reconstruction %.2f s), stratified %.4g, ratio %.2f; default %.4g (ratio %.2f), "
               "unflagged default %.4g (ratio %.2f), mean of the same Poisson samples %.4g\n", cases[c].name, OUT,
               OUT, plan.frames, g.w, g.h, plan.exact ? "exact" : "not exact", mse_cs, t_cs, mse_st,
               mse_cs / mse_st, mse_def, mse_def / mse_st, mse_bl, mse_bl / mse_st, mse_pm);
        if (plan.exact && plan.frames == 1)
            CHECK(mse_def == mse_cs, "%s: exact samples, yet the default's MSE %.6g is not cv's %.6g",
                  cases[c].name, mse_def, mse_cs);
        CHECK(isfinite(mse_cs) && isfinite(mse_st) && isfinite(mse_def) && isfinite(mse_pm) && isfinite(mse_bl),
              "%s: every method ran", cases[c].name);
        CHECK(mse_cs < mse_st, "%s: compressive MSE %.4g is not below stratified's %.4g at 4 spp",
              cases[c].name, mse_cs, mse_st);
        CHECK(mse_def <= mse_pm, "%s: the default's MSE %.4g is above the mean of its own samples "
              "(%.4g)", cases[c].name, mse_def, mse_pm);
        free(ref);
        csi_tracer_free(tr);
        csi_plan_free(&plan);
        csi_scene_free(sc);
    }
    return test_done();
}
