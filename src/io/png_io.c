/* png_io.c — PNG through libpng: RGBA8 and 16-bit grey writers (safe outputs, output.c), an
 * RGBA8 reader for any PNG and the 16-bit greyscale heightmap reader (SPEC S2 ch. 3: "a pixel
 * value is the elevation"). Readers treat the file as untrusted: the signature, colour type, bit
 * depth and size are checked before anything is allocated, libpng errors come back through
 * setjmp as SQ_ERR_PARSE naming the file and keeping libpng's text, and the memory a file asks
 * for is refused through the context's budget before allocation. */
#include <errno.h>
#include <limits.h>
#include <png.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "io/io_internal.h"

/* Largest side a writer accepts (libpng's default user limit). */
#define SQ__PNG_MAX_SIDE 1000000
/* Default pixel limit of the heightmap reader when max_pixels <= 0 (16384 x 16384). */
#define SQ__HEIGHTMAP_DEFAULT_MAX_PIXELS (1 << 28)

typedef struct png_err {
    sq_context *ctx;
    const char *path;
    char msg[256];
} png_err;

static void on_png_error(png_structp png, png_const_charp msg)
{
    png_err *e = (png_err *)png_get_error_ptr(png);
    snprintf(e->msg, sizeof e->msg, "%s", msg ? msg : "unknown error");
    png_longjmp(png, 1);
}

static void on_png_warning(png_structp png, png_const_charp msg)
{
    png_err *e = (png_err *)png_get_error_ptr(png);
    if (e->ctx) sq_log(e->ctx, SQ_LOG_DEBUG, "io", "'%s': libpng: %s", e->path, msg);
}

static bool host_is_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

static const char *color_type_name(int color_type)
{
    switch (color_type) {
    case PNG_COLOR_TYPE_GRAY: return "greyscale";
    case PNG_COLOR_TYPE_GRAY_ALPHA: return "greyscale+alpha";
    case PNG_COLOR_TYPE_RGB: return "RGB";
    case PNG_COLOR_TYPE_RGB_ALPHA: return "RGBA";
    case PNG_COLOR_TYPE_PALETTE: return "palette";
    default: return "unknown colour type";
    }
}

/* ---- writers ------------------------------------------------------------------------------- */

/* Writes w x h pixels of bytes_per_pixel bytes each, rows top first, through a temporary. */
static sq_result png_write(const char *path, int width, int height, const void *pixels,
                           int bit_depth, int color_type, int bytes_per_pixel, bool overwrite)
{
    if (!path || !*path) return sq__set_error(SQ_ERR_INVALID_ARG, "PNG output path is empty");
    if (width < 1 || height < 1 || width > SQ__PNG_MAX_SIDE || height > SQ__PNG_MAX_SIDE)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "cannot write '%s': image is %dx%d; each side must be in 1..%d", path,
                             width, height, SQ__PNG_MAX_SIDE);
    if (!pixels) return sq__set_error(SQ_ERR_INVALID_ARG, "cannot write '%s': no pixels", path);

    char tmp[SQ__TEMP_NAME_MAX];
    int fd = -1;
    sq_result r = sq__output_open_temp(path, overwrite, tmp, sizeof tmp, &fd);
    if (r != SQ_OK) return r;
    FILE *fp = fdopen(fd, "wb");
    if (!fp) {
        int e = errno;
        close(fd);
        sq__output_discard(tmp);
        return sq__set_error(SQ_ERR_IO, "cannot write '%s': %s", path, strerror(e));
    }
    png_err err = {.ctx = NULL, .path = path, .msg = ""};
    png_structp png =
        png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_write_struct(png ? &png : NULL, NULL);
        fclose(fp);
        sq__output_discard(tmp);
        return sq__set_error(SQ_ERR_OUT_OF_MEMORY, "cannot write '%s': libpng could not start",
                             path);
    }
    if (setjmp(png_jmpbuf(png))) {
        const int e = errno; /* a failed fwrite (a full disk) left its reason here */
        png_destroy_write_struct(&png, &info);
        fclose(fp);
        sq__output_discard(tmp);
        char detail[300];
        snprintf(detail, sizeof detail, "libpng: %s", err.msg);
        return sq__write_error(NULL, path, e, detail);
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, (png_uint_32)width, (png_uint_32)height, bit_depth, color_type,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    if (bit_depth == 16 && host_is_little_endian()) png_set_swap(png); /* PNG is big-endian */
    const size_t stride = (size_t)width * (size_t)bytes_per_pixel;
    const unsigned char *rows = (const unsigned char *)pixels;
    for (int y = 0; y < height; y++) png_write_row(png, rows + (size_t)y * stride);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    if (ferror(fp) || fclose(fp) != 0) {
        int e = errno;
        sq__output_discard(tmp);
        return sq__write_error(NULL, path, e, NULL);
    }
    return sq__output_finish(tmp, path, overwrite);
}

