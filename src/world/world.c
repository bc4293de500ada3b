/* world.c — the world: procedural or heightmap terrain with normals, obstacles, sun position
 * from date/time/latitude, a simple analytic sky colour model, and camera helpers.
 * Terrain kinds: hills (fBm gradient noise), dunes (asymmetric transverse ridges: gentle
 * windward slope, steep slip face near the 30-34 degree angle of repose, plus noise), mountain
 * (an inclined release slope that flattens into a run-out plain, with ridges), heightmap (16-bit
 * PNG), grid (float heights given by the caller: DEMs, WRF terrain). */
#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

#include "core/core_internal.h"
#include "squall/noise.h"
#include "world_internal.h"

#define WORLD_MAX_SAMPLES (8192 * 8192)

sq_result sq_world_desc_resolve(const sq_world_desc *in, sq_world_desc *out)
{
    sq_world_desc d = {0};
    if (in) d = *in;
    sq_terrain_desc *t = &d.terrain;
    if (t->kind == SQ_TERRAIN_DEFAULT) t->kind = SQ_TERRAIN_HILLS;
    if (t->kind != SQ_TERRAIN_HEIGHTMAP && t->kind != SQ_TERRAIN_GRID) {
        if (t->size_m[0] == 0.0f) t->size_m[0] = 2000.0f;
        if (t->size_m[1] == 0.0f) t->size_m[1] = 2000.0f;
        if (t->resolution[0] == 0) t->resolution[0] = 257;
        if (t->resolution[1] == 0) t->resolution[1] = 257;
    }
    if (t->relief_m == 0.0f && t->kind != SQ_TERRAIN_FLAT) t->relief_m = 60.0f;
    if (t->feature_m == 0.0f) t->feature_m = 400.0f;
    if (t->octaves == 0) t->octaves = 5;
    if (t->slope_deg == 0.0f) t->slope_deg = 35.0f;
    if (d.sun.day_of_year == 0) d.sun.day_of_year = 172;
    if (!d.sun.hour_set && d.sun.hour_solar == 0.0f) d.sun.hour_solar = 15.0f;
    if (d.sun.irradiance_w_m2 == 0.0f) d.sun.irradiance_w_m2 = 1000.0f;
    if (d.sun.clock_scale == 0.0f) d.sun.clock_scale = 1.0f;
    if (t->vertical_exaggeration == 0.0f) t->vertical_exaggeration = 1.0f;
    if (d.sky.turbidity == 0.0f) d.sky.turbidity = 3.0f;
    if (out) *out = d;
    return SQ_OK;
}

