/* What a convex region's samples make certain of a pixel's cells.
 *
 * Why. Within a few pixels an emitter's corner, a strip light a few pixels tall or a lamp's disc
 * is a convex region on a dark ground (or, beside a bright region's inner corner, the dark side
 * is the convex one). No line divides such a window's samples, yet convexity alone bounds which
 * cells are which: the convex hull of the region's samples lies in the region, and a cell x lies
 * outside it wherever taking x in would bring one of the other side's samples inside the hull of
 * the region's samples and x (the region, convex, would then hold that sample). Both bounds hold
 * for any convex region through the samples; neither needs a fitted boundary. (The convex hull by
 * Andrew's monotone chain: A. M. Andrew, "Another efficient algorithm for convex hulls in two
 * dimensions", Information Processing Letters 9(5), 1979.)
 *
 * The second bound: a point d outside the hull H of the region's samples lies in the hull of H and
 * x exactly when x lies on a ray from d directed away from a point of H, i.e. when the direction
 * of x - d is opposite one of the directions from d to H, an angular interval under pi seen from
 * d, bounded by H's vertices. */
#ifndef CSI_CONVEX_BAND_H
#define CSI_CONVEX_BAND_H

#include <stdbool.h>
#include <stddef.h>

typedef struct csi_point2 {
    double x, y;
} csi_point2;

/* in: the region's samples (n_in, reordered in place), out: the others' (n_out). hull: room for
 * 2 n_in points (the monotone chain's stack at its longest); span: room for 3 n_out doubles. cells: n_cells points. Returns false where the
 * hull of `in` holds a point of `out` (no convex region through them: the caller's region is not
 * convex there), else true with *sure_in the cells inside that hull (on its edges too) and
 * *sure_out the cells that would bring a point of `out` inside the hull of `in` and the cell. */
bool csi_convex_band(csi_point2 *in, size_t n_in, const csi_point2 *out, size_t n_out, const csi_point2 *cells,
                     size_t n_cells, csi_point2 *hull, double *span, size_t *sure_in, size_t *sure_out);

#endif
