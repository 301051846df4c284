/* Keyed motion (docs/scene-format.md, "motion"): whether a track moves, the transform at a
 * shutter fraction, its inverse. Used by the scene parser (plan, checks) and by the tracer
 * (Embree's motion steps, the exact points tests compare against). */
#include "tracer_internal.h"

#include <math.h>
#include <string.h>

static void rot_matrix(const double axis[3], double ang, double R[3][3])
{
    double c = cos(ang), s = sin(ang), C = 1 - c;
    double x = axis[0], y = axis[1], z = axis[2];
    R[0][0] = c + x * x * C;     R[0][1] = x * y * C - z * s; R[0][2] = x * z * C + y * s;
    R[1][0] = y * x * C + z * s; R[1][1] = c + y * y * C;     R[1][2] = y * z * C - x * s;
    R[2][0] = z * x * C - y * s; R[2][1] = z * y * C + x * s; R[2][2] = c + z * z * C;
}

/* Quaternion (w, x, y, z) of an axis-angle rotation and back. */
void tr_aa_to_q(const double axis[3], double ang, double q[4])
{
    double s = sin(ang / 2);
    q[0] = cos(ang / 2);
    q[1] = axis[0] * s;
    q[2] = axis[1] * s;
    q[3] = axis[2] * s;
}
void tr_q_to_aa(const double q[4], double axis[3], double *ang)
{
    double s = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (s < 1e-15) {
        axis[0] = 1;
        axis[1] = axis[2] = 0;
        *ang = 0;
        return;
    }
    for (int i = 0; i < 3; i++)
        axis[i] = q[i + 1] / s;
    *ang = 2 * atan2(s, q[0]);
}

bool tr_motion_moves(const tr_motion *mo)
{
    for (size_t i = 1; i < mo->n; i++) {
        const tr_key *a = &mo->keys[0], *b = &mo->keys[i];
        for (int j = 0; j < 3; j++)
            if (a->translate[j] != b->translate[j] || a->scale[j] != b->scale[j])
                return true;
        /* compare angle and axis, not quaternions: a whole turn between keys is motion */
        if (a->angle != b->angle)
            return true;
        if (a->angle != 0 &&
            (a->axis[0] != b->axis[0] || a->axis[1] != b->axis[1] || a->axis[2] != b->axis[2]))
            return true;
    }
    return false;
}

/* Interpolation between keys: translation and scale linearly; rotation by the angle linearly
 * when both keys share the axis (or one has no rotation), so spins of more than half a turn
 * between keys are kept; otherwise spherical linear interpolation of the quaternions
 * (Shoemake 1985). Before the first key and after the last the transform is held. */
void tr_motion_eval(const csi_scene *sc, const tr_motion *mo, double s, tr_xform *x)
{
    double T[3] = {0, 0, 0}, S[3] = {1, 1, 1}, axis[3] = {1, 0, 0}, ang = 0;
    if (mo->n > 0) {
        double time = sc->shutter_open + s * (sc->shutter_close - sc->shutter_open);
        size_t i = 0;
        while (i + 1 < mo->n && mo->keys[i + 1].time <= time)
            i++;
        const tr_key *a = &mo->keys[i];
        if (i + 1 >= mo->n || time <= a->time) {
            memcpy(T, a->translate, sizeof T);
            memcpy(S, a->scale, sizeof S);
            memcpy(axis, a->axis, sizeof axis);
            ang = a->angle;
        } else {
            const tr_key *b = &mo->keys[i + 1];
            double f = (time - a->time) / (b->time - a->time);
            for (int j = 0; j < 3; j++) {
                T[j] = a->translate[j] + f * (b->translate[j] - a->translate[j]);
                S[j] = a->scale[j] + f * (b->scale[j] - a->scale[j]);
            }
            bool same_axis = dot3(a->axis, b->axis) > 1 - 1e-12;
            if (a->angle == 0 && b->angle == 0) {
                ang = 0;
            } else if (same_axis || a->angle == 0 || b->angle == 0) {
                const double *ax = a->angle != 0 ? a->axis : b->axis;
                memcpy(axis, ax, sizeof axis);
                double aa = a->angle, bb = b->angle;
                if (a->angle != 0 && b->angle == 0)
                    bb = 0;
                ang = aa + f * (bb - aa);
            } else {
                double qa[4], qb[4], q[4];
                tr_aa_to_q(a->axis, a->angle, qa);
                tr_aa_to_q(b->axis, b->angle, qb);
                double d = qa[0] * qb[0] + qa[1] * qb[1] + qa[2] * qb[2] + qa[3] * qb[3];
                if (d < 0) {
                    d = -d;
                    for (int j = 0; j < 4; j++)
                        qb[j] = -qb[j];
                }
                if (d > 0.9995) {
                    double nn = 0;
                    for (int j = 0; j < 4; j++) {
                        q[j] = qa[j] + f * (qb[j] - qa[j]);
                        nn += q[j] * q[j];
                    }
                    for (int j = 0; j < 4; j++)
                        q[j] /= sqrt(nn);
                } else {
                    double th = acos(d), st = sin(th);
                    double wa = sin((1 - f) * th) / st, wb = sin(f * th) / st;
                    for (int j = 0; j < 4; j++)
                        q[j] = wa * qa[j] + wb * qb[j];
                }
                tr_q_to_aa(q, axis, &ang);
            }
        }
    }
    double R[3][3];
    rot_matrix(axis, ang, R);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++)
            x->m[i][j] = R[i][j] * S[j];
        x->t[i] = T[i];
    }
}

bool tr_xform_invert(const tr_xform *x, tr_xform *inv)
{
    const double(*m)[3] = x->m;
    double det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
                 m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                 m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (!(fabs(det) > 1e-300))
        return false;
    double id = 1 / det;
    double (*r)[3] = inv->m;
    r[0][0] = (m[1][1] * m[2][2] - m[1][2] * m[2][1]) * id;
    r[0][1] = (m[0][2] * m[2][1] - m[0][1] * m[2][2]) * id;
    r[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * id;
    r[1][0] = (m[1][2] * m[2][0] - m[1][0] * m[2][2]) * id;
    r[1][1] = (m[0][0] * m[2][2] - m[0][2] * m[2][0]) * id;
    r[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * id;
    r[2][0] = (m[1][0] * m[2][1] - m[1][1] * m[2][0]) * id;
    r[2][1] = (m[0][1] * m[2][0] - m[0][0] * m[2][1]) * id;
    r[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * id;
    for (int i = 0; i < 3; i++)
        inv->t[i] = -(r[i][0] * x->t[0] + r[i][1] * x->t[1] + r[i][2] * x->t[2]);
    return true;
}