static sq_result validate(sq_context *ctx, const sq_world_desc *d)
{
    const sq_terrain_desc *t = &d->terrain;
    if (!(t->vertical_exaggeration > 0.0f) || !isfinite(t->vertical_exaggeration))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                        "world.terrain.vertical_exaggeration = %g; must be > 0",
                        (double)t->vertical_exaggeration);
    if (d->sun.utc_set &&
        (!isfinite(d->sun.utc_start_unix_s) || !isfinite(d->sun.clock_scale) ||
         !(fabsf(d->sun.latitude_deg) <= 90.0f) || !isfinite(d->sun.longitude_deg) ||
         !isfinite(d->sun.north_rotation_deg)))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                        "world.sun: date %g s, clock scale %g, latitude %g, longitude %g, north "
                        "rotation %g: a sun clock needs finite values and |latitude| <= 90",
                        d->sun.utc_start_unix_s, (double)d->sun.clock_scale,
                        (double)d->sun.latitude_deg, (double)d->sun.longitude_deg,
                        (double)d->sun.north_rotation_deg);
    if (t->kind == SQ_TERRAIN_HEIGHTMAP) {
        if (!t->heightmap || t->heightmap_w < 2 || t->heightmap_h < 2)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.terrain: heightmap of %dx%d pixels; at least 2x2 needed",
                            t->heightmap_w, t->heightmap_h);
        if (!(t->metres_per_px > 0.0f) || !isfinite(t->metres_per_px))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.terrain.metres_per_px = %g; must be > 0",
                            (double)t->metres_per_px);
        if (!(t->height_max_m >= t->height_min_m))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.terrain.height_max_m = %g is below height_min_m = %g",
                            (double)t->height_max_m, (double)t->height_min_m);
        if ((int64_t)t->heightmap_w * t->heightmap_h > WORLD_MAX_SAMPLES)
            return sq__fail(ctx, SQ_ERR_TOO_LARGE, "world",
                            "world.terrain: heightmap of %dx%d pixels; at most %d pixels",
                            t->heightmap_w, t->heightmap_h, WORLD_MAX_SAMPLES);
    } else if (t->kind == SQ_TERRAIN_GRID) {
        if (!t->grid_heights_m || t->grid_w < 2 || t->grid_h < 2)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.terrain: height grid of %dx%d samples; at least 2x2 needed",
                            t->grid_w, t->grid_h);
        if ((int64_t)t->grid_w * t->grid_h > WORLD_MAX_SAMPLES)
            return sq__fail(ctx, SQ_ERR_TOO_LARGE, "world",
                            "world.terrain: height grid of %dx%d samples; at most %d samples",
                            t->grid_w, t->grid_h, WORLD_MAX_SAMPLES);
        if (!(t->grid_dx_m > 0.0f) || !isfinite(t->grid_dx_m) || !(t->grid_dy_m > 0.0f) ||
            !isfinite(t->grid_dy_m))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.terrain: grid spacing %g x %g m; both must be > 0",
                            (double)t->grid_dx_m, (double)t->grid_dy_m);
        size_t n = (size_t)t->grid_w * (size_t)t->grid_h;
        for (size_t k = 0; k < n; k++)
            if (!isfinite(t->grid_heights_m[k]) || fabsf(t->grid_heights_m[k]) > 1.0e5f)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.terrain: height grid sample (%zu, %zu) = %g m; heights "
                                "must be finite and within +-100 km (fill no-data first)",
                                k % (size_t)t->grid_w, k / (size_t)t->grid_w,
                                (double)t->grid_heights_m[k]);
    } else {
        for (int a = 0; a < 2; a++) {
            if (!(t->size_m[a] > 0.0f) || !isfinite(t->size_m[a]))
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.terrain.size_m[%d] = %g; must be > 0 m", a,
                                (double)t->size_m[a]);
            if (t->resolution[a] < 2 || t->resolution[a] > 8192)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.terrain.resolution[%d] = %d; must be 2..8192", a,
                                t->resolution[a]);
        }
    }
    if (d->obstacle_count < 0 || d->obstacle_count > SQ_MAX_OBSTACLES)
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                        "world.obstacles: %d given; at most %d", d->obstacle_count,
                        SQ_MAX_OBSTACLES);
    for (int i = 0; i < d->obstacle_count; i++) {
        const sq_obstacle *o = &d->obstacles[i];
        if (!(o->size_m.x > 0.0f && o->size_m.y > 0.0f && o->size_m.z > 0.0f))
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.obstacles[%d].size = (%g, %g, %g); every side must be > 0 m",
                            i, (double)o->size_m.x, (double)o->size_m.y, (double)o->size_m.z);
        if (o->roof_m < 0.0f)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.obstacles[%d].roof_m = %g; must be >= 0 m", i,
                            (double)o->roof_m);
    }
    if (d->area_count < 0 || d->area_count > SQ_MAX_WORLD_AREAS || (d->area_count && !d->areas))
        return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world", "world.areas: %d areas; at most %d",
                        d->area_count, SQ_MAX_WORLD_AREAS);
    for (int a = 0; a < d->area_count; a++) {
        const sq_world_area *ar = &d->areas[a];
        if (!ar->name || !ar->name[0])
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world", "world.areas[%d]: no name", a);
        for (int b = 0; b < a; b++)
            if (strcmp(d->areas[b].name, ar->name) == 0)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.areas[%d].name = '%s': used twice", a, ar->name);
        if (ar->ring_count < 1 || ar->feature_count < 1 || !ar->ring_start || !ar->ring_feature ||
            !ar->xy_m || !ar->feature_value || !ar->feature_area_m2)
            return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                            "world.areas[%d] ('%s'): no polygons", a, ar->name);
        for (int r = 0; r < ar->ring_count; r++)
            if (ar->ring_start[r + 1] - ar->ring_start[r] < 3 || ar->ring_start[r] < 0 ||
                ar->ring_feature[r] < 0 || ar->ring_feature[r] >= ar->feature_count)
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.areas[%d] ('%s'): ring %d is malformed", a, ar->name, r);
        for (int r = 1; r < ar->ring_count; r++)
            if (ar->ring_feature[r] < ar->ring_feature[r - 1])
                return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world",
                                "world.areas[%d] ('%s'): the rings of a feature must be "
                                "consecutive (ring %d)", a, ar->name, r);
    }
    return SQ_OK;
}

/* Asymmetric dune profile in [0, 1] over one wavelength phase p in [0, 1): a long windward
 * ramp (75 % of the wavelength) and a short steep lee (slip) face. */
static float dune_profile(float p)
{
    const float crest = 0.75f;
    if (p < crest) {
        float s = p / crest;
        return s * s * (3.0f - 2.0f * s);
    }
    float s = (p - crest) / (1.0f - crest);
    return 1.0f - s * s * (3.0f - 2.0f * s) * 0.98f - 0.02f * s;
}

/* Fills the heights row by row; returns false when ctx was cancelled (checked every row: a
 * 8192 x 8192 fBm terrain takes minutes). */
