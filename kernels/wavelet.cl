/* 2-D orthonormal Daubechies wavelet, periodized, in the layout of PyWavelets'
 * coeffs_to_array(wavedec2(img, w, mode='periodization', level=L)) (Mallat layout).
 *
 * Filters (not lifting): one level along one axis is a pair of periodic convolutions followed by
 * downsampling by two, written exactly as PyWavelets' periodization path
 * (pywt/_extensions/c/convolution.template.c, downsampling_convolution_periodization):
 *
 *     a[o] = sum_j lo[j] * x[(2o + F/2 - j) mod n],   d[o] = sum_j hi[j] * x[(2o + F/2 - j) mod n]
 *
 * for o in [0, n/2), F the filter length. The inverse is the transpose of that matrix (the
 * periodized filter bank is orthogonal for every even n, also n < F where taps wrap around the
 * band several times): with F/2 even (F = 8, 16), output sample 2p takes the even taps and 2p+1
 * the odd taps,
 *
 *     x[2p]   = sum_k lo[2k]   a[p+k-F/4]   + hi[2k]   d[p+k-F/4]
 *     x[2p+1] = sum_k lo[2k+1] a[p+k+1-F/4] + hi[2k+1] d[p+k+1-F/4]      (indices mod n/2).
 *
 * Each pass has two kernels: an interior kernel, 16 outputs per work-item with no edge test,
 * launched only over items whose taps stay inside the band, and an edge kernel with periodic
 * wrap for the rest (a few outputs at each end of a band, leftover columns, and whole bands
 * shorter than the filter). The host (host/ops/wavelet.c) makes that split.
 *
 * One level of the 2-D transform is an x pass (rows) then a y pass (columns) over the top-left
 * region of the array still holding the approximation; `sstride` and `dstride` are the row
 * strides of source and destination in floats: the image width for the image and coefficient
 * arrays, a padded width for the scratch image (see host/ops/wavelet.c). */

/* Daubechies' extremal-phase orthonormal filters: Daubechies, "Ten Lectures on Wavelets" (SIAM
 * 1992), Table 6.1, in the order and sign convention of PyWavelets 1.8 (pywt.Wavelet('db4').dec_lo,
 * 'db8'), which tests/data/wavelet/gen_refs.py checks this table against. dec_hi[j] =
 * (-1)^(j+1) dec_lo[F-1-j] (the quadrature mirror filter). The reconstruction filters are these
 * reversed, which the transposed index formulas above express. */
__constant float csi_db4_lo[8] = {
    -0.010597401785069032f, 0.032883011666885197f, 0.030841381835560764f, -0.18703481171909309f,
    -0.027983769416859854f, 0.63088076792985892f, 0.71484657055291567f, 0.23037781330889651f};
__constant float csi_db4_hi[8] = {
    -0.23037781330889651f, 0.71484657055291567f, -0.63088076792985892f, -0.027983769416859854f,
    0.18703481171909309f, 0.030841381835560764f, -0.032883011666885197f, -0.010597401785069032f};
__constant float csi_db8_lo[16] = {
    -0.00011747678412476953f, 0.00067544940645056933f, -0.00039174037337694705f,
    -0.0048703529934515741f, 0.0087460940474057766f, 0.013981027917398282f,
    -0.044088253930794755f, -0.017369301001807547f, 0.12874742662047847f,
    0.00047248457391328279f, -0.28401554296154691f, -0.015829105256349306f,
    0.58535468365420673f, 0.67563073629728976f, 0.31287159091429995f, 0.054415842243104008f};
__constant float csi_db8_hi[16] = {
    -0.054415842243104008f, 0.31287159091429995f, -0.67563073629728976f, 0.58535468365420673f,
    0.015829105256349306f, -0.28401554296154691f, -0.00047248457391328279f, 0.12874742662047847f,
    0.017369301001807547f, -0.044088253930794755f, -0.013981027917398282f,
    0.0087460940474057766f, 0.0048703529934515741f, -0.00039174037337694705f,
    -0.00067544940645056933f, -0.00011747678412476953f};

/* Non-negative remainder; i may be negative (taps left of the band) or several bands long (a
 * band shorter than the filter). */
inline int wrap(int i, int n)
{
    int r = i % n;
    return r < 0 ? r + n : r;
}

/* Vectorisation. PoCL's CPU back end vectorises across work-items only when a kernel has no
 * data-dependent control flow; measured at 1024x1024, a one-output-per-item kernel with an edge
 * branch was 7x slower than the same without it. So each interior work-item computes 16-wide
 * vectors explicitly: 16 consecutive outputs of a row in the x passes (three float16 loads split
 * into even and odd samples, then shifted 16-wide windows of those), 16 adjacent columns in the
 * y passes (one float16 load per tap row). Even then an edge path inside the same kernel, never
 * taken, made PoCL's code 3x slower, hence the separate edge kernels.
 *
 * WIN(A, B, K) is elements K .. K+15 of the 32-vector A:B. With clang (PoCL) it is
 * __builtin_shufflevector, one permute instruction; PoCL's shuffle2() with the same constant mask
 * measured 2-4x slower (the mask is not folded), so shuffle2 is only the portable fallback. */
#if defined(__clang__)
#define WIN(A, B, K)                                                                               \
    __builtin_shufflevector(A, B, K, K + 1, K + 2, K + 3, K + 4, K + 5, K + 6, K + 7, K + 8,      \
                            K + 9, K + 10, K + 11, K + 12, K + 13, K + 14, K + 15)
#define ZIP_LO(A, B) __builtin_shufflevector(A, B, 0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23)
#define ZIP_HI(A, B)                                                                               \
    __builtin_shufflevector(A, B, 8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31)
