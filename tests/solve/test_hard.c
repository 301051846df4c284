/* Hard cases for ROMP and SpaRSA (the user asked that they stay numerically stable): y = 0,
 * constant signals, one bright sample among zeros, values spanning 1e-4 to 1e4, N >= k, N below
 * the sparsity, tau above ||A^H y||_inf, NaN in y. Each: no NaN or Inf in x, the residual and
 * output bounded, and the status says what happened.
 *
 * "Bounded": ||A x|| <= 4 ||y|| (a least-squares or l1 fit never needs to overshoot the data by
 * much; a blow-up would be orders of magnitude) and ||x|| <= 1e3 ||x_true|| when x_true != 0. */
#include "problems.h"

static int solver_kind; /* 0 ROMP, 1 SpaRSA */

static csi_status solve(const problem *P, size_t s, csi_solve_report *rep)
{
    if (solver_kind == 0) {
        csi_romp_options o;
        csi_romp_defaults(&o);
        o.s = s;
        return csi_romp(P->op, P->dy, P->dx, &o, rep);
    }
    return csi_sparsa(P->op, P->dy, P->dx, NULL, rep);
}

static const char *name(void) { return solver_kind ? "SpaRSA" : "ROMP"; }

/* Checks finiteness and bounds; returns the relative error. */
static double check_output(const problem *P, const char *what, const csi_solve_report *rep)
{
    size_t nk = P->k * P->w;
    float *xo = malloc(nk * 4);
    test_download(P->dx, xo, nk * 4);
    bool fin = all_finite(xo, nk);
    CHECK(fin, "%s %s: non-finite output", name(), what);
    CHECK(isfinite(rep->rel_residual) && rep->rel_residual <= 4.0, "%s %s: residual %g", name(), what,
          rep->rel_residual);
    double nx = 0, nt = 0;
    for (size_t i = 0; i < nk; i++) {
        nx += (double)xo[i] * xo[i];
        nt += (double)P->x[i] * P->x[i];
    }
    if (nt > 0)
        CHECK(sqrt(nx) <= 1e3 * sqrt(nt), "%s %s: ||x|| = %g vs true %g", name(), what, sqrt(nx), sqrt(nt));
    CHECK(rep->message[0] != '\0', "%s %s: the report says what happened", name(), what);
    double e = test_rel_l2(xo, P->x, nk);
    printf("%-6s %-28s %-22s err %-9.3g res %-9.3g it %-4d | %s\n", name(), what,
           csi_solve_reason_name(rep->reason), e, rep->rel_residual, rep->iterations, rep->message);
    free(xo);
    return e;
}

