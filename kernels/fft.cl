/* Mixed-radix Stockham FFT passes written for CPU OpenCL (PoCL), used by the Gaussian / Wiener
 * filter (host/ops/fft_filter.c); clFFT stays the reference the tests check them against.
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


/* Complex values are kept as separate re / im floats, indices as size_t, and buffers restrict:
 * PoCL (LLVM 15) only vectorises the work-item loop when the body has no float2 vector types and
 * no 32-bit index arithmetic that may wrap (checked in the generated code: with float2 or uint
 * indices the passes compiled to scalar code and ran 2-3x slower). */

/* t = a * b (complex), on values of type T (float, or float16 for 16 lanes: the same
 * expression, so the same rounding per element) */
#define CMUL_T(T, tr, ti, ar, ai, br, bi)                                                       \
    do {                                                                                       \
        T ar_ = (ar), ai_ = (ai), br_ = (br), bi_ = (bi);                                      \
        tr = ar_ * br_ - ai_ * bi_;                                                            \
        ti = ar_ * bi_ + ai_ * br_;                                                            \
    } while (0)
#define CMUL(tr, ti, ar, ai, br, bi) CMUL_T(float, tr, ti, ar, ai, br, bi)
#define CMUL16(tr, ti, ar, ai, br, bi) CMUL_T(float16, tr, ti, ar, ai, br, bi)

/* The power-of-two DFTs, for scalars (T = float, S empty: dft4, dft2, dft8) and for 16 or 8
 * lanes at once (T = float16, S = _v16; T = float8, S = _v8). dft4: 4-point DFT in place,
 * natural order in and out; sgn = -1 forward, +1 inverse. dft8: 4-point DFTs of the even and odd
 * samples, then radix 2 with w8^k, w8 = exp(sgn 2 pi i / 8). */
#define DFT_POW2(T, S)                                                                         \
inline void dft4##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    T a0r = xr[0] + xr[2], a0i = xi[0] + xi[2], a1r = xr[0] - xr[2], a1i = xi[0] - xi[2];      \
    T a2r = xr[1] + xr[3], a2i = xi[1] + xi[3], dr = xr[1] - xr[3], di = xi[1] - xi[3];        \
    T a3r = -sgn * di, a3i = sgn * dr; /* sgn i (x1 - x3) */                                   \
    xr[0] = a0r + a2r;                                                                         \
    xi[0] = a0i + a2i;                                                                         \
    xr[2] = a0r - a2r;                                                                         \
    xi[2] = a0i - a2i;                                                                         \
    xr[1] = a1r + a3r;                                                                         \
    xi[1] = a1i + a3i;                                                                         \
    xr[3] = a1r - a3r;                                                                         \
    xi[3] = a1i - a3i;                                                                         \
}                                                                                              \
inline void dft2##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    T tr = xr[0] - xr[1], ti = xi[0] - xi[1];                                                  \
    xr[0] += xr[1];                                                                            \
    xi[0] += xi[1];                                                                            \
    xr[1] = tr;                                                                                \
    xi[1] = ti;                                                                                \
}                                                                                              \
inline void dft8##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    const float h = 0.70710678118654752f;                                                      \
    T er[4] = {xr[0], xr[2], xr[4], xr[6]}, ei[4] = {xi[0], xi[2], xi[4], xi[6]};              \
    T or_[4] = {xr[1], xr[3], xr[5], xr[7]}, oi[4] = {xi[1], xi[3], xi[5], xi[7]};             \
    dft4##S(er, ei, sgn);                                                                      \
    dft4##S(or_, oi, sgn);                                                                     \
    /* w8^1 = h (1 + sgn i), w8^2 = sgn i, w8^3 = h (-1 + sgn i) */                            \
    T t1r = h * (or_[1] - sgn * oi[1]), t1i = h * (oi[1] + sgn * or_[1]);                      \
    T t2r = -sgn * oi[2], t2i = sgn * or_[2];                                                  \
    T t3r = h * (-or_[3] - sgn * oi[3]), t3i = h * (-oi[3] + sgn * or_[3]);                    \
    xr[0] = er[0] + or_[0];                                                                    \
    xi[0] = ei[0] + oi[0];                                                                     \
    xr[4] = er[0] - or_[0];                                                                    \
    xi[4] = ei[0] - oi[0];                                                                     \
    xr[1] = er[1] + t1r;                                                                       \
    xi[1] = ei[1] + t1i;                                                                       \
    xr[5] = er[1] - t1r;                                                                       \
    xi[5] = ei[1] - t1i;                                                                       \
    xr[2] = er[2] + t2r;                                                                       \
    xi[2] = ei[2] + t2i;                                                                       \
    xr[6] = er[2] - t2r;                                                                       \
    xi[6] = ei[2] - t2i;                                                                       \
    xr[3] = er[3] + t3r;                                                                       \
    xi[3] = ei[3] + t3i;                                                                       \
    xr[7] = er[3] - t3r;                                                                       \
    xi[7] = ei[3] - t3i;                                                                       \
}
DFT_POW2(float, )
DFT_POW2(float16, _v16)
DFT_POW2(float8, _v8)

/* Explicit 16-wide vectors, for the kernels PoCL's work-group vectoriser leaves scalar or turns
 * into gathers and scatters (mirrored or transposed accesses): such kernels run one work-item
 * per group along the vector's axis and hold 16 consecutive elements in each float16. */
#define EVEN16 (uint16)(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30)
#define ODD16 (uint16)(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31)
#define REV16 (uint16)(15, 14, 13, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2, 1, 0)
#define ILV_LO16 (uint16)(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23)
#define ILV_HI16 (uint16)(8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31)
/* float16 at float (4-byte) alignment: plain unaligned vector loads and stores (PoCL's vload16 /
 * vstore16 split into 8-byte pieces). */
typedef float16 float16u __attribute__((aligned(4)));
/* 16 complex values at element e of an interleaved array, as re / im vectors (rev: reversed). */
inline void load16c(__global const float *restrict a, size_t e, bool rev, float16 *re, float16 *im)
{
    const float16 lo = *(__global const float16u *)(a + 2 * e);
    const float16 hi = *(__global const float16u *)(a + 2 * e + 16);
    *re = shuffle2(lo, hi, EVEN16);
    *im = shuffle2(lo, hi, ODD16);
    if (rev) {
        *re = shuffle(*re, REV16);
        *im = shuffle(*im, REV16);
    }
}
inline void store16c(__global float *restrict a, size_t e, float16 re, float16 im)
{
    *(__global float16u *)(a + 2 * e) = shuffle2(re, im, ILV_LO16);
    *(__global float16u *)(a + 2 * e + 16) = shuffle2(re, im, ILV_HI16);
}
/* store16c to memory the stage will not read again soon: where the address allows (64-byte
 * aligned), non-temporal stores, which write the lines without reading them first (a fused row
 * stage's output, 71 MB at a 1920x1080 tile, is read back only after the whole stage, long
 * after it has left the caches); NT_STORES_DONE() orders them before the launch ends. x86 only;
 * elsewhere plain stores. */
#if defined(__x86_64__)
inline void store16nt(__global float *restrict a, size_t e, float16 re, float16 im)
{
    if (((size_t)(a + 2 * e) & 63) == 0) {
        __builtin_nontemporal_store(shuffle2(re, im, ILV_LO16), (__global float16 *)(a + 2 * e));
        __builtin_nontemporal_store(shuffle2(re, im, ILV_HI16), (__global float16 *)(a + 2 * e + 16));
    } else {
        store16c(a, e, re, im);
    }
}
#define NT_STORES_DONE() __asm__ volatile("sfence" ::: "memory")
#else
#define store16nt store16c
#define NT_STORES_DONE()
#endif


/* 16-point DFT as 4 x 4: input index q + 4 m, output s + 4 t:
 * X[s + 4t] = sum_q w4^(q t) w16^(q s) sum_m x[q + 4m] w4^(m s). */
inline void dft16(float *xr, float *xi, float sgn)
{
    const float c1 = 0.92387953251128676f, s1 = 0.38268343236508977f, h = 0.70710678118654752f;
    /* w16^m = (wc[m], sgn ws[m]), m = q s in 0..9 */
    const float wc[10] = {1.0f, c1, h, s1, 0.0f, -s1, -h, -c1, -1.0f, -c1};
    const float ws[10] = {0.0f, s1, h, c1, 1.0f, c1, h, s1, 0.0f, -s1};
    float ar[16], ai[16]; /* a[q * 4 + s] */
#pragma unroll
    for (int q = 0; q < 4; q++) {
        float tr[4] = {xr[q], xr[q + 4], xr[q + 8], xr[q + 12]};
        float ti[4] = {xi[q], xi[q + 4], xi[q + 8], xi[q + 12]};
        dft4(tr, ti, sgn);
#pragma unroll
        for (int s = 0; s < 4; s++) {
            if (q == 0 || s == 0) {
                ar[q * 4 + s] = tr[s];
                ai[q * 4 + s] = ti[s];
            } else {
                CMUL(ar[q * 4 + s], ai[q * 4 + s], tr[s], ti[s], wc[q * s], sgn * ws[q * s]);
            }
        }
    }
#pragma unroll
    for (int s = 0; s < 4; s++) {
        float tr[4] = {ar[s], ar[4 + s], ar[8 + s], ar[12 + s]};
        float ti[4] = {ai[s], ai[4 + s], ai[8 + s], ai[12 + s]};
        dft4(tr, ti, sgn);
#pragma unroll
        for (int t = 0; t < 4; t++) {
            xr[s + 4 * t] = tr[t];
            xi[s + 4 * t] = ti[t];
        }
    }
}

/* Odd radices: x'[q] = sum_r x[r] exp(sgn 2 pi i q r / R), with a_r = x_r + x_(R-r),
 * b_r = x_r - x_(R-r): x'[q], x'[R-q] = x0 + sum a_r cos(2 pi q r/R) +- sgn i sum b_r sin(...).
 * dft3 and dft5 also on 16 and 8 lanes (S = _v16, _v8), by the same expressions. */
