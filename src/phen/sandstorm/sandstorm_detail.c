/* sandstorm_detail.c — flow-following detail of the rendered dust (display only; issue 12).
 *
 * The simulation resolves the haboob's head on 50 m cells; its lobes, clefts and billows are
 * smaller. Their look is synthesised the way advected textures are (Neyret 2003, "Advected
 * textures", SCA; in the spirit of wavelet turbulence, Kim et al. 2008, whose noise is also
 * carried by the simulated flow): every cell carries noise-texture coordinates X (in cells)
 * that the resolved wind advects, DX/Dt = 0 (semi-Lagrangian, RK2 trace, trilinear; linear
 * extrapolation outside the domain, so a uniform wind moves the pattern by exactly u t). A
 * coordinate field is stretched by the flow's shear over time, so there are two, re-seeded
 * (X = x) alternately every `detail.period_s`, half a period apart, and blended with the weights
 * w(age) = 1 - |1 - 2 age / period| (zero when a phase is re-seeded; w_0 + w_1 = 1),
 * normalised by sqrt(w_0^2 + w_1^2) to keep the noise's contrast. The noise at X / scale is a
 * vector n of three gradient-noise fBm fields (two octaves) and a modulation m (one octave); n
 * displaces the point at which the drawable's extinction is looked up, m modulates it,
 *     beta'(x) = beta(x + A n) max(0, 1 + 0.7 (A / A_max) m),
 *     A = A_max (1 - exp(-|omega| / omega_ref)),   A_max = detail.amplitude_m,
 * so dust edges get lobes and clefts where the resolved flow turns (|omega| the vorticity at the
 * cell centre, omega_ref = SQ_SAND_DETAIL_OMEGA_REF) and calm dust keeps its simulated shape.
 * Cells farther than the largest displacement from any dust are copied (the noise is the cost).
 * Metrics, fields and visibility use the simulated extinction, never this one. Deterministic:
 * fixed traversal order, no random numbers beyond the seeded noise table. */
#include <math.h>
#include <string.h>

#include "sandstorm_internal.h"
#include "squall/noise.h"

/* Vorticity at which the detail reaches 63 % of its amplitude (1/s): the haboob head's resolved
 * shear is ~0.1-0.3 1/s (20 m/s over 70-200 m; in the haboob preset the dusty cells average
 * 0.8 of the full amplitude), the air ahead of it ~0.005 1/s. */
#define SQ_SAND_DETAIL_OMEGA_REF 0.1
/* Largest relative modulation of the extinction (lobes and clefts) at full amplitude. */
#define SQ_SAND_DETAIL_CONTRAST 0.7f
/* Extinction (1/m) below which a cell counts as clear for the detail: over the 6 km of a view
 * it adds an optical depth of 0.006. */
#define SQ_SAND_DETAIL_BETA_MIN 1.0e-6f

static inline size_t cell(const sq__sand_detail *d, int i, int j, int k)
{
    return ((size_t)k * (size_t)d->ny + (size_t)j) * (size_t)d->nx + (size_t)i;
}

/* Trilinear value of the three components of a 3-vector field at point p (cells; centres at
 * integers), clamped to the centres, plus the part of p outside them when extrapolate is set (a
 * linear field continued beyond the domain). */
static void vec_at(const sq__sand_detail *d, const float *f, const float p[3], bool extrapolate,
                   float out[3])
{
    const int n[3] = {d->nx, d->ny, d->nz};
    int i0[3];
    float t[3], q[3];
    for (int a = 0; a < 3; a++) {
        q[a] = fminf(fmaxf(p[a], 0.0f), (float)(n[a] - 1));
        i0[a] = (int)q[a];
        if (i0[a] > n[a] - 2) i0[a] = n[a] > 1 ? n[a] - 2 : 0;
        t[a] = n[a] > 1 ? q[a] - (float)i0[a] : 0.0f;
    }
    const int di = d->nx > 1, dj = d->ny > 1, dk = d->nz > 1;
    const size_t sy = (size_t)3 * d->nx, sz = sy * d->ny;
    for (int c = 0; c < 3; c++) {
        const float *b = f + 3 * cell(d, i0[0], i0[1], i0[2]) + c;
        const float c00 = b[0] + t[0] * (b[3 * di] - b[0]);
        const float c10 = b[dj * sy] + t[0] * (b[dj * sy + 3 * di] - b[dj * sy]);
        const float c01 = b[dk * sz] + t[0] * (b[dk * sz + 3 * di] - b[dk * sz]);
        const float c11 =
            b[dj * sy + dk * sz] + t[0] * (b[dj * sy + dk * sz + 3 * di] - b[dj * sy + dk * sz]);
        const float c0 = c00 + t[1] * (c10 - c00), c1 = c01 + t[1] * (c11 - c01);
        float v = c0 + t[2] * (c1 - c0);
        if (extrapolate) v += p[c] - q[c];
        out[c] = v;
    }
}

