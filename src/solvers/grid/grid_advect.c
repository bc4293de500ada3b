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

/* Locates a point (cell units) on a lattice: base offset of the lower corner and fractions. */
static inline ptrdiff_t locate(const lat *l, float X, float Y, float Z, float f[3])
{
    const float p[3] = {X, Y, Z};
    int i[3];
    for (int a = 0; a < 3; a++) {
        float t = p[a] - l->off[a];
        if (l->period[a]) {
            const float P = (float)l->period[a];
            t -= P * floorf(t / P);
        } else {
            t = t < -1.0f ? -1.0f : (t > (float)l->m[a] ? (float)l->m[a] : t);
        }
        int ii = (int)floorf(t);
        if (ii > l->m[a] - 1) ii = l->m[a] - 1;
        if (ii < -1) ii = -1;
        i[a] = ii;
        f[a] = t - (float)ii;
    }
    return (ptrdiff_t)i[0] + (ptrdiff_t)i[1] * l->sy + (ptrdiff_t)i[2] * l->sz;
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

static inline void minmax8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float *mn,
                           float *mx)
{
    const float *q = o + b;
    float v[8] = {q[0], q[1], q[sy], q[sy + 1], q[sz], q[sz + 1], q[sy + sz], q[sy + sz + 1]};
    float lo = v[0], hi = v[0];
    for (int c = 1; c < 8; c++) {
        lo = v[c] < lo ? v[c] : lo;
        hi = v[c] > hi ? v[c] : hi;
    }
    *mn = lo;
    *mx = hi;
}

float sq__grid_interp(const sq_grid *g, const float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                      float X, float Y, float Z)
{
    lat l = make_lat(g, origin, sy, sz, L);
    float f[3];
    ptrdiff_t b = locate(&l, X, Y, Z, f);
    return trilerp(origin, b, sy, sz, f[0], f[1], f[2]);
}

/* Velocity (m/s) at a point in cell units, each component from its own faces. */
static inline void vel_at(const lat v[3], float X, float Y, float Z, float drift, float out[3])
{
    for (int c = 0; c < 3; c++) {
        float f[3];
        ptrdiff_t b = locate(&v[c], X, Y, Z, f);
        out[c] = trilerp(v[c].o, b, v[c].sy, v[c].sz, f[0], f[1], f[2]);
    }
    out[2] += drift;
}

/* RK2 traces of every sample of lattice L: backward (x - dt u) always, forward (x + dt u) when
 * fwd is non-NULL. Each trace is stored as the base offset (int32, in the sampled field's
 * layout, which is the layout of the lattice) and three fractions. Returns max |u| dt / h. */
static float compute_traces(sq_grid *g, int L, float dt, float drift, float *const back[4],
                            float *const fwd[4])
{
    const sq_field3 *ref = L == SQ__L_CELL ? &g->p : &g->vel[L - 1];
    lat v[3];
    for (int c = 0; c < 3; c++) v[c] = make_lat(g, g->vel[c].origin, g->vel[c].sy, g->vel[c].sz, c + 1);
    lat dst = make_lat(g, ref->origin, ref->sy, ref->sz, L);
    const int mx = dst.m[0], my = dst.m[1], mz = dst.m[2];
    const float s = dt / g->h; /* m/s -> cells per step */
    const int nt = sq_context_threads(g->ctx);
    double *pmax = g->plane_sum;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mz; k++) {
        float vmax = 0.0f;
        for (int j = 0; j < my; j++)
            for (int i = 0; i < mx; i++) {
                const size_t t = (size_t)i + (size_t)mx * ((size_t)j + (size_t)my * (size_t)k);
                const float X = (float)i + dst.off[0], Y = (float)j + dst.off[1],
                            Z = (float)k + dst.off[2];
                float u0[3], u1[3], f[3];
                vel_at(v, X, Y, Z, drift, u0);
                float sp = fabsf(u0[0]) + fabsf(u0[1]) + fabsf(u0[2]);
                vmax = sp > vmax ? sp : vmax;
                for (int dir = 0; dir < 2; dir++) {
                    float *const *tr = dir == 0 ? back : fwd;
                    if (!tr) continue;
                    const float sg = dir == 0 ? -s : s;
                    vel_at(v, X + 0.5f * sg * u0[0], Y + 0.5f * sg * u0[1], Z + 0.5f * sg * u0[2],
                           drift, u1);
                    ptrdiff_t b = locate(&dst, X + sg * u1[0], Y + sg * u1[1], Z + sg * u1[2], f);
                    ((int32_t *)(void *)tr[0])[t] = (int32_t)b;
                    tr[1][t] = f[0];
                    tr[2][t] = f[1];
                    tr[3][t] = f[2];
                }
            }
        pmax[k] = (double)vmax;
    }
    double m = 0.0;
    for (int k = 0; k < mz; k++) m = pmax[k] > m ? pmax[k] : m;
    return (float)m * s;
}

