/* Tiles through the public API (csi/csi.h): the layout (and where a tile lies), the whole
 * problem's scale, one tile's reconstruction as a result, and the blend of a layout's tile
 * results into the image. Partials, the tiles as files: partials.c. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "result.h"

static csi_status check_args(csi_device *dev, const csi_samples *s, const char *fn)
{
    if (!dev || !s)
        return csi_fail(CSI_ERR_ARG, "%s: %s is NULL", fn, !dev ? "the device" : "the samples");
    if (s->count && (!s->pos || !s->values))
        return csi_fail(CSI_ERR_ARG, "%s: %zu samples but no %s", fn, s->count, s->pos ? "values" : "positions");
    return CSI_OK;
}

/* The layout of a problem of n samples (a run's sizes: positions and values are not read). */
static csi_status layout_of(csi_device *dev, const csi_samples *s, size_t n, const csi_options *options,
                            const char *fn, csi_tiling *tl)
{
    if (!dev || !s)
        return csi_fail(CSI_ERR_ARG, "%s: %s is NULL", fn, !dev ? "the device" : "the samples");
    csi_recon_options o;
    CSI_TRY(csi_api_options_for(options, s, fn, &o));
    return csi_tiling_layout(dev->ctx, &s->grid, s->channels, n, &o, tl);
}

csi_status csi_tiling_get(csi_device *dev, const csi_samples *s, const csi_options *options, csi_tiling_info *out)
{
    if (!out)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tiling_get: out is NULL"));
    csi_tiling tl;
    CSI_TRY(csi_device_record(dev, layout_of(dev, s, s ? s->count : 0, options, "csi_tiling_get", &tl)));
    memset(out, 0, sizeof *out);
    out->count = tl.count;
    for (int a = 0; a < 3; a++) {
        out->n[a] = tl.n[a];
        out->window[a] = tl.window[a];
    }
    out->tile_bytes = tl.tile_bytes;
    out->whole_bytes = tl.whole_bytes;
    out->budget = tl.budget;
    return CSI_OK;
}

csi_status csi_tiling_stats(csi_device *dev, const csi_samples *s, const csi_options *options, csi_json *j)
{
    if (!j)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tiling_stats: j is NULL"));
    csi_tiling tl;
    CSI_TRY(csi_device_record(dev, layout_of(dev, s, s ? s->count : 0, options, "csi_tiling_stats", &tl)));
    csi_json_int(j, "tiles", tl.count);
    csi_json_int(j, "tiles_x", tl.n[0]);
    csi_json_int(j, "tiles_y", tl.n[1]);
    csi_json_int(j, "tiles_t", tl.n[2]);
    csi_json_int(j, "window_x", tl.window[0]);
    csi_json_int(j, "window_y", tl.window[1]);
    csi_json_int(j, "window_t", tl.window[2]);
    csi_json_int(j, "margin", tl.margin[0]);
    csi_json_int(j, "margin_t", tl.margin[2]);
    csi_json_int(j, "band", tl.band[0]);
    csi_json_int(j, "band_y", tl.band[1]);
    csi_json_int(j, "band_t", tl.band[2]);
    /* the grid the tiles lie on: the image's own, or padded for the FFT (cut at the merge; its
     * frames to the volume's own) */
    csi_json_int(j, "solved_out_w", tl.grid.out_w);
    csi_json_int(j, "solved_out_h", tl.grid.out_h);
    csi_json_int(j, "solved_t", tl.grid.t);
    static const char *names[3] = {"cores_x", "cores_y", "cores_t"};
    for (int a = 0; a < 3; a++) {
        char list[4096];
        size_t at = 0;
        const uint32_t stride = a == 0 ? 1 : a == 1 ? tl.n[0] : tl.n[0] * tl.n[1];
        for (uint32_t i = 0; i <= tl.n[a] && at < sizeof list - 16; i++) {
            csi_tile t;
            csi_tiling_tile(&tl, (i < tl.n[a] ? i : tl.n[a] - 1) * stride, &t);
            at += (size_t)snprintf(list + at, sizeof list - at, "%s%u", i ? "," : "",
                                   i < tl.n[a] ? t.core0[a] : t.core1[a]);
        }
        csi_json_str(j, names[a], list);
    }
    csi_json_int(j, "tile_bytes", (int64_t)tl.tile_bytes);
    csi_json_int(j, "whole_bytes", (int64_t)tl.whole_bytes);
    csi_json_int(j, "budget", (int64_t)tl.budget);
    return CSI_OK;
}

