/* sph_passes.c — the per-step passes of the SPH solver (SPEC §7.6 and §7.8):
 *   sort     cell ids, counting sort, reorder of the structure of arrays (§7.6 steps 2–6);
 *   density  neighbour lists from the 27 neighbour cells (3 x-contiguous cells per row, so 9
 *            ranges), mirror images at walls, ρ_i = Σ_j m W_ij including j = i (§7.2 ⚠ 1),
 *            pressure from the EOS (eq. 3.38 or Tait);
 *   strain   renormalisation matrix L_i = (Σ_j V_j (x_j − x_i) ⊗ ∇W_ij)⁻¹ (Bonet & Lok 1999),
 *            velocity gradient (∇v)_i = [Σ_j V_j (v_j − v_i) ⊗ ∇W_ij] L_i (eq. 3.34 with the
 *            correction), D = ½(∇v + ∇vᵀ), |γ̇| = sqrt(2 D:D) (eq. 3.30 as corrected in the SPEC),
 *            μ(|γ̇|), τ = 2 μ D (eq. 3.56 with the factor 2);
 *   forces   a_i = −Σ m (p_i/ρ_i² + p_j/ρ_j²) ∇̃W + Σ m (τ_i + τ_j)/(ρ_i ρ_j) · ∇̃W + g
 *            (eqs 3.44, 3.57) with ∇̃W = ½(L_i + L_j) ∇W; Newtonian viscosity by the
 *            viscosity-kernel Laplacian (eq. 3.39, symmetrised) or Morris's form (cubic set);
 *            XSPH ε Σ 2m/(ρ_i + ρ_j) (v_j − v_i) W_ij (eq. 3.47).
 * Every loop writes only its own particle i, so results do not depend on the thread count.
 * Neighbour-list entries are j | mask << 29, mask = the axes across whose walls j is mirrored;
 * plain entries come first (nb_plain of them), image entries after.
 * With AVX-512 the neighbour loops run 16 lanes wide (see SQ__SPH_AVX512 below): the density
 * pass packs each cell's 27-cell candidates once and appends the accepted ones with a compress;
 * strain and forces read the j-side data from one packed 32-byte record per particle (rec,
 * written by the density pass) with row loads and transposes. Same per-pair arithmetic; only
 * the order of the sums over neighbours differs from the portable loops. */
#include <stdlib.h>
#include <string.h>

/* Runtime dispatch (a portable build, SQ_NATIVE=OFF, on x86-64 with GCC: SQ_SPH_DISPATCH): this
 * file is compiled a second time for x86-64-v4 (sph_passes_v4.c) with the three passes renamed
 * (*_v4) and without the functions that are not per-pair loops; the portable passes call the
 * *_v4 ones when the CPU has AVX-512 (sq__sph_isa_v4). */
#if defined(SQ__SPH_VARIANT_V4)
#define sq__sph_pass_density sq__sph_pass_density_v4
#define sq__sph_pass_strain sq__sph_pass_strain_v4
#define sq__sph_pass_forces sq__sph_pass_forces_v4
#endif
#include "solvers/sph/sph_internal.h"

/* The hot block functions are compiled twice on x86-64 Linux (AVX2 and baseline) and the
 * loader picks the one the CPU supports. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(__SANITIZE_ADDRESS__) && !defined(SQ_SPH_NO_CLONES)
#define SQ__SPH_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define SQ__SPH_CLONES
#endif
#define SQ__SPH_BLOCK 256
#define SQ__SPH_CHUNK 64 /* neighbours gathered per vector loop */

#if defined(__GNUC__)
#define SQ__INLINE static inline __attribute__((always_inline))
#else
#define SQ__INLINE static inline
#endif

/* With AVX-512 (the default -march=native build on such a CPU, or sph_passes_v4.c in a portable
 * build, chosen at run time) the hot neighbour loops are
 * written with intrinsics: 16 candidates or neighbours per vector, the accepted neighbours
 * appended with a compress, and the j-side data gathered from the packed record (rec). The
 * arithmetic per pair is the scalar code's, operation by operation (no FMA contraction, exact
 * division and square root); only the order of the sums over neighbours differs (16 lanes).
 * Otherwise (and under the sanitizers) the portable loops below are used. */
#if defined(__AVX512F__) && defined(__AVX512VL__) && !defined(SQ_SPH_NO_AVX512)
#include <immintrin.h>
#define SQ__SPH_AVX512 1
#else
#define SQ__SPH_AVX512 0
#endif

#if SQ__SPH_AVX512
#undef SQ__SPH_CLONES /* compiled for this CPU: no AVX2/baseline clones */
#define SQ__SPH_CLONES
#define V16 __m512
#define VADD _mm512_add_ps
#define VSUB _mm512_sub_ps
#define VMUL _mm512_mul_ps
#define VSET1 _mm512_set1_ps

SQ__INLINE __mmask16 v_live(uint32_t left)
{
    return left >= 16u ? (__mmask16)0xFFFFu : (__mmask16)((1u << left) - 1u);
}
/* sq__sph_sqrt: sqrt of max(x, 0) (NaN -> 0, as the scalar x > 0 ? x : 0) */
SQ__INLINE V16 v_sqrt_pos(V16 x) { return _mm512_sqrt_ps(_mm512_max_ps(x, _mm512_setzero_ps())); }
/* sq__sph_w_cubic */
SQ__INLINE V16 v_w_cubic(const sq__sph_kern *k, V16 r)
{
    const V16 s = VMUL(VMUL(VSET1(2.0f), r), VSET1(k->inv_H));
    const V16 in = VMUL(VSET1(k->cubic_c),
                        VADD(VSUB(VSET1(1.0f), VMUL(VMUL(VSET1(1.5f), s), s)),
                             VMUL(VMUL(VMUL(VSET1(0.75f), s), s), s)));
    const V16 t = VSUB(VSET1(2.0f), s);
    const V16 out = VMUL(VMUL(VMUL(VSET1(k->cubic_c * 0.25f), t), t), t);
    const __mmask16 m1 = _mm512_cmp_ps_mask(s, VSET1(1.0f), _CMP_LT_OQ);
    const __mmask16 m2 = _mm512_cmp_ps_mask(s, VSET1(2.0f), _CMP_LT_OQ);
    return _mm512_mask_blend_ps(m1, _mm512_maskz_mov_ps(m2, out), in);
}
/* sq__sph_w_poly6 */
SQ__INLINE V16 v_w_poly6(const sq__sph_kern *k, V16 r2)
{
    V16 w = VSUB(VSET1(1.0f), VMUL(r2, VSET1(k->inv_H2)));
    w = _mm512_max_ps(w, _mm512_setzero_ps());
    return VMUL(VMUL(VMUL(VSET1(k->poly6_c), w), w), w);
}
SQ__INLINE V16 v_w(const sq__sph_kern *k, V16 r, V16 r2, const int cubic)
{
    return cubic ? v_w_cubic(k, r) : v_w_poly6(k, r2);
}
/* sq__sph_gradf_rk */
SQ__INLINE V16 v_gradf(const sq__sph_kern *k, V16 r, V16 inv_r, const int cubic)
{
    if (cubic) {
        const V16 s = VMUL(VMUL(VSET1(2.0f), r), VSET1(k->inv_H));
        const V16 t = _mm512_max_ps(VSUB(VSET1(2.0f), s), _mm512_setzero_ps());
        const V16 inner = VADD(VMUL(VSET1(-3.0f), s), VMUL(VMUL(VSET1(2.25f), s), s));
        const V16 outer = VMUL(VMUL(VSET1(-0.75f), t), t);
        const __mmask16 m1 = _mm512_cmp_ps_mask(s, VSET1(1.0f), _CMP_LT_OQ);
        return VMUL(VMUL(VSET1(k->cubic_g_c), _mm512_mask_blend_ps(m1, outer, inner)), inv_r);
    }
    const V16 w = _mm512_max_ps(VSUB(VSET1(1.0f), VMUL(r, VSET1(k->inv_H))), _mm512_setzero_ps());
    return VMUL(VMUL(VMUL(VSET1(-k->spiky_g_c), w), w), inv_r);
}
/* inv_dist: 1/sqrt(max(r², 1e-30)), 0 at r² = 0 */
SQ__INLINE V16 v_inv_dist(V16 r2)
{
    const V16 q = _mm512_div_ps(VSET1(1.0f), _mm512_sqrt_ps(_mm512_max_ps(r2, VSET1(1e-30f))));
    return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(r2, _mm512_setzero_ps(), _CMP_GT_OQ), q);
}
/* wrap1 (h = +inf on non-periodic axes) */
SQ__INLINE V16 v_wrap(V16 d, float h, float L)
{
    d = _mm512_mask_sub_ps(d, _mm512_cmp_ps_mask(d, VSET1(h), _CMP_GT_OQ), d, VSET1(L));
    return _mm512_mask_add_ps(d, _mm512_cmp_ps_mask(d, VSET1(-h), _CMP_LT_OQ), d, VSET1(L));
}
SQ__INLINE float v_sum(V16 v) { return _mm512_reduce_add_ps(v); }

/* The record of lanes beyond the list: so far away that every kernel term is exactly zero. */
static const float sq__sph_far_rec[SQ__SPH_REC] __attribute__((aligned(32))) = {
    1e18f, 1e18f, 1e18f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};

/* The packed records (x y z V vx vy vz p/ρ²) of the plain list entries e[0..n), n ≤ 16, as
 * eight field vectors f[0..7]: sixteen 32-byte loads and an 8×8 transpose per 256-bit half
 * (24 shuffles) instead of eight 16-element gathers. Lane l holds entry
 * (0 1 2 3 8 9 10 11 4 5 6 7 12 13 14 15)[l]; lanes ≥ n
 * read sq__sph_far_rec. */
SQ__INLINE void v_load_recs(const float *restrict P, const uint32_t *restrict e, int n, V16 f[8])
{
    V16 z[8], t[8], u[8];
    for (int k = 0; k < 8; k++) {
        const float *lo = k < n ? P + SQ__SPH_REC * (size_t)e[k] : sq__sph_far_rec;
        const float *hi = k + 8 < n ? P + SQ__SPH_REC * (size_t)e[k + 8] : sq__sph_far_rec;
        z[k] = _mm512_castpd_ps(_mm512_insertf64x4(_mm512_castps_pd(_mm512_castps256_ps512(
                                                       _mm256_load_ps(lo))),
                                                   _mm256_castps_pd(_mm256_load_ps(hi)), 1));
    }
    for (int k = 0; k < 4; k++) {
        t[2 * k] = _mm512_unpacklo_ps(z[2 * k], z[2 * k + 1]);
        t[2 * k + 1] = _mm512_unpackhi_ps(z[2 * k], z[2 * k + 1]);
    }
    for (int h = 0; h < 2; h++) { /* entries 0–3 / 8–11 (h = 0) and 4–7 / 12–15 (h = 1) */
        u[4 * h + 0] = _mm512_shuffle_ps(t[4 * h], t[4 * h + 2], 0x44);     /* x, vx */
        u[4 * h + 1] = _mm512_shuffle_ps(t[4 * h], t[4 * h + 2], 0xEE);     /* y, vy */
        u[4 * h + 2] = _mm512_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0x44); /* z, vz */
        u[4 * h + 3] = _mm512_shuffle_ps(t[4 * h + 1], t[4 * h + 3], 0xEE); /* V, p/ρ² */
    }
    for (int c = 0; c < 4; c++) {
        f[c] = _mm512_shuffle_f32x4(u[c], u[4 + c], _MM_SHUFFLE(2, 0, 2, 0));
        f[4 + c] = _mm512_shuffle_f32x4(u[c], u[4 + c], _MM_SHUFFLE(3, 1, 3, 1));
    }
}
/* Lane sums of 16 vectors at once (lane k of the result = Σ v[k]) in a fixed tree: 45
 * shuffles and adds instead of 16 separate reductions. */
