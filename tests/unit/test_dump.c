/* Sample dumps: round trips, every malformed input of issue 4 refused with a message naming
 * the file and where, NaN/Inf dropping, duplicate averaging, atomic writes. No OpenCL. */
#include <dirent.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "csi/dump.h"
#include "csi/outfile.h"
#include "testlib.h"

static char dir[256];

/* Independent little-endian encoder for hand-made files (not the library's writer). */
typedef struct { unsigned char b[1 << 14]; size_t n; } bytes;
static void u32le(bytes *o, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        o->b[o->n++] = (unsigned char)(v >> (8 * i));
}
static void u64le(bytes *o, uint64_t v)
{
    u32le(o, (uint32_t)v);
    u32le(o, (uint32_t)(v >> 32));
}
static void f32le(bytes *o, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    u32le(o, u);
}
static void header(bytes *o, uint32_t w, uint32_t h, uint32_t t, uint32_t ow, uint32_t oh, uint32_t ch, uint64_t count)
{
    o->n = 0;
    memcpy(o->b, "CSID", 4);
    o->n = 4;
    u32le(o, 1);
    u32le(o, w), u32le(o, h), u32le(o, t), u32le(o, ow), u32le(o, oh), u32le(o, ch);
    u64le(o, count);
    u64le(o, 99);
    for (int i = 0; i < 16; i++)
        o->b[o->n++] = 0;
}
static void record(bytes *o, uint32_t x, uint32_t y, uint32_t t, const float *v, int ch)
{
    u32le(o, x), u32le(o, y), u32le(o, t);
    for (int c = 0; c < ch; c++)
        f32le(o, v[c]);
}
static const char *save(const bytes *o, const char *name)
{
    static char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    fwrite(o->b, 1, o->n, f);
    fclose(f);
    return path;
}

/* Expects csi_dump_read to fail with `st` and a message holding the file name and `part`. */
static void expect_fail(const bytes *o, const char *name, const csi_dump_read_opts *opts, csi_status st,
                        const char *part)
{
    const char *path = save(o, name);
    csi_dump d;
    csi_status got = csi_dump_read(path, opts, &d, NULL);
    CHECK(got == st && d.pos == NULL && strstr(csi_last_error(), name) && strstr(csi_last_error(), part),
          "%s: got %s \"%s\", wanted %s with \"%s\"", name, csi_status_name(got), csi_last_error(),
          csi_status_name(st), part);
    if (got == CSI_OK)
        csi_dump_free(&d);
}

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

