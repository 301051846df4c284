/* Vector kernels for the solvers: element-wise updates and reductions.
 *
 * Complex vectors are interleaved (re, im) float pairs. Element-wise kernels that do not care
 * about complex structure take the number of floats; kernels that need magnitudes take the
 * number of elements and a `cplx` flag.
 *
 * Reductions: each work-item accumulates a contiguous chunk in 16 or 8 Kahan-compensated SIMD
 * lanes (layout below), merges its lanes exactly, the work-group then combines its items'
 * (hi, lo) pairs by a pairwise tree of exact TwoSum additions in local memory and writes one
 * (hi, lo) partial per group; the host adds the partials in double (csi/vec.h states the bound). The fused kernels (prox_sums, resid_sums)
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
 * quotient, square, sum, sqrt (3 ulp in OpenCL 1.2), product. Why scaled rather than
 * sqrt(re^2 + im^2): that form would do for the solvers' usual 1e-4..1e4 (squares 1e-8..1e8,
 * far inside float's normal range), but squares underflow below |x| ~ 1e-19 (FLT_MIN ~ 1.2e-38:
 * relative accuracy lost, vec.h's relative bound broken for tiny vectors) and overflow above
 * ~1.8e19. Here q = min/max is in [0, 1], so 1 + q^2 is in [1, 2] and m * sqrt(...) overflows
 * only when |z| itself exceeds FLT_MAX. The contiguous-chunk reductions below run at about
 * csi_copy's bytes per second with it (docs/bench/solve.md), so the division is not the limit. */
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

/* ---- reductions -------------------------------------------------------------------------- *
 * Layout (all reductions and fused passes): the array is cut into blocks of 16 floats (16 real
 * terms, or 8 complex elements), nb = full blocks. The host launches exactly G * VEC_LOCAL
 * work-items (no rounding) and passes `per`, the blocks per work-item; work-item j takes the
 * CONTIGUOUS blocks [j per, min((j + 1) per, nb)), clamped once before the loop, so the hot loop
 * has no bounds test and streams consecutive cache lines. (Striding blocks by the global size,
 * as before, made PoCL - which runs a group's work-items one after another - fetch each cache
 * line once per work-item touching it, and left one float4 Kahan chain latency-bound.) Each
 * work-item keeps 16 (real) or 8 (complex) independent Kahan chains, the lanes of one SIMD
 * vector; the < 16-float tail goes to global item 0 after its loop. Lanes are merged exactly by
 * TwoSum halving, then the group tree (group_sum) and the host's double finish follow. */

/* Kahan step: sum += v with compensation c, for any float vector type T. */
#define KAHAN_ADD_T(T, sum, c, v)      \
    do {                               \
        const T y_ = (v) - (c);        \
        const T t_ = (sum) + y_;       \
        (c) = (t_ - (sum)) - y_;       \
        (sum) = t_;                    \
    } while (0)
#define KAHAN_ADD(sum, c, v) KAHAN_ADD_T(float, sum, c, v)
#define KAHAN_ADD8(sum, c, v) KAHAN_ADD_T(float8, sum, c, v)
#define KAHAN_ADD16(sum, c, v) KAHAN_ADD_T(float16, sum, c, v)

/* hi + lo += v + vlo: Knuth's TwoSum of the high parts (exact: the rounding error of hi + v
 * goes into lo), low parts added plainly (they are O(u) of the sums, so that costs O(u^2)). */
#define TWO_SUM_INTO_T(T, hi, lo, v, vlo)                  \
    do {                                                   \
        const T s_ = (hi) + (v);                           \
        const T bb_ = s_ - (hi);                           \
        const T e_ = ((hi) - (s_ - bb_)) + ((v) - bb_);    \
        (hi) = s_;                                         \
        (lo) = ((lo) + (vlo)) + e_;                        \
    } while (0)

/* Pairwise tree over the work-group's VEC_LOCAL (hi, lo) sums of `nout` quantities in local
 * memory (sh[o * VEC_LOCAL + l]), each addition done exactly with TwoSum, so the tree adds only
 * O(u^2) relative error. Item 0 writes partial[(group * nout + o) * 2 + {0, 1}]. nout is
 * uniform, so the barriers are too. */
