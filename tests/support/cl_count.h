/* Every device buffer the process creates and releases, counted apart from csi's own count
 * (csi_device_bytes_live): clCreateBuffer and clReleaseMemObject are defined in cl_count.c, so a
 * test that calls these functions links them into its executable, where every caller in the
 * process (csi's library, clFFT's shared library) resolves them first; they count and call
 * OpenCL's. A buffer is counted from its creation to its release by its owner, whatever
 * references the OpenCL implementation still holds for queued commands. */
#ifndef CSI_TEST_CL_COUNT_H
#define CSI_TEST_CL_COUNT_H

#include <stdint.h>

uint64_t test_cl_live(void);     /* bytes of the buffers created and not released */
uint64_t test_cl_peak(void);     /* the largest test_cl_live since the last reset */
void test_cl_reset_peak(void);   /* the peak := the live bytes now */
int test_cl_created(void);       /* buffers created so far */

#endif
