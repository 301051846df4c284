/* Compressive reconstruction of an image (or an x,y,t volume) from point samples on a fine grid:
 * the paper's Alg. 1 (antialiasing) and Alg. 2 (motion blur), end to end on the device.
 *
 *   grid.t == 1  Alg. 1: A = S Phi^-1 Psi (sampling, Wiener-inverted Gaussian, Daubechies
 *                wavelet synthesis); solve for the wavelet coefficients of the filtered image
 *                f_b; box-integrate Phi^-1 f_b (default) or f_b (the paper's estimator) over
 *                each output pixel, then (default) correct each pixel with its own samples.
 *                The defaults differ from the paper where measurements showed it (sharp target,
 *                Gaussian width following the sample spacing, SpaRSA stopped on the objective
 *                with tau from the samples per pixel, no debiasing, a per-pixel blend with the
 *                pixel's own samples, at most 5 levels): docs/bench/quality.md and
 *                docs/bench/mitsuba.md have the figures. On a path tracer's samples (HDR,
 *                Monte Carlo noise) the default is meant never to be worse than the per-pixel
 *                mean; the paper's configuration loses to stratified sampling from 9 spp on.
 *   grid.t  > 1  Alg. 2: A = S F3^H (3-D orthonormal Fourier basis over x, y, t); solve for the
 *                complex coefficients; f = Re(F3^H x); the image is the mean of f over t, box-
 *                integrated to the output size; optionally every frame too (Sec. 6.1).
 *
 * Channels are independent right-hand sides over one operator built once. Images are planar
 * (channel-major) float32, out_w * out_h per plane. */
#ifndef CSI_RECONSTRUCT_H
#define CSI_RECONSTRUCT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/runtime.h"
#include "csi/samples.h"
#include "csi/solve.h"
#include "csi/spectral.h"
#include "csi/wavelet.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- options ------------------------------------------------------------------------------
 * Every option is a row of one table (options.c): its name (the programs' --name, the Python
 * keyword with '-' as '_', the key in the statistics), its field below, its kind, the range a
 * given value must lie in, its default and its help. The programs' getopt tables and help text,
 * the statistics and the EXR attributes are made from the table; csi_recon_defaults fills the
 * defaults from it.
 *
 * "Unset" is spelled one way: 0. An option whose default depends on the problem (the grid, the
 * number of samples, the method) is "auto" while it holds 0 (enums: the *_AUTO member, which is
 * 0); csi_recon resolves it and reports the value it used in csi_recon_result.options. Where
 * an option can also be switched off, off is -1 (VkFFT's convention: -1 off, 0 auto, 1 on or a
 * value). Options with a fixed default hold their value. */

typedef enum { CSI_SOLVER_AUTO = 0, CSI_SOLVER_ROMP, CSI_SOLVER_SPARSA } csi_solver_kind;

/* Which signal Alg. 1 integrates over each pixel. */
typedef enum {
    CSI_AA_FILTERED = 0, /* the paper's: the filtered estimate f_b = Psi x (biased: blurred) */
    CSI_AA_SHARP,        /* Phi^-1 f_b, the estimate of f the samples constrain */
} csi_aa_output;

