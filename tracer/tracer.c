/* The Embree sampler: builds the Embree scene the plan asks for and evaluates radiance.
 *
 * Geometry: every mesh-like object (mesh, plane, box) is an Embree triangle mesh; spheres are
 * Embree user geometry intersected in closed form (exact, and ellipsoids under non-uniform
 * scale). Moving objects get rtcSetGeometryTimeStepCount(steps) with one vertex buffer per step
 * (Embree 3 API reference, "Motion Blur"); static ones a single buffer, and rays then carry
 * no time. Shading is Lambertian: emission, point/directional lights with one shadow ray each,
 * quad area lights with `samples` shadow rays (soft shadows), ambient occlusion with
 * cosine-weighted rays, and path tracing with next-event estimation, a bounce limit and
 * Russian roulette (Pharr, Jakob, Humphreys, PBRT 3rd ed., 13.7 and 14.5). */
#include "tracer_internal.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#if defined(__SSE__) || defined(__x86_64__)
#include <pmmintrin.h>
#include <xmmintrin.h>
#define TR_HAVE_SSE 1
#endif

typedef struct tr_geom {
    const csi_scene *sc;
    const tr_object *obj;
    uint32_t steps;
    tr_xform x0, inv0; /* static transform and its inverse (steps == 1) */
    double pad;        /* sphere bounds padding for motion between steps */
} tr_geom;

struct csi_tracer {
    const csi_scene *sc;
    const csi_plan *pl;
    RTCDevice dev;
    RTCScene scene;
    unsigned threads;
    tr_geom *geoms;
    csi_tracer_info info;
    pthread_mutex_t lock;
    csi_tracer_counters counters;
    bool cell_jitter; /* csi_tracer_set_cell_jitter */
    char embree_error[512];
};

static void embree_error(void *user, enum RTCError code, const char *str)
{
    csi_tracer *tr = user;
    if (tr && !tr->embree_error[0])
        snprintf(tr->embree_error, sizeof tr->embree_error, "Embree error %d: %s", (int)code,
                 str ? str : "");
}

/* ---- spheres as user geometry --------------------------------------------------------------- */

static void sphere_xform(const tr_geom *g, double s, tr_xform *x, tr_xform *inv)
{
    if (g->steps <= 1) {
        *x = g->x0;
        *inv = g->inv0;
        return;
    }
    tr_motion_eval(g->sc, &g->obj->motion, s, x);
    tr_xform_invert(x, inv);
}

/* World-space box of the ellipsoid at shutter fraction s. */
static void sphere_box(const tr_geom *g, double s, double lo[3], double hi[3])
{
    tr_xform x, inv;
    sphere_xform(g, s, &x, &inv);
    double c[3];
    tr_xform_point(&x, g->obj->center, c);
    for (int i = 0; i < 3; i++) {
        double e = g->obj->radius * sqrt(x.m[i][0] * x.m[i][0] + x.m[i][1] * x.m[i][1] +
                                         x.m[i][2] * x.m[i][2]);
        lo[i] = c[i] - e;
        hi[i] = c[i] + e;
    }
}

static void sphere_bounds(const struct RTCBoundsFunctionArguments *args)
{
    const tr_geom *g = args->geometryUserPtr;
    double s = g->steps > 1 ? (double)args->timeStep / (g->steps - 1) : 0;
    double lo[3], hi[3];
    sphere_box(g, s, lo, hi);
    struct RTCBounds *b = args->bounds_o;
    /* Rounded outward by a relative 1e-6 so float conversion never shrinks the box. */
    double r = 1e-6 * (fabs(lo[0]) + fabs(lo[1]) + fabs(lo[2]) + fabs(hi[0]) + fabs(hi[1]) +
                       fabs(hi[2]) + 1e-3);
    b->lower_x = (float)(lo[0] - g->pad - r);
    b->lower_y = (float)(lo[1] - g->pad - r);
    b->lower_z = (float)(lo[2] - g->pad - r);
    b->upper_x = (float)(hi[0] + g->pad + r);
    b->upper_y = (float)(hi[1] + g->pad + r);
    b->upper_z = (float)(hi[2] + g->pad + r);
}

/* Embree interpolates the per-step boxes linearly; the true box may bulge out between steps
 * when the motion is not linear there (rotation of an ellipsoid, keys off the step grid). The
 * padding is the largest excess found at 16 points inside every step interval, doubled. */
static double sphere_motion_pad(const tr_geom *g)
{
    if (g->steps <= 1)
        return 0;
    double pad = 0;
    for (uint32_t k = 0; k + 1 < g->steps; k++) {
        double a = (double)k / (g->steps - 1), b = (double)(k + 1) / (g->steps - 1);
        double la[3], ha[3], lb[3], hb[3];
        sphere_box(g, a, la, ha);
        sphere_box(g, b, lb, hb);
        for (int j = 1; j < 16; j++) {
            double f = j / 16.0, lo[3], hi[3];
            sphere_box(g, a + f * (b - a), lo, hi);
            for (int i = 0; i < 3; i++) {
                pad = fmax(pad, (la[i] + f * (lb[i] - la[i])) - lo[i]);
                pad = fmax(pad, hi[i] - (ha[i] + f * (hb[i] - ha[i])));
            }
        }
    }
    return 2 * pad;
}

