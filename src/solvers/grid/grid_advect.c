/* grid_advect.c — advection on the MAC grid (SPEC §1.4, eq. 2.10 and 2.11):
 *   semi-Lagrangian  q(x, t+dt) = q(x - u dt, t), trilinear, RK2 (midpoint) back-trace;
 *   MacCormack [Selle, Fedkiw, Kim, Liu, Rossignac 2008]:
 *       q^ = A(q),  q_ = A^R(q^),  q' = q^ + (q - q_)/2,
 *     with the limiter: if q' leaves [min, max] of the 8 values q^ interpolated from, q' is
 *     reverted to q^ (SQ_LIMITER_REVERT) or clamped to that range (SQ_LIMITER_CLAMP).
 * Traces. The RK2 displacements (backward, and forward for the reverse step) are computed once
 * per velocity field at every cell centre, ghost cells included, from a cell-centred copy of
 * the velocity (each component the mean of the cell's two faces), and cached: every scalar and
 * the next velocity advection reuse them while the velocity, dt and drift are unchanged. A face
 * sample takes the mean of its two cells' displacements, which is exact for linear velocity
 * fields (the RK2 displacement is then linear in x), so face traces stay second order. */
#include <string.h>

#include "solvers/grid/grid_internal.h"

typedef float v4f __attribute__((vector_size(16)));

/* A lattice to sample: padded array, strides, interior sample counts, position offsets. */
typedef struct lat {
    const float *o;
    ptrdiff_t sy, sz;
    int m[3];
    float off[3];
    int period[3]; /* cells per period on periodic axes, else 0 */
} lat;

static lat make_lat(const sq_grid *g, const float *o, ptrdiff_t sy, ptrdiff_t sz, int L)
{
    lat l;
    l.o = o;
    l.sy = sy;
    l.sz = sz;
    for (int a = 0; a < 3; a++) {
        l.m[a] = g->n[a] + (L - 1 == a ? 1 : 0);
        l.off[a] = sq__lattice_off(L, a);
        l.period[a] = g->periodic[a] ? g->n[a] : 0;
    }
    return l;
}

/* Lower-corner index and fraction of coordinate t (lattice units) along one axis: wrapped on
 * periodic axes, else clamped into the ghost layer [-1, m]. */
static inline int axis_locate(float t, int m, int period, float *f)
{
    if (period) {
        const float P = (float)period;
        float q = t / P + 4.0f; /* traces never go 4 periods back */
        q = q < 0.0f ? 0.0f : q;
        t -= P * (float)((int)q - 4);
        if (t >= P) t -= P;
        if (t < 0.0f) t = 0.0f;
    } else {
        t = t < -1.0f ? -1.0f : (t > (float)m ? (float)m : t);
    }
    int i = (int)(t + 1.0f) - 1; /* floor for t >= -1 */
    if (i > m - 1) i = m - 1;
    *f = t - (float)i;
    return i;
}

/* Locates a point (cell units) on a lattice: offset of the lower corner and fractions. */
static inline ptrdiff_t locate(const lat *l, float X, float Y, float Z, float f[3])
{
    const int i = axis_locate(X - l->off[0], l->m[0], l->period[0], &f[0]);
    const int j = axis_locate(Y - l->off[1], l->m[1], l->period[1], &f[1]);
    const int k = axis_locate(Z - l->off[2], l->m[2], l->period[2], &f[2]);
    return (ptrdiff_t)i + (ptrdiff_t)j * l->sy + (ptrdiff_t)k * l->sz;
}

