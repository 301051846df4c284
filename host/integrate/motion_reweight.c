/* Reweighted l1 for Alg. 2's solve (csi_recon_options.motion_reweight; Candes, Wakin & Boyd,
 * "Enhancing sparsity by reweighted l1 minimization", J. Fourier Anal. Appl. 14 (2008)
 * 877-905): after the l1 solve, re-solve with a weight per coefficient w_i = c / (|z_i| + eps)
 * from the previous solution z, warm-started, a given number of times.
 *
 * The weights are a column scaling, as the still layer's weight is (csi_half_fourier_set_still_gain):
 * the re-solve is the plain l1 problem on A G, G = diag(g), g_i = 1 / w_i, and z = G u of its
 * solution u; tau stays the unweighted problem's. The paper's problems are constrained (the
 * residual bounded), where the weights' scale does not matter; with a fixed tau it does, and c
 * is the scale that leaves the previous solution's penalty unchanged, sum w_i |z_i| = sum |z_i|:
 * the penalty moves from the large coefficients to the small ones and to those at zero (weight
 * c / eps), rather than shrinking overall, which fits the samples' noise (measured: weights of 1
 * at zero lost on path-traced samples, docs/bench/animation.md, session 11). eps is
 * motion_reweight_eps times the mean magnitude of the previous solution's non-zero
 * coefficients: a scale of the signal's own coefficients, as the paper asks of it. */
#include <math.h>
#include <stdlib.h>

#include "csi/solve.h"
#include "internal.h"

struct csi_motion_reweight {
    csi_linop G;       /* a real gain per coefficient; its state is this struct */
    csi_linop *AG;     /* A G, borrowing both */
    csi_solver *solver;
    cl_mem g;          /* cols floats */
    float *z, *gh;     /* the coefficients (2 cols floats) and the gains on the host */
    size_t cols;
};

/* out = G in: csi_half_weight with the whole vector as its period (one gain per coefficient).
 * G's state is the csi_motion_reweight that holds the gains. */
static csi_status gain_apply(const csi_linop *op, cl_mem in, cl_mem out)
{
    const csi_motion_reweight *rw = op->state;
    cl_kernel k;
    const cl_uint nn = (cl_uint)op->cols;
    CSI_TRY(csi_kernel(op->ctx, "sampling", "csi_half_weight", &k));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(rw->g), CSI_ARG(nn), CSI_ARG(nn)));
    return csi_run1d(op->ctx, k, op->cols);
}

void csi_motion_reweight_buffers(size_t rows, size_t cols, csi_mem_tally *t)
{
    csi_mem_tally_add(t, cols * 4, "the reweighted l1's gains");
    csi_linop_compose_buffers(cols, true, t);
    csi_solver_buffers(rows, cols, true, t);
}

uint64_t csi_motion_reweight_host_bytes(size_t rows, size_t cols)
{
    return (uint64_t)cols * 12 + csi_solver_host_bytes(rows, cols, true, false);
}

void csi_motion_reweight_free(csi_motion_reweight *rw)
{
    if (!rw)
        return;
    csi_solver_free(rw->solver);
    csi_linop_free(rw->AG);
    csi_buffer_release(&rw->g);
    free(rw->z);
    free(rw->gh);
    free(rw);
}

csi_status csi_motion_reweight_create(csi_linop *A, csi_motion_reweight **out)
{
    *out = NULL;
    csi_motion_reweight *rw = calloc(1, sizeof *rw);
    if (!rw)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the reweighted l1");
    rw->cols = A->cols;
    rw->G = (csi_linop){.rows = A->cols, .cols = A->cols, .complex_valued = true, .name = "G (reweighted l1's gains)",
                        .ctx = A->ctx, .apply = gain_apply, .adjoint = gain_apply /* real and diagonal */, .state = rw};
    csi_status s = csi_buffer(A->ctx, rw->cols * 4, CL_MEM_READ_WRITE, "the reweighted l1's gains", &rw->g);
    if (s == CSI_OK)
        s = csi_linop_compose("A G (reweighted l1)", A, &rw->G, false, &rw->AG);
    if (s == CSI_OK)
        s = csi_solver_create(rw->AG, &rw->solver);
    rw->z = malloc(rw->cols * 2 * sizeof *rw->z);
    rw->gh = malloc(rw->cols * sizeof *rw->gh);
    if (s == CSI_OK && (!rw->z || !rw->gh))
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the reweighted l1's %zu coefficients", rw->cols);
    if (s != CSI_OK) {
        csi_motion_reweight_free(rw);
        return s;
    }
    *out = rw;
    return CSI_OK;
}

