/* The velocity of Alg. 2's motion basis, estimated from the samples (csi's extension; issue 12,
 * docs/bench/animation.md).
 *
 * A shear of the basis by the velocity v at which most of the scene moves (a camera pan, a large
 * mover) makes that content static in the aligned volume, so its spectrum collapses onto the
 * temporal DC plane (Egan et al. 2009: motion concentrates the spectrum on a sheared plane). The
 * velocity is chosen in two steps:
 *  1. candidates: the velocities whose motion-compensated temporal mean keeps most of the energy
 *     of a rough estimate f0 (the Gaussian normalized convolution of the samples),
 *         E(v) = sum_u |sum_t F_t(u) exp(+2 pi i <u, v> (t - tc))|^2,
 *     F_t the spatial spectrum of frame t of f0 at low frequencies (the spatial-axis lines left
 *     out: the frame's border is static and would pull towards v = 0), searched coarse to fine:
 *     the peak of E is 1 / (f_c T) wide for frequencies up to f_c, so a coarse grid on the lowest
 *     frequencies finds it and higher frequencies sharpen it;
 *  2. selection and refinement by leave-one-out cross-validation: the normalized convolution along
 *     v (csi/motion_filter.h) predicts every sample from the others,
 *         pred_i = (num_i - w0 y_i) / (den_i - w0),  num = G_v S^T y, den = G_v S^T 1,
 *     and the velocity with the smallest mean squared prediction error wins. It replaces v = 0
 *     only if it is at least 3% better on the mean of the squared errors, and more of the grid's
 *     4 x 4-cell blocks (their samples' errors summed) are predicted better than worse, by one
 *     standard error of that count (a sign test: improved share > 1/2 + 1/(2 sqrt(blocks))):
 *     one global velocity fits a pan (most of the picture predicted better) but not a mover
 *     over a still background, whose own samples it predicts much better (the mean drops) and
 *     the rest no better (the share stays near one half). Blocks, not samples: a block's sum
 *     averages its samples' noise, and with one path a sample the samples' own comparisons were
 *     near chance for a pan and a mover alike (docs/bench/animation.md, sessions 30 and 41).
 *     Last, it must be 3% better than its mirror -v too, which a still texture of one
 *     orientation predicts as well as v (session 44). The rough estimate's own time blur biases
 *     E's peak towards v = 0 by a few percent; the cross-validation does not depend on it.
 * Everything large runs on the device; the host steers with a few thousand numbers. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/motion_filter.h"
#include "csi/spectral.h"
#include "internal.h"

#define PI_ 3.14159265358979323846
#define NCAND 3
#define MAXSEEN 256
/* The side, in cells, of the blocks the acceptance's sign test counts (block_share) */
#define CSI_VELOCITY_BLOCK 4

typedef struct {
    csi_ctx *ctx;
    const csi_grid *g;
    csi_fourier_half *h;
    csi_linop *G; /* the motion filter (its widths set for each use) */
    const csi_linop *S;
    cl_mem va, vb, ydev, gat;
    cl_mem z1, zy; /* the frames' spatial spectra of S^T 1 and S^T y: the same for every velocity */
    const float *y;
    size_t n, k;
    float *ones, *num, *den;
    double *w0, ymean;
    float *err, *err0, *errb; /* per-sample squared errors: the last evaluation's, v = 0's, the best's */
    int evals;
    const csi_recon_options *opt; /* its progress callback hears of every step */
    int steps;                    /* the search's steps so far, for the progress */
    double seen[MAXSEEN][2]; /* the velocities evaluated so far (the first MAXSEEN) */
    int nseen;
} vel_ctx;

/* ---- step 1: the energy of the motion-compensated mean ------------------------------------ */

/* The low-frequency block of the frames' spectra, over the half axis a (x, or y when x has
 * length 1) and the other spatial axis b (y; absent, nb = 1, when the volume has one). */
