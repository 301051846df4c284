/* Scene file parser (grammar in docs/scene-format.md), OBJ loader, motion and camera.
 *
 * The format is a sequence of statements made of words, numbers, "strings" and { } blocks;
 * '#' starts a comment. Every error names file:line:column and what was expected. */
#include "tracer_internal.h"

#include "csi/host_memory.h"
#include "csi/infile.h"

#include <ctype.h>
#include <stdarg.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- lexer ---------------------------------------------------------------------------------- */

enum { TK_EOF, TK_WORD, TK_NUM, TK_STR, TK_LBRACE, TK_RBRACE, TK_BAD };

typedef struct token {
    int kind;
    char text[512];
    double num;
    int line, col;
} token;

typedef struct parser {
    const char *name, *base_dir;
    const char *s;
    size_t pos;
    int line, col;
    token tk;      /* current (peeked) token */
    csi_scene *sc;
} parser;

static const char *tk_desc(const token *t, char *buf, size_t n)
{
    switch (t->kind) {
    case TK_EOF: return "end of file";
    case TK_LBRACE: return "'{'";
    case TK_RBRACE: return "'}'";
    case TK_STR: snprintf(buf, n, "string \"%.200s\"", t->text); return buf;
    default: snprintf(buf, n, "'%.200s'", t->text); return buf;
    }
}

static void lex_next(parser *p)
{
    token *t = &p->tk;
    const char *s = p->s;
    for (;;) {
        char c = s[p->pos];
        if (c == '\n') {
            p->line++;
            p->col = 1;
            p->pos++;
        } else if (c == ' ' || c == '\t' || c == '\r') {
            p->col++;
            p->pos++;
        } else if (c == '#') {
            while (s[p->pos] && s[p->pos] != '\n')
                p->pos++;
        } else {
            break;
        }
    }
    t->line = p->line;
    t->col = p->col;
    t->text[0] = '\0';
    char c = s[p->pos];
    if (!c) {
        t->kind = TK_EOF;
        return;
    }
    if (c == '{' || c == '}') {
        t->kind = c == '{' ? TK_LBRACE : TK_RBRACE;
        t->text[0] = c;
        t->text[1] = '\0';
        p->pos++;
        p->col++;
        return;
    }
    if (c == '"') {
        size_t n = 0;
        p->pos++;
        p->col++;
        while (s[p->pos] && s[p->pos] != '"' && s[p->pos] != '\n') {
            if (n + 1 < sizeof t->text)
                t->text[n++] = s[p->pos];
            p->pos++;
            p->col++;
        }
        t->text[n] = '\0';
        if (s[p->pos] != '"') {
            t->kind = TK_BAD;
            snprintf(t->text, sizeof t->text, "unterminated string");
            return;
        }
        p->pos++;
        p->col++;
        t->kind = TK_STR;
        return;
    }
    size_t n = 0;
    while (s[p->pos] && !isspace((unsigned char)s[p->pos]) && s[p->pos] != '{' &&
           s[p->pos] != '}' && s[p->pos] != '#' && s[p->pos] != '"') {
        if (n + 1 < sizeof t->text)
            t->text[n++] = s[p->pos];
        p->pos++;
        p->col++;
    }
    t->text[n] = '\0';
    if (isdigit((unsigned char)c) || c == '-' || c == '+' || c == '.') {
        char *end;
        errno = 0;
        t->num = strtod(t->text, &end);
        /* strtod accepts "nan"/"inf" only after a sign here; reject any non-finite value. */
        t->kind = (*end == '\0' && end != t->text && isfinite(t->num) && errno != ERANGE)
                      ? TK_NUM
                      : TK_BAD;
        return;
    }
    t->kind = TK_WORD;
}

