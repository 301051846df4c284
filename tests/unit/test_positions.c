/* Sample positions: counts, uniqueness, bounds, stratification, Poisson-disk distance,
 * determinism, seeds, the PRNG against an independent implementation. No OpenCL. */
#include <stdlib.h>
#include <string.h>

#include "csi/positions.h"
#include "testlib.h"

static int sorted_unique_in_bounds(const csi_grid *g, const csi_sample_pos *p, size_t n)
{
    int bad = 0;
    for (size_t i = 0; i < n; i++) {
        if (p[i].x >= g->w || p[i].y >= g->h || p[i].t >= g->t)
            bad++;
        if (i && csi_grid_index(g, p[i - 1]) >= csi_grid_index(g, p[i]))
            bad++;
    }
    return bad;
}

static double min_dist(const csi_sample_pos *p, size_t n)
{
    double best = INFINITY;
    for (size_t i = 0; i < n; i++)
        for (size_t j = i + 1; j < n; j++) {
            double dx = (double)p[i].x - p[j].x, dy = (double)p[i].y - p[j].y, dt = (double)p[i].t - p[j].t;
            double d = sqrt(dx * dx + dy * dy + dt * dt);
            if (d < best)
                best = d;
        }
    return best;
}

/* Counts samples per (pixel, stratum) for the a x b x c split; every count must be exactly 1. */
static int check_strata(const csi_grid *g, const csi_sample_pos *p, size_t n, const uint32_t s[3], uint64_t spp)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h, bt = g->t;
    const size_t P = (size_t)g->out_w * g->out_h;
    unsigned *cnt = calloc(P * spp, sizeof *cnt);
    for (size_t i = 0; i < n; i++) {
        uint32_t px = p[i].x / bw, py = p[i].y / bh, lx = p[i].x % bw, ly = p[i].y % bh, lt = p[i].t;
        uint64_t st;
        if (s[0]) {
            /* stratum index along an axis: the i with floor(i*B/a) <= l < floor((i+1)*B/a) */
            uint32_t a = 0, b = 0, c = 0;
            while ((uint64_t)(a + 1) * bw / s[0] <= lx) a++;
            while ((uint64_t)(b + 1) * bh / s[1] <= ly) b++;
            while ((uint64_t)(c + 1) * bt / s[2] <= lt) c++;
            st = ((uint64_t)c * s[1] + b) * s[0] + a;
        } else {
            uint64_t cells = (uint64_t)bw * bh * bt, cell = ((uint64_t)lt * bh + ly) * bw + lx;
            st = 0;
            while ((st + 1) * cells / spp <= cell) st++;
        }
        cnt[((size_t)py * g->out_w + px) * spp + st]++;
    }
    int bad = 0;
    for (size_t i = 0; i < P * spp; i++)
        bad += cnt[i] != 1;
    free(cnt);
    return bad;
}

static int test_prng(void)
{
    /* splitmix64 of the first state increment for seed 0: the published first output
     * 0xe220a8397b1dcdaf (Vigna's splitmix64.c with x = 0). */
    CHECK(csi_mix64(UINT64_C(0x9e3779b97f4a7c15)) == UINT64_C(0xe220a8397b1dcdaf), "splitmix64");
    /* xoshiro256** seeded by splitmix64(12345): first outputs from an independent Python
     * implementation of the published algorithm. */
    const uint64_t want[4] = {UINT64_C(0xbe6a36374160d49b), UINT64_C(0x214aaa0637a688c6),
                              UINT64_C(0xf69d16de9954d388), UINT64_C(0x0c60048c4e96e033)};
    csi_rng r;
    csi_rng_seed(&r, 12345);
    for (int i = 0; i < 4; i++) {
        uint64_t v = csi_rng_next(&r);
        CHECK(v == want[i], "xoshiro256** output %d: %016llx", i, (unsigned long long)v);
    }
    int bad = 0;
    for (int i = 0; i < 10000; i++) {
        bad += csi_rng_below(&r, 7) >= 7;
        double u = csi_rng_uniform(&r);
        bad += !(u >= 0 && u < 1);
    }
    CHECK(bad == 0, "range");
    CHECK(csi_rng_below(&r, 1) == 0, "below(1)");
    return 0;
}

