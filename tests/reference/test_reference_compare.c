/* test_compare.c — the real-time renderer (half-angle slicing with Harris multiple forward
 * scattering, SPEC 3.3–3.4, and multiple-scattering octaves) against the unbiased reference path tracer on small scenes: a dust
 * blob over flat terrain, seen with the sun behind the camera and against the sun. Both frames
 * are tone mapped with the shared curve (sq_tonemap_rgba8) and compared by mean SSIM
 * (sq_image_ssim) and mean LDR-FLIP at 67 pixels per degree (sq_image_flip). A third scene,
 * optically thick forward-scattering dust lit from behind at the side, is where multiple forward
 * scattering decides the picture. The full renderer must reach a recorded SSIM floor and stay
 * under a recorded FLIP ceiling, and each ablation
 * (single_scatter_only with volume_octaves 1: no forward in-scatter in the light buffer and no
 * multiple-scattering octaves; isotropic_phase: g = 0)
 * must score worse (in both metrics) than the full renderer on the scenes where that
 * approximation matters.
 *
 * Thresholds were recorded from the first accepted run (see docs/validation.md). Set
 * SQ_COMPARE_DUMP=<dir> to write the frames as PFM for inspection. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sq_test.h"
#include "squall/image.h"
#include "squall/render.h"
#include "squall/world.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

#define CW 96
#define CH 64
#define REF_SPP 512

static sq_context *new_ctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 0;
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* Flat terrain 2 km wide, clean air, sun at the given elevation and azimuth. */
static sq_world *new_world(sq_context *ctx, float sun_az_deg, float sun_el_deg)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 2000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.sky.turbidity = 2.0f;
    const double el = (double)sun_el_deg * SQ_PI / 180.0, az = (double)sun_az_deg * SQ_PI / 180.0;
    wd.sun.direction = sq_v3((float)(cos(el) * cos(az)), (float)(cos(el) * sin(az)), (float)sin(el));
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

/* A lumpy dust blob, 48^3 cells in a 240 x 240 x 120 m box resting on the ground. */
typedef struct blob {
    float *density;
    sq_drawable drawable;
} blob;

/* The medium of a comparison scene: extinction per density unit, albedo and g per channel. */
typedef struct medium {
    float sigma_ext, albedo[3], g;
} medium;

static void blob_make(blob *b, const medium *m)
{
    const int n = 48, nz = 24;
    b->density = (float *)malloc(sizeof(float) * n * n * nz);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double x = (i + 0.5) / n * 2 - 1, y = (j + 0.5) / n * 2 - 1, z = (k + 0.5) / nz;
                double r2 = x * x + y * y;
                double lump = 0.75 + 0.25 * sin(9.0 * x + 2.0) * sin(7.0 * y + 1.0) * cos(6.0 * z);
                double v = exp(-2.5 * r2) * exp(-2.0 * z) * lump - 0.08;
                b->density[(k * n + j) * n + i] = (float)(v > 0.0 ? v : 0.0);
            }
    memset(&b->drawable, 0, sizeof b->drawable);
    b->drawable.kind = SQ_DRAWABLE_VOLUME;
    b->drawable.name = "dust";
    sq_volume_view *v = &b->drawable.u.volume;
    v->density = b->density;
    v->nx = v->ny = n;
    v->nz = nz;
    v->origin_m = sq_v3(-120, -120, 0);
    v->size_m = sq_v3(240, 240, 120);
    /* dust: nearly grey extinction, high single-scattering albedo with absorption in the blue
     * (SPEC 2.5: beta_sca / beta_ext 0.99-1; 3.6: the colour comes from the albedo), g = 0.7
     * (SPEC 2.6); sigma_ext 0.1 gives an optical depth about 12 through the core */
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = m->sigma_ext;
        v->g[c] = m->g;
        v->albedo[c] = m->albedo[c];
    }
    v->density_max = 1.0f;
    v->version = 1;
}

static sq_camera camera_for(float view_az_deg, float dist_m)
{
    sq_camera c = {0};
    const double az = (double)view_az_deg * SQ_PI / 180.0;
    c.target_m = sq_v3(0, 0, 30);
    c.position_m = sq_v3((float)(-(double)dist_m * cos(az)), (float)(-(double)dist_m * sin(az)),
                         60.0f);
    c.fov_y_deg = 45.0f;
    c.near_m = 0.5f;
    c.far_m = 20000.0f;
    return c;
}

static void dump(const char *name, const float *rgb)
{
    const char *dir = getenv("SQ_COMPARE_DUMP");
    if (!dir) return;
    char path[512];
    snprintf(path, sizeof path, "%s/%s.pfm", dir, name);
    sq_pfm_write(path, CW, CH, rgb, true);
}

