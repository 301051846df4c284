/* Interpolation of a periodic model grid at point samples on a D-times finer grid, and its
 * adjoint, the spreading of one value per sample onto the model grid (host/ops/interp.c).
 *
 * A sample at fine position p (per axis) sits at model coordinate t = p / D = m + d / D, with m
 * its model cell and d = p mod D its phase; it reads the IW x IW model cells m + o, o in
 * [-IH, IW - 1 - IH], with weights wt8[8 d + (o + IH)] = phi(d / D - o) per axis, phi the
 * interpolation kernel tabulated by the host for the D phases, 8 per phase, zero from IW on
 * (phi(-IW / 2) = 0, so phase 0 uses IW - 1 of its taps).
 *
 * Per sample (in the operator's internal order, grouped by tile of the model grid):
 *   cell[i] = m_y mw + m_x,  ph[i] = d_x | d_y << 8 | INSIDE (when the window rows, read 8 wide,
 *   stay inside the grid) | ROW_END (when the aligned 8-cell block that holds the window's first
 *   cell is its row's last),  perm[i] = the caller's index of the sample.
 * The few samples whose window crosses the grid's border take a scalar path with periodic wrap. */

#define IW 6
#define IH 2
/* ph bit: the sample's 8-wide window rows lie inside the grid (no wrap). */
#define INSIDE 0x10000u
/* ph bit: the aligned 8-cell block of the window's first cell ends its row (the spreading's blocks). */
#define ROW_END 0x20000u

/* (m + o) mod n for a cell m < n and an offset o in [-IH, IW - 1 - IH]: one conditional add or
 * subtract where the grid is at least a window wide (a division costs the border samples more
 * than all their arithmetic), the remainder on smaller grids. */
inline uint wrap_cell(const uint m, const int o, const uint n)
{
    if (n >= IW) {
        const int v = (int)m + o;
        return v < 0 ? (uint)(v + (int)n) : (uint)v >= n ? (uint)v - n : (uint)v;
    }
    return (m + n * IW + (uint)o) % n;
}

/* The taps of a sample whose window wraps around the grid's border (or a grid smaller than the
 * window, where a cell may be read twice), one by one. */
inline float gather_wrap(__global const float *restrict c, const uint mx, const uint my,
                         __global const float *restrict wx, __global const float *restrict wy,
                         const uint mw, const uint mh)
{
    uint rx[IW];
    for (int b = 0; b < IW; b++)
        rx[b] = wrap_cell(mx, b - IH, mw);
    float acc = 0.0f;
    for (int a = 0; a < IW; a++) {
        const size_t ry = wrap_cell(my, a - IH, mh);
        float s = 0.0f;
        for (int b = 0; b < IW; b++)
            s += wx[b] * c[ry * mw + rx[b]];
        acc += wy[a] * s;
    }
    return acc;
}

/* The 8 products wy[a] wx[b] c[...] of each tap column b of sample i (its window inside the
 * grid), summed over the rows a: each tap row is one 8-wide load (the weights wt8[d 8 + b] are
 * zero from b = IW on). */
inline float8 gather_cols(__global const float *restrict c, __global const uint *restrict cell,
                          __global const uint *restrict ph, __global const float *restrict wt8,
                          const uint mw, const size_t i)
{
    const uint p = ph[i];
    __global const float *wx = wt8 + (size_t)(p & 0xffu) * 8;
    __global const float *wy = wt8 + (size_t)((p >> 8) & 0xffu) * 8;
    __global const float *src = c + (size_t)cell[i] - IH * (size_t)mw - IH;
    float8 acc = wy[0] * vload8(0, src);
#pragma unroll
    for (int a = 1; a < IW; a++)
        acc += wy[a] * vload8(0, src + (size_t)a * mw);
    return acc * vload8(0, wx);
}

