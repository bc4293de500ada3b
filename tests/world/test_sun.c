/* test_sun.c — the sun's position for a UTC instant and a place (src/world/sun.c) against
 * published values: the worked example of NREL's Solar Position Algorithm (Reda & Andreas 2004,
 * NREL/TP-560-34302, Table A5.1 and §A.1), the equation of time's annual extremes and zeros from
 * the astronomical almanac, the declination at the 2021 June solstice, and the civil-time
 * conversion. */
#include <math.h>

#include "sq_test.h"
#include "squall/world.h"

SQ_LABEL(physics)

static inline sq_world_light light_of(const sq_world *w)
{
    sq_world_light l;
    sq_world_get_light(w, &l);
    return l;
}

static inline sq_world_terrain terrain_of(const sq_world *w)
{
    sq_world_terrain t;
    sq_world_get_terrain(w, &t);
    return t;
}

SQ_TEST(civil_time_to_unix)
{
    SQ_CHECK_NEAR(sq_unix_time(1970, 1, 1, 0, 0, 0.0), 0.0, 0.0);
    /* 2000-03-01: across the leap day of a year divisible by 400 */
    SQ_CHECK_NEAR(sq_unix_time(2000, 3, 1, 0, 0, 0.0), 951868800.0, 0.0);
    SQ_CHECK_NEAR(sq_unix_time(2005, 9, 21, 3, 0, 0.0), 1127271600.0, 0.0);
    /* month 13 rolls over into January of the next year */
    SQ_CHECK_NEAR(sq_unix_time(2004, 13, 1, 0, 0, 0.0), sq_unix_time(2005, 1, 1, 0, 0, 0.0), 0.0);
    SQ_CHECK_NEAR(sq_unix_time(1969, 12, 31, 23, 59, 59.0), -1.0, 0.0);
}

SQ_TEST(nrel_spa_example)
{
    /* 2003-10-17 12:30:30 local time at UTC-7 = 19:30:30 UTC, 39.742476 N, 105.1786 W.
     * SPA: topocentric zenith 50.11162 deg (refracted at 820 hPa, 11 C), azimuth 194.34024 deg,
     * geocentric declination -9.31434 deg, equation of time 14.641503 min. Our refraction uses a
     * standard atmosphere (1010 hPa: 0.004 deg more at this elevation) and no parallax
     * (0.002 deg): 0.02 deg covers both and the algorithm's own 0.01 deg. */
    const double t = sq_unix_time(2003, 10, 17, 19, 30, 30.0);
    sq_sun_position p = sq_sun_position_at(t, 39.742476, -105.1786);
    SQ_CHECK_NEAR(90.0 - p.elevation_deg, 50.11162, 0.02);
    SQ_CHECK_NEAR(p.azimuth_deg, 194.34024, 0.02);
    SQ_CHECK_NEAR(p.declination_deg, -9.31434, 0.01);
    SQ_CHECK_NEAR(p.equation_of_time_min, 14.641503, 0.05);
    /* the geometric zenith lies above the refracted one by the refraction (~0.02 deg here) */
    SQ_CHECK(p.zenith_deg > 90.0 - p.elevation_deg);
    SQ_CHECK_NEAR(p.zenith_deg - (90.0 - p.elevation_deg), 0.020, 0.003);
    /* the direction vector agrees with the angles: south-south-west, 40 deg up */
    sq_vec3 d = sq_sun_position_direction(&p);
    SQ_CHECK_NEAR(sqrt((double)(d.x * d.x + d.y * d.y + d.z * d.z)), 1.0, 1e-6);
    SQ_CHECK_NEAR(asin((double)d.z) * 180.0 / M_PI, p.elevation_deg, 1e-4);
    SQ_CHECK(d.y < 0.0f && d.x < 0.0f);
}

