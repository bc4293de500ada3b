/* grid_advect.c — advection on the MAC grid (SPEC §1.4, eq. 2.10 and 2.11):
 *   semi-Lagrangian  q(x, t+dt) = q(x - u dt, t), trilinear, RK2 (midpoint) back-trace;
 *   MacCormack [Selle, Fedkiw, Kim, Liu, Rossignac 2008]:
 *       q^ = A(q),  q_ = A^R(q^),  q' = q^ + (q - q_)/2,
 *     with the limiter: if q' leaves [min, max] of the 8 values q^ interpolated from, q' is
 *     reverted to q^ (SQ_LIMITER_REVERT) or clamped to that range (SQ_LIMITER_CLAMP).
 * Each face-velocity component is advected on its own lattice with the velocity interpolated
 * component-wise from the staggered faces. Cell-centre traces are cached and shared by all
 * scalars advected with the same velocity, dt and drift. */
#include <string.h>

#include "solvers/grid/grid_internal.h"

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
static inline float min8(float a, float b, float c, float d, float e, float f, float g, float h)
{
    return mn2(mn2(mn2(a, b), mn2(c, d)), mn2(mn2(e, f), mn2(g, h)));
}
static inline float max8(float a, float b, float c, float d, float e, float f, float g, float h)
{
    return mx2(mx2(mx2(a, b), mx2(c, d)), mx2(mx2(e, f), mx2(g, h)));
}

/* trilinear sample and the range of its 8 source values */
static inline float trilerp_range(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz,
                                  float fx, float fy, float fz, float *mn, float *mx)
{
    const float *q = o + b;
    const float v0 = q[0], v1 = q[1], v2 = q[sy], v3 = q[sy + 1], v4 = q[sz], v5 = q[sz + 1],
                v6 = q[sy + sz], v7 = q[sy + sz + 1];
    *mn = min8(v0, v1, v2, v3, v4, v5, v6, v7);
    *mx = max8(v0, v1, v2, v3, v4, v5, v6, v7);
    float c00 = v0 + fx * (v1 - v0), c10 = v2 + fx * (v3 - v2);
    float c01 = v4 + fx * (v5 - v4), c11 = v6 + fx * (v7 - v6);
    float c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

static inline void range8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float *mn,
                          float *mx)
{
    const float *q = o + b;
    const float v0 = q[0], v1 = q[1], v2 = q[sy], v3 = q[sy + 1], v4 = q[sz], v5 = q[sz + 1],
                v6 = q[sy + sz], v7 = q[sy + sz + 1];
    *mn = min8(v0, v1, v2, v3, v4, v5, v6, v7);
    *mx = max8(v0, v1, v2, v3, v4, v5, v6, v7);
}

float sq__grid_interp(const sq_grid *g, const float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                      float X, float Y, float Z)
{
    lat l = make_lat(g, origin, sy, sz, L);
    float f[3];
    ptrdiff_t b = locate(&l, X, Y, Z, f);
    return trilerp(origin, b, sy, sz, f[0], f[1], f[2]);
}

/* ---- velocity for the traces ------------------------------------------------------------------ */
/* The tracer: cell-centred velocity (SoA in three padded cell arrays, ghosts included, each
 * the mean of the cell's two faces) so that the RK2 midpoint velocity costs one locate and
 * three lerp trees. */
typedef struct tracer {
    lat cell;                /* geometry of the cell lattice (o unused) */
    const float *uc[3];      /* cell-centred velocity at cell (0,0,0) of the padded layout */
    float s;                 /* dt / h */
    float drift;             /* extra vertical velocity, m/s */
} tracer;

static void build_cell_velocity(sq_grid *g, float *uc[3])
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    for (int c = 0; c < 3; c++) {
        const sq_field3 *f = &g->vel[c];
        const ptrdiff_t st = c == 0 ? 1 : c == 1 ? f->sy : f->sz;
        float *o = uc[c] + sq__cidx(g, 0, 0, 0);
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = -1; k <= nz; k++)
            for (int j = -1; j <= ny; j++) {
                const float *p = sq_field3_at(f, 0, j, k);
                float *q = o + (ptrdiff_t)j * g->sy + (ptrdiff_t)k * g->sz;
                for (int i = -1; i <= nx; i++) q[i] = 0.5f * (p[i] + p[i + st]);
            }
    }
}

static tracer make_tracer(sq_grid *g, float *const uc[3], float dt, float drift)
{
    tracer t;
    t.cell = make_lat(g, NULL, g->sy, g->sz, SQ__L_CELL);
    for (int c = 0; c < 3; c++) t.uc[c] = uc[c] + sq__cidx(g, 0, 0, 0);
    t.s = dt / g->h;
    t.drift = drift;
    return t;
}

