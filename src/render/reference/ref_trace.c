/* ref_trace.c — the reference CPU path tracer (sq_reference_render): unbiased volumetric path
 * tracing of the scene the GL renderer draws, to validate its approximations (SPEC §3.1: the
 * full radiative transfer equation (3.9)–(3.10) that half-angle slicing with Harris multiple
 * forward scattering approximates).
 *
 * Conventions and estimators:
 * - Camera: pinhole from sq_camera exactly as sq_m4_look_at / sq_m4_perspective (vertical fov,
 *   aspect = width / height); rays through uniformly jittered points of each pixel (box filter);
 *   near/far planes are not applied. Output rows top to bottom, linear RGB radiance, exposure
 *   NOT applied (callers pass desc->exposure to sq_tonemap_rgba8).
 * - Media: beta_ext,c(x) = density(x) * sigma_ext[c], density trilinear (clamp to edge inside
 *   the box, as the GL linear 3D texture), negative densities read as 0. Free flights by delta
 *   (Woodcock) tracking against a piecewise-constant majorant (max over channels, per brick of
 *   8^3 voxels), all three channels at once with spectral tracking (Kutz et al. 2017,
 *   "history-aware" null/scatter probabilities: P_s ~ max_c |w_c mu_s,c|,
 *   P_n ~ max_c |w_c mu_n,c|; absorption enters the weights), which is unbiased per channel.
 *   Several volumes are tracked as superposed independent Poisson processes, each collision
 *   attributed to the volume whose process produced it (its albedo and phase).
 * - Shadow rays: occlusion by opaque geometry, then ratio tracking per volume with Russian
 *   roulette below transmittance 0.1.
 * - Phase: HG (SPEC §2.6, cos theta = dot of propagation directions, g > 0 forward), optional
 *   second lobe (1 - w2) HG(g) + w2 HG(g2). With per-channel g every path draws a hero channel
 *   and samples its directions from that channel's phase function; the channels are combined
 *   by one-sample MIS over the three hero choices (balance heuristic on the product of phase
 *   values along the path: weight P_c / mean_k P_k <= 3; Wilkie et al. 2014 "hero wavelength").
 * - Sun: a directional (delta) light of irradiance world->sun_radiance (its angular size is
 *   neglected; it is never seen directly by camera or bounce rays), by next-event estimation.
 *   Sky: the analytic gradient of sq__ref_sky, reached by rays that escape.
 * - Terrain, surface drawables, obstacles: opaque Lambertian (albedo from the world, material
 *   or obstacle), sun by next-event estimation, cosine-weighted continuation. Particles drawables
 *   are ignored.
 * - max_bounces counts scattering and reflection vertices; a path contributes only light that
 *   reached the camera through at most max_bounces of them (single_scatter_only = 1). Russian
 *   roulette from the fourth vertex on.
 * - Randomness: Philox stream = pixel index, index = sample * 2^32 + block; pixels are
 *   independent, so the image does not depend on the thread count or schedule. */
#include <math.h>
#include <string.h>

#include "render/reference/reference_internal.h"

#define MODULE "reference"

/* ---- phase functions ----------------------------------------------------------------------- */

double sq__hg_eval(double g, double cos_theta)
{
    double den = 1.0 + g * g - 2.0 * g * cos_theta;
    return (1.0 - g * g) / (4.0 * SQ_PI * den * sqrt(den));
}

double sq__hg_sample_cos(double g, double u)
{
    if (fabs(g) < 1e-4) return 1.0 - 2.0 * u;
    double s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u);
    double c = (1.0 + g * g - s * s) / (2.0 * g);
    return c < -1.0 ? -1.0 : (c > 1.0 ? 1.0 : c);
}

sq__dv3 sq__ref_direction_around(sq__dv3 d, double cos_theta, double u)
{
    /* orthonormal basis (Duff et al. 2017) */
    double sign = d.z >= 0.0 ? 1.0 : -1.0;
    double a = -1.0 / (sign + d.z), b = d.x * d.y * a;
    sq__dv3 t1 = sq__dv(1.0 + sign * d.x * d.x * a, sign * b, -sign * d.x);
    sq__dv3 t2 = sq__dv(b, sign + d.y * d.y * a, -d.y);
    double sin_theta = sqrt(fmax(0.0, 1.0 - cos_theta * cos_theta));
    double phi = 2.0 * SQ_PI * u;
    sq__dv3 r = sq__dv_add(sq__dv_scale(d, cos_theta),
                           sq__dv_add(sq__dv_scale(t1, sin_theta * cos(phi)),
                                      sq__dv_scale(t2, sin_theta * sin(phi))));
    return sq__dv_norm(r);
}

