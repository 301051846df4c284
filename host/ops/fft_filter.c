/* The Gaussian / Wiener filter pass on csi's own Stockham FFT kernels (kernels/fft.cl).
 *
 * Pipeline for a real signal of n0 x n1 x n2 (x fastest, n0 = 2M even):
 *   1. rows as M complex values (x[2m] + i x[2m+1]): radix passes along x      (P/Q ping-pong)
 *   2. unpack to the Hermitian half spectrum, rows of hs >= M + 1 values (hs padded to 16 so
 *      every row starts on a 128-byte boundary)
 *   3. forward passes along y, then z ("column" passes: launch dimension 0 runs along x)
 *   4. inverse passes along z, then y; the first one multiplies by the gain (Gaussian or Wiener)
 *      and by the normalisation 2/N as it loads, so the gain costs no pass of its own
 *   5. pack to M complex values per row, inverse passes along x, the last writing y.
 * Stages 1-2 and 5 run as one launch each where the row plan allows (rows_fused_fit), else block
 * by block where the volumes outgrow the cache (row_block), else pass by pass over all rows.
 * Stages 3-4 of a 2-D filter run as one launch, a strip of 8 columns per work-item held in local
 * memory, where the column plan allows (cols_fused_fit), else pass by pass.
 * No transposes: the layout never changes between axes, which is what a filter allows (the
 * spectrum is never seen outside). A pass launched on its own reads and writes the whole volume
 * once, so the radices are as large as the kernels offer (16) to keep the number of passes small;
 * the fused stages read and write it once per stage. */
#include "fft_filter.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/gaussian.h"

#define PI_ 3.14159265358979323846
#define MAX_PASSES 24
#define ROW_PLAN_BYTES ((1 + 2 * MAX_PASSES) * sizeof(cl_uint)) /* upload_row_plan's table */
#define COL_PLAN_BYTES ((1 + MAX_PASSES) * sizeof(cl_uint))     /* upload_col_plan's table */

typedef struct {
    size_t L;
    int np;
    int radix[MAX_PASSES];
    cl_mem tw; /* exp(-2 pi i m / L), m < L */
    cl_mem twp; /* per-pass tables exp(-2 pi i r k / (p R)) at [(r - 1) p + k], rows only */
    size_t twoff[MAX_PASSES]; /* element offset of each pass's table in twp */
} axis_plan;

struct csi_fft_filter {
    csi_ctx *ctx;
    size_t c[3], M, hs, rows; /* rows = c1 * c2 */
    int nd;
    axis_plan ax[3];          /* ax[0] has length M */
    cl_mem wn;                /* exp(-2 pi i k / n0), k <= M */
    cl_mem P, Q;              /* ping-pong volumes */
    size_t blk;               /* rows per block of the row stages (row_block); rows: not blocked */
    cl_mem A, B;              /* blocked: ping-pong rows of one block (blk rows of M values) */
    size_t nblk;              /* blocked: the number of blocks; 0 when not blocked */
    cl_mem *Pblk, *Qblk;      /* blocked: each block's rows of P and Q as sub-buffers, made once */
    cl_mem plan;              /* fused row stages (rows_fused_fit): the row axis's radices, offsets */
    cl_mem cplan;             /* fused column stage (cols_fused_fit): the y axis's radices */
    cl_mem gx, g1, g2, one;   /* gains along x (hs entries), y, z; {1} */
    cl_mem fc, fa;            /* optional complex factor along x (hs entries) and y (2-D) */
    cl_uint wiener;
    float lambda, scale;
};

static int factor_ok(size_t n)
{
    static const size_t p[] = {2, 3, 5, 7};
    for (int i = 0; i < 4; i++)
        while (n % p[i] == 0)
            n /= p[i];
    return n == 1;
}

bool csi_fft_filter_supported(const size_t c[3], int nd)
{
    /* c[0] >= 4: at least one pass along x, so the unpacking reads a scratch buffer (which has
     * room for its one-past-the-end read), never the caller's input. */
    if (nd < 1 || c[0] < 4 || c[0] % 2)
        return false;
    if (!factor_ok(c[0] / 2))
        return false;
    for (int a = 1; a < nd; a++)
        if (!factor_ok(c[a]))
            return false;
    /* Kernel indices are 32-bit. */
    return (c[0] / 2 + 16) * c[1] * c[2] < ((size_t)1 << 31);
}

/* Radices for a length L: the power of two 2^e in ceil(e/3) passes of near-equal radix (at most
 * 8), then one pass per factor 9 (3 x 3 in one pass: a pass costs its memory traffic more than
 * its arithmetic), 3, 5, 7. Radix 16 exists in kernels/fft.cl but PoCL's 16-wide
 * vectorisation of it spills registers: measured 1.8 ms per 1024 x 1024 pass against 0.36 ms
 * for radix 8, so two radix-8 passes beat one radix-16 pass. Radix 9 only where its passes run
 * on 16-wide vectors (PoCL leaves the per-element radix-9 kernels scalar, slower than two
 * radix-3 passes): along rows (nc = 0) when they come at p a multiple of 16 (p = 2^e 9^j, so
 * 2^e >= 16), along y or z when the nc columns are a multiple of 16. */
static void plan_radices(axis_plan *a, size_t nc)
{
    size_t n = a->L;
    int e = 0;
    while (n % 2 == 0) {
        n /= 2;
        e++;
    }
    const bool nine = nc ? nc % 16 == 0 : e >= 4;
    a->np = 0;
    int passes = (e + 2) / 3;
    for (int i = 0; i < passes; i++) {
        int bits = e / (passes - i);
        if (e % (passes - i))
            bits++;
        a->radix[a->np++] = 1 << bits;
        e -= bits;
    }
    static const int odd[] = {9, 3, 5, 7};
    for (int i = nine ? 0 : 1; i < 4; i++)
        while (n % (size_t)odd[i] == 0) {
            n /= (size_t)odd[i];
            a->radix[a->np++] = odd[i];
        }
}

static csi_status upload_table(csi_ctx *ctx, const void *data, size_t bytes, const char *what, cl_mem *out)
{
    CSI_TRY(csi_buffer(ctx, bytes, CL_MEM_READ_ONLY, what, out));
    return csi_write(ctx, *out, 0, bytes, data);
}

/* exp(-2 pi i m / n) for m < count, computed in double. */
static csi_status twiddles(csi_ctx *ctx, size_t n, size_t count, cl_mem *out)
{
    float *t = malloc(2 * count * sizeof *t);
    if (!t)
        return csi_fail(CSI_ERR_NOMEM, "FFT twiddles: out of host memory");
    for (size_t m = 0; m < count; m++) {
        double ang = -2.0 * PI_ * (double)m / (double)n;
        t[2 * m] = (float)cos(ang);
        t[2 * m + 1] = (float)sin(ang);
    }
    csi_status st = upload_table(ctx, t, 2 * count * sizeof *t, "FFT twiddles", out);
    free(t);
    return st;
}

static csi_status gains(csi_ctx *ctx, size_t n, size_t count, size_t alloc, double sigma, cl_mem *out)
{
    float *g = calloc(alloc, sizeof *g);
    if (!g)
        return csi_fail(CSI_ERR_NOMEM, "filter gains: out of host memory");
    for (size_t k = 0; k < count; k++)
        g[k] = (float)csi_gauss_gain_1d(n, k, sigma);
    csi_status st = upload_table(ctx, g, alloc * sizeof *g, "filter gains", out);
    free(g);
    return st;
}

/* The row passes' per-pass twiddle tables (see csi_fft_rowk_r* in kernels/fft.cl). */
static csi_status pass_twiddles(csi_ctx *ctx, axis_plan *a)
{
    size_t total = 0, p = 1;
    for (int i = 0; i < a->np; i++) {
        a->twoff[i] = total;
        total += (size_t)(a->radix[i] - 1) * p;
        p *= (size_t)a->radix[i];
    }
    if (total == 0)
        total = 1;
    float *t = calloc(2 * total, sizeof *t);
    if (!t)
        return csi_fail(CSI_ERR_NOMEM, "FFT twiddles: out of host memory");
    p = 1;
    for (int i = 0; i < a->np; i++) {
        size_t R = (size_t)a->radix[i];
        for (size_t r = 1; r < R; r++)
            for (size_t k = 0; k < p; k++) {
                double ang = -2.0 * PI_ * (double)(r * k) / (double)(p * R);
                size_t at = a->twoff[i] + (r - 1) * p + k;
                t[2 * at] = (float)cos(ang);
                t[2 * at + 1] = (float)sin(ang);
            }
        p *= R;
    }
    csi_status st = upload_table(ctx, t, 2 * total * sizeof *t, "FFT twiddles", &a->twp);
    free(t);
    return st;
}

/* The buffers prepare_axis allocates for an axis of length L: its twiddles, and along x the
 * per-pass tables. */
static void axis_buffers(size_t L, bool x_axis, csi_mem_tally *t)
{
    axis_plan a = {.L = L};
    plan_radices(&a, x_axis ? 0 : 16); /* only the rows' tables depend on the radices */
    csi_mem_tally_add(t, L * 8, "FFT twiddles");
    if (x_axis) {
        size_t total = 0, p = 1;
        for (int i = 0; i < a.np; i++) {
            total += (size_t)(a.radix[i] - 1) * p;
            p *= (size_t)a.radix[i];
        }
        csi_mem_tally_add(t, (total ? total : 1) * 8, "FFT twiddles");
    }
}

/* Bytes of each ping-pong volume of a real transform: the half spectrum (rows of hs values), or
 * the packed rows plus the one element csi_fft_r2c_post reads past them. */
static size_t spectrum_bytes(size_t M, size_t hs, size_t rows)
{
    size_t spec = hs * rows * 8, packed = (M * rows + 1) * 8;
    return spec > packed ? spec : packed;
}

static size_t half_stride(size_t M) { return (M + 1 + 15) / 16 * 16; }

