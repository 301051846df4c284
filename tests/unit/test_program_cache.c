/* csi's program cache (csi/program_cache.h): filled only on request; a cached program loads
 * without its source and computes what the source-built one computes; a damaged, truncated or
 * foreign file is a miss that builds from source, never a crash; the cache can be turned off. */
#define _XOPEN_SOURCE 700
#include <dirent.h>
#include <ftw.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "csi/program_cache.h"
#include "csi/runtime.h"
#include "testlib.h"

static char g_dir[64];

/* The test cannot go on without this: says why and ends the process with a failure. */
#define MUST(cond, ...)                                                         \
    do {                                                                        \
        if (!(cond)) {                                                          \
            fprintf(stderr, "FATAL %s:%d: %s: ", __FILE__, __LINE__, #cond);    \
            fprintf(stderr, __VA_ARGS__);                                       \
            fprintf(stderr, " (%s)\n", csi_last_error());                       \
            exit(1);                                                            \
        }                                                                       \
    } while (0)
#define MUST_OK(expr) MUST((expr) == CSI_OK, "%s", #expr)

/* The cached file of the probe program (runtime-*.bin), or "" when there is none. */
static void cached_file(char *out, size_t len)
{
    char dir[128];
    snprintf(dir, sizeof dir, "%s/programs", g_dir);
    out[0] = '\0';
    DIR *d = opendir(dir);
    if (!d)
        return;
    for (struct dirent *e; (e = readdir(d));)
        if (!strncmp(e->d_name, "runtime-", 8) && strstr(e->d_name, ".bin") &&
            !strstr(e->d_name, ".tmp"))
            snprintf(out, len, "%s/%s", dir, e->d_name);
    closedir(d);
}

/* A fresh context runs the probe kernel; returns how many programs it took from the cache, and
 * counts wrong values of the kernel's exact result into *bad. */
static int probe(int *bad)
{
    csi_ctx *ctx = NULL;
    MUST_OK(csi_ctx_create(&ctx, NULL));
    cl_kernel k;
    MUST_OK(csi_kernel(ctx, "runtime", "csi_probe_affine", &k));
    const cl_uint n = 257;
    cl_mem out = NULL;
    MUST_OK(csi_buffer(ctx, n * sizeof(float), CL_MEM_READ_WRITE, "the probe's output", &out));
    float a = 0.5f, b = -3.0f;
    MUST_OK(CSI_ARGS(k, CSI_MEM(out), CSI_ARG(n), CSI_ARG(a), CSI_ARG(b)));
    MUST_OK(csi_run1d(ctx, k, n));
    float h[257];
    MUST_OK(csi_read(ctx, out, 0, sizeof h, h));
    *bad = 0;
    for (cl_uint i = 0; i < n; i++)
        *bad += h[i] != 0.5f * (float)i - 3.0f; /* exact: small integers times 0.5 */
    csi_buffer_release(&out);
    const int cached = csi_ctx_programs_from_cache(ctx);
    csi_ctx_release(ctx);
    return cached;
}

static void cache_probe(int expect_stored)
{
    csi_ctx *ctx = NULL;
    MUST_OK(csi_ctx_create(&ctx, NULL));
    int stored = -1;
    MUST_OK(csi_ctx_cache_programs(ctx, "runtime", &stored));
    CHECK(stored == expect_stored, "cache_programs stored %d programs, expected %d", stored, expect_stored);
    csi_ctx_release(ctx);
}

static long file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    fclose(f);
    return n;
}

/* Overwrites `len` bytes at `at` (from the end when negative) with `bytes`. */
static void patch(const char *path, long at, const void *bytes, size_t len)
{
    FILE *f = fopen(path, "r+b");
    MUST(f, "open %s", path);
    fseek(f, at, at < 0 ? SEEK_END : SEEK_SET);
    MUST(fwrite(bytes, 1, len, f) == len, "write %s", path);
    fclose(f);
}

static int rm_entry(const char *path, const struct stat *sb, int flag, struct FTW *ftw)
{
    (void)sb, (void)flag, (void)ftw;
    return remove(path);
}

