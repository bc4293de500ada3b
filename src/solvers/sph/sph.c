/* sph.c — the SPH solver's lifecycle, the step recipe (SPEC §7.5 kick-drift-kick leap-frog
 * and §7.8's pipeline), the adaptive time step (CFL 0.4 ℓ/(c + |v|max), viscous 0.125 ℓ² ρ₀/μmax
 * after Morris 1997, force 0.25 sqrt(ℓ/|a|max), ℓ = H/2), particle insertion, colliders,
 * views and statistics. SI units throughout; the only conversions are the particle mass
 * (ρ₀ over the lattice kernel sum) and the EOS stiffness from the speed of sound (here). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "solvers/sph/sph_internal.h"

#define MOD "sph"

static void free_arrays(sq_sph *s)
{
    sq_context *ctx = s->ctx;
    float **fa[] = {&s->x,  &s->y,  &s->z,  &s->vx, &s->vy,  &s->vz, &s->hx, &s->hy,
                    &s->hz, &s->ax, &s->ay, &s->az, &s->sx,  &s->sy, &s->sz, &s->rho,
                    &s->p,  &s->vol, &s->pr2, &s->L, &s->G, &s->tau, &s->gam, &s->mu, &s->rec};
    for (size_t k = 0; k < sizeof fa / sizeof fa[0]; k++) {
        sq_free(ctx, *fa[k]);
        *fa[k] = NULL;
    }
    sq_free(ctx, s->id);
    sq_free(ctx, s->cellid);
    sq_free(ctx, s->perm);
    for (int a = 0; a < SQ__SPH_NREORDER_F; a++) sq_free(ctx, s->fspare[a]);
    for (int a = 0; a < SQ__SPH_NREORDER_U; a++) sq_free(ctx, s->uspare[a]);
    sq_free(ctx, s->nb);
    sq_free(ctx, s->nb_count);
    sq_free(ctx, s->nb_plain);
    sq_free(ctx, s->cell_start);
    sq_free(ctx, s->kbase);
    sq_free(ctx, s->col_depth);
    sq_free(ctx, s->col_tmp);
    sq_free(ctx, s->hist);
    sq_free(ctx, s->red);
    sq_free(ctx, s->terrain.h);
    sq_free(ctx, s->boxes);
    for (int g = 0; g < s->sdf_count; g++) sq_free(ctx, s->sdfs[g].d);
    sq_free(ctx, s->sdfs);
}

void sq_sph_destroy(sq_sph *s)
{
    if (!s) return;
    sq_context *ctx = s->ctx;
    free_arrays(s);
    sq_free(ctx, s);
}

/* Σ_lattice W over the cubic lattice of spacing dx (double), for the particle mass. */
static double lattice_sum(const sq__sph_kern *k, double dx)
{
    const double H = k->H;
    const int n = (int)ceil(H / dx) + 1;
    double sum = 0.0;
    for (int a = -n; a <= n; a++)
        for (int b = -n; b <= n; b++)
            for (int c = -n; c <= n; c++) {
                const double r = dx * sqrt((double)(a * a + b * b + c * c));
                if (r >= H) continue;
                sum += k->cubic ? (double)sq__sph_w_cubic(k, (float)r)
                                : (double)sq__sph_w_poly6(k, (float)(r * r));
            }
    return sum;
}

/* Σ_lattice V (z_j − z_i) ∂W/∂z_i over the cubic lattice (V = 1/Σ_lattice W, as the particle
 * mass makes it): the factor by which the kernel gradient misses the identity on a lattice. */
static double lattice_gradient_factor(const sq__sph_kern *k, double dx)
{
    const double H = k->H;
    const int n = (int)ceil(H / dx) + 1;
    double sum = 0.0;
    for (int a = -n; a <= n; a++)
        for (int b = -n; b <= n; b++)
            for (int c = -n; c <= n; c++) {
                const double r = dx * sqrt((double)(a * a + b * b + c * c));
                if (r >= H || r == 0.0) continue;
                const double f = (double)sq__sph_gradf(k, (float)r);
                const double dz = c * dx;
                sum += -f * dz * dz;
            }
    return sum / lattice_sum(k, dx);
}

static sq_result alloc_nb(sq_sph *s, int cap)
{
    const uint64_t bytes = (uint64_t)s->cap * (uint64_t)cap * 4u;
    sq_free(s->ctx, s->nb);
    s->nb = NULL;
    char what[96];
    snprintf(what, sizeof what, "sph neighbour lists (%zu particles x %d)", s->cap, cap);
    sq_result r = sq_context_check_memory(s->ctx, bytes, what);
    if (r != SQ_OK) return r;
    s->nb = (uint32_t *)sq_alloc(s->ctx, (size_t)bytes);
    if (!s->nb) return SQ_ERR_OUT_OF_MEMORY;
    s->nb_cap = cap;
    return SQ_OK;
}

