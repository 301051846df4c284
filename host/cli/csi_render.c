/* csi-render: renders a scene with the Embree tracer at host-chosen sample positions and
 * reconstructs in the same process (compressive, or a Monte Carlo baseline). See --help. The
 * tracer is the project's own library (csi_tracer.h); the rest is a thin main over csi/csi.h (its
 * --tile runs: tile.h). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi_tracer.h"
#include "common.h"
#include "outputs.h"
#include "recon_opts.h"
#include "tile.h"

static const char *prog = "csi-render";

static void usage(FILE *f)
{
    fprintf(f,
"usage: csi-render SCENE -o OUT.exr [options]\n"
"       csi-render --plan SCENE\n"
"\n"
"Renders SCENE (docs/scene-format.md) with Embree at sample positions on a fine grid and\n"
"reconstructs the image in-process. Only what the scene calls for is simulated: a static\n"
"scene has no time axis (antialiasing, Alg. 1); a moving one is sampled in x, y, t (motion\n"
"blur, Alg. 2). --plan prints that decision as JSON.\n"
"\n"
"outputs:\n"
"  -o, --output FILE.exr     float32 EXR with the run's parameters as header attributes\n"
"      --png FILE.png        8-bit sRGB preview\n"
"      --frames DIR          moving scenes: every reconstructed frame (DIR/frame_NNNN.exr/.png)\n"
"      --dump FILE.csid      the exact samples, for csi-reconstruct (bit-identical result)\n"
"      --stats FILE.json     plan, ray counts, timings, iterations and residuals\n"
"sampling:\n"
"      --spp N               samples per pixel (over the whole shutter when moving), default 4\n"
"      --method M            cs (compressive; default), stratified or random (Monte Carlo:\n"
"                            per-pixel sample mean)\n"
"      --positions P         cs's positions: auto, poisson, stratified or random [default: auto =\n"
"                            Poisson-disk, except on a moving scene from 2 spp: stratified over\n"
"                            each pixel's shutter, its cells dealt one sample each before any\n"
"                            gets two]\n"
"      --grid K              fine-grid width in cells (a multiple of the image width); default\n"
"                            when moving 2x (3x from 9 spp, 4x from 16) from one sample per 8\n"
"                            frames (8 spp >= T) if the camera holds still or translates\n"
"                            across its view, else 1x (docs/bench/animation.md, sessions 42-44\n"
"                            and 47);\n"
"                            when static Fx, F the smallest power of two >= 4 with F^2 > 4 spp\n"
"                            (more than 4 cells per sample), at most 16: F = 4 up to 3 spp, 8\n"
"                            for 4-15, 16 from 16 (docs/bench/grid.md)\n"
"      --cell-point P        where a sample lies in its cell (docs/scene-format.md, \"Sampling\n"
"                            contract\"): jittered (a uniform random point in x, y and t: a\n"
"                            pixel's samples average to its true integral) or centre [default:\n"
"                            auto = centre for cs, jittered for Monte Carlo and --reference]\n"
"      --time-steps T        frames of the volume for a moving scene (default: the plan's rule)\n"
"      --reference SPP       render a stratified ground truth with SPP samples per pixel instead\n"
"                            (sqrt(SPP / T) cells a pixel side, at least 2 when moving: the\n"
"                            pixel's area, not its centre; SPP = 4 T traces each cell once;\n"
"                            16 T and more are finer than any default grid of a volume)\n"
"      --seed S              seed of positions and shading, default 1\n"
"      --threads N           tracing threads, default: all cores\n"
);
    cli_recon_usage(f);
    cli_tile_usage(f);
    fputs(
"      (csi-render --tile traces only the samples inside the tile's window; without --tile-scale\n"
"      each tile scales tau by its own samples, as an untiled run of the window would)\n"
"other:\n"
"      --device NAME         OpenCL device (default: PoCL CPU, or $CSI_DEVICE)\n"
"      --cache-programs      build csi's OpenCL programs and keep their binaries for later runs\n"
"                            (as csi-reconstruct --cache-programs; once per build and driver)\n"
"  -q, --quiet               no progress on stderr\n"
"      (progress: a redrawn line on a terminal; elsewhere, as in a log, a plain line at most\n"
"      every 60 s; $CSI_PROGRESS = off, bar, or the seconds between plain lines)\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n", f);
}

typedef struct {
    cli_progress *bar;
    cli_recon_progress recon;
} prog_state;

static void on_trace(uint64_t done, uint64_t total, void *user)
{
    prog_state *ps = user;
    char detail[64];
    snprintf(detail, sizeof detail, "%llu / %llu samples", (unsigned long long)done,
             (unsigned long long)total);
    cli_progress_update(ps->bar, "trace", total ? (double)done / (double)total : -1, detail);
}

static bool on_positions(void *user, uint64_t done, uint64_t total)
{
    prog_state *ps = user;
    char detail[64];
    snprintf(detail, sizeof detail, "%llu / %llu placed", (unsigned long long)done, (unsigned long long)total);
    cli_progress_update(ps->bar, "positions", total ? (double)done / (double)total : -1, detail);
    return true;
}

static bool on_solve(void *user, const csi_progress *p)
{
    prog_state *ps = user;
    cli_recon_progress_update(&ps->recon, p->phase, p->iteration, p->residual);
    return true;
}

/* A tile's samples, evaluated by the tracer (cli_tile_eval_fn). */
typedef struct {
    csi_tracer *tr;
    const csi_grid *grid;
    uint64_t seed;
} tile_eval;