/* Rows per block of the filter's row stages. Each radix pass reads and writes the whole volume,
 * so run over all rows a pass's output has left the caches by the time the next pass reads it.
 * Blocked, every pass of a row stage runs on one block of rows (in two scratch volumes of that
 * block only) before the next block, so the stage reads its input and writes its output once and
 * the intermediate passes stay in the cache. ROW_BLOCK_BYTES is the two scratch volumes' size
 * (the caches: L2 per core, the last level shared). A block is a multiple of 16 rows (as the
 * 16-wide kernels' local sizes prefer) and M a multiple of 16, so every block starts on a multiple
 * of 2048 bytes in each buffer, which its sub-buffers need (CL_DEVICE_MEM_BASE_ADDR_ALIGN: 128
 * bytes on PoCL; build() does not block on a device that asks more, nor volumes that fit the
 * device's cache; the tally counts the scratch whenever this blocks). Returns `rows` when not
 * blocked. The arithmetic per element is the same either way (same bits). */
#define ROW_BLOCK_BYTES ((size_t)1 << 20)
static size_t row_block(size_t M, size_t rows)
{
    if (M % 16)
        return rows;
    size_t b = ROW_BLOCK_BYTES / (2 * M * 8) / 16 * 16;
    if (b < 16)
        b = 16;
    return b < rows ? b : rows;
}

/* Whether the row stages run as one launch each (csi_fft_rows_r2c / csi_fft_rows_c2r in
 * kernels/fft.cl: a work-item per row, its passes in two __local rows of M + 1 complex values),
 * which saves the launches of the passes one by one (a fixed cost each on PoCL, per block where
 * the stages run in blocks) and keeps a row's intermediate passes in the core's caches: M whose
 * plan is radix 8 first, then radices 4 and 8, at least 3 such passes (so every pass runs in the
 * 16-wide forms those kernels take: p = 1, p = 8, then multiples of 16), then any passes of
 * radix 9, 3 and 5 (a model grid 7680 cells wide: M = 3840, passes 8, 8, 4, 3, 5), and two rows
 * in the device's local memory. The same arithmetic per element as the passes launched one by
 * one, so the same bits. */
static bool rows_fused_plan(const axis_plan *a)
{
    int pow2 = 0;
    while (pow2 < a->np && (a->radix[pow2] == 4 || a->radix[pow2] == 8))
        pow2++;
    if (pow2 < 3 || a->radix[0] != 8)
        return false;
    for (int i = pow2; i < a->np; i++)
        if (a->radix[i] != 3 && a->radix[i] != 5 && a->radix[i] != 9)
            return false;
    return true;
}

/* Whether a 2-D filter's column stage runs as one launch (csi_fft_cols_2d in kernels/fft.cl: a
 * strip of 8 columns per work-item, its passes in two __local volumes of L x 8 complex values),
 * which reads and writes the spectrum once instead of once per pass: at least 2 passes per
 * direction, each of a radix the kernel takes (2, 3, 4, 5, 8, 9). cols_fused_fit adds the room in
 * the device's local memory. The same arithmetic per element as the passes launched one by one,
 * so the same bits. */
static bool cols_fused_plan(const axis_plan *a)
{
    if (a->np < 2)
        return false;
    for (int i = 0; i < a->np; i++) {
        const int R = a->radix[i];
        if (R != 2 && R != 3 && R != 4 && R != 5 && R != 8 && R != 9)
            return false;
    }
    return true;
}

/* rows_fused_plan's plan (the x axis, length M) in `local` bytes of the device's local memory:
 * two rows of M + 1 complex values. */
static bool rows_fused_fit(const axis_plan *a, uint64_t local)
{
    return rows_fused_plan(a) && 2 * (a->L + 1) * 8 <= local;
}

/* cols_fused_plan's plan (a 2-D filter's y axis) in `local` bytes of the device's local memory:
 * two volumes of L x 8 complex values. */
static bool cols_fused_fit(const axis_plan *y, int nd, uint64_t local)
{
    return nd == 2 && cols_fused_plan(y) && 2 * y->L * 64 <= local;
}

/* Whether the fused column stage (cols_fused_fit) takes two adjacent strips per work-item
 * (csi_fft_cols_2d_pair: their first and last passes read and write each row's 128 bytes in one
 * visit to its page),
 * which needs three volumes of L x 8 complex values in the device's local memory (a 1920x1080
 * tile's 4320 rows: 0.83 MB; PoCL's CPU device reports 2 MiB here). hs is a multiple of 16, so
 * the strips pair up. */
static bool cols_pair_fit(const axis_plan *y, uint64_t local) { return 3 * y->L * 64 <= local; }

/* Whether the spectrum's second volume (Q) is made: only the passes launched one by one
 * ping-pong between P and Q; the fused row stages read and write P (and the caller's rows), and
 * the fused column stage runs in place. A blocked row stage uses its own block scratch, so it
 * would not need Q either, but whether the rows block depends on the device's cache, which the
 * resource plan does not know: Q is kept there, so that the plan stays exact. */
static bool second_volume(bool rows_fused, bool cols_fused, int nd)
{
    return !(rows_fused && (nd == 1 || cols_fused));
}

bool csi_fft_filter_rows_fused(size_t c0, uint64_t local_mem)
{
    if (c0 < 4 || c0 % 2)
        return false;
    axis_plan x = {.L = c0 / 2};
    plan_radices(&x, 0);
    return rows_fused_fit(&x, local_mem);
}

void csi_fft_filter_buffers(const size_t c[3], int nd, csi_mem_tally *t)
{
    const size_t M = c[0] / 2, hs = half_stride(M), rows = c[1] * c[2];
    const size_t L[3] = {M, c[1], c[2]};
    for (int a = 0; a < nd; a++)
        axis_buffers(L[a], a == 0, t);
    csi_mem_tally_add(t, (M + 1) * 8, "FFT twiddles");
    axis_plan x = {.L = M}, y = {.L = nd > 1 ? c[1] : 1};
    plan_radices(&x, 0);
    if (nd > 1)
        plan_radices(&y, hs);
    /* the device's local memory unknown (0): the fused stages' tables counted, and Q too */
    const bool rows_fused = rows_fused_fit(&x, t->local_mem), cols_fused = cols_fused_fit(&y, nd, t->local_mem);
    csi_mem_tally_add(t, spectrum_bytes(M, hs, rows), "the filter's spectrum");
    if (second_volume(rows_fused, cols_fused, nd))
        csi_mem_tally_add(t, spectrum_bytes(M, hs, rows), "the filter's spectrum scratch");
    if (rows_fused || (!t->local_mem && rows_fused_plan(&x)))
        csi_mem_tally_add(t, ROW_PLAN_BYTES, "FFT plan");
    if (cols_fused || (!t->local_mem && nd == 2 && cols_fused_plan(&y)))
        csi_mem_tally_add(t, COL_PLAN_BYTES, "FFT plan");
    /* the blocks whenever row_block blocks: build may run fused rows or find the volumes in the
     * device's cache instead (an upper bound then) */
    const size_t blk = row_block(M, rows);
    if (blk < rows) {
        csi_mem_tally_add(t, (blk * M + 1) * 8, "the filter's row block");
        csi_mem_tally_add(t, (blk * M + 1) * 8, "the filter's row block");
    }
    csi_mem_tally_add(t, hs * 4, "filter gains");
    csi_mem_tally_add(t, c[1] * 4, "filter gains");
    csi_mem_tally_add(t, c[2] * 4, "filter gains");
    csi_mem_tally_add(t, 4, "filter gains");
}

void csi_fft_c2c_buffers(const size_t c[3], int nd, csi_mem_tally *t)
{
    size_t n = 1;
    for (int a = 0; a < nd; a++) {
        axis_buffers(c[a], a == 0, t);
        n *= c[a];
    }
    csi_mem_tally_add(t, n * 8, "the FFT's scratch volume");
}

size_t csi_fft_half_count_for(const size_t c[3], int nd)
{
    size_t rows = 1;
    for (int a = 1; a < nd; a++)
        rows *= c[a];
    return half_stride(c[0] / 2) * rows;
}

void csi_fft_half_buffers(const size_t c[3], int nd, csi_mem_tally *t)
{
    const size_t M = c[0] / 2, hs = half_stride(M);
    size_t L[3] = {M, 1, 1}, rows = 1;
    for (int a = 1; a < nd; a++) {
        L[a] = c[a];
        rows *= c[a];
    }
    for (int a = 0; a < nd; a++)
        axis_buffers(L[a], a == 0, t);
    csi_mem_tally_add(t, (M + 1) * 8, "FFT twiddles");
    csi_mem_tally_add(t, spectrum_bytes(M, hs, rows), "the real FFT's spectrum");
    csi_mem_tally_add(t, spectrum_bytes(M, hs, rows), "the real FFT's scratch");
}

void csi_fft_filter_free(csi_fft_filter *f)
{
    if (!f)
        return;
    for (int a = 0; a < 3; a++) {
        csi_buffer_release(&f->ax[a].tw);
        csi_buffer_release(&f->ax[a].twp);
    }
    csi_buffer_release(&f->wn);
    csi_buffer_release(&f->plan);
    csi_buffer_release(&f->cplan);
    /* the blocks before their parents, and not through csi_buffer_release: a sub-buffer holds
     * no device bytes of its own, so it must not leave the device's live count */
    for (size_t b = 0; b < f->nblk; b++) {
        if (f->Pblk && f->Pblk[b])
            clReleaseMemObject(f->Pblk[b]);
        if (f->Qblk && f->Qblk[b])
            clReleaseMemObject(f->Qblk[b]);
    }
    free(f->Pblk);
    free(f->Qblk);
    csi_buffer_release(&f->P);
    csi_buffer_release(&f->Q);
    csi_buffer_release(&f->A);
    csi_buffer_release(&f->B);
    csi_buffer_release(&f->gx);
    csi_buffer_release(&f->g1);
    csi_buffer_release(&f->g2);
    csi_buffer_release(&f->one);
    csi_buffer_release(&f->fc);
    csi_buffer_release(&f->fa);
    free(f);
}

static const char *pass_kernel_name(const char *kind, int radix)
{
    static char buf[64];
    snprintf(buf, sizeof buf, "csi_fft_%s_r%d", kind, radix);
    return buf;
}

/* Whether pass `pass` of a row axis runs as csi_fft_row1v_r* (the first pass, radix 2, 4 or 8,
 * at least 16 butterflies per row). */
static bool row1v_fits(const axis_plan *a, int pass)
{
    const int R = a->radix[pass];
    return pass == 0 && (R == 2 || R == 4 || R == 8) && a->L / (size_t)R >= 16;
}

