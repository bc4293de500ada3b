/* grid_diffuse.c — viscous diffusion of the face velocities with a mixing-length eddy viscosity
 * (SPEC §1.5, S0 eqs 2.16–2.17, Prandtl; ν instead of S0's inconsistent ν/μ):
 *     du/dt = div( (nu_mol + nu_t) grad u ),   nu_t = (kappa d)^2 |d u_h / dz|,
 * d = height above the nearest solid cell (or the ground wall) below, u_h the horizontal wind.
 * Time stepping: explicit when the largest diffusion number nu dt / h^2 is <= 1/6 (stable);
 * otherwise backward Euler, (1 + sum a) u - sum a u_nb = u_old with a = nu_link dt / h^2,
 * approximated by diffusion_iterations red-black Gauss-Seidel sweeps warm-started from u_old.
 * Every Gauss-Seidel update is a convex combination of neighbours and u_old, so the scheme
 * cannot amplify the velocity for any dt. Faces touching solids keep u = 0 and act as no-slip
 * neighbours (the drag of the ground and of obstacles). */
#include <string.h>

#include "solvers/grid/grid_internal.h"

#define MOD "grid"

static inline float ucell(const sq_grid *g, int c, int i, int j, int k)
{
    const sq_field3 *f = &g->vel[c];
    const float *p = sq_field3_at(f, i, j, k);
    const ptrdiff_t s = c == 0 ? 1 : c == 1 ? f->sy : f->sz;
    return 0.5f * (p[0] + p[s]);
}

/* nu per cell (cell layout, ghosts zero-gradient); returns the largest nu */
static float eddy_viscosity(sq_grid *g, float *nu, float nu_mol, float kappa)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const float h = g->h, ih = 1.0f / g->h;
    const float lmax = g->d.mixing_length_max_m > 0.0 ? (float)g->d.mixing_length_max_m : 1e30f;
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    double *pm = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        float m = nu_mol;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = sq__cidx(g, i, j, k);
                float v = nu_mol;
                const unsigned below = g->below[c];
                if (!(fl[c] & SQ__CF_SOLID) && below > 0 && kappa > 0.0f) {
                    const bool dn = k > 0 && !(fl[c - g->sz] & SQ__CF_SOLID);
                    const bool up = k < nz - 1 && !(fl[c + g->sz] & SQ__CF_SOLID);
                    float du = 0.0f, dv = 0.0f;
                    if (dn && up) {
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
                    v += l * l * sqrtf(du * du + dv * dv);
                }
                nu[c] = v;
                m = v > m ? v : m;
            }
        pm[k] = (double)m;
    }
    double m = nu_mol;
    for (int k = 0; k < nz; k++) m = pm[k] > m ? pm[k] : m;
    sq__grid_fill_ghosts(g, nu + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    return (float)m;
}

/* nu at every sample of face lattice c (padded, including ghosts): mean of its two cells. */
static void face_viscosity(sq_grid *g, int c, const float *nu, float *nf, const sq_field3 *f)
{
    const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
    const ptrdiff_t off = c == 0 ? 1 : c == 1 ? g->sy : g->sz;
    const int nt = sq_context_threads(g->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = -1; k <= mz; k++)
        for (int j = -1; j <= my; j++)
            for (int i = -1; i <= mx; i++) {
                /* the sample's cells are x - e_c and x; keep both inside the padded range */
                int x[3] = {i, j, k};
                x[c] = x[c] < 0 ? 0 : (x[c] > g->n[c] ? g->n[c] : x[c]);
                const ptrdiff_t hi = sq__cidx(g, x[0], x[1], x[2]);
                nf[(ptrdiff_t)i + (ptrdiff_t)j * f->sy + (ptrdiff_t)k * f->sz] =
                    0.5f * (nu[hi] + nu[hi - off]);
            }
}

static inline float link(const float *nf, ptrdiff_t a, ptrdiff_t b, float s)
{
    return s * 0.5f * (nf[a] + nf[b]);
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
    float *nu = g->scratch[0];
    const float numax = eddy_viscosity(g, nu, (float)nu_mol, (float)kappa);
    const float s = (float)dt_s / (g->h * g->h);
    const float dn = numax * s;
    g->stats.last_diffusion_number = (double)dn;
    if (numax == 0.0f) {
        g->stats.last_diffusion_implicit = false;
        g->stats.ms_diffuse += (sq_time_now() - t0) * 1e3;
        return SQ_OK;
    }
    const bool implicit = dn > 1.0f / 6.0f;
    g->stats.last_diffusion_implicit = implicit;
    if (implicit)
        sq_log(g->ctx, SQ_LOG_DEBUG, MOD,
               "diffusion number %.3g > 1/6: implicit backward Euler (%d Gauss-Seidel sweeps)",
               (double)dn, g->d.diffusion_iterations);
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = c == 0 ? 1 : c == 1 ? g->sy : g->sz;
        const ptrdiff_t fsy = f->sy, fsz = f->sz;
        float *nf = g->scratch[1] + (f->origin - f->base);
        float *old = g->scratch[2] + (f->origin - f->base);
        face_viscosity(g, c, nu, nf, f);
        memcpy(g->scratch[2], f->base, f->count * sizeof(float));
        const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
        if (!implicit) {
            float *out = g->scratch[3] + (f->origin - f->base);
            SQ_OMP(omp parallel for schedule(static) num_threads(nt))
            for (int k = 0; k < mz; k++)
                for (int j = 0; j < my; j++) {
                    const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                    for (int i = 0; i < mx; i++) {
                        const ptrdiff_t p = (ptrdiff_t)i + (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
                        const ptrdiff_t hi = r0 + i, lo = hi - off;
                        float u = old[p];
                        if (!((fl[lo] | fl[hi]) & SQ__CF_FIXED)) {
                            const ptrdiff_t nb[6] = {p - 1, p + 1, p - fsy, p + fsy, p - fsz,
                                                     p + fsz};
                            float du = 0.0f;
                            for (int q = 0; q < 6; q++)
                                du += link(nf, p, nb[q], s) * (old[nb[q]] - old[p]);
                            u += du;
                        }
                        out[p] = u;
                    }
                }
            for (int k = 0; k < mz; k++)
                for (int j = 0; j < my; j++) {
                    const ptrdiff_t p = (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
                    memcpy(f->origin + p, out + p, sizeof(float) * (size_t)mx);
                }
        } else {
            float *u = f->origin;
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
                                const ptrdiff_t nb[6] = {p - 1, p + 1, p - fsy, p + fsy, p - fsz,
                                                         p + fsz};
                                float num = old[p], den = 1.0f;
                                for (int q = 0; q < 6; q++) {
                                    const float a = link(nf, p, nb[q], s);
                                    num += a * u[nb[q]];
                                    den += a;
                                }
                                u[p] = num / den;
                            }
                        }
                }
                sq__grid_fill_ghosts(g, f->origin, fsy, fsz, c + 1, -1);
            }
        }
        sq__grid_fill_ghosts(g, f->origin, fsy, fsz, c + 1, -1);
    }
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    g->stats.ms_diffuse += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}
