/* Reconstruction options as data: one table of rows (name, field, kind, range, default, help)
 * from which the defaults, the parsers, the programs' getopt tables and help, the statistics
 * and the EXR attributes are all made. See csi/reconstruct.h. To add an option: a field in
 * csi_recon_options, a row here, and the code that reads it (and, if its default depends on the
 * problem, its rule in resolve.c). */
#include "csi/reconstruct.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

_Static_assert(sizeof(csi_solver_kind) == sizeof(int) && sizeof(csi_switch) == sizeof(int) &&
               sizeof(csi_cv_channels) == sizeof(int) &&
               sizeof(csi_wavelet_family) == sizeof(int), "choice options are stored as int");

/* K_BYTES: a uint64_t byte count, read with an optional K, M, G or T (powers of 1024). */
typedef enum { K_CHOICE, K_DOUBLE, K_FLOAT, K_INT, K_U32, K_SIZE, K_U64, K_BYTES, K_BOOL } storage;

typedef struct {
    const char *name;
    int value;
} choice;

/* Flags of a row. */
enum {
    F_AUTO = 1,     /* 0 (or the enum's AUTO) means auto: resolved from the problem */
    F_OFF = 2,      /* -1 means off; a negative number given is off */
    F_WHOLE1 = 4,   /* a value >= 1 must be whole (a count; below 1 a fraction) */
    F_LIBRARY = 8,  /* not a --name of the programs (they set it through their own flags) */
};

typedef struct {
    const char *name;
    storage st;
    size_t offset;
    double lo, hi;          /* range of a given number */
    const choice *choices;  /* K_CHOICE: terminated by a NULL name */
    unsigned flags;
    const char *def;        /* default as text */
    const char *metavar;
    const char *help;
    const char *auto_rule;  /* F_AUTO: what auto becomes */
} row;

static const choice estimators[] = {{"cs", CSI_EST_CS}, {"mean", CSI_EST_MEAN}, {"gauss", CSI_EST_GAUSS}, {0}};
static const choice solvers[] = {{"auto", CSI_SOLVER_AUTO}, {"romp", CSI_SOLVER_ROMP}, {"sparsa", CSI_SOLVER_SPARSA}, {0}};
static const choice wavelets[] = {{"db4", CSI_WAVELET_DB4}, {"db8", CSI_WAVELET_DB8}, {0}};
static const choice outputs[] = {{"filtered", CSI_AA_FILTERED}, {"sharp", CSI_AA_SHARP}, {0}};
static const choice corrects[] = {{"auto", CSI_CORRECT_AUTO}, {"none", CSI_CORRECT_NONE}, {"cv", CSI_CORRECT_CV},
                                  {"blend", CSI_CORRECT_BLEND}, {0}};
static const choice stops[] = {{"auto", CSI_STOP_AUTO}, {"gap", CSI_STOP_GAP}, {"objective", CSI_STOP_OBJECTIVE}, {0}};
static const choice switches[] = {{"auto", CSI_SWITCH_AUTO}, {"on", CSI_SWITCH_ON}, {"off", CSI_SWITCH_OFF}, {0}};
static const choice cv_channels[] = {{"auto", CSI_CV_CHANNELS_AUTO}, {"mean", CSI_CV_CHANNELS_MEAN},
                                     {"each", CSI_CV_CHANNELS_EACH}, {0}};
static const choice presets[] = {{"csi", CSI_ROMP_PRESET_CSI}, {"published", CSI_ROMP_PRESET_PUBLISHED}, {0}};
static const choice times[] = {{"auto", CSI_MOTION_TIME_AUTO}, {"dft", CSI_MOTION_TIME_DFT}, {"dct", CSI_MOTION_TIME_DCT}, {0}};
static const choice velocities[] = {{"estimate", CSI_VELOCITY_ESTIMATE}, {"none", CSI_VELOCITY_NONE}, {"given", CSI_VELOCITY_GIVEN}, {0}};

#define AT(field) offsetof(csi_recon_options, field)

