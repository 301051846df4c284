/* Determinism: the same scene, positions and seed give bit-identical radiance with 1 thread
 * and with 2 threads (each sample's random numbers depend only on (seed, index)); a different
 * seed changes the noisy samples; the progress callback ends at done == total. The scene uses
 * everything random: an area light, ambient occlusion, path tracing with Russian roulette, and
 * a moving sphere (rays carry time). */
#include "tracer_test_util.h"

static const char *SCENE =
    "camera { position 0 1.5 -3 target 0 0.3 0 size 24 24 }\n"
    "shutter 0 1\n"
    "background 0.2 0.25 0.3\n"
    "ambient_occlusion { samples 2 distance 0.5 color 0.2 0.2 0.2 }\n"
    "path_tracing { max_bounces 5 roulette_start 1 }\n"
    "material floor { checker 0.8 0.8 0.8 0.2 0.2 0.2 0.25 }\n"
    "material ball { diffuse 0.7 0.3 0.2 }\n"
    "plane { corner -5 0 -5 edge_u 10 0 0 edge_v 0 0 10 material floor }\n"
    "box { min 0.4 0 0.2 max 0.9 0.6 0.7 material ball }\n"
    "sphere { center 0 0 0 radius 0.3 material ball motion { key 0 { translate -0.5 0.3 0 } key "
    "1 { translate 0.2 0.3 0 rotate 0 0 1 -130 } } }\n"
    "light area { corner -0.5 2 -0.5 edge_u 1 0 0 edge_v 0 0 1 radiance 4 4 4 samples 3 }\n";

static uint64_t last_done, last_total;
static int calls;
static void progress(uint64_t done, uint64_t total, void *user)
{
    (void)user;
    CHECK(done <= total, "progress %llu > %llu", (unsigned long long)done,
          (unsigned long long)total);
    CHECK(done >= last_done || calls == 0, "progress went backwards");
    last_done = done;
    last_total = total;
    calls++;
}

static float *render(unsigned threads, uint64_t seed, size_t *n_out, csi_tracer_counters *c)
{
    tt_setup s;
    if (!tt_make(&s, SCENE, threads)) {
        tt_free(&s);
        return NULL;
    }
    uint32_t w = 48, h = 48, T = s.pl.frames;
    size_t n = (size_t)w * h * 2;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *rgb = malloc(3 * n * sizeof *rgb);
    test_rng r;
    test_rng_seed(&r, 77);
    for (size_t i = 0; i < n; i++) {
        pos[i].x = (uint32_t)(test_rng_u64(&r) % w);
        pos[i].y = (uint32_t)(test_rng_u64(&r) % h);
        pos[i].t = (uint32_t)(test_rng_u64(&r) % T);
    }
    csi_grid g = {w, h, T, 24, 24};
    last_done = 0;
    calls = 0;
    CHECK_OK(csi_tracer_eval(s.tr, &g, pos, n, seed, rgb, progress, NULL));
    CHECK(calls > 0 && last_done == n && last_total == n, "progress ended at %llu of %llu",
          (unsigned long long)last_done, (unsigned long long)last_total);
    csi_tracer_counters_get(s.tr, c);
    free(pos);
    tt_free(&s);
    *n_out = n;
    return rgb;
}

int main(void)
{
    size_t n1, n2, n3;
    csi_tracer_counters c1, c2, c3;
    float *a = render(1, 1234, &n1, &c1);
    float *b = render(2, 1234, &n2, &c2);
    float *c = render(2, 999, &n3, &c3);
    if (!a || !b || !c)
        return test_done();
    CHECK(memcmp(a, b, 3 * n1 * sizeof(float)) == 0, "1 thread and 2 threads differ");
    CHECK(memcmp(&c1, &c2, sizeof c1) == 0, "counters differ between thread counts");
    size_t differ = 0, finite = 0;
    for (size_t i = 0; i < 3 * n1; i++) {
        differ += a[i] != c[i];
        finite += isfinite(a[i]) && a[i] >= 0;
    }
    CHECK(finite == 3 * n1, "%zu of %zu values finite and non-negative", finite, 3 * n1);
    /* noise from the area light, AO and bounces touches most samples */
    CHECK(differ > n1, "another seed changed only %zu values", differ);
    CHECK(c1.secondary_rays > 0 && c1.ao_rays > 0 && c1.shadow_rays > 0 && c1.timed_rays > 0,
          "expected every kind of ray");
    free(a);
    free(b);
    free(c);
    return test_done();
}
