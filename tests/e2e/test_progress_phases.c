/* The phases a reconstruction reports (csi_recon_options.progress) and the channels it solves:
 * "setup", for a moving volume "velocity search" (with its steps counting up; a cancel there
 * stops the run), then per channel c of C "solve c/C" (with the solver's steps), "integrate c/C"
 * and, on a still image whose samples are not known to be exact, "correct c/C" (the blend's
 * passes over the image counting up; a cancel between two of them stops the run);
 * the per-pixel mean baseline "setup" then "integrate"; a channel whose samples repeat an earlier channel's bit for bit is not solved again and gets
 * that channel's result (the solve is deterministic, so the bits are the same as solving it).
 * RGB on a still image solved as luma and chroma (the default, chroma.c): "solve k/3" and
 * "integrate k/3" for Y, C1 and C2, then "correct c/3" for R, G and B, each channel solved.
 * Alg. 1 (static) and Alg. 2 (moving), small grids. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "testlib.h"

#define MAXP 512

typedef struct {
    char phase[MAXP][32];
    int steps[MAXP];
    int n, backwards;
    const char *stop_at; /* a phase whose first report with at least stop_step steps cancels */
    int stop_step;
} log_t;

static bool record(void *user, const char *phase, int iter, double res)
{
    log_t *l = user;
    (void)res;
    if (l->stop_at && !strcmp(phase, l->stop_at) && iter >= l->stop_step)
        return false;
    if (l->n > 0 && strcmp(l->phase[l->n - 1], phase) == 0) { /* one entry per phase */
        l->backwards += iter < l->steps[l->n - 1];
        l->steps[l->n - 1] = iter;
        return true;
    }
    if (l->n < MAXP) {
        snprintf(l->phase[l->n], sizeof l->phase[0], "%s", phase);
        l->steps[l->n++] = iter;
    }
    return true;
}

static int find(const log_t *l, const char *phase)
{
    for (int i = 0; i < l->n; i++)
        if (!strcmp(l->phase[i], phase))
            return i;
    return -1;
}

/* Channels 0 and 2 bitwise equal, channel 1 different; chroma: a still image's RGB as luma and
 * chroma (else R, G and B one after another). */
static void run(csi_ctx *ctx, uint32_t T, bool copy_equal, bool chroma)
{
    const csi_grid g = {64, 64, T, 16, 16};
    const csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = T > 1 ? 1 : 4, .seed = 3};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(&g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(false, "positions: %s", csi_last_error());
        return;
    }
    float *val = malloc(n * 3 * sizeof *val);
    for (size_t i = 0; i < n; i++) {
        float a = (float)((pos[i].x + 2 * pos[i].t) % 16 < 8) * 0.8f + 0.1f;
        val[3 * i] = val[3 * i + 2] = a;
        val[3 * i + 1] = (float)(pos[i].y % 10) / 10.0f;
    }
    if (!copy_equal) /* channel 2 one ulp away from channel 0 at one sample: solved on its own */
        val[3 * (n / 2) + 2] = nextafterf(val[3 * (n / 2) + 2], 2.0f);
    log_t l = {.n = 0};
    csi_recon_options o;
    csi_recon_defaults(&o);
    o.chroma = chroma ? CSI_SWITCH_ON : CSI_SWITCH_OFF;
    chroma = chroma && T == 1; /* a volume's channels are solved one after another either way */
    o.progress = record;
    o.user = &l;
    csi_recon_result r;
    csi_status st = csi_recon(ctx, &g, 3, pos, val, n, &o, &r);
    CHECK(st == CSI_OK, "reconstruct T = %u: %s", T, st == CSI_OK ? "" : csi_last_error());
    if (st == CSI_OK) {
        CHECK(l.n > 0 && !strcmp(l.phase[0], "setup"), "T = %u: the first phase is setup (%s)", T,
              l.n ? l.phase[0] : "none");
        int prev = 0;
        const int vi = find(&l, "velocity search");
        if (T > 1) {
            CHECK(vi == 1 && l.steps[vi] > 1, "T = %u: the velocity search follows setup with its steps (at %d, %d)",
                  T, vi, vi >= 0 ? l.steps[vi] : 0);
            prev = vi;
        } else
            CHECK(vi < 0, "a still image reports a velocity search");
        CHECK(!l.backwards, "T = %u: %d reports went backwards within a phase", T, l.backwards);
        for (int c = 1; c <= 3 && chroma; c++) { /* Y, C1, C2 solved and integrated, then R, G, B corrected */
            char sname[32], iname[32];
            snprintf(sname, sizeof sname, "solve %d/3", c);
            snprintf(iname, sizeof iname, "integrate %d/3", c);
            const int si = find(&l, sname), ii = find(&l, iname);
            /* C1 = (R - B) / sqrt 2 is zero (R = B: not solved, not integrated) or one ulp at one
             * sample (nothing to step on) */
            const bool empty = c == 2 && copy_equal;
            CHECK(si > prev && (empty ? ii < 0 : ii > si) && (c == 2 || l.steps[si] > 0),
                  "chroma: '%s' (%d steps) then '%s' after the previous channel", sname, si >= 0 ? l.steps[si] : 0, iname);
            prev = empty ? si : ii;
        }
        for (int c = 1; c <= 3 && chroma; c++) {
            char cname[32];
            snprintf(cname, sizeof cname, "correct %d/3", c);
            const int ci = find(&l, cname);
            CHECK(ci > prev && l.steps[ci] > 1, "chroma: '%s' after every solve and the corrections before, with its passes", cname);
            prev = ci;
        }
        for (int c = 1; c <= 3 && !chroma; c++) {
            char sname[32], iname[32], cname[32];
            snprintf(sname, sizeof sname, "solve %d/3", c);
            snprintf(iname, sizeof iname, "integrate %d/3", c);
            snprintf(cname, sizeof cname, "correct %d/3", c);
            int si = find(&l, sname), ii = find(&l, iname), ci = find(&l, cname);
            CHECK(si > prev, "T = %u: '%s' reported after the previous channel", T, sname);
            const bool solved = !(copy_equal && c == 3);
            if (solved) {
                CHECK(ii > si, "T = %u: '%s' after '%s'", T, iname, sname);
                CHECK(l.steps[si] > 0, "T = %u: '%s' carries the solver's steps (%d)", T, sname, l.steps[si]);
                /* still, and the samples are not flagged exact: the blend corrects, reporting its passes */
                CHECK(T > 1 || (ci > ii && l.steps[ci] > 1), "T = %u: '%s' after '%s' with its passes (at %d, %d)", T,
                      cname, iname, ci, ci >= 0 ? l.steps[ci] : 0);
                prev = ci > ii ? ci : ii;
            } else {
                CHECK(ii < 0, "T = %u: a repeated channel is not integrated again", T);
                prev = si;
            }
        }
        const size_t np = 16 * 16;
        /* one ulp at one sample need not show in the image (the cross-validated choice's folds
         * see the channels' mean): channel 2 is told apart by its own solve's time */
        if (copy_equal && !chroma)
            CHECK(memcmp(r.image, r.image + 2 * np, np * sizeof(float)) == 0, "T = %u: channels 0 and 2 have the same bits", T);
        else
            CHECK(r.report[2].t_total > 0, "T = %u: channel 2 (one ulp off channel 0) is solved on its own", T);
        if (copy_equal && !chroma)
            CHECK(r.report[2].iterations == r.report[0].iterations && r.report[2].t_total == 0,
                  "T = %u: the repeated channel reports the first one's solve, no time", T);
        csi_recon_result_free(&r);
    }
    if (T > 1) {
        log_t c = {.n = 0, .stop_at = "velocity search"};
        o.user = &c;
        st = csi_recon(ctx, &g, 3, pos, val, n, &o, &r);
        CHECK(st == CSI_ERR_CANCELLED && strstr(csi_last_error(), "velocity search"),
              "T = %u: a cancel in the velocity search: %d %s", T, (int)st, csi_last_error());
    }
    if (T == 1) { /* a cancel between two of the blend's passes */
        log_t cb = {.n = 0, .stop_at = "correct 2/3", .stop_step = 2};
        o.user = &cb;
        st = csi_recon(ctx, &g, 3, pos, val, n, &o, &r);
        CHECK(st == CSI_ERR_CANCELLED && strstr(csi_last_error(), "correct 2/3"),
              "a cancel inside the blend: %d %s", (int)st, csi_last_error());
    }
    free(pos);
    free(val);
}

