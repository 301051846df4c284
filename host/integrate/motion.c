/* Alg. 2 (motion blur and animation): A = S F3^H on the half (or full) spectrum, solve, residual
 * correction, mean over t and every frame. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/integrate_ops.h"
#include "csi/sampled_half_fourier.h"
#include "csi/sampling.h"
#include "csi/spectral.h"
#include "internal.h"

/* Alg. 2 and Sec. 6.1.
 *
 * The paper solves for the complex 3-D Fourier coefficients x of f with A = S F3^H. For real
 * samples that problem has a Hermitian minimiser (if x minimises, so does its conjugate mirror,
 * and by convexity their mean, which is Hermitian and no worse), so csi solves the same problem
 * on the half spectrum z (csi_fourier_half: z = x on the planes u0 = 0 and u0 = n0/2, 2 x
 * between, so H z = F3^H x and ||z||_1 = ||x||_1): half the unknowns and about half the FFT
 * work, the same tau and the same minimiser (docs/bench/motion.md has the measurements). The
 * full complex formulation stays available (csi_recon_options.motion_full_spectrum) and is
 * used when the size does not allow the half spectrum (an odd first axis). */
csi_status csi_recon_motion(csi_ctx *ctx, const csi_grid *g, uint32_t channels,
                            const csi_sample_pos *pos, const float *values, size_t n,
                            const csi_recon_options *opt, csi_recon_result *res,
                            csi_recon_state *st)
{
    const size_t w = g->w, h = g->h, T = g->t, k = w * h * T, wh = w * h;
    const size_t dims[3] = {w, h, T};
    if (opt->solver == CSI_SOLVER_ROMP)
        return csi_fail(CSI_ERR_ARG, "ROMP is real-valued and the 3-D Fourier problem is complex: "
                                     "use --solver sparsa for a volume (grid_t = %zu)", T);
    bool half = !opt->motion_full_spectrum;
    if (half) {
        csi_status hs = csi_half_fourier_sampling_create(ctx, dims, st->idx, n, &st->A);
        if (hs == CSI_ERR_ARG && !st->A)
            half = false; /* e.g. an odd width: the full complex problem instead */
        else
            CSI_TRY(hs);
    }
    if (!half) {
        csi_linop *F = NULL;
        CSI_TRY(csi_fourier_create(ctx, dims, &F));
        st->inner = F;
        st->Psi = F;
        CSI_TRY(csi_sampling_create(ctx, k, st->idx, n, true, &st->S));
        CSI_TRY(csi_linop_compose("S F3^H", st->S, st->inner, true, &st->A));
    }
    const size_t ncoef = st->A->cols;
    CSI_TRY(csi_solver_create(st->A, &st->solver));

    CSI_TRY(csi_buffer(ctx, n * 8, CL_MEM_READ_WRITE, "the measurements", &st->y));
    CSI_TRY(csi_buffer(ctx, ncoef * 8, CL_MEM_READ_WRITE, "the Fourier coefficients", &st->x));
    if (!half)
        CSI_TRY(csi_buffer(ctx, k * 8, CL_MEM_READ_WRITE, "the reconstructed volume", &st->f));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the real volume", &st->tmp));
    const size_t np = (size_t)g->out_w * g->out_h;
    CSI_TRY(csi_buffer(ctx, (np > wh ? np : wh) * 4, CL_MEM_READ_WRITE, "the output image", &st->out));
    /* k floats of scratch once the solve is done: the operator's volume, or the complex one */
    cl_mem scratch = half ? csi_half_fourier_scratch(st->A) : st->f;
    cl_mem mean = NULL, real_y = NULL;
    csi_status s = csi_buffer(ctx, wh * 4, CL_MEM_READ_WRITE, "the time mean", &mean);
    if (s == CSI_OK)
        s = csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the real measurements", &real_y);
    cl_kernel r2c = NULL, c2r = NULL;
    if (s == CSI_OK)
        s = csi_kernel(ctx, "sampling", "csi_real_to_complex", &r2c);
    if (s == CSI_OK)
        s = csi_kernel(ctx, "sampling", "csi_complex_real", &c2r);

    csi_nc_op rnc;
    memset(&rnc, 0, sizeof rnc);
    float *yhost = NULL;
    const bool correct = opt->motion_resid_sigma > 0;
    if (s == CSI_OK && correct) {
        yhost = malloc(n * sizeof *yhost);
        if (!yhost)
            s = csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        if (s == CSI_OK)
            s = csi_nc_init(ctx, g, st->idx, n, opt->motion_resid_sigma, real_y, scratch, yhost, &rnc);
    }
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();

    double t_solve = 0, t_int = 0;
    for (uint32_t c = 0; c < channels && s == CSI_OK; c++) {
        bool copied = false;
        s = csi_recon_channel_begin(st, opt, res, values, n, channels, c, &copied);
        if (s != CSI_OK || copied)
            continue; /* the loop ends on a failure */
        for (size_t i = 0; i < n; i++)
            st->plane[i] = values[i * channels + c];
        cl_uint nn = (cl_uint)n, nk = (cl_uint)k;
        s = csi_write(ctx, real_y, 0, n * 4, st->plane);
        if (s == CSI_OK)
            s = CSI_ARGS(r2c, CSI_MEM(real_y), CSI_MEM(st->y), CSI_ARG(nn));
        if (s == CSI_OK)
            s = csi_run1d(ctx, r2c, n);
        if (s == CSI_OK)
            s = csi_fill_zero(ctx, st->x, ncoef * 8);
        double t0 = csi_recon_now();
        /* A tile scales tau by the whole volume's DC coefficient rescaled to its own cells and
         * samples (csi_tile_scope): n mean / sqrt(k), the tile's DC had its mean been the
         * whole's. */
        const double tau_scale = st->scope && st->scope->has_scale
                                     ? (double)n * fabs(st->scope->scale[c]) / sqrt((double)k) : 0;
        if (s == CSI_OK)
            s = csi_recon_run_solver(st, opt, tau_scale, &res->report[c]);
        if (s == CSI_OK)
            s = csi_finish(ctx);
        double t1 = csi_recon_now();
        t_solve += t1 - t0;
        if (s == CSI_OK)
            s = csi_recon_progress_channel(opt, "integrate", c, channels);
        if (half) {
            if (s == CSI_OK)
                s = csi_half_fourier_synthesize(st->A, st->x, st->tmp); /* f = H z, real */
        } else {
            if (s == CSI_OK)
                s = csi_linop_apply(st->Psi, st->x, st->f);
            if (s == CSI_OK)
                s = CSI_ARGS(c2r, CSI_MEM(st->f), CSI_MEM(st->tmp), CSI_ARG(nk));
            if (s == CSI_OK)
                s = csi_run1d(ctx, c2r, k); /* f = Re(F3^H x) */
        }
        if (s == CSI_OK && correct)
            s = csi_nc_correct(ctx, &rnc, st->plane, n, k, st->tmp, real_y, scratch, yhost);
        if (s == CSI_OK)
            s = csi_recon_integrate_volume(ctx, g, st->tmp, c, opt, res, mean, st->out);
        res->t_channel_integrate[c] = csi_recon_now() - t1;
        t_int += res->t_channel_integrate[c];
    }
    csi_nc_free(&rnc);
    free(yhost);
    csi_buffer_release(&mean);
    csi_buffer_release(&real_y);
    CSI_TRY(s);
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    CSI_TRY(csi_recon_check_finite(res->image, np * channels, "image"));
    if (opt->frames)
        CSI_TRY(csi_recon_check_finite(res->frames, np * channels * T, "frames"));
    return CSI_OK;
}
