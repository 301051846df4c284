/* What the public API's files share (not installed): the handles behind csi/csi.h's opaque types
 * and the per-device error record. */
#ifndef CSI_API_INTERNAL_H
#define CSI_API_INTERNAL_H

#include "csi/reconstruct.h"

struct csi_device {
    csi_ctx *ctx;
    csi_status error;     /* the first failure not yet read by csi_device_error */
    char message[2048];   /* its message */
    char reported[2048];  /* the message handed out by the last csi_device_error */
};

struct csi_options {
    csi_recon_options o;
};

/* The library's progress reports passed on as csi/csi.h's: o.progress = csi_api_progress_relay,
 * o.user = a csi_api_progress. */
typedef struct {
    csi_progress_fn fn;
    void *user;
} csi_api_progress;
bool csi_api_progress_relay(void *user, const char *phase, int iter, double rel_residual);

/* The options a reconstruction of samples s runs with: *options (NULL: the defaults) and what
 * the samples are (s->flags); CSI_ERR_ARG naming fn when a flag is not one csi knows. */
csi_status csi_api_options_for(const csi_options *options, const csi_samples *s, const char *fn,
                               csi_recon_options *o);

/* Records st's failure (this thread's last message) on dev, unless an earlier one is still
 * unread; returns st. dev may be NULL. */
csi_status csi_device_record(csi_device *dev, csi_status st);

/* A csi_result holding res, which it takes over (res is zeroed; freed with the result even on
 * failure): for the programs' --tile runs and csi-merge, which make a csi_recon_result through the
 * library's own tile calls (csi/tiles.h) and write it as any other result. g: the samples' grid. */
csi_status csi_result_adopt(csi_recon_result *res, const csi_grid *g, csi_result **out);

#endif
