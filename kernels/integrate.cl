/* Integration to the output image: box means over pixel blocks, the mean over t, a pixel's
 * variance over t, and the per-pixel sample mean (the Monte Carlo "splat"
 * baseline).
 *
 * Layouts: channels planar. A fine image is [c][y][x] (w x h per channel), a volume
 * [c][t][y][x], an output image [c][oy][ox]. Sums use Kahan's compensated summation, so the
 * error is bounded by about 2 eps |sum| independent of the block size (Higham, "Accuracy and
 * Stability of Numerical Algorithms", 2nd ed., Sec. 4.3); the build never uses fast-math, so
 * the compensation is not optimised away. */

#define KAHAN_ADD(sum, comp, v)      \
    do {                             \
        float y_ = (v) - (comp);     \
        float t_ = (sum) + y_;       \
        (comp) = (t_ - (sum)) - y_;  \
        (sum) = t_;                  \
    } while (0)

/* out[c][oy][ox] = mean of fine[c][oy*bh .. oy*bh+bh-1][ox*bw .. ox*bw+bw-1].
 * Global: (out_w, out_h, channels). */
__kernel void csi_box_integrate(__global const float *fine, __global float *out, const uint w, const uint h,
                                const uint out_w, const uint out_h, const uint channels)
{
    const uint ox = get_global_id(0), oy = get_global_id(1), c = get_global_id(2);
    if (ox >= out_w || oy >= out_h || c >= channels)
        return;
    const uint bw = w / out_w, bh = h / out_h;
    __global const float *src = fine + (size_t)c * w * h + (size_t)oy * bh * w + (size_t)ox * bw;
    float sum = 0.0f, comp = 0.0f;
    for (uint y = 0; y < bh; y++)
        for (uint x = 0; x < bw; x++)
            KAHAN_ADD(sum, comp, src[(size_t)y * w + x]);
    out[((size_t)c * out_h + oy) * out_w + ox] = sum / (float)(bw * bh);
}

/* out[c][y][x] = mean over t of vol[c][t][y][x]. Global: (w, h, channels). */
__kernel void csi_time_mean(__global const float *vol, __global float *out, const uint w, const uint h,
                            const uint nt, const uint channels)
{
    const uint x = get_global_id(0), y = get_global_id(1), c = get_global_id(2);
    if (x >= w || y >= h || c >= channels)
        return;
    const size_t plane = (size_t)w * h;
    __global const float *src = vol + (size_t)c * nt * plane + (size_t)y * w + x;
    float sum = 0.0f, comp = 0.0f;
    for (uint t = 0; t < nt; t++)
        KAHAN_ADD(sum, comp, src[t * plane]);
    out[(size_t)c * plane + (size_t)y * w + x] = sum / (float)nt;
}

/* The mean of vol[t] over output pixel (ox, oy)'s block: a frame's box mean. */
static float block_mean(__global const float *src, const uint w, const uint bw, const uint bh)
{
    float sum = 0.0f, comp = 0.0f;
    for (uint y = 0; y < bh; y++)
        for (uint x = 0; x < bw; x++)
            KAHAN_ADD(sum, comp, src[(size_t)y * w + x]);
    return sum / (float)(bw * bh);
}

/* out[oy][ox] = the variance over the first nt frames of the pixel's box mean in each: how much
 * the pixel changes over t, about its mean over them, in a second pass (no cancellation). One
 * channel. Global: (out_w, out_h). */
__kernel void csi_box_time_var(__global const float *vol, __global float *out, const uint w, const uint h,
                               const uint nt, const uint out_w, const uint out_h)
{
    const uint ox = get_global_id(0), oy = get_global_id(1);
    if (ox >= out_w || oy >= out_h)
        return;
    const uint bw = w / out_w, bh = h / out_h;
    const size_t plane = (size_t)w * h;
    __global const float *src = vol + (size_t)oy * bh * w + (size_t)ox * bw;
    float sum = 0.0f, comp = 0.0f;
    for (uint t = 0; t < nt; t++)
        KAHAN_ADD(sum, comp, block_mean(src + t * plane, w, bw, bh));
    const float mean = sum / (float)nt;
    sum = comp = 0.0f;
    for (uint t = 0; t < nt; t++) {
        const float d = block_mean(src + t * plane, w, bw, bh) - mean;
        KAHAN_ADD(sum, comp, d * d);
    }
    out[(size_t)oy * out_w + ox] = sum / (float)nt;
}

/* Per-pixel mean of the samples in each output pixel, gathered over a CSR index: the samples
 * of pixel p are rows offsets[p] .. offsets[p+1]-1 of `values` (n x channels, sample-major),
 * in a fixed order, so the result is deterministic (no atomics). Pixels without samples get 0.
 * Global: (out_w, out_h). */
__kernel void csi_splat_gather(__global const float *values, __global const uint *offsets, __global float *out,
                               const uint out_w, const uint out_h, const uint channels)
{
    const uint ox = get_global_id(0), oy = get_global_id(1);
    if (ox >= out_w || oy >= out_h)
        return;
    const uint p = oy * out_w + ox;
    const uint a = offsets[p], b = offsets[p + 1];
    const size_t plane = (size_t)out_w * out_h;
    for (uint c = 0; c < channels; c++) {
        float sum = 0.0f, comp = 0.0f;
        for (uint i = a; i < b; i++)
            KAHAN_ADD(sum, comp, values[(size_t)i * channels + c]);
        out[c * plane + p] = b > a ? sum / (float)(b - a) : 0.0f;
    }
}
