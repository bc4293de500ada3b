/* test_meshes.c — world meshes in the GL renderer (llvmpipe): sun shadows of a box on flat ground
 * (the ground under the box's shadow gets only the sky's light, the ground beside it the full
 * Lambert sun term, the shadow's edge where the geometry puts it), instances drawn where their
 * placement puts them (yaw and scale), LOD choice by screen size, and the tint of materials. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/render_internal.h"
#include "render/snow_map.h"
#include "sq_test.h"
#include "squall/mesh.h"
#include "squall/render.h"
#include "squall/world.h"

SQ_LABEL(render)

static inline sq_world_light light_of(const sq_world *w)
{
    sq_world_light l;
    sq_world_get_light(w, &l);
    return l;
}
SQ_REQUIRES(gl)

#define W 320
#define H 180

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) exit(1);
    return ctx;
}

/* Flat 400 m square world at z = 0 with the sun toward sun_dir and clean air. */
static sq_world *flat_world(sq_context *ctx, sq_vec3 sun_dir)
{
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.terrain.size_m[0] = d.terrain.size_m[1] = 400.0f;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 33;
    d.terrain.material = SQ_GROUND_ROCK;
    d.sun.direction = sun_dir;
    d.sky.turbidity = 2.0f;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &d, &w) != SQ_OK) {
        fprintf(stderr, "world: %s\n", sq_last_error());
        exit(1);
    }
    return w;
}

/* An axis-aligned closed box lo..hi (12 triangles), one material of the given colour. */
static sq_mesh *box_mesh(sq_context *ctx, sq_vec3 lo, sq_vec3 hi, sq_vec3 color, sq_mesh_tint tint)
{
    float p[24];
    for (int k = 0; k < 8; k++) {
        p[3 * k] = (k & 1) ? hi.x : lo.x;
        p[3 * k + 1] = (k & 2) ? hi.y : lo.y;
        p[3 * k + 2] = (k & 4) ? hi.z : lo.z;
    }
    static const uint32_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                     2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    sq_mesh_material m;
    memset(&m, 0, sizeof m);
    m.base_color = color;
    m.tint = tint;
    sq_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.name = "box";
    d.vertex_count = 8;
    d.positions = p;
    d.index_count = 36;
    d.indices = idx;
    d.material_count = 1;
    d.materials = &m;
    sq_mesh *out = NULL;
    if (sq_mesh_create(ctx, &d, &out) != SQ_OK) {
        fprintf(stderr, "mesh: %s\n", sq_last_error());
        exit(1);
    }
    return out;
}

static sq_renderer *make_renderer(sq_context *ctx)
{
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.width = W;
    d.height = H;
    sq_renderer *r = NULL;
    if (sq_renderer_create(ctx, &d, &r) != SQ_OK) {
        fprintf(stderr, "renderer: %s\n", sq_last_error());
        exit(1);
    }
    return r;
}

/* Pixel (column, row from the top) where world point p lands for camera c. */
static void project(const sq_camera *c, sq_vec3 p, int *px, int *py)
{
    const sq_mat4 vp = sq_m4_mul(sq_camera_proj(c, (float)W / (float)H), sq_camera_view(c));
    const sq_vec4 q = sq_m4_mul_v4(vp, (sq_vec4){p.x, p.y, p.z, 1.0f});
    *px = (int)floorf((q.x / q.w * 0.5f + 0.5f) * (float)W);
    *py = H - 1 - (int)floorf((q.y / q.w * 0.5f + 0.5f) * (float)H);
}

/* Mean linear luminance over a 3x3 pixel block around world point p. */
static double radiance_at(const float *rgb, const sq_camera *c, sq_vec3 p)
{
    int x, y;
    project(c, p, &x, &y);
    double s = 0.0;
    for (int j = -1; j <= 1; j++)
        for (int i = -1; i <= 1; i++) {
            const int xx = sq_clampi(x + i, 0, W - 1), yy = sq_clampi(y + j, 0, H - 1);
            const float *v = &rgb[3 * ((size_t)yy * W + (size_t)xx)];
            s += 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
        }
    return s / 9.0;
}

static float *render_linear(sq_renderer *r, const sq_world *w, const sq_camera *c)
{
    float *rgb = malloc((size_t)W * H * 3 * sizeof(float));
    if (sq_renderer_draw(r, w, c, NULL, 0, 0.0) != SQ_OK || sq_renderer_read_linear(r, rgb) != SQ_OK) {
        fprintf(stderr, "draw: %s\n", sq_last_error());
        exit(1);
    }
    return rgb;
}

/* A 10 m cube at the origin under a sun 72 degrees high in the east (+x): its shadow on the
 * ground reaches from x = -5 to x = -5 - 10 / tan(72 deg) = -8.25 m across y in [-5, 5]. */
SQ_TEST(box_shadows_the_ground_under_a_high_sun)
{
    sq_context *ctx = make_ctx();
    const float el = 72.0f * SQ_PI_F / 180.0f;
    sq_world *w = flat_world(ctx, sq_v3(cosf(el), 0.0f, sinf(el)));
    sq_renderer *r = make_renderer(ctx);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(-6.6f, -40.0f, 30.0f);
    cam.target_m = sq_v3(-6.6f, 0.0f, 0.0f);
    cam.fov_y_deg = 40.0f;
    float *bare = render_linear(r, w, &cam);
    sq_mesh *box = box_mesh(ctx, sq_v3(-5, -5, 0), sq_v3(5, 5, 10), sq_v3(0.5f, 0.5f, 0.5f), SQ_TINT_NONE);
    sq_mesh_instance in;
    memset(&in, 0, sizeof in);
    in.mesh = 0;
    in.position_m = sq_v3(0, 0, NAN);
    const sq_mesh *list[1] = {box};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_OK);
    float *shad = render_linear(r, w, &cam);
    const sq_vec3 in_shadow = sq_v3(-6.6f, -2.0f, 0.0f), beside = sq_v3(-11.0f, -2.0f, 0.0f);
    const sq_vec3 edge_in = sq_v3(-7.6f, 0.0f, 0.0f), edge_out = sq_v3(-9.2f, 0.0f, 0.0f);
    const double lit0 = radiance_at(bare, &cam, in_shadow);
    const double dark = radiance_at(shad, &cam, in_shadow);
    const double lit = radiance_at(shad, &cam, beside), lit_ref = radiance_at(bare, &cam, beside);
    /* ground model: albedo (E cos + ambient); in the shadow only albedo * ambient remains */
    const sq_vec3 s = light_of(w).sun_dir;
    const double sun_part = (double)(light_of(w).sun_radiance.y * s.z);
    const double amb = 0.5 * (double)(light_of(w).sky_zenith.y + light_of(w).sky_horizon.y); /* order of magnitude */
    printf("lit %.4f (no mesh %.4f), shadow %.4f, unshadowed there %.4f, sun term %.3f, sky ~%.3f\n",
           lit, lit_ref, dark, lit0, sun_part, amb);
    SQ_CHECK_MSG(fabs(lit - lit_ref) < 0.02 * lit_ref, "beside the shadow %.4f vs %.4f without the box",
                 lit, lit_ref);
    /* the sun term is most of the light on a sunlit plane: the shadow keeps less than half */
    SQ_CHECK_MSG(dark < 0.5 * lit0, "under the box's shadow %.4f; lit there %.4f", dark, lit0);
    /* the edge where the cube's top edge projects (each point against itself without the box:
     * the ground's albedo has a noise detail) */
    const double e_in = radiance_at(shad, &cam, edge_in), e_in0 = radiance_at(bare, &cam, edge_in);
    const double e_out = radiance_at(shad, &cam, edge_out), e_out0 = radiance_at(bare, &cam, edge_out);
    SQ_CHECK_MSG(e_in < 0.5 * e_in0, "0.65 m inside the shadow edge: %.4f (lit %.4f)", e_in, e_in0);
    SQ_CHECK_MSG(fabs(e_out - e_out0) < 0.02 * e_out0, "0.95 m outside the shadow edge: %.4f (lit %.4f)",
                 e_out, e_out0);
    free(bare);
    free(shad);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, box);
    sq_context_destroy(ctx);
}

