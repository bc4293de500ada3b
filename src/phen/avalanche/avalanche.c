/* avalanche.c — the snow avalanche phenomenon (SPEC §7, S2 ch. 3): lifecycle, the step recipe,
 * diagnostics (front, run-out, α angle, moving fraction, deposit depth map), drawables (lit
 * snow spheres, the deposit surface, an optional powder cloud), metrics and export fields.
 * The flow itself is the SPH solver (include/squall/sph.h): summation density with the self
 * term, linear EOS, Cross/Newtonian/power-law/Bingham stress through the velocity-gradient
 * tensor, XSPH, kick-drift-kick leap-frog with CFL/viscous/force limits, and the terrain as a
 * heightfield collider with kinetic Coulomb friction (SPEC §7.2–7.8). SI units throughout; the
 * only conversion is the deposit's volume per cell to a depth (here). */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avalanche_internal.h"
#include "world/world_struct.h"

#define MOD "avalanche"

/* ---- lifecycle ----------------------------------------------------------------------------- */

void sq_avalanche_destroy(sq_avalanche *a)
{
    if (!a) return;
    sq_context *ctx = a->ctx;
    sq_sph_destroy(a->sph);
    sq_free(ctx, a->scratch);
    sq_free(ctx, a->dep_acc);
    sq_free(ctx, a->dep_depth);
    sq_free(ctx, a->dep_smooth);
    sq_free(ctx, a->dep_terrain);
    sq_free(ctx, a->dep_height);
    sq_free(ctx, a->dep_cover);
    sq_free(ctx, a->pos);
    sq_free(ctx, a->spray);
    sq_free(ctx, a->pw_density);
    sq_free(ctx, a->pw_tmp);
    sq_free(ctx, a->pw_ground);
    sq_free(ctx, a->pw_vel);
    sq_free(ctx, a->pw_work);
    sq_free(ctx, a->pw_show);
    sq__aval_hazard_free(a);
    sq_free(ctx, a);
}

/* The world's obstacles as box colliders: the axis-aligned bounds of each (rotated) footprint,
 * from below the lowest terrain under it to its top (ridge included). */
static sq_result add_obstacles(sq_avalanche *a)
{
    const sq_world *w = a->world;
    for (int i = 0; i < w->obstacle_count; i++) {
        const sq_obstacle *o = &w->obstacles[i];
        const float yaw = o->yaw_deg * (float)(SQ_PI / 180.0);
        const float c = fabsf(cosf(yaw)), s = fabsf(sinf(yaw));
        const float ex = 0.5f * (c * o->size_m.x + s * o->size_m.y);
        const float ey = 0.5f * (s * o->size_m.x + c * o->size_m.y);
        float zlo = o->center_m.z;
        for (int k = 0; k < 4; k++) {
            float h = sq_world_height_at(w, o->center_m.x + ((k & 1) ? ex : -ex),
                                         o->center_m.y + ((k & 2) ? ey : -ey));
            if (h < zlo) zlo = h;
        }
        const float top = o->center_m.z + o->size_m.z +
                          (o->kind == SQ_OBSTACLE_HOUSE ? o->roof_m : 0.0f);
        sq_sph_box_desc b;
        memset(&b, 0, sizeof b);
        b.min_m[0] = (double)(o->center_m.x - ex);
        b.max_m[0] = (double)(o->center_m.x + ex);
        b.min_m[1] = (double)(o->center_m.y - ey);
        b.max_m[1] = (double)(o->center_m.y + ey);
        b.min_m[2] = (double)zlo - 1.0;
        b.max_m[2] = (double)top;
        b.contact.friction = a->plan.d.friction;
        b.contact.restitution = a->plan.d.restitution;
        sq_result r = sq_sph_add_box_obstacle(a->sph, &b);
        if (r != SQ_OK) return r;
    }
    return SQ_OK;
}

