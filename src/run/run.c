/* run.c — the frame loop (squall/run.h): the scene's clock (warm-up, steps per frame), camera
 * path or override, drawables handed from the simulation side (sq_run_advance) to the drawing
 * side (sq_run_draw / sq_run_draw_to) through frame slots, the metrics and fields of each frame,
 * interruption and progress. The files are run_outputs.c's, the drawable copies
 * run_snapshot.c's. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "run/run_internal.h"
#include "sq_config.h"
#include "squall/par.h"
#include "squall/render.h"
#include "world/world_internal.h"

/* ---- small pieces ---------------------------------------------------------------------------- */
static bool cancelled(const sq_run *run)
{
    const sq_run_desc *d = &run->desc;
    if (sq_context_cancelled(run->ctx)) return true; /* sq_context_cancel: a signal handler */
    if (d->cancel_flag && *d->cancel_flag) return true;
    return d->cancel && d->cancel(d->user);
}

/* The renderer polls the run's cancel_flag / cancel inside a frame (between its passes and
 * parts) as it polls the context. */
static bool renderer_cancel(void *user)
{
    const sq_run_desc *d = &((const sq_run *)user)->desc;
    return (d->cancel_flag && *d->cancel_flag) || (d->cancel && d->cancel(d->user));
}

static sq_result interrupted(sq_run *run)
{
    return sq__fail(run->ctx, SQ_ERR_CANCELLED, "run", "interrupted at frame %d of %d", run->next,
                    run->frames);
}

static void report(sq_run *run, int done, double within, const char *stage)
{
    if (!run->desc.progress) return;
    sq_run_progress p;
    memset(&p, 0, sizeof p);
    p.frame = done;
    p.frames = run->frames;
    p.fraction = run->frames > 0 ? ((double)done + within) / run->frames : 1.0;
    if (p.fraction > 1.0) p.fraction = 1.0;
    p.elapsed_s = sq_time_now() - run->t0;
    p.frames_per_s = p.elapsed_s > 0.0 ? ((double)done + within) / p.elapsed_s : 0.0;
    p.eta_s = p.fraction > 0.0 ? p.elapsed_s / p.fraction - p.elapsed_s : (double)NAN;
    p.stage = stage;
    run->desc.progress(run->desc.user, &p);
}

static bool renders(const sq_run *run) { return run->desc.render != SQ_RUN_SIMULATE; }

/* ---- lifecycle ------------------------------------------------------------------------------- */
static sq__run_look look_of(const sq_scene_output *o)
{
    sq__run_look l = {o->exposure, o->volume_slices, o->light_buffer, o->volume_noise};
    return l;
}

/* The renderer with the look of the frame drawn (made on first use; a live change of the light
 * buffer size makes it again, the other settings are set on it). */
static sq_result create_renderer(sq_run *run, const sq__run_look *look)
{
    if (run->desc.render == SQ_RUN_REFERENCE || !renders(run)) return SQ_OK;
    if (run->renderer && look && look->light_buffer != run->renderer_look.light_buffer) {
        sq_renderer_destroy(run->renderer);
        run->renderer = NULL;
    }
    if (run->renderer) {
        const sq__run_look *c = &run->renderer_look;
        if (!look || (look->exposure == c->exposure && look->volume_slices == c->volume_slices &&
                      look->volume_noise == c->volume_noise))
            return SQ_OK;
        const sq_result r = sq_renderer_set_look(run->renderer, look->exposure,
                                                 look->volume_slices, look->volume_noise);
        if (r == SQ_OK) run->renderer_look = *look;
        return r;
    }
    const sq__run_look l = look ? *look : look_of(run->out);
    sq_render_desc rd;
    memset(&rd, 0, sizeof rd);
    rd.width = run->out->width;
    rd.height = run->out->height;
    rd.exposure = l.exposure;
    rd.volume_slices = l.volume_slices;
    rd.light_buffer_size = l.light_buffer;
    rd.volume_noise = l.volume_noise;
    rd.shadows_off = run->out->shadow_cascades == 0;
    rd.shadow_cascades = run->out->shadow_cascades;
    rd.shadow_map_size = run->out->shadow_map_size;
    rd.shadow_distance_m = run->out->shadow_distance_m;
    rd.lod_pixels = run->out->lod_pixels;
    rd.cull_pixels = run->out->cull_pixels;
    rd.mesh_distance_m = run->out->mesh_distance_m;
    rd.seed = sq_scene_seed(run->scene);
    rd.use_current_context = run->desc.render == SQ_RUN_GL_CURRENT_CONTEXT;
    rd.cancel = renderer_cancel;
    rd.cancel_user = run;
    const sq_result r = sq_renderer_create(run->ctx, &rd, &run->renderer);
    if (r == SQ_OK) run->renderer_look = l;
    return r;
}

