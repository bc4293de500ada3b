/* procgen_place.c — whole places from a seed (sq_place_generate):
 *   suburb  a street grid (local streets and tree-lined avenues, sidewalks with kerbs) around
 *           blocks of two rows of garden plots; on each plot a detached house (one of ~30
 *           prototypes: gable or hip roof, one or two storeys, garage, porch, chimney) set back
 *           behind a front garden with a picket fence or hedge, a driveway with a car, trees in
 *           front and back gardens, a board fence at the back; parks with scattered trees and
 *           paths; a pavilion in the central park;
 *   town    perimeter blocks of terraced town houses and apartment buildings (3–6 storeys,
 *           shops on the ground floor along avenues, gable or flat roofs) with corner
 *           buildings, courtyard trees, street trees, parked cars and lamps, and a square.
 * Everything is deterministic from the seed: each decision draws from its own (stream, index)
 * of the counter-based generator. Roads, sidewalks, driveways and paths are draped on the
 * ground through desc->height_at and cut into 256 m tiles (one mesh each) so they are culled
 * like everything else. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core_internal.h"
#include "procgen_internal.h"

#define DEG (SQ_PI_F / 180.0f)
#define TILE_M 256.0f

/* random streams */
enum {
    S_XSTREET = 1, S_YSTREET, S_PARK, S_PLOT, S_HOUSE, S_SETBACK, S_TINT, S_TREE, S_FENCE,
    S_CAR, S_MISC, S_BUILD
};

typedef struct gen {
    sq_context *ctx;
    const sq_place_desc *d;
    sq_place *p;
    int cap_m, cap_i;
    sq_result err;
    /* ground tiles */
    int tiles_x, tiles_y;
    float tile_x0, tile_y0;
    pg_mesh *tiles;
    /* prototype indices */
    int houses[40], house_count;
    float house_w[40], house_d[40], house_walls[40]; /* footprint width (garage included), depth, walls */
    bool house_garage[40];
    int trees[3][4], tree_count[3];
    int cars[4];
    int picket, boards, hedge, pavilion, lamp;
    int buildings[64], building_count;
    float building_w[64];
    int building_storeys[64];
    bool building_shop[64];
    uint64_t counter; /* index for draws that need a fresh number */
} gen;

static float rnd(const gen *g, int stream, uint64_t i) { return pg_rand(g->d->seed, (uint64_t)stream, i); }

static float ground(const gen *g, float x, float y)
{
    return g->d->height_at ? g->d->height_at(g->d->height_user, x, y) : 0.0f;
}

static int add_mesh(gen *g, sq_result r, sq_mesh *m)
{
    if (g->err == SQ_OK && r == SQ_OK && sq__cancelled(g->ctx)) /* Ctrl-C: once per mesh */
        g->err = sq__fail_cancelled(g->ctx, "place", "while generating the place's meshes");
    if (g->err != SQ_OK) {
        sq_mesh_destroy(g->ctx, m);
        return -1;
    }
    if (r != SQ_OK) {
        g->err = r;
        return -1;
    }
    if (g->p->mesh_count == g->cap_m) {
        const int nc = g->cap_m ? 2 * g->cap_m : 64;
        sq_mesh **q = sq_alloc(g->ctx, (size_t)nc * sizeof *q);
        if (!q) {
            sq_mesh_destroy(g->ctx, m);
            g->err = SQ_ERR_OUT_OF_MEMORY;
            return -1;
        }
        if (g->p->meshes) memcpy(q, g->p->meshes, (size_t)g->p->mesh_count * sizeof *q);
        sq_free(g->ctx, g->p->meshes);
        g->p->meshes = q;
        g->cap_m = nc;
    }
    g->p->meshes[g->p->mesh_count] = m;
    g->p->bytes += m->bytes;
    return g->p->mesh_count++;
}

static void place(gen *g, int mesh, float x, float y, float yaw_deg, float scale, sq_vec3 t0,
                  sq_vec3 t1)
{
    if (g->err != SQ_OK || mesh < 0) return;
    if (g->p->instance_count == g->cap_i) {
        const int nc = g->cap_i ? 2 * g->cap_i : 4096;
        sq_mesh_instance *q = sq_alloc(g->ctx, (size_t)nc * sizeof *q);
        if (!q) {
            g->err = SQ_ERR_OUT_OF_MEMORY;
            return;
        }
        if (g->p->instances)
            memcpy(q, g->p->instances, (size_t)g->p->instance_count * sizeof *q);
        sq_free(g->ctx, g->p->instances);
        g->p->instances = q;
        g->cap_i = nc;
    }
    sq_mesh_instance *in = &g->p->instances[g->p->instance_count++];
    memset(in, 0, sizeof *in);
    in->mesh = mesh;
    in->position_m = sq_v3(x, y, NAN);
    in->yaw_deg = yaw_deg;
    in->scale = sq_v3(scale, scale, scale);
    in->tint[0] = t0;
    in->tint[1] = t1;
    g->p->faces += sq_mesh_face_count(g->p->meshes[mesh], 0);
}

/* ---- palettes (linear albedo) ------------------------------------------------------------- */
static const float WALLS[][3] = {
    {0.70f, 0.62f, 0.48f}, {0.76f, 0.75f, 0.71f}, {0.72f, 0.62f, 0.36f}, {0.55f, 0.55f, 0.53f},
    {0.45f, 0.50f, 0.40f}, {0.36f, 0.14f, 0.09f}, {0.55f, 0.42f, 0.30f}, {0.50f, 0.58f, 0.66f},
    {0.70f, 0.46f, 0.36f}, {0.62f, 0.60f, 0.55f}, {0.44f, 0.22f, 0.14f}, {0.78f, 0.70f, 0.58f}};
