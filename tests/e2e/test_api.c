/* The public API (csi/csi.h, csi/csi_opencl.h) against the library's own entry point: the same
 * samples and options give the same bits through both; the autos come back resolved to the
 * closed-form rules; bad names and devices fail with the library's message, kept per device
 * until read; a progress callback that returns false cancels cleanly (run under ASan/LSan: no
 * leak); a device on the caller's own OpenCL context and queue gives the same bits and leaves
 * the caller's objects alive. */
#include <math.h>
#include <string.h>
#include <time.h>

#include "csi/csi.h"
#include "csi/csi_opencl.h"
#include "csi/reconstruct.h"
#include "testlib.h"

typedef struct {
    int calls, solve_steps, cancel_at;
    bool saw_setup, saw_integrate;
} prog_log;

static bool on_progress(void *user, const csi_progress *p)
{
    prog_log *l = user;
    l->calls++;
    l->saw_setup |= strcmp(p->phase, "setup") == 0;
    l->saw_integrate |= strncmp(p->phase, "integrate", 9) == 0;
    if (strncmp(p->phase, "solve", 5) == 0 && p->iteration > 0)
        l->solve_steps++;
    return !(l->cancel_at > 0 && l->solve_steps >= l->cancel_at);
}

/* A smooth two-channel signal on the grid's cell centres. */
static void make_samples(const csi_grid *g, csi_sample_pos **pos, float **val, size_t *n)
{
    csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = 3, .seed = 5};
    CHECK_OK(csi_positions(g, &po, pos, n, NULL));
    *val = malloc(*n * 2 * sizeof **val);
    for (size_t i = 0; i < *n; i++) {
        const double u = ((*pos)[i].x + 0.5) / g->w, v = ((*pos)[i].y + 0.5) / g->h;
        const double s = ((*pos)[i].t + 0.5) / g->t;
        (*val)[2 * i] = (float)(0.5 + 0.4 * sin(6.0 * u + 2.0 * s) * cos(4.0 * v));
        (*val)[2 * i + 1] = (float)(u * v > 0.25 ? 0.9 : 0.1);
    }
}