static csi_status perr(parser *p, const token *at, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static csi_status perr(parser *p, const token *at, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return csi_fail(CSI_ERR_SCENE, "%s:%d:%d: %s", p->name, at->line, at->col, msg);
}

static csi_status expected(parser *p, const char *what)
{
    char b[600];
    return perr(p, &p->tk, "expected %s, found %s", what, tk_desc(&p->tk, b, sizeof b));
}

static csi_status expect_kind(parser *p, int kind, const char *what)
{
    if (p->tk.kind != kind)
        return expected(p, what);
    return CSI_OK;
}

static csi_status read_num(parser *p, const char *after, double *v)
{
    if (p->tk.kind != TK_NUM) {
        char what[128];
        snprintf(what, sizeof what, "a finite number after '%s'", after);
        return expected(p, what);
    }
    *v = p->tk.num;
    lex_next(p);
    return CSI_OK;
}

static csi_status read_nums(parser *p, const char *after, double *v, int n)
{
    for (int i = 0; i < n; i++)
        CSI_TRY(read_num(p, after, &v[i]));
    return CSI_OK;
}

static csi_status read_color(parser *p, const char *after, float c[3], bool nonneg)
{
    double v[3];
    token at = p->tk;
    CSI_TRY(read_nums(p, after, v, 3));
    for (int i = 0; i < 3; i++) {
        if (nonneg && v[i] < 0)
            return perr(p, &at, "'%s' needs non-negative values", after);
        c[i] = (float)v[i];
    }
    return CSI_OK;
}

static csi_status read_uint(parser *p, const char *after, uint32_t lo, uint32_t hi, uint32_t *v)
{
    token at = p->tk;
    double d = 0;
    CSI_TRY(read_num(p, after, &d));
    if (d != floor(d) || d < lo || d > hi)
        return perr(p, &at, "'%s' needs an integer in [%u, %u], found '%s'", after, lo, hi,
                    at.text);
    *v = (uint32_t)d;
    return CSI_OK;
}

static csi_status open_block(parser *p, const char *what)
{
    char w[128];
    snprintf(w, sizeof w, "'{' to open the %s block", what);
    CSI_TRY(expect_kind(p, TK_LBRACE, w));
    lex_next(p);
    return CSI_OK;
}

static bool is_word(const parser *p, const char *w)
{
    return p->tk.kind == TK_WORD && strcmp(p->tk.text, w) == 0;
}

/* ---- parsing -------------------------------------------------------------------------------- */

static csi_status parse_motion(parser *p, tr_motion *mo)
{
    token start = p->tk;
    lex_next(p); /* 'motion' */
    CSI_TRY(open_block(p, "motion"));
    size_t cap = 0;
    while (p->tk.kind != TK_RBRACE) {
        if (!is_word(p, "key"))
            return expected(p, "'key' or '}' in the motion block");
        token keytok = p->tk;
        lex_next(p);
        tr_key k;
        memset(&k, 0, sizeof k);
        k.axis[0] = 1;
        k.scale[0] = k.scale[1] = k.scale[2] = 1;
        CSI_TRY(read_num(p, "key", &k.time));
        k.line = keytok.line;
        k.col = keytok.col;
        if (mo->n > 0 && !(k.time > mo->keys[mo->n - 1].time))
            return perr(p, &keytok, "motion key times must increase (%g after %g)", k.time,
                        mo->keys[mo->n - 1].time);
        if (mo->n >= CSI_MAX_TIME_STEPS)
            return perr(p, &keytok, "more than %d motion keys (Embree's time-step limit)",
                        CSI_MAX_TIME_STEPS);
        CSI_TRY(open_block(p, "key"));
        double q[4] = {1, 0, 0, 0};
        while (p->tk.kind != TK_RBRACE) {
            token at = p->tk;
            if (is_word(p, "translate")) {
                lex_next(p);
                CSI_TRY(read_nums(p, "translate", k.translate, 3));
            } else if (is_word(p, "rotate")) {
                lex_next(p);
                double a[4];
                CSI_TRY(read_nums(p, "rotate", a, 4));
                double l = norm3(a);
                if (!(l > 1e-12))
                    return perr(p, &at, "'rotate' needs a non-zero axis");
                double ax[3] = {a[0] / l, a[1] / l, a[2] / l}, qr[4], qn[4];
                if (q[0] == 1 && q[1] == 0 && q[2] == 0 && q[3] == 0) {
                    /* first rotation of the key: keep its angle as written (may exceed pi) */
                    memcpy(k.axis, ax, sizeof ax);
                    k.angle = a[3] * M_PI / 180.0;
                    tr_aa_to_q(k.axis, k.angle, q);
                    if (k.angle == 0)
                        q[0] = 1, q[1] = q[2] = q[3] = 0;
                    continue;
                }
                tr_aa_to_q(ax, a[3] * M_PI / 180.0, qr);
                /* later rotations apply after the earlier ones: q = qr * q */
                qn[0] = qr[0] * q[0] - qr[1] * q[1] - qr[2] * q[2] - qr[3] * q[3];
                qn[1] = qr[0] * q[1] + qr[1] * q[0] + qr[2] * q[3] - qr[3] * q[2];
                qn[2] = qr[0] * q[2] - qr[1] * q[3] + qr[2] * q[0] + qr[3] * q[1];
                qn[3] = qr[0] * q[3] + qr[1] * q[2] - qr[2] * q[1] + qr[3] * q[0];
                memcpy(q, qn, sizeof q);
                tr_q_to_aa(q, k.axis, &k.angle);
            } else if (is_word(p, "scale")) {
                lex_next(p);
                CSI_TRY(read_num(p, "scale", &k.scale[0]));
                if (p->tk.kind == TK_NUM) {
                    CSI_TRY(read_nums(p, "scale", &k.scale[1], 2));
                } else {
                    k.scale[1] = k.scale[2] = k.scale[0];
                }
                for (int j = 0; j < 3; j++)
                    if (!(fabs(k.scale[j]) > 1e-12))
                        return perr(p, &at, "'scale' must not be zero (degenerate geometry)");
            } else {
                return expected(p, "'translate', 'rotate', 'scale' or '}' in the key block");
            }
        }
        lex_next(p);
        if (mo->n == cap) {
            cap = cap ? 2 * cap : 4;
            tr_key *nk = realloc(mo->keys, cap * sizeof *nk);
            if (!nk)
                return csi_fail(CSI_ERR_NOMEM, "out of memory (motion keys)");
            mo->keys = nk;
        }
        mo->keys[mo->n++] = k;
    }
    if (mo->n == 0)
        return perr(p, &start, "the motion block has no 'key'");
    lex_next(p);
    return CSI_OK;
}

static int find_material(const csi_scene *sc, const char *name)
{
    for (size_t i = 0; i < sc->n_materials; i++)
        if (strcmp(sc->materials[i].name, name) == 0)
            return (int)i;
    return -1;
}

static void join_path(const char *dir, const char *file, char *out, size_t n)
{
    if (file[0] == '/' || !dir || !dir[0])
        snprintf(out, n, "%s", file);
    else
        snprintf(out, n, "%s/%s", dir, file);
}

/* Records a file the scene reads (its outputs must not overwrite it). */
static csi_status scene_input(csi_scene *sc, const char *path)
{
    char **ni = realloc(sc->inputs, (sc->n_inputs + 1) * sizeof *ni);
    if (!ni)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (scene inputs)");
    sc->inputs = ni;
    size_t n = strlen(path) + 1;
    if (!(sc->inputs[sc->n_inputs] = malloc(n)))
        return csi_fail(CSI_ERR_NOMEM, "out of memory (scene inputs)");
    memcpy(sc->inputs[sc->n_inputs++], path, n);
    return CSI_OK;
}

size_t csi_scene_input_count(const csi_scene *sc) { return sc->n_inputs; }
const char *csi_scene_input(const csi_scene *sc, size_t i) { return i < sc->n_inputs ? sc->inputs[i] : NULL; }

static csi_status parse_material(parser *p)
{
    csi_scene *sc = p->sc;
    lex_next(p); /* 'material' */
    if (p->tk.kind != TK_WORD && p->tk.kind != TK_STR)
        return expected(p, "a material name after 'material'");
    token nametok = p->tk;
    if (find_material(sc, nametok.text) >= 0)
        return perr(p, &nametok, "material '%s' is declared twice", nametok.text);
    if (strlen(nametok.text) >= 64)
        return perr(p, &nametok, "material name longer than 63 characters");
    /* checked above: fits */
    lex_next(p);
    CSI_TRY(open_block(p, "material"));
    tr_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%.63s", nametok.text);
    m.kind = MAT_DIFFUSE;
    m.albedo[0] = m.albedo[1] = m.albedo[2] = 0.8f;
    m.uv_scale[0] = m.uv_scale[1] = 1;
    m.texture = -1;
    while (p->tk.kind != TK_RBRACE) {
        token at = p->tk;
        if (is_word(p, "diffuse")) {
            lex_next(p);
            CSI_TRY(read_color(p, "diffuse", m.albedo, true));
            m.kind = MAT_DIFFUSE;
        } else if (is_word(p, "checker")) {
            lex_next(p);
            CSI_TRY(read_color(p, "checker", m.albedo, true));
            CSI_TRY(read_color(p, "checker", m.albedo2, true));
            token st = p->tk;
            CSI_TRY(read_num(p, "checker", &m.checker_size));
            if (!(m.checker_size > 0))
                return perr(p, &st, "the checker square size must be positive");
            m.kind = MAT_CHECKER;
        } else if (is_word(p, "texture")) {
            lex_next(p);
            CSI_TRY(expect_kind(p, TK_STR, "a quoted file name after 'texture'"));
            token ft = p->tk;
            char path[1024];
            join_path(p->base_dir, ft.text, path, sizeof path);
            size_t ti;
            for (ti = 0; ti < sc->n_textures; ti++)
                if (strcmp(sc->textures[ti].path, path) == 0)
                    break;
            if (ti == sc->n_textures) {
                tr_texture tx;
                memset(&tx, 0, sizeof tx);
                snprintf(tx.path, sizeof tx.path, "%s", path);
                csi_status st = scene_input(sc, path);
                if (st == CSI_OK)
                    st = tr_image_load(path, &tx.w, &tx.h, &tx.rgb);
                if (st != CSI_OK)
                    return csi_fail_context(CSI_ERR_SCENE, "%s:%d:%d: texture: ", p->name,
                                            ft.line, ft.col);
                tr_texture *nt = realloc(sc->textures, (sc->n_textures + 1) * sizeof *nt);
                if (!nt) {
                    free(tx.rgb);
                    return csi_fail(CSI_ERR_NOMEM, "out of memory (textures)");
                }
                sc->textures = nt;
                sc->textures[sc->n_textures++] = tx;
            }
            m.texture = (int)ti;
            m.kind = MAT_TEXTURE;
            lex_next(p);
        } else if (is_word(p, "uv_scale")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "uv_scale", m.uv_scale, 2));
            if (m.uv_scale[0] == 0 || m.uv_scale[1] == 0)
                return perr(p, &at, "'uv_scale' must not be zero");
        } else if (is_word(p, "emission")) {
            lex_next(p);
            CSI_TRY(read_color(p, "emission", m.emission, true));
        } else {
            return expected(p, "'diffuse', 'checker', 'texture', 'uv_scale', 'emission' or '}' "
                               "in the material block");
        }
    }
    lex_next(p);
    tr_material *nm = realloc(sc->materials, (sc->n_materials + 1) * sizeof *nm);
    if (!nm)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (materials)");
    sc->materials = nm;
    sc->materials[sc->n_materials++] = m;
    return CSI_OK;
}