static bool generate(sq_context *ctx, const sq_terrain_desc *t, sq_world *w)
{
    sq_noise nz;
    sq_noise_init(&nz, t->seed);
    const float inv = 1.0f / t->feature_m;
    for (int j = 0; j < w->ny; j++) {
        if (sq__cancelled(ctx)) return false;
        for (int i = 0; i < w->nx; i++) {
            float x = w->origin.x + (float)i * w->dx, y = w->origin.y + (float)j * w->dy;
            float h = t->base_m;
            switch (t->kind) {
            case SQ_TERRAIN_FLAT: break;
            case SQ_TERRAIN_HEIGHTMAP: {
                int px = i, py = t->heightmap_h - 1 - j; /* row 0 is the north edge */
                float v = (float)t->heightmap[(size_t)py * (size_t)t->heightmap_w + (size_t)px];
                h += t->height_min_m + (t->height_max_m - t->height_min_m) * v / 65535.0f;
                break;
            }
            case SQ_TERRAIN_GRID:
                h += t->grid_heights_m[(size_t)j * (size_t)t->grid_w + (size_t)i];
                break;
            case SQ_TERRAIN_DUNES: {
                float a = t->dune_dir_deg * (float)(SQ_PI / 180.0);
                float along = x * cosf(a) + y * sinf(a);
                float warp = 0.35f * t->feature_m *
                             sq_noise_fbm3(&nz, x * inv * 0.5f, y * inv * 0.5f, 0.5f, 3, 2.0f, 0.5f);
                float ph = (along + warp) * inv;
                ph -= floorf(ph);
                float crest_var = 0.75f + 0.25f * sq_noise3(&nz, x * inv * 0.3f, y * inv * 0.3f, 3.1f);
                h += t->relief_m * crest_var * dune_profile(ph);
                h += 0.08f * t->relief_m *
                     sq_noise_fbm3(&nz, x * inv * 4.0f, y * inv * 4.0f, 1.3f, 3, 2.0f, 0.5f);
                break;
            }
            case SQ_TERRAIN_MOUNTAIN: {
                /* Slope descending toward +x into a flat run-out plain. The toe is a C1 fillet:
                 * over |u - toe| < w the profile is the parabola tangent to the slope at
                 * toe - w and to the plain at toe + w, so neither the height nor the slope
                 * jumps (a fast flow meeting a kink or step is launched). */
                float len = w->dx * (float)(w->nx - 1);
                float u = (x - w->origin.x) / len; /* 0 at the top edge, 1 at the far edge */
                float tanb = tanf(t->slope_deg * (float)(SQ_PI / 180.0));
                const float toe = 0.55f; /* fraction of the length where the slope ends */
                const float fw = 0.1f;   /* half-width of the toe fillet, fraction of the length */
                float top = toe * len * tanb;
                float hs;
                if (u <= toe - fw)
                    hs = top * (1.0f - u / toe);
                else if (u < toe + fw) {
                    float e = toe + fw - u; /* 0 .. 2 fw */
                    hs = (top / toe) * e * e / (4.0f * fw);
                } else
                    hs = 0.0f;
                float ridges = t->relief_m * 0.15f *
                               sq_noise_fbm3(&nz, x * inv, y * inv, 0.7f, t->octaves, 2.0f, 0.5f);
                /* a shallow gully along the fall line to channel the flow; it flattens to 0.3 of
                 * its depth across the same fillet (smoothstep: C1, no step at the toe) */
                float cy = w->origin.y + 0.5f * w->dy * (float)(w->ny - 1);
                float sg = (u - (toe - fw)) / (2.0f * fw);
                sg = sg < 0.0f ? 0.0f : (sg > 1.0f ? 1.0f : sg);
                float gully = -0.25f * t->relief_m * expf(-powf((y - cy) / (0.15f * len), 2.0f)) *
                              (1.0f - 0.7f * sg * sg * (3.0f - 2.0f * sg));
                h += hs + ridges + gully;
                break;
            }
            default: /* hills */
                h += t->relief_m * sq_noise_fbm3(&nz, x * inv, y * inv, 0.37f, t->octaves, 2.0f,
                                                 0.5f);
                break;
            }
            w->heights[(size_t)j * (size_t)w->nx + (size_t)i] = h;
        }
    }
    return true;
}

static void compute_normals(sq_world *w)
{
    float mn = FLT_MAX, mx = -FLT_MAX;
    for (int j = 0; j < w->ny; j++)
        for (int i = 0; i < w->nx; i++) {
            int i0 = i > 0 ? i - 1 : i, i1 = i < w->nx - 1 ? i + 1 : i;
            int j0 = j > 0 ? j - 1 : j, j1 = j < w->ny - 1 ? j + 1 : j;
            const float *H = w->heights;
            float dhdx = (H[(size_t)j * w->nx + i1] - H[(size_t)j * w->nx + i0]) /
                         ((float)(i1 - i0) * w->dx);
            float dhdy = (H[(size_t)j1 * w->nx + i] - H[(size_t)j0 * w->nx + i]) /
                         ((float)(j1 - j0) * w->dy);
            sq_vec3 n = sq_v3_norm(sq_v3(-dhdx, -dhdy, 1.0f));
            float *N = &w->normals[3 * ((size_t)j * w->nx + i)];
            N[0] = n.x;
            N[1] = n.y;
            N[2] = n.z;
            float h = H[(size_t)j * w->nx + i];
            mn = h < mn ? h : mn;
            mx = h > mx ? h : mx;
        }
    w->height_min = mn;
    w->height_max = mx;
}

sq_vec3 sq_sun_direction(int day_of_year, float hour_solar, float latitude_deg)
{
    /* Solar declination (Cooper 1969) and hour angle; azimuth measured from north, clockwise. */
    const double d2r = SQ_PI / 180.0;
    double decl = 23.45 * d2r * sin(2.0 * SQ_PI * (284.0 + day_of_year) / 365.0);
    double hour_angle = (double)(hour_solar - 12.0f) * 15.0 * d2r;
    double lat = (double)latitude_deg * d2r;
    double sin_el = sin(lat) * sin(decl) + cos(lat) * cos(decl) * cos(hour_angle);
    double el = asin(sq_clampd(sin_el, -1.0, 1.0));
    double cos_az = (sin(decl) - sin(el) * sin(lat)) / (cos(el) * cos(lat) + 1e-12);
    double az = acos(sq_clampd(cos_az, -1.0, 1.0));
    if (hour_angle > 0.0) az = 2.0 * SQ_PI - az; /* afternoon: sun in the west */
    /* east = +x, north = +y */
    return sq_v3((float)(cos(el) * sin(az)), (float)(cos(el) * cos(az)), (float)sin(el));
}

/* A compact analytic sky: zenith and horizon radiance from sun elevation and turbidity (a
 * Preetham-flavoured fit: bluer zenith for clear skies, whiter horizon with more haze), and the
 * sun's radiance reddened by the air mass through a Rayleigh+aerosol optical depth. Linear RGB
 * in relative units where a white Lambertian surface under a zenith sun reads about 1. */
