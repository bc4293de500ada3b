/* lbm_kernels.c — the fused D3Q15 collide-and-stream sweep (AA pattern, in place), the
 * periodic ghost exchange and small per-cell helpers.
 *
 * Collision (SPEC §5.2 with the corrected equilibrium and §5.3 recommendations), written in
 * two-relaxation-time form over the 7 pairs (i, opp(i)):
 *   feq+_i = w_i ρ (1 + 4.5 (c_i·u)² − 1.5 u·u),   feq−_i = 3 w_i ρ (c_i·u)
 *   f*_i = f_i − ω+ (f+_i − feq+_i) − ω− (f−_i − feq−_i) + S_i
 * BGK is the special case ω− = ω+ = 1/τ. TRT takes ω− from the magic number
 * Λ = (1/ω+ − ½)(1/ω− − ½). The Smagorinsky variant replaces τ by
 *   τ_eff = ½ (τ0 + sqrt(τ0² + 18 C² sqrt(2 Π:Π)/ρ)),  Π = Σ c c (f − feq)  (Hou et al. 1996)
 * per cell, keeping Λ. The body force g enters with Guo's scheme truncated to its first-order
 * part, which is exactly the SPEC §5.5 injection: u = j/ρ + g/2 in the equilibrium and
 * S_i = (1 − ω−/2) 3 w_i ρ (c_i·g), so each step adds ρg of momentum and no mass.
 *
 * Populations are stored shifted, h_i = f_i − w_i (the rest state is 0), which keeps float
 * round-off of the density and momentum near 1e-9 instead of 1e-7 per update.
 *
 * The sweep is branch-free on rows without solid cells; rows with some solid cells select the
 * bounce-back collision f*_i = f_opp(i) per cell; rows with only solid cells are skipped. */
#include <math.h>
#include <string.h>

#include "lbm_internal.h"

#define W0 (2.0f / 9.0f)
#define W1 (1.0f / 9.0f)
#define W7 (1.0f / 72.0f)

#if defined(__GNUC__) && !defined(__clang__)
#define LBM_IVDEP _Pragma("GCC ivdep")
#define LBM_INLINE static inline __attribute__((always_inline))
#else
#define LBM_INLINE static inline
#define LBM_IVDEP
#endif

/* Branch-free helpers (the auto-vectoriser refuses control flow; sqrtf carries an errno branch
 * under the default -fmath-errno). */
LBM_INLINE uint32_t f2u(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    return u;
}
LBM_INLINE float u2f(uint32_t u)
{
    float x;
    memcpy(&x, &u, sizeof x);
    return x;
}
/* m = all ones: a, m = 0: b (exact, no arithmetic on the values) */
LBM_INLINE float sel(uint32_t m, float a, float b) { return u2f((f2u(a) & m) | (f2u(b) & ~m)); }
/* sqrt(x) for x >= 1e-30: inverse square root from the exponent trick and two Newton steps
 * (relative error below 5e-6, ample for an eddy viscosity), times x */
LBM_INLINE float vsqrt(float x)
{
    float y = u2f(0x5f3759dfu - (f2u(x) >> 1));
    y = y * (1.5f - 0.5f * x * y * y);
    y = y * (1.5f - 0.5f * x * y * y);
    return x * y;
}

/* One pair (i, ī = opp(i)) of the TRT collision on shifted populations h = f − w.
 * cu = c_i·u, rw = w_i ρ, wb = w_i (δρ − 1.5 ρ u·u), sg = the source S_i, s/d = h_i + h_ī and
 * h_i − h_ī. heq+ = wb + 4.5 rw cu², heq− = 3 rw cu. */
LBM_INLINE void trt_pair(float fi, float fo, float s, float d, float cu, float rw, float wb,
                         float op, float om, float sg, float *oi, float *oo)
{
    const float feqp = wb + 4.5f * rw * cu * cu;
    const float feqm = 3.0f * rw * cu;
    const float a = op * (0.5f * s - feqp);
    const float b = om * (0.5f * d - feqm) - sg;
    *oi = fi - a - b;
    *oo = fo - a + b;
}

