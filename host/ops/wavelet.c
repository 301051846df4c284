/* The 2-D periodized orthonormal Daubechies wavelet operator (see csi/wavelet.h).
 *
 * Filters rather than lifting: PyWavelets' periodization path is defined by the filters
 * (pywt/_extensions/c/convolution.template.c), so the same index formula reproduces it exactly,
 * including bands shorter than the filter where taps wrap around several times; the adjoint is
 * the same coefficients with transposed indices, orthonormal to float rounding by construction.
 * A lifting factorisation (Daubechies & Sweldens 1998) would save about half the multiply-adds,
 * but its steps have coefficients of widely varying size (more float rounding for db8), it needs
 * its own handling of wrap-around for short bands, and its in-place steps are sequential passes
 * over memory. The filter kernels already run at roughly half of the CPU device's fma peak
 * (docs/bench/wavelet.md).
 *
 * Per level: one x pass (rows) and one y pass (columns), out of place between the output and one
 * scratch image made at create; or, where the input and output are distinct buffers and a band
 * of the finest level's rows fits the device's local memory (fused_fit), both passes of a level
 * in one launch (the *_xy kernels, the same bits), which reads the level's input and writes its
 * output once. The forward transform reads the input only in level 1's x pass
 * and writes the output only from y passes, so it never writes its input and also works in
 * place; the inverse reads the coarsest approximation straight from the coefficient vector and
 * the details where they lie (no copy), and each level consumes the coefficients it overwrites
 * before writing them, so it works in place too. */
#include "csi/wavelet.h"

#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    csi_wavelet_family family;
    size_t w, h;
    int levels;
    size_t ts;  /* row stride of the scratch image, w + 16: see csi_wavelet_create */
    cl_mem tmp; /* one ts x h scratch image */
    /* Per pass an interior kernel (16-wide, no edge branch) and an edge kernel (scalar,
     * periodic wrap) for the outputs the interior one does not cover. */
    cl_kernel fwd_x, fwd_xw, fwd_xe, fwd_y, fwd_ye, inv_x, inv_xw, inv_xe, inv_y, inv_ye;
    /* Both passes of a level in one launch (fused_fit), NULL where a band does not fit. */
    cl_kernel fwd_xy, inv_xy;
    cl_ulong local; /* the device's local memory, bytes */
} wavelet_state;

const char *csi_wavelet_name(csi_wavelet_family f)
{
    switch (f) {
    case CSI_WAVELET_DB4: return "db4";
    case CSI_WAVELET_DB8: return "db8";
    }
    return "?";
}

int csi_wavelet_taps(csi_wavelet_family f)
{
    switch (f) {
    case CSI_WAVELET_DB4: return 8;
    case CSI_WAVELET_DB8: return 16;
    }
    return 0;
}

/* The decomposition low-pass filters of kernels/wavelet.cl (PyWavelets' dec_lo), in double for
 * the host's frequency responses. */
static const double db4_lo[8] = {
    -0.010597401785069032, 0.032883011666885197, 0.030841381835560764, -0.18703481171909309,
    -0.027983769416859854, 0.63088076792985892, 0.71484657055291567, 0.23037781330889651};
static const double db8_lo[16] = {
    -0.00011747678412476953, 0.00067544940645056933, -0.00039174037337694705,
    -0.0048703529934515741, 0.0087460940474057766, 0.013981027917398282,
    -0.044088253930794755, -0.017369301001807547, 0.12874742662047847,
    0.00047248457391328279, -0.28401554296154691, -0.015829105256349306,
    0.58535468365420673, 0.67563073629728976, 0.31287159091429995, 0.054415842243104008};

const double *csi_wavelet_lowpass(csi_wavelet_family f)
{
    switch (f) {
    case CSI_WAVELET_DB4: return db4_lo;
    case CSI_WAVELET_DB8: return db8_lo;
    }
    return NULL;
}

csi_status csi_wavelet_parse(const char *s, csi_wavelet_family *out)
{
    if (s && strcmp(s, "db4") == 0) {
        *out = CSI_WAVELET_DB4;
        return CSI_OK;
    }
    if (s && strcmp(s, "db8") == 0) {
        *out = CSI_WAVELET_DB8;
        return CSI_OK;
    }
    return csi_fail(CSI_ERR_ARG, "unknown wavelet '%s': expected db4 (8 taps) or db8 (16 taps)",
                    s ? s : "(null)");
}

