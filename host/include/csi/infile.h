/* Input files: regular files only, opened so that nothing can block or surprise the reader.
 *
 * A FIFO would block open(2) until a writer appears, /dev/zero reads forever, a directory reads
 * as an error deep inside a decoder. Every reader in csi (dumps, scenes, OBJ meshes, textures,
 * images) opens its input here: with O_NONBLOCK (a FIFO never blocks), then fstat, and anything
 * but a regular file is refused with one line naming the file and what it is; a file larger than
 * the caller's cap is refused before it is read. */
#ifndef CSI_INFILE_H
#define CSI_INFILE_H

#include <stdint.h>
#include <stdio.h>

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Opens `path` for reading as a stdio stream (binary). `what` names the input in messages ("scene",
 * "sample dump"). max_bytes > 0: larger files are refused (CSI_ERR_TOO_LARGE, naming the size and
 * the cap). Errors: CSI_ERR_IO "path: cannot open <what>: <reason>" (missing, no permission, a
 * directory, a FIFO, a device, a socket). *size: the file's size in bytes (may be NULL). */
csi_status csi_infile_open(const char *path, const char *what, uint64_t max_bytes, FILE **fp,
                           uint64_t *size);

/* The same checks without keeping the file open, for readers that open the path themselves
 * (libpng, OpenEXR). */
csi_status csi_infile_check(const char *path, const char *what, uint64_t max_bytes, uint64_t *size);

/* Reads the whole file into a NUL-terminated buffer (malloc'd; *len without the NUL). */
csi_status csi_infile_read_all(const char *path, const char *what, uint64_t max_bytes, char **text,
                               size_t *len);

#ifdef __cplusplus
}
#endif
#endif
