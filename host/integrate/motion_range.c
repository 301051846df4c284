/* The range projection of Alg. 2's volume (issue 9's bound, along the basis's motion for issue
 * 12; docs/bench/animation.md).
 *
 * Bounding each cell by the samples in its output pixel and the 8 around it, over all t, is
 * right where the picture is still. Where it moves across the pixels (a pan), a
 * pixel sees over the shutter everything that passes it, and at a few percent of the cells its
 * neighbourhood's handful of samples saw only part of that: the projection cut what moved in
 * (a pan at 3% of the cells went from 0.41x to 0.85x the tuned Gaussian's image MSE). In the
 * frame that moves with the basis's velocity the pan is still, so the neighbourhood is taken
 * there: cell (x, y, t) belongs to the aligned pixel at x - vx (t - tc), y - vy (t - tc). With a
 * still basis the window is the pixel's own, grown where its values change over t
 * (sample_range.c), or, where the samples say little moves, the cell's own 3 x 3 cells. */
#include <math.h>
#include <stdlib.h>

#include "internal.h"

/* The aligned pixel of position (x, y, t) (cells), as the kernel csi_clamp_aligned_range
 * computes it (the same float operations; a position the two place one pixel apart is still
 * inside the other's 3 x 3 window). */
static long aligned(uint32_t x, uint32_t t, float v, float tc, uint32_t b, float o)
{
    return (long)floorf(((float)x + 0.5f - v * ((float)t - tc)) / (float)b + o);
}

