/* FFT-domain operators: the Gaussian filter Phi, its Wiener inverse, and the orthonormal
 * Fourier basis (csi's own FFT kernels on the device, clFFT as reference and fallback).
 *
 * Sen & Darabi 2010, Sec. 4 and Alg. 1: Phi = F^H G F with G a Gaussian on the diagonal,
 * sigma_G = k / (2 pi sigma_Phi), sigma_Phi = 1.1 * (1/4) * sqrt(k/p); the inverse is a linear
 * Wiener filter G / (G^2 + lambda). Here everything is per axis: an axis of n samples that is
 * reduced from `grid` to `out` cells gets sigma_Phi = 1.1 * (1/4) * (grid/out) and
 * sigma_G = n / (2 pi sigma_Phi) in DFT-index units (the continuous Fourier pair
 * exp(-x^2 / 2 s^2) <-> exp(-2 pi^2 s^2 f^2) with f = u / n cycles per sample).
 *
 * Layout: a signal of dims[0] x dims[1] x dims[2] floats, x fastest (dims[2] = 1 for 2-D, and
 * dims[1] = dims[2] = 1 for 1-D). Every axis length must factor into 2, 3, 5 and 7 (clFFT's
 * radices); other sizes are refused with CSI_ERR_ARG naming the size. */
#ifndef CSI_SPECTRAL_H
#define CSI_SPECTRAL_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/gaussian.h" /* the filter's width and gain */
#include "csi/linop.h"
#include "csi/runtime.h"
#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum { CSI_FILTER_GAUSS, CSI_FILTER_WIENER } csi_filter_kind;

/* Real, self-adjoint operator on a real signal of dims[0] x dims[1] x dims[2] (rows = cols =
 * product; apply == adjoint).
 *   GAUSS:  Phi = F^H G F, G(u) = prod over axes exp(-u_a^2 / (2 sigma_G,a^2)), u_a the signed
 *           frequency index in [-n/2, n/2), sigma_G,a = n_a / (2 pi sigma_phi[a]).
 *   WIENER: Phi^-1 = F^H ((1 + lambda) G / (G^2 + lambda)) F. The (1 + lambda) factor makes the
 *           DC gain 1: as written in the paper the DC gain is 1 / (1 + lambda) and the image
 *           comes out (1 + lambda) times too bright (a prototype measured 1.3x at lambda = 0.3).
 *           lambda must be finite and > 0 (the largest gain is (1 + lambda) / (2 sqrt(lambda)),
 *           e.g. about 500 at lambda = 1e-6). For GAUSS lambda is ignored.
 * sigma_phi per axis: spatial standard deviation in grid cells; 0 on an axis = no filtering
 * along it; must be finite and >= 0. Real-to-complex / complex-to-real transforms: csi's own FFT
 * kernels where the size allows, else clFFT (plans baked here); see csi_filter_create_backend. */
csi_status csi_filter_create(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                             csi_filter_kind kind, float lambda, csi_linop **out);

/* Which FFT implementation a filter uses. AUTO (what csi_filter_create does): csi's own
 * Stockham kernels (kernels/fft.cl, written for CPU OpenCL; several times faster than clFFT on
 * PoCL) when the first axis longer than 1 has even length, else clFFT. CLFFT: always clFFT (the
 * reference the tests check the native kernels against). NATIVE: csi's kernels or CSI_ERR_ARG. */
typedef enum { CSI_FFT_AUTO, CSI_FFT_CLFFT, CSI_FFT_NATIVE } csi_fft_backend;
csi_status csi_filter_create_backend(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                                     csi_filter_kind kind, float lambda, csi_fft_backend backend,
                                     csi_linop **out);

/* A 2-D filter (dims[2] = 1, both other axes longer than 1) whose gain is that of
 * csi_filter_create times a separable complex factor fx[kx] fy[ky]: fx holds dims[0]/2 + 1
 * interleaved complex values for kx = 0 .. dims[0]/2 (the half spectrum of the real input), fy
 * dims[1] for ky in DFT order. For the output to be the real convolution the gain describes, the
 * factor must be Hermitian (fx[0] real, fy[dims[1] - ky] = conj fy[ky]) and real at the Nyquist
 * bins (zero there is the safe choice). apply filters with the factor, adjoint with its conjugate
 * (the transposed convolution). csi's FFT kernels only: dims[0] must be even and >= 4, with the
 * sizes csi_filter_create_backend(..., CSI_FFT_NATIVE, ...) accepts. */
