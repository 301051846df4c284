/* Where to sample next (csi_refine_positions), on hand-made samples whose disagreements are
 * small integers, so that every sum is exact and the pixels picked follow from the rule alone:
 * a pixel is picked when (image - its samples' mean)^2, summed over the channels, is at least
 * `share` of that sum over the image; the request is every cell of the picked pixels without a
 * sample, pixels in row order, each block's cells in row order.
 *
 *   8 x 8 pixels on a 4x grid (16 cells a pixel), 2 channels, every pixel sampled at cells (0, 0)
 *   and (3, 2) of its block with values 1 (channel 0) and 2 (channel 1), so each pixel's mean is
 *   (1, 2); the image is (1, 2) everywhere except:
 *     - (2, 5): (4, 2), disagreement 9;
 *     - (6, 1): (1, 6), disagreement 16;
 *     - (0, 7): (3, 3), disagreement 4 + 1 = 5;
 *     - (4, 4): (2, 2), disagreement 1, and its block sampled in every cell (all 1, 2): never
 *       picked, nothing is left to sample there;
 *     - (7, 7): no sample at all, image (9, 9): no mean to disagree with, not counted either.
 *   The total is 9 + 16 + 5 + 1 = 31: a share just below 5/31 picks the three, just above it
 *   the two largest, 16/31 only (6, 1), and 1 every pixel only if one holds all of it (none).
 * csi_refine_apply sets a refined pixel to the mean of all its samples and nothing else;
 * csi_refine_settle, given the samples' variances, moves the one bright pixel that holds most of
 * the remaining disagreement to the mean of all its samples and nothing else (below).
 * The mean's own error: where the image is every pixel's mean (no disagreement anywhere), a pixel
 * is picked when its mean's sampling variance, (1 - n / N) s^2 / n over the channels, holds the
 * share of that sum: (3, 3)'s two samples (1, 2) and (9, 2) give s^2 = 32 in channel 0, so
 * (1 - 2 / 16) 32 / 2 = 14; (5, 6)'s (1, 2) and (1, 4) give 0.875 x 2 / 2 = 0.875 (the total
 * 14.875): a share just below 0.875 / 14.875 picks both, just above it (3, 3) alone, above
 * 14 / 14.875 none; (4, 4), sampled in every cell with values 1 and 3 in turn, has nothing left
 * to sample (N = n: 0). A pixel of one sample takes the spread of its 3 x 3 pixels' samples: with
 * (1, 1)'s second sample gone and (2, 1)'s channel 0 at 1 and 9 (its own (1 - 2/16) 32 / 2 = 14),
 * (1, 1)'s window holds 17 samples, channel 0 sixteen 1s and one 9: s^2 = (97 - 25^2 / 17) / 16 =
 * 64 / 17, so (1 - 1/16) 64 / 17 = 60 / 17 of the total 298 / 17. A share just below 60 / 298
 * picks both (all 15 of (1, 1)'s empty cells), just above it (2, 1) alone.
 * Also: an image equal to the means up to float rounding picks nothing; the same call twice gives
 * the same cells; a volume, a share outside (0, 1], an image of another size and a NaN value are
 * refused with CSI_ERR_ARG. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "testlib.h"

enum { OW = 8, F = 4, NP = OW * OW, C = 2 };

typedef struct {
    csi_sample_pos pos[NP * 2 + F * F];
    float val[(NP * 2 + F * F) * C];
    size_t n;
    float img[C * NP];
} scene;

static void add(scene *s, uint32_t x, uint32_t y, float a, float b)
{
    s->pos[s->n] = (csi_sample_pos){x, y, 0};
    s->val[s->n * C] = a;
    s->val[s->n * C + 1] = b;
    s->n++;
}

static void set_px(scene *s, int x, int y, float a, float b)
{
    s->img[y * OW + x] = a;
    s->img[NP + y * OW + x] = b;
}

static void make(scene *s)
{
    memset(s, 0, sizeof *s);
    for (int p = 0; p < NP; p++) {
        const uint32_t x = (uint32_t)(p % OW), y = (uint32_t)(p / OW);
        s->img[p] = 1, s->img[NP + p] = 2;
        if (x == 7 && y == 7)
            continue; /* no sample */
        if (x == 4 && y == 4) {
            for (uint32_t cy = 0; cy < F; cy++)
                for (uint32_t cx = 0; cx < F; cx++)
                    add(s, x * F + cx, y * F + cy, 1, 2);
            continue;
        }
        add(s, x * F, y * F, 1, 2);
        add(s, x * F + 3, y * F + 2, 1, 2);
    }
    set_px(s, 2, 5, 4, 2);
    set_px(s, 6, 1, 1, 6);
    set_px(s, 0, 7, 3, 3);
    set_px(s, 4, 4, 2, 2);
    set_px(s, 7, 7, 9, 9);
}