/* Number of factors of two common to w and h (both non-zero). */
static int common_twos(size_t w, size_t h)
{
    int t = 0;
    while (((w >> t) & 1) == 0 && ((h >> t) & 1) == 0)
        t++;
    return t;
}

int csi_wavelet_default_levels(csi_wavelet_family f, size_t w, size_t h)
{
    int taps = csi_wavelet_taps(f);
    if (taps == 0 || w == 0 || h == 0 || w % 2 || h % 2)
        return 0;
    /* Factors of two common to both sides. */
    int twos = common_twos(w, h);
    /* pywt.dwt_max_level(min(w, h), taps) = floor(log2(min / (taps - 1))), 0 if min < taps - 1. */
    size_t m = w < h ? w : h;
    int maxl = 0;
    while ((m >> (maxl + 1)) >= (size_t)(taps - 1))
        maxl++;
    int l = maxl < twos ? maxl : twos;
    return l < 1 ? 1 : l;
}

static wavelet_state *state_of(const csi_linop *op) { return (wavelet_state *)op->state; }

void csi_wavelet_coarse_block(const csi_linop *op, size_t *cw, size_t *ch)
{
    const wavelet_state *s = state_of(op);
    if (cw)
        *cw = s->w >> s->levels;
    if (ch)
        *ch = s->h >> s->levels;
}

csi_wavelet_family csi_wavelet_family_of(const csi_linop *op) { return state_of(op)->family; }
int csi_wavelet_levels(const csi_linop *op) { return state_of(op)->levels; }

/* Largest power of two <= min(n, cap), at least 1. */
static size_t pow2_at_most(size_t n, size_t cap)
{
    size_t m = n < cap ? n : cap, p = 1;
    while (p * 2 <= m)
        p *= 2;
    return p;
}

/* Launch a 2-D pass over g0 x g1 items with a local size fitted to small regions (coarse levels
 * can be a few items wide): up to 64 along the contiguous dimension, 256 items per group. */
static csi_status run2(csi_ctx *ctx, cl_kernel k, size_t g0, size_t g1)
{
    size_t global[2] = {g0, g1};
    size_t l0 = pow2_at_most(g0, 64);
    size_t local[2] = {l0, pow2_at_most(g1, 256 / l0)};
    return csi_run(ctx, k, 2, global, local);
}

/* Split of one x pass over a band of nh outputs (or coefficient pairs) into 16-wide chunks
 * c (outputs [16c, 16c + 16)): chunks [clo, chi) whose input window lies inside the band go to
 * the interior kernel; the other full chunks, [0, clo) and [chi, full), to the wrapped-window
 * kernel; the last nh % 16 outputs to the scalar kernel. `reach` is the last chunk index whose
 * window ends inside the band (may be negative). */
typedef struct {
    cl_uint first, items;    /* interior: first output, number of chunks */
    cl_uint lo, hi, wrapped; /* wrapped chunks: c < lo and c >= hi, `wrapped` of them */
    cl_uint rest, nrest;     /* scalar outputs [rest, rest + nrest) */
} xsplit;

static xsplit split_x(long nh, long reach)
{
    xsplit x = {0};
    const long full = nh / 16, clo = 1; /* chunk 0 starts left of the band for F <= 64 */
    const long chi = reach + 1 < full ? reach + 1 : full;
    if (chi > clo) {
        x.first = (cl_uint)(16 * clo);
        x.items = (cl_uint)(chi - clo);
        x.lo = (cl_uint)clo;
        x.hi = (cl_uint)chi;
    } else {
        x.lo = x.hi = (cl_uint)full;
    }
    x.wrapped = x.lo + ((cl_uint)full - x.hi);
    x.rest = (cl_uint)(16 * full);
    x.nrest = (cl_uint)(nh - 16 * full);
    return x;
}

