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
 * fields (the RK2 displacement is then linear in x), so face traces stay second order.
 * Kernels. Samples are processed in row chunks: the trace positions of a chunk are located in
 * vectorised loops and shared by every field advected on that lattice (the scalars are advected
 * in batches with one trace); the trilinear samples load the 8 corners as four x-pairs (SSE2).
 * MacCormack: pass 1 takes the limiter's range (min and max of the 8 corners) from the same
 * loads as the sample and stores it, the low end in the output array (overwritten in place by
 * pass 2) and the high end in a scratch array, so pass 2 needs only the forward trace (no
 * second backward trace, no second gather of the source). Scalars go in batches of two (hats
 * in scratch 0..1, highs in 2..3), the velocity components one at a time (hat 0, high 1);
 * semi-Lagrangian scalars in batches of three. OpenMP over z-planes, static schedule; no
 * allocation. */
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "solvers/grid/grid_internal.h"

typedef float v4f __attribute__((vector_size(16)));

/* A lattice to sample: padded array, strides, interior sample counts, position offsets.
 * Positions are in the frame of the whole grid: local sample i lies at global index
 * i + shift[a], traces are clamped (cm) or wrapped (period) as on the whole grid, and the
 * corner found is taken back to the local array (remap; only on the widened copy of a
 * decomposed grid's slab, where shift and cm differ from 0 and m). */
typedef struct lat {
    const float *o;
    ptrdiff_t sy, sz;
    int m[3];
    float off[3];
    int period[3]; /* cells per period on periodic axes (the whole grid's), else 0 */
    int cm[3];     /* the whole grid's sample counts (clamp range) */
    int shift[3];  /* global index of local sample 0 */
    bool remap;
} lat;