static const row table[] = {
    {"estimator", K_CHOICE, AT(estimator), 0, 0, estimators, 0, "cs", "cs|mean|gauss",
     "cs: compressive; baselines: mean = per-pixel sample mean (Monte Carlo), gauss = Gaussian "
     "normalized convolution", NULL},
    {"gauss-sigma", K_DOUBLE, AT(gauss_sigma), 1e-3, 1e4, NULL, F_AUTO, "auto", "S",
     "width of the gauss baseline in grid cells", "0.5 (k/N)^(1/d), d = 2 or 3"},
    {"solver", K_CHOICE, AT(solver), 0, 0, solvers, F_AUTO, "auto", "romp|sparsa",
     "sparse solver", "sparsa, measured best (docs/BENCHMARKS.md)"},
    {"wavelet", K_CHOICE, AT(wavelet), 0, 0, wavelets, 0, "db4", "db4|db8",
     "Alg. 1 basis (db4: 8 taps, db8: 16 taps)", NULL},
    {"levels", K_INT, AT(levels), 1, 16, NULL, F_AUTO, "auto", "L", "wavelet levels",
     "as many as the grid allows, at most 5"},
    {"lambda", K_FLOAT, AT(lambda), 1e-12, 1e6, NULL, 0, "0.3", "L",
     "Wiener regularisation of the inverse filter", NULL},
    {"sigma-scale", K_DOUBLE, AT(sigma_scale), 1e-3, 100, NULL, 0, "1", "S",
     "multiply the paper's Gaussian width", NULL},
    /* 0.8 and 8 below: measured in docs/bench/quality.md. */
    {"sigma-spacing", K_DOUBLE, AT(sigma_spacing), 0, 100, NULL, 0, "0.8", "C",
     "Gaussian width at least C times the sample spacing sqrt(k/N) (0: the paper's width only)",
     NULL},
    {"integrate", K_CHOICE, AT(output), 0, 0, outputs, 0, "sharp", "filtered|sharp",
     "integrate f_b (the paper's) or Phi^-1 f_b", NULL},
    {"correct", K_CHOICE, AT(correct), 0, 0, corrects, F_AUTO, "auto", "auto|none|cv|blend",
     "correct each pixel with its own samples; blend: box(g) moved towards the pixel's sample "
     "mean by weights estimated from the samples, a pixel with one sample towards cv where the "
     "fit passes through it and no HDR step is near (meant never to be worse than the mean; "
     "clamped at 0 when the samples are >= 0); cv: control variate, box(g) + mean of the "
     "pixel's residuals y - g", "cs images: cv when the samples are exact (noise-free point "
     "values: the dump's flag, csi-render without random effects), else blend; none for the "
     "gauss baseline; volumes: "
     "the fine estimate kept within the samples' range (each cell within its own 3 x 3 cells' "
     "where a still camera's samples say little moves) and, with a still basis, the image "
     "corrected by each pixel's mean residual shrunk by its estimated risk, then, samples not "
     "flagged exact, moved towards each pixel's sample mean by the estimated risks of the two"},
    {"cv-select", K_CHOICE, AT(cv_select), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "images: per region of 8 x 8 or 16 x 16 pixels, the image or each pixel's mean of its samples, "
     "whichever the two folds of the samples (each pixel's split in two) say is closer to the "
     "held-out pixel means (two more reconstructions, each from half the samples, on a coarser "
     "model grid where the filter allows it and to a looser stop, --tol at least 0.02)",
     "on with the blend (noisy samples, not flagged exact), on the whole image or in each tile's "
     "window, where it acts from 2 samples per pixel on average; off otherwise (another "
     "correction, volumes, the baselines)"},
    {"cv-smooth", K_CHOICE, AT(cv_smooth), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "with the cross-validated choice: Gaussian averages of the samples 0.5, 1, 2 and 4 pixels "
     "wide as further candidates, a region taking one where both folds gain significantly over "
     "what the choice kept, in squared and in relative error; each pixel's value then kept within "
     "2 standard errors of its own samples' mean (a smoothing removes noise, not signal)",
     "on wherever the choice is (noisy samples; docs/bench/mitsuba.md, session 49)"},
    {"cv-channels", K_CHOICE, AT(cv_channels), 0, 0, cv_channels, F_AUTO, "auto", "mean|each|auto",
     "samples of several channels: what the cross-validated choice's folds reconstruct, the mean "
     "of the channels (one solve per fold, the choice made on it) or each channel (a solve per "
     "channel and fold, the choice made on the sum of the channels' losses)",
     "mean"},
    {"peak-range", K_CHOICE, AT(peak_range), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "images with the blend: a pixel of several samples whose brightest is at least 4 times all "
     "its others takes the mean over its cells of a fit of log(1 + y / s) on the fine grid, "
     "expanded (one more reconstruction, its output the size of the grid)",
     "off"},
    {"blend-spread", K_CHOICE, AT(blend_spread), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "the blend, given each sample's variance (--variance): a pixel whose samples spread more than "
     "4 times their variances (a step or a highlight some of them hit) counts that spread, s^2 / n, "
     "in its mean's noise, scaled by 2 / sqrt(n) from 4 samples on (stratification)", "off"},
    {"settle", K_CHOICE, AT(settle), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "images with the blend, last: a pixel where the image and the mean of its own samples "
     "disagree by more than 0.5% of their disagreement over the whole image (its share) moves to "
     "that mean, wholly from 2%, unless one of the two sees it dark (a firefly) or neither sees it "
     "beyond 4 times the image's mean pixel (an ordinary range, where no pixel decides): one HDR "
     "pixel cannot then put the image above the mean of the same samples (tiled: once, on the "
     "blended image)",
     "on with the blend (noisy samples) on an image; off otherwise, and with --refine-request or "
     "--refine-with, whose second pass samples those pixels instead"},
    {"step-coverage", K_CHOICE, AT(step_coverage), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "images with the blend and each sample's variance (--variance), after --settle: a pixel "
     "across an HDR step moves to the share of the bright side a line through its 5 x 5 pixels' "
     "samples gives it (samples one per stratum: their own share, within what the line allows), "
     "or where no line divides them, a boundary through its 3 x 3 pixels' samples allows "
     "(tiled: each tile's changes of its core, added on the blended image)",
     "on with the blend (noisy samples) on an image; off otherwise, and with --refine-request or "
     "--refine-with, whose second pass samples those pixels instead"},
    {"cv-n0", K_DOUBLE, AT(cv_n0), 0, 1e6, NULL, 0, "8", "N",
     "cv: shrink that correction by n_p / (n_p + N), n_p = samples in the pixel", NULL},
    {"stop", K_CHOICE, AT(stop), 0, 0, stops, F_AUTO, "auto", "gap|objective|auto",
     "SpaRSA stopping rule (relative duality gap or objective change)",
     "objective for images, gap for volumes"},
    {"continuation", K_CHOICE, AT(continuation), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "SpaRSA continuation on tau", "on"},
    {"cont-step", K_DOUBLE, AT(cont_step), 1e-6, 0.99, NULL, F_AUTO | F_OFF, "auto", "F",
     "SpaRSA continuation: each stage's tau F times the previous one's; off: WNF09's adaptive "
     "rule (0.2 ||A^H r||_inf)", "0.1 for images, off for volumes"},
    {"cont-tol", K_DOUBLE, AT(cont_tol), 1e-12, 1, NULL, F_AUTO, "auto", "T",
     "SpaRSA continuation: tolerance of the stages before the last (the last stops at --tol)",
     "3e-2 for images, the solver's 1e-3 for volumes"},
    {"debias", K_CHOICE, AT(debias), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "SpaRSA's final least squares on the support (images; volumes: --motion-debias)", "off"},
    {"tol", K_DOUBLE, AT(tol), 1e-12, 1, NULL, F_AUTO, "auto", "T", "solver tolerance (relative)",
     "3e-3 for images with SpaRSA, else the solver's (1e-5)"},
    {"max-iter", K_INT, AT(max_iter), 1, 1000000, NULL, F_AUTO, "auto", "N",
     "solver iteration cap", "300 for images with SpaRSA, 2000 for volumes; ROMP: its support "
     "limit + 10"},
    {"tau", K_DOUBLE, AT(tau_rel), 1e-12, 1, NULL, F_AUTO, "auto", "T",
     "SpaRSA: tau relative to ||A^H y||_inf", "3e-3 / spp for images (at least 1e-5), "
     "0.25 / sqrt(N) for volumes (in [1e-4, 3e-2])"},
    {"romp-preset", K_CHOICE, AT(romp_preset), 0, 0, presets, 0, "csi", "csi|published",
     "ROMP defaults: csi's for images or Needell & Vershynin's (s from N, stop at 2s); the "
     "--romp-* below override", NULL},
    {"romp-s", K_SIZE, AT(romp_s), 1, 1u << 30, NULL, F_AUTO, "auto", "S",
     "ROMP: candidates per step", "csi: N / 64, at least 16; published: the largest s with "
     "2 s ln(k/s) <= N"},
    {"romp-max-support", K_DOUBLE, AT(romp_max_support), 1e-6, 4294967296.0, NULL, F_AUTO | F_WHOLE1,
     "auto", "M", "ROMP: support size that ends the run (a count, or in (0, 1) a fraction of the "
     "samples)", "csi: 0.15; published: 2s"},
    {"romp-normalize", K_CHOICE, AT(romp_normalize), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "ROMP: rank correlations by column norm", "off"},
    {"romp-seed-levels", K_INT, AT(romp_seed_levels), 1, 16, NULL, F_AUTO | F_OFF, "auto", "off|auto|L",
     "ROMP: start the support with the coarse wavelet block (L = 1) and the L - 1 coarsest "
     "detail levels", "csi: 2; published: off"},
    {"romp-lsq-iter", K_INT, AT(romp_lsq_iter), 1, 100000, NULL, F_AUTO, "auto", "N",
     "ROMP: CG iterations per least squares", "csi: 1; published: 60"},
    {"motion-resid-sigma", K_DOUBLE, AT(motion_resid_sigma), -1e6, 1e4, NULL, F_AUTO | F_OFF, "auto",
     "S", "volumes: width (cells) of the normalized convolution that adds the samples' residual "
     "back after the solve; off or < 0: none (the paper's)", "0.5 (k/N)^(1/3)"},
    {"full-spectrum", K_BOOL, AT(motion_full_spectrum), 0, 0, NULL, 0, "off", NULL,
     "volumes: solve on the full complex spectrum (the paper's form) rather than the half "
     "spectrum of the real volume (same minimiser, 2x work)", NULL},
    {"motion-debias", K_BOOL, AT(motion_debias), 0, 0, NULL, 0, "off", NULL,
     "volumes: SpaRSA's debiasing least squares", NULL},
    {"warm-channels", K_CHOICE, AT(warm_channels), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "Alg. 1 with SpaRSA: each channel after the first starts from the previous one's solution "
     "(scaled by the ratio of their sample sums) at the final tau, stopping on a 3x tighter "
     "objective change (faster; the MSE moves by a few %, docs/bench/cost.md)", "off"},
    {"motion-time", K_CHOICE, AT(motion_time), 0, 0, times, F_AUTO, "auto", "auto|dft|dct",
     "volumes: the basis along t: the DFT (the paper's, periodic) or the DCT-II (mirrored ends)",
     "dct when the basis is sheared (a velocity) or the samples' first and last quarter of "
     "frames differ by more energy than their image holds, else dft"},
    {"motion-velocity", K_CHOICE, AT(motion_velocity), 0, 0, velocities, 0, "estimate",
     "estimate|none|given", "volumes: the velocity the basis is sheared by (what moves at it is "
     "static in the basis): estimated from the samples, none (the paper's), or --motion-vx/-vy",
     NULL},
    {"motion-vx", K_DOUBLE, AT(motion_vx), -1e6, 1e6, NULL, 0, "0", "V",
     "volumes: the given velocity along x (cells per frame)", NULL},
    {"motion-vy", K_DOUBLE, AT(motion_vy), -1e6, 1e6, NULL, 0, "0", "V",
     "volumes: the given velocity along y (cells per frame)", NULL},
    {"motion-resid-sigma-t", K_DOUBLE, AT(motion_resid_sigma_t), 1e-3, 1e4, NULL, F_AUTO, "auto",
     "F", "volumes: width (frames) of the residual correction along the basis's motion (when it "
     "moves or has the DCT)", "the spatial width"},
    {"motion-filter", K_DOUBLE, AT(motion_filter), -1e6, 1e4, NULL, F_AUTO | F_OFF, "auto", "S",
     "volumes (half spectrum): solve for the volume blurred by a Gaussian of width S cells along x "
     "and y, seen by the samples through its Wiener inverse (Alg. 1's model); off: the paper's",
     "with a still basis and fewer than 2 samples per pixel over t, sigma-spacing x sqrt(w h / N), "
     "at least the paper's width; else none"},
    {"motion-still-weight", K_DOUBLE, AT(motion_still_weight), 1e-6, 1e6, NULL, F_AUTO, "auto", "W",
     "volumes (half spectrum): the l1 weight of the coefficients constant along t in the basis's "
     "frame (the still layer; with a velocity, what moves at it) relative to the others'; tau "
     "is still set from the unweighted problem (docs/bench/animation.md, round 7, session 30)",
     "0.5 with a still basis whose samples are a noise-free still picture (most pixels holding two "
     "samples hold equal ones), else 1"},
    {"motion-reweight", K_INT, AT(motion_reweight), 0, 16, NULL, 0, "0", "N",
     "volumes: reweighted l1 (Candes, Wakin & Boyd 2008): N re-solves, each with an l1 weight per "
     "coefficient c / (|z| + eps) from the previous solution z (c: its weighted l1 is its l1), "
     "warm-started; each costs about a solve or more (docs/bench/animation.md, session 11)", NULL},
    {"motion-reweight-eps", K_DOUBLE, AT(motion_reweight_eps), 1e-6, 1e6, NULL, 0, "10", "E",
     "volumes: the reweighted l1's eps, relative to the previous solution's mean non-zero "
     "coefficient magnitude", NULL},
    {"motion-image-cv", K_CHOICE, AT(motion_image_cv), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "volumes solved whole: per region of 8 or 16 pixels, the blurred image of the volume solve or "
     "of a solve of the shutter binned to 4 frames (samples sharing a cell averaged), whichever "
     "two folds of the samples say is closer to the held-out pixel means (up to five more solves)", "off"},
    {"frames-denoise", K_CHOICE, AT(frames_denoise), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "volumes: the frames (not the blurred image) of noisy samples: each sampled cell takes its "
     "unsampled neighbours' value and its samples' mean weighted by the samples' noise, then a "
     "Gaussian along the basis's motion and x, y (at most 1.5 cells and frames) chosen by two "
     "folds of the samples, each half solved alone predicting the other (two more solves of half "
     "the samples; docs/bench/animation.md, session 32)",
     "on when the samples come with their variances and their noise is at least a fifth of their level"},
    {"image-frames", K_CHOICE, AT(image_frames), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "volumes: the blurred image averaged with the mean over t of the frames --frames-denoise gave "
     "(which are then made for it when --frames is not asked for; docs/bench/animation.md, session 33)",
     "on wherever --frames-denoise is on or would be, with or without --frames (time windows too, "
     "but not with --tile-image-binned)"},
    {"model-grid", K_CHOICE, AT(model_grid), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "Alg. 1 on a model grid coarser than the samples' where the filter allows it (the same "
     "operator to ~1e-5 at a fraction of the cost)", "on for the sharp estimate with SpaRSA"},
    {"model-sigma-min", K_DOUBLE, AT(model_sigma_min), 0.25, 100, NULL, F_AUTO, "auto", "C",
     "the model grid: the coarsest grid (D a power of two) on which the Gaussian is at least C "
     "model cells wide (below 1.5 no longer the fine grid's operator: a band-limited model, "
     "cheaper, with the MSE within a few %)", "1.5 (the fine grid's operator to ~1e-5)"},
    {"coarse-start", K_CHOICE, AT(coarse_start), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "Alg. 1 on a model grid: SpaRSA's continuation stages before the last on a grid twice as "
     "coarse, the last on the model grid from their result (about a third of their cost)", "off"},
    {"chroma", K_CHOICE, AT(chroma), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "Alg. 1 on RGB: the samples turned into luma and two chroma channels (an orthonormal "
     "transform), luma solved as a channel is and the chroma on the coarser model grid of "
     "--model-sigma-min 0.75, their solves stopped at 2/3 of --tol, the fits turned back to RGB "
     "before the per-pixel correction: about 0.67x the CPU of three RGB solves, the MSE within "
     "their stop's own spread; off: R, G and B solved one after another",
     "on (RGB still images solved by SpaRSA on a model grid)"},
    /* Tiles (csi/tiles.h): bounded memory. */
    {"mem-budget", K_BYTES, AT(mem_budget), 1048576.0, 18446744073709551615.0, NULL, F_AUTO, "auto",
     "SIZE", "device memory one reconstruction may use, e.g. 512M, 2G (bytes, or K/M/G = "
     "KiB/MiB/GiB); the image is solved in overlapping tiles when the whole would need more",
     "1.5G, at most half the device's"},
    {"tiles", K_U32, AT(tiles), 1, 1048576, NULL, F_AUTO, "auto", "N|auto",
     "exactly N tiles (blended seamlessly)", "as few as fit the budget"},
    {"tile-margin", K_U32, AT(tile_margin), 1, 65536, NULL, F_AUTO, "auto", "P",
     "overlap beyond a tile's core in output pixels", "the wavelet's taps x 2^levels grid cells "
     "(256 at the defaults), at least 4 pixels; 16 for volumes"},
    {"tile-margin-t", K_U32, AT(tile_margin_t), 1, 65536, NULL, F_AUTO, "auto", "F",
     "the same in frames for a volume", "a third of a time window's core, at least 4, and windows of at least 32 frames where the "
     "volume is longer"},
    {"tiles-t", K_U32, AT(tiles_t), 1, 65536, NULL, F_AUTO, "auto", "N",
     "volumes: exactly N time windows (1: never split t)", "as the budget's layout prices them: "
     "cells covered x (1 + 0.02 per window boundary), x/y tiles or windows"},
    {"tile-image-binned", K_CHOICE, AT(tile_image_binned), 0, 0, switches, F_AUTO, "auto", "on|off|auto",
     "volumes split in t: the blurred image from one solve of every frame's samples, binned in t "
     "to a window's length (samples sharing a cell averaged); the windows then give only the "
     "frames (off: the blend of the windows' frames)", "off"},
    {"frames", K_BOOL, AT(frames), 0, 0, NULL, F_LIBRARY, "off", NULL,
     "volumes: also return every frame", NULL},
    {"seed", K_U64, AT(seed), 0, 18446744073709551615.0, NULL, F_LIBRARY, "1", "S",
     "seed of the solver's randomised parts (ROMP's column-norm probes)", NULL},
};
#define NROWS (sizeof table / sizeof table[0])

