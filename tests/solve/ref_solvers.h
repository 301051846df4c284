/* Plain-C dense double reference implementations of ROMP and SpaRSA, written from the papers
 * (Needell & Vershynin 2009; Wright, Nowak & Figueiredo 2009) independently of host/solve/,
 * for small problems (k <= 1024). Real or complex (interleaved) matrices, row-major N x k.
 * ROMP's least squares is solved exactly (Cholesky of the normal equations on the support),
 * so the reference also checks that the device's bounded CGLS is accurate enough. */
#ifndef CSI_REF_SOLVERS_H
#define CSI_REF_SOLVERS_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    size_t N, k;
    bool cplx;
    const double *A; /* N x k, interleaved when cplx */
} ref_mat;

/* y = A x (w = 1 or 2 doubles per element) */
static inline void ref_apply(const ref_mat *M, const double *x, double *y)
{
    for (size_t i = 0; i < M->N; i++) {
        double sr = 0, si = 0;
        for (size_t j = 0; j < M->k; j++) {
            if (M->cplx) {
                double ar = M->A[2 * (i * M->k + j)], ai = M->A[2 * (i * M->k + j) + 1];
                sr += ar * x[2 * j] - ai * x[2 * j + 1];
                si += ar * x[2 * j + 1] + ai * x[2 * j];
            } else {
                sr += M->A[i * M->k + j] * x[j];
            }
        }
        if (M->cplx) {
            y[2 * i] = sr;
            y[2 * i + 1] = si;
        } else {
            y[i] = sr;
        }
    }
}

/* x = A^H y */
static inline void ref_adjoint(const ref_mat *M, const double *y, double *x)
{
    size_t w = M->cplx ? 2 : 1;
    memset(x, 0, M->k * w * sizeof *x);
    for (size_t i = 0; i < M->N; i++)
        for (size_t j = 0; j < M->k; j++) {
            if (M->cplx) {
                double ar = M->A[2 * (i * M->k + j)], ai = -M->A[2 * (i * M->k + j) + 1];
                x[2 * j] += ar * y[2 * i] - ai * y[2 * i + 1];
                x[2 * j + 1] += ar * y[2 * i + 1] + ai * y[2 * i];
            } else {
                x[j] += M->A[i * M->k + j] * y[i];
            }
        }
}

static inline double ref_dot(const double *a, const double *b, size_t n)
{
    double s = 0;
    for (size_t i = 0; i < n; i++)
        s += a[i] * b[i];
    return s;
}

/* ---- ROMP (real) ---- */
typedef struct {
    uint32_t *log; /* selection order */
    size_t support;
    int iterations;
    bool converged;
    double rel_residual;
} ref_romp_result;

/* Least squares on support I (size m) by Cholesky of A_I^T A_I; x zero elsewhere. */
static inline bool ref_lsq(const ref_mat *M, const uint32_t *I, size_t m, const double *y, double *x)
{
    double *G = calloc(m * m, sizeof *G), *b = calloc(m, sizeof *b);
    for (size_t a = 0; a < m; a++) {
        for (size_t c = 0; c <= a; c++) {
            double s = 0;
            for (size_t i = 0; i < M->N; i++)
                s += M->A[i * M->k + I[a]] * M->A[i * M->k + I[c]];
            G[a * m + c] = G[c * m + a] = s;
        }
        double s = 0;
        for (size_t i = 0; i < M->N; i++)
            s += M->A[i * M->k + I[a]] * y[i];
        b[a] = s;
    }
    bool ok = true;
    for (size_t j = 0; j < m && ok; j++) { /* G = L L^T in place (lower) */
        double d = G[j * m + j];
        for (size_t p = 0; p < j; p++)
            d -= G[j * m + p] * G[j * m + p];
        if (!(d > 0)) {
            ok = false;
            break;
        }
        d = sqrt(d);
        G[j * m + j] = d;
        for (size_t i = j + 1; i < m; i++) {
            double s = G[i * m + j];
            for (size_t p = 0; p < j; p++)
                s -= G[i * m + p] * G[j * m + p];
            G[i * m + j] = s / d;
        }
    }
    if (ok) {
        for (size_t i = 0; i < m; i++) { /* L z = b */
            double s = b[i];
            for (size_t p = 0; p < i; p++)
                s -= G[i * m + p] * b[p];
            b[i] = s / G[i * m + i];
        }
        for (size_t i = m; i-- > 0;) { /* L^T x = z */
            double s = b[i];
            for (size_t p = i + 1; p < m; p++)
                s -= G[p * m + i] * b[p];
            b[i] = s / G[i * m + i];
        }
        memset(x, 0, M->k * sizeof *x);
        for (size_t a = 0; a < m; a++)
            x[I[a]] = b[a];
    }
    free(G);
    free(b);
    return ok;
}

