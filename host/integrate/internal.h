/* What the files of the reconstruction share (not installed, not part of the public API):
 * the state of one reconstruction, the methods it dispatches to, and their common steps. */
#ifndef CSI_INTEGRATE_INTERNAL_H
#define CSI_INTEGRATE_INTERNAL_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>

#include "csi/linop.h"
#include "csi/plan.h"
#include "csi/reconstruct.h"
#include "csi/tiles.h"

typedef struct csi_recon_coarse csi_recon_coarse;

/* Everything one reconstruction allocates, released in one place (reconstruct.c). */
typedef struct {
    csi_linop *S, *inner, *A, *Psi, *W;
    csi_linop *Wbox, *Ipix; /* Alg. 1 on a model grid: box-mean filter, reading at the pixels */
    csi_solver *solver;
    cl_mem y, x, f, tmp, out;
    uint32_t *idx;
    float *plane;
    cl_mem romp_norms;   /* ROMP column norms, made once for all channels (or NULL) */
    uint32_t *romp_seed; /* ROMP seed support (or NULL) */
    size_t romp_seed_n;
    /* A tile's reconstruction: the whole problem's figures the defaults follow (csi/tiles.h);
     * NULL when the problem is the whole. Borrowed, not freed. */
    const csi_tile_scope *scope;
    uint32_t channel, channels; /* the channel being solved, for the progress reports */
    bool warm;                  /* x holds the starting point of this solve (warm_channels) */
    /* A time window's fit at its samples (csi_recon_scoped); NULL otherwise. Borrowed. */
    struct csi_recon_fit *fit;
    /* Alg. 1's continuation stages on a coarser grid (coarse_start.c), or NULL. */
    csi_recon_coarse *coarse;
} csi_recon_state;

/* What a time window (csi/tiles.h) hands on for the correction of the whole shutter's image:
 * Alg. 2 with a still basis then leaves the window's image uncorrected (its frames are what the
 * blend uses) and stores the volume at the samples in `at` (the caller's n * channels floats,
 * channel-major), setting `kept`. Another method or a sheared basis leaves kept false. */
typedef struct csi_recon_fit {
    float *at;
    bool kept;
} csi_recon_fit;

/* Residual sums (csi/tiles.h: CSI_RESID_SUMS doubles each) of `pixels` pixels that hold no
 * sample yet: a time window's (tiled.c) and the blend's (tile_blend.c). */
void csi_tiles_resid_clear(double *r, size_t pixels);

/* An image or volume whose grid the transforms cannot take along x or y (a side of 1366, 3440
 * or 858 pixels: a prime factor above 7 in cells x pixels) is solved on a grid padded on the
 * right and the bottom to the nearest lengths they take (padding.c), from the same samples, and
 * cropped: the padding holds no sample and is filled like any region without one. A volume's
 * frame count (11, 13 ...) is padded the same way with later frames, and its image is the mean
 * over its own frames only (csi_recon_options.shutter_frames). csi_recon_pad_grid: whether g
 * needs it, and the padded grid (g itself when not). */
bool csi_recon_pad_grid(const csi_grid *g, csi_grid *padded);
/* Whether v > 0 has no prime factor above 7: a length csi's FFT takes (padding.c). */
bool csi_smooth7(uint64_t v);
/* The grid csi_recon solves an image on (into out; returns whether it is padded): the padded
 * grid when g needs it and it fits the budget whole, or when no layout of tiles of g's own
 * (windows of lengths the transforms take) does; else g. The layout of the one-process run and
 * of each tile run alone follows it (csi_tiling_layout, csi/tiles.h). */
bool csi_recon_solved_grid(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const csi_recon_options *opt, csi_grid *out);
/* s, a refusal of the problem of g padded to `padded` (csi_last_error says why), said of the image
 * g: the message names both sizes. */
csi_status csi_recon_padded_fail(csi_status s, const csi_grid *g, const csi_grid *padded);
/* The result's image and frames cut to their top-left out_w x out_h pixels, and the frames to
 * their first nframes (ignored without frames). */
csi_status csi_recon_crop(csi_recon_result *r, uint32_t out_w, uint32_t out_h, uint32_t nframes);

/* The cross-validated choice (csi/cv_select.h) on a still image's result `out` (reconstructed
 * from all n samples with opt): the two folds' reconstructions, then the choice in out->image;
 * their times and CPU are added to out's. Nothing changes where no pixel holds samples of both
 * folds. */
csi_status csi_recon_cv_select(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                               const float *values, size_t n, const csi_recon_options *opt,
                               csi_recon_result *out);
/* The same on a tile's window cut from a larger image at output pixel (ox, oy): the choice's
 * regions are the larger image's (tiled.c); out->cv_switched counts the pixels inside box (x0, y0,
 * x1, y1 in the window's pixels: the tile's core, so that the tiles' counts add up to the image's;
 * NULL: all). */
csi_status csi_recon_cv_select_at(csi_ctx *ctx, const csi_grid *g, uint32_t ox, uint32_t oy, const uint32_t *box,
                                  uint32_t channels, const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, csi_recon_result *out);

/* The image of a volume's result `out` (reconstructed whole from all n samples with opt) chosen
 * per region between it and binned solves' by two-fold cross-validation (motion_image.c); the
 * count of pixels that changed in out->motion_image_switched. */
csi_status csi_recon_motion_image(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                  const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, csi_recon_result *out);