static inline float trilerp(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float fx,
                            float fy, float fz)
{
    const float *q = o + b;
    float c00 = q[0] + fx * (q[1] - q[0]);
    float c10 = q[sy] + fx * (q[sy + 1] - q[sy]);
    float c01 = q[sz] + fx * (q[sz + 1] - q[sz]);
    float c11 = q[sy + sz] + fx * (q[sy + sz + 1] - q[sy + sz]);
    float c0 = c00 + fy * (c10 - c00);
    float c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

static inline float mn2(float a, float b) { return a < b ? a : b; }
static inline float mx2(float a, float b) { return a > b ? a : b; }

/* trilinear sample and the range of its 8 source values */
static inline float trilerp_range(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz,
                                  float fx, float fy, float fz, float *mn, float *mx)
{
    const float *q = o + b;
    const float v0 = q[0], v1 = q[1], v2 = q[sy], v3 = q[sy + 1], v4 = q[sz], v5 = q[sz + 1],
                v6 = q[sy + sz], v7 = q[sy + sz + 1];
    *mn = mn2(mn2(mn2(v0, v1), mn2(v2, v3)), mn2(mn2(v4, v5), mn2(v6, v7)));
    *mx = mx2(mx2(mx2(v0, v1), mx2(v2, v3)), mx2(mx2(v4, v5), mx2(v6, v7)));
    float c00 = v0 + fx * (v1 - v0), c10 = v2 + fx * (v3 - v2);
    float c01 = v4 + fx * (v5 - v4), c11 = v6 + fx * (v7 - v6);
    float c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

float sq__grid_interp(const sq_grid *g, const float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                      float X, float Y, float Z)
{
    lat l = make_lat(g, origin, sy, sz, L);
    float f[3];
    ptrdiff_t b = locate(&l, X, Y, Z, f);
    return trilerp(origin, b, sy, sz, f[0], f[1], f[2]);
}

/* ---- displacements ------------------------------------------------------------------------------ */
/* uc4: the cell-centred velocity as 4 floats per padded cell (x, y, z, 0), the mean of each
 * cell's two faces, ghost cells included. */
static void build_uc4(sq_grid *g, float *uc4)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    const sq_field3 *U = &g->vel[0], *V = &g->vel[1], *W = &g->vel[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = -1; k <= nz; k++)
        for (int j = -1; j <= ny; j++) {
            const float *u = sq_field3_at(U, 0, j, k), *v0 = sq_field3_at(V, 0, j, k),
                        *v1 = sq_field3_at(V, 0, j + 1, k), *w0 = sq_field3_at(W, 0, j, k),
                        *w1 = sq_field3_at(W, 0, j, k + 1);
            float *q = uc4 + 4 * sq__cidx(g, 0, j, k);
            for (int i = -1; i <= nx; i++) {
                q[4 * i + 0] = 0.5f * (u[i] + u[i + 1]);
                q[4 * i + 1] = 0.5f * (v0[i] + v1[i]);
                q[4 * i + 2] = 0.5f * (w0[i] + w1[i]);
                q[4 * i + 3] = 0.0f;
            }
        }
}

static inline v4f ld4(const float *p)
{
    v4f v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* velocity (m/s) at a point (cell units): trilinear in uc4, all components at once */
static inline v4f vel_at(const lat *C, const float *uc4, float X, float Y, float Z)
{
    float f[3];
    const ptrdiff_t b = locate(C, X, Y, Z, f);
    const float *q = uc4 + 4 * b;
    const ptrdiff_t sy = 4 * C->sy, sz = 4 * C->sz;
    const v4f a0 = ld4(q), a1 = ld4(q + 4), a2 = ld4(q + sy), a3 = ld4(q + sy + 4),
              a4 = ld4(q + sz), a5 = ld4(q + sz + 4), a6 = ld4(q + sy + sz),
              a7 = ld4(q + sy + sz + 4);
    const v4f c00 = a0 + f[0] * (a1 - a0), c10 = a2 + f[0] * (a3 - a2);
    const v4f c01 = a4 + f[0] * (a5 - a4), c11 = a6 + f[0] * (a7 - a6);
    const v4f c0 = c00 + f[1] * (c10 - c00), c1 = c01 + f[1] * (c11 - c01);
    return c0 + f[2] * (c1 - c0);
}

/* RK2 (midpoint) displacements, in cell units, of every padded cell centre: db = x_back - x
 * (and df = x_fwd - x when fwd). Returns max (|u|+|v|+|w|) dt / h over interior cells. */
static float cell_displacements(sq_grid *g, const float *uc4_origin, float dt, float drift,
                                float *const db[3], float *const df[3], bool fwd)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    const lat C = make_lat(g, NULL, g->sy, g->sz, SQ__L_CELL);
    const float s = dt / g->h;
    const v4f dv = {0.0f, 0.0f, drift, 0.0f};
    double *pmax = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = -1; k <= nz; k++) {
        float vmax = 0.0f;
        for (int j = -1; j <= ny; j++)
            for (int i = -1; i <= nx; i++) {
                const ptrdiff_t c = (ptrdiff_t)i + (ptrdiff_t)j * g->sy + (ptrdiff_t)k * g->sz;
                const float X = (float)i + 0.5f, Y = (float)j + 0.5f, Z = (float)k + 0.5f;
                const v4f u0 = ld4(uc4_origin + 4 * c) + dv;
                if (i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz) {
                    const float sp = fabsf(u0[0]) + fabsf(u0[1]) + fabsf(u0[2]);
                    vmax = sp > vmax ? sp : vmax;
                }
                const float hs = 0.5f * s;
                v4f u1 = vel_at(&C, uc4_origin, X - hs * u0[0], Y - hs * u0[1], Z - hs * u0[2]) + dv;
                db[0][c] = -s * u1[0];
                db[1][c] = -s * u1[1];
                db[2][c] = -s * u1[2];
                if (!fwd) continue;
                u1 = vel_at(&C, uc4_origin, X + hs * u0[0], Y + hs * u0[1], Z + hs * u0[2]) + dv;
                df[0][c] = s * u1[0];
                df[1][c] = s * u1[1];
                df[2][c] = s * u1[2];
            }
        if (k >= 0 && k < nz) pmax[k] = (double)vmax;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pmax[k] > m ? pmax[k] : m;
    return (float)m * s;
}

/* Makes the cached displacements valid for the current velocity, dt and drift. */
static void ensure_displacements(sq_grid *g, float dt, float drift, bool fwd)
{
    if (g->trace_valid && g->trace_version == g->vel_version && g->trace_dt == (double)dt &&
        g->trace_drift == (double)drift && (g->trace_fwd || !fwd))
        return;
    sq__grid_enforce_velocity(g);
    float *uc4 = g->scratch[SQ__S_BLOCK];
    build_uc4(g, uc4);
    const ptrdiff_t c0 = sq__cidx(g, 0, 0, 0);
    float *db[3], *df[3];
    for (int a = 0; a < 3; a++) {
        db[a] = g->scratch[SQ__S_DISP + a] + c0;
        df[a] = g->scratch[SQ__S_DISP + 3 + a] + c0;
    }
    g->trace_cfl = cell_displacements(g, uc4 + 4 * c0, dt, drift, db, df, fwd);
    g->trace_valid = true;
    g->trace_fwd = fwd;
    g->trace_version = g->vel_version;
    g->trace_dt = (double)dt;
    g->trace_drift = (double)drift;
}

/* ---- the two passes ------------------------------------------------------------------------------ */
/* Pass 1 over lattice L (for the cell lattice off = 0 and the "two cells" are the same cell):
 * hat = F at the backward trace, and for MacCormack the range of the 8 values used. Pass 2:
 * out = hat + (F - hat at the forward trace) / 2, limited. Solid cells (cell lattice) keep
 * their value. */
static void advect_field(sq_grid *g, int L, int scalar, const lat *F, float *hat, float *mn,
                         float *mx, float *out, bool mac, bool nonneg)
{
    const int mxn = F->m[0], myn = F->m[1], mzn = F->m[2];
    const ptrdiff_t sy = F->sy, sz = F->sz, csy = g->sy, csz = g->sz;
    const ptrdiff_t off = L == SQ__L_U ? 1 : L == SQ__L_V ? csy : L == SQ__L_W ? csz : 0;
    const float *o = F->o;
    const ptrdiff_t c00 = sq__cidx(g, 0, 0, 0);
    const uint8_t *fl = g->flags + c00;
    const bool cell = L == SQ__L_CELL;
    const float *bx = g->scratch[SQ__S_DISP] + c00, *by = g->scratch[SQ__S_DISP + 1] + c00,
                *bz = g->scratch[SQ__S_DISP + 2] + c00;
    const float *fx = g->scratch[SQ__S_DISP + 3] + c00, *fy = g->scratch[SQ__S_DISP + 4] + c00,
                *fz = g->scratch[SQ__S_DISP + 5] + c00;
    const int nt = sq_context_threads(g->ctx);
    float *dst1 = mac ? hat : out;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mzn; k++)
        for (int j = 0; j < myn; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t q0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i = 0; i < mxn; i++) {
                const ptrdiff_t h = q0 + i, l = h - off, p = r0 + i;
                const float X = (float)i + F->off[0] + 0.5f * (bx[l] + bx[h]);
                const float Y = (float)j + F->off[1] + 0.5f * (by[l] + by[h]);
                const float Z = (float)k + F->off[2] + 0.5f * (bz[l] + bz[h]);
                float f[3];
                const ptrdiff_t b = locate(F, X, Y, Z, f);
                float v;
                if (mac)
                    v = trilerp_range(o, b, sy, sz, f[0], f[1], f[2], &mn[p], &mx[p]);
                else
                    v = trilerp(o, b, sy, sz, f[0], f[1], f[2]);
                if (cell) {
                    if (!mac && nonneg && v < 0.0f) v = 0.0f;
                    if (fl[h] & SQ__CF_SOLID) v = o[p];
                }
                dst1[p] = v;
            }
        }
    if (!mac) return;
    sq__grid_fill_ghosts(g, hat, sy, sz, L, scalar);
    const bool clamp = g->d.limiter == SQ_LIMITER_CLAMP;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mzn; k++)
        for (int j = 0; j < myn; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t q0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i = 0; i < mxn; i++) {
                const ptrdiff_t h = q0 + i, l = h - off, p = r0 + i;
                const float X = (float)i + F->off[0] + 0.5f * (fx[l] + fx[h]);
                const float Y = (float)j + F->off[1] + 0.5f * (fy[l] + fy[h]);
                const float Z = (float)k + F->off[2] + 0.5f * (fz[l] + fz[h]);
                float f[3];
                const ptrdiff_t b = locate(F, X, Y, Z, f);
                const float h1 = hat[p], lo = mn[p], hi = mx[p];
                float v = h1 + 0.5f * (o[p] - trilerp(hat, b, sy, sz, f[0], f[1], f[2]));
                if (v < lo || v > hi) v = clamp ? (v < lo ? lo : hi) : h1;
                if (cell) {
                    if (nonneg && v < 0.0f) v = 0.0f;
                    if (fl[h] & SQ__CF_SOLID) v = o[p];
                }
                out[p] = v;
            }
        }
}

