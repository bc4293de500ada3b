/* test_io.c — file outputs and readers (src/io/): safe outputs (temporary + rename, never
 * replacing without overwrite, refusing a missing directory before writing anything), PNG
 * round trips, the 16-bit heightmap reader's refusals, MP4 written and decoded back, NetCDF read
 * back through libnetcdf, VTK image data parsed back. Each case works in its own fresh directory
 * under /tmp (or $TMPDIR) and removes it. */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <png.h>
#include <stdint.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sq_config.h"
#include "sq_test.h"
#include "squall/io.h"

#if SQ_HAVE_NETCDF
#include <netcdf.h>
#endif

SQ_LABEL(unit)

/* ---- helpers ------------------------------------------------------------------------------- */

static char g_dir[512];

static const char *make_dir(void)
{
    const char *base = getenv("TMPDIR");
    if (!base || !*base) base = "/tmp";
    snprintf(g_dir, sizeof g_dir, "%s/sq_io_XXXXXX", base);
    if (!mkdtemp(g_dir)) {
        SQ_FAIL_AT("mkdtemp(%s): %s", g_dir, strerror(errno));
        return "/nonexistent";
    }
    return g_dir;
}

static const char *in_dir(char *buf, size_t size, const char *name)
{
    snprintf(buf, size, "%s/%s", g_dir, name);
    return buf;
}

/* Number of entries in the test directory (all of them; "." and ".." excluded). */
static int dir_entries(int *temps)
{
    DIR *d = opendir(g_dir);
    int n = 0;
    if (temps) *temps = 0;
    if (!d) return -1;
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        n++;
        if (temps && strstr(e->d_name, ".tmp-")) (*temps)++;
    }
    closedir(d);
    return n;
}

/* Removes the test directory and the plain files in it (one level: the tests make no more). */
static void remove_dir(void)
{
    DIR *d = opendir(g_dir);
    if (!d) return;
    char p[1024];
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", g_dir, e->d_name);
        if (unlink(p) != 0) rmdir(p);
    }
    closedir(d);
    rmdir(g_dir);
}

static bool exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Reads a whole file (malloc'd, NUL-terminated); NULL if it cannot. */
static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *fp = fopen(path, "rb");
    if (!fp) return NULL;
    fseek(fp, 0, SEEK_END);
    long n = ftell(fp);
    fseek(fp, 0, SEEK_SET);
    unsigned char *buf = (unsigned char *)malloc((size_t)n + 1);
    size_t got = buf ? fread(buf, 1, (size_t)n, fp) : 0;
    fclose(fp);
    if (!buf || got != (size_t)n) {
        free(buf);
        return NULL;
    }
    buf[n] = 0;
    if (size) *size = (size_t)n;
    return buf;
}

static void spit(const char *path, const void *data, size_t size)
{
    FILE *fp = fopen(path, "wb");
    SQ_CHECK(fp != NULL);
    if (!fp) return;
    SQ_CHECK(fwrite(data, 1, size, fp) == size);
    fclose(fp);
}

/* A file with known content and an mtime in the past, to prove it is left untouched. */
static void make_old_file(const char *path, const char *content)
{
    spit(path, content, strlen(content));
    struct timespec t[2] = {{1000000000, 0}, {1000000000, 0}};
    SQ_CHECK(utimensat(AT_FDCWD, path, t, 0) == 0);
}

static void check_old_file(const char *path, const char *content)
{
    size_t n = 0;
    unsigned char *b = slurp(path, &n);
    SQ_CHECK(b != NULL);
    SQ_CHECK(n == strlen(content) && b && memcmp(b, content, n) == 0);
    free(b);
    struct stat st;
    SQ_CHECK(stat(path, &st) == 0);
    SQ_CHECK(st.st_mtim.tv_sec == 1000000000);
}

/* Writes a PNG of any colour type and depth through libpng directly (the library only writes
 * RGBA8 and grey16). Pixel bytes are big-endian for 16-bit, as in the file. */
static void write_png_any(const char *path, int w, int h, int depth, int color_type, int channels,
                          int interlace)
{
    FILE *fp = fopen(path, "wb");
    SQ_CHECK(fp != NULL);
    if (!fp) return;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        SQ_FAIL_AT("libpng failed writing %s", path);
        png_destroy_write_struct(&png, &info);
        fclose(fp);
        return;
    }
    png_init_io(png, fp);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, depth, color_type, interlace,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    size_t stride = (size_t)w * (size_t)channels * (size_t)(depth / 8);
    unsigned char *img = (unsigned char *)calloc(stride * (size_t)h, 1);
    png_bytep *rows = (png_bytep *)calloc((size_t)h, sizeof(png_bytep));
    for (int y = 0; y < h; y++) {
        rows[y] = img + (size_t)y * stride;
        for (size_t i = 0; i < stride; i++) rows[y][i] = (unsigned char)(i * 7 + (size_t)y * 13);
    }
    png_write_image(png, rows); /* all passes when interlaced */
    free(rows);
    free(img);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(fp);
}

static void write_png_raw(const char *path, int w, int h, int depth, int color_type, int channels)
{
    write_png_any(path, w, h, depth, color_type, channels, PNG_INTERLACE_NONE);
}

static uint32_t crc32_of(const unsigned char *p, size_t n)
{
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; i++) {
        c ^= p[i];
        for (int k = 0; k < 8; k++) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
}

static size_t put_chunk(unsigned char *out, const char *type, const unsigned char *data,
                        uint32_t len)
{
    out[0] = (unsigned char)(len >> 24);
    out[1] = (unsigned char)(len >> 16);
    out[2] = (unsigned char)(len >> 8);
    out[3] = (unsigned char)len;
    memcpy(out + 4, type, 4);
    if (len) memcpy(out + 8, data, len);
    uint32_t c = crc32_of(out + 4, 4 + (size_t)len);
    out[8 + len] = (unsigned char)(c >> 24);
    out[9 + len] = (unsigned char)(c >> 16);
    out[10 + len] = (unsigned char)(c >> 8);
    out[11 + len] = (unsigned char)c;
    return 12 + (size_t)len;
}

/* A valid-looking PNG whose header claims w x h 16-bit grey, with a token IDAT: a reader that
 * trusted the header would allocate w*h*2 bytes. */