static int test_roundtrip(void)
{
    /* A 3-D dump written by the library, read back bit for bit. */
    csi_dump d = {.grid = {12, 8, 5, 3, 2}, .seed = UINT64_C(0x123456789abcdef0)};
    REQUIRE_OK(csi_dump_alloc(&d, 40, 3));
    test_rng r;
    test_rng_seed(&r, 5);
    for (size_t i = 0; i < d.count; i++) {
        /* distinct sorted positions: every 12th cell */
        uint64_t lin = i * 12 + (i % 5);
        d.pos[i] = (csi_sample_pos){(uint32_t)(lin % 12), (uint32_t)(lin / 12 % 8), (uint32_t)(lin / 96)};
        for (int c = 0; c < 3; c++)
            d.values[i * 3 + c] = (float)(test_rng_normal(&r) * 1e3);
    }
    d.values[7] = -0.0f;
    d.values[8] = 1e-40f; /* a subnormal survives */
    char path[512];
    snprintf(path, sizeof path, "%s/rt.csid", dir);
    CHECK_OK(csi_dump_write(path, &d));
    struct stat sb;
    CHECK(stat(path, &sb) == 0 && (uint64_t)sb.st_size == 64 + 40 * (12 + 12), "file size %lld",
          (long long)sb.st_size);
    csi_dump e;
    csi_dump_report rep;
    REQUIRE_OK(csi_dump_read(path, NULL, &e, &rep));
    CHECK(e.count == 40 && e.channels == 3 && e.seed == d.seed && rep.records == 40 && rep.duplicates == 0,
          "header fields");
    CHECK(memcmp(&e.grid, &d.grid, sizeof e.grid) == 0, "grid");
    CHECK(memcmp(e.pos, d.pos, 40 * sizeof *e.pos) == 0, "positions");
    CHECK(memcmp(e.values, d.values, 40 * 3 * sizeof(float)) == 0, "values bit for bit");
    csi_dump_free(&e);

    /* The writer refuses what the reader would, and leaves no file. */
    d.values[5] = NAN;
    snprintf(path, sizeof path, "%s/nan.csid", dir);
    CHECK(csi_dump_write(path, &d) == CSI_ERR_ARG && access(path, F_OK) != 0, "NaN refused by writer");
    d.values[5] = 1;
    d.pos[3].t = 5;
    CHECK(csi_dump_write(path, &d) == CSI_ERR_ARG && strstr(csi_last_error(), "outside"), "%s", csi_last_error());
    d.pos[3].t = 0;
    /* Unwritable destination: CSI_ERR_IO, nothing left behind. */
    int before = count_files();
    snprintf(path, sizeof path, "%s/no/such/dir/x.csid", dir);
    CHECK(csi_dump_write(path, &d) == CSI_ERR_IO && strstr(csi_last_error(), "x.csid"), "%s", csi_last_error());
    /* The destination is a directory: the rename fails after everything was written; the
     * temporary file must be gone. */
    snprintf(path, sizeof path, "%s/adir", dir);
    mkdir(path, 0755);
    before = count_files();
    CHECK(csi_dump_write(path, &d) == CSI_ERR_IO, "rename over a directory fails: %s", csi_last_error());
    CHECK(count_files() == before, "no temporary file left (%d files, %d before)", count_files(), before);
    rmdir(path);
    csi_dump_free(&d);
    return 0;
}

