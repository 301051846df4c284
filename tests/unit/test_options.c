/* The option table: its defaults are the values the methods used before the table existed
 * (exact bits), every value reads back as it was written, bad values are refused with the
 * option's name and leave the options untouched, and the autos resolve to the closed-form
 * rules of the methods (csi/reconstruct.h) and only where they apply. */
#include <math.h>
#include <string.h>

#include "csi/reconstruct.h"
#include "csi/solve.h"
#include "csi/wavelet.h"
#include "testlib.h"

static bool same(const csi_recon_options *a, const csi_recon_options *b)
{
    return memcmp(a, b, sizeof *a) == 0;
}

int main(void)
{
    csi_recon_options d;
    csi_recon_defaults(&d);
    CHECK(csi_last_error()[0] == '\0', "the defaults left an error: %s", csi_last_error());
    /* The fixed defaults, as literals of the code before the table (bit-exact: lambda is a
     * float read from the text "0.3"). */
    float lam = 0.3f;
    CHECK(memcmp(&d.lambda, &lam, sizeof lam) == 0, "lambda %.9g", (double)d.lambda);
    CHECK(d.sigma_scale == 1.0 && d.sigma_spacing == 0.8 && d.cv_n0 == 8.0 && d.seed == 1,
          "sigma_scale %g sigma_spacing %g cv_n0 %g seed %llu", d.sigma_scale, d.sigma_spacing,
          d.cv_n0, (unsigned long long)d.seed);
    CHECK(d.estimator == CSI_EST_CS && d.wavelet == CSI_WAVELET_DB4 && d.output == CSI_AA_SHARP &&
              d.romp_preset == CSI_ROMP_PRESET_CSI && !d.frames && !d.motion_full_spectrum &&
              !d.motion_debias && !d.progress,
          "fixed choices");
    /* Everything problem-dependent starts as auto, spelled 0. */
    CHECK(d.solver == CSI_SOLVER_AUTO && d.levels == 0 && d.tol == 0 && d.max_iter == 0 &&
              d.tau_rel == 0 && d.stop == CSI_STOP_AUTO && d.continuation == CSI_SWITCH_AUTO &&
              d.debias == CSI_SWITCH_AUTO && d.correct == CSI_CORRECT_AUTO && d.gauss_sigma == 0 &&
              d.romp_s == 0 && d.romp_max_support == 0 && d.romp_normalize == CSI_SWITCH_AUTO &&
              d.romp_seed_levels == 0 && d.romp_lsq_iter == 0 && d.motion_resid_sigma == 0 &&
              d.model_grid == CSI_SWITCH_AUTO && d.mem_budget == 0 && d.tiles == 0 &&
              d.tile_margin == 0 && d.tile_margin_t == 0 && d.cont_step == 0 &&
              d.cont_tol == 0,
          "autos");

    /* Every row: described, its default text is what get prints for the defaults, and get ->
     * set -> get is the identity on the options. */
    const size_t count = csi_option_count();
    CHECK(count >= 33, "%zu options", count);
    for (size_t i = 0; i < count; i++) {
        csi_option_info info;
        CHECK_OK(csi_option_describe(i, &info));
        CHECK(info.name && info.help && info.def && strchr(info.name, '_') == NULL, "row %zu", i);
        char text[64];
        CHECK_OK(csi_recon_option_get(&d, info.name, text, sizeof text));
        CHECK(strcmp(text, info.def) == 0, "%s: default prints '%s', the table says '%s'", info.name,
              text, info.def);
        CHECK((info.auto_rule != NULL) == (strcmp(info.def, "auto") == 0), "%s: auto rule", info.name);
        csi_recon_options o = d;
        CHECK_OK(csi_recon_option_set(&o, info.name, text));
        CHECK(same(&o, &d), "%s: '%s' does not read back", info.name, text);
    }
    CHECK(csi_option_describe(count, &(csi_option_info){0}) == CSI_ERR_ARG, "row past the end");

    /* Values: shortest text that reads back the same bits. */
    csi_recon_options o = d;
    char text[64];
    CHECK_OK(csi_recon_option_set(&o, "tau", "0.1"));
    CHECK(o.tau_rel == 0.1, "tau %.17g", o.tau_rel);
    CHECK_OK(csi_recon_option_get(&o, "tau", text, sizeof text));
    CHECK(strcmp(text, "0.1") == 0, "tau prints %s", text);
    CHECK_OK(csi_recon_option_set(&o, "lambda", "0.123456789"));
    CHECK_OK(csi_recon_option_get(&o, "lambda", text, sizeof text));
    csi_recon_options back = d;
    CHECK_OK(csi_recon_option_set(&back, "lambda", text));
    CHECK(back.lambda == o.lambda, "lambda %s reads back as %.9g, not %.9g", text, (double)back.lambda,
          (double)o.lambda);
    CHECK_OK(csi_recon_option_set(&o, "seed", "18446744073709551615"));
    CHECK(o.seed == UINT64_MAX, "seed %llu", (unsigned long long)o.seed);
    CHECK_OK(csi_recon_option_set(&o, "solver", "ROMP"));
    CHECK(o.solver == CSI_SOLVER_ROMP, "choices ignore case");
    CHECK_OK(csi_recon_option_set(&o, "full-spectrum", "on"));
    CHECK(o.motion_full_spectrum, "flag on");
    CHECK_OK(csi_recon_option_set(&o, "mem-budget", "512M"));
    CHECK(o.mem_budget == 512ull << 20, "512M = %llu bytes", (unsigned long long)o.mem_budget);
    CHECK_OK(csi_recon_option_set(&o, "mem-budget", "3GiB"));
    CHECK(o.mem_budget == 3ull << 30, "3GiB = %llu bytes", (unsigned long long)o.mem_budget);
    CHECK_OK(csi_recon_option_get(&o, "mem-budget", text, sizeof text));
    CHECK(strcmp(text, "3221225472") == 0, "a budget prints in bytes: %s", text);

    /* auto and off: one spelling each (0 and -1), whatever the text. */
    o = d;
    CHECK_OK(csi_recon_option_set(&o, "romp-seed-levels", "off"));
    CHECK(o.romp_seed_levels == -1, "seed levels off = %d", o.romp_seed_levels);
    CHECK_OK(csi_recon_option_set(&o, "motion-resid-sigma", "-3.5"));
    CHECK(o.motion_resid_sigma == -1, "a negative width is off, spelled -1: %g", o.motion_resid_sigma);
    CHECK_OK(csi_recon_option_get(&o, "motion-resid-sigma", text, sizeof text));
    CHECK(strcmp(text, "off") == 0, "off prints %s", text);
    CHECK_OK(csi_recon_option_set(&o, "motion-resid-sigma", "0"));
    CHECK(o.motion_resid_sigma == 0, "0 is auto");
    CHECK_OK(csi_recon_option_set(&o, "cont-step", "off"));
    CHECK(o.cont_step == -1, "cont-step off = %g", o.cont_step);
    CHECK(csi_recon_option_set(&o, "cont-step", "1") == CSI_ERR_ARG &&
              csi_recon_option_set(&o, "cont-step", "-0.5") == CSI_ERR_ARG,
          "a continuation step must be below 1, and off is spelled off");
    CHECK_OK(csi_recon_option_set(&o, "tol", "auto"));
    CHECK(o.tol == 0, "auto");
    double v;
    CHECK(csi_recon_option_number(&o, "tol", &v) == CSI_ERR_ARG, "auto has no number");
    CHECK(csi_recon_option_number(&o, "solver", &v) == CSI_ERR_ARG, "a choice has no number");
    CHECK_OK(csi_recon_option_number(&o, "sigma-spacing", &v));
    CHECK(v == 0.8, "sigma-spacing %g", v);

    /* Refusals: the option's name first, nothing changed. */
    struct {
        const char *name, *value;
    } bad[] = {{"lambda", "abc"}, {"lambda", "0"}, {"levels", "17"}, {"levels", "2.5"},
               {"levels", "off"}, {"romp-seed-levels", "-2"}, {"romp-max-support", "2.5"},
               {"solver", "cg"}, {"full-spectrum", "maybe"}, {"seed", "-1"}, {"tau", "nan"},
               {"tol", "1e400"}, {"max-iter", ""}, {"sigma-spacing", "auto"},
               {"mem-budget", "1000"}, {"mem-budget", "2X"}, {"mem-budget", "-1G"}, {"tiles", "0.5"}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        o = d;
        csi_status st = csi_recon_option_set(&o, bad[i].name, bad[i].value);
        CHECK(st == CSI_ERR_ARG && strncmp(csi_last_error(), bad[i].name, strlen(bad[i].name)) == 0 &&
                  same(&o, &d),
              "%s '%s': %s", bad[i].name, bad[i].value, csi_last_error());
    }
    CHECK(csi_recon_option_set(&o, "no-such", "1") == CSI_ERR_ARG && strstr(csi_last_error(), "no-such"),
          "unknown name");
    /* a refusal names the range as a user types it (it was [1, 1.04858e+06] for --tiles) */
    CHECK(csi_recon_option_set(&o, "tiles", "2000000") == CSI_ERR_ARG && strstr(csi_last_error(), "[1, 1048576]"),
          "tiles 2000000: %s", csi_last_error());
    CHECK(csi_recon_option_set(&o, "lambda", "abc") == CSI_ERR_ARG && strstr(csi_last_error(), "[1e-12, 1000000]"),
          "lambda abc: %s", csi_last_error());

    /* Resolution. Alg. 1, SpaRSA: 64x64 grid, 16x16 output, n = 600 samples (spp 2.34). */
    csi_grid still = {64, 64, 1, 16, 16};
    csi_recon_options r;
    CHECK_OK(csi_recon_resolve(&d, &still, 600, &r));
    const double spp = 600.0 / 256.0;
    int lv = csi_wavelet_default_levels(CSI_WAVELET_DB4, 64, 64);
    CHECK(r.solver == CSI_SOLVER_SPARSA && r.levels == (lv > 5 ? 5 : lv) && r.correct == CSI_CORRECT_BLEND &&
              r.stop == CSI_STOP_OBJECTIVE && r.tol == 3e-3 && r.max_iter == 300 &&
              r.debias == CSI_SWITCH_OFF && r.continuation == CSI_SWITCH_ON && r.cont_step == 0.1 &&
              r.cont_tol == 3e-2 &&
              r.model_grid == CSI_SWITCH_ON && r.tau_rel == fmin(3e-3, fmax(1e-5, 3e-3 / spp)),
          "image SpaRSA: levels %d tau %g", r.levels, r.tau_rel);
    CHECK(r.romp_s == 0 && r.gauss_sigma == 0 && r.motion_resid_sigma == 0, "what does not apply stays auto");
    csi_recon_options r2;
    CHECK_OK(csi_recon_resolve(&r, &still, 600, &r2));
    CHECK(same(&r, &r2), "resolving twice changes nothing");
    /* correct = auto follows what the samples are (csi/csi.h CSI_SAMPLES_EXACT): cv for exact
     * values, blend otherwise; for volumes and the Gaussian baseline it stays as without the flag. */
    o = d;
    o.sample_flags = CSI_SAMPLES_EXACT;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(r.correct == CSI_CORRECT_CV && r.tau_rel == fmin(3e-3, fmax(1e-5, 3e-3 / spp)), "exact samples: correct %d",
          (int)r.correct);
    o.correct = CSI_CORRECT_BLEND;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(r.correct == CSI_CORRECT_BLEND, "a given correct wins over the flag");
    o.correct = CSI_CORRECT_AUTO;
    CHECK_OK(csi_recon_resolve(&o, &(csi_grid){32, 32, 8, 32, 32}, 800, &r));
    CHECK(r.correct == CSI_CORRECT_AUTO, "volumes: auto is the range projection, exact or not");
    o.estimator = CSI_EST_GAUSS;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(r.correct == CSI_CORRECT_NONE, "gauss: none, exact or not");
    /* Given values win. */
    o = d;
    o.tau_rel = 0.01;
    o.debias = CSI_SWITCH_ON;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(r.tau_rel == 0.01 && r.debias == CSI_SWITCH_ON, "given values kept");
    /* ROMP, csi's preset and the published one (N = 600, k = 4096). */
    o = d;
    o.solver = CSI_SOLVER_ROMP;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(r.romp_s == 16 && r.romp_max_support == 0.15 && r.romp_seed_levels == 2 && r.romp_lsq_iter == 1 &&
              r.romp_normalize == CSI_SWITCH_OFF && r.tol == 1e-5 && r.max_iter == 90 + 10,
          "csi ROMP: s %zu support %g max_iter %d", r.romp_s, r.romp_max_support, r.max_iter);
    CHECK(r.model_grid == CSI_SWITCH_OFF, "ROMP keeps the samples' grid");
    o.romp_preset = CSI_ROMP_PRESET_PUBLISHED;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    const size_t s = csi_romp_default_s(600, 4096);
    CHECK(r.romp_s == s && r.romp_max_support == (double)(2 * s) && r.romp_seed_levels == -1 &&
              r.romp_lsq_iter == 60 && r.max_iter == (int)(2 * s + 10),
          "published ROMP: s %zu support %g", r.romp_s, r.romp_max_support);
    /* Alg. 2: 32x32x8 grid, n = 800. (The widths are compared to 1e-14 relative: the library's
     * pow(x, 1/d) and cbrt/sqrt may differ in the last bits.) */
    csi_grid vol = {32, 32, 8, 32, 32};
    CHECK_OK(csi_recon_resolve(&d, &vol, 800, &r));
    const double tau = fmin(3e-2, fmax(1e-4, 0.25 / sqrt(800.0)));
    /* Alg. 1's filter and with it the stop wait for the velocity (motion.c reports them) */
    CHECK(r.tau_rel == tau && r.stop == CSI_STOP_AUTO && r.motion_filter == 0 && r.tol == 1e-5 &&
              r.max_iter == 2000 && r.debias == CSI_SWITCH_OFF && r.levels == 0 && r.correct == CSI_CORRECT_AUTO &&
              r.cont_step == -1 && r.cont_tol == 1e-3 &&
              fabs(r.motion_resid_sigma / (0.5 * cbrt(8192.0 / 800.0)) - 1) < 1e-14,
          "motion: tau %g resid %g", r.tau_rel, r.motion_resid_sigma);
    o = d;
    o.motion_full_spectrum = true;
    CHECK_OK(csi_recon_resolve(&o, &vol, 800, &r));
    CHECK(r.stop == CSI_STOP_GAP && r.motion_filter == -1, "the full spectrum (the paper's form): no filter, "
          "the gap stop");
    o.motion_full_spectrum = false;
    o.motion_filter = -1;
    CHECK_OK(csi_recon_resolve(&o, &vol, 800, &r));
    CHECK(r.stop == CSI_STOP_GAP, "the filter off: the gap stop");
    /* Baselines: only their own options. */
    o = d;
    o.estimator = CSI_EST_GAUSS;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(fabs(r.gauss_sigma / (0.5 * sqrt(4096.0 / 600.0)) - 1) < 1e-14 && r.correct == CSI_CORRECT_NONE &&
              r.solver == CSI_SOLVER_AUTO && r.tau_rel == 0,
          "gauss: sigma %g", r.gauss_sigma);
    o.estimator = CSI_EST_MEAN;
    CHECK_OK(csi_recon_resolve(&o, &still, 600, &r));
    CHECK(same(&r, &o), "the sample mean has no options to resolve");
    return test_done();
}
