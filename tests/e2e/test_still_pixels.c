/* A volume's still pixels (csi_recon_still_pixels, host/integrate/still_samples.c) through the
 * public API, against exact arithmetic: the truth is each pixel's mean over t of the volume's
 * cell values, in double; stratified Monte Carlo is the per-pixel mean of the very samples csi
 * gets (stratified positions: each pixel's samples one per stretch of its shutter).
 *
 * The volume: 32 x 32 pixels x 32 frames, one cell per pixel and frame, 3 channels, exact point
 * values. A still picture of independent random texels (the hardest still content for a fit: no
 * two neighbours alike) and a disc of radius 5 crossing it, 24 pixels over the shutter.
 *   1. Every pixel whose 3 x 3 window's pixels each hold two samples or more, all equal, bit
 *      for bit in every channel, is its samples' value in the image; and such pixels are most
 *      of those away from the disc's path.
 *   2. At 2, 4 and 8 spp (3 position seeds each) the image's MSE is below stratified Monte
 *      Carlo's on the same samples. Before the rule and the exact samples' whole correction
 *      (motion_correct.c) csi was 1.24x, 1.37x and 1.80x stratified's here: a still pixel's
 *      every sample is its exact mean over t, and csi's fit of the texture was not.
 *   3. The gate: the same texture panned by half a pixel a frame under a uniform sky (a moving
 *      camera) has fewer than half of its pixels of two samples agreeing, so the rule stays off:
 *      some pixel whose samples agree (the sky over which the horizon sweeps between them) keeps
 *      a value of its own. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "testlib.h"

#define W 32
#define T 32
#define C 3
#define NP (W * W)
#define SEEDS 3

static csi_device *dev;

/* A texel's channel value in [0.1, 0.9], from a hash of its coordinates (independent texels). */
static double texel(int x, int y, int c)
{
    uint64_t h = (uint64_t)(x & 0xffff) * 0x9E3779B97F4A7C15ull ^ (uint64_t)(y & 0xffff) * 0xC2B2AE3D27D4EB4Full ^
                 (uint64_t)c * 0x165667B19E3779F9ull;
    h ^= h >> 31, h *= 0xBF58476D1CE4E5B9ull, h ^= h >> 27;
    return 0.1 + 0.8 * (double)(h >> 11) / 9007199254740992.0;
}

/* The cell (x, y, t)'s value: pan = 0, the still texture and the disc; pan = 1, the texture
 * moving left half a pixel a frame below a uniform sky (rows < 10), and the disc. */
static float cell(int x, int y, int t, int c, int pan)
{
    const double s = (t + 0.5) / T, cx = 4.0 + 24.0 * s, cy = 16.0;
    if (hypot(x + 0.5 - cx, y + 0.5 - cy) < 5.0)
        return (float)(c == 0 ? 0.9 : c == 1 ? 0.2 : 0.1);
    if (!pan)
        return (float)texel(x, y, c);
    if (y < 10)
        return (float)(c == 2 ? 0.85 : 0.7);
    return (float)texel((int)floor(x + 0.5 * t), y, c);
}

typedef struct {
    csi_sample_pos *pos;
    float *val;
    size_t n;
} samples;

static bool sample(int pan, uint32_t spp, uint64_t seed, samples *s)
{
    const csi_grid g = {W, W, T, W, W};
    const csi_pos_opts po = {.method = CSI_POS_STRATIFIED, .spp = spp, .seed = seed};
    csi_status st = csi_positions(&g, &po, &s->pos, &s->n, NULL);
    CHECK(st == CSI_OK, "positions: %s", csi_last_error());
    if (st != CSI_OK || !(s->val = malloc(s->n * C * sizeof *s->val)))
        return false;
    for (size_t i = 0; i < s->n; i++)
        for (int c = 0; c < C; c++)
            s->val[i * C + c] = cell((int)s->pos[i].x, (int)s->pos[i].y, (int)s->pos[i].t, c, pan);
    return true;
}

/* csi's result for the samples, flagged exact, every option its default. */
static csi_result *reconstruct(const samples *s)
{
    const csi_samples smp = {{W, W, T, W, W}, C, s->n, s->pos, s->val, CSI_SAMPLES_EXACT, NULL};
    csi_options *o = NULL;
    csi_result *r = NULL;
    csi_status st = csi_options_new(&o);
    if (st == CSI_OK)
        st = csi_reconstruct(dev, &smp, o, NULL, NULL, &r);
    CHECK(st == CSI_OK, "reconstruct: %s", csi_last_error());
    csi_options_free(o);
    return st == CSI_OK ? r : NULL;
}

/* Per pixel: the sample count, whether every sample equals the first (all channels), that
 * first sample, and the samples' mean. */
typedef struct {
    int n, agree;
    float first[C];
    double mean[C];
} pixel;