static void sky_model(sq_world *w, float turbidity, float irradiance)
{
    float el = asinf(sq_clampf(w->sun_dir.z, -1.0f, 1.0f));
    float mu = sinf(el > 0.02f ? el : 0.02f);
    float airmass = 1.0f / (mu + 0.15f * powf(93.885f - el * 57.29578f, -1.253f));
    const float rayleigh[3] = {0.0058f, 0.0135f, 0.0331f}; /* per unit airmass, 680/550/440nm */
    const float tau_r_scale = 1.0f * 8.0f;                /* scale to optical depth ~0.1 at 550 */
    float aer = 0.02f * turbidity;
    float day = sq_clampf((el + 0.05f) / 0.15f, 0.0f, 1.0f);
    float s = irradiance / 1000.0f;
    float sun[3];
    for (int c = 0; c < 3; c++) {
        float tau = (rayleigh[c] * tau_r_scale + aer) * airmass;
        sun[c] = s * day * expf(-tau);
    }
    w->sun_radiance = sq_v3(sun[0], sun[1], sun[2]);
    float haze = sq_clampf((turbidity - 2.0f) / 8.0f, 0.0f, 1.0f);
    float bright = 0.25f * day * s;
    w->sky_zenith = sq_v3(bright * (0.30f + 0.35f * haze), bright * (0.50f + 0.30f * haze),
                          bright * (0.95f + 0.05f * haze));
    w->sky_horizon = sq_v3(bright * (0.75f + 0.15f * haze), bright * (0.82f + 0.10f * haze),
                           bright * (0.90f + 0.05f * haze));
}

static void *dup_bytes(sq_context *ctx, const void *src, size_t n, int *fail)
{
    void *p = sq_alloc(ctx, n ? n : 1);
    if (!p) *fail = 1;
    else if (n) memcpy(p, src, n);
    return p;
}

/* An owned copy of an area (strings and arrays). */
static sq_result copy_area(sq_context *ctx, const sq_world_area *a, sq_world_area *o)
{
    int fail = 0;
    const size_t nf = (size_t)a->feature_count, nr = (size_t)a->ring_count;
    const size_t np = (size_t)a->ring_start[nr];
    *o = *a;
    o->name = dup_bytes(ctx, a->name, strlen(a->name) + 1, &fail);
    o->source = dup_bytes(ctx, a->source ? a->source : "", strlen(a->source ? a->source : "") + 1,
                          &fail);
    o->feature_value = dup_bytes(ctx, a->feature_value, nf * sizeof(double), &fail);
    o->feature_area_m2 = dup_bytes(ctx, a->feature_area_m2, nf * sizeof(double), &fail);
    o->ring_start = dup_bytes(ctx, a->ring_start, (nr + 1) * sizeof(int), &fail);
    o->ring_feature = dup_bytes(ctx, a->ring_feature, nr * sizeof(int), &fail);
    o->xy_m = dup_bytes(ctx, a->xy_m, 2 * np * sizeof(double), &fail);
    return fail ? sq__fail(ctx, SQ_ERR_OUT_OF_MEMORY, "world", "out of memory for area '%s'",
                           a->name)
                : SQ_OK;
}

static void free_area(sq_context *ctx, sq_world_area *a)
{
    sq_free(ctx, (void *)a->name);
    sq_free(ctx, (void *)a->source);
    sq_free(ctx, (void *)a->feature_value);
    sq_free(ctx, (void *)a->feature_area_m2);
    sq_free(ctx, (void *)a->ring_start);
    sq_free(ctx, (void *)a->ring_feature);
    sq_free(ctx, (void *)a->xy_m);
    memset(a, 0, sizeof *a);
}

const sq_world_area *sq_world_area_find(const sq_world *w, const char *name)
{
    if (!w || !name) return NULL;
    for (int a = 0; a < w->area_count; a++)
        if (w->areas[a].name && strcmp(w->areas[a].name, name) == 0) return &w->areas[a];
    return NULL;
}

int sq_world_area_feature_at(const sq_world_area *a, double x, double y)
{
    if (!a || x < a->bounds[0] || x > a->bounds[2] || y < a->bounds[1] || y > a->bounds[3])
        return -1;
    /* even-odd crossings of a ray toward +x, per feature (its rings are consecutive) */
    const double *p = a->xy_m;
    int inside = 0;
    for (int r = 0; r < a->ring_count; r++) {
        const int b = a->ring_start[r], e = a->ring_start[r + 1];
        for (int k = b, l = e - 1; k < e; l = k++) {
            const double yk = p[2 * k + 1], yl = p[2 * l + 1];
            if ((yk > y) != (yl > y)) {
                const double xc = p[2 * k] + (y - yk) * (p[2 * l] - p[2 * k]) / (yl - yk);
                if (x < xc) inside ^= 1;
            }
        }
        if (r + 1 == a->ring_count || a->ring_feature[r + 1] != a->ring_feature[r]) {
            if (inside) return a->ring_feature[r];
            inside = 0;
        }
    }
    return -1;
}

bool sq_world_void_at(const sq_world *w, float x, float y)
{
    if (!w || !w->terrain_void) return false;
    int i = (int)floorf((x - w->origin.x) / w->dx + 0.5f);
    int j = (int)floorf((y - w->origin.y) / w->dy + 0.5f);
    i = i < 0 ? 0 : (i > w->nx - 1 ? w->nx - 1 : i);
    j = j < 0 ? 0 : (j > w->ny - 1 ? w->ny - 1 : j);
    return w->terrain_void[(size_t)j * (size_t)w->nx + (size_t)i] != 0;
}

