/* What a result says about itself: EXR attributes and statistics, both listing every option as
 * used (from the option table), so that an image and its JSON tell how they were made. The
 * attributes hold only what the inputs decide (no timings): the same inputs and seed give the
 * same bytes. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "result.h"

enum { FIGURES = 9, NAME_LEN = 64, TEXT_LEN = 48 };

csi_status csi_result_make_attributes(csi_result *r)
{
    const size_t nopt = csi_option_count(), cap = FIGURES + nopt;
    /* One block: the attributes, then their names and texts. */
    const size_t bytes = cap * (sizeof(csi_attr) + NAME_LEN + TEXT_LEN) + TEXT_LEN;
    char *block = malloc(bytes);
    if (!block)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for the result's attributes");
    csi_attr *a = (csi_attr *)block;
    char (*names)[NAME_LEN] = (char (*)[NAME_LEN])(block + cap * sizeof(csi_attr));
    char (*texts)[TEXT_LEN] = (char (*)[TEXT_LEN])(block + cap * (sizeof(csi_attr) + NAME_LEN));
    char *software = block + cap * (sizeof(csi_attr) + NAME_LEN + TEXT_LEN);
    snprintf(software, TEXT_LEN, "csi %s", csi_version());
    double iters = 0, resid = 0;
    for (uint32_t c = 0; c < r->r.channels; c++) {
        iters += r->r.report[c].iterations;
        if (r->r.report[c].rel_residual > resid)
            resid = r->r.report[c].rel_residual;
    }
    size_t n = 0;
    a[n++] = CSI_ATTR_S("csi:software", software);
    a[n++] = CSI_ATTR_S("csi:method", r->method);
    a[n++] = CSI_ATTR_S("csi:solver", csi_recon_choice_name("solver", r->options.o.solver));
    a[n++] = CSI_ATTR_D("csi:tau", r->r.report[0].tau);
    a[n++] = CSI_ATTR_D("csi:samples", (double)r->r.n);
    a[n++] = CSI_ATTR_D("csi:unknowns", (double)r->r.k);
    a[n++] = CSI_ATTR_D("csi:tiles", (double)(r->is_tile ? r->tiling.count : r->r.tiles));
    a[n++] = CSI_ATTR_D("csi:iterations", iters);
    a[n++] = CSI_ATTR_D("csi:max_rel_residual", resid);
    for (size_t i = 0; i < nopt; i++) {
        csi_option_info info;
        double v;
        if (csi_option_describe(i, &info) != CSI_OK)
            continue;
        snprintf(names[n], NAME_LEN, "csi:option:%s", info.name);
        if (csi_recon_option_value(&r->options.o, i, &v, texts[n], TEXT_LEN))
            a[n] = CSI_ATTR_D(names[n], v);
        else
            a[n] = CSI_ATTR_S(names[n], texts[n]);
        n++;
    }
    r->attrs = a;
    r->nattrs = n;
    return CSI_OK;
}