static double phase_channel(const sq__ref_volume *v, int c, double mu)
{
    double p = sq__hg_eval(v->g[c], mu);
    if (v->w2 > 0.0) p = (1.0 - v->w2) * p + v->w2 * sq__hg_eval(v->g2, mu);
    return p;
}

/* Samples a new path direction after scattering in v from the hero channel's phase function
 * and multiplies the per-channel phase products P by p_c (renormalised to max 1). */
static sq__dv3 phase_sample(const sq__ref_volume *v, sq__dv3 d, int hero, double P[3],
                            sq__ref_rng *rng)
{
    double u1 = sq__ref_rand(rng), u2 = sq__ref_rand(rng);
    double g = (v->w2 > 0.0 && u1 < v->w2) ? v->g2 : v->g[v->same_phase ? 0 : hero];
    double mu = sq__hg_sample_cos(g, sq__ref_rand(rng));
    if (!v->same_phase) {
        double mx = 0.0;
        for (int k = 0; k < 3; k++) {
            P[k] *= phase_channel(v, k, mu);
            if (P[k] > mx) mx = P[k];
        }
        if (mx > 0.0)
            for (int k = 0; k < 3; k++) P[k] /= mx;
    }
    return sq__ref_direction_around(d, mu, u2);
}

/* One-sample MIS weight of channel c over the three hero strategies (balance heuristic on the
 * phase-sampling part of the path pdf): P_c / mean_k P_k, at most 3. */
static inline double hero_weight(const double P[3], int c)
{
    return P[c] * 3.0 / (P[0] + P[1] + P[2]);
}

/* ---- tracking ------------------------------------------------------------------------------ */

enum { TRACK_NONE = 0, TRACK_SCATTER = 1, TRACK_DEAD = 2 };

/* Delta/spectral tracking along (o, d) over [0, t_end). On a scattering event returns
 * TRACK_SCATTER with *t_out and *vol_out; TRACK_NONE if the ray reaches t_end; TRACK_DEAD if
 * the weights vanished. */
static int track(const sq__ref_scene *s, sq__dv3 o, sq__dv3 d, double t_end, double w[3],
                 sq__ref_rng *rng, double *t_out, int *vol_out)
{
    const int nv = s->volume_count;
    if (nv == 0) return TRACK_NONE;
    double next[SQ__REF_MAX_VOLUMES], maj[SQ__REF_MAX_VOLUMES];
    for (int v = 0; v < nv; v++)
        next[v] = sq__ref_volume_next(&s->volumes[v], o, d, 0.0, t_end, rng, &maj[v]);
    for (;;) {
        int vb = 0;
        for (int v = 1; v < nv; v++)
            if (next[v] < next[vb]) vb = v;
        double t = next[vb];
        if (!(t < t_end)) return TRACK_NONE;
        const sq__ref_volume *vol = &s->volumes[vb];
        double m = maj[vb];
        double rho = sq__ref_volume_density(vol, sq__dv_madd(o, d, t));
        double mus[3], mun[3], ps = 0.0, pn = 0.0;
        for (int c = 0; c < 3; c++) {
            double mut = vol->sig[c] * rho;
            mus[c] = vol->alb[c] * mut;
            mun[c] = m - mut > 0.0 ? m - mut : 0.0;
            double a = fabs(w[c]) * mus[c], b = fabs(w[c]) * mun[c];
            if (a > ps) ps = a;
            if (b > pn) pn = b;
        }
        if (!(ps + pn > 0.0)) return TRACK_DEAD;
        double psum = ps + pn;
        if (sq__ref_rand(rng) * psum < ps) {
            double f = psum / (m * ps);
            for (int c = 0; c < 3; c++) w[c] *= mus[c] * f;
            *t_out = t;
            *vol_out = vb;
            return TRACK_SCATTER;
        }
        double f = psum / (m * pn);
        for (int c = 0; c < 3; c++) w[c] *= mun[c] * f;
        next[vb] = sq__ref_volume_next(vol, o, d, t, t_end, rng, &maj[vb]);
    }
}

