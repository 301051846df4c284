/* Built programs kept on disk as the driver's binaries (csi/program_cache.h). */
#include "csi/program_cache.h"

#include <dirent.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include <sys/stat.h>

/* A file: this magic, the payload's length and its checksum (csi_program_cache_checksum; u64s
 * as the host stores them: a file is only ever read on the machine that wrote it), then the
 * payload. */
static const char MAGIC[8] = {'C', 'S', 'I', 'P', 'B', 'I', 'N', '2'};
#define HEADER_BYTES (sizeof MAGIC + 2 * sizeof(uint64_t))

/* A binary larger than this is not a program of csi's: the file is foreign. */
#define MAX_BINARY_BYTES ((uint64_t)256 << 20)

#define FNV_BASIS 14695981039346656037ull
#define FNV_PRIME 1099511628211ull

/* FNV-1a's step over 8-byte words, then the bytes left (not FNV-1a's values): a program's
 * binary is megabytes, read by every process, and a byte at a time cost more than reading it.
 * Not a cryptographic hash: it tells a damaged file from a whole one. */
static uint64_t hash_words(uint64_t h, const void *data, size_t n)
{
    const unsigned char *p = data;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, p + i, sizeof w);
        h = (h ^ w) * FNV_PRIME;
    }
    for (; i < n; i++)
        h = (h ^ p[i]) * FNV_PRIME;
    return h;
}

uint64_t csi_program_cache_checksum(const void *data, size_t n)
{
    return hash_words(FNV_BASIS, data, n);
}

/* A string into the hash with its terminating zero, so that "ab" + "c" differs from "a" + "bc". */
static uint64_t hash_str(uint64_t h, const char *s)
{
    return hash_words(h, s ? s : "", strlen(s ? s : "") + 1);
}

static uint64_t hash_info(uint64_t h, cl_device_id device, cl_platform_id platform, cl_uint what, bool of_device)
{
    char buf[512] = "";
    if (of_device)
        clGetDeviceInfo(device, what, sizeof buf - 1, buf, NULL);
    else
        clGetPlatformInfo(platform, what, sizeof buf - 1, buf, NULL);
    buf[sizeof buf - 1] = '\0';
    return hash_str(h, buf);
}

bool csi_program_cache_dir(char *out, size_t len)
{
    const char *off = getenv("CSI_PROGRAM_CACHE");
    if (off && strcmp(off, "0") == 0)
        return false;
    const char *dir = getenv("CSI_CACHE_DIR"), *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    int n;
    if (dir && *dir)
        n = snprintf(out, len, "%s/programs", dir);
    else if (xdg && *xdg)
        n = snprintf(out, len, "%s/csi/programs", xdg);
    else if (home && *home)
        n = snprintf(out, len, "%s/.cache/csi/programs", home);
    else
        return false;
    return n > 0 && (size_t)n < len;
}

csi_status csi_program_cache_require_dir(char *out, size_t len)
{
    if (csi_program_cache_dir(out, len))
        return CSI_OK;
    return csi_fail(CSI_ERR_IO, "the program cache is off (CSI_PROGRAM_CACHE=0, or no CSI_CACHE_DIR, XDG_CACHE_HOME "
                                "or HOME to put it in)");
}

/* The file that holds `name`'s binary for this source, options and driver: DIR/NAME-D-S.bin, D a
 * hash of the platform, device and driver, S of the source and options (so that the files of
 * one device can be told from another's in a folder that several machines share). */
static bool cache_path(cl_device_id device, const char *name, const char *source, const char *options, char *out,
                       size_t len)
{
    char dir[1024];
    if (!csi_program_cache_dir(dir, sizeof dir))
        return false;
    cl_platform_id platform = NULL;
    if (clGetDeviceInfo(device, CL_DEVICE_PLATFORM, sizeof platform, &platform, NULL) != CL_SUCCESS)
        return false;
    uint64_t d = FNV_BASIS, h = FNV_BASIS;
    d = hash_info(d, device, platform, CL_PLATFORM_NAME, false);
    d = hash_info(d, device, platform, CL_PLATFORM_VERSION, false);
    d = hash_info(d, device, platform, CL_DEVICE_NAME, true);
    d = hash_info(d, device, platform, CL_DEVICE_VERSION, true);
    d = hash_info(d, device, platform, CL_DRIVER_VERSION, true);
    h = hash_str(h, source);
    h = hash_str(h, options);
    const int n = snprintf(out, len, "%s/%s-%016llx-%016llx.bin", dir, name, (unsigned long long)d,
                           (unsigned long long)h);
    return n > 0 && (size_t)n < len;
}

