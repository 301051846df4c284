/* Tile partials (partial.h; the format is docs/partial-format.md): a little-endian stream of
 * fields, then the image and frames, then a checksum of everything before it. */
#include "partial.h"

#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "csi/outfile.h"
#include "csi/positions.h"

uint64_t csi_hash64(uint64_t h, const void *data, size_t bytes)
{
    const unsigned char *p = data;
    size_t i = 0;
    for (; i + 8 <= bytes; i += 8) {
        uint64_t w = 0;
        for (int b = 7; b >= 0; b--)
            w = w << 8 | p[i + b];
        h = csi_mix64(h ^ w);
    }
    uint64_t t = 0; /* the last bytes, then the length (so that trailing zeros count) */
    for (size_t b = 0; i + b < bytes; b++)
        t |= (uint64_t)p[i + b] << (8 * b);
    h = csi_mix64(h ^ t);
    return csi_mix64(h ^ (uint64_t)bytes);
}

/* The options in a partial: every row of the library's option table but the tile options (the
 * partial holds the layout they decided), by name, as the text csi_recon_option_get writes and
 * csi_recon_option_set reads back (numbers round-trip exactly). */
static bool partial_option(const char *name)
{
    return strcmp(name, "mem-budget") && strcmp(name, "tiles") && strcmp(name, "tile-margin") &&
           strcmp(name, "tile-margin-t") && strcmp(name, "tiles-t");
}

/* ---- a growable little-endian byte stream ---- */
typedef struct {
    unsigned char *b;
    size_t n, cap;
    bool oom;
} wbuf;

static void put(wbuf *w, const void *src, size_t len)
{
    if (w->oom)
        return;
    if (w->n + len > w->cap) {
        size_t cap = w->cap ? w->cap : 4096;
        while (cap < w->n + len)
            cap *= 2;
        unsigned char *nb = realloc(w->b, cap);
        if (!nb) {
            w->oom = true;
            return;
        }
        w->b = nb;
        w->cap = cap;
    }
    memcpy(w->b + w->n, src, len);
    w->n += len;
}
static void put_u64(wbuf *w, uint64_t v)
{
    unsigned char b[8];
    for (int i = 0; i < 8; i++)
        b[i] = (unsigned char)(v >> (8 * i));
    put(w, b, 8);
}
static void put_u32(wbuf *w, uint32_t v) { put_u64(w, v); }
static void put_i32(wbuf *w, int32_t v) { put_u64(w, (uint64_t)(int64_t)v); }
static void put_f64(wbuf *w, double v)
{
    uint64_t u;
    memcpy(&u, &v, 8);
    put_u64(w, u);
}
static void put_str(wbuf *w, const char *s, size_t len)
{
    char buf[256] = {0};
    snprintf(buf, sizeof buf, "%s", s);
    put(w, buf, len);
}
static void put_f32s(wbuf *w, const float *a, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, &a[i], 4);
        unsigned char b[4] = {(unsigned char)u, (unsigned char)(u >> 8), (unsigned char)(u >> 16),
                              (unsigned char)(u >> 24)};
        put(w, b, 4);
    }
}

typedef struct {
    const unsigned char *b;
    size_t n, at;
    bool bad;
} rbuf;