sq_result sq_world_create(sq_context *ctx, const sq_world_desc *desc, sq_world **out)
{
    if (!out) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "world", "sq_world_create: out is NULL");
    *out = NULL;
    sq_world_desc d;
    sq_world_desc_resolve(desc, &d);
    sq_result r = validate(ctx, &d);
    if (r != SQ_OK) return r;
    const sq_terrain_desc *t = &d.terrain;
    int nx, ny;
    float dx, dy;
    if (t->kind == SQ_TERRAIN_HEIGHTMAP) {
        nx = t->heightmap_w;
        ny = t->heightmap_h;
        dx = dy = t->metres_per_px;
    } else if (t->kind == SQ_TERRAIN_GRID) {
        nx = t->grid_w;
        ny = t->grid_h;
        dx = t->grid_dx_m;
        dy = t->grid_dy_m;
    } else {
        nx = t->resolution[0];
        ny = t->resolution[1];
        dx = t->size_m[0] / (float)(nx - 1);
        dy = t->size_m[1] / (float)(ny - 1);
    }
    uint64_t bytes = sizeof(sq_world) + (uint64_t)nx * (uint64_t)ny * 4u * sizeof(float);
    r = sq_context_check_memory(ctx, bytes, "terrain heightfield");
    if (r != SQ_OK) return r;
    sq_world *w = (sq_world *)sq_alloc_zero(ctx, sizeof *w);
    if (!w) return SQ_ERR_OUT_OF_MEMORY;
    w->nx = nx;
    w->ny = ny;
    w->dx = dx;
    w->dy = dy;
    w->heights = (float *)sq_alloc(ctx, (size_t)nx * (size_t)ny * sizeof(float));
    w->normals = (float *)sq_alloc(ctx, (size_t)nx * (size_t)ny * 3 * sizeof(float));
    if (!w->heights || !w->normals) {
        sq_world_destroy(ctx, w);
        return SQ_ERR_OUT_OF_MEMORY;
    }
    float ex = dx * (float)(nx - 1), ey = dy * (float)(ny - 1);
    if (t->origin_set)
        w->origin = sq_v3(t->origin_m[0], t->origin_m[1], 0.0f);
    else
        w->origin = sq_v3(-0.5f * ex, -0.5f * ey, 0.0f);
    w->terrain_kind = t->kind;
    w->terrain_material = t->material;
    w->snow_line_m = t->snow_line_m;
    if (d.crs_wkt && d.crs_wkt[0]) {
        size_t len = strlen(d.crs_wkt) + 1;
        w->crs_wkt = (char *)sq_alloc(ctx, len);
        if (!w->crs_wkt) {
            sq_world_destroy(ctx, w);
            return SQ_ERR_OUT_OF_MEMORY;
        }
        memcpy(w->crs_wkt, d.crs_wkt, len);
        w->crs_offset_m[0] = d.crs_offset_m[0];
        w->crs_offset_m[1] = d.crs_offset_m[1];
    }
    if (!generate(ctx, t, w)) {
        sq_world_destroy(ctx, w);
        return sq__fail_cancelled(ctx, "world", "while generating the terrain");
    }
    if (t->vertical_exaggeration != 1.0f) {
        for (size_t c = 0; c < (size_t)w->nx * (size_t)w->ny; c++)
            w->heights[c] *= t->vertical_exaggeration;
    }
    w->vertical_exaggeration = t->vertical_exaggeration;
    compute_normals(w);
    if (t->kind == SQ_TERRAIN_GRID && t->grid_void) {
        w->terrain_void = (uint8_t *)sq_alloc(ctx, (size_t)nx * (size_t)ny);
        if (!w->terrain_void) {
            sq_world_destroy(ctx, w);
            return SQ_ERR_OUT_OF_MEMORY;
        }
        memcpy(w->terrain_void, t->grid_void, (size_t)nx * (size_t)ny);
    }
    for (int a = 0; a < d.area_count; a++) {
        r = copy_area(ctx, &d.areas[a], &w->areas[a]);
        w->area_count = a + 1;
        if (r != SQ_OK) {
            sq_world_destroy(ctx, w);
            return r;
        }
    }
    w->obstacle_count = d.obstacle_count;
    for (int i = 0; i < d.obstacle_count; i++) {
        sq_obstacle o = d.obstacles[i];
        if (!isfinite(o.center_m.z)) o.center_m.z = sq_world_height_at(w, o.center_m.x, o.center_m.y);
        if (o.albedo.x == 0.0f && o.albedo.y == 0.0f && o.albedo.z == 0.0f)
            o.albedo = o.kind == SQ_OBSTACLE_FENCE ? sq_v3(0.35f, 0.25f, 0.15f)
                                                   : sq_v3(0.55f, 0.50f, 0.45f);
        w->obstacles[i] = o;
    }
    sq_vec3 sd = d.sun.direction;
    w->sun_follows_clock = sq_v3_len(sd) == 0.0f && d.sun.utc_set;
    w->sun_utc_start_unix_s = d.sun.utc_start_unix_s;
    w->sun_clock_scale = d.sun.clock_scale;
    w->sun_latitude_deg = d.sun.latitude_deg;
    w->sun_longitude_deg = d.sun.longitude_deg;
    w->sun_north_rotation_deg = d.sun.north_rotation_deg;
    w->sun_irradiance_w_m2 = d.sun.irradiance_w_m2;
    w->sun_from_time = sq_v3_len(sd) == 0.0f;
    if (sq_v3_len(sd) > 0.0f)
        w->sun_dir = sq_v3_norm(sd);
    else
        w->sun_dir = sq_sun_direction(d.sun.day_of_year, d.sun.hour_solar, d.sun.latitude_deg);
    w->turbidity = d.sky.turbidity;
    w->ground_albedo = sq_v3_len(d.sky.ground_albedo) > 0.0f ? d.sky.ground_albedo
                       : t->material == SQ_GROUND_SNOW ? sq_v3(0.85f, 0.87f, 0.9f)
                                                       : sq_v3(0.35f, 0.3f, 0.25f);
    sky_model(w, d.sky.turbidity, d.sun.irradiance_w_m2);
    sq_world_set_time(w, 0.0);
    w->generation = sq__world_next_generation();
    *out = w;
    return SQ_OK;
}