static void write_png_header_only(const char *path, uint32_t w, uint32_t h)
{
    unsigned char buf[256];
    static const unsigned char sig[8] = {137, 80, 78, 71, 13, 10, 26, 10};
    size_t n = 0;
    memcpy(buf, sig, 8);
    n = 8;
    unsigned char ihdr[13] = {(unsigned char)(w >> 24),
                              (unsigned char)(w >> 16),
                              (unsigned char)(w >> 8),
                              (unsigned char)w,
                              (unsigned char)(h >> 24),
                              (unsigned char)(h >> 16),
                              (unsigned char)(h >> 8),
                              (unsigned char)h,
                              16,
                              0,
                              0,
                              0,
                              0};
    n += put_chunk(buf + n, "IHDR", ihdr, 13);
    const unsigned char idat[2] = {0x78, 0x9c};
    n += put_chunk(buf + n, "IDAT", idat, 2);
    n += put_chunk(buf + n, "IEND", NULL, 0);
    spit(path, buf, n);
}

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.threads = 2};
    SQ_CHECK_OK(sq_context_create(&d, &ctx));
    return ctx;
}

/* ---- safe outputs -------------------------------------------------------------------------- */

SQ_TEST(output_check_rules)
{
    make_dir();
    char p[1024], msg[2048];
    snprintf(p, sizeof p, "%s/out/x.mp4", g_dir);
    snprintf(msg, sizeof msg, "cannot write '%s': directory '%s/out' does not exist", p, g_dir);
    SQ_CHECK_ERR(sq_output_check(p, false), SQ_ERR_IO, msg);
    SQ_CHECK_ERR(sq_output_check(p, true), SQ_ERR_IO, msg);
    SQ_CHECK_ERR(sq_output_check("", false), SQ_ERR_INVALID_ARG, "empty");

    in_dir(p, sizeof p, "x.mp4");
    SQ_CHECK_OK(sq_output_check(p, false));
    make_old_file(p, "old");
    snprintf(msg, sizeof msg, "'%s' exists; pass --overwrite to replace it", p);
    SQ_CHECK_ERR(sq_output_check(p, false), SQ_ERR_EXISTS, msg);
    SQ_CHECK_OK(sq_output_check(p, true));
    check_old_file(p, "old"); /* a check writes nothing */

    /* A file where the directory should be. */
    snprintf(p, sizeof p, "%s/x.mp4/y.png", g_dir);
    SQ_CHECK_ERR(sq_output_check(p, false), SQ_ERR_IO, "is not a directory");
    /* A directory where the file should be. */
    SQ_CHECK_ERR(sq_output_check(g_dir, true), SQ_ERR_IO, "it is a directory");
    remove_dir();
}

SQ_TEST(output_temp_name_format)
{
    char buf[256], want[256];
    SQ_CHECK_OK(sq_output_temp_name("out/x.mp4", buf, sizeof buf));
    snprintf(want, sizeof want, "out/.x.mp4.tmp-%ld", (long)getpid());
    SQ_CHECK_MSG(!strcmp(buf, want), "got '%s', want '%s'", buf, want);
    SQ_CHECK_OK(sq_output_temp_name("x.mp4", buf, sizeof buf));
    snprintf(want, sizeof want, ".x.mp4.tmp-%ld", (long)getpid());
    SQ_CHECK_MSG(!strcmp(buf, want), "got '%s', want '%s'", buf, want);
    SQ_CHECK_OK(sq_output_temp_name("/x.mp4", buf, sizeof buf));
    snprintf(want, sizeof want, "/.x.mp4.tmp-%ld", (long)getpid());
    SQ_CHECK_MSG(!strcmp(buf, want), "got '%s', want '%s'", buf, want);
    SQ_CHECK_ERR(sq_output_temp_name("out/x.mp4", buf, 8), SQ_ERR_INVALID_ARG, "needs");
    /* A very long final name still gives a temporary under NAME_MAX. */
    char longname[300];
    memset(longname, 'a', 250);
    longname[250] = 0;
    SQ_CHECK_OK(sq_output_temp_name(longname, buf, sizeof buf));
    SQ_CHECK(strlen(buf) + 8 < 255);
}

SQ_TEST(output_write_file_replaces_only_with_overwrite)
{
    make_dir();
    char p[1024];
    in_dir(p, sizeof p, "data.bin");
    SQ_CHECK_OK(sq_output_write_file(p, "hello", 5, false));
    size_t n = 0;
    unsigned char *b = slurp(p, &n);
    SQ_CHECK(b && n == 5 && !memcmp(b, "hello", 5));
    free(b);
    int temps = -1;
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);

    make_old_file(p, "old content");
    SQ_CHECK_ERR(sq_output_write_file(p, "new", 3, false), SQ_ERR_EXISTS, "exists");
    check_old_file(p, "old content");
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0); /* the temporary was removed */

    SQ_CHECK_OK(sq_output_write_file(p, "new", 3, true));
    b = slurp(p, &n);
    SQ_CHECK(b && n == 3 && !memcmp(b, "new", 3));
    free(b);
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);

    /* Missing directory: refused, nothing created anywhere. */
    snprintf(p, sizeof p, "%s/missing/data.bin", g_dir);
    SQ_CHECK_ERR(sq_output_write_file(p, "x", 1, true), SQ_ERR_IO, "does not exist");
    SQ_CHECK(dir_entries(NULL) == 1);
    remove_dir();
}

SQ_TEST(output_commit_never_replaces_without_overwrite)
{
    make_dir();
    char tmp[1024], p[1024];
    in_dir(tmp, sizeof tmp, ".final.txt.tmp-1-0");
    in_dir(p, sizeof p, "final.txt");
    spit(tmp, "fresh", 5);
    /* The final name appears after the check (another process): the commit still refuses. */
    make_old_file(p, "someone else's");
    SQ_CHECK_ERR(sq_output_commit(tmp, p, false), SQ_ERR_EXISTS, "exists");
    check_old_file(p, "someone else's");
    SQ_CHECK(exists(tmp)); /* left for the caller */
    SQ_CHECK_OK(sq_output_commit(tmp, p, true));
    SQ_CHECK(!exists(tmp));
    size_t n = 0;
    unsigned char *b = slurp(p, &n);
    SQ_CHECK(b && n == 5 && !memcmp(b, "fresh", 5));
    free(b);
    SQ_CHECK_ERR(sq_output_commit(tmp, p, true), SQ_ERR_IO, "temporary");
    remove_dir();
}

/* ---- PNG ----------------------------------------------------------------------------------- */