#define DFT_3_5(T, S)                                                                          \
inline void dft3##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    const float c = -0.5f, s = 0.86602540378443865f;                                           \
    T ar = xr[1] + xr[2], ai = xi[1] + xi[2], br = xr[1] - xr[2], bi = xi[1] - xi[2];          \
    T mr = xr[0] + c * ar, mi = xi[0] + c * ai;                                                \
    T rr = -sgn * s * bi, ri = sgn * s * br;                                                   \
    xr[0] += ar;                                                                               \
    xi[0] += ai;                                                                               \
    xr[1] = mr + rr;                                                                           \
    xi[1] = mi + ri;                                                                           \
    xr[2] = mr - rr;                                                                           \
    xi[2] = mi - ri;                                                                           \
}                                                                                              \
inline void dft5##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    const float c1 = 0.30901699437494742f, c2 = -0.80901699437494742f;                         \
    const float s1 = 0.95105651629515357f, s2 = 0.58778525229247313f;                          \
    T a1r = xr[1] + xr[4], a1i = xi[1] + xi[4], b1r = xr[1] - xr[4], b1i = xi[1] - xi[4];      \
    T a2r = xr[2] + xr[3], a2i = xi[2] + xi[3], b2r = xr[2] - xr[3], b2i = xi[2] - xi[3];      \
    T m1r = xr[0] + c1 * a1r + c2 * a2r, m1i = xi[0] + c1 * a1i + c2 * a2i;                    \
    T m2r = xr[0] + c2 * a1r + c1 * a2r, m2i = xi[0] + c2 * a1i + c1 * a2i;                    \
    T v1r = s1 * b1r + s2 * b2r, v1i = s1 * b1i + s2 * b2i;                                    \
    T v2r = s2 * b1r - s1 * b2r, v2i = s2 * b1i - s1 * b2i;                                    \
    T r1r = -sgn * v1i, r1i = sgn * v1r, r2r = -sgn * v2i, r2i = sgn * v2r;                    \
    xr[0] += a1r + a2r;                                                                        \
    xi[0] += a1i + a2i;                                                                        \
    xr[1] = m1r + r1r;                                                                         \
    xi[1] = m1i + r1i;                                                                         \
    xr[4] = m1r - r1r;                                                                         \
    xi[4] = m1i - r1i;                                                                         \
    xr[2] = m2r + r2r;                                                                         \
    xi[2] = m2i + r2i;                                                                         \
    xr[3] = m2r - r2r;                                                                         \
    xi[3] = m2i - r2i;                                                                         \
}
DFT_3_5(float, )
DFT_3_5(float16, _v16)
DFT_3_5(float8, _v8)

inline void dft7(float *xr, float *xi, float sgn)
{
    const float c1 = 0.62348980185873353f, c2 = -0.22252093395631440f, c3 = -0.90096886790241913f;
    const float s1 = 0.78183148246802981f, s2 = 0.97492791218182361f, s3 = 0.43388373911755812f;
    float a1r = xr[1] + xr[6], a1i = xi[1] + xi[6], b1r = xr[1] - xr[6], b1i = xi[1] - xi[6];
    float a2r = xr[2] + xr[5], a2i = xi[2] + xi[5], b2r = xr[2] - xr[5], b2i = xi[2] - xi[5];
    float a3r = xr[3] + xr[4], a3i = xi[3] + xi[4], b3r = xr[3] - xr[4], b3i = xi[3] - xi[4];
    float m1r = xr[0] + c1 * a1r + c2 * a2r + c3 * a3r, m1i = xi[0] + c1 * a1i + c2 * a2i + c3 * a3i;
    float m2r = xr[0] + c2 * a1r + c3 * a2r + c1 * a3r, m2i = xi[0] + c2 * a1i + c3 * a2i + c1 * a3i;
    float m3r = xr[0] + c3 * a1r + c1 * a2r + c2 * a3r, m3i = xi[0] + c3 * a1i + c1 * a2i + c2 * a3i;
    float v1r = s1 * b1r + s2 * b2r + s3 * b3r, v1i = s1 * b1i + s2 * b2i + s3 * b3i;
    float v2r = s2 * b1r - s3 * b2r - s1 * b3r, v2i = s2 * b1i - s3 * b2i - s1 * b3i;
    float v3r = s3 * b1r - s1 * b2r + s2 * b3r, v3i = s3 * b1i - s1 * b2i + s2 * b3i;
    xr[0] += a1r + a2r + a3r;
    xi[0] += a1i + a2i + a3i;
    xr[1] = m1r - sgn * v1i;
    xi[1] = m1i + sgn * v1r;
    xr[6] = m1r + sgn * v1i;
    xi[6] = m1i - sgn * v1r;
    xr[2] = m2r - sgn * v2i;
    xi[2] = m2i + sgn * v2r;
    xr[5] = m2r + sgn * v2i;
    xi[5] = m2i - sgn * v2r;
    xr[3] = m3r - sgn * v3i;
    xi[3] = m3i + sgn * v3r;
    xr[4] = m3r + sgn * v3i;
    xi[4] = m3i - sgn * v3r;
}

/* 3-point DFT of (r0, i0), (r1, i1), (r2, i2) of type T in place (dft3 on named values). */
#define DFT3_V(T, r0, i0, r1, i1, r2, i2, sgn)                                                  \
    do {                                                                                       \
        const T ar_ = r1 + r2, ai_ = i1 + i2, br_ = r1 - r2, bi_ = i1 - i2;                    \
        const T mr_ = r0 - 0.5f * ar_, mi_ = i0 - 0.5f * ai_;                                  \
        const T rr_ = -(sgn) * 0.86602540378443865f * bi_;                                     \
        const T ri_ = (sgn) * 0.86602540378443865f * br_;                                      \
        r0 += ar_;                                                                             \
        i0 += ai_;                                                                             \
        r1 = mr_ + rr_;                                                                        \
        i1 = mi_ + ri_;                                                                        \
        r2 = mr_ - rr_;                                                                        \
        i2 = mi_ - ri_;                                                                        \
    } while (0)

/* 9-point DFT as 3 x 3 (input index q + 3 m, output s + 3 t), for scalars (dft9) and 16 or 8
 * lanes (dft9_v16, dft9_v8): X[s + 3t] = sum_q w3^(q t) w9^(q s) sum_m x[q + 3m] w3^(m s). One
 * pass of it replaces two radix-3 passes: every pass reads and writes the whole volume, and a radix-3 pass
 * costs about as much as a radix-8 one (docs/bench/cost.md). Named values throughout, with
 * w9^m = (cos, sgn sin)(2 pi m / 9) for m = q s in {1, 2, 4}. */
#define DFT9(T, S)                                                                             \
inline void dft9##S(T *xr, T *xi, float sgn)                                                   \
{                                                                                              \
    const float c1 = 0.76604444311897804f, s1 = 0.64278760968653933f;                          \
    const float c2 = 0.17364817766693035f, s2 = 0.98480775301220806f;                          \
    const float c4 = -0.93969262078590838f, s4 = 0.34202014332566873f;                         \
    T a0r = xr[0], a0i = xi[0], a1r = xr[3], a1i = xi[3], a2r = xr[6], a2i = xi[6];            \
    T b0r = xr[1], b0i = xi[1], b1r = xr[4], b1i = xi[4], b2r = xr[7], b2i = xi[7];            \
    T d0r = xr[2], d0i = xi[2], d1r = xr[5], d1i = xi[5], d2r = xr[8], d2i = xi[8];            \
    DFT3_V(T, a0r, a0i, a1r, a1i, a2r, a2i, sgn); /* q = 0: a[s] */                           \
    DFT3_V(T, b0r, b0i, b1r, b1i, b2r, b2i, sgn); /* q = 1 */                                 \
    DFT3_V(T, d0r, d0i, d1r, d1i, d2r, d2i, sgn); /* q = 2 */                                 \
    CMUL_T(T, b1r, b1i, b1r, b1i, c1, sgn * s1); /* w9^(q s) */                               \
    CMUL_T(T, b2r, b2i, b2r, b2i, c2, sgn * s2);                                               \
    CMUL_T(T, d1r, d1i, d1r, d1i, c2, sgn * s2);                                               \
    CMUL_T(T, d2r, d2i, d2r, d2i, c4, sgn * s4);                                               \
    DFT3_V(T, a0r, a0i, b0r, b0i, d0r, d0i, sgn); /* s = 0: outputs 0, 3, 6 */                \
    DFT3_V(T, a1r, a1i, b1r, b1i, d1r, d1i, sgn); /* s = 1: outputs 1, 4, 7 */                \
    DFT3_V(T, a2r, a2i, b2r, b2i, d2r, d2i, sgn); /* s = 2: outputs 2, 5, 8 */                \
    xr[0] = a0r, xi[0] = a0i, xr[3] = b0r, xi[3] = b0i, xr[6] = d0r, xi[6] = d0i;              \
    xr[1] = a1r, xi[1] = a1i, xr[4] = b1r, xi[4] = b1i, xr[7] = d1r, xi[7] = d1i;              \
    xr[2] = a2r, xi[2] = a2i, xr[5] = b2r, xi[5] = b2i, xr[8] = d2r, xi[8] = d2i;              \
}
DFT9(float, )
DFT9(float16, _v16)
DFT9(float8, _v8)

/* The pass kernels have no bounds checks: the host launches them with global sizes that are
 * exact multiples of the local sizes (column passes run over the padded row length hs, a
 * multiple of 16, and the padding columns are scratch). With a bounds check PoCL vectorised the
 * loads and stores as masked gathers and scatters, several times slower. */

/* Twiddle, load, store and DFT of one Stockham pass; in/out are float arrays of interleaved
 * (re, im) pairs, complex element e at 2e. `ld(r)` / `st(r)` give the complex element index of
 * the r-th input / output. The table tw holds exp(-2 pi i m / L); conjugated for sgn = +1. */
#define PASS_BODY(R, LD, ST, SCALE) PASS_BODY_L(R, LD, ST, SCALE, LOAD_REAL)
/* Loads of the input element e_ into xr[r], xi[r]: times a real factor SCALE(r), or times the
 * complex factor (gr_[r], gi_[r]) of the gain pass with a complex factor (SCALE unused). */
#define LOAD_REAL(r, e_, SCALE)                                                                 \
    xr[r] = in[2 * e_] * SCALE(r);                                                             \
    xi[r] = in[2 * e_ + 1] * SCALE(r);
#define LOAD_CPLX(r, e_, SCALE)                                                                 \
    CMUL(xr[r], xi[r], in[2 * e_], in[2 * e_ + 1], gr_[r], gi_[r]);
/* k = i mod p, and inputs r > 0 times w^(r k) from the table tw (CM: CMUL or CMUL16). */
#define PASS_TWIDDLES(R, CM)                                                                   \
    const size_t k = i % p;                                                                    \
    if (p > 1) {                                                                               \
        _Pragma("unroll") for (int r = 1; r < R; r++) {                                        \
            const size_t m_ = k * (size_t)r * ts;                                              \
            CM(xr[r], xi[r], xr[r], xi[r], tw[2 * m_], -sgn * tw[2 * m_ + 1]);                 \
        }                                                                                      \
    }
#define PASS_BODY_L(R, LD, ST, SCALE, LOAD)                                                     \
    float xr[R], xi[R];                                                                        \
    _Pragma("unroll") for (int r = 0; r < R; r++) {                                            \
        const size_t e_ = LD(r);                                                               \
        LOAD(r, e_, SCALE)                                                                     \
    }                                                                                          \
    PASS_TWIDDLES(R, CMUL)                                                                     \
    dft##R(xr, xi, sgn);                                                                       \
    const size_t j = (i - k) * R + k;                                                          \
    _Pragma("unroll") for (int r = 0; r < R; r++) {                                            \
        const size_t e_ = ST(r);                                                               \
        out[2 * e_] = xr[r];                                                                   \
        out[2 * e_ + 1] = xi[r];                                                               \
    }

#define NOSCALE(r) 1.0f

/* One pass along a strided axis ("column" pass): launch dimension 0 = x index c (< nc;
 * consecutive work-items touch consecutive addresses), dimension 1 = butterfly i (< L/R),
 * dimension 2 = batch b (< nb). Element q of line (c, b) is at base + q sa, base = c + b sb.
 * ts = L / (p R). */
#define COL_LD(r) (base + (i + (size_t)(r) * T) * sa)
#define COL_ST(r) (base + (j + (size_t)(r) * p) * sa)
#define COL_PASS_PARAMS                                                                         \
    __global const float *restrict in, __global float *restrict out,                           \
        __global const float *restrict tw, const uint L_, const uint p_, const uint ts_,       \
        const uint sa_, const uint nc, const uint nb, const uint sb_, const float sgn
