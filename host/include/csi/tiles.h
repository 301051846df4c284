/* Reconstruction in overlapping tiles: any image size in bounded device memory, and units of
 * work that separate processes or machines can run (issue 11).
 *
 * Layout. The output image is split along x and y (output pixels) and, for a volume (grid.t >
 * 1), along t (frames) into n[0] x n[1] x n[2] tiles. The tiles' cores partition the image; a
 * tile's window is its core extended by at least margin[a] on every side that is not the
 * image's edge, and every window along an axis has the same length (one FFT and wavelet size for
 * all tiles: the fine length window * cells-per-pixel is 7-smooth and, for Alg. 1, a multiple of
 * 2^levels). Core boundaries are multiples of align[a] pixels, so that on the fine grid every
 * window starts on the whole grid's coarsest wavelet lattice where the edges allow it.
 *
 * Each tile is an independent reconstruction of the samples inside its window (positions
 * shifted to the window's origin) by the same method, with the whole problem's figures where a
 * default depends on them (csi_tile_scope): the samples per pixel and cells per sample behind
 * the filter width, the tau rule and the normalized-convolution widths, the wavelet levels, and
 * the solver's tau scale. Everything else is the tile's own.
 *
 * Blending. Along each axis a tile's weight ramps from 0 to 1 as S(u) = u^2 (3 - 2u) across the
 * 2 band[a] pixels (frames) centred on each interior core boundary, and the neighbour's as
 * 1 - S(u), so the weights of every pixel sum to 1 (a partition of unity; the 2-D and 3-D
 * weights are products of the 1-D ones) and a pixel outside every band is exactly its own
 * tile's value. Weights are evaluated at pixel (frame) centres and are constant over an output
 * pixel's block of the fine grid: tiles are aligned to output-pixel boundaries, so a pixel's
 * samples are all in every window that contains the pixel and the per-pixel steps after the
 * solve (Alg. 1's control-variate correction) see the same samples as untiled.
 *
 * Determinism. A tile's result depends only on the samples, the options, the layout and the
 * scope, never on which process computes it or when; the blend adds tiles in index order
 * (csi_tiles_add refuses any other order), so the image is the same bits for any number of
 * workers and any completion order. */
