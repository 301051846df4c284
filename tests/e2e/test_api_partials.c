/* Tiles as separate jobs through the public API (csi/csi.h): a tile written as a partial and read
 * back is the same tile (pixels, place, description); the partials of one run merged in any order
 * give csi_reconstruct's bits (it tiles by itself with the same options); a tile made from only
 * its window's samples (csi_reconstruct_tile_window) is the tile made from all of them; and the
 * merge refuses, with one line naming the file and nothing returned, a missing tile, a tile given
 * twice, a partial of another input, other options or another layout, a truncated, damaged or
 * other-version partial, a file that is not a partial, and frames a static run does not have; a
 * progress callback cancels it. A one-channel 64 x 64 image (4x grid, 2 spp) in 4 tiles; a
 * volume in time windows with the binned shutter's image (binned_windows); and an RGB image solved
 * as luma and chroma (chroma_partials), whose merged partials must be the tiled run's bits and say
 * in their statistics, as it does, the chroma channels' model grid (a partial that did not carry it
 * would say nothing); and a still image whose HDR step's pixels move after the settling
 * (step_partials), whose merged partials must be the tiled run's bits too. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "csi/csi.h"
#include "testlib.h"

static char dir[256];
static char paths[24][512]; /* every file the test names, in dir */
static int npaths;

static const char *path_of(const char *name)
{
    char *p = paths[npaths++ % 24];
    snprintf(p, sizeof paths[0], "%s/%s", dir, name);
    return p;
}

static bool same_image(const csi_result *a, const csi_result *b)
{
    csi_image x, y;
    if (csi_result_image(a, &x) != CSI_OK || csi_result_image(b, &y) != CSI_OK)
        return false;
    return x.w == y.w && x.h == y.h && x.channels == y.channels &&
           !memcmp(x.data, y.data, (size_t)x.w * x.h * x.channels * sizeof(float));
}

/* A copy of file `from` with byte `at` set to `value` (at < 0: only the first -at bytes). */
static void copy_changed(const char *from, const char *to, long at, unsigned char value)
{
    FILE *f = fopen(from, "rb");
    fseek(f, 0, SEEK_END);
    const long size = ftell(f);
    rewind(f);
    unsigned char *b = malloc((size_t)size);
    const size_t got = fread(b, 1, (size_t)size, f);
    fclose(f);
    CHECK(got == (size_t)size, "read %s", from);
    long n = size;
    if (at < 0)
        n = -at;
    else
        b[at] = value;
    f = fopen(to, "wb");
    fwrite(b, 1, (size_t)n, f);
    fclose(f);
    free(b);
}

/* The merge of paths refuses them: status want, one line holding `file` and `what`, no result. */
static void refused(const char *name, const char *const *paths, size_t n, bool frames, csi_status want,
                    const char *file, const char *what)
{
    csi_result *r = (csi_result *)1;
    const csi_status st = csi_partials_merge(paths, n, frames, NULL, NULL, &r, NULL);
    const char *msg = csi_last_error();
    CHECK(st == want && !r && strstr(msg, file) && strstr(msg, what) && !strchr(msg, '\n'),
          "%s: %s: %s", name, csi_status_name(st), msg);
    if (st == CSI_OK)
        csi_result_free(r);
}

static bool stop_after_two(void *user, const csi_progress *p)
{
    int *calls = user;
    ++*calls;
    return !(strcmp(p->phase, "merge") == 0 && p->iteration >= 2);
}

/* A volume in 2 time windows with the binned shutter's image (tile-image-binned): the first
 * window's cells span every frame of its x/y column, the second's its own frames, and each
 * tile made from only its window's samples is the tile made from all of them. A 32 x 32 x 48
 * volume (a square sliding over a ramp), 10% random cells. */