sq_result sq_sph_create(sq_context *ctx, const sq_sph_desc *desc, sq_sph **out)
{
    if (out) *out = NULL;
    if (!ctx || !out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "ctx and out must not be NULL");
    sq_result r = sq__sph_validate(ctx, desc);
    if (r != SQ_OK) return r;
    const sq_sph_desc d = sq_sph_desc_resolve(desc);
    const uint64_t bytes = sq_sph_memory_bytes(&d, d.max_particles);
    {
        char what[128];
        snprintf(what, sizeof what, "sph with %zu particles (%llu bytes)", d.max_particles,
                 (unsigned long long)bytes);
        r = sq_context_check_memory(ctx, bytes, what);
        if (r != SQ_OK) return r;
    }
    sq_sph *s = (sq_sph *)sq_alloc_zero(ctx, sizeof *s);
    if (!s) return SQ_ERR_OUT_OF_MEMORY;
    s->ctx = ctx;
    s->d = d;
    s->nt = sq_context_threads(ctx);
    if (s->nt < 1) s->nt = 1;
    s->avx512 = sq__sph_uses_avx512();

    sq__sph_kern_init(&s->k, (float)d.support_radius_m, d.kernel == SQ_SPH_KERNEL_CUBIC);
    sq__sph_rheo_init(&s->rheo, &d.rheology);
    s->newtonian = d.rheology.kind == SQ_SPH_RHEOLOGY_NEWTONIAN;
    s->visc = (int)d.viscous;
    s->corrected = d.gradient == SQ_SPH_GRADIENT_CORRECTED;
    s->tait = d.eos == SQ_SPH_EOS_TAIT;
    s->tensile = d.tensile_pressure;
    s->rho0 = (float)d.rest_density_kgm3;
    s->c0 = (float)d.speed_of_sound_mps;
    s->c2 = (float)(d.speed_of_sound_mps * d.speed_of_sound_mps);
    s->tait_gamma = 7.0f;
    s->inv_tait_gamma = 1.0f / 7.0f;
    s->tait_b = (float)(d.rest_density_kgm3 * d.speed_of_sound_mps * d.speed_of_sound_mps / 7.0);
    s->xsph_eps = (float)d.xsph_epsilon;
    s->p_bg = (float)d.background_pressure_pa;
    s->av_c = (float)(d.artificial_viscosity * d.speed_of_sound_mps * 0.5 * d.support_radius_m);
    for (int a = 0; a < 3; a++) s->g[a] = (float)d.gravity_mps2[a];
    s->coll_r = (float)d.collision_radius_m;
    s->wall_margin = 0.25f * s->coll_r;
    s->mass = (float)(d.rest_density_kgm3 / lattice_sum(&s->k, d.spacing_m));
    s->pgrad_c = s->corrected ? (float)(1.0 / lattice_gradient_factor(&s->k, d.spacing_m)) : 1.0f;

    uint64_t ncell = 1;
    for (int a = 0; a < 3; a++) {
        s->lo[a] = (float)d.domain_min_m[a];
        s->hi[a] = (float)d.domain_max_m[a];
        s->len[a] = s->hi[a] - s->lo[a];
        s->half_len[a] = 0.5f * s->len[a];
        s->periodic[a] = d.boundary[2 * a] == SQ_SPH_BOUNDARY_PERIODIC;
        s->any_periodic |= s->periodic[a];
        s->wrap_h[a] = s->periodic[a] ? s->half_len[a] : INFINITY;
        s->face[2 * a] = (int)d.boundary[2 * a];
        s->face[2 * a + 1] = (int)d.boundary[2 * a + 1];
        for (int f = 0; f < 2; f++)
            if (s->face[2 * a + f] <= SQ_SPH_BOUNDARY_FREE_SLIP) s->any_wall = 1;
        double c = floor((d.domain_max_m[a] - d.domain_min_m[a]) / d.support_radius_m);
        if (c < 1.0) c = 1.0;
        s->n[a] = (int)c;
        s->cell[a] = s->len[a] / (float)s->n[a];
        s->inv_cell[a] = 1.0f / s->cell[a];
        ncell *= (uint64_t)s->n[a];
    }
    if (d.terrain_layer_m > 0.0) {
        /* terrain-following: n[2] cells per column above kbase (0 until a terrain is set) */
        const int nc = sq__sph_column_cells(d.terrain_layer_m, (double)s->cell[2]);
        if (nc < s->n[2]) {
            ncell = ncell / (uint64_t)s->n[2] * (uint64_t)nc;
            s->n[2] = nc;
        }
        s->column = 1;
    }
    s->ncell = (uint32_t)ncell;
    s->cap = d.max_particles;

    const size_t np = s->cap;
    float **fa[] = {&s->x,  &s->y,  &s->z,  &s->vx, &s->vy,  &s->vz, &s->hx, &s->hy,
                    &s->hz, &s->ax, &s->ay, &s->az, &s->sx,  &s->sy, &s->sz, &s->rho,
                    &s->p,  &s->vol, &s->pr2, &s->gam, &s->mu};
    int ok = 1;
    for (size_t k = 0; k < sizeof fa / sizeof fa[0]; k++) {
        *fa[k] = (float *)sq_alloc_zero(ctx, np * sizeof(float));
        ok &= *fa[k] != NULL;
    }
    s->L = (float *)sq_alloc_zero(ctx, 6 * np * sizeof(float));
    const int tensor = d.viscous == SQ_SPH_VISCOUS_TENSOR; /* G and τ: only this form reads them */
    s->G = tensor ? (float *)sq_alloc_zero(ctx, 9 * np * sizeof(float)) : NULL;
    s->tau = tensor ? (float *)sq_alloc_zero(ctx, 6 * np * sizeof(float)) : NULL;
    s->rec = (float *)sq_alloc_zero(ctx, SQ__SPH_REC * np * sizeof(float));
    s->id = (uint32_t *)sq_alloc_zero(ctx, np * sizeof(uint32_t));
    s->cellid = (uint32_t *)sq_alloc(ctx, np * sizeof(uint32_t));
    s->perm = (uint32_t *)sq_alloc(ctx, np * sizeof(uint32_t));
    for (int a = 0; a < SQ__SPH_NREORDER_F; a++) {
        s->fspare[a] = (float *)sq_alloc(ctx, np * sizeof(float));
        ok &= s->fspare[a] != NULL;
    }
    for (int a = 0; a < SQ__SPH_NREORDER_U; a++) {
        s->uspare[a] = (uint32_t *)sq_alloc(ctx, np * sizeof(uint32_t));
        ok &= s->uspare[a] != NULL;
    }
    s->nb_count = (uint16_t *)sq_alloc_zero(ctx, np * sizeof(uint16_t));
    s->nb_plain = (uint16_t *)sq_alloc_zero(ctx, np * sizeof(uint16_t));
    s->cell_start = (uint32_t *)sq_alloc_zero(ctx, ((size_t)ncell + 2) * sizeof(uint32_t));
    s->hist = (uint32_t *)sq_alloc_zero(ctx, ((size_t)ncell + 2) * sizeof(uint32_t));
    s->red = (double *)sq_alloc_zero(ctx, 8 * (size_t)s->nt * sizeof(double));
    if (s->column) {
        s->kbase = (int32_t *)sq_alloc_zero(ctx, (size_t)s->n[0] * (size_t)s->n[1] * sizeof(int32_t));
        ok &= s->kbase != NULL;
    }
    ok &= s->L && (!tensor || (s->G && s->tau)) && s->rec && s->id && s->cellid && s->perm && s->nb_count &&
          s->nb_plain && s->cell_start && s->hist && s->red;
    if (!ok) {
        sq_sph_destroy(s);
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, MOD, "allocation of %zu particles failed", np);
    }
    r = alloc_nb(s, d.neighbour_capacity);
    if (r != SQ_OK) {
        sq_sph_destroy(s);
        return r;
    }
    for (size_t i = 0; i < np; i++) {
        s->L[6 * i] = s->L[6 * i + 1] = s->L[6 * i + 2] = 1.0f;
    }
    s->bytes = sq_context_bytes_in_use(ctx);
    sq_log(ctx, SQ_LOG_DEBUG, MOD,
           "created: H = %g m, dx = %g m, m = %g kg, c_s = %g m/s, grid %dx%dx%d, capacity %zu",
           d.support_radius_m, d.spacing_m, (double)s->mass, d.speed_of_sound_mps, s->n[0],
           s->n[1], s->n[2], s->cap);
    *out = s;
    return SQ_OK;
}

