/* Radiance against closed forms.
 *  - Lambertian plane under a point light: L = rho/pi * I cos(theta) / r^2.
 *  - Directional light: L = rho/pi * E cos(theta).
 *  - Quad area light above a point under its corner: irradiance E = pi L F with the form factor
 *    of a parallel rectangle seen from below a corner (Howell, "A catalog of radiation heat
 *    transfer configuration factors", B-3):
 *    F = 1/(2 pi) [a/sqrt(a^2+c^2) atan(b/sqrt(a^2+c^2)) + b/sqrt(b^2+c^2) atan(a/sqrt(b^2+c^2))]
 *  - Ambient occlusion of an open plane: L = rho * ambient exactly (nothing blocks).
 *  - Furnace: a camera inside a closed emissive sphere (emission Le, albedo rho): every path
 *    of k bounces returns Le sum_{j<=k} rho^j exactly; with Russian roulette the mean does.
 *  - Triangle coverage: each grid sample of the `triangle` scene is 1 exactly where its cell
 *    centre projects inside the triangle (independent projection and edge tests in double).
 *  - Image texture at texel centres returns the sRGB-decoded texel (IEC 61966-2-1).
 * Tolerances are given at each check. */
#include <png.h>

#include "tracer_test_util.h"

/* Image position (u, v) of world point p for a camera looking along +z from o with up +y
 * (image right is -x): the inverse of the pinhole model. */
static void project_z(const double o[3], double th, double aspect, const double p[3], double *u,
                      double *v)
{
    double d[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    double px = -d[0] / d[2] / th, py = d[1] / d[2] / th;
    *u = (px / aspect + 1) / 2;
    *v = (1 - py) / 2;
}

static void test_point_directional(void)
{
    /* plane z = 0 facing a camera at z = -4; point light at (0.3, -0.2, -1.5) with I = 2; a
     * directional light of irradiance 1.5 along (0.2, 0.1, 1) */
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 0 -4 target 0 0 0 fov 60 size 64 64 }\n"
                     "material m { diffuse 0.6 0.4 0.2 }\n"
                     "plane { corner -10 -10 0 edge_u 20 0 0 edge_v 0 20 0 material m }\n"
                     "light point { position 0.3 -0.2 -1.5 intensity 2 2 2 }\n"
                     "light directional { direction 0.2 0.1 1 irradiance 1.5 1.5 1.5 }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    enum { N = 25 };
    float uvs[3 * N], rgb[3 * N];
    double pts[N][3];
    double o[3] = {0, 0, -4}, th = tan(M_PI / 6);
    for (int i = 0; i < N; i++) {
        pts[i][0] = -1.5 + 0.75 * (i % 5);
        pts[i][1] = -1.5 + 0.75 * (i / 5);
        pts[i][2] = 0;
        double u, v;
        project_z(o, th, 1, pts[i], &u, &v);
        uvs[3 * i] = (float)u;
        uvs[3 * i + 1] = (float)v;
        uvs[3 * i + 2] = 0;
    }
    CHECK_OK(csi_tracer_eval_points(s.tr, uvs, N, 5, rgb, NULL, NULL));
    double rho[3] = {0.6, 0.4, 0.2}, dl[3] = {0.2, 0.1, 1};
    double dn = sqrt(dl[0] * dl[0] + dl[1] * dl[1] + dl[2] * dl[2]);
    for (int i = 0; i < N; i++) {
        /* the hit point is where the float (u, v) ray meets the plane: recompute it */
        double ro[3], rd[3];
        csi_scene_camera_ray(s.sc, uvs[3 * i], uvs[3 * i + 1], 0, ro, rd);
        double t = -ro[2] / rd[2], p[3] = {ro[0] + t * rd[0], ro[1] + t * rd[1], 0};
        double L[3] = {0.3 - p[0], -0.2 - p[1], -1.5};
        double r2 = L[0] * L[0] + L[1] * L[1] + L[2] * L[2];
        double cosp = 1.5 / sqrt(r2);                      /* normal is -z (faces the light) */
        double cosd = dl[2] / dn;                          /* -dir . (-z) */
        double E = 2 * cosp / r2 + 1.5 * cosd;
        for (int c = 0; c < 3; c++) {
            double want = rho[c] / M_PI * E;
            /* float hit point (1e-7 relative) and float output: 1e-5 relative */
            CHECK(fabs(rgb[3 * i + c] - want) <= 1e-5 * want, "point %d channel %d: %.8g want %.8g",
                  i, c, rgb[3 * i + c], want);
        }
    }
    tt_free(&s);
}

