/* test_render.c — the base GL renderer on headless Mesa llvmpipe: known scenes judged by the
 * shading model (sky gradient, Lambert cosine law, depth occlusion, sun disc position, haze),
 * the tone curve (GL against CPU), surfaces, the geometry cache, and every refusal (frame size,
 * camera in the terrain, NaN volumes, broken shaders, no GL at all). Worlds are built by hand
 * so that every radiance is known. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"
#include "render/tonemap_internal.h"
#include "sq_test.h"
#include "squall/render.h"
#include "squall/world.h"
#include "world/world_struct.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

#define W 320
#define H 180

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) {
        fprintf(stderr, "context: %s\n", sq_last_error());
        exit(1);
    }
    return ctx;
}

/* A flat n x n world of side size_m at height z0 with a known sun and sky. */
static sq_world *make_world(int n, float size_m, float z0)
{
    sq_world *w = calloc(1, sizeof *w);
    w->nx = w->ny = n;
    w->dx = w->dy = size_m / (float)(n - 1);
    w->origin = sq_v3(-0.5f * size_m, -0.5f * size_m, 0.0f);
    w->heights = calloc((size_t)n * (size_t)n, sizeof(float));
    w->normals = calloc((size_t)n * (size_t)n * 3, sizeof(float));
    for (int c = 0; c < n * n; c++) {
        w->heights[c] = z0;
        w->normals[3 * c + 2] = 1.0f;
    }
    w->height_min = w->height_max = z0;
    w->terrain_kind = SQ_TERRAIN_FLAT;
    w->sun_dir = sq_v3_norm(sq_v3(0.0f, -0.6f, 0.8f)); /* south, behind a camera looking north */
    w->sun_radiance = sq_v3(0.9f, 0.85f, 0.8f);
    w->sky_zenith = sq_v3(0.08f, 0.13f, 0.25f);
    w->sky_horizon = sq_v3(0.20f, 0.21f, 0.23f);
    w->ground_albedo = sq_v3(0.3f, 0.3f, 0.3f);
    w->turbidity = 1.0f; /* clean air: no haze glow */
    w->generation = 1;
    return w;
}

static void free_world(sq_world *w)
{
    if (!w) return;
    free(w->heights);
    free(w->normals);
    free(w);
}

static sq_renderer *make_renderer(sq_context *ctx, int width, int height)
{
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.width = width;
    d.height = height;
    sq_renderer *r = NULL;
    sq_result res = sq_renderer_create(ctx, &d, &r);
    if (res != SQ_OK) {
        fprintf(stderr, "renderer: %s\n", sq_last_error());
        exit(1);
    }
    return r;
}

/* Camera looking horizontally north from (x, y, z). */
static sq_camera north_camera(float x, float y, float z)
{
    sq_camera c;
    memset(&c, 0, sizeof c);
    c.position_m = sq_v3(x, y, z);
    c.target_m = sq_v3(x, y + 100.0f, z);
    c.fov_y_deg = 50.0f;
    return c;
}

/* Unit view direction through the centre of pixel (px, py) (row 0 at the top) of a camera
 * looking north (right = east, up = z). */
static sq_vec3 north_ray(int px, int py, int width, int height, float fov_deg)
{
    const float t = tanf(0.5f * fov_deg * SQ_PI_F / 180.0f);
    const float nx = ((float)px + 0.5f) / (float)width * 2.0f - 1.0f;
    const float ny = 1.0f - ((float)py + 0.5f) / (float)height * 2.0f;
    return sq_v3_norm(sq_v3(nx * t * (float)width / (float)height, 1.0f, ny * t));
}

/* Pixel (column, row from the top) where direction d lands for a camera looking north. */
static void project_north(sq_vec3 d, int width, int height, float fov_deg, float *x, float *y)
{
    const float t = tanf(0.5f * fov_deg * SQ_PI_F / 180.0f);
    *x = (d.x / d.y / (t * (float)width / (float)height) + 1.0f) * 0.5f * (float)width;
    *y = (1.0f - d.z / d.y / t) * 0.5f * (float)height;
}

static float *render_linear(sq_renderer *r, const sq_world *w, const sq_camera *cam,
                            const sq_drawable *d, int count, int width, int height)
{
    float *rgb = malloc((size_t)width * (size_t)height * 3 * sizeof(float));
    SQ_CHECK_OK(sq_renderer_draw(r, w, cam, d, count, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, rgb));
    return rgb;
}

static const float *px(const float *rgb, int width, int x, int y)
{
    return rgb + 3 * ((size_t)y * (size_t)width + (size_t)x);
}

/* Mean of channel c over a rectangle. */
static double mean_rect(const float *rgb, int width, int x0, int y0, int x1, int y1, int c)
{
    double s = 0.0;
    int n = 0;
    for (int y = y0; y < y1; y++)
        for (int x = x0; x < x1; x++) {
            s += px(rgb, width, x, y)[c];
            n++;
        }
    return s / n;
}

/* ---- sky ---------------------------------------------------------------------------------- */
/* Above the horizon the sky is mix(zenith, horizon, (1 - mu)^3) for view elevation sine mu
 * (clean air: no haze glow); checked against that formula along a column. */
SQ_TEST(sky_gradient_matches_model)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, W, H);
    sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    cam.target_m = sq_v3(0.0f, -400.0f, 40.0f); /* tilted up ~11 degrees: more sky */
    float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
    /* ray through a pixel of the tilted camera */
    const sq_vec3 f = sq_v3_norm(sq_v3_sub(cam.target_m, cam.position_m));
    const sq_vec3 right = sq_v3_norm(sq_v3_cross(f, sq_v3(0, 0, 1)));
    const sq_vec3 up = sq_v3_cross(right, f);
    const float t = tanf(25.0f * SQ_PI_F / 180.0f);
    double worst = 0.0;
    int checked = 0;
    for (int y = 0; y < H; y += 6) {
        const int x = W / 2 + 37;
        const float ny = 1.0f - ((float)y + 0.5f) / H * 2.0f;
        const float nx = ((float)x + 0.5f) / W * 2.0f - 1.0f;
        const sq_vec3 d = sq_v3_norm(sq_v3_add(
            f, sq_v3_add(sq_v3_scale(right, nx * t * W / H), sq_v3_scale(up, ny * t))));
        if (d.z < 0.01f) continue; /* ground and the sky just above it */
        const float k = (1.0f - d.z) * (1.0f - d.z) * (1.0f - d.z);
        const sq_vec3 e = sq_v3_lerp(w->sky_zenith, w->sky_horizon, k);
        const float *p = px(rgb, W, x, y);
        const float ev[3] = {e.x, e.y, e.z};
        for (int c = 0; c < 3; c++) {
            const double rel = fabs(p[c] - ev[c]) / ev[c];
            if (rel > worst) worst = rel;
            SQ_CHECK_REL(p[c], ev[c], 0.01);
        }
        checked++;
    }
    printf("sky: %d rows checked, worst relative error %.2e\n", checked, worst);
    SQ_CHECK(checked >= 15);
    free(rgb);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* With a black sky the ground reflects only the sun: radiance = albedo * E * cos(zenith) *
 * detail * exp(-haze * distance), so between two sun elevations every ground pixel scales by
 * the ratio of the cosines. The absolute level matches the albedo within the detail noise. */
