/* SpaRSA for 0.5 ||y - A x||^2 + tau ||x||_1 (Wright, Nowak & Figueiredo 2009), real and
 * complex. The algorithm is described in csi/solve.h; comments here say how it is realised.
 *
 * Inner products are real parts of x^H y (csi_vec_dot on interleaved data), which is what the
 * objective, the BB step and the acceptance test need; ||x||_1 sums complex magnitudes and the
 * shrinkage is the complex soft threshold. Vector work is fused so that a trial step is two
 * passes (csi_vec_prox_sums over x, csi_vec_resid_sums over y) besides one apply, and an
 * accepted step adds one adjoint and one max-abs pass: three read-backs per step. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

#define SPARSA_MAX_MEMORY 64
#define SPARSA_STALL_STEPS 10
/* The steps without the gap halving after which a stage whose objective has also stopped
 * moving (by less than the stage's tolerance over those steps) ends above the gap's floor. */
#define SPARSA_STALL_LONG 100

void csi_sparsa_defaults(csi_sparsa_options *o)
{
    memset(o, 0, sizeof *o);
    o->tau = 0;
    o->tau_rel = 1e-4;
    o->memory = 5;
    o->sigma = 0.01;
    o->eta = 2.0;
    o->alpha_min = 1e-30;
    o->alpha_max = 1e30;
    o->stop = CSI_SPARSA_STOP_GAP;
    o->tol = 1e-5;
    o->max_iter = 2000;
    o->max_trials = 60;
    o->continuation = true;
    o->cont_factor = 0.2;
    o->cont_tol = 1e-3;
    o->debias = true;
    o->debias_iter = 200;
    o->debias_tol = 1e-6;
}

static csi_status check_options(const csi_sparsa_options *o)
{
    if (!(o->tau >= 0) || !isfinite(o->tau) || (o->tau == 0 && !(o->tau_rel > 0 && o->tau_rel < INFINITY)))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: tau %g / tau_rel %g: need tau > 0 or tau_rel > 0", o->tau,
                        o->tau_rel);
    if (o->memory < 0 || o->memory > SPARSA_MAX_MEMORY)
        return csi_fail(CSI_ERR_ARG, "SpaRSA: memory M = %d outside 0..%d", o->memory, SPARSA_MAX_MEMORY);
    if (!(o->sigma > 0 && o->sigma < 1) || !(o->eta > 1) || !isfinite(o->eta))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: need 0 < sigma < 1 and eta > 1 (sigma %g, eta %g)",
                        o->sigma, o->eta);
    if (!(o->alpha_min > 0) || !(o->alpha_max > o->alpha_min) || !isfinite(o->alpha_max))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: need 0 < alpha_min < alpha_max < inf (%g, %g)",
                        o->alpha_min, o->alpha_max);
    if (!(o->tol > 0) || !(o->cont_tol > 0) || o->max_iter <= 0 || o->max_trials <= 0 ||
        o->debias_iter < 0 || !(o->debias_tol >= 0))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: tolerances must be > 0 and iteration caps positive");
    if (o->continuation && !(o->cont_factor > 0 && o->cont_factor < 1))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: continuation factor %g must be in (0, 1)", o->cont_factor);
    if (!(o->cont_step >= 0 && o->cont_step < 1))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: continuation step %g must be 0 (adaptive) or in (0, 1)",
                        o->cont_step);
    if (o->stop != CSI_SPARSA_STOP_GAP && o->stop != CSI_SPARSA_STOP_OBJECTIVE)
        return csi_fail(CSI_ERR_ARG, "SpaRSA: unknown stopping rule %d", (int)o->stop);
    return CSI_OK;
}

static csi_status count_nonzeros(csi_solver *S, cl_mem x, size_t *nnz)
{
    CSI_TRY(csi_vec_nonzero_mask(S->ctx, S->k, S->cplx, x, S->mask));
    CSI_TRY(csi_read(S->ctx, S->mask, 0, S->k, S->h_mask));
    size_t c = 0;
    for (size_t i = 0; i < S->k; i++)
        c += S->h_mask[i] != 0;
    *nnz = c;
    return CSI_OK;
}