/* ---- particles -------------------------------------------------------------------------------- */

sq_result sq_sph_add_particles(sq_sph *s, size_t count, const float *pos, const float *vel)
{
    if (!s) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sph is NULL");
    if (count == 0) return SQ_OK;
    if (!pos) return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "positions_m is NULL");
    if (count > s->cap - s->count)
        return sq__fail(s->ctx, SQ_ERR_TOO_LARGE, MOD,
                        "adding %zu particles to %zu exceeds max_particles = %zu", count, s->count,
                        s->cap);
    for (size_t k = 0; k < count; k++) {
        for (int a = 0; a < 3; a++) {
            const float v = pos[3 * k + (size_t)a];
            if (!(v >= s->lo[a] && v <= s->hi[a]))
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                                "positions_m[%zu].%c = %g is outside the domain [%g, %g]", k,
                                "xyz"[a], (double)v, (double)s->lo[a], (double)s->hi[a]);
            if (s->column && a == 2 && sq__sph_above_layer(s, pos[3 * k], pos[3 * k + 1], v))
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                                "positions_m[%zu] = (%g, %g, %g) lies above the terrain-following "
                                "layer (terrain_layer_m = %g m over the lowest terrain of its "
                                "column)", k, (double)pos[3 * k], (double)pos[3 * k + 1],
                                (double)v, s->d.terrain_layer_m);
            if (vel && !isfinite(vel[3 * k + (size_t)a]))
                return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                                "velocities_mps[%zu].%c is not finite", k, "xyz"[a]);
        }
    }
    for (size_t k = 0; k < count; k++) {
        const size_t i = s->count + k;
        float p[3] = {pos[3 * k], pos[3 * k + 1], pos[3 * k + 2]};
        for (int a = 0; a < 3; a++)
            if (s->periodic[a] && p[a] >= s->hi[a]) p[a] -= s->len[a];
        s->x[i] = p[0];
        s->y[i] = p[1];
        s->z[i] = p[2];
        const float v[3] = {vel ? vel[3 * k] : 0.0f, vel ? vel[3 * k + 1] : 0.0f,
                            vel ? vel[3 * k + 2] : 0.0f};
        s->vx[i] = s->hx[i] = v[0];
        s->vy[i] = s->hy[i] = v[1];
        s->vz[i] = s->hz[i] = v[2];
        s->ax[i] = s->ay[i] = s->az[i] = 0.0f;
        s->sx[i] = s->sy[i] = s->sz[i] = 0.0f;
        s->id[i] = s->next_id++;
    }
    s->count += count;
    s->forces_valid = 0;
    return SQ_OK;
}

sq_result sq_sph_add_block(sq_sph *s, const double min_m[3], const double max_m[3],
                           const double velocity_mps[3], size_t *added)
{
    if (added) *added = 0;
    if (!s || !min_m || !max_m)
        return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "sph, min_m and max_m must not be NULL");
    const double dx = s->d.spacing_m;
    size_t n[3];
    for (int a = 0; a < 3; a++) {
        const double L = max_m[a] - min_m[a];
        if (!(L >= 0.0) || !isfinite(L))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "block %c: min %g > max %g", "xyz"[a],
                            min_m[a], max_m[a]);
        n[a] = (size_t)floor(L / dx + 1e-6);
    }
    const size_t total = n[0] * n[1] * n[2];
    if (total == 0) return SQ_OK;
    if (total > s->cap - s->count)
        return sq__fail(s->ctx, SQ_ERR_TOO_LARGE, MOD,
                        "block of %zux%zux%zu = %zu particles added to %zu exceeds max_particles = %zu",
                        n[0], n[1], n[2], total, s->count, s->cap);
    /* in chunks through sq_sph_add_particles (one validation path) */
    float buf[3 * 1024], vb[3 * 1024];
    size_t k = 0, done = 0;
    for (size_t c = 0; c < n[2]; c++)
        for (size_t b = 0; b < n[1]; b++)
            for (size_t a = 0; a < n[0]; a++) {
                buf[3 * k] = (float)(min_m[0] + ((double)a + 0.5) * dx);
                buf[3 * k + 1] = (float)(min_m[1] + ((double)b + 0.5) * dx);
                buf[3 * k + 2] = (float)(min_m[2] + ((double)c + 0.5) * dx);
                for (int e = 0; e < 3; e++) vb[3 * k + (size_t)e] = velocity_mps ? (float)velocity_mps[e] : 0.0f;
                if (++k == 1024) {
                    sq_result r = sq_sph_add_particles(s, k, buf, vb);
                    if (r != SQ_OK) return r;
                    done += k;
                    k = 0;
                }
            }
    if (k) {
        sq_result r = sq_sph_add_particles(s, k, buf, vb);
        if (r != SQ_OK) return r;
        done += k;
    }
    if (added) *added = done;
    return SQ_OK;
}

