/* Analytic test images and their exact box averages, shared by the end-to-end quality tests.
 *
 * A GRID x GRID fine grid holds the image's value at each cell centre (what a renderer's point
 * samples see); the truth of each of the OUT x OUT output pixels is the box average of the
 * continuous image, by the midpoint rule with SS x SS points per fine cell, in double. Edge
 * pixels: pixels whose cells span a step larger than 0.15. */
#ifndef CSI_TEST_ANALYTIC_H
#define CSI_TEST_ANALYTIC_H

#include <stdbool.h>
#include <stddef.h>

#include "csi/csi.h"
#include "testlib.h"

#define GRID 256
#define OUT 64
#define BLK (GRID / OUT)
#define NP (OUT * OUT)
#define SS 8

typedef double (*analytic_fn)(double x, double y);

/* A slanted triangle, 1.0 on 0.1. */
double analytic_triangle(double x, double y);
/* Sinusoids, a rotated checker and a disc: texture with edges and smooth parts. */
double analytic_texture(double x, double y);

/* Both images by name, for the tests that run on each. */
typedef struct {
    const char *name;
    analytic_fn fn;
} analytic_image;
#define ANALYTIC_IMAGES 2
extern const analytic_image analytic_images[ANALYTIC_IMAGES];

typedef struct {
    float fine[GRID * GRID];
    double truth[NP];
    bool edge[NP];
    int nedge;
} analytic_scene;

void analytic_scene_make(analytic_fn fn, analytic_scene *s);

/* Sample values (malloc'd, n): the scene at the cells of pos times a noise factor of mean 1:
 * paths = 0, none; else the mean of `paths` unit exponentials (the distribution of a single
 * light path's weight in the simplest case), drawn from r. */
float *analytic_sample(const analytic_scene *s, const csi_sample_pos *pos, size_t n, int paths,
                       test_rng *r);

/* Positions on the scene's grid (GRID x GRID cells, OUT x OUT pixels) by `method` at `spp`
 * (csi_positions, seed `seed`) in *pos (malloc'd, *n of them) and their values as
 * analytic_sample's, the noise drawn from a generator seeded with `noise_seed`. NULL (nothing
 * allocated) if either fails. */
float *analytic_draw(const analytic_scene *s, csi_pos_method method, uint32_t spp, uint64_t seed,
                     uint64_t noise_seed, int paths, csi_sample_pos **pos, size_t *n);

/* A scene given per cell of a grid: its value at the cell's centre. */
typedef double (*analytic_cell_fn)(uint32_t x, uint32_t y);
/* Stratified positions on g at `spp` (csi_positions, seed `seed`) in *pos (malloc'd, *n of
 * them), and each one's value scene(x, y) times 1 + spread (u - 1/2), u uniform from csi_rng
 * seeded with `noise_seed`, drawn in sample order: a path tracer's multiplicative noise. NULL
 * (nothing allocated) if either fails. */
float *analytic_noisy_cells(const csi_grid *g, analytic_cell_fn scene, uint32_t spp, uint64_t seed,
                            uint64_t noise_seed, double spread, csi_sample_pos **pos, size_t *n);

#endif