sq_result sq__sand_detail_init(sq__sand_detail *d, sq_context *ctx, int nx, int ny, int nz,
                               double h, double amplitude_m, double scale_m, double period_s,
                               uint64_t seed)
{
    memset(d, 0, sizeof *d);
    if (!(amplitude_m > 0.0)) return SQ_OK; /* off */
    const size_t n = (size_t)nx * ny * nz;
    d->nx = nx;
    d->ny = ny;
    d->nz = nz;
    d->h = h;
    d->amplitude_m = amplitude_m;
    d->scale_cells = scale_m / h;
    d->period_s = period_s;
    d->coord[0] = sq_alloc(ctx, n * 3 * sizeof(float));
    d->coord[1] = sq_alloc(ctx, n * 3 * sizeof(float));
    d->tmp = sq_alloc(ctx, n * 3 * sizeof(float));
    d->vel = sq_alloc(ctx, n * 3 * sizeof(float));
    d->amp = sq_alloc_zero(ctx, n * sizeof(float)); /* no detail before the first step */
    d->near[0] = sq_alloc(ctx, n);
    d->near[1] = sq_alloc(ctx, n);
    if (!d->coord[0] || !d->coord[1] || !d->tmp || !d->vel || !d->amp || !d->near[0] ||
        !d->near[1]) {
        sq__sand_detail_free(d, ctx);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "sandstorm",
                        "no memory for the flow-following detail (%zu cells)", n);
    }
    sq_noise_init(&d->noise, seed ^ 0xDE7A11ull);
    sq__sand_detail_reseed(d, 0);
    sq__sand_detail_reseed(d, 1);
    d->age[0] = 0.0;
    d->age[1] = 0.5 * period_s;
    d->enabled = true;
    return SQ_OK;
}

void sq__sand_detail_free(sq__sand_detail *d, sq_context *ctx)
{
    sq_free(ctx, d->coord[0]);
    sq_free(ctx, d->coord[1]);
    sq_free(ctx, d->tmp);
    sq_free(ctx, d->vel);
    sq_free(ctx, d->amp);
    sq_free(ctx, d->near[0]);
    sq_free(ctx, d->near[1]);
    memset(d, 0, sizeof *d);
}

void sq__sand_detail_reseed(sq__sand_detail *d, int phase)
{
    float *X = d->coord[phase];
    for (int k = 0; k < d->nz; k++)
        for (int j = 0; j < d->ny; j++)
            for (int i = 0; i < d->nx; i++) {
                float *x = X + 3 * cell(d, i, j, k);
                x[0] = (float)i;
                x[1] = (float)j;
                x[2] = (float)k;
            }
    d->age[phase] = 0.0;
}

/* Cell-centre velocity (cells/s) from the face velocities, and the detail amplitude from the
 * vorticity (central differences, one-sided at the faces). */
