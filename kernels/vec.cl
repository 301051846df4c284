/* Vector kernels for the solvers: element-wise updates and reductions.
 *
 * Complex vectors are interleaved (re, im) float pairs. Element-wise kernels that do not care
 * about complex structure take the number of floats; kernels that need magnitudes take the
 * number of elements and a `cplx` flag.
 *
 * Reductions: each work-item accumulates a strided slice with Kahan-compensated summation,
 * the work-group then combines its items' (sum, correction) pairs by a pairwise tree of exact
 * TwoSum additions in local memory and writes one (hi, lo) partial per group; the host adds the
 * partials in double (csi/vec.h states the bound). The fused kernels (prox_sums, resid_sums)
 * do an update and several such reductions in one pass, for SpaRSA.
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

/* |re + i im| without overflow or harmful underflow (scaled like hypot, but branch-free so
 * PoCL vectorises it; OpenCL's hypot measured ~10x slower here). Relative error <= 8 ulp:
 * quotient, square, sum, sqrt (3 ulp in OpenCL 1.2), product. */
inline float cmag(const float re, const float im)
{
    const float a = fabs(re), b = fabs(im);
    const float m = fmax(a, b), s = fmin(a, b);
    const float q = m > 0.0f ? s / m : 0.0f;
    return m * sqrt(1.0f + q * q);
}

/* Soft threshold of v by t >= 0. Real: sign(v) max(|v| - t, 0). Complex: v max(|v| - t, 0) / |v|,
 * v = 0 mapped to 0 (the 0/0 guard: mag > t >= 0 before dividing) and t = 0 the identity. */
inline float soft1(const float v, const float t)
{
    const float m = fabs(v) - t;
    return m > 0.0f ? copysign(m, v) : 0.0f;
}
inline float2 soft2(const float re, const float im, const float t)
{
    const float mag = cmag(re, im);
    const float m = mag - t;
    const float f = t == 0.0f ? 1.0f : (m > 0.0f ? m / mag : 0.0f);
    return (float2)(re * f, im * f);
}

__kernel void vec_soft_r(__global const float *x, const uint n, const float t, __global float *out)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = soft1(x[i], t);
}

__kernel void vec_soft_c(__global const float *x, const uint n, const float t, __global float *out)
{
    const size_t i = get_global_id(0);
    if (i < n) {
        const float2 o = soft2(x[2 * i], x[2 * i + 1], t);
        out[2 * i] = o.x;
        out[2 * i + 1] = o.y;
    }
}

/* ---- reductions -------------------------------------------------------------------------- */

/* Kahan step: sum += v with compensation c (float; KAHAN_ADD4 for float4 lanes). */
#define KAHAN_ADD_T(T, sum, c, v)      \
    do {                               \
        const T y_ = (v) - (c);        \
        const T t_ = (sum) + y_;       \
        (c) = (t_ - (sum)) - y_;       \
        (sum) = t_;                    \
    } while (0)
#define KAHAN_ADD(sum, c, v) KAHAN_ADD_T(float, sum, c, v)
#define KAHAN_ADD4(sum, c, v) KAHAN_ADD_T(float4, sum, c, v)

/* Pairwise tree over the work-group's VEC_LOCAL (hi, lo) sums of `nout` quantities in local
 * memory (sh[o * VEC_LOCAL + l]), each addition done exactly with Knuth's TwoSum (the rounding
 * error of hi + hi goes into lo), so the tree adds only O(u^2) relative error. Item 0 writes
 * partial[(group * nout + o) * 2 + {0, 1}]. nout is uniform, so the barriers are too. */
