/* output.c — safe outputs (ARCHITECTURE.md "Files and data safety"): every output is written to
 * a temporary "dir/.name.tmp-PID-N" in the directory of its final name and renamed when it is
 * complete, so an interrupted run never leaves a truncated file under the final name. The final
 * name is checked before any expensive work (sq_output_check); an existing file is replaced only
 * with overwrite, and without it the rename itself refuses to replace (RENAME_NOREPLACE, or
 * link + unlink where the filesystem lacks it), so a file that appears meanwhile is kept too. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/io_internal.h"

/* The longest part of the final base name kept in the temporary name, so that the temporary
 * stays under NAME_MAX (255) even for long final names. */
#define SQ__TEMP_BASE_MAX 200

/* Splits path into its directory ("." when there is none) and base name. */
static void split_path(const char *path, char *dir, size_t dir_size, const char **base)
{
    const char *slash = strrchr(path, '/');
    if (!slash) {
        snprintf(dir, dir_size, ".");
        *base = path;
    } else if (slash == path) {
        snprintf(dir, dir_size, "/");
        *base = slash + 1;
    } else {
        snprintf(dir, dir_size, "%.*s", (int)(slash - path), path);
        *base = slash + 1;
    }
}

sq_result sq_output_check(const char *path, bool overwrite)
{
    if (!path || !*path) return sq__set_error(SQ_ERR_INVALID_ARG, "output path is empty");
    if (strlen(path) >= SQ__TEMP_NAME_MAX - 64)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "output path '%.80s...' is %zu characters; at most %d", path,
                             strlen(path), SQ__TEMP_NAME_MAX - 65);
    char dir[SQ__TEMP_NAME_MAX];
    const char *base = NULL;
    split_path(path, dir, sizeof dir, &base);
    if (!*base)
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': the path names a directory, not a file",
                             path);
    struct stat st;
    if (stat(dir, &st) != 0) {
        if (errno == ENOENT || errno == ENOTDIR)
            return sq__set_error(SQ_ERR_IO, "cannot write '%s': directory '%s' does not exist",
                                 path, dir);
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': directory '%s': %s", path, dir,
                             strerror(errno));
    }
    if (!S_ISDIR(st.st_mode))
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': '%s' is not a directory", path, dir);
    if (access(dir, W_OK | X_OK) != 0)
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': directory '%s' is not writable (%s)",
                             path, dir, strerror(errno));
    if (lstat(path, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            return sq__set_error(SQ_ERR_IO, "cannot write '%s': it is a directory", path);
        if (!overwrite)
            return sq__set_error(SQ_ERR_EXISTS, "'%s' exists; pass --overwrite to replace it",
                                 path);
    } else if (errno != ENOENT) {
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    }
    return SQ_OK;
}

sq_result sq_output_temp_name(const char *path, char *buf, size_t size)
{
    if (!buf || size == 0)
        return sq__set_error(SQ_ERR_INVALID_ARG, "temporary name buffer is empty");
    buf[0] = 0;
    if (!path || !*path) return sq__set_error(SQ_ERR_INVALID_ARG, "output path is empty");
    char dir[SQ__TEMP_NAME_MAX];
    const char *base = NULL;
    split_path(path, dir, sizeof dir, &base);
    int n;
    if (base == path) /* no directory part: keep the temporary relative as well */
        n = snprintf(buf, size, ".%.*s.tmp-%ld", SQ__TEMP_BASE_MAX, base, (long)getpid());
    else
        n = snprintf(buf, size, "%.*s.%.*s.tmp-%ld", (int)(base - path), path, SQ__TEMP_BASE_MAX,
                     base, (long)getpid());
    if (n < 0 || (size_t)n >= size) {
        buf[0] = 0;
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "temporary name for '%.80s' needs %d bytes; the buffer has %zu", path,
                             n + 1, size);
    }
    return SQ_OK;
}

sq_result sq__output_open_temp(const char *path, bool overwrite, char *tmp, size_t size,
                               int *fd_out)
{
    *fd_out = -1;
    if (tmp && size) tmp[0] = 0;
    sq_result r = sq_output_check(path, overwrite);
    if (r != SQ_OK) return r;
    char prefix[SQ__TEMP_NAME_MAX];
    r = sq_output_temp_name(path, prefix, sizeof prefix);
    if (r != SQ_OK) return r;
    for (unsigned n = 0; n < 10000; n++) {
        int len = snprintf(tmp, size, "%s-%u", prefix, n);
        if (len < 0 || (size_t)len >= size)
            return sq__set_error(SQ_ERR_INVALID_ARG, "temporary name for '%.80s' is too long",
                                 path);
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        if (fd >= 0) {
            *fd_out = fd;
            return SQ_OK;
        }
        if (errno != EEXIST) {
            int e = errno;
            sq__set_error(SQ_ERR_IO, "cannot create '%s' (temporary for '%s'): %s", tmp, path,
                          strerror(e));
            tmp[0] = 0;
            return SQ_ERR_IO;
        }
    }
    tmp[0] = 0;
    return sq__set_error(SQ_ERR_IO, "cannot create a temporary for '%s': 10000 names are taken",
                         path);
}

/* Best effort: makes a rename durable by syncing the directory that holds path. */
static void sync_directory_of(const char *path)
{
    char dir[SQ__TEMP_NAME_MAX];
    const char *base = NULL;
    split_path(path, dir, sizeof dir, &base);
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd >= 0) {
        (void)fsync(fd);
        close(fd);
    }
}

