/* csi-reconstruct: a sample dump in, an antialiased (Alg. 1) or motion-blurred (Alg. 2) image
 * out. See --help and docs/dump-format.md. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "csi/dump.h"
#include "csi/reconstruct.h"
#include "csi/runtime.h"
#include "csi/stats.h"
#include "outputs.h"

static const char *prog = "csi-reconstruct";

static void usage(FILE *f)
{
    fprintf(f,
"usage: csi-reconstruct DUMP -o OUT.exr [options]\n"
"\n"
"Reconstructs an image from a sample dump (docs/dump-format.md) by compressive estimation\n"
"(Sen & Darabi 2010). grid_t = 1: antialiasing (Alg. 1: Gaussian-blurred Daubechies wavelets);\n"
"grid_t > 1: motion blur (Alg. 2: 3-D Fourier basis), the image being the mean over time.\n"
"\n"
"outputs:\n"
"  -o, --output FILE.exr     float32 EXR with the run's parameters as header attributes\n"
"      --png FILE.png        8-bit sRGB preview\n"
"      --frames DIR          grid_t > 1: also every reconstructed frame (DIR/frame_NNNN.exr/.png)\n"
"      --stats FILE.json     timings, iterations and residuals as JSON\n"
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
"      --tau T               SpaRSA: tau relative to ||A^H y||_inf; default for images 3e-3 / spp\n"
"      --romp-preset csi|published  ROMP defaults: csi's for images (default) or Needell &\n"
"                            Vershynin's (s from N, stop at 2s); the --romp-* below override\n"
"      --romp-s S            ROMP: candidates per step (csi: N / 64, at least 16)\n"
"      --romp-max-support M  ROMP: support size that ends the run (a count, or in (0, 1) a\n"
"                            fraction of the samples; csi: 0.15)\n"
"      --romp-normalize on|off|auto  ROMP: rank correlations by column norm\n"
"      --romp-seed-levels off|auto|L  ROMP: start the support with the coarse wavelet block\n"
"                            (L = 1) and the L - 1 coarsest detail levels (csi: 2)\n"
"      --romp-lsq-iter N     ROMP: CG iterations per least squares (csi: 1)\n"
"input:\n"
"      --drop-invalid        drop records with NaN/Inf values (with a warning) instead of failing\n"
"other:\n"
"      --device NAME         OpenCL device (substring of 'platform / device'; default: PoCL CPU,\n"
"                            or $CSI_DEVICE); --device list prints the devices\n"
"  -q, --quiet               no progress or warnings on stderr\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n");
}

typedef struct {
    cli_progress *bar;
    uint32_t channel, channels;
} prog_state;

static void on_progress(void *user, const char *phase, int iter, double res)
{
    prog_state *ps = user;
    char detail[96] = "";
    if (res >= 0)
        snprintf(detail, sizeof detail, "channel %u/%u  iter %d  residual %.2e", ps->channel + 1,
                 ps->channels, iter, res);
    cli_progress_update(ps->bar, phase, -1, detail);
}

int main(int argc, char **argv)
{
    enum { O_PNG = 256, O_FRAMES, O_STATS, O_SOLVER, O_WAVELET, O_LEVELS, O_LAMBDA, O_SIGMA, O_INTEGRATE,
           O_TOL, O_MAXIT, O_TAU, O_DROP, O_DEVICE, O_VERSION, O_EST, O_GSIGMA, O_CORRECT, O_CVN0, O_SPACING, O_STOP, O_CONT, O_DEBIAS, O_ROMP_S, O_ROMP_MAXS, O_ROMP_NORM, O_ROMP_SEED, O_ROMP_LSQ, O_ROMP_PRESET };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, O_PNG},
        {"frames", required_argument, 0, O_FRAMES}, {"stats", required_argument, 0, O_STATS},
        {"solver", required_argument, 0, O_SOLVER}, {"wavelet", required_argument, 0, O_WAVELET},
        {"levels", required_argument, 0, O_LEVELS}, {"lambda", required_argument, 0, O_LAMBDA},
        {"sigma-scale", required_argument, 0, O_SIGMA}, {"integrate", required_argument, 0, O_INTEGRATE},
        {"tol", required_argument, 0, O_TOL}, {"max-iter", required_argument, 0, O_MAXIT},
        {"tau", required_argument, 0, O_TAU}, {"drop-invalid", no_argument, 0, O_DROP},
        {"device", required_argument, 0, O_DEVICE}, {"estimator", required_argument, 0, O_EST},
        {"gauss-sigma", required_argument, 0, O_GSIGMA},
        {"correct", required_argument, 0, O_CORRECT}, {"cv-n0", required_argument, 0, O_CVN0},
        {"sigma-spacing", required_argument, 0, O_SPACING},
        {"stop", required_argument, 0, O_STOP}, {"continuation", required_argument, 0, O_CONT},
        {"debias", required_argument, 0, O_DEBIAS},
        {"romp-s", required_argument, 0, O_ROMP_S}, {"romp-max-support", required_argument, 0, O_ROMP_MAXS},
        {"romp-normalize", required_argument, 0, O_ROMP_NORM},
        {"romp-seed-levels", required_argument, 0, O_ROMP_SEED},
        {"romp-lsq-iter", required_argument, 0, O_ROMP_LSQ}, {"romp-preset", required_argument, 0, O_ROMP_PRESET}, {"quiet", no_argument, 0, 'q'},
        {"help", no_argument, 0, 'h'}, {"version", no_argument, 0, O_VERSION}, {0, 0, 0, 0}};
    cli_outputs outs = {0};
    csi_recon_options opt;
    csi_recon_defaults(&opt);
    bool quiet = false, drop = false;
    const char *device = NULL;
    int c;
    double d;
    uint64_t u;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': outs.exr = optarg; break;
        case O_PNG: outs.png = optarg; break;
        case O_FRAMES: outs.frames_dir = optarg; opt.frames = true; break;
        case O_STATS: outs.stats = optarg; break;
        case O_SOLVER:
            if (csi_solver_kind_parse(optarg, &opt.solver) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--solver: %s", csi_last_error());
            break;
        case O_WAVELET:
            if (csi_wavelet_parse(optarg, &opt.wavelet) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--wavelet: %s", csi_last_error());
            break;
        case O_LEVELS:
            if (!cli_parse_u64(optarg, 1, 16, &u))
                return cli_error(prog, CSI_ERR_ARG, "--levels: '%s' is not a whole number from 1 to 16", optarg);
            opt.levels = (int)u;
            break;
        case O_LAMBDA:
            if (!cli_parse_double(optarg, 1e-12, 1e6, &d))
                return cli_error(prog, CSI_ERR_ARG, "--lambda: '%s' is not a number in [1e-12, 1e6]", optarg);
            opt.lambda = (float)d;
            break;
        case O_SIGMA:
            if (!cli_parse_double(optarg, 1e-3, 100, &d))
                return cli_error(prog, CSI_ERR_ARG, "--sigma-scale: '%s' is not a number in [0.001, 100]", optarg);
            opt.sigma_scale = d;
            break;
        case O_INTEGRATE:
            if (csi_aa_output_parse(optarg, &opt.output) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--integrate: %s", csi_last_error());
            break;
        case O_TOL:
            if (!cli_parse_double(optarg, 1e-12, 1, &d))
                return cli_error(prog, CSI_ERR_ARG, "--tol: '%s' is not a number in [1e-12, 1]", optarg);
            opt.tol = d;
            break;
        case O_MAXIT:
            if (!cli_parse_u64(optarg, 1, 1000000, &u))
                return cli_error(prog, CSI_ERR_ARG, "--max-iter: '%s' is not a whole number from 1 to 1e6", optarg);
            opt.max_iter = (int)u;
            break;
        case O_TAU:
            if (!cli_parse_double(optarg, 1e-12, 1, &d))
                return cli_error(prog, CSI_ERR_ARG, "--tau: '%s' is not a number in [1e-12, 1]", optarg);
            opt.tau_rel = d;
            break;
        case O_EST:
            if (csi_estimator_parse(optarg, &opt.estimator) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--estimator: %s", csi_last_error());
            break;
        case O_CORRECT:
            if (csi_aa_correct_parse(optarg, &opt.correct) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--correct: %s", csi_last_error());
            break;
        case O_CVN0:
            if (!cli_parse_double(optarg, 0, 1e6, &d))
                return cli_error(prog, CSI_ERR_ARG, "--cv-n0: '%s' is not a number in [0, 1e6]", optarg);
            opt.cv_n0 = d;
            break;
        case O_SPACING:
            if (!cli_parse_double(optarg, 0, 100, &d))
                return cli_error(prog, CSI_ERR_ARG, "--sigma-spacing: '%s' is not a number in [0, 100]", optarg);
            opt.sigma_spacing = d;
            break;
        case O_STOP:
            if (csi_recon_stop_parse(optarg, &opt.stop) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--stop: %s", csi_last_error());
            break;
        case O_CONT:
            if (csi_switch_parse(optarg, &opt.continuation) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--continuation: %s", csi_last_error());
            break;
        case O_DEBIAS:
            if (csi_switch_parse(optarg, &opt.debias) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--debias: %s", csi_last_error());
            break;
        case O_ROMP_S:
            if (!cli_parse_u64(optarg, 1, 1u << 30, &u))
                return cli_error(prog, CSI_ERR_ARG, "--romp-s: '%s' is not a whole number from 1 to 2^30", optarg);
            opt.romp_s = (size_t)u;
            break;
        case O_ROMP_MAXS:
            if (!cli_parse_double(optarg, 1e-6, 4294967296.0, &d) || (d >= 1 && d != floor(d)))
                return cli_error(prog, CSI_ERR_ARG, "--romp-max-support: '%s' is neither a fraction of "
                                 "the samples in (0, 1) nor a whole count", optarg);
            opt.romp_max_support = d;
            break;
        case O_ROMP_NORM:
            if (csi_switch_parse(optarg, &opt.romp_normalize) != CSI_OK)
                return cli_error(prog, CSI_ERR_ARG, "--romp-normalize: %s", csi_last_error());
            break;
        case O_ROMP_SEED:
            if (!strcmp(optarg, "off"))
                opt.romp_seed_levels = -1;
            else if (!strcmp(optarg, "auto"))
                opt.romp_seed_levels = 0;
            else if (cli_parse_u64(optarg, 1, 16, &u))
                opt.romp_seed_levels = (int)u;
            else
                return cli_error(prog, CSI_ERR_ARG, "--romp-seed-levels: '%s' (expected off, auto or 1 to 16)", optarg);
            break;
        case O_ROMP_PRESET:
            if (strcmp(optarg, "csi") && strcmp(optarg, "published"))
                return cli_error(prog, CSI_ERR_ARG, "--romp-preset: '%s' (expected csi or published)", optarg);
            opt.romp_published = !strcmp(optarg, "published");
            break;
        case O_ROMP_LSQ:
            if (!cli_parse_u64(optarg, 1, 100000, &u))
                return cli_error(prog, CSI_ERR_ARG, "--romp-lsq-iter: '%s' is not a whole number from 1 to 1e5", optarg);
            opt.romp_lsq_iter = (int)u;
            break;
        case O_GSIGMA:
            if (!cli_parse_double(optarg, 1e-3, 1e4, &d))
                return cli_error(prog, CSI_ERR_ARG, "--gauss-sigma: '%s' is not a number in [0.001, 1e4]", optarg);
            opt.gauss_sigma = d;
            break;
        case O_DROP: drop = true; break;
        case O_DEVICE: device = optarg; break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); return 0;
        case O_VERSION: printf("csi-reconstruct %s\n", CSI_VERSION); return 0;
        default:
            return cli_error(prog, CSI_ERR_ARG, "unknown or incomplete option '%s' (see --help)",
                             argv[optind - 1]);
        }
    }
    if (device && !strcmp(device, "list")) {
        char buf[8192];
        if (csi_list_devices(buf, sizeof buf) != CSI_OK)
            return cli_error(prog, CSI_ERR_DEVICE, "%s", csi_last_error());
        fputs(buf[0] ? buf : "no OpenCL devices\n", stdout);
        return 0;
    }
    if (optind != argc - 1)
        return cli_error(prog, CSI_ERR_ARG, optind >= argc ? "no sample dump given (see --help)"
                                                          : "more than one input given (see --help)");
    const char *in = argv[optind];
    if (!outs.exr && !outs.png)
        return cli_error(prog, CSI_ERR_ARG, "no output given: use -o OUT.exr and/or --png OUT.png");
    csi_status s = cli_outputs_check(&outs);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", csi_last_error());

    csi_dump dump = {0};
    csi_dump_report drep = {0};
    csi_dump_read_opts ropts = {.drop_invalid = drop};
    s = csi_dump_read(in, &ropts, &dump, &drep);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", csi_last_error());
    if (!quiet && drep.dropped_invalid)
        fprintf(stderr, "%s: warning: %s: dropped %llu records with NaN/Inf values (first: record %llu)\n",
                prog, in, (unsigned long long)drep.dropped_invalid, (unsigned long long)drep.first_invalid);
    if (!quiet && drep.duplicates)
        fprintf(stderr, "%s: warning: %s: %llu records repeat a position; their values were averaged\n",
                prog, in, (unsigned long long)drep.duplicates);
    if (dump.grid.t > 1 && opt.solver == CSI_SOLVER_ROMP) {
        csi_dump_free(&dump);
        return cli_error(prog, CSI_ERR_ARG, "%s: ROMP is real-valued and a volume (grid_t = %u) needs "
                         "the complex 3-D Fourier problem: use --solver sparsa", in, dump.grid.t);
    }
    if (opt.frames && dump.grid.t == 1 && !quiet)
        fprintf(stderr, "%s: warning: %s is a static dump (grid_t = 1): --frames writes nothing\n", prog, in);

    csi_ctx *ctx = NULL;
    s = csi_ctx_create(&ctx, device);
    if (s != CSI_OK) {
        csi_dump_free(&dump);
        return cli_error(prog, s, "%s", csi_last_error());
    }
    cli_progress bar;
    cli_progress_init(&bar, quiet);
    prog_state ps = {&bar, 0, dump.channels};
    opt.progress = on_progress;
    opt.user = &ps;
    csi_recon_result res;
    double t0 = cli_now();
    s = csi_reconstruct(ctx, &dump.grid, dump.channels, dump.pos, dump.values, dump.count, &opt, &res);
    cli_progress_end(&bar);
    int rc = 0;
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", in, csi_last_error());
    } else {
        const char *method = opt.estimator == CSI_EST_MEAN ? "sample mean (Monte Carlo)"
                             : opt.estimator == CSI_EST_GAUSS ? "Gaussian normalized convolution"
                             : dump.grid.t > 1 ? "compressive motion (Alg. 2)" : "compressive antialias (Alg. 1)";
        s = cli_write_images(&outs, &opt, &res, method);
        if (s == CSI_OK && outs.stats) {
            csi_json *j = NULL;
            s = csi_json_new(&j);
            if (s == CSI_OK) {
                csi_json_str(j, "tool", "csi-reconstruct");
                csi_json_str(j, "input", in);
                csi_json_str(j, "device", csi_ctx_device_name(ctx));
                csi_json_int(j, "grid_w", dump.grid.w);
                csi_json_int(j, "grid_h", dump.grid.h);
                csi_json_int(j, "grid_t", dump.grid.t);
                csi_json_int(j, "out_w", dump.grid.out_w);
                csi_json_int(j, "out_h", dump.grid.out_h);
                csi_json_int(j, "records", (int64_t)drep.records);
                csi_json_int(j, "duplicates", (int64_t)drep.duplicates);
                csi_json_int(j, "dropped_invalid", (int64_t)drep.dropped_invalid);
                cli_stats_recon(j, &opt, &res);
                csi_json_num(j, "t_wall_s", cli_now() - t0);
                s = csi_json_write(j, outs.stats);
                csi_json_free(j);
            }
        }
        if (s != CSI_OK)
            rc = cli_error(prog, s, "%s", csi_last_error());
        if (s == CSI_OK && !quiet) {
            bool all = true;
            for (uint32_t ch = 0; ch < res.channels; ch++)
                if (!res.report[ch].converged) {
                    all = false;
                    fprintf(stderr, "%s: warning: channel %u: %s\n", prog, ch, res.report[ch].message);
                }
            fprintf(stderr, "%s: %ux%u from %zu samples of a %ux%ux%u grid (%s) in %.2f s%s\n", prog,
                    res.out_w, res.out_h, res.n, dump.grid.w, dump.grid.h, dump.grid.t,
                    opt.estimator == CSI_EST_CS ? csi_solver_kind_name(res.solver) : csi_estimator_name(opt.estimator), cli_now() - t0, all ? "" : " (not converged)");
        }
        csi_recon_result_free(&res);
    }
    csi_ctx_release(ctx);
    csi_dump_free(&dump);
    return rc;
}
