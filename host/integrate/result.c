/* The reconstruction result: integrating a fine volume into its image (and frames), the final
 * finiteness check, and freeing it. */
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/integrate_ops.h"
#include "internal.h"

void csi_recon_result_free(csi_recon_result *r)
{
    if (!r)
        return;
    free(r->image);
    free(r->frames);
    r->image = r->frames = NULL;
}

void csi_recon_result_drop_frames(csi_recon_result *r)
{
    free(r->frames);
    r->frames = NULL;
    r->nframes = 0;
    r->options.frames = false;
}

/* The first channel before c whose samples are bitwise those of channel c, or -1. */
static int same_channel(const float *values, size_t n, uint32_t channels, uint32_t c)
{
    for (uint32_t e = 0; e < c; e++) {
        size_t i = 0;
        while (i < n && memcmp(&values[i * channels + e], &values[i * channels + c], sizeof(float)) == 0)
            i++;
        if (i == n)
            return (int)e;
    }
    return -1;
}

csi_status csi_recon_channel_begin(csi_recon_state *st, const csi_recon_options *opt,
                                   csi_recon_result *res, const float *values, size_t n,
                                   uint32_t channels, uint32_t c, bool *copied)
{
    st->channel = c;
    st->channels = channels;
    *copied = false;
    CSI_TRY(csi_recon_progress_channel(opt, "solve", c, channels));
    const int from = same_channel(values, n, channels, c);
    if (from < 0)
        return CSI_OK;
    const size_t np = (size_t)res->out_w * res->out_h;
    memcpy(res->image + (size_t)c * np, res->image + (size_t)from * np, np * sizeof(float));
    for (uint32_t t = 0; t < res->nframes; t++)
        memcpy(res->frames + ((size_t)t * res->channels + c) * np,
               res->frames + ((size_t)t * res->channels + (uint32_t)from) * np, np * sizeof(float));
    res->report[c] = res->report[from];
    res->report[c].t_total = 0;
    *copied = true;
    return CSI_OK;
}

double csi_recon_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* Magnitudes in [2^-SCALE_FREE, 2^SCALE_FREE] are solved as they are (so every result so far
 * keeps its bits): their squares and sums of squares over 2^32 samples stay inside float's
 * normal range (2^-126 .. 2^128), which the solvers' norms and steps need. Outside it a channel
 * is scaled so that its largest magnitude lies in [0.5, 1). */
#define SCALE_FREE 32

csi_status csi_recon_scale_values(const float *values, size_t n, uint32_t channels, bool common, int e[4],
                                  float **scaled)
{
    *scaled = NULL;
    bool any = false;
    float all = 0;
    for (uint32_t c = 0; c < channels; c++) {
        float m = 0;
        for (size_t i = 0; i < n; i++) { /* fmaxf's NaN rule without its call per sample */
            const float a = fabsf(values[i * channels + c]);
            m = a > m ? a : m;
        }
        all = fmaxf(all, m);
        int ex = 0;
        if (m > 0)
            frexpf(m, &ex);
        e[c] = m > 0 && (ex > SCALE_FREE || ex < -SCALE_FREE) ? ex : 0;
        any = any || e[c] != 0;
    }
    if (common) {
        int ex = 0;
        if (all > 0)
            frexpf(all, &ex);
        any = all > 0 && (ex > SCALE_FREE || ex < -SCALE_FREE);
        for (uint32_t c = 0; c < channels; c++)
            e[c] = any ? ex : 0;
    }
    if (!any)
        return CSI_OK;
    float *s = malloc(n * channels * sizeof *s);
    if (!s)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu scaled samples", n);
    for (size_t i = 0; i < n; i++)
        for (uint32_t c = 0; c < channels; c++)
            s[i * channels + c] = ldexpf(values[i * channels + c], -e[c]);
    *scaled = s;
    return CSI_OK;
}