/* The row kernel. q[i] points at f_i of the row's first cell; f*_i goes to q[opp(i)] (in both
 * AA steps the location f*_i is written to is the one f_opp(i) was read from, so 15 pointers
 * serve for reading and writing). In place: each location is read and written by the same
 * iteration only (hence ivdep). masked: solid holds the row's flags; smag: per-cell
 * Smagorinsky rates. */
LBM_INLINE void row_kernel(float *const *q, const uint8_t *solid, int n,
                           const sq__lbm_kparams *p, const float kg[8], const int masked,
                           const int smag, const int force)
{
    float *r0 = q[0], *r1 = q[1], *r2 = q[2], *r3 = q[3], *r4 = q[4];
    float *r5 = q[5], *r6 = q[6], *r7 = q[7], *r8 = q[8], *r9 = q[9];
    float *r10 = q[10], *r11 = q[11], *r12 = q[12], *r13 = q[13], *r14 = q[14];
    const float hgx = 0.5f * p->g[0], hgy = 0.5f * p->g[1], hgz = 0.5f * p->g[2];
    const float op_c = p->omega_p, om_c = p->omega_m;
    const float d0 = p->d0, tau0 = p->tau0, sk = p->smag_k, lam = p->magic;
    /* kg[k] = 3 (c·g) w for pair k (w = 1, weights applied with rho below), k = 0..6;
     * kg[7] = the constant source factor */
    const float g1 = kg[0], g3 = kg[1], g5 = kg[2], g7 = kg[3], g9 = kg[4], g11 = kg[5];
    const float g13 = kg[6], sf_c = kg[7];
    LBM_IVDEP
    for (int x = 0; x < n; x++) {
        const float f0 = r0[x], f1 = r1[x], f2 = r2[x], f3 = r3[x], f4 = r4[x];
        const float f5 = r5[x], f6 = r6[x], f7 = r7[x], f8 = r8[x], f9 = r9[x];
        const float f10 = r10[x], f11 = r11[x], f12 = r12[x], f13 = r13[x], f14 = r14[x];
        const float s1 = f1 + f2, s3 = f3 + f4, s5 = f5 + f6, s7 = f7 + f8;
        const float s9 = f9 + f10, s11 = f11 + f12, s13 = f13 + f14;
        const float d1 = f1 - f2, d3 = f3 - f4, d5 = f5 - f6, d7 = f7 - f8;
        const float d9 = f9 - f10, d11 = f11 - f12, d13 = f13 - f14;
        /* shifted populations: ρ = 1 + Σ h_i keeps the small density fluctuations exact */
        const float drho = f0 + (s1 + s3) + (s5 + s7) + (s9 + s11) + s13;
        const float rho = 1.0f + drho;
        const float ir = 1.0f / rho;
        const float jx = d1 + d7 + d9 + d11 - d13;
        const float jy = d3 + d7 + d9 - d11 + d13;
        const float jz = d5 + d7 - d9 + d11 + d13;
        const float ux = force ? jx * ir + hgx : jx * ir;
        const float uy = force ? jy * ir + hgy : jy * ir;
        const float uz = force ? jz * ir + hgz : jz * ir;
        const float usq = ux * ux + uy * uy + uz * uz;
        float op = op_c, om = om_c, sf = sf_c;
        if (smag) {
            const float sd = s7 + s9 + s11 + s13;
            /* Σ w c_a c_a = 1/3 cancels against ρ/3 up to δρ/3 */
            const float drho3 = drho * (1.0f / 3.0f);
            const float pxx = s1 + sd - drho3 - rho * ux * ux;
            const float pyy = s3 + sd - drho3 - rho * uy * uy;
            const float pzz = s5 + sd - drho3 - rho * uz * uz;
            const float pxy = (s7 + s9) - (s11 + s13) - rho * ux * uy;
            const float pxz = (s7 + s11) - (s9 + s13) - rho * ux * uz;
            const float pyz = (s7 + s13) - (s9 + s11) - rho * uy * uz;
            const float qn = pxx * pxx + pyy * pyy + pzz * pzz +
                            2.0f * (pxy * pxy + pxz * pxz + pyz * pyz);
            const float xs = sk * vsqrt(2.0f * qn + 1e-30f) * ir;
            /* τ_eff − ½ without cancellation */
            const float d = d0 + xs / (2.0f * (vsqrt(tau0 * tau0 + xs) + tau0));
            op = 1.0f / (0.5f + d);
            om = d / (0.5f * d + lam);
            sf = 1.0f - 0.5f * om;
        }
        const float base = drho - 1.5f * rho * usq;
        const float rw1 = W1 * rho, rw7 = W7 * rho, wb1 = W1 * base, wb7 = W7 * base;
        /* the source S_i = sf 3 w_i ρ (c_i·g); exactly 0 without a body force */
        const float sr1 = force ? sf * rw1 : 0.0f, sr7 = force ? sf * rw7 : 0.0f;
        float o0 = f0 - op * (f0 - W0 * base);
        float o1, o2, o3, o4, o5, o6, o7, o8, o9, o10, o11, o12, o13, o14;
        trt_pair(f1, f2, s1, d1, ux, rw1, wb1, op, om, sr1 * g1, &o1, &o2);
        trt_pair(f3, f4, s3, d3, uy, rw1, wb1, op, om, sr1 * g3, &o3, &o4);
        trt_pair(f5, f6, s5, d5, uz, rw1, wb1, op, om, sr1 * g5, &o5, &o6);
        trt_pair(f7, f8, s7, d7, ux + uy + uz, rw7, wb7, op, om, sr7 * g7, &o7, &o8);
        trt_pair(f9, f10, s9, d9, ux + uy - uz, rw7, wb7, op, om, sr7 * g9, &o9, &o10);
        trt_pair(f11, f12, s11, d11, ux - uy + uz, rw7, wb7, op, om, sr7 * g11, &o11, &o12);
        trt_pair(f13, f14, s13, d13, uy + uz - ux, rw7, wb7, op, om, sr7 * g13, &o13, &o14);
        if (masked) {
            /* solid cell: bounce-back collision f*_i = f_opp(i), a no-op in the AA layout */
            const uint32_t m = 0u - (uint32_t)solid[x]; /* flags are 0 or 1 */
            o0 = sel(m, f0, o0);
            o1 = sel(m, f2, o1);
            o2 = sel(m, f1, o2);
            o3 = sel(m, f4, o3);
            o4 = sel(m, f3, o4);
            o5 = sel(m, f6, o5);
            o6 = sel(m, f5, o6);
            o7 = sel(m, f8, o7);
            o8 = sel(m, f7, o8);
            o9 = sel(m, f10, o9);
            o10 = sel(m, f9, o10);
            o11 = sel(m, f12, o11);
            o12 = sel(m, f11, o12);
            o13 = sel(m, f14, o13);
            o14 = sel(m, f13, o14);
        }
        r0[x] = o0;
        r2[x] = o1;
        r1[x] = o2;
        r4[x] = o3;
        r3[x] = o4;
        r6[x] = o5;
        r5[x] = o6;
        r8[x] = o7;
        r7[x] = o8;
        r10[x] = o9;
        r9[x] = o10;
        r12[x] = o11;
        r11[x] = o12;
        r14[x] = o13;
        r13[x] = o14;
    }
}

