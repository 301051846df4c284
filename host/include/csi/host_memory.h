/* The host memory a run may use: what the operating system says is available now.
 *
 * Used by the resource plan (csi/plan.h) and the readers to refuse an input that cannot fit
 * before allocating for it, rather than being killed by the OOM killer or swapping for minutes.
 * csi_host_available_bytes and csi_bytes_text are public (csi/csi.h declares them). */
#ifndef CSI_HOST_MEMORY_H
#define CSI_HOST_MEMORY_H

#include "csi/csi.h"

#endif
