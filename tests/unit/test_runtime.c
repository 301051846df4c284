/* OpenCL runtime: device choice, kernel registry and cache, error naming, buffer limits. */
#include <stdlib.h>
#include <string.h>

#include "csi/runtime.h"
#include "testlib.h"

int main(void)
{
    csi_ctx *ctx = test_ctx();
    CHECK(strlen(csi_ctx_device_name(ctx)) > 0, "device has a name");
    CHECK(csi_ctx_max_alloc(ctx) > 0, "max alloc known");

    /* A kernel launch with n not a multiple of the local size computes every element once. */
    const cl_uint n = 1000;
    cl_mem out = test_alloc(n * sizeof(float));
    cl_kernel k;
    REQUIRE_OK(csi_kernel(ctx, "runtime", "csi_probe_affine", &k));
    cl_kernel k2;
    REQUIRE_OK(csi_kernel(ctx, "runtime", "csi_probe_affine", &k2));
    CHECK(k == k2, "kernels are cached per ctx");
    float a = 0.5f, b = -3.0f;
    REQUIRE_OK(CSI_ARGS(k, CSI_MEM(out), CSI_ARG(n), CSI_ARG(a), CSI_ARG(b)));
    REQUIRE_OK(csi_run1d(ctx, k, n));
    float *h = malloc(n * sizeof *h);
    test_download(out, h, n * sizeof *h);
    int bad = 0;
    for (cl_uint i = 0; i < n; i++)
        bad += h[i] != 0.5f * (float)i - 3.0f; /* exact: small integers times 0.5 */
    CHECK(bad == 0, "%d wrong values from the probe kernel", bad);
    free(h);
    csi_buffer_release(&out);
    CHECK(out == NULL, "release clears the handle");

    /* Errors are named, not numbered. */
    CHECK(strcmp(csi_cl_error_name(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES") == 0, "name");
    CHECK(strcmp(csi_cl_error_name(-9999), "CL_ERROR(-9999)") == 0, "unknown code");
    csi_status st = CSI_CL(CL_INVALID_MEM_OBJECT);
    CHECK(st == CSI_ERR_CL && strstr(csi_last_error(), "CL_INVALID_MEM_OBJECT"), "%s", csi_last_error());

    /* Unknown programs and kernels: a clear error, no crash. */
    st = csi_kernel(ctx, "no_such_program", "x", &k);
    CHECK(st == CSI_ERR_BUILD && strstr(csi_last_error(), "no_such_program"), "%s", csi_last_error());
    st = csi_kernel(ctx, "runtime", "no_such_kernel", &k);
    CHECK(st == CSI_ERR_BUILD && strstr(csi_last_error(), "no_such_kernel"), "%s", csi_last_error());

    /* A buffer over the single-allocation limit is refused before allocation, naming the limit. */
    cl_mem big;
    st = csi_buffer(ctx, csi_ctx_max_alloc(ctx) + 1, CL_MEM_READ_WRITE, "a test volume", &big);
    CHECK(st == CSI_ERR_DEVICE && big == NULL && strstr(csi_last_error(), "a test volume") &&
              strstr(csi_last_error(), "limit"), "%s", csi_last_error());

    /* A device spec that matches nothing is a clear error. */
    csi_ctx *none = NULL;
    st = csi_ctx_create(&none, "no-such-device-xyz");
    CHECK(st == CSI_ERR_DEVICE && none == NULL && strstr(csi_last_error(), "no-such-device-xyz"),
          "%s", csi_last_error());

    char list[4096];
    CHECK_OK(csi_list_devices(list, sizeof list));
    CHECK(strstr(list, "Portable Computing Language") != NULL, "PoCL listed: %s", list);
    return test_done();
}
