/* FFT-domain filtering: the diagonal of the Gaussian filter G and of its Wiener inverse, applied
 * to a half spectrum (clFFT's Hermitian-interleaved R2C layout: h0 = n0/2 + 1 complex values per
 * x-line, then n1 lines, then n2 planes).
 *
 * G is separable, G(u) = g0[u0] g1[u1] g2[u2] (Sen & Darabi 2010, Alg. 1 step 2), so only three
 * short tables are read instead of a full-size gain volume. Wiener inverse (ibid. Sec. 4):
 * (1 + lambda) G / (G^2 + lambda); the (1 + lambda) factor makes the DC gain exactly 1. */

__kernel void csi_spectral_gain(__global float2 *spec, __global const float *g0,
                                __global const float *g1, __global const float *g2,
                                const uint h0, const uint n1, const uint n2, const uint wiener,
                                const float lambda)
{
    const uint i = (uint)get_global_id(0), j = (uint)get_global_id(1), k = (uint)get_global_id(2);
    if (i >= h0 || j >= n1 || k >= n2)
        return;
    const size_t at = (size_t)i + (size_t)h0 * ((size_t)j + (size_t)n1 * (size_t)k);
    float g = g0[i] * g1[j] * g2[k];
    if (wiener)
        g = (1.0f + lambda) * g / (g * g + lambda);
    spec[at] *= g;
}