/* Isolated peaks by the log fit (csi/peak_range.h) on a still image's result `out`
 * (reconstructed from all n samples with opt, out->options resolved): the peak pixels take the
 * fit's value; its time and CPU are added to out's. Nothing runs where no pixel is a peak pixel. */
csi_status csi_recon_peak_range(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                const float *values, size_t n, const csi_recon_options *opt,
                                csi_recon_result *out);

/* Releases everything in st (not st itself). */
void csi_recon_state_free(csi_recon_state *st);

/* The cells and samples the filter width follows: the whole problem's when st is a tile's,
 * else k and n. */
static inline double csi_recon_scope_k(const csi_recon_state *st, size_t k)
{
    return st->scope ? (double)st->scope->k : (double)k;
}
static inline double csi_recon_scope_n(const csi_recon_state *st, size_t n)
{
    return st->scope ? (double)st->scope->n : (double)n;
}

/* The width of Alg. 1's filter in Alg. 2's solve for a still basis (csi_recon_options.motion_filter
 * given, or its auto rule; motion.c), -1 for none; with a sheared basis auto is none. */
double csi_recon_motion_filter_width(const csi_grid *g, size_t n, const csi_recon_options *opt,
                                     const csi_tile_scope *scope);

/* csi_recon_resolve for one problem: a tile's (scope non-NULL) follows the whole problem's
 * cells, samples and pixels where a default depends on them (csi/tiles.h), its own grid for the
 * wavelet levels and its own samples for Alg. 2's tau rule (its tau scale is rescaled to them). */
csi_status csi_recon_resolve_scoped(const csi_recon_options *in, const csi_grid *g, size_t n,
                                    const csi_tile_scope *scope, csi_recon_options *out);

/* The dispatch of csi_recon on one problem (no tiling): the whole when scope is NULL, a tile's
 * window otherwise. Resolves the options' autos for it (csi_recon_resolve_scoped). */
csi_status csi_recon_scoped(csi_ctx *ctx, const csi_grid *grid, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt, const csi_tile_scope *scope,
                            csi_recon_fit *fit, csi_recon_result *out);

/* Alg. 1's tau scale of one problem: ||A^H y||_inf per channel, A built as csi_recon_antialias
 * builds it (st->idx and st->plane filled by the caller; st freed by the caller); RGB solved as
 * luma and chroma (chroma.c): luma's, and the chroma channels' from it. */
csi_status csi_recon_antialias_scale(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                     const float *values, size_t n, const csi_recon_options *opt,
                                     csi_recon_state *st, double scale[4]);

/* The methods, with resolved options (each fills res and st; csi_recon_scoped frees st). */
csi_status csi_recon_antialias(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                               const csi_sample_pos *pos, const float *values, size_t n,
                               const csi_recon_options *opt, csi_recon_result *res,
                               csi_recon_state *st);
csi_status csi_recon_motion(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt, csi_recon_result *res,
                            csi_recon_state *st);
/* Reweighted l1 in Alg. 2's solve (motion_reweight.c): a second solver on A G, G a gain per
 * coefficient. _run re-solves opt->motion_reweight times from the solution in st->x (tau from
 * tau_scale, the unweighted operator's ||A^H y||_inf), leaving the last in st->x and in rep the
 * last solve's report with every solve's work added. */
typedef struct csi_motion_reweight csi_motion_reweight;
csi_status csi_motion_reweight_create(csi_linop *A, csi_motion_reweight **out);
csi_status csi_motion_reweight_run(csi_motion_reweight *rw, csi_recon_state *st, const csi_recon_options *opt,
                                   double tau_scale, csi_solve_report *rep);
void csi_motion_reweight_free(csi_motion_reweight *rw);
void csi_motion_reweight_buffers(size_t rows, size_t cols, csi_mem_tally *t);
uint64_t csi_motion_reweight_host_bytes(size_t rows, size_t cols);
csi_status csi_recon_gauss_nc(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const csi_recon_options *opt, csi_recon_result *res,
                              csi_recon_state *st);
csi_status csi_recon_sample_mean(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                 const csi_sample_pos *pos, const float *values, size_t n,
                                 const csi_recon_options *opt, csi_recon_result *res, csi_recon_state *st);

/* The checks of csi_recon that need only the sizes (CSI_ERR_ARG): 1 to 4 channels, no
 * zero size, grid sides multiples of the output's, at most 2^32 cells, 1 <= n <= k. */
csi_status csi_recon_check_sizes(const csi_grid *g, uint32_t channels, size_t n);
/* The plan (csi/plan.h) of one problem solved whole (csi_reconstruct_scoped), no tiling, with
 * the checks of csi_recon_plan_make; scope: a tile's whole problem (NULL: this is the whole);
 * ctx: the device it will run on, whose local memory decides some buffers (NULL: unknown, the
 * plan then counts them). */
csi_status csi_recon_plan_whole(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                                const csi_recon_options *opt, const csi_tile_scope *scope, csi_recon_plan *out);

/* The shape of Alg. 1's operator (antialias.c): the Gaussian widths (fine cells), the wavelet
 * levels, and the model grid (mw x mh cells, D times coarser than the fine grid, mlevels levels;
 * D = 1: the fine grid), for resolved options (csi_recon_resolve). st may be a tile's (its scope
 * sets the widths); CSI_ERR_ARG when the grid allows no wavelet level. */
