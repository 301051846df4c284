/* The --tile and --tile-info runs of csi-reconstruct and csi-render (tile.h): the layout, the
 * whole problem's scope, one tile's reconstruction and its partial (partial.h). Built on the
 * library's internal headers (tile.h says why); the programs call it with csi.h's types. */
#include "tile.h"

#include <stdlib.h>
#include <string.h>

#include "../api/result.h" /* the device's and options' internals, csi_result_adopt */
#include "csi/stats.h"
#include "csi/tiles.h"
#include "partial.h"

static csi_status cli_tile_layout(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const cli_tile_opts *t, csi_recon_options *opt, csi_tiling *tl)
{
    if (t->one)
        opt->tiles = t->count;
    CSI_TRY(csi_tiling_plan(ctx, g, channels, n, opt, tl));
    if (t->one && t->index >= tl->count)
        return csi_fail(CSI_ERR_ARG, "--tile %u/%u: the layout has %u tiles", t->index, t->count, tl->count);
    return CSI_OK;
}

static bool cli_tile_given_scope(const cli_tile_opts *t, const csi_grid *g, uint32_t channels, size_t n,
                          csi_tile_scope *scope)
{
    if (!t->have_scale)
        return false;
    csi_tile_scope_init(g, channels, n, scope);
    scope->has_scale = true;
    for (uint32_t c = 0; c < channels && c < 4; c++)
        scope->scale[c] = t->scale[c < t->nscale ? c : t->nscale - 1];
    return true;
}

static csi_status cli_tile_info_print(const csi_tiling *tl, const csi_tile_scope *scope,
                               const csi_recon_options *opt, uint64_t input_id)
{
    csi_json *j = NULL;
    CSI_TRY(csi_json_new(&j));
    char id[24], scale[128] = "";
    snprintf(id, sizeof id, "%016llx", (unsigned long long)input_id);
    size_t at = 0;
    for (uint32_t c = 0; scope->has_scale && c < scope->channels && at < sizeof scale; c++)
        at += (size_t)snprintf(scale + at, sizeof scale - at, "%s%.17g", c ? "," : "", scope->scale[c]);
    csi_json_int(j, "tiles", tl->count);
    csi_json_int(j, "tiles_x", tl->n[0]);
    csi_json_int(j, "tiles_y", tl->n[1]);
    csi_json_int(j, "tiles_t", tl->n[2]);
    csi_json_int(j, "window_x", tl->window[0]);
    csi_json_int(j, "window_y", tl->window[1]);
    csi_json_int(j, "window_t", tl->window[2]);
    csi_json_int(j, "margin", tl->margin[0]);
    csi_json_int(j, "margin_t", tl->margin[2]);
    csi_json_int(j, "band", tl->band[0]);
    csi_json_int(j, "band_y", tl->band[1]);
    csi_json_int(j, "band_t", tl->band[2]);
    /* the core boundaries along each axis, "0,64,128", for tools that look at the seams */
    static const char *names[3] = {"cores_x", "cores_y", "cores_t"};
    for (int a = 0; a < 3; a++) {
        char list[4096];
        size_t at = 0;
        const uint32_t stride = a == 0 ? 1 : a == 1 ? tl->n[0] : tl->n[0] * tl->n[1];
        for (uint32_t i = 0; i <= tl->n[a] && at < sizeof list - 16; i++) {
            csi_tile t;
            csi_tiling_tile(tl, (i < tl->n[a] ? i : tl->n[a] - 1) * stride, &t);
            at += (size_t)snprintf(list + at, sizeof list - at, "%s%u", i ? "," : "", i < tl->n[a] ? t.core0[a] : t.core1[a]);
        }
        csi_json_str(j, names[a], list);
    }
    csi_json_int(j, "tile_bytes", (int64_t)tl->tile_bytes);
    csi_json_int(j, "whole_bytes", (int64_t)tl->whole_bytes);
    csi_json_int(j, "budget", (int64_t)tl->budget);
    cli_json_grid(j, &tl->grid);
    csi_json_int(j, "samples", (int64_t)scope->n);
    csi_json_str(j, "input_id", id);
    /* the value of --tile-scale, exact (17 digits round-trip a double) */
    csi_json_str(j, "tile_scale", scope->has_scale ? scale : NULL);
    csi_json_bool(j, "frames", opt->frames);
    const char *text = NULL;
    csi_status s = csi_json_text(j, &text);
    if (s == CSI_OK)
        fputs(text, stdout);
    csi_json_free(j);
    return s;
}

