/* EXR (OpenEXRCore C API) and PNG (libpng) reading and writing (see csi/image.h). */
#include "csi/image.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <openexr.h>
#include <png.h>

#include "csi/host_memory.h"
#include "csi/infile.h"
#include "csi/outfile.h"

csi_status csi_image_alloc(csi_image *img, uint32_t w, uint32_t h, uint32_t channels)
{
    img->data = NULL;
    img->w = img->h = img->channels = 0;
    if (!w || !h || channels < 1 || channels > 4)
        return csi_fail(CSI_ERR_ARG, "image size %" PRIu32 "x%" PRIu32 " with %" PRIu32 " channels is invalid", w, h,
                        channels);
    size_t n = (size_t)w * h * channels;
    img->data = calloc(n, sizeof(float));
    if (!img->data)
        return csi_fail(CSI_ERR_NOMEM, "out of memory for a %" PRIu32 "x%" PRIu32 "x%" PRIu32 " image", w, h, channels);
    img->w = w;
    img->h = h;
    img->channels = channels;
    return CSI_OK;
}

void csi_image_free(csi_image *img)
{
    if (!img)
        return;
    free(img->data);
    img->data = NULL;
    img->w = img->h = img->channels = 0;
}

static csi_status check_image(const char *path, const csi_image *img)
{
    if (!img || !img->data || !img->w || !img->h || img->channels < 1 || img->channels > 4)
        return csi_fail(CSI_ERR_ARG, "%s: cannot write an empty image or one with %" PRIu32 " channels", path,
                        img ? img->channels : 0);
    if (img->w > CSI_IMAGE_MAX_SIDE || img->h > CSI_IMAGE_MAX_SIDE)
        return csi_fail(CSI_ERR_ARG, "%s: image %" PRIu32 "x%" PRIu32 " is larger than %u on a side", path, img->w,
                        img->h, CSI_IMAGE_MAX_SIDE);
    return CSI_OK;
}

/* ---- sRGB -------------------------------------------------------------------------------- */

double csi_srgb_encode(double x)
{
    if (!(x > 0.0))
        return 0.0;
    if (x >= 1.0)
        return 1.0;
    return x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
}

double csi_srgb_decode(double s)
{
    if (!(s > 0.0))
        return 0.0;
    if (s >= 1.0)
        return 1.0;
    return s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
}

/* ---- EXR --------------------------------------------------------------------------------- */

/* OpenEXR reports details through a callback (default: print to stderr). The library never
 * prints: keep the last message for our own error. */
static _Thread_local char exr_msg[512];