/* Whether pass `pass` of a row axis, at p = 8, runs as csi_fft_rowk8v_r* (radix 2, 4 or 8, at
 * least 16 butterflies per row). */
static bool rowk8v_fits(const axis_plan *a, int pass)
{
    const int R = a->radix[pass];
    return (R == 2 || R == 4 || R == 8) && a->L / (size_t)R >= 16;
}

/* Whether a radix-R pass along y or z over nc columns runs as csi_fft_col1v_r*, and one along
 * rows at p as csi_fft_rowkv_r* (kernels/fft.cl: radix 9, whose per-element form PoCL leaves
 * scalar). */
static bool col1v_fits(int R, size_t nc) { return R == 9 && nc % 16 == 0; }
static bool rowkv_fits(int R, size_t p) { return R == 9 && p % 16 == 0; }

/* Plans one axis's passes, uploads its twiddles (and, along x, the per-pass twiddles) and builds
 * every kernel it will launch, so that the first run pays no compile. Along x the first pass
 * uses the `first_row` kernel ("row_s" where it also scales, else "row"); along the other axes
 * `col_gain` also builds the gain-fused column kernels (the filter's first inverse pass), and
 * nc is the number of columns their passes run over (plan_radices). */
static csi_status prepare_axis(csi_ctx *ctx, axis_plan *ax, bool x_axis, size_t nc,
                               const char *first_row, bool col_gain)
{
    plan_radices(ax, x_axis ? 0 : nc);
    CSI_TRY(twiddles(ctx, ax->L, ax->L, &ax->tw));
    if (x_axis)
        CSI_TRY(pass_twiddles(ctx, ax));
    size_t pp = 1; /* the pass's p */
    for (int p = 0; p < ax->np; pp *= (size_t)ax->radix[p], p++) {
        cl_kernel k;
        int R = ax->radix[p];
        if (x_axis) {
            CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name(p == 0 ? first_row : "row", R), &k));
            if (row1v_fits(ax, p))
                CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("row1v", R), &k));
            if (pp == 8 && rowk8v_fits(ax, p))
                CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowk8v", R), &k));
            if (rowkv_fits(R, pp))
                CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowkv", R), &k));
            CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowk", R), &k));
        } else {
            CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("col", R), &k));
            if (col1v_fits(R, 16))
                CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("col1v", R), &k));
            if (col_gain)
                CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("col_gain", R), &k));
        }
    }
    return CSI_OK;
}

/* The region [off, off + bytes) of buf as a buffer of its own. */
static csi_status sub_buffer(cl_mem buf, size_t off, size_t bytes, cl_mem *out)
{
    cl_buffer_region r = {off, bytes};
    cl_int err;
    *out = clCreateSubBuffer(buf, 0, CL_BUFFER_CREATE_TYPE_REGION, &r, &err);
    if (err != CL_SUCCESS) {
        *out = NULL;
        return csi_fail_context(CSI_CL(err), "FFT filter: a block of rows (%zu bytes at %zu): ", bytes, off);
    }
    return CSI_OK;
}

/* Each block's rows of P and Q (hs values a row) as sub-buffers, made once here: the spectrum's
 * buffers are the filter's own. The caller's real rows come with each run, so block_stage makes
 * those per run. */
static csi_status spectrum_blocks(csi_fft_filter *f)
{
    f->nblk = (f->rows + f->blk - 1) / f->blk;
    f->Pblk = calloc(f->nblk, sizeof *f->Pblk);
    f->Qblk = calloc(f->nblk, sizeof *f->Qblk);
    if (!f->Pblk || !f->Qblk)
        return csi_fail(CSI_ERR_NOMEM, "FFT filter: out of host memory");
    for (size_t b = 0; b < f->nblk; b++) {
        const size_t r0 = b * f->blk, n = f->rows - r0 < f->blk ? f->rows - r0 : f->blk;
        CSI_TRY(sub_buffer(f->P, r0 * f->hs * 8, n * f->hs * 8, &f->Pblk[b]));
        CSI_TRY(sub_buffer(f->Q, r0 * f->hs * 8, n * f->hs * 8, &f->Qblk[b]));
    }
    return CSI_OK;
}

/* The fused column stage's plan: the number of passes per direction, then each pass's radix. */
static csi_status upload_col_plan(csi_fft_filter *f)
{
    const axis_plan *a = &f->ax[1];
    cl_uint t[COL_PLAN_BYTES / sizeof(cl_uint)] = {(cl_uint)a->np};
    for (int i = 0; i < a->np; i++)
        t[1 + i] = (cl_uint)a->radix[i];
    return upload_table(f->ctx, t, sizeof t, "FFT plan", &f->cplan);
}

/* The fused row stages' plan: the number of passes, then each pass's radix and table offset. */
static csi_status upload_row_plan(csi_fft_filter *f)
{
    const axis_plan *a = &f->ax[0];
    cl_uint t[ROW_PLAN_BYTES / sizeof(cl_uint)] = {(cl_uint)a->np};
    for (int i = 0; i < a->np; i++) {
        t[1 + 2 * i] = (cl_uint)a->radix[i];
        t[2 + 2 * i] = (cl_uint)a->twoff[i];
    }
    return upload_table(f->ctx, t, sizeof t, "FFT plan", &f->plan);
}

static csi_status build(csi_fft_filter *f, const double sigma[3], bool fuse_rows)
{
    csi_ctx *ctx = f->ctx;
    size_t M = f->M;
    f->ax[0].L = M;
    f->ax[1].L = f->c[1];
    f->ax[2].L = f->c[2];
    for (int a = 0; a < f->nd; a++)
        CSI_TRY(prepare_axis(ctx, &f->ax[a], a == 0, f->hs, "row", true));
    CSI_TRY(twiddles(ctx, 2 * M, M + 1, &f->wn));
    const size_t bytes = spectrum_bytes(M, f->hs, f->rows);
    const uint64_t local = csi_ctx_local_mem(ctx);
    const bool rows_fused = fuse_rows && rows_fused_fit(&f->ax[0], local);
    const bool cols_fused = cols_fused_fit(&f->ax[1], f->nd, local);
    cl_kernel k;
    CSI_TRY(csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "the filter's spectrum", &f->P));
    if (second_volume(rows_fused, cols_fused, f->nd))
        CSI_TRY(csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "the filter's spectrum scratch", &f->Q));
    f->blk = row_block(M, f->rows);
    /* Blocks pay only when the two volumes outgrow the device's cache (PoCL: the last level):
     * below it the passes already find their input there, and the blocks only add launches
     * (the demo's 1024 x 1024 model filter 1.15x the CPU blocked on a quiet machine). */
    cl_uint align_bits = 0;
    cl_ulong cache = 0;
    if (clGetDeviceInfo(csi_ctx_device(ctx), CL_DEVICE_MEM_BASE_ADDR_ALIGN, sizeof align_bits, &align_bits, NULL) !=
            CL_SUCCESS ||
        align_bits > 2048 * 8 ||
        clGetDeviceInfo(csi_ctx_device(ctx), CL_DEVICE_GLOBAL_MEM_CACHE_SIZE, sizeof cache, &cache, NULL) != CL_SUCCESS ||
        2 * bytes <= cache)
        f->blk = f->rows;
    if (rows_fused) {
        f->blk = f->rows;
        CSI_TRY(upload_row_plan(f));
        CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_rows_r2c", &k));
        CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_rows_c2r", &k));
    }
    if (cols_fused) {
        CSI_TRY(upload_col_plan(f));
        const char *cols = cols_pair_fit(&f->ax[1], local) ? "csi_fft_cols_2d_pair" : "csi_fft_cols_2d";
        CSI_TRY(csi_kernel(ctx, "fft", cols, &k));
    }
    if (f->blk < f->rows) {
        /* zeroed: csi_fft_r2c_post reads the element past a block's last row (and discards it) */
        const size_t bb = (f->blk * M + 1) * 8;
        CSI_TRY(csi_buffer(ctx, bb, CL_MEM_READ_WRITE, "the filter's row block", &f->A));
        CSI_TRY(csi_buffer(ctx, bb, CL_MEM_READ_WRITE, "the filter's row block", &f->B));
        CSI_TRY(csi_fill_zero(ctx, f->A, bb));
        CSI_TRY(csi_fill_zero(ctx, f->B, bb));
        CSI_TRY(spectrum_blocks(f));
    }
    CSI_TRY(gains(ctx, 2 * M, M + 1, f->hs, sigma[0], &f->gx));
    CSI_TRY(gains(ctx, f->c[1], f->c[1], f->c[1], f->nd > 1 ? sigma[1] : 0.0, &f->g1));
    CSI_TRY(gains(ctx, f->c[2], f->c[2], f->c[2], f->nd > 2 ? sigma[2] : 0.0, &f->g2));
    const float one = 1.0f;
    CSI_TRY(upload_table(ctx, &one, sizeof one, "filter gains", &f->one));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_r2c_post", &k));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_r2c_edges", &k));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_c2r_pre", &k));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_r2c_post16", &k));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_c2r_pre16", &k));
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_gain_rows", &k));
    return CSI_OK;
}

csi_status csi_fft_filter_create(csi_ctx *ctx, const size_t c[3], int nd, const double sigma[3],
                                 bool wiener, float lambda, csi_fft_filter **out)
{
    return csi_fft_filter_create_rows(ctx, c, nd, sigma, wiener, lambda, true, out);
}

csi_status csi_fft_filter_create_rows(csi_ctx *ctx, const size_t c[3], int nd, const double sigma[3],
                                      bool wiener, float lambda, bool fuse_rows, csi_fft_filter **out)
{
    *out = NULL;
    if (!csi_fft_filter_supported(c, nd))
        return csi_fail(CSI_ERR_ARG, "FFT filter: size %zu x %zu x %zu not supported by csi's FFT",
                        c[0], c[1], c[2]);
    csi_fft_filter *f = calloc(1, sizeof *f);
    if (!f)
        return csi_fail(CSI_ERR_NOMEM, "FFT filter: out of host memory");
    f->ctx = ctx;
    memcpy(f->c, c, sizeof f->c);
    f->nd = nd;
    f->M = c[0] / 2;
    f->hs = half_stride(f->M);
    f->rows = c[1] * c[2];
    f->wiener = wiener;
    f->lambda = wiener ? lambda : 0.0f;
    /* Unnormalised transforms both ways; the inverse along x works on M complex values, so
     * the round trip multiplies by M c1 c2 = N / 2. */
    f->scale = (float)(2.0 / ((double)c[0] * (double)c[1] * (double)c[2]));
    csi_status st = build(f, sigma, fuse_rows);
    if (st != CSI_OK) {
        csi_fft_filter_free(f);
        return st;
    }
    *out = f;
    return CSI_OK;
}