/* ---- meshes --------------------------------------------------------------------------------- */

typedef struct fbuf {
    float *v;
    size_t n, cap;
} fbuf;
typedef struct ubuf {
    uint32_t *v;
    size_t n, cap;
} ubuf;
static bool fpush(fbuf *b, float x)
{
    if (b->n == b->cap) {
        size_t c = b->cap ? 2 * b->cap : 64;
        float *nv = realloc(b->v, c * sizeof *nv);
        if (!nv)
            return false;
        b->v = nv;
        b->cap = c;
    }
    b->v[b->n++] = x;
    return true;
}
static bool upush(ubuf *b, uint32_t x)
{
    if (b->n == b->cap) {
        size_t c = b->cap ? 2 * b->cap : 64;
        uint32_t *nv = realloc(b->v, c * sizeof *nv);
        if (!nv)
            return false;
        b->v = nv;
        b->cap = c;
    }
    b->v[b->n++] = x;
    return true;
}

/* Checks for NaN and zero-area triangles: the first bad one is reported. */
static csi_status check_mesh(const tr_object *o, const char *where)
{
    for (size_t i = 0; i < 3 * o->nv; i++)
        if (!isfinite(o->pos[i]))
            return csi_fail(CSI_ERR_SCENE, "%s: vertex %zu is not finite", where, i / 3);
    for (size_t t = 0; t < o->nt; t++) {
        double e1[3], e2[3], c[3];
        for (int k = 0; k < 3; k++) {
            if (o->tri[3 * t + k] >= o->nv)
                return csi_fail(CSI_ERR_SCENE, "%s: triangle %zu uses vertex %u of %zu", where,
                                t, o->tri[3 * t + k], o->nv);
        }
        const float *a = &o->pos[3 * o->tri[3 * t]], *b = &o->pos[3 * o->tri[3 * t + 1]],
                    *d = &o->pos[3 * o->tri[3 * t + 2]];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)b[k] - a[k];
            e2[k] = (double)d[k] - a[k];
        }
        cross3(e1, e2, c);
        double l = norm3(e1) + norm3(e2);
        if (!(norm3(c) > 1e-12 * l * l) || l == 0)
            return csi_fail(CSI_ERR_SCENE, "%s: triangle %zu is degenerate (zero area)", where,
                            t);
    }
    return CSI_OK;
}

