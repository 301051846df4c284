/* FFT-domain operators with clFFT: the Gaussian filter, its Wiener inverse, the Fourier basis.
 *
 * Filter (real, self-adjoint): y = C2R(gain .* R2C(x)). clFFT's real transforms work on the
 * Hermitian half spectrum (n0/2 + 1 values along x), half the work and memory of a complex
 * transform; the gain is real and even in every frequency index, so the result is real and
 * the operator symmetric: apply == adjoint. Fourier basis: one complex-to-complex plan with both
 * directions scaled by 1/sqrt(N) (clFFT would otherwise scale the backward transform by 1/N).
 *
 * Axes of length 1 are squeezed out before planning (clFFT's plans want every length > 1 and
 * the memory layout of the squeezed array is the same), so 16 x 1 x 8 is planned as 16 x 8. */
#include "csi/spectral.h"

#include "csi/gaussian.h"
#include "fft_filter.h"

#include <clFFT.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* M_PI is XSI, not C11. */
#define CSI_PI 3.14159265358979323846

static csi_status clfft_check(clfftStatus s, const char *call)
{
    if (s == CLFFT_SUCCESS)
        return CSI_OK;
    return csi_fail(CSI_ERR_CL, "%s failed with %s", call, csi_clfft_error_name((int)s));
}
#define CLFFT_TRY(call) CSI_TRY(clfft_check((call), #call))

/* n has only the factors 2, 3, 5, 7 (the radices clFFT 2.12 generates kernels for). */
static int radix_ok(size_t n)
{
    static const size_t p[] = {2, 3, 5, 7};
    if (n == 0)
        return 0;
    for (size_t i = 0; i < 4; i++)
        while (n % p[i] == 0)
            n /= p[i];
    return n == 1;
}

csi_status csi_fft_check_size(const char *what, const size_t dims[3])
{
    if (!dims)
        return csi_fail(CSI_ERR_ARG, "%s: no dimensions given", what);
    size_t total = 1;
    for (int a = 0; a < 3; a++) {
        if (dims[a] == 0)
            return csi_fail(CSI_ERR_ARG, "%s: size %zu x %zu x %zu has a zero axis", what, dims[0],
                            dims[1], dims[2]);
        if (!radix_ok(dims[a]))
            return csi_fail(CSI_ERR_ARG,
                            "%s: size %zu x %zu x %zu: axis %d has length %zu, which has a prime "
                            "factor other than 2, 3, 5, 7 (clFFT cannot transform it); pad or "
                            "choose a size like %s",
                            what, dims[0], dims[1], dims[2], a, dims[a], "2^a 3^b 5^c 7^d");
        if (total > ((size_t)1 << 40) / dims[a])
            return csi_fail(CSI_ERR_ARG, "%s: size %zu x %zu x %zu is too large", what, dims[0],
                            dims[1], dims[2]);
        total *= dims[a];
    }
    if (total < 2)
        return csi_fail(CSI_ERR_ARG, "%s: size %zu x %zu x %zu has fewer than 2 samples", what,
                        dims[0], dims[1], dims[2]);
    return CSI_OK;
}

/* Squeeze axes of length 1: c[0..nd) are the remaining lengths (x fastest), map[i] the
 * original axis of c[i]; unused entries of c are 1. */
static int squeeze(const size_t dims[3], size_t c[3], int map[3])
{
    int nd = 0;
    for (int a = 0; a < 3; a++)
        if (dims[a] > 1) {
            c[nd] = dims[a];
            map[nd] = a;
            nd++;
        }
    for (int a = nd; a < 3; a++) {
        c[a] = 1;
        map[a] = -1;
    }
    return nd;
}

static const clfftDim clfft_dims[4] = {CLFFT_1D, CLFFT_1D, CLFFT_2D, CLFFT_3D};

