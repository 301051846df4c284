/* A dense matrix as an operator, for small problems and tests (k <= a few thousand).
 *
 * One work-item per output entry computes a row of M times a vector, M stored row-major; the
 * adjoint uses a second copy holding M^H row-major (made on the host), so both directions read
 * contiguous rows. The inner sum is Kahan-compensated, so its error stays within a few ulps of
 * sum |M_ij x_j| whatever the length. */
#pragma OPENCL FP_CONTRACT OFF

#define KAHAN_ADD(sum, c, v)           \
    do {                               \
        const float y_ = (v) - (c);    \
        const float t_ = (sum) + y_;   \
        (c) = (t_ - (sum)) - y_;       \
        (sum) = t_;                    \
    } while (0)

/* out[r] = sum_c M[r, c] in[c]; real. */
__kernel void dense_matvec(__global const float *M, const uint rows, const uint cols,
                           __global const float *in, __global float *out)
{
    const size_t r = get_global_id(0);
    if (r >= rows)
        return;
    __global const float *row = M + r * (size_t)cols;
    float s = 0.0f, c = 0.0f;
    for (uint j = 0; j < cols; j++)
        KAHAN_ADD(s, c, row[j] * in[j]);
    out[r] = s;
}

/* Complex: M, in and out interleaved (re, im). */
__kernel void dense_matvec_c(__global const float *M, const uint rows, const uint cols,
                             __global const float *in, __global float *out)
{
    const size_t r = get_global_id(0);
    if (r >= rows)
        return;
    __global const float *row = M + 2 * r * (size_t)cols;
    float sr = 0.0f, cr = 0.0f, si = 0.0f, ci = 0.0f;
    for (uint j = 0; j < cols; j++) {
        const float ar = row[2 * j], ai = row[2 * j + 1];
        const float xr = in[2 * j], xi = in[2 * j + 1];
        KAHAN_ADD(sr, cr, ar * xr);
        KAHAN_ADD(sr, cr, -(ai * xi));
        KAHAN_ADD(si, ci, ar * xi);
        KAHAN_ADD(si, ci, ai * xr);
    }
    out[2 * r] = sr;
    out[2 * r + 1] = si;
}
