/* Sample positions on the fine grid (see csi/positions.h for the definitions). */
#include "csi/positions.h"

#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

/* ---- PRNG ------------------------------------------------------------------------------- */

uint64_t csi_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}

void csi_rng_seed(csi_rng *r, uint64_t seed)
{
    uint64_t x = seed;
    for (int i = 0; i < 4; i++) {
        x += UINT64_C(0x9e3779b97f4a7c15); /* splitmix64's increment */
        r->s[i] = csi_mix64(x);
    }
}

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }

uint64_t csi_rng_next(csi_rng *r)
{
    uint64_t *s = r->s;
    const uint64_t result = rotl(s[1] * 5, 7) * 9;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
}

uint64_t csi_rng_below(csi_rng *r, uint64_t n)
{
    /* Reject draws below 2^64 mod n so the remaining range is a multiple of n. */
    const uint64_t threshold = (0 - n) % n;
    for (;;) {
        uint64_t x = csi_rng_next(r);
        if (x >= threshold)
            return x % n;
    }
}

double csi_rng_uniform(csi_rng *r) { return (double)(csi_rng_next(r) >> 11) * 0x1.0p-53; }

/* ---- options ----------------------------------------------------------------------------- */

const char *csi_pos_method_name(csi_pos_method m)
{
    switch (m) {
    case CSI_POS_POISSON: return "poisson";
    case CSI_POS_STRATIFIED: return "stratified";
    case CSI_POS_RANDOM: return "random";
    }
    return "unknown";
}

csi_status csi_pos_method_parse(const char *s, csi_pos_method *m)
{
    for (int i = 0; i <= CSI_POS_RANDOM; i++)
        if (s && strcmp(s, csi_pos_method_name((csi_pos_method)i)) == 0) {
            *m = (csi_pos_method)i;
            return CSI_OK;
        }
    return csi_fail(CSI_ERR_ARG, "unknown sampling method \"%s\" (choose poisson, stratified or random)",
                    s ? s : "");
}

static csi_status check_grid(const csi_grid *g)
{
    if (!g->w || !g->h || !g->t || !g->out_w || !g->out_h)
        return csi_fail(CSI_ERR_ARG, "grid %" PRIu32 "x%" PRIu32 "x%" PRIu32 " -> %" PRIu32 "x%" PRIu32
                        " has a zero size", g->w, g->h, g->t, g->out_w, g->out_h);
    if (g->w % g->out_w || g->h % g->out_h)
        return csi_fail(CSI_ERR_ARG, "grid %" PRIu32 "x%" PRIu32 " is not a multiple of the output %" PRIu32 "x%" PRIu32,
                        g->w, g->h, g->out_w, g->out_h);
    return CSI_OK;
}

/* Samples per pixel for STRATIFIED. */
static uint64_t strat_spp(const csi_grid *g, const csi_pos_opts *o)
{
    if (o->fraction > 0) {
        double k = (double)g->w * g->h * g->t;
        double s = round(o->fraction * k / ((double)g->out_w * g->out_h));
        return s < 1 ? 1 : (uint64_t)s;
    }
    return o->spp;
}

csi_status csi_positions_count(const csi_grid *g, const csi_pos_opts *o, size_t *n)
{
    CSI_TRY(check_grid(g));
    if (o->method != CSI_POS_POISSON && o->method != CSI_POS_STRATIFIED && o->method != CSI_POS_RANDOM)
        return csi_fail(CSI_ERR_ARG, "unknown sampling method %d", (int)o->method);
    const uint64_t k = (uint64_t)g->w * g->h * g->t;
    const uint64_t pixels = (uint64_t)g->out_w * g->out_h;
    uint64_t N;
    if (!(o->fraction >= 0) || o->fraction > 1)
        return csi_fail(CSI_ERR_ARG, "sampling fraction %g is not in (0, 1]", o->fraction);
    if (o->method == CSI_POS_STRATIFIED) {
        if (o->fraction == 0 && o->spp == 0)
            return csi_fail(CSI_ERR_ARG, "samples per pixel is zero");
        N = strat_spp(g, o) * pixels;
    } else if (o->fraction > 0) {
        N = (uint64_t)llround(o->fraction * (double)k);
        if (N == 0)
            return csi_fail(CSI_ERR_ARG, "sampling fraction %g of %" PRIu64 " cells gives no samples", o->fraction, k);
    } else {
        if (o->spp == 0)
            return csi_fail(CSI_ERR_ARG, "samples per pixel is zero");
        N = (uint64_t)o->spp * pixels;
    }
    if (N > k)
        return csi_fail(CSI_ERR_ARG, "%" PRIu64 " samples asked for, but the %" PRIu32 "x%" PRIu32 "x%" PRIu32
                        " grid has only %" PRIu64 " cells (at most %" PRIu64 " per output pixel)",
                        N, g->w, g->h, g->t, k, k / pixels);
    if (N > SIZE_MAX / sizeof(csi_sample_pos) || N > SIZE_MAX / sizeof(uint64_t))
        return csi_fail(CSI_ERR_NOMEM, "%" PRIu64 " samples do not fit in memory", N);
    *n = (size_t)N;
    return CSI_OK;
}