SQ__INLINE V16 v_sum16(const V16 v[16])
{
    V16 t[8], u[4], w[2];
    for (int k = 0; k < 8; k++) /* [a0+a2 b0+b2 a1+a3 b1+b3] per 128-bit lane */
        t[k] = VADD(_mm512_unpacklo_ps(v[2 * k], v[2 * k + 1]),
                    _mm512_unpackhi_ps(v[2 * k], v[2 * k + 1]));
    for (int k = 0; k < 4; k++) { /* [a b c d] partial sums per 128-bit lane */
        const __m512d a = _mm512_castps_pd(t[2 * k]), b = _mm512_castps_pd(t[2 * k + 1]);
        u[k] = VADD(_mm512_castpd_ps(_mm512_unpacklo_pd(a, b)),
                    _mm512_castpd_ps(_mm512_unpackhi_pd(a, b)));
    }
    for (int k = 0; k < 2; k++) /* across 128-bit lanes */
        w[k] = VADD(_mm512_shuffle_f32x4(u[2 * k], u[2 * k + 1], _MM_SHUFFLE(2, 0, 2, 0)),
                    _mm512_shuffle_f32x4(u[2 * k], u[2 * k + 1], _MM_SHUFFLE(3, 1, 3, 1)));
    return VADD(_mm512_shuffle_f32x4(w[0], w[1], _MM_SHUFFLE(2, 0, 2, 0)),
                _mm512_shuffle_f32x4(w[0], w[1], _MM_SHUFFLE(3, 1, 3, 1)));
}
#endif

#if !defined(SQ__SPH_VARIANT_V4) /* compiled once: not per-pair loops */
/* ---- kernels for tests ------------------------------------------------------------------- */

void sq__sph_kern_init(sq__sph_kern *k, float H, int cubic)
{
    const double h = H, pi = 3.14159265358979323846;
    memset(k, 0, sizeof *k);
    k->cubic = cubic;
    k->H = H;
    k->H2 = H * H;
    k->inv_H = (float)(1.0 / h);
    k->inv_H2 = (float)(1.0 / (h * h));
    k->poly6_c = (float)(315.0 / (64.0 * pi * h * h * h));
    k->spiky_w_c = (float)(15.0 / (pi * h * h * h));
    k->spiky_g_c = (float)(45.0 / (pi * h * h * h * h));
    k->visc_w_c = (float)(15.0 / (2.0 * pi * h * h * h));
    k->visc_lap_c = (float)(45.0 / (pi * h * h * h * h * h));
    const double ell = 0.5 * h;
    k->cubic_c = (float)(1.0 / (pi * ell * ell * ell));
    k->cubic_g_c = (float)(1.0 / (pi * ell * ell * ell * ell));
    k->ell = (float)ell;
    k->ell2 = (float)(ell * ell);
}

float sq__sph_kernel_w(const sq__sph_kern *k, sq__sph_kernel_fn fn, float r)
{
    switch (fn) {
    case SQ__SPH_W_POLY6: return sq__sph_w_poly6(k, r * r);
    case SQ__SPH_W_SPIKY: return sq__sph_w_spiky(k, r);
    case SQ__SPH_W_VISC: return sq__sph_w_visc(k, r);
    case SQ__SPH_W_CUBIC: return sq__sph_w_cubic(k, r);
    }
    return 0.0f;
}

void sq__sph_kernel_grad(const sq__sph_kern *k, sq__sph_kernel_fn fn, const float d[3], float g[3])
{
    const float r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    const float r = sqrtf(r2);
    float f = 0.0f;
    switch (fn) {
    case SQ__SPH_W_POLY6: f = sq__sph_gradf_poly6(k, r2); break;
    case SQ__SPH_W_SPIKY: {
        sq__sph_kern kk = *k;
        kk.cubic = 0;
        f = sq__sph_gradf(&kk, r);
        break;
    }
    case SQ__SPH_W_VISC: {
        /* dW/dr of the viscosity kernel: 15/(2π H³) (−3q²/(2H) + 2q/H − 1/(2 q² H)) */
        float q = r * k->inv_H;
        if (q > 0.0f && q < 1.0f)
            f = k->visc_w_c * k->inv_H * (-1.5f * q * q + 2.0f * q - 0.5f / (q * q)) / r;
        break;
    }
    case SQ__SPH_W_CUBIC: {
        sq__sph_kern kk = *k;
        kk.cubic = 1;
        f = sq__sph_gradf(&kk, r);
        break;
    }
    }
    g[0] = f * d[0];
    g[1] = f * d[1];
    g[2] = f * d[2];
}

#endif

/* ---- grid and sort ---------------------------------------------------------------------- */

static inline int clamp_cell(float f, int n)
{
    int i = 0;
    if (f >= 0.0f) i = f < (float)n ? (int)f : n - 1;
    return i < 0 ? 0 : (i > n - 1 ? n - 1 : i); /* also for whatever a NaN converted to */
}

/* Absolute z cell of height z (from the domain bottom; may exceed the grid). */
static inline int abs_cell_z(const sq_sph *s, float z)
{
    const float f = (z - s->lo[2]) * s->inv_cell[2];
    return f >= 0.0f ? (f < 2e9f ? (int)f : 2000000000) : 0; /* NaN -> 0 */
}

#if !defined(SQ__SPH_VARIANT_V4)
uint32_t sq__sph_cell_of(const sq_sph *s, float x, float y, float z)
{
    const int cx = clamp_cell((x - s->lo[0]) * s->inv_cell[0], s->n[0]);
    const int cy = clamp_cell((y - s->lo[1]) * s->inv_cell[1], s->n[1]);
    if (s->column) {
        const uint32_t col = (uint32_t)cy * (uint32_t)s->n[0] + (uint32_t)cx;
        int k = abs_cell_z(s, z) - s->kbase[col];
        k = k < 0 ? 0 : (k > s->n[2] - 1 ? s->n[2] - 1 : k);
        return col * (uint32_t)s->n[2] + (uint32_t)k;
    }
    const int cz = clamp_cell((z - s->lo[2]) * s->inv_cell[2], s->n[2]);
    return ((uint32_t)cz * (uint32_t)s->n[1] + (uint32_t)cy) * (uint32_t)s->n[0] + (uint32_t)cx;
}

int sq__sph_above_layer(const sq_sph *s, float x, float y, float z)
{
    if (!s->column) return 0;
    const int cx = clamp_cell((x - s->lo[0]) * s->inv_cell[0], s->n[0]);
    const int cy = clamp_cell((y - s->lo[1]) * s->inv_cell[1], s->n[1]);
    return abs_cell_z(s, z) - s->kbase[(size_t)cy * (size_t)s->n[0] + (size_t)cx] >= s->n[2];
}

/* Reorder the persistent arrays by perm in ONE parallel loop (each parallel region costs a
 * thread wake-up, which is slow on a busy machine), into the spare buffers, then swap. */
static void reorder(sq_sph *s, size_t n)
{
    float **fa[SQ__SPH_NREORDER_F] = {&s->x,  &s->y,  &s->z,  &s->vx, &s->vy,
                                     &s->vz, &s->hx, &s->hy, &s->hz};
    uint32_t **ua[SQ__SPH_NREORDER_U] = {&s->id, &s->cellid};
    float *fs[SQ__SPH_NREORDER_F], *fd[SQ__SPH_NREORDER_F];
    uint32_t *us[SQ__SPH_NREORDER_U], *ud[SQ__SPH_NREORDER_U];
    for (int a = 0; a < SQ__SPH_NREORDER_F; a++) {
        fs[a] = *fa[a];
        fd[a] = s->fspare[a];
    }
    for (int a = 0; a < SQ__SPH_NREORDER_U; a++) {
        us[a] = *ua[a];
        ud[a] = s->uspare[a];
    }
    const uint32_t *restrict perm = s->perm;
    const int nt = sq__sph_threads(s, n);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int64_t k = 0; k < (int64_t)n; k++) {
        const uint32_t p = perm[k];
        for (int a = 0; a < SQ__SPH_NREORDER_F; a++) fd[a][k] = fs[a][p];
        for (int a = 0; a < SQ__SPH_NREORDER_U; a++) ud[a][k] = us[a][p];
    }
    for (int a = 0; a < SQ__SPH_NREORDER_F; a++) {
        s->fspare[a] = fs[a];
        *fa[a] = fd[a];
    }
    for (int a = 0; a < SQ__SPH_NREORDER_U; a++) {
        s->uspare[a] = us[a];
        *ua[a] = ud[a];
    }
}

size_t sq__sph_sort(sq_sph *s)
{
    const size_t N = s->count;
    const uint32_t dead = s->ncell; /* bucket of particles that left through open faces */
    const int nt = sq__sph_threads(s, N);
    uint32_t *restrict cid = s->cellid;
    uint32_t cmin = UINT32_MAX, cmax = 0;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(min : cmin) reduction(max : cmax))
    for (int64_t i = 0; i < (int64_t)N; i++) {
        const float p[3] = {s->x[i], s->y[i], s->z[i]};
        int out = 0;
        for (int a = 0; a < 3; a++) {
            if (p[a] < s->lo[a] && s->face[2 * a] == SQ_SPH_BOUNDARY_OPEN) out = 1;
            if (p[a] >= s->hi[a] && s->face[2 * a + 1] == SQ_SPH_BOUNDARY_OPEN) out = 1;
        }
        if (!out && s->column) out = sq__sph_above_layer(s, p[0], p[1], p[2]);
        const uint32_t c = out ? dead : sq__sph_cell_of(s, p[0], p[1], p[2]);
        cid[i] = c;
        if (!out) {
            cmin = c < cmin ? c : cmin;
            cmax = c > cmax ? c : cmax;
        }
    }
    /* Counting sort (serial and stable: the order within a cell is the previous order) over
     * the cells that can be read this step: the occupied range widened by one plane, row and
     * cell, so that sparse fluid in a large domain does not pay for every empty cell. */
    const uint32_t margin = s->column ? ((uint32_t)s->n[0] + 2u) * (uint32_t)s->n[2]
                                      : (uint32_t)s->n[0] * (uint32_t)s->n[1] + (uint32_t)s->n[0] + 1u;
    uint32_t lo = 0, hi = 0;
    if (cmin <= cmax) {
        lo = cmin > margin ? cmin - margin : 0u;
        hi = dead - 1u - cmax > margin ? cmax + margin : dead - 1u;
    }
    uint32_t *restrict h = s->hist;
    uint32_t ndead = 0;
    memset(h + lo, 0, sizeof(uint32_t) * ((size_t)(hi - lo) + 1));
    for (size_t i = 0; i < N; i++) {
        if (cid[i] == dead) ndead++;
        else h[cid[i]]++;
    }
    uint32_t sum = 0;
    for (uint32_t c = lo; c <= hi; c++) {
        const uint32_t t = h[c];
        s->cell_start[c] = sum;
        h[c] = sum;
        sum += t;
    }
    s->cell_start[hi + 1] = sum;
    s->cell_start[dead] = sum;
    s->cell_start[dead + 1] = sum + ndead;
    h[dead] = sum;
    for (size_t i = 0; i < N; i++) s->perm[h[cid[i]]++] = (uint32_t)i;
    const size_t alive = s->cell_start[dead];
    reorder(s, alive); /* positions, velocities, ids and (sorted) cell ids */
    s->count = alive;
    return N - alive;
}

/* ---- which loops run ------------------------------------------------------------------------ */

#if defined(SQ_SPH_DISPATCH) && SQ_SPH_DISPATCH && !SQ__SPH_AVX512
int sq__sph_pass_density_v4(sq_sph *s);
float sq__sph_pass_strain_v4(sq_sph *s);
float sq__sph_pass_forces_v4(sq_sph *s);

int sq__sph_uses_avx512(void)
{
    const char *e = getenv("SQ_SPH_ISA");
    if (e && strcmp(e, "portable") == 0) return 0;
    __builtin_cpu_init();
    return __builtin_cpu_supports("x86-64-v4") != 0;
}
#define SQ__SPH_DISPATCH(call) \
    do { \
        if (s->avx512) return call##_v4(s); \
    } while (0)
#else
int sq__sph_uses_avx512(void) { return SQ__SPH_AVX512; }
#define SQ__SPH_DISPATCH(call) ((void)0)
#endif
#endif /* !SQ__SPH_VARIANT_V4 */
#if defined(SQ__SPH_VARIANT_V4)
#if !SQ__SPH_AVX512
#error "sph_passes_v4.c must be compiled with AVX-512 (-march=x86-64-v4)"
#endif
#define SQ__SPH_DISPATCH(call) ((void)0)
#endif

