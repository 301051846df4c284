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
#include "recon_opts.h"
#include "resources.h"
#include "tile.h"

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
);
    cli_recon_usage(f);
    cli_tile_usage(f);
    fputs(
"input:\n"
"      --drop-invalid        drop records with NaN/Inf values (with a warning) instead of failing\n"
"other:\n"
"      --seed S              seed of the solver's randomised parts (ROMP's column-norm probes with\n"
"                            --romp-normalize on); default: the dump's seed (csi-render's), else 1\n"
"      --device NAME         OpenCL device (substring of 'platform / device'; default: PoCL CPU,\n"
"                            or $CSI_DEVICE); --device list prints the devices\n"
"  -q, --quiet               no progress or warnings on stderr\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n", f);
}

static bool on_progress(void *user, const char *phase, int iter, double res)
{
    cli_recon_progress_update(user, phase, iter, res);
    return true;
}

static const char *method_name(const csi_recon_options *opt, const csi_grid *g)
{
    return opt->estimator == CSI_EST_MEAN    ? "sample mean (Monte Carlo)"
           : opt->estimator == CSI_EST_GAUSS ? "Gaussian normalized convolution"
           : g->t > 1                        ? "compressive motion (Alg. 2)"
                                             : "compressive antialias (Alg. 1)";
}

/* --tile I/N and --tile-info: the layout, the whole problem's scope, then one tile's partial or
 * the layout as JSON. */
static int run_tile(csi_ctx *ctx, csi_outset *set, const csi_dump *d, const char *in, csi_recon_options *opt,
                    const cli_tile_opts *tile, const cli_outputs *outs, bool quiet)
{
    const size_t nv = d->count * d->channels;
    uint64_t id = cli_hash64(0, &d->grid, sizeof d->grid);
    id = cli_hash64(id, &d->channels, sizeof d->channels);
    for (size_t i = 0; i < d->count; i++) {
        const uint32_t xyt[3] = {d->pos[i].x, d->pos[i].y, d->pos[i].t};
        id = cli_hash64(id, xyt, sizeof xyt);
    }
    id = cli_hash64(id, d->values, nv * sizeof(float));
    csi_tiling tl;
    csi_status s = cli_tile_layout(ctx, &d->grid, d->channels, d->count, tile, opt, &tl);
    csi_tile_scope scope;
    if (s == CSI_OK && !cli_tile_given_scope(tile, &d->grid, d->channels, d->count, &scope))
        s = csi_tile_scope_make(ctx, &d->grid, d->channels, d->pos, d->values, d->count, opt, &tl, &scope);
    if (s == CSI_OK && tile->info)
        s = cli_tile_info_print(&tl, &scope, opt, id);
    if (s != CSI_OK || tile->info)
        return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", in, cli_last_error());
    const double t0 = cli_now();
    csi_tile_result res;
    s = csi_recon_tile(ctx, &d->grid, d->channels, d->pos, d->values, d->count, opt, &tl, &scope,
                             tile->index, &res);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s: %s", in, cli_last_error());
    const char *tmp = NULL;
    if (outs->exr) /* the partial and the stats, all or nothing (csi_outset) */
        s = csi_outset_tmp(set, outs->exr, &tmp);
    if (s == CSI_OK && tmp)
        s = cli_named(cli_tile_write(tmp, method_name(opt, &d->grid), in, id, opt, &tl, &scope, &res), tmp, outs->exr);
    if (s == CSI_OK && outs->stats) {
        csi_json *j = NULL;
        s = csi_json_new(&j);
        if (s == CSI_OK) {
            csi_json_str(j, "tool", "csi-reconstruct");
            csi_json_str(j, "input", in);
            csi_json_int(j, "tile", tile->index);
            csi_json_int(j, "tile_count", tl.count);
            csi_json_int(j, "window_x0", res.x0);
            csi_json_int(j, "window_y0", res.y0);
            csi_json_int(j, "window_t0", res.t0);
            cli_stats_recon(j, &res.r);
            csi_json_num(j, "t_wall_s", cli_now() - t0);
            csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
            s = cli_write_stats(set, outs->stats, j);
            csi_json_free(j);
        }
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s == CSI_OK && !quiet)
        fprintf(stderr, "%s: tile %u/%u (%ux%u pixels at %u,%u) from %zu samples in %.2f s\n", prog,
                tile->index, tl.count, res.r.out_w, res.r.out_h, res.x0, res.y0, res.r.n, cli_now() - t0);
    csi_tile_result_free(&res);
    return s == CSI_OK ? 0 : cli_error(prog, s, "%s", cli_last_error());
}