static const float ROOFS[][3] = {{0.07f, 0.07f, 0.08f}, {0.25f, 0.09f, 0.06f}, {0.17f, 0.10f, 0.07f},
                                 {0.11f, 0.12f, 0.14f}, {0.38f, 0.13f, 0.07f}, {0.09f, 0.11f, 0.09f},
                                 {0.30f, 0.28f, 0.26f}};
static const float PAINTS[][3] = {{0.50f, 0.04f, 0.03f}, {0.03f, 0.06f, 0.20f}, {0.60f, 0.60f, 0.60f},
                                  {0.02f, 0.02f, 0.02f}, {0.75f, 0.75f, 0.74f}, {0.10f, 0.22f, 0.12f},
                                  {0.25f, 0.25f, 0.26f}, {0.55f, 0.35f, 0.05f}};
#define NWALLS (int)(sizeof WALLS / sizeof WALLS[0])
#define NROOFS (int)(sizeof ROOFS / sizeof ROOFS[0])
#define NPAINTS (int)(sizeof PAINTS / sizeof PAINTS[0])

static sq_vec3 pick(const float (*pal)[3], int n, float u)
{
    int i = (int)(u * (float)n);
    if (i >= n) i = n - 1;
    return sq_v3(pal[i][0], pal[i][1], pal[i][2]);
}

static sq_vec3 foliage_tint(const gen *g, uint64_t i)
{
    const float u = rnd(g, S_TINT, 7000000u + i), v = rnd(g, S_TINT, 8000000u + i);
    return sq_v3(0.035f + 0.04f * u, 0.09f + 0.06f * v, 0.03f + 0.025f * u);
}

/* ---- ground tiles (roads, sidewalks, driveways, paths) ------------------------------------- */
enum { G_ASPHALT, G_CONCRETE, G_DRIVE, G_PATH, G_PAVING, G_NMAT };

static pg_mesh *tile_at(gen *g, float x, float y)
{
    int i = (int)floorf((x - g->tile_x0) / TILE_M), j = (int)floorf((y - g->tile_y0) / TILE_M);
    i = i < 0 ? 0 : (i >= g->tiles_x ? g->tiles_x - 1 : i);
    j = j < 0 ? 0 : (j >= g->tiles_y ? g->tiles_y - 1 : j);
    return &g->tiles[j * g->tiles_x + i];
}

/* A strip from (x0, y0) to (x1, y1), half width hw, lying dz above the ground, cut into pieces
 * of at most 12 m (each in the tile of its centre). kerb: also a vertical face down to the road
 * on the left (-1), right (+1) or both (2) sides. */
static void strip(gen *g, float x0, float y0, float x1, float y1, float hw, float dz, int mat,
                  int kerb)
{
    const float dx = x1 - x0, dy = y1 - y0, len = sqrtf(dx * dx + dy * dy);
    if (!(len > 0.01f)) return;
    const float nx = -dy / len * hw, ny = dx / len * hw;
    const int n = (int)ceilf(len / 12.0f);
    for (int k = 0; k < n; k++) {
        const float t0 = (float)k / (float)n, t1 = (float)(k + 1) / (float)n;
        const float ax = x0 + dx * t0, ay = y0 + dy * t0, bx = x0 + dx * t1, by = y0 + dy * t1;
        pg_mesh *b = tile_at(g, 0.5f * (ax + bx), 0.5f * (ay + by));
        const sq_vec3 pl0 = sq_v3(ax + nx, ay + ny, 0), pr0 = sq_v3(ax - nx, ay - ny, 0);
        const sq_vec3 pl1 = sq_v3(bx + nx, by + ny, 0), pr1 = sq_v3(bx - nx, by - ny, 0);
        const float zl0 = ground(g, pl0.x, pl0.y) + dz, zr0 = ground(g, pr0.x, pr0.y) + dz;
        const float zl1 = ground(g, pl1.x, pl1.y) + dz, zr1 = ground(g, pr1.x, pr1.y) + dz;
        const int a = pg_vertex(b, sq_v3(pr0.x, pr0.y, zr0)), c = pg_vertex(b, sq_v3(pr1.x, pr1.y, zr1)),
                  d = pg_vertex(b, sq_v3(pl1.x, pl1.y, zl1)), e = pg_vertex(b, sq_v3(pl0.x, pl0.y, zl0));
        pg_quad(b, a, c, d, e, mat);
        if (kerb == 1 || kerb == 2) { /* right side face */
            const int f0 = pg_vertex(b, sq_v3(pr0.x, pr0.y, zr0 - dz + 0.02f)),
                      f1 = pg_vertex(b, sq_v3(pr1.x, pr1.y, zr1 - dz + 0.02f));
            pg_quad(b, f0, f1, c, a, G_CONCRETE);
        }
        if (kerb == -1 || kerb == 2) {
            const int f0 = pg_vertex(b, sq_v3(pl0.x, pl0.y, zl0 - dz + 0.02f)),
                      f1 = pg_vertex(b, sq_v3(pl1.x, pl1.y, zl1 - dz + 0.02f));
            pg_quad(b, f1, f0, e, d, G_CONCRETE);
        }
    }
}

/* A paved disc (plaza) of radius r around (x, y). */
static void disc(gen *g, float x, float y, float r, float dz, int mat)
{
    pg_mesh *b = tile_at(g, x, y);
    const int c = pg_vertex(b, sq_v3(x, y, ground(g, x, y) + dz));
    const int n = 24, first = b->nv;
    for (int k = 0; k < n; k++) {
        const float t = 2.0f * SQ_PI_F * (float)k / (float)n;
        const float px = x + r * cosf(t), py = y + r * sinf(t);
        pg_vertex(b, sq_v3(px, py, ground(g, px, py) + dz));
    }
    for (int k = 0; k < n; k++) pg_tri(b, c, first + k, first + (k + 1) % n, mat);
}

