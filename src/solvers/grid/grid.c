/* grid.c — the MAC-grid fluid solver's lifecycle: desc defaults and validation, memory cost,
 * field views, solid cells, boundary conditions (SPEC §1.12: walls, inflow, outflow, open,
 * periodic; ghost filling and fixed faces), topology (link masks, pins of closed regions,
 * ground distance), diagnostics (finite check, CFL, divergence) and sampling. */
#include <float.h>
#include <stdio.h>
#include <string.h>

#include "solvers/grid/grid_internal.h"
#include "squall/par.h"

#define MOD "grid"

static const char *face_name(int f)
{
    static const char *names[6] = {"SQ_FACE_XMIN", "SQ_FACE_XMAX", "SQ_FACE_YMIN",
                                   "SQ_FACE_YMAX", "SQ_FACE_ZMIN", "SQ_FACE_ZMAX"};
    return f >= 0 && f < 6 ? names[f] : "?";
}

static bool is_wall(sq_boundary b)
{
    return b == SQ_BOUNDARY_FREE_SLIP || b == SQ_BOUNDARY_NO_SLIP || b == SQ_BOUNDARY_INFLOW;
}
static bool is_dirichlet(sq_boundary b)
{
    return b == SQ_BOUNDARY_OUTFLOW || b == SQ_BOUNDARY_OPEN;
}

/* ---- desc ------------------------------------------------------------------------------ */
sq_grid_desc sq_grid_desc_resolve(const sq_grid_desc *desc)
{
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    if (desc) d = *desc;
    for (int f = 0; f < 6; f++)
        if (d.boundary[f] == SQ_BOUNDARY_DEFAULT) d.boundary[f] = SQ_BOUNDARY_FREE_SLIP;
    if (d.pressure == SQ_PRESSURE_DEFAULT) d.pressure = SQ_PRESSURE_MGPCG;
    if (d.jacobi_iterations == 0) d.jacobi_iterations = 40;
    if (d.tolerance == 0.0) d.tolerance = 1e-3;
    if (d.max_iterations == 0) d.max_iterations = 50;
    if (d.smoothing_sweeps == 0) d.smoothing_sweeps = 1;
    if (d.advection == SQ_ADVECT_DEFAULT) d.advection = SQ_ADVECT_MACCORMACK;
    if (d.limiter == SQ_LIMITER_DEFAULT) d.limiter = SQ_LIMITER_REVERT;
    if (d.confinement_max_cells == 0.0) d.confinement_max_cells = 0.25;
    if (d.diffusion_iterations == 0) d.diffusion_iterations = 3;
    return d;
}

static sq_result validate(sq_context *ctx, const sq_grid_desc *d)
{
    const sq_dims n = d->cells;
    if (n.nx < 4 || n.ny < 4 || n.nz < 4)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "cells = %dx%dx%d; every axis needs at least 4", n.nx, n.ny, n.nz);
    if (n.nx > 16384 || n.ny > 16384 || n.nz > 16384 ||
        (double)(n.nx + 3) * (double)(n.ny + 3) * (double)(n.nz + 3) > 2147483647.0)
        return sq__fail(ctx, SQ_ERR_TOO_LARGE, MOD,
                        "cells = %dx%dx%d; at most 16384 per axis and 2^31 samples in all",
                        n.nx, n.ny, n.nz);
    if (!(d->cell_size_m > 0.0) || !isfinite(d->cell_size_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "cell_size_m = %g; must be > 0",
                        d->cell_size_m);
    for (int a = 0; a < 3; a++)
        if (!isfinite(d->origin_m[a]))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "origin_m[%d] = %g; must be finite",
                            a, d->origin_m[a]);
    for (int f = 0; f < 6; f++)
        if (d->boundary[f] < SQ_BOUNDARY_FREE_SLIP || d->boundary[f] > SQ_BOUNDARY_PERIODIC)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "boundary[%s] = %d; not a sq_boundary value", face_name(f),
                            (int)d->boundary[f]);
    for (int a = 0; a < 3; a++) {
        bool p0 = d->boundary[2 * a] == SQ_BOUNDARY_PERIODIC,
             p1 = d->boundary[2 * a + 1] == SQ_BOUNDARY_PERIODIC;
        if (p0 != p1)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                            "boundary[%s] is PERIODIC but boundary[%s] is not; periodic must be "
                            "set on both faces of an axis",
                            face_name(p0 ? 2 * a : 2 * a + 1), face_name(p0 ? 2 * a + 1 : 2 * a));
    }
    if (d->pressure < SQ_PRESSURE_MGPCG || d->pressure > SQ_PRESSURE_JACOBI)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "pressure = %d; not a sq_pressure_solver",
                        (int)d->pressure);
    if (d->jacobi_iterations < 1 || d->jacobi_iterations > 100000)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "jacobi_iterations = %d; must be in 1..100000 (0 = 40)",
                        d->jacobi_iterations);
    if (!(d->tolerance > 0.0 && d->tolerance < 1.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "tolerance = %g; must be in (0, 1) (relative residual; 0 = 1e-3)",
                        d->tolerance);
    if (d->max_iterations < 1 || d->max_iterations > 10000)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "max_iterations = %d; must be in 1..10000 (0 = 50)", d->max_iterations);
    if (d->smoothing_sweeps < 1 || d->smoothing_sweeps > 8)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "smoothing_sweeps = %d; must be in 1..8 (0 = 1)", d->smoothing_sweeps);
    if (d->advection < SQ_ADVECT_MACCORMACK || d->advection > SQ_ADVECT_SEMI_LAGRANGIAN)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "advection = %d; not a sq_advect_scheme",
                        (int)d->advection);
    if (d->limiter < SQ_LIMITER_REVERT || d->limiter > SQ_LIMITER_CLAMP)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "limiter = %d; not a sq_advect_limiter",
                        (int)d->limiter);
    if (d->scalar_count < 0 || d->scalar_count > SQ_GRID_MAX_SCALARS)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "scalar_count = %d; must be in 0..%d",
                        d->scalar_count, SQ_GRID_MAX_SCALARS);
    if (!(d->confinement_max_cells > 0.0 && d->confinement_max_cells <= 10.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "confinement_max_cells = %g; must be in (0, 10] (0 = 0.25)",
                        d->confinement_max_cells);
    if (!(d->wall_roughness_m >= 0.0 && d->wall_roughness_m < 0.5 * d->cell_size_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "wall_roughness_m = %g; must be >= 0 (0 = no-slip) and below half a cell "
                        "(%g m)", d->wall_roughness_m, 0.5 * d->cell_size_m);
    if (!(d->mixing_length_max_m >= 0.0) || !isfinite(d->mixing_length_max_m))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "mixing_length_max_m = %g; must be >= 0 (0 = no cap)",
                        d->mixing_length_max_m);
    if (d->diffusion_iterations < 1 || d->diffusion_iterations > 1000)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD,
                        "diffusion_iterations = %d; must be in 1..1000 (0 = 3)",
                        d->diffusion_iterations);
    return SQ_OK;
}

