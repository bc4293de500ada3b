/* test_volume.c — render tests of the volume pass (half-angle slicing with multiple forward
 * scattering, SPEC 3.3-3.4) and of the soft-particle pass (SPEC 4.2-4.5), judged by physics on
 * read-back LINEAR pixels (headless GL; llvmpipe without a GPU).
 *
 * Pixel rays are rebuilt here from the public camera (sq_camera_view / sq_camera_proj, as the
 * renderer does), so that every check knows exactly which surface and which path length a
 * pixel sees. Set SQ_VOLUME_DUMP=<dir> to write the frames as PNG for inspection. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"
#include "render/volume_sky.h"
#include "squall/io.h"
#include "squall/render.h"
#include "squall/world.h"
#include "sq_test.h"
#include "world/world_struct.h"

SQ_LABEL(render)
SQ_REQUIRES(gl)

#define IMG_W 320
#define IMG_H 180

/* ---- helpers ------------------------------------------------------------------------------ */

static sq_context *new_ctx(void)
{
    sq_context_desc cd = {0};
    cd.threads = 2;
    cd.log_level = SQ_LOG_NONE;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    return ctx;
}

/* Flat terrain at z = 0, clean air (turbidity 1: no haze glow, ~1e-5 /m aerial haze). */
static sq_world *new_world(sq_context *ctx, float size_m, const sq_obstacle *obs, int n)
{
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = size_m;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.sky.turbidity = 1.0f;
    wd.obstacles = obs;
    wd.obstacle_count = n;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    return w;
}

static sq_renderer *new_renderer_amb(sq_context *ctx, int slices, bool single_scatter,
                                     bool uniform_ambient)
{
    sq_render_desc rd = {0};
    rd.volume_ambient_uniform = uniform_ambient;
    rd.width = IMG_W;
    rd.height = IMG_H;
    rd.volume_slices = slices;
    rd.single_scatter_only = single_scatter;
    rd.seed = 7;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    return r;
}

static sq_renderer *new_renderer(sq_context *ctx, int slices, bool single_scatter)
{
    return new_renderer_amb(ctx, slices, single_scatter, false);
}

static sq_camera camera(sq_vec3 pos, sq_vec3 target, float fov)
{
    sq_camera c = {0};
    c.position_m = pos;
    c.target_m = target;
    c.fov_y_deg = fov;
    c.near_m = 0.5f;
    c.far_m = 20000.0f;
    return c;
}

static void dump(const char *name, const float *rgb)
{
    const char *dir = getenv("SQ_VOLUME_DUMP");
    if (!dir || !rgb || !name) return;
    uint8_t *rgba = malloc((size_t)IMG_W * IMG_H * 4);
    if (!rgba) return;
    sq_tonemap_rgba8(rgb, IMG_W, IMG_H, 1.0f, rgba);
    char path[512];
    snprintf(path, sizeof path, "%s/%s.png", dir, name);
    sq_png_write_rgba8(path, IMG_W, IMG_H, rgba, true);
    free(rgba);
}

/* Draws one frame and returns its linear RGB (caller frees), NULL on failure. */
static float *render(sq_renderer *r, const sq_world *w, const sq_camera *c, const sq_drawable *d,
                     int n, double t, const char *name)
{
    sq_result res = sq_renderer_draw(r, w, c, d, n, t);
    SQ_CHECK_OK(res);
    if (res != SQ_OK) return NULL;
    float *rgb = malloc(sizeof(float) * 3 * IMG_W * IMG_H);
    if (!rgb) return NULL;
    SQ_CHECK_OK(sq_renderer_read_linear(r, rgb));
    dump(name, rgb);
    return rgb;
}

/* Sum over pixels of |a - b| in green. */
static double image_l1(const float *a, const float *b)
{
    double s = 0.0;
    for (size_t k = 1; k < (size_t)3 * IMG_W * IMG_H; k += 3) s += fabs((double)a[k] - b[k]);
    return s;
}

/* Ray of pixel (i, j), j counted from the top row, through its centre. */
static void pixel_ray(const sq_camera *c, int i, int j, sq_vec3 *o, sq_vec3 *d)
{
    const sq_mat4 vp = sq_m4_mul(sq_camera_proj(c, (float)IMG_W / (float)IMG_H), sq_camera_view(c));
    const sq_mat4 inv = sq_m4_inverse(vp);
    const float x = ((float)i + 0.5f) / (float)IMG_W * 2.0f - 1.0f;
    const float y = 1.0f - ((float)j + 0.5f) / (float)IMG_H * 2.0f;
    sq_vec4 a = sq_m4_mul_v4(inv, (sq_vec4){x, y, -1.0f, 1.0f});
    sq_vec4 b = sq_m4_mul_v4(inv, (sq_vec4){x, y, 1.0f, 1.0f});
    const sq_vec3 pa = sq_v3(a.x / a.w, a.y / a.w, a.z / a.w);
    const sq_vec3 pb = sq_v3(b.x / b.w, b.y / b.w, b.z / b.w);
    *o = c->position_m;
    *d = sq_v3_norm(sq_v3_sub(pb, pa));
}

/* Ray o + t d against the box [lo, hi]: true with [t0, t1] if it meets it at t1 > 0. */
static bool ray_box(sq_vec3 o, sq_vec3 d, sq_vec3 lo, sq_vec3 hi, float *t0, float *t1)
{
    const float ov[3] = {o.x, o.y, o.z}, dv[3] = {d.x, d.y, d.z};
    const float lv[3] = {lo.x, lo.y, lo.z}, hv[3] = {hi.x, hi.y, hi.z};
    float a = -INFINITY, b = INFINITY;
    for (int k = 0; k < 3; k++) {
        if (fabsf(dv[k]) < 1e-12f) {
            if (ov[k] < lv[k] || ov[k] > hv[k]) return false;
            continue;
        }
        float u = (lv[k] - ov[k]) / dv[k], v = (hv[k] - ov[k]) / dv[k];
        if (u > v) {
            const float s = u;
            u = v;
            v = s;
        }
        a = fmaxf(a, u);
        b = fminf(b, v);
    }
    if (!(a <= b) || b <= 0.0f) return false;
    *t0 = a;
    *t1 = b;
    return true;
}

/* Distance along the ray to the flat ground z = 0 (INFINITY if it looks up). */
static float ground_t(sq_vec3 o, sq_vec3 d) { return d.z < 0.0f ? -o.z / d.z : INFINITY; }

static sq_obstacle box_obstacle(sq_vec3 base_centre, sq_vec3 size, float albedo)
{
    sq_obstacle ob;
    memset(&ob, 0, sizeof ob);
    ob.kind = SQ_OBSTACLE_BOX;
    ob.center_m = base_centre;
    ob.size_m = size;
    ob.albedo = sq_v3(albedo, albedo, albedo);
    return ob;
}

static void obstacle_aabb(const sq_obstacle *ob, sq_vec3 *lo, sq_vec3 *hi)
{
    *lo = sq_v3(ob->center_m.x - 0.5f * ob->size_m.x, ob->center_m.y - 0.5f * ob->size_m.y,
                ob->center_m.z);
    *hi = sq_v3(ob->center_m.x + 0.5f * ob->size_m.x, ob->center_m.y + 0.5f * ob->size_m.y,
                ob->center_m.z + ob->size_m.z);
}

/* A homogeneous grey medium: density 1 on a small grid, beta_ext = beta on every channel. */
typedef struct medium {
    float density[4 * 4 * 4];
    sq_drawable d;
} medium;

static void medium_init(medium *m, sq_vec3 lo, sq_vec3 size, float beta, float albedo, float g,
                        float value)
{
    memset(m, 0, sizeof *m);
    for (int i = 0; i < 64; i++) m->density[i] = value;
    sq_volume_view *v = &m->d.u.volume;
    m->d.kind = SQ_DRAWABLE_VOLUME;
    m->d.name = "medium";
    v->density = m->density;
    v->nx = v->ny = v->nz = 4;
    v->origin_m = lo;
    v->size_m = size;
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = beta;
        v->albedo[c] = albedo;
        v->g[c] = g;
    }
    v->density_max = value;
    v->version = 1;
}

/* ---- Koschmieder: visibility you can see --------------------------------------------------- */
/* What is checked. A homogeneous medium (beta_ext = 0.01 /m, albedo 0.8, g 0.7) fills a box
 * from x = 10 m to x = 3010 m in front of a camera at x = 0 looking along +x; it is lit by the
 * sky only (sun radiance set to 0), so its source function S = a J_amb is the same everywhere:
 * the medium is in radiative equilibrium and a path of length L inside it shows radiance
 * B0 e^(-beta L) + S (1 - e^(-beta L)) for a surface of radiance B0 behind it. The horizon seen
 * through >= 1200 m of the medium (beta L >= 12) therefore has radiance S: that is the
 * background B_bg, measured from pixels. Six dark boxes (albedo 0.001) stand at medium path
 * lengths 25..300 m; their inherent contrast against that horizon, C0 = 1 - B0/B_bg, is taken
 * from a frame without the medium (B0 = the same pixel without it; C0 ~ 1). Koschmieder's law
 * C(L) = C0 exp(-beta L) with C = 1 - B/B_bg is then checked pixel by pixel on the boxes' front
 * faces with the exact path length of each pixel's ray, within 5 % relative, on every channel,
 * for two suns: behind the viewer (front-to-back slicing) and ahead (back-to-front), and with
 * the camera inside the medium (box from x = -50 m; the path then starts at the camera). The last
 * box stands at the Koschmieder distance V = ln(1/0.05)/beta = 299.6 m: there C/C0 must be
 * 0.05 within 5 %, and the visibility fitted from its pixels, ln(20)/beta_fit, must be V
 * within 5 %. The largest relative errors found are printed.
 * Koschmieder's law assumes a uniformly lit path, so these frames are drawn with the renderer's
 * uniform ambient (render_desc.volume_ambient_uniform); the default attenuates the sky inside the
 * medium (checked by ambient_attenuated_in_a_uniform_layer below). */