/* ---- helpers ----------------------------------------------------------------------------- */

/* LSD radix sort of 48-bit keys (k < 2^48 since each side < 2^32 ... in practice k < 2^31),
 * 16 bits per pass. */
static csi_status sort_u64(uint64_t *a, size_t n, uint64_t maxkey)
{
    if (n < 2)
        return CSI_OK;
    uint64_t *tmp = malloc(n * sizeof *tmp);
    size_t *cnt = malloc(65536 * sizeof *cnt);
    if (!tmp || !cnt) {
        free(tmp);
        free(cnt);
        return csi_fail(CSI_ERR_NOMEM, "out of memory sorting %zu positions", n);
    }
    uint64_t *src = a, *dst = tmp;
    for (int shift = 0; shift < 64 && (maxkey >> shift) != 0; shift += 16) {
        memset(cnt, 0, 65536 * sizeof *cnt);
        for (size_t i = 0; i < n; i++)
            cnt[(src[i] >> shift) & 0xffff]++;
        size_t sum = 0;
        for (size_t d = 0; d < 65536; d++) {
            size_t c = cnt[d];
            cnt[d] = sum;
            sum += c;
        }
        for (size_t i = 0; i < n; i++)
            dst[cnt[(src[i] >> shift) & 0xffff]++] = src[i];
        uint64_t *t = src;
        src = dst;
        dst = t;
    }
    if (src != a)
        memcpy(a, src, n * sizeof *a);
    free(tmp);
    free(cnt);
    return CSI_OK;
}

static csi_sample_pos pos_of(const csi_grid *g, uint64_t lin)
{
    csi_sample_pos p;
    p.x = (uint32_t)(lin % g->w);
    lin /= g->w;
    p.y = (uint32_t)(lin % g->h);
    p.t = (uint32_t)(lin / g->h);
    return p;
}

/* Selection sampling (Algorithm S): picks `want` of the `avail` indices 0..avail-1, each
 * subset equally likely, in increasing order, skipping those listed in the sorted array `skip`
 * (the index space is then [0, avail + nskip)). */
static void select_sorted(csi_rng *r, uint64_t avail, uint64_t want, const uint64_t *skip, size_t nskip,
                          uint64_t *out)
{
    uint64_t picked = 0, seen = 0, cell = 0;
    size_t si = 0;
    while (picked < want) {
        if (si < nskip && skip[si] == cell) {
            si++;
            cell++;
            continue;
        }
        if (csi_rng_below(r, avail - seen) < want - picked)
            out[picked++] = cell;
        seen++;
        cell++;
    }
}

/* ---- stratified ------------------------------------------------------------------------- */

static void choose_split(uint64_t spp, uint32_t bw, uint32_t bh, uint32_t bt, uint32_t s[3])
{
    double best = INFINITY;
    s[0] = s[1] = s[2] = 0;
    for (uint64_t a = 1; a <= bw && a <= spp; a++) {
        if (spp % a)
            continue;
        for (uint64_t b = 1; b <= bh && b <= spp / a; b++) {
            if ((spp / a) % b)
                continue;
            uint64_t c = spp / a / b;
            if (c > bt)
                continue;
            double lx = log((double)bw / (double)a), ly = log((double)bh / (double)b);
            double lt = log((double)bt / (double)c);
            double cost = (lx - ly) * (lx - ly);
            if (bt > 1) /* with no time axis only the x/y balance matters */
                cost += (lx - lt) * (lx - lt) + (ly - lt) * (ly - lt);
            if (cost < best) {
                best = cost;
                s[0] = (uint32_t)a;
                s[1] = (uint32_t)b;
                s[2] = (uint32_t)c;
            }
        }
    }
}

