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

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_sample_pos {
    uint32_t x, y, t;
} csi_sample_pos;

typedef struct csi_grid {
    uint32_t w, h, t;   /* fine grid: the paper's k = w * h * t */
    uint32_t out_w, out_h; /* final image; w % out_w == 0 and h % out_h == 0 */
} csi_grid;

/* Linear index of a position in a row-major (t, y, x) volume. */
static inline uint64_t csi_grid_index(const csi_grid *g, csi_sample_pos p)
{
    return ((uint64_t)p.t * g->h + p.y) * g->w + p.x;
}

#ifdef __cplusplus
}
#endif
#endif
