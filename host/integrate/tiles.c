/* The tile layout: how a problem is split into overlapping tiles, each tile's core and window,
 * and the blend weights (csi/tiles.h). Pure geometry and arithmetic: no device work here. */
#include "csi/tiles.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/wavelet.h"
#include "internal.h"

/* Default overlap. Alg. 1: the filter length times 2^levels fine-grid cells (256 with db4 and
 * the default 5 levels), at least 4 pixels: more than the support of the coarsest wavelet
 * ((taps - 1) 2^levels cells). At 128 cells the tiled MSE on checkerboard at 16 spp (16x grid, 4
 * tiles) was 2.7% above the untiled one's, at 256 cells 1.5%, at 384 1.1% (docs/bench/scale.md).
 * Volumes: 16 pixels (the moving train in 2 and 4 tiles along x: 1.1% and 0.7% below untiled,
 * same page). Time windows: the window (core and margins) spans at least 32 frames where the
 * volume is longer, and the margin is at least a third of the core and 4 frames. A window's
 * Fourier model in t fits only its own stretch of the motion, so its length counts, not a fixed
 * margin: on the 48-frame disc of docs/bench/scale.md, 4 windows of 20 frames lost 17-25% against
 * the whole, of 32 frames -4% to +7% (mean 0%); 2 windows of 32 frames lost up to 7%, of 40
 * frames none. */
#define TILE_MARGIN_MIN_PX 4u
#define TILE_MARGIN_MOTION_PX 16u
#define TILE_MARGIN_MOTION_T 4u
#define TILE_MARGIN_T_CORE_DIV 3u
#define TILE_WINDOW_T_MIN 32u

/* The default margin of n time windows over L frames (the longest core's). */
static uint32_t margin_t_auto(uint32_t L, uint32_t n)
{
    const uint32_t core = (L + n - 1) / n;
    uint32_t m = (core + TILE_MARGIN_T_CORE_DIV - 1) / TILE_MARGIN_T_CORE_DIV;
    if (core < TILE_WINDOW_T_MIN && m < (TILE_WINDOW_T_MIN - core + 1) / 2)
        m = (TILE_WINDOW_T_MIN - core + 1) / 2;
    const uint32_t cap = L > core + 1 ? (L - 1 - core) / 2 : 0; /* a window shorter than the volume */
    if (m > cap)
        m = cap;
    return m > TILE_MARGIN_MOTION_T ? m : TILE_MARGIN_MOTION_T;
}

/* Headroom on a tile's samples: a tile holds about its share of the samples when they are
 * spread evenly (Poisson-disk, stratified or uniform positions). */
#define TILE_SAMPLE_HEADROOM 1.25

uint64_t csi_tile_default_budget(const csi_ctx *ctx)
{
    uint64_t b = CSI_TILE_DEFAULT_BUDGET;
    if (ctx) {
        uint64_t half = csi_ctx_global_mem(ctx) / 2;
        if (half && half < b)
            b = half;
    }
    return b;
}

typedef enum { M_AA, M_MOTION, M_GAUSS, M_MEAN } tile_method;

static tile_method method_of(const csi_grid *g, const csi_recon_options *opt)
{
    if (opt->estimator == CSI_EST_MEAN)
        return M_MEAN;
    if (opt->estimator == CSI_EST_GAUSS)
        return M_GAUSS;
    return g->t > 1 ? M_MOTION : M_AA;
}


/* What one axis needs of a window length E (pixels or frames): E * cells is 7-smooth (FFT
 * radices) and a multiple of `multiple` (2^levels for the wavelets, 2 for an even first axis). */
typedef struct {
    uint32_t length, cells, multiple, align, margin;
} axis_req;

static bool len_ok(const axis_req *a, uint32_t e)
{
    uint64_t f = (uint64_t)e * a->cells;
    return csi_smooth7(f) && f % a->multiple == 0;
}

static uint32_t core_bound(uint32_t L, uint32_t n, uint32_t align, uint32_t i)
{
    if (i == 0)
        return 0;
    if (i >= n)
        return L;
    return align * (uint32_t)((uint64_t)i * (L / align) / n);
}

