/* ROMP: regularized orthogonal matching pursuit (Needell & Vershynin 2009), real-valued.
 * The algorithm is described in csi/solve.h; comments here say how each step is realised. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

#define ROMP_BINS 4096
#define ROMP_LOCAL 64

void csi_romp_defaults(csi_romp_options *o)
{
    memset(o, 0, sizeof *o);
    o->s = 0;
    o->tol = 1e-5;
    o->max_iter = 0;
    o->lsq_iter = 60;
    o->lsq_tol = 1e-6;
}

size_t csi_romp_default_s(size_t N, size_t k)
{
    /* Largest s with 2 s ln(k/s) <= N (twice the s log(k/s) measurement bound of compressed
     * sensing), capped at N/4 so the final support 2s stays within N/2 (identifiable). */
    size_t cap = N / 4;
    if (cap > k)
        cap = k;
    size_t best = 1;
    for (size_t s = 1; s <= cap; s++) {
        double need = 2.0 * (double)s * log((double)k / (double)s);
        if (need <= (double)N)
            best = s;
        else
            break; /* s ln(k/s) increases in s for s < k/e */
    }
    return best;
}

typedef struct {
    float v;
    uint32_t i;
} cand;

static int cand_cmp(const void *a, const void *b)
{
    const cand *x = a, *y = b;
    if (x->v != y->v)
        return x->v > y->v ? -1 : 1;
    return x->i < y->i ? -1 : (x->i > y->i);
}

/* Candidates: the s largest |u_i| outside the support, 0 < |u_i| < inf, sorted by magnitude
 * (ties by index) into cands[0..*m). */
static csi_status select_top(csi_solver *S, cl_mem u, cl_mem norms, size_t s, cand **cands, size_t *m)
{
    const cl_uint use_norms = norms != NULL;
    if (!norms)
        norms = u; /* any valid buffer: not read */
    csi_ctx *ctx = S->ctx;
    *m = 0;
    *cands = NULL;
    cl_kernel kh, kc;
    CSI_TRY(csi_kernel(ctx, "romp", "romp_hist", &kh));
    CSI_TRY(csi_kernel(ctx, "romp", "romp_collect", &kc));
    const cl_uint n = (cl_uint)S->k;
    /* Few groups: each builds a 4096-bin local histogram, so fewer groups mean less flushing;
     * 2 cores need only a handful. */
    size_t groups = (S->k + ROMP_LOCAL * 256 - 1) / (ROMP_LOCAL * 256);
    if (groups < 1)
        groups = 1;
    if (groups > 16)
        groups = 16;
    const size_t hl = ROMP_LOCAL, hg = groups * ROMP_LOCAL;
    /* When the keys at or above a bin are few, collect them directly and finish on the host;
     * otherwise refine the threshold inside the boundary bin. */
    const size_t small = 4 * s > 8192 ? 4 * s : 8192;
    const cl_uint shifts[3] = {20, 8, 0}, widths[3] = {12, 12, 8};
    cl_uint pmask = 0, pval = 0, thr = 1;
    size_t need = s;
    for (int pass = 0; pass < 3; pass++) {
        const cl_uint shift = shifts[pass], nb = 1u << widths[pass];
        CSI_TRY(csi_fill_zero(ctx, S->hist, ROMP_BINS * 4));
        CSI_TRY(CSI_ARGS(kh, CSI_MEM(u), CSI_MEM(S->mask), CSI_MEM(norms), CSI_ARG(use_norms), CSI_ARG(n),
                         CSI_ARG(shift), CSI_ARG(pmask), CSI_ARG(pval), CSI_MEM(S->hist)));
        CSI_TRY(csi_run(ctx, kh, 1, &hg, &hl));
        CSI_TRY(csi_read(ctx, S->hist, 0, nb * 4, S->h_hist));
        size_t cum = 0;
        long b = (long)nb - 1;
        for (; b >= 0; b--) {
            cum += S->h_hist[b];
            if (cum >= need)
                break;
        }
        if (b < 0) { /* fewer eligible keys than needed: take them all */
            thr = pval > 0 ? pval : 1;
            break;
        }
        const size_t above = cum - S->h_hist[b];
        thr = pval | ((cl_uint)b << shift);
        if (thr == 0)
            thr = 1;
        if (pass == 2 || (s - need) + cum <= small)
            break;
        pval |= (cl_uint)b << shift;
        pmask |= (nb - 1) << shift;
        need -= above;
    }
    CSI_TRY(csi_fill_zero(ctx, S->count, 4));
    const cl_uint cap = (cl_uint)S->k;
    CSI_TRY(CSI_ARGS(kc, CSI_MEM(u), CSI_MEM(S->mask), CSI_MEM(norms), CSI_ARG(use_norms), CSI_ARG(n),
                     CSI_ARG(thr), CSI_ARG(cap), CSI_MEM(S->count), CSI_MEM(S->cand_idx),
                     CSI_MEM(S->cand_val)));
    const size_t cl = 64, cg = S->k;
    CSI_TRY(csi_run(ctx, kc, 1, &cg, &cl));
    cl_uint cnt = 0;
    CSI_TRY(csi_read(ctx, S->count, 0, 4, &cnt));
    size_t got = cnt < cap ? cnt : cap;
    if (got == 0)
        return CSI_OK;
    CSI_TRY(csi_read(ctx, S->cand_idx, 0, got * 4, S->h_idx));
    CSI_TRY(csi_read(ctx, S->cand_val, 0, got * 4, S->h_val));
    cand *c = malloc(got * sizeof *c);
    if (!c)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu ROMP candidates", got);
    for (size_t i = 0; i < got; i++) {
        c[i].v = S->h_val[i];
        c[i].i = S->h_idx[i];
    }
    qsort(c, got, sizeof *c, cand_cmp); /* order from the atomics is not deterministic; this is */
    *m = got < s ? got : s;
    *cands = c;
    return CSI_OK;
}