static csi_status stratified(const csi_grid *g, const csi_pos_opts *o, uint64_t *lin, size_t n, csi_pos_info *info)
{
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h, bt = g->t;
    const uint64_t spp = strat_spp(g, o);
    const uint64_t cells = (uint64_t)bw * bh * bt;
    uint32_t s[3];
    choose_split(spp, bw, bh, bt, s);
    memcpy(info->strata, s, sizeof s);
    csi_rng r;
    csi_rng_seed(&r, o->seed);
    /* A volume's pixel of several cells whose strata split its shutter alone (the split keeps
     * each stratum's extent in t near its extent in x and y, so a few cells a pixel over many
     * frames are split in t only): each stratum's cell is dealt from a shuffled deck holding
     * every cell of the pixel once, a new deck when it runs out, not drawn at random, so that
     * spp samples fall on min(spp, cells) distinct cells, every cell once before any twice (Latin
     * hypercube sampling across the pixel's cells and its shutter, McKay, Beckman and Conover
     * 1979). A still pixel's samples then see as much of it as the grid holds, where independent
     * draws repeat cells and leave others unseen. */
    const uint32_t deck_n = bt > 1 && s[0] == 1 && s[1] == 1 && bw * bh > 1 && bw * bh <= 256 ? bw * bh : 0;
    uint8_t deck[256];
    size_t m = 0;
    for (uint32_t py = 0; py < g->out_h; py++)
        for (uint32_t px = 0; px < g->out_w; px++) {
            const uint64_t x0 = (uint64_t)px * bw, y0 = (uint64_t)py * bh;
            if (deck_n) {
                uint32_t dealt = deck_n;
                for (uint32_t c = 0; c < s[2]; c++) {
                    if (dealt == deck_n) { /* a fresh deck, shuffled (Fisher-Yates) */
                        for (uint32_t i = 0; i < deck_n; i++)
                            deck[i] = (uint8_t)i;
                        for (uint32_t i = deck_n - 1; i > 0; i--) {
                            const uint32_t j = (uint32_t)csi_rng_below(&r, i + 1);
                            const uint8_t tmp = deck[i];
                            deck[i] = deck[j];
                            deck[j] = tmp;
                        }
                        dealt = 0;
                    }
                    const uint32_t cell = deck[dealt++];
                    const uint64_t ta = (uint64_t)c * bt / s[2], tb = (uint64_t)(c + 1) * bt / s[2];
                    const uint64_t t = ta + csi_rng_below(&r, tb - ta);
                    lin[m++] = (t * g->h + y0 + cell / bw) * g->w + x0 + cell % bw;
                }
            } else if (s[0]) {
                for (uint32_t c = 0; c < s[2]; c++)
                    for (uint32_t b = 0; b < s[1]; b++)
                        for (uint32_t a = 0; a < s[0]; a++) {
                            uint64_t xa = (uint64_t)a * bw / s[0], xb = (uint64_t)(a + 1) * bw / s[0];
                            uint64_t ya = (uint64_t)b * bh / s[1], yb = (uint64_t)(b + 1) * bh / s[1];
                            uint64_t ta = (uint64_t)c * bt / s[2], tb = (uint64_t)(c + 1) * bt / s[2];
                            uint64_t x = x0 + xa + csi_rng_below(&r, xb - xa);
                            uint64_t y = y0 + ya + csi_rng_below(&r, yb - ya);
                            uint64_t t = ta + csi_rng_below(&r, tb - ta);
                            lin[m++] = (t * g->h + y) * g->w + x;
                        }
            } else {
                for (uint64_t i = 0; i < spp; i++) {
                    uint64_t ca = i * cells / spp, cb = (i + 1) * cells / spp;
                    uint64_t c = ca + csi_rng_below(&r, cb - ca); /* (t, y, x) scan order in the block */
                    uint64_t x = x0 + c % bw, y = y0 + (c / bw) % bh, t = c / ((uint64_t)bw * bh);
                    lin[m++] = (t * g->h + y) * g->w + x;
                }
            }
        }
    (void)n;
    return sort_u64(lin, m, (uint64_t)g->w * g->h * g->t);
}

