/* The resource plan (csi/plan.h) against what reconstructions really allocate.
 *
 * For small reconstructions of every method and its variants (Alg. 1 with SpaRSA, ROMP and
 * ROMP with column norms; Alg. 2 on the half spectrum, with the reweighted l1, on the full
 * spectrum and with an odd width that forces the full spectrum and clFFT's filter; frames; the
 * Gaussian baseline in 2-D and 3-D, with an odd width on clFFT's path; the sample mean) the peak
 * of device bytes live at once is measured twice, independently:
 *   - by csi_buffer's own counter (csi_device_bytes_peak), and
 *   - by clCreateBuffer / clReleaseMemObject defined in this executable, which every caller in
 *     the process reaches (csi's library and clFFT's shared library resolve the symbol here
 *     first): it also sees buffers that would bypass csi_buffer.
 * Asserted: the two agree, the plan is >= the peak, and the plan exceeds it by at most the
 * bound it counts for clFFT's intermediate buffers (0 on csi's own FFT kernels, where the plan
 * adds exactly the buffers each create function allocates). In tiles (csi/tiles.h) the plan is
 * one tile's with as many samples as its window holds cells, an upper bound of any tile's.
 * RGB solved as luma and chroma (the default for RGB still images) builds a second operator for
 * the chroma on a coarser grid once luma's is released: the plan counts the larger of the two
 * (checked against the peak as above), so the luma and chroma plan of a 1920x1080 image is the
 * R, G, B plan's device bytes, and its host bytes more (the fits at the samples).
 *
 * Limits: budgets and csi_ctx_limit_memory set by the test, so nothing depends on how much
 * memory the machine happens to have free: an oversized grid is refused in microseconds with no
 * device allocation, and a buffer over a lowered single-buffer limit is refused by csi_buffer. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/plan.h"
#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "csi/wavelet.h"
#include "cl_count.h"
#include "testlib.h"

/* ---- runs ------------------------------------------------------------------------------------ */

typedef struct {
    const char *name;
    csi_grid g;
    uint32_t channels;
    double fraction;      /* of the cells sampled */
    csi_recon_options opt;
    int clfft_ops;        /* operators on clFFT's path (0: csi's own FFT kernels only) */
    bool tiled;           /* solved in tiles: the plan bounds a tile holding all its window's cells */
} run_case;