/* The regularisation step: the window [*lo, *hi) of the sorted candidates with all magnitudes
 * within a factor 2 (v[lo] <= 2 v[hi-1]) and the largest energy sum v^2. */
static void regularise(const cand *c, size_t m, size_t *lo, size_t *hi)
{
    double best = -1, e = 0;
    size_t j = 0;
    *lo = 0;
    *hi = 1;
    for (size_t i = 0; i < m; i++) {
        if (j < i + 1) { /* window starts empty at i */
            j = i;
            e = 0;
        }
        while (j < m && (double)c[i].v <= 2.0 * (double)c[j].v) {
            e += (double)c[j].v * (double)c[j].v;
            j++;
        }
        if (e > best) {
            best = e;
            *lo = i;
            *hi = j;
        }
        e -= (double)c[i].v * (double)c[i].v; /* slide: drop i */
    }
}

csi_status csi_romp_run(csi_solver *S, cl_mem y, cl_mem x, const csi_romp_options *opt,
                        csi_solve_report *rep)
{
    csi_report_init(rep);
    S->result_Ax = NULL;
    const double t0 = csi_solve_now();
    csi_romp_options o;
    if (opt)
        o = *opt;
    else
        csi_romp_defaults(&o);
    if (S->cplx)
        return csi_fail(CSI_ERR_ARG, "ROMP is real-valued; operator %s is complex (use SpaRSA)",
                        S->A->name ? S->A->name : "?");
    if (o.seed_count > 0 && !o.seed_support)
        return csi_fail(CSI_ERR_ARG, "ROMP options: seed_count %zu without seed_support", o.seed_count);
    if (!(o.tol >= 0) || !(o.lsq_tol >= 0) || o.lsq_iter < 0 || o.max_iter < 0)
        return csi_fail(CSI_ERR_ARG, "ROMP options: tol %g, lsq_tol %g, lsq_iter %d, max_iter %d must "
                        "be non-negative", o.tol, o.lsq_tol, o.lsq_iter, o.max_iter);
    CSI_TRY(csi_solver_check_io(S, y, x, "ROMP"));
    CSI_TRY(csi_solver_romp_buffers(S));
    size_t s = o.s ? o.s : csi_romp_default_s(S->N, S->k);
    if (s > S->k)
        s = S->k;
    size_t limit = o.max_support ? o.max_support : 2 * s;
    if (limit > S->k)
        limit = S->k;
    int max_iter = o.max_iter > 0 ? o.max_iter : (int)(limit + 10);
    csi_ctx *ctx = S->ctx;

    double ynorm;
    CSI_TRY(csi_vec_nrm2(S->ws, S->nfN, y, &ynorm));
    if (!isfinite(ynorm))
        return csi_fail(CSI_ERR_ARG, "ROMP: the measurements contain NaN or Inf (or overflow: "
                        "||y|| = %g)", ynorm);
    CSI_TRY(csi_fill_zero(ctx, x, S->nfk * 4));
    CSI_TRY(csi_fill_zero(ctx, S->mask, S->k));
    memset(S->h_mask, 0, S->k);
    if (ynorm == 0) {
        csi_report_set(rep, CSI_SOLVE_ZERO, "ROMP: y = 0, so x = 0");
        rep->t_total = csi_solve_now() - t0;
        return CSI_OK;
    }
    CSI_TRY(csi_vec_copy(ctx, S->r, y, S->nfN));
    double rn = ynorm;
    size_t support = 0; /* indices selected by ROMP (seeded ones not counted) */
    int it = 0;
    const double target = o.tol * ynorm;
    cl_kernel km;
    CSI_TRY(csi_kernel(ctx, "romp", "romp_mark", &km));
    if (o.seed_count > 0) {
        /* csi's extension: start from a given support (e.g. a wavelet's coarse block) and its
         * least-squares fit; the mask then keeps selection from ever returning these indices. */
        for (size_t i = 0; i < o.seed_count; i++) {
            uint32_t j = o.seed_support[i];
            if (j >= S->k)
                return csi_fail(CSI_ERR_ARG, "ROMP seed support: index %u at %zu is outside the %zu "
                                "unknowns", j, i, S->k);
            if (S->h_mask[j])
                return csi_fail(CSI_ERR_ARG, "ROMP seed support: index %u repeats (at %zu)", j, i);
            S->h_mask[j] = 1;
        }
        double ts = csi_solve_now();
        CSI_TRY(csi_write(ctx, S->sel, 0, o.seed_count * 4, o.seed_support));
        cl_uint madd = (cl_uint)o.seed_count;
        const size_t ml = 64, mg = o.seed_count;
        CSI_TRY(CSI_ARGS(km, CSI_MEM(S->mask), CSI_MEM(S->sel), CSI_ARG(madd)));
        CSI_TRY(csi_run(ctx, km, 1, &mg, &ml));
        double tl = csi_solve_now();
        rep->t_select += tl - ts;
        int cg;
        CSI_TRY(csi_cgls(S, y, x, S->mask, o.lsq_iter, o.lsq_tol, target, &cg, &rn, rep));
        if (!isfinite(rn))
            return csi_fail(CSI_ERR_NUMERIC, "ROMP: least squares on the seed support gave a "
                            "non-finite residual");
        rep->inner_iterations += cg;
        rep->t_lsq += csi_solve_now() - tl;
    }
    for (;;) {
        if (rn <= target) {
            csi_report_set(rep, CSI_SOLVE_CONVERGED, "ROMP converged: residual %.3g <= tol %.3g "
                           "after %d iterations, support %zu", rn / ynorm, o.tol, it, support + o.seed_count);
            break;
        }
        if (support >= limit) {
            csi_report_set(rep, CSI_SOLVE_SUPPORT_LIMIT, "ROMP did not converge: support reached "
                           "its limit %zu (s = %zu) with residual %.3g > tol %.3g (too few "
                           "measurements for this sparsity, or s too small)", limit, s, rn / ynorm, o.tol);
            break;
        }
        if (it >= max_iter) {
            csi_report_set(rep, CSI_SOLVE_MAX_ITER, "ROMP did not converge: %d iterations, "
                           "residual %.3g > tol %.3g", it, rn / ynorm, o.tol);
            break;
        }
        double ts = csi_solve_now();
        rep->adjoints++;
        CSI_TRY(csi_linop_adjoint(S->A, S->r, S->g)); /* u = A^H r */
        double umax;
        CSI_TRY(csi_vec_amax(S->ws, S->k, false, S->g, &umax, NULL));
        if (!isfinite(umax))
            return csi_fail(CSI_ERR_NUMERIC, "ROMP iteration %d: A^H r has NaN or Inf (max %g)", it, umax);
        cand *c;
        size_t m;
        CSI_TRY(select_top(S, S->g, o.col_norms, s, &c, &m));
        if (m == 0) {
            free(c);
            rep->t_select += csi_solve_now() - ts;
            csi_report_set(rep, CSI_SOLVE_STALLED, "ROMP stalled: no correlation left outside the "
                           "support (residual %.3g, support %zu)", rn / ynorm, support + o.seed_count);
            break;
        }
        size_t lo, hi;
        regularise(c, m, &lo, &hi);
        size_t add = hi - lo;
        for (size_t i = 0; i < add; i++) {
            uint32_t j = c[lo + i].i;
            if (S->h_mask[j]) { /* cannot happen: the kernels skip the support */
                free(c);
                return csi_fail(CSI_ERR_NUMERIC, "ROMP internal error: index %u selected twice", j);
            }
            S->h_mask[j] = 1;
            S->h_sel[i] = j;
            if (o.support_log && support + i < o.support_log_cap)
                o.support_log[support + i] = j;
        }
        free(c);
        CSI_TRY(csi_write(ctx, S->sel, 0, add * 4, S->h_sel));
        cl_uint madd = (cl_uint)add;
        CSI_TRY(CSI_ARGS(km, CSI_MEM(S->mask), CSI_MEM(S->sel), CSI_ARG(madd)));
        const size_t ml = 64;
        CSI_TRY(csi_run(ctx, km, 1, &add, &ml));
        support += add;
        double tl = csi_solve_now();
        rep->t_select += tl - ts;
        int cg;
        CSI_TRY(csi_cgls(S, y, x, S->mask, o.lsq_iter, o.lsq_tol, target, &cg, &rn, rep));
        if (!isfinite(rn))
            return csi_fail(CSI_ERR_NUMERIC, "ROMP iteration %d: least squares gave a non-finite "
                            "residual", it);
        rep->inner_iterations += cg;
        rep->t_lsq += csi_solve_now() - tl;
        it++;
        if (o.progress && !o.progress(o.user, "romp", it, rn / ynorm))
            return csi_fail(CSI_ERR_CANCELLED, "ROMP cancelled by the caller after %d iterations", it);
    }
    rep->iterations = it;
    support += o.seed_count;
    rep->support = support;
    rep->rel_residual = rn / ynorm;
    rep->objective = 0.5 * rn * rn;
    if (rep->reason == CSI_SOLVE_CONVERGED && 2 * support > S->N && S->N < S->k)
        csi_report_set(rep, CSI_SOLVE_NOT_IDENTIFIABLE, "ROMP fit y (residual %.3g) but with %zu "
                       "non-zeros from %zu measurements (> N/2): the answer is not unique",
                       rn / ynorm, support, S->N);
    rep->t_total = csi_solve_now() - t0;
    return CSI_OK;
}