static void exr_error_cb(exr_const_context_t ctxt, exr_result_t code, const char *msg)
{
    (void)ctxt;
    snprintf(exr_msg, sizeof exr_msg, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

static csi_status exr_fail(csi_status st, const char *path, const char *what, exr_result_t rv)
{
    if (exr_msg[0])
        return csi_fail(st, "%s: %s: %s", path, what, exr_msg);
    return csi_fail(st, "%s: %s: %s", path, what, exr_get_default_error_message(rv));
}

static int64_t exr_write_cb(exr_const_context_t ctxt, void *user, const void *buf, uint64_t sz, uint64_t offset,
                            exr_stream_error_func_ptr_t error_cb)
{
    csi_outfile *of = user;
    const unsigned char *p = buf;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = pwrite(of->fd, p + done, (size_t)(sz - done), (off_t)(offset + done));
        if (n < 0) {
            if (errno == EINTR)
                continue;
            if (error_cb)
                error_cb(ctxt, EXR_ERR_WRITE_IO, "write failed: %s", strerror(errno));
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)sz;
}

static const char *const exr_names[4][4] = {{"Y"}, {"Y", "A"}, {"R", "G", "B"}, {"R", "G", "B", "A"}};

static const char *const exr_reserved[] = {"channels", "compression", "dataWindow", "displayWindow", "lineOrder",
                                           "pixelAspectRatio", "screenWindowCenter", "screenWindowWidth", "tiles",
                                           "type", "name", "version", "chunkCount"};

/* OpenEXRCore up to 3.4.7 (Debian 12 ships 3.1.5) keeps the compressed chunk when zlib's output
 * is exactly as long as the packed pixels, but readers take a chunk of that size for raw data
 * and decode garbage (openexr issue #2306, fixed by PR #2307: the test became >=). Measured here:
 * a 64 x 64 float image whose second 16-line chunk deflated to exactly 4096 bytes read back as
 * NaN and +-3e38. The guard stores such a chunk raw, as the fixed library does. */
static exr_result_t zip_guard(exr_encode_pipeline_t *enc)
{
    typedef exr_result_t (*compress_fn_t)(exr_encode_pipeline_t *);
    compress_fn_t inner = (compress_fn_t)enc->encoding_user_data;
    exr_result_t rv = inner(enc);
    if (rv == EXR_ERR_SUCCESS && enc->compressed_bytes == enc->packed_bytes &&
        enc->compressed_buffer != enc->packed_buffer && enc->compressed_buffer)
        memcpy(enc->compressed_buffer, enc->packed_buffer, enc->packed_bytes);
    return rv;
}

csi_status csi_exr_write(const char *path, const csi_image *img, const csi_attr *attrs, size_t nattrs)
{
    return csi_exr_write_with_progress(path, img, attrs, nattrs, NULL, NULL);
}

csi_status csi_exr_write_with_progress(const char *path, const csi_image *img, const csi_attr *attrs, size_t nattrs,
                                       csi_count_progress_fn progress, void *user)
{
    CSI_TRY(check_image(path, img));
    for (size_t i = 0; i < nattrs; i++) {
        if (!attrs[i].name || !attrs[i].name[0])
            return csi_fail(CSI_ERR_ARG, "%s: header attribute %zu has no name", path, i);
        for (size_t r = 0; r < sizeof exr_reserved / sizeof exr_reserved[0]; r++)
            if (strcmp(attrs[i].name, exr_reserved[r]) == 0)
                return csi_fail(CSI_ERR_ARG, "%s: header attribute \"%s\" is reserved by EXR", path, attrs[i].name);
        for (size_t j = 0; j < i; j++)
            if (strcmp(attrs[i].name, attrs[j].name) == 0)
                return csi_fail(CSI_ERR_ARG, "%s: header attribute \"%s\" given twice", path, attrs[i].name);
        if (attrs[i].type == CSI_ATTR_INT && (attrs[i].i < INT32_MIN || attrs[i].i > INT32_MAX))
            return csi_fail(CSI_ERR_ARG, "%s: header attribute \"%s\" = %" PRId64 " does not fit EXR's int32", path,
                            attrs[i].name, attrs[i].i);
        if (attrs[i].type == CSI_ATTR_STRING && !attrs[i].s)
            return csi_fail(CSI_ERR_ARG, "%s: header attribute \"%s\" has no string", path, attrs[i].name);
    }
    csi_outfile of;
    CSI_TRY(csi_outfile_open(&of, path));

    exr_msg[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    init.user_data = &of;
    init.write_fn = exr_write_cb;
    exr_context_t f = NULL;
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    bool enc_init = false;
    csi_status st = CSI_OK;
    exr_result_t rv;
    int part = 0;
    const int32_t w = (int32_t)img->w, h = (int32_t)img->h;
    const uint32_t nc = img->channels;

#define EXR_STEP(call, what)                                  \
    do {                                                      \
        if ((rv = (call)) != EXR_ERR_SUCCESS) {               \
            st = exr_fail(CSI_ERR_IO, path, (what), rv);      \
            goto fail;                                        \
        }                                                     \
    } while (0)

    EXR_STEP(exr_start_write(&f, path, EXR_WRITE_FILE_DIRECTLY, &init), "cannot start the EXR file");
    EXR_STEP(exr_add_part(f, "main", EXR_STORAGE_SCANLINE, &part), "exr_add_part");
    EXR_STEP(exr_initialize_required_attr_simple(f, part, w, h, EXR_COMPRESSION_ZIP), "required attributes");
    for (uint32_t c = 0; c < nc; c++)
        /* Colour and luminance are "perceptually logarithmic" (0), alpha linear (1): only lossy
         * codecs use the flag, but it should be right in the file. */
        EXR_STEP(exr_add_channel(f, part, exr_names[nc - 1][c], EXR_PIXEL_FLOAT,
                                 strcmp(exr_names[nc - 1][c], "A") == 0 ? EXR_PERCEPTUALLY_LINEAR
                                                                        : EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1),
                 "exr_add_channel");
    for (size_t i = 0; i < nattrs; i++) {
        const csi_attr *a = &attrs[i];
        switch (a->type) {
        case CSI_ATTR_STRING: rv = exr_attr_set_string(f, part, a->name, a->s); break;
        case CSI_ATTR_FLOAT: rv = exr_attr_set_float(f, part, a->name, (float)a->f); break;
        case CSI_ATTR_DOUBLE: rv = exr_attr_set_double(f, part, a->name, a->f); break;
        case CSI_ATTR_INT: rv = exr_attr_set_int(f, part, a->name, (int32_t)a->i); break;
        default: rv = EXR_ERR_INVALID_ARGUMENT; break;
        }
        if (rv != EXR_ERR_SUCCESS) {
            char what[160];
            snprintf(what, sizeof what, "header attribute \"%.100s\"", a->name);
            st = exr_fail(CSI_ERR_ARG, path, what, rv);
            goto fail;
        }
    }
    EXR_STEP(exr_write_header(f), "writing the header");
    int32_t spc = 1;
    EXR_STEP(exr_get_scanlines_per_chunk(f, part, &spc), "exr_get_scanlines_per_chunk");
    for (int32_t y = 0; y < h; y += spc) {
        exr_chunk_info_t ci;
        EXR_STEP(exr_write_scanline_chunk_info(f, part, y, &ci), "chunk info");
        if (!enc_init) {
            EXR_STEP(exr_encoding_initialize(f, part, &ci, &enc), "exr_encoding_initialize");
            enc_init = true;
        } else {
            EXR_STEP(exr_encoding_update(f, part, &ci, &enc), "exr_encoding_update");
        }
        for (int16_t k = 0; k < enc.channel_count; k++) {
            exr_coding_channel_info_t *ch = &enc.channels[k];
            uint32_t c = 0;
            while (c < nc && strcmp(ch->channel_name, exr_names[nc - 1][c]) != 0)
                c++;
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = 4 * w;
            ch->encode_from_ptr = (const uint8_t *)(img->data + ((size_t)c * img->h + (size_t)ci.start_y) * img->w);
        }
        EXR_STEP(exr_encoding_choose_default_routines(f, part, &enc), "exr_encoding_choose_default_routines");
        if (enc.compress_fn && enc.compress_fn != zip_guard) {
            enc.encoding_user_data = (void *)enc.compress_fn;
            enc.compress_fn = zip_guard;
        }
        EXR_STEP(exr_encoding_run(f, part, &enc), "encoding pixels");
        if (progress && !progress(user, (uint64_t)(y + spc < h ? y + spc : h), (uint64_t)h)) {
            st = csi_fail(CSI_ERR_CANCELLED, "%s: writing was cancelled", path);
            goto fail;
        }
    }
    if (enc_init)
        exr_encoding_destroy(f, &enc);
    enc_init = false;
    rv = exr_finish(&f);
    f = NULL;
    if (rv != EXR_ERR_SUCCESS) {
        st = exr_fail(CSI_ERR_IO, path, "finishing the file", rv);
        goto fail;
    }
    return csi_outfile_commit(&of);
#undef EXR_STEP
fail:
    if (enc_init)
        exr_encoding_destroy(f, &enc);
    if (f)
        exr_finish(&f);
    csi_outfile_abort(&of);
    return st;
}

/* A decoded image of w x h x nc floats (plus `extra` bytes while decoding) must fit the host. */
static csi_status check_host(const char *path, uint64_t w, uint64_t h, uint64_t nc, uint64_t extra)
{
    const uint64_t need = w * h * nc * 4 + extra, avail = csi_host_available_bytes();
    if (avail && need > avail) {
        char a[32], b[32];
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: the %" PRIu64 "x%" PRIu64 " image needs %s of host memory, more "
                        "than the %s available", path, w, h, csi_bytes_text(need, a, sizeof a),
                        csi_bytes_text(avail, b, sizeof b));
    }
    return CSI_OK;
}

csi_status csi_exr_read(const char *path, csi_image *out)
{
    memset(out, 0, sizeof *out);
    CSI_TRY(csi_infile_check(path, "image", 0, NULL));
    exr_msg[0] = '\0';
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = exr_error_cb;
    init.flags = EXR_CONTEXT_FLAG_DISABLE_CHUNK_RECONSTRUCTION;
    exr_context_t f = NULL;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    bool dec_init = false;
    csi_status st = CSI_OK;
    exr_result_t rv;

#define EXR_STEP(call, what)                                   \
    do {                                                       \
        if ((rv = (call)) != EXR_ERR_SUCCESS) {                \
            st = exr_fail(CSI_ERR_FORMAT, path, (what), rv);   \
            goto done;                                         \
        }                                                      \
    } while (0)

    EXR_STEP(exr_start_read(&f, path, &init), "not a readable EXR file");
    exr_storage_t storage;
    EXR_STEP(exr_get_storage(f, 0, &storage), "exr_get_storage");
    if (storage != EXR_STORAGE_SCANLINE) {
        st = csi_fail(CSI_ERR_FORMAT, "%s: only scanline EXR files are supported (this one is %s)", path,
                      storage == EXR_STORAGE_TILED ? "tiled" : "deep");
        goto done;
    }
    exr_attr_box2i_t dw;
    EXR_STEP(exr_get_data_window(f, 0, &dw), "exr_get_data_window");
    const int64_t w = (int64_t)dw.max.x - dw.min.x + 1, h = (int64_t)dw.max.y - dw.min.y + 1;
    if (w < 1 || h < 1 || w > CSI_IMAGE_MAX_SIDE || h > CSI_IMAGE_MAX_SIDE) {
        st = csi_fail(CSI_ERR_FORMAT, "%s: data window %" PRId64 "x%" PRId64 " is empty or larger than %u", path, w, h,
                      CSI_IMAGE_MAX_SIDE);
        goto done;
    }
    const exr_attr_chlist_t *chl;
    EXR_STEP(exr_get_channels(f, 0, &chl), "exr_get_channels");
    /* Choose the channels: R G B [A], else Y [A], else the only channel. */
    const char *want[4];
    int nwant = 0;
    bool has[256] = {false};
    for (int i = 0; i < chl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        if (e->name.length == 1)
            has[(unsigned char)e->name.str[0]] = true;
    }
    if (has['R'] && has['G'] && has['B']) {
        want[0] = "R", want[1] = "G", want[2] = "B", nwant = 3;
        if (has['A'])
            want[nwant++] = "A";
    } else if (has['Y']) {
        want[0] = "Y", nwant = 1;
        if (has['A'])
            want[nwant++] = "A";
    } else if (chl->num_channels == 1) {
        want[0] = chl->entries[0].name.str, nwant = 1;
    } else {
        st = csi_fail(CSI_ERR_FORMAT, "%s: no R,G,B or Y channels among its %d channels", path, chl->num_channels);
        goto done;
    }
    for (int i = 0; i < chl->num_channels; i++) {
        const exr_attr_chlist_entry_t *e = &chl->entries[i];
        for (int c = 0; c < nwant; c++)
            if (strcmp(e->name.str, want[c]) == 0) {
                if (e->pixel_type == EXR_PIXEL_UINT) {
                    st = csi_fail(CSI_ERR_FORMAT, "%s: channel %s holds integers, not an image", path, want[c]);
                    goto done;
                }
                if (e->x_sampling != 1 || e->y_sampling != 1) {
                    st = csi_fail(CSI_ERR_FORMAT, "%s: channel %s is subsampled; not supported", path, want[c]);
                    goto done;
                }
            }
    }
    if ((st = check_host(path, (uint64_t)w, (uint64_t)h, (uint64_t)nwant, 0)) != CSI_OK ||
        (st = csi_image_alloc(out, (uint32_t)w, (uint32_t)h, (uint32_t)nwant)) != CSI_OK)
        goto done;
    int32_t spc = 1;
    EXR_STEP(exr_get_scanlines_per_chunk(f, 0, &spc), "exr_get_scanlines_per_chunk");
    for (int64_t y = dw.min.y; y <= dw.max.y; y += spc) {
        exr_chunk_info_t ci;
        EXR_STEP(exr_read_scanline_chunk_info(f, 0, (int)y, &ci), "reading chunk information");
        if (!dec_init) {
            EXR_STEP(exr_decoding_initialize(f, 0, &ci, &dec), "exr_decoding_initialize");
            dec_init = true;
        } else {
            EXR_STEP(exr_decoding_update(f, 0, &ci, &dec), "exr_decoding_update");
        }
        for (int16_t k = 0; k < dec.channel_count; k++) {
            exr_coding_channel_info_t *ch = &dec.channels[k];
            int c = 0;
            while (c < nwant && strcmp(ch->channel_name, want[c]) != 0)
                c++;
            if (c == nwant) {
                ch->decode_to_ptr = NULL; /* not wanted: skipped */
                continue;
            }
            ch->user_bytes_per_element = 4;
            ch->user_data_type = EXR_PIXEL_FLOAT;
            ch->user_pixel_stride = 4;
            ch->user_line_stride = (int32_t)(4 * w);
            ch->decode_to_ptr =
                (uint8_t *)(out->data + ((size_t)c * (size_t)h + (size_t)(ci.start_y - dw.min.y)) * (size_t)w);
        }
        EXR_STEP(exr_decoding_choose_default_routines(f, 0, &dec), "exr_decoding_choose_default_routines");
        EXR_STEP(exr_decoding_run(f, 0, &dec), "decoding pixels");
    }
#undef EXR_STEP
done:
    if (dec_init)
        exr_decoding_destroy(f, &dec);
    if (f)
        exr_finish(&f);
    if (st != CSI_OK)
        csi_image_free(out);
    return st;
}

/* ---- PNG --------------------------------------------------------------------------------- */

typedef struct {
    jmp_buf jb;
    char msg[256];
} png_err;

static void png_error_cb(png_structp png, png_const_charp msg)
{
    png_err *e = png_get_error_ptr(png);
    snprintf(e->msg, sizeof e->msg, "%s", msg);
    longjmp(e->jb, 1);
}

static void png_warn_cb(png_structp png, png_const_charp msg) { (void)png, (void)msg; }

csi_status csi_png_write(const char *path, const csi_image *img)
{
    CSI_TRY(check_image(path, img));
    const uint32_t w = img->w, h = img->h, nc = img->channels;
    const bool has_alpha = nc == 2 || nc == 4;
    const size_t plane = (size_t)w * h;
    unsigned char *pix = malloc(plane * nc);
    png_bytep *rows = malloc(h * sizeof *rows);
    if (!pix || !rows) {
        free(pix);
        free(rows);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory", path);
    }
    for (uint32_t c = 0; c < nc; c++) {
        const bool alpha = has_alpha && c == nc - 1;
        const float *src = img->data + c * plane;
        for (size_t i = 0; i < plane; i++) {
            double v = src[i];
            v = v > 0 ? (v < 1 ? v : 1) : 0; /* clamp; NaN -> 0 */
            if (!alpha)
                v = csi_srgb_encode(v);
            pix[i * nc + c] = (unsigned char)lround(v * 255.0);
        }
    }
    for (uint32_t y = 0; y < h; y++)
        rows[y] = pix + (size_t)y * w * nc;

    csi_outfile of;
    csi_status st = csi_outfile_open(&of, path);
    if (st != CSI_OK) {
        free(pix);
        free(rows);
        return st;
    }
    png_err err = {.msg = ""};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, png_error_cb, png_warn_cb);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        csi_outfile_abort(&of);
        free(pix);
        free(rows);
        return csi_fail(CSI_ERR_NOMEM, "%s: libpng could not start", path);
    }
    if (setjmp(err.jb)) {
        png_destroy_write_struct(&png, &info);
        csi_outfile_abort(&of);
        free(pix);
        free(rows);
        return csi_fail(CSI_ERR_IO, "%s: writing PNG: %s", path, err.msg);
    }
    static const int types[4] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                 PNG_COLOR_TYPE_RGB_ALPHA};
    png_init_io(png, of.fp);
    png_set_IHDR(png, info, w, h, 8, types[nc - 1], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    png_write_image(png, rows);
    png_write_end(png, info);
    png_destroy_write_struct(&png, &info);
    free(pix);
    free(rows);
    return csi_outfile_commit(&of);
}