/* Sun visibility times volume transmittance from x toward the sun. */
static void sun_transmittance(const sq__ref_scene *s, sq__dv3 x, sq__ref_rng *rng, double tr[3])
{
    if (sq__ref_occluded(s, x, s->sun_dir, 0.0, INFINITY)) {
        tr[0] = tr[1] = tr[2] = 0.0;
        return;
    }
    sq__ref_transmittance(s, x, s->sun_dir, INFINITY, rng, tr);
}

/* ---- one path -------------------------------------------------------------------------------- */

typedef struct trace_opts {
    int max_bounces;
} trace_opts;

static void trace_path(const sq__ref_scene *s, const trace_opts *opt, sq__dv3 o, sq__dv3 d,
                       sq__ref_rng *rng, double L[3])
{
    double w[3] = {1.0, 1.0, 1.0}; /* tracking and albedo weights per channel */
    double P[3] = {1.0, 1.0, 1.0}; /* phase products per channel (relative) */
    int hero = (int)(sq__ref_rand(rng) * 3.0);
    if (hero > 2) hero = 2;
    L[0] = L[1] = L[2] = 0.0;
    double tmin = 0.0;
    for (int bounce = 0;; bounce++) {
        sq__ref_hit hit;
        bool surf = sq__ref_intersect(s, o, d, tmin, INFINITY, &hit);
        double t_end = surf ? hit.t : (double)INFINITY;
        double t = 0.0;
        int vol = -1;
        int ev = track(s, o, d, t_end, w, rng, &t, &vol);
        if (ev == TRACK_DEAD) return;
        if (ev == TRACK_NONE && !surf) { /* escaped to the sky */
            double sky[3];
            /* seen from the ray's origin; the sun disc only for camera rays */
            sq__ref_sky(s, d, o.z, bounce == 0, sky);
            for (int c = 0; c < 3; c++) L[c] += w[c] * hero_weight(P, c) * sky[c];
            return;
        }
        if (bounce >= opt->max_bounces) return;
        if (ev == TRACK_SCATTER) {
            const sq__ref_volume *v = &s->volumes[vol];
            sq__dv3 x = sq__dv_madd(o, d, t);
            if (s->sun_on) {
                double tr[3];
                sun_transmittance(s, x, rng, tr);
                if (tr[0] > 0.0 || tr[1] > 0.0 || tr[2] > 0.0) {
                    double mu = sq__dv_dot(d, s->sun_dir);
                    for (int c = 0; c < 3; c++)
                        L[c] += w[c] * hero_weight(P, c) * s->sun_e[c] * tr[c] *
                                phase_channel(v, c, mu);
                }
            }
            d = phase_sample(v, d, hero, P, rng);
            o = x;
            tmin = 0.0;
        } else { /* opaque Lambertian surface */
            sq__dv3 x = sq__dv_madd(o, d, hit.t);
            double eps = s->eps_scale * (1.0 + fabs(x.x) + fabs(x.y) + fabs(x.z)) * 10.0;
            sq__dv3 xo = sq__dv_madd(x, hit.ng, eps);
            if (s->sun_on) {
                double cs = sq__dv_dot(hit.ns, s->sun_dir), cg = sq__dv_dot(hit.ng, s->sun_dir);
                if (cs > 0.0 && cg > 0.0) {
                    double tr[3];
                    sun_transmittance(s, xo, rng, tr);
                    for (int c = 0; c < 3; c++)
                        L[c] += w[c] * hero_weight(P, c) * hit.albedo[c] / SQ_PI * s->sun_e[c] *
                                cs * tr[c];
                }
            }
            /* cosine-weighted hemisphere about the shading normal: weight = albedo */
            double u1 = sq__ref_rand(rng), u2 = sq__ref_rand(rng);
            sq__dv3 nd = sq__ref_direction_around(hit.ns, sqrt(u1), u2);
            if (sq__dv_dot(nd, hit.ng) <= 0.0) return;
            for (int c = 0; c < 3; c++) w[c] *= hit.albedo[c];
            o = xo;
            d = nd;
            tmin = 0.0;
        }
        /* Russian roulette from the fourth vertex on, on the weighted throughput */
        if (bounce >= 3) {
            double q = 0.0;
            for (int c = 0; c < 3; c++) q = fmax(q, fabs(w[c]) * hero_weight(P, c));
            if (q < 0.95) {
                if (!(q > 0.0) || sq__ref_rand(rng) >= q) return;
                for (int c = 0; c < 3; c++) w[c] /= q;
            }
        }
    }
}