/* y[perm[i]] = sum_ab wy[a] wx[b] c[(m_y + a - IH) mw + m_x + b - IH] (periodic) for the samples
 * [g chunk, (g + 1) chunk) of work-item g, one after another, so a sample away from the border
 * is IW vector multiply-adds and the sum of their 8 lanes, (l0 + l4 + l2 + l6) + (l1 + l5 + l3 +
 * l7) in that tree. Where 8 consecutive samples all lie away from the border, their 8 sums are
 * made together: the same additions on the same pairs of lanes, 8 samples to a vector, so the
 * same bits with fewer shuffles and no chain of dependent adds per sample. Work-groups of one
 * item: the vector types are the SIMD lanes (across work-items PoCL would turn every load into
 * gathers).
 *
 * On a grid larger than the cache (`ahead`, the host's choice, as for the spreading), the sample
 * GATHER_AHEAD places later has its window's last row prefetched: the grid comes from a stage
 * that wrote it to memory, a tile's samples reach that row first, and the rows above it were read
 * by the samples before. Prefetches move no data the kernel computes with: the same bits. (The
 * scattered writes of y are not a wait: prefetching them for writing gained nothing.) */
#define GATHER_AHEAD 32
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void csi_interp_gather(__global const float *restrict c, __global float *restrict y,
                       __global const uint *restrict cell, __global const uint *restrict ph,
                       __global const uint *restrict perm, __global const float *restrict wt8,
                       const uint mw, const uint mh, const uint chunk, const uint n,
                       const uint ahead)
{
    const size_t i0 = get_global_id(0) * (size_t)chunk, i1 = min(i0 + chunk, (size_t)n);
    const size_t cells = (size_t)mw * mh;
    for (size_t i = i0; i < i1; i++) {
        if (ahead && i + GATHER_AHEAD < n) {
            /* the 8 cells the row's load reads (a window that wraps past the grid's end
             * prefetches the grid's first cells instead) */
            size_t f = (size_t)cell[i + GATHER_AHEAD] + (IW - 1 - IH) * (size_t)mw - IH;
            f = f + 8 <= cells ? f : 0;
            __builtin_prefetch(c + f);
            __builtin_prefetch(c + f + 7);
        }
        if (i + 8 <= i1 && all((vload8(0, ph + i) & INSIDE) != 0u)) {
            float8 s[8];
#pragma unroll
            for (int k = 0; k < 8; k++)
                s[k] = gather_cols(c, cell, ph, wt8, mw, i + k);
            /* per sample: h = lanes 0-3 + lanes 4-7, then q = h[0, 1] + h[2, 3], then q[0] + q[1] */
            float8 h[4];
#pragma unroll
            for (int k = 0; k < 4; k++)
                h[k] = (float8)(s[2 * k].lo, s[2 * k + 1].lo) + (float8)(s[2 * k].hi, s[2 * k + 1].hi);
            const float8 q0 = (float8)(h[0].s01, h[0].s45, h[1].s01, h[1].s45) +
                              (float8)(h[0].s23, h[0].s67, h[1].s23, h[1].s67);
            const float8 q1 = (float8)(h[2].s01, h[2].s45, h[3].s01, h[3].s45) +
                              (float8)(h[2].s23, h[2].s67, h[3].s23, h[3].s67);
            const float8 v8 = (float8)(q0.even, q1.even) + (float8)(q0.odd, q1.odd);
            y[perm[i]] = v8.s0;
            y[perm[i + 1]] = v8.s1;
            y[perm[i + 2]] = v8.s2;
            y[perm[i + 3]] = v8.s3;
            y[perm[i + 4]] = v8.s4;
            y[perm[i + 5]] = v8.s5;
            y[perm[i + 6]] = v8.s6;
            y[perm[i + 7]] = v8.s7;
            i += 7;
            continue;
        }
        const uint p = ph[i];
        __global const float *wx = wt8 + (size_t)(p & 0xffu) * 8;
        __global const float *wy = wt8 + (size_t)((p >> 8) & 0xffu) * 8;
        float v;
        if (p & INSIDE) {
            const float8 acc = gather_cols(c, cell, ph, wt8, mw, i);
            const float4 h = acc.lo + acc.hi;
            const float2 q = h.lo + h.hi;
            v = q.x + q.y;
        } else {
            v = gather_wrap(c, cell[i] % mw, cell[i] / mw, wx, wy, mw, mh);
        }
        y[perm[i]] = v;
    }
}