static sq_result alloc_buffers(sq_avalanche *a)
{
    sq_context *ctx = a->ctx;
    const sq__aval_plan *pl = &a->plan;
    const size_t cells = (size_t)pl->dep_nx * (size_t)pl->dep_ny;
    a->scratch = (float *)sq_alloc(ctx, pl->count * sizeof(float));
    a->pos = (float *)sq_alloc_zero(ctx, 3 * pl->count * sizeof(float));
    a->spray = (float *)sq_alloc_zero(ctx, 3 * pl->count * sizeof(float));
    a->dep_acc = (double *)sq_alloc_zero(ctx, cells * sizeof(double));
    a->dep_depth = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->dep_smooth = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->dep_terrain = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->dep_height = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    a->dep_cover = (float *)sq_alloc_zero(ctx, cells * sizeof(float));
    if (!a->scratch || !a->pos || !a->spray || !a->dep_acc || !a->dep_depth || !a->dep_smooth ||
        !a->dep_terrain || !a->dep_height || !a->dep_cover)
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "out of memory for %zu particles",
                        pl->count);
    if (pl->pw_n[0] > 0) {
        const size_t nv = (size_t)pl->pw_n[0] * (size_t)pl->pw_n[1] * (size_t)pl->pw_n[2];
        a->pw_density = (float *)sq_alloc_zero(ctx, nv * sizeof(float));
        a->pw_tmp = (float *)sq_alloc_zero(ctx, nv * sizeof(float));
        const size_t cols = (size_t)pl->pw_n[0] * pl->pw_n[1];
        a->pw_ground = (int *)sq_alloc_zero(ctx, cols * sizeof(int));
        a->pw_vel = (float *)sq_alloc_zero(ctx, 4 * cols * sizeof(float));
        a->pw_work = (float *)sq_alloc_zero(ctx, 2 * cols * sizeof(float));
        a->pw_show = (float *)sq_alloc_zero(ctx, nv * sizeof(float));
        if (!a->pw_density || !a->pw_tmp || !a->pw_ground || !a->pw_vel || !a->pw_work ||
            !a->pw_show)
            return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "out of memory for the powder grid");
        memcpy(a->pw_origin, pl->pw_origin, sizeof a->pw_origin);
        sq__aval_powder_ground(a);
        sq_noise_init(&a->pw_noise, 0x706f776465ull); /* fixed: the same billows every run */
    }
    for (int j = 0; j < pl->dep_ny; j++)
        for (int i = 0; i < pl->dep_nx; i++)
            a->dep_terrain[(size_t)j * pl->dep_nx + i] =
                sq_world_height_at(a->world, (float)(pl->dep_origin[0] + (i + 0.5) * pl->dep_cell),
                                   (float)(pl->dep_origin[1] + (j + 0.5) * pl->dep_cell));
    return SQ_OK;
}

sq_result sq_avalanche_create(sq_context *ctx, const sq_avalanche_desc *desc, const sq_world *world,
                              sq_avalanche **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "out is NULL");
    *out = NULL;
    if (!world) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "a world is required");
    sq_result r = sq_avalanche_validate(ctx, desc, world); /* refuses before allocating */
    if (r != SQ_OK) return r;
    sq_avalanche *a = (sq_avalanche *)sq_alloc_zero(ctx, sizeof *a);
    if (!a) return SQ_ERR_OUT_OF_MEMORY;
    a->ctx = ctx;
    a->world = world;
    r = sq__avalanche_plan(ctx, desc, world, &a->plan);
    /* the exact release (O(columns), interruptible), then its positions into the drawable
     * buffer, which is free until the first evaluation */
    size_t n = 0;
    if (r == SQ_OK) r = sq__aval_release_place(ctx, &a->plan, world, NULL, 0, &n, NULL, NULL);
    if (r == SQ_OK && n == 0)
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                     "sq_avalanche_desc.release: the release produces no particles at spacing %g "
                     "m; thicken it or lower particles.spacing_m", a->plan.spacing);
    if (r == SQ_OK) {
        a->plan.count = n;
        a->plan.sph.max_particles = n;
        r = alloc_buffers(a);
    }
    if (r == SQ_OK)
        r = sq__aval_release_place(ctx, &a->plan, world, a->pos, n, &n, &a->plan.volume_m3,
                                   &a->plan.release_top_z);
    if (r == SQ_OK) r = sq_sph_create(ctx, &a->plan.sph, &a->sph);
    if (r == SQ_OK) {
        sq_sph_terrain_desc t;
        memset(&t, 0, sizeof t);
        t.origin_m[0] = world->origin.x;
        t.origin_m[1] = world->origin.y;
        t.spacing_m[0] = world->dx;
        t.spacing_m[1] = world->dy;
        t.nx = world->nx;
        t.ny = world->ny;
        t.heights_m = world->heights;
        t.contact.friction = a->plan.d.friction;
        t.contact.restitution = a->plan.d.restitution;
        t.contact.column_friction = a->plan.d.column_friction;
        t.contact.turbulent_friction_mps2 = a->plan.d.turbulent_friction_mps2;
        r = sq_sph_set_terrain(a->sph, &t);
    }
    if (r == SQ_OK) r = add_obstacles(a);
    if (r == SQ_OK) r = sq__avalanche_add_meshes(a);
    if (r == SQ_OK) r = sq_context_poll_interrupt(ctx, MOD, "the particle release");
    if (r == SQ_OK) r = sq_sph_add_particles(a->sph, a->plan.count, a->pos, NULL);
    if (r == SQ_OK) r = sq__aval_hazard_alloc(a);
    if (r != SQ_OK) {
        sq_avalanche_destroy(a);
        return r;
    }
    const sq_sph_info info = sq_sph_get_info(a->sph);
    a->particle_mass = info.particle_mass_kg;
    sq__aval_hazard_track(a); /* the release: travel origins, the thalweg's first point */
    a->memory_bytes = sq_context_bytes_in_use(ctx);
    a->dirty = true;
    sq_log(ctx, SQ_LOG_INFO, MOD,
           "release of %zu particles (%.4g m3 of snow at %g kg/m3, spacing %g m, H = %g m, "
           "c_s = %.4g m/s) on a %dx%dx%d neighbour grid; fall line (%.3f, %.3f)",
           a->plan.count, a->plan.volume_m3, a->plan.d.density_kgm3, a->plan.spacing,
           a->plan.support, a->plan.sph.speed_of_sound_mps, info.cells[0], info.cells[1],
           info.cells[2], a->plan.fall_dir[0], a->plan.fall_dir[1]);
    *out = a;
    return SQ_OK;
}

