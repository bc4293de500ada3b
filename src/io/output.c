/* output.c — safe outputs (ARCHITECTURE.md "Files and data safety"): every output is written to
 * a temporary "dir/.name.tmp-PID-N" in the directory of its final name and renamed when it is
 * complete, so an interrupted run never leaves a truncated file under the final name. The final
 * name is checked before any expensive work (sq_output_check); an existing file is replaced only
 * with overwrite, and without it the rename itself refuses to replace (RENAME_NOREPLACE, or
 * link + unlink where the filesystem lacks it), so a file that appears meanwhile is kept too. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
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

/* The canonical name of a file that may not exist yet: its directory resolved (symlinks, "..")
 * and its base name; false when the directory does not resolve either. */
static bool canonical_name(const char *path, char *out, size_t size)
{
    char dir[SQ__TEMP_NAME_MAX];
    const char *base = NULL;
    split_path(path, dir, sizeof dir, &base);
    char *real = realpath(dir, NULL);
    if (!real) return false;
    const int n = snprintf(out, size, "%s/%s", strcmp(real, "/") == 0 ? "" : real, base);
    free(real);
    return n > 0 && (size_t)n < size;
}

bool sq_output_same_file(const char *a, const char *b)
{
    if (!a || !b || !*a || !*b) return false;
    struct stat sa, sb;
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
    char ca[SQ__TEMP_NAME_MAX], cb[SQ__TEMP_NAME_MAX];
    if (canonical_name(a, ca, sizeof ca) && canonical_name(b, cb, sizeof cb))
        return strcmp(ca, cb) == 0;
    return strcmp(a, b) == 0;
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
        /* outputs are made under a temporary name and renamed over the path: that would replace
         * a FIFO, device or socket (as root even /dev/null) by a regular file */
        if (!S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode))
            return sq__set_error(SQ_ERR_IO,
                                 "cannot write '%s': it is a %s, not a regular file; outputs are "
                                 "written whole and renamed into place, which would replace it "
                                 "(not even with --overwrite)",
                                 path, S_ISFIFO(st.st_mode)   ? "FIFO"
                                       : S_ISCHR(st.st_mode)  ? "character device"
                                       : S_ISBLK(st.st_mode)  ? "block device"
                                       : S_ISSOCK(st.st_mode) ? "socket"
                                                              : "special file");
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
        if (sq__io_no_space(path, e)) return sq__write_error(NULL, path, e, NULL);
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
            return sq__write_error(NULL, path, e, NULL);
        }
        p += n;
        left -= (size_t)n;
    }
    if (close(fd) != 0) {
        int e = errno;
        sq__output_discard(tmp);
        return sq__write_error(NULL, path, e, NULL);
    }
    return sq__output_finish(tmp, path, overwrite);
}

/* ---- inputs are never written ---------------------------------------------------------------- */
/* Splits a path or prefix into its directory and the name (part) it ends with. */
static void dir_and_name(const char *p, char *dir, size_t size, const char **name)
{
    split_path(p, dir, size, name);
}

/* Whether path reaches input ip through a link: path is a symbolic link, or another name of the
 * file (a hard link); "dem.tif" and "./dem.tif" are the same name. */
static bool through_link(const char *path, const char *ip)
{
    struct stat ls;
    if (lstat(path, &ls) == 0 && S_ISLNK(ls.st_mode)) return true;
    char *a = realpath(path, NULL), *b = realpath(ip, NULL);
    const bool other = !a || !b || strcmp(a, b) != 0;
    free(a);
    free(b);
    return other;
}

static sq_result refuse_input(sq_context *ctx, const char *path, int i)
{
    const char *ip = sq_context_input_path(ctx, i);
    return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                    "output '%s' is the %s '%s'%s: inputs are never written, not even with "
                    "--overwrite; choose another output name",
                    path, sq_context_input_what(ctx, i), ip,
                    through_link(path, ip) ? " (the same file through a link)" : "");
}

static int input_index(const sq_context *ctx, const struct stat *st)
{
    for (int i = 0; i < ctx->input_count; i++)
        if (ctx->inputs[i].dev == (uint64_t)st->st_dev && ctx->inputs[i].ino == (uint64_t)st->st_ino)
            return i;
    return -1;
}

/* A numbered output name: "<anything>DDDDD.<ext>" (5 or more digits before the extension). */
static bool numbered_name(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (!dot || dot == name) return false;
    int digits = 0;
    for (const char *p = dot - 1; p >= name && *p >= '0' && *p <= '9'; p--) digits++;
    return digits >= 5;
}

