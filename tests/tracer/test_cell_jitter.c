/* Samples jittered in their cells (csi_tracer_set_cell_jitter) against closed forms.
 *
 * An emissive plane (radiance 1, nothing else lit) fills the image left of a vertical edge, so a
 * sample is exactly 1 or 0 and a cell's mean radiance is the share of its area (and time) left of
 * the edge. The camera looks along +z from z = -4 with fov 60: image point u meets the plane z = 0
 * at x = -(2u - 1) tan(30 deg) 4 (image right is -x, docs/scene-format.md), so an edge at x = X
 * is the image line u = (1 - X / (4 tan 30 deg)) / 2.
 *  - Still edge through a cell: the mean of N jittered samples of that cell is the share of the
 *    cell's width left of the edge, within 4 binomial standard errors; at the centre every
 *    sample is the centre's side.
 *  - Edge moving over the shutter: a cell of one frame is covered for the part of its (u, s)
 *    rectangle left of the moving line, integrated in double over s; again within 4 standard
 *    errors, and different from the share at the frame's middle time (t is jittered too).
 *  - The same bits for the same seed, for 1 and 3 threads, and for a subset traced with its
 *    indices in the larger set (csi_tracer_eval_ids). */
#include <math.h>

#include "tracer_test_util.h"

enum { W = 16, N = 4096 };

static const double TH = 0.57735026918962576; /* tan(30 deg) */

/* The image u of the edge x = X on the plane z = 0. */
static double edge_u(double X)
{
    return (1 - X / (4 * TH)) / 2;
}

static float *eval_cell(tt_setup *s, csi_sample_pos cell, uint32_t frames, uint64_t seed)
{
    const csi_grid g = {.w = W, .h = W, .t = frames, .out_w = W, .out_h = W};
    csi_sample_pos *pos = malloc(N * sizeof *pos);
    float *rgb = malloc(3 * N * sizeof *rgb);
    for (size_t i = 0; i < N; i++)
        pos[i] = cell;
    CHECK_OK(csi_tracer_eval(s->tr, &g, pos, N, seed, rgb, NULL, NULL));
    free(pos);
    return rgb;
}

/* The mean of the red channel; every sample must be exactly 0 or 1. */
static double mean_01(const float *rgb, const char *what)
{
    double sum = 0;
    size_t bad = 0;
    for (size_t i = 0; i < N; i++) {
        bad += rgb[3 * i] != 0.0f && rgb[3 * i] != 1.0f;
        sum += rgb[3 * i];
    }
    CHECK(bad == 0, "%s: %zu samples neither 0 nor 1", what, bad);
    return sum / N;
}

static void check_share(double got, double want, const char *what)
{
    const double se = sqrt(want * (1 - want) / N);
    CHECK(fabs(got - want) <= 4 * se, "%s: mean %.5f, the cell's share %.5f (4 se = %.5f)", what, got, want, 4 * se);
}

