/* test_reference.c — the reference path tracer against exact answers: Beer–Lambert through
 * homogeneous and linearly varying slabs (delta/ratio/spectral tracking, trilinear density,
 * brick majorants), single scattering of a plane-parallel slab in reflection and transmission
 * (HG with per-channel g and a second lobe, sun next-event estimation), white furnaces (albedo-1
 * media under a uniform sky create no energy and lose none), a Lambertian plane under sun and
 * sky, ray–heightfield and ray–obstacle intersection against brute force, camera conventions
 * against sqmath.h, HG sampling moments, determinism over thread counts, and error handling.
 *
 * Monte Carlo tolerances: every image comparison is made on the mean over pixels of
 * (pixel - exact expectation of that pixel); the standard error of that mean is estimated from
 * the scatter of the per-pixel residuals, and the check is |mean| <= 4 sigma (plus 1e-4 relative
 * for the quadrature of the exact value over each pixel footprint). N (samples per channel) is
 * printed with each result. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/reference/reference_internal.h"
#include "sq_test.h"
#include "squall/render.h"
#include "squall/rng.h"
#include "squall/sqmath.h"
#include "world/world_struct.h"

SQ_LABEL(physics)

/* ---- helpers -------------------------------------------------------------------------------- */

static sq_world *world_new(void)
{
    sq_world *w = (sq_world *)calloc(1, sizeof *w);
    w->sun_dir = sq_v3(0.0f, 0.0f, 1.0f);
    return w;
}

/* Sky radiance (r, g, b) in every direction: zenith = horizon, no haze glow (turbidity 0) and a
 * white ground below the horizon with no sun (the GL sky's ground light is then the sky's). */
static void world_uniform_sky(sq_world *w, float r, float g, float b)
{
    w->sky_zenith = sq_v3(r, g, b);
    w->sky_horizon = sq_v3(r, g, b);
    w->ground_albedo = sq_v3(1, 1, 1);
    w->turbidity = 0.0f;
}

static void set_sun(sq_world *w, double elev_deg, double azim_deg, sq_vec3 e)
{
    double el = elev_deg * SQ_PI / 180.0, az = azim_deg * SQ_PI / 180.0;
    w->sun_dir = sq_v3((float)(cos(el) * cos(az)), (float)(cos(el) * sin(az)), (float)sin(el));
    w->sun_radiance = e;
}

static sq_context *ctx_new(int threads)
{
    sq_context *ctx = NULL;
    sq_context_desc d = {.threads = threads};
    sq_context_create(&d, &ctx);
    return ctx;
}

/* A volume drawable over a box with a density grid (owned by the caller). */
static sq_drawable volume_drawable(const float *dens, int nx, int ny, int nz, sq_vec3 org,
                                   sq_vec3 size, const float sig[3], const float alb[3],
                                   const float g[3])
{
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_VOLUME;
    d.name = "test";
    d.u.volume.density = dens;
    d.u.volume.nx = nx;
    d.u.volume.ny = ny;
    d.u.volume.nz = nz;
    d.u.volume.origin_m = org;
    d.u.volume.size_m = size;
    for (int c = 0; c < 3; c++) {
        d.u.volume.sigma_ext[c] = sig[c];
        d.u.volume.albedo[c] = alb[c];
        d.u.volume.g[c] = g[c];
    }
    return d;
}

static float *const_grid(int nx, int ny, int nz, float v)
{
    float *d = (float *)malloc((size_t)nx * ny * nz * sizeof(float));
    for (int i = 0; i < nx * ny * nz; i++) d[i] = v;
    return d;
}

/* Camera basis identical to sq_m4_look_at. */
typedef struct cam_basis {
    sq__dv3 pos, f, r, u;
    double th, aspect;
} cam_basis;

static cam_basis cam_basis_of(const sq_camera *c, int w, int h)
{
    cam_basis b;
    b.pos = sq__dv_from(c->position_m);
    b.f = sq__dv_norm(sq__dv_sub(sq__dv_from(c->target_m), b.pos));
    sq__dv3 up = sq__dv_from(c->up);
    if (up.x == 0 && up.y == 0 && up.z == 0) up = sq__dv(0, 0, 1);
    b.r = sq__dv_norm(sq__dv_cross(b.f, up));
    b.u = sq__dv_cross(b.r, b.f);
    b.th = tan(0.5 * (double)c->fov_y_deg * SQ_PI / 180.0);
    b.aspect = (double)w / h;
    return b;
}

static sq__dv3 cam_dir(const cam_basis *b, double sx, double sy, int w, int h)
{
    double nx = 2.0 * sx / w - 1.0, ny = 1.0 - 2.0 * sy / h;
    return sq__dv_norm(sq__dv_add(b->f, sq__dv_add(sq__dv_scale(b->r, nx * b->th * b->aspect),
                                                   sq__dv_scale(b->u, ny * b->th))));
}

typedef void (*exact_fn)(void *user, sq__dv3 d, double out[3]);

/* Compares an image with the exact per-pixel expectation (4x4 midpoint quadrature over each
 * pixel footprint): per channel, |mean residual| <= 4 * standard error + 1e-4 * |mean exact|. */
static void check_image(const char *what, const float *img, int w, int h, int spp,
                        const sq_camera *cam, exact_fn f, void *user)
{
    cam_basis b = cam_basis_of(cam, w, h);
    double sum[3] = {0}, sum2[3] = {0}, ex_sum[3] = {0};
    for (int py = 0; py < h; py++)
        for (int px = 0; px < w; px++) {
            double ex[3] = {0, 0, 0};
            for (int j = 0; j < 4; j++)
                for (int i = 0; i < 4; i++) {
                    double v[3];
                    f(user, cam_dir(&b, px + (i + 0.5) / 4.0, py + (j + 0.5) / 4.0, w, h), v);
                    for (int c = 0; c < 3; c++) ex[c] += v[c] / 16.0;
                }
            for (int c = 0; c < 3; c++) {
                double r = (double)img[3 * (py * w + px) + c] - ex[c];
                sum[c] += r;
                sum2[c] += r * r;
                ex_sum[c] += ex[c];
            }
        }
    const double n = (double)w * h;
    for (int c = 0; c < 3; c++) {
        double mean = sum[c] / n, var = sum2[c] / n - mean * mean;
        double se = sqrt(var > 0 ? var / (n - 1) : 0.0);
        double exact = ex_sum[c] / n;
        double tol = 4.0 * se + 1e-4 * fabs(exact);
        printf("%s ch%d: N = %.0f, exact %.6f, rendered %.6f, diff %.2e, 4 sigma %.2e\n", what, c,
               n * spp, exact, exact + mean, mean, 4.0 * se);
        SQ_CHECK_MSG(fabs(mean) <= tol, "%s ch%d: |%.3e| > %.3e (exact %.6f)", what, c, mean, tol,
                     exact);
    }
}