typedef struct {
    double sphi[3];
    int levels, mlevels;
    unsigned D;
    size_t mw, mh;
} csi_aa_shape;
csi_status csi_recon_aa_shape(const csi_grid *g, size_t n, const csi_recon_options *opt,
                              const csi_recon_state *st, csi_aa_shape *out);

/* A = S . (Phi^-1 . Psi) into st (the compositions own their parts; st->Psi and st->W are
 * borrowed from st->inner), on the model grid D times coarser when the filter allows it. opt is
 * resolved (csi_recon_resolve_scoped); the filter width follows the whole problem's cells per
 * sample when st is a tile's. *shape: its shape (the model grid, D, the filter widths). */
csi_status csi_recon_aa_operator(csi_ctx *ctx, const csi_grid *g, size_t n, const csi_recon_options *opt,
                                 csi_recon_state *st, csi_aa_shape *shape);
/* After a solve of st's operator (model grid factor D): the box integral of the estimate into
 * plane (the output's pixels, host), and where the estimate at the samples is for
 * csi_recon_correct: its (S, fine) pair in *S, *at (S NULL: *at holds it; valid until the next
 * solve on st's workspace). */
csi_status csi_recon_aa_integrate(csi_ctx *ctx, const csi_grid *g, const csi_recon_options *opt,
                                  csi_recon_state *st, unsigned D, float *plane, const csi_linop **S,
                                  cl_mem *at);
/* Alg. 1's per-pixel correction for resolved options: the option, or by the samples' kind. */
csi_aa_correct csi_recon_aa_correction(const csi_recon_options *opt);

/* RGB solved as luma and chroma (chroma.c): whether a problem is (three channels of a still
 * image, SpaRSA's sharp estimate on a model grid, the option on); Alg. 1 in that form
 * (csi_recon_antialias hands it over); opponent channel k (0: Y, 1: C1, 2: C2) of n RGB samples
 * (sample-major, 3 per sample) into plane; and a chroma channel's tau scale from luma's
 * ||A^H Y||_inf (a tile's scope takes the whole problem's, csi_recon_antialias_scale). */
bool csi_recon_chroma_on(const csi_grid *g, uint32_t channels, const csi_recon_options *opt);
csi_status csi_recon_antialias_chroma(csi_ctx *ctx, const csi_grid *g, const csi_sample_pos *pos,
                                      const float *values, size_t n, const csi_recon_options *opt,
                                      csi_recon_result *res, csi_recon_state *st);
void csi_recon_opponent(const float *rgb, size_t n, uint32_t k, float *plane);
double csi_recon_chroma_tau_scale(double luma);
/* The chroma channels' options (opt resolved): the coarser model grid, and the stop that luma's
 * solve shares (a fraction of opt's tol). Their operator is a second one beside luma's, on luma's
 * solver workspace (plan.c counts it). */
csi_recon_options csi_recon_chroma_options(const csi_recon_options *opt);

/* The coarse start (coarse_start.c): the operator on the model grid of shape sh coarsened once
 * more, for the samples at idx, its solver on the device buffers of the model grid's (fine);
 * *out NULL (and CSI_OK) where that grid is not available. */
csi_status csi_recon_coarse_create(csi_ctx *ctx, const csi_aa_shape *sh, const csi_recon_options *opt,
                                   const uint32_t *idx, size_t n, const csi_solver *fine,
                                   csi_recon_coarse **out);
void csi_recon_coarse_free(csi_recon_coarse *c);
/* The coarse grid's factor for a problem of shape sh (2 sh->D), or 0 where there is no coarse
 * start (the option off, another solver, no continuation, no coarser grid); and the device
 * buffers it adds, for the resource plan (plan.c). */
unsigned csi_recon_coarse_factor(const csi_aa_shape *sh, const csi_recon_options *opt);
void csi_recon_coarse_buffers(const csi_aa_shape *sh, const csi_recon_options *opt, size_t n, csi_mem_tally *t);
/* SpaRSA's stages before the last (options o, an absolute tau) on the coarse grid, their result
 * written into x, the model grid's fine_k coefficients, for the last stage to start from. */
csi_status csi_recon_coarse_stages(csi_ctx *ctx, csi_recon_coarse *c, cl_mem y, const csi_sparsa_options *o,
                                   cl_mem x, size_t fine_k, csi_solve_report *rep);

/* Runs the solver opt->solver on st->A, st->y into st->x, with the resolved options
 * (csi_recon_resolve). tau_scale > 0: SpaRSA's tau is tau_rel * tau_scale (a tile following the
 * whole problem's scale) instead of tau_rel * ||A^H y||_inf. */
csi_status csi_recon_run_solver(csi_recon_state *st, const csi_recon_options *opt, double tau_scale,
                                csi_solve_report *rep);
/* ROMP's support limit for N samples: romp_max_support as a count, or as a fraction of N. */
size_t csi_recon_romp_support_limit(const csi_recon_options *o, size_t N);

/* Starts channel c of `channels`: records it in st, reports "solve c/C", and when its samples
 * are bitwise those of an earlier channel (a grey image's R, G and B) copies that channel's
 * result (image plane, frames, report) and sets *copied: nothing is left to do for c. Solving
 * is deterministic, so the copy has the bits solving again would give. CSI_ERR_CANCELLED when
 * the progress callback asks to stop. */
