/* test_world.c — terrain generation, sun position, obstacles, camera paths. */
#include <math.h>
#include <string.h>

#include "sq_test.h"
#include "squall/world.h"

SQ_LABEL(unit)

static inline sq_world_terrain terrain_of(const sq_world *w)
{
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    return t;
}

static sq_context *mkctx(void)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    return ctx;
}

SQ_TEST(flat_terrain_and_bounds)
{
    sq_context *ctx = mkctx();
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.terrain.base_m = 12.5f;
    d.terrain.size_m[0] = 100;
    d.terrain.size_m[1] = 50;
    d.terrain.resolution[0] = 11;
    d.terrain.resolution[1] = 6;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    SQ_CHECK_NEAR(terrain_of(w).dx, 10.0, 1e-6);
    SQ_CHECK_NEAR(terrain_of(w).origin.x, -50.0, 1e-6);
    SQ_CHECK_NEAR(sq_world_height_at(w, 3.3f, -7.0f), 12.5, 1e-5);
    sq_vec3 n = sq_world_normal_at(w, 0, 0);
    SQ_CHECK_NEAR(n.z, 1.0, 1e-6);
    SQ_CHECK(sq_world_solid_at(w, sq_v3(0, 0, 12.0f)));
    SQ_CHECK(!sq_world_solid_at(w, sq_v3(0, 0, 13.0f)));
    /* a NaN coordinate (a particle a blown-up wind carried away) reads no memory outside the
     * heights: NaN height, the vertical; far outside, the edge */
    SQ_CHECK(isnan(sq_world_height_at(w, NAN, 0.0f)) && isnan(sq_world_height_at(w, 0.0f, NAN)));
    n = sq_world_normal_at(w, NAN, 1.0f);
    SQ_CHECK(n.x == 0.0f && n.y == 0.0f && n.z == 1.0f);
    SQ_CHECK_NEAR(sq_world_height_at(w, -1e30f, 1e30f), 12.5, 1e-5);
    SQ_CHECK_NEAR(sq_world_height_at(w, INFINITY, -INFINITY), 12.5, 1e-5);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(heightmap_maps_range_and_slope_normals)
{
    sq_context *ctx = mkctx();
    uint16_t px[4 * 3];
    /* a ramp rising toward +x: value = i * 65535 / 3 */
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 4; i++) px[j * 4 + i] = (uint16_t)(i * 21845);
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_HEIGHTMAP;
    d.terrain.heightmap = px;
    d.terrain.heightmap_w = 4;
    d.terrain.heightmap_h = 3;
    d.terrain.metres_per_px = 10.0f;
    d.terrain.height_min_m = 100.0f;
    d.terrain.height_max_m = 130.0f;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    SQ_CHECK(terrain_of(w).nx == 4 && terrain_of(w).ny == 3);
    SQ_CHECK_NEAR(terrain_of(w).height_min, 100.0, 1e-4);
    SQ_CHECK_NEAR(terrain_of(w).height_max, 130.0, 1e-3);
    /* slope 10 m per 10 m: normal = (-1, 0, 1)/sqrt 2 */
    sq_vec3 n = sq_world_normal_at(w, terrain_of(w).origin.x + 15.0f, terrain_of(w).origin.y + 10.0f);
    SQ_CHECK_NEAR(n.x, -sqrt(0.5), 1e-4);
    SQ_CHECK_NEAR(n.z, sqrt(0.5), 1e-4);
    sq_world_destroy(ctx, w);
    d.terrain.metres_per_px = 0.0f;
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "metres_per_px = 0");
    sq_context_destroy(ctx);
}

