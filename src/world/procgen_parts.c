/* procgen_parts.c — prototype meshes of the procedural places, each with hand-made coarser
 * levels (the vertex-clustered ones of mesh.c would melt a house's roof into its walls):
 *   house     walls on a plinth, windows (frame + glass), door, optional porch and garage,
 *             a gable roof of two slabs with overhanging eaves over a gable prism, or a hip
 *             roof solid with its eave soffit, optional chimney;
 *   tree      conifer (trunk + tiers of drooping foliage cones), broadleaf (trunk, branches,
 *             lumpy foliage clumps at the branch ends) or bare (three orders of branches);
 *   car       body and cabin as extruded side profiles, glass, four wheels;
 *   fence     posts, rails and pickets (or boards); hedge;
 *   pavilion  octagonal platform, columns, railings and a concave roof with upturned eaves;
 *   building  town houses and apartment blocks: storeys of framed windows with sills, string
 *             courses, cornice, balconies, a shop front with awning, gable or flat roof.
 * Frames: origin at the footprint centre on the ground (tree: trunk base), x along the
 * frontage, the front faces -y. Colours are linear albedos. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core_internal.h"
#include "procgen_internal.h"

#define DEG (SQ_PI_F / 180.0f)

static sq_mesh_material mat(const char *name, float r, float g, float b, sq_mesh_tint tint)
{
    sq_mesh_material m;
    memset(&m, 0, sizeof m);
    snprintf(m.name, sizeof m.name, "%s", name);
    m.base_color = sq_v3(r, g, b);
    m.tint = tint;
    return m;
}

/* How far the bounding box of level b lies from that of level a on its farthest side (m): a
 * lower bound of the distance between the two surfaces. */
static float box_shift(const pg_mesh *a, const pg_mesh *b)
{
    float lo[2][3], hi[2][3];
    const pg_mesh *l[2] = {a, b};
    for (int k = 0; k < 2; k++) {
        for (int c = 0; c < 3; c++) {
            lo[k][c] = 1e30f;
            hi[k][c] = -1e30f;
        }
        for (int v = 0; v < l[k]->nv; v++)
            for (int c = 0; c < 3; c++) {
                lo[k][c] = fminf(lo[k][c], l[k]->pos[3 * v + c]);
                hi[k][c] = fmaxf(hi[k][c], l[k]->pos[3 * v + c]);
            }
    }
    float d = 0.0f;
    for (int c = 0; c < 3; c++) d = fmaxf(d, fmaxf(fabsf(lo[1][c] - lo[0][c]), fabsf(hi[1][c] - hi[0][c])));
    return d;
}

/* Finishes a prototype: LOD 0 from lod[0], then the given coarser levels. A level's error (what
 * the renderer projects to pixels to pick it) is the hand-set err[i], but never less than how far
 * its bounding box moved from the full level's (a dropped porch, a shorter crown), and larger
 * than the level before it. */
static sq_result finish(sq_context *ctx, const char *name, pg_mesh *lod, const float *err, int n,
                        const sq_mesh_material *mats, int nmat, sq_mesh **out)
{
    sq_mesh *m = NULL;
    sq_result r = pg_to_mesh(&lod[0], name, mats, nmat, false, &m);
    float prev = 0.0f;
    for (int i = 1; i < n && r == SQ_OK; i++) {
        const float e = fmaxf(fmaxf(err[i], box_shift(&lod[0], &lod[i])), 1.01f * prev);
        r = pg_add_lod(&lod[i], m, e);
        prev = e;
    }
    for (int i = 0; i < n; i++) pg_free(&lod[i]);
    if (r != SQ_OK) {
        sq_mesh_destroy(ctx, m);
        return r;
    }
    *out = m;
    return SQ_OK;
}

/* ---- houses ------------------------------------------------------------------------------- */
enum { H_WALL, H_ROOF, H_GLASS, H_TRIM, H_DOOR, H_BRICK, H_PLINTH, H_GARAGE, H_NMAT };

/* Triangular prism along x from x0 to x1: cross-section (-hy, z0), (hy, z0), (0, z1). */
static void gable_prism(pg_mesh *b, float x0, float x1, float hy, float z0, float z1, int m)
{
    const int a0 = pg_vertex(b, sq_v3(x0, -hy, z0)), b0 = pg_vertex(b, sq_v3(x0, hy, z0)),
              c0 = pg_vertex(b, sq_v3(x0, 0, z1));
    const int a1 = pg_vertex(b, sq_v3(x1, -hy, z0)), b1 = pg_vertex(b, sq_v3(x1, hy, z0)),
              c1 = pg_vertex(b, sq_v3(x1, 0, z1));
    pg_tri(b, a0, c0, b0, m);         /* -x end */
    pg_tri(b, a1, b1, c1, m);         /* +x end */
    pg_quad(b, a0, b0, b1, a1, m);    /* bottom */
    pg_quad(b, a0, a1, c1, c0, m);    /* front slope */
    pg_quad(b, b0, c0, c1, b1, m);    /* back slope */
}

/* Hip (or gable, hip = false) roof solid over a rectangle of half sizes X, Y at eave height ze
 * rising at pitch to a ridge along x. */
static void roof_solid(pg_mesh *b, float X, float Y, float ze, float pitch, bool hip, int m)
{
    const float zr = ze + Y * tanf(pitch);
    float rx = hip ? X - Y : X;
    if (rx < 0.0f) rx = 0.0f;
    const int e0 = pg_vertex(b, sq_v3(-X, -Y, ze)), e1 = pg_vertex(b, sq_v3(X, -Y, ze)),
              e2 = pg_vertex(b, sq_v3(X, Y, ze)), e3 = pg_vertex(b, sq_v3(-X, Y, ze));
    const int r0 = pg_vertex(b, sq_v3(-rx, 0, zr)), r1 = pg_vertex(b, sq_v3(rx, 0, zr));
    pg_quad(b, e0, e1, r1, r0, m);
    pg_tri(b, e1, e2, r1, m);
    pg_quad(b, e2, e3, r0, r1, m);
    pg_tri(b, e3, e0, r0, m);
    pg_quad(b, e0, e3, e2, e1, m);
}

/* A framed window on the wall plane y = y_wall facing -y (front) or +y (back) (facing = -1/+1),
 * or on x = x_wall facing -x/+x when on_x. Centre (u, z) along the wall, size w x h. */