static void koschmieder_case(sq_vec3 sun_toward, const char *tag, bool expect_front_to_back,
                             float face_x0, double time_s)
{
    sq_context *ctx = new_ctx();
    const float beta = 0.01f;
    const float V = logf(20.0f) / beta;
    enum { NT = 6 };
    const float path[NT] = {25.0f, 50.0f, 100.0f, 150.0f, 220.0f, V};
    const float az_deg[NT] = {-20.0f, -12.0f, -4.0f, 4.0f, 12.0f, 20.0f};
    sq_obstacle obs[NT];
    float face_x[NT], face_y[NT], face_w[NT];
    for (int i = 0; i < NT; i++) {
        const float az = az_deg[i] * (float)(SQ_PI / 180.0);
        face_x[i] = fmaxf(face_x0, 0.0f) + path[i] * cosf(az);
        face_y[i] = face_x[i] * tanf(az);
        face_w[i] = 2.0f * face_x[i] * tanf(2.2f * (float)(SQ_PI / 180.0));
        obs[i] = box_obstacle(sq_v3(face_x[i] + 5.0f, face_y[i], 0.0f),
                              sq_v3(10.0f, face_w[i], 60.0f), 0.001f);
    }
    sq_world *w = new_world(ctx, 8000.0f, obs, NT);
    sq_renderer *r = new_renderer_amb(ctx, 128, false, true);
    if (!w || !r) goto done;
    w->sun_dir = sq_v3_norm(sun_toward);
    w->sun_radiance = sq_v3(0.0f, 0.0f, 0.0f);

    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 30.0f), sq_v3(100.0f, 0.0f, 30.0f), 30.0f);
    const sq_vec3 lo = sq_v3(face_x0, -1500.0f, -1.0f), size = sq_v3(3000.0f, 3000.0f, 151.0f);
    const float x_in = fmaxf(face_x0, 0.0f); /* where the view rays enter the medium */
    const sq_vec3 hi = sq_v3_add(lo, size);
    /* the slicing order this sun selects: front-to-back iff the light goes the camera's way */
    const sq_vec3 fwd = sq_v3_norm(sq_v3_sub(cam.target_m, cam.position_m));
    SQ_CHECK((sq_v3_dot(fwd, sq_v3_scale(w->sun_dir, -1.0f)) >= 0.0f) == expect_front_to_back);

    medium m;
    medium_init(&m, lo, size, beta, 0.8f, 0.7f, 1.0f);
    char name[64];
    snprintf(name, sizeof name, "koschmieder_%s_clear", tag);
    float *clear = render(r, w, &cam, NULL, 0, 0.0, name);
    snprintf(name, sizeof name, "koschmieder_%s_dust", tag);
    float *dust = render(r, w, &cam, &m.d, 1, time_s, name);
    if (!clear || !dust) goto done_img;

    /* background: horizon seen through beta L >= 12 of medium, no obstacle near the ray */
    double bg[3] = {0, 0, 0}, bg2[3] = {0, 0, 0};
    int nbg = 0;
    for (int j = 0; j < IMG_H; j++)
        for (int i = 0; i < IMG_W; i++) {
            sq_vec3 o, d;
            pixel_ray(&cam, i, j, &o, &d);
            float t0, t1;
            if (!ray_box(o, d, lo, hi, &t0, &t1)) continue;
            const float L = fminf(t1, ground_t(o, d)) - fmaxf(t0, 0.0f);
            if (beta * L < 12.0f) continue;
            bool near_obstacle = false;
            for (int k = 0; k < NT && !near_obstacle; k++) {
                sq_vec3 a, b;
                obstacle_aabb(&obs[k], &a, &b);
                const sq_vec3 grow = sq_v3(3.0f, 0.15f * face_w[k], 3.0f);
                float u0, u1;
                near_obstacle = ray_box(o, d, sq_v3_sub(a, grow), sq_v3_add(b, grow), &u0, &u1);
            }
            if (near_obstacle) continue;
            for (int c = 0; c < 3; c++) {
                const double v = dust[3 * (j * IMG_W + i) + c];
                bg[c] += v;
                bg2[c] += v * v;
            }
            nbg++;
        }
    SQ_CHECK_MSG(nbg > 200, "only %d background pixels", nbg);
    if (nbg == 0) goto done_img;
    for (int c = 0; c < 3; c++) {
        bg[c] /= nbg;
        const double sd = sqrt(fmax(bg2[c] / nbg - bg[c] * bg[c], 0.0));
        /* a uniform source: the equilibrium horizon is the same everywhere */
        SQ_CHECK_MSG(sd <= 0.005 * bg[c], "background channel %d: mean %g, sd %g", c, bg[c], sd);
        SQ_CHECK(bg[c] > 0.0);
    }

    double worst = 0.0, worst_c0 = 1.0;
    double vis_fit_sum = 0.0, ratio_at_v = -1.0, best_centre = INFINITY;
    int nvis = 0;
    for (int k = 0; k < NT; k++) {
        int npx = 0;
        double err_k = 0.0;
        for (int j = 0; j < IMG_H; j++)
            for (int i = 0; i < IMG_W; i++) {
                sq_vec3 o, d;
                pixel_ray(&cam, i, j, &o, &d);
                if (d.x <= 0.0f) continue;
                const float t_face = (face_x[k] - o.x) / d.x;
                const sq_vec3 p = sq_v3_add(o, sq_v3_scale(d, t_face));
                /* front face, away from its edges (1.5 pixels at least) */
                const float px_m = t_face * 2.0f * tanf(15.0f * (float)(SQ_PI / 180.0)) / IMG_H;
                if (fabsf(p.y - face_y[k]) > 0.5f * face_w[k] - 1.5f * px_m) continue;
                if (p.z < 1.5f * px_m || p.z > 60.0f - 1.5f * px_m) continue;
                bool hidden = false; /* by a nearer box */
                for (int k2 = 0; k2 < NT && !hidden; k2++) {
                    sq_vec3 a, b;
                    float u0, u1;
                    obstacle_aabb(&obs[k2], &a, &b);
                    hidden = k2 != k && ray_box(o, d, a, b, &u0, &u1) && u0 < t_face;
                }
                if (hidden) continue;
                const float L = t_face - (x_in - o.x) / d.x;
                for (int c = 0; c < 3; c++) {
                    const size_t q = (size_t)3 * (size_t)(j * IMG_W + i) + (size_t)c;
                    const double C0 = 1.0 - clear[q] / bg[c];
                    const double C = 1.0 - dust[q] / bg[c];
                    const double expect = C0 * exp(-(double)beta * L);
                    const double rel = fabs(C - expect) / expect;
                    if (rel > err_k) err_k = rel;
                    if (C0 < worst_c0) worst_c0 = C0;
                    SQ_CHECK_MSG(rel <= 0.05,
                                 "%s box %d pixel (%d,%d) ch %d: L = %.1f m, C = %.5f, "
                                 "C0 e^-bL = %.5f (rel %.3g)",
                                 tag, k, i, j, c, (double)L, C, expect, rel);
                    if (k == NT - 1 && c == 1) {
                        vis_fit_sum += log(20.0) * L / -log(C / C0);
                        nvis++;
                        const double off = fabs(L - V);
                        if (off < best_centre) {
                            best_centre = off;
                            ratio_at_v = C / C0 * exp((double)beta * (L - V));
                        }
                    }
                }
                npx++;
            }
        SQ_CHECK_MSG(npx >= 20, "%s box %d: only %d face pixels", tag, k, npx);
        printf("koschmieder %s: box %d path %.1f m: %d px, max rel contrast error %.4f\n", tag, k,
               (double)path[k], npx, err_k);
        if (err_k > worst) worst = err_k;
    }
    /* the boxes are dark: inherent contrast close to 1 */
    SQ_CHECK_MSG(worst_c0 > 0.95, "inherent contrast C0 = %g; the boxes should be dark", worst_c0);
    SQ_CHECK(nvis > 0);
    if (nvis > 0) {
        const double v_fit = vis_fit_sum / nvis;
        printf("koschmieder %s: V = %.2f m, fitted %.2f m (rel %.4f); C/C0 at V = %.5f; worst "
               "rel error %.4f\n",
               tag, (double)V, v_fit, fabs(v_fit - V) / V, ratio_at_v, worst);
        SQ_CHECK_REL(v_fit, V, 0.05);
        SQ_CHECK_REL(ratio_at_v, 0.05, 0.05);
    }
done_img:
    free(clear);
    free(dust);
done:
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(koschmieder_sun_behind)
{
    koschmieder_case(sq_v3(-1.0f, 0.3f, 0.6f), "behind", true, 10.0f, 0.25);
}

SQ_TEST(koschmieder_sun_ahead)
{
    koschmieder_case(sq_v3(1.0f, 0.3f, 0.6f), "ahead", false, 10.0f, 0.25);
}

/* The camera inside the medium (the box begins 50 m behind it): the path starts at the camera
 * and no dust may go missing between it and the first slice in front of its near plane. Three
 * frames at different times put the jittered slices (~28 m apart along the rays here) at
 * different depths around the camera; without the first slice standing for the ray down to the
 * camera, these frames lose 4-16 % of the contrast check. */
SQ_TEST(koschmieder_camera_inside)
{
    for (int f = 1; f <= 3; f++)
        koschmieder_case(sq_v3(1.0f, 0.3f, 0.6f), "inside", false, -50.0f, 0.5 * f);
}

/* ---- ambient light inside the medium (volume_sky.c) ---------------------------------------- */
/* The model's decay of diffuse light with optical depth tau in a horizontally uniform layer,
 * written out here from its documented form (the diffusion approximation's decay constant):
 * exp(-kappa tau), kappa = sqrt(3 (1 - albedo)(1 - albedo g)). */
static double diffuse_decay(double tau, double albedo, double g)
{
    return exp(-sqrt(3.0 * (1.0 - albedo) * (1.0 - albedo * g)) * tau);
}

/* What is checked. A horizontally uniform layer (density 1, 400 m deep in 64 layers, 8 km wide)
 * with a different attenuation on each channel (0.001, 0.0037, 0.006 per density unit and metre)
 * seen from inside: at every voxel centre of the middle column the sky's visibility must be
 * exp(-sigma_c (400 m - z)) (1e-5, float sums) on every channel, whatever the direction (each
 * counts the vertical distance it climbs through the uniform layer), and the ground's
 * exp(-sigma_c z) times the ground's own sky visibility (the lowest layer's). Then a column
 * under a thick layer: a layer 5 cells (100 m) deep and 24 cells wide, with sigma 0.05: a
 * vertical depth of 5, 4 layers above the point. The vertical direction (weight 1/2) crosses it
 * (e^-5), the four grazing ones (mu = 0.211, 4.6 cells sideways per layer) pass beside it to the
 * clear sky: visibility 0.5 + 0.5 e^-5 = 0.50337; above the layer the whole sky: 1. */
SQ_TEST(ambient_visibility_model)
{
    {
        const int nx = 16, ny = 16, nz = 64;
        const double cell[3] = {500.0, 500.0, 400.0 / nz}, sig[3] = {0.001, 0.0037, 0.006};
        float *rho = malloc(sizeof(float) * nx * ny * nz);
        float *out = malloc(sizeof(float) * 6 * nx * ny * nz);
        float *work = malloc(sizeof(float) * sq__volume_sky_work_floats(nx, ny));
        if (!rho || !out || !work) goto free1;
        for (int i = 0; i < nx * ny * nz; i++) rho[i] = 1.0f;
        sq__volume_sky_visibility(rho, nx, ny, nz, cell, sig, work, out);
        double worst = 0.0;
        const size_t n = (size_t)nx * ny * nz, c = (size_t)(ny / 2) * nx + nx / 2;
        const size_t nxy = (size_t)nx * ny;
        for (int ch = 0; ch < 3; ch++) {
            const double ground = exp(-sig[ch] * (400.0 - 0.5 * cell[2]));
            for (int k = 0; k < nz; k++) {
                const double z = (k + 0.5) * cell[2];
                const double sky = out[3 * (k * nxy + c) + ch];
                const double gnd = out[3 * n + 3 * (k * nxy + c) + ch];
                const double es = exp(-sig[ch] * (400.0 - z)), eg = ground * exp(-sig[ch] * z);
                worst = fmax(worst, fmax(fabs(sky - es), fabs(gnd - eg)));
                SQ_CHECK_MSG(fabs(sky - es) <= 1e-5,
                             "layer %d ch %d: sky visibility %.6f, expected %.6f", k, ch, sky, es);
                SQ_CHECK_MSG(fabs(gnd - eg) <= 1e-5,
                             "layer %d ch %d: ground visibility %.6f, expected %.6f", k, ch, gnd,
                             eg);
            }
        }
        printf("ambient in a uniform layer: worst |visibility - exp(-sigma D)| %.2e; at the "
               "bottom %.4f / %.4f / %.4f of the sky\n",
               worst, (double)out[3 * c], (double)out[3 * c + 1], (double)out[3 * c + 2]);
    free1:
        free(rho);
        free(out);
        free(work);
    }
    {
        const int n = 32;
        const double cell[3] = {20.0, 20.0, 20.0}, sig[3] = {0.05, 0.05, 0.05};
        float *rho = calloc((size_t)n * n * n, sizeof(float));
        float *out = malloc(sizeof(float) * 6 * n * n * n);
        float *work = malloc(sizeof(float) * sq__volume_sky_work_floats(n, n));
        if (!rho || !out || !work) goto free2;
        for (int k = 18; k <= 22; k++) /* 5 cells of density 1: D = 100 m, depth 5 */
            for (int j = 4; j <= 27; j++)
                for (int i = 4; i <= 27; i++) rho[((size_t)k * n + j) * n + i] = 1.0f;
        sq__volume_sky_visibility(rho, n, n, n, cell, sig, work, out);
        const size_t c = (size_t)16 * n + 16;
        const double under = out[3 * ((size_t)14 * n * n + c) + 1];
        const double over = out[3 * ((size_t)28 * n * n + c) + 1];
        const double expect = 0.5 + 0.5 * exp(-5.0);
        printf("ambient under a thick layer: %.5f (expected %.5f), above it %.5f\n", under,
               expect, over);
        SQ_CHECK(fabs(under - expect) <= 1e-4);
        SQ_CHECK(fabs(over - 1.0) <= 1e-6);
    free2:
        free(rho);
        free(out);
        free(work);
    }
}

