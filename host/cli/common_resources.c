/* Resources before work: a run that cannot fit the device or the host is refused with one line
 * naming the input, the size and the limit, before samples are read or traced (csi/plan.h). */
#include "resources.h"

#include <inttypes.h>
#include <stdio.h>

#include "csi/plan.h"

csi_status cli_check_resources(const csi_ctx *ctx, const char *input, const csi_grid *g, uint32_t channels,
                               size_t n, const csi_recon_options *opt, uint64_t extra_host)
{
    csi_recon_plan p;
    csi_status st = csi_recon_plan_make(ctx, g, channels, n, opt, &p);
    if (st != CSI_OK)
        return csi_fail_context(st, "%s: ", input);
    csi_mem_budget b;
    csi_mem_budget_of(ctx, &b);
    char subject[1200];
    snprintf(subject, sizeof subject, "%s: grid %" PRIu32 "x%" PRIu32 "x%" PRIu32 " (%" PRIu64 " cells), %zu samples%s",
             input, g->w, g->h, g->t, p.cells, n, p.tiles > 1 ? " in tiles" : "");
    return csi_recon_plan_check(&p, &b, extra_host, subject);
}