/* ---- the step ------------------------------------------------------------------------------- */

sq_result sq_avalanche_step(sq_avalanche *a, double dt_s)
{
    if (!a) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "avalanche is NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(a->ctx, SQ_ERR_INVALID_ARG, MOD, "step dt = %g s; must be > 0", dt_s);
    /* density, strain rate and rheology, pressure + stress + gravity, XSPH, leap-frog and the
     * terrain/obstacle colliders with Coulomb friction (SPEC §7.8), sub-stepped at the stable
     * dt (CFL, viscous and force limits, §7.5) */
    sq_result r = sq_sph_step(a->sph, dt_s);
    a->time_s += dt_s;
    a->dirty = true;
    /* hazard maps and thalweg: sampled at a fixed interval of simulated time */
    if (r == SQ_OK && a->time_s - a->track_t >= SQ_AVAL_TRACK_S - 1e-9) sq__aval_hazard_track(a);
    return r;
}

double sq_avalanche_max_stable_dt(const sq_avalanche *a)
{
    return a ? sq_sph_max_stable_dt(a->sph) : 0.0;
}

sq_sph *sq__avalanche_sph(sq_avalanche *a) { return a ? a->sph : NULL; }

/* ---- diagnostics ---------------------------------------------------------------------------- */

/* The deposit: the display grid's depth (dep_depth, for the surface drawable) and the hazard
 * map's (hz_deposit, the exported map), whose covered cells give the metrics. */
static void evaluate_deposit(sq_avalanche *a, const sq_sph_view *v)
{
    const sq__aval_plan *pl = &a->plan;
    const size_t cells = (size_t)pl->dep_nx * (size_t)pl->dep_ny;
    memset(a->dep_acc, 0, cells * sizeof(double));
    sq__aval_deposit_accumulate(v->x, v->y, v->density, v->count, a->particle_mass,
                                pl->d.density_kgm3, pl->dep_origin[0], pl->dep_origin[1],
                                pl->dep_cell, pl->dep_nx, pl->dep_ny, a->dep_acc);
    const double inv_area = 1.0 / (pl->dep_cell * pl->dep_cell);
    for (size_t c = 0; c < cells; c++) a->dep_depth[c] = (float)(a->dep_acc[c] * inv_area);
    sq__aval_hazard_deposit(a);
    const size_t hc = (size_t)pl->hz_nx * (size_t)pl->hz_ny;
    const double area = pl->hz_cell * pl->hz_cell;
    double vol = 0.0, dmax = 0.0;
    size_t covered = 0;
    for (size_t c = 0; c < hc; c++) {
        const double depth = a->hz_deposit[c];
        if (depth > 0.0) {
            covered++;
            vol += depth * area;
            if (depth > dmax) dmax = depth;
        }
    }
    a->st.deposit_volume_m3 = vol;
    a->st.deposit_area_m2 = (double)covered * area;
    a->st.deposit_max_m = dmax;
    a->st.deposit_mean_m = covered ? vol / a->st.deposit_area_m2 : 0.0;
}

