/* The outputs of one run, all or nothing (csi/csi.h: csi_outset). */
#define _GNU_SOURCE /* renameat2 */
#include "csi/status.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <limits.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#include "csi/outfile.h"

enum { E_FILE, E_DIR, E_DIRFILE };

typedef struct {
    int kind;
    char *path;    /* as stated ("dir/name" for a folder's file) */
    char *canon;   /* the destination with its directory resolved */
    const char *what;
    bool exists;   /* the destination existed when stated */
    dev_t dev;
    ino_t ino;
    int dir;       /* E_DIRFILE: index of its folder */
    char *tmp;     /* temporary path (NULL until csi_outset_tmp) */
    char *backup;  /* commit: a hard link to the replaced destination */
    bool renamed;  /* commit: in place */
} entry;

typedef struct {
    char *path;
    dev_t dev;
    ino_t ino;
} input;

struct csi_outset {
    volatile sig_atomic_t busy; /* the arrays are being changed: a signal handler keeps off */
    entry *e;
    size_t n, cap;
    input *in;
    size_t nin, capin;
};

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *d = malloc(n);
    if (d)
        memcpy(d, s, n);
    return d;
}

csi_status csi_outset_create(csi_outset **out)
{
    *out = calloc(1, sizeof **out);
    return *out ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of memory for the outputs");
}

void csi_outset_free(csi_outset *s)
{
    if (!s)
        return;
    csi_outset_abort(s);
    for (size_t i = 0; i < s->nin; i++)
        free(s->in[i].path);
    free(s->in);
    free(s->e);
    free(s);
}

static const char *kind_of(mode_t m)
{
    return S_ISDIR(m) ? "a directory" : S_ISREG(m) ? "a regular file" : S_ISFIFO(m) ? "a FIFO"
         : S_ISCHR(m) ? "a character device" : S_ISBLK(m) ? "a block device" : S_ISSOCK(m) ? "a socket"
         : "not a regular file";
}

/* dir part of path ("." when none; "/" for "/x"), into buf. */
static void dir_of(const char *path, char *buf, size_t len)
{
    snprintf(buf, len, "%s", path);
    char *slash = strrchr(buf, '/');
    if (!slash)
        snprintf(buf, len, ".");
    else if (slash == buf)
        buf[1] = '\0';
    else
        *slash = '\0';
}

static const char *base_of(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash ? slash + 1 : path;
}

/* The canonical form of a destination: realpath of its directory + "/" + its name. */
static csi_status canon_of(const char *path, const char *what, bool need_writable, char **out)
{
    char dir[PATH_MAX], real[PATH_MAX];
    dir_of(path, dir, sizeof dir);
    struct stat sb;
    if (stat(dir, &sb) != 0 || !S_ISDIR(sb.st_mode))
        return csi_fail(CSI_ERR_IO, "%s: cannot write %s: directory %s does not exist", path, what, dir);
    if (need_writable && access(dir, W_OK) != 0)
        return csi_fail(CSI_ERR_IO, "%s: cannot write %s: directory %s is not writable", path, what, dir);
    if (!realpath(dir, real))
        return csi_fail(CSI_ERR_IO, "%s: cannot write %s: %s", path, what, strerror(errno));
    const char *name = base_of(path);
    size_t n = strlen(real) + strlen(name) + 2;
    *out = malloc(n);
    if (!*out)
        return csi_fail(CSI_ERR_NOMEM, "out of memory");
    snprintf(*out, n, "%s%s%s", real, strcmp(real, "/") ? "/" : "", name);
    return CSI_OK;
}

/* Room for one more element in a growing array of `cap` elements holding n. */
static csi_status room(void **a, size_t *cap, size_t n, size_t size)
{
    if (n < *cap)
        return CSI_OK;
    size_t c = *cap ? 2 * *cap : 16;
    void *na = realloc(*a, c * size);
    if (!na)
        return csi_fail(CSI_ERR_NOMEM, "out of memory for the outputs");
    *a = na;
    *cap = c;
    return CSI_OK;
}

