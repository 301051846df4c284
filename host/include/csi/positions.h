/* Sample positions on the fine grid: Poisson-disk, stratified or uniform random; seeded.
 *
 * No OpenCL here: this lives in the base library so the tracer side can choose positions too.
 *
 * How many samples (N):
 *   - spp > 0 and fraction == 0: N = spp * out_w * out_h. `spp` is samples per output pixel
 *     over the whole pixel footprint: for grid_t > 1 that footprint is the pixel's block of the
 *     fine grid across all t (bw x bh x grid_t cells, bw = w/out_w, bh = h/out_h), so "1 spp"
 *     in 3-D is one sample per pixel in space-time, as in the paper's Sec. 6.
 *   - fraction > 0 (spp ignored): N = round(fraction * k), k = w*h*t, the paper's "sampling
 *     rate" (e.g. 0.1 for 10%). For STRATIFIED the per-pixel count is round(fraction * k /
 *     (out_w*out_h)) (at least 1) so every pixel gets the same number of strata.
 *   N must be 1..k.
 *
 * Methods:
 *   - CSI_POS_POISSON (default): dart throwing on the fine grid in a seeded pseudo-random order
 *     of all cells (a Feistel permutation, so each cell is tried once per pass), accepting a cell
 *     when every accepted sample is at least r away (Euclidean distance in fine-grid cells on
 *     every axis, x, y and t; not periodic). r starts at 0.7 * r_max, where r_max is the
 *     spacing of the densest packing of N points in the grid's area/volume (hexagonal in 2-D:
 *     r_max = sqrt(2 k / (sqrt(3) N)); FCC in 3-D: r_max = cbrt(sqrt(2) k / N)); 0.7 is below
 *     the ~0.75 that maximal dart throwing reaches (Lagae & Dutre 2008, "A comparison of
 *     methods for generating Poisson disk distributions"), so usually one pass reaches N. If a
 *     pass ends with fewer than N samples, r shrinks by 0.9 and a new pass adds samples (the
 *     earlier ones are still >= r apart). If r would fall to 1 or below, the rest are chosen
 *     uniformly among free cells and r = 1 (distinct cells are always >= 1 apart). The final r
 *     is reported: every pair of samples is at least that far apart. The distance test uses an
 *     occupancy bitmap and the list of integer offsets closer than r when there are at most 128
 *     of them (small radii, dense sampling), else a grid of buckets of side ceil(r).
 *   - CSI_POS_STRATIFIED: each output pixel's block (bw x bh x t cells) is split into spp
 *     strata, one uniformly chosen cell in each. The split is a x b x c (a along x, b along y,
 *     c along t; a*b*c = spp, a <= bw, b <= bh, c <= t) whose stratum extents (bw/a, bh/b, t/c)
 *     are closest to equal in the sense of the smallest sum of squared differences of their
 *     logarithms over all pairs (ties: smallest a, then smallest b). For a square spp = s^2 and a
 *     square 2-D block with s | bw this is s x s. Strata edges are floor(i * bw / a). If no such
 *     factorisation fits (say spp = 7 on a 4x4 block), the block's cells in (t, y, x) scan order
 *     are split into spp runs of floor(i * cells / spp) and info.strata is {0, 0, 0}.
 *   - CSI_POS_RANDOM: N distinct cells, every N-subset equally likely (selection sampling,
 *     Knuth TAOCP vol. 2, 3.4.2, Algorithm S).
 * The result is unique positions sorted by csi_grid_index, the same bits for the same inputs.
 * t = 0 always when grid_t = 1. */
#ifndef CSI_POSITIONS_H
#define CSI_POSITIONS_H

#include <stddef.h>
#include <stdint.h>

#include "csi/samples.h"
#include "csi/status.h" /* and csi/csi.h: the methods, their options, csi_positions and its host bytes */

#ifdef __cplusplus
extern "C" {
#endif

/* The pseudo-random generator used everywhere a seed is an option: xoshiro256** (Blackman &
 * Vigna, "Scrambled linear pseudorandom number generators", 2021), its 256-bit state filled
 * from the 64-bit seed by splitmix64 (Steele, Lea & Flood 2014), as the xoshiro authors advise. */
typedef struct csi_rng {
    uint64_t s[4];
} csi_rng;

void csi_rng_seed(csi_rng *r, uint64_t seed);
uint64_t csi_rng_next(csi_rng *r);
/* Uniform in [0, n) for n >= 1, unbiased (rejection of the top partial range). */
uint64_t csi_rng_below(csi_rng *r, uint64_t n);
/* Uniform in [0, 1) with 53 random bits. */
double csi_rng_uniform(csi_rng *r);
/* splitmix64's output function: a good 64-bit mix, used for hashing. */
uint64_t csi_mix64(uint64_t x);

#ifdef __cplusplus
}
#endif
#endif
