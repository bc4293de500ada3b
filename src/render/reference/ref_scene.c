/* ref_scene.c — the reference path tracer's scene: preparation from sq_world and drawables,
 * the analytic sky, ray intersection with the terrain heightfield (two-level 2D DDA over
 * blocks and cells, two triangles per cell), surface drawables, obstacles (convex polytopes:
 * boxes, and boxes with a gable roof), and the volume density lookup with brick majorants for
 * delta and ratio tracking (SPEC §2.1 Beer–Lambert; Woodcock tracking). */
#include <float.h>
#include <math.h>
#include <string.h>

#include "render/reference/reference_internal.h"
#include "world/world_struct.h"

#define MODULE "reference"

/* ---- sky (frame_common.glsl sq_sky_radiance) ------------------------------------------- */

#define SKY_SUN_ANGULAR_RADIUS 0.00465 /* rad (0.27 degrees) */

static double smoothstep(double e0, double e1, double x)
{
    double t = (x - e0) / (e1 - e0);
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    return t * t * (3.0 - 2.0 * t);
}

void sq__ref_sky(const sq__ref_scene *s, sq__dv3 d, double z_m, bool with_sun, double out[3])
{
    const sq__dv3 sd = s->sun_dir;
    const double mu = d.z, h = mu > 0.0 ? mu : 0.0;
    const double t = (1.0 - h) * (1.0 - h) * (1.0 - h);
    for (int c = 0; c < 3; c++) out[c] = s->zenith[c] + (s->horizon[c] - s->zenith[c]) * t;
    if (mu < 0.0) {
        double f = smoothstep(0.0, 0.15, -mu);
        for (int c = 0; c < 3; c++) out[c] = s->horizon[c] + (s->ground[c] - s->horizon[c]) * f;
    }
    const double cth = sq__dv_dot(d, sd);
    const double haze = 0.05 * (s->turbidity - 1.0 > 0.0 ? s->turbidity - 1.0 : 0.0) *
                        exp(-fmax(z_m * s->inv_exaggeration, 0.0) / 1500.0);
    if (haze > 0.0 && sd.z >= -0.02) {
        double tau = haze / (h > 0.05 ? h : 0.05);
        double glow = SQ_PI * sq__hg_eval(0.75, cth) * -expm1(-tau) * 0.5;
        for (int c = 0; c < 3; c++) out[c] += s->sun_rad[c] * glow;
    }
    if (with_sun && mu > 0.0 && sd.z > -SKY_SUN_ANGULAR_RADIUS &&
        cth > cos(SKY_SUN_ANGULAR_RADIUS)) {
        const double omega = SQ_PI * SKY_SUN_ANGULAR_RADIUS * SKY_SUN_ANGULAR_RADIUS;
        double r = acos(cth < 1.0 ? cth : 1.0) / SKY_SUN_ANGULAR_RADIUS;
        r = r < 0.0 ? 0.0 : (r > 1.0 ? 1.0 : r);
        const double limb = 1.0 - 0.4 * (1.0 - sqrt(fmax(1.0 - r * r, 0.0)));
        for (int c = 0; c < 3; c++) out[c] += fmin(SQ_PI * s->sun_rad[c] / omega * limb, 30000.0);
    }
}

/* ---- procedural detail (frame_common.glsl sq_hash, sq_value_noise, sq_fbm) -------------- */

static double hash2(int32_t qx, int32_t qy)
{
    uint32_t h = ((uint32_t)qx * 0x8da6b343u) ^ ((uint32_t)qy * 0xd8163841u);
    h ^= h >> 13;
    h *= 0x5bd1e995u;
    h ^= h >> 15;
    return (double)(h & 0xffffffu) / 16777215.0;
}

double sq__ref_value_noise(double x, double y)
{
    double ix = floor(x), iy = floor(y);
    double fx = x - ix, fy = y - iy;
    double ux = fx * fx * (3.0 - 2.0 * fx), uy = fy * fy * (3.0 - 2.0 * fy);
    int32_t qx = (int32_t)ix, qy = (int32_t)iy;
    double a = hash2(qx, qy), b = hash2(qx + 1, qy), c = hash2(qx, qy + 1), e = hash2(qx + 1, qy + 1);
    double lo = a + (b - a) * ux, hi = c + (e - c) * ux;
    return lo + (hi - lo) * uy;
}

double sq__ref_fbm(double x, double y)
{
    return 0.5 * sq__ref_value_noise(x, y) +
           0.3 * sq__ref_value_noise(2.03 * x + 17.1, 2.03 * y + 17.1) +
           0.2 * sq__ref_value_noise(4.01 * x + 41.7, 4.01 * y + 41.7);
}

void sq__ref_terrain_albedo(const double flat[3], const double steep[3], sq__dv3 p, sq__dv3 n,
                            double out[3])
{
    double st = 1.0 - smoothstep(0.72, 0.85, n.z);
    double detail = (0.85 + 0.3 * sq__ref_fbm(p.x / 40.0, p.y / 40.0)) *
                    (0.9 + 0.2 * sq__ref_value_noise(p.x / 2.0, p.y / 2.0));
    for (int c = 0; c < 3; c++) out[c] = (flat[c] + (steep[c] - flat[c]) * st) * detail;
}

/* ---- heightfields ------------------------------------------------------------------------ */

double sq__ref_heightfield_height(const sq__ref_heightfield *hf, double x, double y)
{
    double fx = (x - hf->ox) / hf->dx, fy = (y - hf->oy) / hf->dy;
    fx = fx < 0.0 ? 0.0 : (fx > hf->nx - 1 ? hf->nx - 1 : fx);
    fy = fy < 0.0 ? 0.0 : (fy > hf->ny - 1 ? hf->ny - 1 : fy);
    int i = (int)fx, j = (int)fy;
    if (i > hf->nx - 2) i = hf->nx - 2;
    if (j > hf->ny - 2) j = hf->ny - 2;
    double a = fx - i, b = fy - j;
    const float *h = hf->h;
    int nx = hf->nx;
    return (1 - a) * (1 - b) * (double)h[j * nx + i] + a * (1 - b) * (double)h[j * nx + i + 1] +
           (1 - a) * b * (double)h[(j + 1) * nx + i] + a * b * (double)h[(j + 1) * nx + i + 1];
}

