/* phenomenon.c — the generic phenomenon handle (include/squall/phenomenon.h) over the plug-in
 * vtable: one path from a desc to a running phenomenon (resolve, table ranges, the phenomenon's
 * own rules, memory check, create), sub-cycled stepping, and the published views cached per
 * state so that they stay valid until the next step or camera. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/core_internal.h"
#include "phen/phenomenon_internal.h"

#define MAX_FIELDS 64
#define MAX_METRICS 128
#define MAX_SUBSTEPS 100000.0

struct sq_phenomenon {
    sq_context *ctx;
    const sq_phen_plugin *plugin;
    char name[64];
    char desc_type[64]; /* "sq_<type>_desc", the prefix of messages about the desc */
    void *desc;         /* resolved */
    void *self;         /* the typed object; NULL when validate_only */
    const sq_world *world;
    uint64_t memory_bytes;
    double time_s;
    /* views of the current state (fields and metrics are computed on first request) */
    bool have_fields, have_metrics;
    int field_count, metric_count;
    sq_named_field fields[MAX_FIELDS];
    sq_metric metrics[MAX_METRICS];
};

static void invalidate(sq_phenomenon *p)
{
    p->have_fields = false;
    p->have_metrics = false;
}

/* The rules of a desc, in one place for create and live changes: resolve (defaults for zero
 * fields), the table's ranges, the phenomenon's own validate against the world. */
static sq_result check_desc(sq_context *ctx, const sq_phen_plugin *pl, const char *desc_type,
                            void *desc, const sq_world *world)
{
    sq_result r = pl->desc_resolve ? pl->desc_resolve(desc) : SQ_OK;
    if (r == SQ_OK) r = sq_params_validate(pl->params, pl->param_count, desc, desc_type);
    if (r == SQ_OK && pl->validate) r = pl->validate(ctx, desc, world);
    return r;
}

sq_result sq__phenomenon_make(sq_context *ctx, const sq__phen_make *m, sq_phenomenon **out,
                              sq__phen_stage *stage)
{
    *out = NULL;
    *stage = SQ__PHEN_RULES;
    const sq_phen_plugin *pl = m->plugin;
    sq_phenomenon *p = sq_alloc_zero(ctx, sizeof *p);
    if (!p) return SQ_ERR_OUT_OF_MEMORY;
    p->ctx = ctx;
    p->plugin = pl;
    p->world = m->world;
    snprintf(p->name, sizeof p->name, "%s", m->name && m->name[0] ? m->name : pl->name);
    snprintf(p->desc_type, sizeof p->desc_type, "sq_%s_desc", pl->name);
    p->desc = sq_alloc_zero(ctx, pl->desc_size);
    if (!p->desc) {
        sq_phenomenon_destroy(p);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    memcpy(p->desc, m->desc, pl->desc_size);
    sq_result r = check_desc(ctx, pl, p->desc_type, p->desc, m->world);
    if (r == SQ_OK && pl->memory_bytes) {
        *stage = SQ__PHEN_MEMORY;
        r = pl->memory_bytes(p->desc, m->world, &p->memory_bytes);
        char what[160];
        snprintf(what, sizeof what, "layer '%s' (%s)", p->name, pl->name);
        if (r == SQ_OK) r = sq_context_check_memory(ctx, m->memory_base + p->memory_bytes, what);
    }
    if (r == SQ_OK && !m->validate_only) {
        *stage = SQ__PHEN_CREATE;
        r = pl->create(ctx, p->desc, m->world, &p->self);
    }
    if (r != SQ_OK) {
        sq_phenomenon_destroy(p);
        return r;
    }
    *stage = SQ__PHEN_OK;
    *out = p;
    return SQ_OK;
}

sq_result sq__phenomenon_instantiate(sq_phenomenon *p)
{
    if (p->self) return SQ_OK;
    return p->plugin->create(p->ctx, p->desc, p->world, &p->self);
}

sq_result sq_phenomenon_create(sq_context *ctx, const sq_phenomenon_desc *desc,
                               const sq_world *world, sq_phenomenon **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "phenomenon", "sq_phenomenon_create: out is NULL");
    *out = NULL;
    if (!desc || !desc->type || !world)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "phenomenon", "sq_phenomenon_create: %s is NULL",
                        !desc ? "desc" : !desc->type ? "desc->type" : "world");
    const sq_phen_plugin *pl = sq_plugin_find(desc->type);
    if (!pl) {
        char known[256] = "";
        for (int k = 0; k < sq_plugin_count(); k++) {
            strncat(known, k ? ", " : "", sizeof known - strlen(known) - 1);
            strncat(known, sq_plugin_at(k)->name, sizeof known - strlen(known) - 1);
        }
        return sq__fail(ctx, SQ_ERR_NOT_FOUND, "phenomenon",
                        "sq_phenomenon_desc.type = '%s': no such phenomenon in this build "
                        "(available: %s)",
                        desc->type, known[0] ? known : "none");
    }
    char desc_type[64];
    snprintf(desc_type, sizeof desc_type, "sq_%s_desc", pl->name);
    if (desc->typed_desc && desc->typed_desc_size != pl->desc_size)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_desc.typed_desc_size = %zu; a %s has %zu bytes (pass "
                        "sizeof(%s))",
                        desc->typed_desc_size, desc_type, pl->desc_size, desc_type);
    if (desc->setting_count < 0 || (desc->setting_count > 0 && !desc->settings))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_desc.setting_count = %d with settings %s",
                        desc->setting_count, desc->settings ? "set" : "NULL");
    void *d = sq_alloc_zero(ctx, pl->desc_size);
    if (!d) return SQ_ERR_OUT_OF_MEMORY;
    if (desc->typed_desc) memcpy(d, desc->typed_desc, pl->desc_size);
    else sq_params_defaults(pl->params, pl->param_count, d);
    sq_result r = SQ_OK;
    for (int i = 0; i < desc->setting_count && r == SQ_OK; i++) {
        const char *s = desc->settings[i];
        const char *eq = s ? strchr(s, '=') : NULL;
        char key[256], where[64];
        snprintf(where, sizeof where, "sq_phenomenon_desc.settings[%d]", i);
        if (!eq || eq == s || (size_t)(eq - s) >= sizeof key) {
            r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                         "%s = \"%s\": expected \"key=value\" (see `squall params %s`)", where,
                         s ? s : "(null)", pl->name);
            break;
        }
        memcpy(key, s, (size_t)(eq - s));
        key[eq - s] = '\0';
        r = sq_params_set(pl->params, pl->param_count, d, desc_type, key, eq + 1, where);
        if (r != SQ_OK) sq_log(ctx, SQ_LOG_ERROR, "phenomenon", "%s", sq_last_error());
    }
    if (r == SQ_OK) {
        const sq__phen_make m = {pl, desc->name, d, world, false, 0};
        sq__phen_stage stage;
        r = sq__phenomenon_make(ctx, &m, out, &stage);
    }
    sq_free(ctx, d);
    return r;
}