static uint32_t win_start(uint32_t L, uint32_t n, uint32_t align, uint32_t e, uint32_t i)
{
    if (n == 1)
        return 0;
    const uint32_t b0 = core_bound(L, n, align, i), b1 = core_bound(L, n, align, i + 1);
    int64_t s = (int64_t)b0 - ((int64_t)e - (int64_t)(b1 - b0)) / 2;
    if (s > 0)
        s -= s % align; /* on the coarse wavelet lattice where the edges allow */
    if (s < 0)
        s = 0;
    if (s > (int64_t)L - e)
        s = (int64_t)L - e;
    return (uint32_t)s;
}

/* The shortest valid window length from `from` up to the axis's that gives each of n cores its
 * margin on both sides (up to the image's edge where that is nearer); 0 if none. */
static uint32_t covering_window(const axis_req *a, uint32_t n, uint64_t from)
{
    const uint32_t L = a->length;
    for (uint64_t e = from; e < L; e++) {
        if (!len_ok(a, (uint32_t)e))
            continue;
        bool covers = true;
        for (uint32_t i = 0; i < n && covers; i++) {
            const uint32_t s = win_start(L, n, a->align, (uint32_t)e, i);
            const uint32_t b0 = core_bound(L, n, a->align, i), b1 = core_bound(L, n, a->align, i + 1);
            /* margin beyond the core, or up to the image's edge when that is nearer */
            covers = (i == 0 || s == 0 || s + a->margin <= b0) &&
                     (i == n - 1 || s + e == L || s + e >= (uint64_t)b1 + a->margin);
        }
        if (covers)
            return (uint32_t)e;
    }
    return 0;
}

/* The window length for n tiles along an axis (0 when n tiles cannot be laid out: cores under
 * one alignment unit, or no valid length shorter than the axis). Windows are searched from the
 * core and two margins; where none is shorter than the axis and `edge_margin` (the image's x and
 * y), from the core and one margin: two tiles' windows each reach the image's edge on one side
 * and need the margin only on the other (128 pixels in two tiles with margins of 32: windows of
 * 96). Time windows keep the search from two margins: from one, two windows of a 16-frame volume
 * lost too much and too unevenly against the whole (docs/bench/scale.md, session 30). */
static uint32_t axis_window(const axis_req *a, uint32_t n, bool edge_margin)
{
    const uint32_t L = a->length;
    if (n == 1)
        return L;
    if (L / a->align < n)
        return 0;
    uint32_t core = 0;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t c = core_bound(L, n, a->align, i + 1) - core_bound(L, n, a->align, i);
        if (c == 0)
            return 0;
        if (c > core)
            core = c;
    }
    const uint32_t e = covering_window(a, n, (uint64_t)core + 2ull * a->margin);
    return e || !edge_margin ? e : covering_window(a, n, (uint64_t)core + a->margin);
}

static uint32_t min_core(uint32_t L, uint32_t n, uint32_t align)
{
    uint32_t m = L;
    for (uint32_t i = 0; i < n; i++) {
        uint32_t c = core_bound(L, n, align, i + 1) - core_bound(L, n, align, i);
        if (c < m)
            m = c;
    }
    return m;
}

typedef struct {
    tile_method m;
    axis_req ax[3];
    bool auto_margin_t; /* ax[2].margin follows the number of windows (margin_t_auto) */
    uint64_t k, n;
    uint32_t bw, bh, channels;
    int levels;
    csi_tile_scope scope; /* the whole's sizes, which a tile's defaults follow */
    const csi_ctx *ctx;   /* the device the tiles will run on (NULL: unknown), for their plans */
} plan_ctx;

typedef struct {
    uint32_t n[3], window[3];
    uint64_t bytes, largest, work, samples;
    bool rows_unfused; /* the windows' FFT rows run pass by pass (CSI_TILE_UNFUSED_COST) */
} candidate;

/* The layout of n[] tiles, and one tile's bytes: its resource plan (csi/plan.h) with its share
 * of the samples. false when the layout cannot be made or the tile's problem is refused. */
