/* The tile options of csi-reconstruct and csi-render (tile.h): csi/csi.h only. */
#include "tile.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"

void cli_tile_usage(FILE *f)
{
    fputs(
"tiles on several processes or machines (docs/tiles.md):\n"
"      --tile I/N            reconstruct only tile I (0 <= I < N) of a layout of N tiles and\n"
"                            write it to -o as a partial; csi-merge blends the N partials into\n"
"                            the image (the same bits as one process tiling by itself)\n"
"      --tile-scale S[,S..]  the whole problem's tau scale per channel, as --tile-info prints it\n"
"                            (without it, each --tile run computes it from all the samples)\n"
"      --tile-info           print the layout and the scale as JSON and exit (with --tiles N,\n"
"                            or the layout the budget needs)\n"
"      --partial-frames      with --tile on a volume: keep the window's frames in the partial\n"
"                            (for csi-merge --frames)\n", f);
}

int cli_tile_option(const char *prog, int c, const char *optarg, cli_tile_opts *t)
{
    switch (c) {
    case CLI_O_TILE: {
        char a[32] = "";
        const char *slash = strchr(optarg, '/');
        uint64_t i, n;
        if (!slash || (size_t)(slash - optarg) >= sizeof a)
            return cli_error(prog, CSI_ERR_ARG, "--tile: '%s' is not I/N", optarg);
        memcpy(a, optarg, (size_t)(slash - optarg));
        if (!cli_parse_u64(a, 0, (1u << 20) - 1, &i) || !cli_parse_u64(slash + 1, 1, 1u << 20, &n) || i >= n)
            return cli_error(prog, CSI_ERR_ARG, "--tile: '%s' is not I/N with 0 <= I < N <= 2^20", optarg);
        t->one = true;
        t->index = (uint32_t)i;
        t->count = (uint32_t)n;
        return 0;
    }
    case CLI_O_TILE_SCALE: {
        const char *p = optarg;
        t->nscale = 0;
        while (*p) {
            char *end;
            errno = 0;
            double v = strtod(p, &end);
            if (end == p || errno || !isfinite(v) || v < 0 || t->nscale == 4 || (*end && *end != ','))
                return cli_error(prog, CSI_ERR_ARG, "--tile-scale: '%s' is not 1 to 4 numbers >= 0 separated "
                                 "by commas", optarg);
            t->scale[t->nscale++] = v;
            p = *end ? end + 1 : end;
        }
        if (t->nscale == 0)
            return cli_error(prog, CSI_ERR_ARG, "--tile-scale: no value given");
        t->have_scale = true;
        return 0;
    }
    case CLI_O_TILE_INFO: t->info = true; return 0;
    case CLI_O_PARTIAL_FRAMES: t->frames = true; return 0;
    default: return -1;
    }
}

int cli_tile_check(const char *prog, const cli_tile_opts *t, bool png, bool frames_dir)
{
    if (t->one && t->info)
        return cli_error(prog, CSI_ERR_ARG, "--tile and --tile-info exclude each other");
    if (t->one && (png || frames_dir))
        return cli_error(prog, CSI_ERR_ARG, "--tile writes a partial to -o; --png and --frames belong to "
                         "csi-merge (use --partial-frames to keep the frames)");
    if ((t->have_scale || t->frames) && !t->one && !t->info)
        return cli_error(prog, CSI_ERR_ARG, "--%s applies to --tile runs only",
                         t->have_scale ? "tile-scale" : "partial-frames");
    return 0;
}
