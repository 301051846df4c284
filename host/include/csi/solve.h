/* Sparse recovery solvers on operators: ROMP and SpaRSA.
 *
 * Both solve y ~ A x for a sparse x, seeing only the operator pair (A, A^H) (csi/linop.h), the
 * measurement vector y (A->rows elements, device buffer) and options; x (A->cols elements) is
 * written on the device. All vector work runs in OpenCL kernels (csi/vec.h); the host only
 * steers (scalars, the small candidate lists of ROMP).
 *
 * - ROMP: Needell & Vershynin, "Uniform uncertainty principle and signal recovery via
 *   regularized orthogonal matching pursuit", Found. Comput. Math. 9 (2009) 317-334
 *   (arXiv 0707.4203, 2007). Real-valued operators only.
 * - SpaRSA: Wright, Nowak & Figueiredo, "Sparse reconstruction by separable approximation",
 *   IEEE Trans. Signal Process. 57(7) (2009) 2479-2493. Real and complex operators; minimises
 *   0.5 ||y - A x||_2^2 + tau ||x||_1 (complex: |x_i| is the complex magnitude).
 *
 * Every call fills a csi_solve_report: a solver that stops without meeting its criterion, or
 * whose answer is not identifiable from the measurements (more non-zeros than N / 2, so another
 * equally sparse x fits y as well; only checked when N < k), says so in `converged` / `reason` / `message`: results below
 * the recovery bound are never silently presented as converged.
 *
 * Multi-channel (RGB): make one csi_solver for the operator and call csi_romp_run /
 * csi_sparsa_run per channel (or csi_romp_multi / csi_sparsa_multi), which reuses every buffer;
 * nothing is rebuilt per channel. docs/bench/solve.md has the measurements behind this choice. */
#ifndef CSI_SOLVE_H
#define CSI_SOLVE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/linop.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Progress: called after every outer iteration (and each debiasing / least-squares phase) with
 * the phase name ("romp", "sparsa", "debias"), the iteration count so far and the current
 * relative residual ||y - A x|| / ||y||. May be NULL. Returning false cancels the solve: it
 * returns CSI_ERR_CANCELLED at once (x holds the last iterate). */
typedef bool (*csi_solve_progress_fn)(void *user, const char *phase, int iter, double rel_residual);

typedef enum csi_solve_reason {
    CSI_SOLVE_CONVERGED = 0,     /* the stopping criterion was met */
    CSI_SOLVE_ZERO,              /* x = 0 is the exact answer (y = 0, or tau >= ||A^H y||_inf) */
    CSI_SOLVE_MAX_ITER,          /* the iteration cap was reached first */
    CSI_SOLVE_SUPPORT_LIMIT,     /* ROMP: the support reached its limit (2s) above tolerance */
    CSI_SOLVE_NOT_IDENTIFIABLE,  /* x fits, but has more than N/2 non-zeros: not unique */
    CSI_SOLVE_STALLED,           /* no further progress possible (no candidate / no step) */
} csi_solve_reason;

const char *csi_solve_reason_name(csi_solve_reason r);

typedef struct csi_solve_report {
    bool converged;            /* reason is CONVERGED or ZERO */
    csi_solve_reason reason;
    char message[200];         /* one line: what happened, with the numbers */
    int iterations;            /* ROMP: support-growth steps; SpaRSA: accepted steps, all stages */
    int inner_iterations;      /* CG iterations (ROMP's least squares, SpaRSA's debiasing) */
    int stages;                /* SpaRSA: continuation stages run (1 without continuation) */
    int applies, adjoints;     /* operator calls */
    double rel_residual;       /* ||y - A x|| / ||y|| of the returned x (0 when y = 0) */
    double objective;          /* ROMP: 0.5 ||y - A x||^2; SpaRSA: 0.5||y - Ax||^2 + tau||x||_1
                                  at the end of the l1 phase (before debiasing) */
    double rel_gap;            /* SpaRSA: duality gap / objective at the end of the l1 phase */
    double tau;                /* SpaRSA: the tau used */
    double alpha;              /* SpaRSA: the Barzilai-Borwein alpha the next step would take */
    double tau_next;           /* SpaRSA ended by stop_tau: the tau of the stage it did not run */
    size_t support;            /* non-zeros of the returned x (ROMP: size of the support set) */
    /* seconds per phase (wall clock, device work included) */
    double t_total, t_select, t_lsq, t_step, t_debias;
} csi_solve_report;