/* velocity (m/s) at a point in cell units from the cell-centred copy */
static inline void vel_mid(const tracer *t, float X, float Y, float Z, float u[3])
{
    float f[3];
    const ptrdiff_t b = locate(&t->cell, X, Y, Z, f);
    for (int c = 0; c < 3; c++)
        u[c] = trilerp(t->uc[c], b, t->cell.sy, t->cell.sz, f[0], f[1], f[2]);
    u[2] += t->drift;
}

/* RK2 (midpoint) departure point of the sample at X0 with first-stage velocity u0; sg = -1
 * for the backward trace x - dt u, +1 for the forward trace. */
static inline void trace(const tracer *t, const float X0[3], const float u0[3], float sg,
                         float out[3])
{
    const float h = 0.5f * sg * t->s;
    float u1[3];
    vel_mid(t, X0[0] + h * u0[0], X0[1] + h * u0[1], X0[2] + h * u0[2], u1);
    const float q = sg * t->s;
    out[0] = X0[0] + q * u1[0];
    out[1] = X0[1] + q * u1[1];
    out[2] = X0[2] + q * u1[2];
}

/* ---- velocity advection ------------------------------------------------------------------------ */
/* RK2 displacements (cell units) of every cell centre, ghost cells included: db = x_back - x,
 * df = x_fwd - x. A face takes the mean of its two cells' displacements, which is exact for
 * linear velocity fields (the RK2 displacement is then linear in x), so the face traces stay
 * second order at a third of the cost. Returns max |u| dt / h. */
static float cell_displacements(sq_grid *g, const tracer *t, float *db[3], float *df[3], bool fwd)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    double *pmax = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = -1; k <= nz; k++) {
        float vmax = 0.0f;
        for (int j = -1; j <= ny; j++)
            for (int i = -1; i <= nx; i++) {
                const ptrdiff_t c = (ptrdiff_t)i + (ptrdiff_t)j * g->sy + (ptrdiff_t)k * g->sz;
                const float X0[3] = {(float)i + 0.5f, (float)j + 0.5f, (float)k + 0.5f};
                const float u0[3] = {t->uc[0][c], t->uc[1][c], t->uc[2][c] + t->drift};
                if (i >= 0 && j >= 0 && k >= 0 && i < nx && j < ny && k < nz) {
                    const float sp = fabsf(u0[0]) + fabsf(u0[1]) + fabsf(u0[2]);
                    vmax = sp > vmax ? sp : vmax;
                }
                float X[3];
                trace(t, X0, u0, -1.0f, X);
                for (int a = 0; a < 3; a++) db[a][c] = X[a] - X0[a];
                if (!fwd) continue;
                trace(t, X0, u0, 1.0f, X);
                for (int a = 0; a < 3; a++) df[a][c] = X[a] - X0[a];
            }
        if (k >= 0 && k < nz) pmax[k] = (double)vmax;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pmax[k] > m ? pmax[k] : m;
    return (float)m * t->s;
}

/* Pass 1: hat = F at the backward trace. Pass 2 (MacCormack): out = hat + (F - hat at the
 * forward trace) / 2, limited to the range of the 8 values pass 1 interpolated from. */
static void advect_component(sq_grid *g, int L, const lat *F, float *const db[3],
                             float *const df[3], float *hat, float *out, bool mac)
{
    const int mxn = F->m[0], myn = F->m[1], mzn = F->m[2];
    const ptrdiff_t sy = F->sy, sz = F->sz, csy = g->sy, csz = g->sz;
    const int c = L - 1;
    const ptrdiff_t off = c == 0 ? 1 : c == 1 ? csy : csz; /* cell below the face */
    const float *o = F->o;
    const int nt = sq_context_threads(g->ctx);
    float *dst1 = mac ? hat : out;
    const float *bx = db[0], *by = db[1], *bz = db[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mzn; k++)
        for (int j = 0; j < myn; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t c0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i = 0; i < mxn; i++) {
                const ptrdiff_t h = c0 + i, l = h - off;
                const float X = (float)i + F->off[0] + 0.5f * (bx[l] + bx[h]);
                const float Y = (float)j + F->off[1] + 0.5f * (by[l] + by[h]);
                const float Z = (float)k + F->off[2] + 0.5f * (bz[l] + bz[h]);
                float f[3];
                const ptrdiff_t b = locate(F, X, Y, Z, f);
                dst1[r0 + i] = trilerp(o, b, sy, sz, f[0], f[1], f[2]);
            }
        }
    if (!mac) return;
    sq__grid_fill_ghosts(g, hat, sy, sz, L, -1);
    const bool clamp = g->d.limiter == SQ_LIMITER_CLAMP;
    const float *fx = df[0], *fy = df[1], *fz = df[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mzn; k++)
        for (int j = 0; j < myn; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t c0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i = 0; i < mxn; i++) {
                const ptrdiff_t p = r0 + i, h = c0 + i, l = h - off;
                const float X0 = (float)i + F->off[0], Y0 = (float)j + F->off[1],
                            Z0 = (float)k + F->off[2];
                float f[3], lo, hi;
                ptrdiff_t b = locate(F, X0 + 0.5f * (bx[l] + bx[h]), Y0 + 0.5f * (by[l] + by[h]),
                                     Z0 + 0.5f * (bz[l] + bz[h]), f);
                range8(o, b, sy, sz, &lo, &hi);
                b = locate(F, X0 + 0.5f * (fx[l] + fx[h]), Y0 + 0.5f * (fy[l] + fy[h]),
                           Z0 + 0.5f * (fz[l] + fz[h]), f);
                const float h1 = hat[p];
                float v = h1 + 0.5f * (o[p] - trilerp(hat, b, sy, sz, f[0], f[1], f[2]));
                if (v < lo || v > hi) v = clamp ? (v < lo ? lo : hi) : h1;
                out[p] = v;
            }
        }
}

