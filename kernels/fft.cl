/* Mixed-radix Stockham FFT passes written for CPU OpenCL (PoCL), used by the Gaussian / Wiener
 * filter (host/ops/fft.c); clFFT stays the reference the tests check them against.
 *
 * Why not clFFT alone: its kernels are written for GPUs (work-groups of 64-256 sharing local
 * memory between barriers, plus transposes between axes); on PoCL a 1024^2 R2C + C2R pass took
 * 3x FFTW's time with one core mostly idle. Here each launch is one radix-R pass of the
 * self-sorting Stockham algorithm (E. Bainville, "OpenCL Fast Fourier Transform",
 * http://www.bealto.com/gpu-fft_opencl-1.html; Van Loan, Computational Frameworks for the FFT,
 * Sec. 1.7): work-item i of an axis of length L, T = L/R work-items, p = product of the radices
 * of earlier passes, k = i mod p:
 *     u[r] = in[i + r T] * w^(r k),  w = exp(-+ 2 pi i / (p R))      (r = 0 .. R-1)
 *     u = DFT_R(u)
 *     out[(i - k) R + k + r p] = u[r]
 * After all passes the output is in natural order. Each work-item's body is straight-line code
 * (the radix-R DFT unrolled), so PoCL can vectorise across work-items; for passes along y and z
 * dimension 0 of the launch runs along x, so loads and stores are contiguous across work-items.
 *
 * Twiddles come from a table tw[m] = exp(-2 pi i m / L) computed in double on the host; the
 * index r k L / (p R) is below L. sgn = -1 forward, +1 inverse (conjugated twiddles). */

inline float2 cmul(float2 a, float2 b) { return (float2)(a.x * b.x - a.y * b.y, a.x * b.y + a.y * b.x); }
/* exp(sgn i pi/2) v: -i v forward, +i v inverse */
inline float2 rot90(float2 v, float sgn) { return (float2)(-sgn * v.y, sgn * v.x); }
/* table twiddle, conjugated for the inverse */
inline float2 twid(float2 w, float sgn) { return (float2)(w.x, -sgn * w.y); }

#define BF2(a, b)                                                                              \
    do {                                                                                       \
        float2 t_ = a;                                                                         \
        a = t_ + b;                                                                            \
        b = t_ - b;                                                                            \
    } while (0)

inline void dft2(float2 *u, float sgn) { BF2(u[0], u[1]); }

/* 4-point DFT in place, natural order in and out. */
inline void dft4(float2 *u, float sgn)
{
    float2 a0 = u[0] + u[2], a1 = u[0] - u[2], a2 = u[1] + u[3], a3 = rot90(u[1] - u[3], sgn);
    u[0] = a0 + a2;
    u[2] = a0 - a2;
    u[1] = a1 + a3;
    u[3] = a1 - a3;
}

/* 8-point DFT: two 4-point DFTs of the even and odd samples, then radix-2 with w8^k. */
inline void dft8(float2 *u, float sgn)
{
    const float h = 0.70710678118654752f;
    float2 e[4] = {u[0], u[2], u[4], u[6]}, o[4] = {u[1], u[3], u[5], u[7]};
    dft4(e, sgn);
    dft4(o, sgn);
    /* w8^1 = (1 + sgn i) h, w8^2 = sgn i, w8^3 = (-1 + sgn i) h */
    float2 o1 = (float2)(h * (o[1].x - sgn * o[1].y), h * (o[1].y + sgn * o[1].x));
    float2 o2 = rot90(o[2], sgn);
    float2 o3 = (float2)(h * (-o[3].x - sgn * o[3].y), h * (-o[3].y + sgn * o[3].x));
    u[0] = e[0] + o[0];
    u[4] = e[0] - o[0];
    u[1] = e[1] + o1;
    u[5] = e[1] - o1;
    u[2] = e[2] + o2;
    u[6] = e[2] - o2;
    u[3] = e[3] + o3;
    u[7] = e[3] - o3;
}

