/* snow_map.c — the snow-cover model's CPU side (see snow_map.h): occlusion-map region, exposure,
 * inclination, snow shell displacement, welded normals. shaders/snow_common.glsl mirrors the
 * per-point formulas for the GL renderer. */
#include "render/snow_map.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* ---- step 1: the region ------------------------------------------------------------------ */
sq__snow_map_geom sq__snow_map_region(const sq_camera *camera, float aspect, float detail_m,
                                      int size, int margin_texels, float top_z, float bottom_z)
{
    const sq_camera c = sq_camera_resolve(*camera);
    const sq_vec3 f = sq_v3_norm(sq_v3_sub(c.target_m, c.position_m));
    sq_vec3 r = sq_v3_cross(f, c.up);
    if (sq_v3_len(r) < 1e-6f) r = sq_v3(1.0f, 0.0f, 0.0f);
    r = sq_v3_norm(r);
    const sq_vec3 u = sq_v3_cross(r, f);
    const float ty = tanf(0.5f * c.fov_y_deg * SQ_PI_F / 180.0f), tx = ty * aspect;
    const float near_m = fminf(c.near_m, detail_m), far_m = detail_m;
    double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
    for (int k = 0; k < 8; k++) {
        const float d = (k & 4) ? far_m : near_m;
        const float sx = (k & 1) ? tx : -tx, sy = (k & 2) ? ty : -ty;
        const sq_vec3 p = sq_v3_add(c.position_m,
                                    sq_v3_scale(sq_v3_add(f, sq_v3_add(sq_v3_scale(r, sx),
                                                                       sq_v3_scale(u, sy))),
                                                d));
        lo[0] = fmin(lo[0], p.x), hi[0] = fmax(hi[0], p.x);
        lo[1] = fmin(lo[1], p.y), hi[1] = fmax(hi[1], p.y);
    }
    sq__snow_map_geom g;
    memset(&g, 0, sizeof g);
    g.size = size;
    g.top_z = top_z;
    g.bottom_z = bottom_z;
    /* the box plus the margin on both sides and a texel on each for the rounding of the
     * centred origin must fit size texels */
    const double extent = fmax(hi[0] - lo[0], hi[1] - lo[1]);
    const int usable = size - 2 * margin_texels - 2;
    g.texel_m = exp2(ceil(log2(fmax(extent, 1e-3) / (usable > 1 ? usable : 1))));
    for (int a = 0; a < 2; a++) {
        g.need_lo[a] = lo[a] - margin_texels * g.texel_m;
        g.need_hi[a] = hi[a] + margin_texels * g.texel_m;
        const double centre = 0.5 * (g.need_lo[a] + g.need_hi[a]);
        g.origin[a] = floor(centre / g.texel_m - 0.5 * size) * g.texel_m;
    }
    return g;
}

bool sq__snow_map_serves(const sq__snow_map_geom *have, const sq__snow_map_geom *need)
{
    if (have->texel_m != need->texel_m || have->size != need->size ||
        have->top_z != need->top_z || have->bottom_z != need->bottom_z)
        return false;
    const double ext = have->size * have->texel_m;
    for (int a = 0; a < 2; a++)
        if (need->need_lo[a] < have->origin[a] || need->need_hi[a] > have->origin[a] + ext)
            return false;
    return true;
}

sq__texel_rect sq__snow_map_rect(const sq__snow_map_geom *g, const sq__snow_map_geom *need, int grow)
{
    sq__texel_rect t;
    for (int a = 0; a < 2; a++) {
        const double lo = floor((need->need_lo[a] - g->origin[a]) / g->texel_m) - grow;
        const double hi = ceil((need->need_hi[a] - g->origin[a]) / g->texel_m) + grow;
        t.lo[a] = (int)fmin(fmax(lo, 0.0), (double)g->size);
        t.hi[a] = (int)fmin(fmax(hi, 0.0), (double)g->size);
    }
    return t;
}

static bool rect_empty(sq__texel_rect a) { return a.hi[0] <= a.lo[0] || a.hi[1] <= a.lo[1]; }

bool sq__texel_rect_inside(sq__texel_rect a, sq__texel_rect b)
{
    return rect_empty(a) || (!rect_empty(b) && a.lo[0] >= b.lo[0] && a.lo[1] >= b.lo[1] &&
                             a.hi[0] <= b.hi[0] && a.hi[1] <= b.hi[1]);
}

