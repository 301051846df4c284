/* The tile options of csi-reconstruct and csi-render (tile.h). */
#include "tile.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "csi/stats.h"

void cli_tile_usage(FILE *f)
{
    fputs(
"tiles on several processes or machines (docs/tiles.md):\n"
"      --tile I/N            reconstruct only tile I (0 <= I < N) of a layout of N tiles and\n"
"                            write it to -o as a partial; csi-merge blends the N partials into\n"
"                            the image (the same bits as one process tiling by itself)\n"
"      --tile-scale S[,S..]  the whole problem's tau scale per channel, as --tile-info prints it\n"
"                            (without it, each --tile run computes it from all the samples)\n"
"      --tile-info           print the layout and the scale as JSON and exit (with --tiles N,\n"
"                            or the layout the budget needs)\n"
"      --partial-frames      with --tile on a volume: keep the window's frames in the partial\n"
"                            (for csi-merge --frames)\n", f);
}

int cli_tile_option(const char *prog, int c, const char *optarg, cli_tile_opts *t)
{
    switch (c) {
    case CLI_O_TILE: {
        char a[32] = "";
        const char *slash = strchr(optarg, '/');
        uint64_t i, n;
        if (!slash || (size_t)(slash - optarg) >= sizeof a)
            return cli_error(prog, CSI_ERR_ARG, "--tile: '%s' is not I/N", optarg);
        memcpy(a, optarg, (size_t)(slash - optarg));
        if (!cli_parse_u64(a, 0, (1u << 20) - 1, &i) || !cli_parse_u64(slash + 1, 1, 1u << 20, &n) || i >= n)
            return cli_error(prog, CSI_ERR_ARG, "--tile: '%s' is not I/N with 0 <= I < N <= 2^20", optarg);
        t->one = true;
        t->index = (uint32_t)i;
        t->count = (uint32_t)n;
        return 0;
    }
    case CLI_O_TILE_SCALE: {
        const char *p = optarg;
        t->nscale = 0;
        while (*p) {
            char *end;
            errno = 0;
            double v = strtod(p, &end);
            if (end == p || errno || !isfinite(v) || v < 0 || t->nscale == 4 || (*end && *end != ','))
                return cli_error(prog, CSI_ERR_ARG, "--tile-scale: '%s' is not 1 to 4 numbers >= 0 separated "
                                 "by commas", optarg);
            t->scale[t->nscale++] = v;
            p = *end ? end + 1 : end;
        }
        if (t->nscale == 0)
            return cli_error(prog, CSI_ERR_ARG, "--tile-scale: no value given");
        t->have_scale = true;
        return 0;
    }
    case CLI_O_TILE_INFO: t->info = true; return 0;
    case CLI_O_PARTIAL_FRAMES: t->frames = true; return 0;
    default: return -1;
    }
}

int cli_tile_check(const char *prog, const cli_tile_opts *t, bool png, bool frames_dir)
{
    if (t->one && t->info)
        return cli_error(prog, CSI_ERR_ARG, "--tile and --tile-info exclude each other");
    if (t->one && (png || frames_dir))
        return cli_error(prog, CSI_ERR_ARG, "--tile writes a partial to -o; --png and --frames belong to "
                         "csi-merge (use --partial-frames to keep the frames)");
    if ((t->have_scale || t->frames) && !t->one && !t->info)
        return cli_error(prog, CSI_ERR_ARG, "--%s applies to --tile runs only",
                         t->have_scale ? "tile-scale" : "partial-frames");
    return 0;
}

csi_status cli_tile_layout(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                           const cli_tile_opts *t, csi_recon_options *opt, csi_tiling *tl)
{
    if (t->one)
        opt->tiles = t->count;
    CSI_TRY(csi_tiling_plan(ctx, g, channels, n, opt, tl));
    if (t->one && t->index >= tl->count)
        return csi_fail(CSI_ERR_ARG, "--tile %u/%u: the layout has %u tiles", t->index, t->count, tl->count);
    return CSI_OK;
}

bool cli_tile_given_scope(const cli_tile_opts *t, const csi_grid *g, uint32_t channels, size_t n,
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

csi_status cli_tile_info_print(const csi_tiling *tl, const csi_tile_scope *scope,
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
    csi_json_int(j, "out_w", tl->grid.out_w);
    csi_json_int(j, "out_h", tl->grid.out_h);
    csi_json_int(j, "grid_w", tl->grid.w);
    csi_json_int(j, "grid_h", tl->grid.h);
    csi_json_int(j, "grid_t", tl->grid.t);
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

csi_status cli_tile_write(const char *path, const char *method, const char *input_name,
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