typedef struct {
    double v;
    uint32_t i;
} ref_cand;

static inline int ref_cand_cmp(const void *a, const void *b)
{
    const ref_cand *x = a, *y = b;
    if (x->v != y->v)
        return x->v > y->v ? -1 : 1;
    return x->i < y->i ? -1 : (x->i > y->i);
}

static inline ref_romp_result ref_romp(const ref_mat *M, const double *y, size_t s, double tol,
                                int max_iter, double *x)
{
    ref_romp_result res = {0};
    size_t N = M->N, k = M->k;
    res.log = calloc(k, sizeof *res.log);
    double *r = malloc(N * sizeof *r), *u = malloc(k * sizeof *u);
    unsigned char *in = calloc(k, 1);
    ref_cand *c = malloc(k * sizeof *c);
    memcpy(r, y, N * sizeof *r);
    memset(x, 0, k * sizeof *x);
    double yn = sqrt(ref_dot(y, y, N)), rn = yn;
    size_t limit = 2 * s < k ? 2 * s : k;
    while (rn > tol * yn && res.support < limit && res.iterations < max_iter) {
        ref_adjoint(M, r, u);
        size_t m = 0;
        for (size_t j = 0; j < k; j++)
            if (!in[j] && u[j] != 0) {
                c[m].v = fabs(u[j]);
                c[m].i = (uint32_t)j;
                m++;
            }
        if (m == 0)
            break;
        qsort(c, m, sizeof *c, ref_cand_cmp);
        if (m > s)
            m = s;
        /* comparable windows: max <= 2 min; keep the one of largest energy */
        size_t blo = 0, bhi = 1;
        double best = -1;
        for (size_t i = 0; i < m; i++) {
            double e = 0;
            size_t j = i;
            while (j < m && c[i].v <= 2 * c[j].v) {
                e += c[j].v * c[j].v;
                j++;
            }
            if (e > best) {
                best = e;
                blo = i;
                bhi = j;
            }
        }
        for (size_t i = blo; i < bhi; i++) {
            in[c[i].i] = 1;
            res.log[res.support++] = c[i].i;
        }
        ref_lsq(M, res.log, res.support, y, x);
        ref_apply(M, x, r);
        for (size_t i = 0; i < N; i++)
            r[i] = y[i] - r[i];
        rn = sqrt(ref_dot(r, r, N));
        res.iterations++;
    }
    res.converged = rn <= tol * yn;
    res.rel_residual = yn > 0 ? rn / yn : 0;
    free(r);
    free(u);
    free(in);
    free(c);
    return res;
}

/* ---- SpaRSA (real or complex), the variant with fixed tau (no continuation, no debiasing):
 * BB step clamped, acceptance phi(x+) <= max(last M+1 phi) - sigma/2 alpha ||x+ - x||^2,
 * alpha *= eta on rejection, alpha = 1 at the start, stop on the relative duality gap. Records
 * phi and alpha of every accepted step and the iterates. ---- */
typedef struct {
    int iterations;
    double *phi, *alpha; /* per accepted step */
    double *xs;          /* iterates, iterations x (k w) */
} ref_sparsa_result;

static inline double ref_soft_apply(double *v, size_t n, bool cplx, double t)
{
    double l1 = 0;
    for (size_t i = 0; i < n; i++) {
        if (cplx) {
            double m = hypot(v[2 * i], v[2 * i + 1]);
            double f = t == 0 ? 1.0 : (m > t ? (m - t) / m : 0.0);
            v[2 * i] *= f;
            v[2 * i + 1] *= f;
            l1 += m * f;
        } else {
            double m = fabs(v[i]) - t;
            v[i] = m > 0 ? copysign(m, v[i]) : 0.0;
            l1 += fabs(v[i]);
        }
    }
    return l1;
}