/* The avalanche's snow as a surface drawable (a heightfield over flat ground) casts its shadow:
 * a strip of snow 2 m deep across x in [-4, 4] (0.5 m cells, y in [-10, 10]) under a sun 30
 * degrees high in the east darkens the ground west of it from x = -4 to -4 - 2 / tan 30 deg =
 * -7.46 m; the ground farther west and the ground north of the strip's end keep the sun. Made
 * 1 m deep (a new version of the drawable) the shadow ends at -5.73 m: the kept cascade is drawn
 * again, the point at x = -6 is lit again. */
SQ_TEST(avalanche_surface_casts_its_shadow)
{
    sq_context *ctx = make_ctx();
    const float el = 30.0f * SQ_PI_F / 180.0f;
    sq_world *w = flat_world(ctx, sq_v3(cosf(el), 0.0f, sinf(el)));
    sq_renderer *r = make_renderer(ctx);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(-6.0f, -40.0f, 30.0f);
    cam.target_m = sq_v3(-6.0f, 0.0f, 0.0f);
    cam.fov_y_deg = 40.0f;
    enum { N = 41 };
    float height[N * N], cover[N * N];
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) {
            const float x = -10.0f + 0.5f * (float)i;
            const bool in = fabsf(x) <= 4.0f;
            height[j * N + i] = in ? 2.0f : 0.0f;
            cover[j * N + i] = in ? 1.0f : 0.0f;
        }
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_SURFACE;
    d.name = "avalanche";
    d.u.surface.nx = d.u.surface.ny = N;
    d.u.surface.origin_m = sq_v3(-10.0f, -10.0f, 0.0f);
    d.u.surface.dx_m = d.u.surface.dy_m = 0.5f;
    d.u.surface.height_m = height;
    d.u.surface.coverage = cover;
    d.u.surface.material = SQ_MATERIAL_SNOW_DEBRIS;
    d.u.surface.version = 1;
    float *bare = render_linear(r, w, &cam);
    float *flow = malloc((size_t)W * H * 3 * sizeof(float));
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_linear(r, flow) == SQ_OK);
    const sq_vec3 behind = sq_v3(-6.0f, 0.0f, 0.0f), beyond = sq_v3(-9.5f, 0.0f, 0.0f);
    const sq_vec3 beside = sq_v3(-6.0f, 14.0f, 0.0f);
    const double lit_behind = radiance_at(bare, &cam, behind), dark = radiance_at(flow, &cam, behind);
    const double lit_beyond = radiance_at(bare, &cam, beyond), far = radiance_at(flow, &cam, beyond);
    const double lit_beside = radiance_at(bare, &cam, beside), side = radiance_at(flow, &cam, beside);
    printf("2 m deep: 2 m behind the flow %.4f (no flow %.4f); 5.5 m behind %.4f (%.4f); beside %.4f (%.4f)\n",
           dark, lit_behind, far, lit_beyond, side, lit_beside);
    SQ_CHECK_MSG(dark < 0.5 * lit_behind, "2 m behind the 2 m deep flow: %.4f, lit %.4f", dark, lit_behind);
    SQ_CHECK_MSG(fabs(far - lit_beyond) < 0.02 * lit_beyond, "beyond its shadow: %.4f vs %.4f", far, lit_beyond);
    SQ_CHECK_MSG(fabs(side - lit_beside) < 0.02 * lit_beside, "beside the flow: %.4f vs %.4f", side, lit_beside);
    /* the same drawable again: the cascades are kept */
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK);
    sq_render_stats st;
    SQ_CHECK(sq_renderer_stats(r, &st) == SQ_OK);
    SQ_CHECK_MSG(st.shadow_cascades_drawn == 0, "%d cascades drawn for an unchanged flow", st.shadow_cascades_drawn);
    /* the flow thins to 1 m: its shadow ends 1.73 m behind it */
    for (int c = 0; c < N * N; c++) height[c] = cover[c] > 0.0f ? 1.0f : 0.0f;
    d.u.surface.version = 2;
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_linear(r, flow) == SQ_OK);
    SQ_CHECK(sq_renderer_stats(r, &st) == SQ_OK);
    const double thin = radiance_at(flow, &cam, behind);
    printf("1 m deep: %d cascades drawn again; 2 m behind %.4f (no flow %.4f)\n", st.shadow_cascades_drawn,
           thin, lit_behind);
    SQ_CHECK(st.shadow_cascades_drawn >= 1);
    SQ_CHECK_MSG(fabs(thin - lit_behind) < 0.02 * lit_behind, "2 m behind the 1 m flow: %.4f, lit %.4f", thin,
                 lit_behind);
    free(bare);
    free(flow);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* Flat 400 m world with the sun placed by date and hour (sq_world_set_sky can move it). */
static sq_world *dated_world(sq_context *ctx, float hour)
{
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.terrain.size_m[0] = d.terrain.size_m[1] = 400.0f;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 33;
    d.terrain.material = SQ_GROUND_ROCK;
    d.sun.day_of_year = 20;
    d.sun.hour_solar = hour;
    d.sun.hour_set = true;
    d.sun.latitude_deg = 45.0f;
    d.sky.turbidity = 2.0f;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &d, &w) != SQ_OK) {
        fprintf(stderr, "world: %s\n", sq_last_error());
        exit(1);
    }
    return w;
}

/* 5 x 5 boxes (6 m tall, 12 m apart), shifted by dx: shadows in every cascade. */
static void place_boxes(sq_context *ctx, sq_world *w, const sq_mesh *box, float dx)
{
    sq_mesh_instance in[25];
    memset(in, 0, sizeof in);
    for (int k = 0; k < 25; k++) {
        in[k].position_m = sq_v3(dx + 12.0f * (float)(k % 5 - 2), 40.0f + 12.0f * (float)(k / 5), NAN);
        in[k].scale = sq_v3(1, 1, 1);
    }
    const sq_mesh *list[1] = {box};
    if (sq_world_set_meshes(ctx, w, list, 1, in, 25) != SQ_OK) {
        fprintf(stderr, "meshes: %s\n", sq_last_error());
        exit(1);
    }
}