#define COL_PASS(R)                                                                             \
    __kernel void csi_fft_col_r##R(COL_PASS_PARAMS)                                            \
    {                                                                                          \
        const size_t c = get_global_id(0), i = get_global_id(1), b = get_global_id(2);         \
        const size_t T = (size_t)L_ / R, p = p_, ts = ts_, sa = sa_;                           \
        const size_t base = c + b * (size_t)sb_;                                               \
        PASS_BODY(R, COL_LD, COL_ST, NOSCALE)                                                  \
    }

/* The same pass with the filter gain applied to its input. It is the first inverse pass along
 * the last axis, which reads the spectrum in natural order (p = 1): position q = i + r T is the
 * frequency index along that axis, c the x index and b the middle one. The gain is
 * G = gx[c] gb[b] ga[q] (the separable Gaussian), turned into the Wiener inverse
 * (1 + lambda) G / (G^2 + lambda) when wiener != 0, times the normalisation `scale`. */
#define GAIN_SCALE(r) g_[r]
/* The parameters and index set-up both gain passes share. */
#define GAIN_PASS_PARAMS                                                                        \
    __global const float *restrict in, __global float *restrict out,                           \
        __global const float *restrict tw, const uint L_, const uint p_, const uint ts_,       \
        const uint sa_, const uint nc, const uint nb, const uint sb_, const float sgn,         \
        __global const float *restrict gx, __global const float *restrict gb,                  \
        __global const float *restrict ga, const uint wiener, const float lambda,              \
        const float scale
#define GAIN_PASS_START(R)                                                                       \
    const size_t c = get_global_id(0), i = get_global_id(1), b = get_global_id(2);             \
    const size_t T = (size_t)L_ / R, p = p_, ts = ts_, sa = sa_;                               \
    const size_t base = c + b * (size_t)sb_;                                                   \
    const float gcb = gx[c] * gb[b];
/* The Gaussian or Wiener gain at position q_ along the last axis, times `scale`. */
#define GAIN_AT(q_) GAIN_AT_T(float, q_)
#define GAIN_AT_T(T, q_)                                                                        \
    T g = gcb * ga[q_];                                                                        \
    if (wiener)                                                                                \
        g = (1.0f + lambda) * g / (g * g + lambda);                                            \
    g *= scale;
#define COL_PASS_GAIN(R)                                                                        \
    __kernel void csi_fft_col_gain_r##R(GAIN_PASS_PARAMS)                                      \
    {                                                                                          \
        GAIN_PASS_START(R)                                                                     \
        float g_[R];                                                                           \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            GAIN_AT(i + (size_t)r * T)                                                         \
            g_[r] = g;                                                                         \
        }                                                                                      \
        PASS_BODY(R, COL_LD, COL_ST, GAIN_SCALE)                                               \
    }

/* The gain pass of a 2-D filter times a separable complex factor (csi_filter_create_factor in
 * csi/spectral.h): the gain above (b = 0, gb = {1}) times fc[c] fa[q], both complex
 * (interleaved); csgn = -1 conjugates them, which is the filter's adjoint. */
#define COL_PASS_CGAIN(R)                                                                       \
    __kernel void csi_fft_col_cgain_r##R(GAIN_PASS_PARAMS, __global const float *restrict fc,  \
                                         __global const float *restrict fa, const float csgn)  \
    {                                                                                          \
        GAIN_PASS_START(R)                                                                     \
        const float fcr = fc[2 * c], fci = csgn * fc[2 * c + 1];                               \
        float gr_[R], gi_[R];                                                                  \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            const size_t q_ = i + (size_t)r * T;                                               \
            GAIN_AT(q_)                                                                        \
            float er, ei;                                                                      \
            CMUL(er, ei, fcr, fci, fa[2 * q_], csgn * fa[2 * q_ + 1]);                         \
            gr_[r] = g * er;                                                                   \
            gi_[r] = g * ei;                                                                   \
        }                                                                                      \
        PASS_BODY_L(R, COL_LD, COL_ST, NOSCALE, LOAD_CPLX)                                     \
    }

/* The complex gain pass (always the first inverse pass, p = 1) on 16-wide vectors, for R = 2, 4,
 * 8: a work-item takes 16 consecutive columns c of one butterfly i, whose loads and stores are
 * plain vectors (q sa apart). PoCL's own vectorisation of csi_fft_col_cgain_r* ran at a third of
 * a plain column pass's speed. Same arithmetic per element, so the same bits. */
#define COL_CGAIN_V16(R)                                                                        \
    __kernel void csi_fft_col_cgain1v_r##R(GAIN_PASS_PARAMS,                                   \
                                           __global const float *restrict fc,                  \
                                           __global const float *restrict fa, const float csgn) \
    {                                                                                          \
        const size_t c = 16 * get_global_id(0), i = get_global_id(1), b = get_global_id(2);    \
        const size_t T = (size_t)L_ / R, sa = sa_, base = c + b * (size_t)sb_;                 \
        const float16 gcb = *(__global const float16u *)(gx + c) * gb[b];                      \
        float16 fcr, fci, xr[R], xi[R];                                                        \
        load16c(fc, c, false, &fcr, &fci);                                                     \
        fci = csgn * fci;                                                                      \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            const size_t q_ = i + (size_t)r * T;                                               \
            GAIN_AT_T(float16, q_)                                                             \
            float16 er, ei, ur, ui;                                                            \
            CMUL16(er, ei, fcr, fci, fa[2 * q_], csgn * fa[2 * q_ + 1]);                       \
            load16c(in, base + q_ * sa, false, &ur, &ui);                                      \
            CMUL16(xr[r], xi[r], ur, ui, g * er, g * ei);                                      \
        }                                                                                      \
        dft##R##_v16(xr, xi, sgn);                                                             \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            store16c(out, base + (i * R + (size_t)r) * sa, xr[r], xi[r]);                      \
    }
COL_CGAIN_V16(2)
COL_CGAIN_V16(4)
COL_CGAIN_V16(8)

/* One pass along contiguous rows: dimension 0 = butterfly i (< L/R), dimension 1 = row
 * (< nrows); row n starts at element n rs. */
#define ROW_LD(r) (base + i + (size_t)(r) * T)
#define ROW_ST(r) (base + j + (size_t)(r) * p)
#define ROW_PASS(R)                                                                             \
    __kernel void csi_fft_row_r##R(__global const float *restrict in,                         \
                                   __global float *restrict out,                              \
                                   __global const float *restrict tw, const uint L_,           \
                                   const uint p_, const uint ts_, const uint nrows,            \
                                   const uint rs, const float sgn)                             \
    {                                                                                          \
        const size_t i = get_global_id(0), row = get_global_id(1);                             \
        const size_t T = (size_t)L_ / R, p = p_, ts = ts_;                                     \
        const size_t base = row * (size_t)rs;                                                  \
        PASS_BODY(R, ROW_LD, ROW_ST, NOSCALE)                                                  \
    }

/* A pass along contiguous rows once p >= 8: dimension 0 = k (< p), dimension 1 = block g
 * (< T/p), dimension 2 = row. With i = g p + k both the loads (i + r T) and the stores
 * (g p R + k + r p) are contiguous in k, so PoCL vectorises them as plain vector accesses; the
 * i-indexed form above needs scatters for its stores (stride R). Twiddles come from a per-pass
 * table twp[twoff + (r - 1) p + k] = exp(-2 pi i r k / (p R)), also contiguous in k. */
#define ROWK_PASS_PARAMS                                                                        \
    __global const float *restrict in, __global float *restrict out,                           \
        __global const float *restrict twp, const uint twoff, const uint L_, const uint p_,    \
        const uint rs, const float sgn
#define ROWK_PASS(R)                                                                            \
    __kernel void csi_fft_rowk_r##R(ROWK_PASS_PARAMS)                                          \
    {                                                                                          \
        const size_t k = get_global_id(0), g = get_global_id(1), row = get_global_id(2);       \
        const size_t T = (size_t)L_ / R, p = p_;                                               \
        const size_t base = row * (size_t)rs, i = g * p + k;                                   \
        float xr[R], xi[R];                                                                    \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            const size_t e_ = base + i + (size_t)r * T;                                        \
            xr[r] = in[2 * e_];                                                                \
            xi[r] = in[2 * e_ + 1];                                                            \
        }                                                                                      \
        _Pragma("unroll") for (int r = 1; r < R; r++) {                                        \
            const size_t m_ = (size_t)twoff + (size_t)(r - 1) * p + k;                         \
            CMUL(xr[r], xi[r], xr[r], xi[r], twp[2 * m_], -sgn * twp[2 * m_ + 1]);             \
        }                                                                                      \
        dft##R(xr, xi, sgn);                                                                   \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            const size_t e_ = base + g * p * R + k + (size_t)r * p;                            \
            out[2 * e_] = xr[r];                                                               \
            out[2 * e_ + 1] = xi[r];                                                           \
        }                                                                                      \
    }

/* The first pass along rows (p = 1) of a complex-to-complex transform, with its inputs
 * multiplied by `scale` (the 1/sqrt(N) of the orthonormal Fourier basis, fused here so that it
 * costs no pass of its own). */
#define USCALE(r) scale
#define ROW_PASS_SCALED(R)                                                                      \
    __kernel void csi_fft_row_s_r##R(__global const float *restrict in,                       \
                                     __global float *restrict out,                            \
                                     __global const float *restrict tw, const uint L_,         \
                                     const uint p_, const uint ts_, const uint nrows,          \
                                     const uint rs, const float sgn, const float scale)        \
    {                                                                                          \
        const size_t i = get_global_id(0), row = get_global_id(1);                             \
        const size_t T = (size_t)L_ / R, p = p_, ts = ts_;                                     \
        const size_t base = row * (size_t)rs;                                                  \
        PASS_BODY(R, ROW_LD, ROW_ST, USCALE)                                                   \
    }

/* The first pass along rows (p = 1) on 16-wide vectors, for R = 2, 4, 8: the i-indexed form
 * above stores with a stride of R (scatters), and when T = L / R is not a multiple of 16 PoCL
 * vectorises it only as wide as the power of two dividing T. Here a work-item loads 16
 * consecutive butterflies' inputs (plain vector loads), and the 16 x R outputs, one contiguous
 * run of 16 R complex values, are transposed in registers by log2(2R) rounds of interleaving
 * (the rows xr[0], xi[0], xr[1], ... zipped with the second half) and stored as plain vectors.
 * Group g covers butterflies 16 g .. 16 g + 15; the last group is moved back to end at T
 * (T >= 16), so it recomputes and rewrites a few of its neighbour's outputs with the same
 * values. Inputs times `scale` (1 where the pass is not scaled: exact). Same arithmetic per
 * butterfly as csi_fft_row_r*, so the same bits. */
/* The 16 x R outputs xr[r], xi[r] of 16 butterflies at p = 1 as v[0 .. 2 R - 1], one contiguous
 * run of 16 R complex values: log2(2R) rounds of interleaving the rows xr[0], xi[0], xr[1], ...
 * with their second half, each interleave one two-source permute. Each round's results pass
 * through SHUFFLE_FENCE16: left to itself, LLVM (15, in PoCL) merges the rounds into shuffles of
 * many sources, which it lowers to chains of 128- and 256-bit inserts, blends and permutes, more
 * than twice the instructions, all on the one port that shuffles (seen in the generated code);
 * the fence is an empty asm statement, which LLVM cannot look through. It moves no value, so the
 * transpose's result is the same. Where the device is not x86 with AVX-512 it is nothing. */