typedef struct {
    size_t na, nb, T;
    size_t K0, K1;    /* u0 = 1 .. K0 along a, u1 = -K1 .. K1 along b (K1 = 0 without b) */
    double *re, *im;  /* [(t (2 K1 + 1) + (u1 + K1)) (K0 + 1) + u0] */
} lowspec;

/* E(v) (va, vb: the velocity along a and b) over |u0| <= L0, |u1| <= L1, normalised by the energy
 * of those frequencies. The lines u0 = 0 and u1 = 0 are left out: the frame's borders are
 * static edges along them. */
static double energy(const lowspec *s, size_t L0, size_t L1, double va, double vb)
{
    const size_t T = s->T, r1 = 2 * s->K1 + 1, r0 = s->K0 + 1;
    const double tc = 0.5 * ((double)T - 1.0);
    double num = 0, tot = 0;
    for (size_t j = s->K1 - L1; j <= s->K1 + L1; j++) {
        if (s->nb > 1 && j == s->K1)
            continue;
        const double fb = s->nb > 1 ? ((double)j - (double)s->K1) / (double)s->nb : 0.0;
        for (size_t u0 = 1; u0 <= L0; u0++) {
            const double ph = 2.0 * PI_ * ((double)u0 / (double)s->na * va + fb * vb);
            /* exp(i ph (t - tc)) by recurrence from t = 0 */
            double cr = cos(-ph * tc), ci = sin(-ph * tc), dr = cos(ph), di = sin(ph);
            double ar = 0, ai = 0;
            for (size_t t = 0; t < T; t++) {
                const size_t o = (t * r1 + j) * r0 + u0;
                const double xr = s->re[o], xi = s->im[o];
                ar += xr * cr - xi * ci;
                ai += xr * ci + xi * cr;
                tot += xr * xr + xi * xi;
                const double nr = cr * dr - ci * di;
                ci = cr * di + ci * dr;
                cr = nr;
            }
            num += ar * ar + ai * ai;
        }
    }
    return tot > 0 ? num / ((double)T * tot) : 0.0;
}

typedef struct {
    double e, va, vb;
} cand;

static void keep_best(cand *best, int nbest, cand c)
{
    for (int i = 0; i < nbest; i++)
        if (c.e > best[i].e) {
            memmove(best + i + 1, best + i, (size_t)(nbest - 1 - i) * sizeof *best);
            best[i] = c;
            return;
        }
}

/* Frequencies (bins of an axis of n) up to f_c = 1 / (2 step T) cycles per cell, where E's peak
 * is about two grid steps wide; within [1, K]. */
static size_t cutoff(size_t n, double step, size_t T, size_t K)
{
    double L = (double)n / (2.0 * step * (double)T);
    return L < 1 ? 1 : L > (double)K ? K : (size_t)L;
}

/* The search's progress: phase "velocity search", `done` its steps so far (0 at its start, the
 * rough estimate's two filters and its spectra, rows of the energy's grid, then leave-one-out
 * evaluations); CSI_ERR_CANCELLED when the callback asks to stop. On a
 * volume of hundreds of frames the search is long work of its own (the energy's sums run over
 * every frame), which a log should show advancing. */
static csi_status report(const csi_recon_options *opt, int done)
{
    return csi_recon_progress_step(opt, "velocity search", done);
}

/* Coarse-to-fine search of E's peaks over |v| <= vmax along each axis: NCAND candidates (e < 0
 * where fewer were found). */
