/* The 2-D periodized orthonormal Daubechies wavelet operator (see csi/wavelet.h).
 *
 * Filters rather than lifting: PyWavelets' periodization path is defined by the filters
 * (pywt/_extensions/c/convolution.template.c), so the same index formula reproduces it exactly,
 * including bands shorter than the filter where taps wrap around several times; the adjoint is
 * the same coefficients with transposed indices, orthonormal to float rounding by construction.
 * A lifting factorisation of db8 (Daubechies & Sweldens 1998) would save about half the
 * multiply-adds but has lifting coefficients of widely varying size (worse float rounding), and
 * on this memory-bound CPU device the cost is the passes over memory, which lifting does not
 * reduce.
 *
 * Per level: one x pass (rows) and one y pass (columns), out of place between the output and one
 * scratch image made at create. The forward transform reads the input only at level 1, so x and
 * the coefficient vector never alias; the inverse reads the coarsest approximation straight from
 * the coefficient vector and the details where they lie, so it needs no copy either. */
#include "csi/wavelet.h"

#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    csi_wavelet_family family;
    size_t w, h;
    int levels;
    cl_mem tmp; /* one w x h scratch image */
    cl_kernel fwd_x, fwd_y, inv_x, inv_y;
} wavelet_state;

const char *csi_wavelet_name(csi_wavelet_family f)
{
    switch (f) {
    case CSI_WAVELET_DB4: return "db4";
    case CSI_WAVELET_DB8: return "db8";
    }
    return "?";
}

int csi_wavelet_taps(csi_wavelet_family f)
{
    switch (f) {
    case CSI_WAVELET_DB4: return 8;
    case CSI_WAVELET_DB8: return 16;
    }
    return 0;
}

csi_status csi_wavelet_parse(const char *s, csi_wavelet_family *out)
{
    if (s && strcmp(s, "db4") == 0) {
        *out = CSI_WAVELET_DB4;
        return CSI_OK;
    }
    if (s && strcmp(s, "db8") == 0) {
        *out = CSI_WAVELET_DB8;
        return CSI_OK;
    }
    return csi_fail(CSI_ERR_ARG, "unknown wavelet '%s': expected db4 (8 taps) or db8 (16 taps)",
                    s ? s : "(null)");
}

/* Number of factors of two common to w and h (both non-zero). */
static int common_twos(size_t w, size_t h)
{
    int t = 0;
    while (((w >> t) & 1) == 0 && ((h >> t) & 1) == 0)
        t++;
    return t;
}

int csi_wavelet_default_levels(csi_wavelet_family f, size_t w, size_t h)
{
    int taps = csi_wavelet_taps(f);
    if (taps == 0 || w == 0 || h == 0 || w % 2 || h % 2)
        return 0;
    /* Factors of two common to both sides. */
    int twos = common_twos(w, h);
    /* pywt.dwt_max_level(min(w, h), taps) = floor(log2(min / (taps - 1))), 0 if min < taps - 1. */
    size_t m = w < h ? w : h;
    int maxl = 0;
    while ((m >> (maxl + 1)) >= (size_t)(taps - 1))
        maxl++;
    int l = maxl < twos ? maxl : twos;
    return l < 1 ? 1 : l;
}

static wavelet_state *state_of(const csi_linop *op) { return (wavelet_state *)op->state; }

void csi_wavelet_coarse_block(const csi_linop *op, size_t *cw, size_t *ch)
{
    const wavelet_state *s = state_of(op);
    if (cw)
        *cw = s->w >> s->levels;
    if (ch)
        *ch = s->h >> s->levels;
}

csi_wavelet_family csi_wavelet_family_of(const csi_linop *op) { return state_of(op)->family; }
int csi_wavelet_levels(const csi_linop *op) { return state_of(op)->levels; }

/* Largest power of two <= min(n, cap), at least 1. */
static size_t pow2_at_most(size_t n, size_t cap)
{
    size_t m = n < cap ? n : cap, p = 1;
    while (p * 2 <= m)
        p *= 2;
    return p;
}

/* Launch a 2-D pass over g0 x g1 items with a local size fitted to small regions (coarse levels
 * can be a few items wide): up to 64 along the contiguous dimension, 256 items per group. */
static csi_status run2(csi_ctx *ctx, cl_kernel k, size_t g0, size_t g1)
{
    size_t global[2] = {g0, g1};
    size_t l0 = pow2_at_most(g0, 64);
    size_t local[2] = {l0, pow2_at_most(g1, 256 / l0)};
    return csi_run(ctx, k, 2, global, local);
}