/* Ray-ellipsoid in object space: |o + t d - c|^2 = r^2; t is the same parameter in world space
 * because the map is affine. Returns the nearest root in (tnear, tfar), or -1. The stable
 * quadratic form (Numerical Recipes 5.6) avoids cancellation. */
static double sphere_hit(const tr_geom *g, const float org[3], const float dir[3], double tnear,
                         double tfar, double s, double nrm[3], double uv[2])
{
    tr_xform x, inv;
    sphere_xform(g, s, &x, &inv);
    double o[3] = {org[0], org[1], org[2]}, d[3] = {dir[0], dir[1], dir[2]}, oo[3], dd[3];
    tr_xform_point(&inv, o, oo);
    tr_xform_dir(&inv, d, dd);
    const double *c = g->obj->center, r = g->obj->radius;
    double oc[3] = {oo[0] - c[0], oo[1] - c[1], oo[2] - c[2]};
    double A = dd[0] * dd[0] + dd[1] * dd[1] + dd[2] * dd[2];
    double B = 2 * (oc[0] * dd[0] + oc[1] * dd[1] + oc[2] * dd[2]);
    double C = oc[0] * oc[0] + oc[1] * oc[1] + oc[2] * oc[2] - r * r;
    double disc = B * B - 4 * A * C;
    if (!(disc >= 0) || !(A > 0))
        return -1;
    double q = -0.5 * (B + copysign(sqrt(disc), B));
    double t0 = q / A, t1 = q != 0 ? C / q : t0;
    if (t0 > t1) {
        double tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    double t = t0 > tnear && t0 < tfar ? t0 : (t1 > tnear && t1 < tfar ? t1 : -1);
    if (t < 0)
        return -1;
    if (nrm) {
        double po[3] = {oc[0] + t * dd[0], oc[1] + t * dd[1], oc[2] + t * dd[2]};
        /* normal transforms by the inverse transpose */
        for (int i = 0; i < 3; i++)
            nrm[i] = inv.m[0][i] * po[0] + inv.m[1][i] * po[1] + inv.m[2][i] * po[2];
        /* spherical texture coordinates: u around the object's y axis, v from the top */
        double phi = atan2(po[2], po[0]);
        double cy = po[1] / r;
        cy = cy > 1 ? 1 : cy < -1 ? -1 : cy;
        uv[0] = (phi < 0 ? phi + 2 * M_PI : phi) / (2 * M_PI);
        uv[1] = acos(cy) / M_PI;
    }
    return t;
}

static void sphere_intersect(const struct RTCIntersectFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    const tr_geom *g = args->geometryUserPtr;
    struct RTCRayHit *rh = (struct RTCRayHit *)args->rayhit; /* N == 1 from rtcIntersect1 */
    struct RTCRay *ray = &rh->ray;
    float org[3] = {ray->org_x, ray->org_y, ray->org_z}, dir[3] = {ray->dir_x, ray->dir_y,
                                                                   ray->dir_z};
    double n[3], uv[2];
    double t = sphere_hit(g, org, dir, ray->tnear, ray->tfar, ray->time, n, uv);
    if (t < 0)
        return;
    ray->tfar = (float)t;
    rh->hit.Ng_x = (float)n[0];
    rh->hit.Ng_y = (float)n[1];
    rh->hit.Ng_z = (float)n[2];
    rh->hit.u = (float)uv[0];
    rh->hit.v = (float)uv[1];
    rh->hit.primID = args->primID;
    rh->hit.geomID = args->geomID;
    rh->hit.instID[0] = args->context->instID[0];
}

static void sphere_occluded(const struct RTCOccludedFunctionNArguments *args)
{
    if (!args->valid[0])
        return;
    const tr_geom *g = args->geometryUserPtr;
    struct RTCRay *ray = (struct RTCRay *)args->ray;
    float org[3] = {ray->org_x, ray->org_y, ray->org_z}, dir[3] = {ray->dir_x, ray->dir_y,
                                                                   ray->dir_z};
    if (sphere_hit(g, org, dir, ray->tnear, ray->tfar, ray->time, NULL, NULL) >= 0)
        ray->tfar = -INFINITY;
}

/* ---- building ------------------------------------------------------------------------------- */

uint64_t csi_tracer_host_bytes(const csi_scene *sc, const csi_plan *pl)
{
    /* Per mesh: one vertex buffer per time step (12 bytes a vertex) and the index buffer, as
     * build_mesh allocates them, and Embree's BVH with its build's peak: 64 bytes per triangle
     * per time step for motion geometry and 128 for static (its high-quality build splits
     * triangles). Embree 3.13 measured about 50 and 105 (peak RSS growth of csi_tracer_create on
     * meshes of 20000 and 100000 small triangles at 1, 19 and 129 steps), so the figure is an
     * upper bound within about 25%. Spheres are user geometry: a few hundred bytes. Plus the
     * device, its task threads and the tracing threads' stacks: 16 MiB (2 MiB measured). */
    uint64_t b = UINT64_C(16) << 20;
    for (size_t i = 0; i < sc->n_objects; i++) {
        const tr_object *o = &sc->objects[i];
        const uint64_t steps = pl && i < pl->n_objects && pl->object_time_steps ? pl->object_time_steps[i] : 1;
        if (o->kind == OBJ_SPHERE)
            b += 256 * steps;
        else
            b += steps * ((uint64_t)o->nv * 12 + (uint64_t)o->nt * (steps > 1 ? 64 : 128)) + (uint64_t)o->nt * 12;
    }
    return b;
}

static csi_status build_mesh(csi_tracer *tr, size_t i, RTCGeometry *out)
{
    const tr_object *o = &tr->sc->objects[i];
    uint32_t steps = tr->pl->object_time_steps[i];
    RTCGeometry g = rtcNewGeometry(tr->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!g)
        return csi_fail(CSI_ERR_NOMEM, "Embree: cannot create a triangle mesh (%s)",
                        tr->embree_error);
    if (steps > 1)
        rtcSetGeometryTimeStepCount(g, steps);
    for (uint32_t k = 0; k < steps; k++) {
        double s = steps > 1 ? (double)k / (steps - 1) : 0;
        tr_xform x;
        tr_motion_eval(tr->sc, &o->motion, s, &x);
        float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, k, RTC_FORMAT_FLOAT3,
                                            3 * sizeof(float), o->nv);
        if (!vb) {
            rtcReleaseGeometry(g);
            return csi_fail(CSI_ERR_NOMEM, "Embree: cannot allocate %zu vertices (%s)", o->nv,
                            tr->embree_error);
        }
        for (size_t v = 0; v < o->nv; v++) {
            double p[3] = {o->pos[3 * v], o->pos[3 * v + 1], o->pos[3 * v + 2]}, q[3];
            tr_xform_point(&x, p, q);
            for (int j = 0; j < 3; j++)
                vb[3 * v + j] = (float)q[j];
        }
    }
    uint32_t *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(uint32_t), o->nt);
    if (!ib) {
        rtcReleaseGeometry(g);
        return csi_fail(CSI_ERR_NOMEM, "Embree: cannot allocate %zu triangles (%s)", o->nt,
                        tr->embree_error);
    }
    memcpy(ib, o->tri, 3 * o->nt * sizeof(uint32_t));
    *out = g;
    return CSI_OK;
}