static const row *find(const char *name)
{
    for (size_t i = 0; name && i < NROWS; i++)
        if (!strcmp(table[i].name, name))
            return &table[i];
    return NULL;
}

static void *field(const csi_recon_options *o, const row *r)
{
    return (char *)o + r->offset;
}

/* Stores a number (already checked) into the row's field. */
static void store(csi_recon_options *o, const row *r, double v)
{
    void *p = field(o, r);
    switch (r->st) {
    case K_CHOICE:
    case K_INT: *(int *)p = (int)v; break;
    case K_DOUBLE: *(double *)p = v; break;
    case K_FLOAT: *(float *)p = (float)v; break;
    case K_U32: *(uint32_t *)p = (uint32_t)v; break;
    case K_SIZE: *(size_t *)p = (size_t)v; break;
    case K_BOOL: *(bool *)p = v != 0; break;
    case K_U64:
    case K_BYTES: *(uint64_t *)p = (uint64_t)v; break;
    }
}

static double load(const csi_recon_options *o, const row *r)
{
    const void *p = field(o, r);
    switch (r->st) {
    case K_CHOICE:
    case K_INT: return *(const int *)p;
    case K_DOUBLE: return *(const double *)p;
    case K_FLOAT: return *(const float *)p;
    case K_U32: return *(const uint32_t *)p;
    case K_SIZE: return (double)*(const size_t *)p;
    case K_BOOL: return *(const bool *)p;
    case K_U64:
    case K_BYTES: return (double)*(const uint64_t *)p;
    }
    return 0;
}