#else
#define WIN(A, B, K) shuffle2(A, B, (uint16)(K) + (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15))
#define ZIP_LO(A, B) shuffle2(A, B, (uint16)(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23))
#define ZIP_HI(A, B) shuffle2(A, B, (uint16)(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31))
#endif

/* Forward x taps. With base = 2 o0 - F/2, E[k] = row[base + 2k] and O[k] = row[base + 2k + 1]
 * (k < 24, held as E0:E1 and O0:O1), output o0 + t needs row[base + F + 2t - j]: E[t + (F-j)/2]
 * for even F-j, O[t + (F-j-1)/2] for odd. FTAP(j, V) accumulates tap j for the 16 outputs. */
#define FTAP(LO, HI, J, V)           \
    {                                \
        const float16 v_ = (V);      \
        a = fma(LO[J], v_, a);       \
        d = fma(HI[J], v_, d);       \
    }
#define FWD_X_TAPS_8(LO, HI)                                                                       \
    FTAP(LO, HI, 0, WIN(E0, E1, 4)) FTAP(LO, HI, 1, WIN(O0, O1, 3))                                \
    FTAP(LO, HI, 2, WIN(E0, E1, 3)) FTAP(LO, HI, 3, WIN(O0, O1, 2))                                \
    FTAP(LO, HI, 4, WIN(E0, E1, 2)) FTAP(LO, HI, 5, WIN(O0, O1, 1))                                \
    FTAP(LO, HI, 6, WIN(E0, E1, 1)) FTAP(LO, HI, 7, WIN(O0, O1, 0))
#define FWD_X_TAPS_16(LO, HI)                                                                      \
    FTAP(LO, HI, 0, WIN(E0, E1, 8)) FTAP(LO, HI, 1, WIN(O0, O1, 7))                                \
    FTAP(LO, HI, 2, WIN(E0, E1, 7)) FTAP(LO, HI, 3, WIN(O0, O1, 6))                                \
    FTAP(LO, HI, 4, WIN(E0, E1, 6)) FTAP(LO, HI, 5, WIN(O0, O1, 5))                                \
    FTAP(LO, HI, 6, WIN(E0, E1, 5)) FTAP(LO, HI, 7, WIN(O0, O1, 4))                                \
    FTAP(LO, HI, 8, WIN(E0, E1, 4)) FTAP(LO, HI, 9, WIN(O0, O1, 3))                                \
    FTAP(LO, HI, 10, WIN(E0, E1, 3)) FTAP(LO, HI, 11, WIN(O0, O1, 2))                              \
    FTAP(LO, HI, 12, WIN(E0, E1, 2)) FTAP(LO, HI, 13, WIN(O0, O1, 1))                              \
    FTAP(LO, HI, 14, WIN(E0, E1, 1)) FTAP(LO, HI, 15, WIN(O0, O1, 0))

/* Inverse x taps. With A[i] = a[p0 - F/4 + i] (i < 24, held as A0:A1), D likewise, output pair
 * p0 + t: the even sample from A[t + k], D[t + k] with taps 2k; the odd sample from A[t + k + 1],
 * D[t + k + 1] with taps 2k + 1. */
#define ITAP(LO, HI, K)                                                                            \
    e = fma(LO[2 * K], WIN(A0, A1, K), fma(HI[2 * K], WIN(D0, D1, K), e));                         \
    od = fma(LO[2 * K + 1], WIN(A0, A1, K + 1), fma(HI[2 * K + 1], WIN(D0, D1, K + 1), od));
#define INV_X_TAPS_8(LO, HI) ITAP(LO, HI, 0) ITAP(LO, HI, 1) ITAP(LO, HI, 2) ITAP(LO, HI, 3)
#define INV_X_TAPS_16(LO, HI)                                                                      \
    INV_X_TAPS_8(LO, HI) ITAP(LO, HI, 4) ITAP(LO, HI, 5) ITAP(LO, HI, 6) ITAP(LO, HI, 7)

/* Analysis along x, interior: work-item (q, y) computes outputs o in [o0, o0 + 16),
 * o0 = first + 16q, of row y: a[o] to column o, d[o] to column n/2 + o. The host launches it only
 * over items whose 48-sample window [2 o0 - F/2, 2 o0 - F/2 + 48) lies inside the row, so the
 * kernel has no edge branch (one in the same kernel, even never taken, made PoCL's code 3x
 * slower). src and dst are distinct buffers. */
#define CSI_FWD_X(NAME, F, LO, HI, TAPS)                                                           \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint rows, const uint first,        \
                       const uint items)                                                           \
    {                                                                                              \
        const int q = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        if (q >= (int)items || y >= (int)rows)                                                     \
            return;                                                                                \
        const int nh = (int)(n >> 1), o0 = (int)first + 16 * q, base = 2 * o0 - F / 2;           \
        __global const float *row = src + (size_t)y * sstride + base;                              \
        __global float *out = dst + (size_t)y * dstride + o0;                                      \
        const float16 w0 = vload16(0, row), w1 = vload16(1, row), w2 = vload16(2, row);            \
        const float16 E0 = (float16)(w0.even, w1.even), O0 = (float16)(w0.odd, w1.odd);           \
        const float16 E1 = (float16)(w2.even, w2.even), O1 = (float16)(w2.odd, w2.odd);           \
        float16 a = 0.0f, d = 0.0f;                                                                \
        TAPS(LO, HI)                                                                               \
        vstore16(a, 0, out);                                                                       \
        vstore16(d, 0, out + nh);                                                                  \
    }

