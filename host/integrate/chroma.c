/* Alg. 1 on RGB solved as luma and chroma: the samples' orthonormal opponent transform
 *     Y = (R + G + B) / sqrt 3,  C1 = (R - B) / sqrt 2,  C2 = (R - 2 G + B) / sqrt 6,
 * Y solved as a channel is, the two chroma channels on a coarser model grid (csi/model_grid.h),
 * the fits (the box integrals b and the estimate at the samples A x) turned back into R, G, B,
 * and the per-pixel correction run on those from the RGB samples, as for any image: its rules
 * for HDR steps assume non-negative radiance, which chroma is not. The transform is orthonormal,
 * so a squared error summed over the channels is the same in both spaces: a chroma channel's
 * model error costs the image what it costs that channel. Rendered images carry most of their
 * structure and energy in luma; their chroma is smaller and smoother, so the coarser grid's
 * bias on fine detail (thin bars, checkerboards) weighs by chroma's share only.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* The chroma channels' model grid: the smallest Gaussian width in model cells of
 * `--model-sigma-min 0.75`, the coarser grid measured for whole images (D = 4 instead of 2 at
 * 4 spp on the default 8x grid). */
#define CHROMA_SIGMA_MIN 0.75
/* The luma solve's stop: this times the image's tolerance (2e-3 for the default 3e-3). One luma
 * solve carries what three RGB solves did, and SpaRSA's objective stop sees the image's brightest
 * light in it: at the RGB solves' 3e-3 luma ended after 11 steps on a sun's glossy highlight at
 * 16 spp x 1 path where R took 19, and the image went from 0.94x to 1.03x the relMSE of the
 * samples' mean; at 2e-3 it takes 0.8x (docs/bench/cost.md, session 27). */
#define LUMA_TOL_SCALE (2.0 / 3.0)
/* The chroma solves' stop: this times the image's tolerance (6e-3 for the default 3e-3). The
 * chroma carries a small part of an image's energy, on a coarser grid, and its tau is luma's
 * (csi_recon_chroma_tau_scale): a looser stop leaves out little. Against the luma's stop it took
 * 0.88x the CPU of a 1920x1080 image at 4 spp, every image's MSE within 1.5% of before on 70
 * quality dumps and 300 Mitsuba cells (docs/bench/cost.md, session 28). */
#define CHROMA_TOL_SCALE 2.0

bool csi_recon_chroma_on(const csi_grid *g, uint32_t channels, const csi_recon_options *opt)
{
    return channels == 3 && g->t == 1 && opt->chroma == CSI_SWITCH_ON && opt->estimator == CSI_EST_CS &&
           opt->solver == CSI_SOLVER_SPARSA && opt->output == CSI_AA_SHARP && opt->model_grid != CSI_SWITCH_OFF;
}

void csi_recon_opponent(const float *rgb, size_t n, uint32_t k, float *plane)
{
    const double s3 = sqrt(3.0), s2 = sqrt(2.0), s6 = sqrt(6.0);
    for (size_t i = 0; i < n; i++) {
        const double r = rgb[3 * i], gr = rgb[3 * i + 1], b = rgb[3 * i + 2];
        plane[i] = (float)(k == 0 ? (r + gr + b) / s3 : k == 1 ? (r - b) / s2 : (r - 2.0 * gr + b) / s6);
    }
}

/* The inverse (the transpose) on three planes of m values each (Y, C1, C2 in, R, G, B out). */
static void to_rgb(float *p, size_t m)
{
    const double s3 = sqrt(3.0), s2 = sqrt(2.0), s6 = sqrt(6.0);
    for (size_t i = 0; i < m; i++) {
        const double y = p[i] / s3, c1 = p[m + i] / s2, c2 = p[2 * m + i] / s6;
        p[i] = (float)(y + c1 + c2);
        p[m + i] = (float)(y - 2.0 * c2);
        p[2 * m + i] = (float)(y - c1 + c2);
    }
}

csi_recon_options csi_recon_chroma_options(const csi_recon_options *opt)
{
    csi_recon_options o = *opt;
    o.model_sigma_min = fmin(opt->model_sigma_min, CHROMA_SIGMA_MIN);
    o.tol = opt->tol * CHROMA_TOL_SCALE;
    return o;
}

/* A second state for the chroma channels: its own operator, the samples' indices and host
 * plane borrowed from the luma state's (given back by chroma_state_free). */
