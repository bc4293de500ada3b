/* test_reference_image.c — the image metric and float image files: SSIM (Wang et al. 2004)
 * against values that follow from its formula, its symmetry and its monotone response to
 * noise; PFM round trips, byte order, refusal of existing files and of malformed ones, and the
 * temporary-name-and-rename rule. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "sq_test.h"
#include "squall/image.h"
#include "squall/render.h"
#include "squall/rng.h"

SQ_LABEL(unit)

static uint8_t *image_new(int w, int h)
{
    uint8_t *p = (uint8_t *)malloc((size_t)w * h * 4);
    for (int i = 0; i < w * h * 4; i++) p[i] = 255;
    return p;
}

static void fill_grey(uint8_t *p, int w, int h, int v)
{
    for (int i = 0; i < w * h; i++) p[4 * i] = p[4 * i + 1] = p[4 * i + 2] = (uint8_t)v;
}

/* A textured test image: gradients plus a checker plus seeded noise. */
static void fill_texture(uint8_t *p, int w, int h)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int v = (x * 3 + y * 2) % 160 + (((x / 6) + (y / 5)) % 2) * 40 +
                    (int)(30.0 * sq_rng_uniform_d(3, 0, (uint64_t)(y * w + x)));
            uint8_t *q = p + 4 * (y * w + x);
            q[0] = (uint8_t)v;
            q[1] = (uint8_t)(255 - v);
            q[2] = (uint8_t)(v / 2 + 40);
        }
}

static void add_noise(const uint8_t *src, uint8_t *dst, int w, int h, double amp, uint64_t seed)
{
    for (int i = 0; i < w * h; i++)
        for (int c = 0; c < 3; c++) {
            double v = src[4 * i + c] + amp * (2.0 * sq_rng_uniform_d(seed, (uint64_t)c, (uint64_t)i) - 1.0);
            dst[4 * i + c] = (uint8_t)(v < 0 ? 0 : (v > 255 ? 255 : lrint(v)));
        }
}

SQ_TEST(ssim_identical_is_exactly_one)
{
    const int w = 47, h = 31;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    fill_texture(a, w, h);
    memcpy(b, a, (size_t)w * h * 4);
    SQ_CHECK(sq_image_ssim(a, b, w, h) == 1.0);
    fill_grey(a, w, h, 0);
    fill_grey(b, w, h, 0);
    SQ_CHECK(sq_image_ssim(a, b, w, h) == 1.0);
    free(a);
    free(b);
}

SQ_TEST(ssim_constant_shift_on_flat_image_follows_formula)
{
    /* flat images of luma mu and mu + b: sigma = 0 everywhere, so
     * SSIM = (2 mu (mu + b) + C1) / (mu^2 + (mu + b)^2 + C1), C1 = (0.01 * 255)^2 */
    const int w = 40, h = 30;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    const double c1 = (0.01 * 255) * (0.01 * 255);
    const int pairs[4][2] = {{100, 110}, {100, 150}, {20, 200}, {0, 5}};
    for (int k = 0; k < 4; k++) {
        fill_grey(a, w, h, pairs[k][0]);
        fill_grey(b, w, h, pairs[k][1]);
        double m = pairs[k][0], n = pairs[k][1];
        double expect = (2 * m * n + c1) / (m * m + n * n + c1);
        double got = sq_image_ssim(a, b, w, h);
        printf("flat %g vs %g: ssim %.12f, formula %.12f\n", m, n, got, expect);
        SQ_CHECK_NEAR(got, expect, 1e-9);
    }
    free(a);
    free(b);
}

SQ_TEST(ssim_symmetric_and_decreasing_with_noise)
{
    const int w = 64, h = 48;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    fill_texture(a, w, h);
    double prev = 1.0;
    const double amps[5] = {2, 8, 20, 50, 120};
    for (int k = 0; k < 5; k++) {
        add_noise(a, b, w, h, amps[k], 17);
        double ab = sq_image_ssim(a, b, w, h), ba = sq_image_ssim(b, a, w, h);
        printf("noise +-%g: ssim %.5f\n", amps[k], ab);
        SQ_CHECK(ab == ba);
        SQ_CHECK(ab < prev);
        SQ_CHECK(ab > -1.0 && ab < 1.0);
        prev = ab;
    }
    SQ_CHECK(prev < 0.5);
    free(a);
    free(b);
}