static void window(pg_mesh *b, bool on_x, float wall, int facing, float u, float z, float w,
                   float h, bool sill)
{
    const pg_xf id = pg_xf_identity();
    const float f = (float)facing;
    /* frame: 6 cm proud of the wall; glass 3 cm proud, inside the frame */
    const float t0 = wall - 0.01f * f, t1 = wall + 0.06f * f, g1 = wall + 0.075f * f;
    sq_vec3 lo, hi, glo, ghi;
    if (!on_x) {
        lo = sq_v3(u - 0.5f * w, fminf(t0, t1), z - 0.5f * h);
        hi = sq_v3(u + 0.5f * w, fmaxf(t0, t1), z + 0.5f * h);
        glo = sq_v3(u - 0.5f * w + 0.09f, fminf(t0, g1), z - 0.5f * h + 0.09f);
        ghi = sq_v3(u + 0.5f * w - 0.09f, fmaxf(t0, g1), z + 0.5f * h - 0.09f);
    } else {
        lo = sq_v3(fminf(t0, t1), u - 0.5f * w, z - 0.5f * h);
        hi = sq_v3(fmaxf(t0, t1), u + 0.5f * w, z + 0.5f * h);
        glo = sq_v3(fminf(t0, g1), u - 0.5f * w + 0.09f, z - 0.5f * h + 0.09f);
        ghi = sq_v3(fmaxf(t0, g1), u + 0.5f * w - 0.09f, z + 0.5f * h - 0.09f);
    }
    pg_box(b, &id, lo, hi, H_TRIM);
    pg_box(b, &id, glo, ghi, H_GLASS);
    if (sill) {
        const float s1 = wall + 0.14f * f;
        if (!on_x)
            pg_box(b, &id, sq_v3(u - 0.5f * w - 0.08f, fminf(t0, s1), z - 0.5f * h - 0.08f),
                   sq_v3(u + 0.5f * w + 0.08f, fmaxf(t0, s1), z - 0.5f * h), H_TRIM);
        else
            pg_box(b, &id, sq_v3(fminf(t0, s1), u - 0.5f * w - 0.08f, z - 0.5f * h - 0.08f),
                   sq_v3(fmaxf(t0, s1), u + 0.5f * w + 0.08f, z - 0.5f * h), H_TRIM);
    }
}

/* A flat quad of material mat on a wall (2 cm proud of it): windows and doors on the coarse
 * levels, so that a level switch does not make them vanish. */
static void wall_quad(pg_mesh *b, bool on_x, float wall, int facing, float u, float z, float w,
                      float h, int mat)
{
    const float f = (float)facing, t = wall + 0.02f * f;
    const float u0 = u - 0.5f * w, u1 = u + 0.5f * w, z0 = z - 0.5f * h, z1 = z + 0.5f * h;
    int a, c, d, e;
    if (!on_x) {
        a = pg_vertex(b, sq_v3(u0, t, z0));
        c = pg_vertex(b, sq_v3(u1, t, z0));
        d = pg_vertex(b, sq_v3(u1, t, z1));
        e = pg_vertex(b, sq_v3(u0, t, z1));
        /* counter-clockwise seen from -y is (u0,z0) (u1,z0) (u1,z1) (u0,z1) */
        if (facing < 0) pg_quad(b, a, c, d, e, mat);
        else pg_quad(b, a, e, d, c, mat);
    } else {
        a = pg_vertex(b, sq_v3(t, u0, z0));
        c = pg_vertex(b, sq_v3(t, u1, z0));
        d = pg_vertex(b, sq_v3(t, u1, z1));
        e = pg_vertex(b, sq_v3(t, u0, z1));
        if (facing > 0) pg_quad(b, a, c, d, e, mat);
        else pg_quad(b, a, e, d, c, mat);
    }
}

/* A flat dark quad for a window on the coarse levels. */
static void window_quad(pg_mesh *b, bool on_x, float wall, int facing, float u, float z, float w,
                        float h)
{
    wall_quad(b, on_x, wall, facing, u, z, w, h, H_GLASS);
}

/* Windows of one wall: count evenly spaced along [-half, half], skipping a door gap. */
static void wall_windows(pg_mesh *b, int lod, bool on_x, float wall, int facing, float half,
                         int storeys, float sh, float door_u, float win_w)
{
    const int n = (int)floorf((2.0f * half - 1.2f) / 2.7f);
    for (int s = 0; s < storeys; s++) {
        const float z = (float)s * sh + 0.55f * sh + 0.15f;
        for (int k = 0; k < n; k++) {
            const float u = -half + (2.0f * half) * ((float)k + 0.5f) / (float)n;
            if (s == 0 && fabsf(u - door_u) < 1.0f) continue;
            if (lod == 0) window(b, on_x, wall, facing, u, z, win_w, 1.3f, true);
            else window_quad(b, on_x, wall, facing, u, z, win_w, 1.3f);
        }
    }
}

