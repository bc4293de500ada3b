/* nc3_header.c — a bounds walk over the header of a netCDF-3 file (classic CDF-1, 64-bit offset
 * CDF-2, 64-bit data CDF-5) before libnetcdf opens it.
 *
 * libnetcdf trusts the header's counts: a name, attribute or list length of a few gigabytes in a
 * damaged or hostile file is allocated as declared before the read fails. This walk reads the
 * header as the format specification defines it (NetCDF Users Guide, "File Format
 * Specifications") and refuses a file whose header declares more bytes than the file holds, so
 * every count libnetcdf allocates from is bounded by the file's size. Files that are not netCDF-3
 * (HDF5-based netCDF-4, anything else) are left to libnetcdf. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "io/nc3_header.h"

enum { NC3_DIMENSION = 10, NC3_VARIABLE = 11, NC3_ATTRIBUTE = 12 };

typedef struct nc3_cursor {
    FILE *f;
    uint64_t pos, size; /* bytes read so far; the file's size */
    int version;        /* 1, 2 or 5 */
    const char *what;   /* the header item being read, for the message */
    bool short_read;
} nc3_cursor;

static bool read_be(nc3_cursor *c, int bytes, uint64_t *out)
{
    unsigned char b[8];
    if (c->size - c->pos < (uint64_t)bytes || fread(b, 1, (size_t)bytes, c->f) != (size_t)bytes) {
        c->short_read = true;
        return false;
    }
    uint64_t v = 0;
    for (int i = 0; i < bytes; i++) v = v << 8 | b[i];
    c->pos += (uint64_t)bytes;
    *out = v;
    return true;
}

/* Skips n bytes rounded up to a multiple of 4; false when the file ends first. */
static bool skip_padded(nc3_cursor *c, uint64_t n)
{
    const uint64_t padded = n + (4 - n % 4) % 4;
    if (n > c->size || padded > c->size - c->pos) {
        c->short_read = true;
        return false;
    }
    if (fseeko(c->f, (off_t)padded, SEEK_CUR) != 0) {
        c->short_read = true;
        return false;
    }
    c->pos += padded;
    return true;
}

/* A count (nelems): 4 bytes, 8 in CDF-5. Each element takes at least min_bytes of header, so a
 * count the remaining header cannot hold is refused here, before anything trusts it. */
static bool read_count(nc3_cursor *c, uint64_t min_bytes, uint64_t *n)
{
    if (!read_be(c, c->version == 5 ? 8 : 4, n)) return false;
    if (c->version != 5 && *n > INT32_MAX) return false;
    if (min_bytes > 0 && *n > (c->size - c->pos) / min_bytes) {
        c->short_read = true;
        return false;
    }
    return true;
}

static bool read_name(nc3_cursor *c)
{
    uint64_t len = 0;
    return read_count(c, 1, &len) && skip_padded(c, len);
}

static int type_size(uint64_t type, int version)
{
    switch (type) {
    case 1: case 2: return 1; /* byte, char */
    case 3: return 2;         /* short */
    case 4: case 5: return 4; /* int, float */
    case 6: return 8;         /* double */
    default: break;
    }
    if (version != 5) return 0;
    switch (type) {
    case 7: return 1;           /* ubyte */
    case 8: return 2;           /* ushort */
    case 9: return 4;           /* uint */
    case 10: case 11: return 8; /* int64, uint64 */
    default: return 0;
    }
}

/* A list header: ABSENT (two zeros) or tag + count; *n = 0 when absent. */
static bool read_list(nc3_cursor *c, uint64_t tag, uint64_t min_bytes, uint64_t *n)
{
    uint64_t t = 0;
    if (!read_be(c, 4, &t) || !read_count(c, min_bytes, n)) return false;
    if (t == 0 && *n == 0) return true;
    return t == tag;
}

static bool read_attributes(nc3_cursor *c)
{
    uint64_t n = 0;
    c->what = "attribute list";
    if (!read_list(c, NC3_ATTRIBUTE, 12, &n)) return false;
    for (uint64_t a = 0; a < n; a++) {
        c->what = "attribute";
        uint64_t type = 0, count = 0;
        if (!read_name(c) || !read_be(c, 4, &type)) return false;
        const int ts = type_size(type, c->version);
        if (ts == 0 || !read_count(c, (uint64_t)ts, &count)) return false;
        if (!skip_padded(c, count * (uint64_t)ts)) return false;
    }
    return true;
}

static bool walk(nc3_cursor *c)
{
    uint64_t v = 0, n = 0;
    c->what = "number of records";
    if (!read_be(c, c->version == 5 ? 8 : 4, &v)) return false; /* numrecs: data, not header */
    c->what = "dimension list";
    if (!read_list(c, NC3_DIMENSION, 8, &n)) return false;
    for (uint64_t d = 0; d < n; d++) {
        c->what = "dimension";
        if (!read_name(c) || !read_be(c, c->version == 5 ? 8 : 4, &v)) return false;
    }
    if (!read_attributes(c)) return false;
    c->what = "variable list";
    if (!read_list(c, NC3_VARIABLE, 24, &n)) return false;
    const int idsize = c->version == 5 ? 8 : 4;
    for (uint64_t k = 0; k < n; k++) {
        c->what = "variable";
        uint64_t ndims = 0, type = 0;
        if (!read_name(c) || !read_count(c, (uint64_t)idsize, &ndims)) return false;
        if (!skip_padded(c, ndims * (uint64_t)idsize)) return false;
        if (!read_attributes(c)) return false;
        c->what = "variable";
        if (!read_be(c, 4, &type) || type_size(type, c->version) == 0) return false;
        if (!read_be(c, c->version == 5 ? 8 : 4, &v)) return false;   /* vsize */
        if (!read_be(c, c->version == 1 ? 4 : 8, &v)) return false;   /* begin */
    }
    return true;
}

sq_result sq__nc3_check_header(sq_context *ctx, const char *module, const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return sq__fail(ctx, SQ_ERR_IO, module, "%s: cannot open: %s", path, strerror(errno));
    struct stat st;
    unsigned char magic[4];
    if (fstat(fileno(f), &st) != 0 || fread(magic, 1, 4, f) != 4 || memcmp(magic, "CDF", 3) != 0 ||
        (magic[3] != 1 && magic[3] != 2 && magic[3] != 5)) {
        fclose(f); /* not netCDF-3: libnetcdf decides what it is */
        return SQ_OK;
    }
    nc3_cursor c = {f, 4, (uint64_t)st.st_size, magic[3], "header", false};
    const bool ok = walk(&c);
    fclose(f);
    if (ok) return SQ_OK;
    if (c.short_read)
        return sq__fail(ctx, SQ_ERR_PARSE, module,
                        "%s: truncated or corrupt netCDF-3 file: its header declares a %s that "
                        "does not fit in the file's %llu bytes (at byte %llu)",
                        path, c.what, (unsigned long long)c.size, (unsigned long long)c.pos);
    return sq__fail(ctx, SQ_ERR_PARSE, module,
                    "%s: corrupt netCDF-3 file: invalid %s in the header (at byte %llu)", path,
                    c.what, (unsigned long long)c.pos);
}