/* ---- Poisson disk ----------------------------------------------------------------------- */

/* A keyed pseudo-random bijection of [0, k): a 4-round balanced Feistel network on 2*half
 * bits (2^(2 half) >= k), with cycle walking to stay inside [0, k) (Black & Rogaway, "Ciphers
 * with arbitrary finite domains", 2002). Visiting perm(0), perm(1), ... tries every cell once
 * in a seeded order without storing a k-element permutation. */
typedef struct {
    uint64_t k, mask;
    int half;
    uint64_t key[4];
} feistel;

static void feistel_init(feistel *f, uint64_t k, csi_rng *r)
{
    int bits = 1;
    while ((UINT64_C(1) << bits) < k)
        bits++;
    f->half = (bits + 1) / 2;
    f->mask = (UINT64_C(1) << f->half) - 1;
    f->k = k;
    for (int i = 0; i < 4; i++)
        f->key[i] = csi_rng_next(r);
}

static uint64_t feistel_apply(const feistel *f, uint64_t x)
{
    do {
        uint64_t L = x >> f->half, R = x & f->mask;
        for (int i = 0; i < 4; i++) {
            uint64_t nl = R;
            R = L ^ (csi_mix64(R ^ f->key[i]) & f->mask);
            L = nl;
        }
        x = (L << f->half) | R;
    } while (x >= f->k);
    return x;
}

/* The rows (dy, dt) that the offsets of one candidate span: at most (2 r + 1)^2 for r^2 <= ~9 in
 * 3-D, 2 r + 1 for r^2 <= ~40 in 2-D. */
#define PD_MAX_ROWS 64
/* Candidates whose bitmap words are prefetched ahead of their test. The candidates come in a
 * pseudo-random order, so without it every test waits on several cache misses in turn; with it
 * the misses of the next candidates overlap the current test. */
#define PD_LOOKAHEAD 16

typedef struct {
    const csi_grid *g;
    int dims;
    double r, r2;
    uint32_t cs;        /* accelerator cell size, in fine cells: ceil(r) */
    uint32_t ax, ay, at; /* accelerator grid size */
    int64_t *head;      /* per accelerator cell: first sample, -1 if none */
    int64_t *next;      /* per sample: next in its cell */
    csi_sample_pos *pts;
    size_t n;
    /* Small radii: an occupancy bitmap of the grid and the list of integer offsets closer than
     * r, so a test is a few bit lookups instead of walking the accelerator's neighbour cells
     * (which is memory-bound when the candidates come in random order). */
    uint64_t *bits;     /* k bits, or NULL when the accelerator is used */
    int32_t (*off)[3];  /* offsets (dx, dy, dt) with 0 < |d|^2 < r^2 */
    size_t noff;
    int64_t rows[PD_MAX_ROWS]; /* the linear offsets dt W H + dy W of the rows the offsets touch */
    size_t nrows;
    int32_t reach;             /* the largest |dx| */
} pd_state;

/* Bitmap path limits: at most this many offsets (r^2 <= ~9 in 3-D, ~40 in 2-D) and a bitmap
 * of at most 2^32 cells (512 MiB): a 4K image on the 16x grid (2.1 G cells) stays on the bitmap
 * path, whose random-order tests are a few bit lookups; the accelerator's linked buckets are an
 * order of magnitude slower there. Both test the same predicate, so the positions do not
 * depend on which path ran. */
#define PD_MAX_OFFSETS 128
#define PD_MAX_BITMAP_CELLS (UINT64_C(1) << 32)

