#include "testlib.h"

#include <stdlib.h>
#include <string.h>

int test_passed, test_failed;
static csi_ctx *g_ctx;

static void release_ctx(void) { csi_ctx_release(g_ctx); }

int test_done(void)
{
    printf("%d passed, %d failed\n", test_passed, test_failed);
    fflush(stdout);
    return test_failed ? 1 : 0;
}

csi_ctx *test_ctx(void)
{
    if (g_ctx)
        return g_ctx;
    if (csi_ctx_create(&g_ctx, NULL) != CSI_OK) {
        fprintf(stderr, "FATAL: no OpenCL device: %s\n", csi_last_error());
        exit(1);
    }
    atexit(release_ctx);
    return g_ctx;
}

double test_max_abs_diff(const float *a, const float *b, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - (double)b[i]);
        if (!(d <= m))
            m = d; /* NaN propagates as the max */
    }
    return m;
}

double test_rel_l2(const float *got, const float *want, size_t n)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < n; i++) {
        double d = (double)got[i] - (double)want[i];
        num += d * d;
        den += (double)want[i] * (double)want[i];
    }
    return den > 0 ? sqrt(num / den) : sqrt(num);
}

double test_max_abs(const float *a, size_t n)
{
    double m = 0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i]);
        if (!(d <= m))
            m = d;
    }
    return m;
}

void test_rng_seed(test_rng *r, uint64_t seed) { r->s = seed * 0x9E3779B97F4A7C15ull + 1; }

