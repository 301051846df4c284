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

#include "csi/csi.h" /* csi_sample_pos, csi_grid, csi_grid_index */

#ifdef __cplusplus
extern "C" {
#endif

/* The most frames (t cells) a grid may have across the shutter, in dumps, scenes (`frames`) and
 * every program's --time-steps. The plan's rule gives 8 to 64 (about one pixel of motion per
 * frame); 1024 leaves 16x that for overrides. Beyond it the time axis holds far fewer samples
 * than frames per pixel (4 spp over 1024 frames is one sample in 256 frames), and the motion
 * solve's time-axis transforms dominate its cost: a 4x4x4096 volume of 48 samples took 48 s
 * where 4x4x1024 took 2 s (both with the defaults, on this 2-core machine). */
#define CSI_GRID_MAX_FRAMES 1024u

#ifdef __cplusplus
}
#endif
#endif