SQ_TEST(ground_follows_cosine_law)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    w->sky_zenith = w->sky_horizon = sq_v3(0.0f, 0.0f, 0.0f);
    w->ground_albedo = sq_v3(0.0f, 0.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    const float zen[2] = {20.0f, 65.0f};
    float *img[2];
    for (int k = 0; k < 2; k++) {
        const float z = zen[k] * SQ_PI_F / 180.0f;
        w->sun_dir = sq_v3(0.0f, -sinf(z), cosf(z));
        img[k] = render_linear(r, w, &cam, NULL, 0, W, H);
    }
    const double expect = cos(65.0 * SQ_PI / 180.0) / cos(20.0 * SQ_PI / 180.0);
    /* ground rows: from well below the horizon to the bottom */
    double s0 = 0.0, s1 = 0.0, worst = 0.0;
    for (int y = H / 2 + 10; y < H; y++)
        for (int x = 0; x < W; x++) {
            const double a = px(img[0], W, x, y)[1], b = px(img[1], W, x, y)[1];
            s0 += a;
            s1 += b;
            if (a > 1e-3) worst = fmax(worst, fabs(b / a - expect) / expect);
        }
    printf("cosine law: ratio %.5f expected %.5f, worst pixel %.2e\n", s1 / s0, expect, worst);
    SQ_CHECK_REL(s1 / s0, expect, 0.003);
    SQ_CHECK(worst < 0.01);
    /* absolute level: mean detail ~1, haze < 1 % at these distances */
    sq_vec3 flat, steep;
    sq_world kw;
    memset(&kw, 0, sizeof kw);
    kw.terrain_kind = SQ_TERRAIN_FLAT;
    sq__terrain_albedo(&kw, &flat, &steep);
    const double cos20 = cos(20.0 * SQ_PI / 180.0);
    const double mean_g = mean_rect(img[0], W, 0, H / 2 + 10, W, H, 1);
    printf("ground green %.4f, albedo * E * cos = %.4f\n", mean_g,
           flat.y * w->sun_radiance.y * cos20);
    SQ_CHECK_REL(mean_g, flat.y * w->sun_radiance.y * cos20, 0.12);
    for (int k = 0; k < 2; k++) free(img[k]);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* Below the horizon: lit grass (green over blue, the sun and sky terms of the model); above
 * it: the sky (blue over red). Near the horizon the sky is the horizon colour. */
SQ_TEST(ground_below_sky_above)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
    const float *sky = px(rgb, W, W / 2, H / 2 - 3);
    SQ_CHECK(sky[2] > sky[0]);
    SQ_CHECK_REL(sky[2], w->sky_horizon.z, 0.03);
    /* ground: mean over the lower rows against albedo * (E cos + sky ambient) */
    sq_vec3 flat, steep;
    sq_world kw;
    memset(&kw, 0, sizeof kw);
    kw.terrain_kind = SQ_TERRAIN_FLAT;
    sq__terrain_albedo(&kw, &flat, &steep);
    const sq_vec3 amb = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const double eg = flat.y * (w->sun_radiance.y * w->sun_dir.z + amb.y);
    const double g = mean_rect(rgb, W, 0, H - 40, W, H, 1);
    const double b = mean_rect(rgb, W, 0, H - 40, W, H, 2);
    printf("ground green %.4f expected %.4f; blue %.4f\n", g, eg, b);
    SQ_CHECK_REL(g, eg, 0.12);
    SQ_CHECK(g > b);
    free(rgb);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* The sun disc appears where the sun direction projects, and is the brightest thing in view. */
SQ_TEST(sun_disc_where_the_sun_is)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    /* sun 12 degrees above the horizon, 8 degrees east of north */
    const float el = 12.0f * SQ_PI_F / 180.0f, az = 8.0f * SQ_PI_F / 180.0f;
    w->sun_dir = sq_v3(cosf(el) * sinf(az), cosf(el) * cosf(az), sinf(el));
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
    int bx = 0, by = 0;
    float best = -1.0f;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            if (px(rgb, W, x, y)[1] > best) {
                best = px(rgb, W, x, y)[1];
                bx = x;
                by = y;
            }
    /* projection of the sun direction */
    const sq_vec3 s = w->sun_dir;
    float sx, sy;
    project_north(s, W, H, 50.0f, &sx, &sy);
    printf("brightest pixel (%d, %d) = %.1f; sun projects to (%.2f, %.2f)\n", bx, by,
           (double)best, (double)sx, (double)sy);
    SQ_CHECK_NEAR(bx + 0.5, sx, 1.5);
    SQ_CHECK_NEAR(by + 0.5, sy, 1.5);
    SQ_CHECK(best > 1000.0f);
    /* the ray through that pixel is within a disc radius (+ a pixel) of the sun */
    const sq_vec3 d = north_ray(bx, by, W, H, 50.0f);
    SQ_CHECK(acosf(sq_clampf(sq_v3_dot(d, s), -1.0f, 1.0f)) < 0.00465f + 0.0028f);
    free(rgb);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* Turbidity adds a forward-scattering glow: strong around the sun, weak far from it. */
SQ_TEST(haze_glow_around_the_sun)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    const float el = 15.0f * SQ_PI_F / 180.0f;
    w->sun_dir = sq_v3(0.0f, cosf(el), sinf(el));
    sq_renderer *r = make_renderer(ctx, W, H);
    sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    cam.fov_y_deg = 90.0f;
    float *clear = render_linear(r, w, &cam, NULL, 0, W, H);
    w->turbidity = 6.0f;
    float *hazy = render_linear(r, w, &cam, NULL, 0, W, H);
    /* 4 degrees east of the sun, and the top-left corner (~70 degrees from it) */
    const float az = 4.0f * SQ_PI_F / 180.0f;
    float fx, fy;
    project_north(sq_v3(cosf(el) * sinf(az), cosf(el) * cosf(az), sinf(el)), W, H, 90.0f, &fx,
                  &fy);
    const int xs = (int)fx, ys = (int)fy;
    const sq_vec3 corner = north_ray(0, 0, W, H, 90.0f);
    printf("near pixel (%d, %d); corner %.1f degrees from the sun\n", xs, ys,
           acos(sq_v3_dot(corner, w->sun_dir)) * 180.0 / SQ_PI);
    const double near_clear = px(clear, W, xs, ys)[1], near_hazy = px(hazy, W, xs, ys)[1];
    const double far_clear = px(clear, W, 0, 0)[1], far_hazy = px(hazy, W, 0, 0)[1];
    printf("near sun: %.4f -> %.4f; far: %.4f -> %.4f\n", near_clear, near_hazy, far_clear,
           far_hazy);
    /* forward-peaked: the glow added 4 degrees from the sun is many times what is added ~57
     * degrees away (HG g = 0.75 alone gives a factor ~38) */
    SQ_CHECK(near_hazy > 1.5 * near_clear);
    SQ_CHECK(far_hazy >= far_clear);
    SQ_CHECK(near_hazy - near_clear > 20.0 * (far_hazy - far_clear));
    free(clear);
    free(hazy);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* Mean of exp(-z / H) along a straight path between heights z0 and z1, in closed form (the
 * integral of an exponential profile), for the expectation below. */
#define HAZE_CAM_M 300.0f /* camera above the ground */

static double profile_mean(double z0, double z1, double scale)
{
    if (fabs(z1 - z0) < 1e-6 * scale) return exp(-z0 / scale);
    return scale * (exp(-z0 / scale) - exp(-z1 / scale)) / (z1 - z0);
}

/* Aerial haze falls off with altitude: air molecules (1e-5/m at sea level, scale height 8 km)
 * and turbidity's aerosol (2e-5/m per unit of T - 1, scale height 1.5 km). The same view of
 * flat ground 300 m below the camera, once at sea level and once at 6 km: with a black sky the
 * haze adds only its glow S (single scattering, known per direction), so a ground pixel is
 * S + exp(-tau) (L_ground - S) and the two frames differ by exp(tau_sea - tau_6km) per pixel,
 * tau = distance x sum beta_0 x (mean of exp(-z/H) along the ray). A uniform haze (no fall-off)
 * gives a ratio of 1. */
SQ_TEST(haze_falls_off_with_altitude)
{
    sq_context *ctx = make_ctx();
    const float z0[2] = {0.0f, 6000.0f};
    const float turbidity = 4.0f;
    const float el = 30.0f * SQ_PI_F / 180.0f;
    sq_renderer *r = make_renderer(ctx, W, H);
    float *img[2];
    sq_world *w[2];
    for (int k = 0; k < 2; k++) {
        w[k] = make_world(65, 400000.0f, z0[k]);
        w[k]->sky_zenith = w[k]->sky_horizon = sq_v3(0.0f, 0.0f, 0.0f);
        w[k]->ground_albedo = sq_v3(0.0f, 0.0f, 0.0f);
        w[k]->turbidity = turbidity;
        w[k]->sun_dir = sq_v3(0.0f, -cosf(el), sinf(el)); /* behind the camera */
        sq_camera cam = north_camera(0.0f, -150000.0f, z0[k] + HAZE_CAM_M);
        cam.near_m = 1.0f;
        cam.far_m = 300000.0f;
        img[k] = render_linear(r, w[k], &cam, NULL, 0, W, H);
    }
    const sq_vec3 sun = w[0]->sun_dir, E = w[0]->sun_radiance;
    int checked = 0;
    double worst = 0.0, largest = 0.0;
    for (int y = H / 2 + 1; y < H; y++) {
        /* a band of columns around the centre (the detail noise averages out; the distance
         * varies by < 0.2 % across it) */
        double sa = 0.0, sb = 0.0, want = 0.0;
        for (int x = W / 2 - 16; x <= W / 2 + 16; x++) {
            const sq_vec3 d = north_ray(x, y, W, H, 50.0f);
            const double dist = HAZE_CAM_M / -(double)d.z; /* to the ground */
            /* the glow toward the horizon-clamped direction (frame_common.glsl sq_haze) */
            const sq_vec3 dh = sq_v3_norm(sq_v3(d.x, d.y, 0.02f));
            const double c = sq_v3_dot(dh, sun), g = 0.75;
            const double hg = (1.0 - g * g) / (4.0 * SQ_PI * pow(1.0 + g * g - 2.0 * g * c, 1.5));
            const double tau_glow = 0.05 * (turbidity - 1.0) / 0.05;
            const double glow = SQ_PI * hg * (1.0 - exp(-tau_glow)) * 0.5 * E.y;
            double tau[2];
            for (int k = 0; k < 2; k++)
                tau[k] = dist * (1e-5 * profile_mean(z0[k] + HAZE_CAM_M, z0[k], 8000.0) +
                                 2e-5 * (turbidity - 1.0) *
                                     profile_mean(z0[k] + HAZE_CAM_M, z0[k], 1500.0));
            if (x == W / 2) {
                if (dist < 500.0 || dist > 60000.0) break;
                want = tau[0] - tau[1];
            }
            sa += px(img[0], W, x, y)[1] - glow;
            sb += px(img[1], W, x, y)[1] - glow;
        }
        if (!(want > 0.0) || !(sa > 1e-3)) continue;
        const double got = log(sb / sa);
        worst = fmax(worst, fabs(got - want) / want);
        largest = fmax(largest, want);
        checked++;
        if (checked % 8 == 1) printf("row %d: log ratio %.4f expected %.4f\n", y, got, want);
    }
    printf("%d rows, worst relative error %.3f, largest expected log ratio %.2f\n", checked, worst,
           largest);
    SQ_CHECK(checked >= 10);
    SQ_CHECK(largest > 1.0); /* the test can tell fall-off from none */
    SQ_CHECK(worst < 0.05);
    for (int k = 0; k < 2; k++) {
        free(img[k]);
        free_world(w[k]);
    }
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

/* ---- depth ------------------------------------------------------------------------------- */
static int dominant(const float *p) { return p[0] > p[1] && p[0] > p[2] ? 0 : (p[2] > p[1] ? 2 : 1); }

/* A near red box in front of a far blue one: red wins whatever the drawing order, blue shows
 * beside it, and the box hides the terrain behind it. */
SQ_TEST(obstacles_occlude_by_depth)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    w->sun_dir = sq_v3_norm(sq_v3(0.2f, -0.6f, 0.8f));
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, 0.0f, 10.0f);
    float *bare = render_linear(r, w, &cam, NULL, 0, W, H);
    sq_obstacle red, blue;
    memset(&red, 0, sizeof red);
    memset(&blue, 0, sizeof blue);
    red.kind = blue.kind = SQ_OBSTACLE_BOX;
    red.center_m = sq_v3(0.0f, 60.0f, 0.0f);
    red.size_m = sq_v3(8.0f, 4.0f, 30.0f);
    red.albedo = sq_v3(0.8f, 0.05f, 0.05f);
    blue.center_m = sq_v3(0.0f, 200.0f, 0.0f);
    blue.size_m = sq_v3(120.0f, 4.0f, 60.0f);
    blue.albedo = sq_v3(0.05f, 0.05f, 0.8f);
    for (int order = 0; order < 2; order++) {
        w->obstacles[0] = order ? red : blue;
        w->obstacles[1] = order ? blue : red;
        w->obstacle_count = 2;
        w->generation++;
        float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
        const float *centre = px(rgb, W, W / 2, H / 2 - 5);
        const float *beside = px(rgb, W, W / 2 + 40, H / 2 - 5);
        const float *ground = px(rgb, W, W / 2, H - 5);
        SQ_CHECK_MSG(dominant(centre) == 0, "order %d: centre (%g, %g, %g) is not red", order,
                     (double)centre[0], (double)centre[1], (double)centre[2]);
        SQ_CHECK_MSG(dominant(beside) == 2, "order %d: beside (%g, %g, %g) is not blue", order,
                     (double)beside[0], (double)beside[1], (double)beside[2]);
        /* the terrain in front of the boxes is untouched */
        for (int c = 0; c < 3; c++) SQ_CHECK_NEAR(ground[c], px(bare, W, W / 2, H - 5)[c], 1e-6);
        free(rgb);
    }
    /* the red box faces the camera's south side: lit by the sun from the south */
    w->obstacle_count = 1;
    w->obstacles[0] = red;
    w->generation++;
    float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
    const float *face = px(rgb, W, W / 2, H / 2 - 5);
    const sq_vec3 s = sq_v3_norm(w->sun_dir);
    const double expect = 0.8 * (w->sun_radiance.x * -(double)s.y); /* + small ambient */
    SQ_CHECK(face[0] > expect && face[0] < expect + 0.8 * 0.3);
    free(rgb);
    free(bare);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* A fence is porous: along a row through its middle the boards alternate with gaps. */
SQ_TEST(fence_is_porous)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    w->obstacle_count = 1;
    memset(&w->obstacles[0], 0, sizeof w->obstacles[0]);
    w->obstacles[0].kind = SQ_OBSTACLE_FENCE;
    w->obstacles[0].center_m = sq_v3(0.0f, 8.0f, 0.0f);
    w->obstacles[0].size_m = sq_v3(6.0f, 0.05f, 2.0f);
    w->obstacles[0].albedo = sq_v3(0.9f, 0.02f, 0.02f);
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, 0.0f, 1.0f);
    float *rgb = render_linear(r, w, &cam, NULL, 0, W, H);
    int runs = 0;
    bool in_board = false;
    for (int x = 0; x < W; x++) {
        const bool board = dominant(px(rgb, W, x, H / 2)) == 0;
        if (board && !in_board) runs++;
        in_board = board;
    }
    printf("fence: %d boards across the row\n", runs);
    SQ_CHECK(runs >= 20); /* 6 m of 15 cm board pitch = 40, some merge at this resolution */
    free(rgb);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* ---- surfaces ----------------------------------------------------------------------------- */