/* ---- sizes ------------------------------------------------------------------------------- */
static uint64_t padded(int nx, int ny, int nz)
{
    return (uint64_t)(nx + 2) * (uint64_t)(ny + 2) * (uint64_t)(nz + 2);
}

static uint64_t scratch_samples(const int n[3])
{
    uint64_t m = padded(n[0], n[1], n[2]);
    for (int a = 0; a < 3; a++) {
        int e[3] = {n[0], n[1], n[2]};
        e[a]++;
        uint64_t c = padded(e[0], e[1], e[2]);
        if (c > m) m = c;
    }
    return m;
}

static uint64_t inflow_cells(const int n[3], int face)
{
    int a = face / 2;
    return (uint64_t)(a == 0 ? n[1] * n[2] : a == 1 ? n[0] * n[2] : n[0] * n[1]);
}

uint64_t sq_grid_memory_bytes(const sq_grid_desc *desc)
{
    if (!desc) return 0;
    sq_grid_desc d = sq_grid_desc_resolve(desc);
    if (d.cells.nx <= 0 || d.cells.ny <= 0 || d.cells.nz <= 0) return 0;
    const int n[3] = {d.cells.nx, d.cells.ny, d.cells.nz};
    const uint64_t cells = padded(n[0], n[1], n[2]);
    uint64_t b = 0;
    int sc = d.scalar_count > 0 ? d.scalar_count : 0;
    /* velocity and scalars have scratch capacity (advection swaps its output in) */
    b += (uint64_t)(3 + sc) * scratch_samples(n) * sizeof(float);
    b += sq_field3_bytes(d.cells, 1); /* pressure */
    b += cells * (1 + 1 + 1 + 2);                               /* flags, links, diag, below */
    b += (uint64_t)n[0] * (uint64_t)n[1] * (uint64_t)n[2];      /* public solid flags */
    b += (uint64_t)(n[2] + 2) + (uint64_t)(n[2] + 2) * 4 * sizeof(double);
    b += SQ__SCRATCH * scratch_samples(n) * sizeof(float);
    for (int f = 0; f < 6; f++)
        if (d.boundary[f] == SQ_BOUNDARY_INFLOW) b += inflow_cells(n, f) * 3 * sizeof(float);
    b += (uint64_t)sc * sizeof(sq_field3) + sizeof(struct sq_grid);
    b += sq__grid_multigrid_bytes(n);
    return b;
}

/* ---- lifecycle --------------------------------------------------------------------------- */
void sq_grid_destroy(sq_grid *g)
{
    if (!g) return;
    sq_context *ctx = g->ctx;
    for (int a = 0; a < 3; a++) sq_field3_destroy(ctx, &g->vel[a]);
    if (g->scalar) {
        for (int s = 0; s < g->d.scalar_count; s++) sq_field3_destroy(ctx, &g->scalar[s]);
        sq_free(ctx, g->scalar);
    }
    sq_field3_destroy(ctx, &g->p);
    sq_free(ctx, g->flags);
    sq_free(ctx, g->links);
    sq_free(ctx, g->diag);
    sq_free(ctx, g->below);
    sq_free(ctx, g->solid);
    sq_free(ctx, g->plane_solid);
    sq_free(ctx, g->plane_sum);
    for (int s = 4; s < SQ__SCRATCH; s++) sq_free(ctx, g->scratch[s]);
    sq_free(ctx, g->scratch_block);
    for (int f = 0; f < 6; f++) {
        sq_free(ctx, g->inflow[f]);
        for (int i = 0; i < SQ_GRID_MAX_SCALARS; i++) sq_free(ctx, g->scalar_inflow_data[f][i]);
    }
    sq__grid_free_multigrid(g);
    sq__grid_dist_free(ctx, g->halo);
    sq_free(ctx, g);
}

/* A field with one ghost layer whose allocation holds scratch_count floats, so that an
 * advection output buffer (a scratch array) can be swapped in instead of copied. */
static sq_result field_create(sq_grid *g, sq_dims n, sq_field3 *f)
{
    memset(f, 0, sizeof *f);
    float *base = (float *)sq_alloc_zero(g->ctx, g->scratch_count * sizeof(float));
    if (!base) return SQ_ERR_OUT_OF_MEMORY;
    f->base = base;
    f->n = n;
    f->ghost = 1;
    f->sy = n.nx + 2;
    f->sz = f->sy * (ptrdiff_t)(n.ny + 2);
    f->count = (size_t)f->sz * (size_t)(n.nz + 2);
    f->origin = base + 1 + f->sy + f->sz;
    return SQ_OK;
}

