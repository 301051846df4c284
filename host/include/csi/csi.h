/* csi: compressive signal integration, the public C API.
 *
 * Reconstructs an antialiased image, or a motion-blurred image and its frames, from few point
 * samples of a signal on a fine grid, by compressed sensing (Sen & Darabi, "Compressive
 * estimation for signal integration in rendering", EGSR 2010). This is the one header a program
 * includes; it holds no OpenCL type (csi/csi_opencl.h, opt-in, makes a device on the caller's
 * own OpenCL context and queue).
 *
 *     csi_device *dev;   csi_dump d;   csi_result *r;   csi_image img;
 *     csi_device_new(NULL, &dev);                       // PoCL's CPU device, or $CSI_DEVICE
 *     csi_dump_read("samples.csid", NULL, &d, NULL);    // or fill a csi_samples from arrays
 *     csi_samples s = {d.grid, d.channels, d.count, d.pos, d.values, d.flags, NULL};
 *     csi_reconstruct(dev, &s, NULL, NULL, NULL, &r);   // NULL options: every default
 *     csi_result_image(r, &img);                        // planar float32, out_w x out_h
 *     csi_exr_write("out.exr", &img, NULL, 0);
 *     csi_result_free(r); csi_dump_free(&d); csi_device_release(dev);
 *
 * Conventions
 * - Every function that can fail returns a csi_status; CSI_OK is 0. The failing call leaves a
 *   one-line message (what, where, why): csi_last_error() gives this thread's last one, and a
 *   device keeps the first failure of the calls made with it until csi_device_error() reads
 *   it. The library never prints and never exits.
 * - Memory the library hands out is released by the matching *_free function (arrays by
 *   csi_free).
 * - One call at a time per device (a device holds one in-order queue); devices are independent.
 * - The same inputs, options and seed give the same bits on one machine. */
#ifndef CSI_CSI_H
#define CSI_CSI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define CSI_API __attribute__((visibility("default")))
#else
#define CSI_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* ---- version ------------------------------------------------------------------------------- */
/* The build reads these lines for its own version (CMakeLists.txt), so they are the only place
 * it is written. While MAJOR is 0 a MINOR step may change the ABI (0.2: csi_samples.variance), so
 * the shared library's soname is libcsi.so.0.MINOR and find_package(csi) takes the same minor. */
#define CSI_VERSION_MAJOR 0
#define CSI_VERSION_MINOR 2
#define CSI_VERSION_PATCH 0
/* "MAJOR.MINOR.PATCH" of the library that is running (which may be newer than this header). */
CSI_API const char *csi_version(void);

/* ---- errors -------------------------------------------------------------------------------- */
typedef enum csi_status {
    CSI_OK = 0,
    CSI_ERR_ARG,          /* an argument is out of range or inconsistent (sizes, options) */
    CSI_ERR_IO,           /* a file could not be opened, read or written */
    CSI_ERR_FORMAT,       /* a file's contents are malformed (truncated, bad magic, NaN ...) */
    CSI_ERR_NOMEM,        /* host allocation failed */
    CSI_ERR_DEVICE,       /* no usable OpenCL device, or a size the device cannot hold */
    CSI_ERR_CL,           /* an OpenCL or clFFT call failed */
    CSI_ERR_BUILD,        /* a kernel program failed to build (message holds the log's start) */
    CSI_ERR_NUMERIC,      /* a computation produced NaN/Inf or cannot proceed numerically */
    CSI_ERR_SCENE,        /* a scene file has an error */
    CSI_ERR_TOO_LARGE,    /* the input needs more memory than the device or host has (refused
                             before any work) */
    CSI_ERR_CANCELLED,    /* the progress callback asked to stop; nothing was kept */
} csi_status;

/* Propagates a failure: CSI_TRY(expr) returns expr's status from the enclosing function (which
 * returns csi_status) when it is not CSI_OK. */
#define CSI_TRY(expr)                          \
    do {                                       \
        csi_status csi_try_st_ = (expr);       \
        if (csi_try_st_ != CSI_OK)             \
            return csi_try_st_;                \
    } while (0)

/* "CSI_ERR_IO" for CSI_ERR_IO. */
CSI_API const char *csi_status_name(csi_status st);
/* The message of the last failure on this thread ("" if none). */
CSI_API const char *csi_last_error(void);
/* Releases an array the library allocated (positions). NULL is fine. */
CSI_API void csi_free(void *p);
/* Copies `in` to out (cap bytes, NUL-terminated) with every control character written as
 * \xNN: ASCII controls (newlines and escape sequences included), DEL, C1 controls and bytes that
 * are not valid UTF-8; other UTF-8 is kept. Every message the library records goes through it;
 * a program quoting its own input (a file name, an argument) in a message can do the same, so
 * that no input drives the terminal. Returns the length written. */
CSI_API size_t csi_escape_controls(const char *in, char *out, size_t cap);

/* ---- host memory --------------------------------------------------------------------------- */
/* Bytes the host can give a new allocation now without swapping: Linux's MemAvailable
 * (/proc/meminfo), lowered to $CSI_HOST_MEMORY_LIMIT (bytes) when that is set to a smaller
 * number; 0 when unknown. The library refuses (CSI_ERR_TOO_LARGE) inputs that need more before
 * allocating for them; a program can check its own arrays the same way. */
CSI_API uint64_t csi_host_available_bytes(void);
/* Bytes as text, "3.5 GiB" (binary units), into buf (len >= 16); returns buf. */
CSI_API const char *csi_bytes_text(uint64_t bytes, char *buf, size_t len);

/* ---- devices ------------------------------------------------------------------------------- */
typedef struct csi_device csi_device;

/* A device by name: `name` is a case-insensitive substring of "platform / device" (see
 * csi_device_list); NULL or "" means the environment variable CSI_DEVICE, else PoCL's CPU
 * device, else the first device. CSI_CACHE_DIR (if set) holds PoCL's and clFFT's kernel caches,
 * so a second run does not compile them again. */
CSI_API csi_status csi_device_new(const char *name, csi_device **out);
/* Waits for the device's work and releases it (and, for a device on the caller's OpenCL
 * objects, the references csi took). NULL is fine. */
