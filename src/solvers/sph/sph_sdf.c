/* sph_sdf.c — voxelised solids as particle colliders: a solid mask (meshes voxelised by the
 * caller) becomes a signed distance at the cell centres by the exact Euclidean distance
 * transform (Felzenszwalb & Huttenlocher 2012, "Distance transforms of sampled functions": the
 * lower envelope of parabolas, one axis at a time), the surface lying halfway between a solid and
 * an empty centre. Particles read it trilinearly; its gradient is the contact normal. */
#include <float.h>
#include <math.h>
#include <string.h>

#include "solvers/sph/sph_internal.h"

#define MOD "sph"

/* "No feature on this line yet": large and finite, so the parabola algebra stays exact enough. */
#define EDT_FAR 1e20

/* Squared distance transform of f along one line of n samples with stride st (in place):
 * d(i) = min_q ((i - q)^2 + f(q)). v, z and g are scratch of n, n + 1 and n entries. */
static void edt_line(float *f, size_t st, int n, int *v, double *z, double *g)
{
    for (int i = 0; i < n; i++) g[i] = (double)f[(size_t)i * st];
    int k = 0;
    v[0] = 0;
    z[0] = -INFINITY;
    z[1] = INFINITY;
    for (int q = 1; q < n; q++) {
        double sx = ((g[q] + (double)q * q) - (g[v[k]] + (double)v[k] * v[k])) / (2.0 * (q - v[k]));
        while (k > 0 && sx <= z[k]) {
            k--;
            sx = ((g[q] + (double)q * q) - (g[v[k]] + (double)v[k] * v[k])) / (2.0 * (q - v[k]));
        }
        k++;
        v[k] = q;
        z[k] = sx;
        z[k + 1] = INFINITY;
    }
    k = 0;
    for (int q = 0; q < n; q++) {
        while (z[k + 1] < q) k++;
        const double dq = (double)(q - v[k]);
        f[(size_t)q * st] = (float)(dq * dq + g[v[k]]);
    }
}

/* Squared distance (in cells) from every centre to the nearest centre where feature(mask) holds. */
static sq_result edt3(sq_context *ctx, const uint8_t *mask, uint8_t feature, const int n[3],
                      float *out)
{
    const size_t N = (size_t)n[0] * n[1] * n[2];
    for (size_t c = 0; c < N; c++) out[c] = ((mask[c] != 0) == (feature != 0)) ? 0.0f : (float)EDT_FAR;
    int m = n[0] > n[1] ? n[0] : n[1];
    m = m > n[2] ? m : n[2];
    int *v = (int *)sq_alloc(ctx, (size_t)m * sizeof *v);
    double *z = (double *)sq_alloc(ctx, (size_t)(m + 1) * sizeof *z);
    double *g = (double *)sq_alloc(ctx, (size_t)m * sizeof *g);
    if (!v || !z || !g) {
        sq_free(ctx, v);
        sq_free(ctx, z);
        sq_free(ctx, g);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    const size_t sx = 1, sy = (size_t)n[0], sz = (size_t)n[0] * n[1];
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++) edt_line(out + sy * j + sz * k, sx, n[0], v, z, g);
    for (int k = 0; k < n[2]; k++)
        for (int i = 0; i < n[0]; i++) edt_line(out + (size_t)i + sz * k, sy, n[1], v, z, g);
    for (int j = 0; j < n[1]; j++)
        for (int i = 0; i < n[0]; i++) edt_line(out + (size_t)i + sy * j, sz, n[2], v, z, g);
    sq_free(ctx, v);
    sq_free(ctx, z);
    sq_free(ctx, g);
    return SQ_OK;
}

