/* The resource plan of a reconstruction (csi/plan.h): the buffers each method of
 * csi_recon allocates, in the order it allocates them, from the modules' own `*_buffers`
 * functions, so that the model changes with the code it describes. */
#include "csi/plan.h"

#include <inttypes.h>
#include <limits.h>
#include <stdio.h>
#include <string.h>

#include "csi/host_memory.h"
#include "csi/integrate_ops.h"
#include "csi/interp.h"
#include "csi/model_grid.h"
#include "csi/motion_filter.h"
#include "csi/sampled_half_fourier.h"
#include "csi/sampling.h"
#include "csi/solve.h"
#include "csi/spectral.h"
#include "csi/tiles.h"
#include "csi/vec.h"
#include "csi/wavelet.h"
#include "internal.h"

void csi_mem_budget_of(const csi_ctx *ctx, csi_mem_budget *out)
{
    memset(out, 0, sizeof *out);
    out->device_global = csi_ctx_global_mem(ctx);
    out->device_buffer = csi_ctx_max_alloc(ctx);
    out->host = csi_host_available_bytes();
    cl_device_type type = 0;
    cl_bool unified = CL_FALSE;
    clGetDeviceInfo(csi_ctx_device(ctx), CL_DEVICE_TYPE, sizeof type, &type, NULL);
    clGetDeviceInfo(csi_ctx_device(ctx), CL_DEVICE_HOST_UNIFIED_MEMORY, sizeof unified, &unified, NULL);
    /* PoCL's CPU device keeps its buffers in this process's memory. */
    out->device_in_host = (type & CL_DEVICE_TYPE_CPU) || unified;
    out->device_name = csi_ctx_device_name(ctx);
}

/* A tally of what is held for the whole run, and the largest of the sets held only for a while
 * (or, like ROMP's buffers, allocated last, after another such set was freed). */
typedef struct {
    csi_mem_tally dev;        /* device buffers held to the end */
    uint64_t dev_transient;   /* the largest set of device buffers held for a while */
    uint64_t host;            /* host bytes held to the end */
    uint64_t host_transient;  /* the largest set of host bytes held for a while */
} model;

static void transient_dev(model *m, const csi_mem_tally *t)
{
    if (t->total > m->dev_transient)
        m->dev_transient = t->total;
    if (t->largest > m->dev.largest) {
        m->dev.largest = t->largest;
        m->dev.largest_what = t->largest_what;
    }
}

static void transient_host(model *m, uint64_t bytes)
{
    if (bytes > m->host_transient)
        m->host_transient = bytes;
}

/* csi_sampling_create's duplicate check: a bitmap over the grid, freed before it returns. */
static uint64_t sampling_bitmap(uint64_t k) { return (k + 7) / 8; }

/* The host tables an FFT-domain operator fills while it is made (twiddles, gains: at most
 * 16 bytes per element of the longest axis, doubled for the per-pass tables). */
static uint64_t fft_tables_host(const size_t dims[3])
{
    size_t L = dims[0] > dims[1] ? dims[0] : dims[1];
    L = L > dims[2] ? L : dims[2];
    return 32 * (uint64_t)L + 64;
}

/* What csi_wavelet_create refuses for Alg. 1's model grid (wavelet.c). */
static csi_status check_wavelet(const csi_aa_shape *sh, csi_wavelet_family f)
{
    const size_t w = sh->mw, h = sh->mh;
    if (sh->mlevels < 1 || w % ((size_t)1 << sh->mlevels) || h % ((size_t)1 << sh->mlevels))
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu is not divisible by 2^%d as %d levels need",
                        csi_wavelet_name(f), w, h, sh->mlevels, sh->mlevels);
    if ((w + 16) > INT_MAX / h)
        return csi_fail(CSI_ERR_ARG, "wavelet %s: image size %zux%zu is too large for the kernels' 32-bit "
                        "indexing", csi_wavelet_name(f), w, h);
    return CSI_OK;
}

static csi_status check_unknowns(uint64_t rows, uint64_t cols)
{
    if (cols > 0x7fffffffu || rows > 0x7fffffffu)
        return csi_fail(CSI_ERR_ARG, "solver: the problem (%" PRIu64 " x %" PRIu64 ") exceeds the 31-bit index "
                        "range", rows, cols);
    return CSI_OK;
}