static csi_status build_sphere(csi_tracer *tr, size_t i, RTCGeometry *out)
{
    tr_geom *gd = &tr->geoms[i];
    RTCGeometry g = rtcNewGeometry(tr->dev, RTC_GEOMETRY_TYPE_USER);
    if (!g)
        return csi_fail(CSI_ERR_NOMEM, "Embree: cannot create a user geometry (%s)",
                        tr->embree_error);
    if (gd->steps > 1)
        rtcSetGeometryTimeStepCount(g, gd->steps);
    gd->pad = sphere_motion_pad(gd);
    rtcSetGeometryUserPrimitiveCount(g, 1);
    rtcSetGeometryUserData(g, gd);
    rtcSetGeometryBoundsFunction(g, sphere_bounds, NULL);
    rtcSetGeometryIntersectFunction(g, sphere_intersect);
    rtcSetGeometryOccludedFunction(g, sphere_occluded);
    *out = g;
    return CSI_OK;
}

csi_status csi_tracer_create(const csi_scene *sc, const csi_plan *pl, unsigned threads,
                             csi_tracer **out)
{
    *out = NULL;
    if (!sc || !pl)
        return csi_fail(CSI_ERR_ARG, "csi_tracer_create: NULL scene or plan");
    if (pl->n_objects != sc->n_objects || !pl->object_time_steps)
        return csi_fail(CSI_ERR_ARG, "csi_tracer_create: the plan was not made for this scene");
    for (size_t i = 0; i < sc->n_objects; i++)
        if (pl->object_time_steps[i] < 1 || pl->object_time_steps[i] > CSI_MAX_TIME_STEPS)
            return csi_fail(CSI_ERR_ARG, "object %zu: %u time steps (Embree allows 1..%d)", i,
                            pl->object_time_steps[i], CSI_MAX_TIME_STEPS);
    csi_tracer *tr = calloc(1, sizeof *tr);
    if (!tr)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (tracer)");
    tr->sc = sc;
    tr->pl = pl;
    if (threads == 0) {
        long n = sysconf(_SC_NPROCESSORS_ONLN);
        threads = n > 0 ? (unsigned)n : 1;
    }
    if (threads > 256)
        threads = 256;
    tr->threads = threads;
    pthread_mutex_init(&tr->lock, NULL);
    tr->geoms = calloc(sc->n_objects ? sc->n_objects : 1, sizeof *tr->geoms);
    tr->dev = rtcNewDevice(NULL);
    if (!tr->geoms || !tr->dev) {
        csi_status st = tr->geoms ? csi_fail(CSI_ERR_DEVICE, "Embree: cannot create a device: %d",
                                             (int)rtcGetDeviceError(NULL))
                                  : csi_fail(CSI_ERR_NOMEM, "out of memory (tracer)");
        csi_tracer_free(tr);
        return st;
    }
    rtcSetDeviceErrorFunction(tr->dev, embree_error, tr);
    tr->scene = rtcNewScene(tr->dev);
    /* Robust traversal: thin fence wires and grass blades must not leak rays at edges. */
    rtcSetSceneFlags(tr->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(tr->scene, RTC_BUILD_QUALITY_HIGH);
    csi_status st = CSI_OK;
    for (size_t i = 0; i < sc->n_objects && st == CSI_OK; i++) {
        tr_geom *gd = &tr->geoms[i];
        gd->sc = sc;
        gd->obj = &sc->objects[i];
        gd->steps = pl->object_time_steps[i];
        tr_motion_eval(sc, &gd->obj->motion, 0, &gd->x0);
        if (!tr_xform_invert(&gd->x0, &gd->inv0)) {
            st = csi_fail(CSI_ERR_SCENE, "object %zu: singular transform", i);
            break;
        }
        RTCGeometry g = NULL;
        st = gd->obj->kind == OBJ_SPHERE ? build_sphere(tr, i, &g) : build_mesh(tr, i, &g);
        if (st != CSI_OK)
            break;
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(tr->scene, g, (unsigned)i);
        rtcReleaseGeometry(g);
        tr->info.geometries++;
        if (gd->steps > 1)
            tr->info.motion_geometries++;
    }
    if (st == CSI_OK) {
        rtcCommitScene(tr->scene);
        if (tr->embree_error[0])
            st = csi_fail(CSI_ERR_DEVICE, "%s", tr->embree_error);
    }
    if (st != CSI_OK) {
        csi_tracer_free(tr);
        return st;
    }
    tr->info.threads = threads;
    *out = tr;
    return CSI_OK;
}

void csi_tracer_free(csi_tracer *tr)
{
    if (!tr)
        return;
    if (tr->scene)
        rtcReleaseScene(tr->scene);
    if (tr->dev)
        rtcReleaseDevice(tr->dev);
    free(tr->geoms);
    pthread_mutex_destroy(&tr->lock);
    free(tr);
}

/* ---- random numbers: a counter-based stream per sample -------------------------------------- */

typedef struct rng {
    uint64_t s;
} rng;

static inline uint64_t splitmix64(uint64_t *x)
{
    /* Steele, Lea, Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014. */
    uint64_t z = (*x += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static inline void rng_init(rng *r, uint64_t seed, uint64_t index)
{
    uint64_t a = seed;
    uint64_t h = splitmix64(&a) ^ (index * 0xd1342543de82ef95ull);
    r->s = splitmix64(&h);
}

static inline double rnd(rng *r)
{
    return (double)(splitmix64(&r->s) >> 11) * (1.0 / 9007199254740992.0);
}

/* The key of the cells' random points' streams: the seed's, xor'd with the first 64 bits of the
 * fractional part of sqrt(2) (a constant with nothing to hide). */
#define JITTER_STREAM 0x6a09e667f3bcc908ull

/* ---- shading -------------------------------------------------------------------------------- */

typedef struct tctx {
    csi_tracer *tr;
    struct RTCIntersectContext ictx;
    csi_tracer_counters c;
    bool timed;
    double eps_scale;
} tctx;

typedef struct shit {
    bool hit;
    double t, p[3], n[3];
    unsigned geom, prim;
    float u, v;
} shit;

static void trace(tctx *cx, const double o[3], const double d[3], double tnear, double s,
                  shit *h)
{
    struct RTCRayHit rh;
    rh.ray.org_x = (float)o[0];
    rh.ray.org_y = (float)o[1];
    rh.ray.org_z = (float)o[2];
    rh.ray.dir_x = (float)d[0];
    rh.ray.dir_y = (float)d[1];
    rh.ray.dir_z = (float)d[2];
    rh.ray.tnear = (float)tnear;
    rh.ray.tfar = INFINITY;
    rh.ray.time = (float)s;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(cx->tr->scene, &cx->ictx, &rh);
    if (cx->timed)
        cx->c.timed_rays++;
    h->hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    if (!h->hit)
        return;
    h->t = rh.ray.tfar;
    h->geom = rh.hit.geomID;
    h->prim = rh.hit.primID;
    h->u = rh.hit.u;
    h->v = rh.hit.v;
    double n[3] = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
    double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(l > 0))
        l = 1, n[0] = -d[0], n[1] = -d[1], n[2] = -d[2];
    double sg = (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) > 0 ? -1 : 1; /* two-sided */
    for (int i = 0; i < 3; i++) {
        h->n[i] = sg * n[i] / l;
        h->p[i] = o[i] + h->t * d[i];
    }
}

/* true if the segment from o along d (unit) is blocked before tfar */
static bool occluded(tctx *cx, const double o[3], const double d[3], double tfar, double s)
{
    struct RTCRay r;
    r.org_x = (float)o[0];
    r.org_y = (float)o[1];
    r.org_z = (float)o[2];
    r.dir_x = (float)d[0];
    r.dir_y = (float)d[1];
    r.dir_z = (float)d[2];
    r.tnear = 0;
    r.tfar = (float)tfar;
    r.time = (float)s;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    rtcOccluded1(cx->tr->scene, &cx->ictx, &r);
    if (cx->timed)
        cx->c.timed_rays++;
    return r.tfar < 0;
}

/* true if something lies between the (offset) point o and the light point q */
static bool shadowed(tctx *cx, const double o[3], const double q[3], double s)
{
    double d[3] = {q[0] - o[0], q[1] - o[1], q[2] - o[2]};
    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(dl > 0))
        return false;
    for (int i = 0; i < 3; i++)
        d[i] /= dl;
    return occluded(cx, o, d, dl * (1 - 1e-6), s);
}

static void tex_fetch(const tr_texture *tx, double u, double v, float out[3])
{
    /* bilinear, repeating; texel centres at (i + 0.5) / w */
    double x = u * tx->w - 0.5, y = v * tx->h - 0.5;
    double fx = floor(x), fy = floor(y);
    double ax = x - fx, ay = y - fy;
    long ix = (long)fmod(fx, (double)tx->w), iy = (long)fmod(fy, (double)tx->h);
    if (ix < 0)
        ix += tx->w;
    if (iy < 0)
        iy += tx->h;
    long ix1 = (ix + 1) % (long)tx->w, iy1 = (iy + 1) % (long)tx->h;
    const float *p00 = tx->rgb + 3 * ((size_t)iy * tx->w + ix);
    const float *p10 = tx->rgb + 3 * ((size_t)iy * tx->w + ix1);
    const float *p01 = tx->rgb + 3 * ((size_t)iy1 * tx->w + ix);
    const float *p11 = tx->rgb + 3 * ((size_t)iy1 * tx->w + ix1);
    for (int c = 0; c < 3; c++)
        out[c] = (float)((1 - ay) * ((1 - ax) * p00[c] + ax * p10[c]) +
                         ay * ((1 - ax) * p01[c] + ax * p11[c]));
}

static void surface_albedo(tctx *cx, const shit *h, float alb[3], const float **emis)
{
    const csi_scene *sc = cx->tr->sc;
    const tr_object *o = &sc->objects[h->geom];
    const tr_material *m = &sc->materials[o->material];
    *emis = m->emission;
    if (m->kind == MAT_DIFFUSE) {
        memcpy(alb, m->albedo, 3 * sizeof(float));
        return;
    }
    double uv[2];
    if (o->kind == OBJ_SPHERE) {
        uv[0] = h->u;
        uv[1] = h->v;
    } else if (o->uv) {
        const uint32_t *t = &o->tri[3 * h->prim];
        double b0 = 1.0 - h->u - h->v;
        for (int k = 0; k < 2; k++)
            uv[k] = b0 * o->uv[2 * t[0] + k] + h->u * o->uv[2 * t[1] + k] +
                    h->v * o->uv[2 * t[2] + k];
    } else {
        /* no uvs: world coordinates across the dominant normal axis */
        int ax = fabs(h->n[0]) > fabs(h->n[1]) ? (fabs(h->n[0]) > fabs(h->n[2]) ? 0 : 2)
                                               : (fabs(h->n[1]) > fabs(h->n[2]) ? 1 : 2);
        uv[0] = h->p[(ax + 1) % 3];
        uv[1] = h->p[(ax + 2) % 3];
    }
    uv[0] *= m->uv_scale[0];
    uv[1] *= m->uv_scale[1];
    if (m->kind == MAT_CHECKER) {
        cx->c.checker_lookups++;
        long a = (long)floor(uv[0] / m->checker_size) + (long)floor(uv[1] / m->checker_size);
        memcpy(alb, (a & 1) ? m->albedo2 : m->albedo, 3 * sizeof(float));
    } else {
        cx->c.texture_lookups++;
        tex_fetch(&sc->textures[m->texture], uv[0], uv[1], alb);
    }
}

/* A cosine-distributed direction about n (Malley's method: PBRT 3rd ed., 13.6.3). */
static void cosine_dir(const double n[3], double r1, double r2, double d[3])
{
    double rad = sqrt(r1), phi = 2 * M_PI * r2;
    double x = rad * cos(phi), y = rad * sin(phi), z = sqrt(fmax(0, 1 - r1));
    /* orthonormal basis (Duff et al., "Building an orthonormal basis, revisited", 2017) */
    double sgn = copysign(1.0, n[2]);
    double a = -1.0 / (sgn + n[2]), b = n[0] * n[1] * a;
    double t[3] = {1 + sgn * n[0] * n[0] * a, sgn * b, -sgn * n[0]};
    double bb[3] = {b, sgn + n[1] * n[1] * a, -n[1]};
    for (int i = 0; i < 3; i++)
        d[i] = x * t[i] + y * bb[i] + z * n[i];
}

static double offset_eps(const shit *h)
{
    /* float hit points carry ~1e-7 relative error: offset 100x that, scaled by magnitude */
    double m = fmax(fmax(fabs(h->p[0]), fabs(h->p[1])), fabs(h->p[2]));
    return 1e-5 * (m + h->t) + 1e-7;
}

/* Light arriving at the hit from explicit lights and ambient occlusion, times albedo. */
static void direct(tctx *cx, const shit *h, const float alb[3], double s, rng *r, double L[3])
{
    const csi_scene *sc = cx->tr->sc;
    double eps = offset_eps(h);
    double o[3] = {h->p[0] + eps * h->n[0], h->p[1] + eps * h->n[1], h->p[2] + eps * h->n[2]};
    for (size_t li = 0; li < sc->n_lights; li++) {
        const tr_light *Lt = &sc->lights[li];
        if (Lt->kind == LIGHT_POINT) {
            /* geometry from the surface point; only the shadow ray starts at the offset one */
            double d[3] = {Lt->position[0] - h->p[0], Lt->position[1] - h->p[1],
                           Lt->position[2] - h->p[2]};
            double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], dl = sqrt(d2);
            if (!(dl > 0))
                continue;
            for (int i = 0; i < 3; i++)
                d[i] /= dl;
            double cs = d[0] * h->n[0] + d[1] * h->n[1] + d[2] * h->n[2];
            if (cs <= 0)
                continue;
            cx->c.shadow_rays++;
            if (shadowed(cx, o, Lt->position, s))
                continue;
            double f = cs / (d2 * M_PI);
            for (int c = 0; c < 3; c++)
                L[c] += alb[c] * Lt->color[c] * f;
        } else if (Lt->kind == LIGHT_DIRECTIONAL) {
            double d[3] = {-Lt->direction[0], -Lt->direction[1], -Lt->direction[2]};
            double cs = d[0] * h->n[0] + d[1] * h->n[1] + d[2] * h->n[2];
            if (cs <= 0)
                continue;
            cx->c.shadow_rays++;
            if (occluded(cx, o, d, INFINITY, s))
                continue;
            for (int c = 0; c < 3; c++)
                L[c] += alb[c] * Lt->color[c] * cs / M_PI;
        } else {
            /* Uniform area sampling of the quad: E = sum Le cos cos' A / (r^2 n) (PBRT 14.2). */
            double acc = 0;
            for (uint32_t k = 0; k < Lt->samples; k++) {
                double a = rnd(r), b = rnd(r);
                double q[3], d[3];
                for (int i = 0; i < 3; i++) {
                    q[i] = Lt->corner[i] + a * Lt->eu[i] + b * Lt->ev[i];
                    d[i] = q[i] - h->p[i];
                }
                double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], dl = sqrt(d2);
                if (!(dl > 0))
                    continue;
                for (int i = 0; i < 3; i++)
                    d[i] /= dl;
                double cs = d[0] * h->n[0] + d[1] * h->n[1] + d[2] * h->n[2];
                double cl = -(d[0] * Lt->normal[0] + d[1] * Lt->normal[1] + d[2] * Lt->normal[2]);
                if (cs <= 0 || cl <= 0)
                    continue;
                cx->c.shadow_rays++;
                if (shadowed(cx, o, q, s))
                    continue;
                acc += cs * cl / d2;
            }
            double f = acc * Lt->area / (Lt->samples * M_PI);
            for (int c = 0; c < 3; c++)
                L[c] += alb[c] * Lt->color[c] * f;
        }
    }
    if (sc->ao) {
        /* Ambient light of colour ao_color blocked within ao_distance; with cosine-weighted
         * directions the estimator of (1/pi) integral V cos is the unblocked fraction. */
        uint32_t open = 0;
        for (uint32_t k = 0; k < sc->ao_samples; k++) {
            double d[3];
            cosine_dir(h->n, rnd(r), rnd(r), d);
            cx->c.ao_rays++;
            if (!occluded(cx, o, d, sc->ao_distance, s))
                open++;
        }
        double f = (double)open / sc->ao_samples;
        for (int c = 0; c < 3; c++)
            L[c] += alb[c] * sc->ao_color[c] * f;
    }
}

