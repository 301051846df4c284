/* The result handle behind csi/csi.h's csi_result (not installed): shared by the accessors
 * (reconstruct.c) and the outputs made from a result (result_outputs.c). */
#ifndef CSI_API_RESULT_H
#define CSI_API_RESULT_H

#include "internal.h"

struct csi_result {
    csi_recon_result r;
    csi_options options;  /* as used: the autos that apply resolved */
    csi_grid grid;
    const char *method;   /* static text */
    /* EXR attributes, made on the first csi_result_attributes: attrs points into one block
     * that also holds their names and texts. */
    csi_attr *attrs;
    size_t nattrs;
};

/* Makes r->attrs (csi_result_attributes) once the result is complete. */
csi_status csi_result_make_attributes(csi_result *r);

#endif
