/* csi-merge: blends the partials of one tiled run (csi-reconstruct / csi-render --tile I/N)
 * into the final image. See --help and docs/tiles.md. It reads the partial format, which holds
 * the library's own tile layout and scope (partial.h), so it is built on the library's internal
 * headers; its outputs are written as the other programs write theirs (outputs.h). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../api/internal.h" /* csi_result_adopt */
#include "common.h"
#include "csi/tiles.h"
#include "outputs.h"
#include "partial.h"

static const char *prog = "csi-merge";

static void usage(FILE *f)
{
    fputs(
"usage: csi-merge PARTIAL... -o OUT.exr [options]\n"
"\n"
"Blends the N partials of one tiled reconstruction (written by csi-reconstruct or csi-render\n"
"--tile I/N, in any order) into the image: the same bits as one process tiling by itself.\n"
"Every tile must be there exactly once, and all must come from the same input, options, tile\n"
"layout and software version; otherwise nothing is written.\n"
"\n"
"  -o, --output FILE.exr     float32 EXR with the run's parameters as header attributes\n"
"      --png FILE.png        8-bit sRGB preview\n"
"      --frames DIR          volumes: every frame (the partials must hold them: --partial-frames)\n"
"      --stats FILE.json     the run's figures, summed over the tiles\n"
"  -q, --quiet               no summary line\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n", f);
}

