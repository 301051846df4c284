#include "outputs.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "csi/dump.h"
#include "csi/image.h"

static void frame_name(char *buf, size_t len, uint32_t t, const char *ext)
{
    snprintf(buf, len, "frame_%04u.%s", t, ext);
}

csi_status cli_outputs_stage(const cli_outputs *o, csi_outset *set, uint32_t nframes)
{
    if (o->exr)
        CSI_TRY(csi_outset_file(set, o->exr, "the image (-o)"));
    if (o->png)
        CSI_TRY(csi_outset_file(set, o->png, "the preview (--png)"));
    if (o->stats)
        CSI_TRY(csi_outset_file(set, o->stats, "the statistics (--stats)"));
    if (o->frames_dir && nframes) {
        CSI_TRY(csi_outset_dir(set, o->frames_dir, "the frames folder (--frames)"));
        for (uint32_t t = 0; t < nframes; t++) {
            char name[32];
            frame_name(name, sizeof name, t, "exr");
            CSI_TRY(csi_outset_dir_file(set, o->frames_dir, name, "a frame (--frames)"));
            frame_name(name, sizeof name, t, "png");
            CSI_TRY(csi_outset_dir_file(set, o->frames_dir, name, "a frame's preview (--frames)"));
        }
    }
    return CSI_OK;
}

/* FNV-1a over the float bits of the image: two runs agree on it exactly when their pixels do. */
static uint64_t image_hash(const float *a, size_t n)
{
    uint64_t h = 1469598103934665603ull;
    const unsigned char *b = (const unsigned char *)a;
    for (size_t i = 0; i < n * sizeof(float); i++) {
        h ^= b[i];
        h *= 1099511628211ull;
    }
    return h;
}

void cli_stats_recon(csi_json *j, const csi_recon_result *r)
{
    char hash[32];
    snprintf(hash, sizeof hash, "%016llx",
             (unsigned long long)image_hash(r->image, (size_t)r->out_w * r->out_h * r->channels));
    csi_json_str(j, "image_fnv1a64", hash);
    csi_json_str(j, "solver", csi_recon_choice_name("solver", r->options.solver));
    csi_json_int(j, "k", (int64_t)r->k);
    csi_json_int(j, "n", (int64_t)r->n);
    csi_json_num(j, "sampling_fraction", r->k ? (double)r->n / (double)r->k : 0);
    csi_json_int(j, "tiles", r->tiles);
    csi_json_int(j, "unknowns", (int64_t)r->unknowns);
    csi_json_int(j, "model_grid_factor", r->model_factor);
    /* Every option, as used: the autos that apply resolved, the others "auto". */
    csi_json_begin(j, "options");
    for (size_t i = 0; i < csi_option_count(); i++) {
        csi_option_info info;
        char key[64], text[64];
        double v;
        if (csi_option_describe(i, &info) != CSI_OK)
            continue;
        snprintf(key, sizeof key, "%s", info.name);
        for (char *p = key; *p; p++)
            *p = *p == '-' ? '_' : *p;
        if (csi_recon_option_number(&r->options, info.name, &v) == CSI_OK)
            csi_json_num(j, key, v);
        else if (csi_recon_option_get(&r->options, info.name, text, sizeof text) == CSI_OK)
            csi_json_str(j, key, text);
    }
    csi_json_end(j);
    csi_clear_error();
    csi_json_num(j, "t_setup_s", r->t_setup);
    csi_json_num(j, "t_solve_s", r->t_solve);
    csi_json_num(j, "t_integrate_s", r->t_integrate);
    csi_json_begin(j, "channels");
    static const char *names[4] = {"0", "1", "2", "3"};
    for (uint32_t c = 0; c < r->channels; c++) {
        const csi_solve_report *p = &r->report[c];
        csi_json_begin(j, names[c]);
        csi_json_bool(j, "converged", p->converged);
        csi_json_str(j, "reason", csi_solve_reason_name(p->reason));
        csi_json_str(j, "message", p->message);
        csi_json_int(j, "iterations", p->iterations);
        csi_json_int(j, "inner_iterations", p->inner_iterations);
        csi_json_int(j, "applies", p->applies);
        csi_json_int(j, "adjoints", p->adjoints);
        csi_json_num(j, "rel_residual", p->rel_residual);
        csi_json_num(j, "objective", p->objective);
        csi_json_num(j, "tau", p->tau);
        csi_json_int(j, "support", (int64_t)p->support);
        csi_json_num(j, "t_total_s", p->t_total);
        csi_json_end(j);
    }
    csi_json_end(j);
}