#if defined(__x86_64__) && defined(__AVX512F__)
#define SHUFFLE_FENCE16(x) __asm__("" : "+v"(x))
#else
#define SHUFFLE_FENCE16(x)
#endif
#define ROW1_TRANSPOSE(R, LOG2_2R)                                                              \
    {                                                                                          \
        float16 w[2 * R];                                                                      \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            v[2 * r] = xr[r];                                                                  \
            v[2 * r + 1] = xi[r];                                                              \
        }                                                                                      \
        _Pragma("unroll") for (int round = 0; round < LOG2_2R; round++) {                      \
            _Pragma("unroll") for (int j = 0; j < R; j++) {                                    \
                w[2 * j] = shuffle2(v[j], v[j + R], ILV_LO16);                                 \
                w[2 * j + 1] = shuffle2(v[j], v[j + R], ILV_HI16);                             \
            }                                                                                  \
            _Pragma("unroll") for (int q = 0; q < 2 * R; q++) {                                \
                SHUFFLE_FENCE16(w[q]);                                                         \
                v[q] = w[q];                                                                   \
            }                                                                                  \
        }                                                                                      \
    }
#define ROW1_V16(R, LOG2_2R)                                                                    \
    __kernel void csi_fft_row1v_r##R(__global const float *restrict in,                       \
                                     __global float *restrict out, const uint T_,              \
                                     const uint rs, const float sgn, const float scale)        \
    {                                                                                          \
        const size_t T = T_, row = get_global_id(1);                                           \
        size_t i0 = 16 * get_global_id(0);                                                     \
        if (i0 > T - 16)                                                                       \
            i0 = T - 16;                                                                       \
        const size_t base = row * (size_t)rs;                                                  \
        float16 xr[R], xi[R], v[2 * R];                                                        \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            load16c(in, base + i0 + (size_t)r * T, false, &xr[r], &xi[r]);                     \
            xr[r] *= scale;                                                                    \
            xi[r] *= scale;                                                                    \
        }                                                                                      \
        dft##R##_v16(xr, xi, sgn);                                                             \
        ROW1_TRANSPOSE(R, LOG2_2R)                                                             \
        __global float *o = out + 2 * (base + i0 * R);                                         \
        _Pragma("unroll") for (int q = 0; q < 2 * R; q++)                                      \
            *(__global float16u *)(o + 16 * q) = v[q];                                         \
    }
ROW1_V16(2, 2)
ROW1_V16(4, 3)
ROW1_V16(8, 4)

/* The pass at p = 8 (the second along rows), on 16-wide vectors for R = 2, 4, 8: csi_fft_rowk_r*
 * has only p = 8 work-items along the dimension PoCL vectorises. Here a work-item takes 16
 * consecutive butterflies i = i0 .. i0 + 15 (i0 a multiple of 8: blocks g = i0 / 8 and g + 1,
 * k = i mod 8): plain vector loads, the 8 twiddles of the pass repeated, and per output r two
 * runs of 8 contiguous values, one per block. The last group is moved back to end at T, as
 * above. Same arithmetic per butterfly as csi_fft_rowk_r*, so the same bits. */
#define DUP8_RE (uint16)(0, 2, 4, 6, 8, 10, 12, 14, 0, 2, 4, 6, 8, 10, 12, 14)
#define DUP8_IM (uint16)(1, 3, 5, 7, 9, 11, 13, 15, 1, 3, 5, 7, 9, 11, 13, 15)
#define ROWK8_V16(R)                                                                            \
    __kernel void csi_fft_rowk8v_r##R(__global const float *restrict in,                      \
                                      __global float *restrict out,                           \
                                      __global const float *restrict twp, const uint twoff,    \
                                      const uint T_, const uint rs, const float sgn)           \
    {                                                                                          \
        const size_t T = T_, row = get_global_id(1), p = 8;                                    \
        size_t i0 = 16 * get_global_id(0);                                                     \
        if (i0 > T - 16)                                                                       \
            i0 = T - 16;                                                                       \
        const size_t base = row * (size_t)rs;                                                  \
        float16 xr[R], xi[R];                                                                  \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            load16c(in, base + i0 + (size_t)r * T, false, &xr[r], &xi[r]);                     \
        _Pragma("unroll") for (int r = 1; r < R; r++) {                                        \
            const float16 t = *(__global const float16u *)(twp + 2 * ((size_t)twoff + (r - 1) * p)); \
            CMUL16(xr[r], xi[r], xr[r], xi[r], shuffle(t, DUP8_RE), -sgn * shuffle(t, DUP8_IM)); \
        }                                                                                      \
        dft##R##_v16(xr, xi, sgn);                                                             \
        __global float *o = out + 2 * (base + (i0 / p) * p * R);                               \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            *(__global float16u *)(o + 2 * r * p) = shuffle2(xr[r], xi[r], ILV_LO16);          \
            *(__global float16u *)(o + 2 * (p * R + r * p)) = shuffle2(xr[r], xi[r], ILV_HI16); \
        }                                                                                      \
    }
ROWK8_V16(2)
ROWK8_V16(4)
ROWK8_V16(8)

/* Radix-9 passes on explicit 16-wide vectors: PoCL left the 9-point DFT's work-item loop
 * scalar (its generated code for csi_fft_col_r9 / csi_fft_rowk_r9: scalar ss arithmetic and
 * stack spills, 4-5x the time of a radix-3 pass). A work-item takes 16 consecutive columns
 * (col1v: a pass along y or z at any p; launch dimension 0 counts groups of 16 of the nc
 * columns, nc a multiple of 16) or 16 consecutive k of a row pass at p, a multiple of 16
 * (rowkv), whose loads, twiddles and stores are all contiguous in k. Same arithmetic per element
 * as csi_fft_col_r9 / csi_fft_rowk_r9. */
#define COL_V16(R)                                                                              \
    __kernel void csi_fft_col1v_r##R(COL_PASS_PARAMS)                                          \
    {                                                                                          \
        const size_t c = 16 * get_global_id(0), i = get_global_id(1), b = get_global_id(2);    \
        const size_t T = (size_t)L_ / R, p = p_, ts = ts_, sa = sa_;                           \
        const size_t base = c + b * (size_t)sb_;                                               \
        float16 xr[R], xi[R];                                                                  \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            load16c(in, base + (i + (size_t)r * T) * sa, false, &xr[r], &xi[r]);               \
        PASS_TWIDDLES(R, CMUL16)                                                               \
        dft##R##_v16(xr, xi, sgn);                                                             \
        const size_t j = (i - k) * R + k;                                                      \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            store16c(out, base + (j + (size_t)r * p) * sa, xr[r], xi[r]);                      \
    }
#define ROWK_V16(R)                                                                             \
    __kernel void csi_fft_rowkv_r##R(ROWK_PASS_PARAMS)                                         \
    {                                                                                          \
        const size_t k = 16 * get_global_id(0), g = get_global_id(1), row = get_global_id(2);  \
        const size_t T = (size_t)L_ / R, p = p_;                                               \
        const size_t base = row * (size_t)rs, i = g * p + k;                                   \
        float16 xr[R], xi[R];                                                                  \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            load16c(in, base + i + (size_t)r * T, false, &xr[r], &xi[r]);                     \
        _Pragma("unroll") for (int r = 1; r < R; r++) {                                        \
            float16 wr, wi;                                                                    \
            load16c(twp, (size_t)twoff + (size_t)(r - 1) * p + k, false, &wr, &wi);            \
            CMUL16(xr[r], xi[r], xr[r], xi[r], wr, -sgn * wi);                                 \
        }                                                                                      \
        dft##R##_v16(xr, xi, sgn);                                                             \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            store16c(out, base + g * p * R + k + (size_t)r * p, xr[r], xi[r]);                 \
    }
COL_V16(9)
ROWK_V16(9)

#define ALL_PASSES(R) COL_PASS(R) COL_PASS_GAIN(R) COL_PASS_CGAIN(R) ROW_PASS(R) ROWK_PASS(R) ROW_PASS_SCALED(R)
ALL_PASSES(2)
ALL_PASSES(3)
ALL_PASSES(4)
ALL_PASSES(5)
ALL_PASSES(7)
ALL_PASSES(8)
ALL_PASSES(9)
ALL_PASSES(16)

/* Real-to-complex unpacking (Numerical Recipes 3rd ed. Sec. 12.3.2; Van Loan Sec. 4.4): a real
 * row x of n = 2M samples read as M complex z[m] = x[2m] + i x[2m+1] has Z = DFT_M(z), and
 *     E[k] = (Z[k] + conj Z[M-k]) / 2,  O[k] = -i (Z[k] - conj Z[M-k]) / 2,
 *     X[k] = E[k] + W^k O[k],  W = exp(-2 pi i / n),  k = 0 .. M  (Z[M] = Z[0]).
 * Z rows have M complex values, X rows hs >= M + 1; wn[k] = W^k. */
__kernel void csi_fft_r2c_post(__global const float *restrict Z, __global float *restrict X,
                               __global const float *restrict wn, const uint M_, const uint hs,
                               const uint nrows)
{
    /* Launched over k < M with exact sizes and no bounds check (so PoCL vectorises it; the
     * mirrored read M - k becomes a reversed vector load). k = 0 reads one element past its row
     * (the buffers have room) and is overwritten by csi_fft_r2c_edges with X[0] and X[M]. */
    const size_t k = get_global_id(0), row = get_global_id(1), M = M_;
    const size_t a = row * M + k, b = row * M + M - k;
    float zr = Z[2 * a], zi = Z[2 * a + 1], mr = Z[2 * b], mi = -Z[2 * b + 1]; /* m = conj */
    float er = 0.5f * (zr + mr), ei = 0.5f * (zi + mi);
    float dr = zr - mr, di = zi - mi;
    float or_ = 0.5f * di, oi = -0.5f * dr; /* -i d / 2 */
    float tr, ti;
    CMUL(tr, ti, wn[2 * k], wn[2 * k + 1], or_, oi);
    const size_t o = row * (size_t)hs + k;
    X[2 * o] = er + tr;
    X[2 * o + 1] = ei + ti;
}

/* The unpacking and packing below, written on explicit 16-wide vectors for M a multiple of 16:
 * PoCL leaves the one-element-per-work-item forms above scalar (the mirrored, interleaved
 * re / im loads defeat its work-group vectoriser), which made them cost 2-3x a radix-8 pass
 * for a quarter of its arithmetic. Each work-item handles 16 consecutive k: the mirrored run
 * M - k is one ascending load reversed in registers. Same arithmetic per element as the scalar
 * kernels, so the same bits. Launched over (M / 16, rows), exact. */
