/* test_snow_map.c — the snow-cover model's CPU side (src/render/snow_map.c, SPEC §6.2–6.3):
 *   - exposure of a plane under a box: 0 below the box, 1 outside it, the transition within the
 *     map's texel plus the tap radius of the box's edge (the map is the world's top surface);
 *   - no shimmer: a point's exposure is the same for camera moves smaller than a snapped texel
 *     (and the map's texel grid is the same world-aligned grid);
 *   - the frustum footprint: the region holds every ground point of the view nearer than D_snow;
 *   - a map kept while it serves the view (a static world) gives every point of the view the
 *     exposure a map drawn for that view gives, and is drawn again only now and then;
 *   - inclination: max(0, N·up) without noise, mean-preserving with noise;
 *   - the snow shell on a closed cube with split (sharp-crease) normals stays watertight, where
 *     S2's per-vertex normal displacement cracks it;
 *   - the shell's shading normal over a drift (a depth that varies) is the normal of the surface
 *     z = h(x, y) + depth(x, y), from its plane equation, for slopes up to 60 degrees. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render/snow_map.h"
#include "snow_fixtures.h"
#include "sq_test.h"
#include "squall/world.h"

SQ_LABEL(physics)

/* Flat ground at z = 0 with one box obstacle 10 x 6 m, 4 m high, centred at (0, 0). */
static sq_world *box_world(sq_context *ctx)
{
    sq_obstacle box;
    memset(&box, 0, sizeof box);
    box.kind = SQ_OBSTACLE_BOX;
    box.center_m = sq_v3(0.0f, 0.0f, 0.0f);
    box.size_m = sq_v3(10.0f, 6.0f, 4.0f);
    return snow_test_world(ctx, 200.0f, &box);
}

static sq_camera looking_at_box(float x, float y)
{
    sq_camera c;
    memset(&c, 0, sizeof c);
    c.position_m = sq_v3(x - 30.0f, y - 30.0f, 12.0f);
    c.target_m = sq_v3(x, y, 0.0f);
    c.fov_y_deg = 50.0f;
    c.near_m = 0.5f;
    return sq_camera_resolve(c);
}