sq_result sq_grid_create(sq_context *ctx, const sq_grid_desc *desc, sq_grid **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_grid_create: out is NULL");
    *out = NULL;
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MOD, "sq_grid_create: desc is NULL");
    sq_grid_desc d = sq_grid_desc_resolve(desc);
    sq_result r = validate(ctx, &d);
    if (r != SQ_OK) return r;
    sq__grid_halo *halo = NULL; /* decompose: d becomes this rank's slab (grid_dist.c) */
    r = sq__grid_dist_setup(ctx, &d, &halo);
    if (r != SQ_OK) return r;
    uint64_t bytes = sq_grid_memory_bytes(&d);
    char what[128];
    snprintf(what, sizeof what, "grid %dx%dx%d with %d scalars", d.cells.nx, d.cells.ny,
             d.cells.nz, d.scalar_count);
    r = sq_context_check_memory(ctx, bytes, what);
    sq_grid *g = r == SQ_OK ? (sq_grid *)sq_alloc_zero(ctx, sizeof *g) : NULL;
    if (!g) {
        sq__grid_dist_free(ctx, halo);
        return r != SQ_OK ? r : SQ_ERR_OUT_OF_MEMORY;
    }
    g->halo = halo;
    g->ctx = ctx;
    g->d = d;
    g->n[0] = d.cells.nx;
    g->n[1] = d.cells.ny;
    g->n[2] = d.cells.nz;
    g->h = (float)d.cell_size_m;
    for (int a = 0; a < 3; a++) {
        g->periodic[a] = d.boundary[2 * a] == SQ_BOUNDARY_PERIODIC;
        g->lat_n[a] = g->n[a];
    }

    g->scratch_count = (size_t)scratch_samples(g->n);
    for (int a = 0; a < 3 && r == SQ_OK; a++) {
        sq_dims e = d.cells;
        if (a == 0) e.nx++;
        if (a == 1) e.ny++;
        if (a == 2) e.nz++;
        r = field_create(g, e, &g->vel[a]);
    }
    if (r == SQ_OK) r = sq_field3_create(ctx, d.cells, 1, &g->p);
    if (r == SQ_OK && d.scalar_count > 0) {
        g->scalar = (sq_field3 *)sq_alloc_zero(ctx, sizeof(sq_field3) * (size_t)d.scalar_count);
        if (!g->scalar) r = SQ_ERR_OUT_OF_MEMORY;
        for (int s = 0; s < d.scalar_count && r == SQ_OK; s++)
            r = field_create(g, d.cells, &g->scalar[s]);
    }
    if (g->halo && sq__grid_dist_any(g, r != SQ_OK) && r == SQ_OK) r = SQ_ERR_OUT_OF_MEMORY;
    if (r != SQ_OK) {
        sq_grid_destroy(g);
        return r;
    }
    g->sy = g->p.sy;
    g->sz = g->p.sz;
    g->cell_count = g->p.count;
    const size_t N = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2];
    g->flags = (uint8_t *)sq_alloc_zero(ctx, g->cell_count);
    g->links = (uint8_t *)sq_alloc_zero(ctx, g->cell_count);
    g->diag = (uint8_t *)sq_alloc_zero(ctx, g->cell_count);
    g->below = (uint16_t *)sq_alloc_zero(ctx, g->cell_count * sizeof(uint16_t));
    g->solid = (uint8_t *)sq_alloc_zero(ctx, N);
    g->plane_solid = (uint8_t *)sq_alloc_zero(ctx, (size_t)g->n[2] + 2);
    g->plane_sum = (double *)sq_alloc_zero(ctx, ((size_t)g->n[2] + 2) * 4 * sizeof(double));
    bool ok = g->flags && g->links && g->diag && g->below && g->solid && g->plane_solid &&
              g->plane_sum;
    if (ok) {
        g->scratch_block = (float *)sq_alloc_zero(ctx, 4 * g->scratch_count * sizeof(float));
        ok = g->scratch_block != NULL;
        for (int s = 0; s < 4 && ok; s++) g->scratch[s] = g->scratch_block + s * g->scratch_count;
    }
    for (int s = 4; s < SQ__SCRATCH && ok; s++) {
        g->scratch[s] = (float *)sq_alloc_zero(ctx, g->scratch_count * sizeof(float));
        ok = g->scratch[s] != NULL;
    }
    for (int f = 0; f < 6 && ok; f++) {
        if (d.boundary[f] != SQ_BOUNDARY_INFLOW) continue;
        int a = f / 2;
        g->inflow_n[f][0] = a == 0 ? g->n[1] : g->n[0];
        g->inflow_n[f][1] = a == 2 ? g->n[1] : g->n[2];
        g->inflow[f] = (float *)sq_alloc_zero(ctx, inflow_cells(g->n, f) * 3 * sizeof(float));
        ok = g->inflow[f] != NULL;
    }
    if (g->halo) ok = !sq__grid_dist_any(g, !ok); /* the topology below is collective */
    if (!ok) {
        sq_grid_destroy(g);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    g->topology_dirty = true;
    g->eddy_theta = -1;
    r = sq__grid_update_topology(g);
    if (r != SQ_OK) {
        sq_grid_destroy(g);
        return r;
    }
    char b1[32];
    sq_log(ctx, SQ_LOG_DEBUG, MOD, "grid %dx%dx%d h = %g m, %d scalars, %d multigrid levels, %s",
           g->n[0], g->n[1], g->n[2], d.cell_size_m, d.scalar_count, g->mg_levels,
           sq__format_bytes(bytes, b1));
    *out = g;
    return SQ_OK;
}

sq_grid_info sq_grid_get_info(const sq_grid *g)
{
    sq_grid_info info;
    memset(&info, 0, sizeof info);
    if (!g) return info;
    info.cells = g->d.cells;
    info.cell_size_m = g->d.cell_size_m;
    for (int a = 0; a < 3; a++) info.origin_m[a] = g->d.origin_m[a];
    info.scalar_count = g->d.scalar_count;
    info.memory_bytes = sq_grid_memory_bytes(&g->d);
    info.mg_levels = g->mg_levels;
    return info;
}

sq_grid_desc sq_grid_get_desc(const sq_grid *g)
{
    sq_grid_desc d;
    memset(&d, 0, sizeof d);
    return g ? g->d : d;
}

/* ---- views ------------------------------------------------------------------------------- */
sq_field_view sq_grid_velocity_view(const sq_grid *g, int axis)
{
    sq_field_view v;
    memset(&v, 0, sizeof v);
    if (!g || axis < 0 || axis > 2) return v;
    return sq_field3_view(&g->vel[axis]);
}

sq_field3 *sq_grid_velocity_field(sq_grid *g, int axis)
{
    if (!g || axis < 0 || axis > 2) return NULL;
    g->vel_version++;
    return &g->vel[axis];
}

sq_field_view sq_grid_scalar_view(const sq_grid *g, int idx)
{
    sq_field_view v;
    memset(&v, 0, sizeof v);
    if (!g || idx < 0 || idx >= g->d.scalar_count) return v;
    return sq_field3_view(&g->scalar[idx]);
}

sq_field3 *sq_grid_scalar_field(sq_grid *g, int idx)
{
    if (!g || idx < 0 || idx >= g->d.scalar_count) return NULL;
    return &g->scalar[idx];
}

sq_field_view sq_grid_pressure_view(const sq_grid *g)
{
    sq_field_view v;
    memset(&v, 0, sizeof v);
    if (!g) return v;
    return sq_field3_view(&g->p);
}

const uint8_t *sq_grid_solid(const sq_grid *g) { return g ? g->solid : NULL; }

/* ---- solids ------------------------------------------------------------------------------ */
sq_result sq_grid_set_solid(sq_grid *g, int i, int j, int k, bool solid)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_solid: grid is NULL");
    if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2])
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "solid cell (%d,%d,%d) is outside the grid %dx%dx%d", i, j, k, g->n[0],
                        g->n[1], g->n[2]);
    uint8_t *s = &g->solid[(size_t)i + (size_t)g->n[0] * ((size_t)j + (size_t)g->n[1] * k)];
    uint8_t v = solid ? 1 : 0;
    if (*s != v) {
        *s = v;
        g->topology_dirty = true;
    }
    return SQ_OK;
}

sq_result sq_grid_set_solid_mask(sq_grid *g, const uint8_t *mask)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_solid_mask: grid is NULL");
    const size_t N = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2];
    for (size_t c = 0; c < N; c++) g->solid[c] = mask && mask[c] ? 1 : 0;
    g->topology_dirty = true;
    return SQ_OK;
}

