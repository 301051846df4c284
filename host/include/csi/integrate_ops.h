/* Integration to the output image on the device: box means over each pixel's block of the
 * fine grid, the mean over t of a volume, a pixel's variance over t, and the Monte
 * Carlo per-pixel sample mean.
 *
 * Layouts (float32, channels planar):
 *   fine image  [c][y][x]     w x h per channel
 *   volume      [c][t][y][x]  w x h x T per channel (the order of csi_grid_index)
 *   output      [c][oy][ox]   out_w x out_h per channel
 * Sums are compensated (Kahan), so each result is within a few float32 ulps of the exact mean
 * whatever the block size. Buffers are checked against the sizes the call needs. */
#ifndef CSI_INTEGRATE_OPS_H
#define CSI_INTEGRATE_OPS_H

#include <stddef.h>
#include <stdint.h>

#include "csi/runtime.h"
#include "csi/samples.h"

#ifdef __cplusplus
extern "C" {
#endif

/* out = mean over each (w/out_w) x (h/out_h) block of `fine`. w % out_w == 0, h % out_h == 0. */
csi_status csi_box_integrate(csi_ctx *ctx, cl_mem fine, uint32_t w, uint32_t h, uint32_t channels,
                             uint32_t out_w, uint32_t out_h, cl_mem out);

/* out (w x h x channels) = mean over t of the volume `vol` (w x h x nt x channels). */
csi_status csi_time_mean(csi_ctx *ctx, cl_mem vol, uint32_t w, uint32_t h, uint32_t nt, uint32_t channels,
                         cl_mem out);

/* out (out_w x out_h) = the variance over the first nt frames of one channel's volume `vol`
 * (w x h x at least nt) of each pixel's box mean ((w/out_w) x (h/out_h) cells) in each frame. */
csi_status csi_box_time_var(csi_ctx *ctx, cl_mem vol, uint32_t w, uint32_t h, uint32_t nt, uint32_t out_w,
                            uint32_t out_h, cl_mem out);

/* The Monte Carlo estimate from the samples alone: each output pixel's value is the mean of the
 * samples whose position falls in its block (all t), per channel; pixels with no sample are 0
 * and counted in *empty (may be NULL). values: n x channels, sample-major (as in csi_dump).
 * The samples are grouped by pixel on the host with a stable counting sort, then summed on the
 * device in that fixed order: deterministic. out: out_w x out_h x channels floats. */
csi_status csi_splat_mean(csi_ctx *ctx, const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                          const float *values, size_t n, cl_mem out, size_t *empty);

/* The device buffers csi_splat_mean allocates while it runs (and frees), for n samples and
 * `pixels` output pixels; its host arrays hold (pixels + 1) * 8 + n * (4 + 4 * channels) bytes. */
void csi_splat_mean_buffers(size_t n, uint32_t channels, size_t pixels, csi_mem_tally *t);

#ifdef __cplusplus
}
#endif
#endif