/* ---- workspace: all buffers for one operator, reused across solves and channels ---- */
typedef struct csi_solver csi_solver;
csi_status csi_solver_create(const csi_linop *A, csi_solver **out);
/* A workspace for A on the device buffers of owner's (A with owner's rows, at most its columns,
 * both real or both complex): no device memory of its own. Runs on the two must not interleave
 * (each overwrites the other's state, and owner's csi_solver_result_Ax); owner must outlive it. */
csi_status csi_solver_create_sharing(const csi_linop *A, const csi_solver *owner, csi_solver **out);
void csi_solver_free(csi_solver *s);
/* What a workspace for a rows x cols operator holds: the device buffers csi_solver_create
 * allocates, and those ROMP's first run adds (csi_solver_romp_tally), added to a tally
 * (csi/runtime.h); and its host arrays' bytes (with romp: ROMP's too), at most. */
void csi_solver_buffers(size_t rows, size_t cols, bool complex_valued, csi_mem_tally *t);
void csi_solver_romp_tally(size_t cols, csi_mem_tally *t);
uint64_t csi_solver_host_bytes(size_t rows, size_t cols, bool complex_valued, bool romp);
/* ||A^H y||_inf of the workspace's operator as it is now (SpaRSA's reference for tau_rel), into
 * *hmax; the workspace's gradient buffer is its scratch. For a caller that takes tau from the
 * operator before a change that keeps its sizes (a column scaling, csi/sampled_half_fourier.h). */
csi_status csi_solver_adjoint_amax(csi_solver *s, cl_mem y, double *hmax);
/* The workspace's buffer that holds A x for the x its last run returned (rows floats, complex
 * interleaved), or NULL where the run did not leave it (ROMP, SpaRSA's debiasing or x = 0
 * shortcuts). SpaRSA computes A x of every accepted iterate, so a caller that needs A x of the
 * result (the image correction's estimate at the samples) reads it here instead of applying A
 * again: the same operator on the same x, so the same bits. Valid until the next run. */
cl_mem csi_solver_result_Ax(const csi_solver *s);
/* One of two coefficient buffers of the workspace (i = 0, 1: cols floats, complex interleaved;
 * neither the one csi_solver_result_Ax returns) that a run uses only while it runs: between runs
 * a caller may use them as its own scratch (Alg. 1's integration images), and the next run
 * overwrites them. NULL for any other i. */
cl_mem csi_solver_coef_scratch(const csi_solver *s, int i);

/* ---- ROMP ---------------------------------------------------------------------------------
 * Each iteration: u = A^H r; J = the s largest |u_i| among indices not yet in the support I
 * (chosen on the device by an exact radix select over the float bits of |u_i|, then only the
 * ~s candidates come to the host); the regularisation step: among J sorted by magnitude, the
 * subsets of comparable coordinates (|u_i| <= 2 |u_j| for all i, j in it) are windows of the
 * sorted list, and the window of largest energy sum u_i^2 is J0; I = I u J0 (an index is never
 * selected twice: selection skips I, and the host checks); x = argmin ||y - A x|| over x
 * supported on I by CGLS (CG on the normal equations through A and A^H), warm-started from the
 * previous x, at most lsq_iter iterations; r = y - A x. With seed_support, I starts as that set
 * and x as its least-squares fit. Stops when ||r|| <= tol ||y||
 * (converged), when |I| >= 2s (SUPPORT_LIMIT; max_support overrides 2s), at max_iter (MAX_ITER) or when no candidate is
 * left (STALLED). A fit with |I| > N/2 is reported NOT_IDENTIFIABLE. */
