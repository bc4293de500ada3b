/* checkpoint.c — checkpoint files (issue 17 part 4): the complete state of a scene, written
 * atomically (temporary + rename, output.c), to resume a long run bit-identically.
 *
 * Layout (host byte order, recorded by the marker):
 *   "SQUALLCK"                 8 bytes
 *   u32 format (1), u32 0x01020304 byte-order marker
 *   u64 n, header text         "key: value" lines: squall version, build id (compiler, flags,
 *                              features: sq_config.h SQ_BUILD_ID), scene name and source, the
 *                              directory its relative paths resolve against, frame (the next
 *                              frame to make), time_s (hex float: exact), and one
 *                              "input:" line per input file (what, size, mtime, path)
 *   u64 n, configuration       the scene as YAML (sq_cfg_to_yaml), overrides included
 *   records                    sq_scene_save_state: the clock and every layer's state
 *   "SQEND\0\0\0", u64 FNV-1a 64 of every byte before it
 * Reading verifies the checksum over the whole file before anything else, then the format,
 * marker and build; restoring then checks the scene (same layers, every record's tag and size)
 * and that no input file changed since (size and modification time). */
#include <errno.h>
#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/io_internal.h"
#include "squall/scene.h"

#define MAGIC "SQUALLCK"
#define TRAILER "SQEND\0\0\0"
#define FORMAT 1u
#define MARKER 0x01020304u
#define MAX_HEADER (1u << 20)
#define MAX_YAML (16u << 20)

/* ---- writing ---------------------------------------------------------------------------------- */
typedef struct file_sink {
    FILE *fp;
    int err;
} file_sink;

static sq_result sink_write(void *user, const void *data, size_t n)
{
    file_sink *s = (file_sink *)user;
    if (n && fwrite(data, 1, n, s->fp) != n) {
        s->err = errno ? errno : EIO;
        return SQ_ERR_IO;
    }
    return SQ_OK;
}

static void header_add(char *h, size_t size, const char *fmt, ...) SQ_PRINTF(3, 4);
static void header_add(char *h, size_t size, const char *fmt, ...)
{
    size_t len = strlen(h);
    if (len + 1 >= size) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(h + len, size - len, fmt, ap);
    va_end(ap);
}

sq_result sq_checkpoint_write(sq_context *ctx, const char *path, bool overwrite,
                              const sq_scene *scene, const sq_cfg *cfg, int frame)
{
    if (!path || !*path || !scene || !cfg)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "checkpoint: path, scene and cfg are required");
    char *yaml = sq_cfg_to_yaml(cfg);
    if (!yaml) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "checkpoint '%s': %s", path,
                               sq_last_error());
    char *header = (char *)calloc(1, MAX_HEADER);
    if (!header) {
        free(yaml);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "out of memory writing '%s'", path);
    }
    header_add(header, MAX_HEADER, "squall: %s\nbuild: %s\nfeatures: %s\n", SQ_VERSION_STRING,
               SQ_BUILD_ID, SQ_FEATURES_STRING);
    header_add(header, MAX_HEADER, "scene: %s\nsource: %s\nbase_dir: %s\n", sq_scene_name(scene),
               cfg->source, cfg->base_dir);
    header_add(header, MAX_HEADER, "frame: %d\ntime_s: %a\n", frame, sq_scene_time(scene));
    for (int i = 0; i < sq_context_input_count(ctx); i++) {
        const char *ip = sq_context_input_path(ctx, i);
        struct stat st;
        if (stat(ip, &st) != 0) continue;
        header_add(header, MAX_HEADER, "input: %s\t%lld\t%lld.%09ld\t%s\n",
                   sq_context_input_what(ctx, i), (long long)st.st_size, (long long)st.st_mtim.tv_sec,
                   (long)st.st_mtim.tv_nsec, ip);
    }
    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    sq_result r = sq_output_check_inputs(ctx, path, false);
    if (r == SQ_OK) r = sq__output_open_temp(path, overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) {
        free(yaml);
        free(header);
        return sq__io_relog(ctx, r);
    }
    file_sink sink = {fdopen(fd, "wb"), 0};
    if (!sink.fp) {
        int e = errno;
        close(fd);
        sq__output_discard(tmp);
        free(yaml);
        free(header);
        return sq__write_error(ctx, path, e, NULL);
    }
    sq_state_writer w;
    sq__state_writer_init(&w, ctx, sink_write, &sink);
    const uint32_t fmt = FORMAT, marker = MARKER;
    const uint64_t hl = strlen(header), yl = strlen(yaml);
    sq__state_write_raw(&w, MAGIC, 8);
    sq__state_write_raw(&w, &fmt, sizeof fmt);
    sq__state_write_raw(&w, &marker, sizeof marker);
    sq__state_write_raw(&w, &hl, sizeof hl);
    sq__state_write_raw(&w, header, hl);
    sq__state_write_raw(&w, &yl, sizeof yl);
    sq__state_write_raw(&w, yaml, yl);
    free(yaml);
    free(header);
    r = w.status == SQ_OK ? sq_scene_save_state(scene, &w) : w.status;
    if (r == SQ_OK) {
        sq__state_write_raw(&w, TRAILER, 8);
        const uint64_t sum = w.hash;
        if (w.status == SQ_OK && fwrite(&sum, sizeof sum, 1, sink.fp) != 1) sink.err = errno ? errno : EIO;
        r = w.status;
    }
    if (fflush(sink.fp) != 0 && !sink.err) sink.err = errno ? errno : EIO;
    if (fclose(sink.fp) != 0 && !sink.err) sink.err = errno ? errno : EIO;
    if (sink.err) {
        sq__output_discard(tmp);
        return sq__write_error(ctx, path, sink.err, NULL);
    }
    if (r != SQ_OK) {
        sq__output_discard(tmp);
        return r;
    }
    r = sq__io_relog(ctx, sq__output_finish(tmp, path, overwrite));
    if (r == SQ_OK) sq_log(ctx, SQ_LOG_INFO, "io", "checkpoint '%s' (frame %d)", path, frame);
    return r;
}