csi_status csi_outset_input(csi_outset *s, const char *path)
{
    struct stat sb;
    if (!path || stat(path, &sb) != 0)
        return CSI_OK; /* a missing input is its reader's error */
    /* an input stated after the outputs is checked against them as theirs were against it */
    for (size_t i = 0; i < s->n; i++)
        if (s->e[i].exists && s->e[i].dev == sb.st_dev && s->e[i].ino == sb.st_ino)
            return csi_fail(CSI_ERR_ARG, "%s: %s would overwrite the input %s (the same file)", s->e[i].path,
                            s->e[i].what, path);
    s->busy = 1;
    csi_status rs = room((void **)&s->in, &s->capin, s->nin, sizeof *s->in);
    s->busy = 0;
    CSI_TRY(rs);
    input *in = &s->in[s->nin];
    in->path = dup_str(path);
    if (!in->path)
        return csi_fail(CSI_ERR_NOMEM, "out of memory");
    in->dev = sb.st_dev;
    in->ino = sb.st_ino;
    s->nin++;
    return CSI_OK;
}

/* Checks a new entry against the inputs and the outputs already stated, then appends it. */
static csi_status add(csi_outset *s, entry *e)
{
    for (size_t i = 0; i < s->nin && e->exists; i++)
        if (s->in[i].dev == e->dev && s->in[i].ino == e->ino)
            return csi_fail(CSI_ERR_ARG, "%s: %s would overwrite the input %s (the same file)", e->path, e->what,
                            s->in[i].path);
    for (size_t i = 0; i < s->n; i++) {
        const entry *o = &s->e[i];
        if (!strcmp(o->canon, e->canon) || (o->exists && e->exists && o->dev == e->dev && o->ino == e->ino))
            return csi_fail(CSI_ERR_ARG, "%s: %s and %s are the same file (%s)", e->path, e->what, o->what, o->path);
    }
    s->busy = 1;
    csi_status rs = room((void **)&s->e, &s->cap, s->n, sizeof *s->e);
    if (rs == CSI_OK)
        s->e[s->n++] = *e;
    s->busy = 0;
    CSI_TRY(rs);
    return CSI_OK;
}

static void entry_release(entry *e)
{
    free(e->path);
    free(e->canon);
    free(e->tmp);
    free(e->backup);
    memset(e, 0, sizeof *e);
}

/* A destination file: exists (regular) or not; fills exists/dev/ino. */
static csi_status dest_state(entry *e)
{
    struct stat sb;
    if (lstat(e->path, &sb) != 0) {
        if (errno != ENOENT)
            return csi_fail(CSI_ERR_IO, "%s: cannot write %s: %s", e->path, e->what, strerror(errno));
        return CSI_OK;
    }
    if (S_ISLNK(sb.st_mode) && stat(e->path, &sb) != 0)
        return CSI_OK; /* a dangling link: rename replaces the link itself */
    if (!S_ISREG(sb.st_mode))
        return csi_fail(CSI_ERR_IO, "%s: cannot write %s: it is %s (outputs replace regular files only)", e->path,
                        e->what, kind_of(sb.st_mode));
    e->exists = true;
    e->dev = sb.st_dev;
    e->ino = sb.st_ino;
    return CSI_OK;
}

static csi_status add_file(csi_outset *s, int kind, int dir, const char *path, const char *canon_in,
                           const char *what)
{
    entry e = {.kind = kind, .what = what, .dir = dir};
    size_t len = path ? strlen(path) : 0;
    if (len == 0)
        return csi_fail(CSI_ERR_ARG, "%s: no file name given", what);
    const char *name = base_of(path);
    if (path[len - 1] == '/' || !strcmp(name, ".") || !strcmp(name, ".."))
        return csi_fail(CSI_ERR_IO, "%s: cannot write %s: the name is a directory", path, what);
    e.path = dup_str(path);
    csi_status st = e.path ? CSI_OK : csi_fail(CSI_ERR_NOMEM, "out of memory");
    if (st == CSI_OK) {
        if (canon_in) {
            e.canon = dup_str(canon_in);
            if (!e.canon)
                st = csi_fail(CSI_ERR_NOMEM, "out of memory");
        } else {
            st = canon_of(path, what, true, &e.canon);
        }
    }
    if (st == CSI_OK)
        st = dest_state(&e);
    if (st == CSI_OK)
        st = add(s, &e);
    if (st != CSI_OK)
        entry_release(&e);
    return st;
}

