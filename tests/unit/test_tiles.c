/* The tile layout (csi/tiles.h), checked against its definition by exhaustive enumeration:
 *   - cores partition every axis; windows lie inside the image, have the layout's length, and
 *     reach at least `margin` beyond the core on every interior side (or the image's edge);
 *   - window lengths are valid transform sizes: fine length 7-smooth and, for Alg. 1, a
 *     multiple of 2^levels; interior windows start on the coarse wavelet lattice;
 *   - the blend weights are a partition of unity: at every pixel (frame) of every axis they sum
 *     to 1 within 4 ulp of double (each weight is a product of two smooth steps, and 1 - S + S
 *     rounds at most twice), lie in [0, 1], vanish outside the window, and equal exactly 1 on a
 *     core outside the blend bands;
 *   - the plan: a problem that fits is one tile; a budget forces a tiling whose modelled tile
 *     fits it and whose windows cover the fewest cells among the layouts that fit, checked
 *     against a brute-force search over every (nx, ny) with the same model; N asked gives N;
 *     impossible requests are refused with a message naming the budget or the count;
 *   - an image whose side the FFT cannot take: no layout of its own grid leaves such a side
 *     whole; csi_tiling_layout then lays the tiles over the padded grid with the image's size. */
#include <stdlib.h>
#include <string.h>

#include "csi/tiles.h"
#include "testlib.h"

static bool smooth7(uint64_t v)
{
    static const unsigned p[] = {2, 3, 5, 7};
    for (int i = 0; i < 4; i++)
        while (v && v % p[i] == 0)
            v /= p[i];
    return v == 1;
}

/* The planner's price of a layout (csi/tiles.h), from its windows: the cells they cover in all
 * times 1 + CSI_TILE_T_LOSS per interior time boundary. */
static double layout_price(const csi_tiling *tl)
{
    const double cells = (double)tl->window[0] * (tl->grid.w / tl->grid.out_w) * tl->window[1] *
                         (tl->grid.h / tl->grid.out_h) * tl->window[2] * tl->count;
    return cells * (1.0 + CSI_TILE_T_LOSS * (tl->n[2] - 1));
}

