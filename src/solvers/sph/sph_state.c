/* sph_state.c — the SPH solver's part of a checkpoint (issue 17 part 4): every per-particle
 * array a step reads before recomputing it (positions, velocities, half-step velocities,
 * accelerations, XSPH, density, pressure, volume, gradient correction, velocity gradient and
 * stress where kept, shear rate and viscosity, ids and cells, in the current particle order)
 * and the solver's clock and extrema, so that a restored solver steps bit-identically. Neighbour
 * lists, cell ranges and the packed pass records are rebuilt by the next evaluation. */
#include <string.h>

#include "sph_internal.h"

#define PER_PARTICLE_F(X)                                                                          \
    X(x, 1) X(y, 1) X(z, 1) X(vx, 1) X(vy, 1) X(vz, 1) X(hx, 1) X(hy, 1) X(hz, 1) X(ax, 1)      \
    X(ay, 1) X(az, 1) X(sx, 1) X(sy, 1) X(sz, 1) X(rho, 1) X(p, 1) X(vol, 1) X(pr2, 1) X(L, 6) \
    X(G, 9) X(tau, 6) X(gam, 1) X(mu, 1)

sq_result sq_sph_save_state(const sq_sph *s, sq_state_writer *w)
{
    if (!s || !w) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_sph_save_state: NULL argument");
    const uint64_t count = s->count;
    sq_state_put(w, "sph/count", &count, sizeof count);
    sq_state_put(w, "sph/next_id", &s->next_id, sizeof s->next_id);
#define PUT(name, per)                                                                             \
    if (s->name) sq_state_put(w, "sph/" #name, s->name, sizeof(float) * (per) * s->count);
    PER_PARTICLE_F(PUT)
#undef PUT
    sq_state_put(w, "sph/id", s->id, sizeof(uint32_t) * s->count);
    sq_state_put(w, "sph/cellid", s->cellid, sizeof(uint32_t) * s->count);
    const int32_t flags[2] = {s->forces_valid, s->logged_substep};
    const float ext[3] = {s->vmax, s->amax, s->mumax};
    sq_state_put(w, "sph/flags", flags, sizeof flags);
    sq_state_put(w, "sph/extrema", ext, sizeof ext);
    sq_state_put(w, "sph/steps", &s->steps, sizeof s->steps);
    sq_state_put(w, "sph/time_s", &s->time_s, sizeof s->time_s);
    sq_state_put(w, "sph/cfl_dt_hint", &s->cfl_dt_hint, sizeof s->cfl_dt_hint);
    return w->status;
}

sq_result sq_sph_load_state(sq_sph *s, sq_state_reader *r)
{
    if (!s || !r) return sq__set_error(SQ_ERR_INVALID_ARG, "sq_sph_load_state: NULL argument");
    uint64_t count = 0;
    if (sq_state_get(r, "sph/count", &count, sizeof count) != SQ_OK) return r->status;
    if (count > s->cap)
        return sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "sph",
                        "checkpoint '%s': %llu particles; this solver holds at most %zu", r->source,
                        (unsigned long long)count, s->cap);
    s->count = (size_t)count;
    sq_state_get(r, "sph/next_id", &s->next_id, sizeof s->next_id);
#define GET(name, per)                                                                             \
    if (s->name) sq_state_get(r, "sph/" #name, s->name, sizeof(float) * (per) * s->count);
    PER_PARTICLE_F(GET)
#undef GET
    sq_state_get(r, "sph/id", s->id, sizeof(uint32_t) * s->count);
    sq_state_get(r, "sph/cellid", s->cellid, sizeof(uint32_t) * s->count);
    int32_t flags[2] = {0, 0};
    float ext[3] = {0, 0, 0};
    sq_state_get(r, "sph/flags", flags, sizeof flags);
    sq_state_get(r, "sph/extrema", ext, sizeof ext);
    sq_state_get(r, "sph/steps", &s->steps, sizeof s->steps);
    sq_state_get(r, "sph/time_s", &s->time_s, sizeof s->time_s);
    sq_state_get(r, "sph/cfl_dt_hint", &s->cfl_dt_hint, sizeof s->cfl_dt_hint);
    if (r->status != SQ_OK) return r->status;
    s->forces_valid = flags[0];
    s->logged_substep = flags[1];
    s->vmax = ext[0];
    s->amax = ext[1];
    s->mumax = ext[2];
    return SQ_OK;
}