bool sq_grid_is_solid(const sq_grid *g, int i, int j, int k)
{
    if (!g || i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2])
        return false;
    return g->solid[(size_t)i + (size_t)g->n[0] * ((size_t)j + (size_t)g->n[1] * k)] != 0;
}

/* ---- inflow ------------------------------------------------------------------------------ */
static sq_result check_inflow_face(sq_grid *g, sq_grid_face face)
{
    if ((int)face < 0 || (int)face > 5)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "inflow face = %d; must be 0..5",
                        (int)face);
    if (!g->inflow[face])
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "inflow on %s: its boundary is not SQ_BOUNDARY_INFLOW", face_name(face));
    return SQ_OK;
}

sq_result sq_grid_set_inflow(sq_grid *g, sq_grid_face face, sq_grid_inflow_fn fn, void *user)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_inflow: grid is NULL");
    sq_result r = check_inflow_face(g, face);
    if (r != SQ_OK) return r;
    if (!fn) return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "inflow on %s: fn is NULL",
                             face_name(face));
    const int a = face / 2, side = face % 2;
    const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
    const int na = g->inflow_n[face][0], nb = g->inflow_n[face][1];
    const double h = g->d.cell_size_m;
    for (int q = 0; q < nb; q++)
        for (int p = 0; p < na; p++) {
            double x[3];
            x[a] = side ? g->n[a] * h : 0.0;
            x[ta] = (p + 0.5) * h;
            x[tb] = (q + 0.5) * h;
            float v[3] = {0, 0, 0};
            fn(user, g->d.origin_m[0] + x[0], g->d.origin_m[1] + x[1], g->d.origin_m[2] + x[2],
               v);
            float *o = g->inflow[face] + 3 * ((size_t)p + (size_t)na * (size_t)q);
            for (int c = 0; c < 3; c++) {
                if (!isfinite(v[c]))
                    return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                                    "inflow on %s at boundary cell (%d,%d): component %d = %g; "
                                    "must be finite",
                                    face_name(face), p, q, c, (double)v[c]);
                o[c] = v[c];
            }
        }
    g->vel_version++;
    return SQ_OK;
}

sq_result sq_grid_set_inflow_uniform(sq_grid *g, sq_grid_face face, double vx, double vy,
                                     double vz)
{
    if (!g)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_inflow_uniform: grid is NULL");
    sq_result r = check_inflow_face(g, face);
    if (r != SQ_OK) return r;
    if (!isfinite(vx) || !isfinite(vy) || !isfinite(vz))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "inflow on %s = (%g, %g, %g) m/s; must be finite", face_name(face), vx, vy,
                        vz);
    const size_t m = (size_t)g->inflow_n[face][0] * (size_t)g->inflow_n[face][1];
    for (size_t c = 0; c < m; c++) {
        g->inflow[face][3 * c] = (float)vx;
        g->inflow[face][3 * c + 1] = (float)vy;
        g->inflow[face][3 * c + 2] = (float)vz;
    }
    g->vel_version++;
    return SQ_OK;
}

float *sq_grid_inflow_data(sq_grid *g, sq_grid_face face, int *na, int *nb)
{
    if (na) *na = 0;
    if (nb) *nb = 0;
    if (!g || (int)face < 0 || (int)face > 5 || !g->inflow[face]) return NULL;
    if (na) *na = g->inflow_n[face][0];
    if (nb) *nb = g->inflow_n[face][1];
    g->vel_version++;
    return g->inflow[face];
}

sq_result sq_grid_set_scalar_inflow(sq_grid *g, int idx, double value)
{
    if (!g)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_set_scalar_inflow: grid is NULL");
    if (idx < 0 || idx >= g->d.scalar_count)
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD,
                        "scalar idx = %d; must be in 0..%d (scalar_count = %d)", idx,
                        g->d.scalar_count - 1, g->d.scalar_count);
    if (!isfinite(value))
        return sq__fail(g->ctx, SQ_ERR_INVALID_ARG, MOD, "scalar %d inflow value = %g; must be "
                        "finite", idx, value);
    g->scalar_inflow[idx] = (float)value;
    for (int f = 0; f < 6; f++)
        if (g->scalar_inflow_data[f][idx]) {
            const size_t m = (size_t)g->inflow_n[f][0] * (size_t)g->inflow_n[f][1];
            for (size_t c = 0; c < m; c++) g->scalar_inflow_data[f][idx][c] = (float)value;
        }
    return SQ_OK;
}

float *sq_grid_scalar_inflow_data(sq_grid *g, sq_grid_face face, int idx, int *na, int *nb)
{
    if (na) *na = 0;
    if (nb) *nb = 0;
    if (!g || (int)face < 0 || (int)face > 5 || !g->inflow[face] || idx < 0 ||
        idx >= g->d.scalar_count)
        return NULL;
    const size_t m = (size_t)g->inflow_n[face][0] * (size_t)g->inflow_n[face][1];
    if (!g->scalar_inflow_data[face][idx]) {
        float *a = (float *)sq_alloc(g->ctx, m * sizeof(float));
        if (!a) return NULL;
        for (size_t c = 0; c < m; c++) a[c] = g->scalar_inflow[idx];
        g->scalar_inflow_data[face][idx] = a;
    }
    if (na) *na = g->inflow_n[face][0];
    if (nb) *nb = g->inflow_n[face][1];
    return g->scalar_inflow_data[face][idx];
}

/* ---- ghosts ------------------------------------------------------------------------------ */
static void lattice_dims(const sq_grid *g, int L, int m[3])
{
    for (int a = 0; a < 3; a++) m[a] = g->n[a] + (L - 1 == a ? 1 : 0);
}

enum { GH_COPY, GH_NEG, GH_EXTRAP, GH_CONST, GH_INFLOW, GH_PERIODIC };

/* How one face's ghosts are filled (see sq__grid_fill_ghosts). */
typedef struct ghost_face {
    int f, a, ta, tb, mode;
    ptrdiff_t gi, bi, ii, src;
    float cv;
    const float *cva; /* GH_CONST: per-sample values (na*nb, a fastest) or NULL: cv */
} ghost_face;