static uint64_t get_u64(rbuf *r)
{
    if (r->bad || r->at + 8 > r->n) {
        r->bad = true;
        return 0;
    }
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | r->b[r->at + i];
    r->at += 8;
    return v;
}
static uint32_t get_u32(rbuf *r)
{
    uint64_t v = get_u64(r);
    if (v > UINT32_MAX)
        r->bad = true;
    return (uint32_t)v;
}
static int32_t get_i32(rbuf *r)
{
    int64_t v = (int64_t)get_u64(r);
    if (v < INT32_MIN || v > INT32_MAX)
        r->bad = true;
    return (int32_t)v;
}
static double get_f64(rbuf *r)
{
    uint64_t u = get_u64(r);
    double v;
    memcpy(&v, &u, 8);
    return v;
}
static void get_str(rbuf *r, char *dst, size_t len)
{
    if (r->bad || r->at + len > r->n) {
        r->bad = true;
        dst[0] = '\0';
        return;
    }
    memcpy(dst, r->b + r->at, len);
    dst[len - 1] = '\0';
    r->at += len;
}
static void get_f32s(rbuf *r, float *a, size_t n)
{
    if (r->bad || n > (r->n - r->at) / 4) {
        r->bad = true;
        return;
    }
    for (size_t i = 0; i < n; i++) {
        const unsigned char *b = r->b + r->at + 4 * i;
        uint32_t u = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
        memcpy(&a[i], &u, 4);
    }
    r->at += 4 * n;
}

/* The options as given (all: false; the partial's, without the tile options) or as reported
 * (all: true, every option of the table). */
static void put_options(wbuf *w, const csi_recon_options *o, bool all)
{
    uint32_t count = 0;
    for (size_t i = 0; i < csi_option_count(); i++) {
        csi_option_info info;
        count += csi_option_describe(i, &info) == CSI_OK && (all || partial_option(info.name));
    }
    put_u32(w, count);
    for (size_t i = 0; i < csi_option_count(); i++) {
        csi_option_info info;
        char value[64];
        if (csi_option_describe(i, &info) != CSI_OK || !(all || partial_option(info.name)))
            continue;
        if (csi_recon_option_get(o, info.name, value, sizeof value) != CSI_OK)
            value[0] = '\0';
        put_str(w, info.name, 32);
        put_str(w, value, sizeof value);
    }
}

static void get_options(rbuf *r, csi_recon_options *o, bool all)
{
    csi_recon_defaults(o);
    const uint32_t count = get_u32(r);
    if (count > 4096) {
        r->bad = true;
        return;
    }
    for (uint32_t i = 0; i < count && !r->bad; i++) {
        char name[32], value[64];
        get_str(r, name, sizeof name);
        get_str(r, value, sizeof value);
        if (!r->bad && (!(all || partial_option(name)) || csi_recon_option_set(o, name, value) != CSI_OK))
            r->bad = true; /* an option this program does not know: another version's partial */
    }
}

static void put_tiling(wbuf *w, const csi_tiling *t)
{
    const csi_grid *g = &t->grid;
    const uint32_t gv[5] = {g->w, g->h, g->t, g->out_w, g->out_h};
    for (int i = 0; i < 5; i++)
        put_u32(w, gv[i]);
    put_u32(w, t->image_w);
    put_u32(w, t->image_h);
    put_u32(w, t->image_t);
    for (int a = 0; a < 3; a++) {
        put_u32(w, t->length[a]);
        put_u32(w, t->n[a]);
        put_u32(w, t->window[a]);
        put_u32(w, t->margin[a]);
        put_u32(w, t->band[a]);
        put_u32(w, t->align[a]);
    }
    put_u32(w, t->count);
    put_i32(w, t->levels);
    put_u64(w, t->budget);
    put_u64(w, t->tile_bytes);
    put_u64(w, t->whole_bytes);
}

static void get_tiling(rbuf *r, csi_tiling *t)
{
    memset(t, 0, sizeof *t);
    t->grid.w = get_u32(r);
    t->grid.h = get_u32(r);
    t->grid.t = get_u32(r);
    t->grid.out_w = get_u32(r);
    t->grid.out_h = get_u32(r);
    t->image_w = get_u32(r);
    t->image_h = get_u32(r);
    t->image_t = get_u32(r);
    for (int a = 0; a < 3; a++) {
        t->length[a] = get_u32(r);
        t->n[a] = get_u32(r);
        t->window[a] = get_u32(r);
        t->margin[a] = get_u32(r);
        t->band[a] = get_u32(r);
        t->align[a] = get_u32(r);
    }
    t->count = get_u32(r);
    t->levels = get_i32(r);
    t->budget = get_u64(r);
    t->tile_bytes = get_u64(r);
    t->whole_bytes = get_u64(r);
}