CSI_API void csi_device_release(csi_device *dev);
/* The most device bytes this process held at once through csi (all devices), since it started:
 * what a run needed, for its statistics. */
CSI_API uint64_t csi_device_bytes_peak(void);
/* "platform / device". */
CSI_API const char *csi_device_name(const csi_device *dev);
/* The first failure of a call made with dev since the last query, and clears it: CSI_OK and
 * message "" when there was none. message may be NULL; it stays valid until the next query.
 * dev NULL: this thread's last failure (any call), cleared the same way. */
CSI_API csi_status csi_device_error(csi_device *dev, const char **message);
/* Every platform / device pair, one line each ("platform / device (type)"), into buf. */
CSI_API csi_status csi_device_list(char *buf, size_t len);
/* Builds every OpenCL program of csi's on dev and keeps its binary on disk, in
 * $CSI_CACHE_DIR/programs (else $XDG_CACHE_HOME/csi/programs, else ~/.cache/csi/programs), so
 * that later processes load the programs instead of building them: a process's fixed cost then
 * drops by most of its program time (the run statistics' programs_s). Run it once after
 * installing or rebuilding csi or updating the OpenCL driver (a binary is only used for the
 * same kernels, build options and driver); it takes a while (PoCL compiles every kernel of a
 * program for its binary) and is quick when everything is cached already. *stored (may be
 * NULL): how many programs it stored now. CSI_ERR_IO when the cache is off
 * (CSI_PROGRAM_CACHE=0) or cannot be written. */
CSI_API csi_status csi_device_cache_programs(csi_device *dev, int *stored);
/* The folder csi_device_cache_programs writes to and every device loads from, into buf; CSI_ERR_IO
 * with the reason when the cache is off. */
CSI_API csi_status csi_cached_programs_dir(char *buf, size_t len);

/* ---- the grid and the sample positions ----------------------------------------------------- */
/* Samples lie on the fine grid of the signal (the paper's Sec. 4): a position is the index
 * (x, y, t) of a grid cell, x < w, y < h, t < t (t = 0 when the grid has no time axis). The
 * point a sample stands for is the cell's centre: ((x + 0.5) / w, (y + 0.5) / h) in image space
 * (y down) and time (t + 0.5) / t of the shutter interval (its opening when t = 1). */
typedef struct csi_sample_pos {
    uint32_t x, y, t;
} csi_sample_pos;

typedef struct csi_grid {
    uint32_t w, h, t;      /* fine grid: the paper's k = w * h * t cells */
    uint32_t out_w, out_h; /* final image; w % out_w == 0 and h % out_h == 0 */
} csi_grid;

/* The largest grid: a side of at most 65536 cells (dumps, scenes, requests), and at most 1024
 * frames across the shutter (dumps, scenes' `frames`, every program's --time-steps). The plan's
 * rule gives 8 to 64 frames (about one pixel of motion per frame); 1024 leaves 16x that for
 * overrides. Beyond it the time axis holds far fewer samples than frames per pixel (4 spp over
 * 1024 frames is one sample in 256 frames) and the motion solve's time-axis transforms dominate
 * its cost. */
#define CSI_GRID_MAX_SIDE 65536u
#define CSI_GRID_MAX_FRAMES 1024u

/* Linear index of a position in a row-major (t, y, x) volume. */
static inline uint64_t csi_grid_index(const csi_grid *g, csi_sample_pos p)
{
    return ((uint64_t)p.t * g->h + p.y) * g->w + p.x;
}

typedef enum csi_pos_method {
    CSI_POS_POISSON = 0, /* Poisson-disk dart throwing on the grid (the compressive default) */
    CSI_POS_STRATIFIED,  /* one cell per stratum of each pixel's block (Monte Carlo) */
    CSI_POS_RANDOM,      /* N distinct cells, every N-subset equally likely */
} csi_pos_method;

typedef struct csi_pos_opts {
    csi_pos_method method;
    uint32_t spp;    /* samples per output pixel over the pixel's whole block (all t); used
                        when fraction == 0 */
    double fraction; /* > 0: N = round(fraction * k), the paper's sampling rate */
    uint64_t seed;
} csi_pos_opts;

typedef struct csi_pos_info {
    size_t count;        /* N */
    double radius;       /* POISSON: minimum distance between any two samples, in cells */
    double radius_max;   /* POISSON: spacing of the densest packing of N points (comparison) */
    uint32_t strata[3];  /* STRATIFIED: strata along x, y, t; {0,0,0} for the 1-D split */
} csi_pos_info;

/* "poisson", "stratified", "random", and back (CSI_ERR_ARG naming the choices). */
CSI_API const char *csi_pos_method_name(csi_pos_method m);
CSI_API csi_status csi_pos_method_parse(const char *s, csi_pos_method *m);
/* N for a grid and options (CSI_ERR_ARG with a message when either is unusable). */
CSI_API csi_status csi_positions_count(const csi_grid *g, const csi_pos_opts *o, size_t *n);
/* The default fine-grid factor F (grid = F out_w x F out_h cells, t frames) for `spp` samples
 * per output pixel, the rule csi-render and csi-positions use. Moving (t > 1): from one sample
 * per 8 frames (8 spp >= t) 2, 3 from 9 spp and 4 from 16, so that a pixel's samples see more of
 * it than its centre; else 1 (the time axis already gives each pixel t cells); reduced while a
 * side would exceed 65536 cells
 * (csi_camera_grid_factor for a camera that moves). Static: the
 * smallest power of two F >= 4 with F^2 > 4 spp (more than 4 cells per sample), at most 16:
 * F = 4 up to 3 spp, 8 for 4-15, 16 from 16; halved (not below 4) while a side would exceed
 * 65536 cells. Why: the compressive estimate
 * converges to the mean over the cell centres, a discretisation bias that a fixed 4x grid makes
 * dominant once most cells are sampled (paper Sec. 4, 5.2, Fig. 7: a larger k); the sweep
 * behind the rule is in the source tree's docs/bench/grid.md. */