int main(int argc, char **argv)
{
    enum { O_PNG = 256, O_FRAMES, O_STATS, O_VERSION };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, O_PNG},
        {"frames", required_argument, 0, O_FRAMES}, {"stats", required_argument, 0, O_STATS},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION}, {0, 0, 0, 0}};
    cli_outputs outs = {0};
    bool quiet = false;
    int c;
    opterr = 0;
    while ((c = getopt_long(argc, argv, "o:qh", longopts, NULL)) != -1) {
        switch (c) {
        case 'o': outs.exr = optarg; break;
        case O_PNG: outs.png = optarg; break;
        case O_FRAMES: outs.frames_dir = optarg; break;
        case O_STATS: outs.stats = optarg; break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); return 0;
        case O_VERSION: printf("csi-merge %s\n", CSI_VERSION); return 0;
        default:
            return cli_error(prog, CSI_ERR_ARG, "unknown or incomplete option '%s' (see --help)", argv[optind - 1]);
        }
    }
    if (optind >= argc)
        return cli_error(prog, CSI_ERR_ARG, "no partial given (see --help)");
    if (!outs.exr && !outs.png)
        return cli_error(prog, CSI_ERR_ARG, "no output given: use -o OUT.exr and/or --png OUT.png");
    const double t0 = cli_now();

    /* Pass 1: every partial's header (checksums verified), all of one run, each tile once. */
    cli_partial first;
    csi_status s = cli_partial_read(argv[optind], false, &first);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", cli_last_error());
    const uint32_t count = first.tiling.count;
    const char **by_index = calloc(count, sizeof *by_index);
    if (!by_index)
        return cli_error(prog, CSI_ERR_NOMEM, "out of memory for %u tiles", count);
    int rc = 0;
    for (int a = optind; a < argc && !rc; a++) {
        cli_partial p;
        s = cli_partial_read(argv[a], false, &p);
        if (s != CSI_OK) {
            rc = cli_error(prog, s, "%s", cli_last_error());
            break;
        }
        const char *diff = cli_partial_mismatch(&first, &p);
        if (diff)
            rc = cli_error(prog, CSI_ERR_ARG, "%s: tile %u belongs to another run than %s (they differ in "
                           "%s; inputs %s and %s)", argv[a], p.tile.index, argv[optind], diff, p.input, first.input);
        else if (by_index[p.tile.index])
            rc = cli_error(prog, CSI_ERR_ARG, "%s and %s both hold tile %u", by_index[p.tile.index], argv[a],
                           p.tile.index);
        else
            by_index[p.tile.index] = argv[a];
        cli_partial_free(&p);
    }
    uint32_t missing = 0, first_missing = 0;
    for (uint32_t i = 0; i < count && !rc; i++)
        if (!by_index[i] && missing++ == 0)
            first_missing = i;
    if (!rc && missing)
        rc = cli_error(prog, CSI_ERR_ARG, "tile %u of %u is missing (%u of the %u partials of %s's run are "
                       "not given)", first_missing, count, missing, count, first.input);
    const bool frames = outs.frames_dir != NULL;
    if (!rc && frames && (first.tiling.grid.t == 1 || !first.options.frames))
        rc = cli_error(prog, CSI_ERR_ARG, "--frames: the partials hold no frames (%s)",
                       first.tiling.grid.t == 1 ? "a static image" : "run the tiles with --partial-frames");
    /* Every output stated before the merge (none may be a partial), written all or nothing. */
    csi_outset *set = NULL;
    if (!rc) {
        s = cli_outset_new(&set);
        for (int a = optind; a < argc && s == CSI_OK; a++)
            s = csi_outset_input(set, argv[a]);
        if (s == CSI_OK)
            s = cli_outputs_stage(&outs, set, frames ? first.tiling.grid.t : 0);
        if (s != CSI_OK)
            rc = cli_error(prog, s, "%s", cli_last_error());
    }
    if (rc) {
        cli_outset_free(set);
        free(by_index);
        cli_partial_free(&first);
        return rc;
    }

    /* Pass 2: blend in index order (the order that makes the bits). */
    csi_blend b;
    csi_recon_result res;
    s = csi_tiles_begin(&first.tiling, first.scope.channels, frames, &b, &res);
    for (uint32_t i = 0; i < count && s == CSI_OK; i++) {
        cli_partial p;
        s = cli_partial_read(by_index[i], true, &p);
        if (s == CSI_OK && (cli_partial_mismatch(&first, &p) || p.tile.index != i))
            s = csi_fail(CSI_ERR_ARG, "%s changed while it was merged", by_index[i]);
        if (s == CSI_OK && !frames && p.tile.r.nframes) {
            /* frames the merge does not write: the blend needs only the image */
            free(p.tile.r.frames);
            p.tile.r.frames = NULL;
            p.tile.r.nframes = 0;
        }
        if (s == CSI_OK)
            s = csi_tiles_add(&b, &p.tile);
        cli_partial_free(&p);
    }
    if (s == CSI_OK)
        s = csi_tiles_end(&b);
    res.n = first.scope.n;
    const csi_solver_kind used = res.options.solver; /* the tiles' (their partials hold it) */
    res.options = first.options;                     /* the options as the tiles were given them */
    res.options.solver = used;
    const uint32_t out_w = res.out_w, out_h = res.out_h;
    csi_result *r = NULL;
    if (s == CSI_OK)
        s = csi_result_adopt(&res, &first.tiling.grid, &r);
    if (s == CSI_OK)
        s = cli_write_images(&outs, set, r, first.method);
    if (s == CSI_OK && outs.stats) {
        csi_json *j = NULL;
        s = csi_json_new(&j);
        if (s == CSI_OK) {
            csi_json_str(j, "tool", "csi-merge");
            csi_json_str(j, "input", first.input);
            cli_json_grid(j, &first.tiling.grid);
            csi_result_stats(r, j);
            csi_json_num(j, "t_wall_s", cli_now() - t0);
            s = cli_write_stats(set, outs.stats, j);
            csi_json_free(j);
        }
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s != CSI_OK)
        rc = cli_error(prog, s, "%s", cli_last_error());
    else if (!quiet)
        fprintf(stderr, "%s: %ux%u from %u tiles of %s in %.2f s\n", prog, out_w, out_h, count,
                first.input, cli_now() - t0);
    csi_result_free(r);
    cli_outset_free(set);
    csi_recon_result_free(&res);
    free(by_index);
    cli_partial_free(&first);
    return rc;
}