SQ_TEST(ssim_structure_term_on_a_known_pair)
{
    /* an image against its negative (luma 255 - Y, chroma ignored) has negative structure
     * correlation: SSIM < 0. Against a contrast-scaled copy (Y -> 128 + 0.5 (Y - 128)) the
     * value must be well below 1 but positive. */
    const int w = 32, h = 32;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int v = ((x / 4 + y / 4) % 2) ? 200 : 56;
            fill_grey(a + 4 * (y * w + x), 1, 1, v);
            fill_grey(b + 4 * (y * w + x), 1, 1, 255 - v);
        }
    double neg = sq_image_ssim(a, b, w, h);
    for (int i = 0; i < w * h; i++) fill_grey(b + 4 * i, 1, 1, 128 + (a[4 * i] - 128) / 2);
    double half = sq_image_ssim(a, b, w, h);
    printf("negative %.4f, half contrast %.4f\n", neg, half);
    SQ_CHECK(neg < 0.0);
    SQ_CHECK(half > 0.5 && half < 0.95);
    /* small images use a smaller window and still give 1 for identical input */
    SQ_CHECK(sq_image_ssim(a, a, 5, 4) == 1.0);
    SQ_CHECK(isnan(sq_image_ssim(a, NULL, w, h)));
    SQ_CHECK(isnan(sq_image_ssim(a, a, 0, h)));
    free(a);
    free(b);
}

/* ---- FLIP (Andersson et al. 2020, LDR-FLIP) --------------------------------------------- */

/* CIELAB L* of a grey sRGB byte (D65), written out here independently of flip.c */
static double grey_lstar(int v)
{
    double c = v / 255.0;
    double y = c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
    double f = y > 216.0 / 24389.0 ? cbrt(y) : (24389.0 / 27.0 * y + 16.0) / 116.0;
    return 116.0 * f - 16.0;
}

/* The colour stage of FLIP for two flat grey images: the CSF filters keep a flat image, Hunt
 * leaves a = b = 0 alone, so ΔE_c = compress(|ΔL*|^0.7) with cmax from the CIELAB values of the
 * sRGB green and blue primaries (L, a, b = 87.7347, -86.1827, 83.1793 and 32.2970, 79.1875,
 * -107.8602), and the feature part is 0. */
static double flat_grey_flip(int u, int v)
{
    const double gl = 87.7347, ga = -86.1827, gb = 83.1793;
    const double bl = 32.2970, ba = 79.1875, bb = -107.8602;
    const double ha = 0.01 * gl * ga - 0.01 * bl * ba, hb = 0.01 * gl * gb - 0.01 * bl * bb;
    const double cmax = pow(fabs(gl - bl) + sqrt(ha * ha + hb * hb), 0.7);
    const double e = pow(fabs(grey_lstar(u) - grey_lstar(v)), 0.7);
    return e < 0.4 * cmax ? 0.95 / (0.4 * cmax) * e
                          : 0.95 + (e - 0.4 * cmax) / (0.6 * cmax) * 0.05;
}

SQ_TEST(flip_identical_is_exactly_zero)
{
    const int w = 47, h = 31;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    fill_texture(a, w, h);
    memcpy(b, a, (size_t)w * h * 4);
    SQ_CHECK(sq_image_flip(a, b, w, h, 0.0) == 0.0);
    SQ_CHECK(sq_image_flip(a, b, w, h, 20.0) == 0.0);
    fill_grey(a, w, h, 0);
    fill_grey(b, w, h, 0);
    SQ_CHECK(sq_image_flip(a, b, w, h, 0.0) == 0.0);
    free(a);
    free(b);
}

