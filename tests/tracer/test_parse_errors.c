/* Bad scenes give CSI_ERR_SCENE (or CSI_ERR_IO for a missing scene file) with file:line:column
 * and the expected token, never a crash: unknown keywords, missing numbers, NaN/Inf, missing
 * and malformed OBJ/PNG files, degenerate geometry, zero-size images, motion keys outside the
 * shutter, more than 129 keys, unknown materials, unterminated strings. Also: a good OBJ
 * loads (quad.obj with uvs). */
#include "tracer_test_util.h"

#include <sys/stat.h>
#include <unistd.h>

static void expect_error(const char *text, csi_status want, const char *substr, const char *why)
{
    csi_scene *sc = (csi_scene *)1;
    csi_clear_error();
    csi_status st = csi_scene_parse(text, "bad.scene", CSI_SOURCE_DIR "/tests/tracer/data", &sc);
    CHECK(st == want, "%s: status %s, want %s (%s)", why, csi_status_name(st),
          csi_status_name(want), csi_last_error());
    CHECK(sc == NULL, "%s: scene not NULL on failure", why);
    CHECK(strstr(csi_last_error(), substr) != NULL, "%s: message '%s' lacks '%s'", why,
          csi_last_error(), substr);
    if (st == CSI_OK)
        csi_scene_free(sc);
}

#define CAM "camera { position 0 0 -5 target 0 0 0 }\n"
#define MAT "material m { diffuse 1 1 1 }\n"

