/* The bundled scenes (data/scenes): each loads, plans what its comment says it simulates, and
 * renders a sparse set of grid positions to finite, non-negative, non-constant radiance. The
 * counters agree with the plan (no time on static scenes, shadow rays only with lights,
 * texture lookups only with textures). Speed is measured elsewhere, not here. */
#include "tracer_test_util.h"

typedef struct expect {
    const char *name;
    bool motion, camera_moves, textures, checker, ao, path;
    size_t moving_objects;
    size_t lights;
} expect;

int main(void)
{
    const expect ex[] = {
        {"triangle", false, false, false, false, false, false, 0, 0},
        {"checkerboard", false, false, false, true, false, false, 0, 1},
        {"billiards", true, false, true, false, false, true, 2, 1},
        {"train", true, true, true, true, false, false, 0, 1},
        {"garden", false, false, true, false, true, false, 0, 1},
    };
    for (size_t k = 0; k < sizeof ex / sizeof ex[0]; k++) {
        const expect *e = &ex[k];
        char path[1024];
        snprintf(path, sizeof path, CSI_SOURCE_DIR "/data/scenes/%s.scene", e->name);
        csi_scene *sc;
        csi_status st = csi_scene_load(path, &sc);
        CHECK(st == CSI_OK, "%s: %s", e->name, csi_last_error());
        if (st != CSI_OK)
            continue;
        csi_plan pl;
        CHECK_OK(csi_plan_make(sc, NULL, &pl));
        CHECK(pl.motion == e->motion && pl.camera_moves == e->camera_moves &&
                  pl.n_moving_objects == e->moving_objects,
              "%s: motion %d camera %d moving objects %zu", e->name, pl.motion, pl.camera_moves,
              pl.n_moving_objects);
        CHECK((pl.frames > 1) == e->motion, "%s: frames %u", e->name, pl.frames);
        /* the train's camera translates sideways, across its view */
        CHECK(pl.camera_pans == !strcmp(e->name, "train"), "%s: camera_pans %d", e->name, pl.camera_pans);
        CHECK(pl.image_textures == e->textures && pl.checker_textures == e->checker &&
                  pl.ambient_occlusion == e->ao && pl.path_tracing == e->path,
              "%s: effects differ from the scene's description", e->name);
        CHECK(pl.n_point_lights + pl.n_directional_lights + pl.n_area_lights == e->lights,
              "%s: lights", e->name);
        csi_tracer *tr;
        CHECK_OK(csi_tracer_create(sc, &pl, 2, &tr));
        if (!tr) {
            csi_plan_free(&pl);
            csi_scene_free(sc);
            continue;
        }
        csi_tracer_info info;
        csi_tracer_info_get(tr, &info);
        CHECK(info.motion_geometries == e->moving_objects, "%s: %u motion geometries",
              e->name, info.motion_geometries);
        /* 48 x 48 positions spread over the 256 x 256 (x T) grid */
        enum { M = 48 };
        csi_sample_pos *pos = malloc(M * M * sizeof *pos);
        float *rgb = malloc(3 * M * M * sizeof *rgb);
        for (uint32_t y = 0; y < M; y++)
            for (uint32_t x = 0; x < M; x++) {
                csi_sample_pos *p = &pos[y * M + x];
                p->x = x * pl.width / M;
                p->y = y * pl.height / M;
                p->t = (x + 7 * y) % pl.frames;
            }
        csi_grid g = {pl.width, pl.height, pl.frames, pl.width, pl.height};
        CHECK_OK(csi_tracer_eval(tr, &g, pos, M * M, 42, rgb, NULL, NULL));
        size_t bad = 0;
        float lo = INFINITY, hi = -INFINITY;
        for (size_t i = 0; i < 3 * M * M; i++) {
            bad += !(isfinite(rgb[i]) && rgb[i] >= 0);
            lo = fminf(lo, rgb[i]);
            hi = fmaxf(hi, rgb[i]);
        }
        CHECK(bad == 0, "%s: %zu bad values", e->name, bad);
        CHECK(hi > lo + 0.05f, "%s: flat image [%g, %g]", e->name, lo, hi);
        csi_tracer_counters c;
        csi_tracer_counters_get(tr, &c);
        CHECK((c.timed_rays > 0) == e->motion, "%s: %llu timed rays", e->name,
              (unsigned long long)c.timed_rays);
        CHECK((c.shadow_rays > 0) == (e->lights > 0), "%s: %llu shadow rays", e->name,
              (unsigned long long)c.shadow_rays);
        CHECK((c.texture_lookups > 0) == e->textures && (c.checker_lookups > 0) == e->checker,
              "%s: lookups %llu %llu", e->name, (unsigned long long)c.texture_lookups,
              (unsigned long long)c.checker_lookups);
        CHECK((c.ao_rays > 0) == e->ao && (c.secondary_rays > 0) == e->path,
              "%s: AO %llu bounce %llu", e->name, (unsigned long long)c.ao_rays,
              (unsigned long long)c.secondary_rays);
        free(pos);
        free(rgb);
        csi_tracer_free(tr);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
    return test_done();
}
