/* grid_forces.c — body forces on the MAC grid (SPEC §1.4 eq. 2.6, u <- u + dt F):
 *   uniform and cell-centred accelerations, averaged to the faces;
 *   Boussinesq buoyancy a_z = beta g (T - Tref(z)) / Tref(z) (SPEC §1.10, the recommended
 *     replacement of S0's thermophoresis);
 *   vorticity confinement f = eps h (N x omega), N = grad|omega| / |grad|omega|| [Fedkiw,
 *     Stam, Jensen 2001] and its helicity-adaptive variant (SPEC §1.4 eq. 2.15 with the
 *     dimensional fix): f = eps h (|u.omega| / (|u||omega| + eps0)) (N x omega), clamped so
 *     that |f| dt^2 <= confinement_max_cells * h. */
#include <string.h>

#include "solvers/grid/grid_internal.h"

#define MOD "grid"
#define CROW 128 /* row chunk of the confinement passes */

static sq_result check(sq_grid *g, double dt, const char *what)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "%s: grid is NULL", what);
    if (!(dt > 0.0) || !isfinite(dt))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "%s: dt = %g s; must be > 0", what, dt);
    if (g->topology_dirty) return sq__grid_update_topology(g);
    return SQ_OK;
}

static ptrdiff_t cell_step(const sq_grid *g, int c) { return c == 0 ? 1 : c == 1 ? g->sy : g->sz; }

sq_result sq_grid_add_acceleration(sq_grid *g, double ax, double ay, double az, double dt_s)
{
    sq_result r = check(g, dt_s, "sq_grid_add_acceleration");
    if (r != SQ_OK) return r;
    if (!isfinite(ax) || !isfinite(ay) || !isfinite(az))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "(ax_mps2, ay_mps2, az_mps2) = (%g, %g, %g); must be finite", ax, ay, az);
    double t0 = sq_time_now();
    const float dv[3] = {(float)(ax * dt_s), (float)(ay * dt_s), (float)(az * dt_s)};
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    for (int c = 0; c < 3; c++) {
        if (dv[c] == 0.0f) continue;
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = cell_step(g, c);
        const float d = dv[c];
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++) {
                float *u = sq_field3_at(f, 0, j, k);
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < f->n.nx; i++)
                    u[i] = sq__fsel(((fl[r0 + i - off] | fl[r0 + i]) & SQ__CF_FIXED) != 0, u[i],
                                    u[i] + d);
            }
    }
    sq__grid_enforce_velocity(g);
    g->vel_version++;
    g->stats.ms_forces += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}

static sq_result check_view(sq_grid *g, const sq_field_view *v, const char *name)
{
    if (!v) return SQ_OK;
    if (!v->data || v->n.nx != g->n[0] || v->n.ny != g->n[1] || v->n.nz != g->n[2])
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s view is %dx%dx%d%s; must be %dx%dx%d (the grid's cells)", name,
                        v->n.nx, v->n.ny, v->n.nz, v->data ? "" : " with NULL data", g->n[0],
                        g->n[1], g->n[2]);
    return SQ_OK;
}

/* Face value of a cell-centred quantity: mean of the two cells, or the one fluid cell (int32
 * masks, see sq__fselm). */
static inline float face_mean(const uint8_t *fl, ptrdiff_t lo, ptrdiff_t hi, float a, float b)
{
    const int32_t ua = -(int32_t)((fl[lo] & (SQ__CF_SOLID | SQ__CF_WALL | SQ__CF_DIRICHLET)) == 0);
    const int32_t ub = -(int32_t)((fl[hi] & (SQ__CF_SOLID | SQ__CF_WALL | SQ__CF_DIRICHLET)) == 0);
    return sq__fselm(ua & ub, 0.5f * (a + b), sq__fselm(ua, a, sq__fselm(ub, b, 0.0f)));
}

/* u[i] += dt * (face value of va/vb) on the free faces of one row: fo/fh the flags of the
 * faces' low/high cells, va[i sx]/vb[i sx] the cell values below/above. */
