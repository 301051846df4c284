/* Alg. 1's continuation stages on a model grid twice as coarse, the last stage on the model grid.
 *
 * SpaRSA with continuation (csi/solve.h) solves a sequence of problems at decreasing tau, each
 * from the previous one's solution; only the last, at the final tau, is the estimate. Roughly
 * half of a solve's operator runs go to the stages before it. Those stages only carry the
 * iterate towards the last stage's start, so they are run on the model grid coarsened once more
 * (2D, the Gaussian then at least CSI_MODEL_SIGMA_MIN / 2 model cells wide: the band-limited
 * model of `--model-sigma-min 0.75`, csi/model_grid.h), whose operator costs about half (the
 * interpolation's work per sample does not shrink with the grid), and the last stage runs on the
 * model grid itself from there. An option: the start moves where the last stage's objective stop
 * ends, and with it single images' MSE by a few % either way (docs/bench/cost.md, session 17).
 *
 * The hand-over is exact: the coarse model is the model grid's wavelet with one level fewer
 * (Psi_m x_m = U Psi_c x_c, U one level of synthesis with zero details), so in csi/wavelet.h's
 * layout the coarse coefficients are the top-left quarter of the model grid's, with the finest
 * level's details zero. Both solves use the same absolute tau. */
#include "internal.h"

#include <stdlib.h>

#include "csi/interp.h"
#include "csi/linop.h"
#include "csi/model_grid.h"
#include "csi/vec.h"
#include "csi/wavelet.h"

struct csi_recon_coarse {
    csi_linop *A; /* S_c Phi_c^-1 Psi_c: owns its parts */
    csi_solver *solver;
    cl_mem x;
    size_t mw, mh;     /* the coarse model grid */
    size_t fine_mw;    /* the model grid's width (the row pitch of its coefficients) */
};

unsigned csi_recon_coarse_factor(const csi_aa_shape *sh, const csi_recon_options *opt)
{
    if (opt->coarse_start != CSI_SWITCH_ON || opt->solver != CSI_SOLVER_SPARSA ||
        opt->continuation != CSI_SWITCH_ON || sh->D < 2 || sh->mlevels < 2)
        return 0;
    /* A grid the model grid's rules allow (csi_model_grid_factor: D divides the grid, an even
     * width for the real FFT, the Gaussian wide enough, at least one wavelet level). */
    const unsigned Dc = 2 * sh->D;
    const size_t w = sh->mw * sh->D, h = sh->mh * sh->D;
    return csi_model_grid_factor(w, h, sh->sphi, sh->levels, CSI_MODEL_SIGMA_MIN / 2) >= Dc ? Dc : 0;
}

void csi_recon_coarse_buffers(const csi_aa_shape *sh, const csi_recon_options *opt, size_t n, csi_mem_tally *t)
{
    const unsigned Dc = csi_recon_coarse_factor(sh, opt);
    if (!Dc)
        return;
    const size_t w = sh->mw * sh->D / Dc, h = sh->mh * sh->D / Dc;
    csi_wavelet_buffers(w, h, t);
    csi_model_filter_buffers(w, h, t);
    csi_linop_compose_buffers(w * h, false, t); /* Phi_c^-1 Psi_c */
    csi_interp_buffers(w, h, Dc, n, t);
    csi_linop_compose_buffers(w * h, false, t); /* S_c Phi_c^-1 Psi_c */
    csi_vec_ws_buffers(t);                      /* the solver's own; its vectors are borrowed */
    csi_mem_tally_add(t, (uint64_t)w * h * 4, "the coarse start's coefficients");
}

csi_status csi_recon_coarse_create(csi_ctx *ctx, const csi_aa_shape *sh, const csi_recon_options *opt,
                                   const uint32_t *idx, size_t n, const csi_solver *fine,
                                   csi_recon_coarse **out)
{
    *out = NULL;
    const unsigned Dc = csi_recon_coarse_factor(sh, opt);
    if (!Dc)
        return CSI_OK;
    const size_t w = sh->mw * sh->D, h = sh->mh * sh->D;
    csi_recon_coarse *c = calloc(1, sizeof *c);
    if (!c)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the coarse start");
    c->mw = w / Dc;
    c->mh = h / Dc;
    c->fine_mw = sh->mw;
    csi_linop *Psi = NULL, *W = NULL, *inner = NULL, *S = NULL;
    csi_status s = csi_wavelet_create(ctx, opt->wavelet, c->mw, c->mh, sh->mlevels - 1, &Psi);
    if (s == CSI_OK)
        s = csi_model_filter_create(ctx, c->mw, c->mh, Dc, sh->sphi, opt->lambda, opt->wavelet, 1, 1, &W);
    if (s == CSI_OK) {
        s = csi_linop_compose("Phi_c^-1 Psi_c", W, Psi, true, &inner);
        if (s == CSI_OK)
            W = Psi = NULL;
    }
    if (s == CSI_OK)
        s = csi_interp_create(ctx, c->mw, c->mh, Dc, idx, n, &S);
    if (s == CSI_OK) {
        s = csi_linop_compose("S_c Phi_c^-1 Psi_c", S, inner, true, &c->A);
        if (s == CSI_OK)
            S = inner = NULL;
    }
    if (s == CSI_OK)
        s = csi_solver_create_sharing(c->A, fine, &c->solver);
    if (s == CSI_OK)
        s = csi_buffer(ctx, c->mw * c->mh * sizeof(float), CL_MEM_READ_WRITE, "the coarse start's coefficients",
                       &c->x);
    csi_linop_free(Psi);
    csi_linop_free(W);
    csi_linop_free(inner);
    csi_linop_free(S);
    if (s != CSI_OK) {
        csi_recon_coarse_free(c);
        return s;
    }
    *out = c;
    return CSI_OK;
}

void csi_recon_coarse_free(csi_recon_coarse *c)
{
    if (!c)
        return;
    csi_solver_free(c->solver);
    csi_linop_free(c->A);
    csi_buffer_release(&c->x);
    free(c);
}

csi_status csi_recon_coarse_stages(csi_ctx *ctx, csi_recon_coarse *c, cl_mem y, const csi_sparsa_options *o,
                                   cl_mem x, size_t fine_k, csi_solve_report *rep)
{
    csi_sparsa_options oc = *o;
    oc.stop_tau = o->tau; /* the stage at the final tau is the last */
    oc.debias = false;
    oc.warm_start = false;
    CSI_TRY(csi_sparsa_run(c->solver, y, c->x, &oc, rep));
    CSI_TRY(csi_fill_zero(ctx, x, fine_k * sizeof(float)));
    return csi_copy_rows(ctx, x, c->fine_mw * sizeof(float), c->x, c->mw * sizeof(float), c->mw * sizeof(float),
                         c->mh);
}