/* Normalized convolution (normconv.c: csi_nc_init): S, the Gaussian (unless the caller's,
 * csi_nc_init_filter), density, filtered samples, the estimate at the samples. */
static void nc_buffers(const size_t dims[3], size_t n, bool own_filter, model *m)
{
    const uint64_t k = (uint64_t)dims[0] * dims[1] * dims[2];
    if (own_filter)
        csi_filter_buffers(dims, &m->dev);
    csi_sampling_buffers(n, &m->dev);
    csi_mem_tally_add(&m->dev, k * 4, "the filtered sample density");
    csi_mem_tally_add(&m->dev, k * 4, "the filtered samples");
    csi_mem_tally_add(&m->dev, n * 4, "the estimate at the samples");
    transient_host(m, sampling_bitmap(k) + fft_tables_host(dims));
}

/* csi_interp_create's host arrays while it sorts the samples by tile (interp.c), at most. */
static uint64_t interp_host(size_t mw, size_t mh, size_t n)
{
    return 16 * (uint64_t)n + 12 * ((uint64_t)mw + mh) + 16 * ((uint64_t)mw * mh / 512 + 1);
}

/* Alg. 1's operator of shape sh (csi_recon_aa_operator), its device buffers into t: on the fine
 * grid, or on the model grid D times coarser with the box means at the pixels; and the host
 * tables made with it. */
static void aa_operator_buffers(const csi_aa_shape *sh, const size_t dims[3], size_t n, size_t np, model *m,
                                csi_mem_tally *t)
{
    const size_t km = sh->mw * sh->mh;
    csi_wavelet_buffers(sh->mw, sh->mh, t);
    if (sh->D > 1)
        csi_model_filter_buffers(sh->mw, sh->mh, t);
    else
        csi_filter_buffers(dims, t);
    csi_linop_compose_buffers(km, false, t); /* Phi^-1 Psi */
    if (sh->D > 1)
        csi_interp_buffers(sh->mw, sh->mh, sh->D, n, t);
    else
        csi_sampling_buffers(n, t);
    csi_linop_compose_buffers(km, false, t); /* S Phi^-1 Psi */
    if (sh->D > 1) { /* the box means at the pixels */
        csi_model_filter_buffers(sh->mw, sh->mh, t);
        csi_interp_buffers(sh->mw, sh->mh, sh->D, np, t);
        transient_host(m, interp_host(sh->mw, sh->mh, n > np ? n : np) + (uint64_t)np * 4 +
                              fft_tables_host(dims));
    } else {
        transient_host(m, sampling_bitmap((uint64_t)dims[0] * dims[1]) + fft_tables_host(dims));
    }
}