void sq_world_set_time(sq_world *w, double t_s)
{
    if (!w) return;
    w->time_s = t_s;
    if (!w->sun_follows_clock) return;
    const double utc = w->sun_utc_start_unix_s + w->sun_clock_scale * t_s;
    w->sun_position = sq_sun_position_at(utc, w->sun_latitude_deg, w->sun_longitude_deg);
    /* an azimuth from true north is the azimuth plus the rotation from the world's +y */
    sq_sun_position grid = w->sun_position;
    grid.azimuth_deg += (double)w->sun_north_rotation_deg;
    w->sun_dir = sq_sun_position_direction(&grid);
    sky_model(w, w->turbidity, w->sun_irradiance_w_m2);
}

void sq_world_set_sky(sq_world *w, int day_of_year, float hour_solar, float latitude_deg,
                      double clock_scale, float turbidity, float irradiance_w_m2)
{
    if (!w) return;
    w->turbidity = turbidity;
    w->sun_irradiance_w_m2 = irradiance_w_m2;
    if (w->sun_follows_clock) {
        w->sun_latitude_deg = latitude_deg;
        w->sun_clock_scale = clock_scale;
        sq_world_set_time(w, w->time_s); /* the sun where the clock puts it, and the sky */
        return;
    }
    if (w->sun_from_time) w->sun_dir = sq_sun_direction(day_of_year, hour_solar, latitude_deg);
    sky_model(w, turbidity, irradiance_w_m2);
}

void sq__world_frame_copy(sq_world *dst, const sq_world *src)
{
    if (dst && src && dst != src) *dst = *src; /* the pointers inside are shared, not owned */
}

void sq_world_destroy(sq_context *ctx, sq_world *w)
{
    if (!w) return;
    sq__world_meshes_free(ctx, w);
    sq_free(ctx, w->heights);
    sq_free(ctx, w->normals);
    sq_free(ctx, w->crs_wkt);
    sq_free(ctx, w->terrain_void);
    for (int a = 0; a < w->area_count; a++) free_area(ctx, &w->areas[a]);
    sq_free(ctx, w);
}

static void cell_coords(const sq_world *w, float x, float y, int *i, int *j, float *fx, float *fy)
{
    float gx = (x - w->origin.x) / w->dx, gy = (y - w->origin.y) / w->dy;
    /* a NaN coordinate would survive the clamp and index far outside the heights: the
     * callers return NaN for it (sq_world_height_at) or the vertical; this keeps the index in */
    if (!(gx == gx)) gx = 0.0f;
    if (!(gy == gy)) gy = 0.0f;
    gx = sq_clampf(gx, 0.0f, (float)(w->nx - 1));
    gy = sq_clampf(gy, 0.0f, (float)(w->ny - 1));
    int ii = (int)gx, jj = (int)gy;
    if (ii > w->nx - 2) ii = w->nx - 2;
    if (jj > w->ny - 2) jj = w->ny - 2;
    *i = ii;
    *j = jj;
    *fx = gx - (float)ii;
    *fy = gy - (float)jj;
}

float sq_world_height_at(const sq_world *w, float x, float y)
{
    if (isnan(x) || isnan(y)) return NAN;
    int i, j;
    float fx, fy;
    cell_coords(w, x, y, &i, &j, &fx, &fy);
    const float *H = w->heights;
    size_t nx = (size_t)w->nx;
    float h00 = H[j * nx + i], h10 = H[j * nx + i + 1], h01 = H[(j + 1) * nx + i],
          h11 = H[(j + 1) * nx + i + 1];
    return (h00 * (1 - fx) + h10 * fx) * (1 - fy) + (h01 * (1 - fx) + h11 * fx) * fy;
}