static lat make_lat(const sq_grid *g, const float *o, ptrdiff_t sy, ptrdiff_t sz, int L)
{
    lat l;
    l.o = o;
    l.sy = sy;
    l.sz = sz;
    l.remap = false;
    for (int a = 0; a < 3; a++) {
        l.m[a] = g->n[a] + (L - 1 == a ? 1 : 0);
        l.off[a] = sq__lattice_off(L, a);
        l.period[a] = g->periodic[a] ? g->lat_n[a] : 0;
        l.cm[a] = g->lat_n[a] + (L - 1 == a ? 1 : 0);
        l.shift[a] = g->lat_shift[a];
        if (l.shift[a] != 0 || l.cm[a] != l.m[a]) l.remap = true;
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

float sq__grid_interp(const sq_grid *g, const float *origin, ptrdiff_t sy, ptrdiff_t sz, int L,
                      float X, float Y, float Z)
{
    lat l = make_lat(g, origin, sy, sz, L);
    float f[3];
    ptrdiff_t b = locate(&l, X, Y, Z, f);
    return trilerp(origin, b, sy, sz, f[0], f[1], f[2]);
}

/* ---- chunked locating ---------------------------------------------------------------------------- */
/* Samples are processed in row chunks of CH: the positions of a chunk are located in
 * vectorisable loops (per axis, with the periodic/clamped choice hoisted out), then every field
 * on the lattice is interpolated from the same corner offsets and fractions. */
enum { CH = 64 };

typedef struct chunk {
    int32_t b[CH]; /* offset of the lower corner in the lattice array */
    float fx[CH], fy[CH], fz[CH];
} chunk;

/* t[q] (lattice units) -> lower index ii[q] and fraction (written back to t[q]); wrapped on a
 * periodic axis, else clamped into the ghost layer [-1, m] (NaN maps to -1). Same arithmetic
 * as axis_locate. */
static inline void axis_chunk(float *restrict t, int32_t *restrict ii, int n, int m, int period)
{
    if (period) {
        const float P = (float)period;
        for (int q = 0; q < n; q++) {
            float v = t[q];
            float w = v / P + 4.0f; /* traces never go 4 periods back */
            w = w > 0.0f ? w : 0.0f;
            v -= P * (float)((int)w - 4);
            v = v >= P ? v - P : v;
            v = v > 0.0f ? v : 0.0f;
            int i = (int)(v + 1.0f) - 1;
            i = i < m - 1 ? i : m - 1;
            ii[q] = i;
            t[q] = v - (float)i;
        }
    } else {
        const float hi = (float)m;
        for (int q = 0; q < n; q++) {
            float v = t[q];
            v = v > -1.0f ? v : -1.0f;
            v = v < hi ? v : hi;
            int i = (int)(v + 1.0f) - 1; /* floor for v >= -1 */
            i = i < m - 1 ? i : m - 1;
            ii[q] = i;
            t[q] = v - (float)i;
        }
    }
}

/* Global lower indices ii[q] -> local ones on an axis of a widened slab: shifted, a wrapped
 * index taken to its image inside the local array, and kept inside [-1, m - 1] (a trace that
 * leaves the widened range only feeds samples outside the slab). */
static inline void axis_remap(int32_t *restrict ii, int n, int shift, int m, int period)
{
    for (int q = 0; q < n; q++) {
        int i = ii[q] - shift;
        i += (i < -1) ? period : 0;
        i -= (i > m - 1) ? period : 0;
        i = i < -1 ? -1 : i;
        ii[q] = i < m - 1 ? i : m - 1;
    }
}

/* Positions in cell units in c->fx/fy/fz -> corner offsets and fractions on lattice F. */
static inline void locate_chunk(const lat *F, chunk *restrict c, int n)
{
    int32_t ix[CH], iy[CH], iz[CH];
    const float ox = F->off[0], oy = F->off[1], oz = F->off[2];
    for (int q = 0; q < n; q++) {
        c->fx[q] -= ox;
        c->fy[q] -= oy;
        c->fz[q] -= oz;
    }
    axis_chunk(c->fx, ix, n, F->cm[0], F->period[0]);
    axis_chunk(c->fy, iy, n, F->cm[1], F->period[1]);
    axis_chunk(c->fz, iz, n, F->cm[2], F->period[2]);
    if (F->remap) {
        axis_remap(ix, n, F->shift[0], F->m[0], F->period[0]);
        axis_remap(iy, n, F->shift[1], F->m[1], F->period[1]);
        axis_remap(iz, n, F->shift[2], F->m[2], F->period[2]);
    }
    const int32_t sy = (int32_t)F->sy, sz = (int32_t)F->sz;
    for (int q = 0; q < n; q++) c->b[q] = ix[q] + iy[q] * sy + iz[q] * sz;
}

/* Traces of samples i0 .. i0+n-1 of row (j, k) of lattice F: sample position plus the mean of
 * the cached displacements of the sample's two cells (h and h - off; the same cell on the cell
 * lattice). q0: padded offset of cell (0, j, k) from cell (0, 0, 0). */
static inline void trace_chunk(const lat *F, ptrdiff_t off, const float *dx, const float *dy,
                               const float *dz, int i0, int n, int j, int k, ptrdiff_t q0,
                               chunk *restrict c)
{
    const float *hx = dx + q0 + i0, *hy = dy + q0 + i0, *hz = dz + q0 + i0;
    const float Y = (float)(j + F->shift[1]) + F->off[1], Z = (float)(k + F->shift[2]) + F->off[2];
    const int x0 = i0 + F->shift[0];
    for (int q = 0; q < n; q++) {
        c->fx[q] = (float)(x0 + q) + F->off[0] + 0.5f * (hx[q - off] + hx[q]);
        c->fy[q] = Y + 0.5f * (hy[q - off] + hy[q]);
        c->fz[q] = Z + 0.5f * (hz[q - off] + hz[q]);
    }
    locate_chunk(F, c, n);
}

/* Chunk kernels: the trilinear sample (tri8) and the range of the 8 corner values (range8) at
 * corner offset b. With SSE2 each sample loads its corners as four x-pairs into two vectors
 * (y0/y1 at z0, y0/y1 at z1) and interpolates z, then y, then x across the lanes. */
#if defined(__SSE2__)
static inline __m128 ld_pairs(const float *a, const float *b)
{
    const __m128 lo = _mm_castsi128_ps(_mm_loadl_epi64((const __m128i *)(const void *)a));
    return _mm_loadh_pi(lo, (const __m64 *)(const void *)b);
}

static inline float tri8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float fx,
                         float fy, float fz)
{
    const float *q = o + b;
    const __m128 lo = ld_pairs(q, q + sy), hi = ld_pairs(q + sz, q + sy + sz);
    const __m128 m = _mm_add_ps(lo, _mm_mul_ps(_mm_set1_ps(fz), _mm_sub_ps(hi, lo)));
    const __m128 n = _mm_add_ps(m, _mm_mul_ps(_mm_set1_ps(fy), _mm_sub_ps(_mm_movehl_ps(m, m), m)));
    const __m128 n1 = _mm_shuffle_ps(n, n, _MM_SHUFFLE(1, 1, 1, 1));
    return _mm_cvtss_f32(_mm_add_ss(n, _mm_mul_ss(_mm_set_ss(fx), _mm_sub_ss(n1, n))));
}

/* The smallest and largest of the 8 corner values held as two quadruples */
static inline void range_of_pairs(__m128 lo, __m128 hi, float *mn, float *mx)
{
    __m128 a = _mm_min_ps(lo, hi), c = _mm_max_ps(lo, hi);
    a = _mm_min_ps(a, _mm_movehl_ps(a, a));
    c = _mm_max_ps(c, _mm_movehl_ps(c, c));
    a = _mm_min_ss(a, _mm_shuffle_ps(a, a, _MM_SHUFFLE(1, 1, 1, 1)));
    c = _mm_max_ss(c, _mm_shuffle_ps(c, c, _MM_SHUFFLE(1, 1, 1, 1)));
    *mn = _mm_cvtss_f32(a);
    *mx = _mm_cvtss_f32(c);
}

static inline void range8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float *mn,
                          float *mx)
{
    const float *q = o + b;
    const __m128 lo = ld_pairs(q, q + sy), hi = ld_pairs(q + sz, q + sy + sz);
    range_of_pairs(lo, hi, mn, mx);
}

