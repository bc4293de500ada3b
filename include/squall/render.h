/* squall/render.h — the OpenGL 4.5 core renderer (headless through EGL; Mesa llvmpipe on
 * machines without a GPU) and the reference CPU path tracer. Draws the world (terrain,
 * obstacles, sky) and drawables by kind, for a camera, into an off-screen frame that is read
 * back as 8-bit sRGB RGBA (rows top to bottom) or as linear float RGB. */
#ifndef SQ_RENDER_H
#define SQ_RENDER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "squall/core.h"
#include "squall/drawable.h"
#include "squall/world.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sq_render_desc {
    int width, height;     /* 0 -> 640 x 360 */
    float exposure;        /* linear scale before tone mapping; 0 -> 1 */
    int volume_slices;     /* half-angle slices; 0 -> 128 */
    int light_buffer_size; /* light buffer resolution; 0 -> 256 */
    bool volume_noise;     /* noise perturbation of volume texture coordinates (S0 Fig 3.12) */
    bool single_scatter_only; /* ablation: no multiple forward scattering in the light buffer */
    bool isotropic_phase;  /* ablation: g = 0 */
    uint64_t seed;         /* slice jitter */
    /* sun shadows of opaque geometry (cascaded shadow maps fitted to the view) */
    bool shadows_off;      /* no opaque shadows */
    int shadow_map_size;   /* texels per side of each cascade; 0 -> 2048 */
    int shadow_cascades;   /* 1..4; 0 -> 3 */
    float shadow_distance_m; /* shadows up to this view depth (m), fading out over the last
                                15 %; 0 -> 1500 */
    const char *egl_device; /* NULL: surfaceless platform, else "device" platform hint */
} sq_render_desc;

typedef struct sq_render_info {
    char gl_vendor[128];
    char gl_renderer[128];
    char gl_version[128];
    char glsl_version[64];
    int max_texture_size;
    int max_3d_texture_size;
    int max_viewport[2];
    int max_renderbuffer_size;
} sq_render_info;

typedef struct sq_renderer sq_renderer;

SQ_API sq_result sq_renderer_create(sq_context *ctx, const sq_render_desc *desc,
                                    sq_renderer **out);
SQ_API void sq_renderer_destroy(sq_renderer *r);
SQ_API sq_result sq_renderer_info(const sq_renderer *r, sq_render_info *out);
/* Opens a headless GL context only to report its strings and limits (for `squall info`). */
SQ_API sq_result sq_gl_probe(sq_context *ctx, sq_render_info *out);

/* Draws one frame: sky, terrain, obstacles, surfaces, volumes, particles. time_s animates
 * noise and jitter. Fails with SQ_ERR_INVALID_ARG for a camera inside terrain or a volume with
 * NaN density (reported, not rendered). */
SQ_API sq_result sq_renderer_draw(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                                  const sq_drawable *drawables, int count, double time_s);
/* Reads the last frame: 8-bit sRGB RGBA, width*height*4 bytes, top row first. */
SQ_API sq_result sq_renderer_read_rgba8(sq_renderer *r, uint8_t *rgba);
/* Reads the last frame as linear RGB floats before tone mapping (width*height*3). */
SQ_API sq_result sq_renderer_read_linear(sq_renderer *r, float *rgb);

/* ---- reference path tracer (CPU, OpenMP) ------------------------------------------------- */
typedef struct sq_reference_desc {
    int width, height;     /* 0 -> 320 x 180 */
    int samples;           /* samples per pixel; must be > 0 (0 is refused) */
    int max_bounces;       /* 0 -> 64 */
    float exposure;        /* 0 -> 1; not applied to rgb_out: pass it to sq_tonemap_rgba8 */
    bool single_scatter_only; /* = max_bounces 1 */
    bool isotropic_phase;
    uint64_t seed;
    /* progress callback: fraction done in [0,1]; return false to cancel */
    bool (*progress)(void *user, double fraction);
    void *progress_user;
} sq_reference_desc;

/* Renders linear RGB radiance (width*height*3 floats, top row first) by unbiased volumetric
 * path tracing; see src/render/reference/ref_trace.c for the estimators. Deterministic for a
 * seed, independent of the thread count. SQ_ERR_CANCELLED when progress returns false. */
SQ_API sq_result sq_reference_render(sq_context *ctx, const sq_reference_desc *desc,
                                     const sq_world *world, const sq_camera *camera,
                                     const sq_drawable *drawables, int count, float *rgb_out);

/* Tone mapping shared by both paths: linear RGB * exposure -> ACES-fitted curve -> sRGB 8-bit. */
SQ_API void sq_tonemap_rgba8(const float *rgb, int width, int height, float exposure,
                             uint8_t *rgba);

/* ---- image metrics ------------------------------------------------------------------------ */
/* Mean SSIM (Wang et al. 2004: 11x11 gaussian window sigma 1.5, K1 = 0.01, K2 = 0.03, L = 255,
 * 'valid' windows only; smaller images use the largest odd window that fits) on the luma
 * Y = 0.299 R + 0.587 G + 0.114 B of 8-bit sRGB RGBA. 1 for identical images; NaN (error text
 * set) for NULL images or a size <= 0. */
SQ_API double sq_image_ssim(const uint8_t *a_rgba, const uint8_t *b_rgba, int width, int height);

/* Mean LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images")
 * between two 8-bit sRGB RGBA images: 0 for identical images, up to 1. pixels_per_degree is the
 * viewing condition (0 -> 67.02: 0.7 m from a 0.7 m wide 3840-pixel monitor; else [1, 300]).
 * LDR-FLIP treats both images alike, so the result does not depend on the argument order.
 * NaN (error text set) for NULL images, a size <= 0 or a bad pixels_per_degree. */
SQ_API double sq_image_flip(const uint8_t *reference_rgba, const uint8_t *test_rgba, int width,
                            int height, double pixels_per_degree);
/* The same, also writing the per-pixel maps (width*height floats each; any may be NULL): the
 * FLIP error ΔE = ΔE_c^(1 − ΔE_f), its colour part ΔE_c and its feature part ΔE_f. */
SQ_API double sq_image_flip_maps(const uint8_t *reference_rgba, const uint8_t *test_rgba,
                                 int width, int height, double pixels_per_degree,
                                 float *error_map, float *colour_map, float *feature_map);

#ifdef __cplusplus
}
#endif
#endif