SQ_TEST(equation_of_time_extremes_and_zeros)
{
    /* Almanac: minimum about -14.2 min around 11-12 February, maximum about +16.4 min around
     * 3 November; zeros near 15 April, 13 June, 1 September and 25 December. */
    const double feb11 = sq_unix_time(2023, 2, 11, 12, 0, 0.0);
    const double nov3 = sq_unix_time(2023, 11, 3, 12, 0, 0.0);
    SQ_CHECK_NEAR(sq_sun_position_at(feb11, 0, 0).equation_of_time_min, -14.2, 0.15);
    SQ_CHECK_NEAR(sq_sun_position_at(nov3, 0, 0).equation_of_time_min, 16.4, 0.15);
    const int zero_days[4][2] = {{4, 15}, {6, 13}, {9, 1}, {12, 25}};
    for (int i = 0; i < 4; i++) {
        const double t = sq_unix_time(2023, zero_days[i][0], zero_days[i][1], 12, 0, 0.0);
        /* the equation of time changes by < 0.5 min per day near its zeros */
        SQ_CHECK_NEAR(sq_sun_position_at(t, 0, 0).equation_of_time_min, 0.0, 0.6);
    }
}

SQ_TEST(solstice_declination_and_solar_noon)
{
    /* June solstice 2021-06-21 03:32 UTC: declination = obliquity = 23.4364 deg */
    const double t = sq_unix_time(2021, 6, 21, 3, 32, 0.0);
    sq_sun_position p = sq_sun_position_at(t, 45.0, 0.0);
    SQ_CHECK_NEAR(p.declination_deg, 23.4364, 0.005);
    /* At true solar noon the sun is due south (from 45 N) at 90 - 45 + declination. True solar
     * time = UTC + lon/15 h + EoT: at 90 E solar noon is near 06:00 UTC, shifted by the EoT. */
    const double noon_utc = sq_unix_time(2021, 6, 21, 6, 0, 0.0);
    const double eot = sq_sun_position_at(noon_utc, 45.0, 90.0).equation_of_time_min;
    sq_sun_position q = sq_sun_position_at(noon_utc - 60.0 * eot, 45.0, 90.0);
    SQ_CHECK_NEAR(q.true_solar_time_h, 12.0, 1e-3);
    SQ_CHECK_NEAR(q.hour_angle_deg, 0.0, 0.02);
    SQ_CHECK_NEAR(q.azimuth_deg, 180.0, 0.05);
    SQ_CHECK_NEAR(q.zenith_deg, 45.0 - q.declination_deg, 0.01);
    /* one hour later the sun has moved west (azimuth > 180) by 15 deg of hour angle */
    sq_sun_position r = sq_sun_position_at(noon_utc - 60.0 * eot + 3600.0, 45.0, 90.0);
    SQ_CHECK_NEAR(r.hour_angle_deg, 15.0, 0.02);
    SQ_CHECK(r.azimuth_deg > 190.0);
    /* at midnight it is below the horizon */
    sq_sun_position m = sq_sun_position_at(noon_utc + 12.0 * 3600.0, 45.0, 90.0);
    SQ_CHECK(m.elevation_deg < -15.0);
}

SQ_TEST(coarse_sun_direction_agrees_roughly)
{
    /* The date-free sq_sun_direction (Cooper) agrees with the precise position to ~1 degree
     * when given the true solar time: day 172, 15 h solar, 40 N. */
    const double eot0 = sq_sun_position_at(sq_unix_time(2023, 6, 21, 15, 0, 0.0), 40, 0)
                            .equation_of_time_min;
    sq_sun_position p = sq_sun_position_at(sq_unix_time(2023, 6, 21, 15, 0, 0.0) - 60.0 * eot0,
                                           40.0, 0.0);
    sq_vec3 a = sq_sun_position_direction(&p);
    sq_vec3 b = sq_sun_direction(172, 15.0f, 40.0f);
    const double c = (double)(a.x * b.x + a.y * b.y + a.z * b.z);
    SQ_CHECK(acos(fmin(1.0, c)) * 180.0 / M_PI < 1.0);
}