static sq_renderer *cascade_renderer_opt(sq_context *ctx, bool shadows)
{
    sq_render_desc d;
    memset(&d, 0, sizeof d);
    d.shadows_off = !shadows;
    d.width = W;
    d.height = H;
    d.shadow_cascades = 2;
    d.shadow_map_size = 512;
    d.shadow_distance_m = 150.0f;
    sq_renderer *r = NULL;
    if (sq_renderer_create(ctx, &d, &r) != SQ_OK) {
        fprintf(stderr, "renderer: %s\n", sq_last_error());
        exit(1);
    }
    return r;
}

static sq_renderer *cascade_renderer(sq_context *ctx) { return cascade_renderer_opt(ctx, true); }

/* Pixels of renderer r's last frame that differ from the frame of camera c without shadows. */
static size_t pixels_shadowed(sq_context *ctx, sq_renderer *r, const sq_world *w, const sq_camera *c)
{
    uint8_t *a = malloc((size_t)W * H * 4), *b = malloc((size_t)W * H * 4);
    sq_renderer *plain = cascade_renderer_opt(ctx, false);
    SQ_CHECK(sq_renderer_read_rgba8(r, a) == SQ_OK);
    SQ_CHECK(sq_renderer_draw(plain, w, c, NULL, 0, 0.0) == SQ_OK && sq_renderer_read_rgba8(plain, b) == SQ_OK);
    size_t n = 0;
    for (size_t i = 0; i < (size_t)W * H; i++)
        n += abs(a[4 * i] - b[4 * i]) + abs(a[4 * i + 1] - b[4 * i + 1]) + abs(a[4 * i + 2] - b[4 * i + 2]) > 12;
    sq_renderer_destroy(plain);
    free(a);
    free(b);
    return n;
}

/* The frame of renderer r (which may keep cascades from its earlier frames) and the frame of a
 * fresh renderer for the same world and camera: the same bytes. Returns the cascades r drew. */
static int frame_equals_fresh(sq_context *ctx, sq_renderer *r, const sq_world *w, const sq_camera *c,
                              const char *what)
{
    uint8_t *a = malloc((size_t)W * H * 4), *b = malloc((size_t)W * H * 4);
    sq_renderer *fresh = cascade_renderer(ctx);
    SQ_CHECK(sq_renderer_draw(r, w, c, NULL, 0, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, a) == SQ_OK);
    sq_render_stats st;
    SQ_CHECK(sq_renderer_stats(r, &st) == SQ_OK);
    SQ_CHECK(sq_renderer_draw(fresh, w, c, NULL, 0, 0.0) == SQ_OK &&
             sq_renderer_read_rgba8(fresh, b) == SQ_OK);
    size_t differ = 0;
    for (size_t i = 0; i < (size_t)W * H * 4; i++) differ += a[i] != b[i];
    printf("%s: %d cascades drawn, %zu bytes differ from a fresh renderer's frame\n", what,
           st.shadow_cascades_drawn, differ);
    SQ_CHECK_MSG(differ == 0, "%s: %zu bytes differ from a fresh renderer's frame", what, differ);
    sq_renderer_destroy(fresh);
    free(a);
    free(b);
    return st.shadow_cascades_drawn;
}

/* Shadow cascades kept between frames (render_shadow.c): while the camera moves within the
 * cascades' cells under a static sun over static geometry no cascade is drawn again, and every
 * frame — kept, or after the sun moved, the boxes moved or the camera left the cells — is the
 * frame a fresh renderer draws, byte for byte (a stale map would leave the old shadows). */
SQ_TEST(kept_cascades_equal_fresh_ones)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 13.5f);
    sq_mesh *box = box_mesh(ctx, sq_v3(-2, -2, 0), sq_v3(2, 2, 6), sq_v3(0.5f, 0.5f, 0.5f), SQ_TINT_NONE);
    place_boxes(ctx, w, box, 0.0f);
    sq_renderer *r = cascade_renderer(ctx);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(3.0f, -20.0f, 12.0f);
    cam.target_m = sq_v3(0.0f, 60.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    SQ_CHECK(frame_equals_fresh(ctx, r, w, &cam, "first frame") == 2);
    /* the boxes cast shadows that a stale map would put elsewhere */
    const size_t shadowed = pixels_shadowed(ctx, r, w, &cam);
    SQ_CHECK_MSG(shadowed > (size_t)W * H / 100, "only %zu pixels in the boxes' shadows", shadowed);
    /* a step of 10 cm: inside the cells */
    cam.position_m.x += 0.1f;
    cam.target_m.x += 0.1f;
    SQ_CHECK(frame_equals_fresh(ctx, r, w, &cam, "camera 10 cm on") == 0);
    /* the sun an hour later */
    sq_world_set_sky(w, 20, 14.5f, 45.0f, 1.0, 2.0f, 1000.0f);
    SQ_CHECK(frame_equals_fresh(ctx, r, w, &cam, "sun an hour later") == 2);
    /* the boxes 3 m east (a new world generation) */
    place_boxes(ctx, w, box, 3.0f);
    SQ_CHECK(frame_equals_fresh(ctx, r, w, &cam, "boxes moved") == 2);
    /* the camera 60 m on: out of the near cascade's cell at least */
    cam.position_m.y += 60.0f;
    cam.target_m.y += 60.0f;
    SQ_CHECK(frame_equals_fresh(ctx, r, w, &cam, "camera 60 m on") >= 1);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, box);
    sq_context_destroy(ctx);
}

/* The terrain drawn by tiles (renderer.c: 32 x 32 cells each, culled per view): a camera over
 * hills that sees part of the terrain draws fewer than all its triangles, in its own view and in
 * the shadow cascades, and its frame is byte for byte the frame drawn with every tile (boxes made
 * infinite, the cascades drawn again after the sun moved): no tile a view needs is culled and the
 * multi-draw's runs address the right triangles. */