SQ_TEST(float_grid_terrain_rows_south_first_with_crs)
{
    sq_context *ctx = mkctx();
    /* heights rise toward north: h = 200 + 5 j over a 3 x 4 grid at 20 m x 10 m */
    float h[3 * 4];
    for (int j = 0; j < 4; j++)
        for (int i = 0; i < 3; i++) h[j * 3 + i] = 200.0f + 5.0f * (float)j;
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_GRID;
    d.terrain.grid_heights_m = h;
    d.terrain.grid_w = 3;
    d.terrain.grid_h = 4;
    d.terrain.grid_dx_m = 20.0f;
    d.terrain.grid_dy_m = 10.0f;
    d.terrain.origin_set = true;
    d.crs_wkt = "EPSG:32632";
    d.crs_offset_m[0] = 640000.0;
    d.crs_offset_m[1] = 5170000.0;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    SQ_CHECK(terrain_of(w).nx == 3 && terrain_of(w).ny == 4);
    SQ_CHECK_NEAR(terrain_of(w).dx, 20.0, 0.0);
    SQ_CHECK_NEAR(terrain_of(w).dy, 10.0, 0.0);
    SQ_CHECK_NEAR(sq_world_height_at(w, 0.0f, 0.0f), 200.0, 1e-4);   /* south row */
    SQ_CHECK_NEAR(sq_world_height_at(w, 20.0f, 30.0f), 215.0, 1e-4); /* north row */
    /* slope 5 m per 10 m toward north: normal (0, -0.5, 1)/|.| */
    sq_vec3 n = sq_world_normal_at(w, 20.0f, 15.0f);
    SQ_CHECK_NEAR(n.y, -0.5 / sqrt(1.25), 1e-4);
    double off[2];
    const char *crs = sq_world_crs(w, off);
    SQ_CHECK(crs != NULL && strcmp(crs, "EPSG:32632") == 0);
    SQ_CHECK_NEAR(off[1], 5170000.0, 0.0);
    sq_world_destroy(ctx, w);
    h[5] = NAN;
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "sample (2, 1) = nan");
    h[5] = 200.0f;
    d.terrain.grid_dy_m = 0.0f;
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "grid spacing");
    sq_context_destroy(ctx);
}

SQ_TEST(procedural_kinds_are_finite_and_seeded)
{
    sq_context *ctx = mkctx();
    const sq_terrain_kind kinds[] = {SQ_TERRAIN_HILLS, SQ_TERRAIN_DUNES, SQ_TERRAIN_MOUNTAIN};
    for (int k = 0; k < 3; k++) {
        sq_world_desc d = {0};
        d.terrain.kind = kinds[k];
        d.terrain.resolution[0] = d.terrain.resolution[1] = 65;
        d.terrain.seed = 7;
        sq_world *a = NULL, *b = NULL;
        SQ_CHECK_OK(sq_world_create(ctx, &d, &a));
        SQ_CHECK_OK(sq_world_create(ctx, &d, &b));
        if (!a || !b) break;
        const sq_world_terrain ta = terrain_of(a), tb = terrain_of(b);
        SQ_CHECK(ta.height_max > ta.height_min + 1.0f);
        int same = 1;
        for (int i = 0; i < 65 * 65; i++) {
            SQ_CHECK(isfinite(ta.heights[i]));
            same &= ta.heights[i] == tb.heights[i];
        }
        SQ_CHECK(same);
        sq_world_destroy(ctx, a);
        sq_world_destroy(ctx, b);
    }
    sq_context_destroy(ctx);
}