/* Möller–Trumbore; returns t or -1, with barycentrics (u for p1, v for p2). */
static double tri_hit(sq__dv3 o, sq__dv3 d, sq__dv3 p0, sq__dv3 p1, sq__dv3 p2, double *u,
                      double *v)
{
    sq__dv3 e1 = sq__dv_sub(p1, p0), e2 = sq__dv_sub(p2, p0);
    sq__dv3 pv = sq__dv_cross(d, e2);
    double det = sq__dv_dot(e1, pv);
    if (fabs(det) < 1e-300) return -1.0;
    double inv = 1.0 / det;
    sq__dv3 tv = sq__dv_sub(o, p0);
    double uu = sq__dv_dot(tv, pv) * inv;
    if (uu < 0.0 || uu > 1.0) return -1.0;
    sq__dv3 qv = sq__dv_cross(tv, e1);
    double vv = sq__dv_dot(d, qv) * inv;
    if (vv < 0.0 || uu + vv > 1.0) return -1.0;
    *u = uu;
    *v = vv;
    return sq__dv_dot(e2, qv) * inv;
}

static sq__dv3 hf_vertex(const sq__ref_heightfield *hf, int i, int j)
{
    return sq__dv(hf->ox + i * hf->dx, hf->oy + j * hf->dy, (double)hf->h[j * hf->nx + i]);
}

static sq__dv3 hf_normal(const sq__ref_heightfield *hf, int i, int j)
{
    if (hf->normals) {
        const float *n = hf->normals + 3 * ((size_t)j * hf->nx + i);
        return sq__dv((double)n[0], (double)n[1], (double)n[2]);
    }
    /* central differences, one-sided at the edges (renderer.c terrain mesh, surface.vert) */
    const int il = i > 0 ? i - 1 : i, ir = i < hf->nx - 1 ? i + 1 : i;
    const int jl = j > 0 ? j - 1 : j, jr = j < hf->ny - 1 ? j + 1 : j;
    const float *h = hf->h;
    double gx = ((double)h[j * hf->nx + ir] - (double)h[j * hf->nx + il]) / ((ir - il) * hf->dx);
    double gy = ((double)h[jr * hf->nx + i] - (double)h[jl * hf->nx + i]) / ((jr - jl) * hf->dy);
    return sq__dv_norm(sq__dv(-gx, -gy, 1.0));
}

static void hf_shade(sq__ref_shade shade, const double alb[3], const double steep[3], sq__dv3 p,
                     sq__dv3 n, double out[3])
{
    if (shade == SQ__REF_SHADE_TERRAIN) {
        sq__ref_terrain_albedo(alb, steep, p, n, out);
    } else if (shade == SQ__REF_SHADE_DETAIL) {
        double detail = 0.9 + 0.2 * sq__ref_fbm(p.x / 3.0, p.y / 3.0);
        for (int c = 0; c < 3; c++) out[c] = alb[c] * detail;
    } else {
        for (int c = 0; c < 3; c++) out[c] = alb[c];
    }
}

static double hf_coverage(const sq__ref_heightfield *hf, int i, int j)
{
    return hf->coverage ? (double)hf->coverage[j * hf->nx + i] : 1.0;
}

/* The nearest triangle hit found so far in a heightfield walk. */
typedef struct hf_cand {
    double t, u, v;
    int i, j, tri;
} hf_cand;

/* Tests the two triangles of cell (i, j); keeps the nearest hit in (tmin, *tbest). */
static bool hf_cell_hit(const sq__ref_heightfield *hf, int i, int j, sq__dv3 o, sq__dv3 d,
                        double tmin, double *tbest, hf_cand *cand)
{
    sq__dv3 p00 = hf_vertex(hf, i, j), p10 = hf_vertex(hf, i + 1, j);
    sq__dv3 p01 = hf_vertex(hf, i, j + 1), p11 = hf_vertex(hf, i + 1, j + 1);
    bool found = false;
    for (int tri = 0; tri < 2; tri++) {
        sq__dv3 a = p00, b = tri == 0 ? p10 : p11, c = tri == 0 ? p11 : p01;
        double u = 0.0, v = 0.0, t = tri_hit(o, d, a, b, c, &u, &v);
        if (!(t > tmin && t < *tbest)) continue;
        *tbest = t;
        found = true;
        cand->t = t;
        cand->u = u;
        cand->v = v;
        cand->i = i;
        cand->j = j;
        cand->tri = tri;
    }
    return found;
}

/* Normals and albedo at the chosen hit. */
static void hf_finish(const sq__ref_heightfield *hf, const hf_cand *cd, sq__dv3 o, sq__dv3 d,
                      sq__ref_hit *hit)
{
    const int i = cd->i, j = cd->j, tri = cd->tri;
    const double u = cd->u, v = cd->v, w0 = 1.0 - u - v;
    const int ib = i + 1, jb = tri == 0 ? j : j + 1;
    const int ic = tri == 0 ? i + 1 : i, jc = j + 1;
    sq__dv3 a = hf_vertex(hf, i, j), b = hf_vertex(hf, ib, jb), c = hf_vertex(hf, ic, jc);
    sq__dv3 ng = sq__dv_norm(sq__dv_cross(sq__dv_sub(b, a), sq__dv_sub(c, a)));
    sq__dv3 na = hf_normal(hf, i, j), nb = hf_normal(hf, ib, jb), nc = hf_normal(hf, ic, jc);
    sq__dv3 ns = sq__dv_norm(sq__dv_add(sq__dv_add(sq__dv_scale(na, w0), sq__dv_scale(nb, u)),
                                        sq__dv_scale(nc, v)));
    sq__dv3 p = sq__dv_madd(o, d, cd->t);
    double alb[3];
    hf_shade(hf->shade, hf->albedo, hf->steep, p, ns, alb);
    if (hf->coverage) {
        double cov = w0 * hf_coverage(hf, i, j) + u * hf_coverage(hf, ib, jb) +
                     v * hf_coverage(hf, ic, jc);
        cov = cov < 0.0 ? 0.0 : (cov > 1.0 ? 1.0 : cov);
        double under[3];
        hf_shade(hf->under_shade, hf->under_albedo, hf->under_steep, p, ns, under);
        for (int ch = 0; ch < 3; ch++) alb[ch] = cov * alb[ch] + (1.0 - cov) * under[ch];
    }
    if (sq__dv_dot(ng, d) > 0.0) ng = sq__dv_scale(ng, -1.0);
    if (sq__dv_dot(ns, ng) < 0.0) ns = sq__dv_scale(ns, -1.0);
    hit->t = cd->t;
    hit->ng = ng;
    hit->ns = ns;
    for (int ch = 0; ch < 3; ch++) hit->albedo[ch] = alb[ch];
}

