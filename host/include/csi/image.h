/* Images: float32 EXR (OpenEXR's C API, OpenEXRCore 3.1) and 8-bit sRGB PNG (libpng).
 *
 * In memory an image is float32, channels planar: data[(c * h + y) * w + x], linear light.
 * Channel meaning by count: 1 = Y (luminance), 2 = Y A, 3 = R G B, 4 = R G B A.
 * Writers write a temporary file and rename it (csi/outfile.h): a failed write leaves nothing. */
#ifndef CSI_IMAGE_H
#define CSI_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_image {
    uint32_t w, h, channels; /* channels 1..4 */
    float *data;             /* w * h * channels floats, planar */
} csi_image;

/* Largest side the readers accept (guards allocation on a corrupt header). */
#define CSI_IMAGE_MAX_SIDE 65536u

csi_status csi_image_alloc(csi_image *img, uint32_t w, uint32_t h, uint32_t channels); /* zeroed */
void csi_image_free(csi_image *img);

/* Header attributes for EXR files, given by the caller (solver, parameters, times ...). */
typedef enum csi_attr_type { CSI_ATTR_STRING, CSI_ATTR_FLOAT, CSI_ATTR_DOUBLE, CSI_ATTR_INT } csi_attr_type;
typedef struct csi_attr {
    const char *name;
    csi_attr_type type;
    const char *s; /* CSI_ATTR_STRING */
    double f;      /* CSI_ATTR_FLOAT (stored as float32) and CSI_ATTR_DOUBLE */
    int64_t i;     /* CSI_ATTR_INT (must fit int32: EXR's int attribute) */
} csi_attr;
#define CSI_ATTR_S(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_STRING, .s = (v)})
#define CSI_ATTR_F(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_FLOAT, .f = (v)})
#define CSI_ATTR_D(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_DOUBLE, .f = (v)})
#define CSI_ATTR_I(n, v) ((csi_attr){.name = (n), .type = CSI_ATTR_INT, .i = (v)})

/* Writes a scanline EXR, float32 channels (Y / Y A / R G B / R G B A), ZIP compression
 * (lossless), with the attributes in the header. An attribute named like a required EXR
 * attribute (channels, compression, dataWindow, ...) or given twice is refused (CSI_ERR_ARG).
 * CSI_ERR_IO if the path cannot be written. */
csi_status csi_exr_write(const char *path, const csi_image *img, const csi_attr *attrs, size_t nattrs);

/* Reads a scanline EXR's first part into float32 (half and float channels; uint refused):
 * R G B [A] if R, G and B exist, else Y [A], else a single channel of any name. Tiled, deep and
 * subsampled files are refused with CSI_ERR_FORMAT. */
csi_status csi_exr_read(const char *path, csi_image *out);

/* Writes an 8-bit PNG (gray, gray+alpha, RGB, RGBA by channel count) with the sRGB transfer
 * function applied to colour channels (alpha stays linear, as PNG defines), values clamped to
 * [0, 1] (NaN -> 0), rounded to nearest; an sRGB chunk marks the encoding. */
csi_status csi_png_write(const char *path, const csi_image *img);

/* Reads an 8- or 16-bit PNG (palette and low-bit gray expanded, tRNS becomes alpha) and
 * decodes the sRGB transfer function to linear (alpha kept linear). */
csi_status csi_png_read(const char *path, csi_image *out);

/* Reads a PNG or EXR, chosen by the file's magic bytes. */
csi_status csi_image_read(const char *path, csi_image *out);

/* The sRGB transfer function (IEC 61966-2-1): linear [0,1] -> encoded [0,1] and back. */
double csi_srgb_encode(double linear);
double csi_srgb_decode(double encoded);

#ifdef __cplusplus
}
#endif
#endif