static sq_result render(sq_context *ctx, int w, int h, int spp, int max_bounces,
                        const sq_world *world, const sq_camera *cam, const sq_drawable *dr,
                        int n, float *img)
{
    sq_reference_desc d;
    memset(&d, 0, sizeof d);
    d.width = w;
    d.height = h;
    d.samples = spp;
    d.max_bounces = max_bounces;
    d.seed = 12345;
    return sq_reference_render(ctx, &d, world, cam, dr, n, img);
}

/* ---- (a) transmittance -------------------------------------------------------------------- */

typedef struct slab_x {
    double tau_x[3]; /* optical thickness along x per channel */
    double L[3];
} slab_x;

static void exact_slab_x(void *user, sq__dv3 d, double out[3])
{
    const slab_x *s = (const slab_x *)user;
    for (int c = 0; c < 3; c++) out[c] = s->L[c] * exp(-s->tau_x[c] / d.x);
}

SQ_TEST(transmittance_homogeneous_slab)
{
    /* slab 0 <= x <= 2 m, constant density 1, sigma_ext (0.5, 1, 1.5) /m, albedo 0, seen along
     * +x against a uniform sky: L = L_sky exp(-sigma d / cos theta) exactly. */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 1.0f, 0.7f, 0.4f);
    float *dens = const_grid(2, 2, 2, 1.0f);
    const float sig[3] = {0.5f, 1.0f, 1.5f}, alb[3] = {0, 0, 0}, g[3] = {0, 0, 0};
    sq_drawable dr = volume_drawable(dens, 2, 2, 2, sq_v3(0, -500, -500), sq_v3(2, 1000, 1000),
                                     sig, alb, g);
    sq_camera cam = {.position_m = sq_v3(-10, 0, 0), .target_m = sq_v3(0, 0, 0),
                     .fov_y_deg = 4.0f};
    const int W = 32, H = 32, SPP = 128;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(render(ctx, W, H, SPP, 0, w, &cam, &dr, 1, img));
    slab_x ex = {{1.0, 2.0, 3.0}, {1.0, 0.7, 0.4}};
    check_image("homogeneous slab", img, W, H, SPP, &cam, exact_slab_x, &ex);
    free(img);
    free(dens);
    free(w);
    sq_context_destroy(ctx);
}

SQ_TEST(transmittance_linear_density_trilinear)
{
    /* density rising linearly in x over 32 cells (several 8-cell bricks): the trilinear field
     * is piecewise linear with clamp-to-edge half cells at both ends, so tau is exact by the
     * trapezoid rule over its breakpoints. */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 2.0f, 1.0f, 0.5f);
    const int nx = 32;
    float *dens = (float *)malloc(sizeof(float) * nx * 2 * 2);
    for (int k = 0; k < 2; k++)
        for (int j = 0; j < 2; j++)
            for (int i = 0; i < nx; i++) dens[(k * 2 + j) * nx + i] = 0.2f + 0.1f * (float)i;
    const float sig[3] = {0.1f, 0.25f, 0.4f}, alb[3] = {0, 0, 0}, g[3] = {0, 0, 0};
    const double len = 2.0, cell = len / nx;
    sq_drawable dr = volume_drawable(dens, nx, 2, 2, sq_v3(0, -500, -500), sq_v3((float)len, 1000, 1000),
                                     sig, alb, g);
    /* integral of density over x: breakpoints at 0, 0.5, 1.5, ..., nx-0.5, nx (voxel units) */
    double integral = 0.5 * (double)dens[0] + 0.5 * (double)dens[nx - 1];
    for (int i = 0; i + 1 < nx; i++) integral += 0.5 * ((double)dens[i] + (double)dens[i + 1]);
    integral *= cell;
    slab_x ex;
    for (int c = 0; c < 3; c++) ex.tau_x[c] = (double)sig[c] * integral;
    ex.L[0] = 2.0;
    ex.L[1] = 1.0;
    ex.L[2] = 0.5;
    printf("tau along x = %.4f %.4f %.4f\n", ex.tau_x[0], ex.tau_x[1], ex.tau_x[2]);
    sq_camera cam = {.position_m = sq_v3(-10, 0, 0), .target_m = sq_v3(0, 0, 0),
                     .fov_y_deg = 4.0f};
    const int W = 32, H = 32, SPP = 128;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(render(ctx, W, H, SPP, 0, w, &cam, &dr, 1, img));
    check_image("linear slab", img, W, H, SPP, &cam, exact_slab_x, &ex);
    /* the density lookup itself: exact trilinear values at cell centres and clamped ends */
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, &dr, 1, false, &s));
    if (s) {
        const sq__ref_volume *v = &s->volumes[0];
        SQ_CHECK_NEAR(sq__ref_volume_density(v, sq__dv(0.01, 0, 0)), dens[0], 1e-6);
        SQ_CHECK_NEAR(sq__ref_volume_density(v, sq__dv((5 + 0.5) * cell, 0, 0)), dens[5], 1e-6);
        SQ_CHECK_NEAR(sq__ref_volume_density(v, sq__dv(6 * cell, 0, 0)),
                      0.5 * (dens[5] + dens[6]), 1e-6);
        SQ_CHECK_NEAR(sq__ref_volume_density(v, sq__dv(len - 0.01, 0, 0)), dens[nx - 1], 1e-6);
        SQ_CHECK(sq__ref_volume_density(v, sq__dv(len + 0.01, 0, 0)) == 0.0);
        sq__ref_scene_destroy(s);
    }
    free(img);
    free(dens);
    free(w);
    sq_context_destroy(ctx);
}

/* ---- (b) single scattering of a plane-parallel slab ----------------------------------------- */

typedef struct slab_ss {
    double tau[3], alb[3], g[3], g2, w2, E[3];
    sq__dv3 sun;
    bool below; /* camera below the slab (transmission) */
} slab_ss;

static double phase2(const slab_ss *s, int c, double mu)
{
    return (1.0 - s->w2) * sq__hg_eval(s->g[c], mu) + s->w2 * sq__hg_eval(s->g2, mu);
}

