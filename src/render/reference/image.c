/* image.c — float images on disk (PFM write/read with the temporary-name-and-rename rule) and
 * the image metric used to compare the real-time renderer with the reference path tracer:
 * mean SSIM of Wang, Bovik, Sheikh, Simoncelli, "Image quality assessment: from error
 * visibility to structural similarity", IEEE TIP 13(4), 2004 (eq. 13 with the 11x11 circular-
 * symmetric gaussian window, sigma 1.5, K1 = 0.01, K2 = 0.03, L = 255, 'valid' windows only),
 * on the luma Y = 0.299 R + 0.587 G + 0.114 B of the 8-bit sRGB values. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/core_internal.h"
#include "squall/image.h"
#include "squall/render.h"

#define MODULE "image"

/* ---- PFM ------------------------------------------------------------------------------------ */

static bool host_little_endian(void)
{
    const uint16_t one = 1;
    unsigned char b;
    memcpy(&b, &one, 1);
    return b == 1;
}

static void swap4(unsigned char *p)
{
    unsigned char t = p[0];
    p[0] = p[3];
    p[3] = t;
    t = p[1];
    p[1] = p[2];
    p[2] = t;
}

sq_result sq_pfm_write(const char *path, int width, int height, const float *rgb, bool overwrite)
{
    if (!path || !*path) return sq__set_error(SQ_ERR_INVALID_ARG, "pfm: path is empty");
    if (width <= 0 || height <= 0 || !rgb)
        return sq__set_error(SQ_ERR_INVALID_ARG,
                             "pfm '%s': width x height = %d x %d with rgb %s; need > 0 and data",
                             path, width, height, rgb ? "set" : "NULL");
    if (!overwrite && access(path, F_OK) == 0)
        return sq__set_error(SQ_ERR_EXISTS, "pfm '%s' exists; pass overwrite to replace it",
                             path);
    size_t plen = strlen(path);
    char tmp[4096];
    if (plen + 32 > sizeof tmp)
        return sq__set_error(SQ_ERR_INVALID_ARG, "pfm: path of %zu characters is too long", plen);
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    FILE *f = fopen(tmp, "wb");
    if (!f)
        return sq__set_error(SQ_ERR_IO, "pfm '%s': cannot create '%s': %s", path, tmp,
                             strerror(errno));
    bool ok = fprintf(f, "PF\n%d %d\n-1.0\n", width, height) > 0;
    const bool swap = !host_little_endian();
    unsigned char row_buf[4096];
    for (int y = height - 1; ok && y >= 0; y--) {
        const float *row = rgb + (size_t)y * width * 3;
        size_t n = (size_t)width * 3, done = 0;
        while (ok && done < n) {
            size_t chunk = n - done < sizeof row_buf / 4 ? n - done : sizeof row_buf / 4;
            memcpy(row_buf, row + done, chunk * 4);
            if (swap)
                for (size_t i = 0; i < chunk; i++) swap4(row_buf + 4 * i);
            ok = fwrite(row_buf, 4, chunk, f) == chunk;
            done += chunk;
        }
    }
    int saved = errno;
    if (fclose(f) != 0) ok = false;
    if (!ok) {
        remove(tmp);
        return sq__set_error(SQ_ERR_IO, "pfm '%s': write failed: %s", path, strerror(saved));
    }
    if (!overwrite) {
        /* link() refuses an existing target atomically; fall back to rename where the file
         * system has no hard links */
        if (link(tmp, path) == 0) {
            remove(tmp);
            return SQ_OK;
        }
        if (errno == EEXIST) {
            remove(tmp);
            return sq__set_error(SQ_ERR_EXISTS, "pfm '%s' exists; pass overwrite to replace it",
                                 path);
        }
        if (access(path, F_OK) == 0) {
            remove(tmp);
            return sq__set_error(SQ_ERR_EXISTS, "pfm '%s' exists; pass overwrite to replace it",
                                 path);
        }
    }
    if (rename(tmp, path) != 0) {
        saved = errno;
        remove(tmp);
        return sq__set_error(SQ_ERR_IO, "pfm '%s': cannot rename '%s': %s", path, tmp,
                             strerror(saved));
    }
    return SQ_OK;
}

/* Reads one whitespace-delimited token (at most cap-1 characters). */
static bool read_token(FILE *f, char *buf, size_t cap)
{
    int ch;
    do ch = fgetc(f);
    while (ch == ' ' || ch == '\t' || ch == '\n' || ch == '\r');
    size_t n = 0;
    while (ch != EOF && ch != ' ' && ch != '\t' && ch != '\n' && ch != '\r') {
        if (n + 1 >= cap) return false;
        buf[n++] = (char)ch;
        ch = fgetc(f);
    }
    buf[n] = 0;
    return n > 0 && ch != EOF; /* the single whitespace after the token is consumed */
}

