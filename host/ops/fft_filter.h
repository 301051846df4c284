/* Internal: the filter pass y = F^-1 (gain . F x) on real signals with csi's own FFT kernels
 * (kernels/fft.cl), used by csi_filter_create when the size allows (host/ops/spectral.c).
 * Sizes are squeezed (no axis of length 1 before a longer one): c[0] x c[1] x c[2] with nd
 * axes longer than 1. */
#ifndef CSI_FFT_FILTER_H
#define CSI_FFT_FILTER_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/runtime.h"

typedef struct csi_fft_filter csi_fft_filter;

/* True if c[0] is even and every length (c[0]/2, c[1], c[2]) factors into 2, 3, 5, 7. */
bool csi_fft_filter_supported(const size_t c[3], int nd);

/* sigma[a] is the spatial sigma along squeezed axis a (0 = no filtering along it). */
csi_status csi_fft_filter_create(csi_ctx *ctx, const size_t c[3], int nd, const double sigma[3],
                                 bool wiener, float lambda, csi_fft_filter **out);
csi_status csi_fft_filter_run(csi_fft_filter *f, cl_mem x, cl_mem y);
void csi_fft_filter_free(csi_fft_filter *f);

#endif
