/* Texture images: PNG through libpng's simplified API (libpng 1.6 manual, "Simplified API"),
 * decoded from sRGB to linear; EXR scanline files through OpenEXR's C API (OpenEXRCore:
 * exr_start_read, exr_read_scanline_chunk_info, exr_decoding_*), already linear. */
#include "tracer_internal.h"

#include <inttypes.h>
#include <math.h>
#include <png.h>
#include <stdlib.h>
#include <string.h>

#include <OpenEXR/openexr.h>

#include "csi/host_memory.h"
#include "csi/infile.h"

/* Limit on texture size: 16k x 16k RGB float is 3 GiB, so cap the pixel count well below. */
#define TR_MAX_TEXELS (8192u * 8192u)

/* A decoded texture holds 12 bytes per texel (RGB float), and the PNG path 3 more while it
 * decodes: refuse one the host cannot hold before allocating it. */
static csi_status check_texels(const char *path, uint64_t texels)
{
    const uint64_t need = 15 * texels, avail = csi_host_available_bytes();
    if (avail && need > avail) {
        char a[32], b[32];
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: the texture's %" PRIu64 " texels need %s of host memory, more than "
                        "the %s available", path, texels, csi_bytes_text(need, a, sizeof a),
                        csi_bytes_text(avail, b, sizeof b));
    }
    return CSI_OK;
}

static float srgb_to_linear(float c)
{
    /* IEC 61966-2-1 sRGB transfer function, inverted. */
    return c <= 0.04045f ? c / 12.92f : powf((c + 0.055f) / 1.055f, 2.4f);
}

static csi_status load_png(const char *path, uint32_t *w, uint32_t *h, float **rgb)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return csi_fail(CSI_ERR_FORMAT, "cannot read PNG '%s': %s", path, img.message);
    if (img.width == 0 || img.height == 0 || (uint64_t)img.width * img.height > TR_MAX_TEXELS) {
        png_image_free(&img);
        return csi_fail(CSI_ERR_FORMAT, "PNG '%s' has an unusable size %ux%u", path, img.width,
                        img.height);
    }
    img.format = PNG_FORMAT_RGB; /* 8-bit sRGB; alpha composited on black by libpng */
    size_t n = (size_t)img.width * img.height;
    if (check_texels(path, n) != CSI_OK) {
        png_image_free(&img);
        return CSI_ERR_TOO_LARGE;
    }
    unsigned char *buf = malloc(3 * n);
    float *out = malloc(3 * n * sizeof(float));
    if (!buf || !out) {
        free(buf);
        free(out);
        png_image_free(&img);
        return csi_fail(CSI_ERR_NOMEM, "out of memory reading '%s'", path);
    }
    if (!png_image_finish_read(&img, NULL, buf, 0, NULL)) {
        free(buf);
        free(out);
        return csi_fail(CSI_ERR_FORMAT, "cannot decode PNG '%s': %s", path, img.message);
    }
    float lut[256];
    for (int i = 0; i < 256; i++)
        lut[i] = srgb_to_linear(i / 255.0f);
    for (size_t i = 0; i < 3 * n; i++)
        out[i] = lut[buf[i]];
    free(buf);
    *w = img.width;
    *h = img.height;
    *rgb = out;
    return CSI_OK;
}

static csi_status exr_err(exr_context_t *ctx, const char *path, const char *what, exr_result_t r)
{
    csi_status st = csi_fail(CSI_ERR_FORMAT, "cannot read EXR '%s': %s: %s", path, what,
                             exr_get_default_error_message(r));
    if (*ctx)
        exr_finish(ctx);
    return st;
}

static void exr_silent(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    (void)code;
    (void)msg; /* the library never prints: errors come back as result codes */
}

