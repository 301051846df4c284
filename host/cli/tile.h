/* One tile of a reconstruction run alone (--tile I/N), and the layout a farm needs to know
 * (--tile-info): shared by csi-reconstruct and csi-render (see docs/tiles.md). The options
 * (common_tile.c) and the runs (common_tile_run.c) use csi/csi.h only: the tile's reconstruction
 * (csi_reconstruct_tile, or csi_reconstruct_tile_window for csi-render, which traces only the
 * samples of the tile's window) and its partial (csi_partial_write; the format is
 * docs/partial-format.md). */
#ifndef CSI_CLI_TILE_H
#define CSI_CLI_TILE_H

#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>

#include "outputs.h"

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

/* progress (may be NULL) shows the tile's reconstruction (cli_progress on stderr). */
/* csi-reconstruct --tile / --tile-info over the dump's samples s (`input`: the dump's path): the
 * layout and the whole problem's scale, then tile t->index's partial written to outs->exr (and
 * statistics), or the layout as JSON on stdout. Returns the exit code, after printing an error. */
int cli_tile_run_samples(const char *prog, csi_device *dev, csi_outset *set, const csi_samples *s,
                         const char *input, csi_options *opt, const cli_tile_opts *t, const cli_outputs *outs,
                         bool quiet, cli_recon_progress *progress);

/* Evaluates n samples (their positions, and their indices among all the samples of the run, so
 * that they get the values an untiled render gives them) into rgb (n x 3). */
typedef csi_status (*cli_tile_eval_fn)(void *user, const csi_sample_pos *pos, const uint64_t *ids, size_t n,
                                       float *rgb);
/* csi-render --tile / --tile-info: the same over a scene whose n positions are known but not yet
 * evaluated; a tile evaluates only the samples inside its window, and without --tile-scale scales
 * tau by its own samples, as an untiled run of the window would. `positions` names the positions'
 * method for the partial's method text; sample_flags (CSI_SAMPLES_*) says what the values will
 * be, as csi_samples.flags does. */
int cli_tile_run_render(const char *prog, csi_device *dev, csi_outset *set, const char *scene_path,
                        const csi_grid *g, const csi_pos_opts *po, const csi_sample_pos *pos, size_t n,
                        uint32_t sample_flags, csi_options *opt, const cli_tile_opts *t, const cli_outputs *outs,
                        bool quiet, cli_recon_progress *progress, cli_tile_eval_fn eval, void *user);

#endif