/* The largest power of two <= cap that divides n. */
static size_t pow2_dividing(size_t n, size_t cap)
{
    size_t p = 1;
    while (p * 2 <= cap && n % (p * 2) == 0)
        p *= 2;
    return p;
}

/* Whether the unpacking and packing of rows of M complex values run on 16-wide vectors
 * (csi_fft_r2c_post16, csi_fft_c2r_pre16). */
static bool unpack16(size_t M) { return M % 16 == 0; }

/* The real <-> complex unpacking or packing (`kernel`: csi_fft_r2c_post or csi_fft_c2r_pre) of
 * `rows` rows: its 16-wide form where M allows (see kernels/fft.cl), else the per-element one. */
static csi_status run_unpack(csi_ctx *ctx, const char *kernel, cl_mem in, cl_mem out, cl_mem wn,
                             size_t M_, size_t hs_, size_t rows)
{
    const bool v16 = unpack16(M_);
    char name[40];
    snprintf(name, sizeof name, "%s%s", kernel, v16 ? "16" : "");
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "fft", name, &k));
    cl_uint M = (cl_uint)M_, hs = (cl_uint)hs_, nrows = (cl_uint)rows;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(wn), CSI_ARG(M), CSI_ARG(hs), CSI_ARG(nrows)));
    const size_t n0 = v16 ? M_ / 16 : M_;
    /* Exact launch (no bounds checks). The 16-wide form runs one work-item per group along k
     * (and a few rows), so PoCL has no work-item loop along k to vectorise again: that gave
     * 8-byte gathers instead of the plain vector loads. */
    size_t ex = v16 ? 1 : pow2_dividing(n0, 64), ey = pow2_dividing(rows, v16 ? 16 : 64 / ex);
    size_t global[2] = {n0, rows}, local[2] = {ex, ey};
    return csi_run(ctx, k, 2, global, local);
}

/* The forward unpacking of `rows` real rows (read as M complex values) into the half spectrum:
 * csi_fft_r2c_post for the bins inside, then csi_fft_r2c_edges for bins 0 and M (its 16-wide
 * form writes those itself). */
static csi_status run_r2c_unpack(csi_ctx *ctx, cl_mem in, cl_mem out, cl_mem wn, size_t M_, size_t hs_, size_t rows)
{
    CSI_TRY(run_unpack(ctx, "csi_fft_r2c_post", in, out, wn, M_, hs_, rows));
    if (unpack16(M_))
        return CSI_OK;
    cl_kernel k;
    cl_uint M = (cl_uint)M_, hs = (cl_uint)hs_, nrows = (cl_uint)rows;
    CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_r2c_edges", &k));
    CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_ARG(M), CSI_ARG(hs), CSI_ARG(nrows)));
    return csi_run1d(ctx, k, rows);
}

/* One pass along contiguous rows: `rows` rows of a->L complex values, row n at element n rs.
 * scale >= 0 selects the scaled variant of the p = 1 kernel (inputs multiplied by scale). */
static csi_status launch_row(csi_ctx *ctx, cl_mem in, cl_mem out, const axis_plan *a, int pass,
                             cl_uint p, float sgn, size_t rows, size_t rs_, float scale)
{
    int R = a->radix[pass];
    cl_kernel k;
    if (p == 8 && rowk8v_fits(a, pass)) {
        /* the 16-wide form of the pass at p = 8 (kernels/fft.cl) */
        CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowk8v", R), &k));
        cl_uint T = (cl_uint)(a->L / (size_t)R), rs = (cl_uint)rs_, twoff = (cl_uint)a->twoff[pass];
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->twp), CSI_ARG(twoff), CSI_ARG(T),
                         CSI_ARG(rs), CSI_ARG(sgn)));
        size_t global[2] = {((size_t)T + 15) / 16, rows}, local[2] = {1, pow2_dividing(rows, 16)};
        return csi_run(ctx, k, 2, global, local);
    }
    if (rowkv_fits(R, p)) {
        /* the k-indexed form on 16-wide vectors (kernels/fft.cl) */
        CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowkv", R), &k));
        cl_uint L = (cl_uint)a->L, rs = (cl_uint)rs_, twoff = (cl_uint)a->twoff[pass];
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->twp), CSI_ARG(twoff), CSI_ARG(L),
                         CSI_ARG(p), CSI_ARG(rs), CSI_ARG(sgn)));
        size_t global[3] = {p / 16, a->L / ((size_t)R * p), rows}, local[3] = {1, 1, 1};
        return csi_run(ctx, k, 3, global, local);
    }
    if (p >= 8) {
        /* k-indexed form: contiguous loads and stores (see kernels/fft.cl) */
        CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("rowk", R), &k));
        cl_uint L = (cl_uint)a->L, rs = (cl_uint)rs_, twoff = (cl_uint)a->twoff[pass];
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->twp), CSI_ARG(twoff), CSI_ARG(L),
                         CSI_ARG(p), CSI_ARG(rs), CSI_ARG(sgn)));
        size_t lk = pow2_dividing(p, 16);
        size_t global[3] = {p, a->L / ((size_t)R * p), rows}, local[3] = {lk, 1, 1};
        return csi_run(ctx, k, 3, global, local);
    }
    const bool scaled = scale >= 0.0f;
    if (row1v_fits(a, pass)) {
        /* the 16-wide form of the first pass (kernels/fft.cl); local size 1 along the vectors */
        CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name("row1v", R), &k));
        cl_uint T = (cl_uint)(a->L / (size_t)R), rs = (cl_uint)rs_;
        const float s = scaled ? scale : 1.0f;
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_ARG(T), CSI_ARG(rs), CSI_ARG(sgn), CSI_ARG(s)));
        size_t global[2] = {((size_t)T + 15) / 16, rows}, local[2] = {1, pow2_dividing(rows, 16)};
        return csi_run(ctx, k, 2, global, local);
    }
    CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name(scaled ? "row_s" : "row", R), &k));
    cl_uint L = (cl_uint)a->L, ts = (cl_uint)(a->L / ((size_t)p * (size_t)R)), nrows = (cl_uint)rows,
            rs = (cl_uint)rs_;
    if (scaled)
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                         CSI_ARG(ts), CSI_ARG(nrows), CSI_ARG(rs), CSI_ARG(sgn), CSI_ARG(scale)));
    else
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                         CSI_ARG(ts), CSI_ARG(nrows), CSI_ARG(rs), CSI_ARG(sgn)));
    /* Exact launch (the kernel has no bounds check): local sizes divide the global ones. */
    size_t T = a->L / (size_t)R;
    size_t lx = pow2_dividing(T, 64), ly = pow2_dividing(rows, 64 / lx);
    size_t global[2] = {T, rows}, local[2] = {lx, ly};
    return csi_run(ctx, k, 2, global, local);
}

static csi_status row_pass(csi_fft_filter *f, cl_mem in, cl_mem out, const axis_plan *a, int pass,
                           cl_uint p, float sgn)
{
    return launch_row(f->ctx, in, out, a, pass, p, sgn, f->rows, f->M, -1.0f);
}

/* One unscaled pass along a strided axis: lines (c, b), c < nc (contiguous), b < nb, element q
 * of a line at c + b sb + q sa. */
static csi_status launch_col(csi_ctx *ctx, cl_mem in, cl_mem out, const axis_plan *a, int pass,
                             cl_uint p, float sgn, size_t nc_, size_t sa_, size_t nb_, size_t sb_)
{
    int R = a->radix[pass];
    const bool v16 = col1v_fits(R, nc_);
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "fft", pass_kernel_name(v16 ? "col1v" : "col", R), &k));
    cl_uint L = (cl_uint)a->L, ts = (cl_uint)(a->L / ((size_t)p * (size_t)R));
    cl_uint nc = (cl_uint)nc_, sa = (cl_uint)sa_, nb = (cl_uint)nb_, sb = (cl_uint)sb_;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                     CSI_ARG(ts), CSI_ARG(sa), CSI_ARG(nc), CSI_ARG(nb), CSI_ARG(sb), CSI_ARG(sgn)));
    /* Exact launch: the local size divides nc (the kernel has no bounds check); the 16-wide
     * form runs one work-item per group of 16 columns. */
    size_t global[3] = {v16 ? nc_ / 16 : nc_, a->L / (size_t)R, nb_};
    size_t local[3] = {v16 ? 1 : pow2_dividing(nc_, 16), 1, 1};
    return csi_run(ctx, k, 3, global, local);
}

void csi_fft_filter_factor_buffers(const size_t c[3], csi_mem_tally *t)
{
    csi_mem_tally_add(t, 2 * half_stride(c[0] / 2) * sizeof(float), "filter factors");
    csi_mem_tally_add(t, 2 * c[1] * sizeof(float), "filter factors");
}

/* Whether the complex gain pass (pass `pass` of axis plan a, at p) runs as
 * csi_fft_col_cgain1v_r*: p = 1, radix 2, 4 or 8, and rows of hs (a multiple of 16) columns. */
static bool cgain1v_fits(const axis_plan *a, int pass, cl_uint p, size_t hs)
{
    const int R = a->radix[pass];
    return p == 1 && (R == 2 || R == 4 || R == 8) && hs % 16 == 0;
}