SQ_TEST(terrain_tiles_culled_without_changing_the_frame)
{
    sq_context *ctx = make_ctx();
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_HILLS;
    d.terrain.size_m[0] = d.terrain.size_m[1] = 2000.0f;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 257;
    d.terrain.relief_m = 80.0f;
    d.terrain.feature_m = 500.0f;
    d.terrain.seed = 3;
    d.terrain.material = SQ_GROUND_ROCK;
    d.sun.day_of_year = 172;
    d.sun.hour_solar = 6.0f; /* low: the hills shadow themselves */
    d.sun.hour_set = true;
    d.sun.latitude_deg = 45.0f;
    sq_world *w = NULL;
    SQ_CHECK(sq_world_create(ctx, &d, &w) == SQ_OK);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(-300.0f, -500.0f, 160.0f);
    cam.target_m = sq_v3(100.0f, 200.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    uint8_t *a = malloc((size_t)W * H * 4), *b = malloc((size_t)W * H * 4);
    sq_renderer *all = cascade_renderer(ctx);
    SQ_CHECK(sq_renderer_draw(all, w, &cam, NULL, 0, 0.0) == SQ_OK); /* builds the tiles */
    const int64_t total = (int64_t)all->terrain_index_count / 3;
    SQ_CHECK_MSG(all->terrain_tile_count == 64, "%d tiles", all->terrain_tile_count);
    for (int i = 0; i < all->terrain_tile_count; i++)
        for (int e = 0; e < 3; e++) {
            all->terrain_tiles[i].lo[e] = -1e30f;
            all->terrain_tiles[i].hi[e] = 1e30f;
        }
    sq_world_set_sky(w, 172, 6.5f, 45.0f, 1.0, 3.0f, 1000.0f); /* the cascades drawn again */
    sq_render_stats st;
    SQ_CHECK(sq_renderer_draw(all, w, &cam, NULL, 0, 0.0) == SQ_OK && sq_renderer_read_rgba8(all, b) == SQ_OK);
    SQ_CHECK(sq_renderer_stats(all, &st) == SQ_OK);
    SQ_CHECK(st.shadow_cascades_drawn == 2 && st.camera_terrain_faces == total && st.terrain_faces == 3 * total);
    sq_renderer *r = cascade_renderer(ctx);
    SQ_CHECK(sq_renderer_draw(r, w, &cam, NULL, 0, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, a) == SQ_OK);
    SQ_CHECK(sq_renderer_stats(r, &st) == SQ_OK);
    printf("camera: %lld of %lld terrain triangles; camera and 2 cascades %lld of %lld\n",
           (long long)st.camera_terrain_faces, (long long)total, (long long)st.terrain_faces,
           (long long)(3 * total));
    SQ_CHECK(st.camera_terrain_faces > 0 && st.camera_terrain_faces < total * 3 / 4);
    SQ_CHECK(st.terrain_faces - st.camera_terrain_faces < total);
    size_t differ = 0;
    for (size_t i = 0; i < (size_t)W * H * 4; i++) differ += a[i] != b[i];
    SQ_CHECK_MSG(differ == 0, "%zu bytes differ from the frame with every tile", differ);
    free(a);
    free(b);
    sq_renderer_destroy(r);
    sq_renderer_destroy(all);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

/* A straight ridge along y at x = 0 (grid terrain, crest h above the plain, flanks of slope s),
 * the sun in the east (+x) at elevation el, clean air. */
static sq_world *ridge_world(sq_context *ctx, float h, float s, float el)
{
    enum { N = 81 };
    static float z[N * N];
    const float dx = 2.5f, x0 = -100.0f;
    for (int j = 0; j < N; j++)
        for (int i = 0; i < N; i++) z[j * N + i] = fmaxf(0.0f, h - s * fabsf(x0 + (float)i * dx));
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_GRID;
    d.terrain.material = SQ_GROUND_ROCK;
    d.terrain.grid_heights_m = z;
    d.terrain.grid_w = d.terrain.grid_h = N;
    d.terrain.grid_dx_m = d.terrain.grid_dy_m = dx;
    d.terrain.origin_m[0] = d.terrain.origin_m[1] = x0;
    d.terrain.origin_set = true;
    d.sun.direction = sq_v3(cosf(el), 0.0f, sinf(el));
    d.sky.turbidity = 2.0f;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &d, &w) != SQ_OK) {
        fprintf(stderr, "world: %s\n", sq_last_error());
        exit(1);
    }
    return w;
}

/* The terrain shadows itself where a flank is steeper than the sun is high: a 20 m ridge with
 * 45-degree flanks under a sun 30 degrees up throws its shadow to x = -20 / tan 30 = -34.6 m, so
 * the plain at x = -27 m is dark; under a sun 60 degrees up (steeper than the flanks) and for a
 * ridge of slope 0.5 under the 30-degree sun (tan 30 = 0.577) no point can be shaded, and the
 * renderer skips its shadow cascades there: the same picture as without shadows. */
SQ_TEST(terrain_shadows_itself_only_where_steeper_than_the_sun)
{
    sq_context *ctx = make_ctx();
    sq_renderer *r = make_renderer(ctx);
    sq_render_desc od;
    memset(&od, 0, sizeof od);
    od.width = W;
    od.height = H;
    od.shadows_off = true;
    sq_renderer *off = NULL;
    SQ_CHECK(sq_renderer_create(ctx, &od, &off) == SQ_OK);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(-27.0f, -70.0f, 45.0f);
    cam.target_m = sq_v3(-27.0f, 0.0f, 0.0f);
    cam.fov_y_deg = 40.0f;
    const sq_vec3 plain = sq_v3(-27.0f, 0.0f, 0.0f), foot = sq_v3(-21.0f, 0.0f, 0.0f);
    const float deg = SQ_PI_F / 180.0f;
    struct { float h, s, el; bool shaded; } cases[3] = {
        {20.0f, 1.0f, 30.0f, true}, {20.0f, 1.0f, 60.0f, false}, {10.0f, 0.5f, 30.0f, false}};
    for (int c = 0; c < 3; c++) {
        sq_world *w = ridge_world(ctx, cases[c].h, cases[c].s, cases[c].el * deg);
        float *on = render_linear(r, w, &cam), *ref = render_linear(off, w, &cam);
        const double a = radiance_at(on, &cam, plain), a0 = radiance_at(ref, &cam, plain);
        const double b = radiance_at(on, &cam, foot), b0 = radiance_at(ref, &cam, foot);
        printf("slope %.1f sun %.0f deg: plain %.4f (no shadows %.4f), foot %.4f (%.4f)\n",
               (double)cases[c].s, (double)cases[c].el, a, a0, b, b0);
        if (cases[c].shaded) {
            SQ_CHECK_MSG(a < 0.6 * a0, "plain behind the ridge %.4f, unshadowed %.4f", a, a0);
            SQ_CHECK_MSG(b < 0.6 * b0, "foot of the lee flank %.4f, unshadowed %.4f", b, b0);
        } else {
            SQ_CHECK_MSG(fabs(a - a0) <= 0.01 * a0, "plain %.4f vs %.4f without shadows", a, a0);
            SQ_CHECK_MSG(fabs(b - b0) <= 0.01 * b0, "foot %.4f vs %.4f without shadows", b, b0);
        }
        free(on);
        free(ref);
        sq_world_destroy(ctx, w);
    }
    sq_renderer_destroy(off);
    sq_renderer_destroy(r);
    sq_context_destroy(ctx);
}

/* Instances so far that even the deepest snow's shell would move them by less than half a pixel
 * are drawn by a program without the shell (render_meshes.c): over a field of snow-covered boxes
 * 60 m to 340 m away (30 cm of snow, the split at 2 x 0.3 m x 193 px/m = 116 m here), the frame
 * differs from the frame with the shell on every instance in at most 1/300 of its pixels (edges
 * moved by under half a pixel; 129 here) —
 * the far program still lays the snow on the far roofs (without snow there: 410 pixels). */
