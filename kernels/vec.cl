/* Vector kernels for the solvers: element-wise updates and reductions.
 *
 * Complex vectors are interleaved (re, im) float pairs. Element-wise kernels that do not care
 * about complex structure take the number of floats; kernels that need magnitudes take the
 * number of elements and a `cplx` flag.
 *
 * Reductions: each work-item accumulates a strided slice with Kahan-compensated summation,
 * the work-group then combines its items' (sum, correction) pairs by a pairwise tree of exact
 * TwoSum additions in local memory and writes one (hi, lo) partial per group; the host adds the
 * partials in double (csi/vec.h states the bound).
 * Contraction into FMA is disabled so results do not depend on the compiler's choices and the
 * error analysis holds as written. Local size is fixed at VEC_LOCAL (a power of two). */
#pragma OPENCL FP_CONTRACT OFF

#define VEC_LOCAL 64

__kernel void vec_fill(__global float *x, const uint n, const float v)
{
    const size_t i = get_global_id(0);
    if (i < n)
        x[i] = v;
}

/* x = a * x */
__kernel void vec_scale(__global float *x, const uint n, const float a)
{
    const size_t i = get_global_id(0);
    if (i < n)
        x[i] = a * x[i];
}

/* w = a * x + b * y (w may be x or y) */
__kernel void vec_waxpby(__global float *w, const uint n, const float a, __global const float *x,
                         const float b, __global const float *y)
{
    const size_t i = get_global_id(0);
    if (i < n)
        w[i] = a * x[i] + b * y[i];
}

/* y = y + a * x */
__kernel void vec_axpy(const uint n, const float a, __global const float *x, __global float *y)
{
    const size_t i = get_global_id(0);
    if (i < n)
        y[i] = y[i] + a * x[i];
}

/* x_i = 0 where mask_i == 0 (per element; complex elements are two floats). */
__kernel void vec_mask(__global float *x, const uint n, const uint cplx, __global const uchar *mask)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    if (!mask[i]) {
        if (cplx) {
            x[2 * i] = 0.0f;
            x[2 * i + 1] = 0.0f;
        } else {
            x[i] = 0.0f;
        }
    }
}

/* mask_i = (x_i != 0) */
__kernel void vec_nonzero_mask(__global const float *x, const uint n, const uint cplx,
                               __global uchar *mask)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    mask[i] = cplx ? (x[2 * i] != 0.0f || x[2 * i + 1] != 0.0f) : (x[i] != 0.0f);
}

/* Soft threshold of v by t >= 0 into out. Real: sign(v) max(|v| - t, 0). Complex:
 * v max(|v| - t, 0) / |v|, with v = 0 mapped to 0 (the 0/0 guard) and t = 0 the identity. */
inline void soft1(const float v, const float t, __global float *o)
{
    const float m = fabs(v) - t;
    *o = m > 0.0f ? copysign(m, v) : 0.0f;
}
inline void soft2(const float re, const float im, const float t, __global float *o)
{
    if (t == 0.0f) {
        o[0] = re;
        o[1] = im;
        return;
    }
    const float mag = hypot(re, im);
    const float m = mag - t;
    if (m > 0.0f) { /* mag > t > 0, so no division by zero */
        const float f = m / mag;
        o[0] = re * f;
        o[1] = im * f;
    } else {
        o[0] = 0.0f;
        o[1] = 0.0f;
    }
}

__kernel void vec_soft(__global const float *x, const uint n, const uint cplx, const float t,
                       __global float *out)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    if (cplx)
        soft2(x[2 * i], x[2 * i + 1], t, out + 2 * i);
    else
        soft1(x[i], t, out + i);
}

/* The SpaRSA step: out = soft(x + c g, t) (c = -1/alpha on the gradient). */
__kernel void vec_prox_step(__global const float *x, __global const float *g, const uint n,
                            const uint cplx, const float c, const float t, __global float *out)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    if (cplx) {
        const float re = x[2 * i] + c * g[2 * i];
        const float im = x[2 * i + 1] + c * g[2 * i + 1];
        soft2(re, im, t, out + 2 * i);
    } else {
        soft1(x[i] + c * g[i], t, out + i);
    }
}