csi_status csi_tile_window(csi_device *dev, const csi_samples *s, const csi_options *options, uint32_t index,
                           uint32_t lo[3], uint32_t hi[3])
{
    if (!lo || !hi)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tile_window: %s is NULL", lo ? "hi" : "lo"));
    csi_tiling tl;
    CSI_TRY(csi_device_record(dev, layout_of(dev, s, s ? s->count : 0, options, "csi_tile_window", &tl)));
    if (index >= tl.count)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "tile %u of a layout of %u tiles", index, tl.count));
    csi_tile t;
    csi_tiling_tile(&tl, index, &t);
    const uint32_t cell[3] = {s->grid.w / s->grid.out_w, s->grid.h / s->grid.out_h, 1};
    for (int a = 0; a < 3; a++) {
        lo[a] = t.win0[a] * cell[a];
        hi[a] = lo[a] + tl.window[a] * cell[a];
    }
    /* the first window of an x/y column solves the binned shutter: the column's every frame */
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_tile_window", &o)));
    if (t.pos[2] == 0 && csi_tiling_image_binned(&tl, &o)) {
        lo[2] = 0;
        hi[2] = s->grid.t;
    }
    return CSI_OK;
}

csi_status csi_tile_scale(csi_device *dev, const csi_samples *s, const csi_options *options, double scale[4])
{
    CSI_TRY(csi_device_record(dev, check_args(dev, s, "csi_tile_scale")));
    if (!scale)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tile_scale: scale is NULL"));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_tile_scale", &o)));
    csi_tiling tl;
    csi_tile_scope scope;
    csi_status st = csi_tiling_layout(dev->ctx, &s->grid, s->channels, s->count, &o, &tl);
    if (st == CSI_OK)
        st = csi_tile_scope_make(dev->ctx, &tl.grid, s->channels, s->pos, s->values, s->count, &o, &tl, &scope);
    if (st != CSI_OK)
        return csi_device_record(dev, st);
    for (int c = 0; c < 4; c++)
        scale[c] = scope.has_scale && c < (int)s->channels ? scope.scale[c] : 0;
    return CSI_OK;
}

/* Tile `index` of a problem of `whole` samples from `s` (all of them, or those of the tile's
 * window); scale NULL: the whole's scale from s when s holds every sample, else none. */
static csi_status reconstruct_tile(csi_device *dev, const csi_samples *s, size_t whole, const csi_options *options,
                                   uint32_t index, const double *scale, csi_progress_fn progress, void *user,
                                   const char *fn, csi_result **out)
{
    if (out)
        *out = NULL;
    CSI_TRY(csi_device_record(dev, check_args(dev, s, fn)));
    if (!out)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "%s: out is NULL", fn));
    if (s->count > whole)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "%s: %zu samples of a problem of %zu", fn, s->count,
                                               whole));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, fn, &o)));
    csi_result *r = calloc(1, sizeof *r);
    if (!r)
        return csi_device_record(dev, csi_fail(CSI_ERR_NOMEM, "out of host memory for a result"));
    r->given = o;
    r->given.progress = NULL;
    r->given.user = NULL;
    csi_api_progress pr = {progress, user};
    o.progress = progress ? csi_api_progress_relay : NULL;
    o.user = &pr;
    /* the samples' noise, as csi_recon takes it from the whole's: here from the samples given */
    if (s->grid.t > 1)
        csi_recon_sample_noise(s->values, o.sample_variance, s->count, s->channels, o.sample_noise);
    csi_status st = csi_tiling_layout(dev->ctx, &s->grid, s->channels, whole, &o, &r->tiling);
    /* the grid the layout lies on (padded for the FFT or not): the samples are its cells too */
    const csi_grid *g = &r->tiling.grid;
    if (st == CSI_OK && index >= r->tiling.count)
        st = csi_fail(CSI_ERR_ARG, "tile %u of a layout of %u tiles", index, r->tiling.count);
    if (st == CSI_OK && s->count == whole) /* every sample: refused as the one-process run is */
        st = csi_tiling_check_samples(&r->tiling, s->pos, s->count);
    if (st == CSI_OK && (scale || s->count < whole)) {
        csi_tile_scope_init(g, s->channels, whole, &r->scope);
        r->scope.has_scale = scale != NULL;
        for (uint32_t c = 0; scale && c < s->channels && c < 4; c++)
            r->scope.scale[c] = scale[c];
    } else if (st == CSI_OK) {
        st = csi_tile_scope_make(dev->ctx, g, s->channels, s->pos, s->values, s->count, &o, &r->tiling,
                                 &r->scope);
    }
    csi_tile_result t;
    memset(&t, 0, sizeof t);
    if (st == CSI_OK)
        st = csi_recon_tile(dev->ctx, g, s->channels, s->pos, s->values, s->count, &o, &r->tiling,
                            &r->scope, index, &t);
    if (st == CSI_OK)
        st = csi_recon_reported(&o, &r->tiling, whole, &t.r.options, &r->reported);
    if (st == CSI_OK) {
        r->is_tile = true;
        r->r = t.r;
        r->tile = t;
        memset(&r->tile.r, 0, sizeof r->tile.r); /* the pixels are r->r's */
        st = csi_result_finish(r, &s->grid);
    }
    if (st != CSI_OK) {
        csi_result_free(r);
        return csi_device_record(dev, st);
    }
    *out = r;
    return CSI_OK;
}