static void house_level(pg_mesh *b, const pg_house_spec *s, int lod)
{
    const pg_xf id = pg_xf_identity();
    const float hw = 0.5f * s->width, hd = 0.5f * s->depth;
    const float H = (float)s->storeys * s->storey_h + 0.35f;
    const float p = s->pitch_deg * DEG, oh = s->overhang;
    const float door_u = -0.22f * s->width;
    /* plinth (6 cm proud of the walls: not on the coarsest level) and walls */
    if (lod <= 1)
        pg_box(b, &id, sq_v3(-hw - 0.06f, -hd - 0.06f, -0.3f), sq_v3(hw + 0.06f, hd + 0.06f, 0.35f),
               H_PLINTH);
    pg_box(b, &id, sq_v3(-hw, -hd, 0.0f), sq_v3(hw, hd, H), H_WALL);
    /* windows on every level (flat quads on the coarse ones: 2 triangles each, which the
     * occlusion map's top-face range leaves out): a level switch must not make them vanish */
    wall_windows(b, lod, false, -hd, -1, hw, s->storeys, s->storey_h, door_u, 1.2f);
    wall_windows(b, lod, false, hd, 1, hw, s->storeys, s->storey_h, 1e9f, 1.2f);
    wall_windows(b, lod, true, -hw, -1, hd, s->storeys, s->storey_h, 1e9f, 1.0f);
    wall_windows(b, lod, true, hw, 1, hd, s->storeys, s->storey_h, 1e9f, 1.0f);
    if (lod >= 1) /* the door as a flat quad (1.0 x 2.1 m, as LOD 0's door box) */
        wall_quad(b, false, -hd, -1, door_u, 1.4f, 1.0f, 2.1f, H_DOOR);
    if (lod == 0) {
        /* door with a step */
        pg_box(b, &id, sq_v3(door_u - 0.5f, -hd - 0.06f, 0.35f), sq_v3(door_u + 0.5f, -hd + 0.01f, 2.45f),
               H_DOOR);
        pg_box(b, &id, sq_v3(door_u - 0.8f, -hd - 0.55f, -0.2f), sq_v3(door_u + 0.8f, -hd, 0.2f),
               H_PLINTH);
        if (s->porch) {
            pg_box(b, &id, sq_v3(door_u - 1.1f, -hd - 1.5f, 2.75f), sq_v3(door_u + 1.1f, -hd, 2.9f),
                   H_TRIM);
            pg_box(b, &id, sq_v3(door_u - 1.0f, -hd - 1.4f, 0.0f), sq_v3(door_u - 0.86f, -hd - 1.26f, 2.75f),
                   H_TRIM);
            pg_box(b, &id, sq_v3(door_u + 0.86f, -hd - 1.4f, 0.0f), sq_v3(door_u + 1.0f, -hd - 1.26f, 2.75f),
                   H_TRIM);
        }
    }
    if (s->garage) {
        const float gx0 = hw, gx1 = hw + 3.6f, gy0 = -hd - 0.5f, gy1 = gy0 + 6.2f;
        pg_box(b, &id, sq_v3(gx0 - 0.1f, gy0, 0.0f), sq_v3(gx1, gy1, 2.7f), H_WALL);
        if (lod <= 1) /* its eave trim, 0.3 m proud */
            pg_box(b, &id, sq_v3(gx0 - 0.2f, gy0 - 0.3f, 2.7f), sq_v3(gx1 + 0.3f, gy1 + 0.2f, 2.95f),
                   H_TRIM);
        if (lod <= 1)
            pg_box(b, &id, sq_v3(gx0 + 0.4f, gy0 - 0.04f, 0.0f), sq_v3(gx1 - 0.4f, gy0 + 0.02f, 2.25f),
                   H_GARAGE);
    }
    /* roof */
    if (s->roof == PG_ROOF_GABLE) {
        const float R = hd * tanf(p);
        gable_prism(b, -hw, hw, hd, H, H + R, H_WALL);
        if (lod == 0) {
            /* two slabs of 18 cm, overhanging eaves and gables by oh */
            const float ls = (hd + oh) / cosf(p), t = 0.18f;
            pg_xf front = pg_xf_rot_x(p), back = pg_xf_rot_x(-p);
            front.t = back.t = sq_v3(0, 0, H + R);
            pg_box(b, &front, sq_v3(-hw - oh, -ls, 0.0f), sq_v3(hw + oh, 0.12f, t), H_ROOF);
            pg_box(b, &back, sq_v3(-hw - oh, -0.12f, 0.0f), sq_v3(hw + oh, ls, t), H_ROOF);
        } else {
            /* one solid: the two roof planes lifted by the slab, gable ends flush with the eaves */
            const float lift = 0.18f / cosf(p);
            roof_solid(b, hw + oh, hd + oh, H - oh * tanf(p) + lift, p, false, H_ROOF);
        }
    } else if (s->roof == PG_ROOF_HIP) {
        roof_solid(b, hw + oh, hd + oh, H - oh * tanf(p) + 0.12f, p, true, H_ROOF);
    } else {
        pg_box(b, &id, sq_v3(-hw - oh, -hd - oh, H), sq_v3(hw + oh, hd + oh, H + 0.3f), H_ROOF);
    }
    if (s->chimney && lod <= 1) {
        const float cx = 0.28f * s->width, cy = 0.2f * s->depth;
        const float top = H + hd * tanf(p) + 0.9f;
        pg_box(b, &id, sq_v3(cx - 0.35f, cy - 0.3f, H - 0.5f), sq_v3(cx + 0.35f, cy + 0.3f, top), H_BRICK);
        if (lod == 0)
            pg_box(b, &id, sq_v3(cx - 0.42f, cy - 0.37f, top), sq_v3(cx + 0.42f, cy + 0.37f, top + 0.12f),
                   H_BRICK);
    }
}

sq_result pg_make_house(sq_context *ctx, const pg_house_spec *s, sq_mesh **out)
{
    const sq_mesh_material m[H_NMAT] = {
        mat("walls", 0.62f, 0.58f, 0.50f, SQ_TINT_PRIMARY),
        mat("roof", 0.22f, 0.09f, 0.06f, SQ_TINT_SECONDARY),
        mat("glass", 0.035f, 0.045f, 0.06f, SQ_TINT_NONE),
        mat("trim", 0.78f, 0.78f, 0.75f, SQ_TINT_NONE),
        mat("door", 0.16f, 0.08f, 0.04f, SQ_TINT_NONE),
        mat("brick", 0.30f, 0.11f, 0.07f, SQ_TINT_NONE),
        mat("plinth", 0.30f, 0.29f, 0.27f, SQ_TINT_NONE),
        mat("garage door", 0.55f, 0.55f, 0.52f, SQ_TINT_NONE),
    };
    pg_mesh lod[3];
    for (int i = 0; i < 3; i++) {
        pg_init(&lod[i], ctx);
        house_level(&lod[i], s, i);
    }
    char name[64];
    snprintf(name, sizeof name, "house %.0fx%.0f %d-storey %s", (double)s->width, (double)s->depth,
             s->storeys, s->roof == PG_ROOF_GABLE ? "gable" : s->roof == PG_ROOF_HIP ? "hip" : "flat");
    const float err[3] = {0.0f, 0.12f, 0.6f};
    return finish(ctx, name, lod, err, 3, m, H_NMAT, out);
}

/* ---- trees -------------------------------------------------------------------------------- */
enum { T_BARK, T_LEAF, T_NMAT };

/* A conifer: trunk and `tiers` drooping foliage cones (concave underside), top tier a spire.
 * CONIFER_TIERS on the full level; the coarser levels' spire ends at the full level's tip. */