typedef struct csi_romp_options {
    size_t s;            /* sparsity level. 0: the largest s with 2 s ln(k/s) <= N and s <= N/4
                            (the sparsity N measurements support at twice the s log(k/s)
                            bound), at least 1 */
    double tol;          /* relative residual target, default 1e-5 (float32 data) */
    size_t max_support;  /* support size that ends the run; 0: 2s (the published rule) */
    int max_iter;        /* 0: max_support + 10 (each iteration adds >= 1 index) */
    int lsq_iter;        /* CG iterations per least-squares solve, default 60 */
    double lsq_tol;      /* CG stops when ||A_I^H r|| falls by this factor, default 1e-6 */
    csi_solve_progress_fn progress;
    void *user;
    cl_mem col_norms;        /* optional (NULL): k floats, ||A e_i||. When given, selection ranks
                                |u_i| / ||A e_i|| (ROMP on the column-normalised operator A D,
                                D = diag(1/||A e_i||); x = D z, and the least squares are
                                unchanged); a zero norm excludes index i. Operators whose columns
                                differ in norm (point samples of wavelets: fine-scale wavelets on
                                a sample dominate raw correlations) need this; see
                                csi_column_norms and docs/bench/solve.md. */
    uint32_t *support_log;   /* optional: receives the selected indices in selection order */
    size_t support_log_cap;  /* its capacity (entries beyond it are not written) */
    const uint32_t *seed_support; /* optional (NULL): indices put in the support I before the
                                     first iteration (csi's extension, not in Needell &
                                     Vershynin): e.g. the coarse scaling block of a wavelet
                                     basis, which raw correlations never pick on point samples
                                     (docs/bench/romp.md). The least squares on them run first;
                                     selection never returns them. The support limit
                                     (max_support, or 2s) counts the selected indices only;
                                     csi_solve_report.support counts both. Each index < k, no
                                     repeats, else CSI_ERR_ARG. Not written to support_log. */
    size_t seed_count;
} csi_romp_options;
void csi_romp_defaults(csi_romp_options *o);
/* The default s for N measurements of k unknowns (see csi_romp_options.s). */
size_t csi_romp_default_s(size_t N, size_t k);

csi_status csi_romp_run(csi_solver *s, cl_mem y, cl_mem x, const csi_romp_options *o,
                        csi_solve_report *rep);
/* One-shot: makes a workspace, solves, frees it. */
csi_status csi_romp(const csi_linop *A, cl_mem y, cl_mem x, const csi_romp_options *o,
                    csi_solve_report *rep);
/* nrhs channels over one operator and one workspace: y[c] -> x[c], reports rep[c]. */
csi_status csi_romp_multi(const csi_linop *A, size_t nrhs, const cl_mem *y, const cl_mem *x,
                          const csi_romp_options *o, csi_solve_report *rep);

/* Estimates the column norms ||A e_i|| of any operator into norms (A->cols floats) from
 * `probes` random sign vectors z: E |(A^H z)_i|^2 = ||A e_i||^2 (Hutchinson-style probing), with
 * relative standard deviation at most sqrt(2 / probes) per column (18% at 64 probes: enough to
 * rank correlations); columns A cannot see come out exactly 0. Costs `probes` adjoints.
 * Deterministic for a given seed. */
csi_status csi_column_norms(const csi_linop *A, int probes, uint64_t seed, cl_mem norms);
/* The device buffers csi_column_norms allocates while it runs (and frees before returning). */
void csi_column_norms_buffers(size_t rows, size_t cols, bool complex_valued, csi_mem_tally *t);

/* ---- SpaRSA -------------------------------------------------------------------------------
 * Iteration (WNF09 Alg. 1 for the l1 regulariser): x+ = soft(x - g/alpha, tau/alpha) with
 * g = A^H (A x - y); alpha starts from the Barzilai-Borwein value ||A s||^2 / ||s||^2
 * (s = x_k - x_{k-1}) clamped to [alpha_min, alpha_max] and is multiplied by eta = 2 until the
 * acceptance test holds: phi(x+) <= max_{i = max(k-M,0)..k} phi(x_i) - (sigma/2) alpha ||x+ - x||^2
 * (safeguarded non-monotone, M = 5, sigma = 0.01; M = 0 is the monotone variant).
 * Adaptive continuation (WNF09 Sec. II-E): tau_0 = max(cont_factor ||A^H y||_inf, tau), after
 * each stage tau_{j+1} = max(cont_factor ||A^H r||_inf, tau); with cont_step > 0 a geometric
 * schedule instead, tau_{j+1} = max(cont_step tau_j, tau); intermediate stages stop at
 * cont_tol, the last at tol. Stopping: STOP_OBJECTIVE, 0 <= (phi_{k-1} - phi_k) / phi_{k-1} <= tol
 * (a step that raised phi, which the non-monotone acceptance allows, never stops a stage);
 * STOP_GAP, the duality gap (with the feasible dual point w = r min(1, tau / ||A^H r||_inf))
 * divided by phi <= tol, or the gap below its float32 rounding level 32 u ||y||^2 (u = 2^-24)
 * and not halved for 10 steps (float32 cannot resolve it further), or the gap not halved for
 * 100 steps over which phi fell by at most tol phi (the rounding of A^H r can hold the gap
 * above that level: the iterate has stopped moving, and the stage would run to the cap).
 * Debiasing: CGLS on the non-zero set of x (skipped when it has more
 * than N/2 elements, reported NOT_IDENTIFIABLE). tau >= ||A^H y||_inf: x = 0 at once (ZERO). */
