/* clouds.c — the clouds phenomenon (S4; SPEC §8; issue 10): lifecycle, the step recipe, the
 * drawable (MFS-lit particles or the volume of the same extinction field), metrics and fields.
 *
 * One step, in S4 §2.2's order:
 *   read the source at the new time (WRF: interpolated between stored times)   step 1
 *   optics per cell, clouds = connected cells above the threshold              step 1
 *   particles: drift, age, re-initialise at the end of life, tau from the field steps 2, 4
 *   structured particles: leader clustering with the grid pre-pass             step 3
 *   the drawable: clusters (or particles) grouped by cloud for impostors       step 5 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "clouds_internal.h"
#include "world/world_struct.h"

#define MAX_STEP_S 600.0
#define SPLAT_AREA 0.3f


/* ---- lifecycle ------------------------------------------------------------------------------ */
static sq_result alloc_draw(sq_clouds *c)
{
    sq_context *ctx = c->ctx;
    const size_t n = (size_t)c->d.particles;
    c->d_pos = sq_alloc(ctx, 3 * n * sizeof(float));
    c->d_radius = sq_alloc(ctx, n * sizeof(float));
    c->d_tau = sq_alloc(ctx, n * sizeof(float));
    c->d_g = sq_alloc(ctx, n * sizeof(float));
    c->d_key = sq_alloc(ctx, n * sizeof(int32_t));
    c->d_cursor = sq_alloc(ctx, (SQ__MAX_CLOUDS + 2) * sizeof(int32_t));
    c->groups = sq_alloc(ctx, (SQ__MAX_CLOUDS + 1) * sizeof(sq_cloud_group));
    c->st.pos = sq_alloc(ctx, 3 * n * sizeof(float));
    c->st.radius = sq_alloc(ctx, n * sizeof(float));
    c->st.tau = sq_alloc(ctx, n * sizeof(float));
    c->st.density = sq_alloc(ctx, n * sizeof(float));
    c->st.weight = sq_alloc(ctx, n * sizeof(float));
    c->st.members = sq_alloc(ctx, n * sizeof(int32_t));
    c->st.cloud = sq_alloc(ctx, n * sizeof(int32_t));
    c->st_g = sq_alloc(ctx, n * sizeof(float));
    const sq__cloud_grid *g = &c->field.grid;
    const size_t cols = (size_t)g->nx * g->ny;
    c->map_lwp = sq_alloc(ctx, cols * sizeof(float));
    c->map_iwp = sq_alloc(ctx, cols * sizeof(float));
    c->map_tau = sq_alloc(ctx, cols * sizeof(float));
    c->map_top = sq_alloc(ctx, cols * sizeof(float));
    c->map_cover = sq_alloc(ctx, cols * sizeof(float));
    if (!c->d_pos || !c->d_radius || !c->d_tau || !c->d_g || !c->d_key || !c->d_cursor ||
        !c->groups || !c->st.pos || !c->st.radius || !c->st.tau || !c->st.density ||
        !c->st.weight || !c->st.members || !c->st.cloud || !c->st_g || !c->map_lwp ||
        !c->map_iwp || !c->map_tau || !c->map_top || !c->map_cover)
        return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for %zu cloud particles",
                        n);
    return sq__cluster_reserve(ctx, &c->clus, (int)n);
}

void sq_clouds_destroy(sq_clouds *c)
{
    if (!c) return;
    sq_context *ctx = c->ctx;
    sq__cloud_source_close(c->src);
    sq__cloud_field_free(ctx, &c->field);
    sq__segment_free(ctx, &c->seg);
    sq__particles_free(ctx, &c->parts);
    sq__cluster_free(ctx, &c->clus);
    void *bufs[] = {c->d_pos, c->d_radius, c->d_tau, c->d_g, c->d_key, c->d_cursor, c->groups,
                    c->st.pos, c->st.radius, c->st.tau, c->st.density, c->st.weight,
                    c->st.members, c->st.cloud, c->st_g, c->vox, c->vox_phys, c->vox_cond,
                    c->map_lwp, c->map_iwp, c->map_tau, c->map_top, c->map_cover};
    for (size_t i = 0; i < sizeof bufs / sizeof bufs[0]; i++) sq_free(ctx, bufs[i]);
    sq_free(ctx, c);
}