int sq__texel_rect_minus(sq__texel_rect want, sq__texel_rect have, sq__texel_rect out[4])
{
    if (rect_empty(want)) return 0;
    sq__texel_rect o;
    for (int a = 0; a < 2; a++) {
        o.lo[a] = want.lo[a] > have.lo[a] ? want.lo[a] : have.lo[a];
        o.hi[a] = want.hi[a] < have.hi[a] ? want.hi[a] : have.hi[a];
    }
    if (rect_empty(o)) {
        out[0] = want;
        return 1;
    }
    int n = 0;
    const sq__texel_rect band[4] = {
        {{want.lo[0], want.lo[1]}, {want.hi[0], o.lo[1]}}, /* below the overlap, full width */
        {{want.lo[0], o.hi[1]}, {want.hi[0], want.hi[1]}}, /* above */
        {{want.lo[0], o.lo[1]}, {o.lo[0], o.hi[1]}},       /* left of it, its height */
        {{o.hi[0], o.lo[1]}, {want.hi[0], o.hi[1]}},       /* right */
    };
    for (int k = 0; k < 4; k++)
        if (!rect_empty(band[k])) out[n++] = band[k];
    return n;
}

void sq__snow_map_fill(const sq_world *w, const sq__snow_map_geom *g, float *height)
{
    for (int j = 0; j < g->size; j++)
        for (int i = 0; i < g->size; i++)
            height[(size_t)j * (size_t)g->size + (size_t)i] =
                sq_world_surface_at(w, (float)(g->origin[0] + (i + 0.5) * g->texel_m),
                                    (float)(g->origin[1] + (j + 0.5) * g->texel_m));
}

