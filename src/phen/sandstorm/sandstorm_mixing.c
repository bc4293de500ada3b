/* sandstorm_mixing.c — the dust's turbulent mixing by the ground's own turbulence (solver.
 * surface_layer_mixing): a boundary-layer K-profile for the dust in every column.
 *
 * Why: the resolved closures see the shear of the resolved wind. On 60 m cells a strong wind
 * over the desert (a haboob's body, u ~ 20-25 m/s) is nearly uniform above the first cell; the
 * shear that makes its turbulence, u* / (kappa z), lies below the grid (the log law's stress
 * acts on the first cell only). With the air slightly stable (theta rising with the ambient
 * lapse rate) Lilly's cut-off then gives K = 0, and the emitted dust stays in the first one or
 * two cells. Real outflows are turbulent through their depth and carry the dust up through it
 * (Raman et al. 2014, WRF-Chem, Phoenix 5 July 2011; Vukovic et al. 2014, the same storm: dust
 * filling the outflow's ~1-2 km).
 *
 *   eddy diffusivity  K(z) = kappa u* z (1 - z / h) / Sc       z < h, else 0
 *                     (the parabolic eddy viscosity of a log-law flow with a stress falling
 *                     linearly to 0 at the layer's top, Rouse 1937; Nezu & Nakagawa 1993;
 *                     the neutral limit of Troen & Mahrt's 1986 K-profile); z above the ground,
 *                     u* the column's friction velocity from the first cell's wind (the
 *                     emission's log law), Sc the turbulent Schmidt number (SQ_SAND_PRANDTL_T,
 *                     the same as the other scalar closures).
 *   layer depth       h: the lowest height where the bulk Richardson number
 *                     Ri_b(z) = (g / theta_1) (theta(z) - theta_1) (z - z_1) /
 *                               (|u_h(z) - u_h(z_1)|^2 + b u*^2)
 *                     reaches Ri_c = 0.25, b = 100 (Vogelezang & Holtslag 1996, Boundary-Layer
 *                     Meteorol. 81, 245-269; level 1 the first cell), linear between cells;
 *                     the domain's top (or the first solid above) if never. In a cold pool
 *                     theta jumps at its top, so h is the outflow's depth; in the 3 m/s air
 *                     ahead of a haboob (u* ~ 0.1 m/s) h is a few tens of metres.
 *   steady state      with settling w_s the column balances w_s c + K dc/dz = 0: Rouse's
 *                     profile c / c_a = ((h - z) / z * a / (h - a))^(w_s Sc / (kappa u*)).
 *
 * Applied to the dust bins only: the heat and the wind keep the resolved closure (so the
 * density current's dynamics are those of the closure alone; a limit, docs/phen/sandstorm.md).
 * Backward Euler in each column (Thomas algorithm), flux form with no flux through the ground
 * and the top (emission and deposition are the ground's fluxes): the column's sum is kept to
 * round-off and no new extrema appear, for any dt. */
#include <math.h>

#include "sandstorm_internal.h"

#define RI_CRIT 0.25   /* critical bulk Richardson number (Vogelezang & Holtslag 1996) */
#define RI_B_USTAR 100 /* b: the surface layer's shear-generated turbulence, b u*^2 */

/* Backward Euler of dc/dt = d/dz (K dc/dz) in one column of n cells (stride cs), spacing h:
 * kf[k] is K (m^2/s) on the face between cells k and k + 1 (k < n - 1); no flux at the ends.
 * work: 2 n doubles. */
void sq__sand_column_kmix(float *c, ptrdiff_t cs, int n, const float *kf, double h, double dt,
                          double *work)
{
    if (n < 2) return;
    double *cp = work, *dp = work + n;
    const double r = dt / (h * h);
    /* row k: -a_k c_{k-1} + (1 + a_k + b_k) c_k - b_k c_{k+1} = c_k^old, a_k = r K_{k-1/2},
     * b_k = r K_{k+1/2} */
    double prev_b = 0.0;
    for (int k = 0; k < n; k++) {
        const double a = prev_b, b = k + 1 < n ? r * (double)kf[k] : 0.0;
        const double diag = 1.0 + a + b - (k > 0 ? a * cp[k - 1] : 0.0);
        const double rhs = (double)c[(ptrdiff_t)k * cs] + (k > 0 ? a * dp[k - 1] : 0.0);
        cp[k] = b / diag;
        dp[k] = rhs / diag;
        prev_b = b;
    }
    double next = dp[n - 1];
    c[(ptrdiff_t)(n - 1) * cs] = (float)next;
    for (int k = n - 2; k >= 0; k--) {
        next = dp[k] + cp[k] * next;
        c[(ptrdiff_t)k * cs] = (float)next;
    }
}