/* adjoint: image y -> coefficients x (forward DWT). */
static csi_status wavelet_analysis(const csi_linop *op, cl_mem img, cl_mem coef)
{
    wavelet_state *s = state_of(op);
    const cl_uint stride = (cl_uint)s->w;
    for (int l = 0; l < s->levels; l++) {
        const cl_uint n = (cl_uint)(s->w >> l), m = (cl_uint)(s->h >> l);
        cl_mem src = l == 0 ? img : coef;
        CSI_TRY(CSI_ARGS(s->fwd_x, CSI_MEM(src), CSI_MEM(s->tmp), CSI_ARG(stride), CSI_ARG(n),
                         CSI_ARG(m)));
        CSI_TRY(run2(op->ctx, s->fwd_x, (n / 2 + 7) / 8, m)); /* 8 outputs per item */
        CSI_TRY(CSI_ARGS(s->fwd_y, CSI_MEM(s->tmp), CSI_MEM(coef), CSI_ARG(stride), CSI_ARG(n),
                         CSI_ARG(m)));
        CSI_TRY(run2(op->ctx, s->fwd_y, (n + 15) / 16, m / 2)); /* 16 columns per item */
    }
    return CSI_OK;
}

/* apply: coefficients x -> image y (inverse DWT), coarsest level first. */
static csi_status wavelet_synthesis(const csi_linop *op, cl_mem coef, cl_mem img)
{
    wavelet_state *s = state_of(op);
    const cl_uint stride = (cl_uint)s->w;
    for (int l = s->levels; l >= 1; l--) {
        const cl_uint n = (cl_uint)(s->w >> (l - 1)), m = (cl_uint)(s->h >> (l - 1));
        const cl_uint arows = m / 2;
        cl_mem approx = l == s->levels ? coef : img;
        CSI_TRY(CSI_ARGS(s->inv_x, CSI_MEM(approx), CSI_MEM(coef), CSI_MEM(s->tmp), CSI_ARG(stride),
                         CSI_ARG(n), CSI_ARG(m), CSI_ARG(arows)));
        CSI_TRY(run2(op->ctx, s->inv_x, (n / 2 + 7) / 8, m));
        CSI_TRY(CSI_ARGS(s->inv_y, CSI_MEM(s->tmp), CSI_MEM(img), CSI_ARG(stride), CSI_ARG(n),
                         CSI_ARG(m)));
        CSI_TRY(run2(op->ctx, s->inv_y, (n + 15) / 16, m / 2));
    }
    return CSI_OK;
}

static void wavelet_destroy(csi_linop *op)
{
    wavelet_state *s = state_of(op);
    if (s) {
        csi_buffer_release(&s->tmp);
        free(s);
    }
    op->state = NULL;
}

csi_status csi_wavelet_create(csi_ctx *ctx, csi_wavelet_family f, size_t w, size_t h, int levels,
                              csi_linop **out)
{
    *out = NULL;
    const char *name = csi_wavelet_name(f);
    if (csi_wavelet_taps(f) == 0)
        return csi_fail(CSI_ERR_ARG, "unknown wavelet family %d: expected CSI_WAVELET_DB4 or "
                        "CSI_WAVELET_DB8", (int)f);
    if (w == 0 || h == 0)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu has a zero side", name, w, h);
    if (levels < 1)
        return csi_fail(CSI_ERR_ARG, "wavelet %s on %zux%zu: %d levels requested, need at least 1",
                        name, w, h, levels);
    const int twos = common_twos(w, h);
    if (levels > twos)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu is not divisible by 2^%d as %d "
                        "levels need (at most %d level%s possible for this size)", name, w, h,
                        levels, levels, twos, twos == 1 ? " is" : "s are");
    /* Kernels index with 32-bit ints. */
    if (w > INT_MAX / h)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu has more than %d pixels, over "
                        "the kernels' 32-bit indexing", name, w, h, INT_MAX);

    wavelet_state *s = calloc(1, sizeof *s);
    csi_linop *op = calloc(1, sizeof *op);
    if (!s || !op) {
        free(s);
        free(op);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory creating the %s wavelet", name);
    }
    s->family = f;
    s->w = w;
    s->h = h;
    s->levels = levels;
    op->rows = op->cols = w * h;
    op->complex_valued = false;
    op->name = f == CSI_WAVELET_DB4 ? "wavelet db4" : "wavelet db8";
    op->ctx = ctx;
    op->apply = wavelet_synthesis;
    op->adjoint = wavelet_analysis;
    op->destroy = wavelet_destroy;
    op->state = s;

    char what[96];
    snprintf(what, sizeof what, "the %s wavelet's scratch image (%zux%zu)", name, w, h);
    csi_status st = csi_buffer(ctx, w * h * sizeof(float), CL_MEM_READ_WRITE, what, &s->tmp);
    const int db8 = f == CSI_WAVELET_DB8;
    if (st == CSI_OK)
        st = csi_kernel(ctx, "wavelet", db8 ? "csi_wavelet_fwd_x_db8" : "csi_wavelet_fwd_x_db4", &s->fwd_x);
    if (st == CSI_OK)
        st = csi_kernel(ctx, "wavelet", db8 ? "csi_wavelet_fwd_y_db8" : "csi_wavelet_fwd_y_db4", &s->fwd_y);
    if (st == CSI_OK)
        st = csi_kernel(ctx, "wavelet", db8 ? "csi_wavelet_inv_x_db8" : "csi_wavelet_inv_x_db4", &s->inv_x);
    if (st == CSI_OK)
        st = csi_kernel(ctx, "wavelet", db8 ? "csi_wavelet_inv_y_db8" : "csi_wavelet_inv_y_db4", &s->inv_y);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}
