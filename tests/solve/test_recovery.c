/* Exact recovery at the sizes: SpaRSA on a random partial Fourier operator
 * A = S F^H (complex; F^H the unitary inverse DFT from csi_fourier_create, S random rows),
 * k = 4096 (20 seeds), k = 65536 = 256 x 256 (4 seeds, for time) and a 3-D 32 x 32 x 16 volume
 * (3 seeds), N = 2 s ln(k/s); ROMP
 * (real) on a dense Gaussian at k = 4096, N = 4 s ln(k/s) (20 seeds); both below the bound
 * must report non-convergence.
 * y = A x_true is made with the operator itself (the Fourier operator is checked against numpy
 * in tests/unit/test_spectral.c). "Exact": relative error below 1e-4 (float32). */
#include <time.h>

#include "csi/spectral.h"
#include "problems.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

typedef struct {
    csi_linop *A;
    size_t k, N;
} pf_op;

static pf_op partial_fourier(test_rng *r, const size_t dims[3], size_t N)
{
    pf_op P = {0};
    P.k = dims[0] * dims[1] * dims[2];
    P.N = N;
    csi_linop *F = NULL, *S = NULL;
    uint32_t *rows = rand_subset(r, P.k, N);
    if (csi_fourier_create(test_ctx(), dims, &F) != CSI_OK ||
        csi_sampling_create(test_ctx(), P.k, rows, N, true, &S) != CSI_OK ||
        csi_linop_compose("S*F^H", S, F, true, &P.A) != CSI_OK)
        fprintf(stderr, "partial Fourier: %s\n", csi_last_error());
    free(rows);
    return P;
}

/* Returns the number of seeds recovered to 1e-4; counts claimed convergence in *conv. */
static int run_fourier(const size_t dims[3], size_t s, double factor, int seeds, int *conv, int *wrong_claims,
                       double *secs, double *steps)
{
    const size_t k = dims[0] * dims[1] * dims[2];
    const size_t N = (size_t)ceil(factor * s * log((double)k / s));
    int ok = 0;
    *conv = *wrong_claims = 0;
    *secs = *steps = 0;
    float *x = malloc(k * 8), *xo = malloc(k * 8);
    cl_mem dx = test_alloc(k * 8), dxt = test_alloc(k * 8), dy = test_alloc(N * 8);
    for (int seed = 0; seed < seeds; seed++) {
        test_rng r;
        test_rng_seed(&r, 1000 + seed);
        pf_op P = partial_fourier(&r, dims, N);
        memset(x, 0, k * 8);
        uint32_t *supp = rand_subset(&r, k, s);
        for (size_t i = 0; i < s; i++) {
            x[2 * supp[i]] = (float)test_rng_normal(&r);
            x[2 * supp[i] + 1] = (float)test_rng_normal(&r);
        }
        free(supp);
        CHECK_OK(csi_write(test_ctx(), dxt, 0, k * 8, x));
        CHECK_OK(csi_linop_apply(P.A, dxt, dy));
        csi_solve_report rep;
        double t0 = now();
        CHECK_OK(csi_sparsa(P.A, dy, dx, NULL, &rep));
        *secs += now() - t0;
        *steps += rep.iterations;
        test_download(dx, xo, k * 8);
        double e = test_rel_l2(xo, x, 2 * k);
        ok += e < 1e-4;
        *conv += rep.converged;
        *wrong_claims += rep.converged && !(e < 1e-3);
        CHECK(all_finite(xo, 2 * k), "finite output");
        csi_linop_free(P.A);
    }
    printf("SpaRSA partial Fourier k=%zu s=%zu N=%zu (%.1f s ln(k/s)): %d/%d recovered, %d converged, "
           "%.3f s and %.0f steps per solve\n", k, s, N, factor, ok, seeds, *conv, *secs / seeds, *steps / seeds);
    free(x);
    free(xo);
    csi_buffer_release(&dx);
    csi_buffer_release(&dxt);
    csi_buffer_release(&dy);
    return ok;
}

int main(void)
{
    int conv, wrong;
    double secs, steps;
    const size_t d1[3] = {4096, 1, 1}, d2[3] = {256, 256, 1};
    int ok = run_fourier(d1, 40, 2.0, 20, &conv, &wrong, &secs, &steps);
    CHECK(ok >= 19, "k=4096: %d of 20 recovered", ok);
    CHECK(wrong == 0, "k=4096: %d wrong convergence claims", wrong);
    ok = run_fourier(d2, 200, 2.0, 4, &conv, &wrong, &secs, &steps);
    CHECK(ok >= 4, "k=65536: %d of 4 recovered", ok);
    /* 3-D (x, y, t) as in the motion-blur problem: 32 x 32 x 16. */
    const size_t d3[3] = {32, 32, 16};
    ok = run_fourier(d3, 80, 2.0, 3, &conv, &wrong, &secs, &steps);
    CHECK(ok >= 3 && wrong == 0, "3-D k=16384: %d of 3 recovered", ok);
    /* Below the bound: N = 0.3 s ln(k/s): must not claim convergence. */
    ok = run_fourier(d1, 200, 0.3, 2, &conv, &wrong, &secs, &steps);
    CHECK(conv == 0 && wrong == 0, "below the bound: %d converged claims", conv);

    /* ROMP at k = 4096 on a dense Gaussian, N = 4 s ln(k/s). */
    {
        const size_t k = 4096, s = 20, N = (size_t)ceil(4.0 * s * log((double)k / s));
        int rok = 0, rconv = 0;
        double t = 0;
        float *xo = malloc(k * 4);
        for (uint64_t seed = 0; seed < 20; seed++) {
            test_rng r;
            test_rng_seed(&r, 2000 + seed);
            problem P = problem_make(&r, N, k, s, false, false, false);
            csi_romp_options o;
            csi_romp_defaults(&o);
            o.s = s;
            csi_solve_report rep;
            double t0 = now();
            CHECK_OK(csi_romp(P.op, P.dy, P.dx, &o, &rep));
            t += now() - t0;
            double e = problem_error(&P, xo);
            rok += e < 1e-4;
            rconv += rep.converged;
            CHECK(!rep.converged || e < 1e-3, "ROMP seed %llu converged with error %g", (unsigned long long)seed, e);
            problem_free(&P);
        }
        printf("ROMP Gaussian k=%zu s=%zu N=%zu: %d/20 recovered, %d converged, %.3f s per solve\n", k, s, N,
               rok, rconv, t / 20);
        CHECK(rok >= 19, "ROMP k=4096: %d of 20", rok);
        free(xo);
    }
    return test_done();
}