static void row_fluid(float *const *q, const uint8_t *solid, int n, const sq__lbm_kparams *p,
                       const float kg[8], int force)
{
    if (force)
        row_kernel(q, solid, n, p, kg, 0, 0, 1);
    else
        row_kernel(q, solid, n, p, kg, 0, 0, 0);
}
static void row_mixed(float *const *q, const uint8_t *solid, int n, const sq__lbm_kparams *p,
                       const float kg[8], int force)
{
    if (force)
        row_kernel(q, solid, n, p, kg, 1, 0, 1);
    else
        row_kernel(q, solid, n, p, kg, 1, 0, 0);
}
static void row_fluid_smag(float *const *q, const uint8_t *solid, int n, const sq__lbm_kparams *p,
                            const float kg[8], int force)
{
    if (force)
        row_kernel(q, solid, n, p, kg, 0, 1, 1);
    else
        row_kernel(q, solid, n, p, kg, 0, 1, 0);
}
static void row_mixed_smag(float *const *q, const uint8_t *solid, int n, const sq__lbm_kparams *p,
                            const float kg[8], int force)
{
    if (force)
        row_kernel(q, solid, n, p, kg, 1, 1, 1);
    else
        row_kernel(q, solid, n, p, kg, 1, 1, 0);
}

void sq__lbm_sweep(sq_lbm *l, int parity, const sq__lbm_kparams *p)
{
    sq__lbm_sweep_planes(l, parity, p, 0, l->nz);
}