/* Analysis along x, 16-output items whose window crosses the row's ends: work-item (i, y) does
 * the item starting at o0 = 16c, c = i for i < lo, c = hi + (i - lo) after, with the 48-sample
 * window gathered with periodic wrap (then the same taps as the interior kernel). */
#define CSI_FWD_XW(NAME, F, LO, HI, TAPS)                                                          \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint rows, const uint lo,           \
                       const uint hi, const uint count)                                            \
    {                                                                                              \
        const int i = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        if (i >= (int)count || y >= (int)rows)                                                     \
            return;                                                                                \
        const int nh = (int)(n >> 1);                                                              \
        const int o0 = 16 * (i < (int)lo ? i : (int)hi + (i - (int)lo));                          \
        __global const float *row = src + (size_t)y * sstride;                                     \
        float win[48];                                                                             \
        int k = wrap(2 * o0 - F / 2, (int)n);                                                      \
        for (int t = 0; t < 48; t++) {                                                             \
            win[t] = row[k];                                                                       \
            k = k + 1 == (int)n ? 0 : k + 1;                                                       \
        }                                                                                          \
        const float16 w0 = vload16(0, win), w1 = vload16(1, win), w2 = vload16(2, win);            \
        const float16 E0 = (float16)(w0.even, w1.even), O0 = (float16)(w0.odd, w1.odd);           \
        const float16 E1 = (float16)(w2.even, w2.even), O1 = (float16)(w2.odd, w2.odd);           \
        float16 a = 0.0f, d = 0.0f;                                                                \
        TAPS(LO, HI)                                                                               \
        __global float *out = dst + (size_t)y * dstride + o0;                                      \
        vstore16(a, 0, out);                                                                       \
        vstore16(d, 0, out + nh);                                                                  \
    }

/* Analysis along x, edges: one output per work-item (i, y), for the outputs the interior kernel
 * does not cover: o = i for i < lo, o = hi + (i - lo) after, taps wrapped periodically. */
#define CSI_FWD_X_EDGE(NAME, F, LO, HI)                                                            \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint rows, const uint lo,           \
                       const uint hi)                                                              \
    {                                                                                              \
        const int i = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1), o = i < (int)lo ? i : (int)hi + (i - (int)lo);              \
        if (o >= nh || y >= (int)rows)                                                             \
            return;                                                                                \
        __global const float *row = src + (size_t)y * sstride;                                     \
        /* Taps read row[top - j], top = 2o + F/2: one remainder, then step down with a wrap. */  \
        int k = wrap(2 * o + F / 2, (int)n);                                                       \
        float a = 0.0f, d = 0.0f;                                                                  \
        for (int j = 0; j < F; j++) {                                                              \
            const float v = row[k];                                                                \
            a = fma(LO[j], v, a);                                                                  \
            d = fma(HI[j], v, d);                                                                  \
            k = k == 0 ? (int)n - 1 : k - 1;                                                       \
        }                                                                                          \
        __global float *out = dst + (size_t)y * dstride;                                           \
        out[o] = a;                                                                                \
        out[nh + o] = d;                                                                           \
    }

/* Analysis along y, interior: work-item (g, i) computes columns [16g, 16g + 16) of output rows
 * o and o + 1, o = o0 + 2i, for rows whose taps (input rows 2o + F/2 - j) lie inside the band
 * (the host's split: o0 = F/4, o + 1 < n/2 - F/4). No edge branch, as for the x pass. Two
 * output rows per item share F - 2 of their F + 2 input rows and give four independent fma
 * chains instead of two (the chains' latency, not the loads, bounded the one-row version). */
#define CSI_FWD_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint groups, const uint o0,         \
                       const uint pairs)                                                           \
    {                                                                                              \
        const int g = (int)get_global_id(0), i = (int)get_global_id(1);                          \
        if (g >= (int)groups || i >= (int)pairs)                                                   \
            return;                                                                                \
        const int nh = (int)(n >> 1), o = (int)o0 + 2 * i, x0 = 16 * g;                           \
        /* Row 2o + F/2 + 2 - r for r = 0 .. F+1: output o uses r = 2 + j, output o+1 r = j. */   \
        __global const float *col = src + (size_t)(2 * o + F / 2 + 2) * sstride + x0;              \
        float16 a0 = 0.0f, d0 = 0.0f, a1 = 0.0f, d1 = 0.0f;                                        \
        for (int j = 0; j < F; j++) {                                                              \
            const float16 v = vload16(0, col - (size_t)j * sstride);                               \
            a1 = fma(LO[j], v, a1);                                                                \
            d1 = fma(HI[j], v, d1);                                                                \
            const float16 u = vload16(0, col - (size_t)(j + 2) * sstride);                         \
            a0 = fma(LO[j], u, a0);                                                                \
            d0 = fma(HI[j], u, d0);                                                                \
        }                                                                                          \
        vstore16(a0, 0, dst + (size_t)o * dstride + x0);                                            \
        vstore16(a1, 0, dst + (size_t)(o + 1) * dstride + x0);                                      \
        vstore16(d0, 0, dst + (size_t)(nh + o) * dstride + x0);                                     \
        vstore16(d1, 0, dst + (size_t)(nh + o + 1) * dstride + x0);                                 \
    }

/* Analysis along y, edge rows and leftover columns: work-item (c, i) handles output row
 * o = i for i < lo, o = hi + (i - lo) after (i < count), and columns x0 + 16c .. (16 of them, or
 * fewer at x0 + width), taps wrapped periodically: a 16-wide vector when the 16 columns are
 * there, else one column at a time. */