csi_status tr_obj_parse(const char *text, size_t len, const char *path, tr_object *o)
{
    fbuf v = {0}, vt = {0}, pos = {0}, uv = {0};
    ubuf tri = {0};
    /* One line at a time into a buffer as long as the longest line (no length limit). */
    char *line = NULL;
    size_t line_cap = 0, at = 0;
    int ln = 0;
    csi_status st = CSI_OK;
    bool any_uv = false;
    while (st == CSI_OK && at < len) {
        const char *nl = memchr(text + at, '\n', len - at);
        const size_t ll = (nl ? (size_t)(nl - text) : len) - at;
        ln++;
        if (ll + 1 > line_cap) {
            char *nb = realloc(line, ll + 1);
            if (!nb) {
                st = csi_fail(CSI_ERR_NOMEM, "%s:%d: out of memory for a line of %zu bytes", path, ln, ll);
                break;
            }
            line = nb;
            line_cap = ll + 1;
        }
        memcpy(line, text + at, ll);
        line[ll] = '\0';
        at += ll + 1;
        if (memchr(line, '\0', ll)) {
            st = csi_fail(CSI_ERR_SCENE, "%s:%d: a NUL byte (not a text OBJ file)", path, ln);
            break;
        }
        char *s = line;
        while (*s == ' ' || *s == '\t')
            s++;
        if (*s == '#' || *s == '\n' || *s == '\r' || *s == '\0')
            continue;
        char kw[16];
        int nkw = 0;
        while (*s && !isspace((unsigned char)*s) && nkw < 15)
            kw[nkw++] = *s++;
        kw[nkw] = '\0';
        if (strcmp(kw, "v") == 0 || strcmp(kw, "vt") == 0) {
            int need = kw[1] ? 2 : 3;
            for (int i = 0; i < need; i++) {
                char *end;
                double d = strtod(s, &end);
                if (end == s || !isfinite(d)) {
                    st = csi_fail(CSI_ERR_SCENE, "%s:%d: expected %d finite numbers after '%s'",
                                  path, ln, need, kw);
                    break;
                }
                s = end;
                if (!fpush(kw[1] ? &vt : &v, (float)d))
                    st = csi_fail(CSI_ERR_NOMEM, "out of memory (OBJ)");
            }
        } else if (strcmp(kw, "f") == 0) {
            long idx[64], tix[64];
            int n = 0;
            while (st == CSI_OK) {
                while (*s == ' ' || *s == '\t')
                    s++;
                if (*s == '\0' || *s == '\n' || *s == '\r')
                    break;
                char *end;
                long a = strtol(s, &end, 10), b = 0;
                if (n >= 64) {
                    st = csi_fail(CSI_ERR_SCENE, "%s:%d: a face with more than 64 vertices", path, ln);
                    break;
                }
                if (end == s) {
                    st = csi_fail(CSI_ERR_SCENE, "%s:%d: bad face vertex", path, ln);
                    break;
                }
                s = end;
                if (*s == '/') {
                    s++;
                    if (*s != '/') {
                        b = strtol(s, &end, 10);
                        if (end == s) {
                            st = csi_fail(CSI_ERR_SCENE, "%s:%d: bad texture index", path, ln);
                            break;
                        }
                        s = end;
                    }
                    if (*s == '/') {
                        s++;
                        strtol(s, &end, 10);
                        s = end;
                    }
                }
                long nvv = (long)(v.n / 3), nvt = (long)(vt.n / 2);
                if (a < 0)
                    a += nvv + 1;
                if (b < 0)
                    b += nvt + 1;
                if (a < 1 || a > nvv || b < 0 || b > nvt) {
                    st = csi_fail(CSI_ERR_SCENE, "%s:%d: face index out of range", path, ln);
                    break;
                }
                idx[n] = a - 1;
                tix[n] = b - 1;
                n++;
            }
            if (st != CSI_OK)
                break;
            if (n < 3) {
                st = csi_fail(CSI_ERR_SCENE, "%s:%d: a face needs at least 3 vertices", path, ln);
                break;
            }
            /* Unshared vertices: simple, and uv seams need them anyway. Fan triangulation. */
            uint32_t base = (uint32_t)(pos.n / 3);
            for (int i = 0; i < n; i++) {
                for (int k = 0; k < 3; k++)
                    fpush(&pos, v.v[3 * idx[i] + k]);
                if (tix[i] >= 0) {
                    any_uv = true;
                    fpush(&uv, vt.v[2 * tix[i]]);
                    fpush(&uv, 1.0f - vt.v[2 * tix[i] + 1]); /* OBJ v is up; ours is down */
                } else {
                    fpush(&uv, 0);
                    fpush(&uv, 0);
                }
            }
            for (int i = 1; i + 1 < n; i++) {
                upush(&tri, base);
                upush(&tri, base + i);
                upush(&tri, base + i + 1);
            }
        } else if (strcmp(kw, "vn") == 0 || strcmp(kw, "g") == 0 || strcmp(kw, "o") == 0 ||
                   strcmp(kw, "s") == 0 || strcmp(kw, "usemtl") == 0 ||
                   strcmp(kw, "mtllib") == 0 || strcmp(kw, "l") == 0) {
            /* normals, groups, smoothing, materials: not used (flat shading, scene materials) */
        } else {
            st = csi_fail(CSI_ERR_SCENE, "%s:%d: unknown OBJ statement '%s'", path, ln, kw);
        }
    }
    free(line);
    free(v.v);
    free(vt.v);
    if (st == CSI_OK && tri.n == 0)
        st = csi_fail(CSI_ERR_SCENE, "%s: no faces", path);
    if (st != CSI_OK) {
        free(pos.v);
        free(uv.v);
        free(tri.v);
        return st;
    }
    o->pos = pos.v;
    o->nv = pos.n / 3;
    o->tri = tri.v;
    o->nt = tri.n / 3;
    if (any_uv) {
        o->uv = uv.v;
    } else {
        free(uv.v);
    }
    return CSI_OK;
}

/* OBJ files larger than this are refused: a mesh holds about 5x its file in memory (vertices
 * unshared per face, uvs, triangles) before Embree builds its BVH, so 256 MiB (about 10 million
 * triangles) already takes gigabytes. */
#define TR_OBJ_MAX_BYTES (UINT64_C(256) << 20)

static csi_status load_obj(const char *path, tr_object *o)
{
    char *text;
    size_t len;
    CSI_TRY(csi_infile_read_all(path, "OBJ mesh", TR_OBJ_MAX_BYTES, &text, &len));
    const uint64_t need = 8 * (uint64_t)len, avail = csi_host_available_bytes();
    csi_status st;
    if (avail && need > avail) {
        char a[32], b[32];
        st = csi_fail(CSI_ERR_TOO_LARGE, "%s: the OBJ mesh needs about %s of host memory, more than the %s "
                      "available", path, csi_bytes_text(need, a, sizeof a), csi_bytes_text(avail, b, sizeof b));
    } else {
        st = tr_obj_parse(text, len, path, o);
    }
    free(text);
    return st;
}

