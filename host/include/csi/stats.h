/* A tiny JSON writer for run statistics: an ordered key/value builder.
 *
 * Keys appear in the order they are added; strings are escaped (RFC 8259: quote, backslash,
 * control characters as \uXXXX; other bytes passed through, so UTF-8 stays UTF-8); numbers are
 * printed with %.9g (enough for float32 round trips, and readable), non-finite numbers as null
 * (JSON has no NaN). Nested objects with csi_json_begin / csi_json_end. Misuse (end without
 * begin, writing with an object still open, a NULL key) is remembered and reported by
 * csi_json_text / csi_json_write as CSI_ERR_ARG, so callers may chain adds without checks.
 *
 *   csi_json *j; csi_json_new(&j);
 *   csi_json_str(j, "solver", "romp");
 *   csi_json_begin(j, "times"); csi_json_num(j, "solve_s", 1.25); csi_json_end(j);
 *   csi_json_write(j, "stats.json"); csi_json_free(j);
 */
#ifndef CSI_STATS_H
#define CSI_STATS_H

#include <stdbool.h>
#include <stdint.h>

#include "csi/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct csi_json csi_json;

csi_status csi_json_new(csi_json **out); /* an open top-level object */
void csi_json_free(csi_json *j);

void csi_json_str(csi_json *j, const char *key, const char *value); /* NULL value -> null */
void csi_json_num(csi_json *j, const char *key, double value);
void csi_json_int(csi_json *j, const char *key, int64_t value);
void csi_json_bool(csi_json *j, const char *key, bool value);
void csi_json_begin(csi_json *j, const char *key); /* opens a nested object */
void csi_json_end(csi_json *j);                   /* closes it */

/* The document (closed top-level object, newline-terminated); valid until the next call on j. */
csi_status csi_json_text(csi_json *j, const char **text);
/* Writes the document (temporary file, then rename). */
csi_status csi_json_write(csi_json *j, const char *path);

#ifdef __cplusplus
}
#endif
#endif