SQ_TEST(plane_under_box)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = box_world(ctx);
    const sq_camera cam = looking_at_box(0.0f, 0.0f);
    const int size = 256;
    const sq__snow_map_geom g = sq__snow_map_region(&cam, 16.0f / 9.0f, 80.0f, size, 2, 10.0f, -1.0f);
    SQ_CHECK(g.texel_m > 0.0 && g.texel_m < 1.0);
    float *h = malloc((size_t)size * size * sizeof(float));
    sq__snow_map_fill(w, &g, h);
    const float radius = 1.0f, bias = 0.05f;
    const double band = g.texel_m * (1.0 + radius); /* texel + tap radius */
    int below = 0, outside = 0, checked_below = 0, checked_outside = 0;
    /* points of the ground plane on lines across the box's +x edge (x = 5) and -y edge (y = -3) */
    for (int k = 0; k <= 400; k++) {
        const double s = -4.0 + 8.0 * k / 400.0; /* signed distance outside the edge */
        const sq_vec3 px = sq_v3((float)(5.0 + s), 1.0f, 0.0f);
        const sq_vec3 py = sq_v3(-2.0f, (float)(-3.0 - s), 0.0f);
        const float ex = sq__snow_exposure(h, &g, px, 1.0f, 4, radius, bias);
        const float ey = sq__snow_exposure(h, &g, py, 1.0f, 4, radius, bias);
        if (s < -band) {
            checked_below += 2;
            below += (ex == 0.0f) + (ey == 0.0f);
        } else if (s > band) {
            checked_outside += 2;
            outside += (ex == 1.0f) + (ey == 1.0f);
        }
    }
    SQ_CHECK_MSG(below == checked_below, "%d of %d ground points under the box have f_e = 0",
                 below, checked_below);
    SQ_CHECK_MSG(outside == checked_outside, "%d of %d ground points outside have f_e = 1", outside,
                 checked_outside);
    SQ_CHECK(checked_below > 100 && checked_outside > 100);
    /* the box's top is exposed, its centre on the ground is not */
    SQ_CHECK(sq__snow_exposure(h, &g, sq_v3(0.0f, 0.0f, 4.0f), 1.0f, 4, radius, bias) == 1.0f);
    SQ_CHECK(sq__snow_exposure(h, &g, sq_v3(0.0f, 0.0f, 0.0f), 1.0f, 9, radius, bias) == 0.0f);
    /* the transition is no wider: at the edge itself the taps disagree (partial exposure) */
    const float mid = sq__snow_exposure(h, &g, sq_v3(5.0f + 0.5f * (float)g.texel_m, 1.0f, 0.0f),
                                        1.0f, 4, 2.0f, bias);
    SQ_CHECK_MSG(mid > 0.0f && mid < 1.0f, "f_e at the edge = %g", (double)mid);
    free(h);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(no_shimmer)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = box_world(ctx);
    const int size = 256;
    const sq_camera c0 = looking_at_box(0.0f, 0.0f);
    const sq__snow_map_geom g0 = sq__snow_map_region(&c0, 1.5f, 80.0f, size, 2, 10.0f, -1.0f);
    float *h0 = malloc((size_t)size * size * sizeof(float));
    float *h1 = malloc((size_t)size * size * sizeof(float));
    sq__snow_map_fill(w, &g0, h0);
    /* points near the box's edges, on the ground and the roof */
    sq_vec3 pts[64];
    for (int k = 0; k < 64; k++)
        pts[k] = sq_v3(-6.0f + 12.0f * (float)(k % 8) / 7.0f, -4.0f + 8.0f * (float)(k / 8) / 7.0f,
                       (k & 1) ? 0.0f : 4.0f);
    int moves = 0, same_texel = 0;
    for (int m = 1; m <= 20; m++) {
        /* moves of a fraction of a texel, along and across the view */
        const float d = (float)(g0.texel_m * 0.045 * m);
        const sq_camera c1 = looking_at_box(d, -0.5f * d);
        const sq__snow_map_geom g1 = sq__snow_map_region(&c1, 1.5f, 80.0f, size, 2, 10.0f, -1.0f);
        moves++;
        SQ_CHECK_MSG(g1.texel_m == g0.texel_m, "move %d: texel %g m -> %g m", m, g0.texel_m,
                     g1.texel_m);
        /* the origin is on the same world-aligned grid: whole texels apart */
        const double di = (g1.origin[0] - g0.origin[0]) / g0.texel_m;
        SQ_CHECK_MSG(fabs(di - floor(di + 0.5)) < 1e-9, "origin moved by %g texels", di);
        same_texel++;
        sq__snow_map_fill(w, &g1, h1);
        for (int k = 0; k < 64; k++) {
            const float e0 = sq__snow_exposure(h0, &g0, pts[k], 1.0f, 4, 1.0f, 0.05f);
            const float e1 = sq__snow_exposure(h1, &g1, pts[k], 1.0f, 4, 1.0f, 0.05f);
            SQ_CHECK_MSG(e0 == e1, "move %d, point (%g, %g, %g): f_e %g -> %g", m,
                         (double)pts[k].x, (double)pts[k].y, (double)pts[k].z, (double)e0,
                         (double)e1);
        }
    }
    SQ_CHECK(moves == same_texel);
    /* a map placed with its origin not on whole texels (no snapping) changes exposures: the
     * check above can fail */
    sq__snow_map_geom gs = g0;
    gs.origin[0] += 0.5 * g0.texel_m;
    sq__snow_map_fill(w, &gs, h1);
    int changed = 0;
    for (int k = 0; k <= 200; k++) {
        const sq_vec3 p = sq_v3(5.0f + (float)(k - 100) * 0.01f, 0.0f, 0.0f);
        changed += sq__snow_exposure(h0, &g0, p, 1.0f, 4, 1.0f, 0.05f) !=
                   sq__snow_exposure(h1, &gs, p, 1.0f, 4, 1.0f, 0.05f);
    }
    SQ_CHECK_MSG(changed > 0, "an unsnapped half-texel shift changed no exposure");
    free(h0);
    free(h1);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(kept_map_serves_the_view)
{
    sq_context *ctx = snow_test_ctx();
    sq_world *w = box_world(ctx);
    const int size = 128;
    float *kept = malloc((size_t)size * size * sizeof(float));
    float *fresh = malloc((size_t)size * size * sizeof(float));
    /* a walk past the box: 0.25 m per frame, turning slowly */
    sq__snow_map_geom have;
    int draws = 0, frames = 0, compared = 0;
    for (int k = 0; k < 160; k++, frames++) {
        const float s = 0.25f * (float)k;
        const sq_camera cam = looking_at_box(-20.0f + s, -10.0f + 0.3f * s);
        const sq__snow_map_geom need = sq__snow_map_region(&cam, 1.5f, 40.0f, size, 4, 10.0f, -1.0f);
        if (k == 0 || !sq__snow_map_serves(&have, &need)) {
            have = need;
            sq__snow_map_fill(w, &have, kept);
            draws++;
        }
        if (k % 8) continue;
        /* every point of the needed box: the kept map's exposure is the fresh one's */
        sq__snow_map_fill(w, &need, fresh);
        int differ = 0;
        for (int j = 0; j <= 12; j++)
            for (int i = 0; i <= 12; i++) {
                const sq_vec3 p =
                    sq_v3((float)(need.need_lo[0] + (need.need_hi[0] - need.need_lo[0]) * i / 12.0),
                          (float)(need.need_lo[1] + (need.need_hi[1] - need.need_lo[1]) * j / 12.0),
                          (i + j) % 3 == 0 ? 4.0f : 0.0f);
                differ += sq__snow_exposure(kept, &have, p, 1.0f, 4, 1.0f, 0.05f) !=
                          sq__snow_exposure(fresh, &need, p, 1.0f, 4, 1.0f, 0.05f);
                compared++;
            }
        SQ_CHECK_MSG(differ == 0, "frame %d: %d points differ from a fresh map", k, differ);
    }
    SQ_CHECK(compared > 1000);
    SQ_CHECK_MSG(draws > 1 && draws * 4 < frames, "%d maps drawn for %d frames", draws, frames);
    /* another texel size or a box outside: not served */
    sq__snow_map_geom other = have;
    other.texel_m *= 2.0;
    SQ_CHECK(!sq__snow_map_serves(&have, &other));
    other = have;
    other.need_hi[0] = have.origin[0] + have.size * have.texel_m + 0.01;
    SQ_CHECK(!sq__snow_map_serves(&have, &other));
    free(kept);
    free(fresh);
    sq_world_destroy(ctx, w);
    sq_context_destroy(ctx);
}

