/* csi-merge: blends the partials of one tiled run (csi-reconstruct / csi-render --tile I/N)
 * into the final image. See --help and docs/tiles.md. A thin main over csi/csi.h
 * (csi_partials_merge); its outputs are written as the other programs write theirs (outputs.h). */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "outputs.h"

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
"  -q, --quiet               no progress and no summary line\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n", f);
}

typedef struct {
    cli_progress *bar;
    uint32_t tiles;
} merge_progress;

static bool on_merge(void *user, const csi_progress *p)
{
    const merge_progress *m = user;
    char detail[48];
    snprintf(detail, sizeof detail, "%d of %u tiles", p->iteration, m->tiles);
    cli_progress_update(m->bar, p->phase, m->tiles ? (double)p->iteration / m->tiles : -1, detail);
    return true;
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

    /* The first partial tells the run's grid (its frames folder) before any work; the merge
     * then checks every partial before it blends any. */
    const bool frames = outs.frames_dir != NULL;
    csi_partial_info info;
    csi_status s = csi_partial_read_info(argv[optind], &info);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", cli_last_error());
    if (frames && !info.frames)
        return cli_error(prog, CSI_ERR_ARG, "--frames: the partials hold no frames (%s)",
                         info.grid.t == 1 ? "a static image" : "run the tiles with --partial-frames");
    /* Every output stated before the merge (none may be a partial), written all or nothing. */
    csi_outset *set = NULL;
    s = cli_outset_new(&set);
    for (int a = optind; a < argc && s == CSI_OK; a++)
        s = csi_outset_input(set, argv[a]);
    if (s == CSI_OK)
        s = cli_outputs_stage(&outs, set, frames ? info.grid.t : 0);
    csi_result *r = NULL;
    cli_progress bar;
    if (s == CSI_OK && !cli_progress_init(&bar, prog, quiet))
        s = CSI_ERR_ARG;
    merge_progress mp = {&bar, info.tile_count};
    if (s == CSI_OK) {
        s = csi_partials_merge((const char *const *)argv + optind, (size_t)(argc - optind), frames, on_merge, &mp, &r,
                               &info);
        cli_progress_end(&bar);
    }
    if (s == CSI_OK)
        s = cli_write_images(&outs, set, r, info.method, &bar);
    if (s == CSI_OK && outs.stats) {
        csi_json *j = NULL;
        s = csi_json_new(&j);
        if (s == CSI_OK) {
            csi_json_str(j, "tool", "csi-merge");
            csi_json_str(j, "input", info.input);
            cli_json_grid(j, &info.grid);
            csi_result_stats(r, j);
            csi_json_num(j, "t_wall_s", cli_now() - t0);
            s = cli_write_stats(set, outs.stats, j);
            csi_json_free(j);
        }
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    int rc = 0;
    if (s != CSI_OK)
        rc = cli_error(prog, s, "%s", cli_last_error());
    else if (!quiet) {
        csi_image view;
        csi_result_image(r, &view);
        fprintf(stderr, "%s: %ux%u from %u tiles of %s in %.2f s\n", prog, view.w, view.h, info.tile_count,
                info.input, cli_now() - t0);
    }
    csi_result_free(r);
    cli_outset_free(set);
    return rc;
}
