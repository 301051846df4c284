/* Options by name (csi/csi.h): the public face of the option table (integrate/options.c). */
#include <stdlib.h>

#include "internal.h"

csi_status csi_options_new(csi_options **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_options_new: out is NULL");
    *out = malloc(sizeof **out);
    if (!*out)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for options");
    csi_recon_defaults(&(*out)->o);
    return CSI_OK;
}

void csi_options_free(csi_options *o)
{
    free(o);
}

csi_status csi_options_copy(const csi_options *src, csi_options **out)
{
    if (!src || !out)
        return csi_fail(CSI_ERR_ARG, "csi_options_copy: %s is NULL", src ? "out" : "src");
    *out = malloc(sizeof **out);
    if (!*out)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for options");
    **out = *src;
    return CSI_OK;
}

csi_status csi_options_set(csi_options *o, const char *name, const char *value)
{
    if (!o)
        return csi_fail(CSI_ERR_ARG, "csi_options_set: no options");
    return csi_recon_option_set(&o->o, name, value);
}

csi_status csi_options_set_number(csi_options *o, const char *name, double value)
{
    if (!o)
        return csi_fail(CSI_ERR_ARG, "csi_options_set_number: no options");
    return csi_recon_option_set_number(&o->o, name, value);
}

csi_status csi_options_get(const csi_options *o, const char *name, char *buf, size_t len)
{
    if (!o)
        return csi_fail(CSI_ERR_ARG, "csi_options_get: no options");
    return csi_recon_option_get(&o->o, name, buf, len);
}

csi_status csi_options_get_number(const csi_options *o, const char *name, double *out)
{
    if (!o || !out)
        return csi_fail(CSI_ERR_ARG, "csi_options_get_number: %s is NULL", o ? "out" : "options");
    return csi_recon_option_number(&o->o, name, out);
}