SQ_TEST(region_covers_the_view)
{
    /* every ground point seen by the camera nearer than D_snow lies inside the region */
    const float detail = 120.0f, aspect = 16.0f / 9.0f;
    const sq_camera cams[3] = {looking_at_box(0.0f, 0.0f), looking_at_box(300.0f, -50.0f),
                               looking_at_box(-20.0f, 40.0f)};
    for (int c = 0; c < 3; c++) {
        const sq_camera cam = cams[c];
        const sq__snow_map_geom g = sq__snow_map_region(&cam, aspect, detail, 512, 2, 10.0f, 0.0f);
        const sq_vec3 f = sq_v3_norm(sq_v3_sub(cam.target_m, cam.position_m));
        const sq_vec3 r = sq_v3_norm(sq_v3_cross(f, cam.up));
        const sq_vec3 u = sq_v3_cross(r, f);
        const float ty = tanf(0.5f * cam.fov_y_deg * SQ_PI_F / 180.0f), tx = ty * aspect;
        int inside = 0, seen = 0;
        for (int j = 0; j <= 20; j++)
            for (int i = 0; i <= 20; i++) {
                const sq_vec3 d = sq_v3_add(f, sq_v3_add(sq_v3_scale(r, tx * (i / 10.0f - 1.0f)),
                                                         sq_v3_scale(u, ty * (j / 10.0f - 1.0f))));
                if (d.z >= 0.0f) continue;
                const float t = -cam.position_m.z / d.z; /* hits z = 0 */
                if (t > detail) continue;                 /* beyond D_snow along the view axis */
                const sq_vec3 p = sq_v3_add(cam.position_m, sq_v3_scale(d, t));
                seen++;
                inside += p.x >= g.origin[0] && p.x <= g.origin[0] + g.size * g.texel_m &&
                          p.y >= g.origin[1] && p.y <= g.origin[1] + g.size * g.texel_m;
            }
        SQ_CHECK(seen > 50);
        SQ_CHECK_MSG(inside == seen, "camera %d: %d of %d ground points in the region", c, inside,
                     seen);
    }
}

