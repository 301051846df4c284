/* csi-bench-positions: time to make sample positions at realistic sizes, each method.
 * Usage: csi-bench-positions [W H T OUT_W OUT_H SPP|FRACTION]   (default: a few standard cases) */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "csi/positions.h"

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void run(csi_grid g, uint32_t spp, double fraction)
{
    for (int m = 0; m <= CSI_POS_RANDOM; m++) {
        csi_pos_opts o = {.method = (csi_pos_method)m, .spp = spp, .fraction = fraction, .seed = 1};
        csi_sample_pos *p;
        size_t n;
        csi_pos_info info;
        double t0 = now();
        csi_status st = csi_positions(&g, &o, &p, &n, &info);
        double dt = now() - t0;
        if (st != CSI_OK) {
            printf("%ux%ux%u %s: %s\n", g.w, g.h, g.t, csi_pos_method_name(o.method), csi_last_error());
            continue;
        }
        printf("%5ux%5ux%4u -> %4ux%4u  %-10s N=%9zu  %7.3f s", g.w, g.h, g.t, g.out_w, g.out_h,
               csi_pos_method_name(o.method), n, dt);
        if (m == CSI_POS_POISSON)
            printf("  radius %.3f (r_max %.3f)", info.radius, info.radius_max);
        printf("\n");
        free(p);
    }
}

int main(int argc, char **argv)
{
    if (argc == 7) {
        csi_grid g = {(uint32_t)atoi(argv[1]), (uint32_t)atoi(argv[2]), (uint32_t)atoi(argv[3]),
                      (uint32_t)atoi(argv[4]), (uint32_t)atoi(argv[5])};
        double v = atof(argv[6]);
        run(g, v >= 1 ? (uint32_t)v : 0, v < 1 ? v : 0);
        return 0;
    }
    run((csi_grid){512, 512, 1, 128, 128}, 4, 0);
    run((csi_grid){2048, 2048, 1, 512, 512}, 4, 0);
    run((csi_grid){256, 256, 64, 64, 64}, 0, 0.1);
    run((csi_grid){512, 512, 128, 128, 128}, 0, 0.1);
    run((csi_grid){512, 512, 128, 128, 128}, 1, 0);
    return 0;
}