static int test_bad_inputs(void)
{
    bytes o;
    const float v1[1] = {1.0f}, v3[3] = {1, 2, 3};
    csi_dump_read_opts none = {0};

    header(&o, 4, 4, 1, 2, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    memcpy(o.b, "CSIX", 4);
    expect_fail(&o, "magic.csid", NULL, CSI_ERR_FORMAT, "byte 0: wrong magic \"CSIX\"");
    memcpy(o.b, "\x89PNG", 4);
    expect_fail(&o, "magic2.csid", NULL, CSI_ERR_FORMAT, "\\x89PNG");

    header(&o, 4, 4, 1, 2, 2, 1, 1);
    o.b[4] = 2;
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "version.csid", NULL, CSI_ERR_FORMAT, "byte 4: unknown version 2");

    header(&o, 4, 4, 1, 2, 2, 1, 1);
    o.n = 40;
    expect_fail(&o, "shorthdr.csid", NULL, CSI_ERR_FORMAT, "truncated header");
    o.n = 2;
    expect_fail(&o, "tiny.csid", NULL, CSI_ERR_FORMAT, "truncated header");
    o.n = 0;
    expect_fail(&o, "empty.csid", NULL, CSI_ERR_FORMAT, "truncated header");

    /* Truncated records: count 3, two and a half records present. */
    header(&o, 4, 4, 1, 2, 2, 1, 3);
    record(&o, 0, 0, 0, v1, 1);
    record(&o, 1, 0, 0, v1, 1);
    o.n += 8;
    expect_fail(&o, "trunc.csid", NULL, CSI_ERR_FORMAT, "truncated at record 2");

    /* A count far beyond the file (would be petabytes): refused before allocating. */
    header(&o, 4, 4, 1, 2, 2, 1, UINT64_C(1) << 60);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "hugecount.csid", NULL, CSI_ERR_FORMAT, "byte 32: count = 1152921504606846976");

    header(&o, 4, 4, 1, 2, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    o.b[o.n++] = 0;
    expect_fail(&o, "trailing.csid", NULL, CSI_ERR_FORMAT, "1 trailing bytes");

    header(&o, 0, 4, 1, 2, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "zerow.csid", NULL, CSI_ERR_FORMAT, "byte 8: grid_w is zero");
    header(&o, 4, 4, 0, 2, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "zerot.csid", NULL, CSI_ERR_FORMAT, "byte 16: grid_t is zero");
    header(&o, 4, 4, 1, 2, 0, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "zerooh.csid", NULL, CSI_ERR_FORMAT, "byte 24: out_h is zero");
    header(&o, 6, 4, 1, 4, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "nodiv.csid", NULL, CSI_ERR_FORMAT, "grid_w = 6 is not a multiple of out_w = 4");
    header(&o, 65536, 65536, 65536, 1, 1, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "absurd.csid", NULL, CSI_ERR_FORMAT, "more than the limit");
    header(&o, 100000, 4, 1, 1, 1, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "wide.csid", NULL, CSI_ERR_FORMAT, "grid_w = 100000 is larger than the limit");
    /* The caller's device limit. */
    csi_dump_read_opts lim = {.max_cells = 15};
    header(&o, 4, 4, 1, 2, 2, 1, 1);
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "limit.csid", &lim, CSI_ERR_FORMAT, "16 cells, more than the limit 15");

    header(&o, 4, 4, 1, 2, 2, 0, 1);
    record(&o, 0, 0, 0, v1, 0);
    expect_fail(&o, "ch0.csid", NULL, CSI_ERR_FORMAT, "byte 28: channels = 0");
    header(&o, 4, 4, 1, 2, 2, 5, 1);
    record(&o, 0, 0, 0, (const float[5]){0}, 5);
    expect_fail(&o, "ch5.csid", NULL, CSI_ERR_FORMAT, "channels = 5");

    header(&o, 4, 4, 1, 2, 2, 1, 2);
    record(&o, 0, 0, 0, v1, 1);
    record(&o, 1, 1, 1, v1, 1);
    expect_fail(&o, "static_t.csid", NULL, CSI_ERR_FORMAT, "record 1 (byte 80): t = 1 but the grid is static");
    header(&o, 4, 4, 2, 2, 2, 3, 2);
    record(&o, 3, 3, 1, v3, 3);
    record(&o, 1, 4, 0, v3, 3);
    expect_fail(&o, "outside.csid", NULL, CSI_ERR_FORMAT, "record 1 (byte 88): position (1, 4, 0) outside the 4x4x2 grid");

    header(&o, 4, 4, 1, 2, 2, 3, 2);
    record(&o, 0, 0, 0, v3, 3);
    record(&o, 1, 0, 0, (const float[3]){1, NAN, 3}, 3);
    expect_fail(&o, "nan.csid", &none, CSI_ERR_FORMAT, "record 1 (byte 104): channel 1 is NaN");
    header(&o, 4, 4, 1, 2, 2, 1, 1);
    record(&o, 0, 0, 0, (const float[1]){-INFINITY}, 1);
    expect_fail(&o, "inf.csid", NULL, CSI_ERR_FORMAT, "channel 0 is infinite");
    csi_dump_read_opts drop = {.drop_invalid = true};
    expect_fail(&o, "allinf.csid", &drop, CSI_ERR_FORMAT, "no valid samples");

    header(&o, 4, 4, 1, 2, 2, 1, 0);
    expect_fail(&o, "zero.csid", NULL, CSI_ERR_FORMAT, "byte 32: zero samples");

    header(&o, 4, 4, 1, 2, 2, 1, 1);
    o.b[60] = 7;
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "reserved.csid", NULL, CSI_ERR_FORMAT, "byte 60: reserved byte is 0x07");

    char path[512];
    snprintf(path, sizeof path, "%s/missing.csid", dir);
    csi_dump d;
    CHECK(csi_dump_read(path, NULL, &d, NULL) == CSI_ERR_IO && strstr(csi_last_error(), "missing.csid"), "%s",
          csi_last_error());
    CHECK(csi_dump_read(dir, NULL, &d, NULL) == CSI_ERR_IO, "a directory: %s", csi_last_error());
    return 0;
}

