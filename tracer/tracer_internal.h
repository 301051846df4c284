/* Internal scene representation shared by the parser, the plan and the tracer. */
#ifndef CSI_TRACER_INTERNAL_H
#define CSI_TRACER_INTERNAL_H

#include "csi_tracer.h"
#include "csi/status.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct tr_key {
    double time;          /* in scene time units, inside the shutter */
    double translate[3];
    double axis[3];       /* unit rotation axis */
    double angle;         /* radians */
    double scale[3];
    int line, col;        /* where the key was written (for messages) */
} tr_key;

typedef struct tr_motion {
    size_t n;             /* 0: no keys (identity) */
    tr_key *keys;
} tr_motion;

typedef struct tr_texture {
    char path[1024];
    uint32_t w, h;
    float *rgb;           /* linear RGB, row 0 at the top (v = 0) */
} tr_texture;

enum { MAT_DIFFUSE, MAT_CHECKER, MAT_TEXTURE };

typedef struct tr_material {
    char name[64];
    int kind;
    float albedo[3], albedo2[3]; /* diffuse colour; checker's two colours */
    double checker_size;         /* uv units per square */
    int texture;                 /* index into textures (MAT_TEXTURE) */
    double uv_scale[2];
    float emission[3];
    bool used;
} tr_material;

enum { OBJ_MESH, OBJ_SPHERE };

typedef struct tr_object {
    int kind;
    const char *what;            /* "sphere", "plane", "box", "mesh" */
    int line;
    int material;
    /* mesh, object space */
    size_t nv, nt;
    float *pos;                  /* 3 * nv */
    float *uv;                   /* 2 * nv, or NULL */
    uint32_t *tri;               /* 3 * nt */
    /* sphere, object space */
    double center[3], radius;
    tr_motion motion;
} tr_object;

enum { LIGHT_POINT, LIGHT_DIRECTIONAL, LIGHT_AREA };

typedef struct tr_light {
    int kind;
    double position[3];          /* point */
    double direction[3];         /* directional: unit, direction the light travels */
    double corner[3], eu[3], ev[3]; /* area quad */
    double normal[3], area;      /* area: unit normal (eu x ev), area */
    float color[3];              /* intensity (point, W/sr), irradiance (dir), radiance (area) */
    uint32_t samples;            /* area */
} tr_light;

typedef struct tr_camera {
    double position[3], target[3], up[3];
    double fov_deg;
    uint32_t width, height;
    tr_motion motion;
} tr_camera;

struct csi_scene {
    char name[512];
    tr_camera camera;
    double shutter_open, shutter_close;
    float background[3];
    bool ao;
    uint32_t ao_samples;
    double ao_distance;
    float ao_color[3];
    bool path;
    uint32_t max_bounces, roulette_start;
    uint32_t frames;             /* 0 = rule */
    tr_material *materials;
    size_t n_materials;
    tr_texture *textures;
    size_t n_textures;
    tr_object *objects;
    size_t n_objects;
    tr_light *lights;
    size_t n_lights;
    double extent;               /* size of the scene's bounding box (for ray offsets) */
    char **inputs;               /* files read besides the scene: OBJ meshes, textures */
    size_t n_inputs;
};

/* ---- small vector helpers ------------------------------------------------------------------- */

static inline double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void cross3(const double a[3], const double b[3], double o[3])
{
    double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                   a[0] * b[1] - a[1] * b[0]};
    memcpy(o, r, sizeof r);
}
static inline double norm3(const double a[3]) { return sqrt(dot3(a, a)); }

/* Motion: the keyed transform at shutter fraction s in [0, 1]; p' = T + R (S * p). */
typedef struct tr_xform {
    double m[3][3];              /* R * diag(S) */
    double t[3];
} tr_xform;
void tr_motion_eval(const csi_scene *sc, const tr_motion *mo, double s, tr_xform *x);
bool tr_motion_moves(const tr_motion *mo);
static inline void tr_xform_point(const tr_xform *x, const double p[3], double o[3])
{
    for (int i = 0; i < 3; i++)
        o[i] = x->m[i][0] * p[0] + x->m[i][1] * p[1] + x->m[i][2] * p[2] + x->t[i];
}
static inline void tr_xform_dir(const tr_xform *x, const double p[3], double o[3])
{
    for (int i = 0; i < 3; i++)
        o[i] = x->m[i][0] * p[0] + x->m[i][1] * p[1] + x->m[i][2] * p[2];
}
/* Inverse of an affine transform; false if singular. */
bool tr_xform_invert(const tr_xform *x, tr_xform *inv);
/* Quaternion (w, x, y, z) of an axis-angle rotation and back (motion.c). */
void tr_aa_to_q(const double axis[3], double ang, double q[4]);
void tr_q_to_aa(const double q[4], double axis[3], double *ang);

/* Images (PNG 8/16 bit via libpng, sRGB decoded to linear; EXR via OpenEXR's C API). */
csi_status tr_image_load(const char *path, uint32_t *w, uint32_t *h, float **rgb);
/* Parses an OBJ mesh (v, vt, f; polygons fanned) of len bytes; `path` names it in messages. */
csi_status tr_obj_parse(const char *text, size_t len, const char *path, tr_object *o);

#endif
