/* Alg. 2's sheared basis end to end (csi_recon with the defaults: the velocity estimated from the
 * samples, the DCT along t, the residual correction along the motion) on analytic volumes of
 * 64 x 64 x 16 cells sampled at 6% (random cells, csi_positions):
 *  - a pan: a texture of 10 sinusoids (periods 5-30 cells, random directions and phases) moving
 *    at v = (0.9, -0.45) cells per frame, exact at the cell centres. The estimated velocity is
 *    within 0.05 cells per frame of v on each axis: over the 15 frames between the first and the
 *    last that is 0.75 cells of drift, below the texture's shortest half period (the leave-one-out
 *    refinement steps down to 0.25 / (T - 1) = 0.017; the rest is the statistics of 3932
 *    samples). The image and frames are better than with the paper's basis on the same samples
 *    (motion_time dft, velocity none): the reason the basis is sheared.
 *  - the same pan at 3% of the cells: at most 0.7x the image MSE of the tuned 3-D Gaussian (the
 *    issue's target);
 *  - the same texture still (v = 0) with a disc sliding over a quarter of it: the velocity stays
 *    exactly 0 (the still basis is kept unless a velocity predicts the samples 3% better);
 *  - a still background with a large fast textured mover: the velocity stays 0 (most of the
 *    picture is not predicted better) and the image beats the mover's shear;
 *  - a given velocity is used as given; the estimate is deterministic (same bits twice);
 *  - a single pixel over time (nothing to shear) keeps the paper's basis. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "csi/reconstruct.h"
#include "testlib.h"

#define W 64
#define H 64
#define T 16
#define NS 10
#define PI 3.14159265358979323846

static double amp[NS], kx[NS], ky[NS], ph[NS];

static void texture_init(void)
{
    test_rng r;
    test_rng_seed(&r, 2024);
    for (int i = 0; i < NS; i++) {
        double period = 5 + 25 * test_rng_uniform(&r), dir = 2 * PI * test_rng_uniform(&r);
        kx[i] = cos(dir) / period;
        ky[i] = sin(dir) / period;
        amp[i] = 0.04 + 0.04 * test_rng_uniform(&r);
        ph[i] = 2 * PI * test_rng_uniform(&r);
    }
}

static double texture(double x, double y)
{
    double v = 0.5;
    for (int i = 0; i < NS; i++)
        v += amp[i] * sin(2 * PI * (kx[i] * x + ky[i] * y) + ph[i]);
    return v;
}

/* moving: the texture panned at (vx, vy) cells per frame; else still with a sliding disc */
static float *volume(bool moving, double vx, double vy)
{
    float *f = malloc((size_t)W * H * T * sizeof *f);
    for (int t = 0; t < T; t++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double cx = x + 0.5, cy = y + 0.5, v;
                if (moving) {
                    v = texture(cx - vx * t, cy - vy * t);
                } else {
                    v = texture(cx, cy);
                    double dx = cx - (12 + 2.0 * t), dy = cy - 40;
                    if (dx * dx + dy * dy < 64)
                        v = 0.95;
                }
                f[((size_t)t * H + y) * W + x] = (float)v;
            }
    return f;
}

/* a still background (the texture at 0.3 of its contrast) with a textured disc of radius r
 * (the texture, shifted, at twice its contrast) moving at `speed` cells per frame along x from
 * (12, 32): a ball rolling across a still table */
static float *still_with_mover(double r, double speed)
{
    float *f = malloc((size_t)W * H * T * sizeof *f);
    for (int t = 0; t < T; t++)
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double cx = x + 0.5, cy = y + 0.5, dx = cx - (12 + speed * t), dy = cy - 32;
                double v = dx * dx + dy * dy < r * r ? 0.5 + 2.0 * (texture(dx + 17, dy + 23) - 0.5)
                                                     : 0.5 + 0.3 * (texture(cx, cy) - 0.5);
                f[((size_t)t * H + y) * W + x] = (float)v;
            }
    return f;
}

typedef struct {
    csi_grid g;
    csi_sample_pos *pos;
    float *val;
    size_t n;
} samples;