static sq_result tiles_init(gen *g)
{
    const sq_place_desc *d = g->d;
    g->tile_x0 = d->center_m[0] - 0.5f * d->size_m[0];
    g->tile_y0 = d->center_m[1] - 0.5f * d->size_m[1];
    g->tiles_x = (int)ceilf(d->size_m[0] / TILE_M);
    g->tiles_y = (int)ceilf(d->size_m[1] / TILE_M);
    g->tiles = sq_alloc_zero(g->ctx, (size_t)g->tiles_x * (size_t)g->tiles_y * sizeof(pg_mesh));
    if (!g->tiles) return SQ_ERR_OUT_OF_MEMORY;
    for (int i = 0; i < g->tiles_x * g->tiles_y; i++) pg_init(&g->tiles[i], g->ctx);
    return SQ_OK;
}

static void tiles_finish(gen *g)
{
    sq_mesh_material m[G_NMAT];
    memset(m, 0, sizeof m);
    const char *names[G_NMAT] = {"asphalt", "sidewalk", "driveway", "gravel path", "paving"};
    const float col[G_NMAT][3] = {{0.055f, 0.055f, 0.06f}, {0.36f, 0.35f, 0.33f}, {0.27f, 0.26f, 0.25f},
                                  {0.40f, 0.34f, 0.26f}, {0.42f, 0.38f, 0.34f}};
    for (int i = 0; i < G_NMAT; i++) {
        snprintf(m[i].name, sizeof m[i].name, "%s", names[i]);
        m[i].base_color = sq_v3(col[i][0], col[i][1], col[i][2]);
    }
    for (int j = 0; j < g->tiles_y; j++)
        for (int i = 0; i < g->tiles_x; i++) {
            pg_mesh *b = &g->tiles[j * g->tiles_x + i];
            if (g->err == SQ_OK && b->nt > 0) {
                char name[48];
                snprintf(name, sizeof name, "ground tile %d,%d", i, j);
                sq_mesh *mesh = NULL;
                sq_result r = pg_to_mesh(b, name, m, G_NMAT, true, &mesh);
                if (r == SQ_OK) r = sq_mesh_generate_lods(g->ctx, mesh, 2);
                const int id = add_mesh(g, r, mesh);
                if (id >= 0) {
                    /* vertices are in world coordinates: an instance at the origin, z given */
                    place(g, id, 0.0f, 0.0f, 0.0f, 1.0f, sq_v3(0, 0, 0), sq_v3(0, 0, 0));
                    g->p->instances[g->p->instance_count - 1].position_m.z = 0.0f;
                }
            }
            pg_free(b);
        }
    sq_free(g->ctx, g->tiles);
    g->tiles = NULL;
}

/* ---- prototype library -------------------------------------------------------------------- */
static void make_trees(gen *g)
{
    static const float heights[3][4] = {{9.0f, 12.0f, 15.0f, 19.0f}, {7.0f, 9.5f, 12.0f, 15.0f},
                                        {8.0f, 11.0f, 14.0f, 0.0f}};
    for (int k = 0; k < 3; k++)
        for (int i = 0; i < 4 && heights[k][i] > 0.0f; i++) {
            sq_mesh *m = NULL;
            const sq_result r = pg_make_tree(g->ctx, (pg_tree_kind)k, heights[k][i],
                                             g->d->seed * 31u + (uint64_t)(k * 8 + i), &m);
            g->trees[k][g->tree_count[k]++] = add_mesh(g, r, m);
        }
}

static void make_common(gen *g)
{
    make_trees(g);
    for (int s = 0; s < 4; s++) {
        sq_mesh *m = NULL;
        const sq_result r = pg_make_car(g->ctx, s, g->d->seed, &m);
        g->cars[s] = add_mesh(g, r, m);
    }
    sq_mesh *m = NULL;
    sq_result r = pg_make_lamp(g->ctx, &m);
    g->lamp = add_mesh(g, r, m);
    r = pg_make_pavilion(g->ctx, 3.2f, &m);
    g->pavilion = add_mesh(g, r, m);
}

static void make_suburb_protos(gen *g)
{
    make_common(g);
    sq_mesh *m = NULL;
    sq_result r = pg_make_fence(g->ctx, 4.0f, true, &m);
    g->picket = add_mesh(g, r, m);
    r = pg_make_fence(g->ctx, 4.0f, false, &m);
    g->boards = add_mesh(g, r, m);
    r = pg_make_hedge(g->ctx, 4.0f, g->d->seed, &m);
    g->hedge = add_mesh(g, r, m);
    g->house_count = 0;
    for (int i = 0; i < 30 && g->err == SQ_OK; i++) {
        pg_house_spec s;
        memset(&s, 0, sizeof s);
        const uint64_t k = (uint64_t)i;
        s.width = 7.5f + 5.5f * rnd(g, S_HOUSE, 10 * k);
        s.depth = 7.0f + 3.5f * rnd(g, S_HOUSE, 10 * k + 1);
        s.storeys = rnd(g, S_HOUSE, 10 * k + 2) < 0.55f ? 2 : 1;
        s.storey_h = 2.8f + 0.3f * rnd(g, S_HOUSE, 10 * k + 3);
        s.roof = rnd(g, S_HOUSE, 10 * k + 4) < 0.6f ? PG_ROOF_GABLE : PG_ROOF_HIP;
        s.pitch_deg = (s.roof == PG_ROOF_GABLE ? 30.0f : 24.0f) + 15.0f * rnd(g, S_HOUSE, 10 * k + 5);
        s.overhang = 0.35f + 0.35f * rnd(g, S_HOUSE, 10 * k + 6);
        s.chimney = rnd(g, S_HOUSE, 10 * k + 7) < 0.5f;
        s.porch = rnd(g, S_HOUSE, 10 * k + 8) < 0.5f;
        s.garage = rnd(g, S_HOUSE, 10 * k + 9) < 0.45f;
        s.seed = g->d->seed + k;
        if (s.roof == PG_ROOF_HIP && s.depth > s.width) s.depth = s.width;
        r = pg_make_house(g->ctx, &s, &m);
        const int id = add_mesh(g, r, m);
        g->houses[g->house_count] = id;
        g->house_w[g->house_count] = s.width + (s.garage ? 3.7f : 0.0f);
        g->house_d[g->house_count] = s.depth;
        g->house_walls[g->house_count] = s.width;
        g->house_garage[g->house_count] = s.garage;
        g->house_count++;
    }
}