csi_status csi_outset_file(csi_outset *s, const char *path, const char *what)
{
    return add_file(s, E_FILE, -1, path, NULL, what);
}

csi_status csi_outset_dir(csi_outset *s, const char *dir, const char *what)
{
    entry e = {.kind = E_DIR, .what = what, .dir = -1};
    size_t len = dir ? strlen(dir) : 0;
    if (len == 0)
        return csi_fail(CSI_ERR_ARG, "%s: no folder name given", what);
    e.path = dup_str(dir);
    if (!e.path)
        return csi_fail(CSI_ERR_NOMEM, "out of memory");
    /* "out/" names the folder out */
    while (len > 1 && e.path[len - 1] == '/')
        e.path[--len] = '\0';
    struct stat sb;
    csi_status st = CSI_OK;
    if (stat(e.path, &sb) == 0) {
        char real[PATH_MAX];
        if (!S_ISDIR(sb.st_mode))
            st = csi_fail(CSI_ERR_IO, "%s: cannot write %s: it is %s, not a directory", e.path, what,
                          kind_of(sb.st_mode));
        else if (access(e.path, W_OK) != 0)
            st = csi_fail(CSI_ERR_IO, "%s: cannot write %s: the directory is not writable", e.path, what);
        else if (!realpath(e.path, real))
            st = csi_fail(CSI_ERR_IO, "%s: cannot write %s: %s", e.path, what, strerror(errno));
        else if (!(e.canon = dup_str(real)))
            st = csi_fail(CSI_ERR_NOMEM, "out of memory");
        e.exists = true;
        e.dev = sb.st_dev;
        e.ino = sb.st_ino;
    } else {
        st = canon_of(e.path, what, true, &e.canon);
    }
    if (st == CSI_OK)
        st = add(s, &e);
    if (st != CSI_OK)
        entry_release(&e);
    return st;
}

static int find(const csi_outset *s, const char *path, int kind)
{
    for (size_t i = 0; i < s->n; i++)
        if (s->e[i].kind == kind && !strcmp(s->e[i].path, path))
            return (int)i;
    return -1;
}

/* "dir/name" with dir as a folder entry stores it (trailing slashes removed). */
static csi_status join(const char *dir, const char *name, char *buf, size_t len)
{
    if ((size_t)snprintf(buf, len, "%s/%s", dir, name) >= len)
        return csi_fail(CSI_ERR_ARG, "%s/%s: path too long", dir, name);
    return CSI_OK;
}

static int find_dir(const csi_outset *s, const char *dir)
{
    char d[PATH_MAX];
    snprintf(d, sizeof d, "%s", dir);
    size_t len = strlen(d);
    while (len > 1 && d[len - 1] == '/')
        d[--len] = '\0';
    return find(s, d, E_DIR);
}

csi_status csi_outset_dir_file(csi_outset *s, const char *dir, const char *name, const char *what)
{
    int di = find_dir(s, dir);
    if (di < 0)
        return csi_fail(CSI_ERR_ARG, "%s: not a stated output folder", dir);
    if (strchr(name, '/'))
        return csi_fail(CSI_ERR_ARG, "%s: a folder's file name has no '/'", name);
    char path[PATH_MAX], canon[PATH_MAX];
    CSI_TRY(join(s->e[di].path, name, path, sizeof path));
    CSI_TRY(join(s->e[di].canon, name, canon, sizeof canon));
    return add_file(s, E_DIRFILE, di, path, canon, what);
}