static csi_status eval_tile(void *user, const csi_sample_pos *pos, const uint64_t *ids, size_t n, float *rgb)
{
    const tile_eval *e = user;
    return csi_tracer_eval_ids(e->tr, e->grid, pos, ids, n, e->seed, rgb, NULL, NULL);
}

/* Option `name` of o is `value` (a choice's name). */
static bool option_is(const csi_options *o, const char *name, const char *value)
{
    char buf[64];
    return csi_options_get(o, name, buf, sizeof buf) == CSI_OK && !strcmp(buf, value);
}

/* The statistics of a whole run. */
typedef struct {
    const char *scene, *method;
    const csi_pos_opts *po;
    uint64_t seed;
    bool cell_jitter;
    const csi_grid *grid;
    size_t n;
    double t_render, t_recon, t_device, t_write;
} run_figures;

static csi_status write_stats(csi_outset *set, const char *path, const csi_device *dev, csi_tracer *tr,
                              const csi_result *res, const run_figures *f)
{
    csi_json *j = NULL;
    CSI_TRY(csi_json_new(&j));
    csi_tracer_counters cnt;
    csi_tracer_counters_get(tr, &cnt);
    csi_tracer_info info;
    csi_tracer_info_get(tr, &info);
    csi_json_str(j, "tool", "csi-render");
    csi_json_str(j, "scene", f->scene);
    csi_json_str(j, "device", csi_device_name(dev));
    csi_json_str(j, "method", f->method);
    csi_json_str(j, "positions", csi_pos_method_name(f->po->method));
    csi_json_int(j, "spp", f->po->spp);
    csi_json_int(j, "seed", (int64_t)f->seed);
    csi_json_str(j, "cell_point", f->cell_jitter ? "jittered" : "centre");
    cli_json_grid(j, f->grid);
    csi_json_int(j, "samples", (int64_t)f->n);
    csi_json_num(j, "t_render_s", f->t_render);
    csi_json_num(j, "t_reconstruct_s", f->t_recon);
    csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
    csi_json_num(j, "t_per_sample_us", f->n ? 1e6 * f->t_render / (double)f->n : 0);
    csi_json_begin(j, "rays");
    csi_json_int(j, "primary", (int64_t)cnt.primary_rays);
    csi_json_int(j, "secondary", (int64_t)cnt.secondary_rays);
    csi_json_int(j, "shadow", (int64_t)cnt.shadow_rays);
    csi_json_int(j, "ambient_occlusion", (int64_t)cnt.ao_rays);
    csi_json_int(j, "timed", (int64_t)cnt.timed_rays);
    csi_json_int(j, "texture_lookups", (int64_t)cnt.texture_lookups);
    csi_json_int(j, "checker_lookups", (int64_t)cnt.checker_lookups);
    csi_json_end(j);
    csi_json_int(j, "embree_geometries", info.geometries);
    csi_json_int(j, "embree_motion_geometries", info.motion_geometries);
    csi_json_int(j, "threads", info.threads);
    csi_json_begin(j, "reconstruction");
    csi_result_stats(res, j);
    csi_result_stats_phases(res, j, 0, f->t_device, f->t_write);
    csi_json_end(j);
    const csi_status s = cli_write_stats(set, path, j);
    csi_json_free(j);
    return s;
}