/* GL frame, tone mapped from its linear read-back (the same curve as the reference). */
static bool gl_frame(sq_context *ctx, bool single, bool iso, const sq_world *w,
                     const sq_camera *cam, const sq_drawable *d, const char *name, uint8_t *rgba)
{
    sq_render_desc rd = {0};
    rd.width = CW;
    rd.height = CH;
    rd.single_scatter_only = single;
    rd.volume_ms = single ? SQ_VOLUME_MS_NONE : SQ_VOLUME_MS_DEFAULT; /* the ablation: no
                                                                        multiple scattering */
    rd.isotropic_phase = iso;
    rd.seed = 3;
    sq_renderer *r = NULL;
    sq_result res = sq_renderer_create(ctx, &rd, &r);
    SQ_CHECK_OK(res);
    if (res != SQ_OK) return false;
    float *rgb = (float *)malloc(sizeof(float) * CW * CH * 3);
    SQ_CHECK_OK(sq_renderer_draw(r, w, cam, d, 1, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, rgb));
    dump(name, rgb);
    sq_tonemap_rgba8(rgb, CW, CH, 1.0f, rgba);
    free(rgb);
    sq_renderer_destroy(r);
    return true;
}

static void ref_frame(sq_context *ctx, const sq_world *w, const sq_camera *cam,
                      const sq_drawable *d, const char *name, uint8_t *rgba)
{
    sq_reference_desc rd = {0};
    rd.width = CW;
    rd.height = CH;
    rd.samples = REF_SPP;
    rd.seed = 11;
    float *rgb = (float *)malloc(sizeof(float) * CW * CH * 3);
    SQ_CHECK_OK(sq_reference_render(ctx, &rd, w, cam, d, 1, rgb));
    dump(name, rgb);
    sq_tonemap_rgba8(rgb, CW, CH, 1.0f, rgba);
    free(rgb);
}

/* the dust of the first two scenes: nearly grey extinction, albedo with absorption in the blue
 * (SPEC 2.5, 3.6), g = 0.7 (SPEC 2.6) */
static const medium dust = {0.1f, {0.97f, 0.89f, 0.78f}, 0.7f};

typedef struct scores {
    double full, single, iso;             /* SSIM (1 = identical) */
    double flip_full, flip_single, flip_iso; /* mean LDR-FLIP (0 = identical), 67 ppd */
} scores;