/* c[0 .. n) = 0 before the spreading, ZERO_LINES 64-byte lines per work-item. Where `stream` is
 * set (a grid larger than the cache holds, the host's choice), the lines are written whole, so on
 * x86 as non-temporal stores, which do not read them first (PoCL's fill reads each line, on one
 * thread); STREAM_STORES_DONE() orders them before the launch ends, and the spreading then reads
 * them back. A smaller grid is written with plain stores: it stays in the cache for the
 * spreading, where non-temporal stores would send it to memory first. */
#define ZERO_LINES 1024
#if defined(__x86_64__)
#define STREAM_STORES_DONE() __asm__ volatile("sfence" ::: "memory")
#else
#define STREAM_STORES_DONE()
#endif
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void csi_interp_zero(__global float *restrict c, const uint n, const uint stream)
{
    const size_t i0 = get_global_id(0) * (size_t)ZERO_LINES * 16,
                 i1 = min(i0 + (size_t)ZERO_LINES * 16, (size_t)n);
    size_t i = i0;
#if defined(__x86_64__)
    if (stream) {
        /* the lines whole and aligned: the first aligned one to the last whole one */
        for (; i < i1 && ((size_t)(c + i) & 63) != 0; i++)
            c[i] = 0.0f;
        for (; i + 16 <= i1; i += 16)
            __builtin_nontemporal_store((float16)(0.0f), (__global float16 *)(c + i));
        STREAM_STORES_DONE();
    }
#endif
    for (; i + 16 <= i1; i += 16)
        vstore16((float16)(0.0f), 0, c + i);
    for (; i < i1; i++)
        c[i] = 0.0f;
}

/* c += the spread of r over the samples of the rows of tiles rows[roff .. roff + nrows): each
 * work-item takes one row of tiles, its tiles in the order rows[xoff .. xoff + Tx) (the tile
 * columns by colour along x), and adds each tile's samples one after another, in their internal
 * order. The host launches one colour of rows at a time: rows of one colour, and tiles of one
 * colour within a row, are far enough apart that no two of them write the same cell, so there
 * are no races, and every cell receives its terms in a fixed order (colour by colour, then sample
 * by sample): the result is the same bits on every run.
 *
 * Where the grid's rows are a multiple of 8 cells, a window row is added as the aligned 8-cell
 * blocks that hold it (wpad: each phase's 8 weights between 8 zeros, read shifted by the window's
 * offset in its block; the blocks' other cells get + 0, which leaves them as they are). Neighbouring
 * samples of a tile then read and write either the same aligned block or disjoint ones: the CPU
 * forwards a store to a later load of the same address and size, but a load that only partly
 * overlaps an earlier unaligned store waits for that store to reach the cache, which the
 * unaligned 8-wide rows hit on almost every sample. Every cell receives the same non-zero terms in
 * the same order either way. Both blocks are added whether or not the window reaches the second
 * (it then gets + 0 throughout): whether it does depends on the sample's position, a branch the
 * CPU cannot predict; only where the first block ends the row (ROW_END) is the second left out.
 * The blocks reach 7 cells left and 15 right of the window's first cell, within the tile's margin
 * (see the host).
 *
 * On a grid larger than the cache (`ahead`, the host's choice, the same as the zeroing's), the
 * sample SPREAD_AHEAD places later in the tile has its value and the blocks of its window's last
 * row prefetched: a tile's values lie scattered over r (the caller's order), and the last row is
 * the one a tile's samples reach first in their order (the rows above it were reached by the
 * samples before), so both would otherwise be a wait on memory for most samples. Prefetches move
 * no data the kernel computes with: the additions, and so the bits, are those without them. On a
 * grid the cache holds they only cost instructions. (Holding the blocks of consecutive samples in
 * registers instead of memory costs more than it saves: whether the next sample hits the same
 * blocks, the next ones or others is a branch the CPU cannot predict.) */
