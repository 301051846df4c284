/* Sample dump reader and writer (format: docs/dump-format.md, csi/dump.h). */
#include "csi/dump.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "csi/host_memory.h"
#include "csi/infile.h"
#include "csi/outfile.h"

/* Explicit little-endian (de)coding: the file's byte order never depends on the host's. */
static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static uint64_t le64(const unsigned char *p) { return (uint64_t)le32(p) | (uint64_t)le32(p + 4) << 32; }
static void put32(unsigned char *p, uint32_t v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
    p[2] = (unsigned char)(v >> 16);
    p[3] = (unsigned char)(v >> 24);
}
static void put64(unsigned char *p, uint64_t v)
{
    put32(p, (uint32_t)v);
    put32(p + 4, (uint32_t)(v >> 32));
}
static float f32_of(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}
static uint32_t u32_of(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

csi_status csi_dump_check_grid(const csi_grid *g, uint32_t channels, uint64_t max_cells)
{
    if (max_cells == 0)
        max_cells = CSI_DUMP_MAX_CELLS;
    const struct { const char *name; uint32_t v; } sides[] = {
        {"grid_w", g->w}, {"grid_h", g->h}, {"grid_t", g->t}, {"out_w", g->out_w}, {"out_h", g->out_h}};
    for (size_t i = 0; i < sizeof sides / sizeof sides[0]; i++) {
        if (sides[i].v == 0)
            return csi_fail(CSI_ERR_FORMAT, "%s is zero", sides[i].name);
        if (sides[i].v > CSI_DUMP_MAX_SIDE)
            return csi_fail(CSI_ERR_FORMAT, "%s = %" PRIu32 " is larger than the limit %u", sides[i].name,
                            sides[i].v, CSI_DUMP_MAX_SIDE);
    }
    if (g->t > CSI_GRID_MAX_FRAMES)
        return csi_fail(CSI_ERR_FORMAT, "grid_t = %" PRIu32 " frames is more than the limit %u (docs/dump-format.md)",
                        g->t, CSI_GRID_MAX_FRAMES);
    if (g->w % g->out_w != 0)
        return csi_fail(CSI_ERR_FORMAT, "grid_w = %" PRIu32 " is not a multiple of out_w = %" PRIu32, g->w, g->out_w);
    if (g->h % g->out_h != 0)
        return csi_fail(CSI_ERR_FORMAT, "grid_h = %" PRIu32 " is not a multiple of out_h = %" PRIu32, g->h, g->out_h);
    uint64_t k = (uint64_t)g->w * g->h * g->t; /* < 2^48: no overflow */
    if (k > max_cells)
        return csi_fail(CSI_ERR_FORMAT, "grid %" PRIu32 "x%" PRIu32 "x%" PRIu32 " has %" PRIu64
                        " cells, more than the limit %" PRIu64, g->w, g->h, g->t, k, max_cells);
    if (channels < 1 || channels > CSI_DUMP_MAX_CHANNELS)
        return csi_fail(CSI_ERR_FORMAT, "channels = %" PRIu32 " (must be 1 to %u)", channels, CSI_DUMP_MAX_CHANNELS);
    return CSI_OK;
}

csi_status csi_dump_alloc(csi_dump *d, size_t count, uint32_t channels)
{
    d->pos = NULL;
    d->values = NULL;
    d->count = 0;
    if (channels < 1 || channels > CSI_DUMP_MAX_CHANNELS)
        return csi_fail(CSI_ERR_ARG, "csi_dump_alloc: channels = %" PRIu32 " (must be 1 to 4)", channels);
    if (count > SIZE_MAX / (sizeof(float) * CSI_DUMP_MAX_CHANNELS + sizeof(csi_sample_pos)))
        return csi_fail(CSI_ERR_NOMEM, "csi_dump_alloc: %zu samples is too many", count);
    size_t n = count ? count : 1;
    d->pos = calloc(n, sizeof *d->pos);
    d->values = calloc(n * channels, sizeof *d->values);
    if (!d->pos || !d->values) {
        csi_dump_free(d);
        return csi_fail(CSI_ERR_NOMEM, "out of memory for %zu samples", count);
    }
    d->count = count;
    d->channels = channels;
    return CSI_OK;
}

void csi_dump_free(csi_dump *d)
{
    if (!d)
        return;
    free(d->pos);
    free(d->values);
    d->pos = NULL;
    d->values = NULL;
    d->count = 0;
}

/* One record's offset in the file, for messages. */
static uint64_t rec_offset(uint64_t r, size_t rec_bytes) { return CSI_DUMP_HEADER_BYTES + r * rec_bytes; }

/* Sort keys for merging duplicates: (linear index, record number) makes the order, and so the
 * averaging order, independent of qsort's stability. */
typedef struct { uint64_t lin; uint64_t rec; } dump_key;
static int key_cmp(const void *a, const void *b)
{
    const dump_key *x = a, *y = b;
    if (x->lin != y->lin)
        return x->lin < y->lin ? -1 : 1;
    return x->rec < y->rec ? -1 : x->rec > y->rec;
}

/* Where the bytes come from: a file (read in chunks), or memory (fuzzing, embedders). */
typedef struct {
    FILE *fp;
    const unsigned char *mem;
    size_t len, pos;
} dump_src;

static size_t src_read(dump_src *s, void *buf, size_t n)
{
    if (s->fp)
        return fread(buf, 1, n, s->fp);
    size_t m = s->len - s->pos < n ? s->len - s->pos : n;
    memcpy(buf, s->mem + s->pos, m);
    s->pos += m;
    return m;
}

/* Validates the header bytes h[0..got) of a file of fsize bytes (everything but the records). */
static csi_status parse_header(const char *path, const unsigned char *h, size_t got, uint64_t fsize,
                               const csi_dump_read_opts *opts, csi_dump_header *hdr)
{
    if (got < 4 || memcmp(h, CSI_DUMP_MAGIC, 4) != 0) {
        if (got < 4)
            return csi_fail(CSI_ERR_FORMAT, "%s: byte %zu: truncated header (file has %zu bytes, a dump header "
                            "has 64)", path, got, got);
        char shown[20];
        int k = 0;
        for (int i = 0; i < 4; i++)
            k += snprintf(shown + k, sizeof shown - (size_t)k, (h[i] >= 32 && h[i] < 127) ? "%c" : "\\x%02x", h[i]);
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 0: wrong magic \"%s\" (expected \"CSID\"): not a csi sample dump",
                        path, shown);
    }
    if (got < 8)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte %zu: truncated header (file has %zu bytes, a dump header has 64)",
                        path, got, got);
    uint32_t version = le32(h + 4);
    if (version != CSI_DUMP_VERSION)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 4: unknown version %" PRIu32 " (this reader knows version 1)",
                        path, version);
    if (got < CSI_DUMP_HEADER_BYTES)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte %zu: truncated header (file has %zu bytes, a dump header has 64)",
                        path, got, got);
    csi_grid g = {.w = le32(h + 8), .h = le32(h + 12), .t = le32(h + 16), .out_w = le32(h + 20), .out_h = le32(h + 24)};
    uint32_t channels = le32(h + 28);
    uint64_t count = le64(h + 32);
    if (channels == 0)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 28: channels = 0: a positions request (positions only, no values), "
                        "not samples: a renderer evaluates it and writes a dump with values", path);
    /* Grid and channels before anything that depends on them; the byte offset names the field. */
    {
        csi_status st = csi_dump_check_grid(&g, channels, opts->max_cells);
        if (st != CSI_OK) {
            const char *m = csi_last_error();
            int off = strncmp(m, "grid_w", 6) == 0 ? 8 : strncmp(m, "grid_h", 6) == 0 ? 12
                    : strncmp(m, "grid_t", 6) == 0 ? 16 : strncmp(m, "out_w", 5) == 0 ? 20
                    : strncmp(m, "out_h", 5) == 0 ? 24 : strncmp(m, "channels", 8) == 0 ? 28 : 8;
            return csi_fail_context(st, "%s: byte %d: ", path, off);
        }
    }
    /* Bytes 48-51: the flags (CSI_SAMPLES_*); a bit this reader does not know may change what
     * the values mean, so it is refused like the reserved bytes after it. */
    const uint32_t flags = le32(h + 48);
    if (flags & ~(uint32_t)CSI_SAMPLES_KNOWN_FLAGS)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 48: flags 0x%08" PRIx32 " has reserved bits 0x%08" PRIx32
                        " set, must be zero (this reader knows 0x%08x: exact values)", path, flags,
                        flags & ~(uint32_t)CSI_SAMPLES_KNOWN_FLAGS, CSI_SAMPLES_KNOWN_FLAGS);
    for (int i = 52; i < 64; i++)
        if (h[i] != 0)
            return csi_fail(CSI_ERR_FORMAT, "%s: byte %d: reserved byte is 0x%02x, must be zero", path, i, h[i]);
    if (count == 0)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 32: zero samples (count = 0)", path);
    const size_t rec_bytes = 12 + 4 * (size_t)channels;
    uint64_t payload = fsize - CSI_DUMP_HEADER_BYTES;
    if (count > payload / rec_bytes)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte 32: count = %" PRIu64 " records of %zu bytes but the file holds "
                        "only %" PRIu64 " bytes after the header (truncated at record %" PRIu64 ")", path, count,
                        rec_bytes, payload, payload / rec_bytes);
    if (payload != count * rec_bytes)
        return csi_fail(CSI_ERR_FORMAT, "%s: byte %" PRIu64 ": %" PRIu64 " trailing bytes after the last of %" PRIu64
                        " records", path, rec_offset(count, rec_bytes), payload - count * rec_bytes, count);
    hdr->grid = g;
    hdr->channels = channels;
    hdr->count = count;
    hdr->seed = le64(h + 40);
    hdr->flags = flags;
    return CSI_OK;
}

