/* libFuzzer target: the scene parser (csi_scene_parse) on arbitrary text, then the plan (what is
 * simulated: motion, T, effects) and its JSON for every scene it accepts. File names in the scene
 * resolve against tests/tracer/data (CSI_FUZZ_FILES: the tracer tests' small OBJ and PNG), so
 * meshes and textures load too.
 * Errors must be one line naming the scene. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "csi_tracer.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size > (1u << 20))
        return 0;
    char *text = malloc(size + 1);
    if (!text)
        return 0;
    memcpy(text, data, size);
    text[size] = '\0';
    csi_scene *sc = NULL;
    csi_status st = csi_scene_parse(text, "fuzz.scene", CSI_FUZZ_FILES, &sc);
    if (st == CSI_OK) {
        csi_plan pl;
        if (csi_plan_make(sc, NULL, &pl) == CSI_OK) {
            char *js = NULL;
            if (csi_plan_json_string(sc, &pl, &js) == CSI_OK)
                free(js);
            csi_plan_free(&pl);
        }
        csi_scene_free(sc);
    } else {
        if (sc || strchr(csi_last_error(), '\n'))
            abort();
    }
    free(text);
    return 0;
}