static bool evaluate(const plan_ctx *p, const csi_recon_options *opt, const uint32_t n[3], candidate *c)
{
    for (int a = 0; a < 3; a++) {
        axis_req ax = p->ax[a];
        if (a == 2 && p->auto_margin_t)
            ax.margin = margin_t_auto(ax.length, n[2]);
        c->n[a] = n[a];
        c->window[a] = axis_window(&ax, n[a], a < 2);
        if (!c->window[a])
            return false;
    }
    const uint64_t cells = (uint64_t)c->window[0] * p->bw * c->window[1] * p->bh * c->window[2];
    const uint32_t count = n[0] * n[1] * n[2];
    /* A tile's window along an axis not split is the whole axis, which its transforms must take
     * as well (the whole alone is judged by its own plan below): an image whose side the FFT
     * cannot take is tiled along that side or solved padded (csi_tiling_layout). */
    for (int a = 0; a < 3 && count > 1; a++)
        if (n[a] == 1 && !len_ok(&p->ax[a], c->window[a]))
            return false;
    uint64_t ns = p->n;
    if (count > 1) {
        double share = ceil(TILE_SAMPLE_HEADROOM * (double)p->n * (double)cells / (double)p->k);
        ns = share < (double)cells ? (uint64_t)share : cells;
        if (ns > p->n)
            ns = p->n;
    }
    const csi_grid tg = {.w = c->window[0] * p->bw, .h = c->window[1] * p->bh, .t = c->window[2],
                         .out_w = c->window[0], .out_h = c->window[1]};
    csi_recon_options to = *opt;
    if (p->m == M_AA && p->levels > 0)
        to.levels = p->levels;
    to.frames = opt->frames || n[2] > 1; /* a time window keeps its frames for its share */
    to.tiles = 0;
    csi_recon_plan plan;
    if (csi_recon_plan_whole(p->ctx, &tg, p->channels, (size_t)ns, &to, count > 1 ? &p->scope : NULL, &plan) != CSI_OK)
        return false;
    c->bytes = plan.device_bytes;
    c->largest = plan.largest_buffer;
    c->rows_unfused = plan.rows_unfused;
    if (n[2] > 1 && p->m == M_MOTION && opt->tile_image_binned == CSI_SWITCH_ON) {
        /* The binned shutter (binned.c): the window's x/y cells over fewer frames, but with
         * the samples of its whole x/y column, merged where they share a binned cell. */
        csi_tiling b;
        memset(&b, 0, sizeof b);
        b.grid = (csi_grid){.t = (uint32_t)(p->k / ((uint64_t)p->ax[0].length * p->bw * p->ax[1].length * p->bh))};
        b.n[2] = n[2];
        b.window[2] = c->window[2];
        const uint32_t bins = (b.grid.t + csi_tiling_bin_t(&b) - 1) / csi_tiling_bin_t(&b);
        const csi_grid bg = {.w = tg.w, .h = tg.h, .t = bins, .out_w = tg.out_w, .out_h = tg.out_h};
        const uint64_t bcells = (uint64_t)bg.w * bg.h * bg.t;
        double col = ceil(TILE_SAMPLE_HEADROOM * (double)p->n * (double)cells / (double)p->k * p->ax[2].length /
                          c->window[2]);
        uint64_t bn = col < (double)bcells ? (uint64_t)col : bcells;
        if (bn > p->n)
            bn = p->n;
        to.frames = false;
        csi_recon_plan bplan;
        if (csi_recon_plan_whole(p->ctx, &bg, p->channels, (size_t)bn, &to, &p->scope, &bplan) != CSI_OK)
            return false;
        if (bplan.device_bytes > c->bytes)
            c->bytes = bplan.device_bytes;
        if (bplan.largest_buffer > c->largest)
            c->largest = bplan.largest_buffer;
    }
    c->samples = ns;
    c->work = cells * count;
    return true;
}

static bool fits(const candidate *c, uint64_t budget, uint64_t max_alloc)
{
    return c->bytes <= budget && (!max_alloc || c->largest <= max_alloc);
}

/* The planner's price of a layout (CSI_TILE_T_LOSS, csi/tiles.h): the work, the cells its
 * windows cover in all (every tile's solve steps over its window's cells, and the steps per
 * tile measured about equal: billiards 64x64 x 256 frames, 96 tiles covering 25x the volume's
 * cells took 18.5x the whole's CPU, 8 time windows covering 1.7x took 1.3x), times the error
 * the split is expected to add: an MSE a factor E above the whole's needs about E times the
 * samples for the same image, and the work grows with the samples; times CSI_TILE_UNFUSED_COST
 * where the windows' FFT rows cannot run fused, each of their cells costing more. */