static void check_layout(const csi_tiling *tl, const char *what)
{
    const uint32_t cells[3] = {tl->grid.w / tl->grid.out_w, tl->grid.h / tl->grid.out_h, 1};
    for (int a = 0; a < 3; a++) {
        const uint32_t L = tl->length[a];
        double *sum = calloc(L, sizeof *sum);
        uint32_t *owner = calloc(L, sizeof *owner);
        if (tl->n[a] > 1) {
            const uint64_t f = (uint64_t)tl->window[a] * cells[a];
            CHECK(smooth7(f), "%s: axis %d window %u x %u cells is not 7-smooth", what, a, tl->window[a], cells[a]);
            if (a < 2 && tl->levels > 0)
                CHECK(f % (1u << tl->levels) == 0, "%s: axis %d window %llu cells not a multiple of 2^%d", what, a,
                      (unsigned long long)f, tl->levels);
            CHECK(tl->window[a] < L, "%s: axis %d tiled with a window %u as long as the axis %u", what, a,
                  tl->window[a], L);
        } else {
            CHECK(tl->window[a] == L, "%s: axis %d untiled but window %u != %u", what, a, tl->window[a], L);
        }
        /* Tiles along this axis: walk tile coordinates through indices with the other axes at 0. */
        const uint32_t stride = a == 0 ? 1 : a == 1 ? tl->n[0] : tl->n[0] * tl->n[1];
        uint32_t covered = 0;
        for (uint32_t i = 0; i < tl->n[a]; i++) {
            csi_tile t;
            csi_tiling_tile(tl, i * stride, &t);
            CHECK(t.pos[a] == i, "%s: tile %u has coordinate %u along axis %d, expected %u", what, i * stride,
                  t.pos[a], a, i);
            CHECK(t.core0[a] == covered, "%s: axis %d core %u starts at %u, expected %u", what, a, i, t.core0[a], covered);
            CHECK(t.core1[a] > t.core0[a], "%s: axis %d core %u is empty", what, a, i);
            covered = t.core1[a];
            CHECK(t.win0[a] + tl->window[a] <= L, "%s: axis %d window %u leaves the image", what, a, i);
            if (i > 0) {
                CHECK(t.win0[a] == 0 || t.win0[a] + tl->margin[a] <= t.core0[a], "%s: axis %d window %u reaches only %u before its core",
                      what, a, i, t.core0[a] - t.win0[a]);
                if (a < 2 && tl->align[a] > 1 && t.win0[a] + tl->window[a] < L)
                    CHECK(t.win0[a] % tl->align[a] == 0, "%s: axis %d window %u starts at %u, off the %u lattice",
                          what, a, i, t.win0[a], tl->align[a]);
            }
            if (i + 1 < tl->n[a])
                CHECK(t.win0[a] + tl->window[a] == L || t.win0[a] + tl->window[a] >= t.core1[a] + tl->margin[a], "%s: axis %d window %u reaches "
                      "only %u beyond its core", what, a, i, t.win0[a] + tl->window[a] - t.core1[a]);
            for (uint32_t c = 0; c < L; c++) {
                const double w = csi_tile_weight(tl, &t, a, c);
                CHECK(w >= 0 && w <= 1, "%s: axis %d tile %u weight %g at %u", what, a, i, w, c);
                if (c < t.win0[a] || c >= t.win0[a] + tl->window[a])
                    CHECK(w == 0, "%s: axis %d tile %u weight %g outside its window at %u", what, a, i, w, c);
                const bool far = c >= t.core0[a] && c < t.core1[a] &&
                                 (i == 0 || c >= t.core0[a] + tl->band[a]) &&
                                 (i + 1 == tl->n[a] || c + tl->band[a] < t.core1[a]);
                if (far)
                    CHECK(w == 1, "%s: axis %d tile %u weight %.17g inside its core at %u", what, a, i, w, c);
                sum[c] += w;
                if (c >= t.core0[a] && c < t.core1[a])
                    owner[c]++;
            }
        }
        CHECK(covered == L, "%s: axis %d cores end at %u of %u", what, a, covered, L);
        for (uint32_t c = 0; c < L; c++) {
            CHECK(fabs(sum[c] - 1) <= 4 * 2.220446049250313e-16, "%s: axis %d weights sum to %.17g at %u", what, a,
                  sum[c], c);
            CHECK(owner[c] == 1, "%s: axis %d pixel %u is in %u cores", what, a, c, owner[c]);
        }
        free(sum);
        free(owner);
    }
}

