/* csi-reconstruct: a sample dump in, an antialiased (Alg. 1) or motion-blurred (Alg. 2) image
 * out. See --help and docs/dump-format.md. A thin main over csi/csi.h (its --tile runs: tile.h). */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "outputs.h"
#include "recon_opts.h"
#include "tile.h"

static const char *prog = "csi-reconstruct";

static void usage(FILE *f)
{
    fprintf(f,
"usage: csi-reconstruct DUMP -o OUT.exr [options]\n"
"\n"
"Reconstructs an image from a sample dump (docs/dump-format.md) by compressive estimation\n"
"(Sen & Darabi 2010). grid_t = 1: antialiasing (Alg. 1: Gaussian-blurred Daubechies wavelets);\n"
"grid_t > 1: motion blur (Alg. 2: 3-D Fourier basis), the image being the mean over time.\n"
"\n"
"outputs:\n"
"  -o, --output FILE.exr     float32 EXR with the run's parameters as header attributes\n"
"      --png FILE.png        8-bit sRGB preview\n"
"      --frames DIR          grid_t > 1: also every reconstructed frame (DIR/frame_NNNN.exr/.png)\n"
"      --stats FILE.json     timings, iterations and residuals as JSON\n"
"      --refine-request REQ.csid\n"
"                            images: also where to sample next, a positions request (csi-positions'\n"
"                            format) of every cell without a sample of the pixels where the image and\n"
"                            the mean of the pixel's own samples disagree by at least --refine-share\n"
"                            of their disagreement over the whole image (an HDR highlight that one of\n"
"                            a pixel's few samples hit), the pixels beside such a light's\n"
"                            brightest, and the pixels whose mean's sampling variance (from their\n"
"                            samples' spread; a pixel of one sample, its 3 x 3 pixels') holds that\n"
"                            share of its sum over the image. Have the renderer evaluate it, then run\n"
"                            --refine-with (csi-mitsuba --refine does both); not written when no\n"
"                            pixel is picked (the summary says so). The image is then the first\n"
"                            pass's, which --refine-with completes (--settle off,\n"
"                            --step-coverage off); with no pixel picked it is final: with the\n"
"                            samples' variances, csi-reconstruct's default image, to the bit\n"
"      --refine-share S      the share, 0 < S <= 1 [default: 0.005]\n"
"      --refine-with MORE.csid\n"
"                            the second pass without a second reconstruction: MORE.csid is DUMP's\n"
"                            refinement request (the same --refine-share) evaluated by the renderer;\n"
"                            the image is DUMP's reconstruction with each refined pixel the mean of\n"
"                            all its samples, then, with the samples' variances (--variance), the\n"
"                            pixels that still decide it settled on all their samples' mean (not with\n"
"                            --settle off), and with MORE's variances beside it too\n"
"                            (MORE.variance.csid) an HDR step's pixels given the coverage their\n"
"                            window's samples allow (not with --step-coverage off) (csi-mitsuba's\n"
"                            image; docs/bench/mitsuba.md, sessions 20, 48 and 50)\n"
);
    cli_recon_usage(f);
    cli_tile_usage(f);
    fputs(
"input:\n"
"      --drop-invalid        drop records with NaN/Inf values (with a warning) instead of failing\n"
"      --variance FILE.csid  each sample's variance: a dump of the same grid, positions and\n"
"                            channels whose values are the variances of the dump's (csi-mitsuba's\n"
"                            X.variance.csid, docs/dump-format.md); an isolated bright sample its\n"
"                            own noise explains is then taken as noise, a volume's solve\n"
"                            regularises at least as much as that noise asks, and its frames are\n"
"                            denoised by it (--frames-denoise). Default: DUMP's stem\n"
"                            .variance.csid where that file exists (said on stderr), none with\n"
"                            --drop-invalid; --variance none ignores it\n"
"other:\n"
"      --seed S              seed of the solver's randomised parts (ROMP's column-norm probes with\n"
"                            --romp-normalize on); default: the dump's seed (csi-render's), else 1\n"
"      --device NAME         OpenCL device (substring of 'platform / device'; default: PoCL CPU,\n"
"                            or $CSI_DEVICE); --device list prints the devices\n"
"      --cache-programs      build csi's OpenCL programs and keep their binaries for later runs\n"
"                            (in $CSI_CACHE_DIR/programs, else ~/.cache/csi/programs), which then\n"
"                            load them instead of building them (most of a run's programs_s);\n"
"                            once after installing or rebuilding csi or updating the driver: slow\n"
"                            the first time (PoCL compiles every kernel), quick when cached\n"
"  -q, --quiet               no progress or warnings on stderr\n"
"      (progress: a redrawn line on a terminal; elsewhere, as in a log, a plain line at most\n"
"      every 60 s; $CSI_PROGRESS = off, bar, or the seconds between plain lines)\n"
"  -h, --help                this text\n"
"      --version             version\n"
"exit status: 0 success, 2 bad input or usage, 1 other failure\n", f);
}

