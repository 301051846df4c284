/* Status codes and the error message every failing csi_ call leaves behind.
 *
 * The library never prints and never exits: a function that fails returns a non-zero
 * csi_status and records a one-line message (what, where, why) that the caller can fetch with
 * csi_last_error() and print. The message is per thread. */
#ifndef CSI_STATUS_H
#define CSI_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

typedef enum csi_status {
    CSI_OK = 0,
    CSI_ERR_ARG,          /* an argument is out of range or inconsistent (sizes, options) */
    CSI_ERR_IO,           /* a file could not be opened, read or written */
    CSI_ERR_FORMAT,       /* a file's contents are malformed (truncated, bad magic, NaN ...) */
    CSI_ERR_NOMEM,        /* host allocation failed */
    CSI_ERR_DEVICE,       /* no usable OpenCL device, or a size the device cannot hold */
    CSI_ERR_CL,           /* an OpenCL or clFFT call failed */
    CSI_ERR_BUILD,        /* a kernel program failed to build (message holds the log's start) */
    CSI_ERR_NUMERIC,      /* a computation produced NaN/Inf or cannot proceed numerically */
    CSI_ERR_SCENE,        /* a scene file has an error */
    CSI_ERR_TOO_LARGE,    /* the input needs more memory than the device or host has (refused
                             before any work: csi/plan.h) */
} csi_status;

/* Short name of a status ("CSI_ERR_IO"). */
const char *csi_status_name(csi_status st);

/* The message of the last failure on this thread ("" if none). */
const char *csi_last_error(void);

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

void csi_clear_error(void);

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