static void test_still_edge(void)
{
    /* the edge at x = 0.1: u = 0.4567..., in column 7 (u 0.4375-0.5) at 0.3 of its width */
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 0 -4 target 0 0 0 fov 60 size 16 16 }\n"
                     "material glow { diffuse 0 0 0 emission 1 1 1 }\n"
                     "plane { corner 0.1 -10 0 edge_u 20 0 0 edge_v 0 20 0 material glow }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    CHECK(s.pl.frames == 1, "a still scene has one frame (%u)", s.pl.frames);
    const double ue = edge_u(0.1);
    const uint32_t col = (uint32_t)floor(ue * W);
    const double share = ue * W - col; /* the cell's part with u < ue: covered */
    CHECK(share > 0.1 && share < 0.9, "the edge crosses the cell's middle (share %g)", share);
    const csi_sample_pos cell = {col, 5, 0};

    float *centre = eval_cell(&s, cell, 1, 7);
    const double at_centre = share > 0.5 ? 1 : 0; /* the centre is covered when more than half is */
    CHECK(mean_01(centre, "centre") == at_centre, "every centre sample is the centre's side (%g)", at_centre);
    free(centre);

    csi_tracer_set_cell_jitter(s.tr, true);
    float *jit = eval_cell(&s, cell, 1, 7);
    check_share(mean_01(jit, "jittered"), share, "still edge");

    /* the same bits again, and with 3 threads */
    float *again = eval_cell(&s, cell, 1, 7);
    CHECK(!memcmp(jit, again, 3 * N * sizeof *jit), "jittered samples differ between two runs");
    csi_tracer_free(s.tr);
    CHECK_OK(csi_tracer_create(s.sc, &s.pl, 3, &s.tr));
    csi_tracer_set_cell_jitter(s.tr, true);
    float *three = eval_cell(&s, cell, 1, 7);
    CHECK(!memcmp(jit, three, 3 * N * sizeof *jit), "jittered samples differ between 2 and 3 threads");

    /* a subset traced alone with its indices gets the values it gets in the whole set */
    enum { M = 5 };
    const uint64_t ids[M] = {3, 17, 1000, 2047, 4095};
    csi_sample_pos pos[M];
    float rgb[3 * M];
    for (int i = 0; i < M; i++)
        pos[i] = cell;
    const csi_grid g = {.w = W, .h = W, .t = 1, .out_w = W, .out_h = W};
    CHECK_OK(csi_tracer_eval_ids(s.tr, &g, pos, ids, M, 7, rgb, NULL, NULL));
    for (int i = 0; i < M; i++)
        CHECK(rgb[3 * i] == jit[3 * ids[i]], "sample %llu traced alone: %g, in the set %g",
              (unsigned long long)ids[i], rgb[3 * i], jit[3 * ids[i]]);

    /* another seed draws other points (the same share) */
    float *other = eval_cell(&s, cell, 1, 8);
    CHECK(memcmp(jit, other, 3 * N * sizeof *jit), "seeds 7 and 8 gave the same points");
    check_share(mean_01(other, "seed 8"), share, "still edge, seed 8");
    free(jit);
    free(again);
    free(three);
    free(other);
    tt_free(&s);
}

static void test_moving_edge(void)
{
    /* the edge moves from x = -1.5 to x = 1.7 over the shutter, u from 0.82 to 0.13: 11 cells
     * in 4 frames, so within a frame it sweeps the cell it crosses at the frame's middle */
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 0 -4 target 0 0 0 fov 60 size 16 16 }\nframes 4\n"
                     "material glow { diffuse 0 0 0 emission 1 1 1 }\n"
                     "plane { corner -1.5 -10 0 edge_u 20 0 0 edge_v 0 20 0 material glow\n"
                     "  motion { key 0 { translate 0 0 0 } key 1 { translate 3.2 0 0 } } }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    const uint32_t T = s.pl.frames;
    CHECK(T == 4, "the scene's 4 frames (%u)", T);
    /* the frame in the middle of the shutter and the column the edge crosses then */
    const uint32_t t = T / 2;
    const double um = edge_u(-1.5 + 3.2 * (t + 0.5) / T);
    const uint32_t col = (uint32_t)floor(um * W);
    /* the covered share of the cell's (u, s) rectangle: the mean over s of the covered length */
    enum { STEPS = 200000 };
    double share = 0;
    for (int k = 0; k < STEPS; k++) {
        const double sh = (t + (k + 0.5) / STEPS) / T;
        const double len = edge_u(-1.5 + 3.2 * sh) * W - col;
        share += len < 0 ? 0 : len > 1 ? 1 : len;
    }
    share /= STEPS;
    const double mid = um * W - col; /* the share at the frame's middle time alone */
    csi_tracer_set_cell_jitter(s.tr, true);
    float *jit = eval_cell(&s, (csi_sample_pos){col, 9, t}, T, 11);
    const double got = mean_01(jit, "moving");
    check_share(got, share, "moving edge");
    /* t jittered: the edge leaves the cell within the frame, so the share over the frame's time
     * differs from the middle time's */
    const double se = sqrt(share * (1 - share) / N);
    CHECK(fabs(share - mid) > 8 * se, "the test's geometry: share %.4f, middle time's %.4f", share, mid);
    CHECK(fabs(got - mid) > 4 * se, "moving edge: mean %.5f is the middle time's share %.5f", got, mid);
    free(jit);
    tt_free(&s);
}

int main(void)
{
    test_still_edge();
    test_moving_edge();
    return test_done();
}