SQ_TEST(far_instances_without_the_shell_look_the_same)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_mesh *box = box_mesh(ctx, sq_v3(-3, -3, 0), sq_v3(3, 3, 4), sq_v3(0.3f, 0.1f, 0.08f), SQ_TINT_NONE);
    sq_mesh_instance in[40];
    memset(in, 0, sizeof in);
    for (int k = 0; k < 40; k++) {
        in[k].position_m = sq_v3(-30.0f + 20.0f * (float)(k % 4), -150.0f + 7.5f * (float)k, NAN);
        in[k].scale = sq_v3(1, 1, 1);
    }
    const sq_mesh *list[1] = {box};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, in, 40) == SQ_OK);
    enum { N = 16 };
    float depth[N * N];
    for (int i = 0; i < N * N; i++) depth[i] = 0.3f;
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_SNOW_COVER;
    d.name = "snow";
    sq_snow_cover_view *v = &d.u.snow_cover;
    v->nx = v->ny = N;
    v->origin_m = sq_v3(-200.0f, -200.0f, 0.0f);
    v->dx_m = v->dy_m = 400.0f / N;
    v->depth_m = depth;
    v->detail_distance_m = 250.0f;
    v->map_size = 512;
    v->taps = 4;
    v->tap_radius_texels = 1.0f;
    v->depth_bias_m = 0.05f;
    v->noise_amplitude = 0.3f;
    v->noise_scale_m = 2.0f;
    v->shell_blend = 0.5f;
    v->brdf = SQ_SNOW_BRDF_PHYSICAL;
    v->albedo = sq_v3(0.9f, 0.9f, 0.9f);
    v->sparkle = 0.5f;
    v->shininess = 24.0f;
    v->version = 1;
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -190.0f, 60.0f); /* the far roofs seen from above */
    cam.target_m = sq_v3(0.0f, 60.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    uint8_t *a = malloc((size_t)W * H * 4), *b = malloc((size_t)W * H * 4);
    sq_renderer *split = cascade_renderer(ctx), *all = cascade_renderer(ctx);
    all->shell_everywhere = true;
    SQ_CHECK(sq_renderer_draw(split, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(split, a) == SQ_OK);
    SQ_CHECK(sq_renderer_draw(all, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(all, b) == SQ_OK);
    size_t differ = 0, bytes = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        const int e = abs(a[4 * i] - b[4 * i]) + abs(a[4 * i + 1] - b[4 * i + 1]) + abs(a[4 * i + 2] - b[4 * i + 2]);
        differ += e > 24;
        bytes += e > 0;
    }
    printf("pixels differing by more than 8 levels a channel: %zu (any difference: %zu) of %d\n", differ,
           bytes, W * H);
    SQ_CHECK_MSG(differ <= (size_t)W * H / 300, "%zu pixels differ by more than 8 levels a channel", differ);
    SQ_CHECK_MSG(bytes > 0, "no pixel differs: the far instances were drawn with the shell too");
    free(a);
    free(b);
    sq_renderer_destroy(split);
    sq_renderer_destroy(all);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, box);
    sq_context_destroy(ctx);
}

/* ---- the snow occlusion map over a generated place -------------------------------------------- */

/* A snow-cover drawable of uniform depth over the 400 m flat world (map_size texels). */
static sq_drawable snow_view(float *depth, int n, int map_size)
{
    for (int i = 0; i < n * n; i++) depth[i] = 0.3f;
    sq_drawable d;
    memset(&d, 0, sizeof d);
    d.kind = SQ_DRAWABLE_SNOW_COVER;
    d.name = "snow";
    sq_snow_cover_view *v = &d.u.snow_cover;
    v->nx = v->ny = n;
    v->origin_m = sq_v3(-200.0f, -200.0f, 0.0f);
    v->dx_m = v->dy_m = 400.0f / (float)n;
    v->depth_m = depth;
    v->detail_distance_m = 120.0f;
    v->map_size = map_size;
    v->taps = 4;
    v->tap_radius_texels = 1.0f;
    v->depth_bias_m = 0.05f;
    v->noise_amplitude = 0.3f;
    v->noise_scale_m = 2.0f;
    v->shell_blend = 0.5f;
    v->brdf = SQ_SNOW_BRDF_PHYSICAL;
    v->albedo = sq_v3(0.9f, 0.9f, 0.9f);
    v->sparkle = 0.5f;
    v->shininess = 24.0f;
    v->version = 1;
    return d;
}

/* A 300 m procedural suburb (houses with eaves, trees, cars, fences) on the flat world. */
static sq_place *suburb_on(sq_context *ctx, sq_world *w)
{
    sq_place_desc pd;
    memset(&pd, 0, sizeof pd);
    pd.kind = SQ_PLACE_SUBURB;
    pd.size_m[0] = pd.size_m[1] = 300.0f;
    pd.seed = 7;
    sq_place *p = NULL;
    if (sq_place_generate(ctx, &pd, &p) != SQ_OK ||
        sq_world_set_meshes(ctx, w, (const sq_mesh *const *)p->meshes, p->mesh_count, p->instances,
                            p->instance_count) != SQ_OK) {
        fprintf(stderr, "place: %s\n", sq_last_error());
        exit(1);
    }
    printf("place: %d houses, %d trees, %d cars, %d instances\n", p->houses, p->trees, p->cars,
           p->instance_count);
    return p;
}

/* The texels of map g drawn for its world (sq__snow_pass_map's need box), shrunk by `in`. */
static sq__texel_rect drawn_texels(const sq__snow_map_geom *g, int in)
{
    sq__texel_rect t;
    for (int a = 0; a < 2; a++) {
        t.lo[a] = (int)lround((g->need_lo[a] - g->origin[a]) / g->texel_m) + in;
        t.hi[a] = (int)lround((g->need_hi[a] - g->origin[a]) / g->texel_m) - in;
    }
    return t;
}

/* The camera draws an instance with a coarser level than the occlusion map (finer levels there);
 * the coarse level may lie up to its error below the map's surface, and the snow exposure allows
 * for that error (render_meshes.c passes the drawn level's error to meshes.vert). A box 6 x 6 x
 * 4 m whose second level is 0.2 m lower (error 0.2 m), drawn with lod_pixels 2 from 25 m (0.13 m
 * a pixel: that level is 1.5 px of error), under a map of its finest level: its top is snow-
 * covered. With an allowance of one pixel (0.13 m + the 5 cm bias < 0.2 m) the coarse top was
 * taken to lie under the finer one: bare. Without snow the same pixels have the box's colour. */
