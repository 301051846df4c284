/* Interpolation of a periodic model grid at point samples on a D-times finer grid, and its
 * adjoint, the spreading of one value per sample onto the model grid (host/ops/interp.c).
 *
 * A sample at fine position p (per axis) sits at model coordinate t = p / D = m + d / D, with m
 * its model cell and d = p mod D its phase; it reads the IW x IW model cells m + o, o in
 * [-IH, IW - 1 - IH], with weights wt[d IW + (o + IH)] = phi(d / D - o) per axis, phi the
 * interpolation kernel tabulated by the host for the D phases (phi(-IW / 2) = 0, so phase 0
 * uses IW - 1 of its taps).
 *
 * Per sample (in the operator's internal order, grouped by tile of the model grid):
 *   cell[i] = m_y mw + m_x,  ph[i] = d_x | d_y << 8,  perm[i] = the caller's index of the sample.
 * Samples in tiles away from the grid's border (the first n_int) never wrap around it; the rest
 * take the kernels with periodic wrap. */

#define IW 6
#define IH 2

/* y[perm[i]] = sum_ab wy[a] wx[b] c[(m_y + a - IH) mw + m_x + b - IH] for the interior samples
 * [first + g chunk, first + (g + 1) chunk) of work-item g, one after another: each tap row is
 * one 8-wide load (the weights wt8[d 8 + b] are zero from b = IW on), so a sample is IW vector
 * multiply-adds. Work-groups of one item: the vector types are the SIMD lanes (across work-items
 * PoCL would turn every load into gathers). */
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void csi_interp_gather8(__global const float *restrict c, __global float *restrict y,
                        __global const uint *restrict cell, __global const uint *restrict ph,
                        __global const uint *restrict perm, __global const float *restrict wt8,
                        const uint mw_, const uint first, const uint chunk, const uint n)
{
    const size_t mw = mw_, i0 = (size_t)first + get_global_id(0) * (size_t)chunk;
    const size_t i1 = min(i0 + chunk, (size_t)n);
    for (size_t i = i0; i < i1; i++) {
        __global const float *src = c + (size_t)cell[i] - IH * mw - IH;
        const uint p = ph[i];
        const float8 wx = vload8(p & 0xffu, wt8);
        __global const float *wy = wt8 + (size_t)(p >> 8) * 8;
        float8 acc = wy[0] * vload8(0, src);
#pragma unroll
        for (int a = 1; a < IW; a++)
            acc += wy[a] * vload8(0, src + (size_t)a * mw);
        acc *= wx;
        const float4 h = acc.lo + acc.hi;
        const float2 q = h.lo + h.hi;
        y[perm[i]] = q.x + q.y;
    }
}

/* The same for samples [first, n) with periodic wrap (border tiles and the tail of the interior
 * launch). */
__kernel void csi_interp_gather_wrap(__global const float *restrict c, __global float *restrict y,
                                     __global const uint *restrict cell,
                                     __global const uint *restrict ph,
                                     __global const uint *restrict perm,
                                     __global const float *restrict wt, const uint mw,
                                     const uint mh, const uint first, const uint n)
{
    const size_t i = (size_t)first + get_global_id(0);
    if (i >= n)
        return;
    const uint mx = cell[i] % mw, my = cell[i] / mw, p = ph[i];
    const uint dx = (p & 0xffu) * IW, dy = (p >> 8) * IW;
    float acc = 0.0f;
    for (int a = 0; a < IW; a++) {
        const uint ry = (my + mh * IW + (uint)a - IH) % mh;
        float s = 0.0f;
        for (int b = 0; b < IW; b++) {
            const uint rx = (mx + mw * IW + (uint)b - IH) % mw;
            s += wt[dx + b] * c[(size_t)ry * mw + rx];
        }
        acc += wt[dy + a] * s;
    }
    y[perm[i]] = acc;
}

/* c += the spread of r over the samples of the tiles tlist[toff .. toff + ntl): each work-item adds its
 * tile's samples one after another, in their internal order. The host launches one colour of
 * tiles at a time: tiles of one colour are far enough apart that no two of them write the same
 * cell, so there are no races, and every cell receives its terms in a fixed order (colour by
 * colour, then sample by sample): the result is the same bits on every run. */
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void csi_interp_spread(__global float *restrict c, __global const float *restrict r,
                                __global const uint *restrict cell, __global const uint *restrict ph,
                                __global const uint *restrict perm,
                                __global const float *restrict wt,
                                __global const float *restrict wt8, const uint mw, const uint mh,
                                __global const uint *restrict tstart,
                                __global const uint *restrict tlist, const uint toff,
                                const uint ntl)
{
    const size_t g = get_global_id(0);
    if (g >= ntl)
        return;
    const uint t = tlist[toff + g];
    for (uint i = tstart[t]; i < tstart[t + 1]; i++) {
        const float v = r[perm[i]];
        const uint mx = cell[i] % mw, my = cell[i] / mw, p = ph[i];
        const uint dx = (p & 0xffu) * IW, dy = (p >> 8) * IW;
        /* 8-wide rows (two extra cells get + 0: within the tile's margin, see the host). */
        const bool inside = mx >= IH && mx + 8 - IH <= mw && my >= IH && my + IW - IH <= mh;
        if (inside) {
            __global float *dst = c + (size_t)(my - IH) * mw + (mx - IH);
            const float8 wx = vload8(0, wt8 + dx / IW * 8);
#pragma unroll
            for (int a = 0; a < IW; a++) {
                __global float *row = dst + (size_t)a * mw;
                vstore8(vload8(0, row) + (v * wt[dy + a]) * wx, 0, row);
            }
        } else {
            for (int a = 0; a < IW; a++) {
                const uint ry = (my + mh * IW + (uint)a - IH) % mh;
                const float va = v * wt[dy + a];
                for (int b = 0; b < IW; b++) {
                    const uint rx = (mx + mw * IW + (uint)b - IH) % mw;
                    c[(size_t)ry * mw + rx] += va * wt[dx + b];
                }
            }
        }
    }
}