static void choices_text(const row *r, char *buf, size_t len)
{
    size_t at = 0;
    buf[0] = '\0';
    for (const choice *c = r->choices; c->name && at < len; c++)
        at += (size_t)snprintf(buf + at, len - at, "%s%s", c == r->choices ? "" : ", ", c->name);
}

/* A byte count: a whole number, optionally followed by K, M, G or T (powers of 1024; "KiB",
 * "MB" and the like read the same way), within the row's range. */
static csi_status parse_bytes(const row *r, const char *v, csi_recon_options *o)
{
    bool ok = *v && *v != '-' && *v != '+';
    char *end = NULL;
    errno = 0;
    unsigned long long u = ok ? strtoull(v, &end, 10) : 0;
    ok = ok && !errno && end != v;
    int shift = 0;
    if (ok) {
        switch (*end) {
        case 'k': case 'K': shift = 10; break;
        case 'm': case 'M': shift = 20; break;
        case 'g': case 'G': shift = 30; break;
        case 't': case 'T': shift = 40; break;
        case '\0': break;
        default: ok = false;
        }
    }
    if (ok && shift) {
        end++;
        if (!strcmp(end, "iB") || !strcmp(end, "B") || !strcmp(end, "ib") || !strcmp(end, "b"))
            end += strlen(end);
    }
    ok = ok && !*end && u <= (UINT64_MAX >> shift);
    const uint64_t bytes = ok ? (uint64_t)u << shift : 0;
    if (!ok || (double)bytes < r->lo || (double)bytes > r->hi)
        return csi_fail(CSI_ERR_ARG, "%s: '%s' is not a size of at least %.0fM (bytes, or a number "
                        "with K, M, G or T)%s", r->name, v, r->lo / 1048576.0,
                        (r->flags & F_AUTO) ? " or auto" : "");
    *(uint64_t *)field(o, r) = bytes;
    return CSI_OK;
}
static csi_status store_number(const row *r, double d, bool ok, const char *text, csi_recon_options *o);