/* One pass of the [1 2 1]/4 filter along axis a (end samples kept), tmp as scratch of N. */
static void smooth_axis(float *d, float *tmp, const int n[3], int a)
{
    const size_t N = (size_t)n[0] * n[1] * n[2];
    const size_t st = a == 0 ? 1 : a == 1 ? (size_t)n[0] : (size_t)n[0] * n[1];
    memcpy(tmp, d, N * sizeof *d);
    for (int k = 0; k < n[2]; k++)
        for (int j = 0; j < n[1]; j++)
            for (int i = 0; i < n[0]; i++) {
                const int c = a == 0 ? i : a == 1 ? j : k;
                if (c == 0 || c == n[a] - 1) continue;
                const size_t q = (size_t)i + (size_t)n[0] * ((size_t)j + (size_t)n[1] * k);
                d[q] = 0.25f * (tmp[q - st] + 2.0f * tmp[q] + tmp[q + st]);
            }
}

sq_result sq_sph_add_solid_grid(sq_sph *s, const sq_sph_solid_grid_desc *gd)
{
    if (!s || !gd || !gd->solid)
        return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD,
                        "sph, solid grid and its mask must not be NULL");
    if (!(isfinite(gd->cell_m) && gd->cell_m > 0.0))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "solid grid cell_m = %g; must be > 0 m",
                        gd->cell_m);
    for (int a = 0; a < 3; a++) {
        if (gd->n[a] < 2 || gd->n[a] > 65536)
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "solid grid n[%d] = %d; must be in 2..65536 cells", a, gd->n[a]);
        if (!isfinite(gd->origin_m[a]))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "solid grid origin_m[%d] = %g; must be finite",
                            a, gd->origin_m[a]);
    }
    sq__sph_contact c;
    sq_result r = sq__sph_contact_from_desc(s, &gd->contact, "solid grid", &c);
    if (r != SQ_OK) return r;
    const size_t N = (size_t)gd->n[0] * gd->n[1] * gd->n[2];
    const uint64_t bytes = (uint64_t)N * 2 * sizeof(float);
    if (bytes > sq_context_memory_limit(s->ctx))
        return sq__fail(s->ctx, SQ_ERR_TOO_LARGE, MOD,
                        "solid grid of %d x %d x %d cells needs %llu bytes; the memory limit is %llu",
                        gd->n[0], gd->n[1], gd->n[2], (unsigned long long)bytes,
                        (unsigned long long)sq_context_memory_limit(s->ctx));
    float *din = (float *)sq_alloc(s->ctx, N * sizeof(float));
    float *dout = (float *)sq_alloc(s->ctx, N * sizeof(float));
    sq__sph_sdf *ns = (sq__sph_sdf *)sq_alloc(s->ctx, (size_t)(s->sdf_count + 1) * sizeof *ns);
    if (!din || !dout || !ns) {
        sq_free(s->ctx, din);
        sq_free(s->ctx, dout);
        sq_free(s->ctx, ns);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    r = edt3(s->ctx, gd->solid, 1, gd->n, dout); /* outside: to the nearest solid centre */
    if (r == SQ_OK) r = edt3(s->ctx, gd->solid, 0, gd->n, din); /* inside: to the nearest empty */
    if (r != SQ_OK) {
        sq_free(s->ctx, din);
        sq_free(s->ctx, dout);
        sq_free(s->ctx, ns);
        return r;
    }
    const double h = gd->cell_m;
    const float far = (float)((gd->n[0] + gd->n[1] + gd->n[2]) * h);
    for (size_t k = 0; k < N; k++) {
        const double q = gd->solid[k] ? (double)din[k] : (double)dout[k];
        const double d = q > 0.5 * EDT_FAR ? (double)far : (sqrt(q) - 0.5) * h;
        dout[k] = (float)(gd->solid[k] ? -d : d);
    }
    /* the distance to the nearest centre jumps from centre to centre along a slanted surface (a
     * staircase of centres): two passes of the [1 2 1]/4 filter along each axis smooth those
     * jumps while keeping linear fields (a plane's distance) exact */
    for (int pass = 0; pass < 2; pass++)
        for (int a = 0; a < 3; a++) smooth_axis(dout, din, gd->n, a);
    sq_free(s->ctx, din);
    if (s->sdf_count) memcpy(ns, s->sdfs, (size_t)s->sdf_count * sizeof *ns);
    sq_free(s->ctx, s->sdfs);
    s->sdfs = ns;
    sq__sph_sdf *g = &s->sdfs[s->sdf_count++];
    memset(g, 0, sizeof *g);
    g->nx = gd->n[0];
    g->ny = gd->n[1];
    g->nz = gd->n[2];
    g->h = (float)h;
    g->inv_h = (float)(1.0 / h);
    for (int a = 0; a < 3; a++) {
        g->o[a] = (float)gd->origin_m[a];
        g->lo[a] = (float)(gd->origin_m[a] + 0.5 * h);
        g->hi[a] = (float)(gd->origin_m[a] + (gd->n[a] - 0.5) * h);
    }
    g->d = dout;
    g->c = c;
    return SQ_OK;
}

