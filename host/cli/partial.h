/* Tile partials: one tile's reconstruction written by `--tile I/N`, and read back by csi-merge,
 * which blends the partials of one run into the final image (format: docs/tiles.md).
 *
 * A partial carries what decides its pixels, so that the merge can refuse partials of different
 * runs: the software version, the input's identity (a hash of the dump's samples, or of the
 * scene file and the sampling options), the reconstruction options, the tile layout and the
 * whole problem's scope; then the tile's window image (and frames), its solver reports, and a
 * checksum over everything before it. */
#ifndef CSI_CLI_PARTIAL_H
#define CSI_CLI_PARTIAL_H

#include <stdint.h>

#include "csi/reconstruct.h"
#include "csi/tiles.h"

#define CLI_PARTIAL_MAGIC "CSIP"
#define CLI_PARTIAL_VERSION 1u

typedef struct cli_partial {
    char software[32];   /* "csi 0.1.0" */
    char method[96];     /* the EXR's csi:method */
    char input[128];     /* the input's file name (for messages) */
    uint64_t input_id;   /* content hash of the input (cli_hash64) */
    csi_recon_options options; /* progress/user NULL */
    csi_tiling tiling;
    csi_tile_scope scope;
    csi_tile_result tile;
} cli_partial;

/* A 64-bit content hash, chained: h = cli_hash64(h, data, bytes), starting from any constant.
 * Reads the data as little-endian 64-bit words, so the same bytes hash the same everywhere. */
uint64_t cli_hash64(uint64_t h, const void *data, size_t bytes);

/* Writes p (temporary file, then rename). */
csi_status cli_partial_write(const char *path, const cli_partial *p);

/* Reads and checks a partial: magic, version, checksum, sizes. with_data = false reads the
 * header only (tile.r.image/frames stay NULL) after checking the checksum over the whole file.
 * Errors are CSI_ERR_FORMAT / CSI_ERR_IO naming the path. */
csi_status cli_partial_read(const char *path, bool with_data, cli_partial *out);
void cli_partial_free(cli_partial *p);

/* NULL when a and b belong to the same run (same software, input, options, layout and scope);
 * otherwise what differs ("the input", "the options", ...). */
const char *cli_partial_mismatch(const cli_partial *a, const cli_partial *b);

#endif
