/* test_clouds_compare.c — the same cloud field three ways (issue 10): the particle mode (Harris
 * multiple forward scattering + the diffuse term, billboards; src/render/render_clouds.c), the
 * volume mode (the field voxelised and drawn by half-angle slicing) and the unbiased reference
 * path tracer on that volume. Frames are tone mapped with the shared curve and compared by mean
 * SSIM and mean LDR-FLIP (67 ppd), as tests/reference/test_reference_compare.c does. Recorded
 * floors/ceilings are the first accepted run's values rounded outward (docs/phen/clouds.md);
 * the ablation (Harris only: no diffuse light) must score worse than the full particle lighting
 * against the reference. Set SQ_COMPARE_DUMP=<dir> to write the frames as PFM. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sq_test.h"
#include "squall/clouds.h"
#include "squall/image.h"
#include "squall/render.h"
#include "squall/world.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

#ifndef CW
#define CW 96
#define CH 64
#endif
#define REF_SPP 256

static sq_context *new_ctx(void)
{
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

static sq_world *new_world(sq_context *ctx, float sun_az_deg, float sun_el_deg)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 40000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.sky.turbidity = 2.0f;
    const double el = (double)sun_el_deg * 3.14159265358979 / 180.0;
    const double az = (double)sun_az_deg * 3.14159265358979 / 180.0;
    wd.sun.direction =
        sq_v3((float)(cos(el) * cos(az)), (float)(cos(el) * sin(az)), (float)sin(el));
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

/* One fair-weather cumulus (analytic field, 4 km square, base 800 m, up to 1.8 km deep) of
 * moderate water (0.25 g/m³ peak). */
