/* Regression: an image whose ZIP chunk deflates to exactly its packed size must survive an EXR
 * round trip bit for bit. OpenEXRCore <= 3.4.7 stored such a chunk compressed while readers
 * took it for raw pixels (openexr issue #2306); csi_exr_write guards against it (host/io/image.c).
 * The fixture is a 64x64 reconstruction (tests/data/quality/exr_zip_equal.npy, made by
 * csi-reconstruct on the sweep's triangle at 16 spp) whose rows 16..31 deflate to exactly 4096
 * bytes with Debian 12's zlib; before the guard they read back as NaN and +-3e38. The reference
 * is the array itself: a lossless format must return the same bits. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "csi/image.h"
#include "testlib.h"

int main(void)
{
    test_npy a;
    if (!test_npy_load("quality/exr_zip_equal.npy", &a)) {
        CHECK(false, "cannot load quality/exr_zip_equal.npy");
        return test_done();
    }
    float *src = test_npy_f32(&a);
    CHECK(a.ndim == 2 && a.shape[0] == 64 && a.shape[1] == 64, "fixture is 64x64");
    csi_image img = {0};
    REQUIRE_OK(csi_image_alloc(&img, 64, 64, 1));
    memcpy(img.data, src, 64 * 64 * sizeof(float));
    char path[] = "/tmp/csi_test_exr_zip_XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0, "mkstemp");
    close(fd);
    CHECK_OK(csi_exr_write(path, &img, NULL, 0));
    csi_image back = {0};
    CHECK_OK(csi_exr_read(path, &back));
    size_t bad = 0;
    if (back.data && back.w == 64 && back.h == 64 && back.channels == 1)
        for (size_t i = 0; i < 64 * 64; i++)
            bad += memcmp(&back.data[i], &img.data[i], sizeof(float)) != 0;
    else
        bad = 64 * 64;
    CHECK(bad == 0, "%zu of 4096 values changed in the EXR round trip", bad);
    unlink(path);
    csi_image_free(&img);
    csi_image_free(&back);
    free(src);
    test_npy_free(&a);
    return test_done();
}