/* Option `name` of o is `value` (a choice's name). */
static bool option_is(const csi_options *o, const char *name, const char *value)
{
    char buf[64];
    return csi_options_get(o, name, buf, sizeof buf) == CSI_OK && !strcmp(buf, value);
}

/* The variances csi-mitsuba writes beside a dump X.csid (its --dump with --paths above 1):
 * X.variance.csid, taken by default where it exists, since the two are one render's output and
 * the variances only ever sharpen what the samples say of their own noise. NULL where there is
 * none (or `in` is itself such a file); the caller frees the path. */
static char *variance_beside(const char *in)
{
    static const char ext[] = ".csid", side[] = ".variance.csid";
    const size_t n = strlen(in), e = sizeof ext - 1, v = sizeof side - 1;
    if (n <= e || strcmp(in + n - e, ext) || (n >= v && !strcmp(in + n - v, side)))
        return NULL;
    char *path = malloc(n - e + v + 1);
    if (!path)
        return NULL;
    memcpy(path, in, n - e);
    memcpy(path + n - e, side, v + 1);
    FILE *f = fopen(path, "rb");
    if (!f) {
        free(path);
        return NULL;
    }
    fclose(f);
    return path;
}

/* The variances of the dump `in`'s samples from the dump `path` (--variance): the same grid,
 * channels and positions in the same order, values >= 0. A dump whose duplicates were averaged
 * is refused: the variance of their mean is not the mean of their variances. */
static csi_status read_variance(const char *path, const char *in, const csi_dump *d, const csi_dump_report *drep,
                                const csi_dump_read_opts *ro, csi_dump *v, csi_dump_report *vrep)
{
    CSI_TRY(csi_dump_read(path, ro, v, vrep));
    if (drep->duplicates || vrep->duplicates)
        return cli_fail(CSI_ERR_FORMAT, "%s: --variance needs a dump without repeated positions (%s has %llu)", path,
                        drep->duplicates ? in : path,
                        (unsigned long long)(drep->duplicates ? drep->duplicates : vrep->duplicates));
    if (memcmp(&v->grid, &d->grid, sizeof d->grid) || v->channels != d->channels || v->count != d->count)
        return cli_fail(CSI_ERR_FORMAT, "%s: %zu records of %u channels on a %ux%ux%u grid, but %s has %zu of %u on "
                        "%ux%ux%u: not its variances", path, v->count, v->channels, v->grid.w, v->grid.h, v->grid.t,
                        in, d->count, d->channels, d->grid.w, d->grid.h, d->grid.t);
    for (size_t i = 0; i < d->count; i++) {
        if (memcmp(&v->pos[i], &d->pos[i], sizeof d->pos[i]))
            return cli_fail(CSI_ERR_FORMAT, "%s: record %zu is at (%u, %u, %u), %s's at (%u, %u, %u): not its "
                            "variances", path, i, v->pos[i].x, v->pos[i].y, v->pos[i].t, in, d->pos[i].x,
                            d->pos[i].y, d->pos[i].t);
        for (uint32_t c = 0; c < d->channels; c++)
            if (!(v->values[i * d->channels + c] >= 0))
                return cli_fail(CSI_ERR_FORMAT, "%s: record %zu channel %u: variance %g is negative", path, i, c,
                                (double)v->values[i * d->channels + c]);
    }
    /* checked equal to the dump's: held twice they would add 12 bytes a sample to the peak */
    free(v->pos);
    v->pos = NULL;
    return CSI_OK;
}

/* The cells to sample next (--refine-request), written as a positions request when there are any. */
static csi_status write_refinement(csi_outset *set, const char *path, const csi_samples *samples,
                                   const csi_result *r, double share, size_t *cells, size_t *pixels)
{
    csi_image img;
    CSI_TRY(csi_result_image(r, &img));
    csi_sample_pos *pos = NULL;
    CSI_TRY(csi_refine_positions(samples, &img, share, &pos, cells, pixels));
    if (!*cells)
        return CSI_OK;
    const char *tmp;
    csi_status s = csi_outset_tmp(set, path, &tmp);
    if (s == CSI_OK) {
        const csi_dump req = {samples->grid, 0, 0, *cells, pos, NULL, 0};
        s = csi_dump_write(tmp, &req);
    }
    csi_free(pos);
    return s;
}

