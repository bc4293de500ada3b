/* snowcover_flakes.c — falling snow (S2 §2.3 with SPEC §6.6's corrections):
 *   - emitter: a box of side reach_m placed relative to the camera (its centre half a side ahead
 *     of the camera, horizontally), from below the ground to half a side above the camera; the
 *     flakes live in world coordinates and wrap around the box's sides when the camera moves, so
 *     the snowfall's projection stays stable while walking;
 *   - dynamics: linear drag toward the wind with the exact exponential update,
 *     v = w + v_t + (v0 - w - v_t) e^{-k Δt}, k = g / v_t (so the terminal fall speed is v_t),
 *     the position its exact integral, and an Ornstein–Uhlenbeck velocity noise whose increment
 *     is σ √(1 - e^{-2kΔt}) ≈ σ √(2kΔt) (scaled by √Δt; σ the stationary std);
 *   - a flake reaching the terrain is re-initialised at its birth position (pool reuse);
 *   - spin: an in-plane rotation of the six-fold flake sprite;
 *   - per frame: 3–5 depth layers between near_m and reach_m (geometric), each with its base
 *     size S_l = size × growth^l, the angular radius S_l √(1 / (A + B D + C D²)) (S2 eq 2.4),
 *     hidden nearer than the first layer, faded over the last fifth of the reach. */
#include <math.h>
#include <string.h>

#include "snowcover_internal.h"
#include "squall/rng.h"

#define NOISE_STREAM 0x534E4F57464Cull /* "SNOWFL" */

void sq_snowcover_flake_update(const double wind[3], double fall_speed_mps, double dt_s,
                               double pos[3], double vel[3])
{
    const double k = SQ_SNOWCOVER_G / fall_speed_mps;
    const double e = exp(-k * dt_s);
    const double mean[3] = {wind[0], wind[1], wind[2] - fall_speed_mps};
    for (int a = 0; a < 3; a++) {
        const double dv = vel[a] - mean[a];
        pos[a] += mean[a] * dt_s + dv * (1.0 - e) / k;
        vel[a] = mean[a] + dv * e;
    }
}

/* Box centre (x, y), bottom and top z for the current camera. */
static void emitter(const sq_snowcover *s, double c[2], double *bottom, double *top)
{
    const sq_camera *cam = &s->camera;
    double fx = (double)(cam->target_m.x - cam->position_m.x);
    double fy = (double)(cam->target_m.y - cam->position_m.y);
    const double len = sqrt(fx * fx + fy * fy);
    fx = len > 1e-6 ? fx / len : 0.0;
    fy = len > 1e-6 ? fy / len : 0.0;
    c[0] = (double)cam->position_m.x + 0.5 * s->box_m * fx;
    c[1] = (double)cam->position_m.y + 0.5 * s->box_m * fy;
    const double g = (double)sq_world_height_at(s->world, (float)c[0], (float)c[1]);
    const double cz = (double)cam->position_m.z;
    *bottom = fmin(g, cz) - 2.0;
    *top = fmax(cz, g) + 0.5 * s->box_m;
}

static void wind(const sq_snowcover *s, double w[3])
{
    const double a = s->d.wind_dir_deg * SQ_PI / 180.0;
    w[0] = s->d.wind_speed_mps * cos(a);
    w[1] = s->d.wind_speed_mps * sin(a);
    w[2] = 0.0;
}

void sq__snowcover_flakes_seed(sq_snowcover *s)
{
    double c[2], bottom, top, w[3];
    emitter(s, c, &bottom, &top);
    wind(s, w);
    const double L = s->box_m;
    for (int i = 0; i < s->nflakes; i++) {
        float u[4], v[4];
        sq_rng_uniform4(s->d.seed, NOISE_STREAM + 1, (uint64_t)i, u);
        sq_rng_uniform4(s->d.seed, NOISE_STREAM + 2, (uint64_t)i, v);
        s->birth[2 * i] = (float)(((double)u[0] - 0.5) * L);
        s->birth[2 * i + 1] = (float)(((double)u[1] - 0.5) * L);
        s->pos[3 * i] = (float)(c[0] + (double)s->birth[2 * i]);
        s->pos[3 * i + 1] = (float)(c[1] + (double)s->birth[2 * i + 1]);
        s->pos[3 * i + 2] = (float)(bottom + (double)u[2] * (top - bottom));
        s->vel[3 * i] = (float)w[0];
        s->vel[3 * i + 1] = (float)w[1];
        s->vel[3 * i + 2] = (float)(w[2] - s->d.fall_speed_mps);
        s->rot[i] = 2.0f * SQ_PI_F * u[3];
        s->spin[i] = (float)(s->d.spin_rad_s * (2.0 * (double)v[0] - 1.0));
    }
    s->centre[0] = c[0];
    s->centre[1] = c[1];
    s->centre[2] = top;
    s->seeded = true;
}

static double wrap(double d, double L)
{
    if (d > 0.5 * L) return d - L * floor(d / L + 0.5);
    if (d < -0.5 * L) return d - L * floor(d / L + 0.5);
    return d;
}