/* ---- neighbour search and density --------------------------------------------------------- */

/* 0: no wall within H on axis a; 1: the low wall; 2: the high wall. */
SQ__INLINE int near_wall(const sq_sph *s, int a, float xa)
{
    if (s->face[2 * a] <= SQ_SPH_BOUNDARY_FREE_SLIP && xa - s->lo[a] < s->k.H) return 1;
    if (s->face[2 * a + 1] <= SQ_SPH_BOUNDARY_FREE_SLIP && s->hi[a] - xa < s->k.H) return 2;
    return 0;
}

typedef struct scan_acc {
    int cnt;
    float wsum; /* Σ W over candidates (the density kernel) */
#if SQ__SPH_AVX512
    __m512 wv;  /* lane sums of W (added to wsum at the end) */
    float *r2;  /* NULL, or r² of the accepted entries, parallel to the list (W summed at the
                   end over these instead of over every candidate) */
#endif
} scan_acc;

/* Candidates j in [b, e) seen from the query point q (already shifted for periodicity), in
 * chunks: a vectorisable loop computes r² and the density kernel W (which is zero beyond H, so
 * it needs no test), then a branch-free loop appends the accepted ones (r < H, j ≠ self). */
#if SQ__SPH_AVX512
/* n candidates at X[t], Y[t], Z[t] with particle index J[t] (J = NULL: base + t) seen from the
 * query point q, 16 per vector: r², and the accepted ones (r < H, j ≠ self) compressed to the
 * front of a vector stored at the end of the list (the entries beyond the count are scratch),
 * with their r² alongside (acc->r2, W summed at the end) or W summed here (acc->r2 = NULL;
 * W is zero beyond H, so every live candidate is summed). */
SQ__INLINE void scan_vec(const sq__sph_kern *restrict kp, const float *restrict X,
                         const float *restrict Y, const float *restrict Z,
                         const uint32_t *restrict J, uint32_t base, uint32_t n, float qx, float qy,
                         float qz, uint32_t self, uint32_t tag, uint32_t *restrict nb, int capm1,
                         scan_acc *acc, int cubic)
{
    const sq__sph_kern kk = *kp;
    const int cap = capm1 + 1;
    const __m512 vqx = VSET1(qx), vqy = VSET1(qy), vqz = VSET1(qz), vH2 = VSET1(kk.H2);
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512i vself = _mm512_set1_epi32((int)self), vtag = _mm512_set1_epi32((int)tag);
    __m512 wv = acc->wv;
    float *restrict r2s = acc->r2;
    int cnt = acc->cnt;
    for (uint32_t t0 = 0; t0 < n; t0 += 16) {
        const __mmask16 live = v_live(n - t0);
        const __m512 dx = VSUB(vqx, _mm512_maskz_loadu_ps(live, X + t0));
        const __m512 dy = VSUB(vqy, _mm512_maskz_loadu_ps(live, Y + t0));
        const __m512 dz = VSUB(vqz, _mm512_maskz_loadu_ps(live, Z + t0));
        const __m512 r2 = VADD(VADD(VMUL(dx, dx), VMUL(dy, dy)), VMUL(dz, dz));
        const __m512i jv = J ? _mm512_maskz_loadu_epi32(live, J + t0)
                             : _mm512_add_epi32(_mm512_set1_epi32((int)(base + t0)), iota);
        const __mmask16 ok = _mm512_mask_cmp_ps_mask(live, r2, vH2, _CMP_LT_OQ) &
                             _mm512_cmpneq_epi32_mask(jv, vself);
        const int nok = __builtin_popcount((unsigned)ok);
        if (cnt + 16 <= cap) {
            _mm512_storeu_si512((void *)(nb + cnt),
                                _mm512_maskz_compress_epi32(ok, _mm512_or_si512(jv, vtag)));
            if (r2s) _mm512_storeu_ps(r2s + cnt, _mm512_maskz_compress_ps(ok, r2));
        } else { /* near the end of the list: one at a time, clamped (the caller regrows) */
            float r2l[16];
            uint32_t jl[16];
            _mm512_storeu_ps(r2l, r2);
            _mm512_storeu_si512((void *)jl, jv);
            for (int t = 0; t < 16; t++) {
                if (!((ok >> t) & 1)) continue;
                const int k = cnt + __builtin_popcount((unsigned)ok & ((1u << t) - 1u));
                nb[k < capm1 ? k : capm1] = jl[t] | tag;
                if (r2s && k <= capm1) r2s[k] = r2l[t];
            }
        }
        if (!r2s) {
            const __m512 w = cubic ? v_w_cubic(&kk, v_sqrt_pos(r2)) : v_w_poly6(&kk, r2);
            wv = _mm512_mask_add_ps(wv, live, wv, w);
        }
        cnt += nok;
    }
    acc->wv = wv;
    acc->cnt = cnt;
}
#endif

/* Candidates j in [b, e) seen from the query point q (already shifted for periodicity), in
 * chunks: a vectorisable loop computes r² and the density kernel W (which is zero beyond H, so
 * it needs no test), then a branch-free loop appends the accepted ones (r < H, j ≠ self). */
#define SQ__SPH_SCAN_CHUNK 64
SQ__INLINE void scan_range(const sq_sph *restrict s, uint32_t b, uint32_t e, float qx, float qy,
                           float qz, uint32_t self, uint32_t tag, uint32_t *restrict nb,
                           int capm1, scan_acc *acc, int cubic)
{
    const float *restrict X = s->x, *restrict Y = s->y, *restrict Z = s->z;
#if SQ__SPH_AVX512
    scan_vec(&s->k, X + b, Y + b, Z + b, NULL, b, e - b, qx, qy, qz, self, tag, nb, capm1, acc,
             cubic);
#else
    const float H2 = s->k.H2;
    const sq__sph_kern kk = s->k;
    float r2b[SQ__SPH_SCAN_CHUNK];
    int cnt = acc->cnt;
    for (uint32_t b0 = b; b0 < e; b0 += SQ__SPH_SCAN_CHUNK) {
        const int n = (int)(e - b0 < SQ__SPH_SCAN_CHUNK ? e - b0 : SQ__SPH_SCAN_CHUNK);
        const float *restrict x = X + b0, *restrict y = Y + b0, *restrict z = Z + b0;
        float ws = 0.0f;
        SQ_OMP(omp simd reduction(+ : ws))
        for (int t = 0; t < n; t++) {
            const float dx = qx - x[t], dy = qy - y[t], dz = qz - z[t];
            const float r2 = dx * dx + dy * dy + dz * dz;
            r2b[t] = r2;
            ws += cubic ? sq__sph_w_cubic(&kk, sq__sph_sqrt(r2)) : sq__sph_w_poly6(&kk, r2);
        }
        acc->wsum += ws;
        for (int t = 0; t < n; t++) {
            const uint32_t j = b0 + (uint32_t)t;
            const int slot = cnt < capm1 ? cnt : capm1;
            nb[slot] = j | tag;
            cnt += (int)((r2b[t] < H2) & (j != self));
        }
    }
    acc->cnt = cnt;
#endif
}

/* Distance from v to the interval [a, a + w] (0 inside). */
static inline float gap(float v, float a, float w)
{
    return sq__maxf(sq__maxf(a - v, v - (a + w)), 0.0f);
}

/* Wraps the cell index *k along axis a into the grid. False when it lies outside a non-periodic
 * axis; otherwise *shift is the coordinate shift of the wrapped image (+len below the grid,
 * −len above it, 0 inside). */
SQ__INLINE bool wrap_cell(const sq_sph *restrict s, int a, int *k, float *shift)
{
    *shift = 0.0f;
    if (*k < 0) {
        if (!s->periodic[a]) return false;
        *k += s->n[a];
        *shift = s->len[a];
    } else if (*k >= s->n[a]) {
        if (!s->periodic[a]) return false;
        *k -= s->n[a];
        *shift = -s->len[a];
    }
    return true;
}

/* All candidates in the 27 cells around the query point (x, y, z); rows (and the end cells of
 * each x-row) farther than H from the query are skipped. Axes in fixmask (the mirrored axes of
 * an image query, which lies outside the domain) scan only the wall cell. */
SQ__INLINE void scan_cells(const sq_sph *restrict s, float x, float y, float z, uint32_t self,
                           uint32_t tag, uint32_t *restrict nb, int capm1, scan_acc *acc,
                           int cubic, int fixmask)
{
    const int nx = s->n[0], ny = s->n[1], nz = s->n[2];
    const int cx = clamp_cell((x - s->lo[0]) * s->inv_cell[0], nx);
    const int cy = clamp_cell((y - s->lo[1]) * s->inv_cell[1], ny);
    const int cz = clamp_cell((z - s->lo[2]) * s->inv_cell[2], nz);
    const float H2 = s->k.H2;
    const float *cell = s->cell;
    const uint32_t *restrict st = s->cell_start;
    const int zl = (fixmask & 4) ? 0 : -1, zh = (fixmask & 4) ? 0 : 1;
    const int yl = (fixmask & 2) ? 0 : -1, yh = (fixmask & 2) ? 0 : 1;
    const int xl = (fixmask & 1) ? 0 : -1, xh = (fixmask & 1) ? 0 : 1;
    for (int dz = zl; dz <= zh; dz++) {
        int kz = cz + dz;
        float shz;
        if (!wrap_cell(s, 2, &kz, &shz)) continue;
        const float qz = z + shz;
        const float ez = gap(qz, s->lo[2] + (float)kz * cell[2], cell[2]);
        const float remz = H2 - ez * ez;
        if (remz <= 0.0f) continue;
        for (int dy = yl; dy <= yh; dy++) {
            int ky = cy + dy;
            float shy;
            if (!wrap_cell(s, 1, &ky, &shy)) continue;
            const float qy = y + shy;
            const float ey = gap(qy, s->lo[1] + (float)ky * cell[1], cell[1]);
            const float rem = remz - ey * ey;
            if (rem <= 0.0f) continue;
            const uint32_t row = ((uint32_t)kz * (uint32_t)ny + (uint32_t)ky) * (uint32_t)nx;
            int xa = cx + xl, xb = cx + xh;
            if (s->periodic[0] && (xa < 0 || xb >= nx)) {
                for (int dx = xl; dx <= xh; dx++) {
                    int kx = cx + dx;
                    float shx;
                    (void)wrap_cell(s, 0, &kx, &shx); /* x is periodic here */
                    const float qx = x + shx;
                    const float ex = gap(qx, s->lo[0] + (float)kx * cell[0], cell[0]);
                    if (ex * ex >= rem) continue;
                    scan_range(s, st[row + (uint32_t)kx], st[row + (uint32_t)kx + 1], qx, qy, qz,
                               self, tag, nb, capm1, acc, cubic);
                }
            } else {
                if (xa < 0) xa = 0;
                if (xb >= nx) xb = nx - 1;
                /* trim the end cells of the row when the sphere does not reach them */
                if (xa < cx) {
                    const float ex = gap(x, s->lo[0] + (float)xa * cell[0], cell[0]);
                    if (ex * ex >= rem) xa = cx;
                }
                if (xb > cx) {
                    const float ex = gap(x, s->lo[0] + (float)xb * cell[0], cell[0]);
                    if (ex * ex >= rem) xb = cx;
                }
                scan_range(s, st[row + (uint32_t)xa], st[row + (uint32_t)xb + 1], x, qy, qz, self,
                           tag, nb, capm1, acc, cubic);
            }
        }
    }
}

/* Displacement x_i − x_j for a plain entry (minimum image on periodic axes). */
SQ__INLINE void d_plain(const sq_sph *restrict s, size_t i, uint32_t j, float d[3])
{
    d[0] = s->x[i] - s->x[j];
    d[1] = s->y[i] - s->y[j];
    d[2] = s->z[i] - s->z[j];
    if (s->any_periodic) {
        for (int a = 0; a < 3; a++) {
            if (!s->periodic[a]) continue;
            if (d[a] > s->half_len[a]) d[a] -= s->len[a];
            else if (d[a] < -s->half_len[a]) d[a] += s->len[a];
        }
    }
}

static inline float coord(const sq_sph *s, int a, size_t i)
{
    return a == 0 ? s->x[i] : a == 1 ? s->y[i] : s->z[i];
}

