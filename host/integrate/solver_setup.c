/* The solver of a reconstruction, set up from its resolved options (resolve.c has the defaults):
 * SpaRSA for Alg. 1 and Alg. 2, ROMP for Alg. 1. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "csi/wavelet.h"
#include "internal.h"

/* Probes of csi_column_norms for ROMP's column normalisation: relative deviation sqrt(2/64) =
 * 18% per column, enough to rank correlations (csi/solve.h). */
#define CSI_ROMP_NORM_PROBES 64

static csi_status run_romp(csi_recon_state *st, const csi_recon_options *opt, csi_solve_progress_fn progress,
                           void *user, csi_solve_report *rep)
{
    csi_romp_options o;
    csi_romp_defaults(&o);
    const size_t N = st->A->rows, k = st->A->cols;
    o.s = opt->romp_s;
    o.max_support = csi_recon_romp_support_limit(opt, N);
    o.lsq_iter = opt->romp_lsq_iter;
    o.tol = opt->tol;
    o.max_iter = opt->max_iter;
    const bool normalize = opt->romp_normalize == CSI_SWITCH_ON;
    if (normalize && !st->romp_norms) {
        CSI_TRY(csi_buffer(st->A->ctx, k * sizeof(float), CL_MEM_READ_WRITE,
                           "the ROMP column norms", &st->romp_norms));
        CSI_TRY(csi_column_norms(st->A, CSI_ROMP_NORM_PROBES, opt->seed, st->romp_norms));
    }
    o.col_norms = normalize ? st->romp_norms : NULL;
    if (opt->romp_seed_levels > 0 && !st->romp_seed) {
        /* The top-left block of the coefficient array (csi/wavelet.h's layout): the coarse
         * scaling block, widened by one detail level per extra seed level. */
        const int levels = csi_wavelet_levels(st->Psi);
        size_t cw, ch;
        csi_wavelet_coarse_block(st->Psi, &cw, &ch);
        const int extra = opt->romp_seed_levels - 1 < levels ? opt->romp_seed_levels - 1 : levels;
        cw <<= extra;
        ch <<= extra;
        const size_t w = cw << (levels - extra);
        st->romp_seed = malloc(cw * ch * sizeof *st->romp_seed);
        if (!st->romp_seed)
            return csi_fail(CSI_ERR_NOMEM, "out of host memory for the ROMP seed support");
        for (size_t yy = 0; yy < ch; yy++)
            for (size_t xx = 0; xx < cw; xx++)
                st->romp_seed[st->romp_seed_n++] = (uint32_t)(yy * w + xx);
    }
    if (opt->romp_seed_levels > 0) {
        o.seed_support = st->romp_seed;
        o.seed_count = st->romp_seed_n;
    }
    o.progress = progress;
    o.user = user;
    CSI_TRY(csi_romp_run(st->solver, st->y, st->x, &o, rep));
    /* A support limit set for images (csi's, or the caller's) is the stopping rule, as SpaRSA's
     * objective change is: the samples are not meant to be fit exactly. The published ROMP's
     * limit 2s is not: reaching it above the tolerance is its failure to converge. */
    const bool published_limit = opt->romp_preset == CSI_ROMP_PRESET_PUBLISHED &&
                                 o.max_support == 2 * opt->romp_s;
    if (!published_limit && rep->reason == CSI_SOLVE_SUPPORT_LIMIT) {
        rep->reason = CSI_SOLVE_CONVERGED;
        rep->converged = true;
        snprintf(rep->message, sizeof rep->message, "ROMP reached its support limit %zu "
                 "(the early stop for images): %zu selected + %zu seeded after %d "
                 "iterations, residual %.3g", o.max_support, rep->support - o.seed_count, o.seed_count,
                 rep->iterations, rep->rel_residual);
    }
    return CSI_OK;
}

/* The solvers report their steps as "sparsa" / "romp" / "debias"; the caller sees them as
 * "solve <c>/<channels>", the channel being solved. */
typedef struct {
    const csi_recon_options *opt;
    char phase[32];
} channel_progress;

static bool forward_progress(void *user, const char *phase, int iter, double rel_residual)
{
    const channel_progress *p = user;
    (void)phase;
    return p->opt->progress(p->opt->user, p->phase, iter, rel_residual);
}

csi_status csi_recon_run_solver(csi_recon_state *st, const csi_recon_options *opt, double tau_scale,
                                csi_solve_report *rep)
{
    channel_progress cp = {opt, ""};
    snprintf(cp.phase, sizeof cp.phase, "solve %u/%u", st->channel + 1, st->channels);
    csi_solve_progress_fn progress = opt->progress ? forward_progress : NULL;
    if (opt->solver == CSI_SOLVER_ROMP)
        return run_romp(st, opt, progress, &cp, rep);
    csi_sparsa_options o;
    csi_sparsa_defaults(&o);
    o.stop = opt->stop == CSI_STOP_GAP ? CSI_SPARSA_STOP_GAP : CSI_SPARSA_STOP_OBJECTIVE;
    o.continuation = opt->continuation == CSI_SWITCH_ON;
    o.cont_step = opt->cont_step > 0 ? opt->cont_step : 0;
    if (opt->cont_tol > 0)
        o.cont_tol = opt->cont_tol;
    o.debias = opt->debias == CSI_SWITCH_ON;
    o.tol = opt->tol;
    o.max_iter = opt->max_iter;
    o.tau_rel = opt->tau_rel;
    if (tau_scale > 0)
        o.tau = o.tau_rel * tau_scale;
    if (st->warm) {
        /* A channel started from the previous channel's solution (warm-channels): at the final
         * tau at once, since continuation would threshold the start away, and with a 3x tighter
         * objective stop, since the first steps from a good start change the objective little
         * (at the image default 3e-3 -> 1e-3: on the Mitsuba and bundled scenes the MSE stayed
         * within -3%..+1% of the cold solves', docs/bench/cost.md; with the default stop itself
         * one scene lost 3.6%). */
        o.warm_start = true;
        o.continuation = false;
        o.tol /= 3.0;
    }
    o.progress = progress;
    o.user = &cp;
    if (!st->coarse || st->warm || !o.continuation)
        return csi_sparsa_run(st->solver, st->y, st->x, &o, rep);
    /* The stages before the last on the coarser grid (coarse_start.c), at the absolute tau the
     * model grid's solve would take; then the last stage from their result. */
    if (!(o.tau > 0)) {
        double hmax;
        CSI_TRY(csi_solver_adjoint_amax(st->solver, st->y, &hmax));
        o.tau = o.tau_rel * hmax;
    }
    csi_solve_report rc;
    CSI_TRY(csi_recon_coarse_stages(st->A->ctx, st->coarse, st->y, &o, st->x, st->A->cols, &rc));
    if (rc.iterations > 0) {
        o.warm_start = true;
        o.start_tau = rc.tau_next;
        o.alpha0 = rc.alpha;
    }
    CSI_TRY(csi_sparsa_run(st->solver, st->y, st->x, &o, rep));
    rep->iterations += rc.iterations;
    rep->stages += rc.stages;
    rep->applies += rc.applies;
    rep->adjoints += rc.adjoints;
    rep->t_total += rc.t_total;
    rep->t_step += rc.t_step;
    return CSI_OK;
}