#ifndef CSI_TILES_H
#define CSI_TILES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/reconstruct.h"
#include "csi/runtime.h"
#include "csi/samples.h"
#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The default device budget of one reconstruction: 1.5 GiB, at most half of what the device
 * reports as its global memory. PoCL's CPU device derives its limits from the memory free when
 * it starts (1 GiB per buffer and 3.5 GiB in all on one day, 4 GiB and 13 GiB on another), so
 * the default leaves 2 GiB under the smallest total seen and never exceeds the device (a tile's
 * largest buffer is far below 1 GiB, and the planner checks it against the device's own limit).
 * Why 1.5: a 1920x1080 image at 4 spp is then 2 tiles instead of 3 (less CPU: the tiles' margins
 * and steps) with its peak resident memory under 2 GB, which the untiled problem is not
 * (docs/bench/cost.md). */
#define CSI_TILE_DEFAULT_BUDGET (UINT64_C(3) << 29)
uint64_t csi_tile_default_budget(const csi_ctx *ctx);

/* The planner's expected loss of time windows: each interior boundary between windows adds
 * this fraction to the MSE (billiards 64x64 x 256 frames: 2 windows +1.8%, 4 +6.7%, 8 +14.2%
 * of the whole's, docs/bench/scale.md); x/y tiles were measured within 2% of untiled either
 * way and count none. csi_tiling_plan prices a layout as the cells its windows cover in all
 * times 1 + CSI_TILE_T_LOSS (windows - 1) and takes the cheapest that fits. */
#define CSI_TILE_T_LOSS 0.02

/* The planner's cost of a cell whose model grid's FFT rows run pass by pass rather than fused
 * (csi_recon_plan.rows_unfused: a row length the fused kernels do not take), against one whose
 * rows fuse: 1920x1080 at 4 spp solved whole on a 7680-wide model grid, whose rows ran pass by
 * pass before the fused kernels took radices 3 and 5, took 1.6x the CPU per solve step and cell
 * of its two 4096-wide tiles (docs/bench/cost.md, session 18). A layout's
 * price is multiplied by it where its windows' rows do not fuse, so that fewer but wider windows
 * are not taken where they would cost more. */
#define CSI_TILE_UNFUSED_COST 1.5

/* A layout of tiles over one problem (see the top of this file). Axis 0 = x and 1 = y in output
 * pixels, 2 = t in frames (length 1 when grid.t == 1). */
typedef struct csi_tiling {
    csi_grid grid;       /* the whole problem's grid: the image's own, or padded (csi_tiling_layout) */
    uint32_t image_w, image_h; /* the image's own size (pixels): grid.out_w x out_h unless the grid is
                                  padded, then less (the blend's result is cut to it) */
    uint32_t image_t;    /* its frames: grid.t, or fewer when they are padded (then the image is the
                            mean over these, the first, and t is not split) */
    uint32_t length[3];  /* out_w, out_h, grid.t */
    uint32_t n[3];       /* tiles along each axis */
    uint32_t count;      /* n[0] * n[1] * n[2] */
    uint32_t window[3];  /* window length per axis (pixels / frames), the same for every tile */
    uint32_t margin[3];  /* a window reaches at least this far beyond its core inside the image */
    uint32_t band[3];    /* half-width of the blend ramp around each interior core boundary */
    uint32_t align[3];   /* interior core boundaries are multiples of this */
    int levels;          /* Alg. 1: wavelet levels of every tile (the whole grid's); else 0 */
    uint64_t budget;     /* the device budget it was planned for (bytes) */
    uint64_t tile_bytes; /* the device bytes one tile needs (csi/plan.h) ... */
    uint64_t whole_bytes;/* ... and the whole problem untiled */
    uint64_t tile_samples; /* the samples a tile is assumed to hold: its share of samples spread
                              evenly, with 25% headroom, at most all and at most its cells */
} csi_tiling;

/* One tile: its core and window along each axis, [core0, core1) and [win0, win0 + window). */
typedef struct csi_tile {
    uint32_t index;
    uint32_t pos[3]; /* tile coordinates: index = (pos[2] * n[1] + pos[1]) * n[0] + pos[0] */
    uint32_t core0[3], core1[3];
    uint32_t win0[3];
} csi_tile;

/* Chooses the layout of a problem of n samples for opt (csi_recon_options.mem_budget, .tiles,
 * .tiles_t, .tile_margin, .tile_margin_t; ctx gives the device's limits and may be NULL, then
 * only the budget counts). opt->tiles == 0: count 1 when the whole problem fits, else among the
 * layouts that fit (x/y tiles, time windows or both; only opt->tiles_t windows when given) the
 * lowest price (CSI_TILE_T_LOSS, CSI_TILE_UNFUSED_COST), the fewest tiles on a tie; N > 0: exactly N tiles (the
 * factorisation n[0] n[1] n[2] = N that fits at the lowest price). CSI_ERR_ARG when no
 * layout fits (the message names the budget and the smallest tile's bytes) or when N tiles
 * cannot be laid out on the image (fewer pixels than tiles along every factorisation). A tile's
 * bytes are its resource plan (csi/plan.h) with tile_samples samples: samples clustered in one
 * window beyond that headroom make that tile larger than planned. */
csi_status csi_tiling_plan(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const csi_recon_options *opt, csi_tiling *out);

/* The layout a run of the image g solves (csi_recon, and each tile run alone): csi_tiling_plan
 * over the grid csi_recon_solved_grid decides (g's own, or g padded right and down for the FFT,
 * internal.h), with image_w x image_h g's own size. The one decision both make, so that tiles run
 * apart and merged are the one-process run's problem. */
csi_status csi_tiling_layout(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                             const csi_recon_options *opt, csi_tiling *out);
/* The options a run of layout tl over n samples reports (its result's and its EXR's): `solved`,
 * what its one solve resolved (a layout of one tile: that tile's), or for tiles the given options
 * resolved on the whole grid with the steps on the whole result off; then the layout's autos.
 * csi_recon reports these, and a tile run keeps them for the merge (its partial), so that the
 * merged EXR is the one-process run's, attributes and all. solved may be out. */
csi_status csi_recon_reported(const csi_recon_options *given, const csi_tiling *tl, size_t n,
                              const csi_recon_options *solved, csi_recon_options *out);
/* The image's own grid of a layout (its grid cut to image_w x image_h pixels, image_t frames). */
csi_grid csi_tiling_image_grid(const csi_tiling *tl);

/* The binned shutter of a layout split in t (csi_recon_options.tile_image_binned): the frames
 * per bin b, the smallest with ceil(T / b) bins no more than a window's frames and a 7-smooth
 * number of bins (an FFT length); frame t falls into bin t / b, so the bins are equal (the last
 * holds what is left) and a motion at a constant velocity stays one in the bins. 1 when t is
 * not split. */
uint32_t csi_tiling_bin_t(const csi_tiling *tl);
/* Whether the layout's time windows take their image from the binned shutter (binned.c): t
 * split, the compressive estimator and the option on (auto is off). The first window of each x/y
 * column then needs every sample of the column, over the whole shutter (csi_tile_window). */
bool csi_tiling_image_binned(const csi_tiling *tl, const csi_recon_options *opt);

/* CSI_ERR_ARG when the layout splits t and one of its tiles holds none of the n samples (a part
 * of the shutter the dump does not sample): such a window's frames would be zero, and the
 * shutter's mean short by its share, where the untiled solve carries its basis over the gap.
 * The message names the tile, its frames and the remedy (fewer time windows). Layouts not split
 * in t pass: an x/y tile without samples is dark as the untiled image is there. */
csi_status csi_tiling_check_samples(const csi_tiling *tl, const csi_sample_pos *pos, size_t n);
/* The failure csi_tiling_check_samples gives for tile `index` (a tile run alone given only its
 * window's samples finds its own window empty). */
csi_status csi_tiling_empty_tile(const csi_tiling *tl, uint32_t index);

/* Tile `index` (< count) of a layout. */
void csi_tiling_tile(const csi_tiling *tl, uint32_t index, csi_tile *out);

/* The tile's 1-D blend weight at pixel (frame) coordinate c along axis a (0 outside its
 * window). The weights of all tiles at any coordinate sum to 1. */
double csi_tile_weight(const csi_tiling *tl, const csi_tile *t, int axis, uint32_t c);

/* NULL when tl could be a layout csi_tiling_layout made: a grid whose sizes divide, the axes'
 * lengths its output's, an image size within them, on each axis at least one tile and no more than the axis has alignment
 * units, windows no longer than the axis (the whole axis for one tile) and together at least as
 * long, and count the product of the tiles per axis; otherwise what is wrong ("the tile count").
 * A layout read from a file (docs/partial-format.md) is checked before csi_tiling_tile or a
 * blend uses it: they divide by its tile counts and index the output with its windows, and the
 * windows' lengths make the output no larger than the tiles' pixels, which the files hold. */
const char *csi_tiling_check(const csi_tiling *tl);

/* Whether two layouts are the same (every field that decides windows and weights). */
bool csi_tiling_equal(const csi_tiling *a, const csi_tiling *b);

/* The whole problem's figures every tile's defaults follow (see the top of this file). */
typedef struct csi_tile_scope {
    uint64_t k, n;       /* cells and samples of the whole problem */
    uint32_t out_w, out_h;
    uint32_t channels;
    /* Per channel, the solver's tau scale: Alg. 1 (SpaRSA), ||A^H y||_inf of the whole problem,
     * taken as the largest over the tiles' own (the wavelets are local, so the whole image's
     * largest coefficient is some tile's); Alg. 2, the mean sample value, from which a tile's
     * scale is the whole volume's DC coefficient rescaled to the tile's cells and samples,
     * n_t mean / sqrt(k_t) (for non-negative samples the DC coefficient is ||A^H y||_inf).
     * 0 where unknown: that tile then scales tau by its own ||A^H y||_inf (the untiled rule
     * applied to the tile). */
    double scale[4];
    bool has_scale;
} csi_tile_scope;

/* The scope's sizes (k, n, out_w, out_h, channels) for a grid with n samples, and no scale. */
void csi_tile_scope_init(const csi_grid *g, uint32_t channels, size_t n, csi_tile_scope *out);

/* The scope of a problem from all its samples: k, n and, for the compressive estimator, the
 * tau scale (Alg. 1: one operator setup and one adjoint per tile and channel; Alg. 2: a pass
 * over the samples). ctx is needed for Alg. 1. */
csi_status csi_tile_scope_make(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                               const csi_sample_pos *pos, const float *values, size_t n,
                               const csi_recon_options *opt, const csi_tiling *tl,
                               csi_tile_scope *out);

/* One tile's reconstruction: the result is the tile's window (out_w x out_h = window[0] x
 * window[1] pixels at window origin x0, y0; frames t0 .. t0 + nframes - 1). Its image is, when
 * t is not split, the tile's image; when it is, the tile's share of the mean over t,
 * sum over its frames of w_t(t) frame(t) / grid.t. Frames (opt->frames) are the tile's own.
 *
 * A time window's image is corrected once over the whole shutter, after the blend, by the
 * residuals of every sample against the blended volume (Alg. 2's per-pixel correction with a
 * still basis, csi_aa_correct AUTO): each window's samples weighted by its blend weight there
 * (w = w_x w_y w_t, summing to 1 over the tiles that hold a sample) give, per channel and
 * window pixel, CSI_RESID_SUMS doubles in `resid` ([c][y][x][7]): the weight of the pixel's
 * samples, their weighted mean residual against the window's volume, the weighted sum of
 * squared deviations from it, the smallest and largest value of the samples of weight > 0, and
 * the weighted mean of their values and sum of squared deviations from it (the range the
 * corrected image is projected onto grows where a pixel's values change over t), and of the
 * window's frames (the pixel's box mean in each, frame t weighted by w_x w_y w_t(t), over the
 * shutter's frames) the weight, the weighted mean and the weighted sum of squared deviations
 * from it (with noisy samples, what the fit says the pixel's samples spread by over t:
 * csi_recon_motion_toward_mean).
 * Blended over the tiles they give each pixel's sample count and mean residual against the
 * blended volume exactly, and a sum of squares no smaller than the blended volume's (a sample
 * two windows share counts both windows' residuals). NULL when t is not split, and when the
 * window's basis is sheared (then no tile's image is corrected). The frames' sums blended over
 * the tiles are those of the windows' frames taken together, each at its weight: where two
 * windows overlap in t both count, so their spread is no smaller than the blended frames'. */
#define CSI_RESID_SUMS 10
/* A still image whose pixels settle on their samples' mean (csi/settle.h) settles once, on the
 * blended image, so that a pixel's share is of the whole image's disagreement as in an untiled
 * run (settled in each window, on that window's smaller disagreement, more pixels settled than
 * untiled and the tiled image lost against the untiled one: docs/bench/scale.md). Each tile gives the
 * sample count px_cnt[p] and channel sums px_sum[p * channels + c] (csi_pixel_sums_add) of its
 * window's pixels, counting only the samples of its core's pixels: every pixel lies in one core,
 * so the tiles' sums added are the whole image's exactly. NULL when the image does not settle.
 *
 * A still image given the samples' variances moves an HDR step's pixels by the coverage their
 * window's samples allow (csi/step_coverage.h) once, after the settling: step_delta (planar, the
 * window's size, NULL when the step does not run) is what the step adds to each pixel of the
 * tile's core (0 elsewhere), from the samples of its 3 x 3 pixels, which lie inside the window,
 * and the whole image's mean sample: the tiles' deltas together are the whole image's.
 *
 * A time window's image is averaged with the denoised frames' mean (image_frames) once, after the
 * correction: frames_mean ([c][y][x], NULL unless t is split and the option is on) is the
 * window's share of that mean, sum over its frames of w_t(t) denoised frame(t) / grid.t, which
 * blended like the image is the mean over t of the blended denoised frames. */
typedef struct csi_tile_result {
    uint32_t index;
    uint32_t x0, y0, t0;
    csi_recon_result r;
    /* the samples were flagged exact (CSI_SAMPLES_EXACT): the whole shutter's correction from the
     * residual sums is then an untiled run's for exact samples (motion_correct.c) */
    bool exact;
    double *resid;
    uint32_t *px_cnt;
    double *px_sum;
    float *step_delta;
    float *frames_mean;
} csi_tile_result;
void csi_tile_result_free(csi_tile_result *t);

/* Reconstructs tile `index` of layout tl from the whole problem's samples (pos, values, n as for
 * csi_recon; the tile takes those inside its window). scope from csi_tile_scope_make, or
 * made by the caller from values it was given (a tile run on another machine). */
csi_status csi_recon_tile(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                const csi_sample_pos *pos, const float *values, size_t n,
                                const csi_recon_options *opt, const csi_tiling *tl,
                                const csi_tile_scope *scope, uint32_t index, csi_tile_result *out);

/* Blending: csi_tiles_begin allocates the whole result (image, and frames when `frames`), then
 * csi_tiles_add blends tiles 0, 1, ..., count - 1 in that order (another order, a tile of
 * another layout or size is CSI_ERR_ARG), and csi_tiles_end checks that all came and sums the
 * solver reports (iterations and times added, the largest residual, converged when all did). */
typedef struct csi_blend {
    csi_tiling tl;
    uint32_t next;
    csi_recon_result *out;
    double *resid;  /* time windows: the whole image's residual sums (csi_tile_result) */
    bool resid_all; /* every tile so far had them: the image is corrected at the end */
    uint32_t *px_cnt; /* a still image that settles: the whole image's pixel sums (csi_tile_result) */
    double *px_sum;
    /* a still image given the variances: the HDR step's changes (csi_tile_result), only those not
     * 0 (a few pixels' worth): value v at image index at */
    struct csi_step_change {
        size_t at;
        float v;
    } *step_changes;
    size_t step_count, step_cap;
    bool step_given; /* the tiles carry the changes */
    float *frames_mean; /* time windows with image_frames: the blended frames' mean (csi_tile_result) */
    bool exact;         /* the tiles' samples are flagged exact (csi_tile_result) */
} csi_blend;
csi_status csi_tiles_begin(const csi_tiling *tl, uint32_t channels, bool frames,
                           csi_blend *b, csi_recon_result *out);
csi_status csi_tiles_add(csi_blend *b, const csi_tile_result *t);
/* Time windows: corrects the image by the residual sums of all tiles, then averages it with the
 * blended frames' mean where the tiles carry theirs (image_frames); a still image whose tiles
 * all carry pixel sums: settles it on them, then adds the tiles' HDR step changes where they carry
 * them (see csi_tile_result). A padded layout's result is then
 * cut to the image's own size (image_w x image_h, image_t frames). */
csi_status csi_tiles_end(csi_blend *b);
/* Releases what the blend holds besides out (csi_tiles_end does it too): for a blend given up. */
void csi_tiles_release(csi_blend *b);

/* The whole tiled reconstruction in this process: layout tl (count >= 1), scope, every tile in
 * index order, blended. csi_recon calls it when its plan needs more than one tile. */
csi_status csi_recon_tiled(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                 const csi_sample_pos *pos, const float *values, size_t n,
                                 const csi_recon_options *opt, const csi_tiling *tl,
                                 csi_recon_result *out);

#ifdef __cplusplus
}
#endif
#endif