void cli_stats_phases(csi_json *j, const cli_phase_times *t, const csi_recon_result *r)
{
    static const char *names[4] = {"0", "1", "2", "3"};
    csi_json_begin(j, "phases");
    csi_json_num(j, "read_s", t->read);
    csi_json_num(j, "device_s", t->device);
    csi_json_num(j, "programs_s", r->t_programs);
    csi_json_num(j, "setup_s", r->t_setup);
    csi_json_begin(j, "solve_s");
    for (uint32_t c = 0; c < r->channels; c++)
        csi_json_num(j, names[c], r->report[c].t_total);
    csi_json_end(j);
    csi_json_begin(j, "integrate_s");
    for (uint32_t c = 0; c < r->channels; c++)
        csi_json_num(j, names[c], r->t_channel_integrate[c]);
    csi_json_end(j);
    csi_json_num(j, "write_s", t->write);
    csi_json_end(j);
    csi_json_num(j, "fixed_s", t->read + t->device + r->t_setup);
    csi_json_num(j, "per_sample_us", r->n ? 1e6 * (r->t_solve + r->t_integrate) / (double)r->n : 0);
    csi_json_num(j, "cpu_setup_s", r->cpu_setup);
    csi_json_num(j, "cpu_work_s", r->cpu_work);
    csi_json_num(j, "cpu_per_sample_us", r->n ? 1e6 * r->cpu_work / (double)r->n : 0);
}

static csi_status write_one(csi_outset *set, const char *exr, const char *png, const float *planes, uint32_t w,
                            uint32_t h, uint32_t channels, const csi_attr *attrs, size_t nattrs)
{
    const char *exr_tmp = NULL, *png_tmp = NULL;
    if (exr)
        CSI_TRY(csi_outset_tmp(set, exr, &exr_tmp));
    if (png)
        CSI_TRY(csi_outset_tmp(set, png, &png_tmp));
    csi_image img = {0};
    CSI_TRY(csi_image_alloc(&img, w, h, channels));
    memcpy(img.data, planes, (size_t)w * h * channels * sizeof(float));
    csi_status s = CSI_OK;
    if (exr_tmp)
        s = cli_named(csi_exr_write(exr_tmp, &img, attrs, nattrs), exr_tmp, exr);
    if (s == CSI_OK && png_tmp)
        s = cli_named(csi_png_write(png_tmp, &img), png_tmp, png);
    csi_image_free(&img);
    return s;
}

csi_status cli_write_images(const cli_outputs *o, csi_outset *set, const csi_recon_result *r, const char *method)
{
    double iters = 0, resid = 0;
    for (uint32_t c = 0; c < r->channels; c++) {
        iters += r->report[c].iterations;
        if (r->report[c].rel_residual > resid)
            resid = r->report[c].rel_residual;
    }
    char ver[64];
    snprintf(ver, sizeof ver, "csi %s", CSI_VERSION);
    /* The run's figures, then every option as used ("csi:option:NAME"; numbers as doubles,
     * choices, flags, auto and off as strings): only what the inputs decide, so the same inputs
     * and seed give the same bytes (timings are in the statistics, --stats). */
    enum { MAX_ATTRS = 160 };
    csi_attr attrs[MAX_ATTRS];
    char texts[MAX_ATTRS][48], names[MAX_ATTRS][64];
    size_t nattrs = 0;
    attrs[nattrs++] = CSI_ATTR_S("csi:software", ver);
    attrs[nattrs++] = CSI_ATTR_S("csi:method", method);
    attrs[nattrs++] = CSI_ATTR_S("csi:solver", csi_recon_choice_name("solver", r->options.solver));
    attrs[nattrs++] = CSI_ATTR_D("csi:tau", r->report[0].tau);
    attrs[nattrs++] = CSI_ATTR_D("csi:samples", (double)r->n);
    attrs[nattrs++] = CSI_ATTR_D("csi:unknowns", (double)r->k);
    attrs[nattrs++] = CSI_ATTR_D("csi:tiles", (double)r->tiles);
    attrs[nattrs++] = CSI_ATTR_D("csi:iterations", iters);
    attrs[nattrs++] = CSI_ATTR_D("csi:max_rel_residual", resid);
    for (size_t i = 0; i < csi_option_count() && nattrs < MAX_ATTRS; i++) {
        csi_option_info info;
        double v;
        if (csi_option_describe(i, &info) != CSI_OK)
            continue;
        snprintf(names[nattrs], sizeof names[nattrs], "csi:option:%s", info.name);
        if (csi_recon_option_number(&r->options, info.name, &v) == CSI_OK) {
            attrs[nattrs] = CSI_ATTR_D(names[nattrs], v);
        } else {
            csi_recon_option_get(&r->options, info.name, texts[nattrs], sizeof texts[nattrs]);
            attrs[nattrs] = CSI_ATTR_S(names[nattrs], texts[nattrs]);
        }
        nattrs++;
    }
    csi_clear_error();
    CSI_TRY(write_one(set, o->exr, o->png, r->image, r->out_w, r->out_h, r->channels, attrs, nattrs));
    if (o->frames_dir && r->nframes) {
        const size_t plane = (size_t)r->out_w * r->out_h * r->channels;
        for (uint32_t t = 0; t < r->nframes; t++) {
            char exr[PATH_MAX], png[PATH_MAX], name[32];
            frame_name(name, sizeof name, t, "exr");
            snprintf(exr, sizeof exr, "%s/%s", o->frames_dir, name);
            frame_name(name, sizeof name, t, "png");
            snprintf(png, sizeof png, "%s/%s", o->frames_dir, name);
            CSI_TRY(write_one(set, exr, png, r->frames + t * plane, r->out_w, r->out_h, r->channels, attrs,
                              nattrs));
        }
    }
    return CSI_OK;
}