csi_status csi_sparsa_run(csi_solver *S, cl_mem y, cl_mem x, const csi_sparsa_options *opt,
                          csi_solve_report *rep)
{
    csi_report_init(rep);
    S->result_Ax = NULL;
    const double t0 = csi_solve_now();
    csi_sparsa_options o;
    if (opt)
        o = *opt;
    else
        csi_sparsa_defaults(&o);
    CSI_TRY(check_options(&o));
    CSI_TRY(csi_solver_check_io(S, y, x, "SpaRSA"));
    csi_ctx *ctx = S->ctx;
    const size_t nfN = S->nfN, nfk = S->nfk;

    double ynorm;
    CSI_TRY(csi_vec_nrm2(S->ws, nfN, y, &ynorm));
    if (!isfinite(ynorm))
        return csi_fail(CSI_ERR_ARG, "SpaRSA: the measurements contain NaN or Inf (or overflow: "
                        "||y|| = %g)", ynorm);
    if (!o.warm_start)
        CSI_TRY(csi_fill_zero(ctx, x, nfk * 4));
    rep->stages = 0;
    if (ynorm == 0) {
        CSI_TRY(csi_fill_zero(ctx, x, nfk * 4)); /* a warm start too */
        csi_report_set(rep, CSI_SOLVE_ZERO, "SpaRSA: y = 0, so x = 0");
        rep->t_total = csi_solve_now() - t0;
        return CSI_OK;
    }
    /* h = A^H y (r = y at x = 0): tau is relative to its largest entry, warm start or not */
    cl_mem h = S->g;
    rep->adjoints++;
    CSI_TRY(csi_linop_adjoint(S->A, y, h));
    double hmax;
    CSI_TRY(csi_vec_amax(S->ws, S->k, S->cplx, h, &hmax, NULL));
    if (!isfinite(hmax))
        return csi_fail(CSI_ERR_NUMERIC, "SpaRSA: A^H y has NaN or Inf (max %g)", hmax);
    const double tau = o.tau > 0 ? o.tau : o.tau_rel * hmax;
    rep->tau = tau;
    if (tau >= hmax) {
        CSI_TRY(csi_fill_zero(ctx, x, nfk * 4));
        rep->rel_residual = 1.0;
        rep->objective = 0.5 * ynorm * ynorm;
        csi_report_set(rep, CSI_SOLVE_ZERO, "SpaRSA: tau = %.4g >= ||A^H y||_inf = %.4g, so x = 0 "
                       "is the minimiser", tau, hmax);
        rep->t_total = csi_solve_now() - t0;
        return CSI_OK;
    }

    /* State: cur / Acur hold the accepted iterate and A times it; nxt / Anxt the trial. The
     * handles swap on acceptance; the result is copied into x at the end if needed. */
    cl_mem cur = x, nxt = S->xn, Acur = S->Ax, Anxt = S->Axn, rcur = S->r, rnxt = S->q;
    double rn2 = ynorm * ynorm, l1 = 0.0, ry = rn2;
    if (o.warm_start) {
        /* r = y - A x0, ||x0||_1, and the gradient A^H r at the start. */
        rep->applies++;
        CSI_TRY(csi_linop_apply(S->A, x, Acur));
        CSI_TRY(csi_fill_zero(ctx, Anxt, nfN * 4));
        double dd;
        CSI_TRY(csi_vec_resid_sums(S->ws, nfN, y, Acur, Anxt, rcur, &rn2, &dd, &ry));
        CSI_TRY(csi_vec_asum(S->ws, S->k, S->cplx, x, &l1));
        rep->adjoints++;
        CSI_TRY(csi_linop_adjoint(S->A, rcur, h));
    } else {
        CSI_TRY(csi_fill_zero(ctx, Acur, nfN * 4));
        CSI_TRY(csi_vec_copy(ctx, rcur, y, nfN));
    }
    double tau_k = !o.continuation ? tau : o.start_tau > 0 ? fmax(o.start_tau, tau) : fmax(o.cont_factor * hmax, tau);
    double alpha = o.alpha0 > 0 ? o.alpha0 : 1.0; /* WNF09's code starts from alpha = 1 */
    if (alpha < o.alpha_min)
        alpha = o.alpha_min;
    if (alpha > o.alpha_max)
        alpha = o.alpha_max;
    double hist[SPARSA_MAX_MEMORY + 1];
    int it = 0;
    bool done = false;
    double phi = 0.5 * rn2, gap_rel = INFINITY;
    csi_solve_reason reason = CSI_SOLVE_CONVERGED;
    const double gap_floor = 32.0 * 0x1.0p-24 * ynorm * ynorm;
    const double ts = csi_solve_now();
    while (!done) {
        const bool last = tau_k <= tau;
        if (o.stop_tau > 0 && tau_k <= o.stop_tau) {
            rep->tau_next = tau_k;
            break;
        }
        rep->stages++;
        const double stage_tol = last ? o.tol : fmax(o.cont_tol, o.tol);
        int nh = 1, hpos = 0;
        phi = 0.5 * rn2 + tau_k * l1;
        hist[0] = phi;
        bool stage_done = false;
        double best_gap = INFINITY, phi_at_best = phi;
        int since_best = 0;
        while (!stage_done) {
            if (it >= o.max_iter) {
                reason = CSI_SOLVE_MAX_ITER;
                done = true;
                break;
            }
            double ref = hist[0];
            for (int i = 1; i < nh; i++)
                ref = fmax(ref, hist[i]);
            int trials = 0;
            double phin = 0, rn2n = 0, l1n = 0, dx2 = 0, As2 = 0, ryn = 0;
            for (;;) {
                /* x+ = soft(x + h/alpha, tau/alpha) with ||x+||_1 and ||x+ - x||^2 in the same
                 * pass; then r+ = y - A x+ with ||r+||^2, ||A x+ - A x||^2 and Re<r+, y>. */
                CSI_TRY(csi_vec_prox_sums(S->ws, S->k, S->cplx, cur, h, (float)(1.0 / alpha),
                                          (float)(tau_k / alpha), nxt, &l1n, &dx2));
                rep->applies++;
                CSI_TRY(csi_linop_apply(S->A, nxt, Anxt));
                CSI_TRY(csi_vec_resid_sums(S->ws, nfN, y, Anxt, Acur, rnxt, &rn2n, &As2, &ryn));
                phin = 0.5 * rn2n + tau_k * l1n;
                /* A trial whose objective is not finite (a float overflow from a tiny alpha) fails
                 * the acceptance test like any other: alpha grows and the step shrinks. */
                if (isfinite(phin) && phin <= ref - 0.5 * o.sigma * alpha * dx2)
                    break;
                if (trials >= o.max_trials || alpha * o.eta > o.alpha_max) {
                    reason = CSI_SOLVE_STALLED;
                    done = true;
                    break;
                }
                alpha *= o.eta;
                trials++;
            }
            if (done)
                break;
            /* accepted: the trial buffers become the current ones */
            cl_mem t = cur;
            cur = nxt;
            nxt = t;
            t = Acur;
            Acur = Anxt;
            Anxt = t;
            t = rcur;
            rcur = rnxt;
            rnxt = t;
            const double phi_prev = phi;
            /* The objective stop: only a decrease ends a stage (a non-monotone step that raised
             * phi by a little, accepted against the max of the last M + 1, says nothing about
             * convergence). It needs no gradient, so the last stage's last step skips the
             * adjoint, which only a next step would use. */
            const bool obj_done = o.stop == CSI_SPARSA_STOP_OBJECTIVE && phin <= phi_prev &&
                                  phi_prev - phin <= stage_tol * phi_prev;
            if (!(obj_done && last)) {
                rep->adjoints++;
                CSI_TRY(csi_linop_adjoint(S->A, rcur, h));
            }
            phi = phin;
            rn2 = rn2n;
            l1 = l1n;
            ry = ryn;
            it++;
            if (o.memory > 0) {
                hpos = (hpos + 1) % (o.memory + 1);
                hist[hpos] = phi;
                if (nh < o.memory + 1)
                    nh++;
            } else {
                hist[0] = phi;
            }
            if (o.trace) {
                csi_sparsa_step st = {it, rep->stages, tau_k, alpha, phi, ref, dx2, trials, cur};
                o.trace(o.user, &st);
            }
            /* Barzilai-Borwein for the next step, clamped. */
            /* When the step vanishes in float (A s or s rounds to 0) the BB quotient means nothing:
             * keep the previous alpha instead of jumping to a clamp. */
            if (dx2 > 0 && As2 > 0)
                alpha = As2 / dx2;
            if (!(alpha >= o.alpha_min))
                alpha = o.alpha_min;
            if (alpha > o.alpha_max)
                alpha = o.alpha_max;
            if (o.progress && !o.progress(o.user, "sparsa", it, sqrt(rn2) / ynorm))
                return csi_fail(CSI_ERR_CANCELLED, "SpaRSA cancelled by the caller after %d iterations", it);
            /* Stopping rules. */
            if (obj_done && last) {
                done = true;
                break;
            }
            /* ||A^H r||_inf, a pass over h: only the gap stop and the adaptive continuation
             * read it */
            double hr = 0;
            if (o.stop != CSI_SPARSA_STOP_OBJECTIVE || o.cont_step <= 0)
                CSI_TRY(csi_vec_amax(S->ws, S->k, S->cplx, h, &hr, NULL));
            if (o.stop == CSI_SPARSA_STOP_OBJECTIVE) {
                stage_done = obj_done;
            } else {
                /* Dual of min 0.5||y - Ax||^2 + tau ||x||_1: max_w -0.5||w||^2 + Re<w, y>
                 * subject to ||A^H w||_inf <= tau; w = r * min(1, tau / ||A^H r||_inf) is
                 * feasible and equals r at the optimum, where the gap closes. */
                double sc = hr > tau_k ? tau_k / hr : 1.0;
                double dual = -0.5 * sc * sc * rn2 + sc * ry;
                double gap = phi - dual;
                gap_rel = phi > 0 ? gap / phi : 0.0;
                /* The gap comes from float32 vectors: A x and so r = y - A x carry errors of
                 * about u |y_i|, so the gap is uncertain by up to ~2u ||y||^2 and stagnates there
                 * (measured: 1 .. 10 u ||y||^2, i.e. 1e-4 .. 1e-2 of phi at tau = 1e-4
                 * ||A^H y||_inf). Below gap_floor = 32 u ||y||^2 the stage ends once the gap
                 * has not halved for STALL_STEPS steps: the float32 optimum. */
                if (gap < 0.5 * best_gap) {
                    best_gap = gap;
                    phi_at_best = phi;
                    since_best = 0;
                } else {
                    since_best++;
                }
                /* Above the floor the gap can still stall where float32 rounding of A x and
                 * A^H r leaves it (HDR samples, a sheared basis: the iterate stops moving with
                 * the gap a few times the floor, and the stage runs to the step cap). Once the
                 * gap has not halved for SPARSA_STALL_LONG steps and the objective has fallen
                 * by less than the stage's tolerance over them, the objective stop's own test
                 * holds a hundred times over: the stage ends. */
                stage_done = gap <= stage_tol * phi ||
                             (gap <= gap_floor && since_best >= SPARSA_STALL_STEPS) ||
                             (since_best >= SPARSA_STALL_LONG && phi_at_best - phi <= stage_tol * phi);
            }
            if (stage_done && !last) {
                /* Adaptive continuation: the next tau from the current correlations. A stage
                 * stopped early leaves ||A^H r||_inf several times tau_k, so the adaptive rule can
                 * lower tau by less than cont_factor a stage; the geometric one does not wait. */
                double nt = o.cont_step > 0 ? fmax(o.cont_step * tau_k, tau) : fmax(o.cont_factor * hr, tau);
                if (!(nt < tau_k))
                    nt = fmax(o.cont_factor * tau_k, tau);
                tau_k = nt;
            } else if (stage_done) {
                done = true;
            }
        }
    }
    rep->t_step = csi_solve_now() - ts;
    rep->alpha = alpha;
    rep->iterations = it;
    rep->objective = phi;
    rep->rel_gap = gap_rel;
    if (cur != x)
        CSI_TRY(csi_vec_copy(ctx, x, cur, nfk));
    S->result_Ax = Acur; /* until the debiasing below changes x */
    double rn = sqrt(rn2);
    switch (reason) {
    case CSI_SOLVE_CONVERGED:
        csi_report_set(rep, reason, "SpaRSA converged: %d steps in %d stages, tau %.3g, %s %.3g",
                       it, rep->stages, tau, o.stop == CSI_SPARSA_STOP_GAP ? "relative gap" :
                       "objective change", o.stop == CSI_SPARSA_STOP_GAP ? gap_rel : o.tol);
        break;
    case CSI_SOLVE_MAX_ITER:
        csi_report_set(rep, reason, "SpaRSA did not converge: %d steps (the cap) at tau %.3g, "
                       "stage %d", it, tau_k, rep->stages);
        break;
    default:
        csi_report_set(rep, reason, "SpaRSA stalled: no acceptable step after %d increases of alpha "
                       "(iteration %d, alpha %.3g)", o.max_trials, it, alpha);
        break;
    }
    size_t nnz;
    CSI_TRY(count_nonzeros(S, x, &nnz));
    rep->support = nnz;
    const double td = csi_solve_now();
    /* With N >= k a full-rank A determines x whatever its sparsity; with N < k a solution
     * with more than N/2 non-zeros may have an equally sparse twin. */
    if (2 * nnz > S->N && S->N < S->k) {
        if (rep->converged)
            csi_report_set(rep, CSI_SOLVE_NOT_IDENTIFIABLE, "SpaRSA's l1 minimiser has %zu non-zeros "
                           "from %zu measurements (> N/2): not a unique sparse solution, not debiased",
                           nnz, S->N);
    } else if (o.debias && nnz > 0) {
        /* Debiasing (WNF09 Sec. II-F): least squares on the non-zero set, warm-started. */
        S->result_Ax = NULL;
        int cg;
        CSI_TRY(csi_cgls(S, y, x, S->mask, o.debias_iter, o.debias_tol, 0.0, &cg, &rn, rep));
        rep->inner_iterations += cg;
        if (!isfinite(rn))
            return csi_fail(CSI_ERR_NUMERIC, "SpaRSA debiasing gave a non-finite residual");
        if (o.progress && !o.progress(o.user, "debias", it, rn / ynorm))
            return csi_fail(CSI_ERR_CANCELLED, "SpaRSA cancelled by the caller after debiasing");
    }
    rep->t_debias = csi_solve_now() - td;
    rep->rel_residual = rn / ynorm;
    rep->t_total = csi_solve_now() - t0;
    return CSI_OK;
}

csi_status csi_sparsa(const csi_linop *A, cl_mem y, cl_mem x, const csi_sparsa_options *o,
                      csi_solve_report *rep)
{
    csi_solver *S;
    csi_report_init(rep);
    CSI_TRY(csi_solver_create(A, &S));
    csi_status st = csi_sparsa_run(S, y, x, o, rep);
    csi_solver_free(S);
    return st;
}

csi_status csi_sparsa_multi(const csi_linop *A, size_t nrhs, const cl_mem *y, const cl_mem *x,
                            const csi_sparsa_options *o, csi_solve_report *rep)
{
    csi_solver *S;
    CSI_TRY(csi_solver_create(A, &S));
    csi_status st = CSI_OK;
    for (size_t c = 0; c < nrhs && st == CSI_OK; c++) {
        st = csi_sparsa_run(S, y[c], x[c], o, &rep[c]);
        if (st != CSI_OK)
            csi_fail_context(st, "channel %zu: ", c);
    }
    csi_solver_free(S);
    return st;
}