/* tri8 and range8 at the same corners from one load of the 8 values */
static inline float tri8_range(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float fx,
                               float fy, float fz, float *mn, float *mx)
{
    const float *q = o + b;
    const __m128 lo = ld_pairs(q, q + sy), hi = ld_pairs(q + sz, q + sy + sz);
    range_of_pairs(lo, hi, mn, mx);
    const __m128 m = _mm_add_ps(lo, _mm_mul_ps(_mm_set1_ps(fz), _mm_sub_ps(hi, lo)));
    const __m128 n = _mm_add_ps(m, _mm_mul_ps(_mm_set1_ps(fy), _mm_sub_ps(_mm_movehl_ps(m, m), m)));
    const __m128 n1 = _mm_shuffle_ps(n, n, _MM_SHUFFLE(1, 1, 1, 1));
    return _mm_cvtss_f32(_mm_add_ss(n, _mm_mul_ss(_mm_set_ss(fx), _mm_sub_ss(n1, n))));
}
#else
static inline float mn2(float a, float b) { return a < b ? a : b; }
static inline float mx2(float a, float b) { return a > b ? a : b; }

static inline float tri8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float fx,
                         float fy, float fz)
{
    return trilerp(o, b, sy, sz, fx, fy, fz);
}

static inline void range8(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float *mn,
                          float *mx)
{
    const float *q = o + b;
    const float v0 = q[0], v1 = q[1], v2 = q[sy], v3 = q[sy + 1], v4 = q[sz], v5 = q[sz + 1],
                v6 = q[sy + sz], v7 = q[sy + sz + 1];
    *mn = mn2(mn2(mn2(v0, v1), mn2(v2, v3)), mn2(mn2(v4, v5), mn2(v6, v7)));
    *mx = mx2(mx2(mx2(v0, v1), mx2(v2, v3)), mx2(mx2(v4, v5), mx2(v6, v7)));
}

static inline float tri8_range(const float *o, ptrdiff_t b, ptrdiff_t sy, ptrdiff_t sz, float fx,
                               float fy, float fz, float *mn, float *mx)
{
    range8(o, b, sy, sz, mn, mx);
    return tri8(o, b, sy, sz, fx, fy, fz);
}
#endif

/* ---- displacements ------------------------------------------------------------------------------ */
/* uc4: the cell-centred velocity as 4 floats per padded cell (x, y, z, 0), the mean of each
 * cell's two faces, ghost cells included. */
static void build_uc4(sq_grid *g, float *uc4)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const sq_field3 *U = &g->vel[0], *V = &g->vel[1], *W = &g->vel[2];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = -1; k <= nz; k++) {
        float a[CH], b[CH], c[CH];
        for (int j = -1; j <= ny; j++) {
            const float *u = sq_field3_at(U, 0, j, k), *v0 = sq_field3_at(V, 0, j, k),
                        *v1 = sq_field3_at(V, 0, j + 1, k), *w0 = sq_field3_at(W, 0, j, k),
                        *w1 = sq_field3_at(W, 0, j, k + 1);
            float *q = uc4 + 4 * sq__cidx(g, 0, j, k);
            for (int i0 = -1; i0 <= nx; i0 += CH) {
                const int n = nx + 1 - i0 < CH ? nx + 1 - i0 : CH;
                for (int t = 0; t < n; t++) { /* SoA, vectorised */
                    const int i = i0 + t;
                    a[t] = 0.5f * (u[i] + u[i + 1]);
                    b[t] = 0.5f * (v0[i] + v1[i]);
                    c[t] = 0.5f * (w0[i] + w1[i]);
                }
                float *o = q + 4 * i0;
                int t = 0;
#if defined(__SSE2__)
                for (; t + 4 <= n; t += 4) { /* 4x4 transpose to (x, y, z, 0) per cell */
                    __m128 r0 = _mm_loadu_ps(a + t), r1 = _mm_loadu_ps(b + t),
                           r2 = _mm_loadu_ps(c + t), r3 = _mm_setzero_ps();
                    _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
                    _mm_storeu_ps(o + 4 * t, r0);
                    _mm_storeu_ps(o + 4 * t + 4, r1);
                    _mm_storeu_ps(o + 4 * t + 8, r2);
                    _mm_storeu_ps(o + 4 * t + 12, r3);
                }
#endif
                for (; t < n; t++) {
                    o[4 * t + 0] = a[t];
                    o[4 * t + 1] = b[t];
                    o[4 * t + 2] = c[t];
                    o[4 * t + 3] = 0.0f;
                }
            }
        }
    }
}