#define CONIFER_TIERS 7
static void conifer(pg_mesh *b, float h, uint64_t seed, int tiers, int sides)
{
    pg_cylinder(b, sq_v3(0, 0, -0.2f), sq_v3(0, 0, 0.92f * h), 0.028f * h, 0.008f * h,
                sides > 6 ? 6 : (sides > 4 ? 4 : 3), T_BARK);
    const float base = 0.14f * h, top = h;
    const float tip = base + (top - base) * ((float)(CONIFER_TIERS - 1) / CONIFER_TIERS * 0.92f +
                                             2.2f / CONIFER_TIERS);
    for (int k = 0; k < tiers; k++) {
        const float f = (float)k / (float)tiers;
        const float z0 = base + (top - base) * f * 0.92f;
        float th = (top - base) / (float)tiers * (k == tiers - 1 ? 2.2f : 1.75f);
        if (k == tiers - 1 && tiers != CONIFER_TIERS) th = tip - z0;
        const float r = 0.36f * h * (1.0f - 0.88f * f) * (0.9f + 0.2f * pg_rand(seed, 10, (uint64_t)k));
        const float rad[3] = {0.25f * r, r, 0.0f};
        const float zz[3] = {z0 + 0.22f * th, z0, z0 + th};
        pg_xf x = pg_xf_yaw(sq_v3(0, 0, 0), 2.0f * SQ_PI_F * pg_rand(seed, 11, (uint64_t)k));
        pg_lathe(b, &x, rad, zz, 3, sides, T_LEAF);
    }
}

/* Branch tip positions of a broadleaf tree (main branches then their forks). */
typedef struct branch {
    sq_vec3 a, c;
    float ra, rc;
} branch;

static int broadleaf_branches(float h, uint64_t seed, int orders, branch *out, int max)
{
    int n = 0;
    const sq_vec3 trunk_top = sq_v3(0, 0, 0.42f * h);
    out[n++] = (branch){sq_v3(0, 0, -0.2f), trunk_top, 0.045f * h, 0.032f * h};
    const int mains = 4 + (int)(2.0f * pg_rand(seed, 20, 0));
    for (int i = 0; i < mains && n < max; i++) {
        const float az = 2.0f * SQ_PI_F * ((float)i + 0.4f * pg_rand(seed, 21, (uint64_t)i)) / (float)mains;
        const float el = (38.0f + 25.0f * pg_rand(seed, 22, (uint64_t)i)) * DEG;
        const float len = (0.30f + 0.08f * pg_rand(seed, 23, (uint64_t)i)) * h;
        const sq_vec3 a = sq_v3(0, 0, (0.36f + 0.1f * pg_rand(seed, 24, (uint64_t)i)) * h);
        const sq_vec3 d = sq_v3(cosf(el) * cosf(az), cosf(el) * sinf(az), sinf(el));
        const sq_vec3 c = sq_v3_add(a, sq_v3_scale(d, len));
        const int parent = n;
        out[n++] = (branch){a, c, 0.022f * h, 0.012f * h};
        if (orders < 2) continue;
        for (int j = 0; j < 2 && n < max; j++) {
            const float az2 = az + (j ? 0.6f : -0.6f) + 0.3f * (pg_rand(seed, 25, (uint64_t)(i * 4 + j)) - 0.5f);
            const float el2 = el + (10.0f + 15.0f * pg_rand(seed, 26, (uint64_t)(i * 4 + j))) * DEG;
            const float l2 = 0.55f * len;
            const sq_vec3 a2 = sq_v3_lerp(out[parent].a, out[parent].c, 0.75f);
            const sq_vec3 d2 = sq_v3(cosf(el2) * cosf(az2), cosf(el2) * sinf(az2), sinf(el2));
            const int p2 = n;
            out[n++] = (branch){a2, sq_v3_add(a2, sq_v3_scale(d2, l2)), 0.011f * h, 0.006f * h};
            if (orders < 3) continue;
            for (int k = 0; k < 2 && n < max; k++) {
                const float az3 = az2 + (k ? 0.5f : -0.5f);
                const float el3 = el2 - 5.0f * DEG;
                const sq_vec3 a3 = sq_v3_lerp(out[p2].a, out[p2].c, 0.7f);
                const sq_vec3 d3 = sq_v3(cosf(el3) * cosf(az3), cosf(el3) * sinf(az3), sinf(el3));
                out[n++] = (branch){a3, sq_v3_add(a3, sq_v3_scale(d3, 0.5f * l2)), 0.006f * h, 0.003f * h};
            }
        }
    }
    return n;
}

/* The far level of a broadleaf tree (lod 3): the trunk and one foliage blob over the box of the
 * coarse level's clumps, so the crown keeps its size and place when it is a few pixels wide. */
static void broadleaf_far(pg_mesh *b, float h, uint64_t seed)
{
    branch br[64];
    const int n = broadleaf_branches(h, seed, 1, br, 64);
    pg_cylinder(b, br[0].a, br[0].c, br[0].ra, br[0].rc, 3, T_BARK);
    const float rc = 0.26f * h;
    sq_vec3 lo = sq_v3(-rc, -rc, 0.74f * h - 0.75f * rc), hi = sq_v3(rc, rc, 0.74f * h + 0.75f * rc);
    for (int i = 1; i < n; i++) {
        const float r = 0.2f * h * (0.85f + 0.3f * pg_rand(seed, 30, (uint64_t)i));
        lo = sq_v3(fminf(lo.x, br[i].c.x - r), fminf(lo.y, br[i].c.y - r), fminf(lo.z, br[i].c.z - 0.8f * r));
        hi = sq_v3(fmaxf(hi.x, br[i].c.x + r), fmaxf(hi.y, br[i].c.y + r), fmaxf(hi.z, br[i].c.z + 0.8f * r));
    }
    /* the blob's equator ring lies at 0.95 of its radii (rings 3): reach the box's sides */
    const sq_vec3 c = sq_v3_scale(sq_v3_add(lo, hi), 0.5f);
    const sq_vec3 r = sq_v3(0.5f * (hi.x - lo.x), 0.5f * (hi.y - lo.y), 0.5f * (hi.z - lo.z));
    pg_blob(b, c, r, 3, 6, 0.0f, seed * 7u + 3u, T_LEAF);
}

static void broadleaf(pg_mesh *b, float h, uint64_t seed, int lod, bool bare)
{
    branch br[64];
    if (lod == 3 && !bare) {
        broadleaf_far(b, h, seed);
        return;
    }
    const int orders = bare ? (lod == 0 ? 3 : lod == 1 ? 2 : 1) : (lod == 0 ? 2 : 1);
    const int n = broadleaf_branches(h, seed, orders, br, 64);
    const int sides = lod == 0 ? 6 : (lod == 1 ? 4 : 3);
    for (int i = 0; i < n; i++)
        pg_cylinder(b, br[i].a, br[i].c, br[i].ra, br[i].rc, i == 0 ? sides + 1 : sides, T_BARK);
    if (bare) return;
    /* foliage: a clump at each branch end and one crowning the tree */
    const int rings = lod == 0 ? 6 : (lod == 1 ? 4 : 3), bs = lod == 0 ? 9 : (lod == 1 ? 6 : 5);
    for (int i = 1; i < n; i++) {
        if (lod == 0 && i < n && br[i].ra > 0.02f * h && orders > 1) continue; /* forks carry them */
        const float r = (lod == 0 ? 0.17f : 0.2f) * h * (0.85f + 0.3f * pg_rand(seed, 30, (uint64_t)i));
        pg_blob(b, br[i].c, sq_v3(r, r, 0.8f * r), rings, bs, lod == 0 ? 0.35f : 0.15f,
                seed * 131u + (uint64_t)i, T_LEAF);
    }
    const float rc = 0.26f * h;
    pg_blob(b, sq_v3(0, 0, 0.74f * h), sq_v3(rc, rc, 0.75f * rc), rings, bs, lod == 0 ? 0.3f : 0.1f,
            seed * 7u + 3u, T_LEAF);
}