static double price(const candidate *c)
{
    return (double)c->work * (1.0 + CSI_TILE_T_LOSS * (double)(c->n[2] - 1)) *
           (c->rows_unfused ? CSI_TILE_UNFUSED_COST : 1.0);
}

static bool better(const candidate *a, const candidate *best, bool have)
{
    if (!have)
        return true;
    const double pa = price(a), pb = price(best);
    uint32_t ca = a->n[0] * a->n[1] * a->n[2], cb = best->n[0] * best->n[1] * best->n[2];
    return pa < pb || (pa == pb && ca < cb);
}

csi_status csi_tiling_plan(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const csi_recon_options *opt, csi_tiling *out)
{
    memset(out, 0, sizeof *out);
    out->grid = *g;
    out->image_w = g->out_w;
    out->image_h = g->out_h;
    out->image_t = g->t;
    out->length[0] = g->out_w;
    out->length[1] = g->out_h;
    out->length[2] = g->t;
    for (int a = 0; a < 3; a++) {
        out->n[a] = 1;
        out->window[a] = out->length[a];
        out->align[a] = 1;
    }
    out->count = 1;
    const uint64_t global = ctx ? csi_ctx_global_mem(ctx) : 0;
    const uint64_t max_alloc = ctx ? (uint64_t)csi_ctx_max_alloc(ctx) : 0;
    uint64_t budget = opt->mem_budget ? opt->mem_budget : csi_tile_default_budget(ctx);
    if (global && budget > global)
        budget = global; /* never more than the device reports */
    out->budget = budget;

    plan_ctx p;
    memset(&p, 0, sizeof p);
    p.m = method_of(g, opt);
    p.k = (uint64_t)g->w * g->h * g->t;
    p.n = n;
    p.bw = g->w / g->out_w;
    p.bh = g->h / g->out_h;
    p.channels = channels;
    p.ctx = ctx;
    csi_tile_scope_init(g, channels, n, &p.scope);
    if (p.m == M_AA) {
        p.levels = opt->levels;
        if (p.levels <= 0) {
            p.levels = csi_wavelet_default_levels(opt->wavelet, g->w, g->h);
            if (p.levels > 5)
                p.levels = 5;
        }
        out->levels = p.levels;
    }
    const uint32_t cells[3] = {p.bw, p.bh, 1};
    for (int a = 0; a < 3; a++) {
        axis_req *ax = &p.ax[a];
        ax->length = out->length[a];
        ax->cells = cells[a];
        ax->multiple = 1;
        ax->align = 1;
        if (p.m == M_AA && a < 2 && p.levels > 0 && p.levels < 31) {
            /* Windows a multiple of 2^levels cells long, starting on that lattice: the smallest
             * power of two of pixels that is a multiple of 2^levels cells. */
            const uint32_t pw = 1u << p.levels;
            ax->multiple = pw;
            while ((uint64_t)ax->align * cells[a] % pw != 0)
                ax->align *= 2;
        } else if (a == 0 && p.m != M_MEAN) {
            ax->multiple = 2; /* csi's own FFT kernels and the half spectrum want an even first axis */
        }
        if (a == 2) {
            ax->margin = opt->tile_margin_t ? opt->tile_margin_t : TILE_MARGIN_MOTION_T;
            p.auto_margin_t = !opt->tile_margin_t;
        } else if (p.m == M_AA) {
            const uint32_t mc = (uint32_t)csi_wavelet_taps(opt->wavelet) << (p.levels > 0 && p.levels < 20 ? p.levels : 5);
            uint32_t m = (mc + cells[a] - 1) / cells[a];
            ax->margin = opt->tile_margin ? opt->tile_margin : m < TILE_MARGIN_MIN_PX ? TILE_MARGIN_MIN_PX : m;
        } else
            ax->margin = opt->tile_margin ? opt->tile_margin : TILE_MARGIN_MOTION_PX;
        out->align[a] = ax->align;
        out->margin[a] = ax->margin;
    }

    const uint32_t one[3] = {1, 1, 1};
    candidate whole, best;
    memset(&best, 0, sizeof best);
    memset(&whole, 0, sizeof whole);
    /* The whole may be refused outright (too many cells for one problem): tiles may still do. */
    const bool whole_ok = p.m == M_MEAN || evaluate(&p, opt, one, &whole);
    if (!whole_ok)
        whole.bytes = whole.largest = UINT64_MAX;
    out->whole_bytes = whole.bytes;
    out->tile_bytes = whole.bytes;
    out->tile_samples = n;
    bool have = false;
    const uint32_t frames = g->t > 1 ? g->t : 1;
    if (opt->tiles_t > frames)
        return csi_fail(CSI_ERR_ARG, "%u time windows asked for %s", opt->tiles_t,
                        g->t > 1 ? "more than the volume's frames" : "an image (one frame)");
    if (opt->tiles_t > 1 && opt->tiles && opt->tiles % opt->tiles_t)
        return csi_fail(CSI_ERR_ARG, "%u tiles cannot hold %u time windows (not a multiple)", opt->tiles,
                        opt->tiles_t);
    if (p.m == M_MEAN || (opt->tiles <= 1 && opt->tiles_t <= 1 && fits(&whole, budget, max_alloc))) {
        if (opt->tiles > 1 || opt->tiles_t > 1)
            return csi_fail(CSI_ERR_ARG, "the per-pixel sample mean needs no tiles (asked for %u)",
                            opt->tiles > 1 ? opt->tiles : opt->tiles_t);
        return CSI_OK;
    }
    const uint32_t maxn[3] = {p.ax[0].length / p.ax[0].align, p.ax[1].length / p.ax[1].align, frames};
    /* Among the layouts that fit, the lowest price (work times the expected loss, above): x/y
     * tiles, time windows or both. Before, time windows came only when no split of x and y alone
     * fitted: on billiards 64x64 x 256 frames at 16 MiB that gave 96 tiles at 18.5x the whole's
     * CPU for 1.06x its MSE, where 8 windows took 1.3x for 1.14x (docs/bench/scale.md). */
    const uint32_t nt_lo = opt->tiles_t ? opt->tiles_t : 1, nt_hi = opt->tiles_t ? opt->tiles_t : maxn[2];
    if (opt->tiles > 1) {
        const uint32_t N = opt->tiles;
        bool any = false;
        for (uint32_t nt = nt_lo; nt <= N && nt <= nt_hi; nt++) {
            if (N % nt)
                continue;
            for (uint32_t ny = 1; ny <= N / nt && ny <= maxn[1]; ny++) {
                if ((N / nt) % ny)
                    continue;
                const uint32_t nn[3] = {N / nt / ny, ny, nt};
                candidate c;
                if (nn[0] > maxn[0] || !evaluate(&p, opt, nn, &c))
                    continue;
                any = true;
                if (fits(&c, budget, max_alloc) && better(&c, &best, have)) {
                    best = c;
                    have = true;
                }
            }
        }
        if (!any)
            return csi_fail(CSI_ERR_ARG, "%u tiles cannot be laid out on a %ux%u%s image (each tile "
                            "needs a core of at least %ux%u pixels inside windows of valid FFT sizes, with "
                            "margins of %u pixels%s)",
                            N, g->out_w, g->out_h, g->t > 1 ? " x t" : "", p.ax[0].align, p.ax[1].align,
                            p.ax[0].margin, opt->tile_margin ? "" : ", the default: --tile-margin sets a smaller one");
        if (!have)
            return csi_fail(CSI_ERR_ARG, "%u tiles do not fit the device budget of %llu bytes: ask "
                            "for more tiles or a larger budget", N, (unsigned long long)budget);
    } else {
        bool laid = false;
        for (uint32_t nt = nt_lo; nt <= nt_hi; nt++) {
            /* nt windows cover at least nt window lengths of whole frames, whatever the x/y
             * split: past the best price so far, skip them; once even the volume's own cells
             * (T frames) cost more at this loss, no more windows can be cheaper. */
            if (have && (double)p.k * (1.0 + CSI_TILE_T_LOSS * (nt - 1)) >= price(&best))
                break;
            if (have && nt > 1) {
                axis_req at = p.ax[2];
                if (p.auto_margin_t)
                    at.margin = margin_t_auto(at.length, nt);
                const uint32_t wt = axis_window(&at, nt, false);
                candidate lb = {.n = {1, 1, nt}, .work = p.k / at.length * wt * nt};
                if (!wt || price(&lb) >= price(&best))
                    continue;
            }
            bool alone = false;
            for (uint32_t ny = 1; ny <= maxn[1]; ny++) {
                /* The fewest tiles along x that fit, by bisection (a tile's bytes fall as the
                 * tiles along x grow, up to the rounding of window lengths). */
                uint32_t lo = 1, hi = maxn[0];
                candidate c;
                const uint32_t first[3] = {1, ny, nt}, top[3] = {hi, ny, nt};
                const bool made = evaluate(&p, opt, first, &c);
                laid |= made;
                if (made && fits(&c, budget, max_alloc))
                    hi = 1; /* one along x (2 may not be laid out at all: the bisection would skip 1) */
                else if (!evaluate(&p, opt, top, &c) || (laid = true, !fits(&c, budget, max_alloc)))
                    continue;
                while (lo < hi) {
                    uint32_t mid = lo + (hi - lo) / 2;
                    const uint32_t nn[3] = {mid, ny, nt};
                    if (evaluate(&p, opt, nn, &c) && fits(&c, budget, max_alloc))
                        hi = mid;
                    else
                        lo = mid + 1;
                }
                const uint32_t nn[3] = {lo, ny, nt};
                evaluate(&p, opt, nn, &c);
                if (better(&c, &best, have)) {
                    best = c;
                    have = true;
                }
                /* More, narrower windows cover more cells, but may price lower where their FFT
                 * rows fuse and the fewest's do not (CSI_TILE_UNFUSED_COST): up to where even
                 * fused cells would cost more than the best. */
                for (uint32_t nx = lo + 1; have && nx <= maxn[0]; nx++) {
                    const uint32_t nm[3] = {nx, ny, nt};
                    candidate d;
                    if (!evaluate(&p, opt, nm, &d))
                        continue;
                    if ((double)d.work * (1.0 + CSI_TILE_T_LOSS * (nt - 1)) >= price(&best))
                        break;
                    if (fits(&d, budget, max_alloc) && better(&d, &best, have))
                        best = d;
                }
                if (lo == 1) {
                    alone = ny == 1;
                    break; /* more tiles along y only add overlap */
                }
            }
            if (alone)
                break; /* the windows fit alone: more of them only add overlap and loss */
        }
        if (!laid && opt->tiles_t > 1)
            return csi_fail(CSI_ERR_ARG, "%u time windows cannot be laid out on %u frames with margins of %u "
                            "frames%s (a window's core and margins must be shorter than the volume)",
                            opt->tiles_t, g->t, p.auto_margin_t ? margin_t_auto(g->t, opt->tiles_t) : p.ax[2].margin,
                            p.auto_margin_t ? ", the default (--tile-margin-t sets a smaller one)" : "");
        if (!have && !whole_ok) {
            csi_recon_plan pw;
            return csi_recon_plan_whole(ctx, g, channels, n, opt, NULL, &pw); /* its message */
        }
        if (!have)
            return csi_fail(CSI_ERR_ARG, "no tiling of the %ux%ux%u grid fits the device budget of "
                            "%llu bytes (the whole needs %llu)", g->w, g->h, g->t,
                            (unsigned long long)budget, (unsigned long long)whole.bytes);
    }
    out->count = best.n[0] * best.n[1] * best.n[2];
    out->tile_bytes = best.bytes;
    out->tile_samples = best.samples;
    if (p.auto_margin_t)
        out->margin[2] = margin_t_auto(out->length[2], best.n[2]);
    for (int a = 0; a < 3; a++) {
        out->n[a] = best.n[a];
        out->window[a] = best.window[a];
        uint32_t band = out->margin[a] / 2;
        uint32_t mc = min_core(out->length[a], out->n[a], out->align[a]) / 2;
        if (band > mc)
            band = mc;
        out->band[a] = band ? band : 1;
    }
    return CSI_OK;
}