csi_status csi_fft_filter_set_factor(csi_fft_filter *f, const double *fc, const double *fa)
{
    if (f->nd != 2)
        return csi_fail(CSI_ERR_ARG, "FFT filter: a complex factor needs a 2-D filter (size %zu x "
                        "%zu x %zu)", f->c[0], f->c[1], f->c[2]);
    /* Stored as float like the Gaussian gains; the padding columns of the half spectrum get 0. */
    float *t = calloc(2 * (f->hs > f->c[1] ? f->hs : f->c[1]), sizeof *t);
    if (!t)
        return csi_fail(CSI_ERR_NOMEM, "FFT filter: out of host memory");
    for (size_t k = 0; k < 2 * (f->M + 1); k++)
        t[k] = (float)fc[k];
    csi_status st = upload_table(f->ctx, t, 2 * f->hs * sizeof *t, "filter factors", &f->fc);
    for (size_t k = 0; k < 2 * f->c[1]; k++)
        t[k] = (float)fa[k];
    if (st == CSI_OK)
        st = upload_table(f->ctx, t, 2 * f->c[1] * sizeof *t, "filter factors", &f->fa);
    free(t);
    for (int p = 0; p < f->ax[1].np && st == CSI_OK; p++) {
        cl_kernel k;
        st = csi_kernel(f->ctx, "fft", pass_kernel_name("col_cgain", f->ax[1].radix[p]), &k);
    }
    if (st == CSI_OK && f->ax[1].np > 0 && cgain1v_fits(&f->ax[1], 0, 1, f->hs)) {
        cl_kernel k;
        st = csi_kernel(f->ctx, "fft", pass_kernel_name("col_cgain1v", f->ax[1].radix[0]), &k);
    }
    return st;
}

/* A pass along axis a (1 = y, 2 = z) of the half spectrum; gain != 0 for the gain-fused one
 * (conj: with the complex factor conjugated). */
static csi_status col_pass(csi_fft_filter *f, cl_mem in, cl_mem out, int axis, int pass, cl_uint p,
                           float sgn, bool gain, bool conj)
{
    const axis_plan *a = &f->ax[axis];
    int R = a->radix[pass];
    const bool cgain = gain && f->fc;
    /* the complex gain pass on 16-wide vectors where it has one (kernels/fft.cl) */
    const bool v16 = cgain ? cgain1v_fits(a, pass, p, f->hs) : !gain && col1v_fits(R, f->hs);
    cl_kernel k;
    CSI_TRY(csi_kernel(f->ctx, "fft",
                       pass_kernel_name(v16 ? (cgain ? "col_cgain1v" : "col1v")
                                            : cgain ? "col_cgain" : gain ? "col_gain" : "col", R),
                       &k));
    size_t hs = f->hs, c1 = f->c[1];
    cl_uint L = (cl_uint)a->L, ts = (cl_uint)(a->L / ((size_t)p * (size_t)R));
    /* All hs columns (a multiple of 16, the padding ones are scratch): the kernel has no bounds
     * check, so the launch must be exact. */
    cl_uint nc = (cl_uint)hs, sa, nb, sb;
    if (axis == 1) { /* along y: lines (x, z) */
        sa = (cl_uint)hs;
        nb = (cl_uint)f->c[2];
        sb = (cl_uint)(hs * c1);
    } else { /* along z: lines (x, y) */
        sa = (cl_uint)(hs * c1);
        nb = (cl_uint)c1;
        sb = (cl_uint)hs;
    }
    if (gain) {
        /* The last axis carries the gain; the middle index b is y for z passes (3-D) and
         * absent (nb = 1) for y passes of a 2-D signal. */
        cl_mem gb = axis == 2 ? f->g1 : f->one, ga = axis == 2 ? f->g2 : f->g1;
        const float csgn = conj ? -1.0f : 1.0f;
        if (cgain)
            CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                             CSI_ARG(ts), CSI_ARG(sa), CSI_ARG(nc), CSI_ARG(nb), CSI_ARG(sb),
                             CSI_ARG(sgn), CSI_MEM(f->gx), CSI_MEM(gb), CSI_MEM(ga),
                             CSI_ARG(f->wiener), CSI_ARG(f->lambda), CSI_ARG(f->scale),
                             CSI_MEM(f->fc), CSI_MEM(f->fa), CSI_ARG(csgn)));
        else
            CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                             CSI_ARG(ts), CSI_ARG(sa), CSI_ARG(nc), CSI_ARG(nb), CSI_ARG(sb),
                             CSI_ARG(sgn), CSI_MEM(f->gx), CSI_MEM(gb), CSI_MEM(ga),
                             CSI_ARG(f->wiener), CSI_ARG(f->lambda), CSI_ARG(f->scale)));
    } else {
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(a->tw), CSI_ARG(L), CSI_ARG(p),
                         CSI_ARG(ts), CSI_ARG(sa), CSI_ARG(nc), CSI_ARG(nb), CSI_ARG(sb), CSI_ARG(sgn)));
    }
    size_t global[3] = {nc, a->L / (size_t)R, nb}, local[3] = {16, 1, 1};
    if (v16) {
        /* one work-item per group: with several along i, PoCL vectorised across them again
         * (into gathers) */
        global[0] = nc / 16;
        local[0] = 1;
    }
    return csi_run(f->ctx, k, 3, global, local);
}

static csi_status run_axis_cols(csi_fft_filter *f, cl_mem *cur, int axis, float sgn, bool gain_first,
                               bool conj)
{
    const axis_plan *a = &f->ax[axis];
    cl_uint p = 1;
    for (int i = 0; i < a->np; i++) {
        cl_mem dst = *cur == f->P ? f->Q : f->P;
        CSI_TRY(col_pass(f, *cur, dst, axis, i, p, sgn, gain_first && i == 0, conj));
        *cur = dst;
        p *= (cl_uint)a->radix[i];
    }
    return CSI_OK;
}

/* The passes along x of one block of n rows, from *cur through the block scratch A / B; the last
 * pass writes `last` when given. *cur: the buffer holding the result. */
static csi_status block_passes(csi_fft_filter *f, cl_mem *cur, cl_mem last, float sgn, size_t n)
{
    const axis_plan *ax = &f->ax[0];
    cl_uint p = 1;
    for (int i = 0; i < ax->np; i++) {
        cl_mem dst = last && i == ax->np - 1 ? last : (*cur == f->A ? f->B : f->A);
        CSI_TRY(launch_row(f->ctx, *cur, dst, ax, i, p, sgn, n, f->M, -1.0f));
        *cur = dst;
        p *= (cl_uint)ax->radix[i];
    }
    return CSI_OK;
}

/* One row stage on rows row0 .. row0 + n - 1 of the real rows `real` (M complex values a row)
 * and the half spectrum's block sv (those rows, hs values a row). Forward: the passes along x on
 * real's rows, then the unpacking into sv. Inverse: the packing of sv, then the passes along x,
 * the last writing real's rows. */
static csi_status block_stage(csi_fft_filter *f, cl_mem real, cl_mem sv, size_t row0, size_t n, bool forward)
{
    cl_mem rv = NULL;
    csi_status st = sub_buffer(real, row0 * f->M * 8, n * f->M * 8, &rv);
    cl_mem cur = forward ? rv : f->A;
    if (st == CSI_OK && forward)
        st = block_passes(f, &cur, NULL, -1.0f, n);
    if (st == CSI_OK)
        st = forward ? run_r2c_unpack(f->ctx, cur, sv, f->wn, f->M, f->hs, n)
                     : run_unpack(f->ctx, "csi_fft_c2r_pre", sv, cur, f->wn, f->M, f->hs, n);
    if (st == CSI_OK && !forward)
        st = block_passes(f, &cur, rv, 1.0f, n);
    /* OpenCL keeps a released buffer until the commands that use it have finished */
    if (rv)
        clReleaseMemObject(rv);
    return st;
}

/* A fused row stage (`kernel`: csi_fft_rows_r2c, real rows -> half spectrum, or csi_fft_rows_c2r
 * back) over all rows, one work-item per row with its two __local rows. */
static csi_status rows_fused(csi_fft_filter *f, const char *kernel, cl_mem in, cl_mem out)
{
    cl_kernel k;
    CSI_TRY(csi_kernel(f->ctx, "fft", kernel, &k));
    const cl_uint M = (cl_uint)f->M, hs = (cl_uint)f->hs;
    const size_t row_bytes = (f->M + 1) * 8;
    CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(f->ax[0].twp), CSI_MEM(f->wn), CSI_MEM(f->plan),
                     CSI_ARG(M), CSI_ARG(hs), CSI_LOCAL(row_bytes), CSI_LOCAL(row_bytes)));
    const size_t global[1] = {f->rows}, local[1] = {1};
    return csi_run(f->ctx, k, 1, global, local);
}

/* The fused column stage (cols_fused_fit) of a 2-D filter, spectrum in -> out (the same buffer
 * is allowed; the filter runs it in place): the forward passes along y, the gain pass (with the
 * complex factor, conjugated when conj), the inverse passes; one work-item per strip of 8
 * columns with its two __local volumes, or per two strips with three (cols_pair_fit). */
static csi_status cols_fused(csi_fft_filter *f, cl_mem in, cl_mem out, bool conj)
{
    cl_kernel k;
    const bool pair = cols_pair_fit(&f->ax[1], csi_ctx_local_mem(f->ctx));
    CSI_TRY(csi_kernel(f->ctx, "fft", pair ? "csi_fft_cols_2d_pair" : "csi_fft_cols_2d", &k));
    const cl_uint L = (cl_uint)f->c[1], hs = (cl_uint)f->hs, cplx = f->fc != NULL;
    const float csgn = conj ? -1.0f : 1.0f;
    /* without a factor the kernel reads neither table: any buffer will do */
    cl_mem fc = cplx ? f->fc : f->one, fa = cplx ? f->fa : f->one;
    const size_t strip_bytes = f->c[1] * 64;
#define COLS_ARGS                                                                                 \
    CSI_MEM(in), CSI_MEM(out), CSI_MEM(f->ax[1].tw), CSI_MEM(f->cplan), CSI_ARG(L), CSI_ARG(hs), CSI_MEM(f->gx), \
        CSI_MEM(f->g1), CSI_ARG(f->wiener), CSI_ARG(f->lambda), CSI_ARG(f->scale), CSI_ARG(cplx), CSI_MEM(fc), \
        CSI_MEM(fa), CSI_ARG(csgn), CSI_LOCAL(strip_bytes), CSI_LOCAL(strip_bytes)
    if (pair)
        CSI_TRY(CSI_ARGS(k, COLS_ARGS, CSI_LOCAL(strip_bytes)));
    else
        CSI_TRY(CSI_ARGS(k, COLS_ARGS));
#undef COLS_ARGS
    const size_t global[1] = {pair ? f->hs / 16 : f->hs / 8}, local[1] = {1};
    return csi_run(f->ctx, k, 1, global, local);
}

