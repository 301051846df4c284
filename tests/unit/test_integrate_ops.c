/* Integration kernels against plain C (double accumulation): box means, mean over t, each pixel's
 * variance over t, splat. */
#include <stdlib.h>
#include <string.h>

#include "csi/integrate_ops.h"
#include "testlib.h"

/* Tolerance: the kernels sum with Kahan compensation in float32 (error <= 2u|sum| + O(n u^2),
 * Higham Sec. 4.3, u = 2^-24) and divide once (u more). Relative to the mean of |x| over the
 * block that is at most ~3u = 1.8e-7; 1e-6 (about 5x that) leaves margin for the reference's
 * own rounding. The reference is a double sum. A wrong block, index or divisor is off by far
 * more. */
static int close_enough(const float *got, const double *want, const double *scale, size_t n, const char *what)
{
    int bad = 0;
    for (size_t i = 0; i < n; i++)
        if (!(fabs(got[i] - want[i]) <= 1e-6 * scale[i] + 1e-30)) {
            if (bad < 5)
                fprintf(stderr, "%s[%zu]: %.9g vs %.9g\n", what, i, got[i], want[i]);
            bad++;
        }
    return bad;
}

static int test_box(void)
{
    const uint32_t w = 24, h = 18, ch = 3, ow = 6, oh = 3; /* blocks 4 x 6 */
    const size_t n = (size_t)w * h * ch, on = (size_t)ow * oh * ch;
    float *x = malloc(n * sizeof *x), *got = malloc(on * sizeof *got);
    double *want = calloc(on, sizeof *want), *scale = calloc(on, sizeof *scale);
    test_rng r;
    test_rng_seed(&r, 1);
    for (size_t i = 0; i < n; i++) /* HDR: 1e-4 next to 1e4 */
        x[i] = (float)(test_rng_uniform(&r) * ((i % 7) == 0 ? 1e4 : 1e-4));
    for (uint32_t c = 0; c < ch; c++)
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t xx = 0; xx < w; xx++) {
                size_t o = ((size_t)c * oh + y / 6) * ow + xx / 4;
                want[o] += x[((size_t)c * h + y) * w + xx] / 24.0;
                scale[o] += fabs(x[((size_t)c * h + y) * w + xx]) / 24.0;
            }
    cl_mem dx = test_upload(x, n * sizeof *x), dy = test_alloc(on * sizeof *got);
    REQUIRE_OK(csi_box_integrate(test_ctx(), dx, w, h, ch, ow, oh, dy));
    test_download(dy, got, on * sizeof *got);
    CHECK(close_enough(got, want, scale, on, "box") == 0, "box integration matches the double reference");

    /* Identity when out = fine; a constant stays exact. */
    float *id = malloc(n * sizeof *id);
    cl_mem dz = test_alloc(n * sizeof *id);
    REQUIRE_OK(csi_box_integrate(test_ctx(), dx, w, h, ch, w, h, dz));
    test_download(dz, id, n * sizeof *id);
    CHECK(memcmp(id, x, n * sizeof *x) == 0, "1x1 blocks are the identity");

    /* Bad sizes and short buffers: clear errors. */
    csi_status st = csi_box_integrate(test_ctx(), dx, w, h, ch, 5, oh, dy);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "multiple"), "%s", csi_last_error());
    st = csi_box_integrate(test_ctx(), dy, w, h, ch, ow, oh, dx);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "needed"), "%s", csi_last_error());
    csi_buffer_release(&dx);
    csi_buffer_release(&dy);
    csi_buffer_release(&dz);
    free(x), free(got), free(want), free(scale), free(id);
    return 0;
}