/* Exact single-scattered radiance of a sun-lit plane-parallel slab of optical thickness tau
 * (black sky, nothing below): integrate beta a p E exp(-sun path) exp(-view path) along the
 * view ray; mu0 = sun elevation cosine, mu = |d_z|.
 *   above (reflection):   E a p mu0/(mu0 + mu) (1 - exp(-tau (1/mu0 + 1/mu)))
 *   below (transmission): E a p mu0/(mu - mu0) (exp(-tau/mu) - exp(-tau/mu0)) */
static void exact_slab_ss(void *user, sq__dv3 d, double out[3])
{
    const slab_ss *s = (const slab_ss *)user;
    double mu0 = s->sun.z, mu = fabs(d.z), cth = sq__dv_dot(d, s->sun);
    for (int c = 0; c < 3; c++) {
        double p = phase2(s, c, cth), t = s->tau[c], f;
        if (!s->below)
            f = mu0 / (mu0 + mu) * -expm1(-t * (1.0 / mu0 + 1.0 / mu));
        else if (fabs(mu - mu0) < 1e-9)
            f = t / mu * exp(-t / mu);
        else
            f = mu0 / (mu - mu0) * (exp(-t / mu) - exp(-t / mu0));
        out[c] = s->E[c] * s->alb[c] * p * f;
    }
}

static void single_scatter_case(bool below)
{
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 0, 0, 0);
    w->ground_albedo = sq_v3(0, 0, 0); /* black below the horizon too */
    set_sun(w, 40.0, 0.0, sq_v3(1.0f, 0.8f, 0.6f));
    const float H = 1.0f;
    float *dens = const_grid(4, 4, 4, 1.0f);
    const float sig[3] = {0.3f, 0.5f, 0.8f}, alb[3] = {0.9f, 0.8f, 0.6f};
    const float g[3] = {0.7f, 0.5f, 0.3f};
    sq_drawable dr = volume_drawable(dens, 4, 4, 4, sq_v3(-3000, -3000, 0), sq_v3(6000, 6000, H),
                                     sig, alb, g);
    dr.u.volume.g2 = -0.3f;
    dr.u.volume.w2 = 0.2f;
    slab_ss ex;
    for (int c = 0; c < 3; c++) {
        ex.tau[c] = (double)sig[c] * H;
        ex.alb[c] = alb[c];
        ex.g[c] = g[c];
        /* the sun's irradiance is pi * sun_radiance (a white plane facing it reads
         * sun_radiance, frame_common.glsl) */
        ex.E[c] = SQ_PI * (double)(c == 0 ? w->sun_radiance.x
                                          : (c == 1 ? w->sun_radiance.y : w->sun_radiance.z));
    }
    ex.g2 = -0.3;
    ex.w2 = 0.2;
    ex.sun = sq__dv_from(w->sun_dir);
    ex.below = below;
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.fov_y_deg = 6.0f;
    if (!below) { /* above, looking down and away from the sun: back-scatter side */
        cam.position_m = sq_v3(0, 0, 30);
        cam.target_m = sq_v3(20, 8, 0.5f);
    } else { /* below, looking up 65 deg, 20 deg in azimuth from the sun: forward side */
        cam.position_m = sq_v3(0, 0, -30);
        double el = 65.0 * SQ_PI / 180.0, az = 20.0 * SQ_PI / 180.0;
        cam.target_m = sq_v3((float)(cos(el) * cos(az)), (float)(cos(el) * sin(az)),
                             (float)(-30.0 + sin(el)));
    }
    const int W = 24, H2 = 24, SPP = 256;
    float *img = (float *)malloc(sizeof(float) * W * H2 * 3);
    SQ_CHECK_OK(render(ctx, W, H2, SPP, 1, w, &cam, &dr, 1, img));
    check_image(below ? "single scatter (transmission)" : "single scatter (reflection)", img, W,
                H2, SPP, &cam, exact_slab_ss, &ex);
    free(img);
    free(dens);
    free(w);
    sq_context_destroy(ctx);
}

SQ_TEST(single_scatter_slab_reflection) { single_scatter_case(false); }
SQ_TEST(single_scatter_slab_transmission) { single_scatter_case(true); }

/* ---- (c) furnaces --------------------------------------------------------------------------- */

typedef struct const_L {
    double L[3];
} const_L;
static void exact_const(void *user, sq__dv3 d, double out[3])
{
    (void)d;
    for (int c = 0; c < 3; c++) out[c] = ((const_L *)user)->L[c];
}

/* A heterogeneous blob: density = dmax * (1 - r^2) inside the unit ball of the grid. */
static float *blob_grid(int n, float dmax, uint64_t seed)
{
    float *d = (float *)malloc(sizeof(float) * n * n * n);
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double x = (i + 0.5) / n * 2 - 1, y = (j + 0.5) / n * 2 - 1, z = (k + 0.5) / n * 2 - 1;
                double r2 = x * x + y * y + z * z;
                double noise = 0.5 + sq_rng_uniform_d(seed, 7, (uint64_t)((k * n + j) * n + i));
                d[(k * n + j) * n + i] = r2 < 1.0 ? (float)((double)dmax * (1.0 - r2) * noise) : 0.0f;
            }
    return d;
}

SQ_TEST(white_furnace_conserves_energy)
{
    /* albedo 1 everywhere, uniform sky L in every direction (no terrain), no sun: the radiance
     * of every pixel is exactly L whatever the medium does (here spectrally varying sigma_ext
     * and g, a back lobe, optical depths up to ~20). */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 1.0f, 0.5f, 0.25f);
    const int n = 24;
    float *dens = blob_grid(n, 1.0f, 3);
    const float sig[3] = {1.0f, 1.6f, 2.2f}, alb[3] = {1, 1, 1}, g[3] = {0.8f, 0.5f, 0.0f};
    sq_drawable dr = volume_drawable(dens, n, n, n, sq_v3(-5, -5, -5), sq_v3(10, 10, 10), sig,
                                     alb, g);
    dr.u.volume.g2 = -0.4f;
    dr.u.volume.w2 = 0.3f;
    sq_camera cam = {.position_m = sq_v3(-20, -3, 2), .target_m = sq_v3(0, 0, 0),
                     .fov_y_deg = 25.0f};
    const int W = 32, H = 32, SPP = 64;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(render(ctx, W, H, SPP, 100000, w, &cam, &dr, 1, img));
    const_L ex = {{1.0, 0.5, 0.25}};
    check_image("white furnace", img, W, H, SPP, &cam, exact_const, &ex);
    /* the centre pixel looks through the blob */
    double centre = img[3 * (H / 2 * W + W / 2)];
    printf("centre pixel %.4f (sky 1)\n", centre);
    free(img);
    free(dens);
    free(w);
    sq_context_destroy(ctx);
}