/* The gains g_i = 1 / w_i from the coefficients in rw->z; false when there is nothing to weigh
 * (z = 0). */
static bool set_gains(csi_motion_reweight *rw, double eps_rel)
{
    double sum = 0;
    size_t nz = 0;
    for (size_t i = 0; i < rw->cols; i++) {
        const double m = hypot(rw->z[2 * i], rw->z[2 * i + 1]);
        if (m > 0) {
            sum += m;
            nz++;
        }
    }
    if (!nz)
        return false;
    const double eps = eps_rel * sum / (double)nz;
    double sw = 0;
    for (size_t i = 0; i < rw->cols; i++) {
        const double m = hypot(rw->z[2 * i], rw->z[2 * i + 1]);
        sw += m / (m + eps);
    }
    const double c = sum / sw;
    for (size_t i = 0; i < rw->cols; i++)
        rw->gh[i] = (float)((hypot(rw->z[2 * i], rw->z[2 * i + 1]) + eps) / c);
    return true;
}

csi_status csi_motion_reweight_run(csi_motion_reweight *rw, csi_recon_state *st, const csi_recon_options *opt,
                                   double tau_scale, csi_solve_report *rep)
{
    csi_ctx *ctx = st->A->ctx;
    const size_t n2 = rw->cols * 2;
    csi_solver *own = st->solver;
    const bool warm = st->warm;
    csi_status s = CSI_OK;
    for (int r = 0; r < opt->motion_reweight && s == CSI_OK; r++) {
        s = csi_read(ctx, st->x, 0, n2 * sizeof *rw->z, rw->z);
        if (s != CSI_OK || !set_gains(rw, opt->motion_reweight_eps))
            break;
        /* the start u = G^-1 z: the previous solution, in the weighted problem's coordinates */
        for (size_t i = 0; i < rw->cols; i++) {
            rw->z[2 * i] /= rw->gh[i];
            rw->z[2 * i + 1] /= rw->gh[i];
        }
        s = csi_write(ctx, rw->g, 0, rw->cols * sizeof *rw->gh, rw->gh);
        if (s == CSI_OK)
            s = csi_write(ctx, st->x, 0, n2 * sizeof *rw->z, rw->z);
        csi_solve_report r2;
        st->solver = rw->solver;
        st->warm = true;
        if (s == CSI_OK)
            s = csi_recon_run_solver(st, opt, tau_scale, &r2);
        st->solver = own;
        st->warm = warm;
        /* z = G u */
        if (s == CSI_OK)
            s = csi_read(ctx, st->x, 0, n2 * sizeof *rw->z, rw->z);
        for (size_t i = 0; s == CSI_OK && i < rw->cols; i++) {
            rw->z[2 * i] *= rw->gh[i];
            rw->z[2 * i + 1] *= rw->gh[i];
        }
        if (s == CSI_OK)
            s = csi_write(ctx, st->x, 0, n2 * sizeof *rw->z, rw->z);
        if (s == CSI_OK) {
            /* the report of the last solve, with every solve's work counted */
            r2.iterations += rep->iterations;
            r2.inner_iterations += rep->inner_iterations;
            r2.applies += rep->applies;
            r2.adjoints += rep->adjoints;
            r2.t_total += rep->t_total;
            *rep = r2;
        }
    }
    return s;
}
