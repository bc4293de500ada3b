/* grid_diffuse.c — viscous diffusion of the wind with a mixing-length eddy viscosity (SPEC
 * §1.5, S0 eqs 2.16–2.17, Prandtl; with nu instead of S0's inconsistent nu/mu):
 *
 *   Reynolds shear stress (S0 2.17): tau_xz / rho = nu_t du/dz, tau_yz / rho = nu_t dv/dz,
 *     nu_t = (kappa d)^2 |d u_h / dz|,  d = height above the nearest solid cell (or the ground
 *     wall) below, u_h the horizontal wind; mixing length capped by mixing_length_max_m;
 *     du_h/dz from cell-centred winds (central; one-sided at the top; against the wall value
 *     0 half a cell below in a cell resting on a solid or a no-slip ground);
 *   =>  du/dt = d/dz ((nu_mol + nu_t) du/dz), likewise v  (the horizontal components only, as
 *     in S0; w and horizontal gradients see the molecular viscosity alone).
 *
 * The vertical part is solved exactly by backward Euler: one tridiagonal system per column
 * (Thomas algorithm), unconditionally stable and monotone (an M-matrix: no new extrema) for any
 * dt. Faces touching solids keep u = 0 and act as the no-slip wall half a cell below the
 * lowest free face (as does a NO_SLIP ground); FREE_SLIP and open ends have no flux (so do the
 * column ends of a periodic z axis: the vertical solve is not cyclic).
 *
 * The isotropic molecular part nu_mol lap(u) is applied to all three components only when its
 * diffusion number nu_mol dt / h^2 exceeds 1e-3 (below that it is orders of magnitude smaller
 * than the advection scheme's own numerical diffusion): explicitly when <= 1/6, otherwise by
 * diffusion_iterations red-black Gauss-Seidel sweeps of backward Euler (every update a convex
 * combination, so it cannot amplify the velocity either). */
#include <string.h>

#include "solvers/grid/grid_internal.h"

#define MOD "grid"
#define MOLECULAR_THRESHOLD 1e-3f

static inline float ucell(const sq_grid *g, int c, int i, int j, int k)
{
    const sq_field3 *f = &g->vel[c];
    const float *p = sq_field3_at(f, i, j, k);
    const ptrdiff_t s = c == 0 ? 1 : c == 1 ? f->sy : f->sz;
    return 0.5f * (p[0] + p[s]);
}

/* nu_t per cell (cell layout, ghosts zero-gradient); returns the largest nu_t */
static float eddy_viscosity(sq_grid *g, float *nu, float kappa)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const float h = g->h, ih = 1.0f / g->h;
    const float lmax = g->d.mixing_length_max_m > 0.0 ? (float)g->d.mixing_length_max_m : 1e30f;
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    const bool no_slip_ground = g->d.boundary[SQ_FACE_ZMIN] == SQ_BOUNDARY_NO_SLIP;
    double *pm = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        float m = 0.0f;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = sq__cidx(g, i, j, k);
                float v = 0.0f;
                const unsigned below = g->below[c];
                if (!(fl[c] & SQ__CF_SOLID) && below > 0 && kappa > 0.0f) {
                    const bool dn = k > 0 && !(fl[c - g->sz] & SQ__CF_SOLID);
                    const bool up = k < nz - 1 && !(fl[c + g->sz] & SQ__CF_SOLID);
                    /* resting on a no-slip wall: the wind is 0 half a cell below */
                    const bool wall = k > 0 ? !dn : no_slip_ground;
                    float du = 0.0f, dv = 0.0f;
                    if (wall) {
                        du = 2.0f * ucell(g, 0, i, j, k) * ih;
                        dv = 2.0f * ucell(g, 1, i, j, k) * ih;
                    } else if (dn && up) {
                        du = 0.5f * (ucell(g, 0, i, j, k + 1) - ucell(g, 0, i, j, k - 1)) * ih;
                        dv = 0.5f * (ucell(g, 1, i, j, k + 1) - ucell(g, 1, i, j, k - 1)) * ih;
                    } else if (up) {
                        du = (ucell(g, 0, i, j, k + 1) - ucell(g, 0, i, j, k)) * ih;
                        dv = (ucell(g, 1, i, j, k + 1) - ucell(g, 1, i, j, k)) * ih;
                    } else if (dn) {
                        du = (ucell(g, 0, i, j, k) - ucell(g, 0, i, j, k - 1)) * ih;
                        dv = (ucell(g, 1, i, j, k) - ucell(g, 1, i, j, k - 1)) * ih;
                    }
                    float l = kappa * ((float)below - 0.5f) * h;
                    l = l < lmax ? l : lmax;
                    v = l * l * sqrtf(du * du + dv * dv);
                }
                nu[c] = v;
                m = v > m ? v : m;
            }
        pm[k] = (double)m;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pm[k] > m ? pm[k] : m;
    sq__grid_fill_ghosts(g, nu + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    return (float)m;
}