static int cmp_u64(const void *a, const void *b)
{
    const uint64_t i = *(const uint64_t *)a, j = *(const uint64_t *)b;
    return i < j ? -1 : i > j;
}

/* --refine-with, before the reconstruction: what any refinement request's evaluation is, whatever
 * the image: cells FIRST did not sample, each once, that complete every pixel they touch (a request
 * asks for all the cells a picked pixel lacks). Which pixels is decided by the image, after. */
static csi_status refinement_cells_check(const char *path, const char *in, const csi_samples *first,
                                         const csi_samples *more)
{
    const csi_grid *g = &first->grid;
    const uint32_t bw = g->w / g->out_w, bh = g->h / g->out_h;
    const size_t np = (size_t)g->out_w * g->out_h, m = more->count;
    uint32_t *cnt = calloc(2 * np, sizeof *cnt); /* per pixel: FIRST's samples, MORE's */
    uint64_t *idx = malloc((m ? m : 1) * sizeof *idx);
    csi_status s = CSI_OK;
    if (!cnt || !idx)
        s = cli_fail(CSI_ERR_NOMEM, "out of host memory for %zu pixels", np);
    for (size_t i = 0; i < m && s == CSI_OK; i++) {
        const csi_sample_pos q = more->pos[i];
        idx[i] = csi_grid_index(g, q);
        cnt[2 * ((size_t)(q.y / bh) * g->out_w + q.x / bw) + 1]++;
    }
    if (s == CSI_OK)
        qsort(idx, m, sizeof *idx, cmp_u64);
    for (size_t i = 0; i < m && s == CSI_OK; i++)
        if (i && idx[i] == idx[i - 1])
            s = cli_fail(CSI_ERR_ARG, "%s: position (%u, %u) is given twice: not a refinement request's evaluation",
                         path, (unsigned)(idx[i] % g->w), (unsigned)(idx[i] / g->w));
    for (size_t i = 0; i < first->count && s == CSI_OK; i++) {
        const csi_sample_pos q = first->pos[i];
        const size_t p = (size_t)(q.y / bh) * g->out_w + q.x / bw;
        cnt[2 * p]++;
        const uint64_t k = csi_grid_index(g, q);
        if (cnt[2 * p + 1] && bsearch(&k, idx, m, sizeof *idx, cmp_u64))
            s = cli_fail(CSI_ERR_ARG, "%s: position (%u, %u) is sampled in %s already: not its refinement (a "
                         "request asks for cells without a sample)", path, q.x, q.y, in);
    }
    for (size_t p = 0; p < np && s == CSI_OK; p++)
        if (cnt[2 * p + 1] && cnt[2 * p] + cnt[2 * p + 1] != bw * bh)
            s = cli_fail(CSI_ERR_ARG, "%s: pixel (%zu, %zu) gets %u cells with %s's %u, of its %u: not a refinement "
                         "request's evaluation (a request completes every pixel it picks)", path, p % g->out_w,
                         p / g->out_w, cnt[2 * p + 1], in, cnt[2 * p], bw * bh);
    free(cnt);
    free(idx);
    return s;
}

/* --refine-with: MORE's positions must be the request this reconstruction makes (the same cells,
 * in any order); then the refined pixels take the mean of all their samples (csi_refine_apply),
 * and with settle, the pixels that still decide the image settle on theirs (csi_refine_settle:
 * with the samples' variances only); with step, an HDR step's pixels take the coverage their
 * window's samples allow (csi_refine_step_coverage: with both dumps' variances only). */