static int test_counts_and_errors(void)
{
    csi_grid g = {64, 48, 1, 16, 12};
    size_t n;
    csi_pos_opts o = {.method = CSI_POS_POISSON, .spp = 4};
    CHECK_OK(csi_positions_count(&g, &o, &n));
    CHECK(n == 4 * 16 * 12, "spp count %zu", n);
    o.fraction = 0.25;
    CHECK_OK(csi_positions_count(&g, &o, &n));
    CHECK(n == 768, "fraction count %zu", n);
    csi_grid g3 = {32, 32, 16, 8, 8};
    o = (csi_pos_opts){.method = CSI_POS_RANDOM, .spp = 1};
    CHECK_OK(csi_positions_count(&g3, &o, &n));
    CHECK(n == 64, "3-D spp is per pixel over all t: %zu", n);
    o = (csi_pos_opts){.method = CSI_POS_STRATIFIED, .fraction = 0.1};
    CHECK_OK(csi_positions_count(&g3, &o, &n));
    CHECK(n == 64 * 26, "stratified fraction: round(0.1 * 16384 / 64) = 26 per pixel: %zu", n);

    csi_sample_pos *p = NULL;
    o = (csi_pos_opts){.method = CSI_POS_POISSON, .spp = 17};
    csi_grid small = {8, 8, 1, 2, 2};
    csi_status st = csi_positions(&small, &o, &p, &n, NULL);
    CHECK(st == CSI_ERR_ARG && p == NULL && strstr(csi_last_error(), "only 64 cells"), "%s", csi_last_error());
    o.spp = 0;
    st = csi_positions(&small, &o, &p, &n, NULL);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "zero"), "%s", csi_last_error());
    o.spp = 1;
    o.fraction = 1.5;
    st = csi_positions(&small, &o, &p, &n, NULL);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "fraction"), "%s", csi_last_error());
    csi_grid nd = {10, 8, 1, 3, 2};
    o = (csi_pos_opts){.method = CSI_POS_RANDOM, .spp = 1};
    st = csi_positions(&nd, &o, &p, &n, NULL);
    CHECK(st == CSI_ERR_ARG && strstr(csi_last_error(), "multiple"), "%s", csi_last_error());
    csi_pos_method m;
    CHECK(csi_pos_method_parse("blue", &m) == CSI_ERR_ARG && strstr(csi_last_error(), "poisson"), "parse");
    CHECK_OK(csi_pos_method_parse("stratified", &m));
    CHECK(m == CSI_POS_STRATIFIED, "parse stratified");
    return 0;
}