static void pixels_of(const samples *s, pixel *px)
{
    memset(px, 0, NP * sizeof *px);
    for (size_t i = 0; i < s->n; i++) {
        pixel *p = &px[s->pos[i].y * W + s->pos[i].x];
        if (p->n++ == 0) {
            memcpy(p->first, s->val + i * C, sizeof p->first);
            p->agree = 1;
        } else if (memcmp(p->first, s->val + i * C, sizeof p->first)) {
            p->agree = 0;
        }
        for (int c = 0; c < C; c++)
            p->mean[c] += s->val[i * C + c];
    }
    for (int q = 0; q < NP; q++)
        for (int c = 0; c < C && px[q].n; c++)
            px[q].mean[c] /= px[q].n;
}

int main(void)
{
    REQUIRE_OK(csi_device_new(NULL, &dev));
    static double truth[C * NP];
    static pixel px[NP];
    for (int c = 0; c < C; c++)
        for (int q = 0; q < NP; q++) {
            double m = 0;
            for (int t = 0; t < T; t++)
                m += cell(q % W, q / W, t, c, 0);
            truth[c * NP + q] = m / T;
        }
    const uint32_t spps[3] = {2, 4, 8};
    for (int k = 0; k < 3; k++) {
        double e_csi = 0, e_strat = 0;
        size_t agreeing = 0, wrong = 0;
        for (uint64_t seed = 1; seed <= SEEDS; seed++) {
            samples s = {0};
            csi_result *r = NULL;
            csi_image im;
            if (sample(0, spps[k], seed, &s) && (r = reconstruct(&s)) && csi_result_image(r, &im) == CSI_OK) {
                pixels_of(&s, px);
                for (int q = 0; q < NP; q++)
                    for (int c = 0; c < C; c++) {
                        const double x = im.data[c * NP + q], m = px[q].mean[c], tr = truth[c * NP + q];
                        e_csi += (x - tr) * (x - tr);
                        e_strat += (m - tr) * (m - tr);
                    }
                /* claim 1 */
                for (int q = 0; q < NP; q++) {
                    int calm = 1;
                    for (int dy = -1; dy <= 1; dy++)
                        for (int dx = -1; dx <= 1; dx++) {
                            const int x = q % W + dx, y = q / W + dy;
                            if (x >= 0 && y >= 0 && x < W && y < W)
                                calm &= px[y * W + x].n >= 2 && px[y * W + x].agree;
                        }
                    if (!calm)
                        continue;
                    agreeing++;
                    int bad = 0;
                    for (int c = 0; c < C; c++)
                        bad |= im.data[c * NP + q] != px[q].first[c];
                    wrong += bad;
                }
            }
            csi_result_free(r);
            csi_free(s.pos);
            free(s.val);
        }
        printf("still texture and a disc, %u spp, %d seeds: image MSE csi %.3e, stratified %.3e (%.3fx); "
               "%zu pixels' windows agree, %zu of them not their value\n",
               spps[k], SEEDS, e_csi / (SEEDS * C * NP), e_strat / (SEEDS * C * NP), e_csi / e_strat, agreeing, wrong);
        /* the disc's path covers 14 of 32 rows: half the image lies away from it */
        CHECK(agreeing > SEEDS * NP / 3 && wrong == 0,
              "%u spp: %zu of %zu pixels whose windows' samples agree are not their value", spps[k], wrong, agreeing);
        CHECK(e_csi < e_strat, "%u spp: csi's image MSE %.3e is not below stratified's %.3e", spps[k],
              e_csi / (SEEDS * C * NP), e_strat / (SEEDS * C * NP));
    }
    /* claim 3 */
    samples s = {0};
    csi_result *r = NULL;
    csi_image im;
    if (sample(1, 4, 1, &s) && (r = reconstruct(&s)) && csi_result_image(r, &im) == CSI_OK) {
        pixels_of(&s, px);
        size_t multi = 0, agree = 0, kept_own = 0;
        for (int q = 0; q < NP; q++) {
            if (px[q].n < 2)
                continue;
            multi++;
            if (!px[q].agree)
                continue;
            agree++;
            for (int c = 0; c < C; c++)
                if (im.data[c * NP + q] != px[q].first[c]) {
                    kept_own++;
                    break;
                }
        }
        printf("panned: %zu of %zu pixels' samples agree; %zu of those keep a value of their own\n", agree, multi,
               kept_own);
        CHECK(agree > 0 && 2 * agree < multi && kept_own > 0,
              "panned: %zu of %zu pixels agree, %zu keep their own value: the gate did not hold the rule off",
              agree, multi, kept_own);
    }
    csi_result_free(r);
    csi_free(s.pos);
    free(s.val);
    csi_device_release(dev);
    return test_done();
}