static void binned_windows(csi_device *dev)
{
    const csi_grid g = {32, 32, 48, 32, 32};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    const csi_pos_opts po = {.method = CSI_POS_RANDOM, .fraction = 0.1, .seed = 2};
    csi_options *o = NULL;
    if (csi_positions(&g, &po, &pos, &n, NULL) != CSI_OK || csi_options_new(&o) != CSI_OK) {
        CHECK(false, "positions and options: %s", csi_last_error());
        free(pos);
        return;
    }
    float *val = malloc(n * sizeof *val), *wval = malloc(n * sizeof *wval);
    csi_sample_pos *wpos = malloc(n * sizeof *wpos);
    for (size_t i = 0; i < n; i++) {
        const uint32_t x0 = 4 + pos[i].t / 3;
        val[i] = pos[i].x >= x0 && pos[i].x < x0 + 8 && pos[i].y >= 12 && pos[i].y < 20 ? 0.9f : 0.2f + pos[i].x / 64.0f;
    }
    CHECK_OK(csi_options_set(o, "tiles-t", "2"));
    CHECK_OK(csi_options_set(o, "tile-image-binned", "on"));
    CHECK_OK(csi_options_set(o, "max-iter", "30"));
    const csi_samples s = {g, 1, n, pos, val, 0, NULL};
    double scale[4];
    CHECK_OK(csi_tile_scale(dev, &s, o, scale));
    for (uint32_t i = 0; i < 2; i++) {
        uint32_t lo[3], hi[3];
        CHECK_OK(csi_tile_window(dev, &(csi_samples){g, 1, n, pos, NULL, 0, NULL}, o, i, lo, hi));
        CHECK(i == 0 ? lo[2] == 0 && hi[2] == 48 : lo[2] > 0 && hi[2] == 48,
              "binned image: window %u spans frames [%u, %u)", i, lo[2], hi[2]);
        size_t m = 0;
        for (size_t j = 0; j < n; j++)
            if (pos[j].t >= lo[2] && pos[j].t < hi[2]) {
                wpos[m] = pos[j];
                wval[m++] = val[j];
            }
        csi_result *all = NULL, *own = NULL;
        CHECK_OK(csi_reconstruct_tile(dev, &s, o, i, scale, NULL, NULL, &all));
        CHECK_OK(csi_reconstruct_tile_window(dev, &(csi_samples){g, 1, m, wpos, wval, 0, NULL}, n, o, i, scale, NULL,
                                             NULL, &own));
        CHECK(all && own && same_image(all, own), "binned image: window %u from its cells' samples = from all", i);
        csi_result_free(all);
        csi_result_free(own);
    }
    /* A window that holds none of its samples knows nothing (its frames would be zero): refused,
     * naming it, when a renderer traced that window alone and found nothing there. */
    {
        uint32_t lo[3], hi[3];
        CHECK_OK(csi_tile_window(dev, &(csi_samples){g, 1, n, pos, NULL, 0, NULL}, o, 1, lo, hi));
        size_t m = 0;
        for (size_t j = 0; j < n && m < 4; j++)
            if (pos[j].t < lo[2]) { /* outside window 1: the tile finds none of its own */
                wpos[m] = pos[j];
                wval[m++] = val[j];
            }
        csi_result *empty = NULL;
        const csi_status st = csi_reconstruct_tile_window(dev, &(csi_samples){g, 1, m, wpos, wval, 0, NULL}, n, o, 1,
                                                          scale, NULL, NULL, &empty);
        CHECK(st == CSI_ERR_ARG && !empty && strstr(csi_last_error(), "time window 2 of 2") &&
                  strstr(csi_last_error(), "holds no sample"),
              "a window without samples: %s (%s)", csi_status_name(st), csi_last_error());
    }
    csi_options_free(o);
    free(wpos);
    free(wval);
    free(val);
    free(pos);
}

/* The integer `key` of r's statistics (e.g. "chroma_model_grid_factor"), 0 when they do not name
 * it. */
static long stat_long(const csi_result *r, const char *key)
{
    csi_json *j = NULL;
    const char *text = NULL, *at = NULL;
    char quoted[64];
    long f = 0;
    if (csi_json_new(&j) != CSI_OK)
        return -1;
    csi_result_stats(r, j);
    snprintf(quoted, sizeof quoted, "\"%s\": ", key);
    if (csi_json_text(j, &text) == CSI_OK && (at = strstr(text, quoted)))
        f = strtol(at + strlen(quoted), NULL, 10);
    csi_json_free(j);
    return f;
}