/* ---- reductions -------------------------------------------------------------------------- */

/* Pairwise tree over the work-group's VEC_LOCAL (hi, lo) sums in local memory, each addition
 * done exactly with Knuth's TwoSum (the rounding error of hi + hi goes into lo), so the tree adds
 * only O(u^2) relative error; item 0 writes the group's (hi, lo) pair. */
inline void group_sum(__local float *sh, __local float *sl, const uint l, __global float *partial)
{
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = VEC_LOCAL / 2; h > 0; h >>= 1) {
        if (l < h) {
            const float a = sh[l], b = sh[l + h];
            const float s = a + b;
            const float bb = s - a;
            const float e = (a - (s - bb)) + (b - bb);
            sh[l] = s;
            sl[l] = (sl[l] + sl[l + h]) + e;
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0) {
        partial[2 * get_group_id(0)] = sh[0];
        partial[2 * get_group_id(0) + 1] = sl[0];
    }
}

/* Kahan step: sum += v with compensation c. */
#define KAHAN_ADD(sum, c, v)           \
    do {                               \
        const float y_ = (v) - (c);    \
        const float t_ = (sum) + y_;   \
        (c) = (t_ - (sum)) - y_;       \
        (sum) = t_;                    \
    } while (0)

/* Which sum to take: 0 = sum x_i y_i, 1 = sum x_i^2 (y ignored), 2 = sum |x_i| (real),
 * 3 = sum |x_i| (complex, n elements = 2n floats), 4 = sum (x_i - y_i)^2,
 * 5 = imaginary part of x^H y over n complex elements: sum re(x) im(y) - im(x) re(y). */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_reduce(__global const float *x, __global const float *y, const uint n, const uint what,
                __global float *partial)
{
    __local float sh[VEC_LOCAL], sl[VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0);
    float sum = 0.0f, c = 0.0f;
    for (size_t i = get_global_id(0); i < n; i += stride) {
        float v;
        switch (what) {
        case 0: v = x[i] * y[i]; break;
        case 1: v = x[i] * x[i]; break;
        case 2: v = fabs(x[i]); break;
        case 3: v = hypot(x[2 * i], x[2 * i + 1]); break;
        case 4: { const float d = x[i] - y[i]; v = d * d; } break;
        default: v = x[2 * i] * y[2 * i + 1] - x[2 * i + 1] * y[2 * i]; break;
        }
        KAHAN_ADD(sum, c, v);
    }
    sh[l] = sum;
    sl[l] = -c; /* Kahan's pending correction: sum - c is the slice's sum */
    group_sum(sh, sl, l, partial);
}

/* Max |x_i| and its smallest index per work-group (complex: magnitude). NaN counts as larger
 * than everything so it surfaces in the result instead of hiding. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_amax(__global const float *x, const uint n, const uint cplx, __global float *pval,
              __global uint *pidx)
{
    __local float sv[VEC_LOCAL];
    __local uint si[VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0);
    float best = -1.0f;
    uint bi = 0xffffffffu;
    for (size_t i = get_global_id(0); i < n; i += stride) {
        const float v = cplx ? hypot(x[2 * i], x[2 * i + 1]) : fabs(x[i]);
        if (v > best || (isnan(v) && !isnan(best))) {
            best = v;
            bi = (uint)i;
        }
    }
    sv[l] = best;
    si[l] = bi;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = VEC_LOCAL / 2; h > 0; h >>= 1) {
        if (l < h) {
            const float a = sv[l], b = sv[l + h];
            const uint ia = si[l], ib = si[l + h];
            const bool take_b = (isnan(b) && !isnan(a)) || b > a || (b == a && ib < ia);
            if (take_b) {
                sv[l] = b;
                si[l] = ib;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0) {
        pval[get_group_id(0)] = sv[0];
        pidx[get_group_id(0)] = si[0];
    }
}
