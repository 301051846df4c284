/* The result handle behind csi/csi.h's csi_result (not installed): shared by the accessors
 * (reconstruct.c) and the outputs made from a result (result_outputs.c). */
#ifndef CSI_API_RESULT_H
#define CSI_API_RESULT_H

#include "internal.h"
#include "csi/tiles.h"

struct csi_result {
    csi_recon_result r;
    csi_options options;  /* as used: the autos that apply resolved */
    csi_grid grid;
    const char *method;   /* static text */
    /* EXR attributes, made on the first csi_result_attributes: attrs points into one block
     * that also holds their names and texts. */
    csi_attr *attrs;
    size_t nattrs;
    /* A tile's result (csi_reconstruct_tile): its layout, the whole's scope and its place. */
    bool is_tile;
    csi_tiling tiling;
    csi_tile_scope scope;
    csi_tile_result tile; /* index and window origin; tile.r is unused (the pixels are in r) */
    csi_recon_options given; /* the options the tile was given (its partial holds them) */
    csi_recon_options reported; /* the options the one-process run of its layout reports
                                   (csi_recon_reported): a merge's, and its partial's */
};

/* The text csi_result_info gives as the method. */
const char *csi_result_method_of(const csi_recon_options *o, const csi_grid *g);
/* Fills r's options, grid, method and attributes from r->r: a result made by the library is
 * complete. Frees nothing on failure. */
csi_status csi_result_finish(csi_result *r, const csi_grid *g);

/* A new result whose image (and frames) a blend of tl's tiles fills (csi_tiles_begin); *out is
 * freed by the caller with csi_result_free, also on failure. */
csi_status csi_result_blend_begin(const csi_tiling *tl, uint32_t channels, bool frames, csi_blend *b,
                                  csi_result **out);

/* Makes r->attrs (csi_result_attributes) once the result is complete. */
csi_status csi_result_make_attributes(csi_result *r);

#endif