static int test_methods_basic(void)
{
    const csi_grid grids[] = {{64, 48, 1, 16, 12}, {30, 20, 1, 5, 4}, {24, 24, 12, 6, 6}};
    const csi_pos_method methods[] = {CSI_POS_POISSON, CSI_POS_STRATIFIED, CSI_POS_RANDOM};
    for (int gi = 0; gi < 3; gi++)
        for (int mi = 0; mi < 3; mi++) {
            const csi_grid *g = &grids[gi];
            csi_pos_opts o = {.method = methods[mi], .spp = 4, .seed = 7};
            csi_sample_pos *p, *q;
            size_t n, n2;
            csi_pos_info info;
            REQUIRE_OK(csi_positions(g, &o, &p, &n, &info));
            CHECK(n == (size_t)4 * g->out_w * g->out_h && info.count == n, "count");
            CHECK(sorted_unique_in_bounds(g, p, n) == 0, "grid %d method %d: unique, sorted, in bounds", gi, mi);
            if (g->t == 1) {
                int nz = 0;
                for (size_t i = 0; i < n; i++)
                    nz += p[i].t != 0;
                CHECK(nz == 0, "t = 0 on a static grid");
            }
            /* Determinism: same seed, same bits; another seed, other positions. */
            REQUIRE_OK(csi_positions(g, &o, &q, &n2, NULL));
            CHECK(n2 == n && memcmp(p, q, n * sizeof *p) == 0, "grid %d method %d: deterministic", gi, mi);
            free(q);
            o.seed = 8;
            REQUIRE_OK(csi_positions(g, &o, &q, &n2, NULL));
            CHECK(n2 == n && memcmp(p, q, n * sizeof *p) != 0, "grid %d method %d: seeds differ", gi, mi);
            free(q);
            if (methods[mi] == CSI_POS_POISSON) {
                double d = min_dist(p, n);
                CHECK(d >= info.radius, "grid %d: min distance %g below promised %g", gi, d, info.radius);
                /* The promise is meaningful: at 4 spp on these grids the radius stays near the
                 * 0.7 r_max it starts from (at least 0.5 r_max). */
                CHECK(info.radius >= 0.5 * info.radius_max && info.radius > 1, "grid %d: radius %g vs r_max %g", gi,
                      info.radius, info.radius_max);
            }
            if (methods[mi] == CSI_POS_STRATIFIED)
                CHECK(check_strata(g, p, n, info.strata, 4) == 0, "grid %d: one sample per stratum (%u %u %u)", gi,
                      info.strata[0], info.strata[1], info.strata[2]);
            free(p);
        }
    return 0;
}

static int test_stratified_splits(void)
{
    struct { csi_grid g; uint32_t spp; uint32_t a, b, c; } cases[] = {
        {{32, 32, 1, 4, 4}, 4, 2, 2, 1},   /* square: sqrt x sqrt */
        {{32, 32, 1, 4, 4}, 16, 4, 4, 1},
        {{32, 16, 1, 4, 4}, 2, 2, 1, 1},   /* 8 x 4 block: split the long side */
        {{32, 32, 1, 4, 4}, 3, 1, 3, 1},   /* non-square spp: 1 x 3 and 3 x 1 tie; smallest a wins */
        {{16, 16, 32, 4, 4}, 4, 1, 1, 4},  /* 4 x 4 x 32 block: stratify time */
        {{16, 16, 4, 4, 4}, 8, 2, 2, 2},   /* 4 x 4 x 4: cubic strata */
        {{16, 16, 1, 4, 4}, 7, 0, 0, 0},   /* 7 does not factor into a 4 x 4 block: 1-D runs */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        csi_pos_opts o = {.method = CSI_POS_STRATIFIED, .spp = cases[i].spp, .seed = 3};
        csi_sample_pos *p;
        size_t n;
        csi_pos_info info;
        REQUIRE_OK(csi_positions(&cases[i].g, &o, &p, &n, &info));
        CHECK(info.strata[0] == cases[i].a && info.strata[1] == cases[i].b && info.strata[2] == cases[i].c,
              "case %zu: split %u %u %u", i, info.strata[0], info.strata[1], info.strata[2]);
        CHECK(sorted_unique_in_bounds(&cases[i].g, p, n) == 0, "case %zu: unique", i);
        CHECK(check_strata(&cases[i].g, p, n, info.strata, cases[i].spp) == 0, "case %zu: one per stratum", i);
        free(p);
    }
    return 0;
}

/* A volume's pixel of F x F cells split in t alone: every cell once before any twice, counted
 * per pixel (each cell's count floor(spp / F^2) or one more), one sample per time stratum. */
