/* csi-positions: writes a positions request (docs/dump-format.md, channels = 0): the fine grid
 * and the sample positions csi wants for an output size and sample budget, for any renderer to
 * evaluate at the cells' centres and write back as a dump. The positions come from
 * csi_positions and the grid from csi_default_grid_factor, as in csi-render, so one seed gives
 * the same positions in both. Uses csi/csi.h only. See --help. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"

static const char *prog = "csi-positions";

static void usage(FILE *f)
{
    fprintf(f,
"usage: csi-positions -o REQUEST.csid --out WxH [options]\n"
"\n"
"Writes a positions request: a csi dump with channels = 0 whose records are the fine-grid\n"
"cells (x, y, t) csi wants samples at (docs/dump-format.md). A renderer evaluates each at\n"
"its cell's centre, image point ((x + 0.5) / grid_w, (y + 0.5) / grid_h) (y down, row 0 on\n"
"top) and shutter time (t + 0.5) / grid_t, and writes back a dump with the same header and\n"
"values (several records per position are averaged: N paths per sample). The positions and\n"
"the default grid are csi-render's: the same options and seed give the same positions.\n"
"\n"
"  -o, --output FILE.csid  the request to write (written whole or not at all)\n"
"      --out WxH           final image size\n"
"      --spp N             samples per output pixel (over all frames when T > 1), default 4\n"
"      --fraction F        instead of --spp: a fraction 0 < F <= 1 of all grid cells (the grid\n"
"                          --grid gives, else the default's for --spp, 4 unless given)\n"
"      --grid K            fine-grid width in cells (a multiple of W; the height scales with\n"
"                          it); default when T > 1 2x W (3x from 9 spp, 4x from 16) from one\n"
"                          sample per 8 frames (8 spp >= T), else 1x (csi-render keeps 1x\n"
"                          where its camera moves, unless it translates across its view:\n"
"                          pass --grid W for the others);\n"
"                          when T = 1 F x W with F the smallest power of two >= 4\n"
"                          with F^2 > 4 spp, at most 16: F = 4 up to 3 spp, 8 for 4-15, 16\n"
"                          from 16 (docs/bench/grid.md)\n"
"      --time-steps T      frames across the shutter (T >= 1), default 1 (static image)\n"
"      --method M          poisson, stratified or random [default: the compressive method's, as\n"
"                          csi-render's cs: poisson, or stratified with --time-steps > 1 from 2 spp]\n"
"      --seed S            seed of the positions, stored in the request, default 1\n"
"  -q, --quiet             no progress and no summary line on stderr\n"
"  -h, --help              this text\n"
"      --version           version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n");
}

static bool on_positions(void *user, uint64_t done, uint64_t total)
{
    char detail[64];
    snprintf(detail, sizeof detail, "%llu / %llu placed", (unsigned long long)done, (unsigned long long)total);
    cli_progress_update(user, "positions", total ? (double)done / (double)total : -1, detail);
    return true;
}

int main(int argc, char **argv)
{
    enum { O_OUT = 256, O_SPP, O_FRACTION, O_GRID, O_TSTEPS, O_METHOD, O_SEED, O_VERSION };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"out", required_argument, 0, O_OUT},
        {"spp", required_argument, 0, O_SPP}, {"fraction", required_argument, 0, O_FRACTION},
        {"grid", required_argument, 0, O_GRID}, {"time-steps", required_argument, 0, O_TSTEPS},
        {"method", required_argument, 0, O_METHOD}, {"seed", required_argument, 0, O_SEED},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION}, {0, 0, 0, 0}};
    const char *output = NULL;
    uint32_t out_w = 0, out_h = 0;
    uint64_t spp = 4, grid_k = 0, tsteps = 1, seed = 1;
    double fraction = 0;
    bool quiet = false;
    csi_pos_method method = CSI_POS_POISSON;
    bool method_given = false;
    int c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': output = optarg; break;
        case O_OUT:
            if (!cli_parse_size(optarg, &out_w, &out_h) || out_w > CSI_GRID_MAX_SIDE || out_h > CSI_GRID_MAX_SIDE)
                return cli_error(prog, CSI_ERR_ARG, "--out: '%s' is not a size WxH from 1x1 to 65536x65536", optarg);
            break;
        case O_SPP:
            if (!cli_parse_u64(optarg, 1, 65536, &spp))
                return cli_error(prog, CSI_ERR_ARG, "--spp: '%s' is not a whole number from 1 to 65536", optarg);
            break;
        case O_FRACTION:
            if (!cli_parse_double(optarg, 0, 1, &fraction) || !(fraction > 0))
                return cli_error(prog, CSI_ERR_ARG, "--fraction: '%s' is not a number in (0, 1]", optarg);
            break;
        case O_GRID:
            if (!cli_parse_u64(optarg, 1, CSI_GRID_MAX_SIDE, &grid_k))
                return cli_error(prog, CSI_ERR_ARG, "--grid: '%s' is not a whole number from 1 to 65536", optarg);
            break;
        case O_TSTEPS:
            if (!cli_parse_u64(optarg, 1, CSI_GRID_MAX_FRAMES, &tsteps))
                return cli_error(prog, CSI_ERR_ARG, "--time-steps: '%s' is not a whole number from 1 to %u", optarg,
                                 CSI_GRID_MAX_FRAMES);
            break;
        case O_METHOD: {
            csi_status s = csi_pos_method_parse(optarg, &method);
            if (s != CSI_OK)
                return cli_error(prog, s, "--method: %s", cli_last_error());
            method_given = true;
            break;
        }
        case O_SEED:
            if (!cli_parse_u64(optarg, 0, UINT64_MAX, &seed))
                return cli_error(prog, CSI_ERR_ARG, "--seed: '%s' is not a whole number from 0 to 2^64 - 1", optarg);
            break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); return 0;
        case O_VERSION: printf("csi-positions %s\n", CSI_VERSION); return 0;
        default:
            return cli_error(prog, CSI_ERR_ARG, "unknown or incomplete option '%s' (see --help)", argv[optind - 1]);
        }
    }
    if (optind < argc)
        return cli_error(prog, CSI_ERR_ARG, "unexpected argument '%s' (see --help)", argv[optind]);
    if (!output)
        return cli_error(prog, CSI_ERR_ARG, "no output given: use -o REQUEST.csid");
    if (!out_w)
        return cli_error(prog, CSI_ERR_ARG, "no output size given: use --out WxH");

    uint64_t factor;
    if (grid_k) {
        if (grid_k % out_w)
            return cli_error(prog, CSI_ERR_ARG, "--grid %llu is not a multiple of the image width %u",
                             (unsigned long long)grid_k, out_w);
        factor = grid_k / out_w;
    } else {
        factor = csi_default_grid_factor(out_w, out_h, (uint32_t)tsteps, spp);
    }
    if ((uint64_t)out_w * factor > CSI_GRID_MAX_SIDE || (uint64_t)out_h * factor > CSI_GRID_MAX_SIDE)
        return cli_error(prog, CSI_ERR_ARG, "fine grid %llux%llu is larger than the limit %u per side",
                         (unsigned long long)(out_w * factor), (unsigned long long)(out_h * factor),
                         CSI_GRID_MAX_SIDE);
    csi_grid grid = {.w = (uint32_t)(out_w * factor), .h = (uint32_t)(out_h * factor), .t = (uint32_t)tsteps,
                     .out_w = out_w, .out_h = out_h};
    csi_status s = csi_dump_check_grid(&grid, 1, 0);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", cli_last_error());
    if (!method_given && fraction == 0) /* csi-render's positions for the same spp and T */
        method = cli_default_positions((uint32_t)tsteps, spp);
    csi_pos_opts popts = {.method = method, .spp = (uint32_t)spp, .fraction = fraction, .seed = seed};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    /* The output stated before work, as every program's (a directory, a missing or unwritable
     * folder refused now), and written whole or not at all. */
    csi_outset *set = NULL;
    s = cli_outset_new(&set);
    if (s == CSI_OK)
        s = csi_outset_file(set, output, "the request (-o)");
    if (s != CSI_OK) {
        cli_outset_free(set);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    int rc = 0;
    /* Sizes before work: the positions and the request's records must fit the host. */
    uint64_t need = 0, avail = csi_host_available_bytes();
    s = csi_positions_host_bytes(&grid, &popts, &need);
    if (s == CSI_OK)
        s = csi_positions_count(&grid, &popts, &n);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    need += 12 * (uint64_t)n;
    if (avail && need > avail) {
        char a[32], b[32];
        rc = cli_error(prog, CSI_ERR_TOO_LARGE, "%s: %zu positions on a %ux%ux%u grid need %s of host memory, more "
                       "than the %s available", output, n, grid.w, grid.h, grid.t, csi_bytes_text(need, a, sizeof a),
                       csi_bytes_text(avail, b, sizeof b));
        goto done;
    }
    cli_progress bar;
    if (!cli_progress_init(&bar, prog, quiet)) {
        rc = cli_error(prog, CSI_ERR_ARG, "%s", cli_last_error());
        goto done;
    }
    s = csi_positions_with_progress(&grid, &popts, &pos, &n, NULL, on_positions, &bar);
    cli_progress_end(&bar);
    if (s == CSI_OK) {
        csi_dump req = {.grid = grid, .channels = 0, .seed = seed, .count = n, .pos = pos, .values = NULL};
        s = cli_write_dump(set, output, &req);
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    if (!quiet)
        fprintf(stderr, "%s: %zu %s positions on a %ux%ux%u grid (%llux) for %ux%u, seed %llu -> %s\n", prog, n,
                csi_pos_method_name(method), grid.w, grid.h, grid.t, (unsigned long long)factor, out_w, out_h,
                (unsigned long long)seed, output);
done:
    csi_free(pos);
    cli_outset_free(set);
    return rc;
}