uint64_t csi_dump_read_host_bytes(const csi_dump_header *h)
{
    /* the records as read, the chunk buffer, and when they must be sorted, the keys and the merged
     * copy */
    const uint64_t per = 12 + 4 * (uint64_t)h->channels;
    return h->count * per + ((uint64_t)1 << 16) * per + h->count * 16 + h->count * per;
}

/* Reads and validates the header from a source of fsize bytes. */
static csi_status read_header(dump_src *src, const char *path, uint64_t fsize, const csi_dump_read_opts *opts,
                              csi_dump_header *hdr)
{
    unsigned char h[CSI_DUMP_HEADER_BYTES];
    size_t got = src_read(src, h, sizeof h);
    if (src->fp && got < sizeof h && ferror(src->fp))
        return csi_fail(CSI_ERR_IO, "%s: read error: %s", path, strerror(errno));
    return parse_header(path, h, got, fsize, opts, hdr);
}

csi_status csi_dump_read_header(const char *path, const csi_dump_read_opts *opts, csi_dump_header *out)
{
    csi_dump_read_opts defaults = {0};
    memset(out, 0, sizeof *out);
    if (!opts)
        opts = &defaults;
    dump_src src = {0};
    uint64_t fsize;
    CSI_TRY(csi_infile_open(path, "sample dump", 0, &src.fp, &fsize));
    csi_status st = read_header(&src, path, fsize, opts, out);
    fclose(src.fp);
    return st;
}