csi_status csi_tiling_layout(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                             const csi_recon_options *opt, csi_tiling *out)
{
    csi_grid solved;
    const bool padded = csi_recon_solved_grid(ctx, g, channels, n, opt, &solved);
    /* No time windows over padded frames: a window's share of the image is its frames' */
    csi_recon_options o = *opt;
    csi_status s = CSI_OK;
    if (padded && solved.t != g->t) {
        /* time windows over the volume's own frames, where they fit, are tiles of its own grid
         * (csi_recon_solved_grid); where they do not, say why (the margins, often), not the padding */
        csi_tiling own;
        if (o.tiles_t > 1) {
            CSI_TRY(csi_tiling_plan(ctx, g, channels, n, &o, &own));
            s = csi_fail(CSI_ERR_ARG, "%u time windows asked for a volume whose %u frames are solved as %u (a "
                         "prime factor above 7), which is not split in t", o.tiles_t, g->t, solved.t);
        }
        o.tiles_t = 1;
    }
    if (s == CSI_OK)
        s = csi_tiling_plan(ctx, padded ? &solved : g, channels, n, &o, out);
    if (s != CSI_OK)
        return padded ? csi_recon_padded_fail(s, g, &solved) : s;
    out->image_w = g->out_w;
    out->image_h = g->out_h;
    out->image_t = g->t;
    return CSI_OK;
}