static csi_status energy_search(const lowspec *s, double vmax_a, double vmax_b, const csi_recon_options *opt,
                                int *done, cand *out)
{
    const int steps = 16; /* grid points either side of 0 on the first level */
    double sa = vmax_a / steps, sb = vmax_b / steps;
    const int nb = s->nb > 1 ? steps : 0;
    cand best[NCAND];
    for (int i = 0; i < NCAND; i++)
        best[i] = (cand){-1, 0, 0};
    size_t L0 = cutoff(s->na, sa, s->T, s->K0), L1 = s->nb > 1 ? cutoff(s->nb, sb, s->T, s->K1) : 0;
    for (int ib = -nb; ib <= nb; ib++) {
        for (int ia = -steps; ia <= steps; ia++)
            keep_best(best, NCAND, (cand){energy(s, L0, L1, ia * sa, ib * sb), ia * sa, ib * sb});
        CSI_TRY(report(opt, ++*done));
    }
    /* refine each: halve the step and take the frequencies that match it */
    for (int level = 0; level < 6; level++) {
        sa *= 0.5;
        sb *= 0.5;
        L0 = cutoff(s->na, sa, s->T, s->K0);
        L1 = s->nb > 1 ? cutoff(s->nb, sb, s->T, s->K1) : 0;
        cand next[NCAND];
        for (int i = 0; i < NCAND; i++)
            next[i] = (cand){-1, 0, 0};
        for (int i = 0; i < NCAND; i++) {
            if (best[i].e < 0)
                continue;
            cand top = {-1, 0, 0};
            for (int ib = -(nb ? 2 : 0); ib <= (nb ? 2 : 0); ib++)
                for (int ia = -2; ia <= 2; ia++) {
                    double va = best[i].va + ia * sa, vb = best[i].vb + ib * sb;
                    double e = energy(s, L0, L1, va, vb);
                    if (e > top.e)
                        top = (cand){e, va, vb};
                }
            keep_best(next, NCAND, top);
            CSI_TRY(report(opt, ++*done));
        }
        memcpy(best, next, sizeof best);
    }
    memcpy(out, best, sizeof best);
    return CSI_OK;
}

/* ---- step 2: leave-one-out ---------------------------------------------------------------- */

/* out[i] = (G_v S^T in)[idx_i] from zs, the frames' spatial spectra of S^T in (in: ydev or the
 * ones): G_v's spatial transform is done once for all the velocities (spatial_spectra). */
static csi_status filtered_at_samples(vel_ctx *c, cl_mem zs, float *out)
{
    CSI_TRY(csi_motion_filter_apply_spatial(c->G, zs, c->va));
    CSI_TRY(csi_linop_apply(c->S, c->va, c->gat));
    return csi_read(c->ctx, c->gat, 0, c->n * 4, out);
}

/* The frames' spatial spectra of S^T 1 and S^T y (c->z1, c->zy), for every evaluation. */
static csi_status spatial_spectra(vel_ctx *c)
{
    const size_t bytes = csi_fourier_half_count(c->h) * 8;
    CSI_TRY(csi_buffer(c->ctx, bytes, CL_MEM_READ_WRITE, "the velocity search's spectra", &c->z1));
    CSI_TRY(csi_buffer(c->ctx, bytes, CL_MEM_READ_WRITE, "the velocity search's spectra", &c->zy));
    CSI_TRY(csi_write(c->ctx, c->gat, 0, c->n * 4, c->ones));
    CSI_TRY(csi_linop_adjoint(c->S, c->gat, c->va));
    CSI_TRY(csi_fourier_half_forward_space(c->h, c->va, c->z1));
    CSI_TRY(csi_linop_adjoint(c->S, c->ydev, c->va));
    return csi_fourier_half_forward_space(c->h, c->va, c->zy);
}

static csi_status loo(vel_ctx *c, double vx, double vy, const uint32_t *tof, double *score)
{
    const size_t dims[3] = {c->g->w, c->g->h, c->g->t};
    CSI_TRY(csi_fourier_half_set_motion(c->h, dims, CSI_TIME_DCT, vx, vy));
    CSI_TRY(filtered_at_samples(c, c->z1, c->den));
    CSI_TRY(filtered_at_samples(c, c->zy, c->num));
    double e = 0;
    for (size_t i = 0; i < c->n; i++) {
        const double w0 = c->w0[tof[i]], d = c->den[i] - w0;
        /* a sample with no neighbour within the kernel's reach is predicted by the mean */
        const double p = d > 0.05 * w0 ? (c->num[i] - w0 * c->y[i]) / d : c->ymean;
        c->err[i] = (float)((p - c->y[i]) * (p - c->y[i]));
        e += c->err[i];
    }
    *score = e / (double)c->n;
    c->evals++;
    return report(c->opt, ++c->steps);
}

