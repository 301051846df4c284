/* libFuzzer target: the tile partial reader (docs/partial-format.md) through csi.h, the way
 * csi-merge reads a file: csi_partial_read_info, csi_partial_read, and csi_partials_merge of the
 * file alone (which blends it when its layout has one tile, and otherwise refuses the missing
 * tiles; it also refuses a blend that is not finite). The bytes are written to a scratch file, once as they are and once with their last 8
 * bytes replaced by the checksum of the rest: without that, almost every mutation would stop at
 * the checksum and the fields after it would never be parsed.
 * Properties beyond the sanitizers': read_info and read fail together, with one line naming the
 * file, and return nothing, or succeed together with the same description, and the image and
 * frames read are the file's pixels, bit for bit; the merge succeeds only on a partial they
 * accept whose layout has one tile, and fails with one line. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "csi/csi.h"

static char path[64];

/* The scratch file is unlinked as soon as it is made and named through its descriptor, so that
 * nothing is left behind, not even by a crash. */
int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    /* memory rather than a disk: ext4 writes a file that is truncated and rewritten back on
     * close, which took a sixth of the time per input in /tmp */
    const char *dir = getenv("TMPDIR");
    if (!dir || !*dir)
        dir = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    char name[64];
    snprintf(name, sizeof name, "%.40s/fuzz_partial.XXXXXX", dir);
    const int fd = mkstemp(name);
    if (fd < 0 || unlink(name))
        abort();
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    return 0;
}

/* A failure: one line that names the file, nothing returned. */
static void check_refusal(const csi_result *r)
{
    const char *m = csi_last_error();
    if (r || !m[0] || strchr(m, '\n') || !strstr(m, path))
        abort();
}

static bool same_info(const csi_partial_info *a, const csi_partial_info *b)
{
    return !strcmp(a->software, b->software) && !strcmp(a->method, b->method) && !strcmp(a->input, b->input) &&
           a->input_id == b->input_id && a->tile_index == b->tile_index && a->tile_count == b->tile_count &&
           !memcmp(&a->grid, &b->grid, sizeof a->grid) && a->channels == b->channels &&
           a->frames == b->frames && a->samples == b->samples;
}

/* The image and frames of r are the pixel block before the tile's sums, which end 8 bytes before
 * the end of data (docs/partial-format.md): no sums, the residual sums, the pixel sums or both. */
static bool pixels_at(const csi_result *r, const csi_image *img, uint32_t nf, const uint8_t *px, size_t plane)
{
    if (memcmp(img->data, px, plane))
        return false;
    for (uint32_t t = 0; t < nf; t++) {
        csi_image f;
        if (csi_result_frame(r, t, &f) != CSI_OK || f.w != img->w || f.h != img->h || f.channels != img->channels ||
            memcmp(f.data, px + plane * (1 + (size_t)t), plane))
            return false;
    }
    return true;
}

static void check_pixels(const csi_result *r, const uint8_t *data, size_t size)
{
    csi_image img;
    if (csi_result_image(r, &img) != CSI_OK)
        abort();
    const uint32_t nf = csi_result_frame_count(r);
    const size_t pixels = (size_t)img.w * img.h, plane = pixels * img.channels * sizeof(float);
    const size_t resid = pixels * img.channels * 40, sums = pixels * (1 + (size_t)img.channels) * 8;
    const size_t tails[4] = {0, resid, sums, resid + sums};
    bool found = false;
    for (int k = 0; k < 4 && !found && plane; k++)
        if (plane * (1 + (size_t)nf) + tails[k] <= size - 8)
            found = pixels_at(r, &img, nf, data + size - 8 - tails[k] - plane * (1 + (size_t)nf), plane);
    if (!found)
        abort();
}

static void one(const uint8_t *data, size_t size)
{
    FILE *fp = fopen(path, "wb");
    if (!fp || fwrite(data, 1, size, fp) != size || fclose(fp))
        abort();
    csi_partial_info info, info2;
    const csi_status si = csi_partial_read_info(path, &info);
    if (si != CSI_OK)
        check_refusal(NULL);
    csi_result *r = NULL;
    const csi_status sr = csi_partial_read(path, &r, &info2);
    if ((sr == CSI_OK) != (si == CSI_OK))
        abort();
    if (sr == CSI_OK) {
        if (!same_info(&info, &info2) || info.tile_index >= info.tile_count || info.channels < 1 ||
            info.channels > 4)
            abort();
        check_pixels(r, data, size);
        csi_result_free(r);
    } else {
        check_refusal(r);
    }
    const char *paths[1] = {path};
    csi_result *m = NULL;
    const csi_status sm = csi_partials_merge(paths, 1, false, NULL, NULL, &m, NULL);
    if (sm == CSI_OK) {
        if (si != CSI_OK || info.tile_count != 1)
            abort();
        csi_result_free(m);
    } else if (m || !csi_last_error()[0] || strchr(csi_last_error(), '\n')) {
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    one(data, size);
    if (size >= 16) {
        uint8_t *fixed = malloc(size);
        if (!fixed)
            abort();
        memcpy(fixed, data, size);
        const uint64_t h = csi_hash64(0, fixed, size - 8);
        for (int i = 0; i < 8; i++)
            fixed[size - 8 + i] = (uint8_t)(h >> (8 * i));
        if (memcmp(fixed, data, size))
            one(fixed, size);
        free(fixed);
    }
    return 0;
}