csi_status csi_reconstruct_tile(csi_device *dev, const csi_samples *s, const csi_options *options, uint32_t index,
                                const double *scale, csi_progress_fn progress, void *user, csi_result **out)
{
    return reconstruct_tile(dev, s, s ? s->count : 0, options, index, scale, progress, user,
                            "csi_reconstruct_tile", out);
}

csi_status csi_reconstruct_tile_window(csi_device *dev, const csi_samples *s, size_t whole_count,
                                       const csi_options *options, uint32_t index, const double *scale,
                                       csi_progress_fn progress, void *user, csi_result **out)
{
    return reconstruct_tile(dev, s, whole_count, options, index, scale, progress, user,
                            "csi_reconstruct_tile_window", out);
}

csi_status csi_result_blend_begin(const csi_tiling *tl, uint32_t channels, bool frames, csi_blend *b,
                                  csi_result **out)
{
    *out = calloc(1, sizeof **out);
    if (!*out)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a result");
    return csi_tiles_begin(tl, channels, frames, b, &(*out)->r);
}

static int by_index(const void *a, const void *b)
{
    const csi_result *x = *(const csi_result *const *)a, *y = *(const csi_result *const *)b;
    return x->tile.index < y->tile.index ? -1 : x->tile.index > y->tile.index;
}

csi_status csi_tiles_blend(const csi_result *const *tiles, size_t count, csi_result **out)
{
    if (out)
        *out = NULL;
    if (!tiles || !out || count == 0)
        return csi_fail(CSI_ERR_ARG, "csi_tiles_blend: %s", !out ? "out is NULL" : "no tiles given");
    for (size_t i = 0; i < count; i++)
        if (!tiles[i] || !tiles[i]->is_tile)
            return csi_fail(CSI_ERR_ARG, "csi_tiles_blend: argument %zu is not a tile's result", i);
    const csi_result *first = tiles[0];
    if (count != first->tiling.count)
        return csi_fail(CSI_ERR_ARG, "%zu tiles given for a layout of %u", count, first->tiling.count);
    const csi_result **sorted = malloc(count * sizeof *sorted);
    if (!sorted)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu tiles", count);
    memcpy(sorted, tiles, count * sizeof *sorted);
    qsort(sorted, count, sizeof *sorted, by_index);
    csi_status st = CSI_OK;
    bool frames = true;
    for (size_t i = 0; i < count && st == CSI_OK; i++) {
        const csi_result *t = sorted[i];
        if (!csi_tiling_equal(&t->tiling, &first->tiling))
            st = csi_fail(CSI_ERR_ARG, "tile %u comes from another layout than tile %u", t->tile.index,
                          first->tile.index);
        else if (t->scope.n != first->scope.n || t->scope.has_scale != first->scope.has_scale ||
                 memcmp(t->scope.scale, first->scope.scale, sizeof t->scope.scale))
            st = csi_fail(CSI_ERR_ARG, "tile %u was made with another scale or samples than tile %u",
                          t->tile.index, first->tile.index);
        else if (t->tile.index != i)
            st = csi_fail(CSI_ERR_ARG, "tile %zu is %s", i, t->tile.index < i ? "given twice" : "missing");
        frames = frames && t->r.nframes > 0;
    }
    csi_result *r = NULL;
    csi_blend b = {.next = 0}; /* released below whatever happens */
    if (st == CSI_OK)
        st = csi_result_blend_begin(&first->tiling, first->r.channels, frames, &b, &r);
    for (size_t i = 0; i < count && st == CSI_OK; i++) {
        const csi_result *t = sorted[i];
        csi_tile_result tr = t->tile;
        tr.r = t->r; /* a shallow view: csi_tiles_add only reads it */
        st = csi_tiles_add(&b, &tr);
    }
    if (st == CSI_OK)
        st = csi_tiles_end(&b);
    csi_tiles_release(&b);
    if (st == CSI_OK) {
        r->r.n = first->scope.n;
        r->r.options = first->reported; /* what one process running the layout reports */
        const csi_grid image = csi_tiling_image_grid(&first->tiling);
        st = csi_result_finish(r, &image);
    }
    free(sorted);
    if (st != CSI_OK) {
        csi_result_free(r);
        return st;
    }
    *out = r;
    return CSI_OK;
}
