/* avalanche_kernels.c — pure kernels of the avalanche phenomenon: quantile selection for the
 * front position, the deposit depth map (snow volume per unit area), display smoothing, the
 * ordered dither of the release columns, and the powder cloud's source and diffusion.
 * No allocation, no logging, no globals except const tables. */
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <string.h>

#include "avalanche_internal.h"

float sq__aval_select(float *a, size_t n, size_t k)
{
    /* Hoare's quickselect with a median-of-three pivot: expected O(n). Values must be finite. */
    ptrdiff_t lo = 0, hi = (ptrdiff_t)n - 1;
    const ptrdiff_t kk = (ptrdiff_t)k;
    while (lo < hi) {
        const float x = a[lo], y = a[lo + (hi - lo) / 2], z = a[hi];
        const float piv = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y));
        ptrdiff_t i = lo, j = hi;
        while (i <= j) {
            while (a[i] < piv) i++;
            while (a[j] > piv) j--;
            if (i <= j) {
                const float t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                j--;
            }
        }
        /* a[lo..j] <= piv, a[i..hi] >= piv, a[j+1..i-1] == piv */
        if (kk <= j)
            hi = j;
        else if (kk >= i)
            lo = i;
        else
            return a[kk];
    }
    return a[kk];
}

void sq__aval_deposit_accumulate(const float *x, const float *y, const float *rho, size_t n,
                                 double mass, double rho0, double x0, double y0, double cell,
                                 int nx, int ny, double *acc)
{
    const double inv = 1.0 / cell;
    for (size_t p = 0; p < n; p++) {
        const double fx = ((double)x[p] - x0) * inv, fy = ((double)y[p] - y0) * inv;
        if (!(fx >= 0.0 && fy >= 0.0 && fx < (double)nx && fy < (double)ny)) continue;
        const double r = rho && (double)rho[p] > rho0 ? (double)rho[p] : rho0;
        acc[(size_t)fy * (size_t)nx + (size_t)fx] += mass / r;
    }
}

void sq__aval_deposit_accumulate_resting(const float *x, const float *y, const float *vx,
                                         const float *vy, const float *vz, const float *rho,
                                         size_t n, double v_rest, double mass, double rho0,
                                         double x0, double y0, double cell, int nx, int ny,
                                         double *acc)
{
    const double inv = 1.0 / cell, v2max = v_rest * v_rest;
    for (size_t p = 0; p < n; p++) {
        const double u2 = (double)vx[p] * (double)vx[p] + (double)vy[p] * (double)vy[p] +
                          (double)vz[p] * (double)vz[p];
        if (!(u2 <= v2max)) continue;
        const double fx = ((double)x[p] - x0) * inv, fy = ((double)y[p] - y0) * inv;
        if (!(fx >= 0.0 && fy >= 0.0 && fx < (double)nx && fy < (double)ny)) continue;
        const double r = rho && (double)rho[p] > rho0 ? (double)rho[p] : rho0;
        acc[(size_t)fy * (size_t)nx + (size_t)fx] += mass / r;
    }
}

void sq__aval_smooth3(const float *src, float *dst, int nx, int ny)
{
    for (int j = 0; j < ny; j++) {
        const int j0 = j > 0 ? j - 1 : 0, j1 = j < ny - 1 ? j + 1 : ny - 1;
        for (int i = 0; i < nx; i++) {
            const int i0 = i > 0 ? i - 1 : 0, i1 = i < nx - 1 ? i + 1 : nx - 1;
            const float *r0 = src + (size_t)j0 * nx, *r1 = src + (size_t)j * nx,
                        *r2 = src + (size_t)j1 * nx;
            float s = (r0[i0] + 2.0f * r0[i] + r0[i1]) + 2.0f * (r1[i0] + 2.0f * r1[i] + r1[i1]) +
                      (r2[i0] + 2.0f * r2[i] + r2[i1]);
            dst[(size_t)j * nx + i] = s * (1.0f / 16.0f);
        }
    }
}

double sq__aval_dither(int i, int j)
{
    static const unsigned char bayer[4][4] = {
        {0, 8, 2, 10}, {12, 4, 14, 6}, {3, 11, 1, 9}, {15, 7, 13, 5}};
    return ((double)bayer[j & 3][i & 3] + 0.5) / 16.0;
}

