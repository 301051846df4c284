/* One tile of a reconstruction run alone (--tile I/N), and the layout a farm needs to know
 * (--tile-info): shared by csi-reconstruct and csi-render (see docs/tiles.md). */
#ifndef CSI_CLI_TILE_H
#define CSI_CLI_TILE_H

#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>

#include "csi/tiles.h"
#include "partial.h"

/* getopt values of the tile options; a program's own values stay below, the shared
 * reconstruction options (recon_opts.h) above. */
enum { CLI_TILE_FIRST = 900, CLI_O_TILE, CLI_O_TILE_SCALE, CLI_O_TILE_INFO, CLI_O_PARTIAL_FRAMES };
#define CLI_TILE_LONGOPTS                                                                      \
    {"tile", required_argument, 0, CLI_O_TILE}, {"tile-scale", required_argument, 0, CLI_O_TILE_SCALE}, \
    {"tile-info", no_argument, 0, CLI_O_TILE_INFO}, {"partial-frames", no_argument, 0, CLI_O_PARTIAL_FRAMES}

typedef struct cli_tile_opts {
    bool one;             /* --tile I/N */
    uint32_t index, count;
    bool info;            /* --tile-info */
    bool have_scale;      /* --tile-scale */
    uint32_t nscale;
    double scale[4];
    bool frames;          /* --partial-frames */
} cli_tile_opts;

/* Applies c if it is a tile option: 0 when applied, -1 when it is not one, else the exit code
 * after printing the error. */
int cli_tile_option(const char *prog, int c, const char *optarg, cli_tile_opts *t);
void cli_tile_usage(FILE *f);

/* Checks the tile options against each other and the outputs (one line, exit code) or 0. */
int cli_tile_check(const char *prog, const cli_tile_opts *t, bool png, bool frames_dir);

/* The layout for the options (opt->tiles = count when --tile I/N), checking that I < N. */
csi_status cli_tile_layout(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const cli_tile_opts *t, csi_recon_options *opt, csi_tiling *tl);

/* The scope from --tile-scale (k, n and the grid from the arguments, the scale as given) into
 * *scope, when it was given; returns false (scope untouched) when it was not. */
bool cli_tile_given_scope(const cli_tile_opts *t, const csi_grid *g, uint32_t channels, size_t n,
                          csi_tile_scope *scope);

/* Prints the layout and scope as one JSON object on stdout (what a farm submits from). */
csi_status cli_tile_info_print(const csi_tiling *tl, const csi_tile_scope *scope,
                               const csi_recon_options *opt, uint64_t input_id);

/* Writes the partial of tile `res` (the rest of the partial from the arguments). */
csi_status cli_tile_write(const char *path, const char *method, const char *input_name,
                          uint64_t input_id, const csi_recon_options *opt, const csi_tiling *tl,
                          const csi_tile_scope *scope, const csi_tile_result *res);

#endif
