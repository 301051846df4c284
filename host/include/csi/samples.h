/* Sample positions: the one type the tracer shares with the library.
 *
 * Samples lie on the fine grid of the signal f (the paper's Sec. 4): a position is the index
 * (x, y, t) of a grid cell, x < grid_w, y < grid_h, t < grid_t (t = 0 when grid_t = 1). The
 * continuous point a sample stands for is the cell's centre: ((x + 0.5) / grid_w,
 * (y + 0.5) / grid_h) in image space (y down), and time (t + 0.5) / grid_t of the shutter
 * interval (or the shutter open time when grid_t = 1 and nothing moves). */
#ifndef CSI_SAMPLES_H
#define CSI_SAMPLES_H

#include <stdint.h>

#include "csi/csi.h" /* csi_sample_pos, csi_grid, csi_grid_index, CSI_GRID_MAX_FRAMES */

#endif