double sq__aval_powder_source(const float *x, const float *y, const float *z, const float *vx,
                              const float *vy, const float *vz, size_t n, float v_min, float amount,
                              const int nn[3], const double o[3], double c, const int *ground,
                              float *density)
{
    const double inv = 1.0 / c;
    const float v2min = v_min * v_min;
    double added = 0.0;
    for (size_t p = 0; p < n; p++) {
        const float v2 = vx[p] * vx[p] + vy[p] * vy[p] + vz[p] * vz[p];
        if (!(v2 > v2min)) continue;
        const double f[3] = {((double)x[p] - o[0]) * inv, ((double)y[p] - o[1]) * inv,
                             ((double)z[p] - o[2]) * inv};
        if (!(f[0] >= 0.0 && f[1] >= 0.0 && f[2] >= 0.0 && f[0] < nn[0] && f[1] < nn[1] &&
              f[2] < nn[2]))
            continue;
        const size_t col = (size_t)f[1] * (size_t)nn[0] + (size_t)f[0];
        int kz = (int)f[2];
        if (kz < ground[col]) kz = ground[col]; /* a particle in a ground cell feeds the air above */
        if (kz >= nn[2]) continue;
        const float q = amount * (sqrtf(v2) - v_min);
        density[(size_t)kz * (size_t)nn[0] * (size_t)nn[1] + col] += q;
        added += (double)q;
    }
    return added;
}

double sq__aval_powder_diffuse(const float *src, float *dst, const int nn[3], const int *ground,
                               float k, float decay)
{
    const int nx = nn[0], ny = nn[1], nz = nn[2];
    const size_t sy = (size_t)nx, sz = (size_t)nx * (size_t)ny;
    double settled = 0.0;
    for (int kz = 0; kz < nz; kz++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t col = (size_t)j * sy + (size_t)i, c = (size_t)kz * sz + col;
                if (kz < ground[col]) {
                    dst[c] = 0.0f;
                    continue;
                }
                /* flux only between air cells: no flux through the ground or the box's faces */
                const float v = src[c];
                float s = 0.0f;
                if (i > 0 && kz >= ground[col - 1]) s += src[c - 1] - v;
                if (i < nx - 1 && kz >= ground[col + 1]) s += src[c + 1] - v;
                if (j > 0 && kz >= ground[col - sy]) s += src[c - sy] - v;
                if (j < ny - 1 && kz >= ground[col + sy]) s += src[c + sy] - v;
                if (kz > ground[col]) s += src[c - sz] - v;
                if (kz < nz - 1) s += src[c + sz] - v;
                const float mixed = v + k * s; /* >= 0 for k <= 1/6 */
                const float out = mixed * decay;
                dst[c] = out;
                settled += (double)mixed - (double)out;
            }
    return settled;
}

double sq__aval_powder_shift(const float *src, float *dst, const int nn[3], const int shift[3])
{
    const int nx = nn[0], ny = nn[1], nz = nn[2];
    const size_t sz = (size_t)nx * (size_t)ny;
    double left = 0.0;
    for (size_t c = 0; c < sz * (size_t)nz; c++) left += (double)src[c];
    for (int kz = 0; kz < nz; kz++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const int si = i + shift[0], sj = j + shift[1], sk = kz + shift[2];
                const size_t c = (size_t)kz * sz + (size_t)j * (size_t)nx + (size_t)i;
                if (si < 0 || sj < 0 || sk < 0 || si >= nx || sj >= ny || sk >= nz) {
                    dst[c] = 0.0f;
                    continue;
                }
                const float v = src[(size_t)sk * sz + (size_t)sj * (size_t)nx + (size_t)si];
                dst[c] = v;
                left -= (double)v;
            }
    return left;
}

