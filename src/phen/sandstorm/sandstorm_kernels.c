/* sandstorm_kernels.c — pure kernels of the sandstorm: drag law and terminal speed (SPEC §1.8,
 * eq. 2.29), friction velocity by the log law and the emission flux (SPEC §1.9), conservative
 * settling of a column with deposition, and Koschmieder visibility planes (SPEC §2.7). */
#include <math.h>
#include <string.h>

#include "sandstorm_internal.h"

double sq_drag_coefficient(double re)
{
    if (!(re > 0.0)) return INFINITY;
    return 24.0 / re + 6.0 / (1.0 + sqrt(re)) + 0.4;
}

double sq_dust_terminal_speed(double r, double rho_p, double rho_air, double mu)
{
    if (!(r > 0.0) || !(rho_p > rho_air) || !(mu > 0.0)) return 0.0;
    const double d = 2.0 * r, g = SQ_SAND_GRAVITY;
    /* Stokes start, then fixed-point on w = sqrt(4 d g Δρ / (3 ρ C_D(Re))) with damping; the
     * map is contracting for this drag law (monotone C_D), converging to 1e-12 in < 60 steps. */
    double w = 2.0 * r * r * g * (rho_p - rho_air) / (9.0 * mu);
    for (int it = 0; it < 200; it++) {
        double re = rho_air * w * d / mu;
        double wn = sqrt(4.0 * d * g * (rho_p - rho_air) / (3.0 * rho_air * sq_drag_coefficient(re)));
        double next = 0.5 * (w + wn);
        if (fabs(next - w) <= 1e-13 * w) return next;
        w = next;
    }
    return w;
}

double sq_friction_velocity(double u, double z, double z0)
{
    if (!(z > z0) || !(z0 > 0.0)) return 0.0;
    return SQ_SAND_KARMAN * fabs(u) / log(z / z0);
}

double sq_dust_emission_flux(double us, double ust, double c)
{
    if (!(us > ust) || !(us > 0.0)) return 0.0;
    return c * us * us * us * (1.0 - (ust * ust) / (us * us));
}

/* One explicit upwind settling sub-step in a column: c[k*cs] are concentrations (k = 0 at the
 * bottom), solid[k*ss] the solid flags; a fraction frac = w dt / h <= 1 of each cell falls one
 * cell. A cell above a solid cell (or the domain bottom) loses its falling share to the ground;
 * solid cells hold nothing; nothing falls in through the top. Conservative: returns the
 * deposited amount (concentration units; multiply by h³ for mass). */
double sq__sand_column_settle(float *c, ptrdiff_t cs, const uint8_t *solid, ptrdiff_t ss, int nz,
                              double frac)
{
    double deposited = 0.0;
    const float f = (float)frac;
    for (int k = 0; k < nz; k++) {
        if (solid[(ptrdiff_t)k * ss]) continue;
        float ck = c[(ptrdiff_t)k * cs];
        float out = f * ck;
        if (k == 0 || solid[(ptrdiff_t)(k - 1) * ss]) deposited += (double)out;
        float in = 0.0f;
        if (k + 1 < nz && !solid[(ptrdiff_t)(k + 1) * ss]) in = f * c[(ptrdiff_t)(k + 1) * cs];
        c[(ptrdiff_t)k * cs] = ck - out + in;
    }
    return deposited;
}

/* c ? a : b through bit masks (vectorises where a floating-point ?: would not) */
static inline float fsel(bool c, float a, float b)
{
    int32_t ia, ib;
    memcpy(&ia, &a, sizeof ia);
    memcpy(&ib, &b, sizeof ib);
    const int32_t m = -(int32_t)c;
    const int32_t r = (ia & m) | (ib & ~m);
    float x;
    memcpy(&x, &r, sizeof x);
    return x;
}

/* One settling sub-step of one plane row: ck (plane k), cu (plane k + 1), solid flags sk, sb
 * (plane k - 1) and su (plane k + 1); bottom: k == 0 (sb unused), top: k == nz - 1 (cu, su
 * unused). dep[i]: the amount leaving cell i into the ground. */
static void settle_row(float *restrict ck, const float *restrict cu, const uint8_t *restrict sk,
                       const uint8_t *restrict sb, const uint8_t *restrict su, bool bottom,
                       bool top, int nx, float f, float scale, float *restrict dep)
{
    for (int i = 0; i < nx; i++) {
        const float v = ck[i] * scale, out = f * v; /* scale: the mass fix, first sub-step */
        const bool fluid = !sk[i];
        const bool ground = bottom | (sb[i] != 0);
        const float in = fsel(!top & !su[i], f * (cu[i] * scale), 0.0f);
        dep[i] = fsel(fluid & ground, out, 0.0f);
        ck[i] = fsel(fluid, v - out + in, v);
    }
}

/* sq__sand_column_settle for a block of nrows adjacent y-rows of nx columns, plane by plane
 * (the rows of one plane are contiguous; x fastest, so the inner loop vectorises):
 * c[k*cs + r*cy + i], solid[k*ss + r*sy + i]. The block is scaled by scale (the mass fix) in
 * the first of substeps settling sub-steps by frac. dep[r] += the amount row r deposited
 * (concentration units), summed in double in plane order. */