/* Snow over the west half of the view: bright where covered, the bare ground where not, the
 * average of both at coverage 0.5, and bluish when lit only by a grey sky. */
SQ_TEST(snow_surface_blends_by_coverage)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, W, H);
    sq_camera cam = north_camera(0.0f, -30.0f, 12.0f);
    cam.target_m = sq_v3(0.0f, 20.0f, 0.0f);
    enum { N = 41 };
    float height[N * N], cover[N * N];
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            height[j * N + i] = 0.05f;
            cover[j * N + i] = i < N / 2 ? 1.0f : 0.0f;
        }
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_SURFACE;
    d.name = "snow-cover";
    d.u.surface.nx = d.u.surface.ny = N;
    d.u.surface.origin_m = sq_v3(-40.0f, -20.0f, 0.0f);
    d.u.surface.dx_m = d.u.surface.dy_m = 2.0f;
    d.u.surface.height_m = height;
    d.u.surface.coverage = cover;
    d.u.surface.material = SQ_MATERIAL_SNOW;
    d.u.surface.version = 1;
    float *bare = render_linear(r, w, &cam, NULL, 0, W, H);
    float *half = render_linear(r, w, &cam, &d, 1, W, H);
    /* west (left) of the view is snow, east is bare ground exactly as without the surface */
    const double snow_g = mean_rect(half, W, 10, H - 40, 60, H - 10, 1);
    const double bare_g = mean_rect(bare, W, 10, H - 40, 60, H - 10, 1);
    printf("snow %.3f bare %.3f\n", snow_g, bare_g);
    SQ_CHECK(snow_g > 2.5 * bare_g);
    for (int y = H - 40; y < H - 10; y += 5)
        for (int x = W - 60; x < W - 10; x += 5)
            SQ_CHECK_NEAR(px(half, W, x, y)[1], px(bare, W, x, y)[1], 1e-6);
    /* coverage 0.5 everywhere: the linear blend of snow and ground */
    for (int c = 0; c < N * N; c++) cover[c] = 1.0f;
    d.u.surface.version = 2;
    float *full = render_linear(r, w, &cam, &d, 1, W, H);
    for (int c = 0; c < N * N; c++) cover[c] = 0.5f;
    d.u.surface.version = 3;
    float *mixed = render_linear(r, w, &cam, &d, 1, W, H);
    const double m = mean_rect(mixed, W, 100, H - 40, 220, H - 10, 1);
    const double f = mean_rect(full, W, 100, H - 40, 220, H - 10, 1);
    const double b = mean_rect(bare, W, 100, H - 40, 220, H - 10, 1);
    printf("coverage 0.5: %.4f, half of snow + ground: %.4f\n", m, 0.5 * (f + b));
    SQ_CHECK_REL(m, 0.5 * (f + b), 0.02);
    /* in shadow (sun below the horizon) under a grey sky, snow is slightly blue */
    w->sun_dir = sq_v3_norm(sq_v3(0.0f, -1.0f, -0.1f));
    w->sky_zenith = w->sky_horizon = sq_v3(0.2f, 0.2f, 0.2f);
    d.u.surface.version = 4;
    for (int c = 0; c < N * N; c++) cover[c] = 1.0f;
    float *shade = render_linear(r, w, &cam, &d, 1, W, H);
    const double sr = mean_rect(shade, W, 100, H - 40, 220, H - 10, 0);
    const double sb = mean_rect(shade, W, 100, H - 40, 220, H - 10, 2);
    printf("snow in shadow: red %.4f blue %.4f\n", sr, sb);
    SQ_CHECK(sb > 1.1 * sr);
    free(bare);
    free(half);
    free(full);
    free(mixed);
    free(shade);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* ---- caches ------------------------------------------------------------------------------- */
