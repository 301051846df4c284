/* Internal: the filter pass y = F^-1 (gain . F x) on real signals, and complex-to-complex
 * transforms, with csi's own FFT kernels (kernels/fft.cl), used by csi_filter_create and
 * csi_fourier_create when the size allows (host/ops/spectral.c).
 * Sizes are squeezed (no axis of length 1 before a longer one): c[0] x c[1] x c[2] with nd
 * axes longer than 1. */
#ifndef CSI_FFT_FILTER_H
#define CSI_FFT_FILTER_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/runtime.h"

typedef struct csi_fft_filter csi_fft_filter;

/* True if c[0] >= 4 is even and every length (c[0]/2, c[1], c[2]) factors into 2, 3, 5, 7. */
bool csi_fft_filter_supported(const size_t c[3], int nd);

/* sigma[a] is the spatial sigma along squeezed axis a (0 = no filtering along it). */
csi_status csi_fft_filter_create(csi_ctx *ctx, const size_t c[3], int nd, const double sigma[3],
                                 bool wiener, float lambda, csi_fft_filter **out);
/* The same filter with its row stages launched pass by pass when fuse_rows is false, even where
 * they could run as one launch each: the reference the fused stages' bits are tested against. */
csi_status csi_fft_filter_create_rows(csi_ctx *ctx, const size_t c[3], int nd, const double sigma[3],
                                      bool wiener, float lambda, bool fuse_rows, csi_fft_filter **out);
csi_status csi_fft_filter_run(csi_fft_filter *f, cl_mem x, cl_mem y);
/* Multiplies the gain by a separable complex factor fc[kx] fa[ky] (2-D filters only): fc holds
 * c[0]/2 + 1 interleaved complex values (kx = 0 .. c[0]/2), fa c[1] (ky in DFT order). The
 * factor must be Hermitian (fc[0] real, fa[-ky] = conj fa[ky]) and real at the Nyquist bins for
 * the output to be the real convolution it describes. */
csi_status csi_fft_filter_set_factor(csi_fft_filter *f, const double *fc, const double *fa);
void csi_fft_filter_factor_buffers(const size_t c[3], csi_mem_tally *t); /* what it allocates */
/* The filter pass with the factor conjugated when conj (the adjoint of the pass with it). */
csi_status csi_fft_filter_run_dir(csi_fft_filter *f, cl_mem x, cl_mem y, bool conj);
/* Adds the device buffers csi_fft_filter_create allocates for this size (csi_mem_tally). */
void csi_fft_filter_buffers(const size_t c[3], int nd, csi_mem_tally *t);
/* Whether a filter whose first axis is c0 runs its row stages as one launch each (on a device
 * with local_mem bytes of local memory): otherwise they run pass by pass, at more CPU per cell. */
bool csi_fft_filter_rows_fused(size_t c0, uint64_t local_mem);
void csi_fft_filter_free(csi_fft_filter *f);

/* Complex-to-complex transform of c[0] x c[1] x c[2] interleaved complex values (nd axes
 * longer than 1, squeezed as above) on the same Stockham passes: one pass per radix per axis,
 * no transposes, natural order in and out. Holds one scratch volume of n complex values. */
typedef struct csi_fft_c2c csi_fft_c2c;

/* True if every length c[0..nd) is >= 2 and factors into 2, 3, 5, 7, and the product < 2^32. */
bool csi_fft_c2c_supported(const size_t c[3], int nd);

/* scale multiplies the result (fused into the first pass; must be >= 0). */
csi_status csi_fft_c2c_create(csi_ctx *ctx, const size_t c[3], int nd, float scale,
                              csi_fft_c2c **out);

/* y = scale * sum_u x[u] exp(sign 2 pi i <u, v / c>): sign < 0 forward, > 0 inverse
 * (unnormalised except for scale). x is not modified; x, y must be different buffers. */
csi_status csi_fft_c2c_run(csi_fft_c2c *f, cl_mem x, cl_mem y, int sign);
void csi_fft_c2c_buffers(const size_t c[3], int nd, csi_mem_tally *t); /* what create allocates */
void csi_fft_c2c_free(csi_fft_c2c *f);

/* Half-spectrum transforms of a real signal of c[0] x c[1] x c[2] (c[0] even; the sizes
 * csi_fft_filter_supported accepts). Coefficients: complex, rows of hs >= M + 1 values
 * (M = c[0]/2, hs padded to 16), coefficient (u0 <= M, u1, u2) at u0 + hs (u1 + c[1] u2); the
 * padding entries are zero in every forward output and ignored by the inverse.
 *   forward: z[u] = scale * sum_x f[x] exp(-2 pi i <u, x / c>)  (the R2C transform)
 *   inverse: f[x] = scale * Re sum_{u0 <= M} z[u] exp(+2 pi i <u, x / c>)
 * The inverse is the adjoint of the forward for the real inner products <f, g> and Re <z, w>.
 * Holds two scratch spectra. */
typedef struct csi_fft_half csi_fft_half;
csi_status csi_fft_half_create(csi_ctx *ctx, const size_t c[3], int nd, float scale,
                               csi_fft_half **out);
size_t csi_fft_half_stride(const csi_fft_half *h); /* hs */
size_t csi_fft_half_count(const csi_fft_half *h);  /* hs * c[1] * c[2] */
size_t csi_fft_half_count_for(const size_t c[3], int nd); /* the same, before creating one */
void csi_fft_half_buffers(const size_t c[3], int nd, csi_mem_tally *t); /* what create allocates */
/* The time stage (csi_fourier_half_set_motion): the last axis (nd >= 2) becomes t, transformed
 * by tkind after the spatial axes, each frame's spectrum unsheared by the velocity v[a] (cells
 * per frame) along the spatial axes a = 0 and (nd = 3) 1 first. The values are
 * csi_time_transform's (csi/spectral.h), which spectral.c checks. */
enum { CSI_FFT_TIME_DFT = 0, CSI_FFT_TIME_DCT = 1, CSI_FFT_TIME_NONE = 2 };
csi_status csi_fft_half_set_motion(csi_fft_half *h, int tkind, const double v[2]);
void csi_fft_half_motion_buffers(const size_t c[3], int nd, csi_mem_tally *t); /* its tables */
csi_status csi_fft_half_forward(csi_fft_half *h, cl_mem f, cl_mem z);
/* The forward transform in two parts: the spatial stage (f to zs, csi_fft_half_count values),
 * which does not depend on the time stage, then the rest (zs to z; zs is read only). Chained,
 * they give csi_fft_half_forward's bits. */
csi_status csi_fft_half_forward_space(csi_fft_half *h, cl_mem f, cl_mem zs);
csi_status csi_fft_half_forward_rest(csi_fft_half *h, cl_mem zs, cl_mem z);
csi_status csi_fft_half_inverse(csi_fft_half *h, cl_mem z, cl_mem f);
void csi_fft_half_free(csi_fft_half *h);

#endif
