/* Alg. 1 (antialiasing): A = S Phi^-1 Psi, solve, integrate, per-pixel correction; on a coarser
 * model grid when the filter allows it (csi/model_grid.h). */
#include <math.h>
#include <stdlib.h>

#include "csi/integrate_ops.h"
#include "csi/interp.h"
#include "csi/model_grid.h"
#include "csi/sampling.h"
#include "csi/spectral.h"
#include "csi/vec.h"
#include "csi/wavelet.h"
#include "internal.h"

csi_status csi_recon_aa_shape(const csi_grid *g, size_t n, const csi_recon_options *opt,
                              const csi_recon_state *st, csi_aa_shape *out)
{
    const size_t w = g->w, h = g->h, k = w * h;
    double *sphi = out->sphi;
    sphi[0] = sphi[1] = sphi[2] = 0;
    csi_gauss_sigmas(w, g->out_w, &sphi[0], NULL);
    csi_gauss_sigmas(h, g->out_h, &sphi[1], NULL);
    sphi[0] *= opt->sigma_scale;
    sphi[1] *= opt->sigma_scale;
    /* The filter follows the sampling rate: below a few samples per pixel the paper's width
     * (set by the output size alone) is narrower than the gaps between samples, and the
     * reconstruction rings between them (docs/bench/quality.md). */
    const double spacing = opt->sigma_spacing * sqrt(csi_recon_scope_k(st, k) / csi_recon_scope_n(st, n));
    sphi[0] = fmax(sphi[0], spacing);
    sphi[1] = fmax(sphi[1], spacing);
    const int levels = opt->levels; /* resolved: csi_recon_resolve */
    if (levels < 1)
        return csi_fail(CSI_ERR_ARG, "grid %zux%zu is too small or odd for a %s wavelet level", w, h,
                        csi_wavelet_name(opt->wavelet));
    out->levels = levels;

    /* With a wide filter the image model lives on a grid D times coarser than the samples'
     * (csi/model_grid.h): the same operator to ~1e-5, without the fine grid's FFTs. Only for
     * what it reproduces: the sharp estimate, solved by SpaRSA (ROMP and the filtered estimate
     * keep the fine grid). */
    const unsigned D = opt->model_grid != CSI_SWITCH_OFF && opt->output == CSI_AA_SHARP &&
                               opt->solver == CSI_SOLVER_SPARSA
                           ? csi_model_grid_factor(w, h, sphi, levels, opt->model_sigma_min) : 1;
    out->D = D;
    out->mw = w / D;
    out->mh = h / D;
    out->mlevels = levels;
    for (unsigned d = D; d > 1; d /= 2)
        out->mlevels--;
    return CSI_OK;
}

csi_status csi_recon_aa_operator(csi_ctx *ctx, const csi_grid *g, size_t n, const csi_recon_options *opt,
                                 csi_recon_state *st, csi_aa_shape *shape)
{
    const size_t w = g->w, h = g->h, k = w * h;
    const size_t dims[3] = {w, h, 1};
    CSI_TRY(csi_recon_aa_shape(g, n, opt, st, shape));
    const csi_aa_shape sh = *shape;
    const double *sphi = sh.sphi;
    const unsigned D = sh.D;
    const size_t mw = sh.mw, mh = sh.mh;
    const int mlevels = sh.mlevels;

    /* A = S . (Phi^-1 . Psi); the compositions own their parts. */
    csi_linop *Psi = NULL, *W = NULL, *WPsi = NULL;
    CSI_TRY(csi_wavelet_create(ctx, opt->wavelet, mw, mh, mlevels, &Psi));
    csi_status s = D > 1 ? csi_model_filter_create(ctx, mw, mh, D, sphi, opt->lambda, opt->wavelet, 1, 1, &W)
                         : csi_filter_create(ctx, dims, sphi, CSI_FILTER_WIENER, opt->lambda, &W);
    if (s == CSI_OK)
        s = csi_linop_compose("Phi^-1 Psi", W, Psi, true, &WPsi);
    if (s != CSI_OK) {
        csi_linop_free(W);
        csi_linop_free(Psi);
        return s;
    }
    st->inner = WPsi;
    st->Psi = Psi; /* borrowed from WPsi */
    st->W = W;     /* borrowed from WPsi */
    if (D > 1)
        CSI_TRY(csi_interp_create(ctx, mw, mh, D, st->idx, n, &st->S));
    else
        CSI_TRY(csi_sampling_create(ctx, k, st->idx, n, false, &st->S));
    CSI_TRY(csi_linop_compose("S Phi^-1 Psi", st->S, st->inner, true, &st->A));
    if (D > 1) {
        /* The box mean over each pixel: the model filter with the pixel's Dirichlet kernel, read
         * at each pixel's first fine cell. */
        const size_t np = (size_t)g->out_w * g->out_h;
        const unsigned bx = g->w / g->out_w, by = g->h / g->out_h;
        CSI_TRY(csi_model_filter_create(ctx, mw, mh, D, sphi, opt->lambda, opt->wavelet, bx, by, &st->Wbox));
        uint32_t *pix = malloc(np * sizeof *pix);
        if (!pix)
            return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
        for (size_t oy = 0; oy < g->out_h; oy++)
            for (size_t ox = 0; ox < g->out_w; ox++)
                pix[oy * g->out_w + ox] = (uint32_t)(oy * by * w + ox * bx);
        s = csi_interp_create(ctx, mw, mh, D, pix, np, &st->Ipix);
        free(pix);
        CSI_TRY(s);
    }
    return CSI_OK;
}