sq_result sq_pfm_read(sq_context *ctx, const char *path, int *width, int *height, float **rgb)
{
    if (rgb) *rgb = NULL;
    if (width) *width = 0;
    if (height) *height = 0;
    if (!path || !width || !height || !rgb)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "pfm read: NULL argument");
    FILE *f = fopen(path, "rb");
    if (!f)
        return sq__fail(ctx, SQ_ERR_IO, MODULE, "pfm '%s': cannot open: %s", path,
                        strerror(errno));
    char tok[64];
    sq_result r = SQ_OK;
    int channels = 0;
    long w = 0, h = 0;
    double scale = 0.0;
    if (!read_token(f, tok, sizeof tok) || (strcmp(tok, "PF") != 0 && strcmp(tok, "Pf") != 0)) {
        r = sq__fail(ctx, SQ_ERR_PARSE, MODULE, "pfm '%s': header must start with PF or Pf",
                     path);
        goto done;
    }
    channels = tok[1] == 'F' ? 3 : 1;
    char *end = NULL;
    if (!read_token(f, tok, sizeof tok) || ((w = strtol(tok, &end, 10)), *end) || w < 1 ||
        w > 65536 || !read_token(f, tok, sizeof tok) || ((h = strtol(tok, &end, 10)), *end) ||
        h < 1 || h > 65536) {
        r = sq__fail(ctx, SQ_ERR_PARSE, MODULE,
                     "pfm '%s': width and height must be integers in [1, 65536]", path);
        goto done;
    }
    if (!read_token(f, tok, sizeof tok) || ((scale = strtod(tok, &end)), *end) ||
        !(scale != 0.0) || !isfinite(scale)) {
        r = sq__fail(ctx, SQ_ERR_PARSE, MODULE, "pfm '%s': scale must be a non-zero number",
                     path);
        goto done;
    }
    {
        const size_t npix = (size_t)w * (size_t)h;
        float *out = (float *)sq_alloc(ctx, npix * 3 * sizeof(float));
        if (!out) {
            r = SQ_ERR_OUT_OF_MEMORY;
            goto done;
        }
        const bool swap = (scale < 0.0) != host_little_endian();
        unsigned char px[12];
        for (long y = h - 1; y >= 0; y--)
            for (long x = 0; x < w; x++) {
                if (fread(px, 4, (size_t)channels, f) != (size_t)channels) {
                    sq_free(ctx, out);
                    r = sq__fail(ctx, SQ_ERR_PARSE, MODULE,
                                 "pfm '%s': file ends inside the pixel data (row %ld of %ld)",
                                 path, h - 1 - y, h);
                    goto done;
                }
                float *o = out + 3 * ((size_t)y * w + x);
                for (int c = 0; c < channels; c++) {
                    if (swap) swap4(px + 4 * c);
                    memcpy(&o[c], px + 4 * c, 4);
                }
                if (channels == 1) o[1] = o[2] = o[0];
            }
        *rgb = out;
        *width = (int)w;
        *height = (int)h;
    }
done:
    fclose(f);
    return r;
}

/* ---- SSIM ------------------------------------------------------------------------------------ */

#define SSIM_WIN 11
#define SSIM_SIGMA 1.5

double sq_image_ssim(const uint8_t *a_rgba, const uint8_t *b_rgba, int width, int height)
{
    if (!a_rgba || !b_rgba || width <= 0 || height <= 0) {
        sq__set_error(SQ_ERR_INVALID_ARG, "ssim: images missing or %d x %d; need > 0", width,
                      height);
        return NAN;
    }
    int k = SSIM_WIN;
    if (width < k) k = width;
    if (height < k) k = height;
    if (k % 2 == 0) k--;
    double wgt[SSIM_WIN], wsum = 0.0;
    for (int i = 0; i < k; i++) {
        double x = i - (k - 1) / 2.0;
        wgt[i] = exp(-x * x / (2.0 * SSIM_SIGMA * SSIM_SIGMA));
        wsum += wgt[i];
    }
    for (int i = 0; i < k; i++) wgt[i] /= wsum;
    const int ow = width - k + 1, oh = height - k + 1;
    const size_t n = (size_t)width * height;
    /* luma planes, then five row-filtered planes (width ow x height) */
    double *buf = (double *)sq_alloc(NULL, (2 * n + 5 * (size_t)ow * height) * sizeof(double));
    if (!buf) return NAN;
    double *ya = buf, *yb = buf + n, *rf = buf + 2 * n;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *p = a_rgba + 4 * i, *q = b_rgba + 4 * i;
        ya[i] = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
        yb[i] = 0.299 * q[0] + 0.587 * q[1] + 0.114 * q[2];
    }
    const size_t plane = (size_t)ow * height;
    for (int y = 0; y < height; y++)
        for (int x = 0; x < ow; x++) {
            double s[5] = {0, 0, 0, 0, 0};
            for (int i = 0; i < k; i++) {
                double u = ya[(size_t)y * width + x + i], v = yb[(size_t)y * width + x + i];
                s[0] += wgt[i] * u;
                s[1] += wgt[i] * v;
                s[2] += wgt[i] * (u * u);
                s[3] += wgt[i] * (v * v);
                s[4] += wgt[i] * (u * v);
            }
            for (int m = 0; m < 5; m++) rf[m * plane + (size_t)y * ow + x] = s[m];
        }
    const double c1 = (0.01 * 255.0) * (0.01 * 255.0), c2 = (0.03 * 255.0) * (0.03 * 255.0);
    double total = 0.0;
    for (int y = 0; y < oh; y++) {
        double row = 0.0;
        for (int x = 0; x < ow; x++) {
            double s[5] = {0, 0, 0, 0, 0};
            for (int i = 0; i < k; i++)
                for (int m = 0; m < 5; m++) s[m] += wgt[i] * rf[m * plane + (size_t)(y + i) * ow + x];
            double mx = s[0], my = s[1];
            double vx = s[2] - mx * mx, vy = s[3] - my * my, cxy = s[4] - mx * my;
            row += ((2.0 * (mx * my) + c1) * (2.0 * cxy + c2)) / /* symmetric in a, b */
                   ((mx * mx + my * my + c1) * (vx + vy + c2));
        }
        total += row;
    }
    sq_free(NULL, buf);
    return total / ((double)ow * oh);
}