/* Fills the ghosts of rows q of one face (q over the second tangential axis). */
static void fill_face_row(const sq_grid *g, float *o, const ptrdiff_t st[3], const int m[3],
                          int L, const ghost_face *gf, int q)
{
    const int ta = gf->ta, tb = gf->tb, f = gf->f;
    const ptrdiff_t gi = gf->gi, bi = gf->bi, ii = gf->ii, src = gf->src;
    float *row = o + (ptrdiff_t)q * st[tb];
    const ptrdiff_t sp = st[ta];
    switch (gf->mode) {
    case GH_PERIODIC:
    case GH_COPY:
        for (int p = -1; p <= m[ta]; p++) row[p * sp + gi] = row[p * sp + src];
        break;
    case GH_NEG:
        for (int p = -1; p <= m[ta]; p++) row[p * sp + gi] = -row[p * sp + bi];
        break;
    case GH_EXTRAP:
        for (int p = -1; p <= m[ta]; p++) row[p * sp + gi] = 2.0f * row[p * sp + bi] - row[p * sp + ii];
        break;
    case GH_CONST:
        if (gf->cva) { /* the face sample nearest to the ghost (edges take the edge value) */
            const int na = g->inflow_n[f][0], nb = g->inflow_n[f][1];
            const float *src_row = gf->cva + (size_t)na * (size_t)sq_clampi(q, 0, nb - 1);
            for (int p = -1; p <= m[ta]; p++) row[p * sp + gi] = src_row[sq_clampi(p, 0, na - 1)];
        } else {
            for (int p = -1; p <= m[ta]; p++) row[p * sp + gi] = gf->cv;
        }
        break;
    default: { /* tangential velocity against an inflow face: the inflow value at the ghost
                * sample (tangential lattice indices (p, q) clamped to the face; a component's
                * own axis averages its two adjacent boundary cells), mirrored through the face */
        const int qc = sq_clampi(q, 0, m[tb]);
        const int na = g->inflow_n[f][0], nb = g->inflow_n[f][1];
        const int q0 = sq_clampi(L - 1 == tb ? qc - 1 : qc, 0, nb - 1);
        const int q1 = sq_clampi(qc, 0, nb - 1);
        const float *d0 = g->inflow[f] + 3 * (size_t)na * (size_t)q0 + (L - 1);
        const float *d1 = g->inflow[f] + 3 * (size_t)na * (size_t)q1 + (L - 1);
        const int sh = L - 1 == ta ? 1 : 0;
        for (int p = -1; p <= m[ta]; p++) {
            const int pc = sq_clampi(p, 0, m[ta]);
            const int p0 = sq_clampi(pc - sh, 0, na - 1), p1 = sq_clampi(pc, 0, na - 1);
            const float v = 0.25f * (d0[3 * p0] + d0[3 * p1] + d1[3 * p0] + d1[3 * p1]);
            row[p * sp + gi] = 2.0f * v - row[p * sp + bi];
        }
    } break;
    }
}

void sq__grid_fill_ghosts(sq_grid *g, float *o, ptrdiff_t sy, ptrdiff_t sz, int L, int scalar)
{
    sq__grid_fill_ghosts_local(g, o, sy, sz, L, scalar);
    /* a decomposed grid: the ghost planes toward the neighbouring slabs are their samples */
    sq__grid_dist_halo_lattice(g, o, sy, sz, L);
}

void sq__grid_fill_ghosts_local(sq_grid *g, float *o, ptrdiff_t sy, ptrdiff_t sz, int L, int scalar)
{
    int m[3];
    lattice_dims(g, L, m);
    const ptrdiff_t st[3] = {1, sy, sz};
    ghost_face gf[6];
    int work = 0;
    for (int a = 0; a < 3; a++) {
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        const bool normal = L - 1 == a;
        for (int side = 0; side < 2; side++) {
            const int f = 2 * a + side;
            ghost_face *e = &gf[f];
            const sq_boundary bc = g->d.boundary[f];
            e->f = f;
            e->a = a;
            e->ta = ta;
            e->tb = tb;
            e->gi = (side ? m[a] : -1) * st[a];    /* ghost */
            e->bi = (side ? m[a] - 1 : 0) * st[a]; /* boundary sample */
            e->ii = (side ? m[a] - 2 : 1) * st[a]; /* next inward */
            e->src = e->bi;
            e->cv = 0.0f;
            e->cva = NULL;
            if (bc == SQ_BOUNDARY_PERIODIC) {
                e->mode = GH_PERIODIC;
                e->src = (normal ? (side ? 1 : m[a] - 2) : (side ? 0 : m[a] - 1)) * st[a];
            } else if (normal) {
                e->mode = is_wall(bc) ? GH_EXTRAP : GH_COPY;
            } else if (L == SQ__L_CELL) {
                e->mode = (bc == SQ_BOUNDARY_INFLOW && scalar >= 0) ? GH_CONST : GH_COPY;
                if (e->mode == GH_CONST) {
                    e->cv = g->scalar_inflow[scalar];
                    e->cva = g->scalar_inflow_data[f][scalar];
                }
            } else {
                e->mode = bc == SQ_BOUNDARY_NO_SLIP ? GH_NEG
                          : bc == SQ_BOUNDARY_INFLOW ? GH_INFLOW
                                                     : GH_COPY;
            }
            work += (m[ta] + 2) * (m[tb] + 2);
        }
    }
    /* faces in order (later faces overwrite the edges and corners of earlier ones): one
     * parallel region, a worksharing loop per face with its barrier */
    const int nt = work > 16384 ? sq_context_threads(g->ctx) : 1;
    (void)nt; /* unused without OpenMP */
    SQ_OMP(omp parallel num_threads(nt))
    for (int f = 0; f < 6; f++) {
        const int tb = gf[f].tb;
        SQ_OMP(omp for schedule(static))
        for (int q = -1; q <= m[tb]; q++) fill_face_row(g, o, st, m, L, &gf[f], q);
    }
}

