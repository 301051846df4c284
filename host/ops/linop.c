/* Composition of operators: (outer . inner) x = outer(inner(x)), with one scratch buffer. */
#include "csi/linop.h"

#include <stdlib.h>

typedef struct {
    csi_linop *outer, *inner;
    bool owns;
    cl_mem mid; /* inner->rows elements */
} compose_state;

void csi_linop_free(csi_linop *op)
{
    if (!op)
        return;
    if (op->destroy)
        op->destroy(op);
    free(op);
}

static csi_status compose_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    compose_state *s = op->state;
    CSI_TRY(csi_linop_apply(s->inner, x, s->mid));
    return csi_linop_apply(s->outer, s->mid, y);
}

static csi_status compose_adjoint(const csi_linop *op, cl_mem y, cl_mem x)
{
    compose_state *s = op->state;
    CSI_TRY(csi_linop_adjoint(s->outer, y, s->mid));
    return csi_linop_adjoint(s->inner, s->mid, x);
}

static void compose_destroy(csi_linop *op)
{
    compose_state *s = op->state;
    if (!s)
        return;
    csi_buffer_release(&s->mid);
    if (s->owns) {
        csi_linop_free(s->outer);
        csi_linop_free(s->inner);
    }
    free(s);
    op->state = NULL;
}

void csi_linop_compose_buffers(size_t inner_rows, bool complex_valued, csi_mem_tally *t)
{
    csi_mem_tally_add(t, inner_rows * (complex_valued ? 8u : 4u), "an operator composition's scratch vector");
}

csi_status csi_linop_compose(const char *name, csi_linop *outer, csi_linop *inner, bool owns,
                             csi_linop **out)
{
    *out = NULL;
    if (inner->rows != outer->cols)
        return csi_fail(CSI_ERR_ARG, "composing %s after %s: %zu outputs feed %zu inputs",
                        outer->name ? outer->name : "?", inner->name ? inner->name : "?",
                        inner->rows, outer->cols);
    if (inner->complex_valued != outer->complex_valued)
        return csi_fail(CSI_ERR_ARG, "composing %s after %s: real and complex operators mixed",
                        outer->name ? outer->name : "?", inner->name ? inner->name : "?");
    csi_linop *op = calloc(1, sizeof *op);
    compose_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory composing operators");
    }
    csi_status st = csi_buffer(inner->ctx, inner->rows * csi_linop_elem(inner), CL_MEM_READ_WRITE,
                               "an operator composition's scratch vector", &s->mid);
    if (st != CSI_OK) {
        free(op);
        free(s);
        return st;
    }
    s->outer = outer;
    s->inner = inner;
    s->owns = owns;
    op->rows = outer->rows;
    op->cols = inner->cols;
    op->complex_valued = inner->complex_valued;
    op->name = name;
    op->ctx = inner->ctx;
    op->apply = compose_apply;
    op->adjoint = compose_adjoint;
    op->destroy = compose_destroy;
    op->state = s;
    *out = op;
    return CSI_OK;
}
