/* Reconstruction options: names, parsers, defaults and the default rules that depend on the
 * problem size. See csi/reconstruct.h. */
#include "csi/reconstruct.h"

#include <math.h>
#include <string.h>
#include <strings.h>

const char *csi_solver_kind_name(csi_solver_kind k)
{
    switch (k) {
    case CSI_SOLVER_ROMP: return "romp";
    case CSI_SOLVER_SPARSA: return "sparsa";
    default: return "default";
    }
}

csi_status csi_solver_kind_parse(const char *s, csi_solver_kind *out)
{
    if (s && !strcasecmp(s, "romp"))
        *out = CSI_SOLVER_ROMP;
    else if (s && !strcasecmp(s, "sparsa"))
        *out = CSI_SOLVER_SPARSA;
    else
        return csi_fail(CSI_ERR_ARG, "unknown solver '%s' (expected romp or sparsa)", s ? s : "");
    return CSI_OK;
}

const char *csi_aa_output_name(csi_aa_output o)
{
    return o == CSI_AA_SHARP ? "sharp" : "filtered";
}

csi_status csi_aa_output_parse(const char *s, csi_aa_output *out)
{
    if (s && !strcasecmp(s, "filtered"))
        *out = CSI_AA_FILTERED;
    else if (s && !strcasecmp(s, "sharp"))
        *out = CSI_AA_SHARP;
    else
        return csi_fail(CSI_ERR_ARG, "unknown integration target '%s' (expected filtered or sharp)",
                        s ? s : "");
    return CSI_OK;
}

const char *csi_aa_correct_name(csi_aa_correct c)
{
    return c == CSI_CORRECT_CV ? "cv" : c == CSI_CORRECT_NONE ? "none" : "auto";
}

csi_status csi_aa_correct_parse(const char *s, csi_aa_correct *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_CORRECT_AUTO;
    else if (s && !strcasecmp(s, "none"))
        *out = CSI_CORRECT_NONE;
    else if (s && !strcasecmp(s, "cv"))
        *out = CSI_CORRECT_CV;
    else
        return csi_fail(CSI_ERR_ARG, "unknown correction '%s' (expected none, cv or auto)", s ? s : "");
    return CSI_OK;
}

const char *csi_switch_name(csi_switch s)
{
    return s == CSI_SWITCH_ON ? "on" : s == CSI_SWITCH_OFF ? "off" : "auto";
}

csi_status csi_switch_parse(const char *s, csi_switch *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_SWITCH_AUTO;
    else if (s && !strcasecmp(s, "on"))
        *out = CSI_SWITCH_ON;
    else if (s && !strcasecmp(s, "off"))
        *out = CSI_SWITCH_OFF;
    else
        return csi_fail(CSI_ERR_ARG, "'%s' is not on, off or auto", s ? s : "");
    return CSI_OK;
}

const char *csi_recon_stop_name(csi_recon_stop s)
{
    return s == CSI_STOP_GAP ? "gap" : s == CSI_STOP_OBJECTIVE ? "objective" : "auto";
}

csi_status csi_recon_stop_parse(const char *s, csi_recon_stop *out)
{
    if (s && !strcasecmp(s, "auto"))
        *out = CSI_STOP_AUTO;
    else if (s && !strcasecmp(s, "gap"))
        *out = CSI_STOP_GAP;
    else if (s && !strcasecmp(s, "objective"))
        *out = CSI_STOP_OBJECTIVE;
    else
        return csi_fail(CSI_ERR_ARG, "unknown stopping rule '%s' (expected gap, objective or auto)",
                        s ? s : "");
    return CSI_OK;
}

const char *csi_estimator_name(csi_estimator e)
{
    switch (e) {
    case CSI_EST_MEAN: return "mean";
    case CSI_EST_GAUSS: return "gauss";
    default: return "cs";
    }
}

csi_status csi_estimator_parse(const char *s, csi_estimator *out)
{
    if (s && !strcasecmp(s, "cs"))
        *out = CSI_EST_CS;
    else if (s && !strcasecmp(s, "mean"))
        *out = CSI_EST_MEAN;
    else if (s && !strcasecmp(s, "gauss"))
        *out = CSI_EST_GAUSS;
    else
        return csi_fail(CSI_ERR_ARG, "unknown estimator '%s' (expected cs, mean or gauss)", s ? s : "");
    return CSI_OK;
}

double csi_gauss_nc_default_sigma(size_t k, size_t n, int dims)
{
    if (n == 0 || k == 0 || dims < 1)
        return 1.0;
    return 0.5 * pow((double)k / (double)n, 1.0 / dims);
}

double csi_motion_tau_rel(size_t n)
{
    if (n == 0)
        return CSI_MOTION_TAU_MAX;
    double t = CSI_MOTION_TAU_C / sqrt((double)n);
    return t < CSI_MOTION_TAU_MIN ? CSI_MOTION_TAU_MIN : t > CSI_MOTION_TAU_MAX ? CSI_MOTION_TAU_MAX : t;
}

void csi_recon_defaults(csi_recon_options *o)
{
    memset(o, 0, sizeof *o);
    o->solver = CSI_SOLVER_DEFAULT;
    o->wavelet = CSI_WAVELET_DB4;
    o->lambda = 0.3f;
    o->seed = 1;
    o->sigma_scale = 1.0;
    o->output = CSI_AA_SHARP;
    o->correct = CSI_CORRECT_AUTO;
    o->cv_n0 = -1.0;
    o->sigma_spacing = -1.0;
    o->motion_resid_sigma = 0.0; /* on, width from the sampling density */
}