/* 16-point DFT: 4 x 4 (four 4-point DFTs, twiddles w16^(q s), four 4-point DFTs). */
inline void dft16(float2 *u, float sgn)
{
    const float c1 = 0.92387953251128676f, s1 = 0.38268343236508977f, h = 0.70710678118654752f;
    float2 a[4][4];
    for (int q = 0; q < 4; q++) {
        float2 t[4] = {u[q], u[q + 4], u[q + 8], u[q + 12]};
        dft4(t, sgn);
        for (int s = 0; s < 4; s++)
            a[q][s] = t[s];
    }
    /* w16^m for m = q s, m in {0..9}: (cos(2 pi m/16), sgn sin(2 pi m/16)) */
    const float wc[10] = {1.0f, c1, h, s1, 0.0f, -s1, -h, -c1, -1.0f, -c1};
    const float ws[10] = {0.0f, s1, h, c1, 1.0f, c1, h, s1, 0.0f, -s1};
    for (int q = 1; q < 4; q++)
        for (int s = 1; s < 4; s++)
            a[q][s] = cmul(a[q][s], (float2)(wc[q * s], sgn * ws[q * s]));
    for (int s = 0; s < 4; s++) {
        float2 t[4] = {a[0][s], a[1][s], a[2][s], a[3][s]};
        dft4(t, sgn);
        for (int q = 0; q < 4; q++)
            u[s + 4 * q] = t[q];
    }
}

/* Odd radices: direct DFT with exact constants, u'[q] = sum_r u[r] exp(sgn 2 pi i q r / R). */
inline void dft3(float2 *u, float sgn)
{
    const float c = -0.5f, s = 0.86602540378443865f;
    float2 t1 = u[1] + u[2], t2 = u[1] - u[2];
    float2 m = u[0] + c * t1;
    float2 r = rot90(t2, sgn) * s; /* sgn i s (u1 - u2) */
    u[0] = u[0] + t1;
    u[1] = m + r;
    u[2] = m - r;
}

inline void dft5(float2 *u, float sgn)
{
    const float c1 = 0.30901699437494742f, c2 = -0.80901699437494742f;
    const float s1 = 0.95105651629515357f, s2 = 0.58778525229247313f;
    float2 a1 = u[1] + u[4], b1 = u[1] - u[4], a2 = u[2] + u[3], b2 = u[2] - u[3];
    float2 m1 = u[0] + c1 * a1 + c2 * a2, m2 = u[0] + c2 * a1 + c1 * a2;
    float2 r1 = rot90(s1 * b1 + s2 * b2, sgn), r2 = rot90(s2 * b1 - s1 * b2, sgn);
    u[0] = u[0] + a1 + a2;
    u[1] = m1 + r1;
    u[4] = m1 - r1;
    u[2] = m2 + r2;
    u[3] = m2 - r2;
}

inline void dft7(float2 *u, float sgn)
{
    const float c1 = 0.62348980185873353f, c2 = -0.22252093395631440f, c3 = -0.90096886790241913f;
    const float s1 = 0.78183148246802981f, s2 = 0.97492791218182361f, s3 = 0.43388373911755812f;
    float2 a1 = u[1] + u[6], b1 = u[1] - u[6], a2 = u[2] + u[5], b2 = u[2] - u[5];
    float2 a3 = u[3] + u[4], b3 = u[3] - u[4];
    float2 m1 = u[0] + c1 * a1 + c2 * a2 + c3 * a3;
    float2 m2 = u[0] + c2 * a1 + c3 * a2 + c1 * a3;
    float2 m3 = u[0] + c3 * a1 + c1 * a2 + c2 * a3;
    float2 r1 = rot90(s1 * b1 + s2 * b2 + s3 * b3, sgn);
    float2 r2 = rot90(s2 * b1 - s3 * b2 - s1 * b3, sgn);
    float2 r3 = rot90(s3 * b1 - s1 * b2 + s2 * b3, sgn);
    u[0] = u[0] + a1 + a2 + a3;
    u[1] = m1 + r1;
    u[6] = m1 - r1;
    u[2] = m2 + r2;
    u[5] = m2 - r2;
    u[3] = m3 + r3;
    u[4] = m3 - r3;
}

/* One pass along a strided axis ("column" pass): dimension 0 = x index c (< nc, consecutive
 * work-items touch consecutive addresses), dimension 1 = butterfly i (< L/R), dimension 2 =
 * batch b (< nb). Element at position q of line (c, b): base + q * sa, base = c + b * sb.
 * ts = L / (p R). */
