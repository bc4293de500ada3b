/* test_meshes.c — meshes in the world: creation (normals split at creases, degenerate triangles
 * dropped and counted, bad indices refused), the enclosed volume, vertex-clustering LODs,
 * voxelisation through sq_world_solid_at against analytic volumes (a box, a gable house turned
 * 30 degrees, two overlapping boxes counted once), the surface height over a roof ridge, the
 * placement rules, and the procedural places: deterministic from the seed and reaching their
 * face counts (>= 1 M for a 4 km suburb, >= 5 M for a 2 km town). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sq_test.h"
#include "squall/mesh.h"
#include "squall/world.h"

SQ_LABEL(physics)

static sq_context *make_ctx(void)
{
    sq_context *ctx = NULL;
    sq_context_desc cd;
    memset(&cd, 0, sizeof cd);
    cd.threads = 1;
    if (sq_context_create(&cd, &ctx) != SQ_OK) exit(1);
    return ctx;
}

static sq_world *flat_world(sq_context *ctx, float size)
{
    sq_world_desc d;
    memset(&d, 0, sizeof d);
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.terrain.size_m[0] = d.terrain.size_m[1] = size;
    d.terrain.resolution[0] = d.terrain.resolution[1] = 17;
    sq_world *w = NULL;
    if (sq_world_create(ctx, &d, &w) != SQ_OK) exit(1);
    return w;
}

/* Box lo..hi with 8 shared corners and no normals. */
static sq_result box(sq_context *ctx, sq_vec3 lo, sq_vec3 hi, sq_mesh **out)
{
    float p[24];
    for (int k = 0; k < 8; k++) {
        p[3 * k] = (k & 1) ? hi.x : lo.x;
        p[3 * k + 1] = (k & 2) ? hi.y : lo.y;
        p[3 * k + 2] = (k & 4) ? hi.z : lo.z;
    }
    static const uint32_t idx[36] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                     2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    sq_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.name = "box";
    d.vertex_count = 8;
    d.positions = p;
    d.index_count = 36;
    d.indices = idx;
    return sq_mesh_create(ctx, &d, out);
}

/* A gable house: walls L x W x H (L along x, centred, base z = 0) and a roof prism of ridge
 * height R along x, as two closed parts (the prism's base lies on the walls' top). */
static sq_mesh *house(sq_context *ctx, float L, float Wd, float H, float R)
{
    const float x = 0.5f * L, y = 0.5f * Wd;
    const float p[] = {-x, -y, 0, x, -y, 0, -x, y, 0, x, y, 0, -x, -y, H, x, -y, H, -x, y, H, x, y, H,
                       /* prism */ -x, -y, H, -x, y, H, -x, 0, H + R, x, -y, H, x, y, H, x, 0, H + R};
    static const uint32_t idx[] = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                                   2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5,
                                   /* prism: ends, bottom, slopes */
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

SQ_TEST(box_normals_split_at_creases)
{
    sq_context *ctx = make_ctx();
    sq_mesh *m = NULL;
    SQ_CHECK(box(ctx, sq_v3(0, 0, 0), sq_v3(2, 3, 4), &m) == SQ_OK);
    const sq_mesh_lod *l = &m->lods[0];
    /* 8 shared corners, 3 faces each at 90 degrees: 24 vertices with flat normals */
    SQ_CHECK_MSG(l->vertex_count == 24, "vertices %d", l->vertex_count);
    SQ_CHECK(sq_mesh_face_count(m, 0) == 12);
    for (int t = 0; t < 12; t++) {
        const uint32_t *q = &l->indices[3 * t];
        const float *a = &l->positions[3 * q[0]], *b = &l->positions[3 * q[1]], *c = &l->positions[3 * q[2]];
        const sq_vec3 fn = sq_v3_norm(sq_v3_cross(sq_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                                                  sq_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2])));
        for (int k = 0; k < 3; k++) {
            const float *n = &l->normals[3 * q[k]];
            SQ_CHECK_MSG(fabsf(n[0] - fn.x) < 1e-5f && fabsf(n[1] - fn.y) < 1e-5f && fabsf(n[2] - fn.z) < 1e-5f,
                         "triangle %d corner %d normal (%g %g %g), face (%g %g %g)", t, k, (double)n[0],
                         (double)n[1], (double)n[2], (double)fn.x, (double)fn.y, (double)fn.z);
        }
    }
    SQ_CHECK_MSG(fabs(sq_mesh_volume(m) - 24.0) < 1e-4, "volume %g", sq_mesh_volume(m));
    SQ_CHECK(m->solid);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