static csi_status make_quad(tr_object *o, const double c[3], const double eu[3],
                            const double ev[3], bool flip)
{
    o->nv = 4;
    o->nt = 2;
    o->pos = malloc(12 * sizeof(float));
    o->uv = malloc(8 * sizeof(float));
    o->tri = malloc(6 * sizeof(uint32_t));
    if (!o->pos || !o->uv || !o->tri)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (plane)");
    double lu = norm3(eu), lv = norm3(ev);
    static const double st[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    for (int i = 0; i < 4; i++) {
        for (int k = 0; k < 3; k++)
            o->pos[3 * i + k] = (float)(c[k] + st[i][0] * eu[k] + st[i][1] * ev[k]);
        /* uv in world units along the edges, so checker sizes are lengths */
        o->uv[2 * i] = (float)(st[i][0] * lu);
        o->uv[2 * i + 1] = (float)(st[i][1] * lv);
    }
    static const uint32_t t0[6] = {0, 1, 2, 0, 2, 3}, t1[6] = {0, 2, 1, 0, 3, 2};
    memcpy(o->tri, flip ? t1 : t0, sizeof t0);
    return CSI_OK;
}

static csi_status make_box(tr_object *o, const double lo[3], const double hi[3])
{
    o->nv = 24;
    o->nt = 12;
    o->pos = malloc(72 * sizeof(float));
    o->uv = malloc(48 * sizeof(float));
    o->tri = malloc(36 * sizeof(uint32_t));
    if (!o->pos || !o->uv || !o->tri)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (box)");
    /* Six faces, each a quad with outward winding (normal = e1 x e2). */
    for (int f = 0; f < 6; f++) {
        int ax = f / 2, side = f % 2;
        int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
        double c[3], eu[3] = {0, 0, 0}, ev[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++)
            c[k] = lo[k];
        c[ax] = side ? hi[ax] : lo[ax];
        eu[a1] = hi[a1] - lo[a1];
        ev[a2] = hi[a2] - lo[a2];
        tr_object q = {0};
        csi_status st = make_quad(&q, c, eu, ev, side == 0);
        if (st == CSI_OK) {
            memcpy(o->pos + 12 * f, q.pos, 12 * sizeof(float));
            memcpy(o->uv + 8 * f, q.uv, 8 * sizeof(float));
            for (int i = 0; i < 6; i++)
                o->tri[6 * f + i] = q.tri[i] + 4 * f;
        }
        free(q.pos);
        free(q.uv);
        free(q.tri);
        CSI_TRY(st);
    }
    return CSI_OK;
}

static csi_status parse_index_list(parser *p, const char *what, ubuf *out)
{
    lex_next(p);
    CSI_TRY(open_block(p, what));
    while (p->tk.kind != TK_RBRACE) {
        uint32_t v;
        CSI_TRY(read_uint(p, what, 0, 0x7fffffff, &v));
        if (!upush(out, v))
            return csi_fail(CSI_ERR_NOMEM, "out of memory (mesh)");
    }
    lex_next(p);
    return CSI_OK;
}

static csi_status parse_float_list(parser *p, const char *what, fbuf *out)
{
    lex_next(p);
    CSI_TRY(open_block(p, what));
    while (p->tk.kind != TK_RBRACE) {
        double d = 0;
        CSI_TRY(read_num(p, what, &d));
        if (!fpush(out, (float)d))
            return csi_fail(CSI_ERR_NOMEM, "out of memory (mesh)");
    }
    lex_next(p);
    return CSI_OK;
}

static void object_free(tr_object *o)
{
    free(o->pos);
    free(o->uv);
    free(o->tri);
    free(o->motion.keys);
    memset(o, 0, sizeof *o);
}

static csi_status parse_object_body(parser *p, tr_object *o, const token *start)
{
    csi_scene *sc = p->sc;
    const char *what = o->what;
    bool has_center = false, has_radius = false, has_corner = false, has_eu = false,
         has_ev = false, has_min = false, has_max = false, has_file = false;
    double center[3] = {0}, radius = 0, corner[3] = {0}, eu[3] = {0}, ev[3] = {0}, lo[3] = {0},
           hi[3] = {0};
    fbuf verts = {0}, uvs = {0};
    ubuf tris = {0};
    token file_tok = {0};
    char file_path[1024] = "";
    o->material = -1;
    csi_status st = open_block(p, what);
    while (st == CSI_OK && p->tk.kind != TK_RBRACE) {
        token at = p->tk;
        bool sphere = o->kind == OBJ_SPHERE, plane = strcmp(what, "plane") == 0,
             box = strcmp(what, "box") == 0, mesh = strcmp(what, "mesh") == 0;
        if (is_word(p, "material")) {
            lex_next(p);
            if (p->tk.kind != TK_WORD && p->tk.kind != TK_STR) {
                st = expected(p, "a material name after 'material'");
                break;
            }
            o->material = find_material(sc, p->tk.text);
            if (o->material < 0) {
                st = perr(p, &p->tk, "unknown material '%s' (declare it before use)",
                          p->tk.text);
                break;
            }
            lex_next(p);
        } else if (is_word(p, "motion")) {
            if (o->motion.n) {
                st = perr(p, &at, "a second motion block");
                break;
            }
            st = parse_motion(p, &o->motion);
        } else if (sphere && is_word(p, "center")) {
            lex_next(p);
            st = read_nums(p, "center", center, 3);
            has_center = true;
        } else if (sphere && is_word(p, "radius")) {
            lex_next(p);
            st = read_num(p, "radius", &radius);
            if (st == CSI_OK && !(radius > 0))
                st = perr(p, &at, "the sphere radius must be positive (degenerate geometry)");
            has_radius = true;
        } else if (plane && is_word(p, "corner")) {
            lex_next(p);
            st = read_nums(p, "corner", corner, 3);
            has_corner = true;
        } else if (plane && is_word(p, "edge_u")) {
            lex_next(p);
            st = read_nums(p, "edge_u", eu, 3);
            has_eu = true;
        } else if (plane && is_word(p, "edge_v")) {
            lex_next(p);
            st = read_nums(p, "edge_v", ev, 3);
            has_ev = true;
        } else if (box && is_word(p, "min")) {
            lex_next(p);
            st = read_nums(p, "min", lo, 3);
            has_min = true;
        } else if (box && is_word(p, "max")) {
            lex_next(p);
            st = read_nums(p, "max", hi, 3);
            has_max = true;
        } else if (mesh && is_word(p, "file")) {
            lex_next(p);
            st = expect_kind(p, TK_STR, "a quoted file name after 'file'");
            if (st == CSI_OK) {
                file_tok = p->tk;
                join_path(p->base_dir, p->tk.text, file_path, sizeof file_path);
                has_file = true;
                lex_next(p);
            }
        } else if (mesh && is_word(p, "vertices")) {
            st = parse_float_list(p, "vertices", &verts);
        } else if (mesh && is_word(p, "uvs")) {
            st = parse_float_list(p, "uvs", &uvs);
        } else if (mesh && is_word(p, "triangles")) {
            st = parse_index_list(p, "triangles", &tris);
        } else {
            char w[256];
            snprintf(w, sizeof w, "%s or '}' in the %s block",
                     sphere  ? "'center', 'radius', 'material', 'motion'"
                     : plane ? "'corner', 'edge_u', 'edge_v', 'material', 'motion'"
                     : box   ? "'min', 'max', 'material', 'motion'"
                             : "'file', 'vertices', 'triangles', 'uvs', 'material', 'motion'",
                     what);
            st = expected(p, w);
        }
    }
    token close = p->tk;
    if (st == CSI_OK) {
        lex_next(p);
        if (o->material < 0)
            st = perr(p, &close, "expected 'material' in the %s block", what);
    }
    if (st == CSI_OK) {
        char where[700];
        snprintf(where, sizeof where, "%s:%d:%d: %s", p->name, start->line, start->col, what);
        if (o->kind == OBJ_SPHERE) {
            if (!has_center || !has_radius)
                st = perr(p, &close, "expected '%s' in the sphere block",
                          has_center ? "radius" : "center");
            memcpy(o->center, center, sizeof center);
            o->radius = radius;
        } else if (strcmp(what, "plane") == 0) {
            if (!has_corner || !has_eu || !has_ev)
                st = perr(p, &close, "expected '%s' in the plane block",
                          !has_corner ? "corner" : !has_eu ? "edge_u" : "edge_v");
            else
                st = make_quad(o, corner, eu, ev, false);
        } else if (strcmp(what, "box") == 0) {
            if (!has_min || !has_max)
                st = perr(p, &close, "expected '%s' in the box block", has_min ? "max" : "min");
            else if (!(hi[0] > lo[0] && hi[1] > lo[1] && hi[2] > lo[2]))
                st = perr(p, start, "box: 'max' must exceed 'min' on every axis "
                                    "(degenerate geometry)");
            else
                st = make_box(o, lo, hi);
        } else {
            if (has_file && (verts.n || tris.n))
                st = perr(p, &file_tok, "a mesh has either 'file' or 'vertices'/'triangles'");
            else if (has_file) {
                st = scene_input(p->sc, file_path);
                if (st == CSI_OK)
                    st = load_obj(file_path, o);
                if (st != CSI_OK) /* a scene error, unless it is a size the host cannot hold */
                    st = csi_fail_context(st == CSI_ERR_TOO_LARGE || st == CSI_ERR_NOMEM ? st : CSI_ERR_SCENE,
                                          "%s:%d:%d: ", p->name, file_tok.line, file_tok.col);
            } else {
                if (verts.n == 0 || verts.n % 3 || tris.n == 0 || tris.n % 3)
                    st = perr(p, start, "mesh: 'vertices' needs a multiple of 3 numbers and "
                                        "'triangles' a multiple of 3 indices (both non-empty)");
                else if (uvs.n && uvs.n != verts.n / 3 * 2)
                    st = perr(p, start, "mesh: 'uvs' needs 2 numbers per vertex");
                else {
                    o->pos = verts.v;
                    o->nv = verts.n / 3;
                    o->tri = tris.v;
                    o->nt = tris.n / 3;
                    o->uv = uvs.n ? uvs.v : NULL;
                    verts.v = NULL;
                    tris.v = NULL;
                    if (uvs.n)
                        uvs.v = NULL;
                }
            }
        }
        if (st == CSI_OK && o->kind == OBJ_MESH)
            st = check_mesh(o, where);
        if (st == CSI_OK && strcmp(what, "plane") == 0) {
            double c[3];
            cross3(eu, ev, c);
            if (!(norm3(c) > 1e-12 * dot3(eu, eu) + 1e-300))
                st = perr(p, start, "plane: 'edge_u' and 'edge_v' span no area (degenerate)");
        }
    }
    free(verts.v);
    free(uvs.v);
    free(tris.v);
    return st;
}

static csi_status parse_object(parser *p, int kind, const char *what)
{
    csi_scene *sc = p->sc;
    token start = p->tk;
    lex_next(p);
    tr_object o;
    memset(&o, 0, sizeof o);
    o.kind = kind;
    o.what = what;
    o.line = start.line;
    csi_status st = parse_object_body(p, &o, &start);
    if (st != CSI_OK) {
        object_free(&o);
        return st;
    }
    tr_object *no = realloc(sc->objects, (sc->n_objects + 1) * sizeof *no);
    if (!no) {
        object_free(&o);
        return csi_fail(CSI_ERR_NOMEM, "out of memory (objects)");
    }
    sc->objects = no;
    sc->objects[sc->n_objects++] = o;
    return CSI_OK;
}

static csi_status parse_light(parser *p)
{
    csi_scene *sc = p->sc;
    token start = p->tk;
    lex_next(p);
    tr_light L;
    memset(&L, 0, sizeof L);
    if (is_word(p, "point"))
        L.kind = LIGHT_POINT;
    else if (is_word(p, "directional"))
        L.kind = LIGHT_DIRECTIONAL;
    else if (is_word(p, "area"))
        L.kind = LIGHT_AREA;
    else
        return expected(p, "'point', 'directional' or 'area' after 'light'");
    lex_next(p);
    CSI_TRY(open_block(p, "light"));
    bool have[4] = {false, false, false, false}; /* pos/dir/corner, color, eu, ev */
    L.samples = 1;
    while (p->tk.kind != TK_RBRACE) {
        token at = p->tk;
        if (L.kind == LIGHT_POINT && is_word(p, "position")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "position", L.position, 3));
            have[0] = true;
        } else if (L.kind == LIGHT_POINT && is_word(p, "intensity")) {
            lex_next(p);
            CSI_TRY(read_color(p, "intensity", L.color, true));
            have[1] = true;
        } else if (L.kind == LIGHT_DIRECTIONAL && is_word(p, "direction")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "direction", L.direction, 3));
            double l = norm3(L.direction);
            if (!(l > 1e-12))
                return perr(p, &at, "'direction' must not be zero");
            for (int i = 0; i < 3; i++)
                L.direction[i] /= l;
            have[0] = true;
        } else if (L.kind == LIGHT_DIRECTIONAL && is_word(p, "irradiance")) {
            lex_next(p);
            CSI_TRY(read_color(p, "irradiance", L.color, true));
            have[1] = true;
        } else if (L.kind == LIGHT_AREA && is_word(p, "corner")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "corner", L.corner, 3));
            have[0] = true;
        } else if (L.kind == LIGHT_AREA && is_word(p, "edge_u")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "edge_u", L.eu, 3));
            have[2] = true;
        } else if (L.kind == LIGHT_AREA && is_word(p, "edge_v")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "edge_v", L.ev, 3));
            have[3] = true;
        } else if (L.kind == LIGHT_AREA && is_word(p, "radiance")) {
            lex_next(p);
            CSI_TRY(read_color(p, "radiance", L.color, true));
            have[1] = true;
        } else if (L.kind == LIGHT_AREA && is_word(p, "samples")) {
            lex_next(p);
            CSI_TRY(read_uint(p, "samples", 1, 1024, &L.samples));
        } else {
            return expected(p, L.kind == LIGHT_POINT ? "'position', 'intensity' or '}'"
                               : L.kind == LIGHT_DIRECTIONAL
                                   ? "'direction', 'irradiance' or '}'"
                                   : "'corner', 'edge_u', 'edge_v', 'radiance', 'samples' or '}'");
        }
    }
    token close = p->tk;
    lex_next(p);
    const char *need = !have[0]  ? (L.kind == LIGHT_POINT         ? "position"
                                    : L.kind == LIGHT_DIRECTIONAL ? "direction"
                                                                  : "corner")
                       : !have[1] ? (L.kind == LIGHT_POINT         ? "intensity"
                                     : L.kind == LIGHT_DIRECTIONAL ? "irradiance"
                                                                   : "radiance")
                       : (L.kind == LIGHT_AREA && !have[2]) ? "edge_u"
                       : (L.kind == LIGHT_AREA && !have[3]) ? "edge_v"
                                                            : NULL;
    if (need)
        return perr(p, &close, "expected '%s' in the light block", need);
    if (L.kind == LIGHT_AREA) {
        cross3(L.eu, L.ev, L.normal);
        L.area = norm3(L.normal);
        if (!(L.area > 1e-12))
            return perr(p, &start, "area light: 'edge_u' and 'edge_v' span no area");
        for (int i = 0; i < 3; i++)
            L.normal[i] /= L.area;
    }
    tr_light *nl = realloc(sc->lights, (sc->n_lights + 1) * sizeof *nl);
    if (!nl)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (lights)");
    sc->lights = nl;
    sc->lights[sc->n_lights++] = L;
    return CSI_OK;
}

