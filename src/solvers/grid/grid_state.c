/* grid_state.c — the grid solver's part of a checkpoint (issue 17 part 4): velocity, scalars and
 * pressure (whole allocations, ghost layers included; the pressure is the next projection's
 * starting guess), the inflow profiles and scalar inflow values (constant and per sample), the solid flags and the last
 * projection's dt. The cached trace displacements are dropped: they are a function of the
 * velocity and are recomputed bit-identically; the solid topology is rebuilt from the flags. */
#include <string.h>

#include "grid_internal.h"

static size_t inflow_floats(const sq_grid *g, int f)
{
    return (size_t)g->inflow_n[f][0] * (size_t)g->inflow_n[f][1] * 3;
}

sq_result sq_grid_save_state(const sq_grid *g, sq_state_writer *w)
{
    if (!g || !w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_grid_save_state: NULL argument");
    const int32_t dims[4] = {g->n[0], g->n[1], g->n[2], g->d.scalar_count};
    sq_state_put(w, "grid/dims", dims, sizeof dims);
    for (int a = 0; a < 3; a++)
        sq_state_put(w, "grid/vel", g->vel[a].base, g->vel[a].count * sizeof(float));
    for (int i = 0; i < g->d.scalar_count; i++)
        sq_state_put(w, "grid/scalar", g->scalar[i].base, g->scalar[i].count * sizeof(float));
    sq_state_put(w, "grid/p", g->p.base, g->p.count * sizeof(float));
    sq_state_put(w, "grid/scalar_inflow", g->scalar_inflow, sizeof g->scalar_inflow);
    for (int f = 0; f < 6; f++)
        if (g->inflow[f]) sq_state_put(w, "grid/inflow", g->inflow[f], inflow_floats(g, f) * sizeof(float));
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < g->d.scalar_count; i++)
            if (g->scalar_inflow_data[f][i])
                sq_state_put(w, "grid/scalar_inflow_data", g->scalar_inflow_data[f][i],
                             inflow_floats(g, f) / 3 * sizeof(float));
    const size_t n = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2];
    sq_state_put(w, "grid/solid", g->solid, n);
    sq_state_put(w, "grid/last_project_dt", &g->last_project_dt, sizeof g->last_project_dt);
    return w->status;
}

sq_result sq_grid_load_state(sq_grid *g, sq_state_reader *r)
{
    if (!g || !r) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_grid_load_state: NULL argument");
    int32_t dims[4] = {0, 0, 0, 0};
    if (sq_state_get(r, "grid/dims", dims, sizeof dims) != SQ_OK) return r->status;
    if (dims[0] != g->n[0] || dims[1] != g->n[1] || dims[2] != g->n[2] ||
        dims[3] != g->d.scalar_count)
        return r->status = sq__fail(g->ctx, SQ_ERR_INVALID_ARG, "grid",
                                    "checkpoint '%s': grid %dx%dx%d with %d scalars; this one is "
                                    "%dx%dx%d with %d",
                                    r->source, dims[0], dims[1], dims[2], dims[3], g->n[0],
                                    g->n[1], g->n[2], g->d.scalar_count);
    for (int a = 0; a < 3; a++)
        sq_state_get(r, "grid/vel", g->vel[a].base, g->vel[a].count * sizeof(float));
    for (int i = 0; i < g->d.scalar_count; i++)
        sq_state_get(r, "grid/scalar", g->scalar[i].base, g->scalar[i].count * sizeof(float));
    sq_state_get(r, "grid/p", g->p.base, g->p.count * sizeof(float));
    sq_state_get(r, "grid/scalar_inflow", g->scalar_inflow, sizeof g->scalar_inflow);
    for (int f = 0; f < 6; f++)
        if (g->inflow[f]) sq_state_get(r, "grid/inflow", g->inflow[f], inflow_floats(g, f) * sizeof(float));
    /* per-sample scalar inflow values: the owner allocates the same ones before loading */
    for (int f = 0; f < 6; f++)
        for (int i = 0; i < g->d.scalar_count; i++)
            if (g->scalar_inflow_data[f][i])
                sq_state_get(r, "grid/scalar_inflow_data", g->scalar_inflow_data[f][i],
                             inflow_floats(g, f) / 3 * sizeof(float));
    const size_t n = (size_t)g->n[0] * (size_t)g->n[1] * (size_t)g->n[2];
    uint8_t *solid = (uint8_t *)sq_alloc(g->ctx, n);
    if (!solid) return r->status = SQ_ERR_OUT_OF_MEMORY;
    if (sq_state_get(r, "grid/solid", solid, n) == SQ_OK && memcmp(solid, g->solid, n) != 0)
        sq_grid_set_solid_mask(g, solid);
    sq_free(g->ctx, solid);
    sq_state_get(r, "grid/last_project_dt", &g->last_project_dt, sizeof g->last_project_dt);
    g->trace_valid = false;
    g->vel_version++;
    return r->status;
}