/* ---- reading ---------------------------------------------------------------------------------- */
typedef struct file_source {
    FILE *fp;
    const char *path;
    sq_context *ctx;
    uint64_t left; /* bytes before the trailer */
} file_source;

static sq_result source_read(void *user, void *data, size_t n)
{
    file_source *s = (file_source *)user;
    if ((uint64_t)n > s->left || (n && fread(data, 1, n, s->fp) != n))
        return sq__fail(s->ctx, SQ_ERR_PARSE, "io",
                        "checkpoint '%s' ends early: %zu more bytes expected; the file is "
                        "truncated or damaged",
                        s->path, n);
    s->left -= n;
    return SQ_OK;
}

/* Opens path, verifies size and checksum, and leaves the stream after the magic, format and
 * marker checks; *fp positioned at the header length. */
static sq_result open_verified(sq_context *ctx, const char *path, FILE **fp_out, uint64_t *body)
{
    *fp_out = NULL;
    FILE *fp = NULL;
    sq_result r = sq__input_open(ctx, "io", "checkpoint", path, &fp);
    if (r != SQ_OK) return r;
    struct stat st;
    const uint64_t min = 8 + 4 + 4 + 8 + 8 + 8 + 8;
    if (fstat(fileno(fp), &st) != 0 || (uint64_t)st.st_size < min) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io",
                        "checkpoint '%s' is %lld bytes: too short to be a checkpoint", path,
                        (long long)st.st_size);
    }
    const uint64_t size = (uint64_t)st.st_size;
    char magic[8];
    if (fread(magic, 1, 8, fp) != 8 || memcmp(magic, MAGIC, 8) != 0) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io", "'%s' is not a squall checkpoint (no SQUALLCK "
                        "signature)", path);
    }
    uint64_t h = sq__fnv1a(0xcbf29ce484222325ull, magic, 8);
    unsigned char buf[1 << 16];
    uint64_t left = size - 8 - 8;
    while (left > 0) {
        size_t n = left < sizeof buf ? (size_t)left : sizeof buf;
        if (fread(buf, 1, n, fp) != n) break;
        h = sq__fnv1a(h, buf, n);
        left -= n;
    }
    uint64_t sum = 0;
    if (left != 0 || fread(&sum, sizeof sum, 1, fp) != 1 || sum != h) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io",
                        "checkpoint '%s' is damaged or truncated: its checksum does not match "
                        "its contents",
                        path);
    }
    if (fseek(fp, 8, SEEK_SET) != 0) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_IO, "io", "cannot read checkpoint '%s': %s", path,
                        strerror(errno));
    }
    uint32_t fmt = 0, marker = 0;
    if (fread(&fmt, sizeof fmt, 1, fp) != 1 || fread(&marker, sizeof marker, 1, fp) != 1) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io", "checkpoint '%s' is truncated", path);
    }
    if (marker != MARKER) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "checkpoint '%s' was written on a machine of the other byte order", path);
    }
    if (fmt != FORMAT) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "checkpoint '%s' has format %u; this squall reads format %u", path, fmt,
                        FORMAT);
    }
    *fp_out = fp;
    *body = size - 8 - 4 - 4 - 8; /* after magic, format, marker; before the checksum */
    return SQ_OK;
}