SQ_TEST(furnace_black_ground_loses_energy)
{
    /* the same white medium resting on a black ground under a uniform sky: no pixel may exceed
     * the sky radiance beyond Monte Carlo error, and the mean over the blob must be below it. */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 1.0f, 1.0f, 1.0f);
    static float heights[9];
    w->nx = 3;
    w->ny = 3;
    w->dx = w->dy = 1000.0f;
    w->origin = sq_v3(-1000, -1000, 0);
    w->heights = heights;
    w->ground_albedo = sq_v3(0, 0, 0);
    const int n = 16;
    float *dens = blob_grid(n, 2.0f, 5);
    const float sig[3] = {1.0f, 1.0f, 1.0f}, alb[3] = {1, 1, 1}, g[3] = {0.6f, 0.6f, 0.6f};
    sq_drawable dr = volume_drawable(dens, n, n, n, sq_v3(-5, -5, 0), sq_v3(10, 10, 10), sig, alb,
                                     g);
    sq_camera cam = {.position_m = sq_v3(-20, 0, 5), .target_m = sq_v3(0, 0, 5),
                     .fov_y_deg = 20.0f};
    const int W = 16, H = 16, SPP = 64;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, &dr, 1, false, &s));
    if (!s) return;
    s->terrain.shade = SQ__REF_SHADE_CONST;
    for (int c = 0; c < 3; c++) s->terrain.albedo[c] = 0.0;
    sq_reference_desc rd = {.width = W, .height = H, .samples = SPP, .seed = 1};
    SQ_CHECK_OK(sq__ref_render_scene(ctx, &rd, s, &cam, img));
    sq__ref_scene_destroy(s);
    double sum = 0, sum2 = 0;
    for (int i = 0; i < W * H; i++) {
        sum += img[3 * i + 1];
        sum2 += (double)img[3 * i + 1] * img[3 * i + 1];
    }
    double mean = sum / (W * H), se = sqrt((sum2 / (W * H) - mean * mean) / (W * H - 1));
    printf("black ground furnace: mean %.4f +- %.4f (sky 1), N = %d\n", mean, se, W * H * SPP);
    SQ_CHECK(mean < 1.0 - 4.0 * se);
    SQ_CHECK(mean > 0.0);
    /* the top row sees only sky and the blob top: no energy created there either */
    double top = 0, top2 = 0;
    for (int i = 0; i < W; i++) {
        top += img[3 * i + 1];
        top2 += (double)img[3 * i + 1] * img[3 * i + 1];
    }
    double tm = top / W, ts = sqrt(fmax(top2 / W - tm * tm, 0.0) / (W - 1));
    printf("top row: mean %.4f +- %.4f\n", tm, ts);
    SQ_CHECK(tm <= 1.0 + 4.0 * ts + 1e-6);
    free(img);
    free(dens);
    free(w);
    sq_context_destroy(ctx);
}

/* ---- Lambertian terrain ------------------------------------------------------------------- */

SQ_TEST(lambertian_plane_sun_and_sky)
{
    /* a flat terrain of albedo a under a uniform sky L and a sun of sun_radiance E (irradiance
     * pi E) at elevation 30 deg: every pixel is a (L + E sin(30 deg)) exactly. */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 0.8f, 0.9f, 1.0f);
    set_sun(w, 30.0, 60.0, sq_v3(5.0f, 4.0f, 3.0f));
    float heights[25];
    for (int i = 0; i < 25; i++) heights[i] = 12.0f;
    w->nx = 5;
    w->ny = 5;
    w->dx = w->dy = 100.0f;
    w->origin = sq_v3(-200, -200, 0);
    w->heights = heights;
    sq_camera cam = {.position_m = sq_v3(-30, 10, 60), .target_m = sq_v3(0, 0, 12),
                     .fov_y_deg = 30.0f};
    const int W = 16, H = 16, SPP = 64;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    /* constant albedo instead of the terrain kind's colour and detail noise */
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, NULL, 0, false, &s));
    if (!s) return;
    const double E[3] = {5, 4, 3}, L[3] = {0.8, 0.9, 1.0}, a[3] = {0.2, 0.4, 0.6};
    s->terrain.shade = SQ__REF_SHADE_CONST;
    for (int c = 0; c < 3; c++) s->terrain.albedo[c] = a[c];
    sq_reference_desc rd = {.width = W, .height = H, .samples = SPP, .seed = 1};
    SQ_CHECK_OK(sq__ref_render_scene(ctx, &rd, s, &cam, img));
    sq__ref_scene_destroy(s);
    /* irradiance pi E mu0 from the sun, pi L from the sky: radiance a (E mu0 + L) */
    const_L ex;
    for (int c = 0; c < 3; c++) ex.L[c] = a[c] * (L[c] + E[c] * 0.5);
    check_image("lambertian plane", img, W, H, SPP, &cam, exact_const, &ex);
    free(img);
    free(w);
    sq_context_destroy(ctx);
}

/* ---- geometry ------------------------------------------------------------------------------- */