/* What is checked (GL). A uniform layer (beta_ext 0.01 /m, albedo 0.8, g 0.5: diffusion decay
 * kappa = sqrt(3 0.2 0.6) = 0.6, 0.006 /m), 8 x 8 km wide and 400 m deep on a 4 x 4 x 64 grid,
 * lit by the sky only (sun radiance 0, ground albedo 0: the ground sends nothing), seen from
 * inside looking straight up from 20, 200 and 380 m. Each pixel must equal the line integral
 *     I = integral_0^L a S V(z(t)) beta e^(-beta t) dt + B e^(-beta L),
 * S = the sky's half of the ambient radiance (the mean of the renderer's sky, mix(horizon,
 * zenith, 0.35), over half the sphere), V = exp(-kappa tau) of the optical depth tau above
 * z(t), L = the path to the layer's top and B = the same pixel without the medium (the sky
 * behind it); within 1 % on every channel (measured: 0.11 %). With the renderer's uniform ambient (V = 1, the
 * Koschmieder hypothesis) the same pixels must follow V = 1 within 1 %, and from 20 m the
 * attenuated frame must be less than half as bright (the dark base; so this test fails if the
 * ambient is not attenuated). */
SQ_TEST(ambient_attenuated_in_a_uniform_layer)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 12000.0f, NULL, 0);
    sq_renderer *ra = new_renderer_amb(ctx, 128, false, false);
    sq_renderer *ru = new_renderer_amb(ctx, 128, false, true);
    enum { NX = 4, NZ = 64 };
    static float dens[NX * NX * NZ];
    for (int i = 0; i < NX * NX * NZ; i++) dens[i] = 1.0f;
    const float beta = 0.01f, albedo = 0.8f, g = 0.5f, top = 400.0f;
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_VOLUME;
    d.name = "layer";
    sq_volume_view *v = &d.u.volume;
    v->density = dens;
    v->nx = v->ny = NX;
    v->nz = NZ;
    v->origin_m = sq_v3(-4000.0f, -4000.0f, 0.0f);
    v->size_m = sq_v3(8000.0f, 8000.0f, top);
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = beta;
        v->albedo[c] = albedo;
        v->g[c] = g;
    }
    v->density_max = 1.0f;
    v->version = 1;
    if (!w || !ra || !ru) goto done;
    w->sun_dir = sq_v3(0.0f, 0.0f, 1.0f);
    w->sun_radiance = sq_v3(0.0f, 0.0f, 0.0f);
    w->ground_albedo = sq_v3(0.0f, 0.0f, 0.0f);
    const sq_vec3 skyc = sq_v3_lerp(w->sky_horizon, w->sky_zenith, 0.35f);
    const double S[3] = {0.5 * skyc.x, 0.5 * skyc.y, 0.5 * skyc.z};
    const float heights[3] = {20.0f, 200.0f, 380.0f};
    for (int h = 0; h < 3; h++) {
        sq_camera cam = camera(sq_v3(0.0f, 0.0f, heights[h]), sq_v3(0.0f, 0.0f, heights[h] + 100.0f),
                               30.0f);
        cam.up = sq_v3(1.0f, 0.0f, 0.0f);
        char name[64];
        snprintf(name, sizeof name, "ambient_clear_%d", h);
        float *clear = render(ra, w, &cam, NULL, 0, 0.0, name);
        snprintf(name, sizeof name, "ambient_attenuated_%d", h);
        float *att = render(ra, w, &cam, &d, 1, 0.0, name);
        snprintf(name, sizeof name, "ambient_uniform_%d", h);
        float *uni = render(ru, w, &cam, &d, 1, 0.0, name);
        double worst_a = 0.0, worst_u = 0.0, sum_a = 0.0, sum_u = 0.0;
        int npx = 0;
        for (int j = 0; clear && att && uni && j < IMG_H; j += 3)
            for (int i = 0; i < IMG_W; i += 3) {
                sq_vec3 o, dir;
                pixel_ray(&cam, i, j, &o, &dir);
                if (dir.z <= 0.0f) continue;
                const double L = (top - o.z) / dir.z;
                const int steps = 2000;
                const double dt = L / steps;
                double Ia = 0.0, Iu = 0.0;
                for (int k = 0; k < steps; k++) {
                    const double t = (k + 0.5) * dt, z = o.z + dir.z * t;
                    const double wv = beta * exp(-(double)beta * t) * dt;
                    Ia += wv * diffuse_decay((double)beta * (top - z), albedo, g);
                    Iu += wv;
                }
                const double bg = exp(-(double)beta * L);
                for (int c = 0; c < 3; c++) {
                    const size_t q = (size_t)3 * (size_t)(j * IMG_W + i) + (size_t)c;
                    const double ea = albedo * S[c] * Ia + clear[q] * bg;
                    const double eu = albedo * S[c] * Iu + clear[q] * bg;
                    const double ra_ = fabs(att[q] - ea) / ea, ru_ = fabs(uni[q] - eu) / eu;
                    worst_a = fmax(worst_a, ra_);
                    worst_u = fmax(worst_u, ru_);
                    SQ_CHECK_MSG(ra_ <= 0.01, "z %.0f pixel (%d,%d) ch %d: attenuated %.6g, "
                                 "integral %.6g (rel %.3g)", (double)heights[h], i, j, c,
                                 (double)att[q], ea, ra_);
                    SQ_CHECK_MSG(ru_ <= 0.01, "z %.0f pixel (%d,%d) ch %d: uniform %.6g, "
                                 "integral %.6g (rel %.3g)", (double)heights[h], i, j, c,
                                 (double)uni[q], eu, ru_);
                    if (c == 1) {
                        sum_a += att[q];
                        sum_u += uni[q];
                    }
                }
                npx++;
            }
        printf("ambient from %.0f m up: %d px, worst rel error attenuated %.4f, uniform %.4f; "
               "mean green attenuated / uniform %.4f\n",
               (double)heights[h], npx, worst_a, worst_u, sum_u > 0.0 ? sum_a / sum_u : -1.0);
        SQ_CHECK(npx > 1000);
        if (h == 0) SQ_CHECK(sum_a < 0.5 * sum_u);
        free(clear);
        free(att);
        free(uni);
    }
done:
    sq_renderer_destroy(ra);
    sq_renderer_destroy(ru);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- single scattering of the sun: the eye pass against the line integral ------------------ */
/* What is checked. An optically thin slab (beta 0.005 /m, 100 m deep, albedo 1, HG g = 0.5),
 * single-scattering ablation on, seen against the sky. The sun's share of each pixel (frame with
 * the sun minus frame without it; the ground albedo is set to 0 so that the sky ambient does not
 * depend on the sun) must equal the single-scattering line integral
 *     I = integral over the ray inside the box of
 *         a beta E p_HG(theta) exp(-beta s_sun(t)) exp(-beta (t - t_in)) dt,
 * with E = pi * sun_radiance (the renderer's units: a white Lambertian plane facing the sun has
 * radiance sun_radiance), cos theta = (sun propagation) . (propagation toward the eye), s_sun the
 * path from the point back to the box boundary toward the sun. Evaluated here with
 * midpoint quadrature per pixel (400 steps); checked within 3 % relative on every sky pixel seeing more
 * than 20 m of slab, for the sun behind the viewer (front-to-back) and ahead (back-to-front),
 * with HG and with the isotropic-phase ablation (p = 1/4pi). */
/* With octaves > 1 (multiple-scattering octaves on, render_internal.h sq__volume_ms_weight)
 * the integrand gains, independently of the renderer's code,
 *     a beta E sum_{i=1}^{octaves-1} a^i b^i (exp(-A^i tau_sun) - exp(-tau_sun)) p_HG(theta, C^i g)
 * with A, B, C = 0.5, 0.5, 0.85 (the documented constants) and tau_sun = beta s_sun; the case
 * then also asserts that this part is a sizeable share of the light (so ignoring it fails). */
/* With SQ_VOLUME_MS_DIFFUSION (octaves passed as 0) the integrand gains instead
 *     a beta E (J_diff(tau_sun, tau0) + J_beam(tau_sun)),
 * the documented delta-Eddington diffusion and beam sources (render_internal.h,
 * sq__volume_ms_diffusion and sq__volume_ms_beam), tau0 the sun ray's whole optical depth
 * through the slab at the point. */
static void scatter_case(sq_vec3 sun_toward, bool isotropic, const char *tag, float beta,
                         int octaves)
{
    const bool diffusion = octaves == 0;
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 4000.0f, NULL, 0);
    sq_render_desc rd = {0};
    rd.width = IMG_W;
    rd.height = IMG_H;
    rd.volume_slices = 128;
    rd.single_scatter_only = true;
    rd.isotropic_phase = isotropic;
    rd.volume_octaves = diffusion ? 1 : octaves;
    rd.volume_ms = diffusion ? SQ_VOLUME_MS_DIFFUSION
                   : octaves > 1 ? SQ_VOLUME_MS_OCTAVES
                                 : SQ_VOLUME_MS_NONE;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    float *on = NULL, *off = NULL;
    if (!w || !r) goto done;
    w->sun_dir = sq_v3_norm(sun_toward);
    w->ground_albedo = sq_v3(0.0f, 0.0f, 0.0f);
    const sq_vec3 sun = w->sun_radiance;
    const float g = 0.5f;
    const sq_vec3 lo = sq_v3(50.0f, -1000.0f, 0.0f), size = sq_v3(100.0f, 2000.0f, 100.0f);
    const sq_vec3 hi = sq_v3_add(lo, size);
    medium m;
    medium_init(&m, lo, size, beta, 1.0f, g, 1.0f);
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 50.0f), sq_v3(100.0f, 0.0f, 50.0f), 30.0f);
    char name[64];
    snprintf(name, sizeof name, "single_%s_on", tag);
    on = render(r, w, &cam, &m.d, 1, 0.0, name);
    w->sun_radiance = sq_v3(0.0f, 0.0f, 0.0f);
    snprintf(name, sizeof name, "single_%s_off", tag);
    off = render(r, w, &cam, &m.d, 1, 0.0, name);
    if (!on || !off) goto done;
    const double E = SQ_PI * (double)sun.y;
    const sq_vec3 s = w->sun_dir;
    double worst = 0.0, sum_m = 0.0, sum_e = 0.0, sum_ms = 0.0;
    int npx = 0;
    for (int j = 0; j < IMG_H; j++)
        for (int i = 0; i < IMG_W; i++) {
            sq_vec3 o, d;
            pixel_ray(&cam, i, j, &o, &d);
            float t0, t1;
            if (d.z < 0.02f || !ray_box(o, d, lo, hi, &t0, &t1)) continue;
            t0 = fmaxf(t0, 0.0f);
            if (t1 - t0 < 20.0f) continue;
            const double ct = (double)sq_v3_dot(s, d);
            const double p = isotropic ? 1.0 / (4.0 * SQ_PI)
                                       : (1.0 - (double)(g * g)) /
                                             (4.0 * SQ_PI * pow(1.0 + (double)(g * g) - 2.0 * g * ct, 1.5));
            const int steps = 400;
            const double dt = (double)(t1 - t0) / steps;
            double I = 0.0, Ims = 0.0;
            for (int k = 0; k < steps; k++) {
                const double t = (double)t0 + (k + 0.5) * dt;
                const sq_vec3 x = sq_v3_add(o, sq_v3_scale(d, (float)t));
                float u0 = 0.0f, u1 = 0.0f;
                const float sl = ray_box(x, s, lo, hi, &u0, &u1) ? u1 : 0.0f;
                const double view = (double)beta * E * exp(-(double)beta * (t - t0)) * dt;
                I += view * p * exp(-(double)beta * sl);
                const double tau = (double)beta * sl;
                if (diffusion)
                    Ims += view * (sq__volume_ms_diffusion(1.0, g, tau, (double)beta * (sl - u0), ct) +
                                   sq__volume_ms_beam(1.0, g, tau, ct));
                for (int oc = 1; oc < octaves; oc++) {
                    const double gi = isotropic ? 0.0 : g * pow(0.85, oc);
                    const double pi_ = (1.0 - gi * gi) /
                                       (4.0 * SQ_PI * pow(1.0 + gi * gi - 2.0 * gi * ct, 1.5));
                    Ims += view * pow(0.5, oc) * (exp(-pow(0.5, oc) * tau) - exp(-tau)) * pi_;
                }
            }
            sum_ms += Ims;
            I += Ims;
            const size_t q = (size_t)3 * (size_t)(j * IMG_W + i) + 1;
            const double meas = (double)on[q] - off[q];
            const double rel = fabs(meas - I) / I;
            worst = fmax(worst, rel);
            sum_m += meas;
            sum_e += I;
            npx++;
            SQ_CHECK_MSG(rel <= 0.03, "%s pixel (%d,%d): in-scattered %.6g, integral %.6g (rel %.3g)",
                         tag, i, j, meas, I, rel);
        }
    printf("single scattering %s: %d px, mean measured %.6g vs integral %.6g (rel %.4f), worst "
           "pixel rel %.4f\n",
           tag, npx, npx ? sum_m / npx : 0.0, npx ? sum_e / npx : 0.0,
           sum_e > 0 ? fabs(sum_m - sum_e) / sum_e : -1.0, worst);
    SQ_CHECK(npx > 2000);
    if (octaves > 1 || diffusion) {
        printf("  octaves %d (0: diffusion): their share of the integral %.4f\n", octaves,
               sum_e > 0 ? sum_ms / sum_e : -1.0);
        SQ_CHECK(sum_ms > 0.1 * sum_e); /* large enough that leaving it out fails the 3 % */
    }