void sq__sand_block_settle(float *c, ptrdiff_t cy, ptrdiff_t cs, const uint8_t *solid,
                           ptrdiff_t sy, ptrdiff_t ss, int nx, int nrows, int nz, float scale,
                           int substeps, double frac, double *dep)
{
    const float f = (float)frac;
    float d[256];
    for (int it = 0; it < substeps; it++)
        for (int k = 0; k < nz; k++) {
            const bool bottom = k == 0, top = k + 1 >= nz;
            for (int r = 0; r < nrows; r++) {
                float *ck = c + (ptrdiff_t)k * cs + (ptrdiff_t)r * cy;
                const float *cu = top ? ck : ck + cs;
                const uint8_t *sk = solid + (ptrdiff_t)k * ss + (ptrdiff_t)r * sy;
                const uint8_t *sb = bottom ? sk : sk - ss, *su = top ? sk : sk + ss;
                for (int i0 = 0; i0 < nx; i0 += 256) {
                    const int n = nx - i0 < 256 ? nx - i0 : 256;
                    settle_row(ck + i0, cu + i0, sk + i0, sb + i0, su + i0, bottom, top, n, f,
                               it == 0 ? scale : 1.0f, d);
                    dep[r] += sq__sand_dsum(d, n);
                }
            }
        }
}

/* Visibility (m) on the plane height_m above the terrain: beta from the cell containing that
 * height (linear between cell centres, constant below the first fluid cell's centre). */
void sq__sand_visibility_plane(const float *beta, int nx, int ny, int nz, const int *ground_k,
                               const float *ground_z1, float h, float height_m, double contrast,
                               float *out)
{
    const double lnc = log(1.0 / contrast);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            size_t col = (size_t)j * (size_t)nx + (size_t)i;
            int k0 = ground_k[col];
            if (k0 < 0) {
                out[col] = NAN;
                continue;
            }
            float z1 = ground_z1[col];
            float kf = (float)k0 + (height_m - z1) / h; /* fractional cell index of the plane */
            if (kf < (float)k0) kf = (float)k0;
            if (kf > (float)(nz - 1)) kf = (float)(nz - 1);
            int ka = (int)kf;
            int kb = ka + 1 < nz ? ka + 1 : ka;
            float t = kf - (float)ka;
            size_t plane = (size_t)nx * (size_t)ny;
            double b = (1.0 - (double)t) * (double)beta[(size_t)ka * plane + col] +
                       (double)t * (double)beta[(size_t)kb * plane + col];
            out[col] = (float)(lnc / (b + SQ_SAND_BETA_AIR_550));
        }
}

/* The wall's top as seen from ahead, looking along x (the storm's motion) through the whole
 * domain: per row j the optical depth at 550 nm of each level, tau(j, k) = sum_i beta h over
 * the level's fluid cells (k at or above the column's ground); the row's wall top is the top of
 * the highest level with tau >= ln(1 / contrast), where the dust hides what is behind it
 * (Koschmieder's contrast threshold, as for the visibility), as a height above the row's lowest
 * ground. Returns the median over the rows (rows without such a level count as 0), so a few
 * dense columns do not make a wall. */
double sq__sand_wall_seen(const float *beta, int nx, int ny, int nz, const int *ground_k,
                          const float *ground_z1, float h, double contrast, double *rows)
{
    const double tau_min = log(1.0 / contrast);
    const size_t plane = (size_t)nx * (size_t)ny;
    for (int j = 0; j < ny; j++) {
        int kg = nz;
        float z1 = 0.5f * h;
        for (int i = 0; i < nx; i++) {
            const int k0 = ground_k[(size_t)j * nx + i];
            if (k0 >= 0 && k0 < kg) {
                kg = k0;
                z1 = ground_z1[(size_t)j * nx + i];
            }
        }
        double top = 0.0;
        for (int k = nz - 1; k >= kg && top == 0.0; k--) {
            double tau = 0.0;
            for (int i = 0; i < nx; i++) {
                const size_t col = (size_t)j * nx + i;
                if (ground_k[col] >= 0 && k >= ground_k[col])
                    tau += (double)beta[(size_t)k * plane + col] * (double)h;
            }
            if (tau >= tau_min) top = (k - kg + 0.5) * (double)h + (double)z1;
        }
        rows[j] = top;
    }
    return sq__sand_median_rows(rows, ny);
}

double sq__sand_median_rows(double *rows, int ny)
{
    /* median (insertion sort: ny is at most a few hundred) */
    for (int a = 1; a < ny; a++)
        for (int b = a; b > 0 && rows[b] < rows[b - 1]; b--) {
            const double t = rows[b];
            rows[b] = rows[b - 1];
            rows[b - 1] = t;
        }
    return ny % 2 ? rows[ny / 2] : 0.5 * (rows[ny / 2 - 1] + rows[ny / 2]);
}