static sq_result exists_error(const char *path)
{
    return sq__set_error(SQ_ERR_EXISTS, "'%s' exists; pass --overwrite to replace it", path);
}

/* Renames tmp to path without ever replacing an existing path. */
static sq_result rename_noreplace(const char *tmp, const char *path)
{
#if defined(RENAME_NOREPLACE)
    if (renameat2(AT_FDCWD, tmp, AT_FDCWD, path, RENAME_NOREPLACE) == 0) return SQ_OK;
    if (errno == EEXIST) return exists_error(path);
    if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
        return sq__set_error(SQ_ERR_IO, "cannot rename '%s' to '%s': %s", tmp, path,
                             strerror(errno));
#endif
    /* A hard link fails atomically when path exists. */
    if (link(tmp, path) == 0) {
        (void)unlink(tmp);
        return SQ_OK;
    }
    if (errno == EEXIST) return exists_error(path);
    /* Filesystems without hard links: check, then rename (a small window remains). */
    struct stat st;
    if (lstat(path, &st) == 0) return exists_error(path);
    if (rename(tmp, path) != 0)
        return sq__set_error(SQ_ERR_IO, "cannot rename '%s' to '%s': %s", tmp, path,
                             strerror(errno));
    return SQ_OK;
}

sq_result sq_output_commit(const char *tmp, const char *path, bool overwrite)
{
    if (!tmp || !*tmp || !path || !*path)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "output commit needs a temporary and a final name");
    /* Data first, then the name: after a crash the final name holds the whole file or nothing. */
    int fd = open(tmp, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return sq__set_error(SQ_ERR_IO, "cannot finish '%s': temporary '%s': %s", path, tmp,
                             strerror(errno));
    if (fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {
        int e = errno;
        close(fd);
        return sq__set_error(SQ_ERR_IO, "cannot finish '%s': flushing '%s' failed: %s", path, tmp,
                             strerror(e));
    }
    close(fd);
    sq_result r = SQ_OK;
    if (overwrite) {
        struct stat st;
        if (lstat(path, &st) == 0 && S_ISDIR(st.st_mode))
            return sq__set_error(SQ_ERR_IO, "cannot write '%s': it is a directory", path);
        if (rename(tmp, path) != 0)
            r = sq__set_error(SQ_ERR_IO, "cannot rename '%s' to '%s': %s", tmp, path,
                              strerror(errno));
    } else {
        r = rename_noreplace(tmp, path);
    }
    if (r == SQ_OK) sync_directory_of(path);
    return r;
}

sq_result sq__output_finish(const char *tmp, const char *path, bool overwrite)
{
    sq_result r = sq_output_commit(tmp, path, overwrite);
    if (r != SQ_OK) sq__output_discard(tmp);
    return r;
}

void sq__output_discard(const char *tmp)
{
    if (tmp && *tmp) (void)unlink(tmp);
}

sq_result sq__io_relog(sq_context *ctx, sq_result r)
{
    if (r != SQ_OK && ctx) sq_log(ctx, SQ_LOG_ERROR, "io", "%s", sq_last_error());
    return r;
}

sq_result sq_output_write_file(const char *path, const void *data, size_t size, bool overwrite)
{
    if (size > 0 && !data)
        return sq__set_error(SQ_ERR_INVALID_ARG, "no data for '%s' (%zu bytes)", path ? path : "",
                             size);
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    sq_result r = sq__output_open_temp(path, overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) return r;
    const unsigned char *p = (const unsigned char *)data;
    size_t left = size;
    while (left > 0) {
        ssize_t n = write(fd, p, left);
        if (n < 0) {
            if (errno == EINTR) continue;
            int e = errno;
            close(fd);
            sq__output_discard(tmp);
            return sq__set_error(SQ_ERR_IO, "cannot write '%s': %s", path, strerror(e));
        }
        p += n;
        left -= (size_t)n;
    }
    if (close(fd) != 0) {
        int e = errno;
        sq__output_discard(tmp);
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    return sq__output_finish(tmp, path, overwrite);
}

sq_result sq_output_check_dir(const char *dir, const char *first_file, bool overwrite,
                              bool *created)
{
    *created = false;
    if (!dir || !*dir) return sq__set_error(SQ_ERR_INVALID_ARG, "output directory name is empty");
    struct stat st;
    if (stat(dir, &st) == 0) {
        if (!S_ISDIR(st.st_mode))
            return sq__set_error(SQ_ERR_IO, "frames directory '%s' is not a directory", dir);
    } else {
        char parent[SQ__TEMP_NAME_MAX];
        snprintf(parent, sizeof parent, "%s", dir);
        char *slash = strrchr(parent, '/');
        if (slash && slash != parent) {
            *slash = 0;
            if (stat(parent, &st) != 0 || !S_ISDIR(st.st_mode))
                return sq__set_error(SQ_ERR_IO,
                                     "cannot write frames to '%s': directory '%s' does not exist",
                                     dir, parent);
        }
        if (mkdir(dir, 0777) != 0)
            return sq__set_error(SQ_ERR_IO, "cannot create frames directory '%s': %s", dir,
                                 strerror(errno));
        *created = true;
    }
    if (!first_file) return SQ_OK;
    char first[SQ__TEMP_NAME_MAX];
    snprintf(first, sizeof first, "%s/%s", dir, first_file);
    return sq_output_check(first, overwrite);
}