/* The leave-one-out error of (vx, vy); it becomes the best (*best, *bx, *by) when lower. */
static csi_status try_velocity(vel_ctx *c, double vx, double vy, const uint32_t *tof, double *best,
                               double *bx, double *by, bool *better)
{
    double e;
    *better = false;
    /* a velocity evaluated before was not better than the best of its time, and the best only
     * improves since: the coordinate search's steps back (and repeats) cost nothing */
    for (int i = 0; i < c->nseen; i++)
        if (c->seen[i][0] == vx && c->seen[i][1] == vy)
            return CSI_OK;
    if (c->nseen < MAXSEEN) {
        c->seen[c->nseen][0] = vx;
        c->seen[c->nseen][1] = vy;
        c->nseen++;
    }
    CSI_TRY(loo(c, vx, vy, tof, &e));
    if (e < *best) {
        *best = e;
        *bx = vx;
        *by = vy;
        *better = true;
        memcpy(c->errb, c->err, c->n * sizeof *c->err);
    }
    return CSI_OK;
}

/* The share of the grid's blocks of CSI_VELOCITY_BLOCK x CSI_VELOCITY_BLOCK cells (over all t)
 * that the best velocity predicts better than v = 0: those whose samples' squared leave-one-out
 * errors sum lower (paired). *blocks: how many blocks hold a sample. A block's sum averages its
 * samples' noise, which a sample's own comparison does not: with one path a sample, a pan
 * improves 0.52 of the samples and 0.57-0.74 of the blocks, a ball over a still background
 * 0.51-0.55 of the samples and 0.48-0.52 of the blocks. */
static csi_status block_share(const vel_ctx *c, const uint32_t *idx, double *share, size_t *blocks)
{
    const csi_grid *g = c->g;
    const size_t B = CSI_VELOCITY_BLOCK, wh = (size_t)g->w * g->h;
    const size_t bw = (g->w + B - 1) / B, nb = bw * ((g->h + B - 1) / B);
    double *gain = calloc(nb, sizeof *gain);
    unsigned char *held = calloc(nb, 1);
    if (!gain || !held) {
        free(gain);
        free(held);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the velocity search's %zu blocks", nb);
    }
    for (size_t i = 0; i < c->n; i++) {
        const size_t r = idx[i] % wh, b = (r / g->w / B) * bw + r % g->w / B;
        gain[b] += (double)c->err0[i] - (double)c->errb[i];
        held[b] = 1;
    }
    size_t used = 0, up = 0;
    for (size_t b = 0; b < nb; b++) {
        used += held[b];
        up += held[b] && gain[b] > 0;
    }
    free(gain);
    free(held);
    *share = used ? (double)up / (double)used : 0;
    *blocks = used;
    return CSI_OK;
}