done:
    free(on);
    free(off);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* one octave: single scattering exactly (the octave sum adds nothing) */
SQ_TEST(single_scatter_sun_behind) { scatter_case(sq_v3(-1.0f, 0.0f, 1.0f), false, "behind", 0.005f, 1); }
SQ_TEST(single_scatter_sun_ahead) { scatter_case(sq_v3(1.0f, 0.2f, 1.7f), false, "ahead", 0.005f, 1); }
SQ_TEST(single_scatter_isotropic) { scatter_case(sq_v3(1.0f, 0.2f, 1.7f), true, "isotropic", 0.005f, 1); }

/* Multiple-scattering octaves in a denser slab (beta 0.03 /m: optical depth 3 across it), the
 * eye pass against the line integral of the documented octave sum. */
SQ_TEST(ms_octaves_sun_behind) { scatter_case(sq_v3(-1.0f, 0.0f, 1.0f), false, "ms_behind", 0.03f, 3); }
SQ_TEST(ms_octaves_sun_ahead) { scatter_case(sq_v3(1.0f, 0.2f, 1.7f), false, "ms_ahead", 0.03f, 3); }
/* The same slab with the default multiple scattering (diffusion and the delta-Eddington beam). */
SQ_TEST(ms_diffusion_sun_behind) { scatter_case(sq_v3(-1.0f, 0.0f, 1.0f), false, "diff_behind", 0.03f, 0); }
SQ_TEST(ms_diffusion_sun_ahead) { scatter_case(sq_v3(1.0f, 0.2f, 1.7f), false, "diff_ahead", 0.03f, 0); }

/* ---- multiple-scattering octaves create no energy ------------------------------------------ */
/* What is checked. A plane-parallel slab of optical thickness tau0, albedo 1 (conservative: all
 * light comes out), lit by the sun at normal incidence with irradiance 1. The renderer's model of
 * the light leaving it is the direct beam exp(-tau0) plus, from every depth t, the in-scattered
 * source exp(-t) p(theta, g) + sum_{i>=1} w_i(t) p(theta, C^i g) (single scattering plus the
 * octaves, w_i = sq__volume_ms_weight) attenuated along each escape direction mu by
 * exp(-(tau0 - t)/mu) (down) or exp(-t/|mu|) (up). Its total, integrated over depth and all
 * directions (midpoint rule, 4000 x 4000), may not exceed what entered (1) for any tau0 and g:
 * the octaves may restore the energy single scattering loses, never add more. With one octave
 * the sum is single scattering, which loses energy in every slab (the light scattered more than
 * once); the octaves must recover a part of it from tau0 = 1 on (measured 0.4-15 %: the model
 * stays well below 1, e.g. 0.042 of the light leaves a tau0 = 12, g = 0.69 slab against 0.023
 * with single scattering), and in thin slabs add only at second order (w ~ tau^2): their
 * share at tau0 0.01 and 0.02 scales as tau0^2 within 10 %. */
static double slab_out(double tau0, double g, int octaves)
{
    enum { NT = 2000, NM = 2000 };
    static double phase[8][NM];
    const double dt = tau0 / NT, dmu = 2.0 / NM;
    for (int i = 0; i < octaves; i++)
        for (int b = 0; b < NM; b++) {
            const double mu = -1.0 + (b + 0.5) * dmu, gi = g * pow(SQ_VOL_MS_C, i);
            phase[i][b] = (1.0 - gi * gi) / (4.0 * SQ_PI * pow(1.0 + gi * gi - 2.0 * gi * mu, 1.5));
        }
    double total = 0.0;
    for (int a = 0; a < NT; a++) {
        const double t = (a + 0.5) * dt;
        double w[8] = {exp(-t)};
        for (int i = 1; i < octaves; i++) w[i] = sq__volume_ms_weight(i, t);
        for (int b = 0; b < NM; b++) {
            const double mu = -1.0 + (b + 0.5) * dmu; /* cos(angle to the beam) */
            const double esc = mu > 0.0 ? exp(-(tau0 - t) / mu) : exp(-t / -mu);
            double src = 0.0;
            for (int i = 0; i < octaves; i++) src += w[i] * phase[i][b];
            total += src * esc;
        }
    }
    return exp(-tau0) + total * dt * dmu * 2.0 * SQ_PI;
}

SQ_TEST(ms_octaves_create_no_energy)
{
    const double taus[] = {0.01, 0.1, 1.0, 4.0, 12.0, 50.0};
    const double gs[] = {0.0, 0.69, 0.9};
    for (size_t gi = 0; gi < sizeof gs / sizeof gs[0]; gi++)
        for (size_t ti = 0; ti < sizeof taus / sizeof taus[0]; ti++) {
            const double one = slab_out(taus[ti], gs[gi], 1), three = slab_out(taus[ti], gs[gi], 3);
            printf("slab tau %5.2f g %.2f: out %.4f (1 octave), %.4f (3 octaves)\n", taus[ti],
                   gs[gi], one, three);
            SQ_CHECK_MSG(three <= 1.0 + 1e-3, "tau %g g %g: %.5f leaves, 1 entered", taus[ti],
                         gs[gi], three);
            SQ_CHECK(one < 1.0);
            SQ_CHECK(three >= one);
            if (taus[ti] >= 1.0) SQ_CHECK(three - one > 0.004 * (1.0 - one));
        }
    const double e1 = slab_out(0.01, 0.69, 3) - slab_out(0.01, 0.69, 1);
    const double e2 = slab_out(0.02, 0.69, 3) - slab_out(0.02, 0.69, 1);
    printf("thin slabs: octave share %.3g at tau 0.01, %.3g at 0.02 (ratio %.3f; tau^2: 4)\n", e1,
           e2, e2 / e1);
    SQ_CHECK_REL(e2 / e1, 4.0, 0.1);
}

/* ---- multiple scattering by diffusion: energy and Monte Carlo ----------------------------- */
/* The same plane-parallel slab for the default model: the direct beam plus what the sources
 * single scattering + J_diff + J_beam (albedo w; render_internal.h) send out through both
 * faces, integrated over depth and all directions (midpoint rule, 1500 x 1500), sun at normal
 * incidence with irradiance 1. `up` counts only what leaves through the lit face (the
 * reflectance). */
static double slab_out_diffusion(double tau0, double g, double w, bool up)
{
    enum { NT = 1500, NM = 1500 };
    const double dt = tau0 / NT, dmu = 2.0 / NM;
    double total = 0.0;
    for (int a = 0; a < NT; a++) {
        const double t = (a + 0.5) * dt;
        for (int b = 0; b < NM; b++) {
            const double mu = -1.0 + (b + 0.5) * dmu; /* cos(angle to the beam) */
            if (up && mu > 0.0) continue;
            const double esc = mu > 0.0 ? exp(-(tau0 - t) / mu) : exp(-t / -mu);
            const double p = (1.0 - g * g) / (4.0 * SQ_PI * pow(1.0 + g * g - 2.0 * g * mu, 1.5));
            const double src = exp(-t) * p + sq__volume_ms_diffusion(w, g, t, tau0, mu) +
                               sq__volume_ms_beam(w, g, t, mu);
            total += w * src * esc;
        }
    }
    return (up ? 0.0 : exp(-tau0)) + total * dt * dmu * 2.0 * SQ_PI;
}

/* A conservative slab (albedo 1) may not send out more than it receives, for tau0 0.01..50 and
 * g 0, 0.69, 0.9; the model recovers more than single scattering from tau0 = 1 on. */
SQ_TEST(ms_diffusion_creates_no_energy)
{
    const double taus[] = {0.01, 0.1, 1.0, 4.0, 12.0, 50.0};
    const double gs[] = {0.0, 0.69, 0.9};
    for (size_t gi = 0; gi < sizeof gs / sizeof gs[0]; gi++)
        for (size_t ti = 0; ti < sizeof taus / sizeof taus[0]; ti++) {
            const double one = slab_out(taus[ti], gs[gi], 1);
            const double out = slab_out_diffusion(taus[ti], gs[gi], 1.0, false);
            printf("slab tau %5.2f g %.2f: out %.4f (single scattering), %.4f (diffusion)\n",
                   taus[ti], gs[gi], one, out);
            SQ_CHECK_MSG(out <= 1.0 + 1e-3, "tau %g g %g: %.5f leaves, 1 entered", taus[ti],
                         gs[gi], out);
            SQ_CHECK(out >= one - 1e-9);
            if (taus[ti] >= 1.0) SQ_CHECK(out - one > 0.05 * (1.0 - one));
        }
}

/* Reflectance of a semi-infinite dust layer (optical depth 60) lit at normal incidence, the
 * model against an analogue Monte Carlo written here (HG phase sampled exactly, 200 000
 * photons, fixed seed): for the haboob's dust (albedo 0.82 and ~0.89, g 0.69) and a bright
 * one (0.95). Single scattering returns 0.02 of the light where Monte Carlo returns 0.11-0.32;
 * the model must be within 25 % of Monte Carlo (it leaves out nothing but the P1
 * approximation's error and a small sideways loss). */
static double mc_reflectance(double w, double g, double tau0, int n)
{
    uint64_t st = 0x9E3779B97F4A7C15ull;
    double out = 0.0;
    for (int i = 0; i < n; i++) {
        double z = 0.0, mu = 1.0, wt = 1.0;
        for (;;) {
            st = st * 6364136223846793005ull + 1442695040888963407ull;
            const double u1 = ((double)(st >> 11) + 0.5) / 9007199254740992.0;
            z += mu * -log(u1);
            if (z < 0.0) {
                out += wt;
                break;
            }
            if (z > tau0 || wt < 1e-4) break;
            wt *= w;
            st = st * 6364136223846793005ull + 1442695040888963407ull;
            const double u2 = ((double)(st >> 11) + 0.5) / 9007199254740992.0;
            st = st * 6364136223846793005ull + 1442695040888963407ull;
            const double u3 = ((double)(st >> 11) + 0.5) / 9007199254740992.0;
            double ct = 2.0 * u2 - 1.0;
            if (fabs(g) > 1e-6) {
                const double q = (1.0 - g * g) / (1.0 - g + 2.0 * g * u2);
                ct = (1.0 + g * g - q * q) / (2.0 * g);
            }
            const double stt = sqrt(fmax(0.0, 1.0 - ct * ct)), smu = sqrt(fmax(0.0, 1.0 - mu * mu));
            mu = mu * ct + smu * stt * cos(2.0 * SQ_PI * u3);
        }
    }
    return out / n;
}