CSI_API uint32_t csi_default_grid_factor(uint32_t out_w, uint32_t out_h, uint32_t t, uint64_t spp);
/* How a volume's camera moves over the shutter, for csi_camera_grid_factor: held still (or not
 * known), translating across its view alone (no turn, zoom or dolly), or otherwise. */
typedef enum csi_camera_motion { CSI_CAMERA_STILL = 0, CSI_CAMERA_PANS = 1, CSI_CAMERA_MOVES = 2 } csi_camera_motion;
/* csi_default_grid_factor for a renderer that knows its camera (csi-render's plan, csi-mitsuba's
 * poses): on a volume (t > 1) a moving camera keeps 1, where the finer grid's unknowns cost
 * more than the detail it gains (the camera's blur removes that detail, and parts the basis's one
 * shear does not follow multiply them), except a panning one, which takes
 * csi_default_grid_factor's as a still one does (its motion blurs nothing across itself);
 * CSI_CAMERA_STILL and CSI_CAMERA_PANS are csi_default_grid_factor. docs/bench/animation.md,
 * sessions 42-44 and 47. */
CSI_API uint32_t csi_camera_grid_factor(uint32_t out_w, uint32_t out_h, uint32_t t, uint64_t spp,
                                        csi_camera_motion camera);
/* Makes the positions: *out (release with csi_free) holds *n unique positions sorted by
 * csi_grid_index, the same bits for the same inputs. info may be NULL. The methods' details
 * are in csi/positions.h of the source tree. */
CSI_API csi_status csi_positions(const csi_grid *g, const csi_pos_opts *o, csi_sample_pos **out,
                                 size_t *n, csi_pos_info *info);
/* Progress of work counted in units (csi_positions_with_progress: positions placed), called from
 * the calling thread: `done` of `total` so far. Return true to go on, false to cancel. */
typedef bool (*csi_count_progress_fn)(void *user, uint64_t done, uint64_t total);
/* csi_positions, reporting its progress (the Poisson-disk method, the slow one at millions of
 * positions, as it goes; the others once, at the end). progress may be NULL; when it
 * returns false the call returns CSI_ERR_CANCELLED, having released what it made. */
CSI_API csi_status csi_positions_with_progress(const csi_grid *g, const csi_pos_opts *o, csi_sample_pos **out,
                                               size_t *n, csi_pos_info *info, csi_count_progress_fn progress,
                                               void *user);
/* The host bytes csi_positions holds at most while it makes them (its result included), to
 * check a run against the host's memory (csi_host_available_bytes) before making them. */
CSI_API csi_status csi_positions_host_bytes(const csi_grid *g, const csi_pos_opts *o, uint64_t *bytes);

/* ---- what the samples are ------------------------------------------------------------------ */
/* Flags of a set of samples (csi_samples.flags, csi_dump.flags, a dump's header at byte 48).
 * CSI_SAMPLES_EXACT: every value is the noise-free signal at its cell's centre (a deterministic
 * point evaluation, as a ray tracer without random effects returns), not a Monte Carlo
 * estimate; the option "correct" = auto then takes the control-variate correction, which is the
 * better one on such samples (the source tree's docs/bench/mitsuba.md), and the blend otherwise.
 * 0: unknown, or noisy. Every other bit is reserved and must be zero (refused otherwise). */
#define CSI_SAMPLES_EXACT 1u
#define CSI_SAMPLES_KNOWN_FLAGS CSI_SAMPLES_EXACT

/* ---- sample dumps (docs/dump-format.md) ---------------------------------------------------- */
/* A dump in memory: one record per sample, a position and `channels` float32 values. */
typedef struct csi_dump {
    csi_grid grid;
    uint32_t channels;     /* 1..4 */
    uint64_t seed;         /* the producer's seed, 0 if none */
    size_t count;          /* number of samples */
    csi_sample_pos *pos;   /* count positions */
    float *values;         /* count x channels, sample-major: values[i * channels + c] */
    uint32_t flags;        /* CSI_SAMPLES_* (the header's byte 48); 0 for a positions request */
} csi_dump;

typedef struct csi_dump_read_opts {
    bool drop_invalid;  /* drop records holding NaN/Inf (counted) instead of refusing the file */
    uint64_t max_cells; /* refuse grids with w*h*t above this; 0: 2^31 */
} csi_dump_read_opts;

typedef struct csi_dump_report {
    uint64_t records;         /* records in the file */
    uint64_t dropped_invalid; /* records dropped for NaN/Inf values (only with drop_invalid) */
    uint64_t duplicates;      /* records merged into another at the same position (averaged) */
    uint64_t first_invalid;   /* record number of the first dropped record (if any) */
} csi_dump_report;

/* Reads and validates a dump; every problem is CSI_ERR_FORMAT (CSI_ERR_IO when the file cannot
 * be read) with a message naming the file and the byte or record. Records at one position are
 * averaged; the result is sorted by csi_grid_index and unique, ready for csi_reconstruct.
 * opts and report may be NULL. On failure *out is zeroed. */
CSI_API csi_status csi_dump_read(const char *path, const csi_dump_read_opts *opts, csi_dump *out,
                                 csi_dump_report *report);
/* A dump's header, validated against the file's size (everything csi_dump_read checks before the
 * records): what a program needs to plan a run (csi_reconstruct_check) before reading samples. */
typedef struct csi_dump_header {
    csi_grid grid;
    uint32_t channels;
    uint64_t count;       /* records in the file (before duplicates merge and NaN/Inf drop) */
    uint64_t seed;
    uint32_t flags;       /* CSI_SAMPLES_* */
} csi_dump_header;
CSI_API csi_status csi_dump_read_header(const char *path, const csi_dump_read_opts *opts, csi_dump_header *out);
/* The host bytes csi_dump_read holds at most while reading a dump with this header (the
 * records, and the sorted copy when they must be sorted); it refuses (CSI_ERR_TOO_LARGE) a dump
 * that needs more than the host has available (csi_host_available_bytes). */
