/* squall/render.h — the OpenGL 4.5 core renderer and the reference CPU path tracer. Draws the
 * world (terrain, obstacles, sky) and drawables by kind, for a camera, either
 *   - in its own headless context (EGL; Mesa llvmpipe on machines without a GPU) into an
 *     off-screen frame that is read back as 8-bit sRGB RGBA (rows top to bottom) or as linear
 *     float RGB, or
 *   - in the caller's current OpenGL 4.5 core context (sq_render_desc.use_current_context),
 *     into the caller's framebuffer: the whole frame, or only the drawables composited over the
 *     caller's colour and tested against the caller's depth (sq_renderer_draw_to). */
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

/* Multiple scattering of the sun light in volumes, beyond the single scattering and the light
 * buffer's forward in-scatter (docs/validation.md, "Multiple scattering by diffusion"). */
typedef enum sq_volume_ms {
    SQ_VOLUME_MS_DEFAULT = 0,   /* = SQ_VOLUME_MS_DIFFUSION */
    SQ_VOLUME_MS_DIFFUSION = 1, /* delta-Eddington diffusion along the sun ray */
    SQ_VOLUME_MS_OCTAVES = 2,   /* Wrenninge's octaves (volume_octaves) */
    SQ_VOLUME_MS_NONE = 3       /* single scattering (and the forward in-scatter) only */
} sq_volume_ms;