static csi_status cli_tile_write(const char *path, const char *method, const char *input_name,
                          uint64_t input_id, const csi_recon_options *opt, const csi_tiling *tl,
                          const csi_tile_scope *scope, const csi_tile_result *res)
{
    cli_partial p;
    memset(&p, 0, sizeof p);
    snprintf(p.software, sizeof p.software, "csi %s", CSI_VERSION);
    snprintf(p.method, sizeof p.method, "%s", method);
    const char *base = strrchr(input_name, '/');
    snprintf(p.input, sizeof p.input, "%s", base ? base + 1 : input_name);
    p.input_id = input_id;
    p.options = *opt;
    p.options.progress = NULL;
    p.options.user = NULL;
    p.tiling = *tl;
    p.scope = *scope;
    p.tile = *res; /* borrowed: not freed here */
    return cli_partial_write(path, &p);
}

/* The statistics of a tile run: the program's own members (add), then the tile's figures. */
static csi_status tile_stats(csi_outset *set, const char *path, csi_tile_result *res, const csi_grid *g,
                             void (*add)(csi_json *j, const void *user), const void *user)
{
    csi_result *r = NULL;
    csi_json *j = NULL;
    csi_recon_result copy = res->r; /* the stats read the result; the caller frees res */
    memset(&res->r, 0, sizeof res->r);
    csi_status s = csi_result_adopt(&copy, g, &r);
    if (s == CSI_OK)
        s = csi_json_new(&j);
    if (s == CSI_OK) {
        add(j, user);
        csi_result_stats(r, j);
        csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
        s = cli_write_stats(set, path, j);
    }
    csi_json_free(j);
    csi_result_free(r);
    return s;
}

/* A 64-bit identity of the samples: the grid, channels, positions and values. */
static uint64_t samples_id(const csi_samples *s)
{
    uint64_t id = cli_hash64(0, &s->grid, sizeof s->grid);
    id = cli_hash64(id, &s->channels, sizeof s->channels);
    for (size_t i = 0; i < s->count; i++) {
        const uint32_t xyt[3] = {s->pos[i].x, s->pos[i].y, s->pos[i].t};
        id = cli_hash64(id, xyt, sizeof xyt);
    }
    id = cli_hash64(id, s->values, s->count * s->channels * sizeof(float));
    /* what the samples are decides correct = auto; 0 leaves the ids of earlier partials as they were */
    return s->flags ? cli_hash64(id, &s->flags, sizeof s->flags) : id;
}

typedef struct {
    const char *input;
    const cli_tile_opts *t;
    const csi_tiling *tl;
    const csi_tile_result *res;
    double t0;
} samples_stats;

static void add_samples_stats(csi_json *j, const void *user)
{
    const samples_stats *u = user;
    csi_json_str(j, "tool", "csi-reconstruct");
    csi_json_str(j, "input", u->input);
    csi_json_int(j, "tile", u->t->index);
    csi_json_int(j, "tile_count", u->tl->count);
    csi_json_int(j, "window_x0", u->res->x0);
    csi_json_int(j, "window_y0", u->res->y0);
    csi_json_int(j, "window_t0", u->res->t0);
    csi_json_num(j, "t_wall_s", cli_now() - u->t0);
}