/* After integration, each pixel can be corrected with its own samples (csi's addition, not the
 * paper's); g is the fine estimate (Phi^-1 f_b or f_b for Alg. 1, the volume f for Alg. 2, the
 * Gaussian baseline's image), b = box(g) the uncorrected pixel, m the mean of the pixel's
 * samples (all t), n_p their number.
 *
 * BLEND (the default for the compressive estimator's images): pixel = b + beta_p (m - b), with
 * beta_p = B^2 / (B^2 + V) from the samples alone: V estimates the error variance of m (its
 * samples' spread, pooled robustly over the 3 x 3 pixels around, plus the error that the
 * positions of its samples explain through g; 0 when every cell of the pixel is sampled), B^2
 * the squared bias of b (the excess of (m - b)^2 over V: the pixel's own, pooled, and of one
 * sign over the 3 x 3 pixels). Where b is biased (a blurred or ringing edge, an HDR neighbour's
 * light leaking in) the pixel follows its own samples; where m is noisy and b consistent with
 * it (Monte Carlo noise over smooth shading) it follows b. Every approximation errs towards m,
 * meant to keep the result from being worse than the per-pixel mean (where it still is:
 * docs/bench/mitsuba.md). b and g are first projected onto the range of the samples in the
 * pixel and its 8 neighbours, and b onto the range of those pixels' means, so the result stays
 * in that range (no halo; no negative value from non-negative samples). A pixel without a
 * sample moves from b
 * towards its neighbours' median by their mean beta. On a still image a pixel holding one
 * sample then moves towards CV (below, projected onto the same range) by a weight that trusts
 * the fit where it passes through that sample and no HDR step is near (host/integrate/
 * fit_trust.c; not where most pixels hold two samples or more). A dump that samples every cell
 * gives the exact cell means. Alg. 2 (AUTO): the volume is projected onto the same range (frames
 * too); with a still basis the image is then corrected by each pixel's mean residual y - g (the
 * fit as the samples' control variate), shrunk by that correction's estimated risk
 * (host/integrate/motion_correct.c); fully sampled pixels take their exact mean; the blend
 * itself only on request (BLEND), CV as above.
 * Design and measurements: host/integrate/blend.c, docs/bench/mitsuba.md.
 *
 * CV (the previous default): pixel = b + n_p / (n_p + cv_n0) * mean_i (y_i - g(x_i)), g as a
 * control variate of the pixel's Monte Carlo mean. With n0 = 0 it is the sample mean plus
 * b - mean_i g(x_i); n0 > 0 shrinks the correction where a pixel has few samples.
 *
 * Measurements: docs/bench/quality.md (analytic images), docs/bench/mitsuba.md (a path
 * tracer's samples: HDR, Monte Carlo noise). */
typedef enum {
    CSI_CORRECT_AUTO = 0, /* Alg. 1's images: CV for exact samples (CSI_SAMPLES_EXACT), BLEND
                             otherwise; for Alg. 2 the range projection and, with a still
                             basis, the shrunk control variate; NONE for the Gaussian
                             baseline */
    CSI_CORRECT_NONE,     /* the image is box(g): the paper's */
    CSI_CORRECT_CV,       /* the control-variate correction above */
    CSI_CORRECT_BLEND,    /* the risk-weighted blend of b and the sample mean above */
} csi_aa_correct;

/* A setting that is on, off, or left to the method's measured default. */
typedef enum { CSI_SWITCH_OFF = -1, CSI_SWITCH_AUTO = 0, CSI_SWITCH_ON = 1 } csi_switch;

/* SpaRSA's stopping rule as a reconstruction option: AUTO lets the method choose. */
typedef enum { CSI_STOP_AUTO = 0, CSI_STOP_GAP, CSI_STOP_OBJECTIVE } csi_recon_stop;

/* What the cross-validated choice's folds reconstruct from samples of several channels: the
 * mean of the channels (one solve per fold; auto) or every channel (csi/cv_select.h). */
typedef enum { CSI_CV_CHANNELS_AUTO = 0, CSI_CV_CHANNELS_MEAN, CSI_CV_CHANNELS_EACH } csi_cv_channels;

/* The estimator: csi's compressive method, or one of the baselines it is measured against. */
typedef enum {
    CSI_EST_CS = 0, /* compressive: Alg. 1 (grid.t = 1) or Alg. 2 (grid.t > 1) */
    CSI_EST_MEAN,   /* Monte Carlo: each pixel is the mean of its samples (all t); no frames */
    CSI_EST_GAUSS,  /* normalized convolution with a 2-D / 3-D Gaussian (the paper's linear
                       baseline, Sec. 6.1): f = G*(S^T y) / G*(S^T 1), then integrated like CS */
} csi_estimator;

/* Alg. 2's basis along t (csi_fourier_half_set_motion): AUTO is the measured best. */
typedef enum { CSI_MOTION_TIME_AUTO = 0, CSI_MOTION_TIME_DFT, CSI_MOTION_TIME_DCT } csi_motion_time;
/* Alg. 2's basis velocity: estimated from the samples, none (the paper's still basis), or given
 * (motion_vx, motion_vy). */
typedef enum { CSI_VELOCITY_ESTIMATE = 0, CSI_VELOCITY_NONE, CSI_VELOCITY_GIVEN } csi_velocity_mode;

/* ROMP's defaults for images: csi's (measured, docs/bench/romp.md) or the published ROMP's. */
typedef enum { CSI_ROMP_PRESET_CSI = 0, CSI_ROMP_PRESET_PUBLISHED } csi_romp_preset;

/* The Gaussian baseline's default width (grid cells, every axis): the spacing of N samples
 * spread evenly over k cells in d dimensions, (k/N)^(1/d), times 0.5. */
