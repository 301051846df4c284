/* Output files that appear whole or not at all.
 *
 * Every writer in csi (sample dumps, EXR, PNG, stats JSON) writes to a temporary file in the
 * destination's directory and renames it over the destination only when everything was written
 * and flushed (rename(2) within one file system is atomic in POSIX). On any failure the
 * temporary file is removed, so a failed write never leaves a partial file, and an existing
 * file at the destination is untouched. */
#ifndef CSI_OUTFILE_H
#define CSI_OUTFILE_H

#include <signal.h>
#include <stdbool.h>
#include <stdio.h>

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_outfile {
    FILE *fp;      /* stdio stream on the temporary file (binary mode) */
    int fd;        /* its descriptor, for positioned writes (pwrite) */
    char *path;    /* the destination */
    char *tmp;     /* the temporary file: "<dir>/.<name>.tmpXXXXXX" */
} csi_outfile;

/* Creates the temporary file next to `path`. CSI_ERR_IO (naming the path and the cause) if the
 * directory is missing or not writable. On failure `of` holds nothing to release. */
csi_status csi_outfile_open(csi_outfile *of, const char *path);

/* Flushes, syncs, closes and renames the temporary file to the destination. On failure the
 * temporary file is removed and CSI_ERR_IO returned. Either way `of` is released. */
csi_status csi_outfile_commit(csi_outfile *of);

/* Closes and removes the temporary file; releases `of`. Safe on a zeroed or released struct. */
void csi_outfile_abort(csi_outfile *of);

/* Removes the temporary file being written, if any: async-signal-safe (unlink only), for a
 * program's SIGINT/SIGTERM handler (csi_outset_signal_cleanup calls it). */
void csi_outfile_signal_cleanup(void);

/* Holds back SIGINT, SIGTERM and SIGHUP on the calling thread while a temporary file is created
 * and recorded for the handler (between the two, an interrupted run would leave the file behind):
 * block saves the thread's mask in *old, unblock restores it and lets a held-back signal in. */
void csi_outfile_hold_signals(sigset_t *old);
void csi_outfile_release_signals(const sigset_t *old);

/* Test hook: true for the Nth output event of the process when $CSI_FAIL_OUTPUT = N > 0 (an
 * event: a file's data completed by csi_outfile_commit, or one rename of csi_outset_commit),
 * which then fails as a write error would. Always false otherwise. */
bool csi_output_fault(void);

#ifdef __cplusplus
}
#endif
#endif