void sq__lbm_sweep_planes(sq_lbm *l, int parity, const sq__lbm_kparams *p, int z0, int z1)
{
    const int nt = sq_context_threads(l->ctx);
    const int nx = l->nx, ny = l->ny;
    const int64_t rows = (int64_t)ny * z1, r0 = (int64_t)ny * z0;
    float *const f = l->f;
    const int64_t S = l->stride;
    const uint8_t *const cls = l->row_class;
    const uint8_t *const solid = l->solid;
    /* 3 (c·g) per pair and the constant source factor */
    const float gx = p->g[0], gy = p->g[1], gz = p->g[2];
    const float kg[8] = {3.0f * gx,
                         3.0f * gy,
                         3.0f * gz,
                         3.0f * (gx + gy + gz),
                         3.0f * (gx + gy - gz),
                         3.0f * (gx - gy + gz),
                         3.0f * (gy + gz - gx),
                         p->src};
    /* even step: f_i from slot i of the cell; odd step: from slot opp(i) of x − c_i */
    int64_t roff[SQ_LBM_Q];
    for (int i = 0; i < SQ_LBM_Q; i++)
        roff[i] = parity == 0 ? (int64_t)i * S : (int64_t)sq__lbm_opp[i] * S - l->off[i];
    const int smag = p->smagorinsky;
    const int force = gx != 0.0f || gy != 0.0f || gz != 0.0f;
    const int64_t work = (rows - r0) * nx;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(work > 16384))
    for (int64_t r = r0; r < rows; r++) {
        const uint8_t c = cls[r];
        if (c == SQ_LBM_ROW_SOLID) continue;
        const int y = (int)(r % ny), z = (int)(r / ny);
        const int64_t base = sq__lbm_cell(l, 0, y, z);
        float *q[SQ_LBM_Q];
        for (int i = 0; i < SQ_LBM_Q; i++) q[i] = f + roff[i] + base;
        if (c == SQ_LBM_ROW_FLUID) {
            if (smag)
                row_fluid_smag(q, solid + base, nx, p, kg, force);
            else
                row_fluid(q, solid + base, nx, p, kg, force);
        } else {
            if (smag)
                row_mixed_smag(q, solid + base, nx, p, kg, force);
            else
                row_mixed(q, solid + base, nx, p, kg, force);
        }
    }
}

/* ---- periodic ghost exchange ----------------------------------------------------------------
 * natural layout (parity 0), after an odd step: populations that left through a face sit in
 * the ghost layer; fold them onto the opposite interior layer (axes z, y, x in turn).
 * swapped layout (parity 1), after an even step: the post-collision populations about to leave
 * are in the interior; copy them into the ghost layer beyond the opposite face, where the odd
 * step reads them (axes x, y, z in turn). An axis folded/filled before another has its ghost
 * cells included in the later one's range, which carries the edge and corner populations. */