/* ---- suburb --------------------------------------------------------------------------------- */
static void tree_at(gen *g, float x, float y, float scale_lo, float scale_hi, bool small)
{
    const uint64_t i = g->counter++;
    float u = rnd(g, S_TREE, 4 * i);
    const float leafless = 0.2f;
    int kind = u < 0.38f ? PG_TREE_CONIFER : (u < 1.0f - leafless * 0.62f ? PG_TREE_BROADLEAF : PG_TREE_BARE);
    const int n = g->tree_count[kind];
    if (n <= 0) return;
    int v = (int)(rnd(g, S_TREE, 4 * i + 1) * (float)(small ? (n + 1) / 2 : n));
    if (v >= n) v = n - 1;
    const float s = scale_lo + (scale_hi - scale_lo) * rnd(g, S_TREE, 4 * i + 2);
    place(g, g->trees[kind][v], x, y, 360.0f * rnd(g, S_TREE, 4 * i + 3), s, foliage_tint(g, i),
          sq_v3(0, 0, 0));
}

/* Street lines: positions from lo to hi with spacings in [step, step + jitter]. */
static int street_lines(const gen *g, int stream, float lo, float hi, float step, float jitter,
                        float *out, int max)
{
    int n = 0;
    float v = lo;
    while (v <= hi && n < max) {
        out[n] = v;
        v += step + jitter * rnd(g, stream, (uint64_t)n);
        n++;
    }
    return n;
}

static float half_width(int index, int every) { return index % every == 0 ? 7.5f : 4.5f; }

/* A plot: frontage along x from px0 to px1, the front line at y = fy, the plot extends inward
 * (dir = +1: toward +y, the house faces -y; dir = -1: toward -y, the house faces +y). */
static void plot(gen *g, float px0, float px1, float fy, float depth, int dir)
{
    const uint64_t k = g->counter++;
    const float F = px1 - px0;
    /* a house that fits with side yards of >= 2.5 m */
    int h = -1;
    for (int t = 0; t < 10; t++) {
        int c = (int)(rnd(g, S_PLOT, 16 * k + (uint64_t)t) * (float)g->house_count);
        if (c >= g->house_count) c = g->house_count - 1;
        if (g->house_w[c] <= F - 5.0f && g->house_d[c] <= depth - 14.0f) {
            h = c;
            break;
        }
    }
    const float yaw = dir > 0 ? 0.0f : 180.0f;
    const float sgn = (float)dir;
    /* the house frame's +x is world +x when it faces -y (dir > 0), world -x otherwise */
    const float gside = dir > 0 ? 1.0f : -1.0f;
    const float setback = 5.5f + 4.0f * rnd(g, S_SETBACK, k);
    float ox = 0.5f * (px0 + px1), hd = 8.0f, walls = 8.0f;
    if (h >= 0) {
        const float slack = F - 5.0f - g->house_w[h];
        const float fx = 0.5f * (px0 + px1) + (rnd(g, S_SETBACK, k + 5000000u) - 0.5f) * slack;
        hd = g->house_d[h];
        walls = g->house_walls[h];
        /* footprint [-w/2, w/2 (+ 3.7 garage)] in the frame: origin = footprint centre - shift */
        ox = fx - gside * (g->house_garage[h] ? 1.85f : 0.0f);
        const float oy = fy + sgn * (setback + 0.5f * hd);
        const sq_vec3 wall = pick(WALLS, NWALLS, rnd(g, S_TINT, 2 * k));
        const sq_vec3 roof = pick(ROOFS, NROOFS, rnd(g, S_TINT, 2 * k + 1));
        place(g, g->houses[h], ox, oy, yaw + 2.0f * (rnd(g, S_MISC, 8 * k) - 0.5f), 1.0f, wall, roof);
    }
    /* the driveway runs to the garage (or a parking pad beside the house) */
    const float drive_x = ox + gside * (0.5f * walls + 1.85f);
    /* driveway from the front line to the house front, and a car on it */
    const float dy0 = fy, dy1 = fy + sgn * (setback + 0.3f);
    strip(g, drive_x, dy0, drive_x, dy1, 1.5f, 0.08f, G_DRIVE, 0);
    if (rnd(g, S_CAR, k) < 0.55f) {
        int s = (int)(rnd(g, S_CAR, k + 1000000u) * 4.0f);
        s = s > 3 ? 3 : s;
        const float cyc = fy + sgn * (0.5f * setback + 0.3f);
        place(g, g->cars[s], drive_x, cyc, rnd(g, S_CAR, k + 2000000u) < 0.5f ? 90.0f : 270.0f, 1.0f,
              pick(PAINTS, NPAINTS, rnd(g, S_CAR, k + 3000000u)), sq_v3(0, 0, 0));
    }
    /* a path to the door */
    const float door_x = ox - gside * 0.22f * walls;
    strip(g, door_x, fy, door_x, fy + sgn * setback, 0.6f, 0.06f, G_PATH, 0);
    /* front boundary: picket fence, hedge or open; sections of 4 m skipping the gaps */
    const float fu = rnd(g, S_FENCE, k);
    const int kind = fu < 0.45f ? g->picket : (fu < 0.72f ? g->hedge : -1);
    const sq_vec3 ftint = kind == g->hedge ? foliage_tint(g, k + 9000000u)
                          : rnd(g, S_FENCE, k + 1) < 0.7f ? sq_v3(0.75f, 0.75f, 0.72f)
                                                          : sq_v3(0.33f, 0.22f, 0.13f);
    const float fline = fy + sgn * 0.45f;
    for (float x = px0 + 0.3f; kind >= 0 && x + 4.0f <= px1 - 0.3f; x += 4.0f) {
        if (fabsf(x + 2.0f - drive_x) < 3.7f || fabsf(x + 2.0f - door_x) < 2.6f) continue;
        place(g, kind, x, fline, 0.0f, 1.0f, ftint, sq_v3(0, 0, 0));
    }
    /* back fence */
    if (rnd(g, S_FENCE, k + 2) < 0.55f)
        for (float x = px0 + 0.1f; x + 4.0f <= px1; x += 4.0f)
            place(g, g->boards, x, fy + sgn * (depth - 0.3f), 0.0f, 1.0f,
                  sq_v3(0.28f, 0.19f, 0.11f), sq_v3(0, 0, 0));
    /* trees: back garden and sometimes one in front */
    const float dens = g->d->tree_density;
    const float back0 = setback + hd + 3.0f, back1 = depth - 2.5f;
    const int nb = (int)floorf(dens * (0.6f + 2.2f * rnd(g, S_TREE, 10000000u + k)));
    for (int t = 0; t < nb && back1 > back0; t++) {
        const float tx = px0 + 2.0f + (F - 4.0f) * rnd(g, S_TREE, 11000000u + 4 * k + (uint64_t)t);
        const float ty = fy + sgn * (back0 + (back1 - back0) * rnd(g, S_TREE, 12000000u + 4 * k + (uint64_t)t));
        tree_at(g, tx, ty, 0.75f, 1.2f, false);
    }
    if (rnd(g, S_TREE, 13000000u + k) < 0.35f * dens) {
        float tx = px0 + 2.0f + (F - 4.0f) * rnd(g, S_TREE, 14000000u + k);
        if (fabsf(tx - drive_x) < 3.0f) tx = drive_x + (tx < drive_x ? -3.0f : 3.0f);
        tree_at(g, tx, fy + sgn * (2.0f + 0.3f * setback), 0.6f, 0.9f, true);
    }
}

