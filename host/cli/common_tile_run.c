/* The --tile and --tile-info runs of csi-reconstruct and csi-render (tile.h): the layout, the
 * whole problem's scale, one tile's reconstruction and its partial, all through csi/csi.h. */
#include "tile.h"

#include <stdlib.h>
#include <string.h>

/* The layout the run asks for: --tile I/N sets the option tiles to N. */
static csi_status tile_layout(const cli_tile_opts *t, csi_options *opt)
{
    char text[16];
    if (!t->one)
        return CSI_OK;
    snprintf(text, sizeof text, "%u", t->count);
    return csi_options_set(opt, "tiles", text);
}

/* --tile-scale's values, one per channel (the last given repeats), or NULL without it. */
static const double *given_scale(const cli_tile_opts *t, uint32_t channels, double scale[4])
{
    if (!t->have_scale)
        return NULL;
    for (uint32_t c = 0; c < 4; c++)
        scale[c] = c < channels ? t->scale[c < t->nscale ? c : t->nscale - 1] : 0;
    return scale;
}

/* --tile-info: the layout, the input's identity and the scale (NULL: none) as JSON on stdout. */
static csi_status tile_info_print(csi_device *dev, const csi_samples *s, const csi_options *opt, uint64_t input_id,
                                  const double *scale)
{
    csi_json *j = NULL;
    CSI_TRY(csi_json_new(&j));
    char id[24], text[128] = "";
    snprintf(id, sizeof id, "%016llx", (unsigned long long)input_id);
    bool any = false; /* a scale of zeros is none: each tile then scales tau by its own samples */
    for (uint32_t c = 0; scale && c < s->channels && c < 4; c++)
        any = any || scale[c] != 0;
    size_t at = 0;
    for (uint32_t c = 0; any && c < s->channels && c < 4 && at < sizeof text; c++)
        at += (size_t)snprintf(text + at, sizeof text - at, "%s%.17g", c ? "," : "", scale[c]);
    csi_status st = csi_tiling_stats(dev, s, opt, j);
    if (st == CSI_OK) {
        char frames[8];
        cli_json_grid(j, &s->grid);
        csi_json_int(j, "samples", (int64_t)s->count);
        csi_json_str(j, "input_id", id);
        /* the value of --tile-scale, exact (17 digits round-trip a double) */
        csi_json_str(j, "tile_scale", any ? text : NULL);
        csi_json_bool(j, "frames", csi_options_get(opt, "frames", frames, sizeof frames) == CSI_OK &&
                                       !strcmp(frames, "on"));
        const char *out = NULL;
        st = csi_json_text(j, &out);
        if (st == CSI_OK)
            fputs(out, stdout);
    }
    csi_json_free(j);
    return st;
}

/* The tile's partial and statistics (add: the program's own members first), all or nothing. */
static csi_status tile_outputs(csi_outset *set, const cli_outputs *outs, const csi_result *tile, const char *input,
                               uint64_t id, const char *method, void (*add)(csi_json *j, const void *user),
                               const void *user)
{
    const char *tmp = NULL;
    csi_status s = CSI_OK;
    if (outs->exr)
        s = csi_outset_tmp(set, outs->exr, &tmp);
    if (s == CSI_OK && tmp)
        s = cli_named(csi_partial_write(tmp, tile, input, id, method), tmp, outs->exr);
    if (s == CSI_OK && outs->stats) {
        csi_json *j = NULL;
        s = csi_json_new(&j);
        if (s == CSI_OK) {
            add(j, user);
            csi_result_stats(tile, j);
            csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
            s = cli_write_stats(set, outs->stats, j);
        }
        csi_json_free(j);
    }
    return s == CSI_OK ? csi_outset_commit(set) : s;
}

typedef struct {
    const char *input;
    const csi_result_info *info;
    double t0;
} samples_stats;

static void add_samples_stats(csi_json *j, const void *user)
{
    const samples_stats *u = user;
    csi_json_str(j, "tool", "csi-reconstruct");
    csi_json_str(j, "input", u->input);
    csi_json_int(j, "tile_count", u->info->tiles);
    csi_json_int(j, "window_x0", u->info->tile_origin[0]);
    csi_json_int(j, "window_y0", u->info->tile_origin[1]);
    csi_json_int(j, "window_t0", u->info->tile_origin[2]);
    csi_json_num(j, "t_wall_s", cli_now() - u->t0);
}

int cli_tile_run_samples(const char *prog, csi_device *dev, csi_outset *set, const csi_samples *smp,
                         const char *input, csi_options *opt, const cli_tile_opts *tile, const cli_outputs *outs,
                         bool quiet, cli_recon_progress *progress)
{
    const uint64_t id = csi_samples_id(smp);
    double given[4], whole[4];
    const double *scale = given_scale(tile, smp->channels, given);
    csi_status s = tile_layout(tile, opt);
    if (s == CSI_OK && tile->info) {
        if (!scale && (s = csi_tile_scale(dev, smp, opt, whole)) == CSI_OK)
            scale = whole;
        if (s == CSI_OK)
            s = tile_info_print(dev, smp, opt, id, scale);
    }
    if (s != CSI_OK || tile->info)
        return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", input, cli_last_error());
    const double t0 = cli_now();
    csi_result *res = NULL;
    s = csi_reconstruct_tile(dev, smp, opt, tile->index, scale, cli_recon_progress_fn, progress, &res);
    if (progress)
        cli_progress_end(progress->bar);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s: %s", input, cli_last_error());
    csi_result_info info;
    csi_result_info_get(res, &info);
    const samples_stats u = {input, &info, t0};
    s = tile_outputs(set, outs, res, input, id, NULL, add_samples_stats, &u);
    if (s == CSI_OK && !quiet) {
        csi_image view;
        csi_result_image(res, &view);
        fprintf(stderr, "%s: tile %u/%u (%ux%u pixels at %u,%u) from %zu samples in %.2f s\n", prog, tile->index,
                info.tiles, view.w, view.h, info.tile_origin[0], info.tile_origin[1], info.n, cli_now() - t0);
    }
    csi_result_free(res);
    return s == CSI_OK ? 0 : cli_error(prog, s, "%s", cli_last_error());
}