csi_status csi_filter_create_factor(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                                    csi_filter_kind kind, float lambda, const double *fx,
                                    const double *fy, csi_linop **out);
/* The device buffers csi_filter_create_factor allocates (csi/runtime.h's tally). */
void csi_filter_factor_buffers(const size_t dims[3], csi_mem_tally *t);
/* Whether a filter over dims on csi's FFT kernels runs its row stages fused (one launch each, in
 * the device's local memory of local_mem bytes; 0: unknown, so not), the cheaper form per cell. */
bool csi_filter_rows_fused(const size_t dims[3], uint64_t local_mem);

/* Orthonormal Fourier basis over dims (1-D, 2-D or 3-D; complex operator, rows = cols =
 * product): apply = F^H (coefficients -> signal, unitary inverse DFT), adjoint = F (unitary
 * forward DFT, 1/sqrt(N) scaling), so apply(adjoint(x)) = x and both preserve the 2-norm.
 * Coefficient layout: numpy's fftn order (no shift): coefficient (u0, u1, u2) at
 * u0 + dims[0] * (u1 + dims[1] * u2), matching np.fft.fftn(a, norm="ortho") of an array of
 * shape (dims[2], dims[1], dims[0]). */
csi_status csi_fourier_create(csi_ctx *ctx, const size_t dims[3], csi_linop **out);

/* The device buffers csi_filter_create and csi_fourier_create (AUTO backend) allocate for a size
 * the create function accepts, added to a tally (csi/runtime.h). On clFFT's path its
 * intermediate buffers are known only once a plan is baked: their bound is counted. */
void csi_filter_buffers(const size_t dims[3], csi_mem_tally *t);
void csi_fourier_buffers(const size_t dims[3], csi_mem_tally *t);

/* The same basis on a chosen FFT implementation. AUTO (what csi_fourier_create does): csi's own
 * Stockham kernels (kernels/fft.cl; every size csi_fft_check_size accepts, below 2^32 points),
 * else clFFT. CLFFT: always clFFT (the reference the tests check the native path against).
 * NATIVE: csi's kernels or CSI_ERR_ARG. Device memory: the native path holds one scratch
 * volume (8 N bytes) besides small twiddle tables; clFFT whatever its plan asks for. */
csi_status csi_fourier_create_backend(csi_ctx *ctx, const size_t dims[3], csi_fft_backend backend,
                                      csi_linop **out);

/* The real Fourier basis on the half spectrum (csi's extension for Alg. 2: a real volume has a
 * Hermitian spectrum, so half the coefficients determine it; the solver then carries half the
 * unknowns and each transform does about half the work). With N = dims[0] dims[1] dims[2],
 * M = n0 / 2 and n0 the first axis longer than 1 (it must be even, >= 4, and M a product of 2, 3,
 * 5, 7; other axes products of 2, 3, 5, 7):
 *   forward: z[u] = N^-1/2 sum_x f[x] exp(-2 pi i <u, x / n>) for u0 = 0 .. M (numpy's
 *            rfftn(f, norm="ortho")), all u1, u2;
 *   inverse: f[x] = N^-1/2 Re sum_{u0 = 0..M} z[u] exp(+2 pi i <u, x / n>), the adjoint of
 *            forward for the real inner products <f, g> and Re <z, w>.
 * So for a Hermitian spectrum X of a real f (X = fftn(f, norm="ortho")), inverse(z) = f when
 * z = X on the planes u0 = 0 and u0 = M and z = 2 X in between, and ||z||_1 = ||X||_1 (the
 * l1 norm of the whole spectrum): the l1 problem min 0.5 ||y - S f||^2 + tau ||X||_1 over real f
 * is the same problem over z (see host/integrate/reconstruct.c, motion()).
 * Layout: rows of `stride` >= M + 1 complex values (padded to a multiple of 16), coefficient
 * (u0, u1, u2) at u0 + stride (u1 + n1 u2) (squeezed axes as in csi_fourier_create); padding
 * entries are zero in every forward output and ignored by the inverse. f and z are device
 * buffers of N floats and csi_fourier_half_count complex values; input and output must differ;
 * the input is not modified. Device memory: two scratch spectra of the coefficients' size. */