double csi_gauss_nc_default_sigma(size_t k, size_t n, int dims);

/* Alg. 2's default tau_rel for n samples: CSI_MOTION_TAU_C / sqrt(n), clamped to
 * [CSI_MOTION_TAU_MIN, CSI_MOTION_TAU_MAX]. Why 1/sqrt(n): tau_rel is relative to
 * ||A^H y||_inf, which for A = S F3^H (F unitary) is the DC coefficient, about n mean(y) /
 * sqrt(k); a coefficient the scene does not have still receives the incoherent sum of the
 * samples, about sqrt(n) rms(y) / sqrt(k). So the aliasing floor l1 must cut is
 * ~ (rms / mean) / sqrt(n) of the maximum, and a fixed fraction of it is a fixed C / sqrt(n).
 * C = 0.25 was the best error per second over csi's procedural moving scenes at 64^2 x 16
 * (n 4096 and 6554: tau_rel 3-4e-3) and at 512^2 x 128 (n = 335544: 4.3e-4), see
 * docs/bench/motion.md; the solver's own default (1e-4) costs 3-10x the iterations at the small
 * sizes for a worse result. */
#define CSI_MOTION_TAU_C 0.25
#define CSI_MOTION_TAU_MIN 1e-4
#define CSI_MOTION_TAU_MAX 3e-2
double csi_motion_tau_rel(size_t n);
/* With the samples' variances (csi_samples.variance) a coefficient the scene does not have also
 * receives their noise, about sqrt(n) sigma / sqrt(k): relative to the maximum, (sigma / mean) /
 * sqrt(n), the same form as the aliasing floor above. Alg. 2's tau_rel is then at least
 * CSI_MOTION_TAU_NOISE (sigma / mean) / sqrt(n) per channel (csi_recon_options.sample_noise,
 * motion.c): 3 was within 1% of the best image and 0.15 dB of the best frames on Mitsuba's
 * path-traced animations at 3-10% of the cells (16 paths per sample: noise 0.27-0.29 of the
 * level; 2 and 4 within 3%; docs/bench/animation.md, session 31). Not beyond
 * CSI_MOTION_TAU_NOISE_MAX / sqrt(n), 4 times the default: with one path per sample (noise
 * about the level) 3 (sigma / mean) smoothed the frames more but lost the blurred image 7-25% on
 * two of three scenes, where this cap (about 0.9 sigma / mean there) kept it at or below the
 * image without the variances. */
#define CSI_MOTION_TAU_NOISE 3.0
#define CSI_MOTION_TAU_NOISE_MAX 1.0
/* Each channel's noise relative to its level (sample_noise.c): sqrt(mean variance) / mean |value|
 * over the n samples (channels <= 4); all 0 without variances (variance NULL). */
void csi_recon_sample_noise(const float *values, const float *variance, size_t n, uint32_t channels,
                            double noise[4]);

/* The fields; each one's meaning, range and default are in its row of the table (options.c,
 * printed by the programs' --help). */
