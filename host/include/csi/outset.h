/* The outputs of one run, written all or nothing.
 *
 * A run that writes several files (an EXR, a PNG preview, statistics, a dump, a folder of frames)
 * states them all before any work: each is checked then (its directory exists and is writable;
 * it is not one of the run's inputs, nor another of its outputs) so that a run that cannot write
 * its outputs fails in milliseconds. After the work each output is written to a temporary name
 * beside it, and csi_outset_commit renames them all into place only when every one was written;
 * on any failure, csi_outset_abort (or a failed commit) leaves nothing new: no temporary file, no
 * new file, no folder the run created, and every file the run would have replaced as it was.
 *
 * Identity: two paths are the same file when they name the same device and inode (hard links
 * and symbolic links included), or, for a file that does not exist yet, when their directories
 * resolve to the same directory (realpath) and their names are equal.
 *
 * Commit: destinations that exist are first kept as hard links (backups) beside them, then every
 * temporary file is renamed over its destination (rename(2) is atomic within a directory); if a
 * rename fails, those done are undone (new files removed, backups renamed back), so the set
 * appears whole or not at all except for a crash during the renames themselves.
 *
 * Testing: when the environment variable CSI_FAIL_OUTPUT is a number N > 0, the Nth output event
 * of the process fails as a write error would (an event: one file's data completed by
 * csi_outfile_commit, or one rename of a commit), so that tests can check that a failure after
 * each file leaves nothing behind. */
#ifndef CSI_OUTSET_H
#define CSI_OUTSET_H

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_outset csi_outset;

csi_status csi_outset_create(csi_outset **out);
/* Aborts whatever was not committed, then frees. NULL is fine. */
void csi_outset_free(csi_outset *s);

/* An input of the run (it must exist): no output may resolve to it. */
csi_status csi_outset_input(csi_outset *s, const char *path);

/* An output file. `what` names it in messages ("the image", "--png"). Refused (CSI_ERR_IO, one
 * line naming the path): an empty path or one ending in '/', a directory, a missing or
 * unwritable directory, an input of the run, an output already stated. */
csi_status csi_outset_file(csi_outset *s, const char *path, const char *what);

/* An output folder (frames): refused if it exists and is not a writable directory, or if its
 * parent is missing or unwritable. When it does not exist, the run creates it as a temporary
 * folder beside it, renamed into place by the commit. Its files are stated with
 * csi_outset_dir_file(s, dir, "frame_0000.exr", ...). */
csi_status csi_outset_dir(csi_outset *s, const char *dir, const char *what);
csi_status csi_outset_dir_file(csi_outset *s, const char *dir, const char *name, const char *what);

/* The temporary path to write a stated output to (a file in the destination's directory, or
 * in the temporary folder), made on the first call; `path` as stated (for a folder's file,
 * "dir/name"). Any writer may write it, including by its own temporary file and rename. */
csi_status csi_outset_tmp(csi_outset *s, const char *path, const char **tmp);

/* Renames every output into place (see the top of this file). Outputs stated but never given a
 * temporary path are left out (nothing was written for them). Afterwards the set is empty. */
csi_status csi_outset_commit(csi_outset *s);

/* For a program's SIGINT/SIGTERM/SIGHUP handler: removes the set's temporary files and folders
 * and the file being written (csi_outfile_signal_cleanup) with unlink and rmdir only
 * (async-signal-safe), so an interrupted run leaves nothing either; the handler then ends the
 * program. */
void csi_outset_signal_cleanup(const csi_outset *s);

/* Removes every temporary file and folder of the set; the set is then empty. */
void csi_outset_abort(csi_outset *s);

#ifdef __cplusplus
}
#endif
#endif