/* The value of "key: " in the header (up to the end of its line) into buf. */
static bool header_value(const char *h, const char *key, char *buf, size_t size)
{
    const size_t kl = strlen(key);
    for (const char *p = h; p && *p;) {
        if (strncmp(p, key, kl) == 0 && p[kl] == ':' && p[kl + 1] == ' ') {
            const char *v = p + kl + 2, *e = strchr(v, '\n');
            size_t n = e ? (size_t)(e - v) : strlen(v);
            if (n >= size) n = size - 1;
            memcpy(buf, v, n);
            buf[n] = 0;
            return true;
        }
        p = strchr(p, '\n');
        if (p) p++;
    }
    buf[0] = 0;
    return false;
}

/* Reads header and configuration of a verified file; the stream stays at the records. */
static sq_result read_front(sq_context *ctx, const char *path, FILE *fp, uint64_t body,
                            sq_state_reader *rd, file_source *src, char **header_out,
                            char **yaml_out)
{
    *header_out = *yaml_out = NULL;
    src->fp = fp;
    src->path = path;
    src->ctx = ctx;
    src->left = body;
    sq__state_reader_init(rd, ctx, path, source_read, src);
    uint64_t hl = 0, yl = 0;
    if (sq__state_read_raw(rd, &hl, sizeof hl) != SQ_OK) return rd->status;
    if (hl == 0 || hl > MAX_HEADER || hl > src->left)
        return sq__fail(ctx, SQ_ERR_PARSE, "io", "checkpoint '%s': header of %llu bytes", path,
                        (unsigned long long)hl);
    char *h = (char *)malloc((size_t)hl + 1);
    if (!h) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "out of memory reading '%s'", path);
    if (sq__state_read_raw(rd, h, (size_t)hl) != SQ_OK) {
        free(h);
        return rd->status;
    }
    h[hl] = 0;
    if (sq__state_read_raw(rd, &yl, sizeof yl) != SQ_OK || yl == 0 || yl > MAX_YAML ||
        yl > src->left) {
        free(h);
        return rd->status != SQ_OK ? rd->status
                                   : sq__fail(ctx, SQ_ERR_PARSE, "io",
                                              "checkpoint '%s': configuration of %llu bytes",
                                              path, (unsigned long long)yl);
    }
    char *y = (char *)malloc((size_t)yl + 1);
    if (!y) {
        free(h);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "out of memory reading '%s'", path);
    }
    if (sq__state_read_raw(rd, y, (size_t)yl) != SQ_OK) {
        free(h);
        free(y);
        return rd->status;
    }
    y[yl] = 0;
    *header_out = h;
    *yaml_out = y;
    return SQ_OK;
}

static sq_result parse_info(sq_context *ctx, const char *path, const char *h,
                            sq_checkpoint_info *info)
{
    memset(info, 0, sizeof *info);
    info->format = (int)FORMAT;
    char v[512];
    header_value(h, "squall", info->squall, sizeof info->squall);
    header_value(h, "build", info->build, sizeof info->build);
    header_value(h, "scene", info->scene, sizeof info->scene);
    header_value(h, "source", info->source, sizeof info->source);
    header_value(h, "base_dir", info->base_dir, sizeof info->base_dir);
    char *end = NULL;
    if (!header_value(h, "frame", v, sizeof v)) goto bad;
    long f = strtol(v, &end, 10);
    if (end == v || *end || f < 0 || f > 100000000) goto bad;
    info->frame = (int)f;
    if (!header_value(h, "time_s", v, sizeof v)) goto bad;
    info->time_s = strtod(v, &end);
    if (end == v || *end || !(info->time_s >= 0.0) || info->time_s > 1e300) goto bad;
    if (strcmp(info->build, SQ_BUILD_ID) != 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                        "checkpoint '%s' was written by squall %s build %s; this is squall %s "
                        "build %s (another compiler, flags or features): a checkpoint resumes "
                        "only in the build that wrote it",
                        path, info->squall, info->build, SQ_VERSION_STRING, SQ_BUILD_ID);
    return SQ_OK;
bad:
    return sq__fail(ctx, SQ_ERR_PARSE, "io", "checkpoint '%s': the header lacks a valid frame or "
                    "time", path);
}