csi_status csi_romp(const csi_linop *A, cl_mem y, cl_mem x, const csi_romp_options *o,
                    csi_solve_report *rep)
{
    csi_solver *S;
    csi_report_init(rep);
    CSI_TRY(csi_solver_create(A, &S));
    csi_status st = csi_romp_run(S, y, x, o, rep);
    csi_solver_free(S);
    return st;
}

csi_status csi_romp_multi(const csi_linop *A, size_t nrhs, const cl_mem *y, const cl_mem *x,
                          const csi_romp_options *o, csi_solve_report *rep)
{
    csi_solver *S;
    CSI_TRY(csi_solver_create(A, &S));
    csi_status st = CSI_OK;
    for (size_t c = 0; c < nrhs && st == CSI_OK; c++) {
        st = csi_romp_run(S, y[c], x[c], o, &rep[c]);
        if (st != CSI_OK)
            csi_fail_context(st, "channel %zu: ", c);
    }
    csi_solver_free(S);
    return st;
}

csi_status csi_column_norms(const csi_linop *A, int probes, uint64_t seed, cl_mem norms)
{
    if (!A || probes < 1)
        return csi_fail(CSI_ERR_ARG, "column norms: need an operator and at least one probe (%d)", probes);
    csi_ctx *ctx = A->ctx;
    const size_t N = A->rows, k = A->cols, w = A->complex_valued ? 2 : 1;
    if (k > 0x7fffffffu || N > 0x7fffffffu)
        return csi_fail(CSI_ERR_ARG, "column norms: operator too large (%zu x %zu)", N, k);
    float *z = malloc(N * w * sizeof *z);
    if (!z)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu probe entries", N * w);
    cl_mem dz = NULL, dv = NULL;
    cl_kernel ka, ks;
    csi_status st = csi_buffer(ctx, N * w * 4, CL_MEM_READ_WRITE, "column-norm probe", &dz);
    if (st == CSI_OK)
        st = csi_buffer(ctx, k * w * 4, CL_MEM_READ_WRITE, "column-norm probe image", &dv);
    if (st == CSI_OK)
        st = csi_kernel(ctx, "romp", "romp_acc_sq", &ka);
    if (st == CSI_OK)
        st = csi_kernel(ctx, "romp", "romp_sqrt_scale", &ks);
    if (st == CSI_OK)
        st = csi_fill_zero(ctx, norms, k * 4);
    uint64_t r = seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull;
    const cl_uint nk = (cl_uint)k, cplx = A->complex_valued;
    const size_t gl = k, ll = 64;
    for (int p = 0; p < probes && st == CSI_OK; p++) {
        /* Rademacher probe (complex: unit-modulus +-1 / sqrt2 in each part), splitmix64 */
        for (size_t j = 0; j < N * w; j++) {
            uint64_t q = (r += 0x9E3779B97F4A7C15ull);
            q = (q ^ (q >> 30)) * 0xBF58476D1CE4E5B9ull;
            q = (q ^ (q >> 27)) * 0x94D049BB133111EBull;
            q ^= q >> 31;
            z[j] = (q & 1) ? 1.0f : -1.0f;
            if (w == 2)
                z[j] *= 0.70710678f;
        }
        st = csi_write(ctx, dz, 0, N * w * 4, z);
        if (st == CSI_OK)
            st = csi_linop_adjoint(A, dz, dv);
        if (st == CSI_OK)
            st = CSI_ARGS(ka, CSI_MEM(norms), CSI_MEM(dv), CSI_ARG(nk), CSI_ARG(cplx));
        if (st == CSI_OK)
            st = csi_run(ctx, ka, 1, &gl, &ll);
    }
    float scale = 1.0f / (float)probes;
    if (st == CSI_OK)
        st = CSI_ARGS(ks, CSI_MEM(norms), CSI_ARG(nk), CSI_ARG(scale));
    if (st == CSI_OK)
        st = csi_run(ctx, ks, 1, &gl, &ll);
    free(z);
    csi_buffer_release(&dz);
    csi_buffer_release(&dv);
    return st;
}