/* ---- eq 2.2: exposure --------------------------------------------------------------------- */
int sq__snow_taps(int m, float radius_texels, float offsets[][2])
{
    const float r = radius_texels;
    int n = 0;
    if (m == 1 || m == 5) offsets[n][0] = offsets[n][1] = 0.0f, n++;
    if (m == 4 || m == 5) {
        static const float dir[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (int k = 0; k < 4; k++) offsets[n][0] = r * dir[k][0], offsets[n][1] = r * dir[k][1], n++;
    }
    if (m == 9)
        for (int j = -1; j <= 1; j++)
            for (int i = -1; i <= 1; i++) offsets[n][0] = r * (float)i, offsets[n][1] = r * (float)j, n++;
    return n;
}

float sq__snow_slope_bias(const sq__snow_map_geom *g, float nz, float radius_texels, float bias_m)
{
    const float c = sq_clampf(nz, 0.3162f, 1.0f); /* tan at most 3 */
    return bias_m + (radius_texels + 0.5f) * (float)g->texel_m * sqrtf(1.0f - c * c) / c;
}

float sq__snow_exposure(const float *height, const sq__snow_map_geom *g, sq_vec3 p, float nz,
                        int taps, float radius_texels, float bias_m)
{
    bias_m = sq__snow_slope_bias(g, nz, radius_texels, bias_m);
    float off[9][2];
    const int m = sq__snow_taps(taps, radius_texels, off);
    if (m == 0) return 1.0f;
    const double u = ((double)p.x - g->origin[0]) / g->texel_m, v = ((double)p.y - g->origin[1]) / g->texel_m;
    if (u < 0.0 || v < 0.0 || u >= g->size || v >= g->size) return 1.0f;
    double exposed = 0.0;
    for (int k = 0; k < m; k++) {
        /* each tap compares the four texels around it and blends the answers bilinearly
         * (percentage-closer filtering, as the shader): the grid is the world's, so the answer
         * depends on the point alone; taps off the map read its edge */
        const double a = u + (double)off[k][0] - 0.5, b = v + (double)off[k][1] - 0.5;
        const double fa = floor(a), fb = floor(b);
        const double wx = a - fa, wy = b - fb;
        for (int q = 0; q < 4; q++) {
            const int i = sq_clampi((int)fa + (q & 1), 0, g->size - 1);
            const int j = sq_clampi((int)fb + (q >> 1), 0, g->size - 1);
            const float occ = height[(size_t)j * (size_t)g->size + (size_t)i];
            const double wq = ((q & 1) ? wx : 1.0 - wx) * ((q >> 1) ? wy : 1.0 - wy);
            if (occ <= p.z + bias_m) exposed += wq; /* D_occ - D_act >= -b, depth downward */
        }
    }
    return (float)(exposed / m);
}

float sq__snow_corner_exposure(const float *height, const sq__snow_map_geom *g, sq_vec3 p, float nz,
                               float radius_texels, float bias_m)
{
    bias_m = sq__snow_slope_bias(g, nz, radius_texels, bias_m);
    const double u = ((double)p.x - g->origin[0]) / g->texel_m, v = ((double)p.y - g->origin[1]) / g->texel_m;
    if (u < 0.0 || v < 0.0 || u >= g->size || v >= g->size) return 1.0f;
    const int i0 = (int)floor(u - 0.5), j0 = (int)floor(v - 0.5);
    for (int q = 0; q < 4; q++) {
        const int i = sq_clampi(i0 + (q & 1), 0, g->size - 1), j = sq_clampi(j0 + (q >> 1), 0, g->size - 1);
        if (height[(size_t)j * (size_t)g->size + (size_t)i] > p.z + bias_m) return 0.0f;
    }
    return 1.0f;
}

/* ---- eq 2.3: inclination with noise --------------------------------------------------------- */
static float hash3(int x, int y, int z)
{
    uint32_t h = (uint32_t)x * 0x8da6b343u ^ (uint32_t)y * 0xd8163841u ^ (uint32_t)z * 0xcb1ab31fu;
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (float)(h & 0xffffffu) / 16777215.0f;
}

float sq__snow_noise3(sq_vec3 x)
{
    const float fx = floorf(x.x), fy = floorf(x.y), fz = floorf(x.z);
    const int ix = (int)fx, iy = (int)fy, iz = (int)fz;
    const float tx = x.x - fx, ty = x.y - fy, tz = x.z - fz;
    const float ux = tx * tx * (3 - 2 * tx), uy = ty * ty * (3 - 2 * ty), uz = tz * tz * (3 - 2 * tz);
    float c[2];
    for (int k = 0; k < 2; k++) {
        const float a = hash3(ix, iy, iz + k), b = hash3(ix + 1, iy, iz + k);
        const float d = hash3(ix, iy + 1, iz + k), e = hash3(ix + 1, iy + 1, iz + k);
        c[k] = (a + (b - a) * ux) + ((d + (e - d) * ux) - (a + (b - a) * ux)) * uy;
    }
    return c[0] + (c[1] - c[0]) * uz;
}

float sq__snow_fbm3(sq_vec3 x, int octaves)
{
    float sum = 0.0f, amp = 0.5f, norm = 0.0f;
    for (int o = 0; o < octaves; o++) {
        sum += amp * sq__snow_noise3(x);
        norm += amp;
        amp *= 0.5f;
        x = sq_v3_scale(x, 2.0f);
    }
    return norm > 0.0f ? sum / norm : 0.5f;
}

float sq__snow_inclination(sq_vec3 n, sq_vec3 p, float amplitude, float scale_m)
{
    const float up = fmaxf(0.0f, n.z);
    if (up <= 0.0f || amplitude == 0.0f) return fminf(up, 1.0f);
    const float fbm = sq__snow_fbm3(sq_v3_scale(p, 1.0f / scale_m), 3);
    return sq_clampf(up * (1.0f + amplitude * (2.0f * fbm - 1.0f)), 0.0f, 1.0f);
}

/* ---- the snow shell ----------------------------------------------------------------------- */
sq_vec3 sq__snow_shell_offset(sq_vec4 ns, float depth_m, float f_e, float blend)
{
    const float w = fminf(1.0f, 2.0f * fmaxf(0.0f, ns.z));
    if (w <= 0.0f) return sq_v3(0.0f, 0.0f, 0.0f);
    const sq_vec3 up = sq_v3(0.0f, 0.0f, 1.0f);
    const sq_vec3 dir = ns.w > 0.5f ? up : sq_v3_norm(sq_v3_lerp(sq_v3(ns.x, ns.y, ns.z), up, blend));
    return sq_v3_scale(dir, depth_m * f_e * w);
}

sq_vec3 sq__snow_shell_normal(sq_vec3 n, float gx, float gy)
{
    const float w = fminf(1.0f, 2.0f * fmaxf(0.0f, n.z));
    if (w <= 0.0f) return n;
    return sq_v3_norm(sq_v3_sub(n, sq_v3(n.z * w * gx, n.z * w * gy, 0.0f)));
}

typedef struct keyed {
    float p[3];
    int i;
} keyed;

static int by_position(const void *a, const void *b)
{
    const float *p = ((const keyed *)a)->p, *q = ((const keyed *)b)->p;
    for (int k = 0; k < 3; k++)
        if (p[k] != q[k]) return p[k] < q[k] ? -1 : 1;
    return 0;
}

/* Whether normal a is above b: larger z, ties broken by x, then y (any order of the group gives
 * the same upmost normal). */
static bool upper(const float *a, const float *b)
{
    if (a[2] != b[2]) return a[2] > b[2];
    if (a[0] != b[0]) return a[0] > b[0];
    return a[1] > b[1];
}

/* Marks (1) the vertices that are a corner of a wall triangle above its lowest corner. */
static void mark_wall_tops(const float *positions, const uint32_t *indices, int index_count, int n,
                           unsigned char *top)
{
    memset(top, 0, (size_t)n);
    for (int t = 0; t + 2 < index_count; t += 3) {
        const uint32_t v[3] = {indices[t], indices[t + 1], indices[t + 2]};
        if (v[0] >= (uint32_t)n || v[1] >= (uint32_t)n || v[2] >= (uint32_t)n) continue;
        const float *a = &positions[3 * (size_t)v[0]], *b = &positions[3 * (size_t)v[1]],
                    *c = &positions[3 * (size_t)v[2]];
        const sq_vec3 x = sq_v3_cross(sq_v3(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                                      sq_v3(c[0] - a[0], c[1] - a[1], c[2] - a[2]));
        const float len = sq_v3_len(x);
        if (!(len > 0.0f) || fabsf(x.z) >= SQ__SNOW_WALL_NZ * len) continue;
        const float low = fminf(a[2], fminf(b[2], c[2]));
        for (int k = 0; k < 3; k++)
            if (positions[3 * (size_t)v[k] + 2] > low) top[v[k]] = 1;
    }
}

bool sq__snow_welded_normals(sq_context *ctx, const float *positions, const float *normals, int n,
                             const uint32_t *indices, int index_count, float *out)
{
    for (int i = 0; i < n; i++) {
        memcpy(&out[4 * (size_t)i], &normals[3 * (size_t)i], 3 * sizeof(float));
        out[4 * (size_t)i + 3] = 0.0f;
    }
    keyed *order = sq_alloc(ctx, (size_t)(n > 0 ? n : 1) * sizeof *order);
    unsigned char *wall = sq_alloc(ctx, (size_t)(n > 0 ? n : 1));
    if (!order || !wall) {
        sq_free(ctx, order);
        sq_free(ctx, wall);
        return false;
    }
    mark_wall_tops(positions, indices, index_count, n, wall);
    for (int i = 0; i < n; i++) {
        memcpy(order[i].p, &positions[3 * (size_t)i], sizeof order[i].p);
        order[i].i = i;
    }
    qsort(order, (size_t)n, sizeof *order, by_position);
    for (int a = 0; a < n;) {
        int b = a + 1;
        while (b < n && by_position(&order[a], &order[b]) == 0) b++;
        sq_vec3 s = sq_v3(0.0f, 0.0f, 0.0f);
        const float *top = &normals[3 * (size_t)order[a].i];
        bool on_wall = false;
        for (int k = a; k < b; k++) {
            const float *q = &normals[3 * (size_t)order[k].i];
            s = sq_v3_add(s, sq_v3(q[0], q[1], q[2]));
            if (upper(q, top)) top = q;
            on_wall = on_wall || wall[order[k].i];
        }
        const bool wall_top = on_wall && top[2] >= SQ__SNOW_WALL_NZ;
        if (wall_top)
            s = sq_v3(top[0], top[1], top[2]);
        else /* opposite normals at one place (a sheet seen from both sides) cancel: keep up */
            s = sq_v3_len(s) > 1e-6f ? sq_v3_norm(s) : sq_v3(0.0f, 0.0f, 1.0f);
        for (int k = a; k < b; k++) {
            float *o = &out[4 * (size_t)order[k].i];
            o[0] = s.x, o[1] = s.y, o[2] = s.z, o[3] = wall_top ? 1.0f : 0.0f;
        }
        a = b;
    }
    sq_free(ctx, wall);
    sq_free(ctx, order);
    return true;
}