/* The payload of a whole, undamaged file, or NULL. */
static unsigned char *read_binary(const char *path, size_t *bytes)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    unsigned char head[HEADER_BYTES];
    uint64_t len = 0, sum = 0;
    unsigned char *bin = NULL;
    if (fread(head, 1, sizeof head, f) == sizeof head && memcmp(head, MAGIC, sizeof MAGIC) == 0) {
        memcpy(&len, head + sizeof MAGIC, sizeof len);
        memcpy(&sum, head + sizeof MAGIC + sizeof len, sizeof sum);
        if (len > 0 && len <= MAX_BINARY_BYTES && (bin = malloc(len + 1))) {
            /* one byte more than the payload: a longer file is as damaged as a shorter one */
            if (fread(bin, 1, len + 1, f) != len || csi_program_cache_checksum(bin, len) != sum) {
                free(bin);
                bin = NULL;
            }
        }
    }
    fclose(f);
    *bytes = bin ? (size_t)len : 0;
    return bin;
}

cl_program csi_program_cache_load(cl_context context, cl_device_id device, const char *name, const char *source,
                                  const char *options)
{
    char path[1200];
    if (!cache_path(device, name, source, options, path, sizeof path))
        return NULL;
    size_t bytes = 0;
    unsigned char *bin = read_binary(path, &bytes);
    if (!bin)
        return NULL;
    const unsigned char *bins[1] = {bin};
    cl_int st = CL_SUCCESS, err = CL_SUCCESS;
    cl_program prog = clCreateProgramWithBinary(context, 1, &device, &bytes, bins, &st, &err);
    free(bin);
    if (err != CL_SUCCESS || st != CL_SUCCESS) {
        if (prog)
            clReleaseProgram(prog);
        return NULL;
    }
    if (clBuildProgram(prog, 1, &device, options, NULL, NULL) != CL_SUCCESS) {
        clReleaseProgram(prog);
        return NULL;
    }
    return prog;
}

void csi_cache_mkdirs(const char *path)
{
    char tmp[1024];
    snprintf(tmp, sizeof tmp, "%s", path);
    for (char *p = tmp + 1; *p; p++)
        if (*p == '/') {
            *p = '\0';
            mkdir(tmp, 0755);
            *p = '/';
        }
    mkdir(tmp, 0755);
}

/* The program's files of this device with another source (an earlier build of csi): one binary
 * per program and device is kept, so that rebuilding csi does not grow the cache without bound,
 * and machines sharing the folder keep each their own. `keep` is the file just stored. */
static void remove_others(const char *dir, const char *keep)
{
    const char *base = strrchr(keep, '/') + 1, *src = strrchr(base, '-');
    const size_t prefix = (size_t)(src - base) + 1; /* NAME-D- */
    DIR *d = opendir(dir);
    if (!d)
        return;
    char other[1200];
    for (struct dirent *e; (e = readdir(d));) {
        const size_t len = strlen(e->d_name);
        if (len != strlen(base) || strncmp(e->d_name, base, prefix) != 0 || strcmp(e->d_name, base) == 0 ||
            strcmp(e->d_name + len - 4, ".bin") != 0)
            continue;
        if (snprintf(other, sizeof other, "%s/%s", dir, e->d_name) < (int)sizeof other)
            remove(other);
    }
    closedir(d);
}

bool csi_program_cache_store(cl_program program, cl_device_id device, const char *name, const char *source,
                             const char *options)
{
    char path[1200], dir[1024], tmp[1300];
    if (!cache_path(device, name, source, options, path, sizeof path) || !csi_program_cache_dir(dir, sizeof dir))
        return false;
    cl_uint ndev = 0;
    if (clGetProgramInfo(program, CL_PROGRAM_NUM_DEVICES, sizeof ndev, &ndev, NULL) != CL_SUCCESS || ndev != 1)
        return false;
    size_t bytes = 0;
    if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof bytes, &bytes, NULL) != CL_SUCCESS || !bytes ||
        bytes > MAX_BINARY_BYTES)
        return false;
    unsigned char *bin = malloc(bytes);
    if (!bin)
        return false;
    unsigned char *bins[1] = {bin};
    if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof bins, bins, NULL) != CL_SUCCESS) {
        free(bin);
        return false;
    }
    csi_cache_mkdirs(dir);
    /* a name of this process's own, so that processes storing the same program at once do not
     * write into one file; the rename is atomic, the last one stays */
    snprintf(tmp, sizeof tmp, "%s.%ld.tmp", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    bool ok = f != NULL;
    if (ok) {
        const uint64_t len = bytes, sum = csi_program_cache_checksum(bin, bytes);
        ok = fwrite(MAGIC, 1, sizeof MAGIC, f) == sizeof MAGIC && fwrite(&len, sizeof len, 1, f) == 1 &&
             fwrite(&sum, sizeof sum, 1, f) == 1 && fwrite(bin, 1, bytes, f) == bytes;
        ok = fclose(f) == 0 && ok;
    }
    ok = ok && rename(tmp, path) == 0;
    if (!ok)
        remove(tmp);
    free(bin);
    if (ok)
        remove_others(dir, path);
    return ok;
}
