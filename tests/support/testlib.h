/* Test support: checks that count failures, a shared OpenCL context, reference vectors (.npy).
 *
 * A test is a main() that calls CHECK/CHECK_CLOSE as often as it likes and ends with
 * `return test_done();`, which prints "N passed, M failed" and returns non-zero on any failure. */
#ifndef CSI_TESTLIB_H
#define CSI_TESTLIB_H

#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "csi/runtime.h"

extern int test_passed, test_failed;

#define CHECK(cond, ...)                                                        \
    do {                                                                        \
        if (cond) {                                                             \
            test_passed++;                                                      \
        } else {                                                                \
            test_failed++;                                                      \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond);     \
            fprintf(stderr, __VA_ARGS__);                                       \
            fputc('\n', stderr);                                                \
        }                                                                       \
    } while (0)

/* A csi call that must succeed; on failure prints the library's message and counts a failure. */
#define CHECK_OK(expr)                                                                    \
    do {                                                                                  \
        csi_status check_ok_st_ = (expr);                                                 \
        CHECK(check_ok_st_ == CSI_OK, "%s: %s", csi_status_name(check_ok_st_), csi_last_error()); \
    } while (0)

/* Must succeed, or the test cannot go on: prints and exits with failure. */
#define REQUIRE_OK(expr)                                                                 \
    do {                                                                                 \
        csi_status req_ok_st_ = (expr);                                                  \
        if (req_ok_st_ != CSI_OK) {                                                      \
            fprintf(stderr, "FATAL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #expr,    \
                    csi_status_name(req_ok_st_), csi_last_error());                      \
            test_failed++;                                                               \
            return test_done();                                                          \
        }                                                                                \
    } while (0)

int test_done(void);

/* The process-wide test context (PoCL CPU unless CSI_DEVICE says otherwise); exits the test
 * with a message if there is no device. Released at exit. */
csi_ctx *test_ctx(void);

/* Max-abs and relative L2 differences. */
double test_max_abs_diff(const float *a, const float *b, size_t n);
double test_rel_l2(const float *got, const float *want, size_t n); /* ||got-want|| / ||want|| */
double test_max_abs(const float *a, size_t n);

/* Deterministic pseudo-random numbers for tests (splitmix64 / xorshift). */
typedef struct { uint64_t s; } test_rng;
void test_rng_seed(test_rng *r, uint64_t seed);
uint64_t test_rng_u64(test_rng *r);
double test_rng_uniform(test_rng *r); /* [0, 1) */
double test_rng_normal(test_rng *r);

/* A log of a csi_count_progress_fn's reports (pass test_count_progress and the log as its user
 * data): how many, the last (done, total), how many went backwards (done decreasing or total
 * changing), and a cancel: the report numbered stop_at (from 1; 0: never) returns false. */
typedef struct {
    size_t calls, stop_at;
    uint64_t last_done, last_total;
    int backwards;
} test_count_log;
bool test_count_progress(void *user, uint64_t done, uint64_t total);

/* A .npy array (format 1.0/2.0, C order, little-endian): dtype one of '<f4' '<f8' '<c8' '<c16'
 * '<i4' '<u4' '<i8' '<u8'. Data converted to the type asked for. */
typedef struct {
    char dtype[8];
    int ndim;
    size_t shape[8];
    size_t count; /* product of shape */
    void *data;   /* raw, as stored */
} test_npy;
bool test_npy_load(const char *relpath, test_npy *out); /* relative to tests/data */
void test_npy_free(test_npy *a);
/* The array as floats (real arrays; complex arrays give interleaved re, im: 2*count floats). */
float *test_npy_f32(const test_npy *a);
double *test_npy_f64(const test_npy *a);

/* Upload / download helpers. */
cl_mem test_upload(const void *data, size_t bytes);
cl_mem test_alloc(size_t bytes);
void test_download(cl_mem m, void *out, size_t bytes);

#endif