#define SPREAD_AHEAD 20
__kernel __attribute__((reqd_work_group_size(1, 1, 1)))
void csi_interp_spread(__global float *restrict c, __global const float *restrict r,
                       __global const uint *restrict cell, __global const uint *restrict ph,
                       __global const uint *restrict perm, __global const float *restrict wt8,
                       __global const float *restrict wpad, const uint mw, const uint mh,
                       __global const uint *restrict tstart, __global const uint *restrict rows,
                       const uint roff, const uint nrows, const uint xoff, const uint Tx,
                       const uint ahead)
{
    const size_t g = get_global_id(0);
    if (g >= nrows)
        return;
    const uint ty = rows[roff + g];
    const bool blocks = mw % 8u == 0u;
    const size_t cells = (size_t)mw * mh;
    for (uint q = 0; q < Tx; q++) {
        const uint t = ty * Tx + rows[xoff + q];
        const uint i1 = tstart[t + 1];
        for (uint i = tstart[t]; i < i1; i++) {
            if (ahead && i + SPREAD_AHEAD < i1) {
                const uint j = i + SPREAD_AHEAD;
                __builtin_prefetch(r + perm[j]);
                /* the two aligned blocks of its window's last row (a window that wraps past the
                 * grid's end prefetches the grid's first cells instead) */
                size_t f = ((size_t)cell[j] + (IW - 1 - IH) * (size_t)mw - IH) & ~(size_t)7;
                f = f + 16 <= cells ? f : 0;
                __builtin_prefetch(c + f);
                __builtin_prefetch(c + f + 8);
            }
            const float v = r[perm[i]];
            const uint p = ph[i];
            __global const float *wx = wt8 + (size_t)(p & 0xffu) * 8;
            __global const float *wy = wt8 + (size_t)((p >> 8) & 0xffu) * 8;
            if ((p & INSIDE) && blocks) {
                const size_t e0 = (size_t)cell[i] - IH * (size_t)mw - IH, s = e0 % 8;
                __global float8 *dst = (__global float8 *)(c + (e0 - s));
                __global const float *wp = wpad + (size_t)(p & 0xffu) * 24 + 8 - s;
                const float8 wlo = vload8(0, wp), whi = vload8(0, wp + 8);
                const size_t rs = mw / 8;
                if (!(p & ROW_END)) {
                    __global float8 *row = dst;
#pragma unroll
                    for (int a = 0; a < IW; a++, row += rs) {
                        const float ta = v * wy[a];
                        row[0] = row[0] + ta * wlo;
                        row[1] = row[1] + ta * whi;
                    }
                } else {
                    /* the block ends the row: the window starts it (s = 0, whi all zeros) */
                    __global float8 *row = dst;
#pragma unroll
                    for (int a = 0; a < IW; a++, row += rs)
                        row[0] = row[0] + (v * wy[a]) * wlo;
                }
            } else if (p & INSIDE) {
                /* 8-wide rows (two extra cells get + 0: within the tile's margin, see the host). */
                __global float *dst = c + (size_t)cell[i] - IH * (size_t)mw - IH;
                const float8 w8 = vload8(0, wx);
#pragma unroll
                for (int a = 0; a < IW; a++) {
                    __global float *row = dst + (size_t)a * mw;
                    vstore8(vload8(0, row) + (v * wy[a]) * w8, 0, row);
                }
            } else {
                const uint mx = cell[i] % mw, my = cell[i] / mw;
                uint rx[IW];
                for (int b = 0; b < IW; b++)
                    rx[b] = wrap_cell(mx, b - IH, mw);
                for (int a = 0; a < IW; a++) {
                    const size_t ry = wrap_cell(my, a - IH, mh);
                    const float va = v * wy[a];
                    for (int b = 0; b < IW; b++)
                        c[ry * mw + rx[b]] += va * wx[b];
                }
            }
        }
    }
}
