/* Status codes and the error message every failing csi_ call leaves behind.
 *
 * The library never prints and never exits: a function that fails returns a non-zero
 * csi_status and records a one-line message (what, where, why) that the caller can fetch with
 * csi_last_error() and print. The message is per thread. The codes and csi_last_error are
 * public (csi/csi.h); recording a failure is the library's own business. */
#ifndef CSI_STATUS_H
#define CSI_STATUS_H

#include "csi/csi.h" /* csi_status, csi_status_name, csi_last_error, csi_escape_controls */
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif



/* Records a printf-style message and returns st, so failures read `return csi_fail(...)`. */
csi_status csi_fail(csi_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Prepends context ("reading scene.csid: ") to the current message and returns st. */
csi_status csi_fail_context(csi_status st, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* The status of this thread's last failure (CSI_OK after csi_clear_error). */
csi_status csi_last_status(void);
/* Forgets this thread's last failure. */
void csi_clear_error(void);

#ifdef __cplusplus
}
#endif
#endif
