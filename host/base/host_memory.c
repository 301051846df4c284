/* Available host memory (see csi/host_memory.h). */
#include "csi/host_memory.h"

#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *csi_bytes_text(uint64_t bytes, char *buf, size_t len)
{
    static const char *u[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB"};
    double b = (double)bytes;
    int i = 0;
    while (b >= 1024.0 && i < 5) {
        b /= 1024.0;
        i++;
    }
    if (i == 0)
        snprintf(buf, len, "%" PRIu64 " B", bytes);
    else
        snprintf(buf, len, "%.1f %s", b, u[i]);
    return buf;
}

uint64_t csi_host_available_bytes(void)
{
    uint64_t avail = 0;
    FILE *f = fopen("/proc/meminfo", "r");
    if (f) {
        char line[256];
        unsigned long long kib;
        while (fgets(line, sizeof line, f))
            if (sscanf(line, "MemAvailable: %llu kB", &kib) == 1) {
                avail = (uint64_t)kib * 1024;
                break;
            }
        fclose(f);
    }
    /* A lower limit from the environment: for budgets below the machine's, and for tests of
     * the host check that must not depend on the machine's free memory. */
    const char *env = getenv("CSI_HOST_MEMORY_LIMIT");
    if (env && *env) {
        char *end;
        errno = 0;
        unsigned long long v = strtoull(env, &end, 10);
        if (!errno && *end == '\0' && v > 0 && (avail == 0 || v < avail))
            avail = v;
    }
    return avail;
}