/* One baked single-precision out-of-place plan. */
static csi_status make_plan(csi_ctx *ctx, int nd, const size_t c[3], clfftLayout lin,
                            clfftLayout lout, const size_t istr[3], size_t idist,
                            const size_t ostr[3], size_t odist, float fscale, float bscale,
                            clfftPlanHandle *plan, cl_mem *tmp, const char *what)
{
    CSI_TRY(csi_clfft_ready(ctx));
    size_t len[3] = {c[0], c[1], c[2]};
    size_t is[3] = {istr[0], istr[1], istr[2]}, os[3] = {ostr[0], ostr[1], ostr[2]};
    cl_context clctx = csi_ctx_context(ctx);
    cl_command_queue q = csi_ctx_queue(ctx);
    CLFFT_TRY(clfftCreateDefaultPlan(plan, clctx, clfft_dims[nd], len));
    csi_status st = CSI_OK;
#define PLAN_STEP(call)                                     \
    do {                                                    \
        if (st == CSI_OK)                                   \
            st = clfft_check((call), #call);                \
    } while (0)
    PLAN_STEP(clfftSetPlanPrecision(*plan, CLFFT_SINGLE));
    PLAN_STEP(clfftSetLayout(*plan, lin, lout));
    PLAN_STEP(clfftSetResultLocation(*plan, CLFFT_OUTOFPLACE));
    PLAN_STEP(clfftSetPlanInStride(*plan, clfft_dims[nd], is));
    PLAN_STEP(clfftSetPlanOutStride(*plan, clfft_dims[nd], os));
    PLAN_STEP(clfftSetPlanDistance(*plan, idist, odist));
    PLAN_STEP(clfftSetPlanBatchSize(*plan, 1));
    /* Explicit scales: clFFT's default backward scale is 1/N. */
    PLAN_STEP(clfftSetPlanScale(*plan, CLFFT_FORWARD, fscale));
    PLAN_STEP(clfftSetPlanScale(*plan, CLFFT_BACKWARD, bscale));
    PLAN_STEP(clfftBakePlan(*plan, 1, &q, NULL, NULL));
    size_t tmpbytes = 0;
    PLAN_STEP(clfftGetTmpBufSize(*plan, &tmpbytes));
#undef PLAN_STEP
    if (st == CSI_OK && tmpbytes > 0)
        st = csi_buffer(ctx, tmpbytes, CL_MEM_READ_WRITE, what, tmp);
    if (st != CSI_OK) {
        clfftDestroyPlan(plan);
        *plan = 0;
        return csi_fail_context(st, "%s: ", what);
    }
    return CSI_OK;
}

static csi_status run_plan(csi_ctx *ctx, clfftPlanHandle plan, clfftDirection dir, cl_mem in,
                           cl_mem out, cl_mem tmp)
{
    cl_command_queue q = csi_ctx_queue(ctx);
    return clfft_check(clfftEnqueueTransform(plan, dir, 1, &q, 0, NULL, NULL, &in, &out, tmp),
                       "clfftEnqueueTransform");
}

/* ------------------------------------------------------------------------------------------ */
/* Gaussian filter and Wiener inverse                                                          */

typedef struct {
    size_t c[3], h0;           /* squeezed lengths; h0 = c[0]/2 + 1 (half-spectrum x length) */
    clfftPlanHandle fwd, bwd;  /* R2C, C2R */
    cl_mem tmp_f, tmp_b;       /* clFFT's intermediate buffers (NULL when none needed) */
    cl_mem spec;               /* h0 * c1 * c2 complex values */
    cl_mem g[3];               /* per-axis Gaussian gains over the half spectrum's index ranges */
    cl_uint wiener;
    float lambda;
    csi_fft_filter *native;    /* csi's own FFT kernels (kernels/fft.cl); NULL = clFFT path */
} filter_state;

/* With a complex factor (csi_filter_create_factor) the operator is no longer symmetric: its
 * adjoint conjugates the factor. */
static csi_status filter_adjoint_factor(const csi_linop *op, cl_mem y, cl_mem x)
{
    filter_state *s = op->state;
    if (x == y)
        return csi_fail(CSI_ERR_ARG, "%s: input and output must be different buffers", op->name);
    return csi_fft_filter_run_dir(s->native, y, x, true);
}

static csi_status filter_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    filter_state *s = op->state;
    csi_ctx *ctx = op->ctx;
    if (x == y)
        return csi_fail(CSI_ERR_ARG, "%s: input and output must be different buffers", op->name);
    if (s->native)
        return csi_fft_filter_run(s->native, x, y);
    CSI_TRY(run_plan(ctx, s->fwd, CLFFT_FORWARD, x, s->spec, s->tmp_f));
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "spectral", "csi_spectral_gain", &k));
    cl_uint h0 = (cl_uint)s->h0, n1 = (cl_uint)s->c[1], n2 = (cl_uint)s->c[2];
    CSI_TRY(CSI_ARGS(k, CSI_MEM(s->spec), CSI_MEM(s->g[0]), CSI_MEM(s->g[1]), CSI_MEM(s->g[2]),
                     CSI_ARG(h0), CSI_ARG(n1), CSI_ARG(n2), CSI_ARG(s->wiener),
                     CSI_ARG(s->lambda)));
    size_t global[3] = {s->h0, s->c[1], s->c[2]}, local[3] = {64, 1, 1};
    if (s->h0 < 64)
        local[0] = s->h0 <= 8 ? 8 : (s->h0 <= 16 ? 16 : 32);
    CSI_TRY(csi_run(ctx, k, 3, global, local));
    /* The C2R input (our spectrum scratch) may be overwritten by clFFT; x is untouched. */
    return run_plan(ctx, s->bwd, CLFFT_BACKWARD, s->spec, y, s->tmp_b);
}