int main(void)
{
    snprintf(g_dir, sizeof g_dir, "/tmp/csi-test-progcache-XXXXXX");
    MUST(mkdtemp(g_dir), "a temporary directory");
    /* before the first context: the runtime reads it for PoCL's and clFFT's caches too */
    setenv("CSI_CACHE_DIR", g_dir, 1);
    unsetenv("CSI_PROGRAM_CACHE");
    char path[512];
    int bad = 0;

    /* Using a program builds it from source and stores nothing. */
    CHECK(probe(&bad) == 0, "a program came from an empty cache");
    CHECK(bad == 0, "%d wrong values built from source", bad);
    cached_file(path, sizeof path);
    CHECK(path[0] == '\0', "plain use stored %s", path);

    /* Cached on request, once; stored again, it replaces the program's file of another source on
     * this device, and no other device's or program's; a later context loads it and computes the
     * same values. */
    cache_probe(1);
    cached_file(path, sizeof path);
    MUST(path[0], "no file in %s/programs after caching", g_dir);
    /* the same program and device, another source; another device; another program */
    char stale[600], device[600], other[600];
    const char *dash = strrchr(path, '-');
    snprintf(stale, sizeof stale, "%.*s-0123456789abcdef.bin", (int)(dash - path), path);
    snprintf(device, sizeof device, "%s/programs/runtime-0123456789abcdef-0123456789abcdef.bin", g_dir);
    snprintf(other, sizeof other, "%s/programs/runtimes%s", g_dir, strchr(strrchr(path, '/'), '-'));
    const char *made[3] = {stale, device, other};
    for (int i = 0; i < 3; i++) {
        FILE *f = fopen(made[i], "wb");
        MUST(f && fputs("old", f) >= 0 && fclose(f) == 0, "write %s", made[i]);
    }
    MUST(remove(path) == 0, "remove %s", path);
    cache_probe(1);
    CHECK(access(stale, F_OK) != 0, "the program's file of another source stayed: %s", stale);
    CHECK(access(device, F_OK) == 0, "another device's file was removed: %s", device);
    CHECK(access(other, F_OK) == 0, "another program's file was removed: %s", other);
    remove(device);
    remove(other);
    cached_file(path, sizeof path);
    MUST(path[0], "no file in %s/programs after caching", g_dir);
    cache_probe(0);
    CHECK(probe(&bad) == 1, "the cached program was not loaded");
    CHECK(bad == 0, "%d wrong values from the cached program", bad);

    /* A damaged payload fails its checksum: built from source, right values. */
    const long size = file_size(path);
    MUST(size > 64, "the cached file has %ld bytes", size);
    const unsigned char junk[4] = {0xde, 0xad, 0xbe, 0xef};
    patch(path, -4, junk, sizeof junk);
    CHECK(probe(&bad) == 0, "a damaged file was loaded");
    CHECK(bad == 0, "%d wrong values after a damaged file", bad);

    /* Stored again over it; then a truncated file is a miss too. */
    cache_probe(1);
    CHECK(probe(&bad) == 1 && bad == 0, "the re-stored program did not load and run");
    MUST(truncate(path, size / 2) == 0, "truncate %s", path);
    CHECK(probe(&bad) == 0, "a truncated file was loaded");
    CHECK(bad == 0, "%d wrong values after a truncated file", bad);

    /* A foreign file with a valid header and checksum: the driver refuses the bytes, the program
     * is built from source. The payload is 64 bytes of text; the header's magic is the cached
     * file's own. */
    {
        unsigned char payload[64], magic[8];
        memset(payload, 'x', sizeof payload);
        const uint64_t sum = csi_program_cache_checksum(payload, sizeof payload), len = sizeof payload;
        FILE *f = fopen(path, "rb");
        MUST(f && fread(magic, 1, sizeof magic, f) == sizeof magic, "read %s", path);
        fclose(f);
        f = fopen(path, "wb");
        MUST(f, "rewrite %s", path);
        fwrite(magic, 1, sizeof magic, f);
        fwrite(&len, sizeof len, 1, f);
        fwrite(&sum, sizeof sum, 1, f);
        fwrite(payload, 1, sizeof payload, f);
        fclose(f);
        CHECK(probe(&bad) == 0, "a foreign binary was loaded");
        CHECK(bad == 0, "%d wrong values after a foreign binary", bad);
    }

    /* Off: nothing loaded, caching refused with its reason. */
    cache_probe(1);
    setenv("CSI_PROGRAM_CACHE", "0", 1);
    CHECK(probe(&bad) == 0 && bad == 0, "CSI_PROGRAM_CACHE=0 still loaded the cached program");
    csi_ctx *ctx = NULL;
    MUST_OK(csi_ctx_create(&ctx, NULL));
    CHECK(csi_ctx_cache_programs(ctx, "runtime", NULL) == CSI_ERR_IO, "caching with the cache off");
    CHECK(strstr(csi_last_error(), "off") != NULL, "message: %s", csi_last_error());
    unsetenv("CSI_PROGRAM_CACHE");
    CHECK(csi_ctx_cache_programs(ctx, "no_such_program", NULL) == CSI_ERR_ARG, "an unknown program");
    csi_ctx_release(ctx);

    nftw(g_dir, rm_entry, 8, FTW_DEPTH | FTW_PHYS);
    return test_done();
}