/* Makes scratch array s (holding a result in f's layout) the storage of f; f's old storage
 * becomes scratch array s. Both hold scratch_count floats. */
static void swap_in(sq_grid *g, sq_field3 *f, int s)
{
    float *old = f->base;
    const ptrdiff_t off = f->origin - f->base;
    f->base = g->scratch[s];
    f->origin = f->base + off;
    g->scratch[s] = old;
}

/* origin of f's layout inside scratch array s */
static float *scratch_origin(sq_grid *g, int s, const sq_field3 *like)
{
    return g->scratch[s] + (like->origin - like->base);
}

sq_result sq__grid_advect_velocity(sq_grid *g, float dt)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    ensure_displacements(g, dt, 0.0f, mac);
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        lat F = make_lat(g, f->origin, f->sy, f->sz, c + 1);
        advect_field(g, c + 1, -1, &F, scratch_origin(g, SQ__S_BLOCK, f),
                     scratch_origin(g, SQ__S_BLOCK + 1, f), scratch_origin(g, SQ__S_BLOCK + 2, f),
                     scratch_origin(g, SQ__S_OUT + c, f), mac, false);
    }
    for (int c = 0; c < 3; c++) swap_in(g, &g->vel[c], SQ__S_OUT + c);
    g->stats.last_cfl = (double)g->trace_cfl;
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    return SQ_OK;
}

