/* grid_sgs.c — Smagorinsky–Lilly (or Deardorff's TKE) subgrid-scale closure (large-eddy simulation) of the wind,
 * the heat and every scalar (SPEC §1.5), with a log-law wall stress at the ground:
 *
 *   strain rate      S_ij = (d_j u_i + d_i u_j) / 2,   |S| = sqrt(2 S_ij S_ij)
 *   stratification   N^2 = (g / theta) d theta / dz          (theta: a potential temperature)
 *   eddy viscosity   nu_t = l^2 sqrt(max(0, |S|^2 - N^2 / Pr_t)) = l^2 |S| sqrt(1 - Ri / Pr_t)
 *                    (Smagorinsky 1963; stability correction of Lilly 1962: no subgrid mixing
 *                    above the critical Richardson number Ri = N^2 / |S|^2 = Pr_t, free
 *                    convection where N^2 < 0)
 *   length scale     1 / l^2 = 1 / (C_s h)^2 + 1 / (kappa (z + z0))^2  (Mason & Thomson 1992,
 *                    n = 2: l -> C_s h away from the ground, kappa z near it; z = height of the
 *                    cell centre above the solid or no-slip ground below; no ground: C_s h)
 *   eddy diffusivity K = nu_t / Pr_t
 *   momentum         du_i/dt = d_j (nu_t d_j u_i)   (the transposed part d_j (nu_t d_i u_j) =
 *                    d_i u_j d_j nu_t is left out, as usual for a cell-centred nu_t: it
 *                    vanishes for uniform nu_t in incompressible flow)
 *   scalars          dc/dt = d_j (K d_j c)
 *   wall stress      on the horizontal wind of the first fluid cells above a solid or no-slip
 *                    ground (Schumann 1975; Moeng 1984): tau = u*^2 along -u_h/|u_h|,
 *                    u* = kappa |u_h| / ln(z1 / z0), z1 = h/2, i.e. du_h/dt = -C_d |u_h| u_h / h,
 *                    C_d = (kappa / ln(z1 / z0))^2, taken implicitly (u_h / (1 + dt C_d |u_h| / h)).
 *
 * Discretisation: nu_t at cell centres (the off-diagonal gradients from cell-centred winds,
 * central differences; solids count as wind 0); gradient diffusion in conservative flux form on
 * each lattice, the coefficient of a link the mean of its two samples' values (a face's value
 * is the mean of its two cells). Links exist only between two free samples inside the domain:
 * no flux through solids, the ground (apart from the wall stress), the domain's faces or fixed
 * velocity faces, so the scalars' sum is conserved to round-off and a uniform field stays
 * bit-exact. Explicit, sub-stepped so that each sub-step's diffusion number is <= 1/6 (every
 * update a convex combination: no new extrema). With |S| dt <~ 2 CFL and l <= C_s h the number
 * is ~C_s^2 CFL, so one sub-step is the rule. Periodic axes are treated as closed ends.
 *
 * closure = SQ_SGS_TKE replaces nu_t by Deardorff's (1980) prognostic closure: K_m = C_k l
 * sqrt(e) for the wind, K_h = (1 + 2 l / h) K_m for the scalars, 2 K_m for e itself, from the
 * subgrid kinetic energy e whose sources (shear, buoyancy, dissipation) are grid_tke.c's. The
 * same |S|^2, N^2, diffusion and wall stress. */
#include <string.h>

#include "solvers/grid/grid_internal.h"

#define MOD "grid"

sq_grid_sgs_desc sq_grid_sgs_desc_resolve(const sq_grid_sgs_desc *in)
{
    sq_grid_sgs_desc d;
    memset(&d, 0, sizeof d);
    if (in) d = *in;
    if (d.smagorinsky_c == 0.0) d.smagorinsky_c = 0.18;
    if (d.prandtl_t == 0.0) d.prandtl_t = 0.74;
    if (d.kappa == 0.0) d.kappa = 0.4;
    if (!d.stratified) d.theta_idx = -1;
    if (d.tke_ck == 0.0) d.tke_ck = 0.10;
    if (d.tke_min_m2ps2 == 0.0) d.tke_min_m2ps2 = 1e-6;
    return d;
}