/* The per-pixel mean (a baseline) reports "setup" then "integrate", its pass over every output
 * pixel, and a cancel there stops it with no result. */
static void run_mean(csi_ctx *ctx)
{
    /* every other cell of every other row: 4 samples in each pixel's 4x4 block, in grid order */
    enum { N = 32 * 32 };
    const csi_grid g = {64, 64, 1, 16, 16};
    csi_sample_pos pos[N];
    float val[N];
    const size_t n = N;
    for (size_t i = 0; i < n; i++) {
        pos[i] = (csi_sample_pos){(uint32_t)(2 * (i % 32)), (uint32_t)(2 * (i / 32)), 0};
        val[i] = (float)(pos[i].x % 7) / 7.0f;
    }
    for (int cancel = 0; cancel < 2; cancel++) {
        log_t l = {.n = 0, .stop_at = cancel ? "integrate" : NULL};
        csi_recon_options o;
        csi_recon_defaults(&o);
        o.estimator = CSI_EST_MEAN;
        o.progress = record;
        o.user = &l;
        csi_recon_result r;
        csi_status st = csi_recon(ctx, &g, 1, pos, val, n, &o, &r);
        if (cancel) {
            CHECK(st == CSI_ERR_CANCELLED && strstr(csi_last_error(), "integrate"), "mean: a cancel at integrate: %d %s",
                  (int)st, csi_last_error());
            continue;
        }
        CHECK(st == CSI_OK && l.n == 2 && !strcmp(l.phase[0], "setup") && !strcmp(l.phase[1], "integrate"),
              "mean: setup then integrate (%d phases, the last %s)", l.n, l.n ? l.phase[l.n - 1] : "none");
        if (st != CSI_OK)
            continue;
        double worst = 0; /* pixel (px, py) holds columns 4 px and 4 px + 2 of two rows */
        for (uint32_t p = 0; p < 16 * 16; p++) {
            const uint32_t x0 = 4 * (p % 16);
            const double want = ((x0 % 7) + ((x0 + 2) % 7)) / 14.0;
            worst = fmax(worst, fabs(r.image[p] - want));
        }
        CHECK(worst < 1e-6, "mean: each pixel is the mean of its samples (off by %g)", worst);
        csi_recon_result_free(&r);
    }
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    run_mean(ctx);
    for (int copy = 0; copy < 2; copy++) {
        run(ctx, 1, copy == 1, false);
        run(ctx, 1, copy == 1, true);
        run(ctx, 4, copy == 1, false);
    }
    return test_done();
}