csi_grid csi_tiling_image_grid(const csi_tiling *tl)
{
    csi_grid g = tl->grid;
    if (g.out_w && g.out_h) {
        g.w = g.w / g.out_w * tl->image_w;
        g.h = g.h / g.out_h * tl->image_h;
    }
    g.out_w = tl->image_w;
    g.out_h = tl->image_h;
    g.t = tl->image_t;
    return g;
}

bool csi_tiling_image_binned(const csi_tiling *tl, const csi_recon_options *opt)
{
    return tl->n[2] > 1 && opt->estimator == CSI_EST_CS && opt->tile_image_binned == CSI_SWITCH_ON;
}

uint32_t csi_tiling_bin_t(const csi_tiling *tl)
{
    const uint32_t T = tl->grid.t, L = tl->window[2];
    if (tl->n[2] <= 1 || L == 0)
        return 1;
    uint32_t b = (T + L - 1) / L;
    while (!csi_smooth7((T + b - 1) / b))
        b++;
    return b;
}

void csi_tiling_tile(const csi_tiling *tl, uint32_t index, csi_tile *t)
{
    memset(t, 0, sizeof *t);
    t->index = index;
    t->pos[0] = index % tl->n[0];
    t->pos[1] = index / tl->n[0] % tl->n[1];
    t->pos[2] = index / tl->n[0] / tl->n[1];
    for (int a = 0; a < 3; a++) {
        t->core0[a] = core_bound(tl->length[a], tl->n[a], tl->align[a], t->pos[a]);
        t->core1[a] = core_bound(tl->length[a], tl->n[a], tl->align[a], t->pos[a] + 1);
        t->win0[a] = win_start(tl->length[a], tl->n[a], tl->align[a], tl->window[a], t->pos[a]);
    }
}