/* ---- camera and the frame ---------------------------------------------------------------- */

typedef struct ref_camera {
    sq__dv3 pos, fwd, right, up;
    double tan_half, aspect;
} ref_camera;

static sq_result camera_setup(sq_context *ctx, const sq_camera *cam, int width, int height,
                              ref_camera *rc)
{
    sq__dv3 pos = sq__dv_from(cam->position_m), tgt = sq__dv_from(cam->target_m);
    sq__dv3 up = sq__dv_from(cam->up);
    if (up.x == 0.0 && up.y == 0.0 && up.z == 0.0) up = sq__dv(0.0, 0.0, 1.0);
    double fov = cam->fov_y_deg == 0.0f ? 50.0 : (double)cam->fov_y_deg;
    if (!(fov > 0.0 && fov < 180.0))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "camera fov_y_deg = %g; must be in (0, 180)", fov);
    if (!isfinite(pos.x) || !isfinite(pos.y) || !isfinite(pos.z) || !isfinite(tgt.x) ||
        !isfinite(tgt.y) || !isfinite(tgt.z))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "camera position/target must be finite");
    sq__dv3 f = sq__dv_sub(tgt, pos);
    if (sq__dv_dot(f, f) == 0.0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "camera target_m = position_m = (%g, %g, %g); they must differ", pos.x,
                        pos.y, pos.z);
    f = sq__dv_norm(f);
    sq__dv3 r = sq__dv_cross(f, sq__dv_norm(up));
    if (sq__dv_dot(r, r) < 1e-12)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "camera up = (%g, %g, %g) is parallel to the view direction", up.x, up.y,
                        up.z);
    rc->pos = pos;
    rc->fwd = f;
    rc->right = sq__dv_norm(r);
    rc->up = sq__dv_cross(rc->right, f);
    rc->tan_half = tan(0.5 * fov * SQ_PI / 180.0);
    rc->aspect = (double)width / (double)height;
    return SQ_OK;
}

/* Ray direction through the image point (sx, sy) in pixels from the top-left corner. */
static sq__dv3 camera_ray(const ref_camera *rc, double sx, double sy, int width, int height)
{
    double nx = 2.0 * sx / width - 1.0, ny = 1.0 - 2.0 * sy / height;
    sq__dv3 d = sq__dv_add(rc->fwd,
                           sq__dv_add(sq__dv_scale(rc->right, nx * rc->tan_half * rc->aspect),
                                      sq__dv_scale(rc->up, ny * rc->tan_half)));
    return sq__dv_norm(d);
}

sq_result sq_reference_render(sq_context *ctx, const sq_reference_desc *desc,
                              const sq_world *world, const sq_camera *camera,
                              const sq_drawable *drawables, int count, float *rgb_out)
{
    if (!desc) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "desc is NULL");
    int width = desc->width ? desc->width : 320, height = desc->height ? desc->height : 180;
    if (desc->width < 0 || desc->height < 0 || width > 32768 || height > 32768)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "width x height = %d x %d; each must be in [1, 32768] (0 -> 320 x 180)",
                        desc->width, desc->height);
    if (rgb_out) memset(rgb_out, 0, (size_t)width * height * 3 * sizeof(float));
    if (desc->samples <= 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "samples = %d; must be > 0",
                        desc->samples);
    if (desc->max_bounces < 0)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "max_bounces = %d; must be >= 0",
                        desc->max_bounces);
    if (!(desc->exposure >= 0.0f))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "exposure = %g; must be >= 0",
                        (double)desc->exposure);
    if (!world) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "world is NULL");
    if (!camera) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "camera is NULL");
    if (!rgb_out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE, "rgb_out is NULL");
    if (count < 0 || (count > 0 && !drawables))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                        "count = %d with drawables %s; need count >= 0 and an array", count,
                        drawables ? "set" : "NULL");
    sq__ref_scene *s = NULL;
    sq_result r = sq__ref_scene_create(ctx, world, drawables, count, desc->isotropic_phase, &s);
    if (r != SQ_OK) return r;
    r = sq__ref_render_scene(ctx, desc, s, camera, rgb_out);
    sq__ref_scene_destroy(s);
    return r;
}