/* Alg. 1 (antialias.c), on the fine grid or the model grid D times coarser. */
static csi_status plan_antialias(const csi_grid *g, size_t n, uint32_t channels, const csi_recon_options *opt,
                                 csi_solver_kind solver, const csi_tile_scope *scope, csi_recon_plan *p,
                                 model *m)
{
    const size_t w = g->w, h = g->h, np = (size_t)g->out_w * g->out_h;
    const size_t dims[3] = {w, h, 1};
    csi_recon_state whole;
    memset(&whole, 0, sizeof whole);
    whole.scope = scope; /* a tile's filter (and so its grid) follows the whole's sampling */
    csi_aa_shape sh;
    CSI_TRY(csi_recon_aa_shape(g, n, opt, &whole, &sh));
    CSI_TRY(check_wavelet(&sh, opt->wavelet));
    const size_t km = sh.mw * sh.mh;
    if (sh.D == 1)
        CSI_TRY(csi_fft_check_size("Wiener inverse filter", dims));
    CSI_TRY(check_unknowns(n, km));
    const bool romp = solver == CSI_SOLVER_ROMP;
    p->method = sh.D > 1 ? "Alg. 1 (model grid)" : "Alg. 1";
    p->unknowns = km;
    const size_t mdims[3] = {sh.mw, sh.mh, 1};
    p->rows_unfused = !csi_filter_rows_fused(sh.D > 1 ? mdims : dims, m->dev.local_mem);
    if (csi_recon_chroma_on(g, channels, opt)) {
        /* RGB as luma and chroma (chroma.c): luma's operator, then the chroma channels' on their
         * coarser grid in its place (on luma's solver workspace), and the three channels' fits at
         * the samples on the host */
        const csi_recon_options oc = csi_recon_chroma_options(opt);
        csi_aa_shape shc;
        CSI_TRY(csi_recon_aa_shape(g, n, &oc, &whole, &shc));
        CSI_TRY(check_wavelet(&shc, oc.wavelet));
        csi_mem_tally op[2] = {{.local_mem = m->dev.local_mem}, {.local_mem = m->dev.local_mem}};
        aa_operator_buffers(&sh, dims, n, np, m, &op[0]);
        aa_operator_buffers(&shc, dims, n, np, m, &op[1]);
        csi_vec_ws_buffers(&op[1]); /* the sharing workspace's own reductions, made with it */
        m->dev.total += op[0].total >= op[1].total ? op[0].total : op[1].total; /* one at a time */
        for (int i = 0; i < 2; i++)
            if (op[i].largest > m->dev.largest) {
                m->dev.largest = op[i].largest;
                m->dev.largest_what = op[i].largest_what;
            }
        m->host += 3 * (uint64_t)n * 4 + csi_solver_host_bytes(n, shc.mw * shc.mh, false, false);
    } else {
        aa_operator_buffers(&sh, dims, n, np, m, &m->dev);
    }
    csi_solver_buffers(n, km, false, &m->dev);
    csi_recon_coarse_buffers(&sh, opt, n, &m->dev);
    csi_mem_tally_add(&m->dev, n * 4, "the measurements");
    csi_mem_tally_add(&m->dev, (uint64_t)km * 4, "the wavelet coefficients");
    csi_mem_tally_add(&m->dev, np * 4, "the output image"); /* the fine and sharpened images: the solver's */
    m->host += csi_solver_host_bytes(n, km, false, romp);
    /* the per-pixel correction (cv_correct.c), per channel; the blend (blend.c) holds 80 bytes
     * per pixel more while it runs */
    transient_host(m, (uint64_t)n * 4 + (uint64_t)np * 12 +
                          (opt->correct == CSI_CORRECT_CV ? 0 : (uint64_t)np * 80));
    if (romp) {
        /* solver_setup.c: the column norms first (their probes freed before ROMP runs), then
         * ROMP's buffers, held to the end: the peak holds one or the other. */
        csi_mem_tally probes = {0}, rb = {0};
        if (opt->romp_normalize == CSI_SWITCH_ON) {
            csi_mem_tally_add(&m->dev, (uint64_t)km * 4, "the ROMP column norms");
            csi_column_norms_buffers(n, km, false, &probes);
            transient_host(m, (uint64_t)n * 4);
        }
        csi_solver_romp_tally(km, &rb);
        transient_dev(m, &probes);
        transient_dev(m, &rb);
        /* the seed support: at most the coarse block widened by its levels (k / 4 indices) */
        m->host += (uint64_t)km;
    }
    return CSI_OK;
}