/* Floor division for a possibly negative numerator. */
static long floor_div(long a, long b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/* One y pass over a region cols wide and n high (n/2 outputs or pairs per column), with kernel
 * `vec` for the interior rows [F/4, n/2 - F/4) of full 16-column groups, and `edge` for the edge
 * rows of every column and the leftover columns of interior rows. Both passes (analysis and
 * synthesis) have the same interior: analysis output o reads rows 2o + F/2 - j (j < F), synthesis
 * pair p reads p - F/4 + k (k <= F/2) of each half. */
static csi_status run_y(csi_ctx *ctx, cl_kernel vec, cl_kernel edge, cl_mem src, cl_mem dst,
                        cl_uint sstride, cl_uint dstride, cl_uint cols, cl_uint n, cl_uint F)
{
    const cl_uint nh = n / 2, groups = cols / 16;
    /* The interior kernel takes rows two at a time; an odd last row goes to the edge kernel. */
    const cl_uint r0 = F / 4, avail = nh > F / 2 ? nh - F / 2 : 0;
    const cl_uint pairs = avail / 2, inner = 2 * pairs, r1 = r0 + inner;
    if (pairs && groups) {
        CSI_TRY(CSI_ARGS(vec, CSI_MEM(src), CSI_MEM(dst), CSI_ARG(sstride), CSI_ARG(dstride), CSI_ARG(n), CSI_ARG(groups),
                         CSI_ARG(r0), CSI_ARG(pairs)));
        CSI_TRY(run2(ctx, vec, groups, pairs));
    }
    /* Edge rows, all columns (all rows when there is no interior). */
    const cl_uint x0 = 0, lo = inner ? r0 : nh, hi = inner ? r1 : nh, count = nh - inner;
    CSI_TRY(CSI_ARGS(edge, CSI_MEM(src), CSI_MEM(dst), CSI_ARG(sstride), CSI_ARG(dstride), CSI_ARG(n), CSI_ARG(x0),
                     CSI_ARG(cols), CSI_ARG(lo), CSI_ARG(hi), CSI_ARG(count)));
    CSI_TRY(run2(ctx, edge, (cols + 15) / 16, count)); /* 16 columns per item */
    /* Interior rows of the columns past the last full group: i maps to row r0 + i. */
    const cl_uint tx = 16 * groups, tw = cols - tx, zero = 0;
    if (inner && tw) {
        CSI_TRY(CSI_ARGS(edge, CSI_MEM(src), CSI_MEM(dst), CSI_ARG(sstride), CSI_ARG(dstride), CSI_ARG(n), CSI_ARG(tx),
                         CSI_ARG(tw), CSI_ARG(zero), CSI_ARG(r0), CSI_ARG(inner)));
        CSI_TRY(run2(ctx, edge, (tw + 15) / 16, inner));
    }
    return CSI_OK;
}

/* The fused levels' intermediate approximations live in the scratch image, alternately in its
 * top and bottom half (a level reads one while it writes the other): the one made or read by
 * level l (0 = finest) starts at row (l % 2) h/2 of the scratch image, in floats. */
static cl_uint scratch_half(const wavelet_state *s, int l)
{
    return (cl_uint)((size_t)(l % 2) * (s->h / 2) * s->ts);
}

/* The largest band the fused kernels take: output rows (analysis) or row pairs (synthesis) per
 * work-item. Larger bands compute fewer x rows twice (F - 2 or F/2 per band) but need more local
 * memory. */
#define BAND_MAX 16

/* Bytes of local memory a fused level's band of B needs at width n: its x rows (2B + F - 2 for
 * the analysis, 2 (B + F/2) for the synthesis, the larger for F >= 4), each 2 ceil(n/32) float16. */
static size_t band_bytes(size_t n, int F, size_t B)
{
    return (2 * B + (size_t)F) * 2 * ((n / 2 + 15) / 16) * 64;
}

/* The band for width n within `local` bytes, 0 if not even a band of 1 fits. */
static size_t band_rows(size_t n, int F, cl_ulong local)
{
    size_t B = BAND_MAX;
    while (B > 0 && band_bytes(n, F, B) > local)
        B--;
    return B;
}

/* One fused launch over m rows: a work-item (and a work-group) per band of B. */
static csi_status run_bands(csi_ctx *ctx, cl_kernel k, cl_uint m, cl_uint B)
{
    const size_t global[1] = {(m / 2 + B - 1) / B}, local[1] = {1};
    return csi_run(ctx, k, 1, global, local);
}

/* Forward DWT with each level's two passes in one launch (img and coef distinct): level l reads
 * the image (l = 0) or the previous level's approximation in the scratch image, writes its
 * details into coef and its approximation into the scratch image, or into coef at the last
 * level. */
static csi_status analysis_fused(wavelet_state *s, csi_ctx *ctx, cl_mem img, cl_mem coef)
{
    const cl_uint stride = (cl_uint)s->w, ts = (cl_uint)s->ts;
    const int F = csi_wavelet_taps(s->family);
    for (int l = 0; l < s->levels; l++) {
        const cl_uint n = (cl_uint)(s->w >> l), m = (cl_uint)(s->h >> l);
        const bool first = l == 0, last = l == s->levels - 1;
        const cl_uint B = (cl_uint)band_rows(n, F, s->local);
        cl_mem src = first ? img : s->tmp, ll = last ? coef : s->tmp;
        const cl_uint soff = first ? 0 : scratch_half(s, l - 1), sstride = first ? stride : ts;
        const cl_uint loff = last ? 0 : scratch_half(s, l), lstride = last ? stride : ts;
        CSI_TRY(CSI_ARGS(s->fwd_xy, CSI_MEM(src), CSI_ARG(soff), CSI_ARG(sstride), CSI_MEM(ll),
                         CSI_ARG(loff), CSI_ARG(lstride), CSI_MEM(coef), CSI_ARG(stride), CSI_ARG(n),
                         CSI_ARG(m), CSI_ARG(B), CSI_LOCAL(band_bytes(n, F, B))));
        CSI_TRY(run_bands(ctx, s->fwd_xy, m, B));
    }
    return CSI_OK;
}

/* Inverse DWT with each level's two passes in one launch (coef and img distinct), coarsest level
 * first: it reads its approximation from coef, the finer ones from the scratch image; each level
 * but the finest writes the scratch image, the finest the image. */
static csi_status synthesis_fused(wavelet_state *s, csi_ctx *ctx, cl_mem coef, cl_mem img)
{
    const cl_uint stride = (cl_uint)s->w, ts = (cl_uint)s->ts;
    const int F = csi_wavelet_taps(s->family);
    for (int l = s->levels - 1; l >= 0; l--) {
        const cl_uint n = (cl_uint)(s->w >> l), m = (cl_uint)(s->h >> l);
        const bool coarsest = l == s->levels - 1, finest = l == 0;
        const cl_uint B = (cl_uint)band_rows(n, F, s->local);
        cl_mem approx = coarsest ? coef : s->tmp, dst = finest ? img : s->tmp;
        const cl_uint aoff = coarsest ? 0 : scratch_half(s, l), astride = coarsest ? stride : ts;
        const cl_uint doff = finest ? 0 : scratch_half(s, l - 1), dstride = finest ? stride : ts;
        CSI_TRY(CSI_ARGS(s->inv_xy, CSI_MEM(approx), CSI_ARG(aoff), CSI_ARG(astride), CSI_MEM(coef),
                         CSI_ARG(stride), CSI_MEM(dst), CSI_ARG(doff), CSI_ARG(dstride), CSI_ARG(n),
                         CSI_ARG(m), CSI_ARG(B), CSI_LOCAL(band_bytes(n, F, B))));
        CSI_TRY(run_bands(ctx, s->inv_xy, m, B));
    }
    return CSI_OK;
}

/* adjoint: image y -> coefficients x (forward DWT). */
static csi_status wavelet_analysis(const csi_linop *op, cl_mem img, cl_mem coef)
{
    wavelet_state *s = state_of(op);
    if (s->fwd_xy && img != coef)
        return analysis_fused(s, op->ctx, img, coef);
    const cl_uint stride = (cl_uint)s->w, ts = (cl_uint)s->ts;
    const long F = csi_wavelet_taps(s->family);
    for (int l = 0; l < s->levels; l++) {
        const cl_uint n = (cl_uint)(s->w >> l), m = (cl_uint)(s->h >> l);
        cl_mem src = l == 0 ? img : coef;
        /* Output o reads row[2o + F/2 - j], j < F; chunk c (outputs from 16c) reads the 48
         * samples from 32c - F/2: inside the row for c >= 1 and 32c - F/2 + 48 <= n. */
        const xsplit x = split_x(n / 2, floor_div((long)n + F / 2 - 48, 32));
        const cl_uint zero = 0;
        if (x.items) {
            CSI_TRY(CSI_ARGS(s->fwd_x, CSI_MEM(src), CSI_MEM(s->tmp), CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n),
                             CSI_ARG(m), CSI_ARG(x.first), CSI_ARG(x.items)));
            CSI_TRY(run2(op->ctx, s->fwd_x, x.items, m));
        }
        if (x.wrapped) {
            CSI_TRY(CSI_ARGS(s->fwd_xw, CSI_MEM(src), CSI_MEM(s->tmp), CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n),
                             CSI_ARG(m), CSI_ARG(x.lo), CSI_ARG(x.hi), CSI_ARG(x.wrapped)));
            CSI_TRY(run2(op->ctx, s->fwd_xw, x.wrapped, m));
        }
        if (x.nrest) {
            CSI_TRY(CSI_ARGS(s->fwd_xe, CSI_MEM(src), CSI_MEM(s->tmp), CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n),
                             CSI_ARG(m), CSI_ARG(zero), CSI_ARG(x.rest)));
            CSI_TRY(run2(op->ctx, s->fwd_xe, x.nrest, m));
        }
        CSI_TRY(run_y(op->ctx, s->fwd_y, s->fwd_ye, s->tmp, coef, ts, stride, n, m, (cl_uint)F));
    }
    return CSI_OK;
}