/* ---- colliders --------------------------------------------------------------------------------- */

static sq_result contact_init(sq_sph *s, const sq_sph_collider_desc *c, const char *what,
                              sq__sph_contact *out)
{
    return sq__sph_contact_from_desc(s, c, what, out);
}

sq_result sq__sph_contact_from_desc(sq_sph *s, const sq_sph_collider_desc *c, const char *what,
                                    sq__sph_contact *out)
{
    if (!(c->restitution >= 0.0 && c->restitution <= 1.0))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.contact.restitution = %g; must be in [0, 1]", what, c->restitution);
    if (!(c->friction >= 0.0) || !isfinite(c->friction))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.contact.friction = %g; must be >= 0 (kinetic Coulomb coefficient)",
                        what, c->friction);
    if (!(c->turbulent_friction_mps2 >= 0.0) || !isfinite(c->turbulent_friction_mps2))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.contact.turbulent_friction_mps2 = %g; must be >= 0 (m/s2, 0 = none)",
                        what, c->turbulent_friction_mps2);
    if (c->turbulent_friction_mps2 > 0.0 && !c->column_friction)
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "%s.contact.turbulent_friction_mps2 = %g needs column_friction (the "
                        "Voellmy drag acts on the flow column)", what, c->turbulent_friction_mps2);
    out->e = (float)c->restitution;
    out->mu_k = c->frictionless ? 0.0f : (float)(c->friction == 0.0 ? 0.2 : c->friction);
    out->column = c->column_friction;
    out->col_mu = out->column ? out->mu_k : 0.0f;
    if (out->column) out->mu_k = 0.0f; /* the friction acts on the column instead */
    const double g = sqrt(s->d.gravity_mps2[0] * s->d.gravity_mps2[0] +
                          s->d.gravity_mps2[1] * s->d.gravity_mps2[1] +
                          s->d.gravity_mps2[2] * s->d.gravity_mps2[2]);
    out->turb_k = c->turbulent_friction_mps2 > 0.0 ? (float)(g / c->turbulent_friction_mps2) : 0.0f;
    return SQ_OK;
}

/* Terrain-following grid: each column's lowest cell, one cell below the lowest terrain under
 * its footprint. The bilinear terrain's minimum over a rectangle lies at the rectangle's corners
 * or at a terrain sample inside it, so both are taken. */
static void column_bases(sq_sph *s)
{
    const int nx = s->n[0], ny = s->n[1];
    const sq__sph_terrain *t = &s->terrain;
    float *hmin = (float *)sq_alloc(s->ctx, (size_t)nx * (size_t)ny * sizeof(float));
    if (!hmin) { /* keep the previous bases (correct, only less tight) */
        sq_log(s->ctx, SQ_LOG_WARN, MOD, "no memory for the column bases; kept");
        return;
    }
    for (int cy = 0; cy < ny; cy++)
        for (int cx = 0; cx < nx; cx++) {
            float m = INFINITY;
            for (int q = 0; q < 4; q++) {
                float h, nrm[3];
                const float x = s->lo[0] + (float)(cx + (q & 1)) * s->cell[0];
                const float y = s->lo[1] + (float)(cy + (q >> 1)) * s->cell[1];
                sq__sph_terrain_eval(t, x, y, &h, nrm);
                m = h < m ? h : m;
            }
            hmin[(size_t)cy * (size_t)nx + (size_t)cx] = m;
        }
    for (int j = 0; j < t->ny; j++)
        for (int i = 0; i < t->nx; i++) {
            const float x = t->ox + (float)i * t->dx, y = t->oy + (float)j * t->dy;
            const float fx = (x - s->lo[0]) * s->inv_cell[0], fy = (y - s->lo[1]) * s->inv_cell[1];
            if (!(fx >= 0.0f && fy >= 0.0f && fx < (float)nx && fy < (float)ny)) continue;
            float *m = &hmin[(size_t)fy * (size_t)nx + (size_t)fx];
            const float h = t->h[(size_t)j * (size_t)t->nx + (size_t)i];
            *m = h < *m ? h : *m;
        }
    for (size_t c = 0; c < (size_t)nx * (size_t)ny; c++) {
        const float k = floorf((hmin[c] - s->lo[2]) * s->inv_cell[2]) - 1.0f;
        s->kbase[c] = k > 0.0f ? (k < 1e9f ? (int32_t)k : 1000000000) : 0;
    }
    sq_free(s->ctx, hmin);
}