/* The request the rule gives for the picked pixels `px` (in row order): each block's 14 cells
 * without a sample, in row order. */
static size_t expected(const int (*px)[2], int k, csi_sample_pos *out)
{
    size_t n = 0;
    for (int i = 0; i < k; i++)
        for (uint32_t cy = 0; cy < F; cy++)
            for (uint32_t cx = 0; cx < F; cx++)
                if (!(cx == 0 && cy == 0) && !(cx == 3 && cy == 2))
                    out[n++] = (csi_sample_pos){(uint32_t)px[i][0] * F + cx, (uint32_t)px[i][1] * F + cy, 0};
    return n;
}

/* What a call that should change only pixel (x, y), to (a, b), did: n_px pixels reported, the
 * image img against its copy before, was. */
static void check_one_pixel(const char *what, size_t n_px, const float *img, const float *was, int x, int y,
                            float a, float b)
{
    const int q = y * OW + x;
    size_t other = 0;
    for (int p = 0; p < NP; p++)
        for (int c = 0; c < C; c++)
            other += p != q && img[c * NP + p] != was[c * NP + p];
    CHECK(n_px == 1 && img[q] == a && img[NP + q] == b && !other,
          "%s: %zu pixels, (%d, %d) = (%g, %g), want (%g, %g); %zu others changed", what, n_px, x, y, img[q],
          img[NP + q], a, b, other);
}

static void check_share(const csi_samples *smp, const csi_image *img, double share, const int (*px)[2], int k,
                        const char *what)
{
    csi_sample_pos want[3 * F * F];
    const size_t nw = expected(px, k, want);
    csi_sample_pos *got = NULL;
    size_t n = 0, pixels = 0;
    CHECK_OK(csi_refine_positions(smp, img, share, &got, &n, &pixels));
    CHECK(pixels == (size_t)k && n == nw, "%s: %zu pixels and %zu cells, want %d and %zu", what, pixels, n, k, nw);
    if (n == nw && nw)
        CHECK(got && !memcmp(got, want, nw * sizeof *want), "%s: the cells differ from the rule's", what);
    CHECK(nw || !got, "%s: no cell, but a request array", what);
    csi_free(got);
}