int main(int argc, char **argv)
{
    enum { O_PNG = 256, O_FRAMES, O_STATS, O_DROP, O_DEVICE, O_VERSION, O_SEED };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, O_PNG},
        {"frames", required_argument, 0, O_FRAMES}, {"stats", required_argument, 0, O_STATS},
        {"drop-invalid", no_argument, 0, O_DROP},
        {"device", required_argument, 0, O_DEVICE}, 
        {"seed", required_argument, 0, O_SEED}, {"quiet", no_argument, 0, 'q'},
        {"help", no_argument, 0, 'h'}, {"version", no_argument, 0, O_VERSION}, CLI_TILE_LONGOPTS,
        {0, 0, 0, 0}};
    cli_outputs outs = {0};
    cli_tile_opts tile = {0};
    csi_recon_options opt;
    csi_recon_defaults(&opt);
    bool quiet = false, drop = false, seed_given = false;
    const char *device = NULL;
    int c;
    opterr = 0;
    struct option *all_opts = cli_longopts_with_recon(longopts);
    if (!all_opts)
        return cli_error(prog, CSI_ERR_NOMEM, "out of memory");
    while ((c = getopt_long(argc, argv, "o:qh", all_opts, NULL)) != -1) {
        switch (c) {
        case 'o': outs.exr = optarg; break;
        case O_PNG: outs.png = optarg; break;
        case O_FRAMES: outs.frames_dir = optarg; opt.frames = true; break;
        case O_STATS: outs.stats = optarg; break;
        case O_DROP: drop = true; break;
        case O_SEED: {
            uint64_t v;
            if (!cli_parse_u64(optarg, 0, UINT64_MAX, &v)) {
                free(all_opts);
                return cli_error(prog, CSI_ERR_ARG, "--seed: '%s' is not a whole number", optarg);
            }
            opt.seed = v;
            seed_given = true;
            break;
        }
        case O_DEVICE: device = optarg; break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); return 0;
        case O_VERSION: printf("csi-reconstruct %s\n", CSI_VERSION); return 0;
        default: {
            int rc = cli_tile_option(prog, c, optarg, &tile);
            if (rc < 0)
                rc = cli_recon_option_or_fail(prog, c, optarg, argv[optind - 1], &opt);
            if (rc) {
                free(all_opts);
                return rc;
            }
        }
        }
    }
    free(all_opts);
    if (device && !strcmp(device, "list")) {
        char buf[8192];
        if (csi_list_devices(buf, sizeof buf) != CSI_OK)
            return cli_error(prog, CSI_ERR_DEVICE, "%s", cli_last_error());
        fputs(buf[0] ? buf : "no OpenCL devices\n", stdout);
        return 0;
    }
    if (optind != argc - 1)
        return cli_error(prog, CSI_ERR_ARG, optind >= argc ? "no sample dump given (see --help)"
                                                          : "more than one input given (see --help)");
    const char *in = argv[optind];
    int trc = cli_tile_check(prog, &tile, outs.png != NULL, outs.frames_dir != NULL);
    if (trc)
        return trc;
    if (tile.one && !outs.exr)
        return cli_error(prog, CSI_ERR_ARG, "--tile needs -o PARTIAL (the tile's partial result)");
    if (tile.frames)
        opt.frames = true;
    if (!outs.exr && !outs.png && !tile.info)
        return cli_error(prog, CSI_ERR_ARG, "no output given: use -o OUT.exr and/or --png OUT.png");
    csi_status s;

    csi_dump dump = {0};
    csi_dump_report drep = {0};
    csi_dump_read_opts ropts = {.drop_invalid = drop};
    cli_phase_times pt = {0};
    double tp = cli_now();
    /* Sizes before work: the header alone decides whether the run can fit (docs/dump-format.md). */
    csi_dump_header hdr;
    s = csi_dump_read_header(in, &ropts, &hdr);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", cli_last_error());
    if (hdr.grid.t > 1 && opt.solver == CSI_SOLVER_ROMP)
        return cli_error(prog, CSI_ERR_ARG, "%s: ROMP is real-valued and a volume (grid_t = %u) needs "
                         "the complex 3-D Fourier problem: use --solver sparsa", in, hdr.grid.t);
    /* Every output stated before any work, written all or nothing at the end (csi_outset). */
    csi_outset *set = NULL;
    s = cli_outset_new(&set);
    if (s == CSI_OK)
        s = csi_outset_input(set, in);
    if (s == CSI_OK)
        s = cli_outputs_stage(&outs, set, opt.frames && opt.estimator != CSI_EST_MEAN && hdr.grid.t > 1 ? hdr.grid.t : 0);
    if (s != CSI_OK) {
        cli_outset_free(set);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    csi_ctx *ctx = NULL;
    s = csi_ctx_create(&ctx, device);
    pt.device = cli_now() - tp;
    if (s != CSI_OK) {
        cli_outset_free(set);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    {
        const uint64_t k = (uint64_t)hdr.grid.w * hdr.grid.h * hdr.grid.t;
        s = cli_check_resources(ctx, in, &hdr.grid, hdr.channels, (size_t)(hdr.count < k ? hdr.count : k), &opt,
                                csi_dump_read_host_bytes(&hdr));
    }
    if (s != CSI_OK) {
        csi_ctx_release(ctx);
        cli_outset_free(set);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    tp = cli_now();
    s = csi_dump_read(in, &ropts, &dump, &drep);
    pt.read = cli_now() - tp;
    if (s != CSI_OK) {
        csi_ctx_release(ctx);
        cli_outset_free(set);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    if (!quiet && drep.dropped_invalid)
        cli_warn(prog, "%s: dropped %llu records with NaN/Inf values (first: record %llu)", in, (unsigned long long)drep.dropped_invalid, (unsigned long long)drep.first_invalid);
    if (!quiet && drep.duplicates)
        cli_warn(prog, "%s: %llu records repeat a position; their values were averaged", in, (unsigned long long)drep.duplicates);
    if (!seed_given && dump.seed)
        opt.seed = dump.seed; /* as csi-render ran it, so the result is the same */
    if (opt.frames && dump.grid.t == 1 && !quiet)
        cli_warn(prog, "%s is a static dump (grid_t = 1): --frames writes nothing", in);

    cli_progress bar;
    cli_progress_init(&bar, quiet);
    cli_recon_progress ps;
    cli_recon_progress_init(&ps, &bar);
    opt.progress = on_progress;
    opt.user = &ps;
    if (tile.one || tile.info) {
        int rc = run_tile(ctx, set, &dump, in, &opt, &tile, &outs, quiet);
        cli_progress_end(&bar);
        cli_outset_free(set);
        csi_ctx_release(ctx);
        csi_dump_free(&dump);
        return rc;
    }
    csi_recon_result res;
    double t0 = cli_now();
    s = csi_recon(ctx, &dump.grid, dump.channels, dump.pos, dump.values, dump.count, &opt, &res);
    cli_progress_end(&bar);
    int rc = 0;
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", in, cli_last_error());
    } else {
        const char *method = method_name(&opt, &dump.grid);
        tp = cli_now();
        s = cli_write_images(&outs, set, &res, method);
        pt.write = cli_now() - tp;
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
                cli_stats_recon(j, &res);
                cli_stats_phases(j, &pt, &res);
                csi_json_num(j, "t_wall_s", cli_now() - t0);
                csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
                s = cli_write_stats(set, outs.stats, j);
                csi_json_free(j);
            }
        }
        if (s == CSI_OK)
            s = csi_outset_commit(set);
        if (s != CSI_OK)
            rc = cli_error(prog, s, "%s", cli_last_error());
        if (s == CSI_OK && !quiet) {
            bool all = true;
            for (uint32_t ch = 0; ch < res.channels; ch++)
                if (!res.report[ch].converged && res.report[ch].reason != CSI_SOLVE_NOT_IDENTIFIABLE) {
                    all = false;
                    cli_warn(prog, "channel %u: %s", ch, res.report[ch].message);
                }
            fprintf(stderr, "%s: %ux%u from %zu samples of a %ux%ux%u grid (%s) in %.2f s%s\n", prog,
                    res.out_w, res.out_h, res.n, dump.grid.w, dump.grid.h, dump.grid.t,
                    opt.estimator == CSI_EST_CS ? csi_recon_choice_name("solver", res.options.solver)
                                                : csi_recon_choice_name("estimator", opt.estimator), cli_now() - t0, all ? "" : " (not converged)");
        }
        csi_recon_result_free(&res);
    }
    cli_outset_free(set); /* nothing new is left when the run failed */
    csi_ctx_release(ctx);
    csi_dump_free(&dump);
    return rc;
}