static inline v4f ld4(const float *p)
{
    v4f v;
    memcpy(&v, p, sizeof v);
    return v;
}

/* trilinear uc4 (all components at once) at corner offset b with fractions f */
static inline v4f vel_lerp(const float *uc4, int32_t b, ptrdiff_t sy4, ptrdiff_t sz4, float fx,
                           float fy, float fz)
{
    const float *q = uc4 + 4 * (ptrdiff_t)b;
    const v4f a0 = ld4(q), a1 = ld4(q + 4), a2 = ld4(q + sy4), a3 = ld4(q + sy4 + 4),
              a4 = ld4(q + sz4), a5 = ld4(q + sz4 + 4), a6 = ld4(q + sy4 + sz4),
              a7 = ld4(q + sy4 + sz4 + 4);
    const v4f c00 = a0 + fx * (a1 - a0), c10 = a2 + fx * (a3 - a2);
    const v4f c01 = a4 + fx * (a5 - a4), c11 = a6 + fx * (a7 - a6);
    const v4f c0 = c00 + fy * (c10 - c00), c1 = c01 + fy * (c11 - c01);
    return c0 + fz * (c1 - c0);
}

/* RK2 (midpoint) displacements, in cell units, of every padded cell centre: db = x_back - x
 * (and df = x_fwd - x when fwd). Returns max (|u|+|v|+|w|) dt / h over interior cells. */