void sq_phenomenon_destroy(sq_phenomenon *p)
{
    if (!p) return;
    if (p->self && p->plugin->destroy) p->plugin->destroy(p->self);
    sq_free(p->ctx, p->desc);
    sq_free(p->ctx, p);
}

sq_result sq_phenomenon_apply_live(sq_phenomenon *p, const void *desc, size_t desc_size,
                                   sq_live_result *res)
{
    if (!p || !desc || !res)
        return sq__fail(p ? p->ctx : NULL, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_apply_live: %s is NULL", !p ? "p" : !desc ? "desc" : "res");
    const sq_phen_plugin *pl = p->plugin;
    if (desc_size != pl->desc_size)
        return sq__fail(p->ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_apply_live: desc_size = %zu; a %s has %zu bytes",
                        desc_size, p->desc_type, pl->desc_size);
    void *d = sq_alloc_zero(p->ctx, pl->desc_size);
    if (!d) return SQ_ERR_OUT_OF_MEMORY;
    memcpy(d, desc, pl->desc_size);
    sq_result r = check_desc(p->ctx, pl, p->desc_type, d, p->world);
    if (r == SQ_OK) {
        const sq_param *fixed = sq_params_first_change(pl->params, pl->param_count, p->desc, d, false);
        const sq_param *live = sq_params_first_change(pl->params, pl->param_count, p->desc, d, true);
        if (fixed || (live && !sq_param_live(live, pl))) {
            res->rebuild = true;
            if (fixed)
                snprintf(res->reason, sizeof res->reason,
                         "%s.%s changed: it is not a live key, the layer must be rebuilt",
                         p->desc_type, fixed->key);
            else
                snprintf(res->reason, sizeof res->reason,
                         "%s.%s changed: %s takes no live change, the layer must be rebuilt",
                         p->desc_type, live->key, pl->name);
        } else if (live && p->self) {
            r = pl->apply_live(p->self, d);
            if (r == SQ_OK) {
                for (size_t i = 0; i < pl->param_count; i++)
                    if ((pl->params[i].flags & SQ_PARAM_LIVE) &&
                        sq_params_first_change(&pl->params[i], 1, p->desc, d, true))
                        res->changed++;
                memcpy(p->desc, d, pl->desc_size);
                invalidate(p);
            }
        } else if (live) {
            memcpy(p->desc, d, pl->desc_size); /* validate-only handle: the desc is all there is */
        }
    }
    sq_free(p->ctx, d);
    return r;
}

const char *sq_phenomenon_type(const sq_phenomenon *p) { return p ? p->plugin->name : NULL; }
const char *sq_phenomenon_name(const sq_phenomenon *p) { return p ? p->name : NULL; }
const sq_phen_plugin *sq_phenomenon_plugin(const sq_phenomenon *p) { return p ? p->plugin : NULL; }
const void *sq_phenomenon_desc_get(const sq_phenomenon *p) { return p ? p->desc : NULL; }
uint64_t sq_phenomenon_memory_bytes(const sq_phenomenon *p) { return p ? p->memory_bytes : 0; }
double sq_phenomenon_time(const sq_phenomenon *p) { return p ? p->time_s : 0.0; }

void *sq_phenomenon_typed(sq_phenomenon *p, const char *type)
{
    if (!p || !type || strcmp(type, p->plugin->name) != 0) return NULL;
    return p->self;
}

double sq_phenomenon_max_stable_dt(const sq_phenomenon *p)
{
    if (!p || !p->self || !p->plugin->max_stable_dt) return 0.0;
    return p->plugin->max_stable_dt(p->self);
}

sq_result sq_phenomenon_step(sq_phenomenon *p, double dt_s)
{
    if (!p) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "phenomenon", "sq_phenomenon_step: NULL");
    if (!(dt_s > 0.0) || !isfinite(dt_s))
        return sq__fail(p->ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                        "%s: step dt_s = %g s; must be finite and > 0", p->name, dt_s);
    if (!p->self)
        return sq__fail(p->ctx, SQ_ERR_INVALID_ARG, "phenomenon",
                        "%s: created for validation only; it cannot be stepped", p->name);
    invalidate(p);
    const double lim = sq_phenomenon_max_stable_dt(p);
    int n = 1;
    if (lim > 0.0 && dt_s > lim) {
        const double nn = ceil(dt_s / lim - 1e-9);
        if (nn > MAX_SUBSTEPS)
            return sq__fail(p->ctx, SQ_ERR_UNSTABLE, "phenomenon",
                            "layer '%s': stable step %g s would need %.0f sub-steps for a "
                            "frame step of %g s",
                            p->name, lim, nn, dt_s);
        n = (int)nn;
    }
    for (int k = 0; k < n; k++) {
        if (sq__cancelled(p->ctx))
            return sq__fail_cancelled(p->ctx, "phenomenon", "while stepping (sq_context_cancel)");
        const sq_result r = p->plugin->step(p->self, dt_s / n);
        if (r != SQ_OK) return r;
    }
    p->time_s += dt_s;
    return SQ_OK;
}