/* The particle ranges of the 27 cells around cell c, in the order every scan uses (z rows, then
 * y rows; in each row the x-contiguous cells as one range, or three ranges when the row wraps
 * periodically), each with the shift (sx, sy, sz) to subtract from its particles' coordinates
 * for a wrapped row. Rows outside a non-periodic domain are left out. */
typedef struct cell_ranges {
    int n;
    uint32_t b[27], e[27];
    float sx[27], sy[27], sz[27];
} cell_ranges;

/* The same for the terrain-following grid (no periodic axes): in each of the 9 columns around
 * c's, the cells of the absolute heights k − 1 … k + 1, clipped to the column. */
SQ__INLINE void column_ranges(const sq_sph *restrict s, uint32_t c, cell_ranges *restrict r)
{
    const int nx = s->n[0], ny = s->n[1], nc = s->n[2];
    const uint32_t col = c / (uint32_t)nc;
    const int cx = (int)(col % (uint32_t)nx), cy = (int)(col / (uint32_t)nx);
    const int k = s->kbase[col] + (int)(c % (uint32_t)nc);
    const uint32_t *restrict st = s->cell_start;
    r->n = 0;
    for (int dy = -1; dy <= 1; dy++) {
        const int ky = cy + dy;
        if (ky < 0 || ky >= ny) continue;
        for (int dx = -1; dx <= 1; dx++) {
            const int kx = cx + dx;
            if (kx < 0 || kx >= nx) continue;
            const uint32_t c2 = (uint32_t)ky * (uint32_t)nx + (uint32_t)kx;
            int k0 = k - 1 - s->kbase[c2], k1 = k + 1 - s->kbase[c2];
            k0 = k0 < 0 ? 0 : k0;
            k1 = k1 > nc - 1 ? nc - 1 : k1;
            if (k0 > k1) continue;
            r->b[r->n] = st[c2 * (uint32_t)nc + (uint32_t)k0];
            r->e[r->n] = st[c2 * (uint32_t)nc + (uint32_t)k1 + 1u];
            r->sx[r->n] = r->sy[r->n] = r->sz[r->n] = 0.0f;
            r->n++;
        }
    }
}

SQ__INLINE void neighbour_ranges(const sq_sph *restrict s, uint32_t c, cell_ranges *restrict r)
{
    if (s->column) {
        column_ranges(s, c, r);
        return;
    }
    const int nx = s->n[0], ny = s->n[1];
    const int cx = (int)(c % (uint32_t)nx), cy = (int)(c / (uint32_t)nx % (uint32_t)ny);
    const int cz = (int)(c / ((uint32_t)nx * (uint32_t)ny));
    const uint32_t *restrict st = s->cell_start;
    r->n = 0;
    for (int dz = -1; dz <= 1; dz++) {
        int kz = cz + dz;
        float sz;
        if (!wrap_cell(s, 2, &kz, &sz)) continue;
        for (int dy = -1; dy <= 1; dy++) {
            int ky = cy + dy;
            float sy;
            if (!wrap_cell(s, 1, &ky, &sy)) continue;
            const uint32_t row = ((uint32_t)kz * (uint32_t)ny + (uint32_t)ky) * (uint32_t)nx;
            if (s->periodic[0] && (cx == 0 || cx == nx - 1)) {
                for (int dx = -1; dx <= 1; dx++) {
                    int kx = cx + dx;
                    float sx;
                    (void)wrap_cell(s, 0, &kx, &sx); /* x is periodic here */
                    r->b[r->n] = st[row + (uint32_t)kx];
                    r->e[r->n] = st[row + (uint32_t)kx + 1];
                    r->sx[r->n] = sx;
                    r->sy[r->n] = sy;
                    r->sz[r->n++] = sz;
                }
            } else {
                const int xa = cx > 0 ? cx - 1 : 0, xb = cx < nx - 1 ? cx + 1 : nx - 1;
                r->b[r->n] = st[row + (uint32_t)xa];
                r->e[r->n] = st[row + (uint32_t)xb + 1];
                r->sx[r->n] = 0.0f;
                r->sy[r->n] = sy;
                r->sz[r->n++] = sz;
            }
        }
    }
}

/* The plain neighbours of a group of ng ≤ SQ__SPH_GROUP particles of one cell c (consecutive
 * from g0): the 27 cells around c are the same for all of them, so each candidate j is tested
 * against the whole group in one vectorisable loop (distance, density kernel), and a short
 * branch-free loop appends it to the lists that accept it. The lists come out exactly as a
 * per-particle scan of the same cells would make them. */
#define SQ__SPH_GROUP 16
SQ__INLINE void scan_group(sq_sph *restrict s, uint32_t c, size_t g0, int ng, int *restrict cnt,
                           float *restrict ws, const int cubic)
{
    const int cap = s->nb_cap, capm1 = cap - 1;
    const float H2 = s->k.H2;
    const sq__sph_kern kk = s->k;
    const float *restrict X = s->x, *restrict Y = s->y, *restrict Z = s->z;
    uint32_t *restrict nb = s->nb + g0 * (size_t)cap;
    float gx[SQ__SPH_GROUP], gy[SQ__SPH_GROUP], gz[SQ__SPH_GROUP], r2b[SQ__SPH_GROUP];
    for (int t = 0; t < ng; t++) {
        gx[t] = X[g0 + (size_t)t];
        gy[t] = Y[g0 + (size_t)t];
        gz[t] = Z[g0 + (size_t)t];
    }
    cell_ranges rg;
    neighbour_ranges(s, c, &rg);
    for (int q = 0; q < rg.n; q++) {
        const float sx = rg.sx[q], sy = rg.sy[q], sz = rg.sz[q];
        for (uint32_t j = rg.b[q]; j < rg.e[q]; j++) {
            const float xj = X[j] - sx, yj = Y[j] - sy, zj = Z[j] - sz;
            SQ_OMP(omp simd)
            for (int t = 0; t < ng; t++) {
                const float ex = gx[t] - xj, ey = gy[t] - yj, ez = gz[t] - zj;
                const float r2 = ex * ex + ey * ey + ez * ez;
                r2b[t] = r2;
                ws[t] += cubic ? sq__sph_w_cubic(&kk, sq__sph_sqrt(r2)) : sq__sph_w_poly6(&kk, r2);
            }
            const size_t jr = j - g0; /* j relative to the group (self test) */
            for (int t = 0; t < ng; t++) {
                const int k = cnt[t];
                nb[(size_t)t * (size_t)cap + (size_t)(k < capm1 ? k : capm1)] = j;
                cnt[t] = k + (int)((r2b[t] < H2) & (jr != (size_t)t));
            }
        }
    }
}

/* The mirror-image entries of particle ip (after its plain ones), then its density, pressure
 * and packed record; returns its neighbour count. */
SQ__INLINE int density_finish(sq_sph *restrict s, size_t ip, scan_acc *acc, const int cubic)
{
    const int cap = s->nb_cap, capm1 = cap - 1;
    uint32_t *restrict nb = s->nb + ip * (size_t)cap;
    const int plain = acc->cnt;
    if (s->any_wall) {
        const float xyz[3] = {s->x[ip], s->y[ip], s->z[ip]};
        int side[3], near = 0;
        for (int a = 0; a < 3; a++) {
            side[a] = near_wall(s, a, xyz[a]);
            if (side[a]) near |= 1 << a;
        }
        /* every non-empty subset of the near walls: mirrors, edges, corners */
        for (int m = 1; m < 8; m++) {
            if ((m & near) != m) continue;
            float qp[3];
            for (int a = 0; a < 3; a++) {
                qp[a] = xyz[a];
                if (m & (1 << a)) {
                    const float w = side[a] == 1 ? s->lo[a] : s->hi[a];
                    qp[a] = 2.0f * w - xyz[a];
                }
            }
            scan_cells(s, qp[0], qp[1], qp[2], UINT32_MAX, (uint32_t)m << SQ__SPH_IMAGE_SHIFT, nb,
                       capm1, acc, cubic, m);
        }
    }
#if SQ__SPH_AVX512
    if (acc->r2) {
        /* the self term W(0) and W of the accepted entries (the other candidates have W = 0) */
        const sq__sph_kern kk = s->k;
        const int m = acc->cnt < cap ? acc->cnt : cap;
        __m512 wv = acc->wv;
        for (int k0 = 0; k0 < m; k0 += 16) {
            const __mmask16 live = v_live((uint32_t)(m - k0));
            const __m512 r2 = _mm512_maskz_loadu_ps(live, acc->r2 + k0);
            const __m512 w = cubic ? v_w_cubic(&kk, v_sqrt_pos(r2)) : v_w_poly6(&kk, r2);
            wv = _mm512_mask_add_ps(wv, live, wv, w);
        }
        acc->wsum += cubic ? sq__sph_w_cubic(&kk, 0.0f) : sq__sph_w_poly6(&kk, 0.0f);
        acc->wv = wv;
    }
    acc->wsum += v_sum(acc->wv);
#endif
    const int n = acc->cnt;
    s->nb_count[ip] = (uint16_t)(n < cap ? n : cap);
    s->nb_plain[ip] = (uint16_t)(plain < cap ? plain : cap);
    const float rho = s->mass * acc->wsum;
    const float p = sq__sph_eos(s, rho);
    const float vol = s->mass / rho, pr2 = p / (rho * rho);
    s->rho[ip] = rho;
    s->p[ip] = p;
    s->vol[ip] = vol;
    s->pr2[ip] = pr2;
    float *restrict rc = s->rec + SQ__SPH_REC * ip;
    rc[0] = s->x[ip];
    rc[1] = s->y[ip];
    rc[2] = s->z[ip];
    rc[3] = vol;
    rc[4] = s->vx[ip];
    rc[5] = s->vy[ip];
    rc[6] = s->vz[ip];
    rc[7] = pr2;
    return n;
}

#if SQ__SPH_AVX512
#define SQ__SPH_R2BUF 256
#define SQ__SPH_CANDS 1024
/* The candidates of one cell's particles: the 27 cells around it, row by row (x-contiguous
 * cells as one range), positions shifted by the periodic wrap, so that every particle of the
 * cell scans one contiguous packed array instead of nine ranges. */
typedef struct cand_buf {
    float x[SQ__SPH_CANDS], y[SQ__SPH_CANDS], z[SQ__SPH_CANDS];
    uint32_t j[SQ__SPH_CANDS];
} cand_buf;

/* Fills cb for cell c; returns the count, or -1 if more than SQ__SPH_CANDS. */
static int collect_cands(const sq_sph *restrict s, uint32_t c, cand_buf *restrict cb)
{
    const float *restrict X = s->x, *restrict Y = s->y, *restrict Z = s->z;
    const __m512i iota = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    cell_ranges rg;
    neighbour_ranges(s, c, &rg);
    int n = 0;
    for (int q = 0; q < rg.n; q++) {
        const uint32_t m = rg.e[q] - rg.b[q];
        if ((uint32_t)n + m > SQ__SPH_CANDS) return -1;
        const __m512 vsx = VSET1(rg.sx[q]), vsy = VSET1(rg.sy[q]), vsz = VSET1(rg.sz[q]);
        const uint32_t b0 = rg.b[q];
        for (uint32_t t = 0; t < m; t += 16) {
            const __mmask16 live = v_live(m - t);
            const uint32_t o = (uint32_t)n + t;
            _mm512_mask_storeu_ps(cb->x + o, live,
                                  VSUB(_mm512_maskz_loadu_ps(live, X + b0 + t), vsx));
            _mm512_mask_storeu_ps(cb->y + o, live,
                                  VSUB(_mm512_maskz_loadu_ps(live, Y + b0 + t), vsy));
            _mm512_mask_storeu_ps(cb->z + o, live,
                                  VSUB(_mm512_maskz_loadu_ps(live, Z + b0 + t), vsz));
            _mm512_mask_storeu_epi32(cb->j + o, live,
                                     _mm512_add_epi32(_mm512_set1_epi32((int)(b0 + t)), iota));
        }
        n += (int)m;
    }
    return n;
}

/* Density pass for the cells that start in particles [i0, i1) (each cell is done by the block
 * holding its first particle): the cell's candidates are packed once, then each particle scans
 * them 16 per vector (a cell with too many candidates: each particle scans its own 27 cells).
 * Returns the largest neighbour count. */