/* x 2^e, saturated at float's largest finite magnitude (the output formats' range). */
static float unscale(float x, int e)
{
    double y = ldexp((double)x, e);
    return y > FLT_MAX ? FLT_MAX : y < -FLT_MAX ? -FLT_MAX : (float)y;
}

void csi_recon_unscale_result(csi_recon_result *r, const int e[4])
{
    const size_t np = (size_t)r->out_w * r->out_h;
    for (uint32_t c = 0; c < r->channels; c++) {
        if (!e[c])
            continue;
        for (size_t p = 0; p < np; p++)
            r->image[c * np + p] = unscale(r->image[c * np + p], e[c]);
        for (uint32_t t = 0; r->frames && t < r->nframes; t++)
            for (size_t p = 0; p < np; p++)
                r->frames[((size_t)t * r->channels + c) * np + p] =
                    unscale(r->frames[((size_t)t * r->channels + c) * np + p], e[c]);
    }
}

double csi_recon_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

csi_status csi_recon_progress_step(const csi_recon_options *opt, const char *phase, int done)
{
    if (opt && opt->progress && !opt->progress(opt->user, phase, done, -1.0))
        return csi_fail(CSI_ERR_CANCELLED, "reconstruction cancelled by the caller (at %s)", phase);
    return CSI_OK;
}

csi_status csi_recon_progress(const csi_recon_options *opt, const char *phase)
{
    return csi_recon_progress_step(opt, phase, 0);
}

csi_status csi_recon_progress_channel_step(const csi_recon_options *opt, const char *phase, uint32_t c,
                                           uint32_t channels, int done)
{
    char name[48];
    snprintf(name, sizeof name, "%s %u/%u", phase, c + 1, channels);
    return csi_recon_progress_step(opt, name, done);
}

csi_status csi_recon_progress_channel(const csi_recon_options *opt, const char *phase, uint32_t c,
                                      uint32_t channels)
{
    return csi_recon_progress_channel_step(opt, phase, c, channels, 0);
}

csi_status csi_recon_check_finite(const float *a, size_t n, const char *what)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(a[i]))
            return csi_fail(CSI_ERR_NUMERIC, "the reconstructed %s has a non-finite value at %zu", what, i);
    return CSI_OK;
}

bool csi_recon_nonneg(const float *values, uint32_t channels, uint32_t c, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!(values[i * channels + c] >= 0))
            return false;
    return true;
}

csi_status csi_recon_integrate_volume(csi_ctx *ctx, const csi_grid *g, cl_mem vol,
                                      uint32_t c, const csi_recon_options *opt, csi_recon_result *res,
                                      cl_mem scratch_wh, cl_mem out)
{
    const size_t wh = (size_t)g->w * g->h, np = (size_t)g->out_w * g->out_h;
    const uint32_t channels = res->channels;
    if (g->t == 1) {
        CSI_TRY(csi_box_integrate(ctx, vol, g->w, g->h, 1, g->out_w, g->out_h, out));
        return csi_read(ctx, out, 0, np * 4, res->image + (size_t)c * np);
    }
    /* the shutter's frames are the volume's first (frame-major): the mean over them alone */
    const uint32_t nt = opt->shutter_frames && opt->shutter_frames < g->t ? opt->shutter_frames : g->t;
    CSI_TRY(csi_time_mean(ctx, vol, g->w, g->h, nt, 1, scratch_wh));
    CSI_TRY(csi_box_integrate(ctx, scratch_wh, g->w, g->h, 1, g->out_w, g->out_h, out));
    CSI_TRY(csi_read(ctx, out, 0, np * 4, res->image + (size_t)c * np));
    for (size_t t = 0; opt->frames && t < g->t; t++) {
        CSI_TRY(csi_copy(ctx, scratch_wh, 0, vol, t * wh * 4, wh * 4));
        CSI_TRY(csi_box_integrate(ctx, scratch_wh, g->w, g->h, 1, g->out_w, g->out_h, out));
        CSI_TRY(csi_read(ctx, out, 0, np * 4, res->frames + (t * channels + c) * np));
    }
    return CSI_OK;
}