csi_status csi_fft_filter_run(csi_fft_filter *f, cl_mem x, cl_mem y)
{
    return csi_fft_filter_run_dir(f, x, y, false);
}

csi_status csi_fft_filter_run_dir(csi_fft_filter *f, cl_mem x, cl_mem y, bool conj)
{
    csi_ctx *ctx = f->ctx;
    const axis_plan *ax = &f->ax[0];
    cl_uint M = (cl_uint)f->M, hs = (cl_uint)f->hs, nrows = (cl_uint)f->rows;
    const size_t lx = 32;

    cl_mem cur = x;
    if (f->plan) {
        /* 1, 2 in one launch (rows_fused_fit): the half spectrum in P */
        CSI_TRY(rows_fused(f, "csi_fft_rows_r2c", x, f->P));
        cur = f->P;
    } else if (f->blk < f->rows) {
        /* 1, 2 block by block (row_block): the half spectrum in P */
        for (size_t b = 0, r0 = 0; b < f->nblk; b++, r0 += f->blk)
            CSI_TRY(block_stage(f, x, f->Pblk[b], r0, f->rows - r0 < f->blk ? f->rows - r0 : f->blk, true));
        cur = f->P;
    } else {
        /* 1. forward along x on the real rows read as M complex values */
        cl_uint p = 1;
        for (int i = 0; i < ax->np; i++) {
            cl_mem dst = cur == f->P ? f->Q : f->P;
            CSI_TRY(row_pass(f, cur, dst, ax, i, p, -1.0f));
            cur = dst;
            p *= (cl_uint)ax->radix[i];
        }
        /* 2. unpack to the half spectrum */
        {
            cl_mem dst = cur == f->P ? f->Q : f->P;
            CSI_TRY(run_r2c_unpack(ctx, cur, dst, f->wn, f->M, f->hs, f->rows));
            cur = dst;
        }
    }
    /* 3, 4: forward along y, z; inverse along z, y with the gain in the first inverse pass */
    if (f->cplan) {
        /* 3, 4 in one launch (cols_fused_fit, 2-D only), in place */
        CSI_TRY(cols_fused(f, cur, cur, conj));
    } else if (f->nd >= 2)
        CSI_TRY(run_axis_cols(f, &cur, 1, -1.0f, false, conj));
    if (f->nd == 3) {
        CSI_TRY(run_axis_cols(f, &cur, 2, -1.0f, false, conj));
        CSI_TRY(run_axis_cols(f, &cur, 2, 1.0f, true, conj));
    }
    if (f->nd >= 2 && !f->cplan)
        CSI_TRY(run_axis_cols(f, &cur, 1, 1.0f, f->nd == 2, conj));
    if (f->nd == 1) {
        cl_kernel k;
        CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_gain_rows", &k));
        cl_uint h0 = M + 1;
        CSI_TRY(CSI_ARGS(k, CSI_MEM(cur), CSI_MEM(f->gx), CSI_MEM(f->one), CSI_ARG(h0), CSI_ARG(hs),
                         CSI_ARG(nrows), CSI_ARG(f->wiener), CSI_ARG(f->lambda), CSI_ARG(f->scale)));
        size_t global[2] = {f->M + 1, f->rows}, local[2] = {lx, 1};
        CSI_TRY(csi_run(ctx, k, 2, global, local));
    }
    if (f->plan)
        return rows_fused(f, "csi_fft_rows_c2r", cur, y);
    if (f->blk < f->rows) {
        /* 5 block by block */
        cl_mem *spec = cur == f->P ? f->Pblk : f->Qblk;
        for (size_t b = 0, r0 = 0; b < f->nblk; b++, r0 += f->blk)
            CSI_TRY(block_stage(f, y, spec[b], r0, f->rows - r0 < f->blk ? f->rows - r0 : f->blk, false));
        return CSI_OK;
    }
    /* 5. pack, inverse along x; the last pass writes y */
    {
        cl_mem dst = ax->np == 0 ? y : (cur == f->P ? f->Q : f->P);
        CSI_TRY(run_unpack(ctx, "csi_fft_c2r_pre", cur, dst, f->wn, f->M, f->hs, f->rows));
        cur = dst;
    }
    cl_uint p = 1;
    for (int i = 0; i < ax->np; i++) {
        cl_mem dst = i == ax->np - 1 ? y : (cur == f->P ? f->Q : f->P);
        CSI_TRY(row_pass(f, cur, dst, ax, i, p, 1.0f));
        cur = dst;
        p *= (cl_uint)ax->radix[i];
    }
    return CSI_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Complex-to-complex transforms (the orthonormal Fourier basis)                               */

struct csi_fft_c2c {
    csi_ctx *ctx;
    size_t c[3], n;
    int nd;
    axis_plan ax[3];
    cl_mem Q;       /* scratch volume, n complex values */
    float scale;
};

bool csi_fft_c2c_supported(const size_t c[3], int nd)
{
    if (nd < 1 || nd > 3)
        return false;
    size_t n = 1;
    for (int a = 0; a < nd; a++) {
        if (c[a] < 2 || !factor_ok(c[a]))
            return false;
        n *= c[a];
    }
    /* Kernel arguments (lengths, strides) are 32-bit; element indices are size_t. */
    return n < ((size_t)1 << 32);
}

void csi_fft_c2c_free(csi_fft_c2c *f)
{
    if (!f)
        return;
    for (int a = 0; a < 3; a++) {
        csi_buffer_release(&f->ax[a].tw);
        csi_buffer_release(&f->ax[a].twp);
    }
    csi_buffer_release(&f->Q);
    free(f);
}

csi_status csi_fft_c2c_create(csi_ctx *ctx, const size_t c[3], int nd, float scale,
                              csi_fft_c2c **out)
{
    *out = NULL;
    if (!csi_fft_c2c_supported(c, nd))
        return csi_fail(CSI_ERR_ARG, "FFT: size %zu x %zu x %zu not supported by csi's FFT", c[0],
                        c[1], c[2]);
    csi_fft_c2c *f = calloc(1, sizeof *f);
    if (!f)
        return csi_fail(CSI_ERR_NOMEM, "FFT: out of host memory");
    f->ctx = ctx;
    f->nd = nd;
    f->scale = scale;
    f->n = 1;
    for (int a = 0; a < 3; a++) {
        f->c[a] = a < nd ? c[a] : 1;
        f->n *= f->c[a];
    }
    csi_status st = CSI_OK;
    for (int a = 0; a < nd && st == CSI_OK; a++) {
        f->ax[a].L = f->c[a];
        st = prepare_axis(ctx, &f->ax[a], a == 0, f->c[0], "row_s", false);
    }
    if (st == CSI_OK)
        st = csi_buffer(ctx, f->n * 8, CL_MEM_READ_WRITE, "the FFT's scratch volume", &f->Q);
    if (st != CSI_OK) {
        csi_fft_c2c_free(f);
        return st;
    }
    *out = f;
    return CSI_OK;
}

csi_status csi_fft_c2c_run(csi_fft_c2c *f, cl_mem x, cl_mem y, int sign)
{
    if (x == y || x == f->Q || y == f->Q)
        return csi_fail(CSI_ERR_ARG, "FFT: input, output and scratch must be different buffers");
    const float sgn = sign < 0 ? -1.0f : 1.0f;
    int total = 0;
    for (int a = 0; a < f->nd; a++)
        total += f->ax[a].np;
    /* Stockham passes are out of place: alternate between y and the scratch Q so that the last
     * pass lands in y (pass i writes y when total - 1 - i is even); x is only read. */
    cl_mem cur = x;
    int i = 0;
    const size_t c0 = f->c[0], c1 = f->c[1], c2 = f->c[2];
    for (int a = 0; a < f->nd; a++) {
        const axis_plan *ax = &f->ax[a];
        cl_uint p = 1;
        for (int q = 0; q < ax->np; q++, i++) {
            cl_mem dst = ((total - 1 - i) % 2 == 0) ? y : f->Q;
            if (a == 0)
                CSI_TRY(launch_row(f->ctx, cur, dst, ax, q, p, sgn, c1 * c2, c0,
                                   i == 0 ? f->scale : -1.0f));
            else if (a == 1) /* along y: lines (x, z) */
                CSI_TRY(launch_col(f->ctx, cur, dst, ax, q, p, sgn, c0, c0, c2, c0 * c1));
            else /* along z: lines (x, y) */
                CSI_TRY(launch_col(f->ctx, cur, dst, ax, q, p, sgn, c0, c0 * c1, c1, c0));
            cur = dst;
            p *= (cl_uint)ax->radix[q];
        }
    }
    return CSI_OK;
}

/* ------------------------------------------------------------------------------------------ */
/* Half-spectrum transforms of real signals (the real Fourier basis of Alg. 2)                 */

struct csi_fft_half {
    csi_ctx *ctx;
    size_t c[3], M, hs, rows;
    int nd;
    axis_plan ax[3];
    cl_mem wn, P, Q;
    float scale;
    /* The time stage (csi_fft_half_set_motion): the plain DFT until set; then the last axis is t. */
    int tkind;             /* CSI_FFT_TIME_DFT, _DCT or _NONE */
    bool shear;            /* the phase tables below are applied */
    cl_mem px, py;         /* shear phases: px[t hs + u0], py[t n1 + u1] (complex) */
    cl_mem dA, dB, iA, iB; /* DCT twiddles: analysis and synthesis (complex, T each) */
};

void csi_fft_half_free(csi_fft_half *h)
{
    if (!h)
        return;
    for (int a = 0; a < 3; a++) {
        csi_buffer_release(&h->ax[a].tw);
        csi_buffer_release(&h->ax[a].twp);
    }
    csi_buffer_release(&h->wn);
    csi_buffer_release(&h->P);
    csi_buffer_release(&h->Q);
    csi_buffer_release(&h->px);
    csi_buffer_release(&h->py);
    csi_buffer_release(&h->dA);
    csi_buffer_release(&h->dB);
    csi_buffer_release(&h->iA);
    csi_buffer_release(&h->iB);
    free(h);
}

size_t csi_fft_half_stride(const csi_fft_half *h) { return h->hs; }
size_t csi_fft_half_count(const csi_fft_half *h) { return h->hs * h->rows; }

csi_status csi_fft_half_create(csi_ctx *ctx, const size_t c[3], int nd, float scale,
                               csi_fft_half **out)
{
    *out = NULL;
    if (!csi_fft_filter_supported(c, nd))
        return csi_fail(CSI_ERR_ARG, "FFT: size %zu x %zu x %zu not supported by csi's real FFT "
                        "(the first axis must be even, >= 4, its half a product of 2, 3, 5, 7)",
                        c[0], c[1], c[2]);
    csi_fft_half *h = calloc(1, sizeof *h);
    if (!h)
        return csi_fail(CSI_ERR_NOMEM, "FFT: out of host memory");
    h->ctx = ctx;
    h->nd = nd;
    h->scale = scale;
    for (int a = 0; a < 3; a++)
        h->c[a] = a < nd ? c[a] : 1;
    h->M = h->c[0] / 2;
    h->hs = half_stride(h->M);
    h->rows = h->c[1] * h->c[2];
    csi_status st = CSI_OK;
    h->ax[0].L = h->M;
    h->ax[1].L = h->c[1];
    h->ax[2].L = h->c[2];
    for (int a = 0; a < nd && st == CSI_OK; a++) {
        st = prepare_axis(ctx, &h->ax[a], a == 0, h->hs, "row_s", false);
    }
    if (st == CSI_OK)
        st = twiddles(ctx, 2 * h->M, h->M + 1, &h->wn);
    const size_t bytes = spectrum_bytes(h->M, h->hs, h->rows);
    if (st == CSI_OK)
        st = csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "the real FFT's spectrum", &h->P);
    if (st == CSI_OK)
        st = csi_buffer(ctx, bytes, CL_MEM_READ_WRITE, "the real FFT's scratch", &h->Q);
    static const char *extra[] = {"csi_fft_r2c_post", "csi_fft_r2c_post16", "csi_fft_r2c_edges",
                                  "csi_fft_zero_pad", "csi_fft_c2r_pre_half"};
    for (size_t i = 0; i < 5 && st == CSI_OK; i++) {
        cl_kernel k;
        st = csi_kernel(ctx, "fft", extra[i], &k);
    }
    if (st != CSI_OK) {
        csi_fft_half_free(h);
        return st;
    }
    *out = h;
    return CSI_OK;
}