csi_status csi_recon_motion_range_clamp(csi_ctx *ctx, const csi_grid *g, const float *values,
                                        uint32_t channels, uint32_t c, const csi_sample_pos *pos,
                                        size_t n, double vx, double vy, bool wide, const float *still_range,
                                        const float *cell_range, cl_mem fine)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const float tc = 0.5f * (float)(g->t - 1);
    /* the aligned frame: the output frame widened by what the motion brings in over tc frames
     * either side, and a pixel more (along an axis it moves along) */
    float ox = vx != 0 ? (float)(ceil(fabs(vx) * tc / bw) + 1) : 0;
    float oy = vy != 0 ? (float)(ceil(fabs(vy) * tc / bh) + 1) : 0;
    size_t aw = g->out_w + 2 * (size_t)ox, ah = g->out_h + 2 * (size_t)oy;
    float fvx = (float)vx, fvy = (float)vy;
    if ((double)aw * (double)ah > (wide ? CSI_MOTION_RANGE_MAX_PIXELS : 1) * (double)np) {
        /* a velocity that takes the content far out of the frame (a given one): the range of
         * all the samples, one pixel holding every cell */
        aw = ah = 1;
        ox = oy = 0;
        fvx = fvy = 0;
        bw = g->w;
        bh = g->h;
    }
    const size_t na = aw * ah;
    /* A still basis: the caller's range of each output pixel (sample_range.c: the pixel's own
     * window, grown where its values change over t). The same rule in the frame of a sheared
     * basis cost the Mitsuba camera slide 1-7% of its image MSE (docs/bench/animation.md,
     * session 30): there the window stays 3 x 3, found here. */
    const bool still = still_range && fvx == 0 && fvy == 0 && na == np;
    /* each cell its own range: the kernel's pixels are the cells */
    const bool by_cells = still && cell_range;
    if (by_cells) {
        bw = bh = 1;
        aw = g->w;
        ah = g->h;
    }
    float *lo = NULL, *hi = NULL, *lohi = NULL;
    cl_mem dev = NULL;
    csi_status s = CSI_OK;
    if (!still && (!(lo = malloc(na * sizeof *lo)) || !(hi = malloc(na * sizeof *hi)) ||
                   !(lohi = malloc(2 * na * sizeof *lohi)))) {
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the sample range along the motion");
        goto done;
    }
    for (size_t p = 0; !still && p < na; p++) {
        lo[p] = INFINITY;
        hi[p] = -INFINITY;
    }
    float all_lo = INFINITY, all_hi = -INFINITY;
    for (size_t i = 0; !still && i < n; i++) {
        all_lo = fminf(all_lo, values[i * channels + c]);
        all_hi = fmaxf(all_hi, values[i * channels + c]);
    }
    if (!(all_lo <= all_hi)) {
        all_lo = -INFINITY; /* no sample at all: nothing to clamp to */
        all_hi = INFINITY;
    }
    for (size_t i = 0; !still && i < n; i++) {
        const long ax = aligned(pos[i].x, pos[i].t, fvx, tc, bw, ox);
        const long ay = aligned(pos[i].y, pos[i].t, fvy, tc, bh, oy);
        if (ax < 0 || ay < 0 || ax >= (long)aw || ay >= (long)ah)
            continue; /* not reached: the frame is widened by the whole motion */
        const size_t p = (size_t)ay * aw + (size_t)ax;
        const float v = values[i * channels + c];
        lo[p] = fminf(lo[p], v);
        hi[p] = fmaxf(hi[p], v);
    }
    for (size_t p = 0; !still && p < na; p++) {
        const long px = (long)(p % aw), py = (long)(p / aw);
        float l = INFINITY, h = -INFINITY;
        for (long y = py - 1; y <= py + 1; y++)
            for (long x = px - 1; x <= px + 1; x++)
                if (x >= 0 && y >= 0 && x < (long)aw && y < (long)ah) {
                    l = fminf(l, lo[(size_t)y * aw + (size_t)x]);
                    h = fmaxf(h, hi[(size_t)y * aw + (size_t)x]);
                }
        /* No sample around (the aligned frame's edges, which the motion shows for a few frames
         * only): the range of all the samples, so that non-negative samples still give a
         * non-negative volume. */
        lohi[2 * p] = l <= h ? l : all_lo;
        lohi[2 * p + 1] = l <= h ? h : all_hi;
    }
    cl_kernel kc;
    const cl_uint w = g->w, hh = g->h, cbw = bw, cbh = bh, caw = (cl_uint)aw, cah = (cl_uint)ah;
    const cl_uint cells = (cl_uint)((size_t)g->w * g->h * g->t);
    /* the buffer csi/plan.h counts: the widest aligned frame (wide) or the output frame, at
     * least the cells' frame (whether the cells take their own ranges is decided from the
     * samples; the buffer does not depend on it, so that the plan is the run's) */
    const size_t cap = csi_recon_motion_range_cap(g, wide);
    s = csi_buffer(ctx, 2 * cap * sizeof(float), CL_MEM_READ_ONLY, "the sample range", &dev);
    if (s == CSI_OK)
        s = csi_write(ctx, dev, 0, 2 * (by_cells ? (size_t)g->w * g->h : na) * sizeof(float),
                      by_cells ? cell_range : still ? still_range : lohi);
    if (s == CSI_OK)
        s = csi_kernel(ctx, "recon", "csi_clamp_aligned_range", &kc);
    if (s == CSI_OK)
        s = CSI_ARGS(kc, CSI_MEM(fine), CSI_MEM(dev), CSI_ARG(w), CSI_ARG(hh), CSI_ARG(cbw), CSI_ARG(cbh),
                     CSI_ARG(caw), CSI_ARG(cah), CSI_ARG(fvx), CSI_ARG(fvy), CSI_ARG(ox), CSI_ARG(oy),
                     CSI_ARG(tc), CSI_ARG(cells));
    if (s == CSI_OK)
        s = csi_run1d(ctx, kc, cells);
    if (s == CSI_OK)
        s = csi_finish(ctx); /* dev is released below */
done:
    csi_buffer_release(&dev);
    free(lo), free(hi), free(lohi);
    return s;
}

size_t csi_recon_motion_range_cap(const csi_grid *g, bool wide)
{
    const size_t np = (size_t)g->out_w * g->out_h, wh = (size_t)g->w * g->h;
    const size_t cap = wide ? CSI_MOTION_RANGE_MAX_PIXELS * np : np;
    return wh > cap ? wh : cap;
}
