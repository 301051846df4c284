/* Tile partials (not installed): the file format of one tile's reconstruction, written by
 * csi_partial_write and read back by csi_partial_read / csi_partials_merge (csi/csi.h; the format
 * is docs/partial-format.md).
 *
 * A partial carries what decides its pixels, so that a merge can refuse partials of different
 * runs: the software version, the input's identity (a hash of the dump's samples, or the
 * caller's own), the reconstruction options as given, the tile layout and the whole problem's
 * scope; then the tile's window image (and frames), its solver reports, and a checksum over
 * everything before it. */
#ifndef CSI_API_PARTIAL_H
#define CSI_API_PARTIAL_H

#include <stdint.h>

#include "csi/reconstruct.h"
#include "csi/tiles.h"

#define CSI_PARTIAL_MAGIC "CSIP"
#define CSI_PARTIAL_VERSION 11u

typedef struct csi_partial {
    char software[32];   /* "csi 0.1.0" */
    char method[96];     /* the EXR's csi:method */
    char input[128];     /* the input's file name (for messages) */
    uint64_t input_id;   /* content hash of the input (csi_hash64) */
    csi_recon_options options; /* as given to the tile (progress/user NULL) */
    csi_recon_options reported; /* as the one-process run of the layout reports them (the merge's) */
    csi_tiling tiling;
    csi_tile_scope scope;
    csi_tile_result tile;
} csi_partial;

/* Writes p (temporary file, then rename). */
csi_status csi_partial_store(const char *path, const csi_partial *p);

/* Reads and checks a partial: magic, version, checksum, sizes. with_data = false reads the
 * header only (tile.r.image/frames stay NULL) after checking the checksum over the whole file.
 * Errors are CSI_ERR_FORMAT / CSI_ERR_IO naming the path. */
csi_status csi_partial_load(const char *path, bool with_data, csi_partial *out);
void csi_partial_release(csi_partial *p);

/* NULL when a and b belong to the same run (same software, input, options, layout and scope);
 * otherwise what differs ("the input", "the reconstruction options", ...). */
const char *csi_partial_differs(const csi_partial *a, const csi_partial *b);

#endif
