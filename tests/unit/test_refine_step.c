/* An HDR step's pixels after the passes (csi_refine_step_coverage), on a straight rim whose
 * pixel values are known: a bright side of (100, 50, 25) on a dark one of (1, 1, 1) across a line
 * at 23 degrees, 16 x 16 pixels on an 8x grid, four samples a pixel (four distinct random cells:
 * not one per stratum, so the window's line gives their coverage), each the value at its cell's centre with variance 0 (an emitter seen directly); a
 * second pass samples every remaining cell of three rim pixels. The bright side is an eighth of the
 * image (the rule's step must be 4 times the image's mean sample). The image is the first pass's
 * per-pixel means with the refined pixels given the mean of all their samples
 * (csi_refine_apply), as the passes leave it. The reference is each pixel's box coverage c by
 * 128 x 128 points (an error below 1/128 of the rim's length in the pixel), c B + (1 - c) D.
 *
 *   1. Some pixels move and the summed squared error against the reference falls (the step's
 *      promise on a straight rim, csi/step_coverage.h).
 *   2. The same bits whatever order the samples come in: first and more as given; all of them
 *      merged into one set in csi's cell order (csi-mitsuba's merged dump) with no `more`; first's
 *      samples reversed and more's before them in the merge.
 *   3. Without the first samples' variances, or with more's missing, nothing moves (bit for bit).
 *   4. A negative or NaN variance, a NULL image, and more of another grid are refused with
 *      CSI_ERR_ARG. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "csi/step_coverage.h"
#include "testlib.h"

enum { OW = 16, F = 8, NP = OW * OW, SPP = 4, C = 3, SUPER = 128, N_MAX = NP * F * F };

static const double BRIGHT[C] = {100, 50, 25}, DARK[C] = {1, 1, 1};
static const int REFINED[3][2] = {{10, 15}, {12, 12}, {13, 8}}; /* pixels on the rim (x, y) */

/* Is the image point (x, y), in pixels, on the bright side of the line (the lower right corner)? */
static int bright_at(double x, double y)
{
    const double a = 23.0 * 3.14159265358979323846 / 180.0;
    return x * cos(a) + y * sin(a) > 16.0;
}

static void value_at(uint32_t cx, uint32_t cy, float *v)
{
    const int b = bright_at((cx + 0.5) / F, (cy + 0.5) / F);
    for (int c = 0; c < C; c++)
        v[c] = (float)(b ? BRIGHT[c] : DARK[c]);
}

static uint64_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ull + 1442695040888963407ull;
    return *s >> 33;
}

typedef struct set {
    csi_sample_pos pos[N_MAX];
    float val[N_MAX * C], var[N_MAX * C];
    size_t n;
} set;

static void add(set *s, uint32_t x, uint32_t y)
{
    s->pos[s->n] = (csi_sample_pos){x, y, 0};
    value_at(x, y, s->val + s->n * C);
    for (int c = 0; c < C; c++)
        s->var[s->n * C + c] = 0.0f;
    s->n++;
}

static int is_refined(int px, int py)
{
    for (int k = 0; k < 3; k++)
        if (REFINED[k][0] == px && REFINED[k][1] == py)
            return 1;
    return 0;
}

static double squared_error(const float *img, const double *cov)
{
    double e = 0;
    for (int p = 0; p < NP; p++)
        for (int c = 0; c < C; c++) {
            const double d = img[c * NP + p] - (cov[p] * BRIGHT[c] + (1 - cov[p]) * DARK[c]);
            e += d * d;
        }
    return e;
}

static int cmp_cell(const void *a, const void *b)
{
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};
    const uint64_t x = csi_grid_index(&g, *(const csi_sample_pos *)a), y = csi_grid_index(&g, *(const csi_sample_pos *)b);
    return (x > y) - (x < y);
}

