/* csi-bench-blend: time of the blend (csi_recon_blend, the default per-pixel correction) alone,
 * on an image of OW x OW pixels of 8 x 8 cells with 4 samples in each pixel (csi's default grid
 * at 4 spp; at random cells of their pixel, in raster order of the pixels), HDR values over
 * three decades, a fine estimate that overshoots them.
 *
 *   csi-bench-blend OW RUNS [THREADS]
 *
 * Prints the smallest wall time and the smallest process CPU time of one blend over RUNS runs,
 * its passes on THREADS threads (csi/row_pool.h; default 1: the calling thread alone), and a
 * hash of the output, so that two builds can be checked for the same bits (the samples come
 * from a fixed seed). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/reconstruct.h"
#include "../../host/integrate/internal.h"
#include "fnv1a.h"

static double clock_s(clockid_t id)
{
    struct timespec t;
    clock_gettime(id, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv)
{
    if ((argc != 3 && argc != 4) || atoi(argv[1]) < 1 || atoi(argv[2]) < 1) {
        fprintf(stderr, "usage: csi-bench-blend OW RUNS [THREADS]\n");
        return 2;
    }
    const uint32_t ow = (uint32_t)atoi(argv[1]), F = 8, spp = 4;
    const int runs = atoi(argv[2]), threads = argc == 4 ? atoi(argv[3]) : 1;
    csi_row_pool *pool = csi_row_pool_new(threads);
    const size_t np = (size_t)ow * ow, n = np * spp;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *val = malloc(n * sizeof *val), *fine = malloc(n * sizeof *fine);
    float *box = malloc(np * sizeof *box), *plane = malloc(np * sizeof *plane);
    if (!pos || !val || !fine || !box || !plane) {
        fprintf(stderr, "out of memory\n");
        return 1;
    }
    uint64_t s = 1;
    size_t k = 0;
    for (size_t p = 0; p < np; p++) {
        box[p] = (float)(p % 31);
        for (uint32_t i = 0; i < spp; i++, k++) {
            s = s * 6364136223846793005ull + 1442695040888963407ull;
            pos[k] = (csi_sample_pos){(uint32_t)(p % ow) * F + (uint32_t)(s >> 40) % F,
                                      (uint32_t)(p / ow) * F + (uint32_t)(s >> 50) % F, 0};
            val[k] = (float)((s >> 20) % 1000) / 100.0f * (float)(1 + p % 17);
            fine[k] = 1.1f * val[k];
        }
    }
    const csi_grid g = {ow * F, ow * F, 1, ow, ow};
    csi_recon_options opt;
    csi_recon_defaults(&opt);
    double wall = 1e30, cpu = 1e30;
    for (int r = 0; r < runs; r++) {
        memcpy(plane, box, np * sizeof *plane);
        const double w0 = clock_s(CLOCK_MONOTONIC), c0 = clock_s(CLOCK_PROCESS_CPUTIME_ID);
        if (csi_recon_blend(&g, &opt, val, 1, 0, pos, fine, n, true, pool, plane, NULL) != CSI_OK) {
            fprintf(stderr, "%s\n", csi_last_error());
            return 1;
        }
        const double w = clock_s(CLOCK_MONOTONIC) - w0, c = clock_s(CLOCK_PROCESS_CPUTIME_ID) - c0;
        wall = w < wall ? w : wall;
        cpu = c < cpu ? c : cpu;
    }
    printf("%ux%u, %d threads: wall %.2f ms, CPU %.2f ms (least of %d), output %016llx\n", ow, ow,
           csi_row_pool_threads(pool), 1e3 * wall, 1e3 * cpu, runs,
           (unsigned long long)fnv1a(plane, np * sizeof *plane));
    csi_row_pool_free(pool);
    free(pos), free(val), free(fine), free(box), free(plane);
    return 0;
}