#define COL_PASS(R)                                                                             \
    __kernel void csi_fft_col_r##R(__global const float2 *in, __global float2 *out,           \
                                   __global const float2 *tw, const uint L, const uint p,      \
                                   const uint ts, const uint sa, const uint nc, const uint nb,  \
                                   const uint sb, const float sgn)                             \
    {                                                                                          \
        const uint c = (uint)get_global_id(0), i = (uint)get_global_id(1),                     \
                   b = (uint)get_global_id(2);                                                 \
        const uint T = L / R;                                                                  \
        if (c >= nc || i >= T || b >= nb)                                                      \
            return;                                                                            \
        const size_t base = (size_t)c + (size_t)b * sb;                                        \
        float2 u[R];                                                                           \
        for (uint r = 0; r < R; r++)                                                           \
            u[r] = in[base + (size_t)(i + r * T) * sa];                                        \
        const uint k = i % p;                                                                  \
        for (uint r = 1; r < R; r++)                                                           \
            u[r] = cmul(u[r], twid(tw[k * r * ts], sgn));                                      \
        dft##R(u, sgn);                                                                        \
        const uint j = (i - k) * R + k;                                                        \
        for (uint r = 0; r < R; r++)                                                           \
            out[base + (size_t)(j + r * p) * sa] = u[r];                                       \
    }

/* The same pass with the filter gain applied to its input: the first inverse pass along the
 * last axis reads the spectrum in natural order (p = 1), so position q = i + r T is the
 * frequency index along the axis, c the x index and b the middle index. The gain is
 * G = gx[c] gb[b] ga[q] (separable Gaussian), turned into the Wiener inverse
 * (1 + lambda) G / (G^2 + lambda) when wiener != 0, times the transform's normalisation. */
#define COL_PASS_GAIN(R)                                                                        \
    __kernel void csi_fft_col_gain_r##R(__global const float2 *in, __global float2 *out,      \
                                        __global const float2 *tw, const uint L,               \
                                        const uint p, const uint ts, const uint sa,            \
                                        const uint nc, const uint nb, const uint sb,           \
                                        const float sgn, __global const float *gx,             \
                                        __global const float *gb, __global const float *ga,    \
                                        const uint wiener, const float lambda,                 \
                                        const float scale)                                     \
    {                                                                                          \
        const uint c = (uint)get_global_id(0), i = (uint)get_global_id(1),                     \
                   b = (uint)get_global_id(2);                                                 \
        const uint T = L / R;                                                                  \
        if (c >= nc || i >= T || b >= nb)                                                      \
            return;                                                                            \
        const size_t base = (size_t)c + (size_t)b * sb;                                        \
        const float gcb = gx[c] * gb[b];                                                       \
        float2 u[R];                                                                           \
        for (uint r = 0; r < R; r++) {                                                         \
            float g = gcb * ga[i + r * T];                                                     \
            if (wiener)                                                                        \
                g = (1.0f + lambda) * g / (g * g + lambda);                                    \
            u[r] = in[base + (size_t)(i + r * T) * sa] * (g * scale);                          \
        }                                                                                      \
        const uint k = i % p;                                                                  \
        for (uint r = 1; r < R; r++)                                                           \
            u[r] = cmul(u[r], twid(tw[k * r * ts], sgn));                                      \
        dft##R(u, sgn);                                                                        \
        const uint j = (i - k) * R + k;                                                        \
        for (uint r = 0; r < R; r++)                                                           \
            out[base + (size_t)(j + r * p) * sa] = u[r];                                       \
    }

/* One pass along contiguous rows: dimension 0 = butterfly i (< L/R), dimension 1 = row
 * (< nrows); row n starts at n * rs. */
#define ROW_PASS(R)                                                                             \
    __kernel void csi_fft_row_r##R(__global const float2 *in, __global float2 *out,           \
                                   __global const float2 *tw, const uint L, const uint p,      \
                                   const uint ts, const uint nrows, const uint rs,             \
                                   const float sgn)                                            \
    {                                                                                          \
        const uint i = (uint)get_global_id(0), row = (uint)get_global_id(1);                   \
        const uint T = L / R;                                                                  \
        if (i >= T || row >= nrows)                                                            \
            return;                                                                            \
        const size_t base = (size_t)row * rs;                                                  \
        float2 u[R];                                                                           \
        for (uint r = 0; r < R; r++)                                                           \
            u[r] = in[base + i + r * T];                                                       \
        const uint k = i % p;                                                                  \
        for (uint r = 1; r < R; r++)                                                           \
            u[r] = cmul(u[r], twid(tw[k * r * ts], sgn));                                      \
        dft##R(u, sgn);                                                                        \
        const uint j = (i - k) * R + k;                                                        \
        for (uint r = 0; r < R; r++)                                                           \
            out[base + j + r * p] = u[r];                                                      \
    }

