/* A = S H, the sampled half-spectrum Fourier synthesis of Alg. 2 (csi/sampled_half_fourier.h). */
#include "csi/sampled_half_fourier.h"

#include <math.h>
#include <stdlib.h>

#include "csi/gaussian.h"
#include "csi/sampling.h"

typedef struct {
    csi_fourier_half *H;
    csi_linop *S;   /* real sampling */
    cl_mem vol, yr; /* k and n floats */
    size_t k, n;
    /* csi_half_fourier_set_filter: the gain per (u, v) column (hs x dims[1] floats) and the
     * weighted coefficients (cols complex values), NULL until reserved; `filtered` once set */
    cl_mem gain, zw;
    bool filtered;
    /* csi_half_fourier_set_still_gain: the first plane's extra gain (1: none) */
    float still;
    size_t dims[3];
} half_state;

/* out = D in on the cols coefficients (in place when in == out). */
static csi_status weight(const csi_linop *op, cl_mem in, cl_mem out)
{
    half_state *s = op->state;
    cl_kernel k;
    const cl_uint period = (cl_uint)(csi_fourier_half_stride(s->H) * s->dims[1]), nn = (cl_uint)op->cols;
    if (s->still != 1.0f) {
        CSI_TRY(csi_kernel(op->ctx, "sampling", "csi_half_weight_still", &k));
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(s->gain), CSI_ARG(period), CSI_ARG(nn),
                         CSI_ARG(s->still)));
    } else {
        CSI_TRY(csi_kernel(op->ctx, "sampling", "csi_half_weight", &k));
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(s->gain), CSI_ARG(period), CSI_ARG(nn)));
    }
    return csi_run1d(op->ctx, k, op->cols);
}

/* f = H D z (H z without a filter). */
static csi_status synthesize(const csi_linop *op, cl_mem z, cl_mem f)
{
    half_state *s = op->state;
    if (!s->filtered)
        return csi_fourier_half_inverse(s->H, z, f);
    CSI_TRY(weight(op, z, s->zw));
    return csi_fourier_half_inverse(s->H, s->zw, f);
}

static csi_status half_apply(const csi_linop *op, cl_mem z, cl_mem y)
{
    half_state *s = op->state;
    CSI_TRY(synthesize(op, z, s->vol));
    CSI_TRY(csi_linop_apply(s->S, s->vol, s->yr));
    cl_kernel r2c;
    CSI_TRY(csi_kernel(op->ctx, "sampling", "csi_real_to_complex", &r2c));
    cl_uint nn = (cl_uint)s->n;
    CSI_TRY(CSI_ARGS(r2c, CSI_MEM(s->yr), CSI_MEM(y), CSI_ARG(nn)));
    return csi_run1d(op->ctx, r2c, s->n);
}

static csi_status half_adjoint(const csi_linop *op, cl_mem y, cl_mem z)
{
    half_state *s = op->state;
    cl_kernel c2r;
    CSI_TRY(csi_kernel(op->ctx, "sampling", "csi_complex_real", &c2r));
    cl_uint nn = (cl_uint)s->n;
    CSI_TRY(CSI_ARGS(c2r, CSI_MEM(y), CSI_MEM(s->yr), CSI_ARG(nn)));
    CSI_TRY(csi_run1d(op->ctx, c2r, s->n));
    CSI_TRY(csi_linop_adjoint(s->S, s->yr, s->vol));
    CSI_TRY(csi_fourier_half_forward(s->H, s->vol, z));
    return s->filtered ? weight(op, z, z) : CSI_OK; /* D is real and diagonal: its own adjoint */
}

static void half_destroy(csi_linop *op)
{
    half_state *s = op->state;
    if (!s)
        return;
    csi_fourier_half_free(s->H);
    csi_linop_free(s->S);
    csi_buffer_release(&s->vol);
    csi_buffer_release(&s->yr);
    csi_buffer_release(&s->gain);
    csi_buffer_release(&s->zw);
    free(s);
    op->state = NULL;
}

void csi_half_fourier_sampling_buffers(const size_t dims[3], size_t n, csi_mem_tally *t)
{
    csi_fourier_half_buffers(dims, t);
    csi_sampling_buffers(n, t);
    csi_mem_tally_add(t, dims[0] * dims[1] * dims[2] * 4, "the motion operator's volume");
    csi_mem_tally_add(t, n * 4, "the motion operator's samples");
}