static void accel_row(float *restrict u, const uint8_t *restrict fo, const uint8_t *restrict fh,
                      const float *restrict va, const float *restrict vb, ptrdiff_t sx, int n,
                      float dt)
{
    for (int i = 0; i < n; i++) {
        const int32_t fixed = -(int32_t)(((fo[i] | fh[i]) & SQ__CF_FIXED) != 0);
        u[i] = sq__fselm(fixed, u[i], u[i] + dt * face_mean(fo, i, i + (fh - fo), va[i * sx], vb[i * sx]));
    }
}

sq_result sq_grid_add_acceleration_field(sq_grid *g, const sq_field_view *ax,
                                         const sq_field_view *ay, const sq_field_view *az,
                                         double dt_s)
{
    sq_result r = check(g, dt_s, "sq_grid_add_acceleration_field");
    if (r != SQ_OK) return r;
    const sq_field_view *a[3] = {ax, ay, az};
    static const char *names[3] = {"ax", "ay", "az"};
    for (int c = 0; c < 3; c++)
        if ((r = check_view(g, a[c], names[c])) != SQ_OK) return r;
    double t0 = sq_time_now();
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const float dt = (float)dt_s;
    for (int c = 0; c < 3; c++) {
        if (!a[c]) continue;
        const sq_field_view *v = a[c];
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = cell_step(g, c);
        const int nc = g->n[c];
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++) {
                float *u = sq_field3_at(f, 0, j, k);
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                /* cells below/above the faces along c: periodic neighbours wrap, domain faces
                 * use the inner cell */
                int x[3] = {0, j, k}, xl[3] = {-1, j, k};
                if (c > 0) {
                    xl[c]--;
                    if (xl[c] < 0) xl[c] = g->periodic[c] ? nc - 1 : 0;
                    if (x[c] >= nc) x[c] = g->periodic[c] ? 0 : nc - 1;
                }
                const float *ra = v->data + (ptrdiff_t)xl[1] * v->sy + (ptrdiff_t)xl[2] * v->sz;
                const float *rb = v->data + (ptrdiff_t)x[1] * v->sy + (ptrdiff_t)x[2] * v->sz;
                const ptrdiff_t sx = v->sx;
                const int mx = f->n.nx;
                const uint8_t *fh = fl + r0, *fo = fh - off;
                if (c > 0) {
                    accel_row(u, fo, fh, ra, rb, sx, mx, dt);
                } else { /* along the row: interior faces 1..nc-1, then the two end faces */
                    accel_row(u + 1, fo + 1, fh + 1, ra, rb + sx, sx, nc - 1, dt);
                    const int ends[2] = {0, nc};
                    for (int e2 = 0; e2 < 2; e2++) {
                        const int i = ends[e2];
                        const int ia = i - 1 < 0 ? (g->periodic[0] ? nc - 1 : 0) : i - 1;
                        const int ib = i >= nc ? (g->periodic[0] ? 0 : nc - 1) : i;
                        const float va = ra[(ptrdiff_t)ia * sx], vb = rb[(ptrdiff_t)ib * sx];
                        if ((fo[i] | fh[i]) & SQ__CF_FIXED) continue;
                        u[i] += dt * face_mean(fl, r0 + i - off, r0 + i, va, vb);
                    }
                }
            }
    }
    sq__grid_enforce_velocity(g);
    g->vel_version++;
    g->stats.ms_forces += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}