#define ALL_PASSES(R) COL_PASS(R) COL_PASS_GAIN(R) ROW_PASS(R)
ALL_PASSES(2)
ALL_PASSES(3)
ALL_PASSES(4)
ALL_PASSES(5)
ALL_PASSES(7)
ALL_PASSES(8)
ALL_PASSES(16)

/* Real-to-complex unpacking (Numerical Recipes 3rd ed. Sec. 12.3.2; Van Loan Sec. 4.4): a real
 * row x of n = 2M samples read as M complex z[m] = x[2m] + i x[2m+1] has Z = DFT_M(z), and
 *     E[k] = (Z[k] + conj Z[M-k]) / 2,  O[k] = -i (Z[k] - conj Z[M-k]) / 2,
 *     X[k] = E[k] + W^k O[k],  W = exp(-2 pi i / n),  k = 0 .. M  (Z[M] = Z[0]).
 * Z rows have M values, X rows hs >= M + 1 values; wn[k] = W^k. */
__kernel void csi_fft_r2c_post(__global const float2 *Z, __global float2 *X,
                               __global const float2 *wn, const uint M, const uint hs,
                               const uint nrows)
{
    const uint k = (uint)get_global_id(0), row = (uint)get_global_id(1);
    if (k > M || row >= nrows)
        return;
    const size_t zb = (size_t)row * M;
    float2 zk = Z[zb + (k == M ? 0 : k)];
    float2 zm = Z[zb + (k == 0 ? 0 : M - k)];
    float2 zmc = (float2)(zm.x, -zm.y);
    float2 e = 0.5f * (zk + zmc);
    float2 d = zk - zmc;
    float2 o = 0.5f * (float2)(d.y, -d.x);
    X[(size_t)row * hs + k] = e + cmul(wn[k], o);
}

/* Complex-to-real packing, the inverse of the above for a Hermitian half spectrum X[0..M]:
 *     E[k] = (X[k] + conj X[M-k]) / 2,  O[k] = (X[k] - conj X[M-k]) conj(W^k) / 2,
 *     Z[k] = E[k] + i O[k],  k = 0 .. M-1;
 * an unnormalised inverse DFT_M of Z then gives M (y[2m] + i y[2m+1]), y = IDFT_n(X) / n
 * scaled; the host folds the constants into the gain. */
__kernel void csi_fft_c2r_pre(__global const float2 *X, __global float2 *Z,
                              __global const float2 *wn, const uint M, const uint hs,
                              const uint nrows)
{
    const uint k = (uint)get_global_id(0), row = (uint)get_global_id(1);
    if (k >= M || row >= nrows)
        return;
    const size_t xb = (size_t)row * hs;
    float2 xk = X[xb + k], xm = X[xb + M - k];
    float2 xmc = (float2)(xm.x, -xm.y);
    float2 e = 0.5f * (xk + xmc);
    float2 w = wn[k];
    float2 o = 0.5f * cmul(xk - xmc, (float2)(w.x, -w.y));
    Z[(size_t)row * M + k] = e + (float2)(-o.y, o.x);
}

/* Gain on a half spectrum of rows of hs values (1-D filters, which have no column pass to fuse
 * the gain into): X[row, k] *= scale * gain(gx[k] gr[row]). */
__kernel void csi_fft_gain_rows(__global float2 *X, __global const float *gx,
                                __global const float *gr, const uint h0, const uint hs,
                                const uint nrows, const uint wiener, const float lambda,
                                const float scale)
{
    const uint k = (uint)get_global_id(0), row = (uint)get_global_id(1);
    if (k >= h0 || row >= nrows)
        return;
    float g = gx[k] * gr[row];
    if (wiener)
        g = (1.0f + lambda) * g / (g * g + lambda);
    X[(size_t)row * hs + k] *= g * scale;
}
