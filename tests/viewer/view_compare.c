/* view_compare.c — a helper of the viewer tests: reads PNG screenshots and prints one JSON line
 * with what the tests check: per image the mean and standard deviation of the luma
 * Y = 0.299 R + 0.587 G + 0.114 B (0..255), the fraction of pure black pixels (what a NaN or an
 * unwritten framebuffer shows), the mean luma of the top and bottom halves; for two images of
 * the same size also the SSIM and LDR-FLIP between them (squall/render.h).
 * With one .mp4 argument: {"video": {width, height, frames, codec, mean_luma}} (sq_video_probe).
 * usage: view_compare A.png [B.png] | view_compare CLIP.mp4 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "squall/core.h"
#include "squall/io.h"
#include "squall/render.h"

typedef struct stats {
    double mean, sd, black, top, bottom;
    int alpha_min; /* the window composites the picture with its alpha: 255 = opaque */
} stats;

static stats luma_stats(const uint8_t *px, int w, int h)
{
    stats s = {0};
    double sum = 0, sum2 = 0, top = 0, bottom = 0;
    long black = 0;
    const long n = (long)w * h;
    s.alpha_min = 255;
    for (long i = 0; i < n; i++) {
        const uint8_t *p = px + 4 * i;
        if (p[3] < s.alpha_min) s.alpha_min = p[3];
        const double y = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
        sum += y;
        sum2 += y * y;
        if (p[0] == 0 && p[1] == 0 && p[2] == 0) black++;
        if (i / w < h / 2) top += y; else bottom += y;
    }
    s.mean = sum / (double)n;
    s.sd = sqrt(fmax(sum2 / (double)n - s.mean * s.mean, 0.0));
    s.black = (double)black / (double)n;
    s.top = top / (double)((long)w * (h / 2));
    s.bottom = bottom / (double)(n - (long)w * (h / 2));
    return s;
}

static void print_stats(const char *key, const stats *s, int w, int h)
{
    printf("\"%s\": {\"width\": %d, \"height\": %d, \"mean\": %.4f, \"sd\": %.4f, \"black\": %.6f, "
           "\"top\": %.4f, \"bottom\": %.4f, \"alpha_min\": %d}",
           key, w, h, s->mean, s->sd, s->black, s->top, s->bottom, s->alpha_min);
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: view_compare A.png [B.png]\n");
        return 2;
    }
    sq_context *ctx = NULL;
    sq_context_desc d = {0};
    if (sq_context_create(&d, &ctx) != SQ_OK) return 1;
    const size_t len = strlen(argv[1]);
    if (argc == 2 && len > 4 && strcmp(argv[1] + len - 4, ".mp4") == 0) {
        sq_video_info vi;
        if (sq_video_probe(ctx, argv[1], &vi) != SQ_OK) {
            fprintf(stderr, "view_compare: %s\n", sq_last_error());
            return 1;
        }
        printf("{\"video\": {\"width\": %d, \"height\": %d, \"frames\": %d, \"codec\": \"%s\", "
               "\"mean_luma\": %.4f}}\n",
               vi.width, vi.height, vi.frames, vi.codec, vi.mean_luma);
        sq_context_destroy(ctx);
        return 0;
    }
    uint8_t *img[2] = {NULL, NULL};
    int w[2] = {0, 0}, h[2] = {0, 0};
    for (int i = 0; i + 1 < argc; i++)
        if (sq_png_read_rgba8(ctx, argv[i + 1], &img[i], &w[i], &h[i]) != SQ_OK) {
            fprintf(stderr, "view_compare: %s\n", sq_last_error());
            return 1;
        }
    printf("{");
    stats a = luma_stats(img[0], w[0], h[0]);
    print_stats("a", &a, w[0], h[0]);
    if (img[1]) {
        stats b = luma_stats(img[1], w[1], h[1]);
        printf(", ");
        print_stats("b", &b, w[1], h[1]);
        if (w[0] == w[1] && h[0] == h[1])
            printf(", \"ssim\": %.5f, \"flip\": %.5f", sq_image_ssim(img[0], img[1], w[0], h[0]),
                   sq_image_flip(img[0], img[1], w[0], h[0], 0.0));
    }
    printf("}\n");
    for (int i = 0; i < 2; i++) sq_free(ctx, img[i]);
    sq_context_destroy(ctx);
    return 0;
}