/* Alg. 2 (motion.c). */
static csi_status plan_motion(const csi_grid *g, size_t n, const csi_recon_options *opt,
                              csi_solver_kind solver, const csi_tile_scope *scope, csi_recon_plan *p, model *m)
{
    const size_t w = g->w, h = g->h, T = g->t, k = w * h * T, wh = w * h;
    const size_t np = (size_t)g->out_w * g->out_h;
    const size_t dims[3] = {w, h, T};
    if (solver == CSI_SOLVER_ROMP)
        return csi_fail(CSI_ERR_ARG, "ROMP is real-valued and the 3-D Fourier problem is complex: "
                                     "use --solver sparsa for a volume (grid_t = %zu)", T);
    const bool half = !opt->motion_full_spectrum && csi_fourier_half_supported(dims);
    size_t ncoef;
    if (half) {
        ncoef = csi_fourier_half_count_for(dims);
        p->method = "Alg. 2 (half spectrum)";
        csi_half_fourier_sampling_buffers(dims, n, &m->dev);
        /* reserved before the velocity; the still plane's weight is a gain of the filter's
         * buffers, made wherever it is not 1 or auto (motion.c), and auto's look at the samples
         * holds 13 bytes per pixel (still_samples.c) or 20 per sample (moving_share.c: a
         * sorted copy and the lumas' median) */
        if (csi_recon_motion_filter_width(g, n, opt, scope) > 0 || opt->motion_still_weight != 1)
            csi_half_fourier_filter_buffers(dims, &m->dev);
        if (opt->motion_still_weight <= 0) {
            transient_host(m, (uint64_t)np * 13);
            transient_host(m, (uint64_t)n * 20);
        }
    } else {
        CSI_TRY(csi_fft_check_size("Fourier basis", dims));
        ncoef = k;
        p->method = "Alg. 2 (full spectrum)";
        csi_fourier_buffers(dims, &m->dev);
        csi_sampling_buffers(n, &m->dev);
        csi_linop_compose_buffers(k, true, &m->dev); /* S F3^H */
    }
    CSI_TRY(check_unknowns(n, ncoef));
    p->unknowns = ncoef;
    csi_solver_buffers(n, ncoef, true, &m->dev);
    csi_mem_tally_add(&m->dev, (uint64_t)n * 8, "the measurements");
    csi_mem_tally_add(&m->dev, (uint64_t)ncoef * 8, "the Fourier coefficients");
    if (!half)
        csi_mem_tally_add(&m->dev, (uint64_t)k * 8, "the reconstructed volume");
    csi_mem_tally_add(&m->dev, (uint64_t)k * 4, "the real volume");
    csi_mem_tally_add(&m->dev, (uint64_t)(np > wh ? np : wh) * 4, "the output image");
    csi_mem_tally_add(&m->dev, (uint64_t)wh * 4, "the time mean");
    csi_mem_tally_add(&m->dev, (uint64_t)n * 4, "the real measurements");
    m->host += csi_solver_host_bytes(n, ncoef, true, false);
    if (opt->motion_reweight > 0) { /* motion_reweight.c: a second solver on A G */
        csi_motion_reweight_buffers(n, ncoef, &m->dev);
        m->host += csi_motion_reweight_host_bytes(n, ncoef);
    }
    transient_host(m, sampling_bitmap(k) + fft_tables_host(dims));
    /* the motion basis's tables and its filter (velocity search, residual correction) */
    const bool moved = half && (g->w > 1 || g->h > 1) &&
                       (opt->motion_time != CSI_MOTION_TIME_DFT || opt->motion_velocity != CSI_VELOCITY_NONE);
    const bool correct = opt->motion_resid_sigma > 0;
    if (moved) {
        csi_fourier_half_motion_buffers(dims, &m->dev);
        if (correct || opt->motion_velocity == CSI_VELOCITY_ESTIMATE)
            csi_motion_filter_buffers(dims, &m->dev);
        if (opt->motion_velocity == CSI_VELOCITY_ESTIMATE) {
            transient_host(m, csi_motion_velocity_host_bytes(g, n));
            /* its spectra are released before the solver's buffers are made: they raise the
             * peak only by what they exceed those by */
            csi_mem_tally vs = {0}, sol = {0};
            csi_motion_velocity_buffers(dims, &vs);
            csi_solver_buffers(n, ncoef, true, &sol);
            if (vs.total > sol.total) {
                csi_mem_tally ex = {0};
                csi_mem_tally_add(&ex, vs.total - sol.total, "the velocity search's spectra");
                transient_dev(m, &ex);
            }
        }
    }
    if (correct) {
        if (!moved)
            CSI_TRY(csi_fft_check_size("Gaussian filter", dims));
        nc_buffers(dims, n, !moved, m);
        m->host += (uint64_t)n * 4; /* the residuals on the host */
    }
    if (opt->correct == CSI_CORRECT_AUTO || opt->correct == CSI_CORRECT_BLEND) {
        /* blend.c: the samples' range per pixel (freed after each channel's projection), the
         * exact means of fully sampled pixels; along a motion (motion_range.c) per pixel of the
         * frame that moves with it, at most CSI_MOTION_RANGE_MAX_PIXELS times as many; with a
         * still basis (the velocity is not known yet: counted always) the grown windows' sums
         * (sample_range.c: CSI_SAMPLE_RANGE_PIXEL_BYTES per pixel, a pixel index per sample),
         * or each cell's where a still camera's samples say little moves (motion.c; not known
         * yet: the device buffer holds the cells' frame always, and the host counts their
         * ranges held over the channels) */
        const uint64_t rp = csi_recon_motion_range_cap(g, moved);
        csi_mem_tally r = {0};
        csi_mem_tally_add(&r, rp * 8, "the sample range");
        transient_dev(m, &r);
        transient_host(m, rp * 16 + (uint64_t)g->w * g->h * 8 + (uint64_t)np * CSI_SAMPLE_RANGE_PIXEL_BYTES +
                              (uint64_t)n * 8);
    }
    if (opt->correct == CSI_CORRECT_BLEND || opt->correct == CSI_CORRECT_CV) {
        csi_sampling_buffers(n, &m->dev); /* the volume gathered at the samples */
        transient_host(m, (uint64_t)n * 4 + (uint64_t)np * 92);
    } else if (opt->correct == CSI_CORRECT_AUTO) {
        /* motion_correct.c, with a still basis (the velocity is not known yet: counted always):
         * the volume at the samples, on the device and the host, 48 bytes per pixel (then 60
         * for motion_toward_mean.c's, the former freed), and the
         * range it projects onto (sample_range.c: 8 bytes per pixel, its sums, a pixel index per
         * sample) */
        csi_sampling_buffers(n, &m->dev);
        transient_host(m, (uint64_t)n * 12 + (uint64_t)np * (68 + CSI_SAMPLE_RANGE_PIXEL_BYTES));
    }
    return CSI_OK;
}