static csi_status parse_camera(parser *p, bool *seen)
{
    csi_scene *sc = p->sc;
    tr_camera *c = &sc->camera;
    token start = p->tk;
    if (*seen)
        return perr(p, &start, "a second camera block");
    *seen = true;
    lex_next(p);
    CSI_TRY(open_block(p, "camera"));
    bool has_pos = false, has_tgt = false;
    while (p->tk.kind != TK_RBRACE) {
        token at = p->tk;
        if (is_word(p, "position")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "position", c->position, 3));
            has_pos = true;
        } else if (is_word(p, "target")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "target", c->target, 3));
            has_tgt = true;
        } else if (is_word(p, "up")) {
            lex_next(p);
            CSI_TRY(read_nums(p, "up", c->up, 3));
        } else if (is_word(p, "fov")) {
            lex_next(p);
            CSI_TRY(read_num(p, "fov", &c->fov_deg));
            if (!(c->fov_deg > 0 && c->fov_deg < 180))
                return perr(p, &at, "'fov' must be in (0, 180) degrees");
        } else if (is_word(p, "size")) {
            lex_next(p);
            CSI_TRY(read_uint(p, "size", 1, 65536, &c->width));
            CSI_TRY(read_uint(p, "size", 1, 65536, &c->height));
        } else if (is_word(p, "motion")) {
            if (c->motion.n)
                return perr(p, &at, "a second motion block");
            CSI_TRY(parse_motion(p, &c->motion));
        } else {
            return expected(p, "'position', 'target', 'up', 'fov', 'size', 'motion' or '}' in "
                               "the camera block");
        }
    }
    token close = p->tk;
    lex_next(p);
    if (!has_pos || !has_tgt)
        return perr(p, &close, "expected '%s' in the camera block",
                    has_pos ? "target" : "position");
    double f[3] = {c->target[0] - c->position[0], c->target[1] - c->position[1],
                   c->target[2] - c->position[2]},
           r[3];
    cross3(f, c->up, r);
    if (!(norm3(f) > 1e-12) || !(norm3(r) > 1e-12 * norm3(f) * norm3(c->up)))
        return perr(p, &start, "camera: 'target' must differ from 'position' and 'up' must not "
                               "be parallel to the view direction");
    return CSI_OK;
}

