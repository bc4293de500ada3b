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
 *   With sq_grid_set_eddy_scalars: stratified (Lilly 1962) nu_t = l^2 sqrt(max(0, S^2 -
 *     N^2 / Pr_t)), N^2 = (g / theta) d theta / dz, and every scalar's turbulent flux
 *     dc/dt = d/dz (K dc/dz), K = nu_t / Pr_t (scalars_vertical_implicit).
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

enum { DROW = 128 }; /* row chunk of the eddy-viscosity kernel */

/* Cell-centred horizontal wind of cells i0 .. i0+n-1 of row (j, k) (k may be -1 or nz: the
 * ghost planes). */
static void cell_row_uv(const sq_grid *g, int i0, int n, int j, int k, float *restrict uo,
                        float *restrict vo)
{
    const float *u = sq_field3_at(&g->vel[0], i0, j, k), *v0 = sq_field3_at(&g->vel[1], i0, j, k),
                *v1 = sq_field3_at(&g->vel[1], i0, j + 1, k);
    for (int i = 0; i < n; i++) {
        uo[i] = 0.5f * (u[i] + u[i + 1]);
        vo[i] = 0.5f * (v0[i] + v1[i]);
    }
}

typedef struct eddy_par {
    float ih, h, kappa, lmax;
    float g_pr;                    /* g / Pr_t of the stratification term; 0: neutral */
    bool no_slip_ground, kdn, kup; /* kdn: k > 0, kup: k < nz - 1 */
} eddy_par;

/* nu_t = (kappa d)^2 |du_h/dz| of n cells of one row from the cell winds of planes k-1 (um,
 * vm), k (u0, v0) and k+1 (up, vp); every case is evaluated and selected so that the loop
 * vectorises. Returns the bit pattern of the row's largest nu_t (non-negative floats order
 * like their bits). */
static int32_t eddy_row(const eddy_par *p, const uint8_t *restrict fl,
                        const uint8_t *restrict fdn, const uint8_t *restrict fup,
                        const uint16_t *restrict below, const float *restrict um,
                        const float *restrict u0, const float *restrict up,
                        const float *restrict vm, const float *restrict v0,
                        const float *restrict vp, const float *restrict tm,
                        const float *restrict t0, const float *restrict tp,
                        float *restrict nu, int n)
{
    const float ih = p->ih, h = p->h, kappa = p->kappa, lmax = p->lmax, g_pr = p->g_pr;
    /* conditions as int32 masks (see sq__fselm) */
    const int32_t kdn = -(int32_t)p->kdn, kup = -(int32_t)p->kup,
                  nsg = -(int32_t)p->no_slip_ground, kap = -(int32_t)(kappa > 0.0f);
    float l2[DROW];
    for (int i = 0; i < n; i++) {
        const int32_t dn = kdn & -(int32_t)((fdn[i] & SQ__CF_SOLID) == 0);
        const int32_t upo = kup & -(int32_t)((fup[i] & SQ__CF_SOLID) == 0);
        /* resting on a no-slip wall: the wind is 0 half a cell below */
        const int32_t wall = (kdn & ~dn) | (~kdn & nsg);
        const float du = sq__fselm(
            wall, 2.0f * u0[i] * ih,
            sq__fselm(dn & upo, 0.5f * (up[i] - um[i]) * ih,
                      sq__fselm(upo, (up[i] - u0[i]) * ih, sq__fselm(dn, (u0[i] - um[i]) * ih, 0.0f))));
        const float dv = sq__fselm(
            wall, 2.0f * v0[i] * ih,
            sq__fselm(dn & upo, 0.5f * (vp[i] - vm[i]) * ih,
                      sq__fselm(upo, (vp[i] - v0[i]) * ih, sq__fselm(dn, (v0[i] - vm[i]) * ih, 0.0f))));
        float l = kappa * ((float)below[i] - 0.5f) * h;
        l = l < lmax ? l : lmax;
        const int32_t active =
            kap & -(int32_t)((fl[i] & SQ__CF_SOLID) == 0) & -(int32_t)(below[i] > 0);
        l2[i] = sq__fselm(active, l * l, 0.0f);
        /* stratification (Lilly 1962): S^2 - N^2 / Pr_t, N^2 = (g / theta) d theta / dz
         * (central; one-sided next to a solid or the domain's ends; tm = t0 = tp when
         * neutral) */
        const float dth = sq__fselm(dn & upo, 0.5f * (tp[i] - tm[i]) * ih,
                                    sq__fselm(upo, (tp[i] - t0[i]) * ih,
                                              sq__fselm(dn, (t0[i] - tm[i]) * ih, 0.0f)));
        /* differences below 1e-3 K per cell are round-off of the float theta (its resolution
         * is 3e-5 K at 300 K), not stratification: without this dead band an exactly neutral
         * column without shear would convect on round-off */
        const float dthc = dth * h;
        const float dths = sq__fselm(-(int32_t)((dthc > 1e-3f) | (dthc < -1e-3f)), dth, 0.0f);
        const float ith = sq__fselm(-(int32_t)(t0[i] > 0.0f), 1.0f / t0[i], 0.0f);
        const float s2 = du * du + dv * dv - g_pr * dths * ith;
        nu[i] = sq__fselm(-(int32_t)(s2 > 0.0f), s2, 0.0f);
    }
    sq__sqrt_row(nu, n);
    int32_t m = 0;
    for (int i = 0; i < n; i++) {
        const float v = l2[i] * nu[i];
        nu[i] = v;
        int32_t b;
        memcpy(&b, &v, sizeof b);
        m = b > m ? b : m;
    }
    return m;
}

