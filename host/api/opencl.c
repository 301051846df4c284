/* Devices on the caller's OpenCL objects (csi/csi_opencl.h). */
#include <stdlib.h>

#include "csi/csi_opencl.h"
#include "internal.h"

csi_status csi_device_new_opencl(cl_context context, cl_device_id device, cl_command_queue queue,
                                 csi_device **out)
{
    if (!out)
        return csi_fail(CSI_ERR_ARG, "csi_device_new_opencl: out is NULL");
    *out = NULL;
    csi_device *dev = calloc(1, sizeof *dev);
    if (!dev)
        return csi_fail(CSI_ERR_NOMEM, "out of host memory for a device");
    csi_status st = csi_ctx_wrap(context, device, queue, &dev->ctx);
    if (st != CSI_OK) {
        free(dev);
        return st;
    }
    *out = dev;
    return CSI_OK;
}

cl_context csi_device_opencl_context(const csi_device *dev)
{
    return dev ? csi_ctx_context(dev->ctx) : NULL;
}

cl_device_id csi_device_opencl_device(const csi_device *dev)
{
    return dev ? csi_ctx_device(dev->ctx) : NULL;
}

cl_command_queue csi_device_opencl_queue(const csi_device *dev)
{
    return dev ? csi_ctx_queue(dev->ctx) : NULL;
}