static void evaluate(sq_avalanche *a)
{
    if (!a->dirty) return;
    const sq__aval_plan *pl = &a->plan;
    const sq_sph_view v = sq_sph_particles(a->sph);
    const sq_sph_stats ss = sq_sph_get_stats(a->sph);
    const size_t n = v.count;
    const float dx = (float)pl->fall_dir[0], dy = (float)pl->fall_dir[1];
    const double vmove2 = pl->d.moving_speed_mps * pl->d.moving_speed_mps;
    size_t moving = 0, airborne = 0;
    double vmax2 = 0.0, vsum = 0.0, hmax = -DBL_MAX, below = 0.0;
    for (size_t i = 0; i < n; i++) {
        a->scratch[i] = v.x[i] * dx + v.y[i] * dy;
        const double ux = v.vx[i], uy = v.vy[i], uz = v.vz[i];
        const double v2 = ux * ux + uy * uy + uz * uz;
        if (v2 > vmove2) moving++;
        if (v2 > vmax2) vmax2 = v2;
        vsum += sqrt(v2);
        /* height above the terrain along its normal (the distance to the tangent plane): on a
         * 35° slope the vertical height of a slab's top is 1/cos 35° = 1.22 x its thickness */
        const double above =
            ((double)v.z[i] - (double)sq_world_height_at(a->world, v.x[i], v.y[i])) *
            (double)sq_world_normal_at(a->world, v.x[i], v.y[i]).z;
        if (above > hmax) hmax = above;
        if (above > pl->d.airborne_m) airborne++;
        if (-above > below) below = -above;
        a->pos[3 * i] = v.x[i];
        a->pos[3 * i + 1] = v.y[i];
        a->pos[3 * i + 2] = v.z[i];
    }
    sq_avalanche_state *st = &a->st;
    st->time_s = a->time_s;
    st->particles = n;
    st->released = pl->count;
    st->removed = ss.removed;
    st->release_volume_m3 = pl->volume_m3;
    st->mass_kg = (double)n * a->particle_mass;
    st->fall_dir[0] = pl->fall_dir[0];
    st->fall_dir[1] = pl->fall_dir[1];
    st->moving_fraction = n ? (double)moving / (double)n : 0.0;
    st->airborne_fraction = n ? (double)airborne / (double)n : 0.0;
    st->max_speed_mps = sqrt(vmax2);
    st->mean_speed_mps = n ? vsum / (double)n : 0.0;
    st->max_height_m = n ? hmax : 0.0;
    st->below_terrain_m = below;
    st->substeps = (int)(ss.steps - a->steps_at_eval);
    a->steps_at_eval = ss.steps;
    st->dt_s = ss.dt_s;
    if (n > 0) {
        /* the front: the q-quantile of the fall-line coordinate, and the particle that holds it */
        const size_t k = (size_t)floor(pl->d.front_percentile * (double)(n - 1) + 0.5);
        const float sf = sq__aval_select(a->scratch, n, k);
        size_t fi = 0;
        float best = FLT_MAX;
        for (size_t i = 0; i < n; i++) {
            const float e = fabsf(v.x[i] * dx + v.y[i] * dy - sf);
            if (e < best) {
                best = e;
                fi = i;
            }
        }
        st->front_m = sf;
        st->runout_m = (double)sf - pl->edge_s;
        if (a->have_prev_front && a->time_s > a->prev_front_t)
            st->front_speed_mps = (st->front_m - a->prev_front_m) / (a->time_s - a->prev_front_t);
        else
            st->front_speed_mps = 0.0;
        if (!a->have_prev_front || a->time_s > a->prev_front_t) {
            a->prev_front_m = st->front_m;
            a->prev_front_t = a->time_s;
            a->have_prev_front = true;
        }
        /* α: from the top of the release zone to the front, on the terrain */
        const double zf = sq_world_height_at(a->world, v.x[fi], v.y[fi]);
        const double L = hypot((double)v.x[fi] - pl->crown[0], (double)v.y[fi] - pl->crown[1]);
        st->drop_m = pl->crown[2] - zf;
        st->alpha_deg = atan2(st->drop_m, L) * (180.0 / SQ_PI);
    }
    evaluate_deposit(a, &v);
    st->released_volume_m3 = (double)pl->count * a->particle_mass / pl->d.density_kgm3;
    st->mass_balance = pl->count ? ((double)n + (double)ss.removed - (double)pl->count) /
                                       (double)pl->count
                                 : 0.0;
    sq__aval_hazard_summary(a, &v, st);
    a->version++;
    a->dirty = false;
}

sq_result sq_avalanche_get_state(sq_avalanche *a, sq_avalanche_state *out)
{
    if (!a || !out) return sq__fail(a ? a->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "NULL argument");
    evaluate(a);
    *out = a->st;
    return SQ_OK;
}

const float *sq_avalanche_deposit(sq_avalanche *a, int *nx, int *ny, double origin_m[2],
                                  double *cell_m)
{
    if (!a) return NULL;
    evaluate(a);
    if (nx) *nx = a->plan.dep_nx;
    if (ny) *ny = a->plan.dep_ny;
    if (origin_m) {
        origin_m[0] = a->plan.dep_origin[0];
        origin_m[1] = a->plan.dep_origin[1];
    }
    if (cell_m) *cell_m = a->plan.dep_cell;
    return a->dep_depth;
}

const float *sq_avalanche_positions(sq_avalanche *a, size_t *count)
{
    if (!a) return NULL;
    evaluate(a);
    if (count) *count = a->st.particles;
    return a->pos;
}

/* ---- drawables, metrics, fields -------------------------------------------------------------- */

/* The powder cloud: fast particles shed suspended snow into a box of cells that follows the
 * flow, where it diffuses (turbulent diffusivity) between air cells and settles out
 * (exponential decay) — a visual model with a closed budget (docs/phen/avalanche.md). */
#define POWDER_DIFFUSIVITY 8.0  /* m²/s */
#define POWDER_DECAY_S 6.0      /* s */
/* The cloud's top rises by entraining air at E |u| (E: entrainment coefficient of a turbulent
 * gravity current at small Richardson number, Ellison & Turner 1959, E = (0.08 - 0.1 Ri) /
 * (1 + 5 Ri) -> 0.08). */
#define POWDER_ENTRAINMENT 0.08

