/* The programs' heap: what a run frees is kept for its next allocations.
 *
 * A reconstruction allocates and frees the same large host arrays and device buffers (PoCL's
 * buffers are host memory) once per tile and per channel. glibc serves blocks above its mmap
 * threshold from fresh mappings and returns freed memory at the heap's top to the kernel, so each
 * new array is faulted in and zeroed page by page again (docs/bench/cost.md, "session 17, round
 * 2"). A program that runs one job and exits gains nothing from giving memory back early. The
 * library leaves the heap alone: how a process manages its memory is its own choice, and the
 * programs make it here. */
#include "common.h"

#include <limits.h>
#include <stdlib.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

void cli_heap_keep_freed(void)
{
#if defined(__GLIBC__)
    /* blocks below glibc's largest threshold (32 MiB on 64-bit systems) from the heap, and the
     * heap's freed top kept: where memory comes from changes, not what a run computes */
    (void)mallopt(M_MMAP_THRESHOLD, 32 << 20);
    (void)mallopt(M_TRIM_THRESHOLD, INT_MAX);
#endif
}