static void put_report(wbuf *w, const csi_solve_report *p)
{
    put_u32(w, p->converged);
    put_u32(w, (uint32_t)p->reason);
    put_i32(w, p->iterations);
    put_i32(w, p->inner_iterations);
    put_i32(w, p->stages);
    put_i32(w, p->applies);
    put_i32(w, p->adjoints);
    put_u64(w, p->support);
    const double d[9] = {p->rel_residual, p->objective, p->rel_gap, p->tau, p->t_total,
                         p->t_select, p->t_lsq, p->t_step, p->t_debias};
    for (int i = 0; i < 9; i++)
        put_f64(w, d[i]);
    put_str(w, p->message, sizeof p->message);
}

static void get_report(rbuf *r, csi_solve_report *p)
{
    memset(p, 0, sizeof *p);
    p->converged = get_u32(r) != 0;
    p->reason = (csi_solve_reason)get_u32(r);
    p->iterations = get_i32(r);
    p->inner_iterations = get_i32(r);
    p->stages = get_i32(r);
    p->applies = get_i32(r);
    p->adjoints = get_i32(r);
    p->support = (size_t)get_u64(r);
    double *d[9] = {&p->rel_residual, &p->objective, &p->rel_gap, &p->tau, &p->t_total,
                    &p->t_select, &p->t_lsq, &p->t_step, &p->t_debias};
    for (int i = 0; i < 9; i++)
        *d[i] = get_f64(r);
    get_str(r, p->message, sizeof p->message);
}

/* Everything before the pixels. */
static void put_header(wbuf *w, const csi_partial *p)
{
    put(w, CSI_PARTIAL_MAGIC, 4);
    put(w, (const unsigned char[4]){CSI_PARTIAL_VERSION, 0, 0, 0}, 4);
    put_str(w, p->software, sizeof p->software);
    put_str(w, p->method, sizeof p->method);
    put_str(w, p->input, sizeof p->input);
    put_u64(w, p->input_id);
    put_options(w, &p->options, false);
    put_options(w, &p->reported, true);
    put_tiling(w, &p->tiling);
    const csi_tile_scope *s = &p->scope;
    put_u64(w, s->k);
    put_u64(w, s->n);
    put_u32(w, s->out_w);
    put_u32(w, s->out_h);
    put_u32(w, s->channels);
    put_u32(w, s->has_scale);
    for (int c = 0; c < 4; c++)
        put_f64(w, s->scale[c]);
    const csi_tile_result *t = &p->tile;
    const csi_recon_result *r = &t->r;
    put_u32(w, t->index);
    put_u32(w, t->x0);
    put_u32(w, t->y0);
    put_u32(w, t->t0);
    put_u32(w, r->out_w);
    put_u32(w, r->out_h);
    put_u32(w, r->channels);
    put_u32(w, r->nframes);
    put_u32(w, (uint32_t)r->options.solver);
    put_u32(w, r->model_factor);
    put_u32(w, r->chroma_model_factor);
    put_u64(w, r->k);
    put_u64(w, r->n);
    put_u64(w, r->unknowns);
    const double times[10] = {r->t_setup, r->t_solve, r->t_integrate, r->t_programs, r->cpu_setup, r->cpu_work,
                              r->t_channel_integrate[0], r->t_channel_integrate[1], r->t_channel_integrate[2],
                              r->t_channel_integrate[3]};
    for (int i = 0; i < 10; i++)
        put_f64(w, times[i]);
    for (uint32_t c = 0; c < r->channels && c < 4; c++)
        put_report(w, &r->report[c]);
    put_u32(w, t->resid != NULL);
    put_u32(w, t->px_cnt != NULL);
    put_u32(w, t->frames_mean != NULL);
    put_u32(w, t->step_delta != NULL);
    put_u32(w, t->exact);
}