inline void group_sum(__local float *sh, __local float *sl, const uint l, const uint nout,
                      __global float *partial)
{
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = VEC_LOCAL / 2; h > 0; h >>= 1) {
        if (l < h) {
            for (uint o = 0; o < nout; o++) {
                const uint a_ = o * VEC_LOCAL + l, b_ = a_ + h;
                float s = sh[a_], e = sl[a_];
                TWO_SUM_INTO_T(float, s, e, sh[b_], sl[b_]);
                sh[a_] = s;
                sl[a_] = e;
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

/* Kahan lanes (sum - c each) merged into one exact (hi, lo) pair by TwoSum halving. */
inline float2 merge8(const float8 s, const float8 c)
{
    float4 h4 = s.lo, l4 = -c.lo;
    TWO_SUM_INTO_T(float4, h4, l4, s.hi, -c.hi);
    float2 h2 = h4.lo, l2 = l4.lo;
    TWO_SUM_INTO_T(float2, h2, l2, h4.hi, l4.hi);
    float h = h2.x, l = l2.x;
    TWO_SUM_INTO_T(float, h, l, h2.y, l2.y);
    return (float2)(h, l);
}
inline float2 merge16(const float16 s, const float16 c)
{
    float8 h8 = s.lo, l8 = -c.lo;
    TWO_SUM_INTO_T(float8, h8, l8, s.hi, -c.hi);
    /* (h8, l8) are (sum, -correction) lanes now: merge8 takes corrections, so negate back */
    return merge8(h8, -l8);
}

/* cmag on 8 lanes (see cmag for the error and why it is scaled). */
inline float8 cmag8(const float8 re, const float8 im)
{
    const float8 a = fabs(re), b = fabs(im);
    const float8 m = fmax(a, b), s = fmin(a, b);
    const float8 q = select((float8)(0.0f), s / m, isgreater(m, (float8)(0.0f)));
    return m * sqrt(1.0f + q * q);
}

/* Magnitudes for the reductions (asum, amax, prox_sums' l1): cmag, but NaN when either part is
 * NaN. fmax/fmin drop a NaN operand, so cmag(1, NaN) is finite and a NaN would hide from
 * csi_vec_amax, whose contract is that a NaN anywhere is returned (and from ||x||_1). |re| + |im|
 * is NaN exactly when a part is (both terms are >= 0, so no Inf - Inf). The soft threshold keeps
 * plain cmag: its element outputs are unchanged. */
inline float cmagn(const float re, const float im)
{
    const float s = fabs(re) + fabs(im);
    return isnan(s) ? s : cmag(re, im);
}
inline float8 cmagn8(const float8 re, const float8 im)
{
    const float8 s = fabs(re) + fabs(im);
    return select(cmag8(re, im), s, isnan(s));
}

/* This work-item's blocks [b0, b1) of nb (per blocks each, clamped: items past the end get an
 * empty range). size_t products: j * per can pass 2^32 for the last items of a large launch. */
#define CHUNK(nb, per, b0, b1)                                        \
    const size_t b0 = min((size_t)get_global_id(0) * (per), (nb));     \
    const size_t b1 = min(b0 + (per), (nb))

/* One-output reductions over 16-float blocks: real terms (REAL = 1, n floats, 16 lanes; TERM16(b)
 * the float16 of terms of block b) or complex (REAL = 0, n elements, 8 lanes; TERM8(b)). TERM1(i)
 * is the term of element i, for the tail. */
#define VEC_REDUCE_R(name, TERM16, TERM1)                                                      \
    __kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))                           \
    void name(__global const float *restrict x, __global const float *restrict y,              \
              const uint n, const uint per, __global float *partial)                           \
    {                                                                                          \
        __local float sh[VEC_LOCAL], sl[VEC_LOCAL];                                           \
        const uint l = get_local_id(0);                                                        \
        const size_t nb = n / 16;                                                              \
        CHUNK(nb, per, b0, b1);                                                                \
        float16 sum = (float16)(0.0f), c = (float16)(0.0f);                                   \
        for (size_t b = b0; b < b1; b++) {                                                     \
            const float16 v = (TERM16);                                                        \
            KAHAN_ADD16(sum, c, v);                                                            \
        }                                                                                      \
        if (get_global_id(0) == 0)                                                             \
            for (size_t i = 16 * nb; i < n; i++) {                                             \
                const float v1 = (TERM1);                                                      \
                KAHAN_ADD(sum.s0, c.s0, v1);                                                   \
            }                                                                                  \
        const float2 m = merge16(sum, c);                                                      \
        sh[l] = m.x;                                                                           \
        sl[l] = m.y;                                                                           \
        group_sum(sh, sl, l, 1, partial);                                                      \
    }
#define VEC_REDUCE_C(name, TERM8, TERM1)                                                       \
    __kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))                           \
    void name(__global const float *restrict x, __global const float *restrict y,              \
              const uint n, const uint per, __global float *partial)                           \
    {                                                                                          \
        __local float sh[VEC_LOCAL], sl[VEC_LOCAL];                                           \
        const uint l = get_local_id(0);                                                        \
        const size_t nb = n / 8;                                                               \
        CHUNK(nb, per, b0, b1);                                                                \
        float8 sum = (float8)(0.0f), c = (float8)(0.0f);                                      \
        for (size_t b = b0; b < b1; b++) {                                                     \
            const float8 v = (TERM8);                                                          \
            KAHAN_ADD8(sum, c, v);                                                             \
        }                                                                                      \
        if (get_global_id(0) == 0)                                                             \
            for (size_t i = 8 * nb; i < n; i++) {                                              \
                const float v1 = (TERM1);                                                      \
                KAHAN_ADD(sum.s0, c.s0, v1);                                                   \
            }                                                                                  \
        const float2 m = merge8(sum, c);                                                       \
        sh[l] = m.x;                                                                           \
        sl[l] = m.y;                                                                           \
        group_sum(sh, sl, l, 1, partial);                                                      \
    }