/* The smooth step u^2 (3 - 2u) of u clamped to [0, 1]. */
static double smoothstep(double u)
{
    u = u < 0 ? 0 : u > 1 ? 1 : u;
    return u * u * (3 - 2 * u);
}

double csi_tile_weight(const csi_tiling *tl, const csi_tile *t, int axis, uint32_t c)
{
    if (c < t->win0[axis] || c >= t->win0[axis] + tl->window[axis])
        return 0;
    const double x = c + 0.5, r = tl->band[axis];
    double w = 1;
    if (t->pos[axis] > 0)
        w *= smoothstep((x - (t->core0[axis] - r)) / (2 * r));
    if (t->pos[axis] + 1 < tl->n[axis])
        w *= 1 - smoothstep((x - (t->core1[axis] - r)) / (2 * r));
    return w;
}

const char *csi_tiling_check(const csi_tiling *tl)
{
    const csi_grid *g = &tl->grid;
    if (!g->w || !g->h || !g->t || !g->out_w || !g->out_h || g->w % g->out_w || g->h % g->out_h)
        return "the grid";
    if (tl->length[0] != g->out_w || tl->length[1] != g->out_h || tl->length[2] != g->t)
        return "the lengths of the axes";
    if (!tl->image_w || !tl->image_h || !tl->image_t || tl->image_w > g->out_w || tl->image_h > g->out_h ||
        tl->image_t > g->t || (tl->image_t < g->t && tl->n[2] > 1))
        return "the image's size";
    uint64_t count = 1;
    for (int a = 0; a < 3; a++) {
        const uint32_t L = tl->length[a], n = tl->n[a], e = tl->window[a];
        if (n == 0 || tl->align[a] == 0 || e == 0 || e > L || (n == 1 && e != L) ||
            (n > 1 && L / tl->align[a] < n) || (uint64_t)n * e < L)
            return "the tiles along an axis";
        count *= n;
    }
    return count == tl->count ? NULL : "the tile count";
}

