/* Tiles through the public API (csi/csi.h): the layout csi_tiling_get reports is the one
 * csi_reconstruct uses; tiles made one by one with csi_reconstruct_tile (in reverse order, on two
 * devices, with the scale from csi_tile_scale or computed by the tile itself) and blended by
 * csi_tiles_blend give csi_reconstruct's bits; a missing, repeated or foreign tile is refused
 * with a message naming it. A two-channel image (96 x 96 pixels on an 8x grid, 3 spp) in 4
 * tiles with 16-pixel margins. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "csi/csi.h"
#include "testlib.h"

int main(void)
{
    const csi_grid g = {768, 768, 1, 96, 96};
    const csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = 3, .seed = 9};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    REQUIRE_OK(csi_positions(&g, &po, &pos, &n, NULL));
    float *val = malloc(n * 2 * sizeof *val);
    for (size_t i = 0; i < n; i++) {
        const double u = (pos[i].x + 0.5) / g.w, v = (pos[i].y + 0.5) / g.h;
        val[2 * i] = (float)(0.5 + 0.4 * sin(9.0 * u) * cos(7.0 * v));
        val[2 * i + 1] = (float)((u - 0.5) * (u - 0.5) + (v - 0.4) * (v - 0.4) < 0.05 ? 0.9 : 0.1);
    }
    const csi_samples s = {g, 2, n, pos, val, 0, NULL};
    csi_device *dev = NULL, *dev2 = NULL;
    REQUIRE_OK(csi_device_new(NULL, &dev));
    REQUIRE_OK(csi_device_new(NULL, &dev2));
    csi_options *o = NULL;
    REQUIRE_OK(csi_options_new(&o));
    REQUIRE_OK(csi_options_set(o, "tiles", "4"));
    REQUIRE_OK(csi_options_set(o, "tile-margin", "16"));

    csi_tiling_info info;
    REQUIRE_OK(csi_tiling_get(dev, &s, o, &info));
    CHECK(info.count == 4 && info.n[0] * info.n[1] * info.n[2] == 4, "4 tiles (%u)", info.count);
    csi_result *whole = NULL;
    REQUIRE_OK(csi_reconstruct(dev, &s, o, NULL, NULL, &whole));
    csi_result_info wi;
    csi_result_info_get(whole, &wi);
    CHECK(wi.tiles == 4 && !wi.tile, "csi_reconstruct tiled by itself (%u tiles)", wi.tiles);

    double scale[4];
    REQUIRE_OK(csi_tile_scale(dev, &s, o, scale));
    CHECK(scale[0] > 0 && scale[1] > 0 && scale[2] == 0, "a scale per channel (%g %g %g)", scale[0], scale[1], scale[2]);
    csi_result *tiles[4] = {NULL, NULL, NULL, NULL};
    for (int i = 3; i >= 0; i--) /* reverse order, tile 1 on the second device, tile 2 computing its scale */
        CHECK_OK(csi_reconstruct_tile(i == 1 ? dev2 : dev, &s, o, (uint32_t)i, i == 2 ? NULL : scale, NULL, NULL,
                                      &tiles[i]));
    for (int i = 0; i < 4 && tiles[i]; i++) {
        csi_result_info ti;
        csi_result_info_get(tiles[i], &ti);
        csi_image view;
        csi_result_image(tiles[i], &view);
        CHECK(ti.tile && ti.tile_index == (uint32_t)i && ti.tiles == 4 && view.w == info.window[0] &&
                  view.h == info.window[1] && ti.tile_origin[0] + view.w <= 96 && ti.tile_origin[1] + view.h <= 96,
              "tile %d: index %u, %ux%u window at (%u, %u)", i, ti.tile_index, view.w, view.h, ti.tile_origin[0],
              ti.tile_origin[1]);
    }
    const csi_result *shuffled[4] = {tiles[2], tiles[0], tiles[3], tiles[1]};
    csi_result *blended = NULL;
    CHECK_OK(csi_tiles_blend(shuffled, 4, &blended));
    if (blended && whole) {
        csi_image a, b;
        csi_result_image(whole, &a);
        csi_result_image(blended, &b);
        CHECK(a.w == b.w && a.h == b.h && a.channels == b.channels &&
                  !memcmp(a.data, b.data, (size_t)a.w * a.h * a.channels * sizeof(float)),
              "blended tiles = csi_reconstruct's bits");
    }
    const csi_result *missing[3] = {tiles[0], tiles[1], tiles[2]};
    csi_result *bad = NULL;
    CHECK(csi_tiles_blend(missing, 3, &bad) == CSI_ERR_ARG && !bad && strstr(csi_last_error(), "3 tiles given"),
          "3 of 4 tiles: %s", csi_last_error());
    const csi_result *twice[4] = {tiles[0], tiles[1], tiles[1], tiles[3]};
    CHECK(csi_tiles_blend(twice, 4, &bad) == CSI_ERR_ARG && !bad && strstr(csi_last_error(), "tile 2"),
          "tile 1 twice, tile 2 missing: %s", csi_last_error());
    const csi_result *whole_as_tile[4] = {tiles[0], whole, tiles[2], tiles[3]};
    CHECK(csi_tiles_blend(whole_as_tile, 4, &bad) == CSI_ERR_ARG && !bad && strstr(csi_last_error(), "not a tile"),
          "a whole result among tiles: %s", csi_last_error());
    /* another layout: 2 tiles */
    csi_options *o2 = NULL;
    csi_result *other = NULL;
    CHECK_OK(csi_options_copy(o, &o2));
    CHECK_OK(csi_options_set(o2, "tiles", "2"));
    CHECK_OK(csi_reconstruct_tile(dev, &s, o2, 1, scale, NULL, NULL, &other));
    const csi_result *mixed[4] = {tiles[0], other, tiles[2], tiles[3]};
    CHECK(csi_tiles_blend(mixed, 4, &bad) == CSI_ERR_ARG && !bad && strstr(csi_last_error(), "another layout"),
          "a tile of another layout: %s", csi_last_error());
    CHECK(csi_reconstruct_tile(dev, &s, o, 4, scale, NULL, NULL, &bad) == CSI_ERR_ARG && !bad,
          "tile 4 of 4 is refused");
    csi_result_free(other);
    csi_options_free(o2);
    csi_result_free(blended);
    for (int i = 0; i < 4; i++)
        csi_result_free(tiles[i]);
    csi_result_free(whole);
    csi_options_free(o);
    csi_device_release(dev);
    csi_device_release(dev2);
    free(val);
    free(pos);
    return test_done();
}