void sq__aval_powder_ground(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    const double c = pl->pw_cell;
    for (int j = 0; j < pl->pw_n[1]; j++)
        for (int i = 0; i < pl->pw_n[0]; i++) {
            const double t = sq_world_height_at(a->world, (float)(a->pw_origin[0] + (i + 0.5) * c),
                                                (float)(a->pw_origin[1] + (j + 0.5) * c));
            /* cell k is ground when its centre o + (k + 1/2) c is below the terrain */
            double g = ceil((t - a->pw_origin[2]) / c - 0.5);
            g = g < 0.0 ? 0.0 : g > pl->pw_n[2] ? pl->pw_n[2] : g;
            a->pw_ground[(size_t)j * pl->pw_n[0] + i] = (int)g;
        }
}

/* Re-centres the box on the snow feeding the cloud (the mass centre of the particles faster
 * than powder.speed_mps; its lowest quarter below them) when that has moved more than an
 * eighth of the box: a shift by whole cells, so the powder inside keeps its place. */
static void powder_follow(sq_avalanche *a, const sq_sph_view *v)
{
    const sq__aval_plan *pl = &a->plan;
    const float v2min = (float)(pl->d.powder_speed_mps * pl->d.powder_speed_mps);
    double sum[3] = {0.0, 0.0, 0.0};
    size_t nf = 0;
    for (size_t p = 0; p < v->count; p++) {
        const float v2 = v->vx[p] * v->vx[p] + v->vy[p] * v->vy[p] + v->vz[p] * v->vz[p];
        if (!(v2 > v2min)) continue;
        sum[0] += (double)v->x[p];
        sum[1] += (double)v->y[p];
        sum[2] += (double)v->z[p];
        nf++;
    }
    if (nf == 0) return;
    const double c = pl->pw_cell;
    int shift[3];
    bool move = false;
    for (int k = 0; k < 3; k++) {
        const double want = sum[k] / (double)nf - (k == 2 ? 0.25 : 0.5) * pl->pw_n[k] * c;
        shift[k] = (int)lround((want - a->pw_origin[k]) / c);
        move = move || 8 * abs(shift[k]) > pl->pw_n[k];
    }
    if (!move) return;
    const double cell_volume = c * c * c;
    a->pw_left += cell_volume * sq__aval_powder_shift(a->pw_density, a->pw_tmp, pl->pw_n, shift);
    float *t = a->pw_density;
    a->pw_density = a->pw_tmp;
    a->pw_tmp = t;
    for (int k = 0; k < 3; k++) a->pw_origin[k] += shift[k] * c;
    sq__aval_powder_ground(a);
    /* powder now in a ground cell (the box moved up a slope) settles there */
    const size_t nxy = (size_t)pl->pw_n[0] * pl->pw_n[1];
    for (size_t col = 0; col < nxy; col++)
        for (int k = 0; k < a->pw_ground[col]; k++) {
            float *d = &a->pw_density[(size_t)k * nxy + col];
            a->pw_settled += cell_volume * (double)*d;
            *d = 0.0f;
        }
}

void sq__aval_update_powder(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    if (!a->pw_density) return;
    double dt = a->time_s - a->pw_time_s;
    if (!(dt > 0.0)) return;
    a->pw_time_s = a->time_s;
    const sq_sph_view v = sq_sph_particles(a->sph);
    powder_follow(a, &v);
    const double cell_volume = pl->pw_cell * pl->pw_cell * pl->pw_cell;
    const double share = pl->spacing * pl->spacing * pl->spacing / cell_volume;
    a->pw_entrained +=
        cell_volume * sq__aval_powder_source(v.x, v.y, v.z, v.vx, v.vy, v.vz, v.count,
                                             (float)pl->d.powder_speed_mps,
                                             (float)(pl->d.powder_shed * share * dt *
                                                     pl->d.density_kgm3),
                                             pl->pw_n, a->pw_origin, pl->pw_cell, a->pw_ground,
                                             a->pw_density);
    /* carried with the flow beneath it (and rising by entrainment): donor-cell steps of at most
     * half a cell per step summed over the axes */
    sq__aval_powder_velocity(v.x, v.y, v.vx, v.vy, v.vz, v.count, pl->pw_n, a->pw_origin,
                             pl->pw_cell, (float)POWDER_ENTRAINMENT, a->pw_vel, a->pw_work);
    const size_t cols = (size_t)pl->pw_n[0] * (size_t)pl->pw_n[1];
    float um[3] = {0.0f, 0.0f, 0.0f}; /* per axis: a cell's outflow is at most 2 sum um dt */
    for (size_t col = 0; col < cols; col++)
        for (int d = 0; d < 3; d++) {
            const float u = fabsf(a->pw_vel[4 * col + (size_t)d]);
            um[d] = u > um[d] ? u : um[d];
        }
    const float umax = um[0] + um[1] + um[2];
    if (umax > 0.0f) {
        int nadv = (int)ceil((double)umax * dt / 0.5);
        if (nadv > 256) nadv = 256; /* a frame of minutes: the cloud has long settled */
        const float h = (float)(dt / nadv);
        const float scale = (float)umax * h > 0.5f ? 0.5f / ((float)umax * h) : 1.0f;
        for (int s = 0; s < nadv; s++) {
            a->pw_left += cell_volume * sq__aval_powder_advect(a->pw_density, a->pw_tmp, pl->pw_n,
                                                               a->pw_ground, a->pw_vel,
                                                               h * scale);
            float *t = a->pw_density;
            a->pw_density = a->pw_tmp;
            a->pw_tmp = t;
        }
    }
    const double kmax = 1.0 / 6.0;
    const double ktot = POWDER_DIFFUSIVITY * dt / (pl->pw_cell * pl->pw_cell);
    int nsub = (int)ceil(ktot / kmax);
    if (nsub < 1) nsub = 1;
    if (nsub > 16) nsub = 16; /* beyond that the frame step only smooths further */
    const float k = (float)(ktot / nsub > kmax ? kmax : ktot / nsub);
    const float decay = (float)exp(-dt / POWDER_DECAY_S / nsub);
    for (int s = 0; s < nsub; s++) {
        a->pw_settled += cell_volume * sq__aval_powder_diffuse(a->pw_density, a->pw_tmp, pl->pw_n,
                                                               a->pw_ground, k, decay);
        float *t = a->pw_density;
        a->pw_density = a->pw_tmp;
        a->pw_tmp = t;
    }
    const size_t nv = (size_t)pl->pw_n[0] * (size_t)pl->pw_n[1] * (size_t)pl->pw_n[2];
    float mx = 0.0f;
    for (size_t c = 0; c < nv; c++) mx = a->pw_density[c] > mx ? a->pw_density[c] : mx;
    a->pw_max = mx;
}