/* apply: coefficients x -> image y (inverse DWT), coarsest level first. */
static csi_status wavelet_synthesis(const csi_linop *op, cl_mem coef, cl_mem img)
{
    wavelet_state *s = state_of(op);
    if (s->inv_xy && coef != img)
        return synthesis_fused(s, op->ctx, coef, img);
    const cl_uint stride = (cl_uint)s->w, ts = (cl_uint)s->ts;
    const long F = csi_wavelet_taps(s->family);
    for (int l = s->levels; l >= 1; l--) {
        const cl_uint n = (cl_uint)(s->w >> (l - 1)), m = (cl_uint)(s->h >> (l - 1));
        const cl_uint arows = m / 2;
        cl_mem approx = l == s->levels ? coef : img;
        /* Pair p reads coefficients p - F/4 + k, k <= F/2; chunk c (pairs from 16c) reads the
         * 24 from 16c - F/4: inside the band for c >= 1 and 16c - F/4 + 24 <= n/2. */
        const xsplit x = split_x(n / 2, floor_div((long)n / 2 + F / 4 - 24, 16));
        const cl_uint zero = 0;
        if (x.items) {
            CSI_TRY(CSI_ARGS(s->inv_x, CSI_MEM(approx), CSI_MEM(coef), CSI_MEM(s->tmp),
                             CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n), CSI_ARG(m), CSI_ARG(arows), CSI_ARG(x.first),
                             CSI_ARG(x.items)));
            CSI_TRY(run2(op->ctx, s->inv_x, x.items, m));
        }
        if (x.wrapped) {
            CSI_TRY(CSI_ARGS(s->inv_xw, CSI_MEM(approx), CSI_MEM(coef), CSI_MEM(s->tmp),
                             CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n), CSI_ARG(m), CSI_ARG(arows), CSI_ARG(x.lo),
                             CSI_ARG(x.hi), CSI_ARG(x.wrapped)));
            CSI_TRY(run2(op->ctx, s->inv_xw, x.wrapped, m));
        }
        if (x.nrest) {
            CSI_TRY(CSI_ARGS(s->inv_xe, CSI_MEM(approx), CSI_MEM(coef), CSI_MEM(s->tmp),
                             CSI_ARG(stride), CSI_ARG(ts), CSI_ARG(n), CSI_ARG(m), CSI_ARG(arows), CSI_ARG(zero),
                             CSI_ARG(x.rest)));
            CSI_TRY(run2(op->ctx, s->inv_xe, x.nrest, m));
        }
        CSI_TRY(run_y(op->ctx, s->inv_y, s->inv_ye, s->tmp, img, ts, stride, n, m, (cl_uint)F));
    }
    return CSI_OK;
}

