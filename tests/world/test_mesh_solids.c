/* test_mesh_solids.c — meshes as solids for the other phenomena: a closed gable-house mesh placed
 * in the world becomes exactly the solid cells of the sandstorm grid and of the snowdrift lattice
 * whose centres lie inside the analytic house (walls box + roof prism), the same cells as the
 * equivalent built-in house obstacle, and the lattice wind is blocked behind it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "phen/sandstorm/sandstorm_internal.h"
#include "phen/snowdrift/snowdrift_internal.h"
#include "sq_test.h"
#include "squall/mesh.h"
#include "squall/sandstorm.h"
#include "squall/snowdrift.h"
#include "squall/world.h"

SQ_LABEL(physics)

typedef struct house_dims {
    float L, W, H, R; /* walls L (local x) x W x H, roof prism of ridge height R along x */
} house_dims;

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) exit(1);
    return ctx;
}

/* The house as two closed parts (walls box, roof prism on its top), base at z = 0. */
static sq_mesh *house_mesh(sq_context *ctx, house_dims h)
{
    const float x = 0.5f * h.L, y = 0.5f * h.W, H = h.H, R = h.R;
    const float p[] = {-x, -y, 0, x, -y, 0, -x, y, 0, x, y, 0, -x, -y, H, x, -y, H, -x, y, H, x, y, H,
                       -x, -y, H, -x, y, H, -x, 0, H + R, x, -y, H, x, y, H, x, 0, H + R};
    static const uint32_t idx[] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                   2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5,
                                   8, 10, 9, 11, 12, 13, 8, 9, 12, 8, 12, 11, 8, 11, 13, 8, 13, 10,
                                   9, 10, 13, 9, 13, 12};
    sq_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.name = "house";
    d.vertex_count = 14;
    d.positions = p;
    d.index_count = (int)(sizeof idx / sizeof idx[0]);
    d.indices = idx;
    sq_mesh *m = NULL;
    if (sq_mesh_create(ctx, &d, &m) != SQ_OK) {
        fprintf(stderr, "house: %s\n", sq_last_error());
        exit(1);
    }
    return m;
}

/* A flat 200 m world, with the house as a mesh instance (mesh != NULL) or as the built-in house
 * obstacle of the same shape (mesh == NULL, obstacle), or with nothing (no_house). */
static sq_world *world_with(sq_context *ctx, const sq_mesh *mesh, bool obstacle, house_dims h,
                            sq_vec3 at, float yaw_deg)
{
    static sq_obstacle ob;
    memset(&ob, 0, sizeof ob);
    ob.kind = SQ_OBSTACLE_HOUSE;
    ob.center_m = at;
    ob.size_m = sq_v3(h.L, h.W, h.H);
    ob.roof_m = h.R;
    ob.yaw_deg = yaw_deg;
    sq_world_desc wd;
    memset(&wd, 0, sizeof wd);
    wd.terrain.kind = SQ_TERRAIN_FLAT;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 200.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 33;
    wd.obstacles = obstacle ? &ob : NULL;
    wd.obstacle_count = obstacle ? 1 : 0;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &wd, &w) != SQ_OK) exit(1);
    if (mesh) {
        sq_mesh_instance in;
        memset(&in, 0, sizeof in);
        in.position_m = at;
        in.yaw_deg = yaw_deg;
        const sq_mesh *list[1] = {mesh};
        if (sq_world_set_meshes(ctx, w, list, 1, &in, 1) != SQ_OK) exit(1);
    }
    return w;
}

/* Is p strictly inside the analytic house at `at` turned by yaw? */
static bool in_house(house_dims h, sq_vec3 at, float yaw_deg, double px, double py, double pz)
{
    const double a = (double)yaw_deg * 3.14159265358979323846 / 180.0;
    const double dx = px - at.x, dy = py - at.y;
    const double lx = cos(a) * dx + sin(a) * dy, ly = -sin(a) * dx + cos(a) * dy, lz = pz - at.z;
    if (fabs(lx) >= 0.5 * h.L || fabs(ly) >= 0.5 * h.W || lz <= 0.0) return false;
    return lz < h.H + h.R * (1.0 - fabs(ly) / (0.5 * h.W));
}