SQ_TEST(png_roundtrip_rgba8)
{
    make_dir();
    sq_context *ctx = make_ctx();
    const int w = 37, h = 23;
    uint8_t *img = (uint8_t *)malloc((size_t)w * h * 4);
    for (int i = 0; i < w * h * 4; i++) img[i] = (uint8_t)(i * 31 + (i >> 7));
    char p[1024];
    in_dir(p, sizeof p, "rgba.png");
    SQ_CHECK_OK(sq_png_write_rgba8(p, w, h, img, false));
    uint8_t *back = NULL;
    int bw = 0, bh = 0;
    SQ_CHECK_OK(sq_png_read_rgba8(ctx, p, &back, &bw, &bh));
    SQ_CHECK(bw == w && bh == h);
    SQ_CHECK(back && memcmp(back, img, (size_t)w * h * 4) == 0);
    sq_free(ctx, back);
    SQ_CHECK_ERR(sq_png_write_rgba8(p, w, h, img, false), SQ_ERR_EXISTS, "exists");
    SQ_CHECK_ERR(sq_png_write_rgba8(p, 0, h, img, true), SQ_ERR_INVALID_ARG, "0x23");

    /* Other formats are converted: 8-bit RGB gets alpha 255, 8-bit grey is replicated. */
    in_dir(p, sizeof p, "rgb8.png");
    write_png_raw(p, 5, 3, 8, PNG_COLOR_TYPE_RGB, 3);
    SQ_CHECK_OK(sq_png_read_rgba8(ctx, p, &back, &bw, &bh));
    SQ_CHECK(bw == 5 && bh == 3);
    if (back) {
        /* row y, byte i of the file row = i*7 + y*13 */
        SQ_CHECK(back[0] == 0 && back[1] == 7 && back[2] == 14 && back[3] == 255);
        SQ_CHECK(back[4 * 5 + 0] == 13 && back[4 * 5 + 3] == 255);
    }
    sq_free(ctx, back);
    in_dir(p, sizeof p, "grey8.png");
    write_png_raw(p, 4, 2, 8, PNG_COLOR_TYPE_GRAY, 1);
    SQ_CHECK_OK(sq_png_read_rgba8(ctx, p, &back, &bw, &bh));
    if (back) SQ_CHECK(back[4] == 7 && back[5] == 7 && back[6] == 7 && back[7] == 255);
    sq_free(ctx, back);
    free(img);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(png_roundtrip_gray16)
{
    make_dir();
    sq_context *ctx = make_ctx();
    const int w = 41, h = 17;
    uint16_t *img = (uint16_t *)malloc(sizeof(uint16_t) * (size_t)w * h);
    for (int i = 0; i < w * h; i++) img[i] = (uint16_t)(i * 977u + 0x0102u);
    img[0] = 0;
    img[1] = 65535;
    img[2] = 0x0102; /* byte order matters */
    char p[1024];
    in_dir(p, sizeof p, "depth.png");
    SQ_CHECK_OK(sq_png_write_gray16(p, w, h, img, false));
    /* The file is big-endian 16-bit grey, per the PNG standard. */
    size_t n = 0;
    unsigned char *raw = slurp(p, &n);
    SQ_CHECK(raw && n > 33 && raw[24] == 16 && raw[25] == 0); /* IHDR bit depth, colour type */
    free(raw);
    uint16_t *back = NULL;
    int bw = 0, bh = 0;
    SQ_CHECK_OK(sq_png_read_heightmap16(ctx, p, 0, &back, &bw, &bh));
    SQ_CHECK(bw == w && bh == h);
    SQ_CHECK(back && memcmp(back, img, sizeof(uint16_t) * (size_t)w * h) == 0);
    sq_free(ctx, back);
    /* Without a context (no memory budget) the reader works the same. */
    back = NULL;
    SQ_CHECK_OK(sq_png_read_heightmap16(NULL, p, 0, &back, &bw, &bh));
    SQ_CHECK(back && memcmp(back, img, sizeof(uint16_t) * (size_t)w * h) == 0);
    sq_free(NULL, back);
    /* An interlaced (Adam7) heightmap: samples are big-endian pairs (i*7 + y*13 per byte). */
    in_dir(p, sizeof p, "adam7.png");
    write_png_any(p, 13, 11, 16, PNG_COLOR_TYPE_GRAY, 1, PNG_INTERLACE_ADAM7);
    back = NULL;
    SQ_CHECK_OK(sq_png_read_heightmap16(ctx, p, 0, &back, &bw, &bh));
    SQ_CHECK(bw == 13 && bh == 11);
    int bad = 0;
    for (int y = 0; back && y < 11; y++)
        for (int x = 0; x < 13; x++) {
            unsigned hi = (unsigned char)(2 * x * 7 + y * 13),
                     lo = (unsigned char)((2 * x + 1) * 7 + y * 13);
            if (back[y * 13 + x] != (uint16_t)(hi << 8 | lo)) bad++;
        }
    SQ_CHECK(back && bad == 0);
    sq_free(ctx, back);
    free(img);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(heightmap_refuses_wrong_formats)
{
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], msg[2048];
    uint16_t *hm = (uint16_t *)1;
    int w = -1, h = -1;
    struct {
        const char *file;
        int depth, type, channels;
        const char *found;
    } cases[] = {
        {"rgb8.png", 8, PNG_COLOR_TYPE_RGB, 3, "8-bit RGB"},
        {"grey8.png", 8, PNG_COLOR_TYPE_GRAY, 1, "8-bit greyscale"},
        {"rgb16.png", 16, PNG_COLOR_TYPE_RGB, 3, "16-bit RGB"},
        {"greya16.png", 16, PNG_COLOR_TYPE_GRAY_ALPHA, 2, "16-bit greyscale+alpha"},
        {"rgba8.png", 8, PNG_COLOR_TYPE_RGB_ALPHA, 4, "8-bit RGBA"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        in_dir(p, sizeof p, cases[i].file);
        write_png_raw(p, 8, 8, cases[i].depth, cases[i].type, cases[i].channels);
        snprintf(msg, sizeof msg, "heightmap '%s' is %s; a 16-bit greyscale PNG is required", p,
                 cases[i].found);
        SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, p, 0, &hm, &w, &h), SQ_ERR_INVALID_ARG, msg);
        SQ_CHECK(hm == NULL && w == 0 && h == 0);
    }
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(heightmap_refuses_too_large)
{
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], msg[2048];
    uint16_t *hm = NULL;
    int w = 0, h = 0;
    /* A header claiming 20000x20000 (800 MB of samples) in a 60-byte file. */
    in_dir(p, sizeof p, "huge.png");
    write_png_header_only(p, 20000, 20000);
    snprintf(msg, sizeof msg, "heightmap '%s' is 20000x20000 pixels; at most 16777216", p);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, p, 4096 * 4096, &hm, &w, &h), SQ_ERR_TOO_LARGE, msg);
    SQ_CHECK(hm == NULL && sq_context_bytes_peak(ctx) == 0); /* refused before allocating */
    /* The default limit (16384^2) refuses it too. */
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, p, 0, &hm, &w, &h), SQ_ERR_TOO_LARGE,
                 "is 20000x20000 pixels; at most 268435456");
    /* A real image one pixel over the limit. */
    uint16_t img[6 * 5] = {0};
    in_dir(p, sizeof p, "small.png");
    SQ_CHECK_OK(sq_png_write_gray16(p, 6, 5, img, false));
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, p, 29, &hm, &w, &h), SQ_ERR_TOO_LARGE,
                 "is 6x5 pixels; at most 29");
    SQ_CHECK_OK(sq_png_read_heightmap16(ctx, p, 30, &hm, &w, &h));
    sq_free(ctx, hm);
    /* The context's memory budget refuses a file the pixel limit allows. */
    sq_context *small = NULL;
    sq_context_desc d = {.threads = 1, .memory_limit_bytes = 1 << 20};
    SQ_CHECK_OK(sq_context_create(&d, &small));
    in_dir(p, sizeof p, "big.png");
    write_png_header_only(p, 2000, 2000);
    snprintf(msg, sizeof msg, "cannot read '%s': heightmap 2000x2000", p);
    SQ_CHECK_ERR(sq_png_read_heightmap16(small, p, 0, &hm, &w, &h), SQ_ERR_TOO_LARGE, msg);
    SQ_CHECK(sq_context_bytes_peak(small) == 0);
    sq_context_destroy(small);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(heightmap_refuses_corrupt_and_missing)
{
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], q[1024], msg[2048];
    uint16_t *hm = NULL;
    int w = 0, h = 0;

    in_dir(p, sizeof p, "missing.png");
    snprintf(msg, sizeof msg, "cannot open heightmap '%s': No such file or directory", p);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, p, 0, &hm, &w, &h), SQ_ERR_IO, msg);

    /* A good file to damage. */
    const int gw = 64, gh = 64;
    uint16_t *img = (uint16_t *)malloc(sizeof(uint16_t) * gw * gh);
    for (int i = 0; i < gw * gh; i++) img[i] = (uint16_t)(i * 2654435761u >> 16);
    in_dir(p, sizeof p, "good.png");
    SQ_CHECK_OK(sq_png_write_gray16(p, gw, gh, img, false));
    free(img);
    size_t n = 0;
    unsigned char *good = slurp(p, &n);
    SQ_CHECK(good && n > 200);
    if (!good) return;

    /* Truncated in the middle of the image data. */
    in_dir(q, sizeof q, "truncated.png");
    spit(q, good, n / 2);
    snprintf(msg, sizeof msg, "heightmap '%s' is corrupt or truncated: libpng: ", q);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, msg);
    SQ_CHECK(hm == NULL);
    /* Missing IEND only (all image data present): still refused as truncated. */
    spit(q, good, n - 12);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, msg);

    /* A flipped byte inside IDAT: the CRC check catches it. */
    in_dir(q, sizeof q, "flipped.png");
    good[n / 2] ^= 0x5a;
    spit(q, good, n);
    snprintf(msg, sizeof msg, "heightmap '%s' is corrupt or truncated", q);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, msg);
    good[n / 2] ^= 0x5a;

    /* Not a PNG at all, and an empty file. */
    in_dir(q, sizeof q, "text.png");
    spit(q, "elevation: 12\n", 14);
    snprintf(msg, sizeof msg, "heightmap '%s' is not a PNG file", q);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, msg);
    in_dir(q, sizeof q, "empty.png");
    spit(q, "", 0);
    snprintf(msg, sizeof msg, "heightmap '%s' is not a PNG file", q);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, msg);

    /* The header's CRC damaged: refused before any size is trusted. */
    in_dir(q, sizeof q, "badihdr.png");
    good[29] ^= 0xff;
    spit(q, good, n);
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, q, 0, &hm, &w, &h), SQ_ERR_PARSE, "IHDR");
    free(good);
    /* A directory. */
    SQ_CHECK_ERR(sq_png_read_heightmap16(ctx, g_dir, 0, &hm, &w, &h), SQ_ERR_IO, "directory");
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0); /* every failure freed what it took */
    sq_context_destroy(ctx);
    remove_dir();
}