/* ---- fixed faces --------------------------------------------------------------------------- */
void sq__grid_enforce_velocity_ex(sq_grid *g, bool clip_backflow)
{
    const uint8_t *fl = g->flags;
    const int nt = sq_context_threads(g->ctx);
    (void)nt;
    sq__grid_dist_batch_begin(g); /* the three components' ghost planes in one message */
    for (int c = 0; c < 3; c++) {
        sq_field3 *f = &g->vel[c];
        const ptrdiff_t off = c == 0 ? 1 : c == 1 ? g->sy : g->sz; /* cell lo -> hi */
        int m[3];
        lattice_dims(g, c + 1, m);
        /* faces touching solid cells: only planes that contain solids */
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < m[2]; k++) {
            bool any = g->plane_solid[k + 1] || (c == 2 && g->plane_solid[k]);
            if (!any) continue;
            for (int j = 0; j < m[1]; j++) {
                float *u = sq_field3_at(f, 0, j, k);
                const uint8_t *fh = fl + sq__cidx(g, 0, j, k), *fo = fh - off;
                for (int i = 0; i < m[0]; i++)
                    u[i] = sq__fsel(((fo[i] | fh[i]) & SQ__CF_SOLID) != 0, 0.0f, u[i]);
            }
        }
        /* the two domain faces normal to c (open faces, and outflow faces unless backflow is
         * clipped, keep their values; faces of solid cells were zeroed above) */
        for (int side = 0; side < 2; side++) {
            const int face = 2 * c + side;
            const sq_boundary bc = g->d.boundary[face];
            if (bc == SQ_BOUNDARY_OPEN || (bc == SQ_BOUNDARY_OUTFLOW && !clip_backflow)) continue;
            const int ta = c == 0 ? 1 : 0, tb = c == 2 ? 1 : 2;
            const ptrdiff_t fst[3] = {1, f->sy, f->sz}, cst[3] = {1, g->sy, g->sz};
            /* face sample (p, q): f at bi along c; the inner cell is bi - side along c */
            float *const u0 = f->origin + (ptrdiff_t)(side ? g->n[c] : 0) * fst[c];
            const uint8_t *const c0 =
                fl + sq__cidx(g, 0, 0, 0) + (ptrdiff_t)(side ? g->n[c] - 1 : 0) * cst[c];
            const float *const u_side0 = f->origin; /* periodic: copy from the face at 0 */
            const float *const inflow = g->inflow[face];
            const int na = g->inflow_n[face][0];
            for (int q = 0; q < g->n[tb]; q++)
                for (int p = 0; p < g->n[ta]; p++) {
                    const ptrdiff_t fo = (ptrdiff_t)p * fst[ta] + (ptrdiff_t)q * fst[tb];
                    float *u = u0 + fo;
                    const bool inner_solid =
                        (c0[(ptrdiff_t)p * cst[ta] + (ptrdiff_t)q * cst[tb]] & SQ__CF_SOLID) != 0;
                    if (bc == SQ_BOUNDARY_PERIODIC) {
                        if (side) *u = u_side0[fo];
                    } else if (inner_solid) {
                        *u = 0.0f;
                    } else if (bc == SQ_BOUNDARY_INFLOW) {
                        *u = inflow[3 * ((size_t)p + (size_t)na * (size_t)q) + c];
                    } else if (bc == SQ_BOUNDARY_OUTFLOW) {
                        if (side == 0 && *u > 0.0f) *u = 0.0f;
                        if (side == 1 && *u < 0.0f) *u = 0.0f;
                    } else {
                        *u = 0.0f;
                    }
                }
        }
        sq__grid_fill_ghosts(g, f->origin, f->sy, f->sz, c + 1, -1);
    }
    sq__grid_dist_batch_end(g);
}

void sq_grid_apply_boundary(sq_grid *g)
{
    if (!g) return;
    if (g->topology_dirty) sq__grid_update_topology(g);
    sq__grid_dist_batch_begin(g);
    sq__grid_enforce_velocity(g);
    for (int s = 0; s < g->d.scalar_count; s++)
        sq__grid_fill_ghosts(g, g->scalar[s].origin, g->sy, g->sz, SQ__L_CELL, s);
    sq__grid_dist_batch_end(g);
    g->vel_version++;
}

/* ---- topology ------------------------------------------------------------------------------ */
static uint8_t ghost_flag(sq_boundary bc)
{
    return is_wall(bc) ? SQ__CF_WALL : is_dirichlet(bc) ? SQ__CF_DIRICHLET : 0;
}

static void build_flags(sq_grid *g)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    uint8_t *fl = g->flags;
    memset(fl, 0, g->cell_count);
    memset(g->plane_solid, 0, (size_t)nz + 2);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                if (g->solid[(size_t)i + (size_t)nx * ((size_t)j + (size_t)ny * k)]) {
                    fl[sq__cidx(g, i, j, k)] = SQ__CF_SOLID;
                    g->plane_solid[k + 1] = 1;
                }
    const ptrdiff_t st[3] = {1, g->sy, g->sz};
    for (int a = 0; a < 3; a++) {
        const int ta = a == 0 ? 1 : 0, tb = a == 2 ? 1 : 2;
        for (int side = 0; side < 2; side++) {
            const sq_boundary bc = g->d.boundary[2 * a + side];
            const int gi = side ? g->n[a] : -1;
            for (int q = -1; q <= g->n[tb]; q++)
                for (int p = -1; p <= g->n[ta]; p++) {
                    ptrdiff_t t = sq__cidx(g, 0, 0, 0) + (ptrdiff_t)p * st[ta] +
                                  (ptrdiff_t)q * st[tb];
                    uint8_t v;
                    if (bc == SQ_BOUNDARY_PERIODIC)
                        v = fl[t + (ptrdiff_t)(side ? 0 : g->n[a] - 1) * st[a]];
                    else
                        v = ghost_flag(bc);
                    /* corners keep the strongest flag already there */
                    uint8_t *gv = &fl[t + (ptrdiff_t)gi * st[a]];
                    if (p < 0 || q < 0 || p >= g->n[ta] || q >= g->n[tb])
                        *gv = (uint8_t)(*gv | v);
                    else
                        *gv = v;
                }
        }
    }
    /* inner faces of a decomposed grid: the neighbouring slab's flags */
    sq__grid_halo_cells(g, fl, 1);
    /* periodic solid planes */
    if (g->periodic[2]) {
        g->plane_solid[0] = g->plane_solid[nz];
        g->plane_solid[nz + 1] = g->plane_solid[1];
    }
}

static void build_links(sq_grid *g)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const uint8_t *fl = g->flags;
    const ptrdiff_t st[3] = {1, g->sy, g->sz};
    memset(g->links, 0, g->cell_count);
    memset(g->diag, 0, g->cell_count);
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                ptrdiff_t c = sq__cidx(g, i, j, k);
                if (fl[c] & SQ__CF_SOLID) continue;
                int bits = 0, diag = 0;
                for (int a = 0; a < 3; a++) {
                    int lo = sq__link_coef(fl[c - st[a]], fl[c]);
                    int hi = sq__link_coef(fl[c], fl[c + st[a]]);
                    if (lo == 1) bits |= 1 << (2 * a);
                    if (hi == 1) bits |= 1 << (2 * a + 1);
                    diag += lo + hi;
                }
                g->links[c] = (uint8_t)bits;
                g->diag[c] = (uint8_t)diag;
            }
}

/* Neighbour of padded cell (i,j,k) across link bit l, wrapping periodic axes. */
static ptrdiff_t link_neighbour(const sq_grid *g, int i, int j, int k, int l)
{
    int x[3] = {i, j, k};
    int a = l / 2;
    x[a] += (l & 1) ? 1 : -1;
    if (x[a] < 0) x[a] += g->n[a];
    if (x[a] >= g->n[a]) x[a] -= g->n[a];
    return sq__cidx(g, x[0], x[1], x[2]);
}

/* Every connected fluid region without a p = 0 face gets one pinned cell (diag + 1), which
 * makes the Poisson matrix definite; for a compatible right-hand side the pinned solution is
 * exact (the pinned cell's pressure comes out 0). */