typedef struct csi_recon_options {
    csi_estimator estimator;
    double gauss_sigma;           /* CSI_EST_GAUSS: width in grid cells; 0 auto */
    csi_solver_kind solver;
    csi_wavelet_family wavelet;   /* Alg. 1 basis */
    int levels;                   /* wavelet levels; 0 auto */
    float lambda;                 /* Wiener regularisation */
    double sigma_scale;           /* multiplies the paper's sigma_Phi */
    double sigma_spacing;         /* Alg. 1: sigma_Phi is at least this times the sample spacing
                                     sqrt(k/N) (csi's rule: the filter follows the sampling
                                     rate); 0: the paper's width only */
    csi_aa_output output;
    csi_aa_correct correct;       /* grid.t = 1 (CS and GAUSS) */
    double cv_n0;                 /* CV shrinkage (see csi_aa_correct) */
    csi_switch cv_select;         /* images: per region, the image or the per-pixel mean, chosen
                                     by two-fold cross-validation (csi/cv_select.h) */
    csi_cv_channels cv_channels;  /* what its folds reconstruct (above) */
    csi_switch cv_smooth;         /* with it: Gaussian averages of the samples as further
                                     candidates, bounded by each pixel's own samples
                                     (csi/cv_smooth.h) */
    csi_switch peak_range;        /* images with the blend: a pixel whose samples hold one isolated
                                     peak takes a fit of the samples' logarithm
                                     (csi/peak_range.h); auto: off */
    csi_switch blend_spread;      /* the blend, given each sample's variance: a pixel whose samples
                                     spread beyond their variances counts that spread in its
                                     mean's noise (host/integrate/blend.c); auto: off */
    csi_switch settle;            /* images with the blend, last: the pixels that decide the image
                                     take their samples' mean (csi/settle.h); auto: on with the
                                     blend */
    csi_switch step_coverage;     /* images with the blend and the samples' variances, after the
                                     settling: a pixel across an HDR step given the coverage its
                                     window's samples allow (csi/step_coverage.h); auto: on with
                                     the blend */
    double tol;                   /* solver tolerance; 0 auto */
    int max_iter;                 /* 0 auto */
    double tau_rel;               /* SpaRSA tau relative to ||A^H y||_inf; 0 auto */
    csi_switch warm_channels;     /* Alg. 1 with SpaRSA: channels after the first start from the
                                     previous one's solution (see solver_setup.c); auto: off */
    csi_switch model_grid;        /* Alg. 1 on a grid coarser than the samples' where the filter
                                     allows it (csi/model_grid.h) */
    double model_sigma_min;       /* the model grid's smallest Gaussian width in model cells; 0
                                     auto: CSI_MODEL_SIGMA_MIN */
    csi_switch coarse_start;      /* Alg. 1 on a model grid with SpaRSA's continuation: the stages
                                     before the last on a grid twice as coarse (coarse_start.c) */
    csi_switch chroma;            /* Alg. 1 on 3 channels (RGB): solved as luma and two chroma
                                     channels, the chroma on a coarser model grid (chroma.c),
                                     their solves at 2/3 of tol; auto: on */
    csi_recon_stop stop;
    csi_switch continuation;      /* SpaRSA continuation on tau */
    double cont_step;             /* SpaRSA continuation: each stage's tau this times the previous
                                     one's; -1 off (WNF09's adaptive rule), 0 auto */
    double cont_tol;              /* SpaRSA: tolerance of the stages before the last; 0 auto */
    csi_switch debias;            /* SpaRSA debiasing phase (images) */
    /* ROMP (Alg. 1 only; docs/bench/romp.md has the measurements behind the defaults) */
    csi_romp_preset romp_preset;
    size_t romp_s;                /* candidates per step (csi_romp_options.s); 0 auto */
    double romp_max_support;      /* support size that ends the run: >= 1 a count, in (0, 1) a
                                     fraction of N; 0 auto */
    csi_switch romp_normalize;    /* rank correlations by column norm (csi_column_norms) */
    int romp_seed_levels;         /* support seeded before the first step with the top-left
                                     block of the coefficient array: 1 = the coarse scaling
                                     block, 1 + j = it and the j coarsest detail levels;
                                     -1 off (the published ROMP); 0 auto */
    int romp_lsq_iter;            /* CG iterations per least squares; 0 auto */
    /* Alg. 2 */
    double motion_resid_sigma;    /* width of the residual correction (see the table); -1 off
                                     (the paper's), 0 auto */
    bool motion_full_spectrum;
    bool motion_debias;
    /* Alg. 2's basis (csi's extension, docs/bench/animation.md): the half-spectrum Fourier basis
     * with a transform along t, sheared by a velocity so that what moves at it is static in the
     * basis (csi_fourier_half_set_motion). The paper's basis: time dft, velocity none. */
    csi_motion_time motion_time;
    csi_velocity_mode motion_velocity;
    double motion_vx, motion_vy;  /* cells per frame: given (CSI_VELOCITY_GIVEN); in a result's
                                     options, the velocity the basis had */
    double motion_resid_sigma_t;  /* the residual correction's width along t (frames) when the
                                     basis moves or has the DCT; 0 auto */
    double motion_filter;         /* Alg. 1's filter Phi in Alg. 2 (csi_half_fourier_set_filter):
                                     its width along x and y in cells; -1 off (the paper's), 0
                                     auto */
    double motion_still_weight;   /* the l1 weight of the coefficients constant along t in the
                                     basis's frame (csi_half_fourier_set_still_gain), relative
                                     to the others' (1: one weight, the paper's; 0 auto: 0.5
                                     for a noise-free still picture, else 1) */
    int motion_reweight;          /* reweighted l1 (host/integrate/motion_reweight.c): re-solves
                                     with weights from the previous solution; 0 none */
    double motion_reweight_eps;   /* its eps, relative to the mean non-zero coefficient magnitude */
    csi_switch motion_image_cv;   /* a volume solved whole: per region its image or that of a
                                     solve of the shutter binned in t, by two-fold
                                     cross-validation (host/integrate/motion_image.c); auto: off */
    csi_switch frames_denoise;    /* a volume's frames from noisy samples: each sampled cell given
                                     its neighbours' estimate by its samples' known noise, then a
                                     Gaussian chosen by two folds of the samples
                                     (csi/frames_denoise.h); auto: on with frames and samples whose
                                     variances say their noise is at least
                                     CSI_FRAMES_DENOISE_NOISE_MIN of their level (sample_noise) */
    csi_switch image_frames;      /* a volume's blurred image averaged with the mean over t of the
                                     frames frames_denoise gave (computed for it when frames are
                                     not asked for; frames_denoise auto is then on); auto: on
                                     wherever frames_denoise would be, frames asked for or not;
                                     time windows average after the blend (csi/tiles.h), the
                                     binned shutter's image not; on needs frames_denoise not off */
    bool frames;                  /* grid.t > 1: also return every frame */
    uint64_t seed;                /* seed of the randomised parts (ROMP's column-norm probes);
                                     everything else is deterministic */
    /* Tiles (csi/tiles.h): the problem is solved in overlapping tiles when the whole would need
     * more device memory than mem_budget, or when `tiles` asks for a number of them. */
    uint64_t mem_budget;          /* device bytes one reconstruction may use; 0 auto */
    uint32_t tiles;               /* 0 auto: as few as fit the budget (1 when the whole fits) */
    uint32_t tile_margin;         /* overlap beyond a tile's core, output pixels; 0 auto */
    uint32_t tile_margin_t;       /* the same in frames for a volume; 0 auto */
    uint32_t tiles_t;             /* time windows of a volume; 0 auto: the planner's price (csi/tiles.h) */
    csi_switch tile_image_binned; /* a volume split in t: its blurred image from one solve of the
                                     whole shutter binned in t to a window's length (csi/tiles.h);
                                     the windows then give only the frames */
    /* Not an option (no row in the table): what the samples are, CSI_SAMPLES_* of csi/csi.h,
     * which the library copies from csi_samples.flags; correct = auto follows it. */
    uint32_t sample_flags;
    /* Not an option either: csi_samples.variance (NULL: unknown), read on a still image
     * reconstructed by csi with the blend (csi/peak_noise.h): by csi_recon on the whole image,
     * by each tile in its window (csi_recon_tile); on a volume, only for sample_noise below. */
    const float *sample_variance;
    /* Not an option either: each channel's noise relative to its level over the whole problem's
     * samples, from sample_variance (csi_recon_sample_noise; 0 without variances), set where the
     * whole's samples are at hand (csi_recon, csi_reconstruct_tile) and copied to every tile;
     * Alg. 2's tau follows it (CSI_MOTION_TAU_NOISE). */
    double sample_noise[4];
    /* Not an option either: how many of the grid's frames are the shutter's, the first ones
     * (0: all). A volume whose frame count the FFT cannot take is solved on more frames, which
     * hold no sample (padding.c); its image is the mean over these frames only. */
    uint32_t shutter_frames;
    csi_solve_progress_fn progress; /* phases: "setup", then per channel c of C "solve c/C"
                                     (with the solver's step and relative residual) and
                                     "integrate c/C" (a volume's frames denoised: then the
                                     same of each fold, "frames fold 1 setup" ...); returning
                                     false cancels (CSI_ERR_CANCELLED) */
    void *user;
} csi_recon_options;