SQ_TEST(world_sun_follows_the_clock)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_FLAT;
    d.sun.utc_set = true;
    d.sun.utc_start_unix_s = sq_unix_time(2005, 9, 21, 0, 0, 0.0);
    d.sun.latitude_deg = 30.0f;
    d.sun.longitude_deg = 87.0f;
    d.sun.north_rotation_deg = 10.0f;
    d.sun.clock_scale = 3600.0f; /* one scene second = one hour */
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    if (!w) return;
    /* at 00 UTC the sun rises at 87 E: elevation ~0, in the east (turned by 10 deg) */
    sq_sun_position p0 = sq_sun_position_at(d.sun.utc_start_unix_s, 30.0, 87.0);
    SQ_CHECK_NEAR(light_of(w).sun_position.elevation_deg, p0.elevation_deg, 1e-9);
    SQ_CHECK_NEAR(asin((double)light_of(w).sun_dir.z) * 180.0 / M_PI, p0.elevation_deg, 1e-3);
    const double az0 = atan2((double)light_of(w).sun_dir.x, (double)light_of(w).sun_dir.y) * 180.0 / M_PI;
    SQ_CHECK_NEAR(az0, p0.azimuth_deg + 10.0, 1e-3);
    const float dawn = light_of(w).sun_radiance.y;
    /* 6 scene seconds later = 06 UTC = 11:55 solar: high in the south, brighter light and sky */
    sq_world_set_time(w, 6.0);
    sq_sun_position p6 = sq_sun_position_at(d.sun.utc_start_unix_s + 6 * 3600.0, 30.0, 87.0);
    SQ_CHECK_NEAR(asin((double)light_of(w).sun_dir.z) * 180.0 / M_PI, p6.elevation_deg, 1e-3);
    SQ_CHECK(p6.elevation_deg > 55.0);
    SQ_CHECK(light_of(w).sun_radiance.y > dawn + 0.3f);
    SQ_CHECK_NEAR(light_of(w).time_s, 6.0, 0.0);
    sq_world_destroy(ctx, w);
    /* a given direction wins over the clock and does not move */
    d.sun.direction = sq_v3(0.0f, 0.0f, 1.0f);
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    if (w) {
        sq_world_set_time(w, 6.0);
        SQ_CHECK_NEAR(light_of(w).sun_dir.z, 1.0, 1e-6);
        SQ_CHECK(!light_of(w).sun_follows_clock);
        sq_world_destroy(ctx, w);
    }
    d.sun.latitude_deg = 95.0f;
    d.sun.direction = sq_v3(0.0f, 0.0f, 0.0f);
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "|latitude| <= 90");
    sq_context_destroy(ctx);
}

SQ_TEST(vertical_exaggeration_scales_heights_and_slopes)
{
    sq_context *ctx = NULL;
    sq_context_create(NULL, &ctx);
    float h[3 * 3] = {100, 110, 120, 100, 110, 120, 100, 110, 120}; /* 10 m per 10 m toward +x */
    sq_world_desc d = {0};
    d.terrain.kind = SQ_TERRAIN_GRID;
    d.terrain.grid_heights_m = h;
    d.terrain.grid_w = d.terrain.grid_h = 3;
    d.terrain.grid_dx_m = d.terrain.grid_dy_m = 10.0f;
    d.terrain.vertical_exaggeration = 4.0f;
    sq_world *w = NULL;
    SQ_CHECK_OK(sq_world_create(ctx, &d, &w));
    if (w) {
        SQ_CHECK_NEAR(terrain_of(w).height_min, 400.0, 1e-3);
        SQ_CHECK_NEAR(terrain_of(w).height_max, 480.0, 1e-3);
        SQ_CHECK_NEAR(terrain_of(w).vertical_exaggeration, 4.0, 0.0);
        /* slope 4: normal (-4, 0, 1)/sqrt(17) */
        sq_vec3 n = sq_world_normal_at(w, 0.0f, 0.0f);
        SQ_CHECK_NEAR(n.x, -4.0 / sqrt(17.0), 1e-5);
        sq_world_destroy(ctx, w);
    }
    d.terrain.vertical_exaggeration = -1.0f;
    SQ_CHECK_ERR(sq_world_create(ctx, &d, &w), SQ_ERR_INVALID_ARG, "vertical_exaggeration = -1");
    sq_context_destroy(ctx);
}
