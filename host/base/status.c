/* Per-thread error message storage for csi_status failures. */
#include "csi/status.h"

#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

static _Thread_local char csi_msg[2048];
static _Thread_local csi_status csi_last;

const char *csi_status_name(csi_status st)
{
    switch (st) {
    case CSI_OK: return "CSI_OK";
    case CSI_ERR_ARG: return "CSI_ERR_ARG";
    case CSI_ERR_IO: return "CSI_ERR_IO";
    case CSI_ERR_FORMAT: return "CSI_ERR_FORMAT";
    case CSI_ERR_NOMEM: return "CSI_ERR_NOMEM";
    case CSI_ERR_DEVICE: return "CSI_ERR_DEVICE";
    case CSI_ERR_CL: return "CSI_ERR_CL";
    case CSI_ERR_BUILD: return "CSI_ERR_BUILD";
    case CSI_ERR_NUMERIC: return "CSI_ERR_NUMERIC";
    case CSI_ERR_SCENE: return "CSI_ERR_SCENE";
    case CSI_ERR_TOO_LARGE: return "CSI_ERR_TOO_LARGE";
    case CSI_ERR_CANCELLED: return "CSI_ERR_CANCELLED";
    }
    return "CSI_ERR_UNKNOWN";
}

/* Length of the valid UTF-8 sequence at s (1..4) that is not a C1 control, or 0. */
static size_t utf8_ok(const unsigned char *s)
{
    unsigned c = s[0];
    size_t n = c >= 0xF0 && c <= 0xF4 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 && c < 0xE0 ? 2 : 0;
    if (n == 0)
        return 0;
    uint32_t cp = c & (0x7F >> n);
    for (size_t i = 1; i < n; i++) {
        if ((s[i] & 0xC0) != 0x80)
            return 0;
        cp = cp << 6 | (s[i] & 0x3F);
    }
    if ((n == 3 && cp < 0x800) || (n == 4 && (cp < 0x10000 || cp > 0x10FFFF)) || (cp >= 0xD800 && cp <= 0xDFFF))
        return 0; /* overlong or not a scalar value */
    if (cp >= 0x80 && cp <= 0x9F)
        return 0; /* C1 controls (CSI among them) */
    return n;
}

size_t csi_escape_controls(const char *in, char *out, size_t cap)
{
    size_t o = 0;
    const unsigned char *s = (const unsigned char *)in;
    if (cap == 0)
        return 0;
    while (*s) {
        size_t n = *s >= 0x20 && *s < 0x7F ? 1 : *s >= 0x80 ? utf8_ok(s) : 0;
        if (n) {
            if (o + n >= cap)
                break;
            memcpy(out + o, s, n);
            o += n;
            s += n;
        } else {
            if (o + 4 >= cap)
                break;
            snprintf(out + o, 5, "\\x%02x", *s);
            o += 4;
            s++;
        }
    }
    out[o] = '\0';
    return o;
}

const char *csi_last_error(void) { return csi_msg; }

csi_status csi_last_status(void) { return csi_last; }

void csi_clear_error(void)
{
    csi_msg[0] = '\0';
    csi_last = CSI_OK;
}

csi_status csi_fail(csi_status st, const char *fmt, ...)
{
    char raw[sizeof csi_msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(raw, sizeof raw, fmt, ap);
    va_end(ap);
    csi_last = st;
    csi_escape_controls(raw, csi_msg, sizeof csi_msg);
    return st;
}

csi_status csi_fail_context(csi_status st, const char *fmt, ...)
{
    char prefix[1024], old[sizeof csi_msg];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, csi_msg, sizeof old);
    snprintf(csi_msg, sizeof csi_msg, "%.1023s%.1000s", prefix, old);
    csi_last = st;
    char raw[sizeof csi_msg];
    snprintf(raw, sizeof raw, "%.1023s%.1000s", prefix, old);
    csi_escape_controls(raw, csi_msg, sizeof csi_msg);
    return st;
}
