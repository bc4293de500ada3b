/* avalanche_state.c — the avalanche's checkpoint hooks (issue 17 part 4): the SPH particles
 * (sq_sph_save_state) and what the avalanche carries from one evaluation to the next: its
 * clock, the front history (the front speed is a difference over evaluations), the state it
 * reports, the powder cloud (advanced incrementally) and its clock, the hazard maps' peaks since
 * release, the travel tracking per particle and the thalweg. The deposit maps and the drawables
 * are recomputed from the particles at the next evaluation. */
#include <string.h>

#include "avalanche_internal.h"

/* The hazard record: peaks (hz cells), tracking (per particle id), the thalweg (3 per point). */
static void hazard_put(const sq_avalanche *a, sq_state_writer *w)
{
    const size_t cells = (size_t)a->plan.hz_nx * (size_t)a->plan.hz_ny, n = a->plan.count;
    if (!a->hz_depth_peak) return; /* no hazard maps (nothing allocated) */
    sq_state_put(w, "avalanche/hz_depth_peak", a->hz_depth_peak, sizeof(float) * cells);
    sq_state_put(w, "avalanche/hz_speed_peak", a->hz_speed_peak, sizeof(float) * cells);
    sq_state_put(w, "avalanche/hz_pressure_peak", a->hz_pressure_peak, sizeof(float) * cells);
    sq_state_put(w, "avalanche/hz_alpha", a->hz_alpha, sizeof(float) * cells);
    sq_state_put(w, "avalanche/track_t", &a->track_t, sizeof a->track_t);
    sq_state_put(w, "avalanche/tr_z0", a->tr_z0, sizeof(float) * n);
    sq_state_put(w, "avalanche/tr_path", a->tr_path, sizeof(float) * n);
    sq_state_put(w, "avalanche/tr_px", a->tr_px, sizeof(float) * n);
    sq_state_put(w, "avalanche/tr_py", a->tr_py, sizeof(float) * n);
    const int32_t thw_n = a->thw_n;
    sq_state_put(w, "avalanche/thalweg_n", &thw_n, sizeof thw_n);
    if (thw_n > 0) sq_state_put(w, "avalanche/thalweg", a->thw, sizeof(double) * 3 * (size_t)thw_n);
}

static void hazard_get(sq_avalanche *a, sq_state_reader *r)
{
    const size_t cells = (size_t)a->plan.hz_nx * (size_t)a->plan.hz_ny, n = a->plan.count;
    if (!a->hz_depth_peak) return;
    sq_state_get(r, "avalanche/hz_depth_peak", a->hz_depth_peak, sizeof(float) * cells);
    sq_state_get(r, "avalanche/hz_speed_peak", a->hz_speed_peak, sizeof(float) * cells);
    sq_state_get(r, "avalanche/hz_pressure_peak", a->hz_pressure_peak, sizeof(float) * cells);
    sq_state_get(r, "avalanche/hz_alpha", a->hz_alpha, sizeof(float) * cells);
    sq_state_get(r, "avalanche/track_t", &a->track_t, sizeof a->track_t);
    sq_state_get(r, "avalanche/tr_z0", a->tr_z0, sizeof(float) * n);
    sq_state_get(r, "avalanche/tr_path", a->tr_path, sizeof(float) * n);
    sq_state_get(r, "avalanche/tr_px", a->tr_px, sizeof(float) * n);
    sq_state_get(r, "avalanche/tr_py", a->tr_py, sizeof(float) * n);
    int32_t thw_n = 0;
    sq_state_get(r, "avalanche/thalweg_n", &thw_n, sizeof thw_n);
    if (r->status != SQ_OK || thw_n <= 0) return;
    if (thw_n > a->thw_cap) {
        double *t = (double *)sq_alloc(a->ctx, (size_t)thw_n * 3 * sizeof(double));
        if (!t) {
            r->status = sq__fail(a->ctx, SQ_ERR_OUT_OF_MEMORY, "avalanche",
                                 "checkpoint: no memory for a thalweg of %d points", (int)thw_n);
            return;
        }
        sq_free(a->ctx, a->thw);
        a->thw = t;
        a->thw_cap = thw_n;
    }
    sq_state_get(r, "avalanche/thalweg", a->thw, sizeof(double) * 3 * (size_t)thw_n);
    a->thw_n = thw_n;
}

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
    const double pwb[6] = {a->pw_origin[0], a->pw_origin[1], a->pw_origin[2],
                           a->pw_entrained, a->pw_settled, a->pw_left};
    sq_state_put(w, "avalanche/powder_box", pwb, sizeof pwb);
    hazard_put(a, w);
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
    double pwb[6] = {a->pw_origin[0], a->pw_origin[1], a->pw_origin[2],
                     a->pw_entrained, a->pw_settled, a->pw_left};
    sq_state_get(r, "avalanche/powder_box", pwb, sizeof pwb);
    if (a->pw_ground) {
        for (int k = 0; k < 3; k++) a->pw_origin[k] = pwb[k];
        a->pw_entrained = pwb[3];
        a->pw_settled = pwb[4];
        a->pw_left = pwb[5];
        sq__aval_powder_ground(a);
    }
    hazard_get(a, r);
    if (r->status != SQ_OK) return r->status;
    a->dirty = flags[0] != 0;
    a->have_prev_front = flags[1] != 0;
    a->prev_front_m = front[0];
    a->prev_front_t = front[1];
    sq_result res = sq_sph_load_state(a->sph, r);
    a->dirty = true; /* the deposit, drawables and state follow the restored particles */
    return res;
}
