/* Images: EXR float32 round trips bit for bit, header attributes read back through OpenEXR's
 * C API, PNG 8-bit round trips and the sRGB encoding, unwritable paths, corrupt files. */
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <openexr.h>
#include <png.h>

#include "csi/image.h"
#include "testlib.h"

static char dir[256];

static int count_files(void)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

static const char *pathof(const char *name)
{
    static char p[2][512];
    static int k;
    k ^= 1;
    snprintf(p[k], sizeof p[k], "%s/%s", dir, name);
    return p[k];
}

static int test_exr_roundtrip(void)
{
    test_rng r;
    test_rng_seed(&r, 42);
    for (uint32_t nc = 1; nc <= 4; nc++) {
        csi_image img, back;
        /* 37 x 23: not a multiple of ZIP's 16-line chunks, so the short last chunk is exercised. */
        REQUIRE_OK(csi_image_alloc(&img, 37, 23, nc));
        size_t n = (size_t)37 * 23 * nc;
        for (size_t i = 0; i < n; i++)
            img.data[i] = (float)(test_rng_normal(&r) * pow(10.0, (double)(i % 9) - 4)); /* HDR: 1e-4 .. 1e4 */
        img.data[0] = 0.0f;
        img.data[1] = -0.0f;
        img.data[2] = 65504.0f * 1000.0f; /* beyond half's range: float32 must be kept */
        const char *p = pathof("rt.exr");
        REQUIRE_OK(csi_exr_write(p, &img, NULL, 0));
        REQUIRE_OK(csi_exr_read(p, &back));
        CHECK(back.w == 37 && back.h == 23 && back.channels == nc, "%u channels: size %ux%ux%u", nc, back.w, back.h,
              back.channels);
        CHECK(memcmp(back.data, img.data, n * sizeof(float)) == 0, "%u channels: float32 bit for bit", nc);
        csi_image_free(&back);
        REQUIRE_OK(csi_image_read(p, &back)); /* dispatch by magic */
        CHECK(back.channels == nc && memcmp(back.data, img.data, n * sizeof(float)) == 0, "image_read dispatch");
        csi_image_free(&back);
        /* Channel names as the format expects them (read back through the C API). */
        exr_context_t f;
        exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
        REQUIRE_OK(exr_start_read(&f, p, &init) == EXR_ERR_SUCCESS ? CSI_OK : CSI_ERR_FORMAT);
        const exr_attr_chlist_t *chl;
        exr_get_channels(f, 0, &chl);
        char names[16] = "";
        for (int i = 0; i < chl->num_channels; i++) {
            strcat(names, chl->entries[i].name.str);
            CHECK(chl->entries[i].pixel_type == EXR_PIXEL_FLOAT, "float32 channel");
        }
        static const char *want[4] = {"Y", "AY", "BGR", "ABGR"}; /* stored sorted by name */
        CHECK(strcmp(names, want[nc - 1]) == 0, "channel names %s", names);
        exr_finish(&f);
        csi_image_free(&img);
    }
    return 0;
}

/* A half-float RGB EXR with a data window not at the origin, written directly through the C
 * API (the library converts our float32 input to half): the reader must convert back to
 * float32. The values k/64 in [-4, 4) are exact in half, so the comparison is exact. */
