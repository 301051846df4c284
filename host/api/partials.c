/* Tiles as separate jobs through the public API (csi/csi.h): a tile's result written as a partial
 * and read back, and the merge of one run's partials into the image (the format: partial.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "partial.h"
#include "result.h"

uint64_t csi_samples_id(const csi_samples *s)
{
    if (!s)
        return 0;
    uint64_t id = csi_hash64(0, &s->grid, sizeof s->grid);
    id = csi_hash64(id, &s->channels, sizeof s->channels);
    for (size_t i = 0; i < s->count; i++) {
        const uint32_t xyt[3] = {s->pos[i].x, s->pos[i].y, s->pos[i].t};
        id = csi_hash64(id, xyt, sizeof xyt);
    }
    id = csi_hash64(id, s->values, s->count * s->channels * sizeof(float));
    /* the samples' variances change the result: tiles run with and without them do not merge */
    if (s->variance)
        id = csi_hash64(id, s->variance, s->count * s->channels * sizeof(float));
    /* what the samples are decides correct = auto; 0 leaves the ids of earlier partials as they were */
    return s->flags ? csi_hash64(id, &s->flags, sizeof s->flags) : id;
}

csi_status csi_partial_write(const char *path, const csi_result *tile, const char *input, uint64_t input_id,
                             const char *method)
{
    if (!path || !tile || !input)
        return csi_fail(CSI_ERR_ARG, "csi_partial_write: %s is NULL", !path ? "the path" : !tile ? "the tile" : "input");
    if (!tile->is_tile)
        return csi_fail(CSI_ERR_ARG, "%s: the result is not a tile's (csi_reconstruct_tile)", path);
    csi_partial p;
    memset(&p, 0, sizeof p);
    snprintf(p.software, sizeof p.software, "csi %s", csi_version());
    snprintf(p.method, sizeof p.method, "%s", method ? method : tile->method);
    const char *base = strrchr(input, '/');
    snprintf(p.input, sizeof p.input, "%s", base ? base + 1 : input);
    p.input_id = input_id;
    p.options = tile->given;
    p.reported = tile->reported;
    p.tiling = tile->tiling;
    p.scope = tile->scope;
    p.tile = tile->tile;
    p.tile.r = tile->r; /* borrowed: written, not freed */
    return csi_partial_store(path, &p);
}

static void info_of(const csi_partial *p, csi_partial_info *out)
{
    memset(out, 0, sizeof *out);
    memcpy(out->software, p->software, sizeof out->software);
    memcpy(out->method, p->method, sizeof out->method);
    memcpy(out->input, p->input, sizeof out->input);
    out->input_id = p->input_id;
    out->tile_index = p->tile.index;
    out->tile_count = p->tiling.count;
    out->grid = csi_tiling_image_grid(&p->tiling);
    out->channels = p->scope.channels;
    out->frames = p->tile.r.nframes;
    out->samples = p->scope.n;
}

csi_status csi_partial_read_info(const char *path, csi_partial_info *out)
{
    if (!path || !out)
        return csi_fail(CSI_ERR_ARG, "csi_partial_read_info: %s is NULL", path ? "out" : "the path");
    csi_partial p;
    CSI_TRY(csi_partial_load(path, false, &p));
    info_of(&p, out);
    csi_partial_release(&p);
    return CSI_OK;
}

csi_status csi_partial_read(const char *path, csi_result **out, csi_partial_info *info)
{
    if (out)
        *out = NULL;
    if (!path || !out)
        return csi_fail(CSI_ERR_ARG, "csi_partial_read: %s is NULL", path ? "out" : "the path");
    csi_partial p;
    CSI_TRY(csi_partial_load(path, true, &p));
    if (info)
        info_of(&p, info);
    csi_result *r = calloc(1, sizeof *r);
    if (!r) {
        csi_partial_release(&p);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a result");
    }
    r->is_tile = true;
    r->tiling = p.tiling;
    r->scope = p.scope;
    r->given = p.options;
    r->reported = p.reported;
    r->r = p.tile.r;
    r->tile = p.tile;
    memset(&r->tile.r, 0, sizeof r->tile.r); /* the pixels are r->r's */
    const csi_grid image = csi_tiling_image_grid(&p.tiling);
    const csi_status st = csi_result_finish(r, &image);
    if (st != CSI_OK) {
        csi_result_free(r);
        return st;
    }
    *out = r;
    return CSI_OK;
}