csi_status csi_recon_channel_begin(csi_recon_state *st, const csi_recon_options *opt,
                                   csi_recon_result *res, const float *values, size_t n,
                                   uint32_t channels, uint32_t c, bool *copied);

/* Any finite float32 reconstructs (result.c): per channel, e[c] = 0 when its largest magnitude
 * is within [2^-32, 2^32], else the exponent that brings it into [0.5, 1); common: one e for all
 * channels, by the largest magnitude of any (channels solved as mixtures of each other: RGB as
 * luma and chroma, chroma.c); *scaled is a copy of the values times 2^-e[c] (NULL when every
 * e[c] is 0). After the solve, the result's image and frames are multiplied back by 2^e[c],
 * saturating at +-FLT_MAX. */
csi_status csi_recon_scale_values(const float *values, size_t n, uint32_t channels, bool common, int e[4],
                                  float **scaled);
/* Whether csi_recon_scale_values scales the channels in common for options opt (as given or
 * resolved; auto is on): RGB that may be solved as luma and chroma. */
static inline bool csi_recon_scale_common(uint32_t channels, const csi_recon_options *opt)
{
    return channels == 3 && opt->chroma != CSI_SWITCH_OFF;
}
void csi_recon_unscale_result(csi_recon_result *r, const int e[4]);

/* Monotonic clock in seconds. */
double csi_recon_now(void);
/* The process's CPU time in seconds (every thread, PoCL's workers included). */
double csi_recon_cpu_now(void);
/* Reports a phase to the caller's progress callback (opt or its callback may be NULL: nothing
 * to report): CSI_ERR_CANCELLED when it asks to stop. */
csi_status csi_recon_progress(const csi_recon_options *opt, const char *phase);
/* The same with the steps of the phase done so far (the velocity search's steps, a host pass's
 * passes over the image), so that a long phase is heard from while it works. */
csi_status csi_recon_progress_step(const csi_recon_options *opt, const char *phase, int done);
/* The same for a phase of channel c of `channels`: "<phase> <c+1>/<channels>". */
csi_status csi_recon_progress_channel(const csi_recon_options *opt, const char *phase, uint32_t c,
                                      uint32_t channels);
csi_status csi_recon_progress_channel_step(const csi_recon_options *opt, const char *phase, uint32_t c,
                                           uint32_t channels, int done);
/* CSI_ERR_NUMERIC naming `what` and the first non-finite element of a. */
csi_status csi_recon_check_finite(const float *a, size_t n, const char *what);
/* Integrates one channel's real volume `vol` (w x h x T) into the result: the image plane is the
 * box integral of its mean over t; frames (if asked for) the box integral of each slice.
 * scratch_wh: w*h floats; out: out_w*out_h floats. */
csi_status csi_recon_integrate_volume(csi_ctx *ctx, const csi_grid *g, cl_mem vol, uint32_t c,
                                      const csi_recon_options *opt, csi_recon_result *res,
                                      cl_mem scratch_wh, cl_mem out);

/* The output pixel (row-major, ow wide) that holds a sample, for pixels of bw x bh cells. */
static inline size_t csi_recon_pixel_of(csi_sample_pos p, uint32_t bw, uint32_t bh, size_t ow)
{
    return (size_t)(p.y / bh) * ow + p.x / bw;
}

/* fmin and fmax inlined (the library's are calls), with their results for every argument: the
 * argument that is not NaN, and of two equal ones (+0 and -0) the second, as glibc's. */
static inline double csi_fmin(double a, double b)
{
    return a < b ? a : isnan(b) ? a : b;
}
static inline double csi_fmax(double a, double b)
{
    return a > b ? a : isnan(b) ? a : b;
}
static inline float csi_fminf(float a, float b)
{
    return a < b ? a : isnan(b) ? a : b;
}
static inline float csi_fmaxf(float a, float b)
{
    return a > b ? a : isnan(b) ? a : b;
}

/* The 3 x 3 neighbourhood of the pixel at column x, row y (row-major, ow x oh) clipped to the
 * image: its pixel indices in row order, the pixel among them, and their count. */
static inline int csi_recon_window3_at(size_t x, size_t y, size_t ow, size_t oh, size_t nb[9])
{
    const size_t p = y * ow + x;
    if (x > 0 && y > 0 && x + 1 < ow && y + 1 < oh) {
        /* inside the image (most pixels): the same 9 indices in the same order, without the
         * bounds tests */
        for (int j = 0; j < 3; j++) {
            const size_t row = p + (size_t)(j - 1) * ow; /* wraps for j = 0, then adds back */
            nb[3 * j] = row - 1, nb[3 * j + 1] = row, nb[3 * j + 2] = row + 1;
        }
        return 9;
    }
    const long px = (long)x, py = (long)y;
    int k = 0;
    for (long dy = -1; dy <= 1; dy++)
        for (long dx = -1; dx <= 1; dx++) {
            long xx = px + dx, yy = py + dy;
            if (xx >= 0 && yy >= 0 && xx < (long)ow && yy < (long)oh)
                nb[k++] = (size_t)yy * ow + (size_t)xx;
        }
    return k;
}

/* The same of pixel p. */
static inline int csi_recon_window3(size_t p, size_t ow, size_t oh, size_t nb[9])
{
    return csi_recon_window3_at(p % ow, p / ow, ow, oh, nb);
}

