/* test_clouds_render.c — the cloud pass in frames (SPEC 8.5): the splat falloff as drawn (a
 * single absorbing particle's opacity across the frame against 1 - exp(-tau eta(t)), eta the
 * Hermite falloff with |t|), and the impostor cross-fade (a camera approaching a cloud through
 * dist_impostor and dist_3d: impostors beyond, particles within, and no step between
 * consecutive frames larger than the steady change of the approach — nothing pops), and the
 * aerial haze on far particles (the terrain's law). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"
#include "sq_test.h"
#include "squall/clouds.h"
#include "squall/render.h"
#include "squall/world.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

static sq_context *new_ctx(void)
{
    sq_context_desc cd = {0};
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

static sq_world *new_world(sq_context *ctx)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 400000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 17;
    wd.sun.direction = sq_v3(0.3f, -0.4f, 0.8f);
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

/* Mean of exp(-z / H) along a straight path between heights z0 and z1 (m). */
static double profile_mean(double z0, double z1, double H)
{
    const double d = fabs(z1 - z0) / H, low = exp(-fmin(z0, z1) / H);
    return d < 1e-9 ? low : low * (1.0 - exp(-d)) / d;
}

/* Fraction of the view toward a point at distance dist (m) between heights z0 and z1 that the
 * renderer's aerial haze replaces by sky (docs/phen/clouds.md, frame_common.glsl): 1 - exp(-tau),
 * tau = dist (1e-5 mean(exp(-z / 8 km)) + 2e-5 (T - 1) mean(exp(-z / 1.5 km))), T the turbidity. */
static double haze_fraction(double dist, double z0, double z1, double turbidity)
{
    const double tau = dist * (1e-5 * profile_mean(z0, z1, 8000.0) +
                               2e-5 * (turbidity - 1.0) * profile_mean(z0, z1, 1500.0));
    return 1.0 - exp(-tau);
}

/* One absorbing particle (albedo 0: it only dims what lies behind it) of radius 100 m and
 * optical depth 2 at its centre, 1 km in front of the camera against the sky, no texture noise:
 * along a row through its centre the transmittance L / L_sky equals exp(-2 eta(t)) with
 * eta(t) = 2t³ - 3t² + 1, plus the haze in front of it (the share f of the sky light that the
 * air between camera and particle scatters in, over the particle's opacity), within 0.02
 * (8-bit-free linear read-back; pixel centres sample t). */
SQ_TEST(splat_falloff_in_the_frame)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx);
    const int W = 129, H = 129;
    sq_render_desc rd = {0};
    rd.width = W;
    rd.height = H;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    if (!r) return;
    sq_camera cam = {0};
    cam.position_m = sq_v3(0.0f, 0.0f, 500.0f);
    cam.target_m = sq_v3(0.0f, 1000.0f, 700.0f);
    cam.fov_y_deg = 16.0f;
    cam.near_m = 1.0f;
    cam.far_m = 10000.0f;
    const float pos[3] = {0.0f, 1000.0f, 700.0f}, rad[1] = {100.0f}, tau[1] = {2.0f};
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_CLOUDS;
    sq_clouds_view *v = &d.u.clouds;
    v->count = 1;
    v->position = pos;
    v->radius_m = rad;
    v->tau = tau;
    v->g_default = 0.85f;
    v->albedo = 0.0f;
    v->gamma_sr = 0.09f;
    v->version = 1;
    float *sky = malloc(sizeof(float) * W * H * 3), *img = malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, sky));
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, img));
    /* pixel size at the particle's distance (the view axis passes through its centre) */
    const double d_m = sqrt(1000.0 * 1000.0 + 200.0 * 200.0);
    const double px_m = 2.0 * d_m * tan(8.0 * 3.14159265358979 / 180.0) / H;
    const int cy = H / 2, cx = W / 2;
    const double f_haze = haze_fraction(d_m, 500.0, 700.0, 3.0); /* the world's turbidity 3 */
    double worst = 0.0;
    int inside = 0;
    for (int x = 0; x < W; x++) {
        const size_t q = ((size_t)cy * W + (size_t)x) * 3 + 1; /* green */
        const double T = (double)img[q] / (double)sky[q];
        const double t = fabs((double)(x - cx)) * px_m / 100.0;
        const double eta = t < 1.0 ? (2.0 * t - 3.0) * t * t + 1.0 : 0.0;
        const double want = exp(-2.0 * eta) + (1.0 - exp(-2.0 * eta)) * f_haze;
        worst = fmax(worst, fabs(T - want));
        inside += t < 1.0;
    }
    printf("splat row: %d pixels inside the disc, haze %.4f, worst |T - want| = %.4f\n", inside,
           f_haze, worst);
    SQ_CHECK(inside > 20);
    SQ_CHECK(worst <= 0.02);
    free(sky);
    free(img);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Aerial perspective on cloud particles: one opaque white particle (tau 50, albedo 1) on a ray
 * rising 3 degrees from a camera 1 km up, at 2, 10, 30 and 60 km (its radius growing with the
 * distance, so it covers the same pixels). Its centre pixel is L(d) = (1 - f(d)) L_0 + f(d) S,
 * S the sky behind it (the frame without it), f the terrain's haze law (haze_fraction above)
 * for the path: L_0 follows from the 2 km frame, and the farther frames must match the
 * prediction within 2 % of the contrast |L_0 - S| (unhazed particles miss it at 60 km by f, 0.6
 * of the contrast). The cloud fades into the horizon sky as the terrain does. */
