/* The Gaussian along the motion (csi/motion_filter.h): forward on the motion basis, a separable
 * gain, inverse. */
#include "csi/motion_filter.h"

#include <math.h>
#include <stdlib.h>

#define PI_ 3.14159265358979323846

typedef struct {
    csi_fourier_half *h;
    cl_mem z, g0, g1, gt;
    size_t hs, n1, T, c0;
    csi_time_transform t;
} mf_state;

/* exp(-2 pi^2 s^2 f^2) */
static double gauss_gain(double s, double f) { return exp(-2.0 * PI_ * PI_ * s * s * f * f); }

/* Signed frequency of bin u of n in cycles per sample (+1/2 at an even n's Nyquist bin). */
static double freq(size_t u, size_t n) { return (u <= n / 2 ? (double)u : (double)u - (double)n) / (double)n; }

/* Temporal frequency of coefficient k (cycles per frame) for the time transform t. */
static double tfreq(csi_time_transform t, size_t k, size_t T)
{
    return t == CSI_TIME_DCT ? (double)k / (2.0 * (double)T) : freq(k, T);
}

/* The gain on the spectrum in s->z, then the inverse into y. */
static csi_status gain_inverse(const csi_linop *op, cl_mem y)
{
    mf_state *s = op->state;
    cl_kernel k;
    CSI_TRY(csi_kernel(op->ctx, "fft", "csi_motion_gain", &k));
    cl_uint hs = (cl_uint)s->hs, n1 = (cl_uint)s->n1;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(s->z), CSI_MEM(s->g0), CSI_MEM(s->g1), CSI_MEM(s->gt), CSI_ARG(hs),
                     CSI_ARG(n1)));
    size_t global[3] = {s->hs, s->n1, s->T}, local[3] = {16, 1, 1};
    CSI_TRY(csi_run(op->ctx, k, 3, global, local));
    return csi_fourier_half_inverse(s->h, s->z, y);
}

static csi_status mf_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    mf_state *s = op->state;
    CSI_TRY(csi_fourier_half_forward(s->h, x, s->z));
    return gain_inverse(op, y);
}

csi_status csi_motion_filter_apply_spatial(const csi_linop *G, cl_mem zs, cl_mem y)
{
    mf_state *s = G->state;
    if (zs == s->z)
        return csi_fail(CSI_ERR_ARG, "motion filter: the spatial spectra must not be the filter's scratch");
    CSI_TRY(csi_fourier_half_forward_rest(s->h, zs, s->z));
    return gain_inverse(G, y);
}

static void mf_destroy(csi_linop *op)
{
    mf_state *s = op->state;
    if (!s)
        return;
    csi_buffer_release(&s->g0);
    csi_buffer_release(&s->g1);
    csi_buffer_release(&s->gt);
    free(s);
    op->state = NULL;
}

/* The gains for widths sxy, st into the filter's tables (made on the first call). */
static csi_status write_gains(csi_ctx *ctx, mf_state *s, double sxy, double st)
{
    const size_t hs = s->hs, n1 = s->n1, T = s->T, M = s->c0 / 2;
    float *g0 = calloc(hs, sizeof *g0), *g1 = malloc(n1 * sizeof *g1), *gt = malloc(T * sizeof *gt);
    csi_status r = g0 && g1 && gt ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion filter");
    if (r == CSI_OK) {
        /* the half axis: bins 0 and M once, the bins between stand for themselves and their
         * conjugate mirror (x2), padding 0: inverse(D forward(f)) = f */
        for (size_t u = 0; u <= M; u++)
            g0[u] = (float)((u == 0 || u == M ? 1.0 : 2.0) * gauss_gain(sxy, (double)u / (double)s->c0));
        for (size_t u = 0; u < n1; u++)
            g1[u] = (float)(n1 > 1 ? gauss_gain(sxy, freq(u, n1)) : 1.0);
        for (size_t k = 0; k < T; k++)
            gt[k] = (float)(s->t == CSI_TIME_NONE ? 1.0 : gauss_gain(st, tfreq(s->t, k, T)));
    }
    const struct { cl_mem *m; float *v; size_t n; } tab[3] = {{&s->g0, g0, hs}, {&s->g1, g1, n1}, {&s->gt, gt, T}};
    for (int i = 0; i < 3 && r == CSI_OK; i++) {
        if (!*tab[i].m)
            r = csi_buffer(ctx, tab[i].n * sizeof(float), CL_MEM_READ_ONLY, "the motion filter's gains", tab[i].m);
        if (r == CSI_OK)
            r = csi_write(ctx, *tab[i].m, 0, tab[i].n * sizeof(float), tab[i].v);
    }
    free(g0);
    free(g1);
    free(gt);
    return r;
}