/* The samples of each row of output pixels, for passes over bands of rows (csi/row_pool.h).
 * start[0 .. oh] (oh + 1 entries): start[r] the first sample whose pixel row is r or more if the
 * samples are in row order (sorted by csi_grid_index on a still image), found by bisection;
 * monotone, start[0] = 0 and start[oh] = n whatever the order, so the rows' runs cover the
 * samples once. Whether they are in row order is checked where the runs are read
 * (csi_recon_band_pixel). */
void csi_recon_sample_rows(const csi_grid *g, const csi_sample_pos *pos, size_t n, size_t *start);
/* A sample's output pixel, the divisions by the cells per pixel done as shifts where those are
 * a power of two (the default grids'): the same pixel as csi_recon_pixel_of. */
typedef struct csi_pixel_map {
    uint32_t bw, bh;
    int sx, sy; /* log2 of bw, bh; -1 where not a power of two */
    size_t ow;
} csi_pixel_map;

static inline int csi_recon_log2_exact(uint32_t v)
{
    if (!v || (v & (v - 1)))
        return -1;
    int k = 0;
    while (v >>= 1)
        k++;
    return k;
}

static inline csi_pixel_map csi_recon_pixel_map(const csi_grid *g)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    return (csi_pixel_map){bw, bh, csi_recon_log2_exact(bw), csi_recon_log2_exact(bh), g->out_w};
}

static inline size_t csi_recon_pixel_row(const csi_pixel_map *m, csi_sample_pos p)
{
    return m->sy >= 0 ? p.y >> m->sy : p.y / m->bh;
}

static inline size_t csi_recon_pixel_col(const csi_pixel_map *m, csi_sample_pos p)
{
    return m->sx >= 0 ? p.x >> m->sx : p.x / m->bw;
}

static inline size_t csi_recon_pixel_at(const csi_pixel_map *m, csi_sample_pos p)
{
    return csi_recon_pixel_row(m, p) * m->ow + csi_recon_pixel_col(m, p);
}

/* The pixel of sample i of a band of rows [r0, r1) read in sample order, `last` the row of the
 * band's sample before it (r0 before the first); SIZE_MAX where the sample is outside the band or
 * before that row. A band that meets no SIZE_MAX holds its own rows' samples in row order; when
 * every band does, the whole is in row order, and each band's pass over its run sees each of its
 * pixels' samples, in sample order. */
static inline size_t csi_recon_band_pixel(const csi_pixel_map *m, csi_sample_pos p, size_t r1, size_t *last)
{
    const size_t r = csi_recon_pixel_row(m, p);
    if (r < *last || r >= r1)
        return SIZE_MAX;
    *last = r;
    return r * m->ow + csi_recon_pixel_col(m, p);
}

/* Each output pixel's samples, in sample order (a counting sort: deterministic): pixel p's are
 * idx[start[p] .. start[p + 1]), np pixels. *start (np + 1 entries) and *idx (n) are allocated
 * here and freed by the caller; CSI_ERR_NOMEM leaves both NULL. */
csi_status csi_recon_pixel_samples(const csi_pixel_map *m, const csi_sample_pos *pos, size_t n, size_t np,
                                   size_t **start, size_t **idx);

/* The per-pixel correction of one channel (csi_aa_correct in csi/reconstruct.h; `how` is CV or
 * BLEND) of plane, which holds the box integral of the fine estimate `fine`: gathers `fine` at
 * the samples through S (into `gathered`, n floats on the device; S NULL: `fine` already holds
 * the estimate at the samples, and is read as it is), then all on the host, in
 * double, in sample order (deterministic). values: sample-major, `channels` per sample; this is
 * channel c. clamp: the result is clamped at 0 (BLEND; see csi_recon_nonneg). */
csi_status csi_recon_correct(csi_ctx *ctx, const csi_grid *g, const csi_recon_options *opt,
                             csi_aa_correct how, const csi_linop *S, cl_mem fine, cl_mem gathered,
                             const float *values, uint32_t channels, uint32_t c,
                             const csi_sample_pos *pos, size_t n, bool clamp, float *plane);
/* The blend of the fine estimate's box integral (plane, in and out) with each pixel's sample
 * mean (blend.c). fine_at: the fine estimate at the n samples. Pixels span all t. opt's progress
 * hears "correct c/C" with the passes over the image done so far, after each of them. Its passes
 * run in bands of rows on pool (NULL: on the calling thread), the same bits either way. *multi
 * (unless NULL): how many pixels hold two samples or more. */
csi_status csi_recon_blend(const csi_grid *g, const csi_recon_options *opt, const float *values,
                           uint32_t channels, uint32_t c, const csi_sample_pos *pos,
                           const float *fine_at, size_t n, bool clamp, csi_row_pool *pool, float *plane,
                           size_t *multi);
/* The blend's last step on a still image (fit_trust.c): each pixel of plane (the blend's
 * output, in and out) that holds one sample moves towards the control variate made from box
 * (b, the fine estimate's box integral before the blend) by how far the fit can be trusted
 * there. n0: the control variate's shrinkage (csi_recon_options.cv_n0). */
csi_status csi_recon_fit_trust(const csi_grid *g, const float *values, uint32_t channels,
                               uint32_t c, const csi_sample_pos *pos, const float *fine_at,
                               size_t n, double n0, const float *box, csi_row_pool *pool, float *plane);
