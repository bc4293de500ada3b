/* clouds_particles.c — the cloud particle system (S4 §2.1–2.2 steps 2 and 4, SPEC 8.3):
 *
 * Filling: particles are spawned in the cloudy cells with probability proportional to each
 * cell's extinction content beta_c V_c (so their density follows the condensate), uniformly in
 * the cell and kept with the probability of the sub-grid mask m(p) (clouds_field.c). Then the
 * expected particle density is n(p) = N beta_c m(p) / (X E[m]) with X = sum_c beta_c V_c, and a
 * particle of radius r whose sprite's optical depth integrates to tau 0.3 pi r² carries the
 * field's extinction cross-section when
 *     tau = beta(p) m(p)/E[m] / (n(p) 0.3 pi r²) = beta(p) X / (N beta_c 0.3 pi r²),
 * i.e. tau = coef beta(p) with coef = X / (N beta_c 0.3 pi r² (1 - FADE)) fixed at birth (the
 * last factor compensates the mean of the life fade below) and beta(p) the
 * field interpolated at the particle's current position and time: a particle fades where its
 * cloud thins. The vertical exaggeration e stretches volumes by e and divides extinction by e,
 * so X, and the vertical optical depth of the clouds, are unchanged.
 *
 * Life: each particle lives lifetime_s (+-25 %), drifts with the interpolated wind (w scaled by
 * e), fades in and out over the first and last 15 % of its life, and at the end of its life is
 * re-initialised (S4 step 4) — at a new position drawn from the CURRENT field, not at its old
 * initial position, which the time-varying WRF field may have left clear. Particles in clear air
 * are re-initialised at once. Everything random comes from Philox keyed by (seed, particle,
 * spawn count): a run is reproducible and independent of the thread count.
 *
 * Attributes for the structured particles: position (continuous), density beta(p)/beta_max
 * (continuous), life stage of four (ordinal), phase liquid/mixed/ice from the ice share of the
 * condensate (symbolic, classes d = the particle's cloud). */
#include <math.h>
#include <string.h>

#include "clouds_internal.h"
#include "squall/rng.h"

#define SPAWN_TRIES 8
#define RADIUS_PER_SPACING 1.3f
#define FADE 0.15f
#define STREAM_SPAWN 0x737061776eULL /* "spawn" */
#define SPLAT_AREA 0.3f              /* integral of the splat falloff over the unit disc / pi */

sq_result sq__particles_init(sq_context *ctx, sq__particles *p, int count, size_t cells)
{
    memset(p, 0, sizeof *p);
    const size_t n = (size_t)(count > 0 ? count : 1);
    p->n = count;
    p->pos = sq_alloc_zero(ctx, 3 * n * sizeof(float));
    p->radius = sq_alloc_zero(ctx, n * sizeof(float));
    p->tau = sq_alloc_zero(ctx, n * sizeof(float));
    p->coef = sq_alloc_zero(ctx, n * sizeof(float));
    p->age = sq_alloc_zero(ctx, n * sizeof(float));
    p->life = sq_alloc_zero(ctx, n * sizeof(float));
    p->density = sq_alloc_zero(ctx, n * sizeof(float));
    p->g = sq_alloc_zero(ctx, n * sizeof(float));
    p->stage = sq_alloc_zero(ctx, n);
    p->phase = sq_alloc_zero(ctx, n);
    p->cloud = sq_alloc_zero(ctx, n * sizeof(int32_t));
    p->gen = sq_alloc_zero(ctx, n * sizeof(uint32_t));
    p->cdf = sq_alloc(ctx, (cells + 1) * sizeof(double));
    p->cdf_cell = sq_alloc(ctx, (cells + 1) * sizeof(int32_t));
    if (!p->pos || !p->radius || !p->tau || !p->coef || !p->age || !p->life || !p->density ||
        !p->g || !p->stage || !p->phase || !p->cloud || !p->gen || !p->cdf || !p->cdf_cell) {
        sq__particles_free(ctx, p);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for %d cloud particles",
                        count);
    }
    return SQ_OK;
}