static void radiance(tctx *cx, double u, double v, double s, rng *r, float out[3])
{
    const csi_scene *sc = cx->tr->sc;
    double o[3], d[3];
    csi_scene_camera_ray(sc, u, v, s, o, d);
    double L[3] = {0, 0, 0}, thr[3] = {1, 1, 1};
    shit h;
    cx->c.primary_rays++;
    trace(cx, o, d, 0, s, &h);
    uint32_t depth = 0;
    for (;;) {
        if (!h.hit) {
            for (int c = 0; c < 3; c++)
                L[c] += thr[c] * sc->background[c];
            break;
        }
        float alb[3];
        const float *em;
        surface_albedo(cx, &h, alb, &em);
        double Ld[3] = {0, 0, 0};
        direct(cx, &h, alb, s, r, Ld);
        for (int c = 0; c < 3; c++)
            L[c] += thr[c] * (em[c] + Ld[c]);
        if (!sc->path || depth >= sc->max_bounces)
            break;
        /* Bounce: cosine sampling makes the Lambertian weight f cos / pdf = albedo. */
        double nd[3];
        cosine_dir(h.n, rnd(r), rnd(r), nd);
        for (int c = 0; c < 3; c++)
            thr[c] *= alb[c];
        depth++;
        if (depth > sc->roulette_start) {
            double q = fmin(0.95, fmax(thr[0], fmax(thr[1], thr[2])));
            if (!(rnd(r) < q))
                break;
            for (int c = 0; c < 3; c++)
                thr[c] /= q;
        }
        if (!(thr[0] > 0 || thr[1] > 0 || thr[2] > 0))
            break;
        double eps = offset_eps(&h);
        double no[3] = {h.p[0] + eps * h.n[0], h.p[1] + eps * h.n[1], h.p[2] + eps * h.n[2]};
        cx->c.secondary_rays++;
        trace(cx, no, nd, 0, s, &h);
    }
    for (int c = 0; c < 3; c++)
        out[c] = (float)L[c];
}