csi_status csi_recon_antialias_scale(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                                     const float *values, size_t n, const csi_recon_options *opt,
                                     csi_recon_state *st, double scale[4])
{
    const bool chroma = csi_recon_chroma_on(g, channels, opt);
    csi_aa_shape sh;
    CSI_TRY(csi_recon_aa_operator(ctx, g, n, opt, st, &sh));
    const size_t km = sh.mw * sh.mh;
    CSI_TRY(csi_buffer(ctx, n * sizeof(float), CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, km * sizeof(float), CL_MEM_READ_WRITE, "the wavelet coefficients", &st->x));
    csi_vec_ws *ws = NULL;
    CSI_TRY(csi_vec_ws_create(ctx, &ws));
    csi_status s = CSI_OK;
    for (uint32_t c = 0; c < (chroma ? 1 : channels) && s == CSI_OK; c++) {
        if (chroma)
            csi_recon_opponent(values, n, 0, st->plane);
        else
            for (size_t i = 0; i < n; i++)
                st->plane[i] = values[i * channels + c];
        s = csi_write(ctx, st->y, 0, n * sizeof(float), st->plane);
        if (s == CSI_OK)
            s = csi_linop_adjoint(st->A, st->y, st->x);
        if (s == CSI_OK)
            s = csi_vec_amax(ws, km, false, st->x, &scale[c], NULL);
    }
    if (chroma)
        scale[1] = scale[2] = csi_recon_chroma_tau_scale(scale[0]);
    csi_vec_ws_free(ws);
    return s;
}

csi_aa_correct csi_recon_aa_correction(const csi_recon_options *opt)
{
    return opt->correct != CSI_CORRECT_AUTO          ? opt->correct
           : opt->sample_flags & CSI_SAMPLES_EXACT ? CSI_CORRECT_CV
                                                   : CSI_CORRECT_BLEND;
}

csi_status csi_recon_aa_integrate(csi_ctx *ctx, const csi_grid *g, const csi_recon_options *opt,
                                  csi_recon_state *st, unsigned D, float *plane, const csi_linop **S,
                                  cl_mem *at)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    /* The integration's two images (the model grid's values each) live only between a solve and
     * the next: they are the solver's scratch, idle then (the solver keeps A x of its result
     * apart). */
    cl_mem const fine = csi_solver_coef_scratch(st->solver, 0), sharp = csi_solver_coef_scratch(st->solver, 1);
    CSI_TRY(csi_linop_apply(st->Psi, st->x, fine)); /* f_b = Psi x */
    cl_mem src = fine;
    if (D > 1) {
        CSI_TRY(csi_linop_apply(st->Wbox, fine, sharp)); /* box means of Phi^-1 f_b */
        CSI_TRY(csi_linop_apply(st->Ipix, sharp, st->out));
    } else {
        if (opt->output == CSI_AA_SHARP) {
            CSI_TRY(csi_linop_apply(st->W, fine, sharp)); /* Phi^-1 f_b */
            src = sharp;
        }
        CSI_TRY(csi_box_integrate(ctx, src, g->w, g->h, 1, g->out_w, g->out_h, st->out));
    }
    CSI_TRY(csi_read(ctx, st->out, 0, np * sizeof(float), plane));
    /* The correction reads the estimate at the samples: S src, which on the model grid is
     * A x (the same for the sharp estimate on the fine grid, where A x = S Phi^-1 Psi x).
     * SpaRSA left A x of its result in its workspace (csi_solver_result_Ax): read there, not
     * applied again (one operator run per channel, the same bits). */
    cl_mem Ax = D > 1 ? csi_solver_result_Ax(st->solver) : NULL;
    *S = Ax ? NULL : D > 1 ? st->A : st->S;
    *at = Ax ? Ax : D > 1 ? st->x : src;
    return CSI_OK;
}