sq_result sq_sph_set_terrain(sq_sph *s, const sq_sph_terrain_desc *t)
{
    if (!s || !t) return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "sph and terrain must not be NULL");
    if (t->nx < 2 || t->ny < 2)
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "terrain %dx%d samples; needs at least 2 along each axis", t->nx, t->ny);
    if (!(t->spacing_m[0] > 0.0 && t->spacing_m[1] > 0.0) || !isfinite(t->spacing_m[0]) ||
        !isfinite(t->spacing_m[1]))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "terrain spacing_m = (%g, %g); must be > 0 (m)", t->spacing_m[0],
                        t->spacing_m[1]);
    if (!t->heights_m) return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "terrain heights_m is NULL");
    if (!isfinite(t->origin_m[0]) || !isfinite(t->origin_m[1]))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "terrain origin_m is not finite");
    sq__sph_contact c;
    sq_result r = contact_init(s, &t->contact, "terrain", &c);
    if (r != SQ_OK) return r;
    const size_t n = (size_t)t->nx * (size_t)t->ny;
    for (size_t k = 0; k < n; k++)
        if (!isfinite(t->heights_m[k]))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "terrain heights_m[%zu] (i = %zu, j = %zu) is not finite", k,
                            k % (size_t)t->nx, k / (size_t)t->nx);
    char what[96];
    snprintf(what, sizeof what, "sph terrain %dx%d", t->nx, t->ny);
    r = sq_context_check_memory(s->ctx, n * sizeof(float), what);
    if (r != SQ_OK) return r;
    float *h = (float *)sq_alloc(s->ctx, n * sizeof(float));
    if (!h) return SQ_ERR_OUT_OF_MEMORY;
    memcpy(h, t->heights_m, n * sizeof(float));
    sq_free(s->ctx, s->terrain.h);
    sq__sph_terrain *tr = &s->terrain;
    tr->h = h;
    tr->nx = t->nx;
    tr->ny = t->ny;
    tr->ox = (float)t->origin_m[0];
    tr->oy = (float)t->origin_m[1];
    tr->dx = (float)t->spacing_m[0];
    tr->dy = (float)t->spacing_m[1];
    tr->inv_dx = 1.0f / tr->dx;
    tr->inv_dy = 1.0f / tr->dy;
    tr->c = c;
    s->has_terrain = 1;
    if (s->column) column_bases(s);
    if (c.column && !s->col_depth) {
        const size_t ncol = (size_t)s->n[0] * (size_t)s->n[1];
        s->col_depth = (float *)sq_alloc_zero(s->ctx, ncol * sizeof(float));
        s->col_tmp = (float *)sq_alloc_zero(s->ctx, ncol * sizeof(float));
        if (!s->col_depth || !s->col_tmp)
            return sq__fail(s->ctx, SQ_ERR_OUT_OF_MEMORY, MOD,
                            "out of memory for the flow-depth columns (%zu)", ncol);
    }
    return SQ_OK;
}

sq_result sq_sph_terrain_sample(const sq_sph *s, double x, double y, double *h, double n[3])
{
    if (!s || !s->has_terrain) return sq__set_error(SQ_ERR_NOT_FOUND, "sph: no terrain set");
    float hf, nf[3];
    sq__sph_terrain_eval(&s->terrain, (float)x, (float)y, &hf, nf);
    if (h) *h = hf;
    if (n) {
        n[0] = nf[0];
        n[1] = nf[1];
        n[2] = nf[2];
    }
    return SQ_OK;
}

sq_result sq_sph_add_box_obstacle(sq_sph *s, const sq_sph_box_desc *b)
{
    if (!s || !b) return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "sph and box must not be NULL");
    for (int a = 0; a < 3; a++)
        if (!(b->max_m[a] > b->min_m[a]) || !isfinite(b->min_m[a]) || !isfinite(b->max_m[a]))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "box %c: min %g, max %g; needs finite max > min", "xyz"[a], b->min_m[a],
                            b->max_m[a]);
    sq__sph_contact c;
    sq_result r = contact_init(s, &b->contact, "box", &c);
    if (r != SQ_OK) return r;
    if (s->box_count == s->box_cap) {
        const int nc = s->box_cap ? 2 * s->box_cap : 8;
        sq__sph_box *nb = (sq__sph_box *)sq_alloc(s->ctx, (size_t)nc * sizeof *nb);
        if (!nb) return SQ_ERR_OUT_OF_MEMORY;
        if (s->box_count) memcpy(nb, s->boxes, (size_t)s->box_count * sizeof *nb);
        sq_free(s->ctx, s->boxes);
        s->boxes = nb;
        s->box_cap = nc;
    }
    sq__sph_box *bx = &s->boxes[s->box_count++];
    for (int a = 0; a < 3; a++) {
        bx->lo[a] = (float)b->min_m[a];
        bx->hi[a] = (float)b->max_m[a];
    }
    bx->c = c;
    return SQ_OK;
}

sq_result sq_sph_move_box_obstacle(sq_sph *s, int index, const double min_m[3],
                                   const double max_m[3])
{
    if (!s || !min_m || !max_m)
        return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "sph and bounds must not be NULL");
    if (index < 0 || index >= s->box_count)
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "box obstacle %d: there are %d", index,
                        s->box_count);
    for (int a = 0; a < 3; a++)
        if (!(max_m[a] > min_m[a]) || !isfinite(min_m[a]) || !isfinite(max_m[a]))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD,
                            "box %d %c: min %g, max %g; needs finite max > min", index, "xyz"[a],
                            min_m[a], max_m[a]);
    for (int a = 0; a < 3; a++) {
        s->boxes[index].lo[a] = (float)min_m[a];
        s->boxes[index].hi[a] = (float)max_m[a];
    }
    return SQ_OK;
}

sq_result sq_sph_set_gravity(sq_sph *s, const double g[3])
{
    if (!s || !g) return sq__fail(s ? s->ctx : NULL, SQ_ERR_INVALID_ARG, MOD, "sph and gravity must not be NULL");
    for (int a = 0; a < 3; a++)
        if (!isfinite(g[a]))
            return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "gravity_mps2[%d] is not finite", a);
    for (int a = 0; a < 3; a++) {
        s->d.gravity_mps2[a] = g[a];
        s->g[a] = (float)g[a];
    }
    s->forces_valid = 0;
    return SQ_OK;
}