/* Backward Euler in z for horizontal component c (0 or 1), one tridiagonal system per column:
 *   -a_lo u_{k-1} + (1 + a_lo + a_hi) u_k - a_hi u_{k+1} = u_k^old,
 * a = dt nu_link / h^2 with nu_link the mean of the two faces' nu (each the mean of the face's
 * two cells). Fixed faces are identity rows; a free face next to a fixed face below/above sees
 * u = 0 half a cell away when that face is fixed by a solid (no-slip) and no flux otherwise.
 * Rows of faces are swept together (x fastest) for locality; OpenMP over y. cp, dp: scratch in
 * the face layout (Thomas coefficients). */
static void vertical_implicit(sq_grid *g, int c, const float *nu, float nu_mol, float s,
                              float *cp, float *dp)
{
    sq_field3 *f = &g->vel[c];
    const int mx = f->n.nx, my = f->n.ny, nz = g->n[2];
    const ptrdiff_t fsy = f->sy, fsz = f->sz;
    const ptrdiff_t off = c == 0 ? 1 : g->sy; /* cell on the low side of the face */
    const uint8_t *fl = g->flags;
    float *u = f->origin;
    const sq_boundary bot = g->d.boundary[SQ_FACE_ZMIN], top = g->d.boundary[SQ_FACE_ZMAX];
    const bool wall_bot = bot == SQ_BOUNDARY_NO_SLIP, wall_top = top == SQ_BOUNDARY_NO_SLIP;
    const int nt = sq_context_threads(g->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < my; j++) {
        /* forward elimination, all faces of the row at once */
        for (int k = 0; k < nz; k++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
            const ptrdiff_t c0 = sq__cidx(g, 0, j, k);
            for (int i = 0; i < mx; i++) {
                const ptrdiff_t p = r0 + i, hi = c0 + i, lo = hi - off;
                if ((fl[lo] | fl[hi]) & SQ__CF_FIXED) { /* identity row */
                    cp[p] = 0.0f;
                    dp[p] = u[p];
                    continue;
                }
                const float nf = nu_mol + 0.5f * (nu[lo] + nu[hi]);
                /* link below */
                float alo = 0.0f;
                bool fixed_lo;
                if (k == 0) {
                    fixed_lo = true;
                    alo = wall_bot ? 2.0f * s * nf : 0.0f;
                } else {
                    const ptrdiff_t hb = hi - g->sz, lb = lo - g->sz;
                    fixed_lo = ((fl[lb] | fl[hb]) & SQ__CF_FIXED) != 0;
                    if (fixed_lo)
                        alo = ((fl[lb] | fl[hb]) & SQ__CF_SOLID) ? 2.0f * s * nf : 0.0f;
                    else
                        alo = s * 0.5f * (nf + nu_mol + 0.5f * (nu[lb] + nu[hb]));
                }
                /* link above */
                float ahi;
                bool fixed_hi;
                if (k == nz - 1) {
                    fixed_hi = true;
                    ahi = wall_top ? 2.0f * s * nf : 0.0f;
                } else {
                    const ptrdiff_t ha = hi + g->sz, la = lo + g->sz;
                    fixed_hi = ((fl[la] | fl[ha]) & SQ__CF_FIXED) != 0;
                    if (fixed_hi)
                        ahi = ((fl[la] | fl[ha]) & SQ__CF_SOLID) ? 2.0f * s * nf : 0.0f;
                    else
                        ahi = s * 0.5f * (nf + nu_mol + 0.5f * (nu[la] + nu[ha]));
                }
                /* row: -alo u_{k-1} + (1 + alo + ahi) u_k - ahi u_{k+1} = u_k; a fixed
                 * neighbour contributes its value 0 (no-slip) or nothing (no flux) */
                const float diag = 1.0f + alo + ahi;
                const float lower = fixed_lo ? 0.0f : -alo;
                const float upper = fixed_hi ? 0.0f : -ahi;
                const float cprev = fixed_lo ? 0.0f : cp[p - fsz];
                const float dprev = fixed_lo ? 0.0f : dp[p - fsz];
                const float den = diag - lower * cprev;
                cp[p] = upper / den;
                dp[p] = (u[p] - lower * dprev) / den;
            }
        }
        /* back substitution */
        for (int k = nz - 1; k >= 0; k--) {
            const ptrdiff_t r0 = (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
            for (int i = 0; i < mx; i++) {
                const ptrdiff_t p = r0 + i;
                const float next = k < nz - 1 ? u[p + fsz] : 0.0f;
                u[p] = dp[p] - cp[p] * next;
            }
        }
    }
}

/* Isotropic molecular diffusion of every component (explicit or red-black GS backward Euler). */
static void molecular(sq_grid *g, float nu_mol, float s, bool implicit)
{
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    const float a = s * nu_mol;
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = c == 0 ? 1 : c == 1 ? g->sy : g->sz;
        const ptrdiff_t fsy = f->sy, fsz = f->sz;
        float *old = g->scratch[2] + (f->origin - f->base);
        memcpy(g->scratch[2], f->base, f->count * sizeof(float));
        const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
        if (!implicit) {
            float *u = f->origin;
            SQ_OMP(omp parallel for schedule(static) num_threads(nt))
            for (int k = 0; k < mz; k++)
                for (int j = 0; j < my; j++) {
                    const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                    for (int i = 0; i < mx; i++) {
                        const ptrdiff_t p = (ptrdiff_t)i + (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
                        const ptrdiff_t hi = r0 + i, lo = hi - off;
                        if ((fl[lo] | fl[hi]) & SQ__CF_FIXED) continue;
                        u[p] = old[p] + a * (old[p - 1] + old[p + 1] + old[p - fsy] + old[p + fsy] +
                                             old[p - fsz] + old[p + fsz] - 6.0f * old[p]);
                    }
                }
        } else {
            float *u = f->origin;
            const float den = 1.0f / (1.0f + 6.0f * a);
            for (int it = 0; it < g->d.diffusion_iterations; it++) {
                for (int colour = 0; colour < 2; colour++) {
                    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
                    for (int k = 0; k < mz; k++)
                        for (int j = 0; j < my; j++) {
                            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                            for (int i = (j + k + colour) & 1; i < mx; i += 2) {
                                const ptrdiff_t hi = r0 + i, lo = hi - off;
                                if ((fl[lo] | fl[hi]) & SQ__CF_FIXED) continue;
                                const ptrdiff_t p =
                                    (ptrdiff_t)i + (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
                                u[p] = (old[p] + a * (u[p - 1] + u[p + 1] + u[p - fsy] +
                                                      u[p + fsy] + u[p - fsz] + u[p + fsz])) *
                                       den;
                            }
                        }
                }
                sq__grid_fill_ghosts(g, f->origin, fsy, fsz, c + 1, -1);
            }
        }
        sq__grid_fill_ghosts(g, f->origin, fsy, fsz, c + 1, -1);
    }
}

sq_result sq_grid_diffuse_eddy(sq_grid *g, double nu_mol, double kappa, double dt_s)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_diffuse_eddy: grid is NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "sq_grid_diffuse_eddy: dt = %g s; must "
                        "be > 0", dt_s);
    if (!(nu_mol >= 0.0) || !isfinite(nu_mol))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "nu_mol = %g m^2/s; must be >= 0 (air: 1.5e-5)", nu_mol);
    if (!(kappa >= 0.0 && kappa <= 2.0))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "kappa = %g; must be in [0, 2] (von Karman: 0.4; 0 = molecular only)",
                        kappa);
    if (g->topology_dirty) {
        sq_result r = sq__grid_update_topology(g);
        if (r != SQ_OK) return r;
    }
    double t0 = sq_time_now();
    sq__grid_enforce_velocity(g);
    const float s = (float)dt_s / (g->h * g->h);
    const float mol = (float)nu_mol * s;
    const bool do_mol = mol > MOLECULAR_THRESHOLD;
    float *nu = g->scratch[0];
    const float ntmax = kappa > 0.0 ? eddy_viscosity(g, nu, (float)kappa) : 0.0f;
    g->stats.last_diffusion_number = (double)((ntmax + (float)nu_mol) * s);
    g->stats.last_diffusion_implicit = ntmax > 0.0f || mol > 1.0f / 6.0f;
    if (ntmax > 0.0f) {
        const float mol_in_z = do_mol ? 0.0f : (float)nu_mol;
        for (int c = 0; c < 2; c++) {
            sq_field3 *f = &g->vel[c];
            vertical_implicit(g, c, nu, mol_in_z, s, g->scratch[1] + (f->origin - f->base),
                              g->scratch[2] + (f->origin - f->base));
            sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, c + 1, -1);
        }
    }
    if (do_mol) {
        const bool implicit = mol > 1.0f / 6.0f;
        if (implicit)
            sq_log(g->ctx, SQ_LOG_DEBUG, MOD,
                   "molecular diffusion number %.3g > 1/6: backward Euler (%d Gauss-Seidel "
                   "sweeps)",
                   (double)mol, g->d.diffusion_iterations);
        molecular(g, (float)nu_mol, s, implicit);
    }
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    g->stats.ms_diffuse += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}
