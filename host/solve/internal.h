/* Shared internals of the solvers: the workspace and the masked least-squares step. */
#ifndef CSI_SOLVE_INTERNAL_H
#define CSI_SOLVE_INTERNAL_H

#include <stdio.h>

#include "csi/solve.h"
#include "csi/vec.h"

struct csi_solver {
    const csi_linop *A;
    csi_ctx *ctx;
    csi_vec_ws *ws;
    size_t N, k;        /* rows, cols (elements) */
    size_t nfN, nfk;    /* floats per vector on each side */
    bool cplx;
    /* measurement side (N) */
    cl_mem r, q, Ax, Axn;
    cl_mem result_Ax;   /* Ax or Axn when it holds A x of the x the last run returned, or NULL */
    /* coefficient side (k) */
    cl_mem g, p, s, xn;
    cl_mem mask;        /* k bytes: support (ROMP) / non-zero set (debiasing) */
    bool borrowed;      /* the buffers above are another workspace's (csi_solver_create_sharing) */
    /* ROMP selection: made on the first ROMP run (csi_solver_romp_buffers), so SpaRSA on a
     * large volume does not pay for them */
    cl_mem hist, count, cand_idx, cand_val, sel;
    uint32_t *h_hist, *h_idx, *h_sel;
    float *h_val;
    unsigned char *h_mask;
};

double csi_solve_now(void);

/* Checks the caller's y (N elements) and x (k elements): present, distinct, large enough. */
csi_status csi_solver_check_io(const csi_solver *S, cl_mem y, cl_mem x, const char *who);

/* Allocates ROMP's selection buffers if not yet there. */
csi_status csi_solver_romp_buffers(csi_solver *S);

/* CGLS (CG on A_I^H A_I z = A_I^H y, Hestenes & Stiefel 1952; Bjorck, "Numerical Methods for
 * Least Squares Problems", 1996, Alg. 7.4.1) with A_I = A restricted to mask (NULL: all of A).
 * x is the warm start (zero outside the mask) and the result. Stops after max_iter iterations,
 * when ||A_I^H r|| <= tol ||A_I^H r_0||, or when ||r|| <= r_target. On return S->r = y - A x,
 * recomputed explicitly, and *rnorm = ||r||. Counts calls into rep. */
csi_status csi_cgls(csi_solver *S, cl_mem y, cl_mem x, cl_mem mask, int max_iter, double tol,
                    double r_target, int *iters, double *rnorm, csi_solve_report *rep);

/* r = y - A x into S->r (one apply) and its norm. */
csi_status csi_residual(csi_solver *S, cl_mem y, cl_mem x, double *rnorm, csi_solve_report *rep);

void csi_report_init(csi_solve_report *rep);
void csi_report_set(csi_solve_report *rep, csi_solve_reason reason, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif
