/* Devices (csi/csi.h): an OpenCL context and queue chosen by name, with the first unread
 * failure of the calls made with it (as OIDN's devices keep theirs). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

#include "csi/program_cache.h"

csi_status csi_device_record(csi_device *dev, csi_status st)
{
    if (st != CSI_OK && dev && dev->error == CSI_OK) {
        dev->error = st;
        snprintf(dev->message, sizeof dev->message, "%s", csi_last_error());
    }
    return st;
}

csi_status csi_device_new(const char *name, csi_device **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_device_new: no place for the device (out is NULL)");
    *out = NULL;
    csi_device *dev = calloc(1, sizeof *dev);
    if (!dev)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a device");
    csi_status st = csi_ctx_create(&dev->ctx, name);
    if (st != CSI_OK) {
        free(dev);
        return st;
    }
    *out = dev;
    return CSI_OK;
}

void csi_device_release(csi_device *dev)
{
    if (!dev)
        return;
    csi_ctx_release(dev->ctx);
    free(dev);
}

csi_status csi_cached_programs_dir(char *buf, size_t len)
{
    if (!buf || !len)
        return csi_fail(CSI_ERR_ARG, "csi_cached_programs_dir: no place for the folder (buf is NULL or empty)");
    buf[0] = '\0';
    return csi_program_cache_require_dir(buf, len);
}

csi_status csi_device_cache_programs(csi_device *dev, int *stored)
{
    if (stored)
        *stored = 0;
    if (!dev)
        return csi_fail(CSI_ERR_ARG, "csi_device_cache_programs: no device (dev is NULL)");
    return csi_ctx_cache_programs(dev->ctx, NULL, stored);
}

const char *csi_device_name(const csi_device *dev)
{
    return dev ? csi_ctx_device_name(dev->ctx) : "";
}

csi_status csi_device_error(csi_device *dev, const char **message)
{
    if (!dev) {
        static _Thread_local char thread_reported[2048];
        const csi_status st = csi_last_status();
        snprintf(thread_reported, sizeof thread_reported, "%s", csi_last_error());
        csi_clear_error();
        if (message)
            *message = thread_reported;
        return st;
    }
    const csi_status st = dev->error;
    memcpy(dev->reported, dev->message, sizeof dev->reported);
    if (message)
        *message = dev->reported;
    dev->error = CSI_OK;
    dev->message[0] = '\0';
    return st;
}

csi_status csi_device_list(char *buf, size_t len)
{
    if (!buf || len == 0)
        return csi_fail(CSI_ERR_ARG, "csi_device_list: no buffer");
    return csi_list_devices(buf, len);
}
