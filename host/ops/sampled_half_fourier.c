/* A = S H, the sampled half-spectrum Fourier synthesis of Alg. 2 (csi/sampled_half_fourier.h). */
#include "csi/sampled_half_fourier.h"

#include <stdlib.h>

#include "csi/sampling.h"

typedef struct {
    csi_fourier_half *H;
    csi_linop *S;   /* real sampling */
    cl_mem vol, yr; /* k and n floats */
    size_t k, n;
} half_state;


static csi_status half_apply(const csi_linop *op, cl_mem z, cl_mem y)
{
    half_state *s = op->state;
    CSI_TRY(csi_fourier_half_inverse(s->H, z, s->vol));
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
    return csi_fourier_half_forward(s->H, s->vol, z);
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
    half_state *s = op->state;
    return csi_fourier_half_inverse(s->H, z, f);
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