/* ---- MP4 ----------------------------------------------------------------------------------- */

static uint8_t clamp8(int v) { return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v); }

static void fill_rgba(uint8_t *img, int w, int h, uint8_t r, uint8_t g, uint8_t b, int frame)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t *px = img + 4 * ((size_t)y * w + x);
            /* A faint moving ripple so the encoder has real motion to code. */
            int d = (((x + y + 2 * frame) & 7) - 4) / 2;
            px[0] = clamp8(r + d);
            px[1] = clamp8(g + d);
            px[2] = clamp8(b + d);
            px[3] = 255;
        }
}

#if SQ_HAVE_MP4
/* Writes frames of one colour; returns the result of close. */
static sq_result write_video(sq_context *ctx, const char *path, int w, int h, int frames, uint8_t r,
                             uint8_t g, uint8_t b)
{
    sq_video_desc d = {.path = path, .width = w, .height = h};
    sq_video_writer *vw = NULL;
    sq_result res = sq_video_open(ctx, &d, &vw);
    if (res != SQ_OK) return res;
    uint8_t *img = (uint8_t *)malloc((size_t)w * h * 4);
    for (int f = 0; f < frames && res == SQ_OK; f++) {
        fill_rgba(img, w, h, r, g, b, f);
        res = sq_video_add_rgba8(vw, img);
    }
    free(img);
    if (res != SQ_OK) {
        sq_video_abort(vw);
        return res;
    }
    return sq_video_close(vw);
}

/* Index of the first top-level MP4 box of type t, or -1. */
static int mp4_box_index(const unsigned char *b, size_t n, const char *t)
{
    size_t pos = 0;
    for (int i = 0; pos + 8 <= n && i < 64; i++) {
        uint64_t size = ((uint64_t)b[pos] << 24) | ((uint64_t)b[pos + 1] << 16) |
                        ((uint64_t)b[pos + 2] << 8) | b[pos + 3];
        if (!memcmp(b + pos + 4, t, 4)) return i;
        if (size == 1 && pos + 16 <= n) {
            size = 0;
            for (int k = 0; k < 8; k++) size = (size << 8) | b[pos + 8 + k];
        }
        if (size < 8) return -1;
        pos += size;
    }
    return -1;
}

