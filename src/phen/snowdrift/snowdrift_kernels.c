/* snowdrift_kernels.c — pure kernels of the snow model on the wind lattice (SPEC §5.6, S1 §2.2):
 * snowfall injection, stochastic transport with mean displacement (u − u_g)Δt (S1 eqs 8–11),
 * deposition with stable/roll-off configurations and solidification at a threshold, erosion
 * by the friction velocity (S1 eqs 12–13). Counts are integers; every rule moves flakes between
 * arrays without creating or destroying any, so the budget is exact. Randomness is
 * counter-based (Philox) per (purpose, step, cell): results do not depend on thread count. */
#include <math.h>
#include <string.h>

#include "snowdrift_internal.h"
#include "squall/rng.h"

/* below this many cells the kernels run serially (thread start-up would dominate) */
#define SQ_SNOW_PAR_MIN 32768

/* ---- random numbers ---------------------------------------------------------------------- */

void sq__snow_rng_init(sq__snow_rng *r, uint64_t seed, int purpose, uint64_t step, int64_t cell)
{
    r->seed = seed;
    /* stream: purpose in the top byte, step below; index: cell in the high bits, block low */
    r->stream = ((uint64_t)purpose << 56) ^ step;
    r->index = (uint64_t)cell << 20;
    r->avail = 0;
    r->has_next = false;
}

static uint32_t rng_u32(sq__snow_rng *r)
{
    if (r->avail == 0) {
        if (r->has_next) {
            for (int q = 0; q < 4; q++) r->buf[q] = r->next[q];
            r->has_next = false;
            r->index++;
        } else {
            sq_rng_bits(r->seed, r->stream, r->index++, r->buf);
        }
        r->avail = 4;
    }
    return r->buf[--r->avail];
}

float sq__snow_rng_uniform(sq__snow_rng *r) { return sq_u32_to_unit(rng_u32(r)); }

double sq__snow_rng_uniform_d(sq__snow_rng *r)
{
    const uint64_t a = rng_u32(r) >> 5, b = rng_u32(r) >> 6; /* 27 + 26 bits */
    return ((double)a * 67108864.0 + (double)b) * (1.0 / 9007199254740992.0);
}

static double rng_normal(sq__snow_rng *r)
{
    const double u1 = 1.0 - sq__snow_rng_uniform_d(r); /* (0, 1] */
    const double u2 = sq__snow_rng_uniform_d(r);
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}

uint32_t sq__snow_binomial(sq__snow_rng *r, uint32_t n, double p)
{
    if (n == 0 || !(p > 0)) return 0;
    if (p >= 1) return n;
    if (n <= 32) {
        /* one Bernoulli per flake: compare 32-bit uniforms with p in 2^-32 units */
        const double t = p * 4294967296.0;
        const uint32_t thr = t >= 4294967295.0 ? 4294967295u : (uint32_t)t;
        uint32_t k = 0;
        for (uint32_t i = 0; i < n; i++) k += rng_u32(r) < thr;
        return k;
    }
    const bool flip = p > 0.5;
    const double q = flip ? 1.0 - p : p;
    const double mean = n * q;
    uint32_t k;
    if (mean < 25.0) {
        /* inversion: walk the cumulative distribution from k = 0 */
        const double u = sq__snow_rng_uniform_d(r);
        const double ratio = q / (1.0 - q);
        double pk = pow(1.0 - q, (double)n), cdf = pk;
        k = 0;
        while (u >= cdf && k < n) {
            pk *= ratio * (double)(n - k) / (double)(k + 1);
            k++;
            cdf += pk;
            if (pk < 1e-300 && cdf < u) break; /* round-off tail: stop */
        }
    } else {
        /* normal approximation, stochastically rounded (E[floor(x + U)] = x) */
        const double x =
            mean + sqrt(mean * (1.0 - q)) * rng_normal(r) + sq__snow_rng_uniform_d(r);
        k = x <= 0 ? 0 : x >= (double)n ? n : (uint32_t)x;
    }
    return flip ? n - k : k;
}

/* ---- snowfall ---------------------------------------------------------------------------- */