static void fold_axis(sq_lbm *l, int a, int parity)
{
    const int nt = sq_context_threads(l->ctx);
    const int n[3] = {l->nx, l->ny, l->nz};
    float *const f = l->f;
    const int64_t S = l->stride;
    /* ranges of the other axes: padded where that axis came earlier in the order */
    int lo[3], hi[3];
    for (int b = 0; b < 3; b++) {
        lo[b] = b < a ? -1 : 0;
        hi[b] = b < a ? n[b] + 1 : n[b];
    }
    /* the 10 slots crossing this axis: destination and source layer along a */
    int slot[10], dst_a[10], src_a[10], ns = 0;
    for (int j = 1; j < SQ_LBM_Q; j++) {
        const int cj = sq__lbm_c[j][a];
        if (cj == 0) continue;
        slot[ns] = j;
        if (parity == 0) {
            dst_a[ns] = cj > 0 ? 0 : n[a] - 1;
            src_a[ns] = cj > 0 ? n[a] : -1;
        } else {
            dst_a[ns] = cj < 0 ? -1 : n[a];
            src_a[ns] = cj < 0 ? n[a] - 1 : 0;
        }
        ns++;
    }
    /* outer loop over the slowest remaining axis, rows of x (or single cells for a = x) inside */
    const int ob = a == 2 ? 1 : 2;         /* outer axis */
    const int64_t work = (int64_t)(hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]) / n[a];
    const int olo = lo[ob], ohi = hi[ob];
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(work > 65536))
    for (int o = olo; o < ohi; o++) {
        for (int k = 0; k < ns; k++) {
            float *const fj = f + (int64_t)slot[k] * S;
            if (a == 0) {
                for (int y = lo[1]; y < hi[1]; y++)
                    fj[sq__lbm_cell(l, dst_a[k], y, o)] = fj[sq__lbm_cell(l, src_a[k], y, o)];
            } else {
                const int nxr = hi[0] - lo[0];
                float *d = a == 1 ? fj + sq__lbm_cell(l, lo[0], dst_a[k], o)
                                  : fj + sq__lbm_cell(l, lo[0], o, dst_a[k]);
                const float *sp = a == 1 ? fj + sq__lbm_cell(l, lo[0], src_a[k], o)
                                         : fj + sq__lbm_cell(l, lo[0], o, src_a[k]);
                for (int x = 0; x < nxr; x++) d[x] = sp[x];
            }
        }
    }
}

void sq__lbm_fold_periodic(sq_lbm *l, int parity)
{
    for (int s = 0; s < 3; s++) {
        const int a = parity == 0 ? 2 - s : s;
        if (a == 2 && l->zdist) continue; /* slab faces: sq__lbm_boundaries, lbm_dist.c */
        if (l->periodic[a]) fold_axis(l, a, parity);
    }
}

/* One row of macroscopic fields: q[i] points at f_i of the row's first cell. */
static void macro_row(const float *const *q, const uint8_t *restrict solid, int nx,
                      const float gh[3], float rho_scale, float u_scale, float *restrict ro,
                      float *restrict uo, float *restrict vo, float *restrict wo)
{
    const float *restrict q0 = q[0], *restrict q1 = q[1], *restrict q2 = q[2];
    const float *restrict q3 = q[3], *restrict q4 = q[4], *restrict q5 = q[5];
    const float *restrict q6 = q[6], *restrict q7 = q[7], *restrict q8 = q[8];
    const float *restrict q9 = q[9], *restrict q10 = q[10], *restrict q11 = q[11];
    const float *restrict q12 = q[12], *restrict q13 = q[13], *restrict q14 = q[14];
    const float gx = gh[0], gy = gh[1], gz = gh[2];
    for (int x = 0; x < nx; x++) {
        const float s1 = q1[x] + q2[x], s3 = q3[x] + q4[x], s5 = q5[x] + q6[x];
        const float s7 = q7[x] + q8[x], s9 = q9[x] + q10[x];
        const float s11 = q11[x] + q12[x], s13 = q13[x] + q14[x];
        const float d1 = q1[x] - q2[x], d3 = q3[x] - q4[x], d5 = q5[x] - q6[x];
        const float d7 = q7[x] - q8[x], d9 = q9[x] - q10[x];
        const float d11 = q11[x] - q12[x], d13 = q13[x] - q14[x];
        const float rho = 1.0f + (q0[x] + (s1 + s3) + (s5 + s7) + (s9 + s11) + s13);
        const float ir = 1.0f / rho;
        const float keep = 1.0f - (float)solid[x]; /* flags are 0 or 1 */
        ro[x] = keep * rho * rho_scale;
        uo[x] = keep * ((d1 + d7 + d9 + d11 - d13) * ir + gx) * u_scale;
        vo[x] = keep * ((d3 + d7 + d9 - d11 + d13) * ir + gy) * u_scale;
        wo[x] = keep * ((d5 + d7 - d9 + d11 + d13) * ir + gz) * u_scale;
    }
}