SQ_TEST(degenerate_faces_dropped_bad_indices_refused)
{
    sq_context *ctx = make_ctx();
    const float p[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 0, 0};
    /* a good triangle, a repeated index, a collinear (zero-area) one */
    const uint32_t idx[] = {0, 1, 2, 0, 0, 2, 0, 1, 3};
    sq_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.name = "tri";
    d.vertex_count = 4;
    d.positions = p;
    d.index_count = 9;
    d.indices = idx;
    d.open = true;
    sq_mesh *m = NULL;
    SQ_CHECK(sq_mesh_create(ctx, &d, &m) == SQ_OK);
    SQ_CHECK_MSG(m && m->degenerate_dropped == 2, "dropped %lld", m ? (long long)m->degenerate_dropped : -1);
    SQ_CHECK(m && sq_mesh_face_count(m, 0) == 1);
    sq_mesh_destroy(ctx, m);
    const uint32_t bad[] = {0, 1, 7};
    d.indices = bad;
    d.index_count = 3;
    m = NULL;
    SQ_CHECK(sq_mesh_create(ctx, &d, &m) == SQ_ERR_INVALID_ARG && m == NULL);
    SQ_CHECK_MSG(strstr(sq_last_error(), "tri: triangle 0 uses vertex 7; there are 4 vertices"),
                 "%s", sq_last_error());
    const float nanp[] = {0, 0, 0, 1, 0, 0, 0, NAN, 0, 0, 0, 0};
    d.positions = nanp;
    d.indices = idx;
    SQ_CHECK(sq_mesh_create(ctx, &d, &m) == SQ_ERR_INVALID_ARG);
    SQ_CHECK_MSG(strstr(sq_last_error(), "vertex 2"), "%s", sq_last_error());
    /* only degenerate triangles: nothing left */
    const uint32_t degen[] = {0, 1, 3};
    d.positions = p;
    d.indices = degen;
    SQ_CHECK(sq_mesh_create(ctx, &d, &m) == SQ_ERR_INVALID_ARG);
    sq_context_destroy(ctx);
}

/* A UV sphere of 32 x 64: vertex clustering must cut triangles at each level while the shape
 * stays within the cell size of the sphere. */