sq_result sq_png_write_rgba8(const char *path, int width, int height, const uint8_t *rgba,
                             bool overwrite)
{
    return png_write(path, width, height, rgba, 8, PNG_COLOR_TYPE_RGB_ALPHA, 4, overwrite);
}

sq_result sq_png_write_gray16(const char *path, int width, int height, const uint16_t *gray,
                              bool overwrite)
{
    return png_write(path, width, height, gray, 16, PNG_COLOR_TYPE_GRAY, 2, overwrite);
}

/* ---- readers ------------------------------------------------------------------------------- */

typedef enum png_read_mode { READ_RGBA8, READ_HEIGHTMAP16 } png_read_mode;

/* What a file may make libpng allocate besides the image: the ancillary chunks whose length
 * libpng would allocate whole (text, ICC profile, palettes, EXIF, calibration) are skipped
 * unread; they carry nothing the readers use, and a 41-byte file whose tEXt chunk declares
 * 1.3 GB made libpng allocate 1.3 GB (tests/fuzz/regress/heightmap). Other chunks are limited
 * to SQ__PNG_CHUNK_MAX bytes, at most SQ__PNG_CHUNK_CACHE ancillary chunks are kept, and the
 * image sides to SQ__PNG_MAX_SIDE. */
#define SQ__PNG_CHUNK_MAX (1u << 20)
#define SQ__PNG_CHUNK_CACHE 64
static void limit_reader(png_structp png)
{
    static const png_byte skipped[] = "tEXt\0zTXt\0iTXt\0iCCP\0sPLT\0eXIf\0pCAL\0sCAL\0hIST\0";
    png_set_keep_unknown_chunks(png, PNG_HANDLE_CHUNK_NEVER, skipped, 9);
    png_set_user_limits(png, SQ__PNG_MAX_SIDE, SQ__PNG_MAX_SIDE);
    png_set_chunk_cache_max(png, SQ__PNG_CHUNK_CACHE);
    png_set_chunk_malloc_max(png, SQ__PNG_CHUNK_MAX);
}

/* Reads an open PNG stream (closed here); path names it in messages. */
static sq_result png_read_fp(sq_context *ctx, FILE *fp, const char *path, png_read_mode mode,
                             int64_t max_pixels, void **out, int *width_out, int *height_out)
{
    const char *what = mode == READ_HEIGHTMAP16 ? "heightmap" : "image";
    unsigned char sig[8];
    size_t got = fread(sig, 1, sizeof sig, fp);
    if (got < sizeof sig || png_sig_cmp(sig, 0, sizeof sig) != 0) {
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io", "%s '%s' is not a PNG file (%s)", what, path,
                        got < sizeof sig ? "shorter than the 8-byte signature"
                                         : "the PNG signature is missing");
    }

    png_err err = {.ctx = ctx, .path = path, .msg = ""};
    png_structp png =
        png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(png ? &png : NULL, NULL, NULL);
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "cannot read '%s': libpng could not start",
                        path);
    }
    /* Set after setjmp, so volatile: the longjmp path frees them. */
    void *volatile data = NULL;
    png_bytep *volatile rows = NULL;
    if (setjmp(png_jmpbuf(png))) {
        sq_free(ctx, rows);
        sq_free(ctx, data);
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_PARSE, "io", "%s '%s' is corrupt or truncated: libpng: %s",
                        what, path, err.msg);
    }
    png_init_io(png, fp);
    png_set_sig_bytes(png, (int)sizeof sig);
    limit_reader(png);
    png_read_info(png, info);
    png_uint_32 w = 0, h = 0;
    int bit_depth = 0, color_type = 0, interlace = 0;
    png_get_IHDR(png, info, &w, &h, &bit_depth, &color_type, &interlace, NULL, NULL);

    sq_result r = SQ_OK;
    size_t bpp = mode == READ_HEIGHTMAP16 ? 2 : 4;
    if (mode == READ_HEIGHTMAP16 && (bit_depth != 16 || color_type != PNG_COLOR_TYPE_GRAY)) {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "io",
                     "heightmap '%s' is %d-bit %s; a 16-bit greyscale PNG is required", path,
                     bit_depth, color_type_name(color_type));
    } else if ((uint64_t)w * h > (uint64_t)max_pixels || w > INT_MAX || h > INT_MAX) {
        r = sq__fail(ctx, SQ_ERR_TOO_LARGE, "io", "%s '%s' is %ux%u pixels; at most %lld", what,
                     path, (unsigned)w, (unsigned)h, (long long)max_pixels);
    } else {
        char label[96];
        snprintf(label, sizeof label, "%s %ux%u", what, (unsigned)w, (unsigned)h);
        uint64_t bytes = (uint64_t)w * h * bpp + (uint64_t)h * sizeof(png_bytep);
        r = ctx ? sq_context_check_memory(ctx, bytes, label) : SQ_OK; /* NULL: no budget */
        if (r != SQ_OK) {
            char why[512];
            snprintf(why, sizeof why, "%s", sq_last_error());
            r = sq__fail(ctx, r, "io", "cannot read '%s': %s", path, why);
        }
    }
    if (r != SQ_OK) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return r;
    }

    if (mode == READ_HEIGHTMAP16) {
        if (host_is_little_endian()) png_set_swap(png);
    } else {
        png_set_expand(png);   /* palette -> RGB, grey < 8 bit -> 8 bit, tRNS -> alpha */
        png_set_scale_16(png); /* 16 -> 8 bit, rounded */
        png_set_gray_to_rgb(png);
        png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER); /* only where there is no alpha */
    }
    (void)png_set_interlace_handling(png);
    png_read_update_info(png, info);
    const size_t stride = (size_t)w * bpp;
    const size_t rowbytes = png_get_rowbytes(png, info);
    if (rowbytes != stride) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_INTERNAL, "io",
                        "reading '%s': libpng gives rows of %zu bytes; expected %zu", path,
                        rowbytes, stride);
    }
    data = sq_alloc(ctx, stride * h);
    rows = (png_bytep *)sq_alloc(ctx, sizeof(png_bytep) * h);
    if (!data || !rows) {
        sq_free(ctx, rows);
        sq_free(ctx, data);
        png_destroy_read_struct(&png, &info, NULL);
        fclose(fp);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "io", "cannot read '%s': out of memory", path);
    }
    for (png_uint_32 y = 0; y < h; y++) rows[y] = (png_bytep)data + (size_t)y * stride;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    png_destroy_read_struct(&png, &info, NULL);
    fclose(fp);
    sq_free(ctx, rows);
    *out = data;
    *width_out = (int)w;
    *height_out = (int)h;
    return SQ_OK;
}

