/* The samples of each row of output pixels (csi_recon_sample_rows in internal.h). */
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