sq_result sq__phenomenon_save_state(const sq_phenomenon *p, sq_state_writer *w)
{
    if (!p->plugin->save_state || !p->plugin->load_state)
        return sq__fail(p->ctx, SQ_ERR_UNSUPPORTED, "phenomenon",
                        "layers.%s (%s) cannot be checkpointed: the phenomenon has no state hooks",
                        p->name, p->plugin->name);
    sq_state_put(w, "phenomenon/time_s", &p->time_s, sizeof p->time_s);
    if (w->status == SQ_OK && p->self) p->plugin->save_state(p->self, w);
    return w->status;
}

sq_result sq__phenomenon_load_state(sq_phenomenon *p, sq_state_reader *r)
{
    if (!p->plugin->load_state)
        return r->status = sq__fail(p->ctx, SQ_ERR_UNSUPPORTED, "phenomenon",
                                    "layers.%s (%s) cannot be restored: the phenomenon has no "
                                    "state hooks",
                                    p->name, p->plugin->name);
    sq_state_get(r, "phenomenon/time_s", &p->time_s, sizeof p->time_s);
    if (r->status == SQ_OK && p->self) p->plugin->load_state(p->self, r);
    invalidate(p);
    return r->status;
}

void sq_phenomenon_observe(sq_phenomenon *p, const sq_camera *camera)
{
    if (!p || !p->self || !camera || !p->plugin->observe) return;
    invalidate(p); /* near-field state follows the camera */
    p->plugin->observe(p->self, camera);
}

sq_result sq_phenomenon_frame_sync(sq_phenomenon *p, bool gather)
{
    if (!p || !p->self || !p->plugin->frame_sync) return SQ_OK;
    invalidate(p);
    return p->plugin->frame_sync(p->self, gather);
}

