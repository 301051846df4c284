/* Resource checks the programs make before any work (common_resources.c). */
#ifndef CSI_CLI_RESOURCES_H
#define CSI_CLI_RESOURCES_H

#include <stdint.h>

#include "csi/reconstruct.h"

/* CSI_OK when reconstructing n samples on grid g (channels, opt) fits the device's limits and
 * the host's available memory with extra_host bytes the program holds besides (its samples, the
 * dump reader, positions, the tracer); else CSI_ERR_TOO_LARGE (or the plan's CSI_ERR_ARG) with
 * one line naming `input`, the grid and the limit. Arithmetic on the sizes only. */
csi_status cli_check_resources(const csi_ctx *ctx, const char *input, const csi_grid *g, uint32_t channels,
                               size_t n, const csi_recon_options *opt, uint64_t extra_host);

#endif