/* Whether csi_recon_fit_trust moves any pixel of an image of g in which `multi` pixels hold two
 * samples or more (if not, a caller that knows multi need not run it). */
bool csi_recon_fit_trust_acts(const csi_grid *g, size_t multi);
/* Projects the fine estimate `fine` (the grid's w x h x t cells, on the device) onto the range
 * of the samples (motion_range.c): each cell (x, y, t) into [min, max] of channel c's samples
 * in the 3 x 3 output pixels around it in the frame that moves with (vx, vy) cells per frame
 * (the pixel at x - vx (t - tc), y - vy (t - tc); with v = 0 its own output pixel and the 8
 * around it; or, given still_range (with v = 0), each output pixel's range from
 * csi_recon_sample_ranges, or given cell_range too, each cell's (csi_recon_cell_ranges)).
 * Overshoot and ringing beyond what any nearby sample saw (a sharpened HDR edge) is not signal;
 * with non-negative samples this also makes `fine` non-negative. */
csi_status csi_recon_motion_range_clamp(csi_ctx *ctx, const csi_grid *g, const float *values,
                                        uint32_t channels, uint32_t c, const csi_sample_pos *pos,
                                        size_t n, double vx, double vy, bool wide, const float *still_range,
                                        const float *cell_range, cl_mem fine);
/* The aligned pixels it uses at most (wide: when the volume's basis can be sheared; else as many
 * as the output pixels), as a multiple of the output pixels; beyond, it projects onto the range
 * of all the samples. Its device buffer holds that many. A pixel with no sample around takes
 * the range of all the samples. */
#define CSI_MOTION_RANGE_MAX_PIXELS 4
/* Its device buffer, in ranges (8 bytes each), for a volume of grid g: the aligned pixels it
 * may use, at least the grid's w x h cells (csi_recon_cell_ranges). */
size_t csi_recon_motion_range_cap(const csi_grid *g, bool wide);
/* Alg. 2's image with a still basis (csi_aa_correct AUTO): each pixel of plane (channel c, the
 * box mean of the fitted volume, in and out) moved by the mean of its samples' residuals
 * y - fine_at, shrunk by that correction's estimated risk, then projected onto `range`, the range
 * that bounded the volume (csi_recon_sample_ranges; motion_correct.c); a pixel without a sample
 * then kept within its 8 neighbours' range. fine_at: the volume at the n samples. */
csi_status csi_recon_motion_correct(const csi_grid *g, const float *values, uint32_t channels,
                                    uint32_t c, const csi_sample_pos *pos, const float *fine_at,
                                    size_t n, const float *range, bool exact, float *plane);
/* Its per-pixel part, from what each pixel's samples say (a whole-shutter image blended from
 * time windows has them from the windows' sums, csi/tiles.h): n samples, d their mean residual,
 * ss the sum of their squared deviations from d; v and e are scratch. g: the whole image's grid
 * (its cells per pixel over all t); range: each pixel's bound (csi_recon_value_ranges); exact:
 * the samples are noise-free (CSI_SAMPLES_EXACT), and a pixel of two or more takes its whole
 * correction (motion_correct.c). */
typedef struct {
    double d, ss, v, e;
    uint32_t n;
} csi_px_resid;
void csi_recon_motion_correct_pixels(const csi_grid *g, csi_px_resid *st, const float *range, bool exact,
                                     float *plane);
/* The range that bounds the volume and the image (sample_range.c): lohi[2 p], lohi[2 p + 1] for each
 * pixel p of a w x h frame (the output's, or one that moves with the basis), from channel c's
 * samples (sample i in pixel pix[i]; none where pix[i] >= w h) in the pixel and its 8
 * neighbours, or in the smallest wider window holding 8 samples where the pixels around change
 * over t about as much as their windows vary; the range of all the samples where no window has
 * any. */
csi_status csi_recon_sample_ranges(size_t w, size_t h, const size_t *pix, const float *values, uint32_t channels,
                                   uint32_t c, size_t n, float *lohi);
/* Its host memory while it runs: bytes per pixel of the frame (and a row of prefix sums more). */
#define CSI_SAMPLE_RANGE_PIXEL_BYTES 80
/* The range of each cell of g's w x h frame, over all t (sample_range.c): lohi[2 q], lohi[2 q + 1]
 * for cell q = y w + x, [min, max] of channel c's samples in the 3 x 3 cells around it, or its
 * output pixel's pixel_range (csi_recon_value_ranges) where those cells hold no sample. For a
 * still camera's volume on a grid of several cells a pixel where little moves (motion.c). Host memory:
 * 16 bytes per cell while it runs, beside lohi's 8. */
csi_status csi_recon_cell_ranges(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                 uint32_t channels, uint32_t c, size_t n, const float *pixel_range, float *lohi);
/* How much the shutter's first and last quarters of frames differ, over the image's energy, from
 * the samples of a volume (motion_ends.c); 0 without a difference. Above
 * CSI_MOTION_ENDS_DCT a still basis takes the DCT along t instead of the DFT (motion.c). */
csi_status csi_recon_motion_ends(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                                 const float *values, size_t n, double *ratio);
#define CSI_MOTION_ENDS_DCT 1.0
/* The share of the output pixels holding two samples or more whose samples are all equal in
 * every channel (still_samples.c): near 1 for exact samples of a still picture, 0 for a
 * renderer's noisy ones; 0 when no pixel holds two. */
