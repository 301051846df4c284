/* Sampling operator S (gather) and its adjoint S^T (scatter) on the fine grid.
 * idx holds n distinct positions < k (checked on the host), so the scatter has no conflicts
 * and needs no atomics; the zeros elsewhere come from a fill before the scatter. */

/* y_i = f[idx_i]; `w` floats per element (1 real, 2 complex). */
__kernel void sampling_gather(__global const float *f, __global const uint *idx, const uint n,
                              const uint w, __global float *y)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    const size_t j = idx[i];
    if (w == 2) {
        y[2 * i] = f[2 * j];
        y[2 * i + 1] = f[2 * j + 1];
    } else {
        y[i] = f[j];
    }
}

/* f[idx_i] = y_i (f zeroed beforehand). */
__kernel void sampling_scatter(__global const float *y, __global const uint *idx, const uint n,
                               const uint w, __global float *f)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    const size_t j = idx[i];
    if (w == 2) {
        f[2 * j] = y[2 * i];
        f[2 * j + 1] = y[2 * i + 1];
    } else {
        f[j] = y[i];
    }
}

/* out[i] = (in[i], 0): real samples as complex measurements for the 3-D Fourier problem. */
__kernel void csi_real_to_complex(__global const float *in, __global float2 *out, const uint n)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = (float2)(in[i], 0.0f);
}

/* out[i] = Re(in[i]). The signal is real; the imaginary part the l1 solution leaves is discarded
 * (it is the part of F3^H x no real measurement constrains). */
__kernel void csi_complex_real(__global const float2 *in, __global float *out, const uint n)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = in[i].x;
}

/* out[i] = in[i] * w[i % period]: a real gain per column of the half spectrum (Alg. 2's
 * spatial filter, csi_half_fourier_set_filter); in place when in == out. */
__kernel void csi_half_weight(__global const float2 *in, __global float2 *out, __global const float *w,
                              const uint period, const uint n)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = in[i] * w[i % period];
}

/* The same with the gain of the first plane (i < period: the coefficients constant along t in
 * the basis's frame) times g0: a column scaling, so that an l1 penalty on the scaled
 * coefficients weighs that plane by 1 / g0 (csi_half_fourier_set_still_gain). */
__kernel void csi_half_weight_still(__global const float2 *in, __global float2 *out, __global const float *w,
                                    const uint period, const uint n, const float g0)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = in[i] * (i < period ? w[i] * g0 : w[i % period]);
}
