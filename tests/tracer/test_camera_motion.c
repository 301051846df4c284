/* Camera ray directions at the image corners and centre, against directions derived by hand
 * for a camera at the origin looking down +z with y up (right-handed: image right is -x);
 * motion interpolation at key times, midway, before the first and after the last key; moving
 * geometry in Embree where linear interpolation puts it.
 *
 * Tolerances: the camera and the keyed transforms are computed in double: 1e-12. Embree hits
 * are float: 1e-5 relative. */
#include "tracer_test_util.h"

static void check_dir(const csi_scene *sc, double u, double v, const double want[3],
                      const char *what)
{
    double o[3], d[3], w[3] = {want[0], want[1], want[2]};
    double l = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    csi_scene_camera_ray(sc, u, v, 0, o, d);
    double err = 0;
    for (int i = 0; i < 3; i++)
        err = fmax(err, fabs(d[i] - w[i] / l));
    CHECK(err < 1e-12, "%s: dir (%.12g %.12g %.12g), want (%.12g %.12g %.12g)", what, d[0],
          d[1], d[2], w[0] / l, w[1] / l, w[2] / l);
    CHECK(fabs(o[0]) + fabs(o[1]) + fabs(o[2]) < 1e-12, "%s: origin not at the camera", what);
}

static void test_camera(void)
{
    csi_scene *sc;
    /* fov 90 -> tan(45 deg) = 1; 200 x 100 -> aspect 2. Direction at (u, v) is
     * f + (2u - 1) * 2 * r + (1 - 2v) * up with f = +z, r = f x up = -x, up = +y. */
    CHECK_OK(csi_scene_parse("camera { position 0 0 0 target 0 0 7 up 0 1 0 fov 90 size 200 100 }",
                             "cam", NULL, &sc));
    if (!sc)
        return;
    double c[3] = {0, 0, 1}, tl[3] = {2, 1, 1}, tr[3] = {-2, 1, 1}, bl[3] = {2, -1, 1},
           br[3] = {-2, -1, 1}, mid[3] = {-1, 0.5, 1};
    check_dir(sc, 0.5, 0.5, c, "centre");
    check_dir(sc, 0, 0, tl, "top left");
    check_dir(sc, 1, 0, tr, "top right");
    check_dir(sc, 0, 1, bl, "bottom left");
    check_dir(sc, 1, 1, br, "bottom right");
    check_dir(sc, 0.75, 0.25, mid, "(0.75, 0.25)");
    csi_scene_free(sc);

    /* A moving camera: translate (0,0,0) -> (4,2,0) over keys at 1 and 3 of shutter [1, 3]. */
    CHECK_OK(csi_scene_parse("shutter 1 3\ncamera { position 1 0 0 target 1 0 5 motion { key 1 { "
                             "translate 0 0 0 } key 3 { translate 4 2 0 } } }",
                             "cam2", NULL, &sc));
    if (!sc)
        return;
    double s_list[3] = {0, 0.5, 1};
    for (int k = 0; k < 3; k++) {
        double o[3], d[3];
        csi_scene_camera_ray(sc, 0.5, 0.5, s_list[k], o, d);
        CHECK(fabs(o[0] - (1 + 4 * s_list[k])) < 1e-12 && fabs(o[1] - 2 * s_list[k]) < 1e-12 &&
                  fabs(o[2]) < 1e-12,
              "camera at s=%g: (%g %g %g)", s_list[k], o[0], o[1], o[2]);
        CHECK(fabs(d[2] - 1) < 1e-12, "camera direction at s=%g changed", s_list[k]);
    }
    csi_scene_free(sc);
}