sq_result sq_run_create(sq_context *ctx, const sq_run_desc *desc, sq_run **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "run", "sq_run_create: out is NULL");
    *out = NULL;
    if (!desc || !desc->scene)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "run", "sq_run_create: %s is NULL",
                        desc ? "sq_run_desc.scene" : "desc");
    if ((int)desc->render < SQ_RUN_GL || (int)desc->render > SQ_RUN_GL_CURRENT_CONTEXT)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_desc.render = %d; must be SQ_RUN_GL (0), SQ_RUN_SIMULATE (1), "
                        "SQ_RUN_REFERENCE (2) or SQ_RUN_GL_CURRENT_CONTEXT (3)",
                        (int)desc->render);
    if (desc->render == SQ_RUN_REFERENCE && desc->reference_samples <= 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_desc.reference_samples = %d; the reference path tracer needs at "
                        "least 1 sample per pixel",
                        desc->reference_samples);
    sq_run *run = (sq_run *)sq_alloc_zero(ctx, sizeof *run);
    if (!run) return SQ_ERR_OUT_OF_MEMORY;
    run->ctx = ctx;
    run->desc = *desc;
    run->scene = desc->scene;
    run->out = sq_scene_output_settings(desc->scene);
    run->frames = sq_scene_frame_count(desc->scene);
    run->t0 = sq_time_now();
    run->front = run->drawing = -1;
    if (desc->resume_frame < 0 || desc->resume_frame > run->frames ||
        desc->checkpoint_every_s < 0.0 || !isfinite(desc->checkpoint_every_s) ||
        (desc->checkpoint_every_s > 0.0 && (!desc->checkpoint_path || !*desc->checkpoint_path ||
                                            !desc->checkpoint_cfg))) {
        sq_free(ctx, run);
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_desc: resume_frame = %d (0..%d), checkpoint_every_s = %g (>= 0, "
                        "with a path and the configuration)",
                        desc->resume_frame, run->frames, desc->checkpoint_every_s);
    }
    run->next = desc->resume_frame;
    if (desc->checkpoint_every_s > 0.0)
        run->next_checkpoint_s =
            (floor(sq_scene_time(desc->scene) / desc->checkpoint_every_s + 1e-9) + 1.0) *
            desc->checkpoint_every_s;
    run->slots[0].index = run->slots[1].index = -1;
    if (mtx_init(&run->lock, mtx_plain) != thrd_success) {
        sq_free(ctx, run);
        return sq__fail(ctx, SQ_ERR_INTERNAL, "run", "cannot create a mutex");
    }
    if (cnd_init(&run->released) != thrd_success) {
        mtx_destroy(&run->lock);
        sq_free(ctx, run);
        return sq__fail(ctx, SQ_ERR_INTERNAL, "run", "cannot create a condition variable");
    }
    run->have_lock = true;

    sq__run_outputs *o = &run->outs;
    const sq_scene_output *so = run->out;
    const bool images = desc->render == SQ_RUN_GL || desc->render == SQ_RUN_REFERENCE;
    o->ctx = ctx;
    o->overwrite = desc->overwrite;
    o->width = so->width;
    o->height = so->height;
    o->fps = so->fps;
    o->frames = run->frames;
    o->fields_every = so->fields_every;
    o->fields_format = so->fields_format;
    o->title = sq_scene_name(desc->scene);
    o->world = sq_scene_world(desc->scene);
    if (desc->write_outputs) {
        o->video = images && so->video[0] ? so->video : NULL;
        o->frames_dir = images && so->frames_dir[0] ? so->frames_dir : NULL;
        o->metrics = so->metrics[0] ? so->metrics : NULL;
        o->fields = so->fields[0] ? so->fields : NULL;
    }
    /* a camera under the terrain is named by its key and file:line before any work */
    sq_result r = images ? sq_scene_check_camera(desc->scene) : SQ_OK;
    if (r == SQ_OK) r = sq__run_outputs_check(o, images);
    if (r == SQ_OK)
        r = sq__run_outputs_distinct(o, desc->checkpoint_every_s > 0.0 ? desc->checkpoint_path
                                                                       : NULL);
    if (r == SQ_OK && desc->checkpoint_every_s > 0.0) {
        r = sq_output_check(desc->checkpoint_path,
                            desc->overwrite || desc->checkpoint_replaces);
        if (r == SQ_OK && !desc->checkpoint_replaces)
            r = sq_output_check_inputs(ctx, desc->checkpoint_path, false);
        if (r == SQ_OK) sq_output_remove_stale(ctx, desc->checkpoint_path, false);
    }
    if (r == SQ_OK && images && desc->write_outputs && !o->video && !o->frames_dir &&
        !desc->sinks.frame)
        r = sq__fail(ctx, SQ_ERR_INVALID_ARG, "run",
                     "nothing to write: output.video and output.frames_dir are both empty");
    if (r == SQ_OK && renders(run)) {
        run->draw_world = (sq_world *)sq_alloc_zero(ctx, sizeof(sq_world));
        run->slots[0].world = (sq_world *)sq_alloc_zero(ctx, sizeof(sq_world));
        run->slots[1].world = (sq_world *)sq_alloc_zero(ctx, sizeof(sq_world));
        if (!run->draw_world || !run->slots[0].world || !run->slots[1].world)
            r = SQ_ERR_OUT_OF_MEMORY;
    }
    if (r == SQ_OK && images) {
        const size_t px = (size_t)so->width * (size_t)so->height;
        run->rgba = (uint8_t *)sq_alloc(ctx, px * 4);
        if (desc->render == SQ_RUN_REFERENCE) run->linear = (float *)sq_alloc(ctx, px * 3 * sizeof(float));
        if (!run->rgba || (desc->render == SQ_RUN_REFERENCE && !run->linear))
            r = SQ_ERR_OUT_OF_MEMORY;
    }
    /* the renderer's own context fails here, before any simulation work */
    if (r == SQ_OK && desc->render == SQ_RUN_GL) r = create_renderer(run, NULL);
    if (r == SQ_OK && desc->render == SQ_RUN_GL_CURRENT_CONTEXT && !SQ_HAVE_GL)
        r = create_renderer(run, NULL); /* refuses at once */
    if (r == SQ_OK) r = sq__run_outputs_open(o);
    if (r != SQ_OK) {
        sq_log(ctx, SQ_LOG_DEBUG, "run", "not started: %s", sq_last_error());
        sq_run_destroy(run);
        return r;
    }
    *out = run;
    return SQ_OK;
}