static void filter_destroy(csi_linop *op)
{
    filter_state *s = op->state;
    if (!s)
        return;
    csi_fft_filter_free(s->native);
    if (s->fwd)
        clfftDestroyPlan(&s->fwd);
    if (s->bwd)
        clfftDestroyPlan(&s->bwd);
    csi_buffer_release(&s->tmp_f);
    csi_buffer_release(&s->tmp_b);
    csi_buffer_release(&s->spec);
    for (int a = 0; a < 3; a++)
        csi_buffer_release(&s->g[a]);
    free(s);
    op->state = NULL;
}

static csi_status filter_build(csi_ctx *ctx, csi_linop *op, filter_state *s, const size_t dims[3],
                               const double sigma_phi[3], csi_fft_backend backend, const char *what)
{
    int map[3];
    int nd = squeeze(dims, s->c, map);
    if (backend != CSI_FFT_CLFFT) {
        if (csi_fft_filter_supported(s->c, nd)) {
            double sig[3] = {0, 0, 0};
            for (int a = 0; a < nd; a++)
                sig[a] = sigma_phi[map[a]];
            return csi_fft_filter_create(ctx, s->c, nd, sig, s->wiener, s->lambda, &s->native);
        }
        if (backend == CSI_FFT_NATIVE)
            return csi_fail(CSI_ERR_ARG,
                            "%s: size %zu x %zu x %zu: csi's FFT needs an even length along the "
                            "first axis longer than 1 (clFFT can do this size)",
                            what, dims[0], dims[1], dims[2]);
    }
    s->h0 = s->c[0] / 2 + 1;
    size_t nspec = s->h0 * s->c[1] * s->c[2], n = s->c[0] * s->c[1] * s->c[2];
    CSI_TRY(csi_buffer(ctx, nspec * 8, CL_MEM_READ_WRITE, "the filter's half spectrum", &s->spec));

    /* Per-axis gain tables in double, stored as float (relative rounding 6e-8). */
    size_t glen[3] = {s->h0, s->c[1], s->c[2]};
    for (int a = 0; a < 3; a++) {
        float *g = malloc(glen[a] * sizeof *g);
        if (!g)
            return csi_fail(CSI_ERR_NOMEM, "%s: out of host memory", what);
        double sp = map[a] >= 0 ? sigma_phi[map[a]] : 0.0;
        for (size_t k = 0; k < glen[a]; k++)
            g[k] = (float)csi_gauss_gain_1d(s->c[a], k, sp);
        csi_status st = csi_buffer(ctx, glen[a] * sizeof *g, CL_MEM_READ_ONLY, "filter gains", &s->g[a]);
        if (st == CSI_OK)
            st = csi_write(ctx, s->g[a], 0, glen[a] * sizeof *g, g);
        free(g);
        CSI_TRY(st);
    }

    size_t rstr[3] = {1, s->c[0], s->c[0] * s->c[1]};
    size_t hstr[3] = {1, s->h0, s->h0 * s->c[1]};
    /* Forward unscaled; backward by 1/N so C2R(R2C(x)) = x. */
    CSI_TRY(make_plan(ctx, nd, s->c, CLFFT_REAL, CLFFT_HERMITIAN_INTERLEAVED, rstr, n, hstr, nspec,
                      1.0f, 1.0f / (float)n, &s->fwd, &s->tmp_f, what));
    CSI_TRY(make_plan(ctx, nd, s->c, CLFFT_HERMITIAN_INTERLEAVED, CLFFT_REAL, hstr, nspec, rstr, n,
                      1.0f, 1.0f / (float)n, &s->bwd, &s->tmp_b, what));
    /* Build the gain kernel now so the first apply does not pay for it. */
    cl_kernel k;
    CSI_TRY(csi_kernel(ctx, "spectral", "csi_spectral_gain", &k));
    (void)op;
    return CSI_OK;
}