/* A folder's file by "dir/name", the folder as stated or with slashes after it ("out//name" from
 * "out/" + "/name"). */
static int find_dir_file(const csi_outset *s, const char *path)
{
    char d[PATH_MAX];
    dir_of(path, d, sizeof d);
    const int di = find_dir(s, d);
    for (size_t i = 0; di >= 0 && i < s->n; i++)
        if (s->e[i].kind == E_DIRFILE && s->e[i].dir == di && !strcmp(base_of(s->e[i].path), base_of(path)))
            return (int)i;
    return -1;
}

/* A unique hidden name beside `path` ("<dir>/.<name>.<tag>XXXXXX"), created as an empty file
 * (mkstemp) or a directory (mkdtemp). */
static csi_status make_temp(const char *path, const char *tag, bool dir, char **out)
{
    char d[PATH_MAX];
    dir_of(path, d, sizeof d);
    size_t n = strlen(d) + strlen(base_of(path)) + strlen(tag) + 16;
    char *t = malloc(n);
    if (!t)
        return csi_fail(CSI_ERR_NOMEM, "out of memory");
    snprintf(t, n, "%s/.%s.%sXXXXXX", d, base_of(path), tag);
    bool ok;
    mode_t mask = umask(0);
    umask(mask);
    if (dir) {
        ok = mkdtemp(t) != NULL;
        if (ok) /* mkdtemp makes 0700; a folder gets what mkdir would give it */
            chmod(t, 0777 & ~mask);
    } else {
        int fd = mkstemp(t);
        ok = fd >= 0;
        if (ok) { /* mkstemp makes 0600; a file gets what fopen would give it, whoever writes it */
            (void)fchmod(fd, 0666 & ~mask);
            close(fd);
        }
    }
    if (!ok) {
        int e = errno;
        free(t);
        return csi_fail(CSI_ERR_IO, "%s: cannot create a file in its directory: %s", path, strerror(e));
    }
    *out = t;
    return CSI_OK;
}

csi_status csi_outset_tmp(csi_outset *s, const char *path, const char **tmp)
{
    *tmp = NULL;
    int i = find(s, path, E_FILE);
    if (i < 0)
        i = find_dir_file(s, path);
    if (i < 0)
        return csi_fail(CSI_ERR_ARG, "%s: not a stated output", path);
    entry *e = &s->e[i];
    csi_status st = CSI_OK;
    sigset_t held; /* the temporary is made and recorded with no signal handler in between */
    csi_outfile_hold_signals(&held);
    if (!e->tmp) {
        if (e->kind == E_DIRFILE && !s->e[e->dir].exists) {
            entry *d = &s->e[e->dir];
            char t[PATH_MAX];
            if (!d->tmp)
                st = make_temp(d->path, "csi-", true, &d->tmp);
            if (st == CSI_OK)
                st = join(d->tmp, base_of(e->path), t, sizeof t);
            if (st == CSI_OK && !(e->tmp = dup_str(t)))
                st = csi_fail(CSI_ERR_NOMEM, "out of memory");
        } else {
            st = make_temp(e->path, "csi-", false, &e->tmp);
        }
    }
    csi_outfile_release_signals(&held);
    *tmp = st == CSI_OK ? e->tmp : NULL;
    return st;
}

/* Whether an entry's temporary is renamed into place by itself (not inside a new folder). */
static bool renamed_alone(const csi_outset *s, const entry *e)
{
    return e->tmp && (e->kind == E_FILE || (e->kind == E_DIRFILE && s->e[e->dir].exists));
}

/* Removes a temporary folder and what the run wrote in it. */
static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    if (d) {
        struct dirent *de;
        while ((de = readdir(d)))
            if (strcmp(de->d_name, ".") && strcmp(de->d_name, ".."))
                unlinkat(dirfd(d), de->d_name, 0);
        closedir(d);
    }
    rmdir(dir);
}

static void clear(csi_outset *s)
{
    for (size_t i = 0; i < s->n; i++)
        entry_release(&s->e[i]);
    s->n = 0;
}