csi_status csi_half_fourier_sampling_create(csi_ctx *ctx, const size_t dims[3], const uint32_t *idx,
                                            size_t n, csi_linop **out)
{
    *out = NULL;
    csi_linop *op = calloc(1, sizeof *op);
    half_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion operator");
    }
    op->ctx = ctx;
    op->name = "S H (half-spectrum Fourier)";
    op->complex_valued = true;
    op->apply = half_apply;
    op->adjoint = half_adjoint;
    op->destroy = half_destroy;
    op->state = s;
    s->k = dims[0] * dims[1] * dims[2];
    s->n = n;
    s->still = 1.0f;
    for (int a = 0; a < 3; a++)
        s->dims[a] = dims[a];
    csi_status st = csi_fourier_half_create(ctx, dims, &s->H);
    if (st == CSI_OK)
        st = csi_sampling_create(ctx, s->k, idx, n, false, &s->S);
    if (st == CSI_OK)
        st = csi_buffer(ctx, s->k * 4, CL_MEM_READ_WRITE, "the motion operator's volume", &s->vol);
    if (st == CSI_OK)
        st = csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the motion operator's samples", &s->yr);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    op->rows = n;
    op->cols = csi_fourier_half_count(s->H);
    *out = op;
    return CSI_OK;
}

csi_status csi_half_fourier_synthesize(const csi_linop *op, cl_mem z, cl_mem f)
{
    return synthesize(op, z, f);
}

void csi_half_fourier_filter_buffers(const size_t dims[3], csi_mem_tally *t)
{
    /* hs x dims[1] gains: the count is hs x dims[1] x dims[2] */
    csi_mem_tally_add(t, csi_fourier_half_count_for(dims) / dims[2] * 4, "the motion filter's gains");
    csi_mem_tally_add(t, csi_fourier_half_count_for(dims) * 8, "the filtered coefficients");
}

double csi_half_fourier_filter_gain(size_t w, size_t h, size_t u, size_t v, double sigma, double lambda)
{
    const double g = csi_gauss_gain_1d(w, u, sigma) * csi_gauss_gain_1d(h, v, sigma);
    return (1.0 + lambda) * g / (g * g + lambda);
}

csi_status csi_half_fourier_filter_reserve(csi_linop *op)
{
    half_state *s = op->state;
    const size_t gains = csi_fourier_half_stride(s->H) * s->dims[1];
    csi_status st = CSI_OK;
    if (!s->gain)
        st = csi_buffer(op->ctx, gains * 4, CL_MEM_READ_WRITE, "the motion filter's gains", &s->gain);
    if (st == CSI_OK && !s->zw)
        st = csi_buffer(op->ctx, op->cols * 8, CL_MEM_READ_WRITE, "the filtered coefficients", &s->zw);
    return st;
}

csi_status csi_half_fourier_set_filter(csi_linop *op, double sigma, double lambda)
{
    half_state *s = op->state;
    if (!(isfinite(sigma) && sigma > 0 && isfinite(lambda) && lambda > 0))
        return csi_fail(CSI_ERR_ARG, "the motion filter needs a width > 0 and lambda > 0 (got %g, %g)",
                        sigma, lambda);
    const size_t hs = csi_fourier_half_stride(s->H), w = s->dims[0], h = s->dims[1], M = w / 2;
    float *g = malloc(hs * h * sizeof *g);
    if (!g)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion filter's %zu gains", hs * h);
    for (size_t v = 0; v < h; v++)
        for (size_t u = 0; u < hs; u++) /* the padding past u = M holds no coefficient */
            g[v * hs + u] = u <= M ? (float)csi_half_fourier_filter_gain(w, h, u, v, sigma, lambda) : 0.0f;
    csi_status st = csi_half_fourier_filter_reserve(op);
    if (st == CSI_OK)
        st = csi_write(op->ctx, s->gain, 0, hs * h * sizeof *g, g);
    free(g);
    s->filtered = st == CSI_OK;
    return st;
}

csi_status csi_half_fourier_set_still_gain(csi_linop *op, double g0)
{
    half_state *s = op->state;
    if (!(isfinite(g0) && g0 > 0 && g0 <= 1e6))
        return csi_fail(CSI_ERR_ARG, "the still plane's gain must be in (0, 1e6] (got %g)", g0);
    if (!s->filtered && g0 != 1.0) {
        /* no filter: D = 1, so the gains are ones (zero on the padding past u = M) */
        const size_t hs = csi_fourier_half_stride(s->H), h = s->dims[1], M = s->dims[0] / 2;
        float *g = malloc(hs * h * sizeof *g);
        if (!g)
            return csi_fail(CSI_ERR_NOMEM, "out of host memory for the motion operator's %zu gains", hs * h);
        for (size_t v = 0; v < h; v++)
            for (size_t u = 0; u < hs; u++)
                g[v * hs + u] = u <= M ? 1.0f : 0.0f;
        csi_status st = csi_half_fourier_filter_reserve(op);
        if (st == CSI_OK)
            st = csi_write(op->ctx, s->gain, 0, hs * h * sizeof *g, g);
        free(g);
        CSI_TRY(st);
        s->filtered = true;
    }
    s->still = (float)g0;
    return CSI_OK;
}

cl_mem csi_half_fourier_scratch(const csi_linop *op)
{
    const half_state *s = op->state;
    return s->vol;
}

csi_fourier_half *csi_half_fourier_basis(const csi_linop *op)
{
    const half_state *s = op->state;
    return s->H;
}

const csi_linop *csi_half_fourier_sampler(const csi_linop *op)
{
    const half_state *s = op->state;
    return s->S;
}