int main(void)
{
    scene *s = malloc(sizeof *s);
    if (!s)
        return 1;
    make(s);
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    csi_samples smp = {g, C, s->n, s->pos, s->val, 0, NULL};
    csi_image img = {OW, OW, C, s->img};

    static const int three[][2] = {{6, 1}, {2, 5}, {0, 7}}, two[][2] = {{6, 1}, {2, 5}}, one[][2] = {{6, 1}};
    check_share(&smp, &img, 5.0 / 31 * (1 - 1e-9), three, 3, "share just below 5/31");
    check_share(&smp, &img, 5.0 / 31 * (1 + 1e-9), two, 2, "share just above 5/31");
    check_share(&smp, &img, 16.0 / 31, one, 1, "share 16/31");
    check_share(&smp, &img, 1, NULL, 0, "share 1");
    /* a share small enough for the fully sampled pixel still leaves it out */
    check_share(&smp, &img, 1.0 / 31, three, 3, "share 1/31 (the full pixel has nothing to sample)");

    /* an image that differs from the means by float rounding only (here 2^-20 relative at one
     * pixel, float32's last bits after a few operations) disagrees nowhere: nothing is picked */
    scene *flat = malloc(sizeof *flat);
    if (!flat)
        return 1;
    make(flat);
    for (int p = 0; p < NP; p++)
        flat->img[p] = 1, flat->img[NP + p] = 2;
    flat->img[5 * OW + 2] = 1.0f + 0x1p-20f;
    csi_samples fs = {g, C, flat->n, flat->pos, flat->val, 0, NULL};
    csi_image fi = {OW, OW, C, flat->img};
    check_share(&fs, &fi, 0.01, NULL, 0, "the means up to rounding");
    free(flat);

    /* csi_refine_apply: the refined pixels take the mean of all their samples, the others stay.
     * (2, 5)'s 14 missing cells evaluated at 8 (channel 0) and 9 (channel 1): its mean becomes
     * (2 x 1 + 14 x 8) / 16 = 7.125 and (2 x 2 + 14 x 9) / 16 = 8.125, exact in float. */
    {
        static const int px25[][2] = {{2, 5}};
        csi_sample_pos mp[F * F];
        const size_t nm = expected(px25, 1, mp);
        float mv[F * F * C];
        for (size_t i = 0; i < nm; i++)
            mv[i * C] = 8, mv[i * C + 1] = 9;
        csi_samples more = {g, C, nm, mp, mv, 0, NULL};
        float copy[C * NP];
        memcpy(copy, s->img, sizeof copy);
        csi_image ci = {OW, OW, C, copy};
        size_t set = 0;
        CHECK_OK(csi_refine_apply(&smp, &more, &ci, &set));
        check_one_pixel("refine_apply", set, copy, s->img, 2, 5, 7.125f, 8.125f);
        csi_samples bad = more;
        bad.channels = 1;
        CHECK(csi_refine_apply(&smp, &bad, &ci, NULL) == CSI_ERR_ARG, "refine_apply: other channels not refused");
    }

    /* csi_refine_settle: with the samples' variances, a pixel holding most of what still
     * disagrees, and bright in both (the image and all its samples' mean), takes that mean (the
     * rule of csi/settle.h). (6, 1)'s 14 missing cells evaluated at (40, 40): its 16 samples'
     * mean is ((2 + 560) / 16, (4 + 560) / 16) = (35.125, 35.25), exact in float. With the image
     * at (30, 30) there, its disagreement 5.125^2 + 5.25^2 = 53.83 is 78% of the image's (the
     * others: 9 + 5 + 1), its channel sums 60 and 70.375 beyond 4 times the image's level (3):
     * moved, and only it ((2, 5) and (0, 7) hold 13% and 7% but are not bright). Without the
     * variances nothing moves; without the more samples (6, 1)'s mean is (1, 2), which the image
     * sees 20 times brighter: a firefly's pattern, left alone. */
    {
        static const int px61[][2] = {{6, 1}};
        csi_sample_pos mp[F * F];
        const size_t nm = expected(px61, 1, mp);
        float mv[F * F * C], var[(NP * 2 + F * F) * C] = {0};
        for (size_t i = 0; i < nm * C; i++)
            mv[i] = 40;
        csi_samples more = {g, C, nm, mp, mv, 0, NULL}, with_var = smp;
        with_var.variance = var;
        float copy[C * NP];
        memcpy(copy, s->img, sizeof copy);
        copy[1 * OW + 6] = 30, copy[NP + 1 * OW + 6] = 30;
        float before[C * NP];
        memcpy(before, copy, sizeof before);
        csi_image ci = {OW, OW, C, copy};
        size_t moved = 99;
        CHECK_OK(csi_refine_settle(&smp, &more, &ci, &moved));
        CHECK(moved == 0 && !memcmp(copy, before, sizeof copy), "refine_settle without variances moved %zu pixels",
              moved);
        CHECK_OK(csi_refine_settle(&with_var, NULL, &ci, &moved));
        CHECK(moved == 0 && !memcmp(copy, before, sizeof copy),
              "refine_settle without the more samples moved %zu pixels (a firefly's pattern)", moved);
        CHECK_OK(csi_refine_settle(&with_var, &more, &ci, &moved));
        check_one_pixel("refine_settle", moved, copy, before, 6, 1, 35.125f, 35.25f);
        csi_samples bad = more;
        bad.channels = 1;
        CHECK(csi_refine_settle(&with_var, &bad, &ci, NULL) == CSI_ERR_ARG, "refine_settle: other channels not refused");
        CHECK(csi_refine_settle(&with_var, &more, NULL, NULL) == CSI_ERR_ARG, "refine_settle: no image not refused");
    }

    /* the mean's own error, where the image is the means */
    {
        scene *sp = malloc(sizeof *sp);
        if (!sp)
            return 1;
        make(sp);
        for (size_t i = 0; i < sp->n; i++) {
            const csi_sample_pos q = sp->pos[i];
            const uint32_t px = q.x / F, py = q.y / F;
            if (px == 3 && py == 3 && q.x % F == 3)
                sp->val[i * C] = 9;
            if (px == 5 && py == 6 && q.x % F == 3)
                sp->val[i * C + 1] = 4;
            if (px == 4 && py == 4 && (q.x + q.y) % 2)
                sp->val[i * C] = 3;
        }
        for (int p = 0; p < NP; p++)
            sp->img[p] = 1, sp->img[NP + p] = 2;
        set_px(sp, 3, 3, 5, 2);
        set_px(sp, 5, 6, 1, 3);
        set_px(sp, 4, 4, 2, 2);
        csi_samples ss = {g, C, sp->n, sp->pos, sp->val, 0, NULL};
        csi_image si = {OW, OW, C, sp->img};
        static const int both[][2] = {{3, 3}, {5, 6}}, first[][2] = {{3, 3}};
        check_share(&ss, &si, 0.875 / 14.875 * (1 - 1e-9), both, 2, "spread: share just below 0.875/14.875");
        check_share(&ss, &si, 0.875 / 14.875 * (1 + 1e-9), first, 1, "spread: share just above 0.875/14.875");
        check_share(&ss, &si, 14 / 14.875 * (1 + 1e-9), NULL, 0, "spread: share just above 14/14.875");
        free(sp);
    }

    /* a pixel of one sample, by its 3 x 3 pixels' spread */
    {
        scene *sp = malloc(sizeof *sp);
        if (!sp)
            return 1;
        make(sp);
        size_t k = 0;
        for (size_t i = 0; i < sp->n; i++) {
            const csi_sample_pos q = sp->pos[i];
            if (q.x == 1 * F + 3 && q.y == 1 * F + 2)
                continue; /* (1, 1)'s second sample */
            sp->pos[k] = q;
            sp->val[k * C] = q.x == 2 * F + 3 && q.y == 1 * F + 2 ? 9 : sp->val[i * C];
            sp->val[k * C + 1] = sp->val[i * C + 1];
            k++;
        }
        sp->n = k;
        for (int p = 0; p < NP; p++)
            sp->img[p] = 1, sp->img[NP + p] = 2;
        set_px(sp, 2, 1, 5, 2);
        set_px(sp, 4, 4, 1, 2);
        csi_samples ss = {g, C, sp->n, sp->pos, sp->val, 0, NULL};
        csi_image si = {OW, OW, C, sp->img};
        static const int only21[][2] = {{2, 1}};
        check_share(&ss, &si, 60.0 / 298 * (1 + 1e-9), only21, 1, "one sample: share just above 60/298");
        csi_sample_pos want[15 + 14], *got = NULL;
        size_t nw = 0, n = 0, pixels = 0;
        for (uint32_t cy = 0; cy < F; cy++)
            for (uint32_t cx = 0; cx < F; cx++)
                if (cx || cy)
                    want[nw++] = (csi_sample_pos){1 * F + cx, 1 * F + cy, 0};
        nw += expected(only21, 1, want + nw);
        CHECK_OK(csi_refine_positions(&ss, &si, 60.0 / 298 * (1 - 1e-9), &got, &n, &pixels));
        CHECK(pixels == 2 && n == nw && got && !memcmp(got, want, nw * sizeof *want),
              "one sample: share just below 60/298 gave %zu pixels and %zu cells, want 2 and %zu (the rule's)", pixels,
              n, nw);
        csi_free(got);
        free(sp);
    }

    /* deterministic */
    csi_sample_pos *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    CHECK_OK(csi_refine_positions(&smp, &img, 0.01, &a, &na, NULL));
    CHECK_OK(csi_refine_positions(&smp, &img, 0.01, &b, &nb, NULL));
    CHECK(na == nb && na && !memcmp(a, b, na * sizeof *a), "two calls gave different requests");
    csi_free(a);
    csi_free(b);

    /* refused */
    csi_sample_pos *r = NULL;
    size_t nr = 0;
    csi_samples vol = smp;
    vol.grid.t = 2;
    CHECK(csi_refine_positions(&vol, &img, 0.01, &r, &nr, NULL) == CSI_ERR_ARG, "a volume was not refused");
    CHECK(csi_refine_positions(&smp, &img, 0, &r, &nr, NULL) == CSI_ERR_ARG, "share 0 was not refused");
    CHECK(csi_refine_positions(&smp, &img, 1.5, &r, &nr, NULL) == CSI_ERR_ARG, "share 1.5 was not refused");
    CHECK(csi_refine_positions(&smp, &img, NAN, &r, &nr, NULL) == CSI_ERR_ARG, "share NaN was not refused");
    csi_image small = img;
    small.w = OW - 1;
    CHECK(csi_refine_positions(&smp, &small, 0.01, &r, &nr, NULL) == CSI_ERR_ARG, "a 7-wide image was not refused");
    s->val[5] = NAN;
    CHECK(csi_refine_positions(&smp, &img, 0.01, &r, &nr, NULL) == CSI_ERR_ARG, "a NaN sample was not refused");
    CHECK(!r && !nr, "a refused call left a request");
    free(s);
    return test_done();
}