static sq_result check_desc(sq_grid *g, const sq_grid_sgs_desc *d)
{
    if (d->closure != SQ_SGS_SMAGORINSKY && d->closure != SQ_SGS_TKE)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "closure = %d; must be SQ_SGS_SMAGORINSKY (0) or SQ_SGS_TKE (1)",
                        (int)d->closure);
    if (d->closure == SQ_SGS_TKE) {
        if (d->tke_idx < 0 || d->tke_idx >= g->d.scalar_count ||
            (d->stratified && d->tke_idx == d->theta_idx))
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "tke_idx = %d; must be a scalar in 0..%d other than theta_idx (%d)",
                            d->tke_idx, g->d.scalar_count - 1, d->theta_idx);
        if (!(d->tke_ck > 0.0 && d->tke_ck <= 1.0))
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "tke_ck = %g; must be in (0, 1] (Deardorff 1980: 0.10)", d->tke_ck);
        if (!(d->tke_min_m2ps2 > 0.0 && d->tke_min_m2ps2 <= 1.0))
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "tke_min_m2ps2 = %g; the floor of e must be in (0, 1] m2/s2",
                            d->tke_min_m2ps2);
    }
    if (!(d->smagorinsky_c > 0.0 && d->smagorinsky_c <= 1.0))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "smagorinsky_c = %g; must be in (0, 1] (Lilly 1967: 0.18)", d->smagorinsky_c);
    if (!(d->prandtl_t >= 0.1 && d->prandtl_t <= 10.0))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "prandtl_t = %g (turbulent Prandtl number); must be in [0.1, 10] "
                        "(neutral: 0.74)", d->prandtl_t);
    if (!(d->kappa > 0.0 && d->kappa <= 2.0))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "kappa = %g; must be in (0, 2] (von Karman: 0.4)", d->kappa);
    if (!(d->roughness_m >= 0.0 && d->roughness_m < 0.5 * (double)g->h))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "roughness_m = %g; must be >= 0 (0 = no wall stress) and below half a "
                        "cell (%g m)", d->roughness_m, 0.5 * (double)g->h);
    if (d->stratified) {
        if (d->theta_idx < 0 || d->theta_idx >= g->d.scalar_count)
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "theta_idx = %d; must be in 0..%d (scalar_count = %d)", d->theta_idx,
                            g->d.scalar_count - 1, g->d.scalar_count);
        if (!(d->gravity_mps2 > 0.0 && isfinite(d->gravity_mps2)))
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "gravity_mps2 = %g; must be > 0 with a stratification scalar",
                            d->gravity_mps2);
    }
    return SQ_OK;
}

