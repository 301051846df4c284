/* Vector operations on device buffers: host side of kernels/vec.cl (error bounds in vec.h). */
#include "csi/vec.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>

#define VEC_LOCAL 64     /* must match kernels/vec.cl */
#define VEC_MAX_GROUPS 64
#define VEC_MIN_BLOCKS 8 /* aim for at least this many 16-float blocks per work-item before adding groups */
#define VEC_BLOCK 16     /* floats per block, must match kernels/vec.cl */

struct csi_vec_ws {
    csi_ctx *ctx;
    cl_mem pval, pidx;
    float hval[6 * VEC_MAX_GROUPS];
    cl_uint hidx[VEC_MAX_GROUPS];
};

void csi_vec_ws_buffers(csi_mem_tally *t)
{
    csi_mem_tally_add(t, 6 * VEC_MAX_GROUPS * sizeof(float), "reduction partials");
    csi_mem_tally_add(t, VEC_MAX_GROUPS * sizeof(cl_uint), "reduction partial indices");
}

csi_status csi_vec_ws_create(csi_ctx *ctx, csi_vec_ws **out)
{
    *out = NULL;
    csi_vec_ws *ws = calloc(1, sizeof *ws);
    if (!ws)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a vector workspace");
    ws->ctx = ctx;
    csi_status st = csi_buffer(ctx, 6 * VEC_MAX_GROUPS * sizeof(float), CL_MEM_READ_WRITE,
                               "reduction partials", &ws->pval);
    if (st == CSI_OK)
        st = csi_buffer(ctx, VEC_MAX_GROUPS * sizeof(cl_uint), CL_MEM_READ_WRITE,
                        "reduction partial indices", &ws->pidx);
    /* Build the vector program now: a solver's first step should not pay for it. */
    cl_kernel k;
    if (st == CSI_OK)
        st = csi_kernel(ctx, "vec", "vec_fill", &k);
    if (st != CSI_OK) {
        csi_vec_ws_free(ws);
        return st;
    }
    *out = ws;
    return CSI_OK;
}

void csi_vec_ws_free(csi_vec_ws *ws)
{
    if (!ws)
        return;
    csi_buffer_release(&ws->pval);
    csi_buffer_release(&ws->pidx);
    free(ws);
}

csi_ctx *csi_vec_ws_ctx(const csi_vec_ws *ws) { return ws->ctx; }

static csi_status check_n(size_t n, const char *what)
{
    if (n > (size_t)UINT_MAX / 2)
        return csi_fail(CSI_ERR_ARG, "%s: %zu elements exceed the 32-bit index range of the kernels",
                        what, n);
    return CSI_OK;
}

static csi_status kern(csi_ctx *ctx, const char *name, cl_kernel *k)
{
    return csi_kernel(ctx, "vec", name, k);
}

static csi_status run1(csi_ctx *ctx, cl_kernel k, size_t n)
{
    const size_t local = 64;
    return csi_run(ctx, k, 1, &n, &local);
}

csi_status csi_vec_fill(csi_ctx *ctx, cl_mem x, size_t nf, float v)
{
    CSI_TRY(check_n(nf, "vec_fill"));
    if (v == 0.0f && !signbit(v))
        return csi_fill_zero(ctx, x, nf * sizeof(float));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_fill", &k));
    cl_uint n = (cl_uint)nf;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(n), CSI_ARG(v)));
    return run1(ctx, k, nf);
}

csi_status csi_vec_copy(csi_ctx *ctx, cl_mem dst, cl_mem src, size_t nf)
{
    if (dst == src)
        return CSI_OK;
    return csi_copy(ctx, dst, 0, src, 0, nf * sizeof(float));
}

csi_status csi_vec_scale(csi_ctx *ctx, cl_mem x, size_t nf, float a)
{
    CSI_TRY(check_n(nf, "vec_scale"));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_scale", &k));
    cl_uint n = (cl_uint)nf;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(n), CSI_ARG(a)));
    return run1(ctx, k, nf);
}