/* The Gaussian baseline (baselines.c). */
static csi_status plan_gauss(const csi_grid *g, size_t n, csi_recon_plan *p, model *m)
{
    const size_t k = (size_t)g->w * g->h * g->t, wh = (size_t)g->w * g->h;
    const size_t np = (size_t)g->out_w * g->out_h;
    const size_t dims[3] = {g->w, g->h, g->t};
    CSI_TRY(csi_fft_check_size("Gaussian filter", dims));
    p->method = "Gaussian baseline";
    csi_mem_tally_add(&m->dev, (uint64_t)n * 4, "the measurements");
    csi_mem_tally_add(&m->dev, (uint64_t)k * 4, "the scattered samples");
    csi_mem_tally_add(&m->dev, (uint64_t)k * 4, "the interpolated samples");
    csi_mem_tally_add(&m->dev, (uint64_t)(np > wh ? np : wh) * 4, "the output image");
    csi_mem_tally_add(&m->dev, (uint64_t)wh * 4, "a frame");
    nc_buffers(dims, n, true, m);
    if (g->t == 1) /* the per-pixel correction, when asked for */
        transient_host(m, (uint64_t)n * 4 + (uint64_t)np * 12);
    return CSI_OK;
}

/* The sample mean (baselines.c, csi_splat_mean). */
static void plan_mean(const csi_grid *g, uint32_t channels, size_t n, csi_recon_plan *p, model *m)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    p->method = "sample mean";
    csi_mem_tally_add(&m->dev, (uint64_t)np * channels * 4, "the output image");
    csi_mem_tally t = {0};
    csi_splat_mean_buffers(n, channels, np, &t);
    transient_dev(m, &t);
    transient_host(m, ((uint64_t)np + 1) * 8 + (uint64_t)n * (4 + 4 * (uint64_t)channels));
}

/* The plan of one problem solved whole (csi_recon_scoped), or of a tile's (scope non-NULL). */
csi_status csi_recon_plan_whole(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                                const csi_recon_options *given, const csi_tile_scope *scope,
                                csi_recon_plan *out)
{
    memset(out, 0, sizeof *out);
    CSI_TRY(csi_recon_check_sizes(g, channels, n));
    csi_recon_options resolved;
    /* the autos as csi_recon_scoped sets them */
    CSI_TRY(csi_recon_resolve_scoped(given, g, n, scope, &resolved));
    const csi_recon_options *opt = &resolved;
    const uint64_t k = (uint64_t)g->w * g->h * g->t;
    const csi_solver_kind solver = opt->solver;
    const uint64_t np = (uint64_t)g->out_w * g->out_h;
    model m;
    memset(&m, 0, sizeof m);
    m.dev.local_mem = ctx ? csi_ctx_local_mem(ctx) : 0;
    /* The result (reconstruct.c) */
    m.host += np * channels * 4;
    /* the frames, asked for or made for the image's average with them (image_frames) */
    if (g->t > 1 && (opt->frames || opt->image_frames == CSI_SWITCH_ON) && opt->estimator != CSI_EST_MEAN)
        m.host += np * channels * g->t * 4;
    csi_status st;
    if (opt->estimator == CSI_EST_MEAN) {
        plan_mean(g, channels, n, out, &m);
        st = CSI_OK;
    } else {
        m.host += (uint64_t)n * 8; /* sample indices and one channel's values */
        if (opt->estimator == CSI_EST_GAUSS)
            st = plan_gauss(g, n, out, &m);
        else if (g->t == 1)
            st = plan_antialias(g, n, channels, opt, solver, scope, out, &m);
        else
            st = plan_motion(g, n, opt, solver, scope, out, &m);
    }
    if (st != CSI_OK) {
        memset(out, 0, sizeof *out);
        return st;
    }
    out->cells = k;
    out->tiles = 1;
    out->device_bytes = m.dev.total + m.dev_transient;
    out->largest_buffer = m.dev.largest;
    out->largest_what = m.dev.largest_what;
    out->host_bytes = m.host + m.host_transient;
    return CSI_OK;
}