SQ_TEST(flip_flat_images_follow_the_colour_formula)
{
    /* black against white lands above the compression knee (0.967), small grey steps below it */
    const int w = 40, h = 30;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    const int pairs[4][2] = {{0, 255}, {100, 110}, {20, 200}, {128, 129}};
    float *fmap = (float *)malloc(sizeof(float) * w * h);
    for (int k = 0; k < 4; k++) {
        fill_grey(a, w, h, pairs[k][0]);
        fill_grey(b, w, h, pairs[k][1]);
        double got = sq_image_flip_maps(a, b, w, h, 0.0, NULL, NULL, fmap);
        double expect = flat_grey_flip(pairs[k][0], pairs[k][1]);
        float fmax = 0.0f;
        for (int i = 0; i < w * h; i++) fmax = fmaxf(fmax, fmap[i]);
        printf("flat %d vs %d: flip %.6f, formula %.6f, max feature part %.2g\n", pairs[k][0],
               pairs[k][1], got, expect, (double)fmax);
        SQ_CHECK_NEAR(got, expect, 2e-4); /* the primaries' Lab values are given to 1e-4 */
        SQ_CHECK(fmax < 1e-6f);
    }
    free(fmap);
    free(a);
    free(b);
}

SQ_TEST(flip_grows_with_noise_and_is_symmetric)
{
    /* LDR-FLIP applies the same pipeline to both images and combines them with |ΔL|,
     * ||Δ(a,b)|| and |Δ|edge||, |Δ|point||, all symmetric, so swapping the arguments gives the
     * same value exactly (the asymmetric variant is HDR-FLIP, whose exposure range comes from
     * the reference alone). */
    const int w = 64, h = 48;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    fill_texture(a, w, h);
    double prev = 0.0;
    const double amps[5] = {2, 8, 20, 50, 120};
    for (int k = 0; k < 5; k++) {
        add_noise(a, b, w, h, amps[k], 17);
        double ab = sq_image_flip(a, b, w, h, 0.0), ba = sq_image_flip(b, a, w, h, 0.0);
        printf("noise +-%g: flip %.5f (swapped %.5f)\n", amps[k], ab, ba);
        SQ_CHECK(ab == ba);
        SQ_CHECK(ab > prev);
        SQ_CHECK(ab > 0.0 && ab < 1.0);
        prev = ab;
    }
    SQ_CHECK(prev > 0.3);
    free(a);
    free(b);
}

SQ_TEST(flip_edge_shift_is_caught_by_the_feature_part)
{
    /* a vertical step (grey 60 | grey 200) moved by one pixel: the feature part responds along
     * the edge and raises the error above the colour part; far from the edge it is 0. A uniform
     * brightening (60 -> 70 on the dark side, same edge position) changes the colour part only. */
    const int w = 64, h = 32, edge = 32;
    uint8_t *a = image_new(w, h), *b = image_new(w, h), *c = image_new(w, h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            fill_grey(a + 4 * (y * w + x), 1, 1, x < edge ? 60 : 200);
            fill_grey(b + 4 * (y * w + x), 1, 1, x < edge + 1 ? 60 : 200);
            fill_grey(c + 4 * (y * w + x), 1, 1, x < edge ? 70 : 200);
        }
    const size_t n = (size_t)w * h;
    float *err = (float *)malloc(sizeof(float) * n), *col = (float *)malloc(sizeof(float) * n),
          *feat = (float *)malloc(sizeof(float) * n);
    double mean = sq_image_flip_maps(a, b, w, h, 0.0, err, col, feat);
    double fmax_edge = 0.0, fmax_far = 0.0, col_edge = 0.0, err_edge = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const size_t p = (size_t)y * w + x;
            if (x >= edge - 3 && x <= edge + 3) {
                fmax_edge = fmax(fmax_edge, (double)feat[p]);
                col_edge += (double)col[p];
                err_edge += (double)err[p];
            }
            if (x < edge - 12 || x > edge + 13) fmax_far = fmax(fmax_far, (double)feat[p]);
        }
    printf("edge shift: mean flip %.5f; near the edge: max feature %.4f, colour sum %.3f, flip sum "
           "%.3f; far from it: max feature %.2g\n",
           mean, fmax_edge, col_edge, err_edge, fmax_far);
    SQ_CHECK(fmax_edge > 0.2); /* measured 0.302 */
    SQ_CHECK(err_edge > 1.2 * col_edge);
    SQ_CHECK(fmax_far < 1e-6);
    double mean_c = sq_image_flip_maps(a, c, w, h, 0.0, err, col, feat);
    double fmax_c = 0.0, cmax_c = 0.0, fmax_c_far = 0.0;
    for (size_t p = 0; p < n; p++) {
        const int x = (int)(p % (size_t)w);
        fmax_c = fmax(fmax_c, (double)feat[p]);
        cmax_c = fmax(cmax_c, (double)col[p]);
        if (x < edge - 12 || x > edge + 13) fmax_c_far = fmax(fmax_c_far, (double)feat[p]);
    }
    printf("uniform brightening: mean flip %.5f, max colour part %.4f, max feature part %.3g\n",
           mean_c, cmax_c, fmax_c);
    /* the edge's height changes by 10/255 of a grey level, so the edge detector sees a small
     * difference at the edge only; away from it none */
    SQ_CHECK(cmax_c > 0.05);
    SQ_CHECK(fmax_c < fmax_edge / 2.0);
    SQ_CHECK(fmax_c_far < 1e-6);
    free(err);
    free(col);
    free(feat);
    free(a);
    free(b);
    free(c);
}

