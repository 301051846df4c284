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
 * Every kernel has a fast path for items whose taps stay inside the band and a modular path for
 * the few near the edges (and for bands shorter than the filter).
 *
 * One level of the 2-D transform is an x pass (rows) then a y pass (columns) over the top-left
 * region of the array still holding the approximation; `stride` is the full image width. */

/* Daubechies' extremal-phase orthonormal filters: Daubechies, "Ten Lectures on Wavelets" (SIAM
 * 1992), Table 6.1, in the order and sign convention of PyWavelets 1.8 (pywt.Wavelet('db4').dec_lo,
 * 'db8'), which tools/gen_refs_wavelet.py checks this table against. dec_hi[j] =
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
 * data-dependent control flow, and the periodic edges need some; measured at 1024x1024 an edge
 * branch made a pass 7x slower. So each work-item computes a short vector explicitly: 8
 * consecutive outputs of a row in the x passes (two float16 loads, split into even and odd
 * samples, then shifted windows of those), 16 adjacent columns in the y passes (one float16 load
 * per tap row). The few items whose taps cross the band's edge, and partial vectors at the end
 * of a band, take a scalar path with wrap(); their branch is per work-item and cheap. */

/* Shifted 8-wide windows of a float16: Sk(V) = V[k .. k+7]. */
#define S0(V) (V).s01234567
#define S1(V) (V).s12345678
#define S2(V) (V).s23456789
#define S3(V) (V).s3456789a
#define S4(V) (V).s456789ab
#define S5(V) (V).s56789abc
#define S6(V) (V).s6789abcd
#define S7(V) (V).s789abcde
#define S8(V) (V).s89abcdef

/* Forward x taps. With base = 2 o0 - F/2, E[k] = row[base + 2k] and O[k] = row[base + 2k + 1],
 * output o0 + t needs row[base + F + 2t - j]: E[t + (F-j)/2] for even F-j, O[t + (F-j-1)/2] for
 * odd. FTAP(j, V) accumulates tap j for the 8 outputs. */
#define FTAP(LO, HI, J, V)           \
    {                                \
        const float8 v_ = (V);       \
        a = fma(LO[J], v_, a);       \
        d = fma(HI[J], v_, d);       \
    }
#define FWD_X_TAPS_8(LO, HI)                                                                       \
    FTAP(LO, HI, 0, S4(E)) FTAP(LO, HI, 1, S3(O)) FTAP(LO, HI, 2, S3(E)) FTAP(LO, HI, 3, S2(O))    \
    FTAP(LO, HI, 4, S2(E)) FTAP(LO, HI, 5, S1(O)) FTAP(LO, HI, 6, S1(E)) FTAP(LO, HI, 7, S0(O))
#define FWD_X_TAPS_16(LO, HI)                                                                      \
    FTAP(LO, HI, 0, S8(E)) FTAP(LO, HI, 1, S7(O)) FTAP(LO, HI, 2, S7(E)) FTAP(LO, HI, 3, S6(O))    \
    FTAP(LO, HI, 4, S6(E)) FTAP(LO, HI, 5, S5(O)) FTAP(LO, HI, 6, S5(E)) FTAP(LO, HI, 7, S4(O))    \
    FTAP(LO, HI, 8, S4(E)) FTAP(LO, HI, 9, S3(O)) FTAP(LO, HI, 10, S3(E)) FTAP(LO, HI, 11, S2(O))  \
    FTAP(LO, HI, 12, S2(E)) FTAP(LO, HI, 13, S1(O)) FTAP(LO, HI, 14, S1(E)) FTAP(LO, HI, 15, S0(O))

/* Inverse x taps. With A = a[p0 - F/4 ..], D likewise, output pair p0 + t: even sample from
 * A[t + k], D[t + k] with taps 2k; odd sample from A[t + k + 1], D[t + k + 1] with taps 2k + 1. */
#define ITAP(LO, HI, K, SK, SK1)                                  \
    e = fma(LO[2 * K], SK(A), fma(HI[2 * K], SK(D), e));          \
    od = fma(LO[2 * K + 1], SK1(A), fma(HI[2 * K + 1], SK1(D), od));
#define INV_X_TAPS_8(LO, HI)                                                                       \
    ITAP(LO, HI, 0, S0, S1) ITAP(LO, HI, 1, S1, S2) ITAP(LO, HI, 2, S2, S3) ITAP(LO, HI, 3, S3, S4)