int cli_tile_run_samples(const char *prog, csi_device *dev, csi_outset *set, const csi_samples *smp,
                         const char *input, csi_options *options, const cli_tile_opts *tile, const cli_outputs *outs,
                         bool quiet)
{
    csi_recon_options *opt = &options->o;
    if (smp->flags & ~(uint32_t)CSI_SAMPLES_KNOWN_FLAGS)
        return cli_error(prog, CSI_ERR_ARG, "%s: the samples' flags 0x%08x have reserved bits set", input,
                         (unsigned)smp->flags);
    opt->sample_flags = smp->flags;
    const uint64_t id = samples_id(smp);
    csi_tiling tl;
    csi_status s = cli_tile_layout(dev->ctx, &smp->grid, smp->channels, smp->count, tile, opt, &tl);
    csi_tile_scope scope;
    if (s == CSI_OK && !cli_tile_given_scope(tile, &smp->grid, smp->channels, smp->count, &scope))
        s = csi_tile_scope_make(dev->ctx, &smp->grid, smp->channels, smp->pos, smp->values, smp->count, opt, &tl,
                                &scope);
    if (s == CSI_OK && tile->info)
        s = cli_tile_info_print(&tl, &scope, opt, id);
    if (s != CSI_OK || tile->info)
        return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", input, cli_last_error());
    const double t0 = cli_now();
    csi_tile_result res;
    s = csi_recon_tile(dev->ctx, &smp->grid, smp->channels, smp->pos, smp->values, smp->count, opt, &tl, &scope,
                       tile->index, &res);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s: %s", input, cli_last_error());
    const uint32_t out_w = res.r.out_w, out_h = res.r.out_h;
    const size_t n = res.r.n;
    const char *tmp = NULL;
    if (outs->exr) /* the partial and the stats, all or nothing (csi_outset) */
        s = csi_outset_tmp(set, outs->exr, &tmp);
    if (s == CSI_OK && tmp)
        s = cli_named(cli_tile_write(tmp, csi_result_method_of(opt, &smp->grid), input, id, opt, &tl, &scope, &res),
                      tmp, outs->exr);
    if (s == CSI_OK && outs->stats) {
        const samples_stats u = {input, tile, &tl, &res, t0};
        s = tile_stats(set, outs->stats, &res, &smp->grid, add_samples_stats, &u);
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s == CSI_OK && !quiet)
        fprintf(stderr, "%s: tile %u/%u (%ux%u pixels at %u,%u) from %zu samples in %.2f s\n", prog, tile->index,
                tl.count, out_w, out_h, res.x0, res.y0, n, cli_now() - t0);
    csi_tile_result_free(&res);
    return s == CSI_OK ? 0 : cli_error(prog, s, "%s", cli_last_error());
}

/* The input's identity for csi-render's partials: the scene file's bytes and what decides the
 * samples. */
static csi_status render_id(const char *scene_path, const csi_grid *g, const csi_pos_opts *po, uint64_t *id)
{
    FILE *fp = fopen(scene_path, "rb");
    if (!fp)
        return csi_fail(CSI_ERR_IO, "%s: cannot open", scene_path);
    uint64_t h = 0x637369726e646572ull; /* "csirnder" */
    unsigned char buf[1 << 16];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, fp)) > 0)
        h = cli_hash64(h, buf, got);
    fclose(fp);
    const uint64_t fields[9] = {g->w, g->h, g->t, g->out_w, g->out_h, (uint64_t)po->method, po->spp, po->seed,
                                (uint64_t)(po->fraction * 1e9)};
    *id = cli_hash64(h, fields, sizeof fields);
    return CSI_OK;
}

typedef struct {
    const char *scene;
    const cli_tile_opts *t;
    const csi_tiling *tl;
    size_t m;
    double t_render;
} render_stats;

static void add_render_stats(csi_json *j, const void *user)
{
    const render_stats *u = user;
    csi_json_str(j, "tool", "csi-render");
    csi_json_str(j, "scene", u->scene);
    csi_json_int(j, "tile", u->t->index);
    csi_json_int(j, "tile_count", u->tl->count);
    csi_json_int(j, "samples", (int64_t)u->m);
    csi_json_num(j, "t_render_s", u->t_render);
}

static bool in_window(csi_sample_pos p, const uint32_t lo[3], const uint32_t hi[3])
{
    return p.x >= lo[0] && p.x < hi[0] && p.y >= lo[1] && p.y < hi[1] && p.t >= lo[2] && p.t < hi[2];
}

