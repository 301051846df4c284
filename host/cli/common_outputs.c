/* The outputs of a reconstruction run (outputs.h). */
#include "outputs.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

static void frame_name(char *buf, size_t len, uint32_t t, const char *ext)
{
    snprintf(buf, len, "frame_%04u.%s", t, ext);
}

/* The image format a file name's extension names, among those a user may mean for an image:
 * "exr", "png", another image format's extension, or NULL (none, or one that names no image). */
static const char *image_kind(const char *path)
{
    static const char *const other[] = {"jpg", "jpeg", "hdr", "pfm", "tif", "tiff", "bmp", "ppm", "tga", "webp"};
    const char *slash = strrchr(path, '/'), *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash) || dot[1] == 0)
        return NULL;
    const char *ext = dot + 1;
    if (!strcasecmp(ext, "exr") || !strcasecmp(ext, "png"))
        return !strcasecmp(ext, "exr") ? "exr" : "png";
    for (size_t i = 0; i < sizeof other / sizeof *other; i++)
        if (!strcasecmp(ext, other[i]))
            return other[i];
    return NULL;
}

/* -o writes OpenEXR and --png a PNG whatever the name says, so a name that asks for another
 * format is refused before any work: "-o out.png" would otherwise leave EXR bytes under a PNG
 * name. A name without an image extension is taken as given (scripts' temporary names). */
static csi_status check_kind(const char *path, const char *want, const char *what, const char *hint)
{
    const char *kind = image_kind(path);
    if (kind && strcmp(kind, want))
        return cli_fail(CSI_ERR_ARG, "%s: %s is written as %s, not %s; %s", path, what,
                        !strcmp(want, "exr") ? "OpenEXR" : "an 8-bit PNG", kind, hint);
    return CSI_OK;
}

csi_status cli_outputs_stage(const cli_outputs *o, csi_outset *set, uint32_t nframes)
{
    if (o->exr)
        CSI_TRY(csi_outset_file(set, o->exr, "the image (-o)"));
    if (o->png)
        CSI_TRY(csi_outset_file(set, o->png, "the preview (--png)"));
    if (o->stats)
        CSI_TRY(csi_outset_file(set, o->stats, "the statistics (--stats)"));
    if (o->frames_dir && nframes) {
        CSI_TRY(csi_outset_dir(set, o->frames_dir, "the frames folder (--frames)"));
        for (uint32_t t = 0; t < nframes; t++) {
            char name[32];
            frame_name(name, sizeof name, t, "exr");
            CSI_TRY(csi_outset_dir_file(set, o->frames_dir, name, "a frame (--frames)"));
            frame_name(name, sizeof name, t, "png");
            CSI_TRY(csi_outset_dir_file(set, o->frames_dir, name, "a frame's preview (--frames)"));
        }
    }
    if (o->exr)
        CSI_TRY(check_kind(o->exr, "exr", "the image (-o)", "name it .exr (--png FILE.png writes an 8-bit preview)"));
    if (o->png)
        CSI_TRY(check_kind(o->png, "png", "the preview (--png)", "name it .png (-o FILE.exr writes the HDR image)"));
    return CSI_OK;
}

/* The writing's progress: image `index` of `count` (the image, then the frames), and within an
 * EXR its scanlines. */
typedef struct {
    cli_progress *bar;
    uint32_t index, count;
    const char *name;
} write_progress;

static bool on_write(void *user, uint64_t done, uint64_t total)
{
    const write_progress *w = user;
    const double within = total ? (double)done / (double)total : 0;
    cli_progress_update(w->bar, "write", (w->index + within) / w->count, w->name);
    return true;
}

static csi_status write_one(csi_outset *set, const char *exr, const char *png, const csi_image *img,
                            const csi_attr *attrs, size_t nattrs, write_progress *wp)
{
    const char *exr_tmp = NULL, *png_tmp = NULL;
    if (exr)
        CSI_TRY(csi_outset_tmp(set, exr, &exr_tmp));
    if (png)
        CSI_TRY(csi_outset_tmp(set, png, &png_tmp));
    if (exr_tmp) {
        wp->name = exr;
        CSI_TRY(cli_named(csi_exr_write_with_progress(exr_tmp, img, attrs, nattrs, wp->bar ? on_write : NULL, wp),
                          exr_tmp, exr));
    }
    if (png_tmp) {
        wp->name = png;
        if (wp->bar)
            on_write(wp, 0, 1);
        CSI_TRY(cli_named(csi_png_write(png_tmp, img), png_tmp, png));
    }
    wp->index++;
    return CSI_OK;
}

csi_status cli_write_images(const cli_outputs *o, csi_outset *set, const csi_result *r, const char *method,
                            cli_progress *bar)
{
    const csi_attr *given;
    const size_t nattrs = csi_result_attributes(r, &given);
    csi_attr *attrs = malloc((nattrs ? nattrs : 1) * sizeof *attrs);
    if (!attrs)
        return cli_fail(CSI_ERR_NOMEM, "out of host memory for %zu attributes", nattrs);
    memcpy(attrs, given, nattrs * sizeof *attrs);
    for (size_t i = 0; method && i < nattrs; i++)
        if (!strcmp(attrs[i].name, "csi:method"))
            attrs[i].s = method;
    csi_image img;
    const uint32_t nframes = o->frames_dir ? csi_result_frame_count(r) : 0;
    write_progress wp = {bar, 0, 1 + nframes, NULL};
    csi_status s = csi_result_image(r, &img);
    if (s == CSI_OK)
        s = write_one(set, o->exr, o->png, &img, attrs, nattrs, &wp);
    for (uint32_t t = 0; t < nframes && s == CSI_OK; t++) {
        char exr[PATH_MAX], png[PATH_MAX], name[32];
        frame_name(name, sizeof name, t, "exr");
        snprintf(exr, sizeof exr, "%s/%s", o->frames_dir, name);
        frame_name(name, sizeof name, t, "png");
        snprintf(png, sizeof png, "%s/%s", o->frames_dir, name);
        s = csi_result_frame(r, t, &img);
        if (s == CSI_OK)
            s = write_one(set, exr, png, &img, attrs, nattrs, &wp);
    }
    if (bar)
        cli_progress_end(bar);
    free(attrs);
    return s;
}

const char *cli_solver_or_estimator(const csi_result *r, char *buf, size_t len)
{
    const csi_options *o = csi_result_options(r);
    if (csi_options_get(o, "estimator", buf, len) != CSI_OK || !strcmp(buf, "cs"))
        csi_options_get(o, "solver", buf, len);
    return buf;
}

bool cli_warn_unconverged(const char *prog, const csi_result *r, bool quiet)
{
    bool all = true;
    csi_image img;
    const uint32_t channels = csi_result_image(r, &img) == CSI_OK ? img.channels : 0;
    for (uint32_t c = 0; c < channels; c++) {
        csi_channel_report rep;
        if (csi_result_report(r, c, &rep) == CSI_OK && !rep.converged && rep.outcome != CSI_OUTCOME_NOT_IDENTIFIABLE) {
            all = false;
            if (!quiet)
                cli_warn(prog, "channel %u: %s", c, rep.message);
        }
    }
    return all;
}