#define INV_X_TAPS_16(LO, HI)                                                                      \
    INV_X_TAPS_8(LO, HI)                                                                           \
    ITAP(LO, HI, 4, S4, S5) ITAP(LO, HI, 5, S5, S6) ITAP(LO, HI, 6, S6, S7) ITAP(LO, HI, 7, S7, S8)

/* Analysis along x: work-item (q, y) writes a[o] to column o and d[o] to column n/2 + o of row y
 * for o in [8q, 8q + 8). src and dst are distinct buffers. */
#define CSI_FWD_X(NAME, F, LO, HI, TAPS)                                                           \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint n, const uint rows)                            \
    {                                                                                              \
        const int q = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1), o0 = 8 * q;                                                 \
        if (o0 >= nh || y >= (int)rows)                                                            \
            return;                                                                                \
        __global const float *row = src + (size_t)y * stride;                                     \
        __global float *out = dst + (size_t)y * stride;                                           \
        const int base = 2 * o0 - F / 2;                                                           \
        if (base >= 0 && base + 32 <= (int)n && o0 + 8 <= nh) {                                   \
            const float16 w0 = vload16(0, row + base), w1 = vload16(0, row + base + 16);          \
            const float16 E = (float16)(w0.even, w1.even), O = (float16)(w0.odd, w1.odd);         \
            float8 a = 0.0f, d = 0.0f;                                                             \
            TAPS(LO, HI)                                                                           \
            vstore8(a, 0, out + o0);                                                               \
            vstore8(d, 0, out + nh + o0);                                                          \
            return;                                                                                \
        }                                                                                          \
        for (int o = o0; o < o0 + 8 && o < nh; o++) {                                              \
            const int top = 2 * o + F / 2; /* taps read row[top - j] */                            \
            float a = 0.0f, d = 0.0f;                                                              \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = row[wrap(top - j, (int)n)];                                        \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
            out[o] = a;                                                                            \
            out[nh + o] = d;                                                                       \
        }                                                                                          \
    }

/* Analysis along y: work-item (q, o) over columns [16q, 16q + 16) of the region (cols wide,
 * n high). */
#define CSI_FWD_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint cols, const uint n)                           \
    {                                                                                              \
        const int x0 = 16 * (int)get_global_id(0), o = (int)get_global_id(1);                    \
        const int nh = (int)(n >> 1);                                                              \
        if (x0 >= (int)cols || o >= nh)                                                            \
            return;                                                                                \
        const int top = 2 * o + F / 2;                                                             \
        const bool inside = top - (F - 1) >= 0 && top < (int)n;                                   \
        __global float *outa = dst + (size_t)o * stride, *outd = dst + (size_t)(nh + o) * stride; \
        if (x0 + 16 <= (int)cols) {                                                                \
            float16 a = 0.0f, d = 0.0f;                                                            \
            for (int j = 0; j < F; j++) {                                                          \
                const int r = inside ? top - j : wrap(top - j, (int)n);                           \
                const float16 v = vload16(0, src + (size_t)r * stride + x0);                      \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
            vstore16(a, 0, outa + x0);                                                             \
            vstore16(d, 0, outd + x0);                                                             \
            return;                                                                                \
        }                                                                                          \
        for (int x = x0; x < (int)cols; x++) {                                                     \
            float a = 0.0f, d = 0.0f;                                                              \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = src[(size_t)wrap(top - j, (int)n) * stride + x];                  \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
            outa[x] = a;                                                                           \
            outd[x] = d;                                                                           \
        }                                                                                          \
    }

/* Synthesis along x: work-item (q, y) writes samples [16q, 16q + 16) of row y (region width n)
 * from coefficients p in [8q, 8q + 8) of both halves. The approximation half of rows y < arows
 * is read from `approx`, everything else from `coef`, so the coarsest level reads straight from
 * the coefficient vector and finer levels read the approximation just rebuilt in the output,
 * with no copy of the details. */
#define CSI_INV_X(NAME, F, LO, HI, TAPS)                                                           \
    __kernel void NAME(__global const float *approx, __global const float *coef,                  \
                       __global float *restrict dst, const uint stride, const uint n,             \
                       const uint rows, const uint arows)                                          \
    {                                                                                              \
        const int q = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1), p0 = 8 * q;                                                 \
        if (p0 >= nh || y >= (int)rows)                                                            \
            return;                                                                                \
        __global const float *a = ((y < (int)arows) ? approx : coef) + (size_t)y * stride;       \
        __global const float *d = coef + (size_t)y * stride + nh;                                 \
        __global float *out = dst + (size_t)y * stride;                                           \
        const int first = p0 - F / 4;                                                              \
        if (first >= 0 && first + 16 <= nh && p0 + 8 <= nh) {                                    \
            const float16 A = vload16(0, a + first), D = vload16(0, d + first);                   \
            float8 e = 0.0f, od = 0.0f;                                                            \
            TAPS(LO, HI)                                                                           \
            vstore16((float16)(e.s0, od.s0, e.s1, od.s1, e.s2, od.s2, e.s3, od.s3, e.s4, od.s4,   \
                               e.s5, od.s5, e.s6, od.s6, e.s7, od.s7),                             \
                     0, out + 2 * p0);                                                             \
            return;                                                                                \
        }                                                                                          \
        for (int p = p0; p < p0 + 8 && p < nh; p++) {                                              \
            float e = 0.0f, od = 0.0f;                                                             \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const int i0 = wrap(p - F / 4 + k, nh), i1 = wrap(p - F / 4 + k + 1, nh);         \
                e = fma(LO[2 * k], a[i0], fma(HI[2 * k], d[i0], e));                               \
                od = fma(LO[2 * k + 1], a[i1], fma(HI[2 * k + 1], d[i1], od));                     \
            }                                                                                      \
            out[2 * p] = e;                                                                        \
            out[2 * p + 1] = od;                                                                   \
        }                                                                                          \
    }