SQ_TEST(coarse_level_allowance_is_its_error)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_mesh *box = box_mesh(ctx, sq_v3(-3, -3, 0), sq_v3(3, 3, 4), sq_v3(0.3f, 0.1f, 0.08f), SQ_TINT_NONE);
    {
        float p[24];
        for (int k = 0; k < 8; k++) {
            p[3 * k] = (k & 1) ? 3.0f : -3.0f;
            p[3 * k + 1] = (k & 2) ? 3.0f : -3.0f;
            p[3 * k + 2] = (k & 4) ? 3.8f : 0.0f;
        }
        static const uint32_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                         2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
        sq_mesh_desc d;
        memset(&d, 0, sizeof d);
        d.name = "box lod 1";
        d.vertex_count = 8;
        d.positions = p;
        d.index_count = 36;
        d.indices = idx;
        SQ_CHECK(sq_mesh_add_lod(ctx, box, &d, 0.2f) == SQ_OK);
    }
    sq_mesh_instance in;
    memset(&in, 0, sizeof in);
    in.position_m = sq_v3(0.0f, 0.0f, NAN);
    in.scale = sq_v3(1, 1, 1);
    const sq_mesh *list[1] = {box};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_OK);
    enum { N = 16 };
    float depth[N * N];
    sq_drawable d = snow_view(depth, N, 512);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -12.0f, 26.0f);
    cam.target_m = sq_v3(0.0f, 0.0f, 4.0f);
    cam.fov_y_deg = 50.0f;
    sq_render_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.width = W;
    rd.height = H;
    rd.shadows_off = true;
    rd.lod_pixels = 2.0f;
    sq_renderer *r = NULL;
    SQ_CHECK(sq_renderer_create(ctx, &rd, &r) == SQ_OK);
    r->map_lod_pixels = 1e-3f; /* the map draws the finest level */
    uint8_t *snowy = malloc((size_t)W * H * 4), *bare = malloc((size_t)W * H * 4);
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, snowy) == SQ_OK);
    for (int i = 0; i < N * N; i++) depth[i] = 0.0f;
    d.u.snow_cover.version = 2;
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, bare) == SQ_OK);
    /* a 15 x 15 block at the image centre: the box's top (about 46 x 40 px) */
    int white = 0, red = 0, n = 0;
    for (int y = H / 2 - 7; y <= H / 2 + 7; y++)
        for (int x = W / 2 - 7; x <= W / 2 + 7; x++) {
            const uint8_t *s = &snowy[4 * ((size_t)y * W + x)], *b = &bare[4 * ((size_t)y * W + x)];
            white += s[0] > 150 && s[1] > 150 && s[2] > 150;
            red += b[0] > b[2] + 20;
            n++;
        }
    printf("box top: %d of %d pixels snow-white, %d of them the box's red without snow\n", white, n, red);
    SQ_CHECK_MSG(red == n, "%d of %d pixels of the bare box's top are its colour", red, n);
    SQ_CHECK_MSG(white >= n * 9 / 10, "%d of %d pixels of the coarse level's top are snow", white, n);
    free(snowy);
    free(bare);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, box);
    sq_context_destroy(ctx);
}

/* The snow layer's edge (meshes_shade.glsl): a box's top corners rise straight up by the depth
 * (the top of a wall), which stretches its walls; the part of a wall above its former top edge is
 * the side of the snow on the box, shaded as snow, not as the wall. A red box 4 m tall in front
 * of a blue wall, seen level with its top edge from 17 m under 30 cm of snow: above its former
 * top, where the frame without snow shows the blue wall behind, the snowy frame shows snow
 * (about 3 px a column), not the red wall stretched. */
SQ_TEST(snow_edge_over_a_raised_wall_top)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_mesh *box = box_mesh(ctx, sq_v3(-3, -3, 0), sq_v3(3, 3, 4), sq_v3(0.3f, 0.02f, 0.02f), SQ_TINT_NONE);
    sq_mesh *back = box_mesh(ctx, sq_v3(-15, 10, 0), sq_v3(15, 12, 14), sq_v3(0.02f, 0.03f, 0.3f), SQ_TINT_NONE);
    sq_mesh_instance in[2];
    memset(in, 0, sizeof in);
    in[0].mesh = 0;
    in[1].mesh = 1;
    for (int k = 0; k < 2; k++) {
        in[k].position_m = sq_v3(0.0f, 0.0f, NAN);
        in[k].scale = sq_v3(1, 1, 1);
    }
    const sq_mesh *list[2] = {box, back};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 2, in, 2) == SQ_OK);
    enum { N = 16 };
    float depth[N * N];
    sq_drawable d = snow_view(depth, N, 512);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -20.0f, 4.15f);
    cam.target_m = sq_v3(0.0f, 0.0f, 4.15f);
    cam.fov_y_deg = 50.0f;
    sq_renderer *r = cascade_renderer_opt(ctx, false);
    uint8_t *snowy = malloc((size_t)W * H * 4), *bare = malloc((size_t)W * H * 4);
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, snowy) == SQ_OK);
    for (int i = 0; i < N * N; i++) depth[i] = 0.0f;
    d.u.snow_cover.version = 2;
    SQ_CHECK(sq_renderer_draw(r, w, &cam, &d, 1, 0.0) == SQ_OK && sq_renderer_read_rgba8(r, bare) == SQ_OK);
    int edge = 0, red = 0, box_rows = 0, columns = 0;
    for (int x = W / 2 - 20; x <= W / 2 + 20; x++, columns++)
        for (int y = 0; y < H; y++) {
            const uint8_t *s = &snowy[4 * ((size_t)y * W + x)], *b = &bare[4 * ((size_t)y * W + x)];
            if (b[0] > b[2] + 20) box_rows++; /* the red box without snow */
            if (b[2] > b[0] + 20) {           /* the blue wall behind, without snow */
                edge += s[0] > 150 && s[1] > 150 && s[2] > 150;
                red += s[0] > s[2] + 20;
            }
        }
    printf("%d columns: %d snow-edge pixels over the box's former top, %d red, box %d pixels\n", columns,
           edge, red, box_rows);
    SQ_CHECK(box_rows > columns * 20);
    SQ_CHECK_MSG(edge >= 2 * columns, "%d snow-edge pixels in %d columns", edge, columns);
    SQ_CHECK_MSG(red == 0, "%d pixels of the stretched red wall above its former top", red);
    free(snowy);
    free(bare);
    sq_renderer_destroy(r);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, box);
    sq_mesh_destroy(ctx, back);
    sq_context_destroy(ctx);
}

/* The GL occlusion map of renderer r's last frame as heights, and its placement. */
static float *gl_map(sq_renderer *r, sq__snow_map_geom *g)
{
    SQ_CHECK(sq__snow_pass_map(r, g, NULL));
    float *h = malloc((size_t)g->size * (size_t)g->size * sizeof(float));
    SQ_CHECK(h && sq__snow_pass_map(r, g, h));
    return h;
}

/* The occlusion map (render_snowcover.c) is the highest surface at each texel centre: drawn with
 * the finest levels over a generated suburb it equals the CPU map (sq__snow_map_fill: sq_world_surface_at on the meshes'
 * finest level) within the depth bias at all but 1 % of the texels on meshes (those whose centre
 * lies on an edge of a roof, a crown), and drawing the back faces of the closed meshes too (as
 * before they were culled) changes at most 0.1 % of them and none toward the CPU's top: a back
 * face is never the top (the few it changes are edge-on slivers). A map drawn with the wrong
 * faces culled (the bottoms) is off at every texel on a mesh. */