static csi_status parse(const row *r, const char *s, csi_recon_options *o)
{
    const char *v = s ? s : "";
    if (r->st == K_CHOICE) {
        for (const choice *c = r->choices; c->name; c++)
            if (!strcasecmp(v, c->name)) {
                store(o, r, c->value);
                return CSI_OK;
            }
        char list[160];
        choices_text(r, list, sizeof list);
        return csi_fail(CSI_ERR_ARG, "%s: '%s' is not one of %s", r->name, v, list);
    }
    if (r->st == K_BOOL) {
        if (!strcasecmp(v, "on") || !strcasecmp(v, "true") || !strcmp(v, "1"))
            store(o, r, 1);
        else if (!strcasecmp(v, "off") || !strcasecmp(v, "false") || !strcmp(v, "0"))
            store(o, r, 0);
        else
            return csi_fail(CSI_ERR_ARG, "%s: '%s' is not on or off", r->name, v);
        return CSI_OK;
    }
    if ((r->flags & F_AUTO) && !strcasecmp(v, "auto")) {
        store(o, r, 0);
        return CSI_OK;
    }
    if ((r->flags & F_OFF) && !strcasecmp(v, "off")) {
        store(o, r, -1);
        return CSI_OK;
    }
    errno = 0;
    char *end = NULL;
    double d;
    bool ok;
    if (r->st == K_U64) {
        /* the full 64-bit range, exactly (a double cannot hold every seed; K_U64 options take
         * any 64-bit value) */
        ok = *v && *v != '-' && *v != '+';
        unsigned long long u = ok ? strtoull(v, &end, 10) : 0;
        ok = ok && !errno && end && !*end;
        if (ok) {
            *(uint64_t *)field(o, r) = u;
            return CSI_OK;
        }
        return csi_fail(CSI_ERR_ARG, "%s: '%s' is not a whole number from 0 to 2^64 - 1", r->name, v);
    }
    if (r->st == K_BYTES)
        return parse_bytes(r, v, o);
    d = strtod(v, &end);
    ok = *v && !errno && end && !*end;
    return store_number(r, d, ok, v, o);
}