/* K on the n - 1 faces of a column from the ground's first cell up: face k at height
 * z = z1 + (k + 1/2) h above the ground. Returns the layer depth used. */
double sq__sand_kprofile(float *kf, int n, double z1, double h, double ustar, double depth,
                         double schmidt)
{
    for (int k = 0; k + 1 < n; k++) {
        const double z = z1 + (k + 0.5) * h;
        kf[k] = z < depth ? (float)(SQ_SAND_KARMAN * ustar * z * (1.0 - z / depth) / schmidt) : 0.0f;
    }
    return depth;
}

/* The layer depth h of a column (see the header): theta[k], u[k], v[k] of n fluid cells from
 * the first (k = 0, height z1 above the ground) up, spacing dz. */
double sq__sand_bulk_ri_depth(const float *theta, const float *u, const float *v, int n,
                              double z1, double dz, double ustar, double gravity)
{
    const double th1 = (double)theta[0], shear0 = RI_B_USTAR * ustar * ustar;
    double ri_prev = 0.0;
    for (int k = 1; k < n; k++) {
        const double du = (double)u[k] - (double)u[0], dv = (double)v[k] - (double)v[0];
        const double den = du * du + dv * dv + shear0;
        const double dzk = k * dz;
        const double ri = den > 0.0 ? gravity / th1 * ((double)theta[k] - th1) * dzk / den : (double)INFINITY;
        if (ri >= RI_CRIT) {
            const double f = isfinite(ri) && ri > ri_prev ? (RI_CRIT - ri_prev) / (ri - ri_prev) : 0.0;
            return z1 + (k - 1 + f) * dz;
        }
        ri_prev = ri;
    }
    return z1 + (n - 0.5) * dz; /* the top of the last cell */
}

/* The step: every column of the slab (its first fluid cell k0 = ground_k, up to the first
 * solid cell above or the top) mixes its dust bins with the K-profile of its own u* and h. */
void sq__sand_mix_dust(sq_sandstorm *s, double dt)
{
    if (!s->d.surface_layer_mixing) return;
    const int nx = s->ln[0], ny = s->ln[1], nz = s->nz, nb = s->nbins;
    const int nt = sq_context_threads(s->ctx);
    (void)nt; /* unused without OpenMP */
    const uint8_t *solid = sq_grid_solid(s->grid);
    const ptrdiff_t plane = (ptrdiff_t)nx * ny;
    const sq_field_view u = sq_grid_velocity_view(s->grid, 0), v = sq_grid_velocity_view(s->grid, 1),
                        th = sq_grid_scalar_view(s->grid, s->temp_idx);
    sq_field3 *c[SQ_SANDSTORM_MAX_BINS];
    for (int b = 0; b < nb; b++) c[b] = sq_grid_scalar_field(s->grid, b);
    const double gravity = SQ_SAND_GRAVITY * (s->d.buoyancy_gain > 0.0 ? s->d.buoyancy_gain : 1.0);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < ny; j++) {
        /* the row's own scratch (thread-count independent) */
        float *tc = s->mix_f + (size_t)j * 4 * nz, *uc = tc + nz, *vc = uc + nz, *kf = vc + nz;
        double *work = s->mix_d + (size_t)j * 2 * nz;
        for (int i = 0; i < nx; i++) {
            const size_t col = (size_t)(j + s->lo[1]) * s->nx + (size_t)(i + s->lo[0]);
            const int k0 = s->ground_k[col];
            if (k0 < 0) continue;
            int n = 0;
            while (k0 + n < nz && !solid[(ptrdiff_t)(k0 + n) * plane + (ptrdiff_t)j * nx + i]) {
                const int k = k0 + n;
                uc[n] = 0.5f * (sq_view_get(&u, i, j, k) + sq_view_get(&u, i + 1, j, k));
                vc[n] = 0.5f * (sq_view_get(&v, i, j, k) + sq_view_get(&v, i, j + 1, k));
                tc[n] = sq_view_get(&th, i, j, k);
                n++;
            }
            if (n < 2) continue;
            const double z1 = s->ground_z1[col];
            const double us = sq_friction_velocity(hypot((double)uc[0], (double)vc[0]), z1, s->d.roughness_m);
            if (!(us > 0.0)) continue;
            const double depth = sq__sand_bulk_ri_depth(tc, uc, vc, n, z1, s->h, us, gravity);
            if (depth <= z1 + 0.5 * s->h) continue; /* no face inside the layer */
            sq__sand_kprofile(kf, n, z1, s->h, us, depth, SQ_SAND_PRANDTL_T);
            for (int b = 0; b < nb; b++)
                sq__sand_column_kmix(sq_field3_at(c[b], i, j, k0), c[b]->sz, n, kf, s->h, dt, work);
        }
    }
}