/* nu_t per cell (cell layout, ghosts zero-gradient); returns the largest nu_t */
static float eddy_viscosity(sq_grid *g, float *nu, float kappa)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    eddy_par par;
    par.h = g->h;
    par.ih = 1.0f / g->h;
    par.kappa = kappa;
    par.lmax = g->d.mixing_length_max_m > 0.0 ? (float)g->d.mixing_length_max_m : 1e30f;
    par.no_slip_ground = g->d.boundary[SQ_FACE_ZMIN] == SQ_BOUNDARY_NO_SLIP;
    const bool strat = g->eddy_scalars && g->eddy_theta >= 0;
    par.g_pr = strat ? g->eddy_g / g->eddy_prandtl : 0.0f;
    const sq_field3 *T = strat ? &g->scalar[g->eddy_theta] : NULL;
    double *pm = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        float um[DROW], vm[DROW], u0[DROW], v0[DROW], up[DROW], vp[DROW], one[DROW];
        for (int i = 0; i < DROW; i++) one[i] = 1.0f;
        eddy_par pk = par;
        pk.kdn = k > 0;
        pk.kup = k < nz - 1;
        int32_t m = 0;
        for (int j = 0; j < ny; j++)
            for (int i0 = 0; i0 < nx; i0 += DROW) {
                const int n = nx - i0 < DROW ? nx - i0 : DROW;
                cell_row_uv(g, i0, n, j, k - 1, um, vm);
                cell_row_uv(g, i0, n, j, k, u0, v0);
                cell_row_uv(g, i0, n, j, k + 1, up, vp);
                const ptrdiff_t c = sq__cidx(g, i0, j, k);
                const float *t0 = strat ? sq_field3_at(T, i0, j, k) : one;
                const float *tm = strat ? t0 - T->sz : one, *tp = strat ? t0 + T->sz : one;
                const int32_t rm = eddy_row(&pk, fl + c, fl + c - g->sz, fl + c + g->sz,
                                            g->below + c, um, u0, up, vm, v0, vp, tm, t0, tp,
                                            nu + c, n);
                m = rm > m ? rm : m;
            }
        float mf;
        memcpy(&mf, &m, sizeof mf);
        pm[k] = (double)mf;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pm[k] > m ? pm[k] : m;
    sq__grid_fill_ghosts(g, nu + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    return (float)m;
}

typedef struct vi_par {
    float s, nu_mol;
    int32_t bottom, top;     /* masks: this is plane 0 / plane nz - 1 */
    int32_t wall_bot, wall_top; /* masks: no-slip domain bottom / top */
    int32_t ground_link;        /* mask: the ground below is a link (0: the log-law stress) */
} vi_par;

/* Forward elimination of one row of faces of plane k (see vertical_implicit). u, cp, dp: face
 * rows (cp/dp of plane k - 1 at -fsz); flags and nu: the rows of the faces' low (o) and high
 * (h) cells at planes k - 1 (b), k and k + 1 (a), as offsets -/+ sz from fo/fh and no/nh. */
