/* Ray-geometry hits against closed forms: sphere (user geometry), ellipsoid (scaled sphere),
 * slanted quad, triangle (Moller-Trumbore in double), box faces.
 *
 * Tolerances: Embree takes float rays and returns a float distance; spheres are solved in
 * double from the float ray, so distances agree to a few float ulps of the distance (1e-6
 * relative). Triangles are intersected in float by Embree: 1e-5 relative covers the float
 * rounding of the edge and determinant products for these well-conditioned triangles. */
#include "tracer_test_util.h"

static void norm(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++)
        v[i] /= l;
}

static void check_hit(tt_setup *s, const double o[3], double d[3], double want_t,
                      const double want_n[3], size_t want_obj, double tol, const char *what)
{
    csi_hit h;
    norm(d);
    CHECK_OK(csi_tracer_intersect(s->tr, o, d, 0, &h));
    CHECK(h.hit, "%s: expected a hit", what);
    if (!h.hit)
        return;
    CHECK(fabs(h.distance - want_t) <= tol * want_t, "%s: distance %.9g, want %.9g", what,
          h.distance, want_t);
    double dn = 0;
    for (int i = 0; i < 3; i++)
        dn = fmax(dn, fabs(h.normal[i] - want_n[i]));
    CHECK(dn < 1e-5, "%s: normal (%g %g %g), want (%g %g %g)", what, h.normal[0], h.normal[1],
          h.normal[2], want_n[0], want_n[1], want_n[2]);
    CHECK(h.object == want_obj, "%s: object %zu, want %zu", what, h.object, want_obj);
}

static void test_sphere(void)
{
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 0 -1 target 0 0 0 }\n"
                     "material m { diffuse 1 1 1 }\n"
                     "sphere { center 0 0 5 radius 1 material m }\n"
                     "sphere { center 0 0 0 radius 1 material m motion { key 0.5 { translate "
                     "20 0 0 scale 2 1 1 } } }\n",
                 1)) {
        tt_free(&s);
        return;
    }
    double o[3] = {0, 0, 0};
    /* straight on: t = 5 - 1, normal -z */
    double d0[3] = {0, 0, 1}, n0[3] = {0, 0, -1};
    check_hit(&s, o, d0, 4.0, n0, 0, 1e-6, "sphere centre");
    /* grazing-ish rays: direction to a point on the sphere; t is that point's distance */
    test_rng r;
    test_rng_seed(&r, 11);
    for (int k = 0; k < 50; k++) {
        /* a point on the near hemisphere facing the origin */
        double th = acos(1 - 0.9 * test_rng_uniform(&r)), ph = 2 * M_PI * test_rng_uniform(&r);
        double nrm[3] = {sin(th) * cos(ph), sin(th) * sin(ph), -cos(th)};
        double p[3] = {nrm[0], nrm[1], 5 + nrm[2]};
        double d[3] = {p[0], p[1], p[2]};
        double t = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        /* the point is the first hit only if the ray meets the sphere there from outside */
        double dd[3] = {p[0] / t, p[1] / t, p[2] / t};
        if (dd[0] * nrm[0] + dd[1] * nrm[1] + dd[2] * nrm[2] > -0.05)
            continue;
        check_hit(&s, o, d, t, nrm, 0, 1e-6, "sphere point");
    }
    /* ellipsoid: unit sphere scaled by (2, 1, 1), moved to x = 20: ray along -x from x = 30
     * meets x = 22 at t = 8 with normal +x; ray along -y from y = 10 at x = 21 meets
     * y = sqrt(1 - (1/2)^2) with normal proportional to (x/4, y, 0). */
    double o2[3] = {30, 0, 0}, d2[3] = {-1, 0, 0}, n2[3] = {1, 0, 0};
    check_hit(&s, o2, d2, 8.0, n2, 1, 1e-6, "ellipsoid tip");
    double yy = sqrt(0.75), o3[3] = {21, 10, 0}, d3[3] = {0, -1, 0}, n3[3] = {0.25, yy, 0};
    norm(n3);
    check_hit(&s, o3, d3, 10 - yy, n3, 1, 1e-6, "ellipsoid side");
    /* a miss */
    csi_hit h;
    double dm[3] = {0, 1, 0};
    CHECK_OK(csi_tracer_intersect(s.tr, o, dm, 0, &h));
    CHECK(!h.hit, "ray up should miss");
    tt_free(&s);
}