/* The records after a valid header: validated, then sorted and merged when they are not already
 * sorted and unique. */
static csi_status read_records(dump_src *src, const char *path, const csi_dump_header *hdr,
                               const csi_dump_read_opts *opts, csi_dump *out, csi_dump_report *report)
{
    const csi_grid g = hdr->grid;
    const uint32_t channels = hdr->channels;
    const uint64_t count = hdr->count;
    const size_t rec_bytes = 12 + 4 * (size_t)channels;
    report->records = count;
    const uint64_t avail = csi_host_available_bytes();
    if (avail && csi_dump_read_host_bytes(hdr) > avail) {
        char need[32], have[32];
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: %" PRIu64 " records need %s of host memory to read, more than the "
                        "%s available", path, count, csi_bytes_text(csi_dump_read_host_bytes(hdr), need, sizeof need),
                        csi_bytes_text(avail, have, sizeof have));
    }

    /* The file holds count records, so count is bounded by the file size: allocation is safe. */
    csi_dump raw = {.grid = g, .channels = channels, .seed = hdr->seed, .flags = hdr->flags};
    if (count > SIZE_MAX / rec_bytes)
        return csi_fail(CSI_ERR_NOMEM, "%s: %" PRIu64 " records do not fit in memory", path, count);
    if (csi_dump_alloc(&raw, (size_t)count, channels) != CSI_OK)
        return csi_fail_context(CSI_ERR_NOMEM, "%s: ", path);

    enum { CHUNK = 1 << 16 };
    const size_t chunk = count < CHUNK ? (size_t)count : CHUNK;
    unsigned char *buf = malloc(chunk * rec_bytes);
    if (!buf) {
        csi_dump_free(&raw);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory", path);
    }
    csi_status st = CSI_OK;
    size_t kept = 0;
    bool sorted_unique = true;
    uint64_t prev_lin = 0;
    for (uint64_t r0 = 0; r0 < count && st == CSI_OK; r0 += chunk) {
        size_t nrec = (size_t)(count - r0 < chunk ? count - r0 : chunk);
        size_t rd = src_read(src, buf, nrec * rec_bytes) / rec_bytes;
        if (rd != nrec) {
            st = csi_fail(CSI_ERR_FORMAT, "%s: record %" PRIu64 " (byte %" PRIu64 "): truncated (read error: %s)",
                          path, r0 + rd, rec_offset(r0 + rd, rec_bytes),
                          src->fp && ferror(src->fp) ? strerror(errno) : "end of file");
            break;
        }
        for (size_t i = 0; i < nrec; i++) {
            const unsigned char *p = buf + i * rec_bytes;
            uint64_t r = r0 + i;
            csi_sample_pos ps = {le32(p), le32(p + 4), le32(p + 8)};
            if (ps.t != 0 && g.t == 1) {
                st = csi_fail(CSI_ERR_FORMAT, "%s: record %" PRIu64 " (byte %" PRIu64 "): t = %" PRIu32
                              " but the grid is static (grid_t = 1, so t must be 0)", path, r,
                              rec_offset(r, rec_bytes), ps.t);
                break;
            }
            if (ps.x >= g.w || ps.y >= g.h || ps.t >= g.t) {
                st = csi_fail(CSI_ERR_FORMAT, "%s: record %" PRIu64 " (byte %" PRIu64 "): position (%" PRIu32 ", %"
                              PRIu32 ", %" PRIu32 ") outside the %" PRIu32 "x%" PRIu32 "x%" PRIu32 " grid", path, r,
                              rec_offset(r, rec_bytes), ps.x, ps.y, ps.t, g.w, g.h, g.t);
                break;
            }
            float v[CSI_DUMP_MAX_CHANNELS];
            bool finite = true;
            uint32_t bad_c = 0;
            for (uint32_t c = 0; c < channels; c++) {
                v[c] = f32_of(le32(p + 12 + 4 * c));
                if (finite && !isfinite(v[c])) {
                    finite = false;
                    bad_c = c;
                }
            }
            if (!finite) {
                if (!opts->drop_invalid) {
                    st = csi_fail(CSI_ERR_FORMAT, "%s: record %" PRIu64 " (byte %" PRIu64 "): channel %" PRIu32
                                  " is %s (use drop_invalid / --drop-invalid to skip such records)", path, r,
                                  rec_offset(r, rec_bytes) + 12 + 4 * bad_c, bad_c,
                                  isnan(v[bad_c]) ? "NaN" : "infinite");
                    break;
                }
                if (report->dropped_invalid++ == 0)
                    report->first_invalid = r;
                continue;
            }
            uint64_t lin = csi_grid_index(&g, ps);
            if (kept > 0 && lin <= prev_lin)
                sorted_unique = false;
            prev_lin = lin;
            raw.pos[kept] = ps;
            memcpy(raw.values + kept * channels, v, channels * sizeof(float));
            kept++;
        }
    }
    free(buf);
    if (st != CSI_OK) {
        csi_dump_free(&raw);
        return st;
    }
    if (kept == 0) {
        csi_dump_free(&raw);
        return csi_fail(CSI_ERR_FORMAT, "%s: no valid samples: all %" PRIu64 " records hold NaN or Inf", path, count);
    }
    raw.count = kept;
    if (sorted_unique) {
        *out = raw;
        return CSI_OK;
    }

    /* Sort by (linear index, record) and merge runs at one position by averaging in double. */
    dump_key *keys = malloc(kept * sizeof *keys);
    csi_dump res = {.grid = g, .channels = channels, .seed = hdr->seed, .flags = hdr->flags};
    if (!keys || csi_dump_alloc(&res, kept, channels) != CSI_OK) {
        free(keys);
        csi_dump_free(&raw);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory sorting %zu samples", path, kept);
    }
    for (size_t i = 0; i < kept; i++) {
        keys[i].lin = csi_grid_index(&g, raw.pos[i]);
        keys[i].rec = i;
    }
    qsort(keys, kept, sizeof *keys, key_cmp);
    size_t n = 0;
    for (size_t i = 0; i < kept;) {
        size_t j = i + 1;
        while (j < kept && keys[j].lin == keys[i].lin)
            j++;
        res.pos[n] = raw.pos[keys[i].rec];
        if (j - i == 1) {
            memcpy(res.values + n * channels, raw.values + keys[i].rec * channels, channels * sizeof(float));
        } else {
            for (uint32_t c = 0; c < channels; c++) {
                double s = 0.0;
                for (size_t m = i; m < j; m++)
                    s += raw.values[keys[m].rec * channels + c];
                res.values[n * channels + c] = (float)(s / (double)(j - i));
            }
            report->duplicates += j - i - 1;
        }
        n++;
        i = j;
    }
    free(keys);
    csi_dump_free(&raw);
    res.count = n;
    *out = res;
    return CSI_OK;
}