SQ_TEST(clustering_lods_shrink_within_their_error)
{
    sq_context *ctx = make_ctx();
    enum { RINGS = 32, SIDES = 64 };
    const int nv = (RINGS + 1) * SIDES;
    float *p = malloc((size_t)nv * 3 * sizeof(float));
    uint32_t *idx = malloc((size_t)RINGS * SIDES * 6 * sizeof(uint32_t));
    int k = 0;
    for (int i = 0; i <= RINGS; i++)
        for (int s = 0; s < SIDES; s++) {
            const float th = SQ_PI_F * (float)i / RINGS, ph = 2.0f * SQ_PI_F * (float)s / SIDES;
            p[3 * k] = 10.0f * sinf(th) * cosf(ph);
            p[3 * k + 1] = 10.0f * sinf(th) * sinf(ph);
            p[3 * k + 2] = 10.0f * cosf(th);
            k++;
        }
    int t = 0;
    for (int i = 0; i < RINGS; i++)
        for (int s = 0; s < SIDES; s++) {
            const uint32_t a = (uint32_t)(i * SIDES + s), b = (uint32_t)(i * SIDES + (s + 1) % SIDES);
            const uint32_t c = a + SIDES, e = b + SIDES;
            idx[t++] = a;
            idx[t++] = c;
            idx[t++] = e;
            idx[t++] = a;
            idx[t++] = e;
            idx[t++] = b;
        }
    sq_mesh_desc d;
    memset(&d, 0, sizeof d);
    d.name = "sphere";
    d.vertex_count = nv;
    d.positions = p;
    d.index_count = t;
    d.indices = idx;
    sq_mesh *m = NULL;
    SQ_CHECK(sq_mesh_create(ctx, &d, &m) == SQ_OK);
    SQ_CHECK(sq_mesh_generate_lods(ctx, m, 4) == SQ_OK);
    SQ_CHECK_MSG(m->lod_count >= 3, "only %d LODs", m->lod_count);
    for (int l = 1; l < m->lod_count; l++) {
        const int64_t f0 = sq_mesh_face_count(m, l - 1), f1 = sq_mesh_face_count(m, l);
        SQ_CHECK_MSG(f1 <= f0 * 3 / 4, "LOD %d has %lld faces, LOD %d %lld", l, (long long)f1, l - 1, (long long)f0);
        SQ_CHECK(m->lods[l].error_m > m->lods[l - 1].error_m);
        /* every vertex of a level is the mean of vertices on the sphere inside one cell: within
         * the cell's diagonal of the surface, and never outside it */
        const sq_mesh_lod *L = &m->lods[l];
        double worst = 0.0;
        for (int v = 0; v < L->vertex_count; v++) {
            const double r = sqrt((double)L->positions[3 * v] * L->positions[3 * v] +
                                  (double)L->positions[3 * v + 1] * L->positions[3 * v + 1] +
                                  (double)L->positions[3 * v + 2] * L->positions[3 * v + 2]);
            SQ_CHECK(r <= 10.0 + 1e-3);
            worst = fmax(worst, 10.0 - r);
        }
        SQ_CHECK_MSG(worst <= sqrt(3.0) * m->lods[l].error_m, "LOD %d: %g m inside (cell %g m)", l, worst,
                     (double)m->lods[l].error_m);
    }
    sq_mesh_destroy(ctx, m);
    free(p);
    free(idx);
    sq_context_destroy(ctx);
}

/* Cells of size h over a box region whose centres sq_world_solid_at finds inside meshes
 * (above the terrain at z = 0), times h^3. */
static double voxel_volume(const sq_world *w, sq_vec3 lo, sq_vec3 hi, double h)
{
    const int nx = (int)ceil((hi.x - lo.x) / h), ny = (int)ceil((hi.y - lo.y) / h),
              nz = (int)ceil((hi.z - lo.z) / h);
    long n = 0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const sq_vec3 p = sq_v3((float)(lo.x + (i + 0.5) * h), (float)(lo.y + (j + 0.5) * h),
                                        (float)(lo.z + (k + 0.5) * h));
                n += sq_world_solid_at(w, p);
            }
    return (double)n * h * h * h;
}

SQ_TEST(voxelised_house_matches_analytic_volume)
{
    sq_context *ctx = make_ctx();
    sq_world *w = flat_world(ctx, 200.0f);
    const float L = 12.0f, Wd = 8.0f, H = 5.0f, R = 3.0f;
    sq_mesh *m = house(ctx, L, Wd, H, R);
    const double analytic = (double)L * Wd * H + 0.5 * (double)L * Wd * R; /* 480 + 144 */
    SQ_CHECK_MSG(fabs(sq_mesh_volume(m) - analytic) < 1e-3, "mesh volume %g, analytic %g",
                 sq_mesh_volume(m), analytic);
    SQ_CHECK(m->solid);
    sq_mesh_instance in;
    memset(&in, 0, sizeof in);
    in.position_m = sq_v3(3.3f, -2.1f, 0.1f); /* base and wall top on cell faces (no bias) */
    in.yaw_deg = 30.0f;
    const sq_mesh *list[1] = {m};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_OK);
    SQ_CHECK(sq_world_mesh_face_count(w) == 20);
    /* h = 0.1 m: the discretisation error is about (surface area) x h x (mean |offset| ~ h/4)
     * with random signs (~0.1 %); a 0.5 % bound is several times that for this 624 m^3 house */
    const double v = voxel_volume(w, sq_v3(-10, -10, 0.0f), sq_v3(16, 6, 9), 0.1);
    printf("voxelised %.4f m^3, analytic %.4f m^3 (%.4f %%)\n", v, analytic, 100.0 * (v - analytic) / analytic);
    SQ_CHECK_MSG(fabs(v - analytic) < 0.005 * analytic, "voxelised %g m^3, analytic %g", v, analytic);
    /* a point in the roof, one above the ridge, one between wall top and roof corner */
    const float c = cosf(30.0f * SQ_PI_F / 180.0f), s = sinf(30.0f * SQ_PI_F / 180.0f);
    const sq_vec3 o = in.position_m;