static csi_status pd_offsets(pd_state *s)
{
    const int R = (int)ceil(s->r);
    const int tr = s->dims == 3 ? R : 0;
    size_t n = 0;
    for (int dt = -tr; dt <= tr; dt++)
        for (int dy = -R; dy <= R; dy++)
            for (int dx = -R; dx <= R; dx++) {
                double d2 = (double)dx * dx + (double)dy * dy + (double)dt * dt;
                if (d2 > 0 && d2 < s->r2) {
                    if (n == PD_MAX_OFFSETS) {
                        s->noff = 0;
                        return CSI_OK; /* too many: use the accelerator */
                    }
                    s->off[n][0] = dx, s->off[n][1] = dy, s->off[n][2] = dt;
                    n++;
                }
            }
    s->noff = n;
    s->nrows = 0;
    s->reach = 0;
    const int64_t W = s->g->w, H = s->g->h;
    for (int dt = -tr; dt <= tr; dt++)
        for (int dy = -R; dy <= R; dy++) {
            bool used = dt == 0 && dy == 0; /* the candidate's own row is tested too */
            for (size_t i = 0; i < n; i++) {
                if (s->off[i][1] == dy && s->off[i][2] == dt)
                    used = true;
                if (abs(s->off[i][0]) > s->reach)
                    s->reach = abs(s->off[i][0]);
            }
            if (used && s->nrows < PD_MAX_ROWS)
                s->rows[s->nrows++] = ((int64_t)dt * H + dy) * W;
        }
    return CSI_OK;
}

/* A hint only: the words of the bitmap a test of `lin` will read (ends of each row it spans). */
static void pd_prefetch(const pd_state *s, uint64_t lin)
{
    const int64_t k = (int64_t)s->g->w * s->g->h * s->g->t;
    for (size_t i = 0; i < s->nrows; i++) {
        const int64_t lo = (int64_t)lin + s->rows[i] - s->reach, hi = (int64_t)lin + s->rows[i] + s->reach;
        if (lo >= 0 && lo < k)
            __builtin_prefetch(&s->bits[lo >> 6]);
        if (hi >= 0 && hi < k && (hi >> 6) != (lo >> 6))
            __builtin_prefetch(&s->bits[hi >> 6]);
    }
}

static csi_status pd_rebuild(pd_state *s, double r)
{
    s->r = r;
    s->r2 = r * r;
    if (s->bits) {
        CSI_TRY(pd_offsets(s));
        if (s->noff > 0)
            return CSI_OK;
    }
    double c = ceil(r);
    s->cs = c < 1 ? 1 : (uint32_t)c;
    s->ax = (s->g->w + s->cs - 1) / s->cs;
    s->ay = (s->g->h + s->cs - 1) / s->cs;
    s->at = s->dims == 3 ? (s->g->t + s->cs - 1) / s->cs : 1;
    size_t cells = (size_t)s->ax * s->ay * s->at;
    free(s->head);
    s->head = malloc(cells * sizeof *s->head);
    if (!s->head)
        return csi_fail(CSI_ERR_NOMEM, "out of memory for the Poisson-disk accelerator (%zu cells)", cells);
    for (size_t i = 0; i < cells; i++)
        s->head[i] = -1;
    for (size_t i = 0; i < s->n; i++) {
        const csi_sample_pos p = s->pts[i];
        size_t a = ((size_t)(p.t / s->cs) * s->ay + p.y / s->cs) * s->ax + p.x / s->cs;
        s->next[i] = s->head[a];
        s->head[a] = (int64_t)i;
    }
    return CSI_OK;
}

static bool pd_accept_bits(const pd_state *s, csi_sample_pos p, uint64_t lin)
{
    if (s->bits[lin >> 6] >> (lin & 63) & 1)
        return false;
    const int64_t W = s->g->w, H = s->g->h, T = s->g->t;
    for (size_t i = 0; i < s->noff; i++) {
        int64_t x = (int64_t)p.x + s->off[i][0], y = (int64_t)p.y + s->off[i][1], t = (int64_t)p.t + s->off[i][2];
        if (x < 0 || y < 0 || t < 0 || x >= W || y >= H || t >= T)
            continue;
        uint64_t q = ((uint64_t)t * (uint64_t)H + (uint64_t)y) * (uint64_t)W + (uint64_t)x;
        if (s->bits[q >> 6] >> (q & 63) & 1)
            return false;
    }
    return true;
}

