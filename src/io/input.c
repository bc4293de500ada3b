/* input.c — opening input files safely: only regular files are read (a FIFO would block the
 * open or the read forever, a device such as /dev/zero or /dev/urandom never ends, a directory
 * is not data), and the open itself never blocks (O_NONBLOCK until the type is known). Every
 * reader in src/io opens its file through here, or checks a path it hands to another library
 * (libnetcdf, GDAL, assimp) with sq__input_check first. Both record the file in the context
 * (device, inode) so that no output of the run can replace it (output.c,
 * sq_output_check_inputs). */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/io_internal.h"

static const char *kind_of(mode_t m)
{
    if (S_ISDIR(m)) return "a directory";
    if (S_ISFIFO(m)) return "a FIFO (named pipe)";
    if (S_ISCHR(m)) return "a character device";
    if (S_ISBLK(m)) return "a block device";
    if (S_ISSOCK(m)) return "a socket";
    return "not a regular file";
}

static sq_result not_regular(sq_context *ctx, const char *module, const char *what,
                             const char *path, mode_t m)
{
    return sq__fail(ctx, SQ_ERR_IO, module,
                    "cannot read %s '%s': it is %s; only regular files are read", what, path,
                    kind_of(m));
}

sq_result sq__input_check(sq_context *ctx, const char *module, const char *what, const char *path)
{
    struct stat st;
    if (!path || !*path) return sq__fail(ctx, SQ_ERR_INVALID_ARG, module, "%s path is empty", what);
    if (stat(path, &st) != 0)
        return sq__fail(ctx, SQ_ERR_IO, module, "cannot open %s '%s': %s", what, path,
                        strerror(errno));
    if (!S_ISREG(st.st_mode)) return not_regular(ctx, module, what, path, st.st_mode);
    sq__context_note_input(ctx, path, (uint64_t)st.st_dev, (uint64_t)st.st_ino, what);
    return SQ_OK;
}

sq_result sq__input_guard(sq_context *ctx, const char *module, const char *what, const char *path)
{
    struct stat st;
    if (!path || !*path || stat(path, &st) != 0) return SQ_OK;
    if (!S_ISREG(st.st_mode)) return not_regular(ctx, module, what, path, st.st_mode);
    sq__context_note_input(ctx, path, (uint64_t)st.st_dev, (uint64_t)st.st_ino, what);
    return SQ_OK;
}

sq_result sq__input_open(sq_context *ctx, const char *module, const char *what, const char *path,
                         FILE **out)
{
    *out = NULL;
    if (!path || !*path) return sq__fail(ctx, SQ_ERR_INVALID_ARG, module, "%s path is empty", what);
    int fd = open(path, O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
    if (fd < 0)
        return sq__fail(ctx, SQ_ERR_IO, module, "cannot open %s '%s': %s", what, path,
                        strerror(errno));
    struct stat st;
    if (fstat(fd, &st) != 0) {
        int e = errno;
        close(fd);
        return sq__fail(ctx, SQ_ERR_IO, module, "cannot open %s '%s': %s", what, path,
                        strerror(e));
    }
    if (!S_ISREG(st.st_mode)) {
        close(fd);
        return not_regular(ctx, module, what, path, st.st_mode);
    }
    sq__context_note_input(ctx, path, (uint64_t)st.st_dev, (uint64_t)st.st_ino, what);
    int fl = fcntl(fd, F_GETFL);
    if (fl >= 0) (void)fcntl(fd, F_SETFL, fl & ~O_NONBLOCK);
    FILE *f = fdopen(fd, "rb");
    if (!f) {
        int e = errno;
        close(fd);
        return sq__fail(ctx, SQ_ERR_IO, module, "cannot open %s '%s': %s", what, path,
                        strerror(e));
    }
    *out = f;
    return SQ_OK;
}
