/* grid_tke.c — the sources of the subgrid kinetic energy e (m^2/s^2) of Deardorff's 1.5-order
 * closure (Deardorff 1980, Boundary-Layer Meteorol. 18, 495-527; Moeng 1984, J. Atmos. Sci. 41,
 * 2052-2062; the same closure is WRF's km_opt = 2, Skamarock et al. 2019, NCAR/TN-556+STR,
 * §4.2.3). e is a scalar of the grid, carried by the caller's scalar advection; its diffusion
 * (2 K_m) and the diffusion of the wind (K_m) and of the other scalars (K_h) are grid_sgs.c's.
 * One function per term of
 *
 *   de/dt = K_m |S|^2  -  K_h N^2  -  C_eps e^(3/2) / l   (+ advection, + div (2 K_m grad e))
 *           shear         buoyancy    dissipation
 *
 *   length           l = min(h, 0.76 sqrt(e) / N) where N^2 > 0, else h  (Deardorff 1980 eq. 10;
 *                    at least 1e-3 h as in WRF, so that l > 0)
 *   coefficients     K_m = C_k l sqrt(e)  (C_k = 0.10, Deardorff 1980, Moeng 1984)
 *                    K_h = (1 + 2 l / h) K_m  (Deardorff 1980 eq. 9: Pr_t = 1/3 in neutral air)
 *   dissipation      C_eps = 0.19 + 0.51 l / h  (Deardorff 1980 eq. 11; Moeng 1984)
 *
 * The coefficients come from e at the start of the step (the diffusion uses the same ones).
 * Shear and buoyancy are explicit; the dissipation, with l and C_eps frozen over the step, is
 * integrated exactly: d(e^(-1/2))/dt = C_eps / (2 l), so e <- e / (1 + C_eps dt sqrt(e) / (2 l))^2
 * (never negative, exact in decaying turbulence at rest). e is floored at tke_min before and
 * after the sources (a stable buoyancy sink can overshoot 0 in one explicit step); the
 * coefficients read max(e, tke_min).
 * Kernels over the fluid cells of the padded cell lattice; e shares that layout. */
#include "solvers/grid/grid_internal.h"

#define TKE_LENGTH_STABLE 0.76f  /* l = 0.76 sqrt(e) / N (Deardorff 1980) */
#define TKE_LENGTH_MIN 1e-3f     /* l >= 1e-3 h (WRF) */
#define TKE_CEPS_0 0.19f         /* C_eps = 0.19 + 0.51 l / h (Deardorff 1980; Moeng 1984) */
#define TKE_CEPS_1 0.51f

/* Runs body(c) over the fluid cells c of the padded cell lattice (k split across threads). */
#define FOR_FLUID_CELLS(g, body)                                                                \
    do {                                                                                        \
        const int nx_ = (g)->n[0], ny_ = (g)->n[1], nz_ = (g)->n[2];                            \
        const uint8_t *fl_ = (g)->flags;                                                        \
        const int nt_ = sq_context_threads((g)->ctx);                                           \
        (void)nt_;                                                                              \
        SQ_OMP(omp parallel for schedule(static) num_threads(nt_))                              \
        for (int k_ = 0; k_ < nz_; k_++)                                                        \
            for (int j_ = 0; j_ < ny_; j_++) {                                                  \
                const ptrdiff_t c0_ = sq__cidx((g), 0, j_, k_);                                 \
                for (int i_ = 0; i_ < nx_; i_++) {                                              \
                    const ptrdiff_t c = c0_ + i_;                                               \
                    if (fl_[c] & SQ__CF_SOLID) continue;                                        \
                    body;                                                                       \
                }                                                                               \
            }                                                                                   \
    } while (0)

static void tke_floor(sq_grid *g, float *e, float emin)
{
    FOR_FLUID_CELLS(g, e[c] = e[c] > emin ? e[c] : emin);
}

/* l = min(h, 0.76 sqrt(e) / N) in stable air (N^2 > 0), h otherwise; at least 1e-3 h (e read
 * as max(e, emin)). */
