/* Host side of kernels/integrate.cl (see csi/integrate_ops.h). */
#include "csi/integrate_ops.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

static csi_status need_bytes(cl_mem m, size_t bytes, const char *what)
{
    if (!m)
        return csi_fail(CSI_ERR_ARG, "%s: buffer is NULL", what);
    size_t have = 0;
    CSI_TRY(CSI_CL(clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof have, &have, NULL)));
    if (have < bytes)
        return csi_fail(CSI_ERR_ARG, "%s: buffer holds %zu bytes, %zu needed", what, have, bytes);
    return CSI_OK;
}

/* A w x h grid (times n: channels or frames) in blocks of out_w x out_h pixels. */
static csi_status check_blocks(const char *what, uint32_t w, uint32_t h, uint32_t n, uint32_t out_w, uint32_t out_h)
{
    if (!w || !h || !n || !out_w || !out_h)
        return csi_fail(CSI_ERR_ARG, "%s: zero size (%" PRIu32 "x%" PRIu32 "x%" PRIu32 " -> %" PRIu32 "x%" PRIu32 ")",
                        what, w, h, n, out_w, out_h);
    if (w % out_w || h % out_h)
        return csi_fail(CSI_ERR_ARG, "%s: %" PRIu32 "x%" PRIu32 " is not a multiple of %" PRIu32 "x%" PRIu32, what, w,
                        h, out_w, out_h);
    return CSI_OK;
}

csi_status csi_box_integrate(csi_ctx *ctx, cl_mem fine, uint32_t w, uint32_t h, uint32_t channels,
                             uint32_t out_w, uint32_t out_h, cl_mem out)
{
    CSI_TRY(check_blocks("csi_box_integrate", w, h, channels, out_w, out_h));
    CSI_TRY(need_bytes(fine, (size_t)w * h * channels * sizeof(float), "csi_box_integrate input"));
    CSI_TRY(need_bytes(out, (size_t)out_w * out_h * channels * sizeof(float), "csi_box_integrate output"));
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "integrate", "csi_box_integrate", &k));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(fine), CSI_MEM(out), CSI_ARG(w), CSI_ARG(h), CSI_ARG(out_w), CSI_ARG(out_h),
                     CSI_ARG(channels)));
    const size_t global[3] = {out_w, out_h, channels}, local[3] = {8, 8, 1};
    return csi_run(ctx, k, 3, global, local);
}

csi_status csi_time_mean(csi_ctx *ctx, cl_mem vol, uint32_t w, uint32_t h, uint32_t nt, uint32_t channels,
                         cl_mem out)
{
    if (!w || !h || !nt || !channels)
        return csi_fail(CSI_ERR_ARG, "csi_time_mean: zero size (%" PRIu32 "x%" PRIu32 "x%" PRIu32 "x%" PRIu32 ")", w,
                        h, nt, channels);
    CSI_TRY(need_bytes(vol, (size_t)w * h * nt * channels * sizeof(float), "csi_time_mean input"));
    CSI_TRY(need_bytes(out, (size_t)w * h * channels * sizeof(float), "csi_time_mean output"));
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "integrate", "csi_time_mean", &k));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(vol), CSI_MEM(out), CSI_ARG(w), CSI_ARG(h), CSI_ARG(nt), CSI_ARG(channels)));
    const size_t global[3] = {w, h, channels}, local[3] = {16, 4, 1};
    return csi_run(ctx, k, 3, global, local);
}

csi_status csi_box_time_var(csi_ctx *ctx, cl_mem vol, uint32_t w, uint32_t h, uint32_t nt, uint32_t out_w,
                            uint32_t out_h, cl_mem out)
{
    CSI_TRY(check_blocks("csi_box_time_var", w, h, nt, out_w, out_h));
    CSI_TRY(need_bytes(vol, (size_t)w * h * nt * sizeof(float), "csi_box_time_var input"));
    CSI_TRY(need_bytes(out, (size_t)out_w * out_h * sizeof(float), "csi_box_time_var output"));
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "integrate", "csi_box_time_var", &k));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(vol), CSI_MEM(out), CSI_ARG(w), CSI_ARG(h), CSI_ARG(nt), CSI_ARG(out_w),
                     CSI_ARG(out_h)));
    const size_t global[2] = {out_w, out_h}, local[2] = {8, 8};
    return csi_run(ctx, k, 2, global, local);
}

