/* Analytic test images (see analytic.h). */
#include "analytic.h"

#include <math.h>
#include <stdlib.h>

#include "csi/positions.h"

double analytic_triangle(double x, double y)
{
    const double a[2] = {0.13, 0.21}, b[2] = {0.87, 0.36}, c[2] = {0.38, 0.91};
    double s1 = (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    double s2 = (c[0] - b[0]) * (y - b[1]) - (c[1] - b[1]) * (x - b[0]);
    double s3 = (a[0] - c[0]) * (y - c[1]) - (a[1] - c[1]) * (x - c[0]);
    bool in = (s1 >= 0 && s2 >= 0 && s3 >= 0) || (s1 <= 0 && s2 <= 0 && s3 <= 0);
    return in ? 1.0 : 0.1;
}

double analytic_texture(double x, double y)
{
    const double pi = 3.14159265358979323846;
    double u = 0.8 * x + 0.6 * y, v = -0.6 * x + 0.8 * y;
    double sines = 0.15 * sin(2 * pi * 5.0 * x) * cos(2 * pi * 3.0 * y) + 0.1 * sin(2 * pi * 11.0 * u);
    double checker = fmod(floor(u * 6.0) + floor(v * 6.0), 2.0);
    if (checker < 0)
        checker += 2.0;
    double disc = ((x - 0.6) * (x - 0.6) + (y - 0.4) * (y - 0.4) < 0.04) ? 0.2 : 0.0;
    return 0.2 + sines + 0.4 * checker + disc;
}

const analytic_image analytic_images[ANALYTIC_IMAGES] = {{"triangle", analytic_triangle},
                                                         {"texture", analytic_texture}};

void analytic_scene_make(analytic_fn fn, analytic_scene *s)
{
    for (int y = 0; y < GRID; y++)
        for (int x = 0; x < GRID; x++)
            s->fine[y * GRID + x] = (float)fn((x + 0.5) / GRID, (y + 0.5) / GRID);
    const int m = GRID * SS; /* supersampled points per side */
    for (int p = 0; p < NP; p++)
        s->truth[p] = 0;
    for (int j = 0; j < m; j++) {
        double y = (j + 0.5) / m;
        for (int i = 0; i < m; i++)
            s->truth[(j / (BLK * SS)) * OUT + i / (BLK * SS)] += fn((i + 0.5) / m, y);
    }
    const double per = (double)(BLK * SS) * (BLK * SS);
    s->nedge = 0;
    for (int p = 0; p < NP; p++) {
        s->truth[p] /= per;
        int ox = p % OUT, oy = p / OUT;
        float lo = INFINITY, hi = -INFINITY;
        for (int y = 0; y < BLK; y++)
            for (int x = 0; x < BLK; x++) {
                float v = s->fine[(oy * BLK + y) * GRID + ox * BLK + x];
                lo = fminf(lo, v);
                hi = fmaxf(hi, v);
            }
        s->edge[p] = hi - lo > 0.15f;
        s->nedge += s->edge[p];
    }
}

float *analytic_sample(const analytic_scene *s, const csi_sample_pos *pos, size_t n, int paths,
                       test_rng *r)
{
    float *v = malloc(n * sizeof *v);
    for (size_t i = 0; v && i < n; i++) {
        double f = 1.0;
        if (paths > 0) {
            f = 0;
            for (int k = 0; k < paths; k++)
                f -= log(1.0 - test_rng_uniform(r));
            f /= paths;
        }
        v[i] = (float)(s->fine[pos[i].y * GRID + pos[i].x] * f);
    }
    return v;
}

float *analytic_noisy_cells(const csi_grid *g, analytic_cell_fn scene, uint32_t spp, uint64_t seed,
                            uint64_t noise_seed, double spread, csi_sample_pos **pos, size_t *n)
{
    const csi_pos_opts po = {.method = CSI_POS_STRATIFIED, .spp = spp, .seed = seed};
    *pos = NULL;
    *n = 0;
    if (csi_positions(g, &po, pos, n, NULL) != CSI_OK)
        return NULL;
    float *v = malloc((*n ? *n : 1) * sizeof *v);
    if (!v) {
        free(*pos);
        *pos = NULL;
        return NULL;
    }
    csi_rng rng;
    csi_rng_seed(&rng, noise_seed);
    for (size_t i = 0; i < *n; i++)
        v[i] = (float)(scene((*pos)[i].x, (*pos)[i].y) * (1.0 + spread * (csi_rng_uniform(&rng) - 0.5)));
    return v;
}

float *analytic_draw(const analytic_scene *s, csi_pos_method method, uint32_t spp, uint64_t seed,
                     uint64_t noise_seed, int paths, csi_sample_pos **pos, size_t *n)
{
    const csi_grid g = {GRID, GRID, 1, OUT, OUT};
    const csi_pos_opts po = {.method = method, .spp = spp, .seed = seed};
    *pos = NULL;
    *n = 0;
    if (csi_positions(&g, &po, pos, n, NULL) != CSI_OK)
        return NULL;
    test_rng r;
    test_rng_seed(&r, noise_seed);
    float *v = analytic_sample(s, *pos, *n, paths, &r);
    if (!v) {
        free(*pos);
        *pos = NULL;
    }
    return v;
}