void sq_run_destroy(sq_run *run)
{
    if (!run) return;
    sq_context *ctx = run->ctx;
    if (!run->finished) {
        sq__run_outputs_keep_partial(&run->outs);
        if (run->outs.partial[0])
            sq_log(ctx, SQ_LOG_INFO, "run", "the metrics of the %d frame%s done are in '%s'",
                   run->outs.rows, run->outs.rows == 1 ? "" : "s", run->outs.partial);
        sq__run_outputs_abort(&run->outs);
    }
    sq__run_outputs_free(&run->outs);
    sq_renderer_destroy(run->renderer);
    sq__run_slot_free(ctx, &run->slots[0]);
    sq__run_slot_free(ctx, &run->slots[1]);
    /* copies sharing the scene's world: only their memory is theirs */
    sq_free(ctx, run->slots[0].world);
    sq_free(ctx, run->slots[1].world);
    sq_free(ctx, run->draw_world);
    if (run->have_lock) {
        cnd_destroy(&run->released);
        mtx_destroy(&run->lock);
    }
    sq_free(ctx, run->rgba);
    sq_free(ctx, run->linear);
    sq_free(ctx, run);
}

/* ---- the simulation side ------------------------------------------------------------------------ */
/* The camera of this frame: the override, else the scene's path (both reach the layers' observe
 * hooks, which place near-field particles around it). */
