/* ROMP's seeded support (csi_romp_options.seed_support, csi's extension for the coarse wavelet
 * band): the seeded indices are in the support from the start (the least squares uses them:
 * seeding the true support recovers the signal with no selection at all), selection never
 * returns a seeded index even when the seeded columns still correlate strongly with the
 * residual (one CG step, so the fit on them is far from converged), the support count covers
 * seeds and selections, and bad seed lists are refused.
 *
 * Tolerances: "recovered" is relative error below 1e-4 (float32 data, least squares solved to
 * tol 1e-5 relative on a well-conditioned Gaussian submatrix, as in test_romp.c); "zero
 * outside the support" is exact (the least squares is masked: x stays 0 off the support). */
#include "problems.h"

static bool in_set(uint32_t j, const uint32_t *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (v[i] == j)
            return true;
    return false;
}

/* Indices of the non-zeros of the true signal, in increasing order; returns their count. */
static size_t true_support(const problem *P, uint32_t *out)
{
    size_t m = 0;
    for (size_t j = 0; j < P->k; j++)
        if (P->x[j] != 0)
            out[m++] = (uint32_t)j;
    return m;
}

int main(void)
{
    test_rng r;
    const size_t k = 512, s = 12, N = 160;
    float *xo = malloc(k * 4);
    uint32_t *log = malloc(k * sizeof *log), ts[64], seeds[64];

    /* 1. Seeding the whole true support: x is its least-squares fit, which is the signal, and
     *    ROMP stops before selecting anything. Only possible if the seeds are in the support. */
    {
        test_rng_seed(&r, 401);
        problem P = problem_make(&r, N, k, s, false, false, false);
        size_t m = true_support(&P, ts);
        csi_romp_options o;
        csi_romp_defaults(&o);
        o.s = s;
        o.seed_support = ts;
        o.seed_count = m;
        o.support_log = log;
        o.support_log_cap = k;
        csi_solve_report rep;
        CHECK_OK(csi_romp(P.op, P.dy, P.dx, &o, &rep));
        double e = problem_error(&P, xo);
        CHECK(rep.converged && rep.iterations == 0 && rep.support == m,
              "seeded with the true support: converged %d, %d iterations, support %zu (want %zu): %s",
              rep.converged, rep.iterations, rep.support, m, rep.message);
        CHECK(e < 1e-4, "seeded with the true support: error %g", e);
        problem_free(&P);
    }

    /* 2. Seeds = half the true support plus 4 wrong indices, one CG step per least squares:
     *    the seeded columns keep large correlations with the residual, so only the mask keeps
     *    them out of the candidates. Over 5 problems: no selected index is a seed or repeats,
     *    x is zero outside seeds + selections, and the support count adds both. */
    for (uint64_t seed = 410; seed < 415; seed++) {
        test_rng_seed(&r, seed);
        problem P = problem_make(&r, N, k, s, false, false, false);
        size_t m = true_support(&P, ts), ns = 0;
        for (size_t i = 0; i < m; i += 2)
            seeds[ns++] = ts[i];
        for (uint32_t j = 0; ns < m / 2 + 4 + (m & 1); j++)
            if (P.x[j] == 0)
                seeds[ns++] = j;
        csi_romp_options o;
        csi_romp_defaults(&o);
        o.s = 3 * s; /* many candidates per step: a seed would be among them if not masked */
        o.lsq_iter = 1;
        o.max_support = 2 * s;
        o.seed_support = seeds;
        o.seed_count = ns;
        o.support_log = log;
        o.support_log_cap = k;
        csi_solve_report rep;
        CHECK_OK(csi_romp(P.op, P.dy, P.dx, &o, &rep));
        CHECK(rep.support >= ns, "seed %llu: support %zu below the %zu seeds", (unsigned long long)seed,
              rep.support, ns);
        size_t sel = rep.support - ns, reselected = 0, repeats = 0;
        CHECK(sel > 0 && sel <= k, "seed %llu: %zu selections (one CG step cannot fit y)", (unsigned long long)seed, sel);
        for (size_t i = 0; i < sel && i < k; i++) {
            reselected += in_set(log[i], seeds, ns);
            repeats += in_set(log[i], log, i);
        }
        CHECK(reselected == 0 && repeats == 0, "seed %llu: %zu seeds re-selected, %zu repeats",
              (unsigned long long)seed, reselected, repeats);
        test_download(P.dx, xo, k * 4);
        size_t outside = 0;
        for (uint32_t j = 0; j < k; j++)
            if (xo[j] != 0 && !in_set(j, seeds, ns) && !in_set(j, log, sel))
                outside++;
        CHECK(outside == 0, "seed %llu: %zu non-zeros outside seeds + selections", (unsigned long long)seed,
              outside);
        problem_free(&P);
    }

    /* 3. The same seeds with full least squares: ROMP completes the support and recovers x
     *    (the wrong seeds end at ~0), on all 5 problems. */
    {
        int ok = 0;
        for (uint64_t seed = 410; seed < 415; seed++) {
            test_rng_seed(&r, seed);
            problem P = problem_make(&r, N, k, s, false, false, false);
            size_t m = true_support(&P, ts), ns = 0;
            for (size_t i = 0; i < m; i += 2)
                seeds[ns++] = ts[i];
            for (uint32_t j = 0; ns < m / 2 + 4 + (m & 1); j++)
                if (P.x[j] == 0)
                    seeds[ns++] = j;
            csi_romp_options o;
            csi_romp_defaults(&o);
            o.s = s;
            o.seed_support = seeds;
            o.seed_count = ns;
            csi_solve_report rep;
            CHECK_OK(csi_romp(P.op, P.dy, P.dx, &o, &rep));
            double e = problem_error(&P, xo);
            ok += rep.converged && e < 1e-4;
            problem_free(&P);
        }
        CHECK(ok == 5, "seeded ROMP recovered %d of 5", ok);
    }

    /* 4. Bad seed lists: a repeat, an index >= k, a count without a list. */
    {
        test_rng_seed(&r, 420);
        problem P = problem_make(&r, 64, 128, 4, false, false, false);
        csi_romp_options o;
        csi_romp_defaults(&o);
        csi_solve_report rep;
        uint32_t rep_list[3] = {5, 9, 5}, big[2] = {3, 128};
        o.seed_support = rep_list;
        o.seed_count = 3;
        CHECK(csi_romp(P.op, P.dy, P.dx, &o, &rep) == CSI_ERR_ARG, "a repeated seed is refused");
        o.seed_support = big;
        o.seed_count = 2;
        CHECK(csi_romp(P.op, P.dy, P.dx, &o, &rep) == CSI_ERR_ARG, "a seed >= k is refused");
        o.seed_support = NULL;
        o.seed_count = 1;
        CHECK(csi_romp(P.op, P.dy, P.dx, &o, &rep) == CSI_ERR_ARG, "a seed count without a list is refused");
        problem_free(&P);
    }
    free(xo);
    free(log);
    return test_done();
}