SQ_TEST(ms_diffusion_reflectance_against_monte_carlo)
{
    const double ws[] = {0.82, 0.89, 0.95};
    for (size_t i = 0; i < sizeof ws / sizeof ws[0]; i++) {
        const double mc = mc_reflectance(ws[i], 0.69, 60.0, 200000);
        const double model = slab_out_diffusion(60.0, 0.69, ws[i], true);
        printf("albedo %.2f g 0.69: reflectance model %.4f, Monte Carlo %.4f (ratio %.3f)\n",
               ws[i], model, mc, model / mc);
        SQ_CHECK_REL(model, mc, 0.25);
    }
}

/* ---- sharp dust edges (sq_volume_view.edge_sharpness) ------------------------------------ */
/* What is checked. A cube of density 1 (cells 4..11 of a 16^3 grid of 10 m cells, beta 0.1 /m:
 * opaque) in clear air, seen from 2 km (fov 4 deg, nearly orthographic) against the sky. Trilinear sampling spreads its side
 * edge over the 10 m between the last dense and the first clear cell centre; with
 * edge_sharpness 1 the edge is drawn at the half-maximum contour a fifth as wide. Along the
 * middle row, the pixels between 10 % and 90 % of the way from the sky to the cube's face
 * (the transition; the cube is black, so this is its opacity) must be at most half as many
 * with sharp edges (and at least 3 without, so that the comparison means something); the face
 * itself (the middle pixel) changes by less than 2 % of the sky. A density that varies smoothly (a linear ramp 1 -> 2 across the grid, less than
 * half of its local maximum over two cells) must be drawn identically with and without. */
static float *edge_frame(sq_renderer *r, const sq_world *w, bool ramp, float sharpness,
                         const char *name)
{
    enum { N = 16 };
    static float dens[N * N * N];
    for (int k = 0; k < N; k++)
        for (int j = 0; j < N; j++)
            for (int i = 0; i < N; i++) {
                const bool in = i >= 4 && i < 12 && j >= 4 && j < 12 && k >= 4 && k < 12;
                dens[(k * N + j) * N + i] = ramp ? 1.0f + (float)i / (N - 1) : (in ? 1.0f : 0.0f);
            }
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_VOLUME;
    d.name = "edge";
    sq_volume_view *v = &d.u.volume;
    v->density = dens;
    v->nx = v->ny = v->nz = N;
    v->origin_m = sq_v3(200.0f, -80.0f, 0.0f);
    v->size_m = sq_v3(160.0f, 160.0f, 160.0f);
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = ramp ? 0.01f : 0.1f;
        v->albedo[c] = ramp ? 0.9f : 0.0f; /* the cube black: the pixels show its opacity */
        v->g[c] = 0.6f;
    }
    v->density_max = ramp ? 2.0f : 1.0f;
    v->edge_sharpness = sharpness;
    v->version = ramp ? 11u : 12u;
    const sq_camera cam = camera(sq_v3(-1800.0f, 0.0f, 80.0f), sq_v3(280.0f, 0.0f, 80.0f), 4.0f);
    return render(r, w, &cam, &d, 1, 0.0, name);
}

static int edge_transition_px(const float *rgb)
{
    const int j = IMG_H / 2;
    const double sky = rgb[3 * (j * IMG_W + 2) + 1], face = rgb[3 * (j * IMG_W + IMG_W / 2) + 1];
    int n = 0;
    for (int i = 0; i < IMG_W; i++) {
        const double f = ((double)rgb[3 * (j * IMG_W + i) + 1] - sky) / (face - sky);
        if (f > 0.1 && f < 0.9) n++;
    }
    return n;
}

SQ_TEST(sharp_edges_narrow_the_edge)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 4000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 128, false);
    float *soft = NULL, *sharp = NULL, *rs = NULL, *rh = NULL;
    if (!w || !r) goto done;
    w->sun_dir = sq_v3_norm(sq_v3(-0.6f, -0.3f, 0.7f)); /* behind the camera, to the side */
    soft = edge_frame(r, w, false, 0.0f, "edge_soft");
    sharp = edge_frame(r, w, false, 1.0f, "edge_sharp");
    rs = edge_frame(r, w, true, 0.0f, "ramp_soft");
    rh = edge_frame(r, w, true, 1.0f, "ramp_sharp");
    if (!soft || !sharp || !rs || !rh) goto done;
    const int ws = edge_transition_px(soft), wh = edge_transition_px(sharp);
    const size_t mid = (size_t)3 * ((IMG_H / 2) * IMG_W + IMG_W / 2) + 1;
    const double face = fabs((double)sharp[mid] - soft[mid]) / sharp[3 * ((IMG_H / 2) * IMG_W + 2) + 1];
    double sum = 0.0;
    for (size_t k = 1; k < (size_t)3 * IMG_W * IMG_H; k += 3) sum += rs[k];
    const double ramp_diff = image_l1(rs, rh) / sum;
    printf("edge transition: %d px trilinear, %d px sharp; face changed by %.4f; smooth ramp "
           "changed by %.3g (relative L1)\n",
           ws, wh, face, ramp_diff);
    SQ_CHECK(ws >= 3);
    SQ_CHECK(2 * wh <= ws);
    SQ_CHECK(face < 0.02);
    SQ_CHECK(ramp_diff < 1e-6);
done:
    free(soft);
    free(sharp);
    free(rs);
    free(rh);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Dust beyond the box's y faces (sq_volume_view.mirror_y_m). A box (x 200-300 m, y -100-100 m,
 * z 0-100 m) holds dust graded toward its +y face (density 0, 0, 0.5, 1 over the four layers of
 * y). The camera at y = 100 m, on the face's plane, looks along +x; the sun shines in the x-z
 * plane, the ground is flat: the scene with the dust mirrored at y = 100 m is symmetric about
 * that plane, so the frame must be symmetric left-right (the plane is the frame's centre
 * column). Without mirroring, nothing may be drawn beyond the face: the frame's left half (+y)
 * is the dust-free frame's. Compared over the pixel pairs seen against the sky (the ground's
 * texture is not symmetric). Measured: asymmetry 0.0001 of the dust's contrast with mirroring
 * (against 1 without); the left half without mirroring equal to the clear frame. */
SQ_TEST(mirror_y_draws_the_dust_beyond_the_faces)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 4000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 128, false);
    float *clear = NULL, *cut = NULL, *mir = NULL;
    if (!w || !r) goto done;
    w->sun_dir = sq_v3_norm(sq_v3(-0.5f, 0.0f, 0.8f));
    const sq_camera cam = camera(sq_v3(0.0f, 100.0f, 50.0f), sq_v3(300.0f, 100.0f, 50.0f), 40.0f);
    medium m;
    medium_init(&m, sq_v3(200.0f, -100.0f, 0.0f), sq_v3(100.0f, 200.0f, 100.0f), 0.02f, 0.9f,
                0.7f, 1.0f);
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) m.density[(k * 4 + j) * 4 + i] = j < 2 ? 0.0f : 0.5f * (float)(j - 1);
    clear = render(r, w, &cam, NULL, 0, 0.0, "mirror_clear");
    cut = render(r, w, &cam, &m.d, 1, 0.0, "mirror_off");
    m.d.u.volume.mirror_y_m = 200.0f;
    m.d.u.volume.version = 2;
    mir = render(r, w, &cam, &m.d, 1, 0.0, "mirror_on");
    if (!clear || !cut || !mir) goto done;
    double contrast = 0.0, asym_cut = 0.0, asym_mir = 0.0, left_cut = 0.0;
    for (int y = 0; y < IMG_H; y++)
        for (int x = 0; x < IMG_W / 2; x++) {
            const size_t a = (size_t)3 * (y * IMG_W + x) + 1;
            const size_t b = (size_t)3 * (y * IMG_W + (IMG_W - 1 - x)) + 1;
            left_cut += fabs((double)cut[a] - clear[a]);
            /* the sky is symmetric, the ground's texture is not: pairs seen against the sky */
            if (fabs((double)clear[a] - clear[b]) > 1e-4 * clear[a]) continue;
            contrast += fabs((double)cut[b] - clear[b]);
            asym_cut += fabs((double)cut[a] - cut[b]);
            asym_mir += fabs((double)mir[a] - mir[b]);
        }
    printf("mirror: dust contrast %.4g; asymmetry %.4f with mirroring, %.4f without; left half "
           "without mirroring differs from the clear frame by %.3g (relative to the contrast)\n",
           contrast, asym_mir / contrast, asym_cut / contrast, left_cut / contrast);
    SQ_CHECK(contrast > 0.0);
    SQ_CHECK(asym_cut > 0.5 * contrast);
    SQ_CHECK(asym_mir < 0.01 * contrast);
    SQ_CHECK(left_cut < 1e-6 * contrast);
    m.d.u.volume.mirror_y_m = -1.0f;
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, &m.d, 1, 0.0), SQ_ERR_INVALID_ARG, "mirror_y_m");
done:
    free(clear);
    free(cut);
    free(mir);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- composition with opaque geometry ------------------------------------------------------ */
/* A dense slab (beta 0.1 /m, 100 m thick: optical depth 10) stands 200-300 m ahead. A white box
 * in front of it (x = 120 m) must be untouched (identical pixels with and without the slab) and
 * so must the ground in front of the slab; a white box behind it (x = 400 m) must vanish: with
 * the slab, the frames with and without that box differ by less than 1 % of the box's contrast
 * without the slab (exp(-10) = 4.5e-5 would remain). A slab of density 0 changes no pixel. */