/* What update does with the particles: seed them (creation), advance them by dt (a step), or
 * keep them as they are (after a checkpoint load). */
typedef enum { PARTICLES_SEED, PARTICLES_ADVANCE, PARTICLES_KEEP } particles_action;
static sq_result update(sq_clouds *c, double dt_s, particles_action act);

/* particles.per_km3: the count from the clouds' volume at time 0, refused before allocating
 * when the particles would not fit the memory limit (the message names count and bytes). */
static sq_result particles_for_density(sq_clouds *c)
{
    sq__cloud_frame fr;
    sq_result r = sq__cloud_source_read(c->src, 0.0, &fr);
    if (r != SQ_OK) return r;
    sq__cloud_field_update(&c->field, &fr, 0.0, 0.0);
    sq__segment_clouds(&c->seg, &c->field, (float)c->d.threshold_g_m3);
    double v = 0.0; /* physical in-cloud volume, m³ */
    const sq__cloud_field *f = &c->field;
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny;
    for (size_t q = 0; q < f->cells; q++) {
        if (f->label[q] < 0) continue;
        const float dz = f->zw[q + cols] - f->zw[q];
        v += (double)g->dx * (double)g->dy * (double)dz * (double)(f->sub.on ? f->frac[q] : 1.0f);
    }
    const double want = ceil(c->d.particles_per_km3 * v * 1e-9);
    const uint64_t bytes = (uint64_t)fmin(want, 1e18) * SQ__CLOUDS_BYTES_PER_PARTICLE;
    char what[256];
    snprintf(what, sizeof what,
             "sq_clouds_desc.particles.per_km3 = %g over %.4g km3 of cloud: %.0f particles x %u "
             "bytes",
             c->d.particles_per_km3, v * 1e-9, want, SQ__CLOUDS_BYTES_PER_PARTICLE);
    r = sq_context_check_memory(c->ctx, bytes, what);
    if (r != SQ_OK) return r;
    if (want > 1e7)
        return sq__fail(c->ctx, SQ_ERR_TOO_LARGE, "clouds",
                        "sq_clouds_desc.particles.per_km3 = %g over %.4g km3 of cloud: %.0f "
                        "particles; at most 10000000",
                        c->d.particles_per_km3, v * 1e-9, want);
    c->d.particles = want < 1.0 ? 1 : (int)want;
    return SQ_OK;
}

sq_result sq_clouds_create(sq_context *ctx, const sq_clouds_desc *desc, const sq_world *world,
                           sq_clouds **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "clouds", "sq_clouds_create: out is NULL");
    *out = NULL;
    sq_clouds_desc d;
    sq_clouds_desc_resolve(desc, &d);
    sq_result r = sq_clouds_validate(ctx, &d, world);
    if (r != SQ_OK) return r;
    sq_clouds *c = sq_alloc_zero(ctx, sizeof *c);
    if (!c) return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory");
    c->ctx = ctx;
    c->d = d;
    c->world = world;
    r = sq__cloud_source_open(ctx, &d, world, &c->src);
    sq__cloud_grid grid;
    if (r == SQ_OK) {
        sq__cloud_source_grid(c->src, &grid);
        r = sq__cloud_field_init(ctx, &c->field, &grid, &d, sq__clouds_exaggeration(world));
    }
    if (r == SQ_OK) r = sq__segment_init(ctx, &c->seg, &grid);
    if (r == SQ_OK && d.particles_per_km3 > 0.0) r = particles_for_density(c);
    if (r == SQ_OK) r = sq__particles_init(ctx, &c->parts, c->d.particles, c->field.cells);
    if (r == SQ_OK) r = alloc_draw(c);
    if (r == SQ_OK) {
        c->pp.count = c->d.particles;
        c->pp.radius_m = (float)d.radius_m;
        c->pp.lifetime_s = (float)d.lifetime_s;
        c->pp.seed = d.seed;
        c->pp.threads = sq_context_threads(ctx);
        r = update(c, 0.0, PARTICLES_SEED);
    }
    if (r != SQ_OK) {
        sq_clouds_destroy(c);
        return r;
    }
    sq_log(ctx, SQ_LOG_INFO, "clouds", "%s: %d clouds, %d particles", grid.description,
           c->stats.clouds, c->stats.particles);
    *out = c;
    return SQ_OK;
}