/* Clips the ray to an axis-aligned box; returns false if [t0, t1] is empty. */
static bool clip_box(sq__dv3 o, sq__dv3 d, sq__dv3 bmin, sq__dv3 bmax, double *t0, double *t1)
{
    const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    const double lo[3] = {bmin.x, bmin.y, bmin.z}, hi[3] = {bmax.x, bmax.y, bmax.z};
    double a = *t0, b = *t1;
    for (int k = 0; k < 3; k++) {
        if (dd[k] == 0.0) {
            if (oo[k] < lo[k] || oo[k] > hi[k]) return false;
            continue;
        }
        double inv = 1.0 / dd[k];
        double ta = (lo[k] - oo[k]) * inv, tb = (hi[k] - oo[k]) * inv;
        if (ta > tb) {
            double tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > a) a = ta;
        if (tb < b) b = tb;
        if (a > b) return false;
    }
    *t0 = a;
    *t1 = b;
    return true;
}

/* 2D DDA state over a grid of cells of size (cw, ch) starting at (gx0, gy0). */
typedef struct dda2 {
    int ix, iy, sx, sy, nx, ny;
    double tx, ty, dtx, dty; /* next crossing t per axis, t per cell */
} dda2;

/* Sets the next crossings for the current cell (ix, iy). */
static void dda2_set(dda2 *s, sq__dv3 o, sq__dv3 d, double gx0, double gy0, double cw, double ch)
{
    if (d.x > 0.0) {
        s->sx = 1;
        s->dtx = cw / d.x;
        s->tx = (gx0 + (s->ix + 1) * cw - o.x) / d.x;
    } else if (d.x < 0.0) {
        s->sx = -1;
        s->dtx = -cw / d.x;
        s->tx = (gx0 + s->ix * cw - o.x) / d.x;
    } else {
        s->sx = 0;
        s->dtx = INFINITY;
        s->tx = INFINITY;
    }
    if (d.y > 0.0) {
        s->sy = 1;
        s->dty = ch / d.y;
        s->ty = (gy0 + (s->iy + 1) * ch - o.y) / d.y;
    } else if (d.y < 0.0) {
        s->sy = -1;
        s->dty = -ch / d.y;
        s->ty = (gy0 + s->iy * ch - o.y) / d.y;
    } else {
        s->sy = 0;
        s->dty = INFINITY;
        s->ty = INFINITY;
    }
}

static void dda2_init(dda2 *s, sq__dv3 o, sq__dv3 d, double t0, double gx0, double gy0,
                      double cw, double ch, int nx, int ny)
{
    double px = (o.x + d.x * t0 - gx0) / cw, py = (o.y + d.y * t0 - gy0) / ch;
    s->nx = nx;
    s->ny = ny;
    s->ix = sq_clampi((int)floor(px), 0, nx - 1);
    s->iy = sq_clampi((int)floor(py), 0, ny - 1);
    dda2_set(s, o, d, gx0, gy0, cw, ch);
}

/* End of the current cell's t range; advances; returns false when leaving the grid. */
static bool dda2_step(dda2 *s)
{
    if (s->tx < s->ty) {
        s->ix += s->sx;
        s->tx += s->dtx;
        return s->ix >= 0 && s->ix < s->nx;
    }
    s->iy += s->sy;
    s->ty += s->dty;
    return s->iy >= 0 && s->iy < s->ny;
}

static double dda2_exit(const dda2 *s) { return s->tx < s->ty ? s->tx : s->ty; }

bool sq__ref_heightfield_intersect(const sq__ref_heightfield *hf, sq__dv3 o, sq__dv3 d,
                                   double tmin, double tmax, sq__ref_hit *hit)
{
    if (hf->nx < 2 || hf->ny < 2) return false;
    double x1 = hf->ox + (hf->nx - 1) * hf->dx, y1 = hf->oy + (hf->ny - 1) * hf->dy;
    double pad = 1e-9 * (fabs(x1) + fabs(y1) + fabs(hf->zmax) + 1.0);
    double t0 = tmin, t1 = tmax;
    if (!clip_box(o, d, sq__dv(hf->ox - pad, hf->oy - pad, hf->zmin - pad),
                  sq__dv(x1 + pad, y1 + pad, hf->zmax + pad), &t0, &t1))
        return false;
    const int ncx = hf->nx - 1, ncy = hf->ny - 1;
    const double bw = hf->dx * SQ__REF_BLOCK, bh = hf->dy * SQ__REF_BLOCK;
    double tbest = tmax;
    bool found = false;
    hf_cand cand = {0.0, 0.0, 0.0, 0, 0, 0};
    dda2 b;
    dda2_init(&b, o, d, t0, hf->ox, hf->oy, bw, bh, hf->bnx, hf->bny);
    double ta = t0;
    for (;;) {
        double tb = dda2_exit(&b);
        if (tb > t1) tb = t1;
        double za = o.z + d.z * ta, zb = o.z + d.z * tb;
        if ((za < zb ? za : zb) <= (double)hf->block_max[b.iy * hf->bnx + b.ix]) {
            /* walk the cells of this block over [ta, tb] */
            dda2 c;
            dda2_init(&c, o, d, ta, hf->ox, hf->oy, hf->dx, hf->dy, ncx, ncy);
            int cx0 = b.ix * SQ__REF_BLOCK, cy0 = b.iy * SQ__REF_BLOCK;
            c.ix = sq_clampi(c.ix, cx0, sq_clampi(cx0 + SQ__REF_BLOCK - 1, 0, ncx - 1));
            c.iy = sq_clampi(c.iy, cy0, sq_clampi(cy0 + SQ__REF_BLOCK - 1, 0, ncy - 1));
            dda2_set(&c, o, d, hf->ox, hf->oy, hf->dx, hf->dy);
            double ca = ta;
            for (;;) {
                double cb = dda2_exit(&c);
                if (cb > tb) cb = tb;
                double zca = o.z + d.z * ca, zcb = o.z + d.z * cb;
                if ((zca < zcb ? zca : zcb) <= (double)hf->cell_max[c.iy * ncx + c.ix]) {
                    if (hf_cell_hit(hf, c.ix, c.iy, o, d, tmin, &tbest, &cand)) found = true;
                    /* a neighbour may still be hit first through rounding; but every hit in
                     * this cell is within its column, so stop after this cell's t range */
                }
                if (found && tbest <= cb + 1e-9 * (1.0 + cb)) goto done;
                if (cb >= tb) break;
                ca = cb;
                if (!dda2_step(&c)) break;
                if (c.ix < cx0 || c.ix >= cx0 + SQ__REF_BLOCK || c.iy < cy0 ||
                    c.iy >= cy0 + SQ__REF_BLOCK)
                    break;
            }
        }
        if (found && tbest <= tb + 1e-9 * (1.0 + tb)) goto done;
        if (tb >= t1) break;
        ta = tb;
        if (!dda2_step(&b)) break;
    }
done:
    if (found && hit) hf_finish(hf, &cand, o, d, hit);
    return found;
}