static void vi_forward_row(const vi_par *p, const float *restrict u, float *restrict cp,
                           float *restrict dp, ptrdiff_t fsz, const uint8_t *restrict fo,
                           const uint8_t *restrict fh, const float *restrict no,
                           const float *restrict nh, ptrdiff_t sz, int n)
{
    const float s = p->s, nu_mol = p->nu_mol;
    const int32_t bottom = p->bottom, top = p->top, wb = p->wall_bot, wt = p->wall_top,
                  gl = p->ground_link;
    for (int i = 0; i < n; i++) {
        const int32_t fixed = -(int32_t)(((fo[i] | fh[i]) & SQ__CF_FIXED) != 0);
        const float nf = nu_mol + 0.5f * (no[i] + nh[i]);
        /* link below: the domain bottom, a fixed face (no-slip if fixed by a solid) or free */
        const uint8_t flb = fo[i - sz] | fh[i - sz];
        const int32_t fxl = bottom | -(int32_t)((flb & SQ__CF_FIXED) != 0);
        const int32_t wall_l = (bottom & wb) | (~bottom & -(int32_t)((flb & SQ__CF_SOLID) != 0));
        const float alo = sq__fselm(fxl, sq__fselm(wall_l & gl, 2.0f * s * nf, 0.0f),
                                    s * 0.5f * (nf + nu_mol + 0.5f * (no[i - sz] + nh[i - sz])));
        /* link above */
        const uint8_t fla = fo[i + sz] | fh[i + sz];
        const int32_t fxh = top | -(int32_t)((fla & SQ__CF_FIXED) != 0);
        const int32_t wall_h = (top & wt) | (~top & -(int32_t)((fla & SQ__CF_SOLID) != 0));
        const float ahi = sq__fselm(fxh, sq__fselm(wall_h, 2.0f * s * nf, 0.0f),
                                    s * 0.5f * (nf + nu_mol + 0.5f * (no[i + sz] + nh[i + sz])));
        /* row: -alo u_{k-1} + (1 + alo + ahi) u_k - ahi u_{k+1} = u_k; a fixed neighbour
         * contributes its value 0 (no-slip) or nothing (no flux) */
        const float diag = 1.0f + alo + ahi;
        const float lower = sq__fselm(fxl, 0.0f, -alo);
        const float upper = sq__fselm(fxh, 0.0f, -ahi);
        const float cprev = sq__fselm(fxl, 0.0f, cp[i - fsz]);
        const float dprev = sq__fselm(fxl, 0.0f, dp[i - fsz]);
        const float den = diag - lower * cprev;
        cp[i] = sq__fselm(fixed, 0.0f, upper / den); /* fixed face: identity row */
        dp[i] = sq__fselm(fixed, u[i], (u[i] - lower * dprev) / den);
    }
}

/* Backward Euler in z for horizontal component c (0 or 1), one tridiagonal system per column:
 *   -a_lo u_{k-1} + (1 + a_lo + a_hi) u_k - a_hi u_{k+1} = u_k^old,
 * a = dt nu_link / h^2 with nu_link the mean of the two faces' nu (each the mean of the face's
 * two cells). Fixed faces are identity rows; a free face next to a fixed face below/above sees
 * u = 0 half a cell away when that face is fixed by a solid (no-slip) and no flux otherwise.
 * Rows of faces are swept together (x fastest, vectorised) for locality; OpenMP over y. cp, dp:
 * scratch in the face layout (Thomas coefficients). */
static void vertical_implicit(sq_grid *g, int c, const float *nu, float nu_mol, float s,
                              float *cp, float *dp)
{
    sq_field3 *f = &g->vel[c];
    const int mx = f->n.nx, my = f->n.ny, nz = g->n[2];
    const ptrdiff_t fsy = f->sy, fsz = f->sz;
    const ptrdiff_t off = c == 0 ? 1 : g->sy; /* cell on the low side of the face */
    const uint8_t *fl = g->flags;
    float *u = f->origin;
    vi_par par;
    par.s = s;
    par.nu_mol = nu_mol;
    par.wall_bot = -(int32_t)(g->d.boundary[SQ_FACE_ZMIN] == SQ_BOUNDARY_NO_SLIP);
    par.wall_top = -(int32_t)(g->d.boundary[SQ_FACE_ZMAX] == SQ_BOUNDARY_NO_SLIP);
    par.ground_link = -(int32_t)(g->d.wall_roughness_m <= 0.0);
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < my; j++) {
        vi_par pk = par;
        /* forward elimination, all faces of the row at once */
        for (int k = 0; k < nz; k++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
            const ptrdiff_t hi = sq__cidx(g, 0, j, k), lo = hi - off;
            pk.bottom = -(int32_t)(k == 0);
            pk.top = -(int32_t)(k == nz - 1);
            vi_forward_row(&pk, u + r0, cp + r0, dp + r0, fsz, fl + lo, fl + hi, nu + lo, nu + hi,
                           g->sz, mx);
        }
        /* back substitution */
        for (int k = nz - 1; k >= 0; k--) {
            const ptrdiff_t r0 = (ptrdiff_t)j * fsy + (ptrdiff_t)k * fsz;
            float *ur = u + r0;
            const float *cr = cp + r0, *dr = dp + r0, *un = ur + fsz;
            if (k == nz - 1)
                for (int i = 0; i < mx; i++) ur[i] = dr[i];
            else
                for (int i = 0; i < mx; i++) ur[i] = dr[i] - cr[i] * un[i];
        }
    }
}