static void pin_closed_regions(sq_grid *g)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    int32_t *label = (int32_t *)(void *)g->scratch[0];
    int32_t *queue = (int32_t *)(void *)g->scratch[1];
    memset(label, 0, g->cell_count * sizeof(int32_t));
    g->pins = 0;
    int comp = 0;
    for (int k0 = 0; k0 < nz; k0++)
        for (int j0 = 0; j0 < ny; j0++)
            for (int i0 = 0; i0 < nx; i0++) {
                ptrdiff_t c0 = sq__cidx(g, i0, j0, k0);
                if ((g->flags[c0] & SQ__CF_SOLID) || label[c0]) continue;
                comp++;
                size_t head = 0, tail = 0;
                queue[tail++] = (int32_t)c0;
                label[c0] = comp;
                bool open = false;
                while (head < tail) {
                    ptrdiff_t c = queue[head++];
                    int links = g->links[c];
                    int nlinks = 0;
                    for (int l = 0; l < 6; l++) nlinks += (links >> l) & 1;
                    if (g->diag[c] > nlinks) open = true; /* a Dirichlet link */
                    ptrdiff_t rem = c;
                    int kk = (int)(rem / g->sz) - 1;
                    rem %= g->sz;
                    int jj = (int)(rem / g->sy) - 1;
                    int ii = (int)(rem % g->sy) - 1;
                    for (int l = 0; l < 6; l++) {
                        if (!((links >> l) & 1)) continue;
                        const int xl[3] = {ii, jj, kk};
                        if (sq__grid_dist_inner(g, l) && xl[l / 2] == ((l & 1) ? g->n[l / 2] - 1 : 0)) {
                            open = true; /* continues in the neighbouring slab */
                            continue;
                        }
                        ptrdiff_t nb = link_neighbour(g, ii, jj, kk, l);
                        if (!label[nb]) {
                            label[nb] = comp;
                            queue[tail++] = (int32_t)nb;
                        }
                    }
                }
                if (!open) {
                    g->diag[c0]++;
                    g->links[c0] |= 0x40; /* bit 6: pinned */
                    g->pins++;
                }
            }
}

static void build_ground_distance(sq_grid *g)
{
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    const sq_boundary bottom = g->d.boundary[SQ_FACE_ZMIN];
    const bool ground = bottom == SQ_BOUNDARY_FREE_SLIP || bottom == SQ_BOUNDARY_NO_SLIP;
    memset(g->below, 0, g->cell_count * sizeof(uint16_t));
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int last = ground ? -1 : -100000;
            for (int k = 0; k < nz; k++) {
                ptrdiff_t c = sq__cidx(g, i, j, k);
                if (g->flags[c] & SQ__CF_SOLID) {
                    last = k;
                    continue;
                }
                int d = k - last;
                g->below[c] = (uint16_t)(last < -1 ? 0 : (d > 65535 ? 65535 : d));
            }
        }
}

sq_result sq__grid_update_topology(sq_grid *g)
{
    if (!g->topology_dirty) return SQ_OK;
    build_flags(g);
    build_links(g);
    pin_closed_regions(g);
    build_ground_distance(g);
    g->has_dirichlet = false;
    for (int f = 0; f < 6; f++)
        if (is_dirichlet(g->d.boundary[f])) g->has_dirichlet = true;
    sq_result r = sq__grid_build_multigrid(g);
    if (r != SQ_OK) return r;
    /* pressure in solids is 0, scalars keep their values */
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++)
                if (g->flags[sq__cidx(g, i, j, k)] & SQ__CF_SOLID) *sq_field3_at(&g->p, i, j, k) = 0;
    g->topology_dirty = false;
    g->trace_valid = false;
    g->vel_version++;
    sq_log(g->ctx, SQ_LOG_DEBUG, MOD, "topology rebuilt: %d closed region(s) pinned", g->pins);
    return SQ_OK;
}

double sq__grid_sum_planes(const sq_grid *g, int slot)
{
    double s = 0.0;
    for (int k = 0; k < g->n[2]; k++) s += g->plane_sum[4 * k + slot];
    return s;
}

/* ---- diagnostics ---------------------------------------------------------------------------- */
static double local_max_speed(const sq_grid *g);

static const char *vel_name(int c) { return c == 0 ? "u (x-face)" : c == 1 ? "v (y-face)" : "w (z-face)"; }

/* First sample of row j of plane k of f outside the finite range (|v| <= lim fails: NaN,
 * infinities, or beyond lim), or -1; vectorisable test first, position only when bad. */
static int row_first_bad(const sq_field3 *f, int j, int k, float lim)
{
    const float *row = sq_field3_at(f, 0, j, k);
    const int mx = f->n.nx;
    int bad = 0;
    for (int i = 0; i < mx; i++) bad |= !(fabsf(row[i]) <= lim);
    if (!bad) return -1;
    for (int i = 0; i < mx; i++)
        if (!(fabsf(row[i]) <= lim)) return i;
    return -1;
}

static sq_result check_finite_local(sq_grid *g, int64_t step)
{
    int n0[3], lo[3]; /* a decomposed grid names the cell by its global index */
    sq__grid_dist_frame(g, n0, lo);
    const int nt = sq_context_threads(g->ctx);
    (void)nt; /* unused without OpenMP */
    const int nfields = 3 + g->d.scalar_count + 1;
    for (int fi = 0; fi < nfields; fi++) {
        const sq_field3 *f = fi < 3 ? &g->vel[fi] : fi < nfields - 1 ? &g->scalar[fi - 3] : &g->p;
        const bool is_vel = fi < 3;
        const float lim = is_vel ? 1e8f : FLT_MAX;
        const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
        int64_t *first = (int64_t *)(void *)g->plane_sum; /* per plane: first bad index or -1 */
        SQ_OMP(omp parallel for schedule(static) num_threads(nt))
        for (int k = 0; k < mz; k++) {
            int64_t bad = -1;
            for (int j = 0; j < my && bad < 0; j++) {
                const int i = row_first_bad(f, j, k, lim);
                if (i >= 0) bad = (int64_t)i + (int64_t)mx * j;
            }
            first[k] = bad;
        }
        for (int k = 0; k < mz; k++) {
            if (first[k] < 0) continue;
            int i = (int)(first[k] % mx), j = (int)(first[k] / mx);
            float v = *sq_field3_at(f, i, j, k);
            char name[64];
            if (is_vel)
                snprintf(name, sizeof name, "%s", vel_name(fi));
            else if (fi < nfields - 1)
                snprintf(name, sizeof name, "scalar %d", fi - 3);
            else
                snprintf(name, sizeof name, "pressure");
            double vmax = local_max_speed(g); /* this rank alone fails here: not collective */
            memset(g->plane_sum, 0, ((size_t)g->n[2] + 2) * 4 * sizeof(double));
            return sq__fail(g->ctx, SQ_ERR_UNSTABLE, MOD,
                            "step %lld: %s at (%d,%d,%d) is %g (%s); the largest finite speed is "
                            "%g m/s; reduce dt (CFL 1 needs dt <= %g s) or check the forcing",
                            (long long)step, name, i + lo[0], j + lo[1], k + lo[2], (double)v,
                            isfinite(v) ? "exceeds 1e8 m/s" : "non-finite", vmax,
                            vmax > 0 ? g->d.cell_size_m / vmax : 1e30);
        }
    }
    memset(g->plane_sum, 0, ((size_t)g->n[2] + 2) * 4 * sizeof(double));
    return SQ_OK;
}