static float cell_displacements(sq_grid *g, const float *uc4_origin, float dt, float drift,
                                float *const db[3], float *const df[3], bool fwd)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const lat C = make_lat(g, NULL, g->sy, g->sz, SQ__L_CELL);
    const float s = dt / g->h, hs = 0.5f * s;
    const ptrdiff_t sy4 = 4 * g->sy, sz4 = 4 * g->sz;
    double *pmax = g->plane_sum;
    /* cells (ghosts included) whose backward displacements are computed: all, or on a slab's
     * widened copy those within reach of the first pass (its samples within trace_margin of
     * the slab, each reading its cell and the one below); forward ones: the slab's */
    int lo[3] = {-1, -1, -1}, hi[3] = {nx + 1, ny + 1, nz + 1};
    const int a = g->own_only ? g->own_ax : 0;
    int flo = -1, fhi = a == 0 ? nx + 1 : a == 1 ? ny + 1 : nz + 1;
    if (g->own_only) {
        const int M = g->trace_margin;
        lo[a] = g->own_lo - M - 2 > -1 ? g->own_lo - M - 2 : -1;
        hi[a] = g->own_hi + M + 2 < hi[a] ? g->own_hi + M + 2 : hi[a];
        flo = g->own_lo - 2 > -1 ? g->own_lo - 2 : -1;
        fhi = g->own_hi + 2 < fhi ? g->own_hi + 2 : fhi;
    }
    for (int k = 0; k < nz; k++) pmax[k] = 0.0;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = lo[2]; k < hi[2]; k++) {
        int32_t vmax = 0; /* bit pattern of the non-negative float max */
        float ux[CH], uy[CH], uz[CH];
        v4f u1[CH];
        chunk cm;
        const float Z = (float)(k + C.shift[2]) + 0.5f;
        for (int j = lo[1]; j < hi[1]; j++) {
            const float Y = (float)(j + C.shift[1]) + 0.5f;
            const ptrdiff_t row = (ptrdiff_t)j * g->sy + (ptrdiff_t)k * g->sz;
            const bool inner = j >= 0 && j < ny && k >= 0 && k < nz;
            for (int i0 = lo[0]; i0 < hi[0]; i0 += CH) {
                const int n = hi[0] - i0 < CH ? hi[0] - i0 : CH;
                const float *u = uc4_origin + 4 * (row + i0);
                for (int q = 0; q < n; q++) {
                    ux[q] = u[4 * q];
                    uy[q] = u[4 * q + 1];
                    uz[q] = u[4 * q + 2] + drift;
                }
                if (inner)
                    for (int q = 0; q < n; q++) {
                        const int i = i0 + q;
                        const float sp = sq__fsel((i >= 0) & (i < nx),
                                                  fabsf(ux[q]) + fabsf(uy[q]) + fabsf(uz[q]), 0.0f);
                        int32_t b;
                        memcpy(&b, &sp, sizeof b);
                        vmax = b > vmax ? b : vmax;
                    }
                for (int pass = 0; pass < (fwd ? 2 : 1); pass++) {
                    const float sg = pass ? hs : -hs;
                    int qa = 0, qb = n; /* the chunk's cells this pass computes */
                    if (pass == 1 && a == 0) {
                        qa = flo - i0 > 0 ? flo - i0 : 0;
                        qb = fhi - i0 < n ? fhi - i0 : n;
                    } else if (pass == 1 && ((a == 1 && (j < flo || j >= fhi)) ||
                                             (a == 2 && (k < flo || k >= fhi)))) {
                        qb = 0;
                    }
                    const int m = qb - qa;
                    if (m <= 0) continue;
                    for (int q = 0; q < m; q++) {
                        cm.fx[q] = ((float)(i0 + qa + q + C.shift[0]) + 0.5f) + sg * ux[qa + q];
                        cm.fy[q] = Y + sg * uy[qa + q];
                        cm.fz[q] = Z + sg * uz[qa + q];
                    }
                    locate_chunk(&C, &cm, m);
                    const ptrdiff_t o0 = row + i0 + qa;
                    float *ox = (pass ? df : db)[0] + o0, *oy = (pass ? df : db)[1] + o0,
                          *oz = (pass ? df : db)[2] + o0;
                    const float ss = pass ? s : -s;
                    for (int q = 0; q < m; q++)
                        u1[q] = vel_lerp(uc4_origin, cm.b[q], sy4, sz4, cm.fx[q], cm.fy[q],
                                         cm.fz[q]);
                    for (int q = 0; q < m; q++) {
                        ox[q] = ss * u1[q][0];
                        oy[q] = ss * u1[q][1];
                        oz[q] = ss * (u1[q][2] + drift);
                    }
                }
            }
        }
        float vm;
        memcpy(&vm, &vmax, sizeof vm);
        if (k >= 0 && k < nz) pmax[k] = (double)vm;
    }
    double m = 0.0;
    for (int k = 0; k < nz; k++) m = pmax[k] > m ? pmax[k] : m;
    return (float)m * s;
}

/* Makes the cached displacements valid for the current velocity, dt and drift. A decomposed
 * grid computes them on its widened slab (grid_dist.c), which also holds the velocity the
 * kernels read; its CFL number is the largest over the ranks. */
static sq_result ensure_displacements(sq_grid *g, float dt, float drift, bool fwd)
{
    bool valid = g->trace_valid && g->trace_version == g->vel_version &&
                 g->trace_dt == (double)dt && g->trace_drift == (double)drift &&
                 (g->trace_fwd || !fwd);
    /* a decomposed grid: one slab's change (its inflow face) is every slab's recompute */
    if (g->halo) valid = !sq__grid_dist_any(g, !valid);
    if (valid) return SQ_OK;
    sq__grid_dist_batch_begin(g); /* ghost planes and shared faces in one message */
    sq__grid_enforce_velocity(g);
    sq__grid_dist_sync_faces(g); /* faces held by two slabs: the upper slab's */
    sq__grid_dist_batch_end(g);
    sq_grid *w = g;
    if (g->halo) {
        g->trace_valid = false;
        const sq_result r = sq__grid_dist_widen(g, dt, &w);
        if (r != SQ_OK) return r;
    }
    float *uc4 = w->scratch[SQ__S_BLOCK];
    build_uc4(w, uc4);
    const ptrdiff_t c0 = sq__cidx(w, 0, 0, 0);
    float *db[3], *df[3];
    for (int a = 0; a < 3; a++) {
        db[a] = w->scratch[SQ__S_DISP + a] + c0;
        df[a] = w->scratch[SQ__S_DISP + 3 + a] + c0;
    }
    g->trace_cfl = cell_displacements(w, uc4 + 4 * c0, dt, drift, db, df, fwd);
    if (g->halo) { /* the copy's interior is slab and halo: the global max is the whole grid's */
        double c = (double)g->trace_cfl;
        sq__grid_dist_max(g, &c, 1);
        g->trace_cfl = (float)c;
    }
    g->trace_valid = true;
    g->trace_fwd = fwd;
    g->trace_version = g->vel_version;
    g->trace_dt = (double)dt;
    g->trace_drift = (double)drift;
    return SQ_OK;
}