bool csi_tiling_equal(const csi_tiling *a, const csi_tiling *b)
{
    if (memcmp(&a->grid, &b->grid, sizeof a->grid) || a->image_w != b->image_w || a->image_h != b->image_h ||
        a->image_t != b->image_t || a->count != b->count || a->levels != b->levels)
        return false;
    for (int i = 0; i < 3; i++)
        if (a->length[i] != b->length[i] || a->n[i] != b->n[i] || a->window[i] != b->window[i] ||
            a->margin[i] != b->margin[i] || a->band[i] != b->band[i] || a->align[i] != b->align[i])
            return false;
    return true;
}

/* For each coordinate along an axis, the first and last tile position whose window holds it
 * (windows along an axis are ranges in position order, so the ones holding c are consecutive). */
static csi_status axis_cover(const csi_tiling *tl, int a, uint32_t **first, uint32_t **last)
{
    const uint32_t L = tl->length[a];
    *first = malloc(L * sizeof **first);
    *last = malloc(L * sizeof **last);
    if (!*first || !*last)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the tile layout's windows");
    for (uint32_t c = 0; c < L; c++) {
        (*first)[c] = UINT32_MAX;
        (*last)[c] = 0;
    }
    for (uint32_t p = 0; p < tl->n[a]; p++) {
        const uint32_t w0 = win_start(L, tl->n[a], tl->align[a], tl->window[a], p);
        for (uint32_t c = w0; c < w0 + tl->window[a] && c < L; c++) {
            if ((*first)[c] == UINT32_MAX)
                (*first)[c] = p;
            (*last)[c] = p;
        }
    }
    return CSI_OK;
}

csi_status csi_tiling_empty_tile(const csi_tiling *tl, uint32_t index)
{
    csi_tile t;
    csi_tiling_tile(tl, index, &t);
    const uint32_t f0 = t.win0[2], f1 = f0 + tl->window[2] - 1;
    return csi_fail(CSI_ERR_ARG, "tile %u of %u (time window %u of %u, frames %u-%u) holds no sample: the "
                    "samples do not cover that part of the shutter; ask for fewer time windows (--tiles-t)",
                    index + 1, tl->count, t.pos[2] + 1, tl->n[2], f0, f1 < tl->image_t ? f1 : tl->image_t - 1);
}

csi_status csi_tiling_check_samples(const csi_tiling *tl, const csi_sample_pos *pos, size_t n)
{
    if (tl->n[2] <= 1)
        return CSI_OK;
    uint32_t *first[3] = {NULL, NULL, NULL}, *last[3] = {NULL, NULL, NULL};
    unsigned char *held = calloc(tl->count, 1);
    csi_status s = held ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of host memory for the tile layout's windows");
    for (int a = 0; a < 3 && s == CSI_OK; a++)
        s = axis_cover(tl, a, &first[a], &last[a]);
    const uint32_t bw = tl->grid.w / tl->grid.out_w, bh = tl->grid.h / tl->grid.out_h;
    uint32_t left = tl->count;
    for (size_t i = 0; i < n && left && s == CSI_OK; i++) {
        const uint32_t c[3] = {pos[i].x / bw, pos[i].y / bh, pos[i].t};
        if (c[0] >= tl->length[0] || c[1] >= tl->length[1] || c[2] >= tl->length[2])
            continue; /* outside the grid: the inputs' check names it */
        for (uint32_t pt = first[2][c[2]]; pt <= last[2][c[2]]; pt++)
            for (uint32_t py = first[1][c[1]]; py <= last[1][c[1]]; py++)
                for (uint32_t px = first[0][c[0]]; px <= last[0][c[0]]; px++) {
                    const uint32_t k = (pt * tl->n[1] + py) * tl->n[0] + px;
                    left -= !held[k];
                    held[k] = 1;
                }
    }
    for (uint32_t k = 0; k < tl->count && left && s == CSI_OK; k++)
        if (!held[k])
            s = csi_tiling_empty_tile(tl, k);
    for (int a = 0; a < 3; a++) {
        free(first[a]);
        free(last[a]);
    }
    free(held);
    return s;
}