static sq_result png_read(sq_context *ctx, const char *path, png_read_mode mode, int64_t max_pixels,
                          void **out, int *width_out, int *height_out)
{
    const char *what = mode == READ_HEIGHTMAP16 ? "heightmap" : "image";
    if (out) *out = NULL;
    if (width_out) *width_out = 0;
    if (height_out) *height_out = 0;
    if (!path || !*path) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "%s path is empty", what);
    if (!out || !width_out || !height_out)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "io", "reading '%s' needs output pointers", path);

    FILE *fp = NULL;
    sq_result r0 = sq__input_open(ctx, "io", what, path, &fp); /* no FIFO; never written */
    if (r0 != SQ_OK) return r0;
    return png_read_fp(ctx, fp, path, mode, max_pixels, out, width_out, height_out);
}

sq_result sq__png_decode_rgba8(sq_context *ctx, const void *data, size_t size, const char *name,
                               uint8_t **rgba_out, int *width, int *height)
{
    *rgba_out = NULL;
    *width = *height = 0;
    FILE *fp = size > 0 ? fmemopen((void *)(uintptr_t)data, size, "rb") : NULL;
    if (!fp) return sq__fail(ctx, SQ_ERR_PARSE, "io", "%s: empty or unreadable PNG data", name);
    void *p = NULL;
    sq_result r = png_read_fp(ctx, fp, name, READ_RGBA8, (int64_t)SQ__PNG_MAX_SIDE * SQ__PNG_MAX_SIDE,
                              &p, width, height);
    *rgba_out = (uint8_t *)p;
    return r;
}

sq_result sq_png_read_rgba8(sq_context *ctx, const char *path, uint8_t **rgba_out, int *width,
                            int *height)
{
    void *p = NULL;
    sq_result r = png_read(ctx, path, READ_RGBA8, (int64_t)SQ__PNG_MAX_SIDE * SQ__PNG_MAX_SIDE, &p,
                           width, height);
    if (rgba_out) *rgba_out = (uint8_t *)p;
    return r;
}

sq_result sq_png_read_heightmap16(sq_context *ctx, const char *path, int max_pixels, uint16_t **out,
                                  int *width, int *height)
{
    void *p = NULL;
    int64_t limit = max_pixels > 0 ? max_pixels : SQ__HEIGHTMAP_DEFAULT_MAX_PIXELS;
    sq_result r = png_read(ctx, path, READ_HEIGHTMAP16, limit, &p, width, height);
    if (out) *out = (uint16_t *)p;
    return r;
}