static csi_status check_widths(double sigma_xy, double sigma_t)
{
    if (!(sigma_xy > 0) || !(sigma_t >= 0) || !isfinite(sigma_xy) || !isfinite(sigma_t))
        return csi_fail(CSI_ERR_ARG, "motion filter: widths %g (space) and %g (time) must be finite, "
                        "the first > 0, the second >= 0", sigma_xy, sigma_t);
    return CSI_OK;
}

csi_status csi_motion_filter_create(csi_ctx *ctx, csi_fourier_half *h, const size_t dims[3],
                                    csi_time_transform t, double sigma_xy, double sigma_t,
                                    cl_mem zscratch, csi_linop **out)
{
    *out = NULL;
    CSI_TRY(check_widths(sigma_xy, sigma_t));
    /* the squeezed spatial axes (the half axis first) and t last, as the basis lays them out */
    size_t c[2] = {1, 1};
    int nsp = 0;
    for (int a = 0; a < 2; a++)
        if (dims[a] > 1)
            c[nsp++] = dims[a];
    const size_t T = dims[2], hs = csi_fourier_half_stride(h);
    const size_t n1 = nsp == 2 ? c[1] : 1;
    if (T < 2 || nsp == 0 || csi_fourier_half_count(h) != hs * n1 * T)
        return csi_fail(CSI_ERR_ARG, "motion filter: size %zu x %zu x %zu is not the basis's volume",
                        dims[0], dims[1], dims[2]);
    csi_linop *op = calloc(1, sizeof *op);
    mf_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion filter");
    }
    *s = (mf_state){h, zscratch, NULL, NULL, NULL, hs, n1, T, c[0], t};
    op->ctx = ctx;
    op->name = "G_v (Gaussian along the motion)";
    op->rows = op->cols = dims[0] * dims[1] * dims[2];
    op->apply = mf_apply;
    op->adjoint = mf_apply; /* symmetric */
    op->destroy = mf_destroy;
    op->state = s;
    csi_status st = write_gains(ctx, s, sigma_xy, sigma_t);
    if (st == CSI_OK) {
        cl_kernel k;
        st = csi_kernel(ctx, "fft", "csi_motion_gain", &k);
    }
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}

csi_status csi_motion_filter_set(csi_linop *G, csi_time_transform t, double sigma_xy, double sigma_t)
{
    CSI_TRY(check_widths(sigma_xy, sigma_t));
    mf_state *s = G->state;
    s->t = t;
    return write_gains(G->ctx, s, sigma_xy, sigma_t);
}

void csi_motion_filter_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[2] = {1, 1};
    int nsp = 0;
    for (int a = 0; a < 2; a++)
        if (dims[a] > 1)
            c[nsp++] = dims[a];
    const size_t n1 = nsp == 2 ? c[1] : 1, hs = csi_fourier_half_count_for(dims) / (n1 * dims[2]);
    csi_mem_tally_add(t, hs * sizeof(float), "the motion filter's gains");
    csi_mem_tally_add(t, n1 * sizeof(float), "the motion filter's gains");
    csi_mem_tally_add(t, dims[2] * sizeof(float), "the motion filter's gains");
}

void csi_motion_filter_self_weight(const size_t dims[3], csi_time_transform t, double sigma_xy,
                                   double sigma_t, double *out)
{
    /* spatial: the kernel's value at distance 0 is the mean of its gain over the full spectrum */
    double sp = 1.0;
    for (int a = 0; a < 2; a++) {
        if (dims[a] < 2)
            continue;
        double m = 0;
        for (size_t u = 0; u < dims[a]; u++)
            m += gauss_gain(sigma_xy, freq(u, dims[a]));
        sp *= m / (double)dims[a];
    }
    const size_t T = dims[2];
    for (size_t ti = 0; ti < T; ti++) {
        double d = 0;
        if (t == CSI_TIME_NONE)
            d = 1.0;
        else if (t == CSI_TIME_DFT)
            for (size_t k = 0; k < T; k++)
                d += gauss_gain(sigma_t, freq(k, T)) / (double)T;
        else
            for (size_t k = 0; k < T; k++) {
                double c = k ? sqrt(2.0 / (double)T) : sqrt(1.0 / (double)T);
                double phi = c * cos(PI_ * (double)k * (2.0 * (double)ti + 1.0) / (2.0 * (double)T));
                d += gauss_gain(sigma_t, tfreq(t, k, T)) * phi * phi;
            }
        out[ti] = sp * d;
    }
}