csi_status csi_partial_store(const char *path, const csi_partial *p)
{
    const csi_recon_result *r = &p->tile.r;
    const size_t plane = (size_t)r->out_w * r->out_h * r->channels;
    wbuf w = {0};
    put_header(&w, p);
    put_f32s(&w, r->image, plane);
    if (r->nframes)
        put_f32s(&w, r->frames, plane * r->nframes);
    for (size_t i = 0; p->tile.resid && i < plane * CSI_RESID_SUMS; i++)
        put_f64(&w, p->tile.resid[i]);
    const size_t pixels = (size_t)r->out_w * r->out_h;
    for (size_t i = 0; p->tile.px_cnt && i < pixels; i++)
        put_u32(&w, p->tile.px_cnt[i]);
    for (size_t i = 0; p->tile.px_cnt && i < plane; i++)
        put_f64(&w, p->tile.px_sum[i]);
    if (p->tile.frames_mean)
        put_f32s(&w, p->tile.frames_mean, plane);
    if (p->tile.step_delta)
        put_f32s(&w, p->tile.step_delta, plane);
    put_u64(&w, csi_hash64(0, w.b, w.n));
    if (w.oom) {
        free(w.b);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory writing the partial", path);
    }
    csi_outfile of;
    csi_status s = csi_outfile_open(&of, path);
    if (s != CSI_OK) {
        free(w.b);
        return s;
    }
    if (fwrite(w.b, 1, w.n, of.fp) != w.n) {
        csi_outfile_abort(&of);
        free(w.b);
        return csi_fail(CSI_ERR_IO, "%s: cannot write: %s", path, strerror(errno));
    }
    free(w.b);
    return csi_outfile_commit(&of);
}

void csi_partial_release(csi_partial *p)
{
    csi_tile_result_free(&p->tile);
}