/* Isotropic molecular diffusion of every component (explicit or red-black GS backward Euler). */
static void molecular(sq_grid *g, float nu_mol, float s, bool implicit)
{
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
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
            const int par = sq__grid_dist_parity(g); /* colours by the global index */
            for (int it = 0; it < g->d.diffusion_iterations; it++) {
                for (int colour = 0; colour < 2; colour++) {
                    /* a decomposed grid: the neighbours' other colour, just updated */
                    if (colour == 1) sq__grid_dist_halo_lattice(g, f->origin, fsy, fsz, c + 1);
                    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
                    for (int k = 0; k < mz; k++)
                        for (int j = 0; j < my; j++) {
                            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                            for (int i = (j + k + colour + par) & 1; i < mx; i += 2) {
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

/* Turbulent flux of every scalar, dc/dt = d/dz (K dc/dz) with K = nu_t / Pr_t (gradient
 * diffusion with the momentum's mixing-length closure), by backward Euler per column:
 *   -a_lo c_{k-1} + (1 + a_lo + a_hi) c_k - a_hi c_{k+1} = c_k^old,
 * a = dt K_link / h^2 with K_link the mean of the link's two cells. Links exist only between
 * two fluid cells of the column: no flux through the ground, solids or the column's ends, so
 * the column sum is conserved (to round-off), and the M-matrix keeps c within its old range.
 * nu: eddy viscosity per cell (cell layout; overwritten); ahi, cp, dp: scratch in the cell
 * layout. */
static void scalars_vertical_implicit(sq_grid *g, float *nu, float s_pr, float *ahi,
                                      float *cp, float *dp)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const uint8_t *fl = g->flags;
    const ptrdiff_t sz = g->sz;
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    /* per x-z slice of columns (one j): the slice's coefficients, then every scalar in turn;
     * the coefficients and the increments stay in the cache across the scalars, and each
     * scalar's slice is read and written once (forward elimination, then the back substitution
     * adding each increment as it is found). iden overwrites the slice's nu once its links are
     * known (nu is not needed afterwards). */
    float *iden = (float *)nu;
    const int ns = g->d.scalar_count;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int j = 0; j < ny; j++) {
        for (int k = 0; k < nz; k++) { /* coefficient of the link between cell k and k + 1 */
            const ptrdiff_t c = sq__cidx(g, 0, j, k);
            const int32_t top = -(int32_t)(k == nz - 1);
            for (int i = 0; i < nx; i++) {
                const int32_t open = ~top & -(int32_t)(((fl[c + i] | fl[c + i + sz]) &
                                                        SQ__CF_SOLID) == 0);
                ahi[c + i] = sq__fselm(open, 0.5f * s_pr * (nu[c + i] + nu[c + i + sz]), 0.0f);
            }
        }
        for (int k = 0; k < nz; k++) { /* the elimination's cp and 1/den, shared by the scalars */
            const ptrdiff_t c = sq__cidx(g, 0, j, k);
            const int32_t bottom = -(int32_t)(k == 0);
            for (int i = 0; i < nx; i++) {
                const float alo = sq__fselm(bottom, 0.0f, ahi[c + i - sz]);
                const float ah = ahi[c + i];
                const float cprev = sq__fselm(bottom, 0.0f, cp[c + i - sz]);
                const float inv = 1.0f / (1.0f + alo + ah + alo * cprev); /* cp <= 0 */
                cp[c + i] = -ah * inv;
                iden[c + i] = inv;
            }
        }
        for (int sidx = 0; sidx < ns; sidx++) {
            float *f = g->scalar[sidx].base;
            for (int k = 0; k < nz; k++) { /* forward elimination, a row of columns at once */
                const ptrdiff_t c = sq__cidx(g, 0, j, k);
                const int32_t bottom = -(int32_t)(k == 0);
                for (int i = 0; i < nx; i++) {
                    const float alo = sq__fselm(bottom, 0.0f, ahi[c + i - sz]);
                    const float ah = ahi[c + i];
                    const float dprev = sq__fselm(bottom, 0.0f, dp[c + i - sz]);
                    /* in increments: (1 - a L) dc = a L c, so that a uniform field stays
                     * bit-exact (no round-off anomalies for the buoyancy to amplify) */
                    const float rhs = alo * (f[c + i - sz] - f[c + i]) + ah * (f[c + i + sz] - f[c + i]);
                    dp[c + i] = (rhs + alo * dprev) * iden[c + i];
                }
            }
            { /* the top cell's increment is final */
                const ptrdiff_t c = sq__cidx(g, 0, j, nz - 1);
                for (int i = 0; i < nx; i++) f[c + i] += dp[c + i];
            }
            for (int k = nz - 2; k >= 0; k--) { /* back substitution of the increments */
                const ptrdiff_t c = sq__cidx(g, 0, j, k);
                for (int i = 0; i < nx; i++) {
                    const float d = dp[c + i] - cp[c + i] * dp[c + i + sz];
                    dp[c + i] = d;
                    f[c + i] += d;
                }
            }
        }
    }
    sq__grid_dist_batch_begin(g);
    for (int sidx = 0; sidx < ns; sidx++)
        sq__grid_fill_ghosts(g, g->scalar[sidx].origin, g->scalar[sidx].sy, g->scalar[sidx].sz,
                             SQ__L_CELL, sidx);
    sq__grid_dist_batch_end(g);
}

sq_result sq_grid_set_eddy_scalars(sq_grid *g, double prandtl_t, int theta_idx,
                                   double gravity_mps2)
{
    if (!g)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_eddy_scalars: grid is NULL");
    if (!(prandtl_t >= 0.1 && prandtl_t <= 10.0))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "prandtl_t = %g (turbulent Prandtl number); must be in [0.1, 10] (neutral: 0.74)",
                        prandtl_t);
    if (theta_idx < -1 || theta_idx >= g->d.scalar_count)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "theta_idx = %d; must be -1 (neutral) or in 0..%d (scalar_count = %d)",
                        theta_idx, g->d.scalar_count - 1, g->d.scalar_count);
    if (theta_idx >= 0 && !(gravity_mps2 > 0.0 && isfinite(gravity_mps2)))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "gravity_mps2 = %g; must be > 0 with a stratification scalar",
                        gravity_mps2);
    g->eddy_scalars = true;
    g->eddy_prandtl = (float)prandtl_t;
    g->eddy_theta = theta_idx;
    g->eddy_g = theta_idx >= 0 ? (float)gravity_mps2 : 0.0f;
    return SQ_OK;
}