/* Every field its default from the table (autos 0), progress NULL. */
void csi_recon_defaults(csi_recon_options *o);

/* Sets option `name` from text, as the programs' --name VALUE does: a choice by name, a number
 * in the option's range, "auto" (options with a problem-dependent default), "off" (options
 * that can be switched off), "on"/"off" (flags). CSI_ERR_ARG with "name: 'value' is not ..."
 * otherwise; o is unchanged then. */
csi_status csi_recon_option_set(csi_recon_options *o, const char *name, const char *value);
/* The same with a number (exactly; choices refuse it, flags take 0 or 1). */
csi_status csi_recon_option_set_number(csi_recon_options *o, const char *name, double value);
/* The value of option `name` as text, the form csi_recon_option_set reads back. */
csi_status csi_recon_option_get(const csi_recon_options *o, const char *name, char *buf, size_t len);
/* The value as a number (choices and flags: CSI_ERR_ARG; auto and off: CSI_ERR_ARG too). */
csi_status csi_recon_option_number(const csi_recon_options *o, const char *name, double *out);
/* Option i's value as text in buf, and as a number in *num when it is one (not a choice, a flag,
 * a seed, auto or off): returns whether it is. Never fails (for statistics and attributes). */
bool csi_recon_option_value(const csi_recon_options *o, size_t i, double *num, char *buf, size_t len);
/* The name of value v of choice option `name` ("?" if none). */
const char *csi_recon_choice_name(const char *name, int v);