sq_result pg_make_tree(sq_context *ctx, pg_tree_kind kind, float h, uint64_t seed, sq_mesh **out)
{
    sq_mesh_material m[T_NMAT] = {
        mat("bark", 0.13f, 0.09f, 0.06f, SQ_TINT_NONE),
        mat("foliage", 0.05f, 0.13f, 0.04f, SQ_TINT_PRIMARY),
    };
    if (kind == PG_TREE_CONIFER) m[T_LEAF].base_color = sq_v3(0.025f, 0.075f, 0.035f);
    if (kind == PG_TREE_BARE) m[T_BARK].base_color = sq_v3(0.16f, 0.13f, 0.10f);
    /* levels: full, coarse, coarser, far (conifer: one tier; broadleaf: one crown; a bare tree
     * keeps three levels, its coarsest is already the trunk and main branches) */
    const int levels = kind == PG_TREE_BARE ? 3 : 4;
    pg_mesh lod[4];
    for (int i = 0; i < levels; i++) {
        pg_init(&lod[i], ctx);
        if (kind == PG_TREE_CONIFER)
            conifer(&lod[i], h, seed, i == 0 ? CONIFER_TIERS : (i == 1 ? 4 : i == 2 ? 2 : 1),
                    i == 0 ? 9 : (i == 1 ? 6 : i == 2 ? 5 : 4));
        else
            broadleaf(&lod[i], h, seed, i, kind == PG_TREE_BARE);
    }
    char name[64];
    snprintf(name, sizeof name, "%s tree %.0f m",
             kind == PG_TREE_CONIFER ? "conifer" : kind == PG_TREE_BROADLEAF ? "broadleaf" : "bare",
             (double)h);
    const float err[4] = {0.0f, 0.05f * h, 0.14f * h, 0.3f * h};
    return finish(ctx, name, lod, err, levels, m, T_NMAT, out);
}

/* ---- cars --------------------------------------------------------------------------------- */
enum { C_BODY, C_GLASS, C_TYRE, C_TRIM, C_NMAT };

/* A side profile (x, z) polygon extruded across y from -hw to hw. */
static void profile_solid(pg_mesh *b, const float *xz, int n, float hw, int m)
{
    pg_xf x = pg_xf_rot_x(0.5f * SQ_PI_F); /* (x, y, z) -> (x, -z, y): extrusion along -y */
    x.t = sq_v3(0, hw, 0);
    pg_prism(b, &x, xz, n, 2.0f * hw, m);
}

static void car_level(pg_mesh *b, int style, int lod)
{
    /* length, width, body height, cabin height by style: sedan, hatchback, SUV, van */
    static const float L[4] = {4.6f, 4.0f, 4.7f, 5.0f}, W[4] = {1.78f, 1.72f, 1.9f, 1.95f};
    static const float HB[4] = {0.95f, 0.95f, 1.1f, 1.15f}, HC[4] = {1.45f, 1.5f, 1.75f, 2.0f};
    const float l = 0.5f * L[style], w = 0.5f * W[style], hb = HB[style], hc = HC[style];
    const float body[12] = {-l, 0.32f, l, 0.32f, l + 0.03f, hb - 0.3f, l - 0.15f, hb - 0.05f,
                            -l + 0.1f, hb, -l - 0.02f, hb - 0.35f};
    profile_solid(b, body, 6, w, C_BODY);
    /* cabin: a trapezoid of glass with a roof, set back by style */
    const float cf = style == 3 ? l - 0.9f : (style == 1 ? 0.55f : 0.75f);
    const float cr = style == 3 ? -l + 0.05f : (style == 1 ? -l + 0.15f : -l + 0.75f);
    const float cabin[8] = {cr, hb - 0.05f, cf, hb - 0.05f, cf - 0.55f, hc - 0.06f,
                            cr + (style == 1 || style == 3 ? 0.1f : 0.45f), hc - 0.06f};
    profile_solid(b, cabin, 4, w - 0.08f, C_GLASS);
    if (lod == 0) {
        const pg_xf id = pg_xf_identity();
        pg_box(b, &id, sq_v3(cr + (style == 1 || style == 3 ? 0.12f : 0.45f), -w + 0.06f, hc - 0.08f),
               sq_v3(cf - 0.57f, w - 0.06f, hc), C_BODY);
        for (int k = 0; k < 4; k++) {
            const float x = (k & 1) ? l - 0.8f : -l + 0.8f, y0 = (k & 2) ? w - 0.24f : -w - 0.01f;
            pg_cylinder(b, sq_v3(x, y0, 0.33f), sq_v3(x, y0 + 0.25f, 0.33f), 0.33f, 0.33f, 8, C_TYRE);
        }
        pg_box(b, &id, sq_v3(-l - 0.06f, -w + 0.1f, 0.4f), sq_v3(-l + 0.05f, w - 0.1f, 0.55f), C_TRIM);
        pg_box(b, &id, sq_v3(l - 0.05f, -w + 0.1f, 0.4f), sq_v3(l + 0.08f, w - 0.1f, 0.55f), C_TRIM);
    }
}

sq_result pg_make_car(sq_context *ctx, int style, uint64_t seed, sq_mesh **out)
{
    (void)seed;
    style = ((style % 4) + 4) % 4;
    const sq_mesh_material m[C_NMAT] = {
        mat("paint", 0.5f, 0.05f, 0.04f, SQ_TINT_PRIMARY),
        mat("glass", 0.03f, 0.035f, 0.045f, SQ_TINT_NONE),
        mat("tyre", 0.03f, 0.03f, 0.03f, SQ_TINT_NONE),
        mat("bumper", 0.08f, 0.08f, 0.08f, SQ_TINT_NONE),
    };
    pg_mesh lod[2];
    for (int i = 0; i < 2; i++) {
        pg_init(&lod[i], ctx);
        car_level(&lod[i], style, i);
    }
    static const char *names[4] = {"car sedan", "car hatchback", "car suv", "car van"};
    const float err[2] = {0.0f, 0.2f};
    return finish(ctx, names[style], lod, err, 2, m, C_NMAT, out);
}