static void test_area_light(void)
{
    /* a 1 x 2 light at height 1.5 above the origin's corner, radiance 3, facing down; the
     * receiving point is the origin on a plane y = 0 seen from above */
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 3 0.001 target 0 0 0 fov 30 size 64 64 }\n"
                     "material m { diffuse 1 1 1 }\n"
                     "plane { corner -10 0 -10 edge_u 20 0 0 edge_v 0 0 20 material m }\n"
                     "light area { corner 0 1.5 0 edge_u 1 0 0 edge_v 0 0 2 radiance 3 3 3 "
                     "samples 64 }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    enum { N = 1024 };
    float *uvs = malloc(3 * N * sizeof(float)), *rgb = malloc(3 * N * sizeof(float));
    for (int i = 0; i < N; i++) {
        uvs[3 * i] = 0.5f;
        uvs[3 * i + 1] = 0.5f;
        uvs[3 * i + 2] = 0;
    }
    CHECK_OK(csi_tracer_eval_points(s.tr, uvs, N, 8, rgb, NULL, NULL));
    double mean = 0, m2 = 0;
    for (int i = 0; i < N; i++) {
        mean += rgb[3 * i];
        m2 += (double)rgb[3 * i] * rgb[3 * i];
    }
    mean /= N;
    double sd = sqrt(fmax(0, m2 / N - mean * mean) / N);
    double a = 1, b = 2, c = 1.5;
    double sa = sqrt(a * a + c * c), sb = sqrt(b * b + c * c);
    double F = (a / sa * atan(b / sa) + b / sb * atan(a / sb)) / (2 * M_PI);
    double want = 3 * F; /* L = rho/pi * E = E/pi = L_light F */
    /* 65536 light samples in all: the mean is within 4 standard errors (plus float noise) */
    CHECK(fabs(mean - want) <= 4 * sd + 1e-6, "area light: mean %.6f want %.6f (se %.2g)", mean,
          want, sd);
    CHECK(sd > 0 && sd < 0.01 * want, "area light standard error %g", sd);
    free(uvs);
    free(rgb);
    tt_free(&s);
}

static void test_ao(void)
{
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 3 0.001 target 0 0 0 fov 30 size 16 16 }\n"
                     "material m { diffuse 0.5 0.25 1 }\n"
                     "ambient_occlusion { samples 8 distance 2 color 0.4 0.8 1 }\n"
                     "plane { corner -10 0 -10 edge_u 20 0 0 edge_v 0 0 20 material m }\n",
                 1)) {
        tt_free(&s);
        return;
    }
    float *rgb = tt_eval_grid(&s, 16, 16, 1, 3, NULL);
    double want[3] = {0.5 * 0.4, 0.25 * 0.8, 1};
    double err = 0;
    for (int i = 0; i < 256; i++)
        for (int c = 0; c < 3; c++)
            err = fmax(err, fabs(rgb[3 * i + c] - want[c]));
    CHECK(err < 1e-6, "open-plane AO: max error %g", err); /* float products */
    free(rgb);
    tt_free(&s);
    /* a wall right next to the point blocks part of the hemisphere: 0 < AO < 1 */
}

static void test_furnace(void)
{
    const double rho = 0.6, Le = 0.5;
    for (int rr = 0; rr < 2; rr++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "camera { position 0 0 0 target 0 0 1 size 16 16 }\n"
                 "material m { diffuse %g %g %g emission %g %g %g }\n"
                 "path_tracing { max_bounces 4 roulette_start %d }\n"
                 "sphere { center 0 0 0 radius 3 material m }\n",
                 rho, rho, rho, Le, Le, Le, rr ? 0 : 4);
        tt_setup s;
        if (!tt_make(&s, text, 2)) {
            tt_free(&s);
            return;
        }
        float *rgb = tt_eval_grid(&s, 64, 64, 1, 21, NULL);
        double want = Le * (1 - pow(rho, 5)) / (1 - rho), mean = 0, err = 0;
        for (int i = 0; i < 64 * 64; i++) {
            mean += rgb[3 * i];
            err = fmax(err, fabs(rgb[3 * i] - want));
        }
        mean /= 64 * 64;
        if (!rr) {
            CHECK(err < 1e-6, "furnace without roulette: max error %g", err); /* float sums */
        } else {
            /* each sample is want-ish with roulette weights 1/q: its spread is below Le * 5 /
             * 0.6^4, so the standard error of 4096 samples is below 0.05; use the observed one */
            double m2 = 0;
            for (int i = 0; i < 64 * 64; i++)
                m2 += (rgb[3 * i] - mean) * (rgb[3 * i] - mean);
            double se = sqrt(m2 / (64 * 64 - 1) / (64 * 64));
            CHECK(fabs(mean - want) <= 4 * se, "furnace with roulette: mean %g want %g (se %g)",
                  mean, want, se);
            CHECK(se > 0, "roulette should add noise");
        }
        free(rgb);
        tt_free(&s);
    }
}