sq_result sq_grid_check_finite(sq_grid *g, int64_t step)
{
    if (!g) return sq__fail(NULL, SQ_ERR_INVALID_ARG, MOD, "sq_grid_check_finite: grid is NULL");
    const sq_result r = check_finite_local(g, step);
    /* a decomposed grid: collective, the lowest failing slab's message on every rank */
    return g->halo ? sq_par_agree(r) : r;
}

double sq_grid_max_speed(const sq_grid *g)
{
    if (!g) return 0.0;
    double m = local_max_speed(g);
    sq__grid_dist_max(g, &m, 1); /* a decomposed grid: the largest over the ranks */
    return m;
}

static double local_max_speed(const sq_grid *g)
{
    float m = 0.0f;
    const int nt = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2] > 32768
                       ? sq_context_threads(g->ctx)
                       : 1;
    (void)nt;
    for (int c = 0; c < 3; c++) {
        const sq_field3 *f = &g->vel[c];
        const int mx = f->n.nx, my = f->n.ny, mz = f->n.nz;
        SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(max : m))
        for (int k = 0; k < mz; k++)
            for (int j = 0; j < my; j++) {
                const float *row = sq_field3_at(f, 0, j, k);
                /* |v| as its bit pattern: integer order = float order for non-negative
                 * values, and >= 0x7f800000 for infinities and NaN (skipped) */
                int32_t rm = 0;
                for (int i = 0; i < mx; i++) {
                    int32_t b;
                    memcpy(&b, &row[i], sizeof b);
                    b &= 0x7fffffff;
                    b = b < 0x7f800000 ? b : 0;
                    rm = b > rm ? b : rm;
                }
                float a;
                memcpy(&a, &rm, sizeof a);
                m = a > m ? a : m;
            }
    }
    return (double)m;
}

double sq_grid_cfl_dt(const sq_grid *g, double cfl)
{
    double v = sq_grid_max_speed(g);
    if (!g || !(v > 0.0)) return 1e30;
    return cfl * g->d.cell_size_m / v;
}

double sq_grid_divergence_max(const sq_grid *g)
{
    if (!g) return 0.0;
    const int nx = g->n[0], ny = g->n[1], nz = g->n[2];
    double m = 0.0;
    for (int k = 0; k < nz; k++)
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                if (g->flags[sq__cidx(g, i, j, k)] & SQ__CF_SOLID) continue;
                double d = (double)*sq_field3_at(&g->vel[0], i + 1, j, k) -
                           (double)*sq_field3_at(&g->vel[0], i, j, k) +
                           (double)*sq_field3_at(&g->vel[1], i, j + 1, k) -
                           (double)*sq_field3_at(&g->vel[1], i, j, k) +
                           (double)*sq_field3_at(&g->vel[2], i, j, k + 1) -
                           (double)*sq_field3_at(&g->vel[2], i, j, k);
                d = fabs(d);
                if (d > m) m = d;
            }
    sq__grid_dist_max(g, &m, 1);
    return m / g->d.cell_size_m;
}

sq_vec3 sq_grid_sample_velocity(const sq_grid *g, sq_vec3 p)
{
    sq_vec3 r = {0, 0, 0};
    if (!g) return r;
    const float ih = 1.0f / g->h;
    float X = (p.x - (float)g->d.origin_m[0]) * ih, Y = (p.y - (float)g->d.origin_m[1]) * ih,
          Z = (p.z - (float)g->d.origin_m[2]) * ih;
    X = sq_clampf(X, 0.0f, (float)g->n[0]);
    Y = sq_clampf(Y, 0.0f, (float)g->n[1]);
    Z = sq_clampf(Z, 0.0f, (float)g->n[2]);
    float v[3];
    for (int c = 0; c < 3; c++)
        v[c] = sq__grid_interp(g, g->vel[c].origin, g->vel[c].sy, g->vel[c].sz, c + 1, X, Y, Z);
    r.x = v[0];
    r.y = v[1];
    r.z = v[2];
    return r;
}

float sq_grid_sample_scalar(const sq_grid *g, int idx, sq_vec3 p)
{
    if (!g || idx < 0 || idx >= g->d.scalar_count) return 0.0f;
    const float ih = 1.0f / g->h;
    float X = (p.x - (float)g->d.origin_m[0]) * ih, Y = (p.y - (float)g->d.origin_m[1]) * ih,
          Z = (p.z - (float)g->d.origin_m[2]) * ih;
    X = sq_clampf(X, 0.5f, (float)g->n[0] - 0.5f);
    Y = sq_clampf(Y, 0.5f, (float)g->n[1] - 0.5f);
    Z = sq_clampf(Z, 0.5f, (float)g->n[2] - 0.5f);
    const sq_field3 *f = &g->scalar[idx];
    return sq__grid_interp(g, f->origin, f->sy, f->sz, SQ__L_CELL, X, Y, Z);
}

sq_vec3 sq_grid_cell_velocity(const sq_grid *g, int i, int j, int k)
{
    sq_vec3 r = {0, 0, 0};
    if (!g || i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2]) return r;
    r.x = 0.5f * (*sq_field3_at(&g->vel[0], i, j, k) + *sq_field3_at(&g->vel[0], i + 1, j, k));
    r.y = 0.5f * (*sq_field3_at(&g->vel[1], i, j, k) + *sq_field3_at(&g->vel[1], i, j + 1, k));
    r.z = 0.5f * (*sq_field3_at(&g->vel[2], i, j, k) + *sq_field3_at(&g->vel[2], i, j, k + 1));
    return r;
}

void sq_grid_get_stats(const sq_grid *g, sq_grid_stats *out)
{
    if (!out) return;
    memset(out, 0, sizeof *out);
    if (!g) return;
    *out = g->stats;
    out->mg_levels = g->mg_levels;
}

void sq_grid_stats_reset(sq_grid *g)
{
    if (!g) return;
    memset(&g->stats, 0, sizeof g->stats);
}