static void one(const run_case *rc)
{
    csi_ctx *ctx = test_ctx();
    const uint64_t k = (uint64_t)rc->g.w * rc->g.h * rc->g.t;
    csi_pos_opts po = {.method = CSI_POS_RANDOM, .fraction = rc->fraction, .seed = 3};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(&rc->g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(0, "%s: positions: %s", rc->name, csi_last_error());
        return;
    }
    float *val = malloc(n * rc->channels * sizeof *val);
    for (size_t i = 0; i < n * rc->channels; i++)
        val[i] = (float)(0.5 + 0.4 * sin(0.37 * (double)i) * cos(0.011 * (double)(pos[i / rc->channels].x + 3 * pos[i / rc->channels].y)));
    csi_recon_plan plan;
    CHECK_OK(csi_recon_plan_make(ctx, &rc->g, rc->channels, n, &rc->opt, &plan));

    csi_finish(ctx);
    const uint64_t live0 = csi_device_bytes_live(), ic0 = test_cl_live();
    csi_device_bytes_reset_peak();
    test_cl_reset_peak();
    csi_recon_result res;
    csi_status st = csi_recon(ctx, &rc->g, rc->channels, pos, val, n, &rc->opt, &res);
    CHECK(st == CSI_OK, "%s: %s", rc->name, csi_last_error());
    const uint64_t peak = csi_device_bytes_peak() - live0, ipeak = test_cl_peak() - ic0;
    printf("%-34s k %7llu n %6zu  tiles %2u  plan %9llu  peak %9llu  (interposed %9llu)  host plan %8llu  %s\n",
           rc->name, (unsigned long long)k, n, plan.tiles, (unsigned long long)plan.device_bytes, (unsigned long long)peak,
           (unsigned long long)ipeak, (unsigned long long)plan.host_bytes, plan.method);
    /* clFFT allocates buffers of its own on the first transform (the plan counts 4 x 8 bytes per
     * point + 4 KiB for each operator on its path); everything else goes through csi_buffer. */
    const uint64_t own = (uint64_t)rc->clfft_ops * (4 * 8 * k + 4096);
    CHECK(ipeak >= peak && ipeak - peak <= own, "%s: %llu bytes allocated outside csi_buffer (%llu interposed vs "
          "%llu counted)", rc->name, (unsigned long long)(ipeak - peak), (unsigned long long)ipeak,
          (unsigned long long)peak);
    /* The bound: exact on csi's own kernels; on clFFT's path the plan counts what clFFT may hold
     * (host/ops/spectral.c: measured at most 3.0 x 8 bytes per point of its own, and intermediate
     * buffers of half the spectrum for real plans), so it may exceed the peak by the rest of that
     * allowance: at most 6 x 8 bytes per point + 4 KiB per operator. */
    const uint64_t slack = (uint64_t)rc->clfft_ops * (6 * 8 * k + 4096);
    CHECK(plan.device_bytes >= ipeak, "%s: plan %llu < peak %llu", rc->name, (unsigned long long)plan.device_bytes,
          (unsigned long long)ipeak);
    if (rc->tiled)
        CHECK(plan.tiles > 1 && res.tiles == plan.tiles, "%s: plan %u tiles, run %u", rc->name, plan.tiles, res.tiles);
    else
        CHECK(plan.device_bytes - ipeak <= slack, "%s: plan %llu exceeds the peak %llu by more than %llu", rc->name,
              (unsigned long long)plan.device_bytes, (unsigned long long)ipeak, (unsigned long long)slack);
    CHECK(csi_device_bytes_live() == live0 && test_cl_live() == ic0, "%s: %llu device bytes left after the run", rc->name,
          (unsigned long long)(csi_device_bytes_live() - live0));
    /* the host model holds at least the result the caller receives */
    CHECK(plan.host_bytes >= (uint64_t)rc->g.out_w * rc->g.out_h * rc->channels * 4 * (res.nframes ? 1 + res.nframes : 1),
          "%s: host plan %llu below the result's size", rc->name, (unsigned long long)plan.host_bytes);
    if (st == CSI_OK)
        csi_recon_result_free(&res);
    free(pos);
    free(val);
}