#define CSI_FWD_Y_EDGE(NAME, F, LO, HI)                                                            \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint x0, const uint width,          \
                       const uint lo, const uint hi, const uint count)                             \
    {                                                                                              \
        const int c = (int)get_global_id(0), i = (int)get_global_id(1);                          \
        if (16 * c >= (int)width || i >= (int)count)                                               \
            return;                                                                                \
        const int nh = (int)(n >> 1), x = (int)x0 + 16 * c;                                       \
        const int o = i < (int)lo ? i : (int)hi + (i - (int)lo);                                  \
        const int k0 = wrap(2 * o + F / 2, (int)n); /* input row of tap 0, then down, wrapped */ \
        __global float *outa = dst + (size_t)o * dstride, *outd = dst + (size_t)(nh + o) * dstride; \
        if (16 * c + 16 <= (int)width) {                                                           \
            float16 a = 0.0f, d = 0.0f;                                                            \
            int k = k0;                                                                            \
            for (int j = 0; j < F; j++) {                                                          \
                const float16 v = vload16(0, src + (size_t)k * sstride + x);                       \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
                k = k == 0 ? (int)n - 1 : k - 1;                                                   \
            }                                                                                      \
            vstore16(a, 0, outa + x);                                                              \
            vstore16(d, 0, outd + x);                                                              \
            return;                                                                                \
        }                                                                                          \
        for (int xx = x; xx < (int)(x0 + width); xx++) {                                           \
            float a = 0.0f, d = 0.0f;                                                              \
            int k = k0;                                                                            \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = src[(size_t)k * sstride + xx];                                      \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
                k = k == 0 ? (int)n - 1 : k - 1;                                                   \
            }                                                                                      \
            outa[xx] = a;                                                                          \
            outd[xx] = d;                                                                          \
        }                                                                                          \
    }

/* Synthesis along x, interior: work-item (q, y) writes samples [2 p0, 2 p0 + 32) of row y
 * (region width n) from coefficients p in [p0, p0 + 16), p0 = first + 16q, of both halves; the
 * host launches it only where the 24 coefficients [p0 - F/4, p0 - F/4 + 24) lie inside the band.
 * The approximation half of rows y < arows is read from `approx`, everything else from `coef`,
 * so the coarsest level reads straight from the coefficient vector and finer levels read the
 * approximation just rebuilt in the output, with no copy of the details. */
#define CSI_INV_X(NAME, F, LO, HI, TAPS)                                                           \
    __kernel void NAME(__global const float *approx, __global const float *coef,                  \
                       __global float *restrict dst, const uint sstride, const uint dstride, const uint n,             \
                       const uint rows, const uint arows, const uint first, const uint items)     \
    {                                                                                              \
        const int q = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        if (q >= (int)items || y >= (int)rows)                                                     \
            return;                                                                                \
        const int nh = (int)(n >> 1), p0 = (int)first + 16 * q, w = p0 - F / 4;                  \
        __global const float *a = ((y < (int)arows) ? approx : coef) + (size_t)y * sstride + w;   \
        __global const float *d = coef + (size_t)y * sstride + nh + w;                             \
        const float16 A0 = vload16(0, a), D0 = vload16(0, d);                                      \
        const float8 a1 = vload8(2, a), d1 = vload8(2, d);                                         \
        const float16 A1 = (float16)(a1, a1), D1 = (float16)(d1, d1);                              \
        float16 e = 0.0f, od = 0.0f;                                                               \
        TAPS(LO, HI)                                                                               \
        __global float *out = dst + (size_t)y * dstride + 2 * p0;                                  \
        vstore16(ZIP_LO(e, od), 0, out);                                                           \
        vstore16(ZIP_HI(e, od), 1, out);                                                           \
    }

/* Synthesis along x, 16-pair items whose coefficients cross the band's ends: work-item (i, y)
 * does the item starting at p0 = 16c, c = i for i < lo, c = hi + (i - lo) after, with the 24
 * coefficients of each half gathered with periodic wrap. */
#define CSI_INV_XW(NAME, F, LO, HI, TAPS)                                                          \
    __kernel void NAME(__global const float *approx, __global const float *coef,                  \
                       __global float *restrict dst, const uint sstride, const uint dstride, const uint n,             \
                       const uint rows, const uint arows, const uint lo, const uint hi,           \
                       const uint count)                                                           \
    {                                                                                              \
        const int i = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        if (i >= (int)count || y >= (int)rows)                                                     \
            return;                                                                                \
        const int nh = (int)(n >> 1);                                                              \
        const int p0 = 16 * (i < (int)lo ? i : (int)hi + (i - (int)lo));                          \
        __global const float *a = ((y < (int)arows) ? approx : coef) + (size_t)y * sstride;       \
        __global const float *d = coef + (size_t)y * sstride + nh;                                 \
        float wa[24], wd[24];                                                                      \
        int k = wrap(p0 - F / 4, nh);                                                              \
        for (int t = 0; t < 24; t++) {                                                             \
            wa[t] = a[k];                                                                          \
            wd[t] = d[k];                                                                          \
            k = k + 1 == nh ? 0 : k + 1;                                                           \
        }                                                                                          \
        const float16 A0 = vload16(0, wa), D0 = vload16(0, wd);                                    \
        const float8 a1 = vload8(2, wa), d1 = vload8(2, wd);                                       \
        const float16 A1 = (float16)(a1, a1), D1 = (float16)(d1, d1);                              \
        float16 e = 0.0f, od = 0.0f;                                                               \
        TAPS(LO, HI)                                                                               \
        __global float *out = dst + (size_t)y * dstride + 2 * p0;                                  \
        vstore16(ZIP_LO(e, od), 0, out);                                                           \
        vstore16(ZIP_HI(e, od), 1, out);                                                           \
    }

