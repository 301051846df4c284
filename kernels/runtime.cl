/* Device smoke check used by csi-selfcheck and the runtime tests: out[i] = a * i + b, computed
 * with a local-size-independent index so a wrong launch geometry shows up as wrong values. */
__kernel void csi_probe_affine(__global float *out, const uint n, const float a, const float b)
{
    const size_t i = get_global_id(0);
    if (i < n)
        out[i] = a * (float)i + b;
}