SQ_TEST(depth_composition)
{
    sq_context *ctx = new_ctx();
    sq_obstacle obs[2] = {box_obstacle(sq_v3(120.0f, -25.0f, 0.0f), sq_v3(10.0f, 20.0f, 30.0f), 0.9f),
                          box_obstacle(sq_v3(400.0f, 40.0f, 0.0f), sq_v3(10.0f, 60.0f, 60.0f), 0.9f)};
    sq_world *wa = new_world(ctx, 4000.0f, obs, 2);
    sq_world *wb = new_world(ctx, 4000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 96, false);
    float *r1 = NULL, *r2 = NULL, *r3 = NULL, *r4 = NULL, *r5 = NULL;
    if (!wa || !wb || !r) goto done;
    wa->sun_dir = wb->sun_dir = sq_v3_norm(sq_v3(-0.5f, 0.2f, 0.8f)); /* shadow falls away (+x) */
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 20.0f), sq_v3(100.0f, 0.0f, 15.0f), 40.0f);
    const sq_vec3 lo = sq_v3(200.0f, -600.0f, -1.0f), size = sq_v3(100.0f, 1200.0f, 150.0f);
    medium m, m0;
    medium_init(&m, lo, size, 0.1f, 0.8f, 0.7f, 1.0f);
    medium_init(&m0, lo, size, 0.1f, 0.8f, 0.7f, 0.0f);
    r1 = render(r, wa, &cam, NULL, 0, 0.0, "depth_obstacles_clear");
    r2 = render(r, wa, &cam, &m.d, 1, 0.0, "depth_obstacles_dust");
    r3 = render(r, wb, &cam, &m.d, 1, 0.0, "depth_empty_dust");
    r4 = render(r, wb, &cam, NULL, 0, 0.0, "depth_empty_clear");
    r5 = render(r, wa, &cam, &m0.d, 1, 0.0, "depth_obstacles_zero");
    if (!r1 || !r2 || !r3 || !r4 || !r5) goto done;

    sq_vec3 flo, fhi, blo, bhi;
    obstacle_aabb(&obs[0], &flo, &fhi);
    obstacle_aabb(&obs[1], &blo, &bhi);
    int nfront = 0, nground = 0, nbehind = 0;
    double front_dev = 0.0, ground_dev = 0.0, behind_hidden = 0.0, behind_contrast = 0.0;
    double zero_dev = 0.0;
    for (int j = 0; j < IMG_H; j++)
        for (int i = 0; i < IMG_W; i++) {
            sq_vec3 o, d;
            pixel_ray(&cam, i, j, &o, &d);
            const size_t q = (size_t)3 * (size_t)(j * IMG_W + i) + 1; /* green */
            for (int c = 0; c < 3; c++) {
                const size_t qc = q - 1 + (size_t)c;
                zero_dev = fmax(zero_dev, fabs(r5[qc] - r1[qc]));
            }
            float t0, t1;
            const sq_vec3 shrink = sq_v3(1.0f, 1.0f, 1.0f);
            if (ray_box(o, d, sq_v3_add(flo, shrink), sq_v3_sub(fhi, shrink), &t0, &t1)) {
                front_dev = fmax(front_dev, fabs(r2[q] - r1[q]) / r1[q]);
                nfront++;
                continue;
            }
            if (ray_box(o, d, sq_v3_add(blo, shrink), sq_v3_sub(bhi, shrink), &t0, &t1)) {
                behind_hidden += fabs(r2[q] - r3[q]);
                behind_contrast += fabs(r1[q] - r4[q]);
                nbehind++;
                continue;
            }
            const float tg = ground_t(o, d);
            const sq_vec3 g = sq_v3_add(o, sq_v3_scale(d, tg));
            if (isfinite(tg) && g.x < 150.0f && g.x > 30.0f && fabsf(g.y) < 200.0f) {
                bool near_box = false;
                sq_vec3 a = sq_v3_sub(flo, sq_v3(3, 3, 3)), b = sq_v3_add(fhi, sq_v3(3, 3, 3));
                near_box = ray_box(o, d, a, b, &t0, &t1);
                if (!near_box) {
                    ground_dev = fmax(ground_dev, fabs(r2[q] - r1[q]) / r1[q]);
                    nground++;
                }
            }
        }
    printf("depth composition: front box %d px max rel change %.3g; ground in front %d px max "
           "rel change %.3g; box behind %d px: residual %.3g of its contrast; zero density max "
           "abs change %.3g\n",
           nfront, front_dev, nground, ground_dev, nbehind,
           behind_contrast > 0 ? behind_hidden / behind_contrast : -1.0, zero_dev);
    SQ_CHECK(nfront > 50 && nground > 500 && nbehind > 50);
    SQ_CHECK(front_dev <= 1e-6);
    SQ_CHECK(ground_dev <= 1e-6);
    SQ_CHECK(behind_contrast > 0.05 * nbehind); /* the box is visible without the slab */
    SQ_CHECK(behind_hidden <= 0.01 * behind_contrast);
    SQ_CHECK(zero_dev == 0.0);
done:
    free(r1);
    free(r2);
    free(r3);
    free(r4);
    free(r5);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, wa);
    sq_world_destroy(ctx, wb);
    sq_context_destroy(ctx);
}

/* The density is uploaded when its version changes (not on every frame): new values under the
 * same version are not seen, a new version is. */
SQ_TEST(density_upload_follows_version)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 2000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 32, false);
    float *a = NULL, *b = NULL, *c = NULL;
    if (!w || !r) goto done;
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 20.0f), sq_v3(100.0f, 0.0f, 15.0f), 40.0f);
    medium m;
    medium_init(&m, sq_v3(50.0f, -100.0f, -1.0f), sq_v3(100.0f, 200.0f, 60.0f), 0.02f, 0.8f, 0.7f,
                0.0f);
    a = render(r, w, &cam, &m.d, 1, 0.0, NULL);
    for (int i = 0; i < 64; i++) m.density[i] = 1.0f; /* same version: not uploaded */
    b = render(r, w, &cam, &m.d, 1, 0.0, NULL);
    m.d.u.volume.version = 2;
    c = render(r, w, &cam, &m.d, 1, 0.0, NULL);
    if (!a || !b || !c) goto done;
    SQ_CHECK(image_l1(a, b) == 0.0);
    SQ_CHECK(image_l1(a, c) > 0.01 * IMG_W * IMG_H);
done:
    free(a);
    free(b);
    free(c);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- chunked light array -------------------------------------------------------------------- */
/* When the light array (one 256^2 RGBA16F layer, 512 KiB, per in-box slab) would exceed a
 * quarter of the context's memory limit, render_volume.c sweeps the light in chunks with one
 * checkpoint layer each and the eye pass recomputes a chunk's layers from its checkpoint. The
 * same frame is rendered with the default limit (one chunk), with 64 MiB (budget 32 layers:
 * chunks that fit it) and with 32 MiB (budget 16 layers: none fits, ~sqrt(n) planes per chunk),
 * for the sun behind the viewer (eye pass front to back over the chunks) and ahead (back to
 * front). The chunked frames must match the unchunked one: per pixel within 1 % relative
 * (+ 1e-4 absolute) on every channel, and the mean relative difference below 1e-3. They differ
 * at all only where a light pass groups slabs differently at a chunk boundary (the light is
 * carried in registers within a group and rounded to half floats between groups). */
static void lumpy_volume(float *density, int n, sq_drawable *d)
{
    for (int k = 0; k < n; k++)
        for (int j = 0; j < n; j++)
            for (int i = 0; i < n; i++) {
                double x = (i + 0.5) / n * 2 - 1, y = (j + 0.5) / n * 2 - 1, z = (k + 0.5) / n;
                double v = exp(-2.0 * (x * x + y * y)) * (0.8 + 0.2 * sin(7.0 * x + 3.0 * z)) *
                           exp(-1.5 * z);
                density[(k * n + j) * n + i] = (float)v;
            }
    memset(d, 0, sizeof *d);
    d->kind = SQ_DRAWABLE_VOLUME;
    d->name = "lumpy";
    sq_volume_view *v = &d->u.volume;
    v->density = density;
    v->nx = v->ny = v->nz = n;
    v->origin_m = sq_v3(60.0f, -80.0f, 0.0f);
    v->size_m = sq_v3(160.0f, 160.0f, 100.0f);
    for (int c = 0; c < 3; c++) {
        v->sigma_ext[c] = 0.06f;
        v->albedo[c] = 0.95f - 0.08f * (float)c;
        v->g[c] = 0.8f;
    }
    v->density_max = 1.0f;
    v->version = 1;
}

static float *chunk_frame(uint64_t limit, sq_vec3 sun, const sq_drawable *d, int *chunks,
                          int *len)
{
    sq_context_desc cd = {0};
    cd.threads = 2;
    cd.log_level = SQ_LOG_NONE;
    cd.memory_limit_bytes = limit;
    sq_context *ctx = NULL;
    SQ_CHECK_OK(sq_context_create(&cd, &ctx));
    if (!ctx) return NULL;
    sq_world_desc wd = {0};
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 2000.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.sky.turbidity = 2.0f;
    wd.sun.direction = sun;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    sq_renderer *r = new_renderer(ctx, 128, false);
    float *rgb = NULL;
    if (w && r) {
        const sq_camera cam = camera(sq_v3(-150.0f, -20.0f, 40.0f), sq_v3(140.0f, 0.0f, 35.0f), 50.0f);
        rgb = render(r, w, &cam, d, 1, 0.0, NULL);
        sq__volume_pass_layout(r, chunks, len);
    }
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
    return rgb;
}

static void chunked_case(sq_vec3 sun, const char *tag)
{
    enum { N = 24 };
    static float density[N * N * N];
    sq_drawable d;
    lumpy_volume(density, N, &d);
    const uint64_t limits[3] = {0, (uint64_t)64 << 20, (uint64_t)32 << 20};
    float *img[3] = {NULL, NULL, NULL};
    int chunks[3] = {0, 0, 0}, len[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) img[k] = chunk_frame(limits[k], sun, &d, &chunks[k], &len[k]);
    if (img[0] && img[1] && img[2]) {
        SQ_CHECK(chunks[0] == 1);
        SQ_CHECK(chunks[1] > 1 && chunks[1] + len[1] <= 32);
        SQ_CHECK(chunks[2] > chunks[1]);
        double mean0 = 0.0;
        for (size_t i = 0; i < (size_t)3 * IMG_W * IMG_H; i++) mean0 += img[0][i];
        mean0 /= 3.0 * IMG_W * IMG_H;
        for (int k = 1; k < 3; k++) {
            double worst = 0.0, sum = 0.0;
            int bad = 0;
            for (size_t i = 0; i < (size_t)3 * IMG_W * IMG_H; i++) {
                const double a = img[0][i], b = img[k][i], diff = fabs(a - b);
                const double rel = diff / (fabs(a) + 1e-4);
                worst = fmax(worst, rel);
                sum += diff;
                if (diff > 0.01 * fabs(a) + 1e-4) bad++;
            }
            const double mean_rel = sum / (3.0 * IMG_W * IMG_H) / mean0;
            printf("%s: %d chunks of %d planes vs one: worst pixel %.3g relative, mean %.3g "
                   "relative, %d values beyond 1 %%\n",
                   tag, chunks[k], len[k], worst, mean_rel, bad);
            SQ_CHECK(bad == 0);
            SQ_CHECK(mean_rel < 1e-3);
        }
    }
    for (int k = 0; k < 3; k++) free(img[k]);
}

SQ_TEST(light_array_chunked_matches_unchunked_sun_behind)
{
    chunked_case(sq_v3(-0.6f, -0.3f, 0.5f), "behind");
}

SQ_TEST(light_array_chunked_matches_unchunked_sun_ahead)
{
    chunked_case(sq_v3(0.8f, 0.3f, 0.45f), "ahead");
}

/* ---- sun shadow of the dust on the terrain -------------------------------------------------- */
/* A slab 100-150 m above the ground (beta 0.04 /m, albedo 0.9, g 0.7) covers x < 0; the sun
 * shines from 16.7 degrees off the zenith, (0, 0.3, 1). The camera, below the slab, looks down
 * at the ground on both sides of x = 0. Per pixel, the sun's share of the ground radiance is
 * (frame with sun - frame without sun); its ratio with and without the slab is the sun
 * transmittance through the slab as the terrain sees it. Outside the slab's shadow it must be
 * 1 (within 1 %); under it, with the single-scattering ablation, Beer-Lambert exactly:
 * exp(-beta 50 m / cos 16.7 deg) = 0.1239 within 3 %; with multiple forward scattering the
 * light kept in the forward cone must make it brighter than that (by more than 5 %) yet < 1. */