static void park(gen *g, float x0, float y0, float x1, float y1, bool pavilion)
{
    const float cx = 0.5f * (x0 + x1), cy = 0.5f * (y0 + y1);
    strip(g, x0, y0, x1, y1, 1.2f, 0.05f, G_PATH, 0);
    strip(g, x0, y1, x1, y0, 1.2f, 0.05f, G_PATH, 0);
    const float clear = pavilion ? 16.0f : 6.0f;
    if (pavilion) {
        disc(g, cx, cy, 12.0f, 0.06f, G_PAVING);
        place(g, g->pavilion, cx, cy, 0.0f, 1.0f, sq_v3(0, 0, 0), sq_v3(0, 0, 0));
    }
    const float step = 13.0f;
    for (float y = y0 + 5.0f; y < y1 - 4.0f; y += step)
        for (float x = x0 + 5.0f; x < x1 - 4.0f; x += step) {
            const uint64_t k = g->counter++;
            if (rnd(g, S_PARK, k) > 0.55f * g->d->tree_density) continue;
            const float tx = x + (rnd(g, S_PARK, k + 1000000u) - 0.5f) * 8.0f;
            const float ty = y + (rnd(g, S_PARK, k + 2000000u) - 0.5f) * 8.0f;
            if (hypotf(tx - cx, ty - cy) < clear) continue;
            /* keep off the diagonal paths */
            const float dx = x1 - x0, dy = y1 - y0, l = hypotf(dx, dy);
            const float d1 = fabsf((tx - x0) * dy - (ty - y0) * dx) / l;
            const float d2 = fabsf((tx - x0) * dy + (ty - y1) * dx) / l;
            if (d1 < 3.5f || d2 < 3.5f) continue;
            tree_at(g, tx, ty, 0.9f, 1.35f, false);
        }
}