CSI_API uint64_t csi_dump_read_host_bytes(const csi_dump_header *h);
/* Writes a dump (a temporary file, renamed when complete: a failure leaves nothing). channels =
 * 0 writes a positions request: positions only, for a renderer to evaluate. */
CSI_API csi_status csi_dump_write(const char *path, const csi_dump *d);
/* Allocates pos and values for `count` samples (zeroed); grid, channels and seed are the
 * caller's to set. */
CSI_API csi_status csi_dump_alloc(csi_dump *d, size_t count, uint32_t channels);
CSI_API void csi_dump_free(csi_dump *d);
/* Checks a grid and channel count as the reader does (CSI_ERR_FORMAT naming the field). */
CSI_API csi_status csi_dump_check_grid(const csi_grid *g, uint32_t channels, uint64_t max_cells);

/* ---- options ------------------------------------------------------------------------------- */
/* Reconstruction options by name: the same names as the programs' --name flags and the Python
 * keywords (with '_' for '-'). Each has a default: a fixed value, or "auto", which the library
 * resolves from the problem (the grid, the samples, the method) and reports back in the
 * result's options. Options that can be switched off take "off". The list, with each
 * option's help and default, comes from csi_option_count / csi_option_describe. */
typedef struct csi_options csi_options;

/* Every option at its default. */
CSI_API csi_status csi_options_new(csi_options **out);
CSI_API void csi_options_free(csi_options *o);
CSI_API csi_status csi_options_copy(const csi_options *src, csi_options **out);
/* Sets an option from text, as --name VALUE does: a choice by name, a number within the
 * option's range, "auto", "off", "on" (flags). CSI_ERR_ARG with "name: 'value' is not ..."
 * otherwise, and the option keeps its value. */
CSI_API csi_status csi_options_set(csi_options *o, const char *name, const char *value);
/* Sets a number (exactly: no decimal round trip). */
CSI_API csi_status csi_options_set_number(csi_options *o, const char *name, double value);
/* The value as text ("auto", "off", "sparsa", "0.3"), the form csi_options_set reads back. */
CSI_API csi_status csi_options_get(const csi_options *o, const char *name, char *buf, size_t len);
/* The value as a number; CSI_ERR_ARG for choices, flags, auto and off. */
CSI_API csi_status csi_options_get_number(const csi_options *o, const char *name, double *out);

typedef enum csi_option_kind {
    CSI_OPTION_CHOICE,  /* one of a list of names */
    CSI_OPTION_NUMBER,  /* a real number */
    CSI_OPTION_INTEGER, /* a whole number */
    CSI_OPTION_FLAG,    /* on or off; on the command line a flag without a value */
} csi_option_kind;

typedef struct csi_option_info {
    const char *name;      /* "sigma-scale" */
    csi_option_kind kind;
    const char *metavar;   /* the value's placeholder in help text ("S", "romp|sparsa") */
    const char *help;      /* one or more sentences, no trailing newline */
    const char *def;       /* the default as text ("0.3", "auto", "off") */
    const char *auto_rule; /* what "auto" resolves to; NULL when the default is fixed */
    bool program;          /* the programs take it as --name (false: they set it otherwise) */
} csi_option_info;

CSI_API size_t csi_option_count(void);
/* Option i < csi_option_count() (CSI_ERR_ARG otherwise). The strings are static. */
CSI_API csi_status csi_option_describe(size_t i, csi_option_info *out);

/* ---- reconstruction ------------------------------------------------------------------------ */
/* Samples in host arrays. Positions must be unique and inside the grid (csi_dump_read
 * guarantees both); values finite. The arrays are read during the call only. */
typedef struct csi_samples {
    csi_grid grid;              /* grid.t == 1: antialiasing (Alg. 1); > 1: motion (Alg. 2) */
    uint32_t channels;          /* 1..4 */
    size_t count;               /* N */
    const csi_sample_pos *pos;  /* N positions */
    const float *values;        /* N x channels, sample-major: values[i * channels + c] */
    uint32_t flags;             /* CSI_SAMPLES_* (0: unknown or noisy); after the arrays, so
                                   that an initialiser without it means 0 */
    const float *variance;      /* NULL (unknown), or N x channels like values: each value's
                                   variance as an estimate of the signal at its cell's centre
                                   (a renderer's paths' sample variance / paths), >= 0. In an
                                   image, an isolated bright sample its own noise explains is
                                   then taken as noise (csi/peak_noise.h in the source tree);
                                   in a volume, the solve's tau is at least a multiple of the
                                   samples' noise (CSI_MOTION_TAU_NOISE, csi/reconstruct.h in
                                   the source tree) and its frames are denoised by it
                                   (option frames-denoise, csi/frames_denoise.h there), its
                                   blurred image averaged with those frames' mean (option
                                   image-frames);
                                   in a whole problem and in every tile alike (with
                                   csi_reconstruct_tile_window, the noise of the window's
                                   samples). Last, so that an initialiser without it means
                                   NULL */
} csi_samples;

/* What the reconstruction is doing, for a progress display. */
typedef struct csi_progress {
    const char *phase;   /* "setup", for a moving volume "velocity search", then for channel c
                            of C "solve c/C", "integrate c/C" and "correct c/C" (tiled: "tile i/N
                            solve c/C" ..., then "tile i/N blend") */
    int iteration;       /* the solver's steps in this channel so far (the velocity search: its
                            steps; "correct c/C" on a still image: the passes over the image
                            done); 0 elsewhere */
    double residual;     /* relative residual ||y - A x|| / ||y||; < 0 when not known */
} csi_progress;
/* Called from the calling thread at each phase and after every solver iteration. Return true
 * to go on, false to cancel: csi_reconstruct then returns CSI_ERR_CANCELLED soon after, having
 * released everything it made. */
typedef bool (*csi_progress_fn)(void *user, const csi_progress *p);

typedef struct csi_result csi_result;

/* Reconstructs the samples: the image (and with the option "frames" on and grid.t > 1, every
 * frame of the volume). options NULL: every default. progress may be NULL. */
CSI_API csi_status csi_reconstruct(csi_device *dev, const csi_samples *samples,
                                   const csi_options *options, csi_progress_fn progress,
                                   void *user, csi_result **out);