int main(void)
{
    csi_recon_options o;
    csi_recon_defaults(&o);

    /* Layouts over image sizes, cell sizes, counts and margins (Alg. 1, 2-D). */
    const uint32_t outs[][2] = {{64, 64}, {128, 96}, {256, 256}, {250, 130}, {1920, 1080}, {3840, 2160}};
    const uint32_t factors[] = {4, 8, 16};
    const uint32_t counts[] = {2, 3, 4, 6, 9, 16};
    int laid = 0;
    for (size_t i = 0; i < sizeof outs / sizeof outs[0]; i++)
        for (size_t f = 0; f < sizeof factors / sizeof factors[0]; f++)
            for (size_t c = 0; c < sizeof counts / sizeof counts[0]; c++) {
                const csi_grid g = {outs[i][0] * factors[f], outs[i][1] * factors[f], 1, outs[i][0], outs[i][1]};
                if ((uint64_t)g.w > 65536 || (uint64_t)g.h > 65536)
                    continue;
                o.tiles = counts[c];
                o.tile_margin = 8;
                o.mem_budget = UINT64_C(1) << 50;
                csi_tiling tl;
                char what[96];
                snprintf(what, sizeof what, "%ux%u x%u, %u tiles", g.out_w, g.out_h, factors[f], counts[c]);
                if (csi_tiling_plan(NULL, &g, 3, (size_t)g.out_w * g.out_h * 4, &o, &tl) != CSI_OK) {
                    /* Only a small image may refuse, and with a message. */
                    CHECK(g.out_w * g.out_h <= 250 * 130, "%s refused: %s", what, csi_last_error());
                    CHECK(strstr(csi_last_error(), "cannot be laid out") != NULL, "%s: %s", what, csi_last_error());
                    continue;
                }
                CHECK(tl.count == counts[c] && tl.n[0] * tl.n[1] * tl.n[2] == tl.count, "%s: %u tiles (%ux%ux%u)",
                      what, tl.count, tl.n[0], tl.n[1], tl.n[2]);
                check_layout(&tl, what);
                laid++;
            }
    CHECK(laid >= 80, "only %d layouts were made", laid);

    /* Two tiles whose windows cannot hold both margins shorter than the image: 128 x 128 pixels
     * on an 8x grid with margins of 32 pixels. Each window reaches the image's edge on one side
     * and holds the margin on the other: 96 pixels along the split. */
    {
        const csi_grid g = {1024, 1024, 1, 128, 128};
        o.tiles = 2;
        o.tile_margin = 32;
        o.mem_budget = UINT64_C(1) << 50;
        csi_tiling tl;
        CHECK_OK(csi_tiling_plan(NULL, &g, 3, 128 * 128 * 4, &o, &tl));
        const int split = tl.n[0] == 2 ? 0 : 1;
        CHECK(tl.count == 2 && tl.n[split] == 2 && tl.window[split] == 96 && tl.window[1 - split] == 128,
              "2 tiles of 128 x 128 with 32-pixel margins: %ux%u tiles, windows %ux%u", tl.n[0], tl.n[1],
              tl.window[0], tl.window[1]);
        check_layout(&tl, "128x128 x8, 2 tiles, margins of 32");
    }

    /* Volumes: tiles along t too. */
    {
        const csi_grid g = {64, 48, 64, 64, 48};
        o.tiles = 4;
        o.tile_margin = 16;
        o.tile_margin_t = 4;
        csi_tiling tl;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl));
        /* 16-pixel margins in x/y, 4 frames in t: 4 windows of 24 frames cover fewer cells than
         * any x/y split, and their loss (3 boundaries) does not make up the difference */
        CHECK(tl.n[2] == 4 && tl.count == 4, "a 64x48x64 volume in 4 tiles with 16-pixel margins and 4-frame "
              "margins in t is split in t (n = %u %u %u)", tl.n[0], tl.n[1], tl.n[2]);
        check_layout(&tl, "volume 64x48x64, 4 tiles");
        o.tiles_t = 1;
        csi_tiling xy;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &xy));
        CHECK(xy.n[2] == 1 && xy.count == 4 && layout_price(&tl) < layout_price(&xy),
              "--tiles-t 1: x/y only (n = %u %u %u), priced above the windows (%.0f against %.0f)", xy.n[0], xy.n[1],
              xy.n[2], layout_price(&xy), layout_price(&tl));
        o.tiles_t = 0;
        o.tiles = 8;
        o.tiles_t = 2;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl));
        CHECK(tl.n[2] == 2 && tl.count == 8, "--tiles 8 --tiles-t 2: 2 time windows (n = %u %u %u)", tl.n[0],
              tl.n[1], tl.n[2]);
        check_layout(&tl, "volume 64x48x64, 8 tiles, 2 in t");
        o.tiles_t = 4;
        o.tiles = 0;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl));
        CHECK(tl.n[2] == 4 && tl.count == 4, "--tiles-t 4 alone: 4 windows although the whole fits (n = %u %u %u)",
              tl.n[0], tl.n[1], tl.n[2]);
        o.tiles = 6;
        CHECK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "not a multiple") != NULL,
              "6 tiles in 4 time windows are refused: %s", csi_last_error());
        o.tiles = 0;
        o.tiles_t = 65;
        CHECK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "frames") != NULL,
              "65 windows of 64 frames are refused: %s", csi_last_error());
        /* The default time margin: windows of at least 32 frames where the volume is longer, a
         * margin of at least a third of the core (and 4 frames). */
        {
            const csi_grid gv = {64, 48, 48, 64, 48};
            const uint32_t nts[] = {2, 4, 3, 12}, margins[] = {8, 10, 8, 14};
            csi_recon_options ov;
            csi_recon_defaults(&ov);
            for (int i = 0; i < 4; i++) {
                ov.tiles_t = nts[i];
                REQUIRE_OK(csi_tiling_plan(NULL, &gv, 1, 64 * 48 * 48 / 10, &ov, &tl));
                CHECK(tl.n[2] == nts[i] && tl.margin[2] == margins[i] && tl.window[2] < 48 &&
                          tl.window[2] >= (48 + nts[i] - 1) / nts[i] + 2 * margins[i],
                      "%u windows of 48 frames: margin %u (want %u), window %u", nts[i], tl.margin[2], margins[i],
                      tl.window[2]);
                check_layout(&tl, "48 frames in time windows");
            }
            const csi_grid g32 = {64, 48, 32, 64, 48};
            ov.tiles_t = 2;
            REQUIRE_OK(csi_tiling_plan(NULL, &g32, 1, 64 * 48 * 32 / 10, &ov, &tl));
            CHECK(tl.margin[2] == 7 && tl.window[2] < 32, "2 windows of 32 frames: margin %u (the longest that "
                  "fits), window %u", tl.margin[2], tl.window[2]);
            ov.tile_margin_t = 3;
            REQUIRE_OK(csi_tiling_plan(NULL, &g32, 1, 64 * 48 * 32 / 10, &ov, &tl));
            CHECK(tl.margin[2] == 3, "a given margin is kept (%u)", tl.margin[2]);
        }
        o.tiles_t = 2;
        o.tile_margin_t = 16;
        CHECK(csi_tiling_plan(NULL, &g, 1, 64 * 48 * 4, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "cannot be laid out on 64 frames") != NULL,
              "2 windows of 64 frames with 16-frame margins are refused: %s", csi_last_error());
        o.tile_margin_t = 4;
        /* The binned shutter (csi_tiling_bin_t): 256 frames in windows of 216, 108 and 54 frames
         * are binned 2, 4 and 8 frames a bin (86, 52, 43 and 37 bins are not FFT lengths), and
         * its plan counts the binned problem (a window's cells over fewer frames, the column's
         * samples) besides the window's. */
        {
            const csi_grid gl = {64, 64, 256, 64, 64};
            const uint32_t nts[] = {2, 4, 8}, wins[] = {216, 108, 54}, bins[] = {2, 4, 8};
            csi_recon_options ob;
            csi_recon_defaults(&ob);
            for (int i = 0; i < 3; i++) {
                ob.tiles_t = nts[i];
                ob.tile_image_binned = CSI_SWITCH_OFF;
                csi_tiling a, b;
                REQUIRE_OK(csi_tiling_plan(NULL, &gl, 3, 65536, &ob, &a));
                ob.tile_image_binned = CSI_SWITCH_ON;
                REQUIRE_OK(csi_tiling_plan(NULL, &gl, 3, 65536, &ob, &b));
                CHECK(a.window[2] == wins[i] && csi_tiling_bin_t(&a) == bins[i] && b.tile_bytes >= a.tile_bytes,
                      "%u windows of 256 frames: window %u (want %u), %u frames a bin (want %u), %llu bytes a "
                      "tile binned against %llu", nts[i], a.window[2], wins[i], csi_tiling_bin_t(&a), bins[i],
                      (unsigned long long)b.tile_bytes, (unsigned long long)a.tile_bytes);
            }
            csi_tiling one;
            ob.tiles_t = 1;
            REQUIRE_OK(csi_tiling_plan(NULL, &gl, 3, 65536, &ob, &one));
            CHECK(csi_tiling_bin_t(&one) == 1, "t not split: 1 frame a bin (%u)", csi_tiling_bin_t(&one));
        }
        const csi_grid img = {256, 256, 1, 64, 64};
        o.tiles_t = 2;
        CHECK(csi_tiling_plan(NULL, &img, 1, 4096, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "image") != NULL,
              "time windows of an image are refused: %s", csi_last_error());
        o.tiles_t = 0;
    }

    /* The budget's layouts of a volume: the lowest price (cells covered in all, times 1 +
     * CSI_TILE_T_LOSS per interior time boundary) among every layout that fits. Over budgets
     * from the whole's bytes down, the plan's layout is compared with each layout of 2-64 tiles
     * asked for explicitly (--tiles N, every factorisation with its own windows in t), priced
     * here from the layout's own windows. */
    {
        const csi_grid g = {96, 64, 48, 96, 64};
        const size_t n = (size_t)96 * 64 * 48 / 10;
        csi_recon_defaults(&o);
        csi_tiling whole, tl;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 1, n, &o, &whole));
        int split_t = 0, split_xy = 0;
        for (int b = 1; b <= 40; b++) {
            o.tiles = 0;
            o.tiles_t = 0;
            o.mem_budget = whole.whole_bytes * (uint64_t)(41 - b) / 41;
            if (csi_tiling_plan(NULL, &g, 1, n, &o, &tl) != CSI_OK)
                continue;
            const double p0 = layout_price(&tl);
            split_t += tl.n[2] > 1;
            split_xy += tl.n[0] * tl.n[1] > 1;
            for (uint32_t N = 2; N <= 64; N++)
                for (uint32_t nt = 1; nt <= N && nt <= g.t; nt++) {
                    if (N % nt)
                        continue;
                    o.tiles = N;
                    o.tiles_t = nt;
                    csi_tiling t2;
                    if (csi_tiling_plan(NULL, &g, 1, n, &o, &t2) != CSI_OK)
                        continue;
                    CHECK(p0 <= layout_price(&t2), "budget %llu: the plan's %ux%ux%u (price %.0f) where %ux%ux%u fits "
                          "at %.0f", (unsigned long long)o.mem_budget, tl.n[0], tl.n[1], tl.n[2], p0, t2.n[0], t2.n[1],
                          t2.n[2], layout_price(&t2));
                }
            o.tiles = 0;
            o.tiles_t = 0;
        }
        CHECK(split_xy > 0 && split_t > 0, "the budgets gave layouts split in x/y (%d) and in t (%d)", split_xy,
              split_t);
    }
    /* A long volume of small frames: time windows alone, not windows of x/y tiles (the planner
     * before this rule gave billiards 64x64 x 256 at 16 MiB 96 tiles covering 25x the cells). */
    {
        const csi_grid g = {64, 64, 256, 64, 64};
        csi_recon_defaults(&o);
        o.mem_budget = UINT64_C(16) << 20;
        csi_tiling tl;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 3, 65536, &o, &tl));
        CHECK(tl.n[0] == 1 && tl.n[1] == 1 && tl.n[2] > 1, "64x64x256 at 16 MiB: %ux%ux%u tiles", tl.n[0], tl.n[1],
              tl.n[2]);
        check_layout(&tl, "64x64x256 at 16 MiB");
    }

    /* The plan from a budget. */
    {
        const csi_grid g = {2048, 2048, 1, 256, 256};
        csi_recon_defaults(&o);
        csi_tiling whole, tl;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &whole));
        CHECK(whole.count == 1, "a 2048^2 grid fits the 1 GiB default (%u tiles, %llu bytes)", whole.count,
              (unsigned long long)whole.whole_bytes);
        o.mem_budget = whole.whole_bytes / 3;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &tl));
        CHECK(tl.count > 1 && tl.tile_bytes <= o.mem_budget, "budget %llu: %u tiles of %llu bytes",
              (unsigned long long)o.mem_budget, tl.count, (unsigned long long)tl.tile_bytes);
        check_layout(&tl, "2048^2 under a third of its bytes");
        /* No layout with the same model that fits covers fewer cells (brute force over N). */
        const uint64_t work = (uint64_t)tl.count * tl.window[0] * tl.window[1];
        for (uint32_t N = 2; N <= 64; N++) {
            csi_recon_options q = o;
            q.tiles = N;
            csi_tiling t2;
            if (csi_tiling_plan(NULL, &g, 3, 262144, &q, &t2) != CSI_OK)
                continue;
            CHECK((uint64_t)t2.count * t2.window[0] * t2.window[1] >= work, "%u tiles cover %llu cells, the "
                  "plan's %u cover %llu", N, (unsigned long long)t2.count * t2.window[0] * t2.window[1] * 64,
                  tl.count, (unsigned long long)work * 64);
        }
        o.mem_budget = 1u << 20;
        CHECK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "1048576") != NULL,
              "a 1 MiB budget is refused naming it: %s", csi_last_error());
        csi_recon_defaults(&o);
        o.tiles = 1u << 20;
        CHECK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &tl) == CSI_ERR_ARG &&
                  strstr(csi_last_error(), "cannot be laid out") != NULL,
              "2^20 tiles on 256^2 pixels are refused: %s", csi_last_error());
        /* Same inputs, same layout. */
        o.tiles = 6;
        csi_tiling a, b;
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &a));
        REQUIRE_OK(csi_tiling_plan(NULL, &g, 3, 262144, &o, &b));
        CHECK(csi_tiling_equal(&a, &b) && !memcmp(&a, &b, sizeof a), "the layout is deterministic");
    }
    /* A side the FFT cannot take: 37 x 23 pixels of 4 x 4 cells (148 = 4 * 37, 92 = 4 * 23). A
     * layout of the image's own grid must take every side: in 2 tiles one side stays whole, so
     * there is none, and csi_tiling_layout lays the 2 tiles over the padded grid (40 x 24 pixels),
     * cut back to 37 x 23; 4 tiles (2 x 2) keep the image's own grid; by default the padded
     * whole fits, one tile. */
    {
        const csi_grid g = {148, 92, 1, 37, 23};
        const size_t n = 37 * 23 * 4;
        csi_recon_defaults(&o);
        o.tile_margin = 4;
        o.tiles = 2;
        csi_tiling tl;
        CHECK(csi_tiling_plan(NULL, &g, 1, n, &o, &tl) == CSI_ERR_ARG,
              "2 tiles of the 37x23 image's own grid (one side of 92 cells whole) are refused");
        REQUIRE_OK(csi_tiling_layout(NULL, &g, 1, n, &o, &tl));
        CHECK(tl.count == 2 && tl.grid.out_w == 40 && tl.grid.out_h == 24 && tl.grid.w == 160 && tl.grid.h == 96 &&
                  tl.image_w == 37 && tl.image_h == 23 && !csi_tiling_check(&tl),
              "2 tiles of 37x23: %u over %ux%u (%ux%u cells), image %ux%u", tl.count, tl.grid.out_w, tl.grid.out_h,
              tl.grid.w, tl.grid.h, tl.image_w, tl.image_h);
        check_layout(&tl, "2 tiles of the padded 37x23 image");
        const csi_grid own = csi_tiling_image_grid(&tl);
        CHECK(!memcmp(&own, &g, sizeof g), "the image's own grid from the padded layout: %ux%u -> %ux%u", own.w,
              own.h, own.out_w, own.out_h);
        o.tiles = 4;
        REQUIRE_OK(csi_tiling_layout(NULL, &g, 1, n, &o, &tl));
        CHECK(tl.count == 4 && tl.n[0] == 2 && tl.n[1] == 2 && !memcmp(&tl.grid, &g, sizeof g) && tl.image_w == 37 &&
                  tl.image_h == 23,
              "4 tiles of 37x23: %ux%u over %ux%u", tl.n[0], tl.n[1], tl.grid.out_w, tl.grid.out_h);
        check_layout(&tl, "2x2 tiles of the 37x23 image's own grid");
        o.tiles = 0;
        REQUIRE_OK(csi_tiling_layout(NULL, &g, 1, n, &o, &tl));
        CHECK(tl.count == 1 && tl.grid.out_w == 40 && tl.grid.out_h == 24 && tl.image_w == 37 && tl.image_h == 23,
              "37x23 by default: %u tiles over %ux%u", tl.count, tl.grid.out_w, tl.grid.out_h);
        tl.image_w = 41;
        CHECK(csi_tiling_check(&tl) != NULL, "an image wider than its layout's grid is not a layout csi makes");
    }
    /* The sample mean never tiles. */
    {
        const csi_grid g = {4096, 4096, 1, 1024, 1024};
        csi_recon_defaults(&o);
        o.estimator = CSI_EST_MEAN;
        o.mem_budget = 1u << 20;
        csi_tiling tl;
        CHECK_OK(csi_tiling_plan(NULL, &g, 3, 4u << 20, &o, &tl));
        CHECK(tl.count == 1, "the sample mean is one tile (%u)", tl.count);
    }
    return test_done();
}