/* The flags at byte 48 (docs/dump-format.md): bit 0 (exact values) written and read back, an
 * old dump (zero) reads as not exact, and what a reader cannot know is refused. */
static int test_flags(void)
{
    const float v1[1] = {0.5f};
    bytes o;
    /* hand-made files, decoded by the reader: flag 1, flag 0 */
    for (uint32_t f = 0; f < 2; f++) {
        header(&o, 4, 4, 1, 2, 2, 1, 1);
        o.b[48] = (unsigned char)f;
        record(&o, 0, 0, 0, v1, 1);
        const char *path = save(&o, "flag.csid");
        csi_dump d;
        csi_dump_header h;
        REQUIRE_OK(csi_dump_read(path, NULL, &d, NULL));
        REQUIRE_OK(csi_dump_read_header(path, NULL, &h));
        CHECK(d.flags == f && h.flags == f, "byte 48 = %u read as flags %u (header %u)", f, d.flags, h.flags);
        csi_dump_free(&d);
    }
    /* the library's writer puts the flag at byte 48 (bytes read back here) and the reader keeps it */
    csi_dump d = {.grid = {4, 4, 1, 2, 2}, .flags = CSI_SAMPLES_EXACT};
    REQUIRE_OK(csi_dump_alloc(&d, 1, 1));
    char path[512];
    snprintf(path, sizeof path, "%s/exact.csid", dir);
    CHECK_OK(csi_dump_write(path, &d));
    unsigned char hb[64] = {0};
    FILE *fp = fopen(path, "rb");
    CHECK(fp && fread(hb, 1, 64, fp) == 64, "header bytes");
    if (fp)
        fclose(fp);
    bool rest_zero = true;
    for (int i = 49; i < 64; i++)
        rest_zero &= hb[i] == 0;
    CHECK(hb[48] == 1 && rest_zero, "byte 48 = %u, bytes 49-63 zero: %d", hb[48], rest_zero);
    csi_dump e;
    REQUIRE_OK(csi_dump_read(path, NULL, &e, NULL));
    CHECK(e.flags == CSI_SAMPLES_EXACT, "flags read back %u", e.flags);
    csi_dump_free(&e);
    /* the writer refuses unknown bits and an exact positions request, leaving no file */
    d.flags = 2;
    snprintf(path, sizeof path, "%s/unknown.csid", dir);
    CHECK(csi_dump_write(path, &d) == CSI_ERR_ARG && access(path, F_OK) != 0, "flag 2 written: %s", csi_last_error());
    d.flags = CSI_SAMPLES_EXACT;
    d.channels = 0;
    CHECK(csi_dump_write(path, &d) == CSI_ERR_ARG && access(path, F_OK) != 0, "an exact request written: %s",
          csi_last_error());
    d.channels = 1;
    csi_dump_free(&d);
    /* the reader refuses every reserved bit of the flags, in any of the four bytes */
    header(&o, 4, 4, 1, 2, 2, 1, 1);
    o.b[48] = 3;
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "bit1.csid", NULL, CSI_ERR_FORMAT,
                "byte 48: flags 0x00000003 has reserved bits 0x00000002 set, must be zero");
    header(&o, 4, 4, 1, 2, 2, 1, 1);
    o.b[51] = 0x80;
    record(&o, 0, 0, 0, v1, 1);
    expect_fail(&o, "bit31.csid", NULL, CSI_ERR_FORMAT, "byte 48: flags 0x80000000 has reserved bits 0x80000000");
    return 0;
}