static void test_object_motion(void)
{
    csi_scene *sc;
    /* shutter [0, 4]; keys at 1 and 3: translate (0,0,0) -> (2,4,-6), rotate 0 -> 400 degrees
     * about z (more than half a turn: kept, not folded), scale 1 -> 3. */
    CHECK_OK(csi_scene_parse(
        "shutter 0 4\ncamera { position 0 0 -10 target 0 0 0 }\nmaterial m { diffuse 1 1 1 }\n"
        "box { min -1 -1 -1 max 1 1 1 material m motion { key 1 { translate 0 0 0 } key 3 { "
        "translate 2 4 -6 rotate 0 0 1 400 scale 3 } } }",
        "mo", NULL, &sc));
    if (!sc)
        return;
    double p[3] = {1, 0, 0.5};
    struct {
        double s, f; /* shutter fraction, fraction between the keys */
    } cases[] = {{0, 0}, {0.25, 0}, {0.5, 0.5}, {0.625, 0.75}, {0.75, 1}, {1, 1}};
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; k++) {
        double f = cases[k].f, ang = f * 400 * M_PI / 180, sc3 = 1 + 2 * f;
        double want[3] = {sc3 * (cos(ang) * p[0] - sin(ang) * p[1]) + 2 * f,
                          sc3 * (sin(ang) * p[0] + cos(ang) * p[1]) + 4 * f,
                          sc3 * p[2] - 6 * f};
        double got[3];
        csi_scene_object_point(sc, 0, cases[k].s, p, got);
        double err = fabs(got[0] - want[0]) + fabs(got[1] - want[1]) + fabs(got[2] - want[2]);
        CHECK(err < 1e-12, "s=%g: (%g %g %g), want (%g %g %g)", cases[k].s, got[0], got[1],
              got[2], want[0], want[1], want[2]);
    }
    csi_scene_free(sc);
}

/* Embree's view of motion: a translating triangle mesh (steps on the key grid, so Embree's
 * linear interpolation is exact) and a translating sphere (exact at the ray time). */
static void test_embree_motion(void)
{
    tt_setup s;
    if (!tt_make(&s,
                 "camera { position 0 0 -10 target 0 0 0 }\nmaterial m { diffuse 1 1 1 }\n"
                 "shutter 0 1\n"
                 "plane { corner -1 -1 0 edge_u 2 0 0 edge_v 0 2 0 material m motion { key 0 { "
                 "translate 0 0 5 } key 0.5 { translate 0 0 7 } key 1 { translate 0 0 8 } } }\n"
                 "sphere { center 0 0 0 radius 0.5 material m motion { key 0 { translate 10 0 "
                 "0 } key 1 { translate 10 4 0 } } }\n",
                 1)) {
        tt_free(&s);
        return;
    }
    CHECK(s.pl.object_time_steps[0] == 3, "keys at 0, 0.5, 1 need 3 steps, got %u",
          s.pl.object_time_steps[0]);
    double o[3] = {0.1, 0.2, 0}, d[3] = {0, 0, 1};
    double times[5] = {0, 0.25, 0.5, 0.75, 1}, want[5] = {5, 6, 7, 7.5, 8};
    for (int k = 0; k < 5; k++) {
        csi_hit h;
        CHECK_OK(csi_tracer_intersect(s.tr, o, d, times[k], &h));
        CHECK(h.hit && fabs(h.distance - want[k]) < 1e-5 * want[k],
              "plane at s=%g: hit %d distance %g, want %g", times[k], h.hit, h.distance,
              want[k]);
    }
    /* sphere centre at (10, 4 s, 0): a ray along +z at (10, 4 s, -5) hits at t = 4.5 */
    for (int k = 0; k < 5; k++) {
        double os[3] = {10, 4 * times[k], -5};
        csi_hit h;
        CHECK_OK(csi_tracer_intersect(s.tr, os, d, times[k], &h));
        CHECK(h.hit && fabs(h.distance - 4.5) < 1e-5, "sphere at s=%g: hit %d distance %g",
              times[k], h.hit, h.distance);
        /* the same ray 0.6 above the centre misses at this time */
        double om[3] = {10, 4 * times[k] + 0.6, -5};
        CHECK_OK(csi_tracer_intersect(s.tr, om, d, times[k], &h));
        CHECK(!h.hit, "sphere at s=%g: the ray above it should miss", times[k]);
    }
    tt_free(&s);
}

int main(void)
{
    test_camera();
    test_object_motion();
    test_embree_motion();
    return test_done();
}
