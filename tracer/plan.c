/* The plan: what a scene asks to simulate, decided once before any ray is cast. */
#include "tracer_internal.h"

#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

/* Breakpoints of an object's piecewise-linear motion, as shutter fractions: key times, where
 * the interpolation changes slope (holding before the first key and after the last). */
static bool steps_align(const csi_scene *sc, const tr_motion *mo, uint32_t n)
{
    double span = sc->shutter_close - sc->shutter_open;
    for (size_t k = 0; k < mo->n; k++) {
        double s = (mo->keys[k].time - sc->shutter_open) / span * (n - 1);
        if (fabs(s - nearbyint(s)) > 1e-6)
            return false;
    }
    return true;
}

/* Total rotation angle swept by the keys (radians). */
static double swept_angle(const csi_scene *sc, const tr_motion *mo)
{
    double a = 0;
    tr_xform prev, cur;
    tr_motion_eval(sc, mo, 0, &prev);
    /* measure with 256 sub-steps: the angle between successive rotation matrices */
    for (int i = 1; i <= 256; i++) {
        tr_motion_eval(sc, mo, i / 256.0, &cur);
        /* columns normalised remove scale; angle from trace of R_prev^T R_cur */
        double Rp[3][3], Rc[3][3];
        for (int j = 0; j < 3; j++) {
            double lp = sqrt(prev.m[0][j] * prev.m[0][j] + prev.m[1][j] * prev.m[1][j] +
                             prev.m[2][j] * prev.m[2][j]);
            double lc = sqrt(cur.m[0][j] * cur.m[0][j] + cur.m[1][j] * cur.m[1][j] +
                             cur.m[2][j] * cur.m[2][j]);
            for (int k = 0; k < 3; k++) {
                Rp[k][j] = prev.m[k][j] / lp;
                Rc[k][j] = cur.m[k][j] / lc;
            }
        }
        double tr = 0;
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                tr += Rp[k][j] * Rc[k][j];
        double c = (tr - 1) / 2;
        a += acos(c > 1 ? 1 : c < -1 ? -1 : c);
        prev = cur;
    }
    return a;
}

/* Embree time steps for a moving object (docs/scene-format.md): the smallest n whose uniform
 * steps contain every key time (Embree interpolates vertices linearly between steps, which is
 * exact for translation and scale) and, when the object rotates, at most 5 degrees of rotation
 * per step (chord error <= 0.1% of the radius); 129 (Embree's maximum) when none fits. */
static uint32_t object_steps(const csi_scene *sc, const tr_motion *mo)
{
    double ang = swept_angle(sc, mo);
    uint32_t min_n = 2;
    if (ang > 1e-9) {
        /* (the measured angle carries ~1e-9 rounding: do not round 72.0000001 up to 73) */
        double need = ceil(ang / (5.0 * M_PI / 180.0) - 1e-6) + 1;
        min_n = need > CSI_MAX_TIME_STEPS ? CSI_MAX_TIME_STEPS : (uint32_t)need;
    }
    for (uint32_t n = min_n; n <= CSI_MAX_TIME_STEPS; n++)
        if (steps_align(sc, mo, n))
            return n;
    return CSI_MAX_TIME_STEPS;
}

typedef struct cam_frame {
    double pos[3], f[3], r[3], u[3], th;
    bool ok; /* view direction defined and not parallel to up */
} cam_frame;

static void camera_frame(const csi_scene *sc, double s, cam_frame *cf)
{
    const tr_camera *c = &sc->camera;
    tr_xform x;
    tr_motion_eval(sc, &c->motion, s, &x);
    double tgt[3], up[3];
    tr_xform_point(&x, c->position, cf->pos);
    tr_xform_point(&x, c->target, tgt);
    tr_xform_dir(&x, c->up, up);
    double fl = 0, rl = 0;
    for (int i = 0; i < 3; i++) {
        cf->f[i] = tgt[i] - cf->pos[i];
        fl += cf->f[i] * cf->f[i];
    }
    for (int i = 0; i < 3; i++)
        cf->f[i] /= sqrt(fl);
    cf->r[0] = cf->f[1] * up[2] - cf->f[2] * up[1];
    cf->r[1] = cf->f[2] * up[0] - cf->f[0] * up[2];
    cf->r[2] = cf->f[0] * up[1] - cf->f[1] * up[0];
    for (int i = 0; i < 3; i++)
        rl += cf->r[i] * cf->r[i];
    double ul = up[0] * up[0] + up[1] * up[1] + up[2] * up[2];
    cf->ok = fl > 0 && rl > 1e-18 * ul && isfinite(rl);
    for (int i = 0; i < 3; i++)
        cf->r[i] /= sqrt(rl);
    cf->u[0] = cf->r[1] * cf->f[2] - cf->r[2] * cf->f[1];
    cf->u[1] = cf->r[2] * cf->f[0] - cf->r[0] * cf->f[2];
    cf->u[2] = cf->r[0] * cf->f[1] - cf->r[1] * cf->f[0];
    cf->th = tan(c->fov_deg * M_PI / 360.0);
}