/* A chain of passes ping-ponging between P and Q whose last pass writes the output: `left`
 * counts the passes still to run, so each one learns whether it is the last. */
typedef struct {
    csi_fft_half *h;
    cl_mem cur, out;
    int left;
} half_chain;

static cl_mem chain_dst(half_chain *c)
{
    c->left--;
    if (c->left == 0)
        return c->out;
    return c->cur == c->h->P ? c->h->Q : c->h->P;
}

/* Passes along the strided axis `axis` (1 or 2; lines of hs columns). */
static csi_status half_cols(half_chain *ch, int axis, float sgn)
{
    csi_fft_half *h = ch->h;
    const axis_plan *a = &h->ax[axis];
    const size_t hs = h->hs, c1 = h->c[1], c2 = h->c[2];
    cl_uint p = 1;
    for (int i = 0; i < a->np; i++) {
        cl_mem dst = chain_dst(ch);
        if (axis == 1)
            CSI_TRY(launch_col(h->ctx, ch->cur, dst, a, i, p, sgn, hs, hs, c2, hs * c1));
        else
            CSI_TRY(launch_col(h->ctx, ch->cur, dst, a, i, p, sgn, hs, hs * c1, c1, hs));
        ch->cur = dst;
        p *= (cl_uint)a->radix[i];
    }
    return CSI_OK;
}

/* The time stage's geometry: the last axis is t, the one before it (if any spatial) n1. */
static void time_dims(const csi_fft_half *h, size_t *n1, size_t *T)
{
    *T = h->c[h->nd - 1];
    *n1 = h->nd == 3 ? h->c[1] : 1;
}

/* One kernel of the time stage over (hs, n1, T): the shear pass (csi_motion_phase; tables px,
 * py; synth selects the direction) or Makhoul's twiddles (csi_motion_tmix; tables A, B). */
static csi_status run_time_kernel(csi_fft_half *h, bool tmix, cl_mem in, cl_mem out, cl_mem ta,
                                  cl_mem tb, bool synth)
{
    size_t n1, T;
    time_dims(h, &n1, &T);
    cl_kernel k;
    CSI_TRY(csi_kernel(h->ctx, "fft", tmix ? "csi_motion_tmix" : "csi_motion_phase", &k));
    cl_uint hs = (cl_uint)h->hs, un1 = (cl_uint)n1, uT = (cl_uint)T;
    cl_uint reorder = h->tkind == CSI_FFT_TIME_DCT, dir = synth;
    if (tmix)
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(ta), CSI_MEM(tb), CSI_ARG(hs),
                         CSI_ARG(un1), CSI_ARG(uT)));
    else
        CSI_TRY(CSI_ARGS(k, CSI_MEM(in), CSI_MEM(out), CSI_MEM(ta), CSI_MEM(tb), CSI_ARG(hs),
                         CSI_ARG(un1), CSI_ARG(uT), CSI_ARG(reorder), CSI_ARG(dir)));
    size_t global[3] = {h->hs, n1, T}, local[3] = {16, 1, 1};
    return csi_run(h->ctx, k, 3, global, local);
}

/* exp(i phase) for phase = -2 pi f v (t - tc), f the signed frequency of index u along an axis
 * of n samples (numpy's fftfreq, but 0 at an even n's Nyquist bin: that component is its own
 * conjugate mirror, and no shift of it keeps a real volume real, so it is not moved; every other
 * phase pairs with its conjugate and the basis stays unitary), for u < count (rows of `stride`
 * entries per t; entries beyond count are 1); tc = (T - 1) / 2 centres the shear, so frame tc is
 * not moved. */
static float *shear_table(size_t n, size_t count, size_t stride, size_t T, double v)
{
    float *t = malloc(2 * stride * T * sizeof *t);
    if (!t)
        return NULL;
    const double tc = 0.5 * ((double)T - 1.0);
    for (size_t ti = 0; ti < T; ti++)
        for (size_t u = 0; u < stride; u++) {
            double ph = 0.0;
            if (u < count && n > 1 && 2 * u != n) {
                double f = (u < n / 2 ? (double)u : (double)u - (double)n) / (double)n;
                ph = -2.0 * PI_ * f * v * ((double)ti - tc);
            }
            t[2 * (ti * stride + u)] = (float)cos(ph);
            t[2 * (ti * stride + u) + 1] = (float)sin(ph);
        }
    return t;
}

/* Makhoul's twiddle tables (see csi_motion_tmix in kernels/fft.cl). The transforms
 * around them carry 1/sqrt(T) of the orthonormal scale (csi_fft_half's `scale`), so the DCT's
 * c_k = sqrt((k ? 2 : 1) / T) enters as c_k sqrt(T) / 2 in analysis and 1 / (c_k sqrt(T)) in
 * synthesis. */
static csi_status dct_tables(csi_fft_half *h, size_t T)
{
    float *t = malloc(8 * T * sizeof *t);
    if (!t)
        return csi_fail(CSI_ERR_NOMEM, "DCT tables: out of host memory");
    float *dA = t, *dB = t + 2 * T, *iA = t + 4 * T, *iB = t + 6 * T;
    for (size_t k = 0; k < T; k++) {
        double ang = PI_ * (double)k / (2.0 * (double)T), c = cos(ang), s = sin(ang);
        double e = k ? sqrt(0.5) : 0.5;          /* c_k sqrt(T) / 2 */
        double d = k ? sqrt(0.5) : 1.0;          /* 1 / (c_k sqrt(T)) */
        double dm = (T - k) % T ? sqrt(0.5) : 1.0; /* the same at T - k (unused at k = 0) */
        dA[2 * k] = (float)(e * c);
        dA[2 * k + 1] = (float)(-e * s);
        dB[2 * k] = (float)(e * c);
        dB[2 * k + 1] = (float)(e * s);
        iA[2 * k] = (float)(d * c);
        iA[2 * k + 1] = (float)(d * s);
        /* -i dm exp(i ang) = dm (sin ang - i cos ang); zero at k = 0 (C_T = 0) */
        iB[2 * k] = k ? (float)(dm * s) : 0.0f;
        iB[2 * k + 1] = k ? (float)(-dm * c) : 0.0f;
    }
    csi_status st = upload_table(h->ctx, dA, 2 * T * sizeof *t, "DCT twiddles", &h->dA);
    if (st == CSI_OK)
        st = upload_table(h->ctx, dB, 2 * T * sizeof *t, "DCT twiddles", &h->dB);
    if (st == CSI_OK)
        st = upload_table(h->ctx, iA, 2 * T * sizeof *t, "DCT twiddles", &h->iA);
    if (st == CSI_OK)
        st = upload_table(h->ctx, iB, 2 * T * sizeof *t, "DCT twiddles", &h->iB);
    free(t);
    return st;
}

/* Whether the time stage has its phase (and reordering) pass. */
static bool phase_pass(const csi_fft_half *h) { return h->shear || h->tkind != CSI_FFT_TIME_DFT; }