/* The unpacking of 16 bins: z = Z[k], m = Z[M - k] (not yet conjugated), w = W^k -> X[k]. */
inline void r2c_unpack16(float16 zr, float16 zi, float16 mr, float16 mi, float16 wr, float16 wi,
                         float16 *xr, float16 *xi)
{
    mi = -mi; /* m = conj */
    float16 er = 0.5f * (zr + mr), ei = 0.5f * (zi + mi);
    float16 dr = zr - mr, di = zi - mi;
    float16 or_ = 0.5f * di, oi = -0.5f * dr;
    float16 tr, ti;
    CMUL16(tr, ti, wr, wi, or_, oi);
    *xr = er + tr;
    *xi = ei + ti;
}
/* The packing of 16 bins: x = X[k], m = X[M - k] (not yet conjugated), w = W^k -> Z[k]. */
inline void c2r_pack16(float16 xr, float16 xi, float16 mr, float16 mi, float16 wr, float16 wi,
                       float16 *zr, float16 *zi)
{
    mi = -mi;
    float16 er = 0.5f * (xr + mr), ei = 0.5f * (xi + mi);
    float16 or_, oi;
    CMUL16(or_, oi, xr - mr, xi - mi, wr, -wi);
    *zr = er - 0.5f * oi;
    *zi = ei + 0.5f * or_;
}

/* csi_fft_r2c_post for k = 16 g .. 16 g + 15; the work-item of k = 0 then writes bins 0 and M
 * as csi_fft_r2c_edges does (the same arithmetic; one launch per unpacking instead of two, which
 * counts where the row stages run block by block). */
__kernel void csi_fft_r2c_post16(__global const float *restrict Z, __global float *restrict X,
                                 __global const float *restrict wn, const uint M_,
                                 const uint hs, const uint nrows)
{
    const size_t k0 = 16 * get_global_id(0), row = get_global_id(1), M = M_;
    float16 zr, zi, mr, mi, wr, wi;
    load16c(Z, row * M + k0, false, &zr, &zi);
    load16c(Z, row * M + M - k0 - 15, true, &mr, &mi);
    load16c(wn, k0, false, &wr, &wi);
    float16 xr, xi;
    r2c_unpack16(zr, zi, mr, mi, wr, wi, &xr, &xi);
    const size_t o = row * (size_t)hs;
    store16c(X, o + k0, xr, xi);
    if (k0 == 0) {
        const float z0r = Z[2 * row * M], z0i = Z[2 * row * M + 1];
        X[2 * o] = z0r + z0i;
        X[2 * o + 1] = 0.0f;
        X[2 * (o + M)] = z0r - z0i;
        X[2 * (o + M) + 1] = 0.0f;
    }
}

/* csi_fft_c2r_pre for k = 16 g .. 16 g + 15. */
__kernel void csi_fft_c2r_pre16(__global const float *restrict X, __global float *restrict Z,
                                __global const float *restrict wn, const uint M_, const uint hs,
                                const uint nrows)
{
    const size_t k0 = 16 * get_global_id(0), row = get_global_id(1), M = M_;
    const size_t xb = row * (size_t)hs;
    float16 xr, xi, mr, mi, wr, wi;
    load16c(X, xb + k0, false, &xr, &xi);
    load16c(X, xb + M - k0 - 15, true, &mr, &mi);
    load16c(wn, k0, false, &wr, &wi);
    float16 zr, zi;
    c2r_pack16(xr, xi, mr, mi, wr, wi, &zr, &zi);
    store16c(Z, row * M + k0, zr, zi);
}

/* X[0] = Re Z[0] + Im Z[0] and X[M] = Re Z[0] - Im Z[0] (the formula above at k = 0, M). */
__kernel void csi_fft_r2c_edges(__global const float *restrict Z, __global float *restrict X,
                                const uint M_, const uint hs, const uint nrows)
{
    const size_t row = get_global_id(0), M = M_;
    if (row >= nrows)
        return;
    float zr = Z[2 * row * M], zi = Z[2 * row * M + 1];
    const size_t o = row * (size_t)hs;
    X[2 * o] = zr + zi;
    X[2 * o + 1] = 0.0f;
    X[2 * (o + M)] = zr - zi;
    X[2 * (o + M) + 1] = 0.0f;
}

/* Complex-to-real packing, the inverse of the above for a Hermitian half spectrum X[0..M]:
 *     E[k] = (X[k] + conj X[M-k]) / 2,  O[k] = (X[k] - conj X[M-k]) conj(W^k) / 2,
 *     Z[k] = E[k] + i O[k],  k = 0 .. M-1;
 * an unnormalised inverse DFT_M of Z then gives M (y[2m] + i y[2m+1]) for y = IDFT_n(X) / n;
 * the host folds that factor into the gain. */
__kernel void csi_fft_c2r_pre(__global const float *restrict X, __global float *restrict Z,
                              __global const float *restrict wn, const uint M_, const uint hs,
                              const uint nrows)
{
    /* Exact launch over k < M, no bounds check (vectorised; M - k is a reversed load). */
    const size_t k = get_global_id(0), row = get_global_id(1), M = M_;
    const size_t xb = row * (size_t)hs;
    const size_t a = xb + k, b = xb + M - k;
    float xr = X[2 * a], xi = X[2 * a + 1], mr = X[2 * b], mi = -X[2 * b + 1];
    float er = 0.5f * (xr + mr), ei = 0.5f * (xi + mi);
    float or_, oi;
    CMUL(or_, oi, xr - mr, xi - mi, wn[2 * k], -wn[2 * k + 1]);
    const size_t o = row * M + k;
    Z[2 * o] = er - 0.5f * oi; /* E + i O */
    Z[2 * o + 1] = ei + 0.5f * or_;
}

/* ------------------------------------------------------------------------------------------ */
/* A filter's whole row stage in one launch, one work-item per row (csi_fft_rows_r2c: the passes
 * along x and the unpacking; csi_fft_rows_c2r: the packing and the passes back). Run block by
 * block (host/ops/fft_filter.c), a stage costs a launch per pass and block, and a launch's fixed
 * cost on PoCL is a sizeable share of a block's work (docs/bench/cost.md); here a row's
 * intermediate passes live in two __local rows of M + 1 complex values (in L1 / L2) and the stage
 * reads its input and writes its output once. For M whose plan is radix 8 first, then radices 4
 * and 8 (at least 3 of them: M a multiple of 128), then optionally radices 9, 3 and 5 (the host
 * checks; plan_radices gives radix 2 only where M has a single factor 2): the passes are
 * csi_fft_row1v_r* (p = 1), csi_fft_rowk8v_r* (p = 8) and the k-indexed form of csi_fft_rowk_r*
 * (p >= 16, a multiple of 16; csi_fft_rowkv_r9 for radix 9) on 16-wide vectors, then
 * csi_fft_r2c_post16, with the same arithmetic per element, so the same bits as the stages
 * launched pass by pass. The stages' writes to
 * memory (the forward one's spectrum rows, the inverse one's output rows) are store16nt's, and
 * their first pass asks for the next row's input ahead. plan[0] = the number of
 * passes, plan[1 + 2 j] = pass j's radix, plan[2 + 2 j] = its offset in the twiddles twp. */
inline void load16l(__local const float *restrict a, size_t e, bool rev, float16 *re, float16 *im)
{
    const float16 lo = *(__local const float16u *)(a + 2 * e);
    const float16 hi = *(__local const float16u *)(a + 2 * e + 16);
    *re = shuffle2(lo, hi, EVEN16);
    *im = shuffle2(lo, hi, ODD16);
    if (rev) {
        *re = shuffle(*re, REV16);
        *im = shuffle(*im, REV16);
    }
}
inline void store16l(__local float *restrict a, size_t e, float16 re, float16 im)
{
    *(__local float16u *)(a + 2 * e) = shuffle2(re, im, ILV_LO16);
    *(__local float16u *)(a + 2 * e + 16) = shuffle2(re, im, ILV_HI16);
}

/* The pass at p = 1 of a row of L values, in -> out (csi_fft_row1v_r* without its scale, which
 * the filter's stages set to 1: exact), for input address space AS (LD: load16c or load16l).
 * A stage reads each row from memory once, and the first pass waits for it: the pass also asks
 * for the pfn floats at pf (the stage's next row, NULL for none; a work-item's next row is most
 * often the next one this core runs) a slice per iteration, one cache line at a time. */
#define ROW_FIRST_R(R, LOG2_2R, LD)                                                             \
    for (size_t i0 = 0; i0 < T; i0 += 16) {                                                    \
        if (pf) {                                                                              \
            const size_t it_ = i0 / 16, nit_ = T / 16, end_ = (it_ + 1) * pfn / nit_;          \
            for (size_t q_ = (it_ * pfn / nit_) & ~(size_t)15; q_ < end_; q_ += 16)            \
                __builtin_prefetch(pf + q_);                                                   \
        }                                                                                      \
        float16 xr[R], xi[R], v[2 * R];                                                        \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            LD(in, i0 + (size_t)r * T, false, &xr[r], &xi[r]);                                 \
        dft##R##_v16(xr, xi, sgn);                                                             \
        ROW1_TRANSPOSE(R, LOG2_2R)                                                             \
        __local float *o = out + 2 * (i0 * R);                                                 \
        _Pragma("unroll") for (int q = 0; q < 2 * R; q++)                                      \
            *(__local float16u *)(o + 16 * q) = v[q];                                          \
    }
#define ROW_FIRST(AS, S, LD)                                                                    \
    inline void row_first_##S(AS const float *restrict in, __local float *restrict out, int R,  \
                              size_t L, float sgn, __global const float *pf, size_t pfn)       \
    {                                                                                          \
        const size_t T = L / (size_t)R;                                                        \
        if (R == 8) {                                                                          \
            ROW_FIRST_R(8, 4, LD)                                                              \
        } else {                                                                               \
            ROW_FIRST_R(4, 3, LD)                                                              \
        }                                                                                      \
    }
ROW_FIRST(__global, g, load16c)
ROW_FIRST(__local, l, load16l)

/* The pass at p = 8, __local -> __local (csi_fft_rowk8v_r*). */
#define ROW_P8_R(R)                                                                             \
    for (size_t i0 = 0; i0 < T; i0 += 16) {                                                    \
        float16 xr[R], xi[R];                                                                  \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            load16l(in, i0 + (size_t)r * T, false, &xr[r], &xi[r]);                           \
        _Pragma("unroll") for (int r = 1; r < R; r++) {                                        \
            const float16 t = *(__global const float16u *)(twp + 2 * ((size_t)twoff + (r - 1) * p)); \
            CMUL16(xr[r], xi[r], xr[r], xi[r], shuffle(t, DUP8_RE), -sgn * shuffle(t, DUP8_IM)); \
        }                                                                                      \
        dft##R##_v16(xr, xi, sgn);                                                             \
        __local float *o = out + 2 * ((i0 / p) * p * R);                                       \
        _Pragma("unroll") for (int r = 0; r < R; r++) {                                        \
            *(__local float16u *)(o + 2 * r * p) = shuffle2(xr[r], xi[r], ILV_LO16);           \
            *(__local float16u *)(o + 2 * (p * R + r * p)) = shuffle2(xr[r], xi[r], ILV_HI16); \
        }                                                                                      \
    }
inline void row_p8(__local const float *restrict in, __local float *restrict out,
                   __global const float *restrict twp, size_t twoff, int R, size_t L, float sgn)
{
    const size_t T = L / (size_t)R, p = 8;
    if (R == 8) {
        ROW_P8_R(8)
    } else {
        ROW_P8_R(4)
    }
}