/* The field, its clouds and the particles' clusters follow the source's time: at most
 * MAX_STEP_S per step. The particles' lives are resolved inside the step (particle_substeps). */
double sq_clouds_max_stable_dt(const sq_clouds *c)
{
    (void)c;
    return MAX_STEP_S;
}

/* A particle ages at most a sixth of its nominal life per particle sub-step, so that short lives
 * (particles.lifetime_s down to its documented 1 s) end and respawn when they should; only the
 * particles are sub-stepped (cheap), the field, segmentation, maps and clusters once per step. */
static int particle_substeps(const sq_clouds *c, double dt_s)
{
    const double life = c->d.lifetime_s / 6.0;
    return dt_s > life ? (int)ceil(dt_s / life - 1e-9) : 1;
}

/* ---- the step ------------------------------------------------------------------------------- */
static void compute_maps(sq_clouds *c)
{
    const sq__cloud_field *f = &c->field;
    const sq__cloud_grid *g = &f->grid;
    const size_t cols = (size_t)g->nx * g->ny;
    for (size_t q = 0; q < cols; q++) {
        double lwp = 0, iwp = 0, tau = 0;
        float top = 0.0f, cover = 0.0f;
        for (int k = 0; k < g->nz; k++) {
            const size_t cc = (size_t)k * cols + q;
            const float dz = f->zw[cc + cols] - f->zw[cc];
            lwp += (double)((f->conc[SQ_HYDRO_CLOUD][cc] + f->conc[SQ_HYDRO_RAIN][cc]) * dz);
            iwp += (double)((f->conc[SQ_HYDRO_ICE][cc] + f->conc[SQ_HYDRO_SNOW][cc] +
                             f->conc[SQ_HYDRO_GRAUPEL][cc]) * dz);
            tau += (double)(f->beta[cc] * dz);
            if (f->label[cc] >= 0) {
                cover = 1.0f;
                top = f->z[cc];
            }
        }
        c->map_lwp[q] = (float)lwp;
        c->map_iwp[q] = (float)iwp;
        c->map_tau[q] = (float)tau;
        c->map_top[q] = cover > 0.0f ? top : NAN;
        c->map_cover[q] = cover;
    }
}

static void cluster_particles(sq_clouds *c)
{
    const sq__particles *p = &c->parts;
    sq__cluster_input in;
    in.n = p->n;
    in.pos = p->pos;
    in.density = p->density;
    in.stage = p->stage;
    in.phase = p->phase;
    in.cls = p->cloud;
    in.stages = SQ__STAGES;
    int classes = c->seg.clouds < 1 ? 1 : c->seg.clouds;
    if (classes > SQ__MAX_CLASSES) classes = SQ__MAX_CLASSES;
    c->sym.classes = classes;
    sq__symbolic_table_build(&c->sym, p->phase, p->cloud, p->n);
    in.symbols = &c->sym;
    sq__cluster_ranges rg;
    sq__cluster_ranges_compute(&in, &rg);
    sq__cluster_params cp;
    memset(&cp, 0, sizeof cp);
    const float rad = c->d.cluster_radius_m > 0.0 ? (float)c->d.cluster_radius_m : p->radius_auto;
    for (int a = 0; a < 3; a++) {
        const float range = rg.hi[a] - rg.lo[a];
        cp.sigma_pos[a] = range > 0.0f ? fmaxf(0.0f, 1.0f - rad / range) : 1.0f;
    }
    cp.sigma_density = (float)c->d.sigma_density;
    cp.sigma_stage = (float)c->d.sigma_stage;
    cp.sigma_phase = (float)c->d.sigma_phase;
    cp.symbolic_vdm = c->d.symbolic == SQ_CLOUDS_SYMBOLIC_VDM;
    cp.seed = c->d.seed;
    sq__cluster_leader(c->ctx, &c->clus, &in, &cp, true);
    sq__cluster_aggregate(&c->clus, &in, p->radius, p->tau, &c->st);
    /* g of a structured particle: weighted like its position */
    const int m = c->clus.clusters;
    for (int k = 0; k < m; k++) c->st_g[k] = 0.0f;
    for (int i = 0; i < p->n; i++) {
        const float w = p->tau[i] * p->radius[i] * p->radius[i] + 1e-30f;
        c->st_g[c->clus.label[i]] += w * p->g[i];
    }
    for (int k = 0; k < m; k++) c->st_g[k] /= c->st.weight[k];
}