CSI_API void csi_result_free(csi_result *r);

/* Sizes before work: CSI_OK when reconstructing n samples on grid g (channels, options; NULL:
 * the defaults) fits dev's limits (per buffer and in all) and the host's available memory, with
 * extra_host more bytes that the caller holds meanwhile (its samples, the dump reader, a
 * tracer); else CSI_ERR_TOO_LARGE (CSI_ERR_ARG for a grid no plan can hold) with one line that
 * starts with `input` (a file name, for the message) and names the grid, what is needed and the
 * limit. Arithmetic on the sizes only: nothing is allocated, so a program can refuse an input in
 * milliseconds before reading or tracing its samples. */
CSI_API csi_status csi_reconstruct_check(csi_device *dev, const csi_grid *g, uint32_t channels, size_t n,
                                         const csi_options *options, uint64_t extra_host, const char *input);

/* Images are float32, channels planar: data[(c * h + y) * w + x], linear light. Channel meaning
 * by count: 1 = Y, 2 = Y A, 3 = R G B, 4 = R G B A. */
typedef struct csi_image {
    uint32_t w, h, channels;
    float *data;
} csi_image;

/* The image, as a view into the result (valid until csi_result_free; do not free it). */
CSI_API csi_status csi_result_image(const csi_result *r, csi_image *view);
/* Frames returned (0 unless "frames" was on and grid.t > 1), and frame t as a view. */
CSI_API uint32_t csi_result_frame_count(const csi_result *r);
CSI_API csi_status csi_result_frame(const csi_result *r, uint32_t t, csi_image *view);
/* The options as used: every auto that applies resolved to its value (owned by r). */
CSI_API const csi_options *csi_result_options(const csi_result *r);

typedef struct csi_result_info {
    const char *method;  /* "compressive antialias (Alg. 1)", "compressive motion (Alg. 2)",
                            "Gaussian normalized convolution", "sample mean (Monte Carlo)" */
    const char *solver;  /* "sparsa", "romp"; "auto" for the baselines (no solver) */
    size_t k, n;         /* unknowns and samples per channel */
    double t_setup, t_solve, t_integrate; /* seconds */
    uint32_t tiles;      /* tiles it was solved in (1: the whole at once; see "tiles" below) */
    bool tile;           /* the result of csi_reconstruct_tile: one tile's window, not the image */
    uint32_t tile_index; /* then: which tile, and where its window starts (pixels x, y; frame) */
    uint32_t tile_origin[3];
} csi_result_info;
CSI_API void csi_result_info_get(const csi_result *r, csi_result_info *out);

/* How the solve of one channel ended. */
typedef enum csi_outcome {
    CSI_OUTCOME_CONVERGED = 0,     /* the stopping rule was met */
    CSI_OUTCOME_ZERO,              /* x = 0 is the exact answer */
    CSI_OUTCOME_MAX_ITER,          /* the iteration cap came first */
    CSI_OUTCOME_SUPPORT_LIMIT,     /* ROMP: the support limit came first (published preset) */
    CSI_OUTCOME_NOT_IDENTIFIABLE,  /* the fit has more than N/2 non-zeros: not unique */
    CSI_OUTCOME_STALLED,           /* no further progress was possible */
} csi_outcome;

typedef struct csi_channel_report {
    bool converged;      /* outcome CONVERGED or ZERO */
    csi_outcome outcome;
    const char *reason;  /* the outcome in words ("converged", "iteration cap reached", ...) */
    const char *message; /* one line with the numbers */
    int iterations, inner_iterations;
    double rel_residual; /* ||y - A x|| / ||y|| */
    double objective, tau;
    size_t support;      /* non-zero coefficients */
    double seconds;
} csi_channel_report;
/* The report of channel c (strings owned by r). */
CSI_API csi_status csi_result_report(const csi_result *r, uint32_t c, csi_channel_report *out);

/* ---- where to sample next ------------------------------------------------------------------ */
/* A second pass for a renderer: the grid cells to sample next so that the pixels the image
 * cannot decide are decided. A pixel is picked when (image - mean of its samples)^2, summed over
 * the channels, is at least `share` of that sum over the whole image (share 0 < s <= 1; the
 * default, csi_refine_share_default(), 0.005), and, for a share up to 0.02, when it lies beside
 * a bright pixel holding 0.02 or more (the same light: csi/settle.h), or when its mean's sampling
 * variance estimated from its samples' spread, (1 - n / N) s^2 / n summed over the channels (n of
 * its N cells sampled; a pixel of one sample takes s^2 from its 3 x 3 pixels' samples), is at
 * least `share` of that sum over the image (where the image is the pixel's mean, the two cannot
 * disagree however wrong both are); *out gets every cell of the picked pixels that holds no
 * sample (pixels in row order, each block's cells in row order), *count how many and *pixels (may
 * be NULL) the pixels picked. Evaluate them, append them to the samples and reconstruct again: a
 * pixel sampled in every cell is its samples' mean. Images only (grid.t == 1); image is the
 * reconstruction of these samples (csi_result_image). *out is freed with csi_free (NULL when
 * nothing is picked). Deterministic. Measured in docs/bench/mitsuba.md. */
CSI_API csi_status csi_refine_positions(const csi_samples *samples, const csi_image *image, double share,
                                        csi_sample_pos **out, size_t *count, size_t *pixels);
CSI_API double csi_refine_share_default(void);
/* The image after the second pass without a second reconstruction: every pixel that holds a
 * sample of `more` (the request, evaluated) takes the mean of all its samples in first and more
 * (in double: first's in order, then more's); a pixel sampled in every cell is exactly that mean
 * in a reconstruction too (the blend's finite-population factor), and the rest of the image stays
 * the first pass's fit. Same grid and channels in both; image is the first samples'
 * reconstruction, changed in place; *pixels (may be NULL) the pixels set. */
CSI_API csi_status csi_refine_apply(const csi_samples *first, const csi_samples *more, csi_image *image,
                                    size_t *pixels);