/* ---- obstacles: convex polytopes in the local frame ------------------------------------- */

bool sq__ref_obstacle_intersect(const sq__ref_obstacle *ob, sq__dv3 o, sq__dv3 d, double tmin,
                                double tmax, sq__ref_hit *hit)
{
    double ta = tmin, tb = tmax;
    if (!clip_box(o, d, ob->bmin, ob->bmax, &ta, &tb)) return false;
    /* local frame: rotate by -yaw about the footprint centre, z from the base */
    sq__dv3 r = sq__dv_sub(o, ob->c);
    double c = ob->cos_yaw, s = ob->sin_yaw;
    sq__dv3 lo = sq__dv(c * r.x + s * r.y, -s * r.x + c * r.y, r.z);
    sq__dv3 ld = sq__dv(c * d.x + s * d.y, -s * d.x + c * d.y, d.z);
    /* planes n . p <= k */
    sq__dv3 n[7];
    double k[7];
    int np = 0;
    n[np] = sq__dv(1, 0, 0), k[np++] = ob->hx;
    n[np] = sq__dv(-1, 0, 0), k[np++] = ob->hx;
    n[np] = sq__dv(0, 1, 0), k[np++] = ob->hy;
    n[np] = sq__dv(0, -1, 0), k[np++] = ob->hy;
    n[np] = sq__dv(0, 0, -1), k[np++] = 0.0;
    if (ob->roof > 0.0) {
        /* z <= h + roof (1 - |y| / hy): two planes (roof/hy) y + z <= h + roof and mirrored */
        double a = ob->roof / ob->hy;
        n[np] = sq__dv(0, a, 1), k[np++] = ob->h + ob->roof;
        n[np] = sq__dv(0, -a, 1), k[np++] = ob->h + ob->roof;
    } else {
        n[np] = sq__dv(0, 0, 1), k[np++] = ob->h;
    }
    double tnear = -INFINITY, tfar = INFINITY;
    int inear = -1, ifar = -1;
    for (int p = 0; p < np; p++) {
        double den = sq__dv_dot(n[p], ld), dist = k[p] - sq__dv_dot(n[p], lo);
        if (den == 0.0) {
            if (dist < 0.0) return false;
            continue;
        }
        double t = dist / den;
        if (den < 0.0) {
            if (t > tnear) {
                tnear = t;
                inear = p;
            }
        } else if (t < tfar) {
            tfar = t;
            ifar = p;
        }
        if (tnear > tfar) return false;
    }
    if (inear < 0 || !(tnear > tmin && tnear < tmax)) return false;
    int ihit = inear;
    double thit = tnear, side = 1.0;
    if (ob->fence) {
        /* mesh.frag: boards 10 cm wide with 5 cm gaps, solid rails in the bottom and top 12 %;
         * a ray entering through a gap meets the back face (drawn: no culling) at its exit */
        for (int face = 0; face < 2; face++) {
            sq__dv3 q = sq__dv_madd(lo, ld, thit);
            double frac = q.z / ob->h, along = ob->along_x ? q.x : q.y;
            bool rail = frac < 0.12 || frac > 0.88;
            double f = along / 0.15 - floor(along / 0.15);
            if (rail || !(f > 0.667)) break;
            if (face == 1 || ifar < 0 || !(tfar < tmax)) return false;
            ihit = ifar;
            thit = tfar;
            side = -1.0;
        }
    }
    if (!hit) return true;
    sq__dv3 nl = sq__dv_scale(sq__dv_norm(n[ihit]), side);
    sq__dv3 nw = sq__dv(c * nl.x - s * nl.y, s * nl.x + c * nl.y, nl.z);
    hit->t = thit;
    hit->ng = nw;
    hit->ns = nw;
    const double *alb = (ob->roof > 0.0 && ihit >= 5) ? ob->roof_albedo : ob->albedo;
    for (int ch = 0; ch < 3; ch++) hit->albedo[ch] = alb[ch];
    return true;
}

bool sq__ref_intersect(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double tmin, double tmax,
                       sq__ref_hit *hit)
{
    bool found = false;
    double tbest = tmax;
    sq__ref_hit h;
    if (s->has_terrain && sq__ref_heightfield_intersect(&s->terrain, o, d, tmin, tbest, &h)) {
        *hit = h;
        tbest = h.t;
        found = true;
    }
    for (int i = 0; i < s->surface_count; i++)
        if (sq__ref_heightfield_intersect(&s->surfaces[i], o, d, tmin, tbest, &h)) {
            *hit = h;
            tbest = h.t;
            found = true;
        }
    for (int i = 0; i < s->obstacle_count; i++)
        if (sq__ref_obstacle_intersect(&s->obstacles[i], o, d, tmin, tbest, &h)) {
            *hit = h;
            tbest = h.t;
            found = true;
        }
    return found;
}

bool sq__ref_occluded(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double tmin, double tmax)
{
    for (int i = 0; i < s->obstacle_count; i++)
        if (sq__ref_obstacle_intersect(&s->obstacles[i], o, d, tmin, tmax, NULL)) return true;
    if (s->has_terrain && sq__ref_heightfield_intersect(&s->terrain, o, d, tmin, tmax, NULL))
        return true;
    for (int i = 0; i < s->surface_count; i++)
        if (sq__ref_heightfield_intersect(&s->surfaces[i], o, d, tmin, tmax, NULL)) return true;
    return false;
}

/* ---- volumes ------------------------------------------------------------------------------ */