static inline ref_sparsa_result ref_sparsa(const ref_mat *M, const double *y, double tau, int memory,
                                    double sigma, double tol, int max_iter, double *x)
{
    ref_sparsa_result R = {0};
    size_t w = M->cplx ? 2 : 1, nN = M->N * w, nk = M->k * w;
    R.phi = calloc((size_t)max_iter + 1, sizeof(double));
    R.alpha = calloc((size_t)max_iter + 1, sizeof(double));
    R.xs = calloc(((size_t)max_iter + 1) * nk, sizeof(double));
    double *r = malloc(nN * sizeof *r), *h = malloc(nk * sizeof *h), *xn = malloc(nk * sizeof *xn);
    double *Ax = calloc(nN, sizeof *Ax), *Axn = malloc(nN * sizeof *Axn);
    memset(x, 0, nk * sizeof *x);
    memcpy(r, y, nN * sizeof *r);
    ref_adjoint(M, r, h);
    double phi = 0.5 * ref_dot(r, r, nN), alpha = 1.0;
    double hist[64];
    int nh = 1, hpos = 0, since = 0;
    double best_gap = INFINITY, phi_at_best = phi;
    hist[0] = phi;
    while (R.iterations < max_iter) {
        double ref = hist[0];
        for (int i = 1; i < nh; i++)
            ref = fmax(ref, hist[i]);
        double phin, dx2, rn2;
        int trials = 0;
        for (;;) {
            for (size_t i = 0; i < nk; i++)
                xn[i] = x[i] + h[i] / alpha;
            double l1 = ref_soft_apply(xn, M->k, M->cplx, tau / alpha);
            ref_apply(M, xn, Axn);
            rn2 = 0;
            for (size_t i = 0; i < nN; i++)
                rn2 += (y[i] - Axn[i]) * (y[i] - Axn[i]);
            dx2 = 0;
            for (size_t i = 0; i < nk; i++)
                dx2 += (xn[i] - x[i]) * (xn[i] - x[i]);
            phin = 0.5 * rn2 + tau * l1;
            if (phin <= ref - 0.5 * sigma * alpha * dx2 || trials > 60)
                break;
            alpha *= 2;
            trials++;
        }
        double As2 = 0;
        for (size_t i = 0; i < nN; i++)
            As2 += (Axn[i] - Ax[i]) * (Axn[i] - Ax[i]);
        memcpy(x, xn, nk * sizeof *x);
        memcpy(Ax, Axn, nN * sizeof *Ax);
        for (size_t i = 0; i < nN; i++)
            r[i] = y[i] - Ax[i];
        ref_adjoint(M, r, h);
        phi = phin;
        R.phi[R.iterations] = phi;
        R.alpha[R.iterations] = alpha;
        memcpy(R.xs + (size_t)R.iterations * nk, x, nk * sizeof *x);
        R.iterations++;
        if (memory > 0) {
            hpos = (hpos + 1) % (memory + 1);
            hist[hpos] = phi;
            if (nh < memory + 1)
                nh++;
        } else {
            hist[0] = phi;
        }
        if (dx2 > 0 && As2 > 0)
            alpha = As2 / dx2;
        alpha = fmin(fmax(alpha, 1e-30), 1e30);
        double hr = 0;
        for (size_t j = 0; j < M->k; j++)
            hr = fmax(hr, M->cplx ? hypot(h[2 * j], h[2 * j + 1]) : fabs(h[j]));
        double sc = hr > tau ? tau / hr : 1.0;
        double dual = -0.5 * sc * sc * rn2 + sc * ref_dot(r, y, nN);
        /* the device's float32 floor (csi/solve.h): below 32 u ||y||^2, stop after 10 steps
         * in which the gap has not halved; above it, after 100 such steps over which phi fell by
         * at most tol phi */
        double gap = phi - dual;
        if (gap < 0.5 * best_gap) {
            best_gap = gap;
            phi_at_best = phi;
            since = 0;
        } else {
            since++;
        }
        if (gap <= tol * phi || (gap <= 32.0 * 0x1.0p-24 * ref_dot(y, y, nN) && since >= 10) ||
            (since >= 100 && phi_at_best - phi <= tol * phi))
            break;
    }
    free(r);
    free(h);
    free(xn);
    free(Ax);
    free(Axn);
    return R;
}

static inline void ref_sparsa_free(ref_sparsa_result *R)
{
    free(R->phi);
    free(R->alpha);
    free(R->xs);
}

#endif