static int cmp_u32(const void *a, const void *b)
{
    const uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

/* Pass 1 of a merge: every partial's header (its checksum verified), all of paths[0]'s run, each
 * tile once and none missing; by_index[i] = the path of tile i. With fewer paths than the layout
 * has tiles, by_index is NULL (the count comes from a file, so nothing is allocated by it) and the
 * tiles given are compared among themselves to name the first one missing. */
static csi_status merge_check(const char *const *paths, size_t count, const csi_partial *first,
                              const char **by_index)
{
    uint32_t *given = malloc(count * sizeof *given);
    if (!given)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu tiles", count);
    for (size_t a = 0; a < count; a++) {
        csi_partial p;
        csi_status st = csi_partial_load(paths[a], false, &p);
        if (st != CSI_OK) {
            free(given);
            return st;
        }
        const char *diff = csi_partial_differs(first, &p);
        const char *twice = by_index ? by_index[p.tile.index] : NULL;
        for (size_t b = 0; !by_index && b < a && !twice; b++)
            if (given[b] == p.tile.index)
                twice = paths[b];
        if (diff)
            st = csi_fail(CSI_ERR_ARG, "%s: tile %u belongs to another run than %s (they differ in %s; inputs %s "
                          "and %s)", paths[a], p.tile.index, paths[0], diff, p.input, first->input);
        else if (twice)
            st = csi_fail(CSI_ERR_ARG, "%s and %s both hold tile %u", twice, paths[a], p.tile.index);
        else if (by_index)
            by_index[p.tile.index] = paths[a];
        given[a] = p.tile.index;
        csi_partial_release(&p);
        if (st != CSI_OK) {
            free(given);
            return st;
        }
    }
    const uint32_t n = first->tiling.count;
    uint32_t missing = 0, first_missing = 0;
    if (by_index) {
        for (uint32_t i = 0; i < n; i++)
            if (!by_index[i] && missing++ == 0)
                first_missing = i;
    } else {
        qsort(given, count, sizeof *given, cmp_u32);
        missing = n - (uint32_t)count;
        first_missing = (uint32_t)count;
        for (size_t i = 0; i < count; i++)
            if (given[i] != i) {
                first_missing = (uint32_t)i;
                break;
            }
    }
    free(given);
    if (missing)
        return csi_fail(CSI_ERR_ARG, "tile %u of %u is missing (%u of the %u partials of the run of %s, input %s, "
                        "are not given)", first_missing, n, missing, n, paths[0], first->input);
    return CSI_OK;
}

csi_status csi_partials_merge(const char *const *paths, size_t count, bool frames, csi_progress_fn progress,
                              void *user, csi_result **out, csi_partial_info *info)
{
    if (out)
        *out = NULL;
    if (!paths || !out || count == 0)
        return csi_fail(CSI_ERR_ARG, "csi_partials_merge: %s", !out ? "out is NULL" : "no partial given");
    for (size_t a = 0; a < count; a++)
        if (!paths[a])
            return csi_fail(CSI_ERR_ARG, "csi_partials_merge: path %zu is NULL", a);
    csi_partial first;
    CSI_TRY(csi_partial_load(paths[0], false, &first));
    if (info)
        info_of(&first, info);
    const uint32_t n = first.tiling.count;
    const char **by_index = n <= count ? calloc(n, sizeof *by_index) : NULL;
    if (n <= count && !by_index) {
        csi_partial_release(&first);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %u tiles", n);
    }
    csi_status st = merge_check(paths, count, &first, by_index);
    if (st == CSI_OK && frames && !first.tile.r.nframes)
        st = csi_fail(CSI_ERR_ARG, "%s: the partials hold no frames (%s)", paths[0],
                      first.tiling.grid.t == 1 ? "a static image" : "their tiles were made without the option frames");

    /* Pass 2: blend in index order (the order that makes the bits), one partial at a time. */
    csi_result *r = NULL;
    csi_blend b = {.next = 0}; /* released below whatever happens */
    if (st == CSI_OK)
        st = csi_result_blend_begin(&first.tiling, first.scope.channels, frames, &b, &r);
    for (uint32_t i = 0; i < n && st == CSI_OK; i++) {
        csi_partial p;
        st = csi_partial_load(by_index[i], true, &p);
        if (st == CSI_OK && (csi_partial_differs(&first, &p) || p.tile.index != i))
            st = csi_fail(CSI_ERR_FORMAT, "%s changed while it was merged", by_index[i]);
        if (st == CSI_OK && !frames && p.tile.r.nframes) {
            /* frames the merge does not keep: the blend needs only the image */
            free(p.tile.r.frames);
            p.tile.r.frames = NULL;
            p.tile.r.nframes = 0;
        }
        if (st == CSI_OK)
            st = csi_tiles_add(&b, &p.tile);
        csi_partial_release(&p);
        if (st == CSI_OK && progress &&
            !progress(user, &(csi_progress){.phase = "merge", .iteration = (int)(i + 1), .residual = -1}))
            st = csi_fail(CSI_ERR_CANCELLED, "the merge was cancelled after %u of %u tiles", i + 1, n);
    }
    if (st == CSI_OK)
        st = csi_tiles_end(&b);
    csi_tiles_release(&b);
    if (st == CSI_OK) {
        r->r.n = first.scope.n;
        r->r.options = first.reported; /* what one process running the layout reports */
        const csi_grid image = csi_tiling_image_grid(&first.tiling);
        st = csi_result_finish(r, &image);
    }
    free(by_index);
    csi_partial_release(&first);
    if (st != CSI_OK) {
        csi_result_free(r);
        return st;
    }
    *out = r;
    return CSI_OK;
}