/* Header and records from one source of fsize bytes. */
static csi_status read_source(dump_src *src, const char *path, uint64_t fsize, const csi_dump_read_opts *opts,
                              csi_dump *out, csi_dump_report *report)
{
    csi_dump_read_opts defaults = {0};
    csi_dump_report rep_local;
    if (!opts)
        opts = &defaults;
    if (!report)
        report = &rep_local;
    memset(report, 0, sizeof *report);
    csi_dump_header hdr;
    CSI_TRY(read_header(src, path, fsize, opts, &hdr));
    return read_records(src, path, &hdr, opts, out, report);
}

csi_status csi_dump_read(const char *path, const csi_dump_read_opts *opts, csi_dump *out,
                         csi_dump_report *report)
{
    memset(out, 0, sizeof *out);
    if (report)
        memset(report, 0, sizeof *report);
    if (!path)
        return csi_fail(CSI_ERR_ARG, "csi_dump_read: no path");
    dump_src src = {0};
    uint64_t fsize;
    CSI_TRY(csi_infile_open(path, "sample dump", 0, &src.fp, &fsize));
    csi_status st = read_source(&src, path, fsize, opts, out, report);
    fclose(src.fp);
    return st;
}

csi_status csi_dump_read_mem(const void *data, size_t len, const char *name, const csi_dump_read_opts *opts,
                             csi_dump *out, csi_dump_report *report)
{
    memset(out, 0, sizeof *out);
    if (report)
        memset(report, 0, sizeof *report);
    if (!data && len)
        return csi_fail(CSI_ERR_ARG, "csi_dump_read_mem: no data");
    dump_src src = {.mem = data, .len = len};
    return read_source(&src, name ? name : "(memory)", len, opts, out, report);
}

