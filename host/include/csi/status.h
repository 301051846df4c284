/* Status codes and the error message every failing csi_ call leaves behind.
 *
 * The library never prints and never exits: a function that fails returns a non-zero
 * csi_status and records a one-line message (what, where, why) that the caller can fetch with
 * csi_last_error() and print. The message is per thread. The codes and csi_last_error are
 * public (csi/csi.h); recording a failure is the library's own business. */
#ifndef CSI_STATUS_H
#define CSI_STATUS_H

#include "csi/csi.h" /* csi_status, csi_status_name, csi_last_error */
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

/* Copies `in` to out (cap bytes, NUL-terminated) with every control character written as
 * \xNN: ASCII controls (newlines and escape sequences included), DEL, C1 controls and bytes that
 * are not valid UTF-8; other UTF-8 is kept. Every message csi_fail records goes through it, so
 * input bytes echoed into a message cannot drive a terminal. Returns the length written. */
size_t csi_escape_controls(const char *in, char *out, size_t cap);

/* Propagate a failure: CSI_TRY(expr) returns from the enclosing function when expr fails. */
#define CSI_TRY(expr)                          \
    do {                                       \
        csi_status csi_try_st_ = (expr);       \
        if (csi_try_st_ != CSI_OK)             \
            return csi_try_st_;                \
    } while (0)

#ifdef __cplusplus
}
#endif
#endif