static inline double dens_at(const sq__ref_volume *v, int i, int j, int k)
{
    float x = v->density[((size_t)k * v->ny + j) * v->nx + i];
    return x > 0.0f ? (double)x : 0.0;
}

double sq__ref_volume_density(const sq__ref_volume *v, sq__dv3 p)
{
    double u[3] = {(p.x - v->org.x) / v->size.x, (p.y - v->org.y) / v->size.y,
                   (p.z - v->org.z) / v->size.z};
    if (u[0] < 0.0 || u[0] > 1.0 || u[1] < 0.0 || u[1] > 1.0 || u[2] < 0.0 || u[2] > 1.0)
        return 0.0;
    const int n[3] = {v->nx, v->ny, v->nz};
    int i0[3], i1[3];
    double f[3];
    for (int a = 0; a < 3; a++) {
        double x = u[a] * n[a] - 0.5;
        if (x < 0.0) x = 0.0;
        if (x > n[a] - 1) x = n[a] - 1;
        int i = (int)x;
        if (i > n[a] - 2) i = n[a] - 2 < 0 ? 0 : n[a] - 2;
        i0[a] = i;
        i1[a] = i + 1 < n[a] ? i + 1 : i;
        f[a] = x - i;
    }
    double c00 = dens_at(v, i0[0], i0[1], i0[2]) * (1 - f[0]) + dens_at(v, i1[0], i0[1], i0[2]) * f[0];
    double c10 = dens_at(v, i0[0], i1[1], i0[2]) * (1 - f[0]) + dens_at(v, i1[0], i1[1], i0[2]) * f[0];
    double c01 = dens_at(v, i0[0], i0[1], i1[2]) * (1 - f[0]) + dens_at(v, i1[0], i0[1], i1[2]) * f[0];
    double c11 = dens_at(v, i0[0], i1[1], i1[2]) * (1 - f[0]) + dens_at(v, i1[0], i1[1], i1[2]) * f[0];
    double c0 = c00 * (1 - f[1]) + c10 * f[1], c1 = c01 * (1 - f[1]) + c11 * f[1];
    return c0 * (1 - f[2]) + c1 * f[2];
}

double sq__ref_volume_next(const sq__ref_volume *v, sq__dv3 o, sq__dv3 d, double t_start,
                           double t_end, sq__ref_rng *rng, double *majorant)
{
    double ta = t_start, tb = t_end;
    sq__dv3 bmax = sq__dv_add(v->org, v->size);
    if (!clip_box(o, d, v->org, bmax, &ta, &tb)) return INFINITY;
    double tau = -log(sq__ref_rand(rng));
    /* 3D DDA over bricks */
    const double oo[3] = {o.x, o.y, o.z}, dd[3] = {d.x, d.y, d.z};
    const double org[3] = {v->org.x, v->org.y, v->org.z};
    const double bs[3] = {v->brick_size.x, v->brick_size.y, v->brick_size.z};
    int idx[3], step[3];
    double tnext[3], dt[3];
    for (int a = 0; a < 3; a++) {
        double p = (oo[a] + dd[a] * ta - org[a]) / bs[a];
        idx[a] = sq_clampi((int)floor(p), 0, v->bn[a] - 1);
        if (dd[a] > 0.0) {
            step[a] = 1;
            dt[a] = bs[a] / dd[a];
            tnext[a] = (org[a] + (idx[a] + 1) * bs[a] - oo[a]) / dd[a];
        } else if (dd[a] < 0.0) {
            step[a] = -1;
            dt[a] = -bs[a] / dd[a];
            tnext[a] = (org[a] + idx[a] * bs[a] - oo[a]) / dd[a];
        } else {
            step[a] = 0;
            dt[a] = INFINITY;
            tnext[a] = INFINITY;
        }
    }
    double t = ta;
    for (;;) {
        int a = tnext[0] < tnext[1] ? (tnext[0] < tnext[2] ? 0 : 2) : (tnext[1] < tnext[2] ? 1 : 2);
        double te = tnext[a] < tb ? tnext[a] : tb;
        double m = v->sig_max *
                   (double)v->brick_max[((size_t)idx[2] * v->bn[1] + idx[1]) * v->bn[0] + idx[0]];
        if (te > t && m > 0.0) {
            double seg = m * (te - t);
            if (tau < seg) {
                *majorant = m;
                return t + tau / m;
            }
            tau -= seg;
        }
        if (te > t) t = te;
        if (tnext[a] >= tb) return INFINITY;
        idx[a] += step[a];
        if (idx[a] < 0 || idx[a] >= v->bn[a]) return INFINITY;
        tnext[a] += dt[a];
    }
}

void sq__ref_transmittance(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double t_end,
                           sq__ref_rng *rng, double tr[3])
{
    tr[0] = tr[1] = tr[2] = 1.0;
    for (int vi = 0; vi < s->volume_count; vi++) {
        const sq__ref_volume *v = &s->volumes[vi];
        double t = 0.0, m = 0.0;
        for (;;) {
            t = sq__ref_volume_next(v, o, d, t, t_end, rng, &m);
            if (!(t < t_end)) break;
            double rho = sq__ref_volume_density(v, sq__dv_madd(o, d, t));
            double tmax = 0.0;
            for (int c = 0; c < 3; c++) {
                double f = 1.0 - v->sig[c] * rho / m;
                tr[c] *= f > 0.0 ? f : 0.0;
                if (tr[c] > tmax) tmax = tr[c];
            }
            if (tmax <= 0.0) return;
            if (tmax < 0.1) { /* Russian roulette on the transmittance estimate (unbiased) */
                if (sq__ref_rand(rng) >= 0.5) {
                    tr[0] = tr[1] = tr[2] = 0.0;
                    return;
                }
                for (int c = 0; c < 3; c++) tr[c] *= 2.0;
            }
        }
    }
}

/* ---- scene preparation ----------------------------------------------------------------- */

