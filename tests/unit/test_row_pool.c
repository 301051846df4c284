/* The host's passes in bands of rows on a pool of threads (csi/row_pool.h) give the bits of the
 * same passes on the calling thread alone.
 *
 *   1. The pool covers every row of a pass exactly once, at widths that make one chunk of many
 *      rows, several, and one row a chunk, on 2, 3 and 4 threads, pass after pass.
 *   2. The blend (and with --blend-spread its spread test), the fit's trust, the peaks against
 *      their noise and the empty pixels on images of odd sizes (97 x 61 pixels of 4 x 4 cells,
 *      2111 x 7 pixels of 3 x 2 cells: a band of one row, divisions that are not shifts), at
 *      about 4 samples per pixel and about 1 (the blend's two noise estimates, pixels without a
 *      sample, the fit's trust at work), HDR values with exact zeros: every output on 2, 3 and 4
 *      threads has the bits of the output without a pool (one call over all rows). A pass that
 *      read what another band of the same pass writes, or a band that took another's samples,
 *      would differ.
 *   3. The same with the samples shuffled (not in row order: the passes over the samples fall
 *      back to the calling thread): again the bits without a pool. */
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "csi/empty_pixels.h"
#include "csi/peak_noise.h"
#include "csi/row_pool.h"
#include "../../host/integrate/internal.h"
#include "testlib.h"

/* ---- 1. rows covered once ---- */

typedef struct {
    atomic_int *seen;
} cover;

static void mark_rows(void *arg, size_t r0, size_t r1)
{
    cover *c = arg;
    for (size_t r = r0; r < r1; r++)
        atomic_fetch_add(&c->seen[r], 1);
}

static void check_cover(csi_row_pool *pool, size_t rows, size_t width)
{
    atomic_int *seen = calloc(rows, sizeof *seen);
    cover c = {seen};
    for (int pass = 0; pass < 3; pass++) {
        for (size_t r = 0; r < rows; r++)
            atomic_store(&seen[r], 0);
        csi_row_pool_run(pool, rows, width, mark_rows, &c);
        size_t bad = 0;
        for (size_t r = 0; r < rows; r++)
            bad += atomic_load(&seen[r]) != 1;
        CHECK(bad == 0, "%d threads, %zu rows of %zu: %zu rows not visited once (pass %d)",
              csi_row_pool_threads(pool), rows, width, bad, pass);
    }
    free(seen);
}

/* ---- 2, 3. the passes ---- */

enum { C = 3 };

typedef struct {
    csi_grid g;
    size_t n;
    csi_sample_pos *pos;
    float *val, *var, *fine, *box;
} problem;

/* Samples at each cell with probability `frac`, in grid order (or shuffled); HDR values (a
 * log-normal, one in 50 a thousand times brighter, one in 20 exactly 0), a fine estimate that
 * misses them by 30%, a box integral of its own. */
static void make(problem *pr, uint32_t ow, uint32_t oh, uint32_t bw, uint32_t bh, double frac, bool shuffle,
                 uint64_t seed)
{
    test_rng r;
    test_rng_seed(&r, seed);
    pr->g = (csi_grid){ow * bw, oh * bh, 1, ow, oh};
    const size_t cells = (size_t)pr->g.w * pr->g.h, np = (size_t)ow * oh;
    pr->pos = malloc(cells * sizeof *pr->pos);
    pr->val = malloc(cells * C * sizeof *pr->val), pr->var = malloc(cells * C * sizeof *pr->var);
    pr->fine = malloc(cells * C * sizeof *pr->fine), pr->box = malloc(np * C * sizeof *pr->box);
    size_t n = 0;
    for (uint32_t y = 0; y < pr->g.h; y++)
        for (uint32_t x = 0; x < pr->g.w; x++) {
            if (test_rng_uniform(&r) >= frac)
                continue;
            pr->pos[n] = (csi_sample_pos){x, y, 0};
            for (int c = 0; c < C; c++) {
                double v = exp(1.5 * test_rng_normal(&r));
                if (test_rng_uniform(&r) < 0.02)
                    v *= 1000;
                if (test_rng_uniform(&r) < 0.05)
                    v = 0;
                pr->val[n * C + c] = (float)v;
                pr->var[n * C + c] = (float)(v * v * test_rng_uniform(&r));
                pr->fine[n * C + c] = (float)(v * (1 + 0.3 * test_rng_normal(&r)));
            }
            n++;
        }
    pr->n = n;
    if (shuffle)
        for (size_t i = n; i > 1; i--) {
            const size_t j = (size_t)(test_rng_u64(&r) % i);
            csi_sample_pos tp = pr->pos[i - 1];
            pr->pos[i - 1] = pr->pos[j], pr->pos[j] = tp;
            for (int c = 0; c < C; c++) {
                float *arrs[3] = {pr->val, pr->var, pr->fine};
                for (int a = 0; a < 3; a++) {
                    float t = arrs[a][(i - 1) * C + c];
                    arrs[a][(i - 1) * C + c] = arrs[a][j * C + c], arrs[a][j * C + c] = t;
                }
            }
        }
    for (size_t p = 0; p < np * C; p++)
        pr->box[p] = (float)exp(test_rng_normal(&r));
}