static csi_status apply_refinement(const char *path, const char *in, const csi_samples *first,
                                   const csi_samples *more, csi_result *r, double share, bool settle, bool step,
                                   size_t *pixels, size_t *settled, size_t *stepped)
{
    csi_image img;
    CSI_TRY(csi_result_image(r, &img));
    csi_sample_pos *want = NULL;
    size_t n = 0;
    CSI_TRY(csi_refine_positions(first, &img, share, &want, &n, NULL));
    csi_status s = CSI_OK;
    /* both as grid indices, sorted: the same cells in any order */
    uint64_t *idx = n == more->count && n ? malloc(2 * n * sizeof *idx) : NULL;
    if (n != more->count)
        s = cli_fail(CSI_ERR_ARG, "%s: %zu positions, but %s's refinement request (--refine-share %g) has %zu: not "
                     "its evaluation", path, more->count, in, share, n);
    else if (n && !idx)
        s = cli_fail(CSI_ERR_NOMEM, "out of host memory for %zu positions", n);
    if (s == CSI_OK && n) {
        for (size_t i = 0; i < n; i++) {
            idx[i] = csi_grid_index(&first->grid, want[i]);
            idx[n + i] = csi_grid_index(&first->grid, more->pos[i]);
        }
        qsort(idx, n, sizeof *idx, cmp_u64);
        qsort(idx + n, n, sizeof *idx, cmp_u64);
        for (size_t i = 0; i < n && s == CSI_OK; i++)
            if (idx[i] != idx[n + i])
                s = cli_fail(CSI_ERR_ARG, "%s: position (%u, %u) is not in %s's refinement request (--refine-share "
                             "%g): not its evaluation", path, (unsigned)(idx[n + i] % first->grid.w),
                             (unsigned)(idx[n + i] / first->grid.w), in, share);
    }
    free(idx);
    csi_free(want);
    if (s == CSI_OK)
        s = csi_refine_apply(first, more, &img, pixels);
    if (s == CSI_OK && settle)
        s = csi_refine_settle(first, more, &img, settled);
    if (s == CSI_OK && step)
        s = csi_refine_step_coverage(first, more, &img, stepped);
    return s;
}

/* The statistics of a whole run. */
static csi_status write_stats(csi_outset *set, const char *path, const char *in, const char *varfile,
                              const csi_device *dev, const csi_dump *d, const csi_dump_report *rep,
                              const csi_result *r, const double phase[3], double t0, const char *refine,
                              size_t refine_cells, size_t refine_pixels, size_t refine_settled,
                              size_t refine_stepped)
{
    csi_json *j = NULL;
    CSI_TRY(csi_json_new(&j));
    csi_json_str(j, "tool", "csi-reconstruct");
    csi_json_str(j, "input", in);
    if (varfile) /* named, or found beside the dump: either way an input of the run */
        csi_json_str(j, "variance", varfile);
    csi_json_str(j, "device", csi_device_name(dev));
    cli_json_grid(j, &d->grid);
    csi_json_int(j, "records", (int64_t)rep->records);
    csi_json_int(j, "duplicates", (int64_t)rep->duplicates);
    csi_json_int(j, "dropped_invalid", (int64_t)rep->dropped_invalid);
    csi_result_stats(r, j);
    csi_result_stats_phases(r, j, phase[0], phase[1], phase[2]);
    csi_json_num(j, "t_wall_s", cli_now() - t0);
    csi_json_int(j, "device_peak_bytes", (int64_t)csi_device_bytes_peak());
    if (refine) { /* the request's size, also when none was written (0 cells) */
        csi_json_int(j, "refine_cells", (int64_t)refine_cells);
        csi_json_int(j, "refine_pixels", (int64_t)refine_pixels);
        csi_json_int(j, "refine_settled", (int64_t)refine_settled);
        csi_json_int(j, "refine_step_moved", (int64_t)refine_stepped);
    }
    const csi_status s = cli_write_stats(set, path, j);
    csi_json_free(j);
    return s;
}