static int test_time_mean(void)
{
    const uint32_t w = 10, h = 7, T = 33, ch = 2;
    const size_t plane = (size_t)w * h, n = plane * T * ch;
    float *v = malloc(n * sizeof *v), *got = malloc(plane * ch * sizeof *got);
    double *want = calloc(plane * ch, sizeof *want), *scale = calloc(plane * ch, sizeof *scale);
    test_rng r;
    test_rng_seed(&r, 2);
    for (size_t i = 0; i < n; i++)
        v[i] = (float)(test_rng_normal(&r) * ((i % 5) ? 1.0 : 1e3));
    for (uint32_t c = 0; c < ch; c++)
        for (uint32_t t = 0; t < T; t++)
            for (size_t p = 0; p < plane; p++) {
                want[c * plane + p] += v[((size_t)c * T + t) * plane + p] / T;
                scale[c * plane + p] += fabs(v[((size_t)c * T + t) * plane + p]) / T;
            }
    cl_mem dv = test_upload(v, n * sizeof *v), dm = test_alloc(plane * ch * sizeof *got);
    REQUIRE_OK(csi_time_mean(test_ctx(), dv, w, h, T, ch, dm));
    test_download(dm, got, plane * ch * sizeof *got);
    CHECK(close_enough(got, want, scale, plane * ch, "tmean") == 0, "mean over t matches the double reference");
    CHECK(csi_time_mean(test_ctx(), dv, w, h, 0, ch, dm) == CSI_ERR_ARG, "T = 0 refused");
    csi_buffer_release(&dv);
    csi_buffer_release(&dm);
    free(v), free(got), free(want), free(scale);
    return 0;
}

/* The variance over the first nt frames of each pixel's box mean. A mean far above the spread
 * (100 against 1, and 1e3 against 1e-2 in a third of the blocks) is where a one-pass sum of
 * squares would cancel. Tolerance: each box mean and the mean over t are within ~3u of the
 * block's mean |x| (the bound above), so each deviation is off by e <= ~6u of it; about the
 * exact mean a sum of squares gains e^2 (the cross term sums to zero) and per deviation 2|d|e;
 * rounding the squares and the compensated sum costs a few u of the result: 1e-6 of it plus
 * 1e-5 of its root times the mean |x| plus (1e-6 mean |x|)^2. Frames from nt on are 1e6:
 * counting one would put it far off, and so would a wrong block. */
static int test_box_time_var(void)
{
    const uint32_t w = 12, h = 8, T = 20, nt = 15, ow = 4, oh = 2; /* blocks 3 x 4 */
    const size_t plane = (size_t)w * h, n = plane * T, on = (size_t)ow * oh;
    float *v = malloc(n * sizeof *v), *got = malloc(on * sizeof *got);
    double *box = calloc(on * nt, sizeof *box), *want = calloc(on, sizeof *want), *scale = calloc(on, sizeof *scale);
    test_rng r;
    test_rng_seed(&r, 4);
    for (uint32_t t = 0; t < T; t++)
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                const bool big = (x / 3 + y / 4) % 3 == 0;
                v[t * plane + y * w + x] =
                    t >= nt ? 1e6f : (float)(big ? 1e3 + 1e-2 * test_rng_normal(&r) : 100 + test_rng_normal(&r));
            }
    for (uint32_t t = 0; t < nt; t++)
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++) {
                const size_t o = (y / 4) * ow + x / 3;
                box[o * nt + t] += v[t * plane + y * w + x] / 12.0;
                scale[o] += fabs(v[t * plane + y * w + x]) / (12.0 * nt);
            }
    for (size_t o = 0; o < on; o++) {
        double m = 0;
        for (uint32_t t = 0; t < nt; t++)
            m += box[o * nt + t] / nt;
        for (uint32_t t = 0; t < nt; t++)
            want[o] += (box[o * nt + t] - m) * (box[o * nt + t] - m) / nt;
    }
    cl_mem dv = test_upload(v, n * sizeof *v), dout = test_alloc(on * sizeof *got);
    REQUIRE_OK(csi_box_time_var(test_ctx(), dv, w, h, nt, ow, oh, dout));
    test_download(dout, got, on * sizeof *got);
    int bad = 0;
    for (size_t o = 0; o < on; o++)
        if (!(fabs(got[o] - want[o]) <= 1e-6 * want[o] + 1e-5 * sqrt(want[o]) * scale[o] + 1e-12 * scale[o] * scale[o])) {
            fprintf(stderr, "var[%zu]: %.9g vs %.9g\n", o, got[o], want[o]);
            bad++;
        }
    CHECK(bad == 0, "each pixel's variance over t matches the double two-pass reference");
    CHECK(csi_box_time_var(test_ctx(), dv, w, h, 0, ow, oh, dout) == CSI_ERR_ARG, "nt = 0 refused");
    CHECK(csi_box_time_var(test_ctx(), dv, w, h, nt, 5, oh, dout) == CSI_ERR_ARG, "12 not a multiple of 5 refused");
    csi_buffer_release(&dv);
    csi_buffer_release(&dout);
    free(v), free(got), free(box), free(want), free(scale);
    return 0;
}