#endif

SQ_TEST(video_roundtrip_h264)
{
#if SQ_HAVE_MP4
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    const int w = 64, h = 48, frames = 12;
    /* Expected mean Y (BT.709, limited range 16..235): Y = 16 + 219 * luma(R,G,B)/255. */
    struct {
        const char *file;
        uint8_t r, g, b;
        double y;
    } cases[] = {
        {"bright.mp4", 235, 235, 235, 16.0 + 219.0 * 235.0 / 255.0},
        {"dark.mp4", 20, 20, 20, 16.0 + 219.0 * 20.0 / 255.0},
        /* Pure red separates BT.709 (0.2126 -> 62.6) from BT.601 (0.299 -> 81.5). */
        {"red.mp4", 255, 0, 0, 16.0 + 219.0 * 0.2126},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        in_dir(p, sizeof p, cases[i].file);
        SQ_CHECK_OK(write_video(ctx, p, w, h, frames, cases[i].r, cases[i].g, cases[i].b));
        sq_video_info info;
        SQ_CHECK_OK(sq_video_probe(ctx, p, &info));
        SQ_CHECK(info.frames == frames);
        SQ_CHECK(info.width == w && info.height == h);
        SQ_CHECK_MSG(!strcmp(info.codec, "h264"), "codec = %s", info.codec);
        SQ_CHECK_MSG(!strcmp(info.pix_fmt, "yuv420p"), "pix_fmt = %s", info.pix_fmt);
        SQ_CHECK_NEAR(info.fps, 30.0, 1e-6);
        printf("%s: mean Y %.2f (expected %.2f)\n", cases[i].file, info.mean_luma, cases[i].y);
        SQ_CHECK_NEAR(info.mean_luma, cases[i].y, 3.0);
        /* +faststart: the index (moov) precedes the media data (mdat). */
        size_t n = 0;
        unsigned char *b = slurp(p, &n);
        SQ_CHECK(b != NULL);
        if (b) {
            int moov = mp4_box_index(b, n, "moov"), mdat = mp4_box_index(b, n, "mdat");
            SQ_CHECK_MSG(moov >= 0 && mdat >= 0 && moov < mdat, "moov box %d, mdat box %d", moov,
                         mdat);
        }
        free(b);
    }
    int temps = -1;
    SQ_CHECK(dir_entries(&temps) == 3 && temps == 0);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
#else
    sq_video_writer *vw = NULL;
    sq_video_desc d = {.path = "x.mp4", .width = 64, .height = 48};
    SQ_CHECK_ERR(sq_video_open(NULL, &d, &vw), SQ_ERR_UNSUPPORTED, "without MP4");
#endif
}

SQ_TEST(video_final_name_appears_only_on_close)
{
    if (!sq_has_feature("mp4")) return;
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    in_dir(p, sizeof p, "clip.mp4");
    sq_video_desc d = {.path = p, .width = 32, .height = 32, .fps = 24, .crf = 30};
    sq_video_writer *vw = NULL;
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    uint8_t img[32 * 32 * 4];
    int temps = -1;
    for (int f = 0; f < 5 && vw; f++) {
        fill_rgba(img, 32, 32, 100, 150, 200, f);
        SQ_CHECK_OK(sq_video_add_rgba8(vw, img));
        SQ_CHECK(!exists(p));
        SQ_CHECK(dir_entries(&temps) == 1 && temps == 1); /* only the temporary */
    }
    if (vw) SQ_CHECK_OK(sq_video_close(vw));
    SQ_CHECK(exists(p));
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    sq_video_info info;
    SQ_CHECK_OK(sq_video_probe(ctx, p, &info));
    SQ_CHECK(info.frames == 5);
    SQ_CHECK_NEAR(info.fps, 24.0, 1e-6);

    /* A second writer to the same name: refused at open, the file untouched. */
    make_old_file(p, "previous render");
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_EXISTS, "pass --overwrite to replace it");
    SQ_CHECK(vw == NULL);
    check_old_file(p, "previous render");
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    /* With overwrite it is replaced, but only on close. */
    d.overwrite = true;
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    fill_rgba(img, 32, 32, 10, 10, 10, 0);
    SQ_CHECK_OK(sq_video_add_rgba8(vw, img));
    check_old_file(p, "previous render");
    SQ_CHECK_OK(sq_video_close(vw));
    SQ_CHECK_OK(sq_video_probe(ctx, p, &info));
    SQ_CHECK(info.frames == 1);
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(video_abort_leaves_nothing)
{
    if (!sq_has_feature("mp4")) return;
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024];
    in_dir(p, sizeof p, "aborted.mp4");
    sq_video_desc d = {.path = p, .width = 48, .height = 32};
    sq_video_writer *vw = NULL;
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    uint8_t img[48 * 32 * 4];
    for (int f = 0; f < 3; f++) {
        fill_rgba(img, 48, 32, 200, 30, 30, f);
        SQ_CHECK_OK(sq_video_add_rgba8(vw, img));
    }
    sq_video_abort(vw);
    SQ_CHECK(!exists(p));
    SQ_CHECK(dir_entries(NULL) == 0);
    sq_video_abort(NULL);
    /* Abort without a frame, and close without a frame: nothing is written either. */
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    sq_video_abort(vw);
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    SQ_CHECK_ERR(sq_video_close(vw), SQ_ERR_INVALID_ARG, "has no frames");
    SQ_CHECK(dir_entries(NULL) == 0);
    /* An aborted overwrite leaves the old file as it was. */
    make_old_file(p, "keep me");
    d.overwrite = true;
    SQ_CHECK_OK(sq_video_open(ctx, &d, &vw));
    SQ_CHECK_OK(sq_video_add_rgba8(vw, img));
    sq_video_abort(vw);
    check_old_file(p, "keep me");
    SQ_CHECK(dir_entries(NULL) == 1);
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(video_refuses_bad_requests)
{
    if (!sq_has_feature("mp4")) return;
    make_dir();
    sq_context *ctx = make_ctx();
    char p[1024], msg[2048];
    sq_video_writer *vw = (sq_video_writer *)1;
    snprintf(p, sizeof p, "%s/out/x.mp4", g_dir);
    sq_video_desc d = {.path = p, .width = 64, .height = 48};
    snprintf(msg, sizeof msg, "cannot write '%s': directory '%s/out' does not exist", p, g_dir);
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_IO, msg);
    SQ_CHECK(vw == NULL);
    SQ_CHECK(dir_entries(NULL) == 0); /* refused before writing anything */

    in_dir(p, sizeof p, "odd.mp4");
    d.width = 63;
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_INVALID_ARG,
                 "63x48; width and height must be even");
    d.width = 64;
    d.height = 35;
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_INVALID_ARG, "must be even");
    d.height = 48;
    d.crf = 60;
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_INVALID_ARG, "crf = 60");
    d.crf = 0;
    d.fps = -5;
    SQ_CHECK_ERR(sq_video_open(ctx, &d, &vw), SQ_ERR_INVALID_ARG, "fps = -5");
    SQ_CHECK(dir_entries(NULL) == 0);

    in_dir(p, sizeof p, "none.mp4");
    snprintf(msg, sizeof msg, "cannot open '%s': No such file or directory", p);
    sq_video_info info;
    SQ_CHECK_ERR(sq_video_probe(ctx, p, &info), SQ_ERR_IO, msg);
    in_dir(p, sizeof p, "garbage.mp4");
    spit(p, "this is not a video at all, just some text bytes", 48);
    snprintf(msg, sizeof msg, "'%s'", p);
    sq_result r = sq_video_probe(ctx, p, &info);
    SQ_CHECK(r == SQ_ERR_PARSE);
    SQ_CHECK(strstr(sq_last_error(), msg) != NULL);
    sq_context_destroy(ctx);
    remove_dir();
}