/* The drawn cloud (display only; metrics and the budget use the simulated density): the grid's
 * diffusion gives a smooth body with a soft, wide margin, while a powder cloud's margin is a
 * cauliflower of billows — turbulent lobes with clefts between them — thinning into
 * translucent wisps. The margin (cells whose optical depth per cell, σ ρ c, is below
 * BILLOW_TAU) is carved by a billow field b in [0, 1] (gradient-noise fBm, lobes of
 * BILLOW_SCALE_M and two finer octaves, rising at BILLOW_RISE_MPS as the head's surface does):
 * with r = σ ρ c / BILLOW_TAU and the erosion e = BILLOW_EROSION (1 − b), the drawn density is
 * ρ max(0, (r − e) / (1 − e)) / r, so a lobe (b ≈ 1) keeps the margin, a cleft (b ≈ 0) cuts it
 * away, and the thin outer margin survives only in the lobes. The opaque body (r ≥ 1) is kept. */
#define BILLOW_TAU 2.0f
#define BILLOW_SCALE_M 10.0f
#define BILLOW_RISE_MPS 1.5f
#define BILLOW_EROSION 0.85f
#define POWDER_SIGMA 16.0f /* m²/kg: the mass extinction of the drawn cloud (below) */

static void powder_billows(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    const int nx = pl->pw_n[0], ny = pl->pw_n[1], nz = pl->pw_n[2];
    const float c = (float)pl->pw_cell, tau_cell = POWDER_SIGMA * c;
    const float inv = 1.0f / BILLOW_SCALE_M;
    const float rise = (float)a->time_s * BILLOW_RISE_MPS * inv;
    size_t i = 0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int ii = 0; ii < nx; ii++, i++) {
                const float d = a->pw_density[i];
                const float r = d * tau_cell / BILLOW_TAU;
                if (!(r > 1e-6f) || r >= 1.0f) {
                    a->pw_show[i] = d > 0.0f ? d : 0.0f;
                    continue;
                }
                const float x = (float)(a->pw_origin[0] + (ii + 0.5) * (double)c) * inv;
                const float y = (float)(a->pw_origin[1] + (j + 0.5) * (double)c) * inv;
                const float z = (float)(a->pw_origin[2] + (k + 0.5) * (double)c) * inv - rise;
                float b = 0.5f + 1.2f * sq_noise_fbm3(&a->pw_noise, x, y, z, 3, 2.0f, 0.5f);
                b = b < 0.0f ? 0.0f : b > 1.0f ? 1.0f : b;
                const float e = BILLOW_EROSION * (1.0f - b);
                const float m = (r - e) / (1.0f - e);
                a->pw_show[i] = m > 0.0f ? d * m / r : 0.0f;
            }
}

double sq__aval_powder_suspended(const sq_avalanche *a)
{
    if (!a->pw_density) return 0.0;
    const sq__aval_plan *pl = &a->plan;
    const size_t nv = (size_t)pl->pw_n[0] * (size_t)pl->pw_n[1] * (size_t)pl->pw_n[2];
    double s = 0.0;
    for (size_t c = 0; c < nv; c++) s += (double)a->pw_density[c];
    return s * pl->pw_cell * pl->pw_cell * pl->pw_cell;
}

/* The snow surface (docs/phen/avalanche.md, Drawables): the flow depth on the display grid —
 * the particles' volume per map area, dep_depth — smoothed twice with the 3x3 binomial filter
 * (a splat of ~3 cells) and laid on the terrain; coverage full from half a spacing of snow.
 * Particles more than 1.5 spacings above that surface are spray, drawn as spheres. With
 * render.spheres: every particle a sphere, the surface only over the snow at rest. */
