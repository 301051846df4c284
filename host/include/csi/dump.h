/* Sample dumps: the file format other renderers write (docs/dump-format.md), read and written.
 *
 * A dump holds samples of a signal on a fine grid (csi_grid: w x h x t cells, final image
 * out_w x out_h): one record per sample, a position on the grid and `channels` float32 values.
 * Little-endian, version 1, a 64-byte header, then `count` records of (u32 x, u32 y, u32 t,
 * channels x f32). The reader validates everything and reports a one-line error naming the
 * file and the byte offset or record number; it never allocates more than the file can hold. */
#ifndef CSI_DUMP_H
#define CSI_DUMP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h" /* and csi/csi.h: csi_dump and its reader and writer */

#ifdef __cplusplus
extern "C" {
#endif

#define CSI_DUMP_MAGIC "CSID"
#define CSI_DUMP_VERSION 1u
#define CSI_DUMP_HEADER_BYTES 64u
#define CSI_DUMP_MAX_CHANNELS 4u
/* Absurd-size guards, checked before anything is allocated: each grid side at most 2^16
 * cells, and k = w*h*t at most 2^31 cells (8 GiB per float32 channel, far beyond any device
 * here). The caller tightens the cell limit to its device with csi_dump_read_opts.max_cells. */
#define CSI_DUMP_MAX_SIDE CSI_GRID_MAX_SIDE
#define CSI_DUMP_MAX_CELLS (UINT64_C(1) << 31)

/* csi_dump_read (declared in csi/csi.h) validates everything. Errors (all CSI_ERR_FORMAT unless
 * said otherwise; message "path: byte B: ..." or "path: record R (byte B): ..."): wrong magic,
 * unknown version, truncated header, non-zero reserved bytes, bad grid or channels (before
 * allocating), zero samples, count larger than the file or trailing bytes, positions outside the
 * grid (also t != 0 when grid_t = 1), NaN/Inf values (unless opts->drop_invalid: then dropped and
 * counted; a file with no valid record left is still an error). CSI_ERR_IO if the file cannot be
 * opened/read. Records at the same position are averaged per channel (in double) and counted in
 * report->duplicates. The result is sorted by linear index, unique. opts and report may be NULL.
 * On failure *out is zeroed. The file must be a regular file (csi/infile.h: FIFOs, devices and
 * directories are refused by what they are), and the reader refuses (CSI_ERR_TOO_LARGE) records
 * that need more host memory than is available. */
/* csi_dump_write (csi/csi.h) writes a temporary file, then renames it (csi/outfile.h). It refuses
 * (CSI_ERR_ARG) what the reader would refuse: a bad grid, zero samples, a position outside the
 * grid, a non-finite value. Duplicate positions are allowed (the format permits them). channels = 0
 * writes a positions request (records x, y, t only; values unused, may be NULL): what
 * csi-positions hands a renderer, which csi_dump_read refuses as samples ("a positions request
 * (channels = 0: no values to reconstruct from)"). */

/* csi_dump_header, csi_dump_read_header and csi_dump_read_host_bytes are in csi/csi.h. */

/* csi_dump_read on a dump in memory (len bytes; `name` for messages). */
csi_status csi_dump_read_mem(const void *data, size_t len, const char *name, const csi_dump_read_opts *opts,
                             csi_dump *out, csi_dump_report *report);

#ifdef __cplusplus
}
#endif
#endif