csi_status csi_dump_write(const char *path, const csi_dump *d)
{
    /* channels = 0 is a positions request (records x, y, t only): its grid is checked alone. */
    if (csi_dump_check_grid(&d->grid, d->channels ? d->channels : 1, 0) != CSI_OK)
        return csi_fail_context(CSI_ERR_ARG, "%s: cannot write dump: ", path);
    if (d->count == 0)
        return csi_fail(CSI_ERR_ARG, "%s: cannot write a dump with zero samples", path);
    if (d->flags & ~(uint32_t)CSI_SAMPLES_KNOWN_FLAGS)
        return csi_fail(CSI_ERR_ARG, "%s: cannot write dump: flags 0x%08" PRIx32 " has reserved bits set", path,
                        d->flags);
    if (d->channels == 0 && d->flags)
        return csi_fail(CSI_ERR_ARG, "%s: cannot write dump: a positions request has no values to be exact "
                        "(flags must be 0)", path);
    const uint32_t ch = d->channels;
    for (size_t i = 0; i < d->count; i++) {
        csi_sample_pos p = d->pos[i];
        if (p.x >= d->grid.w || p.y >= d->grid.h || p.t >= d->grid.t)
            return csi_fail(CSI_ERR_ARG, "%s: cannot write dump: sample %zu at (%" PRIu32 ", %" PRIu32 ", %" PRIu32
                            ") is outside the %" PRIu32 "x%" PRIu32 "x%" PRIu32 " grid", path, i, p.x, p.y, p.t,
                            d->grid.w, d->grid.h, d->grid.t);
        for (uint32_t c = 0; c < ch; c++)
            if (!isfinite(d->values[i * ch + c]))
                return csi_fail(CSI_ERR_ARG, "%s: cannot write dump: sample %zu channel %" PRIu32 " is not finite",
                                path, i, c);
    }
    unsigned char h[CSI_DUMP_HEADER_BYTES] = {0};
    memcpy(h, CSI_DUMP_MAGIC, 4);
    put32(h + 4, CSI_DUMP_VERSION);
    put32(h + 8, d->grid.w);
    put32(h + 12, d->grid.h);
    put32(h + 16, d->grid.t);
    put32(h + 20, d->grid.out_w);
    put32(h + 24, d->grid.out_h);
    put32(h + 28, ch);
    put64(h + 32, (uint64_t)d->count);
    put64(h + 40, d->seed);
    put32(h + 48, d->flags);

    csi_outfile of;
    CSI_TRY(csi_outfile_open(&of, path));
    const size_t rec_bytes = 12 + 4 * (size_t)ch;
    enum { CHUNK = 1 << 14 };
    unsigned char *buf = malloc((size_t)CHUNK * rec_bytes);
    if (!buf) {
        csi_outfile_abort(&of);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory", path);
    }
    bool ok = fwrite(h, 1, sizeof h, of.fp) == sizeof h;
    for (size_t i0 = 0; ok && i0 < d->count; i0 += CHUNK) {
        size_t n = d->count - i0 < CHUNK ? d->count - i0 : CHUNK;
        for (size_t i = 0; i < n; i++) {
            unsigned char *p = buf + i * rec_bytes;
            const csi_sample_pos ps = d->pos[i0 + i];
            put32(p, ps.x);
            put32(p + 4, ps.y);
            put32(p + 8, ps.t);
            for (uint32_t c = 0; c < ch; c++)
                put32(p + 12 + 4 * c, u32_of(d->values[(i0 + i) * ch + c]));
        }
        ok = fwrite(buf, rec_bytes, n, of.fp) == n;
    }
    free(buf);
    if (!ok) {
        int e = errno;
        csi_outfile_abort(&of);
        return csi_fail(CSI_ERR_IO, "%s: write failed: %s", path, strerror(e));
    }
    return csi_outfile_commit(&of);
}