/* s in 2 tiles (tile margin 8, max-iter 30, and `extra`: an option name and value, or NULL) by
 * csi_reconstruct (*whole) and by each tile made apart, written as STEM0.csip and STEM1.csip and
 * merged (*merged): the merged partials must be the tiled run's bits. */
static void two_tiles(csi_device *dev, const csi_samples *s, const char *extra, const char *value, const char *stem,
                      csi_result **whole, csi_result **merged)
{
    const uint64_t id = csi_samples_id(s);
    csi_options *o = NULL;
    CHECK_OK(csi_options_new(&o));
    if (extra)
        CHECK_OK(csi_options_set(o, extra, value));
    CHECK_OK(csi_options_set(o, "tiles", "2"));
    CHECK_OK(csi_options_set(o, "tile-margin", "8"));
    CHECK_OK(csi_options_set(o, "max-iter", "30"));
    double scale[4];
    CHECK_OK(csi_reconstruct(dev, s, o, NULL, NULL, whole));
    CHECK_OK(csi_tile_scale(dev, s, o, scale));
    const char *part[2];
    for (int i = 0; i < 2; i++) {
        char name[64];
        snprintf(name, sizeof name, "%s%d.csip", stem, i);
        part[i] = path_of(name);
        csi_result *t = NULL;
        CHECK_OK(csi_reconstruct_tile(dev, s, o, (uint32_t)i, scale, NULL, NULL, &t));
        CHECK_OK(csi_partial_write(part[i], t, "input.csid", id, NULL));
        csi_result_free(t);
    }
    CHECK_OK(csi_partials_merge(part, 2, false, NULL, NULL, merged, NULL));
    CHECK(*merged && *whole && same_image(*merged, *whole), "%s: merged partials = csi_reconstruct's tiled image",
          stem);
    csi_options_free(o);
}

/* RGB as luma and chroma (--chroma on) in two tiles made apart, written and merged: 4 spp on an 8x
 * grid, luma on a model grid D = 2, the chroma on D = 4. */
static void chroma_partials(csi_device *dev)
{
    const csi_grid g = {512, 256, 1, 64, 32};
    const csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = 4, .seed = 9};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(&g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(0, "luma and chroma: positions: %s", csi_last_error());
        return;
    }
    float *rgb = malloc(3 * n * sizeof *rgb);
    for (size_t i = 0; i < n; i++) {
        const double u = (pos[i].x + 0.5) / g.w, v = (pos[i].y + 0.5) / g.h;
        const bool disc = (u - 0.4) * (u - 0.4) + (v - 0.6) * (v - 0.6) < 0.06;
        rgb[3 * i] = (float)(0.2 + 0.6 * disc);
        rgb[3 * i + 1] = (float)(0.3 + 0.2 * u);
        rgb[3 * i + 2] = (float)(0.5 - 0.3 * disc * v);
    }
    const csi_samples s = {g, 3, n, pos, rgb, 0, NULL};
    csi_result *whole = NULL, *merged = NULL;
    two_tiles(dev, &s, "chroma", "on", "chroma", &whole, &merged);
    const long fw = stat_long(whole, "chroma_model_grid_factor"),
               fm = merged ? stat_long(merged, "chroma_model_grid_factor") : -1;
    CHECK(fw == 4 && fm == fw, "luma and chroma: the chroma's model grid factor %ld in the tiled run's statistics, "
          "%ld in the merged partials'", fw, fm);
    csi_result_free(merged);
    csi_result_free(whole);
    free(rgb);
    free(pos);
}

/* A still image given its samples' variances, whose HDR step's pixels move by the coverage their
 * window's samples allow (csi/step_coverage.h, after the settling on the blended image): lamps of
 * 200 on 0.05 (discs of 2 to 5 pixels), 64 x 32 pixels on an 8x grid at 4 spp, variance 0 (an
 * emitter seen directly), in 2 tiles. The merged partials are the tiled run's bits and count the
 * same moved pixels, some. */
