/* Embedding csi in a toy render loop: csi chooses the fine grid and the sample positions, the
 * "renderer" (an analytic disc moving across a gradient) shades each position's cell centre,
 * and csi reconstructs the antialiased, motion-blurred image, reporting progress as it goes.
 * usage: toy_render OUT.exr [SPP] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <csi/csi.h>

/* The renderer: radiance at image point (u, v) at shutter time s, all in [0, 1]. */
static float shade(double u, double v, double s)
{
    const double cx = 0.3 + 0.4 * s, cy = 0.5, r = 0.2;
    return (u - cx) * (u - cx) + (v - cy) * (v - cy) < r * r ? 1.0f : (float)(0.2 * u);
}

static bool on_progress(void *user, const csi_progress *p)
{
    (void)user;
    if (p->residual >= 0 && p->iteration % 20 == 0)
        fprintf(stderr, "  %s: step %d, residual %.3g\n", p->phase, p->iteration, p->residual);
    return true; /* false would cancel: csi_reconstruct returns CSI_ERR_CANCELLED */
}

int main(int argc, char **argv)
{
    if (argc < 2)
        return fprintf(stderr, "usage: %s OUT.exr [SPP]\n", argv[0]), 2;
    const uint32_t W = 64, H = 48, T = 8, spp = argc > 2 ? (uint32_t)atoi(argv[2]) : 2;
    const uint32_t F = csi_default_grid_factor(W, H, T, spp);
    const csi_grid g = {W * F, H * F, T, W, H};
    csi_pos_opts po = {.method = CSI_POS_POISSON, .spp = spp, .seed = 1};
    csi_sample_pos *pos = NULL;
    size_t n = 0;
    csi_device *dev = NULL;
    csi_options *opt = NULL;
    csi_result *r = NULL;
    float *rgb = NULL;
    csi_status s = csi_positions(&g, &po, &pos, &n, NULL);
    if (s == CSI_OK && !(rgb = malloc(n * sizeof *rgb)))
        s = CSI_ERR_NOMEM;
    for (size_t i = 0; s == CSI_OK && i < n; i++) /* the render loop: one sample per position */
        rgb[i] = shade((pos[i].x + 0.5) / g.w, (pos[i].y + 0.5) / g.h, (pos[i].t + 0.5) / g.t);
    if (s == CSI_OK)
        s = csi_device_new(NULL, &dev);
    if (s == CSI_OK)
        s = csi_options_new(&opt);
    if (s == CSI_OK)
        s = csi_options_set(opt, "frames", "on"); /* every frame of the shutter too */
    const csi_samples samples = {g, 1, n, pos, rgb, CSI_SAMPLES_EXACT, NULL}; /* shade() is noise-free */
    if (s == CSI_OK)
        s = csi_reconstruct(dev, &samples, opt, on_progress, NULL, &r);
    csi_image img;
    if (s == CSI_OK && (s = csi_result_image(r, &img)) == CSI_OK) {
        const csi_attr *attrs;
        const size_t na = csi_result_attributes(r, &attrs); /* how it was made, in the header */
        s = csi_exr_write(argv[1], &img, attrs, na);
    }
    char tau[32] = "";
    if (s == CSI_OK)
        s = csi_options_get(csi_result_options(r), "tau", tau, sizeof tau);
    if (s == CSI_OK)
        printf("%ux%u from %zu samples on a %ux%ux%u grid, %u frames, tau %s\n", W, H, n, g.w, g.h,
               g.t, csi_result_frame_count(r), tau);
    else
        fprintf(stderr, "%s: %s\n", argv[0], csi_last_error());
    csi_result_free(r);
    csi_options_free(opt);
    csi_device_release(dev);
    csi_free(pos);
    free(rgb);
    return s == CSI_OK ? 0 : 1;
}