size_t csi_result_attributes(const csi_result *r, const csi_attr **attrs)
{
    *attrs = r ? r->attrs : NULL;
    return r ? r->nattrs : 0;
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

void csi_result_stats(const csi_result *r, csi_json *j)
{
    if (!r || !j)
        return;
    const csi_recon_result *res = &r->r;
    char text[64];
    snprintf(text, sizeof text, "%016llx",
             (unsigned long long)image_hash(res->image, (size_t)res->out_w * res->out_h * res->channels));
    csi_json_str(j, "image_fnv1a64", text);
    csi_json_str(j, "method", r->method);
    csi_json_str(j, "solver", csi_recon_choice_name("solver", r->options.o.solver));
    csi_json_int(j, "k", (int64_t)res->k);
    csi_json_int(j, "n", (int64_t)res->n);
    csi_json_num(j, "sampling_fraction", res->k ? (double)res->n / (double)res->k : 0);
    csi_json_int(j, "tiles", r->is_tile ? r->tiling.count : res->tiles);
    if (r->is_tile)
        csi_json_int(j, "tile", r->tile.index);
    csi_json_int(j, "unknowns", (int64_t)res->unknowns);
    csi_json_int(j, "model_grid_factor", res->model_factor);
    if (res->chroma_model_factor) /* "channels" then holds the solves of Y, C1, C2 */
        csi_json_int(j, "chroma_model_grid_factor", res->chroma_model_factor);
    /* Every option, as used: the autos that apply resolved, the others "auto". */
    csi_json_begin(j, "options");
    for (size_t i = 0; i < csi_option_count(); i++) {
        csi_option_info info;
        char key[64];
        double v;
        if (csi_option_describe(i, &info) != CSI_OK)
            continue;
        snprintf(key, sizeof key, "%s", info.name);
        for (char *p = key; *p; p++)
            *p = *p == '-' ? '_' : *p;
        if (csi_recon_option_value(&r->options.o, i, &v, text, sizeof text))
            csi_json_num(j, key, v);
        else
            csi_json_str(j, key, text);
    }
    csi_json_end(j);
    /* settling is the last step of the whole image: a merge of tiles does it too */
    if (r->options.o.settle == CSI_SWITCH_ON)
        csi_json_int(j, "settled_pixels", (int64_t)res->settled);
    /* after it, given the samples' variances (none moved without them) */
    if (r->options.o.step_coverage == CSI_SWITCH_ON)
        csi_json_int(j, "step_coverage_pixels", (int64_t)res->step_moved);
    csi_json_num(j, "t_setup_s", res->t_setup);
    if (res->t_velocity > 0)
        csi_json_num(j, "t_velocity_s", res->t_velocity); /* of t_setup */
    if (res->velocity_evals > 0)
        csi_json_int(j, "velocity_evaluations", res->velocity_evals);
    csi_json_num(j, "t_solve_s", res->t_solve);
    csi_json_num(j, "t_integrate_s", res->t_integrate);
    csi_json_begin(j, "channels");
    static const char *names[4] = {"0", "1", "2", "3"};
    for (uint32_t c = 0; c < res->channels && c < 4; c++) {
        const csi_solve_report *p = &res->report[c];
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

void csi_result_stats_phases(const csi_result *r, csi_json *j, double read_s, double device_s, double write_s)
{
    if (!r || !j)
        return;
    const csi_recon_result *res = &r->r;
    static const char *names[4] = {"0", "1", "2", "3"};
    csi_json_begin(j, "phases");
    csi_json_num(j, "read_s", read_s);
    csi_json_num(j, "device_s", device_s);
    csi_json_num(j, "programs_s", res->t_programs);
    csi_json_num(j, "setup_s", res->t_setup);
    csi_json_begin(j, "solve_s");
    for (uint32_t c = 0; c < res->channels && c < 4; c++)
        csi_json_num(j, names[c], res->report[c].t_total);
    csi_json_end(j);
    csi_json_begin(j, "integrate_s");
    for (uint32_t c = 0; c < res->channels && c < 4; c++)
        csi_json_num(j, names[c], res->t_channel_integrate[c]);
    csi_json_end(j);
    /* the steps on the whole image, where they ran (their solves are in solve_s and integrate_s) */
    if (r->options.o.cv_select == CSI_SWITCH_ON)
        csi_json_num(j, "cross_validation_s", res->t_cv);
    csi_json_num(j, "write_s", write_s);
    csi_json_end(j);
    if (r->options.o.cv_select == CSI_SWITCH_ON)
        csi_json_int(j, "cv_switched_pixels", (int64_t)res->cv_switched);
    if (r->options.o.cv_smooth == CSI_SWITCH_ON)
        csi_json_int(j, "cv_smoothed_pixels", (int64_t)res->cv_smoothed);
    if (r->options.o.peak_range == CSI_SWITCH_ON)
        csi_json_int(j, "peak_range_pixels", (int64_t)res->peak_range_pixels);
    if (r->options.o.motion_image_cv == CSI_SWITCH_ON)
        csi_json_int(j, "motion_image_switched_pixels", (int64_t)res->motion_image_switched);
    /* the frames' Gaussian frames_denoise chose (one choice per tile in a tiled run: not here) */
    if (r->options.o.frames_denoise == CSI_SWITCH_ON && r->options.o.tiles <= 1 && res->frames_sigma[0] >= 0) {
        csi_json_num(j, "frames_sigma_xy", res->frames_sigma[0]);
        csi_json_num(j, "frames_sigma_t", res->frames_sigma[1]);
        csi_json_num(j, "frames_denoise_s", res->t_frames);
    }
    csi_json_num(j, "fixed_s", read_s + device_s + res->t_setup);
    csi_json_num(j, "per_sample_us", res->n ? 1e6 * (res->t_solve + res->t_integrate) / (double)res->n : 0);
    csi_json_num(j, "cpu_setup_s", res->cpu_setup);
    csi_json_num(j, "cpu_work_s", res->cpu_work);
    csi_json_num(j, "cpu_per_sample_us", res->n ? 1e6 * res->cpu_work / (double)res->n : 0);
}
