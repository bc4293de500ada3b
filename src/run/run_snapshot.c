/* run_snapshot.c — copies of one frame's drawables, so that a viewer can draw frame N on its GL
 * thread while the simulation computes frame N+1 (squall/run.h, "Threads"). Each drawable's
 * arrays go into one buffer of the slot, reused from frame to frame; the copied views point into
 * it and keep their version (the renderer re-uploads on a version change only). */
#include <string.h>

#include "run/run_internal.h"

/* Room for n floats in the slot's buffer k. */
static float *reserve(sq_context *ctx, sq__run_frame_slot *s, int k, size_t n)
{
    if (s->data_cap[k] >= n) return s->data[k];
    sq_free(ctx, s->data[k]);
    s->data[k] = sq_alloc(ctx, n * sizeof(float));
    s->data_cap[k] = s->data[k] ? n : 0;
    return s->data[k];
}

/* Appends the array src[0..n) at *at in dst and returns the copy (NULL for a NULL source). */
static const float *put(float *dst, size_t *at, const float *src, size_t n)
{
    if (!src) return NULL;
    float *p = dst + *at;
    memcpy(p, src, n * sizeof(float));
    *at += n;
    return p;
}

sq_result sq__run_snapshot(sq_context *ctx, sq__run_frame_slot *slot, const sq_drawable *ds,
                           int n)
{
    if (n > SQ_RUN_MAX_DRAWABLES) n = SQ_RUN_MAX_DRAWABLES;
    slot->count = 0;
    for (int k = 0; k < n; k++) {
        sq_drawable d = ds[k];
        size_t need = 0, at = 0;
        switch (d.kind) {
        case SQ_DRAWABLE_VOLUME: {
            const sq_volume_view *v = &d.u.volume;
            need = v->density ? (size_t)v->nx * (size_t)v->ny * (size_t)v->nz : 0;
            float *b = reserve(ctx, slot, k, need);
            if (need && !b) return SQ_ERR_OUT_OF_MEMORY;
            d.u.volume.density = put(b, &at, v->density, need);
            break;
        }
        case SQ_DRAWABLE_PARTICLES: {
            const sq_particles_view *p = &d.u.particles;
            const size_t c = p->count > 0 ? (size_t)p->count : 0;
            need = (p->position ? 3 * c : 0) + (p->radius_m ? c : 0) +
                   (p->rotation_rad ? c : 0) + (p->tau ? c : 0) + (p->fade ? c : 0) +
                   (p->color ? 3 * c : 0);
            float *b = reserve(ctx, slot, k, need);
            if (need && !b) return SQ_ERR_OUT_OF_MEMORY;
            d.u.particles.position = put(b, &at, p->position, 3 * c);
            d.u.particles.radius_m = put(b, &at, p->radius_m, c);
            d.u.particles.rotation_rad = put(b, &at, p->rotation_rad, c);
            d.u.particles.tau = put(b, &at, p->tau, c);
            d.u.particles.fade = put(b, &at, p->fade, c);
            d.u.particles.color = put(b, &at, p->color, 3 * c);
            break;
        }
        case SQ_DRAWABLE_SURFACE: {
            const sq_surface_view *s = &d.u.surface;
            const size_t c = (size_t)(s->nx > 0 ? s->nx : 0) * (size_t)(s->ny > 0 ? s->ny : 0);
            need = (s->height_m ? c : 0) + (s->coverage ? c : 0);
            float *b = reserve(ctx, slot, k, need);
            if (need && !b) return SQ_ERR_OUT_OF_MEMORY;
            d.u.surface.height_m = put(b, &at, s->height_m, c);
            d.u.surface.coverage = put(b, &at, s->coverage, c);
            break;
        }
        case SQ_DRAWABLE_SNOW_COVER: {
            const sq_snow_cover_view *s = &d.u.snow_cover;
            need = s->depth_m ? (size_t)(s->nx > 0 ? s->nx : 0) * (size_t)(s->ny > 0 ? s->ny : 0) : 0;
            float *b = reserve(ctx, slot, k, need);
            if (need && !b) return SQ_ERR_OUT_OF_MEMORY;
            d.u.snow_cover.depth_m = put(b, &at, s->depth_m, need);
            break;
        }
        case SQ_DRAWABLE_CLOUDS: {
            /* the groups (ints and floats, 4 bytes each) first, then the particles' arrays */
            const sq_clouds_view *c = &d.u.clouds;
            const size_t m = c->count > 0 ? (size_t)c->count : 0;
            const size_t gn = c->groups && c->group_count > 0 ? (size_t)c->group_count : 0;
            const size_t gf = (gn * sizeof(sq_cloud_group) + sizeof(float) - 1) / sizeof(float);
            need = gf + (c->position ? 3 * m : 0) + (c->radius_m ? m : 0) + (c->tau ? m : 0) +
                   (c->g ? m : 0);
            float *b = reserve(ctx, slot, k, need);
            if (need && !b) return SQ_ERR_OUT_OF_MEMORY;
            if (gn) {
                memcpy(b, c->groups, gn * sizeof(sq_cloud_group));
                d.u.clouds.groups = (const sq_cloud_group *)(void *)b;
                at = gf;
            }
            d.u.clouds.position = put(b, &at, c->position, 3 * m);
            d.u.clouds.radius_m = put(b, &at, c->radius_m, m);
            d.u.clouds.tau = put(b, &at, c->tau, m);
            d.u.clouds.g = put(b, &at, c->g, m);
            break;
        }
        default: break;
        }
        slot->drawables[slot->count++] = d;
    }
    return SQ_OK;
}

void sq__run_slot_free(sq_context *ctx, sq__run_frame_slot *slot)
{
    for (int k = 0; k < SQ_RUN_MAX_DRAWABLES; k++) {
        sq_free(ctx, slot->data[k]);
        slot->data[k] = NULL;
        slot->data_cap[k] = 0;
    }
}