int main(void)
{
    char ver[32];
    snprintf(ver, sizeof ver, "%d.%d.%d", CSI_VERSION_MAJOR, CSI_VERSION_MINOR, CSI_VERSION_PATCH);
    CHECK(strcmp(csi_version(), ver) == 0, "version %s, header %s", csi_version(), ver);

    /* A device that does not exist: the status, and the thread's message read once. */
    csi_device *bad = NULL;
    CHECK(csi_device_new("no-such-device-anywhere", &bad) == CSI_ERR_DEVICE && !bad, "bad device");
    const char *msg;
    CHECK(csi_device_error(NULL, &msg) == CSI_ERR_DEVICE && strstr(msg, "no-such-device-anywhere"),
          "thread error: %s", msg);
    CHECK(csi_device_error(NULL, &msg) == CSI_OK && msg[0] == '\0', "read once");

    csi_device *dev = NULL;
    REQUIRE_OK(csi_device_new(NULL, &dev));
    const csi_grid g = {64, 64, 1, 16, 16};
    csi_sample_pos *pos = NULL;
    float *val = NULL;
    size_t n = 0;
    make_samples(&g, &pos, &val, &n);

    /* Public API with every default against csi_recon: the same bits. */
    csi_samples s = {g, 2, n, pos, val, 0, NULL};
    csi_result *r = NULL;
    prog_log log = {0};
    REQUIRE_OK(csi_reconstruct(dev, &s, NULL, on_progress, &log, &r));
    CHECK(log.saw_setup && log.saw_integrate && log.solve_steps > 0, "progress: %d calls", log.calls);
    csi_image img;
    CHECK_OK(csi_result_image(r, &img));
    CHECK(img.w == 16 && img.h == 16 && img.channels == 2, "image %ux%ux%u", img.w, img.h, img.channels);
    csi_recon_options o;
    csi_recon_defaults(&o);
    csi_recon_result ref;
    REQUIRE_OK(csi_recon(test_ctx(), &g, 2, pos, val, n, &o, &ref));
    CHECK(memcmp(img.data, ref.image, 16 * 16 * 2 * sizeof(float)) == 0, "public API = csi_recon bits");
    csi_recon_result_free(&ref);

    /* The autos, resolved: SpaRSA, tau from the samples per pixel (resolve.c's rule). */
    const csi_options *used = csi_result_options(r);
    char text[64];
    CHECK_OK(csi_options_get(used, "solver", text, sizeof text));
    CHECK(strcmp(text, "sparsa") == 0, "solver %s", text);
    double tau;
    CHECK_OK(csi_options_get_number(used, "tau", &tau));
    const double spp = (double)n / 256.0;
    CHECK(tau == fmin(3e-3, fmax(1e-5, 3e-3 / spp)), "tau %g", tau);
    csi_result_info info;
    csi_result_info_get(r, &info);
    CHECK(info.n == n && info.k == 64 * 64 && !strcmp(info.solver, "sparsa"), "info");
    csi_channel_report rep;
    CHECK_OK(csi_result_report(r, 1, &rep));
    CHECK(rep.iterations > 0 && rep.reason && rep.message, "report");
    CHECK(csi_result_report(r, 2, &rep) == CSI_ERR_ARG, "channel past the end");
    const csi_attr *attrs;
    size_t na = csi_result_attributes(r, &attrs);
    bool lam = false;
    for (size_t i = 0; i < na; i++)
        lam |= !strcmp(attrs[i].name, "csi:option:lambda") && attrs[i].type == CSI_ATTR_DOUBLE &&
               (float)attrs[i].f == 0.3f;
    CHECK(lam, "the options are attributes (%zu)", na);
    csi_json *j = NULL;
    REQUIRE_OK(csi_json_new(&j));
    csi_result_stats(r, j);
    const char *js;
    CHECK_OK(csi_json_text(j, &js));
    CHECK(strstr(js, "\"options\": {") && strstr(js, "\"image_fnv1a64\""), "stats");
    csi_json_free(j);

    /* Options by name: a bad name or value fails with the name and changes nothing. */
    csi_options *opts = NULL;
    REQUIRE_OK(csi_options_new(&opts));
    CHECK(csi_options_set(opts, "lambda", "-1") == CSI_ERR_ARG && !strncmp(csi_last_error(), "lambda", 6),
          "%s", csi_last_error());
    CHECK(csi_options_set(opts, "no-such", "1") == CSI_ERR_ARG, "unknown option");
    CHECK_OK(csi_options_set_number(opts, "tau", 2e-3));
    CHECK_OK(csi_options_set(opts, "solver", "romp"));
    csi_result *r2 = NULL;
    CHECK_OK(csi_reconstruct(dev, &s, opts, NULL, NULL, &r2));
    CHECK_OK(csi_options_get(csi_result_options(r2), "solver", text, sizeof text));
    CHECK(strcmp(text, "romp") == 0, "given solver kept: %s", text);
    csi_result_free(r2);

    /* Cancel after two solver steps: a clean error, no result, the device's error read once. */
    prog_log stop = {.cancel_at = 2};
    csi_result *r3 = (csi_result *)&stop;
    CHECK(csi_reconstruct(dev, &s, NULL, on_progress, &stop, &r3) == CSI_ERR_CANCELLED && r3 == NULL,
          "cancel");
    CHECK(csi_device_error(dev, &msg) == CSI_ERR_CANCELLED && strstr(msg, "cancel"), "device error %s", msg);
    CHECK(csi_device_error(dev, &msg) == CSI_OK, "read once");

    /* The caller's own OpenCL context and queue. */
    cl_context cctx = csi_device_opencl_context(dev);
    cl_device_id cdev = csi_device_opencl_device(dev);
    cl_int err;
    cl_command_queue q = clCreateCommandQueue(cctx, cdev, 0, &err);
    REQUIRE_OK(err == CL_SUCCESS ? CSI_OK : CSI_ERR_CL);
    csi_device *mine = NULL;
    REQUIRE_OK(csi_device_new_opencl(cctx, cdev, q, &mine));
    CHECK(csi_device_opencl_queue(mine) == q, "runs on the caller's queue");
    csi_result *r4 = NULL;
    CHECK_OK(csi_reconstruct(mine, &s, NULL, NULL, NULL, &r4));
    csi_image img4;
    if (r4 && csi_result_image(r4, &img4) == CSI_OK)
        CHECK(memcmp(img4.data, img.data, 16 * 16 * 2 * sizeof(float)) == 0, "same bits on the caller's queue");
    csi_result_free(r4);
    csi_device_release(mine);
    /* csi must give back exactly the references it took. PoCL's finished events keep a reference
       to their queue until its worker threads free them, after clFinish has returned, so the
       count is polled: a reference csi kept would hold it above 1 forever (10 s here). */
    CHECK(clFinish(q) == CL_SUCCESS, "the caller's queue still works");
    cl_uint refs = 0;
    for (int tries = 0; tries < 1000; tries++) {
        if (clGetCommandQueueInfo(q, CL_QUEUE_REFERENCE_COUNT, sizeof refs, &refs, NULL) != CL_SUCCESS ||
            refs <= 1)
            break;
        nanosleep(&(struct timespec){.tv_nsec = 10 * 1000 * 1000}, NULL);
    }
    CHECK(refs == 1, "the caller's queue is alive with its one reference (%u)", refs);
    clReleaseCommandQueue(q);
    csi_result_free(r);
    csi_free(pos);
    free(val);

    /* A volume with every frame. */
    const csi_grid gv = {16, 16, 4, 16, 16};
    make_samples(&gv, &pos, &val, &n);
    csi_samples sv = {gv, 2, n, pos, val, 0, NULL};
    CHECK_OK(csi_options_set(opts, "solver", "auto"));
    CHECK_OK(csi_options_set(opts, "tau", "auto"));
    CHECK_OK(csi_options_set(opts, "frames", "on"));
    csi_result *rv = NULL;
    CHECK_OK(csi_reconstruct(dev, &sv, opts, NULL, NULL, &rv));
    csi_image fr;
    CHECK(csi_result_frame_count(rv) == 4 && csi_result_frame(rv, 3, &fr) == CSI_OK && fr.w == 16 &&
              fr.channels == 2 && csi_result_frame(rv, 4, &fr) == CSI_ERR_ARG,
          "frames: %u", csi_result_frame_count(rv));
    CHECK_OK(csi_options_get_number(csi_result_options(rv), "tau", &tau));
    CHECK(tau == fmin(3e-2, fmax(1e-4, 0.25 / sqrt((double)n))), "volume tau %g", tau);
    csi_result_free(rv);
    csi_options_free(opts);
    csi_free(pos);
    free(val);
    csi_device_release(dev);
    return test_done();
}