static void suburb(gen *g)
{
    const sq_place_desc *d = g->d;
    const float x0 = d->center_m[0] - 0.5f * d->size_m[0], x1 = d->center_m[0] + 0.5f * d->size_m[0];
    const float y0 = d->center_m[1] - 0.5f * d->size_m[1], y1 = d->center_m[1] + 0.5f * d->size_m[1];
    float xs[512], ys[512];
    const int nx = street_lines(g, S_XSTREET, x0 + 9.0f, x1 - 9.0f, 125.0f, 45.0f, xs, 512);
    const int ny = street_lines(g, S_YSTREET, y0 + 9.0f, y1 - 9.0f, 74.0f, 14.0f, ys, 512);
    /* streets: carriageways along whole lines */
    for (int i = 0; i < nx; i++) strip(g, xs[i], y0 + 2.0f, xs[i], y1 - 2.0f, half_width(i, 4), 0.10f, G_ASPHALT, 0);
    for (int j = 0; j < ny; j++) strip(g, x0 + 2.0f, ys[j], x1 - 2.0f, ys[j], half_width(j, 5), 0.11f, G_ASPHALT, 0);
    /* the block nearest the centre is the park with the pavilion */
    int ci = 0, cj = 0;
    float best = 1e30f;
    for (int i = 0; i + 1 < nx; i++)
        for (int j = 0; j + 1 < ny; j++) {
            const float bx = 0.5f * (xs[i] + xs[i + 1]) - d->center_m[0], by = 0.5f * (ys[j] + ys[j + 1]) - d->center_m[1];
            if (bx * bx + by * by < best) {
                best = bx * bx + by * by;
                ci = i;
                cj = j;
            }
        }
    for (int i = 0; i + 1 < nx; i++)
        for (int j = 0; j + 1 < ny; j++) {
            /* block interior inside the sidewalks (2.2 m) */
            const float sw = 2.2f;
            const float bx0 = xs[i] + half_width(i, 4), bx1 = xs[i + 1] - half_width(i + 1, 4);
            const float by0 = ys[j] + half_width(j, 5), by1 = ys[j + 1] - half_width(j + 1, 5);
            /* sidewalks around the block, with kerbs toward the road */
            strip(g, bx0 + sw, by0 + 0.5f * sw, bx1 - sw, by0 + 0.5f * sw, 0.5f * sw, 0.2f, G_CONCRETE, 1);
            strip(g, bx1 - sw, by1 - 0.5f * sw, bx0 + sw, by1 - 0.5f * sw, 0.5f * sw, 0.2f, G_CONCRETE, 1);
            strip(g, bx0 + 0.5f * sw, by1, bx0 + 0.5f * sw, by0, 0.5f * sw, 0.2f, G_CONCRETE, 1);
            strip(g, bx1 - 0.5f * sw, by0, bx1 - 0.5f * sw, by1, 0.5f * sw, 0.2f, G_CONCRETE, 1);
            const float ix0 = bx0 + sw, ix1 = bx1 - sw, iy0 = by0 + sw, iy1 = by1 - sw;
            if (ix1 - ix0 < 20.0f || iy1 - iy0 < 30.0f) continue;
            /* avenue trees along the sidewalk */
            const bool ave_w = i % 4 == 0, ave_s = j % 5 == 0;
            if (ave_w)
                for (float y = iy0 + 6.0f; y < iy1 - 3.0f; y += 16.0f) tree_at(g, bx0 + 1.1f, y, 0.8f, 1.0f, false);
            if (ave_s)
                for (float x = ix0 + 6.0f; x < ix1 - 3.0f; x += 16.0f) tree_at(g, x, by0 + 1.1f, 0.8f, 1.0f, false);
            if (ave_w)
                for (float y = iy0 + 14.0f; y < iy1; y += 36.0f)
                    place(g, g->lamp, bx0 + 0.6f, y, 0.0f, 1.0f, sq_v3(0, 0, 0), sq_v3(0, 0, 0));
            const bool is_park = (i == ci && j == cj) || rnd(g, S_PARK, (uint64_t)(i * 512 + j)) < 0.06f;
            if (is_park) {
                park(g, ix0, iy0, ix1, iy1, i == ci && j == cj);
                continue;
            }
            /* two rows of plots back to back */
            const float depth = 0.5f * (iy1 - iy0);
            for (int row = 0; row < 2; row++) {
                float x = ix0;
                while (x < ix1 - 12.0f) {
                    const uint64_t k = g->counter++;
                    float f = 18.0f + 8.0f * rnd(g, S_PLOT, 1000000000u + k);
                    if (ix1 - (x + f) < 14.0f) f = ix1 - x;
                    if (row == 0) plot(g, x, x + f, iy0, depth, 1);
                    else plot(g, x, x + f, iy1, depth, -1);
                    x += f;
                }
            }
        }
}

/* ---- town ----------------------------------------------------------------------------------- */
static void make_town_protos(gen *g)
{
    make_common(g);
    static const float widths[6] = {8.0f, 10.0f, 12.0f, 14.0f, 16.0f, 18.0f};
    g->building_count = 0;
    for (int i = 0; i < 48 && g->err == SQ_OK; i++) {
        const uint64_t k = (uint64_t)i;
        const float w = widths[i % 6];
        const int storeys = 3 + (int)(4.0f * rnd(g, S_BUILD, 4 * k));
        const bool shop = (i / 6) % 2 == 1;
        const pg_roof roof = rnd(g, S_BUILD, 4 * k + 1) < 0.6f ? PG_ROOF_GABLE : PG_ROOF_FLAT;
        sq_mesh *m = NULL;
        const sq_result r = pg_make_town_building(g->ctx, w, 13.0f, storeys > 6 ? 6 : storeys, roof,
                                                  shop, g->d->seed + k, &m);
        const int id = add_mesh(g, r, m);
        g->buildings[g->building_count] = id;
        g->building_w[g->building_count] = w;
        g->building_storeys[g->building_count] = storeys;
        g->building_shop[g->building_count] = shop;
        g->building_count++;
    }
    /* corner buildings: square 13 x 13 */
    for (int i = 0; i < 4 && g->err == SQ_OK; i++) {
        sq_mesh *m = NULL;
        const sq_result r = pg_make_town_building(g->ctx, 13.0f, 13.0f, 4 + i % 3,
                                                  i % 2 ? PG_ROOF_FLAT : PG_ROOF_GABLE, i >= 2,
                                                  g->d->seed + 100u + (uint64_t)i, &m);
        const int id = add_mesh(g, r, m);
        g->buildings[g->building_count] = id;
        g->building_w[g->building_count] = -13.0f; /* marks a corner building */
        g->building_storeys[g->building_count] = 4 + i % 3;
        g->building_shop[g->building_count] = i >= 2;
        g->building_count++;
    }
}

/* Buildings along one block edge from a to b (along the edge direction), front facing away
 * from the block: yaw of the building frame. */
static void edge_buildings(gen *g, float ax, float ay, float bx, float by, float yaw_deg, bool shops)
{
    const float dx = bx - ax, dy = by - ay, len = hypotf(dx, dy);
    const float ux = dx / len, uy = dy / len;
    /* inward normal: rotate the front direction (-y in the frame) */
    const float yaw = yaw_deg * DEG;
    const float inx = -sinf(yaw), iny = cosf(yaw); /* the frame's +y (its back) in the world */
    float s = 0.0f;
    while (s < len - 7.5f) {
        const uint64_t k = g->counter++;
        int c = -1;
        for (int t = 0; t < 8; t++) {
            int q = (int)(rnd(g, S_BUILD, 100000u + 8 * k + (uint64_t)t) * (float)(g->building_count - 4));
            q = q >= g->building_count - 4 ? g->building_count - 5 : q;
            if (g->building_shop[q] != shops && t < 6) continue;
            if (g->building_w[q] <= len - s + 0.01f) {
                c = q;
                break;
            }
        }
        if (c < 0) break;
        const float w = g->building_w[c];
        const float cx = ax + ux * (s + 0.5f * w) + inx * 6.5f, cy = ay + uy * (s + 0.5f * w) + iny * 6.5f;
        place(g, g->buildings[c], cx, cy, yaw_deg, 1.0f,
              pick(WALLS, NWALLS, rnd(g, S_TINT, 20000000u + k)),
              pick(PAINTS, NPAINTS, rnd(g, S_TINT, 21000000u + k)));
        s += w;
    }
}