/* Synthesis along x, edges: one coefficient pair p (two output samples) per work-item (i, y):
 * p = i for i < lo, p = hi + (i - lo) after, indices wrapped periodically. */
#define CSI_INV_X_EDGE(NAME, F, LO, HI)                                                            \
    __kernel void NAME(__global const float *approx, __global const float *coef,                  \
                       __global float *restrict dst, const uint sstride, const uint dstride, const uint n,             \
                       const uint rows, const uint arows, const uint lo, const uint hi)           \
    {                                                                                              \
        const int i = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1), p = i < (int)lo ? i : (int)hi + (i - (int)lo);              \
        if (p >= nh || y >= (int)rows)                                                             \
            return;                                                                                \
        __global const float *a = ((y < (int)arows) ? approx : coef) + (size_t)y * sstride;       \
        __global const float *d = coef + (size_t)y * sstride + nh;                                 \
        /* Coefficients p - F/4 + k: one remainder, then step up with a wrap. */                  \
        int i0 = wrap(p - F / 4, nh);                                                              \
        float e = 0.0f, od = 0.0f;                                                                 \
        for (int k = 0; k < F / 2; k++) {                                                          \
            const int i1 = i0 + 1 == nh ? 0 : i0 + 1;                                              \
            e = fma(LO[2 * k], a[i0], fma(HI[2 * k], d[i0], e));                                   \
            od = fma(LO[2 * k + 1], a[i1], fma(HI[2 * k + 1], d[i1], od));                         \
            i0 = i1;                                                                               \
        }                                                                                          \
        __global float *out = dst + (size_t)y * dstride;                                           \
        out[2 * p] = e;                                                                            \
        out[2 * p + 1] = od;                                                                       \
    }

/* Synthesis along y, interior: work-item (g, i) writes columns [16g, 16g + 16) of output rows
 * 2p .. 2p + 3 (pairs p and p + 1), p = p0 + 2i, for pairs whose coefficient rows p - F/4 + k
 * (k <= F/2 + 1) lie inside the band (p0 = F/4, p + 1 < n/2 - F/4). Two pairs per item for
 * independent fma chains, as in the analysis. */
#define CSI_INV_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint groups, const uint p0,         \
                       const uint pairs)                                                           \
    {                                                                                              \
        const int g = (int)get_global_id(0), i = (int)get_global_id(1);                          \
        if (g >= (int)groups || i >= (int)pairs)                                                   \
            return;                                                                                \
        const int nh = (int)(n >> 1), p = (int)p0 + 2 * i, x0 = 16 * g;                           \
        __global const float *a = src + (size_t)(p - F / 4) * sstride + x0;                       \
        __global const float *d = a + (size_t)nh * sstride;                                        \
        float16 e0 = 0.0f, o0 = 0.0f, e1 = 0.0f, o1 = 0.0f;                                        \
        for (int k = 0; k < F / 2; k++) {                                                          \
            const size_t r0 = (size_t)k * sstride, r1 = r0 + sstride, r2 = r1 + sstride;            \
            const float16 a0 = vload16(0, a + r0), a1 = vload16(0, a + r1), a2 = vload16(0, a + r2); \
            const float16 b0 = vload16(0, d + r0), b1 = vload16(0, d + r1), b2 = vload16(0, d + r2); \
            e0 = fma(LO[2 * k], a0, fma(HI[2 * k], b0, e0));                                       \
            o0 = fma(LO[2 * k + 1], a1, fma(HI[2 * k + 1], b1, o0));                               \
            e1 = fma(LO[2 * k], a1, fma(HI[2 * k], b1, e1));                                       \
            o1 = fma(LO[2 * k + 1], a2, fma(HI[2 * k + 1], b2, o1));                               \
        }                                                                                          \
        __global float *out = dst + (size_t)(2 * p) * dstride + x0;                                \
        vstore16(e0, 0, out);                                                                      \
        vstore16(o0, 0, out + dstride);                                                             \
        vstore16(e1, 0, out + 2 * (size_t)dstride);                                                 \
        vstore16(o1, 0, out + 3 * (size_t)dstride);                                                 \
    }

/* Synthesis along y, edge rows and leftover columns: work-item (c, i) handles pair p = i for
 * i < lo, p = hi + (i - lo) after (i < count), columns as in the analysis edge kernel. */
#define CSI_INV_Y_EDGE(NAME, F, LO, HI)                                                            \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint sstride, const uint dstride, const uint n, const uint x0, const uint width,          \
                       const uint lo, const uint hi, const uint count)                             \
    {                                                                                              \
        const int c = (int)get_global_id(0), i = (int)get_global_id(1);                          \
        if (16 * c >= (int)width || i >= (int)count)                                               \
            return;                                                                                \
        const int nh = (int)(n >> 1), x = (int)x0 + 16 * c;                                       \
        const int p = i < (int)lo ? i : (int)hi + (i - (int)lo);                                  \
        const int k0 = wrap(p - F / 4, nh); /* first coefficient row, then up, wrapped */         \
        __global const float *a = src, *d = src + (size_t)nh * sstride;                            \
        __global float *oute = dst + (size_t)(2 * p) * dstride, *outo = oute + dstride;             \
        if (16 * c + 16 <= (int)width) {                                                           \
            float16 e = 0.0f, od = 0.0f;                                                           \
            int i0 = k0;                                                                           \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const int i1 = i0 + 1 == nh ? 0 : i0 + 1;                                          \
                const size_t r0 = (size_t)i0 * sstride + x, r1 = (size_t)i1 * sstride + x;          \
                e = fma(LO[2 * k], vload16(0, a + r0), fma(HI[2 * k], vload16(0, d + r0), e));    \
                od = fma(LO[2 * k + 1], vload16(0, a + r1), fma(HI[2 * k + 1], vload16(0, d + r1), od)); \
                i0 = i1;                                                                           \
            }                                                                                      \
            vstore16(e, 0, oute + x);                                                              \
            vstore16(od, 0, outo + x);                                                             \
            return;                                                                                \
        }                                                                                          \
        for (int xx = x; xx < (int)(x0 + width); xx++) {                                           \
            float e = 0.0f, od = 0.0f;                                                             \
            int i0 = k0;                                                                           \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const int i1 = i0 + 1 == nh ? 0 : i0 + 1;                                          \
                const size_t r0 = (size_t)i0 * sstride + xx, r1 = (size_t)i1 * sstride + xx;       \
                e = fma(LO[2 * k], a[r0], fma(HI[2 * k], d[r0], e));                               \
                od = fma(LO[2 * k + 1], a[r1], fma(HI[2 * k + 1], d[r1], od));                     \
                i0 = i1;                                                                           \
            }                                                                                      \
            oute[xx] = e;                                                                          \
            outo[xx] = od;                                                                         \
        }                                                                                          \
    }