static sq_camera frame_camera(sq_run *run)
{
    mtx_lock(&run->lock);
    const bool override = run->camera_override;
    const sq_camera cam = run->camera;
    mtx_unlock(&run->lock);
    if (!override) return sq_scene_camera(run->scene);
    for (int i = 0; i < sq_scene_layer_count(run->scene); i++)
        sq_phenomenon_observe(sq_scene_layer(run->scene, i), &cam);
    return cam;
}

/* The slot advance fills: with snapshots the one not shown (waiting while it is drawn). */
static int claim_slot(sq_run *run)
{
    if (!run->desc.snapshot) return 0;
    mtx_lock(&run->lock);
    const int w = run->front == 0 ? 1 : 0;
    while (run->drawing == w) cnd_wait(&run->released, &run->lock);
    mtx_unlock(&run->lock);
    return w;
}

static sq_result step_to_frame(sq_run *run)
{
    const double frame_dt = sq_scene_frame_dt(run->scene);
    const int spf = run->out->steps_per_frame > 0 ? run->out->steps_per_frame : 1;
    sq_result r = SQ_OK;
    if (run->next == 0) { /* a resumed run (resume_frame > 0) has had its warm-up */
        while (r == SQ_OK && sq_scene_time(run->scene) + 1e-9 < run->out->warmup_s) {
            if (cancelled(run)) return interrupted(run);
            r = sq_scene_step(run->scene, frame_dt / spf);
        }
        return r;
    }
    for (int s = 0; s < spf && r == SQ_OK; s++) {
        if (cancelled(run)) return interrupted(run);
        r = sq_scene_step(run->scene, frame_dt / spf);
    }
    return r;
}

/* The drawables, camera and look of the scene as it is now become the frame drawn next. */
static sq_result publish_frame(sq_run *run, int frame, double t, const sq_camera *cam)
{
    const int w = claim_slot(run);
    sq__run_frame_slot *slot = &run->slots[w];
    sq_drawable ds[SQ_RUN_MAX_DRAWABLES];
    const int n = sq_scene_drawables(run->scene, ds, SQ_RUN_MAX_DRAWABLES);
    if (run->desc.snapshot) {
        const sq_result r = sq__run_snapshot(run->ctx, slot, ds, n);
        if (r != SQ_OK) return r;
    } else {
        memcpy(slot->drawables, ds, sizeof(sq_drawable) * (size_t)n);
        slot->count = n;
    }
    slot->index = frame;
    slot->time_s = t;
    slot->camera = *cam;
    slot->look = look_of(run->out);
    sq__world_frame_copy(slot->world, sq_scene_world(run->scene)); /* its sun, sky and clock */
    mtx_lock(&run->lock);
    run->front = w;
    mtx_unlock(&run->lock);
    return SQ_OK;
}

sq_result sq_run_apply_live(sq_run *run, const sq_scene_desc *desc, sq_live_result *res)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_apply_live: run is NULL");
    sq_result r = sq_scene_apply_live(run->scene, desc, res);
    if (r != SQ_OK || res->rebuild || res->changed == 0 || run->next == 0 || !renders(run))
        return r;
    /* the latest frame again, with the change: drawn next even while the simulation waits */
    const sq_camera cam = frame_camera(run);
    return publish_frame(run, run->next - 1, sq_scene_time(run->scene), &cam);
}