csi_status csi_recon_plan_make(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                               const csi_recon_options *opt_in, csi_recon_plan *out)
{
    memset(out, 0, sizeof *out);
    csi_recon_options opt = csi_recon_options_or_defaults(opt_in);
    /* what csi_recon solves and how (csi_tiling_layout, over internal.h's csi_recon_solved_grid;
     * a refusal of a padded grid's layout names the padding itself) */
    csi_grid solved;
    const csi_grid *given = g;
    if (csi_recon_solved_grid(ctx, g, channels, n, &opt, &solved))
        g = &solved;
    csi_tiling tl0;
    char layout_why[512] = "";
    const csi_status ts = csi_tiling_layout(ctx, given, channels, n, &opt, &tl0);
    if (ts != CSI_OK)
        snprintf(layout_why, sizeof layout_why, "%s", csi_last_error());
    const csi_status ws = csi_recon_plan_whole(ctx, g, channels, n, &opt, NULL, out);
    /* sides the transforms cannot take in the whole are no obstacle to tiles the planner laid
     * out (windows of lengths they take); any other refusal of the whole stands */
    csi_grid unused;
    const bool tiles_instead = ts == CSI_OK && tl0.count > 1 && csi_recon_pad_grid(g, &unused);
    if (ws != CSI_OK && !tiles_instead)
        return g != &solved ? ws : csi_recon_padded_fail(ws, given, g);
    if (ts != CSI_OK)
        return csi_fail(ts, "%s", layout_why);
    if (ws != CSI_OK)
        out->cells = (uint64_t)g->w * g->h * g->t;
    /* a scaled copy of the samples, made when a channel's magnitude is far from 1 (result.c) */
    const uint64_t scaled_copy = (uint64_t)n * channels * 4;
    out->host_bytes += scaled_copy;
    /* csi_recon's layout (csi/tiles.h): when it tiles, the device holds one tile's
     * problem at a time, and the host the whole result besides. */
    const csi_tiling tl = tl0;
    if (tl.count <= 1)
        return CSI_OK;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const csi_grid tg = {.w = tl.window[0] * bw, .h = tl.window[1] * bh, .t = tl.window[2],
                         .out_w = tl.window[0], .out_h = tl.window[1]};
    const uint64_t tk = (uint64_t)tg.w * tg.h * tg.t;
    /* A tile holds the samples inside its window: the layout's assumption (its share of evenly
     * spread samples, with headroom; csi_tiling.tile_samples). */
    const size_t tn = (size_t)(tl.tile_samples < tk ? tl.tile_samples : tk);
    csi_recon_options to = opt;
    to.levels = tl.levels > 0 ? tl.levels : opt.levels;
    to.frames = opt.frames || tl.n[2] > 1;
    to.tiles = 0;
    csi_recon_plan tp;
    csi_tile_scope scope;
    csi_tile_scope_init(g, channels, n, &scope);
    CSI_TRY(csi_recon_plan_whole(ctx, &tg, channels, tn, &to, &scope, &tp));
    /* the frames, asked for or made for the image's average with them (reconstruct.c's rule) */
    csi_recon_options ro;
    const bool frames = opt.frames || (tl.n[2] == 1 && csi_recon_resolve(&opt, g, n, &ro) == CSI_OK &&
                                       ro.image_frames == CSI_SWITCH_ON);
    const uint64_t whole_result = (uint64_t)g->out_w * g->out_h * channels * 4 *
                                  (g->t > 1 && frames && opt.estimator != CSI_EST_MEAN ? 1 + (uint64_t)g->t : 1);
    /* the blend's per-pixel sums (csi/tiles.h), and a tile's own while it is blended: a time
     * window's residual sums, or a still image's sample counts and sums when it may settle */
    const uint64_t np = (uint64_t)g->out_w * g->out_h, wnp = (uint64_t)tl.window[0] * tl.window[1];
    uint64_t sums = 0;
    if (tl.n[2] > 1) /* and the whole shutter's correction of a channel (tile_blend.c: each pixel's
                      * residual and value statistics, its range and the range's sums), and the
                      * frames' mean the image is averaged with (an upper bound: when it is on) */
        sums = (np + wnp) * channels * (CSI_RESID_SUMS * 8 + 4) +
               np * (sizeof(csi_px_resid) + sizeof(csi_px_values) + 8 + CSI_SAMPLE_RANGE_PIXEL_BYTES);
    else if (g->t == 1 && opt.estimator == CSI_EST_CS && opt.settle != CSI_SWITCH_OFF &&
             (opt.correct == CSI_CORRECT_BLEND ||
              (opt.correct == CSI_CORRECT_AUTO && !(opt.sample_flags & CSI_SAMPLES_EXACT)))) /* resolve.c */
        sums = (np + wnp) * (4 + 8 * (uint64_t)channels);
    out->tiles = tl.count;
    out->method = tp.method;
    out->unknowns = tp.unknowns;
    out->device_bytes = tp.device_bytes;
    out->largest_buffer = tp.largest_buffer;
    out->largest_what = tp.largest_what;
    out->rows_unfused = tp.rows_unfused;
    /* the whole result and the blend's sums, one tile's problem (its samples copied: 12 + 4 per
     * channel bytes each) and everything its reconstruction holds on the host */
    out->host_bytes = scaled_copy + whole_result + sums + (uint64_t)tn * (12 + 4 * (uint64_t)channels) + tp.host_bytes;
    return CSI_OK;
}

