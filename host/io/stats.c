/* Ordered JSON key/value builder (see csi/stats.h). */
#include "csi/stats.h"

#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "csi/outfile.h"

struct csi_json {
    char *buf;
    size_t len, cap;
    int depth;        /* open nested objects below the top level */
    bool first;       /* no member yet in the innermost open object */
    bool nomem;
    const char *misuse;
    char *doc;        /* closed document, made by csi_json_text */
};

static void put(csi_json *j, const char *s, size_t n)
{
    if (j->nomem)
        return;
    if (j->len + n + 1 > j->cap) {
        size_t cap = j->cap ? j->cap : 256;
        while (j->len + n + 1 > cap)
            cap *= 2;
        char *b = realloc(j->buf, cap);
        if (!b) {
            j->nomem = true;
            return;
        }
        j->buf = b;
        j->cap = cap;
    }
    memcpy(j->buf + j->len, s, n);
    j->len += n;
    j->buf[j->len] = '\0';
}

static void puts_(csi_json *j, const char *s) { put(j, s, strlen(s)); }

static void put_string(csi_json *j, const char *s)
{
    put(j, "\"", 1);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        char esc[8];
        switch (*p) {
        case '"': puts_(j, "\\\""); break;
        case '\\': puts_(j, "\\\\"); break;
        case '\n': puts_(j, "\\n"); break;
        case '\r': puts_(j, "\\r"); break;
        case '\t': puts_(j, "\\t"); break;
        case '\b': puts_(j, "\\b"); break;
        case '\f': puts_(j, "\\f"); break;
        default:
            if (*p < 0x20) {
                snprintf(esc, sizeof esc, "\\u%04x", *p);
                puts_(j, esc);
            } else {
                put(j, (const char *)p, 1);
            }
        }
    }
    put(j, "\"", 1);
}

/* Separator, indentation and key of a new member. */
static bool member(csi_json *j, const char *key)
{
    if (!key) {
        j->misuse = "a member has a NULL key";
        return false;
    }
    if (!j->first)
        put(j, ",", 1);
    put(j, "\n", 1);
    for (int i = 0; i <= j->depth; i++)
        put(j, "  ", 2);
    put_string(j, key);
    put(j, ": ", 2);
    j->first = false;
    return true;
}

csi_status csi_json_new(csi_json **out)
{
    csi_json *j = calloc(1, sizeof *j);
    if (!j)
        return csi_fail(CSI_ERR_NOMEM, "out of memory for a JSON document");
    j->first = true;
    put(j, "{", 1);
    if (j->nomem) {
        free(j);
        return csi_fail(CSI_ERR_NOMEM, "out of memory for a JSON document");
    }
    *out = j;
    return CSI_OK;
}

void csi_json_free(csi_json *j)
{
    if (!j)
        return;
    free(j->buf);
    free(j->doc);
    free(j);
}

void csi_json_str(csi_json *j, const char *key, const char *value)
{
    if (!member(j, key))
        return;
    if (value)
        put_string(j, value);
    else
        puts_(j, "null");
}

void csi_json_num(csi_json *j, const char *key, double value)
{
    if (!member(j, key))
        return;
    char b[40];
    if (!isfinite(value))
        snprintf(b, sizeof b, "null");
    else
        snprintf(b, sizeof b, "%.9g", value);
    puts_(j, b);
}

void csi_json_int(csi_json *j, const char *key, int64_t value)
{
    if (!member(j, key))
        return;
    char b[32];
    snprintf(b, sizeof b, "%" PRId64, value);
    puts_(j, b);
}

void csi_json_bool(csi_json *j, const char *key, bool value)
{
    if (member(j, key))
        puts_(j, value ? "true" : "false");
}

void csi_json_begin(csi_json *j, const char *key)
{
    if (!member(j, key))
        return;
    put(j, "{", 1);
    j->depth++;
    j->first = true;
}

void csi_json_end(csi_json *j)
{
    if (j->depth == 0) {
        j->misuse = "csi_json_end without a matching csi_json_begin";
        return;
    }
    bool empty = j->first;
    j->depth--;
    if (!empty) {
        put(j, "\n", 1);
        for (int i = 0; i <= j->depth; i++)
            put(j, "  ", 2);
    }
    put(j, "}", 1);
    j->first = false;
}

csi_status csi_json_text(csi_json *j, const char **text)
{
    if (j->misuse)
        return csi_fail(CSI_ERR_ARG, "JSON document: %s", j->misuse);
    if (j->depth != 0)
        return csi_fail(CSI_ERR_ARG, "JSON document: %d nested object(s) still open", j->depth);
    if (j->nomem)
        return csi_fail(CSI_ERR_NOMEM, "out of memory building a JSON document");
    size_t n = j->len;
    bool empty = j->first;
    free(j->doc);
    j->doc = malloc(n + 4);
    if (!j->doc)
        return csi_fail(CSI_ERR_NOMEM, "out of memory building a JSON document");
    memcpy(j->doc, j->buf, n);
    memcpy(j->doc + n, empty ? "}\n" : "\n}\n", empty ? 3 : 4);
    *text = j->doc;
    return CSI_OK;
}

csi_status csi_json_write(csi_json *j, const char *path)
{
    const char *text;
    CSI_TRY(csi_json_text(j, &text));
    csi_outfile of;
    CSI_TRY(csi_outfile_open(&of, path));
    size_t n = strlen(text);
    if (fwrite(text, 1, n, of.fp) != n) {
        csi_outfile_abort(&of);
        return csi_fail(CSI_ERR_IO, "%s: write failed", path);
    }
    return csi_outfile_commit(&of);
}