static int test_exr_half(void)
{
    const int w = 13, h = 21, x0 = -3, y0 = 5;
    float *src = malloc((size_t)w * h * 3 * sizeof *src);
    for (int i = 0; i < w * h * 3; i++)
        src[i] = (float)((i * 37) % 512 - 256) / 64.0f;
    const char *p = pathof("half.exr");
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    int part = 0, bad = 0;
    bad |= exr_start_write(&f, p, EXR_WRITE_FILE_DIRECTLY, &init);
    bad |= exr_add_part(f, "main", EXR_STORAGE_SCANLINE, &part);
    exr_attr_box2i_t dw;
    dw.min.x = x0, dw.min.y = y0, dw.max.x = x0 + w - 1, dw.max.y = y0 + h - 1;
    exr_attr_v2f_t swc;
    swc.x = 0, swc.y = 0;
    bad |= exr_initialize_required_attr(f, part, &dw, &dw, 1.0f, &swc, 1.0f, EXR_LINEORDER_INCREASING_Y,
                                        EXR_COMPRESSION_PIZ);
    const char *names[3] = {"B", "G", "R"}; /* any order: the reader matches names */
    for (int c = 0; c < 3; c++)
        bad |= exr_add_channel(f, part, names[c], EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1);
    bad |= exr_write_header(f);
    int32_t spc;
    bad |= exr_get_scanlines_per_chunk(f, part, &spc);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    for (int y = y0; y < y0 + h && !bad; y += spc) {
        exr_chunk_info_t ci;
        bad |= exr_write_scanline_chunk_info(f, part, y, &ci);
        bad |= y == y0 ? exr_encoding_initialize(f, part, &ci, &enc) : exr_encoding_update(f, part, &ci, &enc);
        for (int k = 0; k < enc.channel_count; k++) {
            int c = enc.channels[k].channel_name[0] == 'R' ? 0 : enc.channels[k].channel_name[0] == 'G' ? 1 : 2;
            enc.channels[k].user_bytes_per_element = 4;
            enc.channels[k].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[k].user_pixel_stride = 4;
            enc.channels[k].user_line_stride = 4 * w;
            enc.channels[k].encode_from_ptr = (const uint8_t *)(src + ((size_t)c * h + (size_t)(y - y0)) * w);
        }
        bad |= exr_encoding_choose_default_routines(f, part, &enc);
        bad |= exr_encoding_run(f, part, &enc);
    }
    exr_encoding_destroy(f, &enc);
    bad |= exr_finish(&f);
    CHECK(bad == 0, "writing the half test file through the C API");
    csi_image back;
    REQUIRE_OK(csi_exr_read(p, &back));
    CHECK(back.w == (uint32_t)w && back.h == (uint32_t)h && back.channels == 3, "size %ux%u", back.w, back.h);
    CHECK(memcmp(back.data, src, (size_t)w * h * 3 * sizeof *src) == 0, "half values converted exactly");
    csi_image_free(&back);
    free(src);
    return 0;
}

static int test_exr_attributes(void)
{
    csi_image img;
    REQUIRE_OK(csi_image_alloc(&img, 8, 4, 3));
    for (size_t i = 0; i < 96; i++)
        img.data[i] = (float)i / 96.0f;
    const csi_attr attrs[] = {
        CSI_ATTR_S("csi:solver", "romp"),
        CSI_ATTR_F("csi:lambda", 0.125),
        CSI_ATTR_D("csi:residual", 1.0 / 3.0),
        CSI_ATTR_I("csi:iterations", 417),
        CSI_ATTR_S("csi:note", "quotes \" and \\ kept"),
    };
    const char *p = pathof("attrs.exr");
    REQUIRE_OK(csi_exr_write(p, &img, attrs, 5));
    exr_context_t f;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    REQUIRE_OK(exr_start_read(&f, p, &init) == EXR_ERR_SUCCESS ? CSI_OK : CSI_ERR_FORMAT);
    const char *s = NULL;
    int32_t len = 0;
    CHECK(exr_attr_get_string(f, 0, "csi:solver", &len, &s) == EXR_ERR_SUCCESS && len == 4 && memcmp(s, "romp", 4) == 0,
          "string attribute");
    float fl = 0;
    CHECK(exr_attr_get_float(f, 0, "csi:lambda", &fl) == EXR_ERR_SUCCESS && fl == 0.125f, "float attribute %g", fl);
    double db = 0;
    CHECK(exr_attr_get_double(f, 0, "csi:residual", &db) == EXR_ERR_SUCCESS && db == 1.0 / 3.0, "double attribute");
    int32_t it = 0;
    CHECK(exr_attr_get_int(f, 0, "csi:iterations", &it) == EXR_ERR_SUCCESS && it == 417, "int attribute %d", it);
    CHECK(exr_attr_get_string(f, 0, "csi:note", &len, &s) == EXR_ERR_SUCCESS &&
              len == (int32_t)strlen("quotes \" and \\ kept") && memcmp(s, "quotes \" and \\ kept", (size_t)len) == 0,
          "string with quotes");
    exr_compression_t comp;
    CHECK(exr_get_compression(f, 0, &comp) == EXR_ERR_SUCCESS && comp == EXR_COMPRESSION_ZIP, "lossless ZIP");
    exr_finish(&f);

    /* Refused attributes leave no file. */
    int before = count_files();
    const csi_attr bad1[] = {CSI_ATTR_S("channels", "x")};
    CHECK(csi_exr_write(pathof("bad.exr"), &img, bad1, 1) == CSI_ERR_ARG && strstr(csi_last_error(), "reserved"),
          "%s", csi_last_error());
    const csi_attr bad2[] = {CSI_ATTR_I("a", 1), CSI_ATTR_I("a", 2)};
    CHECK(csi_exr_write(pathof("bad.exr"), &img, bad2, 2) == CSI_ERR_ARG && strstr(csi_last_error(), "twice"), "%s",
          csi_last_error());
    const csi_attr bad3[] = {CSI_ATTR_I("big", INT64_C(1) << 40)};
    CHECK(csi_exr_write(pathof("bad.exr"), &img, bad3, 1) == CSI_ERR_ARG, "int64 out of range");
    CHECK(count_files() == before, "no file left by refused writes");
    csi_image_free(&img);
    return 0;
}