/* After the last pass, with each sample's variance given (first->variance: several paths per
 * sample): the pixels where the image and the mean of all their samples (first's in order, then
 * more's; more may be NULL) still disagree by a large share of their disagreement over the whole
 * image take that mean, by the rule csi_reconstruct settles a fixed dump with (csi/settle.h).
 * Once the passes have made the lights' pixels exact, what is left to decide the image is the
 * fit's error around them (the rings of a bulb beside the wall it lights) and dim lights among
 * bright ones, whose pixels held too small a share to be picked: on held-out scenes at 64 paths
 * the second pass was above the mean of the same samples in 13 of 100 cells, by up to 10%, and in
 * 2 with this step, by at most 0.2% (docs/bench/mitsuba.md, session 48). Without variances
 * nothing moves: with one path per sample those pixels' few samples are too noisy a mean (the
 * step cost 3% of MSE there). Same checks as csi_refine_apply; *pixels (may be NULL) the pixels
 * moved. */
CSI_API csi_status csi_refine_settle(const csi_samples *first, const csi_samples *more, csi_image *image,
                                     size_t *pixels);
/* After the settling, with each sample's variance given (first->variance, and more->variance
 * when more holds samples): a pixel across an HDR step moved to the coverage of the bright side its
 * window's samples allow (csi_reconstruct's last step on a fixed dump, csi/step_coverage.h), from
 * all the samples taken in csi's cell order (the passes merged into one dump give the same bits).
 * The first pass goes without it, so that the passes sample the pixels it would move; after them
 * it moves the rims they did not take: on the Cornell box at 16 spp x 64 paths 0.98x -> 0.43x the
 * mean of all the samples' MSE (docs/bench/mitsuba.md, session 50). Without variances nothing
 * moves. Same checks as csi_refine_apply, and each variance finite and not negative; *pixels (may
 * be NULL) the pixels moved. */
CSI_API csi_status csi_refine_step_coverage(const csi_samples *first, const csi_samples *more, csi_image *image,
                                            size_t *pixels);

/* ---- tiles (docs/tiles.md) ------------------------------------------------------------------
 * csi_reconstruct solves a problem that needs more device memory than the option "mem-budget" in
 * overlapping tiles by itself. The same tiles can be computed apart (other threads with their
 * own devices, other processes, other machines) and blended: csi_reconstruct_tile makes tile i
 * of the layout the options give ("tiles" = N asks for N), and csi_tiles_blend blends all N,
 * the same bits as csi_reconstruct tiling by itself, in whatever order they were made. */
typedef struct csi_tiling_info {
    uint32_t count;       /* tiles (1: the whole fits the budget) */
    uint32_t n[3];        /* tiles along x, y (pixels) and t (frames) */
    uint32_t window[3];   /* every tile's window: pixels, pixels, frames */
    uint64_t tile_bytes;  /* device bytes of one tile's reconstruction (the resource plan) */
    uint64_t whole_bytes; /* ... and of the whole untiled */
    uint64_t budget;      /* the budget the layout fits */
} csi_tiling_info;
/* The layout csi_reconstruct and csi_reconstruct_tile use for these samples and options. */
CSI_API csi_status csi_tiling_get(csi_device *dev, const csi_samples *samples, const csi_options *options,
                                  csi_tiling_info *out);
/* The whole problem's tau scale, per channel (scale[c] for c < channels), which every tile
 * follows: for Alg. 1 one operator setup and one adjoint per tile, so compute it once and give
 * it to every csi_reconstruct_tile of the same samples. */
CSI_API csi_status csi_tile_scale(csi_device *dev, const csi_samples *samples, const csi_options *options,
                                  double scale[4]);
/* Tile `index` of the layout: a result holding the tile's window (csi_result_info says where).
 * scale: from csi_tile_scale, or NULL to compute it here. */
CSI_API csi_status csi_reconstruct_tile(csi_device *dev, const csi_samples *samples,
                                        const csi_options *options, uint32_t index, const double *scale,
                                        csi_progress_fn progress, void *user, csi_result **out);
/* Blends the `count` tiles of one layout (each exactly once, in any order; from the same samples
 * and options) into the image. CSI_ERR_ARG naming the problem when one is missing, repeated or
 * from another layout or scale. */
CSI_API csi_status csi_tiles_blend(const csi_result *const *tiles, size_t count, csi_result **out);

typedef struct csi_json csi_json; /* the statistics' JSON builder (below) */
/* The layout as statistics (what a farm needs to know before it hands out tiles): "tiles",
 * "tiles_x", "tiles_y", "tiles_t", "window_x", "window_y", "window_t", "margin", "margin_t",
 * "band", "band_y", "band_t", the core boundaries along each axis as text ("cores_x": "0,64,96",
 * for tools that look at the seams), "tile_bytes", "whole_bytes" and "budget". Like
 * csi_tiling_get it reads the samples' grid, channels and count only (pos and values may be NULL),
 * as does csi_tile_window. */
CSI_API csi_status csi_tiling_stats(csi_device *dev, const csi_samples *samples, const csi_options *options,
                                    csi_json *j);
/* Where tile `index` lies on the fine grid: cells [lo[a], hi[a]) along x, y and t. A renderer
 * that traces one tile alone evaluates only the positions inside (csi_reconstruct_tile_window).
 * With the binned shutter's image ("tile-image-binned" on), the first time window of each x/y
 * column spans every frame: its image is solved from all of them. */
CSI_API csi_status csi_tile_window(csi_device *dev, const csi_samples *samples, const csi_options *options,
                                   uint32_t index, uint32_t lo[3], uint32_t hi[3]);
/* csi_reconstruct_tile for a caller that holds only the samples inside tile index's window
 * (csi_tile_window) of a problem of whole_count samples, such as a renderer that traced that
 * window alone: `samples` are those (positions on the whole grid), whole_count decides the layout
 * and the defaults as it would with every sample at hand. Without the whole's scale (NULL: it
 * needs every sample) the tile scales tau by its own samples, as an untiled run of its window
 * would; a volume's noise (samples->variance) is always its own samples'. */
CSI_API csi_status csi_reconstruct_tile_window(csi_device *dev, const csi_samples *samples, size_t whole_count,
                                               const csi_options *options, uint32_t index, const double *scale,
                                               csi_progress_fn progress, void *user, csi_result **out);