inline void group_sum(__local float *sh, __local float *sl, const uint l, const uint nout,
                      __global float *partial)
{
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = VEC_LOCAL / 2; h > 0; h >>= 1) {
        if (l < h) {
            for (uint o = 0; o < nout; o++) {
                const uint a_ = o * VEC_LOCAL + l, b_ = a_ + h;
                const float a = sh[a_], b = sh[b_];
                const float s = a + b;
                const float bb = s - a;
                const float e = (a - (s - bb)) + (b - bb);
                sh[a_] = s;
                sl[a_] = (sl[a_] + sl[b_]) + e;
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0)
        for (uint o = 0; o < nout; o++) {
            partial[(get_group_id(0) * nout + o) * 2] = sh[o * VEC_LOCAL];
            partial[(get_group_id(0) * nout + o) * 2 + 1] = sl[o * VEC_LOCAL];
        }
}

inline float4 cmag4(const float4 re, const float4 im)
{
    const float4 a = fabs(re), b = fabs(im);
    const float4 m = fmax(a, b), s = fmin(a, b);
    const float4 q = select((float4)(0.0f), s / m, isgreater(m, (float4)(0.0f)));
    return m * sqrt(1.0f + q * q);
}

/* hi + lo += v exactly (TwoSum of the high parts, low parts added). */
#define TWO_SUM_INTO(hi, lo, v, vlo)                   \
    do {                                               \
        const float s_ = (hi) + (v);                   \
        const float bb_ = s_ - (hi);                   \
        const float e_ = ((hi) - (s_ - bb_)) + ((v) - bb_); \
        (hi) = s_;                                     \
        (lo) = ((lo) + (vlo)) + e_;                    \
    } while (0)

/* One-output reductions. Each work-item runs four independent Kahan chains (the lanes of a
 * float4, elements 4b .. 4b+3 of block b, blocks strided over the NDRange): one chain is
 * latency-bound at ~4 dependent adds per element, four lanes run in one SIMD register. The
 * n % 4 tail goes to global item 0. The lanes are then merged exactly (TwoSum) and the group
 * tree follows. TERM4(b) gives the float4 of terms of block b, TERM1(i) the term of element i. */
#define VEC_REDUCE(name, TERM4, TERM1)                                                         \
    __kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))                           \
    void name(__global const float *x, __global const float *y, const uint n,                 \
              __global float *partial)                                                         \
    {                                                                                          \
        __local float sh[VEC_LOCAL], sl[VEC_LOCAL];                                           \
        const uint l = get_local_id(0);                                                        \
        const size_t stride = get_global_size(0), nb = n / 4;                                  \
        float4 sum = (float4)(0.0f), c = (float4)(0.0f);                                      \
        for (size_t b = get_global_id(0); b < nb; b += stride) {                               \
            const float4 v = (TERM4);                                                          \
            KAHAN_ADD4(sum, c, v);                                                             \
        }                                                                                      \
        if (get_global_id(0) == 0)                                                             \
            for (size_t i = 4 * nb; i < n; i++) {                                              \
                const float v1 = (TERM1);                                                      \
                KAHAN_ADD(sum.x, c.x, v1);                                                     \
            }                                                                                  \
        float hi = sum.x, lo = -c.x;                                                           \
        TWO_SUM_INTO(hi, lo, sum.y, -c.y);                                                     \
        TWO_SUM_INTO(hi, lo, sum.z, -c.z);                                                     \
        TWO_SUM_INTO(hi, lo, sum.w, -c.w);                                                     \
        sh[l] = hi;                                                                            \
        sl[l] = lo; /* Kahan's pending corrections: sum - c is each lane's sum */              \
        group_sum(sh, sl, l, 1, partial);                                                      \
    }

VEC_REDUCE(vec_red_dot, vload4(b, x) * vload4(b, y), x[i] * y[i])
VEC_REDUCE(vec_red_sumsq, vload4(b, x) * vload4(b, x), x[i] * x[i])
VEC_REDUCE(vec_red_asum_r, fabs(vload4(b, x)), fabs(x[i]))
VEC_REDUCE(vec_red_dist2, (vload4(b, x) - vload4(b, y)) * (vload4(b, x) - vload4(b, y)),
           (x[i] - y[i]) * (x[i] - y[i]))
/* complex, n elements: block b holds elements 4b .. 4b+3 = floats 8b .. 8b+7 */
VEC_REDUCE(vec_red_asum_c, cmag4(vload8(b, x).even, vload8(b, x).odd), cmag(x[2 * i], x[2 * i + 1]))
/* imaginary part of x^H y over n complex elements */
VEC_REDUCE(vec_red_cdot_im, vload8(b, x).even * vload8(b, y).odd - vload8(b, x).odd * vload8(b, y).even,
           x[2 * i] * y[2 * i + 1] - x[2 * i + 1] * y[2 * i])

/* Merges float4 Kahan lanes (sum - c each) into one exact (hi, lo) pair. */
inline float2 lanes_merge(const float4 sum, const float4 c)
{
    float hi = sum.x, lo = -c.x;
    TWO_SUM_INTO(hi, lo, sum.y, -c.y);
    TWO_SUM_INTO(hi, lo, sum.z, -c.z);
    TWO_SUM_INTO(hi, lo, sum.w, -c.w);
    return (float2)(hi, lo);
}