/* One whole level in one launch: the x pass of a band of rows, then the y pass of that band, with
 * the band held in __local memory between them, so a level reads its input and writes its output
 * once instead of going through the scratch image (a level's two passes are bound by memory, not
 * by their multiply-adds). One work-item per work-group; band g makes output rows (analysis) or
 * row pairs (synthesis) [gB, gB + B) over the whole width, reading and writing whole rows (one
 * work-item per strip of columns, walking down its rows, ran 1.6x slower: every row in another
 * page). The x rows a band needs overlap its neighbours' by F - 2 (analysis) or F/2 (synthesis),
 * computed again by each. Every output is the same fma chain, in the same order, as in the pass
 * kernels above, so the same bits. In local memory a row's halves are G = ceil(n/32) vectors of
 * 16 each; where n/2 is not a multiple of 16 the last vector's extra lanes are computed from
 * wrapped windows and not stored. The host launches these only where input and output are
 * distinct buffers.
 *
 * The x pass asks for the next input row (or the next rows of both halves) a slice per vector it
 * makes: the input was written as non-temporal stores (store_lanes) or by another stage long
 * before, so it is in memory, and the hardware's prefetchers neither guess the jump to the next
 * row nor cross its 4 KiB pages, so each row's start and each page would otherwise be a wait.
 * Prefetches move no data the kernel computes with: the same bits. */

/* 16 lanes of v to p[0 .. cnt) (all 16 when cnt >= 16). A level's output is read back only
 * after the whole launch, long after it has left the caches: on x86, a whole 64-byte aligned
 * line is a non-temporal store, which writes the line without reading it first
 * (NT_STORES_DONE() orders them before the launch ends). */
#if defined(__x86_64__)
#define NT_STORES_DONE() __asm__ volatile("sfence" ::: "memory")
#else
#define NT_STORES_DONE()
#endif
inline void store_lanes(const float16 v, __global float *p, const int cnt)
{
    if (cnt >= 16) {
#if defined(__x86_64__)
        if (((size_t)p & 63) == 0) {
            __builtin_nontemporal_store(v, (__global float16 *)p);
            return;
        }
#endif
        vstore16(v, 0, p);
        return;
    }
    float t[16];
    vstore16(v, 0, t);
    for (int i = 0; i < cnt; i++)
        p[i] = t[i];
}

/* Analysis of one level: src (offset soff, row stride sstride: n x m values) -> the approximation
 * band (ll: n/2 x m/2 at loff, stride lstride) and the three detail bands in coef (stride
 * cstride), in the layout the two passes make: rows o < m/2 low along y, m/2 + o high; columns
 * o low along x, n/2 + o high. Output row o reads x rows 2o + F/2 - j (j < F), so band g's rows
 * [o0, o1) read x rows r0 + i, r0 = 2 o0 - F/2 + 1, i < 2 (o1 - o0) + F - 2 (wrapped into [0, m)),
 * local row i: the low half at S[2Gi + c], the high half at S[2Gi + G + c]. */