csi_status csi_filter_create(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                             csi_filter_kind kind, float lambda, csi_linop **out)
{
    return csi_filter_create_backend(ctx, dims, sigma_phi, kind, lambda, CSI_FFT_AUTO, out);
}

csi_status csi_filter_create_backend(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                                     csi_filter_kind kind, float lambda, csi_fft_backend backend,
                                     csi_linop **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_filter_create: no output pointer");
    *out = NULL;
    if (!ctx || !sigma_phi)
        return csi_fail(CSI_ERR_ARG, "csi_filter_create: missing context or sigma_phi");
    const char *what = kind == CSI_FILTER_WIENER ? "Wiener inverse filter" : "Gaussian filter";
    if (kind != CSI_FILTER_GAUSS && kind != CSI_FILTER_WIENER)
        return csi_fail(CSI_ERR_ARG, "csi_filter_create: unknown filter kind %d", (int)kind);
    CSI_TRY(csi_fft_check_size(what, dims));
    for (int a = 0; a < 3; a++)
        if (!isfinite(sigma_phi[a]) || sigma_phi[a] < 0.0)
            return csi_fail(CSI_ERR_ARG, "%s: sigma_phi[%d] = %g must be finite and >= 0", what, a,
                            sigma_phi[a]);
    if (kind == CSI_FILTER_WIENER && !(isfinite(lambda) && lambda > 0.0f))
        return csi_fail(CSI_ERR_ARG,
                        "%s: lambda = %g must be finite and > 0 (lambda = 0 divides by the "
                        "Gaussian's underflowed tails)",
                        what, (double)lambda);

    csi_linop *op = calloc(1, sizeof *op);
    filter_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of host memory", what);
    }
    s->wiener = kind == CSI_FILTER_WIENER;
    s->lambda = s->wiener ? lambda : 0.0f;
    op->rows = op->cols = dims[0] * dims[1] * dims[2];
    op->complex_valued = false;
    op->name = kind == CSI_FILTER_WIENER ? "wiener-inverse" : "gauss-filter";
    op->ctx = ctx;
    op->apply = filter_apply;
    op->adjoint = filter_apply; /* real symmetric: G is real and even in each frequency index */
    op->destroy = filter_destroy;
    op->state = s;
    if (backend != CSI_FFT_AUTO && backend != CSI_FFT_CLFFT && backend != CSI_FFT_NATIVE) {
        csi_linop_free(op);
        return csi_fail(CSI_ERR_ARG, "%s: unknown FFT backend %d", what, (int)backend);
    }
    csi_status st = filter_build(ctx, op, s, dims, sigma_phi, backend, what);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}

