/* csi on the caller's OpenCL objects: the opt-in interop part of the public API.
 *
 * A renderer that already runs OpenCL can give csi its own context, device and queue, so that
 * csi's kernels run in the renderer's context, in order with its work on that queue:
 *
 *     #include <csi/csi_opencl.h>
 *     csi_device *dev;
 *     csi_device_new_opencl(my_context, my_device, my_queue, &dev);
 *     ... csi_reconstruct(dev, ...) as with any device ...
 *     csi_device_release(dev);   // releases csi's references; the caller's stay valid
 *
 * Everything else is in csi/csi.h. */
#ifndef CSI_CSI_OPENCL_H
#define CSI_CSI_OPENCL_H

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include "csi/csi.h"

#ifdef __cplusplus
extern "C" {
#endif

/* A device on the caller's context, device and queue. The queue must belong to that context
 * and device and execute in order (csi enqueues steps that rely on the previous ones). csi
 * retains the context and the queue until csi_device_release, builds its kernels in the
 * context; its work on the queue is complete when a call returns. */
CSI_API csi_status csi_device_new_opencl(cl_context context, cl_device_id device,
                                         cl_command_queue queue, csi_device **out);

/* The OpenCL objects a device runs on (its own, or the caller's), e.g. to share buffers. */
CSI_API cl_context csi_device_opencl_context(const csi_device *dev);
CSI_API cl_device_id csi_device_opencl_device(const csi_device *dev);
CSI_API cl_command_queue csi_device_opencl_queue(const csi_device *dev);

#ifdef __cplusplus
}
#endif
#endif