#define CSI_FWD_XY(NAME, F, LO, HI, TAPS)                                                          \
    __kernel void NAME(__global const float *src, const uint soff, const uint sstride,            \
                       __global float *ll, const uint loff, const uint lstride,                   \
                       __global float *coef, const uint cstride, const uint n_, const uint m_,    \
                       const uint B, __local float16 *S)                                           \
    {                                                                                              \
        const int n = (int)n_, m = (int)m_, nx = n >> 1, ny = m >> 1, G = (nx + 15) / 16;         \
        const int o0 = (int)get_global_id(0) * (int)B;                                             \
        const int o1 = o0 + (int)B < ny ? o0 + (int)B : ny, r0 = 2 * o0 - F / 2 + 1;               \
        const int rows = 2 * (o1 - o0) + F - 2;                                                    \
        for (int i = 0; i < rows; i++) {                                                           \
            __global const float *row = src + soff + (size_t)wrap(r0 + i, m) * sstride;            \
            __global const float *nrow = src + soff + (size_t)wrap(r0 + i + 1, m) * sstride;       \
            __local float16 *out = S + (size_t)(2 * G) * i;                                        \
            for (int c = 0; c < G; c++) {                                                          \
                const int base = 32 * c - F / 2;                                                   \
                __builtin_prefetch(nrow + 32 * c);                                                 \
                __builtin_prefetch(nrow + min(32 * c + 16, n - 1));                                \
                float16 w0, w1, w2;                                                                \
                if (c >= 1 && base + 48 <= n && 16 * c + 16 <= nx) {                               \
                    w0 = vload16(0, row + base);                                                   \
                    w1 = vload16(1, row + base);                                                   \
                    w2 = vload16(2, row + base);                                                   \
                } else {                                                                           \
                    float win[48];                                                                 \
                    int k = wrap(base, n);                                                         \
                    for (int t = 0; t < 48; t++) {                                                 \
                        win[t] = row[k];                                                           \
                        k = k + 1 == n ? 0 : k + 1;                                                \
                    }                                                                              \
                    w0 = vload16(0, win);                                                          \
                    w1 = vload16(1, win);                                                          \
                    w2 = vload16(2, win);                                                          \
                }                                                                                  \
                const float16 E0 = (float16)(w0.even, w1.even), O0 = (float16)(w0.odd, w1.odd);   \
                const float16 E1 = (float16)(w2.even, w2.even), O1 = (float16)(w2.odd, w2.odd);   \
                float16 a = 0.0f, d = 0.0f;                                                        \
                TAPS(LO, HI)                                                                       \
                out[c] = a;                                                                        \
                out[G + c] = d;                                                                    \
            }                                                                                      \
        }                                                                                          \
        for (int o = o0; o < o1; o++) {                                                            \
            /* x row 2o + F/2 - j is local row 2 (o - o0) + F - 1 - j */                           \
            __local const float16 *top = S + (size_t)(2 * G) * (2 * (o - o0) + F - 1);            \
            for (int c = 0; c < 2 * G; c += 2) {                                                   \
                float16 l0 = 0.0f, h0 = 0.0f, l1 = 0.0f, h1 = 0.0f;                                \
                for (int j = 0; j < F; j++) {                                                      \
                    __local const float16 *r = top - (size_t)(2 * G) * j;                         \
                    const float16 v0 = r[c], v1 = r[c + 1];                                        \
                    l0 = fma(LO[j], v0, l0);                                                       \
                    h0 = fma(HI[j], v0, h0);                                                       \
                    l1 = fma(LO[j], v1, l1);                                                       \
                    h1 = fma(HI[j], v1, h1);                                                       \
                }                                                                                  \
                _Pragma("unroll") for (int u = 0; u < 2; u++) {                                    \
                    const int cc = c + u, hi = cc >= G, x = hi ? nx + 16 * (cc - G) : 16 * cc;     \
                    const int cnt = hi ? nx - 16 * (cc - G) : nx - 16 * cc;                        \
                    const float16 lv = u ? l1 : l0, hv = u ? h1 : h0;                              \
                    store_lanes(lv, hi ? coef + (size_t)o * cstride + x                            \
                                       : ll + loff + (size_t)o * lstride + x, cnt);                \
                    store_lanes(hv, coef + (size_t)(ny + o) * cstride + x, cnt);                   \
                }                                                                                  \
            }                                                                                      \
        }                                                                                          \
        NT_STORES_DONE();                                                                          \
    }

/* Synthesis of one level: the approximation band (approx: n/2 x m/2 at aoff, stride astride) and
 * the three detail bands in coef (stride cstride) -> dst (n x m at doff, stride dstride). Pair p
 * (output rows 2p, 2p + 1) reads x rows p - F/4 + k, k <= F/2, of each half along y, so band g's
 * pairs [p0, p1) read rows p0 - F/4 + i, i < p1 - p0 + F/2 (wrapped into [0, m/2)) of the low
 * half (local rows i) and of the high half (local rows cnt + i); a local row is 2G vectors, the
 * output columns 32c .. 32c + 31 of x pairs 16c .. 16c + 15 at S[2Gi + 2c], S[2Gi + 2c + 1]. */