sq_result sq_grid_add_buoyancy(sq_grid *g, int tidx, const float *tref_k, double beta,
                               double gravity_mps2, double dt_s)
{
    sq_result r = check(g, dt_s, "sq_grid_add_buoyancy");
    if (r != SQ_OK) return r;
    if (tidx < 0 || tidx >= g->d.scalar_count)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "temperature_idx = %d; must be in 0..%d (scalar_count = %d)", tidx,
                        g->d.scalar_count - 1, g->d.scalar_count);
    if (!isfinite(beta) || !isfinite(gravity_mps2))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "buoyancy beta = %g, gravity_mps2 = %g; both must be finite", beta,
                        gravity_mps2);
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const sq_field3 *T = &g->scalar[tidx];
    const uint8_t *fl = g->flags;
    double t0 = sq_time_now();
    /* reference temperature per level, kept in the plane-sum slots 2 (1/Tref) and 3 (Tref):
     * the mean over the level's fluid cells (per level, so independent of the thread count) */
    double *tr = g->plane_sum;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    if (tref_k) {
        for (int k = 0; k < nz; k++) tr[4 * k + 3] = (double)tref_k[k];
    } else {
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < nz; k++) {
            double sum = 0.0, cnt = 0.0;
            for (int j = 0; j < ny; j++) {
                const uint8_t *fr = fl + sq__cidx(g, 0, j, k);
                const float *tr_ = sq_field3_at(T, 0, j, k);
                double p[8] = {0, 0, 0, 0, 0, 0, 0, 0};
                int32_t n = 0;
                int i = 0;
                for (; i + 8 <= nx; i += 8)
                    for (int l = 0; l < 8; l++) {
                        const int32_t fluid = -(int32_t)((fr[i + l] & SQ__CF_SOLID) == 0);
                        p[l] += (double)sq__fselm(fluid, tr_[i + l], 0.0f);
                        n -= fluid;
                    }
                for (; i < nx; i++) {
                    const int32_t fluid = -(int32_t)((fr[i] & SQ__CF_SOLID) == 0);
                    p[0] += (double)sq__fselm(fluid, tr_[i], 0.0f);
                    n -= fluid;
                }
                sum += ((p[0] + p[4]) + (p[1] + p[5])) + ((p[2] + p[6]) + (p[3] + p[7]));
                cnt += (double)n;
            }
            tr[4 * k] = sum;
            tr[4 * k + 1] = cnt;
        }
        sq__grid_dist_sum(g, tr, 4 * nz); /* a decomposed grid: the whole level's mean */
        for (int k = 0; k < nz; k++) {
            const double sum = tr[4 * k], cnt = tr[4 * k + 1];
            tr[4 * k + 3] = cnt > 0.0 ? sum / cnt : 1.0;
        }
    }
    for (int k = 0; k < nz; k++) {
        const double ref = tr[4 * k + 3];
        if (!(ref > 0.0) || !isfinite(ref)) {
            memset(g->plane_sum, 0, ((size_t)nz + 2) * 4 * sizeof(double));
            return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "buoyancy reference temperature at level k = %d is %g K; must be > 0 "
                            "(absolute temperature, SPEC §1.6)",
                            k, ref);
        }
        tr[4 * k + 2] = 1.0 / ref;
    }
    const float bg = (float)(beta * gravity_mps2 * dt_s);
    sq_field3 *W = &g->vel[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k <= nz; k++) {
        const int kl = k - 1 < 0 ? (g->periodic[2] ? nz - 1 : 0) : k - 1;
        const int kh = k >= nz ? (g->periodic[2] ? 0 : nz - 1) : k;
        const float il = (float)tr[4 * kl + 2], rl = (float)tr[4 * kl + 3];
        const float ihh = (float)tr[4 * kh + 2], rh = (float)tr[4 * kh + 3];
        for (int j = 0; j < ny; j++) {
            float *w = sq_field3_at(W, 0, j, k);
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            const float *tl = sq_field3_at(T, 0, j, kl), *th = sq_field3_at(T, 0, j, kh);
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t hi = r0 + i, lo = hi - g->sz;
                const bool fixed = ((fl[lo] | fl[hi]) & SQ__CF_FIXED) != 0;
                const float bl = (tl[i] - rl) * il, bh = (th[i] - rh) * ihh;
                w[i] = sq__fsel(fixed, w[i], w[i] + bg * face_mean(fl, lo, hi, bl, bh));
            }
        }
    }
    memset(g->plane_sum, 0, ((size_t)nz + 2) * 4 * sizeof(double));
    sq__grid_enforce_velocity(g);
    g->vel_version++;
    g->stats.ms_forces += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}

/* ---- vorticity confinement ------------------------------------------------------------------ */
/* One row chunk of confinement pass 1: omega (w*) and |omega| (m) of n cells from the cell
 * velocities u* (pointers at the chunk's first cell; the arrays are padded). Solid cells get 0.
 * Restrict parameters (and square roots as vector operations) let the loop vectorise. */