sq_result sq_run_advance(sq_run *run)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_advance: run is NULL");
    if (run->next >= run->frames)
        return sq__fail(run->ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_advance: all %d frames are done", run->frames);
    if (cancelled(run)) return interrupted(run);
    const int frame = run->next;
    sq_result r = step_to_frame(run);
    if (r != SQ_OK) return r;
    const bool due = sq__run_outputs_fields_due(&run->outs, frame);
    if (sq_par_size() > 1) {
        /* a distributed run: the split layers' frame reductions (their metrics), and their
         * state gathered to rank 0 only when it draws this frame or writes its fields (the
         * last frame too: the rasters after the run read it) */
        double gather = renders(run) || due || run->desc.sinks.fields || frame + 1 == run->frames;
        sq_par_max_f64(&gather, 1);
        r = sq_scene_frame_sync(run->scene, gather > 0.0);
        if (r != SQ_OK) return r;
    }
    const double t = sq_scene_time(run->scene);
    const sq_camera cam = frame_camera(run);
    if (renders(run)) {
        r = publish_frame(run, frame, t, &cam);
        if (r != SQ_OK) return r;
    }
    sq_metric mv[SQ_RUN_MAX_METRICS];
    const int nm = sq_scene_metrics(run->scene, mv, SQ_RUN_MAX_METRICS);
    r = sq__run_outputs_metrics(&run->outs, frame, t, mv, nm);
    if (r == SQ_OK && run->desc.sinks.metrics)
        r = run->desc.sinks.metrics(run->desc.sinks.user, frame, t, mv, nm);
    if (r == SQ_OK && (due || run->desc.sinks.fields)) {
        if (cancelled(run)) return interrupted(run);
        sq_named_field fv[SQ_RUN_MAX_FIELDS];
        const int nf = sq_scene_fields(run->scene, fv, SQ_RUN_MAX_FIELDS);
        if (due) r = sq__run_outputs_fields(&run->outs, frame, t, fv, nf);
        if (r == SQ_OK && run->desc.sinks.fields)
            r = run->desc.sinks.fields(run->desc.sinks.user, frame, t, fv, nf);
    }
    if (r != SQ_OK) return r;
    mtx_lock(&run->lock);
    run->next = frame + 1;
    if (!renders(run)) run->slots[0].camera = cam;
    mtx_unlock(&run->lock);
    /* a checkpoint: the state after this frame, to make frame + 1 next */
    if (run->desc.checkpoint_every_s > 0.0 && t + 1e-9 >= run->next_checkpoint_s) {
        r = sq_checkpoint_write(run->ctx, run->desc.checkpoint_path,
                                run->checkpoint_written || run->desc.overwrite ||
                                    run->desc.checkpoint_replaces,
                                run->scene, run->desc.checkpoint_cfg, run->next);
        if (r != SQ_OK) return r;
        run->checkpoint_written = true;
        while (run->next_checkpoint_s <= t + 1e-9) run->next_checkpoint_s += run->desc.checkpoint_every_s;
    }
    if (!renders(run)) report(run, run->next, 0.0, run->next == run->frames ? "done" : "frame");
    return SQ_OK;
}

/* ---- the drawing side ------------------------------------------------------------------------ */
/* Takes the latest frame for drawing (it is not overwritten until release_slot). */
static sq_result take_slot(sq_run *run, int *slot)
{
    mtx_lock(&run->lock);
    *slot = run->front;
    if (*slot >= 0) run->drawing = *slot;
    mtx_unlock(&run->lock);
    if (*slot < 0)
        return sq__fail(run->ctx, SQ_ERR_INVALID_ARG, "run",
                        "no frame to draw yet: call sq_run_advance first");
    return SQ_OK;
}

static void release_slot(sq_run *run)
{
    mtx_lock(&run->lock);
    run->drawing = -1;
    cnd_broadcast(&run->released);
    mtx_unlock(&run->lock);
}

typedef struct ref_progress {
    sq_run *run;
    int frame;
} ref_progress;

