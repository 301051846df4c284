/* libFuzzer target: the OBJ parser (tr_obj_parse, what a scene's `mesh { file ... }` runs on the
 * file's bytes) on arbitrary bytes. A mesh it accepts has triangles whose indices lie inside its
 * vertices, and uvs for every vertex when it has any. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "tracer_internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    tr_object o;
    memset(&o, 0, sizeof o);
    csi_status st = tr_obj_parse((const char *)data, size, "fuzz.obj", &o);
    if (st == CSI_OK) {
        if (o.nt == 0 || !o.pos || !o.tri)
            abort();
        for (size_t i = 0; i < 3 * o.nt; i++)
            if (o.tri[i] >= o.nv)
                abort();
    } else if (strchr(csi_last_error(), '\n')) {
        abort();
    }
    free(o.pos);
    free(o.uv);
    free(o.tri);
    return 0;
}