/* ---- threads -------------------------------------------------------------------------------- */

typedef struct job {
    csi_tracer *tr;
    const csi_grid *grid;
    const csi_sample_pos *pos;
    const uint64_t *ids; /* sample indices in a larger set (NULL: 0 .. n - 1) */
    const float *uvs;
    size_t n;
    uint64_t seed;
    float *rgb;
    atomic_size_t next, done;
    pthread_mutex_t m;
    pthread_cond_t cv;
    unsigned finished;
} job;

enum { CHUNK = 64 };

static void *worker(void *arg)
{
    job *jb = arg;
    csi_tracer *tr = jb->tr;
#ifdef TR_HAVE_SSE
    /* Embree's advice: flush denormals to zero on every thread that traces. */
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
#endif
    tctx cx;
    memset(&cx, 0, sizeof cx);
    cx.tr = tr;
    cx.timed = tr->pl->motion;
    rtcInitIntersectContext(&cx.ictx);
    bool motion = tr->pl->motion;
    for (;;) {
        size_t b = atomic_fetch_add(&jb->next, CHUNK);
        if (b >= jb->n)
            break;
        size_t e = b + CHUNK < jb->n ? b + CHUNK : jb->n;
        for (size_t i = b; i < e; i++) {
            double u, v, s;
            if (jb->pos) {
                const csi_grid *g = jb->grid;
                double ju = 0.5, jv = 0.5, js = 0.5;
                if (tr->cell_jitter) {
                    /* a stream of its own, so that the shading's numbers stay those of the
                     * cell's centre */
                    rng q;
                    rng_init(&q, jb->seed ^ JITTER_STREAM, jb->ids ? jb->ids[i] : i);
                    ju = rnd(&q), jv = rnd(&q), js = rnd(&q);
                }
                u = (jb->pos[i].x + ju) / g->w;
                v = (jb->pos[i].y + jv) / g->h;
                s = g->t > 1 ? (jb->pos[i].t + js) / g->t : 0;
            } else {
                u = jb->uvs[3 * i];
                v = jb->uvs[3 * i + 1];
                s = jb->uvs[3 * i + 2];
            }
            if (!motion)
                s = 0;
            rng r;
            rng_init(&r, jb->seed, jb->ids ? jb->ids[i] : i);
            radiance(&cx, u, v, s, &r, jb->rgb + 3 * i);
            cx.c.samples++;
        }
        atomic_fetch_add(&jb->done, e - b);
    }
    pthread_mutex_lock(&tr->lock);
    csi_tracer_counters *c = &tr->counters;
    c->samples += cx.c.samples;
    c->primary_rays += cx.c.primary_rays;
    c->secondary_rays += cx.c.secondary_rays;
    c->shadow_rays += cx.c.shadow_rays;
    c->ao_rays += cx.c.ao_rays;
    c->timed_rays += cx.c.timed_rays;
    c->texture_lookups += cx.c.texture_lookups;
    c->checker_lookups += cx.c.checker_lookups;
    pthread_mutex_unlock(&tr->lock);
    pthread_mutex_lock(&jb->m);
    jb->finished++;
    pthread_cond_signal(&jb->cv);
    pthread_mutex_unlock(&jb->m);
    return NULL;
}