/* ---- views ------------------------------------------------------------------------------- */
static void need_fields(sq_phenomenon *p)
{
    if (p->have_fields) return;
    p->field_count = p->self && p->plugin->fields ? p->plugin->fields(p->self, p->fields, MAX_FIELDS)
                                                  : 0;
    if (p->field_count < 0) p->field_count = 0;
    p->have_fields = true;
}

static void need_metrics(sq_phenomenon *p)
{
    if (p->have_metrics) return;
    p->metric_count = p->self && p->plugin->metrics
                          ? p->plugin->metrics(p->self, p->metrics, MAX_METRICS)
                          : 0;
    if (p->metric_count < 0) p->metric_count = 0;
    p->have_metrics = true;
}

int sq_phenomenon_field_count(sq_phenomenon *p)
{
    if (!p) return 0;
    need_fields(p);
    return p->field_count;
}

sq_result sq_phenomenon_field(sq_phenomenon *p, int i, sq_named_field *out)
{
    if (!p || !out)
        return sq__fail(p ? p->ctx : NULL, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_field: %s is NULL", p ? "out" : "phenomenon");
    need_fields(p);
    if (i < 0 || i >= p->field_count) {
        memset(out, 0, sizeof *out);
        return sq__fail(p->ctx, SQ_ERR_NOT_FOUND, "phenomenon",
                        "%s: field index %d; it has %d fields", p->name, i, p->field_count);
    }
    *out = p->fields[i];
    return SQ_OK;
}

sq_result sq_phenomenon_field_find(sq_phenomenon *p, const char *name, sq_named_field *out)
{
    if (!p || !out || !name)
        return sq__fail(p ? p->ctx : NULL, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_field_find: an argument is NULL");
    need_fields(p);
    char known[512] = "";
    for (int i = 0; i < p->field_count; i++) {
        if (strcmp(p->fields[i].name, name) == 0) {
            *out = p->fields[i];
            return SQ_OK;
        }
        strncat(known, i ? ", " : "", sizeof known - strlen(known) - 1);
        strncat(known, p->fields[i].name, sizeof known - strlen(known) - 1);
    }
    memset(out, 0, sizeof *out);
    return sq__fail(p->ctx, SQ_ERR_NOT_FOUND, "phenomenon", "%s (%s) has no field '%s' (fields: %s)",
                    p->name, p->plugin->name, name, known[0] ? known : "none");
}

int sq_phenomenon_metric_count(sq_phenomenon *p)
{
    if (!p) return 0;
    need_metrics(p);
    return p->metric_count;
}

sq_result sq_phenomenon_metric(sq_phenomenon *p, int i, sq_metric *out)
{
    if (!p || !out)
        return sq__fail(p ? p->ctx : NULL, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_metric: %s is NULL", p ? "out" : "phenomenon");
    need_metrics(p);
    if (i < 0 || i >= p->metric_count) {
        memset(out, 0, sizeof *out);
        return sq__fail(p->ctx, SQ_ERR_NOT_FOUND, "phenomenon",
                        "%s: metric index %d; it has %d metrics", p->name, i, p->metric_count);
    }
    *out = p->metrics[i];
    return SQ_OK;
}

sq_result sq_phenomenon_metric_find(sq_phenomenon *p, const char *name, sq_metric *out)
{
    if (!p || !out || !name)
        return sq__fail(p ? p->ctx : NULL, SQ_ERR_INVALID_ARG, "phenomenon",
                        "sq_phenomenon_metric_find: an argument is NULL");
    need_metrics(p);
    char known[1024] = "";
    for (int i = 0; i < p->metric_count; i++) {
        if (strcmp(p->metrics[i].name, name) == 0) {
            *out = p->metrics[i];
            return SQ_OK;
        }
        strncat(known, i ? ", " : "", sizeof known - strlen(known) - 1);
        strncat(known, p->metrics[i].name, sizeof known - strlen(known) - 1);
    }
    memset(out, 0, sizeof *out);
    return sq__fail(p->ctx, SQ_ERR_NOT_FOUND, "phenomenon",
                    "%s (%s) has no metric '%s' (metrics: %s)", p->name, p->plugin->name, name,
                    known[0] ? known : "none");
}

int sq_phenomenon_drawables(sq_phenomenon *p, sq_drawable *out, int max)
{
    if (!p || !out || max <= 0 || !p->self || !p->plugin->drawables) return 0;
    return p->plugin->drawables(p->self, out, max);
}