/* Reads raw 8-bit PNG samples with libpng directly (independent of csi_png_read). */
static int raw_png(const char *path, unsigned char *out, size_t n)
{
    png_image im;
    memset(&im, 0, sizeof im);
    im.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&im, path))
        return -1;
    if (PNG_IMAGE_SIZE(im) != n) {
        png_image_free(&im);
        return -1;
    }
    /* Keep the stored format: no colour-space conversion. */
    if (!png_image_finish_read(&im, NULL, out, 0, NULL))
        return -1;
    return (int)PNG_IMAGE_SAMPLE_CHANNELS(im.format);
}

static int test_png(void)
{
    /* The sRGB curve: values from IEC 61966-2-1's formula evaluated independently. */
    CHECK(fabs(csi_srgb_encode(0.5) - 0.7353569830524495) < 1e-12, "encode(0.5) %.16g", csi_srgb_encode(0.5));
    CHECK(fabs(csi_srgb_decode(0.5) - 0.21404114048223255) < 1e-12, "decode(0.5) %.16g", csi_srgb_decode(0.5));
    CHECK(fabs(csi_srgb_encode(0.0031308) - 0.04044994) < 1e-7 && csi_srgb_encode(2) == 1 && csi_srgb_encode(-1) == 0,
          "knee and clamps");

    /* Round trip of 8-bit values: every code, as linear floats, written and read back. */
    test_rng r;
    test_rng_seed(&r, 9);
    for (uint32_t nc = 1; nc <= 4; nc++) {
        const uint32_t w = 64, h = 9;
        const size_t plane = (size_t)w * h;
        csi_image img, back;
        REQUIRE_OK(csi_image_alloc(&img, w, h, nc));
        unsigned char *codes = malloc(plane * nc);
        for (uint32_t c = 0; c < nc; c++)
            for (size_t i = 0; i < plane; i++) {
                unsigned code = (unsigned)((i + 37 * c) % 256);
                bool alpha = (nc == 2 || nc == 4) && c == nc - 1;
                codes[i * nc + c] = (unsigned char)code;
                img.data[c * plane + i] = alpha ? (float)(code / 255.0) : (float)csi_srgb_decode(code / 255.0);
            }
        const char *p = pathof("rt.png");
        REQUIRE_OK(csi_png_write(p, &img));
        unsigned char *raw = malloc(plane * nc);
        int got = raw_png(p, raw, plane * nc);
        CHECK(got == (int)nc && memcmp(raw, codes, plane * nc) == 0, "%u channels: stored 8-bit codes", nc);
        REQUIRE_OK(csi_png_read(p, &back));
        CHECK(back.w == w && back.h == h && back.channels == nc, "size");
        CHECK(memcmp(back.data, img.data, plane * nc * sizeof(float)) == 0, "%u channels: decoded values exact", nc);
        csi_image_free(&back);
        free(raw);
        free(codes);
        csi_image_free(&img);
    }
    /* Clamping: above 1, below 0, NaN, Inf. */
    csi_image img, back;
    REQUIRE_OK(csi_image_alloc(&img, 4, 1, 1));
    img.data[0] = 7.0f, img.data[1] = -3.0f, img.data[2] = NAN, img.data[3] = INFINITY;
    REQUIRE_OK(csi_png_write(pathof("clamp.png"), &img));
    unsigned char raw[4];
    CHECK(raw_png(pathof("clamp.png"), raw, 4) == 1 && raw[0] == 255 && raw[1] == 0 && raw[2] == 0 && raw[3] == 255,
          "clamped %u %u %u %u", raw[0], raw[1], raw[2], raw[3]);
    csi_image_free(&img);
    /* Mid-grey: linear 0.5 encodes to round(255 * 0.7353569830524495) = 188. */
    REQUIRE_OK(csi_image_alloc(&img, 1, 1, 1));
    img.data[0] = 0.5f;
    REQUIRE_OK(csi_png_write(pathof("grey.png"), &img));
    CHECK(raw_png(pathof("grey.png"), raw, 1) == 1 && raw[0] == 188, "0.5 -> %u", raw[0]);
    REQUIRE_OK(csi_image_read(pathof("grey.png"), &back));
    CHECK(back.channels == 1 && back.data[0] == (float)csi_srgb_decode(188.0 / 255.0), "dispatch to PNG");
    csi_image_free(&back);
    csi_image_free(&img);

    /* A 16-bit gray+alpha PNG written with libpng directly: colour decoded through the sRGB
     * curve at 16-bit resolution, alpha linear. */
    {
        FILE *f = fopen(pathof("deep.png"), "wb");
        png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
        png_infop info = png_create_info_struct(png);
        png_init_io(png, f);
        png_set_IHDR(png, info, 2, 1, 16, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                     PNG_FILTER_TYPE_DEFAULT);
        png_write_info(png, info);
        unsigned char row[8] = {0x80, 0x00, 0xff, 0xff, 0x12, 0x34, 0x40, 0x00}; /* big-endian samples */
        png_write_row(png, row);
        png_write_end(png, info);
        png_destroy_write_struct(&png, &info);
        fclose(f);
        REQUIRE_OK(csi_png_read(pathof("deep.png"), &back));
        CHECK(back.w == 2 && back.h == 1 && back.channels == 2, "16-bit size");
        CHECK(back.data[0] == (float)csi_srgb_decode(0x8000 / 65535.0) &&
                  back.data[1] == (float)csi_srgb_decode(0x1234 / 65535.0),
              "16-bit gray %.9g %.9g", back.data[0], back.data[1]);
        CHECK(back.data[2] == 1.0f && back.data[3] == (float)(0x4000 / 65535.0), "16-bit alpha linear");
        csi_image_free(&back);
    }
    return 0;
}