static void vorticity_row(const uint8_t *restrict fl, const float *restrict ux,
                          const float *restrict uy, const float *restrict uz, float *restrict wx,
                          float *restrict wy, float *restrict wz, float *restrict m, int n,
                          ptrdiff_t sy, ptrdiff_t sz, float i2h)
{
    for (int q = 0; q < n; q++) {
        const bool solid = (fl[q] & SQ__CF_SOLID) != 0;
        const float ox = (uz[q + sy] - uz[q - sy] - uy[q + sz] + uy[q - sz]) * i2h;
        const float oy = (ux[q + sz] - ux[q - sz] - uz[q + 1] + uz[q - 1]) * i2h;
        const float oz = (uy[q + 1] - uy[q - 1] - ux[q + sy] + ux[q - sy]) * i2h;
        wx[q] = sq__fsel(solid, 0.0f, ox);
        wy[q] = sq__fsel(solid, 0.0f, oy);
        wz[q] = sq__fsel(solid, 0.0f, oz);
        m[q] = sq__fsel(solid, 0.0f, ox * ox + oy * oy + oz * oz);
    }
    sq__sqrt_row(m, n);
}

typedef struct confine_par {
    float e, fmax, eps0, i2h;
    bool helicity;
} confine_par;

/* One row chunk of confinement pass 2: f = eps h (N x omega) [* relative helicity], clamped to
 * fmax, written over omega (solid cells keep 0). */
static void confine_row(const confine_par *p, const uint8_t *restrict fl,
                        const float *restrict ux, const float *restrict uy,
                        const float *restrict uz, const float *restrict wm, float *restrict wx,
                        float *restrict wy, float *restrict wz, int n, ptrdiff_t sy,
                        ptrdiff_t sz)
{
    float en[CROW], un[CROW], fn[CROW];
    const float i2h = p->i2h, e = p->e, fmax = p->fmax, eps0 = p->eps0;
    for (int q = 0; q < n; q++) {
        const float ex = (wm[q + 1] - wm[q - 1]) * i2h;
        const float ey = (wm[q + sy] - wm[q - sy]) * i2h;
        const float ez = (wm[q + sz] - wm[q - sz]) * i2h;
        en[q] = ex * ex + ey * ey + ez * ez;
        un[q] = ux[q] * ux[q] + uy[q] * uy[q] + uz[q] * uz[q];
    }
    sq__sqrt_row(en, n);
    sq__sqrt_row(un, n);
    for (int q = 0; q < n; q++) {
        const float ex = (wm[q + 1] - wm[q - 1]) * i2h;
        const float ey = (wm[q + sy] - wm[q - sy]) * i2h;
        const float ez = (wm[q + sz] - wm[q - sz]) * i2h;
        const float inv = 1.0f / (en[q] + 1e-10f);
        const float Nx = ex * inv, Ny = ey * inv, Nz = ez * inv;
        const float ox = wx[q], oy = wy[q], oz = wz[q];
        /* relative helicity (1 for plain confinement) */
        const float hel = fabsf(ux[q] * ox + uy[q] * oy + uz[q] * oz) / (un[q] * wm[q] + eps0);
        const float hw = sq__fsel(p->helicity, hel, 1.0f);
        const float fx = e * (Ny * oz - Nz * oy) * hw;
        const float fy = e * (Nz * ox - Nx * oz) * hw;
        const float fz = e * (Nx * oy - Ny * ox) * hw;
        wx[q] = fx; /* provisional: clamped below */
        wy[q] = fy;
        wz[q] = fz;
        fn[q] = fx * fx + fy * fy + fz * fz;
    }
    sq__sqrt_row(fn, n);
    for (int q = 0; q < n; q++) {
        const bool solid = (fl[q] & SQ__CF_SOLID) != 0;
        /* |f| <= fmax: scale min(1, fmax / |f|) (no division by zero) */
        const float sc = sq__fsel(fn[q] > fmax, fmax / (fn[q] + (float)(fn[q] == 0.0f)), 1.0f);
        wx[q] = sq__fsel(solid, 0.0f, wx[q] * sc);
        wy[q] = sq__fsel(solid, 0.0f, wy[q] * sc);
        wz[q] = sq__fsel(solid, 0.0f, wz[q] * sc);
    }
}

