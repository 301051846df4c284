/* csi-mkdump: makes a sample dump (docs/dump-format.md) from an image at fine resolution.
 *
 * The image IS the fine grid: its pixels are the cells, each sample takes the value of its
 * cell. For 3-D, a numbered sequence of frames gives the grid's t axis. Positions come from
 * csi_positions (Poisson-disk, stratified or random; seeded). Uses csi/csi.h only. */
#include <errno.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"

#define DEFAULT_SEED 1
#define DEFAULT_SPP 4

static void usage(FILE *f)
{
    fprintf(f,
            "usage: csi-mkdump IMAGE.png|IMAGE.exr -o OUT.csid --out WxH [options]\n"
            "       csi-mkdump --frames 'dir/frame_%%03d.png' --count T -o OUT.csid --out WxH [options]\n"
            "\n"
            "Makes a csi sample dump from an image whose pixels are the fine grid (a sequence of\n"
            "frames for 3-D: frame t is the grid's slice t). Each sample takes its cell's value\n"
            "(PNG is decoded from sRGB to linear; EXR is used as is).\n"
            "\n"
            "  -o, --output FILE     the dump to write (written whole or not at all)\n"
            "  --out WxH             final image size; the image size must be a multiple of it\n"
            "  --spp N               samples per output pixel (over all frames in 3-D) [%d]\n"
            "  --fraction F          instead of --spp: a fraction 0 < F <= 1 of all grid cells\n"
            "  --method M            poisson (default), stratified or random\n"
            "  --seed S              seed of the positions, also stored in the dump [%d]\n"
            "  --frames PATTERN      printf-style pattern with one integer conversion, e.g. %%03d\n"
            "  --count T             number of frames (T >= 2)\n"
            "  --start N             number of the first frame [0]\n"
            "  --exact               flag the dump's values as exact: the image holds a noise-free\n"
            "                        signal's values at the cell centres (a deterministic render,\n"
            "                        an analytic image), not a photograph's pixel integrals or a\n"
            "                        Monte Carlo render; csi-reconstruct's --correct auto then takes\n"
            "                        cv instead of blend (docs/dump-format.md)\n"
            "  -q, --quiet           no summary line\n"
            "  -h, --help            this text\n"
            "  --version             version\n"
            "\n"
            "Exit status: 0 on success, 2 on bad arguments or input, or when the output cannot be\n"
            "written.\n",
            DEFAULT_SPP, DEFAULT_SEED);
}

static const char *prog = "csi-mkdump";

/* One line "csi-mkdump: error: ...", exit status 2 (bad arguments or input). */
static int die(const char *fmt, const char *arg)
{
    char msg[4096];
    snprintf(msg, sizeof msg, fmt, arg);
    return cli_error(prog, CSI_ERR_ARG, "%s", msg);
}

static int lib_fail(void)
{
    return cli_error(prog, CSI_ERR_ARG, "%s", cli_last_error());
}

static bool parse_u64(const char *s, uint64_t *out)
{
    if (!s || !*s || *s == '-' || *s == '+')
        return false;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(s, &end, 10);
    if (errno || *end)
        return false;
    *out = v;
    return true;
}

static bool parse_u32(const char *s, uint32_t *out)
{
    uint64_t v;
    if (!parse_u64(s, &v) || v > UINT32_MAX)
        return false;
    *out = (uint32_t)v;
    return true;
}

static bool parse_size(const char *s, uint32_t *w, uint32_t *h)
{
    const char *x = s ? strchr(s, 'x') : NULL;
    if (!x)
        return false;
    char a[32];
    size_t n = (size_t)(x - s);
    if (n == 0 || n >= sizeof a)
        return false;
    memcpy(a, s, n);
    a[n] = '\0';
    return parse_u32(a, w) && parse_u32(x + 1, h) && *w > 0 && *h > 0;
}

/* The pattern must hold exactly one integer conversion (%d, %i, %u with optional 0 flag and
 * width, at most PATTERN_WIDTH_MAX: a frame number has 10 digits, and a width of a million would
 * make a path of a megabyte) and otherwise only %% escapes, so passing it to snprintf is safe. */
#define PATTERN_WIDTH_MAX 20
static bool check_pattern(const char *p)
{
    int convs = 0;
    for (const char *s = p; *s; s++) {
        if (*s != '%')
            continue;
        s++;
        if (*s == '%')
            continue;
        while (*s == '0')
            s++;
        unsigned width = 0;
        while (*s >= '0' && *s <= '9') {
            width = width * 10 + (unsigned)(*s - '0');
            if (width > PATTERN_WIDTH_MAX)
                return false;
            s++;
        }
        if (*s != 'd' && *s != 'i' && *s != 'u')
            return false;
        convs++;
    }
    return convs == 1;
}

