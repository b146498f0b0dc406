/* vwi_file.c — the one safe-write helper (internal/vwi_file.h). */
#define _XOPEN_SOURCE 700 /* realpath */

#include "vwi_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* A new file beside TARGET, created with O_EXCL so that it is ours alone, named .NAME.HEX.tmp
 * (hidden). open() rather than mkstemp(): mkstemp makes mode 0600, and the file should get
 * what fopen would have given it, the umask's default. */
static int open_temp(const char *target, char **out_name)
{
    const char *slash = strrchr(target, '/');
    int dir_len = slash ? (int)(slash - target + 1) : 0;
    size_t size = strlen(target) + 32;
    char *name = malloc(size);
    if (!name)
        return -1;
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    uint64_t x = (uint64_t)ts.tv_nsec ^ (uint64_t)ts.tv_sec << 30 ^ (uint64_t)getpid() << 40 ^ (uintptr_t)name;
    for (int attempt = 0; attempt < 100; ++attempt) {
        x = x * 6364136223846793005u + 1442695040888963407u;
        /* The name's first 64 bytes: a long name plus the suffix must stay a valid name. */
        snprintf(name, size, "%.*s.%.64s.%08x.tmp", dir_len, target, target + dir_len, (unsigned)(x >> 32));
        int fd = open(name, O_WRONLY | O_CREAT | O_EXCL, 0666);
        if (fd >= 0) {
            *out_name = name;
            return fd;
        }
        if (errno != EEXIST)
            break;
    }
    int e = errno;
    free(name);
    errno = e;
    return -1;
}

static int open_failed(vwi_file *o, int e)
{
    free(o->tmp);
    free(o->target);
    o->tmp = o->target = NULL;
    return e ? e : EIO;
}

int vwi_file_open(vwi_file *o, const char *path)
{
    memset(o, 0, sizeof *o);
    o->path = path;
    o->target = realpath(path, NULL); /* NULL for a new file: then the name as given */
    if (!o->target && !(o->target = strdup(path)))
        return open_failed(o, ENOMEM);
    struct stat st;
    int exists = stat(o->target, &st) == 0;
    if (exists && !S_ISREG(st.st_mode)) {
        /* A device or a FIFO can be neither replaced nor removed: write to it (a directory
         * fails here, with EISDIR). */
        o->f = fopen(o->target, "wb");
        return o->f ? 0 : open_failed(o, errno);
    }
    int fd = open_temp(o->target, &o->tmp);
    if (fd < 0)
        return open_failed(o, errno);
    if (exists)
        (void)fchmod(fd, st.st_mode & 07777); /* the replaced file's permissions, as fopen keeps them */
    o->f = fdopen(fd, "wb");
    if (!o->f) {
        int e = errno;
        close(fd);
        unlink(o->tmp);
        return open_failed(o, e);
    }
    return 0;
}

const char *vwi_file_name(const vwi_file *o)
{
    return o->tmp ? o->tmp : o->target;
}

void vwi_file_failed(vwi_file *o)
{
    if (!o->error)
        o->error = errno ? errno : EIO;
}

int vwi_file_write(vwi_file *o, const void *data, size_t size)
{
    if (o->error)
        return -1;
    if (size && fwrite(data, 1, size, o->f) != size) {
        vwi_file_failed(o);
        return -1;
    }
    return 0;
}

int vwi_file_vprintf(vwi_file *o, const char *fmt, va_list ap)
{
    if (o->error)
        return -1;
    if (vfprintf(o->f, fmt, ap) < 0) {
        vwi_file_failed(o);
        return -1;
    }
    return 0;
}

int vwi_file_printf(vwi_file *o, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int rc = vwi_file_vprintf(o, fmt, ap);
    va_end(ap);
    return rc;
}

int vwi_file_finish(vwi_file *o, int ok)
{
    int e = o->error;
    if (o->f) {
        /* Buffered bytes meet the disk here: their failure counts as much as fwrite's. */
        errno = 0;
        if (fflush(o->f) != 0 && !e)
            e = errno ? errno : EIO;
        if (ferror(o->f) && !e)
            e = EIO;
        if (fclose(o->f) != 0 && !e)
            e = errno ? errno : EIO;
        o->f = NULL;
    }
    int rc = e ? e : ok ? 0 : -1;
    if (rc == 0 && o->tmp && rename(o->tmp, o->target) != 0)
        rc = errno ? errno : EIO;
    if (rc != 0 && o->tmp)
        unlink(o->tmp);
    free(o->tmp);
    free(o->target);
    o->tmp = o->target = NULL;
    return rc;
}
