/* Interpolation from a model grid at samples on a finer grid, and the adjoint spreading (see
 * csi/interp.h; kernels/interp.cl).
 *
 * The host groups the samples by tile of the model grid (tiles of at least TILE_H rows x TILE_W
 * columns, row by row) and colours the tiles along each axis so that two tiles of one colour
 * never write the same model cell. The spreading runs one work-item per row of tiles, adding the
 * samples' terms one after another, the row's tiles in the order of their colour along x, and
 * launches the rows one colour along y at a time: every cell receives its terms in the order of
 * the tiles' colour (y, then x) and, within a tile, of its samples. A row's band of the grid stays
 * in the cache from one colour of its tiles to the next. The gather reads the samples in the
 * same order (neighbouring samples, neighbouring cells). */
#include "csi/interp.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PI_ 3.14159265358979323846
/* The kernel's shape: beta = 2.1 w. Measured on the Alg. 1 operator (tests/data/interp/
 * gen_refs.py): 2.0-2.2 w gave the smallest error over white noise and image-like signals. */
#define BETA (2.1 * CSI_INTERP_TAPS)
#define IH (CSI_INTERP_TAPS / 2 - 1)
/* Tile size: larger than the kernel's reach on either side (IH left, w - 1 - IH right; the
 * spreading's aligned blocks reach 7 cells further left and 15 - (w - 1 - IH) further right,
 * kernels/interp.cl), so that tiles two apart never touch the same cell; wide along x for
 * contiguous rows. */
#define TILE_W 64
#define TILE_H 8
/* Cells per work-item of the zeroing before the spreading (kernels/interp.cl, ZERO_LINES lines
 * of 16). */
#define ZERO_CELLS (1024 * 16)
/* The largest grid zeroed with plain stores before the spreading, which then finds it in the
 * cache; a larger one is zeroed with non-temporal stores (kernels/interp.cl): measured between
 * the two (docs/bench/cost.md, session 19). On a larger one the spreading and the gather also
 * prefetch ahead of their samples (kernels/interp.cl), which on a grid in the cache only costs
 * time. */
#define ZERO_CACHED_BYTES ((size_t)8 << 20)
/* Samples per work-item of the gather. */
#define GATHER_CHUNK 256

double csi_interp_kernel(double z)
{
    double u = 2.0 * z / CSI_INTERP_TAPS;
    if (!(fabs(u) < 1.0))
        return 0.0;
    return exp(BETA * (sqrt(1.0 - u * u) - 1.0));
}

/* Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n from Chebyshev guesses). */
#define GL_N 48
static void gauss_legendre(double *x, double *w)
{
    for (int i = 0; i < GL_N; i++) {
        double z = cos(PI_ * (i + 0.75) / (GL_N + 0.5)), pp = 0.0;
        for (int it = 0; it < 100; it++) {
            double p1 = 1.0, p2 = 0.0;
            for (int j = 1; j <= GL_N; j++) {
                double p3 = p2;
                p2 = p1;
                p1 = ((2.0 * j - 1.0) * z * p2 - (j - 1.0) * p3) / j;
            }
            pp = GL_N * (z * p1 - p2) / (z * z - 1.0);
            double dz = p1 / pp;
            z -= dz;
            if (fabs(dz) < 1e-15)
                break;
        }
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * pp * pp);
    }
}

double csi_interp_kernel_ft(double xi)
{
    static double gx[GL_N], gw[GL_N];
    static int ready;
    if (!ready) { /* deterministic; the same values whichever thread fills them */
        gauss_legendre(gx, gw);
        ready = 1;
    }
    /* phi is even: 2 * integral over [0, w/2] of phi(z) cos(2 pi xi z). */
    const double half = CSI_INTERP_TAPS / 2.0;
    double s = 0.0;
    for (int i = 0; i < GL_N; i++) {
        double z = 0.5 * half * (gx[i] + 1.0);
        s += gw[i] * csi_interp_kernel(z) * cos(2.0 * PI_ * xi * z);
    }
    return s * half;
}

typedef struct {
    size_t mw, mh, n;
    cl_mem cell, ph, perm, wt8, wpad, tstart;
    cl_mem rows;       /* the rows of tiles by colour along y, then the tile columns by colour along x */
    size_t Tx, Ty;
    size_t row_off[4]; /* rows of colour c: rows[row_off[c] .. row_off[c + 1]) */
} interp_state;

