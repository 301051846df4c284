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

/* Non-negative remainder; callers pass i > -n * 8 so one add of a multiple of n suffices for
 * the filter lengths used here even when the band is shorter than the filter. */
inline int wrap(int i, int n)
{
    int r = i % n;
    return r < 0 ? r + n : r;
}

/* Analysis along x: work-item (o, y) writes a[o] to column o and d[o] to column n/2 + o of row y.
 * src and dst are distinct buffers. */
#define CSI_FWD_X(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint n, const uint rows)                            \
    {                                                                                              \
        const int o = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1);                                                            \
        if (o >= nh || y >= (int)rows)                                                           \
            return;                                                                                \
        __global const float *row = src + (size_t)y * stride;                                     \
        const int top = 2 * o + F / 2; /* taps read row[top - j], j = 0..F-1 */                   \
        float a = 0.0f, d = 0.0f;                                                                  \
        if (top - (F - 1) >= 0 && top < (int)n) {                                                  \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = row[top - j];                                                      \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
        } else {                                                                                   \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = row[wrap(top - j, (int)n)];                                        \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
        }                                                                                          \
        __global float *out = dst + (size_t)y * stride;                                           \
        out[o] = a;                                                                                \
        out[nh + o] = d;                                                                         \
    }

/* Analysis along y: work-item (x, o) over columns x < cols of the region of height n. */
#define CSI_FWD_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint cols, const uint n)                           \
    {                                                                                              \
        const int x = (int)get_global_id(0), o = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1);                                                            \
        if (x >= (int)cols || o >= nh)                                                           \
            return;                                                                                \
        const int top = 2 * o + F / 2;                                                             \
        float a = 0.0f, d = 0.0f;                                                                  \
        if (top - (F - 1) >= 0 && top < (int)n) {                                                  \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = src[(size_t)(top - j) * stride + x];                              \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
        } else {                                                                                   \
            for (int j = 0; j < F; j++) {                                                          \
                const float v = src[(size_t)wrap(top - j, (int)n) * stride + x];                  \
                a = fma(LO[j], v, a);                                                              \
                d = fma(HI[j], v, d);                                                              \
            }                                                                                      \
        }                                                                                          \
        dst[(size_t)o * stride + x] = a;                                                           \
        dst[(size_t)(nh + o) * stride + x] = d;                                                  \
    }

/* Synthesis along x: work-item (p, y) writes samples 2p and 2p+1 of row y (region width n).
 * The approximation nh of rows y < arows is read from `approx`, everything else from `coef`,
 * so the coarsest level reads straight from the coefficient vector and finer levels read the
 * approximation just rebuilt in the output, with no copy of the details. */
#define CSI_INV_X(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *approx, __global const float *coef,                  \
                       __global float *restrict dst, const uint stride, const uint n,             \
                       const uint rows, const uint arows)                                          \
    {                                                                                              \
        const int p = (int)get_global_id(0), y = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1);                                                            \
        if (p >= nh || y >= (int)rows)                                                           \
            return;                                                                                \
        __global const float *a = ((y < (int)arows) ? approx : coef) + (size_t)y * stride;       \
        __global const float *d = coef + (size_t)y * stride + nh;                               \
        const int first = p - F / 4; /* even output reads a[first + k], odd a[first + 1 + k] */   \
        float e = 0.0f, od = 0.0f;                                                                 \
        if (first >= 0 && first + F / 2 < nh) {                                                  \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const float a0 = a[first + k], d0 = d[first + k];                                 \
                const float a1 = a[first + k + 1], d1 = d[first + k + 1];                         \
                e = fma(LO[2 * k], a0, fma(HI[2 * k], d0, e));                                     \
                od = fma(LO[2 * k + 1], a1, fma(HI[2 * k + 1], d1, od));                           \
            }                                                                                      \
        } else {                                                                                   \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const int i0 = wrap(first + k, nh), i1 = wrap(first + k + 1, nh);            \
                e = fma(LO[2 * k], a[i0], fma(HI[2 * k], d[i0], e));                               \
                od = fma(LO[2 * k + 1], a[i1], fma(HI[2 * k + 1], d[i1], od));                     \
            }                                                                                      \
        }                                                                                          \
        __global float *out = dst + (size_t)y * stride;                                           \
        out[2 * p] = e;                                                                            \
        out[2 * p + 1] = od;                                                                       \
    }

/* Synthesis along y: work-item (x, p) writes rows 2p and 2p+1 of column x (region height n). */
#define CSI_INV_Y(NAME, F, LO, HI)                                                                 \
    __kernel void NAME(__global const float *restrict src, __global float *restrict dst,          \
                       const uint stride, const uint cols, const uint n)                           \
    {                                                                                              \
        const int x = (int)get_global_id(0), p = (int)get_global_id(1);                          \
        const int nh = (int)(n >> 1);                                                            \
        if (x >= (int)cols || p >= nh)                                                           \
            return;                                                                                \
        __global const float *a = src + x;                                                         \
        __global const float *d = src + (size_t)nh * stride + x;                                \
        const int first = p - F / 4;                                                               \
        float e = 0.0f, od = 0.0f;                                                                 \
        if (first >= 0 && first + F / 2 < nh) {                                                  \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const size_t r0 = (size_t)(first + k) * stride, r1 = r0 + stride;                 \
                e = fma(LO[2 * k], a[r0], fma(HI[2 * k], d[r0], e));                               \
                od = fma(LO[2 * k + 1], a[r1], fma(HI[2 * k + 1], d[r1], od));                     \
            }                                                                                      \
        } else {                                                                                   \
            for (int k = 0; k < F / 2; k++) {                                                      \
                const size_t r0 = (size_t)wrap(first + k, nh) * stride;                         \
                const size_t r1 = (size_t)wrap(first + k + 1, nh) * stride;                     \
                e = fma(LO[2 * k], a[r0], fma(HI[2 * k], d[r0], e));                               \
                od = fma(LO[2 * k + 1], a[r1], fma(HI[2 * k + 1], d[r1], od));                     \
            }                                                                                      \
        }                                                                                          \
        dst[(size_t)(2 * p) * stride + x] = e;                                                     \
        dst[(size_t)(2 * p + 1) * stride + x] = od;                                                \
    }

CSI_FWD_X(csi_wavelet_fwd_x_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_Y(csi_wavelet_fwd_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_X(csi_wavelet_inv_x_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_INV_Y(csi_wavelet_inv_y_db4, 8, csi_db4_lo, csi_db4_hi)
CSI_FWD_X(csi_wavelet_fwd_x_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_FWD_Y(csi_wavelet_fwd_y_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_X(csi_wavelet_inv_x_db8, 16, csi_db8_lo, csi_db8_hi)
CSI_INV_Y(csi_wavelet_inv_y_db8, 16, csi_db8_lo, csi_db8_hi)
