/* csi tracer: a small Embree 3 sampler that evaluates linear RGB radiance at given sample
 * positions of a scene (docs/scene-format.md), simulating only what the scene declares.
 *
 * Flow:
 *     csi_scene *sc;  csi_plan pl;  csi_tracer *tr;
 *     csi_scene_load("data/scenes/billiards.scene", &sc);
 *     csi_plan_make(sc, NULL, &pl);              // T, motion geometry, effects
 *     csi_plan_json(sc, &pl, stdout);            // what will be simulated, as JSON
 *     csi_tracer_create(sc, &pl, 0, &tr);        // Embree scene: motion geometry only if moving
 *     csi_tracer_eval(tr, &grid, pos, n, seed, rgb, progress, user);
 *     csi_tracer_counters(tr, &c);               // rays cast, shadow rays, texture lookups ...
 *     csi_tracer_free(tr); csi_plan_free(&pl); csi_scene_free(sc);
 *
 * Image space: u to the right, v down, both in [0, 1] over the image; time s in [0, 1] over the
 * shutter interval. A grid sample (x, y, t) stands for the centre of its fine-grid cell:
 * u = (x + 0.5) / w, v = (y + 0.5) / h, s = (t + 0.5) / T (s = 0 when T = 1; see csi/samples.h),
 * or for a random point of it (csi_tracer_set_cell_jitter).
 *
 * Errors: every function returns a csi_status and leaves a message (csi_last_error()); scene
 * errors read "path:line:column: expected ..., found ..." with status CSI_ERR_SCENE.
 * This module never includes OpenCL. */
#ifndef CSI_TRACER_H
#define CSI_TRACER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "csi/csi.h" /* csi_status, csi_grid, csi_sample_pos: a program including this header
                        needs no other of csi's (csi-render is built against the public headers) */