/* The rough estimate's low-frequency frame spectra (step 1's input). */
static csi_status low_spectra(vel_ctx *c, double sigma, cl_mem z, lowspec *s)
{
    const csi_grid *g = c->g;
    const size_t dims[3] = {g->w, g->h, g->t}, T = g->t;
    /* f0 = G0 S^T y / G0 S^T 1 (G0 the Gaussian of the baseline's width, mirrored ends): the
     * density in va, the numerator in vb, their ratio in vb */
    CSI_TRY(csi_fourier_half_set_motion(c->h, dims, CSI_TIME_DCT, 0, 0));
    CSI_TRY(csi_motion_filter_set(c->G, CSI_TIME_DCT, sigma, sigma));
    CSI_TRY(csi_write(c->ctx, c->gat, 0, c->n * 4, c->ones));
    CSI_TRY(csi_linop_adjoint(c->S, c->gat, c->va));
    CSI_TRY(csi_linop_apply(c->G, c->va, c->va)); /* in place: csi/motion_filter.h */
    CSI_TRY(report(c->opt, ++c->steps));
    CSI_TRY(csi_linop_adjoint(c->S, c->ydev, c->vb));
    CSI_TRY(csi_linop_apply(c->G, c->vb, c->vb));
    CSI_TRY(report(c->opt, ++c->steps));
    cl_kernel div;
    CSI_TRY(csi_kernel(c->ctx, "recon", "csi_nc_divide", &div));
    cl_uint nk = (cl_uint)c->k;
    float eps = (float)(1e-6 / pow(sqrt(2 * PI_) * sigma, 3));
    const float lo = -INFINITY, hi = INFINITY;
    CSI_TRY(CSI_ARGS(div, CSI_MEM(c->vb), CSI_MEM(c->va), CSI_MEM(c->vb), CSI_ARG(nk), CSI_ARG(eps), CSI_ARG(lo),
                     CSI_ARG(hi)));
    CSI_TRY(csi_run1d(c->ctx, div, c->k));
    /* per-frame spectra of f0 */
    CSI_TRY(csi_fourier_half_set_motion(c->h, dims, CSI_TIME_NONE, 0, 0));
    CSI_TRY(csi_fourier_half_forward(c->h, c->vb, z));
    CSI_TRY(report(c->opt, ++c->steps));
    csi_status st = CSI_OK;
    /* the block of low frequencies, one read per (t, u1) row */
    s->na = g->w > 1 ? g->w : g->h;
    s->nb = g->w > 1 && g->h > 1 ? g->h : 1;
    s->T = T;
    s->K0 = s->na / 8 > 0 ? s->na / 8 : 1;
    s->K1 = s->nb > 1 ? (s->nb / 8 > 0 ? s->nb / 8 : 1) : 0;
    const size_t r0 = s->K0 + 1, r1 = 2 * s->K1 + 1, hs = csi_fourier_half_stride(c->h), nb = s->nb;
    s->re = malloc(r0 * r1 * T * sizeof *s->re);
    s->im = malloc(r0 * r1 * T * sizeof *s->im);
    float *row = malloc(r0 * 8);
    if (!s->re || !s->im || !row) {
        free(row);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the velocity search");
    }
    for (size_t t = 0; t < T && st == CSI_OK; t++)
        for (size_t j = 0; j < r1 && st == CSI_OK; j++) {
            const size_t u1 = (j + nb - s->K1) % nb;
            st = csi_read(c->ctx, z, ((t * nb + u1) * hs) * 8, r0 * 8, row);
            for (size_t u = 0; u < r0; u++) {
                s->re[(t * r1 + j) * r0 + u] = row[2 * u];
                s->im[(t * r1 + j) * r0 + u] = row[2 * u + 1];
            }
        }
    free(row);
    return st;
}

