/* The pixels that decide an image settled on their samples' mean (csi_settle, csi/settle.h), on
 * hand-made samples whose disagreements are exact in binary, so that each pixel's share, and so
 * its weight, follows from the rule alone:
 *
 *   8 x 8 pixels on a 4x grid, 2 channels, every pixel sampled at cells (0, 0) and (3, 2) of its
 *   block, with values (1, 2) (mean (1, 2)) except four HDR pixels whose samples are (40, 40);
 *   the image is each pixel's mean except:
 *     - (2, 5): (43, 43), disagreement 9 + 9 = 18;
 *     - (6, 1): (40, 44), disagreement 16;
 *     - (3, 3): (40.5, 40.5), disagreement 0.25 + 0.25 = 0.5;
 *     - (0, 7): its mean (40, 40), no disagreement;
 *     - (7, 7): no sample, image (9, 9): no mean, never moved, not counted.
 *   The image's level (the mean over the 63 sampled pixels of their means' channel sums) is
 *   (59 x 3 + 4 x 80) / 63 = 7.9, so the four are HDR (80 > 4 x 7.9). The total disagreement is
 *   18 + 16 + 0.5 = 34.5: the first two hold far more than the 2% from which a pixel takes its
 *   mean whole; (3, 3) holds 0.5 / 34.5 = 1.45%, inside the ramp, so it moves by
 *   w = (0.5 / 34.5 - 0.005) / (0.02 - 0.005) of the way to its mean.
 * Then, on other images of the same samples: a firefly's pixel (the mean bright, the image dark)
 * holding most of the disagreement is kept while a bright pixel beside it moves; an image of
 * ordinary range (every sample (1, 2), the same disagreements) moves nothing, however large a
 * pixel's share; an image equal to the means up to float rounding moves nothing.
 * Also: the count inside a box; the same call twice gives the same bits; a volume is refused;
 * the second pass's pick (csi_refine_positions) at its default share takes every pixel this
 * step moves; and a pixel beside one that takes its mean whole, on the same light, takes its own
 * whole however small its own share. */
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/settle.h"
#include "testlib.h"

enum { OW = 8, F = 4, NP = OW * OW, C = 2 };

typedef struct {
    csi_sample_pos pos[NP * 2];
    float val[NP * 2 * C];
    size_t n;
    float img[C * NP];
} scene;

static void set_px(scene *s, int x, int y, float a, float b)
{
    s->img[y * OW + x] = a;
    s->img[NP + y * OW + x] = b;
}

static bool hdr_px(uint32_t x, uint32_t y)
{
    return (x == 2 && y == 5) || (x == 6 && y == 1) || (x == 3 && y == 3) || (x == 0 && y == 7);
}

/* Samples of (1, 2), or (40, 40) at the HDR pixels when `hdr`; the image their means. */
static void make_base(scene *s, bool hdr)
{
    memset(s, 0, sizeof *s);
    for (int p = 0; p < NP; p++) {
        const uint32_t x = (uint32_t)(p % OW), y = (uint32_t)(p / OW);
        const bool h = hdr && hdr_px(x, y);
        s->img[p] = h ? 40 : 1, s->img[NP + p] = h ? 40 : 2;
        if (x == 7 && y == 7)
            continue; /* no sample */
        const uint32_t cell[2][2] = {{0, 0}, {3, 2}};
        for (int k = 0; k < 2; k++) {
            s->pos[s->n] = (csi_sample_pos){x * F + cell[k][0], y * F + cell[k][1], 0};
            s->val[s->n * C] = h ? 40 : 1;
            s->val[s->n * C + 1] = h ? 40 : 2;
            s->n++;
        }
    }
    set_px(s, 7, 7, 9, 9);
}

static void make(scene *s)
{
    make_base(s, true);
    set_px(s, 2, 5, 43, 43);
    set_px(s, 6, 1, 40, 44);
    set_px(s, 3, 3, 40.5f, 40.5f);
}

static float at(const scene *s, int x, int y, int c)
{
    return s->img[c * NP + y * OW + x];
}

static int changed_except(const scene *s, const scene *before, int ex, int ey)
{
    int k = 0;
    for (int p = 0; p < NP; p++)
        if (p != ey * OW + ex)
            k += s->img[p] != before->img[p] || s->img[NP + p] != before->img[NP + p];
    return k;
}