sq_result sq__ref_render_scene(sq_context *ctx, const sq_reference_desc *desc,
                               const sq__ref_scene *s, const sq_camera *camera, float *rgb_out)
{
    const int width = desc->width ? desc->width : 320, height = desc->height ? desc->height : 180;
    trace_opts opt;
    opt.max_bounces = desc->single_scatter_only ? 1 : (desc->max_bounces ? desc->max_bounces : 64);
    const int spp = desc->samples;
    ref_camera rc;
    memset(&rc, 0, sizeof rc);
    sq_result r = camera_setup(ctx, camera, width, height, &rc);
    if (r != SQ_OK) return r;
    if (s->has_terrain) {
        const sq__ref_heightfield *hf = &s->terrain;
        double x1 = hf->ox + (hf->nx - 1) * hf->dx, y1 = hf->oy + (hf->ny - 1) * hf->dy;
        if (rc.pos.x >= hf->ox && rc.pos.x <= x1 && rc.pos.y >= hf->oy && rc.pos.y <= y1) {
            double hz = sq__ref_heightfield_height(hf, rc.pos.x, rc.pos.y);
            if (rc.pos.z < hz)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, MODULE,
                                "camera position_m = (%g, %g, %g) is inside the terrain "
                                "(surface at z = %g)",
                                rc.pos.x, rc.pos.y, rc.pos.z, hz);
        }
    }

    const int nt = sq_context_threads(ctx);
    (void)nt; /* unused without OpenMP */
    const uint64_t seed = desc->seed;
    const int npx = width * height;
    long long bad = 0, done = 0;
    int cancel = 0;
    double reported = 0.0;
    if (desc->progress && !desc->progress(desc->progress_user, 0.0))
        return sq__fail(ctx, SQ_ERR_CANCELLED, MODULE, "reference render cancelled at 0%%");
    /* One parallel region over all pixels (dynamic chunks: paths differ wildly in cost). The
     * calling thread (thread 0) reports progress between its pixels; a false answer raises the
     * cancel flag that every thread checks before its next pixel. */
    SQ_OMP(omp parallel num_threads(nt) reduction(+ : bad))
    {
        const bool reporter = sq__thread_num() == 0 && desc->progress != NULL;
        SQ_OMP(omp for schedule(dynamic, 16) nowait)
        for (int k = 0; k < npx; k++) {
            int stop;
            SQ_OMP(omp atomic read)
            stop = cancel;
            if (stop) continue;
            const int py = k / width, px = k % width;
            const uint64_t pixel = (uint64_t)k;
            double acc[3] = {0.0, 0.0, 0.0};
            for (int smp = 0; smp < spp; smp++) {
                sq__ref_rng rng;
                sq__ref_rng_init(&rng, seed, pixel, (uint64_t)smp);
                double jx = sq__ref_rand(&rng), jy = sq__ref_rand(&rng);
                sq__dv3 d = camera_ray(&rc, px + jx, py + jy, width, height);
                double L[3];
                trace_path(s, &opt, rc.pos, d, &rng, L);
                if (!isfinite(L[0]) || !isfinite(L[1]) || !isfinite(L[2])) {
                    bad++;
                    continue;
                }
                for (int c = 0; c < 3; c++) acc[c] += L[c];
            }
            float *o = rgb_out + 3 * pixel;
            for (int c = 0; c < 3; c++) o[c] = (float)(acc[c] / spp);
            long long now;
            SQ_OMP(omp atomic capture)
            now = ++done;
            if (reporter) {
                const double f = (double)now / npx;
                if (f - reported >= 1.0 / 256.0) {
                    reported = f;
                    if (!desc->progress(desc->progress_user, f)) {
                        SQ_OMP(omp atomic write)
                        cancel = 1;
                    }
                }
            }
        }
    }
    if (!cancel && desc->progress && !desc->progress(desc->progress_user, 1.0)) cancel = 1;
    if (cancel) {
        memset(rgb_out, 0, (size_t)npx * 3 * sizeof(float));
        return sq__fail(ctx, SQ_ERR_CANCELLED, MODULE,
                        "reference render cancelled at %.0f%% (%lld of %d pixels done)",
                        100.0 * (double)done / npx, done, npx);
    }
    if (bad)
        sq_log(ctx, SQ_LOG_WARN, MODULE, "%lld of %lld path samples were not finite and dropped",
               bad, (long long)width * height * spp);
    return SQ_OK;
}