SQ_TEST(occlusion_map_is_the_top_surface)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_place *place = suburb_on(ctx, w);
    enum { N = 16, MAP = 512 };
    float depth[N * N];
    sq_drawable d = snow_view(depth, N, MAP);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -70.0f, 40.0f);
    cam.target_m = sq_v3(0.0f, 0.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    sq_renderer *culled = cascade_renderer(ctx), *both = cascade_renderer(ctx);
    both->depth_cull_off = true;
    /* the finest levels, not sunk (the levels' rule: the next test) */
    culled->map_lod_pixels = both->map_lod_pixels = 0.1f;
    culled->map_no_sink = both->map_no_sink = true;
    SQ_CHECK(sq_renderer_draw(culled, w, &cam, &d, 1, 0.0) == SQ_OK);
    SQ_CHECK(sq_renderer_draw(both, w, &cam, &d, 1, 0.0) == SQ_OK);
    sq__snow_map_geom g, g2;
    float *a = gl_map(culled, &g), *b = gl_map(both, &g2);
    SQ_CHECK(g.size == MAP && g2.texel_m == g.texel_m && g2.origin[0] == g.origin[0] &&
             g2.origin[1] == g.origin[1]);
    float *cpu = malloc((size_t)MAP * MAP * sizeof(float));
    sq__snow_map_fill(w, &g, cpu);
    size_t raised = 0, off = 0, culled_differ = 0, culled_worse = 0, on_meshes = 0;
    const sq__texel_rect t = drawn_texels(&g, 0);
    SQ_CHECK(t.hi[0] - t.lo[0] > MAP / 2 && t.hi[1] - t.lo[1] > MAP / 2);
    for (int j = t.lo[1]; j < t.hi[1]; j++)
        for (int ii = t.lo[0]; ii < t.hi[0]; ii++) {
        const size_t i = (size_t)j * MAP + (size_t)ii;
        on_meshes += cpu[i] > 0.2f;
        culled_differ += fabsf(a[i] - b[i]) > 1e-3f;
        culled_worse += fabsf(a[i] - cpu[i]) > fabsf(b[i] - cpu[i]) + 1e-3f;
        off += fabsf(a[i] - cpu[i]) > 0.05f;
        raised += a[i] > cpu[i] + 0.05f;
        }
    printf("map %d texels of %.3f m: %zu on meshes; GL vs CPU off by > 5 cm at %zu (%zu raised), "
           "back faces change %zu (%zu nearer the CPU's)\n",
           MAP, g.texel_m, on_meshes, off, raised, culled_differ, culled_worse);
    SQ_CHECK_MSG(on_meshes > (size_t)MAP * MAP / 20, "only %zu texels on meshes", on_meshes);
    SQ_CHECK_MSG(off <= on_meshes / 100, "%zu texels off the CPU map by more than 5 cm", off);
    SQ_CHECK_MSG(culled_differ <= on_meshes / 1000, "%zu texels changed by the back faces", culled_differ);
    SQ_CHECK_MSG(culled_worse == 0, "%zu texels nearer the CPU's top with the back faces", culled_worse);
    free(a);
    free(b);
    free(cpu);
    sq_renderer_destroy(culled);
    sq_renderer_destroy(both);
    sq_world_destroy(ctx, w);
    sq_place_destroy(ctx, place);
    sq_context_destroy(ctx);
}

typedef struct exposure_diff {
    size_t compared, self_occluded, leaked; /* leaked: occluded on the fine map, exposed here */
} exposure_diff;

/* Exposure (sq__snow_exposure: 4 taps at 1 texel, 5 cm bias) of points on the finest surface at
 * a quarter texel off every texel centre of g, on the GL map `map` against the CPU map `cpu`
 * (sq_world_surface_at: the meshes' finest level). Points are compared where the surface is a
 * plane around them (its slope from the CPU top at ±5 cm) and the CPU exposure is the same at
 * the point and at its 8 neighbours a texel away, and with a bias 1 cm smaller or larger: away
 * from the edges of roofs and crowns, where the exposure is a transition over a texel and the
 * tap radius in any case, and from occluders as high as the bias (5 cm kerbs). */
static exposure_diff compare_exposure(const sq_world *w, const sq__snow_map_geom *g,
                                      const float *map, const float *cpu)
{
    exposure_diff d = {0, 0, 0};
    const double t = g->texel_m;
    const float e = 0.05f;
    const sq__texel_rect drawn = drawn_texels(g, 4);
    for (int j = drawn.lo[1]; j < drawn.hi[1]; j++)
        for (int i = drawn.lo[0]; i < drawn.hi[0]; i++) {
            const float x = (float)(g->origin[0] + (i + 0.75) * t), y = (float)(g->origin[1] + (j + 0.75) * t);
            const float z = sq_world_surface_at(w, x, y);
            const float zx0 = sq_world_surface_at(w, x - e, y), zx1 = sq_world_surface_at(w, x + e, y);
            const float zy0 = sq_world_surface_at(w, x, y - e), zy1 = sq_world_surface_at(w, x, y + e);
            if (fabsf(zx0 + zx1 - 2.0f * z) > 1e-3f || fabsf(zy0 + zy1 - 2.0f * z) > 1e-3f) continue;
            const float gx = (zx1 - zx0) / (2.0f * e), gy = (zy1 - zy0) / (2.0f * e);
            const float nz = 1.0f / sqrtf(1.0f + gx * gx + gy * gy);
            const sq_vec3 p = sq_v3(x, y, z);
            const float fine = sq__snow_exposure(cpu, g, p, nz, 4, 1.0f, 0.05f);
            /* and not a tie: an occluder within a centimetre of the bias (a 5 cm kerb) */
            bool uniform = (fine == 0.0f || fine == 1.0f) &&
                           sq__snow_exposure(cpu, g, p, nz, 4, 1.0f, 0.04f) == fine &&
                           sq__snow_exposure(cpu, g, p, nz, 4, 1.0f, 0.06f) == fine;
            for (int q = 0; q < 9 && uniform; q++) {
                const sq_vec3 pq = sq_v3(x + (float)((q % 3 - 1) * t), y + (float)((q / 3 - 1) * t), z);
                uniform = sq__snow_exposure(cpu, g, pq, nz, 4, 1.0f, 0.05f) == fine;
            }
            if (!uniform) continue;
            const float got = sq__snow_exposure(map, g, p, nz, 4, 1.0f, 0.05f);
            d.compared++;
            d.self_occluded += fine == 1.0f && got < 0.75f;
            d.leaked += fine == 0.0f && got > 0.25f;
        }
    return d;
}

/* The occlusion map's levels of detail (render_snowcover.c): each instance drawn at the coarsest
 * level whose error is at most half a texel, sunk by that error over its faces' inclination
 * (shaders/depth_meshes.vert). Over a generated suburb, points on the finest surface (what the
 * camera draws near by; a coarser camera level is the shader's own term) get the exposure the
 * finest map gives (the CPU map): none of the exposed ones (roofs, bonnets, crowns, open ground)
 * self-occluded, at most 0.2 % of the occluded ones (ground under eaves and trees) exposed; the
 * map draws fewer triangles than at the finest levels, and the sinking only lowers it. (Levels
 * of up to a texel's error are not allowed: a fence's solid far level covers texel centres its
 * boards miss, and the ground along it is then occluded half a metre wide.) */
