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