/* Pixel coordinates of a world point, or false if it is behind (or at) the camera plane. */
static bool project(const csi_scene *sc, const cam_frame *cf, const double p[3], double *px,
                    double *py)
{
    double d[3] = {p[0] - cf->pos[0], p[1] - cf->pos[1], p[2] - cf->pos[2]};
    double z = d[0] * cf->f[0] + d[1] * cf->f[1] + d[2] * cf->f[2];
    if (z < 1e-3 * sc->extent)
        return false;
    double x = (d[0] * cf->r[0] + d[1] * cf->r[1] + d[2] * cf->r[2]) / (z * cf->th);
    double y = (d[0] * cf->u[0] + d[1] * cf->u[1] + d[2] * cf->u[2]) / (z * cf->th);
    /* x in [-aspect, aspect], y in [-1, 1] over the image: half the height is 1 */
    *px = x * sc->camera.height / 2.0;
    *py = y * sc->camera.height / 2.0;
    return true;
}

/* Largest on-screen path length (pixels) over the shutter of any moving point: the 8 corners
 * of each moving object's object-space box (all objects when the camera moves), at 65 times. */
static double motion_pixels(const csi_scene *sc, const csi_plan *pl)
{
    enum { NS = 65 };
    cam_frame cf[NS];
    for (int i = 0; i < NS; i++)
        camera_frame(sc, i / (double)(NS - 1), &cf[i]);
    double best = 0;
    for (size_t oi = 0; oi < sc->n_objects; oi++) {
        const tr_object *o = &sc->objects[oi];
        if (pl->object_time_steps[oi] < 2 && !pl->camera_moves)
            continue;
        double lo[3], hi[3];
        if (o->kind == OBJ_SPHERE) {
            for (int j = 0; j < 3; j++) {
                lo[j] = o->center[j] - o->radius;
                hi[j] = o->center[j] + o->radius;
            }
        } else {
            for (int j = 0; j < 3; j++) {
                lo[j] = HUGE_VAL;
                hi[j] = -HUGE_VAL;
            }
            for (size_t v = 0; v < o->nv; v++)
                for (int j = 0; j < 3; j++) {
                    lo[j] = fmin(lo[j], o->pos[3 * v + j]);
                    hi[j] = fmax(hi[j], o->pos[3 * v + j]);
                }
        }
        for (int c = 0; c < 8; c++) {
            double p[3] = {c & 1 ? hi[0] : lo[0], c & 2 ? hi[1] : lo[1], c & 4 ? hi[2] : lo[2]};
            double len = 0, px0 = 0, py0 = 0;
            bool have = false;
            for (int i = 0; i < NS; i++) {
                double q[3], px, py;
                csi_scene_object_point(sc, oi, i / (double)(NS - 1), p, q);
                if (!project(sc, &cf[i], q, &px, &py)) {
                    have = false;
                    continue;
                }
                if (have)
                    len += hypot(px - px0, py - py0);
                px0 = px;
                py0 = py;
                have = true;
            }
            best = fmax(best, len);
        }
    }
    return best;
}

/* Whether a moving camera only translates, and across its view: no key turns it (so the view
 * direction is target - position throughout), every key's scale is the first key's, and every
 * key's translation from the first has at most a quarter of its length along the view direction
 * (a dolly brings the picture's parts closer at different rates, a turn shears it; a translation
 * across the view moves it, nearer parts faster). */
static bool camera_pans(const tr_camera *c)
{
    const tr_motion *mo = &c->motion;
    double f[3], n = 0;
    for (int j = 0; j < 3; j++) {
        f[j] = c->target[j] - c->position[j];
        n += f[j] * f[j];
    }
    if (!(n > 0))
        return false;
    for (size_t i = 1; i < mo->n; i++) {
        const tr_key *a = &mo->keys[0], *k = &mo->keys[i];
        if (a->angle != 0 || k->angle != 0)
            return false;
        double along = 0, len = 0;
        for (int j = 0; j < 3; j++) {
            if (k->scale[j] != a->scale[j])
                return false;
            const double d = k->translate[j] - a->translate[j];
            along += d * f[j];
            len += d * d;
        }
        if (fabs(along) / sqrt(n) > 0.25 * sqrt(len))
            return false;
    }
    return true;
}