static void wavelet_destroy(csi_linop *op)
{
    wavelet_state *s = state_of(op);
    if (s) {
        csi_buffer_release(&s->tmp);
        free(s);
    }
    op->state = NULL;
}

/* Whether the fused levels fit the device's local memory (s->local): the finest level's band, the
 * widest, of at least BAND_MIN rows. Narrower bands would compute most x rows twice or more. */
#define BAND_MIN 4
static bool fused_fit(const wavelet_state *s)
{
    return band_rows(s->w, csi_wavelet_taps(s->family), s->local) >= BAND_MIN;
}

/* Rows of the scratch image: w + 16 floats (see csi_wavelet_create). */
static size_t scratch_stride(size_t w) { return w + 16; }

void csi_wavelet_buffers(size_t w, size_t h, csi_mem_tally *t)
{
    csi_mem_tally_add(t, scratch_stride(w) * h * sizeof(float), "the wavelet's scratch image");
}

csi_status csi_wavelet_create(csi_ctx *ctx, csi_wavelet_family f, size_t w, size_t h, int levels,
                              csi_linop **out)
{
    *out = NULL;
    const char *name = csi_wavelet_name(f);
    if (csi_wavelet_taps(f) == 0)
        return csi_fail(CSI_ERR_ARG, "unknown wavelet family %d: expected CSI_WAVELET_DB4 or "
                        "CSI_WAVELET_DB8", (int)f);
    if (w == 0 || h == 0)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu has a zero side", name, w, h);
    if (levels < 1)
        return csi_fail(CSI_ERR_ARG, "wavelet %s on %zux%zu: %d levels requested, need at least 1",
                        name, w, h, levels);
    const int twos = common_twos(w, h);
    if (levels > twos)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu is not divisible by 2^%d as %d "
                        "levels need (at most %d level%s possible for this size)", name, w, h,
                        levels, levels, twos, twos == 1 ? " is" : "s are");
    /* Kernels index with 32-bit ints. */
    if (w > INT_MAX / h)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu has more than %d pixels, over "
                        "the kernels' 32-bit indexing", name, w, h, INT_MAX);

    wavelet_state *s = calloc(1, sizeof *s);
    csi_linop *op = calloc(1, sizeof *op);
    if (!s || !op) {
        free(s);
        free(op);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory creating the %s wavelet", name);
    }
    s->family = f;
    s->w = w;
    s->h = h;
    s->levels = levels;
    op->rows = op->cols = w * h;
    op->complex_valued = false;
    op->name = f == CSI_WAVELET_DB4 ? "wavelet db4" : "wavelet db8";
    op->ctx = ctx;
    op->apply = wavelet_synthesis;
    op->adjoint = wavelet_analysis;
    op->destroy = wavelet_destroy;
    op->state = s;

    /* The y passes read the scratch image down columns, F + 2 rows per item. With rows a power
     * of two apart (4 KiB at w = 1024) those rows fall in one L1 cache set and evict each other;
     * 16 floats of padding per row measured 25-30% faster y passes at 1024x1024. */
    s->ts = scratch_stride(w);
    char what[96];
    snprintf(what, sizeof what, "the %s wavelet's scratch image (%zux%zu)", name, w, h);
    if (s->ts > INT_MAX / h) {
        csi_linop_free(op);
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu is too large for the kernels' "
                        "32-bit indexing", name, w, h);
    }
    csi_status st = csi_buffer(ctx, s->ts * h * sizeof(float), CL_MEM_READ_WRITE, what, &s->tmp);
    static const char *const stems[10] = {"fwd_x", "fwd_xw", "fwd_xe", "fwd_y", "fwd_ye",
                                          "inv_x", "inv_xw", "inv_xe", "inv_y", "inv_ye"};
    cl_kernel *slots[10] = {&s->fwd_x, &s->fwd_xw, &s->fwd_xe, &s->fwd_y, &s->fwd_ye,
                            &s->inv_x, &s->inv_xw, &s->inv_xe, &s->inv_y, &s->inv_ye};
    for (int i = 0; i < 10 && st == CSI_OK; i++) {
        char kname[64];
        snprintf(kname, sizeof kname, "csi_wavelet_%s_%s", stems[i], name);
        st = csi_kernel(ctx, "wavelet", kname, slots[i]);
    }
    if (st == CSI_OK &&
        clGetDeviceInfo(csi_ctx_device(ctx), CL_DEVICE_LOCAL_MEM_SIZE, sizeof s->local, &s->local, NULL) != CL_SUCCESS)
        s->local = 0;
    if (st == CSI_OK && fused_fit(s)) {
        char kname[64];
        snprintf(kname, sizeof kname, "csi_wavelet_fwd_xy_%s", name);
        st = csi_kernel(ctx, "wavelet", kname, &s->fwd_xy);
        snprintf(kname, sizeof kname, "csi_wavelet_inv_xy_%s", name);
        if (st == CSI_OK)
            st = csi_kernel(ctx, "wavelet", kname, &s->inv_xy);
    }
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}