static void hf_build_bounds(sq__ref_heightfield *hf)
{
    const int ncx = hf->nx - 1, ncy = hf->ny - 1;
    hf->zmin = INFINITY;
    hf->zmax = -INFINITY;
    for (int b = 0; b < hf->bnx * hf->bny; b++) hf->block_max[b] = -INFINITY;
    for (int j = 0; j < ncy; j++)
        for (int i = 0; i < ncx; i++) {
            float h00 = hf->h[j * hf->nx + i], h10 = hf->h[j * hf->nx + i + 1];
            float h01 = hf->h[(j + 1) * hf->nx + i], h11 = hf->h[(j + 1) * hf->nx + i + 1];
            bool drawn = !hf->coverage ||
                         (hf->coverage[j * hf->nx + i] > 0.0f || hf->coverage[j * hf->nx + i + 1] > 0.0f ||
                          hf->coverage[(j + 1) * hf->nx + i] > 0.0f ||
                          hf->coverage[(j + 1) * hf->nx + i + 1] > 0.0f);
            float mx = fmaxf(fmaxf(h00, h10), fmaxf(h01, h11));
            float mn = fminf(fminf(h00, h10), fminf(h01, h11));
            if (!drawn) {
                hf->cell_max[j * ncx + i] = -INFINITY;
                continue;
            }
            hf->cell_max[j * ncx + i] = mx;
            float *bm = &hf->block_max[(j / SQ__REF_BLOCK) * hf->bnx + i / SQ__REF_BLOCK];
            if (mx > *bm) *bm = mx;
            if ((double)mn < hf->zmin) hf->zmin = (double)mn;
            if ((double)mx > hf->zmax) hf->zmax = (double)mx;
        }
    if (!(hf->zmin <= hf->zmax)) hf->zmin = hf->zmax = 0.0;
}

static sq_result hf_alloc(sq_context *ctx, sq__ref_heightfield *hf)
{
    size_t ncell = (size_t)(hf->nx - 1) * (size_t)(hf->ny - 1);
    hf->bnx = (hf->nx - 1 + SQ__REF_BLOCK - 1) / SQ__REF_BLOCK;
    hf->bny = (hf->ny - 1 + SQ__REF_BLOCK - 1) / SQ__REF_BLOCK;
    hf->cell_max = (float *)sq_alloc(ctx, ncell * sizeof(float));
    hf->block_max = (float *)sq_alloc(ctx, (size_t)hf->bnx * hf->bny * sizeof(float));
    if (!hf->cell_max || !hf->block_max) return SQ_ERR_OUT_OF_MEMORY;
    hf_build_bounds(hf);
    return SQ_OK;
}

static void hf_free(sq_context *ctx, sq__ref_heightfield *hf)
{
    sq_free(ctx, hf->cell_max);
    sq_free(ctx, hf->block_max);
    hf->cell_max = hf->block_max = NULL;
}

static double vc(sq_vec3 v, int c) { return (double)(c == 0 ? v.x : (c == 1 ? v.y : v.z)); }

