/* The reconstruction options csi-render and csi-reconstruct share: one table, one parser, one
 * help text, so the two programs cannot drift apart. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "recon_opts.h"

enum { O_FIRST = CLI_RECON_FIRST, O_SOLVER, O_WAVELET, O_LEVELS, O_LAMBDA, O_SIGMA, O_INTEGRATE, O_TOL, O_MAXIT, O_TAU, O_EST, O_GSIGMA, O_CORRECT, O_SPACING, O_STOP, O_CONT, O_DEBIAS, O_ROMP_S, O_ROMP_MAXS, O_ROMP_NORM, O_ROMP_SEED, O_ROMP_LSQ, O_ROMP_PRESET, O_CVN0, O_MOTION_RESID, O_FULL_SPECTRUM, O_MOTION_DEBIAS, O_BUDGET, O_TILES, O_TILE_MARGIN, O_TILE_MARGIN_T, O_LAST };

static const struct option recon_longopts[] = {
    {"solver", required_argument, 0, O_SOLVER},
    {"wavelet", required_argument, 0, O_WAVELET},
    {"levels", required_argument, 0, O_LEVELS},
    {"lambda", required_argument, 0, O_LAMBDA},
    {"sigma-scale", required_argument, 0, O_SIGMA},
    {"integrate", required_argument, 0, O_INTEGRATE},
    {"tol", required_argument, 0, O_TOL},
    {"max-iter", required_argument, 0, O_MAXIT},
    {"tau", required_argument, 0, O_TAU},
    {"estimator", required_argument, 0, O_EST},
    {"gauss-sigma", required_argument, 0, O_GSIGMA},
    {"correct", required_argument, 0, O_CORRECT},
    {"sigma-spacing", required_argument, 0, O_SPACING},
    {"stop", required_argument, 0, O_STOP},
    {"continuation", required_argument, 0, O_CONT},
    {"debias", required_argument, 0, O_DEBIAS},
    {"romp-s", required_argument, 0, O_ROMP_S},
    {"romp-max-support", required_argument, 0, O_ROMP_MAXS},
    {"romp-normalize", required_argument, 0, O_ROMP_NORM},
    {"romp-seed-levels", required_argument, 0, O_ROMP_SEED},
    {"romp-lsq-iter", required_argument, 0, O_ROMP_LSQ},
    {"romp-preset", required_argument, 0, O_ROMP_PRESET},
    {"cv-n0", required_argument, 0, O_CVN0},
    {"motion-resid-sigma", required_argument, 0, O_MOTION_RESID},
    {"full-spectrum", no_argument, 0, O_FULL_SPECTRUM},
    {"motion-debias", no_argument, 0, O_MOTION_DEBIAS},
    {"mem-budget", required_argument, 0, O_BUDGET},
    {"tiles", required_argument, 0, O_TILES},
    {"tile-margin", required_argument, 0, O_TILE_MARGIN},
    {"tile-margin-t", required_argument, 0, O_TILE_MARGIN_T},
};

struct option *cli_longopts_with_recon(const struct option *own)
{
    size_t n_own = 0, n_rec = sizeof recon_longopts / sizeof recon_longopts[0];
    while (own[n_own].name)
        n_own++;
    struct option *all = calloc(n_own + n_rec + 1, sizeof *all);
    if (!all)
        return NULL;
    memcpy(all, own, n_own * sizeof *all);
    memcpy(all + n_own, recon_longopts, n_rec * sizeof *all);
    return all; /* the last entry stays zero */
}

