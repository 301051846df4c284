/* Images: float32 EXR (OpenEXR's C API, OpenEXRCore 3.1) and 8-bit sRGB PNG (libpng).
 *
 * In memory an image is float32, channels planar: data[(c * h + y) * w + x], linear light.
 * Channel meaning by count: 1 = Y (luminance), 2 = Y A, 3 = R G B, 4 = R G B A.
 * Writers write a temporary file and rename it (csi/outfile.h): a failed write leaves nothing. */
#ifndef CSI_IMAGE_H
#define CSI_IMAGE_H

#include <stddef.h>
#include <stdint.h>

#include "csi/status.h" /* and csi/csi.h: csi_image, csi_attr, the writers, csi_image_read */

#ifdef __cplusplus
extern "C" {
#endif

/* Largest side the readers accept (guards allocation on a corrupt header). */
#define CSI_IMAGE_MAX_SIDE 65536u

/* csi_exr_write (csi/csi.h) writes a scanline EXR, float32 channels (Y / Y A / R G B / R G B A),
 * ZIP compression (lossless), with the attributes in the header. An attribute named like a
 * required EXR attribute (channels, compression, dataWindow, ...) or given twice is refused
 * (CSI_ERR_ARG). CSI_ERR_IO if the path cannot be written. */

/* Reads a scanline EXR's first part into float32 (half and float channels; uint refused):
 * R G B [A] if R, G and B exist, else Y [A], else a single channel of any name. Tiled, deep and
 * subsampled files are refused with CSI_ERR_FORMAT. */
csi_status csi_exr_read(const char *path, csi_image *out);

/* csi_png_write (csi/csi.h) writes an 8-bit PNG (gray, gray+alpha, RGB, RGBA by channel count)
 * with the sRGB transfer function applied to colour channels (alpha stays linear, as PNG defines),
 * values clamped to [0, 1] (NaN -> 0), rounded to nearest; an sRGB chunk marks the encoding. */

/* Reads an 8- or 16-bit PNG (palette and low-bit gray expanded, tRNS becomes alpha) and
 * decodes the sRGB transfer function to linear (alpha kept linear). */
csi_status csi_png_read(const char *path, csi_image *out);

/* The sRGB transfer function (IEC 61966-2-1): linear [0,1] -> encoded [0,1] and back. */
double csi_srgb_encode(double linear);
double csi_srgb_decode(double encoded);

#ifdef __cplusplus
}
#endif
#endif