static bool reference_progress(void *user, double fraction)
{
    const ref_progress *p = (const ref_progress *)user;
    report(p->run, p->frame, fraction, "reference");
    return !cancelled(p->run);
}

/* The world of the slot drawn (its sun, sky and clock), at the one address the renderer keys its
 * caches on; the slot is held (take_slot), so the simulation side does not write it meanwhile. */
static const sq_world *slot_world(sq_run *run, const sq__run_frame_slot *s)
{
    sq__world_frame_copy(run->draw_world, s->world);
    return run->draw_world;
}

static sq_result draw_slot(sq_run *run, const sq__run_frame_slot *s)
{
    const sq_scene_output *so = run->out;
    const sq_world *world = slot_world(run, s);
    if (run->desc.render == SQ_RUN_REFERENCE) {
        sq_reference_desc rd;
        memset(&rd, 0, sizeof rd);
        rd.width = so->width;
        rd.height = so->height;
        rd.samples = run->desc.reference_samples;
        rd.exposure = s->look.exposure;
        rd.seed = sq_scene_seed(run->scene) + (uint64_t)s->index;
        ref_progress rp = {run, s->index};
        rd.progress = reference_progress;
        rd.progress_user = &rp;
        sq_result r = sq_reference_render(run->ctx, &rd, world, &s->camera, s->drawables,
                                          s->count, run->linear);
        if (r == SQ_ERR_CANCELLED) return interrupted(run);
        if (r == SQ_OK) sq_tonemap_rgba8(run->linear, so->width, so->height, s->look.exposure, run->rgba);
        return r;
    }
    sq_result r = create_renderer(run, &s->look);
    if (r == SQ_OK)
        r = sq_renderer_draw(run->renderer, world, &s->camera, s->drawables, s->count, s->time_s);
    /* Ctrl-C inside the renderer's creation or a frame: the run's own message, like between frames */
    if (r == SQ_ERR_CANCELLED) return interrupted(run);
    if (r == SQ_OK) r = sq_renderer_read_rgba8(run->renderer, run->rgba);
    return r;
}

sq_result sq_run_draw(sq_run *run)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_draw: run is NULL");
    if (!renders(run))
        return sq__fail(run->ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_draw: the run was created with SQ_RUN_SIMULATE (no frames)");
    int slot;
    sq_result r = take_slot(run, &slot);
    if (r != SQ_OK) return r;
    const sq__run_frame_slot *s = &run->slots[slot];
    if (cancelled(run)) r = interrupted(run);
    if (r == SQ_OK) r = draw_slot(run, s);
    if (r == SQ_OK && run->desc.sinks.frame) {
        sq_run_frame f = {s->index, s->time_s, run->out->width, run->out->height, run->rgba,
                          run->desc.render == SQ_RUN_REFERENCE ? run->linear : NULL};
        r = run->desc.sinks.frame(run->desc.sinks.user, &f);
    }
    if (r == SQ_OK && cancelled(run)) r = interrupted(run);
    if (r == SQ_OK)
        r = sq__run_outputs_frame(&run->outs, s->index, run->rgba,
                                  run->desc.render == SQ_RUN_REFERENCE ? run->linear : NULL);
    const int done = s->index + 1;
    release_slot(run);
    if (r == SQ_OK) report(run, done, 0.0, done == run->frames ? "done" : "frame");
    return r;
}

sq_result sq_run_draw_to(sq_run *run, const sq_render_target *target)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_draw_to: run is NULL");
    if (run->desc.render != SQ_RUN_GL_CURRENT_CONTEXT)
        return sq__fail(run->ctx, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_draw_to: needs sq_run_desc.render = SQ_RUN_GL_CURRENT_CONTEXT "
                        "(the caller's OpenGL context)");
    int slot;
    sq_result r = take_slot(run, &slot);
    if (r != SQ_OK) return r;
    const sq__run_frame_slot *s = &run->slots[slot];
    /* an interactive camera moves at the display's rate, also while the simulation waits */
    mtx_lock(&run->lock);
    const sq_camera cam = run->camera_override ? run->camera : s->camera;
    mtx_unlock(&run->lock);
    r = create_renderer(run, &s->look);
    if (r == SQ_OK)
        r = sq_renderer_draw_to(run->renderer, target, slot_world(run, s), &cam,
                                s->drawables, s->count, s->time_s);
    release_slot(run);
    return r == SQ_ERR_CANCELLED ? interrupted(run) : r;
}