/* Changing the terrain and its generation rebuilds the mesh: a raised block appears; the sky
 * is unchanged. */
SQ_TEST(world_generation_rebuilds_terrain)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    float *a = render_linear(r, w, &cam, NULL, 0, W, H);
    for (int j = 20; j < 45; j++)
        for (int i = 20; i < 45; i++) w->heights[j * 65 + i] = 40.0f;
    w->height_max = 40.0f;
    w->generation++;
    float *b = render_linear(r, w, &cam, NULL, 0, W, H);
    int changed = 0;
    for (int x = 0; x < W; x++) changed += fabsf(px(a, W, x, H / 2 - 4)[2] - px(b, W, x, H / 2 - 4)[2]) > 1e-3f;
    SQ_CHECK(changed > W / 4); /* the block now rises above the horizon */
    SQ_CHECK_NEAR(px(a, W, 5, 5)[2], px(b, W, 5, 5)[2], 1e-6);
    free(a);
    free(b);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* ---- tone mapping ------------------------------------------------------------------------- */
SQ_TEST(tonemap_curve_properties)
{
    SQ_CHECK(sq__tonemap_channel(0.0f, 1.0f) == 0);
    SQ_CHECK(sq__tonemap_channel(-1.0f, 1.0f) == 0);
    SQ_CHECK(sq__tonemap_channel(NAN, 1.0f) == 0);
    SQ_CHECK(sq__tonemap_channel(1e6f, 1.0f) == 255);
    int prev = 0;
    for (int i = 0; i <= 4000; i++) {
        const int v = sq__tonemap_channel((float)i * 0.005f, 1.0f);
        SQ_CHECK(v >= prev);
        prev = v;
    }
    /* exposure scales the input: 0.2 at exposure 2 is 0.4 at exposure 1 */
    SQ_CHECK(sq__tonemap_channel(0.2f, 2.0f) == sq__tonemap_channel(0.4f, 1.0f));
    /* the Narkowicz fit at 0.18 (mid grey): 0.18(2.51*.18+.03)/(.18(2.43*.18+.59)+.14) */
    SQ_CHECK_NEAR(sq__tonemap_aces(0.18f), 0.18 * (2.51 * 0.18 + 0.03) /
                                               (0.18 * (2.43 * 0.18 + 0.59) + 0.14), 1e-6);
    for (int i = 0; i <= 100; i++) {
        const float x = (float)i / 100.0f;
        SQ_CHECK_NEAR(sq__srgb_decode(sq__srgb_encode(x)), x, 2e-6);
    }
    float rgb[6] = {0.0f, 0.18f, 1.0f, 100.0f, 0.5f, -2.0f};
    uint8_t out[8];
    sq_tonemap_rgba8(rgb, 2, 1, 1.0f, out);
    SQ_CHECK(out[0] == 0 && out[3] == 255 && out[4] == 255 && out[7] == 255 && out[6] == 0);
}