/* Checks number d (ok: it was read) against the row and stores it; `text` names it in messages. */
static csi_status store_number(const row *r, double d, bool ok, const char *text, csi_recon_options *o)
{
    const char *v = text;
    const bool whole = r->st == K_INT || r->st == K_U32 || r->st == K_SIZE || r->st == K_U64 ||
                       r->st == K_BYTES;
    ok = ok && isfinite(d);
    if (ok && (r->flags & F_AUTO) && d == 0) {
        store(o, r, 0);
        return CSI_OK;
    }
    if (ok && whole && d != floor(d))
        ok = false;
    if (ok && (r->flags & F_OFF) && d < 0 && r->lo >= 0)
        ok = false; /* "off" is spelled off; a negative count is a mistake */
    if (ok && (d < r->lo || d > r->hi))
        ok = false;
    if (ok && (r->flags & F_WHOLE1) && d >= 1 && d != floor(d))
        ok = false;
    if (!ok) {
        char extra[64] = "";
        if ((r->flags & (F_AUTO | F_OFF)) == (F_AUTO | F_OFF))
            snprintf(extra, sizeof extra, ", auto or off");
        else if (r->flags & F_AUTO)
            snprintf(extra, sizeof extra, " or auto");
        if (r->flags & F_WHOLE1)
            return csi_fail(CSI_ERR_ARG, "%s: '%s' is neither a fraction in (0, 1) nor a whole count%s",
                            r->name, v, extra);
        return csi_fail(CSI_ERR_ARG, "%s: '%s' is not a %s in [%.12g, %.12g]%s", r->name, v,
                        whole ? "whole number" : "number", r->lo, r->hi, extra);
    }
    if ((r->flags & F_OFF) && d < 0)
        d = -1; /* every negative is off, spelled -1 */
    store(o, r, d);
    return CSI_OK;
}