/* ---- cached cell-centre traces for scalars ------------------------------------------------------ */
/* Stores the backward (and forward) trace of every cell centre as base offset (int32 in the
 * cell layout) and fractions. Returns max |u| dt / h. */
static float cell_traces(sq_grid *g, const tracer *t, float *const back[4], float *const fwd[4])
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    double *pmax = g->plane_sum;
    const lat *C = &t->cell;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++) {
        float vmax = 0.0f;
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const size_t n = (size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
                const float X0[3] = {(float)i + 0.5f, (float)j + 0.5f, (float)k + 0.5f};
                const ptrdiff_t c = sq__cidx(g, i, j, k) - sq__cidx(g, 0, 0, 0);
                const float u0[3] = {t->uc[0][c], t->uc[1][c], t->uc[2][c] + t->drift};
                float X[3], f[3];
                const float sp = fabsf(u0[0]) + fabsf(u0[1]) + fabsf(u0[2]);
                vmax = sp > vmax ? sp : vmax;
                for (int dir = 0; dir < 2; dir++) {
                    float *const *tr = dir == 0 ? back : fwd;
                    if (!tr) continue;
                    trace(t, X0, u0, dir == 0 ? -1.0f : 1.0f, X);
                    const ptrdiff_t b = locate(C, X[0], X[1], X[2], f);
                    ((int32_t *)(void *)tr[0])[n] = (int32_t)b;
                    tr[1][n] = f[0];
                    tr[2][n] = f[1];
                    tr[3][n] = f[2];
                }
            }
        pmax[k] = (double)vmax;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pmax[k] > m ? pmax[k] : m;
    return (float)m * t->s;
}

/* Scalar pass A: dst = F at the cached backward trace (solid cells keep their value). */
static void sample_back(sq_grid *g, const float *o, float *dst, float *const back[4])
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const int nt = sq_context_threads(g->ctx);
    const uint8_t *fl = g->flags + sq__cidx(g, 0, 0, 0);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const size_t t0 = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
            const ptrdiff_t p0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const int32_t *bi = (const int32_t *)(const void *)back[0] + t0;
            const float *fx = back[1] + t0, *fy = back[2] + t0, *fz = back[3] + t0;
            for (int i = 0; i < nx; i++) {
                float v = trilerp(o, bi[i], sy, sz, fx[i], fy[i], fz[i]);
                dst[p0 + i] = (fl[p0 + i] & SQ__CF_SOLID) ? o[p0 + i] : v;
            }
        }
}

/* Scalar pass B: out = hat + (F - hat at the forward trace) / 2 with Selle's limiter over the
 * 8 values the backward step interpolated from. */
