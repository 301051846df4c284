/* Sizes before work (csi/csi.h csi_reconstruct_check): a run that cannot fit the device or the
 * host is refused with one line naming the input, the size and the limit, before its samples are
 * read or traced (the resource plan, csi/plan.h). */
#include <inttypes.h>
#include <stdio.h>

#include "csi/plan.h"
#include "internal.h"

csi_status csi_reconstruct_check(csi_device *dev, const csi_grid *g, uint32_t channels, size_t n,
                                 const csi_options *options, uint64_t extra_host, const char *input)
{
    if (!dev || !g)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_reconstruct_check: %s is NULL",
                                               !dev ? "the device" : "the grid"));
    if (!input)
        input = "the samples";
    csi_recon_options o;
    if (options)
        o = options->o;
    else
        csi_recon_defaults(&o);
    csi_recon_plan p;
    csi_status st = csi_recon_plan_make(dev->ctx, g, channels, n, &o, &p);
    if (st != CSI_OK)
        return csi_device_record(dev, csi_fail_context(st, "%s: ", input));
    csi_mem_budget b;
    csi_mem_budget_of(dev->ctx, &b);
    char subject[1200];
    snprintf(subject, sizeof subject, "%s: grid %" PRIu32 "x%" PRIu32 "x%" PRIu32 " (%" PRIu64 " cells), %zu samples%s",
             input, g->w, g->h, g->t, p.cells, n, p.tiles > 1 ? " in tiles" : "");
    return csi_device_record(dev, csi_recon_plan_check(&p, &b, extra_host, subject));
}
