/* The resource plan of a reconstruction: the memory csi_recon will use, computed from the
 * sizes alone (no device, no allocation, microseconds), and whether it fits a budget.
 *
 * Callers make the plan from a dump's header or a scene's grid before reading samples or
 * tracing, and refuse what cannot fit with one line naming the input, the size and the limit
 * (CSI_ERR_TOO_LARGE), instead of failing after minutes or inside the OpenCL implementation.
 *
 * Device memory: every buffer csi_recon allocates, per method (Alg. 1 with SpaRSA or ROMP,
 * Alg. 2 on the half or full spectrum, the Gaussian and sample-mean baselines), from the
 * `*_buffers` functions beside each module's create function; the peak is the buffers held for
 * the whole run plus the largest set held only for a while (ROMP's column-norm probes, the
 * sample mean's splat arrays). tests/unit/test_recon_plan.c checks it against the peak that
 * csi_buffer counts on real runs of every method. Host memory: the result (image and frames),
 * the per-sample arrays, the solver's host arrays and the largest transient ones. Not counted:
 * the caller's own samples (see csi_recon_plan_check's extra_host) and the OpenCL
 * implementation's own fixed overhead (programs, queues). */
#ifndef CSI_PLAN_H
#define CSI_PLAN_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/host_memory.h"
#include "csi/reconstruct.h"
#include "csi/runtime.h"
#include "csi/samples.h"
#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What a run may use. A limit of 0 is no limit. */
typedef struct csi_mem_budget {
    uint64_t device_global;  /* bytes all device buffers may hold at once */
    uint64_t device_buffer;  /* bytes of the largest single device buffer */
    uint64_t host;           /* host bytes available */
    bool device_in_host;     /* device buffers live in host memory (a CPU device such as PoCL's):
                                they count against `host` too */
    const char *device_name; /* for messages (may be NULL) */
} csi_mem_budget;

/* The device's limits as the context enforces them (csi_ctx_max_alloc, csi_ctx_global_mem:
 * what the device reports, or lower after csi_ctx_limit_memory) and the host's available memory
 * (csi_host_available_bytes). */
void csi_mem_budget_of(const csi_ctx *ctx, csi_mem_budget *out);

typedef struct csi_recon_plan {
    const char *method;        /* "Alg. 1", "Alg. 1 (model grid)", "Alg. 2 (half spectrum)",
                                  "Alg. 2 (full spectrum)", "Gaussian baseline", "sample mean" */
    uint64_t cells;            /* k = w * h * t */
    uint32_t tiles;            /* tiles csi_recon will solve it in (1: the whole at once);
                                  the device figures are then one tile's */
    uint64_t unknowns;         /* the solver's unknowns (complex for Alg. 2); 0 for baselines */
    uint64_t device_bytes;     /* the most device bytes live at once */
    uint64_t largest_buffer;   /* the largest single device buffer */
    const char *largest_what;  /* what it holds */
    uint64_t host_bytes;       /* the most host bytes csi_recon holds at once */
    bool rows_unfused;         /* Alg. 1's filter runs its FFT rows pass by pass, not fused
                                  (csi_filter_rows_fused): more CPU per cell (csi/tiles.h) */
} csi_recon_plan;

/* The plan for csi_recon(ctx, g, channels, pos, values, n, opt, ...) (opt NULL: the
 * defaults; ctx may be NULL: then the tile layout follows the budget alone, as csi_tiling_plan
 * does). When csi_recon will solve the problem in tiles (csi/tiles.h), the device figures
 * are those of one tile holding as many samples as its window can (all of them, at most its
 * cells), and the host's hold the whole result and one tile's problem. Checks what
 * csi_recon checks from the sizes alone, with the same CSI_ERR_ARG messages: zero or
 * non-divisible sizes, more than 2^32 cells, n = 0 or n > k, ROMP on a volume, FFT sizes with a
 * prime factor other than 2, 3, 5, 7, grids too small for a wavelet level, and csi_tiling_plan's
 * refusal when no layout fits the budget. */
csi_status csi_recon_plan_make(const csi_ctx *ctx, const csi_grid *g, uint32_t channels, size_t n,
                               const csi_recon_options *opt, csi_recon_plan *out);

/* CSI_OK when the plan fits the budget, with extra_host more host bytes held by the caller
 * meanwhile (its samples, a tracer); else CSI_ERR_TOO_LARGE with one line that starts with
 * `subject` (say "x.csid: grid 16384x16384x1") and names what is needed and the limit. */
csi_status csi_recon_plan_check(const csi_recon_plan *p, const csi_mem_budget *b,
                                uint64_t extra_host, const char *subject);

#ifdef __cplusplus
}
#endif
#endif
