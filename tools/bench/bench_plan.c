/* csi-bench-plan: the resource plan of images of given sizes on this machine's device, from the
 * sizes alone (csi_recon_plan_make and csi_tiling_plan, as csi-reconstruct decides before any
 * work): the tile layout at the default budget, one tile's device bytes (and whether its FFT rows
 * run fused, csi/tiles.h), the whole problem's device bytes, the host bytes and the largest
 * buffer.
 *
 *   csi-bench-plan WxH:SPP [WxH:SPP ...]      (3 channels, csi's default grid for the spp)
 *
 * Prints one line per size; the figures of docs/bench/scale.md's Targets table. */
#include <stdio.h>

#include "csi/plan.h"
#include "csi/positions.h"
#include "csi/runtime.h"
#include "csi/tiles.h"

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: csi-bench-plan WxH:SPP [WxH:SPP ...]\n");
        return 2;
    }
    csi_ctx *ctx;
    if (csi_ctx_create(&ctx, NULL) != CSI_OK) {
        fprintf(stderr, "csi-bench-plan: %s\n", csi_last_error());
        return 1;
    }
    const double MiB = 1024.0 * 1024.0;
    for (int a = 1; a < argc; a++) {
        unsigned w, h, spp;
        if (sscanf(argv[a], "%ux%u:%u", &w, &h, &spp) != 3 || !w || !h || !spp) {
            fprintf(stderr, "csi-bench-plan: %s is not WxH:SPP\n", argv[a]);
            return 2;
        }
        const unsigned f = csi_default_grid_factor(w, h, 1, spp);
        const csi_grid g = {w * f, h * f, 1, w, h};
        const size_t n = (size_t)w * h * spp;
        csi_recon_options d;
        csi_recon_defaults(&d);
        csi_recon_plan p;
        csi_tiling tl;
        if (csi_recon_plan_make(ctx, &g, 3, n, &d, &p) != CSI_OK || csi_tiling_plan(ctx, &g, 3, n, &d, &tl) != CSI_OK) {
            fprintf(stderr, "csi-bench-plan: %s: %s\n", argv[a], csi_last_error());
            return 1;
        }
        printf("%ux%u %u spp, grid %ux%u: %u tiles (%ux%u), windows %ux%u px, %.0f MiB a tile (FFT rows %s); "
               "whole %.2f GiB; host %.0f MiB; largest buffer %.1f MiB\n", w, h, spp, g.w, g.h, tl.count, tl.n[0],
               tl.n[1], tl.window[0], tl.window[1], p.device_bytes / MiB, p.rows_unfused ? "unfused" : "fused",
               tl.whole_bytes / (MiB * 1024.0), p.host_bytes / MiB, p.largest_buffer / MiB);
    }
    csi_ctx_release(ctx);
    return 0;
}