sq_result sq_grid_diffuse_eddy(sq_grid *g, double nu_mol, double kappa, double dt_s)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_diffuse_eddy: grid is NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "sq_grid_diffuse_eddy: dt = %g s; must "
                        "be > 0", dt_s);
    if (!(nu_mol >= 0.0) || !isfinite(nu_mol))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "nu_mol_m2ps = %g; must be >= 0 (air: 1.5e-5)", nu_mol);
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
    float ntmax = kappa > 0.0 ? eddy_viscosity(g, nu, (float)kappa) : 0.0f;
    if (g->halo) { /* a decomposed grid: every slab takes the same branches */
        double m = (double)ntmax;
        sq__grid_dist_max(g, &m, 1);
        ntmax = (float)m;
    }
    g->stats.last_diffusion_number = (double)((ntmax + (float)nu_mol) * s);
    g->stats.last_diffusion_implicit = ntmax > 0.0f || mol > 1.0f / 6.0f;
    if (ntmax > 0.0f) {
        const float mol_in_z = do_mol ? 0.0f : (float)nu_mol;
        sq__grid_dist_batch_begin(g); /* both components' ghost planes in one message */
        for (int c = 0; c < 2; c++) {
            sq_field3 *f = &g->vel[c];
            vertical_implicit(g, c, nu, mol_in_z, s, g->scratch[1] + (f->origin - f->base),
                              g->scratch[2] + (f->origin - f->base));
            sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, c + 1, -1);
        }
        sq__grid_dist_batch_end(g);
    }
    if (ntmax > 0.0f && g->d.wall_roughness_m > 0.0) /* the ground's log-law stress */
        sq__grid_wall_stress(g, kappa, g->d.wall_roughness_m, (float)dt_s);
    if (ntmax > 0.0f && g->eddy_scalars && g->d.scalar_count > 0)
        scalars_vertical_implicit(g, nu, s / g->eddy_prandtl, g->scratch[3], g->scratch[1],
                                  g->scratch[2]);
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