int main(void)
{
    test_rng r;
    for (solver_kind = 0; solver_kind <= 1; solver_kind++) {
        csi_solve_report rep;
        /* y = 0 */
        {
            test_rng_seed(&r, 1);
            problem P = problem_make(&r, 60, 256, 5, false, false, false);
            memset(P.x, 0, 256 * 4);
            problem_measure(&P);
            CHECK_OK(csi_vec_fill(test_ctx(), P.dx, 256, 7.0f)); /* stale contents must go */
            CHECK_OK(solve(&P, 5, &rep));
            check_output(&P, "y = 0", &rep);
            float xo[256];
            test_download(P.dx, xo, sizeof xo);
            CHECK(rep.reason == CSI_SOLVE_ZERO && rep.converged && test_max_abs(xo, 256) == 0,
                  "%s y = 0: %s", name(), rep.message);
            problem_free(&P);
        }
        /* constant signal, fully sampled: A = S (N = k, a permutation), x = 3 everywhere */
        {
            const size_t k = 256;
            problem P = {0};
            P.N = P.k = k;
            P.w = 1;
            test_rng_seed(&r, 2);
            uint32_t *idx = rand_subset(&r, k, k);
            REQUIRE_OK(csi_sampling_create(test_ctx(), k, idx, k, false, &P.op));
            P.x = malloc(k * 4);
            P.y = malloc(k * 4);
            for (size_t i = 0; i < k; i++)
                P.x[i] = 3.0f;
            for (size_t i = 0; i < k; i++)
                P.y[i] = P.x[idx[i]];
            P.dy = test_upload(P.y, k * 4);
            P.dx = test_alloc(k * 4);
            CHECK_OK(solve(&P, 0, &rep));
            double e = check_output(&P, "constant, N = k", &rep);
            if (solver_kind == 1)
                CHECK(rep.converged && e < 1e-5, "SpaRSA recovers a constant when fully sampled: %g", e);
            else
                CHECK(rep.converged || rep.reason == CSI_SOLVE_SUPPORT_LIMIT, "ROMP: %s", rep.message);
            free(idx);
            csi_linop_free(P.op);
            free(P.x);
            free(P.y);
            csi_buffer_release(&P.dy);
            csi_buffer_release(&P.dx);
        }
        /* constant measurements through a Gaussian operator (not sparse: no exact answer) */
        {
            test_rng_seed(&r, 3);
            problem P = problem_make(&r, 80, 512, 1, false, false, false);
            for (size_t i = 0; i < 80; i++)
                P.y[i] = 5.0f;
            memset(P.x, 0, 512 * 4);
            CHECK_OK(csi_write(test_ctx(), P.dy, 0, 80 * 4, P.y));
            CHECK_OK(solve(&P, 10, &rep));
            check_output(&P, "constant y, Gaussian A", &rep);
            problem_free(&P);
        }
        /* one bright sample among zeros */
        {
            test_rng_seed(&r, 4);
            problem P = problem_make(&r, 40, 1024, 0, false, false, false);
            P.x[377] = 1e4f;
            problem_measure(&P);
            CHECK_OK(solve(&P, 1, &rep));
            double e = check_output(&P, "one bright sample", &rep);
            CHECK(rep.converged && e < 1e-4, "%s bright sample: error %g", name(), e);
            problem_free(&P);
        }
        /* values spanning 1e-4 .. 1e4 (9 magnitudes, random signs) */
        {
            test_rng_seed(&r, 5);
            problem P = problem_make(&r, 200, 1024, 0, false, false, false);
            uint32_t *supp = rand_subset(&r, 1024, 9);
            for (int i = 0; i < 9; i++)
                P.x[supp[i]] = (float)(pow(10.0, i - 4) * ((test_rng_u64(&r) & 1) ? 1 : -1));
            problem_measure(&P);
            CHECK_OK(solve(&P, 9, &rep));
            double e = check_output(&P, "HDR 1e-4 .. 1e4", &rep);
            /* ROMP fits the support exactly. SpaRSA's l1 term zeroes entries below about
             * tau = 1e-4 ||A^H y||_inf ~ 1, and those (1e-4 .. 1) weigh ~1e-4 of ||x|| = 1e4. */
            CHECK(e < (solver_kind ? 1e-3 : 1e-4), "%s HDR: error %g (%s)", name(), e, rep.message);
            free(supp);
            problem_free(&P);
        }
        /* N >= k */
        {
            test_rng_seed(&r, 6);
            problem P = problem_make(&r, 300, 256, 60, false, false, false);
            CHECK_OK(solve(&P, 60, &rep));
            double e = check_output(&P, "N >= k", &rep);
            CHECK(!rep.converged || e < 1e-3, "%s N >= k: converged with error %g", name(), e);
            problem_free(&P);
        }
        /* N below the sparsity */
        {
            test_rng_seed(&r, 7);
            problem P = problem_make(&r, 10, 512, 40, false, false, false);
            CHECK_OK(solve(&P, 40, &rep));
            check_output(&P, "N below sparsity", &rep);
            CHECK(!rep.converged, "%s N < s: claims convergence: %s", name(), rep.message);
            problem_free(&P);
        }
        /* x aliasing y, or a buffer too small: clear argument errors, nothing launched */
        {
            test_rng_seed(&r, 10);
            problem P = problem_make(&r, 30, 128, 3, false, false, false);
            cl_mem small = test_alloc(16);
            cl_mem keep = P.dx;
            P.dx = P.dy;
            csi_status st = solve(&P, 3, &rep);
            CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "different"), "%s aliasing: %s", name(),
                  csi_last_error());
            P.dx = small;
            st = solve(&P, 3, &rep);
            CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "solution (x)"), "%s small x: %s", name(),
                  csi_last_error());
            P.dx = keep;
            csi_buffer_release(&small);
            problem_free(&P);
        }
        /* NaN in y: a clear argument error */
        {
            test_rng_seed(&r, 8);
            problem P = problem_make(&r, 30, 128, 3, false, false, false);
            P.y[4] = NAN;
            CHECK_OK(csi_write(test_ctx(), P.dy, 0, 30 * 4, P.y));
            csi_status st = solve(&P, 3, &rep);
            CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "NaN"), "%s NaN in y: %s", name(),
                  csi_last_error());
            problem_free(&P);
        }
    }
    /* SpaRSA complex: bright sample and tau above max. */
    {
        solver_kind = 1;
        test_rng r2;
        test_rng_seed(&r2, 9);
        problem P = problem_make(&r2, 40, 512, 0, true, false, false);
        P.x[2 * 100] = 3e3f;
        P.x[2 * 100 + 1] = -4e3f;
        problem_measure(&P);
        csi_solve_report rep;
        CHECK_OK(csi_sparsa(P.op, P.dy, P.dx, NULL, &rep));
        double e = check_output(&P, "complex bright sample", &rep);
        CHECK(rep.converged && e < 1e-4, "complex bright sample: %g", e);
        csi_sparsa_options o;
        csi_sparsa_defaults(&o);
        o.tau = 5e3 * 1.01 * 1.5; /* above ||A^H y||_inf ~ 5e3 |a_j|^2, |a_j| ~ 1 */
        CHECK_OK(csi_sparsa(P.op, P.dy, P.dx, &o, &rep));
        check_output(&P, "complex tau above max", &rep);
        CHECK(rep.reason == CSI_SOLVE_ZERO, "tau above max: %s", rep.message);
        problem_free(&P);
    }
    return test_done();
}