static void step_partials(csi_device *dev)
{
    const csi_grid g = {512, 256, 1, 64, 32};
    const csi_pos_opts po = {.method = CSI_POS_STRATIFIED, .spp = 4, .seed = 5};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    if (csi_positions(&g, &po, &pos, &n, NULL) != CSI_OK) {
        CHECK(0, "HDR step: positions: %s", csi_last_error());
        return;
    }
    static const double disc[][3] = {{12.3, 10.6, 2.0}, {31.7, 20.2, 3.5}, {50.4, 12.9, 5.0}};
    float *val = malloc(n * sizeof *val), *var = calloc(n, sizeof *var);
    for (size_t i = 0; i < n; i++) {
        const double x = (pos[i].x + 0.5) / 8, y = (pos[i].y + 0.5) / 8;
        val[i] = 0.05f;
        for (int k = 0; k < 3; k++)
            if ((x - disc[k][0]) * (x - disc[k][0]) + (y - disc[k][1]) * (y - disc[k][1]) < disc[k][2] * disc[k][2])
                val[i] = 200.0f;
    }
    const csi_samples s = {g, 1, n, pos, val, 0, var};
    csi_result *whole = NULL, *merged = NULL;
    two_tiles(dev, &s, NULL, NULL, "step", &whole, &merged);
    const long mw = stat_long(whole, "step_coverage_pixels"), mm = merged ? stat_long(merged, "step_coverage_pixels") : -1;
    CHECK(mw > 0 && mm == mw, "HDR step: %ld pixels moved in the tiled run's statistics, %ld in the merged partials'",
          mw, mm);
    csi_result_free(merged);
    csi_result_free(whole);
    free(val);
    free(var);
    free(pos);
}