int main(void)
{
    expect_error(CAM "spere { center 0 0 0 radius 1 }\n", CSI_ERR_SCENE,
                 "bad.scene:2:1: expected a statement", "unknown keyword");
    expect_error(CAM MAT "sphere { center 0 0 radius 1 material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:21: expected a finite number after 'center', found 'radius'",
                 "missing number");
    expect_error(CAM MAT "sphere { center 0 0 0 radius nan material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:30: expected a finite number after 'radius', found 'nan'", "NaN");
    expect_error(CAM MAT "sphere { center 0 0 1e999 radius 1 material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:21: expected a finite number after 'center', found '1e999'", "overflow to Inf");
    expect_error(CAM MAT "sphere { center 0 0 0 radius 0 material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:23: the sphere radius must be positive", "zero radius");
    expect_error(CAM MAT "sphere { center 0 0 0 material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:34: expected 'radius' in the sphere block", "missing radius");
    expect_error(CAM "sphere { center 0 0 0 radius 1 material wood }\n", CSI_ERR_SCENE,
                 "bad.scene:2:41: unknown material 'wood'", "unknown material");
    expect_error(CAM MAT "mesh { file \"nope.obj\" material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:13: " CSI_SOURCE_DIR "/tests/tracer/data/nope.obj: cannot open OBJ mesh: No such file",
                 "missing OBJ");
    expect_error(CAM MAT "mesh { file \"degenerate.obj\" material m }\n", CSI_ERR_SCENE,
                 "degenerate (zero area)", "degenerate OBJ triangle");
    expect_error(CAM MAT "mesh { file \"badstmt.obj\" material m }\n", CSI_ERR_SCENE,
                 "badstmt.obj:4: unknown OBJ statement 'bogus'", "bad OBJ statement");
    expect_error(CAM MAT "mesh { vertices { 0 0 0 1 1 1 2 2 2 } triangles { 0 1 2 } material m }\n",
                 CSI_ERR_SCENE, "triangle 0 is degenerate", "collinear inline triangle");
    expect_error(CAM MAT "mesh { vertices { 0 0 0 1 0 0 0 1 0 } triangles { 0 1 3 } material m }\n",
                 CSI_ERR_SCENE, "uses vertex 3 of 3", "index out of range");
    expect_error(CAM MAT "box { min 0 0 0 max 1 0 1 material m }\n", CSI_ERR_SCENE,
                 "bad.scene:3:1: box: 'max' must exceed 'min'", "flat box");
    expect_error(CAM MAT "plane { corner 0 0 0 edge_u 1 0 0 edge_v 2 0 0 material m }\n",
                 CSI_ERR_SCENE, "bad.scene:3:1: plane: triangle 0 is degenerate", "degenerate plane");
    expect_error(CAM "material t { texture \"missing.png\" }\n", CSI_ERR_SCENE,
                 "bad.scene:2:22: texture: " CSI_SOURCE_DIR "/tests/tracer/data/missing.png: cannot open texture: "
                 "No such file", "missing texture");
    /* inputs that are not regular files: said so, never read (a FIFO would block) */
    expect_error(CAM "material t { texture \".\" }\n", CSI_ERR_SCENE, "cannot open texture: a directory",
                 "texture that is a directory");
    expect_error(CAM MAT "mesh { file \"/dev/null\" material m }\n", CSI_ERR_SCENE,
                 "/dev/null: cannot open OBJ mesh: a character device", "OBJ that is a device");
    expect_error(CAM "material t { texture \"empty.png\" }\n", CSI_ERR_SCENE,
                 "neither PNG nor OpenEXR (empty file)", "zero-byte image");
    expect_error(CAM "material t { texture \"quad.obj\" }\n", CSI_ERR_SCENE,
                 "neither PNG nor OpenEXR", "not an image");
    expect_error("camera { position 0 0 -5 target 0 0 0 size 0 256 }\n", CSI_ERR_SCENE,
                 "bad.scene:1:44: 'size' needs an integer in [1, 65536], found '0'",
                 "zero-size image");
    expect_error("camera { position 0 0 0 target 0 0 0 }\n", CSI_ERR_SCENE,
                 "bad.scene:1:1: camera: 'target' must differ", "degenerate camera");
    expect_error(CAM MAT "shutter 0 1\nsphere { center 0 0 0 radius 1 material m motion { key 0 { } "
                         "key 1.5 { translate 1 0 0 } } }\n",
                 CSI_ERR_SCENE, "bad.scene:4:62: motion key at time 1.5 is outside the shutter",
                 "key outside shutter");
    /* the shutter may come after the motion that it bounds */
    expect_error(CAM MAT "sphere { center 0 0 0 radius 1 material m motion { key 0 { } key 2 { } "
                         "} }\nshutter 0.5 3\n",
                 CSI_ERR_SCENE, "bad.scene:3:52: motion key at time 0 is outside",
                 "key before a later shutter");
    expect_error(CAM MAT "sphere { center 0 0 0 radius 1 material m motion { key 0.5 { } key 0.5 "
                         "{ } } }\n",
                 CSI_ERR_SCENE, "motion key times must increase", "repeated key time");
    {
        char *text = malloc(20000);
        size_t n = (size_t)sprintf(text, CAM MAT "shutter 0 200\nsphere { center 0 0 0 radius 1 "
                                                 "material m motion {");
        for (int k = 0; k < 130; k++)
            n += (size_t)sprintf(text + n, " key %d { translate %d 0 0 }", k, k);
        sprintf(text + n, " } }\n");
        expect_error(text, CSI_ERR_SCENE, "more than 129 motion keys", "130 keys");
        free(text);
    }
    expect_error(CAM "light spot { }\n", CSI_ERR_SCENE,
                 "bad.scene:2:7: expected 'point', 'directional' or 'area' after 'light'",
                 "unknown light");
    expect_error(CAM "light point { position 0 1 0 }\n", CSI_ERR_SCENE,
                 "bad.scene:2:30: expected 'intensity' in the light block", "light intensity");
    expect_error(CAM "material t { texture \"abc }\n", CSI_ERR_SCENE, "bad.scene:2:22",
                 "unterminated string");
    expect_error(CAM MAT "sphere { center 0 0 0 radius 1 material m\n", CSI_ERR_SCENE,
                 "bad.scene:4:1: expected 'center', 'radius', 'material', 'motion' or '}' in the "
                 "sphere block, found end of file",
                 "unclosed block");
    expect_error("material m { diffuse 1 1 1 }\n", CSI_ERR_SCENE,
                 "expected a 'camera' block", "no camera");
    expect_error(CAM "path_tracing { max_bounces 0 }\n", CSI_ERR_SCENE,
                 "bad.scene:2:28: 'max_bounces' needs an integer in [1, 64]", "zero bounces");
    expect_error(CAM "ambient_occlusion { samples 4 distance -1 }\n", CSI_ERR_SCENE,
                 "bad.scene:2:31: 'distance' must be positive", "negative AO distance");
    expect_error(CAM "material m { diffuse -1 1 1 }\n", CSI_ERR_SCENE,
                 "'diffuse' needs non-negative values", "negative colour");
    expect_error(CAM MAT "sphere { center 0 0 0 radius 1 material m motion { key 0 { scale 0 } } "
                         "}\n",
                 CSI_ERR_SCENE, "'scale' must not be zero", "zero scale");

    /* motion that collapses an object or the camera's view is refused by the plan */
    {
        const char *bad[2] = {
            CAM MAT "shutter 0 2\nsphere { center 0 0 0 radius 1 material m motion { key 0 { scale "
                    "1 } key 2 { scale -1 } } }\n",
            "camera { position 0 0 -5 target 0 0 0 motion { key 0 { } key 1 { scale -1 } } }\n"};
        const char *want[2] = {"test.scene:4: sphere motion collapses it (zero scale) at time 1",
                               "camera motion makes the view degenerate at time 0.5"};
        for (int k = 0; k < 2; k++) {
            csi_scene *bs;
            CHECK_OK(csi_scene_parse(bad[k], "test.scene", NULL, &bs));
            if (!bs)
                continue;
            csi_plan pl;
            csi_status pst = csi_plan_make(bs, NULL, &pl);
            CHECK(pst == CSI_ERR_SCENE && strstr(csi_last_error(), want[k]),
                  "collapsing motion %d: %s %s", k, csi_status_name(pst), csi_last_error());
            if (pst == CSI_OK)
                csi_plan_free(&pl);
            csi_scene_free(bs);
        }
    }

    /* OBJ lines have no length limit (a 6000-byte line is one line, not two), and a face of more
     * than 64 vertices is named as such */
    {
        char path[] = "/tmp/csi-test-objXXXXXX";
        int fd = mkstemp(path);
        FILE *f = fd >= 0 ? fdopen(fd, "w") : NULL;
        CHECK(f != NULL, "temporary OBJ");
        if (f) {
            fprintf(f, "v 0 0 0%6000s\nv 1 0 0\nv 0 1 0\nf 1 2 3 %6000s\n", "", "");
            fclose(f);
            char text[512];
            snprintf(text, sizeof text, CAM MAT "mesh { file \"%s\" material m }\n", path);
            csi_scene *obj_sc = NULL;
            CHECK_OK(csi_scene_parse(text, "long.scene", "/tmp", &obj_sc));
            csi_scene_free(obj_sc);
            f = fopen(path, "w");
            fprintf(f, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
            for (int i = 0; i < 70; i++)
                fprintf(f, " %d", 1 + i % 3);
            fprintf(f, "\n");
            fclose(f);
            expect_error(text, CSI_ERR_SCENE, ":4: a face with more than 64 vertices", "long face");
            unlink(path);
        }
    }
    /* a scene that is a directory or a device: CSI_ERR_IO saying what it is; a FIFO does not
     * block the loader */
    {
        csi_scene *x = NULL;
        csi_status sx = csi_scene_load(CSI_SOURCE_DIR "/tests/tracer/data", &x);
        CHECK(sx == CSI_ERR_IO && strstr(csi_last_error(), "a directory"), "directory scene: %s", csi_last_error());
        sx = csi_scene_load("/dev/zero", &x);
        CHECK(sx == CSI_ERR_IO && strstr(csi_last_error(), "/dev/zero: cannot open scene: a character device"),
              "device scene: %s", csi_last_error());
        char fifo[] = "/tmp/csi-test-fifoXXXXXX";
        int fd = mkstemp(fifo);
        if (fd >= 0) {
            close(fd);
            unlink(fifo);
            if (mkfifo(fifo, 0600) == 0) {
                sx = csi_scene_load(fifo, &x);
                CHECK(sx == CSI_ERR_IO && strstr(csi_last_error(), "a FIFO"), "FIFO scene: %s", csi_last_error());
                unlink(fifo);
            }
        }
    }
    /* missing scene file: CSI_ERR_IO naming the path */
    csi_scene *sc;
    csi_status st = csi_scene_load(CSI_SOURCE_DIR "/tests/tracer/data/no-such.scene", &sc);
    CHECK(st == CSI_ERR_IO && strstr(csi_last_error(), "no-such.scene"), "missing scene: %s %s",
          csi_status_name(st), csi_last_error());

    /* a good OBJ with uvs loads: 4 vertices fan-triangulated into 2 triangles */
    CHECK_OK(csi_scene_parse(CAM MAT "mesh { file \"quad.obj\" material m }\n", "good.scene",
                             CSI_SOURCE_DIR "/tests/tracer/data", &sc));
    if (sc) {
        csi_plan pl;
        CHECK_OK(csi_plan_make(sc, NULL, &pl));
        char *js = NULL;
        CHECK_OK(csi_plan_json_string(sc, &pl, &js));
        CHECK(js && strstr(js, "\"triangles\": 2"), "quad.obj: %s", js ? js : "");
        free(js);
        csi_plan_free(&pl);
        csi_scene_free(sc);
    }
    /* robustness: every truncation and 3000 random byte changes of a bundled scene give
     * either a scene or an error with a message, never a crash (run under ASan too) */
    {
        FILE *f = fopen(CSI_SOURCE_DIR "/data/scenes/billiards.scene", "rb");
        char *text = calloc(1, 1 << 16);
        size_t len = f ? fread(text, 1, (1 << 16) - 1, f) : 0;
        if (f)
            fclose(f);
        CHECK(len > 100, "cannot read billiards.scene");
        char *cp = malloc(len + 1);
        size_t ok = 0, failed_with_msg = 0, total = 0;
        test_rng r;
        test_rng_seed(&r, 3);
        const char pool[] = "{}\"#.-+0123456789eabcxyz \n\t";
        for (size_t cut = 0; cut < len + 3000; cut += cut < len ? 7 : 1) {
            memcpy(cp, text, len + 1);
            if (cut < len) {
                cp[cut] = '\0';
            } else {
                for (int m = 0; m < 3; m++)
                    cp[test_rng_u64(&r) % len] = pool[test_rng_u64(&r) % (sizeof pool - 1)];
            }
            csi_clear_error();
            csi_status st2 = csi_scene_parse(cp, "fuzz.scene", CSI_SOURCE_DIR "/data/scenes", &sc);
            total++;
            if (st2 == CSI_OK) {
                ok++;
                csi_scene_free(sc);
            } else if (csi_last_error()[0] && sc == NULL) {
                failed_with_msg++;
            }
        }
        CHECK(ok + failed_with_msg == total, "%zu of %zu mutated scenes ended without a message",
              total - ok - failed_with_msg, total);
        free(cp);
        free(text);
    }
    /* every bundled scene parses and plans */
    const char *names[] = {"triangle", "checkerboard", "billiards", "train", "garden"};
    for (int i = 0; i < 5; i++) {
        char path[1024];
        snprintf(path, sizeof path, CSI_SOURCE_DIR "/data/scenes/%s.scene", names[i]);
        CHECK_OK(csi_scene_load(path, &sc));
        csi_scene_free(sc);
    }
    return test_done();
}