static int test_stratified_cells_dealt(void)
{
    struct { csi_grid g; uint32_t spp; } cases[] = {
        {{32, 32, 32, 16, 16}, 4},  /* 2 x 2 cells, 4 spp: each cell once */
        {{64, 64, 32, 16, 16}, 16}, /* 4 x 4, 16: each once */
        {{32, 32, 32, 16, 16}, 6},  /* 2 x 2, 6: two cells twice, two once */
        {{64, 64, 32, 16, 16}, 5},  /* 4 x 4, 5: five distinct cells */
        {{32, 32, 64, 16, 16}, 16}, /* 2 x 2, 16 over 64 frames: each cell 4 times */
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const csi_grid *g = &cases[i].g;
        const uint32_t bw = g->w / g->out_w, cells = bw * bw, spp = cases[i].spp;
        csi_pos_opts o = {.method = CSI_POS_STRATIFIED, .spp = spp, .seed = 11};
        csi_sample_pos *p;
        size_t n;
        csi_pos_info info;
        REQUIRE_OK(csi_positions(g, &o, &p, &n, &info));
        CHECK(info.strata[0] == 1 && info.strata[1] == 1 && info.strata[2] == spp, "case %zu: split in t alone (%u %u %u)",
              i, info.strata[0], info.strata[1], info.strata[2]);
        CHECK(check_strata(g, p, n, info.strata, spp) == 0, "case %zu: one per time stratum", i);
        uint32_t *count = calloc((size_t)g->out_w * g->out_h * cells, sizeof *count);
        if (!count) {
            CHECK(count != NULL, "case %zu: out of memory", i);
            free(p);
            return 1;
        }
        for (size_t k = 0; k < n; k++) {
            const uint32_t px = p[k].x / bw, py = p[k].y / bw;
            count[((size_t)py * g->out_w + px) * cells + (p[k].y % bw) * bw + p[k].x % bw]++;
        }
        int bad = 0;
        for (size_t pix = 0; pix < (size_t)g->out_w * g->out_h; pix++)
            for (uint32_t c = 0; c < cells; c++) {
                const uint32_t k = count[pix * cells + c];
                bad += k < spp / cells || k > (spp + cells - 1) / cells;
            }
        CHECK(bad == 0, "case %zu: %d cells of a pixel sampled unevenly", i, bad);
        free(count);
        free(p);
    }
    return 0;
}

