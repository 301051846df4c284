/* A Gaussian along the motion: normalized convolution and leave-one-out scores for Alg. 2 with a
 * moving basis (csi_fourier_half_set_motion).
 *
 * On a motion basis B (the half-spectrum Fourier basis with a time stage, velocity v, transform
 * along t), the filter is G = B^-1 diag(g) B with the separable gain
 *     g(u, k) = exp(-2 pi^2 (sigma_xy^2 |u|^2 + sigma_t^2 nu_k^2)),
 * u the spatial frequency in cycles per cell and nu_k the temporal one in cycles per frame
 * (k / T signed for the DFT, k / 2T for the DCT-II). In the aligned volume (each frame moved back
 * by v (t - tc)) it is a Gaussian of widths sigma_xy (cells) and sigma_t (frames); in the volume
 * itself the kernel is sheared along v: g_xy(x - x' - v (t - t')) g_t(t - t'). The spatial axes
 * are periodic; along t the DFT wraps the last frame onto the first and the DCT mirrors the ends
 * (the convolution of the evenly extended volume). G is real, symmetric and positive
 * semi-definite (apply == adjoint). With v = 0 and the DFT it is csi_filter_create's GAUSS. */
#ifndef CSI_MOTION_FILTER_H
#define CSI_MOTION_FILTER_H

#include <stddef.h>

#include "csi/linop.h"
#include "csi/spectral.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The filter on the basis h of a dims volume, in whatever motion state h is (set with
 * csi_fourier_half_set_motion before each use; the gain is read from h's time transform when
 * the filter is made). h and zscratch (csi_fourier_half_count complex values, overwritten by
 * every call) are borrowed: they must outlive the operator. sigma_xy > 0, sigma_t >= 0 (0: no
 * smoothing along t). apply may be called in place (x == y): the input is read whole into the
 * spectrum before the output is written. */
csi_status csi_motion_filter_create(csi_ctx *ctx, csi_fourier_half *h, const size_t dims[3],
                                    csi_time_transform t, double sigma_xy, double sigma_t,
                                    cl_mem zscratch, csi_linop **out);

/* y = G x from the frames' spatial spectra zs of x (csi_fourier_half_forward_space, not the
 * filter's zscratch; read only), the same bits as csi_linop_apply(G, x, y): a caller filtering
 * one volume along several velocities transforms its frames once. */
csi_status csi_motion_filter_apply_spatial(const csi_linop *G, cl_mem zs, cl_mem y);

/* Another time transform (that of the basis's next state) and widths for the same filter: its
 * gain tables rewritten in place. */
csi_status csi_motion_filter_set(csi_linop *G, csi_time_transform t, double sigma_xy, double sigma_t);
/* The device buffers csi_motion_filter_create allocates (its gain tables). */
void csi_motion_filter_buffers(const size_t dims[3], csi_mem_tally *t);

/* The filter's weight of a cell on itself in frame t, w0(t) = G[(x, t), (x, t)] (the same at
 * every x; it depends on t only through the DCT's mirrored ends): the leave-one-out prediction
 * of a sample removes it from a normalized convolution with it. Computed in double from the
 * gain's closed form (the mean of the spatial gain over the full spectrum times the t-th
 * diagonal entry of the temporal filter). out has dims[2] entries. */
void csi_motion_filter_self_weight(const size_t dims[3], csi_time_transform t, double sigma_xy,
                                   double sigma_t, double *out);

#ifdef __cplusplus
}
#endif
#endif