sq_result sq_run_execute(sq_run *run)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_execute: run is NULL");
    sq_result r = SQ_OK;
    while (r == SQ_OK && run->next < run->frames) {
        r = sq_run_advance(run);
        if (r == SQ_OK && renders(run)) r = sq_run_draw(run);
        /* a distributed run: a rank that failed (rank 0 writing a frame, a slab's blow-up)
         * stops every rank here with its message, instead of leaving them in the next step */
        r = sq_par_agree(r);
    }
    if (r != SQ_OK) {
        /* the rows so far show what happened (a blow-up, where it stopped): kept, and said so
         * in the one message */
        char why[1024];
        snprintf(why, sizeof why, "%s", sq_last_error());
        sq__run_outputs_keep_partial(&run->outs);
        if (run->outs.partial[0])
            sq__set_error(r, "%s; nothing written but the metrics of the %d frame%s done, in '%s'",
                          why, run->outs.rows, run->outs.rows == 1 ? "" : "s", run->outs.partial);
    }
    return r;
}

sq_result sq_run_finish(sq_run *run)
{
    if (!run) return sq__fail(NULL, SQ_ERR_INVALID_ARG, "run", "sq_run_finish: run is NULL");
    if (run->finished)
        return sq__fail(run->ctx, SQ_ERR_INVALID_ARG, "run", "sq_run_finish: already finished");
    const sq_result r = sq__run_outputs_commit(&run->outs);
    if (r == SQ_OK) run->finished = true;
    return r;
}

/* ---- queries ----------------------------------------------------------------------------------- */
void sq_run_set_camera(sq_run *run, const sq_camera *camera)
{
    if (!run) return;
    mtx_lock(&run->lock);
    run->camera_override = camera != NULL;
    if (camera) run->camera = *camera;
    mtx_unlock(&run->lock);
}

bool sq_run_done(const sq_run *run) { return !run || sq_run_frame_index(run) >= run->frames; }
int sq_run_frame_count(const sq_run *run) { return run ? run->frames : 0; }
double sq_run_elapsed_s(const sq_run *run) { return run ? sq_time_now() - run->t0 : 0.0; }

int sq_run_frame_index(const sq_run *run)
{
    if (!run) return 0;
    mtx_t *m = (mtx_t *)&run->lock;
    mtx_lock(m);
    const int n = run->next;
    mtx_unlock(m);
    return n;
}

double sq_run_time(const sq_run *run)
{
    if (!run) return 0.0;
    mtx_t *m = (mtx_t *)&run->lock;
    mtx_lock(m);
    const int f = run->front;
    const double t = f >= 0 ? run->slots[f].time_s : sq_scene_time(run->scene);
    mtx_unlock(m);
    return t;
}

sq_camera sq_run_camera(const sq_run *run)
{
    sq_camera c;
    memset(&c, 0, sizeof c);
    if (!run) return c;
    mtx_t *m = (mtx_t *)&run->lock;
    mtx_lock(m);
    const int f = run->front >= 0 ? run->front : 0;
    c = run->slots[f].camera;
    mtx_unlock(m);
    return c;
}

int sq_run_metric_count(const sq_run *run) { return run ? run->outs.metric_count : 0; }

sq_result sq_run_metric_stats_get(const sq_run *run, int i, sq_run_metric_stats *out)
{
    if (!run || !out)
        return sq__fail(run ? run->ctx : NULL, SQ_ERR_INVALID_ARG, "run",
                        "sq_run_metric_stats_get: an argument is NULL");
    return sq__run_metric_stats(&run->outs, i, out);
}