#define CSI_INV_XY(NAME, F, LO, HI, TAPS)                                                          \
    __kernel void NAME(__global const float *approx, const uint aoff, const uint astride,         \
                       __global const float *coef, const uint cstride, __global float *dst,       \
                       const uint doff, const uint dstride, const uint n_, const uint m_,         \
                       const uint B, __local float16 *S)                                           \
    {                                                                                              \
        const int n = (int)n_, m = (int)m_, nh = n >> 1, ny = m >> 1, G = (nh + 15) / 16;         \
        const int p0 = (int)get_global_id(0) * (int)B;                                             \
        const int p1 = p0 + (int)B < ny ? p0 + (int)B : ny, cnt = p1 - p0 + F / 2;                \
        for (int i = 0; i < 2 * cnt; i++) {                                                        \
            const int y = (i < cnt ? 0 : ny) + wrap(p0 - F / 4 + (i < cnt ? i : i - cnt), ny);    \
            __global const float *a = y < ny ? approx + aoff + (size_t)y * astride                 \
                                             : coef + (size_t)y * cstride;                         \
            __global const float *d = coef + (size_t)y * cstride + nh;                             \
            const int j = i + 1,                                                                   \
                      yn = (j < cnt ? 0 : ny) + wrap(p0 - F / 4 + (j < cnt ? j : j - cnt), ny);    \
            __global const float *na = yn < ny ? approx + aoff + (size_t)yn * astride              \
                                               : coef + (size_t)yn * cstride;                      \
            __global const float *nd = coef + (size_t)yn * cstride + nh;                           \
            __local float16 *out = S + (size_t)(2 * G) * i;                                        \
            for (int c = 0; c < G; c++) {                                                          \
                const int w = 16 * c - F / 4;                                                      \
                __builtin_prefetch(na + 16 * c);                                                   \
                __builtin_prefetch(nd + 16 * c);                                                   \
                float16 A0, D0;                                                                    \
                float8 a1, d1;                                                                     \
                if (c >= 1 && w + 24 <= nh && 16 * c + 16 <= nh) {                                 \
                    A0 = vload16(0, a + w);                                                        \
                    D0 = vload16(0, d + w);                                                        \
                    a1 = vload8(2, a + w);                                                         \
                    d1 = vload8(2, d + w);                                                         \
                } else {                                                                           \
                    float wa[24], wd[24];                                                          \
                    int k = wrap(w, nh);                                                           \
                    for (int t = 0; t < 24; t++) {                                                 \
                        wa[t] = a[k];                                                              \
                        wd[t] = d[k];                                                              \
                        k = k + 1 == nh ? 0 : k + 1;                                               \
                    }                                                                              \
                    A0 = vload16(0, wa);                                                           \
                    D0 = vload16(0, wd);                                                           \
                    a1 = vload8(2, wa);                                                            \
                    d1 = vload8(2, wd);                                                            \
                }                                                                                  \
                const float16 A1 = (float16)(a1, a1), D1 = (float16)(d1, d1);                      \
                float16 e = 0.0f, od = 0.0f;                                                       \
                TAPS(LO, HI)                                                                       \
                out[2 * c] = ZIP_LO(e, od);                                                        \
                out[2 * c + 1] = ZIP_HI(e, od);                                                    \
            }                                                                                      \
        }                                                                                          \
        for (int p = p0; p < p1; p++) {                                                            \
            /* row p - F/4 + k of the low half is local row p - p0 + k, of the high half cnt + */ \
            __local const float16 *ra = S + (size_t)(2 * G) * (p - p0);                            \
            __local const float16 *rd = ra + (size_t)(2 * G) * cnt;                                \
            __global float *out = dst + doff + (size_t)(2 * p) * dstride;                          \
            for (int q = 0; q < 2 * G; q += 2) {                                                   \
                float16 e0 = 0.0f, e1 = 0.0f, od0 = 0.0f, od1 = 0.0f;                              \
                for (int k = 0; k < F / 2; k++) {                                                  \
                    const size_t r0 = (size_t)(2 * G) * k, r1 = r0 + 2 * G;                        \
                    e0 = fma(LO[2 * k], ra[r0 + q], fma(HI[2 * k], rd[r0 + q], e0));               \
                    e1 = fma(LO[2 * k], ra[r0 + q + 1], fma(HI[2 * k], rd[r0 + q + 1], e1));       \
                    od0 = fma(LO[2 * k + 1], ra[r1 + q], fma(HI[2 * k + 1], rd[r1 + q], od0));     \
                    od1 = fma(LO[2 * k + 1], ra[r1 + q + 1], fma(HI[2 * k + 1], rd[r1 + q + 1], od1)); \
                }                                                                                  \
                store_lanes(e0, out + 16 * q, n - 16 * q);                                         \
                store_lanes(e1, out + 16 * q + 16, n - 16 * q - 16);                               \
                store_lanes(od0, out + dstride + 16 * q, n - 16 * q);                              \
                store_lanes(od1, out + dstride + 16 * q + 16, n - 16 * q - 16);                    \
            }                                                                                      \
        }                                                                                          \
        NT_STORES_DONE();                                                                          \
    }

CSI_FWD_X(csi_wavelet_fwd_x_db4, 8, csi_db4_lo, csi_db4_hi, FWD_X_TAPS_8)
CSI_FWD_XW(csi_wavelet_fwd_xw_db4, 8, csi_db4_lo, csi_db4_hi, FWD_X_TAPS_8)
CSI_FWD_X_EDGE(csi_wavelet_fwd_xe_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_Y(csi_wavelet_fwd_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_Y_EDGE(csi_wavelet_fwd_ye_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_X(csi_wavelet_inv_x_db4, 8, csi_db4_lo, csi_db4_hi, INV_X_TAPS_8)
CSI_INV_XW(csi_wavelet_inv_xw_db4, 8, csi_db4_lo, csi_db4_hi, INV_X_TAPS_8)
CSI_INV_X_EDGE(csi_wavelet_inv_xe_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_Y(csi_wavelet_inv_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_Y_EDGE(csi_wavelet_inv_ye_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_XY(csi_wavelet_fwd_xy_db4, 8, csi_db4_lo, csi_db4_hi, FWD_X_TAPS_8)
CSI_INV_XY(csi_wavelet_inv_xy_db4, 8, csi_db4_lo, csi_db4_hi, INV_X_TAPS_8)
CSI_FWD_X(csi_wavelet_fwd_x_db8, 16, csi_db8_lo, csi_db8_hi, FWD_X_TAPS_16)
CSI_FWD_XW(csi_wavelet_fwd_xw_db8, 16, csi_db8_lo, csi_db8_hi, FWD_X_TAPS_16)
CSI_FWD_X_EDGE(csi_wavelet_fwd_xe_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_FWD_Y(csi_wavelet_fwd_y_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_FWD_Y_EDGE(csi_wavelet_fwd_ye_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_X(csi_wavelet_inv_x_db8, 16, csi_db8_lo, csi_db8_hi, INV_X_TAPS_16)
CSI_INV_XW(csi_wavelet_inv_xw_db8, 16, csi_db8_lo, csi_db8_hi, INV_X_TAPS_16)
CSI_INV_X_EDGE(csi_wavelet_inv_xe_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_Y(csi_wavelet_inv_y_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_Y_EDGE(csi_wavelet_inv_ye_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_FWD_XY(csi_wavelet_fwd_xy_db8, 16, csi_db8_lo, csi_db8_hi, FWD_X_TAPS_16)
CSI_INV_XY(csi_wavelet_inv_xy_db8, 16, csi_db8_lo, csi_db8_hi, INV_X_TAPS_16)