/* ---- NetCDF -------------------------------------------------------------------------------- */

static void make_fields(sq_named_field f[2], float *a, float *b, int nx, int ny, int nz)
{
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                size_t c = ((size_t)k * ny + j) * nx + i;
                a[c] = (float)(i + 10 * j + 100 * k) * 0.5f;
                b[c] = -(float)c * 1e-3f;
            }
    const sq_vec3 origin = {10.0f, 20.0f, 0.5f}, spacing = {2.0f, 3.0f, 1.0f};
    f[0] =
        (sq_named_field){.name = "dust_mass_concentration",
                         .units = "kg m-3",
                         .long_name = "dust mass concentration",
                         .standard_name = "mass_concentration_of_dust_dry_aerosol_particles_in_air",
                         .data = a,
                         .nx = nx,
                         .ny = ny,
                         .nz = nz,
                         .origin_m = origin,
                         .spacing_m = spacing};
    f[1] = (sq_named_field){.name = "wind_x",
                            .units = "m s-1",
                            .long_name = "wind towards east",
                            .standard_name = NULL,
                            .data = b,
                            .nx = nx,
                            .ny = ny,
                            .nz = nz,
                            .origin_m = origin,
                            .spacing_m = spacing};
}

#if SQ_HAVE_NETCDF
static void check_att_text(int ncid, int varid, const char *name, const char *want)
{
    size_t len = 0;
    char buf[256] = "";
    int st = nc_inq_attlen(ncid, varid, name, &len);
    SQ_CHECK_MSG(st == NC_NOERR, "attribute %s: %s", name, nc_strerror(st));
    if (st != NC_NOERR || len >= sizeof buf) return;
    SQ_CHECK(nc_get_att_text(ncid, varid, name, buf) == NC_NOERR);
    buf[len] = 0;
    SQ_CHECK_MSG(!strcmp(buf, want), "attribute %s = '%s', want '%s'", name, buf, want);
}
#endif