uint64_t sq__snow_inject(const sq__snow_kparams *kp, double lambda, const uint8_t *kind,
                         uint32_t *air)
{
    if (!(lambda > 0)) return 0;
    const int nx = kp->nx, ny = kp->ny, k = kp->gnz - 1 - kp->kz0; /* the top plane */
    if (k < kp->k0 || k >= kp->k1) return 0;
    const int64_t base = (int64_t)k * nx * ny, g0 = (int64_t)kp->kz0 * nx * ny;
    const double whole = floor(lambda), frac = lambda - whole;
    uint64_t added = 0;
    for (int64_t q = 0; q < (int64_t)nx * ny; q++) {
        const int64_t c = base + q;
        if (kind[c] != SQ_SNOW_AIR) continue;
        sq__snow_rng r;
        sq__snow_rng_init(&r, kp->seed, SQ_SNOW_RNG_INJECT, kp->step, g0 + c);
        const uint32_t m = (uint32_t)whole + (sq__snow_rng_uniform_d(&r) < frac ? 1u : 0u);
        air[c] += m;
        added += m;
    }
    return added;
}

/* ---- transport --------------------------------------------------------------------------- */

static inline void add_atomic(uint32_t *a, uint32_t v)
{
    SQ_OMP(omp atomic)
    *a += v;
}

static inline void add_to(uint32_t *a, uint32_t v, bool atomic)
{
    if (atomic)
        add_atomic(a, v);
    else
        *a += v;
}

/* Philox4x32-10 of sq_rng_bits for up to SQ_SNOW_ROW lanes with one key, written lane-wise so
 * the compiler vectorises it: out[l][q] = sq_rng_bits(seed, stream, index[l])[q] bit for bit
 * (the first block of every cell of a row is drawn here at once). */
#define SQ_SNOW_ROW 256
static void philox_lanes(uint64_t seed, uint64_t stream, const uint64_t *index, int n,
                         uint32_t out[4][SQ_SNOW_ROW])
{
    uint32_t c0[SQ_SNOW_ROW], c1[SQ_SNOW_ROW], c2[SQ_SNOW_ROW], c3[SQ_SNOW_ROW];
    for (int l = 0; l < n; l++) {
        c0[l] = (uint32_t)index[l];
        c1[l] = (uint32_t)(index[l] >> 32);
        c2[l] = (uint32_t)stream;
        c3[l] = (uint32_t)(stream >> 32);
    }
    uint32_t k0 = (uint32_t)seed, k1 = (uint32_t)(seed >> 32);
    for (int r = 0; r < 10; r++) {
        for (int l = 0; l < n; l++) {
            const uint64_t p0 = (uint64_t)0xD2511F53u * c0[l];
            const uint64_t p1 = (uint64_t)0xCD9E8D57u * c2[l];
            const uint32_t n0 = (uint32_t)(p1 >> 32) ^ c1[l] ^ k0;
            const uint32_t n2 = (uint32_t)(p0 >> 32) ^ c3[l] ^ k1;
            c0[l] = n0;
            c1[l] = (uint32_t)p1;
            c2[l] = n2;
            c3[l] = (uint32_t)p0;
        }
        k0 += 0x9E3779B9u;
        k1 += 0xBB67AE85u;
    }
    for (int l = 0; l < n; l++) {
        out[0][l] = c0[l];
        out[1][l] = c1[l];
        out[2][l] = c2[l];
        out[3][l] = c3[l];
    }
}

/* Bernoulli(p) as sq__snow_binomial(r, 1, p) draws it (no draw for p <= 0 or p >= 1). */
static inline uint32_t bernoulli(sq__snow_rng *r, double p)
{
    if (!(p > 0)) return 0;
    if (p >= 1) return 1;
    const double t = p * 4294967296.0;
    const uint32_t thr = t >= 4294967295.0 ? 4294967295u : (uint32_t)t;
    return rng_u32(r) < thr;
}

