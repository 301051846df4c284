/* Solver workspace, reports and the least-squares step (CGLS) shared by ROMP and SpaRSA. */
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "internal.h"

#define ROMP_BINS 4096

double csi_solve_now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

const char *csi_solve_reason_name(csi_solve_reason r)
{
    switch (r) {
    case CSI_SOLVE_CONVERGED: return "converged";
    case CSI_SOLVE_ZERO: return "zero solution";
    case CSI_SOLVE_MAX_ITER: return "iteration cap reached";
    case CSI_SOLVE_SUPPORT_LIMIT: return "support limit reached";
    case CSI_SOLVE_NOT_IDENTIFIABLE: return "not identifiable";
    case CSI_SOLVE_STALLED: return "stalled";
    }
    return "?";
}

void csi_report_init(csi_solve_report *rep)
{
    memset(rep, 0, sizeof *rep);
    rep->reason = CSI_SOLVE_STALLED;
}

void csi_report_set(csi_solve_report *rep, csi_solve_reason reason, const char *fmt, ...)
{
    rep->reason = reason;
    rep->converged = reason == CSI_SOLVE_CONVERGED || reason == CSI_SOLVE_ZERO;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(rep->message, sizeof rep->message, fmt, ap);
    va_end(ap);
}

void csi_solver_free(csi_solver *S)
{
    if (!S)
        return;
    cl_mem *bufs[] = {&S->r, &S->q, &S->Ax, &S->Axn, &S->g, &S->p, &S->s, &S->xn, &S->mask, &S->hist, &S->count, &S->cand_idx, &S->cand_val, &S->sel};
    for (size_t i = S->borrowed ? 9 : 0; i < sizeof bufs / sizeof *bufs; i++)
        csi_buffer_release(bufs[i]);
    csi_vec_ws_free(S->ws);
    free(S->h_hist);
    free(S->h_idx);
    free(S->h_sel);
    free(S->h_val);
    free(S->h_mask);
    free(S);
}

void csi_solver_buffers(size_t rows, size_t cols, bool complex_valued, csi_mem_tally *t)
{
    const size_t w = complex_valued ? 2 : 1, nfN = rows * w, nfk = cols * w;
    csi_vec_ws_buffers(t);
    static const char *const meas[4] = {"solver residual", "solver measurement scratch", "solver A x",
                                        "solver A x (trial)"};
    static const char *const coef[4] = {"solver gradient", "solver direction", "solver coefficient scratch",
                                        "solver trial iterate"};
    for (int i = 0; i < 4; i++)
        csi_mem_tally_add(t, nfN * 4, meas[i]);
    for (int i = 0; i < 4; i++)
        csi_mem_tally_add(t, nfk * 4, coef[i]);
    csi_mem_tally_add(t, cols, "solver support mask");
}

void csi_solver_romp_tally(size_t cols, csi_mem_tally *t)
{
    csi_mem_tally_add(t, ROMP_BINS * 4, "ROMP histogram");
    csi_mem_tally_add(t, 4, "ROMP candidate count");
    csi_mem_tally_add(t, cols * 4, "ROMP candidates");
    csi_mem_tally_add(t, cols * 4, "ROMP candidate values");
    csi_mem_tally_add(t, cols * 4, "ROMP selection");
}

uint64_t csi_solver_host_bytes(size_t rows, size_t cols, bool complex_valued, bool romp)
{
    (void)rows;
    (void)complex_valued;
    uint64_t b = cols; /* the support mask */
    if (romp) /* histogram, candidate indices, selection, values; the sorted candidates (romp.c) */
        b += ROMP_BINS * 4 + 3 * (uint64_t)cols * 4 + (uint64_t)cols * 8;
    return b;
}

void csi_column_norms_buffers(size_t rows, size_t cols, bool complex_valued, csi_mem_tally *t)
{
    const size_t w = complex_valued ? 2 : 1;
    csi_mem_tally_add(t, rows * w * 4, "column-norm probe");
    csi_mem_tally_add(t, cols * w * 4, "column-norm probe image");
}

