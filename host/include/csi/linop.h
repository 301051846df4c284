/* Linear operators as function pairs on device buffers (never matrices).
 *
 * An operator maps a vector of `cols` elements to one of `rows` elements. When complex_valued
 * is true both sides hold complex numbers stored as interleaved float pairs (re, im), so a
 * vector of n elements occupies 2n floats; otherwise plain floats. `apply` computes y = A x and
 * `adjoint` x = A^H y; neither may alias its input and output. State (plans, filters, scratch)
 * is made once at creation and reused by every call. */
#ifndef CSI_LINOP_H
#define CSI_LINOP_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/runtime.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_linop csi_linop;
struct csi_linop {
    size_t rows, cols;
    bool complex_valued;
    const char *name;
    csi_ctx *ctx;
    csi_status (*apply)(const csi_linop *op, cl_mem x, cl_mem y);
    csi_status (*adjoint)(const csi_linop *op, cl_mem y, cl_mem x);
    void (*destroy)(csi_linop *op); /* frees state; NULL if nothing to free */
    void *state;
};

/* Bytes of one element on each side (4 for real, 8 for complex). */
static inline size_t csi_linop_elem(const csi_linop *op) { return op->complex_valued ? 8u : 4u; }

static inline csi_status csi_linop_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    return op->apply(op, x, y);
}
static inline csi_status csi_linop_adjoint(const csi_linop *op, cl_mem y, cl_mem x)
{
    return op->adjoint(op, y, x);
}

/* Destroys op (its state and the struct itself, which must come from malloc); NULL is fine. */
void csi_linop_free(csi_linop *op);

/* out = outer . inner (inner applied first). Takes ownership of both when `owns` is true.
 * inner->rows must equal outer->cols and both must agree on complex_valued. */
csi_status csi_linop_compose(const char *name, csi_linop *outer, csi_linop *inner, bool owns,
                             csi_linop **out);

/* The device buffer csi_linop_compose allocates: a vector of the inner operator's rows. */
void csi_linop_compose_buffers(size_t inner_rows, bool complex_valued, csi_mem_tally *t);

#ifdef __cplusplus
}
#endif
#endif
