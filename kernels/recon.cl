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