VEC_REDUCE_R(vec_red_dot, vload16(b, x) * vload16(b, y), x[i] * y[i])
VEC_REDUCE_R(vec_red_sumsq, vload16(b, x) * vload16(b, x), x[i] * x[i])
VEC_REDUCE_R(vec_red_asum_r, fabs(vload16(b, x)), fabs(x[i]))
VEC_REDUCE_R(vec_red_dist2, (vload16(b, x) - vload16(b, y)) * (vload16(b, x) - vload16(b, y)),
             (x[i] - y[i]) * (x[i] - y[i]))
/* complex, n elements: block b holds elements 8b .. 8b+7 = floats 16b .. 16b+15 */
VEC_REDUCE_C(vec_red_asum_c, cmagn8(vload16(b, x).even, vload16(b, x).odd),
             cmagn(x[2 * i], x[2 * i + 1]))
/* imaginary part of x^H y over n complex elements */
VEC_REDUCE_C(vec_red_cdot_im,
             vload16(b, x).even * vload16(b, y).odd - vload16(b, x).odd * vload16(b, y).even,
             x[2 * i] * y[2 * i + 1] - x[2 * i + 1] * y[2 * i])

inline float16 soft1_16(const float16 v, const float t)
{
    const float16 m = fabs(v) - t;
    return select((float16)(0.0f), copysign(m, v), isgreater(m, (float16)(0.0f)));
}

/* complex soft threshold factor of 8 elements (re, im as float8); the 0/0 guard as in soft2 */
inline float8 soft2_factor8(const float8 re, const float8 im, const float t)
{
    const float8 mag = cmag8(re, im);
    const float8 m = mag - t;
    const float8 f = select((float8)(0.0f), m / mag, isgreater(m, (float8)(0.0f)));
    return t == 0.0f ? (float8)(1.0f) : f;
}