/* The input's identity for csi-render's partials: the scene file's bytes and what decides the
 * samples. */
static csi_status render_id(const char *scene_path, const csi_grid *g, const csi_pos_opts *po, uint64_t *id)
{
    FILE *fp = fopen(scene_path, "rb");
    if (!fp)
        return cli_fail(CSI_ERR_IO, "%s: cannot open", scene_path);
    uint64_t h = 0x637369726e646572ull; /* "csirnder" */
    unsigned char buf[1 << 16];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, fp)) > 0)
        h = csi_hash64(h, buf, got);
    fclose(fp);
    const uint64_t fields[9] = {g->w, g->h, g->t, g->out_w, g->out_h, (uint64_t)po->method, po->spp, po->seed,
                                (uint64_t)(po->fraction * 1e9)};
    *id = csi_hash64(h, fields, sizeof fields);
    return CSI_OK;
}

typedef struct {
    const char *scene;
    const csi_result_info *info;
    size_t m;
    double t_render;
} render_stats;

static void add_render_stats(csi_json *j, const void *user)
{
    const render_stats *u = user;
    csi_json_str(j, "tool", "csi-render");
    csi_json_str(j, "scene", u->scene);
    csi_json_int(j, "tile_count", u->info->tiles);
    csi_json_int(j, "samples", (int64_t)u->m);
    csi_json_num(j, "t_render_s", u->t_render);
}

static bool in_window(csi_sample_pos p, const uint32_t lo[3], const uint32_t hi[3])
{
    return p.x >= lo[0] && p.x < hi[0] && p.y >= lo[1] && p.y < hi[1] && p.t >= lo[2] && p.t < hi[2];
}

int cli_tile_run_render(const char *prog, csi_device *dev, csi_outset *set, const char *scene_path,
                        const csi_grid *grid, const csi_pos_opts *po, const csi_sample_pos *pos, size_t n,
                        uint32_t sample_flags, csi_options *opt, const cli_tile_opts *tile,
                        const cli_outputs *outs, bool quiet, cli_recon_progress *progress, cli_tile_eval_fn eval,
                        void *user)
{
    uint64_t id;
    double given[4];
    const double *scale = given_scale(tile, 3, given); /* none: each tile scales tau by its own samples */
    const csi_samples whole = {*grid, 3, n, pos, NULL, sample_flags, NULL}; /* the run's sizes: no values yet */
    csi_status s = render_id(scene_path, grid, po, &id);
    if (s == CSI_OK)
        s = tile_layout(tile, opt);
    if (s == CSI_OK && tile->info)
        s = tile_info_print(dev, &whole, opt, id, scale);
    if (s != CSI_OK || tile->info)
        return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
    uint32_t lo[3], hi[3];
    s = csi_tile_window(dev, &whole, opt, tile->index, lo, hi);
    if (s != CSI_OK)
        return cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        m += in_window(pos[i], lo, hi);
    csi_sample_pos *sub = malloc((m ? m : 1) * sizeof *sub);
    uint64_t *ids = malloc((m ? m : 1) * sizeof *ids);
    float *rgb = malloc((m ? m : 1) * 3 * sizeof *rgb);
    if (!sub || !ids || !rgb)
        s = cli_fail(CSI_ERR_NOMEM, "out of host memory for the %zu samples of tile %u", m, tile->index);
    for (size_t i = 0, j = 0; i < n && s == CSI_OK; i++)
        if (in_window(pos[i], lo, hi)) {
            sub[j] = pos[i];
            ids[j++] = i;
        }
    const double tstart = cli_now();
    if (s == CSI_OK)
        s = eval(user, sub, ids, m, rgb);
    const double t_render = cli_now() - tstart;
    csi_result *res = NULL;
    if (s == CSI_OK)
        s = csi_reconstruct_tile_window(dev, &(csi_samples){*grid, 3, m, sub, rgb, sample_flags, NULL}, n, opt,
                                        tile->index, scale, cli_recon_progress_fn, progress, &res);
    if (progress)
        cli_progress_end(progress->bar);
    csi_result_info info = {0};
    if (s == CSI_OK) {
        csi_result_info_get(res, &info);
        char mdesc[96];
        snprintf(mdesc, sizeof mdesc, "%s, %s positions", info.method, csi_pos_method_name(po->method));
        const render_stats u = {scene_path, &info, m, t_render};
        s = tile_outputs(set, outs, res, scene_path, id, mdesc, add_render_stats, &u);
    }
    if (s == CSI_OK && !quiet) {
        csi_image view;
        csi_result_image(res, &view);
        fprintf(stderr, "%s: tile %u/%u (%ux%u pixels at %u,%u): %zu samples, render %.2f s, reconstruct %.2f s\n",
                prog, tile->index, info.tiles, view.w, view.h, info.tile_origin[0], info.tile_origin[1], m, t_render,
                cli_now() - tstart - t_render);
    }
    csi_result_free(res);
    free(sub);
    free(ids);
    free(rgb);
    return s == CSI_OK ? 0 : cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
}