/* A pass at p >= 16 (a multiple of 16), 16 consecutive k at a time (csi_fft_rowk_r*'s arithmetic,
 * csi_fft_rowkv_r9's for radix 9), into output address space AS (ST: store16c or store16l). */
#define ROW_PK_R(R, ST)                                                                         \
    for (size_t g = 0; g < T / p; g++)                                                         \
        for (size_t k = 0; k < p; k += 16) {                                                   \
            const size_t i = g * p + k;                                                        \
            float16 xr[R], xi[R];                                                              \
            _Pragma("unroll") for (int r = 0; r < R; r++)                                      \
                load16l(in, i + (size_t)r * T, false, &xr[r], &xi[r]);                         \
            _Pragma("unroll") for (int r = 1; r < R; r++) {                                    \
                float16 wr, wi;                                                                \
                load16c(twp, twoff + (size_t)(r - 1) * p + k, false, &wr, &wi);                \
                CMUL16(xr[r], xi[r], xr[r], xi[r], wr, -sgn * wi);                             \
            }                                                                                  \
            dft##R##_v16(xr, xi, sgn);                                                         \
            _Pragma("unroll") for (int r = 0; r < R; r++)                                      \
                ST(out, g * p * R + k + (size_t)r * p, xr[r], xi[r]);                          \
        }
#define ROW_PK(AS, S, ST)                                                                       \
    inline void row_pk_##S(__local const float *restrict in, AS float *restrict out,           \
                           __global const float *restrict twp, size_t twoff, int R, size_t L,  \
                           size_t p, float sgn)                                                \
    {                                                                                          \
        const size_t T = L / (size_t)R;                                                        \
        switch (R) {                                                                           \
        case 8:                                                                                \
            ROW_PK_R(8, ST)                                                                    \
            break;                                                                             \
        case 4:                                                                                \
            ROW_PK_R(4, ST)                                                                    \
            break;                                                                             \
        case 3:                                                                                \
            ROW_PK_R(3, ST)                                                                    \
            break;                                                                             \
        case 5:                                                                                \
            ROW_PK_R(5, ST)                                                                    \
            break;                                                                             \
        default:                                                                               \
            ROW_PK_R(9, ST)                                                                    \
        }                                                                                      \
    }
ROW_PK(__global, g, store16nt)
ROW_PK(__local, l, store16l)

/* Passes 1 .. np - 1 of a row from *a through b (ping-pong); the last one writes `last` when it
 * is not NULL, else the result is left in *a. */
inline void row_rest(__local float **a, __local float **b, __global float *restrict last,
                     __global const uint *restrict plan, __global const float *restrict twp,
                     size_t L, float sgn)
{
    const uint np = plan[0];
    size_t p = plan[1];
    for (uint j = 1; j < np; j++) {
        const int R = (int)plan[1 + 2 * j];
        const size_t twoff = plan[2 + 2 * j];
        if (p == 8)
            row_p8(*a, *b, twp, twoff, R, L, sgn);
        else if (last && j == np - 1)
            row_pk_g(*a, last, twp, twoff, R, L, p, sgn);
        else
            row_pk_l(*a, *b, twp, twoff, R, L, p, sgn);
        __local float *t = *a;
        *a = *b;
        *b = t;
        p *= (size_t)R;
    }
}

/* The unpacking or packing (OP: r2c_unpack16, c2r_pack16) of a row of M bins, 16 at a time: bins
 * k and M - k of `in` (loaded by LD) with W^k -> bin k of `out` (stored by ST). */
#define MIRRORED_BINS16(LD, in, OP, ST, out)                                                    \
    for (size_t k0 = 0; k0 < M; k0 += 16) {                                                    \
        float16 ar, ai, mr, mi, wr, wi, yr, yi;                                                \
        LD(in, k0, false, &ar, &ai);                                                           \
        LD(in, M - k0 - 15, true, &mr, &mi);                                                   \
        load16c(wn, k0, false, &wr, &wi);                                                      \
        OP(ar, ai, mr, mi, wr, wi, &yr, &yi);                                                  \
        ST(out, k0, yr, yi);                                                                   \
    }
/* The two stage kernels' parameters: A and B are the row's two __local rows. */
#define ROWS_STAGE_PARAMS(IN, OUT)                                                              \
    __global const float *restrict IN, __global float *restrict OUT,                           \
        __global const float *restrict twp, __global const float *restrict wn,                 \
        __global const uint *restrict plan, const uint M_, const uint hs, __local float *A,    \
        __local float *B

/* Forward: row `row` of the real input (M complex values) -> its half spectrum row in X (hs
 * values a row). A and B hold M + 1 complex values each: the unpacking's mirrored load at k = 0
 * reads element M (its lane is then overwritten by bins 0 and M, as in csi_fft_r2c_post16). */
__kernel void csi_fft_rows_r2c(ROWS_STAGE_PARAMS(in, X))
{
    const size_t row = get_global_id(0), M = M_;
    __local float *a = A, *b = B;
    A[2 * M] = A[2 * M + 1] = B[2 * M] = B[2 * M + 1] = 0.0f;
    const bool next = row + 1 < get_global_size(0);
    row_first_g(in + 2 * row * M, b, (int)plan[1], M, -1.0f, next ? in + 2 * (row + 1) * M : NULL, 2 * M);
    row_rest(&b, &a, NULL, plan, twp, M, -1.0f);
    /* csi_fft_r2c_post16 on the row in b */
    __global float *Xr = X + 2 * row * (size_t)hs;
    MIRRORED_BINS16(load16l, b, r2c_unpack16, store16nt, Xr)
    NT_STORES_DONE();
    const float z0r = b[0], z0i = b[1];
    Xr[0] = z0r + z0i;
    Xr[1] = 0.0f;
    Xr[2 * M] = z0r - z0i;
    Xr[2 * M + 1] = 0.0f;
}

/* Inverse: the half spectrum row `row` of X -> the real output row (M complex values). */
__kernel void csi_fft_rows_c2r(ROWS_STAGE_PARAMS(X, out))
{
    const size_t row = get_global_id(0), M = M_;
    __local float *a = A, *b = B;
    /* csi_fft_c2r_pre16 into a */
    __global const float *Xr = X + 2 * row * (size_t)hs;
    MIRRORED_BINS16(load16c, Xr, c2r_pack16, store16l, a)
    const bool next = row + 1 < get_global_size(0);
    row_first_l(a, b, (int)plan[1], M, 1.0f, next ? Xr + 2 * (size_t)hs : NULL, 2 * (M + 1));
    row_rest(&b, &a, out + 2 * row * M, plan, twp, M, 1.0f);
    NT_STORES_DONE();
}

/* ------------------------------------------------------------------------------------------ */
/* A 2-D filter's whole column stage in one launch (csi_fft_cols_2d): the forward passes along y,
 * the gain pass (the first inverse one) and the inverse passes along y, on a strip of 8 adjacent
 * columns per work-item, one work-item per work-group. Launched pass by pass, each of the stage's
 * passes reads and writes the whole spectrum (71 MB at a 1920x1080 tile), which has long left the
 * caches when the next pass reads it; here the strip's L values (64 bytes a row) live in two
 * __local volumes of L x 8 complex values (the core's L2), so the stage reads the spectrum once
 * and writes it once. 8 columns, not the 16 of csi_fft_col1v_r*: one row of the strip is then one
 * cache line, and the volumes fit local memory at twice the rows; where three 8-column volumes
 * fit, csi_fft_cols_2d_pair takes two adjacent strips and runs their first and last passes
 * together. The passes are csi_fft_col_r* / col1v_r* / col_gain_r* / col_cgain_r* on 8 lanes:
 * the same arithmetic per element, so the same bits as the passes launched one by one. Local
 * layout: row q of the strip at v[2 q] (its 8 real parts) and v[2 q + 1] (imaginary parts).
 * plan[0] = the number of passes per direction (>= 2), plan[1 + j] = pass j's radix (2, 3, 4,
 * 5, 8 or 9; the host checks). */
#define EVEN8 (uint8)(0, 2, 4, 6, 8, 10, 12, 14)
#define ODD8 (uint8)(1, 3, 5, 7, 9, 11, 13, 15)
#define ILV8 (uint16)(0, 8, 1, 9, 2, 10, 3, 11, 4, 12, 5, 13, 6, 14, 7, 15)
#define CMUL8(tr, ti, ar, ai, br, bi) CMUL_T(float8, tr, ti, ar, ai, br, bi)
/* row q of the strip at column c0 of a spectrum of rows of hs values (global, interleaved), or
 * of a __local strip */
#define COLS_LD_G(a, q, re, im)                                                                 \
    {                                                                                          \
        const float16 v_ = *(__global const float16 *)(a + 2 * ((q) * hs + c0));               \
        re = shuffle(v_, EVEN8);                                                               \
        im = shuffle(v_, ODD8);                                                                \
    }
#define COLS_ST_G(a, q, re, im)                                                                 \
    *(__global float16 *)(a + 2 * ((q) * hs + c0)) = shuffle2(re, im, ILV8);
#define COLS_LD_L(a, q, re, im)                                                                 \
    {                                                                                          \
        re = a[2 * (q)];                                                                       \
        im = a[2 * (q) + 1];                                                                   \
    }
#define COLS_ST_L(a, q, re, im)                                                                 \
    {                                                                                          \
        a[2 * (q)] = re;                                                                       \
        a[2 * (q) + 1] = im;                                                                   \
    }
/* One radix-R pass at p over the strip, in -> out (address spaces IAS / OAS; PF: the prefetch). */
#define COLS_PASS_R(NAME, R, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                               \
    inline void NAME##_r##R(IAS const ITYPE *restrict in, OAS OTYPE *restrict out,             \
                            __global const float *restrict tw, size_t c0, size_t hs, size_t L,  \
                            size_t p, float sgn)                                               \
    {                                                                                          \
        const size_t T = L / R, ts = L / (p * R);                                              \
        for (size_t i = 0; i < T; i++) {                                                       \
            float8 xr[R], xi[R];                                                               \
            _Pragma("unroll") for (int r = 0; r < R; r++) {                                    \
                LD(in, i + (size_t)r * T, xr[r], xi[r])                                        \
                PF(in, i + 16 + (size_t)r * T);                                                \
            }                                                                                  \
            PASS_TWIDDLES(R, CMUL8)                                                            \
            dft##R##_v8(xr, xi, sgn);                                                          \
            const size_t j = (i - k) * R + k;                                                  \
            _Pragma("unroll") for (int r = 0; r < R; r++)                                      \
                ST(out, j + (size_t)r * p, xr[r], xi[r])                                       \
        }                                                                                      \
    }
