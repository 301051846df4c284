/* Shared helpers for the tracer tests: parse a scene from text, make plan and tracer. */
#ifndef TRACER_TEST_UTIL_H
#define TRACER_TEST_UTIL_H

#include <stdlib.h>
#include <string.h>

#include "csi_tracer.h"
#include "testlib.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct tt_setup {
    csi_scene *sc;
    csi_plan pl;
    csi_tracer *tr;
} tt_setup;

/* Parses text (files relative to tests/tracer/data), plans and builds; false on failure (the
 * failure is counted and printed). */
static inline bool tt_make(tt_setup *s, const char *text, unsigned threads)
{
    memset(s, 0, sizeof *s);
    csi_status st = csi_scene_parse(text, "test.scene", CSI_SOURCE_DIR "/tests/tracer/data",
                                    &s->sc);
    CHECK(st == CSI_OK, "parse: %s", csi_last_error());
    if (st != CSI_OK)
        return false;
    st = csi_plan_make(s->sc, NULL, &s->pl);
    CHECK(st == CSI_OK, "plan: %s", csi_last_error());
    if (st != CSI_OK)
        return false;
    st = csi_tracer_create(s->sc, &s->pl, threads, &s->tr);
    CHECK(st == CSI_OK, "tracer: %s", csi_last_error());
    return st == CSI_OK;
}

static inline void tt_free(tt_setup *s)
{
    csi_tracer_free(s->tr);
    csi_plan_free(&s->pl);
    csi_scene_free(s->sc);
    memset(s, 0, sizeof *s);
}

/* Evaluates every cell of a w x h x t grid (row-major, t slowest); returns malloc'd rgb. */
static inline float *tt_eval_grid(tt_setup *s, uint32_t w, uint32_t h, uint32_t t, uint64_t seed,
                                  csi_sample_pos **pos_out)
{
    size_t n = (size_t)w * h * t;
    csi_sample_pos *pos = malloc(n * sizeof *pos);
    float *rgb = malloc(3 * n * sizeof *rgb);
    size_t i = 0;
    for (uint32_t k = 0; k < t; k++)
        for (uint32_t y = 0; y < h; y++)
            for (uint32_t x = 0; x < w; x++, i++) {
                pos[i].x = x;
                pos[i].y = y;
                pos[i].t = k;
            }
    csi_grid g = {w, h, t, w, h};
    csi_status st = csi_tracer_eval(s->tr, &g, pos, n, seed, rgb, NULL, NULL);
    CHECK(st == CSI_OK, "eval: %s", csi_last_error());
    if (pos_out)
        *pos_out = pos;
    else
        free(pos);
    return rgb;
}

#endif