static bool finite3(sq_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static sq_result volume_prepare(sq_context *ctx, const sq_drawable *dr, int index, bool isotropic,
                                sq__ref_volume *v)
{
    const sq_volume_view *vv = &dr->u.volume;
    const char *name = dr->name ? dr->name : "volume";
    if (!vv->density)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "drawable %d ('%s'): density is NULL",
                        index, name);
    if (vv->nx < 1 || vv->ny < 1 || vv->nz < 1)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "drawable %d ('%s'): nx x ny x nz = %dx%dx%d; every axis needs at least 1 cell",
                        index, name, vv->nx, vv->ny, vv->nz);
    if (!finite3(vv->origin_m) || !finite3(vv->size_m) || !(vv->size_m.x > 0.0f) ||
        !(vv->size_m.y > 0.0f) || !(vv->size_m.z > 0.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "drawable %d ('%s'): size_m = (%g, %g, %g); every extent must be > 0",
                        index, name, (double)vv->size_m.x, (double)vv->size_m.y,
                        (double)vv->size_m.z);
    for (int c = 0; c < 3; c++) {
        if (!(vv->sigma_ext[c] >= 0.0f) || !isfinite(vv->sigma_ext[c]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "drawable %d ('%s'): sigma_ext[%d] = %g; must be finite and >= 0",
                            index, name, c, (double)vv->sigma_ext[c]);
        if (!(vv->albedo[c] >= 0.0f && vv->albedo[c] <= 1.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "drawable %d ('%s'): albedo[%d] = %g; must be in [0, 1]", index,
                            name, c, (double)vv->albedo[c]);
        if (!(fabsf(vv->g[c]) < 1.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                            "drawable %d ('%s'): g[%d] = %g; must be in (-1, 1)", index, name, c,
                            (double)vv->g[c]);
    }
    if (!(vv->w2 >= 0.0f && vv->w2 < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "drawable %d ('%s'): w2 = %g; must be in [0, 1)", index, name,
                        (double)vv->w2);
    if (vv->w2 > 0.0f && !(fabsf(vv->g2) < 1.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "drawable %d ('%s'): g2 = %g; must be in (-1, 1)", index, name,
                        (double)vv->g2);
    memset(v, 0, sizeof *v);
    v->density = vv->density;
    v->nx = vv->nx;
    v->ny = vv->ny;
    v->nz = vv->nz;
    v->org = sq__dv_from(vv->origin_m);
    v->size = sq__dv_from(vv->size_m);
    v->sig_max = 0.0;
    for (int c = 0; c < 3; c++) {
        v->sig[c] = (double)vv->sigma_ext[c];
        v->alb[c] = (double)vv->albedo[c];
        v->g[c] = isotropic ? 0.0 : (double)vv->g[c];
        if (v->sig[c] > v->sig_max) v->sig_max = v->sig[c];
    }
    v->g2 = isotropic ? 0.0 : (double)vv->g2;
    v->w2 = isotropic ? 0.0 : (double)vv->w2;
    v->same_phase = v->g[0] == v->g[1] && v->g[1] == v->g[2];
    const int n[3] = {vv->nx, vv->ny, vv->nz};
    for (int a = 0; a < 3; a++) v->bn[a] = (n[a] + SQ__REF_BRICK - 1) / SQ__REF_BRICK;
    v->brick_size = sq__dv(v->size.x / v->nx * SQ__REF_BRICK, v->size.y / v->ny * SQ__REF_BRICK,
                           v->size.z / v->nz * SQ__REF_BRICK);
    size_t nb = (size_t)v->bn[0] * v->bn[1] * v->bn[2];
    v->brick_max = (float *)sq_alloc_zero(ctx, nb * sizeof(float));
    if (!v->brick_max) return SQ_ERR_OUT_OF_MEMORY;
    /* each voxel raises the bricks whose trilinear footprint it touches: the voxel's own brick
     * and, where it lies on a brick border, the neighbour (apron of one voxel) */
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                float x = vv->density[((size_t)k * n[1] + j) * n[0] + i];
                if (isnan(x) || isinf(x))
                    return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                    "drawable %d ('%s'): density at cell (%d, %d, %d) is %g; "
                                    "must be finite",
                                    index, name, i, j, k, (double)x);
                if (!(x > 0.0f)) continue;
                const int ijk[3] = {i, j, k};
                int lo[3], hi[3];
                for (int a = 0; a < 3; a++) {
                    lo[a] = sq_clampi((ijk[a] - 1) / SQ__REF_BRICK, 0, v->bn[a] - 1);
                    hi[a] = sq_clampi((ijk[a] + 1) / SQ__REF_BRICK, 0, v->bn[a] - 1);
                    if (ijk[a] == 0) lo[a] = 0;
                }
                for (int c = lo[2]; c <= hi[2]; c++)
                    for (int b = lo[1]; b <= hi[1]; b++)
                        for (int a = lo[0]; a <= hi[0]; a++) {
                            float *m = &v->brick_max[((size_t)c * v->bn[1] + b) * v->bn[0] + a];
                            if (x > *m) *m = x;
                        }
            }
    return SQ_OK;
}

void sq__ref_scene_destroy(sq__ref_scene *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    hf_free(ctx, &s->terrain);
    for (int i = 0; i < s->surface_count; i++) hf_free(ctx, &s->surfaces[i]);
    sq_free(ctx, s->surfaces);
    sq_free(ctx, s->obstacles);
    if (s->volumes)
        for (int i = 0; i < s->volume_count; i++) sq_free(ctx, s->volumes[i].brick_max);
    sq_free(ctx, s->volumes);
    sq_free(ctx, s);
}

sq_result sq__ref_scene_create(sq_context *ctx, const sq_world *world,
                               const sq_drawable *drawables, int count, bool isotropic,
                               sq__ref_scene **out)
{
    *out = NULL;
    sq__ref_scene *s = (sq__ref_scene *)sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    sq_result r = SQ_OK;
    double extent = 1.0;

    /* terrain */
    if (world->heights && world->nx >= 2 && world->ny >= 2) {
        if (!(world->dx > 0.0f) || !(world->dy > 0.0f)) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                         "world dx = %g, dy = %g; terrain spacing must be > 0", (double)world->dx,
                         (double)world->dy);
            goto fail;
        }
        sq__ref_heightfield *hf = &s->terrain;
        hf->nx = world->nx;
        hf->ny = world->ny;
        hf->ox = (double)world->origin.x;
        hf->oy = (double)world->origin.y;
        hf->dx = (double)world->dx;
        hf->dy = (double)world->dy;
        hf->h = world->heights;
        hf->normals = world->normals;
        sq_vec3 flat, steep;
        sq__terrain_albedo(world, &flat, &steep);
        hf->shade = SQ__REF_SHADE_TERRAIN;
        for (int c = 0; c < 3; c++) {
            hf->albedo[c] = vc(flat, c);
            hf->steep[c] = vc(steep, c);
        }
        if ((r = hf_alloc(ctx, hf)) != SQ_OK) goto fail;
        s->has_terrain = true;
        extent = fmax(extent, fabs(hf->ox) + fabs(hf->oy) + hf->dx * hf->nx + hf->dy * hf->ny +
                                  fabs(hf->zmax) + fabs(hf->zmin));
    }

    /* obstacles */
    int no = world->obstacle_count;
    if (no < 0 || no > SQ_MAX_OBSTACLES) {
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "world obstacle_count = %d; must be in [0, %d]",
                     no, SQ_MAX_OBSTACLES);
        goto fail;
    }
    if (no > 0) {
        s->obstacles = (sq__ref_obstacle *)sq_alloc_zero(ctx, (size_t)no * sizeof *s->obstacles);
        if (!s->obstacles) {
            r = SQ_ERR_OUT_OF_MEMORY;
            goto fail;
        }
    }
    for (int i = 0; i < no; i++) {
        const sq_obstacle *w = &world->obstacles[i];
        sq__ref_obstacle *ob = &s->obstacles[s->obstacle_count];
        if (!(w->size_m.x > 0.0f && w->size_m.y > 0.0f && w->size_m.z > 0.0f)) continue;
        double yaw = (double)w->yaw_deg * SQ_PI / 180.0;
        ob->cos_yaw = cos(yaw);
        ob->sin_yaw = sin(yaw);
        ob->hx = 0.5 * (double)w->size_m.x;
        ob->hy = 0.5 * (double)w->size_m.y;
        ob->h = (double)w->size_m.z;
        double base = (double)w->center_m.z;
        if (!isfinite(w->center_m.z)) { /* renderer.c: lowest ground under centre and corners */
            base = 0.0;
            if (s->has_terrain) {
                base = sq__ref_heightfield_height(&s->terrain, (double)w->center_m.x,
                                                  (double)w->center_m.y);
                for (int q = 0; q < 4; q++) {
                    double lx = (q & 1 ? 1.0 : -1.0) * ob->hx, ly = (q & 2 ? 1.0 : -1.0) * ob->hy;
                    double z = sq__ref_heightfield_height(
                        &s->terrain, (double)w->center_m.x + ob->cos_yaw * lx - ob->sin_yaw * ly,
                        (double)w->center_m.y + ob->sin_yaw * lx + ob->cos_yaw * ly);
                    if (z < base) base = z;
                }
            }
        }
        ob->c = sq__dv((double)w->center_m.x, (double)w->center_m.y, base);
        ob->roof = (w->kind == SQ_OBSTACLE_HOUSE && w->roof_m > 0.0f) ? (double)w->roof_m : 0.0;
        ob->fence = w->kind == SQ_OBSTACLE_FENCE;
        ob->along_x = w->size_m.x >= w->size_m.y;
        /* renderer.c defaults where no albedo is given */
        const bool given = w->albedo.x > 0.0f || w->albedo.y > 0.0f || w->albedo.z > 0.0f;
        sq_vec3 wall = w->kind == SQ_OBSTACLE_HOUSE   ? sq_v3(0.70f, 0.64f, 0.54f)
                       : w->kind == SQ_OBSTACLE_FENCE ? sq_v3(0.42f, 0.32f, 0.20f)
                                                      : sq_v3(0.50f, 0.48f, 0.45f);
        sq_vec3 roof = sq_v3(0.40f, 0.19f, 0.13f);
        if (given) wall = roof = w->albedo;
        for (int c = 0; c < 3; c++) {
            ob->albedo[c] = vc(wall, c);
            ob->roof_albedo[c] = vc(roof, c);
        }
        double ex = fabs(ob->cos_yaw) * ob->hx + fabs(ob->sin_yaw) * ob->hy;
        double ey = fabs(ob->sin_yaw) * ob->hx + fabs(ob->cos_yaw) * ob->hy;
        double pad = 1e-6 * (1.0 + fabs(ob->c.x) + fabs(ob->c.y) + fabs(ob->c.z));
        ob->bmin = sq__dv(ob->c.x - ex - pad, ob->c.y - ey - pad, ob->c.z - pad);
        ob->bmax = sq__dv(ob->c.x + ex + pad, ob->c.y + ey + pad, ob->c.z + ob->h + ob->roof + pad);
        extent = fmax(extent, fabs(ob->c.x) + fabs(ob->c.y) + fabs(ob->c.z) + ob->h + ob->roof);
        s->obstacle_count++;
    }

    /* drawables */
    int nvol = 0, nsurf = 0;
    for (int i = 0; i < count; i++) {
        if (drawables[i].kind == SQ_DRAWABLE_VOLUME) nvol++;
        if (drawables[i].kind == SQ_DRAWABLE_SURFACE) nsurf++;
    }
    if (nvol > SQ__REF_MAX_VOLUMES) {
        r = sq__fail(ctx, SQ_ERR_UNSUPPORTED, MODULE,
                     "%d volume drawables; the reference renderer takes at most %d", nvol,
                     SQ__REF_MAX_VOLUMES);
        goto fail;
    }
    if (nvol) {
        s->volumes = (sq__ref_volume *)sq_alloc_zero(ctx, (size_t)nvol * sizeof *s->volumes);
        if (!s->volumes) {
            r = SQ_ERR_OUT_OF_MEMORY;
            goto fail;
        }
    }
    if (nsurf) {
        s->surfaces = (sq__ref_heightfield *)sq_alloc_zero(ctx, (size_t)nsurf * sizeof *s->surfaces);
        if (!s->surfaces) {
            r = SQ_ERR_OUT_OF_MEMORY;
            goto fail;
        }
    }
    for (int i = 0; i < count; i++) {
        const sq_drawable *dr = &drawables[i];
        if (dr->kind == SQ_DRAWABLE_VOLUME) {
            r = volume_prepare(ctx, dr, i, isotropic, &s->volumes[s->volume_count]);
            s->volume_count++; /* counted even on failure so destroy frees its bricks */
            if (r != SQ_OK) goto fail;
            const sq__ref_volume *v = &s->volumes[s->volume_count - 1];
            extent = fmax(extent, fabs(v->org.x) + fabs(v->org.y) + fabs(v->org.z) + v->size.x +
                                      v->size.y + v->size.z);
        } else if (dr->kind == SQ_DRAWABLE_SURFACE) {
            const sq_surface_view *sv = &dr->u.surface;
            if (sv->nx < 2 || sv->ny < 2 || !sv->height_m) continue;
            if (!(sv->dx_m > 0.0f) || !(sv->dy_m > 0.0f)) {
                r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                             "drawable %d ('%s'): dx_m = %g, dy_m = %g; must be > 0", i,
                             dr->name ? dr->name : "surface", (double)sv->dx_m, (double)sv->dy_m);
                goto fail;
            }
            sq__ref_heightfield *hf = &s->surfaces[s->surface_count++];
            hf->nx = sv->nx;
            hf->ny = sv->ny;
            hf->ox = (double)sv->origin_m.x;
            hf->oy = (double)sv->origin_m.y;
            hf->dx = (double)sv->dx_m;
            hf->dy = (double)sv->dy_m;
            hf->h = sv->height_m;
            hf->coverage = sv->coverage;
            sq_vec3 alb = sv->albedo;
            if (!(alb.x > 0.0f || alb.y > 0.0f || alb.z > 0.0f)) alb = sq__material_albedo(sv->material);
            hf->shade = sv->material == SQ_MATERIAL_SNOW ? SQ__REF_SHADE_CONST : SQ__REF_SHADE_DETAIL;
            for (int c = 0; c < 3; c++) hf->albedo[c] = vc(alb, c);
            /* where coverage < 1 the terrain shows through (alpha blending in the GL pass) */
            hf->under_shade = s->has_terrain ? s->terrain.shade : hf->shade;
            for (int c = 0; c < 3; c++) {
                hf->under_albedo[c] = s->has_terrain ? s->terrain.albedo[c] : hf->albedo[c];
                hf->under_steep[c] = s->has_terrain ? s->terrain.steep[c] : hf->albedo[c];
            }
            if ((r = hf_alloc(ctx, hf)) != SQ_OK) goto fail;
        }
    }

    /* sun and sky */
    s->sun_dir = sq__dv_norm(sq__dv_from(world->sun_dir));
    for (int c = 0; c < 3; c++) {
        s->sun_rad[c] = vc(world->sun_radiance, c);
        s->sun_e[c] = SQ_PI * s->sun_rad[c];
        s->zenith[c] = vc(world->sky_zenith, c);
        s->horizon[c] = vc(world->sky_horizon, c);
    }
    /* frame_common.glsl: ground light below the horizon = albedo (sun mu + mean sky) */
    const double mu_sun = s->sun_dir.z > 0.0 ? s->sun_dir.z : 0.0;
    for (int c = 0; c < 3; c++)
        s->ground[c] = vc(world->ground_albedo, c) *
                       (s->sun_rad[c] * mu_sun + 0.5 * (s->zenith[c] + s->horizon[c]));
    s->turbidity = (double)world->turbidity;
    s->inv_exaggeration =
        world->vertical_exaggeration > 0.0f ? 1.0 / (double)world->vertical_exaggeration : 1.0;
    s->sun_on = (s->sun_rad[0] > 0.0 || s->sun_rad[1] > 0.0 || s->sun_rad[2] > 0.0) &&
                sq__dv_dot(s->sun_dir, s->sun_dir) > 0.5;
    s->eps_scale = 1e-7 * extent;
    *out = s;
    return SQ_OK;
fail:
    sq__ref_scene_destroy(s);
    return r;
}