SQ_TEST(mountain_slope_angle)
{
    sq_context *ctx = mkctx();
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_MOUNTAIN;
    d.terrain.slope_deg = 35.0f;
    d.terrain.relief_m = 0.001f; /* no ridges: a clean slope */
    d.terrain.size_m[0] = d.terrain.size_m[1] = 1000.0f;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 201;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    float x0 = terrain_of(w).origin.x + 100.0f, x1 = terrain_of(w).origin.x + 300.0f, y = terrain_of(w).origin.y + 100.0f;
    float drop = sq_world_height_at(w, x0, y) - sq_world_height_at(w, x1, y);
    SQ_CHECK_NEAR(atan2(drop, 200.0) * 180.0 / SQ_PI, 35.0, 0.5);
    /* run-out plain at the far end is flat */
    float h1 = sq_world_height_at(w, terrain_of(w).origin.x + 900.0f, y),
          h2 = sq_world_height_at(w, terrain_of(w).origin.x + 950.0f, y);
    SQ_CHECK_NEAR(h1, h2, 0.01);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(sun_direction)
{
    /* Equinox (day 80), noon, equator: the sun is at the zenith (declination ~ 0). */
    sq_vec3 s = sq_sun_direction(80, 12.0f, 0.0f);
    SQ_CHECK(s.z > 0.999f);
    /* 45 N, June solstice, noon: elevation = 90 - 45 + 23.45 = 68.45 deg, due south. */
    s = sq_sun_direction(172, 12.0f, 45.0f);
    SQ_CHECK_NEAR(asin(s.z) * 180.0 / SQ_PI, 68.45, 0.1);
    SQ_CHECK(s.y < 0.0f);
    SQ_CHECK_NEAR(s.x, 0.0, 1e-3);
    /* afternoon: sun in the west (x < 0); morning: east */
    SQ_CHECK(sq_sun_direction(172, 15.0f, 45.0f).x < 0.0f);
    SQ_CHECK(sq_sun_direction(172, 9.0f, 45.0f).x > 0.0f);
    /* midnight: below the horizon */
    SQ_CHECK(sq_sun_direction(172, 0.0f, 45.0f).z < 0.0f);
}

SQ_TEST(obstacles_solid_and_roof)
{
    sq_context *ctx = mkctx();
    sq_obstacle house = {.kind = SQ_OBSTACLE_HOUSE,
                         .center_m = {10, 0, NAN},
                         .size_m = {8, 6, 4},
                         .roof_m = 2};
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.obstacles = &house;
    d.obstacle_count = 1;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    SQ_CHECK_NEAR(sq_world_obstacles(w)[0].center_m.z, 0.0, 1e-6); /* placed on the terrain */
    SQ_CHECK(sq_world_solid_at(w, sq_v3(10, 0, 5.9f)));   /* under the ridge */
    SQ_CHECK(!sq_world_solid_at(w, sq_v3(10, 2.9f, 5.0f))); /* eave side: roof lower */
    SQ_CHECK(!sq_world_solid_at(w, sq_v3(15, 0, 1.0f)));   /* outside the footprint */
    SQ_CHECK_NEAR(sq_world_surface_at(w, 10, 0), 6.0, 1e-5);
    sq_world_destroy(ctx, w);
    house.size_m.y = 0;
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "obstacles[0].size");
    sq_context_destroy(ctx);
}

SQ_TEST(camera_path)
{
    sq_camera base = {.position_m = {0, 0, 10}, .target_m = {1, 0, 10}};
    sq_camera_key keys[3] = {{0.0, {0, 0, 10}, {100, 0, 0}, 0},
                             {5.0, {50, 0, 20}, {100, 0, 0}, 40},
                             {10.0, {100, 0, 10}, {200, 0, 0}, 0}};
    sq_camera c = sq_camera_at(&base, keys, 3, 5.0);
    SQ_CHECK_NEAR(c.position_m.x, 50.0, 1e-4);
    SQ_CHECK_NEAR(c.position_m.z, 20.0, 1e-4);
    SQ_CHECK_NEAR(c.fov_y_deg, 40.0, 1e-4);
    c = sq_camera_at(&base, keys, 3, 20.0);
    SQ_CHECK_NEAR(c.position_m.x, 100.0, 1e-4);
    c = sq_camera_at(&base, keys, 3, 2.5);
    SQ_CHECK(c.position_m.x > 0.0f && c.position_m.x < 50.0f); /* between the keys */
    SQ_CHECK_NEAR(c.fov_y_deg, 45.0, 1e-3);
    c = sq_camera_at(&base, NULL, 0, 3.0);
    SQ_CHECK(c.fov_y_deg == 50.0f && c.near_m == 0.5f);
}

/* The opaque world read through its accessors: what the desc asked for comes back (sizes,
 * spacing, heights of a float grid, obstacles with z on the terrain, CRS and offset, areas),
 * and the sun follows the world's time. */
