/* avalanche_state.c — the avalanche's checkpoint hooks (issue 17 part 4): the SPH particles
 * (sq_sph_save_state) and what the avalanche carries from one evaluation to the next: its
 * clock, the front history (the front speed is a difference over evaluations), the state it
 * reports, the powder cloud (advanced incrementally) and its clock. The deposit map and the
 * drawables are recomputed from the particles at the next evaluation. */
#include <string.h>

#include "avalanche_internal.h"

sq_result sq__avalanche_save_state(const void *self, sq_state_writer *w)
{
    const sq_avalanche *a = (const sq_avalanche *)self;
    sq_state_put(w, "avalanche/time_s", &a->time_s, sizeof a->time_s);
    const int32_t flags[2] = {a->dirty, a->have_prev_front};
    const double front[2] = {a->prev_front_m, a->prev_front_t};
    sq_state_put(w, "avalanche/flags", flags, sizeof flags);
    sq_state_put(w, "avalanche/version", &a->version, sizeof a->version);
    sq_state_put(w, "avalanche/steps_at_eval", &a->steps_at_eval, sizeof a->steps_at_eval);
    sq_state_put(w, "avalanche/front", front, sizeof front);
    sq_state_put(w, "avalanche/state", &a->st, sizeof a->st);
    const size_t pw = (size_t)a->plan.pw_n[0] * (size_t)a->plan.pw_n[1] * (size_t)a->plan.pw_n[2];
    if (pw && a->pw_density) sq_state_put(w, "avalanche/powder", a->pw_density, sizeof(float) * pw);
    sq_state_put(w, "avalanche/powder_max", &a->pw_max, sizeof a->pw_max);
    sq_state_put(w, "avalanche/powder_time_s", &a->pw_time_s, sizeof a->pw_time_s);
    if (w->status != SQ_OK) return w->status;
    return sq_sph_save_state(a->sph, w);
}

sq_result sq__avalanche_load_state(void *self, sq_state_reader *r)
{
    sq_avalanche *a = (sq_avalanche *)self;
    int32_t flags[2] = {1, 0};
    double front[2] = {0, 0};
    sq_state_get(r, "avalanche/time_s", &a->time_s, sizeof a->time_s);
    sq_state_get(r, "avalanche/flags", flags, sizeof flags);
    sq_state_get(r, "avalanche/version", &a->version, sizeof a->version);
    sq_state_get(r, "avalanche/steps_at_eval", &a->steps_at_eval, sizeof a->steps_at_eval);
    sq_state_get(r, "avalanche/front", front, sizeof front);
    sq_state_get(r, "avalanche/state", &a->st, sizeof a->st);
    const size_t pw = (size_t)a->plan.pw_n[0] * (size_t)a->plan.pw_n[1] * (size_t)a->plan.pw_n[2];
    if (pw && a->pw_density) sq_state_get(r, "avalanche/powder", a->pw_density, sizeof(float) * pw);
    sq_state_get(r, "avalanche/powder_max", &a->pw_max, sizeof a->pw_max);
    sq_state_get(r, "avalanche/powder_time_s", &a->pw_time_s, sizeof a->pw_time_s);
    if (r->status != SQ_OK) return r->status;
    a->dirty = flags[0] != 0;
    a->have_prev_front = flags[1] != 0;
    a->prev_front_m = front[0];
    a->prev_front_t = front[1];
    sq_result res = sq_sph_load_state(a->sph, r);
    a->dirty = true; /* the deposit, drawables and state follow the restored particles */
    return res;
}