static scores compare_scene(float sun_az, float sun_el, float view_az, float dist_m,
                            const medium *m, const char *tag)
{
    scores s = {0, 0, 0, 0, 0, 0};
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, sun_az, sun_el);
    blob b;
    blob_make(&b, m);
    sq_camera cam = camera_for(view_az, dist_m);
    uint8_t *ref = (uint8_t *)malloc(CW * CH * 4), *gl = (uint8_t *)malloc(CW * CH * 4);
    char name[64];
    snprintf(name, sizeof name, "%s_ref", tag);
    ref_frame(ctx, w, &cam, &b.drawable, name, ref);
    snprintf(name, sizeof name, "%s_gl", tag);
    if (gl_frame(ctx, false, false, w, &cam, &b.drawable, name, gl)) {
        s.full = sq_image_ssim(gl, ref, CW, CH);
        s.flip_full = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    snprintf(name, sizeof name, "%s_gl_single", tag);
    if (gl_frame(ctx, true, false, w, &cam, &b.drawable, name, gl)) {
        s.single = sq_image_ssim(gl, ref, CW, CH);
        s.flip_single = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    snprintf(name, sizeof name, "%s_gl_iso", tag);
    if (gl_frame(ctx, false, true, w, &cam, &b.drawable, name, gl)) {
        s.iso = sq_image_ssim(gl, ref, CW, CH);
        s.flip_iso = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    printf("%s: SSIM full %.4f, single-scatter ablation %.4f, isotropic ablation %.4f\n", tag,
           s.full, s.single, s.iso);
    printf("%s: FLIP full %.4f, single-scatter ablation %.4f, isotropic ablation %.4f\n", tag,
           s.flip_full, s.flip_single, s.flip_iso);
    free(ref);
    free(gl);
    free(b.density);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
    return s;
}

/* Thresholds from the first accepted runs (2026-11-21, Mesa llvmpipe, 128 slices, reference
 * 512 spp, seed 11), see docs/validation.md. SSIM floors are the measured values rounded down to
 * two decimals, FLIP ceilings the measured values rounded up to two decimals. With the
 * multiple-scattering octaves (issue 12, 2026-11-28; seeds 11 / 12 / 13):
 *   sun behind:   SSIM full 0.9338 / 0.9350 / 0.9332, FLIP 0.0924 (all three): within the
 *                 floors below, 0.0016 SSIM and 0.0011 FLIP worse than without octaves.
 *   against sun:  SSIM full 0.9532 (all three), FLIP 0.0896 / 0.0893 / 0.0898: floor raised to
 *                 0.95, ceiling lowered to 0.10 (0.09 would leave 0.0002 of margin).
 *   side-lit:     SSIM full 0.7531 / 0.7557 / 0.7556, FLIP 0.2187 / 0.2181 / 0.2164: floor
 *                 raised to 0.75, ceiling lowered to 0.22.
 * With the ambient attenuated inside the medium (volume_sky.c, the default since 2026-11-28;
 * seed 11): sun behind SSIM 0.9404, FLIP 0.0817 (better: the uniform ambient made the blob too
 * bright); against the sun 0.9516, 0.0908; side-lit 0.7516, 0.2188 (within 0.0016 SSIM and
 * 0.0012 FLIP of the values above, inside the floors; docs/validation.md "Ambient light inside
 * the medium").
 * The first run's values:
 * With multiple scattering by diffusion instead of the octaves (render_internal.h,
 * sq__volume_ms_diffusion; the default since 2026-11-28, seed 11): sun behind SSIM 0.9406,
 * FLIP 0.0816; against the sun 0.9543, 0.0801; side-lit 0.7428 (0.0088 below the octaves),
 * FLIP 0.2070 (0.0118 better): the side-lit floor lowered to 0.74, its ceiling to 0.21.
 *   sun behind:   SSIM full 0.9354, single 0.9352, iso 0.8855; FLIP full 0.0913, single 0.0910,
 *                 iso 0.1220. The single-scatter ablation is equal within noise (Harris forward
 *                 scattering carries light away from this viewer), so only iso is asserted.
 *   against sun:  SSIM full 0.9457, single 0.9431, iso 0.9193; FLIP full 0.1015, single 0.1040,
 *                 iso 0.1238 (reference seeds 12, 13: full - single stays 0.0025 in FLIP,
 *                 0.0025 +- 0.0002 in SSIM).
 *   side-lit thick forward-scattering dust: see thick_dust_lit_from_behind_at_the_side. */
SQ_TEST(dust_blob_sun_behind_camera)
{
    /* view azimuth 30 deg, sun at azimuth 210 deg behind the camera: back-scatter side */
    scores s = compare_scene(210.0f, 35.0f, 30.0f, 420.0f, &dust, "behind");
    SQ_CHECK(s.full >= 0.93);
    SQ_CHECK(s.full > s.iso);
    SQ_CHECK(s.flip_full <= 0.10);
    SQ_CHECK(s.flip_full < s.flip_iso);
}

SQ_TEST(dust_blob_against_the_sun)
{
    /* view azimuth 30 deg toward a sun at azimuth 30 deg, 35 deg up: forward-scatter side,
     * where the light buffer's multiple forward scattering matters */
    scores s = compare_scene(30.0f, 35.0f, 30.0f, 420.0f, &dust, "ahead");
    SQ_CHECK(s.full >= 0.95);
    SQ_CHECK(s.full > s.single);
    SQ_CHECK(s.full > s.iso);
    SQ_CHECK(s.flip_full <= 0.10);
    SQ_CHECK(s.flip_full < s.flip_single);
    SQ_CHECK(s.flip_full < s.flip_iso);
}

/* The scene where multiple forward scattering carries the light: the same blob, optically thick
 * (sigma_ext 0.1 per density unit, optical depth ~12 through the core), grey and nearly
 * conservative (albedo 0.99) with a strong forward peak (g = 0.9, large grains), seen from
 * 220 m so that it fills the frame, with the sun low (10 deg) behind the blob and 30 deg to the
 * side of the view. The part of the blob away from the sun is lit only by light that crossed
 * the blob: single scattering leaves it in shadow, the Harris light buffer carries the forward
 * in-scatter (about half of the scattered light within its 0.09 sr cone at g = 0.9) into it, as
 * the reference's full multiple scattering does.
 * First accepted run (seed 11): SSIM full 0.7259, single 0.7047, iso 0.6741; FLIP full 0.2557,
 * single 0.2714, iso 0.3146. Reference seeds 12-14: SSIM full 0.7253-0.7281 with
 * full - single 0.0212-0.0219; FLIP full 0.2538-0.2560 with single - full 0.0151-0.0158. The
 * margins asserted (0.01 in both) are about half of the measured ones and 10x their spread. The
 * absolute agreement is lower than in the other scenes: the reference is noisy at 512 spp for
 * g = 0.9 (fireflies from the forward peak). The multiple-scattering octaves (its non-forward
 * multiple scattering, approximately) raised SSIM to 0.7531 and lowered FLIP to 0.2187 (seed
 * 11; the asserted floor and ceiling are from those, see above); the ablation then has neither
 * the forward in-scatter nor the octaves. */
SQ_TEST(thick_dust_lit_from_behind_at_the_side)
{
    static const medium thick = {0.1f, {0.99f, 0.99f, 0.99f}, 0.9f};
    scores s = compare_scene(60.0f, 10.0f, 30.0f, 220.0f, &thick, "side");
    SQ_CHECK(s.full >= 0.74);
    SQ_CHECK(s.flip_full <= 0.21);
    SQ_CHECK(s.full - s.single >= 0.01);
    SQ_CHECK(s.flip_single - s.flip_full >= 0.01);
    SQ_CHECK(s.full > s.iso);
    SQ_CHECK(s.flip_full < s.flip_iso);
}
