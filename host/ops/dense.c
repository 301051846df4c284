/* Dense matrix operator (kernels/dense.cl): A and A^H stored row-major on the device. */
#include "csi/dense.h"

#include <math.h>
#include <stdlib.h>

typedef struct {
    cl_mem A, AH;
} dense_state;

static csi_status matvec(const csi_linop *op, cl_mem M, size_t rows, size_t cols, cl_mem in, cl_mem out)
{
    cl_kernel k;
    CSI_TRY(csi_kernel(op->ctx, "dense", op->complex_valued ? "dense_matvec_c" : "dense_matvec", &k));
    cl_uint r = (cl_uint)rows, c = (cl_uint)cols;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(M), CSI_ARG(r), CSI_ARG(c), CSI_MEM(in), CSI_MEM(out)));
    size_t g = rows, l = 16; /* few rows: small groups spread them over both cores */
    return csi_run(op->ctx, k, 1, &g, &l);
}

static csi_status dense_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    dense_state *s = op->state;
    return matvec(op, s->A, op->rows, op->cols, x, y);
}

static csi_status dense_adjoint(const csi_linop *op, cl_mem y, cl_mem x)
{
    dense_state *s = op->state;
    return matvec(op, s->AH, op->cols, op->rows, y, x);
}

static void dense_destroy(csi_linop *op)
{
    dense_state *s = op->state;
    if (s) {
        csi_buffer_release(&s->A);
        csi_buffer_release(&s->AH);
        free(s);
    }
    op->state = NULL;
}

csi_status csi_dense_create(csi_ctx *ctx, size_t rows, size_t cols, const float *A_rowmajor,
                            bool complex_valued, csi_linop **out)
{
    *out = NULL;
    if (rows == 0 || cols == 0 || rows > 0xffffffu || cols > 0xffffffu)
        return csi_fail(CSI_ERR_ARG, "dense operator: %zu x %zu is not a usable size", rows, cols);
    if (!A_rowmajor)
        return csi_fail(CSI_ERR_ARG, "dense operator: no matrix given");
    size_t w = complex_valued ? 2 : 1;
    size_t nf = rows * cols * w;
    for (size_t i = 0; i < nf; i++)
        if (!isfinite(A_rowmajor[i]))
            return csi_fail(CSI_ERR_ARG, "dense operator: entry (%zu, %zu) is not finite",
                            i / w / cols, i / w % cols);
    float *ah = malloc(nf * sizeof *ah);
    csi_linop *op = calloc(1, sizeof *op);
    dense_state *s = calloc(1, sizeof *s);
    if (!ah || !op || !s) {
        free(ah);
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a %zu x %zu dense operator", rows, cols);
    }
    /* A^H: transpose, conjugate for complex. */
    for (size_t r = 0; r < rows; r++)
        for (size_t c = 0; c < cols; c++) {
            if (complex_valued) {
                ah[2 * (c * rows + r)] = A_rowmajor[2 * (r * cols + c)];
                ah[2 * (c * rows + r) + 1] = -A_rowmajor[2 * (r * cols + c) + 1];
            } else {
                ah[c * rows + r] = A_rowmajor[r * cols + c];
            }
        }
    op->rows = rows;
    op->cols = cols;
    op->complex_valued = complex_valued;
    op->name = "dense";
    op->ctx = ctx;
    op->apply = dense_apply;
    op->adjoint = dense_adjoint;
    op->destroy = dense_destroy;
    op->state = s;
    csi_status st = csi_buffer(ctx, nf * sizeof(float), CL_MEM_READ_ONLY, "a dense matrix", &s->A);
    if (st == CSI_OK)
        st = csi_buffer(ctx, nf * sizeof(float), CL_MEM_READ_ONLY, "a dense matrix's adjoint", &s->AH);
    if (st == CSI_OK)
        st = csi_write(ctx, s->A, 0, nf * sizeof(float), A_rowmajor);
    if (st == CSI_OK)
        st = csi_write(ctx, s->AH, 0, nf * sizeof(float), ah);
    free(ah);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}