/* Moves the flakes of one x-row (j, k). */
static inline void transport_row(const sq__snow_kparams *kp, int j, int k, const float *ux,
                                 const float *uy, const float *uz, const uint8_t *kind,
                                 const uint32_t *air, uint32_t *air_next, uint32_t *land,
                                 uint64_t *out, bool atomic)
{
    const int nx = kp->nx, ny = kp->ny;
    const int64_t sy = nx, sz = (int64_t)nx * ny, g0 = (int64_t)kp->kz0 * sz;
    const float s = kp->dt_over_dx, fall = kp->fall_cells;
    const uint64_t stream = ((uint64_t)SQ_SNOW_RNG_TRANSPORT << 56) ^ kp->step;
    for (int i0 = 0; i0 < nx; i0 += SQ_SNOW_ROW) {
        const int m = nx - i0 < SQ_SNOW_ROW ? nx - i0 : SQ_SNOW_ROW;
        const int64_t c0 = i0 + j * sy + k * sz;
        /* the occupied cells of this stretch and the first random block of each; the second
         * block too for cells holding several flakes (up to 12 draws) */
        int occ[SQ_SNOW_ROW], slot2[SQ_SNOW_ROW];
        uint64_t idx[SQ_SNOW_ROW], idx2[SQ_SNOW_ROW];
        int no = 0, n2 = 0;
        for (int i = 0; i < m; i++) { /* branch-free compaction (occupancy is random) */
            const uint32_t a = air[c0 + i];
            occ[no] = i;
            idx[no] = (uint64_t)(g0 + c0 + i) << 20;
            slot2[no] = a > 1 ? n2 : -1;
            idx2[n2] = idx[no] + 1;
            n2 += a > 1;
            no += a != 0;
        }
        if (no == 0) continue;
        uint32_t blk[4][SQ_SNOW_ROW], blk2[4][SQ_SNOW_ROW];
        philox_lanes(kp->seed, stream, idx, no, blk);
        if (n2 > 0) philox_lanes(kp->seed, stream, idx2, n2, blk2);
        for (int o = 0; o < no; o++) {
            const int i = i0 + occ[o];
            const int64_t c = c0 + occ[o];
            const uint32_t n = air[c];
            /* displacement in cells per step, S1 eq 8 */
            const int64_t cw = c - kp->wind0;
            const float d[3] = {ux[cw] * s, uy[cw] * s, uz[cw] * s - fall};
            int step[3];
            double pr[3];
            for (int a = 0; a < 3; a++) {
                const float v = d[a] > 1.0f ? 1.0f : d[a] < -1.0f ? -1.0f : d[a];
                step[a] = v >= 0 ? 1 : -1;
                pr[a] = fabsf(v);
            }
            /* the cell's generator (sq__snow_rng_init) with its first block already drawn */
            sq__snow_rng r;
            r.seed = kp->seed;
            r.stream = stream;
            r.index = idx[o] + 1;
            for (int q = 0; q < 4; q++) r.buf[q] = blk[q][o];
            r.avail = 4;
            r.has_next = slot2[o] >= 0;
            if (r.has_next)
                for (int q = 0; q < 4; q++) r.next[q] = blk2[q][slot2[o]];
            /* split n into the 8 groups (moves along x?, y?, z?) by binomial draws: the axes
             * are independent, as in S1 where one q is drawn per axis */
            uint32_t g[8];
            int qlo = 0, qhi = 8;
            if (n == 1) { /* one flake: the same three draws, without the splitting */
                const uint32_t mx = bernoulli(&r, pr[0]), my = bernoulli(&r, pr[1]);
                const uint32_t mz = bernoulli(&r, pr[2]);
                qlo = (int)(mx | my << 1 | mz << 2);
                qhi = qlo + 1;
                g[qlo] = 1;
            } else {
                const uint32_t mx = sq__snow_binomial(&r, n, pr[0]);
                const uint32_t gx[2] = {n - mx, mx};
                for (int bx = 0; bx < 2; bx++) {
                    const uint32_t my = sq__snow_binomial(&r, gx[bx], pr[1]);
                    const uint32_t gy[2] = {gx[bx] - my, my};
                    for (int by = 0; by < 2; by++) {
                        const uint32_t mz = sq__snow_binomial(&r, gy[by], pr[2]);
                        g[bx | by << 1 | 0 << 2] = gy[by] - mz;
                        g[bx | by << 1 | 1 << 2] = mz;
                    }
                }
            }
            uint32_t stay = 0, landed = 0;
            for (int q = qlo; q < qhi; q++) {
                const uint32_t cnt = g[q];
                if (cnt == 0) continue;
                if (q == 0) {
                    stay += cnt;
                    continue;
                }
                int ti = i + ((q & 1) ? step[0] : 0);
                int tj = j + ((q & 2) ? step[1] : 0);
                const int tk = k + ((q & 4) ? step[2] : 0);
                if (tk + kp->kz0 < 0) { /* the ground below the lattice */
                    landed += cnt;
                    continue;
                }
                if (tk + kp->kz0 >= kp->gnz) { /* out through the top */
                    *out += cnt;
                    continue;
                }
                if (ti < 0 || ti >= nx) {
                    if (!kp->periodic[0]) {
                        *out += cnt;
                        continue;
                    }
                    ti = ti < 0 ? ti + nx : ti - nx;
                }
                if (tj < 0 || tj >= ny) {
                    if (!kp->periodic[1]) {
                        *out += cnt;
                        continue;
                    }
                    tj = tj < 0 ? tj + ny : tj - ny;
                }
                const int64_t t = ti + tj * sy + tk * sz;
                if (kind[t] != SQ_SNOW_AIR) {
                    landed += cnt; /* hit a surface: deposition decides */
                    continue;
                }
                add_to(&air_next[t], cnt, atomic);
            }
            if (stay) add_to(&air_next[c], stay, atomic);
            land[c] = landed; /* only this iteration writes land[c] */
        }
    }
}