SQ_TEST(flip_fine_pattern_fades_with_viewing_distance)
{
    /* a one-pixel checkerboard of grey 80 / 180 against flat grey 143 (about the same mean
     * linear luminance): the CSF filters and the feature filters widen with the pixels per
     * degree, so the farther the viewer, the less of the pattern survives and the smaller the
     * error (measured 0.732, 0.590, 0.088, 0.048) */
    const int w = 48, h = 40;
    uint8_t *a = image_new(w, h), *b = image_new(w, h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) fill_grey(a + 4 * (y * w + x), 1, 1, (x + y) % 2 ? 180 : 80);
    fill_grey(b, w, h, 143);
    const double ppd[4] = {5.0, 15.0, 40.0, 120.0};
    double prev = 1.0;
    for (int k = 0; k < 4; k++) {
        double f = sq_image_flip(a, b, w, h, ppd[k]);
        printf("checkerboard vs flat at %g ppd: flip %.4f\n", ppd[k], f);
        SQ_CHECK(f < prev);
        prev = f;
    }
    SQ_CHECK(prev < 0.1);
    free(a);
    free(b);
}

SQ_TEST(flip_refuses_bad_input)
{
    const int w = 16, h = 16;
    uint8_t *a = image_new(w, h);
    fill_texture(a, w, h);
    SQ_CHECK(isnan(sq_image_flip(a, NULL, w, h, 0.0)));
    SQ_CHECK(isnan(sq_image_flip(a, a, 0, h, 0.0)));
    SQ_CHECK(isnan(sq_image_flip(a, a, w, h, -5.0)));
    SQ_CHECK(strstr(sq_last_error(), "pixels_per_degree = -5") != NULL);
    /* tiny images and large pixels-per-degree (kernels wider than the image) still work */
    SQ_CHECK(sq_image_flip(a, a, 3, 2, 200.0) == 0.0);
    free(a);
}

static void temp_path(char *buf, size_t n, const char *name)
{
    const char *dir = getenv("SQ_BUILD_DIR");
    snprintf(buf, n, "%s/ref_image_test_%ld_%s", dir ? dir : "/tmp", (long)getpid(), name);
    remove(buf);
}