csi_status csi_filter_create_factor(csi_ctx *ctx, const size_t dims[3], const double sigma_phi[3],
                                    csi_filter_kind kind, float lambda, const double *fx,
                                    const double *fy, csi_linop **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_filter_create_factor: no output pointer");
    *out = NULL;
    if (!fx || !fy || !dims)
        return csi_fail(CSI_ERR_ARG, "csi_filter_create_factor: missing factor or dimensions");
    size_t c[3];
    int map[3];
    if (squeeze(dims, c, map) != 2 || map[0] != 0 || map[1] != 1)
        return csi_fail(CSI_ERR_ARG, "filter with a complex factor: size %zu x %zu x %zu is not "
                        "2-D (two axes longer than 1, the third 1)", dims[0], dims[1], dims[2]);
    csi_linop *op;
    CSI_TRY(csi_filter_create_backend(ctx, dims, sigma_phi, kind, lambda, CSI_FFT_NATIVE, &op));
    filter_state *s = op->state;
    csi_status st = csi_fft_filter_set_factor(s->native, fx, fy);
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    op->name = kind == CSI_FILTER_WIENER ? "wiener-inverse-factor" : "gauss-filter-factor";
    op->adjoint = filter_adjoint_factor;
    *out = op;
    return CSI_OK;
}

/* What an operator on clFFT's path holds on the device beyond its own buffers, known only once
 * its plans are baked and first run: each plan's intermediate buffer (clfftGetTmpBufSize,
 * allocated here through csi_buffer), at most one complex copy of the transform; and the
 * buffers clFFT allocates itself on the first transform. Measured on PoCL for first axes from 3
 * to 59049 in 1-D to 3-D (tests/unit/test_recon_plan.c checks the bound against every
 * allocation in the process): intermediate buffers of the half spectrum's size (real plans) or
 * the transform's (complex ones); clFFT's own, up to 3.0 x 8 bytes per point and up to nine
 * 128-byte buffers. Counted: 8 bytes per point per plan, and 4 x 8 bytes per point + 4 KiB. */
static void clfft_buffers(const size_t c[3], int plans, csi_mem_tally *t)
{
    const uint64_t n = (uint64_t)c[0] * c[1] * c[2];
    for (int i = 0; i < plans; i++)
        csi_mem_tally_add(t, n * 8, "clFFT's intermediate buffer");
    csi_mem_tally_add(t, 4 * n * 8 + 4096, "clFFT's own buffers");
}

void csi_filter_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    if (csi_fft_filter_supported(c, nd)) {
        csi_fft_filter_buffers(c, nd, t);
        return;
    }
    const size_t h0 = c[0] / 2 + 1;
    csi_mem_tally_add(t, h0 * c[1] * c[2] * 8, "the filter's half spectrum");
    csi_mem_tally_add(t, h0 * 4, "filter gains");
    csi_mem_tally_add(t, c[1] * 4, "filter gains");
    csi_mem_tally_add(t, c[2] * 4, "filter gains");
    clfft_buffers(c, 2, t); /* forward and backward plans */
}

bool csi_filter_rows_fused(const size_t dims[3], uint64_t local_mem)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    return csi_fft_filter_supported(c, nd) && csi_fft_filter_rows_fused(c[0], local_mem);
}

void csi_filter_factor_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    csi_fft_filter_buffers(c, nd, t);
    csi_fft_filter_factor_buffers(c, t);
}

/* ------------------------------------------------------------------------------------------ */
/* Orthonormal Fourier basis                                                                   */

typedef struct {
    clfftPlanHandle plan;
    cl_mem tmp;
    csi_fft_c2c *native; /* csi's own kernels; NULL = clFFT */
} fourier_state;

static csi_status fourier_apply(const csi_linop *op, cl_mem x, cl_mem y)
{
    fourier_state *s = op->state;
    if (x == y)
        return csi_fail(CSI_ERR_ARG, "%s: input and output must be different buffers", op->name);
    if (s->native)
        return csi_fft_c2c_run(s->native, x, y, +1);
    /* F^H: clFFT's backward transform is exp(+2 pi i ...), scaled here by 1/sqrt(N). */
    return run_plan(op->ctx, s->plan, CLFFT_BACKWARD, x, y, s->tmp);
}