sq_result sq_output_check_inputs(sq_context *ctx, const char *path, bool prefix)
{
    if (!ctx || ctx->input_count == 0 || !path || !*path) return SQ_OK;
    struct stat st;
    if (!prefix) {
        /* A path that does not exist yet replaces nothing; one that resolves (symlinks followed)
         * to an input's device and inode is that input. */
        if (stat(path, &st) != 0) return SQ_OK;
        const int i = input_index(ctx, &st);
        return i >= 0 ? refuse_input(ctx, path, i) : SQ_OK;
    }
    char dir[SQ__TEMP_NAME_MAX];
    const char *name = NULL;
    dir_and_name(path, dir, sizeof dir, &name);
    const size_t nl = strlen(name);
    DIR *d = opendir(dir);
    if (!d) return SQ_OK;
    sq_result r = SQ_OK;
    struct dirent *e;
    while (r == SQ_OK && (e = readdir(d)) != NULL) {
        if (strncmp(e->d_name, name, nl) != 0 || !numbered_name(e->d_name)) continue;
        char full[SQ__TEMP_NAME_MAX];
        int n = strcmp(dir, ".") == 0 && name == path
                    ? snprintf(full, sizeof full, "%s", e->d_name)
                    : snprintf(full, sizeof full, "%s/%s", dir, e->d_name);
        if (n < 0 || (size_t)n >= sizeof full || stat(full, &st) != 0) continue;
        const int i = input_index(ctx, &st);
        if (i >= 0) r = refuse_input(ctx, full, i);
    }
    closedir(d);
    return r;
}

/* ---- temporaries left by a killed run ---------------------------------------------------------- */
/* The pid of a temporary ".NAME.tmp-PID-N" (0 if the name is not one). */
static long temp_pid(const char *entry, const char *name, size_t nl, bool prefix)
{
    if (entry[0] != '.' || strncmp(entry + 1, name, nl) != 0) return 0;
    const char *t = strstr(entry + 1 + nl, ".tmp-");
    if (!t || (!prefix && t != entry + 1 + nl)) return 0;
    const char *p = t + 5;
    char *end = NULL;
    long pid = strtol(p, &end, 10);
    if (end == p || *end != '-' || pid <= 0) return 0;
    for (const char *q = end + 1; *q; q++)
        if (*q < '0' || *q > '9') return 0;
    return end[1] ? pid : 0;
}

int sq_output_remove_stale(sq_context *ctx, const char *path, bool prefix)
{
    if (!path || !*path) return 0;
    char dir[SQ__TEMP_NAME_MAX];
    const char *name = NULL;
    dir_and_name(path, dir, sizeof dir, &name);
    const size_t nl = strlen(name);
    DIR *d = opendir(dir);
    if (!d) return 0;
    int removed = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        const long pid = temp_pid(e->d_name, name, nl, prefix);
        if (pid == 0 || pid == (long)getpid()) continue;
        /* a live process (perhaps another squall writing the same name) keeps its file */
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH) continue;
        char full[SQ__TEMP_NAME_MAX];
        int n = snprintf(full, sizeof full, "%s/%s", dir, e->d_name);
        if (n < 0 || (size_t)n >= sizeof full) continue;
        if (unlink(full) == 0) {
            removed++;
            sq_log(ctx, SQ_LOG_WARN, "io",
                   "removed '%s': a temporary left by an interrupted run (process %ld is gone)",
                   full, pid);
        }
    }
    closedir(d);
    return removed;
}

/* ---- write errors ------------------------------------------------------------------------------ */
bool sq__io_no_space(const char *path, int err)
{
    if (err == ENOSPC || err == EDQUOT) return true;
    /* libraries that lose errno (HDF5 under libnetcdf): a filesystem without free blocks */
    char dir[SQ__TEMP_NAME_MAX];
    const char *base = NULL;
    split_path(path ? path : ".", dir, sizeof dir, &base);
    struct statvfs vfs;
    return statvfs(dir, &vfs) == 0 && (uint64_t)vfs.f_bavail * (uint64_t)vfs.f_frsize < 65536;
}

sq_result sq__write_error(sq_context *ctx, const char *path, int err, const char *detail)
{
    if (sq__io_no_space(path, err))
        return sq__fail(ctx, SQ_ERR_NO_SPACE, "io",
                        "cannot write '%s': no space left on device (free some space, or write "
                        "elsewhere)",
                        path);
    if (detail && *detail)
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", path, detail);
    return sq__fail(ctx, SQ_ERR_IO, "io", "cannot write '%s': %s", path,
                    strerror(err ? err : EIO));
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