void cli_recon_usage(FILE *f)
{
    fputs(
"method:\n"
"      --estimator cs|mean|gauss  cs: compressive (default); baselines: mean = per-pixel sample\n"
"                            mean (Monte Carlo), gauss = Gaussian normalized convolution\n"
"      --gauss-sigma S       width of the gauss baseline in grid cells (default 0.5 (k/N)^(1/d))\n"
"      --solver romp|sparsa  default: sparsa (measured best; docs/BENCHMARKS.md)\n"
"      --wavelet db4|db8     Alg. 1 basis (db4: 8 taps, db8: 16 taps), default db4\n"
"      --levels L            wavelet levels (default: as many as the grid allows, at most 5)\n"
"      --lambda L            Wiener regularisation of the inverse filter, default 0.3\n"
"      --sigma-scale S       multiply the paper's Gaussian width, default 1\n"
"      --sigma-spacing C     Gaussian width at least C times the sample spacing sqrt(k/N)\n"
"                            (0: the paper's width only), default 0.8\n"
"      --integrate filtered|sharp  integrate f_b (the paper's) or Phi^-1 f_b, default sharp\n"
"      --correct auto|none|cv  correct each pixel with its own samples (control variate:\n"
"                            box(g) + mean of the pixel's residuals y - g); auto: cv for cs,\n"
"                            none for the gauss baseline\n"
"      --cv-n0 N             shrink that correction by n_p / (n_p + N), n_p = samples in the\n"
"                            pixel; default 8\n"
"      --stop gap|objective|auto  SpaRSA stopping rule (relative duality gap or objective change;\n"
"                            auto: objective for images, gap for volumes)\n"
"      --continuation on|off|auto  SpaRSA continuation on tau\n"
"      --debias on|off|auto  SpaRSA's final least squares on the support (auto: off for images)\n"
"      --tol T               solver tolerance (relative); default 3e-3 for images, else the solver's\n"
"      --max-iter N          solver iteration cap; default 300 for images, else the solver's\n"
"      --tau T               SpaRSA: tau relative to ||A^H y||_inf; default 3e-3 / spp for images,\n"
"                            0.25 / sqrt(N) for volumes\n"
"      --romp-preset csi|published  ROMP defaults: csi's for images (default) or Needell &\n"
"                            Vershynin's (s from N, stop at 2s); the --romp-* below override\n"
"      --romp-s S            ROMP: candidates per step (csi: N / 64, at least 16)\n"
"      --romp-max-support M  ROMP: support size that ends the run (a count, or in (0, 1) a\n"
"                            fraction of the samples; csi: 0.15)\n"
"      --romp-normalize on|off|auto  ROMP: rank correlations by column norm\n"
"      --romp-seed-levels off|auto|L  ROMP: start the support with the coarse wavelet block\n"
"                            (L = 1) and the L - 1 coarsest detail levels (csi: 2)\n"
"      --romp-lsq-iter N     ROMP: CG iterations per least squares (csi: 1)\n"
"      --motion-resid-sigma S  volumes: width (cells) of the normalized convolution that adds the\n"
"                            samples' residual back after the solve; 0: from the sampling density\n"
"                            (default), < 0: off (the paper's)\n"
"      --full-spectrum       volumes: solve on the full complex spectrum (the paper's form) rather\n"
"                            than the half spectrum of the real volume (same minimiser, 2x work)\n"
"      --motion-debias       volumes: SpaRSA's debiasing least squares (default off)\n"
"tiles (bounded memory; docs/tiles.md):\n"
"      --mem-budget SIZE     device memory one reconstruction may use, e.g. 512M, 2G (bytes, or\n"
"                            K/M/G = KiB/MiB/GiB); the image is solved in overlapping tiles when\n"
"                            the whole would need more. Default 1G, at most half the device's\n"
"      --tiles N|auto        exactly N tiles (blended seamlessly), or as few as fit (auto, default)\n"
"      --tile-margin P       overlap beyond a tile's core in output pixels (default: 128 grid cells,\n"
"                            at least 4 pixels; 16 for volumes)\n"
"      --tile-margin-t F     the same in frames for a volume (default 4)\n", f);
}