static csi_status fourier_adjoint(const csi_linop *op, cl_mem y, cl_mem x)
{
    fourier_state *s = op->state;
    if (x == y)
        return csi_fail(CSI_ERR_ARG, "%s: input and output must be different buffers", op->name);
    if (s->native)
        return csi_fft_c2c_run(s->native, y, x, -1);
    return run_plan(op->ctx, s->plan, CLFFT_FORWARD, y, x, s->tmp);
}

static void fourier_destroy(csi_linop *op)
{
    fourier_state *s = op->state;
    if (!s)
        return;
    csi_fft_c2c_free(s->native);
    if (s->plan)
        clfftDestroyPlan(&s->plan);
    csi_buffer_release(&s->tmp);
    free(s);
    op->state = NULL;
}

csi_status csi_fourier_create(csi_ctx *ctx, const size_t dims[3], csi_linop **out)
{
    return csi_fourier_create_backend(ctx, dims, CSI_FFT_AUTO, out);
}

csi_status csi_fourier_create_backend(csi_ctx *ctx, const size_t dims[3], csi_fft_backend backend,
                                      csi_linop **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_fourier_create: no output pointer");
    *out = NULL;
    if (!ctx)
        return csi_fail(CSI_ERR_ARG, "csi_fourier_create: no context");
    const char *what = "Fourier basis";
    if (backend != CSI_FFT_AUTO && backend != CSI_FFT_CLFFT && backend != CSI_FFT_NATIVE)
        return csi_fail(CSI_ERR_ARG, "%s: unknown FFT backend %d", what, (int)backend);
    CSI_TRY(csi_fft_check_size(what, dims));
    csi_linop *op = calloc(1, sizeof *op);
    fourier_state *s = calloc(1, sizeof *s);
    if (!op || !s) {
        free(op);
        free(s);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of host memory", what);
    }
    op->rows = op->cols = dims[0] * dims[1] * dims[2];
    op->complex_valued = true;
    op->name = "fourier-basis";
    op->ctx = ctx;
    op->apply = fourier_apply;
    op->adjoint = fourier_adjoint;
    op->destroy = fourier_destroy;
    op->state = s;
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    size_t n = c[0] * c[1] * c[2];
    float scale = (float)(1.0 / sqrt((double)n));
    csi_status st;
    if (backend != CSI_FFT_CLFFT && csi_fft_c2c_supported(c, nd)) {
        st = csi_fft_c2c_create(ctx, c, nd, scale, &s->native);
    } else if (backend == CSI_FFT_NATIVE) {
        st = csi_fail(CSI_ERR_ARG, "%s: size %zu x %zu x %zu is too large for csi's FFT kernels",
                      what, dims[0], dims[1], dims[2]);
    } else {
        size_t str[3] = {1, c[0], c[0] * c[1]};
        st = make_plan(ctx, nd, c, CLFFT_COMPLEX_INTERLEAVED, CLFFT_COMPLEX_INTERLEAVED, str, n, str,
                       n, scale, scale, &s->plan, &s->tmp, what);
    }
    if (st != CSI_OK) {
        csi_linop_free(op);
        return st;
    }
    *out = op;
    return CSI_OK;
}

void csi_fourier_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    if (csi_fft_c2c_supported(c, nd))
        csi_fft_c2c_buffers(c, nd, t);
    else
        clfft_buffers(c, 1, t);
}

/* ------------------------------------------------------------------------------------------ */
/* Real Fourier basis on the half spectrum                                                     */

csi_status csi_fourier_half_create(csi_ctx *ctx, const size_t dims[3], csi_fourier_half **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_fourier_half_create: no output pointer");
    *out = NULL;
    if (!ctx)
        return csi_fail(CSI_ERR_ARG, "csi_fourier_half_create: no context");
    CSI_TRY(csi_fft_check_size("real Fourier basis", dims));
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    if (!csi_fft_filter_supported(c, nd))
        return csi_fail(CSI_ERR_ARG, "real Fourier basis: size %zu x %zu x %zu: the first axis "
                        "longer than 1 must be even and >= 4", dims[0], dims[1], dims[2]);
    float scale = (float)(1.0 / sqrt((double)c[0] * (double)c[1] * (double)c[2]));
    return csi_fft_half_create(ctx, c, nd, scale, out);
}