/* Fused SpaRSA trial step, real (n floats): out = soft(x + c g, t); sums |out_i| and
 * (out_i - x_i)^2. Contiguous chunks and 16 Kahan lanes per quantity, as in VEC_REDUCE_R. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_prox_sums_r(__global const float *restrict x, __global const float *restrict g,
                     const uint n, const uint per, const float cf, const float t,
                     __global float *restrict out, __global float *partial)
{
    __local float sh[2 * VEC_LOCAL], sl[2 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t nb = n / 16;
    CHUNK(nb, per, b0, b1);
    float16 s0 = (float16)(0.0f), c0 = s0, s1 = s0, c1 = s0;
    for (size_t b = b0; b < b1; b++) {
        const float16 xv = vload16(b, x);
        const float16 o = soft1_16(xv + cf * vload16(b, g), t);
        vstore16(o, b, out);
        KAHAN_ADD16(s0, c0, fabs(o));
        KAHAN_ADD16(s1, c1, (o - xv) * (o - xv));
    }
    if (get_global_id(0) == 0)
        for (size_t i = 16 * nb; i < n; i++) {
            const float xi = x[i];
            const float o = soft1(xi + cf * g[i], t);
            out[i] = o;
            KAHAN_ADD(s0.s0, c0.s0, fabs(o));
            KAHAN_ADD(s1.s0, c1.s0, (o - xi) * (o - xi));
        }
    const float2 m0 = merge16(s0, c0), m1 = merge16(s1, c1);
    sh[l] = m0.x;
    sl[l] = m0.y;
    sh[VEC_LOCAL + l] = m1.x;
    sl[VEC_LOCAL + l] = m1.y;
    group_sum(sh, sl, l, 2, partial);
}

/* Complex (n elements): sums |out_i| and |out_i - x_i|^2. Block b = elements 8b .. 8b+7. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_prox_sums_c(__global const float *restrict x, __global const float *restrict g,
                     const uint n, const uint per, const float cf, const float t,
                     __global float *restrict out, __global float *partial)
{
    __local float sh[2 * VEC_LOCAL], sl[2 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t nb = n / 8;
    CHUNK(nb, per, b0, b1);
    float8 s0 = (float8)(0.0f), c0 = s0, s1 = s0, c1 = s0;
    for (size_t b = b0; b < b1; b++) {
        const float16 xv = vload16(b, x), gv = vload16(b, g);
        const float8 re = xv.even + cf * gv.even, im = xv.odd + cf * gv.odd;
        const float8 f = soft2_factor8(re, im, t);
        const float8 ore = re * f, oim = im * f;
        float16 o;
        o.even = ore;
        o.odd = oim;
        vstore16(o, b, out);
        KAHAN_ADD8(s0, c0, cmagn8(ore, oim));
        KAHAN_ADD8(s1, c1, (ore - xv.even) * (ore - xv.even) + (oim - xv.odd) * (oim - xv.odd));
    }
    if (get_global_id(0) == 0)
        for (size_t i = 8 * nb; i < n; i++) {
            const float xr = x[2 * i], xi = x[2 * i + 1];
            const float2 o = soft2(xr + cf * g[2 * i], xi + cf * g[2 * i + 1], t);
            out[2 * i] = o.x;
            out[2 * i + 1] = o.y;
            KAHAN_ADD(s0.s0, c0.s0, cmagn(o.x, o.y));
            KAHAN_ADD(s1.s0, c1.s0, (o.x - xr) * (o.x - xr) + (o.y - xi) * (o.y - xi));
        }
    const float2 m0 = merge8(s0, c0), m1 = merge8(s1, c1);
    sh[l] = m0.x;
    sl[l] = m0.y;
    sh[VEC_LOCAL + l] = m1.x;
    sl[VEC_LOCAL + l] = m1.y;
    group_sum(sh, sl, l, 2, partial);
}

/* Fused residual pass over n floats: r = y - Az; sums r_i^2, (Az_i - Ax_i)^2, r_i y_i. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_resid_sums(__global const float *restrict y, __global const float *restrict Az,
                    __global const float *restrict Ax, const uint n, const uint per,
                    __global float *restrict r, __global float *partial)
{
    __local float sh[3 * VEC_LOCAL], sl[3 * VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t nb = n / 16;
    CHUNK(nb, per, b0, b1);
    float16 s0 = (float16)(0.0f), c0 = s0, s1 = s0, c1 = s0, s2 = s0, c2 = s0;
    for (size_t b = b0; b < b1; b++) {
        const float16 yv = vload16(b, y), zv = vload16(b, Az);
        const float16 rv = yv - zv, dv = zv - vload16(b, Ax);
        vstore16(rv, b, r);
        KAHAN_ADD16(s0, c0, rv * rv);
        KAHAN_ADD16(s1, c1, dv * dv);
        KAHAN_ADD16(s2, c2, rv * yv);
    }
    if (get_global_id(0) == 0)
        for (size_t i = 16 * nb; i < n; i++) {
            const float yi = y[i], zi = Az[i];
            const float ri = yi - zi, di = zi - Ax[i];
            r[i] = ri;
            KAHAN_ADD(s0.s0, c0.s0, ri * ri);
            KAHAN_ADD(s1.s0, c1.s0, di * di);
            KAHAN_ADD(s2.s0, c2.s0, ri * yi);
        }
    const float2 m0 = merge16(s0, c0), m1 = merge16(s1, c1), m2 = merge16(s2, c2);
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

/* Running per-lane maximum: within a lane indices only grow, so strict > keeps the first
 * maximum; NaN replaces a number. */