static void chroma_state_free(csi_recon_state *sc, const csi_recon_state *st)
{
    if (sc->y == st->y)
        sc->y = NULL;
    if (sc->x == st->x)
        sc->x = NULL;
    if (sc->out == st->out)
        sc->out = NULL;
    sc->idx = NULL;
    sc->plane = NULL;
    csi_recon_state_free(sc);
}

/* Luma's operator released (its solver's workspace kept, which the chroma's shares): after
 * luma's solve nothing reads it. */
static void release_operator(csi_recon_state *st)
{
    csi_recon_coarse_free(st->coarse);
    st->coarse = NULL;
    csi_linop_free(st->A); /* owns S and inner, which own Psi and W */
    csi_linop_free(st->Wbox);
    csi_linop_free(st->Ipix);
    st->A = st->S = st->inner = st->Psi = st->W = st->Wbox = st->Ipix = NULL;
}

/* A chroma channel's tau scale (SpaRSA's tau is tau_rel times it) from luma's, ||A^H Y||_inf.
 * tau_rel is relative to a channel's own level, and chroma's level can be near zero (a grey
 * region, a grey image), where its own ||A^H C||_inf would put the threshold at the noise and
 * the solve would fit it (more steps, no gain). Luma's level over sqrt 3 is the level of each
 * RGB channel of a grey image of that luma (R = G = B = Y / sqrt 3): the threshold the RGB solves
 * put on a channel of the image's mean level, in the same units since the transform is
 * orthonormal (noise equal and independent in R, G and B has the same variance in C1 and C2).
 * Luma's operator gives the scale for the chroma's coarser one too: both model the same
 * operator with the same coarsest wavelet block, where ||A^H Y||_inf of an image lies (its
 * mean). */
double csi_recon_chroma_tau_scale(double luma)
{
    return luma / sqrt(3.0);
}

static bool all_zero(const float *plane, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (plane[i] != 0)
            return false;
    return true;
}