/* The shortest decimal that reads back as the same value. */
static void format_number(double v, bool single, char *buf, size_t len)
{
    for (int prec = 6; prec <= 17; prec++) {
        snprintf(buf, len, "%.*g", prec, v);
        double back = strtod(buf, NULL);
        if (single ? (float)back == (float)v : back == v)
            return;
    }
}

static void format(const csi_recon_options *o, const row *r, char *buf, size_t len)
{
    if (r->st == K_U64 || (r->st == K_BYTES && load(o, r) != 0)) {
        snprintf(buf, len, "%llu", (unsigned long long)*(const uint64_t *)field(o, r));
        return;
    }
    const double v = load(o, r);
    if (r->st == K_CHOICE) {
        snprintf(buf, len, "%s", csi_recon_choice_name(r->name, (int)v));
    } else if (r->st == K_BOOL) {
        snprintf(buf, len, "%s", v != 0 ? "on" : "off");
    } else if ((r->flags & F_AUTO) && v == 0) {
        snprintf(buf, len, "auto");
    } else if ((r->flags & F_OFF) && v < 0) {
        snprintf(buf, len, "off");
    } else {
        format_number(v, r->st == K_FLOAT, buf, len);
    }
}

void csi_recon_defaults(csi_recon_options *o)
{
    memset(o, 0, sizeof *o);
    for (size_t i = 0; i < NROWS; i++) {
        csi_status s = parse(&table[i], table[i].def, o);
        (void)s; /* the table's defaults parse (checked by tests/unit/test_options.c) */
    }
}

size_t csi_option_count(void)
{
    return NROWS;
}