static void release(problem *pr)
{
    free(pr->pos), free(pr->val), free(pr->var), free(pr->fine), free(pr->box);
}

/* Every pass on pool, in the order a reconstruction runs them: per channel the blend (with its
 * spread test when `spread`) and the fit's trust, then the empty pixels and the peaks on the
 * whole image. out: the image (np x C). */
static void run(const problem *pr, csi_row_pool *pool, bool spread, float *out, size_t *changed)
{
    const size_t np = (size_t)pr->g.out_w * pr->g.out_h;
    csi_recon_options opt;
    csi_recon_defaults(&opt);
    if (spread) {
        opt.blend_spread = CSI_SWITCH_ON;
        opt.sample_variance = pr->var;
    }
    float *fine_c = malloc((pr->n ? pr->n : 1) * sizeof *fine_c);
    memcpy(out, pr->box, np * C * sizeof *out);
    for (uint32_t c = 0; c < C; c++) {
        for (size_t i = 0; i < pr->n; i++)
            fine_c[i] = pr->fine[i * C + c];
        float *plane = out + (size_t)c * np;
        CHECK_OK(csi_recon_blend(&pr->g, &opt, pr->val, C, c, pr->pos, fine_c, pr->n, true, pool, plane, NULL));
        CHECK_OK(csi_recon_fit_trust(&pr->g, pr->val, C, c, pr->pos, fine_c, pr->n, opt.cv_n0,
                                     pr->box + (size_t)c * np, pool, plane));
    }
    CHECK_OK(csi_empty_pixels(&pr->g, C, pr->pos, pr->val, pr->n, pool, out));
    CHECK_OK(csi_peak_noise(&pr->g, C, pr->pos, pr->val, pr->var, pr->n, pool, out, changed));
    free(fine_c);
}

static void check_same_bits(const char *what, const problem *pr, csi_row_pool *const *pools, int npools)
{
    const size_t np = (size_t)pr->g.out_w * pr->g.out_h;
    float *ref = malloc(np * C * sizeof *ref), *got = malloc(np * C * sizeof *got);
    for (int spread = 0; spread < 2; spread++) {
        size_t ref_changed = 0, changed = 0;
        run(pr, NULL, spread, ref, &ref_changed);
        /* the problem is one where the passes have something to do */
        size_t moved = 0;
        for (size_t p = 0; p < np * C; p++)
            moved += ref[p] != pr->box[p];
        CHECK(moved > np * C / 2, "%s: the passes moved only %zu of %zu values", what, moved, np * C);
        for (int k = 0; k < npools; k++) {
            run(pr, pools[k], spread, got, &changed);
            size_t diff = 0;
            for (size_t p = 0; p < np * C; p++)
                diff += memcmp(&ref[p], &got[p], sizeof *ref) != 0;
            CHECK(diff == 0 && changed == ref_changed,
                  "%s, spread %d, %d threads: %zu of %zu values differ from one thread's, peaks set %zu vs %zu",
                  what, spread, csi_row_pool_threads(pools[k]), diff, np * C, changed, ref_changed);
        }
    }
    free(ref), free(got);
}

int main(void)
{
    csi_row_pool *pools[3];
    for (int k = 0; k < 3; k++) {
        pools[k] = csi_row_pool_new(k + 2);
        REQUIRE_OK(pools[k] ? CSI_OK : CSI_ERR_NOMEM);
        CHECK(csi_row_pool_threads(pools[k]) == k + 2, "a pool of %d threads has %d", k + 2,
              csi_row_pool_threads(pools[k]));
    }
    CHECK(csi_row_pool_new(1) == NULL && csi_row_pool_threads(NULL) == 1, "one thread: no pool");

    for (int k = 0; k < 3; k++) {
        check_cover(pools[k], 61, 97);   /* 3 chunks */
        check_cover(pools[k], 7, 2111);  /* a row each */
        check_cover(pools[k], 5, 16);    /* one chunk */
        check_cover(pools[k], 1000, 3);  /* many */
    }

    const struct {
        uint32_t ow, oh, bw, bh;
        double frac;
        const char *what;
    } cases[] = {
        {97, 61, 4, 4, 0.25, "97 x 61, 4 x 4 cells, 4 spp"},
        {97, 61, 4, 4, 1.0 / 16, "97 x 61, 4 x 4 cells, 1 spp"},
        {2111, 7, 3, 2, 0.6, "2111 x 7, 3 x 2 cells, 3.6 spp"},
        {2111, 7, 3, 2, 1.0 / 6, "2111 x 7, 3 x 2 cells, 1 spp"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++)
        for (int shuffle = 0; shuffle < 2; shuffle++) {
            problem pr;
            make(&pr, cases[i].ow, cases[i].oh, cases[i].bw, cases[i].bh, cases[i].frac, shuffle, 7 + i);
            char what[160];
            snprintf(what, sizeof what, "%s%s", cases[i].what, shuffle ? ", shuffled" : "");
            check_same_bits(what, &pr, pools, 3);
            release(&pr);
        }
    for (int k = 0; k < 3; k++)
        csi_row_pool_free(pools[k]);
    return test_done();
}