typedef struct csi_fft_half csi_fourier_half;
csi_status csi_fourier_half_create(csi_ctx *ctx, const size_t dims[3], csi_fourier_half **out);
size_t csi_fourier_half_count(const csi_fourier_half *h);
size_t csi_fourier_half_stride(const csi_fourier_half *h);
csi_status csi_fourier_half_forward(csi_fourier_half *h, cl_mem f, cl_mem z);
csi_status csi_fourier_half_inverse(csi_fourier_half *h, cl_mem z, cl_mem f);
/* csi_fourier_half_forward in two parts: the frames' spatial spectra (f to zs, which has
 * csi_fourier_half_count values), which do not depend on the time stage or the velocity, then
 * the rest (zs, read only, to z) in the state csi_fourier_half_set_motion last set. Chained, the
 * same bits as the whole; a caller that transforms one volume in several states keeps zs. */
csi_status csi_fourier_half_forward_space(csi_fourier_half *h, cl_mem f, cl_mem zs);
csi_status csi_fourier_half_forward_rest(csi_fourier_half *h, cl_mem zs, cl_mem z);
void csi_fourier_half_free(csi_fourier_half *h);
/* Before creating one: whether this size has a half spectrum, its coefficient count, and the
 * device buffers csi_fourier_half_create allocates (added to a tally). */
bool csi_fourier_half_supported(const size_t dims[3]);
size_t csi_fourier_half_count_for(const size_t dims[3]);
void csi_fourier_half_buffers(const size_t dims[3], csi_mem_tally *t);

/* Alg. 2's motion basis (csi's extension of the paper's 3-D Fourier basis; measurements in
 * docs/bench/animation.md): the half-spectrum basis above with a time stage. For a volume of
 * dims = (w, h, T), T > 1 and w or h > 1, and a velocity (vx, vy) in grid cells per frame:
 *   forward: z[u, k] = sum_t B_k(t) exp(+2 pi i (u_x vx + u_y vy) (t - tc)) X_t[u], where
 *            X_t = numpy's rfft2(f[t], norm="ortho") is frame t's spatial half spectrum,
 *            u_x, u_y its signed frequencies in cycles per cell (0 at the Nyquist bins: no
 *            shift of a component that is its own mirror keeps the volume real, so it stays),
 *            tc = (T - 1) / 2, and B_k the orthonormal transform along t: the DFT
 *            (exp(-2 pi i k t / T) / sqrt(T): with v = 0 exactly csi_fourier_half), the DCT-II
 *            (c_k cos(pi k (2t + 1) / 2T), c_0 = 1 / sqrt(T), c_k = sqrt(2 / T)), or none
 *            (NONE: z holds each frame's unsheared spectrum, k = t);
 *   inverse: the adjoint (as csi_fourier_half_inverse: Re <z, w> and <f, g>), so
 *            inverse(z) = f when z is forward(f) with the inner planes doubled.
 * In words: each frame is moved back by v (t - tc), a shift by the spectral phase (fractional
 * velocities exact, spatial axes periodic), and the aligned volume is transformed along t; the
 * DCT's ends are mirrored instead of the DFT's wrap of the last frame onto the first. Content
 * moving at v is static in the aligned volume, so its coefficients lie on the k = 0 plane (the
 * sheared plane of Egan et al. 2009 becomes an axis plane). Same layout and count as
 * csi_fourier_half (squeezed: t is the last axis). May be called again to change the
 * transform or the velocity; dims must be those the basis was created with. */
typedef enum { CSI_TIME_DFT = 0, CSI_TIME_DCT, CSI_TIME_NONE } csi_time_transform;
const char *csi_time_transform_name(csi_time_transform t);
csi_status csi_time_transform_parse(const char *s, csi_time_transform *out); /* dft, dct, none */
csi_status csi_fourier_half_set_motion(csi_fourier_half *h, const size_t dims[3],
                                       csi_time_transform t, double vx, double vy);
/* The device buffers the first csi_fourier_half_set_motion adds (its phase and DCT tables, kept
 * until the basis is freed; later calls rewrite them in place). */
void csi_fourier_half_motion_buffers(const size_t dims[3], csi_mem_tally *t);

/* CSI_OK if clFFT can transform an axis of length n (n >= 1 and only factors 2, 3, 5, 7);
 * otherwise CSI_ERR_ARG with a message naming `what` and the size. */
csi_status csi_fft_check_size(const char *what, const size_t dims[3]);

#ifdef __cplusplus
}
#endif
#endif
