/* The samples of each row of output pixels, and of each pixel (csi_recon_sample_rows and
 * csi_recon_pixel_samples in internal.h). */
#include <stdlib.h>

#include "internal.h"

void csi_recon_sample_rows(const csi_grid *g, const csi_sample_pos *pos, size_t n, size_t *start)
{
    const size_t oh = g->out_h;
    const uint32_t bh = g->h / g->out_h;
    start[0] = 0;
    for (size_t r = 1; r < oh; r++) {
        /* the first sample from start[r - 1] on whose row is r or more, if they are in order */
        size_t lo = start[r - 1], hi = n;
        while (lo < hi) {
            const size_t mid = lo + (hi - lo) / 2;
            if (pos[mid].y / bh < r)
                lo = mid + 1;
            else
                hi = mid;
        }
        start[r] = lo;
    }
    start[oh] = n;
}

csi_status csi_recon_pixel_samples(const csi_pixel_map *m, const csi_sample_pos *pos, size_t n, size_t np,
                                   size_t **start, size_t **idx)
{
    size_t *st = calloc(np + 1, sizeof *st), *fill = calloc(np ? np : 1, sizeof *fill);
    size_t *ix = malloc((n ? n : 1) * sizeof *ix);
    *start = *idx = NULL;
    if (!st || !fill || !ix) {
        free(st), free(fill), free(ix);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels' samples", np);
    }
    for (size_t i = 0; i < n; i++)
        st[csi_recon_pixel_at(m, pos[i]) + 1]++;
    for (size_t p = 0; p < np; p++)
        st[p + 1] += st[p];
    for (size_t i = 0; i < n; i++) {
        const size_t p = csi_recon_pixel_at(m, pos[i]);
        ix[st[p] + fill[p]++] = i;
    }
    free(fill);
    *start = st, *idx = ix;
    return CSI_OK;
}