/* Copies the drawn elements (clusters or particles) sorted by cloud into d_*, and the groups. */
static void build_draw(sq_clouds *c)
{
    const bool structured = !c->d.plain;
    const int n = structured ? c->clus.clusters : c->parts.n;
    const float *pos = structured ? c->st.pos : c->parts.pos;
    const float *rad = structured ? c->st.radius : c->parts.radius;
    const float *tau = structured ? c->st.tau : c->parts.tau;
    const float *gg = structured ? c->st_g : c->parts.g;
    const int32_t *cloud = structured ? c->st.cloud : c->parts.cloud;
    int clouds = c->seg.clouds;
    if (clouds > SQ__MAX_CLOUDS) clouds = SQ__MAX_CLOUDS;
    const int groups = clouds + 1; /* the last: elements without a cloud */
    int32_t *cur = c->d_cursor;
    memset(cur, 0, (size_t)(groups + 1) * sizeof(int32_t));
    for (int i = 0; i < n; i++) {
        const int key = cloud[i] >= 0 && cloud[i] < clouds ? cloud[i] : clouds;
        c->d_key[i] = key;
        cur[key + 1]++;
    }
    for (int q = 0; q < groups; q++) cur[q + 1] += cur[q];
    c->group_count = 0;
    for (int q = 0; q < groups; q++) {
        const int cnt = cur[q + 1] - cur[q];
        if (cnt == 0) continue;
        sq_cloud_group *gr = &c->groups[c->group_count++];
        gr->first = cur[q];
        gr->count = cnt;
    }
    for (int i = 0; i < n; i++) {
        const int o = cur[c->d_key[i]]++;
        memcpy(c->d_pos + 3 * o, pos + 3 * i, 3 * sizeof(float));
        c->d_radius[o] = rad[i];
        c->d_tau[o] = tau[i];
        c->d_g[o] = gg[i];
    }
    for (int q = 0; q < c->group_count; q++) {
        sq_cloud_group *gr = &c->groups[q];
        double s[3] = {0, 0, 0};
        for (int i = gr->first; i < gr->first + gr->count; i++)
            for (int a = 0; a < 3; a++) s[a] += (double)c->d_pos[3 * i + a];
        const sq_vec3 ctr = sq_v3((float)(s[0] / gr->count), (float)(s[1] / gr->count),
                                  (float)(s[2] / gr->count));
        float r = 0.0f;
        for (int i = gr->first; i < gr->first + gr->count; i++) {
            const sq_vec3 p = sq_v3(c->d_pos[3 * i], c->d_pos[3 * i + 1], c->d_pos[3 * i + 2]);
            r = fmaxf(r, sq_v3_len(sq_v3_sub(p, ctr)) + c->d_radius[i]);
        }
        gr->center_m = ctr;
        gr->radius_m = r;
    }
    c->draw_n = n;
}

static sq_result update(sq_clouds *c, double dt_s, particles_action act)
{
    const double t0 = sq_time_now();
    sq__cloud_frame fr;
    sq_result r = sq__cloud_source_read(c->src, c->time_s, &fr);
    if (r != SQ_OK) return r;
    sq__cloud_field_update(&c->field, &fr, c->time_s, dt_s);
    sq__segment_clouds(&c->seg, &c->field, (float)c->d.threshold_g_m3);
    sq__cloud_field_mask_to_clouds(&c->field);
    compute_maps(c);
    sq__particles_prepare(&c->parts, &c->field, &c->pp);
    if (act == PARTICLES_SEED) sq__particles_seed(&c->parts, &c->field, &c->pp);
    else if (act == PARTICLES_ADVANCE) {
        const int k = particle_substeps(c, dt_s);
        for (int j = 0; j < k; j++) {
            if (sq__cancelled(c->ctx))
                return sq__fail_cancelled(c->ctx, "clouds", "while stepping (sq_context_cancel)");
            sq__particles_advance(&c->parts, &c->field, &c->pp, dt_s / k);
        }
    }
    for (int i = 0; i < c->parts.n; i++)
        if (!isfinite(c->parts.pos[3 * i]) || !isfinite(c->parts.pos[3 * i + 2]) ||
            !isfinite(c->parts.tau[i]))
            return sq__fail(c->ctx, SQ_ERR_UNSTABLE, "clouds",
                            "particle %d at t = %g s: position or optical depth is not finite "
                            "(wind or field values of the source are)",
                            i, c->time_s);
    const double t1 = sq_time_now();
    if (!c->d.plain) cluster_particles(c);
    const double t2 = sq_time_now();
    build_draw(c);
    c->version++;
    sq_clouds_stats *s = &c->stats;
    s->clouds = c->seg.clouds;
    s->particles = c->parts.n;
    s->clusters = c->d.plain ? c->parts.n : c->clus.clusters;
    s->cover_fraction = c->seg.cover_fraction;
    s->cloud_top_m = c->seg.clouds > 0 ? c->seg.cloud_top_m : 0.0;
    s->lwp_g_m2 = c->seg.lwp_g_m2;
    s->iwp_g_m2 = c->seg.iwp_g_m2;
    s->ms_cluster = (t2 - t1) * 1e3;
    s->ms_model = (sq_time_now() - t0) * 1e3;
    return SQ_OK;
}