SQ_TEST(accessors_return_the_desc)
{
    sq_context *ctx = mkctx();
    float h[4 * 3];
    for (int k = 0; k < 12; k++) h[k] = 100.0f + (float)k; /* rises along x, then y */
    const sq_obstacle ob[2] = {{SQ_OBSTACLE_BOX, {5.0f, 5.0f, NAN}, {2.0f, 2.0f, 3.0f}, 0.0f,
                                0.0f, {0.0f, 0.0f, 0.0f}},
                               {SQ_OBSTACLE_HOUSE, {20.0f, 5.0f, 200.0f}, {4.0f, 4.0f, 2.0f},
                                1.0f, 30.0f, {0.5f, 0.5f, 0.5f}}};
    const double fv[1] = {7.0}, fa[1] = {100.0}, xy[8] = {0, 0, 10, 0, 10, 10, 0, 10};
    const int rs[2] = {0, 4}, rf[1] = {0};
    sq_world_area area = {"zone", "test", 1, fv, fa, 1, rs, rf, xy, {0, 0, 10, 10}, 100.0};
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_GRID;
    d.terrain.grid_heights_m = h;
    d.terrain.grid_w = 4;
    d.terrain.grid_h = 3;
    d.terrain.grid_dx_m = 10.0f;
    d.terrain.grid_dy_m = 5.0f;
    d.terrain.origin_set = true;
    d.obstacles = ob;
    d.obstacle_count = 2;
    d.crs_wkt = "EPSG:32632";
    d.crs_offset_m[0] = 644300.0;
    d.crs_offset_m[1] = 5186300.0;
    d.areas = &area;
    d.area_count = 1;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    if (!w) return;
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    SQ_CHECK(t.nx == 4 && t.ny == 3 && t.kind == SQ_TERRAIN_GRID);
    SQ_CHECK_NEAR(t.dx, 10.0, 0.0);
    SQ_CHECK_NEAR(t.dy, 5.0, 0.0);
    SQ_CHECK_NEAR(t.origin.x, 0.0, 0.0);
    SQ_CHECK(t.heights != h); /* the world's copy */
    SQ_CHECK_NEAR(t.heights[2 * 4 + 3], 111.0, 0.0);
    SQ_CHECK_NEAR(t.height_min, 100.0, 0.0);
    SQ_CHECK_NEAR(t.height_max, 111.0, 0.0);
    SQ_CHECK_NEAR(t.vertical_exaggeration, 1.0, 0.0);
    SQ_CHECK(t.normals != NULL && t.void_mask == NULL);
    SQ_CHECK(sq_world_obstacle_count(w) == 2);
    const sq_obstacle *o = sq_world_obstacles(w);
    SQ_CHECK(o[1].kind == SQ_OBSTACLE_HOUSE && o[1].yaw_deg == 30.0f && o[1].roof_m == 1.0f);
    SQ_CHECK_NEAR(o[0].center_m.z, sq_world_height_at(w, 5.0f, 5.0f), 1e-4); /* NaN: on terrain */
    SQ_CHECK_NEAR(o[1].center_m.z, 200.0, 0.0);
    double off[2];
    SQ_CHECK(strcmp(sq_world_crs(w, off), "EPSG:32632") == 0);
    SQ_CHECK(off[0] == 644300.0 && off[1] == 5186300.0);
    SQ_CHECK(sq_world_area_count(w) == 1 && sq_world_area_at(w, 1) == NULL);
    SQ_CHECK(strcmp(sq_world_area_at(w, 0)->name, "zone") == 0);
    SQ_CHECK(sq_world_area_at(w, 0)->feature_value[0] == 7.0);
    const sq_mesh *const *meshes = NULL;
    int mesh_count = -1;
    SQ_CHECK(sq_world_mesh_instances(w, &meshes, &mesh_count, NULL) == 0 && mesh_count == 0);
    const uint64_t g = sq_world_generation(w);
    sq_world_light l;
    sq_world_get_light(w, &l);
    SQ_CHECK_NEAR(sq_v3_len(l.sun_dir), 1.0, 1e-5);
    SQ_CHECK(!l.sun_follows_clock && l.time_s == 0.0);
    sq_world_set_time(w, 12.0);
    sq_world_get_light(w, &l);
    SQ_CHECK(l.time_s == 12.0);
    SQ_CHECK(sq_world_generation(w) == g); /* time is not geometry */
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}