#define AT(lx, ly, lz) sq_v3(o.x + c * (lx) - s * (ly), o.y + s * (lx) + c * (ly), o.z + (lz))
    SQ_CHECK(sq_world_solid_at(w, AT(0.0f, 0.0f, H + R - 0.05f)));
    SQ_CHECK(!sq_world_solid_at(w, AT(0.0f, 0.0f, H + R + 0.05f)));
    SQ_CHECK(!sq_world_solid_at(w, AT(0.0f, 3.9f, H + 0.5f))); /* outside the slope */
    SQ_CHECK(sq_world_solid_at(w, AT(0.0f, 3.9f, H - 0.1f)));
    /* the surface over the ridge line and down the slope: R (1 - |y| / (W/2)) above the walls */
    for (float ly = -3.5f; ly <= 3.5f; ly += 0.7f) {
        const float expect = o.z + H + R * (1.0f - fabsf(ly) / (0.5f * Wd));
        const sq_vec3 q = AT(1.3f, ly, 0.0f);
        const float got = sq_world_surface_at(w, q.x, q.y);
        SQ_CHECK_MSG(fabsf(got - expect) < 1e-3f, "surface at y = %g: %g, expected %g", (double)ly,
                     (double)got, (double)expect);
    }
#undef AT
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

/* Two boxes overlapping by half, placed with one instance each, and a box touching another on a
 * face: the solid is their union (the winding number counts the overlap once). */
SQ_TEST(overlapping_instances_are_a_union)
{
    sq_context *ctx = make_ctx();
    sq_world *w = flat_world(ctx, 100.0f);
    sq_mesh *m = NULL;
    SQ_CHECK(box(ctx, sq_v3(-1, -1, 0), sq_v3(1, 1, 2), &m) == SQ_OK);
    sq_mesh_instance in[3];
    memset(in, 0, sizeof in);
    in[0].position_m = sq_v3(0.0f, 0.0f, 0.0f);
    in[1].position_m = sq_v3(1.0f, 0.0f, 0.0f);   /* overlaps half of the first */
    in[2].position_m = sq_v3(-10.0f, 0.0f, 0.0f);
    in[2].scale = sq_v3(1.5f, 0.5f, 2.0f);          /* 3 x 1 x 4 = 12 m^3 */
    const sq_mesh *list[1] = {m};
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, in, 3) == SQ_OK);
    const double v = voxel_volume(w, sq_v3(-13, -3, 0.0f), sq_v3(4, 3, 5), 0.05);
    const double analytic = 3.0 * 2.0 * 2.0 + 12.0;
    SQ_CHECK_MSG(fabs(v - analytic) < 0.005 * analytic, "union %g m^3, analytic %g", v, analytic);
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

SQ_TEST(placement_rules)
{
    sq_context *ctx = make_ctx();
    sq_world *w = flat_world(ctx, 100.0f); /* x, y in -50..50 */
    sq_mesh *m = NULL;
    SQ_CHECK(box(ctx, sq_v3(-5, -5, 0), sq_v3(5, 5, 3), &m) == SQ_OK);
    const sq_mesh *list[1] = {m};
    sq_mesh_instance in;
    memset(&in, 0, sizeof in);
    in.position_m = sq_v3(46.0f, 0.0f, NAN); /* footprint to x = 51 */
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_ERR_INVALID_ARG);
    SQ_CHECK_MSG(strstr(sq_last_error(), "reaches outside the terrain"), "%s", sq_last_error());
    in.position_m = sq_v3(0.0f, 0.0f, NAN);
    in.scale = sq_v3(1.0f, -1.0f, 1.0f);
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_ERR_INVALID_ARG);
    SQ_CHECK_MSG(strstr(sq_last_error(), "scale"), "%s", sq_last_error());
    in.scale = sq_v3(0, 0, 0);
    in.mesh = 1;
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_ERR_INVALID_ARG);
    in.mesh = 0;
    const uint64_t g = sq_world_generation(w);
    SQ_CHECK(sq_world_set_meshes(ctx, w, list, 1, &in, 1) == SQ_OK);
    SQ_CHECK(sq_world_generation(w) != g);
    const sq_mesh_instance *placed = NULL;
    SQ_CHECK(sq_world_mesh_instances(w, NULL, NULL, &placed) == 1);
    SQ_CHECK(placed[0].position_m.z == 0.0f); /* on the flat terrain */
    SQ_CHECK(placed[0].scale.x == 1.0f);
    /* removing the meshes leaves an empty world */
    SQ_CHECK(sq_world_set_meshes(ctx, w, NULL, 0, NULL, 0) == SQ_OK);
    SQ_CHECK(!sq_world_solid_at(w, sq_v3(0, 0, 1)));
    sq_world_destroy(ctx, w);
    sq_mesh_destroy(ctx, m);
    sq_context_destroy(ctx);
}