inline float4 soft1_4(const float4 v, const float t)
{
    const float4 m = fabs(v) - t;
    return select((float4)(0.0f), copysign(m, v), isgreater(m, (float4)(0.0f)));
}

/* complex soft threshold of 4 elements (re, im as float4); the 0/0 guard as in soft2 */
inline float4 soft2_factor4(const float4 re, const float4 im, const float t)
{
    const float4 mag = cmag4(re, im);
    const float4 m = mag - t;
    const float4 f = select((float4)(0.0f), m / mag, isgreater(m, (float4)(0.0f)));
    return t == 0.0f ? (float4)(1.0f) : f;
}

/* Fused SpaRSA trial step, real: out = soft(x + c g, t); sums |out_i| and (out_i - x_i)^2.
 * Four float4 Kahan lanes per quantity, as in VEC_REDUCE. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_prox_sums_r(__global const float *x, __global const float *g, const uint n, const float cf,
                     const float t, __global float *out, __global float *partial)
{
    __local float sh[2 * VEC_LOCAL], sl[2 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0), nb = n / 4;
    float4 s0 = (float4)(0.0f), c0 = s0, s1 = s0, c1 = s0;
    for (size_t b = get_global_id(0); b < nb; b += stride) {
        const float4 xv = vload4(b, x);
        const float4 o = soft1_4(xv + cf * vload4(b, g), t);
        vstore4(o, b, out);
        KAHAN_ADD4(s0, c0, fabs(o));
        KAHAN_ADD4(s1, c1, (o - xv) * (o - xv));
    }
    if (get_global_id(0) == 0)
        for (size_t i = 4 * nb; i < n; i++) {
            const float xi = x[i];
            const float o = soft1(xi + cf * g[i], t);
            out[i] = o;
            KAHAN_ADD(s0.x, c0.x, fabs(o));
            KAHAN_ADD(s1.x, c1.x, (o - xi) * (o - xi));
        }
    const float2 m0 = lanes_merge(s0, c0), m1 = lanes_merge(s1, c1);
    sh[l] = m0.x;
    sl[l] = m0.y;
    sh[VEC_LOCAL + l] = m1.x;
    sl[VEC_LOCAL + l] = m1.y;
    group_sum(sh, sl, l, 2, partial);
}

/* Complex (n elements): sums |out_i| and |out_i - x_i|^2. Block b = elements 4b .. 4b+3. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_prox_sums_c(__global const float *x, __global const float *g, const uint n, const float cf,
                     const float t, __global float *out, __global float *partial)
{
    __local float sh[2 * VEC_LOCAL], sl[2 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0), nb = n / 4;
    float4 s0 = (float4)(0.0f), c0 = s0, s1 = s0, c1 = s0;
    for (size_t b = get_global_id(0); b < nb; b += stride) {
        const float8 xv = vload8(b, x), gv = vload8(b, g);
        const float4 re = xv.even + cf * gv.even, im = xv.odd + cf * gv.odd;
        const float4 f = soft2_factor4(re, im, t);
        const float4 ore = re * f, oim = im * f;
        float8 o;
        o.even = ore;
        o.odd = oim;
        vstore8(o, b, out);
        KAHAN_ADD4(s0, c0, cmag4(ore, oim));
        KAHAN_ADD4(s1, c1, (ore - xv.even) * (ore - xv.even) + (oim - xv.odd) * (oim - xv.odd));
    }
    if (get_global_id(0) == 0)
        for (size_t i = 4 * nb; i < n; i++) {
            const float xr = x[2 * i], xi = x[2 * i + 1];
            const float2 o = soft2(xr + cf * g[2 * i], xi + cf * g[2 * i + 1], t);
            out[2 * i] = o.x;
            out[2 * i + 1] = o.y;
            KAHAN_ADD(s0.x, c0.x, cmag(o.x, o.y));
            KAHAN_ADD(s1.x, c1.x, (o.x - xr) * (o.x - xr) + (o.y - xi) * (o.y - xi));
        }
    const float2 m0 = lanes_merge(s0, c0), m1 = lanes_merge(s1, c1);
    sh[l] = m0.x;
    sl[l] = m0.y;
    sh[VEC_LOCAL + l] = m1.x;
    sl[VEC_LOCAL + l] = m1.y;
    group_sum(sh, sl, l, 2, partial);
}

/* Fused residual pass over nf floats: r = y - Az; sums r_i^2, (Az_i - Ax_i)^2, r_i y_i. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_resid_sums(__global const float *y, __global const float *Az, __global const float *Ax,
                    const uint n, __global float *r, __global float *partial)
{
    __local float sh[3 * VEC_LOCAL], sl[3 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0), nb = n / 4;
    float4 s0 = (float4)(0.0f), c0 = s0, s1 = s0, c1 = s0, s2 = s0, c2 = s0;
    for (size_t b = get_global_id(0); b < nb; b += stride) {
        const float4 yv = vload4(b, y), zv = vload4(b, Az);
        const float4 rv = yv - zv, dv = zv - vload4(b, Ax);
        vstore4(rv, b, r);
        KAHAN_ADD4(s0, c0, rv * rv);
        KAHAN_ADD4(s1, c1, dv * dv);
        KAHAN_ADD4(s2, c2, rv * yv);
    }
    if (get_global_id(0) == 0)
        for (size_t i = 4 * nb; i < n; i++) {
            const float yi = y[i], zi = Az[i];
            const float ri = yi - zi, di = zi - Ax[i];
            r[i] = ri;
            KAHAN_ADD(s0.x, c0.x, ri * ri);
            KAHAN_ADD(s1.x, c1.x, di * di);
            KAHAN_ADD(s2.x, c2.x, ri * yi);
        }
    const float2 m0 = lanes_merge(s0, c0), m1 = lanes_merge(s1, c1), m2 = lanes_merge(s2, c2);
    sh[l] = m0.x;
    sl[l] = m0.y;
    sh[VEC_LOCAL + l] = m1.x;
    sl[VEC_LOCAL + l] = m1.y;
    sh[2 * VEC_LOCAL + l] = m2.x;
    sl[2 * VEC_LOCAL + l] = m2.y;
    group_sum(sh, sl, l, 3, partial);
}

/* Keeps (bv, bi) or takes (v, i): NaN beats numbers, larger beats smaller, equal values go to
 * the smaller index. */