void sq__aval_powder_velocity(const float *x, const float *y, const float *vx, const float *vy,
                              const float *vz, size_t n, const int nn[3], const double o[3],
                              double c, float e_rise, float *vel, float *work)
{
    const int nx = nn[0], ny = nn[1];
    const size_t cols = (size_t)nx * (size_t)ny;
    const double inv = 1.0 / c;
    memset(vel, 0, 4 * cols * sizeof(float));
    for (size_t p = 0; p < n; p++) {
        const double fx = ((double)x[p] - o[0]) * inv, fy = ((double)y[p] - o[1]) * inv;
        if (!(fx >= 0.0 && fy >= 0.0 && fx < nx && fy < ny)) continue;
        float *v = &vel[4 * ((size_t)fy * (size_t)nx + (size_t)fx)];
        v[0] += vx[p];
        v[1] += vy[p];
        v[2] += vz[p];
        v[3] += 1.0f;
    }
    /* column means weighted by the column's particle count, smoothed as sums: the smoothed
     * velocity is sum(w v) / sum(w), and the weight itself is smoothed and capped at 1 so a
     * column with a few particles beside the flow moves with a share of the flow's speed */
    for (int comp = 0; comp < 4; comp++) {
        float *a = work, *b = work + cols;
        for (size_t k = 0; k < cols; k++) a[k] = vel[4 * k + comp];
        sq__aval_smooth3(a, b, nx, ny);
        sq__aval_smooth3(b, a, nx, ny);
        for (size_t k = 0; k < cols; k++) vel[4 * k + comp] = a[k];
    }
    for (size_t k = 0; k < cols; k++) {
        float *v = &vel[4 * k];
        const float w = v[3];
        if (!(w > 1e-6f)) {
            v[0] = v[1] = v[2] = v[3] = 0.0f;
            continue;
        }
        const float share = (w < 1.0f ? w : 1.0f) / w;
        for (int d = 0; d < 3; d++) v[d] *= share * (float)inv;
        v[2] += e_rise * sqrtf(v[0] * v[0] + v[1] * v[1]);
        v[3] = 0.0f;
    }
}

/* what leaves cell c through a face of the box */
static inline void powder_out(float *dst, size_t c, float f, double *left)
{
    dst[c] -= f;
    *left += (double)f;
}

double sq__aval_powder_advect(const float *src, float *dst, const int nn[3], const int *ground,
                              const float *vel, float dt)
{
    const int nx = nn[0], ny = nn[1], nz = nn[2];
    const size_t sy = (size_t)nx, sz = (size_t)nx * (size_t)ny;
    double left = 0.0;
    memcpy(dst, src, sz * (size_t)nz * sizeof(float));
    /* every face once, in a fixed order: the flux from the upwind cell to the downwind one */
    for (int kz = 0; kz < nz; kz++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t col = (size_t)j * sy + (size_t)i, c = (size_t)kz * sz + col;
                if (kz < ground[col]) continue;
                const float *v = &vel[4 * col];
                /* the box's low faces */
                if (i == 0 && v[0] < 0.0f) powder_out(dst, c, -v[0] * dt * src[c], &left);
                if (j == 0 && v[1] < 0.0f) powder_out(dst, c, -v[1] * dt * src[c], &left);
                /* +x, +y: the mean of the two columns' velocities; none into a ground cell */
                const size_t nb[2] = {1, sy};
                const bool last[2] = {i == nx - 1, j == ny - 1};
                for (int d = 0; d < 2; d++) {
                    if (last[d]) {
                        if (v[d] > 0.0f) powder_out(dst, c, v[d] * dt * src[c], &left);
                        continue;
                    }
                    const size_t o = col + nb[d];
                    if (kz < ground[o]) continue;
                    const float u = 0.5f * (v[d] + vel[4 * o + (size_t)d]);
                    const float f = u * dt * (u > 0.0f ? src[c] : src[c + nb[d]]);
                    dst[c] -= f;
                    dst[c + nb[d]] += f;
                }
                /* +z: the column's own w (the ground is only below ground[col]); the bottom face
                 * of the lowest air cell is the ground: no flux */
                if (kz == nz - 1) {
                    if (v[2] > 0.0f) powder_out(dst, c, v[2] * dt * src[c], &left);
                } else {
                    const float f = v[2] * dt * (v[2] > 0.0f ? src[c] : src[c + sz]);
                    dst[c] -= f;
                    dst[c + sz] += f;
                }
            }
    return left;
}