static sq_place *make_place(sq_context *ctx, sq_place_kind kind, float size, uint64_t seed)
{
    sq_place_desc d;
    memset(&d, 0, sizeof d);
    d.kind = kind;
    d.size_m[0] = d.size_m[1] = size;
    d.seed = seed;
    sq_place *p = NULL;
    if (sq_place_generate(ctx, &d, &p) != SQ_OK) {
        fprintf(stderr, "place: %s\n", sq_last_error());
        exit(1);
    }
    return p;
}

static bool same_place(const sq_place *a, const sq_place *b)
{
    if (a->mesh_count != b->mesh_count || a->instance_count != b->instance_count || a->faces != b->faces)
        return false;
    if (memcmp(a->instances, b->instances, (size_t)a->instance_count * sizeof *a->instances) != 0)
        return false;
    for (int i = 0; i < a->mesh_count; i++) {
        const sq_mesh_lod *x = &a->meshes[i]->lods[0], *y = &b->meshes[i]->lods[0];
        if (x->vertex_count != y->vertex_count || x->index_count != y->index_count ||
            memcmp(x->positions, y->positions, (size_t)x->vertex_count * 3 * sizeof(float)) != 0)
            return false;
    }
    return true;
}

SQ_TEST(places_deterministic_from_seed)
{
    sq_context *ctx = make_ctx();
    for (int kind = SQ_PLACE_SUBURB; kind <= SQ_PLACE_TOWN; kind++) {
        sq_place *a = make_place(ctx, (sq_place_kind)kind, 600.0f, 42);
        sq_place *b = make_place(ctx, (sq_place_kind)kind, 600.0f, 42);
        sq_place *c = make_place(ctx, (sq_place_kind)kind, 600.0f, 43);
        SQ_CHECK_MSG(same_place(a, b), "kind %d: same seed, different places", kind);
        SQ_CHECK_MSG(!same_place(a, c), "kind %d: seeds 42 and 43 give the same place", kind);
        SQ_CHECK(a->houses > 10 && a->trees > 10 && a->cars > 5);
        sq_place_destroy(ctx, a);
        sq_place_destroy(ctx, b);
        sq_place_destroy(ctx, c);
    }
    sq_context_destroy(ctx);
}

static void lod_box(const sq_mesh_lod *L, double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++) {
        lo[a] = 1e30;
        hi[a] = -1e30;
    }
    for (int v = 0; v < L->vertex_count; v++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], (double)L->positions[3 * v + a]);
            hi[a] = fmax(hi[a], (double)L->positions[3 * v + a]);
        }
}

/* The hand-made levels of the procedural prototypes (chosen per instance by the renderer when
 * their error_m projects below output.lod_pixels): each level has fewer faces and a larger error
 * than the one before, and its bounding box stays within its error of the full level's box on
 * every side (a tree does not grow or shrink when it changes level); the trees have a far level
 * (one crown / one cone) of at most half the faces of the level before it. */