sq_result sq_clouds_step(sq_clouds *c, double dt_s)
{
    if (!c) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "clouds", "sq_clouds_step: NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(c->ctx, SQ_ERR_INVALID_ARG, "clouds", "step dt = %g s; must be > 0", dt_s);
    c->time_s += dt_s;
    return update(c, dt_s, PARTICLES_ADVANCE);
}

sq_result sq__clouds_refresh(sq_clouds *c)
{
    return update(c, 0.0, PARTICLES_KEEP);
}

sq_result sq_clouds_stats_get(const sq_clouds *c, sq_clouds_stats *out)
{
    if (!c || !out) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "clouds", "sq_clouds_stats_get: NULL");
    *out = c->stats;
    return SQ_OK;
}

sq_result sq_clouds_cloud(const sq_clouds *c, int i, sq_cloud_info *out)
{
    if (!c || !out || i < 0 || i >= c->seg.clouds)
        return sq__fail(c ? c->ctx : NULL, SQ_ERR_INVALID_ARG, "clouds",
                        "sq_clouds_cloud: index %d; there are %d clouds", i, c ? c->seg.clouds : 0);
    *out = c->seg.info[i];
    return SQ_OK;
}

/* ---- drawables ----------------------------------------------------------------------------- */
static void fill_clouds_view(sq_clouds *c, sq_drawable *out)
{
    memset(out, 0, sizeof *out);
    out->kind = SQ_DRAWABLE_CLOUDS;
    out->name = "clouds";
    sq_clouds_view *v = &out->u.clouds;
    const sq_clouds_desc *d = &c->d;
    v->count = c->draw_n;
    v->position = c->d_pos;
    v->radius_m = c->d_radius;
    v->tau = c->d_tau;
    v->g = c->d_g;
    v->groups = c->groups;
    v->group_count = c->group_count;
    v->g_default = (float)d->g_droplet;
    v->albedo = (float)d->albedo;
    v->rayleigh = d->rayleigh;
    v->splat_opacity = d->splat_opacity;
    v->eta1 = (float)d->eta1;
    v->splat_noise = d->smooth_splat ? 0.0f : (float)d->splat_noise;
    v->tau_splat = (float)d->tau_splat;
    v->gamma_sr = (float)d->gamma_sr;
    v->light_buffer = d->light_buffer;
    v->multiple_scattering = !d->harris_only;
    v->shadows = !d->no_shadows;
    v->impostors = !d->no_impostors;
    v->dist_3d_m = (float)d->dist_3d_m;
    v->dist_impostor_m = (float)d->dist_impostor_m;
    v->impostor_angle_deg = (float)d->impostor_angle_deg;
    v->version = c->version;
}

