/* The library as a whole: its version, and releasing what it hands out. */
#include <stdlib.h>

#include "csi/csi.h"

#define CSI_STR_(x) #x
#define CSI_STR(x) CSI_STR_(x)

const char *csi_version(void)
{
    return CSI_STR(CSI_VERSION_MAJOR) "." CSI_STR(CSI_VERSION_MINOR) "." CSI_STR(CSI_VERSION_PATCH);
}

void csi_free(void *p)
{
    free(p);
}
