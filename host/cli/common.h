/* Shared by the command-line programs: option parsing helpers, the progress bar, exit codes.
 *
 * The program-support library (host/cli/common*.c) sits beside libcsi as OIDN's apps/utils sit
 * beside OIDN: it uses csi/csi.h only, and its headers are not installed with the SDK. */
#ifndef CSI_CLI_COMMON_H
#define CSI_CLI_COMMON_H

#include <stdbool.h>
#include <stdint.h>

#include "csi/csi.h"

/* Exit codes: 0 success, 2 bad input or usage (the user can fix it), 1 anything else. */
enum { CLI_EXIT_OK = 0, CLI_EXIT_FAIL = 1, CLI_EXIT_USAGE = 2 };

/* Kernels built at run time (the first run, or a new FFT size: clFFT's generated kernels) must
 * not print the OpenCL compiler's warnings on the user's stderr ("-q" promises nothing there):
 * asks PoCL to build every program with -w (POCL_EXTRA_BUILD_FLAGS, unless the user set it).
 * Called first in main, before any thread or device. */
void cli_quiet_kernel_builds(void);
/* The compressive method's positions for spp samples per pixel on t frames, the rule csi-render
 * and csi-positions share: Poisson-disk, except on a volume (t > 1) from 2 spp, where each pixel's
 * samples are stratified over its shutter. At 1 spp a pixel's one sample has nothing to be
 * stratified against, and the disk's spread over x, y and t serves the fit better; from 2 spp a
 * pixel's samples see its whole shutter evenly: a still pixel's agree (the reconstruction's still
 * pixels), a moving one's mean is stratified Monte Carlo's, and the fit's image was measured
 * better than on the disk's positions (docs/bench/animation.md, session 40). */
csi_pos_method cli_default_positions(uint32_t t, uint64_t spp);
/* Prints "prog: error: message" on one line and returns the exit code for st. */
int cli_error(const char *prog, csi_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/* Prints "prog: warning: message" on one line (control characters escaped). */
void cli_warn(const char *prog, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Exit code for a library failure: input problems -> 2, the rest -> 1. */
int cli_exit_code(csi_status st);

/* --cache-programs (csi-reconstruct, csi-render): csi_device_cache_programs on `device`, said on
 * stderr unless quiet; refused before any work when the cache is off. The exit code. */
int cli_cache_programs(const char *prog, const char *device, bool quiet);

/* Failures of the program-support code, which records its messages here (the library keeps its
 * own): cli_fail records a printf-style message, forgets the library's last one and returns st;
 * cli_last_error gives the message of the most recent failure on this thread, the library's
 * (csi_last_error) when one came after the last cli_fail, else cli_fail's. So a caller prints
 * cli_last_error() after a failed call of either. */
csi_status cli_fail(csi_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
const char *cli_last_error(void);

/* The run's set of outputs (csi_outset), whose temporary files a SIGINT, SIGTERM or SIGHUP
 * removes before the program ends; cli_outset_free aborts what was not committed. */
csi_status cli_outset_new(csi_outset **set);
void cli_outset_free(csi_outset *set);
/* Outputs of a set (csi_outset) written by one of the library's writers: s, with a message that
 * named the temporary file tmp made to name the output `path` (cli_fail). */
csi_status cli_named(csi_status s, const char *tmp, const char *path);
/* A dump, and statistics, written to the temporary file of `path` in set. */
csi_status cli_write_dump(csi_outset *set, const char *path, const csi_dump *d);
csi_status cli_write_stats(csi_outset *set, const char *path, csi_json *j);

/* The grid as statistics: grid_w, grid_h, grid_t, out_w, out_h. */
void cli_json_grid(csi_json *j, const csi_grid *g);

/* Makes the process keep the memory it frees for its next allocations (glibc; elsewhere
 * nothing): called first by the programs that reconstruct, which allocate the same large arrays
 * once per tile and channel. */
void cli_heap_keep_freed(void);

/* Strict number parsing: the whole string must be a number in [lo, hi]. */
bool cli_parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out);
bool cli_parse_double(const char *s, double lo, double hi, double *out);
/* "WxH" -> w, h (both >= 1). */
bool cli_parse_size(const char *s, uint32_t *w, uint32_t *h);

/* Progress on stderr (none when quiet). On a terminal: one line redrawn at most ~10 times a
 * second and cleared by cli_progress_end. Elsewhere (a log file, a farm's or a batch job's
 * output): plain lines "prog: progress: phase ... [elapsed]", at most one every CLI_PROGRESS_EVERY
 * seconds and the first only after as long, so that a short run, and a refusal, print nothing
 * but their own lines. The environment variable CSI_PROGRESS chooses instead: "off", "bar" (the
 * redrawn line wherever stderr goes), or a number of seconds between plain lines (0: a line for
 * every report, for tests and debugging). */
#define CLI_PROGRESS_EVERY 60.0
typedef enum { CLI_PROGRESS_OFF, CLI_PROGRESS_BAR, CLI_PROGRESS_LINES } cli_progress_mode;
typedef struct cli_progress {
    cli_progress_mode mode;
    double every; /* CLI_PROGRESS_LINES: seconds between lines */
    double start, last;
    char phase[48];
    const char *prog;
} cli_progress;
/* false when CSI_PROGRESS holds something else than the above (the message: cli_last_error). */
bool cli_progress_init(cli_progress *p, const char *prog, bool quiet);
/* fraction < 0: unknown (spinner-free text only). detail: free text such as "iter 12 res 3e-3". */
void cli_progress_update(cli_progress *p, const char *phase, double fraction, const char *detail);
void cli_progress_end(cli_progress *p);
double cli_now(void); /* seconds, monotonic */

/* A reconstruction's progress (common_eta.c): the library's phases ("setup", "solve c/C",
 * "integrate c/C", each after "tile t/T " in a tiled run) with the solver's step, and the time
 * left once a channel's solve is done. */
typedef struct {
    cli_progress *bar;
    unsigned unit, units, done; /* current channel solve (1-based over every tile, 0 before the first) */
    double t_first, t_current;  /* when the first and the current one began */
} cli_recon_progress;
void cli_recon_progress_init(cli_recon_progress *p, cli_progress *bar);
/* A csi_progress_fn's arguments. */
void cli_recon_progress_update(cli_recon_progress *p, const char *phase, int iter, double res);
/* Seconds left, or < 0 while no channel is done. */
double cli_recon_progress_eta(const cli_recon_progress *p, double now);
/* A csi_progress_fn whose user is a cli_recon_progress (or NULL: nothing shown). */
bool cli_recon_progress_fn(void *user, const csi_progress *p);

#endif
