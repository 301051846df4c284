/* ROMP's candidate selection on the device: the s largest |u_i| outside the support.
 *
 * Non-negative floats order like their bit patterns read as unsigned integers, so the s-th
 * largest magnitude is found exactly by a radix select over the 31 magnitude bits: histogram
 * passes over bits [20,31), [8,20) and [0,8), each restricted to the keys whose higher bits
 * match the prefix found so far (the host walks each histogram from the top). A last pass
 * collects the keys at or above the threshold. Only keys of indices outside the support with
 * 0 < |u_i| < inf take part: zeros carry no information and a NaN/Inf is caught by the host.
 * Counts are integers, so the atomics leave the result independent of scheduling. */

#define ROMP_BINS 4096
#define ROMP_LOCAL 64

/* The selection key of index i: |u_i|, or |u_i| / norm_i when column norms are given (use_norms;
 * a zero norm means a column A cannot see: never selected). */
inline uint romp_key(__global const float *u, __global const uchar *mask, __global const float *norms,
                     const uint use_norms, const size_t i)
{
    if (mask[i])
        return 0u;
    float v = fabs(u[i]);
    if (use_norms) {
        const float c = norms[i];
        v = c > 0.0f ? v / c : 0.0f;
    }
    const uint key = as_uint(v);
    return key < 0x7f800000u ? key : 0u; /* drop Inf and NaN */
}

/* hist[b] += #{i : key_i != 0, (key_i & pmask) == pval, ((key_i >> shift) & (ROMP_BINS-1)) == b}.
 * hist must be zeroed before the first group runs (the host fills it). */
__kernel __attribute__((reqd_work_group_size(ROMP_LOCAL, 1, 1)))
void romp_hist(__global const float *u, __global const uchar *mask, __global const float *norms,
               const uint use_norms, const uint n, const uint shift, const uint pmask, const uint pval,
               __global uint *hist)
{
    __local uint lh[ROMP_BINS];
    const uint l = get_local_id(0);
    for (uint b = l; b < ROMP_BINS; b += ROMP_LOCAL)
        lh[b] = 0u;
    barrier(CLK_LOCAL_MEM_FENCE);
    const size_t stride = get_global_size(0);
    for (size_t i = get_global_id(0); i < n; i += stride) {
        const uint key = romp_key(u, mask, norms, use_norms, i);
        if (key != 0u && (key & pmask) == pval)
            atomic_inc(&lh[(key >> shift) & (ROMP_BINS - 1)]);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint b = l; b < ROMP_BINS; b += ROMP_LOCAL)
        if (lh[b])
            atomic_add(&hist[b], lh[b]);
}

/* Appends (i, |u_i|) for every eligible key >= thr; count[0] is the running total (zeroed by
 * the host). Positions past cap are counted but not written. */
__kernel void romp_collect(__global const float *u, __global const uchar *mask,
                           __global const float *norms, const uint use_norms, const uint n,
                           const uint thr, const uint cap, __global uint *count,
                           __global uint *idx, __global float *val)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    const uint key = romp_key(u, mask, norms, use_norms, i);
    if (key != 0u && key >= thr) {
        const uint p = atomic_inc(count);
        if (p < cap) {
            idx[p] = (uint)i;
            val[p] = as_float(key);
        }
    }
}

/* mask[sel_i] = 1 for the newly selected indices. */
__kernel void romp_mark(__global uchar *mask, __global const uint *sel, const uint m)
{
    const size_t i = get_global_id(0);
    if (i < m)
        mask[sel[i]] = 1;
}

/* Column-norm estimation (csi_column_norms): acc_i += |v_i|^2 for one probe v = A^H z. */
__kernel void romp_acc_sq(__global float *acc, __global const float *v, const uint n, const uint cplx)
{
    const size_t i = get_global_id(0);
    if (i >= n)
        return;
    const float a = cplx ? v[2 * i] : v[i];
    const float b = cplx ? v[2 * i + 1] : 0.0f;
    acc[i] = acc[i] + (a * a + b * b);
}

/* norms_i = sqrt(acc_i * scale) */
__kernel void romp_sqrt_scale(__global float *acc, const uint n, const float scale)
{
    const size_t i = get_global_id(0);
    if (i < n)
        acc[i] = sqrt(acc[i] * scale);
}