SQ_TEST(coarse_occlusion_map_levels_keep_the_exposure)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_place *place = suburb_on(ctx, w);
    enum { N = 16, MAP = 512 };
    float depth[N * N];
    sq_drawable d = snow_view(depth, N, MAP);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -70.0f, 40.0f);
    cam.target_m = sq_v3(0.0f, 0.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    /* the rule; the finest levels (errors within the 5 cm bias, as before); the rule's levels
     * not sunk */
    sq_renderer *rule = cascade_renderer(ctx), *fine = cascade_renderer(ctx), *unsunk = cascade_renderer(ctx);
    fine->map_lod_pixels = 0.1f;
    fine->map_no_sink = true;
    unsunk->map_no_sink = true;
    sq_renderer *rs[3] = {rule, fine, unsunk};
    const char *name[3] = {"rule", "finest", "not sunk"};
    float *map[3];
    int64_t faces[3];
    sq__snow_map_geom g;
    for (int k = 0; k < 3; k++) {
        SQ_CHECK(sq_renderer_draw(rs[k], w, &cam, &d, 1, 0.0) == SQ_OK);
        /* this frame's faces over all views: the same camera and cascades, only the map differs */
        sq_render_stats st;
        SQ_CHECK(sq_renderer_stats(rs[k], &st) == SQ_OK);
        faces[k] = st.faces;
        map[k] = gl_map(rs[k], &g);
    }
    float *cpu = malloc((size_t)MAP * MAP * sizeof(float));
    sq__snow_map_fill(w, &g, cpu);
    exposure_diff e[3];
    for (int k = 0; k < 3; k++) {
        e[k] = compare_exposure(w, &g, map[k], cpu);
        printf("%-8s: %lld faces drawn (all views); of %zu points %zu self-occluded, %zu leaked\n",
               name[k], (long long)faces[k], e[k].compared, e[k].self_occluded, e[k].leaked);
    }
    /* sinking only lowers the map, where a level coarser than the finest is drawn */
    size_t lower = 0, higher = 0;
    for (size_t i = 0; i < (size_t)MAP * MAP; i++) {
        lower += map[0][i] < map[2][i] - 1e-3f;
        higher += map[0][i] > map[2][i] + 1e-4f;
    }
    printf("sunk map: %zu texels lower than not sunk, %zu higher\n", lower, higher);
    SQ_CHECK_MSG(e[0].compared > (size_t)MAP * MAP / 4, "only %zu points compared", e[0].compared);
    SQ_CHECK_MSG(e[0].self_occluded == 0, "%zu exposed points self-occluded", e[0].self_occluded);
    SQ_CHECK_MSG(e[0].leaked * 500 <= e[0].compared, "%zu occluded points exposed", e[0].leaked);
    SQ_CHECK_MSG(faces[0] < faces[1], "the rule draws %lld faces, the finest levels %lld",
                 (long long)faces[0], (long long)faces[1]);
    SQ_CHECK_MSG(lower > 0 && higher == 0, "sunk map: %zu texels lower, %zu higher", lower, higher);
    for (int k = 0; k < 3; k++) {
        free(map[k]);
        sq_renderer_destroy(rs[k]);
    }
    free(cpu);
    sq_world_destroy(ctx, w);
    sq_place_destroy(ctx, place);
    sq_context_destroy(ctx);
}

/* The occlusion map kept as the camera moves (render_snowcover.c): the texels the view reads are
 * drawn, then only the bands it newly reads. After moves along and across the suburb, every
 * texel the new view reads equals the map a fresh renderer draws for it (the same world texels;
 * at most 0.1 % differ by more than a millimetre, where a texel centre lies on an edge), and the
 * moves drew bands, not the whole map. */
SQ_TEST(occlusion_map_bands_equal_a_fresh_map)
{
    sq_context *ctx = make_ctx();
    sq_world *w = dated_world(ctx, 12.0f);
    sq_place *place = suburb_on(ctx, w);
    enum { N = 16, MAP = 512 };
    float depth[N * N];
    sq_drawable d = snow_view(depth, N, MAP);
    sq_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position_m = sq_v3(0.0f, -70.0f, 40.0f);
    cam.target_m = sq_v3(0.0f, 0.0f, 0.0f);
    cam.fov_y_deg = 50.0f;
    sq_renderer *kept = cascade_renderer(ctx);
    SQ_CHECK(sq_renderer_draw(kept, w, &cam, &d, 1, 0.0) == SQ_OK);
    SQ_CHECK(sq__snow_pass_bands(kept) == 1);
    const sq_vec3 moves[3] = {sq_v3(0.0f, 25.0f, 0.0f), sq_v3(-22.0f, 18.0f, 0.0f), sq_v3(3.0f, 9.0f, 0.0f)};
    int bands = 0;
    for (int k = 0; k < 3; k++) {
        cam.position_m = sq_v3_add(cam.position_m, moves[k]);
        cam.target_m = sq_v3_add(cam.target_m, moves[k]);
        SQ_CHECK(sq_renderer_draw(kept, w, &cam, &d, 1, 0.0) == SQ_OK);
        bands += sq__snow_pass_bands(kept);
    }
    sq_renderer *fresh = cascade_renderer(ctx);
    SQ_CHECK(sq_renderer_draw(fresh, w, &cam, &d, 1, 0.0) == SQ_OK);
    sq__snow_map_geom gk, gf;
    float *a = gl_map(kept, &gk), *b = gl_map(fresh, &gf);
    SQ_CHECK(gk.texel_m == gf.texel_m);
    /* the texels the view reads: the fresh map's drawn box less the margin drawn around it */
    const sq__texel_rect t = drawn_texels(&gf, 32);
    const long di = lround((gf.origin[0] - gk.origin[0]) / gk.texel_m);
    const long dj = lround((gf.origin[1] - gk.origin[1]) / gk.texel_m);
    size_t compared = 0, differ = 0, outside = 0;
    for (int j = t.lo[1]; j < t.hi[1]; j++)
        for (int i = t.lo[0]; i < t.hi[0]; i++) {
            const long ik = i + di, jk = j + dj;
            if (ik < 0 || jk < 0 || ik >= gk.size || jk >= gk.size) {
                outside++;
                continue;
            }
            compared++;
            differ += fabsf(a[(size_t)jk * MAP + (size_t)ik] - b[(size_t)j * MAP + (size_t)i]) > 1e-3f;
        }
    printf("bands drawn over 3 moves: %d; texels compared %zu, differ %zu, outside the kept map %zu\n",
           bands, compared, differ, outside);
    SQ_CHECK_MSG(bands >= 2, "only %d bands drawn over the moves", bands);
    SQ_CHECK(outside == 0 && compared > (size_t)MAP * MAP / 4);
    SQ_CHECK_MSG(differ * 1000 <= compared, "%zu of %zu texels differ from a fresh map", differ, compared);
    free(a);
    free(b);
    sq_renderer_destroy(kept);
    sq_renderer_destroy(fresh);
    sq_world_destroy(ctx, w);
    sq_place_destroy(ctx, place);
    sq_context_destroy(ctx);
}