static csi_status run_job(csi_tracer *tr, job *jb, csi_tracer_progress_fn progress, void *user)
{
    atomic_init(&jb->next, 0);
    atomic_init(&jb->done, 0);
    pthread_mutex_init(&jb->m, NULL);
    pthread_cond_init(&jb->cv, NULL);
    jb->finished = 0;
    unsigned nt = tr->threads;
    size_t chunks = (jb->n + CHUNK - 1) / CHUNK;
    if (nt > chunks)
        nt = chunks ? (unsigned)chunks : 1;
    pthread_t th[256];
    unsigned started = 0;
    for (; started < nt; started++)
        if (pthread_create(&th[started], NULL, worker, jb) != 0)
            break;
    if (started == 0) {
        pthread_mutex_destroy(&jb->m);
        pthread_cond_destroy(&jb->cv);
        return csi_fail(CSI_ERR_NOMEM, "cannot start a tracing thread");
    }
    pthread_mutex_lock(&jb->m);
    while (jb->finished < started) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        ts.tv_nsec += 200000000L;
        if (ts.tv_nsec >= 1000000000L) {
            ts.tv_sec++;
            ts.tv_nsec -= 1000000000L;
        }
        pthread_cond_timedwait(&jb->cv, &jb->m, &ts);
        if (progress && jb->finished < started) {
            size_t d = atomic_load(&jb->done);
            pthread_mutex_unlock(&jb->m);
            progress(d, jb->n, user);
            pthread_mutex_lock(&jb->m);
        }
    }
    pthread_mutex_unlock(&jb->m);
    for (unsigned i = 0; i < started; i++)
        pthread_join(th[i], NULL);
    pthread_mutex_destroy(&jb->m);
    pthread_cond_destroy(&jb->cv);
    if (progress)
        progress(jb->n, jb->n, user);
    return CSI_OK;
}