static void snow_surface(sq_avalanche *a, bool resting_only)
{
    const sq__aval_plan *pl = &a->plan;
    const int nx = pl->dep_nx, ny = pl->dep_ny;
    const size_t cells = (size_t)nx * (size_t)ny;
    const float full = (float)(0.5 * pl->spacing); /* full coverage from half a layer */
    if (resting_only) {
        sq__aval_smooth3(a->dep_depth, a->dep_smooth, nx, ny);
        /* dep_acc is free after evaluate(); dep_height holds the smoothed resting depth until it
         * is overwritten below */
        const sq_sph_view v = sq_sph_particles(a->sph);
        memset(a->dep_acc, 0, cells * sizeof(double));
        sq__aval_deposit_accumulate_resting(v.x, v.y, v.vx, v.vy, v.vz, v.density, v.count,
                                            pl->d.moving_speed_mps, a->particle_mass,
                                            pl->d.density_kgm3, pl->dep_origin[0],
                                            pl->dep_origin[1], pl->dep_cell, nx, ny, a->dep_acc);
        const double inv_area = 1.0 / (pl->dep_cell * pl->dep_cell);
        for (size_t c = 0; c < cells; c++) a->dep_cover[c] = (float)(a->dep_acc[c] * inv_area);
        sq__aval_smooth3(a->dep_cover, a->dep_height, nx, ny);
    } else {
        sq__aval_smooth3(a->dep_depth, a->dep_cover, nx, ny);
        sq__aval_smooth3(a->dep_cover, a->dep_smooth, nx, ny);
        memcpy(a->dep_height, a->dep_smooth, cells * sizeof(float));
    }
    for (size_t c = 0; c < cells; c++) {
        float f = a->dep_height[c] / full;
        a->dep_cover[c] = f > 1.0f ? 1.0f : f < 0.0f ? 0.0f : f;
        a->dep_height[c] = a->dep_terrain[c] + a->dep_smooth[c];
    }
}

/* The spray: particles more than 1.5 spacings above the snow surface (dep_height) of their
 * cell; returns their count, positions in a->spray. */
static size_t collect_spray(sq_avalanche *a)
{
    const sq__aval_plan *pl = &a->plan;
    const float margin = (float)(1.5 * pl->spacing), inv = (float)(1.0 / pl->dep_cell);
    const float ox = (float)pl->dep_origin[0], oy = (float)pl->dep_origin[1];
    size_t k = 0;
    for (size_t i = 0; i < a->st.particles; i++) {
        const float *p = &a->pos[3 * i];
        int ci = (int)floorf((p[0] - ox) * inv), cj = (int)floorf((p[1] - oy) * inv);
        ci = ci < 0 ? 0 : ci >= pl->dep_nx ? pl->dep_nx - 1 : ci;
        cj = cj < 0 ? 0 : cj >= pl->dep_ny ? pl->dep_ny - 1 : cj;
        if (p[2] > a->dep_height[(size_t)cj * pl->dep_nx + ci] + margin) {
            memcpy(&a->spray[3 * k], p, 3 * sizeof(float));
            k++;
        }
    }
    return k;
}

