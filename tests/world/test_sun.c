/* test_sun.c — the sun's position for a UTC instant and a place (src/world/sun.c) against
 * published values: the worked example of NREL's Solar Position Algorithm (Reda & Andreas 2004,
 * NREL/TP-560-34302, Table A5.1 and §A.1), the equation of time's annual extremes and zeros from
 * the astronomical almanac, the declination at the 2021 June solstice, and the civil-time
 * conversion. */
#include <math.h>

#include "sq_test.h"
#include "squall/world.h"

SQ_LABEL(physics)

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