/* Cell-centred wind (uc, vc, wc in the cell layout; solids 0, ghosts zero-gradient). */
static void cell_winds(sq_grid *g, float *uc, float *vc, float *wc)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    const sq_field3 *U = &g->vel[0], *V = &g->vel[1], *W = &g->vel[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const float *u = sq_field3_at(U, 0, j, k), *v0 = sq_field3_at(V, 0, j, k),
                        *v1 = sq_field3_at(V, 0, j + 1, k), *w0 = sq_field3_at(W, 0, j, k),
                        *w1 = sq_field3_at(W, 0, j, k + 1);
            const ptrdiff_t c = sq__cidx(g, 0, j, k);
            for (int i = 0; i < nx; i++) {
                uc[c + i] = 0.5f * (u[i] + u[i + 1]);
                vc[c + i] = 0.5f * (v0[i] + v1[i]);
                wc[c + i] = 0.5f * (w0[i] + w1[i]);
            }
        }
    sq__grid_dist_batch_begin(g);
    sq__grid_fill_ghosts(g, uc + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    sq__grid_fill_ghosts(g, vc + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    sq__grid_fill_ghosts(g, wc + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    sq__grid_dist_batch_end(g);
}

/* Central difference of a cell-centred field at cell c along stride st (solids hold 0; at a
 * domain end the ghost copies the end cell: half the gradient there). */
static inline float dcell(const float *f, ptrdiff_t c, ptrdiff_t st, float ih2)
{
    return (f[c + st] - f[c - st]) * ih2;
}

/* |S|^2 = 2 S_ij S_ij and gfac (d theta/dz) / theta per fluid cell (cell layout; solids
 * untouched): N^2 / Pr_t with gfac = g / Pr_t (Smagorinsky-Lilly), N^2 with gfac = g (TKE);
 * 0 without a stratification scalar. uc, vc, wc: scratch for the cell winds. */
static void strain_and_stratification(sq_grid *g, const sq_grid_sgs_desc *d, float gfac,
                                      float *s2o, float *n2o, float *uc, float *vc, float *wc)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const float ih = 1.0f / g->h, ih2 = 0.5f / g->h;
    const float g_pr = d->stratified ? gfac : 0.0f;
    const sq_field3 *T = d->stratified ? &g->scalar[d->theta_idx] : NULL;
    const uint8_t *fl = g->flags;
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const sq_field3 *U = &g->vel[0], *V = &g->vel[1], *W = &g->vel[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    cell_winds(g, uc, vc, wc);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        for (int j = 0; j < ny; j++) {
            const float *u = sq_field3_at(U, 0, j, k), *v0 = sq_field3_at(V, 0, j, k),
                        *v1 = sq_field3_at(V, 0, j + 1, k), *w0 = sq_field3_at(W, 0, j, k),
                        *w1 = sq_field3_at(W, 0, j, k + 1);
            const float *th = T ? sq_field3_at(T, 0, j, k) : NULL;
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = sq__cidx(g, i, j, k);
                if (fl[c] & SQ__CF_SOLID) continue;
                /* the velocity gradient tensor */
                const float dudx = (u[i + 1] - u[i]) * ih, dvdy = (v1[i] - v0[i]) * ih,
                            dwdz = (w1[i] - w0[i]) * ih;
                const float dudy = dcell(uc, c, sy, ih2), dudz = dcell(uc, c, sz, ih2);
                const float dvdx = dcell(vc, c, 1, ih2), dvdz = dcell(vc, c, sz, ih2);
                const float dwdx = dcell(wc, c, 1, ih2), dwdy = dcell(wc, c, sy, ih2);
                const float sxy = dudy + dvdx, sxz = dudz + dwdx, syz = dvdz + dwdy;
                /* |S|^2 = 2 S_ij S_ij */
                s2o[c] = 2.0f * (dudx * dudx + dvdy * dvdy + dwdz * dwdz) + sxy * sxy +
                         sxz * sxz + syz * syz;
                /* N^2 (central; one-sided against a solid or a domain end). Differences below
                 * 1e-3 K per cell are the float theta's round-off (3e-5 K at 300 K), not
                 * stratification: counted as neutral, or a neutral column would convect. */
                float n2 = 0.0f;
                if (th) {
                    const bool dn = k > 0 && !(fl[c - sz] & SQ__CF_SOLID);
                    const bool up = k < nz - 1 && !(fl[c + sz] & SQ__CF_SOLID);
                    const float t0 = th[i];
                    const float dth = dn && up ? 0.5f * (th[i + sz] - th[i - sz])
                                      : up     ? th[i + sz] - t0
                                      : dn     ? t0 - th[i - sz]
                                               : 0.0f;
                    if ((dth > 1e-3f || dth < -1e-3f) && t0 > 0.0f) n2 = g_pr * dth * ih / t0;
                }
                n2o[c] = n2;
            }
        }
    }
}

/* Smagorinsky-Lilly nu_t per cell (cell layout, solids and ghosts 0) from |S|^2 and N^2/Pr_t;
 * returns the largest nu_t. */