#ifdef __cplusplus
extern "C" {
#endif

/* Embree 3 accepts at most 129 time steps per motion geometry. */
#define CSI_MAX_TIME_STEPS 129

typedef struct csi_scene csi_scene;
typedef struct csi_tracer csi_tracer;

/* ---- scene ---------------------------------------------------------------------------------- */

/* Parses a scene file (and the OBJ and PNG/EXR files it names, relative to the scene file's
 * directory). On failure *out is NULL. */
csi_status csi_scene_load(const char *path, csi_scene **out);
/* Same, from text in memory; `name` is used in messages and `base_dir` resolves file names. */
csi_status csi_scene_parse(const char *text, const char *name, const char *base_dir,
                           csi_scene **out);
void csi_scene_free(csi_scene *scene);

/* The files the scene read besides itself (OBJ meshes, textures), in the order read. */
size_t csi_scene_input_count(const csi_scene *scene);
const char *csi_scene_input(const csi_scene *scene, size_t i);

/* Image size declared by the camera (`size W H`). */
void csi_scene_image_size(const csi_scene *scene, uint32_t *width, uint32_t *height);
/* Number of objects (spheres, planes, boxes, meshes) in file order. */
size_t csi_scene_object_count(const csi_scene *scene);

/* The primary ray through image point (u, v) at shutter time s in [0, 1] (pinhole camera,
 * vertical field of view, motion keys applied). dir is unit length. */
void csi_scene_camera_ray(const csi_scene *scene, double u, double v, double s, double org[3],
                          double dir[3]);

/* Maps an object-space point of object `index` to world space at shutter time s in [0, 1]
 * (the exact keyed transform, before Embree's per-step linear interpolation). */
void csi_scene_object_point(const csi_scene *scene, size_t index, double s, const double p[3],
                            double out[3]);

/* ---- plan ----------------------------------------------------------------------------------- */

typedef struct csi_plan_overrides {
    uint32_t frames; /* 0: the rule (or the scene's `frames`); otherwise T for a moving scene */
} csi_plan_overrides;

typedef struct csi_plan {
    uint32_t width, height;       /* image size (camera) */
    uint32_t frames;              /* T: 1 when nothing moves in the shutter */
    bool motion;                  /* anything (camera or object) moves: rays carry time */
    bool camera_moves;
    bool camera_pans;             /* it moves by translation alone, across its view (no turn,
                                     zoom or dolly): the picture pans, parallax aside */
    double motion_pixels;         /* largest on-screen travel over the shutter, in pixels */
    const char *frames_rule;      /* "static", "rule", "scene", "override" */
    size_t n_objects;
    uint32_t *object_time_steps;  /* per object: 1 = static geometry, >= 2 = Embree motion */
    size_t n_moving_objects;
    size_t n_point_lights, n_directional_lights, n_area_lights;
    uint32_t shadow_rays_per_hit; /* point + directional + sum of area samples; 0 = none cast */
    bool image_textures;          /* some material that is used samples an image */
    bool checker_textures;        /* some material that is used is a procedural checkerboard */
    bool ambient_occlusion;
    uint32_t ao_samples;
    double ao_distance;
    bool path_tracing;
    uint32_t max_bounces, roulette_start;
    bool exact;                   /* no random number is drawn (no area light, ambient
                                     occlusion or path tracing): every value is the noise-free
                                     radiance at its cell's centre (csi/csi.h CSI_SAMPLES_EXACT) */
} csi_plan;

/* Decides what is simulated (docs/scene-format.md, "The plan"). overrides may be NULL.
 * Rule for T when something moves: T = clamp(next power of two >= ceil(motion_pixels), 8, 64),
 * unless the scene says `frames N` or overrides->frames is set. */
csi_status csi_plan_make(const csi_scene *scene, const csi_plan_overrides *overrides,
                         csi_plan *plan);
void csi_plan_free(csi_plan *plan);
/* Writes the plan as one JSON object (followed by a newline). */
csi_status csi_plan_json(const csi_scene *scene, const csi_plan *plan, FILE *out);
/* Same into a malloc'd string (caller frees). */
csi_status csi_plan_json_string(const csi_scene *scene, const csi_plan *plan, char **out);

/* ---- tracing -------------------------------------------------------------------------------- */

/* What the tracer did, summed over threads and calls since creation (or the last reset). */
typedef struct csi_tracer_counters {
    uint64_t samples;           /* radiance evaluations */
    uint64_t primary_rays;      /* camera rays */
    uint64_t secondary_rays;    /* path-tracing bounce rays (closest hit) */
    uint64_t shadow_rays;       /* rtcOccluded1 calls for lights */
    uint64_t ao_rays;           /* rtcOccluded1 calls for ambient occlusion */
    uint64_t timed_rays;        /* rays of any kind that carried a time (motion scenes only) */
    uint64_t texture_lookups;   /* image texture fetches (bilinear = one lookup) */
    uint64_t checker_lookups;   /* procedural checkerboard evaluations */
} csi_tracer_counters;

/* Embree geometry actually built. */
typedef struct csi_tracer_info {
    uint32_t geometries;        /* Embree geometries (one per object) */
    uint32_t motion_geometries; /* of which with time steps > 1 */
    uint32_t threads;
} csi_tracer_info;

/* Progress: done of total samples; called from the calling thread only, a few times a second
 * and once at the end with done == total. */
typedef void (*csi_tracer_progress_fn)(uint64_t done, uint64_t total, void *user);

/* Builds the Embree scene for the plan. threads = 0: one per online CPU. scene and plan must
 * outlive the tracer. */
csi_status csi_tracer_create(const csi_scene *scene, const csi_plan *plan, unsigned threads,
                             csi_tracer **out);
void csi_tracer_free(csi_tracer *tr);
/* The host bytes csi_tracer_create will hold for this scene and plan (vertex buffers per time
 * step, indices, an estimate of Embree's BVH and threads), before making it. */
uint64_t csi_tracer_host_bytes(const csi_scene *scene, const csi_plan *plan);

/* Where csi_tracer_eval and csi_tracer_eval_ids place a sample in its cell: the centre (the
 * default) or, with jitter, a uniform random point of the cell in x, y and t drawn from
 * (seed, sample index) on a stream apart from the shading's. A jittered sample's expected value
 * is its cell's mean radiance over the cell's area and time, so the mean of a pixel's samples is
 * an unbiased estimate of the pixel's box integral however its cells fall on an edge, where
 * centres give a fixed error that no number of samples removes. Monte Carlo baselines and
 * references need it to converge to the true integral; csi-render turns it on for those
 * (docs/scene-format.md, "Sampling contract"). */
void csi_tracer_set_cell_jitter(csi_tracer *tr, bool jitter);

/* Evaluates radiance (linear RGB, rgb[3*i..3*i+2]) at the centres of the grid cells pos[0..n)
 * (or random points of them: csi_tracer_set_cell_jitter).
 * grid->t must equal plan->frames; positions must lie inside the grid (grid->out_w/out_h are
 * not used: the image spans the whole grid). The random numbers of sample i depend only on
 * (seed, i): same inputs give the same bits for any thread count. The index restarts at 0 in
 * every call, so a caller that splits one set of samples into several calls must give each
 * call its own seed (e.g. seed + batch) or the batches share their noise. One call at a time
 * per tracer (the tracer runs its own threads). */
csi_status csi_tracer_eval(csi_tracer *tr, const csi_grid *grid, const csi_sample_pos *pos,
                           size_t n, uint64_t seed, float *rgb, csi_tracer_progress_fn progress,
                           void *user);

/* The same for a subset of a larger set of samples: the random numbers of sample i depend on
 * (seed, ids[i]), so samples traced here with their indices in the larger set get the values
 * they get there (a tile of an image traced alone). ids = NULL is csi_tracer_eval. */
csi_status csi_tracer_eval_ids(csi_tracer *tr, const csi_grid *grid, const csi_sample_pos *pos,
                               const uint64_t *ids, size_t n, uint64_t seed, float *rgb,
                               csi_tracer_progress_fn progress, void *user);

/* Same at continuous points: uvs[3*i..] = (u, v, s) with u, v in [0, 1] (image space, v down)
 * and s in [0, 1] (shutter time; ignored when the plan has no motion). For references. */
csi_status csi_tracer_eval_points(csi_tracer *tr, const float *uvs, size_t n, uint64_t seed,
                                  float *rgb, csi_tracer_progress_fn progress, void *user);

void csi_tracer_counters_get(const csi_tracer *tr, csi_tracer_counters *c);
void csi_tracer_counters_reset(csi_tracer *tr);
void csi_tracer_info_get(const csi_tracer *tr, csi_tracer_info *info);

/* One closest-hit query (for tests and tools) from org along dir (unit length, so distance is
 * a length) at shutter fraction s (ignored for a static plan): hit = false on a miss. normal
 * is the unit geometric normal facing against dir; object is the scene object index. Not
 * counted. */
typedef struct csi_hit {
    bool hit;
    double distance;
    double point[3], normal[3];
    size_t object;
} csi_hit;
csi_status csi_tracer_intersect(csi_tracer *tr, const double org[3], const double dir[3],
                                double s, csi_hit *hit);

#ifdef __cplusplus
}
#endif
#endif