/* ---- the step --------------------------------------------------------------------------------- */

static double now_ms(void) { return sq_time_now() * 1e3; }

/* Structure update and the three passes at the current positions and (predicted) velocities. */
static sq_result evaluate(sq_sph *s)
{
    double t0 = now_ms();
    const size_t removed = sq__sph_sort(s);
    s->stats.removed += removed;
    double t1 = now_ms();
    int maxcnt = sq__sph_pass_density(s);
    while (maxcnt > s->nb_cap) {
        int cap = (int)ceil(1.25 * maxcnt / 8.0) * 8;
        if (cap > 65000) cap = 65000;
        if (cap <= s->nb_cap)
            return sq__fail(s->ctx, SQ_ERR_TOO_LARGE, MOD,
                            "step %llu: a particle has %d neighbours; the list limit is 65000 "
                            "(particles collapsed onto each other?)",
                            (unsigned long long)s->steps, maxcnt);
        sq_log(s->ctx, SQ_LOG_INFO, MOD, "neighbour list grows from %d to %d entries per particle",
               s->nb_cap, cap);
        sq_result r = alloc_nb(s, cap);
        if (r != SQ_OK) return r;
        maxcnt = sq__sph_pass_density(s);
    }
    double t2 = now_ms();
    s->mumax = sq__sph_pass_strain(s);
    if (s->newtonian) s->mumax = s->rheo.mu;
    double t3 = now_ms();
    s->amax = sq__sph_pass_forces(s);
    double t4 = now_ms();
    s->stats.ms_sort += t1 - t0;
    s->stats.ms_density += t2 - t1;
    s->stats.ms_strain += t3 - t2;
    s->stats.ms_forces += t4 - t3;
    s->stats.max_neighbours = maxcnt;
    s->forces_valid = 1;
    return SQ_OK;
}

static double stable_dt(const sq_sph *s, const char **limit)
{
    const double ell = 0.5 * s->d.support_radius_m;
    double dt = 0.4 * ell / (s->d.speed_of_sound_mps + (double)s->vmax);
    *limit = "cfl";
    if (s->mumax > 0.0f) {
        const double dv = 0.125 * ell * ell * s->d.rest_density_kgm3 / (double)s->mumax;
        if (dv < dt) {
            dt = dv;
            *limit = "viscous";
        }
    }
    if (s->amax > 0.0f) {
        const double df = 0.25 * sqrt(ell / (double)s->amax);
        if (df < dt) {
            dt = df;
            *limit = "force";
        }
    }
    if (s->d.dt_max_s > 0.0 && s->d.dt_max_s < dt) {
        dt = s->d.dt_max_s;
        *limit = "dt_max";
    }
    return dt;
}

static sq_result report_bad(sq_sph *s, size_t i, const char *what)
{
    const char *lim;
    const double dt = stable_dt(s, &lim);
    return sq__fail(s->ctx, SQ_ERR_UNSTABLE, MOD,
                    "step %llu: particle %zu (id %u) %s: position (%g, %g, %g) m, velocity "
                    "(%g, %g, %g) m/s; the stable dt was %.3g s (%s). Lower the frame dt or "
                    "dt_max_s, raise speed_of_sound_mps (now %g m/s) or lower the viscosity",
                    (unsigned long long)s->steps, i, s->id[i], what, (double)s->x[i],
                    (double)s->y[i], (double)s->z[i], (double)s->vx[i], (double)s->vy[i],
                    (double)s->vz[i], dt, lim, s->d.speed_of_sound_mps);
}

/* First kick and drift: v½ = v + a dt/2; x += (v½ + ξ) dt; colliders; v* = v½ + a dt/2. */
static sq_result kick_drift(sq_sph *s, float dt)
{
    const size_t N = s->count;
    const int nt = sq__sph_threads(s, N);
    const float hdt = 0.5f * dt;
    int64_t bad = INT64_MAX;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(min : bad))
    for (int64_t ii = 0; ii < (int64_t)N; ii++) {
        const size_t i = (size_t)ii;
        float hx = s->vx[i] + s->ax[i] * hdt, hy = s->vy[i] + s->ay[i] * hdt,
              hz = s->vz[i] + s->az[i] * hdt;
        s->hx[i] = hx;
        s->hy[i] = hy;
        s->hz[i] = hz;
        float p[3] = {s->x[i] + (hx + s->sx[i]) * dt, s->y[i] + (hy + s->sy[i]) * dt,
                      s->z[i] + (hz + s->sz[i]) * dt};
        if (!(isfinite(p[0]) && isfinite(p[1]) && isfinite(p[2]))) {
            if (ii < bad) bad = ii;
            continue;
        }
        if (s->any_periodic)
            for (int a = 0; a < 3; a++) {
                if (!s->periodic[a]) continue;
                if (p[a] < s->lo[a]) p[a] += s->len[a];
                else if (p[a] >= s->hi[a]) p[a] -= s->len[a];
                if (p[a] >= s->hi[a] || p[a] < s->lo[a]) p[a] = s->lo[a]; /* rounding */
            }
        s->x[i] = p[0];
        s->y[i] = p[1];
        s->z[i] = p[2];
        sq__sph_collide(s, i);
        s->vx[i] = s->hx[i] + s->ax[i] * hdt;
        s->vy[i] = s->hy[i] + s->ay[i] * hdt;
        s->vz[i] = s->hz[i] + s->az[i] * hdt;
    }
    if (bad != INT64_MAX) return report_bad(s, (size_t)bad, "moved to a non-finite position");
    return SQ_OK;
}

