/* Reconstruction through the public API (csi/csi.h): samples in host arrays, options by name, a
 * progress callback that can cancel, and the result behind accessors. */
#include <stdlib.h>
#include <string.h>

#include "result.h"

_Static_assert((int)CSI_OUTCOME_STALLED == (int)CSI_SOLVE_STALLED &&
                   (int)CSI_OUTCOME_NOT_IDENTIFIABLE == (int)CSI_SOLVE_NOT_IDENTIFIABLE &&
                   (int)CSI_OUTCOME_CONVERGED == (int)CSI_SOLVE_CONVERGED,
               "csi_outcome mirrors csi_solve_reason");

const char *csi_result_method_of(const csi_recon_options *o, const csi_grid *g)
{
    switch (o->estimator) {
    case CSI_EST_MEAN: return "sample mean (Monte Carlo)";
    case CSI_EST_GAUSS: return "Gaussian normalized convolution";
    default: return g->t > 1 ? "compressive motion (Alg. 2)" : "compressive antialias (Alg. 1)";
    }
}

bool csi_api_progress_relay(void *user, const char *phase, int iter, double rel_residual)
{
    const csi_api_progress *r = user;
    const csi_progress p = {phase, iter, rel_residual};
    return r->fn(r->user, &p);
}

csi_status csi_api_options_for(const csi_options *options, const csi_samples *s, const char *fn,
                               csi_recon_options *o)
{
    if (options)
        *o = options->o;
    else
        csi_recon_defaults(o);
    if (s->flags & ~(uint32_t)CSI_SAMPLES_KNOWN_FLAGS)
        return csi_fail(CSI_ERR_ARG, "%s: the samples' flags 0x%08x have reserved bits set (known: 0x%08x)", fn,
                        (unsigned)s->flags, CSI_SAMPLES_KNOWN_FLAGS);
    o->sample_flags = s->flags;
    o->sample_variance = s->variance;
    const csi_status st = csi_recon_check_variance(s->variance, s->count, s->channels);
    return st == CSI_OK ? CSI_OK : csi_fail_context(st, "%s: ", fn);
}

csi_status csi_reconstruct(csi_device *dev, const csi_samples *s, const csi_options *options,
                           csi_progress_fn progress, void *user, csi_result **out)
{
    if (out)
        *out = NULL;
    if (!dev || !s || !out)
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_reconstruct: %s is NULL",
                                               !dev ? "the device" : !s ? "the samples" : "out"));
    if (s->count && (!s->pos || !s->values))
        return csi_device_record(dev, csi_fail(CSI_ERR_ARG, "csi_reconstruct: %zu samples but no %s",
                                               s->count, s->pos ? "values" : "positions"));
    csi_recon_options o;
    CSI_TRY(csi_device_record(dev, csi_api_options_for(options, s, "csi_reconstruct", &o)));
    csi_result *r = calloc(1, sizeof *r);
    if (!r)
        return csi_device_record(dev, csi_fail(CSI_ERR_NOMEM, "out of host memory for a result"));
    csi_api_progress pr = {progress, user};
    o.progress = progress ? csi_api_progress_relay : NULL;
    o.user = &pr;
    csi_status st = csi_recon(dev->ctx, &s->grid, s->channels, s->pos, s->values, s->count, &o, &r->r);
    if (st != CSI_OK) {
        free(r);
        return csi_device_record(dev, st);
    }
    st = csi_result_finish(r, &s->grid);
    if (st != CSI_OK) {
        csi_result_free(r);
        return csi_device_record(dev, st);
    }
    *out = r;
    return CSI_OK;
}

csi_status csi_result_finish(csi_result *r, const csi_grid *g)
{
    r->options.o = r->r.options;
    r->options.o.progress = NULL;
    r->options.o.user = NULL;
    r->grid = *g;
    r->method = csi_result_method_of(&r->options.o, g);
    return csi_result_make_attributes(r);
}

csi_status csi_result_adopt(csi_recon_result *res, const csi_grid *g, csi_result **out)
{
    *out = NULL;
    csi_result *r = calloc(1, sizeof *r);
    if (!r) {
        csi_recon_result_free(res);
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a result");
    }
    r->r = *res;
    memset(res, 0, sizeof *res);
    const csi_status st = csi_result_finish(r, g);
    if (st != CSI_OK) {
        csi_result_free(r);
        return st;
    }
    *out = r;
    return CSI_OK;
}

void csi_result_free(csi_result *r)
{
    if (!r)
        return;
    csi_recon_result_free(&r->r);
    csi_tile_result_free(&r->tile); /* its sums (its pixels are r->r's) */
    free(r->attrs);
    free(r);
}

csi_status csi_result_image(const csi_result *r, csi_image *view)
{
    if (!r || !view)
        return csi_fail(CSI_ERR_ARG, "csi_result_image: %s is NULL", r ? "view" : "the result");
    *view = (csi_image){r->r.out_w, r->r.out_h, r->r.channels, r->r.image};
    return CSI_OK;
}

uint32_t csi_result_frame_count(const csi_result *r)
{
    return r ? r->r.nframes : 0;
}

csi_status csi_result_frame(const csi_result *r, uint32_t t, csi_image *view)
{
    if (!r || !view)
        return csi_fail(CSI_ERR_ARG, "csi_result_frame: %s is NULL", r ? "view" : "the result");
    if (t >= r->r.nframes)
        return csi_fail(CSI_ERR_ARG, "frame %u of a result with %u frames", t, r->r.nframes);
    const size_t plane = (size_t)r->r.out_w * r->r.out_h * r->r.channels;
    *view = (csi_image){r->r.out_w, r->r.out_h, r->r.channels, r->r.frames + t * plane};
    return CSI_OK;
}

const csi_options *csi_result_options(const csi_result *r)
{
    return r ? &r->options : NULL;
}

void csi_result_info_get(const csi_result *r, csi_result_info *out)
{
    memset(out, 0, sizeof *out);
    if (!r)
        return;
    out->method = r->method;
    out->solver = csi_recon_choice_name("solver", r->options.o.solver);
    out->k = r->r.k;
    out->n = r->r.n;
    out->t_setup = r->r.t_setup;
    out->t_solve = r->r.t_solve;
    out->t_integrate = r->r.t_integrate;
    out->tiles = r->is_tile ? r->tiling.count : r->r.tiles;
    out->tile = r->is_tile;
    if (r->is_tile) {
        out->tile_index = r->tile.index;
        out->tile_origin[0] = r->tile.x0;
        out->tile_origin[1] = r->tile.y0;
        out->tile_origin[2] = r->tile.t0;
    }
}

csi_status csi_result_report(const csi_result *r, uint32_t c, csi_channel_report *out)
{
    if (!r || !out)
        return csi_fail(CSI_ERR_ARG, "csi_result_report: %s is NULL", r ? "out" : "the result");
    if (c >= r->r.channels)
        return csi_fail(CSI_ERR_ARG, "channel %u of a result with %u channels", c, r->r.channels);
    const csi_solve_report *p = &r->r.report[c];
    *out = (csi_channel_report){
        .converged = p->converged,
        .outcome = (csi_outcome)p->reason,
        .reason = csi_solve_reason_name(p->reason),
        .message = p->message,
        .iterations = p->iterations,
        .inner_iterations = p->inner_iterations,
        .rel_residual = p->rel_residual,
        .objective = p->objective,
        .tau = p->tau,
        .support = p->support,
        .seconds = p->t_total,
    };
    return CSI_OK;
}
