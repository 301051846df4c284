/* The host memory a run may use: what the operating system says is available now.
 *
 * Used by the resource plan (csi/plan.h) and the readers to refuse an input that cannot fit
 * before allocating for it, rather than being killed by the OOM killer or swapping for minutes. */
#ifndef CSI_HOST_MEMORY_H
#define CSI_HOST_MEMORY_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bytes the host can give a new allocation without swapping: Linux's MemAvailable
 * (/proc/meminfo), lowered to $CSI_HOST_MEMORY_LIMIT (bytes) when that is set to a smaller
 * number. 0 when unknown (then nothing is refused for host memory). */
uint64_t csi_host_available_bytes(void);

/* Bytes as text, "3.5 GiB" (binary units), into buf (len >= 16); returns buf. */
const char *csi_bytes_text(uint64_t bytes, char *buf, size_t len);

#ifdef __cplusplus
}
#endif
#endif