static void town(gen *g)
{
    const sq_place_desc *d = g->d;
    const float x0 = d->center_m[0] - 0.5f * d->size_m[0], x1 = d->center_m[0] + 0.5f * d->size_m[0];
    const float y0 = d->center_m[1] - 0.5f * d->size_m[1], y1 = d->center_m[1] + 0.5f * d->size_m[1];
    float xs[512], ys[512];
    const int nx = street_lines(g, S_XSTREET, x0 + 10.0f, x1 - 10.0f, 95.0f, 40.0f, xs, 512);
    const int ny = street_lines(g, S_YSTREET, y0 + 10.0f, y1 - 10.0f, 80.0f, 30.0f, ys, 512);
    for (int i = 0; i < nx; i++) strip(g, xs[i], y0 + 2.0f, xs[i], y1 - 2.0f, i % 3 == 0 ? 8.0f : 6.0f, 0.10f, G_ASPHALT, 0);
    for (int j = 0; j < ny; j++) strip(g, x0 + 2.0f, ys[j], x1 - 2.0f, ys[j], j % 3 == 0 ? 8.0f : 6.0f, 0.11f, G_ASPHALT, 0);
    int ci = nx / 2 - 1, cj = ny / 2 - 1;
    for (int i = 0; i + 1 < nx; i++)
        for (int j = 0; j + 1 < ny; j++) {
            const float hw0 = i % 3 == 0 ? 8.0f : 6.0f, hw1 = (i + 1) % 3 == 0 ? 8.0f : 6.0f;
            const float hs0 = j % 3 == 0 ? 8.0f : 6.0f, hs1 = (j + 1) % 3 == 0 ? 8.0f : 6.0f;
            const float sw = 3.5f;
            const float bx0 = xs[i] + hw0, bx1 = xs[i + 1] - hw1, by0 = ys[j] + hs0, by1 = ys[j + 1] - hs1;
            strip(g, bx0 + sw, by0 + 0.5f * sw, bx1 - sw, by0 + 0.5f * sw, 0.5f * sw, 0.18f, G_CONCRETE, 1);
            strip(g, bx1 - sw, by1 - 0.5f * sw, bx0 + sw, by1 - 0.5f * sw, 0.5f * sw, 0.18f, G_CONCRETE, 1);
            strip(g, bx0 + 0.5f * sw, by1, bx0 + 0.5f * sw, by0, 0.5f * sw, 0.18f, G_CONCRETE, 1);
            strip(g, bx1 - 0.5f * sw, by0, bx1 - 0.5f * sw, by1, 0.5f * sw, 0.18f, G_CONCRETE, 1);
            const float ix0 = bx0 + sw, ix1 = bx1 - sw, iy0 = by0 + sw, iy1 = by1 - sw;
            /* street trees, lamps and parked cars along the sidewalks */
            for (int side = 0; side < 2; side++) {
                const float y = side ? by1 - 1.2f : by0 + 1.2f;
                for (float x = ix0 + 5.0f; x < ix1 - 4.0f; x += 13.0f) tree_at(g, x, y, 0.7f, 0.9f, true);
                for (float x = ix0 + 11.0f; x < ix1 - 4.0f; x += 26.0f)
                    place(g, g->lamp, x, side ? by1 - 0.5f : by0 + 0.5f, side ? 270.0f : 90.0f, 1.0f,
                          sq_v3(0, 0, 0), sq_v3(0, 0, 0));
                const float cy = side ? by1 + 1.3f : by0 - 1.3f;
                for (float x = ix0 + 3.0f; x < ix1 - 3.0f; x += 6.2f) {
                    const uint64_t k = g->counter++;
                    if (rnd(g, S_CAR, k) > 0.55f) continue;
                    int s = (int)(rnd(g, S_CAR, k + 1000000u) * 3.0f);
                    place(g, g->cars[s], x, cy, side ? 180.0f : 0.0f, 1.0f,
                          pick(PAINTS, NPAINTS, rnd(g, S_CAR, k + 3000000u)), sq_v3(0, 0, 0));
                }
            }
            if (ix1 - ix0 < 40.0f || iy1 - iy0 < 40.0f) continue;
            if (i == ci && j == cj) { /* the square */
                disc(g, 0.5f * (ix0 + ix1), 0.5f * (iy0 + iy1), 0.45f * fminf(ix1 - ix0, iy1 - iy0), 0.08f, G_PAVING);
                place(g, g->pavilion, 0.5f * (ix0 + ix1), 0.5f * (iy0 + iy1), 0.0f, 1.0f, sq_v3(0, 0, 0), sq_v3(0, 0, 0));
                park(g, ix0, iy0, ix1, iy1, false);
                continue;
            }
            const bool shops = i % 3 == 0 || (i + 1) % 3 == 0 || j % 3 == 0 || (j + 1) % 3 == 0;
            const float D = 13.0f;
            /* perimeter: south edge faces -y (yaw 0), north +y (180), west -x (-90), east +x (90) */
            edge_buildings(g, ix0 + D, iy0, ix1 - D, iy0, 0.0f, shops);
            edge_buildings(g, ix1 - D, iy1, ix0 + D, iy1, 180.0f, shops);
            edge_buildings(g, ix0, iy1 - D, ix0, iy0 + D, -90.0f, shops);
            edge_buildings(g, ix1, iy0 + D, ix1, iy1 - D, 90.0f, shops);
            /* corner buildings */
            const float cxs[4] = {ix0 + 0.5f * D, ix1 - 0.5f * D, ix1 - 0.5f * D, ix0 + 0.5f * D};
            const float cys[4] = {iy0 + 0.5f * D, iy0 + 0.5f * D, iy1 - 0.5f * D, iy1 - 0.5f * D};
            const float cyaw[4] = {0.0f, 90.0f, 180.0f, -90.0f};
            for (int c = 0; c < 4; c++) {
                const uint64_t k = g->counter++;
                const int q = g->building_count - 4 + (int)(rnd(g, S_BUILD, 300000u + k) * 3.99f);
                place(g, g->buildings[q], cxs[c], cys[c], cyaw[c], 1.0f,
                      pick(WALLS, NWALLS, rnd(g, S_TINT, 22000000u + k)),
                      pick(PAINTS, NPAINTS, rnd(g, S_TINT, 23000000u + k)));
            }
            /* courtyard trees */
            const float qx0 = ix0 + D + 4.0f, qx1 = ix1 - D - 4.0f, qy0 = iy0 + D + 4.0f, qy1 = iy1 - D - 4.0f;
            if (qx1 > qx0 && qy1 > qy0) {
                const uint64_t k = g->counter++;
                const int n = (int)(g->d->tree_density * (2.0f + 5.0f * rnd(g, S_TREE, 30000000u + k)));
                for (int t = 0; t < n; t++)
                    tree_at(g, qx0 + (qx1 - qx0) * rnd(g, S_TREE, 31000000u + 8 * k + (uint64_t)t),
                            qy0 + (qy1 - qy0) * rnd(g, S_TREE, 32000000u + 8 * k + (uint64_t)t), 0.8f, 1.2f, false);
            }
        }
}