csi_status csi_recon_still_exact_share(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                       uint32_t channels, size_t n, double *share);
/* Above this share (csi_recon_still_exact_share) a volume's samples are a noise-free picture that
 * mostly holds still: a still camera's exact samples. */
#define CSI_STILL_PICTURE_SHARE 0.5
/* What of a still camera's samples moves, from each sample's neighbours (within one cell in
 * x and y) at other times (moving_share.c): held, the share of the bright samples (HDR lights)
 * seen again by a bright neighbour a quarter of the shutter away (0 without any); lights, the
 * share of all the samples' energy in bright samples that are not; motion, what neighbours a
 * quarter of the shutter apart differ by beyond those an eighth or less apart, over twice the
 * samples' variance (the lights capped), infinite when no pair says. */
typedef struct {
    double held, lights, motion;
} csi_moving_share;
csi_status csi_recon_moving_share(const csi_grid *g, const csi_sample_pos *pos, const float *values,
                                  uint32_t channels, size_t n, csi_moving_share *out);
/* The still layer's weight, auto, where exact samples on a grid of 2 x 2 cells a pixel or more,
 * as many as the cells, hold at most CSI_MOVING_LIGHTS_SHARE of their energy in moving lights, and
 * either show lights that hold still (more than half held) or a motion share of at most
 * CSI_MOVING_VARIANCE_SHARE (motion.c). */
#define CSI_STILL_WEIGHT_LITTLE_MOVES 0.1
#define CSI_MOVING_LIGHTS_SHARE 0.25
#define CSI_MOVING_VARIANCE_SHARE 0.2
/* Noisy samples (a path tracer's) on such a grid say little moves, for the cells' own range bound
 * alone (csi_recon_cell_ranges; the weight stays one), at most CSI_MOVING_LIGHTS_SHARE of their
 * energy in moving lights and a motion share of at most CSI_MOVING_VARIANCE_SHARE_NOISY: their
 * noise adds to the variance the share divides by (at one path a rolling ball's share fell to
 * under half its 16-path value), and what the bound cuts from a mover their shrunk correction does not give back; the
 * held lights do not count (one path's fireflies are seen again anywhere). */
#define CSI_MOVING_VARIANCE_SHARE_NOISY 0.1
/* A pixel's samples over t (still_samples.c; tile_blend.c from a window's sums): none, one, two or
 * more that differ in some channel, two or more all equal. */
enum { CSI_STILL_NONE, CSI_STILL_ONE, CSI_STILL_DIFFER, CSI_STILL_AGREE };
/* The share of the np pixels of two samples or more whose samples agree (0 without such a pixel),
 * and whether every pixel of p's 3 x 3 window (ow x oh) holds agreeing samples: the still
 * pixels' rule below, on per-pixel states however they were gathered. */
double csi_recon_still_share(const unsigned char *state, size_t np);
bool csi_recon_still_calm(const unsigned char *state, size_t p, size_t ow, size_t oh);
/* In such a volume (the share is its own), a pixel takes its samples' value in the image (planar, channels planes;
 * still_samples.c) where every pixel of its 3 x 3 window holds two samples or more, all equal
 * in every channel. Exact samples that agree at several times are a pixel nothing
 * moved through while they were taken; its neighbours' agreeing too rules out a mover's path
 * that the pixel's few samples happened to miss (a large disc's, whose neighbours' samples hit
 * it). Such a pixel is still, its mean over t each sample, which a fit of the volume at best
 * matches. Where the camera moves a uniform region's samples agree as well while an edge sweeps
 * over it between them: hence the share's gate. The frames stay the fit's. A volume in time
 * windows applies the rule once to the blended image, from the whole shutter's sums
 * (tile_blend.c). */
csi_status csi_recon_still_pixels(const csi_grid *g, const float *values, uint32_t channels,
                                  const csi_sample_pos *pos, size_t n, float *image);
/* Its two halves, for sums made elsewhere (a time window's, csi/tiles.h): what one pixel's samples
 * of a channel say (their count, mean, sum of squared deviations from it, range), gathered from
 * the samples into px (w x h) with all = the range of every sample; and the ranges from them. */
typedef struct {
    double mean, ss;
    uint32_t n;
    float lo, hi;
} csi_px_values;
void csi_recon_pixel_values(size_t w, size_t h, const size_t *pix, const float *values, uint32_t channels,
                            uint32_t c, size_t n, csi_px_values *px, float all[2]);
csi_status csi_recon_value_ranges(size_t w, size_t h, const csi_px_values *px, const float all[2], float *lohi);
/* Noisy samples: a volume's corrected image (plane, of channel c of grid g's output) moved towards
 * each pixel's own sample mean by the estimated risks of the two, at pixels of two samples or more
 * (motion_toward_mean.c). px: what each pixel's samples of that channel say. */
csi_status csi_recon_motion_toward_mean(const csi_grid *g, const csi_px_values *px, const float *fit_var,
                                        float *plane);

/* The blurred image of time window `tile`'s x/y window over the whole shutter, binned in t to
 * the layout's window length (binned.c, csi_recon_options.tile_image_binned): one solve of the
 * samples of that x/y window at every t, those sharing a binned cell averaged, with the
 * whole's figures (scope) carried to the binned grid. out: its image (window[0] x window[1]
 * pixels), no frames. */
