/* Tiles through the public API (csi/csi.h): the layout, the whole problem's scale, one tile's
 * reconstruction as a result, and the blend of a layout's tile results into the image. */
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

csi_status csi_tiling_get(csi_device *dev, const csi_samples *s, const csi_options *options, csi_tiling_info *out)
{
    CSI_TRY(csi_device_record(dev, check_args(dev, s, "csi_tiling_get")));
    if (!out)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tiling_get: out is NULL"));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_tiling_get", &o)));
    csi_tiling tl;
    CSI_TRY(csi_device_record(dev, csi_tiling_plan(dev->ctx, &s->grid, s->channels, s->count, &o, &tl)));
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

csi_status csi_tile_scale(csi_device *dev, const csi_samples *s, const csi_options *options, double scale[4])
{
    CSI_TRY(csi_device_record(dev, check_args(dev, s, "csi_tile_scale")));
    if (!scale)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_tile_scale: scale is NULL"));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_tile_scale", &o)));
    csi_tiling tl;
    csi_tile_scope scope;
    csi_status st = csi_tiling_plan(dev->ctx, &s->grid, s->channels, s->count, &o, &tl);
    if (st == CSI_OK)
        st = csi_tile_scope_make(dev->ctx, &s->grid, s->channels, s->pos, s->values, s->count, &o, &tl, &scope);
    if (st != CSI_OK)
        return csi_device_record(dev, st);
    for (int c = 0; c < 4; c++)
        scale[c] = scope.has_scale && c < (int)s->channels ? scope.scale[c] : 0;
    return CSI_OK;
}

csi_status csi_reconstruct_tile(csi_device *dev, const csi_samples *s, const csi_options *options, uint32_t index,
                                const double *scale, csi_progress_fn progress, void *user, csi_result **out)
{
    if (out)
        *out = NULL;
    CSI_TRY(csi_device_record(dev, check_args(dev, s, "csi_reconstruct_tile")));
    if (!out)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_reconstruct_tile: out is NULL"));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_reconstruct_tile", &o)));
    csi_api_progress pr = {progress, user};
    o.progress = progress ? csi_api_progress_relay : NULL;
    o.user = &pr;
    csi_result *r = calloc(1, sizeof *r);
    if (!r)
        return csi_device_record(dev, csi_fail(CSI_ERR_NOMEM, "out of host memory for a result"));
    csi_status st = csi_tiling_plan(dev->ctx, &s->grid, s->channels, s->count, &o, &r->tiling);
    if (st == CSI_OK && index >= r->tiling.count)
        st = csi_fail(CSI_ERR_ARG, "tile %u of a layout of %u tiles", index, r->tiling.count);
    if (st == CSI_OK && scale) {
        csi_tile_scope_init(&s->grid, s->channels, s->count, &r->scope);
        r->scope.has_scale = true;
        for (uint32_t c = 0; c < s->channels && c < 4; c++)
            r->scope.scale[c] = scale[c];
    } else if (st == CSI_OK) {
        st = csi_tile_scope_make(dev->ctx, &s->grid, s->channels, s->pos, s->values, s->count, &o, &r->tiling,
                                 &r->scope);
    }
    csi_tile_result t;
    memset(&t, 0, sizeof t);
    if (st == CSI_OK)
        st = csi_recon_tile(dev->ctx, &s->grid, s->channels, s->pos, s->values, s->count, &o,
                                         &r->tiling, &r->scope, index, &t);
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
    if (st == CSI_OK) {
        r = calloc(1, sizeof *r);
        if (!r)
            st = csi_fail(CSI_ERR_NOMEM, "out of host memory for a result");
    }
    csi_blend b;
    if (st == CSI_OK)
        st = csi_tiles_begin(&first->tiling, first->r.channels, frames, &b, &r->r);
    for (size_t i = 0; i < count && st == CSI_OK; i++) {
        const csi_result *t = sorted[i];
        csi_tile_result tr = t->tile;
        tr.r = t->r; /* a shallow view: csi_tiles_add only reads it */
        st = csi_tiles_add(&b, &tr);
    }
    if (st == CSI_OK)
        st = csi_tiles_end(&b);
    if (st == CSI_OK) {
        r->r.n = first->scope.n;
        r->r.options = first->r.options; /* tile 0's, with the autos it resolved */
        st = csi_result_finish(r, &first->tiling.grid);
    }
    free(sorted);
    if (st != CSI_OK) {
        csi_result_free(r);
        return st;
    }
    *out = r;
    return CSI_OK;
}