SQ_TEST(far_particle_hazes_like_the_terrain)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx);
    const int W = 129, H = 129;
    sq_render_desc rd = {0};
    rd.width = W;
    rd.height = H;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    if (!r) return;
    const double el = 3.0 * 3.14159265358979 / 180.0, z0 = 1000.0;
    sq_camera cam = {0};
    cam.position_m = sq_v3(0.0f, 0.0f, (float)z0);
    cam.target_m = sq_v3(0.0f, (float)(1000.0 * cos(el)), (float)(z0 + 1000.0 * sin(el)));
    cam.fov_y_deg = 16.0f;
    cam.near_m = 10.0f;
    cam.far_m = 200000.0f; /* the far-plane blend starts at 100 km: not reached */
    float *img = malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
    SQ_CHECK_OK(sq_renderer_read_linear(r, img));
    const size_t centre = ((size_t)(H / 2) * W + (size_t)(W / 2)) * 3 + 1; /* green */
    const double S = img[centre];
    const double dist[4] = {2000.0, 10000.0, 30000.0, 60000.0};
    double L[4], f[4];
    for (int k = 0; k < 4; k++) {
        const float pos[3] = {0.0f, (float)(dist[k] * cos(el)), (float)(z0 + dist[k] * sin(el))};
        const float rad[1] = {(float)(0.02 * dist[k])}, tau[1] = {50.0f};
        sq_drawable d;
        memset(&d, 0, sizeof d);
        d.kind = SQ_DRAWABLE_CLOUDS;
        sq_clouds_view *v = &d.u.clouds;
        v->count = 1;
        v->position = pos;
        v->radius_m = rad;
        v->tau = tau;
        v->g_default = 0.85f;
        v->albedo = 1.0f;
        v->gamma_sr = 0.09f;
        v->multiple_scattering = true;
        v->version = (uint64_t)k + 1;
        SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0));
        SQ_CHECK_OK(sq_renderer_read_linear(r, img));
        L[k] = img[centre];
        f[k] = haze_fraction(dist[k], z0, z0 + dist[k] * sin(el), 3.0);
    }
    const double L0 = (L[0] - f[0] * S) / (1.0 - f[0]);
    const double contrast = fabs(L0 - S);
    printf("sky %.4f, particle unhazed %.4f\n", S, L0);
    SQ_CHECK_MSG(contrast > 0.05 * S, "the particle %.4f hardly differs from the sky %.4f", L0, S);
    for (int k = 1; k < 4; k++) {
        const double want = (1.0 - f[k]) * L0 + f[k] * S;
        printf("%5.0f m: L %.4f, haze law %.4f (f %.3f), error %.2f %% of the contrast\n",
               dist[k], L[k], want, f[k], 100.0 * fabs(L[k] - want) / contrast);
        SQ_CHECK_MSG(fabs(L[k] - want) <= 0.02 * contrast, "at %.0f m: %.4f, the haze law %.4f",
                     dist[k], L[k], want);
    }
    SQ_CHECK(f[3] > 0.5);
    free(img);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The sky's glow around the sun comes from the aerosol above the camera (scale height 1.5 km
 * above sea level): the sky pixel 10 degrees from the sun, seen from 0, 1.5, 3 and 6 km, is
 * A + B (1 - exp(-tau(z))) with tau(z) = 0.05 (T - 1) exp(-z / 1.5 km) / mu (T = 3, mu the
 * pixel's direction's z): A and B from the first two heights, the others within 0.1 % of B;
 * the glow at 6 km is under a tenth of that at sea level. */