/* Fills every auto option that applies to this problem (grid, n samples) and these options
 * with the value csi_recon uses; options that do not apply stay as they are. */
csi_status csi_recon_resolve(const csi_recon_options *in, const csi_grid *g, size_t n,
                             csi_recon_options *out);

typedef struct csi_recon_result {
    uint32_t out_w, out_h, channels;
    uint32_t nframes;       /* grid.t when frames were asked for, else 0 */
    float *image;           /* out_w * out_h * channels, planar */
    float *frames;          /* nframes * channels * out_w * out_h (frame-major, then planar) */
    csi_recon_options options; /* the options used: every auto that applies resolved */
    csi_solve_report report[4];
    size_t cv_switched;     /* pixels the cross-validated choice gave their mean (cv_select; in
                               tiles, each tile's in its core) */
    size_t cv_smoothed;     /* pixels it gave a Gaussian average of the samples (cv_smooth; in
                               tiles likewise) */
    size_t motion_image_switched; /* pixels that took a binned solve's image (motion_image_cv) */
    size_t peak_range_pixels; /* pixels given the log fit's value (peak_range) */
    size_t settled;         /* pixels moved towards their samples' mean (settle; in tiles, on the
                               blended image) */
    size_t step_moved;      /* pixels across an HDR step given their window's coverage
                               (step_coverage; in tiles, on the
                               blended image) */
    double frames_sigma[2]; /* the frames' Gaussian chosen by frames_denoise, along x and y
                               and along t; -1 where it did not run (and in tiles, each of
                               which chooses its own) */
    double t_frames;        /* seconds of frames_denoise, its folds' solves included (untiled) */
    double t_setup, t_solve, t_integrate; /* seconds */
    double t_cv;            /* the cross-validated choice (cv_select): its two folds' reconstructions,
                               whose solves and integration t_solve and t_integrate count, and the
                               choice itself */
    double t_programs;      /* of t_setup: building the kernel programs (csi_ctx_build_seconds) */
    double t_channel_integrate[4]; /* t_integrate per channel (the solves: report[c].t_total) */
    double cpu_setup, cpu_work;    /* process CPU seconds (every thread) of the setup and of the
                                      solves and integration: on a shared machine, less
                                      disturbed by other jobs than wall time */
    size_t k, n;            /* grid cells and measurements per channel (the whole problem's) */
    size_t unknowns;        /* the solver's unknowns per channel: k, or fewer on a model grid */
    uint32_t model_factor;  /* Alg. 1: the model grid's coarsening D (csi/model_grid.h), else 1 */
    uint32_t chroma_model_factor; /* Alg. 1 on RGB as luma and chroma: the chroma channels' D
                                     (the channels' reports are then Y, C1, C2); else 0 */
    uint32_t tiles;         /* tiles it was solved in (1: the whole at once) */
    double t_velocity;      /* Alg. 2: of t_setup, the seconds spent estimating the basis's
                               velocity (options.motion_vx, motion_vy hold it) */
    uint32_t velocity_evals; /* Alg. 2: the velocity search's leave-one-out evaluations */
} csi_recon_result;
void csi_recon_result_free(csi_recon_result *r);

/* values: n * channels floats, sample-major (values[i * channels + c]). Positions must be
 * unique and inside the grid (csi_dump_read guarantees both). */
csi_status csi_recon(csi_ctx *ctx, const csi_grid *grid, uint32_t channels, const csi_sample_pos *pos,
                     const float *values, size_t n, const csi_recon_options *opt,
                     csi_recon_result *out);
/* CSI_OK when variance is NULL or holds n * channels finite values >= 0; else names the first
 * that is not. */
csi_status csi_recon_check_variance(const float *variance, size_t n, uint32_t channels);

#ifdef __cplusplus
}
#endif
#endif