sq_result sq_grid_confine_vorticity(sq_grid *g, double eps, bool helicity_adaptive, double dt_s)
{
    sq_result r = check(g, dt_s, "sq_grid_confine_vorticity");
    if (r != SQ_OK) return r;
    if (!(eps >= 0.0) || !isfinite(eps))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "confinement eps = %g; must be >= 0 (0 turns it off)", eps);
    if (eps == 0.0) return SQ_OK;
    double t0 = sq_time_now();
    sq__grid_enforce_velocity(g);
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const float h = g->h, i2h = 0.5f / g->h;
    const uint8_t *fl = g->flags;
    const ptrdiff_t sy = g->sy, sz = g->sz;
    float *wx = g->scratch[0], *wy = g->scratch[1], *wz = g->scratch[2], *wm = g->scratch[3];
    /* cell-centred velocity (padded, ghosts included) in the displacement-cache arrays */
    g->trace_valid = false;
    float *uc[3] = {g->scratch[SQ__S_DISP], g->scratch[SQ__S_DISP + 1],
                    g->scratch[SQ__S_DISP + 2]};
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    for (int c = 0; c < 3; c++) {
        const sq_field3 *f = &g->vel[c];
        const ptrdiff_t st = c == 0 ? 1 : c == 1 ? f->sy : f->sz;
        float *o = uc[c];
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = -1; k <= nz; k++)
            for (int j = -1; j <= ny; j++) {
                const float *p = sq_field3_at(f, 0, j, k);
                float *q = o + sq__cidx(g, 0, j, k);
                for (int i = -1; i <= nx; i++) q[i] = 0.5f * (p[i] + p[i + st]);
            }
    }
    const float *ux = uc[0], *uy = uc[1], *uz = uc[2];
    /* pass 1: omega and |omega| at cell centres (central differences of cell velocities) */
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            for (int i0 = 0; i0 < nx; i0 += CROW) {
                const int n = nx - i0 < CROW ? nx - i0 : CROW;
                vorticity_row(fl + r0 + i0, ux + r0 + i0, uy + r0 + i0, uz + r0 + i0,
                              wx + r0 + i0, wy + r0 + i0, wz + r0 + i0, wm + r0 + i0, n, sy, sz,
                              i2h);
            }
        }
    sq__grid_fill_ghosts(g, wm + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    /* pass 2: f = eps h (N x omega) [* relative helicity], clamped; written over omega */
    const float dt = (float)dt_s;
    confine_par cp;
    cp.e = (float)eps * h;
    cp.fmax = (float)g->d.confinement_max_cells * h / (dt * dt);
    cp.eps0 = 1e-6f; /* m/s^2: keeps the relative helicity finite at rest */
    cp.i2h = i2h;
    cp.helicity = helicity_adaptive;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
            for (int i0 = 0; i0 < nx; i0 += CROW) {
                const int n = nx - i0 < CROW ? nx - i0 : CROW;
                confine_row(&cp, fl + r0 + i0, ux + r0 + i0, uy + r0 + i0, uz + r0 + i0,
                            wm + r0 + i0, wx + r0 + i0, wy + r0 + i0, wz + r0 + i0, n, sy, sz);
            }
        }
    float *fc[3] = {wx, wy, wz};
    sq__grid_dist_batch_begin(g);
    for (int c = 0; c < 3; c++)
        sq__grid_fill_ghosts(g, fc[c] + sq__cidx(g, 0, 0, 0), g->sy, g->sz, SQ__L_CELL, -1);
    sq__grid_dist_batch_end(g);
    /* pass 3: faces get the mean of their cells' forces */
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = cell_step(g, c);
        const float *F = fc[c];
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < f->n.nz; k++)
            for (int j = 0; j < f->n.ny; j++) {
                float *u = sq_field3_at(f, 0, j, k);
                const ptrdiff_t r0 = sq__cidx(g, 0, j, k);
                for (int i = 0; i < f->n.nx; i++) {
                    const ptrdiff_t hi = r0 + i, lo = hi - off;
                    const bool fixed = ((fl[lo] | fl[hi]) & SQ__CF_FIXED) != 0;
                    const bool sa = (fl[lo] & SQ__CF_SOLID) != 0, sb = (fl[hi] & SQ__CF_SOLID) != 0;
                    const float v = sq__fsel(sa, F[hi], sq__fsel(sb, F[lo], 0.5f * (F[lo] + F[hi])));
                    u[i] = sq__fsel(fixed, u[i], u[i] + dt * v);
                }
            }
    }
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    g->stats.ms_confine += (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}
