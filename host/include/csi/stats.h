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

#include "csi/status.h" /* and csi/csi.h, which declares the builder (public) */

#endif