void sq__snowcover_flakes_step(sq_snowcover *s, double dt_s)
{
    double c[2], bottom, top, w[3];
    emitter(s, c, &bottom, &top);
    wind(s, w);
    s->centre[0] = c[0];
    s->centre[1] = c[1];
    s->centre[2] = top;
    const double L = s->box_m, vt = s->d.fall_speed_mps;
    const double k = SQ_SNOWCOVER_G / vt;
    const double sigma = s->d.turbulence_mps * sqrt(-expm1(-2.0 * k * dt_s));
    const uint64_t base = s->flake_step * (uint64_t)s->nflakes;
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) if(s->nflakes >= 16384))
    for (int i = 0; i < s->nflakes; i++) {
        float *p = &s->pos[3 * i], *v = &s->vel[3 * i];
        double pd[3] = {p[0], p[1], p[2]}, vd[3] = {v[0], v[1], v[2]}, wl[3];
        /* the wind of the snowdrift lattice where it is present, else the layer's own */
        const double *wf = sq__snowcover_input_wind(s, p, wl) ? wl : w;
        sq_snowcover_flake_update(wf, vt, dt_s, pd, vd);
        if (sigma > 0.0) {
            uint32_t b[4];
            sq_rng_bits(s->d.seed, NOISE_STREAM, base + (uint64_t)i, b);
            const double u1 = ((double)(b[0] >> 8) + 0.5) / 16777216.0;
            const double u2 = (double)(b[1] >> 8) / 16777216.0;
            const double u3 = ((double)(b[2] >> 8) + 0.5) / 16777216.0;
            const double u4 = (double)(b[3] >> 8) / 16777216.0;
            const double r1 = sqrt(-2.0 * log(u1)), r2 = sqrt(-2.0 * log(u3));
            vd[0] += sigma * r1 * cos(2.0 * SQ_PI * u2);
            vd[1] += sigma * r1 * sin(2.0 * SQ_PI * u2);
            vd[2] += 0.5 * sigma * r2 * cos(2.0 * SQ_PI * u4);
        }
        /* wrap around the emitter's sides (the camera moved) */
        pd[0] = c[0] + wrap(pd[0] - c[0], L);
        pd[1] = c[1] + wrap(pd[1] - c[1], L);
        if (pd[2] > top) pd[2] -= top - bottom;
        /* reached the ground (or the bottom of the box): re-initialised at its birth position;
         * so is a flake that a non-finite wind (a lattice that is blowing up, reported by its
         * own layer at its next check) would carry to NaN */
        const bool lost = !(isfinite(pd[0]) && isfinite(pd[1]) && isfinite(pd[2]) &&
                            isfinite(vd[0]) && isfinite(vd[1]) && isfinite(vd[2]));
        if (lost || pd[2] < bottom ||
            pd[2] < (double)sq_world_height_at(s->world, (float)pd[0], (float)pd[1])) {
            pd[0] = c[0] + (double)s->birth[2 * i];
            pd[1] = c[1] + (double)s->birth[2 * i + 1];
            pd[2] = top;
            vd[0] = w[0];
            vd[1] = w[1];
            vd[2] = w[2] - vt;
        }
        for (int a = 0; a < 3; a++) p[a] = (float)pd[a], v[a] = (float)vd[a];
        s->rot[i] = fmodf(s->rot[i] + s->spin[i] * (float)dt_s, 2.0f * SQ_PI_F);
    }
    s->flake_step++;
}

void sq__snowcover_flakes_size(sq_snowcover *s)
{
    const sq_camera *cam = &s->camera;
    const sq_vec3 e = cam->position_m;
    const sq_vec3 f = sq_v3_norm(sq_v3_sub(cam->target_m, e));
    sq_vec3 r = sq_v3_cross(f, cam->up);
    r = sq_v3_len(r) > 1e-6f ? sq_v3_norm(r) : sq_v3(1, 0, 0);
    const sq_vec3 u = sq_v3_cross(r, f);
    const float ty = tanf(0.5f * cam->fov_y_deg * SQ_PI_F / 180.0f), tx = ty * 16.0f / 9.0f;
    const sq_snowcover_desc *d = &s->d;
    const float near_m = (float)d->near_m, reach = (float)d->reach_m;
    const float lnr = logf(reach / near_m);
    const int L = d->layers;
    float base[5];
    for (int l = 0; l < L; l++) base[l] = (float)(d->size_mrad * 1e-3 * pow(d->layer_growth, l));
    const float A = (float)d->atten[0], B = (float)d->atten[1], C = (float)d->atten[2];
    int visible = 0;
    const int nt = sq_context_threads(s->ctx);
    SQ_OMP(omp parallel for schedule(static) num_threads(nt) reduction(+:visible) if(s->nflakes >= 16384))
    for (int i = 0; i < s->nflakes; i++) {
        const sq_vec3 q = sq_v3_sub(sq_v3(s->pos[3 * i], s->pos[3 * i + 1], s->pos[3 * i + 2]), e);
        const float z = sq_v3_dot(q, f);
        const float D = sq_v3_len(q);
        if (z < near_m) { /* hidden nearer than the first layer (and behind the camera) */
            s->fade[i] = 0.0f;
            s->radius[i] = 0.001f;
            continue;
        }
        const int l = sq_clampi((int)floorf((float)L * logf(z / near_m) / lnr), 0, L - 1);
        const float theta = base[l] * sqrtf(1.0f / (A + B * D + C * D * D));
        s->radius[i] = theta * D;
        s->fade[i] = 1.0f - sq_clampf((z - 0.8f * reach) / (0.2f * reach), 0.0f, 1.0f);
        visible += s->fade[i] > 0.0f && fabsf(sq_v3_dot(q, r)) < z * tx && fabsf(sq_v3_dot(q, u)) < z * ty;
    }
    s->visible = visible;
}