SQ_TEST(heightfield_intersection_matches_brute_force)
{
    const int nx = 37, ny = 29;
    float *h = (float *)malloc(sizeof(float) * nx * ny);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++)
            h[j * nx + i] = (float)(20.0 * sin(0.3 * i) * cos(0.23 * j) +
                                    10.0 * sq_rng_uniform_d(1, 2, (uint64_t)(j * nx + i)));
    sq__ref_heightfield hf;
    memset(&hf, 0, sizeof hf);
    hf.nx = nx;
    hf.ny = ny;
    hf.ox = -100;
    hf.oy = 50;
    hf.dx = 7.5;
    hf.dy = 5.0;
    hf.h = h;
    hf.bnx = (nx - 1 + SQ__REF_BLOCK - 1) / SQ__REF_BLOCK;
    hf.bny = (ny - 1 + SQ__REF_BLOCK - 1) / SQ__REF_BLOCK;
    /* build the bounds the way the scene does: through a world */
    sq_world *w = world_new();
    w->nx = nx;
    w->ny = ny;
    w->dx = 7.5f;
    w->dy = 5.0f;
    w->origin = sq_v3(-100, 50, 0);
    w->heights = h;
    sq_context *ctx = ctx_new(1);
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, NULL, 0, false, &s));
    int hits = 0, mismatches = 0;
    for (int r = 0; r < 4000 && s; r++) {
        double u[8];
        for (int k = 0; k < 8; k++) u[k] = sq_rng_uniform_d(9, (uint64_t)r, (uint64_t)k);
        sq__dv3 o = sq__dv(-140 + 350 * u[0], 20 + 200 * u[1], -20 + 80 * u[2]);
        sq__dv3 d = sq__dv_norm(sq__dv(u[3] - 0.5, u[4] - 0.5, (u[5] - 0.7) * (r % 3 == 0 ? 0.05 : 1.0)));
        /* brute force over every triangle */
        double tb = INFINITY;
        for (int j = 0; j + 1 < ny; j++)
            for (int i = 0; i + 1 < nx; i++) {
                sq__dv3 p[4] = {
                    sq__dv(hf.ox + i * hf.dx, hf.oy + j * hf.dy, h[j * nx + i]),
                    sq__dv(hf.ox + (i + 1) * hf.dx, hf.oy + j * hf.dy, h[j * nx + i + 1]),
                    sq__dv(hf.ox + (i + 1) * hf.dx, hf.oy + (j + 1) * hf.dy, h[(j + 1) * nx + i + 1]),
                    sq__dv(hf.ox + i * hf.dx, hf.oy + (j + 1) * hf.dy, h[(j + 1) * nx + i])};
                for (int t = 0; t < 2; t++) {
                    sq__dv3 a = p[0], b = p[t == 0 ? 1 : 2], c = p[t == 0 ? 2 : 3];
                    sq__dv3 e1 = sq__dv_sub(b, a), e2 = sq__dv_sub(c, a);
                    sq__dv3 pv = sq__dv_cross(d, e2);
                    double det = sq__dv_dot(e1, pv);
                    if (fabs(det) < 1e-300) continue;
                    sq__dv3 tv = sq__dv_sub(o, a);
                    double uu = sq__dv_dot(tv, pv) / det;
                    sq__dv3 qv = sq__dv_cross(tv, e1);
                    double vv = sq__dv_dot(d, qv) / det, tt = sq__dv_dot(e2, qv) / det;
                    if (uu >= 0 && vv >= 0 && uu + vv <= 1 && tt > 0 && tt < tb) tb = tt;
                }
            }
        sq__ref_hit hit;
        bool got = sq__ref_heightfield_intersect(&s->terrain, o, d, 0.0, INFINITY, &hit);
        if (isfinite(tb)) hits++;
        if (got != isfinite(tb) || (got && fabs(hit.t - tb) > 1e-6 * (1 + tb))) {
            if (mismatches < 5)
                printf("ray %d: got %d t %.9g, brute %.9g\n", r, got, got ? hit.t : -1.0, tb);
            mismatches++;
        }
        if (got) {
            SQ_CHECK(sq__dv_dot(hit.ng, d) < 0);
            SQ_CHECK(fabs(sq__dv_dot(hit.ng, hit.ng) - 1) < 1e-9);
        }
    }
    printf("%d of 4000 rays hit; %d mismatches\n", hits, mismatches);
    SQ_CHECK(hits > 1000);
    SQ_CHECK(mismatches == 0);
    sq__ref_scene_destroy(s);
    sq_context_destroy(ctx);
    free(w);
    free(h);
}

SQ_TEST(obstacle_intersection_box_and_house)
{
    sq_world *w = world_new();
    w->obstacle_count = 2;
    w->obstacles[0] = (sq_obstacle){.kind = SQ_OBSTACLE_BOX, .center_m = sq_v3(10, 0, 0),
                                    .size_m = sq_v3(4, 2, 6), .yaw_deg = 90.0f};
    w->obstacles[1] = (sq_obstacle){.kind = SQ_OBSTACLE_HOUSE, .center_m = sq_v3(-20, 5, 1),
                                    .size_m = sq_v3(8, 6, 3), .roof_m = 2.0f};
    sq_context *ctx = ctx_new(1);
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, NULL, 0, false, &s));
    if (s) {
        sq__ref_hit h;
        /* yaw 90: the 4 m side now lies along y, the 2 m side along x: a ray along +x at z = 3
         * meets the face x = 10 - 1 */
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0, 0, 3), sq__dv(1, 0, 0), 0,
                                            INFINITY, &h));
        SQ_CHECK_NEAR(h.t, 9.0, 1e-9);
        SQ_CHECK_NEAR(h.ng.x, -1.0, 1e-9);
        /* ... and misses at y = 1.5 along x (inside 2 m of the unrotated y but not rotated) */
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0, 1.5, 3), sq__dv(1, 0, 0),
                                            0, INFINITY, &h));
        SQ_CHECK(!sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0, 2.5, 3),
                                             sq__dv(1, 0, 0), 0, INFINITY, &h));
        /* house: walls 3 m from base z = 1, ridge 2 m above along x; a vertical ray at
         * y offset 1.5 from the ridge line meets the roof at 1 + 3 + 2 (1 - 1.5/3) = 5 */
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-19, 6.5, 50),
                                            sq__dv(0, 0, -1), 0, INFINITY, &h));
        SQ_CHECK_NEAR(50.0 - h.t, 5.0, 1e-9);
        SQ_CHECK(h.ng.y > 0 && h.ng.z > 0);
        /* above the eaves outside the footprint: miss; through the gable end along x at the
         * ridge height minus 0.1: hit the end wall x = -24 */
        SQ_CHECK(!sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-19, 8.2, 50),
                                             sq__dv(0, 0, -1), 0, INFINITY, &h));
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-40, 5, 5.9),
                                            sq__dv(1, 0, 0), 0, INFINITY, &h));
        SQ_CHECK_NEAR(h.t, 16.0, 1e-9);
        SQ_CHECK(!sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-40, 5, 6.1),
                                             sq__dv(1, 0, 0), 0, INFINITY, &h));
        /* renderer.c default colours for zero albedo: concrete box, clay-tile roof */
        SQ_CHECK_NEAR(s->obstacles[0].albedo[0], 0.50, 1e-6);
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-19, 6.5, 50),
                                            sq__dv(0, 0, -1), 0, INFINITY, &h));
        SQ_CHECK_NEAR(h.albedo[0], 0.40, 1e-6);
        SQ_CHECK_NEAR(h.albedo[1], 0.19, 1e-6);
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[1], sq__dv(-40, 5, 2),
                                            sq__dv(1, 0, 0), 0, INFINITY, &h));
        SQ_CHECK_NEAR(h.albedo[0], 0.70, 1e-6);
        sq__ref_scene_destroy(s);
    }
    sq_context_destroy(ctx);
    free(w);
}