sq_vec3 sq_world_normal_at(const sq_world *w, float x, float y)
{
    if (isnan(x) || isnan(y)) return sq_v3(0, 0, 1);
    int i, j;
    float fx, fy;
    cell_coords(w, x, y, &i, &j, &fx, &fy);
    sq_vec3 n = sq_v3(0, 0, 0);
    const float wts[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
    const int di[4] = {0, 1, 0, 1}, dj[4] = {0, 0, 1, 1};
    for (int k = 0; k < 4; k++) {
        const float *N = &w->normals[3 * ((size_t)(j + dj[k]) * w->nx + (size_t)(i + di[k]))];
        n = sq_v3_add(n, sq_v3_scale(sq_v3(N[0], N[1], N[2]), wts[k]));
    }
    return sq_v3_norm(n);
}

/* Position p in the obstacle's local frame (origin at footprint centre, base at z = 0). */
static sq_vec3 to_local(const sq_obstacle *o, sq_vec3 p)
{
    float a = -o->yaw_deg * (float)(SQ_PI / 180.0);
    float dx = p.x - o->center_m.x, dy = p.y - o->center_m.y;
    return sq_v3(dx * cosf(a) - dy * sinf(a), dx * sinf(a) + dy * cosf(a), p.z - o->center_m.z);
}

/* Top of the obstacle at local (x, y) (NaN outside its footprint). */
static float obstacle_top_local(const sq_obstacle *o, float lx, float ly)
{
    float hx = 0.5f * o->size_m.x, hy = 0.5f * o->size_m.y;
    if (fabsf(lx) > hx || fabsf(ly) > hy) return NAN;
    float top = o->size_m.z;
    if (o->kind == SQ_OBSTACLE_HOUSE && o->roof_m > 0.0f)
        top += o->roof_m * (1.0f - fabsf(ly) / hy); /* ridge along local x */
    return top;
}

float sq_world_surface_at(const sq_world *w, float x, float y)
{
    float h = sq_world_height_at(w, x, y);
    for (int i = 0; i < w->obstacle_count; i++) {
        const sq_obstacle *o = &w->obstacles[i];
        sq_vec3 l = to_local(o, sq_v3(x, y, 0.0f));
        float top = obstacle_top_local(o, l.x, l.y);
        if (!isnan(top) && o->center_m.z + top > h) h = o->center_m.z + top;
    }
    float zm;
    if (sq__world_mesh_top_at(w, x, y, &zm) && zm > h) h = zm;
    return h;
}

bool sq_world_solid_at(const sq_world *w, sq_vec3 p)
{
    if (p.z <= sq_world_height_at(w, p.x, p.y)) return true;
    for (int i = 0; i < w->obstacle_count; i++) {
        const sq_obstacle *o = &w->obstacles[i];
        sq_vec3 l = to_local(o, p);
        float top = obstacle_top_local(o, l.x, l.y);
        if (!isnan(top) && l.z >= 0.0f && l.z <= top) return true;
    }
    return sq__world_mesh_solid_at(w, p);
}

sq_result sq_world_voxelise(const sq_world *w, const double origin_m[3], double h_m, const int n[3],
                            int parts, uint8_t *solid)
{
    if (!w || !origin_m || !solid || !n || !(h_m > 0.0) || n[0] <= 0 || n[1] <= 0 || n[2] <= 0 ||
        (parts & ~SQ_SOLID_ALL) != 0)
        return sq__fail(NULL, SQ_ERR_INVALID_ARG, "world",
                        "sq_world_voxelise: needs a world, an origin, h > 0, n > 0, SQ_SOLID_* parts and a mask");
    const int nx = n[0], ny = n[1], nz = n[2];
    float *zc = (float *)malloc((size_t)nz * sizeof *zc);
    uint8_t *col = (uint8_t *)malloc((size_t)nz);
    if (!zc || !col) {
        free(zc);
        free(col);
        return sq__fail(NULL, SQ_ERR_OUT_OF_MEMORY, "world", "sq_world_voxelise: %d cells per column",
                        nz);
    }
    for (int k = 0; k < nz; k++) zc[k] = (float)(origin_m[2] + (k + 0.5) * h_m);
    const size_t plane = (size_t)nx * (size_t)ny;
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            const float x = (float)(origin_m[0] + (i + 0.5) * h_m);
            const float y = (float)(origin_m[1] + (j + 0.5) * h_m);
            const float ht = parts & SQ_SOLID_TERRAIN ? sq_world_height_at(w, x, y) : -INFINITY;
            for (int k = 0; k < nz; k++) col[k] = zc[k] <= ht;
            for (int o = 0; (parts & SQ_SOLID_OBSTACLES) && o < w->obstacle_count; o++) {
                const sq_obstacle *ob = &w->obstacles[o];
                const sq_vec3 l = to_local(ob, sq_v3(x, y, 0.0f));
                const float top = obstacle_top_local(ob, l.x, l.y);
                if (isnan(top)) continue;
                for (int k = 0; k < nz; k++) {
                    const float lz = zc[k] - ob->center_m.z;
                    col[k] |= lz >= 0.0f && lz <= top;
                }
            }
            if (parts & SQ_SOLID_MESHES) sq__world_mesh_solid_column(w, x, y, zc, nz, col);
            for (int k = 0; k < nz; k++) solid[(size_t)i + (size_t)nx * j + plane * k] = col[k];
        }
    free(zc);
    free(col);
    return SQ_OK;
}

void sq_world_bounds(const sq_world *w, sq_vec3 *min_out, sq_vec3 *max_out)
{
    if (min_out) *min_out = sq_v3(w->origin.x, w->origin.y, w->height_min);
    if (max_out)
        *max_out = sq_v3(w->origin.x + w->dx * (float)(w->nx - 1),
                         w->origin.y + w->dy * (float)(w->ny - 1), w->height_max);
}

/* ---- camera ------------------------------------------------------------------------------ */
sq_camera sq_camera_resolve(sq_camera c)
{
    if (sq_v3_len(c.up) == 0.0f) c.up = sq_v3(0, 0, 1);
    if (c.fov_y_deg == 0.0f) c.fov_y_deg = 50.0f;
    if (c.near_m == 0.0f) c.near_m = 0.5f;
    if (c.far_m == 0.0f) c.far_m = 20000.0f;
    return c;
}

static sq_vec3 catmull_rom(sq_vec3 p0, sq_vec3 p1, sq_vec3 p2, sq_vec3 p3, float t)
{
    float t2 = t * t, t3 = t2 * t;
    sq_vec3 r = sq_v3_scale(p1, 2.0f);
    r = sq_v3_add(r, sq_v3_scale(sq_v3_sub(p2, p0), t));
    r = sq_v3_add(r, sq_v3_scale(sq_v3_add(sq_v3_sub(sq_v3_add(sq_v3_scale(p0, 2.0f),
                                                               sq_v3_scale(p2, 4.0f)),
                                                      sq_v3_scale(p1, 5.0f)),
                                           sq_v3_scale(p3, -1.0f)),
                                 t2));
    r = sq_v3_add(r, sq_v3_scale(sq_v3_add(sq_v3_sub(sq_v3_scale(p1, 3.0f), p0),
                                           sq_v3_sub(p3, sq_v3_scale(p2, 3.0f))),
                                 t3));
    return sq_v3_scale(r, 0.5f);
}