csi_status csi_tracer_eval(csi_tracer *tr, const csi_grid *grid, const csi_sample_pos *pos,
                           size_t n, uint64_t seed, float *rgb, csi_tracer_progress_fn progress,
                           void *user)
{
    return csi_tracer_eval_ids(tr, grid, pos, NULL, n, seed, rgb, progress, user);
}

csi_status csi_tracer_eval_ids(csi_tracer *tr, const csi_grid *grid, const csi_sample_pos *pos,
                               const uint64_t *ids, size_t n, uint64_t seed, float *rgb,
                               csi_tracer_progress_fn progress, void *user)
{
    if (!tr || !grid || (n && (!pos || !rgb)))
        return csi_fail(CSI_ERR_ARG, "csi_tracer_eval: NULL argument");
    if (grid->w == 0 || grid->h == 0 || grid->t == 0)
        return csi_fail(CSI_ERR_ARG, "csi_tracer_eval: empty grid %ux%ux%u", grid->w, grid->h,
                        grid->t);
    if (grid->t != tr->pl->frames)
        return csi_fail(CSI_ERR_ARG,
                        "csi_tracer_eval: grid has %u frames but the plan asks for T = %u",
                        grid->t, tr->pl->frames);
    for (size_t i = 0; i < n; i++)
        if (pos[i].x >= grid->w || pos[i].y >= grid->h || pos[i].t >= grid->t)
            return csi_fail(CSI_ERR_ARG,
                            "csi_tracer_eval: sample %zu at (%u, %u, %u) lies outside the "
                            "%ux%ux%u grid",
                            i, pos[i].x, pos[i].y, pos[i].t, grid->w, grid->h, grid->t);
    job jb;
    memset(&jb, 0, sizeof jb);
    jb.tr = tr;
    jb.grid = grid;
    jb.pos = pos;
    jb.ids = ids;
    jb.n = n;
    jb.seed = seed;
    jb.rgb = rgb;
    return run_job(tr, &jb, progress, user);
}