SQ__INLINE int density_cells(sq_sph *restrict s, size_t i0, size_t i1, const int cubic)
{
    const int cap = s->nb_cap, capm1 = cap - 1;
    const uint32_t *restrict cid = s->cellid; /* sorted */
    int maxcnt = 0;
    float r2buf[SQ__SPH_R2BUF + 16];
    cand_buf cb __attribute__((aligned(64)));
    size_t i = i0;
    if (i > 0)
        while (i < i1 && cid[i] == cid[i - 1]) i++;
    while (i < i1) {
        const uint32_t c = cid[i];
        const size_t ce = s->cell_start[c + 1];
        const int nc = collect_cands(s, c, &cb);
        for (size_t ip = i; ip < ce; ip++) {
            scan_acc acc;
            acc.cnt = 0;
            acc.wsum = 0.0f;
            acc.wv = _mm512_setzero_ps();
            acc.r2 = cap <= SQ__SPH_R2BUF ? r2buf : NULL; /* long lists: W inside the scan */
            uint32_t *restrict nb = s->nb + ip * (size_t)cap;
            if (nc >= 0)
                scan_vec(&s->k, cb.x, cb.y, cb.z, cb.j, 0u, (uint32_t)nc, s->x[ip], s->y[ip],
                         s->z[ip], (uint32_t)ip, 0u, nb, capm1, &acc, cubic);
            else
                scan_cells(s, s->x[ip], s->y[ip], s->z[ip], (uint32_t)ip, 0u, nb, capm1, &acc,
                           cubic, 0);
            const int n = density_finish(s, ip, &acc, cubic);
            if (n > maxcnt) maxcnt = n;
        }
        i = ce;
    }
    return maxcnt;
}
#else
/* Density pass for the cells that start in particles [i0, i1) (each cell is done by the block
 * holding its first particle); returns the largest neighbour count. */
SQ__INLINE int density_cells(sq_sph *restrict s, size_t i0, size_t i1, const int cubic)
{
    const uint32_t *restrict cid = s->cellid; /* sorted */
    int maxcnt = 0;
    size_t i = i0;
    if (i > 0)
        while (i < i1 && cid[i] == cid[i - 1]) i++;
    while (i < i1) {
        const uint32_t c = cid[i];
        const size_t ce = s->cell_start[c + 1];
        for (size_t g0 = i; g0 < ce; g0 += SQ__SPH_GROUP) {
            const int ng = (int)(ce - g0 < SQ__SPH_GROUP ? ce - g0 : SQ__SPH_GROUP);
            int cnt[SQ__SPH_GROUP];
            float ws[SQ__SPH_GROUP];
            for (int t = 0; t < ng; t++) {
                cnt[t] = 0;
                ws[t] = 0.0f;
            }
            scan_group(s, c, g0, ng, cnt, ws, cubic);
            for (int t = 0; t < ng; t++) {
                scan_acc acc = {cnt[t], ws[t]};
                const int n = density_finish(s, g0 + (size_t)t, &acc, cubic);
                if (n > maxcnt) maxcnt = n;
            }
        }
        i = ce;
    }
    return maxcnt;
}
#endif

SQ__SPH_CLONES static int density_block_poly6(sq_sph *restrict s, size_t i0, size_t i1)
{
    return density_cells(s, i0, i1, 0);
}
SQ__SPH_CLONES static int density_block_cubic(sq_sph *restrict s, size_t i0, size_t i1)
{
    return density_cells(s, i0, i1, 1);
}

int sq__sph_pass_density(sq_sph *s)
{
    SQ__SPH_DISPATCH(sq__sph_pass_density);
    const size_t N = s->count;
    const int64_t nblk = (int64_t)((N + SQ__SPH_BLOCK - 1) / SQ__SPH_BLOCK);
    const int nt = sq__sph_threads(s, N);
    int maxcnt = 0;
    SQ_OMP(omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(max : maxcnt))
    for (int64_t b = 0; b < nblk; b++) {
        const size_t i0 = (size_t)b * SQ__SPH_BLOCK;
        const size_t i1 = i0 + SQ__SPH_BLOCK < N ? i0 + SQ__SPH_BLOCK : N;
        const int m = s->k.cubic ? density_block_cubic(s, i0, i1) : density_block_poly6(s, i0, i1);
        if (m > maxcnt) maxcnt = m;
    }
    return maxcnt;
}

/* ---- mirror images -------------------------------------------------------------------------- */

typedef struct image {
    float d[3];     /* x_i − x_j' */
    float v[3];
    float rho, vol, pr2;
    float L[6];
    float tau[6];
    float mu;       /* μ_j (tensors >= 2: recomputed from the mirrored strain rate) */
} image;

static inline int tidx(int a, int b) /* symmetric 6-vector index: xx yy zz xy xz yz */
{
    if (a == b) return a;
    if (a > b) {
        int t = a;
        a = b;
        b = t;
    }
    return a == 0 ? (b == 1 ? 3 : 4) : 5;
}

/* The state of the mirror image of j seen by i (entry e carries the mirror mask).
 * tensors = 0: geometry, velocity and density only (the strain pass, which is still writing
 * L and G); 1: also L; 2: also L and τ (recomputed from the mirrored velocity gradient). */
static void image_state(const sq_sph *restrict s, size_t i, uint32_t e, int tensors, image *o)
{
    const uint32_t j = e & SQ__SPH_INDEX_MASK;
    const uint32_t m = e >> SQ__SPH_IMAGE_SHIFT;
    d_plain(s, i, j, o->d);
    o->v[0] = s->vx[j];
    o->v[1] = s->vy[j];
    o->v[2] = s->vz[j];
    float G[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
    if (tensors >= 2)
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) G[a][b] = s->G[9 * (size_t)j + 3 * (size_t)a + (size_t)b];
    float sgn[3] = {1.0f, 1.0f, 1.0f};
    float dpot = 0.0f; /* g · (x_j' − x_j) */
    for (int a = 0; a < 3; a++) {
        if (!(m & (1u << a))) continue;
        const float xi = coord(s, a, i), xj = coord(s, a, j);
        const int sd = near_wall(s, a, xi);
        const float w = sd == 1 ? s->lo[a] : s->hi[a];
        o->d[a] = xi + xj - 2.0f * w;
        dpot += s->g[a] * 2.0f * (w - xj);
        sgn[a] = -1.0f;
        const int kind = s->face[2 * a + (sd == 2)];
        if (kind == SQ_SPH_BOUNDARY_NO_SLIP) {
            for (int b = 0; b < 3; b++) {
                o->v[b] = -o->v[b];
                for (int c = 0; c < 3; c++) G[b][c] = -G[b][c];
            }
        } else {
            o->v[a] = -o->v[a];
            for (int c = 0; c < 3; c++) G[a][c] = -G[a][c];
        }
        for (int b = 0; b < 3; b++) G[b][a] = -G[b][a];
    }
    const float rho_j = s->rho[j];
    const float rho = rho_j * (1.0f + dpot / s->c2);
    float p = s->p[j] + rho_j * dpot;
    if (!s->tensile && p < 0.0f) p = 0.0f;
    o->rho = rho;
    o->vol = s->mass / rho;
    o->pr2 = p / (rho * rho);
    o->mu = tensors >= 1 ? s->mu[j] : 0.0f;
    if (tensors >= 1)
        for (int a = 0; a < 3; a++)
            for (int b = a; b < 3; b++) {
                const int t = tidx(a, b);
                o->L[t] = sgn[a] * sgn[b] * s->L[6 * (size_t)j + (size_t)t];
            }
    if (tensors >= 2) {
        float D[6];
        for (int a = 0; a < 3; a++)
            for (int b = a; b < 3; b++) D[tidx(a, b)] = 0.5f * (G[a][b] + G[b][a]);
        const float dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2] +
                         2.0f * (D[3] * D[3] + D[4] * D[4] + D[5] * D[5]);
        const float mu = sq__sph_rheo_mu(&s->rheo, sqrtf(2.0f * dd));
        for (int t = 0; t < 6; t++) o->tau[t] = 2.0f * mu * D[t];
        o->mu = mu;
    }
}

/* ---- strain pass --------------------------------------------------------------------------- */

/* Inverse of the symmetric matrix B (xx yy zz xy xz yz); identity if det < SQ__SPH_DET_MIN or
 * tr(B⁻¹) > SQ__SPH_TRACE_MAX (too few neighbours on some side for a meaningful correction). */
static inline void sym_inverse(const float B[6], float L[6])
{
    const float a = B[0], b = B[1], c = B[2], d = B[3], e = B[4], f = B[5];
    const float cxx = b * c - f * f, cyy = a * c - e * e, czz = a * b - d * d;
    const float cxy = e * f - d * c, cxz = d * f - b * e, cyz = d * e - a * f;
    const float det = a * cxx + d * cxy + e * cxz;
    if (!(det >= SQ__SPH_DET_MIN)) {
        L[0] = L[1] = L[2] = 1.0f;
        L[3] = L[4] = L[5] = 0.0f;
        return;
    }
    const float id = 1.0f / det;
    if (!((cxx + cyy + czz) * id <= SQ__SPH_TRACE_MAX)) { /* an eigenvalue of B below 1/12 */
        L[0] = L[1] = L[2] = 1.0f;
        L[3] = L[4] = L[5] = 0.0f;
        return;
    }
    L[0] = cxx * id;
    L[1] = cyy * id;
    L[2] = czz * id;
    L[3] = cxy * id;
    L[4] = cxz * id;
    L[5] = cyz * id;
}

/* 1/r from r², and 0 at r = 0 (coincident particles, a particle and its own mirror image on
 * the wall): written without a conditional division so that the loops vectorise under the
 * default IEEE rules (GCC will not speculate a division that might trap). */
SQ__INLINE float inv_dist(float r2)
{
    const float q = 1.0f / sqrtf(r2 > 1e-30f ? r2 : 1e-30f);
    return r2 > 0.0f ? q : 0.0f;
}

/* Minimum-image wrap of one displacement component (h = +inf on non-periodic axes). */
SQ__INLINE float wrap1(float d, float h, float L)
{
    d = d > h ? d - L : d;
    return d < -h ? d + L : d;
}

/* The sums of particle i's strain pass: B = Σ V_j (x_j − x_i) ⊗ ∇W (xx yy zz xy xz yz) and
 * Gr = Σ V_j (v_j − v_i) ⊗ ∇W (row-major), plain entries then mirror images. */