#define AMAX_STEP(T, IT, UT, best, bidx, v, idx)                           \
    do {                                                                   \
        const IT take_ = isgreater((v), (best)) | (isnan(v) & ~isnan(best)); \
        (best) = select((best), (v), take_);                               \
        (bidx) = select((bidx), (idx), as_##UT(take_));                    \
    } while (0)

/* Max |x_i| per work-group and its smallest index (complex: cmag). NaN counts as larger than
 * everything so it surfaces in the result instead of hiding. Contiguous chunks of 16-float
 * blocks as in the sums (16 real or 8 complex lanes), lanes merged with amax_take; tail by
 * global item 0. */
__kernel __attribute__((reqd_work_group_size(VEC_LOCAL, 1, 1)))
void vec_amax(__global const float *restrict x, const uint n, const uint per, const uint cplx,
              __global float *pval, __global uint *pidx)
{
    __local float sv[VEC_LOCAL];
    __local uint si[VEC_LOCAL];
    const uint l = get_local_id(0);
    const size_t nb = cplx ? n / 8 : n / 16;
    CHUNK(nb, per, b0, b1);
    float bv = -1.0f;
    uint bi = 0xffffffffu;
    if (cplx) {
        float8 best = (float8)(-1.0f);
        uint8 bidx = (uint8)(0xffffffffu);
        for (size_t b = b0; b < b1; b++) {
            const float16 z = vload16(b, x);
            const float8 v = cmagn8(z.even, z.odd);
            AMAX_STEP(float8, int8, uint8, best, bidx, v,
                      (uint8)(8 * (uint)b) + (uint8)(0, 1, 2, 3, 4, 5, 6, 7));
        }
        for (int k = 0; k < 8; k++)
            amax_take(&bv, &bi, best[k], bidx[k]);
    } else {
        float16 best = (float16)(-1.0f);
        uint16 bidx = (uint16)(0xffffffffu);
        for (size_t b = b0; b < b1; b++) {
            const float16 v = fabs(vload16(b, x));
            AMAX_STEP(float16, int16, uint16, best, bidx, v,
                      (uint16)(16 * (uint)b) +
                          (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15));
        }
        for (int k = 0; k < 16; k++)
            amax_take(&bv, &bi, best[k], bidx[k]);
    }
    if (get_global_id(0) == 0)
        for (size_t i = (cplx ? 8 : 16) * nb; i < n; i++)
            amax_take(&bv, &bi, cplx ? cmagn(x[2 * i], x[2 * i + 1]) : fabs(x[i]), (uint)i);
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
