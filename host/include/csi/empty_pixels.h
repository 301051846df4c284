/* Pixels without a sample (or with one) next to an HDR step: the last step of a still image's
 * blend (csi_aa_correct CSI_CORRECT_BLEND in csi/reconstruct.h), on the whole result, all
 * channels at once. host/integrate/empty_pixels.c says why and how. */
#ifndef CSI_EMPTY_PIXELS_H
#define CSI_EMPTY_PIXELS_H

#include <stddef.h>
#include <stdint.h>

#include "csi/row_pool.h"
#include "csi/samples.h"
#include "csi/status.h"

/* image: a still image's result, out_w * out_h * channels, planar, in and out. Each pixel of g
 * that holds none of the n samples, whose 8 neighbours' means (by the channels' mean) span an
 * HDR step (a ratio of 4, fully from 16) and in which the image stands less than a fraction F of
 * the way from the darkest of them to the brightest (fully below F / 2), moves by that weight to
 * the lowest of its neighbours' means, channel by channel; no value is raised. F is a tenth
 * beside the edge of something extended, the whole step beside a bright side that stands alone
 * (a sub-pixel source, a thin line: empty_pixels.c says how the samples tell). Then, at such a
 * step, where the neighbours' arrangement puts the pixel on a line of the dark side (its row's
 * or column's two neighbours dark, the lines beside it uniform: a slat between bright gaps), it
 * moves by the step's weight to the mean of that line's two neighbours. Last, at a ratio from 16
 * (fully from 64), unless no two dark neighbours lie on opposite sides of it (a dark feature
 * through it) and its row and its column both have both neighbours bright, or one has
 * and the other's dark neighbour does not end a dark line running into the bright side (its own
 * neighbours along the first line within 4x of the brightest neighbour, and a dark sample among
 * the three pixels beyond it: empty_pixels.c), neither having both dark or unknown (a neighbour
 * without a sample stood in for by the pixel beyond it), it is capped at the step's geometric
 * midpoint, all channels scaled together. A pixel holding one sample is capped the same way, its
 * step from its own sample up to the brightest of its neighbours' means; no other pixel holding
 * a sample changes. g->t must be 1.
 * Used on the whole image, or in each tile's window in a tiled run (tiled.c). The passes run in
 * bands of rows on pool (NULL: on the calling thread), the same bits either way. */
csi_status csi_empty_pixels(const csi_grid *g, uint32_t channels, const csi_sample_pos *pos,
                            const float *values, size_t n, csi_row_pool *pool, float *image);

#endif