SQ_TEST(pfm_round_trip_and_refusals)
{
    char path[1024];
    temp_path(path, sizeof path, "a.pfm");
    const int w = 7, h = 5;
    float rgb[7 * 5 * 3];
    for (int i = 0; i < w * h * 3; i++) rgb[i] = (float)(i * 0.37 - 3.0);
    rgb[4] = 1e30f;
    rgb[5] = 1e-30f;
    SQ_CHECK_OK(sq_pfm_write(path, w, h, rgb, false));
    /* no temporary file left beside it */
    char tmp[1100];
    snprintf(tmp, sizeof tmp, "%s.tmp-%ld", path, (long)getpid());
    SQ_CHECK(access(tmp, F_OK) != 0);
    /* header and the first stored row is the bottom row */
    FILE *f = fopen(path, "rb");
    SQ_CHECK(f != NULL);
    if (f) {
        char head[32] = {0};
        SQ_CHECK(fread(head, 1, 13, f) == 13);
        SQ_CHECK(strncmp(head, "PF\n7 5\n-1.0\n", 12) == 0);
        fseek(f, 12, SEEK_SET);
        unsigned char b4[4];
        SQ_CHECK(fread(b4, 1, 4, f) == 4);
        uint32_t u = (uint32_t)b4[0] | (uint32_t)b4[1] << 8 | (uint32_t)b4[2] << 16 | (uint32_t)b4[3] << 24;
        float v;
        memcpy(&v, &u, 4);
        SQ_CHECK(v == rgb[3 * (h - 1) * w]);
        fclose(f);
    }
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    int rw = 0, rh = 0;
    float *back = NULL;
    SQ_CHECK_OK(sq_pfm_read(ctx, path, &rw, &rh, &back));
    SQ_CHECK(rw == w && rh == h);
    if (back) SQ_CHECK(memcmp(back, rgb, sizeof rgb) == 0);
    sq_free(ctx, back);
    /* existing file: refused without overwrite, replaced with it */
    SQ_CHECK_ERR(sq_pfm_write(path, w, h, rgb, false), SQ_ERR_EXISTS, "exists");
    rgb[0] = 42.0f;
    SQ_CHECK_OK(sq_pfm_write(path, w, h, rgb, true));
    SQ_CHECK_OK(sq_pfm_read(ctx, path, &rw, &rh, &back));
    if (back) SQ_CHECK(back[0] == 42.0f);
    sq_free(ctx, back);
    SQ_CHECK_ERR(sq_pfm_write(path, 0, h, rgb, true), SQ_ERR_INVALID_ARG, "width x height = 0 x 5");
    remove(path);
    SQ_CHECK_ERR(sq_pfm_read(ctx, path, &rw, &rh, &back), SQ_ERR_IO, "cannot open");
    SQ_CHECK(back == NULL && rw == 0);
    SQ_CHECK_ERR(sq_pfm_write("/nonexistent-dir-xyz/a.pfm", w, h, rgb, false), SQ_ERR_IO,
                 "cannot create");
    sq_context_destroy(ctx);
}

SQ_TEST(pfm_reads_big_endian_grey_and_rejects_bad_files)
{
    char path[1024];
    temp_path(path, sizeof path, "b.pfm");
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(NULL, &ctx));
    /* grey, big-endian (positive scale), 2 x 1: values 1.5 and -2 */
    FILE *f = fopen(path, "wb");
    fputs("Pf\n2 1\n1.0\n", f);
    const unsigned char be[8] = {0x3f, 0xc0, 0, 0, 0xc0, 0, 0, 0};
    fwrite(be, 1, 8, f);
    fclose(f);
    int w = 0, h = 0;
    float *rgb = NULL;
    SQ_CHECK_OK(sq_pfm_read(ctx, path, &w, &h, &rgb));
    SQ_CHECK(w == 2 && h == 1);
    if (rgb) {
        SQ_CHECK(rgb[0] == 1.5f && rgb[1] == 1.5f && rgb[2] == 1.5f);
        SQ_CHECK(rgb[3] == -2.0f && rgb[5] == -2.0f);
    }
    sq_free(ctx, rgb);
    const char *bad[4][2] = {{"P6\n2 1\n255\n", "must start with PF"},
                             {"PF\n-2 1\n-1.0\n", "width and height"},
                             {"PF\n2 1\n0\n", "scale"},
                             {"PF\n2 2\n-1.0\nabcd", "file ends inside the pixel data"}};
    for (int k = 0; k < 4; k++) {
        f = fopen(path, "wb");
        fputs(bad[k][0], f);
        fclose(f);
        SQ_CHECK_ERR(sq_pfm_read(ctx, path, &w, &h, &rgb), SQ_ERR_PARSE, bad[k][1]);
        SQ_CHECK(rgb == NULL);
    }
    remove(path);
    sq_context_destroy(ctx);
}