void sq__snow_transport(const sq__snow_kparams *kp, const float *ux, const float *uy,
                        const float *uz, const uint8_t *kind, const uint32_t *air,
                        uint32_t *air_next, uint32_t *land, uint64_t *left)
{
    const int ny = kp->ny, k0 = kp->k0, k1 = kp->k1, nt = kp->threads;
    const int64_t n = (int64_t)kp->nx * ny * (k1 - k0);
    uint64_t out = 0;
    if (nt > 1 && n >= SQ_SNOW_PAR_MIN) {
        /* flakes move at most one cell: neighbouring planes may write the same cells */
        SQ_OMP(omp parallel for schedule(dynamic, 1) num_threads(nt) reduction(+:out))
        for (int k = k0; k < k1; k++)
            for (int j = 0; j < ny; j++)
                transport_row(kp, j, k, ux, uy, uz, kind, air, air_next, land, &out, true);
    } else {
        for (int k = k0; k < k1; k++)
            for (int j = 0; j < ny; j++)
                transport_row(kp, j, k, ux, uy, uz, kind, air, air_next, land, &out, false);
    }
    *left += out;
}

/* ---- deposition and solidification ------------------------------------------------------- */

void sq__snow_settle_land(const sq__snow_kparams *kp, uint8_t *kind, uint32_t *land,
                          uint32_t *dep, uint32_t *air_next)
{
    const int nx = kp->nx, ny = kp->ny, k0 = kp->k0, k1 = kp->k1, nt = kp->threads;
    const int64_t sy = nx, sz = (int64_t)nx * ny, g0 = (int64_t)kp->kz0 * sz;
    const bool par = sz * (k1 - k0) >= SQ_SNOW_PAR_MIN;
    (void)nt; /* unused without OpenMP */
    SQ_OMP(omp parallel for schedule(dynamic, 1) num_threads(nt) if(par))
    for (int k = k0; k < k1; k++) {
        for (int j = 0; j < ny; j++) {
            for (int i = 0; i < nx; i++) {
                const int64_t c = i + j * sy + k * sz;
                const uint32_t m = land[c];
                if (m == 0) continue;
                land[c] = 0;
                const bool below_solid = k + kp->kz0 == 0 || kind[c - sz] != SQ_SNOW_AIR;
                if (below_solid) {
                    dep[c] += m; /* stable: supported from below */
                    continue;
                }
                /* roll-off: the free cells among the 8 lower diagonal neighbours */
                int64_t freec[8];
                int nf = 0;
                for (int b = -1; b <= 1; b++)
                    for (int a = -1; a <= 1; a++) {
                        if (a == 0 && b == 0) continue;
                        int ti = i + a, tj = j + b;
                        if (ti < 0 || ti >= nx) {
                            if (!kp->periodic[0]) continue;
                            ti = (ti + nx) % nx;
                        }
                        if (tj < 0 || tj >= ny) {
                            if (!kp->periodic[1]) continue;
                            tj = (tj + ny) % ny;
                        }
                        const int64_t t = ti + tj * sy + (k - 1) * sz;
                        if (kind[t] == SQ_SNOW_AIR) freec[nf++] = t;
                    }
                if (nf == 0) { /* every lower diagonal solid: drop into the hole below */
                    add_atomic(&air_next[c - sz], m);
                    continue;
                }
                sq__snow_rng r;
                sq__snow_rng_init(&r, kp->seed, SQ_SNOW_RNG_ROLL, kp->step, g0 + c);
                /* uniform choice among the free ones: sequential binomial splitting */
                uint32_t rest = m;
                for (int q = 0; q < nf && rest > 0; q++) {
                    const uint32_t take =
                        q == nf - 1 ? rest : sq__snow_binomial(&r, rest, 1.0 / (nf - q));
                    if (take) add_atomic(&air_next[freec[q]], take);
                    rest -= take;
                }
            }
        }
    }
}