inline void amax_take(float *bv, uint *bi, const float v, const uint i)
{
    const bool take = (isnan(v) && !isnan(*bv)) || v > *bv || (v == *bv && i < *bi);
    if (take) {
        *bv = v;
        *bi = i;
    }
}

/* Max |x_i| per work-group and its smallest index (complex: cmag). NaN counts as larger than
 * everything so it surfaces in the result instead of hiding. Four float4 lanes per work-item
 * (elements 4b .. 4b+3 of block b), merged with amax_take; tail by global item 0. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_amax(__global const float *x, const uint n, const uint cplx, __global float *pval,
              __global uint *pidx)
{
    __local float sv[VEC_LOCAL];
    __local uint si[VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t stride = get_global_size(0), nb = n / 4;
    float4 best = (float4)(-1.0f);
    uint4 bidx = (uint4)(0xffffffffu);
    for (size_t b = get_global_id(0); b < nb; b += stride) {
        float4 v;
        if (cplx) {
            const float8 z = vload8(b, x);
            v = cmag4(z.even, z.odd);
        } else {
            v = fabs(vload4(b, x));
        }
        /* within a lane indices only grow, so strict > keeps the first maximum */
        const int4 take = isgreater(v, best) | (isnan(v) & ~isnan(best));
        best = select(best, v, take);
        bidx = select(bidx, (uint4)(4 * (uint)b) + (uint4)(0, 1, 2, 3), as_uint4(take));
    }
    float bv = best.x;
    uint bi = bidx.x;
    amax_take(&bv, &bi, best.y, bidx.y);
    amax_take(&bv, &bi, best.z, bidx.z);
    amax_take(&bv, &bi, best.w, bidx.w);
    if (get_global_id(0) == 0)
        for (size_t i = 4 * nb; i < n; i++)
            amax_take(&bv, &bi, cplx ? cmag(x[2 * i], x[2 * i + 1]) : fabs(x[i]), (uint)i);
    sv[l] = bv;
    si[l] = bi;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = VEC_LOCAL / 2; h > 0; h >>= 1) {
        if (l < h) {
            float a = sv[l];
            uint ia = si[l];
            amax_take(&a, &ia, sv[l + h], si[l + h]);
            sv[l] = a;
            si[l] = ia;
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0) {
        pval[get_group_id(0)] = sv[0];
        pidx[get_group_id(0)] = si[0];
    }
}