static void centre_velocity(sq__sand_detail *d, const sq_grid *g)
{
    const sq_field_view u = sq_grid_velocity_view(g, 0), v = sq_grid_velocity_view(g, 1),
                        w = sq_grid_velocity_view(g, 2);
    const float inv_h = (float)(1.0 / d->h);
    for (int k = 0; k < d->nz; k++)
        for (int j = 0; j < d->ny; j++)
            for (int i = 0; i < d->nx; i++) {
                float *c = d->vel + 3 * cell(d, i, j, k);
                c[0] = 0.5f * (sq_view_get(&u, i, j, k) + sq_view_get(&u, i + 1, j, k)) * inv_h;
                c[1] = 0.5f * (sq_view_get(&v, i, j, k) + sq_view_get(&v, i, j + 1, k)) * inv_h;
                c[2] = 0.5f * (sq_view_get(&w, i, j, k) + sq_view_get(&w, i, j, k + 1)) * inv_h;
            }
    /* vorticity in 1/s: velocities are in cells/s, differences over cells */
    const int n[3] = {d->nx, d->ny, d->nz};
    for (int k = 0; k < d->nz; k++)
        for (int j = 0; j < d->ny; j++)
            for (int i = 0; i < d->nx; i++) {
                const int idx[3] = {i, j, k};
                float grad[3][3]; /* grad[a][c]: d vel_c / d x_a */
                for (int a = 0; a < 3; a++) {
                    int lo[3] = {i, j, k}, hi[3] = {i, j, k};
                    if (idx[a] > 0) lo[a]--;
                    if (idx[a] < n[a] - 1) hi[a]++;
                    const float span = (float)(hi[a] - lo[a]);
                    const float *pl = d->vel + 3 * cell(d, lo[0], lo[1], lo[2]);
                    const float *ph = d->vel + 3 * cell(d, hi[0], hi[1], hi[2]);
                    for (int c = 0; c < 3; c++) grad[a][c] = span > 0.0f ? (ph[c] - pl[c]) / span : 0.0f;
                }
                const float ox = grad[1][2] - grad[2][1], oy = grad[2][0] - grad[0][2],
                            oz = grad[0][1] - grad[1][0];
                const float om = sqrtf(ox * ox + oy * oy + oz * oz);
                d->amp[cell(d, i, j, k)] =
                    (float)(d->amplitude_m / d->h) * (1.0f - expf(-om / (float)SQ_SAND_DETAIL_OMEGA_REF));
            }
}

void sq__sand_detail_advect(sq__sand_detail *d, const sq_grid *g, double dt, int threads)
{
    (void)threads; /* unused without OpenMP */
    if (!d->enabled || !(dt > 0.0)) return;
    centre_velocity(d, g);
    const float fdt = (float)dt;
    for (int ph = 0; ph < 2; ph++) {
        const float *X = d->coord[ph];
        SQ_OMP(omp parallel for schedule(static) num_threads(threads))
        for (int k = 0; k < d->nz; k++)
            for (int j = 0; j < d->ny; j++)
                for (int i = 0; i < d->nx; i++) {
                    const float *u0 = d->vel + 3 * cell(d, i, j, k);
                    /* RK2 (midpoint) trace back to where this cell's air was dt ago */
                    const float mid[3] = {(float)i - 0.5f * fdt * u0[0], (float)j - 0.5f * fdt * u0[1],
                                          (float)k - 0.5f * fdt * u0[2]};
                    float um[3];
                    vec_at(d, d->vel, mid, false, um);
                    const float p[3] = {(float)i - fdt * um[0], (float)j - fdt * um[1],
                                        (float)k - fdt * um[2]};
                    float *out = d->tmp + 3 * cell(d, i, j, k);
                    vec_at(d, X, p, true, out);
                }
        float *swap = d->coord[ph];
        d->coord[ph] = d->tmp;
        d->tmp = swap;
    }
    for (int ph = 0; ph < 2; ph++) {
        d->age[ph] += dt;
        if (d->age[ph] >= d->period_s) sq__sand_detail_reseed(d, ph);
    }
}

double sq__sand_detail_weight(double age, double period)
{
    const double w = 1.0 - fabs(1.0 - 2.0 * age / period);
    return w < 0.0 ? 0.0 : w;
}

/* Noise at coordinates q, roughly in [-1, 1]: a displacement vector (two octaves of gradient
 * noise per component) and a modulation (one octave), decorrelated by offsets. It takes the
 * noise at SQ_SAND_DETAIL_POINTS points, which noise_points lists (for sq_noise3_many, which
 * evaluates many at once) and noise_combine sums. */