/* A workspace for A: its device buffers its own, or owner's (csi_solver_create_sharing). */
static csi_status solver_create(const csi_linop *A, const csi_solver *owner, csi_solver **out)
{
    *out = NULL;
    if (!A || !A->apply || !A->adjoint || !A->ctx)
        return csi_fail(CSI_ERR_ARG, "solver: no usable operator given");
    if (A->rows == 0 || A->cols == 0)
        return csi_fail(CSI_ERR_ARG, "solver: operator %s is %zu x %zu", A->name ? A->name : "?",
                        A->rows, A->cols);
    if (A->cols > 0x7fffffffu || A->rows > 0x7fffffffu)
        return csi_fail(CSI_ERR_ARG, "solver: operator %s (%zu x %zu) exceeds the 31-bit index range",
                        A->name ? A->name : "?", A->rows, A->cols);
    if (owner && (owner->borrowed || A->rows != owner->N || A->cols > owner->k ||
                  A->complex_valued != owner->cplx))
        return csi_fail(CSI_ERR_ARG, "solver: operator %s (%zu x %zu) cannot share the buffers of a "
                        "%zu x %zu workspace", A->name ? A->name : "?", A->rows, A->cols, owner->N, owner->k);
    csi_solver *S = calloc(1, sizeof *S);
    if (!S)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a solver");
    S->A = A;
    S->ctx = A->ctx;
    S->N = A->rows;
    S->k = A->cols;
    S->cplx = A->complex_valued;
    S->nfN = S->N * (S->cplx ? 2 : 1);
    S->nfk = S->k * (S->cplx ? 2 : 1);
    csi_status st = csi_vec_ws_create(S->ctx, &S->ws);
    struct {
        cl_mem *m;
        size_t bytes;
        const char *what;
    } b[] = {
        {&S->r, S->nfN * 4, "solver residual"},        {&S->q, S->nfN * 4, "solver measurement scratch"},
        {&S->Ax, S->nfN * 4, "solver A x"},            {&S->Axn, S->nfN * 4, "solver A x (trial)"},
        {&S->g, S->nfk * 4, "solver gradient"},        {&S->p, S->nfk * 4, "solver direction"},
        {&S->s, S->nfk * 4, "solver coefficient scratch"}, {&S->xn, S->nfk * 4, "solver trial iterate"},
        {&S->mask, S->k, "solver support mask"},
    };
    if (owner) {
        /* the same fields of the owner, in the order of b */
        const cl_mem mine[] = {owner->r, owner->q, owner->Ax, owner->Axn, owner->g, owner->p, owner->s, owner->xn,
                               owner->mask};
        for (size_t i = 0; i < sizeof b / sizeof *b; i++)
            *b[i].m = mine[i];
        S->borrowed = true;
    }
    for (size_t i = 0; !owner && st == CSI_OK && i < sizeof b / sizeof *b; i++)
        st = csi_buffer(S->ctx, b[i].bytes, CL_MEM_READ_WRITE, b[i].what, b[i].m);
    if (st == CSI_OK) {
        S->h_mask = calloc(S->k, 1);
        if (!S->h_mask)
            st = csi_fail(CSI_ERR_NOMEM, "out of host memory for a solver over %zu unknowns", S->k);
    }
    if (st != CSI_OK) {
        csi_solver_free(S);
        return st;
    }
    *out = S;
    return CSI_OK;
}

csi_status csi_solver_create(const csi_linop *A, csi_solver **out)
{
    return solver_create(A, NULL, out);
}

csi_status csi_solver_create_sharing(const csi_linop *A, const csi_solver *owner, csi_solver **out)
{
    if (!owner) {
        *out = NULL;
        return csi_fail(CSI_ERR_ARG, "solver: no workspace to share given");
    }
    return solver_create(A, owner, out);
}

static csi_status check_buf(cl_mem m, size_t need, const char *who, const char *what, size_t n)
{
    if (!m)
        return csi_fail(CSI_ERR_ARG, "%s: no %s buffer given", who, what);
    size_t have = 0;
    CSI_TRY(CSI_CL(clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof have, &have, NULL)));
    if (have < need)
        return csi_fail(CSI_ERR_ARG, "%s: the %s buffer holds %zu bytes, %zu elements need %zu", who, what,
                        have, n, need);
    return CSI_OK;
}

csi_status csi_solver_check_io(const csi_solver *S, cl_mem y, cl_mem x, const char *who)
{
    if (x == y && x)
        return csi_fail(CSI_ERR_ARG, "%s: x and y must be different buffers", who);
    CSI_TRY(check_buf(y, S->nfN * 4, who, "measurement (y)", S->N));
    return check_buf(x, S->nfk * 4, who, "solution (x)", S->k);
}

csi_status csi_solver_adjoint_amax(csi_solver *S, cl_mem y, double *hmax)
{
    CSI_TRY(check_buf(y, S->nfN * 4, "the tau reference", "measurement (y)", S->N));
    CSI_TRY(csi_linop_adjoint(S->A, y, S->g));
    CSI_TRY(csi_vec_amax(S->ws, S->k, S->cplx, S->g, hmax, NULL));
    if (!isfinite(*hmax))
        return csi_fail(CSI_ERR_NUMERIC, "A^H y has NaN or Inf (max %g)", *hmax);
    return CSI_OK;
}

cl_mem csi_solver_result_Ax(const csi_solver *S) { return S->result_Ax; }
cl_mem csi_solver_coef_scratch(const csi_solver *S, int i) { return i == 0 ? S->g : i == 1 ? S->p : NULL; }