void csi_splat_mean_buffers(size_t n, uint32_t channels, size_t pixels, csi_mem_tally *t)
{
    csi_mem_tally_add(t, n * channels * sizeof(float), "splat sample values");
    csi_mem_tally_add(t, (pixels + 1) * sizeof(uint32_t), "splat pixel index");
}

csi_status csi_splat_mean(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, size_t n, cl_mem out, size_t *empty)
{
    if (!g->w || !g->h || !g->t || !g->out_w || !g->out_h || g->w % g->out_w || g->h % g->out_h)
        return csi_fail(CSI_ERR_ARG, "csi_splat_mean: bad grid %" PRIu32 "x%" PRIu32 "x%" PRIu32 " -> %" PRIu32
                        "x%" PRIu32, g->w, g->h, g->t, g->out_w, g->out_h);
    if (channels < 1 || channels > 4)
        return csi_fail(CSI_ERR_ARG, "csi_splat_mean: channels = %" PRIu32 " (must be 1 to 4)", channels);
    if (n >= UINT32_MAX)
        return csi_fail(CSI_ERR_ARG, "csi_splat_mean: %zu samples is more than the 2^32-1 the index holds", n);
    const size_t P = (size_t)g->out_w * g->out_h;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    CSI_TRY(need_bytes(out, P * channels * sizeof(float), "csi_splat_mean output"));

    uint32_t *offsets = calloc(P + 1, sizeof *offsets);
    uint32_t *pix = malloc((n ? n : 1) * sizeof *pix);
    float *sorted = malloc((n ? n : 1) * channels * sizeof *sorted);
    csi_status st = CSI_OK;
    cl_mem dvals = NULL, doff = NULL;
    if (!offsets || !pix || !sorted) {
        st = csi_fail(CSI_ERR_NOMEM, "csi_splat_mean: out of memory for %zu samples", n);
        goto done;
    }
    /* Stable counting sort by output pixel. */
    for (size_t i = 0; i < n; i++) {
        const csi_sample_pos p = pos[i];
        if (p.x >= g->w || p.y >= g->h || p.t >= g->t) {
            st = csi_fail(CSI_ERR_ARG, "csi_splat_mean: sample %zu at (%" PRIu32 ", %" PRIu32 ", %" PRIu32
                          ") is outside the grid", i, p.x, p.y, p.t);
            goto done;
        }
        pix[i] = (p.y / bh) * g->out_w + p.x / bw;
        offsets[pix[i] + 1]++;
    }
    size_t holes = 0;
    for (size_t p = 0; p < P; p++) {
        holes += offsets[p + 1] == 0;
        offsets[p + 1] += offsets[p];
    }
    {
        uint32_t *fill = malloc(P * sizeof *fill);
        if (!fill) {
            st = csi_fail(CSI_ERR_NOMEM, "csi_splat_mean: out of memory");
            goto done;
        }
        memcpy(fill, offsets, P * sizeof *fill);
        for (size_t i = 0; i < n; i++)
            memcpy(sorted + (size_t)fill[pix[i]]++ * channels, values + i * channels, channels * sizeof(float));
        free(fill);
    }
    if (empty)
        *empty = holes;
    if ((st = csi_buffer(ctx, n * channels * sizeof(float), CL_MEM_READ_ONLY, "splat sample values", &dvals)) ||
        (st = csi_buffer(ctx, (P + 1) * sizeof(uint32_t), CL_MEM_READ_ONLY, "splat pixel index", &doff)) ||
        (st = csi_write(ctx, dvals, 0, n * channels * sizeof(float), sorted)) ||
        (st = csi_write(ctx, doff, 0, (P + 1) * sizeof(uint32_t), offsets)))
        goto done;
    cl_kernel k;
    if ((st = csi_kernel(ctx, "integrate", "csi_splat_gather", &k)))
        goto done;
    const uint32_t ow = g->out_w, oh = g->out_h;
    if ((st = CSI_ARGS(k, CSI_MEM(dvals), CSI_MEM(doff), CSI_MEM(out), CSI_ARG(ow), CSI_ARG(oh), CSI_ARG(channels))))
        goto done;
    const size_t global[2] = {ow, oh}, local[2] = {8, 8};
    if ((st = csi_run(ctx, k, 2, global, local)))
        goto done;
    st = csi_finish(ctx); /* the host arrays are freed below; csi_write is blocking, but be explicit */
done:
    csi_buffer_release(&dvals);
    csi_buffer_release(&doff);
    free(offsets);
    free(pix);
    free(sorted);
    return st;
}