SQ_TEST(sun_glow_fades_as_the_camera_climbs)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx);
    const int W = 33, H = 33;
    sq_render_desc rd = {0};
    rd.width = W;
    rd.height = H;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    if (!r) return;
    const sq_vec3 sun = sq_v3_norm(sq_v3(0.3f, -0.4f, 0.8f));
    /* 10 degrees from the sun, toward the horizon in the sun's azimuth plane */
    const sq_vec3 horiz = sq_v3_norm(sq_v3(sun.x, sun.y, 0.0f));
    const float a = 0.1745329f, el = asinf(sun.z) - a;
    const sq_vec3 fwd = sq_v3_add(sq_v3_scale(horiz, cosf(el)), sq_v3(0.0f, 0.0f, sinf(el)));
    const double mu = fwd.z, tau_sl = 0.05 * (3.0 - 1.0) / mu;
    const double z[4] = {0.0, 1500.0, 3000.0, 6000.0};
    double L[4], g[4];
    float *img = malloc(sizeof(float) * W * H * 3);
    for (int k = 0; k < 4; k++) {
        sq_camera cam = {0};
        cam.position_m = sq_v3(0.0f, 0.0f, (float)z[k] + 2.0f);
        cam.target_m = sq_v3_add(cam.position_m, sq_v3_scale(fwd, 1000.0f));
        cam.fov_y_deg = 10.0f;
        cam.near_m = 1.0f;
        cam.far_m = 50000.0f;
        SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0));
        SQ_CHECK_OK(sq_renderer_read_linear(r, img));
        L[k] = img[((size_t)(H / 2) * W + (size_t)(W / 2)) * 3 + 1];
        g[k] = -expm1(-tau_sl * exp(-(z[k] + 2.0) / 1500.0));
    }
    const double B = (L[0] - L[1]) / (g[0] - g[1]), A = L[0] - B * g[0];
    printf("glow: A %.5f B %.5f; glow share at sea level %.4f, at 6 km %.4f\n", A, B, B * g[0],
           B * g[3]);
    SQ_CHECK(B > 0.0);
    for (int k = 2; k < 4; k++) {
        const double want = A + B * g[k];
        printf("%4.0f m: %.5f, law %.5f\n", z[k], L[k], want);
        SQ_CHECK_MSG(fabs(L[k] - want) <= 1e-3 * B, "at %.0f m: %.5f, law %.5f", z[k], L[k], want);
    }
    SQ_CHECK(B * g[3] < 0.1 * B * g[0]);
    free(img);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* A cumulus approached from 95 km to 55 km in 40 frames (dist_3d 65 km, dist_impostor 85 km):
 * beyond 85 km only its impostor is drawn, within 65 km only particles, between both. Each frame
 * is also drawn with particles only; e_k, the mean difference the impostor makes, goes from its
 * far value to 0 through the band without a jump: no step of e_k exceeds half its largest
 * value (a hard switch at one distance steps by all of it). */
SQ_TEST(impostor_crossfade_no_pop)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx);
    const int W = 96, H = 64, N = 40;
    sq_render_desc rd = {0};
    rd.width = W;
    rd.height = H;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    sq_clouds_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.source = SQ_CLOUDS_SOURCE_CUMULUS;
    cd.synthetic_clouds = 1;
    cd.synthetic_size_m[0] = cd.synthetic_size_m[1] = 8000.0;
    cd.synthetic_size_m[2] = 3000.0;
    cd.synthetic_cells[0] = cd.synthetic_cells[1] = 32;
    cd.particles = 4000;
    cd.dist_3d_m = 65000.0;
    cd.dist_impostor_m = 85000.0;
    sq_clouds *c = NULL;
    SQ_CHECK_OK(sq_clouds_create(ctx, &cd, w, &c));
    if (!r || !c) return;
    sq_drawable d, dp;
    SQ_CHECK_OK(sq_clouds_drawable(c, &d));
    dp = d;
    dp.u.clouds.impostors = false;
    const sq_cloud_group *g = &d.u.clouds.groups[0];
    float *img = malloc(sizeof(float) * W * H * 3), *ref = malloc(sizeof(float) * W * H * 3);
    double e[64];
    int imp_frames = 0, part_frames = 0;
    for (int k = 0; k < N; k++) {
        const float dist = 95000.0f - 40000.0f * (float)k / (float)(N - 1);
        sq_camera cam = {0};
        cam.target_m = g->center_m;
        cam.position_m = sq_v3(g->center_m.x - dist, g->center_m.y, g->center_m.z + 200.0f);
        cam.fov_y_deg = 9.0f;
        cam.near_m = 10.0f;
        cam.far_m = 300000.0f;
        SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0));
        SQ_CHECK_OK(sq_renderer_read_linear(r, img));
        sq__clouds_pass_stats st;
        sq__clouds_pass_get_stats(r, &st);
        if (dist > 85000.0f + g->radius_m) {
            SQ_CHECK(st.impostors_drawn == 1 && st.particles_drawn == 0);
            imp_frames++;
        }
        if (dist < 65000.0f - g->radius_m) {
            SQ_CHECK(st.impostors_drawn == 0 && st.particles_drawn > 0);
            part_frames++;
        }
        SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, &dp, 1, 0.0));
        SQ_CHECK_OK(sq_renderer_read_linear(r, ref));
        double s = 0.0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const size_t q = ((size_t)y * W + (size_t)x) * 3 + 1;
                s += fabs((double)img[q] - (double)ref[q]);
            }
        e[k] = s / (double)(W * H);
    }
    double emax = 0.0, step = 0.0;
    for (int k = 0; k < N; k++) emax = fmax(emax, e[k]);
    for (int k = 1; k < N; k++) step = fmax(step, fabs(e[k] - e[k - 1]));
    printf("impostor error: first %.5f, largest %.5f, largest step %.5f, last %.5f (%d "
           "impostor-only, %d particle-only frames)\n",
           e[0], emax, step, e[N - 1], imp_frames, part_frames);
    SQ_CHECK(imp_frames >= 3 && part_frames >= 3);
    SQ_CHECK(emax > 0.0 && e[N - 1] == 0.0);
    SQ_CHECK(step <= 0.5 * emax);
    free(img);
    free(ref);
    sq_clouds_destroy(c);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}