csi_status csi_solver_romp_buffers(csi_solver *S)
{
    if (S->sel)
        return CSI_OK;
    struct {
        cl_mem *m;
        size_t bytes;
        const char *what;
    } b[] = {
        {&S->hist, ROMP_BINS * 4, "ROMP histogram"},   {&S->count, 4, "ROMP candidate count"},
        {&S->cand_idx, S->k * 4, "ROMP candidates"},   {&S->cand_val, S->k * 4, "ROMP candidate values"},
        {&S->sel, S->k * 4, "ROMP selection"},
    };
    csi_status st = CSI_OK;
    for (size_t i = 0; st == CSI_OK && i < sizeof b / sizeof *b; i++)
        if (!*b[i].m)
            st = csi_buffer(S->ctx, b[i].bytes, CL_MEM_READ_WRITE, b[i].what, b[i].m);
    if (st == CSI_OK && !S->h_val) {
        S->h_hist = malloc(ROMP_BINS * sizeof *S->h_hist);
        S->h_idx = malloc(S->k * sizeof *S->h_idx);
        S->h_sel = malloc(S->k * sizeof *S->h_sel);
        S->h_val = malloc(S->k * sizeof *S->h_val);
        if (!S->h_hist || !S->h_idx || !S->h_sel || !S->h_val) {
            free(S->h_hist);
            free(S->h_idx);
            free(S->h_sel);
            free(S->h_val);
            S->h_hist = S->h_idx = S->h_sel = NULL;
            S->h_val = NULL;
            st = csi_fail(CSI_ERR_NOMEM, "out of host memory for ROMP over %zu unknowns", S->k);
        }
    }
    if (st != CSI_OK)
        csi_buffer_release(&S->sel); /* retried next time; the others are reused */
    return st;
}

static csi_status apply(csi_solver *S, cl_mem x, cl_mem y, csi_solve_report *rep)
{
    rep->applies++;
    return csi_linop_apply(S->A, x, y);
}

static csi_status adjoint(csi_solver *S, cl_mem y, cl_mem x, csi_solve_report *rep)
{
    rep->adjoints++;
    return csi_linop_adjoint(S->A, y, x);
}

csi_status csi_residual(csi_solver *S, cl_mem y, cl_mem x, double *rnorm, csi_solve_report *rep)
{
    CSI_TRY(apply(S, x, S->q, rep));
    CSI_TRY(csi_vec_waxpby(S->ctx, S->nfN, 1.0f, y, -1.0f, S->q, S->r));
    return csi_vec_nrm2(S->ws, S->nfN, S->r, rnorm);
}

csi_status csi_cgls(csi_solver *S, cl_mem y, cl_mem x, cl_mem mask, int max_iter, double tol,
                    double r_target, int *iters, double *rnorm, csi_solve_report *rep)
{
    csi_ctx *ctx = S->ctx;
    double rn;
    *iters = 0;
    CSI_TRY(csi_residual(S, y, x, &rn, rep));
    *rnorm = rn;
    if (rn <= r_target || max_iter <= 0)
        return CSI_OK;
    /* s = A_I^H r; p = s */
    CSI_TRY(adjoint(S, S->r, S->s, rep));
    if (mask)
        CSI_TRY(csi_vec_mask(ctx, S->k, S->cplx, mask, S->s));
    CSI_TRY(csi_vec_copy(ctx, S->p, S->s, S->nfk));
    double gamma;
    CSI_TRY(csi_vec_dot(S->ws, S->nfk, S->s, S->s, &gamma));
    const double gamma0 = gamma;
    int it = 0;
    bool moved = false;
    while (it < max_iter && gamma > tol * tol * gamma0 && gamma > 0) {
        CSI_TRY(apply(S, S->p, S->q, rep)); /* q = A p */
        double qq;
        CSI_TRY(csi_vec_dot(S->ws, S->nfN, S->q, S->q, &qq));
        if (!(qq > 0) || !isfinite(qq))
            break; /* p in the null space (or a numerical failure): nothing more to gain */
        const double alpha = gamma / qq;
        CSI_TRY(csi_vec_axpy(ctx, S->nfk, (float)alpha, S->p, x));
        CSI_TRY(csi_vec_axpy(ctx, S->nfN, (float)-alpha, S->q, S->r));
        moved = true;
        it++;
        CSI_TRY(csi_vec_nrm2(S->ws, S->nfN, S->r, &rn));
        if (rn <= r_target)
            break;
        CSI_TRY(adjoint(S, S->r, S->s, rep));
        if (mask)
            CSI_TRY(csi_vec_mask(ctx, S->k, S->cplx, mask, S->s));
        double gnew;
        CSI_TRY(csi_vec_dot(S->ws, S->nfk, S->s, S->s, &gnew));
        const double beta = gnew / gamma;
        gamma = gnew;
        CSI_TRY(csi_vec_xpay(ctx, S->nfk, S->s, (float)beta, S->p)); /* p = s + beta p */
    }
    *iters = it;
    /* The recursively updated r drifts from y - A x in float: recompute it for the report and
     * for the next outer iteration. */
    if (moved)
        CSI_TRY(csi_residual(S, y, x, &rn, rep));
    *rnorm = rn;
    return CSI_OK;
}