/* Voxelises the extinction field (with the sub-grid pattern) over the clouds' box. */
static sq_result build_volume(sq_clouds *c)
{
    if (c->vox && c->vox_version == c->version) return SQ_OK;
    sq_context *ctx = c->ctx;
    const int nx = c->d.volume_cells[0], ny = c->d.volume_cells[1], nz = c->d.volume_cells[2];
    const size_t n = (size_t)nx * ny * nz;
    if (!c->vox) {
        char what[96];
        snprintf(what, sizeof what, "layer clouds: volume of %dx%dx%d voxels", nx, ny, nz);
        sq_result r = sq_context_check_memory(ctx, 3 * n * sizeof(float), what);
        if (r != SQ_OK) return r;
        c->vox = sq_alloc(ctx, n * sizeof(float));
        c->vox_phys = sq_alloc(ctx, n * sizeof(float));
        c->vox_cond = sq_alloc(ctx, n * sizeof(float));
        if (!c->vox || !c->vox_phys || !c->vox_cond)
            return sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "clouds", "no memory for the volume");
    }
    c->vn[0] = nx;
    c->vn[1] = ny;
    c->vn[2] = nz;
    const sq__cloud_field *f = &c->field;
    const float e = f->exaggeration;
    sq_vec3 lo = sq_v3(INFINITY, INFINITY, INFINITY), hi = sq_v3(-INFINITY, -INFINITY, -INFINITY);
    for (int q = 0; q < c->seg.clouds; q++) {
        const sq_vec3 a = c->seg.info[q].min_m, b = c->seg.info[q].max_m;
        lo = sq_v3(fminf(lo.x, a.x), fminf(lo.y, a.y), fminf(lo.z, a.z));
        hi = sq_v3(fmaxf(hi.x, b.x), fmaxf(hi.y, b.y), fmaxf(hi.z, b.z));
    }
    if (c->seg.clouds == 0) {
        const sq__cloud_grid *g = &f->grid;
        lo = sq_v3(g->x0, g->y0, e * f->zw[0]);
        hi = sq_v3(g->x0 + g->dx, g->y0 + g->dy, e * f->zw[0] + 1.0f);
    }
    c->vox_origin = lo;
    c->vox_size = sq_v3_sub(hi, lo);
    const sq_vec3 h = sq_v3(c->vox_size.x / (float)nx, c->vox_size.y / (float)ny,
                            c->vox_size.z / (float)nz);
    const int nt = sq_context_threads(ctx);
    float vmax = 0.0f;
    double gsum = 0.0, bsum = 0.0;
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(max : vmax) reduction(+ : gsum, bsum))
    for (int k = 0; k < nz; k++) {
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                const float x = lo.x + ((float)i + 0.5f) * h.x, y = lo.y + ((float)j + 0.5f) * h.y;
                const float zw = lo.z + ((float)k + 0.5f) * h.z;
                sq__cloud_sample s;
                sq__cloud_field_sample(f, x, y, zw, &s);
                float b = 0.0f;
                if (s.beta > 0.0f) b = s.beta * sq__cloud_subgrid_weight(f, x, y, zw / e, s.frac);
                const size_t q = ((size_t)k * ny + j) * nx + i;
                c->vox_phys[q] = b;
                c->vox[q] = b / e;
                c->vox_cond[q] = s.cond;
                if (b / e > vmax) vmax = b / e;
                gsum += (double)(b * s.g);
                bsum += (double)b;
            }
    }
    c->vox_max = vmax;
    c->vox_g = bsum > 0.0 ? (float)(gsum / bsum) : (float)c->d.g_droplet;
    c->vox_version = c->version;
    return SQ_OK;
}

sq_result sq_clouds_volume_drawable(sq_clouds *c, sq_drawable *out)
{
    sq_result r = build_volume(c);
    if (r != SQ_OK) return r;
    memset(out, 0, sizeof *out);
    out->kind = SQ_DRAWABLE_VOLUME;
    out->name = "clouds";
    sq_volume_view *v = &out->u.volume;
    v->density = c->vox;
    v->nx = c->vn[0];
    v->ny = c->vn[1];
    v->nz = c->vn[2];
    v->origin_m = c->vox_origin;
    v->size_m = c->vox_size;
    for (int q = 0; q < 3; q++) {
        v->sigma_ext[q] = 1.0f; /* density is the extinction in 1/m (world) */
        v->albedo[q] = (float)c->d.albedo;
        v->g[q] = c->d.rayleigh ? 0.0f : c->vox_g;
    }
    v->density_max = c->vox_max;
    v->version = c->version;
    return SQ_OK;
}