/* Second kick v = v½ + a dt/2 with the new accelerations; blow-up checks; max speed. */
static sq_result final_kick(sq_sph *s, float dt)
{
    const size_t N = s->count;
    const int nt = sq__sph_threads(s, N);
    const float hdt = 0.5f * dt;
    const float vlim = (float)(SQ__SPH_RUNAWAY_MACH * s->d.speed_of_sound_mps);
    const float vlim2 = vlim * vlim;
    float v2max = 0.0f;
    int64_t bad = INT64_MAX;
    const int contacts = s->has_terrain || s->box_count > 0 || s->sdf_count > 0 || s->any_wall;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(max : v2max) reduction(min : bad))
    for (int64_t ii = 0; ii < (int64_t)N; ii++) {
        const size_t i = (size_t)ii;
        s->vx[i] = s->hx[i] + s->ax[i] * hdt;
        s->vy[i] = s->hy[i] + s->ay[i] * hdt;
        s->vz[i] = s->hz[i] + s->az[i] * hdt;
        if (contacts) sq__sph_contact_velocity(s, i);
        const float vx = s->vx[i], vy = s->vy[i], vz = s->vz[i];
        const float v2 = vx * vx + vy * vy + vz * vz;
        if (!(v2 <= vlim2)) {
            if (ii < bad) bad = ii;
        } else if (v2 > v2max) {
            v2max = v2;
        }
    }
    if (bad != INT64_MAX) {
        const size_t i = (size_t)bad;
        const float v2 = s->vx[i] * s->vx[i] + s->vy[i] * s->vy[i] + s->vz[i] * s->vz[i];
        char what[128];
        if (isfinite(v2))
            snprintf(what, sizeof what, "runs away at |v| = %.3g m/s > 3 c_s = %.3g m/s",
                     (double)sqrtf(v2), (double)vlim);
        else
            snprintf(what, sizeof what, "has a non-finite velocity");
        return report_bad(s, i, what);
    }
    s->vmax = sqrtf(v2max);
    return SQ_OK;
}

/* Basal friction over the flow column (sq_sph_collider_desc.column_friction): the flow depth h
 * per column of the neighbour grid (particle volumes per area, 3x3 smoothed, at least dx), then
 * for each particle within h + dx of the terrain its velocity along the terrain loses the
 * Coulomb part μ_k g_n dt (not beyond rest) and the Voellmy drag:
 * |v_t| ← max(0, |v_t| − μ_k g_n dt) / (1 + (g/ξ) |v_t| dt / h). */
static void basal_drag(sq_sph *s, float dt)
{
    const int nx = s->n[0], ny = s->n[1];
    const size_t N = s->count, ncol = (size_t)nx * (size_t)ny;
    float *restrict dep = s->col_depth, *restrict tmp = s->col_tmp;
    memset(tmp, 0, ncol * sizeof(float));
    for (size_t i = 0; i < N; i++) {
        const int cx = (int)fminf(fmaxf((s->x[i] - s->lo[0]) * s->inv_cell[0], 0.0f), (float)(nx - 1));
        const int cy = (int)fminf(fmaxf((s->y[i] - s->lo[1]) * s->inv_cell[1], 0.0f), (float)(ny - 1));
        tmp[(size_t)cy * (size_t)nx + (size_t)cx] += s->vol[i];
    }
    const float area = s->cell[0] * s->cell[1];
    for (int cy = 0; cy < ny; cy++)
        for (int cx = 0; cx < nx; cx++) {
            float sum = 0.0f;
            int cells = 0;
            for (int j = cy - 1; j <= cy + 1; j++)
                for (int i = cx - 1; i <= cx + 1; i++) {
                    int ii = i, jj = j; /* periodic axes wrap, others end at the domain */
                    if (s->periodic[0]) ii = (i + nx) % nx;
                    if (s->periodic[1]) jj = (j + ny) % ny;
                    if (ii < 0 || jj < 0 || ii >= nx || jj >= ny) continue;
                    sum += tmp[(size_t)jj * (size_t)nx + (size_t)ii];
                    cells++;
                }
            dep[(size_t)cy * (size_t)nx + (size_t)cx] = sum / ((float)cells * area);
        }
    const float k = s->terrain.c.turb_k * dt, hmin = (float)s->d.spacing_m;
    const float mu_dt = s->terrain.c.col_mu * dt;
    const int nt = sq__sph_threads(s, N);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt))
    for (int64_t ii = 0; ii < (int64_t)N; ii++) {
        const size_t i = (size_t)ii;
        const int cx = (int)fminf(fmaxf((s->x[i] - s->lo[0]) * s->inv_cell[0], 0.0f), (float)(nx - 1));
        const int cy = (int)fminf(fmaxf((s->y[i] - s->lo[1]) * s->inv_cell[1], 0.0f), (float)(ny - 1));
        const float h = fmaxf(dep[(size_t)cy * (size_t)nx + (size_t)cx], hmin);
        float th, n[3];
        sq__sph_terrain_eval(&s->terrain, s->x[i], s->y[i], &th, n);
        if ((s->z[i] - th) * n[2] > h + hmin) continue; /* above its flow: airborne */
        const float v[3] = {s->vx[i], s->vy[i], s->vz[i]};
        const float vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
        const float t[3] = {v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2]};
        const float vt = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        const float gn = -(s->g[0] * n[0] + s->g[1] * n[1] + s->g[2] * n[2]);
        const float c = vt > 0.0f ? fmaxf(vt - mu_dt * fmaxf(gn, 0.0f), 0.0f) / vt : 0.0f;
        const float f = c / (1.0f + k * vt / h);
        s->vx[i] = vn * n[0] + f * t[0];
        s->vy[i] = vn * n[1] + f * t[1];
        s->vz[i] = vn * n[2] + f * t[2];
    }
}

