/* The pinhole camera: the primary ray through an image point at a shutter time (its keyed
 * motion applied), for the tracer and the tests. */
#include "tracer_internal.h"

#include <math.h>

void csi_scene_camera_ray(const csi_scene *sc, double u, double v, double s, double org[3],
                          double dir[3])
{
    const tr_camera *c = &sc->camera;
    tr_xform x;
    tr_motion_eval(sc, &c->motion, s, &x);
    double pos[3], tgt[3], up[3];
    tr_xform_point(&x, c->position, pos);
    tr_xform_point(&x, c->target, tgt);
    tr_xform_dir(&x, c->up, up);
    double f[3] = {tgt[0] - pos[0], tgt[1] - pos[1], tgt[2] - pos[2]};
    double fl = norm3(f);
    for (int i = 0; i < 3; i++)
        f[i] /= fl;
    double r[3], uo[3];
    cross3(f, up, r);
    double rl = norm3(r);
    for (int i = 0; i < 3; i++)
        r[i] /= rl;
    cross3(r, f, uo);
    double th = tan(c->fov_deg * M_PI / 360.0);
    double aspect = (double)c->width / c->height;
    double px = (2 * u - 1) * th * aspect, py = (1 - 2 * v) * th;
    double d[3];
    for (int i = 0; i < 3; i++)
        d[i] = f[i] + px * r[i] + py * uo[i];
    double dl = norm3(d);
    for (int i = 0; i < 3; i++) {
        dir[i] = d[i] / dl;
        org[i] = pos[i];
    }
}