static float sgs_viscosity(sq_grid *g, const sq_grid_sgs_desc *d, float *nu, const float *s2,
                           const float *n2)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const float h = g->h;
    const float ls = (float)d->smagorinsky_c * h, ils2 = 1.0f / (ls * ls);
    const float kappa = (float)d->kappa, z0 = (float)d->roughness_m;
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    memset(nu, 0, g->cell_count * sizeof *nu);
    double *pm = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        float m = 0.0f;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t c = sq__cidx(g, i, j, k);
                if (fl[c] & SQ__CF_SOLID) continue;
                /* the length: C_s h, damped towards kappa z at the ground */
                float il2 = ils2;
                if (g->below[c] > 0) {
                    const float lw = kappa * (((float)g->below[c] - 0.5f) * h + z0);
                    il2 += 1.0f / (lw * lw);
                }
                const float q = s2[c] - n2[c];
                const float v = q > 0.0f ? sqrtf(q) / il2 : 0.0f;
                nu[c] = v;
                m = v > m ? v : m;
            }
        pm[k] = (double)m;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pm[k] > m ? pm[k] : m;
    return (float)m;
}

/* The closure's coefficients of this step: nu (K_m; scratch 0) for the wind, kh for the
 * scalars other than e (Smagorinsky: kh = nu and the caller divides by Pr_t); with TKE also
 * e's sources over dt (dt 0: coefficients only). Returns the largest diffusion coefficient.
 * Uses scratch 0..3 and 7..10 (the cached trace is invalidated by the caller). */
static float closure_coefficients(sq_grid *g, const sq_grid_sgs_desc *d, float dt, float **kh_out)
{
    float *nu = g->scratch[0], *s2 = g->scratch[7], *n2 = g->scratch[8];
    const bool tke = d->closure == SQ_SGS_TKE;
    const float gfac = (float)(tke ? d->gravity_mps2 : d->gravity_mps2 / d->prandtl_t);
    strain_and_stratification(g, d, gfac, s2, n2, g->scratch[1], g->scratch[2], g->scratch[3]);
    const ptrdiff_t c0 = sq__cidx(g, 0, 0, 0);
    if (!tke) {
        *kh_out = nu;
        const float m = sgs_viscosity(g, d, nu, s2, n2);
        /* a decomposed grid: the neighbours' coefficients next to the slab (the domain's
         * ghosts stay 0) */
        sq__grid_dist_halo_lattice(g, nu + c0, g->sy, g->sz, SQ__L_CELL);
        return m;
    }
    float *l = g->scratch[9], *kh = g->scratch[10];
    const float kmax = sq__grid_tke_coefficients(g, d, n2, l, nu, kh);
    if (dt > 0.0f) sq__grid_tke_sources(g, d, s2, n2, l, nu, kh, dt);
    sq__grid_dist_batch_begin(g);
    sq__grid_dist_halo_lattice(g, nu + c0, g->sy, g->sz, SQ__L_CELL);
    sq__grid_dist_halo_lattice(g, kh + c0, g->sy, g->sz, SQ__L_CELL);
    sq__grid_dist_batch_end(g);
    *kh_out = kh;
    return kmax;
}

/* A sample lattice and its free samples: the cell lattice (scalars; solids are not free) or a
 * velocity face lattice (faces touching a solid or a wall/inflow ghost are fixed). */
typedef struct lattice {
    float *origin;
    ptrdiff_t sy, sz;
    int m[3];
    ptrdiff_t cell_off; /* cell below the face along its axis (0 for the cell lattice) */
    bool cells;
} lattice;

static inline bool sample_free(const sq_grid *g, const lattice *L, ptrdiff_t c)
{
    if (L->cells) return !(g->flags[c] & SQ__CF_SOLID);
    return !((g->flags[c] | g->flags[c - L->cell_off]) & SQ__CF_FIXED);
}