/* The GL tone-mapping pass and sq_tonemap_rgba8 agree to one 8-bit step on a whole frame,
 * and the 8-bit read-back has the top row first. */
SQ_TEST(tonemap_gl_matches_cpu)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(65, 2000.0f, 0.0f);
    w->obstacle_count = 1;
    memset(&w->obstacles[0], 0, sizeof w->obstacles[0]);
    w->obstacles[0].kind = SQ_OBSTACLE_HOUSE;
    w->obstacles[0].center_m = sq_v3(10.0f, 60.0f, 0.0f);
    w->obstacles[0].size_m = sq_v3(12.0f, 8.0f, 5.0f);
    w->obstacles[0].roof_m = 3.0f;
    w->obstacles[0].yaw_deg = 25.0f;
    w->sun_dir = sq_v3_norm(sq_v3(0.3f, 0.9f, 0.3f)); /* sun disc in view: saturated pixels */
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.width = W;
    d.height = H;
    d.exposure = 1.7f;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &d, &r));
    const sq_camera cam = north_camera(0.0f, 0.0f, 4.0f);
    float *lin = render_linear(r, w, &cam, NULL, 0, W, H);
    uint8_t *gl = malloc(W * H * 4), *cpu = malloc(W * H * 4);
    SQ_CHECK_OK(sq_renderer_read_rgba8(r, gl));
    sq_tonemap_rgba8(lin, W, H, 1.7f, cpu);
    int worst = 0, saturated = 0;
    for (int i = 0; i < W * H * 4; i++) {
        const int diff = abs((int)gl[i] - (int)cpu[i]);
        if (diff > worst) worst = diff;
        saturated += gl[i] == 255 && i % 4 != 3;
    }
    printf("GL vs CPU tone map: max difference %d (of 255); %d saturated channels\n", worst,
           saturated);
    SQ_CHECK(worst <= 1);
    SQ_CHECK(saturated > 0);
    /* top row first: the top row is sky (blue over red), the bottom row ground */
    SQ_CHECK(gl[4 * (W / 2) + 2] > gl[4 * (W / 2) + 0]);
    SQ_CHECK(gl[4 * ((H - 1) * W + W / 2) + 1] > gl[4 * ((H - 1) * W + W / 2) + 2]);
    free(gl);
    free(cpu);
    free(lin);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* ---- refusals ----------------------------------------------------------------------------- */