csi_status csi_fft_half_set_motion(csi_fft_half *h, int tkind, const double v[2])
{
    if (h->nd < 2)
        return csi_fail(CSI_ERR_ARG, "motion basis: needs a time axis after a spatial one");
    if (tkind != CSI_FFT_TIME_DFT && tkind != CSI_FFT_TIME_DCT && tkind != CSI_FFT_TIME_NONE)
        return csi_fail(CSI_ERR_ARG, "motion basis: unknown time transform %d", tkind);
    for (int a = 0; a < 2; a++)
        if (!isfinite(v[a]))
            return csi_fail(CSI_ERR_ARG, "motion basis: velocity is not finite");
    size_t n1, T;
    time_dims(h, &n1, &T);
    static const char *kn[] = {"csi_motion_phase", "csi_motion_tmix"};
    for (int i = 0; i < 2; i++) {
        cl_kernel k;
        CSI_TRY(csi_kernel(h->ctx, "fft", kn[i], &k));
    }
    /* Every table on the first call, whatever it asks for (csi_fft_half_motion_buffers: the
     * same buffers whichever stage a caller ends up with), then rewritten in place. */
    if (!h->dA) {
        CSI_TRY(csi_buffer(h->ctx, 2 * h->hs * T * sizeof(float), CL_MEM_READ_ONLY, "shear phases", &h->px));
        CSI_TRY(csi_buffer(h->ctx, 2 * n1 * T * sizeof(float), CL_MEM_READ_ONLY, "shear phases", &h->py));
        CSI_TRY(dct_tables(h, T));
    }
    h->tkind = tkind;
    h->shear = v[0] != 0.0 || (h->nd == 3 && v[1] != 0.0);
    /* The phase pass also runs without a shear when the DCT needs its reordering, or when t is
     * not transformed: then the phases carry sqrt(T), the part of the orthonormal scale that the
     * missing transform along t would have cancelled. */
    if (!phase_pass(h))
        return CSI_OK;
    float *tx = shear_table(h->c[0], h->M + 1, h->hs, T, h->shear ? v[0] : 0.0);
    float *ty = shear_table(n1, n1, n1, T, h->shear && h->nd == 3 ? v[1] : 0.0);
    csi_status st = tx && ty ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "shear tables: out of host memory");
    if (st == CSI_OK && tkind == CSI_FFT_TIME_NONE)
        for (size_t i = 0; i < 2 * h->hs * T; i++)
            tx[i] = (float)(tx[i] * sqrt((double)T));
    if (st == CSI_OK)
        st = csi_write(h->ctx, h->px, 0, 2 * h->hs * T * sizeof *tx, tx);
    if (st == CSI_OK)
        st = csi_write(h->ctx, h->py, 0, 2 * n1 * T * sizeof *ty, ty);
    free(tx);
    free(ty);
    return st;
}

void csi_fft_half_motion_buffers(const size_t c[3], int nd, csi_mem_tally *t)
{
    const size_t hs = half_stride(c[0] / 2), T = c[nd - 1], n1 = nd == 3 ? c[1] : 1;
    csi_mem_tally_add(t, 2 * hs * T * sizeof(float), "shear phases");
    csi_mem_tally_add(t, 2 * n1 * T * sizeof(float), "shear phases");
    for (int i = 0; i < 4; i++)
        csi_mem_tally_add(t, 2 * T * sizeof(float), "DCT twiddles");
}

/* Passes of the time stage in each direction (0 when it is the plain DFT). */
static int time_passes(const csi_fft_half *h)
{
    const int taxis = h->nd - 1;
    const bool reorder = h->tkind == CSI_FFT_TIME_DCT;
    int n = phase_pass(h) ? 1 : 0;
    if (h->tkind != CSI_FFT_TIME_NONE)
        n += h->ax[taxis].np;
    if (reorder)
        n++;
    return n;
}

/* The forward transform's passes: the spatial stage (the rows, the half spectrum's unpacking,
 * and the columns of the spatial axis before t, if any) when `space`, else f holds its output;
 * then the rest (the time stage, or the plain DFT along the last axis) when `rest`. The same
 * kernels in the same order either way, so the parts chained give csi_fft_half_forward's bits. */
static csi_status forward_passes(csi_fft_half *h, cl_mem f, cl_mem z, bool space, bool rest)
{
    if (f == z || f == h->P || f == h->Q || z == h->P || z == h->Q)
        return csi_fail(CSI_ERR_ARG, "real FFT: input, output and scratch must be different buffers");
    csi_ctx *ctx = h->ctx;
    const axis_plan *ax = &h->ax[0];
    const bool timed = h->tkind != CSI_FFT_TIME_DFT || h->shear;
    const int taxis = h->nd - 1;
    cl_uint M = (cl_uint)h->M, hs = (cl_uint)h->hs, nrows = (cl_uint)h->rows;
    const int spatial_cols = h->nd == 3 ? h->ax[1].np : 0;
    /* a single axis (nd = 1) is all space */
    const int later = h->nd < 2 ? 0 : timed ? time_passes(h) : h->ax[taxis].np;
    half_chain ch = {h, f, z, (space ? ax->np + 1 + spatial_cols : 0) + (rest ? later : 0)};
    if (ch.left == 0)
        return csi_fail(CSI_ERR_ARG, "real FFT: no pass to run");
    if (space) {
        /* 1. rows as M complex values, scaled by `scale` in the first pass */
        cl_uint p = 1;
        for (int i = 0; i < ax->np; i++) {
            cl_mem dst = chain_dst(&ch);
            CSI_TRY(launch_row(ctx, ch.cur, dst, ax, i, p, -1.0f, h->rows, h->M, i == 0 ? h->scale : -1.0f));
            ch.cur = dst;
            p *= (cl_uint)ax->radix[i];
        }
        /* 2. unpack to the half spectrum, zero the padding */
        {
            cl_mem dst = chain_dst(&ch);
            cl_kernel k;
            CSI_TRY(run_r2c_unpack(ctx, ch.cur, dst, h->wn, h->M, h->hs, h->rows));
            cl_uint npad = (cl_uint)(h->hs - h->M - 1);
            if (npad > 0) {
                CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_zero_pad", &k));
                CSI_TRY(CSI_ARGS(k, CSI_MEM(dst), CSI_ARG(M), CSI_ARG(hs), CSI_ARG(nrows), CSI_ARG(npad)));
                size_t g2[2] = {npad, h->rows}, l2[2] = {16, 4};
                CSI_TRY(csi_run(ctx, k, 2, g2, l2));
            }
            ch.cur = dst;
        }
        /* 3. the spatial axis before t (y) */
        if (h->nd == 3)
            CSI_TRY(half_cols(&ch, 1, -1.0f));
    }
    if (!rest || h->nd < 2)
        return CSI_OK;
    if (!timed)
        /* 4. forward along the last axis */
        return half_cols(&ch, taxis, -1.0f);
    /* 4. the time stage: unshear (and reorder for the DCT), DFT along t, Makhoul's twiddles for
     * the DCT */
    const bool reorder = h->tkind == CSI_FFT_TIME_DCT;
    if (phase_pass(h)) {
        cl_mem dst = chain_dst(&ch);
        CSI_TRY(run_time_kernel(h, false, ch.cur, dst, h->px, h->py, false));
        ch.cur = dst;
    }
    if (h->tkind != CSI_FFT_TIME_NONE)
        CSI_TRY(half_cols(&ch, taxis, -1.0f));
    if (reorder) {
        cl_mem dst = chain_dst(&ch);
        CSI_TRY(run_time_kernel(h, true, ch.cur, dst, h->dA, h->dB, false));
        ch.cur = dst;
    }
    return CSI_OK;
}

csi_status csi_fft_half_forward(csi_fft_half *h, cl_mem f, cl_mem z) { return forward_passes(h, f, z, true, true); }

csi_status csi_fft_half_forward_space(csi_fft_half *h, cl_mem f, cl_mem zs)
{
    return forward_passes(h, f, zs, true, false);
}

csi_status csi_fft_half_forward_rest(csi_fft_half *h, cl_mem zs, cl_mem z)
{
    return forward_passes(h, zs, z, false, true);
}

csi_status csi_fft_half_inverse(csi_fft_half *h, cl_mem z, cl_mem f)
{
    if (f == z || f == h->P || f == h->Q || z == h->P || z == h->Q)
        return csi_fail(CSI_ERR_ARG, "real FFT: input, output and scratch must be different buffers");
    csi_ctx *ctx = h->ctx;
    const axis_plan *ax = &h->ax[0];
    const bool timed = h->tkind != CSI_FFT_TIME_DFT || h->shear;
    const int taxis = h->nd - 1;
    cl_uint M = (cl_uint)h->M, hs = (cl_uint)h->hs, nrows = (cl_uint)h->rows;
    half_chain ch = {h, z, f, 1 + ax->np};
    if (timed)
        ch.left += (h->nd == 3 ? h->ax[1].np : 0) + time_passes(h);
    else
        for (int a = 1; a < h->nd; a++)
            ch.left += h->ax[a].np;
    if (timed) {
        /* 1. the time stage in reverse: Makhoul's synthesis twiddles, inverse DFT along t, shear
         * (and restore the order) */
        const bool reorder = h->tkind == CSI_FFT_TIME_DCT;
        if (reorder) {
            cl_mem dst = chain_dst(&ch);
            CSI_TRY(run_time_kernel(h, true, ch.cur, dst, h->iA, h->iB, true));
            ch.cur = dst;
        }
        if (h->tkind != CSI_FFT_TIME_NONE)
            CSI_TRY(half_cols(&ch, taxis, 1.0f));
        if (phase_pass(h)) {
            cl_mem dst = chain_dst(&ch);
            CSI_TRY(run_time_kernel(h, false, ch.cur, dst, h->px, h->py, true));
            ch.cur = dst;
        }
        if (h->nd == 3)
            CSI_TRY(half_cols(&ch, 1, 1.0f));
    } else {
        /* 1. inverse along z, then y */
        for (int a = h->nd - 1; a >= 1; a--)
            CSI_TRY(half_cols(&ch, a, 1.0f));
    }
    /* 2. pack with the self-conjugate bins' real parts doubled, scaled */
    {
        cl_mem dst = chain_dst(&ch);
        cl_kernel k;
        CSI_TRY(csi_kernel(ctx, "fft", "csi_fft_c2r_pre_half", &k));
        CSI_TRY(CSI_ARGS(k, CSI_MEM(ch.cur), CSI_MEM(dst), CSI_MEM(h->wn), CSI_ARG(M), CSI_ARG(hs),
                         CSI_ARG(nrows), CSI_ARG(h->scale)));
        size_t ex = pow2_dividing(h->M, 64), ey = pow2_dividing(h->rows, 64 / ex);
        size_t global[2] = {h->M, h->rows}, local[2] = {ex, ey};
        CSI_TRY(csi_run(ctx, k, 2, global, local));
        ch.cur = dst;
    }
    /* 3. inverse along x; the last pass writes f */
    cl_uint p = 1;
    for (int i = 0; i < ax->np; i++) {
        cl_mem dst = chain_dst(&ch);
        CSI_TRY(launch_row(ctx, ch.cur, dst, ax, i, p, 1.0f, h->rows, h->M, -1.0f));
        ch.cur = dst;
        p *= (cl_uint)ax->radix[i];
    }
    return CSI_OK;
}