SQ_TEST(procedural_levels_shrink_within_their_error)
{
    sq_context *ctx = make_ctx();
    sq_place *p = make_place(ctx, SQ_PLACE_SUBURB, 600.0f, 42);
    int far_trees = 0;
    for (int i = 0; i < p->mesh_count; i++) {
        const sq_mesh *m = p->meshes[i];
        if (strncmp(m->name, "ground", 6) == 0) continue; /* vertex-clustered: tested above */
        double lo0[3], hi0[3];
        lod_box(&m->lods[0], lo0, hi0);
        for (int l = 1; l < m->lod_count; l++) {
            const int64_t f0 = sq_mesh_face_count(m, l - 1), f1 = sq_mesh_face_count(m, l);
            SQ_CHECK_MSG(f1 < f0, "%s: LOD %d has %lld faces, LOD %d %lld", m->name, l, (long long)f1,
                         l - 1, (long long)f0);
            SQ_CHECK_MSG(m->lods[l].error_m > m->lods[l - 1].error_m, "%s: LOD %d error %g m", m->name,
                         l, (double)m->lods[l].error_m);
            double lo[3], hi[3], worst = 0.0;
            lod_box(&m->lods[l], lo, hi);
            for (int a = 0; a < 3; a++) worst = fmax(worst, fmax(fabs(lo[a] - lo0[a]), fabs(hi[a] - hi0[a])));
            SQ_CHECK_MSG(worst <= (double)m->lods[l].error_m, "%s: LOD %d box %.3f m off LOD 0's (error %.3f m)",
                         m->name, l, worst, (double)m->lods[l].error_m);
        }
        if (strstr(m->name, "tree") && m->lod_count == 4) {
            far_trees++;
            SQ_CHECK_MSG(sq_mesh_face_count(m, 3) * 2 <= sq_mesh_face_count(m, 2), "%s: far level %lld faces, coarse %lld",
                         m->name, (long long)sq_mesh_face_count(m, 3), (long long)sq_mesh_face_count(m, 2));
        }
    }
    SQ_CHECK_MSG(far_trees >= 4, "%d trees with a far level", far_trees);
    sq_place_destroy(ctx, p);
    sq_context_destroy(ctx);
}

/* A house's coarser levels keep what a viewer sees on its walls: its door and windows become
 * flat quads rather than vanishing (the door and, on the far level, every window popped in and
 * out as the camera came near). */
static bool lod_uses_material(const sq_mesh *m, int l, const char *material)
{
    for (int k = 0; k < m->lods[l].part_count; k++) {
        const int mi = m->lods[l].parts[k].material;
        if (m->lods[l].parts[k].index_count > 0 && strcmp(m->materials[mi].name, material) == 0)
            return true;
    }
    return false;
}

SQ_TEST(house_levels_keep_doors_and_windows)
{
    sq_context *ctx = make_ctx();
    sq_place *p = make_place(ctx, SQ_PLACE_SUBURB, 600.0f, 42);
    int houses = 0;
    for (int i = 0; i < p->mesh_count; i++) {
        const sq_mesh *m = p->meshes[i];
        if (strncmp(m->name, "house", 5) != 0 || m->lod_count < 2) continue;
        houses++;
        const char *seen[] = {"door", "glass"};
        for (int l = 1; l < m->lod_count; l++)
            for (int k = 0; k < 2; k++)
                if (lod_uses_material(m, 0, seen[k]))
                    SQ_CHECK_MSG(lod_uses_material(m, l, seen[k]), "%s: LOD %d has no %s (LOD 0 has)",
                                 m->name, l, seen[k]);
    }
    SQ_CHECK_MSG(houses >= 4, "%d houses with levels", houses);
    sq_place_destroy(ctx, p);
    sq_context_destroy(ctx);
}

/* S2 reports a 4 km x 4 km suburb of more than 1 M faces and a town of more than 7 M; the issue
 * asks >= 1 M and >= 5 M. Every generated prototype is a closed solid. */
