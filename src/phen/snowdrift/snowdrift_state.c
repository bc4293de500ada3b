/* snowdrift_state.c — the snowdrift's checkpoint hooks (issue 17 part 4): the wind lattice
 * (sq_lbm_save_state), the snow on it (airborne, landed and deposited flakes per cell, cell
 * kinds, the snow step that seeds its random draws, the budget counters), the clock (time,
 * the part of a snow step not yet stepped, step counts) and the visual flakes carried by the
 * wind. Drawables, fields and the surface u* list are rebuilt from these at the next step. */
#include <string.h>

#include "snowdrift_internal.h"

sq_result sq__snowdrift_save_state(const void *self, sq_state_writer *w)
{
    const sq_snowdrift *s = (const sq_snowdrift *)self;
    const sq__snow *sn = s->snow;
    const size_t n = (size_t)sn->n;
    sq_state_put(w, "snowdrift/time_s", &s->time_s, sizeof s->time_s);
    sq_state_put(w, "snowdrift/t_acc", &s->t_acc, sizeof s->t_acc);
    const int64_t counts[3] = {s->snow_steps, s->steps, s->lbm_steps};
    sq_state_put(w, "snowdrift/steps", counts, sizeof counts);
    sq_state_put(w, "snowdrift/version", &s->version, sizeof s->version);
    sq_state_put(w, "snow/air", sn->air, n * sizeof(uint32_t));
    sq_state_put(w, "snow/land", sn->land, n * sizeof(uint32_t));
    sq_state_put(w, "snow/dep", sn->dep, n * sizeof(uint32_t));
    sq_state_put(w, "snow/kind", sn->kind, n);
    const uint64_t budget[4] = {sn->step, sn->fallen, sn->left, sn->eroded};
    sq_state_put(w, "snow/budget", budget, sizeof budget);
    sq_state_put(w, "snowdrift/flakes", &s->nflakes, sizeof s->nflakes);
    if (s->nflakes > 0) {
        sq_state_put(w, "snowdrift/fpos", s->fpos, sizeof(float) * 3 * (size_t)s->nflakes);
        sq_state_put(w, "snowdrift/frot", s->frot, sizeof(float) * (size_t)s->nflakes);
        sq_state_put(w, "snowdrift/fspin", s->fspin, sizeof(float) * (size_t)s->nflakes);
    }
    if (w->status != SQ_OK) return w->status;
    return sq_lbm_save_state(s->lbm, w);
}

sq_result sq__snowdrift_load_state(void *self, sq_state_reader *r)
{
    sq_snowdrift *s = (sq_snowdrift *)self;
    sq__snow *sn = s->snow;
    const size_t n = (size_t)sn->n;
    int64_t counts[3] = {0, 0, 0};
    uint64_t budget[4] = {0, 0, 0, 0};
    int nflakes = 0;
    sq_state_get(r, "snowdrift/time_s", &s->time_s, sizeof s->time_s);
    sq_state_get(r, "snowdrift/t_acc", &s->t_acc, sizeof s->t_acc);
    sq_state_get(r, "snowdrift/steps", counts, sizeof counts);
    sq_state_get(r, "snowdrift/version", &s->version, sizeof s->version);
    sq_state_get(r, "snow/air", sn->air, n * sizeof(uint32_t));
    sq_state_get(r, "snow/land", sn->land, n * sizeof(uint32_t));
    sq_state_get(r, "snow/dep", sn->dep, n * sizeof(uint32_t));
    sq_state_get(r, "snow/kind", sn->kind, n);
    sq_state_get(r, "snow/budget", budget, sizeof budget);
    if (sq_state_get(r, "snowdrift/flakes", &nflakes, sizeof nflakes) != SQ_OK) return r->status;
    if (nflakes != s->nflakes)
        return r->status = sq__fail(s->ctx, SQ_ERR_INVALID_ARG, "snowdrift",
                                    "checkpoint '%s': %d visual flakes; this layer draws %d",
                                    r->source, nflakes, s->nflakes);
    if (nflakes > 0) {
        sq_state_get(r, "snowdrift/fpos", s->fpos, sizeof(float) * 3 * (size_t)nflakes);
        sq_state_get(r, "snowdrift/frot", s->frot, sizeof(float) * (size_t)nflakes);
        sq_state_get(r, "snowdrift/fspin", s->fspin, sizeof(float) * (size_t)nflakes);
    }
    if (r->status != SQ_OK) return r->status;
    s->snow_steps = counts[0];
    s->steps = counts[1];
    s->lbm_steps = counts[2];
    sn->step = budget[0];
    sn->fallen = budget[1];
    sn->left = budget[2];
    sn->eroded = budget[3];
    sq_result res = sq_lbm_load_state(s->lbm, r);
    s->derived_dirty = s->air_dirty = true;
    return res;
}