sq_result sq__grid_advect_scalar(sq_grid *g, int idx, float dt, float drift)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    const bool nonneg = (g->d.scalar_nonnegative >> idx) & 1u;
    ensure_displacements(g, dt, drift, mac);
    g->stats.last_cfl = (double)g->trace_cfl;
    sq_field3 *f = &g->scalar[idx];
    sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, idx);
    lat F = make_lat(g, f->origin, f->sy, f->sz, SQ__L_CELL);
    advect_field(g, SQ__L_CELL, idx, &F, scratch_origin(g, SQ__S_BLOCK, f),
                 scratch_origin(g, SQ__S_BLOCK + 1, f), scratch_origin(g, SQ__S_BLOCK + 2, f),
                 scratch_origin(g, SQ__S_OUT, f), mac, nonneg);
    swap_in(g, f, SQ__S_OUT);
    sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, idx);
    return SQ_OK;
}

/* ---- public stages ---------------------------------------------------------------------------- */
static sq_result check_dt(sq_grid *g, double dt, const char *what)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "grid", "%s: grid is NULL", what);
    if (!(dt > 0.0) || !isfinite(dt))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, "grid", "%s: dt = %g s; must be > 0", what,
                        dt);
    if (g->topology_dirty) return sq__grid_update_topology(g);
    return SQ_OK;
}

