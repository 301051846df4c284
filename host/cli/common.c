#include "common.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

void cli_quiet_kernel_builds(void)
{
    setenv("POCL_EXTRA_BUILD_FLAGS", "-w", 0);
}

csi_pos_method cli_default_positions(uint32_t t, uint64_t spp)
{
    return t > 1 && spp >= 2 ? CSI_POS_STRATIFIED : CSI_POS_POISSON;
}

int cli_exit_code(csi_status st)
{
    switch (st) {
    case CSI_OK: return CLI_EXIT_OK;
    case CSI_ERR_ARG:
    case CSI_ERR_IO:
    case CSI_ERR_FORMAT:
    case CSI_ERR_SCENE:
    case CSI_ERR_DEVICE:
    case CSI_ERR_TOO_LARGE:
        return CLI_EXIT_USAGE;
    default:
        return CLI_EXIT_FAIL;
    }
}

static _Thread_local char cli_msg[2048];

csi_status cli_fail(csi_status st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cli_msg, sizeof cli_msg, fmt, ap);
    va_end(ap);
    csi_device_error(NULL, NULL); /* a later library failure is then the newer one */
    return st;
}

const char *cli_last_error(void)
{
    const char *lib = csi_last_error();
    return lib[0] ? lib : cli_msg;
}

int cli_error(const char *prog, csi_status st, const char *fmt, ...)
{
    char msg[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    /* One line, and nothing an input put in it reaches the terminal raw. */
    char safe[sizeof msg];
    csi_escape_controls(msg, safe, sizeof safe);
    fprintf(stderr, "%s: error: %s\n", prog, safe);
    return st == CSI_OK ? CLI_EXIT_USAGE : cli_exit_code(st);
}

void cli_warn(const char *prog, const char *fmt, ...)
{
    char msg[4096], safe[4096];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    csi_escape_controls(msg, safe, sizeof safe);
    fprintf(stderr, "%s: warning: %s\n", prog, safe);
}

bool cli_parse_u64(const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    if (!s || !*s || *s == '-' || *s == '+')
        return false;
    errno = 0;
    char *end;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end || v < lo || v > hi)
        return false;
    *out = v;
    return true;
}

bool cli_parse_double(const char *s, double lo, double hi, double *out)
{
    if (!s || !*s)
        return false;
    errno = 0;
    char *end;
    double v = strtod(s, &end);
    if (errno || *end || !isfinite(v) || v < lo || v > hi)
        return false;
    *out = v;
    return true;
}

bool cli_parse_size(const char *s, uint32_t *w, uint32_t *h)
{
    if (!s)
        return false;
    const char *x = strchr(s, 'x');
    if (!x)
        return false;
    char a[32];
    size_t n = (size_t)(x - s);
    if (n == 0 || n >= sizeof a)
        return false;
    memcpy(a, s, n);
    a[n] = '\0';
    uint64_t vw, vh;
    if (!cli_parse_u64(a, 1, 1u << 20, &vw) || !cli_parse_u64(x + 1, 1, 1u << 20, &vh))
        return false;
    *w = (uint32_t)vw;
    *h = (uint32_t)vh;
    return true;
}

double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

bool cli_progress_init(cli_progress *p, const char *prog, bool quiet)
{
    memset(p, 0, sizeof *p);
    p->prog = prog;
    p->start = cli_now();
    p->last = -1;
    p->every = CLI_PROGRESS_EVERY;
    const char *env = getenv("CSI_PROGRESS");
    double every = 0;
    if (env && !strcmp(env, "off"))
        p->mode = CLI_PROGRESS_OFF;
    else if (env && !strcmp(env, "bar"))
        p->mode = CLI_PROGRESS_BAR;
    else if (env && *env && strcmp(env, "auto")) {
        if (!cli_parse_double(env, 0, 1e9, &every)) {
            cli_fail(CSI_ERR_ARG, "CSI_PROGRESS=%.40s is not off, bar, auto or a number of seconds", env);
            return false;
        }
        p->mode = CLI_PROGRESS_LINES;
        p->every = every;
    } else
        p->mode = isatty(STDERR_FILENO) ? CLI_PROGRESS_BAR : CLI_PROGRESS_LINES;
    if (quiet)
        p->mode = CLI_PROGRESS_OFF;
    return true;
}