csi_status csi_motion_velocity_estimate(csi_ctx *ctx, const csi_grid *g, csi_fourier_half *h,
                                        csi_linop *G, cl_mem z, cl_mem va, cl_mem vb,
                                        const csi_linop *S, cl_mem ydev, cl_mem gat, const float *y,
                                        const uint32_t *idx, size_t n, const csi_recon_options *opt,
                                        csi_motion_velocity *out)
{
    memset(out, 0, sizeof *out);
    const double t0 = csi_recon_now();
    if (g->t < 2 || (g->w < 2 && g->h < 2))
        return csi_fail(CSI_ERR_ARG, "velocity search: the volume needs a time axis and a spatial one");
    vel_ctx c;
    memset(&c, 0, sizeof c);
    c.ctx = ctx;
    c.opt = opt;
    c.g = g;
    c.h = h;
    c.G = G;
    c.S = S;
    c.va = va;
    c.vb = vb;
    c.ydev = ydev;
    c.gat = gat;
    c.y = y;
    c.n = n;
    c.k = (size_t)g->w * g->h * g->t;
    const size_t T = g->t, wh = (size_t)g->w * g->h;
    lowspec s;
    memset(&s, 0, sizeof s);
    uint32_t *tof = malloc(n * sizeof *tof);
    c.ones = malloc(n * sizeof *c.ones);
    c.num = malloc(n * sizeof *c.num);
    c.den = malloc(n * sizeof *c.den);
    c.w0 = malloc(T * sizeof *c.w0);
    c.err = malloc(n * sizeof *c.err);
    c.err0 = malloc(n * sizeof *c.err0);
    c.errb = malloc(n * sizeof *c.errb);
    csi_status st = tof && c.ones && c.num && c.den && c.w0 && c.err && c.err0 && c.errb
                        ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the velocity search");
    for (size_t i = 0; st == CSI_OK && i < n; i++) {
        tof[i] = (uint32_t)(idx[i] / wh);
        c.ones[i] = 1.0f;
        c.ymean += y[i] / (double)n;
    }
    if (st == CSI_OK)
        st = csi_write(ctx, ydev, 0, n * 4, y);
    const double k = (double)c.k, rate = (double)n / k;
    if (st == CSI_OK)
        st = report(opt, 0);
    if (st == CSI_OK)
        st = low_spectra(&c, csi_gauss_nc_default_sigma(c.k, n, 3), z, &s);
    cand cands[NCAND];
    if (st == CSI_OK) {
        /* up to three quarters of the frame over the shutter */
        const double span = 0.75 / (double)(T - 1);
        st = energy_search(&s, span * (double)s.na, span * (double)s.nb, opt, &c.steps, cands);
    }
    /* the leave-one-out kernel: sigma_t = T / 8 frames (at most 8, at least 1), sigma_xy such
     * that about 4 samples fall within one sigma of a cell (at least 0.7 cells) */
    const double sig_t = fmax(1.0, fmin(8.0, (double)T / 8.0));
    const double sig_xy = fmax(0.7, sqrt(4.0 / (rate * 2.0 * PI_ * sqrt(2.0 * PI_) * sig_t)));
    if (st == CSI_OK) {
        const size_t dims[3] = {g->w, g->h, g->t};
        csi_motion_filter_self_weight(dims, CSI_TIME_DCT, sig_xy, sig_t, c.w0);
        st = csi_motion_filter_set(G, CSI_TIME_DCT, sig_xy, sig_t);
    }
    if (st == CSI_OK)
        st = spatial_spectra(&c);
    double best = 0, bx = 0, by = 0;
    if (st == CSI_OK)
        st = loo(&c, 0, 0, tof, &out->loo0);
    c.nseen = 1; /* v = 0, zero-initialised */
    if (st == CSI_OK) {
        memcpy(c.err0, c.err, n * sizeof *c.err);
        memcpy(c.errb, c.err, n * sizeof *c.err);
    }
    best = out->loo0;
    for (int i = 0; i < NCAND && st == CSI_OK; i++) {
        if (cands[i].e < 0)
            continue;
        bool better;
        st = try_velocity(&c, g->w > 1 ? cands[i].va : 0, g->w > 1 ? cands[i].vb : cands[i].va,
                          tof, &best, &bx, &by, &better);
    }
    /* coordinate search from the best, the step halved down to a quarter cell of drift over
     * the shutter; only when the best candidate already passes the acceptance's sign test
     * (below): a mover's velocity over a still background does not, and a refinement along it
     * costs 20-60 evaluations and could walk into a velocity that passes by chance (Mitsuba's
     * ball at 16 paths a sample, 3% of the cells: 1.5x the still basis's image MSE) */
    double step = 0.25;
    const double finest = 0.25 / (double)(T - 1);
    double share = 0;
    size_t blocks = 0;
    if (st == CSI_OK && (bx != 0 || by != 0))
        st = block_share(&c, idx, &share, &blocks);
    const bool refine = st == CSI_OK && (bx != 0 || by != 0) && blocks && share > 0.5 + 0.5 / sqrt((double)blocks);
    /* at most MAXSEEN velocities in all: every step must improve, but nothing bounds the walk,
     * and a volume of 8x8x35 cells with 30 samples (tests/fuzz/corpus/recon/velocity_walk) kept
     * improving for 1,112 evaluations (the volumes of fuzz_recon's corpus took 14 on average) */
    while (st == CSI_OK && refine && step >= finest && c.nseen < MAXSEEN) {
        bool moved = true;
        while (moved && st == CSI_OK && c.nseen < MAXSEEN) {
            moved = false;
            static const int d[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
            for (int i = 0; i < 4 && st == CSI_OK; i++) {
                double vx = bx + d[i][0] * step, vy = by + d[i][1] * step;
                if ((g->w < 2 && vx != 0) || (g->h < 2 && vy != 0))
                    continue;
                bool better;
                st = try_velocity(&c, vx, vy, tof, &best, &bx, &by, &better);
                moved = moved || better;
            }
        }
        step *= 0.5;
    }
    if (st == CSI_OK && refine)
        st = block_share(&c, idx, &share, &blocks);
    out->improved = share;
    /* accepted when it predicts the samples 3% better on the whole, and more of the blocks
     * better than worse by one standard error of that count (a sign test at one sigma): a pan
     * improves most of the picture, one mover over a still background a few blocks by much,
     * which lowers the mean (to 0.67-0.91 on billiards and anim_ball, where the still basis's
     * image was better) but leaves the other blocks' comparisons to chance. (Until session 41 the
     * test was on the samples, with the median sample 5% better: with one path a sample the
     * noise left both near their v = 0 values, refusing Mitsuba's camera pan, median 0.96-0.97,
     * and passing its ball, 0.51-0.55 of the samples better; docs/bench/animation.md.) */
    const bool most = blocks && share > 0.5 + 0.5 / sqrt((double)blocks);
    /* and when it predicts them 3% better than its mirror -v too: a still texture of one
     * orientation (stripes, a sinusoid, long edges) is predicted as well along any direction it
     * holds constant, +v and -v alike, and a shear along it fits no better than the still basis
     * (a still sinusoid sheared along its wavefronts: 5.7x the still basis's image MSE,
     * tests/python/test_volume_grid.py); content that moves at v is predicted worse at -v than
     * at 0, so the mirror never refuses what v = 0's test passes there. */
    bool unlike_mirror = false;
    if (st == CSI_OK && best < 0.97 * out->loo0 && most) {
        double mirror;
        st = loo(&c, -bx, -by, tof, &mirror);
        unlike_mirror = st == CSI_OK && best < 0.97 * mirror;
    }
    if (st == CSI_OK && unlike_mirror) {
        out->v[0] = bx;
        out->v[1] = by;
        out->loo = best;
    } else {
        out->loo = out->loo0;
    }
    out->evaluations = c.evals;
    out->seconds = csi_recon_now() - t0;
    csi_buffer_release(&c.z1);
    csi_buffer_release(&c.zy);
    free(tof);
    free(c.ones);
    free(c.num);
    free(c.den);
    free(c.w0);
    free(c.err);
    free(c.err0);
    free(c.errb);
    free(s.re);
    free(s.im);
    return st;
}

void csi_motion_velocity_buffers(const size_t dims[3], csi_mem_tally *t)
{
    const uint64_t bytes = (uint64_t)csi_fourier_half_count_for(dims) * 8;
    csi_mem_tally_add(t, bytes, "the velocity search's spectra");
    csi_mem_tally_add(t, bytes, "the velocity search's spectra");
}

uint64_t csi_motion_velocity_host_bytes(const csi_grid *g, size_t n)
{
    const uint64_t na = g->w > 1 ? g->w : g->h, nb = g->w > 1 && g->h > 1 ? g->h : 1;
    const uint64_t r0 = (na / 8 > 0 ? na / 8 : 1) + 1, r1 = nb > 1 ? 2 * (nb / 8 > 0 ? nb / 8 : 1) + 1 : 1;
    const uint64_t blocks = ((uint64_t)g->w + CSI_VELOCITY_BLOCK - 1) / CSI_VELOCITY_BLOCK *
                            (((uint64_t)g->h + CSI_VELOCITY_BLOCK - 1) / CSI_VELOCITY_BLOCK);
    return r0 * r1 * g->t * 16 + r0 * 8 + (uint64_t)n * 28 + (uint64_t)g->t * 8 + blocks * 9;
}