static samples sample_at(const float *f, double rate)
{
    samples s;
    s.g = (csi_grid){W, H, T, W, H};
    csi_pos_opts po = {CSI_POS_RANDOM, 0, rate, 11};
    if (csi_positions(&s.g, &po, &s.pos, &s.n, NULL) != CSI_OK) {
        fprintf(stderr, "positions: %s\n", csi_last_error());
        exit(1);
    }
    s.val = malloc(s.n * sizeof *s.val);
    for (size_t i = 0; i < s.n; i++)
        s.val[i] = f[csi_grid_index(&s.g, s.pos[i])];
    return s;
}

static samples sample(const float *f)
{
    return sample_at(f, 0.06);
}

static double image_mse(const float *f, const csi_recon_result *r)
{
    double e = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        double m = 0;
        for (int t = 0; t < T; t++)
            m += f[(size_t)t * W * H + i];
        e += (r->image[i] - m / T) * (r->image[i] - m / T);
    }
    return e / (W * H);
}

static double frames_mse(const float *f, const csi_recon_result *r)
{
    double e = 0;
    for (size_t i = 0; i < (size_t)W * H * T; i++)
        e += (r->frames[i] - f[i]) * (r->frames[i] - f[i]);
    return e / ((double)W * H * T);
}

int main(void)
{
    csi_ctx *ctx = test_ctx();
    texture_init();
    const double vx = 0.9, vy = -0.45;

    /* a pan: the velocity found, the result better than the paper's basis */
    {
        float *f = volume(true, vx, vy);
        samples s = sample(f);
        csi_recon_options o;
        csi_recon_defaults(&o);
        o.frames = true;
        csi_recon_result a, b, c;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &o, &a));
        const double ex = a.options.motion_vx, ey = a.options.motion_vy;
        printf("pan (%.2f, %.2f): estimated (%.4f, %.4f) in %.2f s\n", vx, vy, ex, ey, a.t_velocity);
        CHECK(fabs(ex - vx) < 0.05 && fabs(ey - vy) < 0.05, "velocity (%.4f, %.4f) vs (%.2f, %.2f)", ex, ey, vx, vy);
        csi_recon_options p = o;
        p.motion_time = CSI_MOTION_TIME_DFT;
        p.motion_velocity = CSI_VELOCITY_NONE;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &p, &b));
        const double ia = image_mse(f, &a), ib = image_mse(f, &b), fa = frames_mse(f, &a), fb = frames_mse(f, &b);
        printf("image MSE %.3e (paper's basis %.3e), frames MSE %.3e (%.3e)\n", ia, ib, fa, fb);
        CHECK(ia < ib, "image MSE %.3e not below the paper's basis's %.3e", ia, ib);
        CHECK(fa < fb, "frames MSE %.3e not below the paper's basis's %.3e", fa, fb);
        /* deterministic: the same velocity and image bits again */
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &o, &c));
        CHECK(c.options.motion_vx == ex && c.options.motion_vy == ey &&
                  !memcmp(a.image, c.image, (size_t)W * H * sizeof(float)),
              "the same samples give the same velocity and image");
        csi_recon_result_free(&c);
        /* a given velocity is the basis's */
        p = o;
        p.motion_velocity = CSI_VELOCITY_GIVEN;
        p.motion_vx = 0.5;
        p.motion_vy = 0.25;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &p, &c));
        CHECK(c.options.motion_vx == 0.5 && c.options.motion_vy == 0.25 && c.t_velocity == 0,
              "given velocity (%g, %g)", c.options.motion_vx, c.options.motion_vy);
        csi_recon_result_free(&a);
        csi_recon_result_free(&b);
        csi_recon_result_free(&c);
        csi_free(s.pos);
        free(s.val);
        free(f);
    }

    /* the same pan at 3% of the cells against the paper's linear baseline, the 3-D Gaussian
     * normalized convolution with its width chosen by an oracle (the lowest image MSE of the
     * widths 0.5 * 1.15^j <= 6 cells): the target at 3%, at most 0.7x its image MSE.
     * Measured 0.17x; 1.84x when the sheared volume was projected onto each pixel's own sample
     * range over all t (the content moves across the pixels: the range of the few samples
     * around a pixel cuts what moved in). */
    {
        float *f = volume(true, vx, vy);
        samples s = sample_at(f, 0.03);
        double best = INFINITY, sbest = 0;
        for (double sig = 0.5; sig <= 6.0; sig *= 1.15) {
            csi_recon_options go;
            csi_recon_defaults(&go);
            go.estimator = CSI_EST_GAUSS;
            go.gauss_sigma = sig;
            csi_recon_result r;
            REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &go, &r));
            const double e = image_mse(f, &r);
            if (e < best) {
                best = e;
                sbest = sig;
            }
            csi_recon_result_free(&r);
        }
        csi_recon_options o;
        csi_recon_defaults(&o);
        csi_recon_result a;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &o, &a));
        const double e = image_mse(f, &a);
        printf("pan at 3%%: image MSE %.3e, tuned Gaussian's %.3e (sigma %.2f): %.2fx\n", e, best, sbest, e / best);
        CHECK(e <= 0.7 * best, "pan at 3%%: image MSE %.3e is %.2fx the tuned Gaussian's", e, e / best);
        csi_recon_result_free(&a);
        csi_free(s.pos);
        free(s.val);
        free(f);
    }

    /* still background with a small mover: no shear */
    {
        float *f = volume(false, 0, 0);
        samples s = sample(f);
        csi_recon_options o;
        csi_recon_defaults(&o);
        csi_recon_result a;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &o, &a));
        printf("still: estimated (%.4f, %.4f)\n", a.options.motion_vx, a.options.motion_vy);
        CHECK(a.options.motion_vx == 0 && a.options.motion_vy == 0, "still scene: velocity (%g, %g)",
              a.options.motion_vx, a.options.motion_vy);
        csi_recon_result_free(&a);
        csi_free(s.pos);
        free(s.val);
        free(f);
    }
    /* a still background with a large fast mover: the mover's velocity predicts the mover's
     * samples so much better that the mean leave-one-out error drops by half, but most of the
     * picture is background, which that shear predicts worse. The still basis
     * stays, and its image is better than the mover's shear gives on the same samples (the
     * mover's frames can be better sheared: one velocity cannot fit both). */
    {
        const double speed = 3;
        float *f = still_with_mover(12, speed);
        samples s = sample(f);
        csi_recon_options o;
        csi_recon_defaults(&o);
        csi_recon_result a, b;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &o, &a));
        printf("still + large mover: estimated (%.4f, %.4f)\n", a.options.motion_vx, a.options.motion_vy);
        CHECK(a.options.motion_vx == 0 && a.options.motion_vy == 0, "still + large mover: velocity (%g, %g)",
              a.options.motion_vx, a.options.motion_vy);
        csi_recon_options p = o;
        p.motion_velocity = CSI_VELOCITY_GIVEN;
        p.motion_vx = speed;
        p.motion_vy = 0;
        REQUIRE_OK(csi_recon(ctx, &s.g, 1, s.pos, s.val, s.n, &p, &b));
        const double ia = image_mse(f, &a), ib = image_mse(f, &b);
        printf("image MSE %.3e (sheared by the mover %.3e)\n", ia, ib);
        CHECK(ia < ib, "image MSE %.3e not below the mover's shear's %.3e", ia, ib);
        csi_recon_result_free(&a);
        csi_recon_result_free(&b);
        csi_free(s.pos);
        free(s.val);
        free(f);
    }
    /* one pixel over time: nothing to shear, the paper's basis (reported as such) */
    {
        const csi_grid g1 = {1, 1, 8, 1, 1};
        const csi_sample_pos p1[3] = {{0, 0, 1}, {0, 0, 4}, {0, 0, 6}};
        const float v1[3] = {0.2f, 0.5f, 0.3f};
        csi_recon_options o;
        csi_recon_defaults(&o);
        csi_recon_result a;
        REQUIRE_OK(csi_recon(ctx, &g1, 1, p1, v1, 3, &o, &a));
        CHECK(a.options.motion_time == CSI_MOTION_TIME_DFT && a.options.motion_vx == 0 && a.options.motion_vy == 0,
              "a single pixel's basis: time %d, velocity (%g, %g)", (int)a.options.motion_time,
              a.options.motion_vx, a.options.motion_vy);
        csi_recon_result_free(&a);
    }
    return test_done();
}