static double shadow_transmittance(bool single, double *outside)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 4000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 64, single);
    double t_in = -1.0;
    *outside = -1.0;
    float *s1 = NULL, *s0 = NULL, *n1 = NULL, *n0 = NULL;
    if (!w || !r) goto done;
    w->sun_dir = sq_v3_norm(sq_v3(0.0f, 0.3f, 1.0f));
    const sq_vec3 sun = w->sun_radiance;
    const sq_camera cam = camera(sq_v3(0.0f, -60.0f, 40.0f), sq_v3(0.0f, 40.0f, 0.0f), 50.0f);
    medium m;
    medium_init(&m, sq_v3(-500.0f, -500.0f, 100.0f), sq_v3(500.0f, 1000.0f, 50.0f), 0.04f, 0.9f,
                0.7f, 1.0f);
    const char *tag = single ? "single" : "multiple";
    char name[64];
    snprintf(name, sizeof name, "shadow_%s_sun_dust", tag);
    s1 = render(r, w, &cam, &m.d, 1, 0.0, name);
    snprintf(name, sizeof name, "shadow_%s_sun_clear", tag);
    n1 = render(r, w, &cam, NULL, 0, 0.0, name);
    w->sun_radiance = sq_v3(0.0f, 0.0f, 0.0f);
    s0 = render(r, w, &cam, &m.d, 1, 0.0, "shadow_nosun_dust");
    n0 = render(r, w, &cam, NULL, 0, 0.0, "shadow_nosun_clear");
    w->sun_radiance = sun;
    if (!s1 || !s0 || !n1 || !n0) goto done;
    double in_sum = 0.0, out_sum = 0.0, out_max_dev = 0.0;
    int nin = 0, nout = 0;
    for (int j = 0; j < IMG_H; j++)
        for (int i = 0; i < IMG_W; i++) {
            sq_vec3 o, d;
            pixel_ray(&cam, i, j, &o, &d);
            const float tg = ground_t(o, d);
            if (!isfinite(tg) || tg > 400.0f) continue;
            const sq_vec3 g = sq_v3_add(o, sq_v3_scale(d, tg));
            const size_t q = (size_t)3 * (size_t)(j * IMG_W + i) + 1;
            const double sun_clear = n1[q] - n0[q];
            if (sun_clear <= 1e-4) continue;
            const double t = (s1[q] - s0[q]) / sun_clear;
            if (g.x < -15.0f && g.x > -400.0f) {
                in_sum += t;
                nin++;
            } else if (g.x > 15.0f) {
                out_sum += t;
                out_max_dev = fmax(out_max_dev, fabs(t - 1.0));
                nout++;
            }
        }
    SQ_CHECK(nin > 1000 && nout > 1000);
    if (nin > 0) t_in = in_sum / nin;
    if (nout > 0) *outside = out_sum / nout;
    printf("dust shadow (%s scattering): transmittance under the slab %.4f (%d px), outside "
           "%.4f (%d px, max |t-1| %.3g)\n",
           tag, t_in, nin, *outside, nout, out_max_dev);
    SQ_CHECK(out_max_dev <= 0.01);
done:
    free(s1);
    free(s0);
    free(n1);
    free(n0);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
    return t_in;
}

SQ_TEST(dust_shadows_terrain)
{
    double out_s, out_m;
    const double t_single = shadow_transmittance(true, &out_s);
    const double t_multi = shadow_transmittance(false, &out_m);
    const double expect = exp(-0.04 * 50.0 * sqrt(1.0 + 0.09));
    printf("dust shadow: Beer-Lambert %.4f, single %.4f (rel %.4f), multiple %.4f\n", expect,
           t_single, fabs(t_single - expect) / expect, t_multi);
    SQ_CHECK_REL(t_single, expect, 0.03);
    SQ_CHECK(t_multi > 1.05 * t_single);
    SQ_CHECK(t_multi < 0.9);
}

/* ---- refusals ------------------------------------------------------------------------------ */
SQ_TEST(slices_refused)
{
    sq_context *ctx = new_ctx();
    sq_render_desc rd = {0};
    rd.width = 64;
    rd.height = 32;
    sq_renderer *r = NULL;
    rd.volume_slices = -1;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &rd, &r), SQ_ERR_INVALID_ARG, "volume_slices");
    SQ_CHECK(r == NULL);
    rd.volume_slices = 100000;
    SQ_CHECK_ERR(sq_renderer_create(ctx, &rd, &r), SQ_ERR_INVALID_ARG, "volume_slices");
    SQ_CHECK(r == NULL);
    rd.volume_slices = 0; /* the default, 128 */
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

SQ_TEST(texture_limit_refused)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 1000.0f, NULL, 0);
    sq_render_desc rd = {0};
    rd.width = 64;
    rd.height = 32;
    sq_renderer *r = NULL;
    SQ_CHECK_OK(sq_renderer_create(ctx, &rd, &r));
    sq_render_info info;
    if (!w || !r || sq_renderer_info(r, &info) != SQ_OK) goto done;
    SQ_CHECK(info.max_3d_texture_size > 0);
    const int n = info.max_3d_texture_size + 1;
    float *dens = calloc((size_t)n, sizeof(float));
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_VOLUME;
    d.name = "too-long";
    d.u.volume.density = dens;
    d.u.volume.nx = n;
    d.u.volume.ny = d.u.volume.nz = 1;
    d.u.volume.origin_m = sq_v3(-10, -10, 0);
    d.u.volume.size_m = sq_v3(20, 20, 20);
    d.u.volume.sigma_ext[0] = d.u.volume.sigma_ext[1] = d.u.volume.sigma_ext[2] = 0.01f;
    d.u.volume.version = 1;
    const sq_camera cam = camera(sq_v3(0, -100, 20), sq_v3(0, 0, 10), 50.0f);
    char limit[32];
    snprintf(limit, sizeof limit, "= %d", info.max_3d_texture_size);
    SQ_CHECK_ERR(sq_renderer_draw(r, w, &cam, &d, 1, 0.0), SQ_ERR_INVALID_ARG,
                 "GL_MAX_3D_TEXTURE_SIZE");
    SQ_CHECK(strstr(sq_last_error(), limit) != NULL);
    /* the same volume within the limit renders */
    d.u.volume.nx = n - 1;
    SQ_CHECK_OK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0));
    free(dens);
done:
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- soft particles ------------------------------------------------------------------------- */
typedef struct sprite1 {
    float pos[3], radius, rot, tau, fade;
    sq_drawable d;
} sprite1;

static void sprite_init(sprite1 *s, sq_vec3 c, float radius, float tau, sq_sprite_kind kind,
                        float softness)
{
    memset(s, 0, sizeof *s);
    s->pos[0] = c.x;
    s->pos[1] = c.y;
    s->pos[2] = c.z;
    s->radius = radius;
    s->tau = tau;
    s->fade = 1.0f;
    sq_particles_view *p = &s->d.u.particles;
    s->d.kind = SQ_DRAWABLE_PARTICLES;
    s->d.name = "sprite";
    p->count = 1;
    p->position = s->pos;
    p->radius_m = &s->radius;
    p->rotation_rad = &s->rot;
    p->tau = &s->tau;
    p->fade = &s->fade;
    p->sprite = kind;
    p->softness_m = softness;
    p->g = 0.0f; /* albedo 0: black sprites, alpha visible directly */
    p->version = 1;
}

/* Soft depth fade (SPEC 4.2 fix 1): a black disc (tau 4) of radius 3 m centred 1 m above the
 * ground, seen from 10 m up, cuts the ground along a line. Per pixel the effective alpha is
 * 1 - B/B_clear, and the linear view-depth gap between the ground behind and the sprite's plane
 * is known from the geometry. Where the gap is below 0.3 m (on the part of the sprite where its
 * full alpha exceeds 0.65), a softness of 3 m must leave alpha <= 0.15 (prediction: <= 0.1 of
 * the full value): no hard edge. With softness 0 the same pixels must show the hard edge
 * (alpha >= 0.5), so the test can fail. */
SQ_TEST(particle_soft_edge)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 1000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 32, false);
    float *clear = NULL, *soft = NULL, *hard = NULL;
    if (!w || !r) goto done;
    const sq_vec3 c = sq_v3(15.0f, 0.0f, 1.0f);
    const float radius = 3.0f;
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 10.0f), c, 30.0f);
    sprite1 s;
    sprite_init(&s, c, radius, 4.0f, SQ_SPRITE_DISC, 3.0f);
    clear = render(r, w, &cam, NULL, 0, 0.0, "particle_edge_clear");
    soft = render(r, w, &cam, &s.d, 1, 0.0, "particle_edge_soft");
    s.d.u.particles.softness_m = 0.0f;
    hard = render(r, w, &cam, &s.d, 1, 0.0, "particle_edge_hard");
    if (!clear || !soft || !hard) goto done;
    const sq_vec3 fwd = sq_v3_norm(sq_v3_sub(cam.target_m, cam.position_m));
    const sq_vec3 right = sq_v3_norm(sq_v3_cross(fwd, sq_v3(0, 0, 1)));
    const sq_vec3 up = sq_v3_cross(right, fwd);
    const float zc = sq_v3_dot(sq_v3_sub(c, cam.position_m), fwd);
    int nband = 0, ninside = 0;
    double soft_max = 0.0, hard_min = 1.0, soft_inner = 0.0;
    for (int j = 0; j < IMG_H; j++)
        for (int i = 0; i < IMG_W; i++) {
            sq_vec3 o, d;
            pixel_ray(&cam, i, j, &o, &d);
            const float tq = zc / sq_v3_dot(d, fwd);
            const sq_vec3 q = sq_v3_sub(sq_v3_add(o, sq_v3_scale(d, tq)), c);
            const float lx = sq_v3_dot(q, right) / radius, ly = sq_v3_dot(q, up) / radius;
            if (lx * lx + ly * ly > 0.25f) continue; /* central part: full alpha >= 0.65 */
            const float tg = ground_t(o, d);
            const float gap = tg * sq_v3_dot(d, fwd) - zc;
            const size_t k = (size_t)3 * (size_t)(j * IMG_W + i) + 1;
            if (clear[k] <= 0.0f) continue;
            const double a_soft = 1.0 - soft[k] / clear[k], a_hard = 1.0 - hard[k] / clear[k];
            if (gap > 0.0f && gap < 0.3f) {
                soft_max = fmax(soft_max, a_soft);
                hard_min = fmin(hard_min, a_hard);
                nband++;
            } else if (gap > 3.0f) {
                soft_inner = fmax(soft_inner, a_soft);
                ninside++;
            }
        }
    printf("soft particle: %d px within 0.3 m of the ground: alpha soft max %.4f, hard min %.4f; "
           "%d px > 3 m in front: alpha soft max %.4f\n",
           nband, soft_max, hard_min, ninside, soft_inner);
    SQ_CHECK(nband >= 20);
    SQ_CHECK(soft_max <= 0.15);
    SQ_CHECK(hard_min >= 0.5);
    SQ_CHECK(ninside == 0 || soft_inner >= 0.5); /* away from the ground it is opaque */
done:
    free(clear);
    free(soft);
    free(hard);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Rotation (SPEC 4.5 fix): a six-fold flake turned by 60 degrees is the same picture (within 3 %
 * of its own signal), turned by 45 degrees it is a different one (> 20 %); a noisy dust puff
 * turned by 45 degrees changes too (its noise turns with the quad). */
SQ_TEST(particle_rotation)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 1000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 32, false);
    float *bg = NULL, *f0 = NULL, *f45 = NULL, *f60 = NULL, *p0 = NULL, *p45 = NULL;
    if (!w || !r) goto done;
    const sq_vec3 c = sq_v3(30.0f, 0.0f, 10.0f);
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 10.0f), sq_v3(50.0f, 0.0f, 10.0f), 30.0f);
    sprite1 s;
    sprite_init(&s, c, 4.0f, 3.0f, SQ_SPRITE_FLAKE6, 0.0f);
    bg = render(r, w, &cam, NULL, 0, 0.0, "rot_bg");
    f0 = render(r, w, &cam, &s.d, 1, 0.0, "rot_flake_0");
    s.rot = (float)(SQ_PI / 4.0);
    f45 = render(r, w, &cam, &s.d, 1, 0.0, "rot_flake_45");
    s.rot = (float)(SQ_PI / 3.0);
    f60 = render(r, w, &cam, &s.d, 1, 0.0, "rot_flake_60");
    s.d.u.particles.sprite = SQ_SPRITE_PUFF;
    s.tau = 0.7f; /* unsaturated, so that its noise shows */
    s.rot = 0.0f;
    p0 = render(r, w, &cam, &s.d, 1, 0.0, "rot_puff_0");
    s.rot = (float)(SQ_PI / 4.0);
    p45 = render(r, w, &cam, &s.d, 1, 0.0, "rot_puff_45");
    if (!bg || !f0 || !f45 || !f60 || !p0 || !p45) goto done;
    const double sig = image_l1(f0, bg), d60 = image_l1(f0, f60), d45 = image_l1(f0, f45);
    const double psig = image_l1(p0, bg), p45d = image_l1(p0, p45);
    printf("rotation: flake signal %.4g, |0-60| %.4g (%.4f), |0-45| %.4g (%.4f); puff |0-45| "
           "%.4f\n",
           sig, d60, d60 / sig, d45, d45 / sig, p45d / psig);
    SQ_CHECK(sig > 0.0);
    SQ_CHECK(d60 <= 0.03 * sig);
    SQ_CHECK(d45 >= 0.2 * sig);
    SQ_CHECK(p45d >= 0.1 * psig);