bool csi_fourier_half_supported(const size_t dims[3])
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    /* csi_fft_check_size's conditions, without recording a message */
    for (int a = 0; a < 3; a++)
        if (!radix_ok(dims[a]))
            return false;
    return nd > 0 && csi_fft_filter_supported(c, nd);
}

size_t csi_fourier_half_count_for(const size_t dims[3])
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    return csi_fft_half_count_for(c, nd);
}

void csi_fourier_half_motion_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    if (nd >= 2 && dims[2] > 1)
        csi_fft_half_motion_buffers(c, nd, t);
}

void csi_fourier_half_buffers(const size_t dims[3], csi_mem_tally *t)
{
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    csi_fft_half_buffers(c, nd, t);
}

size_t csi_fourier_half_count(const csi_fourier_half *h) { return csi_fft_half_count(h); }
size_t csi_fourier_half_stride(const csi_fourier_half *h) { return csi_fft_half_stride(h); }

csi_status csi_fourier_half_forward(csi_fourier_half *h, cl_mem f, cl_mem z)
{
    return csi_fft_half_forward(h, f, z);
}

csi_status csi_fourier_half_forward_space(csi_fourier_half *h, cl_mem f, cl_mem zs)
{
    return csi_fft_half_forward_space(h, f, zs);
}

csi_status csi_fourier_half_forward_rest(csi_fourier_half *h, cl_mem zs, cl_mem z)
{
    return csi_fft_half_forward_rest(h, zs, z);
}

csi_status csi_fourier_half_inverse(csi_fourier_half *h, cl_mem z, cl_mem f)
{
    return csi_fft_half_inverse(h, z, f);
}

void csi_fourier_half_free(csi_fourier_half *h) { csi_fft_half_free(h); }

static const char *const time_names[] = {"dft", "dct", "none"};

const char *csi_time_transform_name(csi_time_transform t)
{
    return (unsigned)t < 3 ? time_names[t] : "?";
}

csi_status csi_time_transform_parse(const char *s, csi_time_transform *out)
{
    for (int i = 0; i < 3; i++)
        if (s && !strcmp(s, time_names[i])) {
            *out = (csi_time_transform)i;
            return CSI_OK;
        }
    return csi_fail(CSI_ERR_ARG, "unknown time transform '%s' (dft, dct, none)", s ? s : "");
}

_Static_assert((int)CSI_TIME_DFT == CSI_FFT_TIME_DFT && (int)CSI_TIME_DCT == CSI_FFT_TIME_DCT &&
                   (int)CSI_TIME_NONE == CSI_FFT_TIME_NONE,
               "the time transforms have the FFT's values");

csi_status csi_fourier_half_set_motion(csi_fourier_half *h, const size_t dims[3],
                                       csi_time_transform t, double vx, double vy)
{
    if (!h || !dims)
        return csi_fail(CSI_ERR_ARG, "csi_fourier_half_set_motion: no basis or dimensions");
    size_t c[3];
    int map[3];
    int nd = squeeze(dims, c, map);
    if (dims[2] < 2 || nd < 2)
        return csi_fail(CSI_ERR_ARG, "motion basis: size %zu x %zu x %zu has no time axis after "
                        "a spatial one", dims[0], dims[1], dims[2]);
    if (csi_fft_half_count(h) != csi_fft_half_stride(h) * (c[1] * c[2]))
        return csi_fail(CSI_ERR_ARG, "motion basis: size %zu x %zu x %zu is not the basis's",
                        dims[0], dims[1], dims[2]);
    double v[2] = {0.0, 0.0};
    for (int a = 0; a < nd - 1; a++)
        v[a] = map[a] == 0 ? vx : vy;
    return csi_fft_half_set_motion(h, (int)t, v);
}