sq_result sq_clouds_drawable(sq_clouds *c, sq_drawable *out)
{
    if (c->d.mode == SQ_CLOUDS_MODE_VOLUME) return sq_clouds_volume_drawable(c, out);
    fill_clouds_view(c, out);
    return SQ_OK;
}

int sq__clouds_drawables(sq_clouds *c, sq_drawable *out, int max)
{
    if (max < 1) return 0;
    if (sq_clouds_drawable(c, out) != SQ_OK) return 0;
    if (out->kind == SQ_DRAWABLE_CLOUDS && out->u.clouds.count == 0) return 0;
    return 1;
}

int sq__clouds_metrics(sq_clouds *c, sq_metric *out, int max)
{
    const sq_clouds_stats *s = &c->stats;
    const sq_metric m[] = {
        {"cloud_cover_fraction", s->cover_fraction, "1"},
        {"cloud_top_m", s->cloud_top_m, "m"},
        {"lwp_g_m2", s->lwp_g_m2, "g m-2"},
        {"iwp_g_m2", s->iwp_g_m2, "g m-2"},
        {"clouds", (double)s->clouds, "1"},
        {"particles", (double)s->particles, "1"},
        {"clusters", (double)s->clusters, "1"},
        {"source_time_s", c->d.start_s + c->time_s, "s"},
    };
    int n = 0;
    for (size_t i = 0; i < sizeof m / sizeof m[0] && n < max; i++) out[n++] = m[i];
    return n;
}

int sq__clouds_fields(sq_clouds *c, sq_named_field *out, int max)
{
    if (build_volume(c) != SQ_OK) return 0;
    const sq__cloud_grid *g = &c->field.grid;
    const float e = c->field.exaggeration;
    const sq_vec3 h = sq_v3(c->vox_size.x / (float)c->vn[0], c->vox_size.y / (float)c->vn[1],
                            c->vox_size.z / (float)c->vn[2] / e);
    const sq_vec3 o3 = sq_v3(c->vox_origin.x + 0.5f * h.x, c->vox_origin.y + 0.5f * h.y,
                             c->vox_origin.z / e + 0.5f * h.z);
    const sq_vec3 o2 = sq_v3(g->x0, g->y0, 0.0f), h2 = sq_v3(g->dx, g->dy, 1.0f);
    const struct {
        const char *name, *units, *long_name;
        const float *data;
        bool three_d;
    } list[] = {
        {"cloud_extinction", "m-1", "extinction coefficient of the cloud condensate at 550 nm "
                                    "(with the sub-grid pattern; heights above sea level)",
         c->vox_phys, true},
        {"cloud_condensate", "g m-3", "cloud water + ice + snow mass concentration", c->vox_cond,
         true},
        {"liquid_water_path", "g m-2", "cloud water + rain column", c->map_lwp, false},
        {"ice_water_path", "g m-2", "cloud ice + snow + graupel column", c->map_iwp, false},
        {"cloud_optical_depth", "1", "vertical optical depth of the clouds", c->map_tau, false},
        {"cloud_top_height", "m", "highest cloudy cell, above sea level", c->map_top, false},
        {"cloud_cover", "1", "1 where the column holds a cloudy cell", c->map_cover, false},
    };
    int n = 0;
    for (size_t i = 0; i < sizeof list / sizeof list[0] && n < max; i++) {
        sq_named_field *f = &out[n++];
        memset(f, 0, sizeof *f);
        f->name = list[i].name;
        f->units = list[i].units;
        f->long_name = list[i].long_name;
        f->data = list[i].data;
        if (list[i].three_d) {
            f->nx = c->vn[0];
            f->ny = c->vn[1];
            f->nz = c->vn[2];
            f->origin_m = o3;
            f->spacing_m = h;
        } else {
            f->nx = g->nx;
            f->ny = g->ny;
            f->nz = 1;
            f->origin_m = o2;
            f->spacing_m = h2;
        }
    }
    return n;
}

/* ---- live changes (the plug-in's apply_live, clouds_plugin.c) ---------------------------------
 * Lighting and impostor settings: every frame's drawable carries them; the new version makes the
 * renderer light the particles again (and a volume be voxelised again). */
sq_result sq__clouds_apply_live(sq_clouds *c, const sq_param *table, size_t n,
                                const sq_clouds_desc *desc)
{
    sq_params_copy_live(table, n, &c->d, desc);
    c->version++;
    return SQ_OK;
}
