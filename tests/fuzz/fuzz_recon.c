/* libFuzzer target: the whole reconstruction pipeline on tiny grids. The input is a sample dump
 * (the reader limits it to 4096 cells); a dump it accepts goes through the resource plan and
 * csi_recon with options chosen by the header's seed field (estimator, solver, frames, the
 * half or full spectrum, the model grid, tiles, 1 to 8 iterations, and for a volume the basis's
 * velocity and time transform), on one OpenCL context made once. The velocity is estimated for
 * a third of the volumes and none or given (any value) for the others: the estimate's search
 * filters the volume a dozen times or more, most of a volume's cost, and the other two modes are
 * paths of their own (a given shear, the DFT along t with a shear) that the default never takes.
 * Properties: csi_recon succeeds or fails with a one-line message (never NaN in an image it
 * returns: any finite float32 sample must reconstruct, docs/dump-format.md), and the device bytes
 * it held at its peak are within the plan. Grids whose width is odd or below 4 are left out: their
 * filters run on clFFT, whose plans take seconds to bake for every new size (its own path is
 * checked against csi's kernels by tests/unit/test_spectral.c; the reader still sees them in
 * fuzz_dump). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "csi/dump.h"
#include "csi/plan.h"
#include "csi/reconstruct.h"
#include "csi/runtime.h"

static csi_ctx *ctx;

/* An input whose csi_recon takes more than this many seconds of the process's CPU time is a hang
 * (issue 14: none over 20 s). libFuzzer's own -timeout counts wall time, which on a shared
 * machine at a low priority is mostly waiting for a core (a 0.6 s input was stopped after 29 s):
 * the long runs give it a wide margin and leave the 20 s to this check, which does not depend on
 * the load; the ASan + UBSan build is slower than a release one, so the limit is the stricter
 * for it. The time spent building kernel programs (once per program and context, seconds when
 * PoCL's cache is cold) is not the input's. */
#define CPU_LIMIT_S 20.0

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    if (csi_ctx_create(&ctx, NULL) != CSI_OK)
        abort();
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    csi_dump_read_opts ro = {.max_cells = 4096};
    csi_dump d;
    if (csi_dump_read_mem(data, size, "fuzz.csid", &ro, &d, NULL) != CSI_OK)
        return 0;
    if (d.grid.w % 2 || d.grid.w < 4) {
        csi_dump_free(&d);
        return 0;
    }
    const uint64_t sel = d.seed;
    csi_recon_options o;
    csi_recon_defaults(&o);
    o.estimator = (csi_estimator)(sel % 3);
    o.solver = (sel >> 2) & 1 ? CSI_SOLVER_ROMP : CSI_SOLVER_SPARSA;
    o.frames = (sel >> 3) & 1;
    o.motion_full_spectrum = (sel >> 4) & 1;
    o.model_grid = (sel >> 5) & 1 ? CSI_SWITCH_OFF : CSI_SWITCH_AUTO;
    o.tiles = (sel >> 6) & 1 ? 2 : 0;
    o.max_iter = 1 + (int)((sel >> 8) % 8);
    o.seed = sel >> 16;
    o.motion_velocity = (csi_velocity_mode)((sel >> 11) % 3);
    o.motion_vx = (int8_t)(sel >> 32) / 8.0; /* cells per frame, used when given */
    o.motion_vy = (int8_t)(sel >> 40) / 8.0;
    o.motion_time = (csi_motion_time)((sel >> 13) % 3);
    o.sample_flags = d.flags; /* exact values: correct = auto takes cv */
    csi_recon_plan p;
    if (csi_recon_plan_make(ctx, &d.grid, d.channels, d.count, &o, &p) == CSI_OK) {
        const uint64_t live = csi_device_bytes_live();
        csi_device_bytes_reset_peak();
        csi_recon_result r;
        const double t0 = cpu_seconds(), b0 = csi_ctx_build_seconds(ctx);
        csi_status st = csi_recon(ctx, &d.grid, d.channels, d.pos, d.values, d.count, &o, &r);
        const double cpu = cpu_seconds() - t0 - (csi_ctx_build_seconds(ctx) - b0);
        if (cpu > CPU_LIMIT_S) {
            fprintf(stderr, "fuzz_recon: csi_recon took %.1f s of CPU (limit %.0f s)\n", cpu, CPU_LIMIT_S);
            abort();
        }
        /* a tiled plan is one tile's with its share of the samples: only the whole is bounded */
        if (p.tiles == 1 && csi_device_bytes_peak() - live > p.device_bytes)
            abort();
        if (csi_device_bytes_live() != live)
            abort(); /* everything released */
        if (st == CSI_OK) {
            const size_t np = (size_t)r.out_w * r.out_h * r.channels;
            for (size_t i = 0; i < np; i++)
                if (!isfinite(r.image[i]))
                    abort();
            csi_recon_result_free(&r);
        } else if (!csi_last_error()[0] || strchr(csi_last_error(), '\n')) {
            abort();
        }
    }
    csi_dump_free(&d);
    return 0;
}