csi_status csi_recon_plan_check(const csi_recon_plan *p, const csi_mem_budget *b, uint64_t extra_host,
                                const char *subject)
{
    char need[32], lim[32], dev[300] = "";
    if (b->device_name)
        snprintf(dev, sizeof dev, " (%.280s)", b->device_name);
    const char *s = subject ? subject : "reconstruction";
    if (b->device_buffer && p->largest_buffer > b->device_buffer)
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: %s needs a %s device buffer (%s), more than the device's "
                        "single-buffer limit of %s%s", s, p->method, csi_bytes_text(p->largest_buffer, need, sizeof need),
                        p->largest_what ? p->largest_what : "?", csi_bytes_text(b->device_buffer, lim, sizeof lim), dev);
    if (b->device_global && p->device_bytes > b->device_global)
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: %s needs %s of device memory, more than the device's %s%s", s,
                        p->method, csi_bytes_text(p->device_bytes, need, sizeof need),
                        csi_bytes_text(b->device_global, lim, sizeof lim), dev);
    const uint64_t recon = p->host_bytes + (b->device_in_host ? p->device_bytes : 0);
    const uint64_t host = recon + extra_host;
    if (b->host && host > b->host) {
        /* Say which part is the reconstruction's: the caller's share (samples, a tracer's
         * geometry) can be most of it. */
        char part[160] = "", r[32], e[32];
        if (extra_host)
            snprintf(part, sizeof part, " (%s for the reconstruction%s, %s for the samples and inputs)",
                     csi_bytes_text(recon, r, sizeof r), b->device_in_host ? " with the device's buffers" : "",
                     csi_bytes_text(extra_host, e, sizeof e));
        else if (b->device_in_host)
            snprintf(part, sizeof part, " (the device's buffers included)");
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: %s needs %s of host memory%s, more than the %s available", s,
                        p->method, csi_bytes_text(host, need, sizeof need), part,
                        csi_bytes_text(b->host, lim, sizeof lim));
    }
    return CSI_OK;
}