/* Link coefficients a = s (value_p + value_q) / 2 of the links from each sample to its +x,
 * +y, +z neighbour, value = nu (the cell's, or the mean of the face's two cells), s = dt /
 * (h^2 Pr) of one sub-step; 0 where a link does not exist. ax, ay, az: arrays in the lattice's
 * layout (base_count floats from base), pointers at the lattice origin. */
static void link_coefficients(sq_grid *g, const lattice *L, const float *nu, float s,
                              float *ax, float *ay, float *az, ptrdiff_t origin_off,
                              size_t base_count)
{
    memset(ax - origin_off, 0, base_count * sizeof *ax);
    memset(ay - origin_off, 0, base_count * sizeof *ay);
    memset(az - origin_off, 0, base_count * sizeof *az);
    const int mx = L->m[0], my = L->m[1], mz = L->m[2];
    const ptrdiff_t cs[3] = {1, g->sy, g->sz}, off = L->cell_off;
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    /* a decomposed grid: links across a slab face exist (lo: the ghost sample's link to
     * sample 0, hi: the last sample's to the ghost); a lattice normal to the face gets them
     * from the neighbours below instead (they need nu two cells away) */
    int lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    bool normal_split = false;
    for (int a = 0; a < 3; a++) {
        const bool ilo = sq__grid_dist_inner(g, 2 * a), ihi = sq__grid_dist_inner(g, 2 * a + 1);
        if ((ilo || ihi) && !L->cells && off == cs[a]) {
            normal_split = true;
            continue;
        }
        lo[a] = ilo ? -1 : 0;
        hi[a] = ihi ? 1 : 0;
    }
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = lo[2]; k < mz; k++)
        for (int j = lo[1]; j < my; j++)
            for (int i = lo[0]; i < mx; i++) {
                const ptrdiff_t p = (ptrdiff_t)i + j * L->sy + k * L->sz;
                const ptrdiff_t c = sq__cidx(g, i, j, k);
                if (!sample_free(g, L, c)) continue;
                const float vp = L->cells ? nu[c] : 0.5f * (nu[c] + nu[c - off]);
                const bool inside[3] = {i + 1 < mx + hi[0], j + 1 < my + hi[1], k + 1 < mz + hi[2]};
                float *a[3] = {ax, ay, az};
                for (int e = 0; e < 3; e++) {
                    if (!inside[e]) continue;
                    const ptrdiff_t cn = c + cs[e];
                    if (!sample_free(g, L, cn)) continue;
                    const float vq = L->cells ? nu[cn] : 0.5f * (nu[cn] + nu[cn - off]);
                    a[e][p] = 0.5f * s * (vp + vq);
                }
            }
    if (normal_split) {
        float *a[3] = {ax, ay, az};
        for (int e = 0; e < 3; e++)
            if (off == cs[e]) sq__grid_dist_face_links(g, a[e], L->sy, L->sz, e + 1);
    }
}

/* One explicit sub-step of dc/dt = div (a grad c) on lattice L with the link coefficients
 * (pointers at the lattice origin): fluxes in increments, so a uniform field is unchanged bit
 * for bit. old: a copy of the field (pointer at the origin). */
static void diffuse_step(sq_grid *g, const lattice *L, const float *ax, const float *ay,
                         const float *az, const float *old)
{
    float *f = L->origin;
    const ptrdiff_t sy = L->sy, sz = L->sz;
    const int mx = L->m[0], my = L->m[1], mz = L->m[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mz; k++)
        for (int j = 0; j < my; j++) {
            const ptrdiff_t r = j * sy + k * sz;
            for (int i = 0; i < mx; i++) {
                const ptrdiff_t p = r + i;
                const float c0 = old[p];
                const float flux = ax[p] * (old[p + 1] - c0) + ax[p - 1] * (old[p - 1] - c0) +
                                   ay[p] * (old[p + sy] - c0) + ay[p - sy] * (old[p - sy] - c0) +
                                   az[p] * (old[p + sz] - c0) + az[p - sz] * (old[p - sz] - c0);
                f[p] = c0 + flux;
            }
        }
}