static void maccormack_correct(sq_grid *g, const float *o, const float *hat, float *out,
                               float *const back[4], float *const fwd[4], bool nonneg)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const ptrdiff_t sy = g->sy, sz = g->sz;
    const int nt = sq_context_threads(g->ctx);
    const bool clamp = g->d.limiter == SQ_LIMITER_CLAMP;
    const uint8_t *fl = g->flags + sq__cidx(g, 0, 0, 0);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++) {
            const size_t t0 = (size_t)nx * ((size_t)j + (size_t)ny * (size_t)k);
            const ptrdiff_t p0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const int32_t *bb = (const int32_t *)(const void *)back[0] + t0;
            const int32_t *fb = (const int32_t *)(const void *)fwd[0] + t0;
            const float *fx = fwd[1] + t0, *fy = fwd[2] + t0, *fz = fwd[3] + t0;
            for (int i = 0; i < nx; i++) {
                const ptrdiff_t p = p0 + i;
                const float h1 = hat[p];
                float v = h1 + 0.5f * (o[p] - trilerp(hat, fb[i], sy, sz, fx[i], fy[i], fz[i]));
                float lo, hi;
                range8(o, bb[i], sy, sz, &lo, &hi);
                if (v < lo || v > hi) v = clamp ? (v < lo ? lo : hi) : h1;
                if (nonneg && v < 0.0f) v = 0.0f;
                out[p] = (fl[p] & SQ__CF_SOLID) ? o[p] : v;
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

/* Scratch arrays are padded like the sampled field: returns the origin inside scratch s. */
static float *scratch_origin(sq_grid *g, int s, const sq_field3 *like)
{
    return g->scratch[s] + (like->origin - like->base);
}

/* scratch use: cell velocity [0..2] (then hat [0]), displacements [3..8], outputs [9..11] */
sq_result sq__grid_advect_velocity(sq_grid *g, float dt)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    float *uc[3] = {g->scratch[0], g->scratch[1], g->scratch[2]};
    build_cell_velocity(g, uc);
    tracer t = make_tracer(g, uc, dt, 0.0f);
    const ptrdiff_t c0 = sq__cidx(g, 0, 0, 0);
    float *db[3] = {g->scratch[3] + c0, g->scratch[4] + c0, g->scratch[5] + c0};
    float *df[3] = {g->scratch[6] + c0, g->scratch[7] + c0, g->scratch[8] + c0};
    const float cfl = cell_displacements(g, &t, db, df, mac);
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        lat F = make_lat(g, f->origin, f->sy, f->sz, c + 1);
        advect_component(g, c + 1, &F, db, df, scratch_origin(g, 0, f),
                         scratch_origin(g, SQ__S_OUT + c, f), mac);
    }
    for (int c = 0; c < 3; c++) swap_in(g, &g->vel[c], SQ__S_OUT + c);
    g->trace_valid = false;
    g->vel_version++;
    g->stats.last_cfl = (double)cfl;
    sq__grid_enforce_velocity(g);
    return SQ_OK;
}

/* scratch use: traces in [0..7], cell velocity (while tracing) then hat/out in [8..10] */
sq_result sq__grid_advect_scalar(sq_grid *g, int idx, float dt, float drift)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    const bool nonneg = (g->d.scalar_nonnegative >> idx) & 1u;
    float *back[4], *fwd[4];
    for (int s = 0; s < 4; s++) {
        back[s] = g->scratch[SQ__S_BACK + s];
        fwd[s] = g->scratch[SQ__S_FWD + s];
    }
    if (!g->trace_valid || g->trace_version != g->vel_version || g->trace_dt != (double)dt ||
        g->trace_drift != (double)drift) {
        float *uc[3] = {g->scratch[SQ__S_HAT], g->scratch[SQ__S_OUT], g->scratch[SQ__S_OUT + 1]};
        build_cell_velocity(g, uc);
        tracer t = make_tracer(g, uc, dt, drift);
        float cfl = cell_traces(g, &t, back, mac ? fwd : NULL);
        g->stats.last_cfl = (double)cfl;
        g->trace_valid = true;
        g->trace_version = g->vel_version;
        g->trace_dt = (double)dt;
        g->trace_drift = (double)drift;
    }
    sq_field3 *f = &g->scalar[idx];
    sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, idx);
    float *out = scratch_origin(g, SQ__S_OUT, f);
    if (mac) {
        float *hat = scratch_origin(g, SQ__S_HAT, f);
        sample_back(g, f->origin, hat, back);
        sq__grid_fill_ghosts(g, hat, f->sy, f->sz, SQ__L_CELL, idx);
        maccormack_correct(g, f->origin, hat, out, back, fwd, nonneg);
    } else {
        sample_back(g, f->origin, out, back);
        if (nonneg) {
            const int nt = sq_context_threads(g->ctx);
            SQ_OMP(omp parallel for schedule(static) num_threads(nt))
            for (int k = 0; k < g->n[2]; k++)
                for (int j = 0; j < g->n[1]; j++) {
                    float *row = out + (ptrdiff_t)j * f->sy + (ptrdiff_t)k * f->sz;
                    for (int i = 0; i < g->n[0]; i++) row[i] = row[i] < 0.0f ? 0.0f : row[i];
                }
        }
    }
    (void)out;
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
    sq__grid_enforce_velocity(g);
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
    if (!g->trace_valid || g->trace_version != g->vel_version) sq__grid_enforce_velocity(g);
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