csi_status csi_png_read(const char *path, csi_image *out)
{
    memset(out, 0, sizeof *out);
    FILE *fp;
    CSI_TRY(csi_infile_open(path, "image", 0, &fp, NULL));
    unsigned char sig[8];
    if (fread(sig, 1, 8, fp) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
        fclose(fp);
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 0: not a PNG file (bad signature)", path);
    }
    png_err err = {.msg = ""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, png_error_cb, png_warn_cb);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return csi_fail(CSI_ERR_NOMEM, "%s: libpng could not start", path);
    }
    /* Everything allocated after setjmp is reachable through `out` or these volatile pointers. */
    unsigned char *volatile pix = NULL;
    png_bytep *volatile rows = NULL;
    if (setjmp(err.jb)) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        free(pix);
        free(rows);
        csi_image_free(out);
        return csi_fail(CSI_ERR_FORMAT, "%s: reading PNG: %s", path, err.msg);
    }
    png_init_io(png, fp);
    png_set_sig_bytes(png, 8);
    png_set_user_limits(png, CSI_IMAGE_MAX_SIDE, CSI_IMAGE_MAX_SIDE);
    png_read_info(png, info);
    png_set_expand(png); /* palette -> RGB, gray < 8 bits -> 8, tRNS -> alpha */
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const uint32_t w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    const int nc = png_get_channels(png, info), depth = png_get_bit_depth(png, info);
    const size_t rowbytes = png_get_rowbytes(png, info);
    if (nc < 1 || nc > 4 || (depth != 8 && depth != 16))
        png_error(png, "unsupported channel count or bit depth");
    if (check_host(path, w, h, (uint64_t)nc, (uint64_t)rowbytes * h) != CSI_OK) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return CSI_ERR_TOO_LARGE;
    }
    if (csi_image_alloc(out, w, h, (uint32_t)nc) != CSI_OK)
        png_error(png, "out of memory");
    pix = malloc(rowbytes * h);
    rows = malloc(h * sizeof(png_bytep));
    if (!pix || !rows)
        png_error(png, "out of memory");
    for (uint32_t y = 0; y < h; y++)
        rows[y] = pix + (size_t)y * rowbytes;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);

    /* Decode through tables (exactly the function csi_srgb_decode, rounded once to float). */
    const bool has_alpha = nc == 2 || nc == 4;
    const size_t levels = depth == 16 ? 65536 : 256;
    float *lut = malloc(levels * sizeof *lut);
    if (!lut) {
        free(pix);
        free(rows);
        csi_image_free(out);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory", path);
    }
    for (size_t i = 0; i < levels; i++)
        lut[i] = (float)csi_srgb_decode((double)i / (double)(levels - 1));
    const size_t plane = (size_t)w * h;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            for (int c = 0; c < nc; c++) {
                size_t k = (size_t)x * nc + c;
                unsigned v = depth == 16 ? (unsigned)rows[y][2 * k] << 8 | rows[y][2 * k + 1] : rows[y][k];
                bool alpha = has_alpha && c == nc - 1;
                out->data[c * plane + (size_t)y * w + x] = alpha ? (float)((double)v / (double)(levels - 1)) : lut[v];
            }
    free(lut);
    free(pix);
    free(rows);
    return CSI_OK;
}

csi_status csi_image_read(const char *path, csi_image *out)
{
    memset(out, 0, sizeof *out);
    FILE *fp;
    CSI_TRY(csi_infile_open(path, "image", 0, &fp, NULL));
    unsigned char m[4] = {0};
    size_t got = fread(m, 1, 4, fp);
    fclose(fp);
    if (got == 4 && m[0] == 0x89 && m[1] == 'P' && m[2] == 'N' && m[3] == 'G')
        return csi_png_read(path, out);
    if (got == 4 && m[0] == 0x76 && m[1] == 0x2f && m[2] == 0x31 && m[3] == 0x01)
        return csi_exr_read(path, out);
    return csi_fail(CSI_ERR_FORMAT, "%s: byte 0: neither a PNG nor an EXR file", path);
}
