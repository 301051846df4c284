/* Small element-wise conversions for the reconstruction (host/integrate/reconstruct.c). */

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
