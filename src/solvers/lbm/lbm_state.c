/* lbm_state.c — the lattice's part of a checkpoint (issue 17 part 4): the populations (the whole
 * padded array, in the layout of the current step parity), the solid flags, the step count
 * (which fixes the AA parity) and the wind controller's state (targets, ramp set point, inflow
 * reference, body force of the last step, pending one-shot injection). Caches (macroscopic
 * views, u*, boundary fill, inflow shape factors) are recomputed, which is exact: the boundary
 * pass is idempotent and the views are functions of the populations. */
#include <stdlib.h>
#include <string.h>

#include "lbm_internal.h"

sq_result sq_lbm_save_state(const sq_lbm *l, sq_state_writer *w)
{
    if (!l || !w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_save_state: NULL argument");
    if (l->zdist)
        return sq__fail(l->ctx, SQ_ERR_UNSUPPORTED, "lbm",
                        "checkpoints of a lattice split over %d ranks are not supported; run "
                        "with one rank to write checkpoints", l->nranks);
    const int64_t n = (int64_t)l->nx * l->ny * l->nz;
    uint8_t *mask = (uint8_t *)malloc((size_t)n);
    if (!mask) return sq__fail(l->ctx, SQ_ERR_OUT_OF_MEMORY, "lbm", "out of memory (checkpoint)");
    int64_t i = 0;
    for (int z = 0; z < l->nz; z++)
        for (int y = 0; y < l->ny; y++)
            for (int x = 0; x < l->nx; x++) mask[i++] = l->solid[sq__lbm_cell(l, x, y, z)] != 0;
    sq_state_put(w, "lbm/desc", &l->desc, sizeof l->desc);
    sq_state_put(w, "lbm/solid", mask, (size_t)n);
    free(mask);
    sq_state_put(w, "lbm/f", l->f, sizeof(float) * SQ_LBM_Q * (size_t)l->stride);
    sq_state_put(w, "lbm/step", &l->step, sizeof l->step);
    const double wind[5] = {l->wind_speed_mps, l->wind_heading_deg, l->beaufort, l->tau, l->nu_lu};
    sq_state_put(w, "lbm/wind", wind, sizeof wind);
    sq_state_put(w, "lbm/setpoint", l->setpoint, sizeof l->setpoint);
    sq_state_put(w, "lbm/inflow_u", l->inflow_u, sizeof l->inflow_u);
    sq_state_put(w, "lbm/g_step", l->g_step, sizeof l->g_step);
    sq_state_put(w, "lbm/pending", l->pending, sizeof l->pending);
    sq_state_put(w, "lbm/max_wind_lu", &l->max_wind_lu, sizeof l->max_wind_lu);
    return w->status;
}

sq_result sq_lbm_load_state(sq_lbm *l, sq_state_reader *r)
{
    if (!l || !r) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_lbm_load_state: NULL argument");
    if (l->zdist)
        return sq__fail(l->ctx, SQ_ERR_UNSUPPORTED, "lbm",
                        "resuming a lattice split over %d ranks is not supported; resume with "
                        "one rank", l->nranks);
    const int64_t n = (int64_t)l->nx * l->ny * l->nz;
    sq_lbm_desc d;
    if (sq_state_get(r, "lbm/desc", &d, sizeof d) != SQ_OK) return r->status;
    if (d.cells.nx != l->desc.cells.nx || d.cells.ny != l->desc.cells.ny ||
        d.cells.nz != l->desc.cells.nz)
        return r->status = sq__fail(l->ctx, SQ_ERR_INVALID_ARG, "lbm",
                                    "checkpoint '%s': lattice %dx%dx%d; this one is %dx%dx%d",
                                    r->source, d.cells.nx, d.cells.ny, d.cells.nz,
                                    l->desc.cells.nx, l->desc.cells.ny, l->desc.cells.nz);
    uint8_t *mask = (uint8_t *)malloc((size_t)n);
    if (!mask) return sq__fail(l->ctx, SQ_ERR_OUT_OF_MEMORY, "lbm", "out of memory (checkpoint)");
    if (sq_state_get(r, "lbm/solid", mask, (size_t)n) == SQ_OK) sq_lbm_set_solid_mask(l, mask);
    free(mask);
    sq_state_get(r, "lbm/f", l->f, sizeof(float) * SQ_LBM_Q * (size_t)l->stride);
    sq_state_get(r, "lbm/step", &l->step, sizeof l->step);
    double wind[5] = {0, 0, 0, 0, 0};
    sq_state_get(r, "lbm/wind", wind, sizeof wind);
    sq_state_get(r, "lbm/setpoint", l->setpoint, sizeof l->setpoint);
    sq_state_get(r, "lbm/inflow_u", l->inflow_u, sizeof l->inflow_u);
    sq_state_get(r, "lbm/g_step", l->g_step, sizeof l->g_step);
    sq_state_get(r, "lbm/pending", l->pending, sizeof l->pending);
    sq_state_get(r, "lbm/max_wind_lu", &l->max_wind_lu, sizeof l->max_wind_lu);
    if (r->status != SQ_OK) return r->status;
    l->desc = d;
    l->wind_speed_mps = wind[0];
    l->wind_heading_deg = wind[1];
    l->beaufort = wind[2];
    l->tau = wind[3];
    l->nu_lu = wind[4];
    l->bc_valid = false;
    l->macro_valid = l->lmacro_valid = l->ustar_valid = false;
    l->inflow_dirty = true;
    return SQ_OK;
}