/* The model grid is larger than the cache: zeroed with non-temporal stores before the spreading,
 * and read and written by prefetching gathers and spreadings (ZERO_CACHED_BYTES). */
static cl_uint beyond_cache(const interp_state *s)
{
    return s->mw * s->mh * sizeof(float) > ZERO_CACHED_BYTES;
}

static csi_status interp_apply(const csi_linop *op, cl_mem c, cl_mem y)
{
    interp_state *s = op->state;
    cl_kernel k;
    CSI_TRY(csi_kernel(op->ctx, "interp", "csi_interp_gather", &k));
    cl_uint mw = (cl_uint)s->mw, mh = (cl_uint)s->mh, chunk = GATHER_CHUNK, n = (cl_uint)s->n;
    const cl_uint ahead = beyond_cache(s);
    CSI_TRY(CSI_ARGS(k, CSI_MEM(c), CSI_MEM(y), CSI_MEM(s->cell), CSI_MEM(s->ph), CSI_MEM(s->perm),
                     CSI_MEM(s->wt8), CSI_ARG(mw), CSI_ARG(mh), CSI_ARG(chunk), CSI_ARG(n),
                     CSI_ARG(ahead)));
    size_t g = (s->n + GATHER_CHUNK - 1) / GATHER_CHUNK, l = 1;
    return csi_run(op->ctx, k, 1, &g, &l);
}

static csi_status interp_adjoint(const csi_linop *op, cl_mem r, cl_mem c)
{
    interp_state *s = op->state;
    csi_ctx *ctx = op->ctx;
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "interp", "csi_interp_zero", &k));
    const cl_uint cells = (cl_uint)(s->mw * s->mh), stream = beyond_cache(s);
    CSI_TRY(CSI_ARGS(k, CSI_MEM(c), CSI_ARG(cells), CSI_ARG(stream)));
    size_t zl = 1, zg = (s->mw * s->mh + ZERO_CELLS - 1) / ZERO_CELLS;
    CSI_TRY(csi_run(ctx, k, 1, &zg, &zl));
    CSI_TRY(csi_kernel(ctx, "interp", "csi_interp_spread", &k));
    cl_uint mw = (cl_uint)s->mw, mh = (cl_uint)s->mh, Tx = (cl_uint)s->Tx, xoff = (cl_uint)s->Ty;
    for (int col = 0; col < 3; col++) {
        size_t first = s->row_off[col], count = s->row_off[col + 1] - first;
        if (count == 0)
            continue;
        cl_uint roff = (cl_uint)first, nrows = (cl_uint)count;
        CSI_TRY(CSI_ARGS(k, CSI_MEM(c), CSI_MEM(r), CSI_MEM(s->cell), CSI_MEM(s->ph),
                         CSI_MEM(s->perm), CSI_MEM(s->wt8), CSI_MEM(s->wpad), CSI_ARG(mw),
                         CSI_ARG(mh), CSI_MEM(s->tstart), CSI_MEM(s->rows), CSI_ARG(roff), CSI_ARG(nrows),
                         CSI_ARG(xoff), CSI_ARG(Tx), CSI_ARG(stream)));
        size_t l = 1, g = count;
        CSI_TRY(csi_run(ctx, k, 1, &g, &l));
    }
    return CSI_OK;
}

static void interp_destroy(csi_linop *op)
{
    interp_state *s = op->state;
    if (!s)
        return;
    csi_buffer_release(&s->cell);
    csi_buffer_release(&s->ph);
    csi_buffer_release(&s->perm);
    csi_buffer_release(&s->wt8);
    csi_buffer_release(&s->wpad);
    csi_buffer_release(&s->tstart);
    csi_buffer_release(&s->rows);
    free(s);
    op->state = NULL;
}

/* Tile boundaries along an axis of m cells: T = max(1, m / size) tiles, tile t covering
 * [t m / T, (t + 1) m / T), so every tile is at least `size` cells long (or the whole axis).
 * of[i] = the tile of cell i. */
static size_t tile_axis(size_t m, size_t size, uint32_t *of)
{
    size_t T = m / size > 0 ? m / size : 1;
    for (size_t t = 0; t < T; t++)
        for (size_t i = t * m / T; i < (t + 1) * m / T; i++)
            of[i] = (uint32_t)t;
    return T;
}

/* Colour of tile t of T along one axis: alternating, and the last one a third colour when T is
 * odd (it touches tile 0 through the periodic wrap). */