sq_camera sq_camera_at(const sq_camera *base, const sq_camera_key *keys, int n, double t)
{
    sq_camera c = sq_camera_resolve(*base);
    if (!keys || n <= 0) return c;
    if (n == 1 || t <= keys[0].time_s) {
        c.position_m = keys[0].position_m;
        c.target_m = keys[0].target_m;
        if (keys[0].fov_y_deg > 0.0f) c.fov_y_deg = keys[0].fov_y_deg;
        return c;
    }
    if (t >= keys[n - 1].time_s) {
        c.position_m = keys[n - 1].position_m;
        c.target_m = keys[n - 1].target_m;
        if (keys[n - 1].fov_y_deg > 0.0f) c.fov_y_deg = keys[n - 1].fov_y_deg;
        return c;
    }
    int k = 0;
    while (k < n - 2 && t > keys[k + 1].time_s) k++;
    const sq_camera_key *a = &keys[k > 0 ? k - 1 : 0], *b = &keys[k], *e = &keys[k + 1],
                        *f = &keys[k + 2 < n ? k + 2 : n - 1];
    double span = e->time_s - b->time_s;
    float u = span > 0.0 ? (float)((t - b->time_s) / span) : 0.0f;
    c.position_m = catmull_rom(a->position_m, b->position_m, e->position_m, f->position_m, u);
    c.target_m = catmull_rom(a->target_m, b->target_m, e->target_m, f->target_m, u);
    float fb = b->fov_y_deg > 0.0f ? b->fov_y_deg : c.fov_y_deg;
    float fe = e->fov_y_deg > 0.0f ? e->fov_y_deg : c.fov_y_deg;
    c.fov_y_deg = fb + (fe - fb) * u;
    return c;
}

sq_mat4 sq_camera_view(const sq_camera *c)
{
    sq_camera r = sq_camera_resolve(*c);
    return sq_m4_look_at(r.position_m, r.target_m, r.up);
}

sq_mat4 sq_camera_proj(const sq_camera *c, float aspect)
{
    sq_camera r = sq_camera_resolve(*c);
    return sq_m4_perspective(r.fov_y_deg * (float)(SQ_PI / 180.0), aspect, r.near_m, r.far_m);
}

/* ---- read access (the layout is private: src/world/world_struct.h) ------------------------ */
void sq_world_get_terrain(const sq_world *w, sq_world_terrain *out)
{
    memset(out, 0, sizeof *out);
    if (!w) return;
    out->nx = w->nx;
    out->ny = w->ny;
    out->dx = w->dx;
    out->dy = w->dy;
    out->origin = w->origin;
    out->heights = w->heights;
    out->normals = w->normals;
    out->void_mask = w->terrain_void;
    out->height_min = w->height_min;
    out->height_max = w->height_max;
    out->kind = w->terrain_kind;
    out->material = w->terrain_material;
    out->snow_line_m = w->snow_line_m;
    out->vertical_exaggeration = w->vertical_exaggeration > 0.0f ? w->vertical_exaggeration : 1.0f;
}

void sq_world_get_light(const sq_world *w, sq_world_light *out)
{
    memset(out, 0, sizeof *out);
    if (!w) return;
    out->sun_dir = w->sun_dir;
    out->sun_radiance = w->sun_radiance;
    out->sky_zenith = w->sky_zenith;
    out->sky_horizon = w->sky_horizon;
    out->ground_albedo = w->ground_albedo;
    out->turbidity = w->turbidity;
    out->time_s = w->time_s;
    out->sun_follows_clock = w->sun_follows_clock;
    out->sun_position = w->sun_position;
}

int sq_world_obstacle_count(const sq_world *w) { return w ? w->obstacle_count : 0; }
const sq_obstacle *sq_world_obstacles(const sq_world *w) { return w ? w->obstacles : NULL; }
int sq_world_area_count(const sq_world *w) { return w ? w->area_count : 0; }

const sq_world_area *sq_world_area_at(const sq_world *w, int i)
{
    return w && i >= 0 && i < w->area_count ? &w->areas[i] : NULL;
}

const char *sq_world_crs(const sq_world *w, double offset_m[2])
{
    if (offset_m) {
        offset_m[0] = w ? w->crs_offset_m[0] : 0.0;
        offset_m[1] = w ? w->crs_offset_m[1] : 0.0;
    }
    return w ? w->crs_wkt : NULL;
}

int sq_world_mesh_instances(const sq_world *w, const sq_mesh *const **meshes, int *mesh_count,
                            const sq_mesh_instance **instances)
{
    if (meshes) *meshes = w ? w->meshes : NULL;
    if (mesh_count) *mesh_count = w ? w->mesh_count : 0;
    if (instances) *instances = w ? w->mesh_instances : NULL;
    return w ? w->mesh_instance_count : 0;
}

int64_t sq_world_mesh_face_count(const sq_world *w) { return w ? w->mesh_faces : 0; }

uint64_t sq_world_generation(const sq_world *w) { return w ? w->generation : 0; }

uint64_t sq__world_next_generation(void)
{
    static _Atomic uint64_t last = 0;
    return atomic_fetch_add(&last, 1) + 1;
}