int main(void)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/csi_partials_XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(dir)) {
        fprintf(stderr, "cannot make a temporary folder\n");
        return 1;
    }
    const csi_grid g = {256, 256, 1, 64, 64};
    const csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = 2, .seed = 5};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    REQUIRE_OK(csi_positions(&g, &po, &pos, &n, NULL));
    float *val = malloc(n * sizeof *val);
    for (size_t i = 0; i < n; i++) {
        const double u = (pos[i].x + 0.5) / g.w, v = (pos[i].y + 0.5) / g.h;
        val[i] = (float)(0.3 + 0.5 * ((u - 0.4) * (u - 0.4) + (v - 0.6) * (v - 0.6) < 0.06) + 0.1 * u);
    }
    const csi_samples s = {g, 1, n, pos, val, 0, NULL};
    const uint64_t id = csi_samples_id(&s);
    csi_device *dev = NULL;
    REQUIRE_OK(csi_device_new(NULL, &dev));
    csi_options *o = NULL;
    REQUIRE_OK(csi_options_new(&o));
    REQUIRE_OK(csi_options_set(o, "tiles", "4"));
    REQUIRE_OK(csi_options_set(o, "tile-margin", "8"));
    REQUIRE_OK(csi_options_set(o, "max-iter", "30"));
    csi_result *whole = NULL;
    REQUIRE_OK(csi_reconstruct(dev, &s, o, NULL, NULL, &whole));

    /* the four tiles, written as partials */
    double scale[4];
    REQUIRE_OK(csi_tile_scale(dev, &s, o, scale));
    csi_result *tile[4] = {NULL, NULL, NULL, NULL};
    const char *part[4];
    for (int i = 0; i < 4; i++) {
        char name[32];
        snprintf(name, sizeof name, "p%d.csip", i);
        part[i] = path_of(name);
        REQUIRE_OK(csi_reconstruct_tile(dev, &s, o, (uint32_t)i, scale, NULL, NULL, &tile[i]));
        CHECK_OK(csi_partial_write(part[i], tile[i], "/some/where/scene.csid", id, NULL));
    }

    /* round trip: the same tile, its place and its description */
    for (int i = 0; i < 4; i++) {
        csi_result *back = NULL;
        csi_partial_info info, info2;
        CHECK_OK(csi_partial_read(part[i], &back, &info));
        CHECK_OK(csi_partial_read_info(part[i], &info2));
        if (!back)
            continue;
        csi_result_info a, b;
        csi_result_info_get(tile[i], &a);
        csi_result_info_get(back, &b);
        char software[40];
        snprintf(software, sizeof software, "csi %s", csi_version());
        CHECK(same_image(tile[i], back) && b.tile && b.tile_index == (uint32_t)i && b.tiles == 4 &&
                  !memcmp(a.tile_origin, b.tile_origin, sizeof a.tile_origin) && a.n == b.n && a.k == b.k &&
                  !strcmp(a.method, b.method) && !strcmp(a.solver, b.solver),
              "partial %d read back: the tile (index %u, origin %u,%u, n %zu/%zu)", i, b.tile_index,
              b.tile_origin[0], b.tile_origin[1], b.n, a.n);
        CHECK(info.tile_index == (uint32_t)i && info.tile_count == 4 && info.input_id == id &&
                  !strcmp(info.input, "scene.csid") && !strcmp(info.software, software) &&
                  !strcmp(info.method, a.method) && info.grid.w == g.w && info.grid.out_h == g.out_h &&
                  info.channels == 1 && info.frames == 0 && info.samples == n && !memcmp(&info, &info2, sizeof info),
              "partial %d's description: tile %u/%u, input %s, software %s, %llu samples", i, info.tile_index,
              info.tile_count, info.input, info.software, (unsigned long long)info.samples);
        csi_result_free(back);
    }

    /* merge, in any order = the in-process tiled run, bit for bit */
    const char *shuffled[4] = {part[2], part[0], part[3], part[1]};
    csi_result *merged = NULL;
    csi_partial_info minfo;
    int calls = 0;
    CHECK_OK(csi_partials_merge(shuffled, 4, false, NULL, NULL, &merged, &minfo));
    CHECK(merged && same_image(merged, whole), "merged partials = csi_reconstruct's tiled image");
    CHECK(minfo.tile_count == 4 && minfo.tile_index == 2, "the run's description from the first path");
    if (merged) {
        csi_result_info mi;
        csi_result_info_get(merged, &mi);
        CHECK(!mi.tile && mi.tiles == 4 && mi.n == n, "merged: %u tiles, %zu samples", mi.tiles, mi.n);
    }
    csi_result_free(merged);
    merged = NULL;
    calls = 0;
    CHECK(csi_partials_merge(part, 4, false, stop_after_two, &calls, &merged, NULL) == CSI_ERR_CANCELLED &&
              !merged && calls == 2,
          "the progress callback cancels the merge (%d calls): %s", calls, csi_last_error());

    /* a tile from its window's samples only = the tile from all of them */
    uint32_t lo[3], hi[3];
    CHECK_OK(csi_tile_window(dev, &(csi_samples){g, 1, n, pos, NULL, 0, NULL}, o, 1, lo, hi));
    csi_sample_pos *wpos = malloc(n * sizeof *wpos);
    float *wval = malloc(n * sizeof *wval);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (pos[i].x >= lo[0] && pos[i].x < hi[0] && pos[i].y >= lo[1] && pos[i].y < hi[1]) {
            wpos[m] = pos[i];
            wval[m++] = val[i];
        }
    csi_result *wt = NULL;
    CHECK(m > 0 && m < n, "tile 1's window [%u,%u)x[%u,%u) holds %zu of %zu samples", lo[0], hi[0], lo[1], hi[1], m, n);
    CHECK_OK(csi_reconstruct_tile_window(dev, &(csi_samples){g, 1, m, wpos, wval, 0, NULL}, n, o, 1, scale, NULL, NULL, &wt));
    CHECK(wt && same_image(wt, tile[1]), "tile 1 from its window's samples = tile 1 from all");
    csi_result_free(wt);
    free(wpos);
    free(wval);

    /* refusals: one line naming the file and the problem, nothing returned */
    const char *missing[3] = {part[0], part[1], part[2]};
    refused("missing tile", missing, 3, false, CSI_ERR_ARG, part[0], "tile 3 of 4 is missing");
    const char *twice[4] = {part[0], part[1], part[1], part[3]};
    refused("tile twice", twice, 4, false, CSI_ERR_ARG, part[1], "both hold tile 1");
    const char *foreign = path_of("foreign.csip");
    CHECK_OK(csi_partial_write(foreign, tile[2], "other.csid", id ^ 1, NULL));
    const char *with_foreign[4] = {part[0], part[1], foreign, part[3]};
    refused("another input", with_foreign, 4, false, CSI_ERR_ARG, foreign, "the input");
    csi_options *o2 = NULL;
    CHECK_OK(csi_options_copy(o, &o2));
    CHECK_OK(csi_options_set(o2, "max-iter", "31"));
    csi_result *t2 = NULL;
    const char *other_opts = path_of("options.csip");
    CHECK_OK(csi_reconstruct_tile(dev, &s, o2, 2, scale, NULL, NULL, &t2));
    CHECK_OK(csi_partial_write(other_opts, t2, "scene.csid", id, NULL));
    const char *with_options[4] = {part[0], part[1], other_opts, part[3]};
    refused("other options", with_options, 4, false, CSI_ERR_ARG, other_opts, "the reconstruction options");
    csi_result_free(t2);
    t2 = NULL;
    CHECK_OK(csi_options_set(o2, "max-iter", "30"));
    CHECK_OK(csi_options_set(o2, "tiles", "2"));
    const char *other_layout = path_of("layout.csip");
    CHECK_OK(csi_reconstruct_tile(dev, &s, o2, 1, NULL, NULL, NULL, &t2));
    CHECK_OK(csi_partial_write(other_layout, t2, "scene.csid", id, NULL));
    const char *with_layout[4] = {part[0], other_layout, part[2], part[3]};
    refused("another layout", with_layout, 4, false, CSI_ERR_ARG, other_layout, "the tile layout");
    csi_result_free(t2);
    csi_options_free(o2);

    const char *trunc = path_of("trunc.csip"), *damaged = path_of("damaged.csip");
    const char *version = path_of("version.csip"), *notpart = path_of("not.csip");
    FILE *f = fopen(part[2], "rb");
    fseek(f, 0, SEEK_END);
    const long size = ftell(f);
    fclose(f);
    copy_changed(part[2], trunc, -(size / 2), 0);
    copy_changed(part[2], damaged, size - 100, 0x5a); /* a pixel's byte */
    copy_changed(part[2], version, 4, 5); /* the version before the chroma's grid was in it */
    f = fopen(notpart, "wb");
    fputs("CSID this is not a partial\n", f);
    fclose(f);
    const char *bad[5] = {trunc, damaged, version, notpart, path_of("absent.csip")};
    const char *why[5] = {"truncated or damaged", "truncated or damaged", "version 5 (this program reads version 11)",
                          "not a csi tile partial", "cannot open"};
    for (int k = 0; k < 5; k++) {
        const char *set[4] = {part[0], part[1], bad[k], part[3]};
        refused(why[k], set, 4, false, k == 4 ? CSI_ERR_IO : CSI_ERR_FORMAT, bad[k], why[k]);
        csi_partial_info info;
        CHECK(csi_partial_read_info(bad[k], &info) != CSI_OK && strstr(csi_last_error(), bad[k]),
              "csi_partial_read_info refuses %s: %s", bad[k], csi_last_error());
        csi_result *r = (csi_result *)1;
        CHECK(csi_partial_read(bad[k], &r, NULL) != CSI_OK && !r, "csi_partial_read refuses %s", bad[k]);
    }
    refused("frames of a static run", part, 4, true, CSI_ERR_ARG, part[0], "no frames");

    /* a result that is not a tile's is not written, and a failed write leaves nothing */
    const char *nottile = path_of("whole.csip");
    CHECK(csi_partial_write(nottile, whole, "scene.csid", id, NULL) == CSI_ERR_ARG && access(nottile, F_OK) != 0,
          "a whole image is not a partial: %s", csi_last_error());
    const char *nodir = path_of("no/such/dir/p.csip");
    CHECK(csi_partial_write(nodir, tile[0], "scene.csid", id, NULL) == CSI_ERR_IO, "no folder: %s",
          csi_last_error());

    for (int i = 0; i < 4; i++)
        csi_result_free(tile[i]);
    chroma_partials(dev);
    step_partials(dev);
    for (int k = 0; k < npaths; k++)
        remove(paths[k]);
    CHECK(rmdir(dir) == 0, "nothing else is left in %s", dir);
    csi_result_free(whole);
    csi_options_free(o);
    binned_windows(dev);
    csi_device_release(dev);
    free(val);
    free(pos);
    return test_done();
}
