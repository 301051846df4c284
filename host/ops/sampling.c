/* Sampling operator: gather at sample positions, scatter back (kernels/sampling.cl). */
#include "csi/sampling.h"

#include <stdlib.h>
#include <string.h>

typedef struct {
    cl_mem idx;
    cl_uint n;
} sampling_state;

static csi_status sampling_apply(const csi_linop *op, cl_mem f, cl_mem y)
{
    sampling_state *s = op->state;
    cl_kernel k;
    CSI_TRY(csi_kernel(op->ctx, "sampling", "sampling_gather", &k));
    cl_uint w = op->complex_valued ? 2 : 1;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(f), CSI_MEM(s->idx), CSI_ARG(s->n), CSI_ARG(w), CSI_MEM(y)));
    size_t g = s->n, l = 64;
    return csi_run(op->ctx, k, 1, &g, &l);
}

static csi_status sampling_adjoint(const csi_linop *op, cl_mem y, cl_mem f)
{
    sampling_state *s = op->state;
    CSI_TRY(csi_fill_zero(op->ctx, f, op->cols * csi_linop_elem(op)));
    cl_kernel k;
    CSI_TRY(csi_kernel(op->ctx, "sampling", "sampling_scatter", &k));
    cl_uint w = op->complex_valued ? 2 : 1;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(y), CSI_MEM(s->idx), CSI_ARG(s->n), CSI_ARG(w), CSI_MEM(f)));
    size_t g = s->n, l = 64;
    return csi_run(op->ctx, k, 1, &g, &l);
}

static void sampling_destroy(csi_linop *op)
{
    sampling_state *s = op->state;
    if (s) {
        csi_buffer_release(&s->idx);
        free(s);
    }
    op->state = NULL;
}

void csi_sampling_buffers(size_t n, csi_mem_tally *t)
{
    csi_mem_tally_add(t, n * sizeof(uint32_t), "sample indices");
}

csi_status csi_sampling_create(csi_ctx *ctx, size_t k, const uint32_t *indices, size_t n,
                               bool complex_valued, csi_linop **out)
{
    *out = NULL;
    if (k == 0)
        return csi_fail(CSI_ERR_ARG, "sampling operator: the signal size k must be positive");
    if (k > 0xffffffffu || n > 0xffffffffu)
        return csi_fail(CSI_ERR_ARG, "sampling operator: k = %zu, n = %zu beyond 2^32 - 1", k, n);
    if (n > 0 && !indices)
        return csi_fail(CSI_ERR_ARG, "sampling operator: %zu samples but no index array", n);
    /* Range and uniqueness in one pass with a bitmap over the grid (k / 8 bytes). */
    unsigned char *seen = calloc((k + 7) / 8, 1);
    if (!seen)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory checking %zu sample indices", n);
    for (size_t i = 0; i < n; i++) {
        uint32_t j = indices[i];
        if (j >= k) {
            free(seen);
            return csi_fail(CSI_ERR_ARG, "sample record %zu: index %u is outside the grid of %zu "
                            "elements", i, j, k);
        }
        if (seen[j / 8] & (1u << (j % 8))) {
            size_t first = 0;
            while (indices[first] != j)
                first++;
            free(seen);
            return csi_fail(CSI_ERR_ARG, "sample record %zu: its cell (linear index %u on the grid) repeats "
                            "record %zu's (average duplicate samples of a cell first)", i, j, first);
        }
        seen[j / 8] |= (unsigned char)(1u << (j % 8));
    }
    free(seen);

    csi_linop *op = calloc(1, sizeof *op);
    sampling_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the sampling operator");
    }
    s->n = (cl_uint)n;
    csi_status st = csi_buffer(ctx, n * sizeof(uint32_t), CL_MEM_READ_ONLY, "sample indices", &s->idx);
    if (st == CSI_OK)
        st = csi_write(ctx, s->idx, 0, n * sizeof(uint32_t), indices);
    op->rows = n;
    op->cols = k;
    op->complex_valued = complex_valued;
    op->name = "sampling";
    op->ctx = ctx;
    op->apply = sampling_apply;
    op->adjoint = sampling_adjoint;
    op->destroy = sampling_destroy;
    op->state = s;
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}