int cli_tile_run_render(const char *prog, csi_device *dev, csi_outset *set, const char *scene_path,
                        const csi_grid *grid, const csi_pos_opts *po, const csi_sample_pos *pos, size_t n,
                        uint32_t sample_flags, csi_options *options, const cli_tile_opts *tile,
                        const cli_outputs *outs, bool quiet, cli_tile_eval_fn eval, void *user)
{
    csi_recon_options *opt = &options->o;
    opt->sample_flags = sample_flags;
    uint64_t id;
    csi_tiling tl;
    csi_status s = render_id(scene_path, grid, po, &id);
    if (s == CSI_OK)
        s = cli_tile_layout(dev->ctx, grid, 3, n, tile, opt, &tl);
    csi_tile_scope scope;
    if (s == CSI_OK && !cli_tile_given_scope(tile, grid, 3, n, &scope))
        csi_tile_scope_init(grid, 3, n, &scope); /* each tile scales tau by its own samples */
    if (s == CSI_OK && tile->info)
        s = cli_tile_info_print(&tl, &scope, opt, id);
    if (s != CSI_OK || tile->info)
        return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
    csi_tile t;
    csi_tiling_tile(&tl, tile->index, &t);
    const uint32_t bw = grid->w / grid->out_w, bh = grid->h / grid->out_h;
    const uint32_t lo[3] = {t.win0[0] * bw, t.win0[1] * bh, t.win0[2]};
    const uint32_t hi[3] = {lo[0] + tl.window[0] * bw, lo[1] + tl.window[1] * bh, lo[2] + tl.window[2]};
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += in_window(pos[i], lo, hi);
    csi_sample_pos *sub = malloc((m ? m : 1) * sizeof *sub);
    uint64_t *ids = malloc((m ? m : 1) * sizeof *ids);
    float *rgb = malloc((m ? m : 1) * 3 * sizeof *rgb);
    if (!sub || !ids || !rgb)
        s = csi_fail(CSI_ERR_NOMEM, "out of host memory for the %zu samples of tile %u", m, tile->index);
    for (size_t i = 0, j = 0; i < n && s == CSI_OK; i++)
        if (in_window(pos[i], lo, hi)) {
            sub[j] = pos[i];
            ids[j++] = i;
        }
    const double tstart = cli_now();
    if (s == CSI_OK)
        s = eval(user, sub, ids, m, rgb);
    const double t_render = cli_now() - tstart;
    csi_tile_result res;
    memset(&res, 0, sizeof res);
    if (s == CSI_OK)
        s = csi_recon_tile(dev->ctx, grid, 3, sub, rgb, m, opt, &tl, &scope, tile->index, &res);
    char mdesc[96];
    snprintf(mdesc, sizeof mdesc, "%s, %s positions", csi_result_method_of(opt, grid), csi_pos_method_name(po->method));
    const char *tmp = NULL;
    if (s == CSI_OK && outs->exr) /* the partial and the stats, all or nothing (csi_outset) */
        s = csi_outset_tmp(set, outs->exr, &tmp);
    if (s == CSI_OK && tmp)
        s = cli_named(cli_tile_write(tmp, mdesc, scene_path, id, opt, &tl, &scope, &res), tmp, outs->exr);
    if (s == CSI_OK && outs->stats) {
        const render_stats u = {scene_path, tile, &tl, m, t_render};
        s = tile_stats(set, outs->stats, &res, grid, add_render_stats, &u);
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s == CSI_OK && !quiet)
        fprintf(stderr, "%s: tile %u/%u (%ux%u pixels at %u,%u): %zu samples, render %.2f s, reconstruct %.2f s\n",
                prog, tile->index, tl.count, tl.window[0], tl.window[1], t.win0[0], t.win0[1], m, t_render,
                cli_now() - tstart - t_render);
    csi_tile_result_free(&res);
    free(sub);
    free(ids);
    free(rgb);
    return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
}