static void tke_length(sq_grid *g, const float *e, float emin, const float *n2, float *l)
{
    const float h = g->h, lmin = TKE_LENGTH_MIN * h;
    FOR_FLUID_CELLS(g, {
        float v = h;
        if (n2[c] > 0.0f) {
            const float ec = e[c] > emin ? e[c] : emin;
            const float ls = TKE_LENGTH_STABLE * sqrtf(ec / n2[c]);
            v = ls < h ? ls : h;
        }
        l[c] = v > lmin ? v : lmin;
    });
}

/* K_m = C_k l sqrt(e), K_h = (1 + 2 l / h) K_m; returns max(K_h, 2 K_m) (the diffusion's
 * largest coefficient). Solids and ghosts 0. */
static float tke_coefficients(sq_grid *g, float ck, const float *e, float emin, const float *l,
                              float *km, float *kh)
{
    memset(km, 0, g->cell_count * sizeof *km);
    memset(kh, 0, g->cell_count * sizeof *kh);
    const float ih = 1.0f / g->h;
    double *pm = g->plane_sum;
    const int nz = g->n[2];
    for (int k = 0; k < nz; k++) pm[k] = 0.0;
    FOR_FLUID_CELLS(g, {
        const float m = ck * l[c] * sqrtf(e[c] > emin ? e[c] : emin);
        km[c] = m;
        kh[c] = (1.0f + 2.0f * l[c] * ih) * m;
        const float big = kh[c] > 2.0f * m ? kh[c] : 2.0f * m;
        if ((double)big > pm[k_]) pm[k_] = (double)big;
    });
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pm[k] > m ? pm[k] : m;
    return (float)m;
}

/* Shear production: e += dt K_m |S|^2. */
static void tke_shear_production(sq_grid *g, float *e, const float *km, const float *s2, float dt)
{
    FOR_FLUID_CELLS(g, e[c] += dt * km[c] * s2[c]);
}

/* Buoyancy production (N^2 < 0) or destruction (N^2 > 0): e -= dt K_h N^2. */
static void tke_buoyancy(sq_grid *g, float *e, const float *kh, const float *n2, float dt)
{
    FOR_FLUID_CELLS(g, e[c] -= dt * kh[c] * n2[c]);
}

/* Dissipation de/dt = -C_eps e^(3/2) / l, C_eps = 0.19 + 0.51 l / h, exactly over dt. */
static void tke_dissipation(sq_grid *g, float *e, const float *l, float dt)
{
    const float ih = 1.0f / g->h;
    FOR_FLUID_CELLS(g, {
        const float ceps = TKE_CEPS_0 + TKE_CEPS_1 * l[c] * ih;
        const float q = 1.0f + 0.5f * ceps * dt * sqrtf(e[c]) / l[c];
        e[c] /= q * q;
    });
}

float sq__grid_tke_coefficients(sq_grid *g, const sq_grid_sgs_desc *d, const float *n2, float *l,
                                float *km, float *kh)
{
    const float *e = g->scalar[d->tke_idx].base, emin = (float)d->tke_min_m2ps2;
    tke_length(g, e, emin, n2, l);
    return tke_coefficients(g, (float)d->tke_ck, e, emin, l, km, kh);
}

void sq__grid_tke_sources(sq_grid *g, const sq_grid_sgs_desc *d, const float *s2, const float *n2,
                          const float *l, const float *km, const float *kh, float dt)
{
    sq_field3 *E = &g->scalar[d->tke_idx];
    float *e = E->base;
    tke_floor(g, e, (float)d->tke_min_m2ps2);
    tke_shear_production(g, e, km, s2, dt); /* + K_m |S|^2 */
    tke_buoyancy(g, e, kh, n2, dt);         /* - K_h N^2 */
    tke_floor(g, e, (float)d->tke_min_m2ps2);
    tke_dissipation(g, e, l, dt);           /* - C_eps e^(3/2) / l */
    tke_floor(g, e, (float)d->tke_min_m2ps2);
    sq__grid_fill_ghosts(g, E->origin, E->sy, E->sz, SQ__L_CELL, d->tke_idx);
}