static void progress_line(cli_progress *p, const char *phase, double fraction, const char *detail, double now)
{
    /* One line a log can hold: no carriage return, no escape sequence; a phase that changed
     * since the last line is named as it is now. */
    if (p->last < 0 ? now - p->start < p->every : now - p->last < p->every)
        return;
    p->last = now;
    char pct[16] = "";
    if (fraction >= 0)
        snprintf(pct, sizeof pct, " %.0f%%", 100 * (fraction > 1 ? 1 : fraction));
    fprintf(stderr, "%s: progress: %s%s%s%s [%.0f s]\n", p->prog ? p->prog : "csi", phase, pct,
            detail && *detail ? "  " : "", detail ? detail : "", now - p->start);
    fflush(stderr);
}

void cli_progress_update(cli_progress *p, const char *phase, double fraction, const char *detail)
{
    if (p->mode == CLI_PROGRESS_OFF)
        return;
    double now = cli_now();
    if (p->mode == CLI_PROGRESS_LINES) {
        progress_line(p, phase, fraction, detail, now);
        return;
    }
    bool new_phase = strncmp(p->phase, phase, sizeof p->phase - 1) != 0;
    if (!new_phase && now - p->last < 0.1 && fraction < 1.0)
        return;
    p->last = now;
    snprintf(p->phase, sizeof p->phase, "%s", phase);
    char bar[32] = "";
    if (fraction >= 0) {
        if (fraction > 1)
            fraction = 1;
        int filled = (int)(fraction * 20 + 0.5);
        bar[0] = '[';
        for (int i = 0; i < 20; i++)
            bar[1 + i] = i < filled ? '#' : '.';
        bar[21] = ']';
        bar[22] = '\0';
    }
    fprintf(stderr, "\r\033[K%-14s %s %s  %.1fs", phase, bar, detail ? detail : "", now - p->start);
    fflush(stderr);
}

void cli_progress_end(cli_progress *p)
{
    if (p->mode == CLI_PROGRESS_BAR && p->last >= 0) {
        fprintf(stderr, "\r\033[K");
        fflush(stderr);
        p->last = -1;
    }
}

void cli_json_grid(csi_json *j, const csi_grid *g)
{
    csi_json_int(j, "grid_w", g->w);
    csi_json_int(j, "grid_h", g->h);
    csi_json_int(j, "grid_t", g->t);
    csi_json_int(j, "out_w", g->out_w);
    csi_json_int(j, "out_h", g->out_h);
}

/* --cache-programs: csi_device_cache_programs on the chosen device, said on stderr. */
int cli_cache_programs(const char *prog, const char *device, bool quiet)
{
    char dir[1024];
    if (csi_cached_programs_dir(dir, sizeof dir) != CSI_OK)
        return cli_error(prog, CSI_ERR_IO, "%s", cli_last_error());
    csi_device *dev = NULL;
    if (csi_device_new(device, &dev) != CSI_OK)
        return cli_error(prog, CSI_ERR_DEVICE, "%s", cli_last_error());
    if (!quiet)
        fprintf(stderr, "%s: caching the OpenCL programs for %s in %s (a minute or more on a first run)\n",
                prog, csi_device_name(dev), dir);
    int stored = 0;
    const csi_status s = csi_device_cache_programs(dev, &stored);
    csi_device_release(dev);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s", cli_last_error());
    if (!quiet)
        fprintf(stderr, "%s: every program is cached (%d built and stored now)\n", prog, stored);
    return 0;
}