csi_status csi_partial_load(const char *path, bool with_data, csi_partial *out)
{
    memset(out, 0, sizeof *out);
    FILE *fp = fopen(path, "rb");
    if (!fp)
        return csi_fail(CSI_ERR_IO, "%s: cannot open: %s", path, strerror(errno));
    struct stat sb;
    if (fstat(fileno(fp), &sb) != 0 || !S_ISREG(sb.st_mode)) {
        fclose(fp);
        return csi_fail(CSI_ERR_IO, "%s: not a regular file", path);
    }
    const size_t size = (size_t)sb.st_size;
    unsigned char *b = malloc(size ? size : 1);
    if (!b) {
        fclose(fp);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory reading %zu bytes", path, size);
    }
    const size_t got = fread(b, 1, size, fp);
    fclose(fp);
    csi_status s = CSI_OK;
    if (got != size)
        s = csi_fail(CSI_ERR_IO, "%s: read %zu of %zu bytes", path, got, size);
    else if (size < 4 || memcmp(b, CSI_PARTIAL_MAGIC, 4))
        s = csi_fail(CSI_ERR_FORMAT, "%s: not a csi tile partial (no \"CSIP\" magic)", path);
    else if (size < 16)
        s = csi_fail(CSI_ERR_FORMAT, "%s: truncated: %zu bytes, shorter than a partial's header", path, size);
    else if (b[4] != CSI_PARTIAL_VERSION || b[5] || b[6] || b[7])
        s = csi_fail(CSI_ERR_FORMAT, "%s: partial format version %u (this program reads version %u)", path,
                     (unsigned)b[4] | (unsigned)b[5] << 8, CSI_PARTIAL_VERSION);
    else {
        rbuf tail = {b, size, size - 8, false};
        if (get_u64(&tail) != csi_hash64(0, b, size - 8))
            s = csi_fail(CSI_ERR_FORMAT, "%s: checksum mismatch: the partial is truncated or damaged", path);
    }
    rbuf r = {b, size - 8, 8, false};
    if (s == CSI_OK) {
        get_str(&r, out->software, sizeof out->software);
        get_str(&r, out->method, sizeof out->method);
        get_str(&r, out->input, sizeof out->input);
        out->input_id = get_u64(&r);
        get_options(&r, &out->options, false);
        get_options(&r, &out->reported, true);
        get_tiling(&r, &out->tiling);
        csi_tile_scope *sc = &out->scope;
        sc->k = get_u64(&r);
        sc->n = get_u64(&r);
        sc->out_w = get_u32(&r);
        sc->out_h = get_u32(&r);
        sc->channels = get_u32(&r);
        sc->has_scale = get_u32(&r) != 0;
        for (int c = 0; c < 4; c++)
            sc->scale[c] = get_f64(&r);
        csi_tile_result *t = &out->tile;
        csi_recon_result *res = &t->r;
        t->index = get_u32(&r);
        t->x0 = get_u32(&r);
        t->y0 = get_u32(&r);
        t->t0 = get_u32(&r);
        res->out_w = get_u32(&r);
        res->out_h = get_u32(&r);
        res->channels = get_u32(&r);
        res->nframes = get_u32(&r);
        res->options.solver = (csi_solver_kind)get_u32(&r);
        res->model_factor = get_u32(&r);
        res->chroma_model_factor = get_u32(&r);
        res->k = (size_t)get_u64(&r);
        res->n = (size_t)get_u64(&r);
        res->unknowns = (size_t)get_u64(&r);
        double *times[10] = {&res->t_setup, &res->t_solve, &res->t_integrate, &res->t_programs, &res->cpu_setup,
                             &res->cpu_work, &res->t_channel_integrate[0], &res->t_channel_integrate[1],
                             &res->t_channel_integrate[2], &res->t_channel_integrate[3]};
        for (int i = 0; i < 10; i++)
            *times[i] = get_f64(&r);
        res->tiles = 1;
        if (res->channels < 1 || res->channels > 4)
            r.bad = true;
        for (uint32_t c = 0; c < res->channels && !r.bad; c++)
            get_report(&r, &res->report[c]);
        const uint32_t has_resid = get_u32(&r), has_sums = get_u32(&r), has_mean = get_u32(&r),
                       has_delta = get_u32(&r), exact = get_u32(&r);
        const uint64_t pixels = (uint64_t)res->out_w * res->out_h, plane = pixels * res->channels;
        if (has_resid > 1 || has_sums > 1 || has_mean > 1 || has_delta > 1 || exact > 1)
            r.bad = true;
        t->exact = exact == 1;
        if (!r.bad && (plane == 0 || plane * (1 + (uint64_t)res->nframes + has_mean + has_delta) * 4 +
                                             has_resid * plane * CSI_RESID_SUMS * 8 + has_sums * (pixels + plane) * 8 !=
                                         r.n - r.at))
            s = csi_fail(CSI_ERR_FORMAT, "%s: a %ux%u window with %u channels, %u frames,%s residual sums,%s pixel "
                         "sums,%s frames' mean and%s HDR step changes does not match the %zu bytes of pixels", path,
                         res->out_w, res->out_h, res->channels, res->nframes, has_resid ? "" : " no",
                         has_sums ? "" : " no", has_mean ? "" : " no", has_delta ? "" : " no", r.n - r.at);
        else if (r.bad)
            s = csi_fail(CSI_ERR_FORMAT, "%s: malformed header at byte %zu", path, r.at);
        else if (t->index >= out->tiling.count || out->tiling.count == 0)
            s = csi_fail(CSI_ERR_FORMAT, "%s: tile %u of a layout of %u tiles", path, t->index, out->tiling.count);
        else if (csi_tiling_check(&out->tiling))
            s = csi_fail(CSI_ERR_FORMAT, "%s: not a layout of tiles csi makes (%s)", path,
                         csi_tiling_check(&out->tiling));
        if (s == CSI_OK) {
            /* the window the layout gives this tile, which a merge blends it into */
            csi_tile w;
            csi_tiling_tile(&out->tiling, t->index, &w);
            const csi_tiling *tl = &out->tiling;
            if (res->out_w != tl->window[0] || res->out_h != tl->window[1] || t->x0 != w.win0[0] ||
                t->y0 != w.win0[1] || t->t0 != w.win0[2] || (res->nframes && res->nframes != tl->window[2]) ||
                res->channels != sc->channels)
                s = csi_fail(CSI_ERR_FORMAT, "%s: tile %u is a %ux%u window at (%u, %u, %u) with %u frames and %u "
                             "channels; its layout's is %ux%u at (%u, %u, %u) with %u frames and %u", path, t->index,
                             res->out_w, res->out_h, t->x0, t->y0, t->t0, res->nframes, res->channels,
                             tl->window[0], tl->window[1], w.win0[0], w.win0[1], w.win0[2], tl->window[2],
                             sc->channels);
        }
        if (s == CSI_OK && with_data) {
            res->image = malloc((size_t)plane * sizeof(float));
            res->frames = res->nframes ? malloc((size_t)plane * res->nframes * sizeof(float)) : NULL;
            t->resid = has_resid ? malloc((size_t)plane * CSI_RESID_SUMS * sizeof *t->resid) : NULL;
            t->px_cnt = has_sums ? malloc((size_t)pixels * sizeof *t->px_cnt) : NULL;
            t->px_sum = has_sums ? malloc((size_t)plane * sizeof *t->px_sum) : NULL;
            t->frames_mean = has_mean ? malloc((size_t)plane * sizeof *t->frames_mean) : NULL;
            t->step_delta = has_delta ? malloc((size_t)plane * sizeof *t->step_delta) : NULL;
            if (!res->image || (res->nframes && !res->frames) || (has_resid && !t->resid) ||
                (has_sums && (!t->px_cnt || !t->px_sum)) || (has_mean && !t->frames_mean) ||
                (has_delta && !t->step_delta))
                s = csi_fail(CSI_ERR_NOMEM, "%s: out of memory for the tile's pixels", path);
            else {
                get_f32s(&r, res->image, (size_t)plane);
                if (res->nframes)
                    get_f32s(&r, res->frames, (size_t)plane * res->nframes);
                for (size_t i = 0; has_resid && i < plane * CSI_RESID_SUMS; i++)
                    t->resid[i] = get_f64(&r);
                for (size_t i = 0; has_sums && i < pixels; i++)
                    t->px_cnt[i] = get_u32(&r);
                for (size_t i = 0; has_sums && i < plane; i++)
                    t->px_sum[i] = get_f64(&r);
                if (has_mean)
                    get_f32s(&r, t->frames_mean, (size_t)plane);
                if (has_delta)
                    get_f32s(&r, t->step_delta, (size_t)plane);
            }
        }
    }
    free(b);
    if (s != CSI_OK)
        csi_partial_release(out);
    return s;
}

const char *csi_partial_differs(const csi_partial *a, const csi_partial *b)
{
    if (strcmp(a->software, b->software))
        return "the software version";
    if (a->input_id != b->input_id)
        return "the input";
    wbuf wa = {0}, wb = {0};
    put_options(&wa, &a->options, false);
    put_options(&wb, &b->options, false);
    const bool same = !wa.oom && !wb.oom && wa.n == wb.n && !memcmp(wa.b, wb.b, wa.n);
    free(wa.b);
    free(wb.b);
    if (!same)
        return "the reconstruction options";
    if (!csi_tiling_equal(&a->tiling, &b->tiling))
        return "the tile layout";
    const csi_tile_scope *x = &a->scope, *y = &b->scope;
    if (x->k != y->k || x->n != y->n || x->channels != y->channels || x->has_scale != y->has_scale ||
        memcmp(x->scale, y->scale, sizeof x->scale))
        return "the whole problem's scale (--tile-scale)";
    if (strcmp(a->method, b->method))
        return "the method";
    return NULL;
}