SQ__INLINE void strain_sums(sq_sph *restrict s, size_t i, const int cubic, float B[6],
                            float Gr[9])
{
    const int cap = s->nb_cap;
    const uint32_t *restrict nb = s->nb + i * (size_t)cap;
    const int nplain = s->nb_plain[i], ntot = s->nb_count[i];
    const float *restrict X = s->x, *restrict Y = s->y, *restrict Z = s->z;
    const float *restrict VX = s->vx, *restrict VY = s->vy, *restrict VZ = s->vz;
    const float *restrict VOL = s->vol;
    const float hx = s->wrap_h[0], hy = s->wrap_h[1], hz = s->wrap_h[2];
    const float Lx = s->len[0], Ly = s->len[1], Lz = s->len[2];
    const sq__sph_kern kk = s->k;
    const float xi = X[i], yi = Y[i], zi = Z[i];
    const float vxi = VX[i], vyi = VY[i], vzi = VZ[i];
#if SQ__SPH_AVX512
    /* 16 neighbours per vector, their x y z V vx vy vz read from the packed records (X … VOL
     * serve only the portable loop) */
    (void)Y;
    (void)Z;
    (void)VY;
    (void)VZ;
    (void)VOL;
    const float *restrict P = s->rec;
    const __m512 vxi_ = VSET1(xi), vyi_ = VSET1(yi), vzi_ = VSET1(zi);
    const __m512 wvx = VSET1(vxi), wvy = VSET1(vyi), wvz = VSET1(vzi);
    __m512 b0 = _mm512_setzero_ps(), b1 = b0, b2 = b0, b3 = b0, b4 = b0, b5 = b0;
    __m512 g0 = b0, g1 = b0, g2 = b0, g3 = b0, g4 = b0, g5 = b0, g6 = b0, g7 = b0, g8 = b0;
    for (int k0 = 0; k0 < nplain; k0 += 16) {
        __m512 rj[8]; /* the far record of lanes beyond the list gives f = 0, V = 0 */
        v_load_recs(P, nb + k0, nplain - k0, rj);
        const __m512 dx = v_wrap(VSUB(vxi_, rj[0]), hx, Lx);
        const __m512 dy = v_wrap(VSUB(vyi_, rj[1]), hy, Ly);
        const __m512 dz = v_wrap(VSUB(vzi_, rj[2]), hz, Lz);
        const __m512 vol = rj[3];
        const __m512 ux = VSUB(rj[4], wvx);
        const __m512 uy = VSUB(rj[5], wvy);
        const __m512 uz = VSUB(rj[6], wvz);
        const __m512 r2 = VADD(VADD(VMUL(dx, dx), VMUL(dy, dy)), VMUL(dz, dz));
        const __m512 ir = v_inv_dist(r2);
        /* V_j ∇W = f d; dead lanes have V = 0 */
        const __m512 f = VMUL(v_gradf(&kk, VMUL(r2, ir), ir, cubic), vol);
        const __m512 gx = VMUL(f, dx), gy = VMUL(f, dy), gz = VMUL(f, dz);
        /* B += V_j (x_j − x_i) ⊗ ∇W = −(d ⊗ f d) */
        b0 = VSUB(b0, VMUL(dx, gx));
        b1 = VSUB(b1, VMUL(dy, gy));
        b2 = VSUB(b2, VMUL(dz, gz));
        b3 = VSUB(b3, VMUL(dx, gy));
        b4 = VSUB(b4, VMUL(dx, gz));
        b5 = VSUB(b5, VMUL(dy, gz));
        g0 = VADD(g0, VMUL(ux, gx));
        g1 = VADD(g1, VMUL(ux, gy));
        g2 = VADD(g2, VMUL(ux, gz));
        g3 = VADD(g3, VMUL(uy, gx));
        g4 = VADD(g4, VMUL(uy, gy));
        g5 = VADD(g5, VMUL(uy, gz));
        g6 = VADD(g6, VMUL(uz, gx));
        g7 = VADD(g7, VMUL(uz, gy));
        g8 = VADD(g8, VMUL(uz, gz));
    }
    {
        const __m512 z0 = _mm512_setzero_ps();
        const __m512 acc[16] = {b0, b1, b2, b3, b4, b5, g0, g1, g2, g3, g4, g5, g6, g7, g8, z0};
        float sums[16];
        _mm512_storeu_ps(sums, v_sum16(acc));
        for (int t = 0; t < 6; t++) B[t] = sums[t];
        for (int t = 0; t < 9; t++) Gr[t] = sums[6 + t];
    }
#else
    float b0 = 0, b1 = 0, b2 = 0, b3 = 0, b4 = 0, b5 = 0;
    float g0 = 0, g1 = 0, g2 = 0, g3 = 0, g4 = 0, g5 = 0, g6 = 0, g7 = 0, g8 = 0;
    /* gather the neighbours into short local arrays, then a clean vectorisable loop */
    float lx[SQ__SPH_CHUNK], ly[SQ__SPH_CHUNK], lz[SQ__SPH_CHUNK], lv[SQ__SPH_CHUNK];
    float lu[SQ__SPH_CHUNK], lw[SQ__SPH_CHUNK], lt[SQ__SPH_CHUNK];
    for (int k0 = 0; k0 < nplain; k0 += SQ__SPH_CHUNK) {
        const int n = nplain - k0 < SQ__SPH_CHUNK ? nplain - k0 : SQ__SPH_CHUNK;
        for (int k = 0; k < n; k++) {
            const uint32_t j = nb[k0 + k];
            lx[k] = wrap1(xi - X[j], hx, Lx);
            ly[k] = wrap1(yi - Y[j], hy, Ly);
            lz[k] = wrap1(zi - Z[j], hz, Lz);
            lv[k] = VOL[j];
            lu[k] = VX[j] - vxi;
            lw[k] = VY[j] - vyi;
            lt[k] = VZ[j] - vzi;
        }
        SQ_OMP(omp simd reduction(+ : b0, b1, b2, b3, b4, b5, g0, g1, g2, g3, g4, g5, g6, g7, g8))
        for (int k = 0; k < n; k++) {
            const float dx = lx[k], dy = ly[k], dz = lz[k];
            const float r2 = dx * dx + dy * dy + dz * dz;
            const float ir = inv_dist(r2);
            const float f = sq__sph_gradf_rk(&kk, r2 * ir, ir, cubic) * lv[k]; /* V_j ∇W = f d */
            const float gx = f * dx, gy = f * dy, gz = f * dz;
            /* B += V_j (x_j − x_i) ⊗ ∇W = −(d ⊗ f d) */
            b0 -= dx * gx;
            b1 -= dy * gy;
            b2 -= dz * gz;
            b3 -= dx * gy;
            b4 -= dx * gz;
            b5 -= dy * gz;
            const float ux = lu[k], uy = lw[k], uz = lt[k];
            g0 += ux * gx;
            g1 += ux * gy;
            g2 += ux * gz;
            g3 += uy * gx;
            g4 += uy * gy;
            g5 += uy * gz;
            g6 += uz * gx;
            g7 += uz * gy;
            g8 += uz * gz;
        }
    }
    B[0] = b0;
    B[1] = b1;
    B[2] = b2;
    B[3] = b3;
    B[4] = b4;
    B[5] = b5;
    Gr[0] = g0;
    Gr[1] = g1;
    Gr[2] = g2;
    Gr[3] = g3;
    Gr[4] = g4;
    Gr[5] = g5;
    Gr[6] = g6;
    Gr[7] = g7;
    Gr[8] = g8;
#endif
    for (int k = nplain; k < ntot; k++) {
        image im;
        image_state(s, i, nb[k], 0, &im);
        const float *d = im.d;
        const float r = sqrtf(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        const float f = sq__sph_gradf(&kk, r) * im.vol;
        const float gx = f * d[0], gy = f * d[1], gz = f * d[2];
        B[0] -= d[0] * gx;
        B[1] -= d[1] * gy;
        B[2] -= d[2] * gz;
        B[3] -= d[0] * gy;
        B[4] -= d[0] * gz;
        B[5] -= d[1] * gz;
        const float ux = im.v[0] - vxi, uy = im.v[1] - vyi, uz = im.v[2] - vzi;
        Gr[0] += ux * gx; Gr[1] += ux * gy; Gr[2] += ux * gz;
        Gr[3] += uy * gx; Gr[4] += uy * gy; Gr[5] += uy * gz;
        Gr[6] += uz * gx; Gr[7] += uz * gy; Gr[8] += uz * gz;
    }
}

/* Particle i's correction L = B⁻¹ (or I), G = Gr L, |γ̇|, μ and τ from its sums; returns μ. */
SQ__INLINE float strain_tail(sq_sph *restrict s, size_t i, const float B[6], const float Gr[9],
                             const int newtonian, const int corrected)
{
    float L[6] = {1, 1, 1, 0, 0, 0};
    if (corrected) sym_inverse(B, L);
    float *restrict Ls = s->L + 6 * i;
    for (int t = 0; t < 6; t++) Ls[t] = L[t];
    /* G = Gr L (L symmetric); stored for the mirror images of the TENSOR form */
    const float Lm[3][3] = {{L[0], L[3], L[4]}, {L[3], L[1], L[5]}, {L[4], L[5], L[2]}};
    const int tensor = s->visc == SQ_SPH_VISCOUS_TENSOR;
    float G[9];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            G[3 * a + b] = Gr[3 * a] * Lm[0][b] + Gr[3 * a + 1] * Lm[1][b] + Gr[3 * a + 2] * Lm[2][b];
    if (tensor) {
        float *restrict Gs = s->G + 9 * i;
        for (int c = 0; c < 9; c++) Gs[c] = G[c];
    }
    const float D[6] = {G[0], G[4], G[8], 0.5f * (G[1] + G[3]), 0.5f * (G[2] + G[6]),
                        0.5f * (G[5] + G[7])};
    const float dd = D[0] * D[0] + D[1] * D[1] + D[2] * D[2] +
                     2.0f * (D[3] * D[3] + D[4] * D[4] + D[5] * D[5]);
    const float gam = sqrtf(2.0f * dd);
    s->gam[i] = gam;
    const float mu = newtonian ? s->rheo.mu : sq__sph_rheo_mu(&s->rheo, gam);
    if (tensor) {
        float *restrict tau = s->tau + 6 * i;
        for (int t = 0; t < 6; t++) tau[t] = 2.0f * mu * D[t];
    }
    s->mu[i] = mu;
    return mu;
}

SQ__INLINE float strain_particle(sq_sph *restrict s, size_t i, const int newtonian,
                                 const int corrected, const int cubic)
{
    float B[6], Gr[9];
    strain_sums(s, i, cubic, B, Gr);
    return strain_tail(s, i, B, Gr, newtonian, corrected);
}

#if SQ__SPH_AVX512
/* strain_tail for the nt ≤ 16 particles i0 + t at once (lane t), from their sums B[c][t] and
 * Gr[c][t]: the same operations in the same order, 16 lanes wide. Returns max μ. */
SQ__INLINE float strain_tail16(sq_sph *restrict s, size_t i0, int nt, float B[6][16],
                               float Gr[9][16], const int newtonian, const int corrected)
{
    for (int t = nt; t < 16; t++) { /* idle lanes: B = I, Gr = 0 */
        for (int c = 0; c < 6; c++) B[c][t] = c < 3 ? 1.0f : 0.0f;
        for (int c = 0; c < 9; c++) Gr[c][t] = 0.0f;
    }
    const __m512 one = VSET1(1.0f), z0 = _mm512_setzero_ps();
    __m512 L[6] = {one, one, one, z0, z0, z0};
    if (corrected) { /* sym_inverse */
        const __m512 a = _mm512_loadu_ps(B[0]), b = _mm512_loadu_ps(B[1]), c = _mm512_loadu_ps(B[2]);
        const __m512 d = _mm512_loadu_ps(B[3]), e = _mm512_loadu_ps(B[4]), f = _mm512_loadu_ps(B[5]);
        const __m512 cxx = VSUB(VMUL(b, c), VMUL(f, f)), cyy = VSUB(VMUL(a, c), VMUL(e, e));
        const __m512 czz = VSUB(VMUL(a, b), VMUL(d, d)), cxy = VSUB(VMUL(e, f), VMUL(d, c));
        const __m512 cxz = VSUB(VMUL(d, f), VMUL(b, e)), cyz = VSUB(VMUL(d, e), VMUL(a, f));
        const __m512 det = VADD(VADD(VMUL(a, cxx), VMUL(d, cxy)), VMUL(e, cxz));
        const __mmask16 m1 = _mm512_cmp_ps_mask(det, VSET1(SQ__SPH_DET_MIN), _CMP_GE_OQ);
        const __m512 id = _mm512_div_ps(one, det);
        const __mmask16 m2 =
            m1 & _mm512_cmp_ps_mask(VMUL(VADD(VADD(cxx, cyy), czz), id), VSET1(SQ__SPH_TRACE_MAX),
                                    _CMP_LE_OQ);
        L[0] = _mm512_mask_blend_ps(m2, one, VMUL(cxx, id));
        L[1] = _mm512_mask_blend_ps(m2, one, VMUL(cyy, id));
        L[2] = _mm512_mask_blend_ps(m2, one, VMUL(czz, id));
        L[3] = _mm512_mask_blend_ps(m2, z0, VMUL(cxy, id));
        L[4] = _mm512_mask_blend_ps(m2, z0, VMUL(cxz, id));
        L[5] = _mm512_mask_blend_ps(m2, z0, VMUL(cyz, id));
    }
    /* G = Gr L (L symmetric) */
    const __m512 Lm[3][3] = {{L[0], L[3], L[4]}, {L[3], L[1], L[5]}, {L[4], L[5], L[2]}};
    __m512 G[9];
    for (int a = 0; a < 3; a++) {
        const __m512 r0 = _mm512_loadu_ps(Gr[3 * a]), r1 = _mm512_loadu_ps(Gr[3 * a + 1]);
        const __m512 r2 = _mm512_loadu_ps(Gr[3 * a + 2]);
        for (int b = 0; b < 3; b++)
            G[3 * a + b] = VADD(VADD(VMUL(r0, Lm[0][b]), VMUL(r1, Lm[1][b])), VMUL(r2, Lm[2][b]));
    }
    const __m512 half = VSET1(0.5f);
    const __m512 D[6] = {G[0], G[4], G[8], VMUL(half, VADD(G[1], G[3])),
                         VMUL(half, VADD(G[2], G[6])), VMUL(half, VADD(G[5], G[7]))};
    const __m512 dd =
        VADD(VADD(VADD(VMUL(D[0], D[0]), VMUL(D[1], D[1])), VMUL(D[2], D[2])),
             VMUL(VSET1(2.0f), VADD(VADD(VMUL(D[3], D[3]), VMUL(D[4], D[4])), VMUL(D[5], D[5]))));
    const __m512 gam = _mm512_sqrt_ps(VMUL(VSET1(2.0f), dd));
    float gl[16], mul[16], Ll[6][16], Gl[9][16], Dl[6][16];
    _mm512_storeu_ps(gl, gam);
    const sq__sph_rheo *rh = &s->rheo;
    if (newtonian) {
        _mm512_storeu_ps(mul, VSET1(rh->mu));
    } else if (rh->kind == SQ_SPH_RHEOLOGY_CROSS && rh->n == 2.0f) {
        /* sq__sph_rheo_mu for Cross with n = 2 */
        const __m512 kg = VMUL(VSET1(rh->k), gam);
        __m512 mu = VADD(VSET1(rh->mu_inf), _mm512_div_ps(VSET1(rh->mu0 - rh->mu_inf),
                                                          VADD(one, VMUL(kg, kg))));
        if (rh->mu_cap > 0.0f)
            mu = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(mu, VSET1(rh->mu_cap), _CMP_GT_OQ), mu,
                                      VSET1(rh->mu_cap));
        _mm512_storeu_ps(mul, mu);
    } else {
        for (int t = 0; t < nt; t++) mul[t] = sq__sph_rheo_mu(rh, gl[t]);
    }
    for (int c = 0; c < 6; c++) _mm512_storeu_ps(Ll[c], L[c]);
    const int tensor = s->visc == SQ_SPH_VISCOUS_TENSOR;
    if (tensor) {
        for (int c = 0; c < 9; c++) _mm512_storeu_ps(Gl[c], G[c]);
        for (int c = 0; c < 6; c++) _mm512_storeu_ps(Dl[c], D[c]);
    }
    float m = 0.0f;
    for (int t = 0; t < nt; t++) {
        const size_t i = i0 + (size_t)t;
        float *restrict Ls = s->L + 6 * i;
        for (int c = 0; c < 6; c++) Ls[c] = Ll[c][t];
        s->gam[i] = gl[t];
        const float mu = mul[t];
        if (tensor) {
            float *restrict Gs = s->G + 9 * i;
            for (int c = 0; c < 9; c++) Gs[c] = Gl[c][t];
            float *restrict tau = s->tau + 6 * i;
            for (int c = 0; c < 6; c++) tau[c] = 2.0f * mu * Dl[c][t];
        }
        s->mu[i] = mu;
        m = mu > m ? mu : m;
    }
    return m;
}

