/* Embedding csi: reconstruct a sample dump into an EXR through the installed SDK.
 * usage: reconstruct_dump DUMP.csid OUT.exr [STATS.json] */
#include <stdio.h>

#include <csi/csi.h>

int main(int argc, char **argv)
{
    if (argc < 3)
        return fprintf(stderr, "usage: %s DUMP.csid OUT.exr [STATS.json]\n", argv[0]), 2;
    csi_device *dev = NULL;
    csi_dump d = {0};
    csi_result *r = NULL;
    csi_image img;
    csi_json *j = NULL;
    csi_status s = csi_device_new(NULL, &dev);
    if (s == CSI_OK)
        s = csi_dump_read(argv[1], NULL, &d, NULL);
    csi_samples samples = {d.grid, d.channels, d.count, d.pos, d.values, d.flags, NULL};
    if (s == CSI_OK)
        s = csi_reconstruct(dev, &samples, NULL, NULL, NULL, &r);
    if (s == CSI_OK && (s = csi_result_image(r, &img)) == CSI_OK)
        s = csi_exr_write(argv[2], &img, NULL, 0);
    if (s == CSI_OK && argc > 3 && (s = csi_json_new(&j)) == CSI_OK) {
        csi_result_stats(r, j); /* the image's hash, the options as used, each channel's solve */
        s = csi_json_write(j, argv[3]);
    }
    if (s != CSI_OK)
        fprintf(stderr, "%s: %s\n", argv[0], csi_last_error());
    csi_json_free(j);
    csi_result_free(r);
    csi_dump_free(&d);
    csi_device_release(dev);
    return s == CSI_OK ? 0 : 1;
}