static int tile_colour(size_t t, size_t T)
{
    if (T > 1 && T % 2 == 1 && t == T - 1)
        return 2;
    return (int)(t % 2);
}

static csi_status upload(csi_ctx *ctx, const void *data, size_t bytes, const char *what, cl_mem *out)
{
    CSI_TRY(csi_buffer(ctx, bytes, CL_MEM_READ_ONLY, what, out));
    return csi_write(ctx, *out, 0, bytes, data);
}

static csi_status build(csi_ctx *ctx, interp_state *s, unsigned D, const uint32_t *idx)
{
    const size_t mw = s->mw, mh = s->mh, n = s->n, fw = mw * D;
    uint32_t *ofx = malloc(mw * sizeof *ofx), *ofy = malloc(mh * sizeof *ofy);
    if (!ofx || !ofy) {
        free(ofx);
        free(ofy);
        return csi_fail(CSI_ERR_NOMEM, "interpolation: out of host memory");
    }
    const size_t Tx = tile_axis(mw, TILE_W, ofx), Ty = tile_axis(mh, TILE_H, ofy), nt = Tx * Ty;
    uint32_t *count = calloc(nt + 1, sizeof *count);
    uint32_t *cell = malloc(n * sizeof *cell), *ph = malloc(n * sizeof *ph), *perm = malloc(n * sizeof *perm);
    uint32_t *key = malloc(n * sizeof *key), *rows = malloc((Ty + Tx) * sizeof *rows);
    csi_status st = CSI_OK;
    if (!count || !cell || !ph || !perm || !key || !rows)
        st = csi_fail(CSI_ERR_NOMEM, "interpolation: out of host memory for %zu samples", n);
    if (st == CSI_OK) {
        /* Stable counting sort of the samples by tile. */
        for (size_t i = 0; i < n; i++) {
            size_t px = idx[i] % fw, py = idx[i] / fw;
            key[i] = ofy[py / D] * (uint32_t)Tx + ofx[px / D];
            count[key[i] + 1]++;
        }
        for (size_t t = 0; t < nt; t++)
            count[t + 1] += count[t];
        uint32_t *next = malloc(nt * sizeof *next);
        if (!next) {
            st = csi_fail(CSI_ERR_NOMEM, "interpolation: out of host memory");
        } else {
            memcpy(next, count, nt * sizeof *next);
            for (size_t i = 0; i < n; i++) {
                size_t px = idx[i] % fw, py = idx[i] / fw, o = next[key[i]]++;
                const size_t mx = px / D, my = py / D;
                /* kernels/interp.cl's INSIDE: rows of 8 from mx - IH, IW rows from my - IH */
                const bool inside = mx >= IH && mx + 8 - IH <= mw && my >= IH && my + CSI_INTERP_TAPS - IH <= mh;
                /* kernels/interp.cl's ROW_END: the aligned block of cell mx - IH ends the row */
                const bool row_end = inside && (mx - IH) / 8 * 8 + 16 > mw;
                cell[o] = (uint32_t)(my * mw + mx);
                ph[o] = (uint32_t)((px % D) | (py % D) << 8 | (inside ? 0x10000u : 0u) |
                                   (row_end ? 0x20000u : 0u));
                perm[o] = (uint32_t)i;
            }
            free(next);
        }
        /* The rows of tiles by colour along y, then the tile columns by colour along x. */
        size_t fill = 0;
        for (int col = 0; col < 3; col++) {
            s->row_off[col] = fill;
            for (size_t ty = 0; ty < Ty; ty++)
                if (tile_colour(ty, Ty) == col)
                    rows[fill++] = (uint32_t)ty;
        }
        s->row_off[3] = fill;
        for (int col = 0; col < 3; col++)
            for (size_t tx = 0; tx < Tx; tx++)
                if (tile_colour(tx, Tx) == col)
                    rows[fill++] = (uint32_t)tx;
        s->Tx = Tx;
        s->Ty = Ty;
    }
    /* The kernel at the D phases: wt8[8 d + a] = phi(d / D - (a - IH)), zero from a = w on. */
    float wt8[64 * 8];
    memset(wt8, 0, sizeof wt8);
    for (unsigned d = 0; d < D; d++)
        for (int a = 0; a < CSI_INTERP_TAPS; a++)
            wt8[d * 8 + a] = (float)csi_interp_kernel((double)d / D - (a - IH));
    /* The same weights between 8 zeros each side, wpad[24 d + 8 + a] = wt8[8 d + a]: the
     * spreading reads them shifted into its aligned blocks (kernels/interp.cl). */
    float wpad[64 * 24];
    memset(wpad, 0, sizeof wpad);
    for (unsigned d = 0; d < D; d++)
        memcpy(wpad + d * 24 + 8, wt8 + d * 8, 8 * sizeof(float));
    if (st == CSI_OK)
        st = upload(ctx, cell, n * 4, "the samples' model cells", &s->cell);
    if (st == CSI_OK)
        st = upload(ctx, ph, n * 4, "the samples' phases", &s->ph);
    if (st == CSI_OK)
        st = upload(ctx, perm, n * 4, "the samples' order", &s->perm);
    if (st == CSI_OK)
        st = upload(ctx, wt8, D * 8 * sizeof(float), "the interpolation weights", &s->wt8);
    if (st == CSI_OK)
        st = upload(ctx, wpad, D * 24 * sizeof(float), "the interpolation weights", &s->wpad);
    if (st == CSI_OK)
        st = upload(ctx, count, (nt + 1) * 4, "the tiles' sample ranges", &s->tstart);
    if (st == CSI_OK)
        st = upload(ctx, rows, (Ty + Tx) * 4, "the tile lists", &s->rows);
    free(ofx);
    free(ofy);
    free(count);
    free(cell);
    free(ph);
    free(perm);
    free(key);
    free(rows);
    static const char *names[] = {"csi_interp_gather", "csi_interp_spread", "csi_interp_zero"};
    for (int i = 0; i < 3 && st == CSI_OK; i++) {
        cl_kernel k;
        st = csi_kernel(ctx, "interp", names[i], &k);
    }
    return st;
}