SQ_TEST(inclination)
{
    const sq_vec3 p = sq_v3(3.0f, 4.0f, 5.0f);
    SQ_CHECK(sq__snow_inclination(sq_v3(0, 0, 1), p, 0.0f, 1.0f) == 1.0f);
    SQ_CHECK(sq__snow_inclination(sq_v3(1, 0, 0), p, 0.5f, 1.0f) == 0.0f);
    SQ_CHECK(sq__snow_inclination(sq_v3(0, 0, -1), p, 0.5f, 1.0f) == 0.0f);
    const sq_vec3 n45 = sq_v3_norm(sq_v3(1, 0, 1));
    SQ_CHECK(fabsf(sq__snow_inclination(n45, p, 0.0f, 1.0f) - 0.70710678f) < 1e-6f);
    /* noise: mean-one factor (mean of f_inc over many points within 3 % of cos 45), varies */
    double sum = 0.0, lo = 1.0, hi = 0.0;
    const int n = 20000;
    for (int k = 0; k < n; k++) {
        const sq_vec3 q = sq_v3(0.37f * (float)k, 0.11f * (float)(k % 97), 0.05f * (float)(k % 13));
        const double f = sq__snow_inclination(n45, q, 0.3f, 1.0f);
        sum += f;
        lo = fmin(lo, f);
        hi = fmax(hi, f);
    }
    SQ_CHECK_MSG(fabs(sum / n - 0.70710678) < 0.03 * 0.70710678, "mean f_inc %g", sum / n);
    SQ_CHECK(hi - lo > 0.1);
    /* octaves: fbm stays in [0, 1] */
    for (int k = 0; k < 1000; k++) {
        const float v = sq__snow_fbm3(sq_v3(0.7f * (float)k, -1.3f * (float)k, 0.1f * (float)k), 4);
        SQ_CHECK(v >= 0.0f && v <= 1.0f);
    }
}

SQ_TEST(shell_normal_over_a_drift)
{
    /* planes z = b x + c y under depth ramps a1 x + a2 y: the shell is the plane z = (b + a1) x
     * + (c + a2) y; its normal from two of its edge vectors */
    const float planes[][2] = {{0, 0}, {0.5f, 0}, {0, -1.2f}, {0.8f, 0.9f}, {-1.5f, 0.3f}};
    const float ramps[][2] = {{0, 0}, {0.3f, 0}, {-0.6f, 0.2f}, {0.05f, -0.4f}};
    for (size_t i = 0; i < sizeof planes / sizeof planes[0]; i++)
        for (size_t k = 0; k < sizeof ramps / sizeof ramps[0]; k++) {
            const float b = planes[i][0], c = planes[i][1], a1 = ramps[k][0], a2 = ramps[k][1];
            const sq_vec3 n = sq_v3_norm(sq_v3_cross(sq_v3(1, 0, b), sq_v3(0, 1, c)));
            if (n.z < 0.5f) continue; /* steeper than 60 degrees: the shell thins there */
            const sq_vec3 want =
                sq_v3_norm(sq_v3_cross(sq_v3(1, 0, b + a1), sq_v3(0, 1, c + a2)));
            const sq_vec3 got = sq__snow_shell_normal(n, a1, a2);
            SQ_CHECK_MSG(sq_v3_len(sq_v3_sub(got, want)) < 1e-5f,
                         "plane (%g, %g), ramp (%g, %g): (%g %g %g) vs (%g %g %g)", b, c, a1, a2,
                         got.x, got.y, got.z, want.x, want.y, want.z);
        }
    /* walls and overhangs carry no shell: their normal stays */
    const sq_vec3 wall = sq_v3(1, 0, 0), under = sq_v3(0, 0, -1);
    SQ_CHECK(sq_v3_len(sq_v3_sub(sq__snow_shell_normal(wall, 0.7f, 0.2f), wall)) == 0.0f);
    SQ_CHECK(sq_v3_len(sq_v3_sub(sq__snow_shell_normal(under, 0.7f, 0.2f), under)) == 0.0f);
}