/* ---- tiles as separate jobs: partials (docs/partial-format.md) -------------------------------
 * A tile made on one machine is written as a partial (a versioned file with a checksum that
 * holds the tile's pixels and what decided them); a merge reads the partials of one run, from
 * wherever they were made, checks that they are one complete run and blends them: the same bits
 * as csi_reconstruct tiling by itself.
 *
 * Identity: two partials belong to the same run when they were written by the same library
 * version, from the same input (input_id), with the same options (the tile options aside: the
 * layout is compared instead), the same layout and the same whole-problem scale. input_id is the
 * caller's: csi_samples_id for samples at hand, or a hash of whatever decides the samples (a
 * renderer: its scene and sampling, with csi_hash64). */
typedef struct csi_partial_info {
    char software[32];    /* "csi 0.1.0": the library that wrote it */
    char method[96];      /* the method text for the image's csi:method */
    char input[128];      /* the input's file name (no directory), for messages */
    uint64_t input_id;
    uint32_t tile_index, tile_count;
    csi_grid grid;        /* the image's (its tiles may lie on a grid padded for the FFT) */
    uint32_t channels;
    uint32_t frames;      /* frames of the tile's window it holds (0: the image only) */
    uint64_t samples;     /* the whole problem's */
} csi_partial_info;

/* A 64-bit content hash, chained: h = csi_hash64(h, data, bytes) from any starting value; the
 * bytes are read as little-endian 64-bit words, so the same bytes hash the same everywhere. */
CSI_API uint64_t csi_hash64(uint64_t h, const void *data, size_t bytes);
/* The identity of samples: csi_hash64 of the grid, channels, positions and values (and the flags
 * when any is set, and the variances when given). */
CSI_API uint64_t csi_samples_id(const csi_samples *samples);

/* Writes a tile's result (csi_reconstruct_tile or csi_reconstruct_tile_window) as a partial, to
 * a temporary file renamed when complete. input: a name for messages (its directory is dropped);
 * method: the text for the merged image's csi:method (NULL: the result's method). Frames are
 * kept when the tile has them (the option "frames"). */
CSI_API csi_status csi_partial_write(const char *path, const csi_result *tile, const char *input,
                                     uint64_t input_id, const char *method);
/* Reads a partial's description after checking the whole file: CSI_ERR_FORMAT (CSI_ERR_IO when
 * it cannot be read) with one line naming the file for anything but a partial of this format
 * version: another file, another version, a truncated or damaged file (checksum). */
CSI_API csi_status csi_partial_read_info(const char *path, csi_partial_info *out);
/* Reads a partial as the tile's result (for csi_tiles_blend, or to look at it); info may be
 * NULL. Stats and attributes of the result are those of the tile as it was written. */
CSI_API csi_status csi_partial_read(const char *path, csi_result **out, csi_partial_info *info);
/* Merges the partials of one run, given in any order (paths[0 .. count-1]), into the image:
 * first every partial's description (csi_partial_read_info), then the blend in tile order,
 * reading one partial at a time. Refused with one line naming the file (CSI_ERR_FORMAT for a file
 * that is not a partial of this version, CSI_ERR_ARG otherwise), before any blending: a partial of
 * another run (what differs: the input, the options, the layout ...), a tile given twice, a tile
 * missing. frames: the result holds the frames (every partial must hold them). progress (may be
 * NULL) is called after each tile with phase "merge" and iteration = tiles blended; false
 * cancels (CSI_ERR_CANCELLED). info (may be NULL): the run's description, from paths[0]. The
 * result's options are the options the tiles were given (the solver as the tiles resolved it). */
CSI_API csi_status csi_partials_merge(const char *const *paths, size_t count, bool frames,
                                      csi_progress_fn progress, void *user, csi_result **out,
                                      csi_partial_info *info);

/* ---- images -------------------------------------------------------------------------------- */
CSI_API csi_status csi_image_alloc(csi_image *img, uint32_t w, uint32_t h, uint32_t channels);
CSI_API void csi_image_free(csi_image *img);
/* Reads a PNG (sRGB decoded to linear) or a scanline EXR, chosen by the file's magic bytes. */
CSI_API csi_status csi_image_read(const char *path, csi_image *out);

/* Header attributes for EXR files. */
typedef enum csi_attr_type { CSI_ATTR_STRING, CSI_ATTR_FLOAT, CSI_ATTR_DOUBLE, CSI_ATTR_INT } csi_attr_type;
typedef struct csi_attr {
    const char *name;
    csi_attr_type type;
    const char *s; /* CSI_ATTR_STRING */
    double f;      /* CSI_ATTR_FLOAT (stored as float32) and CSI_ATTR_DOUBLE */
    int64_t i;     /* CSI_ATTR_INT (must fit int32: EXR's int attribute) */
} csi_attr;
#define CSI_ATTR_S(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_STRING, .s = (v)})
#define CSI_ATTR_F(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_FLOAT, .f = (v)})
#define CSI_ATTR_D(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_DOUBLE, .f = (v)})
#define CSI_ATTR_I(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_INT, .i = (v)})

/* The result's figures and every option as used, as EXR attributes ("csi:solver",
 * "csi:option:lambda", ...); owned by r. */
CSI_API size_t csi_result_attributes(const csi_result *r, const csi_attr **attrs);

/* A float32 scanline EXR (ZIP, lossless) with the attributes in its header; an 8-bit sRGB PNG
 * (values clamped to [0, 1]). Both written to a temporary file and renamed when complete. */
CSI_API csi_status csi_exr_write(const char *path, const csi_image *img, const csi_attr *attrs,
                                 size_t nattrs);
/* csi_exr_write, reporting the scanlines written (of img->h) after each compressed chunk: a
 * large image's compression takes seconds. progress may be NULL; when it returns false the
 * call returns CSI_ERR_CANCELLED and leaves no file. */
CSI_API csi_status csi_exr_write_with_progress(const char *path, const csi_image *img, const csi_attr *attrs,
                                               size_t nattrs, csi_count_progress_fn progress, void *user);