int main(int argc, char **argv)
{
    enum { O_PNG = 256, O_FRAMES, O_STATS, O_DROP, O_DEVICE, O_VERSION, O_SEED, O_VARIANCE, O_REFINE, O_REFINE_SHARE,
           O_REFINE_WITH, O_CACHE_PROGRAMS };
    static const struct option longopts[] = {
        {"output", required_argument, 0, 'o'}, {"png", required_argument, 0, O_PNG},
        {"frames", required_argument, 0, O_FRAMES}, {"stats", required_argument, 0, O_STATS},
        {"drop-invalid", no_argument, 0, O_DROP}, {"variance", required_argument, 0, O_VARIANCE},
        {"device", required_argument, 0, O_DEVICE}, {"refine-request", required_argument, 0, O_REFINE},
        {"refine-share", required_argument, 0, O_REFINE_SHARE}, {"refine-with", required_argument, 0, O_REFINE_WITH},
        {"seed", required_argument, 0, O_SEED}, {"quiet", no_argument, 0, 'q'},
        {"cache-programs", no_argument, 0, O_CACHE_PROGRAMS}, {"help", no_argument, 0, 'h'},
        {"version", no_argument, 0, O_VERSION}, CLI_TILE_LONGOPTS,
        {0, 0, 0, 0}};
    cli_quiet_kernel_builds();
    cli_heap_keep_freed();
    cli_outputs outs = {0};
    cli_tile_opts tile = {0};
    csi_options *opt = NULL;
    if (csi_options_new(&opt) != CSI_OK)
        return cli_error(prog, CSI_ERR_NOMEM, "%s", cli_last_error());
    bool quiet = false, drop = false, seed_given = false, cache_programs = false;
    const char *device = NULL, *varfile = NULL, *refine = NULL, *refine_with = NULL;
    double refine_share = csi_refine_share_default();
    bool share_given = false;
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
        case O_DROP: drop = true; break;
        case O_VARIANCE: varfile = optarg; break;
        case O_REFINE: refine = optarg; break;
        case O_REFINE_WITH: refine_with = optarg; break;
        case O_REFINE_SHARE: {
            char *end;
            share_given = true;
            refine_share = strtod(optarg, &end);
            if (end == optarg || *end || !(refine_share > 0 && refine_share <= 1))
                rc = cli_error(prog, CSI_ERR_ARG, "--refine-share: '%s' is not a number with 0 < S <= 1", optarg);
            break;
        }
        case O_SEED: {
            uint64_t v;
            if (!cli_parse_u64(optarg, 0, UINT64_MAX, &v))
                rc = cli_error(prog, CSI_ERR_ARG, "--seed: '%s' is not a whole number from 0 to 2^64 - 1", optarg);
            else
                rc = csi_options_set(opt, "seed", optarg) == CSI_OK ? 0 : cli_error(prog, CSI_ERR_ARG, "--%s", cli_last_error());
            seed_given = true;
            break;
        }
        case O_DEVICE: device = optarg; break;
        case O_CACHE_PROGRAMS: cache_programs = true; break;
        case 'q': quiet = true; break;
        case 'h': usage(stdout); rc = -1; break;
        case O_VERSION: printf("csi-reconstruct %s\n", CSI_VERSION); rc = -1; break;
        default:
            rc = cli_tile_option(prog, c, optarg, &tile);
            if (rc < 0)
                rc = cli_recon_option_or_fail(prog, c, optarg, argv[optind - 1], opt);
        }
    }
    free(all_opts);
    if (rc) {
        csi_options_free(opt);
        return rc < 0 ? 0 : rc;
    }
    if (device && !strcmp(device, "list")) {
        char buf[8192];
        csi_options_free(opt);
        if (csi_device_list(buf, sizeof buf) != CSI_OK)
            return cli_error(prog, CSI_ERR_DEVICE, "%s", cli_last_error());
        fputs(buf[0] ? buf : "no OpenCL devices\n", stdout);
        return 0;
    }
    if (cache_programs) {
        csi_options_free(opt);
        if (optind != argc)
            return cli_error(prog, CSI_ERR_ARG, "--cache-programs takes no input (%s given)", argv[optind]);
        return cli_cache_programs(prog, device, quiet);
    }
    if (optind != argc - 1)
        rc = cli_error(prog, CSI_ERR_ARG, optind >= argc ? "no sample dump given (see --help)"
                                                        : "more than one input given (see --help)");
    const char *in = argv[optind];
    if (!rc)
        rc = cli_tile_check(prog, &tile, outs.png != NULL, outs.frames_dir != NULL);
    if (!rc && tile.one && !outs.exr)
        rc = cli_error(prog, CSI_ERR_ARG, "--tile needs -o PARTIAL (the tile's partial result)");
    const bool no_variance = varfile && !strcmp(varfile, "none");
    if (no_variance)
        varfile = NULL;
    if (!rc && varfile && drop)
        rc = cli_error(prog, CSI_ERR_ARG, "--variance and --drop-invalid: a dropped record would leave its "
                       "variance without a sample");
    char *found = !rc && !varfile && !no_variance && !drop ? variance_beside(in) : NULL;
    if (found)
        varfile = found;
    if (!rc && !outs.exr && !outs.png && !tile.info)
        rc = cli_error(prog, CSI_ERR_ARG, "no output given: use -o OUT.exr and/or --png OUT.png");
    if (!rc && (refine || refine_with) && (tile.one || tile.info))
        rc = cli_error(prog, CSI_ERR_ARG, "--refine-%s needs the whole image, not --tile", refine ? "request" : "with");
    if (!rc && refine && refine_with)
        rc = cli_error(prog, CSI_ERR_ARG, "--refine-request and --refine-with: the first pass asks, the second "
                       "applies; give one");
    /* A first pass for a second (csi/settle.h): the pick and its completion need the pixels that
     * decide the image as the fit left them; the second pass samples them instead of settling. */
    if (!rc && refine && option_is(opt, "settle", "on"))
        rc = cli_error(prog, CSI_ERR_ARG, "--settle on and --refine-request: the second pass samples the pixels "
                       "that --settle would give their means; give one");
    if (!rc && refine_with && option_is(opt, "settle", "on"))
        rc = cli_error(prog, CSI_ERR_ARG, "--settle on and --refine-with: the pixels the second pass sampled are "
                       "given their means, and with the samples' variances the settling follows by itself "
                       "(--settle off: not)");
    if (!rc && refine && option_is(opt, "step-coverage", "on"))
        rc = cli_error(prog, CSI_ERR_ARG, "--step-coverage on and --refine-request: the second pass samples the "
                       "pixels that step would move; give one");
    if (!rc && refine_with && option_is(opt, "step-coverage", "on"))
        rc = cli_error(prog, CSI_ERR_ARG, "--step-coverage on and --refine-with: the first pass goes without the "
                       "step, and with both dumps' variances it follows the passes by itself (--step-coverage "
                       "off: not)");
    /* After the second pass, with the samples' variances, the pixels that still decide the image
     * settle on all their samples (csi_refine_settle), unless --settle off says not to. */
    const bool settle_after = (refine || refine_with) && !option_is(opt, "settle", "off");
    const bool step_after = (refine || refine_with) && !option_is(opt, "step-coverage", "off");
    if (!rc && (refine || refine_with)) {
        csi_options_set(opt, "settle", "off");
        csi_options_set(opt, "step-coverage", "off");
    }
    if (!rc && share_given && !refine && !refine_with) /* as csi-mitsuba: an option with nothing to act on */
        rc = cli_error(prog, CSI_ERR_ARG, "--refine-share applies to --refine-request or --refine-with only");
    if (rc) {
        csi_options_free(opt);
        free(found);
        return rc;
    }
    if (tile.frames)
        csi_options_set(opt, "frames", "on");
    const bool frames = option_is(opt, "frames", "on"), mean = option_is(opt, "estimator", "mean");

    csi_status s;
    csi_dump dump = {0}, var = {0}, more = {0}, more_variance = {0};
    csi_dump_report drep = {0}, vrep = {0};
    csi_dump_read_opts ropts = {.drop_invalid = drop};
    double phase[3] = {0}; /* reading the dump, making the device, writing the outputs (s) */
    double tp = cli_now();
    csi_outset *set = NULL;
    csi_device *dev = NULL;
    csi_result *res = NULL;
    /* Sizes before work: the header alone decides whether the run can fit (docs/dump-format.md). */
    csi_dump_header hdr, vhdr = {0};
    s = csi_dump_read_header(in, &ropts, &hdr);
    bool var_failed = false; /* the variances' file is what failed (a found one gets a hint) */
    if (s == CSI_OK && varfile) /* its header too: a missing or damaged file fails here, its bytes count */
        var_failed = (s = csi_dump_read_header(varfile, &ropts, &vhdr)) != CSI_OK;
    if (s == CSI_OK && hdr.grid.t > 1 && option_is(opt, "solver", "romp"))
        s = cli_fail(CSI_ERR_ARG, "%s: ROMP is real-valued and a volume (grid_t = %u) needs the complex 3-D "
                     "Fourier problem: use --solver sparsa", in, hdr.grid.t);
    /* Every output stated before any work, written all or nothing at the end (csi_outset). */
    if (s == CSI_OK)
        s = cli_outset_new(&set);
    if (s == CSI_OK)
        s = csi_outset_input(set, in);
    if (s == CSI_OK && varfile)
        s = csi_outset_input(set, varfile);
    if (s == CSI_OK)
        s = cli_outputs_stage(&outs, set, frames && !mean && hdr.grid.t > 1 ? hdr.grid.t : 0);
    if (s == CSI_OK && (refine || refine_with) && hdr.grid.t > 1)
        s = cli_fail(CSI_ERR_ARG, "%s: --refine-%s picks pixels of an image; this dump is a volume "
                     "(grid_t = %u)", in, refine ? "request" : "with", hdr.grid.t);
    if (s == CSI_OK && (refine || refine_with) && mean)
        s = cli_fail(CSI_ERR_ARG, "--refine-%s: the mean estimator's image is the pixels' means, there is "
                     "nothing to refine", refine ? "request" : "with");
    csi_dump_header mhdr = {0};
    if (s == CSI_OK && refine_with && (s = csi_dump_read_header(refine_with, &ropts, &mhdr)) == CSI_OK &&
        (memcmp(&mhdr.grid, &hdr.grid, sizeof hdr.grid) || mhdr.channels != hdr.channels))
        s = cli_fail(CSI_ERR_ARG, "%s: a %ux%u grid for %ux%u with %u channels, %s's is %ux%u for %ux%u with %u: "
                     "not its refinement", refine_with, mhdr.grid.w, mhdr.grid.h, mhdr.grid.out_w, mhdr.grid.out_h,
                     mhdr.channels, in, hdr.grid.w, hdr.grid.h, hdr.grid.out_w, hdr.grid.out_h, hdr.channels);
    if (s == CSI_OK && refine_with)
        s = csi_outset_input(set, refine_with);
    /* MORE's variances, as the dump's: beside it (MORE.variance.csid), wherever the dump has them */
    char *more_var = s == CSI_OK && refine_with && varfile ? variance_beside(refine_with) : NULL;
    if (s == CSI_OK && more_var)
        s = csi_outset_input(set, more_var);
    if (s == CSI_OK && refine)
        s = csi_outset_file(set, refine, "the refinement request (--refine-request)");
    if (s == CSI_OK)
        s = csi_device_new(device, &dev);
    phase[1] = cli_now() - tp;
    if (s == CSI_OK) {
        const uint64_t k = (uint64_t)hdr.grid.w * hdr.grid.h * hdr.grid.t;
        s = csi_reconstruct_check(dev, &hdr.grid, hdr.channels, (size_t)(hdr.count < k ? hdr.count : k), opt,
                                  csi_dump_read_host_bytes(&hdr) + (varfile ? csi_dump_read_host_bytes(&vhdr) : 0),
                                  in);
    }
    tp = cli_now();
    if (s == CSI_OK)
        s = csi_dump_read(in, &ropts, &dump, &drep);
    if (s == CSI_OK && varfile)
        var_failed = (s = read_variance(varfile, in, &dump, &drep, &ropts, &var, &vrep)) != CSI_OK;
    csi_dump_report mrep = {0}, mvrep = {0};
    if (s == CSI_OK && refine_with)
        s = csi_dump_read(refine_with, &ropts, &more, &mrep);
    if (s == CSI_OK && more_var)
        s = read_variance(more_var, refine_with, &more, &mrep, &ropts, &more_variance, &mvrep);
    phase[0] = cli_now() - tp;
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s%s", cli_last_error(),
                       found && var_failed ? " (found beside the dump; --variance none ignores it)" : "");
        goto done;
    }
    if (!quiet && found)
        fprintf(stderr, "%s: each sample's variance from %s (beside the dump; --variance none ignores it)\n", prog,
                found);
    if (!quiet && drep.dropped_invalid)
        cli_warn(prog, "%s: dropped %llu records with NaN/Inf values (first: record %llu)", in, (unsigned long long)drep.dropped_invalid, (unsigned long long)drep.first_invalid);
    if (!quiet && drep.duplicates)
        cli_warn(prog, "%s: %llu records repeat a position; their values were averaged", in, (unsigned long long)drep.duplicates);
    if (!seed_given && dump.seed) { /* as csi-render ran it, so the result is the same */
        char text[24];
        snprintf(text, sizeof text, "%llu", (unsigned long long)dump.seed);
        csi_options_set(opt, "seed", text);
    }
    if (frames && dump.grid.t == 1 && !quiet)
        cli_warn(prog, "%s is a static dump (grid_t = 1): --frames writes nothing", in);

    if (refine_with) {
        const csi_samples fs = {dump.grid, dump.channels, dump.count, dump.pos, dump.values, dump.flags, NULL};
        const csi_samples ms = {more.grid, more.channels, more.count, more.pos, more.values, more.flags, NULL};
        if ((s = refinement_cells_check(refine_with, in, &fs, &ms)) != CSI_OK) {
            rc = cli_error(prog, s, "%s", cli_last_error());
            goto done;
        }
    }
    cli_progress bar;
    if (!cli_progress_init(&bar, prog, quiet)) {
        rc = cli_error(prog, CSI_ERR_ARG, "%s", cli_last_error());
        goto done;
    }
    cli_recon_progress ps;
    cli_recon_progress_init(&ps, &bar);
    const csi_samples samples = {dump.grid, dump.channels, dump.count, dump.pos, dump.values, dump.flags,
                                 varfile ? var.values : NULL};
    if (tile.one || tile.info) {
        rc = cli_tile_run_samples(prog, dev, set, &samples, in, opt, &tile, &outs, quiet, &ps);
        cli_progress_end(&bar);
        goto done;
    }
    const double t0 = cli_now();
    s = csi_reconstruct(dev, &samples, opt, cli_recon_progress_fn, &ps, &res);
    cli_progress_end(&bar);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s: %s", in, cli_last_error());
        goto done;
    }
    tp = cli_now();
    size_t refine_cells = 0, refine_pixels = 0, refine_settled = 0, refine_stepped = 0;
    if (refine)
        s = write_refinement(set, refine, &samples, res, refine_share, &refine_cells, &refine_pixels);
    if (s == CSI_OK && refine && !refine_cells) { /* no second pass: the image is final, as csi-mitsuba's */
        csi_image img;
        s = csi_result_image(res, &img);
        if (s == CSI_OK && settle_after)
            s = csi_refine_settle(&samples, NULL, &img, &refine_settled);
        if (s == CSI_OK && step_after)
            s = csi_refine_step_coverage(&samples, NULL, &img, &refine_stepped);
    }
    if (refine_with) {
        const csi_samples ms = {more.grid, more.channels, more.count, more.pos, more.values, more.flags,
                                more_var ? more_variance.values : NULL};
        s = apply_refinement(refine_with, in, &samples, &ms, res, refine_share, settle_after, step_after,
                             &refine_pixels, &refine_settled, &refine_stepped);
        refine_cells = more.count;
        if (s == CSI_OK && !quiet && step_after && varfile && !more_var && more.count)
            cli_warn(prog, "%s has no variances beside it (its .variance.csid): an HDR step's pixels keep their "
                     "values after the passes", refine_with);
    }
    if (s == CSI_OK)
        s = cli_write_images(&outs, set, res, NULL, &bar);
    phase[2] = cli_now() - tp;
    if (s == CSI_OK && outs.stats)
        s = write_stats(set, outs.stats, in, varfile, dev, &dump, &drep, res, phase, t0,
                        refine ? refine : refine_with, refine_cells, refine_pixels, refine_settled, refine_stepped);
    if (s == CSI_OK)
        s = csi_outset_commit(set);
    if (s != CSI_OK) {
        rc = cli_error(prog, s, "%s", cli_last_error());
        goto done;
    }
    if (!quiet) {
        const bool all = cli_warn_unconverged(prog, res, quiet);
        csi_result_info info;
        csi_result_info_get(res, &info);
        char used[32];
        fprintf(stderr, "%s: %ux%u from %zu samples of a %ux%ux%u grid (%s) in %.2f s%s\n", prog, dump.grid.out_w,
                dump.grid.out_h, info.n, dump.grid.w, dump.grid.h, dump.grid.t,
                cli_solver_or_estimator(res, used, sizeof used), cli_now() - t0, all ? "" : " (not converged)");
        if (refine_with) {
            fprintf(stderr, "%s: refine: %zu pixels given the mean of all their samples with %zu more from %s",
                    prog, refine_pixels, refine_cells, refine_with);
            if (refine_settled)
                fprintf(stderr, ", %zu more settled on their samples' mean", refine_settled);
            if (refine_stepped)
                fprintf(stderr, ", %zu across an HDR step given their window's coverage", refine_stepped);
            fputc('\n', stderr);
        } else if (refine && refine_cells)
            fprintf(stderr, "%s: refine: %zu cells of %zu pixels to sample next in %s\n", prog, refine_cells,
                    refine_pixels, refine);
        else if (refine)
            fprintf(stderr, "%s: refine: no pixel to refine; %s not written, the image is final (%zu pixels "
                    "settled, %zu across an HDR step moved)\n", prog, refine, refine_settled, refine_stepped);
    }
done:
    csi_result_free(res);
    cli_outset_free(set); /* nothing new is left when the run failed */
    csi_device_release(dev);
    csi_dump_free(&dump);
    csi_dump_free(&var);
    csi_dump_free(&more);
    csi_dump_free(&more_variance);
    free(found);
    free(more_var);
    csi_options_free(opt);
    return rc;
}