static void test_quad_triangle_box(void)
{
    tt_setup s;
    if (!tt_make(&s, "camera { position 0 0 -1 target 0 0 0 }\n"
                     "material m { diffuse 1 1 1 }\n"
                     "plane { corner -1 -1 3 edge_u 2 0 0.5 edge_v 0 2 1 material m }\n"
                     "mesh { vertices { -30 -1 10  -26 -1 12  -28 2 11 } triangles { 0 1 2 } "
                     "material m }\n"
                     "box { min 40 -1 -1 max 42 1 1 material m }\n",
                 2)) {
        tt_free(&s);
        return;
    }
    /* Quad: plane through c with normal n = eu x ev; t = (n.c)/(n.d) from the origin. */
    double c[3] = {-1, -1, 3}, eu[3] = {2, 0, 0.5}, ev[3] = {0, 2, 1};
    double n[3] = {eu[1] * ev[2] - eu[2] * ev[1], eu[2] * ev[0] - eu[0] * ev[2],
                   eu[0] * ev[1] - eu[1] * ev[0]};
    norm(n);
    test_rng r;
    test_rng_seed(&r, 12);
    double o[3] = {0, 0, 0};
    for (int k = 0; k < 50; k++) {
        double a = 0.02 + 0.96 * test_rng_uniform(&r), b = 0.02 + 0.96 * test_rng_uniform(&r);
        double p[3];
        for (int i = 0; i < 3; i++)
            p[i] = c[i] + a * eu[i] + b * ev[i];
        double d[3] = {p[0], p[1], p[2]};
        norm(d);
        double t = (n[0] * c[0] + n[1] * c[1] + n[2] * c[2]) /
                   (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]);
        double nn[3] = {n[0], n[1], n[2]};
        if (nn[0] * d[0] + nn[1] * d[1] + nn[2] * d[2] > 0)
            for (int i = 0; i < 3; i++)
                nn[i] = -nn[i];
        check_hit(&s, o, d, t, nn, 0, 1e-5, "quad");
    }
    /* Triangle: Moller-Trumbore in double for rays from (-28, 0, 0) towards random points. */
    double v0[3] = {-30, -1, 10}, v1[3] = {-26, -1, 12}, v2[3] = {-28, 2, 11};
    double ot[3] = {-28, 0, 0};
    for (int k = 0; k < 50; k++) {
        double d[3] = {-2 + 4 * test_rng_uniform(&r), -1.5 + 3.5 * test_rng_uniform(&r), 11};
        norm(d);
        double e1[3], e2[3], pv[3], tv[3], qv[3];
        for (int i = 0; i < 3; i++) {
            e1[i] = v1[i] - v0[i];
            e2[i] = v2[i] - v0[i];
            tv[i] = ot[i] - v0[i];
        }
        pv[0] = d[1] * e2[2] - d[2] * e2[1];
        pv[1] = d[2] * e2[0] - d[0] * e2[2];
        pv[2] = d[0] * e2[1] - d[1] * e2[0];
        double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
        double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
        qv[0] = tv[1] * e1[2] - tv[2] * e1[1];
        qv[1] = tv[2] * e1[0] - tv[0] * e1[2];
        qv[2] = tv[0] * e1[1] - tv[1] * e1[0];
        double v = (d[0] * qv[0] + d[1] * qv[1] + d[2] * qv[2]) / det;
        double t = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
        double margin = 1e-4;
        bool inside = u > margin && v > margin && u + v < 1 - margin;
        bool outside = u < -margin || v < -margin || u + v > 1 + margin;
        if (inside) {
            double tn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                            e1[0] * e2[1] - e1[1] * e2[0]};
            norm(tn);
            if (tn[0] * d[0] + tn[1] * d[1] + tn[2] * d[2] > 0)
                for (int i = 0; i < 3; i++)
                    tn[i] = -tn[i];
            check_hit(&s, ot, d, t, tn, 1, 1e-5, "triangle");
        } else if (outside) {
            csi_hit h;
            CHECK_OK(csi_tracer_intersect(s.tr, ot, d, 0, &h));
            CHECK(!h.hit || h.object != 1, "triangle: ray outside (u=%g v=%g) hit", u, v);
        }
    }
    /* Box faces: from (41, 0, -10) along +z meets z = -1 at t = 9; from (50, 0.3, 0.2) along
     * -x meets x = 42 at t = 8; from (41, 5, 0) along -y meets y = 1 at t = 4. */
    double ob1[3] = {41, 0, -10}, db1[3] = {0, 0, 1}, nb1[3] = {0, 0, -1};
    check_hit(&s, ob1, db1, 9, nb1, 2, 1e-6, "box -z face");
    double ob2[3] = {50, 0.3, 0.2}, db2[3] = {-1, 0, 0}, nb2[3] = {1, 0, 0};
    check_hit(&s, ob2, db2, 8, nb2, 2, 1e-6, "box +x face");
    double ob3[3] = {41, 5, 0}, db3[3] = {0, -1, 0}, nb3[3] = {0, 1, 0};
    check_hit(&s, ob3, db3, 4, nb3, 2, 1e-6, "box +y face");
    tt_free(&s);
}

int main(void)
{
    test_sphere();
    test_quad_triangle_box();
    return test_done();
}