/* Pass A: dst = F sampled at the backward trace (the semi-Lagrangian step). */
static void sample_back(sq_grid *g, const lat *F, float *dst, float *const back[4], int L,
                        bool keep_solid)
{
    const int mx = F->m[0], my = F->m[1], mz = F->m[2];
    const ptrdiff_t sy = F->sy, sz = F->sz;
    const int nt = sq_context_threads(g->ctx);
    const uint8_t *fl = g->flags;
    const float *o = F->o;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mz; k++)
        for (int j = 0; j < my; j++) {
            const size_t t0 = (size_t)mx * ((size_t)j + (size_t)my * (size_t)k);
            const ptrdiff_t p0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const int32_t *bi = (const int32_t *)(const void *)back[0] + t0;
            const float *fx = back[1] + t0, *fy = back[2] + t0, *fz = back[3] + t0;
            for (int i = 0; i < mx; i++) {
                float v = trilerp(o, bi[i], sy, sz, fx[i], fy[i], fz[i]);
                if (keep_solid && (fl[sq__cidx(g, i, j, k)] & SQ__CF_SOLID)) v = o[p0 + i];
                dst[p0 + i] = v;
            }
        }
    (void)L;
}

/* Pass B: out = hat + (F - A^R(hat)) / 2 with Selle's limiter over the 8 source values. */
static void maccormack_correct(sq_grid *g, const lat *F, const float *hat, float *out,
                               float *const back[4], float *const fwd[4], bool keep_solid,
                               bool nonneg)
{
    const int mx = F->m[0], my = F->m[1], mz = F->m[2];
    const ptrdiff_t sy = F->sy, sz = F->sz;
    const int nt = sq_context_threads(g->ctx);
    const bool clamp = g->d.limiter == SQ_LIMITER_CLAMP;
    const uint8_t *fl = g->flags;
    const float *o = F->o;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mz; k++)
        for (int j = 0; j < my; j++) {
            const size_t t0 = (size_t)mx * ((size_t)j + (size_t)my * (size_t)k);
            const ptrdiff_t p0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const int32_t *bb = (const int32_t *)(const void *)back[0] + t0;
            const int32_t *fb = (const int32_t *)(const void *)fwd[0] + t0;
            for (int i = 0; i < mx; i++) {
                const size_t t = t0 + (size_t)i;
                const ptrdiff_t p = p0 + i;
                float h1 = hat[p];
                float h0 = trilerp(hat, fb[i], sy, sz, fwd[1][t], fwd[2][t], fwd[3][t]);
                float v = h1 + 0.5f * (o[p] - h0);
                float lo, hi;
                minmax8(o, bb[i], sy, sz, &lo, &hi);
                if (v < lo || v > hi) v = clamp ? (v < lo ? lo : hi) : h1;
                if (nonneg && v < 0.0f) v = 0.0f;
                if (keep_solid && (fl[sq__cidx(g, i, j, k)] & SQ__CF_SOLID)) v = o[p];
                out[p] = v;
            }
        }
}