static csi_status parse_toggle_block(parser *p, const char *what, bool *on)
{
    lex_next(p);
    if (is_word(p, "off")) {
        *on = false;
        lex_next(p);
        return CSI_OK;
    }
    if (is_word(p, "on")) /* "on { ... }" reads as well as "{ ... }" */
        lex_next(p);
    char w[128];
    snprintf(w, sizeof w, "'off' or '{' after '%s'", what);
    CSI_TRY(expect_kind(p, TK_LBRACE, w));
    lex_next(p);
    *on = true;
    return CSI_OK;
}

static csi_status parse_top(parser *p)
{
    csi_scene *sc = p->sc;
    bool camera_seen = false, shutter_seen = false;
    lex_next(p);
    while (p->tk.kind != TK_EOF) {
        token at = p->tk;
        if (p->tk.kind == TK_BAD)
            return perr(p, &at, "bad token '%s' (numbers must be finite)", at.text);
        if (is_word(p, "camera")) {
            CSI_TRY(parse_camera(p, &camera_seen));
        } else if (is_word(p, "shutter")) {
            if (shutter_seen)
                return perr(p, &at, "a second 'shutter'");
            shutter_seen = true;
            lex_next(p);
            CSI_TRY(read_num(p, "shutter", &sc->shutter_open));
            token ct = p->tk;
            CSI_TRY(read_num(p, "shutter", &sc->shutter_close));
            if (!(sc->shutter_close > sc->shutter_open))
                return perr(p, &ct, "the shutter must close after it opens");
        } else if (is_word(p, "background")) {
            lex_next(p);
            CSI_TRY(read_color(p, "background", sc->background, true));
        } else if (is_word(p, "frames")) {
            lex_next(p);
            CSI_TRY(read_uint(p, "frames", 1, CSI_GRID_MAX_FRAMES, &sc->frames));
        } else if (is_word(p, "ambient_occlusion")) {
            bool on;
            CSI_TRY(parse_toggle_block(p, "ambient_occlusion", &on));
            sc->ao = on;
            if (on) {
                while (p->tk.kind != TK_RBRACE) {
                    if (is_word(p, "samples")) {
                        lex_next(p);
                        CSI_TRY(read_uint(p, "samples", 1, 4096, &sc->ao_samples));
                    } else if (is_word(p, "distance")) {
                        token dt = p->tk;
                        lex_next(p);
                        CSI_TRY(read_num(p, "distance", &sc->ao_distance));
                        if (!(sc->ao_distance > 0))
                            return perr(p, &dt, "'distance' must be positive");
                    } else if (is_word(p, "color")) {
                        lex_next(p);
                        CSI_TRY(read_color(p, "color", sc->ao_color, true));
                    } else {
                        return expected(p, "'samples', 'distance', 'color' or '}' in the "
                                           "ambient_occlusion block");
                    }
                }
                lex_next(p);
            }
        } else if (is_word(p, "path_tracing")) {
            bool on;
            CSI_TRY(parse_toggle_block(p, "path_tracing", &on));
            sc->path = on;
            if (on) {
                while (p->tk.kind != TK_RBRACE) {
                    if (is_word(p, "max_bounces")) {
                        lex_next(p);
                        CSI_TRY(read_uint(p, "max_bounces", 1, 64, &sc->max_bounces));
                    } else if (is_word(p, "roulette_start")) {
                        lex_next(p);
                        CSI_TRY(read_uint(p, "roulette_start", 0, 64, &sc->roulette_start));
                    } else {
                        return expected(p, "'max_bounces', 'roulette_start' or '}' in the "
                                           "path_tracing block");
                    }
                }
                lex_next(p);
            }
        } else if (is_word(p, "material")) {
            CSI_TRY(parse_material(p));
        } else if (is_word(p, "sphere")) {
            CSI_TRY(parse_object(p, OBJ_SPHERE, "sphere"));
        } else if (is_word(p, "plane")) {
            CSI_TRY(parse_object(p, OBJ_MESH, "plane"));
        } else if (is_word(p, "box")) {
            CSI_TRY(parse_object(p, OBJ_MESH, "box"));
        } else if (is_word(p, "mesh")) {
            CSI_TRY(parse_object(p, OBJ_MESH, "mesh"));
        } else if (is_word(p, "light")) {
            CSI_TRY(parse_light(p));
        } else {
            return expected(p, "a statement ('camera', 'shutter', 'background', 'frames', "
                               "'ambient_occlusion', 'path_tracing', 'material', 'sphere', "
                               "'plane', 'box', 'mesh', 'light')");
        }
    }
    if (!camera_seen)
        return perr(p, &p->tk, "expected a 'camera' block somewhere in the scene");
    /* Keys are checked against the shutter once it is known ('shutter' may come anywhere). */
    for (size_t i = 0; i <= sc->n_objects; i++) {
        const tr_motion *mo = i < sc->n_objects ? &sc->objects[i].motion : &sc->camera.motion;
        for (size_t k = 0; k < mo->n; k++) {
            const tr_key *key = &mo->keys[k];
            if (key->time < sc->shutter_open || key->time > sc->shutter_close) {
                token at = {.line = key->line, .col = key->col};
                return perr(p, &at, "motion key at time %g is outside the shutter interval "
                                    "[%g, %g]",
                            key->time, sc->shutter_open, sc->shutter_close);
            }
        }
    }
    return CSI_OK;
}