SQ_TEST(netcdf_roundtrip_cf)
{
    make_dir();
    sq_context *ctx = make_ctx();
    const int nx = 5, ny = 4, nz = 3;
    float a[5 * 4 * 3], b[5 * 4 * 3];
    sq_named_field f[2];
    make_fields(f, a, b, nx, ny, nz);
    char p[1024];
    in_dir(p, sizeof p, "fields.nc");
    sq_field_file_desc d = {.path = p, .title = "io test", .source = "squall test", .time_s = 12.5};
#if SQ_HAVE_NETCDF
    SQ_CHECK_OK(sq_netcdf_write_fields(ctx, &d, f, 2));
    int temps = -1;
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    int ncid = -1;
    SQ_CHECK(nc_open(p, NC_NOWRITE, &ncid) == NC_NOERR);
    int fmt = 0;
    SQ_CHECK(nc_inq_format(ncid, &fmt) == NC_NOERR && fmt == NC_FORMAT_NETCDF4_CLASSIC); /* HDF5, classic data model */
    /* built in memory, written up to HDF5's end of file: not the whole 64 KiB-rounded buffer */
    struct stat size_st;
    SQ_CHECK(stat(p, &size_st) == 0 && size_st.st_size > 1000 && size_st.st_size < 65536);
    check_att_text(ncid, NC_GLOBAL, "Conventions", "CF-1.8");
    check_att_text(ncid, NC_GLOBAL, "title", "io test");
    check_att_text(ncid, NC_GLOBAL, "source", "squall test");
    size_t hl = 0;
    SQ_CHECK(nc_inq_attlen(ncid, NC_GLOBAL, "history", &hl) == NC_NOERR && hl > 10);
    /* Dimensions. */
    const char *dn[4] = {"time", "z", "y", "x"};
    const size_t dl[4] = {1, 3, 4, 5};
    for (int i = 0; i < 4; i++) {
        int dim = -1;
        size_t len = 0;
        SQ_CHECK(nc_inq_dimid(ncid, dn[i], &dim) == NC_NOERR);
        SQ_CHECK(nc_inq_dimlen(ncid, dim, &len) == NC_NOERR && len == dl[i]);
    }
    /* Coordinates: cell centres in metres with CF identification. */
    int vx, vy, vz, vt;
    SQ_CHECK(nc_inq_varid(ncid, "x", &vx) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(ncid, "y", &vy) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(ncid, "z", &vz) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(ncid, "time", &vt) == NC_NOERR);
    double xs[5], ys[4], zs[3], t = 0;
    SQ_CHECK(nc_get_var_double(ncid, vx, xs) == NC_NOERR);
    SQ_CHECK(nc_get_var_double(ncid, vy, ys) == NC_NOERR);
    SQ_CHECK(nc_get_var_double(ncid, vz, zs) == NC_NOERR);
    SQ_CHECK(nc_get_var_double(ncid, vt, &t) == NC_NOERR);
    for (int i = 0; i < 5; i++) SQ_CHECK_NEAR(xs[i], 10.0 + 2.0 * i, 1e-12);
    for (int j = 0; j < 4; j++) SQ_CHECK_NEAR(ys[j], 20.0 + 3.0 * j, 1e-12);
    for (int k = 0; k < 3; k++) SQ_CHECK_NEAR(zs[k], 0.5 + 1.0 * k, 1e-12);
    SQ_CHECK_NEAR(t, 12.5, 0.0);
    check_att_text(ncid, vx, "units", "m");
    check_att_text(ncid, vx, "axis", "X");
    check_att_text(ncid, vx, "standard_name", "projection_x_coordinate");
    check_att_text(ncid, vy, "standard_name", "projection_y_coordinate");
    check_att_text(ncid, vy, "axis", "Y");
    check_att_text(ncid, vz, "axis", "Z");
    check_att_text(ncid, vz, "positive", "up");
    check_att_text(ncid, vz, "units", "m");
    check_att_text(ncid, vt, "units", "seconds since 2000-01-01 00:00:00");
    check_att_text(ncid, vt, "standard_name", "time");
    check_att_text(ncid, vt, "calendar", "standard");
    /* Data variables. */
    for (int v = 0; v < 2; v++) {
        int id = -1, nd = 0, dims[NC_MAX_VAR_DIMS];
        nc_type type = 0;
        SQ_CHECK(nc_inq_varid(ncid, f[v].name, &id) == NC_NOERR);
        SQ_CHECK(nc_inq_var(ncid, id, NULL, &type, &nd, dims, NULL) == NC_NOERR);
        SQ_CHECK(type == NC_FLOAT && nd == 4);
        for (int i = 0; i < nd && i < 4; i++) {
            char name[NC_MAX_NAME + 1];
            SQ_CHECK(nc_inq_dimname(ncid, dims[i], name) == NC_NOERR && !strcmp(name, dn[i]));
        }
        check_att_text(ncid, id, "units", f[v].units);
        check_att_text(ncid, id, "long_name", f[v].long_name);
        if (f[v].standard_name)
            check_att_text(ncid, id, "standard_name", f[v].standard_name);
        else
            SQ_CHECK(nc_inq_att(ncid, id, "standard_name", NULL, NULL) == NC_ENOTATT);
        float fill = 0.0f;
        SQ_CHECK(nc_get_att_float(ncid, id, "_FillValue", &fill) == NC_NOERR);
        SQ_CHECK(fill == NC_FILL_FLOAT);
        float back[60];
        const size_t start[4] = {0, 0, 0, 0}, count[4] = {1, 3, 4, 5};
        SQ_CHECK(nc_get_vara_float(ncid, id, start, count, back) == NC_NOERR);
        SQ_CHECK(memcmp(back, f[v].data, sizeof back) == 0);
        /* One element by index: (t, k, j, i) = (0, 2, 1, 3). */
        const size_t at[4] = {0, 2, 1, 3};
        float one = 0.0f;
        SQ_CHECK(nc_get_var1_float(ncid, id, at, &one) == NC_NOERR);
        SQ_CHECK(one == f[v].data[(2 * 4 + 1) * 5 + 3]);
    }
    SQ_CHECK(nc_close(ncid) == NC_NOERR);
    SQ_CHECK(a[(2 * 4 + 1) * 5 + 3] == (3 + 10 + 200) * 0.5f);

    /* Exists: refused, untouched; overwrite replaces. */
    struct stat st0, st1;
    SQ_CHECK(stat(p, &st0) == 0);
    SQ_CHECK_ERR(sq_netcdf_write_fields(ctx, &d, f, 2), SQ_ERR_EXISTS, "exists");
    SQ_CHECK(stat(p, &st1) == 0 && st1.st_ino == st0.st_ino && st1.st_size == st0.st_size);
    d.overwrite = true;
    d.reference_time = "2024-02-29 06:00:00";
    SQ_CHECK_OK(sq_netcdf_write_fields(ctx, &d, f, 1));
    SQ_CHECK(nc_open(p, NC_NOWRITE, &ncid) == NC_NOERR);
    SQ_CHECK(nc_inq_varid(ncid, "time", &vt) == NC_NOERR);
    check_att_text(ncid, vt, "units", "seconds since 2024-02-29 06:00:00");
    int nvars = 0;
    SQ_CHECK(nc_inq_nvars(ncid, &nvars) == NC_NOERR && nvars == 5); /* time z y x + 1 field */
    nc_close(ncid);
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
#else
    SQ_CHECK_ERR(sq_netcdf_write_fields(ctx, &d, f, 2), SQ_ERR_UNSUPPORTED, "without NetCDF");
#endif
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(netcdf_2d_field_has_no_z_dimension)
{
    if (!sq_has_feature("netcdf")) return;
    make_dir();
    sq_context *ctx = make_ctx();
    float a[6 * 4], b[6 * 4];
    sq_named_field f[2];
    make_fields(f, a, b, 6, 4, 1);
    char p[1024];
    in_dir(p, sizeof p, "slice.nc");
    sq_field_file_desc d = {.path = p, .time_s = 3.0};
    SQ_CHECK_OK(sq_netcdf_write_fields(ctx, &d, f, 2));
#if SQ_HAVE_NETCDF
    int ncid = -1, id = -1, nd = 0, dims[NC_MAX_VAR_DIMS], zdim = -1, vz = -1, znd = -1;
    SQ_CHECK(nc_open(p, NC_NOWRITE, &ncid) == NC_NOERR);
    SQ_CHECK(nc_inq_dimid(ncid, "z", &zdim) == NC_EBADDIM);
    SQ_CHECK(nc_inq_varid(ncid, "wind_x", &id) == NC_NOERR);
    SQ_CHECK(nc_inq_var(ncid, id, NULL, NULL, &nd, dims, NULL) == NC_NOERR && nd == 3);
    check_att_text(ncid, id, "coordinates", "z");
    /* z is a scalar coordinate holding the slice height. */
    SQ_CHECK(nc_inq_varid(ncid, "z", &vz) == NC_NOERR);
    SQ_CHECK(nc_inq_varndims(ncid, vz, &znd) == NC_NOERR && znd == 0);
    double z = 0;
    SQ_CHECK(nc_get_var_double(ncid, vz, &z) == NC_NOERR);
    SQ_CHECK_NEAR(z, 0.5, 0.0);
    float back[24];
    SQ_CHECK(nc_get_var_float(ncid, id, back) == NC_NOERR);
    SQ_CHECK(memcmp(back, b, sizeof back) == 0);
    check_att_text(ncid, NC_GLOBAL, "Conventions", "CF-1.8");
    nc_close(ncid);
#endif
    sq_context_destroy(ctx);
    remove_dir();
}

SQ_TEST(field_files_refuse_bad_sets)
{
    make_dir();
    sq_context *ctx = make_ctx();
    float a[5 * 4 * 3], b[5 * 4 * 3];
    sq_named_field f[2];
    make_fields(f, a, b, 5, 4, 3);
    char p[1024], msg[2048];
    in_dir(p, sizeof p, "bad.vti");
    sq_field_file_desc d = {.path = p};
    sq_result (*writers[2])(sq_context *, const sq_field_file_desc *, const sq_named_field *,
                            int) = {sq_vtk_write_fields, sq_netcdf_write_fields};
    for (int wi = 0; wi < 2; wi++) {
        if (wi == 1 && !sq_has_feature("netcdf")) break;
        f[1].nx = 4;
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG,
                     "field 'wind_x' is 4x4x3 but 'dust_mass_concentration' is 5x4x3");
        f[1].nx = 5;
        f[1].spacing_m.y = 2.5f;
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG, "another origin or spacing");
        f[1].spacing_m.y = 3.0f;
        f[1].name = "dust_mass_concentration";
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG, "appears twice");
        f[1].name = "wind x";
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG, "name 'wind x' must match");
        f[1].name = "time";
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG, "taken by a coordinate");
        f[1].name = "wind_x";
        f[1].data = NULL;
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_INVALID_ARG, "'wind_x' has no data");
        f[1].data = b;
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 0), SQ_ERR_INVALID_ARG, "field count = 0");
        SQ_CHECK(dir_entries(NULL) == 0);
        /* Missing directory: refused before writing. */
        snprintf(p, sizeof p, "%s/nope/f.out", g_dir);
        d.path = p;
        snprintf(msg, sizeof msg, "cannot write '%s': directory '%s/nope' does not exist", p,
                 g_dir);
        SQ_CHECK_ERR(writers[wi](ctx, &d, f, 2), SQ_ERR_IO, msg);
        in_dir(p, sizeof p, "bad.out");
        SQ_CHECK(dir_entries(NULL) == 0);
    }
    SQ_CHECK(sq_context_bytes_in_use(ctx) == 0);
    sq_context_destroy(ctx);
    remove_dir();
}

