/* Element-wise steps of the reconstruction (host/integrate/). */

/* Normalized convolution: out[i] = num[i] / den[i] where the filtered sample density den is
 * large enough to trust, else 0 (no sample within reach of the filter), clamped to [lo, hi]
 * (the samples' range for the Gaussian baseline; +-infinity, no clamp, elsewhere). */
__kernel void csi_nc_divide(__global const float *num, __global const float *den,
                            __global float *out, const uint n, const float eps, const float lo,
                            const float hi)
{
    const size_t i = get_global_id(0);
    if (i < n) {
        const float d = den[i];
        out[i] = d > eps ? fmin(fmax(num[i] / d, lo), hi) : 0.0f;
    }
}

/* Each cell (x, y, t) of a volume (w x h x T, row-major) clamped to [lohi[2p], lohi[2p + 1]] of
 * its pixel p in the frame that moves with (vx, vy) cells per frame: column
 * floor((x + 0.5 - vx (t - tc)) / bw + ox), row likewise, aw x ah pixels; a cell outside them is
 * left as it is. */
__kernel void csi_clamp_aligned_range(__global float *x, __global const float *lohi, const uint w,
                                      const uint h, const uint bw, const uint bh, const uint aw,
                                      const uint ah, const float vx, const float vy,
                                      const float ox, const float oy, const float tc, const uint n)
{
    const size_t i = get_global_id(0);
    if (i < n) {
        const uint cx = (uint)(i % w), cy = (uint)((i / w) % h), t = (uint)(i / ((size_t)w * h));
        const float dt = (float)t - tc;
        const int ax = (int)floor(((float)cx + 0.5f - vx * dt) / (float)bw + ox);
        const int ay = (int)floor(((float)cy + 0.5f - vy * dt) / (float)bh + oy);
        if (ax >= 0 && ay >= 0 && ax < (int)aw && ay < (int)ah) {
            const size_t p = (size_t)ay * aw + (size_t)ax;
            x[i] = fmin(fmax(x[i], lohi[2 * p]), lohi[2 * p + 1]);
        }
    }
}