static int read_file(const char *path, unsigned char **out, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    rewind(f);
    *out = malloc(*n ? *n : 1);
    const int ok = fread(*out, 1, *n, f) == *n;
    fclose(f);
    return ok;
}

/* csi_exr_write_with_progress: the same bytes as csi_exr_write, one report per ZIP chunk of 16
 * scanlines (ceil(h / 16)), counting up to (h, h); a cancel (mid-file and at the last chunk)
 * returns CSI_ERR_CANCELLED and leaves no file, temporary or final. */
static int test_exr_progress(void)
{
    csi_image img;
    REQUIRE_OK(csi_image_alloc(&img, 19, 70, 3)); /* 70 lines: 5 chunks, the last of 6 lines */
    for (size_t i = 0; i < (size_t)19 * 70 * 3; i++)
        img.data[i] = (float)(i % 97) * 0.25f;
    unsigned char *a = NULL, *b = NULL;
    size_t na = 0, nb = 0;
    REQUIRE_OK(csi_exr_write(pathof("plain.exr"), &img, NULL, 0));
    test_count_log l = {0};
    REQUIRE_OK(csi_exr_write_with_progress(pathof("prog.exr"), &img, NULL, 0, test_count_progress, &l));
    CHECK(read_file(pathof("plain.exr"), &a, &na) && read_file(pathof("prog.exr"), &b, &nb) && na == nb &&
              memcmp(a, b, na) == 0, "progress changed the file's bytes (%zu vs %zu)", na, nb);
    CHECK(l.calls == 5 && !l.backwards && l.last_done == 70 && l.last_total == 70,
          "%zu reports, last %llu of %llu, %d backwards", l.calls, (unsigned long long)l.last_done,
          (unsigned long long)l.last_total, l.backwards);
    const int before = count_files();
    for (size_t stop = 2; stop <= 5; stop += 3) {
        test_count_log c = {.stop_at = stop};
        CHECK(csi_exr_write_with_progress(pathof("cancel.exr"), &img, NULL, 0, test_count_progress, &c) == CSI_ERR_CANCELLED &&
                  strstr(csi_last_error(), "cancel.exr") && c.calls == stop,
              "cancel at report %zu: %s", stop, csi_last_error());
        CHECK(count_files() == before, "cancel at report %zu left a file", stop);
    }
    free(a);
    free(b);
    csi_image_free(&img);
    return 0;
}