/* The sandstorm grid (1 m cells, the house turned by 30 degrees): its solid cells above the ground
 * are the cell centres inside the analytic house, and the same as with the house obstacle. */
SQ_TEST(sandstorm_grid_solid_cells_are_the_house)
{
    sq_context *ctx = make_ctx();
    const house_dims h = {12.0f, 8.0f, 4.5f, 3.0f};
    const sq_vec3 at = sq_v3(0.3f, -0.2f, 0.0f);
    sq_mesh *m = house_mesh(ctx, h);
    sq_sandstorm_desc d;
    memset(&d, 0, sizeof d);
    d.cells[0] = 32;
    d.cells[1] = 24;
    d.cells[2] = 12;
    d.cell_size_m = 1.0;
    d.pressure_amp_pa[0] = 1.0f;
    d.pressure_amp_count = 1;
    uint8_t *solid[2] = {NULL, NULL};
    size_t n = 0;
    for (int v = 0; v < 2; v++) {
        sq_world *w = world_with(ctx, v == 0 ? m : NULL, v == 1, h, at, 30.0f);
        sq_sandstorm *s = NULL;
        SQ_CHECK_OK(sq_sandstorm_create(ctx, &d, w, &s));
        if (!s) {
            sq_world_destroy(ctx, w);
            continue;
        }
        n = (size_t)s->nx * s->ny * s->nz;
        solid[v] = (uint8_t *)malloc(n);
        if (solid[v]) memcpy(solid[v], sq_grid_solid(s->grid), n);
        if (v == 0) {
            int house = 0, expect = 0, wrong = 0;
            for (int k = 0; k < s->nz; k++)
                for (int j = 0; j < s->ny; j++)
                    for (int i = 0; i < s->nx; i++) {
                        const double x = s->origin[0] + (i + 0.5) * s->h;
                        const double y = s->origin[1] + (j + 0.5) * s->h;
                        const double z = s->origin[2] + (k + 0.5) * s->h;
                        const bool is = sq_grid_is_solid(s->grid, i, j, k);
                        const bool want = z <= 0.0 || in_house(h, at, 30.0f, x, y, z);
                        wrong += is != want;
                        house += is && z > 0.0;
                        expect += want && z > 0.0;
                    }
            printf("sandstorm grid: %d solid cells above the ground, %d centres inside the house, "
                   "%d cells differ\n", house, expect, wrong);
            SQ_CHECK(wrong == 0);
            SQ_CHECK(house > 400); /* walls ~ 4 layers of 96 cells and the roof */
        }
        sq_sandstorm_destroy(s);
        sq_world_destroy(ctx, w);
    }
    SQ_CHECK(solid[0] && solid[1] && memcmp(solid[0], solid[1], n) == 0);
    free(solid[0]);
    free(solid[1]);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

static sq_snowdrift *lattice(sq_context *ctx, sq_world *w)
{
    sq_snowdrift_desc d;
    memset(&d, 0, sizeof d);
    d.cells[0] = 48;
    d.cells[1] = 24;
    d.cells[2] = 20;
    d.wind_speed_mps = 6;
    d.snowfall_mmh = 0;
    d.visual_flakes = 0;
    sq_snowdrift *s = NULL;
    if (sq_snowdrift_create(ctx, &d, w, &s) != SQ_OK) {
        fprintf(stderr, "snowdrift: %s\n", sq_last_error());
        return NULL;
    }
    return s;
}

/* The snowdrift lattice (1 m cells, wind along +x): the house mesh's solid cells are the 624
 * cell centres inside it (its volume, 12 x 8 x 5 + 12 x 8 x 3 / 2 m^3, as the walls and roof lie
 * on cell faces), as with the house obstacle; after 20 s of wind the air 2 m behind the lee wall
 * at 2 m height moves at less than half the speed it has there without the house. */
SQ_TEST(snowdrift_lattice_house_blocks_the_wind)
{
    sq_context *ctx = make_ctx();
    const house_dims h = {12.0f, 8.0f, 5.0f, 3.0f};
    const sq_vec3 at = sq_v3(-6.0f, 0.0f, NAN);
    sq_mesh *m = house_mesh(ctx, h);
    double lee_u[3] = {0, 0, 0};
    uint8_t *mask[2] = {NULL, NULL};
    size_t n = 0;
    for (int v = 0; v < 3; v++) { /* mesh, obstacle, nothing */
        sq_world *w = world_with(ctx, v == 0 ? m : NULL, v == 1, h, at, 0.0f);
        sq_snowdrift *s = lattice(ctx, w);
        SQ_CHECK(s != NULL);
        if (!s) {
            sq_world_destroy(ctx, w);
            continue;
        }
        n = (size_t)s->nx * s->ny * s->nz;
        if (v < 2) {
            mask[v] = (uint8_t *)malloc(n);
            int house = 0;
            for (int k = 0; k < s->nz; k++)
                for (int j = 0; j < s->ny; j++)
                    for (int i = 0; i < s->nx; i++) {
                        const bool is = sq_lbm_is_solid(s->lbm, i, j, k);
                        if (mask[v]) mask[v][(size_t)i + (size_t)s->nx * (j + (size_t)s->ny * k)] = is;
                        house += is && s->origin[2] + (k + 0.5) * s->h > 0.0;
                    }
            if (v == 0) {
                printf("snowdrift lattice: %d solid cells above the ground (house volume 624 m^3)\n",
                       house);
                SQ_CHECK(house == 624);
            }
        }
        for (int t = 0; t < 20; t++) SQ_CHECK_OK(sq_snowdrift_step(s, 1.0));
        sq_lbm_views lv;
        SQ_CHECK_OK(sq_lbm_get_views(s->lbm, &lv));
        /* 2 m behind the lee wall (x = 0), 2 m up, on the centre line */
        const int i = (int)floor((2.0 - s->origin[0]) / s->h);
        const int j = (int)floor((0.0 - s->origin[1]) / s->h);
        const int k = (int)floor((2.0 - s->origin[2]) / s->h);
        const sq_field_view *u = &lv.u[0];
        lee_u[v] = u->data[i * u->sx + j * u->sy + k * u->sz];
        sq_snowdrift_destroy(s);
        sq_world_destroy(ctx, w);
    }
    printf("u_x 2 m behind the house at 2 m height: mesh %.3f m/s, obstacle %.3f m/s, no house "
           "%.3f m/s\n", lee_u[0], lee_u[1], lee_u[2]);
    SQ_CHECK(mask[0] && mask[1] && memcmp(mask[0], mask[1], n) == 0);
    SQ_CHECK(lee_u[2] > 1.0);
    SQ_CHECK(lee_u[0] < 0.5 * lee_u[2]);
    SQ_CHECK(lee_u[0] == lee_u[1]); /* the same solid cells give the same wind, bit for bit */
    free(mask[0]);
    free(mask[1]);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

/* ---- SPH colliders ----------------------------------------------------------------------- */
#include "squall/sph.h"

/* One SPH particle (gravity and the contact only) in a 40 m box over the house mesh, which is
 * voxelised on 0.1 m cells (meshes only: the terrain is the SPH heightfield's business) into a
 * signed-distance collider. */
static sq_sph *one_particle_over_house(sq_context *ctx, sq_world *w, const float p0[3],
                                       const float v0[3], double restitution)
{
    sq_sph_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = 0.5;
    d.collision_radius_m = 0.025;
    d.speed_of_sound_mps = 50.0;
    d.gravity_mps2[2] = -9.81;
    for (int a = 0; a < 3; a++) {
        d.domain_min_m[a] = -20.0;
        d.domain_max_m[a] = 20.0;
    }
    d.domain_min_m[2] = -1.0;
    d.max_particles = 4;
    sq_sph *s = NULL;
    if (sq_sph_create(ctx, &d, &s) != SQ_OK) return NULL;
    const double h = 0.1;
    const int n[3] = {160, 120, 100};
    const double origin[3] = {-8.0, -6.0, -1.0};
    uint8_t *mask = (uint8_t *)malloc((size_t)n[0] * n[1] * n[2]);
    if (!mask) exit(1);
    SQ_CHECK_OK(sq_world_voxelise(w, origin, h, n, SQ_SOLID_MESHES, mask));
    sq_sph_solid_grid_desc g;
    memset(&g, 0, sizeof g);
    memcpy(g.origin_m, origin, sizeof origin);
    g.cell_m = h;
    memcpy(g.n, n, sizeof n);
    g.solid = mask;
    g.contact.frictionless = true;
    g.contact.restitution = restitution;
    SQ_CHECK_OK(sq_sph_add_solid_grid(s, &g));
    free(mask);
    SQ_CHECK_OK(sq_sph_add_particles(s, 1, p0, v0));
    return s;
}

/* The voxelised house as an SPH collider: its signed distance and normal match the analytic house
 * (within the 0.1 m cells), a particle thrown at a wall stops at the wall (e = 0) or comes back
 * (e = 1), and a particle let go on the frictionless roof slides down the slope at g sin(pitch). */
SQ_TEST(sph_collides_with_a_voxelised_house)
{
    sq_context *ctx = make_ctx();
    const house_dims hd = {12.0f, 8.0f, 5.0f, 3.0f}; /* x -6..6, y -4..4, eaves 5 m, ridge 8 m */
    sq_mesh *m = house_mesh(ctx, hd);
    sq_world *w = world_with(ctx, m, false, hd, sq_v3(0.0f, 0.0f, 0.0f), 0.0f);
    const float r = 0.025f;
    /* distances and normals: in front of the x = 6 wall, inside, above the roof slope */
    {
        const float p0[3] = {0.0f, 0.0f, 15.0f};
        sq_sph *s = one_particle_over_house(ctx, w, p0, NULL, 0.0);
        SQ_CHECK(s != NULL);
        if (s) {
            double nrm[3];
            const double q1[3] = {7.0, 0.3, 2.0}, q2[3] = {0.0, 0.0, 2.5};
            const double d1 = sq_sph_solid_distance(s, q1, nrm);
            printf("1 m in front of the wall: %.4f m, normal (%.3f %.3f %.3f)\n", d1, nrm[0], nrm[1],
                   nrm[2]);
            SQ_CHECK_NEAR(d1, 1.0, 0.05);
            SQ_CHECK(nrm[0] > 0.99);
            const double d2 = sq_sph_solid_distance(s, q2, nrm);
            printf("house centre at 2.5 m: %.4f m (analytic -2.5)\n", d2);
            SQ_CHECK_NEAR(d2, -2.5, 0.1);
            /* 0.5 m above the slope along its normal, at y = 2 (slope height 6.5 m there) */
            const double th = atan2(3.0, 4.0);
            const double q3[3] = {1.0, 2.0 + 0.5 * sin(th), 6.5 + 0.5 * cos(th)};
            const double d3 = sq_sph_solid_distance(s, q3, nrm);
            const double ang = acos(nrm[1] * sin(th) + nrm[2] * cos(th)) * 180.0 / M_PI;
            printf("0.5 m above the roof: %.4f m, normal %.2f deg off the slope's\n", d3, ang);
            SQ_CHECK_NEAR(d3, 0.5, 0.07);
            SQ_CHECK(ang < 5.0);
            const double far[3] = {30.0, 0.0, 0.0};
            SQ_CHECK(isinf(sq_sph_solid_distance(s, far, NULL)));
            /* bad grids are refused, naming the field */
            const uint8_t one[8] = {1, 1, 1, 1, 1, 1, 1, 1};
            sq_sph_solid_grid_desc bad;
            memset(&bad, 0, sizeof bad);
            bad.cell_m = 0.0;
            bad.n[0] = bad.n[1] = bad.n[2] = 2;
            bad.solid = one;
            SQ_CHECK(sq_sph_add_solid_grid(s, &bad) == SQ_ERR_INVALID_ARG);
            SQ_CHECK_MSG(strstr(sq_last_error(), "cell_m = 0"), "%s", sq_last_error());
            bad.cell_m = 1.0;
            bad.n[1] = 1;
            SQ_CHECK(sq_sph_add_solid_grid(s, &bad) == SQ_ERR_INVALID_ARG);
            SQ_CHECK_MSG(strstr(sq_last_error(), "n[1] = 1"), "%s", sq_last_error());
            bad.n[1] = 2;
            bad.contact.restitution = 2.0;
            SQ_CHECK(sq_sph_add_solid_grid(s, &bad) == SQ_ERR_INVALID_ARG);
            sq_sph_destroy(s);
        }
    }
    /* thrown at the wall x = -6 from the west, without gravity */
    for (int c = 0; c < 2; c++) {
        const double e = c;
        const float p0[3] = {-7.0f, 0.7f, 2.0f}, v0[3] = {4.0f, 0.0f, 0.0f};
        sq_sph *s = one_particle_over_house(ctx, w, p0, v0, e);
        SQ_CHECK(s != NULL);
        if (!s) continue;
        const double g0[3] = {0.0, 0.0, 0.0};
        SQ_CHECK_OK(sq_sph_set_gravity(s, g0));
        SQ_CHECK_OK(sq_sph_step(s, 0.5));
        const sq_sph_view v = sq_sph_particles(s);
        printf("wall e = %.0f: x = %.4f m, vx = %.4f m/s\n", e, v.x[0], v.vx[0]);
        if (e == 0.0) {
            SQ_CHECK_NEAR(v.x[0], -6.0 - r, 2e-3);
            SQ_CHECK_NEAR(v.vx[0], 0.0, 1e-3);
        } else {
            SQ_CHECK_NEAR(v.vx[0], -4.0, 1e-2);
            SQ_CHECK(v.x[0] < -6.0 - r);
        }
        sq_sph_destroy(s);
    }
    /* let go on the roof slope (y = 1, z = 7.25 + r / cos): slides at g sin(pitch) along it */
    {
        const double th = atan2(3.0, 4.0), g = 9.81, T = 0.4;
        const float p0[3] = {0.5f, 1.0f, (float)(7.25 + r / cos(th))};
        sq_sph *s = one_particle_over_house(ctx, w, p0, NULL, 0.0);
        SQ_CHECK(s != NULL);
        if (s) {
            for (int f = 0; f < 40; f++) SQ_CHECK_OK(sq_sph_step(s, T / 40));
            const sq_sph_view v = sq_sph_particles(s);
            const double speed = sqrt((double)v.vy[0] * v.vy[0] + (double)v.vz[0] * v.vz[0]);
            const double zs = 8.0 - 3.0 * fabs((double)v.y[0]) / 4.0; /* the slope under it */
            printf("roof: speed %.4f m/s after %.1f s (analytic %.4f), y %.3f m, %.4f m above "
                   "the slope\n", speed, T, g * sin(th) * T, v.y[0], (v.z[0] - zs) * cos(th));
            SQ_CHECK_REL(speed, g * sin(th) * T, 0.05);
            SQ_CHECK(v.vy[0] > 0.0f && v.vz[0] < 0.0f); /* down the slope toward +y */
            SQ_CHECK_NEAR((v.z[0] - zs) * cos(th), r, 0.03);
            sq_sph_destroy(s);
        }
    }
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

/* ---- the avalanche ------------------------------------------------------------------------ */
#include "squall/avalanche.h"

/* A slab of snow on a 35 degree slope runs into a box mesh (2 x 3 x 3 m, in its path 8 m below
 * the release): the snow touches the box and no particle gets deeper into it than a quarter of the
 * particle spacing (the bound the obstacle box meets in tests/avalanche). */
SQ_TEST(avalanche_stops_at_a_mesh)
{
    sq_context *ctx = make_ctx();
    sq_world_desc wd;
    memset(&wd, 0, sizeof wd);
    wd.terrain.kind = SQ_TERRAIN_MOUNTAIN;
    wd.terrain.size_m[0] = 160.0f;
    wd.terrain.size_m[1] = 48.0f;
    wd.terrain.resolution[0] = 161;
    wd.terrain.resolution[1] = 49;
    wd.terrain.relief_m = 2.0f;
    wd.terrain.feature_m = 60.0f;
    wd.terrain.slope_deg = 35.0f;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &wd, &w));
    if (!w) return;
    /* the box mesh: 8 corners, 12 triangles, base at z = 0 */
    const float p[] = {-1, -1.5f, 0, 1, -1.5f, 0, -1, 1.5f, 0, 1, 1.5f, 0,
                       -1, -1.5f, 3, 1, -1.5f, 3, -1, 1.5f, 3, 1, 1.5f, 3};
    static const uint32_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                     2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    sq_mesh_desc md;
    memset(&md, 0, sizeof md);
    md.name = "box";
    md.vertex_count = 8;
    md.positions = p;
    md.index_count = 36;
    md.indices = idx;
    sq_mesh *m = NULL;
    SQ_CHECK_OK(sq_mesh_create(ctx, &md, &m));
    sq_mesh_instance in;
    memset(&in, 0, sizeof in);
    in.position_m = sq_v3(-4.0f, 0.0f, NAN); /* on the lowest terrain under it */
    const sq_mesh *list[1] = {m};
    SQ_CHECK_OK(sq_world_set_meshes(ctx, w, list, 1, &in, 1));
    const sq_mesh_instance *placed = NULL;
    SQ_CHECK(sq_world_mesh_instances(w, NULL, NULL, &placed) == 1);
    if (!placed) return;
    const sq_vec3 c = placed[0].position_m;
    sq_avalanche_desc d;
    memset(&d, 0, sizeof d);
    d.spacing_m = 0.5;
    d.release_x_m = -12.0;
    d.release_length_m = 8.0;
    d.release_width_m = 8.0;
    d.release_depth_m = 1.5;
    sq_avalanche *a = NULL;
    SQ_CHECK_OK(sq_avalanche_create(ctx, &d, w, &a));
    double worst_inside = 0.0;
    int hit = 0;
    for (int f = 0; a && f < 25; f++) {
        SQ_CHECK_OK(sq_avalanche_step(a, 0.1));
        size_t n = 0;
        const float *q = sq_avalanche_positions(a, &n);
        for (size_t i = 0; i < n; i++) {
            const float dx = fabsf(q[3 * i] - c.x) - 1.0f, dy = fabsf(q[3 * i + 1] - c.y) - 1.5f;
            const float dz = fmaxf(q[3 * i + 2] - (c.z + 3.0f), c.z - q[3 * i + 2]);
            const float depth = -fmaxf(dx, fmaxf(dy, dz));
            if (dx < 0.5f && dy < 0.5f && dz < 0.5f) hit = 1;
            /* inside the box and above the terrain (the box's base is below the slope) */
            if (depth > worst_inside && q[3 * i + 2] > sq_world_height_at(w, q[3 * i], q[3 * i + 1]))
                worst_inside = depth;
        }
    }
    printf("avalanche: deepest inside the box mesh %.3f m, touched %d\n", worst_inside, hit);
    SQ_CHECK(hit);
    SQ_CHECK(worst_inside < 0.25 * d.spacing_m);
    sq_avalanche_destroy(a);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}
