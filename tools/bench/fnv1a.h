/* FNV-1a, 64 bits, over n bytes: the benchmarks print it of their outputs so that two builds can
 * be checked for the same bits. */
#ifndef CSI_BENCH_FNV1A_H
#define CSI_BENCH_FNV1A_H

#include <stddef.h>
#include <stdint.h>

static inline uint64_t fnv1a(const void *p, size_t n)
{
    const unsigned char *b = p;
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 1099511628211ull;
    return h;
}

#endif
