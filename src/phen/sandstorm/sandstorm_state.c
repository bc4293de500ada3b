/* sandstorm_state.c — the sandstorm's checkpoint hooks (issue 17 part 4): the wind and dust
 * grid (sq_grid_save_state: velocity, dust bins and temperature as scalars, pressure, inflow),
 * the clock and step count, the dust budget and statistics, the urban volume, and the
 * near-field particles around the camera with their spawn counter, the background potential
 * temperature, the cold-pool front history (issue 12), the flow-following detail's advected
 * coordinates. Derived buffers
 * (extinction, visibility planes, exports) are recomputed from these. */
#include <string.h>

#include "sandstorm_internal.h"

sq_result sq__sandstorm_save_state(const void *self, sq_state_writer *w)
{
    const sq_sandstorm *s = (const sq_sandstorm *)self;
    sq_state_put(w, "sandstorm/time_s", &s->time_s, sizeof s->time_s);
    sq_state_put(w, "sandstorm/step", &s->step, sizeof s->step);
    sq_state_put(w, "sandstorm/budget", &s->budget, sizeof s->budget);
    sq_state_put(w, "sandstorm/stats", &s->stats, sizeof s->stats);
    sq_state_put(w, "sandstorm/version", &s->version, sizeof s->version);
    sq_state_put(w, "sandstorm/urban", s->urban_density, sizeof s->urban_density);
    sq_state_put(w, "sandstorm/urban_conc", &s->urban_conc, sizeof s->urban_conc);
    const int32_t cam = s->have_camera;
    sq_state_put(w, "sandstorm/camera", &cam, sizeof cam);
    sq_state_put(w, "sandstorm/cam_pos", &s->cam_pos, sizeof s->cam_pos);
    sq_state_put(w, "sandstorm/spawn_counter", &s->spawn_counter, sizeof s->spawn_counter);
    /* issue 12: the background temperature profile, the cold-pool front history, the warnings
     * given (the cold-pool inflow itself is the grid's velocity and temperature inflow) */
    if (s->theta_ref) sq_state_put(w, "sandstorm/theta_ref", s->theta_ref, (size_t)s->nz * sizeof(float));
    sq_state_put(w, "sandstorm/front_t", s->front_t, sizeof s->front_t);
    sq_state_put(w, "sandstorm/front_x", s->front_x, sizeof s->front_x);
    const int32_t fr[3] = {s->front_n, s->front_head, s->warned};
    sq_state_put(w, "sandstorm/front", fr, sizeof fr);
    sq_state_put(w, "sandstorm/near", &s->np, sizeof s->np);
    if (s->np > 0 && s->p_pos) {
        const size_t n = (size_t)s->np;
        sq_state_put(w, "sandstorm/p_pos", s->p_pos, n * 3 * sizeof(float));
        const float *arr[6] = {s->p_radius, s->p_rot, s->p_spin, s->p_tau, s->p_fade, s->p_age};
        for (int k = 0; k < 6; k++) sq_state_put(w, "sandstorm/p", arr[k], n * sizeof(float));
    }
    if (s->detail.enabled) { /* flow-following detail: its phases and their coordinates */
        const size_t n = (size_t)s->nx * s->ny * s->nz * 3 * sizeof(float);
        sq_state_put(w, "sandstorm/detail_age", s->detail.age, sizeof s->detail.age);
        sq_state_put(w, "sandstorm/detail_x0", s->detail.coord[0], n);
        sq_state_put(w, "sandstorm/detail_x1", s->detail.coord[1], n);
        sq_state_put(w, "sandstorm/detail_amp", s->detail.amp, n / 3);
    }
    if (w->status != SQ_OK || !s->grid) return w->status;
    return sq_grid_save_state(s->grid, w);
}

sq_result sq__sandstorm_load_state(void *self, sq_state_reader *r)
{
    sq_sandstorm *s = (sq_sandstorm *)self;
    int32_t cam = 0;
    int np = 0;
    sq_state_get(r, "sandstorm/time_s", &s->time_s, sizeof s->time_s);
    sq_state_get(r, "sandstorm/step", &s->step, sizeof s->step);
    sq_state_get(r, "sandstorm/budget", &s->budget, sizeof s->budget);
    sq_state_get(r, "sandstorm/stats", &s->stats, sizeof s->stats);
    sq_state_get(r, "sandstorm/version", &s->version, sizeof s->version);
    sq_state_get(r, "sandstorm/urban", s->urban_density, sizeof s->urban_density);
    sq_state_get(r, "sandstorm/urban_conc", &s->urban_conc, sizeof s->urban_conc);
    sq_state_get(r, "sandstorm/camera", &cam, sizeof cam);
    sq_state_get(r, "sandstorm/cam_pos", &s->cam_pos, sizeof s->cam_pos);
    sq_state_get(r, "sandstorm/spawn_counter", &s->spawn_counter, sizeof s->spawn_counter);
    if (s->theta_ref) sq_state_get(r, "sandstorm/theta_ref", s->theta_ref, (size_t)s->nz * sizeof(float));
    sq_state_get(r, "sandstorm/front_t", s->front_t, sizeof s->front_t);
    sq_state_get(r, "sandstorm/front_x", s->front_x, sizeof s->front_x);
    int32_t fr[3] = {0, 0, 0};
    sq_state_get(r, "sandstorm/front", fr, sizeof fr);
    s->front_n = fr[0];
    s->front_head = fr[1];
    s->warned = fr[2];
    if (sq_state_get(r, "sandstorm/near", &np, sizeof np) != SQ_OK) return r->status;
    if (np != s->np)
        return r->status = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "sandstorm",
                                    "checkpoint '%s': %d near-field particles; this layer has %d",
                                    r->source, np, s->np);
    if (s->np > 0 && s->p_pos) {
        const size_t n = (size_t)s->np;
        sq_state_get(r, "sandstorm/p_pos", s->p_pos, n * 3 * sizeof(float));
        float *arr[6] = {s->p_radius, s->p_rot, s->p_spin, s->p_tau, s->p_fade, s->p_age};
        for (int k = 0; k < 6; k++) sq_state_get(r, "sandstorm/p", arr[k], n * sizeof(float));
    }
    if (s->detail.enabled) {
        const size_t n = (size_t)s->nx * s->ny * s->nz * 3 * sizeof(float);
        sq_state_get(r, "sandstorm/detail_age", s->detail.age, sizeof s->detail.age);
        sq_state_get(r, "sandstorm/detail_x0", s->detail.coord[0], n);
        sq_state_get(r, "sandstorm/detail_x1", s->detail.coord[1], n);
        sq_state_get(r, "sandstorm/detail_amp", s->detail.amp, n / 3);
    }
    if (r->status != SQ_OK) return r->status;
    s->have_camera = cam != 0;
    s->derived_dirty = true;
    return s->grid ? sq_grid_load_state(s->grid, r) : SQ_OK;
}