SQ_TEST(places_reach_their_face_counts)
{
    sq_context *ctx = make_ctx();
    sq_place *s = make_place(ctx, SQ_PLACE_SUBURB, 4000.0f, 1);
    sq_place *t = make_place(ctx, SQ_PLACE_TOWN, 2000.0f, 1);
    printf("suburb 4 km: %lld faces, %d houses, %d trees, %d cars, %.1f MB (%.2f bytes/face)\n",
           (long long)s->faces, s->houses, s->trees, s->cars, (double)s->bytes / 1e6,
           (double)s->bytes / (double)s->faces);
    printf("town 2 km: %lld faces, %d buildings, %d trees, %d cars, %.1f MB (%.2f bytes/face)\n",
           (long long)t->faces, t->houses, t->trees, t->cars, (double)t->bytes / 1e6,
           (double)t->bytes / (double)t->faces);
    SQ_CHECK(s->faces >= 1000000);
    SQ_CHECK(t->faces >= 5000000);
    for (int i = 0; i < s->mesh_count; i++)
        if (strncmp(s->meshes[i]->name, "ground", 6) != 0)
            SQ_CHECK_MSG(s->meshes[i]->solid && sq_mesh_volume(s->meshes[i]) > 0.0, "%s is not a closed solid",
                         s->meshes[i]->name);
    sq_place_destroy(ctx, s);
    sq_place_destroy(ctx, t);
    sq_context_destroy(ctx);
}

/* sq_world_voxelise (one vertical line per column, as the sandstorm grid and the snowdrift
 * lattice voxelise the world) gives sq_world_solid_at's answer at every cell centre: a 300 m
 * town on hills with an obstacle house, on cells of 0.7 m not aligned with anything. */
SQ_TEST(voxelise_equals_point_queries_over_a_town)
{
    sq_context *ctx = make_ctx();
    sq_obstacle ob;
    memset(&ob, 0, sizeof ob);
    ob.kind = SQ_OBSTACLE_HOUSE;
    ob.center_m = sq_v3(-20.0f, 35.0f, NAN);
    ob.size_m = sq_v3(9.0f, 7.0f, 4.0f);
    ob.roof_m = 2.5f;
    ob.yaw_deg = 20.0f;
    sq_world_desc wd;
    memset(&wd, 0, sizeof wd);
    wd.terrain.kind = SQ_TERRAIN_HILLS;
    wd.terrain.size_m[0] = wd.terrain.size_m[1] = 400.0f;
    wd.terrain.resolution[0] = wd.terrain.resolution[1] = 101;
    wd.terrain.relief_m = 6.0f;
    wd.obstacles = &ob;
    wd.obstacle_count = 1;
    sq_world *w = NULL;
    SQ_CHECK(sq_world_create(ctx, &wd, &w) == SQ_OK);
    sq_place *pl = make_place(ctx, SQ_PLACE_TOWN, 300.0f, 7);
    SQ_CHECK(sq_world_set_meshes(ctx, w, (const sq_mesh *const *)pl->meshes, pl->mesh_count,
                                 pl->instances, pl->instance_count) == SQ_OK);
    const int n[3] = {150, 150, 40};
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    const double h = 0.7, origin[3] = {-60.03, -40.011, (double)t.height_min - 1.13};
    const size_t cells = (size_t)n[0] * n[1] * n[2];
    uint8_t *m = (uint8_t *)malloc(cells);
    SQ_CHECK(m != NULL);
    if (!m) return;
    SQ_CHECK(sq_world_voxelise(w, origin, h, n, SQ_SOLID_ALL, m) == SQ_OK);
    size_t mismatch = 0, solid = 0, mesh_solid = 0;
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                const sq_vec3 p = sq_v3((float)(origin[0] + (i + 0.5) * h),
                                        (float)(origin[1] + (j + 0.5) * h),
                                        (float)(origin[2] + (k + 0.5) * h));
                const bool s = sq_world_solid_at(w, p);
                const uint8_t v = m[(size_t)i + (size_t)n[0] * ((size_t)j + (size_t)n[1] * k)];
                mismatch += (v != 0) != s;
                solid += s;
                mesh_solid += s && p.z > sq_world_height_at(w, p.x, p.y);
            }
    printf("%zu cells, %zu solid (%zu above the terrain), %zu differ\n", cells, solid, mesh_solid,
           mismatch);
    SQ_CHECK(mismatch == 0);
    SQ_CHECK(mesh_solid > 10000); /* buildings and the obstacle were really in the box */
    const double bad_o[3] = {0, 0, 0};
    const int bad_n[3] = {4, 0, 4};
    SQ_CHECK(sq_world_voxelise(w, bad_o, h, bad_n, SQ_SOLID_ALL, m) == SQ_ERR_INVALID_ARG);
    free(m);
    sq_world_destroy(ctx, w);
    sq_place_destroy(ctx, pl);
    sq_context_destroy(ctx);
}