/* Diffuses one field (base .. base + count) on lattice L: link coefficients, then nsub
 * sub-steps; ghosts refilled by the caller's rule. */
static void diffuse_field(sq_grid *g, const lattice *L, float *base, size_t count,
                          const float *nu, float s, int nsub, int ghost_L, int scalar)
{
    const ptrdiff_t oo = L->origin - base;
    float *ax = g->scratch[4] + oo, *ay = g->scratch[5] + oo, *az = g->scratch[6] + oo;
    float *old = g->scratch[1];
    link_coefficients(g, L, nu, s, ax, ay, az, oo, count);
    for (int n = 0; n < nsub; n++) {
        memcpy(old, base, count * sizeof *old);
        diffuse_step(g, L, ax, ay, az, old + oo);
        sq__grid_fill_ghosts(g, L->origin, L->sy, L->sz, ghost_L, scalar);
    }
}

/* Log-law wall stress on the horizontal wind of the first fluid layer above a solid or a
 * no-slip ground (implicit drag, see the header). */
void sq__grid_wall_stress(sq_grid *g, double kappa, double z0, float dt)
{
    const float h = g->h, z1 = 0.5f * h;
    const float cd = (float)pow(kappa / log((double)z1 / z0), 2.0);
    const bool ground_wall = g->d.boundary[SQ_FACE_ZMIN] == SQ_BOUNDARY_NO_SLIP;
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    float *scr = g->scratch[1];
    for (int c = 0; c < 2; c++) {
        sq_field3 *F = &g->vel[c];
        const sq_field3 *O = &g->vel[1 - c];
        /* the wind before the stress (the other component is read from it too) */
        memcpy(scr, O->base, O->count * sizeof *scr);
        const float *ob = scr + (O->origin - O->base);
        const ptrdiff_t off = c == 0 ? 1 : g->sy;
        const int mx = F->n.nx, my = F->n.ny, mz = F->n.nz;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < mz; k++)
            for (int j = 0; j < my; j++)
                for (int i = 0; i < mx; i++) {
                    const ptrdiff_t hi = sq__cidx(g, i, j, k), lo = hi - off;
                    if ((fl[hi] | fl[lo]) & SQ__CF_FIXED) continue;
                    /* on the ground: a cell of the face rests on a solid, or k = 0 over a
                     * no-slip domain bottom */
                    const bool on = k == 0 ? ground_wall
                                           : ((fl[hi - g->sz] | fl[lo - g->sz]) & SQ__CF_SOLID) != 0;
                    if (!on) continue;
                    /* the other horizontal component at this face: the mean of the 4 around */
                    const ptrdiff_t osy = O->sy, osz = O->sz;
                    const ptrdiff_t q = (ptrdiff_t)i + j * osy + k * osz;
                    const float o = c == 0 ? 0.25f * (ob[q - 1] + ob[q] + ob[q - 1 + osy] + ob[q + osy])
                                           : 0.25f * (ob[q - osy] + ob[q + 1 - osy] + ob[q] + ob[q + 1]);
                    float *u = sq_field3_at(F, i, j, k);
                    const float sp = sqrtf(*u * *u + o * o);
                    *u /= 1.0f + dt * cd * sp / h;
                }
    }
}