static csi_recon_options opts(void)
{
    csi_recon_options o;
    csi_recon_defaults(&o);
    o.max_iter = 5; /* the buffers do not depend on the iterations */
    return o;
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    run_case cases[32];
    int nc = 0;
    csi_recon_options o = opts();
    cases[nc++] = (run_case){"Alg. 1, SpaRSA, RGB", {64, 64, 1, 16, 16}, 3, 0.25, o, 0, false};
    /* 1 sample in 50 cells: a wide filter, the model grid 4x coarser (csi/model_grid.h) */
    cases[nc++] = (run_case){"Alg. 1, model grid", {128, 128, 1, 16, 16}, 1, 0.02, o, 0, false};
    o = opts();
    o.solver = CSI_SOLVER_ROMP;
    cases[nc++] = (run_case){"Alg. 1, ROMP", {64, 32, 1, 16, 8}, 1, 0.25, o, 0, false};
    o.romp_normalize = CSI_SWITCH_ON;
    cases[nc++] = (run_case){"Alg. 1, ROMP, column norms", {64, 32, 1, 16, 8}, 2, 0.25, o, 0, false};
    o = opts();
    o.estimator = CSI_EST_GAUSS;
    cases[nc++] = (run_case){"Gaussian 2-D", {48, 40, 1, 12, 10}, 3, 0.2, o, 0, false};
    o.correct = CSI_CORRECT_CV;
    cases[nc++] = (run_case){"Gaussian 2-D, corrected", {48, 40, 1, 12, 10}, 1, 0.2, o, 0, false};
    o.correct = CSI_CORRECT_AUTO;
    cases[nc++] = (run_case){"Gaussian 3-D", {32, 16, 8, 8, 4}, 1, 0.1, o, 0, false};
    /* odd widths: the Gaussian on clFFT */
    cases[nc++] = (run_case){"Gaussian 2-D, odd width (clFFT)", {15, 20, 1, 5, 5}, 1, 0.3, o, 1, false};
    cases[nc++] = (run_case){"Gaussian 3-D, odd width (clFFT)", {15, 12, 4, 5, 4}, 1, 0.3, o, 1, false};
    o = opts();
    o.estimator = CSI_EST_MEAN;
    cases[nc++] = (run_case){"sample mean", {64, 64, 1, 16, 16}, 4, 0.1, o, 0, false};
    cases[nc++] = (run_case){"sample mean, volume", {32, 32, 8, 8, 8}, 3, 0.1, o, 0, false};
    o = opts();
    cases[nc++] = (run_case){"Alg. 2, half spectrum", {32, 32, 8, 8, 8}, 1, 0.1, o, 0, false};
    o.frames = true;
    cases[nc++] = (run_case){"Alg. 2, half spectrum, frames, RGB", {32, 16, 8, 8, 4}, 3, 0.1, o, 0, false};
    o = opts();
    o.motion_full_spectrum = true;
    cases[nc++] = (run_case){"Alg. 2, full spectrum", {32, 32, 8, 8, 8}, 1, 0.1, o, 0, false};
    o = opts();
    o.motion_resid_sigma = -1;
    cases[nc++] = (run_case){"Alg. 2, no residual correction", {32, 32, 8, 8, 8}, 1, 0.1, o, 0, false};
    o = opts();
    o.motion_reweight = 2; /* a second solver on A G */
    cases[nc++] = (run_case){"Alg. 2, reweighted l1", {32, 32, 8, 8, 8}, 2, 0.1, o, 0, false};
    o = opts();
    /* an odd width has no half spectrum: the full one on csi's kernels, the residual
     * correction's Gaussian on clFFT */
    cases[nc++] = (run_case){"Alg. 2, odd width (full, clFFT)", {15, 16, 8, 5, 4}, 1, 0.2, o, 1, false};
    /* RGB as luma and chroma: 4 samples per pixel of 8 x 8 cells, luma on a model grid D = 2,
     * the chroma's on D = 4 (one problem, and in tiles) */
    o = opts();
    o.chroma = CSI_SWITCH_ON;
    cases[nc++] = (run_case){"Alg. 1, RGB as luma and chroma", {256, 256, 1, 32, 32}, 3, 1.0 / 16, o, 0, false};
    o.tiles = 4;
    o.tile_margin = 8;
    cases[nc++] = (run_case){"Alg. 1, luma and chroma, in tiles", {512, 256, 1, 64, 32}, 3, 1.0 / 16, o, 0, true};
    /* in tiles: four over the image, two time windows over a volume */
    o = opts();
    o.tiles = 4;
    o.tile_margin = 16;
    cases[nc++] = (run_case){"Alg. 1 in tiles", {256, 256, 1, 64, 64}, 1, 0.1, o, 0, true};
    o = opts();
    o.tiles = 2;
    cases[nc++] = (run_case){"Alg. 2 in tiles", {32, 32, 48, 32, 32}, 1, 0.1, o, 0, true};
    for (int i = 0; i < nc; i++)
        one(&cases[i]);

    /* ---- limits set here, never the machine's ------------------------------------------------ */
    csi_recon_plan p;
    /* 4096^2 RGB at 4 spp on a 4x grid (Alg. 1 keeps the fine grid at this density) */
    const csi_grid big = {16384, 16384, 1, 4096, 4096};
    const size_t big_n = (size_t)4096 * 4096 * 4;
    const uint64_t live0 = csi_device_bytes_live();
    csi_device_bytes_reset_peak();
    double t0 = now();
    /* a budget that lets the whole problem through (no tiles), so the device limits decide */
    csi_recon_options whole = opts();
    whole.mem_budget = 1ull << 40;
    CHECK_OK(csi_recon_plan_make(NULL, &big, 3, big_n, &whole, &p));
    csi_mem_budget b = {.device_global = 3ull << 30, .device_buffer = 1ull << 30, .host = 64ull << 30,
                        .device_in_host = true, .device_name = "test device"};
    csi_status st = csi_recon_plan_check(&p, &b, 0, "big.csid: grid 16384x16384x1");
    double dt = now() - t0;
    /* The plan is arithmetic on the sizes: well under a millisecond; 0.5 s leaves room for a loaded
     * machine and still fails if anything were allocated or computed per cell. */
    CHECK(st == CSI_ERR_TOO_LARGE && strstr(csi_last_error(), "big.csid") && strstr(csi_last_error(), "1.0 GiB") &&
              strstr(csi_last_error(), "single-buffer"),
          "oversized grid: %s", csi_last_error());
    CHECK(dt < 0.5 && csi_device_bytes_peak() == live0, "refused in %.3f s with %llu device bytes allocated", dt,
          (unsigned long long)(csi_device_bytes_peak() - live0));
    CHECK(p.tiles == 1 && p.device_bytes > 16384ull * 16384 * 4 * 8, "the whole: %u tiles, %llu bytes", p.tiles,
          (unsigned long long)p.device_bytes);
    /* The same grid with a large single-buffer limit: the total is what fails. */
    b.device_buffer = 4ull << 30;
    st = csi_recon_plan_check(&p, &b, 0, "big.csid");
    CHECK(st == CSI_ERR_TOO_LARGE && strstr(csi_last_error(), "device memory") && strstr(csi_last_error(), "3.0 GiB"),
          "total device memory: %s", csi_last_error());
    /* Host memory: on a CPU device the device's buffers count against it. */
    b.device_global = 0;
    b.host = p.device_bytes + p.host_bytes - 1;
    st = csi_recon_plan_check(&p, &b, 0, "big.csid");
    CHECK(st == CSI_ERR_TOO_LARGE && strstr(csi_last_error(), "host memory"), "host: %s", csi_last_error());
    b.device_in_host = false;
    CHECK_OK(csi_recon_plan_check(&p, &b, 0, "big.csid"));
    st = csi_recon_plan_check(&p, &b, p.device_bytes, "big.csid");
    CHECK(st == CSI_ERR_TOO_LARGE, "the caller's own host bytes count: %s", csi_last_error());
    /* With the default budget csi_recon tiles it: the plan is one tile's. */
    csi_recon_options tiled = opts();
    tiled.mem_budget = 256ull << 20;
    CHECK_OK(csi_recon_plan_make(NULL, &big, 3, big_n, &tiled, &p));
    CHECK(p.tiles > 1 && p.largest_buffer < (1ull << 30), "tiled: %u tiles, largest buffer %llu", p.tiles,
          (unsigned long long)p.largest_buffer);
    /* The chroma's operator in the place of luma's: 1920x1080 RGB at 4 spp on the default 8x
     * grid, one problem. */
    const csi_grid hd = {15360, 8640, 1, 1920, 1080};
    const size_t hd_n = (size_t)1920 * 1080 * 4;
    csi_recon_plan rgb, chroma;
    csi_recon_options co = whole;
    co.chroma = CSI_SWITCH_OFF;
    CHECK_OK(csi_recon_plan_make(NULL, &hd, 3, hd_n, &co, &rgb));
    co.chroma = CSI_SWITCH_ON;
    CHECK_OK(csi_recon_plan_make(NULL, &hd, 3, hd_n, &co, &chroma));
    printf("1920x1080 RGB, one problem: device plan %llu as R, G, B, %llu as luma and chroma\n",
           (unsigned long long)rgb.device_bytes, (unsigned long long)chroma.device_bytes);
    CHECK(rgb.tiles == 1 && chroma.tiles == 1 && chroma.device_bytes == rgb.device_bytes &&
              chroma.host_bytes > rgb.host_bytes,
          "the chroma's operator in luma's place: device %llu against %llu bytes, host %llu against %llu",
          (unsigned long long)chroma.device_bytes, (unsigned long long)rgb.device_bytes,
          (unsigned long long)chroma.host_bytes, (unsigned long long)rgb.host_bytes);
    /* Sizes csi_recon refuses are refused by the plan with its messages. */
    const csi_grid odd = {22, 16, 1, 2, 16}; /* 11 cells per pixel: no whole number of pixels pads it */
    CHECK(csi_recon_plan_make(NULL, &odd, 1, 10, NULL, &p) == CSI_ERR_ARG && strstr(csi_last_error(), "prime factor"),
          "FFT size: %s", csi_last_error());
    /* 11 frames are solved as 12 (the last holds no sample), and planned so */
    const csi_grid odd_t = {16, 16, 11, 16, 16};
    CHECK_OK(csi_recon_plan_make(NULL, &odd_t, 1, 10, NULL, &p));
    CHECK(p.cells == 16 * 16 * 12, "padded frames: %llu cells planned, expected 3072", (unsigned long long)p.cells);
    /* An image of such sides is planned as csi_recon solves it: padded right and down to the
     * nearest sides the transforms take (11 pixels of 2 cells: 12 pixels, 24 cells). */
    const csi_grid odd_image = {22, 22, 1, 11, 11};
    CHECK_OK(csi_recon_plan_make(NULL, &odd_image, 1, 10, NULL, &p));
    CHECK(p.cells == 24 * 24, "padded image: %llu cells planned, expected 576", (unsigned long long)p.cells);
    const csi_grid huge = {65536, 65536, 2, 1, 1};
    CHECK(csi_recon_plan_make(NULL, &huge, 1, 10, NULL, &p) == CSI_ERR_ARG && strstr(csi_last_error(), "over 2^32"),
          "cells: %s", csi_last_error());
    csi_recon_options ro = opts();
    ro.solver = CSI_SOLVER_ROMP;
    const csi_grid vol = {16, 16, 4, 4, 4};
    CHECK(csi_recon_plan_make(NULL, &vol, 1, 10, &ro, &p) == CSI_ERR_ARG && strstr(csi_last_error(), "ROMP"),
          "ROMP on a volume: %s", csi_last_error());

    /* csi_buffer enforces a single-buffer limit the test sets (the machine's may be 1 to 4 GiB,
     * depending on the memory free when PoCL starts): a 2 GiB wavelet scratch over 1 GiB. */
    REQUIRE_OK(csi_ctx_limit_memory(ctx, 1ull << 30, 0));
    CHECK(csi_ctx_max_alloc(ctx) <= (1ull << 30), "limit lowered: %zu", csi_ctx_max_alloc(ctx));
    csi_linop *op = NULL;
    st = csi_wavelet_create(ctx, CSI_WAVELET_DB4, 32768, 16384, 1, &op);
    CHECK(st == CSI_ERR_DEVICE && op == NULL && strstr(csi_last_error(), "single-buffer limit"),
          "over the buffer limit: %s", csi_last_error());
    /* and a global limit: 64 KiB in all refuses a 100 KiB buffer before OpenCL sees it */
    REQUIRE_OK(csi_ctx_limit_memory(ctx, 0, csi_device_bytes_live() + 65536));
    cl_mem m = NULL;
    st = csi_buffer(ctx, 100000, CL_MEM_READ_WRITE, "a test buffer", &m);
    CHECK(st == CSI_ERR_DEVICE && m == NULL && strstr(csi_last_error(), "a test buffer") &&
              strstr(csi_last_error(), "in use"),
          "over the global limit: %s", csi_last_error());
    CHECK_OK(csi_buffer(ctx, 1000, CL_MEM_READ_WRITE, "a small buffer", &m));
    csi_buffer_release(&m);
    return test_done();
}