bool sq__sph_sdf_eval(const sq__sph_sdf *g, const float p[3], float *d, float n[3])
{
    if (p[0] < g->lo[0] || p[0] > g->hi[0] || p[1] < g->lo[1] || p[1] > g->hi[1] ||
        p[2] < g->lo[2] || p[2] > g->hi[2])
        return false;
    const int nn[3] = {g->nx, g->ny, g->nz};
    int c[3];
    float t[3];
    for (int a = 0; a < 3; a++) {
        const float f = (p[a] - g->lo[a]) * g->inv_h;
        int i = (int)f;
        if (i > nn[a] - 2) i = nn[a] - 2;
        if (i < 0) i = 0;
        c[a] = i;
        t[a] = f - (float)i;
    }
    const size_t sy = (size_t)g->nx, sz = (size_t)g->nx * g->ny;
    const float *b = g->d + (size_t)c[0] + sy * c[1] + sz * c[2];
    const float d000 = b[0], d100 = b[1], d010 = b[sy], d110 = b[sy + 1];
    const float d001 = b[sz], d101 = b[sz + 1], d011 = b[sz + sy], d111 = b[sz + sy + 1];
    const float tx = t[0], ty = t[1], tz = t[2];
    const float y0 = (1 - ty) * ((1 - tx) * d000 + tx * d100) + ty * ((1 - tx) * d010 + tx * d110);
    const float y1 = (1 - ty) * ((1 - tx) * d001 + tx * d101) + ty * ((1 - tx) * d011 + tx * d111);
    *d = (1 - tz) * y0 + tz * y1;
    float gx = (1 - tz) * ((1 - ty) * (d100 - d000) + ty * (d110 - d010)) +
               tz * ((1 - ty) * (d101 - d001) + ty * (d111 - d011));
    float gy = (1 - tz) * ((1 - tx) * (d010 - d000) + tx * (d110 - d100)) +
               tz * ((1 - tx) * (d011 - d001) + tx * (d111 - d101));
    float gz = y1 - y0;
    const float len = sqrtf(gx * gx + gy * gy + gz * gz);
    if (len > 0.0f) {
        n[0] = gx / len;
        n[1] = gy / len;
        n[2] = gz / len;
    } else {
        n[0] = n[1] = 0.0f;
        n[2] = 1.0f;
    }
    return true;
}

double sq_sph_solid_distance(const sq_sph *s, const double p_m[3], double normal[3])
{
    double best = INFINITY;
    if (!s || !p_m) return best;
    const float p[3] = {(float)p_m[0], (float)p_m[1], (float)p_m[2]};
    for (int k = 0; k < s->sdf_count; k++) {
        float d, n[3];
        if (!sq__sph_sdf_eval(&s->sdfs[k], p, &d, n) || !((double)d < best)) continue;
        best = d;
        if (normal)
            for (int a = 0; a < 3; a++) normal[a] = n[a];
    }
    return best;
}