#define COLS_PASS(NAME, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                    \
    COLS_PASS_R(NAME, 2, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    COLS_PASS_R(NAME, 3, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    COLS_PASS_R(NAME, 4, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    COLS_PASS_R(NAME, 5, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    COLS_PASS_R(NAME, 8, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    COLS_PASS_R(NAME, 9, IAS, ITYPE, LD, OAS, OTYPE, ST, PF)                                   \
    inline void NAME(IAS const ITYPE *restrict in, OAS OTYPE *restrict out,                    \
                     __global const float *restrict tw, size_t c0, size_t hs, size_t L, int R,  \
                     size_t p, float sgn)                                                      \
    {                                                                                          \
        switch (R) {                                                                           \
        case 2: NAME##_r2(in, out, tw, c0, hs, L, p, sgn); break;                              \
        case 3: NAME##_r3(in, out, tw, c0, hs, L, p, sgn); break;                              \
        case 4: NAME##_r4(in, out, tw, c0, hs, L, p, sgn); break;                              \
        case 5: NAME##_r5(in, out, tw, c0, hs, L, p, sgn); break;                              \
        case 8: NAME##_r8(in, out, tw, c0, hs, L, p, sgn); break;                              \
        default: NAME##_r9(in, out, tw, c0, hs, L, p, sgn); break;                             \
        }                                                                                      \
    }
/* The first pass reads the spectrum a row (one cache line) per element, each row in another page,
 * and the hardware prefetchers stay within a page: it asks for the rows 16 butterflies ahead. */
#define COLS_PF_G(a, q) __builtin_prefetch(a + 2 * ((q) * hs + c0))
#define COLS_PF_L(a, q)
COLS_PASS(cols_pass_gl, __global, float, COLS_LD_G, __local, float8, COLS_ST_L, COLS_PF_G)
/* The first pass (p = 1) of two adjacent strips at c0 and c0 + 8 together, in -> out0 and out1:
 * a row of the two is the 128 bytes of an adjacent-line pair, so each visit to a row's page reads
 * both lines, where two strips run one after the other walk the 4320 pages twice (by then the
 * second lines have left the caches and the translations the TLB). The second strip's butterfly
 * reads the lines the first one's has just brought in. Each strip's arithmetic is cols_pass_gl's. */
#define COLS_FIRST_PAIR_R(R)                                                                    \
    inline void cols_first_pair_r##R(__global const float *restrict in,                        \
                                     __local float8 *restrict out0,                            \
                                     __local float8 *restrict out1, size_t c0, size_t hs,      \
                                     size_t L, float sgn)                                      \
    {                                                                                          \
        const size_t T = L / R;                                                                \
        for (size_t i = 0; i < T; i++) {                                                       \
            {                                                                                  \
                float8 xr[R], xi[R];                                                           \
                _Pragma("unroll") for (int r = 0; r < R; r++) {                                \
                    COLS_LD_G(in, i + (size_t)r * T, xr[r], xi[r])                             \
                    COLS_PF_G(in, i + 16 + (size_t)r * T);                                     \
                    __builtin_prefetch(in + 2 * ((i + 16 + (size_t)r * T) * hs + c0) + 16);    \
                }                                                                              \
                dft##R##_v8(xr, xi, sgn);                                                      \
                _Pragma("unroll") for (int r = 0; r < R; r++)                                  \
                    COLS_ST_L(out0, i * R + (size_t)r, xr[r], xi[r])                           \
            }                                                                                  \
            {                                                                                  \
                const size_t c1 = c0 + 8;                                                      \
                float8 xr[R], xi[R];                                                           \
                _Pragma("unroll") for (int r = 0; r < R; r++) {                                \
                    const float16 v_ =                                                         \
                        *(__global const float16 *)(in + 2 * ((i + (size_t)r * T) * hs + c1)); \
                    xr[r] = shuffle(v_, EVEN8);                                                \
                    xi[r] = shuffle(v_, ODD8);                                                 \
                }                                                                              \
                dft##R##_v8(xr, xi, sgn);                                                      \
                _Pragma("unroll") for (int r = 0; r < R; r++)                                  \
                    COLS_ST_L(out1, i * R + (size_t)r, xr[r], xi[r])                           \
            }                                                                                  \
        }                                                                                      \
    }
COLS_FIRST_PAIR_R(2)
COLS_FIRST_PAIR_R(3)
COLS_FIRST_PAIR_R(4)
COLS_FIRST_PAIR_R(5)
COLS_FIRST_PAIR_R(8)
COLS_FIRST_PAIR_R(9)
/* The last inverse pass (at p) of the two strips together, in0 and in1 -> out's columns c0 ..
 * c0 + 15: each row's two lines written in one visit to its page. cols_pass_lg's arithmetic. */
#define COLS_LAST_PAIR_STRIP(R, IN, C)                                                          \
    {                                                                                          \
        float8 xr[R], xi[R];                                                                   \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            COLS_LD_L(IN, i + (size_t)r * T, xr[r], xi[r])                                     \
        PASS_TWIDDLES(R, CMUL8)                                                                \
        dft##R##_v8(xr, xi, sgn);                                                              \
        const size_t j = (i - k) * R + k;                                                      \
        _Pragma("unroll") for (int r = 0; r < R; r++)                                          \
            *(__global float16 *)(out + 2 * ((j + (size_t)r * p) * hs + (C))) =                 \
                shuffle2(xr[r], xi[r], ILV8);                                                  \
    }
#define COLS_LAST_PAIR_R(R)                                                                     \
    inline void cols_last_pair_r##R(__local const float8 *restrict in0,                        \
                                    __local const float8 *restrict in1, __global float *out,   \
                                    __global const float *restrict tw, size_t c0, size_t hs,   \
                                    size_t L, size_t p, float sgn)                             \
    {                                                                                          \
        const size_t T = L / R, ts = L / (p * R);                                              \
        for (size_t i = 0; i < T; i++) {                                                       \
            COLS_LAST_PAIR_STRIP(R, in0, c0)                                                   \
            COLS_LAST_PAIR_STRIP(R, in1, c0 + 8)                                               \
        }                                                                                      \
    }
COLS_LAST_PAIR_R(2)
COLS_LAST_PAIR_R(3)
COLS_LAST_PAIR_R(4)
COLS_LAST_PAIR_R(5)
COLS_LAST_PAIR_R(8)
COLS_LAST_PAIR_R(9)
COLS_PASS(cols_pass_ll, __local, float8, COLS_LD_L, __local, float8, COLS_ST_L, COLS_PF_L)
COLS_PASS(cols_pass_lg, __local, float8, COLS_LD_L, __global, float, COLS_ST_G, COLS_PF_L)

/* The gain pass (p = 1, the first inverse pass), __local -> __local: the gain of
 * csi_fft_col_gain_r* (cplx = 0: inputs times the real gain) or csi_fft_col_cgain_r* (times the
 * gain and the complex factor fc[c] fa[q], conjugated when csgn = -1), as GAIN_AT_T computes it. */
#define COLS_GAIN_R(R)                                                                          \
    inline void cols_gain_r##R(__local const float8 *restrict in, __local float8 *restrict out, \
                               size_t L, float8 gcb, __global const float *restrict ga,       \
                               uint wiener, float lambda, float scale, uint cplx, float8 fcr,  \
                               float8 fci, __global const float *restrict fa, float csgn,     \
                               float sgn)                                                      \
    {                                                                                          \
        const size_t T = L / R;                                                                \
        for (size_t i = 0; i < T; i++) {                                                       \
            float8 xr[R], xi[R];                                                               \
            _Pragma("unroll") for (int r = 0; r < R; r++) {                                    \
                const size_t q_ = i + (size_t)r * T;                                           \
                GAIN_AT_T(float8, q_)                                                          \
                float8 ur, ui;                                                                 \
                COLS_LD_L(in, q_, ur, ui)                                                      \
                if (cplx) {                                                                    \
                    float8 er, ei;                                                             \
                    CMUL8(er, ei, fcr, fci, fa[2 * q_], csgn * fa[2 * q_ + 1]);                \
                    CMUL8(xr[r], xi[r], ur, ui, g * er, g * ei);                               \
                } else {                                                                       \
                    xr[r] = ur * g;                                                            \
                    xi[r] = ui * g;                                                            \
                }                                                                              \
            }                                                                                  \
            dft##R##_v8(xr, xi, sgn);                                                          \
            _Pragma("unroll") for (int r = 0; r < R; r++)                                      \
                COLS_ST_L(out, i * R + (size_t)r, xr[r], xi[r])                                \
        }                                                                                      \
    }
COLS_GAIN_R(2)
COLS_GAIN_R(3)
COLS_GAIN_R(4)
COLS_GAIN_R(5)
COLS_GAIN_R(8)
COLS_GAIN_R(9)

/* One strip's stage between its first and last passes (the first's output in a): the other
 * forward passes, the gain pass, the inverse passes but the last. a and b: L x 8 complex values
 * each; returns the one that holds the result (the other is free). The gain is gx[c] ga[q]
 * (Gaussian or Wiener, times scale) as in csi_fft_col_gain_r*, with the complex factor when
 * cplx != 0. */
inline __local float8 *cols_strip_mid(__local float8 *a, __local float8 *b,
                                      __global const float *restrict tw,
                                      __global const uint *restrict plan, size_t c0, size_t L,
                                      size_t hs, __global const float *restrict gx,
                                      __global const float *restrict ga, uint wiener,
                                      float lambda, float scale, uint cplx,
                                      __global const float *restrict fc,
                                      __global const float *restrict fa, float csgn)
{
    const uint np = plan[0];
    __local float8 *t;
    /* forward: a -> b (swapped after each pass) */
    size_t p = plan[1];
    for (uint j = 1; j < np; j++) {
        cols_pass_ll(a, b, tw, c0, hs, L, (int)plan[1 + j], p, -1.0f);
        t = a, a = b, b = t;
        p *= plan[1 + j];
    }
    /* inverse: the gain pass at p = 1 */
    const float8 gcb = *(__global const float8 *)(gx + c0);
    float8 fcr = 0.0f, fci = 0.0f;
    if (cplx) {
        const float16 v = *(__global const float16 *)(fc + 2 * c0);
        fcr = shuffle(v, EVEN8);
        fci = csgn * shuffle(v, ODD8);
    }
#define COLS_GAIN_CASE(R)                                                                       \
    case R:                                                                                    \
        cols_gain_r##R(a, b, L, gcb, ga, wiener, lambda, scale, cplx, fcr, fci, fa, csgn, 1.0f); \
        break;
    switch (plan[1]) {
    COLS_GAIN_CASE(2)
    COLS_GAIN_CASE(3)
    COLS_GAIN_CASE(4)
    COLS_GAIN_CASE(5)
    COLS_GAIN_CASE(8)
    COLS_GAIN_CASE(9)
    }
    t = a, a = b, b = t;
    p = plan[1];
    for (uint j = 1; j + 1 < np; j++) {
        cols_pass_ll(a, b, tw, c0, hs, L, (int)plan[1 + j], p, 1.0f);
        t = a, a = b, b = t;
        p *= plan[1 + j];
    }
    return a;
}

/* The last inverse pass's p: the product of the radices before it. */
inline size_t cols_last_p(__global const uint *restrict plan)
{
    size_t p = 1;
    for (uint j = 0; j + 1 < plan[0]; j++)
        p *= plan[1 + j];
    return p;
}

#define COLS_2D_PARAMS                                                                          \
    __global const float *in, __global float *out, __global const float *restrict tw,          \
        __global const uint *restrict plan, const uint L_, const uint hs_,                      \
        __global const float *restrict gx, __global const float *restrict ga, const uint wiener, \
        const float lambda, const float scale, const uint cplx, __global const float *restrict fc, \
        __global const float *restrict fa, const float csgn
#define COLS_MID(a, b, c0)                                                                      \
    cols_strip_mid(a, b, tw, plan, c0, L, hs, gx, ga, wiener, lambda, scale, cplx, fc, fa, csgn)

/* Spectrum in -> out (rows of hs values, L rows), strip of columns 8 get_global_id(0) .. + 7.
 * in and out may be the same buffer (not restrict): a work-item reads its whole strip in the first
 * pass before its last pass writes it, and the strips are disjoint. In place, the last pass writes
 * rows the first one brought into the caches, where a second volume would first be read from
 * memory for its writes. A and B: L x 8 complex values each. */
__kernel void csi_fft_cols_2d(COLS_2D_PARAMS, __local float8 *A, __local float8 *B)
{
    const size_t c0 = 8 * get_global_id(0), L = L_, hs = hs_;
    cols_pass_gl(in, A, tw, c0, hs, L, (int)plan[1], 1, -1.0f);
    cols_pass_lg(COLS_MID(A, B, c0), out, tw, c0, hs, L, (int)plan[plan[0]], cols_last_p(plan), 1.0f);
}

/* csi_fft_cols_2d on two adjacent strips per work-item, columns 16 get_global_id(0) .. + 15 (hs
 * a multiple of 16): their first passes together (cols_first_pair_r*, into A and C), the passes
 * between of one strip and then of the other (A's with B as scratch, C's with whichever of A
 * and B the first left free), their last passes together (cols_last_pair_r*), so the stage
 * visits each row's page once to read and once to write its 128 bytes. In place as
 * csi_fft_cols_2d: both strips are read before either is written. A, B, C: L x 8 complex values
 * each. The same arithmetic per element, so the same bits. */
__kernel void csi_fft_cols_2d_pair(COLS_2D_PARAMS, __local float8 *A, __local float8 *B,
                                   __local float8 *C)
{
    const size_t c0 = 16 * get_global_id(0), L = L_, hs = hs_;
    switch (plan[1]) {
    case 2: cols_first_pair_r2(in, A, C, c0, hs, L, -1.0f); break;
    case 3: cols_first_pair_r3(in, A, C, c0, hs, L, -1.0f); break;
    case 4: cols_first_pair_r4(in, A, C, c0, hs, L, -1.0f); break;
    case 5: cols_first_pair_r5(in, A, C, c0, hs, L, -1.0f); break;
    case 8: cols_first_pair_r8(in, A, C, c0, hs, L, -1.0f); break;
    default: cols_first_pair_r9(in, A, C, c0, hs, L, -1.0f); break;
    }
    __local float8 *a = COLS_MID(A, B, c0), *spare = a == A ? B : A;
    __local float8 *b = COLS_MID(C, spare, c0 + 8);
    const size_t p = cols_last_p(plan);
    switch (plan[plan[0]]) {
    case 2: cols_last_pair_r2(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    case 3: cols_last_pair_r3(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    case 4: cols_last_pair_r4(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    case 5: cols_last_pair_r5(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    case 8: cols_last_pair_r8(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    default: cols_last_pair_r9(a, b, out, tw, c0, hs, L, p, 1.0f); break;
    }
}

/* Gain on a half spectrum of rows of hs values (1-D filters, which have no column pass to fuse
 * the gain into): X[row, k] *= scale * gain(gx[k] gr[row]). */
__kernel void csi_fft_gain_rows(__global float *restrict X, __global const float *restrict gx,
                                __global const float *restrict gr, const uint h0,
                                const uint hs, const uint nrows, const uint wiener,
                                const float lambda, const float scale)
{
    const size_t k = get_global_id(0), row = get_global_id(1);
    if (k >= h0 || row >= nrows)
        return;
    float g = gx[k] * gr[row];
    if (wiener)
        g = (1.0f + lambda) * g / (g * g + lambda);
    const size_t o = row * (size_t)hs + k;
    X[2 * o] *= g * scale;
    X[2 * o + 1] *= g * scale;
}

/* Zero the padding columns M+1 .. hs-1 of every half-spectrum row (they are scratch in the
 * filter, but the half-spectrum Fourier basis hands its coefficients to the solver, so they
 * must hold exact zeros). Launched over (hs - M - 1, nrows) with a bounds check. */
__kernel void csi_fft_zero_pad(__global float *restrict X, const uint M_, const uint hs,
                               const uint nrows, const uint npad)
{
    const size_t j = get_global_id(0), row = get_global_id(1);
    if (j >= npad || row >= nrows)
        return;
    const size_t o = row * (size_t)hs + M_ + 1 + j;
    X[2 * o] = 0.0f;
    X[2 * o + 1] = 0.0f;
}

/* The packing step of the half-spectrum synthesis f = Re(sum over u0 = 0..M of R[u0]
 * exp(+2 pi i u0 x / n)) (the real adjoint of the real-to-complex transform; see
 * csi_fourier_half in host/ops/fft_filter.c). It is csi_fft_c2r_pre applied to X' = scale *
 * (2 Re R[0], R[1], ..., R[M-1], 2 Re R[M]): the complex-to-real inverse of a Hermitian
 * spectrum X' gives (X'[0] + X'[M] (-1)^x) / 2 + Re sum_mid X'[u] e^(...), so doubling the real
 * parts of the two self-conjugate bins and dropping their imaginary parts gives exactly the sum
 * above. */
__kernel void csi_fft_c2r_pre_half(__global const float *restrict X, __global float *restrict Z,
                                   __global const float *restrict wn, const uint M_,
                                   const uint hs, const uint nrows, const float scale)
{
    const size_t k = get_global_id(0), row = get_global_id(1), M = M_;
    const size_t xb = row * (size_t)hs;
    const size_t a = xb + k, b = xb + M - k;
    const bool edge = k == 0;
    float xr = X[2 * a], xi = X[2 * a + 1], mr = X[2 * b], mi = -X[2 * b + 1];
    const float fe = edge ? 2.0f * scale : scale;
    xr *= fe;
    mr *= fe;
    xi = edge ? 0.0f : xi * scale;
    mi = edge ? 0.0f : mi * scale;
    float er = 0.5f * (xr + mr), ei = 0.5f * (xi + mi);
    float or_, oi;
    CMUL(or_, oi, xr - mr, xi - mi, wn[2 * k], -wn[2 * k + 1]);
    const size_t o = row * M + k;
    Z[2 * o] = er - 0.5f * oi;
    Z[2 * o + 1] = ei + 0.5f * or_;
}

/* ------------------------------------------------------------------------------------------ */
/* The time stage of Alg. 2's motion basis (csi_fourier_half_set_motion in csi/spectral.h): on a
 * half spectrum already transformed along the spatial axes, a shear (each frame's spectrum
 * multiplied by the phase of a shift by v (t - tc)) and a transform along t (the column passes
 * above, or a DCT-II built on them by Makhoul's reordering: J. Makhoul, "A fast cosine transform
 * in one and two dimensions", IEEE Trans. ASSP 28(1), 1980).
 *
 * Layout: element (u0, u1, t) at u0 + hs (u1 + n1 t); launches are exact over (hs, n1, T) with a
 * local size dividing hs, so no bounds checks (PoCL vectorises along u0). Phase tables are
 * separable, px[t hs + u0] and py[t n1 + u1], computed in double on the host. */

/* Makhoul's order for a DCT-II of length T: v[n] = x[perm(n)], perm(n) = 2n for n < ceil(T/2),
 * else 2 (T - 1 - n) + 1 (the even samples ascending, then the odd ones descending). */
inline size_t makhoul_perm(size_t n, size_t T) { return n < (T + 1) / 2 ? 2 * n : 2 * (T - 1 - n) + 1; }
/* Its inverse: the position n of sample t in v. */
inline size_t makhoul_iperm(size_t t, size_t T) { return (t & 1) ? T - 1 - (t >> 1) : t >> 1; }

/* The shear pass. Analysis (synth = 0): out[u, j] = conj(P[t, u]) in[u, t] with t = perm(j) when
 * `reorder` (the DCT's input order), else t = j. Synthesis (synth = 1, the adjoint):
 * out[u, t] = P[t, u] in[u, n] with n = iperm(t) when `reorder`, else n = t (here t = j).
 * P[t, u] = px[t, u0] py[t, u1]. */
__kernel void csi_motion_phase(__global const float *restrict in, __global float *restrict out,
                               __global const float *restrict px, __global const float *restrict py,
                               const uint hs_, const uint n1_, const uint T_, const uint reorder,
                               const uint synth)
{
    const size_t u0 = get_global_id(0), u1 = get_global_id(1), j = get_global_id(2);
    const size_t hs = hs_, n1 = n1_, T = T_;
    size_t t = j, src = j;
    if (reorder && !synth)
        t = src = makhoul_perm(j, T);
    else if (reorder)
        src = makhoul_iperm(j, T);
    const size_t a = t * hs + u0, b = t * n1 + u1;
    float pr, pi;
    CMUL(pr, pi, px[2 * a], px[2 * a + 1], py[2 * b], py[2 * b + 1]);
    if (!synth)
        pi = -pi;
    const size_t s = u0 + hs * (u1 + n1 * src), d = u0 + hs * (u1 + n1 * j);
    float zr, zi;
    CMUL(zr, zi, in[2 * s], in[2 * s + 1], pr, pi);
    out[2 * d] = zr;
    out[2 * d + 1] = zi;
}

/* Makhoul's twiddle step along t: out[u, k] = A[k] in[u, k] + B[k] in[u, (T - k) mod T], with
 * complex tables A, B of T entries. Forward (after the DFT of the reordered samples):
 * A = e_k exp(-i pi k / 2T), B = conj A (the DCT-II of a complex sequence, each part's real
 * formula extended linearly); inverse (before the inverse DFT): A = d_k exp(+i pi k / 2T),
 * B = -i d_(T-k) exp(+i pi k / 2T), B[0] = 0. The host folds the orthonormal scales into e, d. */
__kernel void csi_motion_tmix(__global const float *restrict in, __global float *restrict out,
                              __global const float *restrict A, __global const float *restrict B,
                              const uint hs_, const uint n1_, const uint T_)
{
    const size_t u0 = get_global_id(0), u1 = get_global_id(1), k = get_global_id(2);
    const size_t hs = hs_, n1 = n1_, T = T_;
    const size_t km = k == 0 ? 0 : T - k;
    const size_t p = u0 + hs * (u1 + n1 * k), q = u0 + hs * (u1 + n1 * km);
    float ar, ai, br, bi;
    CMUL(ar, ai, A[2 * k], A[2 * k + 1], in[2 * p], in[2 * p + 1]);
    CMUL(br, bi, B[2 * k], B[2 * k + 1], in[2 * q], in[2 * q + 1]);
    out[2 * p] = ar + br;
    out[2 * p + 1] = ai + bi;
}

/* A separable real gain on the coefficients, in place: X[u0, u1, k] *= g0[u0] g1[u1] gt[k]
 * (the motion Gaussian of csi_motion_filter: the Gaussian in the sheared frame). */
__kernel void csi_motion_gain(__global float *restrict X, __global const float *restrict g0,
                              __global const float *restrict g1, __global const float *restrict gt,
                              const uint hs_, const uint n1_)
{
    const size_t u0 = get_global_id(0), u1 = get_global_id(1), k = get_global_id(2);
    const size_t o = u0 + (size_t)hs_ * (u1 + (size_t)n1_ * k);
    const float g = g0[u0] * g1[u1] * gt[k];
    X[2 * o] *= g;
    X[2 * o + 1] *= g;
}
