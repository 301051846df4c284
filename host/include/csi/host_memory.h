/* The host memory a run may use: what the operating system says is available now.
 *
 * Used by the resource plan (csi/plan.h) and the readers to refuse an input that cannot fit
 * before allocating for it, rather than being killed by the OOM killer or swapping for minutes. */
#ifndef CSI_HOST_MEMORY_H
#define CSI_HOST_MEMORY_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bytes the host can give a new allocation without swapping: Linux's MemAvailable
 * (/proc/meminfo), lowered to $CSI_HOST_MEMORY_LIMIT (bytes) when that is set to a smaller
 * number. 0 when unknown (then nothing is refused for host memory). */
uint64_t csi_host_available_bytes(void);

#ifdef __cplusplus
}
#endif
#endif