SQ_TEST(fence_is_porous_like_the_gl_fence)
{
    /* a fence 6 m long along x, 0.2 m thick, 2 m high: boards 0.10 m, gaps 0.05 m (along x
     * from the centre, period 0.15 m), solid rails in the bottom and top 12 % */
    sq_world *w = world_new();
    w->obstacle_count = 1;
    w->obstacles[0] = (sq_obstacle){.kind = SQ_OBSTACLE_FENCE, .center_m = sq_v3(0, 0, 0),
                                    .size_m = sq_v3(6, 0.2f, 2)};
    sq_context *ctx = ctx_new(1);
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, NULL, 0, false, &s));
    if (s) {
        sq__ref_hit h;
        const sq__dv3 d = sq__dv(0, 1, 0);
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0.05, -5, 1), d, 0, INFINITY, &h));
        SQ_CHECK_NEAR(h.t, 4.9, 1e-6); /* 0.2f is not exact in float */
        SQ_CHECK(!sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0.125, -5, 1), d, 0, INFINITY, &h));
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0.125, -5, 0.1), d, 0, INFINITY, &h));
        SQ_CHECK(sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(0.125, -5, 1.9), d, 0, INFINITY, &h));
        /* the fraction of horizontal rays passing at mid height is the gap fraction 1/3 */
        int pass = 0;
        const int n = 3000;
        for (int i = 0; i < n; i++) {
            double x = -2.0 + 4.0 * (i + 0.5) / n;
            if (!sq__ref_obstacle_intersect(&s->obstacles[0], sq__dv(x, -5, 1), d, 0, INFINITY, &h))
                pass++;
        }
        SQ_CHECK_NEAR((double)pass / n, 1.0 / 3.0, 0.01);
        sq__ref_scene_destroy(s);
    }
    sq_context_destroy(ctx);
    free(w);
}

SQ_TEST(camera_matches_sqmath_projection)
{
    /* a small black box at a world point projected with sq_m4_look_at/perspective lands on the
     * dark pixel of the rendered image (uniform bright sky elsewhere). */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    world_uniform_sky(w, 1, 1, 1);
    const sq_vec3 P = sq_v3(30, 14, 9);
    w->obstacle_count = 1;
    w->obstacles[0] = (sq_obstacle){.kind = SQ_OBSTACLE_BOX, .center_m = sq_v3(P.x, P.y, P.z - 0.4f),
                                    .size_m = sq_v3(0.8f, 0.8f, 0.8f),
                                    .albedo = sq_v3(1e-6f, 1e-6f, 1e-6f)};
    sq_camera cam = {.position_m = sq_v3(0, 0, 2), .target_m = sq_v3(40, 5, 4),
                     .fov_y_deg = 45.0f};
    const int W = 64, H = 40;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    SQ_CHECK_OK(render(ctx, W, H, 4, 0, w, &cam, NULL, 0, img));
    sq_mat4 vp = sq_m4_mul(sq_m4_perspective(45.0f * SQ_PI_F / 180.0f, (float)W / H, 0.5f, 1000.0f),
                           sq_m4_look_at(cam.position_m, cam.target_m, sq_v3(0, 0, 1)));
    sq_vec4 c = sq_m4_mul_v4(vp, (sq_vec4){P.x, P.y, P.z, 1.0f});
    double sx = (c.x / c.w * 0.5 + 0.5) * W, sy = (0.5 - c.y / c.w * 0.5) * H;
    int px = (int)sx, py = (int)sy;
    printf("projected to pixel (%d, %d) of %d x %d\n", px, py, W, H);
    SQ_CHECK(px > 0 && px < W && py > 0 && py < H);
    if (px > 0 && px < W && py > 0 && py < H) {
        SQ_CHECK(img[3 * (py * W + px)] < 0.05f);
        int far = 3 * ((H - 1 - py) * W + (W - 1 - px));
        SQ_CHECK(img[far] > 0.99f);
    }
    free(img);
    free(w);
    sq_context_destroy(ctx);
}

SQ_TEST(sky_matches_gl_sky_function)
{
    /* the sky of frame_common.glsl: gradient weight (1 - d.z)^3 from zenith to horizon, ground
     * light below the horizon (full at -0.15), a haze glow around the sun with turbidity, and
     * the sun disc only for camera rays */
    sq_context *ctx = ctx_new(0);
    sq_world *w = world_new();
    w->sky_zenith = sq_v3(0.2f, 0.4f, 1.0f);
    w->sky_horizon = sq_v3(1.0f, 0.9f, 0.8f);
    w->ground_albedo = sq_v3(0.5f, 0.5f, 0.5f);
    set_sun(w, 30.0, 0.0, sq_v3(2, 2, 2));
    w->turbidity = 1.0f; /* no glow */
    sq__ref_scene *s = NULL;
    SQ_CHECK_OK(sq__ref_scene_create(ctx, w, NULL, 0, false, &s));
    if (!s) return;
    double L[3];
    sq__ref_sky(s, sq__dv(0, 0, 1), 0.0, false, L);
    SQ_CHECK_NEAR(L[0], 0.2, 1e-7);
    sq__ref_sky(s, sq__dv(0, 1, 0), 0.0, false, L);
    SQ_CHECK_NEAR(L[2], 0.8, 1e-7);
    sq__ref_sky(s, sq__dv_norm(sq__dv(0, sqrt(3.0), 1)), 0.0, false, L); /* d.z = 0.5: weight 1/8 */
    SQ_CHECK_NEAR(L[0], 0.2 + 0.8 / 8.0, 1e-7);
    sq__ref_sky(s, sq__dv_norm(sq__dv(0, 1, -1)), 0.0, false, L); /* ground: 0.5 (2 * 0.5 + mean sky) */
    SQ_CHECK_NEAR(L[1], 0.5 * (2.0 * 0.5 + 0.5 * (0.4 + 0.9)), 1e-6);
    double glow0[3], glow3[3];
    sq__dv3 near_sun = sq__dv_norm(sq__dv(cos(0.5), 0.1, sin(0.5)));
    sq__ref_sky(s, near_sun, 0.0, false, glow0);
    s->turbidity = 3.0;
    sq__ref_sky(s, near_sun, 0.0, false, glow3);
    SQ_CHECK(glow3[0] > glow0[0] + 0.01);
    /* seen from 3 km up the glow is that of the aerosol above: optical depth 0.05 (T - 1)
     * exp(-3 km / 1.5 km) along the zenith (frame_common.glsl sq_haze_depth_above_camera) */
    double glow3z[3];
    sq__ref_sky(s, near_sun, 3000.0, false, glow3z);
    const double tau0 = 0.1 / near_sun.z, tau3 = tau0 * exp(-2.0);
    SQ_CHECK_NEAR((glow3z[0] - glow0[0]) / (glow3[0] - glow0[0]), -expm1(-tau3) / -expm1(-tau0),
                  1e-9);
    double disc[3];
    sq__ref_sky(s, s->sun_dir, 0.0, true, disc);
    sq__ref_sky(s, s->sun_dir, 0.0, false, L);
    SQ_CHECK(disc[0] > L[0] + 1000.0);
    sq__ref_scene_destroy(s);
    /* camera rays see it: top row (nearer the zenith) bluer than the bottom row */
    w->turbidity = 0.0f;
    sq_camera cam = {.position_m = sq_v3(0, 0, 0), .target_m = sq_v3(-1, 0, 0.3f), .fov_y_deg = 60};
    const int W = 8, H = 8;
    float img[8 * 8 * 3];
    SQ_CHECK_OK(render(ctx, W, H, 16, 0, w, &cam, NULL, 0, img));
    SQ_CHECK(img[0] < img[3 * (7 * W)]); /* red: top row nearer the zenith (0.2 < 1.0) */
    free(w);
    sq_context_destroy(ctx);
}