csi_status csi_plan_make(const csi_scene *sc, const csi_plan_overrides *ov, csi_plan *pl)
{
    memset(pl, 0, sizeof *pl);
    if (!sc)
        return csi_fail(CSI_ERR_ARG, "csi_plan_make: NULL scene");
    pl->width = sc->camera.width;
    pl->height = sc->camera.height;
    pl->n_objects = sc->n_objects;
    pl->object_time_steps = calloc(sc->n_objects ? sc->n_objects : 1, sizeof(uint32_t));
    if (!pl->object_time_steps)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (plan)");
    /* Motion must not collapse an object (scale through zero) or the camera (up along the
     * view direction) anywhere in the shutter: checked at 257 times and at every key. */
    for (size_t i = 0; i <= sc->n_objects; i++) {
        const tr_motion *mo = i < sc->n_objects ? &sc->objects[i].motion : &sc->camera.motion;
        if (!tr_motion_moves(mo))
            continue;
        for (int k = 0; k <= 256; k++) {
            double s = k / 256.0;
            tr_xform x, inv;
            tr_motion_eval(sc, mo, s, &x);
            bool bad = !tr_xform_invert(&x, &inv);
            if (!bad && i == sc->n_objects) {
                cam_frame cf;
                camera_frame(sc, s, &cf);
                bad = !cf.ok;
            }
            if (bad) {
                free(pl->object_time_steps);
                pl->object_time_steps = NULL;
                double t = sc->shutter_open + s * (sc->shutter_close - sc->shutter_open);
                if (i == sc->n_objects)
                    return csi_fail(CSI_ERR_SCENE,
                                    "%s: camera motion makes the view degenerate at time %g",
                                    sc->name, t);
                return csi_fail(CSI_ERR_SCENE,
                                "%s:%d: %s motion collapses it (zero scale) at time %g",
                                sc->name, sc->objects[i].line, sc->objects[i].what, t);
            }
        }
    }
    for (size_t i = 0; i < sc->n_objects; i++) {
        const tr_object *o = &sc->objects[i];
        if (tr_motion_moves(&o->motion)) {
            pl->object_time_steps[i] = object_steps(sc, &o->motion);
            pl->n_moving_objects++;
        } else {
            pl->object_time_steps[i] = 1;
        }
    }
    pl->camera_moves = tr_motion_moves(&sc->camera.motion);
    pl->camera_pans = pl->camera_moves && camera_pans(&sc->camera);
    pl->motion = pl->camera_moves || pl->n_moving_objects > 0;
    if (pl->motion) {
        pl->motion_pixels = motion_pixels(sc, pl);
        if (ov && ov->frames) {
            pl->frames = ov->frames;
            pl->frames_rule = "override";
        } else if (sc->frames) {
            pl->frames = sc->frames;
            pl->frames_rule = "scene";
        } else {
            double need = ceil(pl->motion_pixels);
            uint32_t t = 8;
            while (t < 64 && t < need)
                t *= 2;
            pl->frames = t;
            pl->frames_rule = "rule";
        }
    } else {
        pl->frames = 1;
        pl->frames_rule = "static";
    }
    for (size_t i = 0; i < sc->n_lights; i++) {
        const tr_light *L = &sc->lights[i];
        if (L->kind == LIGHT_POINT)
            pl->n_point_lights++;
        else if (L->kind == LIGHT_DIRECTIONAL)
            pl->n_directional_lights++;
        else
            pl->n_area_lights++;
        pl->shadow_rays_per_hit += L->kind == LIGHT_AREA ? L->samples : 1;
    }
    for (size_t i = 0; i < sc->n_objects; i++) {
        const tr_material *m = &sc->materials[sc->objects[i].material];
        pl->image_textures |= m->kind == MAT_TEXTURE;
        pl->checker_textures |= m->kind == MAT_CHECKER;
    }
    pl->ambient_occlusion = sc->ao;
    pl->ao_samples = sc->ao ? sc->ao_samples : 0;
    pl->ao_distance = sc->ao ? sc->ao_distance : 0;
    pl->path_tracing = sc->path;
    pl->max_bounces = sc->path ? sc->max_bounces : 0;
    pl->roulette_start = sc->path ? sc->roulette_start : 0;
    /* The tracer's only random numbers: area-light points, AO directions, bounces and roulette
     * (tracer.c); without them a value is a function of its cell's centre alone. */
    pl->exact = pl->n_area_lights == 0 && !pl->ambient_occlusion && !pl->path_tracing;
    return CSI_OK;
}

void csi_plan_free(csi_plan *pl)
{
    if (!pl)
        return;
    free(pl->object_time_steps);
    pl->object_time_steps = NULL;
}

/* ---- JSON ----------------------------------------------------------------------------------- */

typedef struct sbuf {
    char *s;
    size_t n, cap;
    bool oom;
} sbuf;