#define SQ_SAND_DETAIL_POINTS 7
static void noise_points(const float q[3], float *x, float *y, float *z)
{
    static const float off[4][3] = {{0.0f, 0.0f, 0.0f}, {31.7f, 17.3f, 7.1f}, {11.9f, 53.1f, 29.3f},
                                    {71.3f, 5.9f, 43.7f}};
    for (int c = 0; c < 3; c++) {
        const float px = q[0] + off[c][0], py = q[1] + off[c][1], pz = q[2] + off[c][2];
        x[2 * c] = px;
        y[2 * c] = py;
        z[2 * c] = pz;
        x[2 * c + 1] = 2.03f * px;
        y[2 * c + 1] = 2.03f * py;
        z[2 * c + 1] = 2.03f * pz;
    }
    x[6] = q[0] + off[3][0];
    y[6] = q[1] + off[3][1];
    z[6] = q[2] + off[3][2];
}

static void noise_combine(const float r[SQ_SAND_DETAIL_POINTS], float out[4])
{
    for (int c = 0; c < 3; c++) out[c] = 0.67f * r[2 * c] + 0.33f * r[2 * c + 1];
    out[3] = r[6];
}

/* One axis of the dilation: dst[c] = 1 if src is set within r cells of c along the axis
 * (running count over a window, clipped at the faces). */
static void dilate_axis(const sq__sand_detail *d, const uint8_t *src, uint8_t *dst, int axis,
                        int r, int threads)
{
    (void)threads; /* unused without OpenMP */
    const int n[3] = {d->nx, d->ny, d->nz};
    const size_t stride[3] = {1, (size_t)d->nx, (size_t)d->nx * d->ny};
    const int a1 = axis == 0 ? 1 : 0, a2 = axis == 2 ? 1 : 2; /* the other two axes */
    const int len = n[axis];
    SQ_OMP(omp parallel for schedule(static) num_threads(threads))
    for (int q = 0; q < n[a2]; q++)
        for (int p = 0; p < n[a1]; p++) {
            const size_t base = (size_t)p * stride[a1] + (size_t)q * stride[a2];
            const size_t st = stride[axis];
            int count = 0;
            for (int c = 0; c < r && c < len; c++) count += src[base + (size_t)c * st];
            for (int c = 0; c < len; c++) {
                if (c + r < len) count += src[base + (size_t)(c + r) * st];
                dst[base + (size_t)c * st] = count > 0;
                if (c - r >= 0) count -= src[base + (size_t)(c - r) * st];
            }
        }
}

/* One detailed cell: the input looked up at the displaced point and modulated; r0, r1 hold the
 * noise at the SQ_SAND_DETAIL_POINTS points of phase 0 and 1 (NULL for a phase of weight 0,
 * whose noise counts 0). */
static void detail_cell(const sq__sand_detail *d, const float *in, float *out, int i, int j,
                        int k, float a0, float a1, float amax, const float *r0, const float *r1)
{
    const size_t id = cell(d, i, j, k);
    const float A = d->amp[id];
    float n0[4] = {0, 0, 0, 0}, n1[4] = {0, 0, 0, 0};
    if (r0) noise_combine(r0, n0);
    if (r1) noise_combine(r1, n1);
    /* trilinear lookup of the input at the displaced point (cells), clamped */
    float p[3];
    const int nn[3] = {d->nx, d->ny, d->nz};
    const int id3[3] = {i, j, k};
    int i0[3];
    float t[3];
    for (int c = 0; c < 3; c++) {
        p[c] = (float)id3[c] + A * (a0 * n0[c] + a1 * n1[c]);
        p[c] = fminf(fmaxf(p[c], 0.0f), (float)(nn[c] - 1));
        i0[c] = (int)p[c];
        if (i0[c] > nn[c] - 2) i0[c] = nn[c] > 1 ? nn[c] - 2 : 0;
        t[c] = nn[c] > 1 ? p[c] - (float)i0[c] : 0.0f;
    }
    const size_t plane = (size_t)d->nx * d->ny;
    const size_t sx = d->nx > 1, sy = d->ny > 1 ? (size_t)d->nx : 0, sz = d->nz > 1 ? plane : 0;
    const float *b = in + cell(d, i0[0], i0[1], i0[2]);
    const float c00 = b[0] + t[0] * (b[sx] - b[0]);
    const float c10 = b[sy] + t[0] * (b[sy + sx] - b[sy]);
    const float c01 = b[sz] + t[0] * (b[sz + sx] - b[sz]);
    const float c11 = b[sy + sz] + t[0] * (b[sy + sz + sx] - b[sy + sz]);
    const float c0 = c00 + t[1] * (c10 - c00), c1 = c01 + t[1] * (c11 - c01);
    /* lobes and clefts: the looked-up extinction modulated by a fourth noise, with the same
     * shear weight as the displacement */
    const float m = 1.0f + SQ_SAND_DETAIL_CONTRAST * (A / amax) * (a0 * n0[3] + a1 * n1[3]);
    out[id] = (c0 + t[2] * (c1 - c0)) * fmaxf(m, 0.0f);
}