static csi_status load_exr(const char *path, uint32_t *w, uint32_t *h, float **rgb)
{
    exr_context_t ctx = NULL;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_silent;
    exr_result_t r = exr_start_read(&ctx, path, &init);
    if (r != EXR_ERR_SUCCESS)
        return exr_err(&ctx, path, "open", r);
    exr_storage_t storage;
    r = exr_get_storage(ctx, 0, &storage);
    if (r != EXR_ERR_SUCCESS)
        return exr_err(&ctx, path, "storage", r);
    if (storage != EXR_STORAGE_SCANLINE) {
        exr_finish(&ctx);
        return csi_fail(CSI_ERR_FORMAT, "EXR '%s': only scanline images are supported", path);
    }
    exr_attr_box2i_t dw;
    r = exr_get_data_window(ctx, 0, &dw);
    if (r != EXR_ERR_SUCCESS)
        return exr_err(&ctx, path, "data window", r);
    int64_t ww = (int64_t)dw.max.x - dw.min.x + 1, hh = (int64_t)dw.max.y - dw.min.y + 1;
    if (ww <= 0 || hh <= 0 || (uint64_t)ww * (uint64_t)hh > TR_MAX_TEXELS) {
        exr_finish(&ctx);
        return csi_fail(CSI_ERR_FORMAT, "EXR '%s' has an unusable size", path);
    }
    size_t n = (size_t)ww * (size_t)hh;
    if (check_texels(path, n) != CSI_OK) {
        exr_finish(&ctx);
        return CSI_ERR_TOO_LARGE;
    }
    float *out = calloc(3 * n, sizeof(float));
    if (!out) {
        exr_finish(&ctx);
        return csi_fail(CSI_ERR_NOMEM, "out of memory reading '%s'", path);
    }
    int32_t lines;
    r = exr_get_scanlines_per_chunk(ctx, 0, &lines);
    if (r != EXR_ERR_SUCCESS) {
        free(out);
        return exr_err(&ctx, path, "scanlines per chunk", r);
    }
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool inited = false, found[3] = {false, false, false}, gray = false;
    for (int64_t y = dw.min.y; y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        r = exr_read_scanline_chunk_info(ctx, 0, (int)y, &ci);
        if (r != EXR_ERR_SUCCESS)
            break;
        r = inited ? exr_decoding_update(ctx, 0, &ci, &dec)
                   : exr_decoding_initialize(ctx, 0, &ci, &dec);
        if (r != EXR_ERR_SUCCESS)
            break;
        for (int c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            const char *nm = ch->channel_name;
            int idx = strcmp(nm, "R") == 0 ? 0 : strcmp(nm, "G") == 0 ? 1
                                            : strcmp(nm, "B") == 0 ? 2
                                            : strcmp(nm, "Y") == 0 ? 3 : -1;
            if (idx < 0 || ch->x_samples != 1 || ch->y_samples != 1) {
                ch->decode_to_ptr = NULL;
                continue;
            }
            if (idx == 3) {
                gray = true;
                idx = 0;
            }
            found[idx] = true;
            ch->decode_to_ptr = (uint8_t *)(out + 3 * (size_t)(ci.start_y - dw.min.y) * ww + idx);
            ch->user_pixel_stride = 3 * sizeof(float);
            ch->user_line_stride = (int32_t)(3 * sizeof(float) * ww);
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_bytes_per_element = sizeof(float);
        }
        if (!inited) {
            r = exr_decoding_choose_default_routines(ctx, 0, &dec);
            if (r != EXR_ERR_SUCCESS)
                break;
            inited = true;
        }
        r = exr_decoding_run(ctx, 0, &dec);
        if (r != EXR_ERR_SUCCESS)
            break;
    }
    if (inited || dec.channels)
        exr_decoding_destroy(ctx, &dec);
    if (r != EXR_ERR_SUCCESS) {
        free(out);
        return exr_err(&ctx, path, "decoding", r);
    }
    exr_finish(&ctx);
    if (gray) {
        for (size_t i = 0; i < n; i++)
            out[3 * i + 1] = out[3 * i + 2] = out[3 * i];
    } else if (!found[0] || !found[1] || !found[2]) {
        free(out);
        return csi_fail(CSI_ERR_FORMAT, "EXR '%s' has no R, G, B (or Y) channels", path);
    }
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(out[i]) || out[i] < 0) {
            free(out);
            return csi_fail(CSI_ERR_FORMAT, "EXR '%s' has a negative or non-finite texel", path);
        }
    *w = (uint32_t)ww;
    *h = (uint32_t)hh;
    *rgb = out;
    return CSI_OK;
}

csi_status tr_image_load(const char *path, uint32_t *w, uint32_t *h, float **rgb)
{
    FILE *f;
    CSI_TRY(csi_infile_open(path, "texture", 0, &f, NULL));
    unsigned char magic[8] = {0};
    size_t got = fread(magic, 1, 8, f);
    fclose(f);
    if (got >= 8 && png_sig_cmp(magic, 0, 8) == 0)
        return load_png(path, w, h, rgb);
    if (got >= 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01)
        return load_exr(path, w, h, rgb);
    return csi_fail(CSI_ERR_FORMAT, "image '%s' is neither PNG nor OpenEXR (%s)", path,
                    got == 0 ? "empty file" : "unknown signature");
}