done:
    free(bg);
    free(f0);
    free(f45);
    free(f60);
    free(p0);
    free(p45);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* The fade multiplier scales opacity: alpha = fade (1 - exp(-tau shape)); fade 0.5 must halve
 * the effective alpha of a black splat against the sky (within 1 %). */
SQ_TEST(particle_fade)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 1000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 32, false);
    float *bg = NULL, *a1 = NULL, *a5 = NULL;
    if (!w || !r) goto done;
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 10.0f), sq_v3(50.0f, 0.0f, 12.0f), 30.0f);
    sprite1 s;
    sprite_init(&s, sq_v3(30.0f, 0.0f, 12.0f), 3.0f, 2.0f, SQ_SPRITE_SPLAT, 0.5f);
    bg = render(r, w, &cam, NULL, 0, 0.0, "fade_bg");
    a1 = render(r, w, &cam, &s.d, 1, 0.0, "fade_1");
    s.fade = 0.5f;
    a5 = render(r, w, &cam, &s.d, 1, 0.0, "fade_05");
    if (!bg || !a1 || !a5) goto done;
    double s1 = 0.0, s5 = 0.0;
    for (size_t k = 1; k < (size_t)3 * IMG_W * IMG_H; k += 3) {
        if (bg[k] <= 0.0f) continue;
        s1 += 1.0 - a1[k] / bg[k];
        s5 += 1.0 - a5[k] / bg[k];
    }
    printf("fade: alpha sum at fade 1 %.4f, at fade 0.5 %.4f (ratio %.4f)\n", s1, s5, s5 / s1);
    SQ_CHECK(s1 > 10.0);
    SQ_CHECK_REL(s5 / s1, 0.5, 0.01);
done:
    free(bg);
    free(a1);
    free(a5);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* 10^5 particles of every sprite kind draw, change the frame, give no NaN, and the same frame
 * twice (the back-to-front sort is deterministic). */
SQ_TEST(particles_many)
{
    sq_context *ctx = new_ctx();
    sq_world *w = new_world(ctx, 1000.0f, NULL, 0);
    sq_renderer *r = new_renderer(ctx, 32, false);
    enum { N = 100000 };
    float *pos = malloc(sizeof(float) * 3 * N), *rot = malloc(sizeof(float) * N);
    float *bg = NULL, *a = NULL, *b = NULL;
    if (!w || !r || !pos || !rot) goto done;
    uint32_t h = 12345u;
    for (int i = 0; i < N; i++) {
        for (int k = 0; k < 3; k++) {
            h = h * 1664525u + 1013904223u;
            const float u = (float)(h >> 8) / 16777216.0f;
            pos[3 * i + k] = k == 0 ? 20.0f + 80.0f * u : (k == 1 ? -40.0f + 80.0f * u : 30.0f * u);
        }
        rot[i] = 0.001f * (float)i;
    }
    const sq_camera cam = camera(sq_v3(0.0f, 0.0f, 10.0f), sq_v3(60.0f, 0.0f, 10.0f), 50.0f);
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_PARTICLES;
    d.name = "many";
    sq_particles_view *p = &d.u.particles;
    p->count = N;
    p->position = pos;
    p->rotation_rad = rot;
    p->radius_default_m = 0.3f;
    p->tau_default = 0.5f;
    p->albedo[0] = 0.8f;
    p->albedo[1] = 0.6f;
    p->albedo[2] = 0.4f;
    p->g = 0.6f;
    p->softness_m = 0.5f;
    bg = render(r, w, &cam, NULL, 0, 0.0, "many_bg");
    for (int kind = SQ_SPRITE_DEFAULT; kind <= SQ_SPRITE_SPHERE; kind++) {
        p->sprite = (sq_sprite_kind)kind;
        free(a);
        free(b);
        char name[32];
        snprintf(name, sizeof name, "many_%d", kind);
        a = render(r, w, &cam, &d, 1, 0.0, name);
        b = render(r, w, &cam, &d, 1, 0.0, NULL);
        if (!a || !b) break;
        bool finite = true;
        for (size_t k = 0; k < (size_t)3 * IMG_W * IMG_H; k++) finite = finite && isfinite(a[k]);
        SQ_CHECK(finite);
        SQ_CHECK(image_l1(a, b) == 0.0);
        printf("10^5 particles, sprite %d: mean |change| %.4g\n", kind,
               image_l1(a, bg) / (IMG_W * IMG_H));
        SQ_CHECK(image_l1(a, bg) > 0.002 * IMG_W * IMG_H); /* drew something */
    }
done:
    free(pos);
    free(rot);
    free(bg);
    free(a);
    free(b);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* ---- slices drawn only where they can meet dust (render_volume.c sq__volume_slice_rect) ---- */

/* Whether the eye pass's density lookup at world point p can read a voxel above 0: the lookup
 * (volume_common.glsl vol_density_smooth: trilinear, the B-spline's fetches reaching the texels
 * i - 1 .. i + 2 around the texel coordinate x, i = floor(x)) reads only texels within 2 of x
 * on every axis; the texture clamps x and z (and y unless mirrored) to its faces. Mirrored in y:
 * every y counts (a superset). */
static bool lookup_reaches_dust(const float *den, const int n[3], sq_vec3 origin, sq_vec3 size,
                                bool mirror_y, sq_vec3 p)
{
    const float pw[3] = {p.x, p.y, p.z}, o[3] = {origin.x, origin.y, origin.z},
                sz[3] = {size.x, size.y, size.z};
    float x[3];
    for (int a = 0; a < 3; a++) {
        const float tc = fminf(fmaxf((pw[a] - o[a]) / sz[a], 0.0f), 1.0f);
        x[a] = tc * (float)n[a] - 0.5f;
    }
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                if (!(den[((size_t)k * n[1] + j) * n[0] + i] > 0.0f)) continue;
                if (fabsf((float)i - x[0]) <= 2.0f && fabsf((float)k - x[2]) <= 2.0f &&
                    (mirror_y || fabsf((float)j - x[1]) <= 2.0f))
                    return true;
            }
    return false;
}

/* Conservative: every point of a slice plane, inside the slice box and in the view in front of
 * the near plane, whose lookup can read dust, lies in its plane's window rectangle. Blobs in
 * the middle of the grid and against its faces (the clamped texture repeats them beyond),
 * mirrored y, cameras outside and inside the box. And useful: some planes are culled whole and
 * the rectangles of the others are, on average, smaller than the window. */
SQ_TEST(volume_slice_rect_never_culls_dust)
{
    const int n[3] = {24, 16, 12};
    const sq_vec3 origin = sq_v3(-1000.0f, -500.0f, 0.0f), size = sq_v3(2400.0f, 1600.0f, 1200.0f);
    /* the slice box: the grid box grown by more than the dust box's margin (300 m) */
    const sq_vec3 glo = sq_v3(-1600.0f, -1100.0f, -600.0f), ghi = sq_v3(2000.0f, 1700.0f, 1800.0f);
    float *den = calloc((size_t)n[0] * n[1] * n[2], sizeof(float));
    SQ_CHECK(den != NULL);
    if (!den) return;
    const int W = 160, H = 90;
    uint32_t rs = 2024u;
    int checked = 0, culled_planes = 0, planes = 0;
    double area = 0.0;
    for (int scene = 0; scene < 3; scene++) {
        memset(den, 0, (size_t)n[0] * n[1] * n[2] * sizeof(float));
        for (int k = 0; k < n[2]; k++)
            for (int j = 0; j < n[1]; j++)
                for (int i = 0; i < n[0]; i++) {
                    bool on = scene == 0   ? (i >= 9 && i <= 12 && j >= 6 && j <= 8 && k >= 3 && k <= 5)
                              : scene == 1 ? (i <= 2 && k <= 1 && j >= 4 && j <= 6) /* faces */
                                           : (i >= 14 && i <= 20 && j >= 12 && k <= 4);
                    if (on) den[((size_t)k * n[1] + j) * n[0] + i] = scene == 2 ? 1e-7f : 1.0f;
                }
        const bool mirror = scene == 2;
        sq__volume_dust dust;
        sq__volume_dust_box(den, n[0], n[1], n[2], origin, size, &dust);
        SQ_CHECK(!dust.empty);
        for (int cam_i = 0; cam_i < 6; cam_i++) {
            float u[8];
            for (int q = 0; q < 8; q++) {
                rs = rs * 1664525u + 1013904223u;
                u[q] = (float)(rs >> 8) / 16777216.0f;
            }
            /* cameras 0-2 inside the slice box, 3-5 outside it */
            const sq_vec3 cam = cam_i < 3 ? sq_v3(-900.0f + 2200.0f * u[0], -400.0f + 1400.0f * u[1],
                                                  50.0f + 1000.0f * u[2])
                                          : sq_v3(2500.0f + 1000.0f * u[0], 300.0f * u[1], 600.0f * u[2]);
            const sq_vec3 target = sq_v3(-800.0f + 1800.0f * u[3], -300.0f + 1200.0f * u[4], 900.0f * u[5]);
            const sq_vec3 fwd = sq_v3_norm(sq_v3_sub(target, cam));
            const sq_mat4 vp = sq_m4_mul(sq_m4_perspective(0.9f, (float)W / (float)H, 1.0f, 8000.0f),
                                         sq_m4_look_at(cam, target, sq_v3(0.0f, 0.0f, 1.0f)));
            const sq_vec3 s = sq_v3_norm(sq_v3(u[6] - 0.5f, u[7] - 0.5f, -0.4f));
            for (int plane = 0; plane < 40; plane++) {
                const float d = -1800.0f + 3600.0f * (float)plane / 40.0f;
                int rect[4];
                const bool any = sq__volume_slice_rect(&dust, mirror, glo, ghi, s, d, &vp, cam, fwd,
                                                       1.0f, W, H, rect);
                planes++;
                if (!any) culled_planes++;
                area += (double)rect[2] * rect[3] / (W * H);
                for (int t = 0; t < 300; t++) {
                    float r3[3];
                    for (int a = 0; a < 3; a++) {
                        rs = rs * 1664525u + 1013904223u;
                        r3[a] = (float)(rs >> 8) / 16777216.0f;
                    }
                    sq_vec3 p = sq_v3(glo.x + (ghi.x - glo.x) * r3[0], glo.y + (ghi.y - glo.y) * r3[1],
                                      glo.z + (ghi.z - glo.z) * r3[2]);
                    p = sq_v3_sub(p, sq_v3_scale(s, sq_v3_dot(s, p) - d)); /* onto the plane */
                    if (p.x < glo.x || p.y < glo.y || p.z < glo.z || p.x > ghi.x || p.y > ghi.y ||
                        p.z > ghi.z)
                        continue;
                    if (sq_v3_dot(fwd, sq_v3_sub(p, cam)) < 1.0f) continue; /* behind the near plane */
                    const sq_vec4 c = sq_m4_mul_v4(vp, (sq_vec4){p.x, p.y, p.z, 1.0f});
                    const float wx = (c.x / c.w * 0.5f + 0.5f) * (float)W;
                    const float wy = (c.y / c.w * 0.5f + 0.5f) * (float)H;
                    if (wx < 0.0f || wy < 0.0f || wx >= (float)W || wy >= (float)H) continue;
                    if (!lookup_reaches_dust(den, n, origin, size, mirror, p)) continue;
                    checked++;
                    const int px = (int)wx, py = (int)wy;
                    const bool inside = any && px >= rect[0] && px < rect[0] + rect[2] &&
                                        py >= rect[1] && py < rect[1] + rect[3];
                    SQ_CHECK(inside);
                }
            }
        }
    }
    SQ_CHECK(checked > 2000);                 /* the check saw many dusty points */
    SQ_CHECK(culled_planes > planes / 10);    /* whole planes are culled */
    SQ_CHECK(area / planes < 0.6);            /* and the rest cover less than the window */
    free(den);
}
