/* Write-to-temporary-then-rename output files (see csi/outfile.h). */
#include "csi/outfile.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

/* The temporary file being written now (one writer at a time per program), for
 * csi_outfile_signal_cleanup. */
static char *volatile active_tmp;

void csi_outfile_signal_cleanup(void)
{
    char *t = active_tmp;
    if (t)
        unlink(t);
}

void csi_outfile_hold_signals(sigset_t *old)
{
    sigset_t s;
    sigemptyset(&s);
    sigaddset(&s, SIGINT);
    sigaddset(&s, SIGTERM);
    sigaddset(&s, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &s, old);
}

void csi_outfile_release_signals(const sigset_t *old)
{
    pthread_sigmask(SIG_SETMASK, old, NULL);
}

static void outfile_release(csi_outfile *of)
{
    if (active_tmp == of->tmp)
        active_tmp = NULL;
    free(of->path);
    free(of->tmp);
    of->path = of->tmp = NULL;
    of->fp = NULL;
    of->fd = -1;
}

csi_status csi_outfile_open(csi_outfile *of, const char *path)
{
    memset(of, 0, sizeof *of);
    of->fd = -1;
    if (!path || !*path)
        return csi_fail(CSI_ERR_ARG, "output path is empty");
    size_t len = strlen(path);
    if (path[len - 1] == '/')
        return csi_fail(CSI_ERR_IO, "%s: output path names a directory", path);
    const char *slash = strrchr(path, '/');
    size_t dirlen = slash ? (size_t)(slash - path) + 1 : 0;
    /* "<dir>/.<name>.tmpXXXXXX": a hidden name in the same directory, so rename stays within
     * one file system and is atomic. */
    of->path = malloc(len + 1);
    of->tmp = malloc(len + 16);
    if (!of->path || !of->tmp) {
        outfile_release(of);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory", path);
    }
    memcpy(of->path, path, len + 1);
    memcpy(of->tmp, path, dirlen);
    snprintf(of->tmp + dirlen, len + 16 - dirlen, ".%s.tmpXXXXXX", path + dirlen);
    sigset_t held;
    csi_outfile_hold_signals(&held);
    int fd = mkstemp(of->tmp);
    if (fd >= 0)
        active_tmp = of->tmp;
    csi_outfile_release_signals(&held);
    if (fd < 0) {
        int e = errno;
        outfile_release(of);
        return csi_fail(CSI_ERR_IO, "%s: cannot create a file in its directory: %s", path, strerror(e));
    }
    /* mkstemp makes the file 0600; give it the permissions a plain fopen would (0666 & ~umask). */
    mode_t mask = umask(0);
    umask(mask);
    (void)fchmod(fd, 0666 & ~mask);
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        int e = errno;
        close(fd);
        unlink(of->tmp);
        outfile_release(of);
        return csi_fail(CSI_ERR_IO, "%s: %s", path, strerror(e));
    }
    of->fp = fp;
    of->fd = fd;
    return CSI_OK;
}

bool csi_output_fault(void)
{
    static long events, fail_at = -1;
    if (fail_at < 0) {
        const char *env = getenv("CSI_FAIL_OUTPUT");
        char *end;
        long v = env ? strtol(env, &end, 10) : 0;
        fail_at = env && *env && *end == '\0' && v > 0 ? v : 0;
    }
    return fail_at > 0 && ++events == fail_at;
}

csi_status csi_outfile_commit(csi_outfile *of)
{
    if (!of->fp)
        return csi_fail(CSI_ERR_ARG, "csi_outfile_commit: file is not open");
    int err = 0;
    if (fflush(of->fp) != 0 || ferror(of->fp))
        err = errno ? errno : EIO;
    if (!err && csi_output_fault())
        err = EIO; /* injected (CSI_FAIL_OUTPUT) */
    if (!err && fsync(of->fd) != 0 && errno != EINVAL && errno != EROFS)
        err = errno;
    if (fclose(of->fp) != 0 && !err)
        err = errno ? errno : EIO;
    of->fp = NULL;
    if (!err && rename(of->tmp, of->path) != 0)
        err = errno;
    if (err) {
        unlink(of->tmp);
        csi_status st = csi_fail(CSI_ERR_IO, "%s: write failed: %s", of->path, strerror(err));
        outfile_release(of);
        return st;
    }
    outfile_release(of);
    return CSI_OK;
}

void csi_outfile_abort(csi_outfile *of)
{
    if (of->fp)
        fclose(of->fp);
    if (of->tmp)
        unlink(of->tmp);
    outfile_release(of);
}