/* ---- fences and hedges -------------------------------------------------------------------- */
enum { F_WOOD, F_NMAT };

sq_result pg_make_fence(sq_context *ctx, float length, bool picket, sq_mesh **out)
{
    const sq_mesh_material m[F_NMAT] = {
        picket ? mat("white paint", 0.75f, 0.75f, 0.72f, SQ_TINT_PRIMARY)
               : mat("wood", 0.30f, 0.20f, 0.12f, SQ_TINT_PRIMARY),
    };
    const pg_xf id = pg_xf_identity();
    const float h = picket ? 1.0f : 1.6f;
    pg_mesh lod[3];
    for (int i = 0; i < 3; i++) pg_init(&lod[i], ctx);
    const int posts = (int)ceilf(length / 2.5f);
    for (int i = 0; i <= posts; i++) {
        const float x = length * (float)i / (float)posts;
        for (int l = 0; l < 2; l++)
            pg_box(&lod[l], &id, sq_v3(x - 0.05f, -0.05f, -0.3f), sq_v3(x + 0.05f, 0.05f, h + 0.08f), F_WOOD);
    }
    for (int l = 0; l < 2; l++)
        for (int r = 0; r < 2; r++) {
            const float z = r ? 0.75f * h : 0.25f * h;
            pg_box(&lod[l], &id, sq_v3(0.0f, 0.05f, z), sq_v3(length, 0.1f, z + 0.08f), F_WOOD);
        }
    if (picket) {
        const int n = (int)floorf(length / 0.16f);
        for (int i = 0; i < n; i++) {
            const float x = (float)i * 0.16f + 0.08f;
            pg_box(&lod[0], &id, sq_v3(x - 0.04f, 0.1f, 0.04f), sq_v3(x + 0.04f, 0.12f, h - 0.06f), F_WOOD);
            /* pointed top */
            const int a = pg_vertex(&lod[0], sq_v3(x - 0.04f, 0.1f, h - 0.06f)),
                      b2 = pg_vertex(&lod[0], sq_v3(x + 0.04f, 0.1f, h - 0.06f)),
                      c = pg_vertex(&lod[0], sq_v3(x + 0.04f, 0.12f, h - 0.06f)),
                      d = pg_vertex(&lod[0], sq_v3(x - 0.04f, 0.12f, h - 0.06f)),
                      t0 = pg_vertex(&lod[0], sq_v3(x, 0.1f, h + 0.02f)),
                      t1 = pg_vertex(&lod[0], sq_v3(x, 0.12f, h + 0.02f));
            pg_tri(&lod[0], a, b2, t0, F_WOOD);
            pg_tri(&lod[0], c, d, t1, F_WOOD);
            pg_quad(&lod[0], b2, c, t1, t0, F_WOOD);
            pg_quad(&lod[0], d, a, t0, t1, F_WOOD);
            pg_quad(&lod[0], a, d, c, b2, F_WOOD);
        }
        pg_box(&lod[1], &id, sq_v3(0.0f, 0.1f, 0.04f), sq_v3(length, 0.12f, h - 0.02f), F_WOOD);
    } else {
        pg_box(&lod[0], &id, sq_v3(0.0f, 0.1f, 0.0f), sq_v3(length, 0.13f, h), F_WOOD);
        pg_box(&lod[1], &id, sq_v3(0.0f, 0.1f, 0.0f), sq_v3(length, 0.13f, h), F_WOOD);
    }
    pg_box(&lod[2], &id, sq_v3(0.0f, -0.05f, 0.0f), sq_v3(length, 0.12f, h), F_WOOD);
    const float err[3] = {0.0f, 0.08f, 0.3f};
    if (!picket) { /* the boards are one box already: no middle level */
        pg_free(&lod[1]);
        lod[1] = lod[2];
        return finish(ctx, "board fence", lod, (const float[2]){0.0f, err[2]}, 2, m, F_NMAT, out);
    }
    return finish(ctx, "picket fence", lod, err, 3, m, F_NMAT, out);
}

sq_result pg_make_hedge(sq_context *ctx, float length, uint64_t seed, sq_mesh **out)
{
    const sq_mesh_material m[1] = {mat("hedge", 0.035f, 0.09f, 0.03f, SQ_TINT_PRIMARY)};
    const pg_xf id = pg_xf_identity();
    pg_mesh lod[2];
    for (int i = 0; i < 2; i++) {
        pg_init(&lod[i], ctx);
        pg_box(&lod[i], &id, sq_v3(0.0f, -0.4f, 0.0f), sq_v3(length, 0.4f, 1.2f), 0);
    }
    const int n = (int)ceilf(length / 1.1f);
    for (int i = 0; i < n; i++) {
        const float x = length * ((float)i + 0.5f) / (float)n;
        pg_blob(&lod[0], sq_v3(x, 0.0f, 1.2f), sq_v3(0.6f, 0.45f, 0.3f), 4, 7, 0.3f,
                seed * 17u + (uint64_t)i, 0);
    }
    const float err[2] = {0.0f, 0.3f};
    return finish(ctx, "hedge", lod, err, 2, m, 1, out);
}

/* ---- pavilion ----------------------------------------------------------------------------- */
enum { P_STONE, P_COLUMN, P_ROOF, P_WOOD, P_NMAT };

/* Roof of revolution with 16 sides whose corner vertices (even sides) reach further out and
 * curl up at the eaves: the upturned corners of a Chinese roof. */