void sq__particles_free(sq_context *ctx, sq__particles *p)
{
    sq_free(ctx, p->pos);
    sq_free(ctx, p->radius);
    sq_free(ctx, p->tau);
    sq_free(ctx, p->coef);
    sq_free(ctx, p->age);
    sq_free(ctx, p->life);
    sq_free(ctx, p->density);
    sq_free(ctx, p->g);
    sq_free(ctx, p->stage);
    sq_free(ctx, p->phase);
    sq_free(ctx, p->cloud);
    sq_free(ctx, p->gen);
    sq_free(ctx, p->cdf);
    sq_free(ctx, p->cdf_cell);
    memset(p, 0, sizeof *p);
}

static float cell_volume(const sq__cloud_field *f, size_t c, float *zlo, float *zhi)
{
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny;
    const int k = (int)(c / cols), j = (int)((c % cols) / (size_t)g->nx),
              i = (int)(c % (size_t)g->nx);
    sq__cloud_cell_bounds(f, i, j, k, zlo, zhi);
    return g->dx * g->dy * (*zhi - *zlo);
}

void sq__particles_prepare(sq__particles *p, const sq__cloud_field *f,
                           const sq__particle_params *pp)
{
    double acc = 0.0, vol = 0.0;
    int m = 0;
    p->cdf[0] = 0.0;
    for (size_t c = 0; c < f->cells; c++) {
        if (f->label[c] < 0 || !(f->beta[c] > 0.0f)) continue;
        float zlo, zhi;
        const float v = cell_volume(f, c, &zlo, &zhi);
        acc += (double)f->beta[c] * (double)v;
        vol += (double)v * (double)f->exaggeration * (double)(f->sub.on ? f->frac[c] : 1.0f);
        p->cdf_cell[m] = (int32_t)c;
        p->cdf[++m] = acc;
    }
    p->cdf_n = m;
    p->cross_section = acc;
    p->cloud_volume = vol;
    if (pp->radius_m > 0.0f) {
        p->radius_auto = pp->radius_m;
    } else if (vol > 0.0 && pp->count > 0) {
        p->radius_auto = RADIUS_PER_SPACING * (float)cbrt(vol / (double)pp->count);
    } else if (!(p->radius_auto > 0.0f)) {
        p->radius_auto = 0.25f * fminf(f->grid.dx, f->grid.dy);
    }
}

/* Index of the cloudy cell for a uniform u in [0, 1) (binary search in the CDF). */
static int pick_cell(const sq__particles *p, double u)
{
    const double target = u * p->cdf[p->cdf_n];
    int lo = 0, hi = p->cdf_n; /* cdf[lo] <= target < cdf[hi] */
    while (hi - lo > 1) {
        const int mid = (lo + hi) / 2;
        if (p->cdf[mid] <= target) lo = mid;
        else hi = mid;
    }
    return lo;
}

static float life_fade(float age, float life)
{
    const float a = age / life;
    const float in = a < FADE ? a / FADE : 1.0f, out = a > 1.0f - FADE ? (1.0f - a) / FADE : 1.0f;
    const float t = fmaxf(fminf(fminf(in, out), 1.0f), 0.0f);
    return t * t * (3.0f - 2.0f * t);
}

/* (Re)initialises particle i from the current field; age0 is its starting age. */
static void spawn(sq__particles *p, const sq__cloud_field *f, const sq__particle_params *pp,
                  int i, float age0_fraction)
{
    const uint32_t gen = p->gen[i]++;
    const uint64_t stream = STREAM_SPAWN ^ ((uint64_t)i << 20);
    float u[4];
    if (p->cdf_n == 0) { /* no cloud anywhere: park the particle invisible */
        p->tau[i] = p->coef[i] = 0.0f;
        p->life[i] = pp->lifetime_s;
        p->age[i] = 0.0f;
        p->cloud[i] = -1;
        return;
    }
    sq_rng_uniform4(pp->seed, stream, (uint64_t)gen * 16u, u);
    const int slot = pick_cell(p, (double)u[0]);
    const size_t c = (size_t)p->cdf_cell[slot];
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny;
    const int ci = (int)(c % (size_t)g->nx), cj = (int)((c % cols) / (size_t)g->nx);
    float zlo, zhi;
    cell_volume(f, c, &zlo, &zhi);
    const float cx = g->x0 + (float)ci * g->dx, cy = g->y0 + (float)cj * g->dy;
    float x = cx, y = cy, z = 0.5f * (zlo + zhi);
    for (int t = 0; t < SPAWN_TRIES; t++) {
        float v[4];
        sq_rng_uniform4(pp->seed, stream, (uint64_t)gen * 16u + 1u + (uint64_t)t, v);
        x = cx + (v[0] - 0.5f) * g->dx;
        y = cy + (v[1] - 0.5f) * g->dy;
        z = zlo + v[2] * (zhi - zlo);
        if (v[3] < sq__cloud_subgrid_mask(f, x, y, z, f->frac[c])) break;
    }
    p->pos[3 * i + 0] = x;
    p->pos[3 * i + 1] = y;
    p->pos[3 * i + 2] = z * f->exaggeration;
    const float r = p->radius_auto;
    p->radius[i] = r;
    /* the life fade removes FADE of the cross-section on average (smoothstep ramps over FADE at
     * both ends, ages uniform): compensated so the mean keeps X */
    p->coef[i] = (float)(p->cross_section /
                         ((double)pp->count * (double)f->beta[c] *
                          (double)(SPLAT_AREA * 3.14159265f * r * r) * (1.0 - (double)FADE)));
    p->life[i] = pp->lifetime_s * (0.75f + 0.5f * u[1]);
    p->age[i] = age0_fraction * p->life[i];
    p->cloud[i] = f->label[c];
}