/* Alg. 1. */
csi_status csi_recon_antialias(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                               const csi_sample_pos *pos, const float *values, size_t n,
                               const csi_recon_options *opt, csi_recon_result *res,
                               csi_recon_state *st)
{
    if (csi_recon_chroma_on(g, channels, opt))
        return csi_recon_antialias_chroma(ctx, g, pos, values, n, opt, res, st);
    const size_t np = (size_t)g->out_w * g->out_h;
    csi_aa_shape sh;
    CSI_TRY(csi_recon_aa_operator(ctx, g, n, opt, st, &sh));
    const unsigned D = sh.D;
    const size_t km = sh.mw * sh.mh;
    res->model_factor = D;
    res->unknowns = km;
    CSI_TRY(csi_solver_create(st->A, &st->solver));
    CSI_TRY(csi_recon_coarse_create(ctx, &sh, opt, st->idx, n, st->solver, &st->coarse));

    CSI_TRY(csi_buffer(ctx, n * sizeof(float), CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, km * sizeof(float), CL_MEM_READ_WRITE, "the wavelet coefficients", &st->x));
    CSI_TRY(csi_buffer(ctx, np * sizeof(float), CL_MEM_READ_WRITE, "the output image", &st->out));
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();

    const csi_aa_correct how = csi_recon_aa_correction(opt);
    double t_solve = 0, t_int = 0;
    int warm_from = -1; /* the last channel solved, whose x the next one may start from */
    for (uint32_t c = 0; c < channels; c++) {
        bool copied;
        CSI_TRY(csi_recon_channel_begin(st, opt, res, values, n, channels, c, &copied));
        if (copied)
            continue;
        for (size_t i = 0; i < n; i++)
            st->plane[i] = values[i * channels + c];
        CSI_TRY(csi_write(ctx, st->y, 0, n * sizeof(float), st->plane));
        /* Warm start (csi_recon_options.warm_channels): the previous solved channel's x, scaled
         * to this channel's level; RGB channels of one scene share most of their structure. */
        double ratio = 0;
        if (warm_from >= 0) {
            double a = 0, b = 0;
            for (size_t i = 0; i < n; i++) {
                a += values[i * channels + c];
                b += values[i * channels + (uint32_t)warm_from];
            }
            ratio = b != 0 ? a / b : 0;
        }
        st->warm = ratio > 0 && isfinite(ratio);
        if (st->warm)
            CSI_TRY(csi_vec_scale(ctx, st->x, km, (float)ratio));
        else
            CSI_TRY(csi_fill_zero(ctx, st->x, km * sizeof(float)));
        double t0 = csi_recon_now();
        const double tau_scale = st->scope && st->scope->has_scale ? st->scope->scale[c] : 0;
        CSI_TRY(csi_recon_run_solver(st, opt, tau_scale, &res->report[c]));
        CSI_TRY(csi_finish(ctx));
        double t1 = csi_recon_now();
        t_solve += t1 - t0;
        if (opt->warm_channels == CSI_SWITCH_ON && opt->solver == CSI_SOLVER_SPARSA)
            warm_from = (int)c;
        CSI_TRY(csi_recon_progress_channel(opt, "integrate", c, channels));
        const csi_linop *S;
        cl_mem at;
        CSI_TRY(csi_recon_aa_integrate(ctx, g, opt, st, D, res->image + (size_t)c * np, &S, &at));
        if (how != CSI_CORRECT_NONE)
            CSI_TRY(csi_recon_correct(ctx, g, opt, how, S, at, st->y, values, channels, c, pos, n,
                                      how == CSI_CORRECT_BLEND && csi_recon_nonneg(values, channels, c, n),
                                      res->image + (size_t)c * np));
        res->t_channel_integrate[c] = csi_recon_now() - t1;
        t_int += res->t_channel_integrate[c];
    }
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    return csi_recon_check_finite(res->image, np * channels, "image");
}