/* Synthesis along y: work-item (q, p) writes rows 2p and 2p+1 of columns [16q, 16q + 16)
 * (region cols wide, n high). */
#define CSI_INV_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint cols, const uint n)                           \
    {                                                                                              \
        const int x0 = 16 * (int)get_global_id(0), p = (int)get_global_id(1);                    \
        const int nh = (int)(n >> 1);                                                              \
        if (x0 >= (int)cols || p >= nh)                                                            \
            return;                                                                                \
        __global const float *a = src, *d = src + (size_t)nh * stride;                            \
        __global float *oute = dst + (size_t)(2 * p) * stride, *outo = oute + stride;             \
        const int first = p - F / 4;                                                               \
        const bool inside = first >= 0 && first + F / 2 < nh;                                     \
        if (x0 + 16 <= (int)cols) {                                                                \
            float16 e = 0.0f, od = 0.0f;                                                           \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const int i0 = inside ? first + k : wrap(first + k, nh);                          \
                const int i1 = inside ? first + k + 1 : wrap(first + k + 1, nh);                  \
                const size_t r0 = (size_t)i0 * stride + x0, r1 = (size_t)i1 * stride + x0;        \
                e = fma(LO[2 * k], vload16(0, a + r0), fma(HI[2 * k], vload16(0, d + r0), e));    \
                od = fma(LO[2 * k + 1], vload16(0, a + r1), fma(HI[2 * k + 1], vload16(0, d + r1), od)); \
            }                                                                                      \
            vstore16(e, 0, oute + x0);                                                             \
            vstore16(od, 0, outo + x0);                                                            \
            return;                                                                                \
        }                                                                                          \
        for (int x = x0; x < (int)cols; x++) {                                                     \
            float e = 0.0f, od = 0.0f;                                                             \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const size_t r0 = (size_t)wrap(first + k, nh) * stride + x;                       \
                const size_t r1 = (size_t)wrap(first + k + 1, nh) * stride + x;                   \
                e = fma(LO[2 * k], a[r0], fma(HI[2 * k], d[r0], e));                               \
                od = fma(LO[2 * k + 1], a[r1], fma(HI[2 * k + 1], d[r1], od));                     \
            }                                                                                      \
            oute[x] = e;                                                                           \
            outo[x] = od;                                                                          \
        }                                                                                          \
    }

CSI_FWD_X(csi_wavelet_fwd_x_db4, 8, csi_db4_lo, csi_db4_hi, FWD_X_TAPS_8)
CSI_FWD_Y(csi_wavelet_fwd_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_X(csi_wavelet_inv_x_db4, 8, csi_db4_lo, csi_db4_hi, INV_X_TAPS_8)
CSI_INV_Y(csi_wavelet_inv_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_X(csi_wavelet_fwd_x_db8, 16, csi_db8_lo, csi_db8_hi, FWD_X_TAPS_16)
CSI_FWD_Y(csi_wavelet_fwd_y_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_X(csi_wavelet_inv_x_db8, 16, csi_db8_lo, csi_db8_hi, INV_X_TAPS_16)
CSI_INV_Y(csi_wavelet_inv_y_db8, 16, csi_db8_lo, csi_db8_hi)