static int test_bad_paths(void)
{
    csi_image img, back;
    REQUIRE_OK(csi_image_alloc(&img, 4, 4, 3));
    int before = count_files();
    CHECK(csi_exr_write(pathof("nodir/x.exr"), &img, NULL, 0) == CSI_ERR_IO && strstr(csi_last_error(), "x.exr"),
          "%s", csi_last_error());
    CHECK(csi_png_write(pathof("nodir/x.png"), &img) == CSI_ERR_IO && strstr(csi_last_error(), "x.png"), "%s",
          csi_last_error());
    /* Destination is a directory: everything is written, the rename fails, nothing is left. */
    mkdir(pathof("adir.exr"), 0755);
    mkdir(pathof("adir.png"), 0755);
    before = count_files();
    CHECK(csi_exr_write(pathof("adir.exr"), &img, NULL, 0) == CSI_ERR_IO, "exr over a directory");
    CHECK(csi_png_write(pathof("adir.png"), &img) == CSI_ERR_IO, "png over a directory");
    CHECK(count_files() == before, "no temporary file left");
    rmdir(pathof("adir.exr"));
    rmdir(pathof("adir.png"));

    /* Corrupt and foreign files: clear errors, no crash. */
    REQUIRE_OK(csi_exr_write(pathof("good.exr"), &img, NULL, 0));
    FILE *f = fopen(pathof("good.exr"), "rb");
    unsigned char buf[4096];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    f = fopen(pathof("cut.exr"), "wb");
    fwrite(buf, 1, n / 2, f);
    fclose(f);
    csi_status st = csi_exr_read(pathof("cut.exr"), &back);
    CHECK(st == CSI_ERR_FORMAT && back.data == NULL && strstr(csi_last_error(), "cut.exr"), "truncated EXR: %s",
          csi_last_error());
    f = fopen(pathof("junk.png"), "wb");
    fwrite("\x89PNG\r\n\x1a\njunkjunkjunk", 1, 20, f);
    fclose(f);
    st = csi_png_read(pathof("junk.png"), &back);
    CHECK(st == CSI_ERR_FORMAT && strstr(csi_last_error(), "junk.png"), "corrupt PNG: %s", csi_last_error());
    st = csi_image_read(pathof("good.exr.missing"), &back);
    CHECK(st == CSI_ERR_IO, "missing: %s", csi_last_error());
    f = fopen(pathof("text.txt"), "wb");
    fputs("hello", f);
    fclose(f);
    st = csi_image_read(pathof("text.txt"), &back);
    CHECK(st == CSI_ERR_FORMAT && strstr(csi_last_error(), "neither"), "%s", csi_last_error());
    st = csi_png_read(pathof("text.txt"), &back);
    CHECK(st == CSI_ERR_FORMAT && strstr(csi_last_error(), "not a PNG"), "%s", csi_last_error());
    img.channels = 5;
    CHECK(csi_png_write(pathof("five.png"), &img) == CSI_ERR_ARG, "5 channels refused");
    img.channels = 3;
    csi_image_free(&img);
    return 0;
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s/test_image_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir))
        return 1;
    test_exr_roundtrip();
    test_exr_half();
    test_exr_attributes();
    test_png();
    test_exr_progress();
    test_bad_paths();
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return test_done();
}
