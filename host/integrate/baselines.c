/* The baselines csi is measured against, on the very same samples and integration: the per-pixel
 * sample mean (Monte Carlo) and Gaussian normalized convolution (the paper's Sec. 6.1). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/integrate_ops.h"
#include "internal.h"

/* Baseline: normalized convolution with a Gaussian of the same width on every axis. */
csi_status csi_recon_gauss_nc(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                              const csi_sample_pos *pos, const float *values, size_t n,
                              const csi_recon_options *opt, csi_recon_result *res,
                              csi_recon_state *st)
{
    const size_t k = (size_t)g->w * g->h * g->t, wh = (size_t)g->w * g->h;
    const double sigma = opt->gauss_sigma;
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the scattered samples", &st->x));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the interpolated samples", &st->tmp));
    CSI_TRY(csi_buffer(ctx, (np > wh ? np : wh) * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    cl_mem scratch = NULL;
    csi_nc_op nc;
    memset(&nc, 0, sizeof nc);
    csi_status s = csi_buffer(ctx, wh * 4, CL_MEM_READ_WRITE, "a frame", &scratch);
    if (s == CSI_OK)
        s = csi_nc_init(ctx, g, st->idx, n, sigma, st->y, st->x, st->plane, &nc);
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();
    double t0 = csi_recon_now();
    for (uint32_t c = 0; c < channels && s == CSI_OK; c++) {
        /* The estimate is a mean of the samples with non-negative weights: within their range,
         * where the FFT's rounding (large next to a bright sample, divided by a small density)
         * would otherwise carry it below the darkest (negative from non-negative samples). */
        nc.lo = INFINITY;
        nc.hi = -INFINITY;
        for (size_t i = 0; i < n; i++) {
            st->plane[i] = values[i * channels + c];
            nc.lo = fminf(nc.lo, st->plane[i]);
            nc.hi = fmaxf(nc.hi, st->plane[i]);
        }
        s = csi_write(ctx, st->y, 0, n * 4, st->plane);
        if (s == CSI_OK)
            s = csi_nc_interp(ctx, &nc, st->y, k, st->x, st->tmp);
        if (s == CSI_OK)
            s = csi_recon_integrate_volume(ctx, g, st->tmp, c, opt, res, scratch, st->out);
        if (s == CSI_OK && g->t == 1 && (opt->correct == CSI_CORRECT_CV || opt->correct == CSI_CORRECT_BLEND))
            s = csi_recon_correct(ctx, g, opt, opt->correct, nc.S, st->tmp, st->y, values, channels, c,
                                  pos, n, false, res->image + (size_t)c * np);
        if (s == CSI_OK) {
            csi_solve_report *r = &res->report[c];
            r->converged = true;
            snprintf(r->message, sizeof r->message, "Gaussian normalized convolution, sigma %.3g cells", sigma);
        }
    }
    res->t_integrate = csi_recon_now() - t0;
    csi_nc_free(&nc);
    csi_buffer_release(&scratch);
    return s;
}

/* Baseline: the per-pixel sample mean (Monte Carlo). */
csi_status csi_recon_sample_mean(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                 const csi_sample_pos *pos, const float *values, size_t n,
                                 const csi_recon_options *opt, csi_recon_result *res, csi_recon_state *st)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, np * channels * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();
    /* one pass over every output pixel and its transfer back: seconds at tens of megapixels */
    CSI_TRY(csi_recon_progress(opt, "integrate"));
    double t0 = csi_recon_now();
    size_t empty = 0;
    CSI_TRY(csi_splat_mean(ctx, g, channels, pos, values, n, st->out, &empty));
    CSI_TRY(csi_read(ctx, st->out, 0, np * channels * 4, res->image));
    res->t_integrate = csi_recon_now() - t0;
    for (uint32_t c = 0; c < channels; c++) {
        res->report[c].converged = true;
        snprintf(res->report[c].message, sizeof res->report[c].message,
                 "per-pixel sample mean; %zu of %zu pixels had no sample (left 0)", empty, np);
    }
    return CSI_OK;
}