static void scene_extent(csi_scene *sc)
{
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    for (size_t i = 0; i < sc->n_objects; i++) {
        const tr_object *o = &sc->objects[i];
        /* bound over key poses (and the rest pose) */
        size_t nk = o->motion.n ? o->motion.n : 1;
        for (size_t k = 0; k < nk; k++) {
            double s = o->motion.n ? (o->motion.keys[k].time - sc->shutter_open) /
                                         (sc->shutter_close - sc->shutter_open)
                                   : 0;
            tr_xform x;
            tr_motion_eval(sc, &o->motion, s, &x);
            if (o->kind == OBJ_SPHERE) {
                double c[3], r = o->radius * (fabs(x.m[0][0]) + fabs(x.m[1][1]) + fabs(x.m[2][2]) +
                                              fabs(x.m[0][1]) + fabs(x.m[1][2]) + fabs(x.m[2][0]));
                tr_xform_point(&x, o->center, c);
                for (int j = 0; j < 3; j++) {
                    lo[j] = fmin(lo[j], c[j] - r);
                    hi[j] = fmax(hi[j], c[j] + r);
                }
            } else {
                for (size_t v = 0; v < o->nv; v++) {
                    double pp[3] = {o->pos[3 * v], o->pos[3 * v + 1], o->pos[3 * v + 2]}, q[3];
                    tr_xform_point(&x, pp, q);
                    for (int j = 0; j < 3; j++) {
                        lo[j] = fmin(lo[j], q[j]);
                        hi[j] = fmax(hi[j], q[j]);
                    }
                }
            }
        }
    }
    double e = 0;
    for (int j = 0; j < 3; j++)
        if (hi[j] >= lo[j])
            e = fmax(e, hi[j] - lo[j]);
    for (int j = 0; j < 3; j++)
        e = fmax(e, fabs(sc->camera.position[j]));
    sc->extent = e > 0 ? e : 1;
}

csi_status csi_scene_parse(const char *text, const char *name, const char *base_dir,
                           csi_scene **out)
{
    *out = NULL;
    if (!text || !name)
        return csi_fail(CSI_ERR_ARG, "csi_scene_parse: NULL argument");
    csi_scene *sc = calloc(1, sizeof *sc);
    if (!sc)
        return csi_fail(CSI_ERR_NOMEM, "out of memory (scene)");
    snprintf(sc->name, sizeof sc->name, "%s", name);
    sc->camera.up[1] = 1;
    sc->camera.fov_deg = 45;
    sc->camera.width = sc->camera.height = 256;
    sc->shutter_open = 0;
    sc->shutter_close = 1;
    sc->ao_samples = 8;
    sc->ao_distance = 1;
    sc->ao_color[0] = sc->ao_color[1] = sc->ao_color[2] = 1;
    sc->max_bounces = 4;
    sc->roulette_start = 2;
    parser p = {.name = name, .base_dir = base_dir, .s = text, .line = 1, .col = 1, .sc = sc};
    csi_status st = parse_top(&p);
    if (st != CSI_OK) {
        csi_scene_free(sc);
        return st;
    }
    scene_extent(sc);
    *out = sc;
    return CSI_OK;
}

/* Scene files larger than this are refused: scenes are written by hand or by small generators
 * (the bundled garden, 3000 grass blades in an OBJ and 350 leaf cards inline, is 44 KB);
 * large meshes belong in OBJ files. */
#define TR_SCENE_MAX_BYTES (UINT64_C(16) << 20)

csi_status csi_scene_load(const char *path, csi_scene **out)
{
    *out = NULL;
    if (!path)
        return csi_fail(CSI_ERR_ARG, "csi_scene_load: NULL path");
    char *buf;
    size_t n;
    CSI_TRY(csi_infile_read_all(path, "scene", TR_SCENE_MAX_BYTES, &buf, &n));
    if (strlen(buf) != n) {
        free(buf);
        return csi_fail(CSI_ERR_SCENE, "%s: contains a NUL byte (not a text scene)", path);
    }
    char dir[1024];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (slash)
        *slash = '\0';
    else
        snprintf(dir, sizeof dir, ".");
    csi_status st = csi_scene_parse(buf, path, dir, out);
    free(buf);
    return st;
}

void csi_scene_free(csi_scene *sc)
{
    if (!sc)
        return;
    for (size_t i = 0; i < sc->n_objects; i++)
        object_free(&sc->objects[i]);
    for (size_t i = 0; i < sc->n_textures; i++)
        free(sc->textures[i].rgb);
    free(sc->objects);
    free(sc->textures);
    free(sc->materials);
    free(sc->lights);
    free(sc->camera.motion.keys);
    for (size_t i = 0; i < sc->n_inputs; i++)
        free(sc->inputs[i]);
    free(sc->inputs);
    free(sc);
}

void csi_scene_image_size(const csi_scene *sc, uint32_t *w, uint32_t *h)
{
    *w = sc->camera.width;
    *h = sc->camera.height;
}

size_t csi_scene_object_count(const csi_scene *sc) { return sc->n_objects; }

void csi_scene_object_point(const csi_scene *sc, size_t index, double s, const double p[3],
                            double out[3])
{
    tr_xform x;
    tr_motion_eval(sc, &sc->objects[index].motion, s, &x);
    tr_xform_point(&x, p, out);
}