int main(int argc, char **argv)
{
    enum { O_PNG = 256, O_FRAMES, O_STATS, O_DEVICE, O_VERSION, O_SPP, O_METHOD, O_GRID, O_DUMP, O_REF, O_SEED,
           O_THREADS, O_PLAN, O_TSTEPS, O_CACHE_PROGRAMS, O_POSITIONS, O_CELL_POINT };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, O_PNG},
        {"frames", required_argument, 0, O_FRAMES}, {"stats", required_argument, 0, O_STATS},
        {"device", required_argument, 0, O_DEVICE},
        {"spp", required_argument, 0, O_SPP}, {"method", required_argument, 0, O_METHOD},
        {"positions", required_argument, 0, O_POSITIONS}, {"cell-point", required_argument, 0, O_CELL_POINT},
        {"grid", required_argument, 0, O_GRID}, {"dump", required_argument, 0, O_DUMP},
        {"reference", required_argument, 0, O_REF}, {"seed", required_argument, 0, O_SEED},
        {"threads", required_argument, 0, O_THREADS}, {"plan", no_argument, 0, O_PLAN},
        {"cache-programs", no_argument, 0, O_CACHE_PROGRAMS},
        {"time-steps", required_argument, 0, O_TSTEPS},
        {"quiet", no_argument, 0, 'q'}, {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION}, CLI_TILE_LONGOPTS, {0, 0, 0, 0}};
    cli_quiet_kernel_builds();
    cli_heap_keep_freed();
    cli_outputs outs = {0};
    cli_tile_opts tile = {0};
    csi_options *opt = NULL;
    if (csi_options_new(&opt) != CSI_OK)
        return cli_error(prog, CSI_ERR_NOMEM, "%s", cli_last_error());
    bool quiet = false, plan_only = false, cache_programs = false;
    const char *device = NULL, *dump_path = NULL, *method = "cs", *positions = "auto", *cell_point = "auto";
    uint64_t spp = 4, grid_k = 0, ref_spp = 0, seed = 1, threads = 0, tsteps = 0;
    int c, rc = 0;
    opterr = 0;
    struct option *all_opts = cli_longopts_with_recon(longopts);
    if (!all_opts) {
        csi_options_free(opt);
        return cli_error(prog, CSI_ERR_NOMEM, "out of memory");
    }
    while (!rc && (c = getopt_long(argc, argv, "o:qh", all_opts, NULL)) != -1) {
        switch (c) {
        case 'o': outs.exr = optarg; break;
        case O_PNG: outs.png = optarg; break;
        case O_FRAMES: outs.frames_dir = optarg; csi_options_set(opt, "frames", "on"); break;
        case O_STATS: outs.stats = optarg; break;
        case O_DUMP: dump_path = optarg; break;
        case O_PLAN: plan_only = true; break;
        case O_CACHE_PROGRAMS: cache_programs = true; break;
        case O_SPP:
            if (!cli_parse_u64(optarg, 1, 65536, &spp))
                rc = cli_error(prog, CSI_ERR_ARG, "--spp: '%s' is not a whole number from 1 to 65536", optarg);
            break;
        case O_METHOD:
            if (strcmp(optarg, "cs") && strcmp(optarg, "stratified") && strcmp(optarg, "random"))
                rc = cli_error(prog, CSI_ERR_ARG, "--method: '%s' (expected cs, stratified or random)", optarg);
            method = optarg;
            break;
        case O_POSITIONS: {
            csi_pos_method m;
            if (strcmp(optarg, "auto") && csi_pos_method_parse(optarg, &m) != CSI_OK)
                rc = cli_error(prog, CSI_ERR_ARG, "--positions: '%s' (expected auto, poisson, stratified or random)",
                               optarg);
            positions = optarg;
            break;
        }
        case O_CELL_POINT:
            if (strcmp(optarg, "auto") && strcmp(optarg, "jittered") && strcmp(optarg, "centre"))
                rc = cli_error(prog, CSI_ERR_ARG, "--cell-point: '%s' (expected auto, jittered or centre)", optarg);
            cell_point = optarg;
            break;
        case O_GRID:
            if (!cli_parse_u64(optarg, 1, CSI_GRID_MAX_SIDE, &grid_k))
                rc = cli_error(prog, CSI_ERR_ARG, "--grid: '%s' is not a whole number from 1 to %u", optarg,
                               CSI_GRID_MAX_SIDE);
            break;
        case O_REF:
            if (!cli_parse_u64(optarg, 1, 65536, &ref_spp))
                rc = cli_error(prog, CSI_ERR_ARG, "--reference: '%s' is not a whole number from 1 to 65536", optarg);
            break;
        case O_SEED:
            if (!cli_parse_u64(optarg, 0, UINT64_MAX, &seed))
                rc = cli_error(prog, CSI_ERR_ARG, "--seed: '%s' is not a whole number from 0 to 2^64 - 1", optarg);
            break;
        case O_THREADS:
            if (!cli_parse_u64(optarg, 1, 256, &threads))
                rc = cli_error(prog, CSI_ERR_ARG, "--threads: '%s' is not a whole number from 1 to 256", optarg);
            break;
        case O_TSTEPS:
            if (!cli_parse_u64(optarg, 2, CSI_GRID_MAX_FRAMES, &tsteps))
                rc = cli_error(prog, CSI_ERR_ARG, "--time-steps: '%s' is not a whole number from 2 to %u", optarg,
                               CSI_GRID_MAX_FRAMES);
            break;
        case O_DEVICE: device = optarg; break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); rc = -1; break;
        case O_VERSION: printf("csi-render %s\n", CSI_VERSION); rc = -1; break;
        default:
            rc = cli_tile_option(prog, c, optarg, &tile);
            if (rc < 0)
                rc = cli_recon_option_or_fail(prog, c, optarg, argv[optind - 1], opt);
        }
    }
    free(all_opts);
    if (!rc && cache_programs) {
        csi_options_free(opt);
        if (optind != argc)
            return cli_error(prog, CSI_ERR_ARG, "--cache-programs takes no scene (%s given)", argv[optind]);
        return cli_cache_programs(prog, device, quiet);
    }
    const bool est_given = cli_recon_given("estimator"); /* else it follows --method */
    if (!rc && optind != argc - 1)
        rc = cli_error(prog, CSI_ERR_ARG, optind >= argc ? "no scene given (see --help)"
                                                        : "more than one scene given (see --help)");
    if (rc) {
        csi_options_free(opt);
        return rc < 0 ? 0 : rc;
    }
    const char *scene_path = argv[optind];
    csi_scene *scene = NULL;
    csi_status s = csi_scene_load(scene_path, &scene);
    if (s != CSI_OK) {
        csi_options_free(opt);
        return cli_error(prog, s, "%s", cli_last_error());
    }
    csi_plan plan;
    csi_plan_overrides ov = {.frames = (uint32_t)tsteps};
    s = csi_plan_make(scene, &ov, &plan);
    if (s != CSI_OK) {
        csi_scene_free(scene);
        csi_options_free(opt);
        return cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
    }
    /* A scene without random effects gives noise-free point values: flagged, in the dump too, so
     * that csi-reconstruct of the dump resolves the same options (docs/dump-format.md). */
    const uint32_t flags = plan.exact ? CSI_SAMPLES_EXACT : 0;
    csi_device *dev = NULL;
    csi_tracer *tr = NULL;
    csi_sample_pos *pos = NULL;
    float *rgb = NULL;
    csi_result *res = NULL;
    csi_outset *set = NULL;
    if (plan_only) {
        s = csi_plan_json(scene, &plan, stdout);
        if (s != CSI_OK)
            rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    rc = cli_tile_check(prog, &tile, outs.png != NULL, outs.frames_dir != NULL);
    if (!rc && (tile.one || tile.info) && (dump_path || ref_spp))
        rc = cli_error(prog, CSI_ERR_ARG, "--tile and --tile-info do not go with --%s", dump_path ? "dump" : "reference");
    if (!rc && tile.one && !outs.exr)
        rc = cli_error(prog, CSI_ERR_ARG, "--tile needs -o PARTIAL (the tile's partial result)");
    if (!rc && !outs.exr && !outs.png && !tile.info)
        rc = cli_error(prog, CSI_ERR_ARG, "no output given: use -o OUT.exr and/or --png OUT.png");
    if (rc)
        goto done;
    if (tile.frames)
        csi_options_set(opt, "frames", "on");
    const bool frames = option_is(opt, "frames", "on");
    if (tsteps && !plan.motion && !quiet)
        cli_warn(prog, "%s has no motion in the shutter: --time-steps ignored (T = 1)", scene_path);
    if (frames && !plan.motion && !quiet)
        cli_warn(prog, "%s has no motion: --frames writes nothing", scene_path);

    /* The grid: the image is W x H; the fine grid K x K*H/W, T frames from the plan. */
    const bool reference = ref_spp > 0;
    if (strcmp(positions, "auto") && (reference || strcmp(method, "cs"))) {
        rc = cli_error(prog, CSI_ERR_ARG, "--positions chooses the compressive method's positions; %s samples its own",
                       reference ? "--reference" : !strcmp(method, "stratified") ? "--method stratified" : "--method random");
        goto done;
    }
    /* Where a sample lies in its cell (csi_tracer_set_cell_jitter). Monte Carlo and the reference
     * jitter, as a renderer's do, so that they converge to the pixel's true integral; with
     * centres they converge to the centres' midpoint rule, which a reference on a lattice of
     * centres shares with stratified sampling on the same lattice. The compressive method keeps
     * the centres: against the true integral, jittered cells lost most where small HDR lights
     * cover part of a cell (a jittered sample of one is all or nothing) and won where thin lit
     * bars or a panned texture fall between the centres, neither by a margin that holds over
     * the scenes measured (docs/bench/animation.md, session 46). */
    const bool cell_jitter = !strcmp(cell_point, "auto") ? reference || strcmp(method, "cs")
                                                         : !strcmp(cell_point, "jittered");
    csi_grid grid = {.out_w = plan.width, .out_h = plan.height, .t = plan.frames};
    uint64_t factor;
    if (reference) {
        /* Enough cells per pixel block for SPP distinct stratified samples: sqrt(SPP) per axis
         * when static; when moving, the block has T frames, so sqrt(SPP / T) per axis, and at
         * least 2: a reference of one cell a pixel would be its centre's motion blur, aliased
         * where the default grid (csi_default_grid_factor) is not. Antialiased as well as
         * motion-blurred; each sample at a random point of its cell (--cell-point's default
         * for a reference), so the mean of several seeds converges to the pixel's integral. */
        factor = (uint64_t)ceil(sqrt((double)ref_spp / (double)plan.frames) - 1e-9);
        if (factor < (plan.frames > 1 ? 2u : 1u))
            factor = plan.frames > 1 ? 2 : 1;
    } else if (grid_k) {
        if (grid_k % plan.width) {
            rc = cli_error(prog, CSI_ERR_ARG, "--grid %llu is not a multiple of the image width %u",
                           (unsigned long long)grid_k, plan.width);
            goto done;
        }
        factor = grid_k / plan.width;
    } else {
        /* the plan knows how the camera moves; a renderer without one passes csi-positions --grid */
        const csi_camera_motion cam = plan.camera_pans    ? CSI_CAMERA_PANS
                                      : plan.camera_moves ? CSI_CAMERA_MOVES
                                                          : CSI_CAMERA_STILL;
        factor = csi_camera_grid_factor(plan.width, plan.height, plan.frames, spp, cam);
    }
    if ((uint64_t)plan.width * factor > CSI_GRID_MAX_SIDE || (uint64_t)plan.height * factor > CSI_GRID_MAX_SIDE) {
        rc = cli_error(prog, CSI_ERR_ARG, "%s: fine grid %llux%llu (%ux%u pixels, %llu cells per pixel side) "
                       "is larger than the limit of %u cells a side", scene_path,
                       (unsigned long long)plan.width * factor, (unsigned long long)plan.height * factor,
                       plan.width, plan.height, (unsigned long long)factor, CSI_GRID_MAX_SIDE);
        goto done;
    }
    grid.w = (uint32_t)(plan.width * factor);
    grid.h = (uint32_t)(plan.height * factor);

    csi_pos_opts popts = {0};
    popts.spp = (uint32_t)(reference ? ref_spp : spp);
    popts.seed = seed;
    popts.method = reference || !strcmp(method, "stratified") ? CSI_POS_STRATIFIED
                   : !strcmp(method, "random")              ? CSI_POS_RANDOM
                                                            : cli_default_positions(plan.frames, spp);
    if (!reference && !strcmp(method, "cs") && strcmp(positions, "auto"))
        csi_pos_method_parse(positions, &popts.method); /* checked above */
    if (!est_given)
        csi_options_set(opt, "estimator", reference || strcmp(method, "cs") ? "mean" : "cs");
    const bool mean = option_is(opt, "estimator", "mean");
    char seed_text[24]; /* the reconstruction's seed is the render's */
    snprintf(seed_text, sizeof seed_text, "%llu", (unsigned long long)seed);
    csi_options_set(opt, "seed", seed_text);
    /* Every output stated before any work (none may be the scene or a file it reads), written
     * all or nothing at the end (csi_outset). */
    s = cli_outset_new(&set);
    if (s == CSI_OK)
        s = csi_outset_input(set, scene_path);
    for (size_t i = 0; s == CSI_OK && i < csi_scene_input_count(scene); i++)
        s = csi_outset_input(set, csi_scene_input(scene, i));
    if (s == CSI_OK)
        s = cli_outputs_stage(&outs, set, frames && !mean && grid.t > 1 ? grid.t : 0);
    if (s == CSI_OK && dump_path)
        s = csi_outset_file(set, dump_path, "the dump (--dump)");
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    size_t n = 0;
    csi_pos_info pinfo;
    uint64_t pos_bytes = 0;
    s = csi_positions_count(&grid, &popts, &n);
    if (s == CSI_OK)
        s = csi_positions_host_bytes(&grid, &popts, &pos_bytes);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
        goto done;
    }
    /* Device first: a missing OpenCL device should fail before minutes of tracing. */
    double t_device = cli_now();
    s = csi_device_new(device, &dev);
    t_device = cli_now() - t_device;
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    /* Sizes before work: positions, the traced values (12 bytes per sample), the tracer's
     * geometry and the reconstruction must fit, or the scene is refused now rather than after
     * the tracing. */
    s = csi_reconstruct_check(dev, &grid, 3, n, opt,
                              pos_bytes + 12 * (uint64_t)n + csi_tracer_host_bytes(scene, &plan), scene_path);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    cli_progress bar;
    if (!cli_progress_init(&bar, prog, quiet)) {
        rc = cli_error(prog, CSI_ERR_ARG, "%s", cli_last_error());
        goto done;
    }
    prog_state ps = {&bar, {0}};
    cli_recon_progress_init(&ps.recon, &bar);
    s = csi_positions_with_progress(&grid, &popts, &pos, &n, &pinfo, on_positions, &ps);
    if (s == CSI_OK)
        s = csi_tracer_create(scene, &plan, (unsigned)threads, &tr);
    if (s == CSI_OK)
        csi_tracer_set_cell_jitter(tr, cell_jitter);
    if (s != CSI_OK) {
        cli_progress_end(&bar);
        rc = cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
        goto done;
    }
    if (tile.one || tile.info) {
        tile_eval te = {tr, &grid, seed};
        rc = cli_tile_run_render(prog, dev, set, scene_path, &grid, &popts, pos, n, flags, opt, &tile, &outs, quiet,
                                 &ps.recon, eval_tile, &te);
        goto done;
    }
    rgb = malloc(n * 3 * sizeof(float));
    if (!rgb) {
        rc = cli_error(prog, CSI_ERR_NOMEM, "out of host memory for %zu samples", n);
        goto done;
    }
    double t0 = cli_now();
    s = csi_tracer_eval(tr, &grid, pos, n, seed, rgb, on_trace, &ps);
    double t_render = cli_now() - t0;
    cli_progress_end(&bar);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
        goto done;
    }
    if (dump_path) {
        csi_dump dump = {.grid = grid, .channels = 3, .seed = seed, .count = n, .pos = pos, .values = rgb,
                         .flags = flags};
        s = cli_write_dump(set, dump_path, &dump);
        if (s != CSI_OK) {
            rc = cli_error(prog, s, "%s", cli_last_error());
            goto done;
        }
    }
    const csi_samples samples = {grid, 3, n, pos, rgb, flags, NULL};
    double t1 = cli_now();
    s = csi_reconstruct(dev, &samples, opt, on_solve, &ps, &res);
    double t_recon = cli_now() - t1;
    cli_progress_end(&bar);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", scene_path, cli_last_error());
        goto done;
    }
    csi_result_info info;
    csi_result_info_get(res, &info);
    char mdesc[128];
    snprintf(mdesc, sizeof mdesc, "%s%s, %s positions%s", reference ? "reference " : "", info.method,
             csi_pos_method_name(popts.method), cell_jitter ? ", jittered in their cells" : " at their cells' centres");
    double tw = cli_now();
    s = cli_write_images(&outs, set, res, mdesc, &bar);
    tw = cli_now() - tw;
    if (s == CSI_OK && outs.stats) {
        const run_figures f = {scene_path, reference ? "reference" : method, &popts, seed, cell_jitter, &grid, n,
                               t_render, t_recon, t_device, tw};
        s = write_stats(set, outs.stats, dev, tr, res, &f);
    }
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    if (!quiet) {
        cli_warn_unconverged(prog, res, quiet);
        fprintf(stderr, "%s: %ux%u%s from %zu samples of a %ux%ux%u grid (%s) : render %.2f s, reconstruct %.2f s\n",
                prog, grid.out_w, grid.out_h, grid.t > 1 ? " (motion)" : "", n, grid.w, grid.h, grid.t, mdesc, t_render,
                t_recon);
    }
done:
    cli_outset_free(set); /* nothing new is left when the run failed */
    csi_result_free(res);
    free(rgb);
    csi_free(pos);
    csi_tracer_free(tr);
    csi_device_release(dev);
    csi_plan_free(&plan);
    csi_scene_free(scene);
    csi_options_free(opt);
    return rc;
}