SQ_TEST(frame_size_refused)
{
    sq_context *ctx = make_ctx();
    sq_render_info info;
    SQ_CHECK_OK(sq_gl_probe(ctx, &info));
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    sq_renderer *r = make_renderer(ctx, 4, 4); /* overwritten with NULL on failure */
    sq_renderer *keep = r;
    d.width = -1;
    d.height = 100;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "must both be >= 1");
    SQ_CHECK(r == NULL);
    sq_renderer_destroy(keep);
    d.width = 0;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "frame size 0 x 100");
    /* one pixel more than the smallest GL limit */
    int limit = info.max_texture_size;
    if (info.max_renderbuffer_size < limit) limit = info.max_renderbuffer_size;
    if (info.max_viewport[0] < limit) limit = info.max_viewport[0];
    d.width = limit + 1;
    d.height = 16;
    char needle[64];
    snprintf(needle, sizeof needle, "= %d of", limit);
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, needle);
    SQ_CHECK(strstr(sq_last_error(), "GL_MAX_") != NULL);
    SQ_CHECK(strstr(sq_last_error(), "frame width") != NULL);
    d.width = 16;
    d.height = limit + 1;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "frame height");
    d.height = 16;
    d.volume_slices = 5000;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "volume_slices = 5000");
    d.volume_slices = 0;
    d.exposure = -1.0f;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "exposure");
    d.exposure = 0.0f;
    d.light_buffer_size = info.max_texture_size + 1;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_INVALID_ARG, "light_buffer_size");
    /* the smallest frame is fine; defaults resolve to 640 x 360 */
    d.light_buffer_size = 0;
    d.width = d.height = 1;
    SQ_CHECK_OK(sq_renderer_create(ctx, &d, &r));
    sq_renderer_destroy(r);
    SQ_CHECK_OK(sq_renderer_create(ctx, NULL, &r));
    SQ_CHECK(r && r->width == 640 && r->height == 360 && r->desc.volume_slices == 128 &&
             r->desc.light_buffer_size == 256 && r->desc.exposure == 1.0f);
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

SQ_TEST(camera_inside_terrain_refused)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(33, 200.0f, 10.0f);
    sq_renderer *r = make_renderer(ctx, 64, 36);
    sq_camera cam = north_camera(3.0f, -4.0f, 5.0f);
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_INVALID_ARG,
                 "camera at (3.00, -4.00, 5.00) is below the terrain surface (10.00 m)");
    cam = north_camera(3.0f, -4.0f, 10.05f);
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_INVALID_ARG, "within 0.1 m");
    /* outside the heightfield the edge is extended */
    cam = north_camera(500.0f, 0.0f, 9.0f);
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_INVALID_ARG, "below the terrain");
    cam = north_camera(3.0f, -4.0f, 10.2f);
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
    /* a camera that looks nowhere or along its up vector */
    cam.target_m = cam.position_m;
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_INVALID_ARG, "target equals");
    cam.target_m = sq_v3(3.0f, -4.0f, 0.0f);
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_INVALID_ARG, "up vector");
    cam.up = sq_v3(0.0f, 1.0f, 0.0f);
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

SQ_TEST(volume_nan_refused)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(33, 200.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, 64, 36);
    const sq_camera cam = north_camera(0.0f, -50.0f, 10.0f);
    float dens[4 * 3 * 5];
    for (int i = 0; i < 60; i++) dens[i] = 0.5f;
    sq_drawable d[2];
    memset(d, 0, sizeof d);
    d[0].kind = SQ_DRAWABLE_NONE;
    d[1].kind = SQ_DRAWABLE_VOLUME;
    d[1].name = "dust";
    sq_volume_view *v = &d[1].u.volume;
    v->density = dens;
    v->nx = 4;
    v->ny = 3;
    v->nz = 5;
    v->origin_m = sq_v3(-20.0f, 0.0f, 0.0f);
    v->size_m = sq_v3(40.0f, 30.0f, 50.0f);
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = 0.01f;
        v->albedo[c] = 0.9f;
        v->g[c] = 0.5f;
    }
    v->density_max = 0.5f;
    v->version = 1;
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, d, 2, 0.0));
    dens[2 + 4 * (1 + 3 * 3)] = NAN; /* cell (2, 1, 3) */
    v->version = 2;
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, d, 2, 0.0), SQ_ERR_INVALID_ARG,
                 "volume drawable \"dust\": density at cell (2, 1, 3) is nan");
    dens[2 + 4 * (1 + 3 * 3)] = 0.5f;
    dens[59] = INFINITY;
    v->version = 3;
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, d, 2, 0.0), SQ_ERR_INVALID_ARG, "(3, 2, 4) is inf");
    v->density = NULL;
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, d, 2, 0.0), SQ_ERR_INVALID_ARG, "density NULL");
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* Ctrl-C reaches a frame being drawn: the renderer polls the context between its passes and
 * between the parts of its long ones (terrain rows, volume slices), stops issuing work at the
 * first poll that asks to stop, and fails with SQ_ERR_CANCELLED; the next frame draws the same
 * picture as before. */
typedef struct poll_counter {
    int calls;
    int stop_at; /* the call that asks to stop; 0: never */
} poll_counter;

static bool count_polls(void *user)
{
    poll_counter *p = (poll_counter *)user;
    p->calls++;
    return p->stop_at > 0 && p->calls >= p->stop_at;
}

SQ_TEST(frame_answers_interrupt_between_parts)
{
    poll_counter pc = {0, 0};
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    cd.interrupt = count_polls;
    cd.interrupt_user = &pc;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    sq_world *w = make_world(129, 400.0f, 0.0f);
    sq_renderer *r = make_renderer(ctx, 64, 36);
    const sq_camera cam = north_camera(0.0f, -50.0f, 10.0f);
    float dens[8 * 8 * 8];
    for (int i = 0; i < 512; i++) dens[i] = 0.5f;
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_VOLUME;
    d.name = "dust";
    sq_volume_view *v = &d.u.volume;
    v->density = dens;
    v->nx = v->ny = v->nz = 8;
    v->origin_m = sq_v3(-20.0f, 0.0f, 0.0f);
    v->size_m = sq_v3(40.0f, 40.0f, 40.0f);
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = 0.01f;
        v->albedo[c] = 0.9f;
        v->g[c] = 0.5f;
    }
    v->density_max = 0.5f;
    v->version = 1;
    float *before = render_linear(r, w, &cam, &d, 1, 64, 36);
    /* the terrain (8 parts) and the volume's slices (16 parts) each poll after every part */
    const int polls = pc.calls;
    SQ_CHECK_MSG(polls >= 24, "one frame polled the interrupt %d times (>= 24: passes and parts)",
                 polls);
    const int stops[] = {1, 6, 20};
    for (int k = 0; k < 3; k++) {
        pc.calls = 0;
        pc.stop_at = stops[k];
        SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, &d, 1, 0.0), SQ_ERR_CANCELLED,
                     "interrupted while drawing a frame");
        /* nothing more was issued (nor polled) once it asked to stop */
        SQ_CHECK_MSG(pc.calls == stops[k], "asked to stop at poll %d, polled %d times", stops[k],
                     pc.calls);
    }
    pc.calls = 0;
    pc.stop_at = 0;
    float *after = render_linear(r, w, &cam, &d, 1, 64, 36);
    SQ_CHECK_MSG(memcmp(before, after, 64 * 36 * 3 * sizeof(float)) == 0,
                 "the frame after the interrupted ones differs from the first");
    free(before);
    free(after);
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* The caller's own interrupt (sq_render_desc.cancel, e.g. an engine's "abort frame") is polled
 * where the context's is: between passes and parts; asked to stop at poll k, the draw fails with
 * SQ_ERR_CANCELLED after exactly k polls. */
