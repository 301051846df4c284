/* Synthetic sparse-recovery problems for the solver tests: Gaussian matrices (as dense
 * operators, optionally through the sampling operator), s-sparse signals, seeded. */
#ifndef CSI_TEST_PROBLEMS_H
#define CSI_TEST_PROBLEMS_H

#include <stdlib.h>
#include <string.h>

#include "csi/dense.h"
#include "csi/linop.h"
#include "csi/sampling.h"
#include "csi/solve.h"
#include "csi/vec.h"
#include "testlib.h"

typedef struct {
    size_t N, k, w;  /* w = 1 real, 2 complex */
    float *A;        /* N x k (row-major, interleaved when complex), entries N(0, 1/N) */
    double *Ad;      /* the same in double, for the references */
    float *x;        /* true signal (k w) */
    float *y;        /* A x in double, rounded (N w) */
    csi_linop *op;
    cl_mem dy, dx;
} problem;

/* n distinct indices in [0, k) (partial Fisher-Yates). */
static inline uint32_t *rand_subset(test_rng *r, size_t k, size_t n)
{
    uint32_t *p = malloc(k * sizeof *p);
    for (size_t i = 0; i < k; i++)
        p[i] = (uint32_t)i;
    for (size_t i = 0; i < n; i++) {
        size_t j = i + test_rng_u64(r) % (k - i);
        uint32_t t = p[i];
        p[i] = p[j];
        p[j] = t;
    }
    return p;
}

/* Fills y = A x (double accumulation) and uploads it. */
static inline void problem_measure(problem *P)
{
    for (size_t i = 0; i < P->N; i++) {
        double sr = 0, si = 0;
        for (size_t j = 0; j < P->k; j++) {
            if (P->w == 2) {
                double ar = P->Ad[2 * (i * P->k + j)], ai = P->Ad[2 * (i * P->k + j) + 1];
                sr += ar * P->x[2 * j] - ai * P->x[2 * j + 1];
                si += ar * P->x[2 * j + 1] + ai * P->x[2 * j];
            } else {
                sr += P->Ad[i * P->k + j] * P->x[j];
            }
        }
        P->y[i * P->w] = (float)sr;
        if (P->w == 2)
            P->y[2 * i + 1] = (float)si;
    }
    if (!P->dy)
        P->dy = test_alloc(P->N * P->w * 4);
    if (csi_write(test_ctx(), P->dy, 0, P->N * P->w * 4, P->y) != CSI_OK)
        fprintf(stderr, "upload failed: %s\n", csi_last_error());
}

/* Gaussian N x k operator. via_sampling: A = S G with G a k x k Gaussian and S picking N of
 * its rows at random (the structure of the paper's A = S Psi), else a dense N x k Gaussian
 * (the same distribution, cheaper to apply). Signal: s-sparse, entries N(0,1) (or, with
 * unit_mag, random signs of magnitude 1: the hard case for greedy methods). */
static inline problem problem_make(test_rng *r, size_t N, size_t k, size_t s, bool cplx, bool via_sampling,
                            bool unit_mag)
{
    problem P = {0};
    P.N = N;
    P.k = k;
    P.w = cplx ? 2 : 1;
    P.A = malloc(N * k * P.w * sizeof *P.A);
    P.Ad = malloc(N * k * P.w * sizeof *P.Ad);
    P.x = calloc(k * P.w, sizeof *P.x);
    P.y = malloc(N * P.w * sizeof *P.y + 4);
    const double sc = 1.0 / sqrt((double)N * (double)P.w);
    if (via_sampling) {
        float *G = malloc(k * k * P.w * sizeof *G);
        for (size_t i = 0; i < k * k * P.w; i++)
            G[i] = (float)(sc * test_rng_normal(r));
        uint32_t *rows = rand_subset(r, k, N);
        for (size_t i = 0; i < N; i++)
            memcpy(P.A + i * k * P.w, G + (size_t)rows[i] * k * P.w, k * P.w * sizeof *G);
        csi_linop *Gop = NULL, *S = NULL;
        if (csi_dense_create(test_ctx(), k, k, G, cplx, &Gop) != CSI_OK ||
            csi_sampling_create(test_ctx(), k, rows, N, cplx, &S) != CSI_OK ||
            csi_linop_compose("S*G", S, Gop, true, &P.op) != CSI_OK)
            fprintf(stderr, "operator: %s\n", csi_last_error());
        free(G);
        free(rows);
    } else {
        for (size_t i = 0; i < N * k * P.w; i++)
            P.A[i] = (float)(sc * test_rng_normal(r));
        if (csi_dense_create(test_ctx(), N, k, P.A, cplx, &P.op) != CSI_OK)
            fprintf(stderr, "operator: %s\n", csi_last_error());
    }
    for (size_t i = 0; i < N * k * P.w; i++)
        P.Ad[i] = P.A[i];
    uint32_t *supp = rand_subset(r, k, s);
    for (size_t i = 0; i < s; i++)
        for (size_t c = 0; c < P.w; c++) {
            double v = unit_mag ? ((test_rng_u64(r) & 1) ? 1.0 : -1.0) / (c == 0 && P.w == 2 ? 1 : 1)
                                : test_rng_normal(r);
            P.x[supp[i] * P.w + c] = (float)v;
        }
    free(supp);
    problem_measure(&P);
    P.dx = test_alloc(k * P.w * 4);
    return P;
}

static inline void problem_free(problem *P)
{
    free(P->A);
    free(P->Ad);
    free(P->x);
    free(P->y);
    csi_linop_free(P->op);
    csi_buffer_release(&P->dy);
    csi_buffer_release(&P->dx);
}

/* Relative error ||x_got - x_true|| / ||x_true|| of the solution on the device. */
static inline double problem_error(const problem *P, float *xout)
{
    test_download(P->dx, xout, P->k * P->w * 4);
    return test_rel_l2(xout, P->x, P->k * P->w);
}

static inline bool all_finite(const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return false;
    return true;
}

#endif