/* ---- VTK ----------------------------------------------------------------------------------- */

SQ_TEST(vtk_image_data_roundtrip)
{
    make_dir();
    sq_context *ctx = make_ctx();
    const int nx = 5, ny = 4, nz = 3;
    float a[5 * 4 * 3], b[5 * 4 * 3];
    sq_named_field f[2];
    make_fields(f, a, b, nx, ny, nz);
    f[1].units = "m s-1 <&>"; /* escaped in the XML */
    char p[1024];
    in_dir(p, sizeof p, "fields.vti");
    sq_field_file_desc d = {.path = p, .title = "io -- test", .time_s = 7.25};
    SQ_CHECK_OK(sq_vtk_write_fields(ctx, &d, f, 2));
    int temps = -1;
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    size_t n = 0;
    unsigned char *buf = slurp(p, &n);
    SQ_CHECK(buf != NULL);
    if (!buf) return;
    const char *s = (const char *)buf;
    SQ_CHECK(strstr(s, "<VTKFile type=\"ImageData\"") != NULL);
    SQ_CHECK(strstr(s, "WholeExtent=\"0 4 0 3 0 2\"") != NULL);
    SQ_CHECK(strstr(s, "<Piece Extent=\"0 4 0 3 0 2\">") != NULL);
    SQ_CHECK(strstr(s, "Origin=\"10 20 0.5\"") != NULL);
    SQ_CHECK(strstr(s, "Spacing=\"2 3 1\"") != NULL);
    SQ_CHECK(strstr(s, "Name=\"dust_mass_concentration\"") != NULL);
    SQ_CHECK(strstr(s, "Name=\"wind_x\"") != NULL);
    SQ_CHECK(strstr(s, "units=\"m s-1 &lt;&amp;&gt;\"") != NULL);
    SQ_CHECK(strstr(s, "format=\"ascii\">7.25</DataArray>") != NULL);
    SQ_CHECK(strstr(s, "io -- test") == NULL); /* "--" is not allowed inside a comment */
    SQ_CHECK(strstr(s, "byte_order=\"LittleEndian\"") != NULL ||
             strstr(s, "byte_order=\"BigEndian\"") != NULL);
    SQ_CHECK(strstr(s, "offset=\"0\"") != NULL);
    SQ_CHECK(strstr(s, "offset=\"248\"") != NULL); /* 8-byte header + 60 floats */
    /* The appended block: '_' then per array a UInt64 byte count and the floats. */
    const char *app = strstr(s, "<AppendedData encoding=\"raw\">");
    SQ_CHECK(app != NULL);
    if (app) {
        const unsigned char *u = (const unsigned char *)strchr(app, '_') + 1;
        for (int v = 0; v < 2; v++) {
            uint64_t len = 0;
            memcpy(&len, u, 8);
            SQ_CHECK(len == 60 * sizeof(float));
            SQ_CHECK(memcmp(u + 8, f[v].data, 60 * sizeof(float)) == 0);
            u += 8 + 60 * sizeof(float);
        }
        SQ_CHECK((size_t)(u - buf) < n);
        SQ_CHECK(strstr((const char *)u, "</AppendedData>") != NULL);
        SQ_CHECK(strstr((const char *)u, "</VTKFile>") != NULL);
    }
    free(buf);
    SQ_CHECK_ERR(sq_vtk_write_fields(ctx, &d, f, 2), SQ_ERR_EXISTS, "exists");
    d.overwrite = true;
    f[0].nz = f[1].nz = 1; /* a 2D slice: flat extent */
    SQ_CHECK_OK(sq_vtk_write_fields(ctx, &d, f, 2));
    buf = slurp(p, &n);
    SQ_CHECK(buf && strstr((const char *)buf, "WholeExtent=\"0 4 0 3 0 0\"") != NULL);
    free(buf);
    SQ_CHECK(dir_entries(&temps) == 1 && temps == 0);
    sq_context_destroy(ctx);
    remove_dir();
}