void csi_outset_signal_cleanup(const csi_outset *s)
{
    csi_outfile_signal_cleanup();
    if (!s || s->busy)
        return;
    for (size_t i = 0; i < s->n; i++) {
        const entry *e = &s->e[i];
        if (e->tmp && e->kind != E_DIR && !e->renamed)
            unlink(e->tmp);
        if (e->backup && !e->renamed)
            unlink(e->backup);
    }
    for (size_t i = 0; i < s->n; i++)
        if (s->e[i].kind == E_DIR && s->e[i].tmp)
            rmdir(s->e[i].tmp);
}

void csi_outset_abort(csi_outset *s)
{
    if (!s)
        return;
    for (size_t i = 0; i < s->n; i++) {
        entry *e = &s->e[i];
        if (renamed_alone(s, e))
            unlink(e->tmp);
        if (e->kind == E_DIR && e->tmp)
            remove_tree(e->tmp);
        if (e->backup)
            unlink(e->backup);
    }
    clear(s);
}

/* Undoes the renames done so far (in reverse order). */
static void undo(csi_outset *s)
{
    for (size_t i = s->n; i-- > 0;) {
        entry *e = &s->e[i];
        if (!e->renamed)
            continue;
        if (e->kind == E_DIR) {
            remove_tree(e->path); /* the folder was new: everything in it is the run's */
        } else if (e->backup) {
            rename(e->backup, e->path);
            free(e->backup);
            e->backup = NULL;
        } else {
            unlink(e->path);
        }
        e->renamed = false;
    }
}

static int rename_noreplace(const char *from, const char *to)
{
#ifdef RENAME_NOREPLACE
    if (renameat2(AT_FDCWD, from, AT_FDCWD, to, RENAME_NOREPLACE) == 0)
        return 0;
    if (errno != EINVAL && errno != ENOSYS)
        return -1;
#endif
    return rename(from, to);
}

csi_status csi_outset_commit(csi_outset *s)
{
    csi_status st = CSI_OK;
    /* Backups of what will be replaced (hard links: nothing is copied). Without hard links (some
     * file systems) a replaced file cannot be restored if a later rename fails. */
    for (size_t i = 0; i < s->n && st == CSI_OK; i++) {
        entry *e = &s->e[i];
        if (!renamed_alone(s, e) || !e->exists)
            continue;
        if (make_temp(e->path, "csi-backup-", false, &e->backup) != CSI_OK) {
            st = csi_fail_context(CSI_ERR_IO, "keeping the file it replaces: ");
            break;
        }
        unlink(e->backup);
        if (link(e->path, e->backup) != 0) {
            free(e->backup);
            e->backup = NULL;
        }
    }
    for (size_t i = 0; i < s->n && st == CSI_OK; i++) {
        entry *e = &s->e[i];
        int r = 0, err = 0;
        if (renamed_alone(s, e)) {
            if (csi_output_fault())
                r = -1, err = EIO;
            else if ((r = rename(e->tmp, e->path)) != 0)
                err = errno;
        } else if (e->kind == E_DIR && e->tmp) {
            if (csi_output_fault())
                r = -1, err = EIO;
            else if ((r = rename_noreplace(e->tmp, e->path)) != 0)
                err = errno;
        } else {
            continue;
        }
        if (r != 0) {
            st = csi_fail(CSI_ERR_IO, "%s: cannot put %s in place: %s", e->path, e->what, strerror(err));
            break;
        }
        e->renamed = true;
        if (e->kind == E_DIR) {
            free(e->tmp);
            e->tmp = NULL;
        }
    }
    if (st != CSI_OK) {
        undo(s);
        csi_outset_abort(s);
        return st;
    }
    for (size_t i = 0; i < s->n; i++) {
        entry *e = &s->e[i];
        if (e->backup)
            unlink(e->backup);
        if (renamed_alone(s, e)) {
            free(e->tmp);
            e->tmp = NULL; /* in place: nothing to remove */
        }
    }
    clear(s);
    return CSI_OK;
}
