/* OpenEXR textures: a float RGB scanline EXR written with OpenEXR's own encoder is read back
 * by the tracer's loader; radiance at texel centres equals the texel (linear, no sRGB). A
 * negative texel and a file without R, G, B are refused with a clear message. */
#include <OpenEXR/openexr.h>

#include "tracer_test_util.h"

/* Writes a w x h EXR with the given channels (names[c], planar data[c]) as 32-bit float. */
static bool write_exr(const char *path, int w, int h, int nch, const char *const *names,
                      float *const *data)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part;
    if (exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init) != EXR_ERR_SUCCESS)
        return false;
    bool ok = exr_add_part(ctx, "main", EXR_STORAGE_SCANLINE, &part) == EXR_ERR_SUCCESS &&
              exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP) ==
                  EXR_ERR_SUCCESS;
    for (int c = 0; ok && c < nch; c++)
        ok = exr_add_channel(ctx, part, names[c], EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1,
                             1) == EXR_ERR_SUCCESS;
    ok = ok && exr_write_header(ctx) == EXR_ERR_SUCCESS;
    int32_t lines = 1;
    ok = ok && exr_get_scanlines_per_chunk(ctx, part, &lines) == EXR_ERR_SUCCESS;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool inited = false;
    for (int y = 0; ok && y < h; y += lines) {
        exr_chunk_info_t ci;
        ok = exr_write_scanline_chunk_info(ctx, part, y, &ci) == EXR_ERR_SUCCESS;
        if (!ok)
            break;
        ok = (inited ? exr_encoding_update(ctx, part, &ci, &enc)
                     : exr_encoding_initialize(ctx, part, &ci, &enc)) == EXR_ERR_SUCCESS;
        for (int c = 0; ok && c < enc.channel_count; c++) {
            int k;
            for (k = 0; k < nch; k++)
                if (strcmp(enc.channels[c].channel_name, names[k]) == 0)
                    break;
            enc.channels[c].encode_from_ptr = (const uint8_t *)(data[k] + (size_t)y * w);
            enc.channels[c].user_pixel_stride = sizeof(float);
            enc.channels[c].user_line_stride = (int32_t)(w * sizeof(float));
            enc.channels[c].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[c].user_bytes_per_element = sizeof(float);
        }
        if (ok && !inited) {
            ok = exr_encoding_choose_default_routines(ctx, part, &enc) == EXR_ERR_SUCCESS;
            inited = ok;
        }
        ok = ok && exr_encoding_run(ctx, part, &enc) == EXR_ERR_SUCCESS;
    }
    if (inited)
        exr_encoding_destroy(ctx, &enc);
    return exr_finish(&ctx) == EXR_ERR_SUCCESS && ok;
}

static void project_z(const double o[3], double th, const double p[3], float *u, float *v)
{
    double d[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    *u = (float)((-d[0] / d[2] / th + 1) / 2);
    *v = (float)((1 - d[1] / d[2] / th) / 2);
}

int main(void)
{
    const char *path = CSI_BINARY_DIR "/test_texture_exr.exr";
    /* 3 x 2 texels with HDR values */
    float R[6] = {0.0f, 0.5f, 2.0f, 10.0f, 0.125f, 1e-3f};
    float G[6] = {1.0f, 0.25f, 3.5f, 0.0f, 7.0f, 0.75f};
    float B[6] = {0.3f, 0.6f, 0.9f, 1.2f, 1.5f, 100.0f};
    const char *names[3] = {"R", "G", "B"};
    float *data[3] = {R, G, B};
    REQUIRE_OK(write_exr(path, 3, 2, 3, names, data) ? CSI_OK : CSI_ERR_IO);
    char text[2048];
    /* a 3 x 2 plane: uv = (x, y) / (3, 2) through uv_scale, texel (i, j) centre at
     * x = i + 0.5, y = j + 0.5; irradiance pi straight on gives radiance = albedo */
    snprintf(text, sizeof text,
             "camera { position 1.5 1 -8 target 1.5 1 0 fov 30 size 32 32 }\n"
             "material t { texture \"%s\" uv_scale 0.333333333333333 0.5 }\n"
             "plane { corner 0 0 0 edge_u 3 0 0 edge_v 0 2 0 material t }\n"
             "light directional { direction 0 0 1 irradiance 3.14159265358979 3.14159265358979 "
             "3.14159265358979 }\n",
             path);
    tt_setup s;
    if (tt_make(&s, text, 1)) {
        float uvs[18], rgb[18];
        double o[3] = {1.5, 1, -8}, th = tan(15 * M_PI / 180);
        for (int i = 0; i < 6; i++) {
            double p[3] = {i % 3 + 0.5, i / 3 + 0.5, 0};
            project_z(o, th, p, &uvs[3 * i], &uvs[3 * i + 1]);
            uvs[3 * i + 2] = 0;
        }
        CHECK_OK(csi_tracer_eval_points(s.tr, uvs, 6, 1, rgb, NULL, NULL));
        for (int i = 0; i < 6; i++)
            for (int c = 0; c < 3; c++) {
                double want = data[c][i];
                /* bilinear weights are off by ~1e-6 at float hit points; neighbours differ by
                 * up to 100: allow 1e-3 absolute plus 1e-5 relative */
                CHECK(fabs(rgb[3 * i + c] - want) < 1e-3 + 1e-5 * want,
                      "texel %d channel %d: %g want %g", i, c, rgb[3 * i + c], want);
            }
    }
    tt_free(&s);

    /* negative texel: refused */
    R[2] = -1;
    REQUIRE_OK(write_exr(path, 3, 2, 3, names, data) ? CSI_OK : CSI_ERR_IO);
    csi_scene *sc;
    snprintf(text, sizeof text, "camera { position 0 0 -1 target 0 0 0 }\nmaterial t { texture \"%s\" }\n",
             path);
    csi_status st = csi_scene_parse(text, "exr.scene", NULL, &sc);
    CHECK(st == CSI_ERR_SCENE && strstr(csi_last_error(), "negative or non-finite texel"),
          "negative texel: %s %s", csi_status_name(st), csi_last_error());
    /* only an alpha channel: refused */
    const char *anames[1] = {"A"};
    REQUIRE_OK(write_exr(path, 3, 2, 1, anames, data) ? CSI_OK : CSI_ERR_IO);
    st = csi_scene_parse(text, "exr.scene", NULL, &sc);
    CHECK(st == CSI_ERR_SCENE && strstr(csi_last_error(), "no R, G, B (or Y) channels"),
          "alpha only: %s %s", csi_status_name(st), csi_last_error());
    return test_done();
}