static int test_drop_and_duplicates(void)
{
    bytes o;
    /* Records out of order, with duplicates and a NaN record. */
    header(&o, 4, 4, 1, 2, 2, 2, 7);
    record(&o, 3, 3, 0, (const float[2]){1, 2}, 2);  /* lin 15 */
    record(&o, 1, 0, 0, (const float[2]){1, 10}, 2); /* lin 1 */
    record(&o, 1, 0, 0, (const float[2]){2, 20}, 2); /* lin 1, duplicate */
    record(&o, 0, 2, 0, (const float[2]){NAN, 0}, 2);/* dropped */
    record(&o, 1, 0, 0, (const float[2]){4, 40}, 2); /* lin 1, duplicate */
    record(&o, 3, 3, 0, (const float[2]){3, 4}, 2);  /* lin 15, duplicate */
    record(&o, 2, 1, 0, (const float[2]){5, 6}, 2);  /* lin 6 */
    const char *path = save(&o, "dups.csid");
    csi_dump d;
    csi_dump_report rep;
    csi_dump_read_opts drop = {.drop_invalid = true};
    REQUIRE_OK(csi_dump_read(path, &drop, &d, &rep));
    CHECK(rep.records == 7 && rep.dropped_invalid == 1 && rep.first_invalid == 3 && rep.duplicates == 3,
          "report %llu %llu %llu %llu", (unsigned long long)rep.records, (unsigned long long)rep.dropped_invalid,
          (unsigned long long)rep.first_invalid, (unsigned long long)rep.duplicates);
    CHECK(d.count == 3, "unique count %zu", d.count);
    if (d.count == 3) {
        CHECK(d.pos[0].x == 1 && d.pos[0].y == 0 && d.pos[1].x == 2 && d.pos[1].y == 1 && d.pos[2].x == 3 &&
                  d.pos[2].y == 3, "sorted by linear index");
        /* means: (1+2+4)/3, (10+20+40)/3 rounded once from double; (1+3)/2, (2+4)/2 exact */
        CHECK(d.values[0] == (float)(7.0 / 3.0) && d.values[1] == (float)(70.0 / 3.0), "averaged %g %g",
              d.values[0], d.values[1]);
        CHECK(d.values[2] == 5 && d.values[3] == 6 && d.values[4] == 2 && d.values[5] == 3, "others");
    }
    csi_dump_free(&d);
    /* Without drop_invalid, the NaN record is an error. */
    CHECK(csi_dump_read(path, NULL, &d, NULL) == CSI_ERR_FORMAT && strstr(csi_last_error(), "record 3"), "%s",
          csi_last_error());
    return 0;
}

static int test_outfile(void)
{
    int before = count_files();
    csi_outfile of;
    char path[512];
    snprintf(path, sizeof path, "%s/of.txt", dir);
    REQUIRE_OK(csi_outfile_open(&of, path));
    fputs("partial", of.fp);
    CHECK(access(path, F_OK) != 0, "destination does not exist before commit");
    csi_outfile_abort(&of);
    CHECK(count_files() == before, "abort leaves nothing");
    REQUIRE_OK(csi_outfile_open(&of, path));
    fputs("whole", of.fp);
    CHECK_OK(csi_outfile_commit(&of));
    char buf[16] = {0};
    FILE *f = fopen(path, "rb");
    CHECK(f && fread(buf, 1, sizeof buf - 1, f) == 5 && strcmp(buf, "whole") == 0, "committed content");
    if (f)
        fclose(f);
    CHECK(count_files() == before + 1, "exactly the destination");
    unlink(path);
    return 0;
}

int main(void)
{
    snprintf(dir, sizeof dir, "%s/test_dump_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir)) {
        fprintf(stderr, "cannot make a temporary directory\n");
        return 1;
    }
    test_roundtrip();
    test_bad_inputs();
    test_drop_and_duplicates();
    test_flags();
    test_outfile();
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
    return test_done();
}