uint64_t test_rng_u64(test_rng *r)
{
    uint64_t z = (r->s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

double test_rng_uniform(test_rng *r) { return (double)(test_rng_u64(r) >> 11) * 0x1.0p-53; }

double test_rng_normal(test_rng *r)
{
    double u1 = test_rng_uniform(r), u2 = test_rng_uniform(r);
    if (u1 < 1e-300)
        u1 = 1e-300;
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

bool test_count_progress(void *user, uint64_t done, uint64_t total)
{
    test_count_log *l = user;
    l->backwards += l->calls && (done < l->last_done || total != l->last_total);
    l->calls++;
    l->last_done = done;
    l->last_total = total;
    return l->calls != l->stop_at;
}

static size_t dtype_size(const char *d)
{
    if (!strcmp(d, "<f4") || !strcmp(d, "<i4") || !strcmp(d, "<u4")) return 4;
    if (!strcmp(d, "<f8") || !strcmp(d, "<c8") || !strcmp(d, "<i8") || !strcmp(d, "<u8")) return 8;
    if (!strcmp(d, "<c16")) return 16;
    return 0;
}

bool test_npy_load(const char *relpath, test_npy *out)
{
    memset(out, 0, sizeof *out);
    char path[2048];
    snprintf(path, sizeof path, "%s/%s", CSI_TEST_DATA, relpath);
    FILE *f = fopen(path, "rb");
    if (!f) {
        fprintf(stderr, "cannot open reference %s\n", path);
        return false;
    }
    unsigned char magic[8];
    bool ok = fread(magic, 1, 8, f) == 8 && memcmp(magic, "\x93NUMPY", 6) == 0;
    size_t hlen = 0;
    if (ok) {
        unsigned char b[4];
        if (magic[6] == 1) {
            ok = fread(b, 1, 2, f) == 2;
            hlen = b[0] | (size_t)b[1] << 8;
        } else {
            ok = fread(b, 1, 4, f) == 4;
            hlen = b[0] | (size_t)b[1] << 8 | (size_t)b[2] << 16 | (size_t)b[3] << 24;
        }
    }
    char *hdr = ok ? calloc(1, hlen + 1) : NULL;
    ok = ok && hdr && fread(hdr, 1, hlen, f) == hlen;
    if (ok) {
        char *d = strstr(hdr, "'descr':");
        char *fo = strstr(hdr, "'fortran_order':");
        char *sh = strstr(hdr, "'shape':");
        ok = d && fo && sh && strstr(fo, "False") == fo + strlen("'fortran_order': ");
        if (ok) {
            char *q = strchr(d + 8, '\'');
            ok = q && sscanf(q + 1, "%7[^']", out->dtype) == 1;
        }
        if (ok) {
            char *p = strchr(sh, '(') + 1;
            out->ndim = 0;
            out->count = 1;
            while (*p && *p != ')') {
                char *end;
                unsigned long long v = strtoull(p, &end, 10);
                if (end == p) {
                    p++;
                    continue;
                }
                out->shape[out->ndim++] = (size_t)v;
                out->count *= (size_t)v;
                p = end;
            }
        }
    }
    free(hdr);
    size_t es = ok ? dtype_size(out->dtype) : 0;
    ok = ok && es > 0;
    if (ok) {
        out->data = malloc(out->count * es + 1);
        ok = out->data && fread(out->data, es, out->count, f) == out->count;
    }
    fclose(f);
    if (!ok) {
        fprintf(stderr, "malformed or unsupported .npy: %s\n", path);
        test_npy_free(out);
    }
    return ok;
}

void test_npy_free(test_npy *a)
{
    free(a->data);
    a->data = NULL;
}

float *test_npy_f32(const test_npy *a)
{
    bool cplx = a->dtype[1] == 'c';
    size_t n = a->count * (cplx ? 2 : 1);
    float *o = malloc(n * sizeof *o + 1);
    for (size_t i = 0; i < n; i++) {
        const char *d = a->dtype;
        if (!strcmp(d, "<f4") || !strcmp(d, "<c8")) o[i] = ((const float *)a->data)[i];
        else if (!strcmp(d, "<f8") || !strcmp(d, "<c16")) o[i] = (float)((const double *)a->data)[i];
        else if (!strcmp(d, "<i4")) o[i] = (float)((const int32_t *)a->data)[i];
        else if (!strcmp(d, "<u4")) o[i] = (float)((const uint32_t *)a->data)[i];
        else if (!strcmp(d, "<i8")) o[i] = (float)((const int64_t *)a->data)[i];
        else o[i] = (float)((const uint64_t *)a->data)[i];
    }
    return o;
}

double *test_npy_f64(const test_npy *a)
{
    bool cplx = a->dtype[1] == 'c';
    size_t n = a->count * (cplx ? 2 : 1);
    double *o = malloc(n * sizeof *o + 1);
    for (size_t i = 0; i < n; i++) {
        const char *d = a->dtype;
        if (!strcmp(d, "<f4") || !strcmp(d, "<c8")) o[i] = ((const float *)a->data)[i];
        else if (!strcmp(d, "<f8") || !strcmp(d, "<c16")) o[i] = ((const double *)a->data)[i];
        else if (!strcmp(d, "<i4")) o[i] = ((const int32_t *)a->data)[i];
        else if (!strcmp(d, "<u4")) o[i] = ((const uint32_t *)a->data)[i];
        else if (!strcmp(d, "<i8")) o[i] = (double)((const int64_t *)a->data)[i];
        else o[i] = (double)((const uint64_t *)a->data)[i];
    }
    return o;
}

cl_mem test_alloc(size_t bytes)
{
    cl_mem m;
    if (csi_buffer(test_ctx(), bytes, CL_MEM_READ_WRITE, "a test buffer", &m) != CSI_OK) {
        fprintf(stderr, "FATAL: %s\n", csi_last_error());
        exit(1);
    }
    return m;
}

cl_mem test_upload(const void *data, size_t bytes)
{
    cl_mem m = test_alloc(bytes);
    if (csi_write(test_ctx(), m, 0, bytes, data) != CSI_OK) {
        fprintf(stderr, "FATAL: %s\n", csi_last_error());
        exit(1);
    }
    return m;
}

void test_download(cl_mem m, void *out, size_t bytes)
{
    if (csi_read(test_ctx(), m, 0, bytes, out) != CSI_OK) {
        fprintf(stderr, "FATAL: %s\n", csi_last_error());
        exit(1);
    }
}