/* tau and the attributes from the field at the particle; false in clear air. */
static bool update_from_field(sq__particles *p, const sq__cloud_field *f, int i,
                              sq__cloud_sample *s)
{
    sq__cloud_field_sample(f, p->pos[3 * i], p->pos[3 * i + 1], p->pos[3 * i + 2], s);
    const float fade = life_fade(p->age[i], p->life[i]);
    p->tau[i] = p->coef[i] * s->beta * fade;
    p->density[i] = f->beta_max > 0.0f ? s->beta / f->beta_max : 0.0f;
    p->g[i] = s->g > 0.0f ? s->g : (float)f->optics.g[SQ_HYDRO_CLOUD];
    int st = (int)(SQ__STAGES * p->age[i] / p->life[i]);
    p->stage[i] = (uint8_t)(st < 0 ? 0 : (st >= SQ__STAGES ? SQ__STAGES - 1 : st));
    p->phase[i] = s->ice_fraction < 0.1f ? SQ__PHASE_LIQUID
                  : s->ice_fraction > 0.9f ? SQ__PHASE_ICE
                                           : SQ__PHASE_MIXED;
    const int64_t c = sq__cloud_field_cell_at(f, p->pos[3 * i], p->pos[3 * i + 1], p->pos[3 * i + 2]);
    if (c >= 0 && f->label[c] >= 0) p->cloud[i] = f->label[c];
    return s->beta > 0.0f;
}

/* Particles are independent (each reads the field and writes only itself; its random numbers
 * are keyed by its index and spawn count), so both loops run in parallel with results that do
 * not depend on the thread count. */
void sq__particles_seed(sq__particles *p, const sq__cloud_field *f, const sq__particle_params *pp)
{
    SQ_OMP(omp parallel for schedule(static) num_threads(pp->threads > 0 ? pp->threads : 1))
    for (int i = 0; i < p->n; i++) {
        float u = sq_rng_uniform(pp->seed, STREAM_SPAWN + 1u, (uint64_t)i);
        spawn(p, f, pp, i, u);
        sq__cloud_sample s;
        update_from_field(p, f, i, &s);
    }
}

void sq__particles_advance(sq__particles *p, const sq__cloud_field *f,
                           const sq__particle_params *pp, double dt_s)
{
    const float dt = (float)dt_s;
    uint64_t respawns = 0;
    SQ_OMP(omp parallel for schedule(static) num_threads(pp->threads > 0 ? pp->threads : 1) reduction(+ : respawns))
    for (int i = 0; i < p->n; i++) {
        sq__cloud_sample s;
        sq__cloud_field_sample(f, p->pos[3 * i], p->pos[3 * i + 1], p->pos[3 * i + 2], &s);
        for (int a = 0; a < 3; a++) p->pos[3 * i + a] += s.wind[a] * dt;
        p->age[i] += dt;
        bool alive = p->age[i] < p->life[i] && p->coef[i] > 0.0f;
        if (alive) alive = update_from_field(p, f, i, &s);
        if (!alive) {
            respawns++;
            spawn(p, f, pp, i, 0.0f);
            update_from_field(p, f, i, &s);
        }
    }
    p->respawns += respawns;
}