SQ_TEST(terrain_albedo_follows_gl_shading)
{
    /* terrain.frag: kind colour on gentle slopes, rock above ~40 degrees, detail noise of mean
     * about 1 */
    sq_vec3 flat, steep;
    sq_world kw;
    memset(&kw, 0, sizeof kw);
    kw.terrain_kind = SQ_TERRAIN_HILLS;
    sq__terrain_albedo(&kw, &flat, &steep);
    const double f[3] = {flat.x, flat.y, flat.z}, st[3] = {steep.x, steep.y, steep.z};
    double sum = 0.0, a[3];
    const int n = 20000;
    for (int i = 0; i < n; i++) {
        sq__dv3 p = sq__dv(1000.0 * sq_rng_uniform_d(4, 0, (uint64_t)i),
                           1000.0 * sq_rng_uniform_d(4, 1, (uint64_t)i), 0);
        sq__ref_terrain_albedo(f, st, p, sq__dv(0, 0, 1), a);
        sum += a[1] / f[1];
    }
    printf("mean detail factor %.4f\n", sum / n);
    SQ_CHECK_NEAR(sum / n, 1.0, 0.05);
    sq__dv3 p = sq__dv(12.3, 45.6, 0);
    double af[3], as[3];
    sq__ref_terrain_albedo(f, st, p, sq__dv(0, 0, 1), af);
    sq__ref_terrain_albedo(f, st, p, sq__dv_norm(sq__dv(1, 0, 1)), as); /* 45 degrees: rock */
    SQ_CHECK_NEAR(af[0] / f[0], af[1] / f[1], 1e-12);
    SQ_CHECK_NEAR(as[0] / st[0], as[2] / st[2], 1e-12);
    SQ_CHECK_NEAR(as[0] / st[0], af[0] / f[0], 1e-12);
    /* the GL noise: value noise in [0, 1], continuous */
    for (int i = 0; i < 1000; i++) {
        double x = 100.0 * sq_rng_uniform_d(5, 0, (uint64_t)i) - 50.0, y = 0.37 * i - 100.0;
        double v = sq__ref_value_noise(x, y);
        SQ_CHECK(v >= 0.0 && v <= 1.0);
        SQ_CHECK(fabs(sq__ref_value_noise(x + 1e-7, y) - v) < 1e-5);
    }
}

/* ---- phase function ------------------------------------------------------------------------- */

SQ_TEST(hg_normalised_sampled_and_forward)
{
    const double gs[5] = {-0.8, -0.3, 0.0, 0.5, 0.9};
    for (int k = 0; k < 5; k++) {
        double g = gs[k];
        /* normalisation: 2 pi int p dmu = 1 (Simpson, 20001 nodes) */
        const int n = 20000;
        double s = 0;
        for (int i = 0; i <= n; i++) {
            double mu = -1.0 + 2.0 * i / n, wgt = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
            s += wgt * sq__hg_eval(g, mu);
        }
        s *= 2.0 / n / 3.0 * 2.0 * SQ_PI;
        SQ_CHECK_NEAR(s, 1.0, 1e-6);
        /* sampling: mean cosine = g, mean cos^2 = (1 + 2 g^2) / 3 for HG */
        const int N = 200000;
        double m1 = 0, m2 = 0;
        for (int i = 0; i < N; i++) {
            double mu = sq__hg_sample_cos(g, sq_rng_uniform_d(77, (uint64_t)k, (uint64_t)i));
            m1 += mu;
            m2 += mu * mu;
        }
        m1 /= N;
        m2 /= N;
        double var = m2 - m1 * m1;
        printf("g = %.2f: <mu> = %.5f, <mu^2> = %.5f (exact %.5f)\n", g, m1, m2,
               (1 + 2 * g * g) / 3);
        SQ_CHECK_NEAR(m1, g, 4.0 * sqrt(var / N) + 1e-12);
        SQ_CHECK_NEAR(m2, (1 + 2 * g * g) / 3, 0.01);
    }
    /* g > 0 forward: the propagation directions agree -> larger phase */
    SQ_CHECK(sq__hg_eval(0.7, 1.0) > 10 * sq__hg_eval(0.7, -1.0));
    /* sampled directions are unit and at the requested cosine */
    sq__dv3 d = sq__dv_norm(sq__dv(0.3, -0.5, 0.8));
    sq__dv3 e = sq__ref_direction_around(d, 0.25, 0.6);
    SQ_CHECK_NEAR(sq__dv_dot(e, e), 1.0, 1e-12);
    SQ_CHECK_NEAR(sq__dv_dot(e, d), 0.25, 1e-12);
}

/* ---- (d) determinism and API ------------------------------------------------------------------ */