/* ---- entry points --------------------------------------------------------------------------- */
static sq_place_desc resolve(const sq_place_desc *in)
{
    sq_place_desc d = *in;
    if (d.size_m[0] == 0.0f) d.size_m[0] = 1000.0f;
    if (d.size_m[1] == 0.0f) d.size_m[1] = 1000.0f;
    if (d.tree_density == 0.0f) d.tree_density = 1.0f;
    return d;
}

uint64_t sq_place_memory_bytes(const sq_place_desc *in)
{
    if (!in) return 0;
    const sq_place_desc d = resolve(in);
    /* prototypes (~60 meshes, <= 1.5 MB each with LODs and build scratch) and instances: at most
     * one per 25 m^2 of ground; ground tiles ~ 8 kB per 1000 m^2 */
    const double area = (double)d.size_m[0] * (double)d.size_m[1];
    return (uint64_t)(90.0e6 + area / 25.0 * (double)sizeof(sq_mesh_instance) + area * 8.0);
}

sq_result sq_place_generate(sq_context *ctx, const sq_place_desc *in, sq_place **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place", "sq_place_generate: out is NULL");
    *out = NULL;
    if (!in) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place", "sq_place_generate: desc is NULL");
    const sq_place_desc d = resolve(in);
    if (d.kind != SQ_PLACE_SUBURB && d.kind != SQ_PLACE_TOWN)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place", "place kind %d; must be suburb or town",
                        (int)d.kind);
    for (int a = 0; a < 2; a++)
        if (!(d.size_m[a] >= 100.0f && d.size_m[a] <= 50000.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place",
                            "place size_m[%d] = %g m; must be in [100, 50000] m", a, (double)d.size_m[a]);
    if (!(d.tree_density >= 0.0f && d.tree_density <= 10.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place", "place tree_density = %g; must be in [0, 10]",
                        (double)d.tree_density);
    if (!isfinite(d.center_m[0]) || !isfinite(d.center_m[1]))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "place", "place center is not finite");
    sq_result r = sq_context_check_memory(ctx, sq_place_memory_bytes(&d), "procedural place");
    if (r != SQ_OK) return r;
    sq_place *p = sq_alloc_zero(ctx, sizeof *p);
    if (!p) return SQ_ERR_OUT_OF_MEMORY;
    gen g;
    memset(&g, 0, sizeof g);
    g.ctx = ctx;
    g.d = &d;
    g.p = p;
    g.err = tiles_init(&g);
    if (g.err == SQ_OK) {
        if (d.kind == SQ_PLACE_SUBURB) {
            make_suburb_protos(&g);
            if (g.err == SQ_OK) suburb(&g);
        } else {
            make_town_protos(&g);
            if (g.err == SQ_OK) town(&g);
        }
    }
    if (g.tiles) tiles_finish(&g);
    if (g.err != SQ_OK) {
        sq_place_destroy(ctx, p);
        return g.err;
    }
    for (int i = 0; i < p->instance_count; i++) {
        const char *n = p->meshes[p->instances[i].mesh]->name;
        if (strncmp(n, "house", 5) == 0 || strncmp(n, "building", 8) == 0) p->houses++;
        else if (strstr(n, "tree")) p->trees++;
        else if (strncmp(n, "car", 3) == 0) p->cars++;
    }
    p->bytes += sizeof *p + (uint64_t)p->instance_count * sizeof(sq_mesh_instance) +
                (uint64_t)p->mesh_count * sizeof(sq_mesh *);
    sq_log(ctx, SQ_LOG_INFO, "place", "%s %gx%g m: %d meshes, %d instances, %lld faces, %.1f MB",
           d.kind == SQ_PLACE_SUBURB ? "suburb" : "town", (double)d.size_m[0], (double)d.size_m[1],
           p->mesh_count, p->instance_count, (long long)p->faces, (double)p->bytes / 1e6);
    *out = p;
    return SQ_OK;
}

void sq_place_destroy(sq_context *ctx, sq_place *p)
{
    if (!p) return;
    for (int i = 0; i < p->mesh_count; i++) sq_mesh_destroy(ctx, p->meshes[i]);
    sq_free(ctx, p->meshes);
    sq_free(ctx, p->instances);
    sq_free(ctx, p);
}