void csi_interp_buffers(size_t mw, size_t mh, unsigned D, size_t n, csi_mem_tally *t)
{
    const size_t Tx = mw / TILE_W > 0 ? mw / TILE_W : 1, Ty = mh / TILE_H > 0 ? mh / TILE_H : 1, nt = Tx * Ty;
    csi_mem_tally_add(t, n * 4, "the samples' model cells");
    csi_mem_tally_add(t, n * 4, "the samples' phases");
    csi_mem_tally_add(t, n * 4, "the samples' order");
    csi_mem_tally_add(t, D * 8 * sizeof(float), "the interpolation weights");
    csi_mem_tally_add(t, D * 24 * sizeof(float), "the interpolation weights");
    csi_mem_tally_add(t, (nt + 1) * 4, "the tiles' sample ranges");
    csi_mem_tally_add(t, (Ty + Tx) * 4, "the tile lists");
}

csi_status csi_interp_create(csi_ctx *ctx, size_t mw, size_t mh, unsigned D, const uint32_t *idx,
                             size_t n, csi_linop **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_interp_create: no output pointer");
    *out = NULL;
    if (!ctx || (!idx && n > 0))
        return csi_fail(CSI_ERR_ARG, "csi_interp_create: missing context or indices");
    if (mw == 0 || mh == 0 || D == 0 || D > 64 || n == 0)
        return csi_fail(CSI_ERR_ARG, "interpolation: model grid %zu x %zu, D = %u, %zu samples: "
                        "need positive sizes, D <= 64 and at least one sample", mw, mh, D, n);
    const uint64_t cells = (uint64_t)mw * mh * D * D;
    if (cells > UINT32_MAX || n > UINT32_MAX)
        return csi_fail(CSI_ERR_ARG, "interpolation: fine grid %zu x %zu or %zu samples beyond "
                        "32-bit indexing", mw * D, mh * D, n);
    for (size_t i = 0; i < n; i++)
        if (idx[i] >= cells)
            return csi_fail(CSI_ERR_ARG, "interpolation: sample %zu has index %u, outside the %zu x "
                            "%zu fine grid", i, idx[i], mw * D, mh * D);
    csi_linop *op = calloc(1, sizeof *op);
    interp_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "interpolation: out of host memory");
    }
    s->mw = mw;
    s->mh = mh;
    s->n = n;
    op->rows = n;
    op->cols = mw * mh;
    op->complex_valued = false;
    op->name = "interpolation";
    op->ctx = ctx;
    op->apply = interp_apply;
    op->adjoint = interp_adjoint;
    op->destroy = interp_destroy;
    op->state = s;
    csi_status st = build(ctx, s, D, idx);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}