CSI_API csi_status csi_png_write(const char *path, const csi_image *img);

/* ---- statistics (JSON) --------------------------------------------------------------------- */
/* An ordered JSON object builder: keys in the order added, nested objects with begin / end.
 * Misuse is remembered and reported by csi_json_text / csi_json_write (CSI_ERR_ARG). */
typedef struct csi_json csi_json;
CSI_API csi_status csi_json_new(csi_json **out);
CSI_API void csi_json_free(csi_json *j);
CSI_API void csi_json_str(csi_json *j, const char *key, const char *value); /* NULL -> null */
CSI_API void csi_json_num(csi_json *j, const char *key, double value);      /* NaN/Inf -> null */
CSI_API void csi_json_int(csi_json *j, const char *key, int64_t value);
CSI_API void csi_json_bool(csi_json *j, const char *key, bool value);
CSI_API void csi_json_begin(csi_json *j, const char *key);
CSI_API void csi_json_end(csi_json *j);
/* The document (valid until the next call on j); writing it to a file (temporary + rename). */
CSI_API csi_status csi_json_text(csi_json *j, const char **text);
CSI_API csi_status csi_json_write(csi_json *j, const char *path);
/* Adds the result's statistics to j: a hash of the image's bits ("image_fnv1a64"), the solver,
 * k, n, the solver's unknowns and model grid, times, every option as used ("options") and each
 * channel's report ("channels"). */
CSI_API void csi_result_stats(const csi_result *r, csi_json *j);
/* Adds where the run's time went to j: "phases" {read_s, device_s, programs_s, setup_s, solve_s:
 * {channel: s}, integrate_s: {channel: s}, write_s} (programs_s, building the kernels, is part of
 * setup_s: a cost of the first run on a machine or of a cold cache); "fixed_s" = read + device +
 * setup, what a run costs before its first solver step; "per_sample_us" = (solve + integrate) /
 * samples; "cpu_setup_s", "cpu_work_s" and "cpu_per_sample_us", the same in process CPU time (all
 * threads). read_s, device_s and write_s are the caller's own phases (reading its input, making
 * the device, writing its outputs), in seconds. */
CSI_API void csi_result_stats_phases(const csi_result *r, csi_json *j, double read_s, double device_s,
                                     double write_s);

/* ---- outputs written all or nothing ---------------------------------------------------------
 * A run that writes several files (an EXR, a PNG preview, statistics, a dump, a folder of frames)
 * states them all before any work: each is checked then (its directory exists and is writable;
 * it is not one of the run's inputs, nor another of its outputs), so that a run that cannot
 * write its outputs fails in milliseconds. After the work each output is written to a temporary
 * name beside it (by any writer: csi_exr_write, csi_json_write, the caller's own), and
 * csi_outset_commit renames them all into place only when every one was written; on any
 * failure, csi_outset_abort (or a failed commit) leaves nothing new: no temporary file, no new
 * file, no folder the run created, and every file the run would have replaced as it was.
 *
 * Identity: two paths are the same file when they name the same device and inode (hard links
 * and symbolic links included), or, for a file that does not exist yet, when their directories
 * resolve to the same directory (realpath) and their names are equal.
 *
 * Commit: destinations that exist are first kept as hard links (backups) beside them, then every
 * temporary file is renamed over its destination (rename(2) is atomic within a directory); if a
 * rename fails, those done are undone (new files removed, backups renamed back), so the set
 * appears whole or not at all except for a crash during the renames themselves.
 *
 * Testing: when the environment variable CSI_FAIL_OUTPUT is a number N > 0, the Nth output event
 * of the process fails as a write error would (an event: one file's data completed by one of the
 * library's writers, or one rename of a commit), so that tests can check that a failure after
 * each file leaves nothing behind. */
typedef struct csi_outset csi_outset;

CSI_API csi_status csi_outset_create(csi_outset **out);
/* Aborts whatever was not committed, then frees. NULL is fine. */
CSI_API void csi_outset_free(csi_outset *s);

/* An input of the run (it must exist): no output may resolve to it, whether stated before or after
 * it (CSI_ERR_ARG naming both). */
CSI_API csi_status csi_outset_input(csi_outset *s, const char *path);

/* An output file. `what` names it in messages ("the image", "--png"). Refused (CSI_ERR_IO, one
 * line naming the path): an empty path or one ending in '/', a directory, a missing or
 * unwritable directory, an input of the run, an output already stated. */
CSI_API csi_status csi_outset_file(csi_outset *s, const char *path, const char *what);

/* An output folder (frames): refused if it exists and is not a writable directory, or if its
 * parent is missing or unwritable. When it does not exist, the run creates it as a temporary
 * folder beside it, renamed into place by the commit. Its files are stated with
 * csi_outset_dir_file(s, dir, "frame_0000.exr", ...). */
CSI_API csi_status csi_outset_dir(csi_outset *s, const char *dir, const char *what);
CSI_API csi_status csi_outset_dir_file(csi_outset *s, const char *dir, const char *name, const char *what);

/* The temporary path to write a stated output to (a file in the destination's directory, or
 * in the temporary folder), made on the first call; `path` as stated (for a folder's file,
 * "dir/name"). Any writer may write it, including by its own temporary file and rename. */
CSI_API csi_status csi_outset_tmp(csi_outset *s, const char *path, const char **tmp);

/* Renames every output into place (see above). Outputs stated but never given a temporary path
 * are left out (nothing was written for them). Afterwards the set is empty. */
CSI_API csi_status csi_outset_commit(csi_outset *s);

/* For a program's SIGINT/SIGTERM/SIGHUP handler: removes the set's temporary files and folders
 * and the file a library writer is writing with unlink and rmdir only (async-signal-safe), so an
 * interrupted run leaves nothing either; the handler then ends the program. */
CSI_API void csi_outset_signal_cleanup(const csi_outset *s);

/* Removes every temporary file and folder of the set; the set is then empty. */
CSI_API void csi_outset_abort(csi_outset *s);

#ifdef __cplusplus
}
#endif
#endif