/* ---- the two passes ------------------------------------------------------------------------------ */
/* Advects nf fields src[f] of lattice L (all in F's layout) into out[f], sharing the traces.
 * Pass 1: hat = F at the backward trace (semi-Lagrangian: the result). Pass 2 (MacCormack):
 * out = hat + (F - hat at the forward trace) / 2, limited to the range of the 8 values hat
 * was interpolated from. With rhi (MacCormack), pass 1 stores that range (low in out[f],
 * high in rhi[f]); without it pass 2 recomputes it from a second backward trace.
 * On the cell lattice solid cells keep their value and bit f of nonneg clamps field f at 0.
 * scalar0: scalar index of src[0] (src[f] is scalar scalar0 + f, for the inflow ghosts of
 * hat), or -1 for a velocity component. */
static void advect_fields(sq_grid *g, int L, int scalar0, const lat *F, int nf,
                          const float *const *src, float *const *hat, float *const *out,
                          float *const *rhi, bool mac, unsigned nonneg)
{
    const int mxn = F->m[0], myn = F->m[1], mzn = F->m[2];
    const ptrdiff_t sy = F->sy, sz = F->sz, csy = g->sy, csz = g->sz;
    const ptrdiff_t off = L == SQ__L_U ? 1 : L == SQ__L_V ? csy : L == SQ__L_W ? csz : 0;
    const ptrdiff_t c00 = sq__cidx(g, 0, 0, 0);
    const uint8_t *fl = g->flags + c00;
    const bool cell = L == SQ__L_CELL;
    const float *bx = g->scratch[SQ__S_DISP] + c00, *by = g->scratch[SQ__S_DISP + 1] + c00,
                *bz = g->scratch[SQ__S_DISP + 2] + c00;
    const float *fx = g->scratch[SQ__S_DISP + 3] + c00, *fy = g->scratch[SQ__S_DISP + 4] + c00,
                *fz = g->scratch[SQ__S_DISP + 5] + c00;
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    float *const *dst1 = mac ? hat : out;
    const bool store = mac && rhi; /* limiter range stored by pass 1 (low in out, high in rhi) */
    /* the samples each pass computes: all, or on a slab's widened copy the slab's (pass 2, or
     * a semi-Lagrangian pass 1) and those within trace_margin of them (MacCormack's pass 1) */
    int lo1[3] = {0, 0, 0}, hi1[3] = {mxn, myn, mzn}, lo2[3] = {0, 0, 0}, hi2[3] = {mxn, myn, mzn};
    if (g->own_only) {
        const int a = g->own_ax, M = mac ? g->trace_margin : 0;
        const int ohi = g->own_hi + (L - 1 == a ? 1 : 0); /* a face lattice: both end faces */
        lo1[a] = g->own_lo - M > 0 ? g->own_lo - M : 0;
        hi1[a] = ohi + M < hi1[a] ? ohi + M : hi1[a];
        lo2[a] = g->own_lo;
        hi2[a] = ohi < hi2[a] ? ohi : hi2[a];
    }
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = lo1[2]; k < hi1[2]; k++) {
        chunk cb;
        for (int j = lo1[1]; j < hi1[1]; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t q0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i0 = lo1[0]; i0 < hi1[0]; i0 += CH) {
                const int n = hi1[0] - i0 < CH ? hi1[0] - i0 : CH;
                trace_chunk(F, off, bx, by, bz, i0, n, j, k, q0, &cb);
                for (int f = 0; f < nf; f++) {
                    const float *o = src[f];
                    float *d = dst1[f] + r0 + i0;
                    if (store) {
                        float *rl = out[f] + r0 + i0, *rh = rhi[f] + r0 + i0;
                        for (int q = 0; q < n; q++)
                            d[q] = tri8_range(o, (ptrdiff_t)cb.b[q], sy, sz, cb.fx[q], cb.fy[q],
                                              cb.fz[q], &rl[q], &rh[q]);
                    } else {
                        for (int q = 0; q < n; q++)
                            d[q] = tri8(o, (ptrdiff_t)cb.b[q], sy, sz, cb.fx[q], cb.fy[q], cb.fz[q]);
                    }
                    if (!cell) continue;
                    if (!mac && ((nonneg >> f) & 1u))
                        for (int q = 0; q < n; q++) d[q] = d[q] < 0.0f ? 0.0f : d[q];
                    const float *oc = o + r0 + i0;
                    const uint8_t *fc = fl + q0 + i0;
                    for (int q = 0; q < n; q++) d[q] = sq__fsel(fc[q] & SQ__CF_SOLID, oc[q], d[q]);
                }
            }
        }
    }
    if (!mac) return;
    sq__grid_dist_batch_begin(g);
    for (int f = 0; f < nf; f++)
        sq__grid_fill_ghosts(g, hat[f], sy, sz, L, scalar0 >= 0 ? scalar0 + f : -1);
    sq__grid_dist_batch_end(g);
    const bool clamp = g->d.limiter == SQ_LIMITER_CLAMP;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int k = lo2[2]; k < hi2[2]; k++) {
        chunk cb, cf;
        float lo[CH], hi[CH];
        for (int j = lo2[1]; j < hi2[1]; j++) {
            const ptrdiff_t r0 = (ptrdiff_t)j * sy + (ptrdiff_t)k * sz;
            const ptrdiff_t q0 = (ptrdiff_t)j * csy + (ptrdiff_t)k * csz;
            for (int i0 = lo2[0]; i0 < hi2[0]; i0 += CH) {
                const int n = hi2[0] - i0 < CH ? hi2[0] - i0 : CH;
                if (!store) trace_chunk(F, off, bx, by, bz, i0, n, j, k, q0, &cb);
                trace_chunk(F, off, fx, fy, fz, i0, n, j, k, q0, &cf);
                for (int f = 0; f < nf; f++) {
                    const float *o = src[f], *ht = hat[f];
                    const float *oc = o + r0 + i0, *hc = ht + r0 + i0;
                    float *d = out[f] + r0 + i0;
                    if (store) {
                        const float *rh = rhi[f] + r0 + i0;
                        for (int q = 0; q < n; q++) {
                            lo[q] = d[q];
                            hi[q] = rh[q];
                        }
                    } else {
                        for (int q = 0; q < n; q++)
                            range8(o, (ptrdiff_t)cb.b[q], sy, sz, &lo[q], &hi[q]);
                    }
                    for (int q = 0; q < n; q++)
                        d[q] = tri8(ht, (ptrdiff_t)cf.b[q], sy, sz, cf.fx[q], cf.fy[q], cf.fz[q]);
                    if (clamp) {
                        for (int q = 0; q < n; q++) {
                            float v = hc[q] + 0.5f * (oc[q] - d[q]);
                            v = v > lo[q] ? v : lo[q];
                            d[q] = v < hi[q] ? v : hi[q];
                        }
                    } else {
                        for (int q = 0; q < n; q++) {
                            const float v = hc[q] + 0.5f * (oc[q] - d[q]);
                            d[q] = sq__fsel((v < lo[q]) | (v > hi[q]), hc[q], v);
                        }
                    }
                    if (!cell) continue;
                    if ((nonneg >> f) & 1u)
                        for (int q = 0; q < n; q++) d[q] = d[q] < 0.0f ? 0.0f : d[q];
                    const uint8_t *fc = fl + q0 + i0;
                    for (int q = 0; q < n; q++) d[q] = sq__fsel(fc[q] & SQ__CF_SOLID, oc[q], d[q]);
                }
            }
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

/* On a decomposed grid the kernels run on the widened slab w (its own velocity copy and
 * scratch) and the slab's samples are copied back; the faces a slab shares with its
 * neighbours are computed by both from the same data (across a split periodic axis the first
 * slab's face 0 is kept, as one rank's face n copies face 0). */
sq_result sq__grid_advect_velocity(sq_grid *g, float dt)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    sq_result r = ensure_displacements(g, dt, 0.0f, mac);
    if (r != SQ_OK) return r;
    sq_grid *w = sq__grid_dist_wide(g);
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &w->vel[c];
        lat F = make_lat(w, f->origin, f->sy, f->sz, c + 1);
        const float *src[1] = {f->origin};
        float *hat[1] = {scratch_origin(w, SQ__S_BLOCK, f)};
        float *out[1] = {scratch_origin(w, SQ__S_OUT + c, f)};
        float *rhi[1] = {scratch_origin(w, SQ__S_BLOCK + 1, f)};
        advect_fields(w, c + 1, -1, &F, 1, src, hat, out, rhi, mac, 0u);
    }
    sq__grid_dist_batch_begin(g); /* the shared faces with the ghost planes: one message */
    if (w == g) {
        for (int c = 0; c < 3; c++) swap_in(g, &g->vel[c], SQ__S_OUT + c);
    } else {
        for (int c = 0; c < 3; c++)
            sq__grid_dist_narrow(g, scratch_origin(w, SQ__S_OUT + c, &w->vel[c]), c + 1,
                                 g->vel[c].origin);
        sq__grid_dist_sync_faces(g);
    }
    g->stats.last_cfl = (double)g->trace_cfl;
    g->trace_valid = false;
    g->vel_version++;
    sq__grid_enforce_velocity(g);
    sq__grid_dist_batch_end(g);
    return SQ_OK;
}