static bool pd_accept(const pd_state *s, csi_sample_pos p)
{
    const int64_t cx = p.x / s->cs, cy = p.y / s->cs, ct = p.t / s->cs;
    const int64_t tlo = s->dims == 3 ? -1 : 0, thi = s->dims == 3 ? 1 : 0;
    for (int64_t dt = tlo; dt <= thi; dt++) {
        int64_t tt = ct + dt;
        if (tt < 0 || tt >= s->at)
            continue;
        for (int64_t dy = -1; dy <= 1; dy++) {
            int64_t yy = cy + dy;
            if (yy < 0 || yy >= s->ay)
                continue;
            for (int64_t dx = -1; dx <= 1; dx++) {
                int64_t xx = cx + dx;
                if (xx < 0 || xx >= s->ax)
                    continue;
                for (int64_t i = s->head[(tt * s->ay + yy) * s->ax + xx]; i >= 0; i = s->next[i]) {
                    const csi_sample_pos q = s->pts[i];
                    double ddx = (double)q.x - p.x, ddy = (double)q.y - p.y, ddt = (double)q.t - p.t;
                    if (ddx * ddx + ddy * ddy + ddt * ddt < s->r2)
                        return false;
                }
            }
        }
    }
    return true;
}

/* How often (candidate cells tried) the Poisson-disk dart throwing reports its progress: a
 * fraction of a second of work, so that the call stays negligible. */
#define PD_PROGRESS_EVERY (UINT64_C(1) << 20)

static csi_status poisson(const csi_grid *g, const csi_pos_opts *o, uint64_t *lin, size_t N, csi_pos_info *info,
                          csi_count_progress_fn progress, void *user)
{
    const uint64_t k = (uint64_t)g->w * g->h * g->t;
    const int dims = g->t > 1 ? 3 : 2;
    const double rmax = dims == 2 ? sqrt(2.0 * (double)k / (sqrt(3.0) * (double)N))
                                  : cbrt(sqrt(2.0) * (double)k / (double)N);
    info->radius_max = rmax;
    csi_rng rng;
    csi_rng_seed(&rng, o->seed);
    pd_state s = {.g = g, .dims = dims};
    s.pts = malloc((N ? N : 1) * sizeof *s.pts);
    s.next = malloc((N ? N : 1) * sizeof *s.next);
    csi_status st = CSI_OK;
    if (!s.pts || !s.next) {
        st = csi_fail(CSI_ERR_NOMEM, "out of memory for %zu positions", N);
        goto done;
    }
    if (k <= PD_MAX_BITMAP_CELLS) {
        s.bits = calloc((size_t)((k + 63) / 64), sizeof *s.bits);
        s.off = malloc(PD_MAX_OFFSETS * sizeof *s.off);
        if (!s.bits || !s.off) {
            free(s.bits);
            s.bits = NULL; /* fall back to the accelerator */
        }
    }
    double r = 0.7 * rmax;
    while (s.n < N && r > 1.0) {
        if ((st = pd_rebuild(&s, r)) != CSI_OK)
            goto done;
        feistel f;
        feistel_init(&f, k, &rng);
        const bool bitmap = s.bits && s.noff > 0;
        uint64_t ahead[PD_LOOKAHEAD];
        for (uint64_t j = 0; j < PD_LOOKAHEAD && j < k; j++) {
            ahead[j] = feistel_apply(&f, j);
            if (bitmap)
                pd_prefetch(&s, ahead[j]);
        }
        for (uint64_t i = 0; i < k && s.n < N; i++) {
            if (progress && i % PD_PROGRESS_EVERY == PD_PROGRESS_EVERY - 1 && !progress(user, s.n, N)) {
                st = csi_fail(CSI_ERR_CANCELLED, "making the positions was cancelled");
                goto done;
            }
            const uint64_t lin = ahead[i % PD_LOOKAHEAD];
            if (i + PD_LOOKAHEAD < k) {
                ahead[i % PD_LOOKAHEAD] = feistel_apply(&f, i + PD_LOOKAHEAD);
                if (bitmap)
                    pd_prefetch(&s, ahead[i % PD_LOOKAHEAD]);
            }
            const csi_sample_pos p = pos_of(g, lin);
            if (bitmap) {
                if (!pd_accept_bits(&s, p, lin))
                    continue;
                s.bits[lin >> 6] |= UINT64_C(1) << (lin & 63);
                s.pts[s.n++] = p;
                continue;
            }
            if (!pd_accept(&s, p))
                continue;
            if (s.bits)
                s.bits[lin >> 6] |= UINT64_C(1) << (lin & 63);
            size_t a = ((size_t)(p.t / s.cs) * s.ay + p.y / s.cs) * s.ax + p.x / s.cs;
            s.pts[s.n] = p;
            s.next[s.n] = s.head[a];
            s.head[a] = (int64_t)s.n;
            s.n++;
        }
        if (s.n < N)
            r *= 0.9;
    }
    info->radius = s.n == N ? s.r : 1.0;
    for (size_t i = 0; i < s.n; i++)
        lin[i] = csi_grid_index(g, s.pts[i]);
    if ((st = sort_u64(lin, s.n, k)) != CSI_OK)
        goto done;
    if (s.n < N) {
        /* r reached one cell: distinct cells are always >= 1 apart, so choose the rest
         * uniformly among the free cells. */
        const size_t have = s.n;
        uint64_t *extra = malloc((N - have) * sizeof *extra);
        if (!extra) {
            st = csi_fail(CSI_ERR_NOMEM, "out of memory for %zu positions", N);
            goto done;
        }
        select_sorted(&rng, k - have, N - have, lin, have, extra);
        memcpy(lin + have, extra, (N - have) * sizeof *extra);
        free(extra);
        st = sort_u64(lin, N, k);
    }
done:
    free(s.head);
    free(s.next);
    free(s.pts);
    free(s.bits);
    free(s.off);
    return st;
}