sq_result sq_checkpoint_read_header(sq_context *ctx, const char *path, sq_checkpoint_info *info,
                                    sq_cfg **cfg_out)
{
    if (cfg_out) *cfg_out = NULL;
    if (!info) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "checkpoint: info is NULL");
    FILE *fp = NULL;
    uint64_t body = 0;
    sq_result r = open_verified(ctx, path, &fp, &body);
    if (r != SQ_OK) return r;
    sq_state_reader rd;
    file_source src;
    char *h = NULL, *y = NULL;
    r = read_front(ctx, path, fp, body, &rd, &src, &h, &y);
    fclose(fp);
    if (r == SQ_OK) r = parse_info(ctx, path, h, info);
    if (r == SQ_OK && cfg_out) {
        char source[300];
        snprintf(source, sizeof source, "checkpoint %s", path);
        r = sq_cfg_parse(ctx, y, strlen(y), source, cfg_out);
        if (r == SQ_OK) {
            snprintf((*cfg_out)->base_dir, sizeof (*cfg_out)->base_dir, "%s", info->base_dir);
            /* a scene without a name is named after its file: keep the original's */
            if (!sq_cfg_get((*cfg_out)->root, "name") && info->scene[0])
                sq_cfg_node_append((*cfg_out)->root,
                                   sq_cfg_node_new(SQ_CFG_SCALAR, "name", info->scene, 0, 0));
        }
    }
    free(h);
    free(y);
    return r;
}

/* Every "input:" line of the header must still describe its file. */
static sq_result check_inputs(sq_context *ctx, const char *path, const char *h)
{
    for (const char *p = h; p && *p;) {
        if (strncmp(p, "input: ", 7) == 0) {
            char line[2048];
            const char *e = strchr(p, '\n');
            size_t n = e ? (size_t)(e - p - 7) : strlen(p + 7);
            if (n >= sizeof line) n = sizeof line - 1;
            memcpy(line, p + 7, n);
            line[n] = 0;
            char *f[4] = {line, NULL, NULL, NULL};
            for (int k = 1; k < 4; k++) {
                f[k] = f[k - 1] ? strchr(f[k - 1], '\t') : NULL;
                if (f[k]) *f[k]++ = 0;
            }
            if (f[3] && strcmp(f[0], "checkpoint") != 0 && strcmp(f[0], "scene file") != 0) {
                struct stat st;
                char now[64] = "";
                if (stat(f[3], &st) == 0)
                    snprintf(now, sizeof now, "%lld.%09ld", (long long)st.st_mtim.tv_sec,
                             (long)st.st_mtim.tv_nsec);
                if (!now[0] || atoll(f[1]) != (long long)st.st_size || strcmp(now, f[2]) != 0)
                    return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                                    "checkpoint '%s': the %s '%s' %s since the checkpoint was "
                                    "written; a resumed run would not continue the same one",
                                    path, f[0], f[3], now[0] ? "changed" : "is gone");
            }
        }
        p = strchr(p, '\n');
        if (p) p++;
    }
    return SQ_OK;
}

sq_result sq_checkpoint_restore(sq_context *ctx, const char *path, sq_scene *scene,
                                sq_checkpoint_info *info)
{
    if (!scene) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "checkpoint: scene is NULL");
    FILE *fp = NULL;
    uint64_t body = 0;
    sq_result r = open_verified(ctx, path, &fp, &body);
    if (r != SQ_OK) return r;
    sq_state_reader rd;
    file_source src;
    char *h = NULL, *y = NULL;
    sq_checkpoint_info local;
    r = read_front(ctx, path, fp, body, &rd, &src, &h, &y);
    if (r == SQ_OK) r = parse_info(ctx, path, h, info ? info : &local);
    if (r == SQ_OK) r = check_inputs(ctx, path, h);
    if (r == SQ_OK) r = sq_scene_load_state(scene, &rd);
    if (r == SQ_OK) {
        char trailer[8];
        if (sq__state_read_raw(&rd, trailer, 8) != SQ_OK || memcmp(trailer, TRAILER, 8) != 0 ||
            src.left != 0)
            r = rd.status != SQ_OK ? rd.status
                                   : sq__fail(ctx, SQ_ERR_PARSE, "io",
                                              "checkpoint '%s': records beyond the scene's state",
                                              path);
    }
    fclose(fp);
    free(h);
    free(y);
    return r;
}
