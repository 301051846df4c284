/* Stats JSON: exact text for a small document (order, escaping, %.9g, nesting, null for
 * non-finite), misuse reported, atomic write. */
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "csi/stats.h"
#include "testlib.h"

int main(void)
{
    csi_json *j;
    REQUIRE_OK(csi_json_new(&j));
    csi_json_str(j, "solver", "romp");
    csi_json_num(j, "lambda", 0.1);
    csi_json_int(j, "iterations", -42);
    csi_json_bool(j, "converged", true);
    csi_json_str(j, "text", "a\"b\\c\n\x01/é");
    csi_json_begin(j, "times");
    csi_json_num(j, "solve_s", 1.0 / 3.0);
    csi_json_num(j, "bad", NAN);
    csi_json_begin(j, "empty");
    csi_json_end(j);
    csi_json_end(j);
    csi_json_str(j, "none", NULL);
    const char *text;
    REQUIRE_OK(csi_json_text(j, &text));
    const char *want = "{\n"
                       "  \"solver\": \"romp\",\n"
                       "  \"lambda\": 0.1,\n"
                       "  \"iterations\": -42,\n"
                       "  \"converged\": true,\n"
                       "  \"text\": \"a\\\"b\\\\c\\n\\u0001/é\",\n"
                       "  \"times\": {\n"
                       "    \"solve_s\": 0.333333333,\n"
                       "    \"bad\": null,\n"
                       "    \"empty\": {}\n"
                       "  },\n"
                       "  \"none\": null\n"
                       "}\n";
    CHECK(strcmp(text, want) == 0, "document:\n%s\nwanted:\n%s", text, want);

    char dir[256];
    snprintf(dir, sizeof dir, "%s/test_stats_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir))
        return 1;
    char path[512];
    snprintf(path, sizeof path, "%s/s.json", dir);
    CHECK_OK(csi_json_write(j, path));
    FILE *f = fopen(path, "rb");
    char buf[1024] = {0};
    size_t n = f ? fread(buf, 1, sizeof buf - 1, f) : 0;
    if (f)
        fclose(f);
    CHECK(n == strlen(want) && strcmp(buf, want) == 0, "file content");
    unlink(path);
    snprintf(path, sizeof path, "%s/missing/s.json", dir);
    CHECK(csi_json_write(j, path) == CSI_ERR_IO && strstr(csi_last_error(), "s.json"), "%s", csi_last_error());
    rmdir(dir);
    csi_json_free(j);

    /* Misuse: an unclosed object, an extra end, an empty document. */
    REQUIRE_OK(csi_json_new(&j));
    csi_json_begin(j, "open");
    CHECK(csi_json_text(j, &text) == CSI_ERR_ARG && strstr(csi_last_error(), "still open"), "%s", csi_last_error());
    csi_json_free(j);
    REQUIRE_OK(csi_json_new(&j));
    csi_json_end(j);
    CHECK(csi_json_text(j, &text) == CSI_ERR_ARG && strstr(csi_last_error(), "without"), "%s", csi_last_error());
    csi_json_free(j);
    REQUIRE_OK(csi_json_new(&j));
    CHECK_OK(csi_json_text(j, &text));
    CHECK(strcmp(text, "{}\n") == 0, "empty document \"%s\"", text);
    csi_json_free(j);
    return test_done();
}