/* ---- the default grid ------------------------------------------------------------------ */

uint32_t csi_default_grid_factor(uint32_t out_w, uint32_t out_h, uint32_t t, uint64_t spp)
{
    /* A volume: each pixel already has t cells over its shutter, but a pixel of one spatial cell
     * is seen at its centre only, whatever the spp: the image then converges to the motion blur
     * of the pixel's centre, not of the pixel, and a texture or an edge stays aliased however
     * many samples are taken (stratified's as much as csi's). So F x F cells a pixel once there
     * is a sample for every 8 of its frames or more, F = floor(sqrt(spp)) between 2 and 4: about
     * one cell a sample of the pixel, so that stratified positions see each cell once (below 4
     * spp 2, whose four times the unknowns the fit still carries; docs/bench/animation.md,
     * session 42). F cells hold a still pixel to their centres however many samples there are,
     * and a renderer's jittered samples converge past that (session 43: 2 x 2 cells' image at 16
     * spp 1.25-2.8x a renderer's stratified MSE on five of eleven scenes, 4 x 4 cells' on three;
     * session 44: 3 x 3 at 9 spp, with the still lights' weight, below it on all eight still-camera
     * scenes where 2 x 2 was above it on three). Reduced while a side would exceed 65536 cells. */
    if (t > 1) {
        if (8 * spp < t)
            return 1;
        uint32_t f = spp >= 16 ? 4 : spp >= 9 ? 3 : 2;
        while (f > 1 && ((uint64_t)out_w * f > 65536 || (uint64_t)out_h * f > 65536))
            f--;
        return f;
    }
    /* Measured (docs/bench/grid.md, 64x64, 4 seeds, MSE vs a 256-spp reference / stratified's
     * MSE at equal spp): checkerboard 16 spp 2.11 at 4x, 1.52 at 8x, 0.71 at 16x; 1 spp is best
     * at 4x; non-power-of-two factors (6x, 12x) lose; 16x costs about 3-10x 4x to reconstruct. */
    uint32_t f = 4;
    while (f < 16 && (uint64_t)f * f <= 4 * spp)
        f *= 2;
    while (f > 4 && ((uint64_t)out_w * f > 65536 || (uint64_t)out_h * f > 65536))
        f /= 2;
    return f;
}

