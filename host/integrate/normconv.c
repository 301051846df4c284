/* Normalized convolution on the fine grid: the Gaussian baseline and Alg. 2's residual
 * correction. */
#include <math.h>

#include "csi/sampling.h"
#include "csi/spectral.h"
#include "csi/vec.h"
#include "internal.h"

void csi_nc_free(csi_nc_op *r)
{
    csi_linop_free(r->S);
    csi_linop_free(r->G);
    csi_buffer_release(&r->den);
    csi_buffer_release(&r->b);
    csi_buffer_release(&r->fs);
}

csi_status csi_nc_init(csi_ctx *ctx, const csi_grid *g, const uint32_t *idx, size_t n,
                       double sigma, cl_mem yscratch, cl_mem scratch, float *ones,
                       csi_nc_op *r)
{
    const size_t dims[3] = {g->w, g->h, g->t};
    const int nd = g->t > 1 ? 3 : 2;
    const double sphi[3] = {sigma, sigma, g->t > 1 ? sigma : 0};
    CSI_TRY(csi_filter_create(ctx, dims, sphi, CSI_FILTER_GAUSS, 1.0f, &r->G));
    /* Cells whose filtered density is below 1e-6 of a single sample's peak contribution (no
     * sample within reach of the filter) are left 0 instead of 0/0. */
    const float eps = (float)(1e-6 / pow(sqrt(2 * 3.14159265358979323846) * sigma, nd));
    return csi_nc_init_filter(ctx, g, idx, n, r->G, eps, yscratch, scratch, ones, r);
}

csi_status csi_nc_init_filter(csi_ctx *ctx, const csi_grid *g, const uint32_t *idx, size_t n,
                              csi_linop *G, float eps, cl_mem yscratch, cl_mem scratch,
                              float *ones, csi_nc_op *r)
{
    const size_t k = (size_t)g->w * g->h * g->t;
    r->G = G;
    r->eps = eps;
    r->lo = -INFINITY;
    r->hi = INFINITY;
    CSI_TRY(csi_sampling_create(ctx, k, idx, n, false, &r->S));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the filtered sample density", &r->den));
    CSI_TRY(csi_buffer(ctx, k * 4, CL_MEM_READ_WRITE, "the filtered samples", &r->b));
    CSI_TRY(csi_buffer(ctx, n * 4, CL_MEM_READ_WRITE, "the estimate at the samples", &r->fs));
    for (size_t i = 0; i < n; i++)
        ones[i] = 1.0f;
    CSI_TRY(csi_write(ctx, yscratch, 0, n * 4, ones));
    CSI_TRY(csi_linop_adjoint(r->S, yscratch, scratch));
    return csi_linop_apply(r->G, scratch, r->den);
}

csi_status csi_nc_interp(csi_ctx *ctx, csi_nc_op *r, cl_mem yd, size_t k, cl_mem scratch,
                         cl_mem out)
{
    CSI_TRY(csi_linop_adjoint(r->S, yd, scratch));
    CSI_TRY(csi_linop_apply(r->G, scratch, r->b));
    cl_kernel div;
    CSI_TRY(csi_kernel(ctx, "recon", "csi_nc_divide", &div));
    cl_uint nk = (cl_uint)k;
    CSI_TRY(CSI_ARGS(div, CSI_MEM(r->b), CSI_MEM(r->den), CSI_MEM(out), CSI_ARG(nk), CSI_ARG(r->eps),
                     CSI_ARG(r->lo), CSI_ARG(r->hi)));
    return csi_run1d(ctx, div, k);
}

csi_status csi_nc_correct(csi_ctx *ctx, csi_nc_op *r, const float *y, size_t n, size_t k, cl_mem f,
                          cl_mem yscratch, cl_mem scratch, float *host)
{
    CSI_TRY(csi_linop_apply(r->S, f, r->fs));
    CSI_TRY(csi_read(ctx, r->fs, 0, n * 4, host));
    for (size_t i = 0; i < n; i++)
        host[i] = y[i] - host[i];
    CSI_TRY(csi_write(ctx, yscratch, 0, n * 4, host));
    CSI_TRY(csi_nc_interp(ctx, r, yscratch, k, scratch, scratch));
    return csi_vec_axpy(ctx, k, 1.0f, scratch, f);
}
