/* Per-thread error message storage for csi_status failures. */
#include "csi/status.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char csi_msg[2048];
static _Thread_local csi_status csi_last;

const char *csi_status_name(csi_status st)
{
    switch (st) {
    case CSI_OK: return "CSI_OK";
    case CSI_ERR_ARG: return "CSI_ERR_ARG";
    case CSI_ERR_IO: return "CSI_ERR_IO";
    case CSI_ERR_FORMAT: return "CSI_ERR_FORMAT";
    case CSI_ERR_NOMEM: return "CSI_ERR_NOMEM";
    case CSI_ERR_DEVICE: return "CSI_ERR_DEVICE";
    case CSI_ERR_CL: return "CSI_ERR_CL";
    case CSI_ERR_BUILD: return "CSI_ERR_BUILD";
    case CSI_ERR_NUMERIC: return "CSI_ERR_NUMERIC";
    case CSI_ERR_SCENE: return "CSI_ERR_SCENE";
    case CSI_ERR_TOO_LARGE: return "CSI_ERR_TOO_LARGE";
    case CSI_ERR_CANCELLED: return "CSI_ERR_CANCELLED";
    }
    return "CSI_ERR_UNKNOWN";
}

const char *csi_last_error(void) { return csi_msg; }

csi_status csi_last_status(void) { return csi_last; }

void csi_clear_error(void)
{
    csi_msg[0] = '\0';
    csi_last = CSI_OK;
}

csi_status csi_fail(csi_status st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(csi_msg, sizeof csi_msg, fmt, ap);
    va_end(ap);
    csi_last = st;
    return st;
}

csi_status csi_fail_context(csi_status st, const char *fmt, ...)
{
    char prefix[1024], old[sizeof csi_msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, csi_msg, sizeof old);
    snprintf(csi_msg, sizeof csi_msg, "%.1023s%.1000s", prefix, old);
    csi_last = st;
    return st;
}