static void pavilion_roof(pg_mesh *b, float r, int sides, bool detail)
{
    const int rings = 7;
    const float rad[7] = {r - 0.1f, r + 2.3f, r + 2.45f, r + 1.4f, 0.62f * r, 0.2f * r, 0.0f};
    const float z[7] = {3.55f, 3.72f, 3.98f, 4.35f, 5.2f, 6.35f, 6.9f};
    const float dr[7] = {0.0f, 0.55f, 0.6f, 0.25f, 0.0f, 0.0f, 0.0f};
    const float dz[7] = {0.0f, 0.55f, 0.55f, 0.2f, 0.0f, 0.0f, 0.0f};
    int start[7];
    for (int k = 0; k < rings; k++) {
        start[k] = b->nv;
        if (rad[k] <= 0.0f) {
            pg_vertex(b, sq_v3(0, 0, z[k]));
            continue;
        }
        for (int s = 0; s < sides; s++) {
            const float t = 2.0f * SQ_PI_F * (float)s / (float)sides + SQ_PI_F / 8.0f;
            const bool corner = detail && (s % (sides / 8)) == 0;
            const float rr = rad[k] + (corner ? dr[k] : 0.0f), zz = z[k] + (corner ? dz[k] : 0.0f);
            pg_vertex(b, sq_v3(rr * cosf(t), rr * sinf(t), zz));
        }
    }
    for (int k = 0; k + 1 < rings; k++)
        for (int s = 0; s < sides; s++) {
            const int s1 = (s + 1) % sides;
            if (rad[k + 1] <= 0.0f) pg_tri(b, start[k] + s, start[k] + s1, start[k + 1], P_ROOF);
            else pg_quad(b, start[k] + s, start[k] + s1, start[k + 1] + s1, start[k + 1] + s, P_ROOF);
        }
    const int c = pg_vertex(b, sq_v3(0, 0, z[0]));
    for (int s = 0; s < sides; s++) pg_tri(b, c, start[0] + (s + 1) % sides, start[0] + s, P_ROOF);
}

sq_result pg_make_pavilion(sq_context *ctx, float r, sq_mesh **out)
{
    const sq_mesh_material m[P_NMAT] = {
        mat("stone", 0.45f, 0.43f, 0.40f, SQ_TINT_NONE),
        mat("lacquer", 0.40f, 0.04f, 0.03f, SQ_TINT_NONE),
        mat("glazed tiles", 0.05f, 0.16f, 0.10f, SQ_TINT_NONE),
        mat("wood", 0.25f, 0.12f, 0.06f, SQ_TINT_NONE),
    };
    pg_mesh lod[3];
    for (int l = 0; l < 3; l++) {
        pg_mesh *b = &lod[l];
        pg_init(b, ctx);
        const pg_xf id = pg_xf_identity();
        /* octagonal platform with a step */
        float oct[16], oct2[16];
        for (int i = 0; i < 8; i++) {
            const float t = 2.0f * SQ_PI_F * ((float)i + 0.5f) / 8.0f;
            oct[2 * i] = (r + 1.4f) * cosf(t);
            oct[2 * i + 1] = (r + 1.4f) * sinf(t);
            oct2[2 * i] = (r + 2.0f) * cosf(t);
            oct2[2 * i + 1] = (r + 2.0f) * sinf(t);
        }
        pg_xf lowered = id;
        lowered.t = sq_v3(0, 0, -0.5f);
        pg_prism(b, &lowered, oct, 8, 1.2f, P_STONE);
        if (l < 2) pg_prism(b, &lowered, oct2, 8, 0.8f, P_STONE);
        for (int i = 0; i < 8; i++) {
            const float t = 2.0f * SQ_PI_F * ((float)i + 0.5f) / 8.0f;
            const sq_vec3 p = sq_v3(r * cosf(t), r * sinf(t), 0.7f);
            pg_cylinder(b, p, sq_v3(p.x, p.y, 3.6f), 0.17f, 0.15f, l == 0 ? 8 : 4, P_COLUMN);
            if (l == 0 && i != 6) {
                /* railing between columns i and i+1 (an opening on one side) */
                const float t1 = 2.0f * SQ_PI_F * ((float)i + 1.5f) / 8.0f;
                const sq_vec3 q = sq_v3(r * cosf(t1), r * sinf(t1), 0.7f);
                const sq_vec3 mid = sq_v3_scale(sq_v3_add(p, q), 0.5f);
                const float len = sq_v3_len(sq_v3_sub(q, p));
                pg_xf x = pg_xf_yaw(mid, atan2f(q.y - p.y, q.x - p.x));
                pg_box(b, &x, sq_v3(-0.5f * len, -0.06f, 0.0f), sq_v3(0.5f * len, 0.06f, 0.75f), P_WOOD);
            }
            if (l == 0) {
                const float t1 = 2.0f * SQ_PI_F * ((float)i + 1.5f) / 8.0f;
                const sq_vec3 q = sq_v3(r * cosf(t1), r * sinf(t1), 3.3f);
                const sq_vec3 pp = sq_v3(p.x, p.y, 3.3f);
                const sq_vec3 mid = sq_v3_scale(sq_v3_add(pp, q), 0.5f);
                const float len = sq_v3_len(sq_v3_sub(q, pp));
                pg_xf x = pg_xf_yaw(mid, atan2f(q.y - pp.y, q.x - pp.x));
                pg_box(b, &x, sq_v3(-0.5f * len - 0.1f, -0.12f, 0.0f), sq_v3(0.5f * len + 0.1f, 0.12f, 0.35f),
                       P_COLUMN);
            }
        }
        pavilion_roof(b, r, l == 2 ? 8 : 16, l < 2);
        if (l < 2) {
            pg_cylinder(b, sq_v3(0, 0, 6.8f), sq_v3(0, 0, 7.5f), 0.12f, 0.05f, 6, P_WOOD);
            pg_blob(b, sq_v3(0, 0, 7.6f), sq_v3(0.22f, 0.22f, 0.22f), 4, 6, 0.0f, 1, P_COLUMN);
        }
    }
    const float err[3] = {0.0f, 0.15f, 0.6f};
    return finish(ctx, "pavilion", lod, err, 3, m, P_NMAT, out);
}

/* ---- town buildings ----------------------------------------------------------------------- */
enum { B_WALL, B_ROOF, B_GLASS, B_TRIM, B_SHOP, B_AWNING, B_NMAT };