csi_status csi_recon_antialias_chroma(csi_ctx *ctx, const csi_grid *g, const csi_sample_pos *pos,
                                      const float *values, size_t n, const csi_recon_options *opt,
                                      csi_recon_result *res, csi_recon_state *st)
{
    const size_t np = (size_t)g->out_w * g->out_h;
    const csi_recon_options oc = csi_recon_chroma_options(opt);
    csi_recon_options ol = *opt; /* luma's: its own grid, its own stop */
    ol.tol = opt->tol * LUMA_TOL_SCALE;
    /* the estimate at the samples of each channel, kept on the host: each solve overwrites the
     * workspace that holds it */
    float *at = malloc(3 * n * sizeof *at);
    csi_recon_state sc;
    memset(&sc, 0, sizeof sc);
    sc.scope = st->scope;
    sc.idx = st->idx;
    sc.plane = st->plane;
    csi_status s = at ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the fits at %zu samples", n);

    /* Luma's operator and workspace in st, as for any channel; after luma's solve, chroma's
     * operator in sc in its place, on the workspace's device buffers (the same rows, fewer
     * columns): the two operators are never held at once (plan.c counts the larger). */
    csi_aa_shape sh = {0}, shc = {0};
    if (s == CSI_OK)
        s = csi_recon_aa_operator(ctx, g, n, opt, st, &sh);
    const size_t km = sh.mw * sh.mh;
    if (s == CSI_OK) {
        res->model_factor = sh.D;
        res->unknowns = km;
        s = csi_solver_create(st->A, &st->solver);
    }
    if (s == CSI_OK)
        s = csi_recon_coarse_create(ctx, &sh, opt, st->idx, n, st->solver, &st->coarse);
    if (s == CSI_OK)
        s = csi_buffer(ctx, n * sizeof(float), CL_MEM_READ_WRITE, "the measurements", &st->y);
    if (s == CSI_OK)
        s = csi_buffer(ctx, km * sizeof(float), CL_MEM_READ_WRITE, "the wavelet coefficients", &st->x);
    if (s == CSI_OK)
        s = csi_buffer(ctx, np * sizeof(float), CL_MEM_READ_WRITE, "the output image", &st->out);
    sc.y = st->y;
    sc.x = st->x; /* the chroma grid's coefficients are at most luma's */
    sc.out = st->out;
    res->t_setup = csi_recon_now();
    res->cpu_setup = csi_recon_cpu_now();

    double t_solve = 0, t_int = 0;
    for (uint32_t k = 0; k < 3 && s == CSI_OK; k++) {
        csi_recon_state *cs = k ? &sc : st;
        const csi_recon_options *ok = k ? &oc : &ol;
        if (k == 1) {
            release_operator(st);
            s = csi_recon_aa_operator(ctx, g, n, &oc, &sc, &shc);
            if (s == CSI_OK)
                s = csi_solver_create_sharing(sc.A, st->solver, &sc.solver);
            if (s != CSI_OK)
                break;
            res->chroma_model_factor = shc.D;
        }
        cs->channel = k;
        cs->channels = 3;
        s = csi_recon_progress_channel(opt, "solve", k, 3);
        if (s != CSI_OK)
            break;
        /* luma's from its scope (a tile's) or its own solve (SpaRSA's tau is tau_rel times its
         * ||A^H Y||_inf) */
        const double tau_scale = st->scope && st->scope->has_scale ? st->scope->scale[k]
                                 : k > 0                            ? csi_recon_chroma_tau_scale(res->report[0].tau / opt->tau_rel)
                                                                    : 0;
        csi_recon_opponent(values, n, k, cs->plane);
        if (s == CSI_OK && all_zero(cs->plane, n)) {
            /* no signal in the channel (the chroma of a grey image): x = 0, nothing to solve */
            memset(res->image + (size_t)k * np, 0, np * sizeof(float));
            memset(at + (size_t)k * n, 0, n * sizeof(float));
            memset(&res->report[k], 0, sizeof res->report[k]);
            res->report[k].converged = true;
            res->report[k].reason = CSI_SOLVE_ZERO;
            strcpy(res->report[k].message, "no signal in the channel: x = 0");
            continue;
        }
        if (s == CSI_OK)
            s = csi_write(ctx, cs->y, 0, n * sizeof(float), cs->plane);
        cs->warm = false;
        if (s == CSI_OK)
            s = csi_fill_zero(ctx, cs->x, cs->A->cols * sizeof(float));
        const double t0 = csi_recon_now();
        if (s == CSI_OK)
            s = csi_recon_run_solver(cs, ok, tau_scale, &res->report[k]);
        if (s == CSI_OK)
            s = csi_finish(ctx);
        const double t1 = csi_recon_now();
        t_solve += t1 - t0;
        if (s == CSI_OK)
            s = csi_recon_progress_channel(opt, "integrate", k, 3);
        const csi_linop *S = NULL;
        cl_mem fit = NULL;
        if (s == CSI_OK)
            s = csi_recon_aa_integrate(ctx, g, ok, cs, k ? shc.D : sh.D, res->image + (size_t)k * np, &S, &fit);
        if (s == CSI_OK && S)
            s = csi_linop_apply(S, fit, cs->y);
        if (s == CSI_OK)
            s = csi_read(ctx, S ? cs->y : fit, 0, n * sizeof(float), at + (size_t)k * n);
        t_int += csi_recon_now() - t1;
    }
    chroma_state_free(&sc, st);

    /* Back to R, G, B, then each channel's correction from its own samples, as for any image. */
    const double t1 = csi_recon_now();
    if (s == CSI_OK) {
        to_rgb(res->image, np);
        to_rgb(at, n);
    }
    t_int += csi_recon_now() - t1;
    const csi_aa_correct how = csi_recon_aa_correction(opt);
    for (uint32_t c = 0; c < 3 && s == CSI_OK; c++) {
        const double t2 = csi_recon_now();
        if (how != CSI_CORRECT_NONE) {
            s = csi_write(ctx, st->y, 0, n * sizeof(float), at + (size_t)c * n);
            if (s == CSI_OK)
                s = csi_recon_correct(ctx, g, opt, how, NULL, st->y, st->y, values, 3, c, pos, n,
                                      how == CSI_CORRECT_BLEND && csi_recon_nonneg(values, 3, c, n),
                                      res->image + (size_t)c * np);
        }
        res->t_channel_integrate[c] = csi_recon_now() - t2;
        t_int += res->t_channel_integrate[c];
    }
    free(at);
    res->t_solve = t_solve;
    res->t_integrate = t_int;
    CSI_TRY(s);
    return csi_recon_check_finite(res->image, np * 3, "image");
}