void sq__sand_detail_apply(const sq__sand_detail *d, const float *in, float *out, int threads)
{
    (void)threads; /* unused without OpenMP */
    /* Only cells that can reach dust (extinction above SQ_SAND_DETAIL_BETA_MIN within the
     * largest displacement, |A n| <= 1.5 A_max, plus the trilinear neighbour) are detailed; the
     * rest is copied. */
    const size_t ncell = (size_t)d->nx * d->ny * d->nz;
    const int reach = (int)ceil(1.5 * d->amplitude_m / d->h) + 1;
    for (size_t c = 0; c < ncell; c++) d->near[0][c] = in[c] > SQ_SAND_DETAIL_BETA_MIN;
    dilate_axis(d, d->near[0], d->near[1], 0, reach, threads);
    dilate_axis(d, d->near[1], d->near[0], 1, reach, threads);
    dilate_axis(d, d->near[0], d->near[1], 2, reach, threads);
    const uint8_t *near = d->near[1];
    const double w0 = sq__sand_detail_weight(d->age[0], d->period_s),
                 w1 = sq__sand_detail_weight(d->age[1], d->period_s);
    const double norm = sqrt(w0 * w0 + w1 * w1);
    const float a0 = (float)(w0 / norm), a1 = (float)(w1 / norm);
    const float inv_s = (float)(1.0 / d->scale_cells);
    const float amax = (float)(d->amplitude_m / d->h);
    /* noise points per detailed cell: those of each phase of non-zero weight (w0 + w1 = 1) */
    const int np = ((a0 > 0.0f) + (a1 > 0.0f)) * SQ_SAND_DETAIL_POINTS;
    SQ_OMP(omp parallel for schedule(static) num_threads(threads))
    for (int k = 0; k < d->nz; k++)
        for (int j = 0; j < d->ny; j++) {
            /* the row's detailed cells in batches: their noise points, the noise at all of
             * them at once (sq_noise3_many: vectorised), then each cell's lookup */
            enum { BATCH = 32, PTS = 2 * SQ_SAND_DETAIL_POINTS };
            int bi[BATCH];
            float px[BATCH * PTS], py[BATCH * PTS], pz[BATCH * PTS], nr[BATCH * PTS];
            int nb = 0;
            for (int i = 0; i <= d->nx; i++) {
                if (i < d->nx) {
                    const size_t id = cell(d, i, j, k);
                    if (d->amp[id] <= 0.0f || !near[id]) {
                        out[id] = in[id];
                    } else {
                        /* a phase of weight 0 is not evaluated (its noise counts 0) */
                        const float *X0 = d->coord[0] + 3 * id, *X1 = d->coord[1] + 3 * id;
                        size_t o = (size_t)nb * np;
                        if (a0 > 0.0f) {
                            const float q0[3] = {X0[0] * inv_s, X0[1] * inv_s, X0[2] * inv_s};
                            noise_points(q0, px + o, py + o, pz + o);
                            o += SQ_SAND_DETAIL_POINTS;
                        }
                        if (a1 > 0.0f) {
                            const float q1[3] = {X1[0] * inv_s + 101.0f, X1[1] * inv_s,
                                                 X1[2] * inv_s};
                            noise_points(q1, px + o, py + o, pz + o);
                        }
                        bi[nb++] = i;
                    }
                }
                if (nb == BATCH || (i == d->nx && nb > 0)) {
                    sq_noise3_many(&d->noise, (size_t)nb * np, px, py, pz, nr);
                    for (int b = 0; b < nb; b++) {
                        const float *r = nr + (size_t)b * np;
                        detail_cell(d, in, out, bi[b], j, k, a0, a1, amax, a0 > 0.0f ? r : NULL,
                                    a1 > 0.0f ? r + np - SQ_SAND_DETAIL_POINTS : NULL);
                    }
                    nb = 0;
                }
            }
        }
}