static sq_result substep(sq_sph *s, double dt_s)
{
    const float dt = (float)dt_s;
    double t0 = now_ms();
    if (s->col_depth && s->has_terrain && s->terrain.c.column && s->forces_valid)
        basal_drag(s, dt);                     /* Coulomb + Voellmy over the flow column */
    sq_result r = kick_drift(s, dt);           /* v½, x(t + dt), colliders, v* */
    double t1 = now_ms();
    s->stats.ms_integrate += t1 - t0;
    if (r != SQ_OK) return r;
    r = evaluate(s);                           /* sort, density, strain, forces at t + dt */
    if (r != SQ_OK) return r;
    double t2 = now_ms();
    r = final_kick(s, dt);                     /* v(t + dt) */
    s->stats.ms_integrate += now_ms() - t2;
    s->steps++;
    s->time_s += dt_s;
    return r;
}

static float max_speed(const sq_sph *s)
{
    float v2max = 0.0f;
    const size_t N = s->count;
    for (size_t i = 0; i < N; i++) {
        const float v2 = s->vx[i] * s->vx[i] + s->vy[i] * s->vy[i] + s->vz[i] * s->vz[i];
        if (v2 > v2max) v2max = v2;
    }
    return sqrtf(v2max);
}

static sq_result ensure_forces(sq_sph *s)
{
    if (s->forces_valid) return SQ_OK;
    s->vmax = max_speed(s);
    return evaluate(s);
}

double sq_sph_max_stable_dt(sq_sph *s)
{
    if (!s) return 0.0;
    if (ensure_forces(s) != SQ_OK) return 0.0;
    const char *lim;
    return stable_dt(s, &lim);
}

sq_result sq_sph_step(sq_sph *s, double dt_frame)
{
    if (!s) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sph is NULL");
    if (!(dt_frame > 0.0) || !isfinite(dt_frame))
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, MOD, "dt_frame_s = %g; must be > 0 (s)", dt_frame);
    s->stats.ms_sort = s->stats.ms_density = s->stats.ms_strain = s->stats.ms_forces = 0.0;
    s->stats.ms_integrate = 0.0;
    s->stats.substeps = 0;
    if (s->count == 0) {
        s->time_s += dt_frame;
        return SQ_OK;
    }
    sq_result r = ensure_forces(s);
    if (r != SQ_OK) return r;
    double remaining = dt_frame;
    int sub = 0;
    for (;;) {
        const char *lim;
        const double dts = stable_dt(s, &lim);
        double nleft = ceil(remaining / dts * (1.0 - 1e-9));
        if (nleft < 1.0) nleft = 1.0;
        if (sub + nleft > (double)s->d.max_substeps)
            return sq__fail(s->ctx, SQ_ERR_UNSTABLE, MOD,
                            "step %llu: the frame dt %g s needs more than max_substeps = %d "
                            "sub-steps (stable dt %.3g s, limited by %s; max |a| = %.3g m/s2, "
                            "max |v| = %.3g m/s, max mu = %.3g Pa s)",
                            (unsigned long long)s->steps, dt_frame, s->d.max_substeps, dts, lim,
                            (double)s->amax, (double)s->vmax, (double)s->mumax);
        const double dt = nleft > 1.0 ? remaining / nleft : remaining;
        if (nleft > 1.0 && !s->logged_substep) {
            s->logged_substep = 1;
            sq_log(s->ctx, SQ_LOG_INFO, MOD,
                   "frame dt %.4g s exceeds the stable dt %.4g s (%s limit); sub-stepping "
                   "(%d sub-steps now; logged once)",
                   dt_frame, dts, lim, (int)nleft);
        }
        s->stats.dt_limit = nleft > 1.0 ? lim : "frame";
        r = substep(s, dt);
        sub++;
        s->stats.substeps = sub;
        s->stats.dt_s = dt;
        if (r != SQ_OK) return r;
        if (nleft <= 1.0) break;
        remaining -= dt;
    }
    return SQ_OK;
}

/* ---- views and statistics ---------------------------------------------------------------------- */

sq_sph_view sq_sph_particles(const sq_sph *s)
{
    sq_sph_view v;
    memset(&v, 0, sizeof v);
    if (!s) return v;
    v.count = s->count;
    v.x = s->x;
    v.y = s->y;
    v.z = s->z;
    v.vx = s->vx;
    v.vy = s->vy;
    v.vz = s->vz;
    v.density = s->rho;
    v.pressure = s->p;
    v.shear_rate = s->gam;
    v.viscosity = s->mu;
    v.id = s->id;
    return v;
}

sq_sph_info sq_sph_get_info(const sq_sph *s)
{
    sq_sph_info in;
    memset(&in, 0, sizeof in);
    if (!s) return in;
    in.particle_mass_kg = s->mass;
    in.support_radius_m = s->d.support_radius_m;
    in.speed_of_sound_mps = s->d.speed_of_sound_mps;
    in.max_speed_mps = s->d.max_speed_mps;
    in.stiffness = s->tait ? (double)s->tait_b : (double)s->c2;
    for (int a = 0; a < 3; a++) in.cells[a] = s->n[a];
    in.neighbour_capacity = s->nb_cap;
    in.max_particles = s->cap;
    in.bytes = s->bytes;
    return in;
}

sq_sph_stats sq_sph_get_stats(const sq_sph *s)
{
    sq_sph_stats st;
    memset(&st, 0, sizeof st);
    if (!s) return st;
    st = s->stats;
    st.time_s = s->time_s;
    st.steps = s->steps;
    st.max_speed_mps = s->vmax;
    st.max_accel_mps2 = s->amax;
    st.max_viscosity_pa_s = s->mumax;
    st.particles = s->count;
    uint64_t tot = 0;
    for (size_t i = 0; i < s->count; i++) tot += s->nb_count[i];
    st.neighbours_per_particle = s->count ? (double)tot / (double)s->count : 0.0;
    if (!st.dt_limit) st.dt_limit = "frame";
    return st;
}