csi_status csi_vec_waxpby(csi_ctx *ctx, size_t nf, float a, cl_mem x, float b, cl_mem y, cl_mem w)
{
    CSI_TRY(check_n(nf, "vec_waxpby"));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_waxpby", &k));
    cl_uint n = (cl_uint)nf;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(w), CSI_ARG(n), CSI_ARG(a), CSI_MEM(x), CSI_ARG(b), CSI_MEM(y)));
    return run1(ctx, k, nf);
}

csi_status csi_vec_axpy(csi_ctx *ctx, size_t nf, float a, cl_mem x, cl_mem y)
{
    CSI_TRY(check_n(nf, "vec_axpy"));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_axpy", &k));
    cl_uint n = (cl_uint)nf;
    CSI_TRY(CSI_ARGS(k, CSI_ARG(n), CSI_ARG(a), CSI_MEM(x), CSI_MEM(y)));
    return run1(ctx, k, nf);
}

csi_status csi_vec_axpby(csi_ctx *ctx, size_t nf, float a, cl_mem x, float b, cl_mem y)
{
    return csi_vec_waxpby(ctx, nf, a, x, b, y, y);
}

csi_status csi_vec_xpay(csi_ctx *ctx, size_t nf, cl_mem x, float b, cl_mem y)
{
    return csi_vec_waxpby(ctx, nf, 1.0f, x, b, y, y);
}

csi_status csi_vec_soft(csi_ctx *ctx, size_t n, bool cplx, cl_mem x, float t, cl_mem out)
{
    CSI_TRY(check_n(n, "vec_soft"));
    if (!(t >= 0.0f) || isinf(t))
        return csi_fail(CSI_ERR_ARG, "soft threshold %g must be finite and >= 0", (double)t);
    cl_kernel k;
    CSI_TRY(kern(ctx, cplx ? "vec_soft_c" : "vec_soft_r", &k));
    cl_uint nn = (cl_uint)n;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(nn), CSI_ARG(t), CSI_MEM(out)));
    return run1(ctx, k, n);
}

csi_status csi_vec_mask(csi_ctx *ctx, size_t n, bool cplx, cl_mem mask, cl_mem x)
{
    CSI_TRY(check_n(n, "vec_mask"));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_mask", &k));
    cl_uint nn = (cl_uint)n, c = cplx;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(nn), CSI_ARG(c), CSI_MEM(mask)));
    return run1(ctx, k, n);
}

csi_status csi_vec_nonzero_mask(csi_ctx *ctx, size_t n, bool cplx, cl_mem x, cl_mem mask)
{
    CSI_TRY(check_n(n, "vec_nonzero_mask"));
    cl_kernel k;
    CSI_TRY(kern(ctx, "vec_nonzero_mask", &k));
    cl_uint nn = (cl_uint)n, c = cplx;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(nn), CSI_ARG(c), CSI_MEM(mask)));
    return run1(ctx, k, n);
}

/* Launch shape for a reduction over nb blocks of 16 floats (kernels/vec.cl): g groups of
 * VEC_LOCAL work-items, launched exactly (g * VEC_LOCAL, no rounding up), each work-item taking
 * `per` consecutive blocks. Enough groups that each work-item has >= VEC_MIN_BLOCKS blocks (so
 * small vectors do not pay for thousands of idle items), at most VEC_MAX_GROUPS (the partials
 * are finished on the host; 64 groups also keep both cores busy). Depends on nb only, so the
 * same n gives the same partition and the same bits. */
typedef struct {
    size_t groups, global;
    cl_uint per;
} vec_shape;

