/* Element-wise steps of the reconstruction (host/integrate/). */

/* Normalized convolution: out[i] = num[i] / den[i] where the filtered sample density den is
 * large enough to trust, else 0 (no sample within reach of the filter). */
__kernel void csi_nc_divide(__global const float *num, __global const float *den,
                            __global float *out, const uint n, const float eps)
{
    const size_t i = get_global_id(0);
    if (i < n) {
        const float d = den[i];
        out[i] = d > eps ? num[i] / d : 0.0f;
    }
}

/* Each cell of a fine image or volume (w x h x T, row-major) clamped to its output pixel's
 * [lohi[2p], lohi[2p + 1]] (pixels bw x bh cells, ow per row): the fine estimate projected onto
 * the range of the samples around it. */
__kernel void csi_clamp_pixel_range(__global float *x, __global const float *lohi, const uint w,
                                    const uint h, const uint bw, const uint bh, const uint ow,
                                    const uint n)
{
    const size_t i = get_global_id(0);
    if (i < n) {
        const uint cx = (uint)(i % w), cy = (uint)((i / w) % h);
        const uint p = (cy / bh) * ow + cx / bw;
        x[i] = fmin(fmax(x[i], lohi[2 * p]), lohi[2 * p + 1]);
    }
}