uint32_t csi_camera_grid_factor(uint32_t out_w, uint32_t out_h, uint32_t t, uint64_t spp, csi_camera_motion camera)
{
    /* A camera that translates across its view takes a still one's grid: its motion sweeps the
     * picture along itself only, so on one cell a pixel the edges and thin lines that run along
     * the motion are seen at the pixel's centre row (or column) alone and stay aliased at any spp,
     * as a still camera's were on one cell (docs/bench/animation.md, sessions 42 and 47). Any
     * other moving camera keeps 1: its blur removes the detail a finer grid is for. */
    if (t > 1 && camera == CSI_CAMERA_MOVES)
        return 1;
    return csi_default_grid_factor(out_w, out_h, t, spp);
}

/* ---- entry ------------------------------------------------------------------------------- */

csi_status csi_positions_host_bytes(const csi_grid *g, const csi_pos_opts *o, uint64_t *bytes)
{
    size_t N;
    CSI_TRY(csi_positions_count(g, o, &N));
    const uint64_t k = (uint64_t)g->w * g->h * g->t;
    /* the linear indices (8 N), the result (12 N), the radix sort's copy (8 N) and counts */
    uint64_t b = 28 * (uint64_t)N + 65536 * sizeof(size_t);
    if (o->method == CSI_POS_POISSON) {
        /* the accepted points and their chains (20 N), the occupancy bitmap, and the buckets'
         * heads (8 bytes per bucket of side ceil(r)). With the bitmap, buckets exist only when
         * more than PD_MAX_OFFSETS offsets lie within r: r > 6.3 cells in 2-D (sides >= 7), r >
         * 3.1 in 3-D (sides >= 4); without it, any r > 1 (sides >= 2). */
        b += 20 * (uint64_t)N + PD_MAX_OFFSETS * 12;
        const bool bitmap = k <= PD_MAX_BITMAP_CELLS;
        if (bitmap)
            b += (k + 63) / 64 * 8;
        const uint64_t cs = !bitmap ? 2 : g->t > 1 ? 4 : 7;
        b += 8 * ((g->w + cs - 1) / cs) * ((g->h + cs - 1) / cs) * (g->t > 1 ? (g->t + cs - 1) / cs : 1);
    }
    *bytes = b;
    return CSI_OK;
}

csi_status csi_positions(const csi_grid *g, const csi_pos_opts *o, csi_sample_pos **out, size_t *n,
                         csi_pos_info *info)
{
    return csi_positions_with_progress(g, o, out, n, info, NULL, NULL);
}

csi_status csi_positions_with_progress(const csi_grid *g, const csi_pos_opts *o, csi_sample_pos **out, size_t *n,
                                       csi_pos_info *info, csi_count_progress_fn progress, void *user)
{
    csi_pos_info local;
    if (!info)
        info = &local;
    memset(info, 0, sizeof *info);
    *out = NULL;
    *n = 0;
    size_t N;
    CSI_TRY(csi_positions_count(g, o, &N));
    uint64_t *lin = malloc(N * sizeof *lin);
    if (!lin)
        return csi_fail(CSI_ERR_NOMEM, "out of memory for %zu positions", N);
    csi_status st;
    const uint64_t k = (uint64_t)g->w * g->h * g->t;
    switch (o->method) {
    case CSI_POS_STRATIFIED:
        st = stratified(g, o, lin, N, info);
        break;
    case CSI_POS_RANDOM: {
        csi_rng r;
        csi_rng_seed(&r, o->seed);
        select_sorted(&r, k, N, NULL, 0, lin);
        st = CSI_OK;
        break;
    }
    default:
        st = poisson(g, o, lin, N, info, progress, user);
        break;
    }
    if (st != CSI_OK) {
        free(lin);
        return st;
    }
    csi_sample_pos *p = malloc(N * sizeof *p);
    if (!p) {
        free(lin);
        return csi_fail(CSI_ERR_NOMEM, "out of memory for %zu positions", N);
    }
    for (size_t i = 0; i < N; i++)
        p[i] = pos_of(g, lin[i]);
    free(lin);
    if (progress && !progress(user, N, N)) {
        free(p);
        return csi_fail(CSI_ERR_CANCELLED, "making the positions was cancelled");
    }
    info->count = N;
    *out = p;
    *n = N;
    return CSI_OK;
}