SQ_TEST(frame_answers_the_desc_cancel_between_parts)
{
    poll_counter pc = {0, 0};
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(129, 400.0f, 0.0f);
    sq_render_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.width = 64;
    rd.height = 36;
    rd.cancel = count_polls;
    rd.cancel_user = &pc;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    if (!r) goto done;
    const sq_camera cam = north_camera(0.0f, -50.0f, 10.0f);
    const int creation_polls = pc.calls;
    SQ_CHECK_MSG(creation_polls >= 1, "creation polled the desc's cancel %d times",
                 creation_polls);
    pc.calls = 0;
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
    const int polls = pc.calls;
    SQ_CHECK_MSG(polls >= 8, "one frame polled the desc's cancel %d times (>= 8: terrain parts)",
                 polls);
    const int stops[] = {1, 5};
    for (int k = 0; k < 2; k++) {
        pc.calls = 0;
        pc.stop_at = stops[k];
        SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0), SQ_ERR_CANCELLED,
                     "interrupted while drawing a frame");
        SQ_CHECK_MSG(pc.calls == stops[k], "asked to stop at poll %d, polled %d times", stops[k],
                     pc.calls);
    }
    pc.stop_at = 0;
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
done:
    sq_renderer_destroy(r);
    free_world(w);
    sq_context_destroy(ctx);
}

/* Ctrl-C reaches the creation of a renderer (compiling its programs takes seconds on llvmpipe):
 * with the context cancelled it fails with SQ_ERR_CANCELLED and returns no renderer; cleared,
 * it is created. */
SQ_TEST(renderer_creation_answers_interrupt)
{
    sq_context *ctx = make_ctx();
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.width = 64;
    d.height = 36;
    sq_renderer *r = NULL;
    sq_context_cancel(ctx);
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_CANCELLED,
                 "interrupted while compiling the renderer's shaders");
    SQ_CHECK(r == NULL);
    sq_context_cancel_clear(ctx);
    SQ_CHECK_OK(sq_renderer_create(ctx, &d, &r));
    SQ_CHECK(r != NULL);
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

/* Compile errors name the shader and the line, also after an #include (whose lines must not
 * shift the including file's numbering). */