static int test_poisson_cases(void)
{
    /* 3-D with a fraction, a dense case that ends in the uniform fill (radius 1), full grid. */
    struct { csi_grid g; double frac; uint32_t spp; } cases[] = {
        {{32, 32, 8, 8, 8}, 0.05, 0},
        {{40, 40, 1, 10, 10}, 0.6, 0},
        {{16, 16, 1, 4, 4}, 1.0, 0},
        {{64, 64, 1, 8, 8}, 0, 1},
        /* large radii (over 128 integer offsets inside r): the neighbour-cell accelerator path */
        {{128, 128, 1, 8, 8}, 0, 1},
        {{64, 64, 16, 8, 8}, 0, 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        csi_pos_opts o = {.method = CSI_POS_POISSON, .fraction = cases[i].frac, .spp = cases[i].spp, .seed = 11};
        csi_sample_pos *p;
        size_t n, want;
        csi_pos_info info;
        REQUIRE_OK(csi_positions_count(&cases[i].g, &o, &want));
        REQUIRE_OK(csi_positions(&cases[i].g, &o, &p, &n, &info));
        CHECK(n == want, "case %zu: count %zu of %zu", i, n, want);
        CHECK(sorted_unique_in_bounds(&cases[i].g, p, n) == 0, "case %zu: unique", i);
        double d = n > 1 ? min_dist(p, n) : INFINITY;
        CHECK(d >= info.radius && info.radius >= 1.0, "case %zu: min distance %g, promised %g", i, d, info.radius);
        if (cases[i].spp == 1)
            CHECK(info.radius >= 0.5 * info.radius_max, "case %zu: radius %g of r_max %g", i, info.radius,
                  info.radius_max);
        free(p);
    }
    return 0;
}

static int test_random_uniform(void)
{
    /* Inclusion frequency of each cell over many seeds: N/k expected. 4000 draws of 16 of 64
     * cells: each cell's count is Binomial(4000, 1/4) (mean 1000, sd 27.4); 6 sd bounds make a
     * false failure over 64 cells vanishingly unlikely (and the seeds are fixed anyway). */
    csi_grid g = {8, 8, 1, 2, 2}; /* 4 spp x 4 pixels = 16 of 64 cells */
    unsigned cnt[64] = {0};
    for (uint64_t s = 0; s < 4000; s++) {
        csi_pos_opts o = {.method = CSI_POS_RANDOM, .spp = 4, .seed = s};
        csi_sample_pos *p;
        size_t n;
        REQUIRE_OK(csi_positions(&g, &o, &p, &n, NULL));
        for (size_t i = 0; i < n; i++)
            cnt[csi_grid_index(&g, p[i])]++;
        free(p);
    }
    int bad = 0;
    for (int i = 0; i < 64; i++)
        bad += fabs((double)cnt[i] - 1000.0) > 6 * 27.4;
    CHECK(bad == 0, "%d cells with a biased inclusion frequency", bad);
    return 0;
}

/* csi_positions_with_progress: the same positions as csi_positions, reports that count up to
 * (N, N) for every method, and a cancel (at the first report, inside the Poisson-disk passes,
 * or at the last) that returns CSI_ERR_CANCELLED with nothing made. The Poisson case is large
 * enough (4 M cells) that its passes try more candidates than one report interval. */
static int test_progress(void)
{
    const csi_grid g = {2048, 2048, 1, 256, 256};
    for (int m = 0; m <= CSI_POS_RANDOM; m++) {
        csi_pos_opts o = {.method = (csi_pos_method)m, .spp = 4, .seed = 5};
        csi_sample_pos *p, *q;
        size_t n, n2;
        REQUIRE_OK(csi_positions(&g, &o, &p, &n, NULL));
        test_count_log l = {0};
        REQUIRE_OK(csi_positions_with_progress(&g, &o, &q, &n2, NULL, test_count_progress, &l));
        CHECK(n2 == n && memcmp(p, q, n * sizeof *p) == 0, "%s: progress changed the positions",
              csi_pos_method_name(o.method));
        CHECK(l.calls >= (o.method == CSI_POS_POISSON ? 2u : 1u) && !l.backwards, "%s: %zu reports, %d backwards",
              csi_pos_method_name(o.method), l.calls, l.backwards);
        CHECK(l.last_done == n && l.last_total == n, "%s: last report %llu of %llu, want %zu",
              csi_pos_method_name(o.method), (unsigned long long)l.last_done, (unsigned long long)l.last_total, n);
        const size_t stops[] = {1, l.calls};
        for (size_t k = 0; k < 2; k++) {
            test_count_log c = {.stop_at = stops[k]};
            csi_sample_pos dummy, *r = &dummy; /* must come back NULL */
            size_t nr = 7;
            csi_status st = csi_positions_with_progress(&g, &o, &r, &nr, NULL, test_count_progress, &c);
            CHECK(st == CSI_ERR_CANCELLED && r == NULL && nr == 0 && c.calls == stops[k],
                  "%s: cancel at report %zu: status %d, %zu reports", csi_pos_method_name(o.method), stops[k],
                  (int)st, c.calls);
        }
        free(p);
        free(q);
    }
    return 0;
}

/* The default grid rule, spelled out independently: static F = 4 for 1-3 spp, 8 for 4-15, 16
 * from 16 (smallest power of two >= 4 with F^2 > 4 spp, at most 16); moving, from one sample
 * per 8 frames (8 spp >= t) 2 up to 15 spp and 4 from 16, else 1, halved while a side would
 * pass 65536 cells; static halved (not below 4) while a side would. */
static int test_default_grid(void)
{
    const struct { uint64_t spp; uint32_t f; } rule[] = {{1, 4}, {3, 4}, {4, 8}, {15, 8}, {16, 16}, {64, 16}, {65536, 16}};
    for (size_t i = 0; i < sizeof rule / sizeof rule[0]; i++)
        CHECK(csi_default_grid_factor(128, 96, 1, rule[i].spp) == rule[i].f, "%llu spp: %u",
              (unsigned long long)rule[i].spp, csi_default_grid_factor(128, 96, 1, rule[i].spp));
    const struct { uint32_t t; uint64_t spp; uint32_t f; } moving[] = {
        {8, 1, 2}, {9, 1, 1}, {16, 1, 1}, {16, 2, 2}, {32, 3, 1}, {32, 4, 2}, {32, 8, 2}, {32, 9, 3}, {32, 12, 3},
        {32, 15, 3}, {32, 16, 4}, {32, 100, 4}, {64, 7, 1}, {64, 8, 2}, {64, 16, 4}, {128, 15, 1}, {2, 65536, 4}};
    for (size_t i = 0; i < sizeof moving / sizeof moving[0]; i++)
        CHECK(csi_default_grid_factor(128, 128, moving[i].t, moving[i].spp) == moving[i].f, "moving, %u frames, %llu spp: %u",
              moving[i].t, (unsigned long long)moving[i].spp, csi_default_grid_factor(128, 128, moving[i].t, moving[i].spp));
    /* the camera's motion: a moving one keeps 1, a panning or a still one the default */
    const struct { uint32_t t; uint64_t spp; csi_camera_motion cam; uint32_t f; } cams[] = {
        {32, 4, CSI_CAMERA_STILL, 2}, {32, 3, CSI_CAMERA_PANS, 1}, {32, 4, CSI_CAMERA_PANS, 2},
        {32, 12, CSI_CAMERA_PANS, 3}, {32, 16, CSI_CAMERA_PANS, 4}, {16, 9, CSI_CAMERA_PANS, 3},
        {32, 64, CSI_CAMERA_MOVES, 1}, {32, 3, CSI_CAMERA_STILL, 1}, {1, 16, CSI_CAMERA_MOVES, 16}};
    for (size_t i = 0; i < sizeof cams / sizeof cams[0]; i++)
        CHECK(csi_camera_grid_factor(128, 128, cams[i].t, cams[i].spp, cams[i].cam) == cams[i].f,
              "camera %d, %u frames, %llu spp: %u", (int)cams[i].cam, cams[i].t, (unsigned long long)cams[i].spp,
              csi_camera_grid_factor(128, 128, cams[i].t, cams[i].spp, cams[i].cam));
    CHECK(csi_default_grid_factor(16384, 64, 16, 16) == 4, "moving: 16384 * 4 = 65536 fits");
    CHECK(csi_default_grid_factor(16385, 64, 16, 16) == 3, "moving: 16385 * 4 > 65536: reduced to 3");
    CHECK(csi_default_grid_factor(21845, 64, 16, 9) == 3, "moving: 21845 * 3 = 65535 fits");
    CHECK(csi_default_grid_factor(21846, 64, 16, 9) == 2, "moving: 21846 * 3 > 65536: reduced to 2");
    CHECK(csi_default_grid_factor(32768, 64, 16, 16) == 2, "moving: 32768 * 2 = 65536 fits");
    CHECK(csi_default_grid_factor(64, 32769, 16, 16) == 1, "moving: 32769 * 2 > 65536: 1x");
    CHECK(csi_default_grid_factor(4096, 64, 1, 16) == 16, "4096 * 16 = 65536 fits");
    CHECK(csi_default_grid_factor(64, 4097, 1, 16) == 8, "4097 * 16 > 65536: halved to 8");
    CHECK(csi_default_grid_factor(20000, 64, 1, 16) == 4, "never below 4 (the caller refuses the size)");
    return 0;
}

int main(void)
{
    test_default_grid();
    test_prng();
    test_counts_and_errors();
    test_methods_basic();
    test_stratified_splits();
    test_stratified_cells_dealt();
    test_poisson_cases();
    test_random_uniform();
    test_progress();
    return test_done();
}