void sq__snow_settle_solidify(const sq__snow_kparams *kp, int threshold, uint8_t *kind,
                              uint32_t *dep, uint32_t *air_next, uint8_t *changed)
{
    /* cells that filled up become snow-solid and engulf the flakes in their air */
    const int nt = kp->threads;
    const int64_t sz = (int64_t)kp->nx * kp->ny, c0 = kp->k0 * sz, c1 = kp->k1 * sz;
    const bool par = c1 - c0 >= SQ_SNOW_PAR_MIN;
    (void)nt; /* unused without OpenMP */
    const uint32_t thr = (uint32_t)threshold;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(par))
    for (int64_t c = c0; c < c1; c++) {
        if (kind[c] == SQ_SNOW_AIR && dep[c] > thr) {
            kind[c] = SQ_SNOW_SOLID;
            dep[c] += air_next[c];
            air_next[c] = 0;
            changed[c] = 1;
        }
    }
}

void sq__snow_settle(const sq__snow_kparams *kp, int threshold, uint8_t *kind, uint32_t *land,
                     uint32_t *dep, uint32_t *air_next, uint8_t *changed)
{
    sq__snow_settle_land(kp, kind, land, dep, air_next);
    sq__snow_settle_solidify(kp, threshold, kind, dep, air_next, changed);
}

/* ---- erosion ----------------------------------------------------------------------------- */

uint64_t sq__snow_erode(const sq__snow_kparams *kp, const sq__snow_params *sp,
                        const float *ustar, uint8_t *kind, uint32_t *dep, uint32_t *air_next,
                        uint8_t *changed)
{
    const int nx = kp->nx, ny = kp->ny, nt = kp->threads;
    const int64_t sz = (int64_t)nx * ny, c0 = kp->k0 * sz, c1 = kp->k1 * sz;
    const int64_t g0 = (int64_t)kp->kz0 * sz;
    const bool par = c1 - c0 >= SQ_SNOW_PAR_MIN;
    const double ut = sp->ustar_threshold_mps, eff = sp->erosion_efficiency;
    const double rate = sp->speedup * sp->dt_s / sp->saturation_time_s;
    const double mflake = sp->snow_density_kgm3 * sp->dx_m * sp->dx_m * sp->dx_m / sp->threshold;
    const double nsat = sp->saltation_kgm3 * sp->dx_m * sp->dx_m * sp->dx_m / mflake;
    uint64_t lifted = 0;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(+:lifted) if(par))
    for (int64_t c = c0; c < c1; c++) {
        if (kind[c] != SQ_SNOW_AIR) continue;
        const int64_t b = c - sz; /* the cell below (b + g0 < 0: the ground) */
        const bool ground = b + g0 < 0;
        const bool supported = ground || kind[b] != SQ_SNOW_AIR;
        if (!supported) {
            /* resting flakes whose support eroded away fall again */
            if (dep[c]) {
                air_next[c] += dep[c];
                dep[c] = 0;
            }
            continue;
        }
        if (!ustar) continue;
        const double us = ustar[c];
        if (!(us > ut)) continue;
        const uint32_t avail = dep[c] + (!ground && kind[b] == SQ_SNOW_SOLID ? dep[b] : 0u);
        if (avail == 0) continue;
        const double csat = eff * (1.0 - (ut * ut) / (us * us));
        const double csalt = air_next[c] / nsat;
        if (!(csat > csalt)) continue;
        const double e = rate * (csat - csalt) * nsat; /* expected flakes this step */
        sq__snow_rng r;
        sq__snow_rng_init(&r, kp->seed, SQ_SNOW_RNG_ERODE, kp->step, g0 + c);
        const double x = e + sq__snow_rng_uniform_d(&r);
        uint32_t k = x >= (double)avail ? avail : (uint32_t)x;
        if (k == 0) continue;
        air_next[c] += k;
        lifted += k;
        /* resting flakes first, then the snow-solid cell below */
        const uint32_t from_rest = k < dep[c] ? k : dep[c];
        dep[c] -= from_rest;
        k -= from_rest;
        if (k > 0) {
            dep[b] -= k;
            if (dep[b] == 0) changed[b] = 2; /* the last flake eroded: back to air (below) */
        }
    }
    /* kinds change only now, so every decision above saw the same state (thread-independent);
     * the plane below the updated ones too (a slab's copy of its neighbour's edge plane) */
    const int64_t e0 = c0 >= sz ? c0 - sz : 0;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(par))
    for (int64_t c = e0; c < c1; c++)
        if (changed[c] == 2) kind[c] = SQ_SNOW_AIR;
    return lifted;
}
