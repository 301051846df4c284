/* Regular input files, opened without blocking (see csi/infile.h). */
#include "csi/infile.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <stdbool.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char *kind_of(mode_t m)
{
    if (S_ISDIR(m))
        return "a directory";
    if (S_ISFIFO(m))
        return "a FIFO (named pipe)";
    if (S_ISCHR(m))
        return "a character device";
    if (S_ISBLK(m))
        return "a block device";
    if (S_ISSOCK(m))
        return "a socket";
    return "not a regular file";
}

/* Opens without blocking and checks; on success *fd_out is a blocking descriptor. */
static csi_status open_checked(const char *path, const char *what, uint64_t max_bytes, int *fd_out,
                               uint64_t *size)
{
    if (!path || !*path)
        return csi_fail(CSI_ERR_ARG, "no %s file name given", what);
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0) {
        int e = errno;
        struct stat sb;
        /* open() of a directory for reading succeeds on Linux; EISDIR and friends are still
         * worded by what the path is when stat can tell. */
        if (stat(path, &sb) == 0 && !S_ISREG(sb.st_mode))
            return csi_fail(CSI_ERR_IO, "%s: cannot open %s: %s", path, what, kind_of(sb.st_mode));
        return csi_fail(CSI_ERR_IO, "%s: cannot open %s: %s", path, what, strerror(e));
    }
    struct stat sb;
    if (fstat(fd, &sb) != 0) {
        int e = errno;
        close(fd);
        return csi_fail(CSI_ERR_IO, "%s: cannot open %s: %s", path, what, strerror(e));
    }
    if (!S_ISREG(sb.st_mode)) {
        close(fd);
        return csi_fail(CSI_ERR_IO, "%s: cannot open %s: %s", path, what, kind_of(sb.st_mode));
    }
    const uint64_t bytes = (uint64_t)sb.st_size;
    if (max_bytes && bytes > max_bytes) {
        close(fd);
        return csi_fail(CSI_ERR_TOO_LARGE, "%s: the %s is %" PRIu64 " bytes, more than the limit of %" PRIu64
                        " bytes", path, what, bytes, max_bytes);
    }
    int fl = fcntl(fd, F_GETFL);
    if (fl >= 0)
        fcntl(fd, F_SETFL, fl & ~O_NONBLOCK);
    if (size)
        *size = bytes;
    *fd_out = fd;
    return CSI_OK;
}

csi_status csi_infile_open(const char *path, const char *what, uint64_t max_bytes, FILE **fp, uint64_t *size)
{
    *fp = NULL;
    int fd;
    CSI_TRY(open_checked(path, what, max_bytes, &fd, size));
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return csi_fail(CSI_ERR_IO, "%s: cannot open %s: %s", path, what, strerror(e));
    }
    *fp = f;
    return CSI_OK;
}

csi_status csi_infile_check(const char *path, const char *what, uint64_t max_bytes, uint64_t *size)
{
    int fd;
    CSI_TRY(open_checked(path, what, max_bytes, &fd, size));
    close(fd);
    return CSI_OK;
}

csi_status csi_infile_read_all(const char *path, const char *what, uint64_t max_bytes, char **text, size_t *len)
{
    *text = NULL;
    if (len)
        *len = 0;
    FILE *f;
    uint64_t size;
    CSI_TRY(csi_infile_open(path, what, max_bytes, &f, &size));
    /* The size stat reported, and no more: a file that grows while it is read is cut there. */
    char *buf = malloc((size_t)size + 1);
    if (!buf) {
        fclose(f);
        return csi_fail(CSI_ERR_NOMEM, "%s: out of memory for a %s of %" PRIu64 " bytes", path, what, size);
    }
    size_t n = fread(buf, 1, (size_t)size, f);
    bool err = ferror(f);
    fclose(f);
    if (err || n != size) {
        free(buf);
        return csi_fail(CSI_ERR_IO, "%s: cannot read %s (%zu of %" PRIu64 " bytes read)", path, what, n, size);
    }
    buf[n] = '\0';
    *text = buf;
    if (len)
        *len = n;
    return CSI_OK;
}