/* Cube [-1, 1]^3 with split normals: 24 vertices, 4 per face, 12 triangles. */
static void split_cube(float pos[72], float nrm[72], uint32_t idx[36])
{
    static const int axes[6][3] = {{0, 1, 2}, {0, 1, 2}, {1, 2, 0}, {1, 2, 0}, {2, 0, 1}, {2, 0, 1}};
    int v = 0, t = 0;
    for (int f = 0; f < 6; f++) {
        const float s = (f & 1) ? -1.0f : 1.0f;
        const int a = axes[f][0], b = axes[f][1], c = axes[f][2];
        const float uv[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
        for (int k = 0; k < 4; k++) {
            float *p = &pos[3 * (v + k)], *n = &nrm[3 * (v + k)];
            p[c] = s;
            p[a] = uv[k][0];
            p[b] = uv[k][1] * s; /* keeps the winding outward on both sides */
            n[0] = n[1] = n[2] = 0.0f;
            n[c] = s;
        }
        const uint32_t q[6] = {0, 1, 2, 0, 2, 3};
        for (int k = 0; k < 6; k++) idx[t++] = (uint32_t)v + q[k];
        v += 4;
    }
}

/* Watertight: every edge between displaced positions is used by exactly two triangles. */
static int open_edges(const float *p, const uint32_t *idx, int tris)
{
    int open = 0;
    for (int t = 0; t < tris; t++)
        for (int e = 0; e < 3; e++) {
            const float *a = &p[3 * idx[3 * t + e]], *b = &p[3 * idx[3 * t + (e + 1) % 3]];
            int uses = 0;
            for (int u = 0; u < tris; u++)
                for (int f = 0; f < 3; f++) {
                    const float *c = &p[3 * idx[3 * u + f]], *d = &p[3 * idx[3 * u + (f + 1) % 3]];
                    const bool same = !memcmp(a, c, 12) && !memcmp(b, d, 12);
                    const bool flip = !memcmp(a, d, 12) && !memcmp(b, c, 12);
                    uses += same || flip;
                }
            open += uses != 2;
        }
    return open;
}

SQ_TEST(shell_watertight)
{
    sq_context *ctx = snow_test_ctx();
    float pos[72], nrm[72], sm[96], moved[72], naive[72];
    uint32_t idx[36];
    split_cube(pos, nrm, idx);
    SQ_CHECK(open_edges(pos, idx, 12) == 0); /* closed to begin with */
    SQ_CHECK(sq__snow_welded_normals(ctx, pos, nrm, 24, idx, 36, sm));
    /* exposure varies over the cube (a position-only function, as the map gives), depth 0.3 m */
    for (int v = 0; v < 24; v++) {
        const sq_vec3 p = sq_v3(pos[3 * v], pos[3 * v + 1], pos[3 * v + 2]);
        const float fe = p.x > 0.0f ? 1.0f : 0.5f;
        const sq_vec3 o = sq__snow_shell_offset((sq_vec4){sm[4 * v], sm[4 * v + 1], sm[4 * v + 2], sm[4 * v + 3]},
                                                0.3f, fe, 0.5f);
        moved[3 * v] = p.x + o.x, moved[3 * v + 1] = p.y + o.y, moved[3 * v + 2] = p.z + o.z;
        /* S2: each vertex along its own (split) normal's blend: cracks at the creases */
        const sq_vec3 on = sq__snow_shell_offset((sq_vec4){nrm[3 * v], nrm[3 * v + 1], nrm[3 * v + 2], 0.0f},
                                                 0.3f, fe, 0.5f);
        naive[3 * v] = p.x + on.x, naive[3 * v + 1] = p.y + on.y, naive[3 * v + 2] = p.z + on.z;
    }
    /* the top corners moved (there is a shell), the bottom ones did not */
    int up = 0;
    for (int v = 0; v < 24; v++) up += pos[3 * v + 2] > 0.0f && moved[3 * v + 2] > pos[3 * v + 2] + 0.05f;
    SQ_CHECK_MSG(up == 12, "%d of 12 top-corner vertices raised", up);
    const int open = open_edges(moved, idx, 12);
    SQ_CHECK_MSG(open == 0, "%d open edges in the displaced shell", open);
    const int cracked = open_edges(naive, idx, 12);
    SQ_CHECK_MSG(cracked > 0, "per-vertex normals should crack the cube (%d open edges)", cracked);
    /* ground-level displacement: flat exposed ground moves up by the depth */
    const sq_vec3 g = sq__snow_shell_offset((sq_vec4){0, 0, 1, 0}, 0.25f, 1.0f, 0.5f);
    SQ_CHECK(fabsf(g.z - 0.25f) < 1e-6f && g.x == 0.0f && g.y == 0.0f);
    sq_context_destroy(ctx);
}

/* ---- a house under an overhanging roof: the shell of its walls ------------------------------ */
/* A mesh being built from flat faces, each with its own vertices and normal (split at every
 * edge, as the mesh module splits a box's creases). */
typedef struct faces {
    float pos[3 * 64], nrm[3 * 64];
    uint32_t idx[3 * 64];
    int nv, nt;
} faces;

/* Convex planar polygon of k corners, counter-clockwise seen from outside; fan-triangulated. */
static void add_face(faces *f, const sq_vec3 *c, int k)
{
    const sq_vec3 n = sq_v3_norm(sq_v3_cross(sq_v3_sub(c[1], c[0]), sq_v3_sub(c[2], c[0])));
    for (int i = 0; i < k; i++) {
        float *p = &f->pos[3 * (f->nv + i)], *q = &f->nrm[3 * (f->nv + i)];
        p[0] = c[i].x, p[1] = c[i].y, p[2] = c[i].z;
        q[0] = n.x, q[1] = n.y, q[2] = n.z;
    }
    for (int i = 1; i + 1 < k; i++) {
        f->idx[3 * f->nt] = (uint32_t)f->nv;
        f->idx[3 * f->nt + 1] = (uint32_t)(f->nv + i);
        f->idx[3 * f->nt + 2] = (uint32_t)(f->nv + i + 1);
        f->nt++;
    }
    f->nv += k;
}

static void add_box(faces *f, sq_vec3 lo, sq_vec3 hi)
{
    const float x[2] = {lo.x, hi.x}, y[2] = {lo.y, hi.y}, z[2] = {lo.z, hi.z};
#define C(i, j, k) sq_v3(x[i], y[j], z[k])
    const sq_vec3 q[6][4] = {
        {C(0, 0, 0), C(0, 1, 0), C(1, 1, 0), C(1, 0, 0)}, /* bottom */
        {C(0, 0, 1), C(1, 0, 1), C(1, 1, 1), C(0, 1, 1)}, /* top */
        {C(0, 0, 0), C(1, 0, 0), C(1, 0, 1), C(0, 0, 1)}, /* -y */
        {C(1, 1, 0), C(0, 1, 0), C(0, 1, 1), C(1, 1, 1)}, /* +y */
        {C(0, 1, 0), C(0, 0, 0), C(0, 0, 1), C(0, 1, 1)}, /* -x */
        {C(1, 0, 0), C(1, 1, 0), C(1, 1, 1), C(1, 0, 1)}, /* +x */
    };
#undef C
    for (int k = 0; k < 6; k++) add_face(f, q[k], 4);
}

/* Gable roof solid over |x| <= X, |y| <= Y: flat bottom at ze, ridge along x at ze + Y tan(p). */
static void add_gable_roof(faces *f, float X, float Y, float ze, float tanp)
{
    const float zr = ze + Y * tanp;
    const sq_vec3 e0 = sq_v3(-X, -Y, ze), e1 = sq_v3(X, -Y, ze), e2 = sq_v3(X, Y, ze),
                  e3 = sq_v3(-X, Y, ze), r0 = sq_v3(-X, 0, zr), r1 = sq_v3(X, 0, zr);
    const sq_vec3 front[4] = {e0, e1, r1, r0}, back[4] = {e2, e3, r0, r1}, bottom[4] = {e0, e3, e2, e1};
    const sq_vec3 end1[3] = {e1, e2, r1}, end0[3] = {e3, e0, r0};
    add_face(f, front, 4);
    add_face(f, back, 4);
    add_face(f, bottom, 4);
    add_face(f, end1, 3);
    add_face(f, end0, 3);
}

/* The house: walls 8 x 6 x 3 m and a roof overhanging them by 0.4 m on every side, either a
 * flat slab 0.25 m thick on the walls or the coarse level of a gable roof (a solid whose top
 * lies a slab's 0.22 m above the wall line, pitch 35 degrees: procgen_parts.c house_level). */
enum { HOUSE_FLAT, HOUSE_GABLE };
static const float HW = 4.0f, HD = 3.0f, HH = 3.0f, OH = 0.4f, SLAB = 0.25f, TANP = 0.7002f, LIFT = 0.2197f;

/* Height of the house's top surface at (x, y) (0: the ground): what the occlusion map holds. */
static float house_top(int kind, float x, float y)
{
    const float X = HW + OH, Y = HD + OH;
    if (fabsf(x) > X || fabsf(y) > Y) return 0.0f;
    if (kind == HOUSE_FLAT) return HH + SLAB;
    return HH - OH * TANP + LIFT + (Y - fabsf(y)) * TANP;
}

static void house(int kind, faces *f)
{
    memset(f, 0, sizeof *f);
    add_box(f, sq_v3(-HW, -HD, 0.0f), sq_v3(HW, HD, HH)); /* walls: vertices 0..23 */
    if (kind == HOUSE_FLAT)
        add_box(f, sq_v3(-HW - OH, -HD - OH, HH), sq_v3(HW + OH, HD + OH, HH + SLAB));
    else
        add_gable_roof(f, HW + OH, HD + OH, HH - OH * TANP + LIFT, TANP);
}

/* Under heavy snow (30 cm) with the preset's map (4 taps of radius 1 texel, 5 cm bias plus 10 cm
 * for the camera's level of detail, texels of 25 cm): the corners at the top of the walls, under
 * the eaves (0.25 m under the slab, 0.22 m under the gable roof's top), are occluded and do not
 * move, and no wall vertex moves sideways, so the walls stay vertical (a window quad 2 cm proud
 * of a wall stays in front of it); the roof's top gets the full depth, straight up; the shell
 * stays watertight. */
SQ_TEST(shell_keeps_walls_under_eaves_vertical)
{
    sq_context *ctx = snow_test_ctx();
    const float depth = 0.3f, blend = 0.5f, bias = 0.05f + 0.10f;
    const int taps = 4;
    const float radius = 1.0f;
    sq__snow_map_geom g;
    memset(&g, 0, sizeof g);
    g.size = 128;
    g.texel_m = 0.25;
    g.origin[0] = g.origin[1] = -16.0;
    g.top_z = 10.0f;
    g.bottom_z = -1.0f;
    float *h = malloc((size_t)g.size * g.size * sizeof(float));
    for (int kind = HOUSE_FLAT; kind <= HOUSE_GABLE; kind++) {
        for (int j = 0; j < g.size; j++)
            for (int i = 0; i < g.size; i++)
                h[(size_t)j * g.size + i] = house_top(kind, (float)(g.origin[0] + (i + 0.5) * g.texel_m),
                                                      (float)(g.origin[1] + (j + 0.5) * g.texel_m));
        faces f;
        house(kind, &f);
        float sm[4 * 64], moved[3 * 64];
        SQ_CHECK(sq__snow_welded_normals(ctx, f.pos, f.nrm, f.nv, f.idx, 3 * f.nt, sm));
        sq_vec3 off[64];
        for (int v = 0; v < f.nv; v++) {
            const sq_vec3 p = sq_v3(f.pos[3 * v], f.pos[3 * v + 1], f.pos[3 * v + 2]);
            const sq_vec4 ns = {sm[4 * v], sm[4 * v + 1], sm[4 * v + 2], sm[4 * v + 3]};
            const float fe = ns.w > 0.5f ? sq__snow_corner_exposure(h, &g, p, ns.z, radius, bias)
                                         : sq__snow_exposure(h, &g, p, ns.z, taps, radius, bias);
            off[v] = sq__snow_shell_offset(ns, depth, fe, blend);
            moved[3 * v] = p.x + off[v].x, moved[3 * v + 1] = p.y + off[v].y, moved[3 * v + 2] = p.z + off[v].z;
        }
        int leaning = 0, above_roof = 0, moved_under_roof = 0, roof_short = 0;
        for (int v = 0; v < 24; v++) { /* the walls' box */
            const float *p = &f.pos[3 * v];
            leaning += hypotf(off[v].x, off[v].y) > 1e-3f;
            if (p[2] > 0.0f) {
                above_roof += moved[3 * v + 2] > house_top(kind, p[0], p[1]) - 0.01f;
                moved_under_roof += sq_v3_len(off[v]) > 1e-3f;
            }
        }
        SQ_CHECK_MSG(leaning == 0, "house %d: %d of 24 wall vertices move sideways", kind, leaning);
        SQ_CHECK_MSG(above_roof == 0, "house %d: %d wall-top vertices pierce the roof", kind, above_roof);
        SQ_CHECK_MSG(moved_under_roof == 0, "house %d: %d wall-top vertices under the roof moved", kind,
                     moved_under_roof);
        /* the roof's top (the slab's top corners, the gable's ridge) rises by the depth, straight
         * up; the gable solid's eave corners, where its flat underside meets the slopes, stay:
         * lifting them would lift the underside off the walls (a dark gap under every eave) */
        int lifted = 0;
        for (int v = 24; v < f.nv; v++) {
            const float *p = &f.pos[3 * v];
            const bool top = kind == HOUSE_FLAT ? p[2] > HH + 0.5f * SLAB : p[2] > HH + 1.0f;
            const bool eave = kind == HOUSE_GABLE && p[2] < HH;
            if (top) roof_short += fabsf(off[v].z - depth) > 1e-3f || hypotf(off[v].x, off[v].y) > 1e-3f;
            if (eave) lifted += sq_v3_len(off[v]) > 1e-3f;
        }
        SQ_CHECK_MSG(roof_short == 0, "house %d: %d top roof vertices not raised by the depth", kind,
                     roof_short);
        SQ_CHECK_MSG(lifted == 0, "house %d: %d eave vertices of the underside lifted", kind, lifted);
        SQ_CHECK_MSG(open_edges(moved, f.idx, f.nt) == 0, "house %d: the shell is not watertight", kind);
    }
    free(h);
    sq_context_destroy(ctx);
}

/* The bands of a kept map (sq__texel_rect_minus): want minus have as disjoint rectangles inside
 * want, none inside have, that with want's overlap with have cover want exactly (counted texel
 * by texel), for overlaps on every side, a corner, none, and have covering want. */
SQ_TEST(map_bands_cover_what_the_view_newly_reads)
{
    const sq__texel_rect want = {{10, 20}, {50, 45}};
    const sq__texel_rect haves[6] = {{{30, 30}, {70, 70}}, {{0, 0}, {20, 30}},   {{15, 25}, {40, 40}},
                                     {{60, 0}, {80, 10}},  {{0, 0}, {100, 100}}, {{10, 20}, {50, 30}}};
    for (int h = 0; h < 6; h++) {
        sq__texel_rect band[4];
        const int n = sq__texel_rect_minus(want, haves[h], band);
        SQ_CHECK(n >= 0 && n <= 4);
        int bad = 0;
        for (int j = 0; j < 100; j++)
            for (int i = 0; i < 100; i++) {
                int in_bands = 0;
                for (int k = 0; k < n; k++)
                    in_bands += i >= band[k].lo[0] && i < band[k].hi[0] && j >= band[k].lo[1] && j < band[k].hi[1];
                const sq__texel_rect *a = &want, *b = &haves[h];
                const bool in_want = i >= a->lo[0] && i < a->hi[0] && j >= a->lo[1] && j < a->hi[1];
                const bool in_have = i >= b->lo[0] && i < b->hi[0] && j >= b->lo[1] && j < b->hi[1];
                bad += in_bands != ((in_want && !in_have) ? 1 : 0);
            }
        SQ_CHECK_MSG(bad == 0, "have %d: %d texels wrong", h, bad);
        SQ_CHECK(sq__texel_rect_inside(want, haves[h]) == (h == 4));
    }
}