static void town_level(pg_mesh *b, float w, float d, int storeys, pg_roof roof, bool shop,
                       uint64_t seed, int lod)
{
    const pg_xf id = pg_xf_identity();
    const float hw = 0.5f * w, hd = 0.5f * d;
    const float g = shop ? 4.2f : 3.2f, sh = 3.05f;
    const float H = g + (float)(storeys - 1) * sh;
    pg_box(b, &id, sq_v3(-hw, -hd, -0.3f), sq_v3(hw, hd, H), B_WALL);
    const int n = (int)floorf((w - 0.6f) / 2.6f);
    const bool balconies = pg_rand(seed, 40, 0) < 0.4f && storeys >= 4;
    for (int face = 0; face < 2 && lod <= 1; face++) {
        const float wall = face ? hd : -hd;
        const int f = face ? 1 : -1;
        for (int s = shop && face == 0 ? 1 : 0; s < storeys; s++) {
            const float z0 = s == 0 ? 0.0f : g + (float)(s - 1) * sh;
            const float zc = z0 + (s == 0 ? 0.55f * g : 0.55f * sh);
            for (int k = 0; k < n; k++) {
                const float u = -hw + w * ((float)k + 0.5f) / (float)n;
                if (lod == 0) {
                    window(b, false, wall, f, u, zc, 1.25f, 1.65f, true);
                    if (balconies && s >= 1 && (k % 2) == 0 && face == 1) {
                        const float y0 = hd, y1 = hd + 1.2f * (float)f;
                        pg_box(b, &id, sq_v3(u - 1.0f, fminf(y0, y1), z0 - 0.05f),
                               sq_v3(u + 1.0f, fmaxf(y0, y1), z0 + 0.12f), B_TRIM);
                        pg_box(b, &id, sq_v3(u - 1.0f, fminf(y1, y1 - 0.05f * (float)f), z0 + 0.12f),
                               sq_v3(u + 1.0f, fmaxf(y1, y1 - 0.05f * (float)f), z0 + 1.1f), B_AWNING);
                    }
                } else {
                    window_quad(b, false, wall, f, u, zc, 1.25f, 1.65f);
                }
            }
            if (lod == 0 && s >= 1) /* string course under each upper storey */
                pg_box(b, &id, sq_v3(-hw, fminf(wall, wall + 0.08f * (float)f), z0 - 0.12f),
                       sq_v3(hw, fmaxf(wall, wall + 0.08f * (float)f), z0 + 0.02f), B_TRIM);
        }
    }
    if (shop && lod <= 1) {
        pg_box(b, &id, sq_v3(-hw + 0.5f, -hd - 0.06f, 0.3f), sq_v3(hw - 0.5f, -hd + 0.02f, g - 1.1f),
               B_SHOP);
        pg_box(b, &id, sq_v3(-hw + 0.3f, -hd - (lod == 0 ? 1.4f : 0.1f), g - 0.9f),
               sq_v3(hw - 0.3f, -hd, g - 0.75f), B_AWNING);
        if (lod == 0)
            pg_box(b, &id, sq_v3(-hw + 0.3f, -hd - 0.1f, g - 0.7f), sq_v3(hw - 0.3f, -hd, g - 0.2f), B_TRIM);
    }
    /* cornice and roof */
    if (lod == 0)
        pg_box(b, &id, sq_v3(-hw, -hd - 0.25f, H - 0.4f), sq_v3(hw, hd + 0.25f, H), B_TRIM);
    if (roof == PG_ROOF_GABLE) {
        roof_solid(b, hw + 0.05f, hd + 0.35f, H - 0.05f, 38.0f * DEG, false, B_ROOF);
        if (lod == 0) {
            const float cx = hw * 0.5f;
            pg_box(b, &id, sq_v3(cx - 0.4f, -0.3f, H), sq_v3(cx + 0.4f, 0.3f, H + hd * tanf(38.0f * DEG) + 0.8f),
                   B_WALL);
        }
    } else {
        pg_box(b, &id, sq_v3(-hw, -hd, H), sq_v3(hw, hd, H + 0.15f), B_ROOF);
        if (lod <= 1) {
            const float t = 0.25f, ph = 0.9f;
            pg_box(b, &id, sq_v3(-hw, -hd, H), sq_v3(hw, -hd + t, H + ph), B_TRIM);
            pg_box(b, &id, sq_v3(-hw, hd - t, H), sq_v3(hw, hd, H + ph), B_TRIM);
            pg_box(b, &id, sq_v3(-hw, -hd, H), sq_v3(-hw + t, hd, H + ph), B_TRIM);
            pg_box(b, &id, sq_v3(hw - t, -hd, H), sq_v3(hw, hd, H + ph), B_TRIM);
            if (lod == 0) {
                const float u = (pg_rand(seed, 41, 0) - 0.5f) * (w - 4.0f);
                pg_box(b, &id, sq_v3(u - 1.2f, -1.0f, H), sq_v3(u + 1.2f, 1.5f, H + 2.3f), B_WALL);
            }
        }
    }
}

sq_result pg_make_town_building(sq_context *ctx, float w, float d, int storeys, pg_roof roof,
                                bool shop, uint64_t seed, sq_mesh **out)
{
    const sq_mesh_material m[B_NMAT] = {
        mat("facade", 0.55f, 0.45f, 0.35f, SQ_TINT_PRIMARY),
        mat("roof", 0.12f, 0.10f, 0.10f, SQ_TINT_NONE),
        mat("glass", 0.035f, 0.045f, 0.06f, SQ_TINT_NONE),
        mat("stone trim", 0.70f, 0.68f, 0.62f, SQ_TINT_NONE),
        mat("shop window", 0.06f, 0.07f, 0.08f, SQ_TINT_NONE),
        mat("awning", 0.35f, 0.06f, 0.05f, SQ_TINT_SECONDARY),
    };
    pg_mesh lod[3];
    for (int i = 0; i < 3; i++) {
        pg_init(&lod[i], ctx);
        town_level(&lod[i], w, d, storeys, roof, shop, seed, i);
    }
    char name[64];
    snprintf(name, sizeof name, "building %.0fx%.0f %d-storey%s", (double)w, (double)d, storeys,
             shop ? " shop" : "");
    const float err[3] = {0.0f, 0.15f, 0.8f};
    return finish(ctx, name, lod, err, 3, m, B_NMAT, out);
}

sq_result pg_make_lamp(sq_context *ctx, sq_mesh **out)
{
    const sq_mesh_material m[2] = {mat("steel", 0.10f, 0.11f, 0.12f, SQ_TINT_NONE),
                                   mat("lamp", 0.8f, 0.78f, 0.7f, SQ_TINT_NONE)};
    pg_mesh lod[2];
    const pg_xf id = pg_xf_identity();
    for (int i = 0; i < 2; i++) {
        pg_init(&lod[i], ctx);
        pg_cylinder(&lod[i], sq_v3(0, 0, -0.3f), sq_v3(0, 0, 6.0f), 0.09f, 0.06f, i == 0 ? 6 : 3, 0);
        pg_box(&lod[i], &id, sq_v3(-0.04f, -0.04f, 5.85f), sq_v3(1.2f, 0.04f, 5.95f), 0);
        if (i == 0) pg_box(&lod[i], &id, sq_v3(0.9f, -0.15f, 5.7f), sq_v3(1.5f, 0.15f, 5.86f), 1);
    }
    const float err[2] = {0.0f, 0.15f};
    return finish(ctx, "street lamp", lod, err, 2, m, 2, out);
}