#define SQ__SPH_STRAIN_BLOCK(NAME, NEWT, CORR, CUBIC)                                         \
    SQ__SPH_CLONES static float NAME(sq_sph *restrict s, size_t i0, size_t i1)               \
    {                                                                                       \
        float m = 0.0f;                                                                     \
        for (size_t b = i0; b < i1; b += 16) {                                              \
            const int nt = (int)(i1 - b < 16 ? i1 - b : 16);                                \
            float B[6][16], Gr[9][16];                                                      \
            for (int t = 0; t < nt; t++) {                                                  \
                float Bt[6], Gt[9];                                                         \
                strain_sums(s, b + (size_t)t, CUBIC, Bt, Gt);                               \
                for (int c = 0; c < 6; c++) B[c][t] = Bt[c];                                \
                for (int c = 0; c < 9; c++) Gr[c][t] = Gt[c];                               \
            }                                                                               \
            const float mu = strain_tail16(s, b, nt, B, Gr, NEWT, CORR);                    \
            m = mu > m ? mu : m;                                                            \
        }                                                                                   \
        return m;                                                                           \
    }
#else
#define SQ__SPH_STRAIN_BLOCK(NAME, NEWT, CORR, CUBIC)                                         \
    SQ__SPH_CLONES static float NAME(sq_sph *restrict s, size_t i0, size_t i1)               \
    {                                                                                       \
        float m = 0.0f;                                                                     \
        for (size_t i = i0; i < i1; i++) {                                                  \
            const float mu = strain_particle(s, i, NEWT, CORR, CUBIC);                      \
            m = mu > m ? mu : m;                                                            \
        }                                                                                   \
        return m;                                                                           \
    }
#endif
SQ__SPH_STRAIN_BLOCK(strain_block_000, 0, 0, 0)
SQ__SPH_STRAIN_BLOCK(strain_block_001, 0, 0, 1)
SQ__SPH_STRAIN_BLOCK(strain_block_010, 0, 1, 0)
SQ__SPH_STRAIN_BLOCK(strain_block_011, 0, 1, 1)
SQ__SPH_STRAIN_BLOCK(strain_block_100, 1, 0, 0)
SQ__SPH_STRAIN_BLOCK(strain_block_101, 1, 0, 1)
SQ__SPH_STRAIN_BLOCK(strain_block_110, 1, 1, 0)
SQ__SPH_STRAIN_BLOCK(strain_block_111, 1, 1, 1)

typedef float (*strain_block_fn)(sq_sph *restrict s, size_t i0, size_t i1);

float sq__sph_pass_strain(sq_sph *s)
{
    SQ__SPH_DISPATCH(sq__sph_pass_strain);
    static const strain_block_fn table[8] = {strain_block_000, strain_block_001, strain_block_010,
                                             strain_block_011, strain_block_100, strain_block_101,
                                             strain_block_110, strain_block_111};
    const size_t N = s->count;
    const int64_t nblk = (int64_t)((N + SQ__SPH_BLOCK - 1) / SQ__SPH_BLOCK);
    const int nt = sq__sph_threads(s, N);
    const strain_block_fn fn =
        table[(s->newtonian ? 4 : 0) | (s->corrected ? 2 : 0) | (s->k.cubic ? 1 : 0)];
    float mumax = 0.0f;
    SQ_OMP(omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(max : mumax))
    for (int64_t b = 0; b < nblk; b++) {
        const size_t i0 = (size_t)b * SQ__SPH_BLOCK;
        const size_t i1 = i0 + SQ__SPH_BLOCK < N ? i0 + SQ__SPH_BLOCK : N;
        const float m = fn(s, i0, i1);
        if (m > mumax) mumax = m;
    }
    return mumax;
}

/* ---- force pass ------------------------------------------------------------------------------ */

/* One pair's acceleration and XSPH contributions to particle i (d = x_i − x_j, r² = |d|²,
 * u = v_j − v_i); the j-side quantities are passed in. Branch-free so that the neighbour loop
 * vectorises. visc selects the viscous term (sq_sph_viscous). */
typedef struct pair_out {
    float a0, a1, a2, x0, x1, x2;
} pair_out;

SQ__INLINE pair_out pair_force(const sq__sph_kern *restrict kk, float m, float avc,
                               float pgrad_c, float dx,
                               float dy, float dz, float r2, float ux, float uy, float uz,
                               float rho_i, float irho_i, float rho_j, float vol_j, float pr2_i,
                               float pr2_j, const float Li[6], const float *Lj, float mu_i,
                               float mu_j, const float ti[6], const float *tj, const int visc,
                               const int corrected, const int cubic)
{
    const float ir = inv_dist(r2);
    const float r = r2 * ir;
    const float f = sq__sph_gradf_rk(kk, r, ir, cubic);
    /* pressure and artificial viscosity: the kernel gradient times a constant (so that they
     * stay the gradient of an energy, see sq_sph.pgrad_c) */
    const float fp = f * pgrad_c;
    float gx = f * dx, gy = f * dy, gz = f * dz;
    if (visc == SQ_SPH_VISCOUS_TENSOR && corrected) {
        const float l0 = 0.5f * (Li[0] + Lj[0]), l1 = 0.5f * (Li[1] + Lj[1]);
        const float l2 = 0.5f * (Li[2] + Lj[2]), l3 = 0.5f * (Li[3] + Lj[3]);
        const float l4 = 0.5f * (Li[4] + Lj[4]), l5 = 0.5f * (Li[5] + Lj[5]);
        const float tx = l0 * gx + l3 * gy + l4 * gz;
        const float ty = l3 * gx + l1 * gy + l5 * gz;
        const float tz = l4 * gx + l5 * gy + l2 * gz;
        gx = tx;
        gy = ty;
        gz = tz;
    }
    /* pressure −m (p_i/ρ_i² + p_j/ρ_j²) ∇̃W and Monaghan's artificial viscosity −m Π_ij ∇̃W */
    const float vr = -(ux * dx + uy * dy + uz * dz); /* v_ij · x_ij */
    const float pi = -avc * (vr < 0.0f ? vr : 0.0f) /
                     ((r2 + 0.01f * kk->ell2) * 0.5f * (rho_i + rho_j));
    const float cp = -m * (pr2_i + pr2_j + pi) * fp;
    pair_out o;
    o.a0 = cp * dx;
    o.a1 = cp * dy;
    o.a2 = cp * dz;
    const float cv = vol_j * irho_i; /* m / (ρ_i ρ_j) */
    if (visc == SQ_SPH_VISCOUS_TENSOR) {
        /* SPEC eq. 3.57: m (τ_i + τ_j)/(ρ_i ρ_j) · ∇̃W */
        const float t0 = ti[0] + tj[0], t1 = ti[1] + tj[1], t2 = ti[2] + tj[2];
        const float t3 = ti[3] + tj[3], t4 = ti[4] + tj[4], t5 = ti[5] + tj[5];
        o.a0 += cv * (t0 * gx + t3 * gy + t4 * gz);
        o.a1 += cv * (t3 * gx + t1 * gy + t5 * gz);
        o.a2 += cv * (t4 * gx + t5 * gy + t2 * gz);
    } else {
        float c;
        if (visc == SQ_SPH_VISCOUS_MULLER) {
            /* Müller 2003 eq. 3.39, symmetrised: ½(μ_i + μ_j) m/(ρ_i ρ_j) ∇²W_visc (v_j − v_i) */
            c = 0.5f * (mu_i + mu_j) * cv * sq__sph_lap_visc(kk, r);
        } else {
            /* Morris 1997: (μ_i + μ_j) m/(ρ_i ρ_j) (x_ij·∇W)/(r² + 0.01 ℓ²) (v_i − v_j), with the
             * same constant lattice normalisation as the pressure term */
            c = -(mu_i + mu_j) * cv * fp * r2 / (r2 + 0.01f * kk->ell2);
        }
        o.a0 += c * ux;
        o.a1 += c * uy;
        o.a2 += c * uz;
    }
    /* XSPH 2m/(ρ_i + ρ_j) W (v_j − v_i) */
    const float w = cubic ? sq__sph_w_cubic(kk, r) : sq__sph_w_poly6(kk, r2);
    const float cx = 2.0f * m * w / (rho_i + rho_j);
    o.x0 = cx * ux;
    o.x1 = cx * uy;
    o.x2 = cx * uz;
    return o;
}

