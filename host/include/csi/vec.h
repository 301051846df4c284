/* Vector operations on device buffers for the solvers (kernels/vec.cl).
 *
 * Vectors are float32 device buffers. Complex vectors hold interleaved (re, im) pairs, so a
 * complex vector of n elements is 2n floats. Functions that treat every float alike (fill, copy,
 * scale, axpy, waxpby, real dot) take `nf`, the number of FLOATS, and work unchanged on complex
 * data: for complex x, y the real dot of the interleaved arrays is Re(x^H y), exactly the inner
 * product real-valued algorithms (CG, BB steps, objective values) need. Functions that need
 * magnitudes (asum, amax, soft thresholding, masks) take `n`, the number of ELEMENTS, and a
 * `cplx` flag.
 *
 * Reductions return double and have bounded rounding error. Each work-item sums a contiguous
 * chunk of the array in 16 (real terms) or 8 (complex terms) independent Kahan-compensated
 * chains, the SIMD lanes of one vector (the pending corrections kept); the lanes are merged by
 * exact TwoSum additions, the work-group's items by a pairwise tree of TwoSum additions, and
 * the (hi, lo) group partials are finished in double on the host. For a sum of terms v_i, each
 * formed with relative error <= u (u = 2^-24; 8 ulp for complex magnitudes, see vec.cl), the
 * computed S^ satisfies |S^ - S| <= (3u + O(m u^2)) * sum |v_i|, m = terms per Kahan chain
 * (at most about n / 65536 + 16 for large n: 4096 work-items x 16 lanes, plus the < 16-term
 * tail that one chain takes): u for forming each term, 2u for Kahan (Higham, "Accuracy and
 * Stability of Numerical Algorithms", 2nd ed., Sec. 4.3), O(u^2) for the TwoSum merges, tree
 * and double finish. That is about 1.8e-7 * sum |v_i| whatever n is. Norms are sqrt of such
 * sums, so they overflow only when sum x_i^2 exceeds FLT_MAX (|x| beyond ~1e19); the solvers
 * check for Inf/NaN. Complex magnitudes are scaled (no overflow or underflow for any finite
 * input, see cmag in vec.cl), so sums of |x_i| are accurate from subnormal to FLT_MAX.
 *
 * All reductions block (they read the partials back); element-wise calls only enqueue. */
#ifndef CSI_VEC_H
#define CSI_VEC_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/runtime.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Workspace for reductions: a small partials buffer on the device and its host mirror. One per
 * solver; reuse it for every call. */
typedef struct csi_vec_ws csi_vec_ws;
csi_status csi_vec_ws_create(csi_ctx *ctx, csi_vec_ws **out);
void csi_vec_ws_free(csi_vec_ws *ws);
void csi_vec_ws_buffers(csi_mem_tally *t); /* the device buffers csi_vec_ws_create allocates */
csi_ctx *csi_vec_ws_ctx(const csi_vec_ws *ws);

/* ---- element-wise (nf = number of floats) ---- */
csi_status csi_vec_fill(csi_ctx *ctx, cl_mem x, size_t nf, float v);            /* x = v     */
csi_status csi_vec_copy(csi_ctx *ctx, cl_mem dst, cl_mem src, size_t nf);       /* dst = src */
csi_status csi_vec_scale(csi_ctx *ctx, cl_mem x, size_t nf, float a);           /* x = a x   */
csi_status csi_vec_axpy(csi_ctx *ctx, size_t nf, float a, cl_mem x, cl_mem y);  /* y += a x  */
/* y = a x + b y */
csi_status csi_vec_axpby(csi_ctx *ctx, size_t nf, float a, cl_mem x, float b, cl_mem y);
/* y = x + b y (the CG direction update) */
csi_status csi_vec_xpay(csi_ctx *ctx, size_t nf, cl_mem x, float b, cl_mem y);
/* w = a x + b y; w may be x or y. */
csi_status csi_vec_waxpby(csi_ctx *ctx, size_t nf, float a, cl_mem x, float b, cl_mem y, cl_mem w);

/* ---- element-wise on elements (n elements, cplx: interleaved pairs) ---- */
/* out = soft(x, t), t >= 0: real sign(x) max(|x| - t, 0); complex x max(|x| - t, 0) / |x| with
 * x = 0 giving 0 and t = 0 giving x unchanged (no 0/0). out may be x. */
csi_status csi_vec_soft(csi_ctx *ctx, size_t n, bool cplx, cl_mem x, float t, cl_mem out);
/* x_i = 0 where mask_i == 0 (mask: n bytes). */
csi_status csi_vec_mask(csi_ctx *ctx, size_t n, bool cplx, cl_mem mask, cl_mem x);
/* mask_i = 1 where x_i != 0, else 0 (mask: n bytes). */
csi_status csi_vec_nonzero_mask(csi_ctx *ctx, size_t n, bool cplx, cl_mem x, cl_mem mask);

/* ---- reductions (blocking) ---- */
/* sum x_i y_i over nf floats: the real dot, or Re(x^H y) for interleaved complex data. */
csi_status csi_vec_dot(csi_vec_ws *ws, size_t nf, cl_mem x, cl_mem y, double *out);
/* The full complex x^H y over n complex elements: out[0] = Re, out[1] = Im. */
csi_status csi_vec_cdot(csi_vec_ws *ws, size_t n, cl_mem x, cl_mem y, double out[2]);
/* ||x||_2 over nf floats (real or complex alike). */
csi_status csi_vec_nrm2(csi_vec_ws *ws, size_t nf, cl_mem x, double *out);
/* ||x - y||_2^2 over nf floats, without forming x - y. */
csi_status csi_vec_dist2(csi_vec_ws *ws, size_t nf, cl_mem x, cl_mem y, double *out);
/* sum |x_i| over n elements (complex: magnitudes), i.e. ||x||_1. */
csi_status csi_vec_asum(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, double *out);
/* max |x_i| over n elements and the smallest index attaining it (idx may be NULL). n = 0 gives
 * 0 and index 0. A NaN anywhere is returned as the maximum. */
csi_status csi_vec_amax(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, double *val, size_t *idx);

/* ---- fused passes for SpaRSA (one kernel, one read-back each) ---- */
/* out = soft(x + c g, t) over n elements (the proximal gradient step; c = -1/alpha on the
 * gradient, +1/alpha on A^H r) and, in the same pass, *l1 = ||out||_1 and *dx2 = ||out - x||^2.
 * c finite, t >= 0; out may not alias x or g. */
csi_status csi_vec_prox_sums(csi_vec_ws *ws, size_t n, bool cplx, cl_mem x, cl_mem g, float c,
                             float t, cl_mem out, double *l1, double *dx2);
/* r = y - Az over nf floats and, in the same pass, *rr = ||r||^2, *dd = ||Az - Ax||^2 and
 * *ry = sum r_i y_i (Re<r, y> for complex data). r may not alias the inputs. */
csi_status csi_vec_resid_sums(csi_vec_ws *ws, size_t nf, cl_mem y, cl_mem Az, cl_mem Ax, cl_mem r,
                              double *rr, double *dd, double *ry);

#ifdef __cplusplus
}
#endif
#endif