/* Macroscopic fields of all interior cells (vectorised rows). parity 0: pre-collision
 * populations, u = j/ρ + g/2; parity 1: post-collision, u = j/ρ − g/2 (gh holds ±g/2).
 * Outputs (x fastest, nx*ny*nz): density × rho_scale, velocity × u_scale; 0 in solid cells. */
void sq__lbm_macro(const sq_lbm *l, int parity, const float gh[3], float rho_scale,
                   float u_scale, float *rho_out, float *ux_out, float *uy_out, float *uz_out)
{
    const int nt = sq_context_threads(l->ctx);
    const int nx = l->nx, ny = l->ny;
    const int64_t rows = (int64_t)ny * l->nz;
    const int64_t S = l->stride;
    int64_t so[SQ_LBM_Q];
    for (int i = 0; i < SQ_LBM_Q; i++) so[i] = (int64_t)(parity == 0 ? i : sq__lbm_opp[i]) * S;
    const int64_t work = rows * nx;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(work > 32768))
    for (int64_t r = 0; r < rows; r++) {
        const int y = (int)(r % ny), z = (int)(r / ny);
        const int64_t base = sq__lbm_cell(l, 0, y, z);
        const float *q[SQ_LBM_Q];
        for (int i = 0; i < SQ_LBM_Q; i++) q[i] = l->f + so[i] + base;
        macro_row(q, l->solid + base, nx, gh, rho_scale, u_scale, rho_out + r * nx,
                  ux_out + r * nx, uy_out + r * nx, uz_out + r * nx);
    }
}

void sq__lbm_plane_velocity(const sq_lbm *l, int parity, const float gh[3], int z,
                            double u_sum[2], int64_t *fluid)
{
    const int nx = l->nx;
    const int64_t S = l->stride;
    int64_t so[SQ_LBM_Q];
    for (int i = 0; i < SQ_LBM_Q; i++) so[i] = (int64_t)(parity == 0 ? i : sq__lbm_opp[i]) * S;
    double sx = 0, sy = 0;
    int64_t n = 0;
    for (int y = 0; y < l->ny; y++) {
        for (int x0 = 0; x0 < nx; x0 += 256) {
            const int m = nx - x0 < 256 ? nx - x0 : 256;
            const int64_t base = sq__lbm_cell(l, x0, y, z);
            const float *q[SQ_LBM_Q];
            for (int i = 0; i < SQ_LBM_Q; i++) q[i] = l->f + so[i] + base;
            float ro[256], uo[256], vo[256], wo[256];
            macro_row(q, l->solid + base, m, gh, 1.0f, 1.0f, ro, uo, vo, wo);
            for (int x = 0; x < m; x++) {
                sx += (double)uo[x];
                sy += (double)vo[x];
                n += l->solid[base + x] == 0;
            }
        }
    }
    u_sum[0] = sx;
    u_sum[1] = sy;
    *fluid = n;
}

void sq__lbm_gather(const sq_lbm *l, int64_t c, int parity, double f[SQ_LBM_Q])
{
    for (int i = 0; i < SQ_LBM_Q; i++) {
        const int slot = parity == 0 ? i : sq__lbm_opp[i];
        f[i] = (double)l->f[(int64_t)slot * l->stride + c] + sq__lbm_w[i];
    }
}

void sq__lbm_scatter(sq_lbm *l, int64_t c, int parity, const double f[SQ_LBM_Q])
{
    for (int i = 0; i < SQ_LBM_Q; i++) {
        const int slot = parity == 0 ? i : sq__lbm_opp[i];
        l->f[(int64_t)slot * l->stride + c] = (float)(f[i] - sq__lbm_w[i]);
    }
}

void sq__lbm_feq(double rho, const double u[3], double feq[SQ_LBM_Q])
{
    const double usq = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
    for (int i = 0; i < SQ_LBM_Q; i++) {
        const double cu =
            sq__lbm_c[i][0] * u[0] + sq__lbm_c[i][1] * u[1] + sq__lbm_c[i][2] * u[2];
        feq[i] = sq__lbm_w[i] * rho * (1.0 + 3.0 * cu + 4.5 * cu * cu - 1.5 * usq);
    }
}