static sq_clouds *new_clouds(sq_context *ctx, const sq_world *w, bool harris_only)
{
    sq_clouds_desc d;
    memset(&d, 0, sizeof d);
    d.source = SQ_CLOUDS_SOURCE_CUMULUS;
    d.synthetic_clouds = 1;
    d.synthetic_size_m[0] = d.synthetic_size_m[1] = 4000.0;
    d.synthetic_size_m[2] = 2000.0;
    d.synthetic_cells[0] = d.synthetic_cells[1] = 40;
    d.synthetic_cells[2] = 24;
    d.synthetic_lwc_g_m3 = 0.25;
    d.particles = 8000;
    d.plain = true;
    d.harris_only = harris_only;
    d.volume_cells[0] = d.volume_cells[1] = 64;
    d.volume_cells[2] = 32;
    d.seed = 4;
    sq_clouds *c = NULL;
    SQ_CHECK_OK(sq_clouds_create(ctx, &d, w, &c));
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

static bool gl_frame(sq_context *ctx, const sq_world *w, const sq_camera *cam,
                     const sq_drawable *d, const char *name, uint8_t *rgba)
{
    sq_render_desc rd = {0};
    rd.width = CW;
    rd.height = CH;
    rd.seed = 3;
    sq_renderer *r = NULL;
    sq_result res = sq_renderer_create(ctx, &rd, &r);
    SQ_CHECK_OK(res);
    if (res != SQ_OK) return false;
    float *rgb = malloc(sizeof(float) * CW * CH * 3);
    SQ_CHECK_OK(sq_renderer_draw(r, w, cam, d, 1, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, rgb));
    dump(name, rgb);
    sq_tonemap_rgba8(rgb, CW, CH, 1.0f, rgba);
    free(rgb);
    sq_renderer_destroy(r);
    return true;
}

typedef struct scores {
    double ssim_particles, ssim_volume, ssim_harris;
    double flip_particles, flip_volume, flip_harris;
} scores;

static scores compare(float sun_az, float sun_el, const char *tag)
{
    scores s;
    memset(&s, 0, sizeof s);
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, sun_az, sun_el);
    sq_clouds *c = new_clouds(ctx, w, false), *ch = new_clouds(ctx, w, true);
    if (!c || !ch) return s;
    sq_camera cam = {0};
    cam.position_m = sq_v3(-2300.0f, -1800.0f, 900.0f);
    cam.target_m = sq_v3(0.0f, 0.0f, 1500.0f);
    cam.fov_y_deg = 50.0f;
    cam.near_m = 5.0f;
    cam.far_m = 60000.0f;
    sq_drawable particles, harris, volume;
    SQ_CHECK_OK(sq_clouds_drawable(c, &particles));
    SQ_CHECK_OK(sq_clouds_drawable(ch, &harris));
    SQ_CHECK_OK(sq_clouds_volume_drawable(c, &volume));
    uint8_t *ref = malloc(CW * CH * 4), *gl = malloc(CW * CH * 4);
    float *rgb = malloc(sizeof(float) * CW * CH * 3);
    sq_reference_desc rd = {0};
    rd.width = CW;
    rd.height = CH;
    rd.samples = REF_SPP;
    rd.seed = 11;
    SQ_CHECK_OK(sq_reference_render(ctx, &rd, w, &cam, &volume, 1, rgb));
    char name[64];
    snprintf(name, sizeof name, "%s_ref", tag);
    dump(name, rgb);
    sq_tonemap_rgba8(rgb, CW, CH, 1.0f, ref);
    snprintf(name, sizeof name, "%s_particles", tag);
    if (gl_frame(ctx, w, &cam, &particles, name, gl)) {
        s.ssim_particles = sq_image_ssim(gl, ref, CW, CH);
        s.flip_particles = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    snprintf(name, sizeof name, "%s_harris", tag);
    if (gl_frame(ctx, w, &cam, &harris, name, gl)) {
        s.ssim_harris = sq_image_ssim(gl, ref, CW, CH);
        s.flip_harris = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    snprintf(name, sizeof name, "%s_volume", tag);
    if (gl_frame(ctx, w, &cam, &volume, name, gl)) {
        s.ssim_volume = sq_image_ssim(gl, ref, CW, CH);
        s.flip_volume = sq_image_flip(ref, gl, CW, CH, 0.0);
    }
    printf("%s: SSIM particles %.4f, Harris-only particles %.4f, volume %.4f\n", tag,
           s.ssim_particles, s.ssim_harris, s.ssim_volume);
    printf("%s: FLIP particles %.4f, Harris-only particles %.4f, volume %.4f\n", tag,
           s.flip_particles, s.flip_harris, s.flip_volume);
    free(ref);
    free(gl);
    free(rgb);
    sq_clouds_destroy(c);
    sq_clouds_destroy(ch);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
    return s;
}

/* Thresholds from the first accepted run (2026-11-25, Mesa llvmpipe, 96 x 64, reference 256 spp
 * seed 11; seeds 12 and 13 within 0.004 SSIM and 0.002 FLIP of it): SSIM floors are the measured
 * values rounded down to two decimals, FLIP ceilings rounded up (docs/phen/clouds.md).
 *   sun behind:  SSIM particles 0.8981, Harris-only 0.9100, volume 0.9064;
 *                FLIP particles 0.1166, Harris-only 0.0897, volume 0.0952.
 *                Seen from the sunlit side the diffuse term brightens the cloud more than the
 *                reference does (cloud box mean radiance 0.27 vs 0.20): no ablation asserted.
 *   side-lit:    SSIM particles 0.8682, Harris-only 0.8466, volume 0.8400;
 *                FLIP particles 0.1329, Harris-only 0.1553, volume 0.1556.
 *                The shaded half is lit by diffuse light only: Harris-only (and the volume,
 *                whose light buffer is Harris's too) are darker than the reference (0.17 vs
 *                0.25), the full lighting 0.21. Margins asserted: 0.01, half the measured ones. */

/* Sun behind the camera, 40 degrees up: the lit faces of the clouds. */
SQ_TEST(particles_volume_reference_sun_behind)
{
    const scores s = compare(215.0f, 40.0f, "behind");
    SQ_CHECK(s.ssim_particles >= 0.89);
    SQ_CHECK(s.ssim_volume >= 0.90);
    SQ_CHECK(s.flip_particles <= 0.12);
    SQ_CHECK(s.flip_volume <= 0.10);
}

/* Sun low at the side (15 degrees up, 90 degrees from the view): self-shadowing and the
 * diffuse light decide the shaded halves. */
SQ_TEST(particles_volume_reference_side_lit)
{
    const scores s = compare(-50.0f, 15.0f, "side");
    SQ_CHECK(s.ssim_particles >= 0.86);
    SQ_CHECK(s.ssim_volume >= 0.83);
    SQ_CHECK(s.flip_particles <= 0.14);
    SQ_CHECK(s.flip_volume <= 0.16);
    SQ_CHECK(s.ssim_particles - s.ssim_harris >= 0.01);
    SQ_CHECK(s.flip_harris - s.flip_particles >= 0.01);
}