static void test_triangle_coverage(void)
{
    csi_scene *sc;
    csi_status st = csi_scene_load(CSI_SOURCE_DIR "/data/scenes/triangle.scene", &sc);
    CHECK(st == CSI_OK, "triangle.scene: %s", csi_last_error());
    if (st != CSI_OK)
        return;
    csi_plan pl;
    csi_tracer *tr;
    CHECK_OK(csi_plan_make(sc, NULL, &pl));
    CHECK_OK(csi_tracer_create(sc, &pl, 2, &tr));
    /* vertices from the scene file; camera at (0,0,-2.5) looking along +z, fov 40, square */
    double V[3][3] = {{-0.62, -0.48, 0.0}, {0.71, -0.29, 0.4}, {-0.13, 0.63, -0.2}};
    double o[3] = {0, 0, -2.5}, th = tan(20 * M_PI / 180), P[3][2];
    for (int k = 0; k < 3; k++)
        project_z(o, th, 1, V[k], &P[k][0], &P[k][1]);
    uint32_t W = 128, H = 128;
    tt_setup s = {.sc = sc, .pl = pl, .tr = tr};
    float *rgb = tt_eval_grid(&s, W, H, 1, 1, NULL);
    size_t bad = 0, inside = 0, checked = 0;
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            double u = (x + 0.5) / W, v = (y + 0.5) / H;
            /* signed distances (in image units) to the three edges */
            double dmin = HUGE_VAL;
            int sgn = 0;
            bool in = true;
            for (int k = 0; k < 3; k++) {
                const double *a = P[k], *b = P[(k + 1) % 3];
                double ex = b[0] - a[0], ey = b[1] - a[1];
                double cr = ex * (v - a[1]) - ey * (u - a[0]);
                double d = cr / sqrt(ex * ex + ey * ey);
                int sk = d > 0 ? 1 : -1;
                if (k == 0)
                    sgn = sk;
                else if (sk != sgn)
                    in = false;
                dmin = fmin(dmin, fabs(d));
            }
            /* a projected-edge position is exact to ~1e-7 (float rays): skip samples within
             * 1e-5 of an edge, about 1/1000 of a cell here */
            if (dmin < 1e-5)
                continue;
            checked++;
            float val = rgb[3 * ((size_t)y * W + x)];
            inside += in;
            if (val != (in ? 1.0f : 0.0f))
                bad++;
        }
    CHECK(bad == 0, "%zu of %zu samples disagree with the projected triangle", bad, checked);
    CHECK(inside > 1000 && inside < checked - 1000, "triangle covers %zu of %zu", inside,
          checked);
    free(rgb);
    csi_tracer_free(tr);
    csi_plan_free(&pl);
    csi_scene_free(sc);
}

static void test_texture(void)
{
    const char *png_path = CSI_BINARY_DIR "/test_analytic_tex.png";
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    img.width = 2;
    img.height = 2;
    img.format = PNG_FORMAT_RGB;
    unsigned char px[12] = {0, 10, 200, 64, 20, 100, 128, 30, 50, 255, 40, 0};
    CHECK(png_image_write_to_file(&img, png_path, 0, px, 0, NULL), "cannot write %s", png_path);
    char text[2048];
    /* plane z = 0 with uv = (x, y); irradiance pi straight on makes L = albedo */
    snprintf(text, sizeof text,
             "camera { position 0.5 0.5 -5 target 0.5 0.5 0 fov 20 size 32 32 }\n"
             "material t { texture \"%s\" }\n"
             "plane { corner 0 0 0 edge_u 1 0 0 edge_v 0 1 0 material t }\n"
             "light directional { direction 0 0 1 irradiance 3.14159265358979 3.14159265358979 "
             "3.14159265358979 }\n",
             png_path);
    tt_setup s;
    if (!tt_make(&s, text, 1)) {
        tt_free(&s);
        return;
    }
    float uvs[12], rgb[12];
    double o[3] = {0.5, 0.5, -5}, th = tan(10 * M_PI / 180);
    for (int i = 0; i < 4; i++) {
        double p[3] = {0.25 + 0.5 * (i % 2), 0.25 + 0.5 * (i / 2), 0}, u, v;
        project_z(o, th, 1, p, &u, &v);
        uvs[3 * i] = (float)u;
        uvs[3 * i + 1] = (float)v;
        uvs[3 * i + 2] = 0;
    }
    CHECK_OK(csi_tracer_eval_points(s.tr, uvs, 4, 1, rgb, NULL, NULL));
    for (int i = 0; i < 4; i++)
        for (int c = 0; c < 3; c++) {
            double e = px[3 * i + c] / 255.0;
            double want = e <= 0.04045 ? e / 12.92 : pow((e + 0.055) / 1.055, 2.4);
            /* bilinear weights off by ~1e-6 at float hit points; sRGB table in float */
            CHECK(fabs(rgb[3 * i + c] - want) < 1e-4, "texel %d channel %d: %g want %g", i, c,
                  rgb[3 * i + c], want);
        }
    tt_free(&s);
}

int main(void)
{
    test_point_directional();
    test_area_light();
    test_ao();
    test_furnace();
    test_triangle_coverage();
    test_texture();
    return test_done();
}