sq_result sq_grid_advect_velocity(sq_grid *g, double dt_s)
{
    sq_result r = check_dt(g, dt_s, "sq_grid_advect_velocity");
    if (r != SQ_OK) return r;
    double t0 = sq_time_now();
    r = sq__grid_advect_velocity(g, (float)dt_s);
    g->stats.ms_advect += (sq_time_now() - t0) * 1e3;
    g->stats.advect_calls++;
    return r;
}

sq_result sq_grid_advect_scalar_drift(sq_grid *g, int idx, double dt_s, double drift_w_mps)
{
    sq_result r = check_dt(g, dt_s, "sq_grid_advect_scalar");
    if (r != SQ_OK) return r;
    if (idx < 0 || idx >= g->d.scalar_count)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, "grid",
                        "scalar index = %d; must be in 0..%d (scalar_count = %d)", idx,
                        g->d.scalar_count - 1, g->d.scalar_count);
    if (!isfinite(drift_w_mps))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, "grid", "drift_w_mps = %g; must be finite",
                        drift_w_mps);
    double t0 = sq_time_now();
    r = sq__grid_advect_scalar(g, idx, (float)dt_s, (float)drift_w_mps);
    g->stats.ms_advect += (sq_time_now() - t0) * 1e3;
    g->stats.advect_calls++;
    return r;
}

sq_result sq_grid_advect_scalar(sq_grid *g, int idx, double dt_s)
{
    return sq_grid_advect_scalar_drift(g, idx, dt_s, 0.0);
}

sq_result sq_grid_advect_scalars(sq_grid *g, double dt_s)
{
    sq_result r = check_dt(g, dt_s, "sq_grid_advect_scalars");
    for (int s = 0; r == SQ_OK && s < g->d.scalar_count; s++) r = sq_grid_advect_scalar(g, s, dt_s);
    return r;
}