csi_status csi_tracer_eval_points(csi_tracer *tr, const float *uvs, size_t n, uint64_t seed,
                                  float *rgb, csi_tracer_progress_fn progress, void *user)
{
    if (!tr || (n && (!uvs || !rgb)))
        return csi_fail(CSI_ERR_ARG, "csi_tracer_eval_points: NULL argument");
    for (size_t i = 0; i < 3 * n; i++)
        if (!(uvs[i] >= 0.0f && uvs[i] <= 1.0f))
            return csi_fail(CSI_ERR_ARG,
                            "csi_tracer_eval_points: point %zu has a coordinate outside [0, 1]",
                            i / 3);
    job jb;
    memset(&jb, 0, sizeof jb);
    jb.tr = tr;
    jb.uvs = uvs;
    jb.n = n;
    jb.seed = seed;
    jb.rgb = rgb;
    return run_job(tr, &jb, progress, user);
}

void csi_tracer_set_cell_jitter(csi_tracer *tr, bool jitter)
{
    if (tr)
        tr->cell_jitter = jitter;
}

void csi_tracer_counters_get(const csi_tracer *tr, csi_tracer_counters *c)
{
    pthread_mutex_lock((pthread_mutex_t *)&tr->lock);
    *c = tr->counters;
    pthread_mutex_unlock((pthread_mutex_t *)&tr->lock);
}

void csi_tracer_counters_reset(csi_tracer *tr)
{
    pthread_mutex_lock(&tr->lock);
    memset(&tr->counters, 0, sizeof tr->counters);
    pthread_mutex_unlock(&tr->lock);
}

void csi_tracer_info_get(const csi_tracer *tr, csi_tracer_info *info) { *info = tr->info; }

csi_status csi_tracer_intersect(csi_tracer *tr, const double org[3], const double dir[3],
                                double s, csi_hit *hit)
{
    memset(hit, 0, sizeof *hit);
    if (!tr || !org || !dir)
        return csi_fail(CSI_ERR_ARG, "csi_tracer_intersect: NULL argument");
    if (!(s >= 0 && s <= 1))
        return csi_fail(CSI_ERR_ARG, "csi_tracer_intersect: time %g outside [0, 1]", s);
    tctx cx;
    memset(&cx, 0, sizeof cx);
    cx.tr = tr;
    rtcInitIntersectContext(&cx.ictx);
    shit h;
    trace(&cx, org, dir, 0, tr->pl->motion ? s : 0, &h);
    hit->hit = h.hit;
    if (h.hit) {
        hit->distance = h.t;
        memcpy(hit->point, h.p, sizeof h.p);
        memcpy(hit->normal, h.n, sizeof h.n);
        hit->object = h.geom;
    }
    return CSI_OK;
}