int sq__avalanche_drawables(sq_avalanche *a, sq_drawable *out, int max)
{
    evaluate(a);
    const sq__aval_plan *pl = &a->plan;
    const bool surface = !pl->d.no_deposit_surface, spheres = pl->d.spheres || !surface;
    if (surface) snow_surface(a, spheres);
    int n = 0;
    if (n < max) {
        sq_drawable *d = &out[n++];
        memset(d, 0, sizeof *d);
        d->kind = SQ_DRAWABLE_PARTICLES;
        d->name = "avalanche-snow";
        sq_particles_view *p = &d->u.particles;
        /* with the powder cloud on, the airborne snow is drawn as the cloud it feeds (spray
         * spheres in and under a translucent cloud read as dark grains in its shadow) */
        p->count = spheres ? (int)a->st.particles : a->pw_density ? 0 : (int)collect_spray(a);
        p->position = spheres ? a->pos : a->spray;
        p->radius_default_m = (float)(pl->d.radius_factor * pl->spacing);
        p->tau_default = 1.0f;
        p->sigma_rel[0] = p->sigma_rel[1] = p->sigma_rel[2] = 1.0f;
        p->albedo[0] = p->albedo[1] = p->albedo[2] = (float)pl->d.albedo;
        p->g = 0.0f;
        p->sprite = SQ_SPRITE_SPHERE;
        p->softness_m = 0.0f;
        p->version = a->version;
    }
    if (surface && n < max) {
        const int nx = pl->dep_nx, ny = pl->dep_ny;
        sq_drawable *d = &out[n++];
        memset(d, 0, sizeof *d);
        d->kind = SQ_DRAWABLE_SURFACE;
        d->name = "avalanche-deposit";
        sq_surface_view *s = &d->u.surface;
        s->nx = nx;
        s->ny = ny;
        s->origin_m = sq_v3((float)(pl->dep_origin[0] + 0.5 * pl->dep_cell),
                            (float)(pl->dep_origin[1] + 0.5 * pl->dep_cell), 0.0f);
        s->dx_m = s->dy_m = (float)pl->dep_cell;
        s->height_m = a->dep_height;
        s->coverage = a->dep_cover;
        s->material = SQ_MATERIAL_SNOW_DEBRIS; /* churned snow: lumps, shadowed gaps */
        s->albedo = sq_v3((float)pl->d.albedo, (float)pl->d.albedo, (float)pl->d.albedo);
        s->version = a->version;
    }
    if (a->pw_density && n < max) {
        sq__aval_update_powder(a);
        sq_drawable *d = &out[n++];
        memset(d, 0, sizeof *d);
        d->kind = SQ_DRAWABLE_VOLUME;
        d->name = "avalanche-powder";
        sq_volume_view *vv = &d->u.volume;
        powder_billows(a);
        vv->density = a->pw_show;
        vv->nx = pl->pw_n[0];
        vv->ny = pl->pw_n[1];
        vv->nz = pl->pw_n[2];
        vv->origin_m = sq_v3((float)a->pw_origin[0], (float)a->pw_origin[1], (float)a->pw_origin[2]);
        vv->size_m = sq_v3((float)(pl->pw_n[0] * pl->pw_cell), (float)(pl->pw_n[1] * pl->pw_cell),
                           (float)(pl->pw_n[2] * pl->pw_cell));
        /* ice grains of ~100 µm radius: geometric-optics extinction Q ≈ 2, mass extinction
         * 3 Q / (4 ρ_ice r) ≈ 16 m²/kg, grey; nearly conservative scattering. A single grain
         * scatters forward (g ≈ 0.8), but a powder cloud is optically thick (τ ≫ 1 over a few
         * metres), where multiple scattering makes the light leaving it nearly isotropic; the
         * slicing renderer carries only forward scattering, so the cloud takes an effective
         * g = 0.3 — with 0.8 a thick cloud seen from the side is a grey shadow, not white. */
        for (int c = 0; c < 3; c++) {
            vv->sigma_ext[c] = POWDER_SIGMA;
            vv->albedo[c] = 0.99f;
            vv->g[c] = 0.3f;
        }
        /* irregular, rimed grains scatter some light back (a weak back lobe): the cloud in
         * front of a sun behind the camera is white, not a dark veil */
        vv->g2 = -0.3f;
        vv->w2 = 0.2f;
        vv->density_max = a->pw_max;
        vv->version = a->version;
    }
    return n;
}

int sq__avalanche_metrics(sq_avalanche *a, sq_metric *out, int max)
{
    evaluate(a);
    const sq_avalanche_state *s = &a->st;
    const sq_metric m[] = {
        {"front_m", s->front_m, "m"},
        {"front_speed_mps", s->front_speed_mps, "m/s"},
        {"runout_m", s->runout_m, "m"},
        {"alpha_deg", s->alpha_deg, "deg"},
        {"drop_m", s->drop_m, "m"},
        {"moving_fraction", s->moving_fraction, "1"},
        {"max_speed_mps", s->max_speed_mps, "m/s"},
        {"mean_speed_mps", s->mean_speed_mps, "m/s"},
        {"max_height_m", s->max_height_m, "m"},
        {"airborne_fraction", s->airborne_fraction, "1"},
        {"deposit_depth_mean_m", s->deposit_mean_m, "m"},
        {"deposit_depth_max_m", s->deposit_max_m, "m"},
        {"deposit_volume_m3", s->deposit_volume_m3, "m3"},
        {"released_volume_m3", s->released_volume_m3, "m3"},
        {"mass_balance", s->mass_balance, "1"},
        {"thalweg_runout_m", s->thalweg_runout_m, "m"},
        {"thalweg_alpha_deg", s->thalweg_alpha_deg, "deg"},
        {"beta_deg", s->beta_deg, "deg"},
        {"alpha_lb_deg", s->alpha_lb_deg, "deg"},
        {"particles", (double)s->particles, "1"},
        {"substeps", (double)s->substeps, "1"},
        {"dt_s", s->dt_s, "s"},
    };
    int n = 0;
    for (size_t i = 0; i < sizeof m / sizeof m[0] && n < max; i++) out[n++] = m[i];
    if (a->pw_density) {
        /* the powder budget: entrained = suspended + settled + left behind by the box */
        sq__aval_update_powder(a);
        const sq_metric pw[] = {
            {"powder_entrained_kg", a->pw_entrained, "kg"},
            {"powder_suspended_kg", sq__aval_powder_suspended(a), "kg"},
            {"powder_settled_kg", a->pw_settled, "kg"},
            {"powder_left_kg", a->pw_left, "kg"},
        };
        for (size_t i = 0; i < sizeof pw / sizeof pw[0] && n < max; i++) out[n++] = pw[i];
    }
    return n;
}

int sq__avalanche_fields(sq_avalanche *a, sq_named_field *out, int max)
{
    evaluate(a);
    return sq__aval_hazard_fields(a, out, max);
}