static int test_splat(void)
{
    const csi_grid g = {16, 12, 4, 4, 3}; /* blocks 4 x 4, 4 frames */
    const uint32_t ch = 3;
    const size_t n = 100, P = 12;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *val = malloc(n * ch * sizeof *val), *got = malloc(P * ch * sizeof *got);
    double want[12 * 3] = {0}, scale[12 * 3] = {0};
    unsigned cnt[12] = {0};
    test_rng r;
    test_rng_seed(&r, 3);
    for (size_t i = 0; i < n; i++) {
        /* Pixels 5 and 11 get no samples; duplicates of a position are fine (each counts). */
        uint32_t px;
        do {
            pos[i] = (csi_sample_pos){(uint32_t)(test_rng_u64(&r) % 16), (uint32_t)(test_rng_u64(&r) % 12),
                                      (uint32_t)(test_rng_u64(&r) % 4)};
            px = (pos[i].y / 4) * 4 + pos[i].x / 4;
        } while (px == 5 || px == 11);
        cnt[px]++;
        for (uint32_t c = 0; c < ch; c++)
            val[i * ch + c] = (float)(test_rng_normal(&r) * 100.0);
    }
    for (size_t i = 0; i < n; i++) {
        uint32_t px = (pos[i].y / 4) * 4 + pos[i].x / 4;
        for (uint32_t c = 0; c < ch; c++) {
            want[c * P + px] += val[i * ch + c] / (double)cnt[px];
            scale[c * P + px] += fabs(val[i * ch + c]) / (double)cnt[px];
        }
    }
    cl_mem out = test_alloc(P * ch * sizeof *got);
    size_t empty = 99;
    REQUIRE_OK(csi_splat_mean(test_ctx(), &g, ch, pos, val, n, out, &empty));
    test_download(out, got, P * ch * sizeof *got);
    CHECK(empty == 2, "empty pixels %zu", empty);
    CHECK(close_enough(got, want, scale, P * ch, "splat") == 0, "per-pixel sample means");
    CHECK(got[5] == 0 && got[11] == 0 && got[P + 5] == 0, "empty pixels are zero");
    /* Deterministic: a second run gives the same bits. */
    float *again = malloc(P * ch * sizeof *again);
    REQUIRE_OK(csi_splat_mean(test_ctx(), &g, ch, pos, val, n, out, NULL));
    test_download(out, again, P * ch * sizeof *again);
    CHECK(memcmp(got, again, P * ch * sizeof *got) == 0, "same bits");
    pos[7].t = 4;
    CHECK(csi_splat_mean(test_ctx(), &g, ch, pos, val, n, out, NULL) == CSI_ERR_ARG &&
              strstr(csi_last_error(), "sample 7"), "%s", csi_last_error());
    csi_buffer_release(&out);
    free(pos), free(val), free(got), free(again);
    return 0;
}

int main(void)
{
    test_box();
    test_time_mean();
    test_box_time_var();
    test_splat();
    return test_done();
}