csi_status csi_option_describe(size_t i, csi_option_info *out)
{
    if (i >= NROWS)
        return csi_fail(CSI_ERR_ARG, "option %zu of %zu", i, (size_t)NROWS);
    const row *r = &table[i];
    out->name = r->name;
    out->kind = r->st == K_CHOICE ? CSI_OPTION_CHOICE
                : r->st == K_BOOL ? CSI_OPTION_FLAG
                : r->st == K_DOUBLE || r->st == K_FLOAT ? CSI_OPTION_NUMBER
                                                        : CSI_OPTION_INTEGER;
    out->metavar = r->metavar;
    out->help = r->help;
    out->def = r->def;
    out->auto_rule = r->auto_rule;
    out->program = !(r->flags & F_LIBRARY);
    return CSI_OK;
}

csi_status csi_recon_option_set(csi_recon_options *o, const char *name, const char *value)
{
    const row *r = find(name);
    if (!r)
        return csi_fail(CSI_ERR_ARG, "no option named '%s'", name ? name : "");
    csi_recon_options tmp = *o;
    CSI_TRY(parse(r, value, &tmp));
    *o = tmp;
    return CSI_OK;
}

csi_status csi_recon_option_set_number(csi_recon_options *o, const char *name, double value)
{
    const row *r = find(name);
    if (!r)
        return csi_fail(CSI_ERR_ARG, "no option named '%s'", name ? name : "");
    if (r->st == K_CHOICE)
        return csi_fail(CSI_ERR_ARG, "%s: a choice is set by name, not by a number", r->name);
    if (r->st == K_BOOL) {
        if (value != 0 && value != 1)
            return csi_fail(CSI_ERR_ARG, "%s: %g is not on (1) or off (0)", r->name, value);
        store(o, r, value);
        return CSI_OK;
    }
    char text[32];
    snprintf(text, sizeof text, "%.17g", value);
    csi_recon_options tmp = *o;
    if (r->st == K_U64) {
        if (!(value >= 0 && value <= 9007199254740992.0 && value == floor(value)))
            return csi_fail(CSI_ERR_ARG, "%s: '%s' is not a whole number from 0 to 2^53 (give larger "
                            "seeds as text)", r->name, text);
        *(uint64_t *)field(&tmp, r) = (uint64_t)value;
    } else {
        CSI_TRY(store_number(r, value, true, text, &tmp));
    }
    *o = tmp;
    return CSI_OK;
}

csi_status csi_recon_option_get(const csi_recon_options *o, const char *name, char *buf, size_t len)
{
    const row *r = find(name);
    if (!r)
        return csi_fail(CSI_ERR_ARG, "no option named '%s'", name ? name : "");
    if (!buf || len == 0)
        return csi_fail(CSI_ERR_ARG, "option %s: no room for its value", name);
    format(o, r, buf, len);
    return CSI_OK;
}

csi_status csi_recon_option_number(const csi_recon_options *o, const char *name, double *out)
{
    const row *r = find(name);
    if (!r)
        return csi_fail(CSI_ERR_ARG, "no option named '%s'", name ? name : "");
    if (r->st == K_CHOICE || r->st == K_BOOL)
        return csi_fail(CSI_ERR_ARG, "option %s is not a number", name);
    const double v = load(o, r);
    if (((r->flags & F_AUTO) && v == 0) || ((r->flags & F_OFF) && v < 0))
        return csi_fail(CSI_ERR_ARG, "option %s is %s", name, v == 0 ? "auto" : "off");
    *out = v;
    return CSI_OK;
}

bool csi_recon_option_value(const csi_recon_options *o, size_t i, double *num, char *buf, size_t len)
{
    if (i >= NROWS || !buf || !len)
        return false;
    const row *r = &table[i];
    format(o, r, buf, len);
    if (r->st == K_CHOICE || r->st == K_BOOL || r->st == K_U64)
        return false;
    const double v = load(o, r);
    if (((r->flags & F_AUTO) && v == 0) || ((r->flags & F_OFF) && v < 0))
        return false;
    *num = v;
    return true;
}

const char *csi_recon_choice_name(const char *name, int v)
{
    const row *r = find(name);
    if (r && r->st == K_CHOICE)
        for (const choice *c = r->choices; c->name; c++)
            if (c->value == v)
                return c->name;
    return "?";
}

double csi_gauss_nc_default_sigma(size_t k, size_t n, int dims)
{
    if (n == 0 || k == 0 || dims < 1)
        return 1.0;
    return 0.5 * pow((double)k / (double)n, 1.0 / dims);
}

double csi_motion_tau_rel(size_t n)
{
    if (n == 0)
        return CSI_MOTION_TAU_MAX;
    double t = CSI_MOTION_TAU_C / sqrt((double)n);
    return t < CSI_MOTION_TAU_MIN ? CSI_MOTION_TAU_MIN : t > CSI_MOTION_TAU_MAX ? CSI_MOTION_TAU_MAX : t;
}