int main(void)
{
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    scene s;
    make(&s);
    size_t k = 99;
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, NULL, &k));
    CHECK(k == 3, "%zu pixels moved, want 3: (2, 5), (6, 1), (3, 3)", k);
    CHECK(at(&s, 2, 5, 0) == 40 && at(&s, 2, 5, 1) == 40, "(2, 5) takes its mean: (%g, %g)", at(&s, 2, 5, 0),
          at(&s, 2, 5, 1));
    CHECK(at(&s, 6, 1, 0) == 40 && at(&s, 6, 1, 1) == 40, "(6, 1) takes its mean: (%g, %g)", at(&s, 6, 1, 0),
          at(&s, 6, 1, 1));
    CHECK(at(&s, 7, 7, 0) == 9 && at(&s, 7, 7, 1) == 9, "(7, 7) has no sample and is kept");
    const double w = (0.5 / 34.5 - 0.005) / (0.02 - 0.005);
    const float want0 = (float)(40.5 + w * (40 - 40.5)), want1 = want0;
    CHECK(at(&s, 3, 3, 0) == want0 && at(&s, 3, 3, 1) == want1, "(3, 3) moves by w = %.6f: (%.9g, %.9g), want "
          "(%.9g, %.9g)", w, at(&s, 3, 3, 0), at(&s, 3, 3, 1), want0, want1);
    CHECK(w > 0.6 && w < 0.65, "the ramp's weight at a 1.45%% share is %g", w);
    int others = 0;
    for (int p = 0; p < NP; p++) {
        const int x = p % OW, y = p / OW;
        if ((x == 2 && y == 5) || (x == 6 && y == 1) || (x == 3 && y == 3))
            continue;
        others += at(&s, x, y, 0) != (x == 7 && y == 7 ? 9 : hdr_px((uint32_t)x, (uint32_t)y) ? 40 : 1);
    }
    CHECK(others == 0, "%d other pixels changed", others);

    /* a firefly's pixel: its mean bright (40, 40), the image dark (1, 2), most of the
     * disagreement; it is kept, and (2, 5) beside it moves by its share of the total */
    scene before;
    make_base(&s, true);
    set_px(&s, 0, 7, 1, 2);
    set_px(&s, 2, 5, 43, 43);
    before = s;
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, NULL, &k));
    const double total = 39.0 * 39 + 38.0 * 38 + 18, wf = (18 / total - 0.005) / (0.02 - 0.005);
    CHECK(k == 1 && at(&s, 0, 7, 0) == 1 && at(&s, 0, 7, 1) == 2, "the firefly's pixel moved (%zu moved)", k);
    CHECK(wf > 0 && at(&s, 2, 5, 0) == (float)(43 + wf * (40 - 43)), "(2, 5) beside it: %.9g, want %.9g",
          at(&s, 2, 5, 0), (float)(43 + wf * (40 - 43)));
    CHECK(changed_except(&s, &before, 2, 5) == 0, "other pixels moved beside the firefly");

    /* an image of ordinary range: every sample (1, 2); the same disagreements, shares of 1.45% to
     * 52%, and nothing moves: no pixel is beyond 4 times the image's level */
    make_base(&s, false);
    set_px(&s, 2, 5, 4, 5);
    set_px(&s, 6, 1, 1, 6);
    set_px(&s, 3, 3, 1.5f, 2.5f);
    before = s;
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, NULL, &k));
    CHECK(k == 0 && !memcmp(s.img, before.img, sizeof s.img), "%zu pixels of an ordinary range moved", k);

    /* the count inside a box (a tile's core): x in [0, 4), y in [0, 8) holds (2, 5) and (3, 3) */
    make(&s);
    const uint32_t box[4] = {0, 0, 4, 8};
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, box, &k));
    CHECK(k == 2, "%zu pixels moved inside the box, want 2", k);

    /* deterministic */
    scene a, b;
    make(&a);
    make(&b);
    CHECK_OK(csi_settle(&g, C, a.pos, a.val, a.n, a.img, NULL, NULL));
    CHECK_OK(csi_settle(&g, C, b.pos, b.val, b.n, b.img, NULL, NULL));
    CHECK(!memcmp(a.img, b.img, sizeof a.img), "two calls differ");

    /* given each pixel's sample count and channel sums (made here by hand) instead of the samples:
     * the same bits and count; and the sums of the samples inside a box are that box's */
    make(&a);
    make(&b);
    static uint32_t cnt[NP];
    static double sum[NP * C];
    memset(cnt, 0, sizeof cnt);
    memset(sum, 0, sizeof sum);
    for (size_t i = 0; i < b.n; i++) {
        const size_t p = (size_t)(b.pos[i].y / F) * OW + b.pos[i].x / F;
        cnt[p]++;
        for (int c = 0; c < C; c++)
            sum[p * C + c] += b.val[i * C + c];
    }
    size_t ka = 0, kb = 0;
    CHECK_OK(csi_settle(&g, C, a.pos, a.val, a.n, a.img, NULL, &ka));
    CHECK_OK(csi_settle_sums(&g, C, cnt, sum, b.img, NULL, &kb));
    CHECK(ka == 3 && kb == ka && !memcmp(a.img, b.img, sizeof a.img), "from sums: %zu moved, %zu from samples%s", kb,
          ka, memcmp(a.img, b.img, sizeof a.img) ? ", other bits" : "");
    static uint32_t bcnt[NP];
    static double bsum[NP * C];
    memset(bcnt, 0, sizeof bcnt);
    memset(bsum, 0, sizeof bsum);
    csi_pixel_sums_add(&g, C, b.pos, b.val, b.n, box, bcnt, bsum);
    size_t off = 0;
    for (int p = 0; p < NP; p++) {
        const bool in = p % OW < 4 && p / OW < 8;
        off += bcnt[p] != (in ? cnt[p] : 0u);
        for (int c = 0; c < C; c++)
            off += bsum[p * C + c] != (in ? sum[p * C + c] : 0.0);
    }
    CHECK(off == 0, "the sums inside a box: %zu counts or sums not the box's", off);

    /* the second pass's pick at its default share takes every pixel moved (and the firefly's) */
    make(&s);
    const csi_samples smp = {g, C, s.n, s.pos, s.val, 0, NULL};
    const csi_image im = {OW, OW, C, s.img};
    csi_sample_pos *req = NULL;
    size_t cells = 0, pixels = 0;
    CHECK_OK(csi_refine_positions(&smp, &im, csi_refine_share_default(), &req, &cells, &pixels));
    CHECK(pixels == 3, "the pick takes %zu pixels, want the 3 moved", pixels);
    csi_free(req);

    /* a light's neighbours: (2, 4) made HDR too (samples (40, 40)), beside (2, 5), which takes its
     * mean whole. (2, 4)'s own share, 0.00390625 / 18.25390625 = 0.02%, is far below the ramp, yet
     * it takes its mean whole as well; (1, 5), beside (2, 5) too but of ordinary range (its share
     * 1.4%), is kept. The image's level is now (58 x 3 + 5 x 80) / 63 = 9.1: the five are HDR.
     * The pick takes the three (it does not test the range). */
    make_base(&s, true);
    const size_t p24 = 4 * OW + 2; /* pixel p's samples are 2p and 2p + 1 */
    for (size_t i = 2 * p24; i < 2 * p24 + 2; i++)
        s.val[i * C] = s.val[i * C + 1] = 40;
    set_px(&s, 2, 4, 40.0625f, 40);
    set_px(&s, 2, 5, 43, 43);
    set_px(&s, 1, 5, 1.5f, 2);
    before = s;
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, NULL, &k));
    CHECK(k == 2, "%zu pixels moved beside the light, want 2: (2, 5), (2, 4)", k);
    CHECK(at(&s, 2, 4, 0) == 40 && at(&s, 2, 4, 1) == 40, "(2, 4) beside the light takes its mean: (%.9g, %g)",
          at(&s, 2, 4, 0), at(&s, 2, 4, 1));
    CHECK(at(&s, 2, 5, 0) == 40 && at(&s, 2, 5, 1) == 40, "(2, 5) takes its mean");
    CHECK(at(&s, 1, 5, 0) == 1.5f && at(&s, 1, 5, 1) == 2, "(1, 5) of ordinary range moved");
    int moved = 0;
    for (int p = 0; p < NP; p++)
        if (p != 4 * OW + 2 && p != 5 * OW + 2)
            moved += s.img[p] != before.img[p] || s.img[NP + p] != before.img[NP + p];
    CHECK(moved == 0, "%d other pixels moved beside the light", moved);
    s = before;
    {
        const csi_samples ls = {g, C, s.n, s.pos, s.val, 0, NULL};
        const csi_image li = {OW, OW, C, s.img};
        CHECK_OK(csi_refine_positions(&ls, &li, csi_refine_share_default(), &req, &cells, &pixels));
        CHECK(pixels == 3, "the pick beside the light takes %zu pixels, want 3", pixels);
        csi_free(req);
    }

    /* an image that is its means up to float rounding: nothing to settle */
    make_base(&s, true);
    for (int p = 0; p < NP; p++)
        if (s.img[p] == 40)
            s.img[p] = 40.000004f; /* the next float up */
    before = s;
    CHECK_OK(csi_settle(&g, C, s.pos, s.val, s.n, s.img, NULL, &k));
    CHECK(k == 0 && !memcmp(s.img, before.img, sizeof s.img), "%zu pixels moved by float rounding", k);

    /* a volume is refused */
    const csi_grid vol = {OW * F, OW * F, 2, OW, OW};
    CHECK(csi_settle(&vol, C, s.pos, s.val, s.n, s.img, NULL, &k) == CSI_ERR_ARG, "a volume was not refused");
    return test_done();
}