static void copy_interior(sq_grid *g, const lat *F, float *dst_origin, const float *src)
{
    const int mx = F->m[0], my = F->m[1], mz = F->m[2];
    const int nt = sq_context_threads(g->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = 0; k < mz; k++)
        for (int j = 0; j < my; j++) {
            const ptrdiff_t p0 = (ptrdiff_t)j * F->sy + (ptrdiff_t)k * F->sz;
            memcpy(dst_origin + p0, src + p0, sizeof(float) * (size_t)mx);
        }
}

/* Scratch arrays are padded like the sampled field: returns the origin inside scratch s. */
static float *scratch_origin(sq_grid *g, int s, const sq_field3 *like)
{
    return g->scratch[s] + (like->origin - like->base);
}

sq_result sq__grid_advect_velocity(sq_grid *g, float dt)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    float *back[4], *fwd[4];
    for (int s = 0; s < 4; s++) {
        back[s] = g->scratch[SQ__S_BACK + s];
        fwd[s] = g->scratch[SQ__S_FWD + s];
    }
    float cfl = 0.0f;
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        lat F = make_lat(g, f->origin, f->sy, f->sz, c + 1);
        float cc = compute_traces(g, c + 1, dt, 0.0f, back, mac ? fwd : NULL);
        cfl = cc > cfl ? cc : cfl;
        float *out = scratch_origin(g, SQ__S_OUT + c, f);
        if (!mac) {
            sample_back(g, &F, out, back, c + 1, false);
            continue;
        }
        float *hat = scratch_origin(g, SQ__S_HAT, f);
        sample_back(g, &F, hat, back, c + 1, false);
        sq__grid_fill_ghosts(g, hat, f->sy, f->sz, c + 1, -1);
        maccormack_correct(g, &F, hat, out, back, fwd, false, false);
    }
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        lat F = make_lat(g, f->origin, f->sy, f->sz, c + 1);
        copy_interior(g, &F, f->origin, scratch_origin(g, SQ__S_OUT + c, f));
    }
    g->trace_valid = false;
    g->vel_version++;
    g->stats.last_cfl = (double)cfl;
    sq__grid_enforce_velocity(g);
    return SQ_OK;
}

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
        float cfl = compute_traces(g, SQ__L_CELL, dt, drift, back, mac ? fwd : NULL);
        g->stats.last_cfl = (double)cfl;
        g->trace_valid = true;
        g->trace_version = g->vel_version;
        g->trace_dt = (double)dt;
        g->trace_drift = (double)drift;
    }
    sq_field3 *f = &g->scalar[idx];
    sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, idx);
    lat F = make_lat(g, f->origin, f->sy, f->sz, SQ__L_CELL);
    float *out = scratch_origin(g, SQ__S_OUT, f);
    if (mac) {
        float *hat = scratch_origin(g, SQ__S_HAT, f);
        sample_back(g, &F, hat, back, SQ__L_CELL, true);
        sq__grid_fill_ghosts(g, hat, f->sy, f->sz, SQ__L_CELL, idx);
        maccormack_correct(g, &F, hat, out, back, fwd, true, nonneg);
    } else {
        sample_back(g, &F, out, back, SQ__L_CELL, true);
        if (nonneg) {
            const int nt = sq_context_threads(g->ctx);
            SQ_OMP(omp parallel for schedule(static) num_threads(nt))
            for (int k = 0; k < F.m[2]; k++)
                for (int j = 0; j < F.m[1]; j++) {
                    float *row = out + (ptrdiff_t)j * F.sy + (ptrdiff_t)k * F.sz;
                    for (int i = 0; i < F.m[0]; i++) row[i] = row[i] < 0.0f ? 0.0f : row[i];
                }
        }
    }
    copy_interior(g, &F, f->origin, out);
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