/* Advects scalars s0 .. s0+count-1 with one trace (same dt and drift), in batches of two
 * (MacCormack: hats in scratch 0..1, limiter highs in 2..3) or three (semi-Lagrangian: hats
 * in 0..2); the results go to 10..12 and are swapped in. */
sq_result sq__grid_advect_scalars(sq_grid *g, int s0, int count, float dt, float drift)
{
    const bool mac = g->d.advection == SQ_ADVECT_MACCORMACK;
    sq_result r = ensure_displacements(g, dt, drift, mac);
    if (r != SQ_OK) return r;
    sq_grid *w = sq__grid_dist_wide(g);
    g->stats.last_cfl = (double)g->trace_cfl;
    const int bs = mac ? 2 : 3; /* MacCormack: hats in 0..1, limiter highs in 2..3 */
    /* a decomposed grid: groups of scalars widened in one exchange (their ghost planes toward
     * the neighbours come with the widened copy); the results' ghost planes in one message */
    const int gs = w == g ? count : sq__grid_dist_wide_scalars(g);
    sq__grid_dist_batch_begin(g);
    for (int g0 = s0; g0 < s0 + count; g0 += gs) {
        const int ng = s0 + count - g0 < gs ? s0 + count - g0 : gs;
        if (w != g) {
            for (int q = 0; q < ng; q++) {
                sq_field3 *f = &g->scalar[g0 + q];
                sq__grid_fill_ghosts_local(g, f->origin, f->sy, f->sz, SQ__L_CELL, g0 + q);
            }
            sq__grid_dist_widen_scalars(g, g0, ng); /* into w->scalar[0 .. ng) */
        }
        for (int b0 = g0; b0 < g0 + ng; b0 += bs) {
            const int nb = g0 + ng - b0 < bs ? g0 + ng - b0 : bs;
            const float *src[3];
            float *hat[3], *out[3], *rhi[3];
            unsigned nonneg = 0;
            if (w == g)
                for (int q = 0; q < nb; q++) {
                    sq_field3 *f = &g->scalar[b0 + q];
                    sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, b0 + q);
                }
            for (int q = 0; q < nb; q++) {
                sq_field3 *f = w == g ? &g->scalar[b0 + q] : &w->scalar[b0 - g0 + q];
                src[q] = f->origin;
                hat[q] = scratch_origin(w, SQ__S_BLOCK + q, f);
                out[q] = scratch_origin(w, SQ__S_OUT + q, f);
                rhi[q] = scratch_origin(w, SQ__S_BLOCK + 2 + q, f);
                if ((g->d.scalar_nonnegative >> (b0 + q)) & 1u) nonneg |= 1u << q;
            }
            lat F = make_lat(w, src[0], w->sy, w->sz, SQ__L_CELL);
            advect_fields(w, SQ__L_CELL, b0, &F, nb, src, hat, out, mac ? rhi : NULL, mac, nonneg);
            for (int q = 0; q < nb; q++) {
                sq_field3 *f = &g->scalar[b0 + q];
                if (w == g)
                    swap_in(g, f, SQ__S_OUT + q);
                else
                    sq__grid_dist_narrow(g, out[q], SQ__L_CELL, f->origin);
                sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, SQ__L_CELL, b0 + q);
            }
        }
    }
    sq__grid_dist_batch_end(g);
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
                        "scalar idx = %d; must be in 0..%d (scalar_count = %d)", idx,
                        g->d.scalar_count - 1, g->d.scalar_count);
    if (!isfinite(drift_w_mps))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, "grid", "drift_w_mps = %g; must be finite",
                        drift_w_mps);
    double t0 = sq_time_now();
    r = sq__grid_advect_scalars(g, idx, 1, (float)dt_s, (float)drift_w_mps);
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
    if (r != SQ_OK || g->d.scalar_count == 0) return r;
    double t0 = sq_time_now();
    r = sq__grid_advect_scalars(g, 0, g->d.scalar_count, (float)dt_s, 0.0f);
    g->stats.ms_advect += (sq_time_now() - t0) * 1e3;
    g->stats.advect_calls += g->d.scalar_count;
    return r;
}