SQ__INLINE float force_particle(sq_sph *restrict s, size_t i, const int visc, const int corrected,
                                const int cubic)
{
    const int cap = s->nb_cap;
    const uint32_t *restrict nb = s->nb + i * (size_t)cap;
    const int nplain = s->nb_plain[i], ntot = s->nb_count[i];
    static const float I6[6] = {1, 1, 1, 0, 0, 0};
    static const float Z6[6] = {0, 0, 0, 0, 0, 0};
    const int tensor = visc == SQ_SPH_VISCOUS_TENSOR;
    const float *restrict X = s->x, *restrict Y = s->y, *restrict Z = s->z;
    const float *restrict VX = s->vx, *restrict VY = s->vy, *restrict VZ = s->vz;
    const float *restrict RHO = s->rho, *restrict VOL = s->vol, *restrict PR2 = s->pr2;
    const float *restrict LL = s->L, *restrict TT = s->tau, *restrict MU = s->mu;
    const float hx = s->wrap_h[0], hy = s->wrap_h[1], hz = s->wrap_h[2];
    const float Lx = s->len[0], Ly = s->len[1], Lz = s->len[2];
    const sq__sph_kern kk = s->k;
    const float m = s->mass, avc = s->av_c, pgc = s->pgrad_c;
    const float xi = X[i], yi = Y[i], zi = Z[i];
    const float vxi = VX[i], vyi = VY[i], vzi = VZ[i];
    const float rho_i = RHO[i], irho_i = 1.0f / rho_i, pr2_i = PR2[i], mu_i = MU[i];
    float Li[6], ti[6];
    for (int t = 0; t < 6; t++) {
        Li[t] = corrected && tensor ? LL[6 * i + (size_t)t] : I6[t];
        ti[t] = tensor ? TT[6 * i + (size_t)t] : 0.0f;
    }
    float a0 = 0, a1 = 0, a2 = 0, x0 = 0, x1 = 0, x2 = 0;
#if SQ__SPH_AVX512
    if (!tensor) {
        /* 16 neighbours per vector: x y z V vx vy vz p/ρ² from the packed record, ρ and μ
         * from their arrays; pair_force's arithmetic for the Morris and Müller forms */
        const float *restrict P = s->rec;
        const __m512 z0 = _mm512_setzero_ps();
        const __m512 vxi_ = VSET1(xi), vyi_ = VSET1(yi), vzi_ = VSET1(zi);
        const __m512 wvx = VSET1(vxi), wvy = VSET1(vyi), wvz = VSET1(vzi);
        const __m512 vrho_i = VSET1(rho_i), virho_i = VSET1(irho_i), vpr2_i = VSET1(pr2_i);
        const __m512 vmu_i = VSET1(mu_i), vpgc = VSET1(pgc), veps = VSET1(0.01f * kk.ell2);
        const __m512 vnavc = VSET1(-avc), vnm = VSET1(-m), v2m = VSET1(2.0f * m);
        __m512 va0 = z0, va1 = z0, va2 = z0, vx0 = z0, vx1 = z0, vx2 = z0;
        const __m512i vperm = _mm512_setr_epi32(0, 1, 2, 3, 8, 9, 10, 11, 4, 5, 6, 7, 12, 13, 14, 15);
        for (int k0 = 0; k0 < nplain; k0 += 16) {
            /* lanes in v_load_recs order; the index vector and live mask permuted alike */
            const int n = nplain - k0;
            const __mmask16 live = _mm512_cmplt_epi32_mask(vperm, _mm512_set1_epi32(n));
            const __m512i jv = _mm512_permutexvar_epi32(
                vperm, _mm512_maskz_loadu_epi32(v_live((uint32_t)n), nb + k0));
            __m512 rj[8];
            v_load_recs(P, nb + k0, n, rj);
            const __m512 dx = v_wrap(VSUB(vxi_, rj[0]), hx, Lx);
            const __m512 dy = v_wrap(VSUB(vyi_, rj[1]), hy, Ly);
            const __m512 dz = v_wrap(VSUB(vzi_, rj[2]), hz, Lz);
            const __m512 vol_j = rj[3];
            const __m512 ux = VSUB(rj[4], wvx);
            const __m512 uy = VSUB(rj[5], wvy);
            const __m512 uz = VSUB(rj[6], wvz);
            const __m512 pr2_j = rj[7];
            const __m512 rho_j = _mm512_mask_i32gather_ps(VSET1(1.0f), live, jv, RHO, 4);
            const __m512 mu_j = _mm512_mask_i32gather_ps(z0, live, jv, MU, 4);
            const __m512 r2 = VADD(VADD(VMUL(dx, dx), VMUL(dy, dy)), VMUL(dz, dz));
            const __m512 ir = v_inv_dist(r2);
            const __m512 r = VMUL(r2, ir);
            const __m512 f = _mm512_maskz_mov_ps(live, v_gradf(&kk, r, ir, cubic));
            const __m512 fp = VMUL(f, vpgc);
            const __m512 rsum = VADD(vrho_i, rho_j);
            __m512 pp = VADD(vpr2_i, pr2_j);
            if (avc != 0.0f) {
                /* Monaghan: −α c ℓ min(v_ij·x_ij, 0) / ((r² + 0.01 ℓ²) ½ (ρ_i + ρ_j)) */
                const __m512 vr = _mm512_sub_ps(z0, VADD(VADD(VMUL(ux, dx), VMUL(uy, dy)), VMUL(uz, dz)));
                const __m512 num = VMUL(vnavc, _mm512_min_ps(vr, z0));
                const __m512 den = VMUL(VMUL(VADD(r2, veps), VSET1(0.5f)), rsum);
                pp = VADD(pp, _mm512_div_ps(num, den));
            }
            const __m512 cp = VMUL(VMUL(vnm, pp), fp);
            va0 = VADD(va0, VMUL(cp, dx));
            va1 = VADD(va1, VMUL(cp, dy));
            va2 = VADD(va2, VMUL(cp, dz));
            const __m512 cv = VMUL(vol_j, virho_i);
            __m512 c;
            if (visc == SQ_SPH_VISCOUS_MULLER) {
                const __m512 w = VSUB(VSET1(1.0f), VMUL(r, VSET1(kk.inv_H)));
                const __m512 lap = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(w, z0, _CMP_GT_OQ),
                                                       VMUL(VSET1(kk.visc_lap_c), w));
                c = VMUL(VMUL(VMUL(VSET1(0.5f), VADD(vmu_i, mu_j)), cv), lap);
            } else {
                const __m512 nmu = _mm512_sub_ps(z0, VADD(vmu_i, mu_j));
                c = _mm512_div_ps(VMUL(VMUL(VMUL(nmu, cv), fp), r2), VADD(r2, veps));
            }
            va0 = VADD(va0, VMUL(c, ux));
            va1 = VADD(va1, VMUL(c, uy));
            va2 = VADD(va2, VMUL(c, uz));
            const __m512 w = _mm512_maskz_mov_ps(live, v_w(&kk, r, r2, cubic));
            const __m512 cx = _mm512_div_ps(VMUL(v2m, w), rsum);
            vx0 = VADD(vx0, VMUL(cx, ux));
            vx1 = VADD(vx1, VMUL(cx, uy));
            vx2 = VADD(vx2, VMUL(cx, uz));
        }
        const __m512 acc[16] = {va0, va1, va2, vx0, vx1, vx2, z0, z0, z0, z0, z0, z0, z0, z0, z0, z0};
        float sums[16];
        _mm512_storeu_ps(sums, v_sum16(acc));
        a0 = sums[0];
        a1 = sums[1];
        a2 = sums[2];
        x0 = sums[3];
        x1 = sums[4];
        x2 = sums[5];
    } else
#endif
    SQ_OMP(omp simd reduction(+ : a0, a1, a2, x0, x1, x2))
    for (int k = 0; k < nplain; k++) {
        const uint32_t j = nb[k];
        const float dx = wrap1(xi - X[j], hx, Lx), dy = wrap1(yi - Y[j], hy, Ly),
                    dz = wrap1(zi - Z[j], hz, Lz);
        const float r2 = dx * dx + dy * dy + dz * dz;
        const pair_out o = pair_force(&kk, m, avc, pgc, dx, dy, dz, r2, VX[j] - vxi, VY[j] - vyi,
                                      VZ[j] - vzi, rho_i, irho_i, RHO[j], VOL[j], pr2_i, PR2[j],
                                      Li, corrected && tensor ? LL + 6 * (size_t)j : I6, mu_i,
                                      tensor ? 0.0f : MU[j], ti, tensor ? TT + 6 * (size_t)j : Z6,
                                      visc, corrected, cubic);
        a0 += o.a0;
        a1 += o.a1;
        a2 += o.a2;
        x0 += o.x0;
        x1 += o.x1;
        x2 += o.x2;
    }
    for (int k = nplain; k < ntot; k++) {
        image im;
        image_state(s, i, nb[k], tensor ? 2 : 1, &im);
        const float r2 = im.d[0] * im.d[0] + im.d[1] * im.d[1] + im.d[2] * im.d[2];
        const pair_out o = pair_force(&kk, m, avc, pgc, im.d[0], im.d[1], im.d[2], r2, im.v[0] - vxi,
                                      im.v[1] - vyi, im.v[2] - vzi, rho_i, irho_i, im.rho, im.vol,
                                      pr2_i, im.pr2, Li, corrected && tensor ? im.L : I6, mu_i, im.mu, ti,
                                      tensor ? im.tau : Z6, visc, corrected, cubic);
        a0 += o.a0;
        a1 += o.a1;
        a2 += o.a2;
        x0 += o.x0;
        x1 += o.x1;
        x2 += o.x2;
    }
    a0 += s->g[0];
    a1 += s->g[1];
    a2 += s->g[2];
    s->ax[i] = a0;
    s->ay[i] = a1;
    s->az[i] = a2;
    const float eps = s->xsph_eps;
    s->sx[i] = eps * x0;
    s->sy[i] = eps * x1;
    s->sz[i] = eps * x2;
    return a0 * a0 + a1 * a1 + a2 * a2;
}

#define SQ__SPH_FORCE_BLOCK(NAME, VISC, CORR, CUBIC)                                          \
    SQ__SPH_CLONES static float NAME(sq_sph *restrict s, size_t i0, size_t i1)               \
    {                                                                                       \
        float m = 0.0f;                                                                     \
        for (size_t i = i0; i < i1; i++) {                                                  \
            const float a2 = force_particle(s, i, VISC, CORR, CUBIC);                       \
            m = a2 > m ? a2 : m; /* non-finite values are reported by the integrator */    \
        }                                                                                   \
        return m;                                                                           \
    }
#define SQ__SPH_FORCE_BLOCKS(V, VN)                                                           \
    SQ__SPH_FORCE_BLOCK(force_block_##VN##_00, V, 0, 0)                                     \
    SQ__SPH_FORCE_BLOCK(force_block_##VN##_01, V, 0, 1)                                     \
    SQ__SPH_FORCE_BLOCK(force_block_##VN##_10, V, 1, 0)                                     \
    SQ__SPH_FORCE_BLOCK(force_block_##VN##_11, V, 1, 1)
SQ__SPH_FORCE_BLOCKS(SQ_SPH_VISCOUS_MORRIS, morris)
SQ__SPH_FORCE_BLOCKS(SQ_SPH_VISCOUS_MULLER, muller)
SQ__SPH_FORCE_BLOCKS(SQ_SPH_VISCOUS_TENSOR, tensor)

typedef float (*force_block_fn)(sq_sph *restrict s, size_t i0, size_t i1);

float sq__sph_pass_forces(sq_sph *s)
{
    SQ__SPH_DISPATCH(sq__sph_pass_forces);
    static const force_block_fn table[3][4] = {
        {force_block_morris_00, force_block_morris_01, force_block_morris_10, force_block_morris_11},
        {force_block_muller_00, force_block_muller_01, force_block_muller_10, force_block_muller_11},
        {force_block_tensor_00, force_block_tensor_01, force_block_tensor_10, force_block_tensor_11}};
    const size_t N = s->count;
    const int64_t nblk = (int64_t)((N + SQ__SPH_BLOCK - 1) / SQ__SPH_BLOCK);
    const int nt = sq__sph_threads(s, N);
    const int v = s->visc == SQ_SPH_VISCOUS_MULLER ? 1 : s->visc == SQ_SPH_VISCOUS_TENSOR ? 2 : 0;
    const int corr = v == 2 && s->corrected; /* only the tensor form uses L in pair terms */
    const force_block_fn fn = table[v][(corr ? 2 : 0) | (s->k.cubic ? 1 : 0)];
    float a2max = 0.0f;
    SQ_OMP(omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(max : a2max))
    for (int64_t b = 0; b < nblk; b++) {
        const size_t i0 = (size_t)b * SQ__SPH_BLOCK;
        const size_t i1 = i0 + SQ__SPH_BLOCK < N ? i0 + SQ__SPH_BLOCK : N;
        const float a2 = fn(s, i0, i1);
        if (a2 > a2max) a2max = a2;
    }
    return sqrtf(a2max);
}
