/* libFuzzer target: the sample dump reader (csi_dump_read_mem, the code csi_dump_read runs on a
 * file) on arbitrary bytes, with and without drop_invalid and a small cell limit. Properties
 * checked beyond the sanitizers': a dump it accepts is sorted, unique, inside its grid and finite;
 * a refusal leaves *out zeroed and a one-line message. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "csi/dump.h"

static void check(const csi_dump *d)
{
    for (size_t i = 0; i < d->count; i++) {
        const csi_sample_pos p = d->pos[i];
        if (p.x >= d->grid.w || p.y >= d->grid.h || p.t >= d->grid.t)
            abort();
        if (i && csi_grid_index(&d->grid, d->pos[i - 1]) >= csi_grid_index(&d->grid, p))
            abort();
        for (uint32_t c = 0; c < d->channels; c++)
            if (!isfinite(d->values[i * d->channels + c]))
                abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    for (int mode = 0; mode < 2; mode++) {
        csi_dump_read_opts o = {.drop_invalid = mode == 1, .max_cells = mode == 1 ? 1u << 20 : 0};
        csi_dump d;
        csi_dump_report rep;
        csi_status st = csi_dump_read_mem(data, size, "fuzz.csid", &o, &d, &rep);
        if (st == CSI_OK) {
            check(&d);
            if (d.count > rep.records)
                abort();
            csi_dump_free(&d);
        } else {
            if (d.pos || d.values || d.count)
                abort();
            if (!csi_last_error()[0] || strchr(csi_last_error(), '\n'))
                abort();
        }
    }
    return 0;
}
