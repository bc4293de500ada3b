/* snowcover_desc.c — defaults, the named levels and the rules of the snow-cover desc (SPEC §6).
 * Ranges of single keys live in the parameter table (snowcover_plugin.c); the rules here relate
 * several keys. Messages name the key (sq_snowcover_desc.<key>; the scene shows
 * layers.<name>.<key>), the value and the rule. */
#include <math.h>
#include <string.h>

#include "snowcover_internal.h"

#define DEF(f, v)                                                                              \
    do {                                                                                       \
        if ((f) == 0) (f) = (v);                                                               \
    } while (0)

/* The named levels: hours of snowfall at a rate before t = 0 (depth = rate t ρw / ρs at the
 * default 100 kg/m³: 2, 10 and 30 cm; S2 Figs 2.11–2.14 show these four looks). */
static const struct {
    double rate_mmh, prior_h;
} levels[] = {{0, 0}, {0, 0}, {1.0, 2.0}, {2.5, 4.0}, {5.0, 6.0}};

sq_result sq_snowcover_desc_resolve(const sq_snowcover_desc *in, sq_snowcover_desc *out)
{
    sq_snowcover_desc d;
    memset(&d, 0, sizeof d);
    if (in) d = *in;
    if (d.level > SQ_SNOWCOVER_CUSTOM && d.level <= SQ_SNOWCOVER_HEAVY) {
        d.snowfall_mmh = levels[d.level].rate_mmh;
        d.prior_h = levels[d.level].prior_h;
    }
    DEF(d.density_kgm3, 100.0);
    DEF(d.speedup, 1.0);
    DEF(d.detail_m, 250.0);
    DEF(d.map_size, 1024);
    DEF(d.taps, 4);
    DEF(d.tap_radius, 1.0);
    DEF(d.bias_m, 0.05);
    DEF(d.noise, 0.3);
    DEF(d.noise_scale_m, 2.0);
    DEF(d.shell_blend, 0.5);
    DEF(d.sparkle, 0.5);
    DEF(d.albedo, 0.9);
    DEF(d.shininess, 24.0);
    DEF(d.layers, 4);
    DEF(d.near_m, 1.5);
    DEF(d.reach_m, 80.0);
    DEF(d.size_mrad, 6.0);
    DEF(d.layer_growth, 1.3);
    if (d.atten[0] == 0 && d.atten[1] == 0 && d.atten[2] == 0) d.atten[1] = 1.0;
    DEF(d.fall_speed_mps, 1.0);
    if (out) *out = d;
    return SQ_OK;
}

#define BAD(...) return sq__fail(ctx, SQ_ERR_INVALID_ARG, "snowcover", __VA_ARGS__)

static bool nonneg(double v) { return isfinite(v) && v >= 0; }

sq_result sq_snowcover_validate(sq_context *ctx, const sq_snowcover_desc *in, const sq_world *w)
{
    (void)w;
    sq_snowcover_desc d;
    sq_snowcover_desc_resolve(in, &d);
    const char *P = "sq_snowcover_desc.";
    if (d.level < SQ_SNOWCOVER_CUSTOM || d.level > SQ_SNOWCOVER_HEAVY)
        BAD("%ssnowfall.level = %d; must be custom, none, light, medium or heavy (0..4)", P,
            d.level);
    if (!nonneg(d.snowfall_mmh))
        BAD("%ssnowfall.rate_mmh = %g; must be >= 0 mm/h water equivalent", P, d.snowfall_mmh);
    if (!(isfinite(d.density_kgm3) && d.density_kgm3 >= 10 && d.density_kgm3 <= 917))
        BAD("%ssnowfall.density_kgm3 = %g; must be in [10, 917] kg/m3 (fresh snow 50-150, "
            "ice 917)", P, d.density_kgm3);
    if (!nonneg(d.prior_h)) BAD("%ssnowfall.prior_h = %g; must be >= 0 h", P, d.prior_h);
    const double prior_m = d.snowfall_mmh * 1e-3 * d.prior_h * SQ_SNOWCOVER_RHO_WATER /
                           d.density_kgm3;
    if (!(prior_m <= SQ_SNOWCOVER_MAX_DEPTH_M))
        BAD("%ssnowfall.prior_h = %g h at %ssnowfall.rate_mmh = %g mm/h and %g kg/m3 lays %.4g m "
            "of snow before t = 0; the deepest snow cover ever measured is %.2f m (Mount Ibuki, "
            "1927)", P, d.prior_h, P, d.snowfall_mmh, d.density_kgm3, prior_m,
            SQ_SNOWCOVER_MAX_DEPTH_M);
    if (!(d.taps == 1 || d.taps == 4 || d.taps == 5 || d.taps == 9))
        BAD("%socclusion.taps = %d; must be 1, 4 (S2), 5 or 9", P, d.taps);
    if (d.map_size < 64 || d.map_size > 8192)
        BAD("%socclusion.map_size = %d; must be in [64, 8192] texels", P, d.map_size);
    if (d.flakes > 0) {
        if (d.layers < 3 || d.layers > 5)
            BAD("%sflakes.layers = %d; S2 uses 3 to 5 depth layers", P, d.layers);
        if (!(d.near_m > 0 && d.near_m < d.reach_m))
            BAD("%sflakes.near_m = %g; must be > 0 and below flakes.reach_m = %g m", P, d.near_m,
                d.reach_m);
        const double A = (double)d.atten[0], B = (double)d.atten[1], C = (double)d.atten[2];
        if (!(nonneg(A) && nonneg(B) && nonneg(C)))
            BAD("%sflakes.attenuation = %g %g %g; A, B and C of S2 eq 2.4 must be >= 0", P, A, B, C);
        if (!(A + B * d.near_m + C * d.near_m * d.near_m > 0))
            BAD("%sflakes.attenuation = %g %g %g; A + B D + C D^2 must be > 0 from flakes.near_m", P,
                A, B, C);
    }
    return SQ_OK;
}

void sq__snowcover_grid(const sq_snowcover_desc *d, const sq_world *w, int *nx, int *ny,
                        double origin[2], double *cell)
{
    sq_vec3 lo = sq_v3(-256, -256, 0), hi = sq_v3(256, 256, 0);
    if (w) sq_world_bounds(w, &lo, &hi);
    const double ex = (double)(hi.x - lo.x), ey = (double)(hi.y - lo.y);
    *cell = d->cell_m > 0 ? d->cell_m : fmax(1.0, fmax(ex, ey) / 512.0);
    *nx = (int)ceil(ex / *cell);
    *ny = (int)ceil(ey / *cell);
    if (*nx < 1) *nx = 1;
    if (*ny < 1) *ny = 1;
    origin[0] = (double)lo.x;
    origin[1] = (double)lo.y;
}

uint64_t sq_snowcover_memory_bytes(const sq_snowcover_desc *in, const sq_world *w)
{
    sq_snowcover_desc d;
    sq_snowcover_desc_resolve(in, &d);
    int nx, ny;
    double origin[2], cell;
    sq__snowcover_grid(&d, w, &nx, &ny, origin, &cell);
    const uint64_t flakes = (uint64_t)(d.flakes > 0 ? d.flakes : 0);
    return (uint64_t)nx * (uint64_t)ny * sizeof(float) +
           flakes * SQ__SNOWCOVER_FLAKE_FLOATS * sizeof(float) + sizeof(sq_snowcover);
}
