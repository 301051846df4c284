/* Times the tracer on scenes: 256 x 256 images at 4 samples per pixel (262144 uniformly random
 * positions on a 512 x 512 x T fine grid, seed 1), with 1 and 2 threads; prints one JSON line
 * per run with the counters. Built as build/csi-tracer-time-scenes (tools/bench/tracer_*.c):
 *   build/csi-tracer-time-scenes data/scenes/triangle.scene data/scenes/garden.scene ... */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "csi_tracer.h"

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static uint64_t mix(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

int main(int argc, char **argv)
{
    for (int a = 1; a < argc; a++) {
        csi_scene *sc;
        csi_plan pl;
        if (csi_scene_load(argv[a], &sc) != CSI_OK || csi_plan_make(sc, NULL, &pl) != CSI_OK) {
            fprintf(stderr, "%s\n", csi_last_error());
            return 2;
        }
        const uint32_t W = 256, H = 256, K = 2;
        csi_grid g = {W * K, H * K, pl.frames, W, H};
        size_t n = (size_t)W * H * 4;
        csi_sample_pos *pos = malloc(n * sizeof *pos);
        float *rgb = malloc(3 * n * sizeof *rgb);
        uint64_t s = 1;
        for (size_t i = 0; i < n; i++) {
            pos[i].x = (uint32_t)(mix(&s) % g.w);
            pos[i].y = (uint32_t)(mix(&s) % g.h);
            pos[i].t = (uint32_t)(mix(&s) % g.t);
        }
        for (unsigned th = 1; th <= 2; th++) {
            csi_tracer *tr;
            double t0 = now();
            if (csi_tracer_create(sc, &pl, th, &tr) != CSI_OK) {
                fprintf(stderr, "%s\n", csi_last_error());
                return 2;
            }
            double t1 = now();
            if (csi_tracer_eval(tr, &g, pos, n, 1, rgb, NULL, NULL) != CSI_OK) {
                fprintf(stderr, "%s\n", csi_last_error());
                return 2;
            }
            double t2 = now();
            csi_tracer_counters c;
            csi_tracer_counters_get(tr, &c);
            uint64_t rays = c.primary_rays + c.secondary_rays + c.shadow_rays + c.ao_rays;
            printf("{\"scene\": \"%s\", \"threads\": %u, \"frames\": %u, \"samples\": %zu, "
                   "\"build_s\": %.3f, \"eval_s\": %.3f, \"us_per_sample\": %.3f, "
                   "\"rays_per_sample\": %.2f, \"shadow_rays\": %llu, \"ao_rays\": %llu, "
                   "\"bounce_rays\": %llu, \"timed_rays\": %llu, \"texture_lookups\": %llu}\n",
                   argv[a], th, pl.frames, n, t1 - t0, t2 - t1, 1e6 * (t2 - t1) / n,
                   (double)rays / n, (unsigned long long)c.shadow_rays,
                   (unsigned long long)c.ao_rays, (unsigned long long)c.secondary_rays,
                   (unsigned long long)c.timed_rays, (unsigned long long)c.texture_lookups);
            csi_tracer_free(tr);
        }
        free(pos);
        free(rgb);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
    return 0;
}