int cli_recon_option(const char *prog, int c, const char *optarg, csi_recon_options *opt)
{
    double d;
    uint64_t u;
    switch (c) {
    case O_SOLVER:
        if (csi_solver_kind_parse(optarg, &opt->solver) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--solver: %s", csi_last_error());
        break;
    case O_WAVELET:
        if (csi_wavelet_parse(optarg, &opt->wavelet) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--wavelet: %s", csi_last_error());
        break;
    case O_LEVELS:
        if (!cli_parse_u64(optarg, 1, 16, &u))
            return cli_error(prog, CSI_ERR_ARG, "--levels: '%s' is not a whole number from 1 to 16", optarg);
        opt->levels = (int)u;
        break;
    case O_LAMBDA:
        if (!cli_parse_double(optarg, 1e-12, 1e6, &d))
            return cli_error(prog, CSI_ERR_ARG, "--lambda: '%s' is not a number in [1e-12, 1e6]", optarg);
        opt->lambda = (float)d;
        break;
    case O_SIGMA:
        if (!cli_parse_double(optarg, 1e-3, 100, &d))
            return cli_error(prog, CSI_ERR_ARG, "--sigma-scale: '%s' is not a number in [0.001, 100]", optarg);
        opt->sigma_scale = d;
        break;
    case O_INTEGRATE:
        if (csi_aa_output_parse(optarg, &opt->output) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--integrate: %s", csi_last_error());
        break;
    case O_TOL:
        if (!cli_parse_double(optarg, 1e-12, 1, &d))
            return cli_error(prog, CSI_ERR_ARG, "--tol: '%s' is not a number in [1e-12, 1]", optarg);
        opt->tol = d;
        break;
    case O_MAXIT:
        if (!cli_parse_u64(optarg, 1, 1000000, &u))
            return cli_error(prog, CSI_ERR_ARG, "--max-iter: '%s' is not a whole number from 1 to 1e6", optarg);
        opt->max_iter = (int)u;
        break;
    case O_TAU:
        if (!cli_parse_double(optarg, 1e-12, 1, &d))
            return cli_error(prog, CSI_ERR_ARG, "--tau: '%s' is not a number in [1e-12, 1]", optarg);
        opt->tau_rel = d;
        break;
    case O_EST:
        if (csi_estimator_parse(optarg, &opt->estimator) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--estimator: %s", csi_last_error());
        break;
    case O_CORRECT:
        if (csi_aa_correct_parse(optarg, &opt->correct) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--correct: %s", csi_last_error());
        break;
    case O_CVN0:
        if (!cli_parse_double(optarg, 0, 1e6, &d))
            return cli_error(prog, CSI_ERR_ARG, "--cv-n0: '%s' is not a number in [0, 1e6]", optarg);
        opt->cv_n0 = d;
        break;
    case O_SPACING:
        if (!cli_parse_double(optarg, 0, 100, &d))
            return cli_error(prog, CSI_ERR_ARG, "--sigma-spacing: '%s' is not a number in [0, 100]", optarg);
        opt->sigma_spacing = d;
        break;
    case O_STOP:
        if (csi_recon_stop_parse(optarg, &opt->stop) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--stop: %s", csi_last_error());
        break;
    case O_CONT:
        if (csi_switch_parse(optarg, &opt->continuation) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--continuation: %s", csi_last_error());
        break;
    case O_DEBIAS:
        if (csi_switch_parse(optarg, &opt->debias) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--debias: %s", csi_last_error());
        break;
    case O_ROMP_S:
        if (!cli_parse_u64(optarg, 1, 1u << 30, &u))
            return cli_error(prog, CSI_ERR_ARG, "--romp-s: '%s' is not a whole number from 1 to 2^30", optarg);
        opt->romp_s = (size_t)u;
        break;
    case O_ROMP_MAXS:
        if (!cli_parse_double(optarg, 1e-6, 4294967296.0, &d) || (d >= 1 && d != floor(d)))
            return cli_error(prog, CSI_ERR_ARG, "--romp-max-support: '%s' is neither a fraction of "
                             "the samples in (0, 1) nor a whole count", optarg);
        opt->romp_max_support = d;
        break;
    case O_ROMP_NORM:
        if (csi_switch_parse(optarg, &opt->romp_normalize) != CSI_OK)
            return cli_error(prog, CSI_ERR_ARG, "--romp-normalize: %s", csi_last_error());
        break;
    case O_ROMP_SEED:
        if (!strcmp(optarg, "off"))
            opt->romp_seed_levels = -1;
        else if (!strcmp(optarg, "auto"))
            opt->romp_seed_levels = 0;
        else if (cli_parse_u64(optarg, 1, 16, &u))
            opt->romp_seed_levels = (int)u;
        else
            return cli_error(prog, CSI_ERR_ARG, "--romp-seed-levels: '%s' (expected off, auto or 1 to 16)", optarg);
        break;
    case O_ROMP_PRESET:
        if (strcmp(optarg, "csi") && strcmp(optarg, "published"))
            return cli_error(prog, CSI_ERR_ARG, "--romp-preset: '%s' (expected csi or published)", optarg);
        opt->romp_published = !strcmp(optarg, "published");
        break;
    case O_ROMP_LSQ:
        if (!cli_parse_u64(optarg, 1, 100000, &u))
            return cli_error(prog, CSI_ERR_ARG, "--romp-lsq-iter: '%s' is not a whole number from 1 to 1e5", optarg);
        opt->romp_lsq_iter = (int)u;
        break;
    case O_GSIGMA:
        if (!cli_parse_double(optarg, 1e-3, 1e4, &d))
            return cli_error(prog, CSI_ERR_ARG, "--gauss-sigma: '%s' is not a number in [0.001, 1e4]", optarg);
        opt->gauss_sigma = d;
        break;
    case O_MOTION_RESID:
        if (!cli_parse_double(optarg, -1e6, 1e4, &d))
            return cli_error(prog, CSI_ERR_ARG, "--motion-resid-sigma: '%s' is not a number", optarg);
        opt->motion_resid_sigma = d;
        break;
    case O_BUDGET:
        if (!cli_parse_bytes(optarg, &u) || u < (1u << 20))
            return cli_error(prog, CSI_ERR_ARG, "--mem-budget: '%s' is not a size of at least 1M "
                             "(bytes, or a number with K, M or G)", optarg);
        opt->mem_budget = u;
        break;
    case O_TILES:
        if (!strcmp(optarg, "auto"))
            opt->tiles = 0;
        else if (cli_parse_u64(optarg, 1, 1u << 20, &u))
            opt->tiles = (uint32_t)u;
        else
            return cli_error(prog, CSI_ERR_ARG, "--tiles: '%s' (expected auto or a whole number from 1 to 2^20)", optarg);
        break;
    case O_TILE_MARGIN:
    case O_TILE_MARGIN_T:
        if (!cli_parse_u64(optarg, 1, 65536, &u))
            return cli_error(prog, CSI_ERR_ARG, "--%s: '%s' is not a whole number from 1 to 65536",
                             c == O_TILE_MARGIN ? "tile-margin" : "tile-margin-t", optarg);
        *(c == O_TILE_MARGIN ? &opt->tile_margin : &opt->tile_margin_t) = (uint32_t)u;
        break;
    case O_FULL_SPECTRUM: opt->motion_full_spectrum = true; break;
    case O_MOTION_DEBIAS: opt->motion_debias = true; break;
    default:
        return -1;
    }
    return 0;
}

int cli_recon_option_or_fail(const char *prog, int c, const char *optarg, const char *arg,
                             csi_recon_options *opt)
{
    int rc = cli_recon_option(prog, c, optarg, opt);
    if (rc < 0)
        return cli_error(prog, CSI_ERR_ARG, "unknown or incomplete option '%s' (see --help)", arg);
    return rc;
}