int main(void)
{
    static set first, more, merged, swapped;
    static float patched[C * NP], a[C * NP], b[C * NP], d[C * NP];
    static double cov[NP];
    const csi_grid g = {OW * F, OW * F, 1, OW, OW};

    /* the first pass: four distinct random cells of every pixel, in the pixel's order */
    uint64_t seed = 7;
    static unsigned char taken[OW * F][OW * F];
    for (uint32_t py = 0; py < OW; py++)
        for (uint32_t px = 0; px < OW; px++)
            for (int k = 0; k < SPP;) {
                const uint32_t x = px * F + (uint32_t)(lcg(&seed) % F), y = py * F + (uint32_t)(lcg(&seed) % F);
                if (!taken[y][x])
                    add(&first, x, y), taken[y][x] = 1, k++;
            }
    /* the second pass: every remaining cell of the refined pixels */
    for (int k = 0; k < 3; k++)
        for (uint32_t cy = 0; cy < F; cy++)
            for (uint32_t cx = 0; cx < F; cx++) {
                const uint32_t x = (uint32_t)REFINED[k][0] * F + cx, y = (uint32_t)REFINED[k][1] * F + cy;
                if (!taken[y][x])
                    add(&more, x, y);
            }
    /* the reference: each pixel's box coverage */
    for (int p = 0; p < NP; p++) {
        int hits = 0;
        for (int j = 0; j < SUPER; j++)
            for (int i = 0; i < SUPER; i++)
                hits += bright_at(p % OW + (i + 0.5) / SUPER, p / OW + (j + 0.5) / SUPER);
        cov[p] = (double)hits / (SUPER * SUPER);
    }
    /* the image the passes leave: the first pass's means, the refined pixels all their samples' */
    memset(patched, 0, sizeof patched);
    for (size_t i = 0; i < first.n; i++)
        for (int c = 0; c < C; c++)
            patched[c * NP + (first.pos[i].y / F) * OW + first.pos[i].x / F] += first.val[i * C + c] / SPP;
    csi_samples fs = {g, C, first.n, first.pos, first.val, 0, first.var};
    csi_samples ms = {g, C, more.n, more.pos, more.val, 0, more.var};
    csi_image img = {OW, OW, C, patched};
    size_t set_px = 0;
    CHECK_OK(csi_refine_apply(&fs, &ms, &img, &set_px));
    CHECK(set_px == 3, "csi_refine_apply set %zu pixels, not the 3 refined", set_px);
    for (int p = 0; p < NP; p++)
        if (is_refined(p % OW, p / OW))
            for (int c = 0; c < C; c++) {
                const double want = cov[p] * BRIGHT[c] + (1 - cov[p]) * DARK[c];
                /* the cells' centres count a straight rim's area to within a row of cells, 1/F */
                CHECK(fabs(patched[c * NP + p] - want) <= (BRIGHT[c] - DARK[c]) / F,
                      "refined pixel %d: %g, its coverage's value %g", p, patched[c * NP + p], want);
            }

    /* 1. the step moves rim pixels and the error falls */
    memcpy(a, patched, sizeof a);
    csi_image ia = {OW, OW, C, a};
    size_t moved = 0;
    CHECK_OK(csi_refine_step_coverage(&fs, &ms, &ia, &moved));
    const double e_before = squared_error(patched, cov), e_after = squared_error(a, cov);
    printf("straight rim after the passes: %zu pixels moved, squared error %.4g -> %.4g\n", moved, e_before, e_after);
    CHECK(moved > 0 && e_after < e_before, "%zu moved, error %.6g -> %.6g", moved, e_before, e_after);

    /* 2. any order: merged in cell order, and first reversed after more */
    for (size_t i = 0; i < first.n; i++)
        merged.pos[i] = first.pos[i], memcpy(merged.val + i * C, first.val + i * C, sizeof(float) * C);
    for (size_t i = 0; i < more.n; i++)
        merged.pos[first.n + i] = more.pos[i], memcpy(merged.val + (first.n + i) * C, more.val + i * C, sizeof(float) * C);
    merged.n = first.n + more.n;
    qsort(merged.pos, merged.n, sizeof *merged.pos, cmp_cell); /* values follow from the positions */
    for (size_t i = 0; i < merged.n; i++) {
        value_at(merged.pos[i].x, merged.pos[i].y, merged.val + i * C);
        for (int c = 0; c < C; c++)
            merged.var[i * C + c] = 0.0f;
    }
    memcpy(b, patched, sizeof b);
    csi_samples all = {g, C, merged.n, merged.pos, merged.val, 0, merged.var};
    csi_image ib = {OW, OW, C, b};
    CHECK_OK(csi_refine_step_coverage(&all, NULL, &ib, NULL));
    CHECK(memcmp(a, b, sizeof a) == 0, "first + more and the same samples merged in cell order differ");
    for (size_t i = 0; i < more.n; i++)
        swapped.pos[i] = more.pos[i], memcpy(swapped.val + i * C, more.val + i * C, sizeof(float) * C);
    for (size_t i = 0; i < first.n; i++) {
        const size_t j = first.n - 1 - i;
        swapped.pos[more.n + i] = first.pos[j];
        memcpy(swapped.val + (more.n + i) * C, first.val + j * C, sizeof(float) * C);
    }
    swapped.n = merged.n;
    memset(swapped.var, 0, sizeof swapped.var);
    memcpy(b, patched, sizeof b);
    csi_samples sw = {g, C, swapped.n, swapped.pos, swapped.val, 0, swapped.var};
    CHECK_OK(csi_refine_step_coverage(&sw, NULL, &ib, NULL));
    CHECK(memcmp(a, b, sizeof a) == 0, "the samples in another order give other bits");

    /* 3. without variances nothing moves */
    csi_samples fs_novar = fs, ms_novar = ms;
    fs_novar.variance = NULL, ms_novar.variance = NULL;
    memcpy(d, patched, sizeof d);
    csi_image id = {OW, OW, C, d};
    CHECK_OK(csi_refine_step_coverage(&fs_novar, &ms, &id, &moved));
    CHECK(moved == 0 && !memcmp(d, patched, sizeof d), "no variances of the first samples: %zu moved", moved);
    CHECK_OK(csi_refine_step_coverage(&fs, &ms_novar, &id, &moved));
    CHECK(moved == 0 && !memcmp(d, patched, sizeof d), "no variances of the more samples: %zu moved", moved);

    /* 4. refusals */
    first.var[5] = -1.0f;
    CHECK(csi_refine_step_coverage(&fs, &ms, &id, NULL) == CSI_ERR_ARG, "a negative variance not refused");
    first.var[5] = NAN;
    CHECK(csi_refine_step_coverage(&fs, &ms, &id, NULL) == CSI_ERR_ARG, "a NaN variance not refused");
    first.var[5] = 0.0f;
    CHECK(csi_refine_step_coverage(&fs, &ms, NULL, NULL) == CSI_ERR_ARG, "no image not refused");
    csi_samples other = ms;
    other.grid.w *= 2, other.grid.h *= 2;
    CHECK(csi_refine_step_coverage(&fs, &other, &id, NULL) == CSI_ERR_ARG, "more of another grid not refused");
    CHECK(!memcmp(d, patched, sizeof d), "a refused call changed the image");
    return test_done();
}