typedef enum { CSI_SPARSA_STOP_GAP = 0, CSI_SPARSA_STOP_OBJECTIVE = 1 } csi_sparsa_stop;

typedef struct csi_sparsa_step {
    int iter, stage;
    double tau, alpha;          /* alpha of the accepted step */
    double phi;                 /* objective at the accepted x+ */
    double phi_ref;             /* max of the last M+1 objective values (phi_k when M = 0) */
    double dx2;                 /* ||x+ - x_k||^2 */
    int trials;                 /* alpha increases before acceptance */
    cl_mem x;                   /* the accepted iterate (read-only, valid during the call) */
} csi_sparsa_step;

typedef struct csi_sparsa_options {
    double tau;              /* absolute tau > 0; 0: tau_rel * ||A^H y||_inf */
    double tau_rel;          /* default 1e-4 */
    int memory;              /* M: 5 (safeguarded non-monotone); 0 = monotone */
    double sigma;            /* 0.01 */
    double eta;              /* alpha growth factor on rejection, 2 */
    double alpha_min, alpha_max; /* BB clamps, 1e-30 and 1e30 (WNF09's code) */
    csi_sparsa_stop stop;    /* default CSI_SPARSA_STOP_GAP */
    double tol;              /* default 1e-5 */
    int max_iter;            /* accepted steps over all stages, default 2000 */
    int max_trials;          /* alpha increases per step before STALLED, default 60 */
    bool continuation;       /* default true */
    bool warm_start;         /* start from the x passed in (default false: from x = 0); the
                                start costs one apply and one adjoint more */
    double cont_factor;      /* 0.2 */
    double cont_step;        /* 0 (default): the adaptive rule; in (0, 1): each stage's tau is
                                cont_step times the previous one's */
    double cont_tol;         /* tolerance of intermediate stages, default 1e-3 */
    double stop_tau;         /* > 0: end before the first stage whose tau is at or below it (that
                                tau in the report's tau_next): the caller runs the rest elsewhere
                                (Alg. 1's coarse start); 0 (default): run every stage */
    double start_tau;        /* with continuation, > 0: the first stage's tau (0, the default:
                                cont_factor ||A^H y||_inf) */
    double alpha0;           /* the first step's alpha; 0 (default): 1, as WNF09's code */
    bool debias;             /* default true */
    int debias_iter;         /* CG iterations, default 200 */
    double debias_tol;       /* CG relative tolerance, default 1e-6 */
    csi_solve_progress_fn progress;
    void *user;
    void (*trace)(void *user, const csi_sparsa_step *step); /* every accepted step; may be NULL */
} csi_sparsa_options;
void csi_sparsa_defaults(csi_sparsa_options *o);

csi_status csi_sparsa_run(csi_solver *s, cl_mem y, cl_mem x, const csi_sparsa_options *o,
                          csi_solve_report *rep);
csi_status csi_sparsa(const csi_linop *A, cl_mem y, cl_mem x, const csi_sparsa_options *o,
                      csi_solve_report *rep);
csi_status csi_sparsa_multi(const csi_linop *A, size_t nrhs, const cl_mem *y, const cl_mem *x,
                            const csi_sparsa_options *o, csi_solve_report *rep);

#ifdef __cplusplus
}
#endif
#endif