static void sb_printf(sbuf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void sb_printf(sbuf *b, const char *fmt, ...)
{
    if (b->oom)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int k = vsnprintf(b->s ? b->s + b->n : NULL, b->s ? b->cap - b->n : 0, fmt, ap);
        va_end(ap);
        if (k < 0) {
            b->oom = true;
            return;
        }
        if (b->s && b->n + (size_t)k < b->cap) {
            b->n += (size_t)k;
            return;
        }
        size_t nc = (b->cap ? 2 * b->cap : 1024) + (size_t)k;
        char *ns = realloc(b->s, nc);
        if (!ns) {
            b->oom = true;
            return;
        }
        b->s = ns;
        b->cap = nc;
    }
}

static void sb_str(sbuf *b, const char *s)
{
    sb_printf(b, "\"");
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            sb_printf(b, "\\%c", c);
        else if (c < 0x20)
            sb_printf(b, "\\u%04x", c);
        else
            sb_printf(b, "%c", c);
    }
    sb_printf(b, "\"");
}

csi_status csi_plan_json_string(const csi_scene *sc, const csi_plan *pl, char **out)
{
    *out = NULL;
    sbuf b = {0};
    sb_printf(&b, "{\"scene\": ");
    sb_str(&b, sc->name);
    sb_printf(&b, ", \"width\": %u, \"height\": %u, \"frames\": %u, \"frames_rule\": \"%s\"",
              pl->width, pl->height, pl->frames, pl->frames_rule);
    sb_printf(&b, ", \"method\": \"%s\"", pl->motion ? "3d-motion" : "2d-antialias");
    sb_printf(&b, ", \"shutter\": [%.17g, %.17g]", sc->shutter_open, sc->shutter_close);
    sb_printf(&b, ", \"motion\": %s, \"rays_carry_time\": %s, \"camera_moves\": %s, \"camera_pans\": %s",
              pl->motion ? "true" : "false", pl->motion ? "true" : "false",
              pl->camera_moves ? "true" : "false", pl->camera_pans ? "true" : "false");
    sb_printf(&b, ", \"motion_pixels\": %.6g", pl->motion_pixels);
    sb_printf(&b, ", \"moving_objects\": %zu, \"objects\": [", pl->n_moving_objects);
    for (size_t i = 0; i < sc->n_objects; i++) {
        const tr_object *o = &sc->objects[i];
        sb_printf(&b, "%s{\"index\": %zu, \"type\": \"%s\", \"line\": %d, \"material\": ",
                  i ? ", " : "", i, o->what, o->line);
        sb_str(&b, sc->materials[o->material].name);
        sb_printf(&b, ", \"triangles\": %zu, \"motion_geometry\": %s, \"time_steps\": %u}",
                  o->kind == OBJ_SPHERE ? (size_t)0 : o->nt,
                  pl->object_time_steps[i] > 1 ? "true" : "false", pl->object_time_steps[i]);
    }
    sb_printf(&b, "], \"lights\": {\"point\": %zu, \"directional\": %zu, \"area\": %zu}",
              pl->n_point_lights, pl->n_directional_lights, pl->n_area_lights);
    sb_printf(&b, ", \"shadow_rays_per_hit\": %u", pl->shadow_rays_per_hit);
    sb_printf(&b, ", \"image_textures\": %s, \"checker_textures\": %s",
              pl->image_textures ? "true" : "false", pl->checker_textures ? "true" : "false");
    sb_printf(&b, ", \"ambient_occlusion\": ");
    if (pl->ambient_occlusion)
        sb_printf(&b, "{\"samples\": %u, \"distance\": %.9g}", pl->ao_samples, pl->ao_distance);
    else
        sb_printf(&b, "false");
    sb_printf(&b, ", \"path_tracing\": ");
    if (pl->path_tracing)
        sb_printf(&b, "{\"max_bounces\": %u, \"roulette_start\": %u}", pl->max_bounces,
                  pl->roulette_start);
    else
        sb_printf(&b, "false");
    sb_printf(&b, ", \"exact\": %s", pl->exact ? "true" : "false");
    sb_printf(&b, "}\n");
    if (b.oom) {
        free(b.s);
        return csi_fail(CSI_ERR_NOMEM, "out of memory (plan JSON)");
    }
    *out = b.s;
    return CSI_OK;
}

csi_status csi_plan_json(const csi_scene *sc, const csi_plan *pl, FILE *out)
{
    char *s;
    CSI_TRY(csi_plan_json_string(sc, pl, &s));
    size_t n = strlen(s);
    bool ok = fwrite(s, 1, n, out) == n;
    free(s);
    if (!ok)
        return csi_fail(CSI_ERR_IO, "cannot write the plan JSON");
    return CSI_OK;
}