csi_status csi_recon_binned_image(csi_ctx *ctx, const csi_tiling *tl, const csi_tile *tile, uint32_t channels,
                                  const csi_sample_pos *pos, const float *values, size_t n,
                                  const csi_recon_options *opt, const csi_tile_scope *scope,
                                  csi_recon_result *out);
/* Pixels of plane (channel c) whose every cell (all t) is sampled are set to the mean of their
 * samples: the exact box mean, which no fit improves on (blend.c; Alg. 2 without the blend). */
void csi_recon_exact_full(const csi_grid *g, const float *values, uint32_t channels, uint32_t c,
                          const csi_sample_pos *pos, size_t n, float *plane);
/* Whether every sample of channel c is >= 0: then the truth is too, and the image may be
 * projected onto non-negative values (which never moves a value away from a non-negative
 * truth). */
bool csi_recon_nonneg(const float *values, uint32_t channels, uint32_t c, size_t n);

/* Normalized convolution with a Gaussian of one width on every axis of the grid (t too when the
 * grid has one): NC(y) = G*(S^T y) / G*(S^T 1). The Gaussian baseline is NC of the samples; Alg.
 * 2's residual correction (csi_recon_options.motion_resid_sigma) is f += NC(y - S f). */
typedef struct {
    csi_linop *S, *G;
    cl_mem den, b, fs;
    float eps;
    /* NC(y) clamped to [lo, hi]: +-infinity (csi_nc_init_filter's), or the samples' range, where
     * a normalized convolution, a mean with non-negative weights, lies in exact arithmetic */
    float lo, hi;
} csi_nc_op;

/* yscratch: n floats and scratch: k floats of device scratch; ones: n floats of host scratch. */
csi_status csi_nc_init(csi_ctx *ctx, const csi_grid *g, const uint32_t *idx, size_t n,
                       double sigma, cl_mem yscratch, cl_mem scratch, float *ones, csi_nc_op *r);
/* The same with another smoothing filter G (real, symmetric; r takes ownership, also on
 * failure) and the density below which a cell is left 0. */
csi_status csi_nc_init_filter(csi_ctx *ctx, const csi_grid *g, const uint32_t *idx, size_t n,
                              csi_linop *G, float eps, cl_mem yscratch, cl_mem scratch,
                              float *ones, csi_nc_op *r);
/* out = NC(yd): yd is n floats on the device; out (k floats) may be `scratch`. */
csi_status csi_nc_interp(csi_ctx *ctx, csi_nc_op *r, cl_mem yd, size_t k, cl_mem scratch,
                         cl_mem out);
/* f += NC(y - S f). y: the channel's n samples on the host; yscratch: n floats, scratch: k
 * floats of device scratch; host: n floats of host scratch. */
csi_status csi_nc_correct(csi_ctx *ctx, csi_nc_op *r, const float *y, size_t n, size_t k,
                          cl_mem f, cl_mem yscratch, cl_mem scratch, float *host);
void csi_nc_free(csi_nc_op *r);

/* Alg. 2's basis velocity from the samples (motion_velocity.c): candidates from the energy of
 * the motion-compensated mean of a rough estimate, chosen and refined by the leave-one-out error
 * of the normalized convolution along each velocity. h: the operator's basis and G a motion
 * filter on it with the DCT (csi/motion_filter.h), both left in arbitrary states (the caller
 * sets what it wants next); z: the filter's coefficient scratch; va, vb: k floats and ydev, gat:
 * n floats of device scratch; S: the real sampling operator at idx; y: the n values (host) the
 * motion is judged on; opt: its progress callback (phase "velocity search") hears of every step.
 * Allocates nothing on the device (csi/plan.h counts the caller's). */
typedef struct {
    double v[2];      /* cells per frame; 0, 0 when no velocity predicts the samples at least 3%
                         better (and more of the 4 x 4-cell blocks better than worse) than the
                         still basis */
    double loo, loo0; /* leave-one-out mean squared errors: the chosen velocity's, v = 0's */
    double improved;  /* the share of the blocks the best velocity predicts better than v = 0 */
    int evaluations;  /* leave-one-out evaluations (two filter passes each) */
    double seconds;
} csi_motion_velocity;
csi_status csi_motion_velocity_estimate(csi_ctx *ctx, const csi_grid *g, csi_fourier_half *h,
                                        csi_linop *G, cl_mem z, cl_mem va, cl_mem vb,
                                        const csi_linop *S, cl_mem ydev, cl_mem gat, const float *y,
                                        const uint32_t *idx, size_t n, const csi_recon_options *opt,
                                        csi_motion_velocity *out);
/* The device buffers it holds while it runs (two spectra, released before it returns). */
void csi_motion_velocity_buffers(const size_t dims[3], csi_mem_tally *t);
/* The host bytes it holds at most. */
uint64_t csi_motion_velocity_host_bytes(const csi_grid *g, size_t n);

/* A result's frames dropped: made for its image's average with them (image_frames), not asked
 * for (reconstruct.c, tiled.c). */
void csi_recon_result_drop_frames(csi_recon_result *r);

/* The caller's options, or the defaults where it gives none (NULL). */
static inline csi_recon_options csi_recon_options_or_defaults(const csi_recon_options *given)
{
    csi_recon_options o;
    if (given)
        o = *given;
    else
        csi_recon_defaults(&o);
    return o;
}

#endif
