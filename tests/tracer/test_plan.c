/* The plan simulates only what the scene declares, and the counters prove it:
 * static scene -> T = 1, no motion geometry, zero time-carrying rays; one moving object among
 * static ones -> T > 1, exactly one motion geometry, every ray carries time; keys that do not
 * move -> static; no lights -> zero shadow rays; lights -> shadow rays counted exactly; no
 * texture -> zero lookups; image texture -> one lookup per hit; AO / path tracing rays only
 * when declared; frames rule and override; the JSON names these decisions. */
#include <png.h>

#include "tracer_test_util.h"

#define CAM "camera { position 0 2 -6 target 0 0 0 size 32 32 }\n"

static void test_static(void)
{
    tt_setup s;
    if (!tt_make(&s, CAM "material m { diffuse 0.5 0.5 0.5 }\n"
                         "plane { corner -10 0 -10 edge_u 20 0 0 edge_v 0 0 20 material m }\n"
                         "sphere { center 0 1 0 radius 1 material m motion { key 0.2 { "
                         "translate 1 0 0 } key 0.8 { translate 1 0 0 } } }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    CHECK(s.pl.frames == 1 && !s.pl.motion, "static: frames %u motion %d", s.pl.frames,
          s.pl.motion);
    CHECK(s.pl.n_moving_objects == 0, "identical keys must not count as motion");
    csi_tracer_info info;
    csi_tracer_info_get(s.tr, &info);
    CHECK(info.geometries == 2 && info.motion_geometries == 0, "geometries %u motion %u",
          info.geometries, info.motion_geometries);
    float *rgb = tt_eval_grid(&s, 32, 32, 1, 1, NULL);
    csi_tracer_counters c;
    csi_tracer_counters_get(s.tr, &c);
    CHECK(c.samples == 1024 && c.primary_rays == 1024, "samples %llu primary %llu",
          (unsigned long long)c.samples, (unsigned long long)c.primary_rays);
    CHECK(c.timed_rays == 0, "static scene cast %llu time-carrying rays",
          (unsigned long long)c.timed_rays);
    CHECK(c.shadow_rays == 0, "no lights but %llu shadow rays", (unsigned long long)c.shadow_rays);
    CHECK(c.texture_lookups == 0 && c.checker_lookups == 0, "no textures but lookups");
    CHECK(c.ao_rays == 0 && c.secondary_rays == 0, "AO/path rays without being declared");
    /* no lights, no emission: the diffuse scene is black where hit */
    float mx = 0;
    for (size_t i = 0; i < 3 * 1024; i++)
        mx = fmaxf(mx, rgb[i]);
    CHECK(mx == 0, "unlit scene should be black, max %g", mx);
    char *js;
    CHECK_OK(csi_plan_json_string(s.sc, &s.pl, &js));
    if (js) {
        CHECK(strstr(js, "\"frames\": 1,") && strstr(js, "\"motion\": false") &&
                  strstr(js, "\"2d-antialias\"") && strstr(js, "\"shadow_rays_per_hit\": 0"),
              "plan JSON: %s", js);
        free(js);
    }
    free(rgb);
    tt_free(&s);
}

static void test_moving(void)
{
    tt_setup s;
    if (!tt_make(&s, CAM "shutter 0 1\nmaterial m { diffuse 0.5 0.5 0.5 }\n"
                         "light point { position 0 5 0 intensity 10 10 10 }\n"
                         "plane { corner -10 0 -10 edge_u 20 0 0 edge_v 0 0 20 material m }\n"
                         "box { min -3 0 2 max -2 1 3 material m }\n"
                         "sphere { center 0 0 0 radius 0.5 material m motion { key 0 { "
                         "translate -1 0.5 0 } key 1 { translate 1 0.5 0 } } }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    CHECK(s.pl.motion && s.pl.frames > 1, "moving: frames %u", s.pl.frames);
    CHECK(s.pl.object_time_steps[0] == 1 && s.pl.object_time_steps[1] == 1 &&
              s.pl.object_time_steps[2] == 2,
          "time steps %u %u %u", s.pl.object_time_steps[0], s.pl.object_time_steps[1],
          s.pl.object_time_steps[2]);
    csi_tracer_info info;
    csi_tracer_info_get(s.tr, &info);
    CHECK(info.motion_geometries == 1, "motion geometries %u, want 1", info.motion_geometries);
    float *rgb = tt_eval_grid(&s, 32, 32, s.pl.frames, 3, NULL);
    csi_tracer_counters c;
    csi_tracer_counters_get(s.tr, &c);
    uint64_t rays = c.primary_rays + c.secondary_rays + c.shadow_rays + c.ao_rays;
    CHECK(c.timed_rays == rays && rays > 0, "timed %llu of %llu rays",
          (unsigned long long)c.timed_rays, (unsigned long long)rays);
    CHECK(c.shadow_rays > 0 && c.shadow_rays <= c.primary_rays, "shadow rays %llu",
          (unsigned long long)c.shadow_rays);
    /* grid/plan mismatch is refused */
    csi_grid g = {32, 32, 1, 32, 32};
    csi_sample_pos p = {0, 0, 0};
    float out[3];
    CHECK(csi_tracer_eval(s.tr, &g, &p, 1, 0, out, NULL, NULL) == CSI_ERR_ARG,
          "T = 1 grid accepted for a moving plan");
    free(rgb);
    tt_free(&s);

    /* frames: rule gives a power of two in [8, 64]; the scene's `frames` and an override win */
    csi_scene *sc;
    CHECK_OK(csi_scene_parse(CAM "frames 12\nmaterial m { diffuse 1 1 1 }\nsphere { center 0 0 0 "
                                 "radius 1 material m motion { key 0 { translate 0 0 0 } key 1 { "
                                 "translate 0.001 0 0 } } }\n",
                             "f", NULL, &sc));
    if (sc) {
        csi_plan pl;
        CHECK_OK(csi_plan_make(sc, NULL, &pl));
        CHECK(pl.frames == 12, "scene frames: %u", pl.frames);
        csi_plan_free(&pl);
        csi_plan_overrides ov = {.frames = 5};
        CHECK_OK(csi_plan_make(sc, &ov, &pl));
        CHECK(pl.frames == 5, "override frames: %u", pl.frames);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
    /* a whole turn between keys is motion (the end poses coincide, the path does not) */
    CHECK_OK(csi_scene_parse(CAM "material m { diffuse 1 1 1 }\nbox { min 0 0 0 max 1 1 1 "
                                 "material m motion { key 0 { } key 1 { rotate 0 1 0 360 } } }\n",
                             "spin", NULL, &sc));
    if (sc) {
        csi_plan pl;
        CHECK_OK(csi_plan_make(sc, NULL, &pl));
        CHECK(pl.motion && pl.n_moving_objects == 1 && pl.object_time_steps[0] == 73,
              "full turn: motion %d, %u steps (want 360/5 + 1 = 73)", pl.motion,
              pl.object_time_steps[0]);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
    CHECK_OK(csi_scene_parse(CAM "material m { diffuse 1 1 1 }\nsphere { center 0 0 0 radius 1 "
                                 "material m motion { key 0 { translate 0 0 0 } key 1 { "
                                 "translate 0.001 0 0 } } }\n",
                             "f", NULL, &sc));
    if (sc) {
        csi_plan pl;
        CHECK_OK(csi_plan_make(sc, NULL, &pl));
        CHECK(pl.frames == 8 && pl.motion_pixels < 1, "tiny motion: frames %u (%g px)",
              pl.frames, pl.motion_pixels);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
}

/* Shadow rays: a point light above a plane that fills the view: exactly one per hit. */
static void test_lights_textures(void)
{
    /* a 2 x 2 PNG: texel values 0, 64, 128, 255 in red */
    const char *png_path = CSI_BINARY_DIR "/test_plan_tex.png";
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = 2;
    img.height = 2;
    img.format = PNG_FORMAT_RGB;
    unsigned char px[12] = {0, 0, 0, 64, 0, 0, 128, 0, 0, 255, 0, 0};
    CHECK(png_image_write_to_file(&img, png_path, 0, px, 0, NULL), "cannot write %s", png_path);
    char text[2048];
    snprintf(text, sizeof text,
             "camera { position 0 1 0 target 0 0 0.001 size 16 16 fov 60 }\n"
             "material t { texture \"%s\" }\n"
             "light point { position 0 3 0 intensity 1 1 1 }\n"
             "light directional { direction 0 -1 0 irradiance 1 1 1 }\n"
             "light area { corner -1 4 -1 edge_u 2 0 0 edge_v 0 0 2 radiance 1 1 1 samples 5 }\n"
             "plane { corner -50 0 -50 edge_u 100 0 0 edge_v 0 0 100 material t }\n",
             png_path);
    tt_setup s;
    if (!tt_make(&s, text, 2)) {
        tt_free(&s);
        return;
    }
    CHECK(s.pl.shadow_rays_per_hit == 7 && s.pl.image_textures && !s.pl.checker_textures,
          "plan: %u shadow rays per hit", s.pl.shadow_rays_per_hit);
    float *rgb = tt_eval_grid(&s, 16, 16, 1, 9, NULL);
    csi_tracer_counters c;
    csi_tracer_counters_get(s.tr, &c);
    /* every primary ray hits the plane and every light is above it: 1 + 1 + 5 shadow rays */
    CHECK(c.shadow_rays == 7 * 256, "shadow rays %llu, want %d", (unsigned long long)c.shadow_rays,
          7 * 256);
    CHECK(c.texture_lookups == 256 && c.checker_lookups == 0, "texture lookups %llu",
          (unsigned long long)c.texture_lookups);
    free(rgb);
    tt_free(&s);

    /* AO and path tracing rays appear only when declared, in the declared numbers */
    if (!tt_make(&s, "camera { position 0 1 0 target 0 0 0.001 size 8 8 fov 60 }\n"
                     "material m { checker 1 1 1 0 0 0 1 }\n"
                     "ambient_occlusion { samples 3 distance 0.5 }\n"
                     "plane { corner -50 0 -50 edge_u 100 0 0 edge_v 0 0 100 material m }\n",
                 1)) {
        tt_free(&s);
        return;
    }
    rgb = tt_eval_grid(&s, 8, 8, 1, 9, NULL);
    csi_tracer_counters_get(s.tr, &c);
    CHECK(c.ao_rays == 3 * 64 && c.shadow_rays == 0 && c.secondary_rays == 0 &&
              c.checker_lookups == 64 && c.texture_lookups == 0,
          "AO rays %llu checker %llu", (unsigned long long)c.ao_rays,
          (unsigned long long)c.checker_lookups);
    free(rgb);
    tt_free(&s);
}

int main(void)
{
    test_static();
    test_moving();
    test_lights_textures();
    return test_done();
}