SQ_TEST(broken_shader_names_file_and_line)
{
    sq_context *ctx = make_ctx();
    sq_renderer *r = make_renderer(ctx, 16, 16); /* makes a context current */
    GLuint sh = 0;
    const char *broken = "#version 450 core\n"
                         "out vec4 o;\n"
                         "void main() { o = vec4(1.0) }\n";
    SQ_CHECK_ERR(sq__gl_shader_compile(ctx, GL_FRAGMENT_SHADER, "broken.frag", broken, &sh),
                 SQ_ERR_GL, "broken.frag:3:");
    SQ_CHECK(strstr(sq_last_error(), "fragment shader broken.frag does not compile") != NULL);
    SQ_CHECK(sh == 0);
    printf("message: %s\n", sq_last_error());
    const char *after_include = "#version 450 core\n"
                                "#include \"frame_common.glsl\"\n"
                                "out vec4 o;\n"
                                "void main() {\n"
                                "    o = vec4(sq_sky_radiance(vec3(0, 0, 1), true), undefined_x);\n"
                                "}\n";
    SQ_CHECK_ERR(sq__gl_shader_compile(ctx, GL_FRAGMENT_SHADER, "inc.frag", after_include, &sh),
                 SQ_ERR_GL, "inc.frag:5:");
    SQ_CHECK(strstr(sq_last_error(), "undefined_x") != NULL);
    printf("message: %s\n", sq_last_error());
    const char *bad_include = "#version 450 core\n\n#include \"no_such_file.glsl\"\nvoid main() {}\n";
    SQ_CHECK_ERR(sq__gl_shader_compile(ctx, GL_FRAGMENT_SHADER, "x.frag", bad_include, &sh),
                 SQ_ERR_INTERNAL, "x.frag:3: #include \"no_such_file.glsl\"");
    GLuint prog = 0;
    SQ_CHECK_ERR(sq__gl_program(ctx, "fullscreen.vert", NULL, "missing.frag", &prog),
                 SQ_ERR_INTERNAL, "src/render/shaders/missing.frag.glsl");
    /* the same text without the error compiles */
    const char *good = "#version 450 core\n"
                       "#include \"frame_common.glsl\"\n"
                       "out vec4 o;\n"
                       "void main() { o = vec4(sq_sky_radiance(vec3(0, 0, 1), true), 1.0); }\n";
    SQ_CHECK_OK(sq__gl_shader_compile(ctx, GL_FRAGMENT_SHADER, "good.frag", good, &sh));
    SQ_CHECK(sh != 0);
    glDeleteShader(sh);
    /* every embedded shader of the base renderer is in the table */
    const char *names[] = {"frame_common", "fullscreen.vert", "sky.frag", "terrain.vert",
                           "terrain.frag", "mesh.vert", "mesh.frag", "surface.vert",
                           "surface.frag", "tonemap.frag"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        SQ_CHECK_MSG(sq__shader_source(names[i]) != NULL, "no embedded %s", names[i]);
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

/* Without a usable driver the failure says what failed and how to get a context. Mesa's EGL is
 * made the only vendor (so a GPU vendor library cannot step in) and its DRI drivers are looked
 * for where there are none. */
SQ_TEST(no_gl_context_message)
{
    const char *mesa_json = "/usr/share/glvnd/egl_vendor.d/50_mesa.json";
    FILE *f = fopen(mesa_json, "r");
    if (f) fclose(f);
    setenv("__EGL_VENDOR_LIBRARY_FILENAMES", f ? mesa_json : "/nonexistent/vendor.json", 1);
    setenv("LIBGL_DRIVERS_PATH", "/nonexistent", 1);
    setenv("EGL_LOG_LEVEL", "fatal", 1); /* keep Mesa's loader warnings out of the test log */
    sq_context *ctx = make_ctx();
    sq_renderer *r = NULL;
    SQ_CHECK_ERR(sq_renderer_create(ctx, NULL, &r), SQ_ERR_GL, "no usable OpenGL 4.5 context");
    SQ_CHECK(r == NULL);
    printf("message: %s\n", sq_last_error());
    SQ_CHECK(strstr(sq_last_error(), "apt-get install libgl1-mesa-dri libegl1") != NULL);
    if (f) SQ_CHECK(strstr(sq_last_error(), "eglInitialize failed on the surfaceless platform") != NULL);
    sq_render_info info;
    SQ_CHECK_ERR(sq_gl_probe(ctx, &info), SQ_ERR_GL, "or a GPU driver");
    sq_context_destroy(ctx);
}

SQ_TEST(probe_reports_limits)
{
    sq_context *ctx = make_ctx();
    sq_render_info info;
    SQ_CHECK_OK(sq_gl_probe(ctx, &info));
    printf("%s | %s | %s | GLSL %s | tex %d, 3D %d, viewport %dx%d, rb %d\n", info.gl_vendor,
           info.gl_renderer, info.gl_version, info.glsl_version, info.max_texture_size,
           info.max_3d_texture_size, info.max_viewport[0], info.max_viewport[1],
           info.max_renderbuffer_size);
    SQ_CHECK(strstr(info.gl_version, "4.") == info.gl_version);
    SQ_CHECK(strlen(info.gl_renderer) > 0 && strlen(info.glsl_version) > 0);
    SQ_CHECK(info.max_texture_size >= 1024 && info.max_3d_texture_size >= 256);
    SQ_CHECK(info.max_viewport[0] >= 1024 && info.max_renderbuffer_size >= 1024);
    sq_renderer *r = make_renderer(ctx, 8, 8);
    sq_render_info ri;
    SQ_CHECK_OK(sq_renderer_info(r, &ri));
    SQ_CHECK(strcmp(ri.gl_renderer, info.gl_renderer) == 0);
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

/* Two renderers on one thread (they share one EGL display): each draws into its own frame,
 * destroying one leaves the other working, and a probe in between does not disturb it. */
SQ_TEST(two_renderers_one_thread)
{
    sq_context *ctx = make_ctx();
    sq_world *w = make_world(33, 400.0f, 0.0f);
    sq_renderer *a = make_renderer(ctx, 48, 32);
    sq_renderer *b = make_renderer(ctx, 32, 48);
    const sq_camera cam = north_camera(0.0f, -100.0f, 10.0f);
    uint8_t pa[48 * 32 * 4], pb[32 * 48 * 4];
    SQ_CHECK_ERR(sq_renderer_read_rgba8(a, pa), SQ_ERR_INVALID_ARG, "no frame drawn yet");
    SQ_CHECK_OK(sq_renderer_draw(a, w, &cam, NULL, 0, 0.0));
    SQ_CHECK_OK(sq_renderer_draw(b, w, &cam, NULL, 0, 0.0));
    SQ_CHECK_OK(sq_renderer_read_rgba8(a, pa));
    SQ_CHECK_OK(sq_renderer_read_rgba8(b, pb));
    sq_renderer_destroy(a);
    sq_render_info info;
    SQ_CHECK_OK(sq_gl_probe(ctx, &info));
    SQ_CHECK_OK(sq_renderer_draw(b, w, &cam, NULL, 0, 0.0));
    uint8_t pb2[32 * 48 * 4];
    SQ_CHECK_OK(sq_renderer_read_rgba8(b, pb2));
    SQ_CHECK(memcmp(pb, pb2, sizeof pb) == 0);
    SQ_CHECK(pb[2] > pb[0]); /* top-left: sky */
    sq_renderer_destroy(b);
    sq_renderer_destroy(NULL);
    free_world(w);
    sq_context_destroy(ctx);
}

/* A heightfield larger than the mesh limit is drawn from every stride-th sample (last row and
 * column kept): a plane tilted along x renders the same as from a small heightfield. */
SQ_TEST(large_heightfield_is_subsampled)
{
    sq_context *ctx = make_ctx();
    sq_world *small = make_world(65, 2000.0f, 0.0f);
    sq_world *big = calloc(1, sizeof *big);
    *big = *small;
    big->nx = 2101;
    big->ny = 9;
    big->dx = 2000.0f / 2100.0f;
    big->dy = 2000.0f / 8.0f;
    big->heights = calloc((size_t)big->nx * (size_t)big->ny, sizeof(float));
    big->normals = NULL; /* from the heights */
    const sq_vec3 n = sq_v3_norm(sq_v3(-0.02f, 0.0f, 1.0f));
    for (int j = 0; j < big->ny; j++)
        for (int i = 0; i < big->nx; i++)
            big->heights[j * big->nx + i] = 0.02f * (big->origin.x + (float)i * big->dx);
    for (int j = 0; j < 65; j++)
        for (int i = 0; i < 65; i++) {
            small->heights[j * 65 + i] = 0.02f * (small->origin.x + (float)i * small->dx);
            small->normals[3 * (j * 65 + i) + 0] = n.x;
            small->normals[3 * (j * 65 + i) + 1] = n.y;
            small->normals[3 * (j * 65 + i) + 2] = n.z;
        }
    sq_renderer *r = make_renderer(ctx, W, H);
    const sq_camera cam = north_camera(0.0f, -500.0f, 20.0f);
    float *a = render_linear(r, small, &cam, NULL, 0, W, H);
    float *b = render_linear(r, big, &cam, NULL, 0, W, H);
    /* stride ceil(2100 / 1024) = 3 on both axes: 701 x 4 vertices (rows 0, 3, 6, 8) */
    SQ_CHECK(r->terrain_index_count == 700 * 3 * 6);
    double worst = 0.0;
    for (int y = H / 2 + 10; y < H; y += 3)
        for (int x = 0; x < W; x += 3)
            worst = fmax(worst, fabs(px(a, W, x, y)[1] - px(b, W, x, y)[1]) / px(a, W, x, y)[1]);
    printf("subsampled plane: worst relative difference %.2e\n", worst);
    SQ_CHECK(worst < 1e-3);
    free(a);
    free(b);
    sq_renderer_destroy(r);
    free(big->heights);
    free(big);
    free_world(small);
    sq_context_destroy(ctx);
}

/* egl_device picks a device of the EGL device platform by index or DRM path; an unknown one is
 * refused with the number of devices found. */
SQ_TEST(egl_device_hint)
{
    sq_context *ctx = make_ctx();
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.width = 8;
    d.height = 8;
    d.egl_device = "0";
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &d, &r));
    if (r) {
        sq_world *w = make_world(9, 100.0f, 0.0f);
        const sq_camera cam = north_camera(0.0f, -10.0f, 5.0f);
        SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
        free_world(w);
    }
    sq_renderer_destroy(r);
    d.egl_device = "no-such-gpu";
    SQ_CHECK_ERR(sq_renderer_create(ctx, &d, &r), SQ_ERR_GL, "no EGL device matches egl_device \"no-such-gpu\"");
    sq_context_destroy(ctx);
}