/* A scene with everything: hills, a house, a box, a dust blob, sun and sky. */
typedef struct full_scene {
    sq_world *w;
    float *heights, *dens;
    sq_drawable dr;
    sq_camera cam;
} full_scene;

static void full_scene_make(full_scene *fs)
{
    sq_world *w = world_new();
    w->sky_zenith = sq_v3(0.3f, 0.5f, 1.0f);
    w->sky_horizon = sq_v3(0.9f, 0.9f, 0.9f);
    set_sun(w, 35.0, 200.0, sq_v3(3, 2.8f, 2.5f));
    const int n = 33;
    fs->heights = (float *)malloc(sizeof(float) * n * n);
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) fs->heights[j * n + i] = (float)(4.0 * sin(0.4 * i) * sin(0.3 * j));
    w->nx = w->ny = n;
    w->dx = w->dy = 4.0f;
    w->origin = sq_v3(-64, -64, 0);
    w->heights = fs->heights;
    w->ground_albedo = sq_v3(0.5f, 0.4f, 0.3f);
    w->obstacle_count = 2;
    w->obstacles[0] = (sq_obstacle){.kind = SQ_OBSTACLE_HOUSE, .center_m = sq_v3(10, 8, NAN),
                                    .size_m = sq_v3(8, 6, 4), .roof_m = 3, .yaw_deg = 30};
    w->obstacles[1] = (sq_obstacle){.kind = SQ_OBSTACLE_BOX, .center_m = sq_v3(-12, 6, -2),
                                    .size_m = sq_v3(5, 5, 9)};
    fs->dens = blob_grid(16, 0.5f, 11);
    const float sig[3] = {0.8f, 0.9f, 1.0f}, alb[3] = {0.9f, 0.8f, 0.6f}, g[3] = {0.7f, 0.7f, 0.7f};
    fs->dr = volume_drawable(fs->dens, 16, 16, 16, sq_v3(-15, -15, -2), sq_v3(30, 30, 15), sig, alb, g);
    memset(&fs->cam, 0, sizeof fs->cam);
    fs->cam.position_m = sq_v3(-50, -30, 20);
    fs->cam.target_m = sq_v3(0, 0, 2);
    fs->cam.fov_y_deg = 50;
    fs->w = w;
}

static void full_scene_free(full_scene *fs)
{
    free(fs->w);
    free(fs->heights);
    free(fs->dens);
}

SQ_TEST(deterministic_across_thread_counts)
{
    full_scene fs;
    full_scene_make(&fs);
    const int W = 40, H = 24;
    float *a = (float *)malloc(sizeof(float) * W * H * 3);
    float *b = (float *)malloc(sizeof(float) * W * H * 3);
    sq_context *c1 = ctx_new(1), *c2 = ctx_new(2);
    SQ_CHECK_OK(render(c1, W, H, 4, 0, fs.w, &fs.cam, &fs.dr, 1, a));
    SQ_CHECK_OK(render(c2, W, H, 4, 0, fs.w, &fs.cam, &fs.dr, 1, b));
    SQ_CHECK(memcmp(a, b, sizeof(float) * W * H * 3) == 0);
    double sum = 0;
    for (int i = 0; i < W * H * 3; i++) {
        SQ_CHECK(isfinite(a[i]) && a[i] >= 0.0f);
        sum += a[i];
    }
    SQ_CHECK(sum > 0);
    /* another seed gives another (noisy) image */
    sq_reference_desc d = {.width = W, .height = H, .samples = 4, .seed = 999};
    SQ_CHECK_OK(sq_reference_render(c2, &d, fs.w, &fs.cam, &fs.dr, 1, b));
    SQ_CHECK(memcmp(a, b, sizeof(float) * W * H * 3) != 0);
    free(a);
    free(b);
    sq_context_destroy(c1);
    sq_context_destroy(c2);
    full_scene_free(&fs);
}

static int progress_calls;
static double progress_last;
static bool progress_ok;
static bool progress_cb(void *user, double f)
{
    int stop_after = *(int *)user;
    if (f < progress_last) progress_ok = false;
    progress_last = f;
    return ++progress_calls < stop_after;
}

SQ_TEST(progress_and_cancel)
{
    full_scene fs;
    full_scene_make(&fs);
    sq_context *ctx = ctx_new(1); /* one thread: the reporting thread renders every pixel */
    const int W = 16, H = 70;
    float *img = (float *)malloc(sizeof(float) * W * H * 3);
    int never = 1 << 30;
    sq_reference_desc d = {.width = W, .height = H, .samples = 1, .progress = progress_cb,
                           .progress_user = &never};
    progress_calls = 0;
    progress_last = -1;
    progress_ok = true;
    SQ_CHECK_OK(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img));
    SQ_CHECK(progress_ok);
    SQ_CHECK(progress_calls >= 3);
    SQ_CHECK(progress_last == 1.0);
    int stop = 2;
    d.progress_user = &stop;
    progress_calls = 0;
    progress_last = -1;
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img), SQ_ERR_CANCELLED,
                 "cancelled");
    SQ_CHECK(progress_calls == 2);
    free(img);
    sq_context_destroy(ctx);
    full_scene_free(&fs);
}

SQ_TEST(rejects_bad_input)
{
    full_scene fs;
    full_scene_make(&fs);
    sq_context *ctx = ctx_new(1);
    float img[8 * 8 * 3];
    sq_reference_desc d = {.width = 8, .height = 8, .samples = 0};
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "samples = 0; must be > 0");
    d.samples = -3;
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "samples = -3; must be > 0");
    d.samples = 1;
    fs.dens[5] = NAN;
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "density at cell (5, 0, 0) is nan");
    fs.dens[5] = 0.0f;
    fs.dr.u.volume.albedo[1] = 1.5f;
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "albedo[1] = 1.5; must be in [0, 1]");
    fs.dr.u.volume.albedo[1] = 0.5f;
    sq_camera inside = fs.cam;
    inside.position_m = sq_v3(-20, -5, -5);
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &inside, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "inside the terrain");
    sq_camera same = fs.cam;
    same.target_m = same.position_m;
    SQ_CHECK_ERR(sq_reference_render(ctx, &d, fs.w, &same, &fs.dr, 1, img), SQ_ERR_INVALID_ARG,
                 "they must differ");
    SQ_CHECK_OK(sq_reference_render(ctx, &d, fs.w, &fs.cam, &fs.dr, 1, img));
    sq_context_destroy(ctx);
    full_scene_free(&fs);
}