typedef struct sq_render_desc {
    int width, height;     /* 0 -> 640 x 360 */
    float exposure;        /* linear scale before tone mapping; 0 -> 1 */
    int volume_slices;     /* half-angle slices; 0 -> 128 */
    int light_buffer_size; /* light buffer resolution; 0 -> 256 */
    bool volume_noise;     /* noise perturbation of volume texture coordinates (S0 Fig 3.12) */
    bool single_scatter_only; /* ablation: no multiple forward scattering in the light buffer */
    bool isotropic_phase;  /* ablation: g = 0 */
    /* with volume_ms = SQ_VOLUME_MS_OCTAVES: multiple-scattering octaves of the sun light in
     * volumes, the first (single scattering plus the light buffer's forward in-scatter)
     * included: 0 -> 3; 1 = none; at most 8 (docs/validation.md, "Multiple-scattering
     * octaves") */
    int volume_octaves;
    sq_volume_ms volume_ms; /* multiple scattering model (0 -> diffusion); volume_octaves
                               counts only with SQ_VOLUME_MS_OCTAVES */
    /* ambient (sky and ground) light in volumes: false (default) = attenuated by the medium
     * itself toward the sky and the ground (dark bases and insides; docs/validation.md,
     * "Ambient light inside the medium"); true = the same everywhere (a uniformly lit
     * medium, the hypothesis of Koschmieder's law) */
    bool volume_ambient_uniform;
    uint64_t seed;         /* slice jitter */
    /* sun shadows of opaque geometry (cascaded shadow maps fitted to the view) */
    bool shadows_off;      /* no opaque shadows */
    int shadow_map_size;   /* texels per side of each cascade; 0 -> 2048 */
    int shadow_cascades;   /* 1..4; 0 -> 3 */
    float shadow_distance_m; /* shadows up to this view depth (m), fading out over the last
                                15 %; 0 -> 1500 */
    /* world meshes seen by the camera (docs/meshes.md): the coarsest level whose error projects
     * below lod_pixels (0 -> 1), instances whose bounding sphere projects below cull_pixels
     * skipped (0 -> 0.5), and those farther than mesh_distance_m (0 = no limit; the haze and
     * falling snow hide them) */
    float lod_pixels, cull_pixels, mesh_distance_m;
    const char *egl_device; /* NULL: surfaceless platform, else "device" platform hint */
    /* false: the renderer opens its own headless EGL context (as `squall render` does).
     * true: it uses the OpenGL 4.5 core context current on the calling thread, which the
     * caller created and keeps current for every later call on this renderer (create, draw,
     * read, destroy); egl_device is ignored. The renderer then restores the caller's GL state
     * after each call (see "GL state" below). width/height 0 are allowed: the internal frame
     * takes the size of each sq_renderer_draw_to target. */
    bool use_current_context;
    /* interruption besides the context's (sq_context_cancel, sq_context_desc.interrupt): polled
     * with it between the passes of a frame and the parts of its long ones (and between the
     * passes' creation in sq_renderer_create); returning true ends the call with
     * SQ_ERR_CANCELLED, the frame not finished. Called on the drawing thread. NULL: none. */
    bool (*cancel)(void *user);
    void *cancel_user;
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

/* Creates a renderer: opens its own headless EGL context (or takes the caller's current one,
 * use_current_context), compiles the shaders and allocates the frame. SQ_ERR_UNSUPPORTED in a
 * build without GL; SQ_ERR_GL when no OpenGL 4.5 core context can be had (the message lists
 * what was tried); SQ_ERR_INVALID_ARG for a bad desc (the message names the field). */
SQ_API sq_result sq_renderer_create(sq_context *ctx, const sq_render_desc *desc,
                                    sq_renderer **out);
/* Frees the GL objects (in the caller's context with use_current_context: make it current
 * first) and the renderer's own context. NULL accepted. */
SQ_API void sq_renderer_destroy(sq_renderer *r);
/* Strings and limits of the renderer's GL context. */
SQ_API sq_result sq_renderer_info(const sq_renderer *r, sq_render_info *out);
/* Changes the look of later draws as sq_render_desc sets it at create: exposure (finite, > 0),
 * volume_slices (1..4096; 0 keeps either number) and volume_noise. Call it on the drawing
 * thread. The light buffer size is fixed at create. */
SQ_API sq_result sq_renderer_set_look(sq_renderer *r, float exposure, int volume_slices,
                                      bool volume_noise);
/* Opens a headless GL context only to report its strings and limits (for `squall info`). */
SQ_API sq_result sq_gl_probe(sq_context *ctx, sq_render_info *out);

/* Draws one frame: sky, terrain, obstacles, surfaces, volumes, particles. time_s animates
 * noise and jitter. Fails with SQ_ERR_INVALID_ARG for a camera inside terrain or a volume with
 * NaN density (reported, not rendered). */
SQ_API sq_result sq_renderer_draw(sq_renderer *r, const sq_world *world, const sq_camera *camera,
                                  const sq_drawable *drawables, int count, double time_s);
/* What the last sq_renderer_draw / sq_renderer_draw_to drew (for benchmarks such as `squall bench
 * snow-cover`): mesh faces and instances over all its views (camera, shadow cascades, snow
 * occlusion map), the faces of the camera view alone, and the time of the sun's shadow cascades
 * (CPU, GL work may be queued) and of the snow occlusion map (GL finished; 0 without snow). */
typedef struct sq_render_stats {
    int64_t faces, instances;
    int64_t camera_faces, camera_instances;
    double ms_shadow, ms_occlusion_map;
    int shadow_cascades_drawn; /* of the cascades: the others kept the map of an earlier frame */
    int cloud_impostors_rendered; /* cloud impostors (re-)rendered in this draw (the others
                                     were drawn from their texture of an earlier frame) */
    int64_t terrain_faces, camera_terrain_faces; /* terrain triangles drawn (tiles in view) */
    double cpu_ms_occlusion_map; /* CPU time of the process (all threads: a software rasteriser's
                                    too) while the occlusion map was drawn; 0 when none was */
} sq_render_stats;
/* Fills out with the statistics above for the last draw. */
SQ_API sq_result sq_renderer_stats(const sq_renderer *r, sq_render_stats *out);

/* ---- drawing into the caller's framebuffer --------------------------------------------------
 * With a renderer created with use_current_context, sq_renderer_draw_to draws into a framebuffer
 * object of the caller's context (or its default framebuffer, 0).
 *
 * Target framebuffer: single-sampled (resolve multisampled buffers first), complete, with a colour
 * buffer (input: its read buffer; output: its draw buffer 0; COLOR_ATTACHMENT0 unless the caller
 * changed them) in a float or normalised format (not integer), and a depth buffer (any depth or
 * depth-stencil format; required for SQ_TARGET_DRAWABLES_OVER). The frame covers pixels (0, 0) to
 * (width, height) of it. The caller's depth must come from the same camera: draw your geometry
 * with sq_camera_view() and sq_camera_proj(camera, width/height) of the sq_camera you pass here
 * (standard depth: glDepthRange(0, 1), glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE)).
 *
 * Colour: SQ_TARGET_LINEAR treats the colour buffer as linear scene radiance in the units of the
 * world's sun and sky (an HDR buffer the caller tone-maps; exposure is not applied);
 * SQ_TARGET_DISPLAY treats it as display colour, tone-mapped with Squall's curve (exposure, ACES
 * fit, sRGB encoding as stored values; an 8-bit buffer is fine): drawables are composited in
 * linear radiance after inverting that curve, and the result is tone-mapped again, so that pixels
 * without any drawable keep their value. The alpha channel of the target is never written.
 *
 * Depth: SQ_TARGET_DRAWABLES_OVER tests every drawable against the target's depth (volumes end at
 * the caller's geometry, particles fade near it); surface drawables (deposited snow) are opaque
 * and write their depth into the target's depth buffer. SQ_TARGET_FRAME replaces colour and depth
 * with the whole frame (sky, terrain, obstacles, drawables).
 *
 * GL state: after every call on a use_current_context renderer the caller's state is as before:
 * framebuffer (draw, read) and renderbuffer bindings, viewport, scissor box, program and program
 * pipeline, vertex array, array / pixel pack / pixel unpack / uniform / shader-storage buffer
 * bindings (indexed 0..7 with their ranges), active texture and the 2D, 3D, 2D-array, cube-map and
 * buffer textures and the samplers of units 0..15, image units 0..7, the enables (blend, depth test,
 * cull face, scissor and stencil tests, polygon offset fill, framebuffer sRGB, rasterizer discard,
 * logic op, alpha to coverage, primitive restart, depth clamp, program point size, clip
 * distances 0..7), blend functions, equations and colour, depth function, mask and range, clip
 * control, colour and stencil write masks, polygon mode and offset, cull face mode, front face
 * and the pixel pack/unpack parameters. Not preserved: the contents of the target (written as
 * described above) and pending glGetError flags (the renderer reads and clears them). */
typedef enum sq_target_content {
    SQ_TARGET_FRAME = 0,          /* the whole frame: sky, terrain, obstacles and drawables */
    SQ_TARGET_DRAWABLES_OVER = 1  /* only the drawables, over the target's colour and depth */
} sq_target_content;

typedef enum sq_target_colour {
    SQ_TARGET_LINEAR = 0,  /* linear radiance (HDR): the caller tone-maps */
    SQ_TARGET_DISPLAY = 1  /* tone-mapped display colour (Squall's curve and exposure) */
} sq_target_colour;

typedef struct sq_render_target {
    unsigned framebuffer;      /* GL framebuffer object name; 0 = the default framebuffer */
    int width, height;         /* pixels drawn, from (0, 0); both >= 1 */
    sq_target_content content;
    sq_target_colour colour;
} sq_render_target;

/* Draws drawables (and with SQ_TARGET_FRAME the world) for camera into target, in the caller's
 * context: see above. The renderer must have been created with use_current_context and the same
 * context must be current. Errors: SQ_ERR_INVALID_ARG for a bad target (the message names the
 * field and the rule: size, incomplete or multisampled framebuffer, integer colour, missing
 * depth), for a camera or drawable the renderer refuses (as sq_renderer_draw); SQ_ERR_GL for a
 * GL failure (the text names the pass). Nothing of the target is written on an argument error. */
SQ_API sq_result sq_renderer_draw_to(sq_renderer *r, const sq_render_target *target,
                                     const sq_world *world, const sq_camera *camera,
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