static vec_shape shape_for(size_t nb)
{
    vec_shape s;
    size_t g = (nb + VEC_LOCAL * VEC_MIN_BLOCKS - 1) / (VEC_LOCAL * VEC_MIN_BLOCKS);
    if (g < 1)
        g = 1;
    if (g > VEC_MAX_GROUPS)
        g = VEC_MAX_GROUPS;
    s.groups = g;
    s.global = g * VEC_LOCAL;
    s.per = (cl_uint)((nb + s.global - 1) / s.global); /* nb < 2^31 / 8 (check_n) */
    return s;
}

/* Reads g groups' (hi, lo) partials of nout sums and finishes each in double (2g <= 128
 * terms: at most 128 * 2^-53 relative). */
static csi_status finish(csi_vec_ws *ws, size_t g, int nout, double *out)
{
    CSI_TRY(csi_read(ws->ctx, ws->pval, 0, 2 * g * (size_t)nout * sizeof(float), ws->hval));
    for (int o = 0; o < nout; o++) {
        double s = 0.0;
        for (size_t i = 0; i < g; i++)
            s += (double)ws->hval[(i * (size_t)nout + (size_t)o) * 2] +
                 (double)ws->hval[(i * (size_t)nout + (size_t)o) * 2 + 1];
        out[o] = s;
    }
    return CSI_OK;
}

/* One-output reduction over n terms; epb = terms per 16-float block (16 real, 8 complex). */
static csi_status reduce(csi_vec_ws *ws, cl_mem x, cl_mem y, size_t n, size_t epb, const char *kname,
                         double *out)
{
    *out = 0.0;
    CSI_TRY(check_n(n, "vector reduction"));
    if (n == 0)
        return CSI_OK;
    cl_kernel k;
    CSI_TRY(kern(ws->ctx, kname, &k));
    cl_uint nn = (cl_uint)n;
    vec_shape sh = shape_for(n / epb);
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_MEM(y), CSI_ARG(nn), CSI_ARG(sh.per), CSI_MEM(ws->pval)));
    size_t local = VEC_LOCAL;
    CSI_TRY(csi_run(ws->ctx, k, 1, &sh.global, &local));
    return finish(ws, sh.groups, 1, out);
}

csi_status csi_vec_dot(csi_vec_ws *ws, size_t nf, cl_mem x, cl_mem y, double *out)
{
    return reduce(ws, x, y, nf, VEC_BLOCK, "vec_red_dot", out);
}

csi_status csi_vec_cdot(csi_vec_ws *ws, size_t n, cl_mem x, cl_mem y, double out[2])
{
    CSI_TRY(reduce(ws, x, y, 2 * n, VEC_BLOCK, "vec_red_dot", &out[0]));
    return reduce(ws, x, y, n, VEC_BLOCK / 2, "vec_red_cdot_im", &out[1]);
}

csi_status csi_vec_nrm2(csi_vec_ws *ws, size_t nf, cl_mem x, double *out)
{
    double s;
    CSI_TRY(reduce(ws, x, x, nf, VEC_BLOCK, "vec_red_sumsq", &s));
    *out = sqrt(s > 0 ? s : 0.0);
    if (isnan(s))
        *out = s;
    return CSI_OK;
}

csi_status csi_vec_dist2(csi_vec_ws *ws, size_t nf, cl_mem x, cl_mem y, double *out)
{
    return reduce(ws, x, y, nf, VEC_BLOCK, "vec_red_dist2", out);
}

csi_status csi_vec_asum(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, double *out)
{
    return reduce(ws, x, x, n, cplx ? VEC_BLOCK / 2 : VEC_BLOCK, cplx ? "vec_red_asum_c" : "vec_red_asum_r",
                  out);
}