/* The stage: nu_t, then every velocity component and scalar, then the wall stress. */
sq_result sq_grid_diffuse_sgs(sq_grid *g, const sq_grid_sgs_desc *desc, double dt_s)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_diffuse_sgs: grid is NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "sq_grid_diffuse_sgs: dt = %g s; must be > 0", dt_s);
    const sq_grid_sgs_desc d = sq_grid_sgs_desc_resolve(desc);
    sq_result r = check_desc(g, &d);
    if (r != SQ_OK) return r;
    if (g->topology_dirty) {
        r = sq__grid_update_topology(g);
        if (r != SQ_OK) return r;
    }
    const double t0 = sq_time_now();
    sq__grid_enforce_velocity(g);
    const bool tke = d.closure == SQ_SGS_TKE;
    float *nu = g->scratch[0], *kh = NULL;
    /* Smagorinsky: nu_t; TKE: K_m, K_h, and e advanced by its sources */
    float numax = closure_coefficients(g, &d, (float)dt_s, &kh);
    if (g->halo) { /* a decomposed grid: every slab takes as many sub-steps */
        double m = (double)numax;
        sq__grid_dist_max(g, &m, 1);
        numax = (float)m;
    }
    g->trace_valid = false; /* scratch 4..10 (the cached trace) are used from here on */
    const float ih2 = 1.0f / (g->h * g->h);
    /* the largest diffusion number: Smagorinsky's scalars (K = nu_t / Pr_t) for Pr_t < 1; the
     * TKE closure's max(K_h, 2 K_m) */
    const double number = (double)numax * dt_s * (double)ih2 /
                          (!tke && d.prandtl_t < 1.0 ? d.prandtl_t : 1.0);
    const int nsub = number > 1.0 / 6.0 ? (int)ceil(6.0 * number) : 1;
    if (nsub > 1000)
        return sq__fail(g->ctx, SQ_ERR_UNSTABLE, MOD,
                        "subgrid diffusion number %g would need %d sub-steps (eddy viscosity "
                        "up to %g m2/s): the wind is out of range", number, nsub, (double)numax);
    g->stats.last_diffusion_number = number;
    g->stats.last_diffusion_implicit = false;
    const float s = (float)dt_s * ih2 / (float)nsub;
    if (numax > 0.0f) {
        for (int c = 0; c < 3; c++) {
            sq_field3 *F = &g->vel[c];
            const lattice L = {F->origin, F->sy, F->sz, {F->n.nx, F->n.ny, F->n.nz},
                               c == 0 ? 1 : c == 1 ? g->sy : g->sz, false};
            diffuse_field(g, &L, F->base, F->count, nu, s, nsub, c + 1, -1);
        }
        for (int sidx = 0; sidx < g->d.scalar_count; sidx++) {
            sq_field3 *F = &g->scalar[sidx];
            const lattice L = {F->origin, F->sy, F->sz, {F->n.nx, F->n.ny, F->n.nz}, 0, true};
            /* Smagorinsky: K = nu_t / Pr_t; TKE: K_h, and 2 K_m for e itself */
            const bool e = tke && sidx == d.tke_idx;
            const float *k = e ? nu : kh;
            const float sk = !tke ? s / (float)d.prandtl_t : e ? 2.0f * s : s;
            diffuse_field(g, &L, F->base, F->count, k, sk, nsub, SQ__L_CELL, sidx);
        }
    }
    if (d.roughness_m > 0.0) sq__grid_wall_stress(g, d.kappa, d.roughness_m, (float)dt_s);
    g->trace_valid = false; /* scratch 4..6 (the cached trace) were used */
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    g->stats.ms_diffuse += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}

sq_result sq_grid_sgs_viscosity(sq_grid *g, const sq_grid_sgs_desc *desc, float *nu_out)
{
    if (!g || !nu_out)
        return sq__fail(g ? g->ctx : NULL, SQ_ERR_INVALID_ARG, MOD,
                        "sq_grid_sgs_viscosity: grid or output is NULL");
    const sq_grid_sgs_desc d = sq_grid_sgs_desc_resolve(desc);
    sq_result r = check_desc(g, &d);
    if (r != SQ_OK) return r;
    if (g->topology_dirty) {
        r = sq__grid_update_topology(g);
        if (r != SQ_OK) return r;
    }
    sq__grid_enforce_velocity(g);
    float *nu = g->scratch[0], *kh = NULL;
    closure_coefficients(g, &d, 0.0f, &kh); /* TKE: K_m of the current e (unchanged) */
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                nu_out[((size_t)k * ny + j) * nx + i] = nu[sq__cidx(g, i, j, k)];
    g->trace_valid = false;
    return SQ_OK;
}