int main(int argc, char **argv)
{
    const char *input = NULL, *output = NULL, *frames = NULL, *method_s = "poisson";
    uint32_t out_w = 0, out_h = 0, spp = 0, count = 0, start = 0;
    double fraction = 0;
    uint64_t seed = DEFAULT_SEED;
    bool have_out = false, have_spp = false, have_fraction = false, have_count = false, quiet = false;
    bool exact = false;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
#define NEED_VALUE()                                                  \
    do {                                                              \
        if (!v)                                                       \
            return die("option %s needs a value (see --help)", a);    \
        i++;                                                          \
    } while (0)
        if (!strcmp(a, "-h") || !strcmp(a, "--help")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--version")) {
            printf("csi-mkdump %s\n", CSI_VERSION);
            return 0;
        } else if (!strcmp(a, "-q") || !strcmp(a, "--quiet")) {
            quiet = true;
        } else if (!strcmp(a, "--exact")) {
            exact = true;
        } else if (!strcmp(a, "-o") || !strcmp(a, "--output")) {
            NEED_VALUE();
            output = v;
        } else if (!strcmp(a, "--out")) {
            NEED_VALUE();
            if (!parse_size(v, &out_w, &out_h))
                return die("--out \"%s\" is not a size WxH with positive integers", v);
            have_out = true;
        } else if (!strcmp(a, "--spp")) {
            NEED_VALUE();
            if (!parse_u32(v, &spp) || spp == 0)
                return die("--spp \"%s\" is not a positive integer", v);
            have_spp = true;
        } else if (!strcmp(a, "--fraction")) {
            NEED_VALUE();
            char *end;
            errno = 0;
            fraction = strtod(v, &end);
            if (errno || *end || !(fraction > 0 && fraction <= 1))
                return die("--fraction \"%s\" is not a number in (0, 1]", v);
            have_fraction = true;
        } else if (!strcmp(a, "--method")) {
            NEED_VALUE();
            method_s = v;
        } else if (!strcmp(a, "--seed")) {
            NEED_VALUE();
            if (!parse_u64(v, &seed))
                return die("--seed \"%s\" is not a non-negative integer", v);
        } else if (!strcmp(a, "--frames")) {
            NEED_VALUE();
            frames = v;
        } else if (!strcmp(a, "--count")) {
            NEED_VALUE();
            if (!parse_u32(v, &count))
                return die("--count \"%s\" is not a non-negative integer", v);
            have_count = true;
        } else if (!strcmp(a, "--start")) {
            NEED_VALUE();
            if (!parse_u32(v, &start))
                return die("--start \"%s\" is not a non-negative integer", v);
        } else if (a[0] == '-' && a[1] != '\0') {
            return die("unknown option %s (see --help)", a);
        } else if (!input) {
            input = a;
        } else {
            return die("more than one input image (\"%s\"); for frames use --frames", a);
        }
#undef NEED_VALUE
    }
    if (!output)
        return die("%s", "no output file: give -o OUT.csid (see --help)");
    if (!have_out)
        return die("%s", "no output size: give --out WxH (see --help)");
    if (have_spp && have_fraction)
        return die("%s", "give --spp or --fraction, not both");
    if (input && frames)
        return die("%s", "give an input image or --frames, not both");
    if (!input && !frames)
        return die("%s", "no input: give an image or --frames PATTERN --count T (see --help)");
    if (frames && (!have_count || count < 2))
        return die("%s", "--frames needs --count T with T >= 2");
    if (frames && count > CSI_GRID_MAX_FRAMES)
        return cli_error(prog, CSI_ERR_ARG, "--count %u is more than the limit of %u frames (docs/dump-format.md)",
                         count, CSI_GRID_MAX_FRAMES);
    if (!frames && have_count)
        return die("%s", "--count is only for --frames");
    if (frames && (uint64_t)start + count > INT32_MAX)
        return die("%s", "--start + --count is too large for a frame number");
    if (frames && !check_pattern(frames))
        return die("--frames \"%s\" needs exactly one integer conversion such as %%03d (a width of at most 20, "
                   "and no other %%)", frames);
    csi_pos_method method;
    if (csi_pos_method_parse(method_s, &method) != CSI_OK)
        return lib_fail();

    /* The output: not one of the inputs, written whole or not at all (csi_outset). */
    const uint32_t T = frames ? count : 1;
    char name[4096];
    csi_outset *set = NULL;
    csi_status ss = cli_outset_new(&set);
    for (uint32_t t = 0; t < T && ss == CSI_OK; t++) {
        if (frames)
            snprintf(name, sizeof name, frames, (int)(start + t));
        ss = csi_outset_input(set, frames ? name : input);
    }
    if (ss == CSI_OK)
        ss = csi_outset_file(set, output, "the dump (-o)");
    if (ss != CSI_OK) {
        cli_outset_free(set);
        return lib_fail();
    }
    /* Read the image(s). */
    csi_image *img = calloc(T, sizeof *img);
    if (!img) {
        cli_outset_free(set);
        return die("%s", "out of memory");
    }
    int rc = 0;
    for (uint32_t t = 0; t < T && rc == 0; t++) {
        const char *path = input;
        if (frames) {
            snprintf(name, sizeof name, frames, (int)(start + t));
            path = name;
        }
        if (csi_image_read(path, &img[t]) != CSI_OK) {
            rc = lib_fail();
        } else if (t > 0 && (img[t].w != img[0].w || img[t].h != img[0].h || img[t].channels != img[0].channels)) {
            rc = cli_error(prog, CSI_ERR_FORMAT, "%s: frame %" PRIu32 " is %" PRIu32 "x%" PRIu32 " with %" PRIu32
                           " channels, but frame 0 is %" PRIu32 "x%" PRIu32 " with %" PRIu32, path, t, img[t].w,
                           img[t].h, img[t].channels, img[0].w, img[0].h, img[0].channels);
        }
    }
    csi_dump d = {0};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    csi_pos_info info;
    if (rc == 0) {
        d.grid = (csi_grid){img[0].w, img[0].h, T, out_w, out_h};
        d.seed = seed;
        const char *src = frames ? frames : input;
        if (d.grid.w % out_w || d.grid.h % out_h) {
            rc = cli_error(prog, CSI_ERR_ARG, "%s: image size %" PRIu32 "x%" PRIu32 " is not a multiple of --out %"
                           PRIu32 "x%" PRIu32, src, d.grid.w, d.grid.h, out_w, out_h);
        } else if (csi_dump_check_grid(&d.grid, img[0].channels, 0) != CSI_OK) {
            rc = cli_error(prog, CSI_ERR_ARG, "%s: %s", src, cli_last_error());
        }
    }
    if (rc == 0) {
        csi_pos_opts po = {.method = method, .spp = have_fraction ? 0 : (have_spp ? spp : DEFAULT_SPP),
                           .fraction = have_fraction ? fraction : 0, .seed = seed};
        /* positions and the dump's samples must fit the host besides the images */
        uint64_t need = 0, avail = csi_host_available_bytes();
        if (csi_positions_host_bytes(&d.grid, &po, &need) != CSI_OK ||
            csi_positions_count(&d.grid, &po, &n) != CSI_OK) {
            rc = cli_error(prog, CSI_ERR_ARG, "%s: %s", frames ? frames : input, cli_last_error());
        } else if (need += (uint64_t)n * (12 + 4 * (uint64_t)img[0].channels), avail && need > avail) {
            char a[32], b[32];
            rc = cli_error(prog, CSI_ERR_TOO_LARGE, "%s: %zu samples of a %" PRIu32 "x%" PRIu32 "x%" PRIu32
                           " grid need %s of host memory, more than the %s available", frames ? frames : input, n,
                           d.grid.w, d.grid.h, d.grid.t, csi_bytes_text(need, a, sizeof a),
                           csi_bytes_text(avail, b, sizeof b));
        } else if (csi_positions(&d.grid, &po, &pos, &n, &info) != CSI_OK) {
            rc = lib_fail();
        }
    }
    if (rc == 0) {
        const uint32_t ch = img[0].channels;
        if (csi_dump_alloc(&d, n, ch) != CSI_OK) {
            rc = lib_fail();
        } else {
            d.flags = exact ? CSI_SAMPLES_EXACT : 0;
            const size_t plane = (size_t)d.grid.w * d.grid.h;
            for (size_t i = 0; i < n; i++) {
                d.pos[i] = pos[i];
                const size_t cell = (size_t)pos[i].y * d.grid.w + pos[i].x;
                for (uint32_t c = 0; c < ch; c++)
                    d.values[i * ch + c] = img[pos[i].t].data[c * plane + cell];
            }
            if (cli_write_dump(set, output, &d) != CSI_OK || csi_outset_commit(set) != CSI_OK)
                rc = lib_fail();
        }
    }
    if (rc == 0 && !quiet) {
        printf("wrote %s: %zu samples (%s", output, n, csi_pos_method_name(method));
        if (method == CSI_POS_POISSON)
            printf(", min distance %.3g cells", info.radius);
        if (method == CSI_POS_STRATIFIED)
            printf(", strata %ux%ux%u per pixel", info.strata[0], info.strata[1], info.strata[2]);
        printf(", seed %" PRIu64 ") on a %" PRIu32 "x%" PRIu32 "x%" PRIu32 " grid for a %" PRIu32 "x%" PRIu32
               " image, %" PRIu32 " channel(s)\n", seed, d.grid.w, d.grid.h, d.grid.t, out_w, out_h, d.channels);
    }
    cli_outset_free(set);
    csi_dump_free(&d);
    csi_free(pos);
    for (uint32_t t = 0; t < T; t++)
        csi_image_free(&img[t]);
    free(img);
    return rc;
}