csi_status csi_vec_prox_sums(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, cl_mem g, float cf,
                             float t, cl_mem out, double *l1, double *dx2)
{
    *l1 = *dx2 = 0.0;
    CSI_TRY(check_n(n, "vec_prox_sums"));
    if (!isfinite(cf) || !(t >= 0.0f) || isinf(t))
        return csi_fail(CSI_ERR_ARG, "proximal step needs a finite factor and t >= 0 (c %g, t %g)",
                        (double)cf, (double)t);
    if (n == 0)
        return CSI_OK;
    cl_kernel k;
    CSI_TRY(kern(ws->ctx, cplx ? "vec_prox_sums_c" : "vec_prox_sums_r", &k));
    cl_uint nn = (cl_uint)n;
    vec_shape sh = shape_for(n / (cplx ? VEC_BLOCK / 2 : VEC_BLOCK));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_MEM(g), CSI_ARG(nn), CSI_ARG(sh.per), CSI_ARG(cf), CSI_ARG(t),
                     CSI_MEM(out), CSI_MEM(ws->pval)));
    size_t local = VEC_LOCAL;
    CSI_TRY(csi_run(ws->ctx, k, 1, &sh.global, &local));
    double o[2];
    CSI_TRY(finish(ws, sh.groups, 2, o));
    *l1 = o[0];
    *dx2 = o[1];
    return CSI_OK;
}

csi_status csi_vec_resid_sums(csi_vec_ws *ws, size_t nf, cl_mem y, cl_mem Az, cl_mem Ax, cl_mem r,
                              double *rr, double *dd, double *ry)
{
    *rr = *dd = *ry = 0.0;
    CSI_TRY(check_n(nf, "vec_resid_sums"));
    if (nf == 0)
        return CSI_OK;
    cl_kernel k;
    CSI_TRY(kern(ws->ctx, "vec_resid_sums", &k));
    cl_uint nn = (cl_uint)nf;
    vec_shape sh = shape_for(nf / VEC_BLOCK);
    CSI_TRY(CSI_ARGS(k, CSI_MEM(y), CSI_MEM(Az), CSI_MEM(Ax), CSI_ARG(nn), CSI_ARG(sh.per), CSI_MEM(r),
                     CSI_MEM(ws->pval)));
    size_t local = VEC_LOCAL;
    CSI_TRY(csi_run(ws->ctx, k, 1, &sh.global, &local));
    double o[3];
    CSI_TRY(finish(ws, sh.groups, 3, o));
    *rr = o[0];
    *dd = o[1];
    *ry = o[2];
    return CSI_OK;
}

csi_status csi_vec_amax(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, double *val, size_t *idx)
{
    *val = 0.0;
    if (idx)
        *idx = 0;
    CSI_TRY(check_n(n, "vec_amax"));
    if (n == 0)
        return CSI_OK;
    cl_kernel k;
    CSI_TRY(kern(ws->ctx, "vec_amax", &k));
    cl_uint nn = (cl_uint)n, c = cplx;
    vec_shape sh = shape_for(n / (cplx ? VEC_BLOCK / 2 : VEC_BLOCK));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(x), CSI_ARG(nn), CSI_ARG(sh.per), CSI_ARG(c), CSI_MEM(ws->pval),
                     CSI_MEM(ws->pidx)));
    size_t local = VEC_LOCAL, g = sh.groups;
    CSI_TRY(csi_run(ws->ctx, k, 1, &sh.global, &local));
    CSI_TRY(csi_read(ws->ctx, ws->pval, 0, g * sizeof(float), ws->hval));
    CSI_TRY(csi_read(ws->ctx, ws->pidx, 0, g * sizeof(cl_uint), ws->hidx));
    float best = -1.0f;
    cl_uint bi = 0xffffffffu;
    for (size_t i = 0; i < g; i++) {
        float v = ws->hval[i];
        cl_uint j = ws->hidx[i];
        if (j == 0xffffffffu)
            continue; /* a group that saw no element */
        bool take = (isnan(v) && !isnan(best)) || v > best || (v == best && j < bi);
        if (take) {
            best = v;
            bi = j;
        }
    }
    *val = best < 0.0f ? 0.0 : (double)best;
    if (isnan(best))
        *val = best;
    if (idx)
        *idx = bi == 0xffffffffu ? 0 : bi;
    return CSI_OK;
}
